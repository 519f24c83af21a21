"""Solids: CAD shapes to meshes, and the manifold3d union of texture and base.

This stage replaces the paper's Rhino/Grasshopper sweep (section 2.3): the textured
slab from :mod:`texcad.solid` is unioned onto the base body with manifold3d, whose
booleans are guaranteed to return an oriented 2-manifold. A relief standing on a
planar face with nothing above it can instead be stitched into the body's mesh
without a boolean (:func:`fuse_on_plane`), checked independently (closed and
oriented, areas, volume).

A *base* can be a build123d ``Shape`` (``Part``, ``Solid``, ``Compound``), a CadQuery
``Workplane`` or ``Shape`` (both wrap the same OCP ``TopoDS_Shape``), a raw
``TopoDS_Shape``, a :class:`~texcad.solid.Mesh`, or a ``manifold3d.Manifold``.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from ..errors import GeometryError, ParameterError
from .mesh import Mesh, _edge_keys, closed_and_oriented, edge_report

__all__ = [
    "to_manifold",
    "from_manifold",
    "fuse",
    "retain_freed_memory",
    "clip_above_plane",
    "boundary_loops",
    "fuse_on_plane",
]


def to_manifold(obj: Any):
    """A ``manifold3d.Manifold`` from a :class:`Mesh` or a Manifold.

    Raises:
        GeometryError: the mesh is not an oriented, closed 2-manifold.
    """
    import manifold3d as m3d

    if isinstance(obj, m3d.Manifold):
        return obj
    if not isinstance(obj, Mesh):
        raise ParameterError(
            f"cannot make a manifold3d solid of a {type(obj).__name__}; pass a texcad Mesh "
            "(a CAD shape: tessellate it first with texcad.brep.shape_to_mesh(shape))"
        )
    mesh = obj
    man = m3d.Manifold(m3d.Mesh(vert_properties=mesh.vertices, tri_verts=mesh.faces))
    status = man.status()
    if status != m3d.Error.NoError:
        raise GeometryError(
            f"the mesh is not a closed, oriented solid (manifold3d: {status.name}); "
            "check that the base body is a closed solid"
        )
    return man


def from_manifold(man) -> Mesh:
    """A :class:`Mesh` (float32 vertices, uint32 faces) from a ``manifold3d.Manifold``."""
    out = man.to_mesh()
    # manifold3d hands out read-only views; copy (once) into arrays we own.
    props = np.asarray(out.vert_properties)
    v = np.array(props if props.shape[1] == 3 else props[:, :3], dtype=np.float32, order="C")
    mesh = Mesh(v, np.asarray(out.tri_verts).astype(np.uint32))
    # manifold3d guarantees an oriented closed 2-manifold: record it rather than
    # re-deriving it from a million edges (tests check it independently).
    mesh.__dict__["is_watertight"] = True
    return mesh


#: mm: vertices closer than this are one vertex (what a slicer reading the STL does).
WELD = 1e-5


def drop_pillows(f: np.ndarray) -> np.ndarray:
    """``f`` ``(M, 3)`` without the pairs of triangles on the same three vertices
    (zero volume: two booleans can leave such flat pillows)."""
    key = np.sort(f, axis=1)
    _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return f[count[inv.ravel()] == 1]


def welded(man: Any) -> "Mesh | None":
    """A manifold3d ``Manifold``'s mesh with vertices within :data:`WELD` mm merged
    (positions quantized to ``round(v / WELD)``), the zero-area needles along a cut
    edge (two corners at one position) and the flat pillows dropped; None unless
    every edge then lies on exactly two triangles, opposite ways. When no two
    vertices are that close, the mesh is manifold3d's own, taken as it is."""
    out = man.to_mesh()
    v = np.asarray(out.vert_properties)[:, :3].astype(np.float32)
    f = np.asarray(out.tri_verts).astype(np.int64)
    q = np.round(v.astype(np.float64) / WELD).astype(np.int64)
    order = np.lexsort((q[:, 2], q[:, 1], q[:, 0]))
    sq = q[order]
    new = np.ones(len(v), bool)
    new[1:] = np.any(sq[1:] != sq[:-1], axis=1)
    if new.all():
        mesh = Mesh(np.ascontiguousarray(v), f.astype(np.uint32))
        mesh.__dict__["is_watertight"] = True
        return mesh
    inv = np.empty(len(v), np.int64)
    inv[order] = np.cumsum(new) - 1
    uniq = v[order][new]
    f = inv[f]
    f = drop_pillows(f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])])
    if not len(f) or not edge_report(f)["watertight"]:  # every edge on two triangles, opposite ways
        return None
    used = np.unique(f)
    remap = np.full(len(uniq), -1, np.int64)
    remap[used] = np.arange(len(used))
    mesh = Mesh(np.ascontiguousarray(uniq[used]), remap[f].astype(np.uint32))
    mesh.__dict__["is_watertight"] = True
    return mesh


