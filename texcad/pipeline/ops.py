"""CAD operations on a textured part, checked: the same operation on texcad's mesh
(manifold3d, guaranteed manifold) and, when the B-rep is asked for, on the B-rep
(OCCT), which must then agree with the mesh.

* ``textured - tool``, ``+``, ``&`` (:func:`cad_op`): manifold3d's boolean of the
  fused mesh, and OCCT's boolean of the textured B-rep. OCCT's boolean misses the
  intersection of a tool with a degree-1 B-spline face of many cells (it then returns
  a "valid" solid that kept the material, or two solids for a union), so the B-rep is
  rebuilt for the operation with tiles of at most :data:`texcad.brep.FINE` x
  :data:`~texcad.brep.FINE` cells where the tool's bounding box meets the texture
  (planar faces; measured: 20 of 20 random cuts and bosses right, against 17 of 20
  with 4- to 24-cell tiles; on open profiles such as the sine sample, where the
  grid's poles lie in the tool's bounding box), and the operations made so far are
  replayed on it. If OCCT's result still disagrees with the mesh, the B-rep is made
  again with another tile size under the tool (:data:`FINE_TRIES`) before
  ``GeometryError`` is raised.
  A single curved face textured on its own ``(u, v)`` (cone, sphere, torus, revolved,
  B-spline; :func:`texcad.brep.uv_textured_solid`) is one large face instead, whose
  boolean OCCT misses (a textured torus kept the hole's material): there the
  operations are made on the *plain* part, the face followed through OCCT's history
  and textured again (:func:`_uv_replay`; the hole's wall stays plain), and OCCT's
  boolean of the textured B-rep is tried only if that disagrees with the mesh.
* :func:`fillet` (``Textured.fillet``): OCCT's fillet of the textured B-rep (faces
  on their own ``(u, v)``: of the plain part, textured again); the mesh is the
  textured mesh with what the fillet takes off the *untextured* part cut away and what
  it adds united (OCCT's exact difference, tessellated at 5 um; manifold3d).
* :func:`mirror` (``Textured.mirrored``): meshes and B-rep mirrored about a plane.
* :func:`pattern` (``Textured.patterned``): copies at a list of placements (a linear
  or polar pattern), which must not overlap: the meshes side by side, the B-rep a
  compound of transformed copies (geometry and tile meshes copied).

Every B-rep result must be valid (``BRepCheck_Analyzer``), have as many solids as the
mesh and enclose the mesh's volume within :data:`OP_VOLUME_TOLERANCE`, integrated by
:func:`texcad.brep.volume` (exact on the untrimmed tiles, OCCT's Gauss integration on
the few fine tiles a tool trimmed: 2e-5 from the mesh for a hole in the demo plate;
OCCT's adaptive :func:`texcad.brep.occt_volume` at 1e-4 agrees as closely but takes
seconds per hundred tiles); otherwise :class:`texcad.GeometryError` is raised instead
of giving a silently wrong part. A boolean or a fillet must also change the B-rep's
volume as it changes the mesh's, within :data:`OP_CHANGE_TOLERANCE` of the change
plus the mesh's tolerance over the tool's area: on a large part a small hole that
OCCT left out of the B-rep is within 0.1 % of the whole, not of the hole.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..errors import GeometryError, ParameterError
from ..solid import Mesh, from_manifold, to_manifold
from ..solid.boolean import welded_mesh
from ..brep.occt import matrix_of
from ..brep.occt import solids_of
from ..brep.uvfaces import uv_face_pairs, uv_retextured_solid
from ..brep import FINE, occt_boolean, check_shape, shape_to_mesh, to_topods, transformed_shape, volume

__all__ = ["cad_op", "fillet", "mirror", "pattern", "OPS", "OP_VOLUME_TOLERANCE"]

#: The boolean operations.
OPS = ("cut", "fuse", "common")
#: Largest relative difference between the B-rep's volume and the mesh's after an
#: operation: 0.1 %.
OP_VOLUME_TOLERANCE = 1e-3
#: Largest relative difference between the operation's change of the B-rep's volume
#: and of the mesh's (beyond the mesh's tolerance over the tool's area): 5 %
#: (measured on the tests' holes, cuts, bosses and fillets on every face kind: at most
#: 1.5 %; a hole OCCT left out: 100 %).
OP_CHANGE_TOLERANCE = 0.05
#: mm: tolerance of the tessellation of tools and filleted parts for the mesh side.
TOOL_TOLERANCE = 0.005


def _is_textured(obj: Any) -> bool:
    """A :class:`texcad.Textured` (checked on the type: its meshes are made lazily)."""
    return hasattr(type(obj), "texture_mesh") and hasattr(type(obj), "base_mesh")


def _as_mesh_tool(tool: Any) -> Any:
    """A ``trimesh.Trimesh`` or ``manifold3d.Manifold`` tool as a texcad :class:`Mesh`
    (mm); any other tool as it is."""
    import manifold3d as m3d

    if isinstance(tool, m3d.Manifold):
        return from_manifold(tool)
    if type(tool).__name__ == "Trimesh" and hasattr(tool, "faces"):
        return Mesh(np.asarray(tool.vertices), np.asarray(tool.faces))
    return tool


def _tool_mesh(tool: Any) -> Mesh:
    if _is_textured(tool):
        return tool.mesh
    if isinstance(tool, Mesh):
        return tool
    try:
        return shape_to_mesh(tool, tolerance=TOOL_TOLERANCE)
    except ParameterError:
        raise ParameterError(f"cannot use a {type(tool).__name__} as a tool; pass a build123d / CadQuery / OCP shape, "
                             "a texcad Mesh, a trimesh.Trimesh or a manifold3d Manifold (mm)") from None


def _mesh_op(a: Mesh, b: Mesh, op: str) -> Mesh:
    ma, mb = to_manifold(a), to_manifold(b)
    out = {"cut": lambda: ma - mb, "fuse": lambda: ma + mb, "common": lambda: ma ^ mb}[op]()
    return welded_mesh(out)  # points a cut left apart at one position merged (texcad.solid.boolean.welded)


# -- placements -----------------------------------------------------------------------------
def _m4(m: np.ndarray) -> np.ndarray:
    return np.vstack([np.asarray(m, np.float64)[:3], [0.0, 0.0, 0.0, 1.0]])


def _trsf(m: np.ndarray):
    from OCP.gp import gp_Trsf

    t = gp_Trsf()
    t.SetValues(*[float(m[i, j]) for i in range(3) for j in range(4)])
    return t


def _apply(shape, m: np.ndarray):
    """``shape`` moved (rigid) or mirrored by the ``(3, 4)`` matrix ``m``."""
    from OCP.TopLoc import TopLoc_Location

    if np.allclose(m, np.eye(3, 4), rtol=0, atol=1e-12):
        return shape
    if np.linalg.det(m[:, :3]) > 0:
        return shape.Moved(TopLoc_Location(_trsf(m)))
    return transformed_shape(shape, m)  # a copy with its tiles' meshes (STEP keeps them)


def _history(part: Any) -> dict:
    """How to rebuild ``part``'s B-rep: ``make(fine)`` (the textured part in its own
    frame, or None), ``shape`` (used when ``make`` is None), ``steps`` (operations in
    that frame), ``to_world`` (that frame to the part's unplaced frame), the face
    frame and pitch for the fine tiles, ``base`` (the untextured part); for a part
    whose B-rep cannot be made, ``no_brep`` (why), raised by :func:`_replay`."""
    hist = part.history
    if hist is not None:
        return hist
    try:
        shape = part.shape  # builds and checks the B-rep
    except GeometryError as exc:  # no B-rep: the operations still run on the mesh
        return {"make": None, "shape": None, "no_brep": str(exc), "steps": [], "to_world": np.eye(3, 4), "frame": None,
                "base": part.base_shape}
    placement = part.placement
    unplaced = _apply(shape, np.linalg.inv(_m4(placement))[:3]) if not np.allclose(placement, np.eye(3, 4)) else shape
    info = part.info
    frame = part.fine_frame()  # the adapter's frame for fine tiles under a tool
    if frame is None and info.get("face") == "extrusion":  # open profiles and closed bands alike
        frame = ("box", 2.0 * float(max(part.heightmap.pitch)))  # fine tiles where the grid's poles lie in the tool's box
    elif frame is None and "fine_frame" in info:  # a planar face done by the general method (engraved, centred)
        o, ex, ey, pitch = info["fine_frame"]
        frame = (np.asarray(o), np.asarray(ex), np.asarray(ey), float(pitch))
    make = part.brep if frame is not None else None
    on = part.stages.adapter.textured_on(part.stages)  # chained: the earlier result's B-rep
    uv = uv_face_pairs(on, unplaced) if make is None and on is not None else None
    return {"make": make, "shape": unplaced, "steps": [], "to_world": np.eye(3, 4), "frame": frame, "base": part.base_shape,
            "uv_base": on, "offset": _offset(part, shape), "uv": uv,
            "patches": _patches(part) if make is None and uv is None else None}


def _patches(part: Any) -> list | None:
    """The textures of faces flattened together (the any-faces adapter's patches of
    several faces, :func:`texcad.brep.bands.patch_solid`), to be put again on the
    plain part after an operation: ``[{"faces", "points", "normals", "heights",
    "cells", "wrap", "signed"}, ...]`` (faces of ``part.base_shape``; grids mm), or
    None when the result holds any other texture or is chained."""
    st = part.stages
    if st is None or st.placement.previous is not None:
        return None
    reliefs, pm = getattr(st.fused.data, "patches", None), getattr(st.placement.data, "mesh", None)
    if not reliefs or pm is None or any(r.face is not None for r in reliefs):
        return None
    return [{"faces": [pm.faces[i].face for i in r.faces], "points": r.grid.points, "normals": r.grid.normals,
             "heights": r.h_top if r.fused_top is None else r.fused_top, "cells": r.cells, "wrap": bool(r.grid.wrap_y),
             "signed": bool(r.signed)} for r in reliefs]


def _offset(part: Any, shape) -> float:
    """mm^3 the part's checked B-rep encloses beyond its mesh (see :func:`_checked`)."""
    vb = part.info.get("brep_volume")
    return (float(vb) if vb is not None else volume(shape)) - float(part.mesh.volume)


def _world(part: Any, hist: dict) -> np.ndarray:
    """History frame -> world, where the part is now (``(3, 4)``)."""
    return (_m4(part.placement) @ _m4(hist["to_world"]))[:3]


def _fine_rect(tool_local, frame) -> tuple:
    """The tool's bounding box seen in the face frame ``(x0, x1, y0, y1)`` mm, two
    pixels wider (an open profile's frame ``("box", margin)``: the box itself, ``(lo
    (3,), hi (3,))`` mm, ``margin`` wider)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    box = Bnd_Box()
    BRepBndLib.Add_s(tool_local, box)
    lo, hi = np.array(box.CornerMin().Coord()), np.array(box.CornerMax().Coord())
    if isinstance(frame[0], str):  # ("box", margin)
        return (lo - frame[1], hi + frame[1])
    corners = np.array([[(lo, hi)[i][0], (lo, hi)[j][1], (lo, hi)[k][2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    o, ex, ey, pitch = frame
    u, v = (corners - o) @ ex, (corners - o) @ ey
    m = 2.0 * pitch
    return (float(u.min() - m), float(u.max() + m), float(v.min() - m), float(v.max() + m))


#: Tile sizes (cells a side) under a tool, tried in turn until OCCT's boolean agrees
#: with the mesh: OCCT's boolean sometimes misses the intersection for one tiling and
#: not for another (measured: a 4 mm hole through the sine sample at 0.125 mm kept its
#: material with 2- and 4-cell tiles, not with 1 or 3).
FINE_TRIES = (FINE, 3, 1)


def _replay(hist: dict, cells: int | None = None):
    """The B-rep of a history, in its frame: the textured part (with fine tiles of
    ``cells`` cells a side, default :data:`texcad.brep.FINE`, under every tool) and
    the operations, in order."""
    if hist.get("no_brep"):
        raise GeometryError(
            f"{hist['no_brep']} (the textured part had no B-rep, so neither has the result of CAD operations on it; "
            "its mesh is exact: export STL or 3MF)"
        )
    if hist["make"] is not None:
        rects = [tuple(s["fine"]) + ((cells,) if cells else ()) for s in hist["steps"] if s.get("fine") is not None]
        shape = hist["make"](fine=rects)
    else:
        shape = hist["shape"]
    for step in hist["steps"]:  # one per operation so far
        if step["op"] == "fillet":
            shape = _occt_fillet(shape, step["edges"], step["radius"])
        else:
            shape = occt_boolean(shape, step["tool"], step["op"])
    return shape


def _uv_replay(hist: dict):
    """The B-rep of a history whose textured faces lie on their own ``(u, v)``
    (:func:`texcad.brep.uvfaces.uv_face_pairs`), as parametric CAD makes it: the
    operations on the plain part, each textured face followed through OCCT's history
    (``Modified``, ``IsDeleted``), and the texture put again on what is left of it
    (:func:`texcad.brep.uvfaces.uv_retextured_solid`: a hole's wall stays plain)."""
    shape, pieces = _followed(hist.get("uv_base", hist["base"]), [[face] for face, _, _ in hist["uv"]], hist["steps"])
    return uv_retextured_solid(shape, [(p, tex, grid) for p, (_, tex, grid) in zip(pieces, hist["uv"])])


def _followed(shape, pieces: list, steps: list) -> tuple:
    """The operations ``steps`` made on the plain ``shape``, and each list of its
    faces in ``pieces`` followed through OCCT's history (``Modified``,
    ``IsDeleted``): ``(shape, pieces)``."""
    for step in steps:  # one per operation so far
        if step["op"] == "fillet":
            shape, algo = _occt_fillet(shape, step["edges"], step["radius"], maker=True)
        else:
            shape, algo = occt_boolean(shape, step["tool"], step["op"], maker=True)
        followed = []
        for faces in pieces:  # one per textured face or patch
            now = []
            for f in faces:  # the pieces so far
                if not algo.IsDeleted(f):
                    mods = _listed(algo.Modified(f))
                    now += mods if mods else [f]
            followed.append(now)
        pieces = followed
    return shape, pieces


def _patch_replay(hist: dict):
    """The B-rep of a history whose textures are faces flattened together
    (:func:`_patches`), as parametric CAD makes it: the operations on the plain
    part, the patch's faces followed (:func:`_followed`), and the texture put again
    on what is left of them (:func:`texcad.brep.bands.patch_solid`) over the grid's
    cells that still lie on them (:func:`_cells_left`)."""
    from ..brep import TESSELLATION
    from ..brep.bands import face_in, patch_solid

    shape, pieces = _followed(hist["base"], [p["faces"] for p in hist["patches"]], hist["steps"])
    for p, faces in zip(hist["patches"], pieces):  # one per patch
        if not faces:
            continue
        cells = _cells_left(p, faces)
        out = None if not cells.any() else patch_solid(
            shape, [face_in(shape, f) or f for f in faces], p["points"], p["normals"], p["heights"], cells, wrap=p["wrap"],
            signed=p["signed"], chord=TESSELLATION)
        if out is None:
            raise GeometryError("the faces textured together could not be textured again after the operation")
        shape = out
    return shape


def _cells_left(patch: dict, faces: list) -> np.ndarray:
    """The patch's cells whose four corners lie on ``faces`` (within the part's
    tessellation error and :data:`TOOL_TOLERANCE`); raised, less those next to a cell
    that does not (8-neighbourhood; around the band's seam too: a raised texture's
    wall reaches only its wall height under the face)."""
    import igl
    from scipy.ndimage import binary_erosion

    from ..brep import TESSELLATION, compound

    m = shape_to_mesh(compound(faces), tolerance=TOOL_TOLERANCE)
    P = np.asarray(patch["points"], np.float64)
    d2, _, _ = igl.point_mesh_squared_distance(P.reshape(-1, 3), m.vertices.astype(np.float64), m.faces.astype(np.int64))
    on = (np.sqrt(d2) <= TESSELLATION + 2 * TOOL_TOLERANCE).reshape(P.shape[:2])
    K = np.asarray(patch["cells"], bool)
    nxt = np.roll(on, -1, axis=0) if patch["wrap"] else on[1:]
    left = K & on[: K.shape[0], :-1] & on[: K.shape[0], 1:] & nxt[:, :-1] & nxt[:, 1:]
    lost = K & ~left
    if patch["signed"]:  # the walls reach from the floor (-0.02 mm at least) to above the face: they meet it
        return left
    if patch["wrap"]:
        near = ~binary_erosion(np.concatenate([~lost[-1:], ~lost, ~lost[:1]]), np.ones((3, 3), bool), border_value=1)[1:-1]
    else:
        near = ~binary_erosion(~lost, np.ones((3, 3), bool), border_value=1)
    return left & ~near


def _listed(shapes) -> list:
    """A ``TopTools_ListOfShape`` as a Python list."""
    return list(shapes)


# -- OCCT --------------------------------------------------------------------------------------
def _edge_mids(edges) -> np.ndarray:
    """``(n, 3)`` mid-points (mm) of edges, at their mid parameter."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.TopoDS import TopoDS

    out = []
    for e in edges:  # one per edge
        ad = BRepAdaptor_Curve(TopoDS.Edge_s(to_topods(e)))
        out.append(ad.Value(0.5 * (ad.FirstParameter() + ad.LastParameter())).Coord())
    return np.array(out, dtype=np.float64).reshape(-1, 3)


def _find_edges(shape, mids: np.ndarray, tol: float = 1e-4) -> list:
    """The edges of ``shape`` whose mid-points are ``mids`` (mm, within ``tol``)."""
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopTools import TopTools_IndexedMapOfShape
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    emap = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_EDGE, emap)
    edges = [TopoDS.Edge_s(emap.FindKey(i)) for i in range(1, emap.Extent() + 1)]  # one per edge
    have = _edge_mids(edges)
    found = []
    for p in mids:  # one per edge asked for
        d = np.linalg.norm(have - p, axis=1)
        k = int(np.argmin(d))
        if d[k] > tol:
            raise ParameterError(
                f"no edge of the untextured part has its middle at {np.round(p, 3).tolist()} mm: an edge of the "
                "texture (its tiles, its rim) cannot be filleted; choose edges away from the texture, from "
                "textured.part.edges() or from the original part, or fillet the part before texturing it"
            )
        found.append(edges[k])
    return found


def _whole_edges(shape, mids: np.ndarray, tol: float = 1e-4) -> np.ndarray:
    """``(m, 3)`` mid-points (mm) of the edges of ``shape`` (the plain part) that the
    edges with mid-points ``mids`` lie on: an edge of the textured part may be a piece
    of one (a face textured on its own (u, v) in strips cuts its boundary circles at
    the strip corners); each edge once, in the order asked. A point on no edge is
    kept (:func:`_find_edges` then names it)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedMapOfShape

    emap = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_EDGE, emap)
    edges = [emap.FindKey(i) for i in range(1, emap.Extent() + 1)]  # one per edge of the plain part
    have = _edge_mids(edges)
    out: list = []
    for p in mids:  # one per edge asked for
        got = p
        if np.linalg.norm(have - p, axis=1).min() > tol:  # not a whole edge: the one it lies on
            vx = BRepBuilderAPI_MakeVertex(gp_Pnt(*map(float, p))).Vertex()
            for e, m in zip(edges, have):  # per edge of the plain part (a few dozen)
                dist = BRepExtrema_DistShapeShape(vx, e)
                if dist.IsDone() and dist.Value() <= tol:
                    got = m
                    break
        if not any(np.allclose(got, q, rtol=0, atol=tol) for q in out):
            out.append(got)
    return np.array(out, np.float64).reshape(-1, 3)


def _occt_fillet(shape, mids: np.ndarray, radius: float, maker: bool = False):
    """``shape`` with the edges at ``mids`` rounded (``maker``: and OCCT's fillet
    algorithm, for its history)."""
    from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet

    mk = BRepFilletAPI_MakeFillet(shape)
    for e in _find_edges(shape, mids):  # one per edge
        mk.Add(float(radius), e)
    try:
        mk.Build()
        ok = mk.IsDone()
    except Exception:  # OCCT raises Standard_Failure from inside the fillet builder
        ok = False
    if not ok:
        raise GeometryError(
            f"OCCT cannot fillet these edges with r = {radius:g} mm; use a smaller radius or edges away from the "
            "texture (fillet the part before texturing it)"
        )
    return (mk.Shape(), mk) if maker else mk.Shape()


def _checked(shape, mesh: Mesh, op: str, bodies: int, info: dict | None = None, offset: float = 0.0,
             change: tuple[float, float] | None = None):
    """``shape`` if valid, with ``bodies`` solids, enclosing the mesh's volume plus
    ``offset`` mm^3 (what the textured part's own B-rep encloses beyond its mesh: a
    lean mesh lies within its tolerance of the B-rep's pixel grid, 1.5 mm^3 on a 12 mm
    cylinder at 0.02 mm) within :data:`OP_VOLUME_TOLERANCE`. ``change``: ``(the
    mesh's volume before the operation, mm^3 of slack)``: the B-rep's volume must then
    change as the mesh's, ``|dV_brep - dV_mesh| <= OP_CHANGE_TOLERANCE |dV_mesh| +
    slack`` (:func:`_change_check`)."""
    chk = check_shape(shape)
    face = f" (the textured {info['face']} face)" if info and isinstance(info.get("face"), str) else ""
    if not chk["valid"] or chk["solids"] != bodies:
        raise GeometryError(
            f"OCCT's {op} of the textured B-rep{face} gave {chk['solids']} solid(s) (valid: {chk['valid']}) where the mesh "
            f"has {bodies}; the mesh result is fine: write STL or 3MF, or make the cut before texturing"
        )
    vb, vm = volume(shape), float(mesh.volume)
    if abs(vb - offset - vm) > OP_VOLUME_TOLERANCE * abs(vm):
        beyond = f" (+ {offset:.2f} mm3 the textured part's B-rep holds beyond its mesh)" if offset else ""
        raise GeometryError(
            f"OCCT's {op} of the textured B-rep{face} encloses {vb:.1f} mm3 but the same {op} on texcad's mesh "
            f"{vm:.1f} mm3{beyond} (OCCT lost or kept material it should not); the mesh result is fine: write STL or 3MF, "
            "or make the cut before texturing"
        )
    if change is not None:
        _change_check(vb - offset, vm, change, op, face)
    if info is not None:
        info["brep_volume"] = vb
    _plain_rule_note(shape, vb, vm, offset, op, face)
    return shape


def _plain_rule_note(shape, vb: float, vm: float, offset: float, op: str, face: str) -> None:
    """A TexcadWarning where OCCT's plain volume integration (``BRepGProp`` without a
    tolerance: build123d's ``.volume``, FreeCAD's) reads the B-rep more than
    :data:`OP_VOLUME_TOLERANCE` off the mesh although the B-rep encloses it
    (:func:`texcad.brep.volume`): its fixed Gauss points miss the fine tiles an
    operation trimmed (a textured sphere cut in half: -0.54 %). The B-rep is right;
    its volume read that way is not, and the user is told so."""
    import warnings

    from ..brep import plain_volume
    from ..errors import TexcadWarning

    off = (plain_volume(shape) - offset) / vm - 1.0
    if abs(off) > OP_VOLUME_TOLERANCE:
        warnings.warn(
            f"the {op}'s B-rep{face} encloses the mesh's volume ({vb:.1f} against {vm:.1f} mm3), but OCCT's plain volume "
            f"integration (build123d's .volume, FreeCAD's) reads it {off * 100:+.2f} % off: its Gauss points miss the fine "
            "tiles the operation trimmed; take the volume from texcad.brep.volume(part) or the mesh",
            TexcadWarning, stacklevel=4,
        )


def _change_check(vb: float, vm: float, change: tuple[float, float], op: str, face: str) -> None:
    """Raise GeometryError if the operation changed the B-rep's volume ``vb`` (less the
    part's own offset) otherwise than the mesh's ``vm``: both from the mesh's volume
    before it (``change[0]``), the difference allowed :data:`OP_CHANGE_TOLERANCE` of
    the mesh's change plus ``change[1]`` mm^3."""
    before, slack = change
    d_mesh, d_brep = vm - before, vb - before
    if abs(d_brep - d_mesh) > OP_CHANGE_TOLERANCE * abs(d_mesh) + slack:
        raise GeometryError(
            f"OCCT's {op} of the textured B-rep{face} changed its volume by {d_brep:+.2f} mm3 but the same {op} on "
            f"texcad's mesh by {d_mesh:+.2f} mm3 (OCCT lost or kept material it should not); the mesh result is fine: "
            "write STL or 3MF, or make the cut before texturing"
        )


def _plain_first(hist: dict, world: np.ndarray, mesh: Mesh, op: str, bodies: int, info: dict,
                 change: tuple[float, float] | None = None):
    """The checked B-rep of a history without fine tiles: faces on their own ``(u,
    v)`` by :func:`_uv_replay` (the operations on the plain part), else - or if that
    disagrees with the mesh - the operations replayed on the textured B-rep."""
    offset = hist.get("offset", 0.0)
    if hist.get("uv"):
        try:
            return _checked(_apply(_uv_replay(hist), world), mesh, op, bodies, info, offset, change)
        except GeometryError:
            pass  # the operations on the textured B-rep instead
    if not hist.get("patches"):
        return _checked(_apply(_replay(hist), world), mesh, op, bodies, info, offset, change)
    try:
        return _checked(_apply(_replay(hist), world), mesh, op, bodies, info, offset, change)
    except GeometryError as exc:  # OCCT's operation on the tiles and walls (a fillet along the patch's outline)
        try:
            return _checked(_apply(_patch_replay(hist), world), mesh, op, bodies, info, offset, change)
        except GeometryError:
            raise exc from None


def _derived(part: Any, *, mesh, texture_mesh, base_mesh, shape, info, hist) -> Any:
    """The result of an operation, its mesh through the gate's shell checks first."""
    from ..report.gate import GateReport, gate_shells

    mesh = mesh() if callable(mesh) else mesh
    # the same dict: the B-rep's check writes its volume into it on first use
    info["gate"] = GateReport(gate_shells(mesh, what=f"result of {(info.get('operations') or ['a CAD operation'])[-1]}")).to_dict()
    return type(part).derived(part, mesh=mesh, texture_mesh=texture_mesh, base_mesh=base_mesh, shape=shape, info=info,
                            history=hist)


def _slack(part: Any, tool: Mesh | None = None) -> float:
    """mm^3 an operation's change of the B-rep's volume may differ from the mesh's
    beyond :data:`OP_CHANGE_TOLERANCE`: the mesh's tolerance (a lean mesh lies that far
    from the B-rep's grid) over the tool's area within the part's bounding box, and
    1e-5 of the part's volume."""
    from manifold3d import Manifold

    area = 0.0
    if tool is not None:
        lo, hi = part.mesh.vertices.min(axis=0), part.mesh.vertices.max(axis=0)
        area = float((to_manifold(tool) ^ Manifold.cube(tuple(hi - lo)).translate(tuple(lo))).surface_area())
    return float(part.info.get("tolerance") or 0.02) * area + 1e-5 * abs(float(part.mesh.volume))


def _info(part: Any, what: str) -> dict:
    return {k: v for k, v in part.info.items() if not k.startswith("_") and k != "brep_volume"} | {
        "operations": [*part.info.get("operations", []), what]
    }


def cad_op(part: Any, tool: Any, op: str) -> Any:
    """``part`` cut by, fused with or intersected with ``tool`` (a build123d /
    CadQuery / OCP shape, a :class:`~texcad.solid.Mesh`, ``trimesh.Trimesh`` or
    ``manifold3d.Manifold`` (no B-rep then), or another :class:`Textured`), mm.

    The mesh result is manifold3d's boolean of the fused meshes (exact on the
    triangles); the B-rep result (made on first use of ``.shape``) is OCCT's boolean of
    the textured B-rep - rebuilt with fine tiles under the tool, see the module - with
    the tool's shape, and must be valid, have as many solids as the mesh and enclose
    its volume within :data:`OP_VOLUME_TOLERANCE`.

    Raises:
        ParameterError: unknown operation or tool.
        GeometryError: the operation leaves nothing (or, on ``.shape``, OCCT's result
            disagrees with the mesh).
    """
    if op not in OPS:
        raise ParameterError(f"unknown operation {op!r}; use one of {', '.join(OPS)}")
    tool = _as_mesh_tool(tool)
    tool_mesh = _tool_mesh(tool)
    mesh = _mesh_op(part.mesh, tool_mesh, op)
    if mesh.num_triangles == 0:
        raise GeometryError(f"the {op} leaves nothing of the part; check the tool's placement (mm)")
    texture_op = "cut" if op == "fuse" else op
    bodies = len(to_manifold(mesh).decompose())

    def texture_mesh() -> Mesh:
        return _mesh_op(part.texture_mesh, tool_mesh, texture_op)

    def base_mesh() -> Mesh:
        return _mesh_op(part.base_mesh, tool_mesh, op)

    shape, hist = None, None
    if part.has_brep and not isinstance(tool, Mesh):
        src = _history(part)
        world = _world(part, src)
        other = tool.shape if _is_textured(tool) else to_topods(tool)
        local = _apply(other, np.linalg.inv(_m4(world))[:3])
        step = {"op": op, "tool": local, "fine": _fine_rect(local, src["frame"]) if src["frame"] else None}
        hist = dict(src, steps=[*src["steps"], step], to_world=world)

        def shape():
            change = (float(part.mesh.volume), _slack(part, tool_mesh))  # made only when the B-rep is asked for
            if hist["make"] is None:
                return _plain_first(hist, world, mesh, op, bodies, info, change)
            for k, cells in enumerate(FINE_TRIES):  # another tiling under the tool if OCCT got it wrong
                try:
                    return _checked(_apply(_replay(hist, cells), world), mesh, op, bodies, info, hist.get("offset", 0.0),
                                    change)
                except GeometryError:
                    if k == len(FINE_TRIES) - 1:
                        raise

    info = _info(part, op)
    if part.has_brep and isinstance(tool, Mesh):
        info["no_brep"] = f"a {op} with a mesh tool; use a CAD shape as the tool for a B-rep"
    return _derived(part, mesh=mesh, texture_mesh=texture_mesh, base_mesh=base_mesh, shape=shape, info=info, hist=hist)


def fillet(part: Any, edges: Sequence[Any], radius: float) -> Any:
    """``part`` with ``edges`` rounded to ``radius`` mm (edges of the body away from
    the texture, chosen from ``textured.part.edges()`` or from the original part).

    The B-rep is OCCT's fillet of the textured B-rep (or, for faces on their own ``(u,
    v)``, of the plain part, textured again); the mesh is the textured mesh changed by
    what OCCT's fillet changes on the *untextured* part (the operations made so far
    replayed on it): the material taken off cut away, any added united, each
    tessellated at :data:`TOOL_TOLERANCE` mm (:func:`_fillet_change`). They must
    agree (valid, same number of solids, volume within :data:`OP_VOLUME_TOLERANCE`).

    Raises:
        ParameterError: no edges, a non-positive radius, or an edge not on the part.
        GeometryError: OCCT cannot make the fillet, or the results disagree.
    """
    if not (isinstance(radius, (int, float)) and np.isfinite(radius) and radius > 0):
        raise ParameterError(f"the fillet radius must be a positive number of mm, got {radius!r}")
    edge_list = [edges] if hasattr(edges, "wrapped") and not hasattr(edges, "__len__") else list(edges)
    if not edge_list:
        raise ParameterError("select at least one edge to fillet, e.g. textured.part.edges().filter_by(Axis.Z)")
    hist_src = _history(part)
    if hist_src["base"] is None:
        raise GeometryError("this result has no untextured part to fillet for the mesh; fillet before texturing")
    world = _world(part, hist_src)
    inv = np.linalg.inv(_m4(world))
    mids = _edge_mids(edge_list) @ inv[:3, :3].T + inv[:3, 3]  # in the history frame
    base = hist_src["base"]
    for st in hist_src["steps"]:  # the operations so far, on the untextured part
        base = occt_boolean(base, st["tool"], st["op"]) if st["op"] != "fillet" else _occt_fillet(base, st["edges"], st["radius"])
    mids = _whole_edges(base, mids)  # pieces of an edge (a textured face's strips cut it): the whole edge
    step = {"op": "fillet", "edges": mids, "radius": float(radius)}
    hist = dict(hist_src, steps=[*hist_src["steps"], step], to_world=world)
    change = _fillet_change(base, _occt_fillet(base, mids, radius), world)
    mesh = _changed(part.mesh, change)
    bodies = len(to_manifold(mesh).decompose())

    textured_edge = _borders_texture(base, mids, hist_src)

    def shape():
        try:
            return _plain_first(hist, world, mesh, "fillet", bodies, info, (float(part.mesh.volume), _slack(part)))
        except GeometryError as exc:
            why = (". An edge to fillet borders the textured face: there the mesh's fillet takes off the relief and the "
                   "B-rep's keeps it up to the fillet; fillet the part before texturing it for a B-rep") if textured_edge else ""
            fine = "" if "STL" in str(exc) else " (the mesh result is fine: write STL or 3MF)"
            if not (why or fine):
                raise
            raise GeometryError(f"{exc}{why}{fine}") from None

    info = _info(part, "fillet")
    return _derived(part, mesh=mesh, texture_mesh=lambda: part.texture_mesh, base_mesh=lambda: _changed(part.base_mesh, change),
                    shape=shape, info=info, hist=hist)


def _borders_texture(base, mids: np.ndarray, hist: dict) -> bool:
    """Does an edge of the plain part ``base`` at ``mids`` (mm) bound a face textured
    on its own (u, v) (``hist["uv"]``; faces of the part before any operation)?"""
    from OCP.TopAbs import TopAbs_EDGE

    from ..brep.occt import explore

    faces = [face for face, _, _ in hist.get("uv") or ()]
    if not faces:
        return False
    try:
        edges = _find_edges(base, mids)
    except ParameterError:
        return False
    return any(e.IsSame(g) for f in faces for g in explore(f, TopAbs_EDGE) for e in edges)


def _fillet_change(before, after, world: np.ndarray) -> list:
    """What a fillet changed on the plain part, ``[(mesh, "cut" | "fuse"), ...]`` in
    the world (mm): the material it took off (``before - after``, OCCT, exact on the
    plain part) and what it added (a concave edge), tessellated at
    :data:`TOOL_TOLERANCE` and cleared off the part's old faces (:func:`_cleared`)."""
    from OCP.TopAbs import TopAbs_FACE

    from ..brep import compound
    from ..brep.occt import explore

    out = []
    for a, b, op in ((before, after, "cut"), (after, before, "fuse")):  # taken off, added
        piece, algo = occt_boolean(a, b, "cut", maker=True)
        if not (solids_of(piece) and abs(volume(piece)) > 1e-9):
            continue
        made = [g for f in explore(b, TopAbs_FACE) for g in [f, *_listed(algo.Modified(f))]]  # b's faces, as cut
        new = [g for g in explore(piece, TopAbs_FACE) if any(g.IsSame(m) for m in made)]  # the fillet's own faces
        mesh = shape_to_mesh(_apply(piece, world), tolerance=TOOL_TOLERANCE)
        out.append((_cleared(mesh, shape_to_mesh(_apply(compound(new), world), tolerance=TOOL_TOLERANCE)) if new else mesh, op))
    return out


#: mm: how far a fillet's change is moved off the part's old faces (:func:`_cleared`).
FILLET_CLEAR = 0.05


def _cleared(piece: Mesh, new: Mesh) -> Mesh:
    """A fillet's change ``piece`` with its vertices that are not on its faces of
    the filleted part (``new``, the same triangulation: within 1e-6 mm), i.e. on the
    part's old faces, moved :data:`FILLET_CLEAR` mm out of the piece along its
    vertex normals (out of the part for material taken off, into it for material
    added); the fillet's own faces and their edges stay. On a curved face the
    piece's tessellation and the textured mesh's differ by up to their chord errors:
    cut as they are, the two near-coincident sheets leave slivers that pinch the
    result (a fillet that OCCT runs on along smooth edges to a patch's outline, or
    up to a textured face's corner, did). What the moved faces sweep lies outside
    the part (inside it for added material), or in a relief within 0.05 mm of the
    old face, which the fillet takes off with it."""
    import igl

    v, f = piece.vertices.astype(np.float64), piece.faces.astype(np.int64)
    d2, _, _ = igl.point_mesh_squared_distance(v, new.vertices.astype(np.float64), new.faces.astype(np.int64))
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])  # area-weighted
    vn = np.zeros_like(v)
    for k in range(3):  # the three corners
        np.add.at(vn, f[:, k], fn)
    vn /= np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-18)
    old = d2 > 1e-12
    return Mesh((v + np.where(old[:, None], FILLET_CLEAR * vn, 0.0)).astype(np.float32), piece.faces)


