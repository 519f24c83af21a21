"""B-rep of textured solids: B-spline faces through texture grids, and STEP files.

STL and 3MF come from texcad's own meshes; STEP needs a boundary representation. This
module builds it from the same vertex grids the meshes use (paper, section 2.3: the
CAD model generation that the paper did in Rhino/Grasshopper), with OCCT (OCP):

* :func:`grid_surface` / :func:`grid_face` - a **degree-1 B-spline surface** whose
  poles are the grid vertices. With degree 1 and knots ``u_0 < u_1 < ...`` (simple
  inner knots, end knots of multiplicity 2) the surface interpolates every vertex and
  is bilinear on each cell::

      S(u, v) = sum_ij N_i(u) N_j(v) P_ij,   N_i the hat function on [u_{i-1}, u_{i+1}]

  texcad's meshes split each cell into the two triangles ``(a, b, c)``, ``(a, c, d)``
  (:func:`texcad.solid.grid_faces`). Over a flat grid the volume under the bilinear
  patch is ``A (z_a + z_b + z_c + z_d) / 4`` and under the two triangles
  ``A (2 z_a + z_b + 2 z_c + z_d) / 6``; they differ by ``A (z_a + z_c - z_b - z_d)
  / 12``, which **telescopes** over the grid to the four corner heights: the B-rep
  and the mesh enclose the same volume up to ``A |z_00 + z_RC - z_0C - z_R0| / 12``
  (zero for texcad's plates, whose corners lie on the face).
* OCCT has no bulk constructor for pole arrays (a Python ``SetValue`` per pole would
  be a loop per vertex), so the surface is written in OCCT's own ``.brep`` text format
  with one ``%``-formatting call over the whole array and read back with
  ``BRepTools::Read`` (about 0.7 s for 800 x 800 poles).
* :func:`textured_plane_face` / :func:`replace_face` - a planar face of a body gets a
  textured B-spline surface **in place**: the new surface coincides with the plane
  along the face's outline (the texture is ramped to 0 mm there), so the face keeps
  its own edges and wires, gets pcurves on the new surface, and replaces the old face
  in the body. No boolean, no sewing: the solid stays valid and closed by
  construction.
* :func:`grid_brep` / :func:`fuse_solids` - the general case (textures mapped onto
  curved faces): the slab between a top and a bottom grid (the B-rep twin of
  :func:`texcad.solid.grid_solid`), sewn, and fused onto the base with OCCT's boolean.
* :func:`tiled_grid_faces` / :func:`tiled_plane_solid` / :func:`textured_band_solid` -
  what texcad's B-reps are made of now: the texture grid as **tiles** of at most
  :data:`TILE` x :data:`TILE` cells sharing their edges, each carrying texcad's own
  mesh as its triangulation (OCCT's mesher keeps it; STEP stores it), finer
  (:data:`FINE`) where a CAD operation's tool meets the texture. Planar faces keep
  their plane outside the tiles; closed bands (cylinders) are split by the end rows'
  planes and closed by planar rings; open profiles' faces are tiles sewn to their own
  boundary edges split at the tile corners, and planar faces with holes get tiles
  that keep clear of the outline (:mod:`texcad.solid.brep_faces`). No boolean.
* :func:`write_step` / :func:`read_step` - AP214 STEP in mm, silent, with a fixed
  header (time stamp, product name) so the same shape gives the same bytes.

OCCT's plain volume integration (``BRepGProp::VolumeProperties(shape, props)``, what
build123d's ``.volume`` calls) puts at most 61 Gauss points across a whole face; the
tiles' knots are placed for it (:mod:`texcad.brep.gprop`), so it agrees with the
adaptive one (:func:`occt_volume`) on texcad's tiles.
"""

from __future__ import annotations

import io
from collections import OrderedDict
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ..util import require_memory
from ..errors import GeometryError, ParameterError
from .gprop import GAUSS_POINTS, gauss_knots, polyline_pcurve, run_knots
from .occt import as_array, explore, solids_of, to_topods

if TYPE_CHECKING:
    from ..solid.mesh import Mesh

__all__ = [
    "grid_surface",
    "grid_face",
    "grid_brep",
    "textured_plane_face",
    "replace_face",
    "tiled_grid_faces",
    "tile_grid",
    "transformed_shape",
    "tiled_plane_solid",
    "textured_band_solid",
    "textured_extrusion_solid",
    "TILE",
    "FINE",
    "occt_volume",
    "OCCT_EPS",
    "flat_solids",
    "occt_boolean",
    "fuse_solids",
    "check_shape",
    "volume",
    "surface_grid",
    "grid_flux",
    "shape_mesh",
    "mesh_face",
    "edge_points",
    "face_segments",
    "inside",
    "sample_segments",
]

#: Tolerance in mm given to new faces and pcurves (OCCT's Precision::Confusion).
TOLERANCE = 1e-7
#: Sewing tolerance in mm: grid faces share boundary poles exactly.
SEW_TOLERANCE = 1e-6


# -- OCCT objects from build123d / CadQuery ---------------------------------------------
# -- B-spline surfaces from grids, via the .brep text format ---------------------------------
def _fmt(template: str, arr: np.ndarray) -> str:
    """Format all rows of ``arr`` with a ``%``-template in one C-level call (no loop
    per row: the template is repeated ``rows`` times)."""
    arr = np.asarray(arr, dtype=np.float64)
    per = template.count("%")
    return (template * (arr.size // per)) % tuple(arr.ravel().tolist())


def _knot_lines(k: np.ndarray) -> str:
    """``knot multiplicity`` lines of a degree-1 B-spline: ends twice, inner once."""
    m = np.ones(len(k))
    m[0] = m[-1] = 2
    return _fmt("%.17g %d\n", np.stack([k, m], axis=1))


def _knots(n: int, k: Any, name: str) -> np.ndarray:
    if k is None:
        return np.arange(n, dtype=np.float64)
    k = np.asarray(k, dtype=np.float64)
    if k.shape != (n,) or not np.all(np.diff(k) > 0):
        raise ParameterError(f"{name} knots must be {n} strictly increasing numbers, got shape {k.shape}")
    return k


def grid_surface(grid: np.ndarray, u: Sequence[float] | None = None, v: Sequence[float] | None = None):
    """A degree-1 B-spline surface through an ``(R, C, 3)`` vertex grid (mm).

    Pole ``(i, j)`` is ``grid[j, i]``: ``u`` runs along the columns (texture x) and
    ``v`` along the rows (texture y), so the surface normal ``S_u x S_v`` points the
    way :func:`texcad.solid.grid_faces` orients its triangles. The surface passes
    through every vertex: ``S(u_i, v_j) = grid[j, i]``.

    Args:
        grid: ``(R, C, 3)`` vertex positions in mm, R, C >= 2.
        u: ``(C,)`` strictly increasing knots (default ``0 .. C-1``). Giving the
            vertices' own x coordinates makes ``u`` a length in mm.
        v: ``(R,)`` knots (default ``0 .. R-1``).

    Returns:
        ``Geom_BSplineSurface`` (OCP handle).
    """
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS, TopoDS_Shape

    g = np.asarray(grid, dtype=np.float64)
    if g.ndim != 3 or g.shape[2] != 3 or g.shape[0] < 2 or g.shape[1] < 2:
        raise ParameterError(f"a grid surface needs an (R >= 2, C >= 2, 3) array, got shape {g.shape}")
    if not np.isfinite(g).all():
        raise GeometryError("the grid holds NaN or infinite coordinates")
    rows, cols = g.shape[:2]
    require_memory(rows * cols * 220.0, f"a {rows} x {cols} B-spline surface", "use a larger pitch")
    uk, vk = _knots(cols, u, "u"), _knots(rows, v, "v")
    poles = np.ascontiguousarray(g.transpose(1, 0, 2))  # (C, R, 3): u-major, as OCCT stores them
    # 12 significant digits: 1e-10 mm at 100 mm, far inside the 1e-7 mm tolerance.
    text = "".join(
        [
            "\nCASCADE Topology V3, (c) Open Cascade\nLocations 0\nCurve2ds 0\nCurves 0\nPolygon3D 0\n"
            "PolygonOnTriangulations 0\nSurfaces 1\n",
            f"9 0 0 0 0 1 1 {cols} {rows} {cols} {rows}\n",
            _fmt("%.12g %.12g %.12g\n", poles),
            _knot_lines(uk),
            _knot_lines(vk),
            "\nTriangulations 0\n\nTShapes 1\nFa\n0  1e-07 1 0\n\n1101000\n*\n\n+1 0 \n",
        ]
    )
    shape = TopoDS_Shape()
    BRepTools.Read_s(shape, io.BytesIO(text.encode("ascii")), BRep_Builder())
    if shape.IsNull():
        raise GeometryError(f"OCCT could not read the {rows} x {cols} B-spline surface")
    return BRep_Tool.Surface_s(TopoDS.Face_s(shape))


def grid_face(grid: np.ndarray, u: Sequence[float] | None = None, v: Sequence[float] | None = None):
    """The face bounded by a grid surface's own parameter range (see :func:`grid_surface`).

    A grid whose last column repeats its first (a closed band) gives a face with a
    seam edge.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace

    mk = BRepBuilderAPI_MakeFace(grid_surface(grid, u, v), TOLERANCE)
    if not mk.IsDone():
        raise GeometryError("OCCT could not make a face from the texture grid")
    return mk.Face()


# -- the slab solid (general case) ----------------------------------------------------------
def grid_brep(top: np.ndarray, bottom: np.ndarray, *, wrap_x: bool = False):
    """The B-rep slab between two vertex grids: the twin of :func:`texcad.solid.grid_solid`.

    Faces: the top grid surface, the bottom grid surface, and one wall per boundary
    between the top's and the bottom's boundary rows/columns: a plane bounded by the
    two grid faces' own edges where the wall is planar (OCCT's boolean intersects
    planes robustly, a wiggly degree-1 strip in a plane not always), else a degree-1
    strip. The faces share their boundary edges or poles exactly and are sewn
    (tolerance 1e-6 mm) into a closed shell, made a solid and oriented outward.

    Args:
        top: ``(R, C, 3)`` textured surface in mm, ``d(top)/dc x d(top)/dr`` outward.
        bottom: ``(R, C, 3)`` surface inside the base body, or ``(2, C, 3)``: its first
            and last row only, for a ruled bottom (an extrusion: ``2 C`` poles instead
            of ``R C``, much cheaper for OCCT's booleans).
        wrap_x: the grids close on themselves in x (column ``C - 1`` joins column 0);
            only the two end rows get walls.

    Returns:
        ``TopoDS_Solid``.

    Raises:
        GeometryError: the faces do not close into one valid solid.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeSolid, BRepBuilderAPI_Sewing
    from OCP.BRepLib import BRepLib
    from OCP.TopAbs import TopAbs_SHELL
    from OCP.TopoDS import TopoDS

    top = np.asarray(top, dtype=np.float64)
    bottom = np.asarray(bottom, dtype=np.float64)
    if (
        top.ndim != 3
        or bottom.ndim != 3
        or top.shape[2] != 3
        or min(top.shape[:2]) < 2
        or bottom.shape[1:] != top.shape[1:]
        or bottom.shape[0] not in (2, top.shape[0])
    ):
        raise ParameterError(
            f"top must be (R >= 2, C >= 2, 3) and bottom (R, C, 3) or (2, C, 3); got {top.shape} and {bottom.shape}"
        )
    if wrap_x:
        top = np.concatenate([top, top[:, :1]], axis=1)
        bottom = np.concatenate([bottom, bottom[:, :1]], axis=1)
    else:
        top, bottom = top.copy(), bottom.copy()
    # Walls: (which iso-edge of the grid faces, index into top, index into bottom).
    sides = [("v0", np.s_[0], np.s_[0]), ("v1", np.s_[-1], np.s_[-1])]
    if not wrap_x:
        sides += [("u0", np.s_[:, 0], np.s_[:, 0]), ("u1", np.s_[:, -1], np.s_[:, -1])]
    planar = {}
    for side, ti, bi in sides:  # 4 walls at most
        # Walls within float32 rounding of a plane (1e-6 of their size) are snapped
        # onto it, so they can be real planes.
        planar[side] = _snap_planar(top, bottom, ti, bi)
    top_f, bot_f = grid_face(top), grid_face(bottom)
    faces = [top_f, bot_f]
    for side, ti, bi in sides:  # 4 walls at most
        a, b = top[ti], bottom[bi]
        wall = None
        if planar[side]:
            wall = _planar_wall(_iso_edge(top_f, side), _iso_edge(bot_f, side), closed=wrap_x and side[0] == "v")
        if wall is None:
            if len(b) != len(a):  # a ruled bottom's column: spread along it like the top's
                t = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(a, axis=0), axis=1))])
                t = t / t[-1] if t[-1] > 0 else np.linspace(0.0, 1.0, len(a))
                b = b[0] + t[:, None] * (b[-1] - b[0])
            wall = grid_face(np.stack([a, b]))
        faces.append(wall)
    sew = BRepBuilderAPI_Sewing(SEW_TOLERANCE)
    for f in faces:  # one per face (6 at most)
        sew.Add(f)
    sew.Perform()
    if sew.NbFreeEdges() or sew.NbMultipleEdges():
        raise GeometryError(
            f"the texture slab does not close ({sew.NbFreeEdges()} free, {sew.NbMultipleEdges()} multiple edges); "
            "the top and bottom grids must not touch"
        )
    shells = explore(sew.SewedShape(), TopAbs_SHELL)
    if len(shells) != 1:
        raise GeometryError(f"the texture slab sewed into {len(shells)} shells instead of one")
    solid = BRepBuilderAPI_MakeSolid(TopoDS.Shell_s(shells[0])).Solid()
    BRepLib.OrientClosedSolid_s(solid)
    return solid


