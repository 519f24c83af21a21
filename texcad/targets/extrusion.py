"""Adapter: one face of a CAD part that is a full strip of an extrusion (a cylinder,
an extruded line, arc or spline profile: the 2.5D surfaces of :mod:`texcad.mapping`).

**Place.** The face's frame: ``ey`` the extrusion direction, the profile in the plane
spanned by ``ex`` and ``ez = ex x ey`` through ``origin`` at the face's lowest ``y``;
the profile recovered from the face's cross-section (its edges at ``y = 0``) as a
:class:`~texcad.mapping.Profile` with its normal the face's outward normal, and the
strip's length ``L`` (mm). A face whose area differs from ``profile.length * L`` by
more than 1 % is not a full strip: :class:`~texcad.targets.base.Decline` (the faces
adapter takes it).

**Relief.** The texture fitted to the developed face (:func:`texcad.mapping.fit_texture`),
lowered for ``build_dir`` (:func:`texcad.printability.limit_on_profile`), mapped
(:func:`texcad.mapping.map_texture`: ``mapping="distance"``, algorithm 1, or
``"angle"``, algorithm 2) and lifted off the profile by

    d_n >= LIFT + max(kappa, 0) ds^2 / 8

(:data:`LIFT` mm plus the chord sag of the grid; ``kappa`` the curvature, 1/mm), then
meshed lean within ``tolerance`` (:func:`texcad.targets.surface.lean_mapped_slab`).

**Fuse.** manifold3d's union of the slab (in world mm) with the part's tessellation.
**B-rep**: a closed band is split by the end rows' planes and its middle replaced by
wrapped tiles; an open profile's face is replaced by tiles on its own (u, v)
(:func:`texcad.brep.targets.extrusion_brep`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..contracts import Fused, Placement, Relief, Stages
from ..errors import GeometryError, ParameterError
from ..mapping import Profile
from ..options import Mode, Options
from ..solid import Mesh
from .base import Adapter, Decline
from .cad import body_count, cad_part, face_list, is_cad_target, selected_surface, tessellation
from .surface import lean_mapped_slab

__all__ = ["ExtrusionAdapter", "LIFT", "lift", "extrusion_frame", "extrusion_volume"]

#: mm: the mapped texture's lowest points stay this far outside a curved face (plus
#: the grid's chord sag), so that its B-spline surface never touches the base's own
#: surface tangentially (a case OCCT's boolean handles badly).
LIFT = 0.01


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def extrusion_frame(face: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(origin, ex, ey, ez)`` of a cylinder or extrusion face (mm, unit vectors):
    ``ey`` is the extrusion direction and the profile lies in the plane through
    ``origin`` spanned by ``ex`` and ``ez`` (``ex x ey = ez``)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Cylinder, GeomAbs_SurfaceOfExtrusion

    from ..brep import as_array

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
    else:
        raise Decline(f"a {kind.name.removeprefix('GeomAbs_')} face is not an extrusion")
    return o, ex, ey, np.cross(ex, ey)


def _face_normal(face: Any, point: np.ndarray) -> np.ndarray:
    """Outward unit normal of a face at (the projection of) a point (mm)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepGProp import BRepGProp_Face
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.gp import gp_Pnt, gp_Vec

    proj = GeomAPI_ProjectPointOnSurf(gp_Pnt(*map(float, point)), BRep_Tool.Surface_s(face))
    u, v = proj.LowerDistanceParameters()
    p, nv = gp_Pnt(), gp_Vec()
    BRepGProp_Face(face).Normal(u, v, p, nv)
    return _unit(np.array(nv.Coord()))


