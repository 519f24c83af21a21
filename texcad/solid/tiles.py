"""A textured plate's closed surface, made tile by tile with exact seams.

The plate ``[0, w] x [0, d] x [-t, 0]`` mm has its texture on top. Its top surface is
one grid of *nodes*: a border ring at the plate's edges (x = 0 and w, y = 0 and d, at
z = 0) around the texture's pixel centres (at their heights), so the node grid is
``(R + 2) x (C + 2)`` for an ``R x C`` px texture. :class:`PlateGrid` cuts it into
tiles of nodes that share their border rows and columns with their neighbours: a
seam's vertices are the same numbers (mm) computed once from the same formula, so
there is no gap, and each is numbered once (:class:`Numbering`), so there is no
duplicate vertex. Each tile's cells become two triangles the way
:func:`texcad.solid.grid_faces` makes them, so the tiled top is the untiled grid,
triangle for triangle. :func:`walls` closes the solid: four vertical walls (planar
fans from a bottom corner) and the bottom rectangle. A lean tile
(:func:`lean_plate_tile`) keeps its border nodes and the nodes its triangulation
needs; :class:`Numbering` then numbers only those.

Plain numpy; memory goes with one tile, plus ``O(R + C)`` numbers for the seams.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np

from ..errors import ParameterError
from .grid import grid_faces

__all__ = ["PlateGrid", "Tile", "Numbering", "walls", "block_volume", "SurfaceGrid", "WrapNumbering", "caps", "LeanTile", "lean_plate_tile"]


@dataclass(frozen=True)
class Tile:
    """One tile of nodes: rows ``i0..i1`` and columns ``j0..j1`` (inclusive; a tile
    shares row ``i0`` with the tile below it and column ``j0`` with the one to its left)."""

    i0: int
    i1: int
    j0: int
    j1: int

    @property
    def shape(self) -> tuple[int, int]:
        return self.i1 - self.i0 + 1, self.j1 - self.j0 + 1


@dataclass(frozen=True)
class PlateGrid:
    """The plate's top node grid.

    Attributes:
        size: ``(w, d)`` plate size, mm.
        texture_shape: ``(R, C)`` texture pixels.
        pitch: ``(px, py)`` mm per pixel.
        tile: nodes per tile side (at least 2).
    """

    size: tuple
    texture_shape: tuple
    pitch: tuple
    tile: int

    def __post_init__(self) -> None:
        if int(self.tile) < 2:
            raise ParameterError(f"a tile must be at least 2 nodes a side, got {self.tile!r}")
        w, d = self.size
        (r, c), (px, py) = self.texture_shape, self.pitch
        if c * px > w + 1e-6 or r * py > d + 1e-6:
            raise ParameterError(f"the texture ({c * px:g} x {r * py:g} mm) is larger than the plate ({w:g} x {d:g} mm)")

    @property
    def origin(self) -> tuple[float, float]:
        """``(ox, oy)`` mm: the texture's corner, centred on the plate (as
        :func:`texcad.pipeline.textured_plate` places it)."""
        (r, c), (px, py) = self.texture_shape, self.pitch
        return (self.size[0] - c * px) / 2, (self.size[1] - r * py) / 2

    @property
    def nodes(self) -> tuple[int, int]:
        """``(R + 2, C + 2)``."""
        return self.texture_shape[0] + 2, self.texture_shape[1] + 2

    def xs(self, j0: int, j1: int) -> np.ndarray:
        """x (mm, float32) of node columns ``j0..j1`` (inclusive): 0, the pixel
        centres ``ox + (j - 1/2) px``, w."""
        c = self.texture_shape[1]
        j = np.arange(j0, j1 + 1)
        x = self.origin[0] + (j - 0.5) * self.pitch[0]  # the same float64 as ox + Heightmap.x
        x = np.where(j == 0, 0.0, np.where(j == c + 1, float(self.size[0]), x))
        return x.astype(np.float32)

    def ys(self, i0: int, i1: int) -> np.ndarray:
        """y (mm, float32) of node rows ``i0..i1`` (inclusive)."""
        r = self.texture_shape[0]
        i = np.arange(i0, i1 + 1)
        y = self.origin[1] + (i - 0.5) * self.pitch[1]
        y = np.where(i == 0, 0.0, np.where(i == r + 1, float(self.size[1]), y))
        return y.astype(np.float32)

    def tiles(self) -> Iterator[Tile]:
        """The tiles in row-major order (rows of tiles from y = 0 up)."""
        nr, nc = self.nodes
        step = int(self.tile) - 1
        for i0 in range(0, nr - 1, step):  # per row of tiles
            for j0 in range(0, nc - 1, step):  # per tile
                yield Tile(i0, min(i0 + step, nr - 1), j0, min(j0 + step, nc - 1))

    @property
    def count(self) -> int:
        nr, nc = self.nodes
        step = int(self.tile) - 1
        return -(-(nr - 1) // step) * -(-(nc - 1) // step)

    def texture_block(self, t: Tile) -> tuple[slice, slice, slice, slice]:
        """``(rows, cols, node_rows, node_cols)``: the texture pixels inside tile ``t``
        and where they go in the tile's ``(r, c)`` node array."""
        r, c = self.texture_shape
        a, b = max(t.i0, 1), min(t.i1, r)
        e, f = max(t.j0, 1), min(t.j1, c)
        return (slice(a - 1, b), slice(e - 1, f), slice(a - t.i0, b - t.i0 + 1), slice(e - t.j0, f - t.j0 + 1))

    def vertices(self, t: Tile, heights: np.ndarray) -> np.ndarray:
        """``(r c, 3)`` float32 vertices of tile ``t``: ``heights`` is the tile's
        texture block (:meth:`texture_block`, mm), 0 on the border ring."""
        rows, cols, nrs, ncs = self.texture_block(t)
        z = np.zeros(t.shape, dtype=np.float32)
        z[nrs, ncs] = heights
        v = np.empty(t.shape + (3,), dtype=np.float32)
        v[..., 0] = self.xs(t.j0, t.j1)[None, :]
        v[..., 1] = self.ys(t.i0, t.i1)[:, None]
        v[..., 2] = z
        return v.reshape(-1, 3)

    def top_volume(self, t: Tile, vertices: np.ndarray) -> float:
        """Tile ``t``'s share of the plate's volume, mm^3: :func:`block_volume` of its
        triangles (:meth:`faces`), summed per cell on the grid: a cell ``dx`` by
        ``dy`` mm with corners ``a`` (lower left), ``b``, ``c``, ``d`` (counter-clockwise)
        adds ``dx dy (2 z_a + z_b + 2 z_c + z_d) / 6``."""
        r, c = t.shape
        v = vertices.reshape(r, c, 3)
        dx = np.diff(v[0, :, 0].astype(np.float64))
        dy = np.diff(v[:, 0, 1].astype(np.float64))
        z = v[..., 2].astype(np.float64)
        cell = 2 * z[:-1, :-1] + z[:-1, 1:] + 2 * z[1:, 1:] + z[1:, :-1]
        return float(dy @ cell @ dx / 6.0)

    def faces(self, t: Tile) -> np.ndarray:
        """``(2 (r-1)(c-1), 3)`` local triangles of tile ``t`` (:func:`grid_faces`)."""
        return grid_faces(*t.shape).astype(np.int64)


