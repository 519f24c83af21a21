"""The numerics of the any-faces adapter (:mod:`texcad.targets.faces`), one *patch* at
a time: a patch is a set of selected faces joined by smooth (tangent) edges.

    PartMesh, face ids --smooth_patches--> patches
    patch --patch_param--> PatchParam (texture coordinates, mm)
          --patch_grid--> PatchGrid (texture grid on the surface, heights, M-I ramp, fade)
          --patch_surface--> PatchSurface (signed offset of the textured side, mm)
          --limit_patch--> PatchSurface, overhang report   (with build_dir)
          --patch_bodies--> PatchBodies (slab to add, cutters to subtract)
    = patch_relief --> PatchRelief

Every stage takes and returns frozen dataclasses (arrays float64 mm unless said
otherwise; grids ``(R, C)`` with the row index along texture y and the column index
along texture x). The method (module docstring of :mod:`texcad.targets.faces`):

* **Parameterization in mm.** A planar face: its own frame (exact). One curved face:
  its ``(u, v)`` corrected by its metric, ``x = X(v)``, ``y = Y(u)`` with ``X``, ``Y``
  mean arc lengths (:func:`texcad.mapping.separable_coordinates`); on a closed face a
  whole number of tiles fits around. Several faces: a closed band around an axis by
  the cross-section's arc length (:func:`texcad.mapping.band_coordinates`), any other
  patch by a least-squares conformal flattening (:func:`texcad.mapping.lscm_coordinates`).
* **Grid and envelope.** The texture grid at the texture's pitch
  (:func:`texcad.mapping.lay_grid`); heights fade (``smoothstep``) where the local
  scale leaves ``[FADE_FULL, 1/FADE_FULL]``; the M-I ramp
  ``h <= tan(edge_angle) * max(0, d - 3.75 diag)`` at the patch outline (paper,
  section 2.1.3); ``h <= 0.9 / kappa`` on concave sides, depth ``<= 0.9 / kappa`` on
  convex ones.
* **Limiter.** Heights lowered until no displaced facet overhangs where the face
  does not (vectorized over the grid, iterated).
* **Bodies.** A closed slab (raised, centred) and cutters (engraved, centred), their
  textured side lean within ``tolerance`` (:func:`texcad.solid.lean_grid`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from typing import Any, Optional

import numpy as np

from ..brep import TESSELLATION, FaceMesh, PartMesh, as_array
from ..brep.targets import LEAN_SMOOTH
from ..errors import GeometryError
from ..printability.rule import support_free_angle
from ..solid import Mesh, edge_report
from ..sources import Heightmap
from ..util import smoothstep
from .cad import face_numbers
from .extrusion import require_relief
from .mesh import _gradient

__all__ = [
    "lean_heights", "lean_offsets", "FADE_FULL", "FADE_ZERO", "FLOOR_CURVED", "SMOOTH_ANGLE", "PatchOptions",
    "PatchParam", "PatchGrid",
    "PatchSurface", "PatchBodies", "PatchRelief", "smooth_patches", "patch_param", "patch_grid", "patch_surface",
    "limit_patch", "patch_bodies", "patch_relief", "patch_volume", "patch_displaced", "fused_offset",
]

#: Local texture scale (either direction, or its inverse) down to which the full height is kept.
FADE_FULL = 0.55
#: ... and at which the height has faded to 0 (smoothstep between).
FADE_ZERO = 0.3
#: mm: the relief stays at least this far above a face inside its ramp (no tangential contact).
FLOOR_CURVED = 0.01
#: Tangent edges: faces whose normals differ by less than this across their common
#: edge (degrees) are one patch.
SMOOTH_ANGLE = 12.0
#: mm: how far outside the face an engraving's cutter starts (beyond the tessellation's chord error).
CUT_ABOVE = 0.05
#: mm: near a crease between the patch's faces the cutter's top clears both faces'
#: tangent planes there by at least this (:func:`_cut_above`).
CUT_OVER_CREASE = 0.5 * CUT_ABOVE
#: mm: the lean mesh keeps the face itself (chord error) within this, so the relief
#: never dips under the part's own tessellation where it lies flat on the face.
BASE_TOLERANCE = 0.005
#: Largest share of the grid's triangles a lean relief may keep (else the grid is used):
#: above it the union gains little over the cost of the triangulation.
LEAN_FRACTION = 0.8
#: mm: the slab's bottom (inside the part, never seen) is triangulated within this
#: (by the refinement's own estimate; it lies ``depth`` mm inside the part).
BOTTOM_TOLERANCE = 0.05


# ------------------------------------------------------------------------------------------
# The contracts between the patch stages
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PatchOptions:
    """What a patch is made with (from :class:`texcad.options.Options`, validated).

    Attributes:
        height: largest texture height, mm.
        pitch: texture pixel, mm.
        depth: how far the slab reaches into the body, mm.
        edge_angle: the M-I ramp's angle at the outline, degrees.
        rotation: the texture's turn on planar faces, degrees.
        build_dir: ``(K, 3)`` float64 unit build directions, or None (no limiter).
        critical_angle: steepest printable overhang, degrees.
        tolerance: the lean relief's largest error, mm (0: the grid itself).
        mode: ``"raised"``, ``"engraved"`` or ``"centred"``.
        share: the share ``c`` of the height that goes into the part (0, 1, 1/2).
        gradient: two points (mm) of a height gradient, or None.
        jitter: mm: a nudge after a union that pinched (0 the first time).
        mask: a grey-level mask scaling the height (0 none, 1 full; an array, a
            Heightmap or an image path: :func:`texcad.sources.mask.mask_sampler`) over
            the patch's texture coordinates, or None.
        mask_size: ``(w, d)`` mm of texture coordinates the mask covers, centred on
            the patch's (default: the patch's whole extent).
    """

    height: float
    pitch: float
    depth: float
    edge_angle: float
    rotation: float
    build_dir: Optional[np.ndarray]
    critical_angle: float
    tolerance: float
    mode: str
    share: float
    gradient: Any = None
    jitter: float = 0.0
    mask: Any = None
    mask_size: Optional[tuple] = None


@dataclass(frozen=True)
class PatchParam:
    """A parameterized patch.

    Attributes:
        V: ``(N, 3)`` float64 vertices, mm.
        F: ``(M, 3)`` int triangles.
        XY: ``(N, 2)`` float64 texture coordinates, mm.
        period_y: the period around (mm) of a closed patch, or None.
        method: how the coordinates were made (for people).
        tables: one curved face: ``(u table, v table, closed around u)`` (arc-length
            tables of :func:`texcad.mapping.metric_tables`); None otherwise.
    """

    V: np.ndarray
    F: np.ndarray
    XY: np.ndarray
    period_y: Optional[float]
    method: str
    tables: Optional[tuple] = None


@dataclass(frozen=True)
class PatchGrid:
    """The texture grid laid on a patch and the envelope its heights may use
    (``(R, C)`` arrays over the grid points).

    Attributes:
        par: the patch's parameterization.
        grid: the :class:`texcad.mapping.FaceGrid` (points, normals, valid, wrap_y).
        H: texture heights, mm.
        px, py: grid pitch in texture x and y, mm; diag: the cell diagonal, mm.
        d: distance to the nearest point off the patch, texture mm.
        fade: the height factor where the texture scale leaves ``[FADE_FULL, 1/FADE_FULL]``.
        ramp: the M-I ramp's bound on the height, mm.
        concave, convex: the largest concave / convex normal curvature, 1/mm.
        d_keep, d_floor: mm: points nearer the outline than ``d_keep`` are not
            textured; the ramp starts at ``d_floor``.
        keep: bool, the point carries relief.
        gain: the depth gradient's factor (1 without a gradient).
        cells: bool ``(R-1, C-1)`` (``(R, C-1)`` around a seam): cells meshed.
    """

    par: PatchParam
    grid: Any
    H: np.ndarray
    px: float
    py: float
    diag: float
    d: np.ndarray
    fade: np.ndarray
    ramp: np.ndarray
    concave: np.ndarray
    convex: np.ndarray
    d_keep: float
    d_floor: float
    keep: np.ndarray
    gain: np.ndarray
    cells: np.ndarray


@dataclass(frozen=True)
class PatchSurface:
    """The textured side as a signed offset of the face (``(R, C)`` arrays, mm along
    the normal; see :func:`patch_surface`).

    Attributes:
        surface: the offset ``s``.
        floor: the lowest offset the limiter may bring ``s`` to.
        c: the mode's share into the part (0 raised, 1 engraved, 1/2 centred).
        depth: the slab's depth under the face (capped by curvature).
        limited: bool, where the curvature limit lowered the height.
        floor_c: the floor above (raised) or below (engraved) the face, mm.
        sink: how far the outline band dips into the body, mm.
        band: bool, the outline band (nearer than ``d_floor``).
        env: engraved / centred: the envelope (the texture's top), else None.
    """

    surface: np.ndarray
    floor: np.ndarray
    c: float
    depth: Any
    limited: np.ndarray
    floor_c: float
    sink: Any
    band: np.ndarray
    env: Optional[np.ndarray] = None


@dataclass(frozen=True)
class PatchBodies:
    """The closed meshes that put a patch's texture on the part (mm): ``slab`` to add
    (raised, centred), ``cutter`` to subtract (engraved, centred), ``low_cutter``
    (the texture at its lowest: the base the texture mesh is measured against);
    ``error``: the lean side's measured largest error, mm; ``top_triangles``: the
    textured side's triangle count; ``lean_top``: ``(R, C)`` mm, the raised slab's
    lean top at every grid point, as an offset along the normal (None: the slab's
    top is the grid itself, or the texture is not raised; :func:`lean_offsets`)."""

    slab: Optional[Mesh]
    cutter: Optional[Mesh]
    low_cutter: Optional[Mesh]
    error: float
    top_triangles: int
    lean_top: Optional[np.ndarray] = None


@dataclass(frozen=True)
class PatchRelief:
    """One patch textured (what the adapter's fuse, texture mesh and B-rep read).

    Attributes:
        faces: the patch's face indices (explorer order of the part).
        bodies: its :class:`PatchBodies`.
        info: what was done, plain values (parameterization, grid, distortion ...).
        distortion: the measured :class:`texcad.mapping.Distortion`.
        heightmap: the texture as applied on the grid (mm, >= 0).
        grid: the :class:`texcad.mapping.FaceGrid`.
        limited: the curvature limit lowered the height somewhere.
        h_top: ``(R, C)`` the textured side's signed offset, mm.
        signed: engraved or centred (``h_top`` may be negative).
        cells: bool, the grid's meshed cells.
        tables: one curved face: its arc-length tables (B-rep), else None.
        face: the OCP face of a one-face patch, else None.
        limit: the overhang limiter's report (dict of figures) or None.
        integral: ``(volume, slack, nominal)`` mm^3, the texture's own integral
            (:func:`patch_volume`; nominal None for a centred texture).
        fused_top: ``(R, C)`` the offset (mm) of the fused mesh's surface over the
            cells (:func:`fused_offset`: what the B-rep of faces flattened together
            follows), or None.
        displaced: ``(volume mm^3, area mm^2, slack mm^3, nominal mm^3)``, what the
            texture displaces above and below the face alike (:func:`patch_displaced`;
            the gate's check of a centred texture).
    """

    faces: tuple
    bodies: PatchBodies
    info: dict
    distortion: Any
    heightmap: Heightmap
    grid: Any
    limited: bool
    h_top: np.ndarray
    signed: bool
    cells: np.ndarray
    tables: Optional[tuple]
    face: Any
    limit: Optional[dict] = None
    integral: tuple = (0.0, 0.0, None)
    fused_top: Optional[np.ndarray] = None
    displaced: tuple = (0.0, 0.0, 0.0, None)

    @property
    def max_error(self) -> float:
        """The lean side's measured largest error, mm (0: the grid itself)."""
        return self.bodies.error

    @property
    def brep_top(self) -> np.ndarray:
        """``(R, C)`` mm: the heights a one-face B-rep is made of: where the slab's
        textured side is lean (:attr:`PatchBodies.lean_top`), ``h_top`` plus the lean
        top's offset from it averaged over :data:`LEAN_SMOOTH` x :data:`LEAN_SMOOTH`
        points (the B-rep then encloses the mesh's volume, not the grid's, which the
        mesh lies within its tolerance of: a stones torus at 0.125 mm was +0.09 % off
        its lean mesh, +0.10 % after a drill; and keeps the grid's shape, whose STEP
        tiles fit as few poles), else ``h_top``."""
        if self.bodies.lean_top is None:
            return self.h_top
        from scipy.ndimage import uniform_filter

        mode = ("wrap", "nearest") if self.grid.wrap_y else "nearest"
        mean = uniform_filter(np.asarray(self.bodies.lean_top - self.h_top, np.float64), LEAN_SMOOTH, mode=mode)
        return self.h_top + mean


# ------------------------------------------------------------------------------------------
# Patches and their parameterization
# ------------------------------------------------------------------------------------------
def smooth_patches(pm: PartMesh, idx: list) -> list:
    """Group the selected faces ``idx`` into patches joined by smooth (tangent)
    edges (normals within :data:`SMOOTH_ANGLE` degrees across the edge)."""
    sel = set(idx)
    m = pm.mesh
    v = m.vertices.astype(np.float64)
    f = m.faces.astype(np.int64)
    fn = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    fn /= np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-18)
    ed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    tri = np.tile(np.arange(len(f)), 3)
    key = np.minimum(ed[:, 0], ed[:, 1]) * len(v) + np.maximum(ed[:, 0], ed[:, 1])
    order = np.argsort(key, kind="stable")
    ks, ts = key[order], tri[order]
    same = ks[1:] == ks[:-1]
    t1, t2 = ts[:-1][same], ts[1:][same]
    f1, f2 = pm.face_of_tri[t1], pm.face_of_tri[t2]
    cross = (f1 != f2) & np.isin(f1, idx) & np.isin(f2, idx)
    smooth = (fn[t1] * fn[t2]).sum(axis=1) > np.cos(np.radians(SMOOTH_ANGLE))
    parent = {i: i for i in sel}

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    for a, b in set(zip(f1[cross & smooth].tolist(), f2[cross & smooth].tolist())):  # per pair of faces
        parent[root(a)] = root(b)
    groups: dict = {}
    for i in idx:
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


def _plane_xy(fm: FaceMesh, rotation: float) -> np.ndarray:
    from ..brep import plane_frame

    p0, ex, ey, n = plane_frame(fm.face, rotation)
    q = fm.points - p0
    return np.stack([q @ ex, q @ ey], axis=1)


def _surface_tables(fm: FaceMesh, n: int = 48):
    """Metric tables of one face (:func:`texcad.mapping.metric_tables`) from an
    ``n x n`` OCCT sampling of its surface over the face's uv bounds."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface

    from ..mapping import metric_tables

    ad = BRepAdaptor_Surface(fm.face)
    u0, u1 = float(fm.uv[:, 0].min()), float(fm.uv[:, 0].max())
    v0, v1 = float(fm.uv[:, 1].min()), float(fm.uv[:, 1].max())
    us, vs = np.linspace(u0, u1, n), np.linspace(v0, v1, n)
    pts = np.array([[as_array(ad.Value(float(u), float(v))) for v in vs] for u in us])  # n^2 evaluations
    # Closed around u where the face's first and last u lines coincide (a full
    # cylinder, a closed B-spline): a periodic surface's face that spans less than
    # its period (a fillet, a quarter cylinder) is open, and its rows must not wrap.
    scale = max(1.0, float(np.ptp(pts.reshape(-1, 3), axis=0).max()))
    closed_u = bool(np.abs(pts[0] - pts[-1]).max() < 1e-6 * scale)
    (ut, Y), (vt, X) = metric_tables(pts, us, vs)
    return (ut, Y), (vt, X), closed_u


def _loop_turns(V2: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Turns of each boundary loop of a mesh about its own vertices' mean, seen in the
    2-D coordinates ``V2``: the angle swept along the loop's directed edges (as the
    faces run them; no ordering needed), one figure per loop (connected components
    of the boundary edges, scipy)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    e = F[:, [[0, 1], [1, 2], [2, 0]]].reshape(-1, 2).astype(np.int64)
    key = np.sort(e, axis=1)
    _, inv, cnt = np.unique(key[:, 0] * len(V2) + key[:, 1], return_inverse=True, return_counts=True)
    b = e[cnt[inv] == 1]
    if not len(b):
        return np.zeros(0)
    _, comp = connected_components(coo_matrix((np.ones(len(b)), (b[:, 0], b[:, 1])), shape=(len(V2),) * 2), directed=False)
    lab = comp[b[:, 0]]
    k = int(lab.max()) + 1
    on = np.unique(b.ravel())
    centre = np.stack([np.bincount(comp[on], V2[on, d], k) for d in (0, 1)], axis=1) / np.maximum(np.bincount(comp[on], None, k), 1)[:, None]
    p, q = V2[b[:, 0]] - centre[lab], V2[b[:, 1]] - centre[lab]
    swept = np.arctan2(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0], (p * q).sum(axis=1))
    return np.bincount(lab, swept, k)[np.unique(lab)] / (2 * np.pi)


#: Least spread of a band's unit normals across its axis (:func:`band_axis`; per unit
#: area): ``sin^2(beta) / 2`` for normals at ``beta`` to the axis, 0.1 at 27 degrees.
#: Rings flatter than that (a dished washer) are flattened as sheets with one hole.
BAND_SPREAD = 0.1
#: Largest length of the area-weighted normals' sum, as a share of their summed
#: lengths, across the least-seen direction, of faces that run around (a band).
WRAP_RESULTANT = 0.5


def _least_seen(V: np.ndarray, F: np.ndarray, about_mean: bool = False) -> tuple:
    """``(N, w, a)``: the faces' area-weighted normals ``N`` (``|N_T|`` twice the
    area ``A_T``), the eigenvalues ``w`` (ascending) of ``sum_T N_T N_T^T`` and ``a``,
    the unit direction they see least (its smallest eigenvector). ``about_mean``: of
    the unit normals' spread about their mean ``m``, ``sum_T A_T (n_T - m)(n_T - m)^T``
    instead, whose ``a`` is the direction they vary least along: a cone band's
    normals all lean along its axis by the same amount, so vary along it not at all
    (about the origin, a 45-degree cone's axis is seen as much as any direction
    across it)."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    if not about_mean:
        w, vec = np.linalg.eigh(fn.T @ fn)
        return fn, w, vec[:, 0]
    area = np.linalg.norm(fn, axis=1)
    n = fn / np.maximum(area, 1e-300)[:, None]
    d = n - (area @ n) / max(float(area.sum()), 1e-300)
    w, vec = np.linalg.eigh((d * area[:, None]).T @ d / max(float(area.sum()), 1e-300))
    return fn, w, vec[:, 0]


def wraps_around(V: np.ndarray, F: np.ndarray) -> bool:
    """Whether a mesh of one annulus' topology runs around (a band: a tube, a vase, a
    ring of a box's sides), not a sheet with one hole (a bent panel with a vent hole,
    a flat ring split into two faces): seen across the direction its area-weighted
    normals least see (:func:`band_axis`), a band's normals point every way and
    nearly cancel, a sheet's mostly one way (their sum over
    :data:`WRAP_RESULTANT` of their summed lengths)."""
    fn, _, a = _least_seen(V, F)
    across = fn - np.outer(fn @ a, a)
    total = float(np.linalg.norm(across, axis=1).sum())
    return total > 0 and float(np.linalg.norm(across.sum(axis=0))) < WRAP_RESULTANT * total


def _band_axis_or_sheet(V: np.ndarray, F: np.ndarray) -> "np.ndarray | None":
    """The axis of a mesh of one annulus' topology that runs around it
    (:func:`band_axis`), or None for a sheet with one hole (:func:`wraps_around`
    false: flattened like a disk); a band around no one axis is refused."""
    try:
        return band_axis(V, F)
    except GeometryError:
        if wraps_around(V, F):
            raise
        return None


def band_axis(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The axis a closed band of faces (an annulus) runs around: the direction ``a``
    its unit normals vary least along (:func:`_least_seen` about their mean: the
    smallest eigenvector of their area-weighted spread, per unit area), which must
    stand apart from the other two (a tube, a vase, a cone band at any angle:
    ``lambda_1 < lambda_2 / 2``), with the normals spread across it
    (``lambda_2 >= BAND_SPREAD``: a flat or nearly flat ring is a sheet with one hole)
    and both boundary loops winding once around it seen along it.

    Raises:
        GeometryError: no such axis (the faces bend around no one direction)."""
    _, w, a = _least_seen(V, F, about_mean=True)
    e1 = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    turns = _loop_turns(V @ np.stack([e1, np.cross(a, e1)], axis=1), F)
    if w[0] > 0.5 * w[1] or w[1] < BAND_SPREAD or len(turns) != 2 or np.any(np.abs(np.abs(turns) - 1) > 0.1):
        raise GeometryError(
            "the faces form a closed band that does not run around one axis; texture them in two calls "
            "or as two selections that each form an open strip"
        )
    return a


def patch_param(pm: PartMesh, patch: list, tile: "tuple | None", rotation: float) -> PatchParam:
    """Texture coordinates (mm) of the patch (module docstring): a plane's frame, one
    curved face's ``(u, v)`` by arc length, a band, or LSCM. ``tile``: the texture
    tile ``(w, h)`` mm of a periodic texture (a whole number fits around)."""
    from ..mapping import band_coordinates, lscm_coordinates, separable_coordinates

    if len(patch) == 1:
        fm = pm.faces[patch[0]]
        if fm.kind == "plane":
            return PatchParam(fm.points, fm.tris, _plane_xy(fm, rotation), None, "plane frame (exact)")
        ut, vt, closed = _surface_tables(fm)
        if float(ut[1][-1]) < 1e-6 or float(vt[1][-1]) < 1e-6:
            raise GeometryError(f"the {fm.kind} face is degenerate (no extent along u or v)")
        period = None
        if closed:
            around = float(ut[1][-1])
            period = around if tile is None else max(1, round(around / tile[1])) * tile[1]
            ut = (ut[0], ut[1] * (period / around))
        XY = separable_coordinates(fm.uv, ut, vt)
        return PatchParam(fm.points, fm.tris, XY, period, "face (u, v) by arc length" + (", whole tiles around" if closed else ""),
                          (ut, vt, closed))  # fmt: skip
    # Several faces: the welded mesh of the patch.
    m = pm.mesh
    tmask = np.isin(pm.face_of_tri, patch)
    F0 = m.faces[tmask].astype(np.int64)
    used, F = np.unique(F0, return_inverse=True)
    F = F.reshape(-1, 3)
    V = m.vertices[used].astype(np.float64)
    ne = len(np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0))
    euler = len(V) - ne + len(F)
    axis = _band_axis_or_sheet(V, F) if euler == 0 else None  # an annulus: a band, or a sheet with one hole
    if axis is not None:
        XY, perim = band_coordinates(V, F, axis, V.mean(axis=0))
        period = perim if tile is None else max(1, round(perim / tile[1])) * tile[1]
        XY = np.stack([XY[:, 1], XY[:, 0] * (period / perim)], axis=1)
        return PatchParam(V, F, XY, period, "band: cross-section arc length around, height along the surface")
    return PatchParam(V, F, lscm_coordinates(V, F, rotation), None, "conformal flattening (LSCM)")


# ------------------------------------------------------------------------------------------
# Texture on the grid
# ------------------------------------------------------------------------------------------
def texture_tile(tex: Any, pitch: float, height: float):
    """``(hm, periodic)``: built-ins as one seamless tile (sampled periodically), images
    and Heightmaps as they are (placed once, centred); ``(None, False)`` for an image
    (loaded per patch, stretched over it)."""
    from ..sources import PREFIX, load_texture

    if isinstance(tex, Heightmap):
        return load_texture(tex, height=height), False
    s = os.fspath(tex)
    if s.startswith(PREFIX):
        return load_texture(s, pitch=pitch, height=height), True
    return None, False


def _heights(hm: "Heightmap | None", tex: Any, periodic: bool, grid, pitch: float, height: float) -> np.ndarray:
    """Texture heights (mm) at the grid points: periodic tiles by index modulo the
    tile, images stretched over the grid's extent, Heightmaps centred at their pitch."""
    from ..sources import load_texture

    R, C = grid.valid.shape
    if hm is None:  # an image: stretched over the patch
        px, py = grid.xs[1] - grid.xs[0], grid.ys[1] - grid.ys[0]
        hm = load_texture(tex, size=(C * px, R * py), pitch=float(min(px, py)), height=height)
        rows, cols = hm.shape
        ri = np.clip((np.arange(R) * rows) // R, 0, rows - 1)
        ci = np.clip((np.arange(C) * cols) // C, 0, cols - 1)
        return hm.heights[np.ix_(ri, ci)].astype(np.float64)
    rows, cols = hm.shape
    if periodic:
        return hm.heights[np.ix_(np.arange(R) % rows, np.arange(C) % cols)].astype(np.float64)
    ri = np.arange(R) - (R - rows) // 2
    ci = np.arange(C) - (C - cols) // 2
    out = np.zeros((R, C))
    rm, cm = (ri >= 0) & (ri < rows), (ci >= 0) & (ci < cols)
    out[np.ix_(rm, cm)] = hm.heights[np.ix_(ri[rm], ci[cm])]
    return out


def _border_distance(valid: np.ndarray, px: float, py: float, wrap_y: bool) -> np.ndarray:
    """Distance (texture mm) from each grid point to the nearest point off the face."""
    from scipy.ndimage import distance_transform_edt

    R, C = valid.shape
    pad = np.zeros((R + 2, C + 2), bool)
    pad[1:-1, 1:-1] = valid
    if wrap_y:  # rows close around: three copies, keep the middle one
        pad = np.zeros((3 * R, C + 2), bool)
        pad[:, 1:-1] = np.concatenate([valid] * 3)
        d = distance_transform_edt(pad, sampling=(py, px))
        return d[R : 2 * R, 1:-1]
    return distance_transform_edt(pad, sampling=(py, px))[1:-1, 1:-1]


def patch_grid(pm: PartMesh, patch: list, tex: Any, opts: PatchOptions) -> PatchGrid:
    """Parameterize the patch, lay the texture grid, sample the texture, and the
    envelope the heights may use: the M-I ramp and the fade (module docstring)."""
    from ..mapping import cell_mask, concave_convex, lay_grid, point_scales

    hm, periodic = texture_tile(tex, opts.pitch, opts.height)
    if hm is not None:  # flat at this pitch: say so, not "too small" for every face
        require_relief(hm, tex)
    tile = hm.size if (hm is not None and periodic) else None
    par = patch_param(pm, patch, tile, opts.rotation)
    pitch = hm.pitch if hm is not None else (opts.pitch, opts.pitch)
    px, py = float(pitch[0]), float(pitch[1])
    lo = par.XY.min(axis=0)
    shift = 0.37 * float(opts.jitter) / 0.002  # retries also move the grid by a fraction of a pixel
    origin = (float(lo[0]) - shift * px, float(lo[1]) - (0.0 if par.period_y is not None else shift * py))
    grid = lay_grid(par.V, par.F, par.XY, (px, py), period_y=par.period_y, origin=origin)
    H = _heights(hm, tex, periodic, grid, opts.pitch, opts.height)
    diag = float(np.hypot(px, py))
    d = _border_distance(grid.valid, px, py, grid.wrap_y)
    # Fade where the texture scale leaves [FADE_FULL, 1 / FADE_FULL] (poles, needles).
    sx, sy = point_scales(grid)
    q = np.minimum(np.minimum(sx, sy), 1.0 / np.maximum(np.maximum(sx, sy), 1e-9))
    fade = smoothstep(FADE_ZERO, FADE_FULL, q)
    d_keep, d_floor = 0.75 * diag, 3.75 * diag
    if opts.edge_angle < 90:
        ramp = np.tan(np.radians(opts.edge_angle)) * np.maximum(d - d_floor, 0.0)
    else:
        ramp = np.where(d > d_floor, np.inf, 0.0)
    concave, convex = concave_convex(grid)
    keep = grid.valid & (d >= d_keep)
    gain = _gradient(grid.points.reshape(-1, 3), opts.gradient).reshape(d.shape) * _mask(grid, par.XY, opts)
    return PatchGrid(par, grid, H, px, py, diag, d, fade, ramp, concave, convex, d_keep, d_floor, keep, gain,
                     cell_mask(keep, grid.wrap_y))


def _mask(grid: Any, XY: np.ndarray, opts: PatchOptions) -> "np.ndarray | float":
    """The mask's value ``m`` in [0, 1] at every grid point (1 without a mask): the
    mask stretched over ``opts.mask_size`` mm (default: the patch's extent in
    texture coordinates ``XY``), centred on the patch, sampled bilinearly at the
    grid's texture coordinates; 0 outside it. It scales the height like the gradient
    (``h = min(H fade, ramp) g m``), before the limits, so ramps and limits hold."""
    if opts.mask is None:
        return 1.0
    from ..sources.mask import mask_on_grid

    lo, hi = XY.min(axis=0), XY.max(axis=0)
    size = opts.mask_size if opts.mask_size is not None else tuple(float(t) for t in hi - lo)
    return mask_on_grid(opts.mask, size, grid.xs, grid.ys, centre=0.5 * (lo + hi))


# ------------------------------------------------------------------------------------------
# The textured surface and its limits
# ------------------------------------------------------------------------------------------
def patch_surface(g: PatchGrid, opts: PatchOptions) -> PatchSurface:
    """The textured surface as a signed offset ``s`` (mm along the normal) of the face.

    Raised (``c = 0``): ``s = max(h, FLOOR_CURVED)`` inside, dipping ``sink`` mm into
    the body along the outline band. With the envelope ``E = min(H_max fade, ramp)``
    and ``h = min(H fade, ramp)``, engraved (``c = 1``) and centred (``c = 1/2``) give
    ``s = g (h - c E)`` (``g`` the depth gradient), cut ``FLOOR_CURVED`` below the
    face where it would be at or above it (engraved) and ``2 FLOOR_CURVED`` along the
    outline band. Heights above the face are capped at ``0.9 / kappa`` on concave
    sides, depths below it at ``0.9 / kappa`` on convex ones (self-intersection)."""
    c = opts.share
    jit = float(opts.jitter)  # mm: a retry after a union that pinched (see welded)
    floor_c = FLOOR_CURVED + jit
    hcap = 0.9 / np.maximum(g.concave, 1e-9)
    dcap = 0.9 / np.maximum(g.convex, 1e-9)
    depth = np.minimum(opts.depth, dcap)
    band = g.d < g.d_floor
    h = np.minimum(g.H * g.fade, g.ramp) * g.gain
    env = None
    if c == 0:
        limited = (h > hcap) & g.grid.valid
        h = np.minimum(h, hcap)
        sink = np.minimum(0.05 + 2 * jit, 0.5 * depth)
        blend = np.interp(g.d, [g.d_keep, g.d_floor], [0.0, 1.0])
        s = np.where(band, -sink + blend * (sink + floor_c), np.maximum(h, floor_c))
        floor = np.minimum(s, floor_c)
    else:
        env = np.minimum(opts.height * g.fade, g.ramp) * g.gain
        t = h - c * env
        limited = ((t > hcap) | (t < -dcap)) & g.grid.valid
        t = np.clip(t, -dcap, hcap)
        s = np.where(band, -2 * floor_c, np.minimum(t, -floor_c) if c == 1 else t)
        floor = np.where(band, s, -floor_c if c == 1 else 0.0)
        sink = 0.05 + 2 * jit
    return PatchSurface(s, floor, c, depth, limited, floor_c, sink, band, env)


def textured_points(surf: PatchSurface, keep: np.ndarray) -> np.ndarray:
    """Grid points where a texture is left (after the limiter): above the floor
    (raised) or off the face by more than it (engraved, centred)."""
    s, fc = surf.surface, surf.floor_c
    return keep & ((s > fc + 1e-6) if surf.c == 0 else (np.abs(s) > fc + 1e-6))


def _cell_tris(cells: np.ndarray, R: int, C: int, wrap_y: bool) -> np.ndarray:
    """Both triangulations of every cell (four triangles): the union may flip a cell's
    diagonal, so the limiter makes either one safe."""
    rr, cc = np.nonzero(cells)
    rn = (rr + 1) % R
    a, b = rr * C + cc, rr * C + cc + 1
    d, c = rn * C + cc, rn * C + cc + 1
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1), np.stack([a, b, d], 1), np.stack([b, c, d], 1)])


def _unit_normals(q: np.ndarray, tri: np.ndarray) -> np.ndarray:
    e = np.cross(q[tri[:, 1]] - q[tri[:, 0]], q[tri[:, 2]] - q[tri[:, 0]])
    return e / np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-18)


