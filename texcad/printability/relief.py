"""The overhang limiter for a displaced mesh (a texture as vertex displacements).

A mesh textured by displacing its vertices ``p_i`` along their normals ``n_i`` by
``d_i`` mm (:mod:`texcad.targets.mesh`) prints without support for the build
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
On ``benchmarks/bench_mesh.py`` (983 620 faces, 19 349 of them overhanging at first)
the shrinking settles within 60 rounds (the default): 32 665 vertices lowered, 1 874
of them to 0, 287 mm3 of the 11 024 mm3 relief removed. With 25 rounds 24 faces still
offended then, and setting them to 0 made their neighbours offend in turn: 154 more
rounds zeroed 30 642 more vertices and removed 743 mm3 more.
Then the ridges (``ridges=True``, with build directions): a convex edge whose
contour corner moves outwards as the layers rise (its horizontal run points between
its two faces' horizontal normals) must itself rise at the critical angle or more,
however steep its faces (a pyramid's edges are less steep than its faces), or a
slicer's layer test supports it (:func:`_steep_ridges`). The end that is raised (or
sunk) is shrunk by 0.8 per round (to 0 after ``rounds``), and the faces around it go
through the facet rounds again, until no such edge is left. On the benchmark this
lowers 2 395 more vertices (9 mm3), and PrusaSlicer's support under the part went
from 35.9 m to 0.
The first test of every face is made on the displaced vertices (one position per
vertex, not per corner); later rounds look only at the faces next to a change. Every
test is made on the positions as the writers store them: float32 (STL) and float32
rounded to 0.1 um (3MF), since a face of 0.01 mm turns by half a degree when rounded.

Speed: face data is laid out coordinate first (every operation runs over contiguous
rows of faces), both writers' positions go through each operation at once, faces are
taken in blocks of 8192 (the temporaries stay in the cache), the bisection runs block
by block and the vertex-to-face incidence is one sort of keys (``_THREADS`` puts the
first test's blocks on two threads). Every face's test is the same sequence of float
operations whatever the block or thread (those of ``cross`` and ``np.linalg.norm``,
in their order), so the result does not depend on them: the same bytes as the plain
version's on the benchmark, the mesh tests and random spheres. On the benchmark it
takes 0.25-0.30 s CPU (0.26-0.40 s wall, load 2.3-3.3) where the plain version took
1.1-1.3 s CPU in the same runs.
"""

from __future__ import annotations

import itertools
from concurrent.futures import ThreadPoolExecutor
from contextlib import nullcontext
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..solid.subdivide import cross, rows
from ..util import argsort_ints, beside, threads
from .overhang import build_directions, check_critical_angle
from .rule import slicer_margin

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
        steep_ridges: convex edges that rose less steeply than the critical angle
            after the facets were limited (``limit_relief(ridges=True)``).
        directions: ``(K, 3)`` float64 unit build directions the relief was limited
            for, or None (fold check only): what :func:`texcad.io.export` stands
            the part on the bed by.
    """

    lowered: int
    zeroed: int
    overhang_faces: int
    folded_faces: int
    removed_mm3: float
    steep_ridges: int = 0
    directions: "np.ndarray | None" = field(default=None, repr=False, compare=False)


# The first test's blocks and the incidence on two threads (numpy releases the GIL in
# its loops). Off: on the shared 2-core machine (loads 1.5-2.4, 3 runs each) the limiter
# took 0.35-0.50 s wall with two threads and 0.28-0.40 s with one (a thread waits for the
# GIL while the other is preempted); the bytes are the same either way
# (tests/printability/test_relief.py).
_THREADS = False
_BLOCK = 8192  # faces per block of the first test: its temporaries stay in the cache

# Face data is laid out coordinate first: corners ``(..., 3, 3, F)`` (coordinate,
# corner, face), normals ``(..., 3, F)``, so that every operation runs over contiguous
# rows of faces (4 times faster than over ``(F, 3)`` rows of 3), and both writers'
# positions go through each operation at once (a leading axis of 2); the operations
# are those of ``cross`` and ``np.linalg.norm`` in their order, so the bits are the same.


def _unit(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals ``(..., 3, F)`` and their lengths ``(..., F)`` of the faces with
    corners ``p`` ``(..., 3, 3, F)`` mm. The edges' coordinates are stored as x, y, z,
    x, y so that the cross product is two products of slices and one difference:
    component by component the products and differences of :func:`cross`, and
    ``np.linalg.norm`` sums the squares left to right, as here."""
    e = np.empty(p.shape[:-3] + (5, 2, p.shape[-1]))
    np.subtract(p[..., 1:, :], p[..., :1, :], out=e[..., :3, :, :])  # corners 1 and 2 minus 0
    e[..., 3:, :, :] = e[..., :2, :, :]
    a, b = e[..., 0, :], e[..., 1, :]
    n = a[..., 1:4, :] * b[..., 2:5, :]
    n -= a[..., 2:5, :] * b[..., 1:4, :]
    sq = n * n
    ln = np.sqrt((sq[..., 0, :] + sq[..., 1, :]) + sq[..., 2, :])
    n /= np.maximum(ln, 1e-300)[..., None, :]
    return n, ln


