"""B-rep of faces textured together: a smooth *patch* of several faces (a box's sides
with the fillets between them, a fillet band, any faces flattened together) whose
texture grid lies on no single face's parameter space.

The texture grid (rows and columns of points ``P`` on the part's tessellation, unit
normals ``N``, offsets ``h`` mm) covers the patch's meshed cells ``K``. The B-rep
replaces the part of the patch under ``K``, **without a boolean of the texture**:

* **tiles** (:func:`texcad.brep.tiled_grid_faces`, given ``leaves`` covering ``K``;
  knots placed per run of whole tiles and sides along ``y`` padded for OCCT's plain
  volume integration, :mod:`texcad.brep.gprop`) through ``P + h N``, the boundary points of ``K`` moved to a *wall height*
  ``w`` mm off the face (raised: ``+w``, engraved and centred: at most ``-w``), with
  ``w`` = the tessellation's chord error + twice the largest sag of the grid's
  edges at that point + 5 um, so that the tiles' boundary polyline stays off the
  exact face; where it crosses a crease between two of the patch's faces (two
  fillets meeting at a mitre, convex or concave: the grid's normals are smoothed
  over it), more, until the chords at ``+w`` and ``-w`` clear both faces' tangent
  planes there (:func:`_over_creases`);
* **walls**: per run of tile edges on ``K``'s boundary a degree-1 strip from them
  along ``N`` to the other side of the face (``-w`` or ``+w``), sharing the tile
  edge and the ruling edges at the tile corners;
* OCCT's general fuse (``BRepAlgoAPI_BuilderAlgo``) of the patch's faces and the
  strips cuts both along their exact intersection: the face pieces that keep an edge
  of the patch's outline stay, the rest of the faces (under the tiles) go, and of
  each strip the piece holding its tile edge stays (the step between the face and
  the tiles, ``w`` mm high at most); a kept piece the walls step along (an outline
  across the grid) is cut across into short pieces, which OCCT's mesher meshes
  closed (:func:`_cut_slivers`).

The tiles follow texcad's mesh (its grid points lie on the tessellation, as the
mesh's do), so the B-rep and the mesh enclose the same volume up to the walls'
steps (``w`` times half a cell along ``K``'s boundary). Every edge is shared: the
solid is closed by construction, and :func:`patch_solid` returns None where this
does not apply (a loop the fuse did not cut, an outline piece inside ``K``). A wall
the fuse does not cut (along a fillet's edge tangent to the side face past the
patch's outline, the wall crosses the part there, on a face not in the fuse: an L
plate's outer corner) has the cells on both sides of it left to the part's face
(the B-rep then differs from the mesh by their relief, a few cells), and the patch
is built once more; a :class:`~texcad.errors.TexcadWarning` says how many cells,
where, and that the STL and 3MF keep their relief.

A single planar face textured engraved or centred takes the same way
(:func:`signed_plane_solid`): its mesh keeps the cut's floor out to the cells'
outline and steps up to the face there, and so do the tiles and walls.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from ..errors import TexcadWarning
from ..util.runs import runs_within
from .occt import explore, face_in, general_fuse, to_topods
from .gprop import polyline_pcurve, run_knots, split_at_knots
from .solids import TILE, TOLERANCE, _band_fine, _replace_faces, _tile_bounds, grid_surface, tiled_grid_faces

__all__ = ["patch_solid", "signed_plane_solid", "face_in", "wall_height", "PATCH_TILE", "creases"]

#: Tiles of a patch are at most this many cells a side. With the tiles' knots placed
#: for OCCT's plain Gauss integration (build123d's ``.volume``; :mod:`texcad.brep.gprop`)
#: the B-rep's plain volume is within 0.01 % of the mesh at 4 cells on the bands of
#: ``tests/brep/test_face_kinds_bands.py`` (stones at 0.5 mm, raised, engraved and
#: centred), 0.05 % at 8 and 0.03 % at 24 (knots at the grid index: 0.07 % at 4,
#: 0.2 % at 8).
PATCH_TILE = 4
#: mm added to the wall height over the chord error and the grid's sag.
WALL_MARGIN = 0.005


def _layout(points, normals, heights, cells, wrap: bool):
    """The grid transposed so that texture rows run along the tile columns (a closed
    band then closes in x, as :func:`tiled_grid_faces` wants, its first column
    repeated at the end) and oriented so that ``S_u x S_v`` points along ``N``:
    ``(G, N, H, K)`` with ``K`` the cells ``(rows - 1, columns - 1)``."""
    G, N = np.asarray(points, np.float64).transpose(1, 0, 2), np.asarray(normals, np.float64).transpose(1, 0, 2)
    H, K = np.asarray(heights, np.float64).T, np.asarray(cells, bool).T
    if wrap:
        G, N, H = (np.concatenate([a, a[:, :1]], axis=1) for a in (G, N, H))
    du, dv = G[:-1, 1:] - G[:-1, :-1], G[1:, :-1] - G[:-1, :-1]
    if float((np.cross(du, dv) * N[:-1, :-1])[K].sum()) < 0:  # rows the other way round
        G, N, H, K = G[::-1], N[::-1], H[::-1], K[::-1]
    return np.ascontiguousarray(G), np.ascontiguousarray(N), np.ascontiguousarray(H), np.ascontiguousarray(K)


def _padded(K: np.ndarray, wrap: bool) -> np.ndarray:
    """``K`` with a ring of cells around it: empty, or the wrapped columns (a band)."""
    cols = [K[:, -1:], K, K[:, :1]] if wrap else [np.zeros((K.shape[0], 1), bool), K, np.zeros((K.shape[0], 1), bool)]
    Kc = np.concatenate(cols, axis=1)
    z = np.zeros((1, Kc.shape[1]), bool)
    return np.concatenate([z, Kc, z])


def _corners(K: np.ndarray, wrap: bool) -> np.ndarray:
    """``(4, R, C)`` the four cells around every grid point ``(R, C)``: below-left,
    below-right, above-left, above-right (False off the grid)."""
    Kp = _padded(K, wrap)
    return np.stack([Kp[:-1, :-1], Kp[:-1, 1:], Kp[1:, :-1], Kp[1:, 1:]])


def _unpinched(K: np.ndarray, wrap: bool) -> np.ndarray:
    """``K`` without cells that meet another only at a corner (a pinch would make a
    boundary loop pass a point twice): both cells of such a pair are left out, in
    rounds, until there are none (None if nothing is left)."""
    K = K.copy()
    for _ in range(16):  # rounds: a removal can make a new pinch beside it
        a, b, c, d = _corners(K, wrap)
        pinch = (a & d & ~b & ~c) | (b & c & ~a & ~d)
        if not pinch.any():
            return K if K.any() else None
        r, q = np.nonzero(pinch)
        for dr, dc in ((-1, -1), (-1, 0), (0, -1), (0, 0)):  # the four cells at each pinch point
            rr, cc = r + dr, q + dc
            ok = (rr >= 0) & (rr < K.shape[0]) & (((cc >= 0) & (cc < K.shape[1])) | wrap)
            K[rr[ok], cc[ok] % K.shape[1]] = False
    return None


def wall_height(G: np.ndarray, N: np.ndarray, K: np.ndarray, chord: float, wrap: bool = False) -> np.ndarray:
    """``(R, C)`` mm each grid point must stand off the face on a tile boundary: the
    tessellation's ``chord`` error, plus twice the largest sag of the cells' edges
    at the point (``|e| |N_b - N_a| / 8``, the chord of a curve with the normals'
    turn), plus :data:`WALL_MARGIN` (a boundary segment's chord then stays off the
    exact face: its sag is at most its ends'). ``wrap``: the last column is the
    first (they get the larger of the two)."""
    rows = np.pad(K, ((0, 0), (1, 1)))
    cols = np.pad(K, ((1, 1), (0, 0)))
    sag = np.zeros(G.shape[:2])
    for ax, on in ((0, rows[:, :-1] | rows[:, 1:]), (1, cols[:-1] | cols[1:])):  # edges along the columns, the rows
        e = np.linalg.norm(np.diff(G, axis=ax), axis=-1) * np.linalg.norm(np.diff(N, axis=ax), axis=-1) / 8.0
        e = np.where(on, e, 0.0)  # the cells' edges only (points off the patch hold no geometry)
        lo, hi = [slice(None)] * 2, [slice(None)] * 2
        lo[ax], hi[ax] = slice(None, -1), slice(1, None)
        sag[tuple(lo)] = np.maximum(sag[tuple(lo)], e)
        sag[tuple(hi)] = np.maximum(sag[tuple(hi)], e)
    if wrap:
        sag[:, 0] = sag[:, -1] = np.maximum(sag[:, 0], sag[:, -1])
    return chord + 2.0 * sag + WALL_MARGIN


#: Degrees: an edge between two faces of a patch whose normals differ by more than this
#: is a crease (a mitre between fillets): the walls that cross it are raised over it.
CREASE_ANGLE = 1.0


def _creases(faces: list, step: float) -> tuple:
    """Points along the creases between the patch ``faces`` (edges two of them share,
    where their normals differ by more than :data:`CREASE_ANGLE`), at most ``step``
    mm apart: ``(points (M, 3) mm, n1 (M, 3), n2 (M, 3))`` with the two faces'
    outward unit normals there."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    from .occt import compound

    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(compound(list(faces)), TopAbs_EDGE, TopAbs_FACE, emap)
    out = []
    for k in range(1, emap.Extent() + 1):  # one per edge of the patch
        owners = [TopoDS.Face_s(f) for f in emap.FindFromIndex(k)]
        if len(owners) != 2 or owners[0].IsSame(owners[1]):  # the outline, or a seam
            continue
        e = TopoDS.Edge_s(emap.FindKey(k))
        c = BRepAdaptor_Curve(e)
        t0, t1 = c.FirstParameter(), c.LastParameter()
        got = _edge_normals(e, c, owners, np.linspace(t0, t1, 9))
        if not len(got[0]):  # smooth all along (a tangent edge)
            continue
        ends = np.array([c.Value(t).Coord() for t in (t0, t1)])
        n = max(2, int(np.ceil(_curve_length(c, t0, t1, ends) / step)) + 1)
        out.append(_edge_normals(e, c, owners, np.linspace(t0, t1, n)))
    if not out:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3))
    return tuple(np.concatenate(a) for a in zip(*out))


