"""Does a triangle mesh cross itself? (:func:`self_intersections`, vectorized.)

A closed mesh whose surface crosses itself (two overlapping bodies written as one
"closed" mesh, a fold) encloses no well-defined solid: displacing it or fusing it gives
garbage. The test, all in numpy:

1. *broad phase*: every triangle goes into the cells of a uniform grid (cell about
   twice the median triangle size) that its axis-aligned box overlaps and that it may
   meet (a ball test against its plane and its edges' side planes, so a long diagonal
   sliver does not fill its whole box); triangles that share a cell and whose boxes
   overlap are candidate pairs, each pair counted once (duplicates from the several
   cells two triangles share dropped; issue 27: keeping a pair only in the cell of
   its boxes' lowest common corner lost the pairs the ball test left out there);
2. pairs that share a vertex are left out (neighbours touch by construction);
3. *narrow phase*: two triangles cross when an edge of one passes through the inside
   of the other (Moller-Trumbore, all pairs and their six edges at once); touching
   within a relative 1e-9 does not count.

Coplanar overlaps (two faces lying on each other) are not seen by the edge test; two
bodies that overlap in volume always also cross somewhere.
"""

from __future__ import annotations

import hashlib

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


def _candidate_pairs(lo: np.ndarray, hi: np.ndarray, cell: float, budget: int, tri: np.ndarray) -> np.ndarray:
    """``(P, 2)`` pairs ``a < b`` of triangles that meet a common grid cell, boxes
    overlapping."""
    c0 = np.floor((lo - colmin(lo)) / cell).astype(np.int64)
    c1 = np.floor((hi - colmin(lo)) / cell).astype(np.int64)
    span = c1 - c0 + 1
    ncell = span[:, 0] * span[:, 1] * span[:, 2]
    if ncell.sum() > min(budget, CELLS_PER_TRIANGLE * len(lo)):  # a few huge triangles fill most cells: coarser cells
        return _candidate_pairs(lo, hi, cell * 2.0, budget, tri)
    owner, ix, iy, iz = box_cells(c0, c1)
    big = np.flatnonzero(ncell[owner] > 1)  # a triangle in several cells: only those it may meet
    centre = colmin(lo) + (np.stack([ix[big], iy[big], iz[big]], 1) + 0.5) * cell
    keep = np.ones(len(owner), dtype=bool)
    keep[big] = _touches(tri, owner[big], centre, 0.5 * np.sqrt(3.0) * cell)
    owner, ix, iy, iz = owner[keep], ix[keep], iy[keep], iz[keep]
    dim = c1.max(axis=0) + 1
    key = ix + dim[0] * (iy + dim[1] * iz)
    order = argsort_ints(key)
    key, owner = key[order], owner[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    size = np.diff(np.r_[start, len(key)])
    end = np.repeat(start + size, size)  # one past each entry's group
    pos = np.arange(len(key))
    cnt = end - pos - 1
    a = np.repeat(pos, cnt)
    b = a + 1 + np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    ta, tb = owner[a], owner[b]
    for lk, hk in zip(lo.T, hi.T):  # per axis: the boxes overlap along it
        lk, hk = np.ascontiguousarray(lk), np.ascontiguousarray(hk)
        ok = (lk[ta] <= hk[tb]) & (lk[tb] <= hk[ta])
        ta, tb = ta[ok], tb[ok]
    # each pair once, whichever cells it shares: a pair may be dropped from the cell of
    # its boxes' lowest common corner by the ball test and kept only in others
    # (a sort and a look at neighbours: np.unique hashes, 10x slower on millions of keys)
    pair = np.sort(np.minimum(ta, tb) * len(lo) + np.maximum(ta, tb))
    pair = pair[np.concatenate([[True], pair[1:] != pair[:-1]])] if len(pair) else pair
    return np.stack([pair // len(lo), pair % len(lo)], 1)


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
    pairs = _candidate_pairs(lo, hi, cell, budget, tri)
    fa, fb = f[pairs[:, 0]], f[pairs[:, 1]]
    share = np.zeros(len(pairs), dtype=bool)
    for i in range(3):  # per corner pair
        for j in range(3):
            share |= fa[:, i] == fb[:, j]
    pairs = pairs[~share]
    if not len(pairs):
        return pairs
    pa, pb = tri[pairs[:, 0]], tri[pairs[:, 1]]
    cross = pairs[_edges_cross(pa, pb) | _edges_cross(pb, pa)]
    return cross[np.lexsort((cross[:, 1], cross[:, 0]))]