def _snap_planar(top: np.ndarray, bottom: np.ndarray, ti: Any, bi: Any, rel: float = 1e-6) -> bool:
    """If the wall points ``top[ti]`` and ``bottom[bi]`` (mm) lie within ``rel`` of
    their extent of one plane, project them onto it (in place) and return True."""
    pts = np.concatenate([top[ti], bottom[bi]])
    centre = pts.mean(axis=0)
    c = pts - centre
    extent = float(np.ptp(pts, axis=0).max()) or 1.0
    nrm = np.linalg.svd(c, full_matrices=False)[2][2]
    if float(np.abs(c @ nrm).max()) > rel * extent:
        return False
    for arr, idx in ((top, ti), (bottom, bi)):
        p = arr[idx]
        arr[idx] = p - ((p - centre) @ nrm)[:, None] * nrm
    return True


def _iso_edge(face, side: str):
    """The boundary edge of a grid face at ``u0``, ``u1``, ``v0`` or ``v1`` (its own
    parameter bounds), found from the edges' pcurves (4 edges, plus a seam)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS
    from OCP.gp import gp_Pnt2d

    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    want = {"u0": (0, u0), "u1": (0, u1), "v0": (1, v0), "v1": (1, v1)}[side]
    span = max(u1 - u0, v1 - v0)
    for e in explore(face, TopAbs_EDGE):  # 4 or 5 edges
        edge = TopoDS.Edge_s(e)
        pa, pb = gp_Pnt2d(), gp_Pnt2d()
        BRep_Tool.UVPoints_s(edge, face, pa, pb)
        a, b = (pa.X(), pb.X()) if want[0] == 0 else (pa.Y(), pb.Y())
        if abs(a - want[1]) < 1e-9 * span and abs(b - want[1]) < 1e-9 * span:
            return edge
    raise GeometryError(f"internal: the grid face has no boundary edge at {side}")


def _planar_wall(top_edge, bottom_edge, *, closed: bool):
    """A planar face bounded by a top and a bottom boundary edge: between two closed
    loops (an annulus) or, for open edges, closed by two straight segments."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakeWire
    from OCP.ShapeFix import ShapeFix_Face
    from OCP.TopExp import TopExp

    def wire(*edges):
        mk = BRepBuilderAPI_MakeWire()
        for e in edges:  # at most 4
            mk.Add(e)
        if not mk.IsDone():
            return None
        return mk.Wire()

    if closed:
        outer, inner = wire(top_edge), wire(bottom_edge)
        if outer is None or inner is None:
            return None
        mk = BRepBuilderAPI_MakeFace(outer, True)
        if not mk.IsDone():
            return None
        mk.Add(inner)
    else:
        pts = []
        for e in (top_edge, bottom_edge):
            pts.append([BRep_Tool.Pnt_s(TopExp.FirstVertex_s(e)), BRep_Tool.Pnt_s(TopExp.LastVertex_s(e))])
        s1 = BRepBuilderAPI_MakeEdge(pts[0][1], pts[1][1]).Edge()
        s2 = BRepBuilderAPI_MakeEdge(pts[1][0], pts[0][0]).Edge()
        w = wire(top_edge, s1, bottom_edge, s2)
        if w is None:
            return None
        mk = BRepBuilderAPI_MakeFace(w, True)
    if not mk.IsDone():
        return None
    fix = ShapeFix_Face(mk.Face())
    fix.FixOrientation()
    fix.Perform()
    return fix.Face()


# -- a planar face, textured in place ---------------------------------------------------
def _frame_pln(origin: np.ndarray, normal: np.ndarray, xdir: np.ndarray):
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pln, gp_Pnt

    return gp_Pln(gp_Ax3(gp_Pnt(*map(float, origin)), gp_Dir(*map(float, normal)), gp_Dir(*map(float, xdir))))


def textured_plane_face(
    face: Any,
    heights: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    *,
    origin: Sequence[float],
    xdir: Sequence[float],
    normal: Sequence[float],
):
    """A planar face of a body, re-made on a textured degree-1 B-spline surface.

    The texture lives in the face's frame: vertex ``(r, c)`` is ``origin + x[c] xdir
    + y[r] ydir + heights[r, c] normal`` with ``ydir = normal x xdir`` and ``normal``
    the face's **outward** normal. The knots are ``x`` and ``y`` themselves, so the
    surface parameters ``(u, v)`` are the in-plane coordinates in mm and every edge's
    pcurve is its projection onto the plane (exact: ``GeomAPI::To2d``). The new face
    keeps the old face's wires and edges (the same ``TopoDS_Edge`` objects, shared
    with the neighbouring faces), so it can replace the old face in its body
    (:func:`replace_face`).

    The heights must be exactly 0 in every grid cell the outline passes through (the
    caller ramps the texture down to the outline): there the surface is the plane, so
    the outline lies on it.

    Args:
        face: the planar face (build123d / CadQuery / ``TopoDS_Face``), as found in its
            body (its orientation is kept).
        heights: ``(R, C)`` heights in mm along ``normal``.
        x: ``(C,)`` strictly increasing in-plane x of the columns, mm.
        y: ``(R,)`` strictly increasing in-plane y of the rows, mm.
        origin: a point of the face's plane, mm.
        xdir: unit in-plane x direction.
        normal: unit outward normal of the face.

    Returns:
        ``TopoDS_Face`` (forward; its surface normal points outward).
    """
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.GeomAPI import GeomAPI
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS, TopoDS_Face, TopoDS_Iterator

    old = TopoDS.Face_s(to_topods(face))
    o = np.asarray(origin, np.float64)
    ex = np.asarray(xdir, np.float64)
    n = np.asarray(normal, np.float64)
    ey = np.cross(n, ex)
    h = np.asarray(heights, np.float64)
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    if h.shape != (len(y), len(x)):
        raise ParameterError(f"heights must be (len(y), len(x)) = ({len(y)}, {len(x)}), got {h.shape}")
    grid = o + x[None, :, None] * ex + y[:, None, None] * ey + h[..., None] * n
    surf = grid_surface(grid, x, y)
    pln = _frame_pln(o, n, ex)

    b = BRep_Builder()
    new = TopoDS_Face()
    b.MakeFace(new, surf, TopLoc_Location(), TOLERANCE)
    it = TopoDS_Iterator(old)  # wires, with the face's orientation composed in
    while it.More():  # one per wire (outline and holes)
        b.Add(new, it.Value())
        it.Next()
    for edge in explore(old, TopAbs_EDGE):  # one per edge of the outline
        e = TopoDS.Edge_s(edge)
        curve = BRep_Tool.Curve_s(e, 0.0, 0.0)
        if curve is None:
            raise GeometryError("an edge of the face has no 3-D curve; rebuild the part (BRepLib.BuildCurves3d)")
        b.UpdateEdge(e, GeomAPI.To2d_s(curve, pln), new, TOLERANCE)
    return new


def replace_face(shape: Any, old_face: Any, new_face: Any):
    """``shape`` with ``old_face`` replaced by ``new_face`` (``BRepTools_ReShape``).

    ``new_face`` must share the old face's boundary edges (see
    :func:`textured_plane_face`); the rest of the body is kept as it is.

    Returns:
        The new ``TopoDS_Shape`` (same type as ``shape``).
    """
    from OCP.BRepTools import BRepTools_ReShape

    rs = BRepTools_ReShape()
    rs.Replace(to_topods(old_face), to_topods(new_face))
    return rs.Apply(to_topods(shape))


# -- outlines ------------------------------------------------------------------------------------
def edge_points(edge, spacing: float) -> np.ndarray:
    """Points along an edge every <= ``spacing`` mm, ``(n, 3)`` float64, in the edge's
    own parameter order (lines and circles in closed form; other curves through
    OCCT, one call per sample: an outline has thousands, not millions)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.GeomAbs import GeomAbs_Circle, GeomAbs_Line

    ad = BRepAdaptor_Curve(edge)
    t0, t1 = ad.FirstParameter(), ad.LastParameter()
    kind = ad.GetType()
    if kind == GeomAbs_Line:
        a, b = ad.Value(t0), ad.Value(t1)
        pa, pb = np.array(a.Coord()), np.array(b.Coord())
        n = max(1, int(np.ceil(np.linalg.norm(pb - pa) / spacing)))
        w = np.linspace(0.0, 1.0, n + 1)[:, None]
        return pa + w * (pb - pa)
    if kind == GeomAbs_Circle:
        c = ad.Circle()
        pos = c.Position()
        o, xa, ya, r = as_array(pos.Location()), as_array(pos.XDirection()), as_array(pos.YDirection()), c.Radius()
        n = max(2, int(np.ceil(r * abs(t1 - t0) / spacing)))
        t = np.linspace(t0, t1, n + 1)[:, None]
        return o + r * (np.cos(t) * xa + np.sin(t) * ya)
    length = GCPnts_AbscissaPoint.Length_s(ad)
    n = max(2, int(np.ceil(length / spacing)))
    t = np.linspace(t0, t1, n + 1)
    return np.array([ad.Value(float(ti)).Coord() for ti in t])  # per outline sample


def face_segments(face, spacing: float, *, oriented: bool = False) -> np.ndarray:
    """``(K, 2, 3)`` segments of the face's boundary (all wires), mm.

    ``oriented``: each segment runs the way its edge runs in the face's wire (the
    face's orientation composed in), so that the region lies to the left with
    respect to the surface normal of a forward face."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS

    from ..util import available_memory
    from ..errors import ResourceError

    edges = explore(face, TopAbs_EDGE)
    length = sum(GCPnts_AbscissaPoint.Length_s(BRepAdaptor_Curve(TopoDS.Edge_s(e))) for e in edges)  # per edge
    need, have = 200.0 * (length / spacing + 3 * len(edges)), available_memory()  # points, segments, temporaries
    if need > have:  # memory goes with 1 / spacing here
        fit = spacing * 1.2 * need / max(have, 1.0)
        raise ResourceError(
            f"sampling a face outline of {length:.4g} mm every {spacing:.3g} mm needs about {need / 2**30:.1f} GiB of memory "
            f"but this machine has {have / 2**30:.1f} GiB available; sample it every {fit:.3g} mm or more (a larger pitch)"
        )
    segs = []
    for e in edges:  # one per boundary edge
        p = edge_points(TopoDS.Edge_s(e), spacing)
        if oriented and e.Orientation() == TopAbs_REVERSED:
            p = p[::-1]
        segs.append(np.stack([p[:-1], p[1:]], axis=1))
    if not segs:
        raise GeometryError("the face has no boundary edges")
    return np.concatenate(segs)


