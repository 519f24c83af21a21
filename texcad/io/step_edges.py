"""Edges joined end to end for texcad's STEP (issue 28: a corner patch's STEP).

Where a patch's outline crosses the texture grid (a flattened top and its fillets,
``texcad.brep.bands``), its tiles and walls step along the outline cell by cell:
each tile meets its wall in an edge per tile side, each wall meets the part's face
in a straight section edge per step, and tiles of a staircase meet along edges cut at
each other's corners. In the STEP every edge weighs about 600 bytes of topology
(``EDGE_CURVE``, two ``ORIENTED_EDGE``, a ``SURFACE_CURVE`` with two ``PCURVE``\\ s,
a ``VERTEX_POINT``) besides its curves; on the mitre of ``bench_step.py --sizes``
1324 of its 2366 vertices joined two edges between the same two faces.

:func:`joined_edges` writes each such run as one edge: its 3-D curve and its two
pcurves the degree-1 polylines through the run's kinks (all three are straight
between them: lines, degree-1 B-splines, or texcad's straight raised or padded
iso lines), so the solid is the same point for point. The run's vertices between
go.

OCCT's plain volume rule (``BRepGProp_Gauss``, :mod:`texcad.brep.gprop`) takes one
Gauss rule of ``n = min(max(IntegrationOrder(pcurve), VIntegrationOrder(surface)),
61)`` points over each edge, and at each point ``n`` points across ``u`` from the
face's lowest ``u``. Over a run of pieces its integrand ``F(u(t), v(t)) v'(t)``
jumps where a pcurve turns and kinks where it crosses a knot of its surface, so the
joined edge is parametrised for the rule: its breaks (every kink of its curves and
every knot a pcurve crosses where its ``v`` changes) at the partial sums of the
Gauss weights (:func:`texcad.brep.gprop.gauss_knots`), each piece holding nodes
whose weights add up to its length, and the pcurve on a face whose ``v`` changes
along it padded to :data:`~texcad.brep.gprop.PAD_SPANS` spans (``n = 61``, the
rule texcad places its tiles' knots for). A run keeps at most :data:`MOST_PIECES`
pieces (each then holds two nodes or more).

:func:`lined_edges` then gives each edge along which neither face's rule
integrates (its pcurves keep their ``v``, or lie at the face's lowest ``u``: the
rule adds nothing there whatever the parameter) the running coordinate of its pcurve
on one face as its parameter, where that pcurve is an iso line: that pcurve, and the
other where it runs as fast, is a ``LINE`` instead of a broken line through a point
per break (on the mitre of ``bench_step.py --sizes`` 280 such pcurves, 127 kB).
"""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from ..util.runs import runs_within

__all__ = ["joined_edges", "lined_edges", "MOST_PIECES"]

#: Most straight pieces (between kinks and crossed knots) of a joined edge: with
#: :data:`~texcad.brep.gprop.GAUSS_POINTS` (61) nodes, two or more a piece.
MOST_PIECES = 24
#: Most pieces of a joined edge along which a tile placed for
#: ``texcad.io.step_tiles.THIN_ORDER`` (8) points integrates: its straight pcurves on
#: two pieces at most keep OCCT's rule at ``max(8, 4 pieces) = 8`` points.
FEW_PIECES = 2
#: Decimals (mm) of a joined edge's parameters (:func:`_placed`), its knots in the STEP.
PARAM_DECIMALS = 6
#: Relative tolerance of "straight" (a curve linear in its parameter between two
#: breaks) and of two points being the same break.
_EPS = 1e-9


