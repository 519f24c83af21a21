"""Any face of a CAD part, several at once: ``texcad.texture(part, faces, texture)``.

Every face kind OCCT has (plane, cylinder, cone, sphere, torus, surfaces of revolution
and extrusion, B-spline, Bezier, offset, fillets and blends, trimmed faces with holes)
goes the same way:

1. **Tessellation.** The part is tessellated once by OCCT (0.01 mm chord error); the
   selected faces' triangles, with each face's own ``(u, v)`` at every vertex, are
   the surface the texture is laid on, and the whole tessellation (welded, checked
   watertight by manifold3d, healed if needed) is the base mesh it is fused with.
2. **Parameterization in mm.** Faces that meet across a sharp edge are textured
   apart (the M-I ramp brings the relief to 0 at that edge); faces that meet smoothly
   (tangent edges) form one *patch* and are flattened together, so the texture runs
   on across the edge. Texture coordinates (x, y) in mm:

   * a planar face: its own frame (exact, the texture is not distorted);
   * one curved face: its ``(u, v)`` corrected by its metric,
     ``x = X(v)``, ``y = Y(u)`` with ``X`` the mean arc length along the v lines and
     ``Y`` the mean arc length along the u lines (:func:`texcad.mapping.separable_coordinates`).
     On a face of revolution OCCT's ``u`` is the angle and ``v`` runs along the
     meridian, so this is the paper's 2.5D method with the profile *revolved*: x is
     the meridian's arc length (exact), y runs around. **The circumference changing
     with the radius**: y is ``theta * R_ref``; on a closed face ``R_ref`` is chosen
     so that a whole number of texture tiles fits around (``n = round(2 pi R_mean /
     tile)``), so every ring closes seamlessly, and the texture is stretched along y
     by ``r / R_ref`` where the radius is ``r``. That scale is measured on the laid
     grid and reported as :class:`texcad.mapping.Distortion` (``Textured.distortion``);
   * several smooth faces: a closed band around an axis (the sides and rounded
     corners of a box) by the cross-section's arc length and the height
     (:func:`texcad.mapping.band_coordinates`), any other patch by a least-squares
     conformal flattening (libigl ``lscm``) scaled to the patch's area.
3. **Texture grid.** A grid at the texture's pitch is laid in texture space and
   placed on the surface (:func:`texcad.mapping.lay_grid`); heights are the texture's
   pixels (built-ins tile seamlessly). Where the local scale leaves
   ``[FADE_FULL, 1/FADE_FULL]`` the height fades smoothly to 0 (``smoothstep`` down to
   ``FADE_ZERO``) with a :class:`~texcad.errors.TexcadWarning`: at a sphere's pole or a
   needle-thin region the texture fades out instead of pinching into spikes.
4. **Limits.** The M-I ramp ``h <= tan(edge_angle) * max(0, d - 3 diag)`` at the
   patch outline (``d`` the distance to it in texture mm, ``diag`` the pixel
   diagonal); the self-intersection limit ``h <= 0.9 / kappa`` on concave sides
   (``kappa`` the largest concave normal curvature at the point, 1/mm) and the slab
   depth ``<= 0.9 / kappa`` on convex sides; the overhang limiter (``build_dir``,
   ``critical_angle``) lowers heights where a displaced facet would overhang while
   the face under it does not (iterated, vectorized over the grid).
5. **Slab and union.** The relief is a closed slab: top = surface + h n (at least
   ``FLOOR_CURVED`` above the surface inside, dipping ``sink`` mm into the body along
   the outline band), bottom = surface - depth n, walls along the outline; all slabs
   are fused onto the base mesh in one manifold3d union (one body per solid checked).

STEP: a face parameterized on its own ``(u, v)`` (one curved face) gets a B-rep, the
textured face as a degree-1 B-spline on that parameter space in place of the face
(:mod:`texcad.pipeline.brep_faces`, :func:`texcad.solid.uv_textured_solid`); faces
flattened together (bands, LSCM) have none: ``Textured.shape`` raises
:class:`~texcad.errors.GeometryError` that says so and names the STL / 3MF outputs.
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import GeometryError, ParameterError, TexcadWarning
from ..sources import Heightmap
from ..solid import Mesh, as_array, edge_report, explore, from_manifold, to_manifold
from ..util import Progress, report, smoothstep

__all__ = ["texture_any_faces", "face_list", "part_tessellation", "FADE_FULL", "FADE_ZERO", "FLOOR_CURVED"]

#: Local texture scale (either direction, or its inverse) down to which the full height is kept.
FADE_FULL = 0.55
#: ... and at which the height has faded to 0 (smoothstep between).
FADE_ZERO = 0.3
#: mm: the relief stays at least this far above a face inside its ramp (no tangential contact).
FLOOR_CURVED = 0.01
#: Tangent edges: faces whose normals differ by less than this across their common
#: edge (degrees) are one patch.
SMOOTH_ANGLE = 12.0
#: mm: chord error of the part's tessellation.
TESSELLATION = 0.01


@dataclass
class FaceMesh:
    """One B-rep face's triangles: ``points`` (N, 3) mm, ``tris`` (M, 3) outward,
    ``uv`` (N, 2) the face's own parameters, ``kind`` (``"plane"``, ``"cone"``...)."""

    face: Any
    points: np.ndarray
    tris: np.ndarray
    uv: np.ndarray
    kind: str


