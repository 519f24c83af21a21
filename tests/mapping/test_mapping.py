"""Mapping textures onto 2.5D surfaces (issue 4; paper section 2.2, algorithms 1, 2).

Every geometric claim is checked independently of the code that makes it true:

* arc length against the closed forms (circle ``rho = R theta``, eq. 8; sine through
  the elliptic integral of the second kind, eq. 13) or OCCT's own length integrator;
* watertightness with trimesh and manifold3d;
* self-intersection by slicing the emitted mesh with planes ``y = const``
  (trimesh) and testing every pair of section segments for a proper crossing;
  the checker is itself shown to catch a real fold;
* volumes of the fused part against the base plus the texture volume integrated
  from the grids' cross-sections.
"""

from __future__ import annotations

import warnings

import manifold3d as m3d
import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree
from scipy.special import ellipeinc

from texcad import Heightmap, TexcadWarning
from texcad.errors import GeometryError, ParameterError
from texcad.mapping import fit_texture, map_texture, slab_mesh
from texcad.pipeline import textured_surface
from texcad.solid import to_manifold
from texcad.mapping import Profile, Surface

# -- independent checks ------------------------------------------------------------------


def _tm(mesh) -> trimesh.Trimesh:
    return trimesh.Trimesh(np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces), process=False)


def assert_watertight(mesh) -> None:
    """trimesh: closed, consistently wound, positive volume; manifold3d: no error."""
    t = _tm(mesh)
    assert t.is_watertight and t.is_winding_consistent, "not a closed oriented 2-manifold (trimesh)"
    assert t.volume > 0
    man = m3d.Manifold(m3d.Mesh(vert_properties=np.asarray(mesh.vertices, np.float32), tri_verts=np.asarray(mesh.faces, np.uint32)))
    assert man.status() == m3d.Error.NoError
    assert abs(man.volume() - t.volume) <= 1e-4 * t.volume


def section_crossings(mesh, ys) -> int:
    """Proper crossings between segments of the mesh's sections ``y = const``.

    A closed triangle mesh whose vertices all lie on a few planes ``y = y_r`` (as a
    mapped slab's do) cuts every plane in between into closed polylines; the mesh
    intersects itself there iff two segments of a section cross. Touching at shared
    end points (neighbouring triangles) is not a crossing.
    """
    t = _tm(mesh)
    total = 0
    for y in ys:  # one section per plane
        seg = trimesh.intersections.mesh_plane(t, [0.0, 1.0, 0.0], [0.0, float(y), 0.0])[:, :, [0, 2]]
        if len(seg) < 2:
            continue
        a, b = seg[:, 0], seg[:, 1]
        ln = np.linalg.norm(b - a, axis=1)
        i, j = cKDTree(0.5 * (a + b)).query_pairs(float(ln.max()) + 1e-9, output_type="ndarray").T
        d1, d2 = b[i] - a[i], b[j] - a[j]
        w = a[j] - a[i]
        den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
        ok = np.abs(den) > 1e-12 * ln[i] * ln[j]
        with np.errstate(divide="ignore", invalid="ignore"):
            u = (w[:, 0] * d2[:, 1] - w[:, 1] * d2[:, 0]) / den
            v = (w[:, 0] * d1[:, 1] - w[:, 1] * d1[:, 0]) / den
        # Neighbouring segments (a shared end point) touch, they do not cross.
        ends_i, ends_j = seg[i][:, :, None, :], seg[j][:, None, :, :]
        touching = (np.linalg.norm(ends_i - ends_j, axis=-1) < 1e-6).any(axis=(1, 2))
        eps = 1e-9
        total += int(np.count_nonzero(ok & ~touching & (u > eps) & (u < 1 - eps) & (v > eps) & (v < 1 - eps)))
    return total


def between_rows(y: np.ndarray, k: int = 12) -> np.ndarray:
    """Planes strictly between the grid rows (every slab face is cut there), spread
    over the whole extrusion."""
    idx = np.unique(np.linspace(0, len(y) - 2, k).astype(int))
    return np.concatenate([y[idx] + 0.5 * (y[idx + 1] - y[idx]), y[idx] + 0.1 * (y[idx + 1] - y[idx])])


def assert_no_self_intersection(mesh, y: np.ndarray) -> None:
    assert section_crossings(mesh, between_rows(y)) == 0


