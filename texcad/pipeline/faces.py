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
(:mod:`texcad.brep.targets`, :func:`texcad.brep.uv_textured_solid`); faces
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
from ..solid import Mesh, edge_report, from_manifold, to_manifold
from ..brep import as_array
from ..util import Progress, report, smoothstep
from ..brep.tessellation import TESSELLATION, FaceMesh, PartMesh, part_tessellation
from ..targets.mesh import _gradient

__all__ = ["texture_any_faces", "face_list", "FADE_FULL", "FADE_ZERO", "FLOOR_CURVED"]

#: Local texture scale (either direction, or its inverse) down to which the full height is kept.
FADE_FULL = 0.55
#: ... and at which the height has faded to 0 (smoothstep between).
FADE_ZERO = 0.3
#: mm: the relief stays at least this far above a face inside its ramp (no tangential contact).
FLOOR_CURVED = 0.01
#: Tangent edges: faces whose normals differ by less than this across their common
#: edge (degrees) are one patch.
SMOOTH_ANGLE = 12.0
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
    """One patch: the texture grid on it, its heights and limits (module docstring,
    steps 2-4) and the bodies that put it on the part (step 5)."""
    from ..mapping import measure_distortion

    g = _patch_grid(pm, patch, tex, opts)
    surf = _surfaces(g, opts)
    lim = _limit_surface(g, surf, opts) if opts["build_dir"] is not None else None
    if not _textured(surf, g["keep"]).any():
        raise GeometryError(
            f"no texture is left on the face(s) {patch}: too small or narrow for the {g['d_floor']:.2f} mm border band at "
            f"{g['px']:.3g} mm pitch (or faded / limited away); use a smaller pitch or a larger face"
        )
    grid, keep = g["grid"], g["keep"]
    faded = (g["fade"] < 1.0) & (g["H"] > 1e-6) & keep & (g["d"] > g["d_floor"])
    dist = measure_distortion(grid, keep & (g["fade"] > 0))
    dist = type(dist)(dist.x, dist.y, float(faded.sum() / max(keep.sum(), 1)))
    bodies = _bodies(g, surf, opts)
    s_top = surf["surface"]
    info = {
        "faces": [int(i) for i in patch],
        "kinds": [pm.faces[i].kind for i in patch],
        "parameterization": g["par"].method,
        "grid": tuple(grid.valid.shape),
        "period_y": g["par"].period_y,
        "distortion": dist.to_dict(),
        "faded_fraction": dist.faded_fraction,
        "curvature_limited_points": int(surf["limited"].sum()),
        "max_height": float(np.where(keep, s_top, 0).max()),
        "mode": opts.get("mode", "raised"),
        "triangles": {"grid": 2 * int(g["cells"].sum()), "mesh": bodies["top_triangles"]},
        "max_error_mm": bodies["error"],
    }
    if surf["c"] > 0:
        info["max_depth"] = float(-np.where(keep, s_top, 0).min())
    if lim is not None:
        info["overhang_limit"] = lim
    shown = np.where(keep, s_top, 0.0)
    shown = np.maximum(shown, 0.0) if surf["c"] == 0 else np.where(keep, shown - shown[keep].min(), 0.0)
    hmap = Heightmap(shown.astype(np.float32), (g["px"], g["py"]))
    return {"slab": bodies["slab"], "cutter": bodies["cutter"], "low_cutter": bodies["low_cutter"], "info": info,
            "distortion": dist, "heightmap": hmap, "grid": grid, "limited": bool(surf["limited"].any()),
            "h_top": s_top, "signed": surf["c"] > 0, "cells": g["cells"], "max_error": bodies["error"],
            "tables": g["par"].tables, "face": pm.faces[patch[0]].face if len(patch) == 1 else None}


