"""STEP of texcad's texture tiles, written with numpy instead of OCCT's per-number writer.

OCCT's STEP writer formats every number on its own; for the demo plate (1089 tiles,
680 k poles) that was most of the write time and size. Here OCCT writes everything
but the tiles' poles (and triangulations): each degree-1 tile surface is swapped, in
a topological copy of the shape, for a 2 x 2-pole stand-in with the same parameter
range (its edges get the same pcurves on it), and the STEP text is then completed
with numpy:

* every point is written once (``CARTESIAN_POINT``, four to a line): a pole on the
  border of two tiles is one entity both surfaces refer to, and OCCT's own points
  that are poles (the tiles' edge curves and vertices) are dropped and refer to it,
  so tiles, edges and vertices meet exactly whatever the decimals;
* at a tolerance (:meth:`texcad.Textured.export` passes the mesh's, 0.02 mm by
  default) the tiles keep fewer poles (:func:`_reduced`): each edge between two
  tiles, or between a tile and a planar face of the part, keeps the points its
  fitted polyline needs (:func:`_edge_fit`, minimax-fitted by :func:`_minimax`,
  least squares beside a planar face;
  among the chains of chords that hold, the one adding the fewest rows and columns
  to the tiles beside it, :func:`_cheapest`; its 3-D curve, and its pcurve on the
  plane, become that polyline and the tiles' border poles move onto it), each tile
  the rows and columns its edges need plus the fewest its interior needs with its
  inner poles fitted (least squares, reweighted by rows and columns where it misses
  a little: :func:`_chosen`, :func:`_fitted`), checked bilinear on every grid point;
  and fewer decimals (:func:`decimals_for`: 3 at 0.02 mm; 8 on edges shared with the
  part's own faces, whose pcurves are OCCT's, and on border poles moved onto an edge
  between its points). Issue 28: the STEP against the binary STL in
  ``docs/benchmarks/step.md``. An edge between tiles of different knots (the small
  tiles under a tool have their own, placed for OCCT's plain rule: the tile beyond
  maps the edge by a broken line) keeps every point and is parametrised as before
  (:func:`_foreign`);
* at a tolerance, tiles no tool trimmed that lie side by side with even knot spans
  (the fine tiles texcad makes under a tool, past its trace) are merged into tiles
  of at most :data:`MERGED` cells a side (:func:`_merged`, :func:`_even`);
* the stand-in's ``B_SPLINE_SURFACE_WITH_KNOTS`` is rewritten with the tile's poles
  and knots;
* OCCT's entities are written without layout whitespace, the same geometry once
  (OCCT writes a 2-D context, a direction and a vector for every pcurve), their
  points with at most 9 decimals, knots and 2-D points rounded to
  :data:`KNOT_DECIMALS` (:func:`_short`, :func:`_knots`), and everything
  numbered densely from ``#1`` (:func:`_renumbered`), the poles last, then numbered
  again by how often each is referred to and written end to end in lines of 200
  characters (:func:`_dense`);
* with ``tessellate`` each tile that carries its triangulation (texcad's mesh: two
  triangles per grid cell) also gets a ``COMPLEX_TRIANGULATED_FACE`` linked to its
  ``ADVANCED_FACE`` (AP242), with its nodes (``COORDINATES_LIST``, the same numbers as
  the poles, formatted once), no normals (optional in AP242; OCCT's viewers compute
  them) and its triangles as one strip per column of cells (two numbers per node
  instead of six), and a ``TESSELLATED_SOLID`` per solid lists them, as OCCT's own
  writer does; the tiles then keep every pole.

The stand-ins are matched to the STEP entities through the shells' face order and
checked by their corner points; anything unexpected returns None and the caller uses
OCCT's own writer.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np

from ..brep import TILE, surface_grid, tile_grid
from ..brep.occt import explore
from ..util.runs import runs_within
from .step_edges import joined_edges, lined_edges, polyline3d as _polyline3d, shapes_in

__all__ = ["tiled_step_text"]

_ENTITY = re.compile(rb"#(\d+) = ([A-Z0-9_]*)\(([^;]*)\);")
_ANY_ENTITY = re.compile(rb"#(\d+) ?= ?([A-Z0-9_]*)\(([^;]*)\);")  # OCCT's layout or texcad's
_REF = re.compile(rb"#(\d+)")


def _real(v: float) -> str:
    """A STEP REAL (always with a decimal point), exact."""
    s = repr(float(v)).upper()
    mant, _, exp = s.partition("E")
    if "." not in mant:
        mant += "."
    elif mant.endswith(".0"):
        mant = mant[:-1]  # "1." (STEP's shortest real)
    return mant + ("E" + exp if exp else "")


def _reals(a) -> str:
    return ",".join(map(_real, np.asarray(a, np.float64).tolist()))  # per knot (tens per tile)


#: Decimals of the knots written (:func:`_knots`): 5e-10 in a surface's parameters,
#: inside OCCT's parametric confusion (1e-9).
KNOT_DECIMALS = 9
_ZEROS = re.compile(r"(\.\d*?)0+$")


def _knots(a) -> str:
    """Knots as STEP REALs with at most :data:`KNOT_DECIMALS` decimals, trailing zeros
    dropped (OCCT writes 12-17 significant digits: 4 % of a file); exact (:func:`_reals`)
    where rounding would make two of them equal."""
    k = np.asarray(a, np.float64)
    r = np.round(k, KNOT_DECIMALS) + 0.0  # (+ 0.0: no "-0.")
    if len(k) > 1 and not (np.diff(r) > 0).all():
        return _reals(k)
    return ",".join(_ZEROS.sub(r"\1", f"{x:.{KNOT_DECIMALS}f}") for x in r.tolist())  # per knot (tens per tile)


def _tile_map(tiles: list):
    """The tiles' faces (``(_, face, _)`` of :func:`_tiles_of`) as an OCCT indexed map."""
    from OCP.TopTools import TopTools_IndexedMapOfShape

    mine = TopTools_IndexedMapOfShape()
    for _, face, _ in tiles:  # one per tile
        mine.Add(face)
    return mine


def _tiles_of(topo) -> tuple[list, list]:
    """Faces of ``topo`` in shell order (what OCCT's writer lists in each shell) and,
    for each degree-1 B-spline face without location, ``(index, face, surface)``."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineSurface
    from OCP.TopAbs import TopAbs_SHELL
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS, TopoDS_Iterator

    order, tiles = [], []
    exp = TopExp_Explorer(topo, TopAbs_SHELL)
    while exp.More():  # one per shell
        it = TopoDS_Iterator(exp.Current())
        while it.More():  # one per face
            face = TopoDS.Face_s(it.Value())
            surf = BRep_Tool.Surface_s(face)
            if (
                isinstance(surf, Geom_BSplineSurface)
                and surf.UDegree() == 1
                and surf.VDegree() == 1
                and face.Location().IsIdentity()
                and not surf.IsURational()
                and not surf.IsVRational()
                and not surf.IsUPeriodic()
                and not surf.IsVPeriodic()
                and surf.NbUKnots() == surf.NbUPoles()
                and surf.NbVKnots() == surf.NbVPoles()
            ):
                tiles.append((len(order), face, surf))
            order.append(face)
            it.Next()
        exp.Next()
    return order, tiles


def _stand_in(b, face, surf) -> None:
    """Swap the face's surface for a 2 x 2-pole degree-1 surface over the same
    parameter range (corner poles kept), with its edges' pcurves re-attached."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineSurface
    from OCP.TColgp import TColgp_Array2OfPnt
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    nu, nv = surf.NbUPoles(), surf.NbVPoles()
    poles = TColgp_Array2OfPnt(1, 2, 1, 2)
    for i, ii in ((1, 1), (2, nu)):  # the four corners
        for j, jj in ((1, 1), (2, nv)):
            poles.SetValue(i, j, surf.Pole(ii, jj))
    uk, vk, mult = TColStd_Array1OfReal(1, 2), TColStd_Array1OfReal(1, 2), TColStd_Array1OfInteger(1, 2)
    uk.SetValue(1, surf.UKnot(1))
    uk.SetValue(2, surf.UKnot(nu))
    vk.SetValue(1, surf.VKnot(1))
    vk.SetValue(2, surf.VKnot(nv))
    mult.SetValue(1, 2)
    mult.SetValue(2, 2)
    stand = Geom_BSplineSurface(poles, uk, vk, mult, mult, 1, 1)
    curves = []
    exp = TopExp_Explorer(face, TopAbs_EDGE)
    while exp.More():  # one per edge (a seam twice)
        e = TopoDS.Edge_s(exp.Current())
        if BRep_Tool.IsClosed_s(e, face):
            c1 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(e.Oriented(TopAbs_FORWARD)), face, 0.0, 0.0)
            c2 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(e.Oriented(TopAbs_REVERSED)), face, 0.0, 0.0)
            curves.append((e, c1, c2))
        else:
            curves.append((e, BRep_Tool.CurveOnSurface_s(e, face, 0.0, 0.0), None))
        exp.Next()
    b.UpdateFace(face, stand, TopLoc_Location(), BRep_Tool.Tolerance_s(face))
    for e, c1, c2 in curves:  # one per edge
        if c1 is None:
            raise ValueError("edge without pcurve")
        if c2 is None:
            b.UpdateEdge(e, c1, face, BRep_Tool.Tolerance_s(e))
        else:
            b.UpdateEdge(e, c1, c2, face, BRep_Tool.Tolerance_s(e))


def _whole(face, u: np.ndarray, v: np.ndarray) -> bool:
    """Is ``face`` (one wire, no seam) bounded by its parameter rectangle's sides only
    (a tile no tool trimmed)?"""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    wires = TopExp_Explorer(face, TopAbs_WIRE)
    wires.Next()
    if wires.More():
        return False
    eu, ev = 1e-9 * (1 + abs(u).max()), 1e-9 * (1 + abs(v).max())
    exp = TopExp_Explorer(face, TopAbs_EDGE)
    while exp.More():  # one per edge of the tile (a handful)
        edge = TopoDS.Edge_s(exp.Current())
        exp.Next()
        if BRep_Tool.IsClosed_s(edge, face):
            return False
        u0, u1, v0, v1 = BRepTools.UVBounds_s(face, edge)
        on_u = u1 - u0 <= eu and min(abs(u0 - u[0]), abs(u0 - u[-1])) <= eu
        on_v = v1 - v0 <= ev and min(abs(v0 - v[0]), abs(v0 - v[-1])) <= ev
        if not (on_u or on_v):
            return False
    return True


def _even(t: np.ndarray) -> bool:
    """Are the knot spans of ``t`` (a tile's parameters, or two neighbours') within a
    factor 2 of each other? Not so in the sliver tiles texcad makes where a texture's wall meets a
    face's boundary (spans 1e-3 of a cell): merged into a tile of full cells, OCCT's
    STEP reader and mesher gave that tile no triangulation (a filleted box's quarter
    cylinder, tests/brep/test_targets.py)."""
    d = np.diff(t)
    return len(d) > 0 and d.min() > EVEN * d.max()


def _neighbours(shape, tiles: list, grids: list) -> tuple[dict, dict]:
    """For each whole tile (:func:`_whole`), the whole tile past its high-u side
    (``right``) and past its high-v side (``up``) when that side is one edge they
    share, in the same parameter space (the same grid: equal knots and border poles)
    and with the same orientation in the shell; the two tiles' knot spans even
    together (:func:`_even`)."""
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp, TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape

    ancestors = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ancestors)
    index = TopTools_IndexedMapOfShape()
    for _, face, _ in tiles:  # one per tile
        index.Add(face)
    whole = [g is not None and _even(g[1]) and _even(g[2]) and _whole(f, g[1], g[2]) for (_, f, _), g in zip(tiles, grids)]
    right, up = {}, {}
    for a, ((_, face, _), g) in enumerate(zip(tiles, grids)):  # one per tile
        if not whole[a]:
            continue
        ga, u, v = g
        exp = TopExp_Explorer(face, TopAbs_EDGE)
        while exp.More():  # one per edge of the tile
            edge = TopoDS.Edge_s(exp.Current())
            exp.Next()
            u0, u1, v0, v1 = BRepTools.UVBounds_s(face, edge)
            high_u = abs(u0 - u[-1]) + abs(u1 - u[-1]) <= 1e-9 * (1 + abs(u).max()) and abs(v0 - v[0]) + abs(v1 - v[-1]) <= 1e-9 * (1 + abs(v).max())
            high_v = abs(v0 - v[-1]) + abs(v1 - v[-1]) <= 1e-9 * (1 + abs(v).max()) and abs(u0 - u[0]) + abs(u1 - u[-1]) <= 1e-9 * (1 + abs(u).max())
            faces = ancestors.FindFromKey(edge)
            if not (high_u or high_v) or faces.Size() != 2:
                continue
            b = [index.FindIndex(f) - 1 for f in shapes_in(faces) if not f.IsSame(face)]
            if len(b) != 1 or b[0] < 0 or not whole[b[0]] or tiles[b[0]][1].Orientation() != face.Orientation():
                continue
            gb, ub, vb = grids[b[0]]
            if high_u and ub[0] == u[-1] and np.array_equal(vb, v) and np.array_equal(gb[:, 0], ga[:, -1]):
                if _even(np.r_[u, ub[1:]]):
                    right[a] = b[0]
            elif high_v and vb[0] == v[-1] and np.array_equal(ub, u) and np.array_equal(gb[0], ga[-1]):
                if _even(np.r_[v, vb[1:]]):
                    up[a] = b[0]
    return right, up


def _chains(nxt: dict, size: dict, cells: int, block: dict | None = None) -> list:
    """Runs of keys along ``nxt`` (key -> the next one), each at most ``cells`` in
    total ``size``; every key in ``size`` once. ``block``: a number per key; a run
    then also ends where it changes (:func:`_blocks`: the runs of rows side by side
    start and end at the same grid lines, so that :func:`_groups` merges them)."""
    after = {b for a, b in nxt.items() if a in size}
    out = []
    for head in size:  # one per key
        if head in after:
            continue
        run, total, at = [head], size[head], nxt.get(head)
        while at is not None:  # one per key of the chain
            if total + size[at] > cells or (block is not None and block[at] != block[run[0]]):
                out.append(run)
                run, total = [], 0
            run.append(at)
            total += size[at]
            at = nxt.get(at)
        out.append(run)
    return out


