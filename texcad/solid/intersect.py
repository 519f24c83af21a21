"""Does a triangle mesh cross itself? (:func:`self_intersections`, vectorized.)

A closed mesh whose surface crosses itself (two overlapping bodies written as one
"closed" mesh, a fold) encloses no well-defined solid: displacing it or fusing it gives
garbage. The test, all in numpy:

1. *broad phase*: uniform grids, one per size class of triangles (cells halving from
   about twice the median triangle size down to the finest triangles'): each triangle
   goes into the cells of its class's grid that its axis-aligned box overlaps, a
   triangle of the coarsest class only into those it may meet (a ball test against
   its plane and its edges' side planes, so a long diagonal sliver does not fill its
   whole box); it meets the triangles of coarser classes in their grids, where its
   box spans at most two cells per axis. Triangles that share a cell and whose boxes
   overlap are candidate pairs, each counted once per chunk of pairs (issue 27:
   keeping a pair only in the cell of its boxes' lowest common corner lost the pairs
   the ball test left out there);
2. pairs that share a vertex are left out (neighbours touch by construction);
3. *narrow phase*: two triangles cross when an edge of one passes through the inside
   of the other (Moller-Trumbore, all pairs and their six edges at once); touching
   within a relative 1e-9 does not count.

Coplanar overlaps (two faces lying on each other) are not seen by the edge test; two
bodies that overlap in volume always also cross somewhere.
"""

from __future__ import annotations

import hashlib
from typing import Iterator

import numpy as np

from ..util import argsort_ints, colmax, colmin, rowdot, rowmax, rownorm
from .subdivide import cross

__all__ = ["self_intersections", "box_cells"]

#: Relative tolerance: an edge that ends on, or grazes, a triangle does not cross it.
EPS = 1e-9
#: Grid cells per triangle at most, on average, in the broad phase: beyond, the cells
#: double (3DBenchy's bridge roof, 24556 triangles of which a few are 9 mm wide over
#: 0.13 mm cells, had 287 per triangle and took 27 s; with cells 4 x as wide, 11, 3 s).
CELLS_PER_TRIANGLE = 32
#: Grids finer than the coarsest, at most (cells halving each): triangles down to
#: 1/64 of the median size get cells of their own size.
LEVELS = 6
#: Pairs of grid entries formed at once (memory: about 100 bytes each).
PAIR_CHUNK = 4_000_000


def _touches(tri: np.ndarray, t: np.ndarray, centre: np.ndarray, r: float) -> np.ndarray:
    """``(E,)`` bool: the ball of radius ``r`` around ``centre[k]`` may meet triangle
    ``tri[t[k]]`` (within ``r`` of its plane and of the inner side of its three edges:
    conservative, never drops a cell the triangle meets)."""
    p = np.take(tri, t, axis=0)
    n = cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    n /= np.maximum(rownorm(n), 1e-300)[:, None]
    ok = np.abs(rowdot(centre - p[:, 0], n)) <= r
    for k in range(3):  # per edge: its side plane, normal pointing away from the triangle
        s = cross(p[:, (k + 1) % 3] - p[:, k], n)
        s /= np.maximum(rownorm(s), 1e-300)[:, None]
        ok &= rowdot(centre - p[:, k], s) <= r
    return ok


