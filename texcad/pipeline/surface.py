"""A 2.5D surface (a profile extruded, paper section 2.2) textured and fused onto its
base body: stages fit -> map -> slab -> union."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ..errors import ParameterError
from ..mapping import Surface, fit_texture, lean_slab_mesh, map_texture
from ..solid import DEFAULT_TOLERANCE, Mesh, check_tolerance, from_manifold, to_manifold
from ..brep import shape_to_mesh
from ..sources import Heightmap
from ..util import Progress, fitting_pitch, report, require_memory, subrange, texture_bytes
from .result import Textured

__all__ = ["textured_surface", "lean_mapped_slab"]


def lean_mapped_slab(top, bottom, profile, s, *, closed: bool, tolerance: float, build_dir=None, critical_angle: float = 45.0):
    """The slab of a mapped grid (``top`` ``(R, C, 3)`` mm, ``bottom`` ``(2, C, 3)`` or
    ``(R, C, 3)`` mm, columns at arc lengths ``s`` ``(C,)`` mm on ``profile``): lean
    within ``tolerance`` mm (:func:`texcad.mapping.lean_slab_mesh`), or the full
    grid for tolerance 0 and, with ``build_dir`` (``(3,)`` or ``(K, 3)``, the grid's
    frame), made in tiles of which those whose lean facets would overhang (at the
    critical angle + 1 degree, the slicer's rule; more than the grid's where the
    surface itself faces down) are redone tighter or as the grid
    (the limiter bounds the pixel facets; a thin lean triangle at a sharp feature
    can be steeper). Returns ``(slab, max_error mm)``."""
    from ..mapping import slab_mesh

    if tolerance <= 0:
        return slab_mesh(top, bottom, closed=closed), 0.0
    if build_dir is None:
        return lean_slab_mesh(top, bottom, profile, s, closed=closed, tolerance=tolerance)
    from ..printability import build_directions, overhang_area

    dirs = build_directions(build_dir)
    # The slicer's rule: support below its threshold + 1 degree (SLICER_MARGIN).
    limit = min(float(critical_angle) + 1.0, 89.9)

    def facets_ok(v: np.ndarray, f: np.ndarray) -> float:  # overhanging area, mm2
        m = Mesh(np.asarray(v, np.float32), f.astype(np.uint32))
        return max(overhang_area(m, d, limit, plate_tolerance=-1.0) for d in dirs)

    return lean_slab_mesh(top, bottom, profile, s, closed=closed, tolerance=tolerance, facets_ok=facets_ok)


def textured_surface(
    surface: Any,
    texture: "str | os.PathLike | Heightmap",
    *,
    length: float | None = None,
    height: float = 2.0,
    mapping: str = "distance",
    pitch: float = 0.125,
    depth: float | None = None,
    base: Any = None,
    thickness: float | None = None,
    periodic_x: bool | None = None,
    transition: float | None = None,
    build_dir: Any = None,
    critical_angle: float = 45.0,
    tolerance: float = DEFAULT_TOLERANCE,
    mode: str = "raised",
    gradient: Any = None,
    progress: Progress = None,
):
    """Texture a 2.5D surface and fuse it onto its base body: a watertight solid.

    Stages: fit the texture to the surface (:func:`fit_texture`) -> map it
    (:func:`map_texture`, algorithm 1 or 2) -> close the slab
    (:func:`texcad.solid.grid_solid`) -> mesh the base -> union with manifold3d
    (:func:`texcad.fuse`).

    Args:
        surface: a :class:`~texcad.mapping.Surface` (e.g. ``Surface.cylinder(20, 100)``),
            a :class:`~texcad.mapping.Profile`, or a build123d curve or sketch (then
            ``length`` is required).
        texture: ``"builtin:NAME"``, an image path, or a Heightmap (used as is).
        length: extrusion length in mm (profiles only).
        height: maximum texture height in mm (built-ins and images).
        mapping: ``"distance"`` (algorithm 1, texture along z, support-free flanks) or
            ``"angle"`` (algorithm 2, texture along the normal).
        pitch: mm per pixel for built-ins (images: their own pixels over the surface).
        depth: how far the slab reaches into the base in mm (default: half the base's
            wall thickness, at most 0.5 mm).
        base: a build123d / CadQuery solid, Mesh or Manifold replacing the surface's base.
        thickness: base thickness in mm for profiles without a base (default 5 mm).
        periodic_x: closed profiles: the (image or Heightmap) texture tiles in x.
        transition: fade length in mm (see :func:`map_texture`).
        build_dir: make the texture print without support for this build direction
            ``(3,)``, or every direction of a ``(K, 3)`` set, given in the surface's
            frame (x across the profile, y along the extrusion, z up: the frame of
            the returned mesh; e.g. ``texcad.orientation(60, "+x")``). The surface's
            tilt under every texture column comes from the profile's tangent
            (``Profile.at(s)``) and adds to the texture's slope (paper, section
            3.1); :func:`texcad.printability.limit_overhangs_mapped` lowers the
            texture as little as needed (offset ``"normal"`` for ``mapping="angle"``,
            ``"vertical"`` for ``"distance"``) and ramps the borders whose walls
            would overhang (M-I, section 2.1.3) down to 0.02 mm inside the base.
            None: the texture is used as is.
        critical_angle: critical overhang angle in degrees (default 45; paper,
            section 2.1.3), used with ``build_dir``.
        tolerance: largest distance in mm from the mesh to the mapped texture at
            any pixel centre (default 0.02 mm): a lean mesh
            (:func:`texcad.mapping.lean_slab_mesh`: greedy insertion with the
            curvature of the surface in the bound, measured in 3-D and reported as
            ``.max_error``); 0 keeps one vertex per pixel. With ``build_dir`` the
            full grid is used where a lean facet would overhang.
        mode: ``"raised"`` (the texture stands on the surface), ``"engraved"`` (cut
            into the base: nothing lies above the surface, the outer envelope is
            kept) or ``"centred"`` (half above, half below); see
            :mod:`texcad.mapping.modes`.
        gradient: ``(start, end)`` points in mm, ``(x0, y0, z0, x1, y1, z1)``: the full
            depth at ``start``, fading linearly to none at ``end`` (projected on the
            line between them); None: the full depth everywhere.
        progress: optional ``progress(fraction, message)`` callback.

    Returns:
        :class:`texcad.Textured` (fused mesh, texture slab, base mesh, heightmap as
        mapped) that also holds the :class:`texcad.mapping.MappedSurface`
        (``.mapped``: grids, height ``limits``, ``x_scale``);
        ``.height_limits`` lists where the height was limited; ``.limits`` is the
        overhang limiter's :class:`~texcad.printability.LimitReport` (None without
        ``build_dir``), its ``remaining_overhang_mm2`` measured on the mapped slab.

    Raises:
        ParameterError: ``build_dir`` with ``mapping="distance"`` on a profile that
            looks both up and down (use ``mapping="angle"``).
    """
    tolerance = check_tolerance(tolerance)
    share = _share(mode)
    report(progress, 0.0, "building the surface")
    surf = _surface(surface, length, base, thickness)
    if depth is None:
        depth = min(0.5, surf.thickness / 2) if surf.thickness else 0.5
    report(progress, 0.05, "loading texture")
    hm, periodic = fit_texture(surf.profile, texture, length=surf.length, pitch=pitch, height=height, periodic_x=periodic_x)
    need = texture_bytes(hm.shape[0] * hm.shape[1], 0.0)
    fix = f"use pitch >= {fitting_pitch(min(hm.pitch), need):.3g} mm"
    require_memory(need, f"a {hm.shape[0]} x {hm.shape[1]} px texture on the surface", fix)
    full = float(hm.heights.max())  # the envelope H of engraved and centred textures, mm
    overhang = None
    if build_dir is not None:
        from ..printability import limit_on_profile

        report(progress, 0.08, f"limiting overhangs to {critical_angle:g} deg")
        hm, overhang = limit_on_profile(surf.profile, hm, build_dir, critical_angle, mapping=mapping, periodic=periodic)
    mapped = map_texture(
        surf.profile,
        hm,
        mapping=mapping,
        length=surf.length,
        depth=depth + (share * full + 0.1 + 2.0 * tolerance if share else 0.0),  # a centred slab's bottom lies under the cut
        periodic_x=periodic,
        transition=transition,
        progress=subrange(progress, 0.1, 0.3),
    )
    report(progress, 0.3, f"closing the {mapped.top.shape[0]} x {mapped.top.shape[1]} texture slab")
    lean = dict(closed=mapped.closed, tolerance=tolerance, build_dir=build_dir, critical_angle=critical_angle)
    wall = float(surf.thickness) if surf.thickness else float("inf")
    bodies = _bodies(surf.profile, mapped, share, full, gradient, lean, wall)
    if overhang is not None:
        from ..printability import measured

        overhang = measured(overhang, bodies["shown"], build_dir, critical_angle)
    report(progress, 0.4, "meshing the base body")
    base_mesh = surf.base if isinstance(surf.base, Mesh) else shape_to_mesh(surf.base)
    report(progress, 0.5, f"fusing {bodies['triangles']} texture triangles onto the base (manifold3d)")
    fused, texture_mesh = _apply(base_mesh, bodies)
    report(progress, 1.0, "fused")
    from ..targets.legacy import legacy_stages

    return Textured(legacy_stages(
        mesh=fused, texture_mesh=texture_mesh, base_mesh=base_mesh, heightmap=mapped.heightmap, limits=overhang,
        height_limits=list(mapped.limits), mapped=mapped, max_error=bodies["error"],
        info={"face": "surface", "mapping": mapping, "grid": tuple(mapped.top.shape[:2]), "closed": mapped.closed,
              "tolerance": tolerance, "mode": mode, "no_brep": "a 2.5D surface is textured as a mesh"},
        kind="surface", result_kind="surface",
    ))


def _share(mode: str) -> float:
    """The mode's share ``c`` of the height that goes under the surface."""
    from ..targets.mesh import MODES

    if mode not in MODES:
        raise ParameterError(f"mode {mode!r}: use 'raised', 'engraved' (cut in, the envelope kept) or 'centred'")
    return MODES[mode]