def _folds(n: np.ndarray, ln: np.ndarray, n0: np.ndarray) -> np.ndarray:
    """Faces turned by 90 degrees or more from ``n0`` ``(3, F)`` (or degenerate), from
    their unit normals ``n`` ``(..., 3, F)`` and lengths ``ln``."""
    c = n * n0
    return ((c[..., 0, :] + c[..., 1, :]) + c[..., 2, :] <= 0.0) | (ln <= 1e-300)


def _directions(dirs) -> tuple:
    """The build directions as :func:`_steep` takes them: ``(k, s)`` for an axis
    direction ``s e_k`` (one component +-1, the others 0: ``n . d`` is exactly ``s n_k``,
    the zeros add nothing), else ``(None, d)``."""
    plan = []
    for d in () if dirs is None else dirs:  # per build direction
        k = int(np.argmax(np.abs(d)))
        axis = np.count_nonzero(d) == 1 and abs(d[k]) == 1.0
        plan.append((k, float(d[k])) if axis else (None, tuple(float(c) for c in d)))
    return tuple(plan)


def _steep(n: np.ndarray, plan: tuple, cos_limit: float) -> np.ndarray:
    """``any(-n . d > cos_limit)`` over the build directions (all False without), face
    by face in a fixed order (no BLAS call, whose last bit can depend on the batch);
    ``-x > c`` is tested as ``x < -c``, the same for every float."""
    out = np.zeros(n.shape[:-2] + n.shape[-1:], dtype=bool)
    for k, d in plan:  # per build direction
        if k is None:
            out |= (n[..., 0, :] * d[0] + n[..., 1, :] * d[1]) + n[..., 2, :] * d[2] < -cos_limit
        else:
            out |= (n[..., k, :] > cos_limit) if d < 0 else (n[..., k, :] < -cos_limit)
    return out


def _as_written(p: np.ndarray) -> np.ndarray:
    """Positions ``(2, ...)`` as the writers store them: float32 (STL) and float32
    rounded to 0.1 um (3MF's ``%.4f``). A face of 0.01 mm turns by half a degree when
    rounded, more than the limiter's margin: both must pass."""
    w = np.empty((2,) + p.shape)
    w[0] = p.astype(np.float32)
    np.round(w[0], 4, out=w[1])
    return w


