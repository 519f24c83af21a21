"""Memory estimated for a CAD job before its first large allocation (issue 27): the
selected faces' area and outline at the pitch asked for (each zone at its own pitch),
against the memory available; a refusal names the finest pitch that fits. Lengths
in mm, areas in mm^2.
"""

from __future__ import annotations

import sys
from typing import Any

__all__ = ["require_faces_memory", "tiles_fit", "TILED_PIXELS"]


def _groups(where: Any, options: Any) -> list:
    """``[(faces, pitch mm), ...]``: the selected faces, one group per zone."""
    from .cad import is_zones, selected_faces

    if not is_zones(where):
        return [(selected_faces(where), float(options.pitch))]
    items = where.items() if isinstance(where, dict) else where
    out = []
    for z in items:  # per zone: its faces at its own pitch
        opts = z[2] if isinstance(z, tuple) and len(z) == 3 and isinstance(z[2], dict) else \
            (z[1][1] if isinstance(where, dict) and isinstance(z[1], tuple) and len(z[1]) == 2 else {})
        if isinstance(where, dict) and z[1] is None:  # a face left alone
            continue
        out.append((selected_faces(z[0]), float(opts.get("pitch", options.pitch))))
    return out


#: Bytes a pixel of a texture the tiles hold whole (an image or a Heightmap: float32
#: heights and a copy while it is loaded).
HELD_BYTES = 8.0


#: Most texture pixels a planar face is made with in tiles (:mod:`texcad.targets.tiled_faces`):
#: 40 x the 1 x 1 m face at 0.1 mm. Beyond, a job takes hours and its built-in's
#: heights file (8 bytes a pixel) tens of GB: it is refused, naming the pitch that fits
#: untiled.
TILED_PIXELS = 4e9


def tiles_fit(pixels: float, texture: Any) -> bool:
    """Whether ``pixels`` texture pixels are made in tiles at all: at most
    :data:`TILED_PIXELS`, and a built-in's heights file (8 bytes a pixel) within half
    the free space of the temporary folder."""
    import shutil
    import tempfile

    if pixels > TILED_PIXELS:
        return False
    return not _is_builtin(texture) or 8.0 * pixels <= shutil.disk_usage(tempfile.gettempdir()).free / 2


def _is_builtin(texture: Any) -> bool:
    return isinstance(texture, str) and texture.startswith("builtin:")


def _tiles_if_large(texture: Any, options: Any) -> bool:
    """Whether the planar-face adapter makes this job in tiles where the untiled
    relief does not fit (:mod:`texcad.targets.tiled_faces`): raised, no gradient
    (``build_dir`` too: limited block by block). A face with material over it is
    refused later, by the adapter."""
    from ..options import Mode

    return options.mode is Mode.RAISED and options.gradient is None


def require_faces_memory(target: Any, where: Any, texture: Any, options: Any) -> None:
    """Refuse (ResourceError naming the finest pitch that fits) a CAD job whose
    selected faces, at the pitch asked for, need more memory than is available
    (:func:`texcad.util.available_memory`, bounded by ``max_memory``). A target
    that is not a CAD part, or faces that cannot be resolved, pass: the adapters
    report those.

    Bytes: ``grid_area / p^2`` pixels at :data:`texcad.util.resources.BYTES_PER_PIXEL`
    each, plus ``outline / (p / 2)`` outline samples at
    :data:`texcad.brep.budget.OUTLINE_BYTES`. One planar face that the plane adapter
    would make in tiles (raised, no gradient) counts only what the tiles hold
    whole: the outline, and an image's or Heightmap's pixels (:data:`HELD_BYTES`).
    """
    if "OCP" not in sys.modules or where is None:  # no OCCT loaded: not a CAD part (a mesh never loads it)
        return
    from OCP.TopAbs import TopAbs_FACE

    from ..brep.budget import OUTLINE_BYTES, face_extent
    from ..brep.occt import to_topods
    from ..errors import TexcadError
    from ..sources import Heightmap
    from ..util import require_pitch
    from ..util.resources import BYTES_PER_PIXEL

    try:
        groups = [([to_topods(f) for f in faces], pitch) for faces, pitch in _groups(where, options)]
    except (TexcadError, TypeError, AttributeError, IndexError):
        return
    if any(f.ShapeType() != TopAbs_FACE for faces, _ in groups for f in faces):
        return
    if isinstance(texture, Heightmap) and len(groups) == 1:
        groups = [(groups[0][0], float(min(texture.pitch)))]
    ext = [[face_extent(f) for f in faces] for faces, _ in groups]  # per group, per face
    one_plane = len(ext) == 1 and len(ext[0]) == 1 and ext[0][0][3]
    per_px = BYTES_PER_PIXEL["grid" if (options.tolerance <= 0 or not one_plane) else "lean"]
    pixels0 = sum(sum(e[1] for e in g) / p**2 for g, (_, p) in zip(ext, groups))
    if one_plane and _tiles_if_large(texture, options) and tiles_fit(pixels0, texture):  # made in tiles where it does not fit
        per_px = 0.0 if _is_builtin(texture) else HELD_BYTES  # the texture held whole, if any
    finest = min(p for _, p in groups)
    # each group at its own pitch; the pitch named scales them all alike (the finest one's)
    pixels = sum(sum(e[1] for e in g) / p**2 for g, (_, p) in zip(ext, groups))
    outline = sum(sum(e[2] for e in g) / (0.5 * p) for g, (_, p) in zip(ext, groups)) * OUTLINE_BYTES
    area = sum(e[0] for g in ext for e in g)
    what = f"texturing {sum(map(len, ext))} face(s) of {area:.4g} mm2 ({pixels:.3g} px)"
    require_pitch(what, finest, pixels * per_px + outline)
