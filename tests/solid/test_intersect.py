"""Self-intersection of a triangle mesh: found where surfaces cross, never on good
closed meshes (curved, sharp-edged, finely textured)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from texcad.solid import self_intersections


def _two_boxes():
    a = trimesh.creation.box((2.0, 2.0, 2.0))
    b = trimesh.creation.box((2.0, 2.0, 2.0))
    b.apply_translation((1.0, 0.5, 0.3))
    return trimesh.util.concatenate([a, b])  # each closed: the union of edges is "closed" too


def _folded_box():
    b = trimesh.creation.box((2.0, 2.0, 2.0))
    v = np.array(b.vertices)
    k = int(np.argmax(v.sum(1)))  # the (+1, +1, +1) corner, pushed through the far side
    v[k] = (-0.4, -0.3, -2.5)
    return trimesh.Trimesh(v, b.faces, process=False)


@pytest.mark.parametrize("make", [_two_boxes, _folded_box])
def test_crossing_surfaces_are_found(make):
    tm = make()
    pairs = self_intersections(tm.vertices, tm.faces)
    assert len(pairs) > 0 and np.all(pairs[:, 0] < pairs[:, 1])
    # an independent necessary condition: each triangle of a pair has corners on both
    # sides of the other's plane (a separating plane would rule the crossing out)
    for a, b in pairs:
        for x, y in ((a, b), (b, a)):
            p, q = tm.vertices[tm.faces[x]], tm.vertices[tm.faces[y]]
            n = np.cross(q[1] - q[0], q[2] - q[0])
            s = (p - q[0]) @ n
            assert s.min() < 0 < s.max()
    # the unions of the right parts: two boxes overlap in 1 x 1.5 x 1.7 mm3
    if make is _two_boxes:
        import manifold3d as m3d

        vol = sum(m3d.Manifold.cube((2, 2, 2)).volume() for _ in range(2))
        assert tm.volume == pytest.approx(vol)  # the "closed" mesh hides its overlap


def test_good_meshes_do_not_cross():
    meshes = [
        trimesh.creation.icosphere(4, radius=5.0),
        trimesh.creation.box((20.0, 3.0, 0.5)),
        trimesh.creation.cylinder(radius=9.0, height=16.0, sections=200),  # long slivers, a fan cap
        trimesh.creation.annulus(r_min=4.0, r_max=4.2, height=10.0, sections=120),  # thin wall
    ]
    for tm in meshes:
        assert len(self_intersections(tm.vertices, tm.faces)) == 0


def test_a_textured_mesh_does_not_cross():
    import warnings

    import texcad

    c = trimesh.creation.cylinder(radius=9.0, height=16.0, sections=48)
    c.apply_translation((0, 0, 8.0))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        r = texcad.texture(c, "all", "builtin:stones", height=0.8, pitch=0.5, build_dir=(0, 0, 1))
    m = r.mesh
    assert m.num_triangles > 20_000
    assert len(self_intersections(m.vertices, m.faces)) == 0


def test_a_fine_body_beside_a_coarse_one_stays_linear():
    """A 1 mm sphere of 20 k triangles inside a 40 mm one of 80 k: in one grid sized by
    the median triangle the small sphere fills a few cells, whose pairs grow with the
    square of its triangles (2.0 GB, 18 s before); each size class in its own grid
    keeps the broad phase linear."""
    import tracemalloc

    m = trimesh.util.concatenate([trimesh.creation.icosphere(6, radius=20.0), trimesh.creation.icosphere(5, radius=0.5)])
    tracemalloc.start()
    try:
        pairs = self_intersections(m.vertices, m.faces)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(pairs) == 0
    assert peak < 400e6, f"{peak / 1e6:.0f} MB"


def test_chunks_find_the_same_crossings(monkeypatch):
    """Pairs formed a few at a time (a pair may come in two chunks) give the same
    crossings as all at once."""
    import texcad.solid.intersect as si

    tm = trimesh.util.concatenate([_two_boxes(), _folded_box()])
    tm.vertices[len(_two_boxes().vertices) :] += (0.5, 0.2, 0.1)
    whole = si._self_intersections(np.asarray(tm.vertices, float), np.asarray(tm.faces, np.int64), 20_000_000)
    monkeypatch.setattr(si, "PAIR_CHUNK", 7)
    chunked = si._self_intersections(np.asarray(tm.vertices, float), np.asarray(tm.faces, np.int64), 20_000_000)
    assert len(whole) > 10 and np.array_equal(whole, chunked)
