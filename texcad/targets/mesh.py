"""Texturing a mesh (STL, 3MF, OBJ, a :class:`texcad.Mesh` or a ``trimesh.Trimesh``).

The job, for each texture *layer* ``(region, texture, options)``:

1. read and repair the mesh (merge duplicate vertices, drop degenerate and duplicate
   triangles, make the winding consistent, each shell outward and a cavity's wall
   inward: :func:`texcad.solid.repair_closed`); refuse it unless every body is
   closed (:func:`load_closed`) and its surface does not cross itself (tested on a
   second thread while the steps below run);
2. pick the region's faces (:class:`texcad.mapping.Region`; never the bed face by
   default, and with ``build_dir`` never a face that overhangs by itself) and refine
   only them, conforming (the mesh stays closed): with ``tolerance=0`` until no edge
   is longer than ``pitch`` mm (:func:`texcad.solid.subdivide.refine`, the *pitch
   grid*); with ``tolerance > 0`` (default 0.02 mm) each face only as finely as the
   texture needs to stay within ``tolerance`` mm of the pitch grid's points, measured
   there and reported as ``max_error`` (:mod:`texcad.solid.adaptive`, :func:`_adaptive`);
3. sample the texture at the region's vertices, ``h in [0, H]`` mm, through the
   projection (:class:`texcad.mapping.projection.Projection`) or as a solid 3-D
   texture;
4. fade it out towards the region's border with the M-I ramp: with ``s`` the
   distance (mm) of a vertex from the nearest vertex on the region's border and
   ``b`` the border width, ``R = H min(1, s/b)`` and the relief is ``min(h, R)``,
   so it is 0 on the border and never steeper than ``H/b`` there;
5. displace every region vertex along its angle-weighted normal by
   ``d = g (min(h, R) - c R)`` with ``c = 0`` raised (outward), ``c = 1`` engraved
   (inward: the texture's top is the original surface, so the outer envelope is
   kept) and ``c = 1/2`` centred, ``g in [0, 1]`` the depth gradient along an axis;
   where the part stands on an untextured bed face, no vertex moves past the bed's
   plane (:func:`keep_bed`: a fillet beside the bed face would otherwise carry crests
   under it);
6. limit: no displaced face may overhang for ``build_dir`` nor fold over
   (:func:`texcad.printability.limit_relief`);
7. check: the result is closed and oriented (every directed edge once, and its
   reverse once; tested beside the limiter, the topology not depending on the
   displacements) with as many bodies as the input, and finite, else GeometryError.

**Blocks.** Where the refinement would not fit in the memory available (the
machine's, or ``max_memory``), a one-layer job is made in blocks instead
(:mod:`texcad.targets.tiled_mesh`): the pitch grid (``tolerance=0``) refined,
displaced, limited for folds and for ``build_dir``'s overhangs, gated and streamed a
block at a time, the result a :class:`~texcad.targets.tiled_mesh.TiledMeshBlocks`
(``info["fuse"] == "tiled"``), several layers and zones too (their regions' faces
bisected layer by layer, each edge cut by its layers' finest pitch: other triangles
than the untiled layer-by-layer refinement where regions meet).

Sampling and measuring run on every core (:func:`texcad.util.split_rows`, the same
bytes as on one).

The result is a :class:`MeshTextured` (a :class:`texcad.Textured`): ``mesh`` is the
displaced mesh, ``base_mesh`` the part with every texture at its lowest (the surface
itself for raised textures, pushed in by ``H`` for engraved ones) and :data:`SKIN` mm
below that inside the regions, ``texture_mesh``
the texture alone (``mesh - base_mesh``, manifold3d), ``layer_meshes`` one texture
body per layer; a 3MF with ``separate_texture=True`` holds the base and every
texture as parts of one object (one object per build item of a 3MF part). A mesh
has no B-rep: ``.shape`` raises.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import GeometryError, InputError, ParameterError, ResourceError, TexcadWarning
from ..mapping.projection import PROJECTIONS, Projection, TileSampler, parse_axis, sample_heights
from ..mapping.region import Region, bed_faces, hold_above, mark_cavities, resolve_faces, resolve_paint, zone_layers
from ..printability import build_directions, check_critical_angle
from ..printability.relief import limit_relief
from ..sources.mask import mask_sampler
from ..solid import DEFAULT_TOLERANCE, Mesh, check_tolerance, closed_and_oriented, edge_report, repair_closed, self_intersections, shells
from ..solid.repair import SPECK, drop_specks
from ..solid.adaptive import build, carried, coarse_mesh, edge_counts, measure, pitch_samples
from ..solid.repair import repair_crossings
from ..solid.subdivide import coarsen, face_normals, offset_directions, refine, vertex_normals
from ..util import beside, colmax, colmin, one_blas_thread, rowany, split_rows, threads
from ..contracts import Fused, Placement, Relief, Stages
from ..options import Options
from ..report.gate import Expectation
from .base import Adapter

__all__ = ["MESH_SUFFIXES", "MODES", "MESH_OPTIONS", "Layer", "MeshAdapter", "is_mesh_target", "load_closed"]

MESH_SUFFIXES = (".stl", ".3mf", ".obj")
#: How far (mm) the base lies under the regions in ``base_mesh`` (texture bodies have
#: at least this thickness, so a slicer's multi-material split has no zero-thickness
#: slivers).
SKIN = 0.02
MODES = {"raised": 0.0, "engraved": 1.0, "centred": 0.5, "centered": 0.5}
#: Options of :func:`texture_mesh` (per call; every layer may override the layer ones).
LAYER_OPTIONS = ("height", "mode", "projection", "axis", "origin", "radius", "blend", "rotation", "local_radius",
                 "border", "gradient", "scale", "size", "pitch", "mask", "mask_size")
MESH_OPTIONS = LAYER_OPTIONS + ("build_dir", "critical_angle", "progress", "tolerance")


def is_mesh_target(target: Any) -> bool:
    """A :class:`texcad.Mesh`, a ``trimesh.Trimesh`` or a path ending in .stl/.3mf/.obj."""
    if isinstance(target, Mesh):
        return True
    if isinstance(target, (str, os.PathLike)):
        return Path(os.fspath(target)).suffix.lower() in MESH_SUFFIXES
    return type(target).__name__ == "Trimesh" and hasattr(target, "faces") and hasattr(target, "vertices")


def load_closed(target: Any, *, crossing: bool = True) -> tuple[np.ndarray, np.ndarray, int, dict]:
    """Read and repair a mesh; ``(vertices float64 (N, 3) mm, faces int64 (M, 3),
    bodies, info)``.

    Repairs (:func:`texcad.solid.repair_closed`): vertices merged where equal to
    1e-8 mm, degenerate and duplicate triangles dropped, winding made consistent
    and outward per body. ``crossing=False`` leaves the self-intersection test to
    the caller (:func:`assert_uncrossed`, e.g. run beside other work).

    Raises:
        InputError: unreadable, empty, not closed after repair (the message counts
            the open and non-manifold edges), one-sided, or its surface crosses
            itself (:func:`assert_uncrossed`).
    """
    from ..io import read_mesh

    name = _name(target)
    if isinstance(target, (str, os.PathLike)):
        m = read_mesh(target)
        v, f = m.vertices, m.faces
    elif isinstance(target, Mesh):
        v, f = target.vertices, target.faces
    else:
        v, f = np.asarray(target.vertices), np.asarray(target.faces)
    if len(f) == 0:
        raise InputError(f"{name} holds no triangles")
    n_in = len(f)
    notes: list = []
    v, f, _ = repair_closed(v, f, name=name, notes=notes)
    v, f, bodies, specks = drop_specks(v, f, name)  # bodies: outer shells (a cavity is none)
    if crossing:
        assert_uncrossed(v, f, name)
    info = {"input_triangles": int(n_in), "repaired_triangles": int(len(f)), "bodies": bodies}
    if notes:  # the surface changed: said (specks enclose nothing, so they are only noted)
        warnings.warn(TexcadWarning(f"{name} was repaired: {'; '.join(notes)}; check that the result is the part you meant"), stacklevel=3)
    if specks:
        notes.append(f"{specks} speck{'s' if specks > 1 else ''} dropped (shells enclosing under {SPECK:g} mm3)")
    if notes:
        info["repaired"] = "; ".join(notes)
    return v, f, bodies, info


#: Pitches the largest extent of a mesh part must span: a smaller part has no room
#: for a texture (and was most likely written in metres or inches).
MIN_PITCHES = 4


def require_size(v: np.ndarray, name: str, pitch: float) -> None:
    """InputError when the part ``v`` (``(N, 3)`` mm) spans under :data:`MIN_PITCHES`
    pitches along every axis: no texture fits on it (a mesh in metres, from a game
    engine or a scan, reads as mm; an OBJ has no unit)."""
    size = np.ptp(v, axis=0)
    if float(size.max()) < MIN_PITCHES * pitch:
        dims = " x ".join(f"{s:.3g}" for s in size)
        raise InputError(
            f"{name} is {dims} mm: under {MIN_PITCHES} pitches ({MIN_PITCHES * pitch:g} mm), no texture fits on it. "
            "If it was written in metres (or inches), scale it to mm first (x1000, or x25.4: e.g. trimesh's "
            "mesh.apply_scale); else use a smaller pitch"
        )


def _name(target: Any) -> str:
    return repr(os.fspath(target)) if isinstance(target, (str, os.PathLike)) else "the mesh"


def assert_uncrossed(vertices: np.ndarray, faces: np.ndarray, name: str = "the mesh", united: bool = False) -> None:
    """InputError if the surface ``(N, 3)`` mm / ``(M, 3)`` crosses itself
    (:func:`texcad.solid.self_intersections`: two overlapping bodies in one mesh, a
    fold), naming where; ``united``: its bodies were united already (``union=True``),
    so what is left is a fold inside one body, beyond a union."""
    v, f = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    cross = self_intersections(v, f)
    if not len(cross):
        return
    at = v[f[cross[0]]].reshape(-1, 3).mean(axis=0)
    where = f"({len(cross)} pairs of triangles, one near ({at[0]:.2f}, {at[1]:.2f}, {at[2]:.2f}) mm)"
    if united:
        raise InputError(
            f"{name} crosses itself inside one body {where}: union=True unites separate bodies but cannot undo a "
            "fold within one; repair the mesh in a mesh tool (e.g. a 'make solid' or remesh repair) and export it again"
        )
    raise InputError(
        f"{name} intersects itself: {len(cross)} pairs of its triangles cross (one near "
        f"({at[0]:.2f}, {at[1]:.2f}, {at[2]:.2f}) mm), so it encloses no well-defined solid; "
        "unite the overlapping bodies or undo the fold in the CAD program, or with manifold3d "
        "(Manifold.batch_boolean of the separate bodies) or trimesh.boolean.union, and export it again"
    )


@dataclass
class Layer:
    """One texture on a mesh: where, what, and how (lengths mm, angles degrees).

    Attributes:
        region: a :class:`texcad.mapping.Region` or its string form.
        texture: ``builtin:NAME[:k=v]``, an image path (needs ``size``) or a Heightmap
            (one tile).
        height: relief depth ``H``, mm.
        mode: ``raised``, ``engraved`` or ``centred``.
        projection: a :class:`Projection`, or its kind (``planar``, ``cylindrical``,
            ``spherical``, ``triplanar``, ``cubic``, ``solid``) with ``axis`` etc.
        border: fade width at the region's border, mm (M-I ramp).
        gradient: ``(start, end)`` points (mm): full depth at ``start``, fading
            linearly to 0 at ``end`` (along ``end - start``), or None.
        scale: factor on the texture's lengths.
        size: tile size ``(w, d)`` mm of an image texture.
        pitch: longest edge after subdivision, mm.
        mask: where to texture inside the region, in the projection: an image path, a
            Heightmap or a 2-D array, 0 (black) = none ... 1 (white) = full depth,
            stretched over ``mask_size`` ``(w, d)`` mm of texture coordinates centred
            on the projection's origin (0 outside it).
    """

    region: Any = "all"
    texture: Any = "builtin:stones"
    height: float = 1.0
    mode: str = "raised"
    projection: Any = "triplanar"
    border: float = 2.0
    gradient: Any = None
    scale: float = 1.0
    size: Any = None
    pitch: float = 0.5
    mask: Any = None
    mask_size: Any = None

    @classmethod
    def make(cls, region: Any, texture: Any, options: dict) -> "Layer":
        opts = dict(options)
        proj = opts.pop("projection", "triplanar")
        pkeys = ("axis", "origin", "radius", "blend", "rotation", "local_radius")
        pargs = {k: opts.pop(k) for k in pkeys if k in opts}
        if isinstance(proj, str):
            kind, _, ax = proj.partition(":")
            if ax:
                pargs.setdefault("axis", ax)
            proj = Projection(kind.strip().lower(), **pargs)
        elif not isinstance(proj, Projection):
            raise ParameterError(f"projection must be one of {', '.join(PROJECTIONS)} or a Projection, got {proj!r}")
        layer = cls(Region.parse(region), texture, projection=proj, **opts)
        if layer.mode not in MODES:
            raise ParameterError(f"mode {layer.mode!r}: use raised, engraved or centred")
        for k in ("height", "pitch", "scale"):
            v = getattr(layer, k)
            if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
                raise ParameterError(f"{k} must be a positive number (mm), got {v!r}")
        if not (np.isfinite(layer.border) and layer.border >= 0):
            raise ParameterError(f"border must be a width >= 0 in mm, got {layer.border!r}")
        return layer

    def heights(self, points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, dict]:
        """Texture heights ``h in [0, height]`` mm at ``points`` with unit ``normals``."""
        from ..sources.solid_textures import solid_texture
        from ..sources.textures import PREFIX, parse_texture_spec

        H = float(self.height)
        proj = self.projection
        if proj.kind == "solid":
            if not (isinstance(self.texture, str) and self.texture.startswith(PREFIX)):
                raise ParameterError("a solid projection needs a built-in texture with a 3-D form, e.g. builtin:stones")
            if self.mask is not None:
                raise ParameterError("a mask lies in a projection's texture coordinates; a solid texture has none: use a region instead")
            name, params = parse_texture_spec(self.texture)
            axis = parse_axis(proj.axis)
            origin = proj.origin if proj.origin is not None else 0.5 * (points.min(0) + points.max(0))
            f = solid_texture(name, scale=self.scale * params.pop("scale", 1.0), origin=origin, axis=axis, **params)
            return H * np.clip(f(points), 0.0, 1.0), {"projection": "solid"}
        sampler = self._sampler()
        samples, info = proj.samples(points, normals, sampler.tile)
        info["projection"] = proj.kind
        if self.mask is not None:
            if "_mask" not in self.__dict__:
                self.__dict__["_mask"] = mask_sampler(self.mask, self.mask_size)
            info["mask"] = sample_heights(samples, self.__dict__["_mask"])
        return np.clip(sample_heights(samples, sampler), 0.0, H), info

    def faces(self, v: np.ndarray, f: np.ndarray, fn: np.ndarray, dirs: Any, crit: float, tol: float, *, loose: bool,
              ids: "np.ndarray | None" = None) -> np.ndarray:
        """``(M,)`` bool: the faces ``f`` of ``v`` (mm) with unit normals ``fn`` in this
        layer's region (build directions ``dirs`` or None, critical angle ``crit``
        degrees, bed face tolerance ``tol`` mm; ``ids``: each face's input face)."""
        return _select(self, v, f, fn, dirs, crit, tol, loose=loose, ids=ids)

    def relief_rows(self, p: np.ndarray, unit: np.ndarray, dist: np.ndarray) -> tuple:
        """``(d, b, info, mask)`` at points ``p`` ``(P, 3)`` mm of the region with unit
        normals and distances (mm) to its border: displacement and lowest displacement
        (mm), point by point (module docstring, steps 3-5)."""
        return _relief_rows(self, p, unit, dist)

    def border_distance(self, border: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
        """``dist(points)``: distance (mm) to the nearest of the region's ``border``
        vertices ``(B, 3)``, inf beyond this layer's border width."""
        return _nearest(border, self.border)

    def with_projection(self, projection: Projection) -> "Layer":
        """This layer with another projection (the texture's sampler kept)."""
        out = replace(self, projection=projection)
        for key in ("_tile", "_mask"):  # the samplers made so far
            if key in self.__dict__:
                out.__dict__[key] = self.__dict__[key]
        return out

    def _sampler(self) -> TileSampler:
        """The texture's tile sampler, made once per layer."""
        from ..sources import Heightmap, builtin
        from ..sources.textures import PREFIX

        if "_tile" in self.__dict__:
            return self.__dict__["_tile"]
        H = float(self.height)
        if isinstance(self.texture, Heightmap):
            hm = self.texture if np.isclose(self.texture.max_height, H) else self.texture.scaled(H)
            sampler = TileSampler(hm, (self.scale, self.scale))
        elif isinstance(self.texture, str) and self.texture.startswith(PREFIX):
            sampler = TileSampler(builtin(self.texture, pitch=min(0.1, self.pitch / 2), height=H, scale=self.scale))
        else:
            if self.size is None:
                raise ParameterError(f"say how large one tile of the image {str(self.texture)!r} is: size=(w, d) in mm")
            hm = Heightmap.from_image(os.fspath(self.texture), size=self.size, height=H)
            sampler = TileSampler(hm, (self.scale, self.scale))
        self.__dict__["_tile"] = sampler
        return sampler


def _border_distance(v: np.ndarray, f: np.ndarray, sel: np.ndarray, upto: float = np.inf) -> np.ndarray:
    """Per vertex: distance (mm) to the nearest vertex shared by a region face and a
    face outside it (inf when the region has no border, or farther than ``upto``);
    NaN off the region."""
    return _distances(v, f, sel, _border_query(v, f, sel, upto))[0]


def _distances(v: np.ndarray, f: np.ndarray, sel: np.ndarray, query, skip: "np.ndarray | None" = None):
    """``(dist, inside)``: each vertex's distance by ``query`` where it belongs to a
    face of ``sel`` and not to ``skip`` (NaN elsewhere), and which vertices belong."""
    inside = np.zeros(len(v), dtype=bool)
    inside[f[sel].ravel()] = True
    todo = inside if skip is None else inside & ~skip
    dist = np.full(len(v), np.nan)
    dist[todo] = query(v[todo])
    return dist, inside


def _border_query(v: np.ndarray, f: np.ndarray, sel: np.ndarray, upto: float = np.inf) -> Callable[[np.ndarray], np.ndarray]:
    """``dist(points)``: distance (mm) of points to the nearest vertex shared by a
    region face and a face outside it (inf without a border, or farther than ``upto``)."""
    inside = np.zeros(len(v), dtype=bool)
    inside[f[sel].ravel()] = True
    outside = np.zeros(len(v), dtype=bool)
    outside[f[~sel].ravel()] = True
    return _nearest(v[np.flatnonzero(inside & outside)], upto)


def _nearest(border: np.ndarray, upto: float) -> Callable[[np.ndarray], np.ndarray]:
    """``dist(points)``: distance (mm) to the nearest of ``border`` ``(B, 3)`` (inf if
    there is none, or it is farther than ``upto``)."""
    from scipy.spatial import cKDTree

    if not len(border):
        return lambda p: np.full(len(p), np.inf)
    up = upto * (1 + 1e-9) if np.isfinite(upto) and upto > 0 else np.inf
    tree = cKDTree(border)
    lo, hi = colmin(border) - up, colmax(border) + up  # farther from this box: farther than up

    def dist(p: np.ndarray) -> np.ndarray:
        out = np.full(len(p), np.inf)
        near = np.ones(len(p), dtype=bool)
        for k in range(3):  # per axis
            near &= (p[:, k] >= lo[k]) & (p[:, k] <= hi[k])
        idx = np.flatnonzero(near)
        out[idx] = tree.query(p[idx], workers=threads(), distance_upper_bound=up)[0]
        return out

    return dist


def _gradient(points: np.ndarray, gradient: Any) -> np.ndarray:
    if gradient is None:
        return np.ones(len(points))
    g = np.asarray(gradient, dtype=np.float64).reshape(-1)
    if g.shape != (6,) or not np.all(np.isfinite(g)) or np.allclose(g[:3], g[3:]):
        raise ParameterError(f"gradient is (start, end): two different points (x, y, z) in mm, got {gradient!r}")
    a = g[3:] - g[:3]
    t = (points - g[:3]) @ a / (a @ a)
    return np.clip(1.0 - t, 0.0, 1.0)


def _select(layer: Layer, v, f, fn, dirs, crit, tol, loose, ids=None):
    """The layer's faces; ``ids``: each face's input face (what paint regions need)."""
    sel = layer.region.select(v, f, fn, build_dir=dirs[0] if dirs is not None else np.array([0.0, 0, 1]), tolerance=tol, loose=loose, ids=ids)
    if dirs is not None:  # a face that overhangs by itself cannot carry a support-free texture
        sel &= ~np.any(-(fn @ dirs.T) > np.cos(np.radians(min(89.9, crit + 1.0))), axis=1)
    return sel


def _check_regions(layers, masks) -> None:
    for k, m in enumerate(masks):  # per layer
        if not m.any():
            raise ParameterError(f"region {k + 1} ({layers[k].region}) holds no face of the mesh; choose another region")


def _refine_layers(layers, v, f, dirs, crit, tol):
    """Refine each layer's region to its pitch; returns v, f, per-layer face masks."""
    fn, _ = face_normals(v, f)
    ids = np.arange(len(f))
    for layer in layers:  # per layer
        sel = _select(layer, v, f, fn, dirs, crit, tol, loose=True, ids=ids)
        v, f, parent = refine(v, f, sel, layer.pitch)
        fn, ids = fn[parent], ids[parent]  # every piece lies in its parent's plane
    masks = [_select(layer, v, f, fn, dirs, crit, tol, loose=False, ids=ids) for layer in layers]
    return v, f, masks


def _relief_at(layer: Layer, p: np.ndarray, unit: np.ndarray, dist: np.ndarray):
    """Displacement ``d`` and lowest displacement ``b`` (mm) of one layer at points
    ``p`` ``(P, 3)`` of its region, with unit normals and distances to its border (mm);
    point by point, on every core (the projection fixed from all of ``p`` first)."""
    layer = layer.with_projection(layer.projection.fixed(p))
    if layer.projection.kind != "solid":
        layer.heights(p[:1], unit[:1])  # the samplers made once, before the threads
    parts = split_rows(lambda r: _relief_rows(layer, p[r], unit[r], dist[r]), len(p))
    if any(m is not None for *_, m in parts) and not any(np.any(m > 0) for *_, m in parts):
        raise ParameterError("the mask covers none of the region: check mask_size (mm) and the projection's origin")
    return np.concatenate([q[0] for q in parts]), np.concatenate([q[1] for q in parts]), parts[0][2]


def _relief_rows(layer: Layer, p: np.ndarray, unit: np.ndarray, dist: np.ndarray):
    """:func:`_relief_at` on some points, and the mask there (None without one)."""
    H = float(layer.height)
    R = H * (np.minimum(1.0, dist / layer.border) if layer.border > 0 else (dist > 0).astype(float))
    h, info = layer.heights(p, unit)
    m = info.pop("mask", None)
    if m is not None:
        R = R * m  # the mask scales the M-I ramp: 0 where it is black
    c = MODES[layer.mode]
    g = _gradient(p, layer.gradient)
    return g * (np.minimum(h, R) - c * R), -g * c * R, info, m


def _relief(layer: Layer, v, f, sel, normals, dist=None):
    """Per-vertex displacement ``d`` and lowest displacement ``b`` of one layer (mm)."""
    dist = _border_distance(v, f, sel, upto=layer.border) if dist is None else dist
    idx = np.flatnonzero(np.isfinite(dist) | np.isinf(dist))
    dd, bb, info = _relief_at(layer, v[idx], normals[idx], dist[idx])
    d = np.zeros(len(v))
    b = np.zeros(len(v))
    d[idx] = dd
    b[idx] = bb
    info["vertices"] = int(len(idx))
    inside = np.zeros(len(v), dtype=bool)
    inside[idx] = dist[idx] > 0  # the border itself stays where it is
    return d, b, info, inside


def _coarse_layers(layers, v, f, dirs, crit, tol):
    """Cut each layer's region into ladders and bisect it down to 3 pitches
    (:func:`coarsen`); the coarse mesh, its parent normals and each face's pitch (inf
    outside every region)."""
    fn, _ = face_normals(v, f)
    pitch = np.full(len(f), np.inf)
    ids = np.arange(len(f))
    for layer in layers:  # per layer
        sel = _select(layer, v, f, fn, dirs, crit, tol, loose=True, ids=ids)
        v, f, _, parent = coarsen(v, f, sel, layer.pitch, ladders=True)
        fn, pitch, ids = fn[parent], np.where(sel[parent], np.minimum(pitch[parent], layer.pitch), pitch[parent]), ids[parent]
    return v, f, fn, pitch, ids


def _frozen(layers, c, s, masks):
    """Each layer with its projection's origin and radius fixed from the pitch grid's
    points in its region (what tolerance 0 would use), so every later call agrees."""
    out = []
    for layer, m in zip(layers, masks):  # per layer
        vin = np.zeros(len(c.v), dtype=bool)
        vin[c.f[m].ravel()] = True
        pts = np.concatenate([c.v[vin], s["xyz"][_sample_member(c, s, m)]])
        out.append(layer.with_projection(layer.projection.fixed(pts)))
    return out


def _sample_member(c, s, mask):
    """Samples in a region given by coarse face ``mask``: inner points of its faces,
    edge points of its faces' edges."""
    e = s["edge"]
    return np.where(e >= 0, mask[c.ef[np.maximum(e, 0), 0]] | mask[c.ef[np.maximum(e, 0), 1]], mask[np.maximum(s["face"], 0)])


def _sample_relief(layers, c, s, masks, queries, skip):
    """Displacement (mm) at the samples, NaN where not measured (``skip`` faces)."""
    ds = np.zeros(len(s["xyz"]))
    for layer, m, q in zip(layers, masks, queries):  # per layer
        idx = np.flatnonzero(_sample_member(c, s, m))
        if len(idx):
            ds[idx] += _relief_at(layer, s["xyz"][idx], s["normal"][idx], q(s["xyz"][idx]))[0]
    return np.where(_sample_member(c, s, skip) | _sample_member(c, s, ~np.any(masks, axis=0)), np.nan, ds)


def _output_relief(layers, out, carry=None):
    """Per layer ``(d, b, info, inside)`` at the output's vertices, its strict face
    masks and each layer's border query. ``carry`` ``(ids, old ids, old parts)``:
    vertices an earlier round had at the same place (:func:`carried`) keep its values
    (layers with a mask are sampled anew: its check needs all points)."""
    parts, queries = [], []
    for k, (layer, m) in enumerate(zip(layers, out["masks"])):  # per layer
        q = _border_query(out["v"], out["f"], m, layer.border)
        keep = carry is not None and layer.mask is None
        skip = None
        if keep:
            skip = np.zeros(len(out["v"]), dtype=bool)
            skip[carry[0]] = True
        dist, inside = _distances(out["v"], out["f"], m, q, skip)
        d, b, info, ins = _relief(layer, out["v"], out["f"], m, out["normal"], dist=dist)
        if keep:
            new, old, (od, ob, _, oins) = carry[0], carry[1], carry[2][k]
            d[new], b[new], ins[new] = od[old], ob[old], oins[old]
            info["vertices"] = int(inside.sum())
        parts.append((d, b, info, ins))
        queries.append(q)
    return parts, queries


def _coarse_relief(layers, c, s, masks):
    """Without faces that straddle a region's edge: each layer's border query from the
    coarse mesh (the ends and pitch-grid points of its border edges: the vertices the
    output has there, as those edges keep their pitch counts) and the displacement
    at the coarse vertices (mm)."""
    queries, d = [], np.zeros(len(c.v))
    for layer, m in zip(layers, masks):  # per layer
        be = m[c.ef[:, 0]] != m[c.ef[:, 1]]
        on = (s["edge"] >= 0) & be[np.maximum(s["edge"], 0)]
        q = _nearest(np.concatenate([c.v[np.unique(c.edges[be])], s["xyz"][on]]), layer.border)
        d += _relief(layer, c.v, c.f, m, c.vn, dist=_distances(c.v, c.f, m, q)[0])[0]
        queries.append(q)
    return queries, d


def _first_levels(c, s, ds, d, tolerance):
    """Grid level per face from its level-1 error (the samples against its corners'
    linear interpolation): ``ceil(sqrt(e1 / tolerance))``, at most the pitch level."""
    e1 = np.zeros(len(c.f))
    ok = np.isfinite(ds)
    e = s["edge"]
    on = np.flatnonzero(ok & (e >= 0))
    ee, t = e[on], s["t"][on]
    a, b = c.edges[ee, 0], c.edges[ee, 1]
    err = np.abs(ds[on] - d[a] * (1 - t) - d[b] * t)
    np.maximum.at(e1, c.ef[ee].ravel(), np.repeat(err, 2))
    inn = np.flatnonzero(ok & (e < 0))
    fi = s["face"][inn]
    lev = c.level[fi]
    w = np.stack([lev - s["i"][inn] - s["j"][inn], s["i"][inn], s["j"][inn]], 1) / lev[:, None]
    err = np.abs(ds[inn] - (w * d[c.f[fi]]).sum(1))
    np.maximum.at(e1, fi, err)
    scale = np.linalg.norm(c.vdir, axis=1)[c.f].max(axis=1)
    return np.clip(np.ceil(np.sqrt(e1 * scale / tolerance) - 1e-9), 1, np.maximum(c.level, 1)).astype(np.int64)


def _output_masks(layers, out, masks, straddle, fn, dirs, crit, tol, ids=None):
    """Each layer's faces of the output: its coarse faces' pieces, and where a face
    straddles a box or sphere region's boundary, the pieces it selects itself."""
    par = out["parent"]
    res = masks[:, par]
    cut = np.flatnonzero(straddle[par])
    for k, layer in enumerate(layers):  # per layer
        if len(cut):
            res[k, cut] = _select(layer, out["v"], out["f"][cut], fn[par[cut]], dirs, crit, tol, loose=False,
                                  ids=None if ids is None else ids[par[cut]])
    return list(res)


def _adaptive(layers, v, f, dirs, crit, tol, tolerance, progress):
    """Error-driven adaptive subdivision (:mod:`texcad.solid.adaptive`): every face at
    the coarsest grid level whose displacement stays within ``tolerance`` mm of the
    pitch grid's samples. Returns the output (``v``, ``f``, ``parent``, ``normal``,
    ``dir``, ``masks``), the layers' reliefs and the measured largest error (mm)."""
    v, f, fn, pitch, ids = _coarse_layers(layers, v, f, dirs, crit, tol)
    progress(0.12, "pitch-grid samples")
    c = coarse_mesh(v, f, pitch)
    s = pitch_samples(c)
    masks = np.array([_select(layer, v, f, fn, dirs, crit, tol, loose=False, ids=ids) for layer in layers])
    straddle = ~np.all([layer.region.settled(v, f) for layer in layers], axis=0) & np.isfinite(pitch)
    forced = np.any(masks[:, c.ef[:, 0]] != masks[:, c.ef[:, 1]], axis=0) | straddle[c.ef].any(axis=1)
    layers = _frozen(layers, c, s, masks)
    levels = np.where(straddle, c.level, 1)
    ds, err, rounds = None, np.inf, 0
    if not straddle.any():  # the border and the corners from the coarse mesh: no first tessellation
        progress(0.13, "sampling the texture at the samples")
        queries, d = _coarse_relief(layers, c, s, masks)
        ds = _sample_relief(layers, c, s, masks, queries, straddle)
        levels = np.maximum(levels, _first_levels(c, s, ds, d, tolerance))
        progress(0.14, "adaptive tessellation and measurement")
    counts = per_face = out = None
    while True:  # per round: tessellate, measure, refine the faces still off (a few)
        counts, before, prev = edge_counts(c, levels, forced), counts, out
        out = build(c, counts)
        out["masks"] = _output_masks(layers, out, masks, straddle, fn, dirs, crit, tol, ids)
        carry = None if per_face is None else (*carried(c, before, counts, prev, out), parts)
        parts, queries = _output_relief(layers, out, carry)
        d = np.sum([p[0] for p in parts], axis=0)
        if ds is None:
            progress(0.13, "sampling the texture at the samples")
            ds = _sample_relief(layers, c, s, masks, queries, straddle)
            levels = np.maximum(levels, _first_levels(c, s, ds, d, tolerance))
            progress(0.14, "adaptive tessellation and measurement")
            continue
        per_face, err = _measure(c, counts, before, per_face, out, d, s, ds)
        rounds += 1
        bad = (per_face > tolerance) & (levels < c.level)
        progress(0.1 + 0.05 * min(rounds, 4), f"adaptive round {rounds}: {len(out['f'])} triangles, error {err:.4f} mm")
        if not bad.any():
            break
        levels[bad] = c.level[bad]
    if err > tolerance:
        raise GeometryError(f"the adaptive mesh is {err:.4f} mm off the texture where {tolerance:g} mm was asked; use tolerance=0 (a report of this would help)")
    out["rounds"] = rounds
    return out, parts, err


def _measure(c, counts, before, per_face, out, d, s, ds):
    """Per coarse face error and the largest (mm): after the first measurement only
    the faces whose edge counts changed are measured again (the border stays at the
    pitch grid, so elsewhere the triangles and their vertices' displacements are
    those measured before)."""
    if before is None or per_face is None:
        return measure(c, counts, out, d, s, ds)
    changed = np.any(counts[c.eid] != before[c.eid], axis=1)
    new, _ = measure(c, counts, out, d, s, ds, faces=changed)
    per_face = np.where(changed, new, per_face)
    return per_face, float(per_face.max()) if len(per_face) else 0.0


def _assert_closed(faces: np.ndarray, nv: int, bodies: int, what: str) -> None:
    """Closed and oriented (:func:`texcad.solid.closed_and_oriented`) with ``bodies``
    connected bodies (:func:`texcad.solid.shells`), else GeometryError: the topology
    of a displaced mesh, which does not depend on where its vertices move.
    (manifold3d's check of the same costs 14 s at 5 M triangles; the tests run it too.)"""
    if not closed_and_oriented(faces, nv):
        rep = edge_report(faces)
        raise GeometryError(f"the {what} is not a closed oriented solid ({rep['boundary']} open, {rep['nonmanifold']} "
                            f"non-manifold, {rep['misoriented']} misoriented edges); use a smaller height")
    n = shells(faces, nv)
    if n != bodies:
        raise GeometryError(f"the {what} has {n} bodies where the input had {bodies}")


def offset_volumes(v: np.ndarray, f: np.ndarray, offsets: list) -> list:
    """For each ``offset`` (N, 3) mm of ``offsets``: the volume (mm^3; + outward) swept
    when the vertices ``v`` of the closed, outward mesh ``(v, f)`` move by it, i.e. the
    moved mesh's volume minus the mesh's (the prisms between each triangle and its
    moved copy add up to that exactly). It carries the curvature terms of the integral
    ``sum (d + H d^2 + K d^3 / 3) dA`` that ``sum d dA`` leaves out (engraving a thin
    cylinder removes less than ``d A``). Only the triangles with a moved corner
    contribute (the others give the same term twice); the terms
    ``a . (b x c) / 6`` are taken about the box centre, coordinate by coordinate."""
    f = np.asarray(f, dtype=np.int64)
    v = np.asarray(v, dtype=np.float64)
    o = 0.5 * (colmin(v) + colmax(v)) if len(v) else np.zeros(3)
    moved = [np.any(np.asarray(off) != 0, axis=1) for off in offsets]
    live = np.flatnonzero(rowany(np.logical_or.reduce(moved)[f]) if moved else np.zeros(0, dtype=bool))
    t = np.ascontiguousarray(f[live].T)  # (3, F) corners of the faces that move in any offset

    def terms(x: np.ndarray) -> np.ndarray:  # a . (b x c) per face, x (3, N) positions
        ax, ay, az = (np.take(x[k], t[0]) for k in range(3))
        bx, by, bz = (np.take(x[k], t[1]) for k in range(3))
        cx, cy, cz = (np.take(x[k], t[2]) for k in range(3))
        return ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz) + az * (bx * cy - by * cx)

    x0 = np.ascontiguousarray((v - o).T)
    before = terms(x0)
    out = []
    for off, m in zip(offsets, moved):  # per offset
        keep = rowany(m[t.T])
        out.append(float((terms(x0 + np.asarray(off, dtype=np.float64).T)[keep] - before[keep]).sum() / 6.0))
    return out


