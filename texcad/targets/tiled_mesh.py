"""A mesh target too large for memory, textured in blocks (issue 30).

The mesh adapter (:mod:`texcad.targets.mesh`) takes this path by itself where its
untiled refinement would not fit in the memory available (``max_memory``). The result
is the untiled pitch grid (``tolerance=0``), made a block at a time:

* **coarse, once.** The region's faces are bisected down to three pitches
  (:func:`texcad.solid.subdivide.coarsen`, as :func:`~texcad.solid.subdivide.refine`
  does first); that mesh has a sixth to a ninth of the refined triangles. Each of its edges gets
  ``ceil(length / pitch)`` pieces (1 off the region): a number that depends on the
  edge alone, so both faces at an edge cut it at the same points.
* **blocks.** The coarse faces are ordered along a Morton curve of their centroids
  and cut into runs of about the same number of refined triangles (*blocks*). A
  block is tessellated (:func:`~texcad.solid.subdivide.tessellate`) together with its
  *halo*, every coarse face that shares a vertex with it: the refined faces round
  each of the block's vertices are then all there, in the untiled order (faces sorted
  by coarse face), so its angle-weighted normal and offset direction are the untiled
  ones, bit for bit, and a vertex on a block border comes out the same float32 point
  from both neighbours.
* **the relief at each vertex.** The texture sampled at the vertex through the
  projection fixed once for the whole region (origin from the refined region's
  bounding box, radius from a pass over all its vertices), the M-I ramp from the distance to
  the region's border vertices (collected in a first pass over the blocks: a curve,
  small), the depth gradient and mode: all point by point, as the untiled adapter.
* **welded by numbers.** Coarse vertices, the points of each coarse edge and the
  inner points of each coarse face get global numbers the first time a block emits
  them, so a border edge's points are one vertex each (no gap, no duplicate, no
  T-junction) and the streaming writers (:mod:`texcad.io.stream`) write each once.
* **folds and overhangs.** The limiter (:func:`texcad.printability.limit_relief`)
  runs block by block. Without a build direction (folds only) on the block's own
  faces. With ``build_dir`` also on every face at a point of its border (from the
  halo, two rings of coarse faces deep there so that their points' normals are the
  untiled ones), since the limiter's ridge test needs the faces on both sides of an
  edge. Those faces are an open surface: the limiter tests the ridges at its edges
  of two faces and none at its border (what it did on them closed by a copy, at
  half the cost; tested). Overhangs,
  folds or ridges that stay inside a block are limited as on the whole mesh (the
  limiter's rounds only look at faces next to a change). Where a block lowers a
  point next to its border (its border points, and with ``build_dir`` the points of
  the faces at them, on both sides), that point is *pinned* at the least
  displacement any block gave it and the blocks of the next pass start from it
  (every block of a pass from the pins as they stood at its start: the blocks of a
  pass can be made in any order, on a Dask cluster too, with the same bytes); the
  blocks whose pinned points changed since they were made are
  made again (the others keep their share of the gate's tally, and only take their
  vertex numbers from their coarse faces), until no block lowers such a point (from
  the second pass on a newly lowered one is pinned at 0, the undisplaced surface,
  where the limiter itself ends; at most :data:`MAX_PASSES`): both neighbours then
  move it alike, and every face, fold and ridge was tested by a block that had all
  its points' final displacements. A block made again starts from the points its
  limiter lowered when it was last made (kept between passes, :data:`KEPT_BYTES`),
  so it only limits what its changed pins changed; its limiter's result passes the
  limiter's own tests, so made again with the same pins (for the writers) it gives
  the same result.

**On a Dask cluster** (``texcad.texture(..., client=)``): each pass's blocks of one colour
(:func:`_colours`: no two share a coarse vertex) are made from the same pins, in any
order, so the cluster's workers make them (:func:`_make`, the plan and pins sent
once per colour) with the bytes this process makes (tested on two workers); the
colours go one after the other, each from the pins the ones before left.

:class:`TiledMeshBlocks` is that mesh kept as a recipe: its blocks are made on demand
for the gate (:func:`gate_mesh_blocks`: each block's open edges pair up across blocks,
each directed edge once and its reverse once; a vertex in two blocks is the same
float32 point in both; as many bodies as the input; the volume change against the
texture's swept volume summed over blocks; every vertex within reach of where it
was) and for the streaming STL / 3MF writers. Lengths in mm.

**Memory.** The coarse mesh is made whole: about 450 bytes per coarse triangle at the
peak (a coarse triangle of 3 pitches becomes 6 to 9 refined ones), against about 415
bytes per refined triangle untiled (an icosphere of radius 60 mm at 0.2 mm, 4.4 M
triangles: 372 MB against 1754 MB peak); blocks are sized to what it leaves. Where
that coarse mesh would take more than half the memory available, its faces span more
pitches (``factor``, up to :data:`MAX_FACTOR`: ``(3 / factor)^2`` as many coarse
faces, each tessellated into a finer grid), so what stays whole goes with the input
mesh, not the pitch; the triangles then differ from the untiled ones (the same
surface and relief volume to 0.1 %, tested; with ``build_dir`` the limiter's result
on those other triangles differs more). With ``build_dir`` a block takes about twice
the memory per triangle (:data:`LIMITED_BYTES`: two rings of halo, the limiter's
edge table), so its blocks are half as large, and the blocks whose pins change are
made again (the passes above), from where they were: the more overhang crosses
block borders, the more passes. Where ``max_memory`` is given the plan goes with it
alone, not with what the machine has free (:func:`texcad.util.available_memory`).

**Against the untiled mesh** (``tolerance=0``, coarse faces of 3 pitches): the same triangles on the same
float32 vertices (tested on a sphere, a box with its bed face, with and without
``build_dir``, a cylinder with a cylindrical projection and two bodies with a normal
region), except round points pinned for a fold or an overhang, where the limiter's
rounds start from the pinned depth (tested: an engraved texture on a box's edges,
at most 1 % of the vertices, the volume to 1e-3; ``build_dir`` on a sphere whose
lower half overhangs, in 7 blocks, at most 5 % of the vertices, each within 6
pitches of a border, the relief volume to 0.5 %). What matters is limited alike: the
limiter run again on the blocks' result lowers nothing (no face overhangs or folds,
no ridge too flat, across borders too; tested). The more overhang crosses borders,
the more the result differs, and the farther from the borders where the overhang is
one connected band (another result the limiter leaves as it is, keeping more of the
relief than the untiled one, whose rounds shrink a long band more). The projection's origin comes from
the refined region's bounding box and its radius from a pass over its vertices, as
untiled. A tiled mesh keeps every pitch-grid point (its error is 0, within any
``tolerance``).

**Layers and zones** (a list of layers, zones, painted zones): each layer's region is bisected
in turn on the coarse mesh (as the untiled refinement takes the layers), each edge cut
by the finest pitch of the layers at it, and each layer's relief (its own region,
border fade and projection, fixed from its own region's points) summed at every
vertex before the limiter. Where regions are apart, the untiled triangles (tested:
two zones of their own pitch and height, with ``build_dir``); where they meet or
overlap, the untiled refinement cuts the mesh its first layer already refined and the
blocks do not: other triangles on the same surface (a cylindrical projection's mean
radius then from other points), the relief volume to 0.5 % (tested). ``texture_mesh`` and ``layer_meshes`` (booleans of
the whole mesh) are refused; ``base_mesh`` is the input.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import GeometryError, ParameterError, ResourceError, TexcadWarning
from ..mapping.region import bed_plane, hold_above
from ..printability.relief import limit_relief
from ..solid.subdivide import coarsen, edge_counts, face_normals, offset_directions, tessellate, vertex_normals
from ..util import Progress, available_memory, finest_pitch, report, split_rows
from .tiled import CountedTiles, _at, in_order, tiles_verdict
from .tiled_faces import open_edges

__all__ = ["MeshPlan", "FineBlock", "BlockRelief", "TiledMeshBlocks", "mesh_plan", "fine_block", "gate_mesh_blocks",
           "BLOCK_BYTES", "LIMITED_BYTES", "KEPT_BYTES", "COARSE_BYTES", "MAX_FACTOR"]

#: Peak bytes per refined triangle of one block (tessellation, normals, relief and the
#: emitted float32 block; about 450 measured on an icosphere of radius 40 mm at 0.25 mm
#: in one block): what a block's size is chosen by.
BLOCK_BYTES = 500.0
#: The same with ``build_dir``: two rings of halo, and the overhang limiter on the
#: block's faces and those across its border, with its edge table for the ridges
#: (818 measured as the growth of the peak resident memory, VmHWM, from blocks of
#: 60 000 to 180 000 triangles, an icosphere of radius 40 mm at 0.35 mm; 290 without
#: ``build_dir`` in the same runs), with a margin.
LIMITED_BYTES = 1000.0
#: Bytes per refined triangle of the whole job that the blocks' lowered points keep
#: between passes (:attr:`BlockRelief.kept`: a key and a displacement, 16 bytes, a
#: point; about half a point a triangle where the limiter lowers all of them).
KEPT_BYTES = 8.0
#: Peak bytes per coarse triangle of the whole job in blocks (434 measured as peak
#: resident memory over the interpreter's on an icosphere of radius 60 mm at 0.2 mm:
#: the bisection's peak, the coarse mesh kept after it, one block).
COARSE_BYTES = 450.0
#: :func:`~texcad.solid.subdivide.refined_triangles`'s estimate per coarse triangle:
#: the least of 6.4 to 12.8 measured on a sphere, box, cylinder and torus at 0.3 and
#: 0.5 mm (the coarse mesh is estimated from it before it is made).
COARSE_RATIO = 6.4
#: Most pitches a coarse face may span (where 3, the untiled refinement's, would not fit).
MAX_FACTOR = 24
#: Most refined triangles per block (larger blocks are no faster).
MAX_BLOCK = 250_000


@dataclass(frozen=True)
class MeshPlan:
    """The coarse mesh and its blocks, what every block is made from (mm).

    Attributes:
        v: ``(N, 3)`` float64 coarse vertices, mm.
        f: ``(M, 3)`` int64 coarse faces (counter-clockwise from outside).
        fn: ``(M, 3)`` float64 unit normal of each coarse face's input face.
        ids: ``(M,)`` int64 each coarse face's input face.
        counts: ``(M, 3)`` int64 pieces of each face's edge ``k`` (corner ``k`` to
            ``k + 1``): ``ceil(length / pitch)``, the most any face at the edge asks
            (its layers' finest pitch; 1 off every region).
        keys: ``(E,)`` int64 sorted edge keys ``min * N + max``.
        body: ``(M,)`` int64 each coarse face's connected piece (shell).
        blocks: the coarse faces of each block, sorted int64 arrays.
        layers: the layers (:class:`texcad.targets.mesh.Layer`), their projections fixed.
        tol: mm, the region selection's tolerance; low: ``(3,)`` the lowest vertex
            (the bed face's height).
        borders: per layer ``(K, 3)`` float64 its refined region's border vertices.
        reach: mm, the farthest a vertex may move (offset directions are at most
            3 times as long as the normal).
        fits: mm, the pitch at which the untiled job fits (named where folds across
            block borders do not settle).
        factor: how many pitches a coarse face spans at most (3: the untiled
            refinement's; more where that coarse mesh would not fit).
        dirs: ``(K, 3)`` float64 unit build directions, or None (folds only);
            crit: the critical angle, degrees (the overhang limiter's).
        bed: ``(up, level)``: the plane (unit direction, mm) of the untextured bed face
            no point may move under (:func:`texcad.mapping.region.bed_plane`), or None.
    """

    v: np.ndarray
    f: np.ndarray
    fn: np.ndarray
    ids: np.ndarray
    counts: np.ndarray
    keys: np.ndarray
    body: np.ndarray
    blocks: tuple
    layers: tuple
    tol: float
    low: np.ndarray
    borders: tuple
    reach: float
    fits: float
    factor: float = 3.0
    dirs: Any = None
    crit: float = 45.0
    bed: Any = None

    @property
    def pitch(self) -> float:
        """The finest layer's pitch, mm."""
        return min(float(layer.pitch) for layer in self.layers)

    @property
    def triangles(self) -> int:
        """Refined triangles, counted from the grid levels (before the drops at
        edges cut into fewer pieces than their face: an upper bound)."""
        lev = self.counts.max(axis=1)
        return int((lev * lev).sum())


@dataclass(frozen=True)
class FineBlock:
    """One block refined with its halo (mm).

    Attributes:
        near: sorted coarse faces (the block and its halo).
        used: sorted coarse vertices of ``near`` (local vertex ``i < len(used)`` is
            coarse vertex ``used[i]``).
        v: ``(P, 3)`` float64 refined vertices; f: ``(T, 3)`` int64 refined faces.
        src: ``(T,)`` each refined face's index into ``near``; own: ``(T,)`` bool,
            the refined faces of the block itself.
        classes: where each new point lies (:func:`~texcad.solid.subdivide.tessellate`).
    """

    near: np.ndarray
    used: np.ndarray
    v: np.ndarray
    f: np.ndarray
    src: np.ndarray
    own: np.ndarray
    classes: dict


def mesh_plan(layers: tuple, v: np.ndarray, f: np.ndarray, tol: float, refined: int, fits: float,
              progress: Progress = None, dirs: Any = None, crit: float = 45.0) -> MeshPlan:
    """Coarsen the layers' regions of ``(v, f)`` (layer by layer, as the untiled
    refinement takes them) and cut the mesh into blocks that fit in the memory
    available (module docstring); the first pass over the blocks finds each region's
    border vertices and fixes its projection. ``refined``: about how many triangles
    the refinement makes; ``fits``: the pitch (mm) at which the untiled job fits (named
    where something is refused); ``dirs``: ``(K, 3)`` build directions or None,
    ``crit``: the critical angle (degrees) of the overhang limiter.

    Raises:
        ResourceError: the coarse mesh or one block does not fit (names a pitch).
        ParameterError: a region holds no face.
    """
    layers = tuple(layers)
    pitch = min(float(layer.pitch) for layer in layers)
    factor = _coarse_factor(refined, len(f), pitch)
    fn, _ = face_normals(v, f)
    cv, cf, ids, finest = v, f, np.arange(len(f)), np.full(len(f), np.inf)
    for k, layer in enumerate(layers):  # per layer: its region bisected down to `factor` of its pitches
        sel = layer.faces(cv, cf, fn[ids], dirs, crit, tol, loose=True, ids=ids)
        if not sel.any():
            raise ParameterError(f"region {k + 1} ({layer.region}) holds no face of the mesh; choose another region")
        # the cap on the whole mesh's triangles is the STL's here: the mesh is never whole
        cv, cf, _, parent = coarsen(cv, cf, sel, float(layer.pitch), guard=False, coarse=factor, max_faces=2**32 - 1)
        ids, finest = ids[parent], np.where(sel[parent], np.minimum(finest[parent], float(layer.pitch)), finest[parent])
    report(progress, 0.12, f"coarse mesh: {len(cf)} triangles of up to {factor} pitches")
    counts, keys = _counts(cv, cf, finest)
    lev = counts.max(axis=1)
    body = _bodies(cf, len(cv))
    blocks = _blocks(cv, cf, lev * lev, _block_triangles(len(cf), pitch, BLOCK_BYTES if dirs is None else LIMITED_BYTES,
                                                       int((lev * lev).sum())))
    reach = 3.0 * sum(float(layer.height) for layer in layers) + 0.01
    plan = MeshPlan(cv, cf, fn[ids], ids, counts, keys, body, blocks, layers, tol, cv[np.argmin(cv[:, 2])],
                    (), reach, float(fits), factor, dirs, float(crit), bed_plane(cv, cf, fn[ids], dirs, [layer.region for layer in layers], tol))
    return _first_pass(plan, progress)


def _counts(v: np.ndarray, f: np.ndarray, finest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~texcad.solid.subdivide.edge_counts` with each face's own pitch
    ``finest`` (mm, inf off every region): the most any face at an edge asks."""
    out, keys = None, None
    for p in np.unique(finest[np.isfinite(finest)]):  # per pitch (one per layer at most)
        c, keys = edge_counts(v, f, finest == p, float(p))
        out = c if out is None else np.maximum(out, c)
    return out, keys


def _coarse_factor(refined: int, faces: int, pitch: float) -> float:
    """How many pitches the coarse faces may span: 3, as the untiled refinement
    (the same triangles), where that coarse mesh takes at most half the memory
    available; else the least (up to :data:`MAX_FACTOR`) at which it does (its faces
    ``(3 / factor)^2`` as many). ResourceError naming a pitch where none does."""
    have = available_memory() / 2
    need = refined / COARSE_RATIO * COARSE_BYTES
    if need <= have:
        return 3.0
    factor = math.ceil(3.0 * math.sqrt(need / max(have - faces * COARSE_BYTES, 1.0)))
    if factor > MAX_FACTOR or faces * COARSE_BYTES >= have:
        least = need * (3.0 / MAX_FACTOR) ** 2
        raise ResourceError(f"refining the mesh to about {refined} triangles in blocks at a pitch of {pitch:.3g} mm needs "
                            f"about {2 * (least + faces * COARSE_BYTES) / 2**30:.1f} GiB for its coarse mesh and a block, "
                            f"more than the {2 * have / 2**30:.1f} GiB available; use a pitch of at least "
                            f"{finest_pitch(pitch, 2 * least, 2 * faces * COARSE_BYTES):.3g} mm or allow more memory (max_memory)")
    return float(factor)


def _block_triangles(coarse: int, pitch: float, per: float = BLOCK_BYTES, refined: int = 0) -> int:
    """Refined triangles per block that fit in what the coarse mesh (made, and held
    by this process already) leaves, beside the vertex numbers (16 bytes per coarse
    triangle) and the lowered points the blocks keep (:data:`KEPT_BYTES` per
    ``refined`` triangle of the job), at ``per`` bytes a triangle
    (:data:`BLOCK_BYTES`, :data:`LIMITED_BYTES`); ResourceError naming a pitch
    where not even a small block fits. Rounded down to ``2^k`` or ``1.5 2^k``: the
    blocks, and so the bytes where a fold or an overhang crosses their borders, do
    not change with the few kilobytes the process holds more or less from one run
    to the next."""
    held = 16.0 * coarse + KEPT_BYTES * refined
    have = available_memory() / 1.25 - held
    n = int(min(MAX_BLOCK, have / per))
    if n < 20_000:
        p = finest_pitch(pitch, coarse * COARSE_BYTES + KEPT_BYTES * refined, 20_000 * per)
        need = 1.25 * (held + 20_000 * per) / 2**20
        how = f"use a pitch of at least {p:.3g} mm or allow" if p < float("inf") else "allow at least"
        raise ResourceError(f"the mesh's coarse refinement ({coarse} triangles at a pitch of {pitch:.3g} mm) leaves no "
                            f"room for a block in the memory available; {how} {need:.0f} MB more memory (max_memory) "
                            "than the process holds")
    if n >= MAX_BLOCK:
        return n
    k = 1 << (n.bit_length() - 1)
    return max(20_000, k + k // 2 if n >= k + k // 2 else k)


def _morton(c: np.ndarray) -> np.ndarray:
    """Morton (Z-order) keys of points ``(M, 3)``: 21 bits per axis."""
    lo, hi = c.min(axis=0), c.max(axis=0)
    q = ((c - lo) / np.maximum(hi - lo, 1e-300) * ((1 << 21) - 1)).astype(np.uint64)
    key = np.zeros(len(c), dtype=np.uint64)
    for bit in range(21):  # per bit of each coordinate
        for k in range(3):  # per axis
            key |= ((q[:, k] >> np.uint64(bit)) & np.uint64(1)) << np.uint64(3 * bit + k)
    return key


def _blocks(v: np.ndarray, f: np.ndarray, tris: np.ndarray, per_block: int) -> tuple:
    """Coarse faces cut into runs along the Morton curve of their centroids, each of
    at most ``per_block`` refined triangles (``tris`` per face); sorted per block."""
    c = (v[f[:, 0]] + v[f[:, 1]] + v[f[:, 2]]) / 3.0
    order = np.argsort(_morton(c), kind="stable")
    cum = np.cumsum(tris[order])
    cut = np.searchsorted(cum, np.arange(per_block, int(cum[-1]), per_block), side="right")
    return tuple(np.sort(b) for b in np.split(order, np.unique(cut)) if len(b))


def _bodies(f: np.ndarray, nv: int) -> np.ndarray:
    """Each face's connected piece (through shared vertices)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]]])
    g = coo_matrix((np.ones(len(e), dtype=np.int8), (e[:, 0], e[:, 1])), shape=(nv, nv))
    _, label = connected_components(g, directed=False)
    return label[f[:, 0]].astype(np.int64)


def fine_block(plan: MeshPlan, block: np.ndarray, rings: int = 1) -> FineBlock:
    """Block ``block`` (sorted coarse faces) refined with its halo (module docstring):
    ``rings`` rings of coarse faces round it (2 for the overhang limiter, whose
    faces across the block's border need their own vertices' normals)."""
    near = block
    for _ in range(rings):  # per ring of coarse faces
        mark = np.zeros(len(plan.v), dtype=bool)
        mark[plan.f[near].ravel()] = True
        near = np.flatnonzero(mark[plan.f].any(axis=1))  # sorted: the untiled face order
    used, inv = np.unique(plan.f[near], return_inverse=True)  # sorted: each edge's end order as untiled
    classes: dict = {}
    v, f, src = tessellate(plan.v[used], inv.reshape(-1, 3), plan.counts[near], classes=classes)
    own = np.isin(near, block)[src]
    return FineBlock(near, used, v, f, src, own, classes)


def _strict(plan: MeshPlan, b: FineBlock, k: int = 0) -> np.ndarray:
    """The refined faces in layer ``k``'s region (as the untiled adapter selects
    them; the bed face's height from the whole mesh)."""
    vv = np.concatenate([b.v, plan.low[None, :]])  # the lowest point: bed faces as on the whole mesh
    return plan.layers[k].faces(vv, b.f, plan.fn[b.near][b.src], plan.dirs, plan.crit, plan.tol, loose=False,
                                ids=plan.ids[b.near][b.src])


def _owned(b: FineBlock) -> np.ndarray:
    """Vertices of the block's own faces."""
    ref = np.zeros(len(b.v), dtype=bool)
    ref[b.f[b.own].ravel()] = True
    return ref


def _first_pass(plan: MeshPlan, progress: Progress) -> MeshPlan:
    """Each region's border vertices (a vertex of a face of the region and of a face
    outside it), its bounding box and, for a cylindrical or spherical projection
    without a radius, the mean distance from the axis or centre (a second pass)."""
    n = len(plan.layers)
    border, lo, hi = [[] for _ in range(n)], np.full((n, 3), np.inf), np.full((n, 3), -np.inf)
    for k, blk in enumerate(plan.blocks):  # per block
        b = fine_block(plan, blk)
        own = _owned(b)
        for i in range(n):  # per layer
            m = _strict(plan, b, i)
            ins, out = np.zeros(len(b.v), dtype=bool), np.zeros(len(b.v), dtype=bool)
            ins[b.f[m].ravel()] = True
            out[b.f[~m].ravel()] = True
            border[i].append(b.v[ins & out & own])
            if (ins & own).any():
                lo[i], hi[i] = np.minimum(lo[i], b.v[ins & own].min(axis=0)), np.maximum(hi[i], b.v[ins & own].max(axis=0))
        report(progress, 0.12 + 0.08 * (k + 1) / len(plan.blocks), f"block {k + 1}/{len(plan.blocks)}: the regions' borders")
    layers = []
    for i, layer in enumerate(plan.layers):  # per layer
        if not np.isfinite(lo[i]).all():
            raise ParameterError(f"region {i + 1} ({layer.region}) holds no face of the mesh; choose another region")
        proj = layer.projection
        if proj.origin is None:
            proj = replace(proj, origin=tuple(float(t) for t in 0.5 * (lo[i] + hi[i])))
        layers.append(layer.with_projection(proj))
    plan = replace(plan, borders=tuple(np.concatenate(x) for x in border), layers=tuple(layers))
    for i, layer in enumerate(plan.layers):  # per layer: a radius from its points where none is given
        proj = layer.projection
        if proj.radius is None and proj.kind in ("cylindrical", "spherical"):
            radius = _mean_radius(plan, i)
            plan = replace(plan, layers=plan.layers[:i] + (layer.with_projection(replace(proj, radius=radius)),)
                           + plan.layers[i + 1:])
    return plan


def _mean_radius(plan: MeshPlan, i: int) -> float:
    """Mean distance (mm) of layer ``i``'s region's refined vertices from its
    projection's axis (cylindrical) or centre (spherical), each vertex once (its
    first block)."""
    from ..mapping.projection import frame, parse_axis

    proj = plan.layers[i].projection
    a = parse_axis(proj.axis)
    eu, ev = frame(a)
    o = np.asarray(proj.origin, dtype=np.float64)
    numbering = _Numbering(plan)
    total, count = 0.0, 0
    for blk in plan.blocks:  # per block
        b = fine_block(plan, blk)
        m = _strict(plan, b, i)
        ids = numbering.ids(plan, b)
        ins = np.zeros(len(b.v), dtype=bool)
        ins[b.f[m & b.own].ravel()] = True
        new = ins & (ids >= numbering.start)
        q = b.v[new] - o
        x, y = q @ eu, q @ ev
        rho = np.hypot(x, y) if proj.kind == "cylindrical" else np.sqrt(x * x + y * y + (q @ a) ** 2)
        total, count = total + float(rho.sum()), count + len(rho)
    return total / max(count, 1)


class _Numbering:
    """Global vertex numbers, given the first time a block emits a vertex: coarse
    vertices, each coarse edge's points (a run from its smaller end) and each coarse
    face's inner points. ``start``: the first number of the block just numbered."""

    def __init__(self, plan: MeshPlan) -> None:
        self.coarse = np.full(len(plan.v), -1, dtype=np.int64)
        self.edge = np.full(len(plan.keys), -1, dtype=np.int64)
        self.next = 0
        self.start = 0

    def _take(self, n: int) -> np.ndarray:
        out = self.next + np.arange(n, dtype=np.int64)
        self.next += n
        return out

    def skip(self, plan: MeshPlan, block: np.ndarray) -> int:
        """The numbers block ``block`` takes (as :meth:`ids` gives them), from its
        coarse faces alone: its coarse vertices, the points of its edges cut into 2 or
        more (in the order of their keys) and ``(N - 1)(N - 2) / 2`` inner points of
        each face of grid level ``N``. Returns the first of its inner points'."""
        self.start = self.next
        g = np.unique(plan.f[block])
        fresh = g[self.coarse[g] < 0]
        self.coarse[fresh] = self._take(len(fresh))
        f, cnt = plan.f[block], plan.counts[block]
        e = f[:, [1, 2, 0]]
        cut = cnt > 1
        ge = np.searchsorted(plan.keys, (np.minimum(f, e) * np.int64(len(plan.v)) + np.maximum(f, e))[cut])
        ge, first = np.unique(ge, return_index=True)
        runs = cnt[cut][first] - 1
        new = self.edge[ge] < 0
        ids = self._take(int(runs[new].sum()))
        self.edge[ge[new]] = ids[np.concatenate([[0], np.cumsum(runs[new])[:-1]]).astype(np.int64)] if new.any() else ids
        lev = cnt.max(axis=1)
        first = self.next
        self._take(int(((lev - 1) * (lev - 2) // 2).sum()))
        return first

    @staticmethod
    def whole(plan: MeshPlan) -> "tuple[_Numbering, np.ndarray]":
        """Every block numbered (:meth:`skip`) and the first number of each block's
        inner points: :meth:`number` from there gives a block its numbers in any
        order (every coarse vertex and edge has its number already)."""
        out = _Numbering(plan)
        return out, np.array([out.skip(plan, blk) for blk in plan.blocks], dtype=np.int64)

    def ids(self, plan: MeshPlan, b: FineBlock) -> np.ndarray:
        """``(P,)`` the global number of each vertex of the block's own faces, -1
        for the halo's other vertices."""
        return self.number(plan, b.used, b.classes, _owned(b))

    def number(self, plan: MeshPlan, used: np.ndarray, c: dict, ref: np.ndarray) -> np.ndarray:
        """:meth:`ids` from what it reads of the fine block: its coarse vertices
        ``used``, where its points lie ``c`` (:attr:`FineBlock.classes`) and the
        vertices of its own faces ``ref``."""
        self.start = self.next
        gid = np.full(len(ref), -1, dtype=np.int64)
        nl = len(used)
        cv = np.flatnonzero(ref[:nl])
        g = used[cv]
        fresh = self.coarse[g] < 0
        self.coarse[g[fresh]] = self._take(int(fresh.sum()))
        gid[cv] = self.coarse[g]
        if len(c.get("t", ())):
            ep = nl + np.arange(len(c["t"]))
            le = c["edge_point"]
            ge, pos = _edge_points(plan, used, c)
            hit = ref[ep]
            e_hit = np.unique(le[hit])
            fresh_e = e_hit[self.edge[ge[e_hit]] < 0]
            runs = c["edge_count"][fresh_e] - 1
            first = self._take(int(runs.sum()))
            self.edge[ge[fresh_e]] = first[np.concatenate([[0], np.cumsum(runs)[:-1]]).astype(np.int64)] if len(runs) else first
            gid[ep[hit]] = self.edge[ge[le[hit]]] + pos[hit] - 1
            inner = np.arange(nl + len(c["t"]), len(ref))
        else:
            inner = np.arange(nl, len(ref))
        hit = inner[ref[inner]]
        gid[hit] = self._take(len(hit))
        return gid


def _edge_points(plan: MeshPlan, used: np.ndarray, c: dict) -> tuple[np.ndarray, np.ndarray]:
    """A fine block's cut edges (its coarse vertices ``used``, its points' classes
    ``c``) as numbers into ``plan.keys`` and each edge point's place on its edge
    (1 .. count - 1 from the edge's smaller coarse vertex)."""
    nvl = np.int64(max(len(used), 1))
    uk = c["edge_key"]
    ge = np.searchsorted(plan.keys, used[uk // nvl] * np.int64(len(plan.v)) + used[uk % nvl])
    return ge, np.rint(c["t"] * c["edge_count"][c["edge_point"]]).astype(np.int64)


def _keys(plan: MeshPlan, b: FineBlock) -> np.ndarray:
    """``(P,)`` int64: a number for each vertex of the fine block (halo too) that every
    block gives that point alike: its coarse vertex, its coarse edge and place on it,
    or its coarse face and grid point (what pins are kept by)."""
    c, nl, nv = b.classes, len(b.used), len(plan.v)
    n = int(plan.counts.max(initial=1)) + 1
    out = np.empty(len(b.v), dtype=np.int64)
    out[:nl] = b.used
    ne = len(c.get("t", ()))
    if ne:
        ge, pos = _edge_points(plan, b.used, c)
        out[nl:nl + ne] = nv + ge[c["edge_point"]] * n + pos
    face, w = b.near[c["inner_face"]], c["inner_w"]
    lev = plan.counts[face].max(axis=1)
    i, j = np.rint(w[:, 1] * lev).astype(np.int64), np.rint(w[:, 2] * lev).astype(np.int64)
    out[nl + ne:] = nv + len(plan.keys) * n + (face * n + i) * n + j
    return out


@dataclass(frozen=True)
class BlockRelief:
    """One block displaced: its emitted vertices ``v`` ``(k, 3)`` float32 mm, faces
    ``f`` (local), global numbers ``ids``, and per emitted vertex its undisplaced
    position ``v0`` (float64), displacement ``offset`` ``(k, 3)`` mm and its length
    along the offset direction ``d`` (mm, after the limiter); ``body``:
    each face's connected piece; ``mask``: per layer its mask's largest value there
    (None without a mask); ``folded``: faces the fold limiter lowered the texture
    at; ``moved``: the points (:func:`_keys`) next to the block's border it lowered
    and their displacements after it (mm); ``watch``: the points (sorted
    :func:`_keys`) whose pins the block's result depends on (the limiter's points
    next to its border or off its own faces); ``kept``: ``(keys, d)`` the limiter's
    points it lowered (sorted :func:`_keys`) and their displacements after it (mm),
    what the block starts from when it is made again."""

    v: np.ndarray
    f: np.ndarray
    ids: np.ndarray
    v0: np.ndarray
    offset: np.ndarray
    body: np.ndarray
    mask: Any
    folded: int
    moved: tuple
    d: np.ndarray
    watch: np.ndarray
    kept: tuple


def _relief(plan: MeshPlan, b: FineBlock, keep: np.ndarray, unit: np.ndarray) -> tuple[np.ndarray, tuple]:
    """Displacement (mm) of the block's vertices ``keep``, the layers' summed (each 0
    off its region), and per layer its mask's largest value there (None without one)."""
    d = np.zeros(len(b.v))
    masks = []
    for k, layer in enumerate(plan.layers):  # per layer
        m = _strict(plan, b, k)
        ins = np.zeros(len(b.v), dtype=bool)
        ins[b.f[m].ravel()] = True
        idx = np.flatnonzero(ins & keep)
        dist = layer.border_distance(plan.borders[k])(b.v[idx])
        if layer.projection.kind != "solid" and len(idx):
            layer.heights(b.v[idx[:1]], unit[idx[:1]])  # the samplers made once, before the threads
        parts = split_rows(lambda r: layer.relief_rows(b.v[idx[r]], unit[idx[r]], dist[r]), len(idx))
        if parts:
            d[idx] += np.concatenate([p[0] for p in parts])
        seen = [p[3] for p in parts if p[3] is not None and len(p[3])]
        masks.append(max(float(q.max()) for q in seen) if seen else None)
    return d, tuple(masks)


def _displace(plan: MeshPlan, b: FineBlock, pins: tuple, kept: "tuple | None" = None) -> BlockRelief:
    """The block's vertices moved along their offset directions by the relief
    (module docstring), limited (:func:`_limit`) on the faces :func:`_zone` names;
    ``pins`` ``(keys, d)``: points (sorted :func:`_keys`) whose displacement a block's
    limiter lowered, and to what (mm): they start from that here (``ids`` is left
    to the caller: the numbers go block after block, :class:`_Numbering`); ``kept``: the
    block's own lowered points when it was last made (:attr:`BlockRelief.kept`): the
    limiter starts from them where they are lower, so a block made again only
    limits what its changed pins changed (and, the limiter's result passing its own
    tests, made again with the same pins it gives the same result)."""
    unit = vertex_normals(b.v, b.f)
    dirs = offset_directions(b.v, b.f, unit)
    faces, seam = _zone(plan, b)
    used = np.zeros(len(b.v), dtype=bool)
    used[b.f[faces].ravel()] = True
    d, mask = _relief(plan, b, used, unit)
    if plan.bed is not None:  # no crest under the untextured bed face (texcad.targets.mesh.keep_bed)
        d = hold_above(b.v, dirs, d, *plan.bed)
    keys = _keys(plan, b)
    hit, at = _lookup(pins, keys, used)
    d[hit] = pins[1][at[hit]]
    start = d.copy()
    if kept is not None:
        hit, at = _lookup(kept, keys, used)
        start[hit] = np.where(np.abs(kept[1][at[hit]]) < np.abs(d[hit]), kept[1][at[hit]], d[hit])
    low = _limit(plan, b, faces, dirs, start, used)
    folded = _folded(b.v, b.f[b.own], dirs, np.where(used, d, 0.0))
    changed = seam & (low != d)
    lowered = used & (low != d)
    order = np.argsort(keys[lowered])
    keep = _owned(b)
    local = np.full(len(b.v), -1, dtype=np.int64)
    local[keep] = np.arange(int(keep.sum()))
    f = local[b.f[b.own]]
    v0 = b.v[keep]
    off = dirs[keep] * low[keep][:, None]
    v32 = (v0 + off).astype(np.float32)
    return BlockRelief(v32, f, None, v0, off, plan.body[b.near][b.src][b.own], mask, folded,
                       (keys[changed], low[changed]), low[keep], np.sort(keys[used & (seam | ~keep)]),
                       (keys[lowered][order], low[lowered][order]))


def _lookup(table: tuple, keys: np.ndarray, where: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(hit, at)``: which of ``keys`` (among ``where``) are in ``table``'s sorted
    keys ``table[0]``, and at which place."""
    if not len(table[0]):
        return np.zeros(len(keys), dtype=bool), np.zeros(len(keys), dtype=np.int64)
    at = np.minimum(np.searchsorted(table[0], keys), len(table[0]) - 1)
    return where & (table[0][at] == keys), at


def _zone(plan: MeshPlan, b: FineBlock) -> tuple[np.ndarray, np.ndarray]:
    """``(faces, seam)``: the refined faces the block's limiter runs on and the
    points whose lowering every block must hear of (bools over ``b.f``, ``b.v``).
    Folds only: the block's own faces (a face's test needs its corners alone) and its
    border points. With build directions the ridges between a border face and the
    one across also count: the own faces and every face at a border point, and the
    points of all those faces."""
    own = np.zeros(len(b.v), dtype=bool)
    own[b.f[b.own].ravel()] = True
    halo = np.zeros(len(b.v), dtype=bool)
    halo[b.f[~b.own].ravel()] = True
    border = own & halo
    if plan.dirs is None:
        return b.own, border
    touch = border[b.f].any(axis=1)
    seam = np.zeros(len(b.v), dtype=bool)
    seam[b.f[touch].ravel()] = True
    return b.own | touch, seam


def _limit(plan: MeshPlan, b: FineBlock, faces: np.ndarray, dirs: np.ndarray, d: np.ndarray,
           used: np.ndarray) -> np.ndarray:
    """The displacements (mm) after :func:`texcad.printability.limit_relief` on
    ``faces`` of the block (its points ``used``; ``d`` elsewhere). The faces are an
    open surface: the limiter tests the ridges at the edges of two of them, not at
    their border (where the faces across are another block's, or the halo's beyond
    the faces at the border points)."""
    idx = np.flatnonzero(used)
    local = np.full(len(b.v), -1, dtype=np.int64)
    local[idx] = np.arange(len(idx))
    low = d.copy()
    low[idx] = limit_relief(b.v[idx], local[b.f[faces]], dirs[idx], d[idx], build_dir=plan.dirs,
                            critical_angle=plan.crit)[0]
    return low


def _folded(v0: np.ndarray, f: np.ndarray, n: np.ndarray, d: np.ndarray) -> int:
    """Faces ``f`` that fold over (their normal turned by 90 degrees or more) when the
    points ``v0`` (mm) move by ``d`` along ``n``, on float32 positions (the count
    the limiter reports, for the warning)."""
    p = (v0 + n * d[:, None]).astype(np.float32).astype(np.float64)
    a, _ = face_normals(p, f)
    a0, _ = face_normals(v0, f)
    return int(np.sum((a * a0).sum(axis=1) <= 0.0))


def _make(plan: MeshPlan, k: int, pins: tuple, kept: "tuple | None") -> tuple:
    """Block ``k`` refined and displaced (:func:`_displace`), and what its numbers are
    made from (:meth:`_Numbering.number`): ``(BlockRelief, used, classes, ref)``.
    Plain data in and out: a Dask worker makes it as this process does."""
    b = fine_block(plan, plan.blocks[k], 1 if plan.dirs is None else 2)
    r = _displace(plan, b, pins, kept)
    c = {key: b.classes[key] for key in ("t", "edge_point", "edge_key", "edge_count") if key in b.classes}
    return r, b.used, c, _owned(b)


def _made(client: Any, plan: MeshPlan, todo: list, pins: tuple, kept: dict) -> Any:
    """``(k, _make(...))`` for the blocks ``todo``, in order: made here, or on the
    cluster's workers (the plan and pins sent once, at most two blocks per worker in
    flight, a task retried once)."""
    if client is None:
        for k in todo:  # per block
            yield k, _make(plan, k, pins, kept.get(k))
        return
    [p, q] = client.scatter([plan, pins], broadcast=True, hash=False)  # new keys: a key being released would hang
    yield from in_order(client, ((k, _make, (p, k, q, kept.get(k))) for k in todo))


class TiledMeshBlocks(CountedTiles):
    """A textured mesh kept as the recipe of its blocks (:class:`MeshPlan`, mm).
    Blocks are made on demand (:meth:`blocks`), gated (:func:`gate_mesh_blocks`) and
    written (:meth:`write`, streamed) one at a time."""

    def __init__(self, plan: MeshPlan, progress: Progress = None, client: Any = None) -> None:
        self.plan, self.progress, self.thickness = plan, progress, 0.0
        self.client = client  # texcad.texture(client=): the blocks made on that Dask cluster
        self.grid = None

    def displaced(self, progress: Progress = None, redo: Any = None) -> Any:
        """:class:`BlockRelief` per block, in order, made here or on the Dask
        cluster of ``client`` (:func:`_make`: the same bytes), each from the pins as
        they stand when called; with ``redo`` (block number -> bool) None for the
        blocks it says need not be made again (only numbered)."""
        plan = self.plan
        if "numbers" not in self.__dict__:
            self.__dict__["numbers"] = _Numbering.whole(plan)
        numbering, firsts = self.__dict__["numbers"]
        n = len(plan.blocks)
        todo = [k for k in range(n) if redo is None or redo(k)]
        kept = self.__dict__.setdefault("kept", {})  # per block: its lowered points when last made
        made = _made(self.client, plan, todo, self.__dict__.get("pins", (np.zeros(0, dtype=np.int64), np.zeros(0))), kept)
        todo = set(todo)
        for k in range(n):  # per block, in order
            if k not in todo:
                yield None
                continue
            r, used, classes, ref = next(made)[1]
            kept[k] = r.kept
            numbering.next = int(firsts[k])
            yield replace(r, ids=numbering.number(plan, used, classes, ref)[ref])
            report(progress, (k + 1) / n, f"block {k + 1}/{n}")

    def blocks(self, progress: Progress = None) -> Any:
        """``(block, vertices, faces, ids)`` per block: float32 mm, local faces,
        global numbers (each block's new vertices numbered on from the last's)."""
        for k, r in enumerate(self.displaced(progress)):  # per block
            yield k, r.v, r.f, r.ids

    def share(self, t: Any, v: np.ndarray, f: np.ndarray) -> float:
        from ..solid.tiles import block_volume

        return block_volume(v, f)

    def gate(self, ex: Any) -> Any:
        """texcad's gate on this mesh, block by block (:func:`gate_mesh_blocks`)."""
        return gate_mesh_blocks(self, ex)

    def __repr__(self) -> str:
        return f"TiledMeshBlocks({len(self.plan.f)} coarse triangles in {len(self.plan.blocks)} blocks)"


def _face_terms(v: np.ndarray, f: np.ndarray, o: np.ndarray) -> np.ndarray:
    """``a . (b x c)`` per face about ``o`` (six times the tetrahedron's volume), float64."""
    x = np.asarray(v, dtype=np.float64) - o
    a, b, c = x[f[:, 0]], x[f[:, 1]], x[f[:, 2]]
    return (a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1]) + a[:, 1] * (b[:, 2] * c[:, 0] - b[:, 0] * c[:, 2])
            + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0]))


@dataclass
class _Tally:
    """What one pass over the blocks adds up for the gate (volumes mm^3, lengths mm)."""

    out_vol: np.ndarray
    in_vol: np.ndarray
    edges: list
    seam_ids: list
    seam_xyz: list
    moved: list
    swept: float = 0.0
    spread: float = 0.0
    farthest: float = 0.0
    finite: bool = True
    nv: int = 0
    nt: int = 0
    folded: int = 0
    masked: Any = None

    @staticmethod
    def merged(shares: list) -> "_Tally":
        """The blocks' tallies added up, in block order."""
        t = _Tally(np.zeros_like(shares[0].out_vol), np.zeros_like(shares[0].in_vol), [], [], [], [])
        for s in shares:  # per block
            t.finite &= s.finite
            t.out_vol += s.out_vol
            t.in_vol += s.in_vol
            t.nv, t.nt, t.folded = max(t.nv, s.nv), t.nt + s.nt, t.folded + s.folded
            t.swept, t.spread, t.farthest = t.swept + s.swept, t.spread + s.spread, max(t.farthest, s.farthest)
            t.masked = _most(t.masked, s.masked)
            t.edges += s.edges
            t.seam_ids += s.seam_ids
            t.seam_xyz += s.seam_xyz
            t.moved += s.moved
        return t

    def add(self, r: BlockRelief, o: np.ndarray) -> None:
        """Block ``r``'s shares, volumes about the point ``o``."""
        nb = len(self.out_vol)
        self.finite &= bool(np.isfinite(r.v).all())
        self.nv, self.nt, self.folded = max(self.nv, int(r.ids.max(initial=-1)) + 1), self.nt + len(r.f), self.folded + r.folded
        self.out_vol += np.bincount(r.body, weights=_face_terms(r.v, r.f, o), minlength=nb) / 6.0
        before = _face_terms(r.v0, r.f, o)
        self.in_vol += np.bincount(r.body, weights=before, minlength=nb) / 6.0
        self.swept += float((_face_terms(r.v0 + r.offset, r.f, o) - before).sum()) / 6.0
        shift = np.linalg.norm(r.offset, axis=1)
        self.spread += float((_areas(r.v0, r.f) / 3.0 * shift[r.f].sum(axis=1)).sum())
        self.farthest = max(self.farthest, float(np.linalg.norm(r.v.astype(np.float64) - r.v0, axis=1).max(initial=0.0)))
        self.masked = _most(self.masked, r.mask)
        open_, _ = open_edges(r.ids[r.f])
        self.edges.append(open_)
        ring = np.unique(open_)
        self.seam_ids.append(ring)
        self.seam_xyz.append(_at(r.ids, r.v, ring))
        self.moved.append(r.moved)


#: Most passes over the blocks before the limiters' border points are given up on.
MAX_PASSES = 30


def _most(a: "tuple | None", b: "tuple | None") -> "tuple | None":
    """Per layer the larger of two masks' largest values (None: no value yet)."""
    if a is None or b is None:
        return b if a is None else a
    return tuple(y if x is None else (x if y is None else max(x, y)) for x, y in zip(a, b))


def _tally(mesh: "TiledMeshBlocks") -> _Tally:
    """Passes over the blocks; where a block's limiter lowered a point next to its
    border (:func:`_zone`), that point is pinned at its least displacement after the
    pass (every block of a pass starts from the pins as they stood at its start, so
    the blocks of a pass can be made in any order and anywhere), and the blocks whose
    watched points' pins changed since they were made are made again, until no
    limiter lowers such a point (from the second pass on, a point it lowers is pinned
    at 0, where the limiter leaves it). A block made again with the pins it was made
    with gives the same result, so the others keep their shares of the tally."""
    plan = mesh.plan
    o = 0.5 * (plan.v.min(axis=0) + plan.v.max(axis=0))
    nb = int(plan.body.max()) + 1
    shares: list = [None] * len(plan.blocks)  # per block: (its tally, the points it watches, the clock when made)
    clock = _Clock()
    redo = lambda k: shares[k] is None or clock.changed(shares[k][1], shares[k][2])  # noqa: E731
    colour = _colours(plan)
    for k in range(MAX_PASSES):  # per pass: pins only grow and go down
        settled = True
        for c in range(int(colour.max()) + 1):  # per colour: its blocks from the pins as they stand
            moved = []
            for j, r in enumerate(mesh.displaced(mesh.progress, lambda b: colour[b] == c and redo(b))):  # noqa: B023
                if r is None:
                    continue
                t = _Tally(np.zeros(nb), np.zeros(nb), [], [], [], [])
                t.add(r, o)
                shares[j] = (t, r.watch, clock.now)
                if len(r.moved[0]):
                    moved.append(r.moved)
            if moved:
                settled = False
                mesh.__dict__["pins"] = clock.pin(mesh.__dict__.get("pins"), moved, zero=k >= 1)
        if settled:
            mesh.__dict__["passes"] = k + 1
            return _Tally.merged([sh[0] for sh in shares])
    raise GeometryError(f"the texture folds over or overhangs across block borders, and pinning them did not settle it; "
                        f"use a smaller height or a pitch of at least {plan.fits:.3g} mm (made whole)")


def _colours(plan: MeshPlan) -> np.ndarray:
    """``(B,)`` a colour per block, no two blocks that share a coarse vertex (whose
    limiters' points can meet) of one colour: greedy, in block order. The blocks of
    one colour are made from the same pins (in any order, on a cluster too), the
    colours one after the other, each from the pins the ones before left."""
    from scipy.sparse import coo_matrix

    rows = np.concatenate([np.full(3 * len(b), k) for k, b in enumerate(plan.blocks)])
    cols = np.concatenate([plan.f[b].ravel() for b in plan.blocks])
    inc = coo_matrix((np.ones(len(rows), dtype=np.int32), (rows, cols)), shape=(len(plan.blocks), len(plan.v))).tocsr()
    touch = (inc @ inc.T).tolil().rows
    out = np.full(len(plan.blocks), -1, dtype=np.int64)
    for k in range(len(plan.blocks)):  # per block: the least colour none of its earlier neighbours has
        taken = set(out[touch[k]].tolist())
        out[k] = next(c for c in range(len(plan.blocks) + 1) if c not in taken)
    return out


class _Clock:
    """When each pin last changed (a count of the pins' changes), to tell which blocks
    must be made again."""

    def __init__(self) -> None:
        self.now = 0
        self.keys = np.zeros(0, dtype=np.int64)
        self.when = np.zeros(0, dtype=np.int64)

    def pin(self, pins: "tuple | None", moved: list, zero: bool) -> tuple:
        """:func:`_pinned`, noting the pins that are new or lower now."""
        new = _pinned(pins, moved, zero)
        old = pins if pins is not None else (np.zeros(0, dtype=np.int64), np.zeros(0))
        at = np.minimum(np.searchsorted(old[0], new[0]), max(len(old[0]) - 1, 0))
        same = (old[0][at] == new[0]) & (old[1][at] == new[1]) if len(old[0]) else np.zeros(len(new[0]), dtype=bool)
        self.now += 1
        prev = np.zeros(len(new[0]), dtype=np.int64)
        seen = np.minimum(np.searchsorted(self.keys, new[0]), max(len(self.keys) - 1, 0))
        if len(self.keys):
            hit = self.keys[seen] == new[0]
            prev[hit] = self.when[seen[hit]]
        self.keys, self.when = new[0], np.where(same, prev, self.now)
        return new

    def changed(self, watch: np.ndarray, since: int) -> bool:
        """Whether a pin on any of the points ``watch`` (sorted keys) changed after
        ``since``."""
        if not len(self.keys) or not len(watch):
            return False
        at = np.minimum(np.searchsorted(self.keys, watch), len(self.keys) - 1)
        hit = self.keys[at] == watch
        return bool(np.any(self.when[at[hit]] > since))


def _pinned(pins: "tuple | None", moved: list, zero: bool) -> tuple:
    """``(keys, d)`` sorted: the pins and the newly lowered points, each at
    its least displacement (mm; the limiter only lowers, keeping the sign); with
    ``zero`` the newly lowered ones at 0 (the undisplaced surface, where the limiter
    itself ends: after the first pass, so that the passes settle: a limiter that lowers
    a pinned point again would shrink it pass after pass)."""
    ids = np.concatenate([m[0] for m in moved] + ([pins[0]] if pins else []))
    d = np.concatenate([m[1] * (0.0 if zero else 1.0) for m in moved] + ([pins[1]] if pins else []))
    order = np.lexsort((np.abs(d), ids))
    ids, d = ids[order], d[order]
    first = np.r_[True, ids[1:] != ids[:-1]]
    return ids[first], d[first]


def gate_mesh_blocks(mesh: "TiledMeshBlocks", ex: Any) -> Any:
    """texcad's gate (checks 1-5, :func:`texcad.report.gate.gate`) on a mesh made in
    blocks, in memory that goes with one block plus the blocks' open edges:

    1. closed and oriented: the blocks' open edges (global numbers) pair up, each
       directed edge once and its reverse once; a vertex in two blocks is the same
       float32 point in both; every vertex finite;
    2-3. as many bodies (connected shells) as the input, each with the sign of its
       input's volume;
    4. the volume change of the written float32 mesh against the texture's swept
       volume (the prisms between every face and its displaced copy, float64, summed
       over blocks) within 5 % of ``sum |d| A`` (as the untiled adapter);
    5. every vertex moved at most the plan's reach (3 times the height: the longest
       offset direction) from where it was.

    Returns:
        :class:`texcad.report.gate.GateReport`; sets the mesh's volume and counts.

    Raises:
        GeometryError: a check failed (the message names it and the figures).
        ParameterError: the texture's mask covers none of the region.
    """
    from ..report.gate import ShellReport

    what = "textured mesh (in blocks)"
    t = _tally(mesh)
    if t.masked is not None and any(m is not None and not m > 0 for m in t.masked):
        raise ParameterError("the mask covers none of the region: check mask_size (mm) and the projection's origin")
    if t.folded:
        warnings.warn(f"the texture was lowered where {t.folded} faces would fold over (too deep for the curvature there)",
                      TexcadWarning, stacklevel=3)
    apart = _apart(np.concatenate(t.seam_ids), np.concatenate(t.seam_xyz))
    if apart:
        raise GeometryError(f"the {what} failed texcad's gate: {apart} vertices differ between neighbouring blocks "
                            "(a gap at a seam); please report this")
    open_, bad = open_edges(np.concatenate(t.edges))
    closed = t.finite and not len(open_) and not bad
    nb = len(t.out_vol)
    flipped = int(np.sum(np.sign(t.out_vol) != np.sign(t.in_vol)))
    shells = ShellReport(closed=closed, open_edges=len(open_), nonmanifold_edges=bad, misoriented_edges=0,
                         volumes=tuple(sorted(t.out_vol.tolist(), reverse=True)), nesting=(0,) * nb, inside_out=flipped,
                         nested_bodies=0, bodies=nb)
    if not shells.manifold or nb != int(ex.bodies) or flipped:
        raise GeometryError(f"the {what} failed texcad's gate: {shells.problem() or ''} {nb} bodies where the input had "
                            f"{ex.bodies}, {flipped} turned inside out; please report this")
    volume = float(t.out_vol.sum())
    mesh.__dict__.update(volume=volume, counts=(t.nv, t.nt), closed=closed, swept=t.swept)
    change = volume - float(t.in_vol.sum())
    slack = 0.05 * t.spread + 1e-6 * abs(float(t.in_vol.sum())) + 1e-6
    return tiles_verdict(what, shells, change, t.swept, slack, t.farthest, float(mesh.plan.reach), "surface it was put on")


def _areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    _, area = face_normals(v, f)
    return area


def _apart(sid: np.ndarray, sxyz: np.ndarray) -> int:
    """How many vertices in two blocks are not the same float32 point in both."""
    order = np.argsort(sid, kind="stable")
    sid, sxyz = sid[order], sxyz[order]
    same = sid[1:] == sid[:-1]
    return int(np.sum(np.any(sxyz[1:][same] != sxyz[:-1][same], axis=1)))
