"""Adapter: any faces of a CAD part, several at once, smooth bands across edges,
chaining onto an earlier result (``texcad.texture(part, faces, texture)``).

Every face kind OCCT has (plane, cylinder, cone, sphere, torus, surfaces of revolution
and extrusion, B-spline, Bezier, offset, fillets and blends, trimmed faces with holes)
goes the same way (the numerics of one patch: :mod:`texcad.targets.patches`):

**Place.** The part is tessellated once by OCCT (0.01 mm chord error); the selected
faces' triangles, with each face's own ``(u, v)`` at every vertex, are the surface the
texture is laid on, and the whole tessellation (welded, checked watertight, healed if
needed) is the base mesh (chained: the earlier result's mesh). Faces that meet across
a sharp edge are textured apart (the M-I ramp brings the relief to 0 at that edge);
faces that meet smoothly (tangent edges) form one *patch* and are flattened together,
so the texture runs on across the edge.

**Zones.** ``where`` may give zones, ``[(faces, texture, {options}), ...]``
(:func:`texcad.targets.cad.cad_zones`): each zone's faces form patches of their own
(never joined to another zone's, even across a tangent edge), made with the zone's
texture and options (:data:`texcad.targets.cad.ZONE_OPTIONS` over the call's), so
touching zones each ramp to 0 at the shared edge. All patches are fused in one
union; each zone's relief is then checked against its own height from its own faces
(:func:`_zone_reach`), ``layer_meshes`` gives one body per zone and the base is the
part with every texture at its lowest (3MF parts that split the volume).

**Relief.** Per patch: texture coordinates in mm (a plane's own frame; one curved
face's ``(u, v)`` by arc length, whole tiles around a closed face, the texture
stretched by ``r / R_ref`` there and reported as :class:`texcad.mapping.Distortion`;
a closed band by the cross-section's arc length; LSCM otherwise), the texture grid,
the fade at poles and needles (``[FADE_FULL, 1/FADE_FULL]``, a TexcadWarning), the
M-I ramp, the curvature limits ``0.9 / kappa``, the overhang limiter on the grid
(``build_dir``, ``critical_angle``) and the slab / cutters, lean within ``tolerance``.

**Fuse.** All slabs and cutters in one manifold3d union, ``(base - cutters) +
slabs``; one body per solid checked; the result welded within
:data:`~texcad.solid.weld.WELD` mm (a union that pinches along an edge is
redone with the relief nudged by 2 um).

**B-rep.** A patch parameterized on its own ``(u, v)`` (one curved face) becomes a
degree-1 B-spline on that parameter space in place of the face
(:func:`texcad.brep.uv_textured_solid`); a planar face is tiled in its frame
(:func:`texcad.brep.uvfaces.holed_plane_solid`); faces flattened together (bands,
LSCM) are tiled over their meshed cells with walls down to the faces, cut by OCCT's
general fuse (:func:`texcad.brep.bands.patch_solid`).
"""

from __future__ import annotations

import warnings
import weakref
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..contracts import Fused, Placement, Relief, Stages
from ..errors import GeometryError, ParameterError, TexcadWarning
from ..options import Options
from ..report.gate import Expectation
from ..solid import Mesh, from_manifold, to_manifold
from ..solid.boolean import welded_mesh
from .base import Adapter
from .cad import (CadPart, body_count, cad_part, cad_zones, face_list, face_numbers, is_cad_target, is_zones, selected_surface,
                  tessellation, zone_options)
from ..solid.weld import welded
from .patches import FADE_FULL, PatchOptions, PatchRelief, patch_relief, smooth_patches

__all__ = ["FacesAdapter", "FacesPlacement", "FacesRelief", "FacesFused", "FacesZone", "patch_options", "union_patches",
           "patches_integral", "patches_displaced"]


@dataclass(frozen=True)
class FacesZone:
    """One zone: faces textured with their own texture and options
    (``FacesPlacement.zones``; a call without zones has one).

    Attributes:
        name: how outputs name it (a 3MF part): ``"zone K TEXTURE"``, or ``"texture"``.
        faces: its face indices (explorer order of the part).
        texture: its texture as given (``"builtin:..."``, an image path or a Heightmap).
        options: what its patches are made with (:class:`~texcad.targets.patches.PatchOptions`;
            ``height`` mm, ``mode``, ...).
    """

    name: str
    faces: tuple
    texture: Any
    options: PatchOptions