def _breaks(curve, first: float, last: float) -> np.ndarray | None:
    """Parameters from ``first`` to ``last`` between which the 3-D or 2-D ``curve``
    is linear in its parameter (a line; a degree-1 B-spline's knots; a straight
    B-spline of higher degree whose parameter runs evenly: texcad's raised iso
    lines), or None for any other curve."""
    from OCP.Geom import Geom_BSplineCurve, Geom_Line
    from OCP.Geom2d import Geom2d_BSplineCurve, Geom2d_Line

    if isinstance(curve, (Geom_Line, Geom2d_Line)):
        return np.array([first, last])
    if not isinstance(curve, (Geom_BSplineCurve, Geom2d_BSplineCurve)) or curve.IsPeriodic() or curve.IsRational():
        return None
    if curve.Degree() == 1:
        k = np.array([curve.Knot(i) for i in range(1, curve.NbKnots() + 1)])  # per knot (a few to 17)
        eps = _EPS * (1.0 + abs(first) + abs(last))
        return np.r_[first, k[(k > first + eps) & (k < last - eps)], last]
    t = np.linspace(first, last, 2 * curve.NbPoles() + 1)
    p = np.array([curve.Value(a).Coord() for a in t.tolist()])  # per sample (about 20: an 11-pole raised line)
    line = p[0] + (p[-1] - p[0]) * ((t - first) / (last - first))[:, None]
    if np.abs(p - line).max() > _EPS * (1.0 + np.abs(p).max()):
        return None
    return np.array([first, last])


def polyline3d(p: np.ndarray, t: np.ndarray):
    """The degree-1 ``Geom_BSplineCurve`` through ``p`` ``(k, 3)`` mm at ``t`` ``(k,)``."""
    from OCP.Geom import Geom_BSplineCurve
    from OCP.TColgp import TColgp_Array1OfPnt
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.gp import gp_Pnt

    poles, knots, mults = TColgp_Array1OfPnt(1, len(t)), TColStd_Array1OfReal(1, len(t)), TColStd_Array1OfInteger(1, len(t))
    for i, (a, q) in enumerate(zip(t.tolist(), p.tolist()), 1):  # per kept point (a few)
        poles.SetValue(i, gp_Pnt(*q))
        knots.SetValue(i, a)
        mults.SetValue(i, 2 if i in (1, len(t)) else 1)
    return Geom_BSplineCurve(poles, knots, mults, 1)


def _sampled(edge, faces: list):
    """``(t (k,), p (k, 3) mm, [q (k, 2)] per face)``: the edge's 3-D curve and
    pcurves at every break of any of them (:func:`_breaks`), or None."""
    from OCP.BRep import BRep_Tool

    first, last = BRep_Tool.Range_s(edge)
    curves = [BRep_Tool.Curve_s(edge, 0.0, 0.0)] + [BRep_Tool.CurveOnSurface_s(edge, f, 0.0, 0.0) for f in faces]
    if any(c is None for c in curves) or last - first <= _EPS:
        return None
    ts = [_breaks(c, first, last) for c in curves]
    if any(t is None for t in ts):
        return None
    t = np.unique(np.concatenate(ts))
    t = t[np.r_[True, np.diff(t) > _EPS * (1.0 + abs(first) + abs(last))]]
    t[-1] = last
    vals = [np.array([c.Value(a).Coord() for a in t.tolist()]) for c in curves]  # per break (a few)
    return t, vals[0], vals[1:]


