"""Repair a triangle soup into closed, consistently oriented bodies (numpy, scipy).

What a downloaded STL/3MF/OBJ needs before it can be displaced, in order:

1. vertices equal to ``merge`` mm (1e-8) are one vertex (first occurrence kept, in
   input order); unless that leaves the mesh open or non-manifold where its own
   indexing closes it (PrusaSlicer's 3MF keeps apart points of two walls that touch
   along a line, with needle triangles there): then the indexing is kept, the needles
   flipped away (:func:`flip_needles`) and the walls pulled 2 um apart there
   (:func:`pull_apart`);
2. triangles with a repeated vertex (after merging) or with the same three vertices
   as an earlier one are dropped, and so are vertices no triangle uses; in a closed
   mesh, vertices closer than :data:`NEAR` are then merged too where it stays closed
   with as many shells (:func:`_merge_near`: a needle's short side);
3. closed: every undirected edge belongs to exactly two triangles. Where not, bodies
   exported touching each other (a shaft in its bore, a lid on its box) are tried:
   a wall two of them share face to face (the same triangles wound both ways) is
   dropped, and each edge they share (4, 6 ... triangles) is taken apart per body
   (:func:`split_edges`); if that does not close it, :class:`InputError` counting the
   open and the non-manifold edges;
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

And, for a closed mesh whose triangles cross a little (:func:`resolve_crossings`):

6. the self-union (libigl's exact boolean): the outer surface of what it encloses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .mesh import edge_report, edge_slot_pairs
from .overlap import SPECK, _shell_volumes

__all__ = ["repair_closed", "CrossingRepair", "resolve_crossings", "repair_crossings", "split_pinches", "split_edges", "flip_needles", "pull_apart", "drop_specks", "cavity_faces"]


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


def _clean(v: np.ndarray, f: np.ndarray, cancel: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Drop triangles with a repeated vertex or the vertex set of an earlier one, then
    the vertices no triangle uses. ``cancel``: where as many of one vertex set run one
    way as the other (the wall two bodies share face to face, each wound outward), all
    go: what is left is their union."""
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 2] != f[:, 0])]
    s = np.sort(f, axis=1)
    _, first, group = np.unique(s, axis=0, return_index=True, return_inverse=True)
    if cancel:
        turn = np.where(np.argmin(f, axis=1)[:, None] == np.arange(3), np.roll(f, -1, axis=1), 0).sum(axis=1)
        way = np.where(turn == s[:, 1], 1, -1)  # +1: min -> mid -> max in the winding's order
        first = first[np.bincount(group.ravel(), weights=way) != 0]
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


def _touching(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, str]:
    """``(v, f, note)``: ``(v, f)`` cleaned (:func:`_clean`), or, where that is not
    closed, with bodies that touch taken apart or united: a wall two of them share
    face to face dropped (``cancel=True``), then each edge they share taken apart
    (:func:`split_edges`), if that closes them; ``note`` says what was done ("" if
    nothing)."""
    cv, cf = _clean(v, f)
    if not len(cf) or _edge_pairs(cf)[0] is not None:
        return cv, cf, ""
    uv, uf = _clean(v, f, cancel=True)
    tv, tf, _ = split_edges(uv, uf)
    if not (len(tf) and _edge_pairs(tf)[0] is not None):
        return cv, cf, ""
    walls, edges = len(cf) - len(uf), edge_report(uf)["nonmanifold"]
    done = [f"{walls} triangles of walls shared face to face dropped (the bodies united there)"] if walls else []
    done += [f"{edges} edges shared by more than two triangles taken apart (bodies touching along them)"] if edges else []
    return tv, tf, "; ".join(done)


#: Vertices of a closed mesh closer than this (mm) are one where the mesh stays closed
#: (:func:`_merge_near`): a texture grid puts points on a needle's two long sides that
#: lie closer than a float32 step (7.6e-6 mm at 65 mm) near its tip and meet when
#: written; PrusaSlicer's extruder_idler.obj has a short side of 7.9e-6 mm. Under half
#: :data:`PULL`'s 2 um, so walls pulled apart stay apart.
NEAR = 5e-4


