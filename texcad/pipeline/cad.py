"""Textures on faces of build123d and CadQuery parts: the CAD branch of
``texcad.texture(part, faces, texture)``.

Pick faces with the CAD library's selectors and texture them::

    from build123d import *
    import texcad

    part = Box(60, 40, 10)
    top = part.faces().sort_by(Axis.Z)[-1]
    textured = texcad.texture(part, top, "builtin:diamond_knurl", height=1.0)
    textured.export("part.stl")      # texcad's own mesh (watertight, manifold3d)
    textured.export("part.3mf", separate_texture=True)
    textured.export("part.step")     # the B-rep, made now (tiles of B-spline faces)

The result is a :class:`texcad.Textured`: texcad's fused mesh (STL and 3MF are written
from it) and the textured B-rep, made on first use of ``.shape`` / ``.part`` /
``.workplane`` and checked (:func:`checked_brep`).

Which faces
-----------
* **Planar faces of any outline** (holes included). The texture is laid in the face's
  frame (x along the world x for horizontal faces, y towards world +z otherwise,
  ``rotation`` turns it), centred on the outline's bounding rectangle, and clipped to
  the outline: with ``d`` the distance in mm from a grid vertex to the nearest
  vertex outside the face (or under other parts of the body within the texture
  height), the height becomes

      h' = min(h, tan(edge_angle) * max(0, d - 3 sqrt(px^2 + py^2)))

  which is 0 on every cell the outline crosses and then rises at ``edge_angle``
  (45 degrees: the paper's edge modification M-I, section 2.1.3, applied on every
  border). The texture therefore lies on the selected face only, and the textured
  surface meets the face's own edges at height 0: the B-rep keeps the body's edges
  and swaps the textured part of the face's plane for B-spline tiles
  (:func:`texcad.brep.solids.textured_plane_solid`; with holes or notches inside the
  texture, tiles that keep clear of the outline and one planar face per region
  around them), and the mesh is the body's mesh with the relief above the face
  stitched in (a lean relief on an unobstructed face, no boolean:
  :func:`texcad.solid.boolean.fuse_on_plane`) or united (manifold3d).
* **Faces of extruded profiles** (cylinders, extrusions of lines, arcs and splines:
  the 2.5D surfaces of :mod:`texcad.mapping`). The profile is recovered from the
  face's cross-section, the texture is mapped with :func:`texcad.mapping.map_texture`
  (``mapping="distance"``, algorithm 1, or ``"angle"``, algorithm 2) and the slab is
  unioned with manifold3d for the mesh. B-rep: a closed band (a cylinder) is split
  by the end rows' planes and its middle replaced by wrapped tiles, without a
  boolean (:func:`texcad.brep.solids.textured_extrusion_solid`); an open profile's
  face is replaced by tiles on its own (u, v) sewn to its boundary edges, split at
  the tile corners (:func:`texcad.brep.open_extrusion_solid`).

* **Any other face, several faces at once, chaining** (cones, spheres, tori, surfaces
  of revolution, B-splines, fillets, partial strips, trimmed faces; a list, a
  ``ShapeList`` or a CadQuery selection; a :class:`Textured` as the part): the general
  method of :mod:`texcad.pipeline.faces` (a texture grid on a parameterization of the
  face in mm, fused as a mesh; ``Textured.distortion`` reports the texture scale). Their
  B-rep (:mod:`texcad.brep.targets`): each face parameterized on its own (u, v)
  becomes a degree-1 B-spline on that parameter space in its place; faces flattened
  together, and chained textures, have none: ``.shape`` raises ``GeometryError``
  naming the STL / 3MF outputs.

Checks: the B-rep must be one valid solid (``BRepCheck``) per input solid and must
enclose the mesh's volume within 0.1 % (:data:`VOLUME_TOLERANCE`; they differ only by
the bilinear-vs-triangle term of :mod:`texcad.brep.solids`); OCCT's boolean occasionally
returns a "valid" solid that lost material, and then ``.shape`` raises
``GeometryError`` (the meshes are fine). A lean mesh (``tolerance``) may differ from
the one-pole-per-pixel B-rep by its tolerance times the area (``info["volume_slack"]``).
"""

from __future__ import annotations

import os
from typing import Any, Callable, Sequence

import numpy as np

from ..brep import solids as _brep
from ..brep import targets as _brep_faces
from ..brep import plane_frame
from ..brep import as_array, explore, solids_of, to_topods
from ..errors import GeometryError, ParameterError
from ..sources import Heightmap
from ..solid import DEFAULT_TOLERANCE, Mesh, check_tolerance, heightfield_slab, mesh_error
from ..util import Progress, report, subrange
from ..solid import from_manifold, fuse, to_manifold
from ..solid.boolean import fuse_on_plane
from ..solid.mesh import heightfield_volume
from .surface import lean_mapped_slab

__all__ = ["texture_faces", "LIFT"]