def _test(p: np.ndarray, n0: np.ndarray, plan: tuple, cos_limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Overhang and fold flags ``(F,)`` of faces with displaced corners ``p``
    ``(3, 3, F)`` mm (either writer's positions) and undisplaced unit normals ``n0``
    ``(3, F)``."""
    n, ln = _unit(_as_written(p))
    fold = _folds(n, ln, n0)
    over = _steep(n, plan, cos_limit)
    return over[0] | over[1], fold[0] | fold[1]


class _Ctx(NamedTuple):
    """What every step reads: ``v0``, ``nrm`` ``(3, N)`` undisplaced positions (mm) and
    displacement directions, coordinate first; ``f`` ``(3, M)`` faces; ``dirs`` the build
    directions ``(K, 3)`` or None, ``plan`` the same for :func:`_steep`; ``cos_limit``;
    ``pool`` 2 threads or None."""

    v0: np.ndarray
    nrm: np.ndarray
    f: np.ndarray
    dirs: np.ndarray | None
    plan: tuple
    cos_limit: float
    pool: ThreadPoolExecutor | None


def _blocks(ctx: _Ctx, n: int, fn) -> None:
    """``fn(b)`` for the slices ``b`` of ``_BLOCK`` faces of ``n``, on the pool's two
    threads when there are several (numpy releases the GIL in its loops; each block
    writes only its own slice, so the order does not change the result)."""
    blocks = [slice(a, a + _BLOCK) for a in range(0, n, _BLOCK)]
    if ctx.pool is None or len(blocks) < 2:
        for b in blocks:  # per block of faces
            fn(b)
    else:
        for _ in ctx.pool.map(fn, blocks):  # per block of faces (re-raises errors)
            pass


def _corners(ctx: _Ctx, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Undisplaced corners and displacement directions ``(3, 3, F)`` of the faces with
    vertex indices ``t`` ``(3, F)``."""
    return np.take(ctx.v0, t, axis=1), np.take(ctx.nrm, t, axis=1)


def _offending(ctx, t, dd):
    """Overhang and fold flags of the faces with vertices ``t`` ``(3, F)`` and corner
    displacements ``dd`` ``(3, F)``, block by block."""
    over, fold = np.empty(t.shape[1], dtype=bool), np.empty(t.shape[1], dtype=bool)

    def block(b: slice) -> None:
        p0, dn = _corners(ctx, t[:, b])
        over[b], fold[b] = _test(p0 + dn * dd[:, b], _unit(p0)[0], ctx.plan, ctx.cos_limit)

    _blocks(ctx, t.shape[1], block)
    return over, fold


def _largest_factor(ctx, p0, dn, n0, base, mask):
    """Per offending face (corners ``p0``, directions ``dn``, normals ``n0``): the largest
    factor s in [0, 1] on the displacements ``base`` ``(3, F)`` of its corners in
    ``mask`` (the others kept) that makes it pass (12 bisection steps); 0 if even s = 0
    does not. Block by block: a block's arrays stay in the cache through its steps."""
    lo = np.zeros(n0.shape[1])

    def block(b: slice) -> None:
        lo[b] = _bisect(ctx, p0[..., b], dn[..., b], n0[:, b], base[:, b], mask[:, b])

    _blocks(ctx, len(lo), block)
    return lo


def _bisect(ctx, p0, dn, n0, base, mask):
    """:func:`_largest_factor` on one block."""
    lo, hi = np.zeros(n0.shape[1]), np.ones(n0.shape[1])
    keep = 1.0 - mask
    for _ in range(12):  # per bisection step, all the block's faces at once
        mid = 0.5 * (lo + hi)
        o, fo = _test(p0 + dn * (base * (keep + mask * mid)), n0, ctx.plan, ctx.cos_limit)
        ok = ~(o | fo)
        lo, hi = np.where(ok, mid, lo), np.where(ok, hi, mid)
    return lo


def _corner_to_lower(dirs, p0, n0, over, base):
    """``(3, F)`` mask of the corner whose displacement, moved towards 0, makes an
    overhanging face steep no more: its highest corner along the build direction
    it overhangs most for when that one is raised (``d > 0``), else its lowest when that
    one is sunk (``d < 0``); all three corners for a fold or when neither applies."""
    mask = np.ones(base.shape)
    if dirs is None or not over.any():
        return mask
    k = np.flatnonzero(over)
    w = dirs[np.argmax(np.ascontiguousarray(n0[:, k].T) @ -dirs.T, axis=1)].T  # (3, K)
    q = p0[:, :, k]
    h = (q[0] * w[0] + q[1] * w[1]) + q[2] * w[2]  # (corner, K)
    top, bot = np.argmax(h, axis=0), np.argmin(h, axis=0)
    ar = np.arange(len(k))
    up, down = base[top, k] > 0, base[bot, k] < 0
    pick = np.where(up, top, bot)
    one = up | down
    m = np.zeros((3, len(k)))
    m[pick[one], ar[one]] = 1.0
    m[:, ~one] = 1.0
    mask[:, k] = m
    return mask


def _distinct(idx: np.ndarray, n: int) -> np.ndarray:
    """``np.unique(idx)`` for indices in ``0..n-1``: by a sort when there are few (20
    times faster than ``np.unique``, which hashes), by a mask of ``n`` when many."""
    if len(idx) * 8 < n:
        s = np.sort(idx)
        keep = np.empty(len(s), dtype=bool)
        keep[:1] = True
        np.not_equal(s[1:], s[:-1], out=keep[1:])
        return s[keep]
    mark = np.zeros(n, dtype=bool)
    mark[idx] = True
    return np.flatnonzero(mark)


def _faces_at(f: np.ndarray, n: int):
    """Vertex -> face incidence of the faces ``f`` ``(3, M)``: ``faces_of(verts)`` gives
    the faces (indices into ``M``) at any of ``verts``, sorted and unique, in time
    proportional to the answer. One sort of ``vertex << bits | face`` keys (a sort
    of values, 4 times faster than a stable argsort of the vertices; timsort, as a
    mesh's faces come in runs: half the time of the default sort)."""
    m = f.shape[1]
    bits = max(1, m.bit_length())
    key = f.astype(np.int64) << bits
    key |= np.arange(m)
    key = key.ravel()
    key.sort(kind="stable")
    start = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(np.bincount(f.ravel(), minlength=n), out=start[1:])
    low = (1 << bits) - 1

    def faces_of(verts: np.ndarray) -> np.ndarray:
        lo, cnt = start[verts], start[verts + 1] - start[verts]
        at = np.arange(int(cnt.sum())) + np.repeat(lo - (np.cumsum(cnt) - cnt), cnt)
        return _distinct(np.take(key, at) & low, m)

    return faces_of


def _first(ctx: _Ctx, out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Overhang and fold flags of every face with a displaced corner (the others
    False), from one displaced position per vertex, block by block."""
    over, fold = np.empty(ctx.f.shape[1], dtype=bool), np.empty(ctx.f.shape[1], dtype=bool)
    pos = _as_written(ctx.v0 + ctx.nrm * out)
    moved = out != 0

    def block(b: slice) -> None:
        t = np.ascontiguousarray(ctx.f[:, b])
        n0 = _unit(np.take(ctx.v0, t, axis=1))[0]
        n, ln = _unit(np.take(pos, t, axis=2))
        fo = _folds(n, ln, n0)
        ov = _steep(n, ctx.plan, ctx.cos_limit)
        m = moved[t]
        live = m[0] | m[1] | m[2]
        over[b], fold[b] = (ov[0] | ov[1]) & live, (fo[0] | fo[1]) & live

    _blocks(ctx, ctx.f.shape[1], block)
    return over, fold


def _lower(ctx, out, t, over, scale, fac):
    """One shrinking round on the offending faces with vertices ``t`` ``(3, F)``: every
    vertex takes the smallest factor of its offending faces (times ``scale``); returns
    the lowered vertices. ``fac`` ``(N,)`` is all ones before and after."""
    base = out[t]
    p0, dn = _corners(ctx, t)
    n0 = _unit(p0)[0]
    mask = _corner_to_lower(ctx.dirs, p0, n0, over, base)
    s = 0.98 * _largest_factor(ctx, p0, dn, n0, base, mask) * scale
    np.minimum.at(fac, t.ravel(), np.where(mask > 0, s, 1.0).ravel())
    touched = _distinct(t.ravel(), len(fac))
    verts = touched[fac[touched] < 1.0]
    out[verts] *= fac[verts]
    fac[touched] = 1.0
    return verts


def _rounds(ctx, out, rounds, shrink, first, faces_of):
    """The limiter's rounds, in place on ``out``; ``first`` the flags of every face,
    ``faces_of`` from :func:`_faces_at`."""
    f, n = ctx.f, len(out)
    fac = np.ones(n)
    over, fold = first
    idx = np.flatnonzero(over | fold)  # round 0: every face was tested, these offend
    over, fold = over[idx], fold[idx]
    for r in range(rounds + n + 1):  # per round; only faces near a change are looked at
        if not len(idx):
            break
        t = np.take(f, idx, axis=1)
        dd = out[t]
        if r:
            over, fold = _offending(ctx, t, dd)
        sel = (over | fold) & (dd != 0).any(axis=0)  # an undisplaced face is as it was
        if not sel.any():
            break
        if r < rounds:
            verts = _lower(ctx, out, t[:, sel], (over & ~fold)[sel], shrink ** (r // 10), fac)
        else:
            verts = _distinct(t[:, sel].ravel(), n)
            out[verts] = 0.0
        idx = faces_of(verts)


class _Edges(NamedTuple):
    """Each undirected edge of two faces once: ends ``a``, ``b``, its two faces
    ``f1``, ``f2`` and ``c2`` the corner of ``f2`` off the edge ``(E,)``; ``eid``
    ``(M, 3)`` each face's edges (-1: an edge of that face alone)."""

    a: np.ndarray
    b: np.ndarray
    f1: np.ndarray
    f2: np.ndarray
    c2: np.ndarray
    eid: np.ndarray


def _slot_pairs(f: np.ndarray) -> "np.ndarray | None":
    """``(E, 2)``: the two *slots* ``3 face + k`` of each edge of two faces ``f``
    ``(M, 3)``, in the order of their keys (of a closed mesh, every edge:
    :func:`texcad.solid.edge_slot_pairs`); the edges of one face (an open surface's
    border: no ridge) left out; None where an edge is in three faces or more."""
    a, b = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(a, b) * np.int64(int(f.max(initial=0)) + 1) + np.maximum(a, b)
    order = argsort_ints(key)
    same = key[order][1:] == key[order][:-1]
    if np.any(same[1:] & same[:-1]):
        return None
    at = np.flatnonzero(same)
    return np.stack([order[at], order[at + 1]], axis=1)


def _edge_table(f: np.ndarray) -> "_Edges | None":
    """:class:`_Edges` of the faces ``f`` ``(3, M)``; None where an edge is in three
    faces or more."""
    m = f.shape[1]
    pair = _slot_pairs(f.T)
    if pair is None:
        return None
    a, b, c = f.T.ravel(), f[[1, 2, 0]].T.ravel(), f[[2, 0, 1]].T.ravel()  # slot 3 face + k: corner k -> k + 1
    eid = np.full(3 * m, -1, dtype=np.int64)
    eid[pair.ravel()] = np.repeat(np.arange(len(pair)), 2)
    return _Edges(a[pair[:, 0]], b[pair[:, 0]], pair[:, 0] // 3, pair[:, 1] // 3, c[pair[:, 1]], eid.reshape(m, 3))


def _ridge_normals(p: np.ndarray, f: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit normals ``(3, F)`` of ``faces`` at positions ``p`` ``(3, N)`` (:func:`_unit`)."""
    return _unit(np.take(p, np.take(f, faces, axis=1), axis=1))[0]


def _steep_ridges(ctx: _Ctx, out: np.ndarray, tab: _Edges, sel: np.ndarray, tan_limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Of the edges ``sel``: which are *steep ridges* and the end to lower for each.

    A slicer compares each layer with the one below grown by ``h cot(alpha)``. Where a
    convex edge crosses a layer the contour has a corner, which moves per layer by
    ``h |u|`` (``u`` the edge's horizontal run per unit of height) in a direction
    between its two faces' outward (horizontal) normals; such a corner outruns the
    grown layer below unless the edge itself rises at ``alpha`` or more, however
    steep its faces are (a pyramid's edges are less steep than its faces: a diamond
    knurl limited facet by facet still got 43 m of support in PrusaSlicer on a 24 mm
    cylinder). Edges whose ends are both undisplaced are the part's own (left out
    before anything is computed for them).
    """
    p = ctx.v0 + ctx.nrm * out
    bad, end = np.zeros(len(sel), dtype=bool), tab.b[sel]
    live = np.flatnonzero((out[tab.a[sel]] != 0) | (out[tab.b[sel]] != 0))
    a, b = tab.a[sel[live]], tab.b[sel[live]]
    e = np.take(p, b, axis=1) - np.take(p, a, axis=1)
    ee = (e * e).sum(axis=0)
    flat = np.zeros(len(a), dtype=bool)
    for d in ctx.dirs:  # per build direction: rises less steeply than the limit (cheap test first)
        ez = d @ e
        flat |= (ee - ez * ez) * (tan_limit * tan_limit) > ez * ez
    cand = np.flatnonzero(flat)
    if len(cand):
        bad[live[cand]], end[live[cand]] = _ridge_test(ctx, p, out, tab, sel[live[cand]], e[:, cand], tan_limit)
    return bad, end


def _face_normals_of(p: np.ndarray, f: np.ndarray, f1: np.ndarray, f2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals ``(3, E)`` of the faces ``f1`` and ``f2`` at positions ``p``
    (:func:`_unit`, face by face, so the same bits either way): of every face once when
    they name most faces, else of each named face."""
    if 2 * len(f1) >= f.shape[1]:
        n = _unit(np.take(p, f, axis=1))[0]
        return np.take(n, f1, axis=1), np.take(n, f2, axis=1)
    return _ridge_normals(p, f, f1), _ridge_normals(p, f, f2)


def _ridge_test(ctx: _Ctx, p: np.ndarray, out: np.ndarray, tab: _Edges, sel: np.ndarray, e: np.ndarray, tan_limit: float):
    """:func:`_steep_ridges` on candidate edges ``sel`` with vectors ``e`` ``(3, E)``
    (positions ``p`` ``(3, N)``): convex, and their corner moving between the faces'
    outward normals. For an axis build direction ``s e_k`` the horizontal parts are the
    other two coordinates and ``d . (x X y)`` is ``s`` times the k-th component of the
    cross product: the same numbers, without the zero terms."""
    a, b = tab.a[sel], tab.b[sel]
    n1, n2 = _face_normals_of(p, ctx.f, tab.f1[sel], tab.f2[sel])
    convex = ((np.take(p, tab.c2[sel], axis=1) - np.take(p, a, axis=1)) * n1).sum(axis=0) < 0
    bad = np.zeros(len(a), dtype=bool)
    upper = b.copy()
    for d, (k, sk) in zip(ctx.dirs, ctx.plan):  # per build direction
        if k is not None:  # s e_k: ez = s e_k exactly; the products below all carry s twice or not at all
            ez = e[k] * sk
            sg = np.where(ez < 0, -1.0, 1.0)
            i, j = (k + 1) % 3, (k + 2) % 3  # the cross product's k-th component: x_i y_j - x_j y_i
            ui, uj = e[i] * sg, e[j] * sg
            s12 = n1[i] * n2[j] - n1[j] * n2[i]
            s1u = n1[i] * uj - n1[j] * ui
            su2 = ui * n2[j] - uj * n2[i]
            lo_, hi_ = min(i, j), max(i, j)  # sums of squares in coordinate order
            h11 = n1[lo_] * n1[lo_] + n1[hi_] * n1[hi_]
            h22 = n2[lo_] * n2[lo_] + n2[hi_] * n2[hi_]
            uu = (e[lo_] * sg) ** 2 + (e[hi_] * sg) ** 2
        else:
            ez = d @ e
            u = (e - np.outer(d, ez)) * np.where(ez < 0, -1.0, 1.0)
            h1, h2 = n1 - np.outer(d, d @ n1), n2 - np.outer(d, d @ n2)
            s12, s1u, su2 = (d @ np.cross(h1, h2, axis=0)), (d @ np.cross(h1, u, axis=0)), (d @ np.cross(u, h2, axis=0))
            h11, h22, uu = (h1 * h1).sum(axis=0), (h2 * h2).sum(axis=0), (u * u).sum(axis=0)
        up = np.where(ez < 0, a, b)
        big = np.abs(s12) > 1e-9 * np.sqrt(h11 * h22)  # not (anti)parallel
        inside = big & (s1u * s12 >= 0) & (su2 * s12 >= 0)
        flat = np.sqrt(uu) * tan_limit > np.abs(ez)
        hit = convex & inside & flat
        upper = np.where(hit & ~bad, up, upper)
        bad |= hit
    low = np.where(upper == a, b, a)
    # as for faces: the upper end when it is raised, the lower when it is sunk (moving
    # either towards the surface steepens the edge), else the end that is displaced
    end = np.where(out[upper] > 0, upper, np.where(out[low] < 0, low, np.where(out[upper] != 0, upper, low)))
    return bad, end


def _ridges(ctx: _Ctx, out: np.ndarray, faces_of, rounds: int, shrink: float, tan_limit: float, tab: "_Edges | None") -> int:
    """Lower the displacements until no steep ridge is left (:func:`_steep_ridges`),
    each round shrinking the offending ridges' ends by 0.8 (after ``rounds`` rounds:
    to 0) and then running the facet rounds (``shrink``) on the faces around them
    again; only edges near a change are looked at again. Every steep ridge has a
    displaced end, and from round ``rounds`` on one is set to 0 each round, so the
    loop ends with none left. Returns the steep ridges found first."""
    n = len(out)
    if tab is None:  # an edge in three faces or more
        return 0
    sel = np.arange(len(tab.a))
    found = None
    for r in itertools.count():  # per round
        bad, end = _steep_ridges(ctx, out, tab, sel, tan_limit)
        found = int(bad.sum()) if found is None else found
        if not bad.any():
            break
        verts = _distinct(end[bad], n)
        before = out.copy()
        out[verts] = out[verts] * 0.8 if r < rounds else 0.0
        idx = faces_of(verts)
        t = np.take(ctx.f, idx, axis=1)
        over, fold = np.zeros(ctx.f.shape[1], dtype=bool), np.zeros(ctx.f.shape[1], dtype=bool)
        over[idx], fold[idx] = _offending(ctx, t, out[t])
        _rounds(ctx, out, rounds, shrink, (over, fold), faces_of)
        near = tab.eid[faces_of(np.flatnonzero(out != before))].ravel()
        sel = _distinct(near[near >= 0], len(tab.a))
    return found or 0


def limit_relief(
    vertices: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray,
    d: np.ndarray,
    *,
    build_dir=None,
    critical_angle: float = 45.0,
    margin: float | None = None,
    shrink: float = 0.7,
    rounds: int = 60,
    ridges: bool = True,
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
        margin: degrees added to ``critical_angle`` for the limit; None: the
            slicers' margin (:func:`texcad.printability.rule.slicer_margin`), so
            that PrusaSlicer and CuraEngine at threshold ``critical_angle`` put no
            support under the relief and it passes :func:`texcad.check`.
        shrink: extra factor per five rounds on the offending faces' displacements.
        rounds: rounds of shrinking before what still offends is set to 0.
        ridges: also lower the relief where a convex edge rises less steeply than
            the critical angle in a direction its faces overhang (a slicer's layer
            test sees such an edge's corner outrun the layer below; with build
            directions only). The edges of two faces are tested: on an open
            surface (a block of a larger mesh) its border edges are not.

    Returns:
        ``(d', report)`` with ``|d'_i| <= |d_i|`` and the same signs.
    """
    v0 = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces)
    nrm = np.asarray(normals, dtype=np.float64)
    d0 = np.asarray(d, dtype=np.float64)
    out = d0.copy()
    dirs = None if build_dir is None else build_directions(build_dir)
    cos_limit = 0.0
    if dirs is not None:
        crit = check_critical_angle(critical_angle)
        margin = slicer_margin(crit) if margin is None else float(margin)
        cos_limit = float(np.cos(np.radians(min(89.9, crit + margin))))
    want = ridges and dirs is not None
    with ThreadPoolExecutor(2) if _THREADS and threads() > 1 else nullcontext() as pool, \
            beside(_edge_table, np.ascontiguousarray(faces.T)) if want else nullcontext() as table:
        ctx = _Ctx(np.ascontiguousarray(v0.T), np.ascontiguousarray(nrm.T), np.ascontiguousarray(faces.T), dirs,
                   _directions(dirs), cos_limit, pool)
        incidence = pool.submit(_faces_at, ctx.f, len(v0)) if pool else None  # beside the first test
        over, fold = _first(ctx, out)
        faces_of = incidence.result() if pool else _faces_at(ctx.f, len(v0))
        first = (int(over.sum()), int(fold.sum()))
        _rounds(ctx._replace(pool=None), out, rounds, shrink, (over, fold), faces_of)
        steep = 0
        if want:  # the edge table was made on a second thread meanwhile
            tan_limit = float(np.tan(np.radians(min(89.9, check_critical_angle(critical_angle) + margin))))
            steep = _ridges(ctx._replace(pool=None), out, faces_of, rounds, shrink, tan_limit, table.result())
    low = out != d0
    near = rows(faces, faces_of(np.flatnonzero(low)))  # the faces at a lowered vertex, in order
    area = np.zeros(len(v0))
    p = rows(v0, near)
    fa = 0.5 * np.linalg.norm(cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    for k in range(3):  # per corner
        area += np.bincount(near[:, k], weights=fa / 3.0, minlength=len(v0))
    rep = ReliefLimit(
        lowered=int(low.sum()),
        zeroed=int((low & (out == 0)).sum()),
        overhang_faces=first[0],
        folded_faces=first[1],
        removed_mm3=float((np.abs(d0 - out) * area).sum()),
        steep_ridges=steep,
        directions=dirs,
    )
    return out, rep
