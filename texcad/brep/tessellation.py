"""OCCT tessellation: a CAD shape as a texcad :class:`~texcad.solid.Mesh`, and a part
as per-face meshes (with each face's own ``(u, v)``) plus the welded whole, checked
closed. Chord errors in mm, angles in radians (OCCT's convention).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import GeometryError, ParameterError
from ..solid import Mesh, to_manifold
from ..solid.weld import grid_ids
from .occt import explore

__all__ = ["shape_to_mesh", "closed_shape_mesh", "part_tessellation", "FaceMesh", "PartMesh", "TESSELLATION"]


def shape_to_mesh(shape: Any, *, tolerance: float = 0.01, angular_tolerance: float = 0.1, refine: bool = True) -> Mesh:
    """Tessellate a build123d/CadQuery/OCP shape into a closed :class:`Mesh`.

    Args:
        shape: build123d ``Shape``, CadQuery ``Workplane``/``Shape`` or ``TopoDS_Shape``.
        tolerance: linear deflection in mm (max distance of the triangles from the
            true surface).
        angular_tolerance: angular deflection in radians.
        refine: OCCT's check of the angle between the normals at a link's ends
            (``AngleInterior``). Off, faces are refined by distance alone (their
            triangles' middles within ``tolerance``): a texture's degree-1 tiles
            kink at every knot, where no link satisfies the angle, and refining
            them down to OCCT's least size took minutes and millions of triangles;
            analytic faces are meshed the same either way.

    Raises:
        ParameterError: the object is not a shape.
        GeometryError: the shape has no faces or does not tessellate.
    """
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.IMeshTools import IMeshTools_Parameters

    from .occt import to_topods

    try:
        topo = to_topods(shape)
    except ParameterError:
        raise ParameterError(
            f"cannot use a {type(shape).__name__} as a base body; pass a build123d Part/Solid, "
            "a CadQuery Workplane/Shape, a texcad Mesh or a manifold3d Manifold"
        ) from None
    params = IMeshTools_Parameters()
    params.Deflection, params.Angle, params.InParallel = tolerance, angular_tolerance, True
    if not refine:
        params.AngleInterior = np.pi  # no link's normals are further apart: distance alone refines
    BRepMesh_IncrementalMesh(topo, params)
    got = _stl_corners(topo) or _node_corners(topo)
    if got is None:
        raise GeometryError("the base shape has no faces to tessellate; is it an empty or 2-D shape?")
    v, f = got
    # Faces are tessellated separately: weld the copies of shared edge vertices.
    inv, first = _welded(v, tolerance * 1e-3)
    f = inv[f]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return Mesh(v[first], f[keep])


def _welded(v: np.ndarray, quantum: float) -> tuple[np.ndarray, np.ndarray]:
    """``(ids (N,), first (K,))``: the points ``v`` (mm) that round to one point of the
    grid of ``quantum`` mm numbered as one (:func:`texcad.solid.weld.grid_ids`, as
    ``np.unique(..., axis=0)`` numbers them), and each number's first point."""
    inv = grid_ids(v, quantum)
    first = np.full(int(inv.max()) + 1 if len(inv) else 0, -1, dtype=np.int64)
    first[inv[::-1]] = np.arange(len(v))[::-1]
    return inv, first


def _stl_corners(topo: Any) -> "tuple[np.ndarray, np.ndarray] | None":
    """The same as :func:`_node_corners`, three corners per triangle, written by
    OCCT's binary STL writer (``StlAPI_Writer``, C++) and read back with numpy: the
    nodes in float32 (as the mesh keeps them), tens of times faster than node by node
    (2.7 M triangles: 9.8 s). None where the writer fails or writes another number of
    triangles than the faces hold (then :func:`_node_corners` reads them)."""
    import os
    import tempfile

    from OCP.BRep import BRep_Tool
    from OCP.StlAPI import StlAPI_Writer
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    from .occt import explore

    count = 0
    for face in explore(topo, TopAbs_FACE):  # one per B-rep face: its triangle count
        poly = BRep_Tool.Triangulation_s(TopoDS.Face_s(face), TopLoc_Location())
        count += 0 if poly is None else poly.NbTriangles()
    if count == 0:
        return None
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "faces.stl")
        writer = StlAPI_Writer()
        writer.ASCIIMode = False
        if not writer.Write(topo, path):
            return None
        data = np.fromfile(path, dtype=np.uint8)
    if len(data) != 84 + 50 * count or int(data[80:84].view("<u4")[0]) != count:
        return None
    corners = data[84:].reshape(count, 50)[:, 12:48].copy().view("<f4").reshape(-1, 3)
    return corners.astype(np.float64), np.arange(3 * count, dtype=np.int64).reshape(-1, 3)


