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

1. the *plain* part is split along iso-``u`` and iso-``v`` lines of the face every
   :data:`TRIM_TILE` grid cells (OCCT's splitter: edges on an analytic or smooth
   surface; the face's neighbours take the pieces of any edge the lines cross);
2. each piece of the face gets the textured surface over its tile, on the same
   parameters (so the piece's own pcurves stay valid); the cut lines and a closed
   face's seam between two pieces become the lifted grid lines (degree-1 iso curves
   of the textured surface), their inner vertices lifted with them; the face's own
   edges keep their curves, with the tolerance of their chord to the new surface.

Each piece is at most :data:`TRIM_TILE` spans a side, and its pcurves that are not
along u take the rule's 61 points (:func:`_rich`: lines as padded degree-1
B-splines, knots inserted in short B-splines), so the plain rule has about eight
Gauss points per span on it. (Knots inserted in the pieces' surfaces did the same
with four times the poles: a drilled cylinder's STEP 5.8x its STL, 1.4x now.) Whole tiles (no edge of the face crosses them)
carry their grid's triangulation as :func:`texcad.brep.uvstrips.strip_faces` do.
"""

from __future__ import annotations

import io
from typing import Any

import numpy as np

from .gprop import GAUSS_POINTS, polyline_pcurve, run_knots
from .occt import explore, to_topods
from .solids import TOLERANCE, _remember_tile, _replace_faces, _tile_bounds, _tile_text
from .uvstrips import _remapped

__all__ = ["trimmed_tiles", "TRIM_TILE"]

#: Grid cells a tile of a trimmed face has at most along u and v.
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


def _iso_edges(fwd, u: np.ndarray, v: np.ndarray, cu: np.ndarray, cv: np.ndarray) -> list:
    """Edges on the plain face's surface along the iso-u lines ``cu`` (from ``v[0]`` to
    ``v[-1]``) and the iso-v lines ``cv`` (from ``u[0]`` to ``u[-1]``): each the
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
    lines = [(gp_Pnt2d(float(a), 0.0), gp_Dir2d(0.0, 1.0), v[0], v[-1], True, float(a)) for a in cu.tolist()]
    lines += [(gp_Pnt2d(0.0, float(c)), gp_Dir2d(1.0, 0.0), u[0], u[-1], False, float(c)) for c in cv.tolist()]
    for p, d, t0, t1, iso_u, val in lines:  # one per cut line (tens)
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


