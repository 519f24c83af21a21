"""B-rep of faces textured by the general method (cones, spheres, tori, surfaces of
revolution, B-spline faces, partial cylinders): the textured face as a degree-1
B-spline **on the face's own parameter space**, in place of the face, without a
boolean.

A face parameterized by its own ``(u, v)`` corrected by the metric (texture ``y =
Y(u)``, ``x = X(v)``, :func:`texcad.mapping.separable_coordinates`) carries a texture
grid whose rows are iso-``u`` and columns iso-``v`` lines. The new surface has the
knots ``u0, u(y_0), ..., u(y_R-1), u1`` and ``v0, v(x_0), ..., v1`` (the face's UV
bounds around the grid's own parameters) and the poles ``P + h n`` (texcad's grid
points and heights, ``h >= 0``: where the mesh's relief dips under the face the face
shows); its boundary rows are the face's boundary, evaluated by OCCT (the relief is
ramped to 0 mm there). The face's wires, edges and pcurves (in the same ``(u, v)``)
are kept; the edges' tolerances grow by the chord of the boundary rows (sampled),
and on a closed face the seam edge is replaced by the lifted seam row (the texture
runs on across it). The face carries its grid's triangulation (texcad's mesh, two
triangles per cell), which OCCT's mesher and texcad's STEP writer keep.

A face whose outline is the iso-line rectangle is made of strips of that surface
(:mod:`texcad.brep.uvstrips`: at most ``TILE`` spans wide, knots placed for OCCT's
plain volume integration, :mod:`texcad.brep.gprop`), its edges along u cut at the
strip corners in every face that has them. A face trimmed inside that rectangle (a
cone cut by flutes or a slanted plane, a cylinder with a hole or a slot through it)
is made of tiles on its own ``(u, v)`` (:mod:`texcad.brep.uvtrim`: the plain part
split along iso lines, each piece on its tile of the textured surface); grid points
off the face lie on its surface (the relief is 0 mm near its edges). Where neither
gives a valid solid, each face stays one face.

CAD operations on such a face (:mod:`texcad.pipeline.ops`) are made on the plain part
and the texture is put again on what is left of the face (:func:`uv_face_pairs`,
:func:`uv_retextured_solid`): the same poles, the relief taken off where the
operation's edges cross it.

Faces this does not apply to (several faces flattened together; a face no grid point
lies on) raise ``GeometryError`` saying so; the meshes (STL, 3MF) are unaffected.

Tiles instead of one face (OCCT meshes, integrates and cuts tiles of a few hundred
poles reliably, not one face of hundreds of thousands):

* :func:`tiled_in_place` / :func:`open_extrusion_solid` - an open profile's face (the
  sine sample, a partial cylinder) as tiles on its own ``(u, v)``, sewn to its four
  boundary edges split at the tile corners (the neighbouring faces get the same
  pieces); the flat frame and the narrow walls are tiles of their own.
* :func:`holed_plane_solid` - a planar face with holes, pockets or notches inside
  the texture: tiles over the cells where the texture leaves the plane, halved down
  to single cells near the outline (never touching it), and one planar face per
  region around them.
"""

from __future__ import annotations

import io
from typing import Any, Sequence

import numpy as np

from ..errors import GeometryError
from .solids import (
    TILE,
    TOLERANCE,
    _remember_tile,
    _replace_faces,
    _tile_text,
    check_shape,
    replace_face,
    textured_plane_face,
    tiled_grid_faces,
    tiled_plane_solid,
)
from .occt import explore, face_in, to_topods
from .tessellation import TESSELLATION
from .uvstrips import _grid_face, _used_twice, strip_faces, strip_origin
from .uvtrim import _bilinear, _edge_deviation, trimmed_tiles

__all__ = ["uv_textured_solid", "open_extrusion_solid", "tiled_in_place", "holed_plane_solid", "textured_plane_solid",
           "uv_face_pairs", "uv_retextured_solid"]