def offset_volume(v: np.ndarray, f: np.ndarray, offset: np.ndarray) -> float:
    """:func:`offset_volumes` for one ``offset`` (N, 3) mm: mm^3, + outward."""
    return offset_volumes(v, f, [offset])[0]


@dataclass(frozen=True)
class MeshPlace:
    """A mesh placed: its repaired vertices ``(N, 3)`` float64 mm and faces ``(M, 3)``,
    the layers (region, texture, options each), its name for messages and what the
    repair did."""

    vertices: np.ndarray
    faces: np.ndarray
    layers: tuple
    name: str
    info: dict


@dataclass(frozen=True)
class MeshRelief:
    """The relief on a mesh: the refined mesh ``v`` (mm), ``f``, the offset directions
    ``normals``, the displacement ``d`` (mm) of each vertex after the limiter, the
    lowest displacement ``b`` (every texture at its lowest, :data:`SKIN` under the
    regions), each layer's ``(d, b, info, inside)`` and the region's face mask."""

    v: np.ndarray
    f: np.ndarray
    normals: np.ndarray
    d: np.ndarray
    b: np.ndarray
    parts: tuple
    region: np.ndarray


def _zone_name(region: Any, texture: Any) -> str:
    """A layer's name in the output (3MF part names): its region and texture."""
    r = region if isinstance(region, str) else getattr(region, "kind", "region")
    t = texture if isinstance(texture, str) else type(texture).__name__
    return f"{r} {t}"