def _overhangs(n: np.ndarray, dirs: np.ndarray, cos_c: float) -> np.ndarray:
    over = np.zeros(len(n), bool)
    for d in dirs:  # per build direction
        over |= -(n @ d) > cos_c
    return over


def limit_overhangs_grid(P, N, h, cells, wrap_y, dirs, critical_angle, floor):
    """Lower heights until no displaced facet overhangs where the face under it does not.

    A facet overhangs along build direction d when ``-n . d > cos(critical_angle +
    1 deg)`` (:func:`texcad.printability.overhang_mask` with a 1 degree margin), for
    both triangulations of every grid cell. Each round (vectorized over the grid)
    moves the heights of every overhanging facet's corners 40 % of the way down to
    ``floor``; 80 rounds bring any height to within 1e-17 of it. Where the face
    itself overhangs, the texture goes down to the floor.

    Args:
        P, N: ``(R, C, 3)`` grid points and unit normals, mm; h: ``(R, C)`` offsets, mm.
        cells: bool cells; wrap_y: rows close around; dirs: ``(K, 3)`` unit vectors.
        critical_angle: degrees; floor: ``(R, C)`` lowest offsets, mm.

    Returns:
        ``(h, rounds, base_over, remaining_overhang_mm2)``.
    """
    R, C = h.shape
    floor = np.asarray(floor, np.float64).reshape(-1)
    tri = _cell_tris(cells, R, C, wrap_y)
    Pf, Nf = P.reshape(-1, 3), N.reshape(-1, 3)
    cos_c = np.cos(np.radians(support_free_angle(critical_angle)))  # the slicers' rule (texcad.printability.rule)
    hf = h.reshape(-1).copy()
    base_n = _unit_normals(Pf, tri)
    if (base_n * Nf[tri].mean(axis=1)).sum() < 0:  # the grid's cells run clockwise seen from outside
        tri = tri[:, ::-1]
        base_n = -base_n
    base_over = _overhangs(base_n, dirs, cos_c)
    rounds = 0
    active = np.arange(len(tri))  # facets to look at: all, then those next to lowered vertices
    for rounds in range(1, 81):  # per limiting round
        t = tri[active]
        q = Pf + hf[:, None] * Nf
        over = _overhangs(_unit_normals(q, t), dirs, cos_c)
        # A facet that overhangs and still stands above the floor somewhere is lowered
        # (on a face that overhangs by itself the texture goes down to the floor).
        over &= (np.abs(hf[t] - floor[t]) > 1e-9).any(axis=1)
        if not over.any():
            break
        changed = np.zeros(len(hf), bool)
        changed[t[over].ravel()] = True
        idx = np.flatnonzero(changed)
        hf[idx] = floor[idx] + 0.6 * (hf[idx] - floor[idx])
        active = np.flatnonzero(changed[tri].any(axis=1))
    q = Pf + hf[:, None] * Nf
    e = np.cross(q[tri[:, 1]] - q[tri[:, 0]], q[tri[:, 2]] - q[tri[:, 0]])
    area = 0.5 * np.linalg.norm(e, axis=1)
    n = e / np.maximum(2 * area[:, None], 1e-18)
    over = _overhangs(n, dirs, cos_c)
    remaining = float(area[over & ~base_over].sum())
    return hf.reshape(R, C), rounds, base_over, remaining