def _tile_of(face, ub: np.ndarray, vb: np.ndarray) -> tuple[int, int]:
    """The tile ``(i, j)`` (between ``ub[i] .. ub[i + 1]`` and ``vb[j] .. vb[j + 1]``,
    parameter values) the piece ``face`` lies in: the one holding its UV box's centre."""
    from OCP.BRepTools import BRepTools

    a, z, c, d = BRepTools.UVBounds_s(face)
    i = int(np.clip(np.searchsorted(ub, 0.5 * (a + z)) - 1, 0, len(ub) - 2))
    j = int(np.clip(np.searchsorted(vb, 0.5 * (c + d)) - 1, 0, len(vb) - 2))
    return i, j


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
    (A piece's own surface has at most :data:`TRIM_TILE` spans a side, whose order,
    ``2 (1 + 1) 8 = 32``, the rule takes on lines; texcad once inserted knots in the
    surfaces instead: four times the poles in the STEP.)"""
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
    new edge per old edge (on the iso curve of the textured surface of the tile it
    bounds: the degree-1 grid's row or column over that tile, the same curve on the
    tile beside it), its vertices lifted (onto the bilinear grid ``grid`` ``(u, v,
    top)``) unless the face's own edges hold them."""

    def __init__(self, b, grid: tuple, kept_vertices: list, placed: tuple):
        self.b, self.grid, self.kept = b, grid, _Same(kept_vertices)
        self.knots = grid[:2]  # (u, v) of the whole surface: iso values and crossings snap to them
        self.placed = placed  # (u, v) knots placed for the plain rule: the lifted edges' parameters
        self.edges = _Same()  # old edge -> (old edge, new edge)
        self.verts = _Same()  # old vertex -> new vertex

    def snap(self, q: np.ndarray) -> np.ndarray:
        """``q (2,)`` with each coordinate within 1e-7 of the span of a knot moved onto it (OCCT's
        splitter leaves about 1e-9 on its intersections)."""
        out = np.array(q, np.float64)
        for a, k in enumerate(self.knots):  # u, then v
            i = int(np.argmin(np.abs(k - out[a])))
            if abs(k[i] - out[a]) <= 1e-7 * (abs(k[-1] - k[0]) + 1.0):
                out[a] = k[i]
        return out

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

    def to_placed(self, axis: int, x):
        """Face parameters ``x`` along ``axis`` (0: u) on the placed knots (piecewise linear)."""
        return np.interp(x, self.knots[axis], self.placed[axis])

    def edge(self, old, c2, surf, placed: bool) -> tuple:
        """``(new edge, along u, iso value of this use, same direction as old)`` for
        the use of ``old`` whose pcurve is ``c2`` (an iso line of the face: a seam's
        two uses lie at ``u0`` and ``u1``) on the piece whose tile's surface is
        ``surf`` (on the placed knots if ``placed``). The new edge runs on the placed
        knots whichever tile made it (its curve's knots set to them)."""
        from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
        from OCP.TopExp import TopExp
        from OCP.TopoDS import TopoDS, TopoDS_Edge

        p0, p1 = (self.snap(p) for p in _ends(c2))  # along the edge's own parameter (whatever its use)
        along_u = abs(p1[1] - p0[1]) <= abs(p1[0] - p0[0])  # an iso-v line: runs along u
        k = 0 if along_u else 1
        inc = bool(p1[k] > p0[k])
        hit = self.edges.get(old)
        if hit is None:
            fe = TopoDS.Edge_s(old.Oriented(TopAbs_FORWARD))
            first, last = TopExp.FirstVertex_s(fe), TopExp.LastVertex_s(fe)
            (va, pa), (vz, pz) = ((first, p0), (last, p1)) if inc else ((last, p1), (first, p0))
            na, nz = self.vertex(va, pa), self.vertex(vz, pz)
            curve = surf.VIso(float(pa[1])) if along_u else surf.UIso(float(pa[0]))  # a tile bound: the same placed
            if not placed:
                from OCP.TColStd import TColStd_Array1OfReal

                ks = self.to_placed(k, np.array([curve.Knot(i) for i in range(1, curve.NbKnots() + 1)]))
                arr = TColStd_Array1OfReal(1, len(ks))
                for i, a in enumerate(ks.tolist(), 1):  # per knot of the tile's side (nine)
                    arr.SetValue(i, a)
                curve.SetKnots(arr)
            new = TopoDS_Edge()
            self.b.MakeEdge(new, curve, TOLERANCE)
            self.b.Add(new, na.Oriented(TopAbs_FORWARD))
            self.b.Add(new, nz.Oriented(TopAbs_REVERSED))
            self.b.Range(new, float(self.to_placed(k, pa[k])), float(self.to_placed(k, pz[k])))
            hit = (old, new)
            self.edges.add(old, hit)
        return hit[1], along_u, float(0.5 * (p0[1 - k] + p1[1 - k])), inc

    def pcurve(self, new, along_u: bool, val: float, placed: bool):
        """The pcurve of the lifted edge ``new`` (on the placed knots, at the face
        parameter ``val`` across it) on a piece whose surface is on the placed knots
        (``placed``: a straight line, along v a degree-1 B-spline with knots at the
        rows, padded for the rule's points) or on the face's own (a broken line,
        corners at the grid lines: exact, both maps are linear between them)."""
        from OCP.BRep import BRep_Tool
        from OCP.Geom2d import Geom2d_Line
        from OCP.gp import gp_Dir2d, gp_Pnt2d

        k = 0 if along_u else 1
        if along_u and placed:  # no share in the rule
            return Geom2d_Line(gp_Pnt2d(0.0, float(self.to_placed(1, val))), gp_Dir2d(1.0, 0.0))
        t0, t1 = BRep_Tool.Range_s(new)
        kp = self.placed[k]
        ts = np.concatenate([[t0], kp[(kp > t0 + 1e-9 * (1 + abs(t0))) & (kp < t1 - 1e-9 * (1 + abs(t1)))], [t1]])
        run = ts if placed else np.interp(ts, kp, self.knots[k])
        across = np.full(len(ts), self.to_placed(1 - k, val) if placed else val)
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


def trimmed_tiles(shape: Any, face: Any, u: np.ndarray, v: np.ndarray, top: np.ndarray, tile: int = TRIM_TILE):
    """``shape`` with ``face`` textured in tiles on its own parameters (see the
    module); ``u (Nu,)``, ``v (Nv,)``, ``top (Nu, Nv, 3)`` mm as
    :func:`texcad.brep.uvfaces._poles` gives them (the whole ``(u, v)`` rectangle).
    None where OCCT's splitter fails."""
    from OCP.BRep import BRep_Builder
    from OCP.TopAbs import TopAbs_FACE, TopAbs_FORWARD
    from OCP.TopoDS import TopoDS

    fwd = TopoDS.Face_s(to_topods(face).Oriented(TopAbs_FORWARD))
    ub, vb = _tile_bounds(len(u) - 1, tile), _tile_bounds(len(v) - 1, tile)
    shape = to_topods(shape)
    got = _split(shape, fwd, _iso_edges(fwd, u, v, u[ub[1:-1]], v[vb[1:-1]]))
    if got is None:
        return None
    split, faces, images = got
    pieces = [TopoDS.Face_s(f) for f in images[0]]
    uses = [_uses(TopoDS.Face_s(p.Oriented(TopAbs_FORWARD))) for p in pieces]
    inner, kept_v = _inner_edges(split, uses)
    u, v = np.asarray(u, np.float64), np.asarray(v, np.float64)
    uk, vk = run_knots(u, ub), run_knots(v, vb)
    tiles = [(*_tile_of(p, u[ub], v[vb]), _placeable(us, inner)) for p, us in zip(pieces, uses)]
    keys = sorted(set(tiles))
    subs = {(i, j, q): (u[ub[i] : ub[i + 1] + 1], v[vb[j] : vb[j + 1] + 1], top[ub[i] : ub[i + 1] + 1, vb[j] : vb[j + 1] + 1])
            for i, j, q in keys}  # fmt: skip
    on = {(i, j, q): (uk[ub[i] : ub[i + 1] + 1], vk[vb[j] : vb[j + 1] + 1], subs[(i, j, q)][2]) if q else subs[(i, j, q)]
          for i, j, q in keys}  # fmt: skip
    surfs = dict(zip(keys, _surfaces([on[k] for k in keys])))
    b = BRep_Builder()
    lifted = _Lifted(b, (u, v, top), kept_v, (uk, vk))
    new = []
    for piece, us, key in zip(pieces, uses, tiles):  # one per piece of the face
        nf = _piece_face(b, TopoDS.Face_s(piece.Oriented(TopAbs_FORWARD)), us, surfs[key], subs[key], lifted, inner, key[2])
        new.append(TopoDS.Face_s(nf.Oriented(piece.Orientation())))
    return _replace_faces(shape, [(faces[0], new)] + list(zip(faces[1:], images[1:])))