def _node_corners(topo: Any) -> "tuple[np.ndarray, np.ndarray] | None":
    """``(nodes (N, 3) float64 mm, triangles (M, 3))`` of every meshed face of
    ``topo``, outward, face after face (not welded), read node by node through OCP;
    None without a meshed face."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    verts: list[np.ndarray] = []
    tris: list[np.ndarray] = []
    offset = 0
    exp = TopExp_Explorer(topo, TopAbs_FACE)
    while exp.More():  # one iteration per B-rep face, not per vertex
        face = TopoDS.Face_s(exp.Current())
        loc = TopLoc_Location()
        poly = BRep_Tool.Triangulation_s(face, loc)
        exp.Next()
        if poly is None:
            continue
        trsf = loc.Transformation()
        nn, nt = poly.NbNodes(), poly.NbTriangles()
        pts = np.empty((nn, 3), dtype=np.float64)
        for i in range(nn):  # OCP exposes nodes one by one; base bodies are small
            p = poly.Node(i + 1).Transformed(trsf)
            pts[i] = (p.X(), p.Y(), p.Z())
        tri = np.empty((nt, 3), dtype=np.int64)
        for i in range(nt):
            tri[i] = poly.Triangle(i + 1).Get()
        tri -= 1
        if face.Orientation() == TopAbs_REVERSED:
            tri = tri[:, ::-1]
        verts.append(pts)
        tris.append(tri + offset)
        offset += nn
    return (np.concatenate(verts), np.concatenate(tris)) if tris else None


#: mm: chord error of the part's tessellation.
TESSELLATION = 0.01


@dataclass
class FaceMesh:
    """One B-rep face's triangles: ``points`` (N, 3) mm, ``tris`` (M, 3) outward,
    ``uv`` (N, 2) the face's own parameters, ``kind`` (``"plane"``, ``"cone"``...)."""

    face: Any
    points: np.ndarray
    tris: np.ndarray
    uv: np.ndarray
    kind: str


@dataclass
class PartMesh:
    """The part's tessellation: per-face meshes and the welded whole."""

    faces: list
    mesh: Mesh
    face_of_tri: np.ndarray


# ------------------------------------------------------------------------------------------
# Tessellation
# ------------------------------------------------------------------------------------------
def _face_kind(face) -> str:
    from OCP.BRepAdaptor import BRepAdaptor_Surface

    return BRepAdaptor_Surface(face).GetType().name.removeprefix("GeomAbs_").lower()


def _face_triangles(face) -> "FaceMesh | None":
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_REVERSED
    from OCP.TopLoc import TopLoc_Location

    loc = TopLoc_Location()
    poly = BRep_Tool.Triangulation_s(face, loc)
    if poly is None:
        return None
    trsf = loc.Transformation()
    nn, nt = poly.NbNodes(), poly.NbTriangles()
    pts = np.empty((nn, 3))
    uv = np.zeros((nn, 2))
    has_uv = poly.HasUVNodes()
    for i in range(nn):  # OCP exposes nodes one by one (per node of the coarse mesh)
        p = poly.Node(i + 1).Transformed(trsf)
        pts[i] = (p.X(), p.Y(), p.Z())
        if has_uv:
            q = poly.UVNode(i + 1)
            uv[i] = (q.X(), q.Y())
    tri = np.array([poly.Triangle(i + 1).Get() for i in range(nt)], dtype=np.int64).reshape(-1, 3) - 1
    if face.Orientation() == TopAbs_REVERSED:
        tri = tri[:, ::-1]
    return FaceMesh(face, pts, tri, uv, _face_kind(face))


def closed_shape_mesh(shape: Any, *, tolerance: float = 0.01, angular_tolerance: float = 0.1, refine: bool = True) -> Mesh:
    """:func:`shape_to_mesh` (``tolerance`` mm, ``angular_tolerance`` radians, ``refine``), or
    where that is not closed (OCCT's mesher leaves some faces of some files open, e.g.
    a cone bounded by one wire of 75 edges meshed as 12 triangles) the healed
    tessellation texcad textures parts with (:func:`part_tessellation` at
    ``tolerance`` and ``angular_tolerance``: finer, cleaned, welded, split at 90
    degrees, sewn), and last texcad's mesh repair (:func:`texcad.solid.repair_closed`:
    a solid of a heat sink enclosure STEP meshed with an edge in four triangles and
    two wound the wrong way, which manifold3d takes but no STL or 3MF writer does), so that a closed part is
    not shown, reported or refused as open. A shape that stays open comes back as
    OCCT meshed it. Closed means both: every edge in two triangles wound opposite
    ways (``Mesh.is_watertight``) and a valid manifold3d solid."""
    from .occt import to_topods

    mesh = shape_to_mesh(shape, tolerance=tolerance, angular_tolerance=angular_tolerance, refine=refine)
    if _closed(mesh):
        return mesh
    try:
        healed = part_tessellation(to_topods(shape), tolerance, angular_tolerance).mesh
    except GeometryError:
        healed = mesh
    if _closed(healed):
        return healed
    return _repaired(healed) or _repaired(mesh) or mesh