@dataclass(frozen=True)
class FacesPlacement:
    """The selected faces placed (``Placement.data``).

    Attributes:
        mesh: the part's tessellation (:class:`texcad.brep.PartMesh`: per-face meshes
            with their ``(u, v)``, the welded whole, the face of every triangle), mm.
        patches: the selected faces grouped into patches joined by smooth edges
            (face indices in the part's explorer order); never across two zones.
        zones: the :class:`FacesZone` of the call (one without zones).
        zone_of: the zone (index into ``zones``) of every patch.
        zoned: the call gave zones (``where`` a list of ``(faces, texture, {options})``).
    """

    mesh: Any
    patches: tuple
    zones: tuple = ()
    zone_of: tuple = ()
    zoned: bool = False


@dataclass(frozen=True)
class FacesRelief:
    """The reliefs of the patches (``Relief.data``).

    Attributes:
        patches: one :class:`~texcad.targets.patches.PatchRelief` per patch textured
            (patches with no texture left are skipped with a warning).
        options: what the patches were made with (:class:`~texcad.targets.patches.PatchOptions`).
        texture: the texture as given (a ``"builtin:..."`` / image path, or a Heightmap),
            for a union that has to be redone nudged.
        zone_of: the zone of every patch relief (index into ``FacesPlacement.zones``).
    """

    patches: tuple
    options: PatchOptions
    texture: Any
    zone_of: tuple = ()


@dataclass(frozen=True)
class FacesFused:
    """The union (``Fused.data``).

    Attributes:
        patches: the patch reliefs in the fused mesh (those of :class:`FacesRelief`,
            or their nudged remakes when the first union pinched).
        union: the manifold3d union ``(base - cutters) + slabs`` (``manifold3d.Manifold``).
        base: the base as a ``manifold3d.Manifold``.
    """

    patches: tuple
    union: Any
    base: Any


def patch_options(options: Options) -> PatchOptions:
    """The patch stages' options from the validated :class:`~texcad.options.Options`."""
    dirs = None
    if options.build_dir is not None:
        from ..printability import build_directions

        dirs = build_directions(options.directions)
    return PatchOptions(
        height=options.height, pitch=options.pitch, depth=options.depth, edge_angle=float(options.edge_angle),
        rotation=float(options.rotation), build_dir=dirs, critical_angle=options.critical_angle,
        tolerance=options.tolerance, mode=options.mode.value, share=options.mode.share, gradient=options.gradient,
        mask=options.mask, mask_size=options.mask_size,
    )


def _warn_untextured(bare: list) -> None:
    """One warning for the patches ``[(faces, GeometryError), ...]`` left untextured
    (a fluted knob's forty narrow flutes: one line, not forty)."""
    if not bare:
        return
    if len(bare) == 1:
        warnings.warn(f"face(s) {bare[0][0]} left untextured: {bare[0][1]}", TexcadWarning, stacklevel=4)
        return
    faces = ", ".join(str(f) for p, _ in bare for f in p)
    warnings.warn(f"{len(bare)} patches of faces ({faces}) left untextured; the first: {bare[0][1]}", TexcadWarning,
                  stacklevel=4)


