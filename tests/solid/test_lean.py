"""Lean meshes (texcad.solid.lean): error bound at every pixel centre, watertight slabs,
volume within tolerance x area, tolerance=0 unchanged."""

import numpy as np
import pytest

import texcad
from texcad.solid import lean
from texcad.errors import ParameterError
from texcad.sources import Heightmap
from texcad.solid import edge_report, heightfield_slab


def _brute_error(h, rc, z, faces):
    """Max |surface - h| over the pixel centres, one triangle at a time (float64
    barycentric solve; independent of lean.surface_error's scanlines)."""
    rows, cols = h.shape
    P = np.stack(np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"), -1).reshape(-1, 2).astype(float)
    worst, seen = 0.0, np.zeros(len(P), bool)
    for tri in faces:
        a, b, c = rc[tri].astype(float)
        M = np.array([[b[1] - a[1], c[1] - a[1]], [b[0] - a[0], c[0] - a[0]]])
        uv = np.linalg.solve(M, (P[:, [1, 0]] - a[[1, 0]]).T).T
        ins = (uv[:, 0] >= -1e-12) & (uv[:, 1] >= -1e-12) & (uv.sum(1) <= 1 + 1e-12)
        s = z[tri[0]] + uv[ins, 0] * (z[tri[1]] - z[tri[0]]) + uv[ins, 1] * (z[tri[2]] - z[tri[0]])
        p = P[ins].astype(int)
        seen |= ins
        if len(s):
            worst = max(worst, float(np.abs(s - h[p[:, 0], p[:, 1]]).max()))
    assert seen.all()
    return worst


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_surface_error_matches_a_brute_force_measurement(seed):
    rng = np.random.default_rng(seed)
    h = (rng.random((23, 31)) * rng.random()).astype(np.float32)
    rc, f = lean.triangulate(h, 0.1, max_fraction=1.0)
    z = h[rc[:, 0], rc[:, 1]].astype(np.float64)
    assert np.isclose(lean.surface_error(h, rc, z, f), _brute_error(h, rc, z, f), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", ["stones", "diamond_knurl", "pins", "leather"])
@pytest.mark.parametrize("tol", [0.01, 0.05])
def test_error_bound_at_every_pixel_centre(name, tol):
    hm = texcad.builtin(name, size=(20, 15), pitch=0.125, height=1.5)
    rc, f = lean.triangulate(hm.heights, tol, max_fraction=1.0)
    err = lean.surface_error(hm.heights, rc, hm.heights[rc[:, 0], rc[:, 1]], f)
    assert err <= tol * (1 + 1e-6)
    rows, cols = hm.shape
    assert len(f) < 2 * (rows - 1) * (cols - 1)
    # the corners are kept, every vertex is a grid point
    assert {(0, 0), (0, cols - 1), (rows - 1, 0), (rows - 1, cols - 1)} <= set(map(tuple, rc.tolist()))


def test_surface_error_sees_a_wrong_vertex():
    hm = texcad.builtin("stones", size=(10, 10), pitch=0.125, height=1.0)
    rc, f = lean.triangulate(hm.heights, 0.02)
    z = hm.heights[rc[:, 0], rc[:, 1]].astype(np.float64)
    z[len(z) // 2] += 0.3
    assert lean.surface_error(hm.heights, rc, z, f) >= 0.3 - 1e-9


def _slab_checks(hm, tol, origin=(1.5, -2.0, 0.25), depth=0.5):
    import manifold3d
    import trimesh

    dense = heightfield_slab(hm, depth=depth, origin=origin)
    slab = heightfield_slab(hm, depth=depth, origin=origin, tolerance=tol)
    assert edge_report(slab.faces)["watertight"]
    assert manifold3d.Manifold(manifold3d.Mesh(slab.vertices, slab.faces)).status() == manifold3d.Error.NoError
    assert trimesh.Trimesh(slab.vertices, slab.faces, process=True).is_watertight
    err = lean.mesh_error(hm.heights, hm.pitch, origin, slab.vertices, slab.faces[slab.groups["texture"]])
    assert err <= tol + 1e-6  # + float32 rounding of the vertex heights
    area = hm.size[0] * hm.size[1]
    assert abs(slab.volume - dense.volume) <= tol * area
    assert slab.num_triangles < dense.num_triangles
    return slab, dense


@pytest.mark.parametrize("name", ["stones", "diamond_knurl", "pins"])
def test_lean_slab_is_watertight_bounded_and_keeps_volume(name):
    hm = texcad.builtin(name, size=(25, 20), pitch=0.125, height=2.0)
    _slab_checks(hm, 0.02)


def test_lean_slab_with_boundary_down_to_the_bottom_uses_ring_walls():
    # heights within 0.5 um of -depth on the border would pinch the wall polygons:
    # ring walls instead
    hm = texcad.builtin("stones", size=(10, 10), pitch=0.125, height=1.0)
    h = hm.heights.copy()
    h[:, :3] = -0.4999
    _slab_checks(Heightmap(h, hm.pitch), 0.02, depth=0.5)


def test_tolerance_zero_is_the_pixel_grid_byte_for_byte():
    hm = texcad.builtin("diamond_knurl", size=(12, 9), pitch=0.25, height=1.0)
    a = heightfield_slab(hm, depth=0.4, origin=(1, 2, 3))
    b = heightfield_slab(hm, depth=0.4, origin=(1, 2, 3), tolerance=0)
    assert a.vertices.tobytes() == b.vertices.tobytes() and a.faces.tobytes() == b.faces.tobytes()
    rows, cols = hm.shape
    assert len(a.vertices) == rows * cols + 4


def test_same_heights_same_lean_bytes():
    hm = texcad.builtin("stones", size=(15, 15), pitch=0.125, height=1.0)
    a = heightfield_slab(hm, tolerance=0.02)
    b = heightfield_slab(hm, tolerance=0.02)
    assert a.vertices.tobytes() == b.vertices.tobytes() and a.faces.tobytes() == b.faces.tobytes()


@pytest.mark.parametrize("bad", [-0.01, float("nan"), "x"])
def test_bad_tolerance_is_a_parameter_error(bad):
    hm = texcad.builtin("stones", size=(5, 5), pitch=0.25, height=1.0)
    with pytest.raises(ParameterError, match="tolerance"):
        heightfield_slab(hm, tolerance=bad)


def test_textured_plate_reports_its_measured_error():
    kw = dict(size=(30, 20), thickness=3, height=1.5, pitch=0.125)
    lean_part = texcad.pipeline.textured_plate("builtin:stones", tolerance=0.02, **kw)
    dense = texcad.pipeline.textured_plate("builtin:stones", tolerance=0, **kw)
    assert lean_part.mesh.is_watertight and lean_part.texture_mesh.is_watertight
    assert 0 < lean_part.max_error <= 0.02 + 1e-6
    assert dense.max_error <= 1e-6
    assert abs(lean_part.mesh.volume - dense.mesh.volume) <= 0.02 * 30 * 20
    assert lean_part.mesh.num_triangles < 0.6 * dense.mesh.num_triangles


def test_texture_on_a_planar_face_is_lean_and_bounded():
    import trimesh
    from build123d import Axis, Box, Cylinder

    part = Box(30, 20, 6) - Cylinder(4, 10)  # a hole: an outline the M-I ramp follows
    face = part.faces().sort_by(Axis.Z)[-1]
    a = texcad.texture(part, face, "builtin:diamond_knurl", height=1.0, pitch=0.125, brep=False, tolerance=0.02)
    b = texcad.texture(part, face, "builtin:diamond_knurl", height=1.0, pitch=0.125, brep=False, tolerance=0)
    assert a.max_error <= 0.02 + 1e-6 and b.max_error <= 1e-6
    tm = trimesh.Trimesh(a.mesh.vertices, a.mesh.faces, process=True)
    assert tm.is_watertight and tm.is_volume
    assert abs(a.mesh.volume - b.mesh.volume) <= 0.02 * 30 * 20
    assert a.mesh.num_triangles < b.mesh.num_triangles


def test_noisy_texture_keeps_the_pixel_grid():
    # sand needs ~0.8 of the grid's triangles at 0.02 mm: more than MAX_FRACTION,
    # so the slab is the pixel grid itself (exact), not a slower lean mesh
    hm = texcad.builtin("sand", size=(20, 15), pitch=0.125, height=1.0)
    assert lean.triangulate(hm.heights, 0.02) is None
    a = heightfield_slab(hm, tolerance=0.02)
    b = heightfield_slab(hm)
    assert a.faces.tobytes() == b.faces.tobytes() and a.vertices.tobytes() == b.vertices.tobytes()
    rc, f = lean.triangulate(hm.heights, 0.02, max_fraction=1.0)
    assert len(f) > lean.MAX_FRACTION * 2 * (hm.shape[0] - 1) * (hm.shape[1] - 1)


def test_tiled_triangulation_tiles_meet_and_a_rejected_tile_is_the_grid():
    """Tiles keep their borders, so they meet on the same vertices (watertight slab);
    the error bound holds at every pixel centre; a tile its check rejects is the
    pixel grid there, the others stay lean."""
    hm = texcad.builtin("stones", size=(30, 20), pitch=0.125, height=1.5)
    tol = 0.02
    rows, cols = hm.shape
    seen = []

    def accept(rc, faces):
        lo = rc.min(axis=0)
        seen.append(tuple(lo))
        return not (lo[0] == 0 and lo[1] == 0)  # reject the first tile: the grid there

    rc, f = lean.tiled_triangulation(hm.heights, tol, tile=64, accept=accept, max_fraction=1.0)
    assert len(seen) >= 4 * 3  # a few tiles, the first tried three times
    err = lean.surface_error(hm.heights, rc, hm.heights[rc[:, 0], rc[:, 1]], f)
    assert err <= tol * (1 + 1e-6)
    # the rejected tile (rows 0..64, cols 0..64) has every grid point
    inside = (rc[:, 0] <= 64) & (rc[:, 1] <= 64)
    assert inside.sum() == 65 * 65
    # tile borders kept: row 64 and column 64 are complete
    assert (rc[:, 0] == 128).sum() == cols and (rc[:, 1] == 128).sum() == rows
    slab = heightfield_slab(hm, depth=0.5, tolerance=tol, lean=(rc, f))
    assert edge_report(slab.faces)["watertight"]
    dense = heightfield_slab(hm, depth=0.5)
    assert abs(slab.volume - dense.volume) <= tol * hm.size[0] * hm.size[1]
    assert slab.num_triangles < 0.6 * dense.num_triangles


def test_full_border_keeps_every_border_point():
    hm = texcad.builtin("pins", size=(12, 9), pitch=0.125, height=1.0)
    rows, cols = hm.shape
    rc, f = lean.triangulate(hm.heights, 0.05, max_fraction=1.0, full_border=True)
    border = (rc[:, 0] == 0) | (rc[:, 0] == rows - 1) | (rc[:, 1] == 0) | (rc[:, 1] == cols - 1)
    assert border.sum() == 2 * (rows + cols) - 4
    assert lean.surface_error(hm.heights, rc, hm.heights[rc[:, 0], rc[:, 1]], f) <= 0.05 * (1 + 1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_full_border_is_within_the_tolerance_by_construction(seed, monkeypatch):
    """full_border on random heightmaps (smooth hills, a noisy patch, a step): every
    border point kept, the brute-force error within the tolerance with no slack, one
    greedy insertion (no retry), and the triangles that touch the outer ring reach no
    further than the next line in (the one-pixel strip, which adds no error)."""
    rng = np.random.default_rng(seed)
    r, c = int(rng.integers(6, 40)), int(rng.integers(6, 40))
    y, x = np.mgrid[0:r, 0:c] / 6.0
    h = 0.5 + 0.4 * np.sin(x * rng.uniform(0.5, 3)) * np.cos(y * rng.uniform(0.5, 3))
    h[: r // 3, c // 2 :] += rng.uniform(0, 0.2, (r // 3, c - c // 2))
    h[r // 2 :, : c // 3] += 0.3
    tol = float(rng.uniform(0.005, 0.05))
    runs = []
    real = lean._greedy
    monkeypatch.setattr(lean, "_greedy", lambda *a: runs.append(1) or real(*a))
    rc, f = lean.triangulate(h, tol, max_fraction=1.0, full_border=True)
    assert len(runs) == 1
    ring = (rc[:, 0] == 0) | (rc[:, 0] == r - 1) | (rc[:, 1] == 0) | (rc[:, 1] == c - 1)
    assert ring.sum() == 2 * (r + c) - 4
    assert _brute_error(h, rc, h[rc[:, 0], rc[:, 1]], f) <= tol
    near = (rc[:, 0] <= 1) | (rc[:, 0] >= r - 2) | (rc[:, 1] <= 1) | (rc[:, 1] >= c - 2)
    touching = ring[f].any(axis=1)
    assert touching.any() and near[f[touching]].all()
    rc2, f2, err = lean.lean_tile(h, tol)
    assert np.array_equal(rc2, rc) and len(runs) == 2 and 0 <= err <= tol


def _open_edges(faces):
    """Directed edges of ``faces`` whose reverse is not among them."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    have = set(map(tuple, e))
    return {(a, b) for a, b in map(tuple, e) if (b, a) not in have}


def test_lean_tiles_meet_on_their_whole_border_within_the_bound():
    """Two blocks sharing a column, each made lean alone (lean.lean_tile): every
    point of their borders kept, the shared column the same points and the same unit
    edges (opposite ways) in both, each within the tolerance at every pixel centre
    (the measure it returns is the independent brute-force one), far leaner than the
    grid; the union of both is closed along the seam."""
    h = texcad.builtin("builtin:stones", size=(30, 20), pitch=0.25).heights
    tol = 0.02
    left, right = h[:, :61], h[:, 60:]
    out = []
    for block in (left, right):
        rc, f, err = lean.lean_tile(block, tol)
        r, c = block.shape
        border = {(i, j) for i in range(r) for j in range(c) if i in (0, r - 1) or j in (0, c - 1)}
        assert border <= set(map(tuple, rc))
        assert 0 < err <= tol and np.isclose(err, _brute_error(block, rc, block[rc[:, 0], rc[:, 1]], f), atol=1e-6)
        assert len(f) < 0.6 * 2 * (r - 1) * (c - 1)
        out.append((rc, f))
    (rl, fl), (rr, fr) = out
    ko = {tuple(p): k for k, p in enumerate(rl)}
    kr = {(i, j + 60): len(rl) + k for k, (i, j) in enumerate(rr)}
    glob = {**ko, **kr}  # the seam column's points: one number
    names = np.array([glob[tuple(p)] for p in rl] + [glob[(i, j + 60)] for i, j in rr])
    faces = np.concatenate([names[fl], names[fr + len(rl)]])
    seam = {(a, b) for a, b in _open_edges(faces)}
    on_seam = {k for p, k in glob.items() if p[1] == 60}
    assert not any(a in on_seam and b in on_seam for a, b in seam)  # the seam's edges all paired


def test_lean_tile_falls_back_to_the_grid():
    """A check that rejects every lean triangulation, or a share it cannot keep, gives
    the pixel grid (error 0)."""
    h = texcad.builtin("builtin:stones", size=(10, 8), pitch=0.25).heights
    r, c = h.shape
    for kw in (dict(accept=lambda rc, f: False), dict(max_fraction=0.01), dict(grid=True)):
        rc, f, err = lean.lean_tile(h, 0.02, **kw)
        assert err == 0.0 and len(rc) == r * c and len(f) == 2 * (r - 1) * (c - 1)
    rc, f, err = lean.lean_tile(h, 0.02, accept=lambda rc, f: 3.0)  # "3 x the bound": tightened twice, then the grid
    assert err == 0.0 and len(rc) == r * c


@pytest.mark.parametrize("seed, tol", [(0, 0.05), (1, 0.2), (2, 0.5), (3, 0.0)])
def test_refined_heights_are_lean_heights_bit_for_bit(seed, tol):
    """lean.refined_heights (half-cells at once, other triangles by exact integer row
    spans) gives patches.lean_heights(sub=2)'s values bit for bit: the same point set
    of every triangle, the same last writer on shared sides, the same arithmetic
    (tolerance 0: the pixel grid, all half-cells; coarse tolerances: long slivers).
    Faces shuffled too (the last triangle holding a point writes it)."""
    from texcad.targets.patches import lean_heights

    rng = np.random.default_rng(seed)
    h = (np.cumsum(rng.normal(size=(37, 53)), axis=1) * 0.3 + 3 * rng.random((37, 53)) ** 8).astype(np.float32)
    if tol > 0:
        rc, f = lean.triangulate(h, tol, max_fraction=1.0)
    else:
        from texcad.solid import grid_faces

        rc = np.stack(np.divmod(np.arange(h.size), h.shape[1]), axis=1)
        f = grid_faces(*h.shape)
    pitch, origin = (0.3, 0.7), (-5.0, 2.0, 1.5)
    v = np.stack([origin[0] + (rc[:, 1] + 0.5) * pitch[0], origin[1] + (rc[:, 0] + 0.5) * pitch[1],
                  origin[2] + h[rc[:, 0], rc[:, 1]]], axis=1).astype(np.float32)
    for faces in (f, f[rng.permutation(len(f))]):
        want = lean_heights(v, faces, origin, pitch, h.shape, sub=2)
        got = lean.refined_heights(v, faces, origin, pitch, h.shape)
        assert not np.isnan(got).any()
        np.testing.assert_array_equal(got.view(np.int64), want.view(np.int64))