def _linked(keys: list, links: list) -> list:
    """The keys in groups joined by the ``links`` (dicts key -> key), directly or not
    (scipy's connected components); each group in the keys' order."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    at = {a: i for i, a in enumerate(keys)}
    pairs = np.array([(at[a], at[b]) for one in links for a, b in one.items() if a in at and b in at], np.int64).reshape(-1, 2)
    n = len(keys)
    _, label = connected_components(coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)), directed=False)
    members: dict = {}
    for a, k in zip(keys, label.tolist()):  # one per key
        members.setdefault(k, []).append(a)
    return list(members.values())


def _blocks(keys: list, links: list, start: dict, size: dict, cells: int) -> dict:
    """A block number per key (a tile: its first grid line ``start`` and its cells
    ``size`` along one way, in the grid it shares with the keys ``links`` join,
    directly or not): the grid lines where most of the grid's tiles start (at least
    half as many as at the commonest) cut, greedily, into runs of at most ``cells``;
    a key's block is the run its start lies in. The same for every row of tiles,
    wherever the row begins (a patch's outline crosses the grid in a staircase)."""
    out = {}
    for group in _linked(keys, links):  # one per grid
        starts, counts = np.unique([start[a] for a in group], return_counts=True)
        lines = np.r_[starts[counts * 2 >= counts.max()], max(start[a] + size[a] for a in group)]
        cuts = [lines[0]]
        for k in range(1, len(lines)):  # one per grid line (tens)
            if lines[k] - cuts[-1] > cells and lines[k - 1] > cuts[-1]:
                cuts.append(lines[k - 1])
        for a in group:  # one per tile
            out[a] = int(np.searchsorted(cuts, start[a], side="right"))
    return out


def _grid_index(keys: list, grids: list, links: list, axis: int) -> dict:
    """Each tile's first grid line along ``axis`` (1: u, 2: v) among the knots of all
    the tiles ``links`` join with it (the same grid)."""
    out = {}
    for group in _linked(keys, links):  # one per grid
        xs = np.unique(np.concatenate([grids[a][axis] for a in group]))
        out.update((a, int(np.searchsorted(xs, grids[a][axis][0]))) for a in group)
    return out


def _trimmed_neighbours(shape, tiles: list, grids: list) -> tuple[dict, dict]:
    """For each tile a tool trimmed (not :func:`_whole`: its outline follows the
    tool's trace) of at most :data:`SMALL` cells a side, the like tile past its high-u
    side (``right``) and past its high-v side (``up``): in the same parameter space
    (equal knots along the shared side, the same border poles there), with the same
    orientation, the knot spans even together (:func:`_even`; OCCT's cut leaves
    border poles up to 5e-12 mm apart: within 1e-9 mm). Their surfaces are
    whole (the trimming is their outline's), so a rectangle of them is one grid
    without a gap; the shared side may be cut or missing (the tool took it). Not past
    the high-u side of a tile whose u knots are placed for OCCT's plain rule over
    itself (:func:`_placed`; a patch's tiles, ``texcad.brep.bands``): the rule across
    u then spans the merged tile and misses (4-cell tiles of a box's sides merged into
    24: the STEP's plain volume 2.5 % low)."""
    from OCP.TopAbs import TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer

    small = {}
    for a, ((_, face, _), g) in enumerate(zip(tiles, grids)):  # one per tile
        if g is None:
            continue
        ga, u, v = g
        if min(len(u), len(v)) - 1 > SMALL or not (_even(u) and _even(v)):
            continue
        wires = TopExp_Explorer(face, TopAbs_WIRE)
        wires.Next()
        if not wires.More():  # one wire: no hole inside the tile
            small[(float(u[0]), float(v[0]))] = a
    right, up = {}, {}
    for a in small.values():  # one per small trimmed tile
        ga, u, v = grids[a]
        b = small.get((float(u[-1]), float(v[0])))
        if b is not None and (_placed(u) or _placed(grids[b][1])):
            b = None  # u knots placed for OCCT's plain rule over the tile alone (a patch's, texcad.brep.bands): not wider
        if b is not None and tiles[b][1].Orientation() == tiles[a][1].Orientation():
            gb, ub, vb = grids[b]
            if np.array_equal(vb, v) and np.allclose(gb[:, 0], ga[:, -1], rtol=0.0, atol=1e-9) and _even(np.r_[u, ub[1:]]):
                right[a] = b
        b = small.get((float(u[0]), float(v[-1])))
        if b is not None and tiles[b][1].Orientation() == tiles[a][1].Orientation():
            gb, ub, vb = grids[b]
            if np.array_equal(ub, u) and np.allclose(gb[0], ga[-1], rtol=0.0, atol=1e-9) and _even(np.r_[v, vb[1:]]):
                up[a] = b
    return right, up


#: Largest side (grid cells) of a trimmed tile :func:`_merged` joins with its like
#: neighbours (the fine tiles around a hole texcad drills through a texture).
SMALL = 4


def _groups(shape, tiles: list, grids: list, cells: int, trimmed: bool = False) -> list:
    """Rectangles of whole tiles (tile indices) at most ``cells`` grid cells a side:
    runs along u, then runs of those along v whose tiles are each other's ``up``,
    both cut at the same grid lines whatever tile a row or column starts at
    (:func:`_blocks`; each row's runs from its first tile, the runs of a patch whose
    outline crosses the grid in a staircase lay offset row to row and seldom merged
    along v: the mitre of ``bench_step.py --sizes`` 4.98 -> 3.90 MB).
    ``trimmed``: rectangles of small trimmed tiles instead (:func:`_trimmed_neighbours`)."""
    right, up = (_trimmed_neighbours if trimmed else _neighbours)(shape, tiles, grids)
    whole = sorted({a for a in right} | set(right.values()) | set(up) | set(up.values()))
    wide, tall = {a: len(grids[a][1]) - 1 for a in whole}, {a: len(grids[a][2]) - 1 for a in whole}
    col, row = _grid_index(whole, grids, [right, up], 1), _grid_index(whole, grids, [right, up], 2)
    strips = _chains(right, wide, cells, _blocks(whole, [right, up], col, wide, cells))
    head = {s[0]: i for i, s in enumerate(strips)}
    above = {}
    for i, s in enumerate(strips):  # one per strip
        j = head.get(up.get(s[0], -1))
        if j is not None and strips[j] == [up.get(a) for a in s]:
            above[i] = j
    rows = _blocks(whole, [right, up], row, tall, cells)
    runs = _chains(above, {i: tall[s[0]] for i, s in enumerate(strips)}, cells, {i: rows[s[0]] for i, s in enumerate(strips)})
    return [[a for i in run for a in strips[i]] for run in runs]


def _merged(shape, cells: int, trimmed: bool = False):
    """``shape`` with each rectangle of whole tiles (:func:`_groups`; the fine tiles
    texcad makes under a tool, past its trace) written as one tile of at most
    ``cells`` grid cells a side: one surface through their poles, bounded by their
    outer edges (kept, with their vertices; the edges between them go). The
    rectangles keep the tiles' parameter space, so the edges' pcurves stay as they
    are. Returns the new shape, or ``shape`` when there is nothing to merge.

    A rectangle of whole tiles is merged only where its knots are placed for OCCT's
    plain volume rule over it (:func:`_placed`, both ways: it is a tile texcad made,
    cut by a tool's box). The fine tiles under a tool have knots of their own,
    placed for the rule on each (``texcad.brep.solids``); merged, the rule takes
    more points across them and misses: a 30 mm plate drilled through read +0.107 %
    in the plain rule (+0.053 % so), and the merged tile kept whole rows and columns
    of poles across all of them (2.04x its STL; 2.005x so).

    Tiles whose knots are placed each for the rule over itself (a patch's 4-cell
    tiles, ``texcad.brep.bands``) are merged with their u knots placed again over the
    merged tile (:func:`~texcad.brep.gprop.gauss_knots`; a degree-1 surface's knots are
    free), the outer edges' pcurves mapped to them (:func:`_remapped`): the rule
    across u then spans the merged tile as placed, and along v each edge keeps its
    own rule over its tile's placed v knots (merged as they were, a box's sides read
    2.5 % low in the plain rule). An edge along u between two such merged tiles one
    above the other (the same u mapped the same way) gets the new parameter instead
    (:func:`_reparametrised`: its 3-D curve's knots mapped, straight pcurves), so
    that :func:`_fused_sides` joins the run of them between the two: the band of a
    box's sides and rounded edges in ``bench_step.py --sizes`` 5.21 -> 4.21 MB."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepTools import BRepTools_ReShape
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    _, tiles = _tiles_of(shape)
    grids = _grids(tiles)
    groups = [g for g in _groups(shape, tiles, grids, cells, trimmed) if len(g) > 1]
    if not groups:
        return shape
    ancestors = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ancestors)
    plans = _merge_plans(groups, tiles, grids, trimmed)
    seen, along = _reparametrised(plans, tiles, ancestors)
    reshape = BRepTools_ReShape()
    for plan in plans:  # one per merged rectangle
        _merge_one(plan, tiles, lambda e: along.get(seen.FindIndex(e)), reshape)
    b = BRep_Builder()
    for e, curve, _, rng in along.values():  # one per edge along u given the merged tiles' parameter
        b.UpdateEdge(e, curve, BRep_Tool.Tolerance_s(e))
        b.Range(e, *rng)
    return reshape.Apply(shape)


def _merge_plans(groups: list, tiles: list, grids: list, trimmed: bool) -> list:
    """``(group, U0, U, G, V, outline, chain)`` per rectangle of tiles that
    :func:`_merged` merges: the tiles' knots ``U0`` / ``V`` and the merged tile's
    ``U`` (placed again where the tiles were placed each), the poles ``G``, and its
    outer edges ``outline`` in loop order ``chain``; rectangles whose knots do not
    suit OCCT's plain rule, or whose outline is not one simple loop, are left out."""
    from OCP.TopTools import TopTools_IndexedMapOfShape

    from ..brep.gprop import gauss_knots

    vertices = TopTools_IndexedMapOfShape()
    plans = []
    for group in groups:  # one per merged rectangle
        U = np.unique(np.concatenate([grids[a][1] for a in group]))
        V = np.unique(np.concatenate([grids[a][2] for a in group]))
        U0 = U
        if not trimmed and not (_placed(U) and _placed(V)):
            if not all(_placed(grids[a][1]) and _placed(grids[a][2]) and len(grids[a][1]) <= SMALL + 1 for a in group):
                continue  # knots not placed for OCCT's plain rule over the merged tile (docstring)
            U = gauss_knots(U0[0], U0[-1], len(U0) - 1)  # tiles placed each (a patch's): u placed again over the merge
        G = np.zeros((len(V), len(U), 3))
        for a in group:  # one per tile of the rectangle
            g, u, v = grids[a]
            G[np.ix_(np.searchsorted(V, v), np.searchsorted(U0, u))] = g
        loop = _outline_loop(group, tiles, vertices)
        if loop is not None:
            plans.append((group, U0, U, G, V, *loop))
    return plans


def _outline_loop(group: list, tiles: list, vertices) -> "tuple | None":
    """``(outline, chain)``: the outer edges of the tiles ``group`` (each as in its
    forward tile, with that tile) and their order around the one loop they make, or
    None where they make no simple loop."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD
    from OCP.TopExp import TopExp, TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    from ..brep.occt import compound

    inside = TopTools_IndexedDataMapOfShapeListOfShape()  # the group's edges and their tiles in it
    TopExp.MapShapesAndAncestors_s(compound([tiles[a][1] for a in group]), TopAbs_EDGE, TopAbs_FACE, inside)
    outline = []  # (edge as in its forward tile, that tile)
    for a in group:  # one per tile of the rectangle
        fwd = TopoDS.Face_s(tiles[a][1].Oriented(TopAbs_FORWARD))
        exp = TopExp_Explorer(fwd, TopAbs_EDGE)
        while exp.More():  # one per edge of the tile
            e = TopoDS.Edge_s(exp.Current())
            exp.Next()
            if inside.FindFromKey(e).Size() < 2:
                outline.append((e, fwd))
    start = {}
    for k, (e, _) in enumerate(outline):  # one per outer edge
        start.setdefault(vertices.Add(TopExp.FirstVertex_s(e, True)), []).append(k)
    chain, at = [0], vertices.Add(TopExp.LastVertex_s(outline[0][0], True))
    while len(chain) < len(outline) and len(start.get(at, ())) == 1:  # one per outer edge
        chain.append(start[at][0])
        at = vertices.Add(TopExp.LastVertex_s(outline[chain[-1]][0], True))
    if len(set(chain)) != len(outline) or any(len(ks) != 1 for ks in start.values()):
        return None  # not one simple loop: leave these tiles as they are
    return outline, chain


def _merge_one(plan: tuple, tiles: list, at, reshape) -> None:
    """Record in ``reshape`` the merge of one rectangle ``plan`` (:func:`_merge_plans`):
    one face on the poles ``G`` over ``U`` x ``V``, bounded by the outer edges with
    their pcurves (mapped to ``U``, or the new curves ``at(edge)`` gives an edge along
    u given the merged tiles' parameter), the other tiles removed."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS_Face, TopoDS_Wire

    from ..brep import grid_surface

    group, U0, U, G, V, outline, chain = plan
    b, face, wire = BRep_Builder(), TopoDS_Face(), TopoDS_Wire()
    first = tiles[group[0]][1]
    b.MakeFace(face, grid_surface(G, U, V), TopLoc_Location(), BRep_Tool.Tolerance_s(first))
    b.MakeWire(wire)
    placed = _placed(U)
    pcs = [BRep_Tool.CurveOnSurface_s(outline[k][0], outline[k][1], 0.0, 0.0) for k in chain]  # one per outer edge
    if U is not U0:
        pcs = [at(outline[k][0])[2] if at(outline[k][0]) else _remapped(outline[k][0], pc, U0, U)
               for k, pc in zip(chain, pcs)]  # fmt: skip
        if any(pc is None for pc in pcs):
            return
    for k, pc in zip(chain, pcs):  # one per outer edge
        e = outline[k][0]
        b.Add(wire, e)
        b.UpdateEdge(e, _ruled(e, pc, U[0], placed), face, BRep_Tool.Tolerance_s(e))
    wire.Closed(True)
    b.Add(face, wire)
    reshape.Replace(first, face.Oriented(first.Orientation()))
    for a in group[1:]:  # one per other tile of the rectangle
        reshape.Remove(tiles[a][1])


def _reparametrised(plans: list, tiles: list, ancestors) -> dict:
    """The edges along ``u`` between two rectangles :func:`_merged` joins whose ``u``
    knots are placed again the same way (the same ``U0`` mapped to the same ``U``: one
    above the other), ``{edge: (3-D curve, pcurve, (first, last))}``: the edge's
    degree-1 3-D curve with its knots mapped from ``U0`` to ``U`` (piecewise linearly,
    as the merged surfaces' u), its pcurve on both merged tiles then the straight
    iso-v line ``(t, v)`` again, not the broken line :func:`_remapped` gives; such
    runs of edges between the same two merged tiles are then joined into one
    (:func:`_fused_sides`; an edge along ``u`` adds nothing to OCCT's plain rule).
    Returns ``(edges, {index in edges: (edge, curve, pcurve, (first, last))})``."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineCurve
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    moved = TopTools_IndexedMapOfShape()  # the tiles of the rectangles whose u is placed again
    which = {}
    for i, (group, U0, U, *_rest) in enumerate(plans):  # one per merged rectangle
        if U is U0:
            continue
        for a in group:  # one per tile of the rectangle
            which[moved.Add(tiles[a][1])] = i
    out, seen = {}, TopTools_IndexedMapOfShape()  # keyed by the edge's index in seen (either orientation)
    for i, (group, U0, U, _, _, outline, _) in enumerate(plans):  # one per merged rectangle
        if U is U0:
            continue
        for e, fwd in outline:  # one per outer edge
            if seen.Contains(e):
                continue
            seen.Add(e)
            fs = [TopoDS.Face_s(f) for f in shapes_in(ancestors.FindFromKey(e))]
            if len(fs) != 2 or fs[0].IsSame(fs[1]) or not all(moved.Contains(f) for f in fs):
                continue
            j = [which[moved.FindIndex(f)] for f in fs]
            if len(set(j)) != 2 or any(not (np.array_equal(plans[x][1], U0) and np.array_equal(plans[x][2], U)) for x in j):
                continue
            isos = [_iso(e, TopoDS.Face_s(f.Oriented(TopAbs_FORWARD))) for f in fs]
            if None in isos or any(ax != 1 for ax, _ in isos) or isos[0][1] != isos[1][1]:
                continue  # along u on both, the same v (one above the other share it)
            loc = TopLoc_Location()
            c = BRep_Tool.Curve_s(e, loc, 0.0, 0.0)
            if not isinstance(c, Geom_BSplineCurve) or c.Degree() != 1 or not loc.IsIdentity():
                continue
            k = np.array([c.Knot(x) for x in range(1, c.NbKnots() + 1)])
            p = np.array([c.Pole(x).Coord() for x in range(1, c.NbPoles() + 1)])
            eps = 1e-9 * (1.0 + np.abs(U0).max())
            if len(p) != len(k) or k[0] < U0[0] - eps or k[-1] > U0[-1] + eps:
                continue
            first, last = BRep_Tool.Range_s(e)
            line = Geom2d_Line(gp_Pnt2d(0.0, isos[0][1]), gp_Dir2d(1.0, 0.0))
            m = np.interp(k, U0, U)
            out[seen.FindIndex(e)] = (e, _polyline3d(p, m), line, (float(np.interp(first, U0, U)), float(np.interp(last, U0, U))))
    return seen, out


def _remapped(edge, pc, u: np.ndarray, new: np.ndarray):
    """The pcurve ``pc`` of ``edge`` with its ``u`` mapped from the knots ``u`` to
    ``new`` (piecewise linearly: the same points of a degree-1 surface whose u knots
    are ``new``), or None if ``pc`` is not a line or a degree-1 B-spline. An edge
    along v (``u`` constant) keeps its curve, moved (a line stays a line, a padded
    pcurve its spans: OCCT's plain rule keeps its order along it); an edge along u
    becomes the broken line through its points at ``u`` and its own knots."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_BSplineCurve, Geom2d_Line
    from OCP.gp import gp_Vec2d

    from ..brep.gprop import polyline_pcurve

    if isinstance(pc, Geom2d_BSplineCurve) and pc.Degree() == 1:
        ks = np.array([pc.Knot(i) for i in range(1, pc.NbKnots() + 1)])
    elif isinstance(pc, Geom2d_Line):
        ks = np.zeros(0)
    else:
        return None
    first, last = BRep_Tool.Range_s(edge)
    t = np.unique(np.r_[first, ks[(ks > first) & (ks < last)], last])
    q = np.array([pc.Value(x).Coord() for x in t.tolist()])  # per knot (tens)
    eps = 1e-12 * (1.0 + np.abs(u).max())
    if np.ptp(q[:, 0]) <= eps:  # along v
        out = pc.Copy()
        out.Translate(gp_Vec2d(float(np.interp(q[0, 0], u, new)) - q[0, 0], 0.0))
        return out
    cut = [t]
    for a in range(len(t) - 1):  # per span: where it crosses a knot of u
        lo, hi = sorted((q[a, 0], q[a + 1, 0]))
        inner = u[(u > lo + eps) & (u < hi - eps)]
        cut.append(t[a] + (inner - q[a, 0]) / (q[a + 1, 0] - q[a, 0]) * (t[a + 1] - t[a]))
    t = np.unique(np.concatenate(cut))
    q = np.array([pc.Value(x).Coord() for x in t.tolist()])  # per point (tens)
    return polyline_pcurve(np.stack([np.interp(q[:, 0], u, new), q[:, 1]], axis=-1), t, pad=False)


def _iso(edge, face) -> tuple | None:
    """``(axis, value)`` when the pcurve of ``edge`` on ``face`` is the iso line of the
    face's parameter ``axis`` (0: u, 1: v) at ``value``, parametrised by the other
    parameter (a tile side as texcad makes it); else None. Checked at the ends, the
    middle and, on a B-spline pcurve, at its knots and between them (a broken line
    through the grid points at the tiles' knots, on a wall strip whose ``u`` is the
    grid index, matched the iso line at its ends and middle only)."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_BSplineCurve

    pc = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
    if pc is None:
        return None
    first, last = BRep_Tool.Range_s(edge)
    t = np.array([first, 0.5 * (first + last), last])
    if isinstance(pc, Geom2d_BSplineCurve):
        k = np.array([pc.Knot(i) for i in range(1, pc.NbKnots() + 1)])  # per knot (tens)
        k = k[(k > first) & (k < last)]
        t = np.unique(np.r_[t, k, 0.5 * (np.r_[first, k] + np.r_[k, last])])
    q = np.array([pc.Value(x).Coord() for x in t.tolist()])  # per knot (tens)
    eps = 1e-9 * (1.0 + np.abs(q[[0, -1]]).max())
    for axis in (0, 1):  # u constant (runs along v), then v constant
        if np.abs(q[:, axis] - q[0, axis]).max() <= eps and np.abs(q[:, 1 - axis] - t).max() <= eps:
            return axis, float(round(q[0, axis], 12))
    return None


def _fused_sides(shape, traced=None):
    """``shape`` with each run of edges between the same two tiles, along one iso line
    of both (tile sides, parametrised as the grid), whose inner vertices no other edge
    uses, written as one edge: its 3-D curve the run's degree-1 curves end to end, its
    pcurves the iso lines. Around a hole drilled through the texture the fine tiles
    texcad leaves split their neighbours' sides into an edge each (about 650 bytes of
    STEP an edge). Runs of the traces in ``traced`` (polylines :func:`_fitted_traces`
    made) between the same two faces are joined too (:func:`_trace_runs`).

    Only runs along ``u`` (iso-``v`` on both tiles) are joined: OCCT's plain volume rule
    takes one Gauss rule over each edge that runs along ``v`` (:mod:`texcad.brep.gprop`),
    and texcad places a tile's ``v`` knots for the rule over each such edge (a face in
    strips, ``texcad.brep.uvstrips``: a strip's sides split at its runs); one edge over
    several runs put a whole cone's plain volume 2.5 % off at 0.25 mm. An edge along
    ``u`` adds nothing to that rule."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepTools import BRepTools_ReShape
    from OCP.Geom import Geom_BSplineCurve
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_VERTEX
    from OCP.TopExp import TopExp
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    _, tiles = _tiles_of(shape)
    mine = _tile_map(tiles)
    faces_of = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, faces_of)
    edges_of = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_VERTEX, TopAbs_EDGE, edges_of)
    runs: dict = {}  # (face a, face b, iso on a, iso on b) -> [(first, last, edge)]
    for k in range(1, faces_of.Extent() + 1):  # one per edge
        edge = TopoDS.Edge_s(faces_of.FindKey(k))
        fs = [TopoDS.Face_s(f) for f in shapes_in(faces_of.FindFromIndex(k))]
        if len(fs) != 2 or fs[0].IsSame(fs[1]) or not all(mine.Contains(f) for f in fs):
            continue
        loc = TopLoc_Location()
        curve = BRep_Tool.Curve_s(edge, loc, 0.0, 0.0)
        if not isinstance(curve, Geom_BSplineCurve) or curve.Degree() != 1 or not loc.IsIdentity():
            continue
        ids = sorted(((mine.FindIndex(f), f) for f in fs), key=lambda x: x[0])
        isos = [_iso(edge, f) for _, f in ids]
        if None in isos or any(axis == 0 for axis, _ in isos):  # along v: one Gauss rule per edge (docstring)
            continue
        runs.setdefault((ids[0][0], ids[1][0], *isos), []).append((*BRep_Tool.Range_s(edge), edge, ids))
    traces = _trace_runs(shape, traced, edges_of) if traced is not None else []
    b, reshape, fused = BRep_Builder(), BRepTools_ReShape(), False
    for key, items in runs.items():  # one per pair of tiles and iso line
        items.sort(key=lambda x: x[0])
        chain = [items[0]]
        for it in items[1:] + [None]:  # one per edge of the run, then the end
            joined = it is not None and abs(it[0] - chain[-1][1]) <= 1e-12 * (1 + abs(it[0]))
            if joined:
                v = TopExp.LastVertex_s(chain[-1][2], True)
                joined = v.IsSame(TopExp.FirstVertex_s(it[2], True)) and edges_of.FindFromKey(v).Size() == 2
            if joined:
                chain.append(it)
                continue
            if len(chain) > 1:
                ne = _joined_edge(b, chain, key[2:])
                if ne is not None:
                    reshape.Replace(TopoDS.Edge_s(chain[0][2].Oriented(TopAbs_FORWARD)), ne)
                    for _, _, e, _ in chain[1:]:  # one per edge the run drops
                        reshape.Remove(e)
                    fused = True
            chain = [it]
    traces = [([chain[i] for i in part], faces) for chain, faces in traces
              for part in runs_within([_spans(e) for e, _ in chain], TRACE_SPANS)]  # fmt: skip
    for chain, faces in traces:  # one per run of traces between the same two faces
        if len(chain) < 2:
            continue
        ne = _joined_trace(b, chain, faces)
        if ne is not None:
            traced.Add(ne)
            reshape.Replace(TopoDS.Edge_s(chain[0][0].Oriented(TopAbs_FORWARD)), ne.Oriented(chain[0][1]))
            for e, _ in chain[1:]:  # one per edge the run drops
                reshape.Remove(e)
            fused = True
    return reshape.Apply(shape) if fused else shape


