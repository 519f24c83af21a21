"""The one verb: ``texcad.texture(target, where, texture, **options)``.

The target says which pipeline runs:

* a build123d / CadQuery part (or an OCP shape holding solids): ``where`` picks the
  face(s), chosen with the CAD library's selectors
  (:func:`texcad.pipeline.cad.texture_faces`);
* a :class:`texcad.Surface` or :class:`texcad.Profile` (a 2.5D surface, paper section
  2.2): the whole surface, ``where`` is None
  (:func:`texcad.pipeline.surface.textured_surface`);
* a mesh (a path ending in .stl / .3mf / .obj, a :class:`texcad.Mesh`, a
  ``trimesh.Trimesh``): ``where`` is a region such as ``"normal:+x:70"`` or a list of
  layers (:func:`texcad.targets.mesh.MeshAdapter`).

Every target gives a :class:`texcad.Textured`.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

from ..errors import ParameterError
from ..mapping import Profile, Surface
from ..options import Options
from ..sources import DEFAULT_TEXTURE, Heightmap
from .result import Textured

__all__ = ["texture"]

def _legacy(target: Any, where: Any, texture: Any, o: Options) -> Textured:
    """Targets whose adapters are not written yet: their handlers, with the options
    validated once (one set of defaults)."""
    if isinstance(target, (Surface, Profile)):
        if where is not None:
            raise ParameterError("a Surface is textured whole: pass where=None")
        from .surface import textured_surface

        o.refuse(set(SURFACE_OPTIONS), "a Surface")
        names = [n for n in SURFACE_OPTIONS if n in o.given or n in ("height", "pitch", "mapping", "tolerance", "mode", "critical_angle")]
        return textured_surface(target, texture, **o.as_kwargs(names))
    if where is None:
        raise ParameterError(
            "say which face to texture: texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], texture) "
            "(build123d) or texcad.texture(wp, wp.faces('>Z'), texture) (CadQuery)"
        )
    from .cad import texture_faces

    o.refuse(set(FACE_OPTIONS), "a CAD part")
    return texture_faces(target, where, texture, **o.as_kwargs([n for n in FACE_OPTIONS if n != "progress"]), progress=o.progress)


#: Options of the targets that still run their own handler (mm and degrees).
COMMON = ("height", "pitch", "mapping", "depth", "periodic_x", "transition", "build_dir", "critical_angle", "progress")
FACE_OPTIONS = COMMON + ("edge_angle", "rotation", "offset", "brep", "tolerance", "mode", "gradient")
SURFACE_OPTIONS = COMMON + ("length", "base", "thickness", "tolerance", "mode", "gradient")


def texture(
    target: Any,
    where: Any = None,
    texture: "str | os.PathLike | Heightmap" = f"builtin:{DEFAULT_TEXTURE}",
    **options: Any,
) -> Textured:
    """Texture a part: the one verb of texcad.

    Args:
        target: what to texture: a build123d ``Part``/``Solid``/``Compound`` or
            ``BuildPart``, a CadQuery ``Workplane`` or ``Shape``, an OCP
            ``TopoDS_Shape`` holding solids; or a 2.5D :class:`~texcad.Surface` /
            :class:`~texcad.Profile`.
        where: CAD parts: the face to texture, chosen with selectors, e.g.
            ``part.faces().sort_by(Axis.Z)[-1]`` or ``wp.faces(">Z")``. Surfaces:
            None (the whole surface).
        texture: ``"builtin:NAME[:key=value,...]"``, an image path (white = ``height``
            mm, black = on the surface; stretched over the face), or a
            :class:`~texcad.Heightmap` (used at its own pitch, centred).
        **options: all lengths in mm, angles in degrees:

            * ``height`` (2.0): maximum texture height, mm (built-ins and images);
            * ``pitch`` (0.125): mm per pixel for built-ins: one mesh vertex per pixel;
            * ``mapping`` (``"angle"``): curved faces and surfaces: ``"angle"``
              (algorithm 2, heights along the normal) or ``"distance"`` (algorithm 1,
              heights along z);
            * ``depth``: how far the texture slab reaches into the body, mm;
            * ``build_dir`` / ``critical_angle`` (45): make the texture print without
              support for this build direction ``(3,)`` (or each of a ``(K, 3)`` set),
              in the part's frame (:func:`texcad.printability.orientation`);
            * ``periodic_x``, ``transition``: closed profiles, fades (see
              :func:`texcad.mapping.map_texture`);
            * planar CAD faces: ``edge_angle`` (45: the M-I ramp at the outline),
              ``rotation`` (degrees about the normal), ``offset`` (``(dx, dy)`` mm);
            * CAD parts: ``brep`` (True: ``.shape`` can be made; it is made on first
              use either way);
            * surfaces: ``length`` (extrusion length of a profile, mm), ``base``,
              ``thickness`` (mm);
            * CAD faces and surfaces: ``tolerance`` (0.02): largest distance in mm
              from the mesh to the exact texture at any pixel centre (a lean mesh,
              measured and reported as ``.max_error``; 0: one vertex per pixel);
              meshes: the same default, measured at every point of the pitch grid
              (0: the pitch grid itself);
            * CAD faces and surfaces: ``mode`` (``"raised"``; ``"engraved"``: cut
              into the part, its outer envelope kept; ``"centred"``: half and half)
              and ``gradient`` (``(start, end)`` points, mm: full depth at ``start``,
              none at ``end``);
            * ``progress``: a ``progress(fraction, message)`` callback.

    Returns:
        A :class:`texcad.Textured`: ``mesh`` (fused, watertight), ``texture_mesh``,
        ``base_mesh``, ``heightmap``, ``limits``; ``export(path)`` by extension
        (``.stl``, ``.3mf``, ``.step``, ``.png``), ``render``, ``show``, ``check``;
        ``shape`` / ``part`` / ``workplane`` for the B-rep.

    Raises:
        ParameterError: the face is not on the part, an unknown option, a bad value.
        GeometryError: the face cannot be textured or a boolean failed.
    """
    o = Options.make(**options)
    if not isinstance(texture, Heightmap):
        texture = os.fspath(texture)
    elif "height" not in o.given and texture.max_height > 0:  # a Heightmap keeps its own heights unless told
        o = dataclasses.replace(o, height=float(texture.max_height))
    from ..targets import ADAPTERS

    if any(a.accepts(target, where, o) for a in ADAPTERS):
        from ..targets import Decline
        from .driver import run

        try:
            return run(target, where, texture, o)
        except Decline:
            pass
    return _legacy(target, where, texture, o)
