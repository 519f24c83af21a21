"""Adaptive, conforming subdivision of a triangle mesh and displacement along normals.

Displacing a mesh by a texture needs vertices at least as dense as the texture's
features, but only where the texture is. :func:`refine` does it in two steps:

1. *longest-edge bisection* (Rivara) down to a few times the target edge: every
   round, each active triangle longer than that has its longest edge split at its
   midpoint; a triangle that has any of its edges split must also split its own
   longest edge (the closure), and then each triangle is cut into 2, 3 or 4 along
   the split edges, with Lawson flips between coplanar triangles after each round
   (long slivers of CAD exports become well-shaped triangles);
2. :func:`tessellate`: every edge of the region cut into ``ceil(length / max_edge)``
   equal pieces and every face into the matching grid, all faces at once.

Each split edge is split for both of its triangles at the same points, so the mesh
stays conforming: a closed mesh stays closed, with no T-junctions.

:func:`vertex_normals` gives angle-weighted vertex normals (each face contributes its
unit normal times its interior angle at the vertex, Thürmer and Wüthrich 1998), the
direction :func:`displace` moves vertices along.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError, ResourceError
from ..util import argsort_ints, require_pitch, rowany, rowdot, rowmax, rownorm
from ..util.resources import round_up

#: Peak bytes of the whole mesh job per triangle of the refined region (as
#: :func:`refined_triangles` estimates them), measured on an icosphere of radius 10 mm
#: at pitch 0.1 and 0.05 mm (about 165 B, the adaptive default) and at ``tolerance=0``
#: (the pitch grid) on icospheres of radius 40 mm at 0.25 mm and 60 mm at 0.2 mm (272
#: and 242 B of peak resident memory): the memory estimate.
TRIANGLE_BYTES = 280.0

__all__ = ["refine", "coarsen", "refined_triangles", "ladder", "tessellate", "rows", "cross", "flip_edges", "vertex_normals", "offset_directions", "face_normals", "edge_lengths", "edge_counts"]

_ROT = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])


def _edges(faces: np.ndarray, slots: bool = False, stable: bool = False):
    """Unique undirected edges ``(E, 2)`` and, per face, its three edges' ids
    ``(M, 3)`` (local edge k runs from corner k to corner k+1); with ``slots`` also
    the ``3M`` slots ``3 face + corner`` sorted by edge (consecutive per edge; with
    ``stable`` in slot order within an edge, else in the order of numpy's default
    argsort, which the pitch grid's bytes were made with)."""
    a, b = faces.reshape(-1), faces[:, [1, 2, 0]].reshape(-1)  # slot 3 face + k: corner k to k + 1
    e = np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)
    n = np.int64(e.max() + 1) if e.size else np.int64(1)
    key = e[:, 0] * n + e[:, 1]
    order = np.argsort(key) if slots and not stable else argsort_ints(key)
    ks = key[order]
    first = np.ones(len(ks), dtype=bool)
    first[1:] = ks[1:] != ks[:-1]
    inv = np.empty(len(ks), dtype=np.int64)
    inv[order] = np.cumsum(first) - 1
    uniq = e[order[first]]
    return (uniq, inv.reshape(-1, 3), order) if slots else (uniq, inv.reshape(-1, 3))


def rows(a: np.ndarray, index: np.ndarray) -> np.ndarray:
    """``a[index]`` for a 2-D ``a``, by ``np.take`` (the same values; numpy's fancy
    indexing with a strided index such as ``faces[:, 0]`` is several times slower)."""
    return np.take(a, index, axis=0)


