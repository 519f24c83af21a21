"""Adapter: one planar face of a CAD part (any outline, holes included).

**Place.** The face's frame (x along world x on horizontal faces, y towards world +z
otherwise, ``rotation`` turns it; :func:`texcad.brep.plane_frame`), its outline as 2-D
segments, a pixel grid over the outline's bounding rectangle, and the distance ``d``
(mm) of every grid vertex from the nearest vertex outside the face or under other
parts of the body within the texture height.

**Relief.** The texture fitted to the face (centred, ``offset``), then the paper's
edge modification M-I (section 2.1.3) on every border,

    h' = min(h, tan(edge_angle) * max(0, d - 3 sqrt(px^2 + py^2)))

(0 on every cell the outline crosses, then rising at ``edge_angle``), a floor of
:data:`FLOOR` mm inside the ramp, the overhang limiter for ``build_dir``
(:func:`texcad.printability.limit_overhangs`) and the slab mesh (lean within
``tolerance``, or one vertex per pixel; also where a lean top would cross steep
cells far from the pixel grid's surface, :func:`_lean_crosses`: pins a few pixels
across).

**Fuse.** A lean relief on an unobstructed face is stitched into the body's mesh
without a boolean (:func:`texcad.solid.boolean.fuse_on_plane`, checked); otherwise
manifold3d's union. **B-rep**: the textured part of the plane becomes B-spline tiles
sewn to the face's own edges (:func:`texcad.brep.textured_plane_solid`), their
heights moved from the pixel grid's so that they enclose the lean mesh's volume
within its tolerance of it (:func:`_brep_heights`, from the cell offsets the relief
made for its crossing test, :class:`CellOffsets`).

**Tiles.** Where the untiled relief would not fit in the memory available (the
machine's, or ``max_memory``), the face is made in tiles instead
(:mod:`texcad.targets.tiled_faces`): the same heights and ramps a tile at a time, lean
blocks inside the texture within ``tolerance`` (every pixel centre kept with 0),
the face round the texture re-triangulated on its own
outline, the result a :class:`~texcad.targets.tiled_faces.TiledFaceMesh` that the
gate checks and the export streams tile by tile (``info["fuse"] == "tiled"``).
With ``build_dir`` the ramped heights are limited block by block (the untiled limited
heights, bit for bit). Part material over the face within the texture's height is
not tiled: refused, naming a pitch that fits; a tiled face has no B-rep (STL / 3MF).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..brep import face_segments, inside, plane_frame, sample_segments, textured_plane_solid
from ..contracts import Fused, Placement, Relief, Stages
from ..errors import GeometryError, ParameterError
from ..options import Mode, Options
from ..sources import Heightmap
from ..solid import Mesh, from_manifold, fuse, heightfield_slab, mesh_error, to_manifold
from ..solid.boolean import welded_mesh, fuse_on_plane
from ..solid.mesh import heightfield_volume
from ..util import fitting_pitch, require_memory, texture_bytes
from .base import Adapter, Decline
from .cad import body_count, cad_part, face_list, is_cad_target, selected_surface, tessellation

__all__ = ["PlaneAdapter", "FLOOR"]

#: mm: the texture is at least this high inside its ramp, so that it never touches the
#: face along isolated lines or points (a union would keep pinched vertices there).
FLOOR = 1e-3


@dataclass(frozen=True)
class PlaneFrame:
    """A planar face placed: frame (mm, unit vectors), outline (local 2-D segments
    ``(S, 2, 2)`` centred on the bounding rectangle ``lo..hi``), the base mesh in the
    face's frame (z = 0 on the face), and the footprint of body material above the
    face (``obstruction``, segments, or None)."""

    face: Any
    origin: np.ndarray
    axes: np.ndarray
    segments: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    base_local: Mesh


@dataclass(frozen=True)
class PlaneFused:
    """The fused mesh in the face's frame, and the stitched relief (or None after a union)."""

    local: Mesh
    stitched: "Mesh | None"


def _positive_volume(vertices: np.ndarray, faces: np.ndarray, z0: float) -> float:
    """mm^3: the volume between ``z = z0`` and the triangles ``faces`` of
    ``vertices`` (``(N, 3)`` mm, a heightfield's top) where they lie above it,
    exactly: per triangle of projected area ``A`` and heights ``a <= b <= c`` (mm
    above ``z0``) ``A (a + b + c) / 3`` less the part below, ``A a^3 / (3 (a - b)
    (a - c))`` where only ``a < 0``, or ``A c^3 / (3 (c - a) (c - b))`` where only
    ``c > 0`` (the linear height over the corner triangle the plane cuts off)."""
    v = np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)]
    e1, e2 = v[:, 1, :2] - v[:, 0, :2], v[:, 2, :2] - v[:, 0, :2]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    a, b, c = np.sort(v[:, :, 2] - z0, axis=1).T
    with np.errstate(divide="ignore", invalid="ignore"):
        one_below = (a + b + c) / 3 - a ** 3 / (3 * (a - b) * (a - c))
        one_above = c ** 3 / (3 * (c - a) * (c - b))
    mean = np.where(a >= 0, (a + b + c) / 3, np.where(b >= 0, one_below, np.where(c > 0, one_above, 0.0)))
    return float((area * mean).sum())


