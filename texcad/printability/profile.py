"""Print orientation for mapped textures: the slope limiter on a profile's columns.

Shared by :func:`texcad.mapping.textured_surface` and :func:`texcad.pipeline.texture`
(curved faces). Given a :class:`~texcad.mapping.Profile`, the texture about to be
mapped onto it and a build direction in the profile's frame (x across the profile, y
along the extrusion, z up in the profile), it finds the surface tilt under every
texture column from the profile's tangent (``Profile.at(s)``, paper eq. 4: column
``c`` sits at arc length ``s_c``, exactly where :func:`texcad.mapping.map_texture`
puts it) and runs :func:`texcad.printability.limit_overhangs_mapped` with the offset
the mapping uses (``"normal"`` for ``mapping="angle"``, algorithm 2; ``"vertical"``
for ``"distance"``, algorithm 1).

* Distance mapping adds heights along ``sigma z`` (``sigma`` = the facing of the
  function piece). A profile that looks down everywhere (``sigma = -1``) is handled
  by turning the frame 180 degrees about y (a proper rotation, so the outward normal
  stays the tangent's left normal): ``d -> (-d_x, d_y, -d_z)``, ``tilt -> tilt +
  180``. Profiles that look both ways need ``mapping="angle"`` for a build direction.
* Closed profiles: the texture is fitted to the perimeter as ``map_texture`` does it
  (whole repeats, x pitch ``L / columns``) and the limiter runs on three copies side
  by side (tilt continued by the profile's total turning), keeping the middle one;
  this is repeated with the result until the middle copy no longer changes, so the
  texture also satisfies the bounds across the seam (the limiter only lowers).

Borders whose walls would overhang are ramped (M-I) down to ``SINK`` mm *below* the
surface (the limiter runs on ``h + SINK``), so no sliver of their wall is left above
the tessellated base; facets keep the slicers' margin plus ``SLIVER_MARGIN`` degrees from the critical
angle, because the union with the base cuts them into slivers whose float32 normals
scatter.

The heights ``map_texture`` applies are ``w(s) h`` (``w`` = fade and intersection
factor, 1 on smooth upward profiles such as the paper's arc and sine); where ``w < 1``
varies the limiter's model is not exact, so the callers measure the overhang on the
mapped grid and report it (``LimitReport.remaining_overhang_mm2``).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np

from ..errors import ParameterError, TexcadWarning
from ..sources import Heightmap
from ..mapping import column_positions
from ..solid import Mesh
from .overhang import LimitReport, build_directions, limit_overhangs_mapped, overhang_area
from .rule import slicer_margin
from ..mapping import Profile

__all__ = ["limit_on_profile", "measured"]

#: mm: ramped borders end this far below the surface (2x the base's tessellation
#: tolerance in :func:`texcad.brep.shape_to_mesh`), so that their walls lie inside it.
SINK = 0.02
#: Passes over the three copies of a closed texture before giving up (each pass only lowers).
_MAX_PASSES = 12
#: Degrees added to the slicers' margin (:func:`texcad.printability.rule.slicer_margin`)
#: for the facets: mapped meshes are cut by the base surface into slivers whose
#: float32 normals scatter by a few tenths of a degree.
SLIVER_MARGIN = 0.5


def limit_on_profile(
    profile: Profile,
    hm: Heightmap,
    build_dir,
    critical_angle: float,
    *,
    mapping: str,
    periodic: bool = False,
) -> tuple[Heightmap, LimitReport]:
    """Lower ``hm`` so that, mapped onto ``profile``, no texture facet overhangs.

    Args:
        profile: the surface's profile (XZ plane, mm).
        hm: the texture about to be mapped (heights mm, pitch mm/px).
        build_dir: ``(3,)`` or ``(K, 3)`` build direction(s) in the profile's frame.
        critical_angle: degrees (0..90).
        mapping: ``"angle"`` or ``"distance"``.
        periodic: closed profiles: the texture tiles in x (as given to map_texture).

    Returns:
        ``(heightmap', report)``: ``heightmap'`` has ``hm``'s pitch (closed profiles:
        already repeated to fill the perimeter, so ``map_texture`` uses it once).

    Raises:
        ParameterError: distance mapping on a profile that looks both up and down.
    """
    dirs = build_directions(build_dir)
    s, fitted = column_positions(profile, hm, periodic_x=periodic)
    fr = profile.at(np.clip(s, 0.0, profile.length) if not profile.closed else s)
    tilt = np.degrees(np.unwrap(np.arctan2(fr.tangent[:, 1], fr.tangent[:, 0])))
    offset = "normal" if mapping == "angle" else "vertical"
    if offset == "vertical":
        facing = fr.facing
        if np.all(facing < 0):  # looks down everywhere: turn the frame 180 deg about y
            dirs = dirs * np.array([-1.0, 1.0, -1.0])
            tilt = tilt + 180.0
            tilt = (tilt + 180.0) % 360.0 - 180.0
        elif not np.all(facing > 0):
            raise ParameterError(
                "the distance-preserving mapping adds heights along +z on upward and along -z on downward-looking "
                "parts of this profile; the overhang limiter needs one of the two: use mapping='angle' with build_dir"
            )
    margin = slicer_margin(critical_angle) + SLIVER_MARGIN
    h0 = fitted.heights.astype(np.float32)
    # Run on h + SINK and subtract it again: the borders M-I ramps end SINK mm below
    # the surface, inside the base, so no sliver of their wall stands above it.
    lifted = h0 + np.float32(SINK)
    if not profile.closed:
        out, rep = limit_overhangs_mapped(
            Heightmap(lifted, fitted.pitch), tilt, dirs, critical_angle, offset=offset, margin=margin
        )
        res = out.heights
    else:
        # Three copies side by side, tilt continued by the total turning.
        C = fitted.shape[1]
        ext = np.degrees(np.unwrap(np.radians(np.concatenate([tilt, tilt[:1]]))))
        turn = float(ext[-1] - ext[0])  # degrees, +-360 for a smooth closed profile
        tilt3 = np.concatenate([tilt - turn, tilt, tilt + turn])
        res = lifted
        for _ in range(_MAX_PASSES):  # per pass over the three copies; each only lowers
            out, rep = limit_overhangs_mapped(
                Heightmap(np.tile(res, (1, 3)), fitted.pitch), tilt3, dirs, critical_angle, offset=offset, margin=margin
            )
            mid = np.minimum(res, out.heights[:, C : 2 * C])
            if np.array_equal(mid, res):
                break
            res = mid
        rep = dataclasses.replace(rep, ramped_borders=tuple(b for b in rep.ramped_borders if b in ("y0", "y1")))
    h = np.where(res == lifted, h0, res - np.float32(SINK)).astype(np.float32)
    px, py = fitted.pitch
    removed = h0.astype(np.float64) - np.maximum(h, 0.0).astype(np.float64)
    rep = dataclasses.replace(
        rep,
        removed_volume_mm3=float(removed.sum() * px * py),
        max_removed_mm=float(removed.max(initial=0.0)),
        touched_fraction=float(np.count_nonzero(removed > 1e-6) / removed.size),
    )
    # At the texture's own x pitch: map_texture fits a closed one to the perimeter once.
    return Heightmap(h, (hm.pitch[0], py)), rep


def measured(rep: LimitReport, slab: Mesh, build_dir, critical_angle: float) -> LimitReport:
    """``rep`` with ``remaining_overhang_mm2`` measured on the mapped slab's texture
    faces (group ``"texture"``, same frame as ``build_dir``), in mm^2, for the worst
    direction; a :class:`~texcad.errors.TexcadWarning` if it is not 0."""
    faces = slab.groups.get("texture")
    dirs = build_directions(build_dir)
    area = max(overhang_area(slab, d, critical_angle, faces=faces) for d in dirs)  # per direction
    if area > 0 and not rep.surface_overhang:
        warnings.warn(
            f"{area:.3g} mm2 of the mapped texture still overhang (where the mapping fades the texture out near "
            "corners or division points, the limiter's model is approximate); check the part with texcad.check",
            TexcadWarning,
            stacklevel=3,
        )
    return dataclasses.replace(rep, remaining_overhang_mm2=float(area))