def limit_patch(g: PatchGrid, surf: PatchSurface, opts: PatchOptions) -> "tuple[PatchSurface, dict]":
    """The overhang limiter on the textured surface: the lowered surface and the
    limiter's figures (removed volume mm^3, largest removal mm, rounds, share of
    points touched, whether the face overhangs, remaining overhang mm^2)."""
    before = surf.surface.copy()
    s, rounds, base_over, remaining = limit_overhangs_grid(
        g.grid.points, g.grid.normals, surf.surface, g.cells, g.grid.wrap_y, opts.build_dir, opts.critical_angle, surf.floor
    )
    removed = np.abs(before - s)
    report = {"removed_volume_mm3": float(removed.sum() * g.px * g.py), "max_removed_mm": float(removed.max()),
              "rounds": rounds, "touched_fraction": float((removed > 1e-6).mean()), "surface_overhang": bool(base_over.any()),
              "remaining_overhang_mm2": remaining}
    return replace(surf, surface=s), report


# ------------------------------------------------------------------------------------------
# The bodies: slab and cutters, lean where that saves triangles
# ------------------------------------------------------------------------------------------
def patch_bodies(g: PatchGrid, surf: PatchSurface, opts: PatchOptions, faces: tuple = ()) -> PatchBodies:
    """The bodies that put the texture on: a slab to add (raised, centred) and a
    cutter to subtract (engraved, centred). Their textured side is lean
    (:func:`texcad.solid.lean_grid`) within ``tolerance`` mm of the grid where that
    saves triangles; their other side, inside the part or outside it, is always lean
    (within :data:`BOTTOM_TOLERANCE`), with the same outline. ``faces``: the patch's
    :class:`texcad.brep.FaceMesh` es (the cutter's top rises over the creases between
    them and over their facets, :func:`_cut_above`)."""
    grid, cells = g.grid, g.cells
    P, N = grid.points, grid.normals
    s, c, fc = surf.surface, surf.c, surf.floor_c
    tex_tri, err = _lean_relief(g, surf, float(opts.tolerance), opts)
    lean_top = lean_offsets(P, N, s, tex_tri, grid.wrap_y) if tex_tri is not None and c == 0 else None
    if tex_tri is None:
        tex_tri = _cell_triangles(cells, grid.wrap_y)
    ring = _outline_ring(cells, grid.wrap_y)

    def body(textured, plain, textured_on_top: bool, plain_tol: float):
        plain_tri = _relief_triangles(g, [plain], plain_tol, [1.0], lean=True, measure=False, fine=ring)[0]
        plain_tri = _cell_triangles(cells, grid.wrap_y) if plain_tri is None else plain_tri
        tt, bt, to, bo = (tex_tri, plain_tri, textured, plain) if textured_on_top else (plain_tri, tex_tri, plain, textured)
        return _slab(P + to[..., None] * N, P + bo[..., None] * N, tt, bt)

    inside = min(BOTTOM_TOLERANCE, 0.2 * float(np.min(surf.depth)))  # a slab's bottom, depth mm in the part
    outside = 0.25 * (CUT_ABOVE - TESSELLATION)  # a cutter's top, CUT_ABOVE mm out: clear of the part's facets
    slab = cutter = low = None
    if c == 0:
        slab = body(s, -surf.depth, True, inside)
    else:
        cut_bottom = np.minimum(s, -fc) - (fc if c < 1 else 0.0)
        above = _cut_above(grid, faces)
        cutter = body(cut_bottom, above, False, outside)
        low = body(np.minimum(-c * surf.env, -fc) - 2 * fc, above, False, outside)
        if c < 1:
            slab = body(np.where(surf.band, -surf.sink, s), np.minimum(-surf.depth, cut_bottom - 0.05), True, inside)
    return PatchBodies(slab, cutter, low, err, len(tex_tri), lean_top)