#: mm: the mapped texture's lowest points stay this far outside a curved face (plus
#: the grid's chord sag), so that its B-spline surface never touches the base's own
#: surface tangentially (a case OCCT's boolean handles badly).
LIFT = 0.01
#: Largest relative difference between the B-rep's and the mesh's volume accepted.
VOLUME_TOLERANCE = 1e-3
#: mm: planar faces: the texture is at least this high inside its ramp, so that it
#: never touches the face along isolated lines or points (see _texture_plane).
FLOOR = 1e-3


# ------------------------------------------------------------------------------------------
# Inputs: part, face
# ------------------------------------------------------------------------------------------
def _part_shape(part: Any):
    """The part's ``TopoDS_Shape`` (holding at least one solid)."""
    topo = to_topods(part)
    if not solids_of(topo):
        raise ParameterError(f"the {type(part).__name__} holds no solid to texture; pass a solid part")
    return topo


def _find_face(topo, face: Any):
    """The face of ``topo`` that is ``face`` (same TShape and location), as it lies in
    the part (with its orientation)."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    if callable(getattr(face, "vals", None)) and hasattr(face, "objects"):  # a CadQuery selection
        face = face.vals()
    if isinstance(face, (list, tuple)) or type(face).__name__ == "ShapeList":
        if len(face) != 1:
            raise ParameterError(f"select one face, got {len(face)}; e.g. part.faces().sort_by(Axis.Z)[-1]")
        face = face[0]
    f = to_topods(face)
    if f.ShapeType() != TopAbs_FACE:
        raise ParameterError(f"expected a face, got a {f.ShapeType().name.removeprefix('TopAbs_').lower()}")
    for cand in explore(topo, TopAbs_FACE):  # one per face of the part
        if cand.IsSame(f):
            return TopoDS.Face_s(cand)
    raise ParameterError(
        "the face is not a face of this part; select it from the part itself, "
        "e.g. part.faces().sort_by(Axis.Z)[-1] (build123d) or wp.faces('>Z') (CadQuery)"
    )


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)




# ------------------------------------------------------------------------------------------
# Outline of a face: polyline segments
# ------------------------------------------------------------------------------------------
# ------------------------------------------------------------------------------------------
# Planar faces
# ------------------------------------------------------------------------------------------
def _local(points: np.ndarray, origin: np.ndarray, axes: np.ndarray) -> np.ndarray:
    return (np.asarray(points, np.float64) - origin) @ axes.T


def _place_heightmap(hm: Heightmap, xs_k: np.ndarray, ys_k: np.ndarray) -> np.ndarray:
    """Heights on the grid columns/rows ``k`` (integer pixel indices of ``hm``; 0 mm
    outside the texture)."""
    rows, cols = hm.shape
    h = np.zeros((len(ys_k), len(xs_k)), dtype=np.float32)
    cm = (xs_k >= 0) & (xs_k < cols)
    rm = (ys_k >= 0) & (ys_k < rows)
    if cm.any() and rm.any():
        h[np.ix_(rm, cm)] = hm.heights[np.ix_(ys_k[rm], xs_k[cm])]
    return h


def _obstruction_segments(base_local: Mesh, lo: np.ndarray, hi: np.ndarray, top: float) -> np.ndarray | None:
    """Footprint (2-D segments) of body material above the face plane within
    ``top`` mm, over the rectangle ``lo..hi`` (local frame): texture there would run
    into the body."""
    import manifold3d as m3d

    z0 = 1e-3
    size = (float(hi[0] - lo[0]), float(hi[1] - lo[1]), float(top))
    if top <= z0:
        return None
    box = m3d.Manifold.cube(size).translate((float(lo[0]), float(lo[1]), z0))
    above = to_manifold(base_local) ^ box
    if above.is_empty() or above.volume() < 1e-9:
        return None
    polys = above.project().to_polygons()
    segs = [np.stack([p, np.roll(p, -1, axis=0)], axis=1) for p in polys if len(p) >= 3]  # per polygon
    return np.concatenate(segs) if segs else None


def _texture_plane(
    topo,
    face,
    tex: Any,
    *,
    height: float,
    pitch: float,
    edge_angle: float,
    rotation: float,
    offset: Sequence[float],
    make_brep: bool,
    build_dir: np.ndarray | None,
    critical_angle: float,
    progress: Progress,
    tolerance: float = 0.0,
) -> dict:
    from scipy.ndimage import distance_transform_edt

    from ..sources import load_texture

    p0, ex, ey, n = plane_frame(face, rotation)
    axes = np.stack([ex, ey, n])
    report(progress, 0.02, "reading the face outline")
    spacing0 = 0.5 * (min(tex.pitch) if isinstance(tex, Heightmap) else pitch)
    segs3 = _brep.face_segments(face, spacing0)
    segs = _local(segs3.reshape(-1, 3), p0, axes).reshape(-1, 2, 3)
    off_plane = float(np.abs(segs[..., 2]).max())
    if off_plane > 1e-4:
        raise GeometryError(f"the face's edges leave its plane by {off_plane:.3g} mm; is the face really planar?")
    segs = segs[..., :2]
    lo, hi = segs.reshape(-1, 2).min(axis=0), segs.reshape(-1, 2).max(axis=0)
    centre = (lo + hi) / 2
    origin = p0 + centre[0] * ex + centre[1] * ey
    segs = segs - centre
    lo, hi = lo - centre, hi - centre
    size = hi - lo
    report(progress, 0.05, f"loading texture for the {size[0]:.1f} x {size[1]:.1f} mm face")
    hm = load_texture(tex, size=(float(size[0]), float(size[1])), pitch=pitch, height=height)
    _require_relief(hm, tex)
    px, py = hm.pitch
    rows, cols = hm.shape
    # Pixel (r, c) of the texture sits at x0 + (c + 1/2) px: centred, then offset.
    x0 = -cols * px / 2 + float(offset[0])
    y0 = -rows * py / 2 + float(offset[1])
    kx = np.arange(int(np.floor((lo[0] - x0) / px - 0.5)) - 2, int(np.ceil((hi[0] - x0) / px - 0.5)) + 3)
    ky = np.arange(int(np.floor((lo[1] - y0) / py - 0.5)) - 2, int(np.ceil((hi[1] - y0) / py - 0.5)) + 3)
    from ..util import fitting_pitch, require_memory, texture_bytes

    need = texture_bytes(len(kx) * len(ky), tolerance)
    require_memory(need, f"a {len(ky)} x {len(kx)} px texture on the face", f"use pitch >= {fitting_pitch(min(px, py), need):.3g} mm")
    xs = x0 + (kx + 0.5) * px
    ys = y0 + (ky + 0.5) * py
    h = _place_heightmap(hm, kx, ky)

    report(progress, 0.1, f"clipping the {len(ky)} x {len(kx)} texture to the face outline")
    mask = _brep.inside(segs, xs, ys)
    spacing = 0.5 * min(px, py)
    all_segs = [segs]
    hmax = float(h.max())
    base_mesh = _base_mesh(topo)
    base_local = Mesh(_local(base_mesh.vertices, origin, axes), base_mesh.faces)
    z = base_local.vertices[:, 2]
    snap = max(1e-5, 4 * float(np.finfo(np.float32).eps) * float(np.abs(base_mesh.vertices).max()))
    z[np.abs(z) < snap] = 0.0  # the face's own vertices: exactly on the plane z = 0
    obst = _obstruction_segments(base_local, np.array([xs[0], ys[0]]), np.array([xs[-1], ys[-1]]), hmax + 1e-3)
    if obst is not None:
        mask &= ~_brep.inside(obst, xs, ys)
        all_segs.append(obst)
    pts = _brep.sample_segments(np.concatenate(all_segs), spacing)
    ci = np.clip(np.rint((pts[:, 0] - xs[0]) / px).astype(np.int64), 0, len(xs) - 1)
    ri = np.clip(np.rint((pts[:, 1] - ys[0]) / py).astype(np.int64), 0, len(ys) - 1)
    mask[ri, ci] = False
    dist = distance_transform_edt(mask, sampling=(py, px))
    # Zero band: every vertex of a cell the outline crosses lies within 1.75 diagonals
    # of a marked boundary pixel (cell diagonal + half a sample step + half a diagonal).
    margin = 3.0 * float(np.hypot(px, py))
    if edge_angle >= 90.0:
        ramp = np.where(dist > margin, np.inf, 0.0)
    else:
        ramp = np.tan(np.radians(edge_angle)) * np.maximum(dist - margin, 0.0)
    h = np.where(mask, np.minimum(h, ramp), 0.0)
    # A FLOOR (1 um) under the texture inside the ramp: where the texture reaches 0 mm
    # inside the face (the valleys of a knurl) the relief would touch the face along
    # lines and points, which the union keeps as pinched (duplicated) vertices; an STL
    # reader that welds by position then sees non-manifold edges. max() keeps the M-I
    # ramp and the difference bounds of the overhang limiter below.
    h = np.where(mask, np.maximum(h, np.minimum(FLOOR, ramp)), 0.0).astype(np.float32)
    limits = None
    if build_dir is not None:
        from ..printability import limit_overhangs

        # The world build direction(s) in the face frame (ex, ey, n); the limiter only
        # lowers heights, so the outline band stays at 0 mm.
        report(progress, 0.2, f"limiting overhangs to {critical_angle:g} deg")
        lowered, limits = limit_overhangs(Heightmap(h, (px, py)), build_dir @ axes.T, critical_angle)
        h = lowered.heights
    if not (h > 0).any():
        raise GeometryError(
            f"no texture is left on the face: it is too small or narrow for a {margin:.2f} mm border band "
            "at this pitch (or the overhang limiter removed it all); use a smaller pitch or a larger face"
        )
    _check_flat_outline(h, xs, ys, _brep.sample_segments(segs, spacing))

    report(progress, 0.3, "meshing the relief")
    # The relief above the face: the heightfield trimmed at the face plane z = 0. Vertices
    # near and outside the outline go to -1 mm so that the trim also removes the flat
    # (zero-thickness) part there: what is left lies inside the outline, on the face.
    h_mesh = np.where(dist > 1.75 * float(np.hypot(px, py)), h, np.float32(-1.0))
    slab_origin = (xs[0] - px / 2, ys[0] - py / 2, 0.0)
    stitch = obst is None and tolerance > 0  # (even where the lean mesh falls back to the grid)
    if build_dir is not None and tolerance > 0:
        from ..printability import printable_lean_slab

        # lean facets keep the limiter's angle too (else a finer tolerance, down to 0)
        slab, tolerance = printable_lean_slab(
            Heightmap(h_mesh, (px, py)), build_dir @ axes.T, critical_angle, tolerance=tolerance, depth=1.0, origin=slab_origin
        )
    else:
        slab = heightfield_slab(Heightmap(h_mesh, (px, py)), depth=1.0, origin=slab_origin, tolerance=tolerance)
    report(progress, 0.4, f"fusing {slab.num_triangles} texture triangles onto the part")
    fused_local, relief, how = _fuse_relief(base_local, slab, stitch, Heightmap(h_mesh, (px, py)), tolerance)

    def world(m: Mesh) -> Mesh:
        v = np.einsum("ij,jk->ik", m.vertices.astype(np.float64), axes) + origin  # 6 x faster than @ here
        out = Mesh(v.astype(np.float32), m.faces)
        out.__dict__["is_watertight"] = m.__dict__.get("is_watertight", None) or m.is_watertight
        return out

    def texture_only() -> Mesh:
        # (base + relief) - base: the bumps alone (manifold3d resolves the shared face
        # plane consistently this way round); the stitched relief is that already.
        return world(relief or from_manifold(to_manifold(fused_local) - to_manifold(base_local)))

    def max_error() -> float:
        return mesh_error(h_mesh, (px, py), slab_origin, slab.vertices, slab.faces[slab.groups["texture"]])

    result = {
        "max_error": max_error,
        "mesh": world(fused_local),
        "texture_mesh": texture_only,
        "base_mesh": base_mesh,
        "heightmap": Heightmap(h, (px, py)),
        "limits": limits,
        "info": {
            "face": "plane",
            "origin": origin.tolist(),
            "xdir": ex.tolist(),
            "ydir": ey.tolist(),
            "normal": n.tolist(),
            "grid": (len(ys), len(xs)),
            "x": xs,
            "y": ys,
            "obstructed": obst is not None,
            "fuse": how,
            "tolerance": float(tolerance),
            # the lean surface may enclose up to tolerance x area more or less than the B-rep
            "volume_slack": float(tolerance) * px * py * h_mesh.size,
        },
    }
    def make_shape(fine=None):
        return _brep.textured_plane_solid(topo, face, h, xs, ys, origin=origin, xdir=ex, normal=n, fine=fine)

    result["shape"] = make_shape if make_brep else None
    return result


def _fuse_relief(
    base_local: Mesh, slab: Mesh, stitch: bool, field: Heightmap, tolerance: float
) -> tuple[Mesh, "Mesh | None", str]:
    """The relief (``slab`` above the face plane z = 0) fused onto the body, in the
    face's frame: ``(fused, relief or None, how)``. With ``stitch`` (an unobstructed
    face) it is stitched into the body's mesh (:func:`texcad.solid.boolean.fuse_on_plane`,
    checked; its volume against the heightfield ``field``'s within ``tolerance`` mm x
    area); otherwise, or if a check of the stitch fails (``how`` says which),
    manifold3d's union."""
    how = "manifold3d"
    if stitch:
        vol, slack = heightfield_volume(field.heights, field.pitch)
        expect = (vol, slack + float(tolerance) * field.pitch[0] * field.pitch[1] * field.heights.size)
        try:
            fused, relief = fuse_on_plane(base_local, slab.vertices, slab.faces[slab.groups["texture"]], expect=expect)
            return fused, relief, "stitched"
        except GeometryError as exc:
            how = f"manifold3d (the stitch failed a check: {exc})"
    return fuse(base_local, to_manifold(slab).trim_by_plane((0.0, 0.0, 1.0), 0.0)), None, how


