"""Error-driven adaptive tessellation for displacement (``tolerance`` in mm).

:func:`texcad.solid.subdivide.refine` cuts every face of a region into the grid
whose edges are at most ``pitch`` mm: the *pitch grid*. Where the displacement ``d``
is flat or linear that grid holds many triangles that carry nothing. Here every face
of the coarse mesh (after :func:`~texcad.solid.subdivide.coarsen`) gets its own grid
level ``L <= M`` (``M`` its pitch-grid level), each edge the finest count either of
its faces asks for (:func:`~texcad.solid.subdivide.tessellate` keeps the mesh
conforming), and the result is measured against the pitch grid's points:

* the *samples* (:func:`pitch_samples`) are the points the pitch grid would have: on
  every edge ``t = k / n`` (``n`` its pitch count), inside every face the level-``M``
  grid's inner points;
* the *error* (:func:`measure`) at a sample is ``|d(x) - sum_k w_k d_k| max_k |n_k|``:
  the texture's displacement at the sample against the mesh's, linear over the
  output triangle ``(w_k, d_k)`` that holds it, measured along the displacement
  direction (``|n_k| >= 1`` scales it up at sharp edges, where vertices move along
  the diagonal). Points along an edge are found on the edge's own points, inner
  points in the triangles of their face (each tested against every triangle of its
  face, a handful, in one vectorized pass); a sample that no triangle holds is an
  error (``AssertionError``), so the measurement covers every sample. Where the
  output is the pitch grid itself the samples are its vertices (error 0) and are
  skipped.

The points' normals and displacement directions come from the coarse mesh by kind
(a vertex: its angle-weighted normal; a point on an edge: the mean of the two faces'
normals; a point inside a face: its normal), which is what
:func:`~texcad.solid.subdivide.vertex_normals` gives on any subdivision of it.

Faces whose error exceeds the tolerance are set to their pitch level, where the
mesh has a vertex at every sample (error 0): the driver
(:func:`texcad.targets.mesh.MeshAdapter`) repeats until none does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..util import argsort_ints, rowall, rowany, rowdot, rowmax, rownorm, split_rows
from .subdivide import _edges, edge_lengths, face_normals, offset_directions, rows, tessellate, vertex_normals

__all__ = ["Coarse", "coarse_mesh", "pitch_samples", "build", "carried", "measure"]


@dataclass
class Coarse:
    """A coarse closed mesh with what its tessellations need (lengths mm).

    Attributes:
        v: ``(N, 3)`` float64 vertices; f: ``(M, 3)`` int64 faces.
        edges: ``(E, 2)`` unique edges (smaller vertex first, sorted); eid: ``(M, 3)``
            each face's edges (corner k to k + 1); ef: ``(E, 2)`` each edge's faces.
        n: ``(E,)`` pitch counts (pieces of each edge in the pitch grid).
        level: ``(M,)`` pitch-grid level of each face (its largest count).
        fn: ``(M, 3)`` unit face normals; vn, vdir: ``(N, 3)`` unit vertex normals and
            displacement directions (:func:`~texcad.solid.subdivide.offset_directions`).
        en, edir: ``(E, 3)`` each edge's unit normal and displacement direction (made
            on first use).
        grid: ``(M, 2, 3)`` each face's map to its grid coordinates (made on first
            use, :func:`_grid_maps`).
    """

    v: np.ndarray
    f: np.ndarray
    edges: np.ndarray
    eid: np.ndarray
    ef: np.ndarray
    n: np.ndarray
    level: np.ndarray
    fn: np.ndarray
    vn: np.ndarray
    vdir: np.ndarray
    en: "np.ndarray | None" = None
    edir: "np.ndarray | None" = None
    grid: "np.ndarray | None" = None


def coarse_mesh(vertices: np.ndarray, faces: np.ndarray, pitch: np.ndarray) -> Coarse:
    """The :class:`Coarse` of a closed mesh; ``pitch`` ``(M,)`` is each face's longest
    edge after refinement, mm (inf: the face is not refined but along its edges)."""
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    edges, eid, order = _edges(f, slots=True, stable=True)
    ef = (order // 3).reshape(-1, 2)  # closed: two slots per edge
    per = np.where(np.isfinite(pitch)[:, None], np.ceil(edge_lengths(v, f) / np.where(np.isfinite(pitch), pitch, 1.0)[:, None] - 1e-9), 1)
    n = np.ones(len(edges), dtype=np.int64)
    np.maximum.at(n, eid.ravel(), per.astype(np.int64).ravel())
    fn, _ = face_normals(v, f)
    vn = vertex_normals(v, f)
    return Coarse(v, f, edges, eid, ef, n, rowmax(n[eid]), fn, vn, offset_directions(v, f, vn))


def _edge_frames(c: Coarse, e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normal and displacement direction ``(P, 3)`` at points inside edges ``e``:
    the two faces' normals averaged (their angles there are both 180 degrees), over
    ``min(1, n . n_f)`` (clipped at 1/3) as in ``offset_directions``."""
    if c.en is None:  # once per edge
        f1, f2 = c.ef[:, 0], c.ef[:, 1]
        s = c.fn[f1] + c.fn[f2]
        n = s / np.maximum(rownorm(s), 1e-300)[:, None]
        cos = np.minimum(rowdot(n, c.fn[f1]), rowdot(n, c.fn[f2]))
        c.en, c.edir = n, n / np.clip(cos, 1.0 / 3.0, 1.0)[:, None]
    return c.en[e], c.edir[e]


