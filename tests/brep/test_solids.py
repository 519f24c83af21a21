"""B-rep stage: degree-1 B-spline faces through texture grids, slabs, volumes, STEP."""

import numpy as np
import pytest

from texcad.brep import solids as brep
import texcad.io
from texcad.errors import InputError, ParameterError
from texcad.solid import grid_solid as mesh_grid_solid


def _heightfield(rows=12, cols=17, seed=3, lift=1.0):
    """(R, C, 3) grid over [0, 8] x [0, 5] mm with random heights, corners at z = lift."""
    rng = np.random.default_rng(seed)
    x, y = np.linspace(0, 8, cols), np.linspace(0, 5, rows)
    z = lift + rng.uniform(0, 1, (rows, cols))
    z[[0, 0, -1, -1], [0, -1, 0, -1]] = lift
    return np.stack(np.broadcast_arrays(x[None, :], y[:, None], z), axis=-1)


def test_grid_surface_interpolates_every_vertex():
    from OCP.BRep import BRep_Tool

    g = _heightfield()
    face = brep.grid_face(g, g[0, :, 0], g[:, 0, 1])  # knots = the x and y in mm
    surf = BRep_Tool.Surface_s(face)
    assert surf.UDegree() == 1 and surf.VDegree() == 1
    for r, c in [(0, 0), (3, 7), (11, 16), (6, 2)]:
        p = np.array(surf.Value(float(g[0, c, 0]), float(g[r, 0, 1])).Coord())
        assert np.abs(p - g[r, c]).max() < 1e-9
    back, uk, vk = brep.surface_grid(surf)  # the inverse, through the .brep text
    assert np.abs(back - g).max() < 1e-9 and np.allclose(uk, g[0, :, 0]) and np.allclose(vk, g[:, 0, 1])


def test_grid_solid_matches_mesh_volume_exactly():
    top = _heightfield()
    bottom = top.copy()
    bottom[..., 2] = 0.0
    solid = brep.grid_brep(top, bottom)
    chk = brep.check_shape(solid)
    assert chk == {"valid": True, "solids": 1, "faces": 6, "closed": True}
    mesh = mesh_grid_solid(top.astype(np.float32), bottom.astype(np.float32))
    # Same corner heights: the bilinear and the triangle volume are identical (the
    # difference telescopes to the corners, see texcad.brep.solids).
    assert brep.volume(solid) == pytest.approx(mesh.volume, rel=1e-6)
    assert brep.occt_volume(solid) == pytest.approx(mesh.volume, rel=1e-4)  # OCCT's own integrator
    # ... and a ruled (2-row) bottom gives the same solid.
    ruled = brep.grid_brep(top, bottom[[0, -1]])
    assert brep.check_shape(ruled)["valid"]
    assert brep.volume(ruled) == pytest.approx(brep.volume(solid), rel=1e-12)


def test_closed_band_slab_and_fuse_with_cylinder():
    from build123d import Cylinder

    th = np.linspace(0, 2 * np.pi, 90, endpoint=False)
    z = np.linspace(-8, 8, 20)
    r_top = 10.4 + 0.3 * np.sin(6 * th)[None, :] * np.cos(z)[:, None]
    top = np.stack([r_top * np.cos(th), r_top * np.sin(th), np.broadcast_to(z[:, None], r_top.shape)], axis=-1)
    bottom = np.stack([9.5 * np.cos(th) + 0 * z[:, None], 9.5 * np.sin(th) + 0 * z[:, None], np.broadcast_to(z[:, None], r_top.shape)], axis=-1)
    slab = brep.grid_brep(top, bottom, wrap_x=True)
    assert brep.check_shape(slab)["valid"]
    ring = mesh_grid_solid(top.astype(np.float32), bottom.astype(np.float32), wrap_x=True)
    assert brep.volume(slab) == pytest.approx(ring.volume, rel=2e-3)  # bilinear vs triangles
    cyl = Cylinder(10, 20)
    fused = brep.fuse_solids(cyl, slab)
    assert brep.check_shape(fused)["valid"]
    # Volume of the union: cylinder + slab - the part of the slab inside (r 9.5..10).
    inside = np.pi * (10**2 - 9.5**2) * 16
    assert brep.volume(fused) == pytest.approx(cyl.volume + brep.volume(slab) - inside, rel=1e-3)
    # OCCT's integrator against manifold3d's union of the meshes: independent of texcad.brep.volume
    from texcad.solid import fuse
    from texcad.brep import shape_to_mesh

    assert brep.occt_volume(fused) == pytest.approx(fuse(shape_to_mesh(cyl, tolerance=0.002), ring).volume, rel=3e-3)