def _require_relief(hm: Heightmap, tex: Any) -> None:
    if not float(hm.heights.max()) > 0:
        raise ParameterError(
            f"the texture {tex if isinstance(tex, str) else 'heightmap'!s} is flat (0 mm everywhere) at a pitch of "
            f"{min(hm.pitch):.3g} mm: its features are finer than the pitch; use a smaller pitch"
        )


def _check_flat_outline(h: np.ndarray, xs: np.ndarray, ys: np.ndarray, pts: np.ndarray) -> None:
    """The bilinear surface must be exactly 0 mm along the outline (so the face's
    edges lie on it): check at the outline samples."""
    px, py = xs[1] - xs[0], ys[1] - ys[0]
    fx = np.clip((pts[:, 0] - xs[0]) / px, 0, len(xs) - 1.000001)
    fy = np.clip((pts[:, 1] - ys[0]) / py, 0, len(ys) - 1.000001)
    c, r = fx.astype(np.int64), fy.astype(np.int64)
    cells = np.maximum.reduce([h[r, c], h[r + 1, c], h[r, c + 1], h[r + 1, c + 1]])
    if cells.max() > 0:
        raise GeometryError("internal: the texture does not vanish along the face outline; please report this")


# ------------------------------------------------------------------------------------------
# Faces of extruded profiles (texcad.mapping / texcad.mapping)
# ------------------------------------------------------------------------------------------
def _extrusion_frame(face):
    """``(origin, ex, ey, ez, y_length)``: ``ey`` is the extrusion direction, the
    profile lies in the plane through ``origin`` spanned by ``ex`` and ``ez``
    (``ex x ey = ez``), and the face spans ``0 <= y <= y_length`` mm."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Cylinder, GeomAbs_Plane, GeomAbs_SurfaceOfExtrusion

    ad = BRepAdaptor_Surface(face)
    kind = ad.GetType()
    if kind == GeomAbs_Cylinder:
        ax = ad.Cylinder().Position()
        o, ey, ex = as_array(ax.Location()), as_array(ax.Direction()), as_array(ax.XDirection())
    elif kind == GeomAbs_SurfaceOfExtrusion:
        ey = _unit(as_array(ad.Direction()))
        ref = np.array([0.0, 0.0, 1.0]) if abs(ey[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        ex = _unit(np.cross(ey, ref))
        o = np.zeros(3)
    elif kind == GeomAbs_Plane:
        raise ParameterError("internal: planar faces take the planar path")
    else:
        raise GeometryError(
            f"texcad textures planar faces and faces of extruded profiles (cylinders, extrusions); "
            f"this face is a {kind.name.removeprefix('GeomAbs_')}"
        )
    ez = np.cross(ex, ey)
    return o, ex, ey, ez


def _texture_extrusion(
    topo,
    face,
    tex: Any,
    *,
    height: float,
    pitch: float,
    mapping: str,
    depth: float,
    periodic_x: bool | None,
    transition: float | None,
    make_brep: bool,
    build_dir: np.ndarray | None,
    critical_angle: float,
    progress: Progress,
    tolerance: float = 0.0,
) -> dict:
    from build123d import Compound, Edge
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pnt, gp_Trsf
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    from ..mapping import Profile, fit_texture, map_texture
    from ..util import fitting_pitch, require_memory, texture_bytes

    o, ex, ey, ez = _extrusion_frame(face)
    axes = np.stack([ex, ey, ez])
    report(progress, 0.02, "recovering the face's profile")
    edges = [TopoDS.Edge_s(e) for e in explore(face, TopAbs_EDGE)]
    pts = [_local(_brep.edge_points(e, 0.5), o, axes) for e in edges]  # per boundary edge
    ally = np.concatenate([p[:, 1] for p in pts])
    y_lo, y_hi = float(ally.min()), float(ally.max())
    length = y_hi - y_lo
    tol = 1e-6 * max(1.0, float(np.abs(np.concatenate(pts)).max()))
    section = [e for e, p in zip(edges, pts) if np.all(np.abs(p[:, 1] - y_lo) < tol)]
    if not section or length <= tol:
        raise GeometryError("cannot find the face's cross-section: is it a face of an extrusion (a full strip)?")
    o = o + y_lo * ey
    trsf = gp_Trsf()
    trsf.SetTransformation(gp_Ax3(gp_Pnt(*o), gp_Dir(*ez), gp_Dir(*ex)))  # world -> local
    # Local axes (ex, ey, ez) = (X, Y, Z): gp_Ax3(o, Z = ez, X = ex) has Y = ez x ex = ey.
    local_edges = [Edge(TopoDS.Edge_s(BRepBuilderAPI_Transform(e, trsf, True).Shape())) for e in section]
    profile = Profile.from_cad(Compound(local_edges))
    # Make the profile's normal the face's outward normal.
    s_mid = profile.length * 0.37
    pm = profile.point(np.array([s_mid]))[0]
    nm = profile.normal(np.array([s_mid]))[0]
    world_pt = o + pm[0] * ex + 0.5 * length * ey + pm[1] * ez
    fn = _face_normal(face, world_pt)
    if float(fn @ (nm[0] * ex + nm[1] * ez)) < 0:
        profile = Profile.from_cad(Compound(local_edges), side="inside") if profile.closed else profile.reversed()
    area = _area(face)
    if abs(area - profile.length * length) > 0.01 * area:
        raise GeometryError(
            f"the face ({area:.1f} mm2) is not a full strip of its extrusion ({profile.length:.1f} x {length:.1f} mm); "
            "texcad textures whole faces of extruded profiles"
        )
    report(progress, 0.05, f"mapping the texture onto the {profile.length:.1f} x {length:.1f} mm face ({mapping})")
    hm, periodic = fit_texture(profile, tex, length=length, pitch=pitch, height=height, periodic_x=periodic_x)
    _require_relief(hm, tex)
    need = texture_bytes(hm.shape[0] * hm.shape[1], 0.0)
    require_memory(need, f"a {hm.shape[0]} x {hm.shape[1]} px texture on the face", f"use pitch >= {fitting_pitch(min(hm.pitch), need):.3g} mm")
    limits = None
    d_local = None
    if build_dir is not None:
        from ..printability import limit_on_profile

        # The world build direction(s) in the profile's frame (ex, ey, ez).
        d_local = build_dir @ axes.T
        report(progress, 0.05, f"limiting overhangs to {critical_angle:g} deg")
        hm, limits = limit_on_profile(profile, hm, d_local, critical_angle, mapping=mapping, periodic=periodic)
    mapped = map_texture(
        profile,
        hm,
        mapping=mapping,
        length=length,
        depth=depth,
        periodic_x=periodic,
        transition=transition,
        progress=subrange(progress, 0.05, 0.3),
    )
    top = _lift(mapped.top.astype(np.float64), profile, mapped.s, closed=mapped.closed)
    # The mesh keeps the borders the overhang limiter sank into the body below the
    # surface (no sliver of wall above it); the B-rep lifts them like the rest (OCCT's
    # union of a grid face crossing a curved face is unreliable).
    top_mesh = _lift(mapped.top.astype(np.float64), profile, mapped.s, closed=mapped.closed, keep_sunk=True) if limits is not None else top
    # The bottom: (2, C, 3) first and last row of a ruled surface (extrusion of the
    # offset profile), or a full (R, C, 3) grid.
    bottom = np.asarray(mapped.bottom, dtype=np.float64)
    # Every row lies in its plane y = const exactly (float32 rounding would tilt the end
    # walls by 1e-7 mm: OCCT then intersects them as wiggly strips, not planes).
    y_rows = np.asarray(mapped.y, np.float64)
    top[..., 1] = y_rows[:, None]
    top_mesh[..., 1] = y_rows[:, None]
    if bottom.shape[0] == top.shape[0]:
        bottom[..., 1] = y_rows[:, None]
    else:
        bottom[0, :, 1], bottom[-1, :, 1] = y_rows[0], y_rows[-1]

    def world(g: np.ndarray) -> np.ndarray:
        return o + g[..., 0:1] * ex + g[..., 1:2] * ey + g[..., 2:3] * ez

    top_w = world(top)
    report(progress, 0.35, "meshing and fusing (manifold3d)")
    slab_local, max_error = lean_mapped_slab(top_mesh, bottom, profile, mapped.s, closed=mapped.closed, tolerance=tolerance, build_dir=d_local, critical_angle=critical_angle)  # lean (issue 15)
    if limits is not None:
        from ..printability import measured

        limits = measured(limits, slab_local, d_local, critical_angle)
    slab = Mesh(world(slab_local.vertices.astype(np.float64)).astype(np.float32), slab_local.faces)
    base_mesh = _base_mesh(topo)
    fused = fuse(base_mesh, slab)

    def texture_only() -> Mesh:
        return from_manifold(to_manifold(fused) - to_manifold(base_mesh))

    result = {
        "mesh": fused,
        "texture_mesh": texture_only,
        "base_mesh": base_mesh,
        "heightmap": mapped.heightmap,
        "limits": limits, "max_error": max_error,
        "info": {
            "face": "extrusion",
            "origin": o.tolist(),
            "xdir": ex.tolist(),
            "ydir": ey.tolist(),
            "zdir": ez.tolist(),
            "grid": tuple(mapped.top.shape[:2]),
            "closed": mapped.closed,
            "mapping": mapping,
            "profile_length": profile.length,
            "length": length, "tolerance": float(tolerance), "volume_slack": float(tolerance) * profile.length * length,
            "limits": [str(x) for x in mapped.limits],
        },
    }
    def make_shape(fine=None):  # base: the face under the first row's columns (local x, y0, z)
        base = world(np.insert(profile.point(np.asarray(mapped.s, np.float64)), 1, y_rows[0], axis=1))
        return _brep_faces.extrusion_brep(topo, face, top_w, world(bottom), closed=mapped.closed, base=base, fine=fine)

    result["shape"] = make_shape if make_brep else None
    return result


def _lift(top: np.ndarray, profile, s: np.ndarray, *, closed: bool, keep_sunk: bool = False) -> np.ndarray:
    """Keep every top vertex at least ``LIFT`` mm plus the grid's chord sag outside
    the profile (along its normal): ``d_n >= LIFT + max(kappa, 0) ds^2 / 8``.

    A degree-1 surface between vertices that lie *on* a convex profile cuts into it
    by the sag ``kappa ds^2 / 8`` (and touches a concave one along lines); either way
    OCCT's boolean would have to resolve thousands of tangential contacts. The lift
    (10 um, a tenth of a layer) moves the texture's zero level just off the surface,
    for the mesh and the B-rep alike. With ``keep_sunk``, vertices placed below the
    surface on purpose (borders the overhang limiter sank into the body, see
    :data:`texcad.printability.profile.SINK`) stay there.
    """
    p = profile.point(s)  # (C, 2): x, z
    nrm = profile.normal(s)
    kappa = profile.curvature(s)
    ds = np.diff(s)
    if closed:
        gap = profile.length - (s[-1] - s[0])
        left = np.concatenate([[gap], ds])
        right = np.concatenate([ds, [gap]])
    else:
        left = np.concatenate([ds[:1], ds])
        right = np.concatenate([ds, ds[-1:]])
    need = LIFT + np.maximum(kappa, 0.0) * np.maximum(left, right) ** 2 / 8.0
    dn = (top[..., 0] - p[None, :, 0]) * nrm[None, :, 0] + (top[..., 2] - p[None, :, 1]) * nrm[None, :, 1]
    add = np.maximum(need[None, :] - dn, 0.0)
    if keep_sunk:
        add[dn < -0.5 * LIFT] = 0.0
    out = top.copy()
    out[..., 0] += add * nrm[None, :, 0]
    out[..., 2] += add * nrm[None, :, 1]
    return out


def _face_normal(face, point: np.ndarray) -> np.ndarray:
    """Outward unit normal of a face at (the projection of) a point."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepGProp import BRepGProp_Face
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.gp import gp_Pnt, gp_Vec

    surf = BRep_Tool.Surface_s(face)
    proj = GeomAPI_ProjectPointOnSurf(gp_Pnt(*map(float, point)), surf)
    u, v = proj.LowerDistanceParameters()
    p, nv = gp_Pnt(), gp_Vec()
    BRepGProp_Face(face).Normal(u, v, p, nv)
    return _unit(np.array(nv.Coord()))