def pitch_samples(c: Coarse) -> dict:
    """The pitch grid's points but the corners: ``xyz`` ``(P, 3)`` mm, unit ``normal``,
    ``edge`` (edge id, -1 inside a face), ``t`` (along the edge from its smaller
    vertex), ``face`` (-1 on an edge), ``i``, ``j`` (grid point of the face's level
    ``level[face]``: ``w = (M - i - j, i, j) / M``)."""
    cnt = c.n - 1
    e = np.repeat(np.arange(len(c.edges)), cnt)
    k = np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt) + 1
    t = k / c.n[e]
    a, b = c.v[c.edges[e, 0]], c.v[c.edges[e, 1]]
    xyz, normal = [a * (1 - t)[:, None] + b * t[:, None]], [_edge_frames(c, e)[0]]
    face, ii, jj = [np.full(len(e), -1)], [np.zeros(len(e), np.int64)], [np.zeros(len(e), np.int64)]
    for lev in np.unique(c.level[c.level >= 3]):  # per grid level
        sel = np.flatnonzero(c.level == lev)
        i, j = np.meshgrid(np.arange(1, lev), np.arange(1, lev), indexing="ij")
        q = (i + j) < lev
        i, j = i[q], j[q]
        w = np.stack([lev - i - j, i, j], 1) / lev
        xyz.append(np.einsum("qk,gkx->gqx", w, c.v[c.f[sel]]).reshape(-1, 3))
        normal.append(np.repeat(c.fn[sel], len(i), axis=0))
        face.append(np.repeat(sel, len(i)))
        ii.append(np.tile(i, len(sel)))
        jj.append(np.tile(j, len(sel)))
    nf = sum(len(x) for x in face[1:])
    return {"xyz": np.concatenate(xyz), "normal": np.concatenate(normal), "edge": np.concatenate([e, np.full(nf, -1)]),
            "t": np.concatenate([t, np.zeros(nf)]), "face": np.concatenate(face), "i": np.concatenate(ii), "j": np.concatenate(jj)}


def edge_counts(c: Coarse, levels: np.ndarray, forced: np.ndarray) -> np.ndarray:
    """``(E,)`` pieces per edge: the finest ``ceil(n L / M)`` of its two faces at grid
    levels ``levels`` (``(M,)``), the pitch count ``n`` on ``forced`` edges."""
    s = levels / np.maximum(c.level, 1)
    want = np.maximum(rowmax(np.ceil(c.n[:, None] * s[c.ef] - 1e-9)), 1).astype(np.int64)
    return np.where(forced, c.n, np.minimum(want, c.n))


def build(c: Coarse, counts: np.ndarray) -> dict:
    """Tessellate with ``counts`` ``(E,)`` pieces per edge
    (:func:`~texcad.solid.subdivide.tessellate`). Returns ``v`` ``(N', 3)`` mm, ``f``,
    ``parent``, per vertex the unit ``normal`` and displacement direction ``dir``,
    ``edge_start`` ``(E,)`` (id of each edge's first inner point, -1 if none) and
    ``inner_start`` ``(M,)`` (id of each face's first inner point, -1 if none)."""
    cls: dict = {}
    v, f, parent = tessellate(c.v, c.f, counts[c.eid], classes=cls)
    nv = np.int64(len(c.v))
    mine = np.searchsorted(c.edges[:, 0] * nv + c.edges[:, 1], cls["edge_key"])  # tessellate's edges -> ours
    start = np.full(len(c.edges), -1, dtype=np.int64)
    start[mine] = cls["edge_start"]
    en, ed = _edge_frames(c, mine[cls["edge_point"]])
    fi = cls["inner_face"]
    normal = np.concatenate([c.vn, en, c.fn[fi]])
    direc = np.concatenate([c.vdir, ed, c.fn[fi]])
    inner = np.full(len(c.f), -1, dtype=np.int64)
    faces, first = np.unique(fi, return_index=True)
    inner[faces] = len(v) - len(fi) + first  # inner points come last, face by face
    return {"v": v, "f": f, "parent": parent, "normal": normal, "dir": direc, "edge_start": start, "inner_start": inner}


