"""Repair a triangle soup into closed, consistently oriented bodies (numpy, scipy).

What a downloaded STL/3MF/OBJ needs before it can be displaced, in order:

1. vertices equal to ``merge`` mm (1e-8) are one vertex (first occurrence kept, in
   input order);
2. triangles with a repeated vertex (after merging) or with the same three vertices
   as an earlier one are dropped, and so are vertices no triangle uses;
3. closed: every undirected edge belongs to exactly two triangles (else
   :class:`InputError` counting the open and the non-manifold edges);
4. consistent winding per body: at an edge the two triangles must run through it in
   opposite directions. Triangles are nodes of a graph whose links (shared edges)
   say whether the two run the same way; a breadth-first tree per body gives each
   triangle the parity of flips on its path to the root (pointer doubling:
   ``log2(depth)`` vectorized steps), and the flips are applied. A link that still
   disagrees means a one-sided (Moebius-like) body: InputError;
5. outward: each shell's signed volume ``sum det(a, b, c) / 6`` is made positive,
   except for a shell inside an odd number of others (a ray from one of its corners
   crosses such a shell an odd number of times): that is a cavity's wall, which faces
   into the cavity (negative volume). ``trimesh.repair.fix_normals(multibody=True)``
   turns every shell outward, filling cavities.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .mesh import edge_report, edge_slot_pairs

__all__ = ["repair_closed"]


def _merge(v: np.ndarray, f: np.ndarray, merge: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices equal after rounding to ``merge`` mm are one (first kept, input order)."""
    key = np.round(v / merge).astype(np.int64)
    order = np.lexsort(key.T[::-1])
    k = key[order]
    new = np.r_[True, np.any(k[1:] != k[:-1], axis=1)]
    group = np.cumsum(new) - 1
    first = np.full(int(group[-1]) + 1 if len(group) else 0, len(v), dtype=np.int64)
    np.minimum.at(first, group, order)
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(first))
    remap = np.empty(len(v), dtype=np.int64)
    remap[order] = rank[group]
    return v[np.sort(first)], remap[f]


def _clean(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop triangles with a repeated vertex or the vertex set of an earlier one, then
    the vertices no triangle uses."""
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])]
    s = np.sort(f, axis=1)
    _, first = np.unique(s, axis=0, return_index=True)
    f = f[np.sort(first)]
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    remap = np.cumsum(used) - 1
    return v[used], remap[f]


def _edge_pairs(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each undirected edge's two triangles ``(E, 2)`` and whether they run through it
    the same way ``(E,)``; None, None unless every edge has exactly two."""
    slot = edge_slot_pairs(f)
    if slot is None:
        return None, None
    a, b = f.ravel(), f[:, [1, 2, 0]].ravel()
    same = (a[slot[:, 0]] < b[slot[:, 0]]) == (a[slot[:, 1]] < b[slot[:, 1]])
    return slot // 3, same


def _parity(tri: np.ndarray, same: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle ``(m,)``: whether to flip it (consistent winding) and its body."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components

    def graph(rows, cols, n):
        return coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n)).tocsr()

    _, body = connected_components(graph(tri[:, 0], tri[:, 1], m), directed=False)
    roots = np.unique(body, return_index=True)[1]
    hub = np.full(len(roots), m)  # one extra node linked to every body's first triangle
    g = graph(np.r_[tri[:, 0], hub], np.r_[tri[:, 1], roots], m + 1)
    _, pred = breadth_first_order(g, m, directed=False, return_predecessors=True)
    pred = pred[:m].astype(np.int64)
    pred[roots] = roots
    key = np.minimum(tri[:, 0], tri[:, 1]).astype(np.int64) * m + np.maximum(tri[:, 0], tri[:, 1])
    order = np.argsort(key)
    kid = np.flatnonzero(pred != np.arange(m))
    q = np.minimum(kid, pred[kid]) * m + np.maximum(kid, pred[kid])
    flip = np.zeros(m, dtype=bool)  # first: the flip between a triangle and its parent
    flip[kid] = same[order[np.searchsorted(key[order], q)]]
    anc = pred
    while True:  # pointer doubling: flip[i] = parity of the path from i to anc[i]
        nxt = anc[anc]
        if np.array_equal(nxt, anc):
            return flip, body
        flip, anc = flip ^ flip[anc], nxt