def _layers(where: Any, texture: Any, o: Options) -> tuple:
    """The layers of a call: ``where`` a region (or its string) or a list of layers
    ``(region, texture, {options})``, each layer's options over the call's."""
    names = [n for n in LAYER_OPTIONS if getattr(o, n) is not None and (n in o.given or n in ("height", "mode", "pitch", "border", "scale"))]
    base = o.as_kwargs(names)
    raw = zone_layers("all" if where is None else where, texture)  # a region, a list of layers or a mapping {region: texture}
    return tuple(Layer.make(r, t, {**base, **dict(opts)}) for r, t, opts in raw), raw




def _vertex_areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """A third of the area (mm^2) of every face around each vertex (coordinate by
    coordinate: the edges, their cross product and its length)."""
    x, t = np.ascontiguousarray(np.asarray(v, dtype=np.float64).T), np.ascontiguousarray(np.asarray(f, dtype=np.int64).T)
    p = [[np.take(x[k], t[c]) for k in range(3)] for c in range(3)]  # corner, coordinate
    u = [p[1][k] - p[0][k] for k in range(3)]
    w = [p[2][k] - p[0][k] for k in range(3)]
    n = [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
    a3 = np.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) * (0.5 / 3.0)
    out = np.bincount(t[0], weights=a3, minlength=len(v))
    out += np.bincount(t[1], weights=a3, minlength=len(v))
    out += np.bincount(t[2], weights=a3, minlength=len(v))
    return out