class FacesAdapter(Adapter):
    """Any faces of a CAD part (the last adapter: it takes every CAD target with faces)."""

    kind = "faces"
    label = "faces of a CAD part"
    options = frozenset({"height", "pitch", "depth", "edge_angle", "rotation", "build_dir", "critical_angle", "tolerance",
                         "mode", "gradient", "brep", "mask", "mask_size"})

    def accepts(self, target: Any, where: Any, options: Options) -> bool:
        return where is not None and is_cad_target(target)

    # -- place --------------------------------------------------------------------------
    def place(self, target: Any, where: Any, texture: Any, options: Options) -> Placement:
        options.report(0.02, "tessellating the part (OCCT)")
        zoned = is_zones(where)
        czs = cad_zones(target, where, texture) if zoned else ()
        cp = _all_zones(czs) if zoned else cad_part(target, where)
        pm = tessellation(cp.topo)
        for i in cp.face_ids:  # per selected face
            if pm.faces[i] is None:
                raise ParameterError(
                    "a face is not a face of this part (or has no area); select it from the part itself, "
                    "e.g. part.faces().filter_by(GeomType.CONE) (build123d) or wp.faces('%CONE') (CadQuery)"
                )
        base = pm.mesh if cp.previous is None else cp.previous.fused.mesh
        if zoned:  # each zone its own texture and options; patches never join two zones
            zones = tuple(FacesZone(z.name, z.part.face_ids, z.texture, patch_options(zone_options(options, z, k)))
                          for k, z in enumerate(czs))
        else:
            zones = (FacesZone("texture", cp.face_ids, texture, patch_options(options)),)
        patches, zone_of = [], []
        for k, z in enumerate(zones):  # per zone
            for p in smooth_patches(pm, list(z.faces)):  # per patch of the zone
                patches.append(tuple(p))
                zone_of.append(k)
        data = FacesPlacement(pm, tuple(patches), zones, tuple(zone_of), zoned)
        return Placement("faces", base, body_count(cp.topo), selected_surface(pm, cp.face_ids), cp.topo, cp.face_ids,
                         cp.previous, data)

    # -- relief -------------------------------------------------------------------------
    def relief(self, placement: Placement, texture: Any, options: Options) -> Relief:
        from ..mapping import Distortion

        fp: FacesPlacement = placement.data
        pm, patches = fp.mesh, fp.patches
        opts = patch_options(options)
        reliefs, zone_of, bare_patches = [], [], []
        for k, patch in enumerate(patches):  # per patch of smoothly joined faces
            zone = fp.zones[fp.zone_of[k]] if fp.zones else FacesZone("texture", patch, texture, opts)
            options.report(0.05 + 0.6 * k / len(patches), f"texturing face(s) {face_numbers(patch)} ({', '.join(pm.faces[i].kind for i in patch)})")
            try:
                reliefs.append(patch_relief(pm, list(patch), zone.texture, zone.options))
                zone_of.append(fp.zone_of[k] if fp.zones else 0)
            except GeometryError as e:
                if len(patches) == 1:
                    raise
                bare_patches.append((face_numbers(patch), e))
        _warn_untextured(bare_patches)
        if not reliefs:
            raise GeometryError("no texture is left on any selected face: they are too small or narrow at this pitch")
        bare = sorted(set(range(len(fp.zones))) - set(zone_of)) if fp.zoned else []
        if bare:
            raise GeometryError(f"no texture is left on {fp.zones[bare[0]].name} (faces {list(fp.zones[bare[0]].faces)}): "
                                "its faces are too small or narrow at its pitch; use a smaller pitch or leave the zone out")
        _warn(reliefs)
        volume, slack, nominal = patches_integral(reliefs)
        reach = max(float(np.abs(r.h_top).max()) for r in reliefs) + 0.05
        return Relief(
            heightmap=reliefs[0].heightmap if len(reliefs) == 1 else None,
            limits=_limits(reliefs, options, opts) if opts.build_dir is not None else None,
            volume=volume, volume_slack=slack, nominal_volume=nominal, reach=reach,
            distortion=Distortion.combined([r.distortion for r in reliefs]),
            data=FacesRelief(tuple(reliefs), opts, texture, tuple(zone_of)),
        )

    # -- fuse ---------------------------------------------------------------------------
    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        fp: FacesPlacement = placement.data
        fr: FacesRelief = relief.data
        reliefs, opts = list(fr.patches), fr.options
        n_tri = sum(b.num_triangles for r in reliefs for b in (r.bodies.slab, r.bodies.cutter) if b is not None)
        options.report(0.7, f"fusing {n_tri} texture triangles onto the part (manifold3d)")
        base_man = to_manifold(placement.base)
        want = len(base_man.decompose())
        for attempt in range(3):  # a union whose output pinches (two sheets along an edge) is redone, nudged
            fused_man = union_patches(base_man, reliefs)
            got = len(fused_man.decompose())
            if got != want:
                raise GeometryError(
                    f"the textured part has {got} bodies, the part {want}: a relief came off the face; "
                    "use a smaller height or depth, or report this"
                )
            fused = welded(fused_man)
            if fused is not None:
                break
            if attempt == 2:
                raise GeometryError("the textured mesh touches itself along an edge (welded by position it is not a manifold); "
                                    "try another pitch or height")
            options.report(0.75, "the union pinched along an edge: redoing it with the relief nudged by 2 um")
            opts = replace(opts, jitter=0.002 * (attempt + 1))
            zs = [fp.zones[k] if fp.zones else FacesZone("texture", (), fr.texture, fr.options) for k in _zone_of(fr, reliefs)]
            reliefs = [patch_relief(fp.mesh, list(r.faces), z.texture, replace(z.options, jitter=opts.jitter))
                       for r, z in zip(reliefs, zs)]  # fmt: skip
        info = _info(placement, reliefs, options)
        base_mesh = placement.base
        if fp.zoned:  # zones: each zone's relief in info, checked on its own; the base at every texture's lowest (3MF)
            info.update(_zone_info(fp, fr, reliefs))
            options.report(0.8, "checking each zone's reach from its own faces")
            _zone_reach(fused, placement.base, fp, fr, reliefs, info["zone_reliefs"])
            lows = [to_manifold(r.bodies.low_cutter) for r in reliefs if r.bodies.low_cutter is not None]
            if lows:
                import manifold3d as m3d

                base_mesh = welded_mesh(m3d.Manifold.batch_boolean([base_man] + lows, m3d.OpType.Subtract))
        return Fused(fused, base_mesh, info, FacesFused(tuple(reliefs), fused_man, base_man))

    # -- the gate's expectation ---------------------------------------------------------
    def expectation(self, placement: Placement, relief: Relief, fused: Fused) -> Expectation:
        """Body count, the reach from the selected faces (the texture's largest
        offset plus the cutters' clearance) and the texture's integral summed over
        the patches as fused (:func:`patches_integral`: a union redone nudged has
        remade them)."""
        volume, slack, nominal = patches_integral(fused.data.patches)
        return Expectation(bodies=placement.bodies, base=placement.base, selected=placement.selected, height=relief.reach,
                           volume=volume, volume_slack=slack, nominal_volume=nominal,
                           displaced=patches_displaced(fused.data.patches))

    # -- on demand ----------------------------------------------------------------------
    def texture_mesh(self, stages: Stages) -> Mesh:
        """The union minus the base with every texture at its lowest (engraved and
        centred: the low cutters subtracted), mm."""
        import manifold3d as m3d

        f: FacesFused = stages.fused.data
        lows = [to_manifold(r.bodies.low_cutter) for r in f.patches if r.bodies.low_cutter is not None]
        lowest = m3d.Manifold.batch_boolean([f.base] + lows, m3d.OpType.Subtract) if lows else f.base
        return welded_mesh(f.union - lowest)

    def layer_meshes(self, stages: Stages) -> list:
        """One texture body per zone (mm): the zone's slabs and cutters on the part,
        minus the part with the zone's texture at its lowest (as :meth:`texture_mesh`);
        one body without zones."""
        import manifold3d as m3d

        fp: FacesPlacement = stages.placement.data
        if not fp.zoned:
            return [self.texture_mesh(stages)]
        f: FacesFused = stages.fused.data
        zone_of = _zone_of(stages.relief.data, f.patches)
        out = []
        for k in range(len(fp.zones)):  # per zone
            rs = [r for r, z in zip(f.patches, zone_of) if z == k]
            lows = [to_manifold(r.bodies.low_cutter) for r in rs if r.bodies.low_cutter is not None]
            lowest = m3d.Manifold.batch_boolean([f.base] + lows, m3d.OpType.Subtract) if lows else f.base
            out.append(welded_mesh(union_patches(f.base, rs) - lowest))
        return out

    def max_error(self, stages: Stages) -> float:
        """The lean relief's largest measured error against the texture grid, mm (0: the grid)."""
        return max(r.max_error for r in stages.fused.data.patches)

    def brep(self, stages: Stages, fine: Any = None) -> Any:
        """Each patch on its own ``(u, v)`` (:func:`texcad.brep.uv_textured_solid`), a
        planar face in tiles, or faces flattened together in tiles with walls
        (:func:`texcad.brep.bands.patch_solid`); chained, on the earlier result's
        B-rep (:func:`chained_base`). ``fine``: rectangles ``(x0, x1, y0, y1)`` mm in a
        lone planar face's frame, or boxes ``(lo, hi)`` mm (CAD operations)."""
        kinds = sorted({k for i in stages.fused.info["faces"] for k in i["kinds"]})
        no_brep = f"no B-rep of the textured {', '.join(kinds)} face(s)"
        if not stages.options.brep:
            raise GeometryError("textured with brep=False; texture it again with brep=True for STEP")
        base = stages.placement.topo
        if stages.placement.previous is not None:  # chained: this texture on the earlier result's B-rep
            base = chained_base(stages.placement.previous)
        return _brep(base, stages.fused.data.patches, no_brep, float(stages.options.rotation), fine, stages.placement.data.mesh)

    def textured_on(self, stages: Stages) -> Any:
        """The untextured part, or, chained, the earlier result's B-rep (the same
        object :meth:`brep` puts this texture on, :func:`chained_base`)."""
        prev = stages.placement.previous
        return stages.placement.topo if prev is None else chained_base(prev)

    def fine_frame(self, stages: Stages) -> Any:
        """A lone planar face: its frame and pitch ``(origin, xdir, ydir, pitch)`` mm."""
        ff = stages.fused.info.get("fine_frame")
        if ff is None:
            return None
        o, ex, ey, pitch = ff
        return (np.asarray(o), np.asarray(ex), np.asarray(ey), float(pitch))