creases = _creases  # public: the engraving cutters of texcad.targets.patches rise over these too


def _edge_normals(e, c, owners: list, ts: np.ndarray) -> tuple:
    """The points of the edge ``e`` (curve adaptor ``c``) at the parameters ``ts``
    where its two faces ``owners`` meet at a crease, and their outward unit normals
    there: ``(points, n1, n2)``, each ``(M, 3)``."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d, BRepAdaptor_Surface
    from OCP.TopAbs import TopAbs_REVERSED

    pts = np.array([c.Value(float(t)).Coord() for t in ts])  # a few per edge
    nrm = []
    for f in owners:  # the two faces
        pc, sf = BRepAdaptor_Curve2d(e, f), BRepAdaptor_Surface(f)
        sign = -1.0 if f.Orientation() == TopAbs_REVERSED else 1.0
        nrm.append(np.array([_surface_normal(sf, pc.Value(float(t))) for t in ts]) * sign)
    keep = (nrm[0] * nrm[1]).sum(axis=1) < np.cos(np.radians(CREASE_ANGLE))
    return pts[keep], nrm[0][keep], nrm[1][keep]


def _curve_length(c, t0: float, t1: float, ends: np.ndarray) -> float:
    """mm, the length of the curve ``c`` from ``t0`` to ``t1`` (``ends`` its end points)."""
    from OCP.GCPnts import GCPnts_AbscissaPoint

    try:
        return float(GCPnts_AbscissaPoint.Length_s(c, t0, t1))
    except Exception:  # OCCT could not integrate it: the chord
        return float(np.linalg.norm(ends[1] - ends[0]))


def _surface_normal(sf, uv) -> np.ndarray:
    """The unit normal ``S_u x S_v`` of the surface adaptor ``sf`` at the 2D point ``uv``."""
    from OCP.gp import gp_Pnt, gp_Vec

    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    sf.D1(uv.X(), uv.Y(), p, du, dv)
    n = np.cross(du.Coord(), dv.Coord())
    return n / max(float(np.linalg.norm(n)), 1e-18)


def _cell_size(G: np.ndarray, K: np.ndarray) -> float:
    """mm, the median length of the cells' edges along the grid rows."""
    return float(np.median(np.linalg.norm(G[:-1, 1:] - G[:-1, :-1], axis=-1)[K]))