def carried(c: Coarse, before: np.ndarray, counts: np.ndarray, old: dict, new: dict) -> tuple[np.ndarray, np.ndarray]:
    """Vertices two tessellations (:func:`build`, edge counts ``before`` and
    ``counts`` ``(E,)``) share at the same place: ``(ids in new, ids in old)``. The
    corners always; an edge's inner points where its count is the same; a face's
    inner points where its three counts are (its grid level and points then are)."""
    nc = len(c.v)
    same_e = np.flatnonzero((before == counts) & (counts > 1))
    k = counts[same_e] - 1
    same_f = np.flatnonzero(rowall(before[c.eid] == counts[c.eid]) & (new["inner_start"] >= 0))
    lev = rowmax(counts[c.eid[same_f]])
    q = (lev - 1) * (lev - 2) // 2  # inner points of a level-L grid
    starts_new = np.r_[new["edge_start"][same_e], new["inner_start"][same_f]]
    starts_old = np.r_[old["edge_start"][same_e], old["inner_start"][same_f]]
    size = np.r_[k, q]
    off = np.arange(int(size.sum())) - np.repeat(np.cumsum(size) - size, size)
    ids_new = np.r_[np.arange(nc), np.repeat(starts_new, size) + off]
    ids_old = np.r_[np.arange(nc), np.repeat(starts_old, size) + off]
    return ids_new, ids_old


def _on_edges(c: Coarse, counts, out, d, dlen, s, ds):
    """Errors at the edge samples: linear between the edge's own points."""
    e = s["edge"]
    t, ce = s["t"], counts[e]
    j = np.minimum(np.floor(t * ce + 1e-12).astype(np.int64), ce - 1)
    fr = t * ce - j

    def point(k):
        inner = out["edge_start"][e] + k - 1
        return np.where(k == 0, c.edges[e, 0], np.where(k == ce, c.edges[e, 1], inner))

    a, b = point(j), point(j + 1)
    return np.abs(ds - (d[a] * (1 - fr) + d[b] * fr)) * np.maximum(dlen[a], dlen[b])


def _grid_maps(c: Coarse) -> np.ndarray:
    """``(M, 2, 3)`` per face the rows ``A``, ``B`` with ``(i, j) = (r . A, r . B)``
    for ``r = x - a`` (the inverse of ``x = a + i/L e1 + j/L e2`` in the face's
    plane, ``L`` its pitch level; made once)."""
    if c.grid is None:
        a = rows(c.v, c.f[:, 0])
        e1, e2 = rows(c.v, c.f[:, 1]) - a, rows(c.v, c.f[:, 2]) - a
        g11, g12, g22 = rowdot(e1, e1), rowdot(e1, e2), rowdot(e2, e2)
        m = (c.level / (g11 * g22 - g12 * g12))[:, None]
        c.grid = np.stack([m * (g22[:, None] * e1 - g12[:, None] * e2), m * (g11[:, None] * e2 - g12[:, None] * e1)], 1)
    return c.grid


def _grid_xy(c: Coarse, out, tri: np.ndarray) -> np.ndarray:
    """``(T, 3, 2)`` grid coordinates of output triangles' corners in their parent
    face: ``(i, j)`` of ``a + i/M (b - a) + j/M (c - a)``, ``M`` its pitch level."""
    p = out["parent"][tri]
    g = np.take(_grid_maps(c), p, axis=0)
    a = rows(c.v, np.take(c.f[:, 0], p))
    xy = np.empty((len(tri), 3, 2))
    for k in range(3):  # per corner
        r = rows(out["v"], np.take(out["f"][:, k], tri)) - a
        xy[:, k, 0] = rowdot(r, g[:, 0])
        xy[:, k, 1] = rowdot(r, g[:, 1])
    return xy