@dataclass
class PartMesh:
    """The part's tessellation: per-face meshes and the welded whole."""

    faces: list
    mesh: Mesh
    face_of_tri: np.ndarray


# ------------------------------------------------------------------------------------------
# Tessellation
# ------------------------------------------------------------------------------------------
def _face_kind(face) -> str:
    from OCP.BRepAdaptor import BRepAdaptor_Surface

    return BRepAdaptor_Surface(face).GetType().name.removeprefix("GeomAbs_").lower()


def _face_triangles(face) -> "FaceMesh | None":
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_REVERSED
    from OCP.TopLoc import TopLoc_Location

    loc = TopLoc_Location()
    poly = BRep_Tool.Triangulation_s(face, loc)
    if poly is None:
        return None
    trsf = loc.Transformation()
    nn, nt = poly.NbNodes(), poly.NbTriangles()
    pts = np.empty((nn, 3))
    uv = np.zeros((nn, 2))
    has_uv = poly.HasUVNodes()
    for i in range(nn):  # OCP exposes nodes one by one (per node of the coarse mesh)
        p = poly.Node(i + 1).Transformed(trsf)
        pts[i] = (p.X(), p.Y(), p.Z())
        if has_uv:
            q = poly.UVNode(i + 1)
            uv[i] = (q.X(), q.Y())
    tri = np.array([poly.Triangle(i + 1).Get() for i in range(nt)], dtype=np.int64).reshape(-1, 3) - 1
    if face.Orientation() == TopAbs_REVERSED:
        tri = tri[:, ::-1]
    return FaceMesh(face, pts, tri, uv, _face_kind(face))


def part_tessellation(topo, tolerance: float = TESSELLATION) -> PartMesh:
    """Tessellate ``topo`` (OCCT, ``tolerance`` mm chord error) into per-face meshes
    and one welded mesh; checked closed (manifold3d) and healed if needed (finer
    tessellation, then a wider weld).

    Raises:
        GeometryError: no watertight tessellation could be made.
    """
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    last = None
    for tol, weld in ((tolerance, 1e-5), (tolerance / 3, 1e-5), (tolerance / 3, 1e-3)):  # healing attempts
        BRepMesh_IncrementalMesh(topo, tol, False, 0.1, True)
        fms = [_face_triangles(TopoDS.Face_s(f)) for f in explore(topo, TopAbs_FACE)]
        pm = _weld(fms, weld)
        try:
            to_manifold(pm.mesh)
            return pm
        except GeometryError as e:
            last = e
    raise GeometryError(
        f"OCCT's tessellation of the part is not a closed solid even after healing ({last}); "
        "check the part with a CAD tool (is it one closed solid?) or fix its faces"
    )


