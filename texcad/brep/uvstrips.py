"""A face textured on its own ``(u, v)`` as strips OCCT's plain volume integration
gets right (issue 28; see :mod:`texcad.brep.gprop`).

One degree-1 face over the whole ``(u, v)`` rectangle (:func:`texcad.brep.uvfaces.uv_textured_solid`)
has about 100 knot spans around a cone or a torus, and ``BRepGProp``'s plain rule puts
61 Gauss points across it: 0.3-1.2 % off. Here the face is cut along iso-``u`` grid
lines into strips of at most :data:`~texcad.brep.solids.TILE` spans, each its own
degree-1 surface (the same poles) with its knots placed by
:func:`texcad.brep.gprop.run_knots` in both directions. OCCT integrates a face along
the edges whose ``v`` changes, from the face's lowest ``u``: here only the strips' own
edges along ``v`` (the cuts, and a closed face's lifted seam), which run on the
strips' knots and are cut where the ``v`` runs end; edges along ``u`` (the face's
boundary circles, poles, a torus's seam) add nothing, so they are only split at the
strip corners (their neighbours, such as a cone's caps, get the same pieces). An open
face's side along ``v`` at its largest ``u`` keeps its own parameter (its knots are
not placed), so the strip along it is one span wide: what OCCT integrates along it
is one cell's width.

Faces whose outline is not the iso-line rectangle (any edge not along ``u`` or ``v``)
get None: the caller keeps one face.
"""

from __future__ import annotations

import io
from collections import OrderedDict

import numpy as np

from ..errors import GeometryError
from .gprop import polyline_pcurve, run_knots
from .occt import explore
from .solids import TILE, TOLERANCE, _remember_tile, _tile_bounds, _tile_text

__all__ = ["strip_faces", "strip_origin"]

#: ``id(strip surface) -> (surface, original face, grid (Nv, Nu, 3) mm, u, v)``: the
#: whole textured face a strip was cut from, on the face's own parameters (CAD
#: operations put the texture again from it: :func:`texcad.brep.uvfaces.uv_face_pairs`).
_ORIGIN: "OrderedDict[int, tuple]" = OrderedDict()
#: Strips remembered at most.
ORIGIN_MEMORY = 4096


def strip_origin(surface):
    """``(original face, grid (Nv, Nu, 3) mm, u (Nu,), v (Nv,))`` of the whole face a
    strip's surface was cut from (:func:`strip_faces`), or None."""
    got = _ORIGIN.get(id(surface))
    return None if got is None or got[0] is not surface else got[1:]


def _grid_face(u: np.ndarray, v: np.ndarray, top: np.ndarray):
    """A natural-bounds degree-1 face through ``top`` (u along columns of the pole
    grid) carrying the grid's triangulation; returns ``(surface, triangulation)``."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS, TopoDS_Iterator, TopoDS_Shape

    grid = np.ascontiguousarray(top.transpose(1, 0, 2))  # (Nv, Nu, 3): rows along v, columns along u
    comp = TopoDS_Shape()
    BRepTools.Read_s(comp, io.BytesIO(_tile_text([grid], [u], [v], True).encode("ascii")), BRep_Builder())
    it = TopoDS_Iterator(comp)
    if comp.IsNull() or not it.More():
        raise GeometryError("OCCT could not read the textured face's surface")
    f = TopoDS.Face_s(it.Value())
    surf = BRep_Tool.Surface_s(f)
    _remember_tile(surf, grid, u, v)
    return surf, BRep_Tool.Triangulation_s(f, TopLoc_Location())


def _used_twice(face, edge) -> bool:
    """A seam of ``face``: ``edge`` is in its wires twice (both ways). An edge may
    carry two pcurves on a periodic surface (``BRep_Tool::IsClosed``) and be used once:
    a cut exactly along the old seam leaves such an edge on the face's border."""
    from OCP.TopAbs import TopAbs_EDGE

    return sum(1 for e in explore(face, TopAbs_EDGE) if e.IsSame(edge)) > 1