def _surface_rows(face, u: np.ndarray, v: np.ndarray):
    """Points and outward unit normals ``(len(u), len(v), 3)`` of a face's surface at
    ``u x v`` (OCCT, one call per point: boundary rows only)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.gp import gp_Pnt, gp_Vec
    from OCP.TopAbs import TopAbs_REVERSED

    ad = BRepAdaptor_Surface(face, False)
    sign = -1.0 if face.Orientation() == TopAbs_REVERSED else 1.0
    pts = np.zeros((len(u), len(v), 3))
    nrm = np.zeros((len(u), len(v), 3))
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    for i, a in enumerate(u.tolist()):  # per boundary sample
        for j, b in enumerate(v.tolist()):
            ad.D1(a, b, p, du, dv)
            pts[i, j] = p.Coord()
            n = np.cross(du.Coord(), dv.Coord())
            nrm[i, j] = sign * n / max(float(np.linalg.norm(n)), 1e-300)
    return pts, nrm


def _surface_points(face, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Points ``(n, 3)`` mm of a face's surface at the parameter pairs ``(u[k], v[k])``
    (one OCCT call per point: OCCT evaluates no batch)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface

    ad = BRepAdaptor_Surface(face, False)
    return np.array([ad.Value(a, b).Coord() for a, b in zip(u.tolist(), v.tolist())]).reshape(-1, 3)  # per point off the face


def _poles(face, item: dict):
    """Knots ``u (Nu,)``, ``v (Nv,)`` and poles ``(Nu, Nv, 3)`` mm of the textured face."""
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopoDS import TopoDS

    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    u0, u1, v0, v1 = BRepTools.UVBounds_s(fwd)
    ut, vt = item["u_table"], item["v_table"]
    ur = np.interp(item["ys"], ut[1], ut[0])
    vc = np.interp(item["xs"], vt[1], vt[0])
    eu, ev = 1e-9 * (abs(u1 - u0) + 1.0), 1e-9 * (abs(v1 - v0) + 1.0)
    rows = (ur > u0 + eu) & (ur < u1 - eu)
    cols = (vc > v0 + ev) & (vc < v1 - ev)
    valid = item["valid"][np.ix_(rows, cols)]
    if rows.sum() < 1 or cols.sum() < 1 or not valid.any():
        raise GeometryError(_uncovered(fwd, (u0, u1, v0, v1), int((~valid).sum()), int(valid.size)))
    h = item["heights"][np.ix_(rows, cols)]  # signed (engraved, centred) or raised (its dip under the face cut off)
    P, N = item["points"][np.ix_(rows, cols)], item["normals"][np.ix_(rows, cols)]
    if not item.get("signed"):  # raised: where it dips under the face the mesh is the part's tessellation
        h = np.maximum(h, 0.0) + _mesh_lift(face, P, N, h, valid)
    elif item.get("cells") is not None:  # engraved: where no cutter cell reaches, the mesh is the part's tessellation
        bare = _bare_cells(item["cells"], np.flatnonzero(rows), np.flatnonzero(cols))
        h = np.where(_corners_of(~bare), h, 0.0)
        h = h + _mesh_lift(face, P, N, h, valid, bare)
    h = np.where(valid, h, 0.0)
    inner = item["points"][np.ix_(rows, cols)] + h[..., None] * item["normals"][np.ix_(rows, cols)]
    u = np.concatenate([[u0], ur[rows], [u1]])
    v = np.concatenate([[v0], vc[cols], [v1]])
    ri, ci = np.nonzero(~valid)  # off the face (trimmed inside its rectangle) or missed near a pole: the surface itself
    inner[ri, ci] = _surface_points(face, u[1:-1][ri], v[1:-1][ci])
    top = np.zeros((len(u), len(v), 3))
    top[1:-1, 1:-1] = inner
    edge_u, _ = _surface_rows(face, u, v[[0, -1]])  # the v0 and v1 boundaries (the relief is 0 there)
    top[:, 0], top[:, -1] = edge_u[:, 0], edge_u[:, 1]
    seam, seam_n = _surface_rows(face, u[[0, -1]], v)
    if item["closed_u"]:  # the texture runs on across the seam: its height between the last and first rows
        hs = np.zeros(len(v))
        hs[1:-1] = 0.5 * (h[0] + h[-1])
        top[0] = top[-1] = seam[0] + hs[:, None] * seam_n[0]
    else:
        top[0], top[-1] = seam[0], seam[1]
    return u, v, top


#: Samples per cell side where :func:`_mesh_lift` measures how far the part's
#: tessellation lies off the grid's cells.
GAP_SAMPLES = (0.25, 0.75)


def _bare_cells(cells: np.ndarray, ri: np.ndarray, ci: np.ndarray) -> np.ndarray:
    """``(len(ri) - 1, len(ci) - 1)`` bool: the cells between the grid rows ``ri`` and
    columns ``ci`` (increasing indices) that the mesh's cutter leaves bare: not among
    the grid's meshed ``cells`` (``(R, C - 1)`` when the rows wrap, else ``(R - 1, C -
    1)``), or spanning rows or columns that are not neighbours."""
    a, b = ri[:-1, None], ci[None, :-1]
    ok = ((ri[1:] - ri[:-1]) == 1)[:, None] & ((ci[1:] - ci[:-1]) == 1)[None, :]
    return ~(ok & cells[np.minimum(a, len(cells) - 1), np.minimum(b, cells.shape[1] - 1)])


def _corners_of(cells: np.ndarray) -> np.ndarray:
    """``(R, C)`` bool: the grid points that are a corner of at least one of the
    ``(R - 1, C - 1)`` ``cells``."""
    out = np.zeros((cells.shape[0] + 1, cells.shape[1] + 1), dtype=bool)
    for a, b in ((slice(None, -1), slice(None, -1)), (slice(1, None), slice(None, -1)), (slice(None, -1), slice(1, None)),
                 (slice(1, None), slice(1, None))):  # fmt: skip
        out[a, b] |= cells
    return out


def _mesh_lift(face, P: np.ndarray, N: np.ndarray, h: np.ndarray, valid: np.ndarray, bare: "np.ndarray | None" = None) -> np.ndarray:
    """``(R, C)`` mm to add to a raised relief's heights (``max(h, 0)``) so that the
    B-rep follows texcad's mesh where the relief dips under the face, or, given
    ``bare`` (``(R - 1, C - 1)`` bool), to an engraved relief's (0 at the points of
    no cut cell) over the cells its cutter leaves bare (a torus's band along its
    seam in ``v``: the B-rep lay 0.02 mm under the mesh there, -0.16 %).

    texcad's mesh is the union of the relief's slab (through ``P + h N``: grid
    points ``P`` on the face, mm, unit normals ``N``) with the part's own
    tessellation (OCCT, chord :data:`texcad.brep.TESSELLATION` and 0.1 rad). Where
    ``h < 0`` at the four corners of a cell (the M-I ramp's band along a face's
    edges, the bare band a torus's seam in ``v`` leaves) the slab lies under the
    face and the mesh there *is* that tessellation, while a degree-1 surface
    through ``P`` is the grid's chords: on a convex face of small radius the
    tessellation is the finer, so the B-rep lay under the mesh (a stones torus at
    0.5 mm: -0.071 %, and -0.118 % by OCCT's plain rule after a drill), on a
    coarser grid's chords over it. Here the gap along the normal is measured at
    :data:`GAP_SAMPLES` points of each such cell (signed; AABB distance to the
    tessellation, within 4 chord errors of it) and each point is moved by the mean
    gap of those cells around it (0 elsewhere, and without a tessellation)."""
    tess = _face_tessellation(face)
    whole = valid[:-1, :-1] & valid[1:, :-1] & valid[:-1, 1:] & valid[1:, 1:]
    top = np.where(valid, h, np.inf)
    low = whole & (np.maximum(np.maximum(top[:-1, :-1], top[1:, :-1]), np.maximum(top[:-1, 1:], top[1:, 1:])) < 0.0)
    if bare is not None:  # signed reliefs: the cells the cutter leaves bare, given
        low = whole & bare
    lift = np.zeros(h.shape)
    if tess is None or not low.any():
        return lift
    import igl

    ri, ci = np.nonzero(low)
    corners = ((ri, ci), (ri + 1, ci), (ri, ci + 1), (ri + 1, ci + 1))
    gaps = np.zeros(len(ri))
    for s in GAP_SAMPLES:  # 2 x 2 points per cell
        for t in GAP_SAMPLES:
            w = ((1 - s) * (1 - t), s * (1 - t), (1 - s) * t, s * t)
            q = sum(wk * P[c] for wk, c in zip(w, corners))
            n = sum(wk * N[c] for wk, c in zip(w, corners))
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-18)
            d2, _, near = igl.point_mesh_squared_distance(q, *tess)
            up = np.einsum("ij,ij->i", near - q, n)
            gaps += np.where(d2 < (4 * TESSELLATION) ** 2, up, 0.0) / len(GAP_SAMPLES) ** 2
    cell = np.zeros(low.shape)
    cell[ri, ci] = gaps
    total, count = np.zeros(h.shape), np.zeros(h.shape)
    for a, b in ((slice(None, -1), slice(None, -1)), (slice(1, None), slice(None, -1)), (slice(None, -1), slice(1, None)),
                 (slice(1, None), slice(1, None))):  # fmt: skip
        total[a, b] += cell  # each such cell at its four corners
        count[a, b] += low
    return np.where(count > 0, total / np.maximum(count, 1), 0.0)


def _face_tessellation(face):
    """``(points (n, 3) mm, triangles (m, 3))`` of the triangulation ``face``
    carries (the part's tessellation), or OCCT's at :data:`texcad.brep.TESSELLATION`
    and 0.1 rad of a copy of it (what the part's tessellation makes); None if there
    is none."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopoDS import TopoDS

    from .tessellation import _face_triangles

    fm = _face_triangles(face)
    if fm is None:
        copy = TopoDS.Face_s(BRepBuilderAPI_Copy(face).Shape())
        BRepMesh_IncrementalMesh(copy, TESSELLATION, False, 0.1, True)
        fm = _face_triangles(copy)
    if fm is None or not len(fm.tris):
        return None
    return np.ascontiguousarray(fm.points, np.float64), np.ascontiguousarray(fm.tris, np.int64)


def _uncovered(face, rect: tuple, off: int, total: int) -> str:
    """Why ``face`` (its ``(u, v)`` bounds ``rect``) gets no B-rep: which face (its
    surface kind, centre in mm), how much of the grid is off it, and what to do."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    kind = str(BRepAdaptor_Surface(face).GetType()).rsplit("_", 1)[-1].lower()
    c = ", ".join(f"{x:.2f}" for x in props.CentreOfMass().Coord())
    u0, u1, v0, v1 = rect
    return (f"no B-rep for the {kind} face centred at ({c}) mm ({props.Mass():.1f} mm2): the texture grid does not "
            f"reach the face's (u, v) rectangle u {u0:.4g}..{u1:.4g}, v {v0:.4g}..{v1:.4g} ({off} of {total} grid "
            "points off it: no grid point lies on the face); its STL and 3MF are unaffected: export those, or "
            "texture the face before the cuts that trim it and make them afterwards on the result (textured - tool), "
            "which keeps a B-rep")


def _u_seam(edge, fwd, u: np.ndarray) -> bool:
    """Is this seam edge the one at ``u = u0`` (its pcurve runs along v)?"""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d

    c2 = BRepAdaptor_Curve2d(edge, fwd)
    a, b = c2.Value(c2.FirstParameter()), c2.Value(c2.LastParameter())
    return abs(a.X() - b.X()) < 1e-9 * (abs(u[-1] - u[0]) + 1.0)


def _seam_edge(b, e, fwd, surf, u, v, top):
    """The new seam edge (the lifted grid row at ``u0``, running along v) for the old
    seam ``e``: ``(edge, pcurve of its forward use, of its reversed use, same
    direction as e)``."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_VERTEX
    from OCP.TopoDS import TopoDS, TopoDS_Edge

    ne = TopoDS_Edge()
    b.MakeEdge(ne, surf.UIso(float(u[0])), TOLERANCE)
    ends = explore(e, TopAbs_VERTEX)
    pts = [np.array(BRep_Tool.Pnt_s(TopoDS.Vertex_s(x)).Coord()) for x in ends]
    first = int(np.argmin([np.linalg.norm(p - top[0, 0]) for p in pts]))
    b.Add(ne, ends[first].Oriented(TopAbs_FORWARD))
    b.Add(ne, ends[1 - first if len(ends) > 1 else 0].Oriented(TopAbs_REVERSED))
    cf = BRepAdaptor_Curve2d(TopoDS.Edge_s(e.Oriented(TopAbs_FORWARD)), fwd)
    ends_v = sorted((cf.Value(cf.FirstParameter()).Y(), cf.Value(cf.LastParameter()).Y()))
    b.Range(ne, float(max(ends_v[0], v[0])), float(min(ends_v[1], v[-1])))  # the old seam's run (a trimmed face: part of v)
    cr = BRepAdaptor_Curve2d(TopoDS.Edge_s(e.Oriented(TopAbs_REVERSED)), fwd)
    up = cf.Value(cf.LastParameter()).Y() > cf.Value(cf.FirstParameter()).Y()
    uf, ur = cf.Value(cf.FirstParameter()).X(), cr.Value(cr.FirstParameter()).X()
    if not up:  # the new edge runs the other way: its forward use is the old reversed one
        uf, ur = ur, uf
    lines = [Geom2d_Line(gp_Pnt2d(float(a), 0.0), gp_Dir2d(0.0, 1.0)) for a in (uf, ur)]
    return ne, lines[0], lines[1], up


def _new_face(face, u, v, top, keep_seam: bool = False):
    """The textured face replacing ``face`` (same wires, same orientation; a new seam
    edge on a closed face unless ``keep_seam``: its rows are then the face itself)."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_VERTEX
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS, TopoDS_Face, TopoDS_Iterator, TopoDS_Wire

    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    surf, tri = _grid_face(u, v, top)
    b = BRep_Builder()
    new = TopoDS_Face()
    b.MakeFace(new, surf, TopLoc_Location(), TOLERANCE)
    seams: dict = {}
    wires = []
    wit = TopoDS_Iterator(fwd)
    while wit.More():  # one per wire
        w = TopoDS_Wire()
        b.MakeWire(w)
        eit = TopoDS_Iterator(wit.Value())
        while eit.More():  # one per edge of the wire
            e = TopoDS.Edge_s(eit.Value())
            if not keep_seam and _used_twice(fwd, e) and _u_seam(e, fwd, u):  # the seam: the lifted row at u0 (u1 the same points)
                key = next((k for k in seams if k.IsSame(e)), None)
                if key is None:
                    seams[e] = _seam_edge(b, e, fwd, surf, u, v, top)
                    key = e
                ne, _, _, up = seams[key]
                b.Add(w, ne.Oriented(e.Orientation() if up else e.Reversed().Orientation()))
            else:
                b.Add(w, e)
            eit.Next()
        w.Closed(True)
        wires.append(w)
        wit.Next()
    for w in wires:  # one per wire
        b.Add(new, w)
    for e in explore(fwd, TopAbs_EDGE):  # the kept edges: pcurves on the new surface, tolerance
        edge = TopoDS.Edge_s(e)
        if _used_twice(fwd, edge):
            if not keep_seam and _u_seam(edge, fwd, u):
                continue
            c1 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(edge.Oriented(TopAbs_FORWARD)), fwd, 0.0, 0.0)
            c2 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(edge.Oriented(TopAbs_REVERSED)), fwd, 0.0, 0.0)
            b.UpdateEdge(edge, c1, c2, new, BRep_Tool.Tolerance_s(edge))  # a seam along u (a torus's tube): kept
        else:
            b.UpdateEdge(edge, BRep_Tool.CurveOnSurface_s(edge, fwd, 0.0, 0.0), new, BRep_Tool.Tolerance_s(edge))
        if BRep_Tool.Degenerated_s(edge):  # a pole (a point): its pcurve is all it has
            continue
        dev = _edge_deviation(edge, fwd, u, v, top)
        tol = max(BRep_Tool.Tolerance_s(edge), 1.5 * dev + TOLERANCE)
        b.UpdateEdge(edge, tol)
        for x in explore(edge, TopAbs_VERTEX):  # its two vertices
            vx = TopoDS.Vertex_s(x)
            b.UpdateVertex(vx, max(BRep_Tool.Tolerance_s(vx), tol))
    for ne, c1, c2, _ in seams.values():  # the seam's two pcurves (u = u0 and u = u1)
        b.UpdateEdge(ne, c1, c2, new, TOLERANCE)
    b.UpdateFace(new, tri)
    return new if face.Orientation() != TopAbs_REVERSED else TopoDS.Face_s(new.Oriented(TopAbs_REVERSED))


def uv_textured_solid(shape: Any, items: list):
    """``shape`` with faces textured on their own parameter space (see the module).

    Args:
        shape: the untextured part.
        items: one dict per face: ``face`` (OCP face of ``shape``), ``points``,
            ``normals`` ``(R, C, 3)`` (texcad's grid on the face, mm, outward),
            ``heights`` ``(R, C)`` mm, ``valid`` ``(R, C)`` bool, ``xs (C,)``, ``ys
            (R,)`` texture mm of the columns and rows, ``u_table``, ``v_table`` the
            ``(parameter, mm)`` tables (``y = Y(u)``, ``x = X(v)``), ``closed_u``.

    Each face becomes strips (:func:`texcad.brep.uvstrips.strip_faces`, for OCCT's
    plain volume rule), one face after the other (two faces sharing an edge, such as
    a knob's grip cone and its chamfer, each take the other's pieces of it), where
    that gives a valid solid; else one degree-1 B-spline face each, valid, whose
    plain-rule volume is then less exact (the adaptive one is not).

    A face whose outline is not the iso-line rectangle (trimmed inside it) is made
    of tiles on its own ``(u, v)`` instead (:func:`texcad.brep.uvtrim.trimmed_tiles`).

    Raises:
        GeometryError: no grid point lies on a face (or inside its (u, v) rectangle).
    """
    out = _uv_solid(shape, items, strips=True)
    if check_shape(out)["valid"]:
        return out
    return _uv_solid(shape, items, strips=False)


def _uv_solid(shape: Any, items: list, *, strips: bool):
    """:func:`uv_textured_solid` with each face as strips (where its outline allows)
    or as one face."""
    from OCP.TopoDS import TopoDS

    topo = to_topods(shape)
    for item in items:  # one per face, in turn: two faces sharing an edge (a knob's grip cone and chamfer) both cut it
        face = TopoDS.Face_s(to_topods(item["face"]))
        face = face_in(topo, face) if strips else face  # rebuilt if a face before it cut an edge of it
        if face is None:
            raise GeometryError("a face to texture on its own (u, v) was lost when its neighbour was cut into strips")
        u, v, top = _poles(face, item)
        got = strip_faces(face, u, v, top, bool(item["closed_u"]), _tolerance(face, u, v, top)) if strips else None
        if got is None:  # not the iso-line rectangle: tiles on the face's own (u, v), else one face
            tiled = trimmed_tiles(topo, face, u, v, top) if strips else None
            topo = tiled if tiled is not None else _replace_faces(topo, [(face, [_new_face(face, u, v, top)])])
            continue
        topo = _edges_cut(_replace_faces(topo, [(face, got[0])]), got[1])
    return topo


def _tolerance(face, u, v, top):
    """``tolerance(edge)``: mm an edge of ``face`` needs on the textured surface
    (``u``, ``v``, ``top`` as :func:`_poles`): its own, or 1.5 times its largest
    distance from it."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopoDS import TopoDS

    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    seen: list = []

    def tolerance(edge) -> float:
        got = next((t for e, t in seen if e.IsSame(edge)), None)
        if got is None:
            own = BRep_Tool.Tolerance_s(edge)
            got = own if BRep_Tool.Degenerated_s(edge) else max(own, 1.5 * _edge_deviation(edge, fwd, u, v, top) + TOLERANCE)
            seen.append((edge, got))
        return got

    return tolerance


def _edges_cut(shape, splits: list):
    """``shape`` with each edge of ``splits`` ``[(edge, pieces)]`` replaced by its
    pieces (in order along it) in every face that still has it (``BRepTools_ReShape``:
    a cone's caps take the pieces of the circle its strips were cut along)."""
    if not splits:
        return shape
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools_ReShape
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopoDS import TopoDS_Wire

    b, reshape = BRep_Builder(), BRepTools_ReShape()
    for edge, pieces in splits:  # one per cut edge
        w = TopoDS_Wire()
        b.MakeWire(w)
        for p in pieces:  # in order along the edge
            b.Add(w, p)
        reshape.Replace(edge.Oriented(TopAbs_FORWARD), w)
    return reshape.Apply(shape)


class _Projector:
    """Points projected onto a surface (mm -> ``(u, v)``), each starting from the last
    answer (``ShapeAnalysis_Surface::NextValueOfUV``: Newton steps, fast along a grid
    line; OCCT's global search only for the first point)."""

    def __init__(self, surf):
        from OCP.ShapeAnalysis import ShapeAnalysis_Surface

        self.sas = ShapeAnalysis_Surface(surf)
        self.last = None

    def __call__(self, p: np.ndarray) -> tuple[float, float]:
        from OCP.gp import gp_Pnt

        q = gp_Pnt(*map(float, p))
        uv = self.sas.ValueOfUV(q, 1e-9) if self.last is None else self.sas.NextValueOfUV(self.last, q, 1e-9)
        self.last = uv
        return float(uv.X()), float(uv.Y())

    def point(self, u: float, v: float) -> np.ndarray:
        return np.array(self.sas.Value(u, v).Coord())


def open_extrusion_solid(shape: Any, face: Any, top: np.ndarray, base: np.ndarray | None = None, *, fine=None):
    """``shape`` with a face of an open extruded profile (a partial cylinder, the
    sine sample's top) textured in place, **without a boolean**: the texture grid
    ``top`` (``(R, C, 3)`` mm; rows across the extrusion, columns along the profile,
    half a pixel inside the face, with walls at its border as texcad's mesh has) on
    the face's own ``(u, v)``, framed by rows of the face itself: its boundary, and
    ``1e-3`` of a cell inside the grid's border the face again (h = 0) - the
    mesh's walls, upright within that.

    The grid's parameters come from projecting its first column and, for the columns,
    ``base`` (``(C, 3)`` mm: the face's point under each column of the first row;
    without it the grid's first row) onto the surface; the surface's ``u`` and ``v``
    must follow the columns and rows (an extrusion: checked on the last row). The walls rise from the face under each border line (where the
    texture is lifted along z, e.g. the distance mapping, texcad's mesh walls meet
    the face up to h tan(slope) away: 0.07 mm on the sine sample).

    Returns:
        The new shape, or None where the face is not such an extrusion.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepTools import BRepTools
    from OCP.gp import gp_Pnt, gp_Vec
    from OCP.TopAbs import TopAbs_FORWARD
    from OCP.TopoDS import TopoDS

    old = TopoDS.Face_s(to_topods(face))
    fwd = TopoDS.Face_s(old.Oriented(TopAbs_FORWARD))
    g = np.asarray(top, np.float64)
    R, C = g.shape[:2]
    surf = BRep_Tool.Surface_s(fwd)
    proj = _Projector(surf)
    ad = BRepAdaptor_Surface(fwd, False)
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()

    def normal(a, c):
        ad.D1(a, c, p, du, dv)
        n = np.cross(du.Coord(), dv.Coord())
        return n / max(float(np.linalg.norm(n)), 1e-300)

    try:
        row = np.array([proj(q) for q in g[0]])  # per column
        col = np.array([proj(q) for q in g[:, 0]])  # per row
    except RuntimeError:
        return None
    swap = np.ptp(row[:, 0]) < np.ptp(row[:, 1])  # the columns follow v: transpose
    uc, vr = (row[:, 1], col[:, 0]) if swap else (row[:, 0], col[:, 1])
    step = max(1, C // 8)
    if base is not None and not swap:  # the columns' parameter: the face's point under each column
        uc = np.array([proj(q)[0] for q in np.asarray(base, np.float64)])  # per column
        last = uc[::step]  # the same under every row of an extrusion (dS/dv is checked below)
    else:
        last = np.array([proj(q) for q in g[-1, ::step]])[:, 1 if swap else 0]
    if np.abs(last - uc[::step]).max() > 1e-6 * (np.ptp(uc) + 1.0):
        return None  # the columns' parameter changes along them: not an extrusion's grid
    grid = g.transpose(1, 0, 2) if not swap else g  # axis 0 along u
    pu, pv = (uc, vr) if not swap else (vr, uc)
    if not (np.all(np.diff(pu) > 0) or np.all(np.diff(pu) < 0)) or not (np.all(np.diff(pv) > 0) or np.all(np.diff(pv) < 0)):
        return None
    if pu[0] > pu[-1]:
        pu, grid = pu[::-1], grid[::-1]
    if pv[0] > pv[-1]:
        pv, grid = pv[::-1], grid[:, ::-1]
    u0, u1, v0, v1 = BRepTools.UVBounds_s(fwd)
    ku, kv = _framed(pu, u0, u1), _framed(pv, v0, v1)
    if ku is None or kv is None:
        return None
    (U, su, gi), (V, sv, gj) = ku, kv

    def along_u(params):  # S(params, v0) and dS/dv there (one OCCT call per knot)
        pts, ds = [], []
        for a in params.tolist():  # per knot
            ad.D1(a, v0, p, du, dv)
            pts.append(p.Coord())
            ds.append(dv.Coord())
        return np.array(pts), np.array(ds)

    base, deriv = along_u(su)
    edge, _ = along_u(U)
    if np.abs(deriv - deriv[0]).max() > 1e-9 * (np.linalg.norm(deriv[0]) + 1.0):
        return None  # dS/dv varies along u: not an extrusion
    T = base[:, None, :] + (sv - v0)[None, :, None] * deriv[0]  # the face under every knot
    T[:, 0] = edge + (V[0] - v0) * deriv[0]  # the face's own boundary, at the knots
    T[:, -1] = edge + (V[-1] - v0) * deriv[0]
    T[0] = edge[0] + (V - v0)[:, None] * deriv[0]
    T[-1] = edge[-1] + (V - v0)[:, None] * deriv[0]
    T[np.ix_(gi, gj)] = grid
    # Tiles end at every frame line: the flat frame and the narrow walls are tiles of their own.
    frame = [np.concatenate([np.arange(1, k[0] + 1), np.arange(k[-1], n - 1)]) for k, n in ((gj, len(V)), (gi, len(U)))]
    out = tiled_in_place(shape, old, U, V, T, breaks=tuple(frame), fine=_fine_cells(T, fine))
    if out is not None:
        return out
    return _replace_faces(to_topods(shape), [(old, [_new_face(old, U, V, T)])])


def _fine_cells(T: np.ndarray, boxes) -> list | None:
    """Index rectangles ``(v0, v1, u0, u1[, cells])`` of the pole grid ``T`` (``(Nu,
    Nv, 3)`` mm) around the poles inside each box ``(lo (3,), hi (3,)[, cells])`` mm,
    one cell wider."""
    if not boxes:
        return None
    out = []
    for box in boxes:  # one per CAD operation's tool: (lo, hi[, cells])
        iu, iv = np.nonzero(((T >= np.asarray(box[0])) & (T <= np.asarray(box[1]))).all(axis=-1))
        if len(iu):
            out.append((max(int(iv.min()) - 1, 0), int(iv.max()) + 1, max(int(iu.min()) - 1, 0), int(iu.max()) + 1, *box[2:]))
    return out


def _framed(pg: np.ndarray, lo: float, hi: float):
    """Knots ``K`` for a grid's increasing parameters ``pg`` on a face's range ``[lo,
    hi]``, the parameter ``S`` of the face point under each knot, and the indices of
    the knots that carry the grid's lines. Around the grid: the face's bound (h = 0)
    and the face again ``1e-3`` of a cell before the grid's border line (h = 0, under
    that line: an upright wall, as texcad's mesh has); a border line on the bound
    itself stands ``1e-3`` of a cell inside it (its wall rises from the bound). None
    if the grid leaves the range."""
    e = 1e-3 * float(np.diff(pg).min())
    tol = 1e-6 * (abs(hi - lo) + 1.0)
    K = pg.astype(np.float64).copy()
    if pg[0] - lo > 4 * e:
        low_k, low_s = [lo, pg[0] - e], [lo, pg[0]]
    elif abs(pg[0] - lo) < tol:
        low_k, low_s = [lo], [lo]
        K[0] = lo + e
    else:
        return None
    if hi - pg[-1] > 4 * e:
        up_k, up_s = [pg[-1] + e, hi], [pg[-1], hi]
    elif abs(hi - pg[-1]) < tol:
        up_k, up_s = [hi], [hi]
        K[-1] = hi - e
    else:
        return None
    if len(K) > 1 and not np.all(np.diff(K) > 0):
        return None
    knots = np.concatenate([low_k, K, up_k])
    under = np.concatenate([low_s, pg, up_s])
    return knots, under, np.arange(len(low_k), len(low_k) + len(pg))


# -- a face replaced by tiles, sewn to its own boundary edges split at the tile corners -----------
def _sides(fwd, U: np.ndarray, V: np.ndarray) -> dict | None:
    """The face's boundary edge on each side of its ``(u, v)`` rectangle ``U[0] ..
    U[-1]`` x ``V[0] .. V[-1]``: ``{"v0": (edge, increasing), ...}`` (``increasing``:
    the edge's parameter runs towards higher ``u`` or ``v``), or None unless there are
    exactly four edges, one per side, none a seam or degenerate."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    edges = explore(fwd, TopAbs_EDGE)
    tol = 1e-7 * (abs(U[-1] - U[0]) + abs(V[-1] - V[0]) + 1.0)
    out: dict = {}
    for e in edges:  # 4 edges
        edge = TopoDS.Edge_s(e)
        if BRep_Tool.IsClosed_s(edge, fwd) or BRep_Tool.Degenerated_s(edge):
            return None
        c2 = BRepAdaptor_Curve2d(edge, fwd)
        a, b = np.array(c2.Value(c2.FirstParameter()).Coord()), np.array(c2.Value(c2.LastParameter()).Coord())
        for name, axis, val in (("u0", 0, U[0]), ("u1", 0, U[-1]), ("v0", 1, V[0]), ("v1", 1, V[-1])):  # 4 sides
            if abs(a[axis] - val) < tol and abs(b[axis] - val) < tol and name not in out:
                out[name] = (edge, bool(b[1 - axis] > a[1 - axis]))
                break
        else:
            return None
    return out if len(out) == 4 and len(edges) == 4 else None


def _split_edge(b, edge, fwd, points2d: np.ndarray, increasing: bool, tol: float):
    """``edge`` split at the parameters whose pcurve on ``fwd`` passes ``points2d``
    (``(n, 2)``, in the order of the tile corners, ends included): ``(vertices,
    pieces along the edge, pieces oriented towards the higher index)``."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.Geom2dAPI import Geom2dAPI_ProjectPointOnCurve
    from OCP.gp import gp_Pnt, gp_Pnt2d
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS, TopoDS_Edge, TopoDS_Vertex

    ad = BRepAdaptor_Curve(edge)
    f, l = ad.FirstParameter(), ad.LastParameter()
    curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
    pc = BRep_Tool.CurveOnSurface_s(edge, fwd, 0.0, 0.0)
    if curve is None or pc is None:
        return None
    ts = [f if increasing else l]
    for q in points2d[1:-1]:  # per inner tile corner on the side
        pr = Geom2dAPI_ProjectPointOnCurve(gp_Pnt2d(float(q[0]), float(q[1])), pc, f, l)
        if pr.NbPoints() < 1:
            return None
        ts.append(pr.LowerDistanceParameter())
    ts.append(l if increasing else f)
    ts = np.array(ts)
    if not (np.all(np.diff(ts) > 0) if increasing else np.all(np.diff(ts) < 0)):
        return None
    first, last = TopExp.FirstVertex_s(edge), TopExp.LastVertex_s(edge)  # at f and at l (edge orientation ignored)
    verts = [first if increasing else last]
    for t in ts[1:-1].tolist():  # per inner tile corner
        v = TopoDS_Vertex()
        b.MakeVertex(v, gp_Pnt(*ad.Value(t).Coord()), tol)
        verts.append(v)
    verts.append(last if increasing else first)
    along, oriented = [], []
    for k in range(len(ts) - 1):  # per piece
        lo, hi = (k, k + 1) if increasing else (k + 1, k)
        piece = TopoDS_Edge()
        b.MakeEdge(piece, curve, tol)
        b.Add(piece, verts[lo].Oriented(TopAbs_FORWARD))
        b.Add(piece, verts[hi].Oriented(TopAbs_REVERSED))
        b.Range(piece, float(ts[lo]), float(ts[hi]))
        along.append(piece)
        oriented.append((piece if increasing else TopoDS.Edge_s(piece.Reversed()), pc))
    if not increasing:
        along = along[::-1]
    return verts, along, oriented


def _with_pieces(b, face, pieces: dict, tol: dict):
    """A copy of ``face`` (same surface, location and orientation) whose wires have
    each edge of ``pieces`` (``{edge: [pieces along it]}``) replaced by its pieces,
    which get the edge's pcurves on it."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS, TopoDS_Iterator, TopoDS_Wire

    new = TopoDS.Face_s(face.EmptyCopied())
    for edge, along in pieces.items():  # the replaced edges on this face
        if BRep_Tool.IsClosed_s(edge, face):
            c1 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(edge.Oriented(TopAbs_FORWARD)), face, 0.0, 0.0)
            c2 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(edge.Oriented(TopAbs_REVERSED)), face, 0.0, 0.0)
            for p in along:  # per piece
                b.UpdateEdge(p, c1, c2, face, tol[edge])
        else:
            c = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
            for p in along:  # per piece
                b.UpdateEdge(p, c, face, tol[edge])
    wit = TopoDS_Iterator(face)
    while wit.More():  # per wire
        w = TopoDS_Wire()
        b.MakeWire(w)
        eit = TopoDS_Iterator(wit.Value())
        while eit.More():  # per edge of the wire
            e = eit.Value()
            key = next((k for k in pieces if k.IsSame(e)), None)
            if key is None:
                b.Add(w, e)
            elif e.Orientation() == TopAbs_FORWARD:
                for p in pieces[key]:  # per piece
                    b.Add(w, p)
            elif e.Orientation() == TopAbs_REVERSED:
                for p in reversed(pieces[key]):  # per piece
                    b.Add(w, p.Reversed())
            else:
                return None
            eit.Next()
        w.Closed(wit.Value().Closed())
        b.Add(new, w)
        wit.Next()
    return new


def tiled_in_place(shape: Any, face: Any, U: np.ndarray, V: np.ndarray, T: np.ndarray, *, tile: int = TILE, breaks=((), ()),
                   fine=None):
    """``shape`` with ``face`` replaced by the degree-1 surface through the poles
    ``T`` (``(len(U), len(V), 3)`` mm) on the face's own ``(u, v)`` knots ``U`` x
    ``V`` (whose outer rows are the face's boundary), made as **tiles** of at most
    ``tile`` x ``tile`` cells (:func:`texcad.solid.tiled_grid_faces`, each carrying its
    grid triangulation) sewn to the face's own boundary edges, split at the tile
    corners (tiles also end at the grid lines ``breaks``, ``(v indices, u indices)``,
    see :func:`texcad.solid.tiled_grid_faces`); the neighbouring faces get the same
    pieces in place of each edge; ``fine``: index rectangles ``(v0, v1, u0, u1)``
    where the tiles are small (:data:`texcad.solid.FINE`). No
    boolean, no sewing: every edge is shared by construction. The pieces' tolerance
    grows by the chord between the edge and the bilinear tiles (sampled).

    Returns:
        The new shape, or None unless the face has four boundary edges, one per side
        of its ``(u, v)`` rectangle (then use one face, :func:`uv_textured_solid`'s way).
    """
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_VERTEX
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    topo, old = to_topods(shape), TopoDS.Face_s(to_topods(face))
    fwd = TopoDS.Face_s(old.Oriented(TopAbs_FORWARD))
    sides = _sides(fwd, U, V)
    if sides is None:
        return None
    b = BRep_Builder()
    tol, pieces, failed = {}, {}, []
    for edge, _ in sides.values():  # 4 edges
        tol[edge] = max(BRep_Tool.Tolerance_s(edge), 1.5 * _edge_deviation(edge, fwd, U, V, T) + TOLERANCE)
        for x in explore(edge, TopAbs_VERTEX):  # its two vertices
            vx = TopoDS.Vertex_s(x)
            b.UpdateVertex(vx, max(BRep_Tool.Tolerance_s(vx), tol[edge]))

    def outline(name: str, stops: np.ndarray):
        edge, increasing = sides[name]
        pts = np.stack([U[stops], np.full(len(stops), V[0 if name == "v0" else -1])], axis=1) if name[0] == "v" else \
            np.stack([np.full(len(stops), U[0 if name == "u0" else -1]), V[stops]], axis=1)  # fmt: skip
        got = _split_edge(b, edge, fwd, pts, increasing, tol[edge])
        if got is None:
            failed.append(name)
            raise GeometryError(f"internal: the face's {name} edge cannot be split at the tile corners")
        verts, along, oriented = got
        pieces[edge] = along
        return verts, oriented

    grid = np.ascontiguousarray(np.asarray(T, np.float64).transpose(1, 0, 2))  # rows along v, columns along u
    try:
        tiles, _ = tiled_grid_faces(grid, np.asarray(U, np.float64), np.asarray(V, np.float64), tile=tile, outline=outline, breaks=breaks, fine=fine)
    except GeometryError:
        if failed:
            return None
        raise
    if old.Orientation() == TopAbs_REVERSED:
        tiles = [TopoDS.Face_s(t.Reversed()) for t in tiles]
    owners = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(topo, TopAbs_EDGE, TopAbs_FACE, owners)
    neighbours: list = []
    for edge in pieces:  # 4 edges
        for f in owners.FindFromKey(edge):  # the faces along it (two)
            if f.IsSame(old):
                continue
            hit = next((n for n in neighbours if n[0].IsSame(f)), None)
            if hit is None:
                neighbours.append((TopoDS.Face_s(f), {}))
                hit = neighbours[-1]
            hit[1][edge] = pieces[edge]
    swaps = [(old, tiles)]
    for f, mine in neighbours:  # 4 faces at most
        new = _with_pieces(b, f, mine, tol)
        if new is None:
            return None
        swaps.append((f, [new]))
    return _replace_faces(topo, swaps)


# -- a planar face with holes: tiles where the texture is, planar faces around them --------------
def _dirty_cells(old, o, ex, ey, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(dirty, segs)``: ``(R - 1, C - 1)`` bool, the grid cells that the face's
    outline touches (sampled every quarter cell, then grown by one cell) or whose
    centre lies outside the face; ``segs`` the outline in the face frame (mm)."""
    from scipy.ndimage import binary_dilation

    from .solids import face_segments, inside, sample_segments

    step = 0.25 * float(min(x[1] - x[0], y[1] - y[0]))
    seg3 = face_segments(old, step) - o
    segs = np.stack([seg3 @ ex, seg3 @ ey], axis=-1)
    pts = sample_segments(segs, step)
    R, C = len(y), len(x)
    hit = np.zeros((R - 1, C - 1), bool)
    ci = np.clip(np.searchsorted(x, pts[:, 0]) - 1, 0, C - 2)
    ri = np.clip(np.searchsorted(y, pts[:, 1]) - 1, 0, R - 2)
    hit[ri, ci] = True
    hit = binary_dilation(hit, np.ones((3, 3), bool))
    centre = inside(segs, 0.5 * (x[1:] + x[:-1]), 0.5 * (y[1:] + y[:-1]))
    return hit | ~centre, segs


def _quad_leaves(want: np.ndarray, dirty: np.ndarray, tile: int, fine) -> list | None:
    """Rectangles of cells ``(r0, r1, c0, c1)`` covering every ``want`` cell with
    clean cells only: :func:`~texcad.solid.brep._leaves` tiles, halved until clean
    (down to single cells); None if a wanted cell is dirty."""
    from .solids import _leaves

    if (want & dirty).any():
        return None
    cw = np.pad(np.cumsum(np.cumsum(want, 0), 1), ((1, 0), (1, 0)))  # summed-area tables
    cd = np.pad(np.cumsum(np.cumsum(dirty, 0), 1), ((1, 0), (1, 0)))

    def count(t, r0, r1, c0, c1):
        return t[r1, c1] - t[r0, c1] - t[r1, c0] + t[r0, c0]

    out, todo = [], list(_leaves(want.shape[0], want.shape[1], tile, fine))
    while todo:  # one per rectangle looked at (tiles, halved near the outline)
        r0, r1, c0, c1 = todo.pop()
        if not count(cw, r0, r1, c0, c1):
            continue
        if not count(cd, r0, r1, c0, c1):
            out.append((r0, r1, c0, c1))
        elif r1 - r0 >= c1 - c0:
            m = (r0 + r1) // 2
            todo += [(r0, m, c0, c1), (m, r1, c0, c1)]
        else:
            m = (c0 + c1) // 2
            todo += [(r0, r1, c0, m), (r0, r1, m, c1)]
    return sorted(out)


def _cover(want: np.ndarray, dirty: np.ndarray, tile: int, fine) -> tuple[list, np.ndarray] | None:
    """Tiles over the wanted cells whose union has no pinch (two tiles meeting at a
    corner only: add the clean cells beside it, up to 8 rounds); ``(leaves, (R - 1,
    C - 1) covered cells)`` or None."""
    for _ in range(8):  # rounds of pinches filled
        leaves = _quad_leaves(want, dirty, tile, fine)
        if leaves is None:
            return None
        m = np.zeros_like(want)
        for r0, r1, c0, c1 in leaves:  # one per tile
            m[r0:r1, c0:c1] = True
        a, b, c, d = m[:-1, :-1], m[:-1, 1:], m[1:, :-1], m[1:, 1:]
        pinch = (a & d & ~b & ~c) | (b & c & ~a & ~d)
        if not pinch.any():
            return leaves, m
        add = np.zeros_like(want)
        add[:-1, :-1] |= pinch & ~a
        add[:-1, 1:] |= pinch & ~b
        add[1:, :-1] |= pinch & ~c
        add[1:, 1:] |= pinch & ~d
        want = want | add
    return None


def _loops(edges: dict, m: np.ndarray) -> list:
    """The boundary of the covered cells ``m`` as closed loops of tile edges, each
    ``[(edge, param_line, (r, c) start), ...]`` running the way the tiles run them
    (counter-clockwise about the cells)."""
    from OCP.TopoDS import TopoDS

    R, C = m.shape

    def cell(r, c):
        return bool(0 <= r < R and 0 <= c < C and m[r, c])

    nxt = {}
    for (horizontal, line, a, z), (e, pl) in edges.items():  # every tile edge
        if horizontal:
            above, below = cell(line, a), cell(line - 1, a)
            if above == below:
                continue
            ends = ((line, a), (line, z)) if above else ((line, z), (line, a))
            fwd = above
        else:
            right, left = cell(a, line), cell(a, line - 1)
            if right == left:
                continue
            ends = ((z, line), (a, line)) if right else ((a, line), (z, line))
            fwd = not right
        nxt[ends[0]] = (e if fwd else TopoDS.Edge_s(e.Reversed()), pl, ends[0], ends[1])
    loops = []
    while nxt:  # one per loop
        start = next(iter(nxt))
        loop, at = [], start
        while True:  # one per edge of the loop
            e, pl, a, z = nxt.pop(at)
            loop.append((e, pl, a))
            at = z
            if at == start:
                break
        loops.append(loop)
    return loops


def _loop_item(segs: np.ndarray, **kw) -> dict:
    """A closed loop given by its oriented 2-D segments ``(K, 2, 2)`` mm: signed area
    (Green's theorem, summed segment by segment: any order) and one point on it."""
    a, b = segs[:, 0], segs[:, 1]
    area = 0.5 * float((a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum())
    return dict(kw, segs=segs, area=area, point=segs[0, 0])


def _wire_segments(w, o, ex, ey, spacing: float) -> np.ndarray:
    """A wire of the face as oriented 2-D segments ``(K, 2, 2)`` in the face frame
    (mm): each edge sampled every <= ``spacing`` mm, run the way the wire runs it."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS

    from .solids import edge_points

    segs = []
    for e in explore(w, TopAbs_EDGE):  # one per edge of the wire (its orientation composed in)
        p = edge_points(TopoDS.Edge_s(e), spacing)
        p = (p[::-1] if e.Orientation() == TopAbs_REVERSED else p) - o
        q = np.stack([p @ ex, p @ ey], axis=-1)
        segs.append(np.stack([q[:-1], q[1:]], axis=1))
    return np.concatenate(segs)


def _fine_index(fine, x: np.ndarray, y: np.ndarray) -> list:
    """Rectangles ``(x0, x1, y0, y1)`` mm in the face frame as cell index rectangles."""
    idx = []
    for f in fine or ():  # one per tool: (x0, x1, y0, y1[, cells])
        ca, cz = np.searchsorted(x, [f[0], f[1]]) + np.array([-1, 1])
        ra, rz = np.searchsorted(y, [f[2], f[3]]) + np.array([-1, 1])
        idx.append((max(int(ra), 0), int(rz), max(int(ca), 0), int(cz), *f[4:]))
    return idx


def _plane_regions(items: list) -> list | None:
    """Group closed loops (:func:`_loop_item`, each
    oriented with its region on the left) into faces: each counter-clockwise loop
    with the clockwise loops it is the smallest to contain. None if a hole has no
    loop around it."""
    from .solids import inside

    outers = [i for i in items if i["area"] > 0]
    faces = [[o] for o in outers]
    for hole in (i for i in items if i["area"] <= 0):  # one per hole
        p = hole["point"]
        best = None
        for k, o in enumerate(outers):  # the loops around it
            if inside(o["segs"], np.array([p[0]]), np.array([p[1]]))[0, 0] and (best is None or o["area"] < outers[best]["area"]):
                best = k
        if best is None:
            return None
        faces[best].append(hole)
    return faces


def _plane_face(b, surf, pln, loops: list, placed: bool = False):
    """A planar face on ``surf`` (the face frame's plane ``pln``) bounded by
    ``loops``: the part's own wires (``"wire"``, oriented for the outward normal) or
    tile boundary loops (``"loop"``, run the tiles' way: reversed here). ``placed``:
    the tiles' knots are not mm (placed for OCCT's plain rule,
    :func:`texcad.brep.gprop.run_knots`): each tile edge's pcurve is its 3-D curve
    (a degree-1 polyline in the plane) projected on ``pln``, the same parameters
    (an affine map of the poles), else the straight line ``param_line``."""
    from OCP.BRep import BRep_Tool
    from OCP.Geom2d import Geom2d_Line
    from OCP.GeomAPI import GeomAPI
    from OCP.gp import gp_Dir2d, gp_Pnt2d
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS, TopoDS_Face, TopoDS_Wire

    from .solids import TOLERANCE

    f = TopoDS_Face()
    b.MakeFace(f, surf, TOLERANCE)
    for item in loops:  # outer loop, then holes
        if "wire" in item:
            b.Add(f, item["wire"])
            for e in explore(item["wire"], TopAbs_EDGE):  # one per edge of the part's wire
                edge = TopoDS.Edge_s(e)
                curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
                if curve is None:
                    raise GeometryError("an edge of the face has no 3-D curve; rebuild the part (BRepLib.BuildCurves3d)")
                b.UpdateEdge(edge, GeomAPI.To2d_s(curve, pln), f, TOLERANCE)
            continue
        w = TopoDS_Wire()
        b.MakeWire(w)
        for e, pl, _ in reversed(item["loop"]):  # one per tile edge on the loop
            b.Add(w, e.Reversed())
            pc = GeomAPI.To2d_s(BRep_Tool.Curve_s(TopoDS.Edge_s(e), 0.0, 0.0), pln) if placed else Geom2d_Line(gp_Pnt2d(pl[0], pl[1]), gp_Dir2d(pl[2], pl[3]))
            b.UpdateEdge(TopoDS.Edge_s(e), pc, f, TOLERANCE)
        w.Closed(True)
        b.Add(f, w)
    return f


def holed_plane_solid(shape: Any, face: Any, heights: np.ndarray, x: np.ndarray, y: np.ndarray, *, origin, xdir, normal,
                      tile: int = TILE, fine=None, flatten_outline: bool = False):  # fmt: skip
    """``shape`` with a planar ``face`` of any outline (holes, pockets, notches)
    textured in place, **in tiles, without a boolean**: the grid cells where the
    texture leaves the plane are covered by tiles (:func:`texcad.solid.tiled_grid_faces`,
    at most ``tile`` cells a side, halved down to single cells where the face's
    outline comes near: no tile touches it), and the rest of the face stays planar:
    one planar face per region between the face's own wires and the tiles' boundary
    loops (a texture ring around a hole leaves a planar island around it). Every edge
    is shared: closed by construction. The tiles' knots are placed for OCCT's plain
    volume rule as on a rectangular top (:func:`texcad.brep.gprop.run_knots` over the
    grid's runs, knots of their own on the tiles halved near the outline,
    ``tiled_grid_faces(relay=True)``): with the grid's mm knots a run of 21 cells
    under one 61-point rule put a heat sink's plain volume 1.6 % over (4 mm pins at
    0.5 mm), now 0.004 %. Arguments as
    :func:`texcad.solid.textured_plane_face` (mm; ``heights`` exactly 0 on every cell
    the outline crosses), ``fine`` as :func:`texcad.solid.tiled_plane_solid`.
    ``flatten_outline``: set the heights to 0 on every cell within two cells of the
    outline instead (a relief that runs on to the outline, such as an engraving's
    20 um floor).

    Returns:
        The new shape, or None where the tiles cannot avoid the outline (a lifted
        cell it touches) or the regions do not nest.
    """
    from OCP.BRep import BRep_Builder
    from OCP.Geom import Geom_Plane
    from OCP.TopoDS import TopoDS, TopoDS_Iterator

    from .gprop import run_knots
    from .solids import _frame_pln, _split_bounds

    old = TopoDS.Face_s(to_topods(face))
    o, ex, n = (np.asarray(a, np.float64) for a in (origin, xdir, normal))
    ey = np.cross(n, ex)
    h = np.asarray(heights, np.float64)
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    dirty, _ = _dirty_cells(old, o, ex, ey, x, y)
    if flatten_outline:
        near = np.zeros(h.shape, bool)
        for a, b in ((slice(None, -1), slice(None, -1)), (slice(None, -1), slice(1, None)), (slice(1, None), slice(None, -1)), (slice(1, None), slice(1, None))):
            near[a, b] |= dirty  # the 4 corners of each cell
        h = np.where(near, 0.0, h)
    up = h != 0
    want = up[:-1, :-1] | up[:-1, 1:] | up[1:, :-1] | up[1:, 1:]
    if not want.any():
        return None
    got = _cover(want, dirty, tile, _fine_index(fine, x, y))
    if got is None:
        return None
    leaves, covered = got
    grid = o + x[None, :, None] * ex + y[:, None, None] * ey + h[..., None] * n
    edges: dict = {}
    xk, yk = run_knots(x, _split_bounds(len(x) - 1, tile)), run_knots(y, _split_bounds(len(y) - 1, tile))  # for OCCT's plain Gauss rule
    tiles, _ = tiled_grid_faces(grid, xk, yk, tile=tile, leaves=leaves, edges_out=edges, relay=True)
    items = []
    for loop in _loops(edges, covered):  # the tiles' boundary loops, reversed for the plane
        poly = np.array([(x[c], y[r]) for _, _, (r, c) in loop])[::-1]
        items.append(_loop_item(np.stack([poly, np.roll(poly, -1, axis=0)], axis=1), loop=loop))
    it = TopoDS_Iterator(old)  # the face's wires, its orientation composed in
    while it.More():  # one per wire (outline and holes)
        segs = _wire_segments(it.Value(), o, ex, ey, 0.25 * float(min(x[1] - x[0], y[1] - y[0])))
        items.append(_loop_item(segs, wire=it.Value()))
        it.Next()
    regions = _plane_regions(items)
    if regions is None:
        return None
    b = BRep_Builder()
    pln = _frame_pln(o, n, ex)
    surf = Geom_Plane(pln)
    flats = [_plane_face(b, surf, pln, loops, placed=True) for loops in regions]  # one per planar region
    return _replace_faces(to_topods(shape), [(old, flats + list(tiles))])


def textured_plane_solid(
    shape: Any,
    face: Any,
    heights: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    *,
    origin: Sequence[float],
    xdir: Sequence[float],
    normal: Sequence[float],
    tile: int = TILE,
    fine: Sequence | None = None,
):
    """``shape`` with the planar ``face`` textured in place (arguments as
    :func:`textured_plane_face`, mm; ``fine`` as :func:`tiled_plane_solid`): in
    tiles that carry texcad's mesh (:func:`tiled_plane_solid`) where the textured
    rectangle lies inside the face,
    else as one B-spline face trimmed by the face's own wires
    (:func:`textured_plane_face` + :func:`~texcad.brep.solids.replace_face`: the same solid, slower for
    OCCT's mesher and booleans)."""
    frame = dict(origin=origin, xdir=xdir, normal=normal)
    out = tiled_plane_solid(shape, face, heights, x, y, tile=tile, fine=fine, **frame)
    if out is None:  # an outline inside the textured rectangle (holes, pockets, notches)
        out = holed_plane_solid(shape, face, heights, x, y, tile=tile, fine=fine, **frame)
    if out is not None:
        return out
    return replace_face(shape, face, textured_plane_face(face, heights, x, y, **frame))


# -- CAD work on a face textured on its own (u, v): the operation on the plain part, the texture again --
def uv_face_pairs(base: Any, textured: Any) -> list | None:
    """``[(face of base, face whose edges it had, (grid (Nv, Nu, 3) mm, u, v)), ...]``
    for a B-rep made by :func:`uv_textured_solid` from ``base``: every face of
    ``base`` missing from ``textured`` matched to what replaced it - its strips
    (:func:`texcad.brep.uvstrips.strip_faces`: the whole face's grid on the face's
    own parameters, and the face itself) or the one degree-1 B-spline face (the same
    ``(u, v)`` rectangle, the nearest at its middle; itself); faces that only took
    the pieces of a cut edge (a cone's caps: same surface) need nothing. None for any
    other B-rep (tiles, a boolean's result)."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    from .solids import surface_grid, tile_grid

    old_faces = [TopoDS.Face_s(f) for f in explore(to_topods(base), TopAbs_FACE)]
    new_faces = [TopoDS.Face_s(f) for f in explore(to_topods(textured), TopAbs_FACE)]
    gone = [f for f in old_faces if not any(f.IsSame(g) for g in new_faces)]
    added = [f for f in new_faces if not any(f.IsSame(g) for g in old_faces)]
    wholes, grids, others = [], [], []
    for f in added:  # one per new face: a strip, a whole textured face, or a face that took pieces
        surf = BRep_Tool.Surface_s(f)
        origin = strip_origin(surf)
        if origin is not None:
            if not any(origin[0].IsSame(w[0]) for w in wholes):
                wholes.append(origin)
            continue
        got = tile_grid(surf) or surface_grid(surf)
        if got is None:
            others.append(surf)
        else:
            grids.append((f, got))
    pairs = []
    for f in gone:  # one per replaced face
        whole = next((w for w in wholes if w[0].IsSame(f)), None)
        if whole is not None:
            pairs.append((f, _kept_edges(whole[0], whole[2]), whole[1:]))
            continue
        best = _same_rectangle(f, grids)
        if best is not None:
            pairs.append((f, *best))
        elif not any(_same_surface(BRep_Tool.Surface_s(f), s) for s in others):
            return None
    return pairs if pairs else None


def _same_surface(a, b) -> bool:
    """Do two OCCT surfaces (a face and its copy with the pieces of a cut edge) give
    the same points at three parameters?"""
    if a.DynamicType().Name() != b.DynamicType().Name():
        return False
    pts = [(0.0, 0.0), (1.0, 0.5), (0.3, 2.0)]
    return all(a.Value(*q).Distance(b.Value(*q)) < 1e-12 for q in pts)


def _kept_edges(face, u: np.ndarray):
    """A compound of the edges of ``face`` its textured version keeps (all but a
    seam along v, which the lifted seam row replaces)."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD
    from OCP.TopoDS import TopoDS

    from .occt import compound

    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    edges = [TopoDS.Edge_s(e) for e in explore(fwd, TopAbs_EDGE)]
    return compound([e for e in edges if not (_used_twice(fwd, e) and _u_seam(e, fwd, u))])


def _same_rectangle(f, grids: list):
    """``(textured face, grid)`` of ``grids`` ``[(face, (grid, u, v))]`` on ``f``'s
    ``(u, v)`` rectangle, the nearest at its middle; None if none is."""
    from OCP.BRepTools import BRepTools

    u0, u1, v0, v1 = BRepTools.UVBounds_s(f)
    mid = _surface_rows(f, np.array([0.5 * (u0 + u1)]), np.array([0.5 * (v0 + v1)]))[0][0, 0]
    best, dist = None, np.inf
    for face, (g, u, v) in grids:  # the textured faces on the same rectangle
        if not np.allclose([u[0], u[-1], v[0], v[-1]], [u0, u1, v0, v1], rtol=0, atol=1e-9 * (abs(u1 - u0) + abs(v1 - v0))):
            continue
        d = float(np.linalg.norm(_bilinear(u, v, g.transpose(1, 0, 2), np.array([[0.5 * (u0 + u1), 0.5 * (v0 + v1)]]))[0] - mid))
        if d < dist:
            best, dist = (face, (g, u, v)), d
    return best


def _crossed_cells(face, edges, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``(Nu - 1, Nv - 1)`` bool: the cells of the knot grid ``u x v`` that the
    pcurves of ``edges`` on ``face`` pass through (sampled 16 times per cell of the
    grid's size)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.TopoDS import TopoDS

    hit = np.zeros((len(u) - 1, len(v) - 1), bool)
    n = 16 * (len(u) + len(v)) + 8
    for e in edges:  # one per edge made by the operations
        c2 = BRepAdaptor_Curve2d(TopoDS.Edge_s(e), face)
        ts = np.linspace(c2.FirstParameter(), c2.LastParameter(), n)
        q = np.array([c2.Value(float(t)).Coord() for t in ts])  # per sample
        i = np.clip(np.searchsorted(u, q[:, 0]) - 1, 0, len(u) - 2)
        j = np.clip(np.searchsorted(v, q[:, 1]) - 1, 0, len(v) - 2)
        hit[i, j] = True
    return hit


#: Each knot interval a new edge crosses is split in this many (the same surface, more
#: poles), so that only a quarter cell around a hole's rim is made plain.
SPLIT = 4


def _refined(u: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The knots ``u`` with ``SPLIT - 1`` more inside each interval ``rows`` marks."""
    i = np.nonzero(rows)[0]
    extra = (u[i, None] + (u[i + 1] - u[i])[:, None] * (np.arange(1, SPLIT) / SPLIT)[None, :]).ravel()
    return np.unique(np.concatenate([u, extra]))


def _plain_near(face, textured, u: np.ndarray, v: np.ndarray, top: np.ndarray) -> tuple:
    """``(u, v, top, seam_cut)``: a textured face's knots and poles (``(Nu, Nv, 3)``
    mm) with the relief taken off (the poles put back on ``face``'s surface) at the
    corners of every cell that an edge of ``face`` not on ``textured`` passes (a
    hole's rim: the hole's wall stays plain); the knot intervals those edges cross are
    split in :data:`SPLIT` first (knot insertion: the same surface), so the plain
    rim is a quarter cell wide. ``seam_cut``: the u-seam was cut (its rows made plain)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD
    from OCP.TopoDS import TopoDS

    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    own = explore(textured, TopAbs_EDGE)
    new, seam_cut = [], False
    span = abs(v[-1] - v[0])
    for e in explore(fwd, TopAbs_EDGE):  # one per edge of the face after the operations
        edge = TopoDS.Edge_s(e)
        if BRep_Tool.Degenerated_s(edge) or any(edge.IsSame(o) for o in own):
            continue
        if _used_twice(fwd, edge) and _u_seam(edge, fwd, u):
            c2 = BRepAdaptor_Curve2d(edge, fwd)
            seam_cut |= abs(c2.Value(c2.LastParameter()).Y() - c2.Value(c2.FirstParameter()).Y()) < span * (1 - 1e-9)
            continue
        new.append(edge)
    if new:  # knot insertion where the new edges run (degree 1: the bilinear surface at the new knots)
        coarse = _crossed_cells(fwd, new, u, v)
        u2, v2 = _refined(u, coarse.any(axis=1)), _refined(v, coarse.any(axis=0))
        q = np.stack(np.meshgrid(u2, v2, indexing="ij"), axis=-1).reshape(-1, 2)
        top = _bilinear(u, v, top, q).reshape(len(u2), len(v2), 3)
        u, v = u2, v2
    out = top.copy()
    cells = _crossed_cells(fwd, new, u, v) if new else np.zeros((len(u) - 1, len(v) - 1), bool)
    corners = np.zeros(top.shape[:2], bool)
    corners[:-1, :-1] |= cells
    corners[1:, :-1] |= cells
    corners[:-1, 1:] |= cells
    corners[1:, 1:] |= cells
    if seam_cut:
        corners[0] = corners[-1] = True
    ri, ci = np.nonzero(corners)
    if len(ri):
        from OCP.BRepAdaptor import BRepAdaptor_Surface

        ad = BRepAdaptor_Surface(fwd, False)
        out[ri, ci] = np.array([ad.Value(float(u[a]), float(v[c])).Coord() for a, c in zip(ri.tolist(), ci.tolist())])
    return u, v, out, seam_cut


def uv_retextured_solid(shape: Any, faces: list) -> Any:
    """``shape`` (the plain part after CAD operations) with its faces textured again
    from their textured B-rep: ``faces`` ``[(pieces, textured face, (grid, u, v)),
    ...]``, ``pieces`` the faces of ``shape`` the operations made of the plain face
    (OCCT's history), ``grid``, ``u``, ``v`` the textured face's poles (``(Nv, Nu,
    3)`` mm) and knots (:func:`uv_face_pairs`). Each piece gets the textured
    surface, its relief taken off around the edges the operations made (the wall of
    a hole stays plain), and keeps its own wires (:func:`_new_face`).

    Raises:
        GeometryError: a piece's edge lies off the new surface by more than 0.05 mm.
    """
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    made = []
    for pieces, textured, (grid, u, v) in faces:  # one per textured face
        top0 = np.ascontiguousarray(np.asarray(grid, np.float64).transpose(1, 0, 2))
        for piece in pieces:  # the faces the operations left of it
            f = TopoDS.Face_s(piece)
            made.append((f, *_plain_near(f, textured, np.asarray(u, np.float64), np.asarray(v, np.float64), top0)))
    tiled = _retextured_tiles(shape, made)
    if tiled is not None:
        return tiled
    swaps = []
    for f, uk, vk, top, seam_cut in made:  # one face each (OCCT's plain volume rule is then less exact)
        new = _new_face(f, uk, vk, top, keep_seam=seam_cut)
        worst = max((BRep_Tool.Tolerance_s(TopoDS.Edge_s(e)) for e in explore(new, TopAbs_EDGE)), default=0.0)
        if worst > 0.05:
            raise GeometryError(f"an edge of the operated face lies {worst:.3f} mm off its textured surface")
        swaps.append((f, [new]))
    return _replace_faces(to_topods(shape), swaps) if swaps else to_topods(shape)


def _retextured_tiles(shape: Any, made: list):
    """``shape`` with each piece of ``made`` ``[(piece, u, v, top, seam cut)]`` in tiles
    on its own ``(u, v)`` (:func:`texcad.brep.uvtrim.trimmed_tiles`: OCCT's plain
    volume rule right on them), one piece after the other (a piece is looked up again
    when an earlier one's cut lines split its edges); None unless every piece is
    tiled, no edge lies more than 0.05 mm off its tiles, and the result is valid."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    topo = to_topods(shape)
    for f, uk, vk, top, _ in made:  # one per piece
        face = face_in(topo, f)
        out = None if face is None else trimmed_tiles(topo, face, uk, vk, top)
        if out is None:
            return None
        topo = out
    worst = max((BRep_Tool.Tolerance_s(TopoDS.Edge_s(e)) for e in explore(topo, TopAbs_EDGE)), default=0.0)
    return topo if worst <= 0.05 and check_shape(topo)["valid"] else None
