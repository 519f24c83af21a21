"""The B-rep of faces textured by the general method (:mod:`texcad.pipeline.faces`):
each textured face that was parameterized on its own ``(u, v)`` becomes a degree-1
B-spline on that parameter space in place of the face
(:func:`texcad.solid.uv_textured_solid`); other patches (several faces flattened
together) raise the clear error that names the mesh outputs."""

from __future__ import annotations

from typing import Any

from ..errors import GeometryError
from ..solid import uv_textured_solid

__all__ = ["general_brep"]


def general_brep(topo: Any, res: dict, no_brep: str):
    """The textured B-rep of :func:`texcad.pipeline.faces.texture_any_faces`'s result
    ``res`` on the part ``topo`` (mm).

    Raises:
        GeometryError: a patch has no B-rep this way (the message ``no_brep`` says
            what to write instead).
    """
    items = []
    for r in res["reliefs"]:  # one per patch
        if r["face"] is None or r["tables"] is None:
            why = (f"faces {r['info']['faces']} were flattened together" if r["face"] is None else
                   "a planar face textured by the general method (engraved, centred or with a gradient) has none yet")
            raise GeometryError(f"{no_brep} ({why})")
        ut, vt, closed = r["tables"]
        g = r["grid"]
        items.append({"face": r["face"], "points": g.points, "normals": g.normals, "heights": r["h_top"], "signed": r.get("signed", False), "valid": g.valid,
                      "xs": g.xs, "ys": g.ys, "u_table": ut, "v_table": vt, "closed_u": bool(closed)})  # fmt: skip
    try:
        return uv_textured_solid(topo, items)
    except GeometryError as e:
        raise GeometryError(f"{no_brep}: {e}") from None


def extrusion_brep(topo: Any, face: Any, top, bottom, *, closed: bool, base=None, fine=None):
    """The textured B-rep of a face of an extruded profile (grids in world mm, as
    :func:`texcad.solid.textured_extrusion_solid`; ``base`` ``(C, 3)``: the face
    under the grid's first row): an open profile's face is replaced in place by tiles
    (:func:`texcad.solid.open_extrusion_solid`, no boolean; ``fine``: boxes ``(lo,
    hi)`` mm where the tiles are small, for a CAD operation's tool); closed bands and
    anything else go to :func:`texcad.solid.textured_extrusion_solid`."""
    from ..solid import open_extrusion_solid, textured_extrusion_solid

    if not closed:
        out = open_extrusion_solid(topo, face, top, base, fine=fine)
        if out is not None:
            return out
    return textured_extrusion_solid(topo, face, top, bottom, closed=closed)