def _closed(mesh: Mesh) -> bool:
    """Every edge of ``mesh`` in two triangles wound opposite ways, and manifold3d
    takes it as a solid."""
    if not mesh.is_watertight:
        return False
    try:
        to_manifold(mesh)
    except GeometryError:
        return False
    return True


def _repaired(mesh: Mesh) -> "Mesh | None":
    """``mesh`` through :func:`texcad.solid.repair_closed` (merged, cleaned, wound
    outward), or None where that leaves no closed mesh."""
    from ..errors import TexcadError
    from ..solid import repair_closed

    try:
        v, f, _ = repair_closed(mesh.vertices, mesh.faces)
    except TexcadError:
        return None
    out = Mesh(v.astype(np.float32), f.astype(np.uint32))
    return out if _closed(out) else None


def part_tessellation(topo, tolerance: float = TESSELLATION, angle: float = 0.1) -> PartMesh:
    """Tessellate ``topo`` (OCCT, ``tolerance`` mm chord error, ``angle`` radians) into per-face meshes
    and one welded mesh; checked closed (manifold3d) and healed if needed, in order:
    a finer tessellation; the same after dropping every triangulation the file
    carried (``BRepTools::Clean``: a STEP file's own, possibly open, meshes are
    otherwise kept); a wider weld; the curved faces split into pieces of at most
    90 degrees (``ShapeUpgrade_ShapeDivideAngle``: OCCT's mesher leaves some whole
    periodic faces, e.g. a cone under a knurl's 72 flutes, with their boundary
    nodes but hardly any triangles); and last the faces sewn along their edges
    (``BRepBuilderAPI_Sewing``, so that neighbours share one edge discretization).
    ``faces[k]`` is always the part's own face ``k`` (its pieces' triangles
    together, their ``(u, v)`` moved by whole periods onto the face's own domain:
    :func:`_in_domain`), so face numbers keep meaning what ``texcad faces`` lists.

    Raises:
        GeometryError: no watertight tessellation could be made; the message names
            the faces with open edges and their count.
    """
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    last, pm = None, None
    attempts = ((tolerance, 1e-5, ""), (tolerance / 3, 1e-5, ""), (tolerance / 3, 1e-5, "clean"),
                (tolerance / 3, 1e-3, "clean"), (tolerance, 1e-5, "split"), (tolerance / 3, 1e-3, "sew"))
    own = [TopoDS.Face_s(f) for f in explore(topo, TopAbs_FACE)]
    for tol, weld, how in attempts:  # healing attempts
        shape, whose = topo, None
        if how == "sew":
            shape, whose = _sewn(topo, own, max(10 * tol, 1e-3))
        elif how == "split":
            shape, whose = _split(topo, own)
        if how:
            BRepTools.Clean_s(shape)
        BRepMesh_IncrementalMesh(shape, tol, False, angle, True)
        fms = [_face_triangles(TopoDS.Face_s(f)) for f in explore(shape, TopAbs_FACE)]
        if whose is not None:  # the pieces' triangles, for the part's own faces
            fms = _own_faces(fms, whose, own)
        pm = _weld(fms, weld)
        try:
            to_manifold(pm.mesh)
            return pm
        except GeometryError as e:
            last = e
    raise GeometryError(
        f"OCCT's tessellation of the part is not a closed solid even after healing (finer, re-meshed, welded and sewn: "
        f"{_open_faces(pm)}); the part's faces do not meet along shared edges: sew them in the CAD program "
        "(e.g. 'stitch'/'knit' surfaces, or export the solid as one closed body) or texture an STL of the part instead"
    )


def _sewn(topo, own: list, tol: float) -> "tuple[Any, list[int]]":
    """``topo`` sewn along its edges (``tol`` mm), and for each face of the result
    (in its face order) the index of the part's own face it came from."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing

    sew = BRepBuilderAPI_Sewing(tol)
    sew.Add(topo)
    sew.Perform()
    made = [sew.ModifiedSubShape(f) if sew.IsModifiedSubShape(f) else f for f in own]
    return sew.SewedShape(), _whose(sew.SewedShape(), [[m] for m in made])


def _split(topo, own: list) -> "tuple[Any, list[int]]":
    """``topo`` with its curved faces split into pieces of at most 90 degrees
    (``ShapeUpgrade_ShapeDivideAngle``), and for each face of the result the index
    of the part's own face it is a piece of."""
    from OCP.ShapeUpgrade import ShapeUpgrade_ShapeDivideAngle
    from OCP.TopAbs import TopAbs_FACE

    div = ShapeUpgrade_ShapeDivideAngle(math.pi / 2, topo)
    div.Perform()
    ctx = div.GetContext()
    made = [list(explore(ctx.Apply(f), TopAbs_FACE)) for f in own]  # a face, or its pieces (as rebuilt in the result)
    return div.Result(), _whose(div.Result(), made)


