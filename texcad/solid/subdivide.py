"""Adaptive, conforming subdivision of a triangle mesh and displacement along normals.

Displacing a mesh by a texture needs vertices at least as dense as the texture's
features, but only where the texture is. :func:`refine` splits the triangles of a
region by *longest-edge bisection* (Rivara): every round, each active triangle whose
longest edge is longer than ``max_edge`` mm has that edge split at its midpoint; a
triangle that has any of its edges split must also split its own longest edge (the
closure, repeated until no triangle needs more), and then each triangle is cut
into 2, 3 or 4 along the split edges. Every split edge is split for both of its
triangles at the same midpoint (one new vertex per edge), so the mesh stays
conforming: a closed mesh stays closed, with no T-junctions. Bisecting the longest
edge keeps the angles bounded away from 0 (long slivers of CAD exports become
well-shaped triangles instead of ever thinner slivers).

:func:`vertex_normals` gives angle-weighted vertex normals (each face contributes its
unit normal times its interior angle at the vertex, Thürmer and Wüthrich 1998), the
direction :func:`displace` moves vertices along.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError
from ..util import require_memory

__all__ = ["refine", "flip_edges", "vertex_normals", "offset_directions", "face_normals", "edge_lengths"]

_ROT = np.array([[0, 1, 2], [1, 2, 0], [2, 0, 1]])


def _edges(faces: np.ndarray, slots: bool = False):
    """Unique undirected edges ``(E, 2)`` and, per face, its three edges' ids
    ``(M, 3)`` (local edge k runs from corner k to corner k+1); with ``slots`` also
    the ``3M`` slots ``3 face + corner`` sorted by edge (consecutive per edge)."""
    e = np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1).reshape(-1, 2)
    e.sort(axis=1)
    n = np.int64(e.max() + 1) if e.size else np.int64(1)
    key = e[:, 0] * n + e[:, 1]
    order = np.argsort(key)
    ks = key[order]
    first = np.ones(len(ks), dtype=bool)
    first[1:] = ks[1:] != ks[:-1]
    inv = np.empty(len(ks), dtype=np.int64)
    inv[order] = np.cumsum(first) - 1
    uniq = e[order[first]]
    return (uniq, inv.reshape(-1, 3), order) if slots else (uniq, inv.reshape(-1, 3))


def edge_lengths(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(M, 3)`` lengths in mm of each face's edges (corner k to corner k+1)."""
    v = vertices[faces]
    return np.linalg.norm(v[:, [1, 2, 0]] - v, axis=2)