def lean_offsets(P: np.ndarray, N: np.ndarray, s: np.ndarray, tri: np.ndarray, wrap: bool) -> np.ndarray:
    """``(R, C)`` mm: the lean surface through ``P + s N`` (grid points and unit
    normals ``(R, C, 3)`` mm, offsets ``s`` mm) over the triangles ``tri`` (flat grid
    indices, ``(M, 3)``; rows closed round when ``wrap``) at every grid point, as
    its offset along the point's normal: each point inside a triangle in the grid's
    index plane gets the triangle's point at its barycentric coordinates there (the
    lean facet's chord under a curved face included); points under no triangle keep
    ``s``. Vectorized over the points of the triangles' bounding boxes, in chunks of
    at most :data:`LEAN_CHUNK` points."""
    R, C = s.shape
    rows, cols = tri // C, tri % C
    if wrap:  # a triangle across the seam: row 0 is row R there
        rows = np.where((rows.max(axis=1, keepdims=True) - rows.min(axis=1, keepdims=True)) > R // 2,
                        np.where(rows == 0, R, rows), rows)
    Pe, Ne, se = (np.concatenate([a, a[:1]]) for a in (P, N, s)) if wrap else (P, N, s)
    V = (Pe + se[..., None] * Ne).reshape(-1, 3)  # the lean surface's vertices (row R: row 0 again)
    unrolled = rows * C + cols
    out = np.asarray(s, np.float64).copy()
    for part in _chunks(rows, cols):  # one per chunk of triangles
        qr, qc, L = _lean_points(rows[part], cols[part], V[unrolled[part]])
        out[qr % R, qc] = np.einsum("ij,ij->i", L - P[qr % R, qc], N[qr % R, qc])
    return out