def _patch_grid(pm: PartMesh, patch: list[int], tex: Any, opts: dict) -> dict:
    """Parameterize the patch, lay the texture grid, sample the texture, and the
    envelope the heights may use: the M-I ramp and the fade (module docstring)."""
    from ..mapping import cell_mask, concave_convex, lay_grid, point_scales

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
    concave, convex = concave_convex(grid)
    keep = grid.valid & (d >= d_keep)
    gain = _gradient(grid.points.reshape(-1, 3), opts.get("gradient")).reshape(d.shape)
    return {"par": par, "grid": grid, "H": H, "px": px, "py": py, "diag": diag, "d": d, "fade": fade, "ramp": ramp,
            "concave": concave, "convex": convex, "d_keep": d_keep, "d_floor": d_floor, "keep": keep, "gain": gain,
            "cells": cell_mask(keep, grid.wrap_y)}


def _surfaces(g: dict, opts: dict) -> dict:
    """The textured surface as a signed offset ``s`` (mm along the normal) of the face.

    Raised (``c = 0``): ``s = max(h, FLOOR_CURVED)`` inside, dipping ``sink`` mm into
    the body along the outline band. With the envelope ``E = min(H_max fade, ramp)``
    and ``h = min(H fade, ramp)``, engraved (``c = 1``) and centred (``c = 1/2``) give
    ``s = g (h - c E)`` (``g`` the depth gradient), cut ``FLOOR_CURVED`` below the
    face where it would be at or above it (engraved) and ``2 FLOOR_CURVED`` along the
    outline band. Heights above the face are capped at ``0.9 / kappa`` on concave
    sides, depths below it at ``0.9 / kappa`` on convex ones (self-intersection)."""
    from ..targets.mesh import MODES

    mode = opts.get("mode", "raised")
    if mode not in MODES:
        raise ParameterError(f"mode {mode!r}: use raised, engraved or centred")
    c = MODES[mode]
    jit = float(opts.get("jitter", 0.0))  # mm: a retry after a union that pinched (see welded)
    floor_c = FLOOR_CURVED + jit
    hcap = 0.9 / np.maximum(g["concave"], 1e-9)
    dcap = 0.9 / np.maximum(g["convex"], 1e-9)
    depth = np.minimum(opts["depth"], dcap)
    band = g["d"] < g["d_floor"]
    h = np.minimum(g["H"] * g["fade"], g["ramp"]) * g["gain"]
    if c == 0:
        limited = (h > hcap) & g["grid"].valid
        h = np.minimum(h, hcap)
        sink = np.minimum(0.05 + 2 * jit, 0.5 * depth)
        blend = np.interp(g["d"], [g["d_keep"], g["d_floor"]], [0.0, 1.0])
        s = np.where(band, -sink + blend * (sink + floor_c), np.maximum(h, floor_c))
        floor = np.minimum(s, floor_c)
    else:
        env = np.minimum(opts["height"] * g["fade"], g["ramp"]) * g["gain"]
        t = h - c * env
        limited = ((t > hcap) | (t < -dcap)) & g["grid"].valid
        t = np.clip(t, -dcap, hcap)
        s = np.where(band, -2 * floor_c, np.minimum(t, -floor_c) if c == 1 else t)
        floor = np.where(band, s, -floor_c if c == 1 else 0.0)
        sink = 0.05 + 2 * jit
    return {"surface": s, "floor": floor, "c": c, "depth": depth, "limited": limited, "floor_c": floor_c,
            "sink": sink, "band": band, "env": (None if c == 0 else env)}


def _textured(surf: dict, keep: np.ndarray) -> np.ndarray:
    """Grid points where a texture is left (after the limiter): above the floor
    (raised) or off the face by more than it (engraved, centred)."""
    s, fc = surf["surface"], surf["floor_c"]
    return keep & ((s > fc + 1e-6) if surf["c"] == 0 else (np.abs(s) > fc + 1e-6))


