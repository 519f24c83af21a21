"""The flat textured plate (paper, section 2.2) as a function with the ``texcad plate``
defaults: a thin wrapper over the one driver and the plate adapter
(:class:`texcad.targets.plate.PlateAdapter`); ``texcad.texture(texcad.Plate(...), None,
texture)`` is the same with the API's defaults.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any, Sequence

from ..solid import DEFAULT_TOLERANCE
from ..sources import Heightmap
from ..targets.plate import Plate, plate_base
from ..util import Progress
from .driver import run
from .result import Textured

__all__ = ["plate_base", "textured_plate"]


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
    from ..options import Options

    plate = Plate(tuple(size), thickness, base)
    o = Options.make(height=height, pitch=pitch, depth=depth, build_dir=build_dir, critical_angle=critical_angle,
                     tolerance=tolerance, progress=progress)
    if isinstance(texture, Heightmap):  # used as it is: its own pitch and heights
        o = dataclasses.replace(o, given=o.given - {"height"})
    else:
        texture = os.fspath(texture)
    return run(plate, None, texture, o)
