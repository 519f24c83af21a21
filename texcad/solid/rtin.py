"""Lean meshes of mapped grids: error-bounded right-triangulated irregular networks.

A texture laid on a curved face is a grid of points ``V = P + h N`` (mm): the face's
point ``P`` plus the height ``h`` along its unit normal ``N``. Greedy insertion on
the heights (:func:`texcad.solid.triangulate`) cannot bound the error of such a grid:
a flat triangle across a curved face misses it by its chord error whatever the
heights. This module triangulates the grid by *longest-edge bisection* (a
right-triangulated irregular network, RTIN: Evans, Kirkpatrick and Townsend 2001;
Mapbox's Martini) with the error measured along the face's normal:

* the grid is split into squares of ``block`` cells, each cut along a diagonal into
  two right isosceles triangles; a triangle splits at the midpoint ``m`` of its
  hypotenuse ``ab`` into two halves, down to half grid cells. Below the top level a
  square's diagonal runs through its parent's centre, so square ``(i, j)`` of any
  level is cut along its main diagonal when ``i + j`` is even;
* the error of vertex ``m`` is ``e(m) = max_k w_k |((V_k(a) + V_k(b)) / 2 - P(m)) .
  N(m) - h_k(m)|`` over the height fields ``h_k`` (weights ``w_k``): the chord's
  height error at its midpoint, sag of the face included. It is raised to the
  largest error of the vertices its halves split at, so a triangle splits when any
  finer level inside it must (Martini's rule). The two triangles that share a
  hypotenuse read the same vertex, so the mesh is conforming (no T-junctions);
* squares holding a cell outside ``cells`` *and* one inside, or a cell marked
  ``fine``, split down to half cells: the outline and the M-I ramps stay exactly as
  the grid has them. Only triangles wholly inside ``cells`` are kept.

The vertex errors steer the refinement; the bound is what :func:`grid_error`
measures independently afterwards: the mesh's height along ``N(q)`` at every grid
point ``q`` against ``h(q)``. :func:`lean_grid` lowers the threshold until that
measured error is within the tolerance.

Pure numpy, vectorized per level; grid coordinates are ``(row, col)``.
"""

from __future__ import annotations

import numpy as np

from ..errors import GeometryError

__all__ = ["BLOCK", "rtin_triangles", "grid_error", "lean_grid"]

#: Cells per side of the largest triangles' squares (a power of two).
BLOCK = 64
#: Largest share of the grid's triangles a lean mesh may keep (else the grid is used).
MAX_FRACTION = 0.6


def _sizes(block: int) -> list[int]:
    """Square sizes from the finest (2) to ``block``."""
    return [1 << k for k in range(1, int(np.log2(block)) + 1)]