def _limit_surface(g: dict, surf: dict, opts: dict) -> dict:
    """The overhang limiter on the textured surface (in place); its report."""
    before = surf["surface"].copy()
    s, rounds, base_over, remaining = _limit_overhangs_grid(
        g["grid"].points, g["grid"].normals, surf["surface"], g["cells"], g["grid"].wrap_y, opts["build_dir"],
        opts["critical_angle"], surf["floor"]
    )
    surf["surface"] = s
    removed = np.abs(before - s)
    return {"removed_volume_mm3": float(removed.sum() * g["px"] * g["py"]), "max_removed_mm": float(removed.max()),
            "rounds": rounds, "touched_fraction": float((removed > 1e-6).mean()), "surface_overhang": bool(base_over.any()),
            "remaining_overhang_mm2": remaining}


#: mm: how far outside the face an engraving's cutter starts (beyond the tessellation's chord error).
CUT_ABOVE = 0.05
#: mm: the lean mesh keeps the face itself (chord error) within this, so the relief
#: never dips under the part's own tessellation where it lies flat on the face.
BASE_TOLERANCE = 0.005


#: Largest share of the grid's triangles a lean relief may keep (else the grid is used):
#: above it the union gains little over the cost of the triangulation.
LEAN_FRACTION = 0.8
#: mm: the slab's bottom (inside the part, never seen) is triangulated within this
#: (by the refinement's own estimate; it lies ``depth`` mm inside the part).
BOTTOM_TOLERANCE = 0.05


def _bodies(g: dict, surf: dict, opts: dict) -> dict:
    """The bodies that put the texture on: a slab to add (raised, centred) and a
    cutter to subtract (engraved, centred). Their textured side is lean
    (:func:`texcad.solid.lean_grid`) within ``tolerance`` mm of the grid where that
    saves triangles; their other side, inside the part or outside it, is always lean
    (within :data:`BOTTOM_TOLERANCE`), with the same outline."""
    grid, cells = g["grid"], g["cells"]
    P, N = grid.points, grid.normals
    s, c, fc = surf["surface"], surf["c"], surf["floor_c"]
    tol = float(opts.get("tolerance", 0.0))
    tex_tri, err = _lean_relief(g, surf, tol, opts)
    if tex_tri is None:
        tex_tri = _cell_triangles(cells, grid.wrap_y)
    ring = _outline_ring(cells, grid.wrap_y)

    def body(textured, plain, textured_on_top: bool, plain_tol: float):
        plain_tri = _relief_triangles(dict(g, fine=ring), [plain], plain_tol, [1.0], lean=True, measure=False)[0]
        plain_tri = _cell_triangles(cells, grid.wrap_y) if plain_tri is None else plain_tri
        tt, bt, to, bo = (tex_tri, plain_tri, textured, plain) if textured_on_top else (plain_tri, tex_tri, plain, textured)
        return _slab(P + to[..., None] * N, P + bo[..., None] * N, tt, bt)

    inside = min(BOTTOM_TOLERANCE, 0.2 * float(np.min(surf["depth"])))  # a slab's bottom, depth mm in the part
    outside = 0.25 * (CUT_ABOVE - TESSELLATION)  # a cutter's top, CUT_ABOVE mm out: clear of the part's facets
    slab = cutter = low = None
    if c == 0:
        slab = body(s, -surf["depth"], True, inside)
    else:
        cut_bottom = np.minimum(s, -fc) - (fc if c < 1 else 0.0)
        above = np.full(s.shape, CUT_ABOVE)
        cutter = body(cut_bottom, above, False, outside)
        low = body(np.minimum(-c * surf["env"], -fc) - 2 * fc, above, False, outside)
        if c < 1:
            slab = body(np.where(surf["band"], -surf["sink"], s), np.minimum(-surf["depth"], cut_bottom - 0.05), True, inside)
    return {"slab": slab, "cutter": cutter, "low_cutter": low, "error": err, "top_triangles": len(tex_tri)}