def _over_creases(w: np.ndarray, G: np.ndarray, N: np.ndarray, edge: np.ndarray, creases: tuple, wrap: bool = False) -> np.ndarray:
    """The wall heights ``w`` (mm, ``(R, C)``) raised where a boundary segment crosses
    a crease (the normals ``N`` are smoothed over it, so the sag estimate of
    :func:`wall_height` misses its kink): the chord from ``G_a + w_a N_a`` to ``G_b +
    w_b N_b`` must stay :data:`WALL_MARGIN` mm outside the part (over a convex crease
    it dips: above the roof of the two faces' tangent planes at the crease point
    nearest its middle) and the chord from ``G_a - w_a N_a`` to ``G_b - w_b N_b`` as
    far inside (under a concave crease it rises: under the valley of the planes).
    The tiles' boundary and the walls' other side are these chords (raised: the
    outer one is the tiles'; engraved and centred: the inner one, or deeper).
    ``edge``: the boundary grid points; ``wrap``: the last column is the first."""
    from scipy.spatial import cKDTree

    c, n1, n2 = creases
    if not len(c) or not edge.any():
        return w
    w = w.copy()
    segs = []
    for ax in (0, 1):  # grid segments along the columns, the rows
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[ax], hi[ax] = slice(None, -1), slice(1, None)
        ia = np.stack(np.nonzero(edge[tuple(lo)] & edge[tuple(hi)]), axis=1)
        segs.append(np.concatenate([ia, ia + np.eye(2, dtype=int)[ax]], axis=1))
    s = np.concatenate(segs)
    a, b = (s[:, 0], s[:, 1]), (s[:, 2], s[:, 3])
    mid = 0.5 * (G[a] + G[b])
    length = np.linalg.norm(G[b] - G[a], axis=1)
    dist, near = cKDTree(c).query(mid)
    on = dist <= length  # the segments across a crease
    a, b, near = (a[0][on], a[1][on]), (b[0][on], b[1][on]), near[on]
    p1, p2, q = n1[near], n2[near], c[near]
    slope = np.minimum(np.maximum((N[a] * p1).sum(1), (N[a] * p2).sum(1)),
                       np.maximum((N[b] * p1).sum(1), (N[b] * p2).sum(1)))  # clearance gained per mm of w
    for _ in range(8):  # rounds: raise both ends until both chords clear the faces
        low = np.full(len(q), np.inf)
        for side in (1.0, -1.0):  # outside (convex creases), inside (concave)
            A, B = G[a] + side * w[a][:, None] * N[a] - q, G[b] + side * w[b][:, None] * N[b] - q
            low = np.minimum(low, _roof_clearance(A, B, side * p1, side * p2))
        short = low < WALL_MARGIN
        if not short.any():
            break
        lift = np.where(short, (WALL_MARGIN - low) / np.maximum(slope, 0.3) + WALL_MARGIN, 0.0)
        np.maximum.at(w, a, w[a] + lift)
        np.maximum.at(w, b, w[b] + lift)
    if wrap:
        w[:, 0] = w[:, -1] = np.maximum(w[:, 0], w[:, -1])
    return w


def _roof_clearance(A: np.ndarray, B: np.ndarray, n1: np.ndarray, n2: np.ndarray) -> np.ndarray:
    """``(S,)`` the least height over the segments ``A -> B`` (``(S, 3)`` mm, relative
    to a point of a convex crease) of the roof of the planes with normals ``n1``,
    ``n2`` through that point: ``min_t max(n1 . P(t), n2 . P(t))`` (convex and
    piecewise linear in ``t``: its least value is at an end or where the two meet)."""
    a1, b1 = (A * n1).sum(1), (B * n1).sum(1)
    a2, b2 = (A * n2).sum(1), (B * n2).sum(1)
    den = (a1 - b1) - (a2 - b2)
    t = np.clip(np.divide(a1 - a2, den, out=np.zeros_like(den), where=np.abs(den) > 1e-18), 0.0, 1.0)
    meet = np.maximum(a1 + t * (b1 - a1), a2 + t * (b2 - a2))
    return np.minimum(np.minimum(np.maximum(a1, a2), np.maximum(b1, b2)), meet)


def _loops(edges: dict, K: np.ndarray, period: int | None) -> list:
    """The boundary of the cells ``K`` as closed loops of tile edges, each
    ``[(edge, key, forward), ...]`` counter-clockwise about the cells (about ``S_u x
    S_v``): ``key`` ``(horizontal, line, a, z)`` as :func:`tiled_grid_faces` keys it,
    ``forward`` whether the loop runs it from ``a`` to ``z`` (grid columns wrap by
    ``period`` on a closed band)."""
    from OCP.TopoDS import TopoDS

    R, C = K.shape

    def cell(r, c):
        if period is not None:
            c %= period
        return bool(0 <= r < R and 0 <= c < C and K[r, c])

    def vid(r, c):
        return (r, c % period) if period is not None else (r, c)

    nxt = {}
    for key, (e, _) in edges.items():  # every tile edge
        horizontal, line, a, z = key
        if horizontal:
            above, below = cell(line, a), cell(line - 1, a)
            if above == below:
                continue
            fwd, ends = above, ((line, a), (line, z))
        else:
            right, left = cell(a, line), cell(a, line - 1)
            if right == left:
                continue
            fwd, ends = not right, ((a, line), (z, line))
        start, end = (ends[0], ends[1]) if fwd else (ends[1], ends[0])
        nxt[vid(*start)] = (e if fwd else TopoDS.Edge_s(e.Reversed()), key, fwd, vid(*end))
    loops = []
    while nxt:  # one per loop
        first = next(iter(nxt))
        loop, at = [], first
        while True:  # one per edge of the loop
            e, key, fwd, at = nxt.pop(at)
            loop.append((e, key, fwd))
            if at == first:
                break
        loops.append(loop)
    return loops