def welded_mesh(man: Any) -> Mesh:
    """The :class:`Mesh` of a boolean's result as a file reader sees it: :func:`welded`
    where that closes it, else manifold3d's own (:func:`from_manifold`)."""
    return welded(man) or from_manifold(man)


def fuse(base: Any, *textures: Any) -> Mesh:
    """Union textured slabs onto a base body with manifold3d.

    Args:
        base: the part the texture sits on (see module docstring for types).
        *textures: watertight texture slabs (:class:`Mesh` or Manifold) whose
            bottoms lie inside the base body.

    Returns:
        The fused solid as a watertight :class:`Mesh` in mm.

    Raises:
        GeometryError: an input is not a closed solid, or the union is empty.

    Most of the time of a large union goes to manifold3d building its half-edge
    structure for the slab and for the result (an 800 x 800 px slab: about 1.3 s on
    two cores); slabs from :func:`texcad.solid.heightfield_slab` cross the base's face
    with only a few edges, so the boolean itself cuts little. One-shot processes save
    a further ~0.3 s with :func:`retain_freed_memory`.
    """
    import manifold3d as m3d

    parts = [to_manifold(base), *(to_manifold(t) for t in textures)]
    result = m3d.Manifold.batch_boolean(parts, m3d.OpType.Add) if len(parts) > 1 else parts[0]
    if result.status() != m3d.Error.NoError or result.is_empty():
        raise GeometryError(f"the union of texture and base failed (manifold3d: {result.status().name})")
    # vertices a cut left at one point merged, the needles there dropped (what a file reader sees)
    return welded_mesh(result)


def retain_freed_memory() -> bool:
    """Let this process's C allocator reuse freed memory instead of returning it (glibc).

    A union of an 800 x 800 px slab makes manifold3d allocate and free arrays of tens
    of MB again and again. By default glibc serves every such array from fresh pages
    (``mmap``) and unmaps it when freed, so the kernel faults in and zeroes the pages
    anew each time: about 0.3 s of CPU per 800 x 800 px job, a quarter of it spent in
    the kernel. This sets ``M_MMAP_MAX = 0`` and a 2 GB ``M_TRIM_THRESHOLD``
    (``mallopt``): freed blocks stay in the heap and the next array reuses them. The
    process then keeps its peak memory until it exits, so this is for one-shot
    processes (the CLI, benchmarks), not for long-running hosts. Without code, the
    same is ``GLIBC_TUNABLES=glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=2147483647``
    in the environment.

    Returns:
        True if the allocator was tuned, False where the C library is not glibc (or
        refused the setting); nothing changes then.
    """
    import ctypes

    try:
        libc = ctypes.CDLL(None)
        libc.gnu_get_libc_version  # noqa: B018 (glibc only: musl, macOS, Windows differ)
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    m_trim_threshold, m_mmap_max = -1, -4  # <malloc.h>
    return bool(mallopt(m_trim_threshold, 2**31 - 1)) and bool(mallopt(m_mmap_max, 0))


def solids(meshes: Iterable[Mesh]) -> int:  # pragma: no cover - helper for reports
    """Number of separate shells in the union of ``meshes``."""
    return sum(len(to_manifold(m).decompose()) for m in meshes)