def _seamed(shape, fmap) -> set:
    """Indices in ``fmap`` of the faces of ``shape`` that have a seam (an edge used
    twice by the face: a drilled hole's wall): their edges are not joined (joined
    along a hole's rim, the wall of the demo plate's 8 mm hole re-read invalid)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopoDS import TopoDS

    from ..brep.occt import explore

    out = set()
    for f in explore(shape, TopAbs_FACE):  # one per face
        face = TopoDS.Face_s(f)
        if any(BRep_Tool.IsClosed_s(TopoDS.Edge_s(e), face) for e in explore(face, TopAbs_EDGE)):
            out.add(fmap.FindIndex(face))
    return out


def shapes_in(shapes) -> list:
    """The shapes of a ``TopTools_ListOfShape`` (an edge's faces, a vertex's edges), in
    order. OCP's Python iteration over such a list takes about 0.1 ms a shape (the
    demo plate's thousands of edges: seconds); its head and tail, or a copy emptied
    from the head, take microseconds."""
    from OCP.TopTools import TopTools_ListOfShape

    n = shapes.Size()
    if n == 0:
        return []
    if n <= 2:
        return [shapes.First(), shapes.Last()] if n == 2 else [shapes.First()]
    rest, out = TopTools_ListOfShape(), []
    rest.Assign(shapes)
    while not rest.IsEmpty():  # one per shape of the list (a vertex's edges)
        out.append(rest.First())
        rest.RemoveFirst()
    return out


def _linked(shape) -> list:
    """Runs ``([(edge, forward), ...], [face, face])`` of two or
    more edges end to end between the same two faces, each vertex between them
    used by those two edges only (a closed loop of them is left one edge short);
    ``forward``: the edge's parameter runs along the run."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_VERTEX
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape

    fmap = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_FACE, fmap)
    ef = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ef)
    ve = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_VERTEX, TopAbs_EDGE, ve)
    pair, ends = {}, {}
    seamed = _seamed(shape, fmap)
    for k in range(1, ef.Extent() + 1):  # one per edge
        e = TopoDS.Edge_s(ef.FindKey(k).Oriented(TopAbs_FORWARD))
        fs = [TopoDS.Face_s(f) for f in shapes_in(ef.FindFromIndex(k))]
        if (len(fs) != 2 or fs[0].IsSame(fs[1]) or BRep_Tool.Degenerated_s(e) or not e.Location().IsIdentity()
                or any(BRep_Tool.IsClosed_s(e, f) or not f.Location().IsIdentity() or fmap.FindIndex(f) in seamed for f in fs)):  # fmt: skip
            continue
        a, z = ve.FindIndex(TopExp.FirstVertex_s(e)), ve.FindIndex(TopExp.LastVertex_s(e))
        if a != z:
            pair[k], ends[k] = tuple(sorted(fmap.FindIndex(f) for f in fs)), (a, z)

    def step(k: int, fwd: bool):  # the edge past k's end (its direction), if linked there
        v = ends[k][1 if fwd else 0]
        es = [ef.FindIndex(x) for x in shapes_in(ve.FindFromIndex(v))]
        if len(es) != 2 or es[0] == es[1]:
            return None
        j = es[1] if es[0] == k else es[0]
        if j not in pair or pair[j] != pair[k]:
            return None
        return j, ends[j][0] == v

    chains, seen = [], set()
    for k in sorted(pair):  # one per edge (each chain once)
        if k in seen:
            continue
        start, fwd, back = k, True, step(k, False)
        while back is not None and back[0] != k:  # to the run's first edge (one that starts where it ends runs against it)
            start, fwd = back[0], not back[1]
            back = step(start, not fwd)
        run, at = [(start, fwd)], step(start, fwd)
        while at is not None and at[0] != start:  # one per edge of the run
            run.append(at)
            at = step(*at)
        seen.update(j for j, _ in run)
        if at is not None:  # a closed loop: one edge stays apart
            run = run[:-1]
        if len(run) > 1:
            faces = [TopoDS.Face_s(fmap.FindKey(i)) for i in pair[start]]
            chains.append(([(TopoDS.Edge_s(ef.FindKey(j).Oriented(TopAbs_FORWARD)), f) for j, f in run], faces))
    return chains


def _joined(chain: list, faces: list):
    """``(s (n,), p (n, 3), [q (n, 2)] per face, cuts (edges + 1,))``: the run's
    curves sampled at their breaks end to end along it (:func:`_sampled`), ``s`` a
    running parameter, ``cuts`` the sample index of each edge's start (and the
    end); None where an edge is not straight between breaks or the ends miss."""
    out, at, cuts = None, 0.0, [0]
    for e, fwd in chain:  # one per edge of the run (a few to tens)
        got = _sampled(e, faces)
        if got is None:
            return None
        t, p, qs = got
        if not fwd:
            t, p, qs = t[-1] + t[0] - t[::-1], p[::-1], [q[::-1] for q in qs]
        s = t - t[0] + at
        if out is not None:
            if np.abs(out[1][-1] - p[0]).max() > 1e-6 or any(np.abs(a[-1] - q[0]).max() > 1e-7 for a, q in zip(out[2], qs)):
                return None
            s, p, qs = s[1:], p[1:], [q[1:] for q in qs]
            out = (np.r_[out[0], s], np.r_[out[1], p], [np.r_[a, q] for a, q in zip(out[2], qs)])
        else:
            out = (s, p, qs)
        at = float(s[-1])
        cuts.append(len(out[0]) - 1)
    return (*out, np.array(cuts))


