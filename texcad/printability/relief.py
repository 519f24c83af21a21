"""The overhang limiter for a displaced mesh (a texture as vertex displacements).

A mesh textured by displacing its vertices ``p_i`` along their normals ``n_i`` by
``d_i`` mm (:mod:`texcad.pipeline.mesh`) prints without support for the build
directions ``D`` when no displaced face overhangs: ``-n_f . d <= cos(alpha_crit)``
for every displaced face ``f`` and every ``d`` in ``D`` (paper, section 2.1.3; the
faces of the undisplaced surface are left out of the region beforehand when they
overhang themselves). :func:`limit_relief` lowers the displacements where a face
breaks that, and also where a face would fold over (its displaced normal turned by
90 degrees or more from its undisplaced one: the relief is deeper than the local
curvature allows, e.g. an engraving into a thin convex edge): each round finds, for
every offending face, the largest factor ``s in [0, 1]`` on the displacement of the
corner that makes it steep (the highest corner along the build direction when it is
raised, the lowest when it is sunk: moving that one towards the surface lowers the
face's slope without steepening the faces below, so the fix runs up a wall as one
wave instead of digging pits; all three corners for a fold) that makes it pass (12
bisection steps; ``s = 0`` is the undisplaced corner), and every vertex takes the
smallest factor of its offending faces (times ``0.98 shrink^(round // 10)``, so that it
converges where neighbours keep disturbing each other); after ``rounds`` rounds what
still offends is set to 0. Only faces next to a changed vertex are looked at again.
On ``benchmarks/bench_mesh.py``'s 5.5 M faces this lowers 44 600 vertices and removes
8.7 mm3 of relief, where lowering all three corners lowered 2 M and zeroed 1 M.
The first test of every face is made on the displaced vertices (one position per
vertex, not per corner); later rounds look only at the faces next to a change. Every
test is made on the positions as the writers store them: float32 (STL) and float32
rounded to 0.1 um (3MF), since a face of 0.01 mm turns by half a degree when rounded.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..solid.subdivide import cross, rows
from .overhang import build_directions, check_critical_angle

__all__ = ["ReliefLimit", "limit_relief"]


@dataclass(frozen=True)
class ReliefLimit:
    """What :func:`limit_relief` changed.

    Attributes:
        lowered: vertices whose displacement was lowered.
        zeroed: vertices set back on the surface.
        overhang_faces: faces that overhung before limiting.
        folded_faces: faces that folded over before limiting.
        removed_mm3: estimated relief volume removed, ``sum |d - d'| A_i`` (mm^3,
            ``A_i`` a third of the area of the faces around vertex ``i``).
    """

    lowered: int
    zeroed: int
    overhang_faces: int
    folded_faces: int
    removed_mm3: float


def _bad(v, f, n0, dirs, cos_limit):
    p = rows(v, f)
    n = cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.linalg.norm(n, axis=1)
    n = n / np.maximum(ln, 1e-300)[:, None]
    fold = ((n * n0).sum(1) <= 0.0) | (ln <= 1e-300)
    over = np.zeros(len(f), dtype=bool) if dirs is None else np.any(-(n @ dirs.T) > cos_limit, axis=1)
    return over, fold


def _as_written(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions as the writers store them: float32 (STL) and float32 rounded to
    0.1 um (3MF's ``%.4f``). A face of 0.01 mm turns by half a degree when rounded,
    more than the limiter's margin: both must pass."""
    p32 = p.astype(np.float32).astype(np.float64)
    return p32, np.round(p32, 4)


def _offending(ctx, idx, dd):
    """Overhang and fold flags of the faces ``f[idx]`` with displacements ``dd``."""
    v0, nrm, f, n0, dirs, cos_limit = ctx
    fi = f[idx]
    tri = np.arange(3 * len(idx)).reshape(-1, 3)
    flags = [_bad(vv.reshape(-1, 3), tri, n0[idx], dirs, cos_limit) for vv in _as_written(rows(v0, fi) + rows(nrm, fi) * dd[..., None])]
    return flags[0][0] | flags[1][0], flags[0][1] | flags[1][1]


def _largest_factor(ctx, bad, base, mask):
    """Per offending face: the largest factor s in [0, 1] on the displacements of its
    corners in ``mask`` ``(F, 3)`` (the others kept) that makes it pass (12 bisection
    steps); 0 if even s = 0 does not."""
    lo, hi = np.zeros(len(bad)), np.ones(len(bad))
    keep = 1.0 - mask
    for _ in range(12):  # per bisection step, all offending faces at once
        mid = 0.5 * (lo + hi)
        o, fo = _offending(ctx, bad, base * (keep + mask * mid[:, None]))
        ok = ~(o | fo)
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return lo


def _corner_to_lower(ctx, bad, over, base):
    """``(F, 3)`` mask of the corner whose displacement, moved towards 0, makes an
    overhanging face steep no more: its highest corner along the build direction
    it overhangs most for when that one is raised (``d > 0``), else its lowest when that
    one is sunk (``d < 0``); all three corners for a fold or when neither applies."""
    v0, nrm, f, n0, dirs, cos_limit = ctx
    mask = np.ones(base.shape)
    if dirs is None or not over.any():
        return mask
    k = np.flatnonzero(over)
    fi = f[bad[k]]
    worst = dirs[np.argmax(n0[bad[k]] @ -dirs.T, axis=1)]  # (K, 3)
    h = (v0[fi] * worst[:, None, :]).sum(2)
    top, bot = np.argmax(h, axis=1), np.argmin(h, axis=1)
    ar = np.arange(len(k))
    up, down = base[k, top] > 0, base[k, bot] < 0
    pick = np.where(up, top, bot)
    one = up | down
    m = np.zeros((len(k), 3))
    m[ar[one], pick[one]] = 1.0
    m[~one] = 1.0
    mask[k] = m
    return mask