def _changed(mesh: Mesh, change: list) -> Mesh:
    """``mesh`` with a fillet's change (:func:`_fillet_change`) applied (manifold3d)."""
    for piece, op in change:  # taken off, then added
        mesh = _mesh_op(mesh, piece, op)
    return mesh


def _vector(v: Any, what: str, axis: bool) -> np.ndarray:
    """``(3,)`` float64 from three numbers, a build123d ``Vector`` or (``axis``) an
    axis word."""
    from ..util import axis_word

    a = axis_word(v) if isinstance(v, str) and axis else None
    try:
        a = np.asarray(tuple(v) if a is None else a, np.float64)
    except (TypeError, ValueError):
        a = None
    if a is None or a.shape != (3,) or not np.isfinite(a).all():
        also = " or an axis (+x, -z...)" if axis else ""
        raise ParameterError(f"{what} must be three numbers (x, y, z), a build123d Vector{also}, got {v!r}")
    return a


def _mirror_matrix(origin: Any, normal: Any) -> np.ndarray:
    if hasattr(origin, "z_dir") and hasattr(origin, "origin"):  # a build123d Plane
        origin, normal = origin.origin, origin.z_dir
    n = _vector(normal, "the mirror plane's normal", axis=True)
    if not np.linalg.norm(n) > 0:
        raise ParameterError(f"the mirror plane's normal must be a non-zero (3,) vector, got {normal!r}")
    n = n / np.linalg.norm(n)
    o = _vector(origin, "the mirror plane's origin (mm)", axis=False)
    r = np.eye(3) - 2.0 * np.outer(n, n)
    return np.hstack([r, (o - r @ o)[:, None]])


