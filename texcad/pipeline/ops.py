"""CAD operations on a textured part, checked: the same boolean on texcad's mesh
(manifold3d, guaranteed manifold) and, when the B-rep is asked for, on the B-rep
(OCCT), which must then agree with the mesh.

A boolean that OCCT gets wrong (it can return a "valid" solid that lost the cut) raises
:class:`texcad.GeometryError` instead of giving a silently wrong part.
"""

from __future__ import annotations

from typing import Any

from ..errors import GeometryError, ParameterError
from ..solid import Mesh, check_shape, from_manifold, shape_to_mesh, to_manifold, to_topods, volume

__all__ = ["cad_op", "OPS", "OP_VOLUME_TOLERANCE"]

#: The operations: name -> (manifold3d operator, the OCCT algorithm's name).
OPS = ("cut", "fuse", "common")
#: Largest relative difference between the B-rep's and the mesh's volume after an
#: operation (the tool's tessellation, 0.01 mm, and the texture's bilinear term).
OP_VOLUME_TOLERANCE = 2e-3


def _is_textured(obj: Any) -> bool:
    """A :class:`texcad.Textured` (checked on the type: its meshes are made lazily)."""
    return hasattr(type(obj), "texture_mesh") and hasattr(type(obj), "base_mesh")


def _tool_mesh(tool: Any) -> Mesh:
    if _is_textured(tool):
        return tool.mesh
    if isinstance(tool, Mesh):
        return tool
    return shape_to_mesh(tool, tolerance=0.005)


def _mesh_op(a: Mesh, b: Mesh, op: str) -> Mesh:
    ma, mb = to_manifold(a), to_manifold(b)
    out = {"cut": lambda: ma - mb, "fuse": lambda: ma + mb, "common": lambda: ma ^ mb}[op]()
    return from_manifold(out)


def _occt_op(shape, tool, op: str):
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common, BRepAlgoAPI_Cut, BRepAlgoAPI_Fuse
    from OCP.TopTools import TopTools_ListOfShape

    algo = {"cut": BRepAlgoAPI_Cut, "fuse": BRepAlgoAPI_Fuse, "common": BRepAlgoAPI_Common}[op]()
    args, tools = TopTools_ListOfShape(), TopTools_ListOfShape()
    args.Append(shape)
    tools.Append(tool)
    algo.SetArguments(args)
    algo.SetTools(tools)
    algo.SetRunParallel(True)
    algo.Build()
    if not algo.IsDone():
        raise GeometryError(f"OCCT's {op} of the textured B-rep failed; the mesh result is fine: write STL or 3MF")
    return algo.Shape()


def _checked(shape, mesh: Mesh, op: str, bodies: int):
    chk = check_shape(shape)
    if not chk["valid"] or chk["solids"] != bodies:
        raise GeometryError(
            f"OCCT's {op} of the textured B-rep gave {chk['solids']} solid(s) (valid: {chk['valid']}) where the mesh "
            f"has {bodies}; the mesh result is fine: write STL or 3MF, or make the cut before texturing"
        )
    vb, vm = volume(shape), float(mesh.volume)
    if abs(vb - vm) > OP_VOLUME_TOLERANCE * abs(vm):
        raise GeometryError(
            f"OCCT's {op} of the textured B-rep encloses {vb:.1f} mm3 but the same {op} on texcad's mesh "
            f"{vm:.1f} mm3 (OCCT lost or kept material it should not); the mesh result is fine: write STL or 3MF, "
            "or make the cut before texturing"
        )
    return shape


def cad_op(part: Any, tool: Any, op: str) -> Any:
    """``part`` cut by, fused with or intersected with ``tool`` (a build123d /
    CadQuery / OCP shape, a :class:`~texcad.solid.Mesh` or another
    :class:`Textured`), mm.

    The mesh result is manifold3d's boolean of the fused meshes (exact on the
    triangles); the B-rep result (made on first use of ``.shape``) is OCCT's boolean of
    the textured B-rep with the tool's shape, and must have as many solids as the
    mesh and enclose its volume within :data:`OP_VOLUME_TOLERANCE`.

    Raises:
        ParameterError: unknown operation or tool.
        GeometryError: the operation leaves nothing (or, on ``.shape``, OCCT's result
            disagrees with the mesh).
    """
    if op not in OPS:
        raise ParameterError(f"unknown operation {op!r}; use one of {', '.join(OPS)}")
    tool_mesh = _tool_mesh(tool)
    mesh = _mesh_op(part.mesh, tool_mesh, op)
    if mesh.num_triangles == 0:
        raise GeometryError(f"the {op} leaves nothing of the part; check the tool's placement (mm)")
    texture_op = "cut" if op == "fuse" else op
    base_op = op
    bodies = len(to_manifold(mesh).decompose())
    info = dict(part.info, operations=[*part.info.get("operations", []), op])

    def texture_mesh() -> Mesh:
        return _mesh_op(part.texture_mesh, tool_mesh, texture_op)

    def base_mesh() -> Mesh:
        return _mesh_op(part.base_mesh, tool_mesh, base_op)

    shape = None
    if part._shape is not None and not isinstance(tool, Mesh):
        def shape():
            other = tool.shape if _is_textured(tool) else to_topods(tool)
            return _checked(_occt_op(part.shape, other, op), mesh, op, bodies)

    return type(part)(
        mesh=mesh,
        texture_mesh=texture_mesh,
        base_mesh=base_mesh,
        shape=shape,
        heightmap=part.heightmap,
        limits=part.limits,
        height_limits=part.height_limits,
        distortion=part.distortion,
        info=info,
        kind=part.kind,
    )
