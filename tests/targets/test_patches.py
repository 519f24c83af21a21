"""Any face of a CAD part (issue 13): cones, spheres, B-splines, bands of faces, several
faces per call, chaining, left-handed planes; watertight, one body, texture only on
the selected faces, distortion as reported, no texture overhang with build_dir."""

import warnings

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

import texcad
from texcad.errors import GeometryError, ParameterError, TexcadError, TexcadWarning
from texcad.brep import part_tessellation
from texcad.printability import face_areas, overhang_mask, unit_normals
from texcad.brep import to_topods

PITCH = 0.5


def knob(inner=0.0):
    from build123d import Axis, BuildLine, BuildPart, BuildSketch, Plane, Polyline, make_face, revolve

    with BuildPart() as k:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Polyline((inner, 0), (15, 0), (15, 2), (12, 14), (10, 16), (inner, 16), close=True)
            make_face()
        revolve(axis=Axis.Z)
    return k.part


def lever():
    from build123d import Align, Cylinder, Pos, Sphere

    return Cylinder(3, 40, align=(Align.CENTER, Align.CENTER, Align.MIN)) + Pos(0, 0, 46) * Sphere(8)


def grip(radii=((12, 9), (15, 11), (12, 9))):
    from build123d import BuildPart, BuildSketch, Ellipse, Plane, loft

    with BuildPart() as g:
        for k, (a, b) in enumerate(radii):  # one section per loft station
            with BuildSketch(Plane.XY.offset(25.0 * k)):
                Ellipse(a, b)
        loft()
    return g.part


def rounded_box():
    from build123d import Axis, Box, fillet

    return fillet(Box(50, 34, 16).edges().filter_by(Axis.Z), 5)


