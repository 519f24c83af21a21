"""Solids: CAD shapes to meshes, and the manifold3d union of texture and base.

This stage replaces the paper's Rhino/Grasshopper sweep (section 2.3): the textured
slab from :mod:`texcad.solid` is unioned onto the base body with manifold3d, whose
booleans are guaranteed to return an oriented 2-manifold.

A *base* can be a build123d ``Shape`` (``Part``, ``Solid``, ``Compound``), a CadQuery
``Workplane`` or ``Shape`` (both wrap the same OCP ``TopoDS_Shape``), a raw
``TopoDS_Shape``, a :class:`~texcad.solid.Mesh`, or a ``manifold3d.Manifold``.
"""

from __future__ import annotations

from typing import Any, Iterable

import numpy as np

from ..errors import GeometryError, ParameterError
from .mesh import Mesh

__all__ = ["shape_to_mesh", "to_manifold", "from_manifold", "fuse", "retain_freed_memory"]


def shape_to_mesh(shape: Any, *, tolerance: float = 0.01, angular_tolerance: float = 0.1) -> Mesh:
    """Tessellate a build123d/CadQuery/OCP shape into a closed :class:`Mesh`.

    Args:
        shape: build123d ``Shape``, CadQuery ``Workplane``/``Shape`` or ``TopoDS_Shape``.
        tolerance: linear deflection in mm (max distance of the triangles from the
            true surface).
        angular_tolerance: angular deflection in radians.

    Raises:
        ParameterError: the object is not a shape.
        GeometryError: the shape has no faces or does not tessellate.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    from .occt import to_topods

    try:
        topo = to_topods(shape)
    except ParameterError:
        raise ParameterError(
            f"cannot use a {type(shape).__name__} as a base body; pass a build123d Part/Solid, "
            "a CadQuery Workplane/Shape, a texcad Mesh or a manifold3d Manifold"
        ) from None
    BRepMesh_IncrementalMesh(topo, tolerance, False, angular_tolerance, True)
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
    if not tris:
        raise GeometryError("the base shape has no faces to tessellate; is it an empty or 2-D shape?")
    v = np.concatenate(verts)
    f = np.concatenate(tris)
    # Faces are tessellated separately: weld the copies of shared edge vertices.
    _, inv = np.unique(np.round(v / (tolerance * 1e-3)).astype(np.int64), axis=0, return_inverse=True)
    first = np.full(inv.max() + 1, -1, dtype=np.int64)
    first[inv[::-1]] = np.arange(len(v))[::-1]
    f = inv.ravel()[f]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return Mesh(v[first], f[keep])


def to_manifold(obj: Any):
    """A ``manifold3d.Manifold`` from a Mesh, a CAD shape or a Manifold.

    Raises:
        GeometryError: the mesh is not an oriented, closed 2-manifold.
    """
    import manifold3d as m3d

    if isinstance(obj, m3d.Manifold):
        return obj
    mesh = obj if isinstance(obj, Mesh) else shape_to_mesh(obj)
    man = m3d.Manifold(m3d.Mesh(vert_properties=mesh.vertices, tri_verts=mesh.faces))
    status = man.status()
    if status != m3d.Error.NoError:
        raise GeometryError(
            f"the mesh is not a closed, oriented solid (manifold3d: {status.name}); "
            "check that the base body is a closed solid"
        )
    return man


def from_manifold(man) -> Mesh:
    """A :class:`Mesh` (float32 vertices, uint32 faces) from a ``manifold3d.Manifold``."""
    out = man.to_mesh()
    # manifold3d hands out read-only views; copy (once) into arrays we own.
    props = np.asarray(out.vert_properties)
    v = np.array(props if props.shape[1] == 3 else props[:, :3], dtype=np.float32, order="C")
    mesh = Mesh(v, np.asarray(out.tri_verts).astype(np.uint32))
    # manifold3d guarantees an oriented closed 2-manifold: record it rather than
    # re-deriving it from a million edges (tests check it independently).
    mesh.__dict__["is_watertight"] = True
    return mesh


def fuse(base: Any, *textures: Any) -> Mesh:
    """Union textured slabs onto a base body with manifold3d.

    Args:
        base: the part the texture sits on (see module docstring for types).
        *textures: watertight texture slabs (:class:`Mesh` or Manifold) whose
            bottoms lie inside the base body.

    Returns:
        The fused solid as a watertight :class:`Mesh` in mm.

    Raises:
        GeometryError: an input is not a closed solid, or the union is empty.

    Most of the time of a large union goes to manifold3d building its half-edge
    structure for the slab and for the result (an 800 x 800 px slab: about 1.3 s on
    two cores); slabs from :func:`texcad.solid.heightfield_slab` cross the base's face
    with only a few edges, so the boolean itself cuts little. One-shot processes save
    a further ~0.3 s with :func:`retain_freed_memory`.
    """
    import manifold3d as m3d

    parts = [to_manifold(base), *(to_manifold(t) for t in textures)]
    result = m3d.Manifold.batch_boolean(parts, m3d.OpType.Add) if len(parts) > 1 else parts[0]
    if result.status() != m3d.Error.NoError or result.is_empty():
        raise GeometryError(f"the union of texture and base failed (manifold3d: {result.status().name})")
    return from_manifold(result)


def retain_freed_memory() -> bool:
    """Let this process's C allocator reuse freed memory instead of returning it (glibc).

    A union of an 800 x 800 px slab makes manifold3d allocate and free arrays of tens
    of MB again and again. By default glibc serves every such array from fresh pages
    (``mmap``) and unmaps it when freed, so the kernel faults in and zeroes the pages
    anew each time: about 0.3 s of CPU per 800 x 800 px job, a quarter of it spent in
    the kernel. This sets ``M_MMAP_MAX = 0`` and a 2 GB ``M_TRIM_THRESHOLD``
    (``mallopt``): freed blocks stay in the heap and the next array reuses them. The
    process then keeps its peak memory until it exits, so this is for one-shot
    processes (the CLI, benchmarks), not for long-running hosts. Without code, the
    same is ``GLIBC_TUNABLES=glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=2147483647``
    in the environment.

    Returns:
        True if the allocator was tuned, False where the C library is not glibc (or
        refused the setting); nothing changes then.
    """
    import ctypes

    try:
        libc = ctypes.CDLL(None)
        libc.gnu_get_libc_version  # noqa: B018 (glibc only: musl, macOS, Windows differ)
        mallopt = libc.mallopt
    except (OSError, AttributeError, TypeError):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    m_trim_threshold, m_mmap_max = -1, -4  # <malloc.h>
    return bool(mallopt(m_trim_threshold, 2**31 - 1)) and bool(mallopt(m_mmap_max, 0))


def solids(meshes: Iterable[Mesh]) -> int:  # pragma: no cover - helper for reports
    """Number of separate shells in the union of ``meshes``."""
    return sum(len(to_manifold(m).decompose()) for m in meshes)