class _Walls:
    """The wall strips along the loops of tile edges (see the module): one face per
    run of tile edges along a grid line (:func:`_runs`), sharing those edges, and the
    ruling edges at the runs' ends and their vertices with the next runs. ``top``:
    ``(R, C, 3)`` the tiles' grid (mm); ``other``: the strips' other side."""

    def __init__(self, top: np.ndarray, other: np.ndarray, period: int | None, knots: tuple):
        from OCP.BRep import BRep_Builder

        self.b, self.top, self.other, self.period = BRep_Builder(), top, other, period
        self.knots = knots  # (x, y): the tiles' knots at the grid columns and rows
        self.rulings: dict = {}

    def _vid(self, r: int, c: int) -> tuple:
        return (r, c % self.period) if self.period is not None else (r, c)

    def _ruling(self, surf, at: float, vt, r: int, c: int):
        """The straight edge from the tile corner ``vt`` (grid point ``(r, c)``) to the
        strip's other side: the strip ``surf``'s iso-line at ``u = at``, ``v`` 0 .. 1
        (the neighbouring strip's iso-line there is the same line, same parameter)."""
        from OCP.gp import gp_Pnt
        from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
        from OCP.TopoDS import TopoDS_Edge, TopoDS_Vertex

        k = self._vid(r, c)
        if k not in self.rulings:
            vo = TopoDS_Vertex()
            self.b.MakeVertex(vo, gp_Pnt(*map(float, self.other[r, c])), TOLERANCE)
            e = TopoDS_Edge()
            self.b.MakeEdge(e, surf.UIso(float(at)), TOLERANCE)
            self.b.Add(e, vt.Oriented(TopAbs_FORWARD))
            self.b.Add(e, vo.Oriented(TopAbs_REVERSED))
            self.b.Range(e, 0.0, 1.0)
            self.rulings[k] = (e, vo)
        return self.rulings[k]

    def _indices(self, run: list) -> tuple:
        """Grid indices ``(rows, cols)`` along a run of tile edges on one grid line,
        in the loop's order (joins counted once)."""
        rows, cols = [], []
        for k, (_, key, fwd) in enumerate(run):  # one per tile edge
            horizontal, line, a, z = key
            idx = np.arange(a, z + 1) if fwd else np.arange(z, a - 1, -1)
            idx = idx if k == 0 else idx[1:]
            rows.append(np.full(len(idx), line) if horizontal else idx)
            cols.append(idx if horizontal else np.full(len(idx), line))
        return np.concatenate(rows), np.concatenate(cols)

    def _pcurve(self, key: tuple, start: int, fwd: bool):
        """The pcurve on a strip of the tile edge ``key`` (parameter: the tiles' knots)
        that starts at the strip's ``u = start`` (grid index; ``fwd``: the loop runs the
        edge from ``a`` to ``z``): the broken line through ``(u, 0)`` at the knots."""
        a, z = key[2], key[3]
        knots = (self.knots[0] if key[0] else self.knots[1])[a : z + 1]
        u = start + (np.arange(z + 1 - a) if fwd else np.arange(z - a, -1, -1))
        return polyline_pcurve(np.stack([u, np.zeros_like(u)], axis=-1).astype(np.float64), knots, pad=False)

    def strip(self, run: list):
        """The wall face along a run of tile edges on one grid line (``[(edge
        oriented the loop's way, key, forward), ...]``): ``(face, top points, other
        points)``, its normal ``S_u x S_v`` with ``u`` the loop's way and ``v`` from the
        tiles to the other side. A run all around a closed band closes on a seam."""
        from OCP.Geom2d import Geom2d_Line
        from OCP.gp import gp_Dir2d, gp_Pnt2d
        from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
        from OCP.TopExp import TopExp
        from OCP.TopoDS import TopoDS_Edge, TopoDS_Face, TopoDS_Vertex, TopoDS_Wire

        b = self.b
        rows, cols = self._indices(run)
        T, O = self.top[rows, cols], self.other[rows, cols]
        u = np.arange(len(T), dtype=np.float64)
        surf = grid_surface(np.stack([T, O]), u, np.array([0.0, 1.0]))
        face = TopoDS_Face()
        b.MakeFace(face, surf, TOLERANCE)

        def line(p, d):
            return Geom2d_Line(gp_Pnt2d(*p), gp_Dir2d(*d))

        start = 0
        for e, key, fwd in run:  # the tile edges: their parameter is the tile knot, the strip's u the grid index
            a, z = key[2], key[3]
            b.UpdateEdge(e, self._pcurve(key, start, fwd), face, TOLERANCE)
            start += z - a
        va, vz = TopoDS_Vertex(), TopoDS_Vertex()
        TopExp.Vertices_s(run[0][0], va, TopoDS_Vertex(), True)
        TopExp.Vertices_s(run[-1][0], TopoDS_Vertex(), vz, True)
        closed = va.IsSame(vz)
        ra, oa = self._ruling(surf, u[0], va, int(rows[0]), int(cols[0]))
        rz, oz = (ra, oa) if closed else self._ruling(surf, u[-1], vz, int(rows[-1]), int(cols[-1]))
        bottom = TopoDS_Edge()
        b.MakeEdge(bottom, surf.VIso(1.0), TOLERANCE)
        b.Add(bottom, oa.Oriented(TopAbs_FORWARD))
        b.Add(bottom, oz.Oriented(TopAbs_REVERSED))
        b.Range(bottom, float(u[0]), float(u[-1]))
        b.UpdateEdge(bottom, line((0.0, 1.0), (1.0, 0.0)), face, TOLERANCE)
        if closed:  # a seam: its pcurves at u = end (as the wire runs it forward) and u = 0
            b.UpdateEdge(ra, line((float(u[-1]), 0.0), (0.0, 1.0)), line((0.0, 0.0), (0.0, 1.0)), face, TOLERANCE)
        else:
            b.UpdateEdge(ra, line((0.0, 0.0), (0.0, 1.0)), face, TOLERANCE)
            b.UpdateEdge(rz, line((float(u[-1]), 0.0), (0.0, 1.0)), face, TOLERANCE)
        w = TopoDS_Wire()
        b.MakeWire(w)
        for piece in [e for e, _, _ in run] + [rz, bottom.Reversed(), ra.Reversed()]:  # counter-clockwise in (u, v)
            b.Add(w, piece)
        w.Closed(True)
        b.Add(face, w)
        return face, T, O


#: Most grid cells a wall strip runs along (OCCT's fuse intersects short strips reliably).
RUN = 24


def _runs(loop: list, most: int = RUN) -> list:
    """A loop's tile edges in runs along one grid line (a run does not turn a corner)
    of at most ``most`` cells (one tile edge at least)."""
    line = [(key[0], key[1]) for _, key, _ in loop]
    cut = [k for k in range(len(loop)) if line[k] != line[k - 1]] or [0]
    loop = loop[cut[0]:] + loop[: cut[0]]
    cut = [k - cut[0] for k in cut] + [len(loop)]
    out = []
    for a, z in zip(cut[:-1], cut[1:]):  # one per straight stretch
        stretch = loop[a:z]
        runs = runs_within([item[1][3] - item[1][2] for item in stretch], most)  # cells per tile edge
        out.extend([stretch[k] for k in r] for r in runs)
    return out


def _leaves_over(K: np.ndarray, tile: int, fine) -> list | None:
    """Tiles ``(r0, r1, c0, c1)`` covering exactly the cells ``K``, laid from the
    corner of ``K``'s bounding box (so that a band of whole rows needs no small
    tiles), at most :data:`~texcad.brep.FINE` cells a side in the ``fine`` index
    rectangles."""
    from .uvfaces import _quad_leaves

    rows, cols = np.nonzero(K.any(axis=1))[0], np.nonzero(K.any(axis=0))[0]
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    sub = K[r0:r1, c0:c1]
    shifted = [(f[0] - r0, f[1] - r0, f[2] - c0, f[3] - c0, *f[4:]) for f in fine or ()]
    got = _quad_leaves(sub, ~sub, tile, shifted or None)
    return None if got is None else [(a + r0, b + r0, c + c0, d + c0) for a, b, c, d in got]