def box_cells(c0: np.ndarray, c1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every grid cell of every box: boxes ``k`` spanning the integer cells ``c0[k]``
    to ``c1[k]`` ``(K, 3)`` inclusive. Returns ``(owner, ix, iy, iz)``, one entry
    per (box, cell), x fastest (the uniform-grid broad phase of
    :func:`self_intersections` and of the texture check's point lookups)."""
    span = c1 - c0 + 1
    ncell = span.prod(axis=1)
    owner = np.repeat(np.arange(len(c0)), ncell)
    k = np.arange(int(ncell.sum())) - np.repeat(np.cumsum(ncell) - ncell, ncell)
    sx, sy = span[owner, 0], span[owner, 1]
    return owner, c0[owner, 0] + k % sx, c0[owner, 1] + (k // sx) % sy, c0[owner, 2] + k // (sx * sy)


def _levels(size: np.ndarray, top: float) -> tuple[np.ndarray, np.ndarray]:
    """``(level (K,), cells (J + 1,))``: the broad phase's grids, cells of
    ``top / 2^(J - j)`` mm, and each triangle's: the finest whose cell is at least
    the triangle's box size (at most :data:`LEVELS` grids below ``top``; bigger
    triangles go to ``top``), so that a cell holds a few triangles of its own size
    wherever the mesh is fine or coarse."""
    small = float(np.percentile(size, 1)) if len(size) else top
    J = int(np.clip(np.ceil(np.log2(top / max(small, top * 2.0**-LEVELS))), 0, LEVELS))
    cells = top / 2.0 ** (J - np.arange(J + 1))
    level = np.clip(np.ceil(np.log2(np.maximum(size, 1e-300) / cells[0])), 0, J).astype(np.int64)
    return level, cells


def _grid_entries(lo, hi, idx, origin, cell, dim, tri=None) -> tuple[np.ndarray, np.ndarray, int]:
    """``(owner, key, entries)``: every cell of the grid of ``cell`` mm (from
    ``origin``, ``dim`` cells per axis) that the box of each triangle ``idx`` overlaps,
    one per (triangle, cell), ``key`` the cell's number (x fastest); ``entries``:
    their count. With ``tri``, a triangle spanning several cells keeps only those it
    may meet (:func:`_touches`)."""
    c0 = np.floor((lo[idx] - origin) / cell).astype(np.int64)
    c1 = np.floor((hi[idx] - origin) / cell).astype(np.int64)
    owner, ix, iy, iz = box_cells(c0, c1)
    entries = len(owner)
    if tri is not None:
        span = c1 - c0 + 1
        many = np.flatnonzero(span[owner].prod(axis=1) > 1)
        centre = origin + (np.stack([ix[many], iy[many], iz[many]], 1) + 0.5) * cell
        keep = np.ones(len(owner), dtype=bool)
        keep[many] = _touches(tri, idx[owner[many]], centre, 0.5 * np.sqrt(3.0) * cell)
        owner, ix, iy, iz = owner[keep], ix[keep], iy[keep], iz[keep]
    return idx[owner], ix + dim[0] * (iy + dim[1] * iz), entries


def _cell_pairs(key: np.ndarray, query: np.ndarray, owner: np.ndarray) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Pairs of entries in the same cell, ``(owner a, owner b)`` in chunks of about
    :data:`PAIR_CHUNK`: every two members (``query`` False) once, and every query
    with every member."""
    order = argsort_ints(key * 2 + query)  # in each cell its members first
    key, query, owner = key[order], query[order], owner[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    size = np.diff(np.r_[start, len(key)])
    gs = np.repeat(start, size)
    gm = np.repeat(np.add.reduceat((~query).astype(np.int64), start), size) if len(key) else gs
    pos = np.arange(len(key))
    first = np.where(query, gs, pos + 1)  # a member pairs with the members after it
    cnt = np.maximum(np.where(query, gm, gs + gm - pos - 1), 0)
    total = np.cumsum(cnt)
    cuts = np.searchsorted(total, np.arange(PAIR_CHUNK, int(total[-1]) if len(total) else 0, PAIR_CHUNK))
    for p0, p1 in zip(np.r_[0, cuts], np.r_[cuts, len(key)]):  # per chunk of entries
        c = cnt[p0:p1]
        a = np.repeat(pos[p0:p1], c)
        b = np.repeat(first[p0:p1], c) + np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        yield owner[a], owner[b]


def _candidate_pairs(lo: np.ndarray, hi: np.ndarray, cell: float, budget: int, tri: np.ndarray) -> Iterator[np.ndarray]:
    """``(P, 2)`` pairs ``a < b`` of triangles that meet a common grid cell, boxes
    overlapping, in chunks (a pair found in cells of two chunks comes twice).

    Each triangle sits in the grid of its level (:func:`_levels`); a triangle of the
    coarsest level only in the cells it may meet (:func:`_touches`). A triangle looks
    for partners of coarser levels in their grids, where its box spans at most two
    cells per axis. So the pairs grow with the triangles, not with their squares in
    the cells where a fine mesh meets a coarse one (a painted seam's 0.03 mm
    triangles in one grid of 0.34 mm cells: 377 M pairs of entries)."""
    origin, far = colmin(lo), colmax(hi)
    level, cells = _levels(rowmax(hi - lo), cell)
    for j in range(len(cells) - 1, -1, -1):  # per grid, coarsest first
        dim = np.floor((far - origin) / cells[j]).astype(np.int64) + 1
        mine, finer = np.flatnonzero(level == j), np.flatnonzero(level < j)
        top = j == len(cells) - 1
        owner, key, n = _grid_entries(lo, hi, mine, origin, cells[j], dim, tri if top else None)
        if top and n > min(budget, CELLS_PER_TRIANGLE * len(lo)):  # a few huge triangles fill most cells: coarser cells
            yield from _candidate_pairs(lo, hi, cell * 2.0, budget, tri)
            return
        q_owner, q_key, _ = _grid_entries(lo, hi, finer, origin, cells[j], dim)
        query = np.r_[np.zeros(len(key), dtype=bool), np.ones(len(q_key), dtype=bool)]
        for ta, tb in _cell_pairs(np.r_[key, q_key], query, np.r_[owner, q_owner]):  # per chunk
            yield _overlapping(lo, hi, ta, tb)


def _overlapping(lo: np.ndarray, hi: np.ndarray, ta: np.ndarray, tb: np.ndarray) -> np.ndarray:
    """``(P, 2)`` the pairs ``(min, max)`` of ``ta``, ``tb`` whose boxes overlap, each
    once (a sort and a look at neighbours: np.unique hashes, 10x slower on millions
    of keys)."""
    for lk, hk in zip(lo.T, hi.T):  # per axis: the boxes overlap along it
        lk, hk = np.ascontiguousarray(lk), np.ascontiguousarray(hk)
        ok = (lk[ta] <= hk[tb]) & (lk[tb] <= hk[ta])
        ta, tb = ta[ok], tb[ok]
    n = len(lo)
    pair = np.sort(np.minimum(ta, tb) * n + np.maximum(ta, tb))
    pair = pair[np.concatenate([[True], pair[1:] != pair[:-1]])] if len(pair) else pair
    return np.stack([pair // n, pair % n], 1)


def _edges_cross(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``(P,)`` bool: an edge of triangle ``p[k]`` ``(P, 3, 3)`` passes through the
    inside of triangle ``q[k]``."""
    a = q[:, 0]
    e1, e2 = q[:, 1] - a, q[:, 2] - a
    scale = rownorm(e1) * rownorm(e2)
    hit = np.zeros(len(p), dtype=bool)
    for k in range(3):  # per edge of p
        o = p[:, k]
        d = p[:, (k + 1) % 3] - o
        pv = cross(d, e2)
        det = rowdot(e1, pv)
        ok = np.abs(det) > EPS * scale * rownorm(d)
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        tv = o - a
        u = rowdot(tv, pv) * inv
        qv = cross(tv, e1)
        v = rowdot(d, qv) * inv
        t = rowdot(e2, qv) * inv
        hit |= ok & (u > EPS) & (v > EPS) & (u + v < 1 - EPS) & (t > EPS) & (t < 1 - EPS)
    return hit


def self_intersections(vertices: np.ndarray, faces: np.ndarray, *, budget: int = 20_000_000) -> np.ndarray:
    """Pairs of triangles that cross each other (module docstring).

    Args:
        vertices: ``(N, 3)`` positions, mm.
        faces: ``(M, 3)`` vertex indices.
        budget: most (triangle, grid cell) entries of the broad phase (memory bound).

    Returns:
        ``(K, 2)`` int64 face index pairs ``a < b`` that cross, sorted (empty: the
        surface does not cross itself, up to coplanar overlaps).
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) < 2:
        return np.zeros((0, 2), dtype=np.int64)
    global _LAST
    digest = hashlib.blake2b(np.ascontiguousarray(v).tobytes() + np.ascontiguousarray(f).tobytes(), digest_size=16).digest()
    key = (digest, v.shape, f.shape, budget)
    last = _LAST
    if last is not None and last[0] == key:
        return last[1].copy()
    out = _self_intersections(v, f, budget)
    _LAST = (key, out)
    return out.copy()


#: The last mesh tested and its answer: the mesh adapter tests a mesh when it reads it
#: (to repair small crossings) and again beside the displacement; the second is free.
_LAST: "tuple | None" = None


def _self_intersections(v: np.ndarray, f: np.ndarray, budget: int) -> np.ndarray:
    """:func:`self_intersections` without its memory of the last mesh."""
    tri = np.take(v, f, axis=0)
    lo = np.minimum(np.minimum(tri[:, 0], tri[:, 1]), tri[:, 2])
    hi = np.maximum(np.maximum(tri[:, 0], tri[:, 1]), tri[:, 2])
    size = float(np.median(rowmax(hi - lo)))
    extent = float((colmax(hi) - colmin(lo)).max())
    cell = max(2.0 * size, extent / 512.0, 1e-9)
    found = [np.zeros((0, 2), dtype=np.int64)]
    for pairs in _candidate_pairs(lo, hi, cell, budget, tri):  # per chunk
        fa, fb = f[pairs[:, 0]], f[pairs[:, 1]]
        share = np.zeros(len(pairs), dtype=bool)
        for i in range(3):  # per corner pair
            for j in range(3):
                share |= fa[:, i] == fb[:, j]
        pairs = pairs[~share]
        pa, pb = tri[pairs[:, 0]], tri[pairs[:, 1]]
        found.append(pairs[_edges_cross(pa, pb) | _edges_cross(pb, pa)])
    cross = np.unique(np.concatenate(found), axis=0)
    return cross[np.lexsort((cross[:, 1], cross[:, 0]))]