def _area(face: Any) -> float:
    """The face's area, mm^2."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    g = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, g)
    return float(g.Mass())


def _section_edges(face: Any, o: np.ndarray, axes: np.ndarray) -> tuple[list, float, float]:
    """The face's edges that lie in its lowest section plane ``y = y_lo`` (local
    frame), and ``(y_lo, length)`` mm."""
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    from ..brep import edge_points, explore

    edges = [TopoDS.Edge_s(e) for e in explore(face, TopAbs_EDGE)]
    pts = [(np.asarray(edge_points(e, 0.5), np.float64) - o) @ axes.T for e in edges]  # per boundary edge
    ally = np.concatenate([p[:, 1] for p in pts])
    y_lo, y_hi = float(ally.min()), float(ally.max())
    tol = 1e-6 * max(1.0, float(np.abs(np.concatenate(pts)).max()))
    section = [e for e, p in zip(edges, pts) if np.all(np.abs(p[:, 1] - y_lo) < tol)]
    if not section or y_hi - y_lo <= tol:
        raise Decline("cannot find the face's cross-section: is it a face of an extrusion (a full strip)?")
    return section, y_lo, y_hi - y_lo


def _profile(face: Any, section: list, o: np.ndarray, axes: np.ndarray, length: float) -> Profile:
    """The cross-section as a Profile in the local (x, z) plane, its normal the face's
    outward normal."""
    from build123d import Compound, Edge
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Ax3, gp_Dir, gp_Pnt, gp_Trsf
    from OCP.TopoDS import TopoDS

    ex, ey, ez = axes
    trsf = gp_Trsf()
    trsf.SetTransformation(gp_Ax3(gp_Pnt(*o), gp_Dir(*ez), gp_Dir(*ex)))  # world -> local
    # Local axes (ex, ey, ez) = (X, Y, Z): gp_Ax3(o, Z = ez, X = ex) has Y = ez x ex = ey.
    local_edges = [Edge(TopoDS.Edge_s(BRepBuilderAPI_Transform(e, trsf, True).Shape())) for e in section]
    profile = Profile.from_cad(Compound(local_edges))
    s_mid = profile.length * 0.37
    pm = profile.point(np.array([s_mid]))[0]
    nm = profile.normal(np.array([s_mid]))[0]
    fn = _face_normal(face, o + pm[0] * ex + 0.5 * length * ey + pm[1] * ez)
    if float(fn @ (nm[0] * ex + nm[1] * ez)) < 0:
        profile = Profile.from_cad(Compound(local_edges), side="inside") if profile.closed else profile.reversed()
    return profile


def normal_offset(top: np.ndarray, profile: Profile, s: np.ndarray) -> np.ndarray:
    """``d_n`` (R, C) mm: how far each grid point ``top`` (R, C, 3) (local x, y, z)
    lies outside the profile along its normal at the column's arc length ``s`` (C,)."""
    p = profile.point(s)  # (C, 2): x, z
    nrm = profile.normal(s)
    return (top[..., 0] - p[None, :, 0]) * nrm[None, :, 0] + (top[..., 2] - p[None, :, 1]) * nrm[None, :, 1]


def lift(top: np.ndarray, profile: Profile, s: np.ndarray, *, closed: bool, keep_sunk: bool = False) -> np.ndarray:
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
    nrm = profile.normal(s)
    kappa = profile.curvature(s)
    ds = np.diff(s)
    if closed:
        gap = profile.length - (s[-1] - s[0])
        left, right = np.concatenate([[gap], ds]), np.concatenate([ds, [gap]])
    else:
        left, right = np.concatenate([ds[:1], ds]), np.concatenate([ds, ds[-1:]])
    need = LIFT + np.maximum(kappa, 0.0) * np.maximum(left, right) ** 2 / 8.0
    dn = normal_offset(top, profile, s)
    add = np.maximum(need[None, :] - dn, 0.0)
    if keep_sunk:
        add[dn < -0.5 * LIFT] = 0.0
    out = top.copy()
    out[..., 0] += add * nrm[None, :, 0]
    out[..., 2] += add * nrm[None, :, 1]
    return out


def require_relief(hm: Any, tex: Any) -> None:
    """ParameterError when the fitted texture ``hm`` is flat (0 mm everywhere)."""
    if not float(hm.heights.max()) > 0:
        raise ParameterError(
            f"the texture {tex if isinstance(tex, str) else 'heightmap'!s} is flat (0 mm everywhere) at a pitch of "
            f"{min(hm.pitch):.3g} mm: its features are finer than the pitch; use a smaller pitch"
        )


@dataclass(frozen=True)
class ExtrusionFrame:
    """An extruded face placed: the face, the local frame (``origin`` (3,) mm at the
    strip's start, ``axes`` (3, 3) rows ``ex, ey, ez``), the strip's ``length`` along
    ``ey`` (mm) and the cross-section ``profile`` in the local (x, z) plane."""

    face: Any
    origin: np.ndarray
    axes: np.ndarray
    length: float
    profile: Profile

    def world(self, g: np.ndarray) -> np.ndarray:
        """Local points ``(..., 3)`` mm in world mm: ``o + x ex + y ey + z ez``."""
        ex, ey, ez = self.axes
        return self.origin + g[..., 0:1] * ex + g[..., 1:2] * ey + g[..., 2:3] * ez


