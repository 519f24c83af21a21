"""Adapter: a 2.5D surface (a :class:`texcad.Surface`, or a :class:`texcad.Profile`
extruded by ``length`` mm; paper, section 2.2), textured whole (``where=None``).

**Place.** The surface in its own frame (profile in the XZ plane, extrusion along +y
from 0 to ``length`` mm), its base body meshed, the slab's reach into the base
``depth`` (default ``min(0.5, thickness / 2)`` mm) and the wall under the surface.

**Relief.** The texture fitted to the developed surface
(:func:`texcad.mapping.fit_texture`), lowered for ``build_dir``
(:func:`texcad.printability.limit_on_profile`), mapped (:func:`texcad.mapping.map_texture`,
algorithm 1 ``distance`` or 2 ``angle``), then the bodies of the mode
(:mod:`texcad.mapping.modes`: with the share ``c`` of the height ``H`` that goes under
the surface, a point at height ``h`` moves by ``t = g (h - c H)`` along its offset,
``g`` the gradient's gain): a slab to add (raised, centred) and a cutter to subtract
(engraved, centred), each lean within ``tolerance`` mm (:func:`lean_mapped_slab`).

**Fuse.** ``(base - cutter) + slab`` with manifold3d, welded
(:func:`texcad.solid.weld.join_bodies`). There is no B-rep.

**Tiles.** Where the untiled relief would not fit in the memory available (the
machine's, or ``max_memory``), a closed smooth surface whose base is its profile's
solid, raised, engraved or centred, is made in tiles instead
(:func:`texcad.targets.tiled.surface_tiles`): the fitted texture is held whole (4 bytes a pixel), the fused mesh is a
:class:`~texcad.targets.tiled.TiledSurfaceMesh` that the gate checks and the export
streams, tile by tile. Its texture vertices are the untiled ones (every pixel: its
error is 0, within any ``tolerance``; ``depth`` is not used) and its ends slope from
the first and last texture row to the profile (``info["fuse"] == "tiled"``); an
engraved texture's top lies up to the cutter's floor (0.01 mm) higher; a gradient's
gain is taken at the same points. Other surfaces (open or with corners, a tube,
``build_dir``) are refused as before, naming a pitch that fits.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from ..contracts import Fused, Placement, Relief, Stages
from ..errors import GeometryError, ParameterError
from ..mapping import Profile, Surface
from ..options import Options
from ..solid import Mesh, from_manifold, to_manifold
from ..solid.boolean import welded_mesh
from .base import Adapter

__all__ = ["SurfaceAdapter", "lean_mapped_slab", "gradient_gain", "mode_bodies", "ModeBodies", "Lean", "surface_volume"]


@dataclass(frozen=True)
class Lean:
    """How a mapped slab is meshed: ``closed`` profile, ``tolerance`` mm (0: the full
    grid), ``build_dir`` ``(3,)`` or ``(K, 3)`` in the grid's frame or None, and the
    ``critical_angle`` in degrees."""

    closed: bool
    tolerance: float
    build_dir: Any = None
    critical_angle: float = 45.0

    def kwargs(self) -> dict:
        return {"closed": self.closed, "tolerance": self.tolerance, "build_dir": self.build_dir,
                "critical_angle": self.critical_angle}


def lean_mapped_slab(top, bottom, profile, s, *, closed: bool, tolerance: float, build_dir=None, critical_angle: float = 45.0):
    """The slab of a mapped grid (``top`` ``(R, C, 3)`` mm, ``bottom`` ``(2, C, 3)`` or
    ``(R, C, 3)`` mm, columns at arc lengths ``s`` ``(C,)`` mm on ``profile``): lean
    within ``tolerance`` mm (:func:`texcad.mapping.lean_slab_mesh`), or the full
    grid for tolerance 0 and, with ``build_dir`` (``(3,)`` or ``(K, 3)``, the grid's
    frame), made in tiles of which those whose lean facets would overhang (at the
    critical angle + 1 degree, the slicer's rule; more than the grid's where the
    surface itself faces down) are redone tighter or as the grid. Returns
    ``(slab, max_error mm)``."""
    from ..mapping import lean_slab_mesh, slab_mesh

    if tolerance <= 0:
        return slab_mesh(top, bottom, closed=closed), 0.0
    if build_dir is None:
        return lean_slab_mesh(top, bottom, profile, s, closed=closed, tolerance=tolerance)
    from ..printability import build_directions, overhang_area

    dirs = build_directions(build_dir)
    from ..printability.rule import overhang_angle

    limit = min(overhang_angle(critical_angle), 89.9)  # what the slicers support (texcad.printability.rule)

    def facets_ok(v: np.ndarray, f: np.ndarray) -> float:  # overhanging area, mm2
        m = Mesh(np.asarray(v, np.float32), f.astype(np.uint32))
        return max(overhang_area(m, d, limit, plate_tolerance=-1.0) for d in dirs)

    return lean_slab_mesh(top, bottom, profile, s, closed=closed, tolerance=tolerance, facets_ok=facets_ok)


def gradient_gain(points: np.ndarray, gradient: Any) -> np.ndarray:
    """The gradient's gain ``g = clip(1 - t, 0, 1)`` at ``points`` ``(N, 3)`` mm, with
    ``t = (p - a) . (b - a) / |b - a|^2`` the position along the line from the start
    ``a`` (full depth) to the end ``b`` (none); ``gradient`` is ``(a, b)`` in mm."""
    g = np.asarray(gradient, dtype=np.float64).reshape(-1)
    if g.shape != (6,) or not np.all(np.isfinite(g)) or np.allclose(g[:3], g[3:]):
        raise ParameterError(f"gradient is (start, end): two different points (x, y, z) in mm, got {gradient!r}")
    a = g[3:] - g[:3]
    return np.clip(1.0 - (points - g[:3]) @ a / (a @ a), 0.0, 1.0)


def inverted(inner: np.ndarray, outer: np.ndarray, profile: Profile, s: np.ndarray, lean: Lean) -> tuple[Mesh, Mesh, float]:
    """The closed body between a textured sheet ``inner`` ``(R, C, 3)`` mm and the
    sheet ``outer`` ``(2, C, 3)`` outside it (a cutter): :func:`lean_mapped_slab` with
    the sheets swapped, its two sheets turned (they face the wrong way for a body
    whose textured side is its bottom; the end walls are oriented by their geometry).
    Returns ``(cutter, as made (its "texture" faces facing out of the part), max_error mm)``."""
    from ..solid import edge_report

    made, err = lean_mapped_slab(inner, outer, profile, s, **lean.kwargs())
    faces = made.faces.copy()
    sheets = np.concatenate([made.groups["texture"], made.groups["bottom"]])
    faces[sheets] = faces[sheets, ::-1]
    cutter = Mesh(made.vertices, faces, made.groups)
    if not edge_report(faces)["watertight"] or cutter.volume <= 0:
        raise GeometryError("the texture's cutter is not a closed solid (its textured side crosses the surface); "
                            "use a smaller height")
    return cutter, made, err


@dataclass(frozen=True)
class ModeBodies:
    """The bodies that put a texture on a mapped surface (:mod:`texcad.mapping.modes`),
    in the surface's frame, mm.

    Attributes:
        slab: the body to add (raised, centred), or None.
        cutter: the body to subtract (engraved, centred), or None.
        shown: the body whose ``"texture"`` faces are the part's textured surface, outward.
        error: the largest distance of the lean sheets from their grids, mm.
        low: ``(inner (R, C, 3), outer (2, C, 3))``: the envelope's cutter sheets (the
            texture alone is what of the part lies above it), or None.
        sheets: ``(slab top, cut)``: the ``(R, C, 3)`` grids (mm) of the slab's top
            and of the cutter's textured side (None where there is no such body):
            the part's new surface, from which :func:`surface_volume` sums the
            texture's integral.
    """

    slab: "Mesh | None"
    cutter: "Mesh | None"
    shown: Mesh
    error: float
    low: "tuple | None" = None
    sheets: tuple = (None, None)

    @property
    def triangles(self) -> int:
        return sum(b.num_triangles for b in (self.slab, self.cutter) if b is not None)


def _warn_limited(limited: int, total: int) -> None:
    import warnings

    from ..errors import TexcadWarning

    warnings.warn(f"the texture was cut less deep at {limited} of {total} grid points, where the base is not thick "
                  "enough under the surface for it; use a smaller height or a thicker base", TexcadWarning, stacklevel=5)


def mode_bodies(profile: Profile, mapped: Any, share: float, full: float, gain: "np.ndarray | None", lean: Lean,
                wall: float) -> ModeBodies:
    """The :class:`ModeBodies` of a raised mapping ``mapped`` for the mode's share ``c``
    (``share``: 0 raised, 1/2 centred, 1 engraved) of the full height ``full`` mm,
    the gain ``(R, C)`` (or None) and the base's ``wall`` mm under the surface."""
    from ..mapping import CUT_FLOOR, mode_sheets

    s = mapped.s
    if share == 0 and gain is None:
        slab, err = lean_mapped_slab(mapped.top, mapped.bottom, profile, s, **lean.kwargs())
        return ModeBodies(slab, None, slab, err, None, (mapped.top, None))
    # Two lean sheets each within tolerance of their grids: 2 tolerance apart, they cannot cross.
    sheets = mode_sheets(profile, mapped, share=share, height=full, gain=gain, overlap=CUT_FLOOR + 2.0 * lean.tolerance,
                         thickness=wall)
    if sheets["limited"]:
        _warn_limited(sheets["limited"], mapped.top.shape[0] * mapped.top.shape[1])
    slab = cutter = low = None
    err = 0.0
    top = sheets["slab"] if share > 0 else sheets["surface"]
    if share < 1:  # raised with a gradient: the surface itself; centred: its outline under the cut
        slab, err = lean_mapped_slab(top, mapped.bottom, profile, s, **lean.kwargs())
    if share > 0:
        cutter, made, cut_err = inverted(sheets["cut"], sheets["outer"], profile, s, lean)
        low = (sheets["low"], sheets["outer"])
        err = max(err, cut_err)
    return ModeBodies(slab, cutter, made if share == 1 else slab, err, low,
                      (top if share < 1 else None, sheets["cut"] if share > 0 else None))