class MeshAdapter(Adapter):
    """A closed mesh (STL, 3MF, OBJ, a :class:`texcad.Mesh`, a ``trimesh.Trimesh``):
    its region(s) refined, displaced along the offset directions and limited (module
    docstring). The displaced mesh is the fused mesh; a mesh has no B-rep."""

    kind = "mesh"
    label = "a mesh"
    result_kind = "mesh"
    options = frozenset(MESH_OPTIONS + ("union",)) - {"progress"}

    def accepts(self, target: Any, where: Any, options: Options) -> bool:
        return is_mesh_target(target)

    def place(self, target: Any, where: Any, texture: Any, options: Options) -> Placement:
        layers, raw = _layers(where, texture, options)
        # paint regions (texcad.mapping.region.resolve_paint): the project cut along its paint
        target, regions, painted = resolve_paint(target, [layer.region for layer in layers])
        layers = tuple(replace(layer, region=r) for layer, r in zip(layers, regions))
        options.report(0.0, "reading the mesh")
        v, f, bodies, info = load_closed(target, crossing=False)
        require_size(v, _name(target), options.pitch)
        if bodies > 1 or options.union:  # overlapping or touching bodies: refused, or united on request
            v, f, bodies = _separate_bodies(v, f, bodies, info, _name(target), options.union)
        if painted is None:  # small self-intersections resolved (issue 27); paint follows face numbers: not re-meshed
            v, f, bodies = repair_crossings(v, f, bodies, info, _name(target))
        regions = resolve_faces(v, f, [layer.region for layer in layers])  # direction words: flat patches of this mesh
        regions = mark_cavities(v, f, regions)  # a sealed void's wall is in no region
        layers = tuple(replace(layer, region=r) for layer, r in zip(layers, regions))
        if painted is not None or isinstance(where, dict):  # zones: their 3MF parts named by region and texture
            info["zones"] = [_zone_name(r, t) for r, t, _ in raw]
        if painted is not None:
            info["paint"] = {"kind": painted.kind, "project": painted.project.path, "dialect": painted.project.dialect,
                             "items": painted.items,
                             "extruders": [r.state if r.kind == "paint" and r.paint == "color" else None for r in regions]}
        if isinstance(target, (str, os.PathLike)) and os.fspath(target).lower().endswith(".3mf") and painted is None:
            info["source_3mf"] = os.fspath(target)  # written back one object per build item (texcad.pipeline.items)
        base = Mesh(v.astype(np.float32), f.astype(np.uint32))
        return Placement("mesh", base, bodies, None, data=MeshPlace(v, f, layers, _name(target), info))

    def relief(self, placement: Placement, texture: Any, options: Options) -> Relief:
        mp: MeshPlace = placement.data
        progress = options.report
        tiled = _tiled(mp, options)
        if tiled is not None:
            return tiled
        # numpy's BLAS on one thread: texcad runs its own two here (the self-intersection test beside, the
        # samplers and kd queries split by rows), and BLAS threads would only spin against them (its
        # products split by rows: the same values on one thread; the same bytes on bench_mesh)
        with beside(assert_uncrossed, mp.vertices, mp.faces, mp.name, options.union) as crossed, one_blas_thread():
            try:
                r, d, limit, max_error = _displace(list(mp.layers), mp.vertices, mp.faces, mp.info, options.directions,
                                                   options.critical_angle, options.tolerance, progress)
            except Exception:
                crossed.result()  # a crossed input is the cause of what failed: say that first
                raise
            crossed.result()
        area = _vertex_areas(r.v, r.f)
        vol, nominal = offset_volumes(r.v, r.f, [r.normals * r.d[:, None], r.normals * d[:, None]])
        used = np.zeros(len(r.v), dtype=bool)
        used[r.f[r.region].ravel()] = True
        region_area = float(area[used].sum())
        slack = 0.05 * float((np.abs(r.d) * area).sum()) + 2.0 * options.tolerance * region_area + 1e-6
        stretch = np.linalg.norm(r.normals, axis=1)  # offset directions are mitred at edges: |n| >= 1
        reach = float((stretch * np.maximum(np.abs(d), np.abs(r.d))).max(initial=0.0)) + options.tolerance + 0.01
        return Relief(heightmap=None, limits=limit, volume=vol, volume_slack=slack, nominal_volume=nominal,
                      reach=reach, max_error=max_error, data=r)

    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        if not isinstance(relief.data, MeshRelief):  # made in blocks (texcad.targets.tiled_mesh)
            from .tiled import cluster_client
            from .tiled_mesh import TiledMeshBlocks

            plan = relief.data
            told = lambda f, m: options.report(0.92 + 0.07 * f, f"checking the result (texcad's gate): {m}")  # noqa: E731
            info = dict(placement.data.info, fuse="tiled", blocks=len(plan.blocks), coarse_triangles=int(len(plan.f)),
                        coarse_pitches=plan.factor,
                        tolerance=0.0, max_error=0.0, kind="mesh", face="mesh", pitch=plan.pitch,
                        no_brep="a mesh has no B-rep: it is textured as a mesh")
            return Fused(TiledMeshBlocks(plan, progress=told, client=cluster_client(options.client)), placement.base, info, None)
        r: MeshRelief = relief.data
        options.report(0.85, "the displaced mesh")
        out = Mesh((r.v + r.normals * r.d[:, None]).astype(np.float32), r.f.astype(np.uint32),
                   {"texture": np.flatnonzero(rowany(r.d[r.f] != 0))})
        if not np.all(np.isfinite(out.vertices)):
            raise GeometryError("the textured mesh has vertices that are not finite numbers; check the texture and the height")
        base = Mesh((r.v + r.normals * r.b[:, None]).astype(np.float32), r.f.astype(np.uint32))
        return Fused(out, base, dict(placement.data.info), None)

    def expectation(self, placement: Placement, relief: Relief, fused: Fused) -> Expectation:
        ex = super().expectation(placement, relief, fused)
        if not isinstance(relief.data, MeshRelief):  # made in blocks: gated block by block
            return ex
        r: MeshRelief = relief.data
        return Expectation(**{**ex.__dict__, "selected": (r.v, r.f[r.region])})

    def texture_mesh(self, stages: Stages) -> Mesh:
        _whole(stages)
        return _difference(stages.fused.mesh, stages.fused.base_mesh)

    def layer_meshes(self, stages: Stages) -> list:
        _whole(stages)
        r: MeshRelief = stages.relief.data
        res = []
        for *_, inside in r.parts:  # per layer: its own relief on the base
            mk = Mesh((r.v + r.normals * np.where(inside, r.d, r.b)[:, None]).astype(np.float32), r.f.astype(np.uint32))
            res.append(_difference(mk, stages.fused.base_mesh))
        return res