#: Most sample triangles the gate's reach check may make of the base (a stopgap: the
#: gate splits every triangle in four until its longest edge is short, so a long thin
#: triangle of a tessellated cylinder becomes 4^8 triangles; a sphere on a 40 mm


#: The B-rep of each earlier result a chained texture is put on, by ``id`` of its
#: stages, while those stages live (:func:`chained_base`).
_CHAINED: dict = {}


def chained_base(previous: Stages) -> Any:
    """The B-rep a chained texture is put on: the earlier result's (made by its own
    adapter, itself chained or not; made once, so that the texture's B-rep and a CAD
    operation's replay, :meth:`FacesAdapter.textured_on`, hold the same OCCT faces).
    Its untextured faces are the part's own (the same OCCT faces), so the faces
    selected on the part are found in it.

    Raises:
        GeometryError: the earlier result has no B-rep (the message says why).
    """
    key = id(previous)
    if key not in _CHAINED:
        try:
            _CHAINED[key] = previous.adapter.brep(previous)
        except GeometryError as e:
            raise GeometryError(f"this result textures a face of an earlier textured result (chained), whose B-rep failed: {e}") from None
        weakref.finalize(previous, _CHAINED.pop, key, None)
    return _CHAINED[key]


def _warn(reliefs: list) -> None:
    faded = [r for r in reliefs if r.distortion.faded_fraction > 0]
    if faded:
        warnings.warn(
            f"the texture fades out on {100 * max(r.distortion.faded_fraction for r in faded):.1f} % of face(s) "
            f"{[face_numbers(r.info['faces']) for r in faded]}: the texture scale there leaves [{FADE_FULL}, {1 / FADE_FULL:.2f}] "
            "(a pole, a needle-thin region)",
            TexcadWarning,
            stacklevel=4,
        )
    if any(r.limited for r in reliefs):
        warnings.warn("the texture height was limited to 0.9 / curvature on concave parts of the face(s)", TexcadWarning, stacklevel=4)