#: Centred textures: the share of the gross volume ``int |t| dA`` accepted as the
#: error of the net volume (check 4; see :func:`surface_volume`).
CENTRED_SHARE = 0.1


def surface_volume(profile: Profile, mapped: Any, bodies: ModeBodies, nominal: Any, share: float, full: float,
                   tolerance: float, tessellation: float = 0.01) -> tuple[float, float, float]:
    """The texture's own integral on a mapped 2.5D surface, for the gate's check 4:
    ``(volume, slack, nominal)`` mm^3 (raised +, engraved -).

    **Volume.** The part's new surface over every grid point is the highest of what
    the bodies leave there, compared along the profile's outward normal ``n``: the
    cutter's textured side where there is a cutter (it removes everything above it,
    the surface included), else the surface itself; and over that the slab's top
    where there is a slab. That sheet against the profile's points ``P`` at the
    columns (extruded to the rows) is summed exactly by swept prisms
    (:func:`texcad.mapping.surface.grid_swept`): ``int (t + kappa t^2 / 2) ds dy``
    for an offset ``t`` along the normal of a profile of curvature ``kappa`` (a
    raised texture on a convex profile adds more than ``t A``, an engraved one
    removes less than ``|t| A``), less the circular segments ``kappa ds^3 / 12``
    between the profile and the polygon through ``P``, times the length
    (:func:`texcad.mapping.surface.chord_excess`). The cutters' floor
    (:data:`texcad.mapping.CUT_FLOOR`) and the cuts the base's wall thickness made
    shallower are in it (they are in the sheets).

    **Slack.** Each lean side lies within ``tolerance`` mm of its grid (twice with a
    slab and a cutter), the base's mesh within ``tessellation`` mm of the profile
    (:func:`texcad.brep.shape_to_mesh`'s 0.01 mm deflection for a CAD base; a given
    mesh counts as within it): ``(k tolerance + tessellation) A``, plus the segment term and
    ``1e-3 |volume|`` (float32 vertices). Centred: the net volume is the difference
    of a raised and an engraved part, whose sheets (along z with the distance
    mapping) are joined where the texture crosses the surface; their error is a
    share of the gross volume ``int |t| dA``: :data:`CENTRED_SHARE` of it is added
    (measured up to 4.3 % on an arc, distance mapping).

    **Nominal** (raised and engraved; None for centred, whose net volume is about 0
    by design). ``int (t + kappa t^2 / 2) ds dy`` over the surface's area with
    ``t = h - c H`` of the fitted texture ``nominal`` before the overhang limiter
    and the mapping's curvature limits (:func:`texcad.mapping.surface.relief_integral`,
    ``kappa`` the profile's mean curvature over the columns); a gradient's gain is
    applied (by the caller) as its mean over the grid.
    """
    from ..mapping.surface import chord_excess, grid_swept, mean_curvature, relief_integral

    s = np.asarray(mapped.s, np.float64)
    y = np.asarray(mapped.y, np.float64)
    R, C = mapped.top.shape[:2]
    fc = profile.at(s)
    base = np.empty((R, C, 3))
    base[..., 0], base[..., 1], base[..., 2] = fc.point[None, :, 0], y[:, None], fc.point[None, :, 1]
    nrm = np.zeros((R, C, 3))
    nrm[..., 0], nrm[..., 2] = fc.normal[None, :, 0], fc.normal[None, :, 1]

    def up(g: np.ndarray) -> np.ndarray:  # the normal offset of a sheet, (R, C) mm
        return np.einsum("rck,rck->rc", np.asarray(g, np.float64) - base, nrm)

    slab_top, cut = bodies.sheets
    new = base if cut is None else np.where((up(cut) < 0)[..., None], np.asarray(cut, np.float64), base)
    if slab_top is not None:
        new = np.where((up(slab_top) > up(new))[..., None], np.asarray(slab_top, np.float64), new)
    closed = bool(mapped.closed)
    length = float(y[-1] - y[0])
    excess = chord_excess(profile, s, closed=closed) * length
    vol = grid_swept(base, new, nrm, wrap_cols=closed, measure=False).volume - excess
    area = (profile.length if closed else float(s[-1] - s[0])) * length
    sides = sum(b is not None for b in bodies.sheets)
    slack = (sides * float(tolerance) + float(tessellation)) * area + abs(excess) + 1e-3 * abs(vol) + 1e-3
    if share not in (0, 1):  # centred: the net of a raised and an engraved part, each with its own error
        gross = float(np.abs(up(new)).mean()) * area
        return vol, slack + CENTRED_SHARE * gross, None
    kappa = mean_curvature(profile, s, closed=closed)
    return vol, slack, relief_integral(np.asarray(nominal.heights, np.float64) - share * full, area, kappa)


