"""A face textured on its own ``(u, v)`` whose outline is not the iso-line rectangle
(a cone trimmed by flutes or a slanted cut, a cylinder with a hole or a slot through
it, a wall of revolution with a window): tiles on the face's own parameters (issue 28).

The texture grid covers the face's whole ``(u, v)`` rectangle: grid points off the
face lie on the face's surface (``h = 0``), and the relief is 0 mm near the face's
own edges (texcad's M-I ramp), so the textured degree-1 surface
(:func:`texcad.brep.uvfaces._poles`) meets them within the chord of a cell. One such
face over the whole rectangle is valid, but OCCT's plain volume rule
(``BRepGProp::VolumeProperties`` without a precision, build123d's ``.volume``) puts 61
Gauss points across its hundred or so knot spans (:mod:`texcad.brep.gprop`): 0.1-0.3 %
off. Here:

1. the *plain* face is split along iso-``u`` and iso-``v`` lines every
   :data:`~texcad.brep.solids.TILE` grid cells, and every :data:`TRIM_TILE` cells
   inside the tiles an edge of the face off its rectangle's sides crosses (a hole's
   rim, a flute: :func:`_dirty_of`, :class:`_Tiling`). OCCT's splitter cuts the face
   and the faces sharing an edge with it, as a compound of faces (on the solid it
   would classify every piece of a cut line off the face against the whole solid),
   the lines on the surface's own iso curves (circles and lines on an analytic
   surface, which it intersects fast);
2. each piece of the face gets the textured surface over its tile, on knots placed
   for OCCT's plain rule (:func:`_knots`: :func:`texcad.brep.gprop.gauss_knots`
   over the tile's cells, the tile's sides at the grid's own parameters): the cut
   lines and a closed face's seam between two pieces become the lifted grid lines
   (degree-1 iso curves of the textured surface), their inner vertices lifted with
   them; the face's own edges keep their 3-D curves, their pcurves mapped onto the
   placed knots (:func:`_placed_pcurve`: an iso line exactly, a trim curve through
   :data:`MAPPED_POINTS` of its points) with the tolerance of their distance to the
   new surface. A piece with a pole or a seam of its own keeps the face's
   parameters (:func:`_rich` pads its pcurves for the rule's 61 points).

OCCT's plain rule integrates a face along its edges whose ``v`` changes, across ``u``
from the face's lowest ``u`` (:mod:`texcad.brep.gprop`): on a tile's right side that
is the whole tile, for which its ``u`` knots are placed; each lifted edge along v
runs on ``v`` knots placed for its own extent (a side cut by the corners of the
smaller tiles beside it is integrated piece by piece: :meth:`_Lifted.own_v`), every
piece mapping it by a broken line (exact: both maps are linear between grid lines).
Only the integrals across ``u`` that end on a trim curve are not placed; they are
a small part of the face. Whole tiles carry their grid's triangulation as
:func:`texcad.brep.uvstrips.strip_faces` do.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from .gprop import GAUSS_POINTS, gauss_knots, polyline_pcurve
from .occt import explore, to_topods
from .solids import TILE, TOLERANCE, _remember_tile, _replace_faces, _tile_bounds, _tile_text
from .uvstrips import _remapped

__all__ = ["trimmed_tiles", "TRIM_TILE"]

#: Grid cells a tile of a trimmed face has at most along u and v where an edge of the
#: face crosses it (elsewhere :data:`~texcad.brep.solids.TILE`).
TRIM_TILE = 8


def _bilinear(u: np.ndarray, v: np.ndarray, top: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The degree-1 surface through ``top`` at parameters ``q (n, 2)``."""
    i = np.clip(np.searchsorted(u, q[:, 0]) - 1, 0, len(u) - 2)
    j = np.clip(np.searchsorted(v, q[:, 1]) - 1, 0, len(v) - 2)
    s = ((q[:, 0] - u[i]) / (u[i + 1] - u[i]))[:, None]
    t = ((q[:, 1] - v[j]) / (v[j + 1] - v[j]))[:, None]
    return (1 - s) * (1 - t) * top[i, j] + s * (1 - t) * top[i + 1, j] + (1 - s) * t * top[i, j + 1] + s * t * top[i + 1, j + 1]


