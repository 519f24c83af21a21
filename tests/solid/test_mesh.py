import numpy as np
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import texcad
from texcad import Heightmap
from texcad.solid import edge_report, grid_solid, heightfield_slab


def _trimesh(m):
    return trimesh.Trimesh(m.vertices, m.faces, process=False)


def test_slab_one_vertex_per_pixel_and_watertight(small_hm):
    slab = heightfield_slab(small_hm, depth=0.5)
    rows, cols = small_hm.shape
    # One vertex per pixel plus the four bottom corners; each wall is one polygon.
    assert len(slab.vertices) == rows * cols + 4
    assert slab.num_triangles == 2 * (rows - 1) * (cols - 1) + 2 * (rows + cols) + 2
    assert edge_report(slab.faces)["watertight"]
    tm = _trimesh(slab)
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    assert np.isclose(tm.volume, slab.volume, rtol=1e-9)
    # Top vertices at pixel centres: 0.5 mm pitch.
    assert np.allclose(slab.vertices[:2, 0], [0.25, 0.75])
    # Every non-top face is a vertical wall facing out of the footprint, or the bottom.
    n = slab.face_normals()[slab.num_triangles - 2 * (rows + cols) - 2 :]
    walls, bottom = n[:-2], n[-2:]
    assert np.allclose(walls[:, 2], 0, atol=1e-6) and np.allclose(bottom, [0, 0, -1], atol=1e-6)
    centre = slab.vertices[: rows * cols, :2].mean(0)
    wf = slab.faces[slab.num_triangles - 2 * (rows + cols) - 2 : -2]
    out = slab.vertices[wf].mean(1)[:, :2] - centre
    assert np.all(np.einsum("ij,ij->i", out, walls[:, :2]) > 0)


def test_slab_walls_cross_the_base_face_at_few_edges(small_hm):
    """The point of the polygon walls: the base body's top face (z = 0) is crossed only
    by the edges from the bottom corners, not by two per boundary pixel (bottom-ring
    walls), so the union has little to cut and re-triangulate."""
    slab = heightfield_slab(small_hm, depth=0.5)
    f = slab.faces.astype(np.int64)
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), 1), axis=0)
    z = slab.vertices[:, 2]
    crossing = int(np.count_nonzero((z[e[:, 0]] < 0) != (z[e[:, 1]] < 0)))
    rows, cols = small_hm.shape
    boundary = 2 * (rows + cols) - 4
    assert crossing == int(np.count_nonzero((e[:, 0] < rows * cols) & (e[:, 1] >= rows * cols)))  # corner edges
    assert crossing < boundary / 2  # bottom-ring walls: 2 * boundary


def test_walls_fall_back_to_a_bottom_ring_when_a_boundary_touches_the_bottom():
    # Boundary heights of -depth pinch the wall polygons (the CAD relief does this).
    h = np.full((6, 7), -1.0, np.float32)
    h[2:4, 2:5] = 0.75
    hm = Heightmap(h, (0.5, 0.5))
    slab = heightfield_slab(hm, depth=1.0)
    ring = 2 * (6 + 7) - 4
    assert len(slab.vertices) == 6 * 7 + ring and slab.is_watertight
    assert np.isclose(texcad.solid.to_manifold(slab).volume(), slab.volume, rtol=1e-6)
    # Lifting the boundary by 0.5 mm gives polygon walls and adds exactly that layer.
    lifted = heightfield_slab(Heightmap(h + np.float32(0.5), (0.5, 0.5)), depth=1.0)
    assert len(lifted.vertices) == 6 * 7 + 4 and lifted.is_watertight
    assert np.isclose(lifted.volume - slab.volume, 6 * 0.5 * 5 * 0.5 * 0.5, rtol=1e-5)


def test_flat_slab_volume_is_exact():
    hm = Heightmap(np.full((11, 21), 1.5, np.float32), (0.5, 0.25))
    slab = heightfield_slab(hm, depth=0.5)
    # Footprint spans the pixel centres: (cols-1) px x (rows-1) py.
    assert np.isclose(slab.volume, (20 * 0.5) * (10 * 0.25) * 2.0, rtol=1e-6)


