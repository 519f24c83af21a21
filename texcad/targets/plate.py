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

**Tiles.** Where the untiled relief would not fit in the memory available (the
machine's, or ``max_memory``), a plain plate is made in tiles instead
(:mod:`texcad.targets.tiled`): the relief is the texture's source, read a tile at a
time, the fused mesh a :class:`~texcad.targets.tiled.TiledMesh` that the gate checks
(:func:`~texcad.targets.tiled.gate_tiled`) and the export streams, tile by tile. With
a ``tolerance`` > 0 (the default 0.02 mm, as untiled) each tile is lean within it (its border rows and columns kept whole,
so that the tiles meet exactly; the error measured at every pixel centre and gated
tile by tile); with 0 it keeps every pixel centre. ``depth`` is not used (the texture
is the plate's top) and the rim slopes from the outer pixel centres to the plate's
edge (``info["fuse"] == "tiled"``). With ``build_dir`` the overhang
limiter runs block by block, each block limited from the block grown by a halo
(:func:`texcad.printability.overhang.limit_overhangs_tiled`): the same heights as the untiled
limiter, bit for bit. A given ``base`` is not tiled: that is refused as before.
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
class PlateTiles:
    """The relief of a plate made in tiles (``Relief.data``): the node ``grid``
    (:class:`texcad.solid.tiles.PlateGrid`) and the texture's ``source`` (its
    ``heights(rows, cols)`` in mm, a block at a time)."""

    grid: Any
    source: Any


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
        tiled = self._tiled(placement, texture, options)
        if tiled is not None:
            return tiled
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

    def _tiled(self, placement: Placement, texture: Any, options: Options) -> "Relief | None":
        """The relief in tiles where the untiled one would not fit in the memory
        available, else None (see the module's docstring)."""
        from .tiled import builtin_grid, plate_source
        from ..util import available_memory

        pl: PlatePlacement = placement.data
        w, d = pl.size
        if isinstance(texture, Heightmap):
            shape = texture.shape
        else:
            shape = builtin_grid(texture, (w, d), options.pitch)
            if shape is None:  # an image: its pixels at this pitch (loaded once more by the source)
                shape = (int(d / options.pitch), int(w / options.pitch))
        need = texture_bytes(shape[0] * shape[1], options.tolerance)
        if need <= available_memory():
            return None
        what = f"a {shape[0]} x {shape[1]} px texture on the plate"
        if not _is_box(placement.base, w, d, pl.thickness):
            require_memory(need, what, "a plate with its own base is not made in tiles; use pitch >= "
                                       f"{fitting_pitch(options.pitch, need):.3g} mm")
        options.report(0.1, f"{what}: made in tiles")
        height: Any = options.height
        if isinstance(texture, Heightmap):  # as the untiled plate: its own pixels, and its own heights unless told
            from ..sources import load_texture

            texture = texture if "height" not in options.given else load_texture(texture, height=options.height)
            height = None
        source, side = plate_source(texture, (w, d), options.pitch, height, bound=options.max_memory,
                                    progress=lambda f, m: options.report(0.1 + 0.2 * f, m), tolerance=_tile_tolerance(options))
        top = float(source.hm.heights.max()) if height is None else float(height)
        nominal, limits = source.integral()[0], None
        if options.directions is not None:  # the limiter block by block (each from its halo), the result on disk
            from .tiled import LimitedSource

            options.report(0.3, f"limiting overhangs to {options.critical_angle:g} deg, in blocks")
            try:
                limited = LimitedSource(source, options.directions, options.critical_angle, side,
                                        progress=lambda f, m: options.report(0.3 + 0.1 * f, m))
            finally:
                source.close()  # the unlimited heights are not read again
            source, limits, top = limited, limited.limit.report, limited.limit.top
        from ..solid.tiles import PlateGrid

        grid = PlateGrid((w, d), source.shape, source.pitch, side)
        vol, slack = source.integral()
        (r, c), (px, py) = source.shape, source.pitch
        rim = 2 * (w + d) * (max(w - c * px, d - r * py) / 2 + max(px, py) / 2) * max(top, 0.0) / 2  # the sloped rim (tiled.py)
        tol = _tile_tolerance(options)
        lean = tol * c * px * r * py  # a lean surface within the tolerance of the heights
        return Relief(heightmap=None, limits=limits, volume=vol, volume_slack=slack + rim + lean + 1e-3 * abs(vol),
                      nominal_volume=nominal, reach=top + 1e-3, max_error=None if tol > 0 else 0.0,
                      data=PlateTiles(grid, source))

    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        pl: PlatePlacement = placement.data
        if isinstance(relief.data, PlateTiles):
            from .tiled import TiledMesh, cluster_client

            g = relief.data.grid
            options.report(0.45, f"{g.count} tile(s) of up to {g.tile} x {g.tile} nodes")
            tol = _tile_tolerance(options)
            info = {"face": "plate", "grid": tuple(relief.data.source.shape), "size": pl.size, "thickness": pl.thickness,
                    "fuse": "tiled", "tiles": g.count, "tile": int(g.tile), "tolerance": tol}
            told = lambda f, m: options.report(0.92 + 0.07 * f, f"checking the result (texcad's gate): {m}")  # noqa: E731
            check = None
            if options.directions is not None and tol > 0:  # lean facets keep the limiter's angle
                from ..printability.overhang import lean_facets

                check = lean_facets(options.directions, options.critical_angle)
            client = cluster_client(options.client, limited=options.directions is not None)
            mesh = TiledMesh(g, relief.data.source, pl.thickness, client, progress=told, tolerance=tol, check=check)
            return Fused(mesh, placement.base, info)
        r: PlateRelief = relief.data
        options.report(0.45, f"fusing {r.slab.num_triangles} texture triangles onto the base")
        fused, how = fuse_plate(placement.base, r.slab, relief.heightmap, r.tolerance)
        info = {"face": "plate", "grid": relief.heightmap.shape, "size": pl.size, "thickness": pl.thickness, "fuse": how}
        return Fused(fused, placement.base, info)

    def texture_mesh(self, stages: Stages) -> Mesh:
        """The slab itself (it reaches ``depth`` mm into the plate), mm."""
        if isinstance(stages.relief.data, PlateTiles):
            raise GeometryError("a plate made in tiles keeps no separate texture body (it does not fit in memory); "
                                "write the part's STL or 3MF, or use a coarser pitch")
        return stages.relief.data.slab

    def max_error(self, stages: Stages) -> float:
        """The slab's largest height error at the pixel centres, mm (lean tiles: as
        measured tile by tile)."""
        if isinstance(stages.relief.data, PlateTiles):
            return stages.fused.mesh.max_error
        r: PlateRelief = stages.relief.data
        hm = stages.relief.heightmap
        return mesh_error(hm.heights, hm.pitch, r.origin, r.slab.vertices, r.slab.faces[r.slab.groups["texture"]])

    def brep(self, stages: Stages, fine: Any = None) -> Any:
        raise GeometryError("a textured plate has no B-rep (its texture is a mesh); write STL or 3MF instead")


def _tile_tolerance(options: Options) -> float:
    """The tiles' tolerance, mm: the untiled plate's (``options.tolerance``, default
    0.02 mm), so a plate is as lean in tiles as it is whole; 0 keeps every pixel centre."""
    return float(options.tolerance)


def _is_box(mesh: Mesh, w: float, d: float, t: float) -> bool:
    """Whether ``mesh`` is the plain plate ``[0, w] x [0, d] x [-t, 0]`` mm."""
    b = np.asarray(mesh.bounds, dtype=np.float64)
    return bool(np.allclose(b, [[0, 0, -t], [w, d, 0]], atol=1e-6) and abs(float(mesh.volume) - w * d * t) <= 1e-6 * w * d * t)


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
