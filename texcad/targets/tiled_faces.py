"""A planar face of a CAD part too large for memory, textured in tiles (issue 30).

The planar-face adapter (:mod:`texcad.targets.plane`) takes this path by itself where
its untiled relief would not fit in the memory available (``max_memory``). The result
is the untiled one's geometry, made a tile at a time:

* **the grid.** The untiled adapter's pixel grid over the face's bounding rectangle
  (face frame, mm): node ``(i, j)`` at ``(ox + (j + 1/2) px, oy + (i + 1/2) py)``,
  cut into tiles of nodes that share their border rows and columns
  (:class:`texcad.solid.tiles.Tile`, as the tiled plate).
* **the heights, tile by tile.** Each tile's texture block (read from the source, a
  built-in sampled once in a first pass, as the tiled plate) is masked by the face's
  outline and ramped down to it (the paper's M-I edge modification, the same formula
  as the untiled adapter, ``h' = min(h, tan(edge_angle) max(0, d - margin))``, with its
  1 um floor), where ``d`` is the distance transform of the tile's block grown by a
  halo of ``ceil((margin + height / tan(edge_angle)) / pitch) + 2`` px, on the grid's
  own node spacing: every node's height is the untiled one (a node farther than the
  halo from the outline is not ramped at all).
* **the textured cells.** A cell with a corner above the face (h > 0) is textured:
  two triangles, as :func:`texcad.solid.grid_faces` makes them. Every corner of such a
  cell lies at least two cell diagonals inside the outline, and where textured cells
  end the nodes are at 0 mm, in the face's plane.
* **joined without a boolean.** The rest of the part is its tessellation with the
  face's triangles replaced by a triangulation (manifold3d) of the face minus the
  textured cells' footprint, on the face's own outline vertices (shared, unchanged,
  with the faces around it: no T-junction) and on the textured cells' boundary nodes
  (the same float32 points as in their tiles). The result is one closed, oriented
  body: the base's volume plus the texture's.

:class:`TiledFaceMesh` is that mesh kept as a recipe: its blocks are made on demand,
one tile at a time, for the gate (:func:`gate_faces`: each tile's triangles read back
as cells of its grid, closed and oriented across tile borders, the same float32
points where blocks meet, the volume change against the heights' own integral,
reach) and for the streaming STL / 3MF writers. Lengths in mm.

**Against the untiled face** (tolerance 0: one vertex per pixel centre): the same
float32 vertices wherever the texture stands above the face (the same heights, ramps
and frame transform) and the same triangles wherever all three corners do (tested);
the triangles that touch the face at the texture's foot and the flat face around
them are triangulated differently (the untiled union re-triangulates them; the
surface is the same), so the volumes agree to float rounding (1e-6 relative, tested).
With ``tolerance=0`` a tiled face keeps every pixel centre (error 0); with a
tolerance (the default 0.02 mm, as untiled), blocks wholly inside the textured region are lean (:func:`lean_cells`, their
borders whole; checked by the gate: :func:`lean_tile_check`). With ``build_dir`` the ramped heights
(:class:`RampedSource`) are limited block by block, each block from the block grown
by the limiter's halo (:class:`texcad.targets.tiled.LimitedSource`,
:func:`texcad.printability.overhang.limit_overhangs_tiled`), into a temporary file (4
bytes a node) that the tiles read: the untiled limited heights, bit for bit
(tested). Not tiled (refused, naming a pitch that fits): faces with part material over
them within the texture's height (material standing on the outline, a boss or a
step, is fine) and more than :data:`texcad.targets.budget.TILED_PIXELS` pixels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import GeometryError
from ..solid.tiles import PlateGrid, Tile, block_volume
from ..util import Progress, report
from .tiled import CountedTiles, _at, tiles_verdict

__all__ = ["FaceGrid", "TiledFaceMesh", "TileCells", "face_tiles", "gate_faces", "tile_halo", "material_over", "open_edges", "RampedSource", "ramped_block", "lean_cells", "lean_tile_check"]


@dataclass(frozen=True)
class FaceGrid:
    """The pixel-node grid over a planar face, in the face's frame (mm).

    Attributes:
        shape: ``(R, C)`` nodes (the untiled adapter's grid rows and columns).
        k0: ``(ky0, kx0)`` texture pixel of node ``(0, 0)`` (may be negative: nodes
            off the texture are 0 mm).
        x0, y0: mm, the texture's corner (centred, ``offset`` added): node column
            ``j`` is at ``x0 + (kx0 + j + 1/2) px``, as the untiled grid.
        pitch: ``(px, py)`` mm.
        tile: nodes per tile side; halo: px of neighbours each tile's distances see.
        margin: mm, the zero band along the outline; edge_angle: degrees; floor: mm,
            the least height inside the ramp (:data:`texcad.targets.plane.FLOOR`).
        segments: ``(S, 2, 2)`` float64 the face's outline (all loops).
        marks: ``(P, 2)`` int64 ``(row, col)`` of the nodes nearest the outline
            samples (0 mm, as the untiled grid marks them).
        origin: ``(3,)`` mm, axes: ``(3, 3)`` rows x, y, normal (the face frame).
    """

    shape: tuple
    k0: tuple
    x0: float
    y0: float
    pitch: tuple
    tile: int
    halo: int
    margin: float
    edge_angle: float
    floor: float
    segments: np.ndarray
    marks: np.ndarray
    origin: np.ndarray
    axes: np.ndarray

    @property
    def nodes(self) -> tuple[int, int]:
        return tuple(self.shape)

    tiles = PlateGrid.tiles
    count = PlateGrid.count

    def xs(self, j0: int, j1: int) -> np.ndarray:
        """x (mm, float64) of node columns ``j0..j1`` (inclusive): the untiled ``xs``."""
        return self.x0 + (np.arange(self.k0[1] + j0, self.k0[1] + j1 + 1) + 0.5) * self.pitch[0]

    def ys(self, i0: int, i1: int) -> np.ndarray:
        """y (mm, float64) of node rows ``i0..i1`` (inclusive)."""
        return self.y0 + (np.arange(self.k0[0] + i0, self.k0[0] + i1 + 1) + 0.5) * self.pitch[1]

    @property
    def ramp_pitch(self) -> tuple[float, float]:
        """``(px, py)`` mm as the untiled ramps take them: the first two nodes' spacing
        (the distance transform is not exact where the sampling is a hair anisotropic;
        the same numbers give the same distances)."""
        xs, ys = self.xs(0, 1), self.ys(0, 1)
        return float(xs[1] - xs[0]), float(ys[1] - ys[0])

    def local(self, i: np.ndarray, j: np.ndarray, h: np.ndarray) -> np.ndarray:
        """``(k, 3)`` float32 face-frame points of nodes ``(i, j)`` at heights ``h``:
        ``(ox + (j + 1/2) px, oy + (i + 1/2) py, h)`` with ``o`` the grid's corner,
        the numbers :func:`texcad.solid.heightfield_slab` gives the untiled relief."""
        px, py = self.pitch
        ox = float(self.xs(0, 0)[0]) - px / 2
        oy = float(self.ys(0, 0)[0]) - py / 2
        out = np.empty((len(i), 3), np.float32)
        out[:, 0] = ox + (j + 0.5) * px
        out[:, 1] = oy + (i + 0.5) * py
        out[:, 2] = h
        return out

    def world(self, local: np.ndarray) -> np.ndarray:
        """Face-frame float32 points to the part's frame, float32 (as the untiled adapter)."""
        return (np.einsum("ij,jk->ik", local.astype(np.float64), self.axes) + self.origin).astype(np.float32)

    def to_local(self, v: np.ndarray) -> np.ndarray:
        """The part's points ``(k, 3)`` in the face frame, float64 mm."""
        return np.einsum("ij,kj->ik", np.asarray(v, np.float64) - self.origin, self.axes)  # faster than @ here


def tile_halo(margin: float, height: float, edge_angle: float, pitch: float) -> int:
    """Pixels of neighbours a tile needs so that its distances to the outline give
    the untiled heights: the zero band and the ramp up to ``height`` mm, plus 2."""
    reach = margin + (0.0 if edge_angle >= 90.0 else height / math.tan(math.radians(edge_angle)))
    return int(math.ceil(reach / pitch)) + 2


@dataclass(frozen=True)
class TileHeights:
    """One tile's heights and textured cells (all ``(r, c)`` over its nodes or
    ``(r - 1, c - 1)`` over its cells).

    Attributes:
        h: float32 mm, the ramped heights (the untiled ``h``).
        cells: bool, textured cells (a corner above 0 mm).
        used: bool, nodes of a textured cell (here or in a neighbouring tile).
        rim: bool, used nodes that are also a corner of a cell that is not textured.
    """

    h: np.ndarray
    cells: np.ndarray
    used: np.ndarray
    rim: np.ndarray


def _texture_block(grid: FaceGrid, source: Any, rows: slice, cols: slice) -> np.ndarray:
    """The source's heights at node rows / columns ``rows``, ``cols`` (0 mm off the texture)."""
    (ky0, kx0), (tr, tc) = grid.k0, source.shape
    h = np.zeros((rows.stop - rows.start, cols.stop - cols.start), np.float32)
    r0, r1 = max(rows.start + ky0, 0), min(rows.stop + ky0, tr)
    c0, c1 = max(cols.start + kx0, 0), min(cols.stop + kx0, tc)
    if r1 > r0 and c1 > c0:
        h[r0 - ky0 - rows.start : r1 - ky0 - rows.start, c0 - kx0 - cols.start : c1 - kx0 - cols.start] = \
            source.heights(slice(r0, r1), slice(c0, c1))
    return h


def _ramped(grid: FaceGrid, h: np.ndarray, rows: slice, cols: slice, mask_scale: Any) -> np.ndarray:
    """M-I ramps on a block of nodes (the untiled adapter's formula and floor)."""
    from scipy.ndimage import distance_transform_edt

    from ..brep import inside

    px, py = grid.ramp_pitch
    xs, ys = grid.xs(cols.start, cols.stop - 1), grid.ys(rows.start, rows.stop - 1)
    if mask_scale is not None:
        h = (h * mask_scale(xs, ys)).astype(h.dtype)
    segs = grid.segments
    lo, hi = np.minimum(segs[:, 0, 1], segs[:, 1, 1]), np.maximum(segs[:, 0, 1], segs[:, 1, 1])
    mask = inside(segs[(hi >= ys[0]) & (lo <= ys[-1])], xs, ys)  # only the segments that cross these rows
    mk = grid.marks
    at = (mk[:, 0] >= rows.start) & (mk[:, 0] < rows.stop) & (mk[:, 1] >= cols.start) & (mk[:, 1] < cols.stop)
    mask[mk[at, 0] - rows.start, mk[at, 1] - cols.start] = False
    dist = np.full(mask.shape, np.inf) if mask.all() else distance_transform_edt(mask, sampling=(py, px))
    margin = grid.margin
    if grid.edge_angle >= 90.0:
        ramp = np.where(dist > margin, np.inf, 0.0)
    else:
        ramp = np.tan(np.radians(grid.edge_angle)) * np.maximum(dist - margin, 0.0)
    h = np.where(mask, np.minimum(h, ramp), 0.0)
    return np.where(mask, np.maximum(h, np.minimum(grid.floor, ramp)), 0.0).astype(np.float32)


def ramped_block(grid: FaceGrid, source: Any, rows: slice, cols: slice, mask_scale: Any = None) -> np.ndarray:
    """The ramped heights (float32 mm, the untiled ``h`` before the overhang limiter)
    of node rows ``rows`` and columns ``cols`` (within the grid): the block grown by
    the halo, ramped (M-I, :func:`tile_halo`), cut back."""
    nr, nc = grid.shape
    hh = grid.halo
    wr = slice(max(rows.start - hh, 0), min(rows.stop + hh, nr))
    wc = slice(max(cols.start - hh, 0), min(cols.stop + hh, nc))
    h = _ramped(grid, _texture_block(grid, source, wr, wc), wr, wc, mask_scale)
    return h[rows.start - wr.start : rows.stop - wr.start, cols.start - wc.start : cols.stop - wc.start]


class RampedSource:
    """A face grid's ramped heights as a source (``shape``, ``pitch``,
    ``heights(rows, cols)`` float32 mm: :func:`ramped_block`), for the overhang
    limiter in blocks (:class:`texcad.targets.tiled.LimitedSource`)."""

    def __init__(self, grid: FaceGrid, source: Any, mask_scale: Any = None) -> None:
        self.grid, self.source, self.mask_scale = grid, source, mask_scale
        self.shape, self.pitch = tuple(grid.shape), tuple(grid.pitch)

    def heights(self, rows: slice, cols: slice) -> np.ndarray:
        return ramped_block(self.grid, self.source, rows, cols, self.mask_scale)


def tile_heights(grid: FaceGrid, source: Any, t: Tile, mask_scale: Any = None, limited: Any = None) -> TileHeights:
    """Tile ``t``'s :class:`TileHeights`: its block grown by the halo, ramped, cut back
    to the tile (one node around it kept to tell its used and rim nodes); or, with
    ``limited`` (the grid's heights after the overhang limiter, ``heights(rows,
    cols)`` mm), read from there."""
    nr, nc = grid.shape
    rows = slice(max(t.i0 - 1, 0), min(t.i1 + 2, nr))
    cols = slice(max(t.j0 - 1, 0), min(t.j1 + 2, nc))
    h = ramped_block(grid, source, rows, cols, mask_scale) if limited is None else limited.heights(rows, cols)
    # the tile and one node around it (padded with 0 mm off the grid)
    ring = np.zeros((t.shape[0] + 2, t.shape[1] + 2), np.float32)
    a, c = rows.start - (t.i0 - 1), cols.start - (t.j0 - 1)
    ring[a : a + h.shape[0], c : c + h.shape[1]] = h
    up = ring > 0
    cell = up[:-1, :-1] | up[:-1, 1:] | up[1:, :-1] | up[1:, 1:]  # (r + 1, c + 1): cells around and in the tile
    used = cell[:-1, :-1] | cell[:-1, 1:] | cell[1:, :-1] | cell[1:, 1:]
    full = cell[:-1, :-1] & cell[:-1, 1:] & cell[1:, :-1] & cell[1:, 1:]
    return TileHeights(ring[1:-1, 1:-1], cell[1:-1, 1:-1], used, used & ~full)


class FaceNumbering:
    """Global vertex numbers of the used nodes, tile by tile in :meth:`FaceGrid.tiles`
    order (as :class:`texcad.solid.tiles.Numbering`, unused nodes get none: -1)."""

    def __init__(self, grid: FaceGrid) -> None:
        nc = grid.shape[1]
        self.next = 0
        self._above = np.full(nc, -1, np.int64)
        self._below = np.full(nc, -1, np.int64)
        self._left: "np.ndarray | None" = None
        self._row = -1

    def ids(self, t: Tile, used: np.ndarray) -> np.ndarray:
        """``(r, c)`` numbers of tile ``t``'s nodes (-1: unused); call once per tile, in order."""
        if t.i0 != self._row:
            if self._row >= 0:
                self._above, self._below = self._below, self._above
            self._row, self._left = t.i0, None
        ids = np.full(t.shape, -1, np.int64)
        r0, c0 = int(t.i0 > 0), int(t.j0 > 0)
        if r0:
            ids[0, :] = self._above[t.j0 : t.j1 + 1]
        if c0:
            ids[:, 0] = self._left
        new = used[r0:, c0:]
        k = int(new.sum())
        block = ids[r0:, c0:]
        block[new] = np.arange(self.next, self.next + k, dtype=np.int64)
        self.next += k
        self._left = ids[:, -1].copy()
        self._below[t.j0 : t.j1 + 1] = ids[-1, :]
        return ids


def _cell_faces(t: Tile, cells: np.ndarray) -> np.ndarray:
    """Local triangles (row-major node indices of tile ``t``) of its textured cells,
    two per cell as :func:`texcad.solid.grid_faces` (counter-clockwise from +z)."""
    r, c = t.shape
    ci, cj = np.nonzero(cells)
    a = ci * c + cj
    b, cc, d = a + 1, a + c + 1, a + c
    tri = np.empty((2 * len(a), 3), np.int64)
    tri[0::2, 0], tri[0::2, 1], tri[0::2, 2] = a, b, cc
    tri[1::2, 0], tri[1::2, 1], tri[1::2, 2] = a, cc, d
    return tri


@dataclass(frozen=True)
class FaceTiles:
    """What a tiled planar face is made from (``Relief.data``).

    Attributes:
        grid: the :class:`FaceGrid`.
        source: the texture's heights a block at a time (``heights(rows, cols)`` mm).
        base: the part's closed mesh (mm, part frame).
        face_tris: ``(M,)`` bool, the base triangles of the textured face.
        mask: the ``mask`` option and its ``mask_size`` mm, or None.
        reach: mm, the largest distance a vertex may have from the face.
        limited: with ``build_dir``, the grid's ramped heights after the overhang
            limiter (a :class:`texcad.targets.tiled.LimitedSource` over the node
            grid: ``heights(rows, cols)`` mm, its report in ``limit.report``), else None.
        tolerance: mm; > 0: blocks wholly inside the textured region (every cell
            textured, no rim node) are made lean within it (:func:`lean_cells`).
        check: with ``build_dir`` and a tolerance, the lean facets' check
            (:func:`texcad.printability.overhang.lean_facets`, face frame), else None.
    """

    grid: FaceGrid
    source: Any
    base: Any
    face_tris: np.ndarray
    mask: Any
    reach: float
    limited: Any = None
    tolerance: float = 0.0
    check: Any = None


class _MaskScale:
    """The ``mask`` option sampled on a block of the grid (plain data, picklable)."""

    def __init__(self, mask: Any, size: tuple) -> None:
        self.mask, self.size = mask, size

    def __call__(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        from ..sources.mask import mask_on_grid

        return mask_on_grid(self.mask, self.size, xs, ys)


class TiledFaceMesh(CountedTiles):
    """A part with a textured planar face, kept as the recipe of its tiles (mm): the
    face's :class:`FaceTiles`. Blocks are made on demand (:meth:`blocks`): one per
    tile (its textured cells), then the rest of the part (its tessellation with the
    face re-triangulated round the textured cells). Gated (:func:`gate_faces`) and
    written (:meth:`write`, streamed) tile by tile."""

    def __init__(self, tiles: FaceTiles, progress: Progress = None) -> None:
        self.tiles, self.progress, self.client, self.thickness = tiles, progress, None, 0.0
        self.grid = tiles.grid
        self._scale = None if tiles.mask is None else _MaskScale(*tiles.mask)

    def blocks(self, progress: Progress = None) -> Any:
        """``(tile, vertices, faces, ids)`` per tile (float32 mm in the part's frame,
        local faces, global numbers), then ``(None, ...)`` for the rest of the part."""
        grid = self.grid
        numbering = FaceNumbering(grid)
        rim = []
        total = grid.count
        errors = self.__dict__["lean_pass"] = {}  # lean tiles' errors, mm, filled as they come
        for k, t in enumerate(grid.tiles()):  # per tile, in order
            th = tile_heights(grid, self.tiles.source, t, self._scale, self.tiles.limited)
            lean = lean_cells(t, th, self.tiles.tolerance, self.tiles.check, grid.pitch)
            used = th.used if lean is None else lean.keep
            ids = numbering.ids(t, used)
            keep = ids.ravel() >= 0
            local = np.full(ids.size, -1, np.int64)
            local[keep] = np.arange(int(keep.sum()))
            i, j = np.nonzero(used)
            v = grid.world(grid.local(i + t.i0, j + t.j0, th.h[i, j]))
            f = local[_cell_faces(t, th.cells) if lean is None else lean.faces]
            if lean is not None:
                errors[(t.i0, t.j0)] = lean.error
            rim.append(_rim_part(grid, t, th, ids))
            yield t, v, f, ids.ravel()[keep]
            report(progress, (k + 1) / (total + 1), f"tile {k + 1}/{total}")
        self.__dict__["lean"] = errors
        yield (None, *self._rest(rim, numbering.next))

    @property
    def tolerance(self) -> float:
        """mm: the lean tiles' bound (0: every pixel centre)."""
        return float(self.tiles.tolerance)

    @property
    def max_error(self) -> float:
        """The largest height error at a node of the lean tiles, mm (0 without; one
        pass over the tiles the first time)."""
        if self.tolerance <= 0:
            return 0.0
        if "lean" not in self.__dict__:
            for _ in self.blocks():  # per tile: the lean tiles' errors are kept at the end
                pass
        return max(self.__dict__["lean"].values(), default=0.0)

    def is_lean(self, t: Tile) -> bool:
        """Whether tile ``t`` (of the pass over :meth:`blocks` under way, or the last)
        is lean."""
        return (t.i0, t.j0) in self.__dict__.get("lean_pass", {})

    def _rest(self, rim: list, first: int) -> tuple:
        """The rest of the part (cached: it is small): :func:`rest_block`."""
        if "rest" not in self.__dict__:
            self.__dict__["rest"] = rest_block(self.tiles, rim, first)
        return self.__dict__["rest"]

    def share(self, t: Any, v: np.ndarray, f: np.ndarray) -> float:
        return block_volume(v, f)

    def reach(self, t: Any, v: np.ndarray, q: "np.ndarray | None" = None) -> tuple[float, float]:
        """``(farthest, highest)``: tile ``t``'s largest distance from the face's plane
        (inf off the grid's rectangle) and its highest point over it, mm (``q``: ``v``
        in the face frame, if known)."""
        if not len(v):
            return 0.0, -np.inf
        q = self.grid.to_local(v) if q is None else q
        xs, ys = self.grid.xs(0, self.grid.shape[1] - 1), self.grid.ys(0, self.grid.shape[0] - 1)
        px, py = self.grid.pitch
        off = (q[:, 0].min() < xs[0] - px) | (q[:, 0].max() > xs[-1] + px) | (q[:, 1].min() < ys[0] - py) | (q[:, 1].max() > ys[-1] + py)
        high = float(q[:, 2].max())
        return (float("inf") if off else max(high, -float(q[:, 2].min()))), high

    def gate(self, ex: Any) -> Any:
        """texcad's gate on this mesh, tile by tile (:func:`gate_faces`)."""
        return gate_faces(self, ex)

    def __repr__(self) -> str:
        nr, nc = self.grid.shape
        return f"TiledFaceMesh({nr} x {nc} nodes in {self.grid.count} tiles)"


#: Smallest block side (nodes) :func:`lean_cells` splits a tile into.
LEAN_BLOCK = 8


def lean_cells(t: Tile, th: TileHeights, tolerance: float, check: Any = None, pitch: tuple = (1.0, 1.0)) -> "Any | None":
    """Tile ``t`` made lean where it can be (:class:`texcad.solid.tiles.LeanTile`: kept
    nodes, row-major local triangles, measured error) within ``tolerance`` mm, or None
    (no tolerance, or nothing lean). A block of the tile (the tile first) wholly
    inside the textured region (every cell textured, no rim node: the face round the
    texture is triangulated on the rim nodes, which stay whole) is made lean whole;
    another is split in four, down to :data:`LEAN_BLOCK` nodes a side, whose textured
    cells then stay cells. Each lean block keeps its border whole
    (:func:`texcad.solid.lean.lean_tile`), so what meets it (a neighbouring tile,
    block or cell) meets it on the same nodes and edges; a block whose lean mesh keeps
    more than :data:`texcad.solid.lean.MAX_FRACTION` of its triangles (plus its
    border's share) stays cells. ``check(points, faces)`` (points mm in the face frame,
    ``pitch`` mm apart) may reject a block's lean triangles (a facet that overhangs),
    which are then tightened, down to the cells."""
    if tolerance <= 0:
        return None
    r, c = th.h.shape
    node = np.arange(r * c).reshape(r, c)
    keep, done = th.used.copy(), np.zeros(th.cells.shape, bool)
    faces, error = [], 0.0
    todo = [(0, r - 1, 0, c - 1)]
    while todo:  # per block: lean whole, or split in four
        a0, a1, b0, b1 = todo.pop()
        if not th.cells[a0:a1, b0:b1].any():
            continue
        if th.cells[a0:a1, b0:b1].all() and not th.rim[a0 : a1 + 1, b0 : b1 + 1].any():
            got = _lean_block(th.h[a0 : a1 + 1, b0 : b1 + 1], tolerance, check, pitch)
            if got is not None:
                rc, f, err = got
                keep[a0 + 1 : a1, b0 + 1 : b1] = False
                keep[rc[:, 0] + a0, rc[:, 1] + b0] = True
                faces.append(node[a0 : a1 + 1, b0 : b1 + 1][rc[:, 0], rc[:, 1]][f])
                done[a0:a1, b0:b1], error = True, max(error, err)
            continue
        if min(a1 - a0, b1 - b0) >= 2 * LEAN_BLOCK:
            am, bm = (a0 + a1) // 2, (b0 + b1) // 2
            todo += [(a0, am, b0, bm), (a0, am, bm, b1), (am, a1, b0, bm), (am, a1, bm, b1)]
    if not faces:
        return None
    from ..solid.tiles import LeanTile

    return LeanTile(keep, np.concatenate([_cell_faces(t, th.cells & ~done)] + faces), float(error))


def _lean_block(h: np.ndarray, tolerance: float, check: Any = None, pitch: tuple = (1.0, 1.0)) -> "tuple | None":
    """:func:`texcad.solid.lean.lean_tile` of a block of nodes (at least 3 a side;
    ``check`` of its points, ``pitch`` mm apart), or None where it keeps the grid (or
    more than its share of the grid's triangles)."""
    from ..solid.lean import MAX_FRACTION, lean_tile

    r, c = h.shape
    if min(r, c) < 3:
        return None
    accept = None
    if check is not None:
        def accept(rc: np.ndarray, f: np.ndarray) -> bool:  # noqa: E306 - the block's points, face frame
            return check(np.stack([rc[:, 1] * pitch[0], rc[:, 0] * pitch[1], h[rc[:, 0], rc[:, 1]]], 1).astype(np.float64), f)
    rc, f, err = lean_tile(h, tolerance, accept=accept, max_fraction=MAX_FRACTION + (r + c) / ((r - 1) * (c - 1)))
    return None if len(rc) == r * c else (rc, f, err)


def _rim_part(grid: FaceGrid, t: Tile, th: TileHeights, ids: np.ndarray) -> tuple:
    """Tile ``t``'s share of the textured cells' boundary: ``(faces, ids, xy, world)``,
    the triangles (global numbers) of its textured cells with a rim node, and its rim
    nodes' numbers, face-frame ``(x, y)`` (float64 of the float32 points) and
    part-frame float32 points."""
    r, c = t.shape
    rim = th.rim
    near = th.cells & (rim[:-1, :-1] | rim[:-1, 1:] | rim[1:, :-1] | rim[1:, 1:])
    faces = ids.ravel()[_cell_faces(t, near)]
    i, j = np.nonzero(rim)
    local = grid.local(i + t.i0, j + t.j0, th.h[i, j])
    return faces, ids[i, j], local[:, :2].astype(np.float64), grid.world(local)


def _loops(faces: np.ndarray, ids: np.ndarray, xy: np.ndarray) -> list:
    """The textured cells' boundary loops (global numbers, counter-clockwise round
    the cells) from their rim triangles ``faces`` and rim nodes ``ids`` at ``xy``."""
    from ..solid.boolean import boundary_loops

    uniq, inv = np.unique(faces, return_inverse=True)
    f = inv.reshape(-1, 3)
    on = np.isin(uniq, ids)
    pos = np.zeros((len(uniq), 2))
    order = np.argsort(ids)
    pos[on] = xy[order[np.searchsorted(ids, uniq[on], sorter=order)]]
    return [uniq[lp] for lp in boundary_loops(f, len(uniq), on=on, xy=pos)]  # per loop


def rest_block(tiles: FaceTiles, rim: list, first: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The part around the textured face: ``(vertices, faces, ids)`` as the streaming
    writers take them. The base's triangles but the face's, and the face minus the
    textured cells' footprint triangulated (manifold3d) on the face's outline (the
    base's own vertices, numbered from ``first``) and on the rim nodes (``rim``: per
    tile, :func:`_rim_part`), facing along the face's normal.

    Raises:
        GeometryError: the triangulation does not cover the face minus the footprint
            (the textured cells reach the outline as tessellated, or it crosses itself).
    """
    import manifold3d

    from ..solid.boolean import boundary_loops

    grid, base = tiles.grid, tiles.base
    faces = np.concatenate([p[0] for p in rim])
    rid = np.concatenate([p[1] for p in rim])
    rxy = np.concatenate([p[2] for p in rim])
    rw = np.concatenate([p[3] for p in rim])
    rid, at = np.unique(rid, return_index=True)  # a rim node on a tile border comes twice (the same point)
    rxy, rw = rxy[at], rw[at]
    r_loops = _loops(faces, rid, rxy) if len(faces) else []
    bv = np.asarray(base.vertices, np.float32)
    bf = np.asarray(base.faces, np.int64)
    bxy = grid.to_local(bv)[:, :2]
    f_loops = boundary_loops(bf[tiles.face_tris], len(bv), xy=bxy)
    nb = len(bv)
    # rim nodes after the base's vertices: index nb + k is rid[k]
    xy = np.concatenate([bxy, rxy])
    loops = f_loops + [np.searchsorted(rid, lp[::-1]) + nb for lp in r_loops]
    idx = np.concatenate(loops)
    tri = idx[np.asarray(manifold3d.triangulate([xy[lp] for lp in loops]), dtype=np.int64).reshape(-1, 3)]
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 2] != tri[:, 0])]  # a pinch, listed twice
    _check_ring(xy, tri, [xy[lp] for lp in f_loops], [xy[lp] for lp in loops[len(f_loops):]])
    out = np.concatenate([bf[~tiles.face_tris], tri])
    used = np.zeros(nb + len(rid), bool)
    used[out.ravel()] = True
    used_base = np.flatnonzero(used[:nb])
    gid = np.full(nb + len(rid), -1, np.int64)
    gid[used_base] = np.arange(first, first + len(used_base))
    gid[nb:] = rid
    keep = np.flatnonzero(used)
    local = np.full(nb + len(rid), -1, np.int64)
    local[keep] = np.arange(len(keep))
    v = np.concatenate([bv, rw])[keep]
    return v, local[out], gid[keep]


def _shoelace(p: np.ndarray) -> float:
    return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))


def _check_ring(xy: np.ndarray, tri: np.ndarray, outline: list, holes: list) -> None:
    """The ring's triangles face up and cover the face minus the footprint (1e-6)."""
    p = xy[tri]
    area2 = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 2, 0] - p[:, 0, 0]) * (p[:, 1, 1] - p[:, 0, 1])
    want = sum(_shoelace(q) for q in outline) + sum(_shoelace(q) for q in holes)
    got = 0.5 * float(area2.sum())
    if (area2 < 0).any() or abs(got - want) > 1e-6 * max(1.0, sum(abs(_shoelace(q)) for q in outline)):
        raise GeometryError(
            f"the face round the tiled texture cannot be triangulated ({got:.6g} mm2 made for {want:.6g} mm2, "
            f"{int((area2 < 0).sum())} triangle(s) upside down): the texture reaches the face's outline as tessellated; "
            "use a larger edge_angle margin or a finer tessellation, or a coarser pitch untiled"
        )


def face_tiles(fr: Any, base: Any, face_tris: np.ndarray, source: Any, options: Any, *, side: int, floor: float,
               progress: Progress = None) -> FaceTiles:
    """The :class:`FaceTiles` of a planar face ``fr`` (the plane adapter's frame) with
    the texture's ``source`` (its pixels centred on the face, ``offset`` added), ``side``
    nodes per tile side and ``floor`` mm the least height inside the ramps. With
    ``options.directions`` (``build_dir``) the ramped heights are limited block by
    block (:class:`texcad.targets.tiled.LimitedSource`: each block from the block
    grown by the limiter's halo, :func:`texcad.printability.overhang.limit_overhangs_tiled`,
    the directions turned into the face frame as the untiled adapter does): the
    untiled limited heights, bit for bit; ``progress`` is told of its blocks."""
    from ..brep import sample_segments

    px, py = (float(p) for p in source.pitch)
    rows, cols = source.shape
    x0 = -cols * px / 2 + float(options.offset[0])
    y0 = -rows * py / 2 + float(options.offset[1])
    kx = (int(np.floor((fr.lo[0] - x0) / px - 0.5)) - 2, int(np.ceil((fr.hi[0] - x0) / px - 0.5)) + 3)
    ky = (int(np.floor((fr.lo[1] - y0) / py - 0.5)) - 2, int(np.ceil((fr.hi[1] - y0) / py - 0.5)) + 3)
    shape = (ky[1] - ky[0], kx[1] - kx[0])
    xs0, ys0 = x0 + (kx[0] + 0.5) * px, y0 + (ky[0] + 0.5) * py
    rx, ry = float(np.diff(x0 + (kx[0] + np.array([0.5, 1.5])) * px)[0]), float(np.diff(y0 + (ky[0] + np.array([0.5, 1.5])) * py)[0])
    pts = sample_segments(fr.segments, 0.5 * min(rx, ry))
    ci = np.clip(np.rint((pts[:, 0] - xs0) / px).astype(np.int64), 0, shape[1] - 1)
    ri = np.clip(np.rint((pts[:, 1] - ys0) / py).astype(np.int64), 0, shape[0] - 1)
    marks = np.unique(np.stack([ri, ci], 1), axis=0)
    margin = 3.0 * float(np.hypot(rx, ry))  # as the untiled ramps: on the grid's own spacing
    hm = getattr(source, "hm", None)  # a heightmap held whole, else a built-in of the height asked for
    top = float(hm.heights.max()) if hm is not None else float(source.height)
    halo = tile_halo(margin, top, float(options.edge_angle), min(px, py))
    if halo > side // 2:
        side = 2 * halo + 2
    grid = FaceGrid(shape, (ky[0], kx[0]), x0, y0, (px, py), int(side), halo, margin, float(options.edge_angle), float(floor),
                    np.asarray(fr.segments, np.float64), marks, np.asarray(fr.origin, np.float64), np.asarray(fr.axes, np.float64))
    mask = None
    if options.mask is not None:
        size = options.mask_size if options.mask_size is not None else tuple(float(t) for t in fr.hi - fr.lo)
        mask = (options.mask, size)
    limited = None
    if options.directions is not None:
        from .tiled import LimitedSource

        ramped = RampedSource(grid, source, None if mask is None else _MaskScale(*mask))
        limited = LimitedSource(ramped, np.asarray(options.directions) @ np.asarray(fr.axes).T, options.critical_angle, side,
                                progress=progress, nominal=source.integral())
    tolerance = float(options.tolerance)  # as the untiled face: lean within it, 0 keeps every pixel centre
    check = None
    if limited is not None and tolerance > 0:  # lean facets keep the limiter's angle (the untiled lean slab's rule)
        from ..printability.overhang import lean_facets

        check = lean_facets(np.asarray(options.directions) @ np.asarray(fr.axes).T, options.critical_angle)
    return FaceTiles(grid, source, base, face_tris, mask, top + 1e-3, limited, tolerance, check)


def material_over(base_local: Any, face_tris: np.ndarray, top: float, inset: float) -> bool:
    """Whether the part has material over the face's interior (its outline inset by
    ``inset`` mm) between 1 um and ``top`` mm above it (``base_local``: the part's
    mesh in the face frame, the face at z = 0). Walls that stand on the outline (a
    boss in a hole of the face, a step beside it) are not over it: the texture is 0 mm
    there (the M-I ramps), so it cannot meet them."""
    import manifold3d as m3d

    from ..solid import to_manifold
    from ..solid.boolean import boundary_loops

    v = np.asarray(base_local.vertices, np.float64)
    loops = boundary_loops(np.asarray(base_local.faces, np.int64)[face_tris], len(v), xy=v[:, :2])
    section = m3d.CrossSection([v[lp, :2] for lp in loops], m3d.FillRule.Positive).offset(-inset, m3d.JoinType.Miter)
    if section.is_empty() or top <= 1e-3:
        return False
    prism = m3d.Manifold.extrude(section, float(top) - 1e-3).translate((0.0, 0.0, 1e-3))
    over = to_manifold(base_local) ^ prism
    return not over.is_empty() and over.volume() > 1e-9


def face_integral(grid: FaceGrid, t: Tile, h: np.ndarray) -> float:
    """Tile ``t``'s cells' share of the heights' integral, mm^3: each cell ``px py``
    times its corners' mean height (the trapezoid sum
    :func:`texcad.solid.mesh.heightfield_volume` makes over the whole grid)."""
    g = h.astype(np.float64)
    px, py = grid.pitch
    return float((g[:-1, :-1] + g[:-1, 1:] + g[1:, :-1] + g[1:, 1:]).sum()) * px * py / 4.0


def _apart(sid: np.ndarray, sxyz: np.ndarray) -> int:
    """How many vertices numbered ``sid`` in two blocks are not the same float32
    point ``sxyz`` in both."""
    order = np.argsort(sid, kind="stable")
    sid, sxyz = sid[order], sxyz[order]
    same = sid[1:] == sid[:-1]
    return int(np.sum(np.any(sxyz[1:][same] != sxyz[:-1][same], axis=1)))


def gate_faces(mesh: TiledFaceMesh, ex: Any) -> Any:
    """texcad's gate (checks 1-5, :func:`texcad.report.gate.gate`) on a tiled face, one
    tile at a time, in memory that goes with one tile plus the tiles' open edges:

    1. closed and oriented: each tile's open edges (global numbers) and the rest's
       edges pair up, each directed edge once and its reverse once; a vertex in two
       blocks is the same float32 point in both; every vertex finite;
    2-3. one body per base body, facing out (the volume positive);
    4. the volume change against the base is the heights' own integral (the trapezoid
       sum over the grid, computed from the tiles' heights, not from the triangles)
       within its slack (``px py`` times the highest point) and float rounding;
    5. every tile vertex lies within ``ex.height`` mm of the face's plane, over the grid;
    6. a lean tile (:func:`lean_cells`): its triangles' open edges (none used twice the
       same way) pair up as above, its heights are read again from the source and its
       triangles lie within the tolerance of them at every node
       (:func:`lean_tile_check`); the slack of 4 grows by tolerance x its area.

    Returns:
        :class:`texcad.report.gate.GateReport`; sets the mesh's volume, top and counts.

    Raises:
        GeometryError: a check failed (the message names it and the figures).
    """
    from ..report.gate import ShellReport

    what = "textured face (in tiles)"
    grid = mesh.grid
    edges, seam_ids, seam_xyz = [], [], []
    volume, integral, top, farthest, finite = 0.0, 0.0, -np.inf, 0.0, True
    nv, nt, error, lean_area, scale = 0, 0, 0.0, 0.0, 0.0
    for t, v, f, ids in mesh.blocks(mesh.progress):  # per tile
        finite &= bool(np.isfinite(v).all())
        scale = max(scale, float(np.abs(v).max(initial=0.0)))
        nv, nt = max(nv, int(ids.max(initial=-1)) + 1), nt + len(f)
        q = grid.to_local(v)
        if t is None:  # the rest of the part: its volume in the face frame too (the field (0, 0, z) there)
            volume += block_volume(q, f)
            g = ids[f]
            edges.append(np.concatenate([g[:, [0, 1]], g[:, [1, 2]], g[:, [2, 0]]]))
            seam_ids.append(ids)
            seam_xyz.append(v)
            continue
        far, high = mesh.reach(t, v, q)
        farthest, top = max(farthest, far), max(top, high)
        if mesh.is_lean(t):
            h, open_, err = lean_tile_check(mesh, t, q, f, ids, what)
            integral += face_integral(grid, t, h)
            volume += block_volume(q, f)
            error = max(error, err)
            lean_area += (t.shape[0] - 1) * (t.shape[1] - 1) * grid.pitch[0] * grid.pitch[1]
        else:
            cells = TileCells.of(grid, t, q, f, what)
            integral += face_integral(grid, t, cells.h)
            volume += cells.volume(grid.pitch)
            open_ = ids[cells.open_edges()]
        edges.append(open_)
        ring = np.unique(open_)
        seam_ids.append(ring)
        seam_xyz.append(_at(ids, v, ring))
    apart = _apart(np.concatenate(seam_ids), np.concatenate(seam_xyz))
    if apart:
        raise GeometryError(f"the {what} failed texcad's gate: {apart} vertices differ between neighbouring blocks "
                            "(a gap at a seam); please report this")
    open_, bad = open_edges(np.concatenate(edges))
    closed = finite and not len(open_) and not bad
    shells = ShellReport(closed=closed, open_edges=len(open_), nonmanifold_edges=bad, misoriented_edges=0,
                         volumes=(volume,), nesting=(0,), inside_out=int(volume <= 0), nested_bodies=0, bodies=int(ex.bodies))
    if not shells.manifold:
        raise GeometryError(f"the {what} failed texcad's gate: {shells.problem() or 'its vertices are not finite'}; please report this")
    mesh.__dict__.update(volume=volume, top=top, counts=(nv, nt), closed=closed)
    if error > mesh.tolerance + 1e-6 + 4 * float(np.finfo(np.float32).eps) * scale:  # the part's float32 points
        raise GeometryError(f"the {what} failed texcad's gate: its lean tiles lie up to {error:.4f} mm from the "
                            f"texture's heights at a node, beyond tolerance={mesh.tolerance:g} mm; please report this")
    change = volume - float(ex.base.volume)
    px, py = grid.pitch
    slack = px * py * float(ex.height) + 1e-3 * abs(integral) + 1e-6 * abs(float(ex.base.volume)) + 1e-3
    slack += mesh.tolerance * lean_area
    return tiles_verdict(what, shells, change, integral, slack, farthest, float(ex.height), "face")


def lean_tile_check(mesh: TiledFaceMesh, t: Tile, q: np.ndarray, f: np.ndarray, ids: np.ndarray,
                    what: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Lean tile ``t`` (its vertices ``q`` in the face frame, mm, local triangles
    ``f``, global numbers ``ids``) read back: ``(h, open, error)``, the tile's heights
    read again from the source (``(r, c)`` float32 mm), its triangles' open edges
    (global numbers) and their largest height error at the nodes they cover, mm
    (:func:`texcad.solid.lean.surface_error`, the cells no triangle covers filled in
    at the heights read: error 0 there; a node covered twice or not at all is an
    error).

    Raises:
        GeometryError: a vertex off the tile's nodes, two on one node, an edge used
            twice the same way, or triangles that do not tile the textured cells.
    """
    from ..solid.lean import surface_error

    grid = mesh.grid
    r, c = t.shape
    px, py = grid.pitch
    fi, fj = (q[:, 1] - grid.ys(t.i0, t.i0)[0]) / py, (q[:, 0] - grid.xs(t.j0, t.j0)[0]) / px
    i, j = np.rint(fi).astype(np.int64), np.rint(fj).astype(np.int64)
    if i.min() < 0 or j.min() < 0 or i.max() >= r or j.max() >= c or max(np.abs(fi - i).max(), np.abs(fj - j).max()) > 0.01:
        raise GeometryError(f"the {what} failed texcad's gate: a lean tile's vertices are off its node grid; please report this")
    node = i * c + j
    if len(np.unique(node)) != len(node):
        raise GeometryError(f"the {what} failed texcad's gate: two vertices of a lean tile on one node; please report this")
    open_, twice = open_edges(ids[f])
    if twice:
        raise GeometryError(f"the {what} failed texcad's gate: a lean tile has {twice} edge(s) used twice the same way "
                            "or by more than two triangles; please report this")
    th = tile_heights(grid, mesh.tiles.source, t, mesh._scale, mesh.tiles.limited)
    z = th.h.astype(np.float64).ravel()
    z[node] = q[:, 2]
    rc = np.stack(np.divmod(np.arange(r * c), c), 1)
    try:
        err = surface_error(th.h, rc, z, np.concatenate([node[f], _cell_faces(t, ~th.cells)]))
    except GeometryError:
        raise GeometryError(f"the {what} failed texcad's gate: a lean tile's triangles do not cover its textured cells; "
                            "please report this") from None
    return th.h, open_, err


@dataclass(frozen=True)
class TileCells:
    """A tile's triangles read back as cells of the node grid (checked).

    Attributes:
        node: ``(r, c)`` int64, the tile's vertex at each node, -1 where none.
        cells: ``(r - 1, c - 1)`` bool, cells that hold their two triangles.
        h: ``(r, c)`` float64 mm, the nodes' heights over the face (0 where none).
    """

    node: np.ndarray
    cells: np.ndarray
    h: np.ndarray

    @classmethod
    def of(cls, grid: FaceGrid, t: Tile, q: np.ndarray, f: np.ndarray, what: str) -> "TileCells":
        """Read tile ``t``'s vertices ``q`` (face frame, mm) and triangles ``f``: every
        vertex on a node of the tile (within a hundredth of a pixel), one vertex per
        node, every pair of triangles ``(a, b, c), (a, c, d)`` a cell counter-clockwise
        from +z (:func:`texcad.solid.grid_faces`), each cell once.

        Raises:
            GeometryError: naming what is not so.
        """
        r, c = t.shape
        px, py = grid.pitch
        y0, x0 = grid.ys(t.i0, t.i0)[0], grid.xs(t.j0, t.j0)[0]
        fi, fj = (q[:, 1] - y0) / py, (q[:, 0] - x0) / px
        i, j = np.rint(fi).astype(np.int64), np.rint(fj).astype(np.int64)
        if len(q) and (i.min() < 0 or j.min() < 0 or i.max() >= r or j.max() >= c
                       or max(np.abs(fi - i).max(), np.abs(fj - j).max()) > 0.01):
            raise GeometryError(f"the {what} failed texcad's gate: a tile's vertices are off its node grid; please report this")
        node = np.full((r, c), -1, np.int64)
        node[i, j] = np.arange(len(q))
        if int((node >= 0).sum()) != len(q):
            raise GeometryError(f"the {what} failed texcad's gate: two vertices of a tile on one node (a duplicate vertex); "
                                "please report this")
        f0, f1 = f[0::2], f[1::2]
        ci, cj = i[f0[:, 0]], j[f0[:, 0]]
        ok = len(f) % 2 == 0 and ci.max(initial=0) < r - 1 and cj.max(initial=0) < c - 1
        if ok:
            a, b, cc, d = node[ci, cj], node[ci, cj + 1], node[ci + 1, cj + 1], node[ci + 1, cj]
            ok = bool((f0[:, 1] == b).all() and (f0[:, 2] == cc).all() and (f1[:, 0] == a).all()
                      and (f1[:, 1] == cc).all() and (f1[:, 2] == d).all())
        cells = np.zeros((r - 1, c - 1), bool)
        if ok:
            cells[ci, cj] = True
            ok = int(cells.sum()) == len(f0)
        if not ok:
            raise GeometryError(f"the {what} failed texcad's gate: a tile's triangles are not its grid's cells, "
                                "each once, counter-clockwise; please report this")
        h = np.zeros((r, c))
        h[i, j] = q[:, 2]
        return cls(node, cells, h)

    def open_edges(self) -> np.ndarray:
        """``(k, 2)`` the cells' directed border edges (vertex indices): where a cell's
        neighbour across an edge is not a cell of the tile (counter-clockwise round
        them; the diagonals pair up inside each cell)."""
        m, n = self.cells, self.node
        none = np.zeros((1, m.shape[1]), bool)
        below = np.vstack([none, m[:-1]])
        above = np.vstack([m[1:], none])
        left = np.hstack([np.zeros((m.shape[0], 1), bool), m[:, :-1]])
        right = np.hstack([m[:, 1:], np.zeros((m.shape[0], 1), bool)])
        out = []
        for side, (p0, p1) in (((m & ~below), ((0, 0), (0, 1))), ((m & ~right), ((0, 1), (1, 1))),
                               ((m & ~above), ((1, 1), (1, 0))), ((m & ~left), ((1, 0), (0, 0)))):  # per side
            ci, cj = np.nonzero(side)
            out.append(np.stack([n[ci + p0[0], cj + p0[1]], n[ci + p1[0], cj + p1[1]]], 1))
        return np.concatenate(out)

    def volume(self, pitch: tuple) -> float:
        """The cells' share of the volume in the face frame (the field ``(0, 0, z)``):
        a cell ``px`` by ``py`` mm with corners ``a`` (lower left), ``b``, ``c``, ``d``
        (counter-clockwise) adds ``px py (2 h_a + h_b + 2 h_c + h_d) / 6``."""
        h, m = self.h, self.cells
        cell = 2 * h[:-1, :-1] + h[:-1, 1:] + 2 * h[1:, 1:] + h[1:, :-1]
        return float(cell[m].sum()) * pitch[0] * pitch[1] / 6.0


def open_edges(faces: np.ndarray) -> tuple[np.ndarray, int]:
    """``(open, bad)``: the directed edges ``(k, 2)`` of triangles ``faces`` (or of
    directed edges ``(m, 2)``; indices from 0) whose reverse is not among them, and how
    many edges come twice the same way or more than twice (non-manifold or
    misoriented). One sort of int64 keys."""
    f = np.asarray(faces, np.int64)
    if not len(f):
        return np.zeros((0, 2), np.int64), 0
    a, b = (f.ravel(), f[:, [1, 2, 0]].ravel()) if f.shape[1] == 3 else (f[:, 0], f[:, 1])
    n = int(f.max()) + 1
    k = np.sort((np.minimum(a, b) * n + np.maximum(a, b)) * 2 + (a > b))
    und = k >> 1
    bad = int(np.sum(k[1:] == k[:-1])) + (int(np.sum(und[2:] == und[:-2])) if len(k) > 2 else 0)
    single = np.ones(len(k), bool)
    single[1:] &= und[1:] != und[:-1]
    single[:-1] &= und[:-1] != und[1:]
    ks = k[single]
    lo, hi, flip = (ks >> 1) // n, (ks >> 1) % n, (ks & 1).astype(bool)
    return np.stack([np.where(flip, hi, lo), np.where(flip, lo, hi)], 1), bad