def _weld(fms: list, weld: float) -> PartMesh:
    verts, tris, fid, offs = [], [], [], []
    off = 0
    for k, fm in enumerate(fms):  # per B-rep face
        offs.append(off)
        if fm is None:
            continue
        verts.append(fm.points)
        tris.append(fm.tris + off)
        fid.append(np.full(len(fm.tris), k))
        off += len(fm.points)
    if not tris:
        raise GeometryError("the part has no faces to tessellate")
    v = np.concatenate(verts)
    f = np.concatenate(tris)
    _, first, inv = np.unique(np.round(v / weld).astype(np.int64), axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    f = inv[f]
    keep = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return PartMesh(fms, Mesh(v[first].astype(np.float32), f[keep].astype(np.uint32)), np.concatenate(fid)[keep])


# ------------------------------------------------------------------------------------------
# Faces: selection and patches
# ------------------------------------------------------------------------------------------
def face_list(faces: Any) -> list:
    """A list of OCP faces from one face, a build123d ``ShapeList``, a list or a
    CadQuery selection."""
    if callable(getattr(faces, "vals", None)) and hasattr(faces, "objects"):
        faces = faces.vals()
    if isinstance(faces, (list, tuple)) or type(faces).__name__ == "ShapeList":
        items = list(faces)
    else:
        items = [faces]
    if not items:
        raise ParameterError("no face selected; pass a face or a list of faces of the part")
    return items


def _patches(pm: PartMesh, idx: list[int]) -> list[list[int]]:
    """Group the selected faces into patches joined by smooth (tangent) edges."""
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
    groups: dict[int, list[int]] = {}
    for i in idx:
        groups.setdefault(root(i), []).append(i)
    return list(groups.values())


# ------------------------------------------------------------------------------------------
# Parameterization of a patch
# ------------------------------------------------------------------------------------------
def _plane_xy(fm: FaceMesh, rotation: float) -> np.ndarray:
    from .cad import plane_frame

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
    span = ad.LastUParameter() - ad.FirstUParameter()
    closed_u = bool((ad.IsUPeriodic() or ad.IsUClosed()) and (u1 - u0) > span * (1 - 1e-6))
    if ad.IsUPeriodic():
        closed_u = closed_u or (u1 - u0) > ad.UPeriod() * (1 - 1e-6)
    (ut, Y), (vt, X) = metric_tables(pts, us, vs)
    return (ut, Y), (vt, X), closed_u


@dataclass
class Param:
    """A parameterized patch: vertices, triangles, texture coordinates (mm), the
    period around (mm) for closed patches, and how it was made."""

    V: np.ndarray
    F: np.ndarray
    XY: np.ndarray
    period_y: float | None
    method: str
    tables: tuple | None = None  # one curved face: (u table, v table, closed around u)


def _param(pm: PartMesh, patch: list[int], tile: tuple[float, float] | None, rotation: float) -> Param:
    from ..mapping import band_coordinates, lscm_coordinates, separable_coordinates

    if len(patch) == 1:
        fm = pm.faces[patch[0]]
        if fm.kind == "plane":
            return Param(fm.points, fm.tris, _plane_xy(fm, rotation), None, "plane frame (exact)")
        ut, vt, closed = _surface_tables(fm)
        if float(ut[1][-1]) < 1e-6 or float(vt[1][-1]) < 1e-6:
            raise GeometryError(f"the {fm.kind} face is degenerate (no extent along u or v)")
        period = None
        if closed:
            around = float(ut[1][-1])
            period = around if tile is None else max(1, round(around / tile[1])) * tile[1]
            ut = (ut[0], ut[1] * (period / around))
        XY = separable_coordinates(fm.uv, ut, vt)
        return Param(fm.points, fm.tris, XY, period, "face (u, v) by arc length" + (", whole tiles around" if closed else ""),
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
    if euler == 0:  # a band (annulus): around an axis
        fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
        w, vec = np.linalg.eigh(fn.T @ fn)
        axis = vec[:, 0]
        if w[0] > 0.05 * w[2]:
            raise GeometryError(
                "the faces form a closed band that does not run around one axis; texture them in two calls "
                "or as two selections that each form an open strip"
            )
        XY, perim = band_coordinates(V, F, axis, V.mean(axis=0))
        period = perim if tile is None else max(1, round(perim / tile[1])) * tile[1]
        XY = np.stack([XY[:, 1], XY[:, 0] * (period / perim)], axis=1)
        return Param(V, F, XY, period, "band: cross-section arc length around, height along the axis")
    return Param(V, F, lscm_coordinates(V, F), None, "conformal flattening (LSCM)")


# ------------------------------------------------------------------------------------------
# Texture on the grid
# ------------------------------------------------------------------------------------------
def _texture_tile(tex: Any, pitch: float, height: float):
    """``(hm, periodic)``: built-ins as one seamless tile (sampled periodically), images
    and Heightmaps as they are (placed once, centred)."""
    from ..sources import PREFIX, load_texture

    if isinstance(tex, Heightmap):
        return load_texture(tex, height=height), False
    s = os.fspath(tex)
    if s.startswith(PREFIX):
        return load_texture(s, pitch=pitch, height=height), True
    return None, False


def _heights(hm: Heightmap | None, tex: Any, periodic: bool, grid, pitch: float, height: float) -> np.ndarray:
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


def _limit_overhangs_grid(P, N, h, cells, wrap_y, dirs, critical_angle, floor):
    """Lower heights until no displaced facet overhangs where the face under it does not.

    A facet overhangs along build direction d when ``-n . d > cos(critical_angle +
    1 deg)`` (:func:`texcad.printability.overhang_mask` with a 1 degree margin), for
    both triangulations of every grid cell. Each round (vectorized over the grid)
    moves the heights of every overhanging facet's corners 40 % of the way down to
    ``floor``; 80 rounds bring any height to within 1e-17 of it. Where the face
    itself overhangs, the texture goes down to the floor.

    Returns:
        ``(h, removed_volume_mm3_estimate, max_removed, rounds)``.
    """
    R, C = h.shape
    floor = np.asarray(floor, np.float64).reshape(-1)
    tri = _cell_tris(cells, R, C, wrap_y)
    Pf, Nf = P.reshape(-1, 3), N.reshape(-1, 3)
    cos_c = np.cos(np.radians(critical_angle + 1.0))  # 1 degree stricter than overhang_mask
    hf = h.reshape(-1).copy()

    def normals(q):
        e = np.cross(q[tri[:, 1]] - q[tri[:, 0]], q[tri[:, 2]] - q[tri[:, 0]])
        return e / np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-18)

    base_n = normals(Pf)
    if (base_n * Nf[tri].mean(axis=1)).sum() < 0:  # the grid's cells run clockwise seen from outside
        tri = tri[:, ::-1]
        base_n = -base_n
    base_over = np.zeros(len(tri), bool)
    for d in dirs:
        base_over |= -(base_n @ d) > cos_c
    rounds = 0
    active = np.arange(len(tri))  # facets to look at: all, then those next to lowered vertices
    for rounds in range(1, 81):  # per limiting round
        t = tri[active]
        q = Pf + hf[:, None] * Nf
        e = np.cross(q[t[:, 1]] - q[t[:, 0]], q[t[:, 2]] - q[t[:, 0]])
        n = e / np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-18)
        over = np.zeros(len(t), bool)
        for d in dirs:  # per build direction
            over |= -(n @ d) > cos_c
        # A facet that overhangs and still stands above the floor somewhere is lowered
        # (on a face that overhangs by itself the texture goes down to the floor).
        over &= (hf[t] > floor[t] + 1e-9).any(axis=1)
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
    over = np.zeros(len(tri), bool)
    for d in dirs:
        over |= -(n @ d) > cos_c
    remaining = float(area[over & ~base_over].sum())
    return hf.reshape(R, C), rounds, base_over, remaining