@settings(max_examples=25, deadline=None)
@given(
    rows=st.integers(2, 30),
    cols=st.integers(2, 30),
    seed=st.integers(0, 2**32 - 1),
    height=st.floats(0.01, 5.0),
    depth=st.floats(0.05, 2.0),
)
def test_random_heightfields_are_watertight_solids(rows, cols, seed, height, depth):
    h = np.random.default_rng(seed).random((rows, cols)) * height
    slab = heightfield_slab(Heightmap(h, (0.3, 0.7)), depth=depth)
    rep = edge_report(slab.faces)
    assert rep["watertight"], rep
    man = texcad.solid.to_manifold(slab)  # raises if manifold3d disagrees
    assert np.isclose(man.volume(), slab.volume, rtol=1e-4)
    assert _trimesh(slab).is_winding_consistent
    # Volume is the integral of (h + depth) over the footprint: the mean height of
    # each cell's two triangles, exactly (trapezoid rule on the triangulated grid).
    hf = h.astype(np.float32).astype(np.float64)
    a, b, c, d = hf[:-1, :-1], hf[:-1, 1:], hf[1:, 1:], hf[1:, :-1]
    expected = 0.3 * 0.7 * (((a + b + c) + (a + c + d)) / 6 + depth).sum()
    assert np.isclose(slab.volume, expected, rtol=1e-4)


def test_grid_solid_tube_closes_on_shared_vertices():
    r, n, rows = 10.0, 90, 6
    th = np.linspace(0, -2 * np.pi, n, endpoint=False)  # clockwise in XZ: outward normals
    y = np.linspace(0, 5, rows)
    top = np.stack(np.broadcast_arrays(r * np.cos(th)[None], y[:, None], r * np.sin(th)[None]), -1)
    bottom = top * np.array([0.8, 1, 0.8])
    tube = grid_solid(top, bottom, wrap_x=True)
    assert tube.is_watertight
    man = texcad.solid.to_manifold(tube)
    assert man.genus() == 1
    polygon_area = 0.5 * n * np.sin(2 * np.pi / n) * (r**2 - (0.8 * r) ** 2)
    assert np.isclose(tube.volume, polygon_area * 5, rtol=1e-5)


@settings(max_examples=25, deadline=None)
@given(
    rows=st.integers(2, 25),
    cols=st.integers(2, 25),
    seed=st.integers(0, 2**32 - 1),
    dip=st.floats(0.0, 1.0),
)
def test_walls_stay_valid_when_the_boundary_dips_towards_the_bottom(rows, cols, seed, dip):
    """Boundary heights down to (and onto) the bottom: polygon walls while they stay
    clear of it, bottom-ring walls once they touch; always a closed solid manifold3d
    accepts, with the volume of the triangulated heightfield."""
    depth = 0.5
    h = np.random.default_rng(seed).random((rows, cols)) * 2.0 - dip * depth
    h = np.maximum(h, -depth).astype(np.float32)
    slab = heightfield_slab(Heightmap(h, (0.4, 0.6)), depth=depth)
    assert edge_report(slab.faces)["watertight"] and _trimesh(slab).is_winding_consistent
    assert np.isclose(texcad.solid.to_manifold(slab).volume(), slab.volume, rtol=1e-4)
    hf = h.astype(np.float64)
    a, b, c, d = hf[:-1, :-1], hf[:-1, 1:], hf[1:, 1:], hf[1:, :-1]
    assert np.isclose(slab.volume, 0.4 * 0.6 * (((a + b + c) + (a + c + d)) / 6 + depth).sum(), rtol=1e-4, atol=1e-9)


def test_edge_slot_pairs_and_shells():
    """Two boxes: every edge's two slots run through it opposite ways, two shells;
    an extra fin (an edge on three faces) or a hole gives no pairs."""
    import manifold3d as m3d

    from texcad.solid import edge_slot_pairs, shells

    g = (m3d.Manifold.cube((1, 1, 1)) + m3d.Manifold.cube((1, 1, 1)).translate((3, 0, 0))).to_mesh()
    f = np.asarray(g.tri_verts).astype(np.int64)
    pairs = edge_slot_pairs(f)
    assert pairs.shape == (3 * len(f) // 2, 2)
    a, b = f.ravel(), f[:, [1, 2, 0]].ravel()
    assert np.array_equal(a[pairs[:, 0]], b[pairs[:, 1]]) and np.array_equal(b[pairs[:, 0]], a[pairs[:, 1]])
    assert shells(f, len(g.vert_properties)) == 2
    assert edge_slot_pairs(np.concatenate([f, [[f[0, 0], f[0, 1], len(g.vert_properties)]]])) is None
    assert edge_slot_pairs(f[1:]) is None