def _surface(surface: Any, length: float | None, base: Any, thickness: float | None) -> Surface:
    if isinstance(surface, Surface):
        if base is None:
            return surface
        return Surface(surface.profile, surface.length, base, thickness if thickness is not None else surface.thickness,
                       surface.params)
    if length is None:
        raise ParameterError("give the extrusion length in mm (length=...) when texturing a profile")
    return Surface.from_profile(surface, length, base=base, thickness=thickness)


def _inverted(inner: np.ndarray, outer: np.ndarray, profile, s, lean: dict) -> tuple[Mesh, Mesh, float]:
    """The closed body between a textured sheet ``inner`` ``(R, C, 3)`` and the sheet
    ``outer`` ``(2, C, 3)`` outside it (a cutter): :func:`lean_mapped_slab` with the
    sheets swapped. Its two sheets are oriented by their grids, facing the wrong way
    for a body whose textured side is its bottom, and are turned; its end walls are
    oriented by their geometry and stay. Returns ``(cutter, as made (its "texture"
    faces facing out of the part), max_error mm)``."""
    from ..errors import GeometryError
    from ..solid import edge_report

    made, err = lean_mapped_slab(inner, outer, profile, s, **lean)
    faces = made.faces.copy()
    sheets = np.concatenate([made.groups["texture"], made.groups["bottom"]])
    faces[sheets] = faces[sheets, ::-1]
    cutter = Mesh(made.vertices, faces, made.groups)
    if not edge_report(faces)["watertight"] or cutter.volume <= 0:
        raise GeometryError("the texture's cutter is not a closed solid (its textured side crosses the surface); "
                            "use a smaller height")
    return cutter, made, err