def _face_triangles(c: Coarse, out) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Output triangles grouped by parent face: ``(order, first, count)``, the
    triangles of face ``p`` being ``order[first[p]:first[p] + count[p]]``."""
    par = out["parent"]
    order = argsort_ints(par)
    count = np.bincount(par, minlength=len(c.f))
    return order, np.cumsum(count) - count, count


def _in_faces(c: Coarse, out, groups, d, dlen, s, ds, inner):
    """Errors at the inner samples ``inner`` (indices into ``s``): each tested against
    every output triangle of its face (a handful: faces are at most a few pitches;
    ``groups`` from :func:`_face_triangles`), the largest over the triangles that
    hold it."""
    order, first, count = groups
    fs = s["face"][inner]
    n = count[fs]
    k = np.repeat(np.arange(len(inner)), n)
    tri = order[np.repeat(first[fs], n) + np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)]
    used, slot = np.unique(tri, return_inverse=True)
    xy = _grid_xy(c, out, used)[slot]
    x0, y0 = xy[:, 0, 0], xy[:, 0, 1]
    ax, ay, bx, by = xy[:, 1, 0] - x0, xy[:, 1, 1] - y0, xy[:, 2, 0] - x0, xy[:, 2, 1] - y0
    den = ax * by - ay * bx
    px, py = s["i"][inner][k] - x0, s["j"][inner][k] - y0
    l1 = (px * by - py * bx) / den
    l2 = (ax * py - ay * px) / den
    l0 = 1.0 - l1 - l2
    eps = 1e-9
    hit = (l0 >= -eps) & (l1 >= -eps) & (l2 >= -eps) & (den > 0)
    fv = out["f"][tri[hit]]
    val = l0[hit] * d[fv[:, 0]] + l1[hit] * d[fv[:, 1]] + l2[hit] * d[fv[:, 2]]
    err = np.full(len(inner), -1.0)
    np.maximum.at(err, k[hit], np.abs(ds[inner][k[hit]] - val) * rowmax(dlen[fv]))
    return err


def measure(
    c: Coarse, counts: np.ndarray, out: dict, d: np.ndarray, s: dict, ds: np.ndarray, *, exhaustive: bool = False,
    faces: "np.ndarray | None" = None,
) -> tuple[np.ndarray, float]:
    """Per sample error (mm; module docstring) of the output ``out`` (:func:`build`)
    with vertex displacements ``d`` against the samples' displacements ``ds``
    (NaN: not measured); returns ``(per face largest error (M,), largest)``.

    Where the output is the pitch grid itself (an edge cut into its pitch count, a
    face whose edges all are) the samples are its vertices, evaluated by the same
    function: their error is 0 and they are skipped unless ``exhaustive``. With
    ``faces`` ``(M,)`` bool only the samples of those faces are measured (0
    elsewhere): a face whose three edge counts are those of an earlier measurement
    has the same triangles and vertices, so its error is that one's. The samples
    are measured on every core (:func:`texcad.util.split_rows`)."""
    dlen = rownorm(out["dir"])
    err = np.zeros(len(ds))
    e_exact = counts == c.n
    f_exact = rowall(e_exact[c.eid])
    e, fc = s["edge"], s["face"]
    skip = ~exhaustive & np.where(e >= 0, e_exact[np.maximum(e, 0)], f_exact[np.maximum(fc, 0)])
    if faces is not None:
        skip |= ~np.where(e >= 0, rowany(faces[c.ef[np.maximum(e, 0)]]), faces[np.maximum(fc, 0)])
    on_edge = np.flatnonzero((e >= 0) & np.isfinite(ds) & ~skip)
    sub = {k: v[on_edge] for k, v in s.items()}
    err[on_edge] = _on_edges(c, counts, out, d, dlen, sub, ds[on_edge])
    inner = np.flatnonzero((e < 0) & np.isfinite(ds) & ~skip)
    if len(inner):
        groups = _face_triangles(c, out)
        e_in = np.concatenate(split_rows(lambda r: _in_faces(c, out, groups, d, dlen, s, ds, inner[r]), len(inner)))
        if np.any(e_in < 0):
            raise AssertionError(f"{int((e_in < 0).sum())} samples lie in no output triangle")  # pragma: no cover
        err[inner] = e_in
    per_face = np.zeros(len(c.f))
    np.maximum.at(per_face, c.ef[s["edge"][on_edge]].ravel(), np.repeat(err[on_edge], 2))
    np.maximum.at(per_face, s["face"][inner], err[inner])
    return per_face, float(err.max()) if len(err) else 0.0