class Numbering:
    """Global vertex numbers given tile by tile, in :meth:`PlateGrid.tiles` order: a
    tile's new nodes (all but its first row and column, which the tiles below and to
    the left numbered) are numbered on from the last; keeps the numbers of one row of
    nodes and one tile's column (``O(C + tile)`` integers)."""

    def __init__(self, grid: PlateGrid) -> None:
        self.grid = grid
        nr, nc = grid.nodes
        self.next = 0
        self._above = np.full(nc, -1, dtype=np.int64)  # the last tile row's top row
        self._below = np.full(nc, -1, dtype=np.int64)  # this tile row's top row, filled as it goes
        self._left: "np.ndarray | None" = None
        self._row = -1
        #: numbers of the border ring, for :func:`walls`: rows 0 and R+1, columns 0 and C+1
        self.ring = {"bottom": np.full(nc, -1, np.int64), "top": np.full(nc, -1, np.int64),
                     "left": np.full(nr, -1, np.int64), "right": np.full(nr, -1, np.int64)}

    def ids(self, t: Tile, used: "np.ndarray | None" = None) -> np.ndarray:
        """``(r, c)`` global numbers of tile ``t``'s nodes (call once per tile, in
        order); with ``used`` (``(r, c)`` bool, a lean tile's kept nodes, its border
        all kept) only those are numbered, the others get -1."""
        if t.i0 != self._row:  # a new row of tiles
            if self._row >= 0:
                self._above, self._below = self._below, self._above
            self._row, self._left = t.i0, None
        r, c = t.shape
        ids = np.empty((r, c), dtype=np.int64)
        r0, c0 = int(t.i0 > 0), int(t.j0 > 0)
        if r0:
            ids[0, :] = self._above[t.j0 : t.j1 + 1]
        if c0:
            ids[:, 0] = self._left
        if used is None:
            k = (r - r0) * (c - c0)
            ids[r0:, c0:] = np.arange(self.next, self.next + k, dtype=np.int64).reshape(r - r0, c - c0)
        else:
            new = np.asarray(used, bool)[r0:, c0:]
            k = int(new.sum())
            block = np.full(new.shape, -1, np.int64)
            block[new] = np.arange(self.next, self.next + k, dtype=np.int64)
            ids[r0:, c0:] = block
        self.next += k
        self._left = ids[:, -1].copy()
        self._below[t.j0 : t.j1 + 1] = ids[-1, :]
        nr, nc = self.grid.nodes
        if t.i0 == 0:
            self.ring["bottom"][t.j0 : t.j1 + 1] = ids[0, :]
        if t.i1 == nr - 1:
            self.ring["top"][t.j0 : t.j1 + 1] = ids[-1, :]
        if t.j0 == 0:
            self.ring["left"][t.i0 : t.i1 + 1] = ids[:, 0]
        if t.j1 == nc - 1:
            self.ring["right"][t.i0 : t.i1 + 1] = ids[:, -1]
        return ids