def _crossed(s: np.ndarray, p: np.ndarray, qs: list, cuts: np.ndarray, knots: list):
    """The samples of :func:`_joined` with one more wherever a pcurve crosses a knot
    line of its face (``knots``: ``(u, v)`` per face, or None) between two of them
    (all three curves are linear in ``s`` there: the new points interpolated), and
    ``cuts`` moved to match."""
    extra = []
    for q, kn in zip(qs, knots):  # one per face (two)
        if kn is None:
            continue
        for axis, k in enumerate(kn):  # u knots, then v knots
            a, z = q[:-1, axis, None], q[1:, axis, None]
            eps = _EPS * (1.0 + np.abs(k).max())
            inside = (k[None, :] > np.minimum(a, z) + eps) & (k[None, :] < np.maximum(a, z) - eps)
            seg, j = np.nonzero(inside)
            w = (k[j] - a[seg, 0]) / (z[seg, 0] - a[seg, 0])
            extra.append(s[seg] + w * (s[seg + 1] - s[seg]))
    if not extra or not sum(len(x) for x in extra):
        return s, p, qs, cuts
    new = np.union1d(s, np.concatenate(extra))
    at = lambda x: np.stack([np.interp(new, s, x[:, i]) for i in range(x.shape[1])], axis=1)  # noqa: E731
    return new, at(p), [at(q) for q in qs], np.searchsorted(new, s[cuts])


def _needed(s: np.ndarray, p: np.ndarray, qs: list, knots: list) -> np.ndarray:
    """``(n,)`` bool: the samples a joined edge keeps as breaks: its ends, each
    where a curve turns or its parameter changes pace (the three curves' velocities
    not in one ratio), and each where a pcurve whose ``v`` changes beside it crosses
    a knot line of its surface (``knots``: ``(u, v)`` per face, or None)."""
    ds = np.diff(s)[:, None]
    vel = np.concatenate([np.diff(p, axis=0) / ds] + [np.diff(q, axis=0) / ds for q in qs], axis=1)  # (n - 1, 7)
    a, b = vel[:-1], vel[1:]
    lam = np.linalg.norm(a, axis=1) / np.maximum(np.linalg.norm(b, axis=1), 1e-300)
    turn = np.linalg.norm(a - lam[:, None] * b, axis=1) > 1e-7 * np.maximum(np.linalg.norm(a, axis=1), 1e-300)
    keep = np.r_[True, turn, True]
    for q, kn in zip(qs, knots):  # one per face (two)
        if kn is None:
            continue
        d = np.diff(q, axis=0)
        moving = np.abs(d) > _EPS * (1.0 + np.abs(q).max())  # (n - 1, 2): u, v change along each piece
        live = moving[:, 1]  # pieces along which the rule's integrand is not zero
        for axis, k in enumerate(kn):  # u knots, then v knots
            if k is None or len(k) < 3:
                continue
            on = np.abs(q[:, axis, None] - k[None, 1:-1]).min(axis=1) <= _EPS * (1.0 + np.abs(k).max())
            cross = moving[:, axis] & live
            keep |= on & (np.r_[False, cross] | np.r_[cross, False])
    return keep