def _edge_deviation(edge, fwd, u: np.ndarray, v: np.ndarray, top: np.ndarray) -> float:
    """Largest distance (mm) between an edge's 3-D curve and its pcurve on the new
    surface, sampled four times per grid cell it crosses (one OCCT call per sample:
    an outline's thousands)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Curve2d

    c3, c2 = BRepAdaptor_Curve(edge), BRepAdaptor_Curve2d(edge, fwd)
    t0, t1 = c2.FirstParameter(), c2.LastParameter()
    n = 4 * (len(u) + len(v)) + 8
    ts = np.linspace(t0, t1, n)
    q = np.array([c2.Value(float(t)).Coord() for t in ts])  # per sample
    p = np.array([c3.Value(float(t)).Coord() for t in ts])
    return float(np.linalg.norm(_bilinear(u, v, top, q) - p, axis=1).max())


def _iso_edges(fwd, lines: list) -> list:
    """Edges on the plain face's surface along the cut lines ``[(iso u, value, first,
    last)]`` (an iso-u line at ``u = value`` from ``v = first`` to ``last``, or an
    iso-v line): each the
    surface's own iso curve (``UIso``/``VIso``: a circle or a line on an analytic
    surface, which OCCT's splitter intersects faster than an approximation), on the
    same parameter as its straight pcurve; an approximation (``BuildCurves3d``) only
    where the iso curve strays from ``S(pcurve(t))`` by more than 1e-9 mm."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.BRepLib import BRepLib
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d

    surf, b = BRep_Tool.Surface_s(fwd), BRep_Builder()
    out = []
    for iso_u, val, t0, t1 in lines:  # one per cut line (tens)
        p, d = (gp_Pnt2d(val, 0.0), gp_Dir2d(0.0, 1.0)) if iso_u else (gp_Pnt2d(0.0, val), gp_Dir2d(1.0, 0.0))
        mk = BRepBuilderAPI_MakeEdge(Geom2d_Line(p, d), surf, float(t0), float(t1))
        if not mk.IsDone():
            return []
        e = mk.Edge()
        curve = surf.UIso(val) if iso_u else surf.VIso(val)
        ts = np.linspace(float(t0), float(t1), 9).tolist()
        off = max(curve.Value(t).Distance(surf.Value(val, t) if iso_u else surf.Value(t, val)) for t in ts)  # 9 samples
        if off <= 1e-9:
            b.UpdateEdge(e, curve, BRep_Tool.Tolerance_s(e))
        else:
            BRepLib.BuildCurves3d_s(e, 1e-7)
        out.append(e)
    return out


def _split(shape, fwd, edges: list):
    """``(split compound, [face, its neighbours], [their pieces])`` by OCCT's
    splitter (the face first, each piece oriented as its face lies in the shell), or
    None. Only the face and the faces sharing an edge with it (which take
    the pieces of any edge the cut lines cross) are split, as a compound of faces: on
    the solid, OCCT would also classify every piece of a cut line off the face (in a
    hole) against the whole solid (``FillInternalShapes``), a drilled torus's
    thousands of faces each time."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Splitter
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_ListOfShape

    from .occt import compound

    owners = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, owners)
    faces = [f for f in explore(shape, TopAbs_FACE) if f.IsSame(fwd)][:1]
    for e in explore(fwd, TopAbs_EDGE):  # the face's edges: their other faces
        for f in owners.FindFromKey(e) if owners.Contains(e) else []:  # two faces, a seam's one
            if not any(f.IsSame(g) for g in faces):
                faces.append(f)
    args, tools = TopTools_ListOfShape(), TopTools_ListOfShape()
    args.Append(compound(faces))
    for e in edges:  # the cut lines
        tools.Append(e)
    sp = BRepAlgoAPI_Splitter()
    sp.SetArguments(args)
    sp.SetTools(tools)
    sp.SetRunParallel(False)
    try:
        sp.Build()
    except Exception:  # OCCT raises Standard_Failure from inside the splitter
        return None
    if not sp.IsDone() or not faces:
        return None
    of = _Same()
    for k, f in enumerate(faces):  # the face, then its neighbours
        for m in list(sp.Modified(f)) or [f]:  # its images
            of.add(m, k)
    images: list = [[] for _ in faces]
    for f in explore(sp.Shape(), TopAbs_FACE):  # the split faces, oriented as their face lies in the shell
        k = of.get(f)
        if k is None:
            return None
        images[k].append(f)
    return sp.Shape(), faces, images


def _uses(face) -> list:
    """``[(edge as used, pcurve adaptor of that use)]`` over the face's wires, in order."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.TopoDS import TopoDS, TopoDS_Iterator

    out = []
    wit = TopoDS_Iterator(face)
    while wit.More():  # one per wire
        eit = TopoDS_Iterator(wit.Value())
        while eit.More():  # one per edge use
            e = TopoDS.Edge_s(eit.Value())
            out.append((e, BRepAdaptor_Curve2d(e, face)))
            eit.Next()
        wit.Next()
    return out


def _ends(c2) -> tuple:
    """``(p at first, p at last)`` of a pcurve adaptor, ``(2,)`` arrays."""
    return np.array(c2.Value(c2.FirstParameter()).Coord()), np.array(c2.Value(c2.LastParameter()).Coord())