@dataclass(frozen=True)
class LeanTile:
    """A plate tile's lean triangulation (:func:`lean_plate_tile`).

    Attributes:
        keep: ``(r, c)`` bool, the tile's nodes that are vertices (its border all).
        faces: ``(m, 3)`` int64 triangles, row-major node indices of the tile,
            counter-clockwise seen from +z.
        error: mm, the largest height error at the tile's pixel centres (measured).
    """

    keep: np.ndarray
    faces: np.ndarray
    error: float


def lean_plate_tile(grid: PlateGrid, t: Tile, vertices: np.ndarray, tolerance: float, *, accept=None,
                    max_fraction: float = 1.0, measure: bool = True) -> LeanTile:
    """Tile ``t`` of a plate (its ``(r c, 3)`` float32 ``vertices``, mm) made lean
    within ``tolerance`` mm (:func:`texcad.solid.lean.lean_tile`): its texture
    pixels triangulated with their block's four sides at full resolution, so the
    tile's border rows and columns keep every node (its neighbours meet it on the
    same points and edges) and so do the texture's outer rows and columns, whose cells
    to the plate's rim stay the grid's (the rim's spacing is not the pixels').
    ``accept(points, faces)`` (``(k, 3)`` float64 mm, local triangles) may reject a
    lean block (e.g. a facet that overhangs), which is then tightened, down to the
    grid. The grid too where the lean block keeps more than ``max_fraction`` of its
    grid's triangles plus what its whole border costs (about ``2 (a + b)`` triangles
    of the border strip for an ``a x b`` block: the untiled rule,
    :data:`texcad.solid.lean.MAX_FRACTION`, for a plate cut into tiles). ``measure``
    False: the error is left to the caller (NaN for a lean block, e.g. measured by the
    gate tile by tile)."""
    from .lean import lean_tile

    r, c = t.shape
    _, _, nrs, ncs = grid.texture_block(t)
    a, b = nrs.stop - nrs.start, ncs.stop - ncs.start
    node = np.arange(r * c).reshape(r, c)
    cells = np.ones((r - 1, c - 1), bool)
    keep = np.ones((r, c), bool)
    faces, error = [], 0.0
    if a >= 2 and b >= 2:
        v = vertices.reshape(r, c, 3)[nrs, ncs]
        here = None
        if accept is not None:
            here = lambda rc, f: accept(v[rc[:, 0], rc[:, 1]].astype(np.float64), f)  # noqa: E731
        share = max_fraction + (a + b) / ((a - 1) * (b - 1))
        if accept is None:
            rc, f, error = lean_tile(v[..., 2], tolerance, max_fraction=share, measure=measure)
        else:  # in blocks of TILE px (as the untiled lean slab): a facet that fails makes only its block finer
            rc, f, error = _checked_lean(v[..., 2], tolerance, here, share, measure)
        sub = node[nrs, ncs]
        faces.append(sub[rc[:, 0], rc[:, 1]][f])
        keep[nrs.start + 1 : nrs.stop - 1, ncs.start + 1 : ncs.stop - 1] = False
        keep[rc[:, 0] + nrs.start, rc[:, 1] + ncs.start] = True
        cells[nrs.start : nrs.stop - 1, ncs.start : ncs.stop - 1] = False
    ci, cj = np.nonzero(cells)  # the grid's cells round the texture block (to the rim)
    p = ci * c + cj
    tri = np.empty((2 * len(p), 3), np.int64)
    tri[0::2, 0], tri[0::2, 1], tri[0::2, 2] = p, p + 1, p + c + 1
    tri[1::2, 0], tri[1::2, 1], tri[1::2, 2] = p, p + c + 1, p + c
    faces.insert(0, tri)
    return LeanTile(keep, np.concatenate(faces).astype(np.int64), float(error))