def _whose(shape, made: "list[list]") -> "list[int]":
    """For each face of ``shape``: the index ``k`` whose ``made[k]`` holds it (-1: none)."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopTools import TopTools_IndexedMapOfShape

    index = TopTools_IndexedMapOfShape()
    for f in explore(shape, TopAbs_FACE):  # one per face of the result
        index.Add(f)
    whose = [-1] * index.Extent()
    for k, pieces in enumerate(made):  # per own face
        for p in pieces:
            i = index.FindIndex(p)
            if i > 0:
                whose[i - 1] = k
    return whose


def _own_faces(fms: list, whose: "list[int]", own: list) -> list:
    """Per own face, one :class:`FaceMesh` of its pieces' triangles (``None`` if no
    piece was meshed; a face nothing came from then shows as open)."""
    out = []
    for k, face in enumerate(own):  # per own face: a few pieces at most
        mine = [fm for fm, w in zip(fms, whose) if w == k and fm is not None]
        if not mine:
            out.append(None)
            continue
        offs = np.cumsum([0] + [len(fm.points) for fm in mine[:-1]])
        out.append(FaceMesh(face, np.concatenate([fm.points for fm in mine]),
                            np.concatenate([fm.tris + o for fm, o in zip(mine, offs)]),
                            np.concatenate(_in_domain(face, [fm.uv for fm in mine])), mine[0].kind))
    return out


def _in_domain(face, uvs: list) -> list:
    """The pieces' ``(u, v)`` ``uvs`` (each ``(n, 2)``) on ``face``'s own domain.

    A piece of a face on a periodic surface (period ``T`` in u or v) carries its
    parameters in the range OCCT picked for the piece (``ShapeUpgrade`` and the
    sewing put them in ``[0, T)``), while the face's own domain may start anywhere
    (a STEP reader's cylinder in ``u`` ``[-pi, pi]`` or ``[pi, 3pi]``): the same
    point at ``u`` and ``u + kT``. Each piece is moved by the whole number of
    periods ``k = round((m_piece - m_face) / T)`` that brings the middle of its
    range ``m_piece`` nearest the middle of the face's ``m_face`` (a piece lies
    inside its face, so ``|m_piece - m_face| < T / 2`` once moved)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepTools import BRepTools

    ad = BRepAdaptor_Surface(face, False)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    axes = [(0, ad.IsUPeriodic() and ad.UPeriod(), 0.5 * (u0 + u1)), (1, ad.IsVPeriodic() and ad.VPeriod(), 0.5 * (v0 + v1))]
    out = []
    for uv in uvs:  # one per piece
        uv = np.array(uv, dtype=np.float64)
        for axis, period, mid in axes:  # u, v
            if period and len(uv):
                k = np.round((0.5 * (uv[:, axis].min() + uv[:, axis].max()) - mid) / period)
                uv[:, axis] -= k * period
        out.append(uv)
    return out


def _open_faces(pm: "PartMesh | None") -> str:
    """Which faces (index in the part's face order) have open or non-manifold edges
    in the tessellation ``pm``, and how many such edges."""
    if pm is None:
        return "no triangles"
    f = pm.mesh.faces.astype(np.int64)
    a, b = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(a, b) * (int(f.max()) + 1) + np.maximum(a, b)
    uniq, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
    bad = cnt[inv] != 2
    faces = np.unique(pm.face_of_tri[np.repeat(np.arange(len(f)), 3)[bad]])
    shown = ", ".join(map(str, faces[:12].tolist())) + (" ..." if len(faces) > 12 else "")
    return f"{int((cnt != 2).sum())} open or non-manifold edges on faces {shown} (texcad faces PART.step numbers them)"


def _weld(fms: list, weld: float) -> PartMesh:
    verts, tris, fid, offs = [], [], [], []
    off = 0
    for k, fm in enumerate(fms):  # per B-rep face
        offs.append(off)
        if fm is None:
            continue
        verts.append(fm.points)
        tris.append(fm.tris + off)
        fid.append(np.full(len(fm.tris), k))
        off += len(fm.points)
    if not tris:
        raise GeometryError("the part has no faces to tessellate")
    v = np.concatenate(verts)
    f = np.concatenate(tris)
    inv, first = _welded(v, weld)
    f = inv[f]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return PartMesh(fms, Mesh(v[first].astype(np.float32), f[keep].astype(np.uint32)), np.concatenate(fid)[keep])