def _cell_tris(cells: np.ndarray, R: int, C: int, wrap_y: bool) -> np.ndarray:
    """Both triangulations of every cell (four triangles): the union may flip a cell's
    diagonal, so the limiter makes either one safe."""
    rr, cc = np.nonzero(cells)
    rn = (rr + 1) % R
    a, b = rr * C + cc, rr * C + cc + 1
    d, c = rn * C + cc, rn * C + cc + 1
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1), np.stack([a, b, d], 1), np.stack([b, c, d], 1)])


# ------------------------------------------------------------------------------------------
# One patch: grid, heights, limits, slab
# ------------------------------------------------------------------------------------------
def _patch_relief(pm: PartMesh, patch: list[int], tex: Any, opts: dict) -> dict:
    from ..mapping import cell_mask, concave_convex, grid_slab, lay_grid, measure_distortion, point_scales

    hm, periodic = _texture_tile(tex, opts["pitch"], opts["height"])
    tile = hm.size if (hm is not None and periodic) else None
    par = _param(pm, patch, tile, opts["rotation"])
    pitch = hm.pitch if hm is not None else (opts["pitch"], opts["pitch"])
    px, py = float(pitch[0]), float(pitch[1])
    lo = par.XY.min(axis=0)
    shift = 0.37 * float(opts.get("jitter", 0.0)) / 0.002  # retries also move the grid by a fraction of a pixel
    origin = (float(lo[0]) - shift * px, float(lo[1]) - (0.0 if par.period_y is not None else shift * py))
    grid = lay_grid(par.V, par.F, par.XY, (px, py), period_y=par.period_y, origin=origin)
    H = _heights(hm, tex, periodic, grid, opts["pitch"], opts["height"])
    diag = float(np.hypot(px, py))
    d = _border_distance(grid.valid, px, py, grid.wrap_y)
    # Fade where the texture scale leaves [FADE_FULL, 1 / FADE_FULL] (poles, needles).
    sx, sy = point_scales(grid)
    q = np.minimum(np.minimum(sx, sy), 1.0 / np.maximum(np.maximum(sx, sy), 1e-9))
    fade = smoothstep(FADE_ZERO, FADE_FULL, q)
    d_keep, d_floor = 0.75 * diag, 3.75 * diag
    ramp = np.tan(np.radians(opts["edge_angle"])) * np.maximum(d - d_floor, 0.0) if opts["edge_angle"] < 90 else np.where(d > d_floor, np.inf, 0.0)
    h = np.minimum(H * fade, ramp)
    # Self-intersection: h <= 0.9 / kappa on concave sides; depth <= 0.9 / kappa on convex ones.
    concave, convex = concave_convex(grid)
    hcap = 0.9 / np.maximum(concave, 1e-9)
    limited = (h > hcap) & grid.valid
    h = np.minimum(h, hcap)
    depth = np.minimum(opts["depth"], 0.9 / np.maximum(convex, 1e-9))
    jit = float(opts.get("jitter", 0.0))  # mm: a retry after a union that pinched (see welded)
    floor_c = FLOOR_CURVED + jit
    sink = np.minimum(0.05 + 2 * jit, 0.5 * depth)
    band = np.interp(d, [d_keep, d_floor], [0.0, 1.0])
    h_top = np.where(d < d_floor, -sink + band * (sink + floor_c), np.maximum(h, floor_c))
    keep = grid.valid & (d >= d_keep)
    cells = cell_mask(keep, grid.wrap_y)
    limit_info = None
    if opts["build_dir"] is not None:
        floor_arr = np.minimum(h_top, floor_c)
        before = h_top.copy()
        h_top, rounds, base_over, remaining = _limit_overhangs_grid(
            grid.points, grid.normals, h_top, cells, grid.wrap_y, opts["build_dir"], opts["critical_angle"], floor_arr
        )
        removed = np.maximum(before - h_top, 0.0)
        limit_info = {"removed_volume_mm3": float(removed.sum() * px * py), "max_removed_mm": float(removed.max()), "rounds": rounds,
                      "touched_fraction": float((removed > 1e-6).mean()), "surface_overhang": bool(base_over.any()),
                      "remaining_overhang_mm2": remaining}
    textured = keep & (h_top > floor_c + 1e-6)
    if not textured.any():
        raise GeometryError(
            f"no texture is left on the face(s) {patch}: too small or narrow for the {d_floor:.2f} mm border band at "
            f"{px:.3g} mm pitch (or faded / limited away); use a smaller pitch or a larger face"
        )
    faded = (fade < 1.0) & (H > 1e-6) & keep & (d > d_floor)
    dist = measure_distortion(grid, keep & (fade > 0))
    dist = type(dist)(dist.x, dist.y, float(faded.sum() / max(keep.sum(), 1)))
    P, N = grid.points, grid.normals
    top = P + h_top[..., None] * N
    bottom = P - depth[..., None] * N
    slab = grid_slab(top, bottom, cells, grid.wrap_y)
    info = {
        "faces": [int(i) for i in patch],
        "kinds": [pm.faces[i].kind for i in patch],
        "parameterization": par.method,
        "grid": tuple(grid.valid.shape),
        "period_y": par.period_y,
        "distortion": dist.to_dict(),
        "faded_fraction": dist.faded_fraction,
        "curvature_limited_points": int(limited.sum()),
        "max_height": float(np.where(keep, h_top, 0).max()),
    }
    if limit_info is not None:
        info["overhang_limit"] = limit_info
    hmap = Heightmap(np.where(keep, np.maximum(h_top, 0.0), 0.0).astype(np.float32), (px, py))
    return {"slab": slab, "info": info, "distortion": dist, "heightmap": hmap, "grid": grid, "limited": bool(limited.any()), "h_top": h_top,
            "cells": cells, "tables": par.tables, "face": pm.faces[patch[0]].face if len(patch) == 1 else None}  # fmt: skip