def _mirrored_mesh(mesh: Mesh, m: np.ndarray) -> Mesh:
    v = mesh.vertices.astype(np.float64) @ m[:, :3].T + m[:, 3]
    return Mesh(v.astype(np.float32), np.ascontiguousarray(mesh.faces[:, ::-1]), mesh.groups)


def mirror(part: Any, origin: Sequence[float] = (0.0, 0.0, 0.0), normal: Sequence[float] = (1.0, 0.0, 0.0)) -> Any:
    """``part`` mirrored about the plane through ``origin`` (mm) with ``normal`` (or
    about a build123d ``Plane`` given as ``origin``, e.g. ``Plane.YZ``): meshes (vertices reflected, triangles turned to keep them outward) and B-rep
    (``BRepBuilderAPI_Transform``) alike; later operations still get fine tiles."""
    m = _mirror_matrix(origin, normal)
    hist_src = _history(part) if part.has_brep else None
    hist, shape = None, None
    if hist_src is not None:
        world = (_m4(m) @ _m4(_world(part, hist_src)))[:3]
        hist = dict(hist_src, to_world=world)

        def shape():
            mesh = _mirrored_mesh(part.mesh, m)
            bodies = len(to_manifold(mesh).decompose())
            if hist["make"] is None and hist["steps"]:  # operations made so far: on the plain part first, as they were
                return _plain_first(hist, world, mesh, "mirror", bodies, info)
            return _checked(_apply(_replay(hist), world), mesh, "mirror", bodies, info, hist.get("offset", 0.0))

    info = _info(part, "mirror")
    return _derived(
        part,
        mesh=lambda: _mirrored_mesh(part.mesh, m),
        texture_mesh=lambda: _mirrored_mesh(part.texture_mesh, m),
        base_mesh=lambda: _mirrored_mesh(part.base_mesh, m),
        shape=shape,
        info=info,
        hist=hist,
    )