@dataclass(frozen=True)
class ExtrusionRelief:
    """The relief on an extruded face: the lifted top grid ``top`` (R, C, 3) and the
    bottom (2, C, 3) or (R, C, 3), both world mm (the B-rep's grids), the columns' arc
    lengths ``s`` (C,) mm, the first row's ``y0`` (local mm), whether the profile is
    closed, and the slab (world mm) the mesh is fused from."""

    top: np.ndarray
    bottom: np.ndarray
    s: np.ndarray
    y0: float
    closed: bool
    slab: Mesh


def _surface_kind(where: Any) -> Any:
    """The OCCT surface type of the one selected face, or None."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    from ..brep import to_topods

    try:
        faces = face_list(where)
        f = to_topods(faces[0]) if len(faces) == 1 else None
    except (ParameterError, TypeError, AttributeError):
        return None
    if f is None or f.ShapeType() != TopAbs_FACE:
        return None
    return BRepAdaptor_Surface(TopoDS.Face_s(f)).GetType()


def _directions(options: Options) -> np.ndarray:
    """``build_dir`` as ``(K, 3)`` unit vectors, normalised once more as the stage
    functions do (:func:`texcad.printability.build_directions`; same bits as before)."""
    from ..printability import build_directions

    d = options.directions
    return build_directions(d[0] if len(d) == 1 else d)


def _grids(mapped: Any, profile: Profile, limited: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(top, top_mesh, bottom)`` local mm: the mapped grids lifted (:func:`lift`), with
    every row exactly in its plane ``y = const`` (float32 rounding would tilt the end
    walls by 1e-7 mm: OCCT then intersects them as wiggly strips, not planes). The
    mesh keeps the borders the overhang limiter sank into the body (``limited``); the
    B-rep lifts them like the rest (OCCT's union of a grid face crossing a curved face
    is unreliable)."""
    top0 = mapped.top.astype(np.float64)
    top = lift(top0, profile, mapped.s, closed=mapped.closed)
    top_mesh = lift(top0, profile, mapped.s, closed=mapped.closed, keep_sunk=True) if limited else top
    bottom = np.asarray(mapped.bottom, dtype=np.float64)  # (2, C, 3) ruled, or a full (R, C, 3) grid
    y_rows = np.asarray(mapped.y, np.float64)
    top[..., 1] = y_rows[:, None]
    top_mesh[..., 1] = y_rows[:, None]
    if bottom.shape[0] == top.shape[0]:
        bottom[..., 1] = y_rows[:, None]
    else:
        bottom[0, :, 1], bottom[-1, :, 1] = y_rows[0], y_rows[-1]
    return top, top_mesh, bottom


def extrusion_volume(profile: Profile, mapped: Any, top: np.ndarray, nominal: Any, tolerance: float,
                     tessellation: "float | None" = None) -> tuple[float, float, float]:
    """The texture's own integral on an extruded face, for the gate's check 4:
    ``(volume, slack, nominal)`` mm^3.

    **Volume.** The relief as meshed is the sheet ``top`` ``(R, C, 3)`` (local mm: the
    mapped grid, lifted, rows at ``mapped.y``) over the profile's points ``P`` at the
    columns' arc lengths ``mapped.s`` extruded to the same rows. The volume between
    the two sheets is summed exactly by swept prisms
    (:func:`texcad.mapping.surface.grid_swept`): for a relief ``h`` along the
    normal of a profile of curvature ``kappa`` it is ``int (h + kappa h^2 / 2) ds dy``
    (a raised relief on a convex profile adds more than ``h A``), and it takes in
    the :data:`LIFT` and the chord sag the lift adds. Points the limiter sank into the
    body add nothing (they count as 0). The polygon through ``P`` lies inside a
    convex profile by the circular segments ``kappa ds^3 / 12`` per gap
    (:func:`texcad.mapping.surface.chord_excess`), which the union does not add:
    ``volume = swept - excess L``.

    **Slack.** What the union adds differs from that volume by at most: the lean
    mesh's ``tolerance`` (mm) times the face's area ``A``; the part's tessellation
    (its chords lie up to ``tessellation`` mm, default
    :data:`texcad.brep.TESSELLATION`, inside the exact face, where the union adds
    the relief's floor too) times ``A``; the segment term itself (``excess L``, the
    tessellation's segments are not the grid's); and float32 rounding of the
    vertices (``1e-3 |volume|``). With the default 0.02 mm that is 0.03 mm times
    the area: a texture that vanished, or one turned inwards, is far outside it.

    **Nominal.** ``int (h + kappa h^2 / 2) ds dy`` over the face's area ``A`` for the
    fitted texture ``nominal`` before the overhang limiter and the mapping's
    curvature limits (:func:`texcad.mapping.surface.relief_integral`: its mean
    height terms times ``A``, ``kappa`` the profile's mean curvature over the
    columns, :func:`texcad.mapping.surface.mean_curvature`), so that the gate warns
    when the limits removed most of it.
    """
    from ..brep import TESSELLATION
    from ..mapping.surface import chord_excess, grid_swept, mean_curvature, relief_integral

    tess = TESSELLATION if tessellation is None else float(tessellation)
    s = np.asarray(mapped.s, np.float64)
    y = np.asarray(mapped.y, np.float64)
    R, C = top.shape[:2]
    fc = profile.at(s)
    base = np.empty((R, C, 3))
    base[..., 0], base[..., 1], base[..., 2] = fc.point[None, :, 0], y[:, None], fc.point[None, :, 1]
    nrm = np.zeros((R, C, 3))
    nrm[..., 0], nrm[..., 2] = fc.normal[None, :, 0], fc.normal[None, :, 1]
    moved = np.where((normal_offset(top, profile, s) < 0)[..., None], base, np.asarray(top, np.float64))
    length = float(y[-1] - y[0])
    excess = chord_excess(profile, s, closed=bool(mapped.closed)) * length
    vol = grid_swept(base, moved, nrm, wrap_cols=bool(mapped.closed), measure=False).volume - excess
    area = (profile.length if mapped.closed else float(s[-1] - s[0])) * length
    slack = (float(tolerance) + tess) * area + abs(excess) + 1e-3 * abs(vol) + 1e-3
    return vol, slack, relief_integral(nominal.heights, area, mean_curvature(profile, s, closed=bool(mapped.closed)))