def _far_from_lean(q: np.ndarray, rr: np.ndarray, cc: np.ndarray, V: np.ndarray, F: np.ndarray, xs: np.ndarray,
                   ys: np.ndarray, shape: tuple, limit: float) -> np.ndarray:
    """``(N,)`` bool: the points ``q`` (``(N, 3)`` mm, over pixel centres ``(rr,
    cc)`` of the ``shape`` grid at ``(xs, ys)``) that lie more than ``limit`` mm from
    the lean top (triangles ``F`` of ``V``, corners at pixel centres; libigl's AABB
    search). Only the triangles whose pixel bounding box comes within ``m =
    ceil(limit / pitch + 0.01)`` pixels of a point are searched (a summed-area table
    of the points' pixels): a triangle within ``limit`` of a point has a point within
    ``limit`` of it in x and y, so the answer is the whole top's, and the tree is
    built on a few triangles instead of all."""
    import igl

    R, C = shape
    vc = np.rint((V[:, 0] - xs[0]) / (xs[1] - xs[0])).astype(np.int64)[F]
    vr = np.rint((V[:, 1] - ys[0]) / (ys[1] - ys[0])).astype(np.int64)[F]
    m = int(np.ceil(limit / min(xs[1] - xs[0], ys[1] - ys[0]) + 0.01))  # (0.01: float32 vertices)
    marked = np.zeros((R + 1, C + 1), np.int64)
    marked[rr + 1, cc + 1] = 1
    S = marked.cumsum(0).cumsum(1)  # S[i, j]: points in rows < i, columns < j
    lo = lambda a: np.minimum(np.minimum(a[:, 0], a[:, 1]), a[:, 2]) - m  # noqa: E731
    hi = lambda a: np.maximum(np.maximum(a[:, 0], a[:, 1]), a[:, 2]) + m  # noqa: E731
    r0, r1, c0, c1 = np.clip(lo(vr), 0, R - 1), np.clip(hi(vr), 0, R - 1) + 1, np.clip(lo(vc), 0, C - 1), np.clip(hi(vc), 0, C - 1) + 1
    near = F[S[r1, c1] - S[r0, c1] - S[r1, c0] + S[r0, c0] > 0]
    if not len(near):
        return np.ones(len(q), bool)
    return igl.point_mesh_squared_distance(q, V, near)[0] > limit ** 2


def _far_from(g: np.ndarray, h: np.ndarray, at: np.ndarray, xs: np.ndarray, ys: np.ndarray, z0: float, V: np.ndarray,
              F: np.ndarray, limit: float) -> np.ndarray:
    """``(R, C)`` bool: the pixel centres moved off ``h`` to ``g`` (mm, at ``(xs,
    ys)`` over ``z0``) that lie more than ``limit`` mm from the lean top (triangles
    ``F`` of ``V``; ``at`` its heights there), or under a vertex of it (a kept pixel
    centre) that lies more than ``limit`` from the grid through ``g`` (libigl's AABB
    search both ways). Only moves of more than ``limit`` (off ``at``, resp. ``h``)
    are searched: a vertical gap bounds the distance."""
    import igl

    from ..solid import grid_faces

    R, C = g.shape
    out = np.zeros(g.shape, bool)
    rr, cc = np.nonzero((g != h) & (np.abs(g - at) > limit))
    if len(rr):
        q = np.stack([xs[cc], ys[rr], z0 + g[rr, cc]], axis=1).astype(np.float64)
        out[rr, cc] = _far_from_lean(q, rr, cc, V, F, xs, ys, g.shape, limit)
    used = np.zeros(len(V), bool)
    used[F] = True
    used = np.flatnonzero(used)  # np.unique(F), without sorting 3 M indices
    kc = np.rint((V[used, 0] - xs[0]) / (xs[1] - xs[0])).astype(np.int64)
    kr = np.rint((V[used, 1] - ys[0]) / (ys[1] - ys[0])).astype(np.int64)
    near = np.abs(g[kr, kc] - h[kr, kc]) > limit  # kept pixel centres that moved more than limit
    if near.any():
        kr, kc = kr[near], kc[near]
        # the grid's triangles in the 4 cells round each (the nearest point within limit < pitch lies there)
        ci = np.clip(kr[:, None] + np.array([-1, -1, 0, 0]), 0, R - 2)
        cj = np.clip(kc[:, None] + np.array([-1, 0, -1, 0]), 0, C - 2)
        cells = np.unique((ci * (C - 1) + cj).ravel())
        tri = grid_faces(R, C).astype(np.int64)[np.stack([2 * cells, 2 * cells + 1], axis=1).ravel()]
        gx, gy = np.meshgrid(xs, ys)
        grid = np.stack([gx.ravel(), gy.ravel(), z0 + g.ravel()], axis=1).astype(np.float64)
        q = np.stack([xs[kc], ys[kr], z0 + h[kr, kc]], axis=1).astype(np.float64)
        far = igl.point_mesh_squared_distance(q, grid, tri)[0] > limit ** 2
        out[kr[far], kc[far]] = True
    return out


@dataclass(frozen=True)
class CellOffsets:
    """A lean top against the pixel grid's surface cell by cell (:func:`_cell_offsets`):
    ``cells`` ``(R - 1, C - 1)`` mm, ``e_c = T_c - B_c``; ``centres`` ``(R, C)`` mm, the
    lean top's heights at the pixel centres (0 where it lies below the face)."""

    cells: np.ndarray
    centres: np.ndarray