def patches_integral(reliefs) -> tuple:
    """``(volume, slack, nominal)`` mm^3 over the patches: the sums of their
    :func:`~texcad.targets.patches.patch_volume` (nominal None if any patch is
    centred)."""
    parts = [r.integral for r in reliefs]
    nominal = None if any(p[2] is None for p in parts) else float(sum(p[2] for p in parts))
    return float(sum(p[0] for p in parts)), float(sum(p[1] for p in parts)), nominal


def patches_displaced(reliefs) -> "Displaced | None":
    """What the patches displace above and below their faces alike, summed
    (:func:`~texcad.targets.patches.patch_displaced`), when one is centred (the
    gate's check of a texture whose net volume is about 0), else None."""
    from ..report.gate import Displaced

    if not any(r.info["mode"] == "centred" for r in reliefs):
        return None
    v, a, s, n = (float(sum(r.displaced[k] for r in reliefs)) for k in range(4))
    return Displaced(v, a, s, n)


def union_patches(base_man, reliefs: list):
    """``(base - cutters) + slabs`` (manifold3d); checked."""
    import manifold3d as m3d

    cutters = [to_manifold(r.bodies.cutter) for r in reliefs if r.bodies.cutter is not None]
    slabs = [to_manifold(r.bodies.slab) for r in reliefs if r.bodies.slab is not None]
    man = m3d.Manifold.batch_boolean([base_man] + cutters, m3d.OpType.Subtract) if cutters else base_man
    if slabs:
        man = m3d.Manifold.batch_boolean([man] + slabs, m3d.OpType.Add)
    if man.status() != m3d.Error.NoError or man.is_empty():
        raise GeometryError(f"the union of texture and part failed (manifold3d: {man.status().name})")
    return man