#: Most spans (3-D curve knots) of a joined trace (:func:`_fused_sides`): OCCT's plain
#: rule takes at most 61 points along an edge on the part's own face too, where the
#: polyline's kinks are no knots it places (a cap's section edges joined along 24-cell
#: walls read its STEP at 0.25 mm 0.6 % high).
TRACE_SPANS = 8


def _spans(edge) -> int:
    """Spans of the degree-1 3-D curve of ``edge`` within its range (1 for another curve)."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineCurve

    c = BRep_Tool.Curve_s(edge, 0.0, 0.0)
    if not isinstance(c, Geom_BSplineCurve):
        return 1
    first, last = BRep_Tool.Range_s(edge)
    return 1 + sum(first < c.Knot(i) < last for i in range(1, c.NbKnots() + 1))  # per knot (a few)


def _trace_runs(shape, traced, edges_of) -> list:
    """Runs ``[([(edge, orientation relative to the run)], [face, face]), ...]`` of two
    or more traces in ``traced`` end to end between the same two faces, their inner
    vertices used by no other edge."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape

    faces_of = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, faces_of)
    fmap = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_FACE, fmap)
    pair = {}
    for k in range(1, traced.Extent() + 1):  # one per trace
        e = traced.FindKey(k)
        if faces_of.Contains(e) and faces_of.FindFromKey(e).Size() == 2:
            pair[k] = tuple(sorted(fmap.FindIndex(f) for f in shapes_in(faces_of.FindFromKey(e))))
    def after(k: int, forward: bool):  # the next trace of the run past an end, with its direction
        e = TopoDS.Edge_s(traced.FindKey(k))
        v = TopExp.LastVertex_s(e, True) if forward else TopExp.FirstVertex_s(e, True)
        nxt = [TopoDS.Edge_s(x) for x in shapes_in(edges_of.FindFromKey(v)) if not x.IsSame(e)]
        if len(nxt) != 1 or not traced.Contains(nxt[0]) or pair.get(traced.FindIndex(nxt[0])) != pair[k]:
            return None
        j = traced.FindIndex(nxt[0])
        return j, TopExp.FirstVertex_s(nxt[0], True).IsSame(v) == forward
    seen, out = set(), []
    for k in pair:  # one per trace
        if k in seen:
            continue
        start, fwd, hops = k, True, 0
        back = after(start, False)
        while back is not None and back[0] != k and hops < len(pair):  # walk to the run's first trace
            start, fwd, hops = back[0], back[1], hops + 1
            back = after(start, not fwd)
        run, at = [(start, fwd)], after(start, fwd)
        while at is not None and at[0] not in [r for r, _ in run]:  # one per trace of the run
            run.append(at)
            at = after(*at)
        seen.update(r for r, _ in run)
        if len(run) > 1 and run[-1][0] != start:
            faces = [TopoDS.Face_s(f) for f in shapes_in(faces_of.FindFromKey(traced.FindKey(start)))]
            out.append(([(TopoDS.Edge_s(traced.FindKey(r)), TopAbs_FORWARD if f else TopAbs_REVERSED) for r, f in run], faces))
    return out


def _joined_trace(b, chain: list, faces: list):
    """One edge (its direction the run's) for the traces ``chain`` ``[(edge,
    orientation)]`` between ``faces``: 3-D and 2-D polylines end to end, parameters
    continued."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineCurve
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS_Edge

    pts, uvs, knots, tol, at = [], None, [], 0.0, 0.0
    for e, o in chain:  # one per trace of the run (a few)
        c = BRep_Tool.Curve_s(e, 0.0, 0.0)
        if not isinstance(c, Geom_BSplineCurve) or c.Degree() != 1:
            return None
        first, last = BRep_Tool.Range_s(e)
        k = np.array([c.Knot(i) for i in range(1, c.NbKnots() + 1)])
        p = np.array([c.Pole(i).Coord() for i in range(1, c.NbPoles() + 1)])
        if len(k) != len(p):
            return None
        q = []
        for f in faces:  # its two faces
            pc = BRep_Tool.CurveOnSurface_s(e, f, 0.0, 0.0)
            if not isinstance(pc, Geom2d_BSplineCurve) or pc.Degree() != 1 or pc.NbPoles() != len(k):
                return None
            q.append(np.array([pc.Pole(i).Coord() for i in range(1, pc.NbPoles() + 1)]))
        t = k - first
        if o == TopAbs_REVERSED:
            p, q, t = p[::-1], [x[::-1] for x in q], (last - first) - t[::-1]
        if pts and np.abs(pts[-1][-1] - p[0]).max() > 1e-7:
            return None
        sl = slice(None) if not pts else slice(1, None)
        pts.append(p[sl])
        uvs = [x[sl] for x in q] if uvs is None else [np.concatenate([a, x[sl]]) for a, x in zip(uvs, q)]
        knots.append((t + at)[sl])
        at += last - first
        tol = max(tol, BRep_Tool.Tolerance_s(e))
    p, k = np.concatenate(pts), np.concatenate(knots)
    ne = TopoDS_Edge()
    b.MakeEdge(ne, _polyline3d(p, k), tol)
    e0, o0 = chain[0]
    e1, o1 = chain[-1]
    v0 = TopExp.FirstVertex_s(e0, True) if o0 == TopAbs_FORWARD else TopExp.LastVertex_s(e0, True)
    v1 = TopExp.LastVertex_s(e1, True) if o1 == TopAbs_FORWARD else TopExp.FirstVertex_s(e1, True)
    b.Add(ne, v0.Oriented(TopAbs_FORWARD))
    b.Add(ne, v1.Oriented(TopAbs_REVERSED))
    for f, q in zip(faces, uvs):  # its two faces
        b.UpdateEdge(ne, _polyline2d(q, k), f, tol)
    b.Range(ne, float(k[0]), float(k[-1]))
    return ne


def _joined_edge(b, chain: list, isos: tuple):
    """One edge (forward) for ``chain`` ``[(first, last, edge, [(index, face)] * 2)]``
    (increasing, end to end), on the iso lines ``isos`` of its two faces; None when a
    3-D curve does not join the next."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS_Edge

    pts, knots, tol = [], [], 0.0
    for first, last, e, _ in chain:  # one per edge of the run (a few)
        c = BRep_Tool.Curve_s(e, 0.0, 0.0)
        k = np.array([c.Knot(i) for i in range(1, c.NbKnots() + 1)])
        p = np.array([c.Pole(i).Coord() for i in range(1, c.NbPoles() + 1)])
        if abs(k[0] - first) > 1e-12 * (1 + abs(first)) or abs(k[-1] - last) > 1e-12 * (1 + abs(last)) or len(p) != len(k):
            return None
        if pts and np.abs(pts[-1][-1] - p[0]).max() > 1e-9:
            return None
        pts.append(p if not pts else p[1:])
        knots.append(k if not knots else k[1:])
        tol = max(tol, BRep_Tool.Tolerance_s(e))
    p, k = np.concatenate(pts), np.concatenate(knots)
    ne = TopoDS_Edge()
    b.MakeEdge(ne, _polyline3d(p, k), tol)
    b.Add(ne, TopExp.FirstVertex_s(chain[0][2], True).Oriented(TopAbs_FORWARD))
    b.Add(ne, TopExp.LastVertex_s(chain[-1][2], True).Oriented(TopAbs_REVERSED))
    b.Range(ne, float(k[0]), float(k[-1]))
    for (_, face), (axis, value) in zip(chain[0][3], isos):  # its two faces
        line = (Geom2d_Line(gp_Pnt2d(value, 0.0), gp_Dir2d(0.0, 1.0)) if axis == 0
                else Geom2d_Line(gp_Pnt2d(0.0, value), gp_Dir2d(1.0, 0.0)))  # fmt: skip
        b.UpdateEdge(ne, line, face, tol)
    b.Range(ne, float(k[0]), float(k[-1]))
    return ne


def _ruled(edge, pc, u0: float, placed: bool):
    """The pcurve ``pc`` of ``edge`` on a tile :func:`_merged` joins, for the merged
    tile whose parameters start at ``u0``. OCCT's plain volume rule integrates a face
    along each edge's ``v`` and, at each point, across ``u`` from ``u0`` to the
    edge's (:mod:`texcad.brep.gprop`): only the iso-u edges past ``u0`` count, with
    as many Gauss points as their pcurve's or the surface's order give. The small
    tiles under a tool keep straight pcurves, whose order comes from the small tile's
    few spans and is too low across the merged tile. Where the merged tile's u knots
    are placed for 61 points (``placed``, :func:`_placed`: it spans a whole tile
    texcad made, as around a hole drilled through a cylinder's texture, whose STEP
    read 0.12 % high in the plain rule, its B-rep 0.04 %), those become the same
    line of order :data:`GAUSS_ORDER` (:func:`_gauss_line`). Any other pcurve stays
    as it is (elsewhere the rule's order does not make the merged tile exact: its
    knots are part of a tile's run, placed for that run)."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_Line

    if not placed or not isinstance(pc, Geom2d_Line):
        return pc
    first, last = BRep_Tool.Range_s(edge)
    a, z = np.array(pc.Value(first).Coord()), np.array(pc.Value(last).Coord())
    if abs(z[0] - a[0]) > 1e-9 * (1 + abs(a[0])) or a[0] <= u0 + 1e-9 * (1 + abs(u0)):
        return pc  # along u (no share of the integral) or on the low-u side (an empty one)
    return _gauss_line(a, z, first, last)

def _placed(u: np.ndarray) -> bool:
    """Are the knots ``u`` those :func:`texcad.brep.gprop.gauss_knots` places for
    OCCT's 61-point rule between their ends?"""
    from ..brep.gprop import gauss_knots

    return bool(np.allclose(u, gauss_knots(u[0], u[-1], len(u) - 1), rtol=0.0, atol=1e-9 * (1 + np.abs(u).max())))


def _grids(tiles: list) -> list:
    """Each tile's ``(grid, u, v)``: remembered by texcad (:func:`texcad.brep.tile_grid`)
    or read from OCCT."""
    out = []
    for _, _, surf in tiles:  # one per tile
        got = tile_grid(surf)
        out.append(got if got is not None else surface_grid(surf))
    return out


def _carries_grid_mesh(face, rows: int, cols: int) -> bool:
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location

    tri = BRep_Tool.Triangulation_s(face, TopLoc_Location())
    return tri is not None and tri.NbNodes() == rows * cols and tri.NbTriangles() == 2 * (rows - 1) * (cols - 1)


def _mults(n: int) -> str:
    return "2" if n == 1 else "2," + "1," * (n - 2) + "2"


def _grid_ids_template(cols: int, rows: int) -> str:
    return "(" + "),(".join([",".join(["#%d"] * rows)] * cols) + ")"


def _strips_text(rows: int, cols: int) -> str:
    """The triangles of :func:`texcad.solid.grid_faces` (``rows x cols`` nodes,
    row-major, 1-based: the same cells, diagonals and orientation) as one triangle
    strip per column of cells, two numbers per node instead of six.

    The order is the one OCCT's STEP reader turns into counter-clockwise triangles
    (``StepToTopoDS_TranslateFace``: ``(s1, s3, s2), (s2, s3, s4), ...``): the strip of
    cell column c runs up the rows as ``(r, c + 1), (r, c)``."""
    a = np.arange(rows)[None, :] * cols + np.arange(cols - 1)[:, None] + 1  # (c, r) -> node (r, c)
    strips = np.stack([a + 1, a], axis=-1).reshape(cols - 1, 2 * rows)
    one = "(" + ",".join(["%d"] * (2 * rows)) + ")"
    return ",".join([one] * (cols - 1)) % tuple(strips.ravel().tolist())


def _border(rows: int, cols: int) -> np.ndarray:
    """True for the nodes of a ``rows x cols`` tile grid on its border, u-major
    (index ``c * rows + r``)."""
    on = np.zeros((cols, rows), bool)
    on[[0, -1], :], on[:, [0, -1]] = True, True
    return on.ravel()


_TRAILING = re.compile(r"(\.\d*?)0+(?=[,\n])")


def _tokens(p: np.ndarray, decimals: int) -> np.ndarray:
    """``"x,y,z"`` per point with ``decimals`` decimals, trailing zeros dropped."""
    if not len(p):
        return np.empty(0, dtype=object)
    fmt = f"%.{decimals}f,%.{decimals}f,%.{decimals}f\n"
    text = _TRAILING.sub(r"\1", (fmt * len(p)) % tuple(p.ravel().tolist()))
    return np.array(text.split("\n")[:-1], dtype=object)


def tiled_step_text(topo: Any, occt_write, *, tessellate: bool = True, tolerance: float = 0.0) -> bytes | None:
    """STEP text of ``topo`` whose texture tiles' poles and triangulations are written
    with numpy (see the module docstring).

    Args:
        topo: ``TopoDS_Shape`` (not changed: the stand-ins go into a topological copy).
        occt_write: ``occt_write(shape) -> bytes``, OCCT's writer (AP242 when
            ``tessellate``, else AP214) without tessellation.
        tessellate: add the tiles' triangulations (texcad's grid mesh) as AP242
            ``COMPLEX_TRIANGULATED_FACE``; the tiles keep every pole then.
        tolerance: mm; when > 0 (and not ``tessellate``) the tiles are written with
            fewer poles and fewer decimals, within ``tolerance`` of every grid point
            (:func:`decimals_for`, :func:`_reduced`), whole tiles side by side merged
            into larger ones (:func:`_merged`): a STEP at the mesh's tolerance. At 0
            every pole is written, with 8 decimals (5e-9 mm; 4 with ``tessellate``).

    Returns:
        The STEP bytes, or None where this does not apply (no tiles) or a check
        fails (write with OCCT's own writer then).
    """
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy

    order0, tiles0 = _tiles_of(topo)
    if not tiles0:
        return None
    copy = BRepBuilderAPI_Copy(topo, False, False).Shape()  # new topology, the same geometry
    traced = None
    if not tessellate and tolerance > 0:
        copy = _joined_walls(_merged(_merged(copy, MERGED), MERGED, trimmed=True))
    _segments(BRep_Builder(), copy)
    if not tessellate and tolerance > 0:
        traced = _fitted_traces(BRep_Builder(), copy, RIM_SHARE * tolerance, decimals_for(tolerance)[1])
        copy = _fused_sides(copy, traced)
    order, tiles = _tiles_of(copy)
    if tessellate and (len(order) != len(order0) or [t[0] for t in tiles] != [t[0] for t in tiles0]):
        return None
    grids = _grids(tiles)
    if any(g is None for g in grids):
        return None
    meshed = [False] * len(tiles)
    if tessellate:
        meshed = [_carries_grid_mesh(f, g[0].shape[0], g[0].shape[1]) for (_, f, _), g in zip(tiles0, grids)]
    b = BRep_Builder()
    sides = _sides(copy, tiles, grids)
    written = grids
    outer = _outer(sides, grids, traced if not tessellate and tolerance > 0 else None)
    inner = 4 if tessellate else 8  # 8: 5e-9 mm, below OCCT's own precision (1e-7 mm)
    if tolerance > 0 and not tessellate:
        inner, rounding = decimals_for(tolerance)
        red = _reduced(b, sides, grids, tolerance - rounding, inner, _foreign(tiles, sides, grids))

        # the points moved onto an edge's polyline between its own points keep 8 decimals too (so they stay on it:
        # with 6, OCCT's reader fixed the edges' tolerances and read a plate 3.5 times as long)
        outer = [o[np.ix_(r, c)] | line for o, (_, _, _, r, c, line) in zip(outer, red)]
        written = [(g, u, v) for g, u, v, _, _, _ in red]
    _line_pcurves(b, tiles, sides, grids, written)
    full, grids = grids, written
    if tolerance > 0 and not tessellate:
        got = _edges_written_fewer(b, copy, tiles, sides, full, grids, outer)
        if got is None:
            return None
        copy, tiles, grids, outer = got
    if inner < 8:  # poles a few rounding steps from a neighbour keep 8 decimals (else a sliver collapses)
        outer = [o | _thin(g, THIN * 10.0**-inner) for o, (g, _, _) in zip(outer, grids)]
    try:
        for _, face, surf in tiles:  # one per tile
            _stand_in(b, face, surf)
    except ValueError:
        return None
    data = occt_write(copy)
    return _complete(data, len(order), tiles, grids, meshed, outer, inner)


def _edges_written_fewer(b, shape, tiles: list, sides: list, full: list, written: list, outer: list):
    """``(shape, tiles, written, outer)`` with thin tiles' ``u`` knots placed for
    fewer Gauss points (:func:`_replaced_knots`), tiles mirrored where that puts fewer
    edges on their high-``u`` side (:func:`_flipped_tiles`) and the runs of edges
    between the same two faces joined (:func:`_joined_runs`); None where the faces
    did not stay the same in the same order (the caller uses OCCT's writer)."""

    def same(new):
        got = _tiles_of(new)[1]
        return got if [t[0] for t in got] == [t[0] for t in tiles] else None

    written, thin = _replaced_knots(b, tiles, sides, written)
    shape, written, outer = _flipped_tiles(b, shape, tiles, sides, full, written, outer, thin)
    tiles = same(shape)
    if tiles is None:
        return None
    shape = lined_edges(_joined_runs(shape, tiles, written, full, thin))
    tiles = same(shape)
    return None if tiles is None else (shape, tiles, written, outer)