def _cell_offsets(h: np.ndarray, slab: Mesh, origin: tuple, pitch: tuple) -> CellOffsets:
    """How far the lean top of ``slab`` (its ``"texture"`` group, over ``origin``)
    lies above the bilinear surface through ``h`` (``(R, C)`` mm, pixel ``pitch``)
    on average over each pixel cell: ``T_c - B_c``, ``T_c`` the lean top's mean
    height over the cell by the trapezoid rule on the grid refined twice
    (:func:`texcad.solid.lean.refined_heights`, weights 1, 2, 4 / 16, only above the
    face), ``B_c`` the mean of the cell's corners. Made once per relief: the crossing
    test (:func:`_lean_crosses`) and the B-rep's heights (:func:`_brep_heights`,
    through :attr:`PlaneRelief.offsets`) use the same."""
    from ..solid.lean import refined_heights

    top = slab.faces[slab.groups["texture"]]
    L = np.nan_to_num(np.maximum(refined_heights(slab.vertices, top, origin, pitch, h.shape), 0.0))
    corner = lambda g, i, j: g[i:g.shape[0] - 2 + i:2, j:g.shape[1] - 2 + j:2]  # noqa: E731 - (R-1, C-1) points of each cell
    T = (corner(L, 0, 0) + corner(L, 0, 2) + corner(L, 2, 0) + corner(L, 2, 2)
         + 2 * (corner(L, 1, 0) + corner(L, 1, 2) + corner(L, 0, 1) + corner(L, 2, 1)) + 4 * corner(L, 1, 1)) / 16
    g = np.asarray(h, np.float64)
    return CellOffsets(T - 0.25 * (g[:-1, :-1] + g[1:, :-1] + g[:-1, 1:] + g[1:, 1:]), np.ascontiguousarray(L[::2, ::2]))


def _lean_crosses(h: np.ndarray, offsets: CellOffsets, pitch: tuple, tolerance: float) -> float:
    """The volume (mm^3) the lean top loses against the pixel grid's surface (``h``,
    ``(R, C)`` mm, pixel ``pitch``) in the cells it crosses more than ``tolerance``
    away from it on average (``offsets``, :func:`_cell_offsets`), as a share of
    ``tolerance`` x the textured area: about 0.01 on stones (its chords stay near the
    grid), 0.7-1.1 on pins 2 px across (its triangles cut their edges between the
    pixel centres), where neither the gate's allowance (the tolerance x area) nor a
    B-rep through the pixel centres near the mesh holds."""
    e = offsets.cells
    far = np.abs(e) > tolerance
    textured = float((np.asarray(h) > 0).sum()) * pitch[0] * pitch[1]
    return abs(float(e[far].sum())) * pitch[0] * pitch[1] / max(tolerance * textured, 1e-300)