class _Tiling:
    """The tiles of a trimmed face: runs of at most :data:`~texcad.brep.solids.TILE`
    cells (``ub``, ``vb``, grid indices), each a trim curve crosses (``dirty``) cut in
    runs of at most :data:`TRIM_TILE`; ``lines()`` the cut lines ``[(iso u, value,
    first, last)]`` (parameters) for :func:`_iso_edges`, ``rect(face)`` the tile
    ``(a0, a1, b0, b1)`` (grid indices) a piece lies in (the one holding its UV box's
    centre)."""

    def __init__(self, u: np.ndarray, v: np.ndarray, dirty_of):
        self.u, self.v = u, v
        self.ub, self.vb = _tile_bounds(len(u) - 1, TILE), _tile_bounds(len(v) - 1, TILE)
        self.dirty = dirty_of(u[self.ub], v[self.vb])

    def fine(self, b: np.ndarray, i: int) -> np.ndarray:
        return b[i] + _tile_bounds(int(b[i + 1] - b[i]), TRIM_TILE)

    def lines(self) -> list:
        u, v, ub, vb = self.u, self.v, self.ub, self.vb
        out = [(True, float(u[a]), v[0], v[-1]) for a in ub[1:-1].tolist()]
        out += [(False, float(v[c]), u[0], u[-1]) for c in vb[1:-1].tolist()]
        for i, j in zip(*np.nonzero(self.dirty)):  # the coarse tiles a trim curve crosses (a few)
            out += [(True, float(u[a]), v[vb[j]], v[vb[j + 1]]) for a in self.fine(ub, i)[1:-1].tolist()]
            out += [(False, float(v[c]), u[ub[i]], u[ub[i + 1]]) for c in self.fine(vb, j)[1:-1].tolist()]
        return out

    def rect(self, face) -> tuple:
        from OCP.BRepTools import BRepTools

        a, z, c, d = BRepTools.UVBounds_s(face)
        mid = (0.5 * (a + z), 0.5 * (c + d))
        i, j = (int(np.clip(np.searchsorted(k[b], m) - 1, 0, len(b) - 2)) for k, b, m in ((self.u, self.ub, mid[0]), (self.v, self.vb, mid[1])))
        bu, bv = (self.fine(self.ub, i), self.fine(self.vb, j)) if self.dirty[i, j] else (self.ub[i : i + 2], self.vb[j : j + 2])
        fi = int(np.clip(np.searchsorted(self.u[bu], mid[0]) - 1, 0, len(bu) - 2))
        fj = int(np.clip(np.searchsorted(self.v[bv], mid[1]) - 1, 0, len(bv) - 2))
        return int(bu[fi]), int(bu[fi + 1]), int(bv[fj]), int(bv[fj + 1])


def _dirty_of(fwd, u: np.ndarray, v: np.ndarray):
    """``dirty(ub, vb)``: ``(len(ub) - 1, len(vb) - 1)`` bool, the tiles between the
    parameter values ``ub``, ``vb`` that an edge of ``fwd`` off its ``(u, v)``
    rectangle's sides passes (sampled four times per grid cell)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    span = max(abs(u[-1] - u[0]), abs(v[-1] - v[0]))
    q = []
    for e in explore(fwd, TopAbs_EDGE):  # the face's edges (a few)
        c2 = BRepAdaptor_Curve2d(TopoDS.Edge_s(e), fwd)
        ts = np.linspace(c2.FirstParameter(), c2.LastParameter(), 4 * (len(u) + len(v)) + 8)
        pts = np.array([c2.Value(float(t)).Coord() for t in ts])  # per sample
        on_side = [np.abs(pts[:, a] - x).max() <= 1e-9 * span for a, x in ((0, u[0]), (0, u[-1]), (1, v[0]), (1, v[-1]))]
        if not any(on_side):
            q.append(pts)
    pts = np.concatenate(q) if q else np.zeros((0, 2))

    def dirty(ub: np.ndarray, vb: np.ndarray) -> np.ndarray:
        out = np.zeros((len(ub) - 1, len(vb) - 1), bool)
        i = np.clip(np.searchsorted(ub, pts[:, 0]) - 1, 0, len(ub) - 2)
        j = np.clip(np.searchsorted(vb, pts[:, 1]) - 1, 0, len(vb) - 2)
        out[i, j] = True
        return out

    return dirty


def _surfaces(parts: list) -> list:
    """``[(surface, triangulation)]`` of degree-1 grids ``parts`` ``[(u, v, top (Nu, Nv,
    3))]`` (one OCCT read for all)."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS, TopoDS_Iterator, TopoDS_Shape

    grids = [np.ascontiguousarray(t.transpose(1, 0, 2)) for _, _, t in parts]
    comp = TopoDS_Shape()
    text = _tile_text(grids, [p[0] for p in parts], [p[1] for p in parts], True)
    BRepTools.Read_s(comp, io.BytesIO(text.encode("ascii")), BRep_Builder())
    out = []
    it = TopoDS_Iterator(comp)
    while it.More():  # one per tile
        f = TopoDS.Face_s(it.Value())
        out.append((BRep_Tool.Surface_s(f), BRep_Tool.Triangulation_s(f, TopLoc_Location())))
        it.Next()
    for (surf, _), g, (uu, vv, _) in zip(out, grids, parts):  # texcad's tiles: remembered for the STEP writer
        _remember_tile(surf, g, uu, vv)
    return out