def _at(err: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``err[rows[:, None], cols[None, :]]`` with 0 outside the grid."""
    R, C = err.shape
    ri, ci = np.clip(rows, 0, R - 1), np.clip(cols, 0, C - 1)
    ok = ((rows >= 0) & (rows < R))[:, None] & ((cols >= 0) & (cols < C))[None, :]
    return np.where(ok, err[np.ix_(ri, ci)], 0.0)


def _mid_error(F: dict, m: tuple, a: tuple, b: tuple) -> np.ndarray:
    """Per midpoint: the largest weighted height error along the normal of the
    chord's midpoint, ``w |((V(a) + V(b)) / 2 - P(m)) . N(m) - h(m)|``."""
    P, N = F["P"], F["N"]
    out = None
    for V, h, w in zip(F["V"], F["h"], F["w"]):  # per field (one or two)
        d = 0.5 * (V[a] + V[b]) - P[m]
        e = w * np.abs(np.einsum("...k,...k->...", d, N[m]) - h[m])
        out = e if out is None else np.maximum(out, e)
    return out


def _edge_level(err, F, force_sq, s, horizontal: bool) -> None:
    """Errors of the midpoints of the ``s``-squares' edges (in place)."""
    R1, C1 = err.shape
    h, q = s // 2, s // 4
    if horizontal:  # edges along rows 0, s, 2s, ...; midpoints at columns h, h + s, ...
        m, a, b = np.s_[::s, h::s], np.s_[::s, : -1 : s], np.s_[::s, s::s]
        rows, cols = np.arange(0, R1, s), np.arange(h, C1, s)
        pad = np.zeros((1, force_sq.shape[1]), bool)
        f = np.concatenate([pad, force_sq]) | np.concatenate([force_sq, pad])
    else:
        m, a, b = np.s_[h::s, ::s], np.s_[: -1 : s, ::s], np.s_[s::s, ::s]
        rows, cols = np.arange(h, R1, s), np.arange(0, C1, s)
        pad = np.zeros((force_sq.shape[0], 1), bool)
        f = np.concatenate([pad, force_sq], axis=1) | np.concatenate([force_sq, pad], axis=1)
    e = _mid_error(F, m, a, b)
    if q:  # children: the centres of the (s/2)-squares on both sides of the edge
        for dr in (-q, q):
            for dc in (-q, q):
                e = np.maximum(e, _at(err, rows + dr, cols + dc))
    err[m] = np.where(f, np.inf, e)


def _centre_level(err, F, force_sq, s) -> None:
    """Errors of the ``s``-squares' centres (in place): children are the edge midpoints."""
    h = s // 2
    nr, nc = force_sq.shape
    main = (np.add.outer(np.arange(nr), np.arange(nc)) % 2) == 0
    e_main = _mid_error(F, np.s_[h::s, h::s], np.s_[: -1 : s, : -1 : s], np.s_[s::s, s::s])
    e_anti = _mid_error(F, np.s_[h::s, h::s], np.s_[: -1 : s, s::s], np.s_[s::s, : -1 : s])
    kids = np.maximum.reduce([err[: -1 : s, h::s], err[s::s, h::s], err[h::s, : -1 : s], err[h::s, s::s]])
    err[h::s, h::s] = np.where(force_sq, np.inf, np.maximum(np.where(main, e_main, e_anti), kids))


def _halve(mask: np.ndarray, how) -> np.ndarray:
    """``(R/2, C/2)``: ``how`` (np.logical_or / and) over each 2 x 2 block."""
    return how(how(mask[0::2, 0::2], mask[1::2, 0::2]), how(mask[0::2, 1::2], mask[1::2, 1::2]))


def _vertex_errors(F: dict, allowed: np.ndarray, fine: np.ndarray, block: int) -> np.ndarray:
    """Per grid vertex ``(R+1, C+1)``: the split error (mm), ``inf`` where a split is
    forced (a square holding cells inside and outside ``allowed``, or a ``fine`` cell)."""
    err = np.zeros(F["P"].shape[:2])
    any_in, all_in, any_fine = allowed, allowed, fine & allowed
    for s in _sizes(block):  # per level, finest first: children before parents
        any_in, all_in = _halve(any_in, np.logical_or), _halve(all_in, np.logical_and)
        any_fine = _halve(any_fine, np.logical_or)
        force_sq = any_in & (~all_in | any_fine)
        _edge_level(err, F, force_sq, s, horizontal=True)
        _edge_level(err, F, force_sq, s, horizontal=False)
        _centre_level(err, F, force_sq, s)
    return err


def _roots(nr: int, nc: int, s: int, C1: int) -> np.ndarray:
    """The top-level triangles ``(n, 3)`` as flat vertex indices ``row * C1 + col``
    (hypotenuse ends, apex), counter-clockwise seen with columns right and rows up."""
    i, j = (g.ravel() for g in np.meshgrid(np.arange(nr), np.arange(nc), indexing="ij"))
    A, B = i * s * C1 + j * s, (i + 1) * s * C1 + (j + 1) * s
    Cc, D = i * s * C1 + (j + 1) * s, (i + 1) * s * C1 + j * s
    main = ((i + j) % 2 == 0)[:, None]
    first = np.where(main, np.stack([B, A, Cc], 1), np.stack([Cc, D, A], 1))
    second = np.where(main, np.stack([A, B, D], 1), np.stack([D, Cc, B], 1))
    return np.concatenate([first, second])


def rtin_triangles(err: np.ndarray, threshold: float, block: int) -> np.ndarray:
    """Split the ``block``-squares' triangles while their hypotenuse midpoint's error
    exceeds ``threshold`` mm; the leaves ``(n, 3)`` as flat indices into ``err``
    (``row * C1 + col``). A midpoint's flat index is the mean of its ends' (all
    triangles of a round have the same size, so the last round is the half cells)."""
    R1, C1 = err.shape
    e = err.ravel()
    tri = _roots((R1 - 1) // block, (C1 - 1) // block, block, C1)
    leaves = []
    for level in range(2 * int(np.log2(block))):  # per level
        m = (tri[:, 0] + tri[:, 1]) // 2
        split = e[m] > threshold
        leaves.append(tri[~split])
        t, m = tri[split], m[split]
        tri = np.empty((2 * len(t), 3), np.int64)
        tri[0::2, 0], tri[0::2, 1], tri[0::2, 2] = t[:, 2], t[:, 0], m
        tri[1::2, 0], tri[1::2, 1], tri[1::2, 2] = t[:, 1], t[:, 2], m
    leaves.append(tri)
    return np.concatenate(leaves)


def _stencil(u: np.ndarray, v: np.ndarray):
    """Grid offsets strictly inside or on the edges of the triangle ``(u, v, 0)``
    (offsets from its apex), its vertices excluded, with their barycentric weights
    ``(K, 3)`` for the vertices ``(apex + u, apex + v, apex)``."""
    lo, hi = np.minimum(np.minimum(u, v), 0), np.maximum(np.maximum(u, v), 0)
    rr, cc = (g.ravel() for g in np.meshgrid(np.arange(lo[0], hi[0] + 1), np.arange(lo[1], hi[1] + 1), indexing="ij"))
    det = u[0] * v[1] - u[1] * v[0]
    a = (rr * v[1] - cc * v[0]) / det  # q = a u + b v
    b = (u[0] * cc - u[1] * rr) / det
    inside = (a >= -1e-12) & (b >= -1e-12) & (a + b <= 1 + 1e-12)
    corner = ((rr == 0) & (cc == 0)) | ((rr == u[0]) & (cc == u[1])) | ((rr == v[0]) & (cc == v[1]))
    k = inside & ~corner
    return rr[k], cc[k], np.stack([a[k], b[k], 1 - a[k] - b[k]], axis=1)


def grid_error(F: dict, tri: np.ndarray, *, chunk: int = 1 << 20) -> tuple[float, np.ndarray]:
    """The largest weighted height error (mm) of the mesh at the grid points it covers.

    ``F``: ``P``, ``N`` ``(R, C, 3)`` the face's points (mm) and unit normals, and per
    field a height grid ``h`` ``(R, C)`` mm, its vertices ``V = P + h N`` and a weight
    ``w``. At grid point ``q`` the mesh's height is where the line ``P(q) + t N(q)``
    meets the plane of the triangle over ``q`` (in grid coordinates); the error is
    ``w |t - h(q)|`` (on a flat face, the vertical error of a heightfield mesh).
    Where the triangle is nearly parallel to the normal (``|N . n| < 0.1``) the 3-D
    distance to the barycentric point is taken instead (larger).

    ``tri`` ``(n, 3)`` flat vertex indices ``row * C + col``. A triangle's own vertices
    have no error; the other grid points in it (edges included, so a point on a
    shared edge is measured by both sides) are listed once per triangle shape (an
    RTIN has a few dozen), with their barycentric weights. Returns the error and
    the ``(R, C)`` coverage mask."""
    R, C = F["P"].shape[:2]
    flat = {"V": [V.reshape(-1, 3) for V in F["V"]], "h": [h.reshape(-1) for h in F["h"]]}
    Pf, Nf = F["P"].reshape(-1, 3), F["N"].reshape(-1, 3)
    covered = np.zeros(R * C, bool)
    covered[tri.ravel()] = True
    r, c = tri // C, tri % C
    key = np.stack([r[:, 0] - r[:, 2], c[:, 0] - c[:, 2], r[:, 1] - r[:, 2], c[:, 1] - c[:, 2]], axis=1)
    keys, inv = _unique_rows(key)
    worst = 0.0
    order = np.argsort(inv, kind="stable")
    bounds = np.searchsorted(inv[order], np.arange(len(keys) + 1))
    for k in range(len(keys)):  # per triangle shape
        sr, sc, lam = _stencil(keys[k, :2], keys[k, 2:])
        if not len(sr):
            continue
        off = sr * C + sc
        sel = order[bounds[k] : bounds[k + 1]]
        step = max(1, chunk // len(off))
        for s0 in range(0, len(sel), step):  # per chunk of triangles of this shape
            t = sel[s0 : s0 + step]
            vid_q = tri[t, 2][:, None] + off[None, :]
            covered[vid_q.ravel()] = True
            for V, h, w in zip(flat["V"], flat["h"], F["w"]):  # per field
                worst = max(worst, w * _height_error(V[tri[t]], lam, Pf[vid_q], Nf[vid_q], V[vid_q], h[vid_q]))
    return worst, covered.reshape(R, C)


def _height_error(Vt, lam, Pq, Nq, Vq, hq) -> float:
    """Largest ``|t - h|`` over a chunk: ``Vt`` ``(n, 3, 3)`` triangles, ``lam``
    ``(K, 3)`` barycentric stencil, ``Pq, Nq, Vq`` ``(n, K, 3)``, ``hq`` ``(n, K)``."""
    n_t = np.cross(Vt[:, 1] - Vt[:, 0], Vt[:, 2] - Vt[:, 0])
    n_t /= np.maximum(np.linalg.norm(n_t, axis=1, keepdims=True), 1e-300)
    cos = np.einsum("nkd,nd->nk", Nq, n_t)
    along = np.einsum("nkd,nd->nk", Vt[:, None, 0] - Pq, n_t)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.abs(along / cos - hq)
    steep = np.abs(cos) < 0.1
    if steep.any():
        est = np.einsum("kj,njd->nkd", lam, Vt)
        e = np.where(steep, np.linalg.norm(est - Vq, axis=-1), e)
    return float(e.max()) if e.size else 0.0


def _unique_rows(key: np.ndarray):
    """``np.unique(key, axis=0, return_inverse=True)`` for small-integer rows, by a 1-D code."""
    lo = key.min(axis=0)
    span = key.max(axis=0) - lo + 1
    code = np.zeros(len(key), np.int64)
    for j in range(key.shape[1]):  # per column (4)
        code = code * span[j] + (key[:, j] - lo[j])
    uc, first, inv = np.unique(code, return_index=True, return_inverse=True)
    return key[first], inv.ravel()


def _pad(a: np.ndarray, rows: int, cols: int, value=None) -> np.ndarray:
    pr, pc = rows - a.shape[0], cols - a.shape[1]
    widths = [(0, pr), (0, pc)] + [(0, 0)] * (a.ndim - 2)
    return np.pad(a, widths, mode="edge") if value is None else np.pad(a, widths, constant_values=value)


def lean_grid(
    P: np.ndarray,
    N: np.ndarray,
    heights: list,
    cells: np.ndarray,
    tolerance: float,
    *,
    weights: "list | None" = None,
    fine: np.ndarray | None = None,
    block: int = BLOCK,
    max_fraction: float = MAX_FRACTION,
    measure: bool = True,
) -> "dict | None":
    """An error-bounded triangulation of the grid cells ``cells``.

    Args:
        P: ``(R, C, 3)`` mm, the face's points at the grid.
        N: ``(R, C, 3)`` unit normals there.
        heights: ``(R, C)`` height grids (mm along ``N``): the surfaces the mesh must
            follow (its vertices are ``P + h N``), e.g. the relief and 0 (the face).
        cells: ``(R-1, C-1)`` bool, the cells to cover (cell ``(r, c)`` spans grid
            points ``r..r+1``, ``c..c+1``).
        tolerance: mm, > 0: the largest height error at a grid point
            (:func:`grid_error`), each field's error multiplied by its weight.
        weights: one per height grid (default 1).
        fine: ``(R-1, C-1)`` bool, cells kept at the grid's resolution (outlines,
            ramps, seams).
        block: largest triangles' square side in cells (a power of two).
        max_fraction: give up (None) when the mesh keeps more than this share of the
            grid's triangles.
        measure: False: trust the vertex errors (no bound; for surfaces no one sees,
            such as a slab's bottom inside the part).

    Returns:
        None, or a dict: ``rc`` ``(N, 2)`` int64 ``(row, col)`` of the kept grid
        points (row-major), ``faces`` ``(M, 3)`` int64 into ``rc`` (counter-clockwise
        with columns right, rows up), ``error`` the measured largest error (mm),
        ``threshold`` the split threshold used.

    Raises:
        GeometryError: the triangles leave a grid point of ``cells`` uncovered.
    """
    R, C = P.shape[:2]
    nr, nc = -(-(R - 1) // block) * block, -(-(C - 1) // block) * block
    C1 = nc + 1
    allowed = _pad(np.asarray(cells, bool), nr, nc, False)
    fine_p = _pad(np.zeros_like(cells, bool) if fine is None else np.asarray(fine, bool), nr, nc, False)

    def grid(a):
        return _pad(np.nan_to_num(np.asarray(a, np.float64)), nr + 1, C1)

    Pp, Np = grid(P), grid(N)
    hs = [grid(h) for h in heights]
    F = {"P": Pp, "N": Np, "h": hs, "V": [Pp + h[..., None] * Np for h in hs],
         "w": [1.0] * len(hs) if weights is None else [float(w) for w in weights]}
    err = _vertex_errors(F, allowed, fine_p, block)
    grid_tris = 2 * int(np.count_nonzero(cells))
    need = np.zeros((nr + 1, C1), bool)
    for dr in (0, 1):
        for dc in (0, 1):
            need[dr : nr + dr, dc : nc + dc] |= allowed
    threshold = float(tolerance)
    for _ in range(6):  # lower the threshold until the measured error is within the tolerance
        tri = rtin_triangles(err, threshold, block)
        cr = np.minimum((tri // C1).sum(axis=1) // 3, nr - 1)  # the cell of the centroid:
        cc = np.minimum((tri % C1).sum(axis=1) // 3, nc - 1)  # each leaf lies in one square
        tri = tri[allowed[cr, cc]]
        if len(tri) > max_fraction * grid_tris:
            return None
        worst, covered = grid_error(F, tri) if measure else (float("nan"), need)
        if (need & ~covered).any():
            raise GeometryError(f"the lean mesh leaves {int((need & ~covered).sum())} grid points uncovered (a texcad bug)")
        if worst <= tolerance or not measure:
            mark = np.zeros((nr + 1) * C1, bool)
            mark[tri.ravel()] = True
            used = np.flatnonzero(mark)  # row-major
            index = np.cumsum(mark) - 1
            rc = np.stack([used // C1, used % C1], axis=1)
            return {"rc": rc, "faces": index[tri], "error": worst, "threshold": threshold}
        threshold *= 0.7
    return None