def _classify(edge, fwd, u: np.ndarray, v: np.ndarray):
    """``(side, t0, t1, p0, p1)``: ``side`` one of ``"v0"``, ``"v1"`` (along ``u`` on
    the rectangle's bottom or top), ``"u0"``, ``"u1"`` (along ``v``), the pcurve of
    this use of ``edge`` from ``p0`` at ``t0`` to ``p1`` at ``t1``, straight in its
    parameter; None for any other edge."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d

    c2 = BRepAdaptor_Curve2d(edge, fwd)
    t0, t1 = c2.FirstParameter(), c2.LastParameter()
    p0, p1 = np.array(c2.Value(t0).Coord()), np.array(c2.Value(t1).Coord())
    pm = np.array(c2.Value(0.5 * (t0 + t1)).Coord())
    span = np.array([u[-1] - u[0], v[-1] - v[0]])
    if np.abs(pm - 0.5 * (p0 + p1)).max() > 1e-9 * span.max():
        return None
    tol = 1e-7 * span
    for axis, name, ends in ((1, "v", (v[0], v[-1])), (0, "u", (u[0], u[-1]))):  # along u (v fixed), along v
        if abs(p0[axis] - p1[axis]) < tol[axis]:
            for side, val in zip((name + "0", name + "1"), ends):  # the two sides
                if abs(p0[axis] - val) < tol[axis] and abs(p1[axis] - val) < tol[axis]:
                    return side, t0, t1, p0, p1
    return None


def _params(t0, t1, p0, p1, axis: int, cuts: np.ndarray) -> np.ndarray:
    """The parameters of a straight pcurve (``p0`` at ``t0`` to ``p1`` at ``t1``)
    where its coordinate ``axis`` passes ``cuts`` (inside it only), in order of t."""
    a, z = sorted((p0[axis], p1[axis]))
    c = cuts[(cuts > a + 1e-12 * (z - a)) & (cuts < z - 1e-12 * (z - a))]
    t = t0 + (c - p0[axis]) / (p1[axis] - p0[axis]) * (t1 - t0)
    return np.sort(t)


def _remapped(t0, t1, p0, p1, u, v, uk, vk):
    """Pcurve (on the strips' knots ``uk``, ``vk``) of a straight pcurve on the face's
    own ``(u, v)``: a broken line with a corner where it crosses a grid line."""
    axis = 0 if abs(p1[0] - p0[0]) > abs(p1[1] - p0[1]) else 1
    ts = np.concatenate([[t0], _params(t0, t1, p0, p1, axis, u if axis == 0 else v), [t1]])
    ts = ts[np.r_[True, np.diff(ts) > 1e-9 * abs(t1 - t0)]]  # a grid line a hair from a point: no span OCCT refuses
    ts[-1] = t1  # the end kept where a grid line a hair before it took its place
    q = p0[None, :] + ((ts - t0) / (t1 - t0))[:, None] * (p1 - p0)[None, :]
    pts = np.stack([np.interp(q[:, 0], u, uk), np.interp(q[:, 1], v, vk)], axis=-1)
    return polyline_pcurve(pts, ts)


def _piece(b, edge, va, vz, ta: float, tz: float):
    """A piece of ``edge`` (its curves, pcurves and tolerance) from ``va`` at ``ta`` to
    ``vz`` at ``tz`` (``ta < tz``)."""
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS

    p = TopoDS.Edge_s(edge.Oriented(TopAbs_FORWARD).EmptyCopied())
    b.Add(p, va.Oriented(TopAbs_FORWARD))
    b.Add(p, vz.Oriented(TopAbs_REVERSED))
    b.Range(p, float(ta), float(tz))
    return p


def _vertex(b, point: np.ndarray, tol: float):
    from OCP.gp import gp_Pnt
    from OCP.TopoDS import TopoDS_Vertex

    vx = TopoDS_Vertex()
    b.MakeVertex(vx, gp_Pnt(*map(float, point)), tol)
    return vx


def strip_faces(face, u: np.ndarray, v: np.ndarray, top: np.ndarray, closed_u: bool, tolerance):
    """The strips replacing ``face`` (see the module): ``(strips, splits)``, the
    strips oriented as ``face`` and ``splits`` ``[(edge, pieces)]`` the face's edges
    along ``u`` cut at the strip corners (their other faces must take the pieces:
    :func:`texcad.brep.uvfaces.uv_textured_solid`); None where this does not apply
    (the caller keeps one face). ``u (Nu,)``, ``v (Nv,)``, ``top (Nu, Nv, 3)`` mm as
    :func:`texcad.brep.uvfaces._poles` gives them; ``tolerance(edge)`` the tolerance
    (mm) an edge of the face needs on the new surface."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_VERTEX
    from OCP.TopoDS import TopoDS, TopoDS_Face

    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    ku, kv = len(u) - 1, len(v) - 1
    ub, vb = _tile_bounds(ku, TILE), _tile_bounds(kv, TILE)
    if not closed_u and ku > 1:  # an open face: its own side at u1 (not placed) borders a strip one span wide
        ub = np.concatenate([_tile_bounds(ku - 1, TILE), [ku]])
    uk, vk = run_knots(u, ub), run_knots(v, vb)
    uses = []
    for e in explore(fwd, TopAbs_EDGE):  # one per use of an edge in the face's wires
        got = _classify(TopoDS.Edge_s(e), fwd, u, v)
        if got is None:
            return None
        uses.append((TopoDS.Edge_s(e), *got))
    sides = {s: [x for x in uses if x[1] == s] for s in ("v0", "v1", "u0", "u1")}
    seam = closed_u and len(sides["u0"]) == 1 and len(sides["u1"]) == 1 and sides["u0"][0][0].IsSame(sides["u1"][0][0])
    if closed_u != seam or not all(sides.values()) or any(len(sides[s]) != 1 for s in ("u0", "u1")):
        return None
    b = BRep_Builder()
    surfs = [_grid_face(uk[a : z + 1], vk, top[a : z + 1]) for a, z in zip(ub[:-1], ub[1:])]  # one per strip
    strips = []
    for surf, tri in surfs:  # one per strip
        f = TopoDS_Face()
        b.MakeFace(f, surf, TOLERANCE)
        b.UpdateFace(f, tri)
        strips.append(f)
    # Corner vertices along each iso-u cut (and the seam): bottom and top from the face's edges.
    cut_u = u[ub[1:-1]]
    bottom, top_side, splits = {}, {}, []
    done: dict = {}
    tols: dict = {}
    for side, store in (("v0", bottom), ("v1", top_side)):  # the face's edges along u, cut at the strip corners
        for e, _, t0, t1, p0, p1 in sides[side]:
            key = next((k for k in done if k.IsSame(e)), None)
            if key is None:
                key, done[e] = e, _cut_edge(b, e, _params(t0, t1, p0, p1, 0, cut_u), tolerance(e), tols)
                if not _used_twice(fwd, e) and not BRep_Tool.Degenerated_s(e):  # uncut, a copy: the neighbour takes it too
                    splits.append((e, done[e][0]))
            pieces, params, verts = done[key]
            for i, p in enumerate(pieces):  # each piece on the strip it borders
                ta, tz = params[i], params[i + 1]
                qa = p0 + (ta - t0) / (t1 - t0) * (p1 - p0)
                qz = p0 + (tz - t0) / (t1 - t0) * (p1 - p0)
                k = int(np.clip(np.searchsorted(u[ub], 0.5 * (qa[0] + qz[0])) - 1, 0, len(strips) - 1))
                store.setdefault(k, []).append((p, ta, tz, qa, qz, e.Orientation()))
    for e, *_ in sides["u0"] + sides["u1"] if not seam else []:  # an open face's own sides along v
        tols[e] = tol = tolerance(e)
        for x in explore(e, TopAbs_VERTEX):
            b.UpdateVertex(TopoDS.Vertex_s(x), max(tol, BRep_Tool.Tolerance_s(TopoDS.Vertex_s(x))))
    out = _assemble(b, (u, v, uk, vk, ub, vb, top), strips, surfs, sides, (bottom, top_side), seam, tols)
    if out is None:
        return None
    for (surf, _), f in zip(surfs, strips):  # where each strip came from (CAD operations)
        _ORIGIN[id(surf)] = (surf, face, np.ascontiguousarray(top.transpose(1, 0, 2)), u, v)
        while len(_ORIGIN) > ORIGIN_MEMORY:
            _ORIGIN.popitem(last=False)
    rev = face.Orientation() == TopAbs_REVERSED
    return [TopoDS.Face_s(f.Oriented(TopAbs_REVERSED)) if rev else f for f in out], splits


def _cut_edge(b, e, ts: np.ndarray, tol: float, tols: dict) -> tuple:
    """``(pieces, params, vertices)``: ``e`` cut at its parameters ``ts`` (new vertices
    there; a pole's degenerate edge keeps its one vertex), each piece and vertex at
    least ``tol`` mm (``tols`` gets the pieces')."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    fe = TopoDS.Edge_s(e.Oriented(TopAbs_FORWARD))
    ends = [TopExp.FirstVertex_s(fe), TopExp.LastVertex_s(fe)]
    fa, fz = BRep_Tool.Range_s(e)
    if BRep_Tool.Degenerated_s(e):
        mids = [ends[0]] * len(ts)
    else:
        c3 = BRepAdaptor_Curve(e)
        mids = [_vertex(b, np.array(c3.Value(float(t)).Coord()), tol) for t in ts.tolist()]  # per strip corner
    params, verts = [fa, *ts.tolist(), fz], [ends[0], *mids, ends[1]]
    pieces = [_piece(b, e, verts[i], verts[i + 1], params[i], params[i + 1]) for i in range(len(params) - 1)]
    for p in pieces:  # their tolerance on the textured surface
        b.UpdateEdge(p, tol)
        tols[p] = tol
    for x in mids + ends:
        b.UpdateVertex(x, max(tol, BRep_Tool.Tolerance_s(x)))
    return pieces, params, verts


def _corner(pieces: list, at: float, u: np.ndarray):
    """The vertex of the edge pieces ``[(piece, ta, tz, qa, qz, _)]`` at ``u = at``."""
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    tol = 1e-9 * (abs(u[-1] - u[0]) + 1.0)
    for p, _, _, qa, qz, _ in pieces:  # a few pieces
        fwd = TopoDS.Edge_s(p.Oriented(TopAbs_FORWARD))
        if abs(qa[0] - at) < tol:
            return TopExp.FirstVertex_s(fwd)
        if abs(qz[0] - at) < tol:
            return TopExp.LastVertex_s(fwd)
    return None


def _along_v(b, curve, va, vz, vk: np.ndarray, vb: np.ndarray, top_col: np.ndarray):
    """Edges on the 3-D curve ``curve`` (an iso-u line of the strips, parameter
    ``vk``) from ``va`` to ``vz``, cut where the v runs ``vb`` end."""
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Edge

    verts = [va] + [_vertex(b, top_col[i], TOLERANCE) for i in vb[1:-1].tolist()] + [vz]
    out = []
    for i, (a, z) in enumerate(zip(vb[:-1].tolist(), vb[1:].tolist())):  # one per v run
        e = TopoDS_Edge()
        b.MakeEdge(e, curve, TOLERANCE)
        b.Add(e, verts[i].Oriented(TopAbs_FORWARD))
        b.Add(e, verts[i + 1].Oriented(TopAbs_REVERSED))
        b.Range(e, float(vk[a]), float(vk[z]))
        out.append((e, a, z))
    return out


def _line_at(uval: float, vk: np.ndarray, a: int, z: int):
    """The straight pcurve ``u = uval`` over the rows ``a .. z`` (knots ``vk``)."""
    rows = vk[a : z + 1]
    return polyline_pcurve(np.stack([np.full(len(rows), uval), rows], axis=-1), rows)


def _rim_uses(items: list, up: bool, u, v, uk, vk) -> list:
    """``[(piece, orientation, pcurve)]`` of a strip's pieces of the face's bottom
    (``up``: run towards higher u) or top edges (towards lower u), in wire order."""
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED

    out = []
    for p, ta, tz, qa, qz, _ in sorted(items, key=lambda x: min(x[3][0], x[4][0]), reverse=not up):  # a few pieces
        o = TopAbs_FORWARD if (qz[0] > qa[0]) == up else TopAbs_REVERSED
        out.append((p, o, _remapped(ta, tz, qa, qz, u, v, uk, vk)))
    return out


def _side_uses(k: int, S: int, cuts: dict, sides: dict, knots: tuple, right: bool) -> list:
    """``[(edge, orientation, pcurve)]`` of strip ``k``'s right (upwards) or left
    (downwards) side: a cut, the lifted seam or the face's own side edge."""
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED

    u, v, uk, vk, ub = knots
    s = k + 1 if right else k
    if s in cuts:
        uval = float(uk[ub[s]])
        items = [(e, TopAbs_FORWARD if right else TopAbs_REVERSED, _line_at(uval, vk, a, z)) for e, a, z in cuts[s]]
        return items if right else items[::-1]
    e, _, t0, t1, p0, p1 = sides["u1" if right else "u0"][0]
    o = TopAbs_FORWARD if (p1[1] > p0[1]) == right else TopAbs_REVERSED
    return [(e, o, _remapped(t0, t1, p0, p1, u, v, uk, vk))]


def _assemble(b, knots: tuple, strips: list, surfs: list, sides: dict, rims: tuple, seam: bool, tols: dict):
    """Wire each strip (counter-clockwise about ``S_u x S_v``): its pieces of the
    face's bottom (``v0``) and top (``v1``) edges, the cuts along v between strips
    (the lifted seam on a closed face, else the face's own ``u0``/``u1`` sides), each
    with its pcurves on the strip; returns the strips or None."""
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Wire

    u, v, uk, vk, ub, vb, top = knots
    bottom, top_side = rims
    S = len(strips)
    cuts = {}  # strip boundary index -> [(edge, a, z)] along v, upwards
    for s in range(1 if not seam else 0, S):  # one per iso-u line between strips (and the seam at 0)
        near = [k for k in (s - 1, s) if 0 <= k < S]
        vb0 = next((x for k in near if (x := _corner(bottom.get(k, []), u[ub[s]], u)) is not None), None)
        vt0 = next((x for k in near if (x := _corner(top_side.get(k, []), u[ub[s]], u)) is not None), None)
        if vb0 is None or vt0 is None:
            return None
        cuts[s] = _along_v(b, surfs[s][0].UIso(float(uk[ub[s]])), vb0, vt0, vk, vb, top[ub[s]])
    if seam:
        cuts[S] = cuts[0]
    out = []
    for k, f in enumerate(strips):  # one per strip
        uses = (_rim_uses(bottom.get(k, []), True, u, v, uk, vk) + _side_uses(k, S, cuts, sides, (u, v, uk, vk, ub), True)
                + _rim_uses(top_side.get(k, []), False, u, v, uk, vk) + _side_uses(k, S, cuts, sides, (u, v, uk, vk, ub), False))  # fmt: skip
        w = TopoDS_Wire()
        b.MakeWire(w)
        for e, o, _ in uses:  # in wire order
            b.Add(w, e.Oriented(o))
        w.Closed(True)
        b.Add(f, w)
        curves: list = []
        for e, o, c in uses:  # an edge used twice (a seam of the strip) gets both pcurves at once
            hit = next((x for x in curves if x[0].IsSame(e)), None)
            if hit is None:
                curves.append([e, {o: c}])
            else:
                hit[1][o] = c
        for e, got in curves:  # one per edge of the strip
            tol = tols.get(e, TOLERANCE)
            if len(got) == 2:
                b.UpdateEdge(e, got[TopAbs_FORWARD], got[TopAbs_REVERSED], f, tol)
            else:
                b.UpdateEdge(e, next(iter(got.values())), f, tol)
        out.append(f)
    return out