def test_volume_is_exact_on_analytic_and_trimmed_faces():
    from build123d import Box, Cylinder, Location

    part = Box(60, 40, 10).moved(Location((3, 4, 5))) - Cylinder(5, 20)
    # planes with circular holes: the outline is sampled (second order): 1e-7
    assert brep.volume(part) == pytest.approx(60 * 40 * 10 - np.pi * 25 * 10, rel=1e-7)


def test_textured_plane_face_replaces_face_in_place():
    from build123d import Axis, Box

    box = Box(20, 10, 4)
    top = box.faces().sort_by(Axis.Z)[-1]
    x, y = np.linspace(-11, 11, 45), np.linspace(-6, 6, 25)
    X, Y = np.meshgrid(x, y)
    h = np.where((np.abs(X) < 8) & (np.abs(Y) < 3), 1 + np.sin(X) * np.cos(Y), 0.0)  # 0 near the outline
    face = brep.textured_plane_face(top, h, x, y, origin=(0, 0, 2), xdir=(1, 0, 0), normal=(0, 0, 1))
    solid = brep.replace_face(box, top, face)
    assert brep.check_shape(solid) == {"valid": True, "solids": 1, "faces": 6, "closed": True}
    # Exact: box + bilinear volume under the heights (cells of 0.5 x 0.5 mm; corner
    # heights are 0, so triangles and bilinear patches agree).
    cell = (x[1] - x[0]) * (y[1] - y[0])
    bump = cell * (h[:-1, :-1] + h[1:, :-1] + h[:-1, 1:] + h[1:, 1:]).sum() / 4
    assert brep.volume(solid) == pytest.approx(800 + bump, rel=1e-9)


def test_inside_square_with_hole():
    sq = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    hole = np.array([[4, 4], [6, 4], [6, 6], [4, 6]], float)
    segs = np.concatenate([np.stack([p, np.roll(p, -1, 0)], 1) for p in (sq, hole)])
    xs = ys = np.arange(-0.5, 11, 1.0)
    m = brep.inside(segs, xs, ys)
    X, Y = np.meshgrid(xs, ys)
    want = (X > 0) & (X < 10) & (Y > 0) & (Y < 10) & ~((X > 4) & (X < 6) & (Y > 4) & (Y < 6))
    assert np.array_equal(m, want)


def test_step_round_trip_is_reproducible(tmp_path):
    top = _heightfield(rows=30, cols=40)
    bottom = top.copy()
    bottom[..., 2] = 0.0
    solid = brep.grid_brep(top, bottom)
    a, b = tmp_path / "a.step", tmp_path / "b.step"
    texcad.io.write_step(solid, a, name="slab")
    texcad.io.write_step(solid, b, name="slab")
    assert a.read_bytes() == b.read_bytes()
    assert b"FILE_DESCRIPTION" in a.read_bytes() and b"'slab'" in a.read_bytes()
    back = texcad.io.read_step(a)
    assert brep.check_shape(back)["valid"] and brep.check_shape(back)["solids"] == 1
    assert brep.volume(back) == pytest.approx(brep.volume(solid), rel=1e-9)
    assert brep.occt_volume(back) == pytest.approx(brep.volume(solid), rel=1e-4)
    m = brep.shape_mesh(back)  # viewing mesh: grid faces from their poles
    assert m.num_triangles >= 2 * 29 * 39
    with pytest.raises(InputError, match="does not exist"):
        texcad.io.read_step(tmp_path / "missing.step")