def repair_closed(vertices: np.ndarray, faces: np.ndarray, *, merge: float = 1e-8, name: str = "the mesh") -> tuple[np.ndarray, np.ndarray, int]:
    """Closed, consistently wound, outward bodies from a triangle soup (module
    docstring). Returns ``(vertices float64 (N, 3) mm, faces int64 (M, 3), bodies)``.

    Args:
        vertices: ``(N, 3)`` mm. faces: ``(M, 3)`` vertex indices.
        merge: vertices closer than this (mm, per coordinate after rounding) are one.
        name: how error messages call the mesh.

    Raises:
        InputError: a vertex index out of range or a vertex that is not finite, no
            triangle left, open or non-manifold edges, or a one-sided body.
    """
    v, f = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    if f.size and (f.min() < 0 or f.max() >= len(v)):
        raise InputError(f"{name} has triangles that index missing vertices ({int(f.min())} .. {int(f.max())} of {len(v)}); export it again")
    bad = ~np.isfinite(v).all(axis=1)
    if bad[np.unique(f)].any():
        raise InputError(f"{name} has {int(bad[np.unique(f)].sum())} vertices that are not finite numbers (NaN or inf); export it again")
    v, f = _merge(v, f, merge)
    v, f = _clean(v, f)
    if not len(f):
        raise InputError(f"{name} holds no triangles (after dropping degenerate ones)")
    tri, same = _edge_pairs(f)
    if tri is None:
        bad = edge_report(f)
        raise InputError(
            f"{name} is not closed after repair ({bad['boundary']} open edges, {bad['nonmanifold']} non-manifold "
            "edges); texcad textures closed solids: close the holes (e.g. in the CAD program or a mesh repair "
            "tool) and export it again"
        )
    flip, body = _parity(tri, same, len(f))
    if np.any(same ^ flip[tri[:, 0]] ^ flip[tri[:, 1]]):
        raise InputError(f"{name} has a one-sided (Moebius-like) body: no winding makes it closed and oriented; fix it in the CAD program")
    p = v[f]
    det = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])) * np.where(flip, -1.0, 1.0)
    inward = _depths(p, body) % 2 == 1  # a cavity's shell faces into the cavity
    flip ^= ((np.bincount(body, weights=det) < 0) != inward)[body]
    f[flip] = f[flip][:, ::-1]
    return v, f, int(body.max() + 1)


#: A ray direction no mesh made of axis-aligned or 45-degree features runs along.
_RAY = np.array([1.0, 0.0123456, 0.0234567]) / np.linalg.norm([1.0, 0.0123456, 0.0234567])


def _crossings(pts: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """``(K,)`` how many triangles ``(T, 3, 3)`` the ray from each of ``pts``
    ``(K, 3)`` along :data:`_RAY` passes through (Moller-Trumbore, in chunks)."""
    a = tri[:, 0]
    e1, e2 = tri[:, 1] - a, tri[:, 2] - a
    pv = np.cross(_RAY, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    out = np.zeros(len(pts), dtype=np.int64)
    step = max(1, 2_000_000 // max(len(tri), 1))
    for k in range(0, len(pts), step):  # per chunk of points: (chunk, T) arrays
        tv = pts[k : k + step, None, :] - a[None]
        u = np.einsum("ktj,tj->kt", tv, pv) * inv
        qv = np.cross(tv, e1[None])
        w = np.einsum("j,ktj->kt", _RAY, qv) * inv
        t = np.einsum("tj,ktj->kt", e2, qv) * inv
        out[k : k + step] = (ok & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 0)).sum(axis=1)
    return out


def _depths(p: np.ndarray, body: np.ndarray) -> np.ndarray:
    """``(B,)`` how many other shells enclose each shell (the parity of a ray from one
    of its corners through each other shell whose box holds that corner)."""
    nb = int(body.max()) + 1
    depth = np.zeros(nb, dtype=np.int64)
    if nb == 1:
        return depth
    order = np.argsort(body, kind="stable")
    cut = np.searchsorted(body[order], np.arange(nb + 1))
    lo = np.minimum.reduceat(p[order].min(axis=1), cut[:-1])
    hi = np.maximum.reduceat(p[order].max(axis=1), cut[:-1])
    probe = p[order[cut[:-1]], 0]  # a corner of each shell
    for j in range(nb):  # per shell that may hold others (one box test each)
        inside = np.flatnonzero(np.all((probe > lo[j]) & (probe < hi[j]), axis=1))
        inside = inside[inside != j]
        if len(inside):
            depth[inside] += _crossings(probe[inside], p[order[cut[j] : cut[j + 1]]]) % 2
    return depth