def _bodies(profile, mapped, share: float, full: float, gradient: Any, lean: dict, wall: float) -> dict:
    """The bodies that put the texture on (:mod:`texcad.mapping.modes`): ``slab`` to
    add, ``cutter`` to subtract, ``low`` (the envelope's cutter, for the texture
    alone), ``shown`` (the body whose ``"texture"`` faces are the part's textured
    surface, outward), ``error`` (mm) and ``triangles``."""
    from ..mapping import CUT_FLOOR, mode_sheets
    from ..targets.mesh import _gradient

    s = mapped.s
    gain = None if gradient is None else _gradient(mapped.top.reshape(-1, 3).astype(np.float64), gradient).reshape(mapped.top.shape[:2])
    if share == 0 and gain is None:
        slab, err = lean_mapped_slab(mapped.top, mapped.bottom, profile, s, **lean)
        return {"slab": slab, "cutter": None, "low": None, "shown": slab, "error": err, "triangles": slab.num_triangles}
    # Two lean sheets each within tolerance of their grids: 2 tolerance apart, they cannot cross.
    sheets = mode_sheets(profile, mapped, share=share, height=full, gain=gain, overlap=CUT_FLOOR + 2.0 * lean["tolerance"],
                         thickness=wall)
    if sheets["limited"]:
        import warnings

        from ..errors import TexcadWarning

        warnings.warn(f"the texture was cut less deep at {sheets['limited']} of {mapped.top.shape[0] * mapped.top.shape[1]} "
                      "grid points, where the base is not thick enough under the surface for it; use a smaller height "
                      "or a thicker base", TexcadWarning, stacklevel=3)
    slab = cutter = low = None
    err = 0.0
    if share < 1:  # raised with a gradient: the surface itself; centred: its outline under the cut
        slab, err = lean_mapped_slab(sheets["slab"] if share > 0 else sheets["surface"], mapped.bottom, profile, s, **lean)
    if share > 0:
        cutter, made, cut_err = _inverted(sheets["cut"], sheets["outer"], profile, s, lean)
        low = lambda: _inverted(sheets["low"], sheets["outer"], profile, s, dict(lean, tolerance=0.0, build_dir=None))[0]  # noqa: E731
        err = max(err, cut_err)
    shown = made if share == 1 else slab  # its "texture" faces: the part's textured surface, facing out
    n = sum(b.num_triangles for b in (slab, cutter) if b is not None)
    return {"slab": slab, "cutter": cutter, "low": low, "shown": shown, "error": err, "triangles": n}