def test_bad_grids_are_refused():
    with pytest.raises(ParameterError, match="R >= 2"):
        brep.grid_surface(np.zeros((1, 5, 3)))
    with pytest.raises(ParameterError, match="strictly increasing"):
        brep.grid_surface(_heightfield(), u=np.zeros(17))
    with pytest.raises(ParameterError, match="cannot use"):
        brep.to_topods(42)


def test_tiles_share_edges_and_refine_locally():
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    g = _heightfield(rows=40, cols=50)
    x, y = g[0, :, 0], g[:, 0, 1]
    faces, boundary = brep.tiled_grid_faces(g, x, y, tile=16, fine=[(10, 20, 10, 30)])
    assert len(faces) > 4 * 4  # 3 x 4 coarse tiles, some split into 2 x 2-cell tiles
    shell = texcad.brep.compound(faces)
    # Every inner edge is shared by exactly two tiles (no T-junctions), the border by one.
    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shell, TopAbs_EDGE, TopAbs_FACE, emap)
    uses = np.array([emap.FindFromIndex(i).Size() for i in range(1, emap.Extent() + 1)])
    assert set(uses) == {1, 2} and (uses == 1).sum() == len(boundary)
    # Together they enclose exactly the bilinear surface's flux.
    flux = sum(brep._grid_face_flux(f, np.zeros(3)) for f in faces)
    assert flux == pytest.approx(brep.grid_flux(g), rel=1e-12)


@pytest.mark.parametrize("fine", [(0, 7, 13, 23), (5, 9, 40, 50), (3, 8, 0, 6)])
def test_band_tiles_under_a_tool_close_round_the_seam(fine):
    """A closed band's tiles (wrap_x) with small tiles under a tool: every inner edge
    is shared by two tiles, also where the small tiles split the first column's
    side (the last column's side, the same line, is split there too; it was one
    edge, and a boss 0.1 mm from a full cylinder's relief was refused)."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    t = np.linspace(0, 2 * np.pi, 97)[:-1]
    z = np.linspace(0, 10, 22)
    r = 8 + 0.2 * np.sin(3 * t)[None, :] * np.cos(z)[:, None]
    g = np.stack([r * np.cos(t)[None, :], r * np.sin(t)[None, :], np.broadcast_to(z[:, None], r.shape)], axis=-1)
    grid = np.concatenate([g, g[:, :1]], axis=1)
    x, y = np.arange(grid.shape[1], dtype=float), np.arange(grid.shape[0], dtype=float)
    faces, rows = brep.tiled_grid_faces(grid, x, y, tile=24, wrap_x=True, fine=[fine])
    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(texcad.brep.compound(faces), TopAbs_EDGE, TopAbs_FACE, emap)
    uses = np.array([emap.FindFromIndex(i).Size() for i in range(1, emap.Extent() + 1)])
    assert set(uses) == {1, 2} and (uses == 1).sum() == len(rows["v0"]) + len(rows["v1"])


@pytest.mark.parametrize("boss", [False, True])
def test_cylinder_band_without_boolean(boss):
    import warnings
    from build123d import Box, Cylinder, GeomType, Pos
    import texcad

    body = Box(30, 30, 4) + Pos(0, 0, 8) * Cylinder(6, 12) if boss else Cylinder(8, 16)
    side = body.faces().filter_by(GeomType.CYLINDER)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        tx = texcad.texture(body, side, "builtin:stones", height=0.6, pitch=0.5)
    called = []
    real = brep.fuse_solids
    brep.fuse_solids = lambda *a, **k: called.append(1) or real(*a, **k)
    try:
        shape = tx.shape
    finally:
        brep.fuse_solids = real
    assert not called  # no OCCT boolean
    chk = brep.check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert chk["faces"] > len(texcad.brep.faces_of(body)) + 4  # tiles and two rings
    assert brep.volume(shape) == pytest.approx(tx.volume, rel=1e-4)
    assert brep.occt_volume(shape) == pytest.approx(tx.volume, rel=1e-3)


def _plain_volume(shape) -> float:
    """mm^3 by OCCT's plain (default, non-adaptive) Gauss integration: what
    build123d's ``.volume`` calls."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return props.Mass()