def _brep_heights(r: "PlaneRelief") -> np.ndarray:
    """``(R, C)`` mm: the heights the B-rep is made of: ``r.h`` moved so that its
    bilinear surface encloses the lean mesh's volume, near where the lean mesh has
    it. A lean top is within ``tolerance`` of ``r.h`` at the pixel centres only:
    between them its chords cut under convex stones (a stones plate at 0.125 mm read
    0.12 % below its B-rep) and, where the relief is steep, its triangles cross the
    cells other than the grid's diagonals (pins 2 px across at 0.5 mm: 0.53 %).

    Each cell ``c`` (area ``A = px py``) is off by ``e_c = A (T_c - B_c)``: ``T_c``
    the lean top's mean height over it by the trapezoid rule on the grid refined
    twice (:func:`_cell_offsets`, made with the relief, weights 1, 2, 4 / 16),
    ``B_c`` the mean of its corners (the bilinear surface's). Its corners with
    ``h > 0`` (the face round the relief stays) move by ``e_c / (A n_c)`` each
    (``n_c`` of them; a corner raised by ``d`` adds ``A d`` to the bilinear
    volume), averaged over :data:`~texcad.brep.targets.LEAN_SMOOTH` pixels a side
    where the relief is gentle (the STEP tiles fit as few poles). A pixel centre
    stays within ``a = REACH x tolerance`` of the lean top across its steepest facet
    (slope ``s``: ``|g - L| <= a sqrt(1 + s^2)``); what the estimate misses of the
    exact difference (the lean top's volume above the face,
    :func:`_positive_volume`, less the grid's,
    :func:`~texcad.solid.mesh.heightfield_volume`) goes to the pixel centres in
    proportion to the room they have. Where no facet is steeper than :data:`WALL`
    every moved pixel centre is then checked against the lean top, and every kept
    vertex of the lean top against the moved grid (:func:`_far_from`): a move that
    puts them more than ``a`` apart is halved (and the volume spread again), so the
    B-rep lies within the tolerance of the mesh there."""
    if r.tolerance <= 0:
        return r.h
    from scipy.ndimage import maximum_filter, minimum_filter, uniform_filter

    from ..brep.targets import LEAN_SMOOTH as smooth

    s = r.slab
    top = s.faces[s.groups["texture"]]
    px, py = float(r.xs[1] - r.xs[0]), float(r.ys[1] - r.ys[0])
    area = px * py
    h = np.asarray(r.h, np.float64)
    o = r.offsets if r.offsets is not None else _cell_offsets(h, s, r.slab_origin, (px, py))
    e = o.cells
    ok = h > 0
    okf = ok.astype(np.float64)
    n = okf[:-1, :-1] + okf[1:, :-1] + okf[:-1, 1:] + okf[1:, 1:]
    share = np.where(n > 0, e / np.maximum(n, 1.0), 0.0)
    d = np.zeros_like(h)
    d[:-1, :-1] += share
    d[1:, :-1] += share
    d[:-1, 1:] += share
    d[1:, 1:] += share
    d *= okf
    # gentle relief: the offsets averaged (the STEP tiles fit as few poles)
    gentle = ok & (maximum_filter(h, 3) - minimum_filter(h, 3) <= STEEP * min(px, py))
    wf = gentle.astype(np.float64)
    mean = uniform_filter(d * wf, smooth, mode="constant") / np.maximum(uniform_filter(wf, smooth, mode="constant"), 1e-12)
    d = np.where(gentle, mean, d)
    target = _positive_volume(s.vertices, top, float(r.slab_origin[2]))
    dx, dy = np.abs(np.diff(h, axis=1)) / px, np.abs(np.diff(h, axis=0)) / py
    sx = np.maximum(np.pad(dx, ((0, 0), (1, 0))), np.pad(dx, ((0, 0), (0, 1))))
    sy = np.maximum(np.pad(dy, ((1, 0), (0, 0))), np.pad(dy, ((0, 1), (0, 0))))
    limit = REACH * r.tolerance
    reach = limit * np.sqrt(1.0 + sx ** 2 + sy ** 2)
    checked = np.maximum(sx, sy) <= WALL
    at = o.centres
    lo = np.minimum(np.where(ok, np.maximum(at - reach, 0.0), h), h)  # (the grid itself always may be)
    hi = np.maximum(np.where(ok, at + reach, h), h)
    g = np.clip(h + d, lo, hi)
    V, F = np.asarray(s.vertices, np.float64), np.asarray(top, np.int64)
    z0 = float(r.slab_origin[2])
    for _ in range(CHECKS):
        for _ in range(2):  # what the estimate missed, to the corners with room, in proportion to it
            miss = target - heightfield_volume(g, (px, py))[0]
            room = (hi - g) if miss > 0 else (g - lo)
            if not room.sum() > 0 or abs(miss) <= 1e-9 * target:
                break
            g = np.clip(g + np.sign(miss) * min(1.0, abs(miss) / (area * room.sum())) * room, lo, hi)
        far = _far_from(g, h, at, r.xs, r.ys, z0, V, F, limit) & checked
        if not far.any():
            break
        half = h + 0.5 * (g - h)
        lo, hi = np.where(far, np.minimum(half, h), lo), np.where(far, np.maximum(half, h), hi)
        g = np.where(far, half, g)
    else:
        g = np.where(_far_from(g, h, at, r.xs, r.ys, z0, V, F, limit) & checked, h, g)
    return g.astype(np.asarray(r.h).dtype)


#: Largest :func:`_lean_crosses` a lean slab may have (else the pixel grid is used).
CROSSING = 0.25
#: Gentle relief (:func:`_brep_heights` averages its offsets): heights within
#: ``STEEP`` pitches over every 3 x 3 pixels.
STEEP = 4.0
#: The B-rep's pixel centres stay within this share of the tolerance of the lean top
#: (across its slope), so within it of the mesh.
REACH = 0.9
#: Rounds of :func:`_brep_heights`' distance check.
CHECKS = 4
#: Steep relief (a facet's slope above ``WALL``, 76 degrees): the lean top crosses
#: the pixel cells there far from the grid's surface (2 px pins: by 1 mm in the middle
#: of a cell), so its pixel centres may move by :data:`REACH` x tolerance across the
#: slope without the distance check.
WALL = 4.0


@dataclass(frozen=True)
class PlaneRelief:
    """The relief on a planar face: heights ``h`` (R, C) mm on pixel centres ``xs``,
    ``ys`` (face frame), the meshed field ``h_mesh`` (-1 mm off the face), the slab,
    whether body material lies over the face, ``field_volume``: ``h_mesh``'s
    :func:`~texcad.solid.mesh.heightfield_volume` ``(volume, slack)`` mm^3, and
    ``offsets``: a lean slab's :class:`CellOffsets` for the B-rep (None without one
    or with ``brep=False``; :func:`_brep_heights` makes them then)."""

    h: np.ndarray
    h_mesh: np.ndarray
    xs: np.ndarray
    ys: np.ndarray
    slab: Mesh
    slab_origin: tuple
    tolerance: float
    obstructed: bool
    field_volume: tuple = (0.0, 0.0)
    offsets: "CellOffsets | None" = None


def _local(points: np.ndarray, origin: np.ndarray, axes: np.ndarray) -> np.ndarray:
    return (np.asarray(points, np.float64) - origin) @ axes.T


def _place_heightmap(hm: Heightmap, xs_k: np.ndarray, ys_k: np.ndarray) -> np.ndarray:
    """Heights on the grid columns/rows ``k`` (integer pixel indices of ``hm``; 0 mm
    outside the texture)."""
    rows, cols = hm.shape
    h = np.zeros((len(ys_k), len(xs_k)), dtype=np.float32)
    cm = (xs_k >= 0) & (xs_k < cols)
    rm = (ys_k >= 0) & (ys_k < rows)
    if cm.any() and rm.any():
        h[np.ix_(rm, cm)] = hm.heights[np.ix_(ys_k[rm], xs_k[cm])]
    return h