def _checked_lean(z: np.ndarray, tolerance: float, accept, share: float,
                  measure: bool = True) -> tuple[np.ndarray, np.ndarray, float]:
    """``(rc, faces, error)`` of a texture block made lean in blocks of
    :data:`texcad.solid.lean.TILE` px, each checked by ``accept``
    (:func:`texcad.solid.lean.tiled_triangulation`); the grid where that keeps more
    than ``share`` of the grid's triangles."""
    from .grid import grid_faces
    from .lean import surface_error, tiled_triangulation

    lean = tiled_triangulation(z, tolerance, accept=accept, max_fraction=share)
    if lean is None:
        r, c = z.shape
        g = np.stack(np.meshgrid(np.arange(r), np.arange(c), indexing="ij"), -1).reshape(-1, 2)
        return g, grid_faces(r, c).astype(np.int64), 0.0
    rc, f = lean[0], lean[1].astype(np.int64)
    return rc, f, surface_error(z, rc, z[rc[:, 0], rc[:, 1]], f) if measure else float("nan")


def _fan(a: int, b: int, chain: np.ndarray) -> np.ndarray:
    """A planar wall: corner ``a`` below ``chain[0]``, corner ``b`` below ``chain[-1]``:
    triangles ``(a, chain[k+1], chain[k])`` and ``(a, b, chain[-1])``."""
    tri = np.empty((len(chain), 3), dtype=np.int64)
    tri[:-1, 0], tri[:-1, 1], tri[:-1, 2] = a, chain[1:], chain[:-1]
    tri[-1] = (a, b, chain[-1])
    return tri


