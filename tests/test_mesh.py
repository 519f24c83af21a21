import numpy as np
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

import texcad
from texcad import Heightmap, edge_report, grid_solid, heightfield_slab


def _trimesh(m):
    return trimesh.Trimesh(m.vertices, m.faces, process=False)


def test_slab_one_vertex_per_pixel_and_watertight(small_hm):
    slab = heightfield_slab(small_hm, depth=0.5)
    rows, cols = small_hm.shape
    ring = 2 * (rows + cols) - 4
    assert len(slab.vertices) == rows * cols + ring
    assert slab.num_triangles == 2 * (rows - 1) * (cols - 1) + 2 * ring + ring - 2
    assert edge_report(slab.faces)["watertight"]
    tm = _trimesh(slab)
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    assert np.isclose(tm.volume, slab.volume, rtol=1e-9)
    # Top vertices at pixel centres: 0.5 mm pitch.
    assert np.allclose(slab.vertices[:2, 0], [0.25, 0.75])


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
    man = texcad.to_manifold(slab)  # raises if manifold3d disagrees
    assert np.isclose(man.volume(), slab.volume, rtol=1e-4)
    # Volume is the integral of (h + depth) over the footprint, to bilinear accuracy.
    assert slab.volume > (cols - 1) * 0.3 * (rows - 1) * 0.7 * depth * 0.999


def test_grid_solid_tube_closes_on_shared_vertices():
    r, n, rows = 10.0, 90, 6
    th = np.linspace(0, -2 * np.pi, n, endpoint=False)  # clockwise in XZ: outward normals
    y = np.linspace(0, 5, rows)
    top = np.stack(np.broadcast_arrays(r * np.cos(th)[None], y[:, None], r * np.sin(th)[None]), -1)
    bottom = top * np.array([0.8, 1, 0.8])
    tube = grid_solid(top, bottom, wrap_x=True)
    assert tube.is_watertight
    man = texcad.to_manifold(tube)
    assert man.genus() == 1
    polygon_area = 0.5 * n * np.sin(2 * np.pi / n) * (r**2 - (0.8 * r) ** 2)
    assert np.isclose(tube.volume, polygon_area * 5, rtol=1e-5)