def _obstruction_segments(base_local: Mesh, lo: np.ndarray, hi: np.ndarray, top: float) -> np.ndarray | None:
    """Footprint (2-D segments) of body material above the face plane within ``top``
    mm, over the rectangle ``lo..hi`` (local frame): texture there would run into the body."""
    import manifold3d as m3d

    z0 = 1e-3
    if top <= z0:
        return None
    box = m3d.Manifold.cube((float(hi[0] - lo[0]), float(hi[1] - lo[1]), float(top))).translate((float(lo[0]), float(lo[1]), z0))
    above = to_manifold(base_local) ^ box
    if above.is_empty() or above.volume() < 1e-9:
        return None
    segs = [np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in above.project().to_polygons() if len(p) >= 3]  # per polygon
    return np.concatenate(segs) if segs else None


def _require_relief(hm: Heightmap, tex: Any) -> None:
    if not float(hm.heights.max()) > 0:
        raise ParameterError(
            f"the texture {tex if isinstance(tex, str) else 'heightmap'!s} is flat (0 mm everywhere) at a pitch of "
            f"{min(hm.pitch):.3g} mm: its features are finer than the pitch; use a smaller pitch"
        )


def _check_flat_outline(h: np.ndarray, xs: np.ndarray, ys: np.ndarray, pts: np.ndarray) -> None:
    """The bilinear surface must be exactly 0 mm along the outline (so the face's
    edges lie on it): check at the outline samples."""
    px, py = xs[1] - xs[0], ys[1] - ys[0]
    fx = np.clip((pts[:, 0] - xs[0]) / px, 0, len(xs) - 1.000001)
    fy = np.clip((pts[:, 1] - ys[0]) / py, 0, len(ys) - 1.000001)
    c, r = fx.astype(np.int64), fy.astype(np.int64)
    cells = np.maximum.reduce([h[r, c], h[r + 1, c], h[r, c + 1], h[r + 1, c + 1]])
    if cells.max() > 0:
        raise GeometryError("internal: the texture does not vanish along the face outline; please report this")


def _masked(h: np.ndarray, fr: PlaneFrame, xs: np.ndarray, ys: np.ndarray, options: Options) -> np.ndarray:
    """``h`` (mm) scaled by ``options.mask`` (values in [0, 1]: 0 no texture, 1 the
    full height), stretched over ``options.mask_size`` mm of the face's texture
    coordinates (default: the face's bounding rectangle), centred on the face and
    sampled bilinearly at the grid ``(xs, ys)`` mm; 0 outside the mask. Heights
    are scaled before the ramps and the limiter, so both still hold."""
    if options.mask is None:
        return h
    from ..sources.mask import mask_on_grid

    size = options.mask_size if options.mask_size is not None else tuple(float(t) for t in fr.hi - fr.lo)
    return (h * mask_on_grid(options.mask, size, xs, ys)).astype(h.dtype)