def _rich(pc, first: float, last: float, knots: np.ndarray | None = None):
    """The pcurve ``pc`` over ``first .. last`` as a curve along which OCCT's plain
    volume rule takes its :data:`~texcad.brep.gprop.GAUSS_POINTS` points: a straight
    line (``Geom2d_Line``) as a degree-1 B-spline of at least
    :data:`~texcad.brep.gprop.PAD_SPANS` spans with knots at ``knots`` (the grid
    lines it passes; :func:`~texcad.brep.gprop.polyline_pcurve`), a B-spline of too
    few spans with each span cut in equal parts (knots inserted: the same curve);
    the same points at the same parameters either way. Any other curve as it is.
    Used on the pieces that keep the face's parameters (a pole or a seam of their
    own). (Texcad once inserted knots in the surfaces instead: four times the poles
    in the STEP.)"""
    from OCP.Geom2d import Geom2d_BSplineCurve, Geom2d_Line

    if isinstance(pc, Geom2d_Line):
        dx, dy = pc.Direction().Coord()
        if abs(dy) <= 1e-12 or last - first <= 1e-12:  # along u: no share in the rule (or of no length)
            return pc
        t = np.array([first, last], np.float64)
        if knots is not None and abs(dx) <= 1e-12:  # an iso-u line: knots at the grid's rows
            inside = knots[(knots > first + 1e-9 * (1 + abs(first))) & (knots < last - 1e-9 * (1 + abs(last)))]
            t = np.concatenate([[first], inside, [last]])
        pts = np.array([pc.Value(float(a)).Coord() for a in t.tolist()])  # per grid line it passes (tens)
        return polyline_pcurve(pts, t)
    if isinstance(pc, Geom2d_BSplineCurve) and 2 * (pc.Degree() + 1) * (pc.NbKnots() - 1) < GAUSS_POINTS:
        k = np.array([pc.Knot(i) for i in range(1, pc.NbKnots() + 1)])
        parts = -(-GAUSS_POINTS // (2 * (pc.Degree() + 1) * (len(k) - 1)))
        out = pc.Copy()
        for a, z in zip(k[:-1].tolist(), k[1:].tolist()):  # one per span (a few)
            for s in (np.arange(1, parts) / parts).tolist():
                out.InsertKnot(a + (z - a) * s, 1, 0.0)
        return out
    return pc


class _Same:
    """Shapes to values, found by ``IsSame`` (same TShape and location, any
    orientation) through OCCT's shape hash, which ignores orientation too: one lookup,
    not a scan (a fine torus's cut made 5.8 million ``IsSame`` calls)."""

    def __init__(self, shapes=()):
        self._by: dict = {}
        for s in shapes:  # one per shape given
            self.add(s, s)

    def get(self, shape):
        return next((v for k, v in self._by.get(hash(shape), ()) if k.IsSame(shape)), None)

    def add(self, shape, value) -> None:
        self._by.setdefault(hash(shape), []).append((shape, value))


class _Lifted:
    """The lifted grid lines replacing the cut lines and the seam between pieces: one
    new edge per old edge (on the iso curve of the textured surface of a tile it
    bounds: the degree-1 grid's row or column, the same curve on the tile beside it),
    its vertices lifted (onto the bilinear grid ``grid`` ``(u, v, top)``) unless the
    face's own edges hold them. An edge along v runs on the v knots of the piece whose
    right side (largest u) it is (``left``: OCCT's plain rule integrates along it
    there, across the piece's whole u range; on the piece at its other side the
    integral across u is empty), an edge along u on the face's u (no share in the
    rule); each piece maps it by a broken line onto its own knots (exact: both are
    linear between grid lines)."""

    def __init__(self, b, grid: tuple, kept_vertices: list):
        self.b, self.grid, self.kept = b, grid, _Same(kept_vertices)
        self.knots = grid[:2]  # (u, v) of the whole surface: iso values and crossings snap to them
        self.edges = _Same()  # old edge -> (old edge, new edge, its knots (along its axis, at the grid lines))
        self.verts = _Same()  # old vertex -> new vertex
        self.left = _Same()  # old edge along v -> the v knots of the piece whose right side it is

    def snap(self, q: np.ndarray) -> np.ndarray:
        """``q (2,)`` with each coordinate within 1e-7 of the span of a knot moved onto it (OCCT's
        splitter leaves about 1e-9 on its intersections)."""
        out = np.array(q, np.float64)
        for a, k in enumerate(self.knots):  # u, then v
            i = int(np.argmin(np.abs(k - out[a])))
            if abs(k[i] - out[a]) <= 1e-7 * (abs(k[-1] - k[0]) + 1.0):
                out[a] = k[i]
        return out

    def own_v(self, old, a: float, z: float, mine: np.ndarray) -> np.ndarray:
        """The v knots of a lifted edge along v from ``v = a`` to ``z`` (face
        parameters): between two grid rows, placed for OCCT's rule along it alone
        (:func:`texcad.brep.gprop.gauss_knots`: a piece's side cut by its neighbour's
        tile corners is integrated piece by piece); else those of the piece whose
        right side it is, or ``mine``."""
        v = self.knots[1]
        i, k = np.searchsorted(v, [a, z])
        if i < k and v[i] == a and k < len(v) and v[k] == z:
            out = v.copy()
            out[i : k + 1] = gauss_knots(a, z, int(k - i))
            return out
        left = self.left.get(old)
        return left if left is not None else mine

    def iso(self, c2) -> tuple:
        """``(p0, p1, along u, axis, iso value)`` of an iso-line pcurve, snapped."""
        p0, p1 = (self.snap(p) for p in _ends(c2))
        along_u = abs(p1[1] - p0[1]) <= abs(p1[0] - p0[0])  # an iso-v line: runs along u
        k = 0 if along_u else 1
        return p0, p1, along_u, k, float(0.5 * (p0[1 - k] + p1[1 - k]))

    def vertex(self, old, uv: np.ndarray):
        from OCP.BRep import BRep_Tool
        from OCP.gp import gp_Pnt
        from OCP.TopoDS import TopoDS_Vertex

        got = self.verts.get(old)
        if got is not None:
            return got
        p = _bilinear(*self.grid[:2], self.grid[2], np.asarray(uv, np.float64)[None, :])[0]
        if self.kept.get(old) is not None:  # on the face's own edges: stays, wide enough for both
            tol = max(BRep_Tool.Tolerance_s(old), 1.5 * float(np.linalg.norm(p - np.array(BRep_Tool.Pnt_s(old).Coord()))) + TOLERANCE)
            self.b.UpdateVertex(old, tol)
            self.verts.add(old, old)
            return old
        new = TopoDS_Vertex()
        self.b.MakeVertex(new, gp_Pnt(*p.tolist()), TOLERANCE)
        self.verts.add(old, new)
        return new

    def edge(self, old, c2, surf, knots: tuple) -> tuple:
        """``(new edge, its knots, along u, iso value of this use, same direction as
        old)`` for the use of ``old`` whose pcurve is ``c2`` (an iso line of the face:
        a seam's two uses lie at ``u0`` and ``u1``) on a piece whose tile's surface is
        ``surf`` on the knots ``knots`` ``(u, v)`` (the face's grid lines mapped)."""
        from OCP.TColStd import TColStd_Array1OfReal
        from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
        from OCP.TopExp import TopExp
        from OCP.TopoDS import TopoDS, TopoDS_Edge

        p0, p1, along_u, k, val = self.iso(c2)  # along the edge's own parameter (whatever its use)
        inc = bool(p1[k] > p0[k])
        hit = self.edges.get(old)
        if hit is None:
            fe = TopoDS.Edge_s(old.Oriented(TopAbs_FORWARD))
            first, last = TopExp.FirstVertex_s(fe), TopExp.LastVertex_s(fe)
            (va, pa), (vz, pz) = ((first, p0), (last, p1)) if inc else ((last, p1), (first, p0))
            na, nz = self.vertex(va, pa), self.vertex(vz, pz)
            grid, mine = self.knots[k], knots[k]
            own = self.knots[0] if along_u else self.own_v(old, pa[1], pz[1], mine)
            at = float(np.interp(val, self.knots[1 - k], knots[1 - k]))
            curve = surf.VIso(at) if along_u else surf.UIso(at)
            ks = np.interp(np.interp([curve.Knot(i) for i in range(1, curve.NbKnots() + 1)], mine, grid), grid, own)
            arr = TColStd_Array1OfReal(1, len(ks))
            for i, a in enumerate(ks.tolist(), 1):  # per knot of the tile's side (a few)
                arr.SetValue(i, a)
            curve.SetKnots(arr)
            new = TopoDS_Edge()
            self.b.MakeEdge(new, curve, TOLERANCE)
            self.b.Add(new, na.Oriented(TopAbs_FORWARD))
            self.b.Add(new, nz.Oriented(TopAbs_REVERSED))
            self.b.Range(new, float(np.interp(pa[k], grid, own)), float(np.interp(pz[k], grid, own)))
            hit = (old, new, own)
            self.edges.add(old, hit)
        return hit[1], hit[2], along_u, val, inc

    def pcurve(self, new, own: np.ndarray, along_u: bool, val: float, knots: tuple):
        """The pcurve of the lifted edge ``new`` (on the knots ``own`` along its axis,
        at the face parameter ``val`` across it) on a piece whose surface is on
        ``knots`` ``(u, v)``: a broken line with corners at the grid lines (exact), as
        a degree-1 B-spline, along v padded for the rule's points."""
        from OCP.BRep import BRep_Tool

        k = 0 if along_u else 1
        t0, t1 = BRep_Tool.Range_s(new)
        ts = np.concatenate([[t0], own[(own > t0 + 1e-9 * (1 + abs(t0))) & (own < t1 - 1e-9 * (1 + abs(t1)))], [t1]])
        run = np.interp(np.interp(ts, own, self.knots[k]), self.knots[k], knots[k])
        across = np.full(len(ts), float(np.interp(val, self.knots[1 - k], knots[1 - k])))
        return polyline_pcurve(np.stack([run, across] if along_u else [across, run], axis=-1), ts, pad=not along_u)


def _owners(shape):
    """``uses(edge)``: how many times the faces of ``shape`` use ``edge`` (a seam twice
    in its face), counted in one pass over the faces' edge uses."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopTools import TopTools_IndexedMapOfShape

    faces, seen = TopTools_IndexedMapOfShape(), TopTools_IndexedMapOfShape()
    count: dict = {}
    for f in explore(shape, TopAbs_FACE):  # one per face use: each face once
        if faces.Contains(f):
            continue
        faces.Add(f)
        for e in explore(f, TopAbs_EDGE):  # its edge uses (a seam's two)
            k = seen.Add(e)
            count[k] = count.get(k, 0) + 1

    def uses(edge) -> int:
        k = seen.FindIndex(edge)
        return count.get(k, 0) if k else 0

    return uses


def trimmed_tiles(shape: Any, face: Any, u: np.ndarray, v: np.ndarray, top: np.ndarray):
    """``shape`` with ``face`` textured in tiles on its own parameters (see the
    module); ``u (Nu,)``, ``v (Nv,)``, ``top (Nu, Nv, 3)`` mm as
    :func:`texcad.brep.uvfaces._poles` gives them (the whole ``(u, v)`` rectangle).
    None where OCCT's splitter fails."""
    from OCP.BRep import BRep_Builder
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopoDS import TopoDS

    fwd = TopoDS.Face_s(to_topods(face).Oriented(TopAbs_FORWARD))
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    tiling = _Tiling(u, v, _dirty_of(fwd, u, v))
    shape = to_topods(shape)
    got = _split(shape, fwd, _iso_edges(fwd, tiling.lines()))
    if got is None:
        return None
    split, faces, images = got
    pieces = [TopoDS.Face_s(f) for f in images[0]]
    uses = [_uses(TopoDS.Face_s(p.Oriented(TopAbs_FORWARD))) for p in pieces]
    inner, kept_v = _inner_edges(split, uses)
    keys = [(*tiling.rect(p), _placeable(us, inner)) for p, us in zip(pieces, uses)]
    knots = {key: _knots(u, v, key) for key in set(keys)}
    order = sorted(knots)
    subs = {(a0, a1, b0, b1, q): (u[a0 : a1 + 1], v[b0 : b1 + 1], top[a0 : a1 + 1, b0 : b1 + 1]) for a0, a1, b0, b1, q in order}
    surfs = dict(zip(order, _surfaces([(knots[k][0][k[0] : k[1] + 1], knots[k][1][k[2] : k[3] + 1], subs[k][2]) for k in order])))
    b = BRep_Builder()
    lifted = _Lifted(b, (u, v, top), kept_v)
    for us, key in zip(uses, keys):  # the edges along v each piece has on its right side: their knots
        for e, c2 in us:
            if inner.Contains(e):
                _, _, along_u, _, val = lifted.iso(c2)
                if not along_u and val == u[key[1]]:
                    lifted.left.add(e, knots[key][1])
    new = []
    for piece, us, key in zip(pieces, uses, keys):  # one per piece of the face
        nf = _piece_face(b, TopoDS.Face_s(piece.Oriented(TopAbs_FORWARD)), us, surfs[key], subs[key], lifted, inner, knots[key])
        new.append(TopoDS.Face_s(nf.Oriented(piece.Orientation())))
    return _replace_faces(shape, [(faces[0], new)] + list(zip(faces[1:], images[1:])))


def _knots(u: np.ndarray, v: np.ndarray, key: tuple) -> tuple:
    """``(u, v)`` knots of a piece's surface over the whole grid (only its tile's
    ``key[:4]`` part is used): the face's own, or on the tile placed for OCCT's plain
    rule (``key[4]``: :func:`texcad.brep.gprop.gauss_knots` over its cells)."""
    a0, a1, b0, b1, placed = key
    ku, kv = u.copy(), v.copy()
    if placed:
        ku[a0 : a1 + 1] = gauss_knots(u[a0], u[a1], a1 - a0)
        kv[b0 : b1 + 1] = gauss_knots(v[b0], v[b1], b1 - b0)
    return ku, kv


def _placeable(us: list, inner) -> bool:
    """Can the piece with edge uses ``us`` go on knots placed for OCCT's plain rule
    (:func:`_knots`)? Unless one of its own edges (not ``inner``: those are lifted) is
    a pole's or used twice (a seam the piece keeps): each gets a pcurve on the placed
    knots (:func:`_placed_pcurve`)."""
    from OCP.BRep import BRep_Tool

    own = [e for e, _ in us if not inner.Contains(e)]
    return not any(BRep_Tool.Degenerated_s(e) or sum(1 for x in own if x.IsSame(e)) > 1 for e in own)


#: Points per kept pcurve that is not an iso line when mapped onto placed knots (the
#: piece lies in one tile of at most :data:`TRIM_TILE` cells a side).
MAPPED_POINTS = 129


def _placed_pcurve(c2, grid: tuple, knots: tuple):
    """A piece's own edge's pcurve ``c2`` (on the face's parameters, grid lines
    ``grid`` ``(u, v)``) on the piece's placed knots ``knots`` (the grid lines mapped,
    piecewise linearly): an iso line as the broken line with corners at the grid lines
    (exact, :func:`texcad.brep.uvstrips._remapped`), any other curve as the degree-1
    B-spline through :data:`MAPPED_POINTS` of its points mapped (its distance to the
    3-D curve goes into the edge's tolerance: :func:`_mapped_deviation`). Either way
    on the edge's own parameter, its knots padded for the rule's points."""
    from OCP.GeomAbs import GeomAbs_Line

    t0, t1 = c2.FirstParameter(), c2.LastParameter()
    if c2.GetType() == GeomAbs_Line and min(abs(x) for x in c2.Line().Direction().Coord()) <= 1e-12:
        return _remapped(t0, t1, *_ends(c2), *grid, *knots)
    ts = np.linspace(t0, t1, MAPPED_POINTS)
    q = np.array([c2.Value(float(t)).Coord() for t in ts.tolist()])  # per point
    return polyline_pcurve(np.stack([np.interp(q[:, 0], grid[0], knots[0]), np.interp(q[:, 1], grid[1], knots[1])], axis=-1), ts)


def _mapped_deviation(edge, pc, sub: tuple, knots: tuple) -> float:
    """Largest distance (mm) between ``edge``'s 3-D curve and the textured surface at
    its pcurve ``pc`` on placed knots (``knots`` ``(u, v)``, the sub-grid ``sub``
    ``(u, v, top)``'s lines mapped), sampled at four points per span of ``pc``."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve

    c3 = BRepAdaptor_Curve(edge)
    t0, t1 = BRep_Tool.Range_s(edge)
    ts = np.linspace(t0, t1, 4 * MAPPED_POINTS)
    q = np.array([pc.Value(float(t)).Coord() for t in ts.tolist()])  # per sample
    p = np.array([c3.Value(float(t)).Coord() for t in ts.tolist()])
    back = np.stack([np.interp(q[:, 0], knots[0], sub[0]), np.interp(q[:, 1], knots[1], sub[1])], axis=-1)
    return float(np.linalg.norm(_bilinear(sub[0], sub[1], sub[2], back) - p, axis=1).max())


def _inner_edges(split, uses: list) -> tuple:
    """``(inner, kept vertices)``: the edges of the pieces (``uses``, per piece) that no
    other face has (the cut lines, a closed face's seam; not a pole's degenerate edge),
    as a ``TopTools_IndexedMapOfShape``, and the vertices of the face's own edges."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    count: dict = {}
    seen = TopTools_IndexedMapOfShape()
    for us in uses:  # one per piece
        for e, _ in us:  # its edge uses
            k = seen.Add(e)
            count[k] = count.get(k, 0) + 1
    owners = _owners(split)
    inner = TopTools_IndexedMapOfShape()
    kept = []
    for k in range(1, seen.Extent() + 1):  # one per edge of the pieces
        e = TopoDS.Edge_s(seen.FindKey(k))
        if count[k] >= 2 and count[k] == owners(e) and not BRep_Tool.Degenerated_s(e):
            inner.Add(e)
        else:
            kept += explore(e, TopAbs_VERTEX)
    return inner, kept


def _piece_face(b, pf, us: list, tile: tuple, sub: tuple, lifted, inner, knots: tuple):
    """The new face (forward) of the piece ``pf`` (its edge uses ``us``) on its tile's
    ``(surface, triangulation)``; ``sub`` the tile's ``(u, v, top)`` on the face's
    parameters: the piece's wires with the inner edges lifted (``lifted``), pcurves
    and tolerances. ``knots`` ``(u, v)``: the surface's knots at the face's grid
    lines (placed ones: the piece's own edges, iso lines, get broken lines onto them,
    :func:`_placeable`)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS_Face, TopoDS_Iterator, TopoDS_Wire

    surf, tri = tile
    placed = not (np.array_equal(knots[0], lifted.knots[0]) and np.array_equal(knots[1], lifted.knots[1]))
    nf = TopoDS_Face()
    b.MakeFace(nf, surf, TopLoc_Location(), TOLERANCE)
    curves: list = []  # [(edge, {orientation: pcurve}, kept)]
    wit, k = TopoDS_Iterator(pf), 0
    while wit.More():  # one per wire
        w = TopoDS_Wire()
        b.MakeWire(w)
        n = len(explore(wit.Value(), TopAbs_EDGE))
        for e, c2 in us[k : k + n]:  # the wire's edge uses
            if inner.Contains(e):
                ne, own, along_u, val, inc = lifted.edge(e, c2, tile[0], knots)
                use, pc, kept = ne.Oriented(e.Orientation() if inc else e.Reversed().Orientation()), lifted.pcurve(ne, own, along_u, val, knots), False
            elif placed:
                use, pc, kept = e, _placed_pcurve(c2, lifted.knots, knots), True
            else:
                use, pc, kept = e, BRep_Tool.CurveOnSurface_s(e, pf, 0.0, 0.0), True
                pc = _rich(pc, *BRep_Tool.Range_s(e, pf), lifted.knots[1])
            b.Add(w, use)
            hit = next((x for x in curves if x[0].IsSame(use)), None)
            if hit is None:
                curves.append([use, {use.Orientation(): pc}, kept])
            else:
                hit[1][use.Orientation()] = pc
        k += n
        w.Closed(True)
        b.Add(nf, w)
        wit.Next()
    _pcurves(b, nf, pf, curves, sub, (knots[0][np.searchsorted(lifted.knots[0], sub[0])], knots[1][np.searchsorted(lifted.knots[1], sub[1])]) if placed else None)
    if not any(kept for *_, kept in curves):  # a whole tile: its grid's triangulation
        b.UpdateFace(nf, tri)
    return nf


def _pcurves(b, nf, pf, curves: list, sub: tuple, placed: tuple | None) -> None:
    """Each edge of ``curves`` ``[(edge, {orientation: pcurve}, kept)]`` gets its
    pcurves on the new face ``nf``; the piece's own (kept) edges the tolerance of their
    distance to the tile's surface ``sub`` ``(u, v, top)`` (on the placed knots
    ``placed`` ``(u, v)`` of ``sub``'s lines, if not None: through their new pcurve),
    and their vertices too."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_VERTEX
    from OCP.TopoDS import TopoDS

    for e, pcs, kept in curves:  # one per edge of the piece
        edge = TopoDS.Edge_s(e.Oriented(TopAbs_FORWARD))
        tol = max(BRep_Tool.Tolerance_s(edge), TOLERANCE)
        if kept and not BRep_Tool.Degenerated_s(edge):
            dev = _edge_deviation(edge, pf, *sub) if placed is None else _mapped_deviation(edge, next(iter(pcs.values())), sub, placed)
            tol = max(tol, 1.5 * dev + TOLERANCE)
        if len(pcs) == 2:
            b.UpdateEdge(edge, pcs[TopAbs_FORWARD], pcs[TopAbs_REVERSED], nf, tol)
        else:
            b.UpdateEdge(edge, next(iter(pcs.values())), nf, tol)
        if kept and BRep_Tool.Degenerated_s(edge):  # a pole's piece: its own range (no 3-D curve to take it from)
            b.Range(edge, nf, *BRep_Tool.Range_s(edge, pf))
        for x in explore(edge, TopAbs_VERTEX):  # its vertices at least as wide
            vx = TopoDS.Vertex_s(x)
            b.UpdateVertex(vx, max(BRep_Tool.Tolerance_s(vx), tol))