def _placements(locations: Any) -> list[np.ndarray]:
    """``(3, 4)`` matrices of a pattern's placements: a build123d ``Locations`` /
    ``GridLocations`` / ``PolarLocations``, or a list of ``Location``s, ``Pos``es or
    matrices."""
    items = getattr(locations, "locations", locations)
    if hasattr(items, "wrapped") or (isinstance(items, np.ndarray) and items.ndim == 2):
        items = [items]
    mats = [matrix_of(loc) for loc in items]  # one per copy
    if not mats:
        raise ParameterError("a pattern needs at least one placement, e.g. [Pos(0, 0, 0), Pos(120, 0, 0)]")
    for m in mats:  # one per copy
        if not np.allclose(m[:, :3].T @ m[:, :3], np.eye(3), atol=1e-9):
            raise ParameterError("pattern placements must be rigid (rotations and translations, or mirrors)")
    return mats


def pattern(part: Any, locations: Any) -> Any:
    """Copies of ``part`` at each of ``locations`` (placements relative to where the
    part is now, mm and degrees: ``GridLocations(120, 0, 3, 1)``, ``PolarLocations(60,
    6)``, ``[Pos(0, 0, 0), Pos(0, 120, 0)]``, or ``(3, 4)`` matrices), as one result
    with one body per copy and body of ``part``.

    The mesh holds the moved copies side by side; the B-rep (on first use) is a
    compound of the copies (:func:`texcad.brep.transformed_shape`: geometry and the
    tiles' meshes copied), checked like every operation (valid, one solid per body,
    volume within :data:`OP_VOLUME_TOLERANCE` of the mesh's).

    Raises:
        ParameterError: no placement or a non-rigid one.
        GeometryError: copies overlap or touch (fuse such copies with ``+``).
    """
    mats = _placements(locations)
    bodies = len(to_manifold(part.mesh).decompose())
    copies = [_placed(part.mesh, m) for m in mats]
    _disjoint(copies, bodies)
    mesh = _side_by_side(copies)
    info = _info(part, f"pattern x{len(copies)}")
    shape = None
    if part.has_brep:

        def shape():
            from OCP.BRep import BRep_Builder
            from OCP.TopoDS import TopoDS_Compound

            src = part.shape
            b, comp = BRep_Builder(), TopoDS_Compound()
            b.MakeCompound(comp)
            for m in mats:  # one per copy
                b.Add(comp, src if np.allclose(m, np.eye(3, 4), rtol=0, atol=1e-12) else transformed_shape(src, m))
            return _checked(comp, mesh, "pattern", bodies * len(copies), info, len(copies) * _offset(part, src))

    out = _derived(
        part,
        mesh=mesh,
        texture_mesh=lambda: _side_by_side([_placed(part.texture_mesh, m) for m in mats]),
        base_mesh=lambda: _side_by_side([_placed(part.base_mesh, m) for m in mats]),
        shape=shape,
        info=info,
        hist=None,
    )
    return out  # later operations start from the compound (no history: _cad_history is None)