def lean_heights(vertices: np.ndarray, faces: np.ndarray, origin: tuple, pitch: tuple, shape: tuple,
                 sub: int = 1) -> np.ndarray:
    """``((R - 1) sub + 1, (C - 1) sub + 1)`` mm: a lean heightfield surface
    (``vertices`` ``(N, 3)`` mm at pixel centres ``origin + ((c + 1/2) px, (r + 1/2)
    py, z)`` of an ``(R, C)`` = ``shape`` grid, triangles ``faces``; a slab's
    ``"texture"`` group) at every point of the grid refined ``sub`` times (point
    ``(i, j)`` at pixel ``(i / sub, j / sub)``; ``sub = 1``: the pixel centres),
    barycentric in the pixel grid as :func:`lean_offsets`, height above
    ``origin[2]``; NaN where no triangle lies."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    col = np.rint((v[:, 0] - origin[0]) / pitch[0] - 0.5).astype(np.int64)
    row = np.rint((v[:, 1] - origin[1]) / pitch[1] - 0.5).astype(np.int64)
    z = np.zeros((len(v), 3))
    z[:, 2] = v[:, 2] - origin[2]
    rows, cols = sub * row[f], sub * col[f]
    out = np.full(((shape[0] - 1) * sub + 1, (shape[1] - 1) * sub + 1), np.nan)
    for part in _chunks(rows, cols):  # one per chunk of triangles
        qr, qc, L = _lean_points(rows[part], cols[part], z[f[part]])
        ok = (qr >= 0) & (qr < out.shape[0]) & (qc >= 0) & (qc < out.shape[1])
        out[qr[ok], qc[ok]] = L[ok, 2]
    return out


def _chunks(rows: np.ndarray, cols: np.ndarray) -> list:
    """Slices of consecutive triangles (grid corners ``rows``, ``cols`` ``(M, 3)``)
    whose bounding boxes hold at most about :data:`LEAN_CHUNK` grid points each."""
    box = (rows.max(1) - rows.min(1) + 1) * (cols.max(1) - cols.min(1) + 1)
    ends = np.searchsorted(np.cumsum(box), np.arange(LEAN_CHUNK, int(box.sum()) + LEAN_CHUNK, LEAN_CHUNK), side="right")
    bounds = np.unique(np.concatenate([[0], np.clip(ends, 1, len(rows))]))
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


#: Grid points (over the triangles' bounding boxes) :func:`lean_offsets` handles at once.
LEAN_CHUNK = 1_000_000


def _lean_points(rows: np.ndarray, cols: np.ndarray, corners: np.ndarray) -> tuple:
    """``(qr, qc, L)``: the grid points ``(qr, qc)`` inside the triangles with grid
    corners ``rows``, ``cols`` ``(M, 3)`` and points ``corners`` ``(M, 3, 3)`` mm,
    and the triangles' points ``L`` ``(n, 3)`` there (barycentric in the index plane)."""
    r0, r1, c0, c1 = rows.min(1), rows.max(1), cols.min(1), cols.max(1)
    nr, nc = r1 - r0 + 1, c1 - c0 + 1
    k = np.repeat(np.arange(len(rows)), nr * nc)  # one per point of each triangle's box
    local = np.arange(len(k)) - np.repeat(np.cumsum(nr * nc) - nr * nc, nr * nc)
    qr, qc = r0[k] + local // nc[k], c0[k] + local % nc[k]
    (ar, br, cr), (ac, bc, cc) = rows[k].T, cols[k].T
    det = (br - ar) * (cc - ac) - (cr - ar) * (bc - ac)
    safe = np.where(det == 0, 1, det)
    l1 = ((qr - ar) * (cc - ac) - (cr - ar) * (qc - ac)) / safe
    l2 = ((br - ar) * (qc - ac) - (qr - ar) * (bc - ac)) / safe
    lam = np.stack([1.0 - l1 - l2, l1, l2], axis=1)
    inside = (lam >= -1e-9).all(axis=1) & (det != 0)
    k, lam = k[inside], lam[inside]
    return qr[inside], qc[inside], np.einsum("ij,ijk->ik", lam, corners[k])