def _close(mark: np.ndarray, eid: np.ndarray, longest: np.ndarray) -> None:
    """Rivara's closure, in place: a face with any split edge splits its longest."""
    ar = np.arange(len(eid))
    for _ in range(10_000):  # per propagation step (bounded by the longest-edge paths)
        fm = mark[eid]
        need = fm.any(axis=1) & ~fm[ar, longest]
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
        both = active[pair[:, 0] // 3] & active[pair[:, 1] // 3]
        pair = pair[both]
        f1, k1 = pair[:, 0] // 3, pair[:, 0] % 3
        f2, k2 = pair[:, 1] // 3, pair[:, 1] % 3
        a, b = f[f1, k1], f[f1, (k1 + 1) % 3]
        c, d = f[f1, (k1 + 2) % 3], f[f2, (k2 + 2) % 3]
        ok = (f[f2, k2] == b) & (f[f2, (k2 + 1) % 3] == a) & (c != d)
        va, vb, vc, vd = v[a], v[b], v[c], v[d]
        # not locally Delaunay: the angles at c and d add up to more than 180 degrees,
        # i.e. cot c + cot d < 0 (cot = dot / |cross| of the edges from the corner)
        n1 = np.cross(vb - va, vc - va)
        n2 = np.cross(va - vb, vd - vb)
        l1, l2 = np.sqrt((n1 * n1).sum(1)), np.sqrt((n2 * n2).sum(1))
        cot = ((va - vc) * (vb - vc)).sum(1) / np.maximum(l1, 1e-300) + ((vb - vd) * (va - vd)).sum(1) / np.maximum(l2, 1e-300)
        ok &= (cot < -1e-9) & (l1 > 0) & (l2 > 0) & ((n1 * n2).sum(1) > (1.0 - 1e-12) * l1 * l2)
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


def refine(
    vertices: np.ndarray,
    faces: np.ndarray,
    active: np.ndarray,
    max_edge: float,
    *,
    max_faces: int = 40_000_000,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Split the ``active`` faces until none has an edge longer than ``max_edge`` mm.

    Longest-edge bisection with Rivara's closure (module docstring): faces next to
    split ones are cut too where needed, so the result is conforming (watertight in,
    watertight out) and every new triangle keeps the orientation of its parent.

    Args:
        vertices: ``(N, 3)`` positions in mm (kept as float64).
        faces: ``(M, 3)`` vertex indices, counter-clockwise from outside.
        active: ``(M,)`` bool, the faces to refine (their children stay active).
        max_edge: longest edge allowed in the active faces, mm.
        max_faces: refuse (ResourceError via the memory estimate) beyond this many
            faces.

    Returns:
        ``(vertices, faces, parent)``: float64 ``(N', 3)`` mm, int64 ``(M', 3)``, and
        ``parent[i]`` the input face that face ``i`` lies in.
    """
    if not (np.isfinite(max_edge) and max_edge > 0):
        raise ParameterError(f"max_edge must be a positive length in mm, got {max_edge!r}")
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    act = np.asarray(active, dtype=bool)
    parent = np.arange(len(f), dtype=np.int64)
    if act.any():
        lens = edge_lengths(v, f[act])
        est = int(len(f) + 2.5 * (lens.max(axis=1) * lens.min(axis=1)).sum() / max_edge**2)
        require_memory(est * 120, f"about {est} triangles", "use a larger pitch or a smaller region")
        if est > max_faces:
            require_memory(10**15, f"about {est} triangles", "use a larger pitch or a smaller region")
    for _ in range(200):  # per round: every long edge is halved
        edges, eid = _edges(f)
        elen = np.linalg.norm(v[edges[:, 1]] - v[edges[:, 0]], axis=1)
        fl = elen[eid]
        longest = np.argmax(fl, axis=1)
        ar = np.arange(len(f))
        want = act & (fl[ar, longest] > max_edge)
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
        f = flip_edges(v, f, act, passes=1)  # keeps the triangles well shaped
    return v, f, parent


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit face normals ``(M, 3)`` and face areas ``(M,)`` in mm^2."""
    v = vertices[faces]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    ln = np.linalg.norm(n, axis=1)
    return n / np.maximum(ln, 1e-300)[:, None], 0.5 * ln


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Angle-weighted unit vertex normals ``(N, 3)``: ``n_v = sum_f theta_f(v) n_f``
    normalised, ``theta_f(v)`` the interior angle of face ``f`` at ``v`` (radians)."""
    v = np.asarray(vertices, dtype=np.float64)
    fn, _ = face_normals(v, faces)
    p = v[faces]
    out = np.zeros_like(v)
    for k in range(3):  # per corner
        e1 = p[:, (k + 1) % 3] - p[:, k]
        e2 = p[:, (k + 2) % 3] - p[:, k]
        cosang = (e1 * e2).sum(1) / np.maximum(np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1), 1e-300)
        ang = np.arccos(np.clip(cosang, -1.0, 1.0))
        for c in range(3):  # per coordinate
            out[:, c] += np.bincount(faces[:, k], weights=fn[:, c] * ang, minlength=len(v))
    ln = np.linalg.norm(out, axis=1)
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
    dots = (np.repeat(fn, 3, axis=0) * normals[corner]).sum(1)
    order = np.argsort(corner, kind="stable")
    cs = corner[order]
    starts = np.flatnonzero(np.r_[True, cs[1:] != cs[:-1]])
    c = np.ones(len(v))
    c[cs[starts]] = np.minimum.reduceat(dots[order], starts)
    c = np.clip(c, 1.0 / cap, 1.0)
    return normals / c[:, None]