def cross(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``np.cross`` of ``(..., 3)`` arrays, column by column: the same products and
    differences in the same order (the same bits), 3 to 6 times faster."""
    out = np.empty(np.broadcast_shapes(x.shape, y.shape), dtype=np.result_type(x, y))
    out[..., 0] = x[..., 1] * y[..., 2] - x[..., 2] * y[..., 1]
    out[..., 1] = x[..., 2] * y[..., 0] - x[..., 0] * y[..., 2]
    out[..., 2] = x[..., 0] * y[..., 1] - x[..., 1] * y[..., 0]
    return out


def edge_lengths(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(M, 3)`` lengths in mm of each face's edges (corner k to corner k+1)."""
    v = rows(vertices, faces)
    return rownorm(v[:, [1, 2, 0]] - v)


def _close(mark: np.ndarray, eid: np.ndarray, longest: np.ndarray) -> None:
    """Rivara's closure, in place: a face with any split edge splits its longest."""
    ar = np.arange(len(eid))
    for _ in range(10_000):  # per propagation step (bounded by the longest-edge paths)
        fm = mark[eid]
        need = rowany(fm) & ~fm[ar, longest]
        if not need.any():
            return
        mark[eid[need, longest[need]]] = True
    raise AssertionError("longest-edge closure did not converge")  # pragma: no cover


def _split(faces: np.ndarray, eid: np.ndarray, longest: np.ndarray, mid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cut every face along its split edges (``mid[e] >= 0`` is the new vertex of edge
    ``e``). Returns the new faces and each one's index into ``faces``."""
    ar = np.arange(len(faces))
    rot = _ROT[longest]  # corners so that local edge 0 (a -> b) is the longest
    a, b, c = (faces[ar, rot[:, k]] for k in range(3))
    m, p, q = (mid[eid[ar, rot[:, k]]] for k in range(3))  # midpoints of ab, bc, ca
    keep = m < 0
    out = [faces[keep]]
    src = [ar[keep]]
    s = ~keep
    # left half (a, m, c), cut again at q (mid of ca) if that edge is split too
    lq = s & (q >= 0)
    ln = s & (q < 0)
    out += [np.stack([a[ln], m[ln], c[ln]], 1), np.stack([a[lq], m[lq], q[lq]], 1), np.stack([q[lq], m[lq], c[lq]], 1)]
    src += [ar[ln], ar[lq], ar[lq]]
    # right half (m, b, c), cut again at p (mid of bc)
    rp = s & (p >= 0)
    rn = s & (p < 0)
    out += [np.stack([m[rn], b[rn], c[rn]], 1), np.stack([m[rp], b[rp], p[rp]], 1), np.stack([m[rp], p[rp], c[rp]], 1)]
    src += [ar[rn], ar[rp], ar[rp]]
    return np.concatenate(out), np.concatenate(src)


def flip_edges(v: np.ndarray, f: np.ndarray, active: np.ndarray, *, passes: int = 4) -> np.ndarray:
    """Lawson edge flips between coplanar active triangles (in place on a copy).

    An edge shared by the active triangles ``(a, b, c)`` and ``(b, a, d)`` that lie in
    one plane (normals within 1e-9 rad) is flipped to ``c-d`` when the angles at ``c``
    and ``d`` add up to more than 180 degrees (it is not locally Delaunay). A flip
    changes neither the surface (the two triangles cover the same planar quad, which
    is convex when the angles add up to more than 180 degrees) nor its closedness; it
    removes the fans of thin triangles that bisection leaves on the long slivers of CAD
    exports. Each pass flips an independent set of edges (no triangle in two flips:
    an edge flips when its rank by excess angle is the highest at both of its triangles;
    ranks are unique, so ties cannot flip two edges of one triangle).
    """
    f = f.copy()
    for _ in range(passes):  # per pass over all edges at once
        _, _, order = _edges(f, slots=True)
        pair = order.reshape(-1, 2)  # closed mesh: every edge has two (face, corner) slots
        del order
        pair = pair[active[pair[:, 0] // 3] & active[pair[:, 1] // 3]]
        f1, k1 = pair[:, 0] // 3, pair[:, 0] % 3
        f2, k2 = pair[:, 1] // 3, pair[:, 1] % 3
        del pair
        a, b = f[f1, k1], f[f1, (k1 + 1) % 3]
        c, d = f[f1, (k1 + 2) % 3], f[f2, (k2 + 2) % 3]
        ok = (f[f2, k2] == b) & (f[f2, (k2 + 1) % 3] == a) & (c != d)
        cot = np.empty(len(a))
        for i in range(0, len(a), _FLIP_CHUNK):  # per chunk of edges (the same values; less memory at once)
            r = slice(i, i + _FLIP_CHUNK)
            ok[r] &= _not_delaunay(v, a[r], b[r], c[r], d[r], cot[r])
        s = np.flatnonzero(ok)
        if not len(s):
            break
        pri = np.empty(len(s), dtype=np.int64)  # unique ranks: no two winners share a face
        pri[np.argsort(-cot[s], kind="stable")] = np.arange(len(s))
        best = np.full(len(f), -1, dtype=np.int64)
        np.maximum.at(best, f1[s], pri)
        np.maximum.at(best, f2[s], pri)
        s = s[(pri == best[f1[s]]) & (pri == best[f2[s]])]
        f[f1[s]] = np.stack([a[s], d[s], c[s]], 1)
        f[f2[s]] = np.stack([d[s], b[s], c[s]], 1)
    return f


#: Edges whose flip test :func:`flip_edges` makes at once.
_FLIP_CHUNK = 1 << 18


def _not_delaunay(v, a, b, c, d, cot):
    """Per edge ``a-b`` between the triangles ``(a, b, c)`` and ``(b, a, d)``: not
    locally Delaunay (the angles at c and d add up to more than 180 degrees, i.e.
    cot c + cot d < 0, cot = dot / |cross| of the edges from the corner) and the two
    in one plane; ``cot`` (out) receives the sum."""
    va, vb, vc, vd = rows(v, a), rows(v, b), rows(v, c), rows(v, d)
    n1 = cross(vb - va, vc - va)
    n2 = cross(va - vb, vd - vb)
    l1, l2 = np.sqrt((n1 * n1).sum(1)), np.sqrt((n2 * n2).sum(1))
    cot[:] = ((va - vc) * (vb - vc)).sum(1) / np.maximum(l1, 1e-300) + ((vb - vd) * (va - vd)).sum(1) / np.maximum(l2, 1e-300)
    return (cot < -1e-9) & (l1 > 0) & (l2 > 0) & ((n1 * n2).sum(1) > (1.0 - 1e-12) * l1 * l2)


def _bisect(v, f, act, parent, coarse):
    """Longest-edge bisection (Rivara, with its closure: conforming) of the active
    faces longer than ``coarse`` mm, with a Lawson flip pass after each round (which
    turns the slivers' pieces into well-shaped triangles), until none is."""
    for _ in range(200):  # per round: every long face halves its longest edge
        edges, eid = _edges(f)
        elen = rownorm(v[edges[:, 1]] - v[edges[:, 0]])
        fl = elen[eid]
        longest = np.argmax(fl, axis=1)
        want = act & (fl[np.arange(len(f)), longest] > coarse)
        if not want.any():
            break
        mark = np.zeros(len(edges), dtype=bool)
        mark[eid[want, longest[want]]] = True
        _close(mark, eid, longest)
        split = np.flatnonzero(mark)
        mid = np.full(len(edges), -1, dtype=np.int64)
        mid[split] = len(v) + np.arange(len(split))
        v = np.concatenate([v, 0.5 * (v[edges[split, 0]] + v[edges[split, 1]])])
        f, src = _split(f, eid, longest, mid)
        parent, act = parent[src], act[src]
        f = flip_edges(v, f, act, passes=1)
    return v, f, act, parent


def refine(
    vertices: np.ndarray,
    faces: np.ndarray,
    active: np.ndarray,
    max_edge: float,
    *,
    max_faces: int = 40_000_000,
    coarse: float = 3.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the ``active`` faces until none has an edge longer than ``max_edge`` mm.

    Two steps (module docstring): active faces longer than ``coarse * max_edge``
    are bisected along their longest edge (Rivara, with its closure: conforming; a
    Lawson flip pass between coplanar faces after each round turns the slivers of CAD
    exports into well-shaped triangles), then every edge of an active face is cut into
    ``ceil(length / max_edge)`` equal pieces and each face into the matching grid
    (:func:`tessellate`, one vectorized step; the faces next to the region only along
    their shared edges). Every new triangle lies in its parent's plane with its
    orientation: watertight in, watertight out. A grid's triangles are similar to
    their face; next to an edge cut into fewer pieces than the face's longest they
    are sheared by up to half a piece, so some edges there (0.5 % of them at 0.2 mm
    on ``benchmarks/bench_mesh.py``'s part, 9 % on a coarse 24-sided cylinder) are up
    to about 1.35 ``max_edge`` long; the median edge is about 0.7 ``max_edge``.

    Args:
        vertices: ``(N, 3)`` positions in mm (kept as float64).
        faces: ``(M, 3)`` vertex indices, counter-clockwise from outside.
        active: ``(M,)`` bool, the faces to refine.
        max_edge: the edge length to cut down to in the active faces, mm.
        max_faces: refuse (ResourceError via the memory estimate) beyond this many
            faces.
        coarse: bisect down to this many ``max_edge`` before the grids.

    Returns:
        ``(vertices, faces, parent)``: float64 ``(N', 3)`` mm, int64 ``(M', 3)``, and
        ``parent[i]`` the input face that face ``i`` lies in.
    """
    v, f, act, parent = coarsen(vertices, faces, active, max_edge, max_faces=max_faces, coarse=coarse)
    if not act.any():
        return v, f, parent
    v, f, src = tessellate(v, f, edge_counts(v, f, act, max_edge)[0])
    return v, f, parent[src]


def edge_counts(v: np.ndarray, f: np.ndarray, active: np.ndarray, max_edge: float) -> tuple[np.ndarray, np.ndarray]:
    """``(M, 3)`` pieces each face's edges are split into, ``ceil(length / max_edge)``
    (mm) for an edge of an ``active`` face, the most any face at the edge asks (so a
    shared edge is split alike from both sides, and by its own length alone), and the
    sorted edge keys ``min * N + max`` of the vertex indices."""
    g = f[:, [1, 2, 0]]
    nv = np.int64(len(v))
    key = (np.minimum(f, g) * nv + np.maximum(f, g)).ravel()
    uk, inv = np.unique(key, return_inverse=True)
    n = np.where(active[:, None], np.ceil(edge_lengths(v, f) / max_edge - 1e-9), 1).astype(np.int64).ravel()
    per_edge = np.ones(len(uk), dtype=np.int64)
    np.maximum.at(per_edge, inv, n)
    return per_edge[inv].reshape(-1, 3), uk

def _quads(v, f, act, target):
    """Pairs of active, coplanar (within 1e-5 mm) triangles that share the longest edge
    of both and form a long thin quad (the strips of CAD exports): ``(Q,)`` faces
    ``f1``, ``f2`` and the quad's corners ``(Q, 4)`` counter-clockwise, starting at
    one end of a long side (``c0 -> c1`` and ``c2 -> c3`` are the long sides)."""
    edges, eid, order = _edges(f, slots=True)
    pair = order.reshape(-1, 2)
    el = rownorm(v[edges[:, 1]] - v[edges[:, 0]])
    lf = el[eid]
    k = np.argmax(lf, axis=1)
    g1, g2 = pair[:, 0] // 3, pair[:, 1] // 3
    k1, k2 = pair[:, 0] % 3, pair[:, 1] % 3
    ok = act[g1] & act[g2] & (k[g1] == k1) & (k[g2] == k2) & (el >= 2 * target)
    g1, g2, k1, k2 = g1[ok], g2[ok], k1[ok], k2[ok]
    p, q, r1 = f[g1, k1], f[g1, (k1 + 1) % 3], f[g1, (k1 + 2) % 3]
    r2 = f[g2, (k2 + 2) % 3]
    n = np.cross(v[q] - v[p], v[r1] - v[p])
    off = np.abs(((v[r2] - v[p]) * n).sum(1)) / np.maximum(np.linalg.norm(n, axis=1), 1e-300)
    c = np.stack([p, r2, q, r1], 1)  # counter-clockwise
    side = np.linalg.norm(v[c[:, [1, 2, 3, 0]]] - v[c], axis=2)  # c0c1, c1c2, c2c3, c3c0
    turn = side[:, 1] + side[:, 3] > side[:, 0] + side[:, 2]  # long sides c1c2, c3c0: start at c1
    c = np.where(turn[:, None], c[:, [1, 2, 3, 0]], c)
    side = np.where(turn[:, None], side[:, [1, 2, 3, 0]], side)
    thin = np.maximum(side[:, 1], side[:, 3]) < 0.5 * np.minimum(side[:, 0], side[:, 2])
    keep = (off <= 1e-5) & thin & (np.minimum(side[:, 0], side[:, 2]) >= 2 * target)
    return g1[keep], g2[keep], c[keep]


def ladder(v: np.ndarray, f: np.ndarray, active: np.ndarray, target: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cut the long thin quads of two active triangles (:func:`_quads`; the strips a
    CAD program exports for a cylinder's side) into ladders: each long side cut
    into ``ceil(length / target)`` equal pieces (a side shared with a face that is not
    such a quad stays whole, so the mesh stays conforming) and the strip between the
    two sides triangulated in order of the pieces' positions. Longest-edge bisection
    would put its new points inside the strip at irregular places, and every later
    grid inherits the slivers. Lengths mm.

    Returns:
        ``(vertices, faces, active, parent)`` as :func:`coarsen`.
    """
    g1, g2, c = _quads(v, f, active, target)
    parent = np.arange(len(f))
    if not len(g1):
        return v, f, active, parent
    nv = np.int64(len(v))
    lo, hi = np.minimum(c[:, [0, 2]], c[:, [1, 3]]), np.maximum(c[:, [0, 2]], c[:, [1, 3]])
    key = lo * nv + hi  # (Q, 2): the long sides c0c1, c2c3
    uk, inv, cnt = np.unique(key.ravel(), return_inverse=True, return_counts=True)
    ln = rownorm(v[uk % nv] - v[uk // nv])
    pieces = np.where(cnt == 2, np.ceil(ln / target - 1e-9), 1).astype(np.int64)  # shared by two quads, or whole
    start = nv + np.concatenate([[0], np.cumsum(pieces - 1)[:-1]])
    e = np.repeat(np.arange(len(uk)), pieces - 1)
    t = (np.arange(int((pieces - 1).sum())) - np.repeat(start - nv, pieces - 1) + 1) / pieces[e]
    a, b = v[uk[e] // nv], v[uk[e] % nv]
    v = np.concatenate([v, a * (1 - t)[:, None] + b * t[:, None]])
    tri = _zip(c, inv.reshape(-1, 2), pieces, start, uk // nv)
    gone = np.zeros(len(f), dtype=bool)
    gone[g1] = gone[g2] = True
    keep = np.flatnonzero(~gone)
    src = np.concatenate([keep, g1[tri[1]]])
    return v, np.concatenate([f[keep], tri[0]]), active[src], src


def _zip(c, side, pieces, start, first):
    """Triangles ``(T, 3)`` (and each one's quad) between the two long sides of every
    quad: bottom ``c0 -> c1`` and top ``c3 -> c2`` points merged by their position."""
    def points(qi, s, from_, to_):  # ids of the points along side s of quads qi, from_ -> to_
        n = pieces[side[qi, s]]
        k = np.arange(int(n.sum()) + len(qi)) - np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
        qq = np.repeat(qi, n + 1)
        nn = np.repeat(n, n + 1)
        fwd = first[side[qq, s]] == from_[qq]
        kk = np.where(fwd, k, nn - k)
        inner = start[side[qq, s]] + kk - 1
        ids = np.where(kk == 0, np.where(fwd, from_[qq], to_[qq]), np.where(kk == nn, np.where(fwd, to_[qq], from_[qq]), inner))
        return ids, k / nn, qq

    q = np.arange(len(c))
    bot, tb, qb = points(q, 0, c[:, 0], c[:, 1])
    top, tt, qt = points(q, 1, c[:, 3], c[:, 2])
    nb, nt = pieces[side[:, 0]], pieces[side[:, 1]]
    # steps: advance along the bottom (at the middle of piece i) or the top, in order
    sb = np.concatenate([[0], np.cumsum(nb + 1)])[:-1]
    st = np.concatenate([[0], np.cumsum(nt + 1)])[:-1]
    kb = np.arange(int(nb.sum())) - np.repeat(np.cumsum(nb) - nb, nb)
    kt = np.arange(int(nt.sum())) - np.repeat(np.cumsum(nt) - nt, nt)
    qsb, qst = np.repeat(q, nb), np.repeat(q, nt)
    ev_q = np.concatenate([qsb, qst])
    ev_key = np.concatenate([(kb + 0.5) / nb[qsb], (kt + 0.5) / nt[qst]])
    ev_bot = np.concatenate([np.ones(len(qsb), bool), np.zeros(len(qst), bool)])
    o = np.lexsort((~ev_bot, ev_key, ev_q))
    ev_q, ev_bot = ev_q[o], ev_bot[o]
    first_ev = np.concatenate([[0], np.cumsum(nb + nt)])[:-1]
    cb = np.cumsum(ev_bot) - ev_bot
    ct = np.cumsum(~ev_bot) - ~ev_bot
    i = cb - (cb[first_ev] )[ev_q] if len(ev_q) else cb
    j = ct - (ct[first_ev])[ev_q] if len(ev_q) else ct
    B = lambda k: bot[sb[ev_q] + k]  # noqa: E731
    T = lambda k: top[st[ev_q] + k]  # noqa: E731
    tri = np.where(ev_bot[:, None], np.stack([B(i), B(np.minimum(i + 1, nb[ev_q])), T(j)], 1),
                   np.stack([B(i), T(np.minimum(j + 1, nt[ev_q])), T(j)], 1))
    return tri, ev_q


def coarsen(
    vertices: np.ndarray, faces: np.ndarray, active: np.ndarray, max_edge: float, *, max_faces: int = 40_000_000, coarse: float = 3.0,
    ladders: bool = False, guard: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The first step of :func:`refine`: the ``active`` faces bisected (Rivara, with
    its closure and Lawson flips) until no edge is longer than ``coarse * max_edge``
    mm, after a memory estimate for the refinement down to ``max_edge`` (``guard``:
    refused, naming a pitch that fits, where the refined mesh would not fit in memory;
    False where the caller refines in blocks, :mod:`texcad.targets.tiled_mesh`; the
    triangle cap holds either way).

    Returns:
        ``(vertices, faces, active, parent)``: float64 ``(N', 3)`` mm, int64
        ``(M', 3)``, bool ``(M',)`` and each face's input face.
    """
    if not (np.isfinite(max_edge) and max_edge > 0):
        raise ParameterError(f"max_edge must be a positive length in mm, got {max_edge!r}")
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    act = np.asarray(active, dtype=bool)
    parent = np.arange(len(f), dtype=np.int64)
    if not act.any():
        return v, f, act, parent
    est = refined_triangles(v, f, act, max_edge)
    if guard:
        require_pitch(f"refining to about {est} triangles", max_edge, (est - len(f)) * TRIANGLE_BYTES, len(f) * TRIANGLE_BYTES)
    if est > max_faces:  # beyond the triangle cap: the pitch at which the count is at the cap
        fit = max_edge * ((est - len(f)) / max(max_faces - len(f), 1)) ** 0.5
        raise ResourceError(f"refining to about {est} triangles at a pitch of {max_edge:.3g} mm exceeds the cap of "
                            f"{max_faces} triangles; use a pitch of at least {round_up(fit):.3g} mm or a smaller region")
    if ladders:
        v, f, act, parent = ladder(v, f, act, 0.5 * coarse * max_edge)
    return _bisect(v, f, act, parent, coarse * max_edge)


def refined_triangles(vertices: np.ndarray, faces: np.ndarray, active: np.ndarray, max_edge: float) -> int:
    """About how many triangles :func:`refine` makes of ``(vertices, faces)`` with the
    ``active`` faces refined to ``max_edge`` mm: the faces, plus 2.5 per
    ``max_edge^2`` of each active face's longest times shortest edge (mm^2)."""
    act = np.asarray(active, dtype=bool)
    f = np.asarray(faces, dtype=np.int64)
    if not act.any():
        return int(len(f))
    lens = edge_lengths(np.asarray(vertices, dtype=np.float64), f[act])
    return int(len(f) + 2.5 * (lens.max(axis=1) * lens.min(axis=1)).sum() / max_edge**2)


def _grid(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The level-``n`` grid of a triangle ``a, b, c``: points ``(i, j)`` (``(P, 2)``
    int, ``i + j <= n``, the point ``a + i/n (b - a) + j/n (c - a)``) and its ``n^2``
    triangles ``(n^2, 3)`` (indices into the points, counter-clockwise like ``a, b, c``)."""
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1), indexing="ij")
    keep = (i + j) <= n
    pts = np.stack([i[keep], j[keep]], 1)
    index = np.full((n + 2, n + 2), -1, dtype=np.int64)
    index[pts[:, 0], pts[:, 1]] = np.arange(len(pts))
    ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up, dn = (ii + jj) <= n - 1, (ii + jj) <= n - 2
    a, b = ii[up], jj[up]
    tri = [np.stack([index[a, b], index[a + 1, b], index[a, b + 1]], 1)]
    a, b = ii[dn], jj[dn]
    tri.append(np.stack([index[a + 1, b], index[a + 1, b + 1], index[a, b + 1]], 1))
    return pts, np.concatenate(tri)


def _snap(t: np.ndarray, level: int, count: np.ndarray) -> np.ndarray:
    """Index ``0..count`` of the edge point nearest to the grid point ``t`` of ``level``
    along an edge (``t / level`` of the way), an exact half rounded down; integers."""
    return (2 * t * count + level - 1) // (2 * level)


def _grid_ids(v, f, cnt, sel, lev, pts, edge_of, start, nxt):
    """Global vertex ids ``(G, P)`` of the level-``lev`` grid points of faces ``sel``,
    the next free id, and the positions of the new interior points (mm)."""
    i, j = pts[:, 0], pts[:, 1]
    gid = np.empty((len(sel), len(pts)), dtype=np.int64)
    fs = f[sel]
    for k, c in enumerate(((0, 0), (lev, 0), (0, lev))):  # per corner
        gid[:, int(np.flatnonzero((i == c[0]) & (j == c[1]))[0])] = fs[:, k]
    sides = ((j == 0) & (i > 0) & (i < lev), i), ((i + j == lev) & (j > 0) & (j < lev), j), ((i == 0) & (j > 0) & (j < lev), lev - j)
    for k, (on, t) in enumerate(sides):  # per edge k: corner k -> k + 1, t from corner k
        cols = np.flatnonzero(on)
        n = cnt[sel, k][:, None]
        s = _snap(t[cols][None, :], lev, n)
        fwd = (fs[:, k] < fs[:, (k + 1) % 3])[:, None]
        e = edge_of[sel, k][:, None]
        ids = start[e] + np.where(fwd, s, n - s) - 1
        ids = np.where(s == 0, fs[:, [k]], np.where(s == n, fs[:, [(k + 1) % 3]], ids))
        gid[:, cols] = ids
    inner = np.flatnonzero((i > 0) & (j > 0) & (i + j < lev))
    gid[:, inner] = nxt + np.arange(len(sel) * len(inner)).reshape(len(sel), len(inner))
    w = np.stack([lev - i[inner] - j[inner], i[inner], j[inner]], 1) / lev  # (Q, 3) barycentric
    pos = np.einsum("qk,gkx->gqx", w, v[fs]).reshape(-1, 3)
    return gid, nxt + len(sel) * len(inner), pos


def tessellate(vertices: np.ndarray, faces: np.ndarray, counts: np.ndarray, *, classes: dict | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cut every edge into ``counts`` equal pieces and each face into a matching grid.

    A face whose edges are cut into ``(n0, n1, n2)`` pieces gets the uniform grid of
    level ``N = max(n0, n1, n2)`` (``N^2`` triangles similar to the face); on an edge
    cut into fewer than ``N`` pieces the grid's points slide along the edge to the
    nearest of its ``n + 1`` points (an exact half towards the edge's start, seen
    counter-clockwise) and the triangles that shrink to a segment are dropped. The two
    faces at an edge use the same points, so the mesh stays conforming; points only
    slide along their own edge, and at a corner one edge rounds towards it and the
    other away, so no triangle turns over (``tests/solid/test_subdivide.py`` checks
    every ``(n0, n1, n2)`` up to 9). All faces at once: one loop per grid level.

    Args:
        vertices: ``(N, 3)`` mm.
        faces: ``(M, 3)`` vertex indices.
        counts: ``(M, 3)`` int >= 1, pieces of each face's edge ``k`` (corner ``k`` to
            ``k + 1``); the two faces at an edge must agree.

    Returns:
        ``(vertices, faces, parent)``: float64 ``(N', 3)`` mm (the input's first, then
        the edges' points, then the faces' inner points), int64 ``(M', 3)`` (the faces
        with all counts 1 first, unchanged), ``parent[i]`` the input face of face ``i``.
        A dict passed as ``classes`` receives where each new point lies: ``edge_key``
        (the cut edges' keys ``min * N + max``), ``edge_start`` (id of each cut
        edge's first point, from its smaller vertex), ``edge_count``, ``edge_point``
        and ``t`` (per edge point: its edge and parameter), ``inner_face`` and
        ``inner_w`` ``(Q, 3)`` (per inner point: its face and barycentric weights).
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    cnt = np.asarray(counts, dtype=np.int64)
    level = rowmax(cnt)
    keep = np.flatnonzero(level <= 1)
    nv = np.int64(max(len(v), 1))
    g = f[:, [1, 2, 0]]
    key = np.minimum(f, g) * nv + np.maximum(f, g)  # (M, 3) undirected edge keys
    cut = level > 1
    uk, inv = np.unique(key[cut], return_inverse=True)
    ecount = np.zeros(len(uk), dtype=np.int64)
    ecount[inv.ravel()] = cnt[cut].ravel()
    if np.any(ecount[inv.ravel()] != cnt[cut].ravel()):
        raise ParameterError("tessellate: the two faces at an edge give it different counts")
    edge_of = np.zeros(f.shape, dtype=np.int64)
    edge_of[cut] = inv.reshape(-1, 3)
    reps = ecount - 1
    start = len(v) + np.concatenate([[0], np.cumsum(reps)[:-1]]) if len(uk) else np.zeros(0, np.int64)
    eidx = np.repeat(np.arange(len(uk)), reps)
    t = (np.arange(int(reps.sum())) - np.repeat(start - len(v), reps) + 1) / ecount[eidx]
    ea, eb = uk // nv, uk % nv
    new_v = [v, v[ea[eidx]] * (1 - t)[:, None] + v[eb[eidx]] * t[:, None]]
    nxt = len(v) + int(reps.sum())
    out_f, out_p = [f[keep]], [keep]
    inner_f, inner_w = [np.zeros(0, np.int64)], [np.zeros((0, 3))]
    for lev in np.unique(level[cut]):  # per grid level (a handful)
        sel = np.flatnonzero(level == lev)
        pts, tri = _grid(int(lev))
        gid, nxt, pos = _grid_ids(v, f, cnt, sel, int(lev), pts, edge_of, start, nxt)
        new_v.append(pos)
        if classes is not None:
            i, j = pts[:, 0], pts[:, 1]
            q = (i > 0) & (j > 0) & (i + j < lev)
            inner_f.append(np.repeat(sel, int(q.sum())))
            inner_w.append(np.tile(np.stack([lev - i[q] - j[q], i[q], j[q]], 1) / lev, (len(sel), 1)))
        ft = gid[:, tri].reshape(-1, 3)
        ok = (ft[:, 0] != ft[:, 1]) & (ft[:, 1] != ft[:, 2]) & (ft[:, 2] != ft[:, 0])
        out_f.append(ft[ok])
        out_p.append(np.repeat(sel, len(tri))[ok])
    if classes is not None:
        classes.update(edge_key=uk, edge_start=start, edge_count=ecount, edge_point=eidx, t=t,
                       inner_face=np.concatenate(inner_f), inner_w=np.concatenate(inner_w))
    return np.concatenate(new_v), np.concatenate(out_f), np.concatenate(out_p)


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit face normals ``(M, 3)`` and face areas ``(M,)`` in mm^2."""
    v = rows(vertices, faces)
    n = cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    ln = rownorm(n)
    return n / np.maximum(ln, 1e-300)[:, None], 0.5 * ln


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Angle-weighted unit vertex normals ``(N, 3)``: ``n_v = sum_f theta_f(v) n_f``
    normalised, ``theta_f(v)`` the interior angle of face ``f`` at ``v`` (radians)."""
    v = np.asarray(vertices, dtype=np.float64)
    a, b, c = rows(v, faces[:, 0]), rows(v, faces[:, 1]), rows(v, faces[:, 2])
    e = (b - a, c - b, a - c)  # edge k from corner k to k + 1, (M, 3) each
    n = cross(e[0], -e[2])
    twice = rownorm(n)
    fn = n / np.maximum(twice, 1e-300)[:, None]
    out = np.zeros_like(v)
    for k in range(3):  # per corner: the angle between edge k and the reversed edge k - 1
        ang = np.arctan2(twice, -np.einsum("ij,ij->i", e[k], e[(k + 2) % 3]))
        for c in range(3):  # per coordinate
            out[:, c] += np.bincount(faces[:, k], weights=fn[:, c] * ang, minlength=len(v))
    ln = rownorm(out)
    return out / np.maximum(ln, 1e-300)[:, None]


def offset_directions(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, *, cap: float = 3.0) -> np.ndarray:
    """Displacement directions that offset every face plane by the same distance:
    ``n_v / c_v`` with ``c_v = min_f (n_v . n_f)`` over the faces ``f`` at vertex ``v``
    (clipped to ``[1/cap, 1]``). On a smooth surface ``c_v ~ 1``; on a sharp edge
    between faces at 90 degrees ``c_v = cos 45``, so moving the edge vertex by
    ``d / c_v`` along the diagonal keeps both faces ``d`` mm from where they were
    (an inward texture at a convex edge, or an outward one in a concave corner, does
    not fold over)."""
    v = np.asarray(vertices, dtype=np.float64)
    fn, _ = face_normals(v, faces)
    corner = faces.ravel()
    dots = rowdot(np.repeat(fn, 3, axis=0), rows(normals, corner))
    c = np.ones(len(v))
    np.minimum.at(c, corner, dots)
    c = np.clip(c, 1.0 / cap, 1.0)
    return normals / c[:, None]