def _limits(reliefs: list, options: Options, opts: PatchOptions):
    """One :class:`texcad.printability.LimitReport` over the patches."""
    from ..printability import LimitReport

    li = [r.limit for r in reliefs if r.limit is not None]
    return LimitReport(
        removed_volume_mm3=float(sum(x["removed_volume_mm3"] for x in li)),
        max_removed_mm=float(max((x["max_removed_mm"] for x in li), default=0.0)),
        touched_fraction=float(max((x["touched_fraction"] for x in li), default=0.0)),
        ramped_borders=(),
        critical_angle_deg=float(options.critical_angle),
        margin_deg=1.0,
        directions=np.asarray(opts.build_dir),
        remaining_overhang_mm2=float(sum(x["remaining_overhang_mm2"] for x in li)),
        surface_overhang=any(x["surface_overhang"] for x in li),
        iterations=int(max((x["rounds"] for x in li), default=1)),
    )


def _at_tolerance(reliefs: list) -> bool:
    """Is the STEP of these patches written at the mesh's tolerance? Yes: faces
    flattened together too, whole runs of tiles merged (a band all around, a
    rectangle of cells) and the 4-cell tiles where their outline turns a corner
    (the face pieces kept beside the walls there are cut short,
    :func:`texcad.brep.bands._cut_slivers`, so OCCT meshes them closed)."""
    return bool(reliefs)


def _info(placement: Placement, reliefs: list, options: Options) -> dict:
    """What was done, plain values (``Textured.info``)."""
    from ..mapping import Distortion

    infos = [r.info for r in reliefs]
    dist = Distortion.combined([r.distortion for r in reliefs])
    max_error = max(r.max_error for r in reliefs)
    area = float(sum(r.cells.sum() * np.prod(r.heightmap.pitch) for r in reliefs))
    chained = placement.previous is not None
    info = {
        "face": "faces" if len(infos) > 1 else infos[0]["kinds"][0],
        "faces": infos,
        "grid": infos[0]["grid"],
        "brep": True,
        "distortion": None if dist is None else dist.to_dict(),
        "chained": chained,
        # the lean mesh may enclose up to its error times the textured area more or less than the grid's B-rep
        # (chained: and the earlier textures' lean meshes theirs)
        "volume_slack": max_error * area + (float(placement.previous.fused.info.get("volume_slack", 0.0)) if chained else 0.0),
    }
    if _at_tolerance(reliefs) and (not chained or placement.previous.fused.info.get("tolerance")):
        info["tolerance"] = float(options.tolerance)  # the STEP is written at it (texcad.io.step_tiles)
    if options.build_dir is not None:
        info["build_dir"] = np.asarray(patch_options(options).build_dir).tolist()
        info["critical_angle"] = float(options.critical_angle)
    lone = reliefs[0] if len(reliefs) == 1 else None
    if not chained and lone is not None and lone.face is not None and lone.tables is None:  # one planar face
        from ..brep import plane_frame

        p0, ex, ey, _ = plane_frame(lone.face, float(options.rotation))
        info["fine_frame"] = (p0.tolist(), ex.tolist(), ey.tolist(), float(options.pitch))
    return info


def _brep(topo: Any, patches: tuple, no_brep: str, rotation: float, fine: Any = None, pm: Any = None) -> Any:
    """The textured B-rep of the patches on the part ``topo`` (mm; ``rotation``: the
    texture's turn on planar faces, degrees). Curved faces:
    :func:`texcad.brep.uv_textured_solid`; planar faces: tiles in the face's frame;
    faces flattened together (``pm`` the part's tessellation): tiles with walls
    (:func:`texcad.brep.bands.patch_solid`).

    Raises:
        GeometryError: a patch has no B-rep this way (``no_brep`` names the faces; the
            message names the mesh outputs).
    """
    from ..brep import uv_textured_solid

    items, planes, groups = [], [], []
    if pm is not None:  # chained: the faces as they lie in the earlier result's B-rep
        patches = [_found(topo, r, pm) for r in patches]
    for r in patches:  # one per patch
        if r.face is None:
            groups.append(r)
            continue
        if r.tables is None:  # a plane: its grid lies in the face's frame
            planes.append(r)
            continue
        ut, vt, closed = r.tables
        g = r.grid
        items.append({"face": r.face, "points": g.points, "normals": g.normals, "heights": r.brep_top, "signed": r.signed,
                      "valid": g.valid, "xs": g.xs, "ys": g.ys, "u_table": ut, "v_table": vt, "closed_u": bool(closed),
                      "cells": r.cells if r.info.get("mode") == "engraved" else None})  # the cutter's cells
    try:
        shape = uv_textured_solid(topo, items) if items else topo
        for r in planes:  # one per planar face
            shape = _plane_brep(shape, r, r.info.get("rotation", rotation), fine)
        for r in groups:  # one per patch of faces flattened together
            shape = _patch_brep(shape, r, pm, fine)
        return shape
    except GeometryError as e:
        raise GeometryError(f"{no_brep}: {e}; the mesh is fine: export('part.stl') or export('part.3mf')") from None


