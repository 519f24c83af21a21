"""The one adapter between texcad and OCCT: build123d, CadQuery and OCP objects to
``TopoDS_Shape``, sub-shape exploration and OCP vectors as numpy arrays.

Every part of texcad that takes a CAD object goes through :func:`to_topods`, so a
build123d ``Part``/``Solid``/``Face``/``ShapeList``, a ``BuildPart`` builder, a
CadQuery ``Workplane`` (all the objects on its stack) or ``Shape``, a list of shapes
and a raw ``TopoDS_Shape`` are read the same way everywhere.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = ["to_topods", "explore", "solids_of", "faces_of", "as_array", "compound", "matrix_of", "face_in", "general_fuse",
           "curved_area"]


def compound(shapes: list):
    """A ``TopoDS_Compound`` of OCP shapes (one ``Add`` per shape)."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    comp, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(comp)
    for s in shapes:  # one per shape
        builder.Add(comp, s)
    return comp


def to_topods(obj: Any):
    """The OCP ``TopoDS_Shape`` behind a build123d or CadQuery object.

    A ``BuildPart`` gives its part; a CadQuery ``Workplane`` the shapes on its stack
    (one shape itself, several as a compound); a list, tuple or ``ShapeList`` a
    compound of its items.

    Raises:
        ParameterError: the object holds no shape.
    """
    from OCP.TopoDS import TopoDS_Shape

    if isinstance(obj, TopoDS_Shape):
        return obj
    if hasattr(obj, "part") and type(obj).__name__ == "BuildPart":
        obj = obj.part
    vals = getattr(obj, "vals", None)
    if callable(vals) and hasattr(obj, "objects"):  # CadQuery Workplane
        items = [v.wrapped for v in vals() if isinstance(getattr(v, "wrapped", None), TopoDS_Shape)]
        if not items:
            raise ParameterError("the CadQuery Workplane holds no shape; end the chain with a solid, e.g. .box(...)")
        return items[0] if len(items) == 1 else compound(items)
    if isinstance(obj, (list, tuple)) or type(obj).__name__ == "ShapeList":
        if not obj:
            raise ParameterError("an empty list holds no shape; select at least one")
        items = [to_topods(o) for o in obj]  # one per shape
        return items[0] if len(items) == 1 else compound(items)
    wrapped = getattr(obj, "wrapped", None)
    if isinstance(wrapped, TopoDS_Shape):
        return wrapped
    raise ParameterError(
        f"cannot use a {type(obj).__name__} as a CAD shape; pass a build123d Part/Solid/Face, "
        "a CadQuery Workplane/Shape or an OCP TopoDS_Shape"
    )


def explore(shape, kind) -> list:
    """The sub-shapes of ``kind`` (``TopAbs_FACE``, ``TopAbs_EDGE``...) of an OCP shape,
    in OCCT's order (shared sub-shapes once per use)."""
    from OCP.TopExp import TopExp_Explorer

    out = []
    exp = TopExp_Explorer(shape, kind)
    while exp.More():  # one per sub-shape (faces, edges, solids), never per vertex
        out.append(exp.Current())
        exp.Next()
    return out


def solids_of(shape: Any) -> list:
    """The ``TopoDS_Solid`` objects in a shape."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopoDS import TopoDS

    return [TopoDS.Solid_s(s) for s in explore(to_topods(shape), TopAbs_SOLID)]


def faces_of(shape: Any) -> list:
    """The ``TopoDS_Face`` objects in a shape."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    return [TopoDS.Face_s(s) for s in explore(to_topods(shape), TopAbs_FACE)]


def as_array(v) -> np.ndarray:
    """An OCP ``gp_Pnt``/``gp_Dir``/``gp_Vec``/``gp_XYZ`` as a ``(3,)`` float64 array."""
    return np.array(v.Coord(), dtype=np.float64)


def matrix_of(location: Any) -> np.ndarray:
    """``(3, 4)`` float64 matrix of a build123d ``Location``, an OCP ``gp_Trsf`` /
    ``TopLoc_Location`` or a ``(3, 4)``/``(4, 4)`` array."""
    trsf = getattr(location, "wrapped", location)
    if hasattr(trsf, "Transformation"):
        trsf = trsf.Transformation()
    if hasattr(trsf, "Value"):
        return np.array([[trsf.Value(i, j) for j in range(1, 5)] for i in range(1, 4)], dtype=np.float64)
    m = np.asarray(location, dtype=np.float64)
    if m.shape not in ((3, 4), (4, 4)):
        raise ParameterError(f"a placement is a build123d Location or a (3, 4) / (4, 4) matrix, got {m.shape}")
    return m[:3]


def face_in(shape: Any, face: Any):
    """``face`` as it lies in ``shape``: itself, or the face that took its place when
    an earlier texture rebuilt it (its edges split where a neighbour's tiles end): on
    the same kind of surface, with the same area and centre (within 1e-6 of its
    size). None if there is none."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    def props(f):
        p = GProp_GProps()
        BRepGProp.SurfaceProperties_s(f, p)
        return float(p.Mass()), np.array(p.CentreOfMass().Coord()), BRepAdaptor_Surface(TopoDS.Face_s(f)).GetType()

    face = to_topods(face)
    faces = explore(to_topods(shape), TopAbs_FACE)
    for f in faces:  # the part's faces
        if f.IsSame(face):
            return TopoDS.Face_s(f)
    area, centre, kind = props(face)
    size = np.sqrt(area) or 1.0
    for f in faces:  # the part's faces: the rebuilt one
        if BRepAdaptor_Surface(TopoDS.Face_s(f)).GetType() != kind:
            continue
        a, c, _ = props(f)
        if abs(a - area) <= 1e-6 * area and float(np.linalg.norm(c - centre)) <= 1e-6 * size:
            return TopoDS.Face_s(f)
    return None


def curved_area(shape: Any) -> float:
    """mm^2 of the shape's faces that are not planar (where a tessellation's chords
    leave the surface; OCCT's surface integration, ``BRepGProp``)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    total = 0.0
    for f in explore(to_topods(shape), TopAbs_FACE):  # per face
        if BRepAdaptor_Surface(TopoDS.Face_s(f), False).GetType() != GeomAbs_Plane:
            p = GProp_GProps()
            BRepGProp.SurfaceProperties_s(f, p)
            total += float(p.Mass())
    return total


def general_fuse(groups: list):
    """OCCT's general fuse (``BRepAlgoAPI_BuilderAlgo``, not run in parallel) of the
    ``groups`` of shapes, each group one argument (a compound: its shapes are not
    intersected with each other, only with the other groups'): the builder, whose
    ``Modified`` gives each input's pieces, or None if the fuse failed.

    Pairs of shapes are intersected only where their oriented bounding boxes meet
    (``SetUseOBB``): the axis-aligned boxes of a twisted B-spline side (a real vase's)
    span nearly the whole part, so every wall strip along its rims was intersected
    with every face (about a second of CPU each, on a twisted lofted vase)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_BuilderAlgo
    from OCP.TopTools import TopTools_ListOfShape

    args = TopTools_ListOfShape()
    for g in groups:  # one argument per group
        args.Append(compound(list(g)))
    gf = BRepAlgoAPI_BuilderAlgo()
    gf.SetArguments(args)
    gf.SetRunParallel(False)
    gf.SetUseOBB(True)
    try:
        gf.Build()
    except Exception:  # OCCT raises Standard_Failure from inside the fuse
        return None
    return gf if gf.IsDone() else None