def _cut_above(grid: Any, faces: tuple) -> np.ndarray:
    """mm ``(R, C)``: how far out along the grid's normals the cutter's top lies:
    :data:`CUT_ABOVE`, more near a crease between the patch ``faces`` (FaceMeshes;
    two fillets at a mitre, :func:`texcad.brep.bands.creases`): the normals are
    smoothed over it, so there the grid's segments (rows, columns, diagonals) at
    ``CUT_ABOVE`` dip under the ridge; their ends rise until each segment clears the
    roof of both faces' tangent planes at the crease point nearest its middle by
    :data:`CUT_OVER_CREASE` mm. Then the same over the faces' own facets
    (:func:`_over_facets`: long cells on a tight curve, normals smoothed along a
    facet strip)."""
    from scipy.spatial import cKDTree

    from ..brep.bands import creases

    P, N = grid.points, grid.normals
    above = np.full(P.shape[:2], CUT_ABOVE)
    segs = a, b = _grid_segments(grid.valid, grid.wrap_y)
    if not len(faces) or not len(a[0]):
        return above
    length = np.linalg.norm(P[b] - P[a], axis=1)
    q, n1, n2 = creases([fm.face for fm in faces], 0.25 * float(np.median(length))) if len(faces) > 1 else ((),) * 3
    if not len(q):
        return _over_facets(above, P, N, *segs, faces)
    dist, near = cKDTree(q).query(0.5 * (P[a] + P[b]))
    on = dist <= length  # the segments across or next to a crease
    a, b, q, n1, n2 = (a[0][on], a[1][on]), (b[0][on], b[1][on]), q[near[on]], n1[near[on]], n2[near[on]]
    slope = np.maximum(np.minimum(np.maximum((N[a] * n1).sum(1), (N[a] * n2).sum(1)),
                                  np.maximum((N[b] * n1).sum(1), (N[b] * n2).sum(1))), 0.3)  # clearance per mm of rise
    for _ in range(8):  # rounds: raise both ends until every segment clears the roof
        low = _roof_clearance(P[a] + above[a][:, None] * N[a] - q, P[b] + above[b][:, None] * N[b] - q, n1, n2)
        short = low < CUT_OVER_CREASE
        if not short.any():
            break
        lift = np.where(short, (CUT_OVER_CREASE - low) / slope + 0.1 * CUT_OVER_CREASE, 0.0)
        np.maximum.at(above, a, above[a] + lift)
        np.maximum.at(above, b, above[b] + lift)
    return _over_facets(above, P, N, *segs, faces)


def _over_facets(above: np.ndarray, P: np.ndarray, N: np.ndarray, a: tuple, b: tuple, faces: tuple) -> np.ndarray:
    """``above`` (mm) raised until the grid's segments ``a -> b`` at ``P + above N``
    clear the faces' facets (the mesh the cutter is subtracted from) by
    :data:`CUT_OVER_CREASE` mm at their quarter points: the clearance of a point is
    its largest height over the planes of the 8 facets nearest it that face its
    way (exact where the part is locally convex, where a chord can dip into it)."""
    from scipy.spatial import cKDTree

    T = np.concatenate([fm.points[fm.tris] for fm in faces]).astype(np.float64)
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-18)
    seg = np.linalg.norm(P[b] - P[a], axis=1)
    c, owner = _facet_samples(T, float(np.median(seg)))
    tree, k = cKDTree(c), min(8, len(c))
    n = n[owner]
    for _ in range(6):  # rounds: raise both ends until every segment clears the facets
        A, B = P[a] + above[a][:, None] * N[a], P[b] + above[b][:, None] * N[b]
        low = np.full(len(A), np.inf)
        for t in (0.25, 0.5, 0.75):  # a few points per segment
            X = A + t * (B - A)
            near = tree.query(X, k=k)[1].reshape(len(X), -1)
            h = np.einsum("skd,skd->sk", X[:, None] - c[near], n[near])
            facing = np.einsum("skd,sd->sk", n[near], N[a] + N[b]) > 0.5
            low = np.minimum(low, np.where(facing, h, -np.inf).max(axis=1))
        short = np.isfinite(low) & (low < CUT_OVER_CREASE)
        if not short.any():
            break
        lift = (CUT_OVER_CREASE - low[short]) / 0.5 + 0.1 * CUT_OVER_CREASE
        np.maximum.at(above, (a[0][short], a[1][short]), above[a][short] + lift)
        np.maximum.at(above, (b[0][short], b[1][short]), above[b][short] + lift)
    return above


def _facet_samples(T: np.ndarray, spacing: float) -> tuple:
    """Points on the triangles ``T`` ``(M, 3, 3)`` (mm) at most about ``spacing`` mm
    apart (the centroids of pieces split at their longest edge's midpoint until no
    edge is longer), and the triangle each lies on."""
    owner = np.arange(len(T))
    for _ in range(64):  # rounds of halving (a long strip facet needs a few)
        L = np.linalg.norm(T - np.roll(T, -1, axis=1), axis=2)  # edges 0-1, 1-2, 2-0
        long = L.max(axis=1) > spacing
        if not long.any():
            break
        e = L[long].argmax(axis=1)
        Tl = np.take_along_axis(T[long], np.stack([e, (e + 1) % 3, (e + 2) % 3], 1)[..., None], axis=1)
        m = 0.5 * (Tl[:, 0] + Tl[:, 1])
        halves = np.concatenate([np.stack([Tl[:, 0], m, Tl[:, 2]], 1), np.stack([m, Tl[:, 1], Tl[:, 2]], 1)])
        T, owner = np.concatenate([T[~long], halves]), np.concatenate([owner[~long], np.tile(owner[long], 2)])
    return T.mean(axis=1), owner