def _runs_over(K: np.ndarray, tile: int) -> tuple:
    """The runs of cells ``(rows, columns)``, each a list of ``(a, z)`` grid lines,
    of :func:`_leaves_over`'s whole tiles (before any is halved near the outline or
    made small under a tool): their knots are placed for OCCT's plain Gauss rule
    (:func:`texcad.brep.gprop.run_knots`). A smaller tile keeps its run's knots (the
    edges it shares stay as its neighbours'): its nodes are then not placed, but 61
    of them (:func:`_pad_sides`) lie closer than its cells (measured: within 0.02 %
    on engraved and centred plates with holes and notches)."""
    rows, cols = np.nonzero(K.any(axis=1))[0], np.nonzero(K.any(axis=0))[0]
    out = []
    for a in (rows, cols):  # rows, columns
        b = int(a[0]) + _tile_bounds(int(a[-1]) + 1 - int(a[0]), tile)
        out.append(list(zip(b[:-1].tolist(), b[1:].tolist())))
    return tuple(out)


def _placed(n: int, runs: list) -> np.ndarray:
    """``n`` knots at the grid index, placed for OCCT's plain Gauss rule in the
    ``runs`` ``[(a, z), ...]`` (consecutive grid lines)."""
    return run_knots(np.arange(n, dtype=np.float64), [runs[0][0]] + [z for _, z in runs])


def _pad_sides(edges: dict, leaves: list, tiles: list, x: np.ndarray, y: np.ndarray, period: int | None) -> None:
    """Give the tile edges along ``y`` pcurves of :data:`~texcad.brep.gprop.PAD_SPANS`
    spans or more on each of their tiles (the same line), so that OCCT's plain volume
    integration puts its 61 Gauss points along them and across the tile, as the knots
    of the runs of whole tiles are placed for (:mod:`texcad.brep.gprop`); on a small
    tile (near the outline, under a tool) the 61 points lie closer than its cells."""
    from OCP.BRep import BRep_Builder

    along: dict = {}
    for key in edges:  # every tile edge: those along y by grid column
        if not key[0]:
            along.setdefault(key[1], []).append(key)
    b = BRep_Builder()
    for k, (r0, r1, c0, c1) in enumerate(leaves):  # one per tile
        for c in (c0, c1):  # its two sides along y
            for key in along.get(c % period if period is not None else c, ()):  # the edges on the side
                lo, hi = key[2], key[3]
                if r0 <= lo and hi <= r1:
                    pts = np.stack([np.full(hi + 1 - lo, x[c]), y[lo : hi + 1]], axis=-1)
                    b.UpdateEdge(edges[key][0], polyline_pcurve(pts, y[lo : hi + 1]), tiles[k], TOLERANCE)


