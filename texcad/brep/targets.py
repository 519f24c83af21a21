"""The B-rep of a textured face of an extruded profile (:class:`texcad.targets.ExtrusionAdapter`):
:func:`extrusion_brep`."""

from __future__ import annotations

from typing import Any


__all__ = ["extrusion_brep"]


def extrusion_brep(topo: Any, face: Any, top, bottom, *, closed: bool, base=None, fine=None):
    """The textured B-rep of a face of an extruded profile (grids in world mm, as
    :func:`texcad.brep.textured_extrusion_solid`; ``base`` ``(C, 3)``: the face
    under the grid's first row): an open profile's face is replaced in place by tiles
    (:func:`texcad.brep.open_extrusion_solid`, no boolean; ``fine``: boxes ``(lo,
    hi)`` mm where the tiles are small, for a CAD operation's tool); closed bands and
    anything else go to :func:`texcad.brep.textured_extrusion_solid`."""
    from .uvfaces import open_extrusion_solid
    from .solids import textured_extrusion_solid

    if not closed:
        out = open_extrusion_solid(topo, face, top, base, fine=fine)
        if out is not None:
            return out
    return textured_extrusion_solid(topo, face, top, bottom, closed=closed, fine=fine)