def _flipped_tiles(b, shape, tiles: list, sides: list, full: list, written: list, outer: list, thin: set):
    """``(shape, written, outer)`` with each whole tile (not a wall) that has more
    edges on its high-``u`` side than on its low-``u`` one mirrored along ``u``
    (``u -> u0 + u1 - u``: its written grid's columns reversed, its pcurves mirrored,
    the face reversed in its shell: the same solid). OCCT's plain volume rule
    integrates a face from its lowest ``u`` (:mod:`texcad.brep.gprop`): each edge on
    the high side gets a pcurve of 61 Gauss points (:func:`_line_pcurves`: 11 or 17
    poles), each on the low side a ``LINE``; along a patch's staircase a tile meets
    the wall or the teeth beside it in many edges on one side and its neighbour in
    one on the other. ``full``/``written``: ``(grid, u, v)`` per tile before and
    after :func:`_reduced`; ``outer``: their poles kept with 8 decimals; ``thin``:
    tiles :func:`_replaced_knots` placed for fewer points (left as they are)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools_ReShape
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Ax2d, gp_Dir2d, gp_Pnt2d
    from OCP.TopLoc import TopLoc_Location

    from ..brep.solids import grid_surface

    reshape, written, outer, done = BRepTools_ReShape(), list(written), list(outer), False
    for k, ((_, face, _), tile, (g, u, v), (gw, wu, wv)) in enumerate(zip(tiles, sides, full, written)):  # one per tile
        lo = [(e, sd) for e, _, sd, _, _ in tile if sd is not None and sd[0] == 1 and sd[1] == 0]
        hi = [(e, sd) for e, _, sd, _, _ in tile if sd is not None and sd[0] == 1 and sd[1] == len(u) - 1]
        if len(wu) < 3 or len(hi) <= len(lo) or k in thin or _is_wall(g, u, v) or not _whole(face, u, v):
            continue
        if any(abs(BRep_Tool.Range_s(e)[0] - v[sd[2]]) > 1e-9 or abs(BRep_Tool.Range_s(e)[1] - v[sd[3]]) > 1e-9 for e, sd in lo):
            continue  # (a low side not parametrised as the grid)
        axis = gp_Ax2d(gp_Pnt2d(0.5 * (u[0] + u[-1]), 0.0), gp_Dir2d(0.0, 1.0))
        new_pc = {}
        for e, _, sd, _, _ in tile:  # one per edge: mirrored
            new_pc[e] = BRep_Tool.CurveOnSurface_s(e, face, 0.0, 0.0).Mirrored(axis)
        for e, sd in hi:  # the new low side: straight lines (the rule adds nothing there)
            new_pc[e] = Geom2d_Line(gp_Pnt2d(float(u[0]), 0.0), gp_Dir2d(0.0, 1.0))
        for e, sd in lo:  # the new high side: 61 points where the rule needs them (as _line_pcurves)
            t = v[sd[2] : sd[3] + 1]
            part = sd[2] > 0 or sd[3] < len(v) - 1
            if 2 * 2 * (len(wv) - 1) < GAUSS_ORDER or part:
                new_pc[e] = _rising(t, wv, (float(u[-1]), None))
            else:
                new_pc[e] = Geom2d_Line(gp_Pnt2d(float(u[-1]), 0.0), gp_Dir2d(0.0, 1.0))
        mu = wu[0] + wu[-1] - wu[::-1]
        mu[0], mu[-1] = wu[0], wu[-1]
        written[k] = (gw[:, ::-1].copy(), mu, wv)
        outer[k] = outer[k][:, ::-1].copy()
        tols = {e: BRep_Tool.Tolerance_s(e) for e in new_pc}
        b.UpdateFace(face, grid_surface(written[k][0], mu, wv), TopLoc_Location(), BRep_Tool.Tolerance_s(face))
        for e, pc in new_pc.items():  # one per edge of the tile
            b.UpdateEdge(e, pc, face, tols[e])
        reshape.Replace(face, face.Reversed())
        done = True
    return (reshape.Apply(shape) if done else shape), written, outer


#: Gauss points OCCT's plain rule takes across a tile of one ``v`` span whose edges
#: have straight pcurves (``BRepGProp_Face``: ``max(8, ...)``): :func:`_replaced_knots`
#: places such a tile's ``u`` knots for them.
THIN_ORDER = 8


def _replaced_knots(b, tiles: list, sides: list, written: list) -> tuple[list, set]:
    """``(written, thin)``: each whole tile of one ``v`` span and 2 to
    :data:`THIN_ORDER` ``u`` spans as written (a thin tile along a patch's staircase)
    with its ``u`` knots placed for the :data:`THIN_ORDER`-point rule OCCT's plain
    volume integration then takes across it (:func:`texcad.brep.gprop.gauss_knots`;
    the poles as they are: the same surface, its parameter mapped by a broken line
    ``phi``), its high-``u`` side a ``LINE`` instead of 61 points' pcurve (11 or 17
    poles, :func:`_line_pcurves`), each edge along ``u`` the broken line ``(phi(t),
    v)`` through its grid lines; ``thin``: their indices. A tile with any other edge
    stays as it is."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d
    from OCP.TopLoc import TopLoc_Location

    from ..brep.gprop import gauss_knots, polyline_pcurve
    from ..brep.solids import grid_surface

    written, thin = list(written), set()
    for k, ((_, face, _), tile, (gw, wu, wv)) in enumerate(zip(tiles, sides, written)):  # one per tile
        if len(wv) != 2 or not 3 <= len(wu) <= THIN_ORDER + 1 or _is_wall(gw, wu, wv):
            continue
        new_u = gauss_knots(float(wu[0]), float(wu[-1]), len(wu) - 1, THIN_ORDER)
        isos = [(e, _iso(e, face)) for e, _, _, _, _ in tile]
        if any(iso is None or (iso[0] == 0 and iso[1] not in (float(round(wu[0], 12)), float(round(wu[-1], 12)))) for _, iso in isos):
            continue  # (an edge off the tile's sides)
        new_pc = {}
        for e, (axis, value) in isos:  # one per edge
            if axis == 0:  # along v at u0 or u1: a line (the map keeps the ends)
                new_pc[e] = Geom2d_Line(gp_Pnt2d(value, 0.0), gp_Dir2d(0.0, 1.0))
                continue
            first, last = BRep_Tool.Range_s(e)
            t = np.r_[first, wu[(wu > first + 1e-9) & (wu < last - 1e-9)], last]
            new_pc[e] = polyline_pcurve(np.stack([np.interp(t, wu, new_u), np.full(len(t), value)], axis=1), t, pad=False)
        written[k] = (gw, new_u, wv)
        tols = {e: BRep_Tool.Tolerance_s(e) for e in new_pc}
        b.UpdateFace(face, grid_surface(gw, new_u, wv), TopLoc_Location(), BRep_Tool.Tolerance_s(face))
        for e, pc in new_pc.items():  # one per edge of the tile
            b.UpdateEdge(e, pc, face, tols[e])
        thin.add(k)
    return written, thin


def _rising(t: np.ndarray, own: np.ndarray, fixed: tuple):
    """The straight iso-u pcurve along a tile side on which OCCT's plain rule takes
    61 points (``t``: the side's grid lines, ``own``: the tile's written knots along
    it; ``fixed`` as in :func:`_padded`): :func:`_padded` where it gives 16 spans or
    raises the line, else the line raised on the tile's own knots."""
    mine = np.isin(t, own)
    mine[[0, -1]] = True
    if len(t) - 1 > PAD_SPANS or mine.sum() - 1 <= RAISED_SPANS:
        return _padded(t, own, fixed)
    k = t[mine]
    return _raised_line(k, fixed, max(1, int(np.ceil(GAUSS_ORDER / (2.0 * (len(k) - 1)))) - 1))


def _joined_runs(shape, tiles: list, grids: list, full: list, thin: set):
    """``shape`` with its runs of edges between the same two faces joined
    (:func:`texcad.io.step_edges.joined_edges`), the tiles' knots as written
    (``grids``: ``(grid, u, v)`` per tile of ``tiles``; ``full``: before
    :func:`_reduced`, which tells a patch's walls, :func:`_is_wall`; ``thin``: the
    tiles whose ``u`` knots are placed for :data:`THIN_ORDER` points)."""
    mine = _tile_map(tiles)
    walls = [_is_wall(*g) for g in full]

    def knots_of(face):
        i = mine.FindIndex(face) - 1
        return None if i < 0 else (grids[i][1], grids[i][2], walls[i], THIN_ORDER if i in thin else GAUSS_ORDER)

    return joined_edges(shape, knots_of)


#: Most grid cells a wall :func:`_joined_walls` makes runs along (as many as a strip,
#: :data:`texcad.brep.bands.RUN`): a mitre's walls joined all along the outline (a few
#: hundred cells each; their poles then with 3 decimals) made no smaller a STEP, which
#: read back valid and within 0.1 %, but OCCT's mesher left a hole.
WALL_CELLS = 24


def _wall_links(shape, tiles: list, grids: list) -> dict:
    """``{i: (j, ruling)}``: the wall strips of a patch (:func:`_is_wall`) continued by
    another: the tile ``i``'s side at its last ``u`` knot is an edge (``ruling``) that the tile ``j`` has at its first ``u`` knot, the
    two surfaces' poles there the same (to 1e-9 mm), their ``v`` knots the same and both
    faces the same way round in the shell: the two are one degree-1 ruled strip over
    ``u`` (its grid columns end to end), cut apart at the ruling."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_Line
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    strips = {i for i, (g, u, v) in enumerate(grids) if _is_wall(g, u, v)}
    if not strips:
        return {}
    mine = _tile_map(tiles)
    ancestors = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ancestors)
    links, taken = {}, set()
    for i in sorted(strips):  # one per strip (hundreds)
        face, (g, u, v) = tiles[i][1], grids[i]
        for e in explore(face, TopAbs_EDGE):  # its edges (four or five)
            e = TopoDS.Edge_s(e)
            if not isinstance(BRep_Tool.CurveOnSurface_s(e, face, 0.0, 0.0), Geom2d_Line):  # not a ruling
                continue
            owners = [TopoDS.Face_s(f) for f in shapes_in(ancestors.FindFromKey(e))]
            if len(owners) != 2 or _iso(e, face) != (0, float(round(u[-1], 12))):
                continue
            other = owners[1] if owners[0].IsSame(face) else owners[0]
            j = mine.FindIndex(other) - 1
            if j < 0 or j not in strips or j in taken or j == i or other.Orientation() != face.Orientation():
                continue
            h, uj, vj = grids[j]
            if (_iso(e, other) == (0, float(round(uj[0], 12))) and np.array_equal(v, vj)
                    and np.abs(g[:, -1] - h[:, 0]).max() <= 1e-9):  # fmt: skip
                links[i] = (j, e)
                taken.add(j)
                break
    return links


def _is_wall(g: np.ndarray, u: np.ndarray, v: np.ndarray) -> bool:
    """Is the grid ``(g, u, v)`` a patch's wall strip (``texcad.brep.bands``): two rows
    of poles, ``v`` 0 .. 1, ``u`` the grid index from 0?"""
    return g.shape[0] == 2 and np.array_equal(v, [0.0, 1.0]) and np.array_equal(u, np.arange(len(u)))


def _folded(top: np.ndarray) -> bool:
    """Does the polyline ``top`` (a wall's tile side, mm) turn by more than 45 degrees
    at a point (a wall joined along a staircase of grid lines)?"""
    d = np.diff(top, axis=0)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    return bool(((d[1:] * d[:-1]).sum(axis=1) < np.sqrt(0.5)).any())


def _wall_chains(links: dict, grids: list, most: int) -> list:
    """Chains ``[i, ...]`` of strips :func:`_wall_links` links end to end (a loop
    all around is opened at its lowest strip), each of at most ``most`` grid cells
    (a longer one split; a loop in two at least), two strips at least."""
    heads = sorted(set(links) - {j for j, _ in links.values()})
    out, seen = [], set()
    for h in heads + sorted(links):  # one per chain (the heads first: the rest are loops)
        if h in seen:
            continue
        strips = _follow(links, h)
        seen.update(strips)
        cap = most
        if strips[-1] in links:  # a loop: two chains (one face would hold a ruling twice, a seam)
            cap = min(most, (sum(len(grids[i][1]) - 1 for i in strips) + 1) // 2)
        runs = runs_within([len(grids[i][1]) - 1 for i in strips], cap)  # cells per strip
        out.extend([strips[k] for k in r] for r in runs)
    return [c for c in out if len(c) > 1]


def _follow(links: dict, i: int) -> list:
    """The strips from ``i`` along ``links`` to the chain's end (or back to ``i``)."""
    out = [i]
    while out[-1] in links and links[out[-1]][0] != i:  # one per strip
        out.append(links[out[-1]][0])
    return out


def _joined_wall(b, chain: list, links: dict, tiles: list, grids: list):
    """One face for the strips ``chain`` (:func:`_wall_chains`), the same way round
    as they are: its surface the degree-1 strip through their grid columns end to end
    (strip ``k``'s ``u`` shifted by ``o_k``, the sum of the spans before it, so that
    the surface is theirs there point for point), its wire their edges but the rulings
    between them, each edge's pcurve on it its pcurve on its strip shifted by ``o_k``
    along ``u`` (the old one dropped). None where the edges do not close one loop."""
    from OCP.BRep import BRep_Tool
    from OCP.gp import gp_Vec2d
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS, TopoDS_Face, TopoDS_Wire
    from OCP.TopTools import TopTools_IndexedMapOfShape

    from ..brep.solids import grid_surface

    inner = TopTools_IndexedMapOfShape()
    for i in chain[:-1]:  # the rulings between the strips
        inner.Add(links[i][1])
    cols, knots, moved, at = [], [], [], 0.0
    for k, i in enumerate(chain):  # one per strip
        g, u, v = grids[i]
        off = at - float(u[0])
        cols.append(g if k == 0 else g[:, 1:])
        knots.append((u + off) if k == 0 else (u[1:] + off))
        at = float(u[-1]) + off
        face = TopoDS.Face_s(tiles[i][1].Oriented(TopAbs_FORWARD))
        for e in explore(face, TopAbs_EDGE):  # its edges, as its wire runs them
            if inner.Contains(e):
                continue
            if BRep_Tool.IsClosed_s(TopoDS.Edge_s(e), face):
                return None
            moved.append((TopoDS.Edge_s(e), face, off))
    surf = grid_surface(np.concatenate(cols, axis=1), np.concatenate(knots), grids[chain[0]][2])
    new = TopoDS_Face()
    b.MakeFace(new, surf, max(BRep_Tool.Tolerance_s(tiles[i][1]) for i in chain))
    verts = TopTools_IndexedMapOfShape()
    starts = {}
    for e, face, off in moved:  # one per edge kept (tens)
        starts[verts.Add(TopExp.FirstVertex_s(e, True))] = e
    loop = [moved[0][0]]
    while len(loop) < len(moved):  # the edges end to end
        nxt = starts.get(verts.FindIndex(TopExp.LastVertex_s(loop[-1], True)))
        if nxt is None or any(nxt.IsSame(x) for x in loop):
            return None
        loop.append(nxt)
    if len(starts) != len(moved) or not TopExp.LastVertex_s(loop[-1], True).IsSame(TopExp.FirstVertex_s(loop[0], True)):
        return None
    for e, face, off in moved:  # their pcurves moved onto the joined strip
        tol = BRep_Tool.Tolerance_s(e)
        pc = BRep_Tool.CurveOnSurface_s(e, face, 0.0, 0.0)
        b.UpdateEdge(e, pc.Translated(gp_Vec2d(off, 0.0)), new, tol)
        b.UpdateEdge(e, None, face, tol)
    wire = TopoDS_Wire()
    b.MakeWire(wire)
    for e in loop:  # counter-clockwise, as on the strips
        b.Add(wire, e)
    wire.Closed(True)
    b.Add(new, wire)
    return new if tiles[chain[0]][1].Orientation() == TopAbs_FORWARD else new.Reversed()


def _joined_walls(shape, most: int = WALL_CELLS):
    """``shape`` with each chain of wall strips end to end (:func:`_wall_chains`)
    written as one face (:func:`_joined_wall`): where a patch's outline crosses the
    texture grid its walls step along it a cell or two each (``texcad.brep.bands``),
    and each, with its ruling and its section edge, weighed more in the STEP than the
    tiles beside it. The joined face is the same surface, bounded by the same edges
    (but the rulings between the strips), so the solid is the same point for point;
    :func:`_trace_runs` then joins the section edges along it."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools_ReShape

    _, tiles = _tiles_of(shape)
    grids = _grids(tiles)
    links = _wall_links(shape, tiles, grids)
    b, reshape, done = BRep_Builder(), BRepTools_ReShape(), False
    for chain in _wall_chains(links, grids, most):  # one per joined wall
        new = _joined_wall(b, chain, links, tiles, grids)
        if new is None:
            continue
        reshape.Replace(tiles[chain[0]][1], new)
        for i in chain[1:]:  # the strips it replaces
            reshape.Remove(tiles[i][1])
        done = True
    return reshape.Apply(shape) if done else shape


def _segments(b, shape) -> None:
    """Give each edge of ``shape`` whose 3-D curve is a B-spline reaching past the
    edge's range that curve's segment over the range (``Geom_BSplineCurve::Segment``:
    the same points at the same parameters, so the pcurves stay as they are). The
    lifted grid lines between the tiles of a trimmed face
    (:mod:`texcad.brep.uvtrim`) are iso curves of the whole face's surface: written
    whole, each carried every pole of a grid row (a drilled cylinder's STEP: 4 MB of
    its 5.5 MB)."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineCurve
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    edges = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_EDGE, edges)
    for k in range(1, edges.Extent() + 1):  # one per edge
        edge = TopoDS.Edge_s(edges.FindKey(k))
        loc = TopLoc_Location()
        curve = BRep_Tool.Curve_s(edge, loc, 0.0, 0.0)
        if not isinstance(curve, Geom_BSplineCurve) or curve.IsPeriodic():
            continue
        first, last = BRep_Tool.Range_s(edge)
        lo, hi = curve.FirstParameter(), curve.LastParameter()
        eps = 1e-9 * (1.0 + abs(lo) + abs(hi))
        if first <= lo + eps and last >= hi - eps or last - first <= eps:
            continue
        inside = sum(first - eps < curve.Knot(i) < last + eps for i in range(1, curve.NbKnots() + 1))  # per knot
        if inside + 2 >= curve.NbKnots():  # nothing much to drop
            continue
        seg = curve.Copy()
        seg.Segment(max(first, lo), min(last, hi))
        b.UpdateEdge(edge, seg, loc, BRep_Tool.Tolerance_s(edge))
        b.Range(edge, first, last)


#: Share of the tolerance a trace's polyline may miss OCCT's curve by (:func:`_fitted_traces`;
#: the curve lies on the written tile), and the most its pcurves' images may lie from it
#: (times that share; the edge's tolerance covers it): a 30 mm plate drilled through was
#: 2.02x its STL with a quarter of each, 1.99x with these.
RIM_SHARE = 1.0
RIM_PCURVE = 0.5
#: Decimals (mm) of a fitted trace's inner points (its pcurves' inner points: 6): its
#: ends are the vertices, as they are.
TRACE_DECIMALS = 5