def _found(shape: Any, r: PatchRelief, pm: Any) -> PatchRelief:
    """The patch ``r`` with its faces as they lie in ``shape`` (an earlier texture
    may have rebuilt a neighbour face: :func:`texcad.brep.bands.face_in`).

    Raises:
        GeometryError: a face is not in ``shape``.
    """
    from ..brep.bands import face_in

    for i in r.faces:  # the patch's faces
        if face_in(shape, pm.faces[i].face) is None:
            raise GeometryError(f"face {i} ({pm.faces[i].kind}) is not in the earlier result's B-rep (an earlier texture "
                                "rebuilt it); texture the faces together in one call for STEP")
    return r if r.face is None else replace(r, face=face_in(shape, r.face))


def _patch_brep(shape: Any, r: PatchRelief, pm: Any, fine: Any = None) -> Any:
    """``shape`` with the faces of the patch ``r`` (flattened together) textured in
    tiles with walls (:func:`texcad.brep.bands.patch_solid`; ``fine``: boxes ``(lo,
    hi)`` mm where a CAD operation's tool is)."""
    from ..brep import TESSELLATION
    from ..brep.bands import face_in, patch_solid

    boxes = [f for f in fine or () if len(f) >= 2 and np.ndim(f[0]) == 1]
    g = r.grid
    top = r.h_top if r.fused_top is None else r.fused_top
    out = patch_solid(shape, [face_in(shape, pm.faces[i].face) for i in r.faces], g.points, g.normals, top, r.cells, wrap=bool(g.wrap_y),
                      signed=bool(r.signed), chord=TESSELLATION, fine=boxes or None)
    if out is None:
        raise GeometryError(f"faces {face_numbers(r.info['faces'])} were flattened together and OCCT did not cut their walls")
    return out


def _plane_brep(shape: Any, r: PatchRelief, rotation: float, fine: Any = None) -> Any:
    """``shape`` with the planar face of the patch ``r`` in tiles: engraved and
    centred, the fused mesh's surface with its floor and the step down to it
    (:func:`texcad.brep.bands.signed_plane_solid`); else heights 0 outside the kept
    cells and near the outline."""
    from ..brep import plane_frame
    from ..brep.bands import face_in, signed_plane_solid
    from ..brep.uvfaces import holed_plane_solid

    p0, ex, ey, n = plane_frame(r.face, rotation)
    g, cells = r.grid, r.cells
    if r.signed and r.fused_top is not None:
        out = signed_plane_solid(shape, face_in(shape, r.face) or r.face, g.points, g.normals, r.fused_top, cells,
                                 frame=(p0, ex, ey, n), fine=fine)
        if out is None:
            raise GeometryError("OCCT did not cut the planar face along the walls of its engraved or centred texture")
        return out
    kept = np.zeros(g.valid.shape, bool)
    for a, b in ((slice(None, -1), slice(None, -1)), (slice(None, -1), slice(1, None)), (slice(1, None), slice(None, -1)),
                 (slice(1, None), slice(1, None))):  # the 4 corners of each kept cell
        kept[a, b] |= cells
    h = np.where(kept & g.valid, r.h_top, 0.0)
    face = face_in(shape, r.face) or r.face  # a neighbour's texture may have rebuilt it (split its edges)
    out = holed_plane_solid(shape, face, h, np.asarray(g.xs, np.float64), np.asarray(g.ys, np.float64),
                            origin=p0, xdir=ex, normal=n, flatten_outline=True, fine=fine)  # fmt: skip
    if out is None:
        raise GeometryError("the planar face's texture grid reaches its outline; texture it in raised mode for a B-rep")
    return out