def _disjoint(copies: list, bodies: int) -> None:
    """Raise unless the meshes ``copies`` (each ``bodies`` bodies) are apart: where
    bounding boxes meet, their manifold3d union must keep every body and the volume."""
    lo = np.array([c.vertices.min(axis=0) for c in copies], np.float64)
    hi = np.array([c.vertices.max(axis=0) for c in copies], np.float64)
    meet = ((lo[:, None] <= hi[None] + 1e-6) & (lo[None] <= hi[:, None] + 1e-6)).all(axis=2)
    if meet.sum() == len(copies):  # each box meets only itself
        return
    mans = [to_manifold(c) for c in copies]
    union = mans[0]
    for m in mans[1:]:  # one per copy
        union = union + m
    total = sum(m.volume() for m in mans)
    if len(union.decompose()) != bodies * len(copies) or abs(union.volume() - total) > 1e-6 * abs(total):
        raise GeometryError(
            f"the {len(copies)} copies of the pattern overlap or touch; space them further apart, or fuse such "
            "copies with + (textured + textured.moved(Pos(...)))"
        )


def _side_by_side(meshes: list) -> Mesh:
    """One mesh holding ``meshes`` (their groups kept, renumbered)."""
    offs = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    toff = np.cumsum([0] + [m.num_triangles for m in meshes[:-1]])
    groups: dict = {}
    for m, t in zip(meshes, toff):  # one per copy
        for k, g in m.groups.items():  # a few groups
            groups.setdefault(k, []).append(np.asarray(g, np.int64) + t)
    return Mesh(
        np.concatenate([m.vertices for m in meshes]).astype(np.float32),
        np.concatenate([m.faces.astype(np.int64) + o for m, o in zip(meshes, offs)]).astype(np.uint32),
        {k: np.concatenate(v).astype(np.uint32) for k, v in groups.items()},
    )


def _placed(mesh: Mesh, m: np.ndarray) -> Mesh:
    """``mesh`` moved by the rigid ``(3, 4)`` matrix ``m`` (a mirror turns the triangles)."""
    if np.linalg.det(m[:, :3]) < 0:
        return _mirrored_mesh(mesh, m)
    v = mesh.vertices.astype(np.float64) @ m[:, :3].T + m[:, 3]
    return Mesh(v.astype(np.float32), mesh.faces, mesh.groups)
