"""Memory estimated for a CAD job before its first large allocation: the selected
faces' area and outline at the pitch asked for, against the memory available, with a
refusal that names the finest pitch that fits (the check itself:
:func:`texcad.targets.budget.require_faces_memory`). Lengths in mm, areas in mm^2.

Every CAD adapter then allocates its pixel grid (``area / pitch^2`` pixels), its
outline samples (``length / pitch``) and the texture; this check runs once, ahead of
them all, so that a tiny pitch (1e-6 mm on a 20 mm face) is refused in milliseconds
instead of after gigabytes (issue 27).
"""

from __future__ import annotations

from typing import Any

__all__ = ["face_extent", "OUTLINE_BYTES", "CURVED_GRID"]

#: Peak bytes per outline sample of :func:`texcad.brep.face_segments` (points,
#: segments, their concatenation and the float64 temporaries).
OUTLINE_BYTES = 200.0
#: Pixels of the parameter grid of a curved face per mm^2 of its area at pitch 1 mm:
#: the grid covers the face's parameter rectangle, stretched where the mapping
#: distorts (measured on cylinder and sphere faces: at most 1.3).
CURVED_GRID = 1.5


def face_extent(face: Any) -> tuple[float, float, float, bool]:
    """``(area, grid_area, outline, planar)`` of an OCP face, mm^2 and mm: its area,
    the area its texture grid covers (the bounding rectangle in its plane for a
    planar face, :data:`CURVED_GRID` times the area for a curved one) and the length
    of its boundary."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.BRepTools import BRepTools
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    from .occt import explore

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    area = abs(float(props.Mass()))
    outline = sum(GCPnts_AbscissaPoint.Length_s(BRepAdaptor_Curve(TopoDS.Edge_s(e))) for e in explore(face, TopAbs_EDGE))
    planar = BRepAdaptor_Surface(face).GetType() == GeomAbs_Plane
    if planar:  # the plane's parameters are mm: its UV box is a bounding rectangle in the plane
        u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
        grid = max(area, (u1 - u0) * (v1 - v0))
    else:
        grid = CURVED_GRID * area
    return area, grid, float(outline), planar