def _lean_relief(g: dict, surf: dict, tol: float, opts: dict):
    """The textured side's lean triangles (or ``(None, 0.0)``: the grid). With
    ``build_dir``, a lean triangle that overhangs where the face under it does not
    (the limiter made the grid safe, not every plane through its points) has the
    cells under it kept at grid resolution, and the triangulation is made again."""
    heights, weights = [surf["surface"], np.zeros_like(surf["surface"])], [1.0, tol / BASE_TOLERANCE]
    tri, err = _relief_triangles(g, heights, tol, weights, lean=True)
    if opts["build_dir"] is None or tri is None:
        return tri, err
    more = np.zeros_like(g["cells"])
    for _ in range(4):  # per round of refinement where a lean facet overhangs
        bad = _overhanging_cells(g, surf["surface"], tri, opts["build_dir"], opts["critical_angle"])
        if bad is None:
            return tri, err
        more |= bad
        tri, err = _relief_triangles(dict(g, more_fine=more), heights, tol, weights, lean=True)
        if tri is None:
            return None, 0.0
    return None, 0.0


def _overhanging_cells(g: dict, s: np.ndarray, tri: np.ndarray, dirs: np.ndarray, critical_angle: float):
    """Cells ``(R-1, C-1)`` (or ``(R, C-1)`` around a seam) under the lean triangles
    that overhang (``-n . d > cos(critical + 1 deg)``) where the face does not; None
    if there are none."""
    grid = g["grid"]
    P, N = grid.points.reshape(-1, 3), grid.normals.reshape(-1, 3)
    V = P + s.reshape(-1)[:, None] * N
    n = np.cross(V[tri[:, 1]] - V[tri[:, 0]], V[tri[:, 2]] - V[tri[:, 0]])
    base = N[tri].mean(axis=1)
    n *= np.sign((n * base).sum(axis=1, keepdims=True))  # outward, along the face's normal
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-18)
    base /= np.maximum(np.linalg.norm(base, axis=1, keepdims=True), 1e-18)
    cos_c = np.cos(np.radians(critical_angle + 1.0))
    bad = np.any(-(n @ dirs.T) > cos_c, axis=1) & ~np.any(-(base @ dirs.T) > cos_c, axis=1)
    if not bad.any():
        return None
    R, C = grid.valid.shape
    rows, cols = tri[bad] // C, tri[bad] % C
    if grid.wrap_y:  # a triangle across the seam has rows 0 and R-1: its cells are the last row
        rows = np.where((rows.max(axis=1, keepdims=True) - rows.min(axis=1, keepdims=True)) > R // 2, np.where(rows == 0, R, rows), rows)
    r0, c0 = rows.min(1), cols.min(1)
    r1, c1 = np.maximum(rows.max(1), r0 + 1), np.maximum(cols.max(1), c0 + 1)
    shape = g["cells"].shape
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


def _relief_triangles(g: dict, heights: list, tolerance: float, weights: list, lean: bool, measure: bool = True):
    """``(faces, error_mm)``: a lean triangulation of the grid's cells following the
    surfaces ``P + h N`` for ``h`` in ``heights`` (flat grid indices, ``(M, 3)``), or
    ``(None, 0.0)`` for the grid itself (tolerance 0, the overhang limiter on, or no
    saving). Cells marked ``g["fine"]`` (default: within two pixel diagonals of the
    outline band, where the union's intersection with the part runs) stay at the
    grid's resolution, and so do the rows along a closed face's seam."""
    from ..solid import lean_grid

    if tolerance <= 0 or not lean:
        return None, 0.0
    grid, cells = g["grid"], g["cells"]
    P, N = grid.points, grid.normals
    R, C = P.shape[:2]
    if "fine" in g:
        fine = g["fine"]
    else:
        near = g["d"] < g["d_floor"] + 2 * g["diag"]
        near = np.concatenate([near, near[:1]]) if grid.wrap_y else near
        fine = near[:-1, :-1] | near[1:, :-1] | near[:-1, 1:] | near[1:, 1:]
        fine = fine | g["more_fine"] if "more_fine" in g else fine
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
# The faces of a part
# ------------------------------------------------------------------------------------------
def _face_indices(pm: PartMesh, topo, faces: list) -> list[int]:
    from OCP.TopAbs import TopAbs_FACE

    from ..brep import to_topods

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


#: mm: vertices of the union closer than this (one cell of a grid this fine) are one.
WELD = 1e-5


def welded(man) -> "Mesh | None":
    """The union's mesh with vertices within :data:`WELD` mm merged (as an STL reader
    or a mesh tool that merges by position does), the zero-area needles manifold3d
    sometimes leaves along a cut edge (a triangle with two vertices at one position)
    and the flat pillows two booleans can leave (two triangles on the same three
    vertices, facing apart) dropped; None unless every edge then lies on exactly two
    triangles, opposite ways. When no two vertices are that close, the mesh is
    manifold3d's own (a closed, oriented 2-manifold) and is taken as it is."""
    out = man.to_mesh()
    v = np.asarray(out.vert_properties)[:, :3].astype(np.float32)
    f = np.asarray(out.tri_verts).astype(np.int64)
    q = np.round(v.astype(np.float64) / WELD).astype(np.int64)
    order = np.lexsort((q[:, 2], q[:, 1], q[:, 0]))
    sq = q[order]
    new = np.ones(len(v), bool)
    new[1:] = np.any(sq[1:] != sq[:-1], axis=1)
    if new.all():
        mesh = Mesh(np.ascontiguousarray(v), f.astype(np.uint32))
        mesh.__dict__["is_watertight"] = True
        return mesh
    inv = np.empty(len(v), np.int64)
    inv[order] = np.cumsum(new) - 1
    uniq = v[order][new]
    f = inv[f]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    f = _drop_pillows(f)
    if not len(f) or not edge_report(f)["watertight"]:  # every edge on two triangles, opposite ways
        return None
    used = np.unique(f)
    remap = np.full(len(uniq), -1, np.int64)
    remap[used] = np.arange(len(used))
    mesh = Mesh(np.ascontiguousarray(uniq[used]), remap[f].astype(np.uint32))
    mesh.__dict__["is_watertight"] = True
    return mesh


def _drop_pillows(f: np.ndarray) -> np.ndarray:
    """``f`` without the pairs of triangles on the same three vertices (zero volume)."""
    key = np.sort(f, axis=1)
    _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return f[count[inv.ravel()] == 1]


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
    from ..brep import solids_of

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
    n_tri = sum(b.num_triangles for r in reliefs for b in (r["slab"], r["cutter"]) if b is not None)
    report(progress, 0.7, f"fusing {n_tri} texture triangles onto the part (manifold3d)")
    base_man = to_manifold(base)
    want = len(base_man.decompose())
    for attempt in range(3):  # a union whose output pinches (two sheets along an edge) is redone, nudged
        fused_man = _apply(base_man, reliefs)
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
        lows = [to_manifold(r["low_cutter"]) for r in reliefs if r["low_cutter"] is not None]
        lowest = m3d.Manifold.batch_boolean([base_man] + lows, m3d.OpType.Subtract) if lows else base_man
        return from_manifold(fused_man - lowest)

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
        "max_error": max(r["max_error"] for r in reliefs),
        "textured_area": float(sum(r["cells"].sum() * np.prod(r["heightmap"].pitch) for r in reliefs)),
        "reliefs": reliefs,  # for the B-rep (texcad.pipeline.cad: texcad.brep.uv_textured_solid)
    }


def _apply(base_man, reliefs: list):
    """``(base - cutters) + slabs`` (manifold3d); checked."""
    import manifold3d as m3d

    cutters = [to_manifold(r["cutter"]) for r in reliefs if r["cutter"] is not None]
    slabs = [to_manifold(r["slab"]) for r in reliefs if r["slab"] is not None]
    man = m3d.Manifold.batch_boolean([base_man] + cutters, m3d.OpType.Subtract) if cutters else base_man
    if slabs:
        man = m3d.Manifold.batch_boolean([man] + slabs, m3d.OpType.Add)
    if man.status() != m3d.Error.NoError or man.is_empty():
        raise GeometryError(f"the union of texture and part failed (manifold3d: {man.status().name})")
    return man
