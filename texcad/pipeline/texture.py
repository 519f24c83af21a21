"""The one verb: ``texcad.texture(target, where, texture, **options)``.

The target says which pipeline runs:

* a build123d / CadQuery part (or an OCP shape holding solids): ``where`` picks the
  face(s), chosen with the CAD library's selectors (:class:`texcad.targets.PlaneAdapter`,
  :class:`~texcad.targets.ExtrusionAdapter`, :class:`~texcad.targets.FacesAdapter`), or
  gives zones ``[(faces, texture, {options}), ...]`` (the any-faces adapter);
* a :class:`texcad.Surface` or :class:`texcad.Profile` (a 2.5D surface, paper section
  2.2): the whole surface, ``where`` is None
  (:class:`texcad.targets.surface.SurfaceAdapter`);
* a mesh (a path ending in .stl / .3mf / .obj, a :class:`texcad.Mesh`, a
  ``trimesh.Trimesh``): ``where`` is a region such as ``"normal:+x:70"`` or a list of
  layers (:func:`texcad.targets.mesh.MeshAdapter`);
* a :class:`texcad.Plate`: its top face, ``where`` is None
  (:class:`texcad.targets.plate.PlateAdapter`).

Every target gives a :class:`texcad.Textured`.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

from ..errors import ParameterError
from ..options import Options
from ..sources import DEFAULT_TEXTURE, Heightmap
from .result import Textured

__all__ = ["texture"]


def texture(
    target: Any,
    where: Any = None,
    texture: "str | os.PathLike | Heightmap" = f"builtin:{DEFAULT_TEXTURE}",
    **options: Any,
) -> Textured:
    """Texture a part: the one verb of texcad. Lengths in mm, angles in degrees.

    Every target runs the same stages (:func:`texcad.pipeline.driver.run`): the
    options are validated once (:class:`texcad.options.Options`), the target's
    adapter places the texture, makes the relief and fuses it, and the result passes
    texcad's gate (:mod:`texcad.report.gate`) before it is returned.

    Args:
        target: what to texture: a build123d ``Part``/``Solid``/``Compound`` or
            ``BuildPart``, a CadQuery ``Workplane`` or ``Shape``, an OCP
            ``TopoDS_Shape`` holding solids, a STEP file's path (read strictly:
            :func:`texcad.io.read_step`), an earlier result (chaining); a 2.5D
            :class:`~texcad.Surface` / :class:`~texcad.Profile`; a
            :class:`~texcad.Plate`; or a mesh (a path
            ending in .stl / .3mf / .obj, a :class:`texcad.Mesh`, a ``trimesh.Trimesh``).
        where: CAD parts: the face(s), chosen with selectors, e.g.
            ``part.faces().sort_by(Axis.Z)[-1]`` or ``wp.faces(">Z")``, or named as
            on the command line (``"top"``, ``"cylinder:all"``, ``"front+back"``,
            ``"solid:1/top"``: :mod:`texcad.brep.selectors`), or zones: a
            list of ``(faces, texture, {options})`` (or a mapping ``{face: texture}``),
            each zone its own texture and its own ``height``, ``pitch``, ``mode``,
            ``depth``, ``edge_angle``, ``rotation``, ``tolerance``, ``gradient`` over
            the call's (:data:`texcad.targets.cad.ZONE_OPTIONS`); surfaces, plates: None;
            meshes: a region such as ``"normal:+x:70"`` (default: every face but the
            bed face) or a list of layers ``(region, texture, {options})``.
        texture: ``"builtin:NAME[:key=value,...]"``, an image path (white = ``height``
            mm, black = on the surface), or a :class:`~texcad.Heightmap` (used at its
            own pitch and heights unless ``height`` is given). With zones, only the
            zones whose texture is None use it.
        **options: the fields of :class:`texcad.options.Options`, with the defaults
            the ``texcad`` command uses too: ``height`` (1 mm), ``pitch`` (0.25 mm),
            ``mode`` (raised / engraved / centred), ``tolerance`` (0.02 mm),
            ``build_dir`` and ``critical_angle`` (45 degrees), ``gradient``,
            ``rotation``, ``max_memory``, ``progress``; for CAD faces and surfaces
            ``mapping``, ``depth``, ``edge_angle``, ``offset``, ``periodic_x``,
            ``transition``, ``brep``; for surfaces ``length``, ``base``,
            ``thickness``; for meshes ``projection``, ``axis``, ``origin``, ``radius``,
            ``blend``, ``local_radius``, ``border``, ``scale``, ``size``, ``mask``,
            ``mask_size``. An option that does not apply to the target is refused.

    Returns:
        A :class:`texcad.Textured`: ``mesh`` (fused, watertight), ``texture_mesh``,
        ``base_mesh``, ``heightmap``, ``limits``, ``gate`` (the gate's figures);
        ``export(path)`` by extension (``.stl``, ``.3mf``, ``.step``, ``.png``),
        ``render``, ``show``, ``check``; ``shape`` / ``part`` / ``workplane`` for the
        B-rep; ``-``, ``+``, ``&``, ``fillet``, ``mirrored``, ``patterned``.

    Raises:
        ParameterError: the face is not on the part, an unknown option, a bad value;
            with zones, a face in two zones, an empty zone, an option a zone cannot
            set (the message names the zone).
        InputError: an unreadable or broken input file.
        GeometryError: the texture cannot be made, or the result failed the gate.
        ResourceError: more memory than the machine (or ``max_memory``) allows; the
            message names the finest pitch that fits. A :class:`~texcad.Plate` too
            large for memory is textured in tiles instead (:mod:`texcad.targets.tiled`).
    """
    o = Options.make(**options)
    if not isinstance(texture, (Heightmap, str, os.PathLike)):
        raise ParameterError(f"texture {texture!r}: use 'builtin:NAME' (texcad textures lists them), an image path "
                             "or a texcad.Heightmap")
    if not isinstance(texture, Heightmap):
        texture = os.fspath(texture)
    elif "height" not in o.given and texture.max_height > 0:  # a Heightmap keeps its own heights unless told
        o = dataclasses.replace(o, height=float(texture.max_height))
    from .driver import run

    return run(_read_step_target(target), where, texture, o)


def _read_step_target(target: Any) -> Any:
    """A STEP path (``.step`` / ``.stp``) read as a build123d ``Compound`` (as the
    command line reads it); any other target as it is."""
    if not (isinstance(target, (str, os.PathLike)) and os.fspath(target).lower().endswith((".step", ".stp"))):
        return target
    from build123d import Compound

    from ..io import read_step

    return Compound(read_step(target))