def _whole(stages: Stages) -> None:
    """GeometryError for a mesh made in blocks: it keeps no texture body."""
    if not isinstance(stages.relief.data, MeshRelief):
        raise GeometryError("a mesh textured in blocks keeps no separate texture body (a boolean of the whole mesh, which "
                            "does not fit in memory); write the part's STL or 3MF, or use a coarser pitch")


def refined_count(v: np.ndarray, f: np.ndarray, layers: tuple, dirs: Any, crit: float, tol: float) -> int:
    """About how many triangles refining every layer's region of ``(v, f)`` to its
    pitch makes (:func:`texcad.solid.subdivide.refined_triangles`)."""
    from ..solid.subdivide import refined_triangles

    fn, _ = face_normals(v, f)
    return len(f) + sum(refined_triangles(v, f, _select(layer, v, f, fn, dirs, crit, tol, loose=True), layer.pitch) - len(f)
                        for layer in layers)


def untiled_bytes(triangles: int) -> float:
    """Peak bytes of the untiled mesh job for ``triangles`` refined triangles (the
    estimate :func:`texcad.solid.subdivide.coarsen` refuses by)."""
    from ..solid.subdivide import TRIANGLE_BYTES

    return float(triangles) * TRIANGLE_BYTES


def _sampler_fits(layer: Layer) -> None:
    """Make the layer's texture tile; where it does not fit in memory, ResourceError
    naming the mesh pitch that makes it fit (a built-in tile is sampled at half the
    mesh's pitch below 0.2 mm, so its guard's pitch is doubled)."""
    import re

    try:
        layer._sampler()
    except ResourceError as exc:
        m = re.search(r"use a pitch of at least ([0-9.e+-]+) mm", str(exc))
        if m is None or float(layer.pitch) >= 0.2:
            raise
        tp = min(0.1, float(layer.pitch) / 2)
        raise ResourceError(f"the texture's tile sampled at {tp:.3g} mm (half the mesh's pitch of {float(layer.pitch):.3g} mm) "
                            f"does not fit in the memory available; use a pitch of at least {2 * float(m.group(1)):.3g} mm") from exc