def _edge_tolerance(face) -> float:
    """The largest tolerance (mm) of the face's edges (``BRep_Tool::Tolerance``): how
    far the file, or OCCT's fixing of it, says an edge's curve may lie from the faces
    it bounds (a SolidWorks knob's fluted rim: 0.011 mm off its top plane)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    from ..brep.occt import explore

    return max((BRep_Tool.Tolerance_s(TopoDS.Edge_s(e)) for e in explore(face, TopAbs_EDGE)), default=0.0)


class PlaneAdapter(Adapter):
    kind = "plane"
    label = "a planar face"
    options = frozenset({"height", "pitch", "tolerance", "build_dir", "critical_angle", "rotation", "edge_angle",
                         "offset", "brep", "mode", "mapping", "depth", "mask", "mask_size"})

    def accepts(self, target: Any, where: Any, options: Options) -> bool:
        if options.mode is not Mode.RAISED or options.gradient is not None or not is_cad_target(target) or where is None:
            return False
        return len(face_list(where)) == 1 and not hasattr(target, "stages")

    # -- place --------------------------------------------------------------------------
    def place(self, target: Any, where: Any, texture: Any, options: Options) -> Placement:
        from OCP.BRepAdaptor import BRepAdaptor_Surface
        from OCP.GeomAbs import GeomAbs_Plane

        cp = cad_part(target, where)
        face = cp.faces[0]
        if BRepAdaptor_Surface(face).GetType() != GeomAbs_Plane:
            raise Decline("not a planar face")
        options.report(0.02, "reading the face outline")
        p0, ex, ey, n = plane_frame(face, options.rotation)
        axes = np.stack([ex, ey, n])
        segs3 = face_segments(face, 0.5 * (min(texture.pitch) if isinstance(texture, Heightmap) else options.pitch))
        segs = _local(segs3.reshape(-1, 3), p0, axes).reshape(-1, 2, 3)
        off_plane, edge_tol = float(np.abs(segs[..., 2]).max()), _edge_tolerance(face)
        if off_plane > max(1e-4, 1.01 * edge_tol):  # within what the file says its edges are good to
            raise GeometryError(f"the face's edges leave its plane by {off_plane:.3g} mm, more than their own tolerance "
                                f"({edge_tol:.3g} mm); is the face really planar?")
        segs = segs[..., :2]
        lo, hi = segs.reshape(-1, 2).min(axis=0), segs.reshape(-1, 2).max(axis=0)
        centre = (lo + hi) / 2
        origin = p0 + centre[0] * ex + centre[1] * ey
        pm = tessellation(cp.topo)
        base = pm.mesh
        base_local = Mesh(_local(base.vertices, origin, axes), base.faces)
        z = base_local.vertices[:, 2]
        snap = max(1e-5, 4 * float(np.finfo(np.float32).eps) * float(np.abs(base.vertices).max()))
        z[np.abs(z) < snap] = 0.0  # the face's own vertices: exactly on the plane z = 0
        frame = PlaneFrame(face, origin, axes, segs - centre, lo - centre, hi - centre, base_local)
        return Placement("plane", base, body_count(cp.topo), selected_surface(pm, cp.face_ids), cp.topo, cp.face_ids, None, frame)

    # -- relief -------------------------------------------------------------------------
    def _grid(self, fr: PlaneFrame, texture: Any, options: Options):
        """The texture fitted to the face and laid on the pixel grid over the outline."""
        from ..sources import load_texture

        size = fr.hi - fr.lo
        options.report(0.05, f"loading texture for the {size[0]:.1f} x {size[1]:.1f} mm face")
        hm = load_texture(texture, size=(float(size[0]), float(size[1])), pitch=options.pitch, height=options.height)
        _require_relief(hm, texture)
        px, py = hm.pitch
        rows, cols = hm.shape
        # Pixel (r, c) of the texture sits at x0 + (c + 1/2) px: centred, then offset.
        x0 = -cols * px / 2 + float(options.offset[0])
        y0 = -rows * py / 2 + float(options.offset[1])
        kx = np.arange(int(np.floor((fr.lo[0] - x0) / px - 0.5)) - 2, int(np.ceil((fr.hi[0] - x0) / px - 0.5)) + 3)
        ky = np.arange(int(np.floor((fr.lo[1] - y0) / py - 0.5)) - 2, int(np.ceil((fr.hi[1] - y0) / py - 0.5)) + 3)
        need = texture_bytes(len(kx) * len(ky), options.tolerance)
        require_memory(need, f"a {len(ky)} x {len(kx)} px texture on the face", f"use pitch >= {fitting_pitch(min(px, py), need):.3g} mm")
        xs, ys = x0 + (kx + 0.5) * px, y0 + (ky + 0.5) * py
        return _masked(_place_heightmap(hm, kx, ky), fr, xs, ys, options), xs, ys, (px, py)

    def _ramp(self, fr: PlaneFrame, h: np.ndarray, xs: np.ndarray, ys: np.ndarray, edge_angle: float):
        """M-I ramps at the outline and at body material over the face: ``(h, dist,
        obstructed)``."""
        from scipy.ndimage import distance_transform_edt

        px, py = xs[1] - xs[0], ys[1] - ys[0]
        mask = inside(fr.segments, xs, ys)
        all_segs = [fr.segments]
        obst = _obstruction_segments(fr.base_local, np.array([xs[0], ys[0]]), np.array([xs[-1], ys[-1]]), float(h.max()) + 1e-3)
        if obst is not None:
            mask &= ~inside(obst, xs, ys)
            all_segs.append(obst)
        pts = sample_segments(np.concatenate(all_segs), 0.5 * min(px, py))
        ci = np.clip(np.rint((pts[:, 0] - xs[0]) / px).astype(np.int64), 0, len(xs) - 1)
        ri = np.clip(np.rint((pts[:, 1] - ys[0]) / py).astype(np.int64), 0, len(ys) - 1)
        mask[ri, ci] = False
        dist = distance_transform_edt(mask, sampling=(py, px))
        # Zero band: every vertex of a cell the outline crosses lies within 1.75 diagonals
        # of a marked boundary pixel (cell diagonal + half a sample step + half a diagonal).
        margin = 3.0 * float(np.hypot(px, py))
        ramp = np.where(dist > margin, np.inf, 0.0) if edge_angle >= 90.0 else np.tan(np.radians(edge_angle)) * np.maximum(dist - margin, 0.0)
        h = np.where(mask, np.minimum(h, ramp), 0.0)
        # FLOOR (1 um) under the texture inside the ramp: no contact of relief and face
        # along lines and points; max() keeps the M-I ramp and the limiter's bounds.
        h = np.where(mask, np.maximum(h, np.minimum(FLOOR, ramp)), 0.0).astype(np.float32)
        return h, dist, obst is not None, margin

    def relief(self, placement: Placement, texture: Any, options: Options) -> Relief:
        fr: PlaneFrame = placement.data
        tiled = self._tiled(placement, texture, options)
        if tiled is not None:
            return tiled
        h, xs, ys, (px, py) = self._grid(fr, texture, options)
        options.report(0.1, f"clipping the {len(ys)} x {len(xs)} texture to the face outline")
        h, dist, obstructed, margin = self._ramp(fr, h, xs, ys, options.edge_angle)
        nominal = heightfield_volume(h, (px, py))[0]
        limits, dirs = None, options.directions
        if dirs is not None:
            from ..printability import limit_overhangs

            options.report(0.2, f"limiting overhangs to {options.critical_angle:g} deg")
            lowered, limits = limit_overhangs(Heightmap(h, (px, py)), dirs @ fr.axes.T, options.critical_angle)
            h = lowered.heights
        if not (h > 0).any():
            raise GeometryError(
                f"no texture is left on the face: it is too small or narrow for a {margin:.2f} mm border band "
                "at this pitch (or the overhang limiter removed it all); use a smaller pitch or a larger face"
            )
        _check_flat_outline(h, xs, ys, sample_segments(fr.segments, 0.5 * min(px, py)))
        options.report(0.3, "meshing the relief")
        # The relief above the face: vertices near and outside the outline go to -1 mm,
        # so that trimming at z = 0 leaves only what lies inside the outline, on the face.
        h_mesh = np.where(dist > 1.75 * float(np.hypot(px, py)), h, np.float32(-1.0))
        slab_origin = (xs[0] - px / 2, ys[0] - py / 2, 0.0)
        tolerance = options.tolerance
        if dirs is not None and tolerance > 0:
            from ..printability import printable_lean_slab

            # lean facets keep the limiter's angle too (else a finer tolerance, down to 0)
            slab, tolerance = printable_lean_slab(Heightmap(h_mesh, (px, py)), dirs @ fr.axes.T, options.critical_angle,
                                                  tolerance=tolerance, depth=1.0, origin=slab_origin)
        else:
            slab = heightfield_slab(Heightmap(h_mesh, (px, py)), depth=1.0, origin=slab_origin, tolerance=tolerance)
        offsets = _cell_offsets(h, slab, slab_origin, (px, py)) if tolerance > 0 else None
        if offsets is not None and _lean_crosses(h, offsets, (px, py), tolerance) > CROSSING:
            # steep relief a few pixels across: the pixel grid (see _lean_crosses)
            slab, tolerance, offsets = heightfield_slab(Heightmap(h_mesh, (px, py)), depth=1.0, origin=slab_origin), 0.0, None
        vol, slack = heightfield_volume(h_mesh, (px, py))
        data = PlaneRelief(h, h_mesh, xs, ys, slab, slab_origin, float(tolerance), obstructed, (vol, slack),
                           offsets if options.brep else None)
        return Relief(
            heightmap=Heightmap(h, (px, py)), limits=limits, volume=vol,
            volume_slack=slack + float(tolerance) * px * py * h_mesh.size + 1e-3 * abs(vol),
            nominal_volume=nominal, reach=float(h.max()) + 1e-3, data=data,
        )

    def _tiled(self, placement: Placement, texture: Any, options: Options) -> "Relief | None":
        """The relief in tiles (:mod:`texcad.targets.tiled_faces`) where the untiled one
        would not fit in the memory available, else None. A face with part material
        over it is not tiled: refused, naming a pitch that fits."""
        from ..util import available_memory
        from .tiled import builtin_grid, plate_source
        from .budget import TILED_PIXELS, tiles_fit
        from .tiled_faces import face_tiles, material_over

        fr: PlaneFrame = placement.data
        size = tuple(float(t) for t in fr.hi - fr.lo)
        pitch = float(min(texture.pitch)) if isinstance(texture, Heightmap) else float(options.pitch)
        shape = texture.shape if isinstance(texture, Heightmap) else builtin_grid(texture, size, pitch)
        if shape is None:  # an image: its pixels at this pitch
            shape = (int(size[1] / pitch), int(size[0] / pitch))
        need = texture_bytes((shape[0] + 5) * (shape[1] + 5), options.tolerance)
        if need <= available_memory():
            return None
        what = f"a {shape[0] + 5} x {shape[1] + 5} px texture on the face"
        base = placement.base
        row = lambda f: np.ascontiguousarray(f, np.int64).view([("", np.int64)] * 3).ravel()  # noqa: E731 - a triangle as one value
        face_tris = np.isin(row(base.faces), row(placement.selected[1]))  # the textured face's triangles in the part's mesh
        why = None
        if not tiles_fit(float(shape[0] + 5) * (shape[1] + 5), texture):
            why = f"a texture of more than {TILED_PIXELS:.0e} px (or whose heights file would not fit in the temporary folder)"
        elif material_over(fr.base_local, face_tris, max(float(options.height), float(getattr(texture, "max_height", 0.0))) + 1e-3,
                           0.5 * pitch):
            why = "a face with part material over it within the texture's height"
        if why is not None:
            require_memory(need, what, f"{why} is not made in tiles; use pitch >= {fitting_pitch(pitch, need):.3g} mm")
        options.report(0.1, f"{what}: made in tiles")
        source, side = plate_source(texture, size, float(options.pitch), options.height, bound=options.max_memory,
                                    progress=lambda f, m: options.report(0.1 + 0.2 * f, m),
                                    tolerance=float(options.tolerance))
        vol, slack = source.integral()
        if not vol > 0:
            source.close()
            _require_relief(Heightmap(np.zeros((2, 2), np.float32), source.pitch), texture)
        tiles = face_tiles(fr, base, face_tris, source, options, side=side, floor=FLOOR,
                           progress=lambda f, m: options.report(0.3 + 0.1 * f, m))
        limits = None if tiles.limited is None else tiles.limited.limit.report
        return Relief(heightmap=None, limits=limits, volume=vol, volume_slack=slack, nominal_volume=vol,
                      reach=tiles.reach, max_error=None if tiles.tolerance > 0 else 0.0, data=tiles)

    # -- fuse ---------------------------------------------------------------------------
    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        fr: PlaneFrame = placement.data
        if not isinstance(relief.data, PlaneRelief):  # made in tiles
            return self._fuse_tiled(fr, placement, relief, options)
        r: PlaneRelief = relief.data
        options.report(0.4, f"fusing {r.slab.num_triangles} texture triangles onto the part")
        how, stitched = "manifold3d", None
        field = Heightmap(r.h_mesh, relief.heightmap.pitch)
        if not r.obstructed and r.tolerance > 0:
            vol, slack = r.field_volume
            expect = (vol, slack + r.tolerance * field.pitch[0] * field.pitch[1] * field.heights.size)
            try:
                fused_local, stitched = fuse_on_plane(fr.base_local, r.slab.vertices, r.slab.faces[r.slab.groups["texture"]], expect=expect)
                how = "stitched"
            except GeometryError as exc:
                how = f"manifold3d (the stitch failed a check: {exc})"
        if stitched is None:
            fused_local = fuse(fr.base_local, to_manifold(r.slab).trim_by_plane((0.0, 0.0, 1.0), 0.0))
        px = float(r.xs[1] - r.xs[0])
        info = {
            "face": "plane", "origin": fr.origin.tolist(), "xdir": fr.axes[0].tolist(), "ydir": fr.axes[1].tolist(),
            "normal": fr.axes[2].tolist(), "grid": (len(r.ys), len(r.xs)), "obstructed": r.obstructed, "fuse": how,
            "tolerance": r.tolerance, "pitch": px,
            # the lean surface may enclose up to tolerance x area more or less than the B-rep
            "volume_slack": r.tolerance * px * float(r.ys[1] - r.ys[0]) * r.h_mesh.size,
        }
        if options.directions is not None:
            info["build_dir"], info["critical_angle"] = options.directions.tolist(), float(options.critical_angle)
        return Fused(self._world(fused_local, fr), placement.base, info, PlaneFused(fused_local, stitched))

    @staticmethod
    def _fuse_tiled(fr: PlaneFrame, placement: Placement, relief: Relief, options: Options) -> Fused:
        from .tiled_faces import TiledFaceMesh

        g = relief.data.grid
        options.report(0.45, f"{g.count} tile(s) of up to {g.tile} x {g.tile} nodes")
        told = lambda f, m: options.report(0.92 + 0.07 * f, f"checking the result (texcad's gate): {m}")  # noqa: E731
        info = {
            "face": "plane", "origin": fr.origin.tolist(), "xdir": fr.axes[0].tolist(), "ydir": fr.axes[1].tolist(),
            "normal": fr.axes[2].tolist(), "grid": tuple(g.shape), "obstructed": False, "fuse": "tiled",
            "tiles": g.count, "tile": int(g.tile), "tolerance": relief.data.tolerance, "pitch": float(g.pitch[0]),
        }
        if options.directions is not None:
            info["build_dir"], info["critical_angle"] = options.directions.tolist(), float(options.critical_angle)
        return Fused(TiledFaceMesh(relief.data, progress=told), placement.base, info)

    @staticmethod
    def _world(m: Mesh, fr: PlaneFrame) -> Mesh:
        v = np.einsum("ij,jk->ik", m.vertices.astype(np.float64), fr.axes) + fr.origin  # 6 x faster than @ here
        out = Mesh(v.astype(np.float32), m.faces)
        out.__dict__["is_watertight"] = m.__dict__.get("is_watertight", None) or m.is_watertight
        return out

    # -- on demand ----------------------------------------------------------------------
    def texture_mesh(self, stages: Stages) -> Mesh:
        """(base + relief) - base in the face frame (manifold3d resolves the shared
        plane consistently this way round); a stitched relief is that already."""
        fr: PlaneFrame = stages.placement.data
        f: PlaneFused = stages.fused.data
        if f is None:  # made in tiles
            raise GeometryError("a face textured in tiles keeps no separate texture body (it does not fit in memory); "
                                "write the part's STL or 3MF, or use a coarser pitch")
        return self._world(f.stitched or welded_mesh(to_manifold(f.local) - to_manifold(fr.base_local)), fr)

    def max_error(self, stages: Stages) -> float:
        if not isinstance(stages.relief.data, PlaneRelief):  # made in tiles: the lean tiles' measured error
            return stages.fused.mesh.max_error
        r: PlaneRelief = stages.relief.data
        s = r.slab
        return mesh_error(r.h_mesh, stages.relief.heightmap.pitch, r.slab_origin, s.vertices, s.faces[s.groups["texture"]])

    def brep(self, stages: Stages, fine: Any = None) -> Any:
        if not stages.options.brep:
            raise GeometryError("textured with brep=False; texture it again with brep=True for STEP")
        if not isinstance(stages.relief.data, PlaneRelief):  # made in tiles (tileplane's hook)
            raise GeometryError("a face textured in tiles has no B-rep (it does not fit in memory); write STL or 3MF, "
                                "or use a coarser pitch for STEP")
        fr: PlaneFrame = stages.placement.data
        r: PlaneRelief = stages.relief.data
        return textured_plane_solid(stages.placement.topo, fr.face, _brep_heights(r), r.xs, r.ys, origin=fr.origin,
                                    xdir=fr.axes[0], normal=fr.axes[2], fine=fine)

    def fine_frame(self, stages: Stages) -> Any:
        fr: PlaneFrame = stages.placement.data
        r: PlaneRelief = stages.relief.data
        return (fr.origin, fr.axes[0], fr.axes[1], float(r.xs[1] - r.xs[0]))
