"""STEP files texcad writes, read back and meshed by OCCT as a CAD viewer would
(``BRepMesh_IncrementalMesh`` at 0.1 mm): one valid solid, and the shown mesh within
the deflection (plus the grid's own bilinear term) of texcad's mesh."""

import numpy as np
import pytest

import texcad
from texcad.brep import check_shape, occt_volume, shape_to_mesh

DEFLECTION = 0.1  # mm, what CQ-editor / ocp_vscode use on a part this size


def _distance(points: np.ndarray, mesh: texcad.solid.Mesh) -> float:
    """Largest distance (mm) from ``points`` to the triangles of ``mesh`` (exact:
    libigl's AABB tree)."""
    import igl

    d2 = igl.point_mesh_squared_distance(
        np.asarray(points, np.float64), mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64)
    )[0]
    return float(np.sqrt(d2.max()))


def _shown(tx, path, tol, occt_integrates=True, write=None):
    """Write ``tx`` as STEP (``write(path)``, else ``tx.export``: at the mesh's
    tolerance), read it, mesh it with OCCT; the two one-sided distances
    between OCCT's mesh and texcad's (mm) must be within ``tol``. ``occt_integrates``
    False: the textured face is one large trimmed B-spline face, which OCCT's adaptive
    volume integration does not resolve (its result changes by percents with eps),
    so the volume of OCCT's shown mesh stands in for it."""
    (write or tx.export)(path)
    back = texcad.io.read_step(path)
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    slack = tx.info.get("volume_slack", 0.0)  # a lean mesh: its tolerance x area
    shown = shape_to_mesh(back, tolerance=DEFLECTION, angular_tolerance=0.5)
    if occt_integrates:
        assert abs(occt_volume(back) - tx.volume) <= 1e-3 * tx.volume + slack
    else:
        assert abs(shown.volume - tx.volume) <= 1e-3 * tx.volume + slack
    ours = tx.mesh
    assert _distance(shown.vertices, ours) < tol  # OCCT's mesh lies on texcad's
    assert _distance(ours.vertices, shown) < tol  # and keeps its detail
    return back


def test_plate_step_carries_texcads_mesh(tmp_path):
    from build123d import Axis, Box

    box = Box(30, 20, 5)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.5, pitch=0.25)
    path = tmp_path / "plate.step"
    # tessellated: the tiles carry the pixel grid (one pole per pixel) and its mesh;
    # texcad's fused mesh is the lean one, within its tolerance of that grid.
    back = _shown(tx, path, tx.info["tolerance"] + 1e-3, write=lambda p: texcad.io.write_step(tx.shape, p, tessellated=True))
    text = path.read_bytes()
    assert b"TRIANGULATED_FACE" in text and b"AP242" in text[:2000]
    # Without tessellation (the default): plain AP214, and OCCT meshes the B-spline tiles itself.
    texcad.io.write_step(back, tmp_path / "plain.step")
    plain = (tmp_path / "plain.step").read_bytes()
    assert b"TRIANGULATED_FACE" not in plain and b"AUTOMOTIVE_DESIGN" in plain[:2000]
    again = texcad.io.read_step(tmp_path / "plain.step")
    shown = shape_to_mesh(again, tolerance=DEFLECTION, angular_tolerance=0.5)
    assert _distance(shown.vertices, tx.mesh) < DEFLECTION
    assert _distance(tx.mesh.vertices, shown) < DEFLECTION + 0.25  # + the pitch's scale


def test_cylinder_step(tmp_path):
    from build123d import Cylinder, GeomType

    cyl = Cylinder(8, 16)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    tx = texcad.texture(cyl, side, "builtin:diamond_knurl", height=0.6, pitch=0.5)
    _shown(tx, tmp_path / "cyl.step", DEFLECTION + 0.5 * 0.5)  # + half the pitch (the grid face is bilinear)


def test_sine_step(tmp_path):
    from build123d import Plane, Polyline, SortBy, Spline, extrude, make_face

    k = 2 * np.pi / 25
    x = np.linspace(0, 25, 33)
    top = Spline(*[(a, 2 * np.sin(k * a)) for a in x], tangents=[(1, 2 * k), (1, 2 * k)])
    section = make_face([top, Polyline(top @ 1, (25, -5), (0, -5), (0, 0))])
    part = extrude(Plane.XZ * section, amount=-15)
    face = part.faces().sort_by(SortBy.AREA)[-1]
    tx = texcad.texture(part, face, "builtin:stones", height=0.8, pitch=0.5, mapping="distance")
    # Tiles sewn in place of the sine face (no boolean): OCCT integrates them.
    _shown(tx, tmp_path / "sine.step", DEFLECTION + 0.5 * 0.5)