def _tiled(mp: MeshPlace, options: Options) -> "Relief | None":
    """The relief in blocks (:mod:`texcad.targets.tiled_mesh`) where the untiled
    refinement would not fit in the memory available, else None."""
    from ..util import available_memory
    from ..util import finest_pitch
    from .tiled_mesh import mesh_plan

    v, f, layers = mp.vertices, mp.faces, mp.layers
    tol = 0.01 + 1e-6 * float(np.ptp(v, axis=0).max())
    count = refined_count(v, f, layers, options.directions, options.critical_angle, tol)
    need = untiled_bytes(count)
    if need <= available_memory():
        return None
    what, pitch = f"refining {mp.name} to about {count} triangles", min(float(layer.pitch) for layer in layers)
    options.report(0.05, f"{what}: made in blocks")
    for layer in layers:  # the textures' tiles first, before the coarse mesh
        if layer.projection.kind != "solid":
            _sampler_fits(layer)
    assert_uncrossed(v, f, mp.name, options.union)
    plan = mesh_plan(layers, v, f, tol, count, finest_pitch(pitch, need), options.report, options.directions,
                     options.critical_angle)
    mp.info.update(triangles=plan.triangles, kind="mesh", face="mesh", tolerance=0.0, max_error=0.0)
    return Relief(heightmap=None, limits=None, volume=float("nan"), volume_slack=float("nan"), nominal_volume=None,
                  reach=plan.reach, max_error=0.0, data=plan)