def _merge_near(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A closed mesh ``(v, f)`` with vertices closer than :data:`NEAR` merged (each
    group of neighbours, transitively, to its first vertex; triangles left degenerate
    dropped), if that leaves it closed with as many shells; else as it is."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(v).query_pairs(NEAR, output_type="ndarray")
    if not len(pairs):
        return v, f
    n = len(v)
    _, group = connected_components(coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)), directed=False)
    first = np.full(int(group.max()) + 1, n, dtype=np.int64)
    np.minimum.at(first, group, np.arange(n))
    mv, mf = _clean(v, first[group][f])
    if not len(mf) or _edge_pairs(mf)[0] is None or _shell_count(mf) != _shell_count(f):
        return v, f
    return mv, mf


#: A triangle no higher than this over its longest side (mm) is a needle: its third
#: point lies on that side (a T-junction stitched with a zero-area triangle).
NEEDLE = 1e-6


def flip_needles(v: np.ndarray, f: np.ndarray, passes: int = 32) -> tuple[np.ndarray, int]:
    """A closed mesh's needles (:data:`NEEDLE`) removed by flipping their longest side:
    the needle ``(p, q, m)``, ``m`` on ``pq``, and the triangle across ``pq``,
    ``(q, p, x)``, become ``(p, x, m)`` and ``(x, q, m)`` - the same surface, no
    triangle of zero area. Needles beside needles wait for a later pass. Returns
    ``(faces, needles flipped)``; the faces unchanged where a flip would leave the
    mesh open or an edge doubled."""
    f0, g, done = f, f.copy(), 0
    for _ in range(passes):  # each pass flips needles whose neighbours are not needles
        slots = edge_slot_pairs(g)
        p = v[g]
        side = p[:, [1, 2, 0]] - p
        length = np.sqrt(np.einsum("ijk,ijk->ij", side, side))
        k = np.argmax(length, axis=1)
        area2 = np.linalg.norm(np.cross(side[:, 0], side[:, 2]), axis=1)
        needle = area2 <= NEEDLE * np.maximum(length[np.arange(len(g)), k], 1e-300)
        if slots is None or not needle.any():
            break
        partner = np.empty(3 * len(g), dtype=np.int64)
        partner[slots[:, 0]], partner[slots[:, 1]] = slots[:, 1], slots[:, 0]
        t = np.flatnonzero(needle)
        across = partner[3 * t + k[t]]
        other = across // 3
        ok = ~needle[other]
        t, across, other = t[ok], across[ok], other[ok]
        _, first = np.unique(other, return_index=True)
        t, across, other = t[first], across[first], other[first]
        if not len(t):
            break
        kt, ko = k[t], across % 3
        pp, q, m = g[t, kt], g[t, (kt + 1) % 3], g[t, (kt + 2) % 3]
        x = g[other, (ko + 2) % 3]
        g[t], g[other] = np.stack([pp, x, m], 1), np.stack([x, q, m], 1)
        done += len(t)
    if done and (edge_slot_pairs(g) is None or len(np.unique(np.sort(g, axis=1), axis=0)) < len(g)):
        return f0, 0
    return g, done


