"""A 2.5D surface (a profile extruded, paper section 2.2) textured and fused onto its
base body: :func:`textured_surface`, the public entry with its own defaults, runs the
one driver with :class:`texcad.targets.surface.SurfaceAdapter` (whose module holds the
numerics: fit -> map -> mode bodies -> union)."""

from __future__ import annotations

import os
from typing import Any

from ..solid import DEFAULT_TOLERANCE
from ..sources import Heightmap
from ..util import Progress
from .result import Textured

__all__ = ["textured_surface"]


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
) -> Textured:
    """Texture a 2.5D surface and fuse it onto its base body: a watertight solid.

    The stages run in the one driver (:func:`texcad.pipeline.driver.run`) with the
    :class:`~texcad.targets.surface.SurfaceAdapter`: fit the texture to the surface
    -> map it (algorithm 1 or 2) -> the mode's slab and cutter -> union with
    manifold3d -> texcad's gate. This function keeps its own defaults (``height`` 2 mm,
    ``pitch`` 0.125 mm, ``mapping="distance"``); :func:`texcad.texture` takes the same
    surface with the shared defaults.

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
    from ..mapping import Profile, Surface
    from ..options import Options
    from ..targets.surface import as_surface
    from .driver import run

    if not isinstance(surface, (Surface, Profile)):  # a build123d curve or sketch: a Surface first
        surface, length, base, thickness = as_surface(surface, length, base, thickness), None, None, None
    options = Options.make(
        length=length, height=height, mapping=mapping, pitch=pitch, depth=depth, base=base, thickness=thickness,
        periodic_x=periodic_x, transition=transition, build_dir=build_dir, critical_angle=critical_angle,
        tolerance=tolerance, mode=mode, gradient=gradient, progress=progress,
    )
    return run(surface, None, texture if isinstance(texture, Heightmap) else os.fspath(texture), options)