def _displace(layers, v, f, info, dirs, crit, tolerance, progress):
    """Subdivide, sample, displace and limit (module docstring, steps 2-6):
    ``(MeshRelief, displacement before the limiter, limiter report, max error)``."""
    tol = 0.01 + 1e-6 * float(np.ptp(v, axis=0).max())
    progress(0.1, "subdividing the region")
    if tolerance > 0:
        out, parts, max_error = _adaptive(layers, v, f, dirs, crit, tol, tolerance, progress)
        info["adaptive_rounds"] = out["rounds"]
        v, f, masks, normals = out["v"], out["f"], out["masks"], out["dir"]
        _check_regions(layers, masks)
    else:
        v, f, masks = _refine_layers(layers, v, f, dirs, crit, tol)
        _check_regions(layers, masks)
        progress(0.3, "normals")
        unit = vertex_normals(v, f)
        normals = offset_directions(v, f, unit)  # keeps sharp edges sharp: no fold
        progress(0.4, "sampling the texture")
        parts = [_relief(layer, v, f, m, unit) for layer, m in zip(layers, masks)]
        max_error = 0.0  # the pitch grid itself: the samples are its vertices
    d = np.sum([p[0] for p in parts], axis=0)
    b = np.sum([p[1] for p in parts], axis=0)
    d, info["bed_held"] = keep_bed(v, f, normals, d, dirs, masks, tol)
    progress(0.6, "limiting overhangs")
    d2, limit = limit_relief(v, f, normals, d, build_dir=dirs, critical_angle=crit)
    if limit.folded_faces:
        warnings.warn(f"the texture was lowered where {limit.folded_faces} faces would fold over (too deep for the curvature there)", TexcadWarning, stacklevel=3)
    # the base lies SKIN mm under every region, so no texture body has parts of zero thickness
    b = b - SKIN * np.any([p[3] for p in parts], axis=0)
    info.update(triangles=int(len(f)), layers=[p[2] for p in parts], kind="mesh", face="mesh", tolerance=tolerance, max_error=max_error,
                no_brep="a mesh has no B-rep: it is textured as a mesh", region_faces=[int(m.sum()) for m in masks])
    region = np.any(masks, axis=0)
    return MeshRelief(v, f, normals, d2, b, tuple(parts), region), d, limit, max_error