def inside(segs: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test of every grid point ``(xs[c], ys[r])`` against
    2-D segments ``(K, 2, 2)`` (any order, any number of loops), vectorized: for each
    row, the segments crossing ``y = ys[r]`` (half-open rule) toggle the inside state
    of every column right of the crossing; a cumulative sum along the row counts the
    toggles.

    Returns:
        ``(R, C)`` bool.
    """
    rows, cols = len(ys), len(xs)
    count = np.zeros((rows, cols + 1), dtype=np.int32)
    a, b = segs[:, 0], segs[:, 1]
    step = max(1, int(4_000_000 // max(1, rows)))
    for k0 in range(0, len(segs), step):  # chunks of segments, for memory
        ya, yb = a[k0 : k0 + step, 1:2], b[k0 : k0 + step, 1:2]
        cross = (ya <= ys[None, :]) != (yb <= ys[None, :])
        ki, ri = np.nonzero(cross)
        ki += k0
        t = (ys[ri] - a[ki, 1]) / (b[ki, 1] - a[ki, 1])
        xc = a[ki, 0] + t * (b[ki, 0] - a[ki, 0])
        ci = np.searchsorted(xs, xc, side="right")
        np.add.at(count, (ri, ci), 1)
    return (np.cumsum(count, axis=1)[:, :cols] % 2) == 1


def sample_segments(segs: np.ndarray, spacing: float) -> np.ndarray:
    """Points every <= ``spacing`` mm along 2-D segments ``(K, 2, 2)``, vectorized."""
    d = segs[:, 1] - segs[:, 0]
    n = np.maximum(1, np.ceil(np.linalg.norm(d, axis=1) / spacing)).astype(np.int64)
    k = np.repeat(np.arange(len(segs)), n + 1)
    start = np.repeat(np.cumsum(n + 1) - (n + 1), n + 1)
    w = (np.arange(k.size) - start) / np.repeat(n, n + 1)
    return segs[k, 0] + w[:, None] * d[k]


# -- booleans and checks ----------------------------------------------------------------------
def occt_boolean(shape: Any, tool: Any, op: str = "fuse", *, parallel: bool = True, maker: bool = False):
    """OCCT's general boolean (``BRepAlgoAPI_Cut`` / ``_Fuse`` / ``_Common``) of two
    shapes: the one place texcad calls it. ``maker``: return ``(shape, algorithm)``,
    the algorithm for its history (``Modified``, ``IsDeleted``).

    Raises:
        ParameterError: unknown ``op``.
        GeometryError: OCCT reports failure.
    """
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Common, BRepAlgoAPI_Cut, BRepAlgoAPI_Fuse
    from OCP.TopTools import TopTools_ListOfShape

    algos = {"cut": BRepAlgoAPI_Cut, "fuse": BRepAlgoAPI_Fuse, "common": BRepAlgoAPI_Common}
    if op not in algos:
        raise ParameterError(f"unknown boolean {op!r}; use one of {', '.join(algos)}")
    algo = algos[op]()
    args, tools = TopTools_ListOfShape(), TopTools_ListOfShape()
    args.Append(to_topods(shape))
    tools.Append(to_topods(tool))
    algo.SetArguments(args)
    algo.SetTools(tools)
    algo.SetRunParallel(parallel)
    algo.Build()
    if not algo.IsDone():
        raise GeometryError(f"OCCT's {op} of the textured B-rep failed; the mesh (STL/3MF) is still valid")
    return (algo.Shape(), algo) if maker else algo.Shape()


def fuse_solids(base: Any, tool: Any, *, parallel: bool = True, solids: int = 1):
    """OCCT boolean union of ``base`` and ``tool``, checked: it must have ``solids``
    solids (one: the ``TopoDS_Solid`` itself is returned).

    Raises:
        GeometryError: the boolean failed or gave another number of solids.
    """
    fused = occt_boolean(base, tool, "fuse", parallel=parallel)
    sols = solids_of(fused)
    if len(sols) != solids:
        raise GeometryError(
            f"OCCT's union of texture and base gave {len(sols)} solids instead of {solids}: its boolean found no "
            "(or too little) intersection between the texture slab and the base, which happens with fine "
            "grids on curved B-spline faces; build the STEP at a coarser pitch (e.g. 0.25 mm). "
            "The mesh (STL/3MF) does not depend on OCCT and is valid"
        )
    return sols[0] if solids == 1 else fused


def check_shape(shape: Any) -> dict:
    """Validity report of a B-rep: ``{"valid": BRepCheck_Analyzer, "solids": n,
    "faces": n, "closed": every shell closed}``."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepCheck import BRepCheck_Analyzer
    from OCP.TopAbs import TopAbs_FACE, TopAbs_SHELL
    from OCP.TopoDS import TopoDS

    topo = to_topods(shape)
    shells = explore(topo, TopAbs_SHELL)
    return {
        "valid": bool(BRepCheck_Analyzer(topo).IsValid()),
        "solids": len(solids_of(topo)),
        "faces": len(explore(topo, TopAbs_FACE)),
        "closed": bool(shells) and all(BRep_Tool.IsClosed_s(TopoDS.Shell_s(s)) for s in shells),
    }


def surface_grid(surface) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Poles and knots of a non-rational degree-1 B-spline surface, as numpy arrays.

    The inverse of :func:`grid_surface`, through the same ``.brep`` text (no Python
    loop per pole): a face on the surface is written with ``BRepTools::Write`` and the
    numbers are parsed with numpy.

    Returns:
        ``(grid (R, C, 3), u (C,), v (R,))`` in :func:`grid_surface`'s layout, or None
        for any other kind of surface.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepTools import BRepTools
    from OCP.Geom import Geom_BSplineSurface

    if not isinstance(surface, Geom_BSplineSurface):
        return None
    if surface.UDegree() != 1 or surface.VDegree() != 1 or surface.IsURational() or surface.IsVRational():
        return None
    buf = io.BytesIO()
    BRepTools.Write_s(BRepBuilderAPI_MakeFace(surface, TOLERANCE).Face(), buf)
    text = buf.getvalue().decode("ascii")
    i = text.index("Surfaces 1")
    j = text.index("Triangulations", i)
    nums = np.array(text[i + len("Surfaces 1") : j].split(), dtype=np.float64)
    nu, nv, nku, nkv = (int(x) for x in nums[7:11])
    poles = nums[11 : 11 + nu * nv * 3].reshape(nu, nv, 3)
    k = nums[11 + nu * nv * 3 :].reshape(-1, 2)
    uk, vk = k[:nku, 0], k[nku : nku + nkv, 0]
    # Periodic directions (OCCT's booleans and STEP make closed bands periodic): one
    # knot more than poles; the band closes on the first pole row/column.
    if surface.IsUPeriodic():
        poles = np.concatenate([poles, poles[:1]], axis=0)
    if surface.IsVPeriodic():
        poles = np.concatenate([poles, poles[:, :1]], axis=1)
    if len(uk) != poles.shape[0] or len(vk) != poles.shape[1]:  # repeated inner knots: not a plain grid
        return None
    return np.ascontiguousarray(poles.transpose(1, 0, 2)), uk, vk


_G = 0.5 / np.sqrt(3.0)
_GAUSS2 = (0.5 - _G, 0.5 + _G)  # 2-point Gauss-Legendre on [0, 1], weights 1/2


def grid_flux(grid: np.ndarray) -> float:
    """``(1/3) integral p . n dA`` over the bilinear surface through an ``(R, C, 3)``
    grid, ``n dA = p_s x p_t ds dt`` (columns x rows): the surface's share of a
    solid's volume by the divergence theorem. Exact: on each cell the integrand is a
    polynomial of degree 2 in each parameter, and 2 x 2 Gauss points integrate
    degree 3 exactly. Accumulated in float64, vectorized over the cells."""
    g = np.asarray(grid, dtype=np.float64)
    a, b, c, d = g[:-1, :-1], g[:-1, 1:], g[1:, 1:], g[1:, :-1]  # (r, c), (r, c+1), (r+1, c+1), (r+1, c)
    total = 0.0
    for s in _GAUSS2:  # 4 Gauss points, each vectorized over all cells
        for t in _GAUSS2:
            p = (1 - s) * (1 - t) * a + s * (1 - t) * b + s * t * c + (1 - s) * t * d
            ps = (1 - t) * (b - a) + t * (c - d)
            pt = (1 - s) * (d - a) + s * (c - b)
            total += 0.25 * float((p * np.cross(ps, pt)).sum())
    return total / 3.0


#: Relative precision of OCCT's adaptive integration on a texture tile a tool trimmed
#: (its plain Gauss integration, 61 points at most, is off by percents on a trimmed
#: 24 x 24-cell tile: measured 178 mm3 on a 4 mm hole through the sine sample).
TILE_EPS = 1e-6


def _face_flux(face, ref: np.ndarray) -> float:
    """``(1/3) integral (p - ref) . n dA`` over one face (mm^3), by OCCT's Gauss
    integration (``BRepGProp_Vinert``): exact for planes and quadrics, good for smooth
    faces with few spans. Texture tiles that a tool trimmed get OCCT's adaptive
    variant (relative error :data:`TILE_EPS`; untrimmed tiles are integrated exactly
    by :func:`grid_flux`).

    ``BRepGProp::VolumeProperties`` cannot be used face by face (it integrates relative
    to each shape's own vertex barycentre, so the shares do not add up), and OCCT's
    *adaptive* variant is unreliable on trimmed spline faces (off by percents here), so
    this is the plain integration relative to one reference point ``ref`` (mm) shared
    by all faces."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepGProp import BRepGProp_Domain, BRepGProp_Face, BRepGProp_Vinert
    from OCP.gp import gp_Pnt
    from OCP.TopoDS import TopoDS_Iterator

    bf = BRepGProp_Face(face)
    loc = gp_Pnt(*map(float, ref))
    grid = surface_grid(BRep_Tool.Surface_s(face)) is not None
    if not grid and not _quadric(face):  # a part's own free-form face of many spans
        return _mesh_flux(face, ref)
    if TopoDS_Iterator(face).More():  # trimmed by wires
        if grid or _spline_trimmed(face):  # a tile a tool trimmed, or a section: adaptive
            return float(BRepGProp_Vinert(bf, BRepGProp_Domain(face), loc, TILE_EPS).Mass())
        return float(BRepGProp_Vinert(bf, BRepGProp_Domain(face), loc).Mass())
    return float(BRepGProp_Vinert(bf, loc).Mass())  # natural bounds


def _quadric(face) -> bool:
    """A plane, cylinder, cone, sphere or torus (OCCT's Gauss integration is exact on it)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Cone, GeomAbs_Cylinder, GeomAbs_Plane, GeomAbs_Sphere, GeomAbs_Torus

    return BRepAdaptor_Surface(face, False).GetType() in (GeomAbs_Plane, GeomAbs_Cylinder, GeomAbs_Cone, GeomAbs_Sphere,
                                                         GeomAbs_Torus)


#: Chord of the triangulation :func:`_mesh_flux` integrates a free-form face on,
#: relative to the face's size (its bounding box's diagonal)...
FLUX_CHORD = 2e-5
#: ...and at least this, mm: the flux is then off by at most 1 um times the face's
#: area, a fiftieth of what the default mesh tolerance (0.02 mm) allows the mesh it is
#: compared with. Finer chords cost seconds on a part with engraved lettering (263
#: spline faces: 5.4 s at 2e-5 mm, 0.35 s at 1e-3 mm).
MIN_FLUX_CHORD = 1e-3


def _mesh_flux(face, ref: np.ndarray) -> float:
    """``(1/3) integral (p - ref) . n dA`` over a part's own free-form face (mm^3), on
    a copy of it triangulated by OCCT to a chord of :data:`FLUX_CHORD` of its size
    (at least :data:`MIN_FLUX_CHORD`):
    the sum of the signed tetrahedra ``(a - ref) . ((b - ref) x (c - ref)) / 6``, off by
    at most the chord times the area. OCCT's Gauss integration takes a fixed number of
    points per face and is percents off on a face of many spans (a spline profile's
    extrusion: -14 mm^3 where the flux is +300)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopoDS import TopoDS

    from .tessellation import _face_triangles

    copy = TopoDS.Face_s(BRepBuilderAPI_Copy(face, True, False).Shape())
    box = Bnd_Box()
    BRepBndLib.Add_s(copy, box)
    size = float(np.linalg.norm(np.array(box.CornerMax().Coord()) - np.array(box.CornerMin().Coord())))
    BRepMesh_IncrementalMesh(copy, max(FLUX_CHORD * size, MIN_FLUX_CHORD), False, 0.5, False)  # the chord bounds the error
    fm = _face_triangles(copy)
    if fm is None:
        raise GeometryError("OCCT could not triangulate a free-form face to integrate its volume")
    v = fm.points - ref
    a, b, c = v[fm.tris[:, 0]], v[fm.tris[:, 1]], v[fm.tris[:, 2]]
    return float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)


def _spline_trimmed(face) -> bool:
    """A face trimmed by an edge that is no line or circle (a section curve, such as
    the walls of a textured patch leave on a torus: OCCT's plain Gauss integration
    of such a face is off by 2 mm^3 on a 6 mm fillet ring, its adaptive one is not)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GeomAbs import GeomAbs_Circle, GeomAbs_Line
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    return any(BRepAdaptor_Curve(TopoDS.Edge_s(e)).GetType() not in (GeomAbs_Line, GeomAbs_Circle)
               for e in explore(face, TopAbs_EDGE))  # fmt: skip


def _plane_flux(face, ref: np.ndarray, spacing: float) -> float:
    """``(1/3) integral (p - ref) . n dA`` over a planar face, mm^3: ``(1/3) h A`` with
    ``h`` the signed distance of ``ref`` to the plane and ``A`` the area enclosed by
    the oriented boundary (Green's theorem over the outline sampled every
    ``spacing`` mm: exact on straight and polyline edges, second order on curves).
    OCCT's Gauss integration of a plane bounded by edges with hundreds of spans (the
    walls of texture slabs) is off by a factor of two or more."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface

    pln = BRepAdaptor_Surface(face, False).Plane()
    n = np.array(pln.Axis().Direction().Coord())
    p0 = np.array(pln.Location().Coord())
    segs = face_segments(face, spacing, oriented=True) - ref
    area = 0.5 * float(np.cross(segs[:, 0], segs[:, 1]).sum(axis=0) @ n)
    return float(n @ (p0 - ref)) * area / 3.0


def _grid_face_info(face) -> dict | None:
    """What texcad knows exactly about a face on a degree-1 grid surface, or None.

    Returns ``{"grid": (R, C, 3) world mm, "sign": +-1 (face orientation), "kind":
    "natural" | "planar", ...}``:

    * ``"natural"``: the face spans the surface's natural bounds (e.g. a mapped
      texture's top).
    * ``"planar"``: trimmed by a **planar** outline, with the surface leaving the
      plane only inside the outline (texcad's textured planar faces); adds
      ``"plane_face"`` (the forward planar face with the same wires), ``"normal"``
      (unit, like the surface's ``u x v``), ``"point"`` (on the plane) and
      ``"lifted"`` ((R, C) bool, vertices off the plane).
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepTools import BRepTools
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pln, gp_Pnt
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_WIRE
    from OCP.TopoDS import TopoDS

    got = surface_grid(BRep_Tool.Surface_s(face))
    if got is None:
        return None
    grid, uk, vk = got
    loc = face.Location()
    if not loc.IsIdentity():
        t = loc.Transformation()
        m = np.array([[t.Value(i, j) for j in range(1, 5)] for i in range(1, 4)])  # 3 x 4 getters
        grid = grid @ m[:, :3].T + m[:, 3]
    info: dict = {"grid": grid, "sign": -1.0 if face.Orientation() == TopAbs_REVERSED else 1.0}
    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    u0, u1, v0, v1 = BRepTools.UVBounds_s(fwd)
    span = max(uk[-1] - uk[0], vk[-1] - vk[0])
    if max(abs(u0 - uk[0]), abs(u1 - uk[-1]), abs(v0 - vk[0]), abs(v1 - vk[-1])) < 1e-9 * span and _on_bounds(fwd, uk, vk):
        info["kind"] = "natural"
        return info
    # Planar outline?
    pts = face_segments(fwd, 1.0).reshape(-1, 3)
    centre = pts.mean(axis=0)
    _, sv, vt = np.linalg.svd(pts - centre, full_matrices=False)
    nrm = vt[2]
    extent = float(np.ptp(pts, axis=0).max()) or 1.0
    if sv[2] / np.sqrt(len(pts)) > 1e-7 * extent or np.abs((pts - centre) @ nrm).max() > 1e-6 * extent:
        return None
    # Orient the plane like the surface (u x v).
    du = grid[grid.shape[0] // 2, -1] - grid[grid.shape[0] // 2, 0]
    dv = grid[-1, grid.shape[1] // 2] - grid[0, grid.shape[1] // 2]
    if float(np.cross(du, dv) @ nrm) < 0:
        nrm = -nrm
    lifted = np.abs((grid - centre) @ nrm) > 1e-9 * extent
    if lifted.any():
        # Every lifted vertex must lie inside the trimmed region: test the knots
        # against the outline's pcurves in the (u, v) parameter plane.
        step = 0.5 * float(min(np.diff(uk).min(), np.diff(vk).min()))
        if not _inside_uv(fwd, uk, vk, step)[lifted].all():
            return None
    pln = gp_Pln(gp_Ax3(gp_Pnt(*centre), gp_Dir(*nrm)))
    outer = BRepTools.OuterWire_s(fwd)
    mk = BRepBuilderAPI_MakeFace(pln, outer, True)
    for w in explore(fwd, TopAbs_WIRE):  # the holes
        if not w.IsSame(outer):
            mk.Add(TopoDS.Wire_s(w))
    if not mk.IsDone():
        return None
    info.update(kind="planar", plane_face=mk.Face(), normal=nrm, point=centre, lifted=lifted, extent=extent)
    return info


def _on_bounds(face, uk: np.ndarray, vk: np.ndarray) -> bool:
    """Does every edge of the face run along its surface's parameter bounds (ends
    and middle of each pcurve on one side of the rectangle ``uk[0] .. uk[-1]`` x
    ``vk[0] .. vk[-1]``): the face is the whole surface, no hole, no notch a tool cut
    (3 OCCT calls per edge)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    tol = 1e-9 * max(uk[-1] - uk[0], vk[-1] - vk[0])
    for e in explore(face, TopAbs_EDGE):  # a few edges per tile
        ad = BRepAdaptor_Curve2d(TopoDS.Edge_s(e), face)
        t0, t1 = ad.FirstParameter(), ad.LastParameter()
        p = np.array([ad.Value(t).Coord() for t in (t0, 0.5 * (t0 + t1), t1)])  # 3 points
        on = [np.abs(p[:, 0] - uk[0]) < tol, np.abs(p[:, 0] - uk[-1]) < tol, np.abs(p[:, 1] - vk[0]) < tol, np.abs(p[:, 1] - vk[-1]) < tol]
        if not any(side.all() for side in on):
            return False
    return True


def _grid_face_flux(face, ref: np.ndarray) -> float | None:
    """Exact share ``(1/3) integral (p - ref) . n dA`` of a face on a degree-1 grid
    surface (mm^3), or None if the face is not one texcad can integrate exactly
    (see :func:`_grid_face_info`).

    * ``"natural"`` faces: :func:`grid_flux` of the whole grid.
    * ``"planar"`` faces: the planar face with the same wires (:func:`_plane_flux`),
      plus the bilinear flux of the whole grid minus that of the grid projected onto
      the plane (they cancel cell by cell where the surface is the plane, i.e.
      outside the outline).
    """
    info = _grid_face_info(face)
    if info is None:
        return _holed_grid_flux(face, ref)
    grid = info["grid"] - ref
    if info["kind"] == "natural":
        return info["sign"] * grid_flux(grid)
    nrm, point = info["normal"], info["point"] - ref
    flat = grid - ((grid - point) @ nrm)[..., None] * nrm
    plane_part = _plane_flux(info["plane_face"], ref, 0.01 * info["extent"] / max(grid.shape))
    return info["sign"] * (plane_part + grid_flux(grid) - grid_flux(flat))


def _holed_grid_flux(face, ref: np.ndarray) -> float | None:
    """The share (mm^3) of a face on a degree-1 grid surface whose outer wire runs
    along the surface's bounds and whose other wires are holes (a textured face a
    tool drilled, :func:`texcad.brep.uvfaces.uv_retextured_solid`): the whole grid's
    exact :func:`grid_flux` minus each hole's share, a face on the same surface
    bounded by the hole's wire (OCCT's adaptive integration over the hole's small
    ``(u, v)`` range instead of the whole face's: seconds -> milliseconds). None for
    any other face."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_WIRE
    from OCP.TopoDS import TopoDS

    surf = BRep_Tool.Surface_s(face)
    got = surface_grid(surf)
    if got is None or not face.Location().IsIdentity():
        return None
    grid, uk, vk = got
    fwd = TopoDS.Face_s(face.Oriented(TopAbs_FORWARD))
    outer = BRepTools.OuterWire_s(fwd)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(fwd)
    span = max(uk[-1] - uk[0], vk[-1] - vk[0])
    if outer.IsNull() or max(abs(u0 - uk[0]), abs(u1 - uk[-1]), abs(v0 - vk[0]), abs(v1 - vk[-1])) > 1e-9 * span:
        return None
    whole = TopoDS.Face_s(fwd.EmptyCopied())
    BRep_Builder().Add(whole, outer)
    if not _on_bounds(whole, uk, vk):
        return None
    total = grid_flux(grid - ref)
    for w in explore(fwd, TopAbs_WIRE):  # the holes
        if w.IsSame(outer):
            continue
        hole = _hole_face(fwd, surf, TopoDS.Wire_s(w), uk, vk)
        if hole is None:
            return None
        total -= _face_flux(hole, ref)
    return (-1.0 if face.Orientation() == TopAbs_REVERSED else 1.0) * total


def _hole_face(fwd, surf, wire, uk: np.ndarray, vk: np.ndarray):
    """The part of ``fwd``'s grid surface inside a hole ``wire`` of it, as a face on
    the surface cut down to the knot spans around the hole (the same parameters:
    OCCT's integration then runs over those spans, not the whole face's), bounded by
    a copy of the wire (its pcurves on ``fwd``); None if OCCT cannot make it."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy, BRepBuilderAPI_MakeFace
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS, TopoDS_Face

    mk = BRepBuilderAPI_MakeFace(surf, TopoDS.Wire_s(wire.Reversed()), True)
    if not mk.IsDone():
        return None
    a0, a1, b0, b1 = BRepTools.UVBounds_s(mk.Face())
    i0, i1 = max(int(np.searchsorted(uk, a0, side="right")) - 2, 0), min(int(np.searchsorted(uk, a1)) + 1, len(uk) - 1)
    j0, j1 = max(int(np.searchsorted(vk, b0, side="right")) - 2, 0), min(int(np.searchsorted(vk, b1)) + 1, len(vk) - 1)
    sub = surf.Copy()  # a Geom_BSplineSurface (OCP gives the dynamic type)
    sub.Segment(float(uk[i0]), float(uk[i1]), float(vk[j0]), float(vk[j1]))
    copy = TopoDS.Wire_s(BRepBuilderAPI_Copy(wire, False, False).Shape())
    b = BRep_Builder()
    for old, new in zip(explore(wire, TopAbs_EDGE), explore(copy, TopAbs_EDGE)):  # one per edge of the hole
        e_old, e_new = TopoDS.Edge_s(old), TopoDS.Edge_s(new)
        pc = BRep_Tool.CurveOnSurface_s(e_old, fwd, 0.0, 0.0)
        if pc is None:
            return None
        b.UpdateEdge(e_new, pc, sub, fwd.Location(), BRep_Tool.Tolerance_s(e_old))
    f = TopoDS_Face()
    b.MakeFace(f, sub, TOLERANCE)
    b.Add(f, copy.Reversed())
    return f


def shape_mesh(shape: Any, *, tolerance: float = 0.05) -> "Mesh":
    """A triangle mesh of a B-rep **for viewing** (e.g. a STEP file texcad wrote), mm.

    OCCT's tessellation of a large degree-1 B-spline face takes minutes and drops
    detail; texcad's grid faces are meshed from their poles instead (exact: degree 1
    is bilinear between the poles), trimmed planar grid faces as their plane
    (OCCT, fast) plus the grid cells that leave it. Every other face is tessellated by
    OCCT with ``tolerance`` mm; a shape without grid faces (any CAD part) healed
    where OCCT meshes it open (:func:`texcad.brep.closed_shape_mesh`). Not guaranteed
    watertight: use texcad's own meshes (STL/3MF) for printing.
    """
    from OCP.BRep import BRep_Builder
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS, TopoDS_Compound

    from ..solid.mesh import Mesh, grid_faces
    from .tessellation import closed_shape_mesh, shape_to_mesh

    topo = to_topods(shape)
    rest = TopoDS_Compound()
    builder = BRep_Builder()
    builder.MakeCompound(rest)
    n_rest = 0
    parts: list[tuple[np.ndarray, np.ndarray]] = []
    for f in explore(topo, TopAbs_FACE):  # one per face
        face = TopoDS.Face_s(f)
        info = _grid_face_info(face)
        if info is None:
            builder.Add(rest, face)
            n_rest += 1
            continue
        grid = info["grid"]
        rows, cols = grid.shape[:2]
        tri = grid_faces(rows, cols).astype(np.int64)
        if info["kind"] == "planar":
            pf = info["plane_face"] if info["sign"] > 0 else info["plane_face"].Reversed()
            builder.Add(rest, pf)
            n_rest += 1
            lift = info["lifted"]
            cell = lift[:-1, :-1] | lift[:-1, 1:] | lift[1:, :-1] | lift[1:, 1:]
            tri = tri[np.repeat(cell.ravel(), 2)]
        if info["sign"] < 0:
            tri = tri[:, ::-1]
        used, tri = np.unique(tri, return_inverse=True)  # drop vertices of cells left out
        parts.append((grid.reshape(-1, 3)[used], tri.reshape(-1, 3)))
    if n_rest:  # a part with no grid face: healed where OCCT meshes it open, as texcad check shows it
        m = closed_shape_mesh(topo, tolerance=tolerance) if not parts else shape_to_mesh(rest, tolerance=tolerance)
        parts.append((m.vertices.astype(np.float64), m.faces.astype(np.int64)))
    if not parts:
        raise GeometryError("the shape has no faces to mesh")
    offs = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    verts = np.concatenate([v for v, _ in parts]).astype(np.float32)
    faces = np.concatenate([t + o for (_, t), o in zip(parts, offs)]).astype(np.uint32)
    return Mesh(verts, faces)


def _inside_uv(face, uk: np.ndarray, vk: np.ndarray, step: float) -> np.ndarray:
    """``(len(vk), len(uk))`` bool: which grid knots ``(uk[i], vk[j])`` lie inside a
    face's trimmed region, by the even-odd rule against its edges' pcurves sampled
    every ``step`` parameter units (straight pcurves: their two ends)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve2d
    from OCP.GeomAbs import GeomAbs_Line
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    segs = []
    for e in explore(face, TopAbs_EDGE):  # one per boundary edge
        ad = BRepAdaptor_Curve2d(TopoDS.Edge_s(e), face)
        t0, t1 = ad.FirstParameter(), ad.LastParameter()
        a, b = ad.Value(t0), ad.Value(t1)
        if ad.GetType() == GeomAbs_Line:
            pts = np.array([[a.X(), a.Y()], [b.X(), b.Y()]])
        else:
            n = max(2, int(np.ceil(np.hypot(b.X() - a.X(), b.Y() - a.Y()) / step)), 64)
            pts = np.array([ad.Value(float(t)).Coord() for t in np.linspace(t0, t1, n + 1)])  # per sample
        segs.append(np.stack([pts[:-1], pts[1:]], axis=1))
    return inside(np.concatenate(segs), np.asarray(uk, np.float64), np.asarray(vk, np.float64))


def volume(shape: Any) -> float:
    """Volume in mm^3 of a B-rep, exact on texcad's grid faces.

    By the divergence theorem the volume is the sum over faces of
    ``(1/3) integral (p - ref) . n dA`` for any fixed point ``ref`` (here the centre
    of the bounding box, which keeps the terms small). Faces on degree-1 grid
    surfaces are integrated exactly (see :func:`grid_flux`; OCCT's integration uses at
    most 61 Gauss points across a whole face and is off by tenths of a percent to
    percents on texture grids); planar faces are ``(1/3) h A`` with the area from
    their outline (:func:`_plane_flux`); quadrics go to OCCT's Gauss integration
    (exact on them), the part's own free-form faces to a fine triangulation
    (:func:`_mesh_flux`: OCCT's Gauss integration is percents off on faces of many
    spans).
    """
    from OCP.Bnd import Bnd_Box
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepBndLib import BRepBndLib
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.TopAbs import TopAbs_EXTERNAL, TopAbs_FACE, TopAbs_INTERNAL
    from OCP.TopoDS import TopoDS

    topo = to_topods(shape)
    box = Bnd_Box()
    BRepBndLib.Add_s(topo, box)
    if box.IsVoid():
        return 0.0
    lo, hi = np.array(box.CornerMin().Coord()), np.array(box.CornerMax().Coord())
    ref = 0.5 * (lo + hi)
    spacing = 2e-4 * float(np.linalg.norm(hi - lo))
    total = 0.0
    for f in explore(topo, TopAbs_FACE):  # one per face
        face = TopoDS.Face_s(f)
        if face.Orientation() in (TopAbs_INTERNAL, TopAbs_EXTERNAL):
            continue
        part = _grid_face_flux(face, ref)
        if part is None:
            planar = BRepAdaptor_Surface(face, False).GetType() == GeomAbs_Plane
            part = _plane_flux(face, ref, spacing) if planar else _face_flux(face, ref)
        total += part
    return total


def mesh_face(vertices: np.ndarray, faces: np.ndarray):
    """A ``TopoDS_Face`` that carries only a triangulation (no surface, no edges): a
    mesh that CAD viewers (ocp_vscode, CQ-editor) display as it is, without
    tessellating anything. Flat shaded: three nodes per triangle, with the
    triangle's normal. Written in OCCT's ``.brep`` text with one formatting call per
    array (no loop per vertex) and read back.

    Args:
        vertices: ``(N, 3)`` mm.
        faces: ``(M, 3)`` vertex indices, counter-clockwise seen from outside.
    """
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS, TopoDS_Shape

    corners = np.asarray(vertices, np.float64)[np.asarray(faces, np.int64).ravel()]
    tri = corners.reshape(-1, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    nt = len(tri)
    if nt == 0:
        raise GeometryError("the mesh has no triangles")
    text = "".join(
        [
            "\nCASCADE Topology V3, (c) Open Cascade\nLocations 0\nCurve2ds 0\nCurves 0\nPolygon3D 0\n"
            "PolygonOnTriangulations 0\nSurfaces 0\n",
            f"Triangulations 1\n{3 * nt} {nt} 0 1 0\n",  # nodes, triangles, no UV, normals, deflection
            _fmt("%.9g %.9g %.9g ", corners),
            _fmt("%d %d %d ", np.arange(1, 3 * nt + 1).reshape(-1, 3)),
            _fmt("%.6g %.6g %.6g ", np.repeat(n, 3, axis=0)),
            "\n\nTShapes 1\nFa\n0  1e-07 0 0\n2  1\n0101000\n*\n\n+1 0 \n",
        ]
    )
    shape = TopoDS_Shape()
    BRepTools.Read_s(shape, io.BytesIO(text.encode("ascii")), BRep_Builder())
    if shape.IsNull():
        raise GeometryError("OCCT could not read the display mesh")
    return TopoDS.Face_s(shape)


# -- textured faces in tiles -------------------------------------------------------------------
#: Grid cells per side of a texture tile. OCCT's mesher (what CAD programs run to show a
#: shape) takes time growing steeply with the poles of one B-spline face (measured: 50 x
#: 50 poles 0.24 s, 100 x 100 1.5 s), but only about 40 us per pole on faces of a few
#: hundred poles; OCCT's booleans only intersect the tiles a tool reaches.
TILE = 24
#: Grid cells per side of the tiles where a CAD operation's tool reaches the texture:
#: OCCT's boolean misses intersections of a tool with a degree-1 face of many cells
#: (measured: 3 of 20 random cuts into 4 x 4- to 8 x 8-cell tiles kept the material,
#: none into 1 x 1 or 2 x 2 cells).
FINE = 2


#: Cells a tile's side along y has at least to get a pcurve of 16 spans or more (OCCT's
#: plain volume integration then puts its 61 points on it, as the tile's knots are placed
#: for: :mod:`texcad.brep.gprop`); shorter sides (small tiles under a CAD operation's
#: tool) stay lines: a small area, and a compact STEP.
PLACED = 8


def _tile_bounds(n: int, tile: int) -> np.ndarray:
    """Indices ``0 = b_0 < b_1 < ... < b_k = n`` splitting ``n`` cells into ``k =
    ceil(n / tile)`` nearly equal runs."""
    k = max(1, -(-int(n) // int(tile)))
    return np.unique(np.round(np.linspace(0, n, k + 1)).astype(np.int64))


def _tile_text(grids: list, us: list, vs: list, triangulate: bool) -> str:
    """OCCT ``.brep`` text of a compound of natural-bounds faces, one per degree-1 grid
    (with its triangulation: the grid's two triangles per cell, UV = the knots), one
    formatting call per array."""
    from ..solid.mesh import grid_faces

    n = len(grids)
    surfs, tris, shapes = [], [], []
    for k, (g, u, v) in enumerate(zip(grids, us, vs)):  # one per tile
        rows, cols = g.shape[:2]
        surfs += [
            f"9 0 0 0 0 1 1 {cols} {rows} {cols} {rows}\n",
            # 17 digits: the surface holds the grid's own numbers (tile_grid's and the STEP's).
            _fmt("%.17g %.17g %.17g\n", np.ascontiguousarray(g.transpose(1, 0, 2))),
            _knot_lines(u),
            _knot_lines(v),
        ]
        if triangulate:
            uv = np.stack(np.broadcast_arrays(u[None, :], v[:, None]), axis=-1)
            tri = grid_faces(rows, cols).astype(np.int64) + 1
            tris += [
                f"{rows * cols} {len(tri)} 1 0 0\n",
                _fmt("%.10g %.10g %.10g ", g.reshape(-1, 3)),  # for display: 1e-8 mm at 100 mm
                _fmt("%.10g %.10g ", uv.reshape(-1, 2)),
                _fmt("%d %d %d ", tri),
                "\n",
            ]
        shapes.append(f"Fa\n0  1e-07 {k + 1} 0\n" + (f"2  {k + 1}\n" if triangulate else "\n") + "1101000\n*\n")
    refs = " ".join(f"+{n + 1 - k} 0" for k in range(n))  # TShapes are referenced from the end
    return "".join(
        [
            "\nCASCADE Topology V3, (c) Open Cascade\nLocations 0\nCurve2ds 0\nCurves 0\nPolygon3D 0\n"
            f"PolygonOnTriangulations 0\nSurfaces {n}\n",
            *surfs,
            f"\nTriangulations {n if triangulate else 0}\n",
            *tris,
            f"\nTShapes {n + 1}\n",
            *shapes,
            f"Co\n\n1100000\n{refs} *\n\n+1 0 \n",
        ]
    )


def _split_bounds(n: int, tile: int, breaks: Sequence[int] = ()) -> np.ndarray:
    """:func:`_tile_bounds` of each run of cells between the grid lines ``breaks``
    (tiles end there)."""
    cuts = np.unique(np.clip(np.concatenate([[0, n], np.asarray(breaks, np.int64)]), 0, n))
    return np.unique(np.concatenate([a + _tile_bounds(z - a, tile) for a, z in zip(cuts[:-1], cuts[1:])]))


def _leaves(rows: int, cols: int, tile: int, fine: Sequence | None, breaks=((), ()), block: bool = False) -> list[tuple[int, int, int, int]]:
    """Tiles ``(r0, r1, c0, c1)`` (grid line indices) over ``rows`` x ``cols`` cells:
    at most ``tile`` cells a side, ending at the grid lines ``breaks`` ``(rows,
    columns)``, and at most :data:`FINE` where a tile overlaps one of the ``fine``
    index rectangles ``(r0, r1, c0, c1)`` (or ``(r0, r1, c0, c1, cells)``: at most
    ``cells`` there)."""
    rb, cb = _split_bounds(rows, tile, breaks[0]), _split_bounds(cols, tile, breaks[1])
    out = []
    for i in range(len(rb) - 1):  # one per tile
        for j in range(len(cb) - 1):
            r0, r1, c0, c1 = int(rb[i]), int(rb[i + 1]), int(cb[j]), int(cb[j + 1])
            hit = [f for f in (fine or ()) if r0 < f[1] and f[0] < r1 and c0 < f[3] and f[2] < c1]
            if not hit:
                out.append((r0, r1, c0, c1))
                continue
            size = min(int(f[4]) if len(f) > 4 else FINE for f in hit)
            out += _fine_block((r0, r1, c0, c1), hit, size) if block else _fine_split((r0, r1, c0, c1), size)
    return out


def _fine_split(leaf: tuple, size: int) -> list:
    """The tile ``leaf`` ``(r0, r1, c0, c1)`` split into tiles of at most ``size``
    cells a side."""
    r0, r1, c0, c1 = leaf
    sr, sc = r0 + _tile_bounds(r1 - r0, size), c0 + _tile_bounds(c1 - c0, size)
    return [(int(sr[a]), int(sr[a + 1]), int(sc[c]), int(sc[c + 1])) for a in range(len(sr) - 1) for c in range(len(sc) - 1)]


def _fine_block(leaf: tuple, hit: list, size: int) -> list:
    """The tile ``leaf`` ``(r0, r1, c0, c1)`` with tiles of at most ``size`` cells a
    side over the part of it the index rectangles ``hit`` cover (their bounding box)
    and the rest in at most four tiles around that block (below and above it across
    the tile's width, left and right of it)."""
    r0, r1, c0, c1 = leaf
    ra, rz = max(r0, min(int(f[0]) for f in hit)), min(r1, max(int(f[1]) for f in hit))
    ca, cz = max(c0, min(int(f[2]) for f in hit)), min(c1, max(int(f[3]) for f in hit))
    rest = [(r0, ra, c0, c1), (rz, r1, c0, c1), (ra, rz, c0, ca), (ra, rz, cz, c1)]
    return [t for t in rest if t[1] > t[0] and t[3] > t[2]] + _fine_split((ra, rz, ca, cz), size)


def _tile_points(rows: int) -> int:
    """Gauss points OCCT's plain volume rule puts along the edges of a degree-1 tile
    of ``rows`` cells along ``v`` whose pcurves are lines or unpadded broken lines, and
    across its ``u`` range (``BRepGProp_Face::VIntegrationOrder``: ``max(8, 2 max(4,
    2 rows))``, at most :data:`~texcad.brep.gprop.GAUSS_POINTS`)."""
    return min(max(8, 4 * int(rows)), GAUSS_POINTS)


def _corner_stops(leaves: list, period: int | None = None) -> tuple[dict, dict]:
    """``(on_row, on_col)``: the tile corners on each grid row and column (grid
    indices, increasing), where the tiles' sides are split. ``period``: a closed
    band's last column (its first): both get the corners of either (small tiles under
    a tool at the first column split the last column's side too: one shared edge
    each, else the band is open there)."""
    corners = np.array([(l[0], l[2]) for l in leaves] + [(l[0], l[3]) for l in leaves]
                       + [(l[1], l[2]) for l in leaves] + [(l[1], l[3]) for l in leaves])  # fmt: skip
    corners = np.unique(corners, axis=0)
    on_row = {r: np.unique(corners[corners[:, 0] == r, 1]) for r in np.unique(corners[:, 0])}  # one per line
    on_col = {c: np.unique(corners[corners[:, 1] == c, 0]) for c in np.unique(corners[:, 1])}
    if period is not None and 0 in on_col and period in on_col:
        on_col[0] = on_col[period] = np.union1d(on_col[0], on_col[period])
    return on_row, on_col


def _right_pieces(leaf: tuple, on_col: dict) -> np.ndarray:
    """The grid rows where the right side of ``leaf`` ``(r0, r1, c0, c1)`` is split
    into edges (its ends included)."""
    stops = on_col[leaf[3]]
    return stops[(stops >= leaf[0]) & (stops <= leaf[1])]


def _relaid(leaves: list, rows: int, cols: int, tile: int, breaks, period: int | None = None) -> dict:
    """``{tile index: Gauss points}`` for the tiles among ``leaves`` that are not one
    of the grid's own runs of ``tile`` cells (the tiles under and around a CAD
    operation's tool) or whose right side is split by smaller tiles beside it: they
    get knots of their own (:func:`_own_knots`), placed for OCCT's plain rule with
    that many points: :data:`~texcad.brep.gprop.GAUSS_POINTS` on a tile across a
    whole run (its edges along ``y`` on the right get that order,
    :func:`_share_tile_edges`; its knots across stay the run's, which the edges
    along ``x`` keep for the faces beyond them, such as a band's end rings), else
    :func:`_tile_points`. ``period``: as :func:`_corner_stops`."""
    rb, cb = _split_bounds(rows, tile, breaks[0]), _split_bounds(cols, tile, breaks[1])
    ri, ci = {int(a): int(z) for a, z in zip(rb[:-1], rb[1:])}, {int(a): int(z) for a, z in zip(cb[:-1], cb[1:])}
    on_col = _corner_stops(leaves, period)[1]
    return {k: GAUSS_POINTS if ci.get(l[2]) == l[3] else _tile_points(l[1] - l[0]) for k, l in enumerate(leaves)  # one per tile
            if ri.get(l[0]) != l[1] or ci.get(l[2]) != l[3] or len(_right_pieces(l, on_col)) > 2}  # fmt: skip


def _own_knots(leaves: list, x: np.ndarray, y: np.ndarray, relaid: dict, period: int | None = None) -> list:
    """``[(u, v), ...]``: each tile's knots. Tiles in ``relaid`` get knots placed for
    OCCT's plain rule on themselves (:mod:`texcad.brep.gprop`): ``u`` at the partial
    sums of the weights of the rule of ``relaid[k]`` points over the tile's ``u``
    range, ``v`` so over each edge of its right side (the side whose edges carry the
    rule along ``v``: each edge integrates the face from its lowest ``u`` to the
    edge's); the corners keep the grid's knots ``x``, ``y``. The others keep ``x``,
    ``y``, placed for their runs (:func:`texcad.brep.gprop.run_knots`)."""
    on_col = _corner_stops(leaves, period)[1] if relaid else {}
    out = []
    for k, (r0, r1, c0, c1) in enumerate(leaves):  # one per tile
        if k not in relaid:
            out.append((x[c0 : c1 + 1], y[r0 : r1 + 1]))
            continue
        n = relaid[k]
        stops = _right_pieces(leaves[k], on_col).tolist()
        v = np.concatenate([[y[r0]]] + [gauss_knots(y[a], y[z], z - a, n)[1:] for a, z in zip(stops[:-1], stops[1:])])
        out.append((gauss_knots(x[c0], x[c1], c1 - c0, n), v))
    return out


def tiled_grid_faces(
    grid: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    *,
    tile: int = TILE,
    triangulate: bool = True,
    fine: Sequence | None = None,
    wrap_x: bool = False,
    outline: Any = None,
    breaks: tuple = ((), ()),
    leaves: list | None = None,
    edges_out: dict | None = None,
    relay: bool = False,
):
    """The degree-1 B-spline surface through an ``(R, C, 3)`` grid (mm), made as a
    patchwork of tiles of at most ``tile`` x ``tile`` cells that **share** their
    boundary edges and vertices (one ``TopoDS_Edge`` per tile side, with a pcurve on
    each of its two faces): together they are exactly the surface of
    :func:`grid_surface` (the tiles share the poles along their common grid lines), as
    faces OCCT meshes and cuts tile by tile.

    Tiles span whole grid cells; their knots are ``x`` and ``y`` (mm), so every edge's
    pcurve is a straight line and the 3-D curves are the surfaces' iso-curves
    (``S(u, y_r)``, ``S(x_c, v)``). ``fine``: index rectangles ``(r0, r1, c0, c1)``
    where the tiles are at most :data:`FINE` cells a side (where a CAD operation's
    tool meets the texture: over their bounding box in each tile they meet, the rest
    of that tile in up to four tiles); a larger tile next to them has its side split
    at their corners (shared vertices: no T-junctions). Without ``outline`` and
    ``leaves``, tiles that are not one of the grid's runs get knots of their own,
    placed for OCCT's plain volume rule on each (:func:`_own_knots`; the tiles' knots
    are then not all ``x`` and ``y``).

    ``triangulate``: each tile carries its triangulation (``Poly_Triangulation``):
    texcad's own mesh of the tile, the two triangles ``(a, b, c)``, ``(a, c, d)`` per
    cell through the poles, which the B-spline surface interpolates. OCCT's mesher
    (``BRepMesh_IncrementalMesh``, what CAD viewers run) keeps a face's triangulation
    and skips the face, and the STEP writer stores it (see
    :func:`texcad.io.write_step`), so a viewer shows texcad's mesh at once instead
    of re-meshing hundreds of thousands of poles.

    ``wrap_x``: the grid's last column is its first (a closed band): the tiles there
    share their edges with the first column's tiles, and ``boundary`` is
    ``{"v0": row 0's edges, "v1": the last row's}``, each left to right.

    ``outline``: the patchwork's border is made of given edges instead of the grid's
    own iso-lines (a face's boundary edges, split at the tile corners:
    :func:`texcad.solid.open_extrusion_solid`): ``outline(side, stops)`` for each
    side ``"v0"`` (row 0), ``"v1"`` (last row), ``"u0"`` (column 0), ``"u1"`` (last
    column) and the grid indices ``stops`` of the tile corners on it returns
    ``(vertices, pieces)``: one ``TopoDS_Vertex`` per stop and, per pair of
    consecutive stops, ``(edge, pcurve)``: the edge oriented towards the higher index
    and its ``Geom2d_Curve`` in the ``(x, y)`` parameter plane (its tolerance is the
    edge's own). ``breaks``: ``(rows, columns)`` grid lines where tiles must end
    (around narrow cells such as a wall: OCCT's Gauss integration of a tile is off
    where its cells differ in size by orders of magnitude). ``leaves``: the tiles
    ``(r0, r1, c0, c1)`` (grid line indices) to make instead of the whole grid's (any
    set of non-overlapping rectangles; ``boundary`` is then empty); ``edges_out``: a
    dict filled with every edge, ``{(horizontal, line, a, z): (edge, param_line)}``
    (grid indices; edges oriented towards the higher index). ``relay``: given
    ``leaves`` that are not one of the grid's runs of ``tile`` cells get knots of
    their own too (as without ``leaves``; ``x``, ``y`` then the runs' knots,
    :func:`texcad.brep.gprop.run_knots`, and the edges' parameters not mm: a face
    beyond them maps them, :func:`_mm_pcurve`).

    Returns:
        ``(faces, boundary)``: ``faces`` a list of forward ``TopoDS_Face`` (normal
        ``S_u x S_v``), ``boundary`` the edges around the patchwork, counter-clockwise
        about ``S_u x S_v`` (bottom row left to right, right column upwards, top row
        right to left, left column downwards), each ``(edge, param_line)`` with the
        edge oriented that way and ``param_line = (x0, y0, dx, dy)`` its pcurve in the
        ``(x, y)`` parameter plane.
    """
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.TopoDS import TopoDS, TopoDS_Iterator, TopoDS_Shape

    g = np.asarray(grid, np.float64)
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    if g.ndim != 3 or g.shape[2] != 3 or g.shape[:2] != (len(y), len(x)) or min(g.shape[:2]) < 2:
        raise ParameterError(f"a tiled grid needs an (R >= 2, C >= 2, 3) array with R y and C x knots, got {g.shape}")
    if not np.isfinite(g).all():
        raise GeometryError("the grid holds NaN or infinite coordinates")
    require_memory(g.shape[0] * g.shape[1] * 500.0, f"a {g.shape[0]} x {g.shape[1]} tiled B-spline face", "use a larger pitch")
    own = leaves is None
    if own:
        leaves = _leaves(g.shape[0] - 1, g.shape[1] - 1, tile, fine, breaks, block=outline is None)
    period = g.shape[1] - 1 if wrap_x else None
    relaid = _relaid(leaves, g.shape[0] - 1, g.shape[1] - 1, tile, breaks, period) if (own or relay) and outline is None else {}
    knots = _own_knots(leaves, x, y, relaid, period)
    text = _tile_text(
        [g[r0 : r1 + 1, c0 : c1 + 1] for r0, r1, c0, c1 in leaves],
        [u for u, _ in knots],
        [v for _, v in knots],
        triangulate,
    )
    comp = TopoDS_Shape()
    b = BRep_Builder()
    BRepTools.Read_s(comp, io.BytesIO(text.encode("ascii")), b)
    it = TopoDS_Iterator(comp)
    faces = []
    for _ in leaves:  # one per tile
        if not it.More():
            raise GeometryError(f"OCCT could not read the {len(leaves)} texture tiles")
        faces.append(TopoDS.Face_s(it.Value()))
        faces[-1].Free(True)  # read shapes are frozen; the wire is added below
        it.Next()
    out, boundary, edges = _share_tile_edges(b, g, x, y, leaves, faces, wrap_x, outline, knots, relaid)
    if edges_out is not None:
        edges_out.update(edges)
    return out, (boundary if own else [])


def _patch_boundary(edges: dict, R: int, C: int, wrap: bool):
    """The edges around a tile patchwork (``edges`` keyed ``(horizontal, line, a, z)``
    in grid indices, ``R`` x ``C`` cells): counter-clockwise, or for a closed band
    ``{"v0": row 0, "v1": row R}`` left to right."""
    from OCP.TopoDS import TopoDS

    def along(horizontal, idx, reverse):
        keys = sorted(key for key in edges if key[0] == horizontal and key[1] == idx)
        items = [edges[key] for key in keys]
        if reverse:
            items = [(TopoDS.Edge_s(e.Reversed()), line) for e, line in reversed(items)]
        return items

    if wrap:
        return {"v0": along(True, 0, False), "v1": along(True, R, False)}
    return along(True, 0, False) + along(False, C, False) + along(True, R, True) + along(False, 0, True)


#: Poles remembered by :func:`tile_grid` (the most recent tiles' surfaces, at most this many
#: poles in all, about 100 MB; older ones are forgotten and read back from OCCT instead).
TILE_MEMORY = 4_000_000
_TILES: "OrderedDict[int, tuple]" = OrderedDict()
_TILE_POLES = [0]


def _remember_tile(surface, grid: np.ndarray, u: np.ndarray, v: np.ndarray) -> None:
    """Keep a tile's grid (mm) next to its OCCT surface for :func:`tile_grid` (the
    surface object is kept alive with it, so its Python identity stays its own)."""
    _TILES[id(surface)] = (surface, grid, u, v, grid.shape[0] * grid.shape[1])
    _TILE_POLES[0] += grid.shape[0] * grid.shape[1]
    while _TILE_POLES[0] > TILE_MEMORY and len(_TILES) > 1:  # the oldest tiles first
        _TILE_POLES[0] -= _TILES.popitem(last=False)[1][4]


def tile_grid(surface) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The ``(grid (R, C, 3) mm, u (C,), v (R,))`` of a texture tile's degree-1
    B-spline surface (:func:`tiled_grid_faces`), the same numbers the surface holds,
    without reading its poles through OCCT one by one; None when this surface is not a
    remembered tile (then :func:`surface_grid` reads it)."""
    got = _TILES.get(id(surface))
    if got is None or got[0] is not surface:
        return None
    return got[1], got[2], got[3]


def transformed_shape(shape: Any, matrix: np.ndarray):
    """``shape`` moved or mirrored by the ``(3, 4)`` matrix ``matrix`` (mm), geometry
    and triangulations copied (``BRepBuilderAPI_Transform``, no locations: texcad's
    STEP writer and OCCT's mesher see the tiles as tiles); the copies of texture tiles
    are remembered with their transformed grids (:func:`tile_grid`).

    Raises:
        ParameterError: ``matrix`` is not ``(3, 4)`` with a non-singular rotation part.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    m = np.asarray(matrix, np.float64)
    if m.shape != (3, 4) or abs(np.linalg.det(m[:, :3])) < 1e-12:
        raise ParameterError(f"a placement must be a (3, 4) matrix with an invertible rotation, got {m.shape}")
    t = gp_Trsf()
    t.SetValues(*[float(m[i, j]) for i in range(3) for j in range(4)])
    topo = to_topods(shape)
    mk = BRepBuilderAPI_Transform(topo, t, True, True)
    for f in explore(topo, TopAbs_FACE):  # one per face
        got = tile_grid(BRep_Tool.Surface_s(TopoDS.Face_s(f)))
        if got is not None:
            new = BRep_Tool.Surface_s(TopoDS.Face_s(mk.ModifiedShape(f)))
            _remember_tile(new, got[0] @ m[:, :3].T + m[:, 3], got[1], got[2])
    return mk.Shape()


def _share_tile_edges(b, g: np.ndarray, x: np.ndarray, y: np.ndarray, leaves: list, faces: list, wrap_x: bool = False,
                      outline: Any = None, knots: list | None = None, relaid: dict | None = None):
    """Give the tile faces (``leaves`` ``(r0, r1, c0, c1)`` of the grid ``g``) shared
    vertices and edges, split at every tile corner on a side, with straight pcurves
    (the border's edges from ``outline`` if given, see :func:`tiled_grid_faces`;
    those along ``y`` of at least :data:`PLACED` cells broken lines of
    :data:`~texcad.brep.gprop.PAD_SPANS` spans or more, with knots at the rows, for
    OCCT's plain volume integration: :mod:`texcad.brep.gprop`). ``knots``: each
    tile's ``(u, v)`` (default ``x``, ``y``); ``relaid``: tiles with knots of their
    own (:func:`_own_knots`): an edge along ``y`` beside one is made on the tile to
    its left (its parameters are that tile's knots, placed for its rule) and a tile
    whose knots differ from an edge's parameters gets a broken-line pcurve mapping
    them. Returns :func:`tiled_grid_faces`' ``(faces, boundary)`` and every edge (a
    dict)."""
    from OCP.BRep import BRep_Tool
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS_Edge, TopoDS_Vertex

    knots = knots or [(x[c0 : c1 + 1], y[r0 : r1 + 1]) for r0, r1, c0, c1 in leaves]
    relaid = relaid or {}
    surf = {k: BRep_Tool.Surface_s(f) for k, f in enumerate(faces)}  # one per tile
    for k, (r0, r1, c0, c1) in enumerate(leaves):  # one per tile
        _remember_tile(surf[k], g[r0 : r1 + 1, c0 : c1 + 1], *knots[k])
    on_row, on_col = _corner_stops(leaves, g.shape[1] - 1 if wrap_x else None)
    verts, edges, params = {}, {}, {}
    given = _given_outline(outline, on_row, on_col, g.shape[0] - 1, g.shape[1] - 1, verts, edges)
    period = g.shape[1] - 1 if wrap_x else None
    owner = _left_owners(leaves, on_col, relaid, period)

    def vertex(r, c):
        if period is not None:
            c = c % period  # the last grid column is the first
        if (r, c) not in verts:
            v = TopoDS_Vertex()
            b.MakeVertex(v, gp_Pnt(*g[r, c]), TOLERANCE)
            verts[r, c] = v
        return verts[r, c]

    def along(k, horizontal, a, z):
        """Tile ``k``'s knots at the grid lines ``a .. z`` along a side."""
        r0, _, c0, _ = leaves[k]
        return knots[k][0][a - c0 : z + 1 - c0] if horizontal else knots[k][1][a - r0 : z + 1 - r0]

    def make(k, key, line_idx, a, z, at):
        """The edge ``key`` as an iso-curve of tile ``k`` (its parameters: ``k``'s
        knots) at the grid column ``at`` (along ``y``)."""
        horizontal = key[0]
        curve = surf[k].VIso(float(y[line_idx])) if horizontal else surf[k].UIso(float(x[at]))
        p = along(k, horizontal, a, z)
        border = line_idx in ((0, g.shape[0] - 1) if horizontal else (() if period else (0, g.shape[1] - 1)))
        if k in relaid and border and (horizontal or leaves[k][2] == line_idx):  # not a tile's right side: free
            curve, p = _border_curve(g, x, y, horizontal, line_idx, a, z)
        e = TopoDS_Edge()
        b.MakeEdge(e, curve, TOLERANCE)
        ends = ((line_idx, a), (line_idx, z)) if horizontal else ((a, line_idx), (z, line_idx))
        b.Add(e, vertex(*ends[0]).Oriented(TopAbs_FORWARD))
        b.Add(e, vertex(*ends[1]).Oriented(TopAbs_REVERSED))
        b.Range(e, float(p[0]), float(p[-1]))
        params[key] = p
        return e

    def side(k, horizontal, line_idx, lo, hi):
        """Edges along one side of leaf ``k``, split at every corner on it, in
        increasing grid index; each gets this leaf's pcurve."""
        stops = on_row[line_idx] if horizontal else on_col[line_idx]
        stops = stops[(stops >= lo) & (stops <= hi)]
        line = (0.0, float(y[line_idx]), 1.0, 0.0) if horizontal else (float(x[line_idx]), 0.0, 0.0, 1.0)
        out = []
        for a, z in zip(stops[:-1], stops[1:]):  # one per edge
            key = (horizontal, int(line_idx), int(a), int(z))
            if period is not None and not horizontal:
                key = (horizontal, int(line_idx) % period, int(a), int(z))
            if key not in edges:
                j = owner.get(key, k)  # the tile to its left (its right side: a closed band's last column is its first)
                edges[key] = (make(j, key, line_idx, int(a), int(z), line_idx if j == k else leaves[j][3]), line)
            e, mine = edges[key][0], along(k, horizontal, int(a), int(z))
            if key in given:  # a given border edge: its own pcurve and tolerance
                b.UpdateEdge(e, edges[key][1], faces[k], BRep_Tool.Tolerance_s(e))
            else:
                long_side = hi - lo >= PLACED and z - a > 1
                wide = relaid.get(k) == GAUSS_POINTS and leaves[k][3] == line_idx  # right side, a run wide (_relaid)
                pc = _tile_pcurve(line, mine, params[key], z - a, long_side, wide, k in relaid)
                b.UpdateEdge(e, pc, faces[k], TOLERANCE)
            out.append(e)
        return out

    out = [_tile_wire(b, k, leaf, faces[k], side) for k, leaf in enumerate(leaves)]  # one per tile
    return out, _patch_boundary(edges, g.shape[0] - 1, g.shape[1] - 1, period is not None), edges


def _border_curve(g: np.ndarray, x: np.ndarray, y: np.ndarray, horizontal: bool, line: int, a: int, z: int) -> tuple:
    """``(curve, params)`` of a tile edge on a patch's border along the grid line
    ``line`` from ``a`` to ``z`` (grid indices; ``g`` the grid, mm, ``x``, ``y`` its
    knots): the face beyond integrates along it (a plane, a band's end ring) with the
    rule OCCT gives a degree-1 pcurve of its spans, so its parameters are placed for
    that (over a whole run: the grid's own knots), and its curve is the polyline
    through the grid points there."""
    pts = g[line, a : z + 1] if horizontal else g[a : z + 1, line]
    p = gauss_knots(*(x[[a, z]] if horizontal else y[[a, z]]), z - a, min(max(8, 4 * (z - a)), GAUSS_POINTS))
    return _polyline_3d(pts, p), p


def _tile_pcurve(line: tuple, mine: np.ndarray, params: np.ndarray, span: int, long_side: bool, wide: bool, own: bool):
    """The pcurve on a tile of its edge along the grid line ``line`` ``(x0, y0, dx,
    dy)`` over ``span`` cells, at the tile's knots ``mine`` at the grid lines and
    the edge's parameters ``params`` there: a broken line from those onto these
    where they differ (another tile's parameters); else along ``y``, for OCCT's plain
    rule, a broken line of :data:`~texcad.brep.gprop.PAD_SPANS` spans or more with
    knots at the rows (61 points) if at least :data:`PLACED` cells long and the tile
    keeps its run's knots, or on the right side of a tile across a whole run with knots
    of its own (``wide``), or with knots at the rows, where OCCT's adaptive rule
    starts, on a piece of a ``long_side`` (small tiles beside it: a line is 0.28 %
    off) or of a tile with knots of its own (``own``: as many points as its rule
    across); else a line."""
    from OCP.Geom2d import Geom2d_Line
    from OCP.gp import gp_Dir2d, gp_Pnt2d

    horizontal = line[3] == 0.0
    fixed = np.full(len(mine), line[1] if horizontal else line[0])
    pts = np.stack([mine, fixed] if horizontal else [fixed, mine], axis=-1)
    if not np.array_equal(mine, params):
        return polyline_pcurve(pts, params, pad=False)
    if not horizontal and (span >= PLACED or long_side or wide):
        return polyline_pcurve(pts, mine, pad=wide or (span >= PLACED and not own))
    return Geom2d_Line(gp_Pnt2d(line[0], line[1]), gp_Dir2d(line[2], line[3]))


def _polyline_3d(points: np.ndarray, params: np.ndarray):
    """The degree-1 ``Geom_BSplineCurve`` through ``points`` ``(m + 1, 3)`` (mm) at
    the increasing ``params`` ``(m + 1,)``: a tile's iso-curve along a grid line with
    other parameters."""
    from OCP.Geom import Geom_BSplineCurve
    from OCP.gp import gp_Pnt
    from OCP.TColgp import TColgp_Array1OfPnt
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal

    n = len(params)
    poles, knots, mults = TColgp_Array1OfPnt(1, n), TColStd_Array1OfReal(1, n), TColStd_Array1OfInteger(1, n)
    for i, (q, t) in enumerate(zip(np.asarray(points, np.float64).tolist(), np.asarray(params, np.float64).tolist()), 1):  # per grid point of one edge (tens)
        poles.SetValue(i, gp_Pnt(*q))
        knots.SetValue(i, t)
        mults.SetValue(i, 2 if i in (1, n) else 1)
    return Geom_BSplineCurve(poles, knots, mults, 1)


def _left_owners(leaves: list, on_col: dict, relaid: set, period: int | None) -> dict:
    """``{edge key: tile}`` for the edges along ``y`` beside a tile in ``relaid``:
    the tile to the edge's left (whose right side it is; see
    :func:`_share_tile_edges`)."""
    if not relaid:
        return {}
    right_of = {}
    for k, leaf in enumerate(leaves):  # one per tile: the edges of its right side
        stops = _right_pieces(leaf, on_col).tolist()
        for a, z in zip(stops[:-1], stops[1:]):  # one per edge
            right_of[(False, leaf[3] % period if period else leaf[3], a, z)] = k
    out = {}
    for k, (r0, r1, c0, c1) in enumerate(leaves):  # one per tile
        if k in relaid:
            out.update({key: j for key, j in right_of.items() if key[1] in (c0 % period if period else c0, c1 % period if period else c1)
                        and r0 <= key[2] and key[3] <= r1})  # fmt: skip
    return out


def _tile_wire(b, k: int, leaf: tuple, face, side):
    """Give tile ``k`` (``leaf`` ``(r0, r1, c0, c1)``) its wire of shared edges
    (``side(k, horizontal, line, lo, hi)``: the edges along one side, oriented
    towards the higher grid index), counter-clockwise; returns the face."""
    from OCP.TopoDS import TopoDS_Wire

    r0, r1, c0, c1 = leaf
    w = TopoDS_Wire()
    b.MakeWire(w)
    for e in side(k, True, r0, c0, c1):  # bottom, left to right
        b.Add(w, e)
    for e in side(k, False, c1, r0, r1):  # right, upwards
        b.Add(w, e)
    for e in reversed(side(k, True, r1, c0, c1)):  # top, right to left
        b.Add(w, e.Reversed())
    for e in reversed(side(k, False, c0, r0, r1)):  # left, downwards
        b.Add(w, e.Reversed())
    w.Closed(True)
    b.Add(face, w)
    return face


def _given_outline(outline: Any, on_row: dict, on_col: dict, R: int, C: int, verts: dict, edges: dict) -> set:
    """Fill ``verts`` and ``edges`` with the border of a tile patchwork from
    ``outline`` (see :func:`tiled_grid_faces`); returns the keys of the given edges."""
    given: set = set()
    if outline is None:
        return given
    for name, horizontal, idx in (("v0", True, 0), ("v1", True, R), ("u0", False, 0), ("u1", False, C)):  # 4 sides
        stops = on_row[idx] if horizontal else on_col[idx]
        vs, pieces = outline(name, stops)
        if len(vs) != len(stops) or len(pieces) != len(stops) - 1:
            raise GeometryError(f"internal: the outline's side {name} has {len(pieces)} edges for {len(stops)} tile corners")
        for s, v in zip(stops.tolist(), vs):  # per tile corner on the side
            verts[(idx, s) if horizontal else (s, idx)] = v
        for a, z, piece in zip(stops[:-1].tolist(), stops[1:].tolist(), pieces):  # per edge
            key = (horizontal, idx, a, z)
            edges[key] = piece
            given.add(key)
    return given


def tiled_plane_solid(
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
    triangulate: bool = True,
    fine: Sequence | None = None,
):
    """``shape`` with a planar ``face`` textured in place, the texture in tiles.

    Like :func:`textured_plane_face` + :func:`replace_face` (same surface: vertex
    ``(r, c)`` at ``origin + x[c] xdir + y[r] ydir + heights[r, c] normal``), but the
    part of the grid that leaves the plane - the rectangle of rows and columns one
    beyond the outermost non-zero heights, where every height on its border is 0 - is
    made by :func:`tiled_grid_faces`, and the rest of the face stays a plane with the
    face's own wires and that rectangle as a hole. The tiles' border edges lie on the
    plane, so the planar face and the tiles share them: a closed shell by construction,
    no boolean, no sewing.

    ``triangulate``: the tiles carry texcad's mesh as their triangulation (see
    :func:`tiled_grid_faces`). ``fine``: rectangles ``(x0, x1, y0, y1)`` in the face
    frame (mm) where the tiles are at most :data:`FINE` cells a side (where a CAD
    operation's tool will meet the texture).

    Returns:
        The new shape, or None when the rectangle is not inside the face (an outline
        crosses it: use :func:`textured_plane_face`).
    """
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.Geom import Geom_Plane
    from OCP.Geom2d import Geom2d_Line
    from OCP.GeomAPI import GeomAPI
    from OCP.gp import gp_Dir2d, gp_Pnt2d
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS, TopoDS_Face, TopoDS_Iterator, TopoDS_Shell, TopoDS_Wire

    old = TopoDS.Face_s(to_topods(face))
    o, ex, n = (np.asarray(a, np.float64) for a in (origin, xdir, normal))
    ey = np.cross(n, ex)
    h = np.asarray(heights, np.float64)
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    lifted_r, lifted_c = np.nonzero((h != 0).any(axis=1))[0], np.nonzero((h != 0).any(axis=0))[0]
    if not len(lifted_r):
        return None
    r0, r1 = max(0, lifted_r[0] - 1), min(len(y) - 1, lifted_r[-1] + 1)
    c0, c1 = max(0, lifted_c[0] - 1), min(len(x) - 1, lifted_c[-1] + 1)
    if r1 - r0 < 1 or c1 - c0 < 1 or h[[r0, r1]].any() or h[:, [c0, c1]].any():
        return None  # non-zero heights on the grid's own border
    # The rectangle must lie inside the face: no outline point in it, its centre inside.
    segs = face_segments(old, 0.25 * float(min(x[1] - x[0], y[1] - y[0]))) - o
    uv = np.stack([segs @ ex, segs @ ey], axis=-1)
    p = uv.reshape(-1, 2)
    eps = 1e-9 * float(np.abs(p).max() + 1.0)
    if ((p[:, 0] > x[c0] - eps) & (p[:, 0] < x[c1] + eps) & (p[:, 1] > y[r0] - eps) & (p[:, 1] < y[r1] + eps)).any():
        return None
    mid = np.array([0.5 * (x[c0] + x[c1])]), np.array([0.5 * (y[r0] + y[r1])])
    if not inside(uv, *mid)[0, 0]:
        return None
    xs, ys = x[c0 : c1 + 1], y[r0 : r1 + 1]
    grid = o + xs[None, :, None] * ex + ys[:, None, None] * ey + h[r0 : r1 + 1, c0 : c1 + 1, None] * n
    idx = []
    for f in fine or ():  # one per tool: (x0, x1, y0, y1[, cells])
        (ca, cz), (ra, rz) = np.searchsorted(xs, f[:2]) + [-1, 1], np.searchsorted(ys, f[2:4]) + [-1, 1]
        idx.append((int(ra), int(rz), int(ca), int(cz), *f[4:]))
    xk, yk = run_knots(xs, _split_bounds(c1 - c0, tile)), run_knots(ys, _split_bounds(r1 - r0, tile))  # for OCCT's plain Gauss rule
    tiles, boundary = tiled_grid_faces(grid, xk, yk, tile=tile, triangulate=triangulate, fine=idx)
    pln = _frame_pln(o, n, ex)
    b = BRep_Builder()
    flat = TopoDS_Face()
    b.MakeFace(flat, Geom_Plane(pln), TOLERANCE)
    it = TopoDS_Iterator(old)  # the face's wires, its orientation composed in
    while it.More():  # one per wire (outline and holes)
        b.Add(flat, it.Value())
        it.Next()
    for e in explore(old, TopAbs_EDGE):  # one per outline edge
        edge = TopoDS.Edge_s(e)
        curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
        if curve is None:
            raise GeometryError("an edge of the face has no 3-D curve; rebuild the part (BRepLib.BuildCurves3d)")
        b.UpdateEdge(edge, GeomAPI.To2d_s(curve, pln), flat, TOLERANCE)
    hole = TopoDS_Wire()
    b.MakeWire(hole)
    for e, line in reversed(boundary):  # clockwise: a hole in the planar face
        b.Add(hole, e.Reversed())
        b.UpdateEdge(TopoDS.Edge_s(e), _mm_pcurve(TopoDS.Edge_s(e), line, (xk, xs), (yk, ys)), flat, TOLERANCE)
    hole.Closed(True)
    b.Add(flat, hole)
    patch = TopoDS_Shell()
    b.MakeShell(patch)
    for f in [flat, *tiles]:  # one per tile
        b.Add(patch, f)
    return _replace_by_faces(to_topods(shape), old, patch)


def _mm_pcurve(edge, line: tuple, xs: tuple, ys: tuple):
    """The pcurve on the face frame's plane (mm) of a tile edge along the grid line
    ``line`` (its pcurve on the tiles, in knots): ``xs``, ``ys`` the ``(knots,
    mm)`` of the grid's columns and rows; a broken line through the grid points at
    the knots (the knots are not mm: :func:`texcad.brep.gprop.run_knots`), of
    :data:`~texcad.brep.gprop.PAD_SPANS` spans or more if at least :data:`PLACED`
    cells long."""
    from OCP.BRep import BRep_Tool

    t0, t1 = BRep_Tool.Range_s(edge)
    (along, mm), (across, mm_across) = (xs, ys) if line[3] == 0.0 else (ys, xs)
    a, z = np.searchsorted(along, [min(t0, t1), max(t0, t1)])
    fixed = float(np.interp(line[1] if line[3] == 0.0 else line[0], across, mm_across))
    pts = np.stack([mm[a : z + 1], np.full(z + 1 - a, fixed)], axis=-1)
    params = _edge_knots(edge, z + 1 - a)
    if params is None:
        params = along[a : z + 1]
    return polyline_pcurve(pts if line[3] == 0.0 else pts[:, ::-1], params, pad=z - a >= PLACED)


def _edge_knots(edge, count: int) -> np.ndarray | None:
    """The knots within its range of an edge's 3-D curve (a tile's degree-1
    iso-curve: the parameters at the grid lines, those of the tile it was made on,
    :func:`_own_knots`), or None unless there are ``count``."""
    from OCP.BRep import BRep_Tool
    from OCP.GeomAbs import GeomAbs_BSplineCurve
    from OCP.GeomAdaptor import GeomAdaptor_Curve

    t0, t1 = sorted(BRep_Tool.Range_s(edge))
    c = GeomAdaptor_Curve(BRep_Tool.Curve_s(edge, 0.0, 0.0))
    if c.GetType() != GeomAbs_BSplineCurve:
        return None
    bs = c.BSpline()
    k = np.array([bs.Knot(i) for i in range(1, bs.NbKnots() + 1)])
    k = k[(k >= t0) & (k <= t1)]
    return k if len(k) == count and k[0] == t0 and k[-1] == t1 else None


def _replace_by_faces(shape, old, patch):
    """``shape`` with the face ``old`` replaced by the faces of the shell ``patch``
    (forward faces whose normals point out of the body)."""
    from OCP.TopAbs import TopAbs_FACE

    return _replace_faces(shape, [(old, explore(patch, TopAbs_FACE))])


def _replace_faces(shape, swaps: list):
    """``shape`` with each old face of ``swaps`` ``[(old, [new faces]), ...]`` replaced
    by its new faces (oriented as they are to lie in the shell: normals outward)."""
    from OCP.BRep import BRep_Builder
    from OCP.TopAbs import TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopoDS import TopoDS_Compound, TopoDS_Iterator, TopoDS_Shell, TopoDS_Solid

    b = BRep_Builder()
    hits = [False] * len(swaps)

    def rebuild(s):
        kind = s.ShapeType()
        if kind == TopAbs_SHELL:
            sh = TopoDS_Shell()
            b.MakeShell(sh)
            it = TopoDS_Iterator(s)
            found = False
            while it.More():  # one per face of the shell
                f = it.Value()
                for k, (old, new) in enumerate(swaps):  # a few swaps
                    if f.IsSame(old):
                        found = hits[k] = True
                        for nf in new:  # the new faces
                            b.Add(sh, nf)
                        break
                else:
                    b.Add(sh, f)
                it.Next()
            sh.Closed(True if found else s.Closed())
            return (sh if found else s), found
        if kind == TopAbs_SOLID or kind.name.endswith("COMPOUND") or kind.name.endswith("COMPSOLID"):
            out = TopoDS_Solid() if kind == TopAbs_SOLID else TopoDS_Compound()
            if kind == TopAbs_SOLID:
                b.MakeSolid(out)
            else:
                b.MakeCompound(out)
            it = TopoDS_Iterator(s)
            hit = False
            while it.More():  # one per sub-shape (shells, solids)
                sub, f = rebuild(it.Value())
                b.Add(out, sub)
                hit |= f
                it.Next()
            return (out if hit else s), hit
        return s, False

    # The new faces point outward like the old ones: the solids keep their orientation
    # (checked_brep checks the volume's sign and size).
    result, _ = rebuild(shape)
    if not all(hits):
        raise GeometryError("internal: a face to replace is not in the part")
    return result


def _band_fine(grid: np.ndarray, boxes) -> list | None:
    """Index rectangles ``(r0, r1, c0, c1[, cells])`` of a closed band's grid (``(R,
    C + 1, 3)`` mm, the last column the first) around its poles inside each box
    ``(lo (3,), hi (3,)[, cells])`` mm, one cell wider: one rectangle per run of
    neighbouring columns (a tool through the band meets it twice)."""
    if not boxes:
        return None
    out, last = [], grid.shape[1] - 1
    for box in boxes:  # one per CAD operation's tool
        hit = ((grid >= np.asarray(box[0])) & (grid <= np.asarray(box[1]))).all(axis=-1)
        rows, cols = np.nonzero(hit.any(axis=1))[0], np.nonzero(hit.any(axis=0))[0]
        if not len(rows):
            continue
        r0, r1 = max(int(rows.min()) - 1, 0), min(int(rows.max()) + 1, grid.shape[0] - 1)
        runs = np.split(cols, np.nonzero(np.diff(cols) > 1)[0] + 1)
        for run in runs:  # one per run of columns
            out.append((r0, r1, max(int(run[0]) - 1, 0), min(int(run[-1]) + 1, last), *box[2:]))
    return out


def textured_band_solid(shape: Any, face: Any, top: np.ndarray, *, tile: int = TILE, fine=None):
    """``shape`` with a closed band face (a cylinder's side, any closed extruded
    profile) textured by the grid ``top`` in tiles, **without a boolean**.

    ``top`` is ``(R, C, 3)`` mm, closed in x (column ``C - 1`` joins column 0), with
    ``d(top)/dc x d(top)/dr`` outward, outside the face, and its first and last rows
    each in a plane across the band, inside the face's length (the pixel rows end
    half a pixel short of the face's ends). The face is split by those two planes
    (``BRepAlgoAPI_Splitter``: a plane across a cylinder or an extrusion, exact); its
    middle part is replaced by :func:`tiled_grid_faces` (``wrap_x``) and two planar
    rings between the split's section edges and the end rows' edges: the slab walls
    of texcad's mesh. Every edge is shared: closed by construction. ``fine``: boxes
    ``(lo (3,), hi (3,)[, cells])`` mm where the tiles are small (a CAD operation's
    tool, as :func:`texcad.brep.open_extrusion_solid`).

    Returns:
        The new shape, or None where this does not apply (then use :func:`grid_brep`
        + :func:`fuse_solids`).
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Splitter
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_ListOfShape

    topo, band = to_topods(shape), TopoDS.Face_s(to_topods(face))
    g = np.asarray(top, np.float64)
    extent = float(np.ptp(g.reshape(-1, 3), axis=0).max()) or 1.0
    planes = []
    for r, inward in ((0, 1), (-1, -2)):  # the two end rows
        row = g[r]
        centre = row.mean(axis=0)
        nrm = np.linalg.svd(row - centre, full_matrices=False)[2][2]
        if np.abs((row - centre) @ nrm).max() > 1e-7 * extent:
            return None
        if float((g[inward].mean(axis=0) - centre) @ nrm) > 0:
            nrm = -nrm  # pointing away from the texture: the ring's outward normal
        planes.append((centre, nrm))
    # The planes must cut the band strictly inside its length.
    ends = face_segments(band, 0.05 * extent).reshape(-1, 3)
    for centre, nrm in planes:
        d = (ends - centre) @ nrm
        if not (d.max() > 1e-4 and d.min() < -1e-4):  # mm: the face reaches past the plane
            return None
    tools = TopTools_ListOfShape()
    big = 10.0 * extent
    pl = [gp_Pln(gp_Pnt(*map(float, c)), gp_Dir(*map(float, n))) for c, n in planes]
    for p in pl:  # two cutting planes
        tools.Append(BRepBuilderAPI_MakeFace(p, -big, big, -big, big).Face())
    args = TopTools_ListOfShape()
    args.Append(band)  # the face alone: its end edges, shared with the body, stay as they are
    sp = BRepAlgoAPI_Splitter()
    sp.SetArguments(args)
    sp.SetTools(tools)
    sp.Build()
    if not sp.IsDone():
        return None
    split = sp.Shape()
    middle, strips = None, []
    for f in explore(split, TopAbs_FACE):  # the band's pieces (3), oriented as the band
        props = GProp_GProps()
        BRepGProp.SurfaceProperties_s(f, props)
        c = np.array(props.CentreOfMass().Coord())
        if all(float((c - centre) @ nrm) < 0 for centre, nrm in planes):
            middle = TopoDS.Face_s(f)
        else:
            strips.append(TopoDS.Face_s(f))
    if middle is None or len(strips) != 2:
        return None
    sections = [TopoDS.Edge_s(e) for e in explore(middle, TopAbs_EDGE) if not BRep_Tool.IsClosed_s(TopoDS.Edge_s(e), middle)]
    if len(sections) != 2:
        return None
    grid = np.concatenate([g, g[:, :1]], axis=1)
    u, v = np.arange(grid.shape[1], dtype=np.float64), np.arange(grid.shape[0], dtype=np.float64)
    u, v = run_knots(u, _split_bounds(len(u) - 1, tile)), run_knots(v, _split_bounds(len(v) - 1, tile))  # for OCCT's plain Gauss rule
    tiles, rows = tiled_grid_faces(grid, u, v, tile=tile, wrap_x=True, fine=_band_fine(grid, fine))
    new_faces = strips + list(tiles)
    for (centre, nrm), p, key in zip(planes, pl, ("v0", "v1")):  # the two rings
        sec = [e for e in sections if abs(float((edge_points(e, 0.1 * extent)[0] - centre) @ nrm)) < 1e-6 * extent]
        if len(sec) != 1:
            return None
        ring = _ring_face(p, next(e for e in explore(middle, TopAbs_EDGE) if e.IsSame(sec[0])), rows[key], key == "v0")
        if ring is None:
            return None
        new_faces.append(ring)
    return _replace_faces(topo, [(band, new_faces)])


def _ring_face(pln, section, row: list, first: bool):
    """The planar ring (plane ``pln``, normal away from the texture) between a band's
    section edge (as the band's middle piece ran it) and the texture's end row edges
    (``first``: row 0, which the tiles run forward)."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.Geom import Geom_Plane
    from OCP.GeomAPI import GeomAPI
    from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopoDS import TopoDS, TopoDS_Face, TopoDS_Wire

    b = BRep_Builder()
    ring = TopoDS_Face()
    b.MakeFace(ring, Geom_Plane(pln), TOLERANCE)
    # The strip beyond runs the section edge against the middle piece; the ring, which
    # takes the middle piece's place along it, runs it as the middle piece did. The
    # tiles run row 0 forward and the last row reversed: the ring the other way.
    w1, w2 = TopoDS_Wire(), TopoDS_Wire()
    b.MakeWire(w1)
    b.Add(w1, section)
    w1.Closed(True)
    b.MakeWire(w2)
    want = TopAbs_REVERSED if first else TopAbs_FORWARD
    for edge, _ in row:  # one per tile along the end
        b.Add(w2, edge.Oriented(want))
    w2.Closed(True)
    b.Add(ring, w1)
    b.Add(ring, w2)
    for e in [section] + [edge for edge, _ in row]:  # pcurves on the ring's plane
        edge = TopoDS.Edge_s(e)
        curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
        if curve is None:
            return None
        b.UpdateEdge(edge, GeomAPI.To2d_s(curve, pln), ring, TOLERANCE)
    return ring


def textured_extrusion_solid(shape: Any, face: Any, top: np.ndarray, bottom: np.ndarray, *, closed: bool, fine=None):
    """``shape`` with a face of an extruded profile textured: the texture grid ``top``
    (``(R, C, 3)`` mm, outward ``d/dc x d/dr``) and the slab's ``bottom`` inside the
    body (as :func:`grid_brep`).

    A closed band whose ends are planar faces (a cylinder, a boss on a plate, any
    closed extruded profile between planes) gets :func:`textured_band_solid`: the
    face is replaced, no boolean (``fine``: boxes where its tiles are small, see
    there). Other faces get the slab of :func:`grid_brep` fused
    onto the body by OCCT's boolean (:func:`fuse_solids`; slow on fine grids).

    Raises:
        GeometryError: the boolean failed or changed the number of solids.
    """
    if closed:
        out = textured_band_solid(shape, face, top, fine=fine)
        if out is not None:
            return out
    topo = to_topods(shape)
    slab = grid_brep(top, bottom, wrap_x=closed)
    return fuse_solids(topo, slab, solids=len(solids_of(topo)))


#: Relative precision asked of OCCT's adaptive volume integration (:func:`occt_volume`).
OCCT_EPS = 1e-4


def plain_volume(shape: Any) -> float:
    """Volume in mm^3 by OCCT's plain integration, ``BRepGProp::VolumeProperties``
    without a tolerance: a fixed Gauss rule per face, what build123d's ``.volume`` and
    FreeCAD give (exact where the knots are placed for it, :mod:`texcad.brep.gprop`)."""
    return _gprop_volume(shape, None)


def _gprop_volume(shape: Any, eps: "float | None") -> float:
    """``BRepGProp::VolumeProperties`` of ``shape``, mm^3: its plain rule (``eps``
    None) or adaptive to the relative error ``eps`` over closed shells only."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    if eps is None:
        BRepGProp.VolumeProperties_s(to_topods(shape), props)
    else:
        BRepGProp.VolumeProperties_s(to_topods(shape), props, float(eps), True)
    return float(props.Mass())


def occt_volume(shape: Any, eps: float = OCCT_EPS) -> float:
    """Volume in mm^3 by OCCT's own integrator: ``BRepGProp::VolumeProperties(shape,
    props, eps, OnlyClosed=True)``, adaptive Gauss integration to the relative error
    ``eps`` (OCCT's default, non-adaptive integration agrees on texcad's tiles and
    strips, whose knots are placed for it, :mod:`texcad.brep.gprop`; not on other
    B-spline faces of many spans). Independent of texcad's
    own :func:`volume` (exact on untrimmed grid faces, OCCT's plain Gauss integration
    on faces a boolean trimmed)."""
    return _gprop_volume(shape, eps)


def flat_solids(shape: Any):
    """``shape``'s solids as one flat ``TopoDS_Compound`` (each solid a direct child,
    with its location), free shells (not in a solid) made solids.

    What a textured B-rep is handed out as: build123d's ``Part(shape).volume`` sums
    only the solids and shells that are direct children of a compound, so a bare
    ``TopoDS_Solid`` gives 0 and nested compounds hide theirs (issue 28: a textured
    knob top's ``Textured.part.volume`` was 0).
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeSolid
    from OCP.TopAbs import TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from .occt import compound, solids_of

    topo = to_topods(shape)
    out = solids_of(topo)
    exp = TopExp_Explorer(topo, TopAbs_SHELL, TopAbs_SOLID)
    while exp.More():  # one per free shell
        out.append(BRepBuilderAPI_MakeSolid(TopoDS.Shell_s(exp.Current())).Solid())
        exp.Next()
    return compound(out)