# ------------------------------------------------------------------------------------------
# A relief on a planar face, fused without a boolean
# ------------------------------------------------------------------------------------------
def clip_above_plane(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The part of a triangulated surface on or above the plane z = 0.

    Triangles with no vertex above the plane are dropped, those with none below are
    kept, and those that cross it are cut along it (Sutherland-Hodgman against the
    half-space z >= 0, vectorized): a new vertex where an edge crosses z = 0, one per
    edge, shared by its two triangles, at z = 0 exactly.

    Args:
        vertices: ``(N, 3)`` mm.
        faces: ``(M, 3)`` vertex indices, any orientation (kept).

    Returns:
        ``(vertices, faces)``: ``(N', 3)`` float64 mm (the used input vertices in their
        order, then the cut points) and ``(M', 3)`` int64.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    n = len(v)
    above, below = v[:, 2] > 0, v[:, 2] < 0
    fa, fb = above[f], below[f]
    any_a = fa[:, 0] | fa[:, 1] | fa[:, 2]  # (faster than .any(axis=1) on 3 columns)
    any_b = fb[:, 0] | fb[:, 1] | fb[:, 2]
    whole = f[any_a & ~any_b]
    cut = f[any_a & any_b]
    a, b = cut, np.roll(cut, -1, axis=1)  # edge k runs a[:, k] -> b[:, k]
    cross = (above[a] & below[b]) | (below[a] & above[b])
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keys, inv = np.unique((lo * n + hi)[cross], return_inverse=True)
    elo, ehi = keys // n, keys % n
    t = v[elo, 2] / (v[elo, 2] - v[ehi, 2])
    pts = v[elo] + t[:, None] * (v[ehi] - v[elo])
    pts[:, 2] = 0.0
    # Per cut triangle, up to 6 slots: vertex k if not below, then edge k's cut point.
    slot = np.full((len(cut), 6), -1, dtype=np.int64)
    slot[:, 0::2] = np.where(below[cut], -1, cut)
    ex = np.full(cut.shape, -1, dtype=np.int64)
    ex[cross] = n + inv.reshape(-1)
    slot[:, 1::2] = ex
    order = np.argsort(slot < 0, axis=1, kind="stable")
    s = np.take_along_axis(slot, order, axis=1)
    quad = s[:, 3] >= 0
    tris = np.concatenate([s[:, [0, 1, 2]], s[quad][:, [0, 2, 3]]])
    used, faces_out = _compact(np.concatenate([whole, tris]), n + len(pts))
    return np.concatenate([v, pts])[used], faces_out


def _compact(faces: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(used, faces')``: the indices of the ``n`` vertices that ``faces`` use, in
    their order, and the faces renumbered onto them (no sort: a mask and a cumsum)."""
    mask = np.zeros(n, dtype=bool)
    mask[faces.reshape(-1)] = True
    return np.flatnonzero(mask), (np.cumsum(mask) - 1)[faces]


def _pinch_pairs(u: np.ndarray, w: np.ndarray, xy: np.ndarray, pinch: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """At vertices where a surface touches itself (``pinch``), which boundary edge
    (``u -> w``) leaves along the same wedge that each arriving edge bounds: around
    the vertex, counter-clockwise, a wedge of the surface runs from its leaving
    edge's direction to its arriving edge's (reversed), so the edge leaving is the
    one just before the arriving one in angle. Returns ``(arriving, leaving)``
    edge indices."""
    e_in, e_out = np.flatnonzero(pinch[w]), np.flatnonzero(pinch[u])
    vert = np.r_[w[e_in], u[e_out]]
    d = np.r_[xy[u[e_in]] - xy[w[e_in]], xy[w[e_out]] - xy[u[e_out]]]
    arriving = np.r_[np.ones(len(e_in), bool), np.zeros(len(e_out), bool)]
    edge = np.r_[e_in, e_out]
    o = np.lexsort((np.arctan2(d[:, 1], d[:, 0]), vert))
    vert, arriving, edge = vert[o], arriving[o], edge[o]
    k = np.arange(len(vert))
    first = np.maximum.accumulate(np.where(np.r_[True, vert[1:] != vert[:-1]], k, 0))
    last = np.minimum.accumulate(np.where(np.r_[vert[1:] != vert[:-1], True], k, len(k))[::-1])[::-1]
    prev = np.where(k == first, last, k - 1)  # cyclically, around each vertex
    if arriving[prev[arriving]].any():
        raise GeometryError("the surface's boundary pinches in a way that cannot be followed")
    return edge[arriving], edge[prev[arriving]]


def boundary_loops(
    faces: np.ndarray, num_vertices: int, on: "np.ndarray | None" = None, xy: "np.ndarray | None" = None
) -> list[np.ndarray]:
    """The boundary of an oriented triangulated surface as closed loops of vertex
    indices, each in the direction of its directed edges (the surface on the left).

    Vectorized: the loops are labelled and ordered by pointer jumping (``log2``
    rounds over the boundary vertices), not traced vertex by vertex. ``on``: an
    optional ``(num_vertices,)`` bool mask of the vertices the boundary is known to
    lie on; only the faces with two or more of them are looked at (an edge between
    two such vertices is in those faces alone, so it pairs up the same way).
    ``xy``: ``(num_vertices, 2)`` positions of a surface over the plane (facing +z),
    to follow the boundary through vertices where the surface touches itself
    (:func:`_pinch_pairs`): a loop may then pass such a vertex twice, or two loops
    share it.

    Raises:
        GeometryError: a directed edge is used twice (not oriented), or a boundary
            vertex starts or ends more than one boundary edge (a pinch) and ``xy``
            is not given or does not resolve it.
    """
    n = int(num_vertices)
    f = np.asarray(faces, dtype=np.int64)
    if on is not None:
        hit = on[f]
        f = f[hit[:, 0].astype(np.int8) + hit[:, 1] + hit[:, 2] >= 2]
        a, b = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
        both = on[a] & on[b]
        k = np.sort((2 * (np.minimum(a, b) * n + np.maximum(a, b)) + (a > b))[both])
    else:
        k = _edge_keys(f, n)
    if (k[1:] == k[:-1]).any():
        raise GeometryError("the surface is not oriented: a directed edge is used twice")
    und = k >> 1
    single = np.ones(len(k), bool)
    single[1:] &= und[1:] != und[:-1]
    single[:-1] &= und[:-1] != und[1:]
    ks = k[single]
    if len(ks) == 0:
        return []
    lo, hi = (ks >> 1) // n, (ks >> 1) % n
    flip = (ks & 1).astype(bool)
    order = np.argsort(np.where(flip, hi, lo), kind="stable")
    u, w = np.where(flip, hi, lo)[order], np.where(flip, lo, hi)[order]
    m = len(u)
    if not np.array_equal(np.bincount(u, minlength=n), np.bincount(w, minlength=n)):
        raise GeometryError("the surface's boundary is not closed: a vertex ends a different number of edges than it starts")
    nxt = np.searchsorted(u, w)
    pinch = np.bincount(u, minlength=n) > 1  # the surface touches itself at these vertices
    if pinch.any():
        if xy is None:
            raise GeometryError("the surface's boundary pinches: a vertex starts or ends two boundary edges")
        e_in, e_out = _pinch_pairs(u, w, xy, pinch)
        nxt[e_in] = e_out
    if not (np.bincount(nxt, minlength=m) == 1).all():
        raise GeometryError("the surface's boundary pinches in a way that cannot be followed")
    rounds = int(np.ceil(np.log2(m))) + 1
    lab, p = np.arange(m), nxt.copy()
    for _ in range(rounds):  # pointer jumping: the smallest index on each loop
        lab, p = np.minimum(lab, lab[p]), p[p]
    # Cut each loop before its leader and rank the vertices by their distance to the cut.
    succ = np.where(lab[nxt] == nxt, np.arange(m), nxt)  # the leader's predecessor ends the list
    d = (succ != np.arange(m)).astype(np.int64)
    for _ in range(rounds):
        d, succ = d + d[succ], succ[succ]
    pos = d[lab] - d  # 0 at the leader
    seq = np.lexsort((pos, lab))
    starts = np.flatnonzero(np.r_[True, lab[seq][1:] != lab[seq][:-1]])
    return [u[s] for s in np.split(seq, starts[1:])]  # per loop


def _area2(xy: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Twice the signed area in mm^2 of triangles ``f`` over 2-D points ``xy``."""
    x = np.ascontiguousarray(xy[:, 0], dtype=np.float64)[f]  # (M, 3): one gather per column
    y = np.ascontiguousarray(xy[:, 1], dtype=np.float64)[f]
    return (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (y[:, 1] - y[:, 0]) * (x[:, 2] - x[:, 0])


def _tet_volume(v: np.ndarray, f: np.ndarray, ref: np.ndarray) -> float:
    """Divergence-theorem volume in mm^3 of faces ``f`` about the point ``ref``
    (float64, one coordinate column at a time)."""
    x, y, z = (np.ascontiguousarray(v[:, k], dtype=np.float64)[f] - float(ref[k]) for k in range(3))  # (M, 3) each
    det = x[:, 0] * (y[:, 1] * z[:, 2] - z[:, 1] * y[:, 2])
    det -= y[:, 0] * (x[:, 1] * z[:, 2] - z[:, 1] * x[:, 2])
    det += z[:, 0] * (x[:, 1] * y[:, 2] - y[:, 1] * x[:, 2])
    return float(det.sum() / 6.0)


def _prism_volume(v: np.ndarray, f: np.ndarray) -> float:
    """Volume in mm^3 between a surface over the xy plane (``f`` facing up, not
    overlapping in xy) and z = 0: each triangle's xy area times its mean height."""
    z = np.ascontiguousarray(v[:, 2], dtype=np.float64)[f]
    return float(np.dot(_area2(v, f), z[:, 0] + z[:, 1] + z[:, 2]) / 6.0)


def _triangulate_loops(xy: np.ndarray, loops: list[np.ndarray]) -> np.ndarray:
    """manifold3d's triangulation of the region the ``loops`` (indices into ``xy``,
    counter-clockwise outer loops, clockwise holes) bound, as ``(T, 3)`` indices
    into ``xy``, counter-clockwise."""
    import manifold3d

    if not loops:
        return np.zeros((0, 3), dtype=np.int64)
    ids = np.concatenate(loops)
    tri = ids[np.asarray(manifold3d.triangulate([xy[lp] for lp in loops]), dtype=np.int64).reshape(-1, 3)]
    # Where loops touch at a vertex (a pinch) it is listed twice; a sliver between
    # its two copies collapses to nothing.
    tri = tri[(tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 2] != tri[:, 0])]
    return _split_flat(tri, xy)


def _split_flat(tri: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Zero-area triangles ``(a, m, c)`` with ``m`` straight between ``a`` and ``c``
    (ears at a pinch whose edges run straight through it) removed by splitting the
    neighbour across ``c -> a``, ``(a, c, d)``, into ``(a, m, d)`` and ``(m, c, d)``.
    Those that cannot be split (no such neighbour, or it is flat too) are left for
    the caller's area check."""
    for _ in range(8):  # rounds: a neighbour is split once per round (chains of flat ones)
        flat = np.flatnonzero(_area2(xy, tri) == 0)
        if len(flat) == 0:
            return tri
        p = xy[tri[flat]].astype(np.float64)  # (F, 3, 2)
        d = [((p[:, (k + 1) % 3] - p[:, k]) * (p[:, (k + 2) % 3] - p[:, k])).sum(axis=1) for k in range(3)]
        mid = np.argmin(np.stack(d, axis=1), axis=1)  # the vertex between the other two (dot < 0)
        t = np.arange(len(flat))
        m, c, a = tri[flat, mid], tri[flat, (mid + 1) % 3], tri[flat, (mid + 2) % 3]
        n = len(xy)
        e = np.stack([tri, np.roll(tri, -1, axis=1)], axis=-1).reshape(-1, 2)
        key = e[:, 0] * n + e[:, 1]
        order = np.argsort(key)
        want = a * n + c
        at = order[np.minimum(np.searchsorted(key[order], want), len(key) - 1)]
        nb = at // 3
        ok = (key[at] == want) & ~np.isin(nb, flat)
        _, first = np.unique(nb[ok], return_index=True)
        go = np.flatnonzero(ok)[first]
        if len(go) == 0:
            return tri
        dd = tri[nb[go], (at[go] % 3 + 2) % 3]
        new = np.concatenate([np.stack([a[go], m[go], dd], 1), np.stack([m[go], c[go], dd], 1)])
        drop = np.zeros(len(tri), bool)
        drop[flat[t[go]]] = True
        drop[nb[go]] = True
        tri = np.concatenate([tri[~drop], new])
    return tri


def fuse_on_plane(
    base: Mesh,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    expect: "tuple[float, float] | None" = None,
) -> tuple[Mesh, Mesh]:
    """Fuse a relief that stands on the plane z = 0 onto a base body, without a boolean.

    The base has a face in the plane z = 0 (its vertices there at z = 0 exactly,
    facing +z), and the relief's surface (``vertices``, ``faces``: e.g. the top of
    :func:`texcad.solid.heightfield_slab`) is cut at z = 0 (:func:`clip_above_plane`).
    Where the relief stands, the base's face is cut out; the rest of that face is
    triangulated again around the relief's footprint (manifold3d's polygon
    triangulation), sharing its boundary vertices: the fused solid is the base's mesh
    with the relief stitched in, as the union would make it. The caller must know
    that nothing else of the body lies above the face where the relief stands.

    Checked independently, else :class:`GeometryError` (use :func:`fuse` then):
    every directed edge appears once and its reverse once (closed and oriented);
    every new face triangle faces +z and together they cover the face's area minus
    the relief's footprint; the volume (divergence theorem about a point off the
    plane) is the base's plus the relief's own (its triangles' prisms down to
    z = 0); and with ``expect = (volume, slack)`` mm^3 the relief's volume is
    within ``slack`` of ``volume`` (e.g. the heightfield's sum of h dA).

    Args:
        base: closed :class:`Mesh` in mm, in the plane's frame.
        vertices: ``(N, 3)`` mm, the relief surface (below z = 0 where it is cut away).
        faces: ``(M, 3)`` its triangles, facing up (+z).

    Returns:
        ``(fused, relief)``: the fused solid (watertight, checked), and the relief
        alone closed by its footprint at z = 0 (float32 mm :class:`Mesh`; None where
        the relief touches itself at a point, which the fused solid closes around
        but the relief alone would not: a pinched vertex).
    """
    rv, rf = clip_above_plane(vertices, faces)
    bv = base.vertices.astype(np.float64)
    bf = base.faces.astype(np.int64)
    on = (bv[:, 2] == 0.0)[bf].all(axis=1) & (_area2(bv, bf) > 0)
    if not on.any() or not len(rf):
        raise GeometryError("nothing to stitch: the base has no face at z = 0 or the relief is empty")
    f_loops = boundary_loops(bf[on], len(bv), xy=bv[:, :2])
    r_loops = boundary_loops(rf, len(rv), on=rv[:, 2] == 0.0, xy=rv[:, :2])  # the relief's boundary is at z = 0
    looped = np.concatenate(r_loops) if r_loops else np.zeros(0, np.int64)
    pinched = len(np.unique(looped)) < len(looped)  # the relief touches itself at a point
    if any(float(np.abs(rv[lp, 2]).max()) != 0.0 for lp in r_loops):  # per loop
        raise GeometryError("the relief's boundary leaves the plane z = 0")
    nb = len(bv)
    xy = np.concatenate([bv[:, :2], rv[:, :2]])
    ring = _triangulate_loops(xy, f_loops + [lp[::-1] + nb for lp in r_loops])
    foot = _triangulate_loops(rv[:, :2], r_loops)
    faces_out = np.concatenate([bf[~on], ring, rf + nb])
    v = np.concatenate([bv, rv])
    used, faces_out = _compact(faces_out, len(v))
    fused = Mesh(v[used].astype(np.float32), faces_out.astype(np.uint32))
    # The relief closes on its footprint: the triangulation of its own boundary loops
    # (manifold3d keeps the loops' edges), so it is closed when the fused solid is.
    relief = None if pinched else Mesh(rv.astype(np.float32), np.concatenate([rf, foot[:, ::-1]]).astype(np.uint32))
    areas = (_area2(xy, ring), _area2(bv, bf[on]), _area2(rv, foot))
    _check_stitch(fused, base, _prism_volume(rv.astype(np.float32), rf), areas, expect)
    fused.__dict__["is_watertight"] = True
    return fused, relief


def _check_stitch(fused: Mesh, base: Mesh, v_relief: float, areas: tuple, expect) -> None:
    """The checks of :func:`fuse_on_plane` (GeometryError naming the one that failed):
    ``v_relief`` is the relief's own volume (mm^3), ``areas`` twice the signed xy
    areas of the new face triangles, the old face's and the relief's footprint's."""
    if not closed_and_oriented(fused.faces, len(fused.vertices)):
        raise GeometryError("the stitched solid is not closed and oriented")
    ring, face, foot = areas
    scale = float(face.sum())
    if (ring <= 0).any() or abs(float(ring.sum()) - (scale - float(foot.sum()))) > 1e-6 * scale:
        raise GeometryError("the face around the relief does not cover the face's area minus the relief's footprint")
    lo = base.bounds[0].astype(np.float64) - 1.0
    v_fused = _tet_volume(fused.vertices, fused.faces.astype(np.int64), lo)
    v_base = _tet_volume(base.vertices, base.faces.astype(np.int64), lo)
    if abs(v_fused - v_base - v_relief) > 1e-6 * (abs(v_base) + abs(v_relief)) + 1e-9:
        raise GeometryError(
            f"the stitched solid's volume {v_fused:.6g} mm3 is not the base's {v_base:.6g} plus the relief's {v_relief:.6g}"
        )
    if expect is not None and abs(v_relief - expect[0]) > expect[1] + 1e-6 * abs(expect[0]) + 1e-9:
        raise GeometryError(f"the relief's volume {v_relief:.6g} mm3 is not the heightfield's {expect[0]:.6g} +- {expect[1]:.3g}")
