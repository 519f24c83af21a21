"""A relief stitched onto a planar face without a boolean (texcad.solid.boolean.fuse_on_plane):
the same solid as manifold3d's union (volume, watertight, one body), its checks, and
the helpers it is made of (cutting at z = 0, boundary loops, the heightfield's volume)."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from texcad.errors import GeometryError
from texcad.solid import Mesh, fuse, grid_faces, heightfield_slab, to_manifold
from texcad.solid import closed_and_oriented
from texcad.solid.boolean import boundary_loops, clip_above_plane, fuse_on_plane
from texcad.solid.mesh import heightfield_volume
from texcad.sources import Heightmap


def _box(lo, hi) -> Mesh:
    """A closed box with its top face split into 2 triangles (like OCCT's plate)."""
    import manifold3d as m3d

    size = np.subtract(hi, lo)
    out = m3d.Manifold.cube(tuple(float(s) for s in size)).translate(tuple(float(v) for v in lo)).to_mesh()
    return Mesh(np.array(out.vert_properties)[:, :3].copy(), np.array(out.tri_verts))


def _heights(seed: int, rows: int = 40, cols: int = 56) -> np.ndarray:
    """Random bumps, a 0 mm band and -1 mm outside (the planar-face path's h_mesh)."""
    rng = np.random.default_rng(seed)
    h = (rng.random((rows, cols)) * 1.5).astype(np.float32)
    h[:3], h[-3:], h[:, :3], h[:, -3:] = 0, 0, 0, 0
    h[:1], h[-1:], h[:, :1], h[:, -1:] = -1, -1, -1, -1
    return h


def _watertight_one_body(m: Mesh) -> None:
    import trimesh

    t = trimesh.Trimesh(m.vertices, m.faces, process=False)
    assert t.is_watertight and t.is_winding_consistent
    man = to_manifold(m)
    assert len(man.decompose()) == 1
    assert closed_and_oriented(m.faces, len(m.vertices))


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("tolerance", [0.0, 0.05])
def test_stitched_solid_is_the_union(seed, tolerance):
    h = _heights(seed)
    hm = Heightmap(h, (0.25, 0.25))
    slab = heightfield_slab(hm, depth=1.0, origin=(1.0, 2.0, 0.0), tolerance=tolerance)
    base = _box((0.0, 0.0, -5.0), (18.0, 16.0, 0.0))
    top = slab.faces[slab.groups["texture"]]
    fused, relief = fuse_on_plane(base, slab.vertices, top)
    union = fuse(base, to_manifold(slab).trim_by_plane((0.0, 0.0, 1.0), 0.0))
    _watertight_one_body(fused)
    assert fused.volume == pytest.approx(union.volume, rel=1e-6)
    assert relief.volume == pytest.approx(union.volume - base.volume, rel=1e-5)
    assert float(relief.vertices[:, 2].min()) == 0.0
    for m in (fused, relief):  # no zero-area triangles
        v = m.vertices.astype(np.float64)
        f = m.faces
        assert (np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1) > 0).all()
    # every fused vertex is a base vertex or a relief vertex
    assert len(fused.vertices) <= len(base.vertices) + len(relief.vertices)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10_000), rows=st.integers(8, 30), cols=st.integers(8, 30))
def test_stitch_matches_manifold3d_on_random_reliefs(seed, rows, cols):
    h = _heights(seed, rows, cols)
    slab = heightfield_slab(Heightmap(h, (0.5, 0.5)), depth=1.0, origin=(0.5, 0.5, 0.0), tolerance=0.1)
    base = _box((0.0, 0.0, -3.0), (cols * 0.5 + 1.0, rows * 0.5 + 1.0, 0.0))
    try:
        fused, _ = fuse_on_plane(base, slab.vertices, slab.faces[slab.groups["texture"]])
    except GeometryError as exc:  # a pinch (two parts of the relief touching at a point) is refused
        assert "pinch" in str(exc)
        return
    union = fuse(base, to_manifold(slab).trim_by_plane((0.0, 0.0, 1.0), 0.0))
    _watertight_one_body(fused)
    assert fused.volume == pytest.approx(union.volume, rel=1e-6)