def test_numpy_step_matches_occts_own(tmp_path, monkeypatch):
    """The tiles' poles and meshes written with numpy (texcad.io.step_tiles) give the
    same B-rep as OCCT's own writer: same faces, same volume, same shown mesh."""
    from build123d import Axis, Box

    import texcad.io.step as step

    box = Box(30, 20, 5)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.5, pitch=0.5)
    mirrored = tx.mirrored((0, 0, 0), (1, 0, 0))  # copied tiles, remembered with their mirrored grids
    texcad.io.write_step(mirrored.shape, tmp_path / "fast.step", tessellated=True)
    fast = (tmp_path / "fast.step").read_bytes()
    texcad.io.write_step(mirrored.shape, tmp_path / "again.step", tessellated=True)
    assert (tmp_path / "again.step").read_bytes() == fast  # reproducible
    monkeypatch.setattr(step, "tiled_step_text", lambda *a, **k: None)
    texcad.io.write_step(mirrored.shape, tmp_path / "occt.step", tessellated=True)
    occt = (tmp_path / "occt.step").read_bytes()
    assert len(fast) < 0.85 * len(occt)  # no per-node normals (0.72 on the demo plate)
    assert fast.count(b"TRIANGULATED_FACE(") == occt.count(b"TRIANGULATED_FACE(") > 0
    a, b = texcad.io.read_step(tmp_path / "fast.step"), texcad.io.read_step(tmp_path / "occt.step")
    ca, cb = check_shape(a), check_shape(b)
    assert ca == cb and ca["valid"] and ca["solids"] == 1
    assert occt_volume(a) == pytest.approx(occt_volume(b), rel=1e-6)
    sa = shape_to_mesh(a, tolerance=DEFLECTION, angular_tolerance=0.5)
    sb = shape_to_mesh(b, tolerance=DEFLECTION, angular_tolerance=0.5)
    assert sa.num_triangles == sb.num_triangles
    # the poles inside the tiles are written to 1e-4 mm (5e-5 mm at most off)
    assert _distance(sa.vertices, sb) < 6e-5 and _distance(sb.vertices, sa) < 6e-5


def _grid_miss(s, g: np.ndarray, u: np.ndarray, v: np.ndarray, tol: float) -> float:
    """Largest distance (mm) from the grid points ``g`` (at the knots ``u``, ``v``) to
    the degree-1 surface ``s`` written on a subset of those knots (exact above
    ``tol / 2``, else an upper bound)."""
    from OCP.ShapeAnalysis import ShapeAnalysis_Surface
    from OCP.gp import gp_Pnt, gp_Pnt2d

    ku = np.array([s.UKnot(i + 1) for i in range(s.NbUKnots())])
    kv = np.array([s.VKnot(i + 1) for i in range(s.NbVKnots())])
    at_u = np.interp(np.arange(len(u)), np.searchsorted(u, ku - 1e-9), ku)
    at_v = np.interp(np.arange(len(v)), np.searchsorted(v, kv - 1e-9), kv)
    ev = np.array([[s.Value(x, y).Coord() for x in at_u] for y in at_v])  # per grid point (a test: 9 k)
    miss = np.sqrt(((ev - g) ** 2).sum(-1))
    sas = ShapeAnalysis_Surface(s)
    for r, c in np.argwhere(miss > 0.5 * tol):  # the farther ones projected (most on the tiles' borders)
        p = gp_Pnt(*g[r, c])
        sas.NextValueOfUV(gp_Pnt2d(at_u[c], at_v[r]), p, 1e-9)
        miss[r, c] = min(miss[r, c], sas.Gap())
    return float(miss.max())