def keep_bed(v: np.ndarray, f: np.ndarray, normals: np.ndarray, d: np.ndarray, dirs: Any, masks: list,
             tol: float) -> tuple[np.ndarray, int]:
    """``(d, held)``: the displacements ``d`` (mm, along ``normals``) capped so that no
    vertex of ``(v, f)`` (mm) moves past the plane of the part's lowest point along the
    build direction (``dirs[0]``, else +z), and how many vertices were held there.

    Only where the part stands on a bed face (:func:`texcad.mapping.bed_faces`,
    ``tol`` mm) that no layer's mask (``masks``, per face) textures: a raised texture on
    a fillet or chamfer beside that face would otherwise reach under it, and the part
    would stand on the texture's crests instead (a plate's rounded bottom edge, 0.2 mm
    under its bed face at 0.5 mm of relief). Where the bed face is textured, ``d`` is
    returned as it is.
    """
    up = np.asarray(dirs[0] if dirs is not None else (0.0, 0.0, 1.0), dtype=np.float64)
    up = up / np.linalg.norm(up)
    bed = bed_faces(v, f, face_normals(v, f)[0], up, tol)
    if not bed.any() or np.any([m[bed].any() for m in masks]):
        return d, 0
    held = hold_above(v, normals, d, up, float((v @ up).min()))
    return held, int(np.count_nonzero(held != d))


def _separate_bodies(v: np.ndarray, f: np.ndarray, bodies: int, info: dict, name: str, union: bool):
    """``(v, f, bodies)`` whose bodies neither overlap nor touch
    (:func:`texcad.solid.overlap.overlapping_bodies`): as they are, or united with
    manifold3d when ``union`` (``info["repaired"]`` says what was done).

    Raises:
        InputError: bodies overlap or touch and ``union`` is False.
    """
    from ..solid.overlap import describe_overlaps, overlapping_bodies, split_bodies, union_bodies

    split = split_bodies(v, f)
    found = overlapping_bodies(v, f, split=split)
    if not found:  # a crossing inside one body is left to the relief stage's test (assert_uncrossed)
        return v, f, bodies
    if not union:
        raise InputError(
            f"{name} intersects itself: its bodies overlap or touch ({describe_overlaps(found, split)}), so it encloses no "
            "well-defined solid. Unite them first: texture(..., union=True) or texcad texture --union (manifold3d), "
            "or separate or unite them in the CAD program and export again"
        )
    uv, uf, note = union_bodies(v, f, split=split)
    v, f, bodies = repair_closed(uv, uf, name=name)
    note = f"{info['repaired']}; {note}" if info.get("repaired") else note
    info.update(bodies=bodies, repaired=note, repaired_triangles=int(len(f)))
    return v, f, bodies


def _difference(a: Mesh, b: Mesh) -> Mesh:
    """``a - b`` (manifold3d), without the zero-volume shells (< 1e-6 mm^3) that
    coincident surfaces can leave."""
    import manifold3d as m3d

    from ..solid import from_manifold, to_manifold

    pieces = [p for p in (to_manifold(a) - to_manifold(b)).decompose() if p.volume() > 1e-6]  # per shell
    return from_manifold(m3d.Manifold.compose(pieces) if pieces else m3d.Manifold())