def walls(grid: PlateGrid, numbering: Numbering, thickness: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The block closing the plate: ``(vertices, faces, ids)`` as the streaming
    writers take it (:mod:`texcad.io.stream`): the four bottom corners (new, at z =
    -thickness) and the ring nodes (already numbered), four vertical walls and the
    bottom, every triangle facing out."""
    w, d = (float(s) for s in grid.size)
    ring = numbering.ring
    nr, nc = grid.nodes
    n = numbering.next
    corners = np.array([[0, 0, -thickness], [w, 0, -thickness], [w, d, -thickness], [0, d, -thickness]], dtype=np.float32)
    c00, cw0, cwd, c0d = n, n + 1, n + 2, n + 3
    xs, ys = grid.xs(0, nc - 1), grid.ys(0, nr - 1)
    chains = [  # (corner below the first node, corner below the last, node numbers, their (x, y), outward normal)
        (c00, cw0, ring["bottom"], np.stack([xs, np.zeros_like(xs)], 1), (0.0, -1.0)),
        (c0d, cwd, ring["top"], np.stack([xs, np.full_like(xs, d)], 1), (0.0, 1.0)),
        (c00, c0d, ring["left"], np.stack([np.zeros_like(ys), ys], 1), (-1.0, 0.0)),
        (cw0, cwd, ring["right"], np.stack([np.full_like(ys, w), ys], 1), (1.0, 0.0)),
    ]
    ids = np.concatenate([np.arange(n, n + 4)] + [c[2] for c in chains])
    xy = np.concatenate([corners[:, :2]] + [c[3] for c in chains])
    verts = np.concatenate([corners, np.column_stack([xy[4:], np.zeros(len(xy) - 4, np.float32)])]).astype(np.float32)
    local = {int(g): k for k, g in enumerate(ids[:4])}
    off = 4
    tris = []
    for a, b, chain, _, out in chains:  # per wall
        pos_chain = np.arange(off, off + len(chain))
        off += len(chain)
        t = _fan(local[a], local[b], pos_chain)
        p = verts[t[-1]].astype(np.float64)  # the last triangle is never degenerate
        nrm = np.cross(p[1] - p[0], p[2] - p[0])
        if nrm[0] * out[0] + nrm[1] * out[1] < 0:
            t = t[:, [0, 2, 1]]
        tris.append(t)
    tris.append(np.array([[0, 2, 1], [0, 3, 2]], dtype=np.int64))  # the bottom, facing -z
    return verts, np.concatenate(tris), ids


def block_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """This block's share of a closed mesh's volume, mm^3 (float64; the divergence
    theorem with the field ``(0, 0, z)``: the sum over its triangles of their mean z
    times their signed area seen from +z, so the blocks' shares add up; vertical
    walls add nothing)."""
    v = vertices.astype(np.float64)
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    return float(np.dot(area2, a[:, 2] + b[:, 2] + c[:, 2]) / 6.0)


@dataclass(frozen=True)
class SurfaceGrid:
    """The node grid of a closed 2.5D surface (a closed profile in the XZ plane
    extruded along +y from 0 to ``length`` mm, :class:`texcad.Surface`), cut into
    tiles as :class:`PlateGrid`: node rows are the ends (y = 0 and ``length``, on the
    profile itself) around the texture's ``R`` rows; node columns are the texture's
    ``C`` columns and, last, column 0 again (the seam: the same vertices, numbered
    once by :class:`WrapNumbering`).

    Attributes:
        texture_shape: ``(R, C)`` texture pixels (C: around the whole profile).
        y: ``(R,)`` float64 y of the texture rows, mm.
        length: the extrusion's length, mm.
        point: ``(C, 2)`` float32 (x, z) of each column on the profile, mm.
        offset: ``(C, 2)`` float32 (x, z) offset per mm of height of each column.
        tile: nodes per tile side.
    """

    texture_shape: tuple
    y: np.ndarray
    length: float
    point: np.ndarray
    offset: np.ndarray
    tile: int

    @property
    def nodes(self) -> tuple[int, int]:
        """``(R + 2, C + 1)``."""
        return self.texture_shape[0] + 2, self.texture_shape[1] + 1

    tiles = PlateGrid.tiles
    count = PlateGrid.count
    faces = PlateGrid.faces

    def ys(self, i0: int, i1: int) -> np.ndarray:
        """y (mm, float32) of node rows ``i0..i1``: 0, the texture rows, ``length``."""
        r = self.texture_shape[0]
        i = np.arange(i0, i1 + 1)
        y = np.where(i == 0, 0.0, np.where(i == r + 1, float(self.length), self.y[np.clip(i - 1, 0, r - 1)]))
        return y.astype(np.float32)

    def texture_block(self, t: Tile) -> tuple[slice, np.ndarray, slice]:
        """``(rows, cols, node_rows)``: the texture rows inside tile ``t``, the texture
        column of each of its node columns (column ``C`` is column 0) and where the
        rows go in the tile's node array."""
        r, c = self.texture_shape
        a, b = max(t.i0, 1), min(t.i1, r)
        return slice(a - 1, b), np.arange(t.j0, t.j1 + 1) % c, slice(a - t.i0, b - t.i0 + 1)

    def vertices(self, t: Tile, heights: np.ndarray) -> np.ndarray:
        """``(r c, 3)`` float32 vertices of tile ``t`` from its texture rows'
        ``heights`` (mm, ``(rows, r_cols)`` for :meth:`texture_block`'s columns):
        ``P + h offset`` as :func:`texcad.mapping.map_texture` computes its top grid
        (float32, the same operations), ``P`` on the end rows."""
        rows, cols, nrs = self.texture_block(t)
        h = np.zeros((t.shape[0], len(cols)), dtype=np.float32)
        h[nrs] = heights
        v = np.empty(t.shape + (3,), dtype=np.float32)
        off, pt = self.offset[cols], self.point[cols]
        v[..., 0] = h * off[:, 0]
        v[..., 0] += pt[:, 0]
        v[..., 1] = self.ys(t.i0, t.i1)[:, None]
        v[..., 2] = h * off[:, 1]
        v[..., 2] += pt[:, 1]
        return v.reshape(-1, 3)


class WrapNumbering(Numbering):
    """:class:`Numbering` for a :class:`SurfaceGrid`: the last node column is column
    0 again, so it takes the numbers column 0 got (in the first tile of the same row
    of tiles) and no new ones."""

    def ids(self, t: Tile) -> np.ndarray:
        nr, nc = self.grid.nodes
        if t.j1 != nc - 1:
            return super().ids(t)
        inner = Tile(t.i0, t.i1, t.j0, t.j1 - 1)
        ids = np.empty(t.shape, dtype=np.int64)
        ids[:, :-1] = super().ids(inner)
        ids[:, -1] = self.ring["left"][t.i0 : t.i1 + 1]
        self._below[t.j1] = ids[-1, -1]
        if t.i0 == 0:
            self.ring["bottom"][t.j1] = ids[0, -1]
        if t.i1 == nr - 1:
            self.ring["top"][t.j1] = ids[-1, -1]
        self.ring["right"][t.i0 : t.i1 + 1] = ids[:, -1]
        return ids


def caps(grid: SurfaceGrid, numbering: WrapNumbering) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two end caps closing a :class:`SurfaceGrid`'s surface into a solid (the
    profile's interior at y = 0 and y = ``length``, facing -y and +y):
    ``(vertices, faces, ids)`` as the streaming writers take them, on the end rows'
    nodes (already numbered), the profile polygon triangulated by manifold3d."""
    import manifold3d

    r, c = grid.texture_shape
    p = grid.point.astype(np.float64)
    area = 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))
    order = np.arange(c) if area > 0 else np.arange(c)[::-1]  # counter-clockwise in (x, z)
    tri = order[np.asarray(manifold3d.triangulate([p[order]]), dtype=np.int64).reshape(-1, 3)]
    lo = tri  # counter-clockwise in (x, z): the normal x cross z = -y
    v = np.concatenate([np.column_stack([grid.point[:, 0], np.zeros(c, np.float32), grid.point[:, 1]]),
                        np.column_stack([grid.point[:, 0], np.full(c, np.float32(grid.length)), grid.point[:, 1]])])
    ids = np.concatenate([numbering.ring["bottom"][:c], numbering.ring["top"][:c]])
    faces = np.concatenate([lo, lo[:, [0, 2, 1]] + c])
    return v.astype(np.float32), faces, ids
