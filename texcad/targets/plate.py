"""Adapter: a flat textured plate, the paper's flat sample (section 2.2):
``texcad.texture(texcad.Plate((100, 100), 3), None, "builtin:stones")``.

**Place.** The plate is a box ``size[0] x size[1] x thickness`` mm with its top face
at z = 0 and its corner at the origin (or a given base whose top face is that
rectangle); the texture goes on the top face, centred.

**Relief.** The texture at its pitch over the plate (a Heightmap as it is unless
``height`` is given), the overhang limiter for ``build_dir``
(:func:`texcad.printability.limit_overhangs`), and the slab: mesh vertices at pixel
centres (lean within ``tolerance``; all of them with ``tolerance=0``), reaching
``depth`` mm into the plate (default: half the thickness, at most 0.5 mm).

**Fuse.** A lean slab on a base with nothing above z = 0 is stitched into the plate's
mesh without a boolean (:func:`texcad.solid.boolean.fuse_on_plane`, checked;
``info["fuse"]`` says how); otherwise manifold3d's union. No B-rep (write STL / 3MF).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..contracts import Fused, Placement, Relief, Stages
from ..errors import GeometryError, ParameterError
from ..options import Options
from ..report.gate import shell_report
from ..solid import Mesh, fuse, heightfield_slab, mesh_error
from ..solid.boolean import fuse_on_plane
from ..solid.mesh import heightfield_volume
from ..sources import Heightmap
from ..util import fitting_pitch, require_memory, texture_bytes
from .base import Adapter

__all__ = ["Plate", "PlateAdapter", "plate_base"]


@dataclass(frozen=True)
class Plate:
    """A flat plate to texture on its top face (a target of :func:`texcad.texture`).

    Attributes:
        size: ``(width, depth)`` of the plate, mm (x, y).
        thickness: mm; the plate spans z from ``-thickness`` to 0, x and y from 0.
        base: optional build123d / CadQuery solid or :class:`texcad.Mesh` to use
            instead of the plain box; its top face must be the rectangle
            ``[0, width] x [0, depth]`` at z = 0.

    Raises:
        ParameterError: a size or thickness that is not a positive number of mm.
    """

    size: tuple
    thickness: float = 5.0
    base: Any = None

    def __post_init__(self) -> None:
        try:
            w, d = (float(s) for s in self.size)
        except (TypeError, ValueError):
            raise ParameterError(f"a plate's size is (width, depth) in mm, got {self.size!r}") from None
        for label, v in (("plate width", w), ("plate depth", d), ("thickness", self.thickness)):
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
                raise ParameterError(f"{label} must be a positive number of mm, got {v!r}")
        object.__setattr__(self, "size", (w, d))
        object.__setattr__(self, "thickness", float(self.thickness))


def plate_base(size, thickness: float):
    """A build123d box ``size[0] x size[1] x thickness`` mm with its top face at z = 0
    and its corner at the origin (x, y >= 0)."""
    from build123d import Align, Box

    return Box(size[0], size[1], thickness, align=(Align.MIN, Align.MIN, Align.MAX))


@dataclass(frozen=True)
class PlatePlacement:
    """The plate placed (``Placement.data``): its size ``(w, d)`` and thickness (mm),
    and ``depth``, how far the slab reaches into it (mm)."""

    size: tuple
    thickness: float
    depth: float


@dataclass(frozen=True)
class PlateRelief:
    """The slab on the plate (``Relief.data``): the closed slab mesh (mm, its top at
    the texture's pixel centres, group ``"texture"``), its ``origin`` (the corner of
    the texture on the plate, mm) and the lean ``tolerance`` (mm)."""

    slab: Mesh
    origin: tuple
    tolerance: float


class PlateAdapter(Adapter):
    """A :class:`Plate`: the texture on its top face."""

    kind = "plate"
    label = "a plate"
    result_kind = "plate"
    options = frozenset({"height", "pitch", "depth", "tolerance", "build_dir", "critical_angle"})

    def accepts(self, target: Any, where: Any, options: Options) -> bool:
        return isinstance(target, Plate)

    def place(self, target: Plate, where: Any, texture: Any, options: Options) -> Placement:
        from ..brep import shape_to_mesh

        if where is not None:
            raise ParameterError("a Plate is textured on its top face: pass where=None")
        w, d = target.size
        depth = options.depth if "depth" in options.given else min(0.5, target.thickness / 2)
        if not (0 < depth < target.thickness):
            raise GeometryError(
                f"the texture slab would reach {depth} mm into a {target.thickness} mm plate; "
                f"use a depth between 0 and {target.thickness} mm"
            )
        options.report(0.02, "building base body")
        shape = plate_base((w, d), target.thickness) if target.base is None else target.base
        base = shape if isinstance(shape, Mesh) else shape_to_mesh(shape)
        top = (np.array([[0, 0, 0], [w, 0, 0], [w, d, 0], [0, d, 0]], np.float64), np.array([[0, 1, 2], [0, 2, 3]]))
        return Placement("plate", base, shell_report(base).bodies, top, data=PlatePlacement((w, d), target.thickness, depth))

    def relief(self, placement: Placement, texture: Any, options: Options) -> Relief:
        from ..sources import load_texture

        pl: PlatePlacement = placement.data
        w, d = pl.size
        options.report(0.05, "loading texture")
        if isinstance(texture, Heightmap):  # its own pitch, and its own heights unless told
            hm = texture if "height" not in options.given else load_texture(texture, height=options.height)
        else:
            hm = load_texture(texture, size=(w, d), pitch=options.pitch, height=options.height)
        tw, td = hm.size
        if tw > w + 1e-6 or td > d + 1e-6:
            raise GeometryError(
                f"the texture covers {tw:g} x {td:g} mm but the plate is only {w:g} x {d:g} mm; "
                "crop the texture or make the plate larger"
            )
        nominal = heightfield_volume(hm.heights, hm.pitch)[0]
        limits, dirs = None, options.directions
        if dirs is not None:
            from ..printability import limit_overhangs

            options.report(0.1, f"limiting overhangs to {options.critical_angle:g} deg")
            hm, limits = limit_overhangs(hm, dirs, options.critical_angle)
        options.report(0.15, f"meshing {hm.shape[0]} x {hm.shape[1]} px heightmap")
        tolerance = options.tolerance
        need = texture_bytes(hm.shape[0] * hm.shape[1], tolerance)
        fix = f"use pitch >= {fitting_pitch(min(hm.pitch), need):.3g} mm"
        require_memory(need, f"a {hm.shape[0]} x {hm.shape[1]} px texture on the plate", fix)
        origin = ((w - tw) / 2, (d - td) / 2, 0.0)
        if dirs is not None and tolerance > 0:
            from ..printability import printable_lean_slab

            # lean facets keep the limiter's angle too (else a finer tolerance, down to 0)
            slab, _ = printable_lean_slab(hm, dirs, options.critical_angle, tolerance=tolerance, depth=pl.depth, origin=origin)
        else:
            slab = heightfield_slab(hm, depth=pl.depth, origin=origin, tolerance=tolerance)
        vol, slack = heightfield_volume(hm.heights, hm.pitch)
        return Relief(
            heightmap=hm, limits=limits, volume=vol, volume_slack=slack + tolerance * tw * td + 1e-3 * abs(vol),
            nominal_volume=nominal, reach=float(hm.heights.max()) + 1e-3, data=PlateRelief(slab, origin, float(tolerance)),
        )

    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        pl: PlatePlacement = placement.data
        r: PlateRelief = relief.data
        options.report(0.45, f"fusing {r.slab.num_triangles} texture triangles onto the base")
        fused, how = fuse_plate(placement.base, r.slab, relief.heightmap, r.tolerance)
        info = {"face": "plate", "grid": relief.heightmap.shape, "size": pl.size, "thickness": pl.thickness, "fuse": how}
        return Fused(fused, placement.base, info)

    def texture_mesh(self, stages: Stages) -> Mesh:
        """The slab itself (it reaches ``depth`` mm into the plate), mm."""
        return stages.relief.data.slab

    def max_error(self, stages: Stages) -> float:
        """The slab's largest height error at the pixel centres, mm."""
        r: PlateRelief = stages.relief.data
        hm = stages.relief.heightmap
        return mesh_error(hm.heights, hm.pitch, r.origin, r.slab.vertices, r.slab.faces[r.slab.groups["texture"]])

    def brep(self, stages: Stages, fine: Any = None) -> Any:
        raise GeometryError("a textured plate has no B-rep (its texture is a mesh); write STL or 3MF instead")


def fuse_plate(base_mesh: Mesh, slab: Mesh, hm: Heightmap, tolerance: float) -> "tuple[Mesh, str]":
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