def _outline_edges(topo, faces: list) -> list:
    """The edges of the patch ``faces`` that a face outside the patch shares (its
    outline in the part)."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(topo, TopAbs_EDGE, TopAbs_FACE, emap)
    out = []
    for f in faces:  # one per face of the patch
        for e in explore(f, TopAbs_EDGE):  # its edges
            owners = emap.FindFromKey(e)
            if any(not any(o.IsSame(p) for p in faces) for o in owners):  # a few owners
                out.append(e)
    return out


def _pieces(gf, shape) -> list:
    """What the general fuse made of ``shape`` (itself if it was not split)."""
    mod = gf.Modified(shape)
    if mod.Size() == 0:
        return [] if gf.IsDeleted(shape) else [shape]
    return list(mod)


def _without_internal(face):
    """``face`` without its INTERNAL edges: what OCCT's general fuse leaves of a cut
    line that divides nothing (one from a wall's corner to a hole's rim in the piece
    only joins the outline to the hole); ``BRepCheck`` calls such a face's wires
    intersecting. The same face where it has none."""
    from OCP.BRep import BRep_Builder
    from OCP.TopAbs import TopAbs_INTERNAL
    from OCP.TopoDS import TopoDS, TopoDS_Wire

    wires = [(w, _raw(w)) for w in _raw(face)]  # per wire: its edges, as stored
    if not any(e.Orientation() == TopAbs_INTERNAL for _, edges in wires for e in edges):
        return face
    b, out = BRep_Builder(), TopoDS.Face_s(face.EmptyCopied())
    for w, edges in wires:  # per wire: its other edges, in order
        edges = [e for e in edges if e.Orientation() != TopAbs_INTERNAL]
        if not edges:
            continue
        nw = TopoDS_Wire()
        b.MakeWire(nw)
        for e in edges:
            b.Add(nw, e)
        nw.Closed(True)
        nw.Location(w.Location())
        b.Add(out, nw.Oriented(w.Orientation()))
    return out


def _raw(shape) -> list:
    """The sub-shapes of ``shape`` one level down, as stored in it (their own
    orientations and locations, not composed with ``shape``'s), in order."""
    from OCP.TopoDS import TopoDS_Iterator

    it, out = TopoDS_Iterator(shape, False, False), []
    while it.More():
        out.append(it.Value())
        it.Next()
    return out


def _has_edge(face, edges: list) -> bool:
    from OCP.TopAbs import TopAbs_EDGE

    return any(e.IsSame(o) for e in explore(face, TopAbs_EDGE) for o in edges)


def patch_solid(shape: Any, faces: list, points: np.ndarray, normals: np.ndarray, heights: np.ndarray, cells: np.ndarray, *,
                wrap: bool, signed: bool, chord: float, tile: int = PATCH_TILE, fine=None):
    """``shape`` with the smooth patch ``faces`` (as they lie in it) textured in
    place, in tiles with walls (module docstring).

    Args:
        points, normals: ``(R, C, 3)`` grid points on the patch's tessellation (mm) and
            unit outward normals; rows close around when ``wrap``.
        heights: ``(R, C)`` offsets along the normals, mm (raised: only the part above
            the face counts; ``signed``: engraved or centred, as they are).
        cells: bool ``(R - 1, C - 1)`` (``(R, C - 1)`` when ``wrap``), the meshed cells.
        chord: mm, how far the grid points may lie off the exact faces (the
            tessellation's chord error).
        fine: boxes ``(lo (3,), hi (3,)[, cells])`` mm where the tiles are small (a CAD
            operation's tool).

    Returns:
        The new shape, or None where this does not apply.
    """
    topo = to_topods(shape)
    G, N, H, K = _layout(points, normals, heights, cells, wrap)
    out = _patch_over(topo, faces, (G, N, H), K, wrap, signed, chord, tile, fine)
    if isinstance(out, list):  # walls the fuse did not cut: the cells beside them left to the part's face, once
        left = np.zeros_like(K)
        for rows, cols in out:  # one per wall not cut
            left[_beside(rows, cols, K.shape, wrap)] = True
        left &= K
        out = _patch_over(topo, faces, (G, N, H), K & ~left, wrap, signed, chord, tile, fine)
        if not isinstance(out, list) and out is not None:
            _warn_left_out(G, left)
    return None if isinstance(out, list) else out


def _warn_left_out(G: np.ndarray, left: np.ndarray) -> None:
    """A :class:`~texcad.errors.TexcadWarning` that the cells ``left`` (of the grid
    ``G``, laid out by :func:`_layout`) are left to the part's face in the B-rep: how
    many, and the centre of their centres in mm."""
    r, c = np.nonzero(left)
    at = (G[r, c] + G[r + 1, c] + G[r, c + 1] + G[r + 1, c + 1]).mean(axis=0) / 4.0
    where = ", ".join(f"{v:.1f}" for v in at.tolist())
    warnings.warn(
        f"{len(r)} texture cells around ({where}) mm are left untextured in the B-rep (STEP): OCCT's fuse did not "
        "cut a wall there (a fillet's edge tangent to the face below it); the STL and 3MF keep their relief",
        TexcadWarning,
        stacklevel=3,
    )


def _beside(rows: np.ndarray, cols: np.ndarray, shape: tuple, wrap: bool) -> tuple:
    """Index arrays of the cells (of ``shape``) on both sides of each grid edge
    between consecutive grid points ``(rows, cols)`` of a wall (along one grid line)."""
    r, c = np.minimum(rows[:-1], rows[1:]), np.minimum(cols[:-1], cols[1:])
    across = rows[:-1] == rows[1:]  # an edge along a row: the cells below and above it
    rr = np.concatenate([np.where(across, r - 1, r), r])
    cc = np.concatenate([c, np.where(across, c, c - 1)])
    if wrap:
        cc %= shape[1]
    ok = (rr >= 0) & (rr < shape[0]) & (cc >= 0) & (cc < shape[1])
    return rr[ok], cc[ok]


def _patch_over(topo, faces: list, grid: tuple, K: np.ndarray, wrap: bool, signed: bool, chord: float, tile: int, fine):
    """:func:`patch_solid` over the cells ``K`` (``grid``: ``(G, N, H)`` laid out by
    :func:`_layout`): the new shape, None, or the walls the fuse did not cut
    (:func:`_walled`)."""
    G, N, H = grid
    K = _unpinched(K, wrap)
    if K is None:
        return None
    period = G.shape[1] - 1 if wrap else None
    around = _corners(K, wrap).sum(axis=0)
    edge = (around > 0) & (around < 4)
    w = wall_height(G, N, K, chord, wrap)
    w = _over_creases(w, G, N, edge, _creases(faces, 0.25 * _cell_size(G, K)), wrap)
    return _walled(topo, faces, (G, N, H, K, edge, period), w, signed, tile, fine)


def _walled(topo, faces: list, grid: tuple, w: np.ndarray, signed: bool, tile: int, fine):
    """:func:`patch_solid` from the wall height ``w`` on (``grid``: ``(G, N, H, K,
    edge, period)``): the tiles, the walls and their fuse (:func:`_assemble`): the new
    shape, None, or the grid indices ``[(rows, cols), ...]`` of the walls the fuse did
    not cut."""
    G, N, H, K, edge, period = grid
    wrap = period is not None
    h = H if signed else np.maximum(H, 0.0)
    h = np.where(edge, np.minimum(h, -w) if signed else w, h)
    top = G + h[..., None] * N
    other = G + (w if signed else -w)[..., None] * N
    leaves = _leaves_over(K, tile, _band_fine(top, fine))
    if not leaves:
        return None
    runs = _runs_over(K, tile)  # knots placed per run of whole tiles for OCCT's plain Gauss rule
    x, y = _placed(G.shape[1], runs[1]), _placed(G.shape[0], runs[0])
    edges: dict = {}
    tiles, _ = tiled_grid_faces(top, x, y, leaves=leaves, wrap_x=wrap, edges_out=edges)
    _pad_sides(edges, leaves, tiles, x, y, period)
    try:
        loops = _loops(edges, K, period)
    except KeyError:  # a loop that does not close
        return None
    walls = _Walls(top, other, period, (x, y))
    strips = []
    for loop in loops:  # one per boundary loop
        for run in _runs(loop):  # one per straight run of tile edges
            face, T, O = walls.strip(run)
            e, key, _ = run[0]
            travel = T[1] - T[0]  # the loop's way, the cells on its left
            away = np.cross(travel, _mid_normal(N, key))  # away from the cells, along the face
            nrm = np.cross(travel, O[0] - T[0])  # the strip's S_u x S_v there
            want = -1.0 if signed else 1.0  # raised: the wall faces away from the tiles; engraved: towards them
            strips.append((face if float(nrm @ away) * want > 0 else face.Reversed(), e, walls._indices(run)))
    return _assemble(topo, faces, tiles, strips, _cell_size(G, K))


def signed_plane_solid(shape: Any, face: Any, points: np.ndarray, normals: np.ndarray, heights: np.ndarray, cells: np.ndarray, *,
                       frame: tuple, tile: int = TILE, fine=None):
    """``shape`` with one planar ``face`` textured engraved or centred, as texcad's
    mesh has it: :func:`patch_solid` (tiles through ``points + heights normals``, a
    wall along the cells' outline from the tiles up to the face, the face kept
    outside it), so the B-rep keeps the mesh's floor (the cut ``2 FLOOR_CURVED`` or
    ``3 FLOOR_CURVED`` mm under the face along the outline band) and its step at the
    cells' outline, where a plain rim ramped into the tiles would enclose
    ``floor x rim`` mm^3 more (0.15 % of a 20 mm box, centred).

    Args:
        points, normals, heights, cells: as :func:`patch_solid` (``heights``: the
            fused mesh's offset, signed, mm).
        frame: ``(origin, xdir, ydir, normal)`` mm, the face frame ``fine`` is given in.
        tile: most cells a tile side (the face's plane stays exact: no Gauss-rule
            limit as on curved patches).
        fine: rectangles ``(x0, x1, y0, y1[, cells])`` mm in ``frame``, or boxes
            ``(lo (3,), hi (3,)[, cells])`` mm, where a CAD operation's tool is.

    Returns:
        The new shape, or None where this does not apply.
    """
    reach = float(np.nanmax(np.abs(heights))) + 1.0  # mm: a rectangle's box along the normal
    boxes = [_rect_box(f, frame, reach) for f in fine or ()]
    return patch_solid(shape, [face], points, normals, heights, cells, wrap=False, signed=True, chord=0.0, tile=tile,
                       fine=boxes or None)


def _rect_box(f: tuple, frame: tuple, reach: float) -> tuple:
    """A rectangle ``(x0, x1, y0, y1[, cells])`` mm in the face ``frame`` as the box
    ``(lo, hi[, cells])`` mm around it, ``reach`` mm off the plane either side (a
    box is passed through)."""
    if np.ndim(f[0]) == 1:
        return tuple(f)
    o, ex, ey, n = (np.asarray(a, np.float64) for a in frame)
    xy = np.array([(x, y) for x in f[:2] for y in f[2:4]], np.float64)
    corners = o + xy[:, :1] * ex + xy[:, 1:] * ey
    corners = np.concatenate([corners + reach * n, corners - reach * n])
    return (corners.min(axis=0), corners.max(axis=0), *f[4:])


def _mid_normal(N: np.ndarray, key) -> np.ndarray:
    """The grid normal halfway along the tile edge ``key``."""
    horizontal, line, a, z = key
    m = (a + z) // 2
    if horizontal:
        return N[line, m]
    return N[m, line]


def _outside(pieces: list, outline: list, walls: list) -> list:
    """The face pieces outside the tiles: those joined to a piece with an edge of the
    patch's outline by edges other than the walls' (the walls' section edges part
    the pieces under the tiles from the rest)."""
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopTools import TopTools_IndexedMapOfShape

    emap = TopTools_IndexedMapOfShape()
    cut = {emap.Add(e) for w in walls for e in explore(w, TopAbs_EDGE)}  # one per wall edge
    rim = {emap.Add(e) for e in outline}
    edges = [{emap.Add(e) for e in explore(p, TopAbs_EDGE)} for p in pieces]  # one per piece
    out = {k for k, es in enumerate(edges) if es & rim}
    todo = list(out)
    while todo:  # flood across shared edges that are not the walls'
        k = todo.pop()
        for j, es in enumerate(edges):  # a few dozen pieces
            if j not in out and (es & edges[k]) - cut:
                out.add(j)
                todo.append(j)
    return [pieces[k] for k in sorted(out)]


def _sliver_cuts(topo, faces: list, kept: list, walls: list, length: float) -> tuple:
    """``(edges, owners)``: for each piece of ``kept`` with edges on the ``walls``
    that spans more than twice ``length`` mm along them, edges across it on its
    surface (a straight line in its parameters) from wall corners about ``length`` mm
    apart (:func:`_wall_corners`) to the nearest point of the patch's outline (at most
    ``length / 2`` mm away: a sliver), from each corner of the outline to the nearest
    wall corner within ``2 length`` mm (:func:`_rim_turns`), and the faces of the part
    that own the outline edges.""" 
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape

    from .occt import compound

    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(topo, TopAbs_EDGE, TopAbs_FACE, emap)
    outline = _outline_edges(topo, faces)
    on_walls = TopTools_IndexedMapOfShape()
    for w in walls:  # one per wall
        TopExp.MapShapes_s(w, TopAbs_EDGE, on_walls)
    cuts, owners = [], []
    for k in kept:  # a few pieces
        edges = explore(k, TopAbs_EDGE)
        rim = [e for e in edges if any(e.IsSame(o) for o in outline)]
        if not rim:
            continue
        sides = [e for e in edges if on_walls.Contains(e)]
        corners = _wall_corners(sides, rim, length)
        if corners is None:  # no saw-tooth: the walls run along the outline
            continue
        for p in corners:  # one per cut
            dist = BRepExtrema_DistShapeShape(p, compound(rim))
            if not dist.IsDone() or dist.NbSolution() < 1 or dist.Value() > 0.5 * length:
                continue
            cuts.append(_cut_edge(k, p, dist.PointOnShape2(1)))
        cuts += [_cut_edge(k, p, q) for q, p in _rim_turns(rim, sides, 2.0 * length)]
        owners += [f for e in rim for f in emap.FindFromKey(e)]
    cuts = [e for e in cuts if e is not None]
    return cuts, owners


def _wall_corners(edges: list, rim: list, length: float) -> list:
    """Vertices of the wall ``edges`` of a kept piece, about ``length`` mm apart along
    the line they spread along (their principal axis): near each mark the one nearest
    the outline ``rim`` (a tooth's tip, so that the cut from it crosses no tooth);
    empty when they span less than twice ``length``; None when their distances to the
    outline differ by less than half a cell (``length / SLIVER`` mm): the walls run along
    the outline, as on a band, and the piece is a plain strip OCCT meshes closed."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopoDS import TopoDS
    from scipy.spatial import cKDTree

    verts = [TopoDS.Vertex_s(v) for e in edges for v in explore(e, TopAbs_VERTEX)]
    if len(verts) < 3:
        return None
    pts = np.array([BRep_Tool.Pnt_s(v).Coord() for v in verts])  # per vertex (hundreds)
    curves = [BRepAdaptor_Curve(TopoDS.Edge_s(e)) for e in rim]
    line = np.array([a.Value(x).Coord() for a in curves for x in np.linspace(a.FirstParameter(), a.LastParameter(), 200)])
    gap = cKDTree(line).query(pts)[0]  # mm to the outline (sampled), per vertex
    if np.ptp(gap) < 0.5 * length / SLIVER:
        return None
    c = pts - pts.mean(axis=0)
    t = c @ np.linalg.svd(c, full_matrices=False)[2][0]
    lo, hi = float(t.min()), float(t.max())
    if hi - lo < 2.0 * length:
        return []
    n = int((hi - lo) // length)
    out = []
    for j in range(1, n):  # one per cut
        near = np.abs(t - (lo + (hi - lo) * j / n)) <= 0.25 * length
        if near.any():
            out.append(verts[int(np.flatnonzero(near)[np.argmin(gap[near])])])
    return out


def _rim_turns(rim: list, sides: list, reach: float) -> list:
    """``[(outline vertex, wall vertex), ...]``: each vertex where two of a kept
    piece's ``rim`` edges meet (the outline turns: a fillet's end) and the vertex of
    its wall edges ``sides`` nearest it, within ``reach`` mm (a cut between them
    parts the piece's arms, which OCCT's mesher joined across the tiles' side)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopoDS import TopoDS

    walls = [TopoDS.Vertex_s(v) for e in sides for v in explore(e, TopAbs_VERTEX)]
    ends = [TopoDS.Vertex_s(v) for e in rim for v in explore(e, TopAbs_VERTEX)]
    if not walls:
        return []
    wp = np.array([BRep_Tool.Pnt_s(v).Coord() for v in walls])  # per vertex (hundreds)
    out = []
    for v in ends:  # two per rim edge
        if sum(v.IsSame(x) for x in ends) < 2 or any(v.IsSame(x) for x in walls) or any(v.IsSame(q) for q, _ in out):
            continue
        d = np.linalg.norm(wp - np.array(BRep_Tool.Pnt_s(v).Coord()), axis=1)
        if d.min() <= reach:
            out.append((v, walls[int(np.argmin(d))]))
    return out


def _cut_edge(face, vertex, q):
    """The edge on ``face``'s surface from ``vertex`` to ``q`` (a vertex, or a point
    ``gp_Pnt`` mm): the straight line between their parameters (periodic ones brought into the
    face's range), or None."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeVertex
    from OCP.BRepLib import BRepLib
    from OCP.BRepTools import BRepTools
    from OCP.GCE2d import GCE2d_MakeSegment
    from OCP.gp import gp_Pnt2d
    from OCP.ShapeAnalysis import ShapeAnalysis_Surface
    from OCP.TopoDS import TopoDS, TopoDS_Vertex

    face = TopoDS.Face_s(face)
    surf = BRep_Tool.Surface_s(face)
    sa = ShapeAnalysis_Surface(surf)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    uv = []
    end = q if isinstance(q, TopoDS_Vertex) else None
    for p in (BRep_Tool.Pnt_s(vertex), q if end is None else BRep_Tool.Pnt_s(end)):  # the two ends
        a = sa.ValueOfUV(p, 1e-7)
        u, v = a.X(), a.Y()
        if surf.IsUPeriodic():
            u += surf.UPeriod() * np.round((0.5 * (u0 + u1) - u) / surf.UPeriod())
        if surf.IsVPeriodic():
            v += surf.VPeriod() * np.round((0.5 * (v0 + v1) - v) / surf.VPeriod())
        uv.append(gp_Pnt2d(u, v))
    if uv[0].Distance(uv[1]) < 1e-9:
        return None
    try:
        seg = GCE2d_MakeSegment(uv[0], uv[1]).Value()
        end = BRepBuilderAPI_MakeVertex(q).Vertex() if end is None else end
        mk = BRepBuilderAPI_MakeEdge(seg, surf, vertex, end, seg.FirstParameter(), seg.LastParameter())
        if not mk.IsDone():
            return None
        e = mk.Edge()
        BRepLib.BuildCurves3d_s(e)
        return e
    except Exception:  # OCCT's Standard_Failure: no cut here
        return None


def _assemble(topo, faces: list, tiles: list, strips: list, cell: float):
    """The general fuse of the patch's faces and the walls; the pieces kept (module
    docstring) and the tiles in place of the patch's faces; None if a face was not cut
    as expected, the grid indices of the walls (``strips``' third item) the faces did
    not cut if any."""
    gf = general_fuse([list(faces), [s for s, _, _ in strips]])
    if gf is None:
        return None
    walls, uncut = [], []
    for s, e, at in strips:  # the walls: the piece on the tile's side
        pieces = _pieces(gf, s)
        mine = [p for p in pieces if _has_edge(p, [e])]
        if len(pieces) < 2 or len(mine) != 1:  # a wall the faces did not cut
            uncut.append(at)
        else:
            walls.append(mine[0])
    if uncut:
        return uncut
    pieces = [p for f in faces for p in _pieces(gf, f)]  # the patch's faces, cut along the walls
    outline = _outline_edges(topo, faces)
    kept = _outside(pieces, outline, walls)
    split = split_at_knots(kept, walls, outline)  # section edges cut for the plain Gauss rule; the outline (shared outside) whole
    if split is None:
        return None
    kept, walls = split
    kept, walls, beside = _cut_slivers(topo, faces, kept, walls, cell)
    return _replace_faces(topo, [(faces[0], kept + walls + list(tiles))] + [(f, []) for f in faces[1:]] + beside)


#: Grid cells (along the outline) a face piece kept beside the walls spans at most
#: before :func:`_cut_slivers` cuts it across.
SLIVER = 8


def _cut_slivers(topo, faces: list, kept: list, walls: list, cell: float):
    """``(kept, walls, [(neighbour, [its new face]), ...])``: the face pieces ``kept``
    that the walls step along cut across (:func:`_sliver_cuts`): from a wall's corner
    to the nearest point of the patch's outline every :data:`SLIVER` cells (``cell``
    mm) or so along them, and from each turn of the outline to the wall corner
    nearest it, by OCCT's general fuse (the outline edges cut there, and their faces
    outside the patch with them). Where the patch's outline runs across the grid the
    walls step along it and the piece kept between them and the outline is a long
    sliver with a saw-tooth side (with an arm along a fillet's end): OCCT's mesher
    (0.1 mm, 0.5 rad) laid triangles across its teeth and between its arms, outside
    the face, and the STEP meshed open (a box top and two fillets at 0.25 and 0.125
    mm, every pole or at the tolerance); the short pieces mesh closed. Unchanged
    where no piece is that long, or the fuse fails or cuts a wall."""
    cuts, owners = _sliver_cuts(topo, faces, kept, walls, SLIVER * cell)
    if not cuts:
        return kept, walls, []
    beside = []
    for o in owners:  # a few faces, each once
        if not any(o.IsSame(f) for f in faces + beside):
            beside.append(o)
    gf = general_fuse([list(kept) + list(walls) + beside, cuts])
    if gf is None or any(gf.Modified(w).Size() > 0 or gf.IsDeleted(w) for w in walls):
        return kept, walls, []  # a cut crossed a wall: the pieces as they were
    pieces = [_without_internal(p if p.Orientation() == k.Orientation() else p.Reversed()) for k in kept for p in _pieces(gf, k)]
    swaps = []
    for o in beside:  # one per face outside the patch along the cut outline
        got = _pieces(gf, o)
        if len(got) != 1:
            return kept, walls, []
        swaps.append((o, [got[0] if got[0].Orientation() == o.Orientation() else got[0].Reversed()]))
    return pieces, walls, swaps