# ------------------------------------------------------------------------------------------
# Zones
# ------------------------------------------------------------------------------------------
def _all_zones(zones: tuple) -> CadPart:
    """One :class:`~texcad.targets.cad.CadPart` holding every zone's faces."""
    first = zones[0].part
    return CadPart(first.topo, tuple(f for z in zones for f in z.part.faces), tuple(i for z in zones for i in z.part.face_ids),
                   first.previous, first.done)


def _zone_of(fr: FacesRelief, reliefs) -> tuple:
    """The zone of every patch relief (0 for all without zones)."""
    return fr.zone_of if len(fr.zone_of) == len(reliefs) else (0,) * len(reliefs)


def _zone_info(fp: FacesPlacement, fr: FacesRelief, reliefs: list) -> dict:
    """Per zone, plain values (``Textured.info``): ``zones`` the names (3MF parts),
    ``zone_reliefs`` the faces, texture, mode, height (mm) asked and reached."""
    zone_of = _zone_of(fr, reliefs)
    out = []
    for k, z in enumerate(fp.zones):  # per zone
        infos = [r.info for r, j in zip(reliefs, zone_of) if j == k]
        item = {"name": z.name, "faces": [int(i) for i in z.faces], "texture": z.name.split(" ", 2)[-1], "mode": z.options.mode,
                "height": float(z.options.height), "pitch": float(z.options.pitch),
                "max_height": float(max(i["max_height"] for i in infos))}
        if z.options.share > 0:
            item["max_depth"] = float(max(i.get("max_depth", 0.0) for i in infos))
        out.append(item)
    return {"zones": [z.name for z in fp.zones], "zone_reliefs": out}


#: mm: how far the engraved cutters start outside the face (the relief's reach over its largest offset).
CUT_CLEARANCE = 0.05


def _zone_reach(mesh: Mesh, base: Mesh, fp: FacesPlacement, fr: FacesRelief, reliefs: list, out: list) -> None:
    """Every zone's relief stays within its own reach of its own faces: each vertex of
    the fused ``mesh`` off the ``base`` surface belongs to the zone whose faces are
    nearest, and lies no farther from them than that zone's largest offset plus the
    cutters' clearance (0.05 mm) and the gate's margin (a quarter of the height, at
    least 0.05 mm). Adds ``reach_mm`` and ``farthest_mm`` (measured) to each zone's
    entry of ``out``. Exact point-triangle distances (libigl's AABB tree).

    Raises:
        GeometryError: a zone's relief reaches farther (another zone's texture on its
            faces, or a relief off its faces).
    """
    import igl

    pm = fp.mesh
    zone_of = _zone_of(fr, reliefs)
    pts = np.ascontiguousarray(mesh.vertices, dtype=np.float64)
    sv = np.ascontiguousarray(pm.mesh.vertices, dtype=np.float64)
    dist = np.empty((len(fp.zones), len(pts)))
    allowed = np.empty(len(fp.zones))
    for k, z in enumerate(fp.zones):  # per zone: the exact distance of every vertex to its faces
        sf = np.ascontiguousarray(pm.mesh.faces[np.isin(pm.face_of_tri, np.asarray(z.faces))], dtype=np.int64)
        dist[k] = np.sqrt(igl.point_mesh_squared_distance(pts, sv, sf)[0])
        top = max(float(np.abs(r.h_top).max()) for r, j in zip(reliefs, zone_of) if j == k) + CUT_CLEARANCE
        allowed[k] = top + max(0.25 * top, 0.05)
        out[k]["reach_mm"] = float(allowed[k])
    near = np.argmin(dist, axis=0)
    d = dist[near, np.arange(len(pts))]
    far = np.flatnonzero(d > allowed[near])
    if len(far):  # a vertex on the part's own surface (an untextured face) is not relief
        bf = np.ascontiguousarray(base.faces, dtype=np.int64)
        on = np.sqrt(igl.point_mesh_squared_distance(pts[far], np.ascontiguousarray(base.vertices, np.float64), bf)[0])
        far = far[on > 0.05]
    for k in range(len(fp.zones)):  # per zone: the farthest of its relief vertices
        mine = (near == k) & (d <= allowed[k])
        out[k]["farthest_mm"] = float(d[mine].max(initial=0.0))
    if len(far):
        k = int(near[far[np.argmax(d[far])]])
        raise GeometryError(
            f"{fp.zones[k].name}: {int((near[far] == k).sum())} vertices lie up to {float(d[far].max()):.3f} mm from its "
            f"faces, where its texture reaches {allowed[k]:.3f} mm; a relief landed off its zone: please report this"
        )