def _fitted_traces(b, shape, tol: float, rounding: float = 0.0):
    """Each edge of a texture tile that a tool's surface traced (OCCT's intersection
    curves around a hole drilled through the texture: B-splines of degree 3-8 with
    tens of poles, in 3-D and on both faces) becomes a polyline through points of
    that curve within ``tol`` mm of it (:func:`_keep` on samples along it), its
    pcurves the polylines through the same points' parameters on each face, at the
    same parameters. The edge's tolerance then covers the largest distance between
    the 3-D polyline and its pcurves' images (at most :data:`RIM_PCURVE` times
    ``tol``; else the edge stays as it is) on the tiles as written: their poles
    rounded by up to ``rounding`` mm (:func:`decimals_for`) move the images as far.
    STEP keeps no edge tolerance: OCCT's writer puts the mean of the shape's
    tolerances in the file's uncertainty, which its reader takes as its precision.
    Without the rounding, an L plate at 0.25 mm (issue 28) was written with 2e-4 mm
    (with it 5e-4 mm; 3e-4 mm already did), and OCCT's reader re-made the pcurve of a
    trace joined along a wall a few hundredths of a mm high across the wall's top,
    split the wall there and its mesher left a hole. A short trace keeps
    a few points instead of OCCT's tens of poles in three curves. Returns the edges
    made polylines (a
    ``TopTools_IndexedMapOfShape``): the tiles' poles around them keep the tiles'
    decimals (:func:`_outer`)."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineCurve
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape

    _, tiles = _tiles_of(shape)
    mine = _tile_map(tiles)
    ancestors = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ancestors)
    done = TopTools_IndexedMapOfShape()
    for k in range(1, ancestors.Extent() + 1):  # one per edge
        edge = TopoDS.Edge_s(ancestors.FindKey(k))
        faces = [TopoDS.Face_s(f) for f in shapes_in(ancestors.FindFromIndex(k))]
        loc = TopLoc_Location()
        curve = BRep_Tool.Curve_s(edge, loc, 0.0, 0.0)
        if (not isinstance(curve, Geom_BSplineCurve) or curve.Degree() < 2 or not loc.IsIdentity()
                or not any(mine.Contains(f) for f in faces) or BRep_Tool.Degenerated_s(edge)):  # fmt: skip
            continue
        if any(BRep_Tool.IsClosed_s(edge, f) or not f.Location().IsIdentity() for f in faces):
            continue
        fit = _trace_fit(edge, curve, faces, tol)
        if fit is None:
            continue
        t, p, uvs, gap = fit
        p[1:-1], uvs = np.round(p[1:-1], TRACE_DECIMALS), [np.r_[q[:1], np.round(q[1:-1], KNOT_DECIMALS - 3), q[-1:]] for q in uvs]
        etol = max(BRep_Tool.Tolerance_s(edge), 1.5 * gap + rounding + 1e-7)  # the images on the rounded tiles
        b.UpdateEdge(edge, _polyline3d(p, t), TopLoc_Location(), etol)
        for f, uv in zip(faces, uvs):  # one per face of the edge (two)
            b.UpdateEdge(edge, _polyline2d(uv, t), f, etol)
        b.Range(edge, float(t[0]), float(t[-1]))
        for vx in (TopExp.FirstVertex_s(edge), TopExp.LastVertex_s(edge)):  # its ends at least as wide
            b.UpdateVertex(vx, max(BRep_Tool.Tolerance_s(vx), etol))
        done.Add(edge)
    return done


def _trace_fit(edge, curve, faces: list, tol: float):
    """``(params (k,), 3-D points (k, 3), [uv (k, 2) per face], gap mm)``: the points
    an edge's polyline keeps within ``tol`` of its curve sampled along its range (more
    where a pcurve's image strays past :data:`RIM_PCURVE` times ``tol`` from it), or
    None when it would keep as many as the curve has poles (:func:`_fitted_traces`)."""
    from OCP.BRep import BRep_Tool

    first, last = BRep_Tool.Range_s(edge)
    n = int(np.clip(2 * curve.NbPoles() + 1, 9, 129))
    t = np.linspace(first, last, n)
    p = np.array([curve.Value(a).Coord() for a in t.tolist()])  # per sample (tens)
    pcs = [BRep_Tool.CurveOnSurface_s(edge, f, 0.0, 0.0) for f in faces]
    if any(pc is None for pc in pcs):
        return None
    uv = [np.array([pc.Value(a).Coord() for a in t.tolist()]) for pc in pcs]  # per face, per sample
    surfs = [BRep_Tool.Surface_s(f) for f in faces]
    kept = _chords(p, t, tol)
    for _ in range(8):  # a few rounds: more points where a pcurve's image strays
        if len(kept) >= curve.NbPoles():
            return None
        gap = _image_gap(p, uv, surfs, kept)
        far = gap > RIM_PCURVE * tol
        if not far.any():
            return t[kept], p[kept], [q[kept] for q in uv], float(gap.max(initial=0.0))
        a, z = kept[:-1][far], kept[1:][far]
        if (z - a < 2).any():
            return None
        kept = np.union1d(kept, (a + z) // 2)
    return None


def _image_gap(p: np.ndarray, uv: list, surfs: list, kept: np.ndarray) -> np.ndarray:
    """Per span between the kept samples ``kept`` of a trace: the largest distance
    (mm) between the 3-D polyline through ``p[kept]`` and the images on their
    surfaces ``surfs`` of the polylines through ``uv[f][kept]``, at the samples
    between and the span's middle."""
    w = np.arange(len(p))
    span = np.clip(np.searchsorted(kept, w, side="right") - 1, 0, len(kept) - 2)
    s = ((w - kept[span]) / (kept[span + 1] - kept[span]))[:, None]
    mids = (0.5 * (kept[:-1] + kept[1:]))
    ms = np.arange(len(kept) - 1)
    line = np.concatenate([p[kept[span]] * (1 - s) + p[kept[span + 1]] * s,
                           0.5 * (p[kept[:-1]] + p[kept[1:]])])  # fmt: skip
    which = np.concatenate([span, ms])
    gap = np.zeros(len(kept) - 1)
    del mids
    for q, surf in zip(uv, surfs):  # one per face (two)
        at = np.concatenate([q[kept[span]] * (1 - s) + q[kept[span + 1]] * s, 0.5 * (q[kept[:-1]] + q[kept[1:]])])
        img = np.array([surf.Value(a, c).Coord() for a, c in at.tolist()])  # per sample (tens)
        np.maximum.at(gap, which, np.sqrt(((img - line) ** 2).sum(-1)))
    return gap