def test_the_heightfield_volume_check_catches_a_wrong_relief():
    h = _heights(3)
    slab = heightfield_slab(Heightmap(h, (0.25, 0.25)), depth=1.0, origin=(1.0, 1.0, 0.0))
    base = _box((0.0, 0.0, -5.0), (16.0, 12.0, 0.0))
    vol, slack = heightfield_volume(h, (0.25, 0.25))
    fused, relief = fuse_on_plane(base, slab.vertices, slab.faces[slab.groups["texture"]], expect=(vol, slack))
    assert relief.volume == pytest.approx(vol, abs=slack)
    with pytest.raises(GeometryError, match="heightfield"):
        fuse_on_plane(base, slab.vertices, slab.faces[slab.groups["texture"]], expect=(1.1 * vol, 0.01 * vol))


def test_a_relief_beyond_the_face_is_refused():
    """The relief's footprint reaches past the base's top face: the stitch fails a
    check (the caller then uses manifold3d's union) instead of writing a wrong solid."""
    h = np.full((20, 20), 0.5, np.float32)
    slab = heightfield_slab(Heightmap(h, (0.5, 0.5)), depth=1.0, origin=(0.0, 0.0, 0.0))
    base = _box((2.0, 2.0, -5.0), (6.0, 6.0, 0.0))  # smaller than the 10 x 10 mm relief
    with pytest.raises(GeometryError):
        fuse_on_plane(base, slab.vertices, slab.faces)
    with pytest.raises(GeometryError, match="nothing to stitch"):
        fuse_on_plane(_box((0, 0, -5.0), (10, 10, -1.0)), slab.vertices, slab.faces)


def test_clip_above_plane_cuts_exactly_at_zero():
    v = np.array([[0, 0, 1.0], [1, 0, -1.0], [0, 1, -3.0], [1, 1, 2.0]])
    f = np.array([[0, 1, 3], [0, 3, 2]])
    cv, cf = clip_above_plane(v, f)
    assert (cv[:, 2] >= 0).all()
    # edge 0-1 is cut at its middle, 0-2 at a quarter, 1-3 at a third, 2-3 at 3/5
    cut = cv[cv[:, 2] == 0][:, :2]
    assert len(cut) == 4
    for p in ([0.5, 0.0], [0.0, 0.25], [1.0, 1 / 3], [0.6, 1.0]):
        assert np.isclose(cut, p).all(axis=1).any()
    a = cv[cf]
    n = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    assert (n[:, 2] > 0).all()  # orientation kept


def test_boundary_loops_of_a_grid_with_a_hole():
    f = grid_faces(6, 7).astype(np.int64)
    idx = np.arange(42).reshape(6, 7)
    hole = np.isin(f, idx[2:4, 2:5]).all(axis=1)  # the cells inside rows 2-3, cols 2-4
    loops = boundary_loops(f[~hole], 42)
    xy = np.stack([np.arange(42) % 7, np.arange(42) // 7], axis=1).astype(float)

    def area(lp):
        x, y = xy[lp, 0], xy[lp, 1]
        return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))

    assert sorted(len(lp) for lp in loops) == [6, 22]
    ring = np.zeros(42, bool)
    ring[idx[[0, -1], :]] = ring[idx[:, [0, -1]]] = ring[idx[1:5, 1:6]] = True  # the sides and around the hole
    same = boundary_loops(f[~hole], 42, on=ring)
    assert sorted(map(tuple, loops)) == sorted(map(tuple, same))
    assert sorted(area(lp) for lp in loops) == [-2.0, 30.0]  # the hole runs clockwise
    with pytest.raises(GeometryError, match="pinch"):
        two = np.array([[0, 1, 2], [0, 3, 4]])  # two triangles touching at vertex 0
        boundary_loops(two, 5)