@dataclass(frozen=True)
class SurfacePlace:
    """A 2.5D surface placed: the :class:`~texcad.mapping.Surface` (its base given or
    replaced), the slab's reach ``depth`` into the base (mm) and the base's ``wall``
    under the surface (mm; inf when not known)."""

    surface: Surface
    depth: float
    wall: float
    deferred: "float | None" = None  # the selected surface not made yet (too large?): its spacing, mm


@dataclass(frozen=True)
class SurfaceRelief:
    """The relief of a surface: its :class:`ModeBodies`, how they were meshed, and
    the columns' arc lengths ``s`` (C,) mm on the profile."""

    bodies: ModeBodies
    lean: Lean
    s: np.ndarray


@dataclass(frozen=True)
class SurfaceTiles:
    """The relief of a surface made in tiles: the
    :class:`~texcad.targets.tiled.TiledSurfaceMesh` (the fused part, kept as its
    tiles) and what the gate expects of it, ``expect``
    (:func:`texcad.targets.tiled.surface_tiles`)."""

    mesh: Any
    expect: Any


@dataclass(frozen=True)
class SurfaceFused:
    """The fused manifold3d ``Manifold`` (before welding): the texture alone of a
    cut texture is measured against it."""

    manifold: Any


def as_surface(target: Any, length: "float | None", base: Any, thickness: "float | None") -> Surface:
    """``target`` as a :class:`~texcad.mapping.Surface`: a Surface (its ``base`` and
    ``thickness`` replaced when given), or a profile (Profile, build123d curve or
    sketch) extruded by ``length`` mm."""
    if isinstance(target, Surface):
        if base is None:
            return target
        return Surface(target.profile, target.length, base, thickness if thickness is not None else target.thickness,
                       target.params)
    if length is None:
        raise ParameterError("give the extrusion length in mm (length=...) when texturing a profile")
    return Surface.from_profile(target, length, base=base, thickness=thickness)