def repair_closed(vertices: np.ndarray, faces: np.ndarray, *, merge: float = 1e-8, name: str = "the mesh",
                  notes: list | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Closed, consistently wound, outward bodies from a triangle soup (module
    docstring). Returns ``(vertices float64 (N, 3) mm, faces int64 (M, 3), bodies)``,
    ``bodies`` the outer shells (a cavity's wall is no body: the gate counts so).

    Args:
        vertices: ``(N, 3)`` mm. faces: ``(M, 3)`` vertex indices.
        merge: vertices closer than this (mm, per coordinate after rounding) are one.
        name: how error messages call the mesh.
        notes: given, a sentence is appended for each change to the surface beyond
            merging points and dropping degenerate triangles (walls of touching
            bodies dropped, edges they share taken apart).

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
    mv, mf, note = _touching(*_merge(v, f, merge))
    closed = bool(len(mf)) and _edge_pairs(mf)[0] is not None
    if closed:
        mv, mf = _merge_near(mv, mf)  # stays closed (or is left as it was)
    indexed = False
    if len(mf) and not closed:  # closed only as indexed (a 3MF keeps points apart that touch)
        iv, i_f = _clean(v, f)
        indexed = bool(len(i_f)) and _edge_pairs(i_f)[0] is not None
        mv, mf = (iv, i_f) if indexed else (mv, mf)
    v, f = mv, mf
    if note and not indexed and notes is not None:
        notes.append(note)
    if not len(f):
        raise InputError(f"{name} holds no triangles (after dropping degenerate ones)")
    tri, same = _edge_pairs(f)
    if tri is None:
        bad = edge_report(f)
        what = ("close the holes" if bad["boundary"] else
                "its non-manifold edges (each in more than two triangles) are objects or walls that overlap or "
                "touch, or a surface folded onto itself: make one closed surface per body")
        raise InputError(
            f"{name} is not closed after repair ({bad['boundary']} open edges, {bad['nonmanifold']} non-manifold "
            f"edges); texcad textures closed solids: {what} (e.g. in the CAD program or a mesh repair tool) and "
            "export it again"
        )
    flip, body = _parity(tri, same, len(f))
    if np.any(same ^ flip[tri[:, 0]] ^ flip[tri[:, 1]]):
        raise InputError(f"{name} has a one-sided (Moebius-like) body: no winding makes it closed and oriented; fix it in the CAD program")
    p = v[f]
    det = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])) * np.where(flip, -1.0, 1.0)
    inward = _depths(p, body) % 2 == 1  # a cavity's shell faces into the cavity
    flip ^= ((np.bincount(body, weights=det) < 0) != inward)[body]
    f[flip] = f[flip][:, ::-1]
    f, _ = flip_needles(v, f)  # wound alike now: each needle's neighbour runs its long side the other way
    if indexed:
        v = pull_apart(v, f)
    return v, f, int((~inward).sum())


#: How far (mm) :func:`pull_apart` moves each copy of a point two walls share.
PULL = 1e-3


