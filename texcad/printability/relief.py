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


_BLOCK = 1 << 15  # faces per block of the first test: its temporaries stay in the cache


def _unit(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals ``(F, 3)`` and their lengths ``(F,)`` of the faces with corners ``p``
    ``(F, 3, 3)``: the operations of ``cross`` and ``np.linalg.norm`` (which sums the
    squares left to right) in their order, so the same bits."""
    n = cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    ln = np.sqrt((n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1]) + n[:, 2] * n[:, 2])
    n /= np.maximum(ln, 1e-300)[:, None]
    return n, ln


def _steep(n: np.ndarray, dirs, cos_limit: float) -> np.ndarray:
    """``any(-n . d > cos_limit)`` over the build directions ``d`` (all False without).
    An axis direction (one component +-1, the others 0) takes that component alone:
    ``n @ d`` is exactly that (the zeros add nothing), without a BLAS call."""
    if dirs is None:
        return np.zeros(len(n), dtype=bool)
    if not ((np.count_nonzero(dirs, axis=1) == 1) & (np.abs(dirs).max(axis=1) == 1.0)).all():
        return np.any(-(n @ dirs.T) > cos_limit, axis=1)
    out = np.zeros(len(n), dtype=bool)
    for d in dirs:  # per build direction
        k = int(np.argmax(np.abs(d)))
        out |= (n[:, k] > cos_limit) if d[k] < 0 else (-n[:, k] > cos_limit)
    return out


def _bad(p: np.ndarray, n0: np.ndarray, dirs, cos_limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Overhang and fold flags of faces with corners ``p`` ``(F, 3, 3)`` mm and
    undisplaced unit normals ``n0`` ``(F, 3)``."""
    n, ln = _unit(p)
    fold = ((n[:, 0] * n0[:, 0] + n[:, 1] * n0[:, 1]) + n[:, 2] * n0[:, 2] <= 0.0) | (ln <= 1e-300)
    return _steep(n, dirs, cos_limit), fold


def _as_written(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions as the writers store them: float32 (STL) and float32 rounded to
    0.1 um (3MF's ``%.4f``). A face of 0.01 mm turns by half a degree when rounded,
    more than the limiter's margin: both must pass."""
    p32 = p.astype(np.float32).astype(np.float64)
    return p32, np.round(p32, 4)


def _test(p: np.ndarray, n0: np.ndarray, dirs, cos_limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Overhang and fold flags of faces with displaced corners ``p`` ``(F, 3, 3)``, as
    either writer stores them."""
    (o1, f1), (o2, f2) = (_bad(q, n0, dirs, cos_limit) for q in _as_written(p))
    return o1 | o2, f1 | f2


def _offending(ctx, idx, dd):
    """Overhang and fold flags of the faces ``f[idx]`` with displacements ``dd``."""
    v0, nrm, f, n0, dirs, cos_limit = ctx
    fi = f[idx]
    return _test(rows(v0, fi) + rows(nrm, fi) * dd[..., None], n0[idx], dirs, cos_limit)


def _largest_factor(ctx, bad, base, mask):
    """Per offending face: the largest factor s in [0, 1] on the displacements of its
    corners in ``mask`` ``(F, 3)`` (the others kept) that makes it pass (12 bisection
    steps); 0 if even s = 0 does not."""
    v0, nrm, f, n0, dirs, cos_limit = ctx
    fi = f[bad]
    p0, dn, nb = rows(v0, fi), rows(nrm, fi), n0[bad]
    lo, hi = np.zeros(len(bad)), np.ones(len(bad))
    keep = 1.0 - mask
    for _ in range(12):  # per bisection step, all offending faces at once
        mid = 0.5 * (lo + hi)
        o, fo = _test(p0 + dn * (base * (keep + mask * mid[:, None]))[..., None], nb, dirs, cos_limit)
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


def _faces_at(f: np.ndarray, n: int):
    """Vertex -> face incidence: ``faces_of(verts)`` gives the faces (indices into
    ``f``) at any of ``verts``, sorted and unique, in time proportional to the answer.
    One sort of ``vertex << bits | face`` keys (a plain sort, 4 times faster than a
    stable argsort of the vertices)."""
    bits = max(1, int(len(f)).bit_length())
    key = np.sort((f.astype(np.int64) << bits | np.arange(len(f))[:, None]).ravel())
    start = np.concatenate([[0], np.cumsum(np.bincount(f.ravel(), minlength=n))])
    low = (1 << bits) - 1

    def faces_of(verts: np.ndarray) -> np.ndarray:
        lo, cnt = start[verts], start[verts + 1] - start[verts]
        total = int(cnt.sum())
        offs = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
        return np.unique(key[np.repeat(lo, cnt) + offs] & low)

    return faces_of


def _first(v0, nrm, f, out, dirs, cos_limit):
    """Unit normals ``n0`` ``(F, 3)`` of the undisplaced faces, and the overhang and
    fold flags of every face from one displaced position per vertex, block by block."""
    n0 = np.empty((len(f), 3))
    over, fold = np.empty(len(f), dtype=bool), np.empty(len(f), dtype=bool)
    pos = _as_written(v0 + nrm * out[:, None])
    for a in range(0, len(f), _BLOCK):  # per block of faces
        fb = f[a:a + _BLOCK]
        n0[a:a + _BLOCK] = _unit(rows(v0, fb))[0]
        (o1, f1), (o2, f2) = (_bad(rows(p, fb), n0[a:a + _BLOCK], dirs, cos_limit) for p in pos)
        over[a:a + _BLOCK], fold[a:a + _BLOCK] = o1 | o2, f1 | f2
    return n0, over, fold


def _lower(ctx, out, bad, over, scale, fac):
    """One shrinking round on the offending faces ``bad``: every vertex takes the
    smallest factor of its offending faces (times ``scale``); returns the lowered
    vertices. ``fac`` ``(N,)`` is all ones before and after."""
    fb = ctx[2][bad]
    base = out[fb]
    mask = _corner_to_lower(ctx, bad, over, base)
    s = 0.98 * _largest_factor(ctx, bad, base, mask) * scale
    np.minimum.at(fac, fb.ravel(), np.where(mask > 0, s[:, None], 1.0).ravel())
    touched = np.unique(fb)
    verts = touched[fac[touched] < 1.0]
    out[verts] *= fac[verts]
    fac[touched] = 1.0
    return verts


def _rounds(ctx, out, rounds, shrink, first, faces_of):
    """The limiter's rounds, in place on ``out``; ``first`` the flags of every face,
    ``faces_of`` from :func:`_faces_at`."""
    v0, f = ctx[0], ctx[2]
    fac = np.ones(len(v0))
    over, fold = first
    idx = np.flatnonzero(over | fold)  # round 0: every face was tested, these offend
    over, fold = over[idx], fold[idx]
    for r in range(rounds + len(v0) + 1):  # per round; only faces near a change are looked at
        if not len(idx):
            break
        dd = out[f[idx]]
        if r:
            over, fold = _offending(ctx, idx, dd)
        sel = (over | fold) & (dd != 0).any(axis=1)  # an undisplaced face is as it was
        bad = idx[sel]
        if not len(bad):
            break
        if r < rounds:
            verts = _lower(ctx, out, bad, (over & ~fold)[sel], shrink ** (r // 10), fac)
        else:
            verts = np.unique(f[bad])
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
    nz = (out != 0)[faces]
    live = np.flatnonzero(nz[:, 0] | nz[:, 1] | nz[:, 2])
    f = faces[live]
    n0, over, fold = _first(v0, nrm, f, out, dirs, cos_limit)
    faces_of = _faces_at(f, len(v0))
    first = (int(over.sum()), int(fold.sum()))
    _rounds((v0, nrm, f, n0, dirs, cos_limit), out, rounds, shrink, (over, fold), faces_of)
    low = out != d0
    near = f[faces_of(np.flatnonzero(low))]  # the faces at a lowered vertex, in order
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