def _grid_segments(valid: np.ndarray, wrap_y: bool) -> tuple:
    """The grid's segments between valid points along the rows, the columns and both
    diagonals of the cells: ``(a, b)``, each ``(rows, cols)`` index arrays."""
    R, C = valid.shape
    r, c = np.nonzero(valid)
    ends = []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):  # per direction
        r2, c2 = (r + dr) % R if wrap_y else r + dr, c + dc
        ok = (r2 < R) & (c2 >= 0) & (c2 < C)
        ok[ok] = valid[r2[ok], c2[ok]]
        ends.append((r[ok], c[ok], r2[ok], c2[ok]))
    ra, ca, rb, cb = (np.concatenate(x) for x in zip(*ends))
    return (ra, ca), (rb, cb)


def _roof_clearance(A: np.ndarray, B: np.ndarray, n1: np.ndarray, n2: np.ndarray) -> np.ndarray:
    """``(S,)`` mm: the least height of the segments ``A -> B`` (``(S, 3)`` mm, from a
    point of a crease) over the roof of the planes through it with unit normals
    ``n1``, ``n2``: ``min_t max(n1 . P(t), n2 . P(t))`` (at an end or where they meet)."""
    a1, b1, a2, b2 = (A * n1).sum(1), (B * n1).sum(1), (A * n2).sum(1), (B * n2).sum(1)
    den = (a1 - b1) - (a2 - b2)
    t = np.clip(np.divide(a1 - a2, den, out=np.zeros_like(den), where=np.abs(den) > 1e-18), 0.0, 1.0)
    meet = np.maximum(a1 + t * (b1 - a1), a2 + t * (b2 - a2))
    return np.minimum(np.minimum(np.maximum(a1, a2), np.maximum(b1, b2)), meet)


def _lean_relief(g: PatchGrid, surf: PatchSurface, tol: float, opts: PatchOptions):
    """The textured side's lean triangles (or ``(None, 0.0)``: the grid). With
    ``build_dir``, a lean triangle that overhangs where the face under it does not
    (the limiter made the grid safe, not every plane through its points) has the
    cells under it kept at grid resolution, and the triangulation is made again."""
    heights, weights = [surf.surface, np.zeros_like(surf.surface)], [1.0, tol / BASE_TOLERANCE]
    tri, err = _relief_triangles(g, heights, tol, weights, lean=True)
    if opts.build_dir is None or tri is None:
        return tri, err
    more = np.zeros_like(g.cells)
    for _ in range(4):  # per round of refinement where a lean facet overhangs
        bad = _overhanging_cells(g, surf.surface, tri, opts.build_dir, opts.critical_angle)
        if bad is None:
            return tri, err
        more |= bad
        tri, err = _relief_triangles(g, heights, tol, weights, lean=True, more_fine=more)
        if tri is None:
            return None, 0.0
    return None, 0.0