class ExtrusionAdapter(Adapter):
    """One face of a CAD part that is a full strip of an extrusion. The gate runs
    checks 1-5; the texture's integral (check 4) is :func:`extrusion_volume`."""

    kind = "extrusion"
    label = "an extruded face"
    options = frozenset({"height", "pitch", "mapping", "depth", "periodic_x", "transition", "build_dir", "critical_angle",
                         "tolerance", "brep", "mode"})

    def accepts(self, target: Any, where: Any, options: Options) -> bool:
        """One cylinder or extrusion face of a CAD part (not chained), raised, no
        gradient; options this adapter does not use are left to the faces path, unless
        given at their default (the command line gives ``rotation=0``)."""
        from OCP.GeomAbs import GeomAbs_Cylinder, GeomAbs_SurfaceOfExtrusion

        if options.mode is not Mode.RAISED or options.gradient is not None or where is None or hasattr(target, "stages"):
            return False
        if options.changed - self.options - {"progress", "max_memory"} or not is_cad_target(target):
            return False
        return _surface_kind(where) in (GeomAbs_Cylinder, GeomAbs_SurfaceOfExtrusion)

    # -- place --------------------------------------------------------------------------
    def place(self, target: Any, where: Any, texture: Any, options: Options) -> Placement:
        cp = cad_part(target, where)
        face = cp.faces[0]
        o, ex, ey, ez = extrusion_frame(face)
        axes = np.stack([ex, ey, ez])
        options.report(0.02, "recovering the face's profile")
        section, y_lo, length = _section_edges(face, o, axes)
        o = o + y_lo * ey
        try:
            profile = _profile(face, section, o, axes, length)
        except GeometryError as e:  # a cross-section the mapping cannot take: the faces path
            if "strip" in str(e) or "cross-section" in str(e):
                raise Decline(str(e)) from e
            raise
        area = _area(face)
        if abs(area - profile.length * length) > 0.01 * area:
            raise Decline(f"the face ({area:.1f} mm2) is not a full strip of its extrusion "
                          f"({profile.length:.1f} x {length:.1f} mm)")
        pm = tessellation(cp.topo)
        frame = ExtrusionFrame(face, o, axes, float(length), profile)
        return Placement("extrusion", pm.mesh, body_count(cp.topo), selected_surface(pm, cp.face_ids), cp.topo,
                         cp.face_ids, None, frame)

    # -- relief -------------------------------------------------------------------------
    def _fitted(self, fr: ExtrusionFrame, texture: Any, options: Options):
        """The texture fitted to the developed face, lowered for ``build_dir``:
        ``(Heightmap, periodic, limits, build_dir in the local frame or None, the
        Heightmap before the limiter)``."""
        from ..mapping import fit_texture
        from ..util import fitting_pitch, require_memory, texture_bytes

        options.report(0.05, f"mapping the texture onto the {fr.profile.length:.1f} x {fr.length:.1f} mm face "
                             f"({options.mapping.value})")
        hm, periodic = fit_texture(fr.profile, texture, length=fr.length, pitch=options.pitch, height=options.height,
                                   periodic_x=options.periodic_x)
        require_relief(hm, texture)
        need = texture_bytes(hm.shape[0] * hm.shape[1], 0.0)
        require_memory(need, f"a {hm.shape[0]} x {hm.shape[1]} px texture on the face",
                       f"use pitch >= {fitting_pitch(min(hm.pitch), need):.3g} mm")
        if options.directions is None:
            return hm, periodic, None, None, hm
        from ..printability import limit_on_profile

        d_local = _directions(options) @ fr.axes.T  # the world build direction(s) in the profile's frame
        options.report(0.05, f"limiting overhangs to {options.critical_angle:g} deg")
        nominal = hm
        hm, limits = limit_on_profile(fr.profile, hm, d_local, options.critical_angle, mapping=options.mapping.value,
                                      periodic=periodic)
        return hm, periodic, limits, d_local, nominal

    def relief(self, placement: Placement, texture: Any, options: Options) -> Relief:
        from ..mapping import map_texture
        from ..util import subrange

        fr: ExtrusionFrame = placement.data
        hm, periodic, limits, d_local, hm_nominal = self._fitted(fr, texture, options)
        mapped = map_texture(fr.profile, hm, mapping=options.mapping.value, length=fr.length, depth=options.depth,
                             periodic_x=periodic, transition=options.transition, progress=subrange(options.progress, 0.05, 0.3))
        top, top_mesh, bottom = _grids(mapped, fr.profile, limits is not None)
        options.report(0.35, "meshing and fusing (manifold3d)")
        slab_local, max_error = lean_mapped_slab(top_mesh, bottom, fr.profile, mapped.s, closed=mapped.closed,
                                                 tolerance=options.tolerance, build_dir=d_local,
                                                 critical_angle=options.critical_angle)  # lean (issue 15)
        if limits is not None:
            from ..printability import measured

            limits = measured(limits, slab_local, d_local, options.critical_angle)
        slab = Mesh(fr.world(slab_local.vertices.astype(np.float64)).astype(np.float32), slab_local.faces)
        reach = float(normal_offset(top_mesh, fr.profile, mapped.s).max())
        data = ExtrusionRelief(fr.world(top), fr.world(bottom), np.asarray(mapped.s, np.float64), float(mapped.y[0]),
                               bool(mapped.closed), slab)
        vol, slack, nominal = extrusion_volume(fr.profile, mapped, top_mesh, hm_nominal, options.tolerance)
        return Relief(heightmap=mapped.heightmap, limits=limits, volume=vol, volume_slack=slack, nominal_volume=nominal,
                      reach=reach + options.tolerance + 1e-3, max_error=max_error, mapped=mapped, data=data)

    # -- fuse ---------------------------------------------------------------------------
    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        from ..solid import fuse

        fr: ExtrusionFrame = placement.data
        mapped = relief.mapped
        fused = fuse(placement.base, relief.data.slab)
        info = {
            "face": "extrusion", "origin": fr.origin.tolist(), "xdir": fr.axes[0].tolist(), "ydir": fr.axes[1].tolist(),
            "zdir": fr.axes[2].tolist(), "grid": tuple(mapped.top.shape[:2]), "closed": mapped.closed,
            "mapping": options.mapping.value, "profile_length": fr.profile.length, "length": fr.length,
            "tolerance": options.tolerance, "volume_slack": options.tolerance * fr.profile.length * fr.length,
            "limits": [str(x) for x in mapped.limits], "brep": options.brep,
        }
        if options.directions is not None:
            info["build_dir"] = _directions(options).tolist()
            info["critical_angle"] = options.critical_angle
        if not options.brep:
            info["no_brep"] = "textured with brep=False; texture it again with brep=True for STEP"
        return Fused(fused, placement.base, info)

    # -- on demand ----------------------------------------------------------------------
    def brep(self, stages: Stages, fine: Any = None) -> Any:
        """The face replaced by B-spline tiles on the lifted grid; ``base`` (C, 3):
        the face under the first row's columns (local x, y0, z in world mm)."""
        from ..brep.targets import extrusion_brep

        if not stages.options.brep:
            raise GeometryError("textured with brep=False; texture it again with brep=True for STEP")
        fr: ExtrusionFrame = stages.placement.data
        r: ExtrusionRelief = stages.relief.data
        base = fr.world(np.insert(fr.profile.point(r.s), 1, r.y0, axis=1))
        return extrusion_brep(stages.placement.topo, fr.face, r.top, r.bottom, closed=r.closed, base=base, fine=fine,
                              mesh=stages.fused.mesh, max_error=float(stages.relief.max_error or 0.0))
