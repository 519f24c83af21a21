"""The B-rep of faces textured by the general method (:mod:`texcad.pipeline.faces`):
each textured face that was parameterized on its own ``(u, v)`` becomes a degree-1
B-spline on that parameter space in place of the face
(:func:`texcad.brep.uv_textured_solid`); other patches (several faces flattened
together) raise the clear error that names the mesh outputs."""

from __future__ import annotations

from typing import Any

from ..errors import GeometryError
from .uvfaces import uv_textured_solid

__all__ = ["general_brep"]


def general_brep(topo: Any, res: dict, no_brep: str, rotation: float = 0.0, fine=None):
    """The textured B-rep of :func:`texcad.pipeline.faces.texture_any_faces`'s result
    ``res`` on the part ``topo`` (mm; ``rotation``: the texture's turn on planar
    faces, degrees; ``fine``: rectangles ``(x0, x1, y0, y1)`` mm in a planar face's
    frame where its tiles are small, for a CAD operation's tool). Curved faces:
    :func:`texcad.brep.uv_textured_solid`; planar faces (engraved, centred, with a
    gradient): tiles in the face's frame
    (:func:`texcad.brep.uvfaces.holed_plane_solid`).

    Raises:
        GeometryError: a patch has no B-rep this way (the message ``no_brep`` says
            what to write instead).
    """
    items, planes = [], []
    for r in res["reliefs"]:  # one per patch
        if r["face"] is None:
            raise GeometryError(f"{no_brep} (faces {r['info']['faces']} were flattened together)")
        if r["tables"] is None:  # a plane: its grid lies in the face's frame
            planes.append(r)
            continue
        ut, vt, closed = r["tables"]
        g = r["grid"]
        items.append({"face": r["face"], "points": g.points, "normals": g.normals, "heights": r["h_top"], "signed": r.get("signed", False), "valid": g.valid,
                      "xs": g.xs, "ys": g.ys, "u_table": ut, "v_table": vt, "closed_u": bool(closed)})  # fmt: skip
    try:
        shape = uv_textured_solid(topo, items) if items else topo
        for r in planes:  # one per planar face
            shape = _plane_brep(shape, r, rotation, fine)
        return shape
    except GeometryError as e:
        raise GeometryError(f"{no_brep}: {e}") from None


def _plane_brep(shape: Any, r: dict, rotation: float, fine=None):
    """``shape`` with the planar face of the relief ``r`` (the general method's grid,
    in the face's frame) in tiles; heights 0 outside the kept cells and near the
    outline (the mesh's 20 um floor there is not carried over)."""
    import numpy as np

    from .uvfaces import holed_plane_solid
    from .frames import plane_frame

    p0, ex, _, n = plane_frame(r["face"], rotation)
    g, cells = r["grid"], r["cells"]
    kept = np.zeros(g.valid.shape, bool)
    for a, b in ((slice(None, -1), slice(None, -1)), (slice(None, -1), slice(1, None)), (slice(1, None), slice(None, -1)), (slice(1, None), slice(1, None))):
        kept[a, b] |= cells  # the 4 corners of each kept cell
    h = np.where(kept & g.valid, r["h_top"], 0.0)
    out = holed_plane_solid(shape, r["face"], h, np.asarray(g.xs, np.float64), np.asarray(g.ys, np.float64),
                            origin=p0, xdir=ex, normal=n, flatten_outline=True, fine=fine)  # fmt: skip
    if out is None:
        raise GeometryError("the planar face's texture grid reaches its outline; texture it in raised mode for a B-rep")
    return out


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