def _apply(base_mesh: Mesh, bodies: dict):
    """``(base - cutter) + slab`` with manifold3d, checked to make no more bodies than
    the base has: ``(fused Mesh, texture_mesh)`` (the texture alone: the slab, or for a
    cut texture a callable giving what of the part lies above the envelope's
    bottom)."""
    import manifold3d as m3d

    from ..errors import GeometryError

    base = to_manifold(base_mesh)
    man = base - to_manifold(bodies["cutter"]) if bodies["cutter"] is not None else base
    if bodies["slab"] is not None:
        man = man + to_manifold(bodies["slab"])
    parts = man.decompose()
    real = [p for p in parts if p.volume() > 1e-6]  # booleans can leave flat, zero-volume slivers
    if len(real) < len(parts):
        man = m3d.Manifold.compose(real)
    want, got = len(base.decompose()), len(real)
    if man.status() != m3d.Error.NoError or man.is_empty() or got > want:  # a slab may join pieces of a base
        raise GeometryError(
            f"putting the texture on gave {got} bodies from the base's {want} (manifold3d: {man.status().name}): "
            "a texture came off the surface or cut through the base; use a smaller height, or a thicker base"
        )
    from .faces import welded

    # Vertices within 1e-5 mm merged, as a slicer reading the STL does; where that
    # would pinch an edge, manifold3d's own (index-manifold) mesh is kept.
    fused = welded(man) or from_manifold(man)

    if bodies["cutter"] is None:
        return fused, bodies["slab"]

    def texture_only() -> Mesh:
        return from_manifold(man - (base - to_manifold(bodies["low"]())))

    return fused, texture_only