def _selected(surf: Surface, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The surface as triangles about ``spacing`` mm wide and long (the gate's reach
    check samples them): the profile sampled every ``spacing`` mm, at rows ``y`` from
    0 to ``length`` mm: ``(vertices (R C, 3), faces (2 (R - 1)(C - 1), 3))``."""
    from ..solid import grid_faces

    _, p = surf.profile.sample(spacing)
    if surf.profile.closed:
        p = np.concatenate([p, p[:1]])
    ys = np.linspace(0.0, float(surf.length), max(2, int(np.ceil(surf.length / spacing)) + 1))
    v = np.stack([np.broadcast_to(p[None, :, 0], (len(ys), len(p))), np.broadcast_to(ys[:, None], (len(ys), len(p))),
                  np.broadcast_to(p[None, :, 1], (len(ys), len(p)))], axis=-1).reshape(-1, 3)
    return v, np.asarray(grid_faces(len(ys), len(p)), dtype=np.int64)


def _may_not_fit(surf: Surface, options: Options) -> bool:
    """Whether the untiled relief might not fit in the memory available: the
    texture's pixels estimated at ``options.pitch`` before it is fitted (then
    :func:`_selected`, one vertex a pixel too, waits until the relief is made)."""
    from ..util import available_memory, texture_bytes

    p = float(options.pitch)
    return texture_bytes((float(surf.profile.length) / p + 1) * (float(surf.length) / p + 1), 0.0) > 0.5 * available_memory()


def _build_dir(options: Options) -> Any:
    """``build_dir`` as the stage functions take it: ``(3,)`` for one direction,
    ``(K, 3)`` for several (unit vectors), or None."""
    d = options.directions
    return None if d is None else (d[0] if len(d) == 1 else d)


def united_bodies(base: Mesh) -> int:
    """How many bodies the base makes when bodies that overlap or touch count as one
    (:func:`texcad.solid.overlap.overlapping_bodies`; groups by union-find): the base
    of a profile with pieces facing each other is one body per piece, the pieces touch,
    and the texture joins them into one."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    from ..solid.overlap import overlapping_bodies, split_bodies

    v, f = np.asarray(base.vertices, np.float64), np.asarray(base.faces, np.int64)
    split = split_bodies(v, f)
    n = len(split.volumes)
    pairs = np.array([(o.a, o.b) for o in overlapping_bodies(v, f, split=split)], np.int64).reshape(-1, 2)
    if n < 2 or not len(pairs):
        return n
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return int(connected_components(graph, directed=False)[0])