# ------------------------------------------------------------------------------------------
# The faces of a part
# ------------------------------------------------------------------------------------------
def _face_indices(pm: PartMesh, topo, faces: list) -> list[int]:
    from OCP.TopAbs import TopAbs_FACE

    from ..solid import to_topods

    out = []
    for face in faces:  # per selected face
        f = to_topods(face)
        if f.ShapeType() != TopAbs_FACE:
            raise ParameterError(f"expected faces, got a {f.ShapeType().name.removeprefix('TopAbs_').lower()}")
        hit = [k for k, fm in enumerate(pm.faces) if fm is not None and fm.face.IsSame(f)]
        if not hit:
            raise ParameterError(
                "a face is not a face of this part (or has no area); select it from the part itself, "
                "e.g. part.faces().filter_by(GeomType.CONE) (build123d) or wp.faces('%CONE') (CadQuery)"
            )
        if hit[0] not in out:
            out.append(hit[0])
    return out


def welded(man) -> "Mesh | None":
    """The union's mesh with vertices at the same position merged (as an STL reader
    does) and the zero-area needles manifold3d sometimes leaves along a cut edge
    (a triangle with two vertices at one position) dropped; None unless every edge
    then lies on exactly two triangles."""
    out = man.to_mesh()
    v = np.asarray(out.vert_properties)[:, :3].astype(np.float32)
    f = np.asarray(out.tri_verts).astype(np.int64)
    order = np.lexsort((v[:, 2], v[:, 1], v[:, 0]))
    sv = v[order]
    new = np.ones(len(v), bool)
    new[1:] = np.any(sv[1:] != sv[:-1], axis=1)
    inv = np.empty(len(v), np.int64)
    inv[order] = np.cumsum(new) - 1
    uniq = sv[new]
    f = inv[f]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    if not edge_report(f)["watertight"]:  # every edge on two triangles, opposite ways
        return None
    used = np.unique(f)
    remap = np.full(len(uniq), -1, np.int64)
    remap[used] = np.arange(len(used))
    mesh = Mesh(np.ascontiguousarray(uniq[used]), remap[f].astype(np.uint32))
    mesh.__dict__["is_watertight"] = True
    return mesh


