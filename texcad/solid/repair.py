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
5. outward: a body whose signed volume ``sum det(a, b, c) / 6`` is negative is turned
   inside out (each body on its own, as ``trimesh.repair.fix_normals(multibody=True)``
   does).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..util import argsort_ints

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


def _edge_pairs(f: np.ndarray) -> tuple[np.ndarray, np.ndarray, dict]:
    """Each undirected edge's two triangles ``(E, 2)`` and whether they run through it
    the same way ``(E,)``; InputError if an edge has not exactly two."""
    nv = np.int64(f.max() + 1)
    a, b = f.ravel(), f[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * nv + np.maximum(a, b)
    order = argsort_ints(key)
    k = key[order]
    start = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
    count = np.diff(np.r_[start, len(k)])
    if np.any(count != 2):
        return None, None, {"boundary": int((count == 1).sum()), "nonmanifold": int((count > 2).sum())}
    slot = order.reshape(-1, 2)
    same = (a[slot[:, 0]] < b[slot[:, 0]]) == (a[slot[:, 1]] < b[slot[:, 1]])
    return slot // 3, same, {}


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
        InputError: no triangle left, open or non-manifold edges, or a one-sided body.
    """
    v, f = _merge(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), merge)
    v, f = _clean(v, f)
    if not len(f):
        raise InputError(f"{name} holds no triangles (after dropping degenerate ones)")
    tri, same, bad = _edge_pairs(f)
    if bad:
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
    flip ^= (np.bincount(body, weights=det) < 0)[body]  # a body inside out as a whole
    f[flip] = f[flip][:, ::-1]
    return v, f, int(body.max() + 1)