def _area(face) -> float:
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    g = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, g)
    return float(g.Mass())


# ------------------------------------------------------------------------------------------
# Faces of a CAD part
# ------------------------------------------------------------------------------------------
def _check_options(mapping: str, height: float, pitch: float, depth: float, edge_angle: float, offset) -> None:
    from ..mapping import MAPPINGS

    if mapping not in MAPPINGS:
        raise ParameterError(f"unknown mapping {mapping!r}; use 'angle' (algorithm 2) or 'distance' (algorithm 1)")
    for label, v in (("height", height), ("pitch", pitch), ("depth", depth)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
            raise ParameterError(f"{label} must be a positive number of mm, got {v!r}")
    if not (0 < float(edge_angle) <= 90):
        raise ParameterError(f"edge_angle must be in (0, 90] degrees, got {edge_angle!r}")
    if np.shape(offset) != (2,):
        raise ParameterError(f"offset must be (dx, dy) in mm, got {offset!r}")


def _base_mesh(topo) -> Mesh:
    """The part's tessellation, welded and checked closed (healed if needed:
    :func:`texcad.brep.part_tessellation`)."""
    from ..brep import part_tessellation

    return part_tessellation(topo).mesh


def _face_index(topo, face) -> int:
    from OCP.TopAbs import TopAbs_FACE

    return next(k for k, c in enumerate(explore(topo, TopAbs_FACE)) if c.IsSame(face))


def _chain_base(part: Any):
    """``(topo, previous)``: the part's shape, and the earlier :class:`Textured` when
    ``part`` is one (chaining: its mesh is the base, its base B-rep gives the faces).

    Raises:
        ParameterError: a textured result that cannot be chained (no base part, or
            moved since).
    """
    from .result import Textured

    prev = part if isinstance(part, Textured) else getattr(part, "texcad", None)
    if not isinstance(prev, Textured):
        return _part_shape(part), None
    if prev.stages is None or prev.stages.placement.topo is None or not prev.is_unmoved:
        raise ParameterError(
            "this textured result cannot be textured again (it was moved, or did not come from a CAD part); "
            "texture all faces in one call: texcad.texture(part, [face1, face2, ...], texture)"
        )
    return prev.stages.placement.topo, prev


def _texture_general(part, topo, prev, faces, texture, *, progress, **opts):
    """Any face kind, several faces, chaining: the any-faces adapter
    (:class:`texcad.targets.FacesAdapter`) through the one driver."""
    from ..options import Options
    from ..targets.faces import taking_every_face
    from .driver import run

    o = Options.make(**{k: v for k, v in opts.items() if v is not None}, progress=progress)
    with taking_every_face():
        return run(part, faces, texture, o)


def checked_brep(make_shape: Callable[[], Any], topo, mesh: Mesh, info: dict | None = None, progress: Progress = None):
    """Build a B-rep with ``make_shape()`` and check it against the mesh: one valid
    solid (``BRepCheck_Analyzer``) per solid of ``topo``, enclosing the mesh's volume
    within :data:`VOLUME_TOLERANCE` (OCCT's booleans can return a "valid" solid that
    lost part of the body; a lean mesh may differ by ``info["volume_slack"]`` mm3, its
    tolerance times the area); the B-rep's volume goes to ``info["brep_volume"]``.

    Raises:
        GeometryError: the B-rep is invalid or encloses another volume.
    """
    report(progress, 0.0, "building the B-rep (OCCT)")
    shape = make_shape()
    chk = _brep.check_shape(shape)
    if not chk["valid"] or chk["solids"] != len(solids_of(topo)):
        raise GeometryError(
            f"the textured B-rep is not valid ({chk}); the meshes are fine: write STL or 3MF, and please report this"
        )
    vb, vm = _brep.volume(shape), float(mesh.volume)
    if abs(vb - vm) > VOLUME_TOLERANCE * abs(vm) + (info or {}).get("volume_slack", 0.0):
        raise GeometryError(
            f"the textured B-rep encloses {vb:.1f} mm3 but the mesh {vm:.1f} mm3 (OCCT's union went wrong); "
            "the meshes are fine: write STL or 3MF"
        )
    if info is not None:
        info["brep_volume"] = vb
        # For CAD operations on the result (texcad.pipeline.ops): the untextured part,
        # and the builder (planar faces take fine=[(x0, x1, y0, y1)]: finer tiles there).
        info["_base_shape"] = topo
        info["_make_shape"] = make_shape
    report(progress, 1.0, "B-rep checked")
    return shape


def texture_faces(
    part: Any,
    face: Any,
    texture: "str | os.PathLike | Heightmap",
    *,
    height: float = 2.0,
    pitch: float = 0.125,
    mapping: str = "angle",
    depth: float = 0.5,
    edge_angle: float = 45.0,
    rotation: float = 0.0,
    offset: Sequence[float] = (0.0, 0.0),
    periodic_x: bool | None = None,
    transition: float | None = None,
    brep: bool = True,
    build_dir: Any = None,
    critical_angle: float = 45.0,
    tolerance: float = DEFAULT_TOLERANCE,
    mode: str = "raised",
    gradient: Any = None,
    progress: Progress = None,
):
    """Texture a face of a build123d or CadQuery part: see :func:`texcad.texture`
    for the arguments (mm and degrees). Returns a :class:`texcad.Textured` whose
    B-rep is made on first use of ``.shape`` (STEP, CAD work)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Cylinder, GeomAbs_Plane, GeomAbs_SurfaceOfExtrusion

    from ..targets.cad import face_list

    _check_options(mapping, height, pitch, depth, edge_angle, offset)
    tolerance = check_tolerance(tolerance)
    dirs = None
    if build_dir is not None:
        from ..printability import build_directions, check_critical_angle

        dirs = build_directions(build_dir)
        critical_angle = check_critical_angle(critical_angle)
    if not isinstance(texture, Heightmap):
        texture = os.fspath(texture)
    topo, prev = _chain_base(part)
    faces = face_list(face)
    common = dict(height=height, pitch=pitch, make_brep=brep, build_dir=dirs, critical_angle=critical_angle, progress=progress)
    res = None
    if len(faces) == 1 and prev is None and mode == "raised" and gradient is None:
        f = _find_face(topo, faces[0])
        kind = BRepAdaptor_Surface(f).GetType()
        if kind == GeomAbs_Plane:
            res = _texture_plane(topo, f, texture, edge_angle=float(edge_angle), rotation=rotation, offset=offset, tolerance=tolerance, **common)
        elif kind in (GeomAbs_Cylinder, GeomAbs_SurfaceOfExtrusion):
            try:
                res = _texture_extrusion(topo, f, texture, mapping=mapping, depth=depth, periodic_x=periodic_x, transition=transition, tolerance=tolerance, **common)
            except GeometryError as e:  # not a full strip of its extrusion: the general method
                if "strip" not in str(e) and "cross-section" not in str(e):
                    raise
    if res is None:
        return _texture_general(part, topo, prev, faces, texture, height=height, pitch=pitch, depth=depth,
                                edge_angle=float(edge_angle), rotation=float(rotation), build_dir=dirs,
                                critical_angle=critical_angle, progress=progress, tolerance=tolerance,
                                mode=mode, gradient=gradient)
    report(progress, 1.0, "textured")
    return _result(res, topo, brep, dirs, critical_angle, _face_index(topo, f))


def _result(res: dict, topo, brep: bool, dirs, critical_angle: float, face_index: int):
    """The :class:`Textured` of one planar or extruded face, with its B-rep made on
    first use and checked (:func:`checked_brep`)."""
    from .result import Textured

    info = res["info"]
    info["brep"] = bool(brep)
    if dirs is not None:
        info["build_dir"] = dirs.tolist()
        info["critical_angle"] = float(critical_angle)
    shape = res["shape"]
    if shape is None:
        info["no_brep"] = "textured with brep=False; texture it again with brep=True for STEP"
    from ..targets.legacy import legacy_stages

    return Textured(legacy_stages(
        mesh=res["mesh"], texture_mesh=res["texture_mesh"], base_mesh=res["base_mesh"], shape=shape,
        heightmap=res["heightmap"], limits=res["limits"], height_limits=res.get("height_limits"),
        max_error=res.get("max_error", 0.0), info=info, kind=info["face"], result_kind="face", topo=topo,
        face_ids=(face_index,), bodies=len(solids_of(topo)), brep=brep,
    ))