def texture_any_faces(topo, faces: list, tex: Any, *, base_mesh: Mesh | None = None, progress: Progress = None, **opts) -> dict:
    """Texture ``faces`` (OCP faces of ``topo``) with the general method of this
    module; fuse every relief onto ``base_mesh`` (default: the part's tessellation).

    Options (mm, degrees): ``height``, ``pitch``, ``depth``, ``edge_angle``,
    ``rotation``, ``build_dir`` ((K, 3) unit or None), ``critical_angle``.

    Returns:
        A dict: ``mesh`` (fused), ``texture_mesh`` (callable), ``base_mesh``,
        ``heightmap`` (one patch) or None, ``distortion``, ``info``, ``limits``.
    """
    import manifold3d as m3d

    from ..mapping import Distortion
    from ..solid import solids_of

    report(progress, 0.02, "tessellating the part (OCCT)")
    pm = part_tessellation(topo)
    idx = _face_indices(pm, topo, faces)
    base = pm.mesh if base_mesh is None else base_mesh
    patches = _patches(pm, idx)
    reliefs = []
    for k, patch in enumerate(patches):  # per patch of smoothly joined faces
        report(progress, 0.05 + 0.6 * k / len(patches), f"texturing face(s) {patch} ({', '.join(pm.faces[i].kind for i in patch)})")
        try:
            reliefs.append(_patch_relief(pm, patch, tex, opts))
        except GeometryError as e:
            if len(patches) == 1:
                raise
            warnings.warn(f"face(s) {patch} left untextured: {e}", TexcadWarning, stacklevel=3)
    if not reliefs:
        raise GeometryError("no texture is left on any selected face: they are too small or narrow at this pitch")
    faded = [r for r in reliefs if r["distortion"].faded_fraction > 0]
    if faded:
        warnings.warn(
            f"the texture fades out on {100 * max(r['distortion'].faded_fraction for r in faded):.1f} % of face(s) "
            f"{[r['info']['faces'] for r in faded]}: the texture scale there leaves [{FADE_FULL}, {1 / FADE_FULL:.2f}] "
            "(a pole, a needle-thin region)",
            TexcadWarning,
            stacklevel=3,
        )
    if any(r["limited"] for r in reliefs):
        warnings.warn("the texture height was limited to 0.9 / curvature on concave parts of the face(s)", TexcadWarning, stacklevel=3)
    report(progress, 0.7, f"fusing {sum(r['slab'].num_triangles for r in reliefs)} texture triangles onto the part (manifold3d)")
    base_man = to_manifold(base)
    want = len(base_man.decompose())
    for attempt in range(3):  # a union whose output pinches (two sheets along an edge) is redone, nudged
        parts = [base_man] + [to_manifold(r["slab"]) for r in reliefs]
        fused_man = m3d.Manifold.batch_boolean(parts, m3d.OpType.Add)
        if fused_man.status() != m3d.Error.NoError or fused_man.is_empty():
            raise GeometryError(f"the union of texture and part failed (manifold3d: {fused_man.status().name})")
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
        report(progress, 0.75, "the union pinched along an edge: redoing it with the relief nudged by 2 um")
        opts = dict(opts, jitter=0.002 * (attempt + 1))
        reliefs = [_patch_relief(pm, r["info"]["faces"], tex, opts) for r in reliefs]

    def texture_only() -> Mesh:
        return from_manifold(fused_man - base_man)

    dist = Distortion.combined([r["distortion"] for r in reliefs])
    infos = [r["info"] for r in reliefs]
    return {
        "mesh": fused,
        "texture_mesh": texture_only,
        "base_mesh": base,
        "heightmap": reliefs[0]["heightmap"] if len(reliefs) == 1 else None,
        "distortion": dist,
        "info": infos,
        "face_indices": idx,
        "solids": len(solids_of(topo)),
        "reliefs": reliefs,  # for the B-rep (texcad.pipeline.cad: texcad.solid.uv_textured_solid)
    }