def _chords(p: np.ndarray, t: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the points ``p`` ``(n, 3)`` mm (at the increasing parameters ``t``)
    a polyline keeps within ``tol`` mm of every point, at their parameters: from each
    kept point the farthest one whose chord holds all between (any length)."""
    n = len(t)
    kept, at = [0], 0
    while at < n - 1:  # one per kept point (a few)
        j = np.arange(at + 1, n)
        w = np.clip((t[None, :] - t[at]) / (t[j] - t[at])[:, None], 0.0, 1.0)  # (chord, sample)
        chord = p[at] + w[..., None] * (p[j] - p[at])[:, None, :]
        d = np.sqrt(((chord - p[None, :, :]) ** 2).sum(-1))
        inside = (np.arange(n)[None, :] > at) & (np.arange(n)[None, :] < j[:, None])
        holds = np.flatnonzero(np.where(inside, d, 0.0).max(1) <= tol)
        at = int(j[holds[-1]]) if len(holds) else at + 1
        kept.append(at)
    return np.asarray(kept)


def _polyline2d(q: np.ndarray, t: np.ndarray):
    """The degree-1 ``Geom2d_BSplineCurve`` through ``q`` ``(k, 2)`` at ``t`` ``(k,)``."""
    from ..brep.gprop import polyline_pcurve

    return polyline_pcurve(q, t, pad=False)


def _line_pcurves(b, tiles: list, sides: list, grids: list, written: list) -> None:
    """Shorten the pcurve of each edge along a whole tile side (:func:`_sides`) on
    that tile where the edge is parametrised as the tile's grid (its range the side's
    knots, its start the side's first grid point) and the pcurve is that
    iso-parameter line as a 2-D B-spline with a knot per grid line: texcad pads those
    to at least 16 spans so that OCCT's plain volume rule puts its 61 Gauss points
    along them (:mod:`texcad.brep.gprop`), a ``CARTESIAN_POINT`` and a knot per grid
    line in the STEP (7 % of a plate's file). Written as a ``LINE`` where the tile as
    written has 16 spans in v or more (OCCT's rule then takes its 61 points from the
    surface: ``2 (1 + 1) 16``) and the edge is the tile's whole side; on fewer spans,
    or along a part of the side (a strip's run: with a ``LINE`` there OCCT's adaptive
    integration read an engraved full cylinder's STEP 0.19 % low, its plain rule right),
    the padded pcurve keeps
    :data:`PAD_SPANS` of its spans (:func:`_padded`: the tile's own knots along it and
    grid lines between; the same line in 11 poles, :func:`_gauss_line`, put a band's
    re-read volume 0.42 % off); ``written``: ``(grid, u, v)`` per tile as written.
    A ``LINE`` too where the rule's integrand has no kink (:func:`_kinked`: the tile
    as written has no knot inside the ranges it integrates over; the staircase's one-
    and two-cell tiles along a patch's outline) and on every iso-v side (it adds
    nothing to the rule): the mitre of ``bench_step.py --sizes`` 5.51 -> 4.98 MB, its
    volumes as they were. Other pcurves stay."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_BSplineCurve, Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d

    for (_, face, _), tile, (g, u, v), (_, wu, wv) in zip(tiles, sides, grids, written):  # one per tile
        spans = len(wv) - 1
        for edge, _, side, _, _ in tile:  # one per edge
            if side is None or BRep_Tool.IsClosed_s(edge, face):
                continue
            axis, line, lo, hi = side
            t = (v if axis == 1 else u)[lo : hi + 1]
            first, last = BRep_Tool.Range_s(edge)
            curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
            pc = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
            start = g[lo, line] if axis == 1 else g[line, lo]
            if curve is None or not isinstance(pc, Geom2d_BSplineCurve) or abs(first - t[0]) > 1e-9 or abs(last - t[-1]) > 1e-9:
                continue
            if 2 * (pc.Degree() + 1) * (pc.NbKnots() - 1) < GAUSS_ORDER and axis == 1:
                continue
            if np.abs(np.array(curve.Value(first).Coord()) - start).max() > 1e-7 * (1 + np.abs(start).max()):
                continue
            kn = np.array([pc.Knot(i) for i in range(1, pc.NbKnots() + 1)])  # per knot (16-30)
            at = np.unique(np.clip(np.r_[kn, 0.5 * (kn[1:] + kn[:-1]), first, last], first, last))
            iso = np.stack([np.full(len(at), u[line]), at] if axis == 1 else [at, np.full(len(at), v[line])], axis=-1)
            if np.abs(np.array([pc.Value(a).Coord() for a in at.tolist()]) - iso).max() > 1e-9 * (1 + np.abs(iso).max()):
                continue  # not the straight iso-line along its whole length (checked at every knot and between)
            part = lo > 0 or hi < len(v if axis == 1 else u) - 1  # a part of the tile's side (a strip's run)
            kinked = _kinked(wu, wv, axis, u[line] if axis == 1 else v[line], t)
            if (2 * 2 * spans < GAUSS_ORDER or part) and kinked:  # padded (an 11-pole line in its place put the re-read
                # band of a box's sides and fillets 0.42 % off: tests/brep/test_face_kinds_bands.py)
                mine = np.isin(t, wv if axis == 1 else wu)
                mine[[0, -1]] = True
                if len(t) - 1 > PAD_SPANS or mine.sum() - 1 <= RAISED_SPANS:  # (a shorter side's padded pcurve has
                    # knots between its grid lines: kept, or raised on the tile's own knots, :func:`_raised_line`)
                    fixed = (u[line], None) if axis == 1 else (None, v[line])
                    b.UpdateEdge(edge, _padded(t, wv if axis == 1 else wu, fixed), face, BRep_Tool.Tolerance_s(edge))
                continue
            at = gp_Pnt2d(u[line], 0.0) if axis == 1 else gp_Pnt2d(0.0, v[line])
            new = Geom2d_Line(at, gp_Dir2d(0.0, 1.0) if axis == 1 else gp_Dir2d(1.0, 0.0))
            b.UpdateEdge(edge, new, face, BRep_Tool.Tolerance_s(edge))


def _kinked(wu: np.ndarray, wv: np.ndarray, axis: int, at: float, t: np.ndarray) -> bool:
    """Does OCCT's plain volume rule integrate over a knot of a tile written on the
    knots ``wu`` x ``wv`` along its iso-parameter edge (``axis`` 1: at ``u = at``,
    from ``t[0]`` to ``t[-1]`` in v; 0: iso-v)? Along an iso-u edge the rule takes
    its points along the edge and, at each, along u from the tile's first knot to
    ``at`` (``BRepGProp_Gauss``): without a knot inside either range the integrand is
    a polynomial (of degree 2 each way on a bilinear span), which the rule's 8 points
    at least (a ``LINE`` pcurve on a degree-1 surface) take exactly; an iso-v edge,
    and an iso-u edge at the tile's first knot, add nothing. Else the pcurve keeps its
    spans (:func:`_padded`)."""
    if axis == 0 or at <= wu[0]:
        return False  # (along u, or at the first u: the rule's range along u is empty)
    inside = ((wv > t[0]) & (wv < t[-1])).any() or ((wu > wu[0]) & (wu < at)).any()
    return bool(inside)


#: Spans a padded pcurve keeps (:func:`_padded`): OCCT's plain rule takes
#: ``2 (1 + 1) 16 = 64`` points, capped at :data:`GAUSS_ORDER` (``texcad.brep.gprop``).
PAD_SPANS = 16


#: Most own spans along a tile side :func:`_padded` writes raised (:func:`_raised_line`).
RAISED_SPANS = 8


def _padded(t: np.ndarray, own: np.ndarray, fixed: tuple):
    """The straight iso-line pcurve along a tile side as a degree-1 2-D B-spline of
    :data:`PAD_SPANS` spans, parametrised as the side (its parameter is the running
    coordinate): knots at the tile's own knots ``own`` within the side's grid lines
    ``t`` and at grid lines between, evenly picked (OCCT's adaptive integration
    starts from a pcurve's knots). ``fixed``: ``(u, None)`` for an iso-u side,
    ``(None, v)`` for an iso-v one. A side of at most 8 own spans (a patch's 4-cell
    tiles, ``texcad.brep.bands``) is written on its own knots instead (spans halved
    up to 4), of degree ``ceil(61 / (2 spans)) - 1`` (:func:`_raised_line`: 11 poles
    for 17; the merged flattened box patch of ``bench_step.py --sizes`` 3.90 -> 3.66 MB)."""
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.TColgp import TColgp_Array1OfPnt2d
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.gp import gp_Pnt2d

    mine = np.isin(t, own)
    mine[[0, -1]] = True
    k = t[mine]
    if len(k) - 1 <= RAISED_SPANS:  # the side's own knots (widest spans halved up to 4), the degree raised: 11 poles (with
        # more own spans the padded line is as long, its poles on grid lines a neighbouring tile's pcurve shares)
        while len(k) - 1 < 4:  # (a few: a side of 1-3 spans)
            w = int(np.argmax(np.diff(k)))
            k = np.insert(k, w + 1, 0.5 * (k[w] + k[w + 1]))
        return _raised_line(k, fixed, int(np.ceil(GAUSS_ORDER / (2.0 * (len(k) - 1)))) - 1)
    k = t[_pad(np.isin(t, own))]
    poles, knots, mults = TColgp_Array1OfPnt2d(1, len(k)), TColStd_Array1OfReal(1, len(k)), TColStd_Array1OfInteger(1, len(k))
    for i, kv in enumerate(k.tolist()):  # one per knot (17)
        poles.SetValue(i + 1, gp_Pnt2d(fixed[0], kv) if fixed[0] is not None else gp_Pnt2d(kv, fixed[1]))
        knots.SetValue(i + 1, kv)
        mults.SetValue(i + 1, 2 if i in (0, len(k) - 1) else 1)
    return Geom2d_BSplineCurve(poles, knots, mults, 1)


def _raised_line(k: np.ndarray, fixed: tuple, deg: int):
    """The straight iso-line pcurve along a tile side (``fixed`` as in :func:`_padded`),
    parametrised as the side, as a B-spline of degree ``deg`` whose knots are ``k``
    only (the tile's own knots along it, simple inside): poles at the Greville
    abscissae ``(t_{i+1} + ... + t_{i+deg}) / deg`` of the full knot vector (a B-spline
    reproduces linear functions there), ``len(k) - 1 + deg`` of them. OCCT's plain rule
    takes ``min(2 (deg + 1) spans, 61)`` points along it (61 for ``deg`` from
    ``ceil(61 / (2 spans)) - 1``), its adaptive integration starts at the grid lines
    ``k``; 11 poles and 5 knots for a 4-cell side instead of 17 and 17 padded."""
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.TColgp import TColgp_Array1OfPnt2d
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.gp import gp_Pnt2d

    full = np.r_[[k[0]] * deg, k, [k[-1]] * deg]
    n = len(k) - 1 + deg
    grev = np.convolve(full[1:-1], np.ones(deg) / deg, mode="valid")[:n]  # per pole
    grev[0], grev[-1] = k[0], k[-1]
    poles, knots, mults = TColgp_Array1OfPnt2d(1, n), TColStd_Array1OfReal(1, len(k)), TColStd_Array1OfInteger(1, len(k))
    for i, g in enumerate(grev.tolist()):  # per pole (about 11)
        poles.SetValue(i + 1, gp_Pnt2d(fixed[0], g) if fixed[0] is not None else gp_Pnt2d(g, fixed[1]))
    for i, kv in enumerate(k.tolist()):  # per knot (about 5)
        knots.SetValue(i + 1, kv)
        mults.SetValue(i + 1, deg + 1 if i in (0, len(k) - 1) else 1)
    return Geom2d_BSplineCurve(poles, knots, mults, deg)


#: OCCT's largest Gauss rule (``math::GaussPointsMax``), what texcad's padded pcurves
#: get from its plain volume integration (:mod:`texcad.brep.gprop`).
GAUSS_ORDER = 61


def _gauss_line(a: np.ndarray, b: np.ndarray, first: float, last: float):
    """The straight 2-D line from ``a`` at ``first`` to ``b`` at ``last`` (linear in
    its parameter) as a degree-3 B-spline of 8 even spans, poles at the Greville
    abscissae: OCCT's plain volume rule integrates along it with ``2 (3 + 1) 8 = 64``
    points, capped at :data:`GAUSS_ORDER`, as along texcad's padded pcurves, from 11
    poles."""
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.TColgp import TColgp_Array1OfPnt2d
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.gp import gp_Pnt2d

    deg, spans = 3, 8
    k = first + (last - first) * np.arange(spans + 1) / spans
    k[-1] = last
    full = np.r_[[first] * deg, k, [last] * deg]
    grev = np.array([full[i + 1 : i + 1 + deg].mean() for i in range(spans + deg)])  # per pole (11)
    w = (grev - first) / (last - first)
    poles, knots, mults = TColgp_Array1OfPnt2d(1, len(w)), TColStd_Array1OfReal(1, spans + 1), TColStd_Array1OfInteger(1, spans + 1)
    for i, f in enumerate(w.tolist()):  # per pole (11)
        x, y = (a + (b - a) * f).tolist()
        poles.SetValue(i + 1, gp_Pnt2d(x, y))
    for i, kv in enumerate(k.tolist()):  # per knot (9)
        knots.SetValue(i + 1, kv)
        mults.SetValue(i + 1, deg + 1 if i in (0, spans) else 1)
    return Geom2d_BSplineCurve(poles, knots, mults, deg)


def decimals_for(tolerance: float) -> tuple[int, float]:
    """Decimals for the poles inside the tiles of a STEP at ``tolerance`` mm, and the
    largest distance (mm) that rounding moves a point: a tenth of the tolerance at
    most (4 decimals, 5e-5 mm a coordinate, for an exact grid; 3 for 0.02 mm)."""
    d = 4 if tolerance <= 0 else int(min(4, max(2, np.ceil(np.log10(5 * np.sqrt(3) / tolerance)))))
    return d, 0.5 * 10.0**-d * np.sqrt(3)


def _sides(shape, tiles: list, grids: list) -> list:
    """Each tile's edges as ``(edge, shared, tile side)``: ``shared`` when the edge
    lies between two tiles (else it meets the part's own faces, or is a seam); the
    side ``(axis, line, lo, hi)``: ``axis`` 1 for an iso-u edge (grid column ``line``,
    rows ``lo..hi``), 0 for an iso-v edge (grid row ``line``, columns ``lo..hi``).
    An edge that is neither (a given outline's) has side None."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp, TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    ancestors = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ancestors)
    mine = _tile_map(tiles)
    out = []
    for (_, face, _), (g, u, v) in zip(tiles, grids):  # one per tile
        sides = []
        exp = TopExp_Explorer(face, TopAbs_EDGE)
        while exp.More():  # one per edge of the tile (a handful)
            edge = TopoDS.Edge_s(exp.Current())
            exp.Next()
            faces = ancestors.FindFromKey(edge)
            shared = faces.Size() == 2 and all(mine.Contains(f) for f in shapes_in(faces)) and not BRep_Tool.IsClosed_s(edge, face)
            plane = None if shared else _plane_beside(faces, face)
            u0, u1, v0, v1 = BRepTools.UVBounds_s(face, edge)  # the pcurve's box (a hole's circle too)
            eu, ev = 1e-9 * (1 + abs(u).max()), 1e-9 * (1 + abs(v).max())
            iu = np.flatnonzero((u >= u0 - eu) & (u <= u1 + eu))
            iv = np.flatnonzero((v >= v0 - ev) & (v <= v1 + ev))
            side = None
            if len(iu) == 1 and iu[0] in (0, len(u) - 1) and len(iv) >= 2 and u1 - u0 <= 2 * eu:
                side = (1, int(iu[0]), int(iv[0]), int(iv[-1]))
            elif len(iv) == 1 and iv[0] in (0, len(v) - 1) and len(iu) >= 2 and v1 - v0 <= 2 * ev:
                side = (0, int(iv[0]), int(iu[0]), int(iu[-1]))
            if side is None:  # any other edge (a given outline, a hole's trace): the grid lines around it
                iu = np.arange(max(np.searchsorted(u, u0 - eu, "right") - 1, 0), min(np.searchsorted(u, u1 + eu), len(u) - 1) + 1)
                iv = np.arange(max(np.searchsorted(v, v0 - ev, "right") - 1, 0), min(np.searchsorted(v, v1 + ev), len(v) - 1) + 1)
            sides.append((edge, shared, side, (iu, iv), plane))
        out.append(sides)
    return out


def _outer(sides: list, grids: list, traced=None) -> list:
    """Per tile, ``(rows, cols)`` True on the poles of an edge that is not shared with
    another tile: where the patchwork meets the part's own faces (their curves and
    pcurves are OCCT's, so these poles keep 8 decimals). Not the edges in ``traced``
    (a ``TopTools_IndexedMapOfShape``: traces :func:`_fitted_traces` made polylines,
    whose tolerance is the tiles' already). Every pole of a wall :func:`_joined_walls`
    joined (:func:`_is_wall` and :func:`_folded`): the traces along it may hold tighter
    than its rounding (a wall is a few hundredths of a mm high, its section polylines
    fitted within a few um); with 3 decimals OCCT's reader re-made some of their
    pcurves, across a fold onto the wall's top, split the wall there and its mesher
    left a hole (a box top and two mitred fillets at 0.5 and 0.125 mm). A straight
    strip keeps its rounding (with 8 decimals a band's STEP was 0.7 % larger)."""
    out = []
    for tile, (g, u, v) in zip(sides, grids):  # one per tile
        on = np.full(g.shape[:2], _is_wall(g, u, v) and _folded(g[0]))  # a joined wall: every pole (docstring)
        for edge, shared, _, (iu, iv), _ in tile:  # one per edge
            if not shared and (traced is None or not traced.Contains(edge)):
                on[np.ix_(iv, iu)] = True
        out.append(on)
    return out


#: Largest side (grid cells) of a tile :func:`_merged` makes from whole tiles side by
#: side: texcad's own tiles' (:data:`texcad.brep.TILE`).
MERGED = TILE
#: Smallest knot span against the largest of tiles :func:`_merged` merges
#: (:func:`_even`).
EVEN = 0.05
#: Longest chord (grid cells) :func:`_keep` tries.
SPAN = 8
#: Share of the tolerance an edge's polyline may miss its grid points by: between two
#: tiles, and beside a planar face of the part (whose volume OCCT's plain rule takes
#: along it; there least squares, not minimax: with Lawson's rounds a cylinder's end
#: rings put its plain volume +0.27 % off, +0.13 % without). A 30 mm plate drilled
#: through was +0.14 % off in the plain rule at the whole tolerance while :func:`_merged`
#: merged fine tiles whose knots were not placed for the rule; with those left as they
#: are, 0.9 of it moves the plain volume by 0.001 % from 0.75 (and the file 2 % smaller).
EDGE_SHARE = 1.0
PLANE_SHARE = 0.9
#: Cost of a point an edge keeps, besides the rows or columns of poles it adds to the
#: tiles on its sides (one each where that tile has none there yet; :func:`_keep`).
NEW_POINT = 0.5
#: Shares of that an edge's chords are first chosen within (:func:`_edge_fit`); the
#: last, 1.0, is the chords through the grid points.
EDGE_SHARES = (2.0, 1.5, 1.0)
#: Shares of the tolerance a tile's rows and columns are first chosen within (each
#: direction); the bilinear result is then checked against the whole tolerance.
INNER_SHARES = (4.0, 3.0, 2.5, 2.0, 1.5, 1.0, 0.75, 0.5, 0.25)
#: Most rows or columns a tile keeps for :func:`_chosen` to try dropping each in turn.
LONG = 2 * TILE + 1
#: Rounding steps (``10**-decimals`` mm) within which two neighbouring poles keep 8
#: decimals (:func:`_thin`).
THIN = 10.0


def _thin(g: np.ndarray, width: float) -> np.ndarray:
    """``(rows, cols)`` True on each pole within ``width`` mm of its neighbour along a
    row or a column (both of them): the corners of a tiny knot span (the 1e-4 rad
    column and 5e-4 mm row where a texture's wall meets a half cylinder's flat end
    and top) or of a wall that ends in a point. Rounded to fewer decimals than their
    distance, such a span's sides collapse onto one curve (a cell of no area, or
    sides crossed): OCCT's STEP reader then rebuilds the pcurves around it off the
    tile's rows (a stray degenerated edge) and its mesher gives the face nothing.
    At 8 decimals they stay as texcad made them; they are a handful of poles."""
    on = np.zeros(g.shape[:2], bool)
    near = np.sqrt(((g[1:] - g[:-1]) ** 2).sum(-1)) < width
    on[:-1] |= near
    on[1:] |= near
    near = np.sqrt(((g[:, 1:] - g[:, :-1]) ** 2).sum(-1)) < width
    on[:, :-1] |= near
    on[:, 1:] |= near
    return on


def _keep(p: np.ndarray, t: np.ndarray, tol: float, misses: np.ndarray | None = None,
          new: np.ndarray | None = None) -> np.ndarray:
    """Indices along axis 0 of ``p`` (``(n, m, 3)`` mm: ``m`` polylines sampled at
    the parameters ``t``) to keep so that the polylines through the kept points stay
    within ``tol`` mm (3-D distance) of every point; first and last always kept.
    Greedy: from each kept point, the farthest one whose chord holds all between.
    ``misses``: :func:`_misses` of ``p`` and ``t`` (computed here when None; pass it
    to try several tolerances on the same points). ``new``: per point, how many
    tiles would get a row or column of poles more by keeping it (the tiles on both
    sides of an edge keep whole rows and columns through its points): the cheapest
    chain of chords is taken then (:func:`_cheapest`), not the fewest points."""
    n = len(t)
    if misses is None:
        misses = _misses(p, t)
    if misses is None:
        return np.arange(n)
    ok = misses <= tol  # (i, s): the chord from i to i + 1 + s holds its points
    if new is not None:
        return _cheapest(ok, NEW_POINT + np.asarray(new, np.float64))
    kept, at = [0], 0
    while at < n - 1:  # one per kept point
        at = int(min(at + 1 + np.flatnonzero(ok[at])[-1], n - 1)) if ok[at].any() else at + 1
        kept.append(at)
    return np.asarray(kept)


def _greedy(misses: np.ndarray | None, n: int, tols: np.ndarray) -> np.ndarray:
    """``(len(tols), n)`` bool: the points :func:`_keep` keeps (without ``new``) at
    each tolerance in ``tols`` (mm), all at once: each point's farthest chord that
    holds (its jump), and the chain of jumps from the first point followed by
    pointer doubling (a jump of ``2**r`` points each round)."""
    f = len(tols)
    if misses is None:
        return np.ones((f, n), bool)
    ok = misses[None] <= np.asarray(tols, np.float64)[:, None, None]  # (f, i, s)
    i = np.arange(n)
    last = ok.shape[2] - 1 - np.argmax(ok[..., ::-1], axis=2)  # the longest chord that holds
    jump = np.minimum(np.where(ok.any(2), i + 1 + last, i + 1), n - 1)  # (f, i)
    on = np.zeros((f, n), bool)
    on[:, 0] = True
    rows = np.arange(f)[:, None]
    for _ in range(max(1, int(n - 1).bit_length())):  # log2(n) rounds
        at = np.nonzero(on)
        on[at[0], jump[at]] = True
        jump = jump[rows, jump]
    return on


def _cheapest(ok: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Indices of the chain of chords from the first point to the last (``ok[i, s]``:
    the chord from ``i`` to ``i + 1 + s`` holds) whose kept points cost least
    (``cost`` per point; the first is free); ties go to the longer chords. Dynamic
    programming over the points of one edge (tens): the chords into each point are
    found for all points at once, and the recurrence (each point's cost on its
    cheapest start, sequential by nature) runs on Python floats, the same sums as
    numpy's float64."""
    n, w = len(cost), ok.shape[1]
    j = np.arange(n)[:, None]
    start = j - 1 - np.arange(w)  # (j, s): where the chord into j, s + 1 points long, starts
    into = (start >= 0) & ((start == j - 1) | ok[np.maximum(start, 0), np.arange(w)])
    starts, ends = start[into].tolist(), np.r_[0, np.cumsum(into.sum(1))].tolist()  # per point: its starts, shortest first
    price = cost.tolist()
    best, prev = [0.0] + [np.inf] * (n - 1), [0] * n
    for k in range(1, n):  # one per point of the edge (the recurrence)
        at = min(reversed(starts[ends[k] : ends[k + 1]]), key=best.__getitem__)  # the longest chord among the cheapest
        best[k], prev[k] = best[at] + price[k], at
    kept = [n - 1]
    while kept[-1] > 0:  # one per kept point
        kept.append(prev[kept[-1]])
    return np.asarray(kept[::-1])


def _misses(p: np.ndarray, t: np.ndarray) -> np.ndarray | None:
    """``(n, s)``: the largest distance (mm) from the chord between point ``i`` and
    point ``i + 1 + s`` (chords up to :data:`SPAN` long) to the points it skips, over
    the ``m`` polylines of ``p`` (``(n, m, 3)`` mm at the parameters ``t``); None
    when there are too few points or too many to compare (then every point stays).
    Only the pairs (skipped point ``i + q``, chord end ``i + s``) with ``q < s`` are
    computed (half of the ``(q, s)`` square; the chord's ends clipped to the last
    point), each number as over the whole square."""
    n = len(t)
    w_ = min(n - 1, SPAN)
    if n <= 2 or n * w_**2 * p.shape[1] > 4_000_000:  # a tile's 25 x 25 points: 40 k (a strip's 166 x 25: 0.27 M)
        return None
    qs, ss = np.triu_indices(w_ + 1, 1)  # (q, s), 0 <= q < s <= w_, ordered by q then s
    pair = qs > 0
    order = np.argsort(ss[pair], kind="stable")
    q, s = qs[pair][order], ss[pair][order]  # by chord length s, then skipped point q
    i = np.arange(n)[:, None]
    j = np.minimum(i + s, n - 1)  # (i, pair): the chord's end
    k = np.minimum(i + q, n - 1)  # (i, pair): the point it skips
    span = t[j] - t[i]
    w = np.clip((t[k] - t[i]) / np.where(span > 0, span, 1.0), 0.0, 1.0)[..., None, None]  # (i, pair, 1, 1)
    chord = p[i] * (1 - w) + p[j] * w  # (i, pair, m, 3)
    d = np.where(k < j, np.sqrt(((chord - p[k]) ** 2).sum(-1)).max(-1), 0.0)  # (i, pair)
    out = np.zeros((n, w_))
    first = np.searchsorted(s, np.arange(2, w_ + 1))  # each chord length's first pair (s = 1 skips none)
    out[:, 1:] = np.maximum.reduceat(d, first, axis=1)
    return out


def _even_t(t: np.ndarray) -> np.ndarray:
    """Even parameters (the indices) for the parameters ``t`` of a grid's rows or
    columns: the points' distance to a degree-1 fit's image is at most their
    distance to it at these parameters, and the grid's points are (nearly) evenly
    spaced along its rows and columns."""
    return np.arange(len(t), dtype=np.float64)


def _side_index(side: tuple) -> tuple:
    """``(rows, cols)`` index arrays of a tile side ``(axis, line, lo, hi)``."""
    return (np.arange(side[2], side[3] + 1), np.array([side[1]])) if side[0] == 1 else (np.array([side[1]]), np.arange(side[2], side[3] + 1))


def _hats(t: np.ndarray, kept: np.ndarray) -> np.ndarray:
    """``(len(t), len(kept))``: the degree-1 B-spline basis on the knots ``t[kept]``
    at the parameters ``t``."""
    tk = t[kept]
    at = np.clip(np.searchsorted(tk, t, side="right") - 1, 0, len(tk) - 2)
    w = (t - tk[at]) / (tk[at + 1] - tk[at])
    m = np.zeros((len(t), len(tk)))
    m[np.arange(len(t)), at] = 1 - w
    m[np.arange(len(t)), at + 1] += w
    return m


def _reduced(b, sides: list, grids: list, tol: float, decimals: int = 8, whole=None) -> list:
    """The tiles' grids with fewer poles, within ``tol`` mm of every pole (issue 28:
    a STEP at the mesh's tolerance). Each edge between two tiles keeps the points
    its polyline needs within :data:`EDGE_SHARE` of ``tol`` (its 3-D curve is replaced by that
    polyline, so both tiles' borders and the edge stay one curve: the dropped border
    points move onto it); each tile keeps the rows and columns its edges keep plus
    those its interior needs, checked on every grid point (bilinear, 3-D distance)
    against ``tol``, else all of them. The edges in ``whole`` (a
    ``TopTools_IndexedMapOfShape``, :func:`_foreign`) keep every point, and the tiles
    beside them every row or column along them. Returns ``(grid, u, v)`` per tile."""
    from OCP.TopTools import TopTools_IndexedMapOfShape

    done = TopTools_IndexedMapOfShape()
    plans = {}  # edge index -> kept indices along it (None: all)
    moved = [g.copy() for g, _, _ in grids]
    keep_r = [np.zeros(g.shape[0], bool) for g, _, _ in grids]
    keep_c = [np.zeros(g.shape[1], bool) for g, _, _ in grids]
    on_line = [np.zeros(g.shape[:2], bool) for g, _, _ in grids]  # moved onto an edge's polyline
    on_edge = [np.zeros(g.shape[:2], bool) for g, _, _ in grids]  # on a side whose edge became a polyline
    frozen = [np.zeros(g.shape[:2], bool) for g, _, _ in grids]  # around edges that are not whole tile sides
    for ti, tile in enumerate(sides):  # one per tile
        for _, _, side, (iu, iv), _ in tile:  # one per edge
            if side is None:
                frozen[ti][np.ix_(iv, iu)] = True
    owners: dict = {}  # edge index -> (tile, side) of each tile it bounds as a whole side
    index = TopTools_IndexedMapOfShape()
    for ti, tile in enumerate(sides):  # one per tile
        for edge, _, side, _, _ in tile:  # one per edge
            if side is not None:
                owners.setdefault(index.Add(edge), []).append((ti, side))
    stay = whole if whole is not None else TopTools_IndexedMapOfShape()  # edges with a frozen point in either tile: kept whole
    for ti, tile in enumerate(sides):  # one per tile
        for edge, _, side, _, _ in tile:  # one per edge
            if side is not None and frozen[ti][np.ix_(*_side_index(side))].any():
                stay.Add(edge)
    for ti, tile in enumerate(sides):  # one per tile
        g, u, v = grids[ti]
        for edge, shared, side, (iu, iv), plane in tile:  # one per edge
            if side is None:  # not a whole tile side: the rows and columns of the cells it crosses stay
                keep_r[ti][iv], keep_c[ti][iu] = True, True
                continue
            axis, line, lo, hi = side
            pts = g[lo : hi + 1, line] if axis == 1 else g[line, lo : hi + 1]
            t = (v if axis == 1 else u)[lo : hi + 1]
            key = done.FindIndex(edge)
            if key == 0:
                key = done.Add(edge)
                cut = (shared or plane is not None) and not stay.Contains(edge)
                mine = owners.get(index.FindIndex(edge), [])
                new = _new_lines(mine, keep_r, keep_c, hi - lo + 1)
                plans[key] = _polyline(b, edge, pts, t, tol, decimals if shared else 8, plane, new) if cut else (None, None)
                if plans[key][0] is not None:  # the rows or columns it adds, known to the other tile at once
                    for tj, (ax, _, lo_j, _) in mine:  # one per tile beside the edge (two)
                        (keep_r if ax == 1 else keep_c)[tj][lo_j + plans[key][0]] = True
            sel, q = plans[key]
            idx = np.arange(lo, hi + 1) if sel is None else lo + sel
            if axis == 1:
                keep_r[ti][idx] = True
                if sel is not None:
                    moved[ti][lo : hi + 1, line] = np.stack([np.interp(t, t[sel], q[:, c]) for c in range(3)], axis=-1)
                    moved[ti][lo + sel, line] = q  # the polyline's own points, bit for bit
                    on_line[ti][lo : hi + 1, line] = True
                    on_edge[ti][lo : hi + 1, line] = True
                    on_line[ti][lo + sel[1:-1], line] = False  # (shared with the curve, rounded already)
            else:
                keep_c[ti][idx] = True
                if sel is not None:
                    moved[ti][line, lo : hi + 1] = np.stack([np.interp(t, t[sel], q[:, c]) for c in range(3)], axis=-1)
                    moved[ti][line, lo + sel] = q  # the polyline's own points, bit for bit
                    on_line[ti][line, lo : hi + 1] = True
                    on_edge[ti][line, lo : hi + 1] = True
                    on_line[ti][line, lo + sel[1:-1]] = False  # (shared with the curve, rounded already)
    out = []
    for ti, (g, u, v) in enumerate(grids):  # one per tile
        m, fit = moved[ti], not frozen[ti].any()
        # fitted and checked at even parameters (the grid's indices): a degree-1 surface's
        # image is its poles', whatever its knots, so each grid point is within tol of the
        # tile written on the grid's own knots (texcad's are placed for OCCT's Gauss rule,
        # uneven: checked at them, a dropped row's tangential shift alone could miss tol)
        rows, cols, poles = _chosen(m, g, _even_t(u), _even_t(v), keep_r[ti], keep_c[ti], tol, fit, on_edge[ti])
        out.append((poles, u[cols], v[rows], rows, cols, on_line[ti][np.ix_(rows, cols)]))
    return out


def _foreign(tiles: list, sides: list, grids: list):
    """The edges along a tile side (:func:`_sides`) not parametrised as that tile's
    grid: their pcurve on it does not run as the iso line ``(line, t)`` through the
    side's knots ``t`` (a ``TopTools_IndexedMapOfShape``). texcad gives the small
    tiles under a tool knots of their own (``texcad.brep.solids._own_knots``): an
    edge along ``v`` is made on the tile to its left, the tile beyond maps it by a
    broken line. A polyline :func:`_reduced` fitted in one tile's knots put the edge
    off its pcurve on the other, and OCCT's reader re-made those pcurves (degree 3,
    twenty knots): a drilled cylinder's plain volume +0.12 %."""
    from OCP.BRep import BRep_Tool
    from OCP.TopTools import TopTools_IndexedMapOfShape

    out = TopTools_IndexedMapOfShape()
    for (_, face, _), tile, (_, u, v) in zip(tiles, sides, grids):  # one per tile
        for edge, _, side, _, _ in tile:  # one per edge
            if side is None or out.Contains(edge):
                continue
            axis, line, lo, hi = side
            t = (v if axis == 1 else u)[lo : hi + 1]
            at = (u if axis == 1 else v)[line]
            pc = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
            first, last = BRep_Tool.Range_s(edge)
            eps = 1e-9 * (1.0 + np.abs(t).max() + abs(at))
            ok = pc is not None and abs(first - t[0]) <= eps and abs(last - t[-1]) <= eps
            if ok:
                q = np.array([pc.Value(x).Coord() for x in t.tolist()])  # per grid point of the side (tens)
                want = np.stack([np.full(len(t), at), t] if axis == 1 else [t, np.full(len(t), at)], axis=-1)
                ok = np.abs(q - want).max() <= eps
            if not ok:
                out.Add(edge)
    return out


def _new_lines(owners: list, keep_r: list, keep_c: list, n: int) -> np.ndarray | None:
    """Per point of an edge (``n``), how many of the tiles it bounds (``owners``:
    ``(tile, side)``) keep no row or column of poles through it yet (``keep_r``,
    ``keep_c``: per tile); None when the sides do not all have ``n`` points."""
    new = np.zeros(n)
    for ti, (axis, _, lo, hi) in owners:  # one per tile beside the edge (two)
        if hi - lo + 1 != n:
            return None
        new += ~(keep_r if axis == 1 else keep_c)[ti][lo : hi + 1]
    return new


def _chosen(m: np.ndarray, g: np.ndarray, u: np.ndarray, v: np.ndarray, need_r: np.ndarray, need_c: np.ndarray,
            tol: float, fit: bool, skip: np.ndarray | None = None) -> tuple:
    """The rows and columns of poles a tile keeps and its poles (:func:`_fitted`):
    ``m`` its grid with the border moved onto its edges' polylines, ``g`` the grid
    (``(R, C, 3)`` mm at the parameters ``v``, ``u``), ``need_r``/``need_c`` (bool)
    the rows and columns its edges keep. Candidate rows and columns are those whose
    chords stay within each share of the tolerance (:data:`INNER_SHARES`, each
    direction on its own, :func:`_greedy`); the pair with the fewest poles that holds
    within ``tol`` on every grid point is taken, then each interior row and column
    not needed by an edge is dropped in turn if the tile still holds without it
    (the fitted poles move into the gap: the least-squares fit spreads a bump over
    wider spans than chords through the points do). All of them when nothing holds."""
    along_v, along_u = _misses(m, v), _misses(m.transpose(1, 0, 2), u)
    tols = np.array([f * tol for f in INNER_SHARES])
    on_r, on_c = _greedy(along_v, len(v), tols) | need_r, _greedy(along_u, len(u), tols) | need_c
    cand_r = {f: np.flatnonzero(on) for f, on in zip(INNER_SHARES, on_r)}
    cand_c = {f: np.flatnonzero(on) for f, on in zip(INNER_SHARES, on_c)}
    need_r, need_c = np.flatnonzero(need_r), np.flatnonzero(need_c)
    pairs = sorted(((len(cand_r[a]) * len(cand_c[b]), a, b) for a in INNER_SHARES for b in INNER_SHARES))
    cache: dict = {}  # the bases of the rows' and columns' knots tried (each direction keeps its own while the other changes)
    tried = set()  # shares often keep the same rows or columns: each pair is fitted once
    for _, a, b in pairs:  # a few dozen, cheapest first
        key = (cand_r[a].tobytes(), cand_c[b].tobytes())
        if key in tried:
            continue
        tried.add(key)
        poles = _fitted(m, g, u, v, cand_r[a], cand_c[b], tol, fit, skip, cache)
        if poles is not None:
            rows, cols = cand_r[a], cand_c[b]
            break
    else:
        return np.arange(len(v)), np.arange(len(u)), m
    dropped = [True, True]
    for k, axis in enumerate((0, 1, 0, 1)):  # rows, columns, and again (dropping one frees the other direction)
        if k >= 2 and not dropped[1 - axis]:  # the other direction is as it was when this one was tried
            break
        dropped[axis] = False
        kept, need = (rows, need_r) if axis == 0 else (cols, need_c)
        if len(kept) > LONG:  # a strip's length (a face in strips, texcad.brep.uvstrips): a fit per line is too slow
            continue
        for i in kept[1:-1]:  # one per kept interior row or column (24 at most)
            if i in need:
                continue
            fewer = kept[kept != i] if axis == 0 else rows
            fewer_c = cols if axis == 0 else kept[kept != i]
            got = _fitted(m, g, u, v, fewer, fewer_c, tol, fit, skip, cache)
            if got is not None:
                rows, cols, poles, kept = fewer, fewer_c, got, fewer if axis == 0 else fewer_c
                dropped[axis] = True
    return rows, cols, poles


def _polyline(b, edge, pts: np.ndarray, t: np.ndarray, tol: float, decimals: int, plane=None,
              new: np.ndarray | None = None) -> tuple:
    """The points an edge between two tiles keeps (indices into ``pts``, ``(n, 3)``
    mm at the parameters ``t``) so that its polyline stays within ``tol`` mm of every
    point, and those points as written (``decimals``; its ends as they are: other
    edges meet there); the edge's 3-D curve becomes that polyline. ``(None, None)``
    when nothing is dropped or the curve is not parametrised as the grid. ``plane``:
    the part's planar face on the edge's other side (else None: two tiles), whose
    pcurve of the edge becomes the same polyline in the plane's parameters. ``new``:
    per point, the tiles it would add a row or column of poles to (:func:`_keep`)."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_BSplineCurve
    from OCP.TColgp import TColgp_Array1OfPnt
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.TopLoc import TopLoc_Location
    from OCP.gp import gp_Pnt

    # between two tiles at even parameters (see _reduced); beside a plane at its own (OCCT's
    # plain volume rule on the plane missed a plate's volume by 0.06 % more otherwise)
    sel, q = (_edge_fit(pts, _even_t(t), EDGE_SHARE * tol, new) if plane is None
              else _edge_fit(pts, t, PLANE_SHARE * tol, new, rounds=0))
    first, last = BRep_Tool.Range_s(edge)
    if len(sel) == len(t) or abs(first - t[0]) > 1e-9 or abs(last - t[-1]) > 1e-9:
        return None, None
    q[1:-1] = np.round(q[1:-1], decimals)  # as written: the points between them stay on it
    at, pq = sel, q
    was = BRep_Tool.CurveOnSurface_s(edge, plane, 0.0, 0.0) if plane is not None else None
    if hasattr(was, "NbKnots") and 2 * (was.Degree() + 1) * (was.NbKnots() - 1) >= GAUSS_ORDER:
        # OCCT's reader makes the plane's pcurve from the 3-D curve (knot for knot): both keep knots at grid lines
        # between, up to 16 spans, so that OCCT's plain rule keeps its 61 points along it, for which the tile's
        # knots are placed (a drilled plate's 13-span polylines got 52: its plain volume +0.07 %)
        at = _pad(np.isin(np.arange(len(t)), sel))
        pq = np.stack([np.interp(t[at], t[sel], q[:, c]) for c in range(3)], axis=-1)
        pq[np.isin(at, sel)] = q  # its own points, bit for bit
    poles, knots, mult = TColgp_Array1OfPnt(1, len(at)), TColStd_Array1OfReal(1, len(at)), TColStd_Array1OfInteger(1, len(at))
    for n, (x, y, z) in enumerate(pq.tolist()):  # one per point of the edge's curve
        poles.SetValue(n + 1, gp_Pnt(x, y, z))
        knots.SetValue(n + 1, float(t[at[n]]))
        mult.SetValue(n + 1, 2 if n in (0, len(at) - 1) else 1)
    b.UpdateEdge(edge, Geom_BSplineCurve(poles, knots, mult, 1), TopLoc_Location(), BRep_Tool.Tolerance_s(edge))
    if plane is not None:
        b.UpdateEdge(edge, _in_plane(plane, pq, t[at]), plane, BRep_Tool.Tolerance_s(edge))
    return sel, q


def _pad(mine: np.ndarray) -> np.ndarray:
    """Indices of the points ``mine`` (bool, per grid line along a side) and of
    others between, evenly picked, up to :data:`PAD_SPANS` spans (all of them on a
    shorter side): the knots of a degree-1 pcurve along which OCCT's plain volume
    rule then takes its 61 points (``texcad.brep.gprop``)."""
    mine = mine.copy()
    mine[[0, -1]] = True
    rest = np.flatnonzero(~mine)
    need = min(max(PAD_SPANS + 1 - int(mine.sum()), 0), len(rest))
    if need:
        mine[rest[np.round(np.linspace(0, len(rest) - 1, need)).astype(np.int64)]] = True
    return np.flatnonzero(mine)


def _in_plane(plane, q: np.ndarray, knots: np.ndarray):
    """The degree-1 2-D curve through the points ``q`` (``(k, 3)`` mm, in the planar
    face ``plane``) in the plane's parameters, on ``knots`` (``k``, the ends doubled)."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_BSplineCurve
    from OCP.TColgp import TColgp_Array1OfPnt2d
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal
    from OCP.gp import gp_Pnt2d

    pos = BRep_Tool.Surface_s(plane).Position()  # with the face's location: the same parameters
    o, x, y = (np.array(a.Coord()) for a in (pos.Location(), pos.XDirection(), pos.YDirection()))
    uv = np.stack([(q - o) @ x, (q - o) @ y], axis=-1)
    poles, kn, mult = TColgp_Array1OfPnt2d(1, len(q)), TColStd_Array1OfReal(1, len(q)), TColStd_Array1OfInteger(1, len(q))
    for n, ((pu, pv), k) in enumerate(zip(uv.tolist(), knots.tolist())):  # one per point of the edge
        poles.SetValue(n + 1, gp_Pnt2d(pu, pv))
        kn.SetValue(n + 1, k)
        mult.SetValue(n + 1, 2 if n in (0, len(q) - 1) else 1)
    return Geom2d_BSplineCurve(poles, kn, mult, 1)


def _plane_beside(faces, face):
    """The face other than ``face`` in ``faces`` (an edge's two faces) when it is a
    plane without a seam on that edge, else None."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom import Geom_Plane
    from OCP.TopoDS import TopoDS

    if faces.Size() != 2:
        return None
    other = [TopoDS.Face_s(f) for f in shapes_in(faces) if not f.IsSame(face)]
    if len(other) != 1 or not isinstance(BRep_Tool.Surface_s(other[0]), Geom_Plane):
        return None
    return other[0]


def _edge_fit(pts: np.ndarray, t: np.ndarray, tol: float, new: np.ndarray | None = None, rounds: int | None = None) -> tuple:
    """The points an edge's polyline keeps (indices into ``pts``, ``(n, 3)`` mm at the
    parameters ``t``) and where they go (``(k, 3)`` mm): the fewest whose chords hold
    within a share of ``tol`` (:data:`EDGE_SHARES`, :func:`_keep`) and whose inner
    points, fitted to all of ``pts`` (:func:`_minimax`; the ends stay), bring the
    polyline within ``tol`` of every point; the chord points themselves where no fit
    holds.
    ``new``: see :func:`_keep` (the cheapest chords for the tiles beside the edge);
    ``rounds``: of :func:`_minimax` (default :data:`LAWSON`; 0: least squares)."""
    misses = _misses(pts[:, None], t)
    for share in EDGE_SHARES:  # the largest share first: the fewest points
        sel = _keep(pts[:, None], t, share * tol, misses, new)
        if len(sel) < 3:
            if share <= 1.0:
                return sel, pts[sel].copy()
            continue
        q = _minimax(pts, _hats(t, sel), pts[sel].copy(), tol, LAWSON if rounds is None else rounds)
        if q is not None:
            return sel, q
    return sel, pts[sel].copy()


def _minimax(pts: np.ndarray, h: np.ndarray, q: np.ndarray, tol: float, rounds: int = 10) -> np.ndarray | None:
    """The inner points of the polyline ``h @ q`` (``h``: :func:`_hats`; ``q``: its
    points, the ends kept) fitted to ``pts`` (``(n, 3)`` mm) so that it stays within
    ``tol`` mm of every point, or None: least squares, then Lawson's reweighting
    towards the smallest largest miss (``rounds`` rounds; C. L. Lawson 1961)."""
    rhs = pts - h[:, [0, -1]] @ q[[0, -1]]
    w = np.ones(len(pts))
    for _ in range(rounds + 1):  # a few rounds on one edge (tens of points)
        s = np.sqrt(w)[:, None]
        q[1:-1] = np.linalg.lstsq(s * h[:, 1:-1], s * rhs, rcond=None)[0]
        miss = np.sqrt(((h @ q - pts) ** 2).sum(-1))
        if miss.max() <= tol:
            return q
        w = w * miss / max(float((w * miss).sum()), 1e-300)
    return None


#: Rounds of Lawson's reweighting an edge's fit gets (:func:`_minimax`).
LAWSON = 10


def _fitted(m: np.ndarray, g: np.ndarray, u: np.ndarray, v: np.ndarray, rows: np.ndarray, cols: np.ndarray, tol: float,
            fit: bool, skip: np.ndarray | None = None, cache: dict | None = None) -> np.ndarray | None:
    """Poles ``(len(rows), len(cols), 3)`` mm of a degree-1 surface on the knots
    ``v[rows]``, ``u[cols]`` within ``tol`` mm of every grid point ``g`` (at its own
    ``(u, v)``), or None. The poles are the grid points ``m`` there (the tile's
    border moved onto its edges' polylines); with ``fit``, if those miss, the border
    stays and the inner poles are the least-squares fit to the grid instead (a
    bilinear patch through the points lies on one side of a curved relief; the
    fitted one straddles it, so fewer rows and columns hold): the interior block is
    a tensor product, so it is ``pinv(Bv) R pinv(Bu)^T``. Where that misses by less
    than :data:`REACH` times ``tol``, it is fitted again (:data:`LAWSON` rounds) with
    each row and column of grid points weighted by its largest miss (a weight per
    row times one per column keeps the product form), towards the smallest largest
    miss: the bound is on every point."""
    (mv, iv), (mu, iu) = _basis(v, rows, cache), _basis(u, cols, cache)
    gk = g.transpose(2, 0, 1)  # (3, R, C): one matrix per coordinate
    p = m[np.ix_(rows, cols)]
    keep = slice(None) if skip is None else ~skip
    if np.sqrt(((mv @ p.transpose(2, 0, 1) @ mu.T - gk) ** 2).sum(0))[keep].max(initial=0.0) <= tol:
        return p
    if not fit or len(rows) < 3 or len(cols) < 3:
        return None
    pk = p.transpose(2, 0, 1).copy()
    pk[:, 1:-1, 1:-1] = 0.0
    rest = gk - mv @ pk @ mu.T
    pk[:, 1:-1, 1:-1] = iv @ rest @ iu.T
    miss = np.sqrt(((mv @ pk @ mu.T - gk) ** 2).sum(0))
    most = miss[keep].max(initial=0.0)
    if most <= tol:
        return pk.transpose(1, 2, 0)
    if most > REACH * tol:
        return None
    counted = np.ones(miss.shape, bool) if skip is None else ~skip
    wr, wc = np.ones(len(v)), np.ones(len(u))
    for _ in range(LAWSON):  # a few rounds
        worst = np.where(counted, miss, 0.0)
        wr, wc = wr * (worst.max(1) + 1e-3 * tol), wc * (worst.max(0) + 1e-3 * tol)
        wr, wc = wr / wr.max(), wc / wc.max()
        by_v, by_u = _weighted_pair(mv[:, 1:-1], wr, mu[:, 1:-1], wc)
        pk[:, 1:-1, 1:-1] = by_v @ rest @ by_u.T
        miss = np.sqrt(((mv @ pk @ mu.T - gk) ** 2).sum(0))
        if miss[keep].max(initial=0.0) <= tol:
            return pk.transpose(1, 2, 0)
    return None


def _weighted(h: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The weighted least-squares solver ``(h^T W h)^-1 h^T W`` of a basis ``h``
    (``(n, k)``) with weights ``w`` (``n``) on its rows."""
    hw = h.T * w
    return np.linalg.solve(hw @ h + _ridge(h.shape[1]), hw)


def _weighted_pair(hv: np.ndarray, wv: np.ndarray, hu: np.ndarray, wu: np.ndarray) -> tuple:
    """:func:`_weighted` of the bases ``hv`` and ``hu`` (a tile's rows and columns)
    with their weights: one LAPACK call on the two stacked when they have the same
    shape (each the same numbers as alone), else one each."""
    if hv.shape != hu.shape:
        return _weighted(hv, wv), _weighted(hu, wu)
    hwv, hwu = hv.T * wv, hu.T * wu
    got = np.linalg.solve(np.stack([hwv @ hv, hwu @ hu]) + _ridge(hv.shape[1]), np.stack([hwv, hwu]))
    return got[0], got[1]


_RIDGES: dict = {}


def _ridge(k: int) -> np.ndarray:
    """``1e-12`` times the ``k x k`` identity (read-only, made once per ``k``): what
    :func:`_weighted` adds to its normal equations."""
    got = _RIDGES.get(k)
    if got is None:
        got = _RIDGES[k] = 1e-12 * np.eye(k)
        got.flags.writeable = False
    return got


#: How far (times the tolerance) a tile's least-squares fit may miss before it is
#: reweighted (:func:`_fitted`): rows and columns of grid points weighted by their
#: largest miss, Lawson's rule in each direction (C. L. Lawson 1961).
REACH = 1.5


def _basis(t: np.ndarray, kept: np.ndarray, cache: dict | None) -> tuple:
    """:func:`_hats` of ``t`` on the knots ``t[kept]`` and the pseudo-inverse of its
    inner columns (None with fewer than 3 knots), from ``cache`` when there."""
    key = (len(t), kept.tobytes())
    got = None if cache is None else cache.get(key)
    if got is None:
        h = _hats(t, kept)
        inner = h[:, 1:-1]
        if len(kept) < 3:
            got = (h, None)
        elif len(t) > LONG:  # a strip's length: the normal equations (tridiagonal), a tenth of an SVD's time
            got = (h, np.linalg.solve(inner.T @ inner, inner.T))
        else:
            got = (h, np.linalg.pinv(inner))
        if cache is not None:
            cache[key] = got
    return got


def _layout(ents: dict):
    """Faces of the shells in order, the shell of each face, the solid of each shell
    and the shape representation of each solid, from OCCT's STEP entities."""
    face_ids, shell_of, msb, absr = [], {}, {}, []
    for eid in sorted(ents):  # one per entity
        m = ents[eid]
        if m.group(2) in (b"CLOSED_SHELL", b"OPEN_SHELL"):
            refs = [int(r) for r in _REF.findall(m.group(3))]
            face_ids += refs
            shell_of.update((r, eid) for r in refs)
        elif m.group(2) == b"MANIFOLD_SOLID_BREP":
            msb[int(_REF.findall(m.group(3))[0])] = eid
        elif m.group(2) == b"ADVANCED_BREP_SHAPE_REPRESENTATION":
            absr.append(eid)
    absr_of = {int(r): eid for eid in absr for r in _REF.findall(ents[eid].group(3))}  # item -> representation
    return face_ids, shell_of, msb, absr_of


def _stand_in_ids(ents: dict, face: int, pts: np.ndarray, corners: list) -> tuple[int, list] | None:
    """The stand-in surface entity of the ``ADVANCED_FACE`` ``face`` and its four
    corner point entities, checked against the tile's corner poles ``pts[corners]``."""
    fm = ents.get(face)
    if fm is None or fm.group(2) != b"ADVANCED_FACE":
        return None
    sid = int(_REF.findall(fm.group(3))[-1])
    sm = ents.get(sid)
    if sm is None or sm.group(2) != b"B_SPLINE_SURFACE_WITH_KNOTS":
        return None
    corner_ids = [int(r) for r in _REF.findall(sm.group(3))]
    if len(corner_ids) != 4:
        return None
    for cid, at in zip(corner_ids, corners):  # the four corners
        cm = ents.get(cid)
        if cm is None or cm.group(2) != b"CARTESIAN_POINT":
            return None
        xyz = np.array(cm.group(3).split(b"(")[1].split(b")")[0].split(b","), np.float64)
        if np.abs(xyz - pts[at]).max() > 1e-6 * (1.0 + np.abs(pts[at]).max()):
            return None
    return sid, corner_ids


def _complete(data: bytes, n_faces: int, tiles: list, grids: list, meshed: list, outer: np.ndarray,
              inner: int = 4) -> bytes | None:
    """Rewrite the stand-in surfaces of OCCT's STEP text ``data`` with the tiles' poles
    and add their triangulations; None when the text is not laid out as expected.

    Every point is written once: a pole shared by neighbouring tiles (their common
    border) is one ``CARTESIAN_POINT`` both surfaces refer to, and OCCT's own points
    that are poles (the tiles' edge curves and vertices: iso-curves of the tiles,
    through their border poles) are dropped and refer to it too, so an edge between
    two tiles is exactly both tiles' border whatever the decimals. ``outer``: the
    poles on edges shared with the part's own faces, written with 8 decimals (5e-9
    mm, inside the edges' 1e-7 mm: those faces' pcurves are OCCT's); every other
    pole with ``inner`` decimals (4: 5e-5 mm, far below any mesh tolerance). The
    poles come first (``#1`` on), then OCCT's entities, identical geometry written
    once and numbered densely (:func:`_renumbered`)."""
    ents = {int(m.group(1)): m for m in _ENTITY.finditer(data)}
    face_ids, shell_of, msb, absr_of = _layout(ents)
    if len(face_ids) != n_faces:
        return None
    pts = np.concatenate([g.transpose(1, 0, 2).reshape(-1, 3) for g, _, _ in grids])
    border = np.concatenate([_border(g.shape[0], g.shape[1]) for g, _, _ in grids])
    outer = np.concatenate([o.T.ravel() for o in outer])  # u-major as pts
    tok = _tokens(pts, inner)
    tok[outer] = _tokens(pts[outer], 8)
    key = "i" + tok  # a point on a tile border is shared by its exact value (elementwise, object arrays)
    key[border] = "b" + _tokens(pts[border], 8)
    uniq, first, inv = np.unique(key, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")  # the points in the order they first occur
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order))
    swaps, tess = {}, []
    off = 0
    for (k, _, _), (g, u, v), mesh in zip(tiles, grids, meshed):  # one per tile
        rows, cols = g.shape[:2]
        corners = [off, off + rows - 1, off + (cols - 1) * rows, off + cols * rows - 1]  # u-major
        got = _stand_in_ids(ents, face_ids[k], pts, corners)
        if got is None:
            return None
        swaps[got[0]] = (off, rows, cols, u, v)
        if mesh:
            if absr_of.get(msb.get(shell_of.get(face_ids[k], -1), -1)) is None:
                return None
            tess.append((face_ids[k], off, rows, cols))
        off += rows * cols
    n_emit = len(order)
    # OCCT's points that are poles (8 decimals: border poles) refer to the pole instead.
    pole_id = {t[1:]: int(rank[i]) for i, t in enumerate(uniq.tolist()) if t[0] == "b"}
    occt_pts = [e for e, m in ents.items() if m.group(2) == b"CARTESIAN_POINT"]
    occt_tok = _tokens(np.array([_xyz(ents[e]) for e in occt_pts], np.float64).reshape(-1, 3), 8)
    alias = {e: pole_id[t] for e, t in zip(occt_pts, occt_tok.tolist()) if t in pole_id}
    exact = np.zeros(len(uniq), bool)  # a point is written with 8 decimals if any of its uses needs them
    np.logical_or.at(exact, inv, outer)
    emit_tok = tok[first]
    emit_tok[exact & ~outer[first]] = _tokens(pts[first[exact & ~outer[first]]], 8)
    repl, extra = {}, []
    next_id = max(ents) + 1
    next_id, items = _tessellation_text(tess, tok, next_id, shell_of, msb, extra)
    for rep in sorted({absr_of[solid] for solid, _ in items}):  # one per shape representation
        mine = [t for solid, t in items if absr_of[solid] == rep]
        refs = [int(r) for r in _REF.findall(ents[rep].group(3))]
        ctx, listed = refs[-1], ",".join(f"#{r}" for r in refs[:-1] + mine)
        repl[rep] = f"'',({listed}),#{ctx}".encode("ascii")
        extra.append(f"#{next_id} = TESSELLATED_SHAPE_REPRESENTATION('',({','.join(f'#{r}' for r in mine)}),#{ctx});\n")
        next_id += 1
    listed = [(e, m.group(2), m.group(3)) for e, m in ents.items() if e not in alias]
    listed += [(int(m.group(1)), m.group(2), m.group(3)) for m in _ANY_ENTITY.finditer("".join(extra).encode("ascii"))]
    pole = rank[inv]  # each pole's point, from the first point id
    rest, base = _renumbered(listed, repl, alias, lambda sid, base: _surface_text(swaps[sid], base + pole) if sid in swaps else None)
    inter = [None] * (2 * n_emit)
    inter[0::2], inter[1::2] = (base + np.arange(n_emit)).tolist(), emit_tok[order].tolist()
    one = "#%d=CARTESIAN_POINT('',(%s));"  # four to a line (lines of ~200 characters)
    points = (((one * 4 + "\n") * (n_emit // 4)) + one * (n_emit % 4) + "\n") % tuple(inter)
    head, end = data[: data.index(b"\nDATA;") + 7], data.rindex(b"ENDSEC;")
    return b"".join([head, _dense(rest + points.encode("ascii")), data[end:]])


_NUMBER = re.compile(rb"(?<=#)(\d+)")  # an entity's id after its '#': defined (followed by '=') or referred to
#: Characters a line of :func:`_dense` holds at most (entities end to end; a longer entity on its own).
LINE = 200


def _dense(body: bytes) -> bytes:
    """A STEP DATA section's entities renumbered by how often they are referred to
    (the most referred first: a pole that four tiles, two edges and a vertex use gets
    the shortest id; ties in the order they were), written end to end in lines of at
    most :data:`LINE` characters (a line break only after an entity's ``;``, which
    STEP does not need between entities). The ids are the same set ``1..n``; a ``#``
    inside a string (an odd number of quotes before it) is left as it is."""
    pieces = _NUMBER.split(body)  # text, number, text, ..., text
    texts, nums = pieces[0::2], pieces[1::2]
    if not nums:
        return body
    real = np.cumsum([t.count(b"'") for t in texts[:-1]]) % 2 == 0  # per number: outside a string
    ids = np.where(real, np.array(nums).astype(np.int64), 0)
    is_def = real & np.array([t[:1] == b"=" for t in texts[1:]])
    top = int(ids.max()) + 1
    uses = np.bincount(ids[real & ~is_def], minlength=top)
    defined = np.zeros(top, bool)
    defined[ids[is_def]] = True
    old = np.flatnonzero(defined)
    new = np.zeros(top, np.int64)
    new[old[np.argsort(-uses[old], kind="stable")]] = np.arange(1, len(old) + 1)
    if (new[ids[real]] == 0).any():
        return body  # a reference to no entity: leave the text as it is
    pieces[1::2] = [b"%d" % x if r else n for x, r, n in zip(new[ids].tolist(), real.tolist(), nums)]  # per number
    out, width = [], 0
    for line in b"".join(pieces).rstrip(b"\n").split(b"\n"):  # per line (one per entity, four points to one)
        if out and out[-1].endswith(b";") and width + len(line) <= LINE:
            out[-1] += line
            width += len(line)
        else:
            out.append(line)
            width = len(line)
    return b"\n".join(out) + b"\n"


#: Entity types written once when two are the same (geometry, no topology): OCCT
#: writes a 2-D context, a direction and a vector for every pcurve.
_SHARED = {b"CARTESIAN_POINT", b"DIRECTION", b"VECTOR", b"LINE", b"AXIS2_PLACEMENT_2D", b"AXIS2_PLACEMENT_3D",
           b"DEFINITIONAL_REPRESENTATION", b"PCURVE", b""}  # b"": complex entities (contexts, units)


def _renumbered(listed: list, repl: dict, alias: dict, surface) -> tuple[bytes, int]:
    """OCCT's entities ``(id, type, parameters)`` as compact text (no layout
    whitespace), numbered 1, 2, ... in their order, and the first id after them
    (``base``: the points' ids start there). Every reference is renumbered:
    ``alias`` maps a dropped entity to the point (index from ``base``) that stands for
    it, ``repl`` gives new parameters for an entity, and ``surface(id, base)`` those
    of a stand-in surface (None: not one). Geometry (:data:`_SHARED`) that is the
    same as an earlier entity, once its own references are, is dropped and refers
    to that one."""
    body = {e: (t, repl.get(e, _short(t, _compact(p)))) for e, t, p in listed}
    same: dict = {}  # entity -> the entity it is written as
    seen: dict = {}  # canonical text -> entity

    def canon(e: int) -> int:  # one per shared entity (memoized; geometry nests a few levels)
        if e in same or e not in body:
            return same.get(e, e)
        t, p = body[e]
        if t not in _SHARED:
            same[e] = e
            return e
        same[e] = e  # (no cycles in geometry)
        text = t + b"(" + _REF.sub(lambda m: b"#%d" % _ref(int(m.group(1))), p) + b")"
        same[e] = seen.setdefault(text, e)
        return same[e]

    def _ref(r: int) -> int:
        return -1 - alias[r] if r in alias else canon(r)

    for e in body:  # one per entity
        canon(e)
    new_id, n = {}, 1
    for e in body:  # one per entity written
        if same[e] == e:
            new_id[e], n = n, n + 1

    def final(m) -> bytes:
        r = int(m.group(1))
        return b"#%d" % (n + alias[r] if r in alias else new_id[same.get(r, r)])

    out = []
    for e, (t, p) in body.items():  # one per entity
        if same[e] != e:
            continue
        text = surface(e, n) if t == b"B_SPLINE_SURFACE_WITH_KNOTS" else None
        out.append(b"#%d=%s(%s);\n" % (new_id[e], t, _REF.sub(final, p) if text is None else text))
    return b"".join(out), n
_WRAP = re.compile(rb"\n +")


def _compact(params: bytes) -> bytes:
    """OCCT's entity parameters without its layout whitespace: no line breaks inside
    an entity (after a comma or parenthesis, never in a string: texcad's names are
    single-line). Whitespace between tokens means nothing in STEP."""
    return _WRAP.sub(b"", params)


_CURVE_KNOTS = re.compile(rb"\(([-+0-9.E,]+)\),\.[A-Z_]+\.$")  # a B-spline curve's knots, its last list
_LONG = re.compile(rb"(\d\.\d{9})\d+")  # 3-D: mm
_ZEROS_3D = re.compile(rb"(\.\d*?)0+(?=[,)])")  # trailing zeros (the same number)


def _short(kind: bytes, params: bytes) -> bytes:
    """A ``CARTESIAN_POINT``'s coordinates cut to at most 9 decimals in 3-D (OCCT writes
    17 significant digits: 1e-9 mm is far inside its 1e-7 mm edge tolerances) and
    rounded as the knots in 2-D (:func:`_knots`: a pcurve's points, in the surface's
    parameters: OCCT's parametric confusion is 1e-9, and a pcurve 1e-9 off its tile's
    knots next to an edge of no length, where a texture wall ends in a point, has
    OCCT's reader rebuild that tile's wire and its mesher then gives the tile nothing:
    rounded alike, a pcurve on a tile's side and the tile's last knot are the same
    number); a B-spline curve's knots as :func:`_knots`; other entities as they
    are."""
    if kind == b"B_SPLINE_CURVE_WITH_KNOTS":  # its knots as texcad's tiles' (:func:`_knots`)
        m = _CURVE_KNOTS.search(params)
        if m is None:
            return params
        knots = _knots([float(x) for x in m.group(1).split(b",")]).encode("ascii")
        return params[: m.start(1)] + knots + params[m.end(1) :]
    if kind != b"CARTESIAN_POINT":
        return params
    at = params.rindex(b"(")
    if params[at:].count(b",") >= 2:
        return _ZEROS_3D.sub(rb"\1", _LONG.sub(rb"\1", params))
    uv = [float(x) for x in params[at + 1 : params.rindex(b")")].split(b",")]
    return params[: at + 1] + ",".join(_ZEROS.sub(r"\1", f"{x:.{KNOT_DECIMALS}f}") for x in (np.round(uv, KNOT_DECIMALS) + 0.0).tolist()).encode("ascii") + b")"


def _xyz(m) -> list:
    """The three coordinates of a ``CARTESIAN_POINT`` entity match (mm; a 2-D point
    gets z = NaN, so it matches no pole)."""
    xyz = [float(c) for c in m.group(3).split(b"(")[1].split(b")")[0].split(b",")]
    return xyz if len(xyz) == 3 else [xyz[0], xyz[1], float("nan")]


def _surface_text(swap: tuple, ids: np.ndarray) -> bytes:
    """The parameters of a tile's ``B_SPLINE_SURFACE_WITH_KNOTS`` with its pole ids
    (u-major) and knots; ``swap``: ``(offset, rows, cols, u, v)``."""
    o, rows, cols, u, v = swap
    poles = _grid_ids_template(cols, rows) % tuple(ids[o : o + rows * cols].tolist())
    return (
        f"'',1,1,({poles}),.UNSPECIFIED.,.F.,.F.,.F.,({_mults(cols)}),"
        f"({_mults(rows)}),({_knots(u)}),({_knots(v)}),.UNSPECIFIED."
    ).encode("ascii")


def _tessellation_text(tess: list, tok: np.ndarray, next_id: int, shell_of: dict, msb: dict, new: list):
    """Append ``COORDINATES_LIST`` + ``TRIANGULATED_FACE`` per triangulated tile and a
    ``TESSELLATED_SOLID`` per solid to ``new``; returns the next free id and the
    ``(solid, tessellated solid)`` ids."""
    tri_text, by_solid = {}, {}
    for face, o, rows, cols in tess:  # one per triangulated tile
        if (rows, cols) not in tri_text:
            tri_text[rows, cols] = _strips_text(rows, cols)
        node = o + (np.arange(cols)[None, :] * rows + np.arange(rows)[:, None]).ravel()  # row-major nodes
        cid, tid = next_id, next_id + 1
        next_id += 2
        new.append(f"#{cid}=COORDINATES_LIST('',{rows * cols},(({'),('.join(tok[node].tolist())})));\n")
        new.append(
            f"#{tid}=COMPLEX_TRIANGULATED_FACE('',#{cid},{rows * cols},(),#{face},(),({tri_text[rows, cols]}),());\n"
        )
        by_solid.setdefault(msb[shell_of[face]], []).append(tid)
    items = []
    for solid, tfs in by_solid.items():  # one per solid
        new.append(f"#{next_id} = TESSELLATED_SOLID('',({','.join(f'#{t}' for t in tfs)}),#{solid});\n")
        items.append((solid, next_id))
        next_id += 1
    return next_id, items
