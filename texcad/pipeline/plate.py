"""Whole jobs composed from the stages: the flat textured plate (paper, section 2.2).

These functions hold no numerics of their own; they call the stages in order
(texture -> slab mesh -> base body -> union) and report progress.
"""

from __future__ import annotations

import os
from typing import Any, Sequence

import numpy as np

from ..errors import GeometryError, ParameterError
from ..sources import Heightmap
from ..solid import DEFAULT_TOLERANCE, Mesh, check_tolerance, heightfield_slab, mesh_error
from ..util import Progress, fitting_pitch, report, require_memory, texture_bytes
from ..solid import fuse
from ..brep import shape_to_mesh
from ..solid.boolean import fuse_on_plane
from ..solid.mesh import heightfield_volume
from ..sources import load_texture
from .result import Textured

__all__ = ["plate_base", "textured_plate"]


def plate_base(size: Sequence[float], thickness: float):
    """A build123d box ``size[0] x size[1] x thickness`` mm with its top face at z = 0
    and its corner at the origin (x, y >= 0)."""
    from build123d import Align, Box

    return Box(size[0], size[1], thickness, align=(Align.MIN, Align.MIN, Align.MAX))


def textured_plate(
    texture: "str | os.PathLike | Heightmap",
    *,
    size: Sequence[float] = (100.0, 100.0),
    thickness: float = 5.0,
    height: float = 2.0,
    pitch: float = 0.125,
    depth: float | None = None,
    base: Any = None,
    build_dir: Any = None,
    critical_angle: float = 45.0,
    tolerance: float = DEFAULT_TOLERANCE,
    progress: Progress = None,
) -> Textured:
    """Texture the top face of a plate: the paper's flat sample (section 2.2).

    The texture lies on the plate's top face (z = 0), centred; mesh vertices at
    pixel centres (all of them with ``tolerance=0``); the slab reaches ``depth`` mm
    into the plate. A lean slab (``tolerance`` > 0) on a base with nothing above
    z = 0 is stitched into the plate's mesh without a boolean
    (:func:`texcad.solid.boolean.fuse_on_plane`, checked; ``info["fuse"]`` says
    how); otherwise it is unioned onto the plate with manifold3d.

    Args:
        texture: ``"builtin:NAME"``, an image path, or a Heightmap (used as is).
        size: ``(width, depth)`` of the plate in mm (x, y).
        thickness: plate thickness in mm (z from ``-thickness`` to 0).
        height: maximum texture height in mm (for built-ins and images).
        pitch: mm per pixel for built-ins (images: ``size / pixels``).
        depth: how far in mm the slab reaches into the plate (default: half the
            thickness, at most 0.5 mm).
        base: optional build123d/CadQuery solid to use instead of the plain plate;
            its top face must be the rectangle ``[0, w] x [0, d]`` at z = 0.
        build_dir: make the texture print without support for this build
            direction ``(3,)`` (plate frame: z is the face normal; see
            :func:`texcad.printability.orientation`) or every direction of a
            ``(K, 3)`` set: M-I ramps at the borders that would overhang and the
            slope limiter (:func:`texcad.printability.limit_overhangs`) lower the
            texture as little as needed. None: the texture is used as is.
        critical_angle: critical overhang angle in degrees (default 45; paper,
            section 2.1.3), used with ``build_dir``.
        tolerance: largest height error in mm of the texture surface at any pixel
            centre (default 0.02 mm; :func:`texcad.solid.lean.triangulate`); 0 keeps
            one vertex per pixel. The measured error is ``Textured.max_error``.
        progress: optional ``progress(fraction, message)`` callback.

    Returns:
        :class:`texcad.Textured` with the fused mesh, the texture slab as
        ``texture_mesh`` (it reaches ``depth`` mm into the plate), ``limits`` (what
        the overhang limiter removed).

    Raises:
        ParameterError: non-positive size, thickness, height or depth.
        GeometryError: the texture is larger than the plate, or the slab would
            reach through the plate.
    """
    w, d = (float(s) for s in size)
    for label, v in (("plate width", w), ("plate depth", d), ("thickness", thickness), ("height", height)):
        if not (np.isfinite(v) and v > 0):
            raise ParameterError(f"{label} must be a positive number of mm, got {v!r}")
    depth = min(0.5, thickness / 2) if depth is None else float(depth)
    if not (0 < depth < thickness):
        raise GeometryError(
            f"the texture slab would reach {depth} mm into a {thickness} mm plate; "
            f"use a depth between 0 and {thickness} mm"
        )
    report(progress, 0.0, "loading texture")
    hm = texture if isinstance(texture, Heightmap) else load_texture(texture, size=(w, d), pitch=pitch, height=height)
    tw, td = hm.size
    if tw > w + 1e-6 or td > d + 1e-6:
        raise GeometryError(
            f"the texture covers {tw:g} x {td:g} mm but the plate is only {w:g} x {d:g} mm; "
            "crop the texture or make the plate larger"
        )
    limits = None
    if build_dir is not None:
        from ..printability import limit_overhangs

        report(progress, 0.1, f"limiting overhangs to {critical_angle:g} deg")
        hm, limits = limit_overhangs(hm, build_dir, critical_angle)
    report(progress, 0.15, f"meshing {hm.shape[0]} x {hm.shape[1]} px heightmap")
    tolerance = check_tolerance(tolerance)
    need = texture_bytes(hm.shape[0] * hm.shape[1], tolerance)
    fix = f"use pitch >= {fitting_pitch(min(hm.pitch), need):.3g} mm"
    require_memory(need, f"a {hm.shape[0]} x {hm.shape[1]} px texture on the plate", fix)
    origin = ((w - tw) / 2, (d - td) / 2, 0.0)
    if build_dir is not None and tolerance > 0:
        from ..printability import printable_lean_slab

        # lean facets keep the limiter's angle too (else a finer tolerance, down to 0)
        slab, _ = printable_lean_slab(hm, build_dir, critical_angle, tolerance=tolerance, depth=depth, origin=origin)
    else:
        slab = heightfield_slab(hm, depth=depth, origin=origin, tolerance=tolerance)
    report(progress, 0.35, "building base body")
    base_shape = plate_base((w, d), thickness) if base is None else base
    base_mesh = base_shape if isinstance(base_shape, Mesh) else shape_to_mesh(base_shape)
    report(progress, 0.45, f"fusing {slab.num_triangles} texture triangles onto the base")
    fused, how = _fuse_plate(base_mesh, slab, hm, tolerance)
    report(progress, 0.9, "measuring the surface error at every pixel centre")
    err = mesh_error(hm.heights, hm.pitch, origin, slab.vertices, slab.faces[slab.groups["texture"]])
    report(progress, 1.0, "fused")
    from ..targets.legacy import legacy_stages

    return Textured(legacy_stages(
        mesh=fused, texture_mesh=slab, base_mesh=base_mesh, heightmap=hm, limits=limits, max_error=err,
        info={"face": "plate", "grid": hm.shape, "size": (w, d), "thickness": float(thickness), "fuse": how},
        kind="plate", result_kind="plate",
    ))


def _fuse_plate(base_mesh: Mesh, slab: Mesh, hm: Heightmap, tolerance: float) -> tuple[Mesh, str]:
    """The slab fused onto the plate: ``(fused, how)``. A lean slab on a base with
    nothing above its top face (z <= 0) is stitched in without a boolean
    (:func:`texcad.solid.boolean.fuse_on_plane`, checked against the heightfield's
    volume within ``tolerance`` x area); otherwise, with ``tolerance=0`` (the same
    bytes as before) or when a check fails (``how`` says which), manifold3d's union."""
    how = "manifold3d"
    if tolerance > 0 and float(base_mesh.bounds[1][2]) <= 0.0:
        vol, slack = heightfield_volume(hm.heights, hm.pitch)
        area = hm.size[0] * hm.size[1]
        try:
            return fuse_on_plane(base_mesh, slab.vertices, slab.faces, expect=(vol, slack + tolerance * area))[0], "stitched"
        except GeometryError as exc:
            how = f"manifold3d (the stitch failed a check: {exc})"
    return fuse(base_mesh, slab), how