def test_heightfield_volume_is_the_grid_mesh_volume():
    rng = np.random.default_rng(5)
    h = (rng.random((15, 21)) - 0.2).astype(np.float32)
    slab = heightfield_slab(Heightmap(h, (0.3, 0.2)), depth=2.0)
    exact = to_manifold(slab).trim_by_plane((0.0, 0.0, 1.0), 0.0).volume()
    vol, slack = heightfield_volume(h, (0.3, 0.2))
    assert abs(vol - exact) <= slack
    pos = np.abs(h) + 0.1
    vol2, slack2 = heightfield_volume(pos, (0.3, 0.2))
    exact2 = to_manifold(heightfield_slab(Heightmap(pos, (0.3, 0.2)), depth=2.0)).trim_by_plane((0, 0, 1.0), 0.0).volume()
    assert abs(vol2 - exact2) <= slack2 <= 0.3 * 0.2 * 1.2  # only the corners differ


def _pyramids(*footprints, height=0.5):
    """A relief surface: a pyramid (apex over the centroid) on each counter-clockwise
    triangle footprint ``(3, 2)`` mm at z = 0; corners shared where footprints touch."""
    pts, faces = [], []
    key = {}

    def vid(p):
        k = tuple(np.round(p, 9))
        if k not in key:
            key[k] = len(pts)
            pts.append(p)
        return key[k]

    for fp in footprints:  # per pyramid
        fp = np.asarray(fp, float)
        corners = [vid(np.r_[c, 0.0]) for c in fp]
        apex = vid(np.r_[fp.mean(axis=0), height])
        faces += [[corners[i], corners[(i + 1) % 3], apex] for i in range(3)]
    return np.array(pts), np.array(faces)


def test_a_relief_touching_itself_at_a_point_is_stitched_around_it():
    """Two pyramids whose footprints touch at one corner (a pinch): the face around
    them closes the fused solid there (one watertight body, exact volume); the relief
    alone would have a pinched vertex, so it is not returned."""
    a = [(3.0, 4.0), (5.0, 5.0), (4.0, 6.0)]
    b = [(5.0, 5.0), (7.0, 4.5), (6.5, 7.0)]
    v, f = _pyramids(a, b)
    base = _box((0.0, 0.0, -2.0), (10.0, 10.0, 0.0))
    fused, relief = fuse_on_plane(base, v, f)
    assert relief is None
    area = sum(0.5 * abs(np.cross(np.subtract(t[1], t[0]), np.subtract(t[2], t[0]))) for t in (a, b))
    assert fused.volume == pytest.approx(base.volume + area * 0.5 / 3, rel=1e-9)
    _watertight_one_body(fused)


def test_a_pinch_with_edges_straight_through_it():
    """Two blocks of a heightfield touching at one grid point, their outlines running
    straight through it: the face's triangulation would make zero-area ears there;
    they are split away, and the solid is the union's."""
    h = np.full((9, 9), -1.0, np.float32)
    h[1:5, 1:5] = h[4:8, 4:8] = 0.0
    h[2:4, 2:4] = h[5:7, 5:7] = 0.5
    slab = heightfield_slab(Heightmap(h, (1.0, 1.0)), depth=2.0)
    base = _box((-1.0, -1.0, -3.0), (11.0, 11.0, 0.0))
    fused, relief = fuse_on_plane(base, slab.vertices, slab.faces[slab.groups["texture"]])
    assert relief is None  # the relief alone would be pinched there
    union = fuse(base, to_manifold(slab).trim_by_plane((0.0, 0.0, 1.0), 0.0))
    assert fused.volume == pytest.approx(union.volume, rel=1e-9)
    _watertight_one_body(fused)
    v = fused.vertices.astype(np.float64)
    f = fused.faces
    assert (np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1) > 0).all()