def _random_plate(seed: int):
    """A 30 x 30 x 4 mm box, its top, pixel centres ``x`` (57, mm) and random heights
    ``(57, 57)`` up to 0.5 mm, 0 on the border."""
    from build123d import Axis, Box

    box = Box(30, 30, 4)
    x = np.linspace(-14, 14, 57)
    h = np.random.default_rng(seed).uniform(0, 0.5, (57, 57))
    h[[0, -1]] = 0.0
    h[:, [0, -1]] = 0.0
    return box, box.faces().sort_by(Axis.Z)[-1], x, h


@pytest.mark.parametrize("tile", [8, 15, 24])
def test_tiles_are_integrated_right_by_occts_plain_rule(tile):
    """A 30 x 30 mm plate of random bilinear relief in tiles of 8, 15 and 24 cells:
    OCCT's plain Gauss rule (61 points over a tile) gives the adaptive integrator's
    volume within 2e-5 (the knots at partial sums of its weights; with the knots at
    the grid's mm it was 0.1-0.5 % off; tiles under PLACED cells keep straight sides
    and are not placed exactly), and the gauss_knots partition the rule."""
    from texcad.brep.gprop import GAUSS_POINTS, gauss_knots

    k = gauss_knots(0.0, 1.0, 24)
    assert k[0] == 0.0 and k[-1] == 1.0 and np.all(np.diff(k) > 0)
    nodes = (np.polynomial.legendre.leggauss(GAUSS_POINTS)[0] + 1) / 2
    assert (np.histogram(nodes, k)[0] >= 2).all()  # every span holds its own nodes
    box, face, x, h = _random_plate(5)
    shape = brep.tiled_plane_solid(box, face, h, x, x, origin=(0, 0, 2), xdir=(1, 0, 0), normal=(0, 0, 1), tile=tile)
    assert brep.check_shape(shape)["valid"]
    exact = brep.occt_volume(shape, 1e-6)
    assert abs(_plain_volume(shape) - exact) < 2e-5 * exact


@pytest.mark.parametrize("cells", [1, 2, 3])
def test_small_tiles_under_a_tool_are_integrated_right_by_occts_plain_rule(cells):
    """The same plate with small tiles of 1, 2 and 3 cells where a tool will cut (a
    block of them, the rest of each tile it meets in up to four tiles): every tile
    that is not one of the grid's runs has knots of its own, placed for the rule
    OCCT's plain integration uses on it (8 or 12 points; with the runs' knots, placed
    for 61 points, the 2-cell tiles put a drilled plate 0.53 % and a drilled
    cylinder 1.7 % off), so the plain rule agrees with the adaptive one within 2e-5,
    and the tiles are one valid closed shell."""
    box, face, x, h = _random_plate(7)
    fine = [(-3.2, 2.9, -1.3, 4.4, cells)]  # (x0, x1, y0, y1, cells), mm
    shape = brep.tiled_plane_solid(box, face, h, x, x, origin=(0, 0, 2), xdir=(1, 0, 0), normal=(0, 0, 1), fine=fine)
    coarse = brep.tiled_plane_solid(box, face, h, x, x, origin=(0, 0, 2), xdir=(1, 0, 0), normal=(0, 0, 1))
    chk = brep.check_shape(shape)
    assert chk["valid"] and chk["closed"] and chk["faces"] > brep.check_shape(coarse)["faces"] + 10
    exact = brep.occt_volume(shape, 1e-6)
    assert exact == pytest.approx(brep.occt_volume(coarse, 1e-6), rel=1e-8)  # the same surface
    # the small tiles add no error to the runs' own (2e-5): 2e-6 at most (0.2-0.5 % with the runs' knots)
    assert abs(_plain_volume(shape) - exact) < abs(_plain_volume(coarse) - exact) + 2e-6 * exact