# -- the five profiles of the issue --------------------------------------------------------
R_CYL = 20.0
SINE = dict(amplitude=5.0, period=50.0, width=100.0)


def _closed_spline():
    from build123d import BuildLine, Plane, Spline

    with BuildLine(Plane.XZ) as bl:
        Spline((0, 0), (30, -5), (50, 10), (35, 30), (5, 25), periodic=True)
    return bl.line


def _hook():
    """A non-function open spline: it turns back over itself in x (paper, Fig. 8)."""
    from build123d import Spline

    return Spline((0, 0), (40, 5), (55, 25), (40, 40), (25, 32))


def _surface(kind: str, length: float) -> Surface:
    if kind == "plane":
        return Surface.plate(100.0, length, 5.0)
    if kind == "cylinder":
        return Surface.cylinder(R_CYL, length, 5.0)
    if kind == "sine":
        return Surface.sine(length=length, thickness=5.0, **SINE)
    if kind == "closed_spline":
        return Surface.from_profile(_closed_spline(), length)
    if kind == "non_function":
        return Surface.from_profile(_hook(), length, thickness=5.0)
    raise AssertionError(kind)


def _arclen_closed_form(kind: str, prof: Profile, pts: np.ndarray) -> np.ndarray | None:
    """Arc length from the profile's start to points on it, by closed form (mm)."""
    if kind == "plane":
        return pts[:, 0]
    if kind == "cylinder":
        theta = np.arctan2(pts[:, 1], pts[:, 0])  # starts at theta = 0, runs clockwise
        return np.mod(-theta, 2 * np.pi) * R_CYL  # eq. 8: rho = R theta
    if kind == "sine":
        a, lp = SINE["amplitude"], SINE["period"]
        k = 2 * np.pi * a / lp
        m = k * k / (1 + k * k)  # eq. 12
        return lp / (2 * np.pi) * np.sqrt(1 + k * k) * ellipeinc(2 * np.pi * pts[:, 0] / lp, m)  # eq. 13
    return None