def _overhanging_cells(g: PatchGrid, s: np.ndarray, tri: np.ndarray, dirs: np.ndarray, critical_angle: float):
    """Cells ``(R-1, C-1)`` (or ``(R, C-1)`` around a seam) under the lean triangles
    that overhang (``-n . d > cos(critical + 1 deg)``) where the face does not; None
    if there are none."""
    grid = g.grid
    P, N = grid.points.reshape(-1, 3), grid.normals.reshape(-1, 3)
    V = P + s.reshape(-1)[:, None] * N
    n = np.cross(V[tri[:, 1]] - V[tri[:, 0]], V[tri[:, 2]] - V[tri[:, 0]])
    base = N[tri].mean(axis=1)
    n *= np.sign((n * base).sum(axis=1, keepdims=True))  # outward, along the face's normal
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-18)
    base /= np.maximum(np.linalg.norm(base, axis=1, keepdims=True), 1e-18)
    cos_c = np.cos(np.radians(support_free_angle(critical_angle)))
    bad = np.any(-(n @ dirs.T) > cos_c, axis=1) & ~np.any(-(base @ dirs.T) > cos_c, axis=1)
    if not bad.any():
        return None
    R, C = grid.valid.shape
    rows, cols = tri[bad] // C, tri[bad] % C
    if grid.wrap_y:  # a triangle across the seam has rows 0 and R-1: its cells are the last row
        rows = np.where((rows.max(axis=1, keepdims=True) - rows.min(axis=1, keepdims=True)) > R // 2, np.where(rows == 0, R, rows), rows)
    r0, c0 = rows.min(1), cols.min(1)
    r1, c1 = np.maximum(rows.max(1), r0 + 1), np.maximum(cols.max(1), c0 + 1)
    shape = g.cells.shape
    diff = np.zeros((shape[0] + 1, shape[1] + 1), np.int64)  # the triangles' cell boxes, summed
    for rr, cc, sign in ((r0, c0, 1), (r0, c1, -1), (r1, c0, -1), (r1, c1, 1)):
        np.add.at(diff, (rr, cc), sign)
    return diff.cumsum(axis=0).cumsum(axis=1)[: shape[0], : shape[1]] > 0


def _cell_triangles(cells: np.ndarray, wrap_y: bool) -> np.ndarray:
    """The grid's own triangles over ``cells`` ``(M, 3)``, as flat grid indices."""
    R, C = cells.shape[0] + (0 if wrap_y else 1), cells.shape[1] + 1
    rr, cc = np.nonzero(cells)
    rn = (rr + 1) % R
    a, b, d, c = rr * C + cc, rr * C + cc + 1, rn * C + cc, rn * C + cc + 1
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def _outline_ring(cells: np.ndarray, wrap_y: bool) -> np.ndarray:
    """Cells next to a cell outside ``cells`` (8-neighbourhood): kept at the grid's
    resolution on both sides of a slab so that their outlines match."""
    from scipy.ndimage import binary_erosion

    if wrap_y:
        inner = binary_erosion(np.concatenate([cells[-1:], cells, cells[:1]]), np.ones((3, 3), bool), border_value=0)[1:-1]
    else:
        inner = binary_erosion(cells, np.ones((3, 3), bool), border_value=0)
    return cells & ~inner


def _relief_triangles(g: PatchGrid, heights: list, tolerance: float, weights: list, lean: bool, measure: bool = True,
                      fine: "np.ndarray | None" = None, more_fine: "np.ndarray | None" = None):
    """``(faces, error_mm)``: a lean triangulation of the grid's cells following the
    surfaces ``P + h N`` for ``h`` in ``heights`` (flat grid indices, ``(M, 3)``), or
    ``(None, 0.0)`` for the grid itself (tolerance 0, the overhang limiter on, or no
    saving). Cells marked ``fine`` (default: within two pixel diagonals of the
    outline band, where the union's intersection with the part runs, and
    ``more_fine``) stay at the grid's resolution, and so do the rows along a closed
    face's seam."""
    from ..solid import lean_grid

    if tolerance <= 0 or not lean:
        return None, 0.0
    grid, cells = g.grid, g.cells
    P, N = grid.points, grid.normals
    R, C = P.shape[:2]
    if fine is None:
        near = g.d < g.d_floor + 2 * g.diag
        near = np.concatenate([near, near[:1]]) if grid.wrap_y else near
        fine = near[:-1, :-1] | near[1:, :-1] | near[:-1, 1:] | near[1:, 1:]
        fine = fine | more_fine if more_fine is not None else fine
    if grid.wrap_y:  # unroll the seam: row R is row 0 again
        P, N = np.concatenate([P, P[:1]]), np.concatenate([N, N[:1]])
        heights = [np.concatenate([h, h[:1]]) for h in heights]
        fine = fine.copy()
        fine[0] = fine[-1] = True
    out = lean_grid(P, N, heights, cells, tolerance, weights=weights, fine=fine, max_fraction=LEAN_FRACTION, measure=measure)
    if out is None:
        return None, 0.0
    flat = (out["rc"][:, 0] % R) * C + out["rc"][:, 1]
    tri = flat[out["faces"]]
    # Row-major by the first corner (then the rest): manifold3d builds a mesh whose
    # triangles are spatially coherent several times faster.
    return tri[np.lexsort((tri[:, 2], tri[:, 1], tri[:, 0]))], float(out["error"])


def _slab(top: np.ndarray, bottom: np.ndarray, top_tri: np.ndarray, bottom_tri: np.ndarray) -> Mesh:
    """The closed slab between ``top`` and ``bottom`` ``(R, C, 3)`` (mm), each side
    triangulated on its own (flat grid indices), sharing their outline."""
    from ..solid import surface_slab

    ut, ti = np.unique(top_tri, return_inverse=True)
    ub, bi = np.unique(bottom_tri, return_inverse=True)
    pos = np.minimum(np.searchsorted(ub, ut), len(ub) - 1)
    under = np.where(ub[pos] == ut, pos, -1)
    return surface_slab(top.reshape(-1, 3)[ut], bottom.reshape(-1, 3)[ub], ti.reshape(-1, 3),
                        bottom_tri=bi.reshape(-1, 3), bottom_of=under)


# ------------------------------------------------------------------------------------------
# The texture's own integral (the gate's check 4)
# ------------------------------------------------------------------------------------------
def fused_offset(surf: PatchSurface) -> np.ndarray:
    """``(R, C)`` mm: the offset along the normal of the part's new surface where the
    bodies are fused (see :func:`patch_volume`): raised ``max(s, 0)``, engraved
    ``min(s, -f)``, centred the higher of the slab's top and the cut."""
    s, c, fc = surf.surface, surf.c, surf.floor_c
    if c == 0:
        return np.maximum(s, 0.0)
    if c == 1:
        return np.minimum(s, -fc)
    return np.maximum(np.where(surf.band, -surf.sink, s), np.minimum(s, -fc) - fc)


def patch_volume(g: PatchGrid, surf: PatchSurface, opts: PatchOptions) -> tuple:
    """``(volume, slack, nominal)`` mm^3: what the patch's bodies add to the part
    (raised +, engraved -), the difference the gate accepts, and the texture's
    integral before the limits (None for a centred texture, whose net volume is
    about 0 by design, so that no share of it can be read as kept).

    **Volume.** Over the meshed cells, the part's new surface is the offset ``t``
    (mm) along the face's normal ``N`` of every grid point ``P``: raised
    ``t = max(s, 0)`` (the slab adds what stands above the face; its outline band
    under the face adds nothing); engraved ``t = min(s, -f)`` (the cutter's textured
    side, ``f`` = ``floor_c`` mm under the face at least); centred the higher of the
    slab's top (``s``; ``-sink`` along the band) and the cut ``min(s, -f) - f``. The
    volume between the grid's cells at ``P`` and at ``P + t N`` is summed exactly by
    swept prisms (:func:`texcad.mapping.surface.grid_swept`): for principal
    curvatures ``k1``, ``k2`` (mean ``H``, Gaussian ``K``, positive convex) it is
    ``int (t + H t^2 + K t^3 / 3) dA``, which a raised relief on a convex face
    exceeds ``t A`` by and an engraved one falls short of. The grid's flat cells lie
    inside a convex face (outside a concave one) by their sag, ``e . (n_b - n_a) / 8``
    at an edge ``e``'s midpoint (:func:`texcad.mapping.surface.sheet_excess`): what
    lies between them and the face is the part's already, so
    ``volume = swept - excess`` (raised: added less; engraved: removed more).

    **Slack.** The textured side is lean within ``tolerance`` mm of the grid and the
    part's tessellation within :data:`texcad.brep.TESSELLATION` mm of the face:
    ``(tolerance + TESSELLATION) A`` over the cells' area ``A``, plus the excess
    itself (its estimate is second order) and ``1e-3 |volume|``.

    **Nominal.** The same sum for the texture as sampled, ``t = g (H - c H_max)``
    (``g`` the gradient), before the M-I ramp, the fade, the curvature and the
    overhang limits: a texture that the limits removed for the most part (a face
    too narrow for the ramps, too curved, too steep) makes the gate warn.
    """
    from ..mapping.surface import grid_swept

    P, N = g.grid.points, g.grid.normals
    t, c = fused_offset(surf), surf.c
    wrap = bool(g.grid.wrap_y)
    swept, area, excess = grid_swept(P, P + t[..., None] * N, N, cells=g.cells, wrap_rows=wrap)
    vol = swept - excess
    slack = (float(opts.tolerance) + TESSELLATION) * area + abs(excess) + 1e-3 * abs(vol) + 1e-3
    nominal = None
    if c in (0, 1):
        nom = np.where(g.grid.valid, (g.H - c * float(opts.height)) * g.gain, 0.0)
        nominal = grid_swept(P, P + nom[..., None] * N, N, cells=g.cells, wrap_rows=wrap, measure=False).volume - excess
    return vol, slack, nominal


def patch_displaced(g: PatchGrid, surf: PatchSurface, opts: PatchOptions, error: float) -> tuple:
    """``(volume, area, slack, nominal)``: what the patch displaces above and below
    the face alike, ``int |t| dA`` mm^3 over the cells (``t`` = :func:`fused_offset`,
    linear over the grid's two triangles a cell,
    :func:`texcad.report.gate.linear_abs_integral`), their area mm^2, the slack
    (the lean side's measured ``error`` mm times the area, mm^3) and the same
    integral of the texture as sampled, ``g (H - c H_max)``, before the ramps and
    limits (mm^3). The gate checks a centred texture's mesh by it: its net volume is
    about 0 by design."""
    from ..report.gate import linear_abs_integral

    P = g.grid.points.reshape(-1, 3)
    tri = _cell_triangles(g.cells, bool(g.grid.wrap_y))
    p = P[tri]
    areas = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    area = float(areas.sum())
    vol = linear_abs_integral(fused_offset(surf).reshape(-1)[tri], areas)
    nom = np.where(g.grid.valid, (g.H - surf.c * float(opts.height)) * g.gain, 0.0)
    nominal = linear_abs_integral(np.broadcast_to(nom, g.grid.valid.shape).reshape(-1)[tri], areas)
    return vol, area, float(error) * area + 1e-3 * vol + 1e-3, nominal


# ------------------------------------------------------------------------------------------
# One patch, all stages
# ------------------------------------------------------------------------------------------
def patch_relief(pm: PartMesh, patch: list, tex: Any, opts: PatchOptions) -> PatchRelief:
    """One patch: the texture grid on it, its heights and limits and the bodies that
    put it on the part (module docstring).

    Raises:
        GeometryError: no texture is left on the patch (too small or narrow at this
            pitch, or faded / limited away), or a degenerate face.
        ParameterError: the built-in texture is flat (0 mm everywhere) at this pitch.
    """
    from ..mapping import measure_distortion

    g = patch_grid(pm, patch, tex, opts)
    surf = patch_surface(g, opts)
    lim = None
    if opts.build_dir is not None:
        surf, lim = limit_patch(g, surf, opts)
    if not textured_points(surf, g.keep).any():
        raise GeometryError(
            f"no texture is left on the face(s) {face_numbers(patch)}: too small or narrow for the {g.d_floor:.2f} mm border band at "
            f"{g.px:.3g} mm pitch (or faded / limited away); use a smaller pitch or a larger face"
        )
    grid, keep = g.grid, g.keep
    faded = (g.fade < 1.0) & (g.H > 1e-6) & keep & (g.d > g.d_floor)
    dist = measure_distortion(grid, keep & (g.fade > 0))
    dist = type(dist)(dist.x, dist.y, float(faded.sum() / max(keep.sum(), 1)))
    bodies = patch_bodies(g, surf, opts, tuple(pm.faces[i] for i in patch) if opts.mode != "raised" else ())
    s_top = surf.surface
    info = {
        "faces": [int(i) for i in patch],
        "kinds": [pm.faces[i].kind for i in patch],
        "parameterization": g.par.method,
        "grid": tuple(grid.valid.shape),
        "period_y": g.par.period_y,
        "distortion": dist.to_dict(),
        "faded_fraction": dist.faded_fraction,
        "curvature_limited_points": int(surf.limited.sum()),
        "max_height": float(np.where(keep, s_top, 0).max()),
        "mode": opts.mode,
        "rotation": float(opts.rotation),
        "triangles": {"grid": 2 * int(g.cells.sum()), "mesh": bodies.top_triangles},
        "max_error_mm": bodies.error,
    }
    if surf.c > 0:
        info["max_depth"] = float(-np.where(keep, s_top, 0).min())
    if lim is not None:
        info["overhang_limit"] = lim
    shown = np.where(keep, s_top, 0.0)
    shown = np.maximum(shown, 0.0) if surf.c == 0 else np.where(keep, shown - shown[keep].min(), 0.0)
    hmap = Heightmap(shown.astype(np.float32), (g.px, g.py))
    return PatchRelief(tuple(int(i) for i in patch), bodies, info, dist, hmap, grid, bool(surf.limited.any()), s_top,
                       surf.c > 0, g.cells, g.par.tables, pm.faces[patch[0]].face if len(patch) == 1 else None, lim,
                       patch_volume(g, surf, opts), fused_offset(surf), patch_displaced(g, surf, opts, bodies.error))


# ------------------------------------------------------------------------------------------
# Welding the union's mesh
# ------------------------------------------------------------------------------------------