def pull_apart(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """A closed, outward mesh whose walls touch along edges only by position (distinct
    vertices at one point: walls of zero thickness between them, as PrusaSlicer's 3MF
    keeps them) with each such vertex moved :data:`PULL` mm inwards (against its
    area-weighted normal): a gap of about 2 um, so that a reader that joins points by
    position (an STL, the gate) finds every edge in two triangles."""
    key = np.unique(np.asarray(v, np.float32), axis=0, return_inverse=True)[1].ravel()
    w = key[f]
    ends = np.sort(np.stack([w.ravel(), w[:, [1, 2, 0]].ravel()], axis=1), axis=1)
    _, inv, count = np.unique(ends, axis=0, return_inverse=True, return_counts=True)
    crowded = count[inv.ravel()] > 2
    if not crowded.any():
        return v
    move = np.unique(np.concatenate([f.ravel()[np.flatnonzero(crowded)], f[:, [1, 2, 0]].ravel()[np.flatnonzero(crowded)]]))
    p = v[f]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    vn = np.zeros_like(v)
    for k in range(3):  # per corner of the triangles
        np.add.at(vn, f[:, k], n)
    out = v.copy()
    d = vn[move] / np.maximum(np.linalg.norm(vn[move], axis=1, keepdims=True), 1e-300)
    out[move] -= PULL * d
    return out


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


# -- small self-intersections (issue 27: 3DBenchy's 23 crossing pairs) ------------------------

#: A crossing is repaired when the self-union changes the volume by at most this share...
MAX_VOLUME_CHANGE = 0.01
#: ...and the crossing triangles hold at most this share of the surface area; beyond, the
#: mesh is refused (a fold, overlapping bodies: what the user must decide).
MAX_CROSSING_AREA = 0.5
#: Distances (mm) within which the union's vertices (rounded to float32) are snapped together
#: (:func:`_snap`), tried in order: the coarsest first, which also closes the union's edges
#: of a few nm (new vertices beside old ones) that the displacement cannot keep apart.
MERGE = (1e-4, 1e-5, 1e-8)
#: A repaired mesh with an edge shorter than this (mm) is not used: displaced and written
#: in float32 its ends can meet (the test meshes: 9e-5 mm textures, 2e-6 mm tears).
MIN_EDGE = 2e-5
#: Tolerances (mm) of manifold3d's edge collapse (``Manifold.simplify``), tried in order
#: when the snapped union still has edges under :data:`MIN_EDGE` (a real flashlight
#: handle's union: 6e-8 mm edges that snapping cannot merge without a non-manifold edge).
COLLAPSE = (1e-5, 1e-4)


def _shell_count(f: np.ndarray) -> int:
    from .overlap import _shell_labels

    return int(_shell_labels(f).max()) + 1


@dataclass(frozen=True)
class CrossingRepair:
    """What :func:`resolve_crossings` did to a mesh whose triangles crossed a little.

    Attributes:
        pairs: pairs of triangles that crossed.
        triangles: ``(before, after)`` triangle counts.
        volume: ``(before, after)`` enclosed volume, mm^3.
        bodies: closed bodies after the repair.
    """

    pairs: int
    triangles: tuple
    volume: tuple
    bodies: int

    @property
    def note(self) -> str:
        """One line for the result's info and the warning."""
        return (f"{self.pairs} pairs of crossing triangles resolved by a self-union (outer surface kept): volume "
                f"{self.volume[0]:.4g} -> {self.volume[1]:.4g} mm3, {self.triangles[0]} -> {self.triangles[1]} triangles")


def _volume(v: np.ndarray, f: np.ndarray) -> float:
    p = v[f]
    return float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


def _areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    p = v[f]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def _split_corners(v: np.ndarray, f: np.ndarray, label: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Each vertex made one vertex per fan of its corners, the corners of a vertex joined
    through the edges (slot ``(t, k)``: ``f[t, k] -> f[t, k+1]``) that share a ``label``
    ``(3M,)``. Returns ``(vertices, faces, vertices added)``."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = len(f)
    lab = label.reshape(m, 3)
    corner = np.repeat(np.arange(3 * m), 2)  # corner (t, k) touches edge slots (t, k) and (t, k-1)
    edge = np.stack([lab, lab[:, [2, 0, 1]]], axis=2).ravel()
    vert = np.repeat(f.ravel(), 2)
    order = np.lexsort((vert, edge))
    e, w, c = edge[order], vert[order], corner[order]
    same = (e[1:] == e[:-1]) & (w[1:] == w[:-1])  # the same edge, at the same vertex
    _, fan = connected_components(coo_matrix((np.ones(int(same.sum())), (c[:-1][same], c[1:][same])), shape=(3 * m, 3 * m)),
                                  directed=False)
    pair = np.stack([f.ravel(), fan])  # (vertex, fan) of each corner
    uniq, inv = np.unique(pair, axis=1, return_inverse=True)
    added = int(uniq.shape[1] - len(np.unique(f)))
    if added == 0:
        return v, f, 0
    return v[uniq[0]], inv.reshape(m, 3).astype(np.int64), added


def _edge_labels(f: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per edge slot ``(3M,)``: its undirected edge's number, how many slots that edge
    has, and the slot's ``(lo, hi)`` vertices ``(3M, 2)``."""
    ends = np.sort(np.stack([f.ravel(), f[:, [1, 2, 0]].ravel()], axis=1), axis=1)
    _, label, count = np.unique(ends, axis=0, return_inverse=True, return_counts=True)
    label = label.ravel()
    return label, count[label], ends


def split_pinches(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """A closed, edge-manifold mesh whose surface touches itself at single vertices
    (two fans of triangles around one vertex that share no edge there) with each such
    vertex made one vertex per fan, at the same place. Returns ``(vertices, faces,
    vertices split)``. The corners of one vertex are joined through the edges at that
    vertex (connected components of corners)."""
    return _split_corners(v, f, _edge_labels(f)[0])


#: Radians within which faces around an edge are at one angle (two bodies face to face).
_SAME_ANGLE = 1e-9


def split_edges(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Bodies that touch along an edge (an edge of 4, 6 ... triangles: two solids
    exported in one file, a shaft on a knob) taken apart there. Around such an edge
    (axis ``a -> b``, ``a < b``) each triangle's third vertex has an angle ``theta``
    and the triangle's normal ``n`` (as wound, the mesh's signed volume made positive)
    points to smaller or larger angles: ``s = sign(n . (axis x r))`` with ``r`` the
    third vertex's direction off the axis. Sorted by ``theta`` (at equal angles, the
    faces of two bodies touching face to face, ``s > 0`` first), the signs alternate
    where solid wedges alternate with empty ones; each triangle with ``s < 0`` (solid
    towards larger angles) is paired with the next one, and the vertices are split per
    pair (:func:`_split_corners`). Edges whose signs do not alternate stay as they are.
    Returns ``(vertices, faces, vertices added)``."""
    label, count, ends = _edge_labels(f)
    many = np.flatnonzero((count > 2) & (count % 2 == 0))
    if not len(many):
        return v, f, 0
    tri = many // 3
    p = v[f[tri]]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal *= np.sign(np.einsum("ij,ij->i", v[f][:, 0], np.cross(v[f][:, 1], v[f][:, 2])).sum()) or 1.0
    lo, hi = v[ends[many, 0]], v[ends[many, 1]]
    axis = (hi - lo) / np.linalg.norm(hi - lo, axis=1, keepdims=True)
    third = v[f.ravel()[3 * tri + (many + 2) % 3]] - lo
    r = third - np.einsum("ij,ij->i", third, axis)[:, None] * axis
    order = np.lexsort((np.arange(len(many)), label[many]))
    first = np.r_[True, label[many][order][1:] != label[many][order][:-1]]
    ref = r[order][np.maximum.accumulate(np.where(first, np.arange(len(order)), 0))]  # each edge's first slot
    ref_of = np.empty_like(ref)
    ref_of[order] = ref
    theta = np.arctan2(np.einsum("ij,ij->i", np.cross(axis, ref_of), r), np.einsum("ij,ij->i", ref_of, r)) % (2 * np.pi)
    theta[theta > 2 * np.pi - _SAME_ANGLE] = 0.0
    opens = np.einsum("ij,ij->i", normal, np.cross(axis, r)) < 0
    order = np.lexsort((theta, label[many]))
    step = np.r_[True, (np.diff(theta[order]) > _SAME_ANGLE) | (np.diff(label[many][order]) != 0)]
    tie = np.empty(len(order), dtype=np.int64)
    tie[order] = np.cumsum(step)  # faces at one angle (coplanar) share a rank
    order = np.lexsort((opens, tie))  # at one angle a wedge closes before the next opens
    start = np.flatnonzero(np.r_[True, label[many][order][1:] != label[many][order][:-1]])
    size = np.diff(np.r_[start, len(order)])
    group = np.repeat(np.arange(len(start)), size)
    pos = np.arange(len(order)) - start[group]
    nxt = start[group] + (pos + 1) % size[group]  # the next slot around the edge, cyclically
    o = opens[order]
    ok = np.ones(len(start), dtype=bool)
    np.logical_and.at(ok, group, o != o[nxt])
    pair = np.where(o, pos, (pos - 1) % size[group])  # an opener's own position, a closer's opener's
    new = label.copy()
    keep = ok[group]
    new[many[order][keep]] = label.max() + 1 + start[group][keep] + pair[keep]
    return _split_corners(v, f, new)


def drop_specks(v: np.ndarray, f: np.ndarray, name: str = "the mesh") -> tuple[np.ndarray, np.ndarray, int, int]:
    """A repaired mesh without its specks (shells under :data:`SPECK` mm^3, when any
    other shell is left): ``(vertices, faces, bodies, specks dropped)``."""
    label, vol = _shell_volumes(v, f)
    speck = np.abs(vol) < SPECK
    if not speck.any() or speck.all():
        return v, f, int((vol > 0).sum()), 0
    rv, rf, bodies = repair_closed(v, f[~speck[label]], name=name)
    return rv, rf, bodies, int(speck.sum())


def cavity_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``(M,)`` bool: the faces of a closed, repaired mesh (:func:`repair_closed`)
    that line a sealed cavity (shells of negative signed volume, wound into the void)."""
    label, vol = _shell_volumes(np.asarray(vertices, np.float64), np.asarray(faces, np.int64))
    return (vol < 0)[label]


def _without_slivers(v: np.ndarray, f: np.ndarray, least: float, name: str):
    """``(v, f, bodies)`` without the shells that enclose less than ``least`` mm^3."""
    label, vol = _shell_volumes(v, f)
    keep = np.abs(vol) >= least
    if keep.all():
        return v, f, int((vol > 0).sum())
    return repair_closed(v, f[keep[label]], name=name)


def _snap(v: np.ndarray, f: np.ndarray, d: float) -> np.ndarray:
    """``f`` with every vertex within ``d`` mm of another (transitively) replaced by the
    first of its cluster (scipy's k-d tree: pairs across grid lines too)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(v).query_pairs(d, output_type="ndarray")
    if not len(pairs):
        return f
    n = len(v)
    _, lab = connected_components(coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n)), directed=False)
    first = np.full(int(lab.max()) + 1, n, dtype=np.int64)
    np.minimum.at(first, lab, np.arange(n))
    return first[lab][f]


def _shortest(v: np.ndarray, f: np.ndarray) -> float:
    """The shortest edge of the triangles ``f`` of ``v``, mm."""
    from .subdivide import edge_lengths

    return float(edge_lengths(v, f).min())


def _collapsed(v: np.ndarray, f: np.ndarray, bodies: int, short: float, name: str):
    """``(v, f, bodies, shortest edge)`` with the union's too-short edges collapsed by
    manifold3d's ``simplify`` (edges collapsed where that moves the surface by at most
    :data:`COLLAPSE` mm), the first tolerance that leaves no edge under
    :data:`MIN_EDGE`, no crossing and the same bodies; or the input as it was."""
    from .boolean import from_manifold
    from .intersect import self_intersections
    from .overlap import _manifold

    solid = _manifold(v, f)
    for tol in COLLAPSE:
        out = from_manifold(solid.simplify(tol))
        sv, sf = np.asarray(out.vertices, np.float64), np.asarray(out.faces, np.int64)
        if len(sf) and _shortest(sv, sf) >= MIN_EDGE and not len(self_intersections(sv, sf)):
            rv, rf, nb = repair_closed(sv, sf, merge=1e-8, name=name)
            if nb == bodies:
                return rv, rf, nb, _shortest(rv, rf)
    return v, f, bodies, short


def _unrepaired(v: np.ndarray, f: np.ndarray, cross: np.ndarray, name: str, why: str):
    """InputError: the crossings were small but the self-union gave no clean solid."""
    at = v[f[cross[0]]].reshape(-1, 3).mean(axis=0)
    raise InputError(
        f"{name} intersects itself: {len(cross)} pairs of its triangles cross (one near ({at[0]:.2f}, {at[1]:.2f}, "
        f"{at[2]:.2f}) mm), and texcad's repair, a self-union of the mesh, gives no clean solid ({why}); repair it in a "
        "mesh tool (a 'make solid' or remesh repair, or manifold3d / trimesh.boolean.union of its parts) and export it again"
    )


def resolve_crossings(vertices: np.ndarray, faces: np.ndarray, *, name: str = "the mesh"):
    """A closed, oriented mesh whose triangles cross a little (a fillet poking through
    a wall, two features stitched into one shell) made into one that does not: the
    self-union, the region of positive winding number, whose surface is the outer
    surface of what the mesh encloses (libigl's exact mesh boolean, CGAL kernels,
    union with nothing), then :func:`repair_closed`.

    Only small crossings are repaired: the union changes the volume by at most
    :data:`MAX_VOLUME_CHANGE` and the crossing triangles hold at most
    :data:`MAX_CROSSING_AREA` of the area; a mesh that does not cross is returned as
    it is. Anything else (a fold, bodies pushed into each other) is returned as it is
    too, for the self-intersection test to refuse with its reasons.

    Raises:
        InputError: the crossings are small but their self-union is no clean solid
            (its surface touches itself along edges, or leaves edges too short to
            texture): the message says so and where the mesh crosses.

    Args:
        vertices: ``(N, 3)`` float64 mm. faces: ``(M, 3)`` int64, closed and oriented
            (:func:`repair_closed`).
        name: how messages call the mesh.

    Returns:
        ``(vertices, faces, repair)``: float64 ``(N', 3)`` mm, int64 ``(M', 3)`` and a
        :class:`CrossingRepair`, or the input and None.
    """
    from ..errors import TexcadError
    from .intersect import self_intersections

    v, f = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    cross = self_intersections(v, f)
    if not len(cross):
        return v, f, None
    area = _areas(v, f)
    if area[np.unique(cross)].sum() > MAX_CROSSING_AREA * area.sum():
        return v, f, None
    try:
        import igl.copyleft.cgal as cgal
    except ImportError:  # pragma: no cover - libigl is a dependency; a build without CGAL
        return v, f, None
    uv, uf, _ = cgal.mesh_boolean(v, f, np.zeros((0, 3)), np.zeros((0, 3), np.int64), "union")
    uv = uv.astype(np.float32).astype(np.float64)  # vertices as the output will hold them: ones that meet merge now
    before, shells = _volume(v, f), int(_shell_count(f))
    for merge in MERGE:  # the union's new vertices may lie closer than float32 tells apart: merged at the coarsest that works
        try:
            rv, rf, bodies = repair_closed(uv, _snap(uv, uf, merge), merge=1e-8, name=name)
            if bodies > 1:  # the union may leave slivers of no volume where surfaces met: dropped
                rv, rf, bodies = _without_slivers(rv, rf, 1e-9 * abs(before) + 1e-9, name)
        except TexcadError:  # the union touches itself along an edge (non-manifold) at this merge distance
            continue
        if not len(self_intersections(rv, rf)):
            break
    else:
        _unrepaired(v, f, cross, name, "its outer surface touches itself along edges or still crosses")
    after = _volume(rv, rf)
    if abs(after - before) > MAX_VOLUME_CHANGE * abs(before) or bodies > shells:  # a large change, or bodies split off
        return v, f, None
    short = _shortest(rv, rf)
    if short < MIN_EDGE:  # edges the displacement cannot keep apart: collapsed, or refused
        rv, rf, bodies, short = _collapsed(rv, rf, bodies, short, name)
    if short < MIN_EDGE:
        _unrepaired(v, f, cross, name, f"it leaves edges of {short:.2g} mm, too short to texture")
    rv, rf, _ = split_pinches(rv, rf)  # the outer surface touches itself at a vertex: one vertex per fan
    return rv, rf, CrossingRepair(int(len(cross)), (int(len(f)), int(len(rf))), (before, after), int(bodies))


def repair_crossings(vertices: np.ndarray, faces: np.ndarray, bodies: int, info: dict, name: str = "the mesh"):
    """:func:`resolve_crossings` for the mesh adapter: ``(vertices, faces, bodies)``
    repaired or as they were; a repair is noted in ``info["repaired"]`` (with
    ``info["crossings_repaired"]``, the pairs) and told in a
    :class:`~texcad.errors.TexcadWarning`."""
    import warnings

    from ..errors import TexcadWarning

    v, f, rep = resolve_crossings(vertices, faces, name=name)
    if rep is None:
        return v, f, bodies
    note = rep.note
    info.update(repaired="; ".join(filter(None, [info.get("repaired"), note])), crossings_repaired=rep.pairs,
                repaired_triangles=int(len(f)), bodies=rep.bodies)
    warnings.warn(TexcadWarning(f"{name}: {note}"), stacklevel=2)
    return v, f, rep.bodies