def _placeable(us: list, inner) -> bool:
    """Can the piece with edge uses ``us`` go on the knots placed for OCCT's plain rule
    (:func:`texcad.brep.gprop.run_knots` per tile)? Only if each of its own edges (not
    ``inner``: those are lifted) is a straight iso line of the face, used once, not a
    pole's: its pcurve is then a broken line on the placed knots, exactly. A piece a
    trim curve crosses keeps the face's parameters (and OCCT's rule its few tenths of
    a per mille there)."""
    from OCP.BRep import BRep_Tool
    from OCP.GeomAbs import GeomAbs_Line

    own = [(e, c2) for e, c2 in us if not inner.Contains(e)]
    for e, c2 in own:  # the piece's own edges (a few)
        if BRep_Tool.Degenerated_s(e) or c2.GetType() != GeomAbs_Line or sum(1 for x, _ in own if x.IsSame(e)) > 1:
            return False
        dx, dy = c2.Line().Direction().Coord()
        if min(abs(dx), abs(dy)) > 1e-12:
            return False
    return True


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


def _piece_face(b, pf, us: list, tile: tuple, sub: tuple, lifted, inner, placed: bool):
    """The new face (forward) of the piece ``pf`` (its edge uses ``us``) on its tile's
    ``(surface, triangulation)``; ``sub`` the tile's ``(u, v, top)`` on the face's
    parameters: the piece's wires with the inner edges lifted (``lifted``), pcurves
    and tolerances. ``placed``: the surface is on the placed knots (the piece's own
    edges, iso lines, get broken lines onto them: :func:`_placeable`)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS_Face, TopoDS_Iterator, TopoDS_Wire

    surf, tri = tile
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
                ne, along_u, val, inc = lifted.edge(e, c2, tile[0], placed)
                use, pc, kept = ne.Oriented(e.Orientation() if inc else e.Reversed().Orientation()), lifted.pcurve(ne, along_u, val, placed), False
            elif placed:  # an iso line of the face: a broken line on the placed knots
                t0, t1 = c2.FirstParameter(), c2.LastParameter()
                use, pc, kept = e, _remapped(t0, t1, *_ends(c2), *lifted.knots, *lifted.placed), True
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
    _pcurves(b, nf, pf, curves, sub)
    if not any(kept for *_, kept in curves):  # a whole tile: its grid's triangulation
        b.UpdateFace(nf, tri)
    return nf


def _pcurves(b, nf, pf, curves: list, sub: tuple) -> None:
    """Each edge of ``curves`` ``[(edge, {orientation: pcurve}, kept)]`` gets its
    pcurves on the new face ``nf``; the piece's own (kept) edges the tolerance of their
    distance to the tile's surface ``sub`` ``(u, v, top)``, and their vertices too."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_VERTEX
    from OCP.TopoDS import TopoDS

    for e, pcs, kept in curves:  # one per edge of the piece
        edge = TopoDS.Edge_s(e.Oriented(TopAbs_FORWARD))
        tol = max(BRep_Tool.Tolerance_s(edge), TOLERANCE)
        if kept and not BRep_Tool.Degenerated_s(edge):
            tol = max(tol, 1.5 * _edge_deviation(edge, pf, *sub) + TOLERANCE)
        if len(pcs) == 2:
            b.UpdateEdge(edge, pcs[TopAbs_FORWARD], pcs[TopAbs_REVERSED], nf, tol)
        else:
            b.UpdateEdge(edge, next(iter(pcs.values())), nf, tol)
        if kept and BRep_Tool.Degenerated_s(edge):  # a pole's piece: its own range (no 3-D curve to take it from)
            b.Range(edge, nf, *BRep_Tool.Range_s(edge, pf))
        for x in explore(edge, TopAbs_VERTEX):  # its vertices at least as wide
            vx = TopoDS.Vertex_s(x)
            b.UpdateVertex(vx, max(BRep_Tool.Tolerance_s(vx), tol))