class SurfaceAdapter(Adapter):
    """A :class:`~texcad.mapping.Surface` or :class:`~texcad.mapping.Profile` (with
    ``length`` mm), textured whole. The gate runs checks 1-3 (closed, oriented, one
    body per base body), 4 (the texture's integral, :func:`surface_volume`) and 5
    (reach, raised reliefs)."""

    kind = "surface"
    label = "a Surface"
    result_kind = "surface"
    options = frozenset({"height", "pitch", "mapping", "depth", "periodic_x", "transition", "build_dir", "critical_angle",
                         "length", "base", "thickness", "tolerance", "mode", "gradient"})

    def accepts(self, target: Any, where: Any, options: Options) -> bool:
        return isinstance(target, (Surface, Profile))

    # -- place --------------------------------------------------------------------------
    def place(self, target: Any, where: Any, texture: Any, options: Options) -> Placement:
        from ..brep import shape_to_mesh

        if where is not None:
            raise ParameterError("a Surface is textured whole: pass where=None")
        options.report(0.0, "building the surface")
        surf = as_surface(target, options.length, options.base, options.thickness)
        depth = options.depth if "depth" in options.given else (min(0.5, surf.thickness / 2) if surf.thickness else 0.5)
        wall = float(surf.thickness) if surf.thickness else float("inf")
        options.report(0.02, "meshing the base body")
        base = surf.base if isinstance(surf.base, Mesh) else shape_to_mesh(surf.base)
        large = _may_not_fit(surf, options)  # then the surface for check 5 is made only if the relief is not tiled
        selected = None if large else _selected(surf, options.pitch)
        return Placement("surface", base, united_bodies(base), selected,
                         data=SurfacePlace(surf, float(depth), wall, float(options.pitch) if large else None))

    # -- relief -------------------------------------------------------------------------
    def _fitted(self, surf: Surface, texture: Any, options: Options):
        """The texture fitted to the developed surface: ``(Heightmap, periodic)``."""
        from ..mapping import fit_texture

        options.report(0.05, "loading texture")
        return fit_texture(surf.profile, texture, length=surf.length, pitch=options.pitch, height=options.height,
                           periodic_x=options.periodic_x)

    def _tiled(self, placement: Placement, hm: Any, periodic: bool, options: Options) -> "Relief | None":
        """The relief in tiles where the untiled one would not fit in the memory
        available, else None; ResourceError naming a pitch where it does not fit and
        tiles are not made for this surface (see the module's docstring)."""
        from ..util import available_memory, fitting_pitch, require_memory, texture_bytes
        from .tiled import NotTiled, surface_tiles

        need = texture_bytes(hm.shape[0] * hm.shape[1], 0.0)
        if need <= available_memory():
            return None
        sp: SurfacePlace = placement.data
        what = f"a {hm.shape[0]} x {hm.shape[1]} px texture on the surface"
        fix = f"use pitch >= {fitting_pitch(min(hm.pitch), need):.3g} mm"
        why = "build_dir (the overhang limiter)" if options.directions is not None else None
        gain = None if options.gradient is None else partial(gradient_gain, gradient=options.gradient)
        if why is None:
            options.report(0.1, f"{what}: made in tiles")
            try:
                mesh, ex = surface_tiles(sp.surface, hm, periodic, mapping=options.mapping.value, transition=options.transition,
                                         max_memory=options.max_memory, base=placement.base, share=options.mode.share,
                                         gain=gain)
            except NotTiled as exc:
                why = exc.reason
        if why is not None:
            require_memory(need, what, f"{why} is not made in tiles; {fix}")
            return None  # it fits after all (the memory available changed since)
        return Relief(heightmap=hm, limits=None, volume=ex.volume, volume_slack=ex.volume_slack,
                      nominal_volume=ex.nominal_volume, reach=ex.height, max_error=0.0, data=SurfaceTiles(mesh, ex))

    def relief(self, placement: Placement, texture: Any, options: Options) -> Relief:
        from ..mapping import CUT_FLOOR, map_texture
        from ..util import subrange

        sp: SurfacePlace = placement.data
        surf, share, mapping, bd = sp.surface, options.mode.share, options.mapping.value, _build_dir(options)
        hm, periodic = self._fitted(surf, texture, options)
        tiled = self._tiled(placement, hm, periodic, options)
        if tiled is not None:
            return tiled
        full = float(hm.heights.max())  # the envelope H of engraved and centred textures, mm
        hm_nominal, overhang = hm, None
        if bd is not None:
            from ..printability import limit_on_profile

            options.report(0.08, f"limiting overhangs to {options.critical_angle:g} deg")
            hm, overhang = limit_on_profile(surf.profile, hm, bd, options.critical_angle, mapping=mapping, periodic=periodic)
        extra = share * full + 0.1 + 2.0 * options.tolerance if share else 0.0  # a centred slab's bottom lies under the cut
        mapped = map_texture(surf.profile, hm, mapping=mapping, length=surf.length, depth=sp.depth + extra, periodic_x=periodic,
                             transition=options.transition, progress=subrange(options.progress, 0.1, 0.3))
        options.report(0.3, f"closing the {mapped.top.shape[0]} x {mapped.top.shape[1]} texture slab")
        lean = Lean(mapped.closed, options.tolerance, bd, options.critical_angle)
        gain = None if options.gradient is None else gradient_gain(
            mapped.top.reshape(-1, 3).astype(np.float64), options.gradient).reshape(mapped.top.shape[:2])
        bodies = mode_bodies(surf.profile, mapped, share, full, gain, lean, sp.wall)
        if overhang is not None:
            from ..printability import measured

            overhang = measured(overhang, bodies.shown, bd, options.critical_angle)
        vol, slack, nominal = surface_volume(surf.profile, mapped, bodies, hm_nominal, share, full, options.tolerance)
        if gain is not None and nominal is not None:
            nominal *= float(gain.mean())
        return Relief(heightmap=mapped.heightmap, limits=overhang, volume=vol, volume_slack=slack, nominal_volume=nominal,
                      reach=full + CUT_FLOOR + 2.0 * options.tolerance + 0.1, max_error=bodies.error,
                      height_limits=tuple(mapped.limits), mapped=mapped, data=SurfaceRelief(bodies, lean, mapped.s))

    def expectation(self, placement: Placement, relief: Relief, fused: Fused) -> Any:
        """Checks 1-3 and, for a raised relief, 5 (reach). An engraving body (engraved,
        centred) reaches past the surface's edges at the ends of the profile so that
        the cut is clean; the points it leaves there lie farther from the surface than
        the depth, so check 5 is left out for it."""
        import dataclasses

        ex = super().expectation(placement, relief, fused)
        if isinstance(relief.data, SurfaceTiles):  # the tiles' own (check 5 against each column's profile point)
            return dataclasses.replace(relief.data.expect, bodies=placement.bodies)
        sp: SurfacePlace = placement.data
        if relief.data.bodies.cutter is not None:
            return dataclasses.replace(ex, selected=None)
        if ex.selected is None and sp.deferred is not None:  # not made in place(): it might not have fitted
            ex = dataclasses.replace(ex, selected=_selected(sp.surface, sp.deferred))
        return ex

    # -- fuse ---------------------------------------------------------------------------
    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        from ..solid.weld import join_bodies

        if isinstance(relief.data, SurfaceTiles):
            t = relief.data.mesh
            options.report(0.45, f"{t.grid.count} tile(s) of up to {t.grid.tile} x {t.grid.tile} nodes")
            t.progress = lambda f, m: options.report(0.92 + 0.07 * f, f"checking the result (texcad's gate): {m}")
            info = {"face": "surface", "mapping": options.mapping.value, "grid": tuple(relief.heightmap.shape), "closed": True,
                    "tolerance": 0.0, "mode": options.mode.value, "fuse": "tiled", "tiles": t.grid.count,  # every pixel kept
                    "tile": int(t.grid.tile), "no_brep": "a 2.5D surface is textured as a mesh"}
            return Fused(t, placement.base, info)
        b: ModeBodies = relief.data.bodies
        mapped = relief.mapped
        options.report(0.5, f"fusing {b.triangles} texture triangles onto the base (manifold3d)")
        fused, man = join_bodies(placement.base, b.slab, b.cutter)
        options.report(0.9, "fused")
        info = {"face": "surface", "mapping": options.mapping.value, "grid": tuple(mapped.top.shape[:2]),
                "closed": mapped.closed, "tolerance": options.tolerance, "mode": options.mode.value,
                "no_brep": "a 2.5D surface is textured as a mesh"}
        return Fused(fused, placement.base, info, SurfaceFused(man))

    # -- on demand ----------------------------------------------------------------------
    def texture_mesh(self, stages: Stages) -> Mesh:
        """The slab (raised), or what of the part lies above the envelope's cutter
        (engraved, centred: ``fused - (base - low)``), mm."""
        import dataclasses

        r: SurfaceRelief = stages.relief.data
        if isinstance(r, SurfaceTiles):
            raise GeometryError("a surface made in tiles keeps no separate texture body (it does not fit in memory); "
                                "write the part's STL or 3MF, or use a coarser pitch")
        b = r.bodies
        if b.cutter is None:
            return b.slab
        inner, outer = b.low
        exact = dataclasses.replace(r.lean, tolerance=0.0, build_dir=None)
        low = inverted(inner, outer, stages.placement.data.surface.profile, r.s, exact)[0]
        base = to_manifold(stages.placement.base)
        return welded_mesh(stages.fused.data.manifold - (base - to_manifold(low)))

    def brep(self, stages: Stages, fine: Any = None) -> Any:
        raise GeometryError("this surface result has no B-rep (a 2.5D surface is textured as a mesh); write STL or 3MF instead")