def _placed(p: np.ndarray, big: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """``(T (m + 1,), sub (big + 1,))``: the joined edge's parameters at the ends of
    its ``m`` pieces (points ``p`` ``(m + 1, 3)`` mm) and at the ``big >= m`` spans
    of a padded pcurve (the extra spans shared out by the pieces' lengths), from 0 to
    the run's length in mm: the partial sums of the weights of the ``points``-point
    Gauss rule (:func:`texcad.brep.gprop.gauss_knots`; even spans past it), ``T``
    among them; by length where ``points`` is 0 (no face's rule integrates along it)."""
    from ..brep.gprop import gauss_knots

    length = np.linalg.norm(np.diff(p, axis=0), axis=1)
    m, total = len(length), float(max(length.sum(), 1e-6))
    if points == 0:
        T = np.r_[0.0, np.cumsum(np.maximum(length, 1e-6 * total / m))]
        return T, T
    share = (big - m) * length / max(length.sum(), 1e-300)
    each = np.floor(share).astype(np.int64)
    each[np.argsort(-(share - each), kind="stable")[: big - m - int(each.sum())]] += 1
    sub = gauss_knots(0.0, total, big, points)
    short = np.round(sub, PARAM_DECIMALS)  # (the knots written shorter: 1e-6 mm moves no Gauss node past a break)
    if (np.diff(short) > 0).all():
        sub = short
    return sub[np.r_[0, np.cumsum(1 + each)]], sub


def _v_order(face, knots) -> int:
    """OCCT's ``BRepGProp_Face::VIntegrationOrder`` of ``face`` as written
    (``knots``: a tile's ``(u, v)``, or None): ``max(8, 2 max(4, (degree + 1)
    spans))`` along ``v`` of a B-spline, 8 on a plane, 18 on other surfaces."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_BSplineSurface, GeomAbs_Plane

    if knots is not None:
        return max(8, 2 * max(4, 2 * (len(knots[1]) - 1)))
    sf = BRepAdaptor_Surface(face, False)
    if sf.GetType() == GeomAbs_Plane:
        return 8
    if sf.GetType() == GeomAbs_BSplineSurface:
        bs = sf.BSpline()
        return max(8, 2 * max(4, (bs.VDegree() + 1) * (bs.NbVKnots() - 1)))
    return 18


def _rule(faces: list, qs: list, knots: list, m: int) -> tuple[int, int]:
    """``(spans, points)``: the spans of the pcurves on the faces whose ``v`` changes
    along a joined edge of ``m`` pieces (:func:`_rises`), and the Gauss points OCCT's
    plain rule then takes along it (0: on neither face). 61 points (16 spans at
    least, unless the tile's own 16 ``v`` spans give 61) where a tile's ``u`` knots
    lie inside the range the rule integrates across (placed for 61 points,
    :mod:`texcad.brep.gprop`), or the two faces would take
    different rules; else the one face's own rule on ``m`` spans."""
    from ..brep.gprop import GAUSS_POINTS, PAD_SPANS

    orders = []
    for f, q, kn in zip(faces, qs, knots):  # its two faces
        if not _rises(q, f):
            continue
        if kn is not None and ((kn[0] > kn[0][0]) & (kn[0] < q[:, 0].max())).any():  # (16 v spans give 61 already)
            return (m if _v_order(f, kn) >= GAUSS_POINTS else max(m, PAD_SPANS)), GAUSS_POINTS
        orders.append(min(max(4 * m, _v_order(f, kn)), GAUSS_POINTS))
    if not orders:
        return m, 0
    if len(set(orders)) > 1:
        return max(m, PAD_SPANS), GAUSS_POINTS
    return m, orders[0]


def _along(T: np.ndarray, sub: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The points ``q`` ``(m + 1, 2)`` at the parameters ``T`` and, linearly between
    them, at the parameters ``sub`` (a padded pcurve's): ``(len(sub), 2)``."""
    return np.stack([np.interp(sub, T, q[:, 0]), np.interp(sub, T, q[:, 1])], axis=1)


def _rises(q: np.ndarray, face) -> bool:
    """Does OCCT's plain rule integrate across ``u`` along the pcurve ``q`` ``(k,
    2)`` on ``face``: does its ``v`` change, and does it leave the face's lowest
    ``u`` (from which the rule integrates: nothing along a side there)?"""
    from OCP.BRepTools import BRepTools

    eps = _EPS * (1.0 + np.abs(q).max())
    if np.abs(np.diff(q[:, 1])).max(initial=0.0) <= eps:
        return False
    return bool(q[:, 0].max() > BRepTools.UVBounds_s(face)[0] + eps)


def _new_edge(b, chain: list, faces: list, s, p, qs, knots: list, few: int = 0):
    """One edge for the run ``chain`` between ``faces`` (samples ``s``, ``p``, ``qs``
    of :func:`_joined`): polylines through its breaks (:func:`_needed`), placed for
    OCCT's plain rule (:func:`_placed`), the pcurve on a face whose ``v`` changes
    along it padded (``few``: the points a tile's rule takes across ``u`` where its
    knots are placed for fewer than 61); its vertices the run's ends, its direction
    the run's."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS_Edge

    from ..brep.gprop import polyline_pcurve

    keep = _needed(s, p, qs, knots)
    s, p, qs = s[keep], p[keep], [q[keep] for q in qs]
    rising = [_rises(q, f) for q, f in zip(qs, faces)]
    big, points = (len(s) - 1, few) if few else _rule(faces, qs, knots, len(s) - 1)
    T, sub = _placed(p, big, points)
    tol = max(BRep_Tool.Tolerance_s(e) for e, _ in chain)
    ne = TopoDS_Edge()
    b.MakeEdge(ne, polyline3d(p, T), tol)
    (e0, f0), (e1, f1) = chain[0], chain[-1]
    v0 = TopExp.FirstVertex_s(e0) if f0 else TopExp.LastVertex_s(e0)
    v1 = TopExp.LastVertex_s(e1) if f1 else TopExp.FirstVertex_s(e1)
    b.Add(ne, v0.Oriented(TopAbs_FORWARD))
    b.Add(ne, v1.Oriented(TopAbs_REVERSED))
    for f, q, up in zip(faces, qs, rising):  # its two faces
        pc = polyline_pcurve(_along(T, sub, q), sub, pad=False) if up else polyline_pcurve(q, T, pad=False)
        b.UpdateEdge(ne, pc, f, tol)
    b.Range(ne, float(T[0]), float(T[-1]))
    return ne


def joined_edges(shape, knots_of: Callable[[Any], "tuple | None"]):
    """``shape`` with each run of edges end to end between the same two faces
    (:func:`_linked`) written as one edge (module docstring), in runs of at most
    :data:`MOST_PIECES` pieces; ``knots_of(face)``: ``(u, v, wall, points)``, a
    texture tile's knots as written, whether it is a patch's wall strip and the Gauss
    points its ``u`` knots are placed for; or None. Runs whose curves are not all straight
    between breaks stay as they are."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools_ReShape

    from ..brep.gprop import GAUSS_POINTS

    chains = _linked(shape)
    b, reshape, done = BRep_Builder(), BRepTools_ReShape(), False
    for chain, faces in chains:  # one per run (hundreds)
        got = _joined(chain, faces)
        if got is None:
            continue
        s, p, qs, cuts = got
        kn, rise = [knots_of(f) for f in faces], [_rises(q, f) for q, f in zip(qs, faces)]
        if any(k is not None and k[2] and r for k, r in zip(kn, rise)):
            continue  # a wall's rule runs across its u knots at the grid's cells, placed for no rule: left as it was
        few = [k[3] for k, r in zip(kn, rise) if k is not None and r and k[3] < GAUSS_POINTS]
        if few and sum(rise) > 1:
            continue  # a tile whose u knots are placed for fewer points, and another rule along the run
        kn = [None if k is None or not r else k[:2] for k, r in zip(kn, rise)]  # where its rule integrates along the run
        s, p, qs, cuts = _crossed(s, p, qs, cuts, kn)
        keep = _needed(s, p, qs, kn)
        pieces = [max(1, int(keep[a + 1 : z + 1].sum())) for a, z in zip(cuts[:-1], cuts[1:])]
        for run in runs_within(pieces, FEW_PIECES if few else MOST_PIECES):  # one per joined edge
            if len(run) < 2:
                continue
            a, z = cuts[run[0]], cuts[run[-1] + 1] + 1
            part = [chain[i] for i in run]
            ne = _new_edge(b, part, faces, s[a:z], p[a:z], [q[a:z] for q in qs], kn, few[0] if few else 0)
            e0, f0 = part[0]
            reshape.Replace(e0, ne if f0 else ne.Reversed())
            for e, _ in part[1:]:  # one per edge the run drops
                reshape.Remove(e)
            done = True
    return reshape.Apply(shape) if done else shape


def _iso_param(q: np.ndarray) -> tuple | None:
    """``(T, w)`` where the samples ``q`` ``(k, 2)`` of a pcurve lie on one iso line
    of its surface and run along it one way: the running coordinate as an
    increasing parameter ``T`` (``k,``; negated where the coordinate falls) and the
    unit direction ``w`` (2,) with ``q = q[0] + (T - T[0]) w``; else None."""
    eps = _EPS * (1.0 + np.abs(q).max())
    for axis in (0, 1):  # u runs (iso-v), then v runs (iso-u)
        d = np.diff(q[:, axis])
        if np.abs(q[:, 1 - axis] - q[0, 1 - axis]).max() > eps or len(d) == 0:
            continue
        sign = 1.0 if (d > eps).all() else -1.0 if (d < -eps).all() else 0.0
        if sign:
            w = np.zeros(2)
            w[axis] = sign
            return sign * q[:, axis], w
    return None


def _line2d(q: np.ndarray, T: np.ndarray):
    """``q`` ``(k, 2)`` at the increasing ``T`` as a ``Geom2d_Line`` (``Value(T) = P +
    T D``, ``D`` a unit vector) where the samples are that line, else None."""
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d

    w = (q[-1] - q[0]) / (T[-1] - T[0])
    eps = _EPS * (1.0 + np.abs(q).max())
    if abs(np.hypot(*w) - 1.0) > _EPS or np.abs(q - (q[0] + (T - T[0])[:, None] * w)).max() > eps:
        return None
    p = q[0] - T[0] * w
    return Geom2d_Line(gp_Pnt2d(float(p[0]), float(p[1])), gp_Dir2d(float(w[0]), float(w[1])))


def _lined(b, edge, faces: list):
    """The edge ``edge`` between ``faces`` parametrised by the running coordinate of
    its pcurve on one face where that pcurve is an iso line (:func:`_iso_param`), so
    that it is a ``LINE`` there (and on the other face where it runs as fast), or
    None where no face gains a line or a face's volume rule integrates along it."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_Line
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS_Edge

    from ..brep.gprop import polyline_pcurve

    lines = sum(isinstance(BRep_Tool.CurveOnSurface_s(edge, f, 0.0, 0.0), Geom2d_Line) for f in faces)
    if lines == len(faces):
        return None  # lines already (most edges: nothing to sample)
    got = _sampled(edge, faces)
    if got is None or any(_rises(q, f) for q, f in zip(got[2], faces)):
        return None
    t, p, qs = got
    best = None
    for q in qs:  # one per face: its running coordinate as the parameter
        iso = _iso_param(q)
        if iso is not None:
            made = [_line2d(x, iso[0]) for x in qs]
            if best is None or sum(m is not None for m in made) > sum(m is not None for m in best[1]):
                best = (iso[0], made)
    if best is None or sum(m is not None for m in best[1]) <= lines:
        return None
    T, made = best
    keep = _needed(T, p, qs, [None] * len(qs))
    tol = BRep_Tool.Tolerance_s(edge)
    ne = TopoDS_Edge()
    b.MakeEdge(ne, polyline3d(p[keep], T[keep]), tol)
    b.Add(ne, TopExp.FirstVertex_s(edge).Oriented(TopAbs_FORWARD))
    b.Add(ne, TopExp.LastVertex_s(edge).Oriented(TopAbs_REVERSED))
    for f, q, m in zip(faces, qs, made):  # its two faces
        b.UpdateEdge(ne, m if m is not None else polyline_pcurve(q[keep], T[keep], pad=False), f, tol)
    b.Range(ne, float(T[0]), float(T[-1]))
    return ne


def lined_edges(shape):
    """``shape`` with each edge between two faces along which neither face's plain
    volume rule integrates (:func:`_rises`: the pcurve keeps its ``v``, or lies at
    the face's lowest ``u``; the rule adds nothing along it, whatever its parameter)
    parametrised by its pcurve's running coordinate on one face where that pcurve is
    an iso line (:func:`_lined`): that pcurve, and the other where it runs as fast
    (two tiles of one grid), is then a ``LINE`` instead of a broken line through a
    point per break (a joined run placed by its length, a side mapped to a tile's
    placed knots). The 3-D curve keeps its points (and one where the parameter's pace
    changes: a tile's pole there). Seams, degenerate edges and curves that are not
    straight between breaks (:func:`_breaks`) stay as they are."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepTools import BRepTools_ReShape
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    ef = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ef)
    b, reshape, done = BRep_Builder(), BRepTools_ReShape(), False
    for k in range(1, ef.Extent() + 1):  # one per edge
        e = TopoDS.Edge_s(ef.FindKey(k).Oriented(TopAbs_FORWARD))
        fs = [TopoDS.Face_s(f) for f in shapes_in(ef.FindFromIndex(k))]
        if (len(fs) != 2 or fs[0].IsSame(fs[1]) or BRep_Tool.Degenerated_s(e) or not e.Location().IsIdentity()
                or any(BRep_Tool.IsClosed_s(e, f) or not f.Location().IsIdentity() for f in fs)):  # fmt: skip
            continue
        ne = _lined(b, e, fs)
        if ne is not None:
            reshape.Replace(e, ne)
            done = True
    return reshape.Apply(shape) if done else shape