def test_fine_plate_step_holds_every_grid_point(tmp_path):
    """At 0.125 mm the tiles drop a quarter of their poles only when fitted at even
    parameters (texcad's knots are uneven, placed for OCCT's Gauss
    rule); whatever the knots, every grid point stays within the tolerance of the
    written tile, OCCT's volume within 0.1 % of the mesh, and the STEP under twice
    the binary STL (issue 28)."""
    from build123d import Axis, Box
    from OCP.BRep import BRep_Tool

    from texcad.brep import faces_of, tile_grid, to_topods

    box = Box(20, 20, 4)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=2.0, pitch=0.125)
    tol = tx.info["tolerance"]
    tx.export(tmp_path / "fine.step")
    tx.export(tmp_path / "fine.stl")
    # 1.69 (1.89 before the minimax fits; the demo plate: docs/benchmarks/step.md)
    assert (tmp_path / "fine.step").stat().st_size <= 1.75 * (tmp_path / "fine.stl").stat().st_size
    back = texcad.io.read_step(tmp_path / "fine.step")
    assert check_shape(back)["valid"]
    assert occt_volume(back) == pytest.approx(tx.volume, rel=1e-3)
    grids = {}
    for f in faces_of(to_topods(tx.shape)):  # one per face
        got = tile_grid(BRep_Tool.Surface_s(f))
        if got is not None:
            grids[(round(got[1][0], 6), round(got[2][0], 6))] = got
    worst, poles, points = 0.0, 0, 0
    for f in faces_of(back):  # one per face
        s = BRep_Tool.Surface_s(f)
        if hasattr(s, "UDegree") and s.UDegree() == 1:
            g, u, v = grids[(round(s.UKnot(1), 6), round(s.VKnot(1), 6))]
            worst = max(worst, _grid_miss(s, g, u, v, tol))
            poles, points = poles + s.NbUPoles() * s.NbVPoles(), points + len(u) * len(v)
    assert worst <= tol, worst
    assert poles < 0.85 * points  # 0.75 (at the tiles' own knots: 0.93)


def test_step_size_and_reread(tmp_path):
    """The STEP at the mesh's tolerance (the default export): well under twice the
    binary STL, the same bytes twice, re-read as one valid solid within 0.1 % of the mesh
    volume whose edges keep OCCT's 1e-7 mm (tiles, edge curves and vertices share
    their points), and every grid point of every tile within the tolerance of the
    written surface; the tessellated STEP's strips are texcad's grid triangles,
    counter-clockwise, as OCCT's reader expands them."""
    from build123d import Axis, Box
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopoDS import TopoDS

    from texcad.brep import explore, faces_of, tile_grid, to_topods
    from texcad.io.step_tiles import _strips_text, decimals_for
    from texcad.solid import grid_faces

    box = Box(24, 24, 4)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.5, pitch=0.25)
    tol = tx.info["tolerance"]
    (tmp_path / "again").mkdir()
    a, b = tmp_path / "a.step", tmp_path / "again" / "a.step"  # the header holds the name
    tx.export(a)
    tx.export(b)
    assert a.read_bytes() == b.read_bytes()
    tx.export(tmp_path / "a.stl")
    ratio = a.stat().st_size / (tmp_path / "a.stl").stat().st_size
    assert ratio < 1.18, ratio  # issue 28 asks for 2 (1.16 here, 1.21 before the minimax fits)
    back = texcad.io.read_step(a)
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert occt_volume(back) == pytest.approx(tx.volume, rel=1e-3)
    assert max(BRep_Tool.Tolerance_s(TopoDS.Edge_s(e)) for e in explore(back, TopAbs_EDGE)) < 1e-6
    # every grid point of the original tiles against the written surfaces: at the point the
    # writer checked (its index between the kept rows and columns, which texcad's uneven
    # knots map elsewhere: the image is the poles'), else its projection onto the surface
    grids = {}
    for f in faces_of(to_topods(tx.shape)):  # one per face
        got = tile_grid(BRep_Tool.Surface_s(f))
        if got is not None:
            grids[(round(got[1][0], 6), round(got[2][0], 6))] = got
    worst, seen = 0.0, 0
    for f in faces_of(back):  # one per face
        s = BRep_Tool.Surface_s(f)
        if not hasattr(s, "UDegree") or s.UDegree() != 1:
            continue
        g, u, v = grids[(round(s.UKnot(1), 6), round(s.VKnot(1), 6))]
        assert s.NbUPoles() * s.NbVPoles() <= len(u) * len(v)
        worst, seen = max(worst, _grid_miss(s, g, u, v, tol)), seen + 1
    assert seen == len(grids) and worst <= tol + 1e-9, worst
    assert decimals_for(tol)[0] == 3 and decimals_for(0.0)[0] == 4
    # The strips OCCT's reader expands are grid_faces' triangles (orientation kept).
    strips = [[int(i) for i in s.split(",")] for s in _strips_text(4, 5)[1:-1].split("),(")]
    got = []
    for s in strips:  # OCCT: (s1, s3, s2), (s2, s3, s4), ... (StepToTopoDS_TranslateFace)
        got += [(s[i - 2], s[i], s[i - 1]) for i in range(2, len(s), 2)]
        got += [(s[i - 2], s[i - 1], s[i]) for i in range(3, len(s), 2)]
    canon = lambda tris: sorted(tuple(np.roll(t, -int(np.argmin(t))).tolist()) for t in np.asarray(tris))  # noqa: E731
    assert canon(np.asarray(got) - 1) == canon(grid_faces(4, 5).astype(int))