def texture(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        return texcad.texture(*args, **kw)


def _key(v):
    return np.round(np.asarray(v, np.float64), 4)


def base_flags(tx):
    """Per fused-mesh vertex: is it a vertex of the base mesh (by position)?"""
    b = {tuple(x) for x in _key(tx.base_mesh.vertices)}
    return np.array([tuple(x) in b for x in _key(tx.mesh.vertices)])


def selected_points(part, faces, spacing=0.05):
    """Dense points on the selected faces (their tessellation, 0.01 mm chords)."""
    topo = to_topods(part)
    pm = part_tessellation(topo)
    sel = [k for k, fm in enumerate(pm.faces) if fm is not None and any(fm.face.IsSame(to_topods(f)) for f in faces)]
    pts = []
    rng = np.random.default_rng(0)
    for k in sel:  # per selected face
        fm = pm.faces[k]
        t = fm.points[fm.tris]
        area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
        n = np.maximum(1, (area / spacing**2).astype(int))
        tri = np.repeat(np.arange(len(t)), n)
        a, b = rng.random((2, len(tri)))
        flip = a + b > 1
        a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
        pts.append(t[tri, 0] + a[:, None] * (t[tri, 1] - t[tri, 0]) + b[:, None] * (t[tri, 2] - t[tri, 0]))
        pts.append(fm.points)
    return np.concatenate(pts)


def assert_solid(tx, part):
    m = tx.mesh
    tm = trimesh.Trimesh(m.vertices, m.faces, process=True)
    assert tm.is_watertight and tm.is_winding_consistent
    assert len(tm.split(only_watertight=False)) == 1
    assert m.volume > tx.base_mesh.volume + 1.0  # the texture added material


def assert_only_on(tx, part, faces, height, spacing=0.05):
    """No vertex of the relief farther than ``height`` (+ sampling) from the selected
    faces; every base vertex farther than 1 mm from them is untouched."""
    pts = selected_points(part, faces, spacing)
    tree = cKDTree(pts)
    isb = base_flags(tx)
    v = tx.mesh.vertices.astype(np.float64)
    d_new, _ = tree.query(v[~isb])
    assert d_new.max() <= height + 2 * spacing, d_new.max()
    bv = tx.base_mesh.vertices.astype(np.float64)
    d_base, _ = tree.query(bv)
    far = {tuple(x) for x in _key(bv[d_base > 1.0])}
    fused = {tuple(x) for x in _key(v)}
    assert far <= fused


def base_facet_under(b, bn, pts):
    """Index of the base facet each point projects into along its normal (nearest
    such), and the distance to it (mm)."""
    bv = b.vertices.astype(np.float64)
    tri = bv[b.faces]
    tree = cKDTree(tri.mean(axis=1))
    out = np.zeros(len(pts), np.int64)
    gap = np.zeros(len(pts))
    for k, p in enumerate(pts):  # per overhanging facet (few)
        cand = np.array(tree.query_ball_point(p, 20.0), dtype=np.int64)
        if len(cand) == 0:
            cand = np.array([tree.query(p)[1]], dtype=np.int64)
        a, e0, e1 = tri[cand, 0], tri[cand, 1] - tri[cand, 0], tri[cand, 2] - tri[cand, 0]
        n = bn[cand]
        dist = ((p - a) * n).sum(axis=1)
        q = p - dist[:, None] * n - a
        d00, d01, d11 = (e0 * e0).sum(1), (e0 * e1).sum(1), (e1 * e1).sum(1)
        d20, d21 = (q * e0).sum(1), (q * e1).sum(1)
        den = d00 * d11 - d01 * d01
        v = (d11 * d20 - d01 * d21) / den
        w = (d00 * d21 - d01 * d20) / den
        # Outside every facet (over a convex fold): the nearest by distance plus how far out.
        outside = np.maximum.reduce([-v, -w, v + w - 1, np.zeros_like(v)]) * np.sqrt(np.maximum(d00, d11))
        score = np.abs(dist) + outside
        i = int(np.argmin(score))
        out[k] = cand[i]
        gap[k] = float(np.abs(dist[i]))
    return out, gap


def texture_overhang(tx, build_dir, crit=45.0, band=1.0):
    """mm2 of relief facets that overhang where the base mesh's facet under them (the
    closest one, trimesh) does not, nor comes within ``band`` degrees of it."""
    m, b = tx.mesh, tx.base_mesh
    isb = base_flags(tx)
    tex = ~isb[m.faces].all(axis=1)
    over = overhang_mask(m, build_dir, crit) & tex
    if not over.any():
        return 0.0
    bn = unit_normals(b)
    j, gap = base_facet_under(b, bn, m.vertices[m.faces[over]].mean(axis=1).astype(np.float64))
    # Pieces of the base's own facets (cut by the union) lie on it: not texture.
    base_ok = (-(bn[j] @ np.asarray(build_dir, float)) <= np.cos(np.radians(crit + band))) & (gap > 2e-3)
    return float(face_areas(m)[over][base_ok].sum())


# ------------------------------------------------------------------------------------------
def test_knurled_cone_and_top_in_one_call():
    from build123d import Axis, GeomType

    part = knob()
    faces = list(part.faces().filter_by(GeomType.CONE)) + [part.faces().sort_by(Axis.Z)[-1]]
    tx = texture(part, faces, "builtin:diamond_knurl", height=0.5, pitch=PITCH)
    assert_solid(tx, part)
    assert_only_on(tx, part, faces, 0.5)
    assert tx.heightmap is None and isinstance(tx.info["faces"], list)
    # Distortion against the geometry: on the big cone x follows the meridian (scale 1)
    # and y = r / R_ref, r in [12, 15] mm, R_ref = period / (2 pi) (whole tiles around).
    cone = [f for f in tx.info["faces"] if f["kinds"] == ["cone"] and f["period_y"] > 80][0]
    r_ref = cone["period_y"] / (2 * np.pi)
    assert cone["period_y"] / 2.0 == pytest.approx(round(cone["period_y"] / 2.0), abs=1e-9)  # 2 mm tiles
    dx, dy = cone["distortion"]["x"], cone["distortion"]["y"]
    assert 0.98 < dx[0] <= dx[1] < 1.02
    assert 12 / r_ref - 0.03 < dy[0] <= dy[1] < 15 / r_ref + 0.03
    assert 12 / r_ref - 0.03 < dy[2] < 15 / r_ref + 0.03
    # B-rep: the cones on their own (u, v), the planar top in tiles; checked (valid,
    # one solid, volume within 0.1 % of the mesh) when made.
    chk = texcad.brep.check_shape(tx.shape)
    assert chk["valid"] and chk["solids"] == 1


def test_left_handed_plane_frame_bottom_annulus():
    from build123d import Axis

    part = knob(inner=4.0)
    bottom = part.faces().sort_by(Axis.Z)[0]
    tx = texture(part, bottom, "builtin:ridges", height=0.5, pitch=PITCH)
    assert_solid(tx, part)
    assert_only_on(tx, part, [bottom], 0.5)


def test_chaining_keeps_the_first_texture():
    from build123d import Axis, GeomType

    part = knob()
    top = part.faces().sort_by(Axis.Z)[-1]
    cones = part.faces().filter_by(GeomType.CONE)
    first = texture(part, top, "builtin:ridges", height=0.5, pitch=PITCH, brep=False)
    chained = texture(first, cones, "builtin:ridges", height=0.5, pitch=PITCH)
    both = texture(part, list(cones) + [top], "builtin:ridges", height=0.5, pitch=PITCH)
    added_first = first.mesh.volume - part.volume
    assert chained.mesh.volume - part.volume > added_first + 1.0
    assert chained.mesh.volume == pytest.approx(both.mesh.volume, rel=5e-3)
    assert_solid(chained, part)
    with pytest.raises(ParameterError, match="textured already"):
        texture(chained, top, "builtin:ridges", height=0.5, pitch=PITCH)
    with pytest.raises(ParameterError, match="one call"):
        from build123d import Pos

        texture(first.moved(Pos(5, 0, 0)), cones, "builtin:ridges", height=0.5, pitch=PITCH)


def test_sphere_fades_at_the_pole_with_a_warning():
    from build123d import GeomType

    part = lever()
    ball = part.faces().filter_by(GeomType.SPHERE)
    with pytest.warns(TexcadWarning, match="fades out"):
        tx = texcad.texture(part, ball, "builtin:dimples", height=0.5, pitch=PITCH)
    assert_solid(tx, part)
    assert_only_on(tx, part, list(ball), 0.5)
    d = tx.distortion
    assert 0 < d.faded_fraction < 0.3
    assert 0.97 < d.x[0] and d.x[1] < 1.03  # meridian arc length
    assert d.y[2] >= 0.25  # faded to 0 where the scale drops below FADE_ZERO (0.3, per point)
    # No spike at the pole: the fused mesh near the pole stays within the base sphere + 1 um.
    v = tx.mesh.vertices.astype(np.float64)
    near_pole = np.linalg.norm(v[:, :2], axis=1) < 1.0
    assert np.all(np.linalg.norm(v[near_pole] - [0, 0, 46], axis=1) < 8.0 + 0.02)


def test_lofted_bspline_grip_wraps_around():
    from build123d import GeomType

    part = grip()
    side = part.faces().filter_by(GeomType.BSPLINE)
    tx = texture(part, side, "builtin:diamond_knurl", height=0.5, pitch=PITCH)
    assert_solid(tx, part)
    assert_only_on(tx, part, list(side), 0.5)
    info = tx.info["faces"][0]
    assert info["period_y"] is not None and info["period_y"] / 2.0 == pytest.approx(round(info["period_y"] / 2.0))
    assert 0.7 < tx.distortion.y[0] and tx.distortion.y[1] < 1.4


def test_rounded_box_sides_run_across_the_fillets_without_overhang():
    from build123d import Axis

    part = rounded_box()
    sides = part.faces().filter_by(Axis.Z, reverse=True)
    assert len(sides) == 8
    free = texture(part, sides, "builtin:hexagons", height=1.0, pitch=PITCH)
    assert texture_overhang(free, (0, 0, 1)) > 1.0  # without the limiter the hexagons' flanks overhang
    tx = texture(part, sides, "builtin:hexagons", height=1.0, pitch=PITCH, build_dir=(0, 0, 1))
    assert len(tx.info["faces"]) == 1 and len(tx.info["faces"][0]["faces"]) == 8  # one patch: no seam
    assert "band" in tx.info["faces"][0]["parameterization"]
    assert_solid(tx, part)
    assert_only_on(tx, part, list(sides), 1.0)
    assert tx.distortion.y[0] > 0.97 and tx.distortion.y[1] < 1.03
    assert texture_overhang(tx, (0, 0, 1)) < 0.01
    assert tx.limits is not None and tx.limits.removed_volume_mm3 > 0.1
    assert tx.limits.remaining_overhang_mm2 < 0.01


def test_ball_and_cone_without_texture_overhang():
    from build123d import GeomType

    part = lever()
    ball = part.faces().filter_by(GeomType.SPHERE)
    tx = texture(part, ball, "builtin:dimples", height=0.5, pitch=PITCH, build_dir=(0, 0, 1))
    assert_solid(tx, part)
    assert texture_overhang(tx, (0, 0, 1)) < 0.01


def test_partial_cylinder_and_cadquery_selection():
    import cadquery as cq

    # A cylinder with a cross hole: its round face is no longer a full strip of its
    # extrusion (a trimmed face with two holes).
    wp = cq.Workplane("XY").cylinder(24, 8).cut(cq.Workplane("YZ").cylinder(30, 3))
    faces = wp.faces("%CYLINDER").vals()
    side = [f for f in faces if abs(f.Area() - max(g.Area() for g in faces)) < 1e-6]
    tx = texture(wp.val(), side, "builtin:ridges", height=0.4, pitch=PITCH)
    assert tx.info["faces"][0]["kinds"] == ["cylinder"]
    assert_solid(tx, wp.val())
    assert_only_on(tx, wp.val(), side, 0.4)
    # CadQuery selection of several faces at once.
    box = cq.Workplane("XY").box(30, 20, 10)
    tx2 = texture(box, box.faces(">Z or <X"), "builtin:ridges", height=0.4, pitch=PITCH)
    assert len(tx2.info["faces"]) == 2
    assert_solid(tx2, box.val())


def test_bad_input():
    from build123d import Box, GeomType

    part = knob()
    with pytest.raises(ParameterError, match="not a face of this part"):
        texture(part, Box(5, 5, 5).faces()[0:2], "builtin:ridges", pitch=PITCH)
    # A 0.4 mm chamfer-like cone: smaller than the border band at this pitch.
    from build123d import Cylinder, chamfer

    c = chamfer(Cylinder(10, 10).edges(), 0.4)
    tiny = c.faces().filter_by(GeomType.CONE)[0]
    with pytest.raises(TexcadError):
        texture(c, tiny, "builtin:ridges", height=0.4, pitch=1.0)


def test_height_against_concave_curvature_is_limited():
    from build123d import Axis, Box, Cylinder, GeomType, Pos, fillet

    # A boss on a plate with a 4 mm concave fillet: it cannot carry 8 mm of texture.
    part = Box(50, 50, 6) + Pos(0, 0, 8) * Cylinder(8, 10)
    part = fillet(part.edges().filter_by(GeomType.CIRCLE).sort_by(Axis.Z)[0:1], 4.0)  # the boss foot
    fil = part.faces().filter_by(GeomType.TORUS)
    assert len(fil) == 1
    with pytest.warns(TexcadWarning, match="curvature"):
        tx = texcad.texture(part, fil, "builtin:ridges", height=8.0, pitch=PITCH, edge_angle=90)
    assert_solid(tx, part)
    assert tx.info["faces"][0]["max_height"] <= 0.9 * 4.0 * 1.05


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(r0=st.floats(8, 18), r1=st.floats(6, 16), h=st.floats(8, 16))
def test_random_revolved_profiles(r0, r1, h):
    assume(abs(r0 - r1) > 0.5)  # a cone; a cylinder (r0 = r1) is a full strip: the 2.5D path of test_cad
    from build123d import Axis, BuildLine, BuildPart, BuildSketch, GeomType, Plane, Polyline, make_face, revolve

    with BuildPart() as k:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Polyline((0, 0), (r0, 0), (r1, h), (0, h), close=True)
            make_face()
        revolve(axis=Axis.Z)
    part = k.part
    faces = part.faces().filter_by(GeomType.CONE) or part.faces().filter_by(GeomType.CYLINDER)
    tx = texture(part, faces, "builtin:diamond_knurl", height=0.5, pitch=PITCH)
    assert_solid(tx, part)
    assert_only_on(tx, part, list(faces), 0.5, spacing=0.1)
    per = tx.info["faces"][0]["period_y"]
    r_ref = per / (2 * np.pi)
    lo, hi = min(r0, r1) / r_ref, max(r0, r1) / r_ref
    # The closure around: whole tiles, so the step from the last row to the first is no
    # larger than the steps between rows elsewhere (no seam).
    h = tx.heightmap.heights.astype(np.float64)
    assert h.shape[0] * PITCH == pytest.approx(per)
    inner = np.abs(np.diff(h, axis=0)).max()
    assert np.abs(h[0] - h[-1]).max() <= inner + 1e-6
    assert lo - 0.03 < tx.distortion.y[0] and tx.distortion.y[1] < hi + 0.03


@settings(max_examples=3, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(radii=st.lists(st.tuples(st.floats(8, 14), st.floats(6, 10)), min_size=3, max_size=3))
def test_random_bspline_faces(radii):
    from build123d import GeomType

    part = grip(radii)
    side = part.faces().filter_by(GeomType.BSPLINE)
    tx = texture(part, side, "builtin:dimples", height=0.4, pitch=PITCH)
    assert_solid(tx, part)
    assert_only_on(tx, part, list(side), 0.4, spacing=0.1)
    d = tx.distortion
    assert d.x[0] <= d.x[1] and d.y[0] <= d.y[1]


def test_cli_selects_several_faces_and_prints_distortion(tmp_path, capsys):
    from build123d import export_step

    from texcad.cli import main

    export_step(knob(inner=3.0), str(tmp_path / "knob.step"))
    argv = ["texture", str(tmp_path / "knob.step"), "--face", "cone:all", "--face", "normal:0,0,1", "--pitch", "0.5",
            "--height", "0.5", "--texture", "builtin:ridges", "-q", "-o", str(tmp_path / "k.stl")]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "3 face(s)" in out and out.count("distortion   patch") >= 2 and "texture scale" in out
    stl = trimesh.load(tmp_path / "k.stl")
    assert stl.is_watertight
    assert main(argv[:3] + ["cone:9", "-o", str(tmp_path / "x.stl")]) != 0
    assert "cone:0..1" in capsys.readouterr().err


def test_tessellation_that_needs_healing_is_retried(monkeypatch):
    import texcad.brep.tessellation as F
    from texcad.solid import Mesh

    part = knob()
    weld = F._weld
    calls = []

    def leaky(fms, tol):  # the first tessellation loses a triangle: not a closed solid
        pm = weld(fms, tol)
        calls.append(tol)
        if len(calls) == 1:
            pm.mesh = Mesh(pm.mesh.vertices, pm.mesh.faces[1:])
            pm.face_of_tri = pm.face_of_tri[1:]
        return pm

    monkeypatch.setattr(F, "_weld", leaky)
    pm = F.part_tessellation(to_topods(part))
    assert len(calls) == 2 and trimesh.Trimesh(pm.mesh.vertices, pm.mesh.faces).is_watertight

    def broken(fms, tol):
        pm = weld(fms, tol)
        pm.mesh = Mesh(pm.mesh.vertices, pm.mesh.faces[1:])
        return pm

    monkeypatch.setattr(F, "_weld", broken)
    with pytest.raises(GeometryError, match="not a closed solid even after healing"):
        F.part_tessellation(to_topods(part))


# ------------------------------------------------------------------------------------------
# Modes (issue 14 on CAD faces) and lean reliefs (issue 15 on curved faces)
# ------------------------------------------------------------------------------------------
def radial(m):
    v = m.vertices.astype(np.float64)
    return np.hypot(v[:, 0], v[:, 1]), v[:, 2]


def assert_one_watertight_body(m):
    tm = trimesh.Trimesh(m.vertices, m.faces, process=True)
    assert tm.is_watertight and tm.is_winding_consistent
    assert len(tm.split(only_watertight=False)) == 1


@pytest.mark.parametrize("mode", ["engraved", "centred"])
def test_modes_on_a_cylinder(mode):
    from build123d import Cylinder, GeomType

    cyl = Cylinder(10, 24)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    tx = texture(cyl, side, "builtin:diamond_knurl:period=2", height=0.6, pitch=0.25, mode=mode)
    assert_one_watertight_body(tx.mesh)
    r, z = radial(tx.mesh)
    mid = (z > 3) & (z < 21)
    if mode == "engraved":  # the knurl is cut in: the diameter is kept
        assert r.max() <= 10.0 + 1e-4
        assert 10.0 - r[mid].min() == pytest.approx(0.6, abs=0.05)
        assert tx.mesh.volume < tx.base_mesh.volume - 50
    else:  # half out, half in
        assert r.max() - 10.0 == pytest.approx(0.3, abs=0.05)
        assert 10.0 - r[mid].min() == pytest.approx(0.3, abs=0.05)
    assert tx.info["faces"][0]["mode"] == mode
    assert tx.texture_mesh.volume > 1.0  # the texture as its own body (multi-material)


def test_engraved_top_face_stays_within_the_envelope():
    from build123d import Axis, Box

    box = Box(30, 20, 6)
    top = box.faces().sort_by(Axis.Z)[-1]
    tx = texture(box, top, "builtin:pins", height=1.0, pitch=0.25, mode="engraved")
    assert_one_watertight_body(tx.mesh)
    z = tx.mesh.vertices[:, 2]
    assert z.max() <= 3.0 + 1e-4 and z.min() == pytest.approx(-3.0)
    assert 3.0 - np.percentile(z[z > -2.9], 1) > 0.9  # the pins are cut 1 mm deep
    assert tx.mesh.volume < box.volume - 10


def test_gradient_fades_the_texture_along_an_axis():
    from build123d import Cylinder, GeomType

    cyl = Cylinder(10, 30)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    tx = texture(cyl, side, "builtin:diamond_knurl:period=2", height=0.6, pitch=0.25, gradient=((0, 0, -15), (0, 0, 15)))
    r, z = radial(tx.mesh)
    low, high = (z > -13) & (z < -8), (z > 8) & (z < 13)
    assert r[low].max() - 10 > 0.45 and r[high].max() - 10 < 0.25


def test_bad_mode():
    from build123d import Cylinder, GeomType

    cyl = Cylinder(10, 24)
    with pytest.raises(ParameterError, match="mode"):
        texture(cyl, cyl.faces().filter_by(GeomType.CYLINDER)[0], "builtin:pins", mode="embossed")


def test_lean_relief_on_a_cone_within_the_tolerance():
    from build123d import GeomType

    part = knob()
    cone = part.faces().filter_by(GeomType.CONE)
    opts = dict(height=0.6, pitch=0.125)
    grid = texture(part, cone, "builtin:stones", tolerance=0, **opts)
    lean = texture(part, cone, "builtin:stones", tolerance=0.02, **opts)
    assert grid.max_error == 0.0 and 0.0 < lean.max_error <= 0.02
    assert lean.mesh.num_triangles < 0.6 * grid.mesh.num_triangles
    assert_one_watertight_body(lean.mesh)
    area = sum(f.area for f in cone)
    assert abs(lean.mesh.volume - grid.mesh.volume) <= 0.02 * area
    # Independent: every vertex of the grid relief lies within the tolerance of the lean mesh.

    g = grid.mesh.vertices.astype(np.float64)
    lm = lean.mesh
    far = g[np.linalg.norm(g[:, :2], axis=1) > 3]  # relief and part
    pts = far[np.random.default_rng(0).choice(len(far), 4000, replace=False)]
    from conftest import distance_to_mesh

    d = distance_to_mesh(pts, lm.vertices.astype(np.float64), lm.faces.astype(np.int64), k=24)
    assert d.max() <= 0.02 + 0.012  # + the part's own tessellation (0.01 mm chords)


def test_cli_engraves_a_step_cylinder(tmp_path, capsys):
    from build123d import Cylinder, export_step

    from texcad.cli import main

    export_step(Cylinder(10, 20), str(tmp_path / "c.step"))
    argv = ["texture", str(tmp_path / "c.step"), "--face", "cylinder", "--texture", "builtin:diamond_knurl:period=2",
            "--height", "0.5", "--pitch", "0.25", "--mode", "engraved", "-q", "-o", str(tmp_path / "c.stl")]
    assert main(argv) == 0
    stl = trimesh.load(tmp_path / "c.stl")
    assert stl.is_watertight
    r = np.hypot(stl.vertices[:, 0], stl.vertices[:, 1])
    assert r.max() <= 10.0 + 1e-4 and r.min() < 9.6
    with pytest.raises(SystemExit) as e:  # argparse: one line on stderr, exit 2
        main(argv[:-2] + ["--gradient", "0,0", "-o", str(tmp_path / "x.stl")])
    assert e.value.code == 2 and "two different points" in capsys.readouterr().err
    assert not (tmp_path / "x.stl").exists()


def test_lean_relief_with_build_dir_has_no_texture_overhang():
    from build123d import GeomType

    part = knob()
    cone = part.faces().filter_by(GeomType.CONE)
    grid = texture(part, cone, "builtin:stones", height=0.6, pitch=0.2, build_dir=(0, 0, -1), tolerance=0)
    lean = texture(part, cone, "builtin:stones", height=0.6, pitch=0.2, build_dir=(0, 0, -1), tolerance=0.02)
    assert 0 < lean.max_error <= 0.02
    assert lean.mesh.num_triangles < 0.95 * grid.mesh.num_triangles
    assert texture_overhang(lean, (0, 0, -1)) == 0.0
    assert_one_watertight_body(lean.mesh)


def _mode_cases():
    from build123d import Axis, Box, Cylinder, GeomType, Pos

    plate = Box(40, 30, 5) - Pos(5, 0, 0) * Cylinder(4, 10) - Pos(-10, 5, 0) * Box(6, 6, 10)
    lv, g, rb = lever(), grip(), rounded_box()
    return {
        "plane with holes": (plate, plate.faces().sort_by(Axis.Z)[-1]),
        "sphere": (lv, lv.faces().filter_by(GeomType.SPHERE)),
        "bspline around": (g, g.faces().filter_by(GeomType.BSPLINE)),
        "band of planes and fillets": (rb, rb.faces().filter_by(Axis.Z, reverse=True)),
    }


@pytest.mark.parametrize("mode", ["engraved", "centred"])
@pytest.mark.parametrize("case", ["plane with holes", "sphere", "bspline around", "band of planes and fillets"])
def test_modes_on_every_face_kind(case, mode):

    from texcad.solid import to_manifold

    part, faces = _mode_cases()[case]
    tx = texture(part, faces, "builtin:stones", height=0.6, pitch=0.3, mode=mode)
    assert_one_watertight_body(tx.mesh)
    base, out = to_manifold(tx.base_mesh), to_manifold(tx.mesh)
    added, removed = (out - base).volume(), (base - out).volume()
    area = sum(f.area for f in (faces if isinstance(faces, list) or type(faces).__name__ == "ShapeList" else [faces]))
    assert removed > 0.05 * area * 0.6  # the texture is cut in
    if mode == "engraved":
        assert added < 1e-3  # nothing outside the part's envelope
    else:
        assert added > 0.05 * area * 0.6 * 0.5
    assert 0 <= tx.max_error <= 0.02
    assert_only_on(tx, part, list(faces) if not hasattr(faces, "wrapped") else [faces], 0.6)


def test_engraved_plane_has_its_step(tmp_path):
    """Engraved planar faces get their B-rep in tiles (texcad.brep.targets):
    the STEP re-reads as one valid solid with the mesh's volume (OCCT, 0.1 %)."""
    from build123d import Axis, Box

    box = Box(30, 20, 6)
    tx = texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:pins", height=1.0, pitch=0.5, mode="engraved")
    tx.export(tmp_path / "x.step")
    back = texcad.io.read_step(tmp_path / "x.step")
    chk = texcad.brep.check_shape(back)
    assert chk["valid"] and chk["solids"] == 1
    assert texcad.brep.occt_volume(back, 1e-4) == pytest.approx(tx.volume, rel=1e-3)  # (eps 1e-3 stops early: 2e-3)
    tx.export(tmp_path / "x.stl")
    assert trimesh.load(tmp_path / "x.stl").is_watertight


def _frustum(top_radius: float):
    """A hexagonal frustum (lofted: B-spline faces) with its slanted edges rounded
    r 3 mm: its twelve sides form one smooth band around z, tilted inwards."""
    from build123d import Plane, RegularPolygon, fillet, loft

    part = loft([RegularPolygon(20, 6), Plane.XY.offset(20) * RegularPolygon(top_radius, 6)])
    part = fillet([e for e in part.edges() if abs(e.tangent_at(0.5).Z) > 0.1], 3)
    return part, [f for f in part.faces() if abs(f.normal_at().Z) < 0.9]


def test_a_tilted_band_is_textured_at_its_scale_along_the_surface():
    """A band whose faces lean off its axis (a frustum's rounded sides, 17 degrees;
    a vase's bulge) runs around it too: one band, watertight, only on its faces,
    and the texture keeps its scale up the slope (heights along the surface,
    :func:`texcad.mapping.param.meridian_heights`; the height along the axis would
    shrink it to cos 17 = 0.96)."""
    part, sides = _frustum(14)
    assert len(sides) == 12
    tx = texture(part, sides, "builtin:stones", height=0.4, pitch=PITCH)
    (info,) = tx.info["faces"]
    assert "band" in info["parameterization"] and len(info["faces"]) == 12
    assert_solid(tx, part)
    assert_only_on(tx, part, sides, 0.4)
    assert 0.99 < tx.distortion.x[0] and tx.distortion.x[1] < 1.015  # up the slope


def test_a_band_around_no_one_axis_is_refused():
    """An elbow's tube (cylinder, torus, cylinder): a closed band whose two rims
    face different ways; refused with the way out."""
    from build123d import BuildLine, BuildPart, BuildSketch, Circle, GeomType, JernArc, Line, Plane, sweep

    with BuildPart() as elbow:
        with BuildLine():
            a = Line((0, 0, 0), (0, 0, 20))
            b = JernArc(a @ 1, a % 1, 10, 90)
            Line(b @ 1, b @ 1 + (b % 1) * 20)
        with BuildSketch(Plane.XY):
            Circle(5)
        sweep()
    tube = [f for f in elbow.part.faces() if f.geom_type != GeomType.PLANE]
    with pytest.raises(GeometryError, match="does not run around one axis.*two calls"):
        texture(elbow.part, tube, "builtin:stones", height=0.4, pitch=PITCH)


def _frustum_band(r0: float, r1: float, height: float, rings: int = 21, sections: int = 128):
    """A frustum's side as a triangle mesh: ``rings`` circles from radius ``r0`` at
    z = 0 to ``r1`` at ``height`` (mm)."""
    t = np.linspace(0.0, 1.0, rings)[:, None]
    ang = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)[None, :]
    r, z = r0 + (r1 - r0) * t, height * t
    V = np.stack([r * np.cos(ang), r * np.sin(ang), z + 0 * ang], axis=2).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(rings - 1), np.arange(sections), indexing="ij")
    a, b = i * sections + j, i * sections + (j + 1) % sections
    F = np.concatenate([np.stack([a, b, b + sections], -1), np.stack([a, b + sections, a + sections], -1)]).reshape(-1, 3)
    return V, F


def test_meridian_heights_are_the_slant_length():
    """On a frustum the heights along the surface are the slant length (z times
    sqrt(1 + (dr/dz)^2)) up to the chords' error; on a straight band (every
    triangle parallel to the axis) they are the heights given, unchanged."""
    from texcad.mapping.param import meridian_heights

    axis = np.array([0.0, 0, 1])
    V, F = _frustum_band(10.0, 5.0, 10.0)
    y = meridian_heights(V, F, axis, V[:, 2])
    slant = np.hypot(5.0, 10.0) / 10.0
    assert np.abs((y - y.mean()) - (V[:, 2] - V[:, 2].mean()) * slant).max() < 1e-3 * 10.0
    V, F = _frustum_band(5.0, 5.0, 10.0)
    assert np.array_equal(meridian_heights(V, F, axis, V[:, 2]), V[:, 2])