def _distinct(idx: np.ndarray, n: int) -> np.ndarray:
    """``np.unique(idx)`` for indices in ``0..n-1``, by a mask (no hashing or sorting)."""
    mark = np.zeros(n, dtype=bool)
    mark[idx] = True
    return np.flatnonzero(mark)


def _faces_at(f: np.ndarray, n: int):
    """Vertex -> face incidence: ``faces_of(verts)`` gives the faces (indices into
    ``f``) at any of ``verts``, sorted and unique, in time proportional to the answer."""
    corner = f.ravel()
    order = np.argsort(corner, kind="stable") // 3
    start = np.concatenate([[0], np.cumsum(np.bincount(corner, minlength=n))])

    def faces_of(verts: np.ndarray) -> np.ndarray:
        lo, cnt = start[verts], start[verts + 1] - start[verts]
        total = int(cnt.sum())
        offs = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        return _distinct(order[np.repeat(lo, cnt) + offs], len(f))

    return faces_of


def _all_offending(ctx, out):
    """Overhang and fold flags of every face, from one displaced position per vertex."""
    v0, nrm, f, n0, dirs, cos_limit = ctx
    used = _distinct(f.ravel(), len(v0))
    pos = np.zeros((len(v0), 3))
    pos[used] = v0[used] + nrm[used] * out[used, None]
    flags = [_bad(p, f, n0, dirs, cos_limit) for p in _as_written(pos)]
    return flags[0][0] | flags[1][0], flags[0][1] | flags[1][1]


def _rounds(ctx, out, rounds, shrink, first):
    """The limiter's rounds, in place on ``out``; ``first`` the flags of every face."""
    v0, f = ctx[0], ctx[2]
    faces_of = _faces_at(f, len(v0))
    idx = np.arange(len(f))
    for r in range(rounds + len(v0) + 1):  # per round; only faces near a change are looked at
        if not len(idx):
            break
        dd = out[f[idx]]
        over, fold = _offending(ctx, idx, dd) if r else first
        bad = idx[(over | fold) & (dd != 0).any(axis=1)]  # an undisplaced face is as it was
        if not len(bad):
            break
        fb = f[bad]
        if r < rounds:  # every vertex takes the smallest factor of its offending faces
            sel = ((over | fold) & (dd != 0).any(axis=1))
            base = out[fb]
            mask = _corner_to_lower(ctx, bad, (over & ~fold)[sel], base)
            lo = _largest_factor(ctx, bad, base, mask)
            fac = np.ones(len(v0))
            s = 0.98 * lo * shrink ** (r // 10)
            for k in range(3):  # per corner
                np.minimum.at(fac, fb[:, k], np.where(mask[:, k] > 0, s, 1.0))
            verts = np.flatnonzero(fac < 1.0)
            out[verts] *= fac[verts]
        else:
            verts = _distinct(fb.ravel(), len(v0))
            out[verts] = 0.0
        idx = faces_of(verts)


def limit_relief(
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray,
    d: np.ndarray,
    *,
    build_dir=None,
    critical_angle: float = 45.0,
    margin: float = 1.0,
    shrink: float = 0.7,
    rounds: int = 25,
) -> tuple[np.ndarray, ReliefLimit]:
    """Lower vertex displacements so that no displaced face overhangs or folds.

    Args:
        vertices: ``(N, 3)`` undisplaced positions, mm.
        faces: ``(M, 3)`` vertex indices.
        normals: ``(N, 3)`` unit displacement directions.
        d: ``(N,)`` displacements along ``normals``, mm (0 off the texture).
        build_dir: ``(3,)`` or ``(K, 3)`` build direction(s), or None (fold check
            only).
        critical_angle: degrees between face and build plate, 0..90.
        margin: degrees added to ``critical_angle`` for the limit, so that the
            result passes :func:`texcad.check` after rounding to float32.
        shrink: extra factor per five rounds on the offending faces' displacements.
        rounds: rounds of shrinking before what still offends is set to 0.

    Returns:
        ``(d', report)`` with ``|d'_i| <= |d_i|`` and the same signs.
    """
    v0 = np.asarray(vertices, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    d0 = np.asarray(d, dtype=np.float64)
    out = d0.copy()
    dirs = None if build_dir is None else build_directions(build_dir)
    cos_limit = 0.0
    if dirs is not None:
        cos_limit = float(np.cos(np.radians(min(89.9, check_critical_angle(critical_angle) + margin))))
    live = np.flatnonzero((out[faces] != 0).any(axis=1))
    f = faces[live]
    p0 = rows(v0, f)
    n0 = cross(p0[:, 1] - p0[:, 0], p0[:, 2] - p0[:, 0])
    n0 /= np.maximum(np.linalg.norm(n0, axis=1), 1e-300)[:, None]
    ctx = (v0, nrm, f, n0, dirs, cos_limit)
    over, fold = _all_offending(ctx, out)
    first = (int(over.sum()), int(fold.sum()))
    _rounds(ctx, out, rounds, shrink, (over, fold))
    low = out != d0
    near = faces[low[faces].any(axis=1)]  # the faces at a lowered vertex
    area = np.zeros(len(v0))
    p = v0[near]
    fa = 0.5 * np.linalg.norm(cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    for k in range(3):  # per corner
        area += np.bincount(near[:, k], weights=fa / 3.0, minlength=len(v0))
    rep = ReliefLimit(
        lowered=int(low.sum()),
        zeroed=int((low & (out == 0)).sum()),
        overhang_faces=first[0] if first else 0,
        folded_faces=first[1] if first else 0,
        removed_mm3=float((np.abs(d0 - out) * area).sum()),
    )
    return out, rep