def _occt_arclen(edge, pts: np.ndarray, *, drawn_on_xy: bool) -> np.ndarray:
    """Arc length along a build123d edge from its start to points ``(x, z)`` on the
    profile (OCCT's projection and length integrator; test only)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.GeomAPI import GeomAPI_ProjectPointOnCurve
    from OCP.gp import gp_Pnt

    ad = BRepAdaptor_Curve(edge.wrapped)
    curve = BRep_Tool.Curve_s(edge.wrapped, 0.0, 1.0)  # with the edge's location applied
    zero = np.zeros(len(pts))
    xyz = np.stack([pts[:, 0], pts[:, 1], zero] if drawn_on_xy else [pts[:, 0], zero, pts[:, 1]], 1)
    out = []
    for p in xyz:  # a few dozen points, test only
        proj = GeomAPI_ProjectPointOnCurve(gp_Pnt(*map(float, p)), curve)
        assert proj.LowerDistance() < 1e-4
        out.append(GCPnts_AbscissaPoint.Length_s(ad, ad.FirstParameter(), proj.LowerDistanceParameter(), 1e-10))
    return np.array(out)


def _texture(cols: int, rows: int, pitch: float, height: float, seed: int = 0) -> Heightmap:
    """A random smooth texture whose first row is zero (row 0 of the mapped grid is
    then the profile itself) and that tiles in x."""
    rng = np.random.default_rng(seed)
    x = (np.arange(cols) + 0.5) / cols * 2 * np.pi
    h = np.zeros((rows, cols))
    for k in range(1, 6):  # a few harmonics, periodic in x
        h += rng.uniform(0, 1) * (1 + np.sin(k * x[None, :] + rng.uniform(0, 6) + 0.7 * k * np.arange(rows)[:, None] / rows * 6))
    h[0] = 0.0
    h = h / h.max() * height
    return Heightmap(h.astype(np.float32), (pitch, pitch))


CASES = ("plane", "cylinder", "sine", "closed_spline", "non_function")
LENGTH = 6.0  # extrusion in the tests, mm


@pytest.fixture(scope="module")
def surfaces():
    return {k: _surface(k, LENGTH) for k in CASES}


def _mapped(surf: Surface, mapping: str, pitch: float = 0.5, height: float = 1.0):
    prof = surf.profile
    cols = int(np.floor(prof.length / pitch)) if prof.closed else int(np.floor(0.97 * prof.length / pitch))
    px = prof.length / cols if prof.closed else pitch  # closed: whole pixels around
    hm = _texture(cols, int(LENGTH / pitch) - 1, px, height)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        return hm, map_texture(prof, hm, mapping=mapping, length=LENGTH, depth=0.5, periodic_x=prof.closed)


@pytest.mark.parametrize("mapping", ["distance", "angle"])
@pytest.mark.parametrize("kind", CASES)
def test_mapping_on_the_five_profiles(surfaces, kind, mapping):
    surf = surfaces[kind]
    prof = surf.profile
    hm, ms = _mapped(surf, mapping)
    top = ms.top.astype(np.float64)
    rows, cols = top.shape[:2]
    px = hm.pitch[0]

    # 1. Texture x -> arc length (eq. 4): row 0 has height 0, so its vertices are
    # the profile points the texture columns were mapped to. Their arc length by
    # closed form (or OCCT) equals the texture coordinate within 1 um.
    base = top[0][:, [0, 2]]
    s_tex = ms.s
    s_ref = _arclen_closed_form(kind, prof, base)
    if s_ref is None:
        # No closed form for splines: OCCT's own arc-length integrator.
        closed_spline = kind == "closed_spline"
        edge = (_closed_spline() if closed_spline else _hook()).edges()[0]
        pick = np.linspace(0, cols - 1, 40).astype(int)
        s_occ = _occt_arclen(edge, base[pick], drawn_on_xy=not closed_spline)
        if prof.closed:
            # Same curve, possibly started elsewhere and run the other way
            # (outward orientation): compare modulo the perimeter, both senses.
            def wrap(e):
                return np.abs(np.mod(e + prof.length / 2, prof.length) - prof.length / 2)

            errs = [wrap(sg * s_occ - s_tex[pick] - (sg * s_occ[0] - s_tex[pick[0]])) for sg in (1, -1)]
            err = min(errs, key=lambda e: e.max())
            assert abs(edge.length - prof.length) < 1e-3
        else:
            err = np.abs(s_occ - s_tex[pick])
    else:
        err = np.abs(s_ref - s_tex)
        if prof.closed:
            err = np.minimum(err, prof.length - err)
    assert prof.length >= 100.0 - 1e-9  # "over 100 mm"
    assert err.max() < 1e-3, f"arc-length error {err.max() * 1e3:.3f} um"

    # 2. Physical scale along the distance-preserving direction: successive
    # columns are one pixel apart along the surface, within 0.5 % (float32 grid).
    if s_ref is not None:
        ds = np.diff(np.unwrap(s_ref, period=prof.length) if prof.closed else s_ref)
        assert np.abs(ds / px - 1).max() < 0.005
    assert abs(ms.x_scale - 1) < 0.005
    span = float(np.sum(np.linalg.norm(np.diff(base, axis=0), axis=1)))  # chord sum ~ arc length
    assert abs(span / ((cols - 1) * px) - 1) < 0.005

    # 3. Height direction: along z (algorithm 1) or the normal (algorithm 2).
    d = top[1:] - top[:1]
    h = hm.heights[1:].astype(np.float64) * ms.factor[None, :]
    if mapping == "distance":
        assert np.abs(d[..., 0]).max() < 1e-5
        assert np.allclose(np.abs(d[..., 2]), h, atol=2e-5)
        # Upward-looking pieces go up, downward-looking ones down (sign of n_z).
        nz = prof.at(ms.s).normal[:, 1]
        moved = h > 1e-3
        assert np.all(np.sign(d[..., 2])[moved] == np.sign(nz)[None, :].repeat(rows - 1, 0)[moved])
    else:
        n = prof.at(ms.s).normal
        along = d[..., 0] * n[None, :, 0] + d[..., 2] * n[None, :, 1]
        across = d[..., 0] * n[None, :, 1] - d[..., 2] * n[None, :, 0]
        assert np.allclose(along, h, atol=2e-5) and np.abs(across).max() < 2e-5

    # 4. Watertight slab, zero seam gap, no self-intersection.
    slab = ms.solid()
    assert_watertight(slab)
    if prof.closed:
        assert_zero_seam(slab, rows, cols)
    assert_no_self_intersection(slab, ms.y)


def assert_zero_seam(slab, rows: int, cols: int) -> None:
    """The seam is closed on shared vertices: no two vertices coincide (nothing was
    duplicated at s = 0), the last column is joined to the first by faces, and the
    mesh has no boundary edge (trimesh watertight, checked by the caller)."""
    v = np.asarray(slab.vertices, np.float64)
    assert len(cKDTree(v).query_pairs(1e-6)) == 0
    f = np.asarray(slab.faces).astype(np.int64)
    idx = np.arange(rows * cols).reshape(rows, cols)
    last, first = set(idx[:, -1].tolist()), set(idx[:, 0].tolist())
    tex = f[np.asarray(slab.groups["texture"])]
    joined = tex[np.isin(tex, idx[:, -1]).any(1) & np.isin(tex, idx[:, 0]).any(1)]
    assert len(joined) == 2 * (rows - 1)  # one quad per row band across the seam
    assert all(set(fc.tolist()) <= last | first for fc in joined)
    # Every edge is shared by exactly two faces: nothing open at the seam.
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)


@pytest.mark.parametrize("kind,mapping", [("cylinder", "angle"), ("sine", "distance"), ("non_function", "distance"), ("closed_spline", "angle")])
def test_fused_on_curved_base_is_watertight_and_volume_consistent(surfaces, kind, mapping):
    surf = surfaces[kind]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        part = textured_surface(surf, "builtin:pins", height=1.0, mapping=mapping, pitch=0.5)
    assert_watertight(part.mesh)
    assert_watertight(part.texture_mesh)
    ms = part.mapped
    # Texture volume above the profile from the grids: the area of every row's
    # cross-section between the textured polyline and the profile polyline
    # (shoelace), integrated along y (trapezoid). Independent of manifold3d.
    top = ms.top.astype(np.float64)
    prof = surf.profile
    base = prof.point(ms.s)
    areas = []
    for r in range(top.shape[0]):  # one cross-section per row
        t = top[r][:, [0, 2]]
        if prof.closed:
            a = abs(_shoelace(t)) - abs(_shoelace(base))
        else:
            a = abs(_shoelace(np.concatenate([t, base[::-1]])))
        areas.append(a)
    v_tex = float(np.trapezoid(areas, ms.y)) if hasattr(np, "trapezoid") else float(np.trapz(areas, ms.y))
    base_v = part.base_mesh.volume
    assert part.mesh.volume == pytest.approx(base_v + v_tex, rel=0.01, abs=0.02 * v_tex)
    # Inclusion-exclusion with the slab (the slab's bottom lies inside the base).
    overlap = (to_manifold(part.texture_mesh) ^ to_manifold(part.base_mesh)).volume()
    assert part.mesh.volume == pytest.approx(base_v + part.texture_mesh.volume - overlap, rel=1e-3)
    # The overlap is the band the slab reaches into the base: depth x width x length.
    band = 0.5 * (ms.s[-1] - ms.s[0] if not prof.closed else prof.length) * (ms.y[-1] - ms.y[0])
    assert overlap == pytest.approx(band, rel=0.15)


def _shoelace(p: np.ndarray) -> float:
    return 0.5 * float(np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1]))


# -- intersection analysis ---------------------------------------------------------------
def _fillet_step(radius: float = 1.0):
    """A step up with a tight concave fillet at its foot (and a convex one on top)."""
    from build123d import Wire

    w = Wire.make_polygon([(0, 0, 0), (20, 0, 0), (20, 0, 15), (40, 0, 15)], close=False)
    return w.fillet_2d(radius, w.vertices()[1:3])


def test_checker_catches_a_real_fold():
    """Without the limit, h = 2 mm along the normal folds inside the 1 mm concave
    fillet (h kappa = 2 >= 1): the section checker must see it."""
    prof = Profile.from_cad(_fillet_step())
    s = np.linspace(0.1, prof.length - 0.1, 600)
    f = prof.at(s)
    assert f.curvature.min() == pytest.approx(-1.0, rel=1e-3)  # concave, R = 1 mm
    y = np.array([0.0, 1.0, 2.0])
    top = np.empty((3, len(s), 3))
    top[..., 0] = f.point[:, 0] + 2.0 * f.normal[:, 0]
    top[..., 2] = f.point[:, 1] + 2.0 * f.normal[:, 1]
    top[..., 1] = y[:, None]
    bottom = np.empty((2, len(s), 3))
    nb = _smooth_normals(f.normal, 40)
    bottom[..., 0] = f.point[:, 0] - 0.3 * nb[:, 0]
    bottom[..., 2] = f.point[:, 1] - 0.3 * nb[:, 1]
    bottom[..., 1] = y[[0, -1]][:, None]
    # End columns made planar as slab_mesh requires.
    for k in (0, -1):
        top[:, k, [0, 2]] = f.point[k] + 2.0 * f.normal[k]
        bottom[:, k, [0, 2]] = f.point[k] - 0.3 * f.normal[k]
    folded = slab_mesh(top, bottom)
    assert section_crossings(folded, [0.5, 1.5]) > 0


def _smooth_normals(n: np.ndarray, k: int) -> np.ndarray:
    ker = np.ones(2 * k + 1) / (2 * k + 1)
    out = np.stack([np.convolve(np.pad(n[:, i], k, mode="edge"), ker, "valid") for i in range(2)], 1)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


@pytest.mark.parametrize("mapping", ["angle", "distance"])
def test_tight_concave_fillet_is_limited_with_a_warning(mapping):
    prof = Profile.from_cad(_fillet_step(1.0))
    with pytest.warns(TexcadWarning, match="limited") if mapping == "angle" else warnings.catch_warnings():
        part = textured_surface(prof, "builtin:pins", length=6.0, height=2.0, mapping=mapping, pitch=0.25)
    ms = part.mapped
    assert_watertight(part.texture_mesh)
    assert_watertight(part.mesh)
    assert_no_self_intersection(part.texture_mesh, ms.y)
    if mapping == "angle":
        lim = part.height_limits
        assert lim, "the fold at h kappa >= 1 must be detected"
        # Placed at the fillet (centre (19, 1)), and cut below the 1 mm radius.
        assert any(abs(L.point[0] - 19.7) < 1.5 and abs(L.point[1] - 0.3) < 1.5 for L in lim)
        assert min(L.height for L in lim) < 1.0
        fill = np.flatnonzero(np.abs(ms.s - (20.0 - 1.0 + np.pi / 4)) < 0.3)
        assert np.all(ms.factor[fill] * 2.0 < 1.0)  # h_applied * kappa < 1 in the fillet
    else:
        # Distance mode: the vertical wall is a division between function pieces;
        # the texture fades out there and the pieces stay apart.
        wall = np.flatnonzero((ms.s > 22.0) & (ms.s < 33.0))
        assert np.all(ms.factor[wall] < 1e-9)


@pytest.mark.parametrize("mapping", ["distance", "angle"])
def test_pieces_facing_each_other_do_not_collide(mapping):
    """A slot 3 mm high, textured inside: a downward-looking piece above an
    upward-looking one (a non-function profile split at the vertical back wall).
    2 mm of texture from both sides would collide; the height is cut (to 0.4 of the
    gap each, below half of it) and a warning says where. The base under the three
    pieces is one body (a band swept from each segment, joined along areas: the
    smoothed offset crossed itself and left three bodies meeting along edges only,
    non-manifold by position once fused)."""
    from texcad.solid.overlap import split_bodies

    prof = Profile.polyline([(20, 3), (0, 3), (0, 0), (20, 0)])
    assert [p.facing for p in prof.function_pieces()] == [-1, 0, 1]
    base = prof.base_body(4.0)
    assert len(split_bodies(np.asarray(base.vertices, np.float64), np.asarray(base.faces, np.int64)).volumes) == 1
    with pytest.warns(TexcadWarning, match="limited"):
        part = textured_surface(prof, "builtin:pins", length=4.0, height=2.0, mapping=mapping, pitch=0.2)
    assert_watertight(part.mesh)
    assert_no_self_intersection(part.texture_mesh, part.mapped.y)
    assert part.height_limits and max(L.height for L in part.height_limits) <= 1.5 + 1e-9
    # The two textures keep clear of each other: in every section, the highest
    # point of the lower texture stays below the lowest point of the upper one.
    top = part.mapped.top
    lower = top[:, :, 2][:, part.mapped.s > 23 + 8]
    upper = top[:, :, 2][:, part.mapped.s < 20 - 8]
    assert lower.max() < upper.min()


@pytest.mark.parametrize("mapping", ["distance", "angle"])
def test_sharp_convex_tip_keeps_the_slab_bottom_simple(mapping):
    """A triangle with a 19 degree tip: the inner offsets of its two sides meet
    1.5 mm below the tip for a 0.5 mm deep slab. The bottom must stay simple and
    inside the material (the depth is reduced there, nowhere else)."""
    prof = Profile.polyline([(0, 0), (20, 0), (10, 60)], closed=True)
    cols = int(prof.length / 0.4)
    hm = _texture(cols, 8, prof.length / cols, 1.0)
    ms = map_texture(prof, hm, mapping=mapping, length=4.0, depth=0.5, periodic_x=True)
    slab = ms.solid()
    assert_watertight(slab)
    assert_no_self_intersection(slab, ms.y)
    b = ms.bottom[0][:, [0, 2]].astype(np.float64)
    p = prof.point(ms.s)
    depth = np.linalg.norm(p - b, axis=1)
    assert np.all(depth > 0)
    far = np.linalg.norm(p - [10, 60], axis=1) > 5  # away from the tip: full depth on the sides
    far &= np.min(np.linalg.norm(p[:, None] - np.array([[0, 0], [20, 0]]), axis=2), axis=1) > 3
    assert np.median(depth[far]) == pytest.approx(0.5, rel=0.05)


# -- closed profiles -------------------------------------------------------------------------
def test_closed_builtin_fits_whole_tiles_exactly():
    prof = Profile.circle(R_CYL)
    with pytest.warns(TexcadWarning, match="scaled"):
        hm, periodic = fit_texture(prof, "builtin:stones", length=10.0, pitch=0.5, height=1.0)
    assert periodic
    assert hm.size[0] == pytest.approx(prof.length, abs=1e-9)
    # 5 stones tiles of 24 mm -> 125.66 mm: the same heights repeat every fifth of the way
    c = hm.shape[1] // 5
    assert np.array_equal(hm.heights[:, :c], hm.heights[:, c : 2 * c])
    ms = map_texture(prof, hm, length=10.0, periodic_x=periodic, mapping="angle")
    assert ms.x_scale == pytest.approx(1.0, abs=1e-12)


def test_non_periodic_texture_on_closed_profile_warns_about_seam():
    prof = Profile.circle(5.0)
    hm = Heightmap(np.random.default_rng(1).uniform(0, 0.5, (8, 63)).astype(np.float32), (0.5, 0.5))
    with pytest.warns(TexcadWarning, match="seamless"):
        ms = map_texture(prof, hm, length=4.0)
    assert_watertight(ms.solid())


def test_errors_name_the_problem():
    prof = Profile.plane(10.0)
    hm = Heightmap(np.zeros((4, 100), np.float32), (0.5, 0.5))
    with pytest.raises(GeometryError, match="only 10.00 mm long"):
        map_texture(prof, hm)
    with pytest.raises(ParameterError, match="unknown mapping"):
        map_texture(prof, hm, mapping="conformal")
    with pytest.raises(ParameterError, match="depth"):
        map_texture(prof, Heightmap(np.zeros((4, 4), np.float32), (0.5, 0.5)), depth=-1)


def test_same_inputs_same_bytes():
    surf = Surface.sine(3.0, 20.0, 30.0, 4.0)
    a = textured_surface(surf, "builtin:stones", height=1.0, pitch=0.5, mapping="angle")
    b = textured_surface(surf, "builtin:stones", height=1.0, pitch=0.5, mapping="angle")
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)


# -- property test ----------------------------------------------------------------------------
@st.composite
def random_profiles(draw):
    kind = draw(st.sampled_from(["closed", "open", "arc", "polygon", "zigzag"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    if kind == "polygon":
        # Star-shaped about the origin (angles spread all around): simple, with
        # convex and concave corners, some sharp.
        n = int(rng.integers(3, 10))
        th = (np.arange(n) + rng.uniform(0, 0.8, n)) * 2 * np.pi / n
        r = rng.uniform(6, 16, n)
        return Profile.polyline(np.stack([r * np.cos(th), r * np.sin(th)], 1), closed=True)
    if kind == "zigzag":
        n = int(rng.integers(3, 8))
        x = np.concatenate([[0.0], np.sort(rng.uniform(1, 40, n - 1))])
        return Profile.polyline(np.stack([x, rng.uniform(-6, 6, n)], 1))
    if kind == "arc":
        # A non-function open curve: most of a wobbly ellipse, textured on its
        # convex outside or its concave inside.
        a, b = rng.uniform(5, 15, 2)
        span = rng.uniform(np.pi, 1.8 * np.pi)
        t0 = rng.uniform(0, 2 * np.pi)
        wob, k = rng.uniform(0, 0.08), int(rng.integers(2, 5))

        def arc(t):
            r = 1 + wob * np.sin(k * t)
            return a * r * np.cos(t), b * r * np.sin(t)

        prof = Profile.parametric(arc, t0 + span, t0, samples=1024)  # clockwise: outside
        return prof.reversed() if draw(st.booleans()) else prof
    if kind == "closed":
        r0 = draw(st.floats(6.0, 20.0))
        ks = rng.integers(2, 6, 2)
        amp = rng.uniform(0, 0.25, 2) / ks  # star-shaped, never crossing itself
        ph = rng.uniform(0, 2 * np.pi, 2)

        def curve(t):
            r = r0 * (1 + sum(a * np.cos(k * t + p) for a, k, p in zip(amp, ks, ph)))
            return r * np.cos(t), r * np.sin(t)

        return Profile.parametric(curve, 0.0, 2 * np.pi, closed=True, samples=1024)
    w = draw(st.floats(15.0, 40.0))
    a = rng.uniform(0, 4, 3)
    k = rng.uniform(0.1, 0.6, 3)
    ph = rng.uniform(0, 2 * np.pi, 3)
    return Profile.function(lambda x: sum(ai * np.sin(ki * x + pi) for ai, ki, pi in zip(a, k, ph)), 0.0, w, samples=1024)


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(prof=random_profiles(), height=st.floats(0.2, 3.0), mapping=st.sampled_from(["distance", "angle"]), seed=st.integers(0, 99))
def test_random_profiles_give_watertight_non_self_intersecting_slabs(prof, height, mapping, seed):
    pitch = 0.4
    cols = int(prof.length / pitch) if prof.closed else int(0.95 * prof.length / pitch)
    px = prof.length / cols if prof.closed else pitch
    hm = _texture(cols, 8, px, height, seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        ms = map_texture(prof, hm, mapping=mapping, length=4.0, depth=0.4, periodic_x=prof.closed)
    slab = ms.solid()
    assert_watertight(slab)
    assert_no_self_intersection(slab, ms.y)
    assert np.all((ms.factor >= 0) & (ms.factor <= 1))


# -- texcad make ------------------------------------------------------------------------------
def test_cli_make_writes_a_watertight_part(tmp_path, capsys):
    from texcad.cli import main

    out = tmp_path / "grip.stl"
    argv = ["make", "--surface", "cylinder", "--radius", "8", "--length", "6", "--texture", "builtin:pins"]
    argv += ["--height", "0.8", "--mapping", "angle", "--pitch", "0.5", "-o", str(out)]
    assert main(argv) == 0
    cap = capsys.readouterr()
    for key in ("triangles", "watertight   True", "volume", "seconds", "limits"):
        assert key in cap.out
    assert "%]" in cap.err  # progress
    mesh = trimesh.load(out)
    tube = np.pi * (8**2 - 3**2) * 6  # default 5 mm wall
    assert mesh.is_watertight and tube < mesh.volume < tube + 2 * np.pi * 8 * 6 * 0.8  # plus texture
    assert not [p for p in tmp_path.iterdir() if p.name != "grip.stl"]  # no temp files left


def test_cli_make_sine_3mf_and_image_texture(tmp_path, capsys):
    from PIL import Image

    from texcad.cli import main

    img = (np.random.default_rng(3).uniform(0, 255, (16, 40))).astype(np.uint8)
    Image.fromarray(img).save(tmp_path / "t.png")
    out = tmp_path / "wave.3mf"
    argv = ["make", "--surface", "sine", "--width", "30", "--length", "8", "--amplitude", "3", "--period", "15"]
    argv += ["--texture", str(tmp_path / "t.png"), "--height", "1", "--mapping", "distance", "-o", str(out)]
    assert main(argv) == 0
    assert "watertight   True" in capsys.readouterr().out
    assert out.stat().st_size > 1000


def test_cli_make_limits_are_reported(tmp_path, capsys):
    """A sine with 0.84 mm concave radius in its troughs (R = L^2 / (4 pi^2 A)) and
    2 mm of texture along the normal: the summary lists where it was limited."""
    from texcad.cli import main

    out = tmp_path / "tight.stl"
    argv = ["make", "--surface", "sine", "--amplitude", "3", "--period", "10", "--width", "20", "--length", "4"]
    argv += ["--texture", "builtin:pins", "--height", "2", "--mapping", "angle", "--pitch", "0.25", "-o", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    n = int(text.split("limits", 1)[1].split()[0])
    assert n >= 1 and text.count("concave radius of curvature 0.8") == n
    kept = float(text.split("at most ", 1)[1].split()[0])
    assert kept <= 0.81 * 10**2 / (4 * np.pi**2 * 3)  # h kappa <= 0.8 (+ sampling), R = L^2 / (4 pi^2 A)
    assert trimesh.load(out).is_watertight


@pytest.mark.parametrize(
    "argv,message",
    [
        (["--surface", "torus"], "invalid choice"),
        (["--surface", "plate", "--height", "-1"], "expected a positive number"),
        (["--surface", "plate", "--mapping", "conformal"], "invalid choice"),
    ],
)
def test_cli_make_bad_options_exit_2_without_a_file(tmp_path, argv, message):
    import subprocess
    import sys

    out = tmp_path / "bad.stl"
    full = [sys.executable, "-m", "texcad", "make", "--texture", "builtin:pins", "--pitch", "1", "-o", str(out), *argv]
    r = subprocess.run(full, capture_output=True, text=True)
    assert r.returncode == 2
    assert message in r.stderr and "Traceback" not in r.stderr
    assert not out.exists() and not list(tmp_path.iterdir())


def test_cli_make_bad_values_exit_2_without_a_file(tmp_path, capsys):
    from texcad.cli import main

    out = tmp_path / "part.obj"
    assert main(["make", "--surface", "plate", "--texture", "builtin:pins", "-o", str(out)]) == 2
    assert "must end in .stl or .3mf" in capsys.readouterr().err
    out = tmp_path / "arc.stl"
    argv = ["make", "--surface", "arc", "--angle", "400", "--texture", "builtin:pins", "-o", str(out)]
    assert main(argv) == 2
    assert "texcad: error: arc angle must be in (0, 360) degrees, got 400.0" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


def test_a_flattened_box_top_is_squared_with_its_edges():
    """LSCM pins its flattening by two boundary points, so the texture's grid lay at
    whatever angle the patch's principal axis took (about 30 degrees to a box's edges
    on an L-shaped patch or a top and two fillets: a staircase of cells along the whole outline). Where the
    outline's edges run along two perpendicular directions the texture's x is turned
    along them (texcad.mapping.param._outline_turn); a round outline keeps its long
    axis along x."""
    import igl
    import trimesh

    from texcad.mapping import lscm_coordinates

    man = m3d.Manifold.cube((30, 12, 1)) + m3d.Manifold.cube((12, 30, 1))  # an L, 12 mm arms
    mg = man.to_mesh()
    ell = trimesh.Trimesh(np.asarray(mg.vert_properties)[:, :3], np.asarray(mg.tri_verts)).subdivide().subdivide()
    top = ell.faces[ell.face_normals[:, 2] > 0.9]
    used, F = np.unique(top, return_inverse=True)
    V = np.asarray(ell.vertices)[used]
    F = F.reshape(-1, 3)
    XY = lscm_coordinates(V, F)  # principal axis: the L's diagonal, 45 degrees to its edges
    loop = igl.boundary_loop(F)
    e = XY[np.roll(loop, -1)] - XY[loop]
    along = np.minimum(np.abs(e[:, 0]), np.abs(e[:, 1])) / np.hypot(e[:, 0], e[:, 1])
    assert along.max() < 1e-6  # every outline edge along x or y
    assert np.ptp(XY[:, 0]) == pytest.approx(30.0, rel=1e-6) and np.ptp(XY[:, 1]) == pytest.approx(30.0, rel=1e-6)
    disk = trimesh.creation.cylinder(radius=10, height=1, sections=64)
    top = disk.faces[disk.face_normals[:, 2] > 0.9]
    used, F = np.unique(top, return_inverse=True)
    XY = lscm_coordinates(np.asarray(disk.vertices)[used], F.reshape(-1, 3))
    assert np.ptp(XY[:, 0]) == pytest.approx(20.0, rel=0.01)  # no square outline: the long axis, as before
