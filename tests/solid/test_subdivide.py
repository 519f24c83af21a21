"""Longest-edge subdivision stays conforming and keeps its angles; normals."""

from __future__ import annotations

import pytest
import numpy as np
import trimesh

import texcad

from texcad.solid.subdivide import edge_lengths, offset_directions, refine, vertex_normals


def _min_angles(v, f):
    p = v[f]
    out = []
    for k in range(3):
        e1, e2 = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
        c = (e1 * e2).sum(1) / (np.linalg.norm(e1, axis=1) * np.linalg.norm(e2, axis=1))
        out.append(np.degrees(np.arccos(np.clip(c, -1, 1))))
    return np.min(out, axis=0)


def test_refine_region_is_conforming_and_exact():
    tm = trimesh.creation.cylinder(radius=10, height=30, sections=24)  # long slivers on the side
    v, f = np.asarray(tm.vertices), np.asarray(tm.faces)
    n = np.asarray(tm.face_normals)
    active = n[:, 0] > 0.5  # a strip of the side
    V, F, parent = refine(v, f, active, 0.7)
    t = trimesh.Trimesh(V, F, process=False)
    assert t.is_watertight and t.is_winding_consistent
    assert abs(t.volume - tm.volume) < 1e-9 * tm.volume  # midpoints on flat faces: same solid
    act = active[parent]
    el = edge_lengths(V, F[act])
    # cut to 0.7 mm, except a few grid triangles sheared next to an edge cut into fewer pieces
    assert el.max() <= 1.4 * 0.7 and np.mean(el > 0.7 + 1e-12) < 0.12 and np.median(el) < 0.7
    # Rivara: angles stay bounded away from 0 (at least half the smallest input angle)
    assert _min_angles(V, F[act]).min() >= 0.5 * _min_angles(v, f[active]).min() - 1e-9
    # the caps are only split along the strip's border (a fan per border edge), not refined
    caps = np.abs(n[:, 2]) > 0.9
    assert np.count_nonzero(caps[parent]) < 8 * np.count_nonzero(caps)
    # every child lies in its parent's plane
    c = V[F].mean(axis=1)
    assert np.abs(((c - v[f[parent, 0]]) * n[parent]).sum(1)).max() < 1e-9
    assert len(F) > 20 * np.count_nonzero(active)


def test_tessellate_every_edge_count_gives_a_tiling():
    """Every count triple up to 9 on a skewed triangle: no triangle turned over or
    flat, the areas add up, and every edge carries exactly its count of pieces."""
    import itertools

    from texcad.solid.subdivide import tessellate

    v = np.array([[0.0, 0, 0], [3.0, 0.4, 0], [0.7, 2.2, 0]])
    f = np.array([[0, 1, 2]])
    full = 0.5 * np.cross(v[1] - v[0], v[2] - v[0])[2]
    for n in itertools.product(range(1, 10), repeat=3):
        V, F, P = tessellate(v, f, np.array([n]))
        p = V[F]
        a = 0.5 * np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2]
        assert a.min() > 1e-6 * full and abs(a.sum() - full) < 1e-12
        assert np.all(P == 0) and len(F) <= max(n) ** 2
        t = trimesh.Trimesh(V, F, process=False)
        boundary = t.edges_sorted[trimesh.grouping.group_rows(t.edges_sorted, require_count=1)]
        assert len(boundary) == sum(n)


def test_tessellate_random_counts_stay_closed():
    from texcad.solid import edge_report
    from texcad.solid.subdivide import tessellate

    s = trimesh.creation.icosphere(2)
    v, f = np.asarray(s.vertices), np.asarray(s.faces)
    g = f[:, [1, 2, 0]]
    key = np.minimum(f, g) * len(v) + np.maximum(f, g)
    uk, inv = np.unique(key, return_inverse=True)
    counts = np.random.default_rng(3).integers(1, 7, len(uk))[inv.reshape(-1, 3)]
    V, F, P = tessellate(v, f, counts)
    assert edge_report(F)["watertight"]
    t = trimesh.Trimesh(V, F, process=False)
    assert t.is_winding_consistent and abs(t.volume - s.volume) < 1e-12 * s.volume
    with pytest.raises(texcad.ParameterError, match="different counts"):
        bad = counts.copy()
        bad[0, 0] += 1
        tessellate(v, f, bad)


def test_nothing_to_do_and_determinism():
    tm = trimesh.creation.box((2, 2, 2))
    v, f = np.asarray(tm.vertices), np.asarray(tm.faces)
    V, F, P = refine(v, f, np.ones(len(f), bool), 10.0)
    assert len(F) == len(f) and np.array_equal(P, np.arange(len(f)))
    a = refine(v, f, np.ones(len(f), bool), 0.3)
    b = refine(v, f, np.ones(len(f), bool), 0.3)
    assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes()


def test_normals_and_offset_directions():
    s = trimesh.creation.icosphere(4, radius=5.0)
    n = vertex_normals(np.asarray(s.vertices), np.asarray(s.faces))
    radial = s.vertices / np.linalg.norm(s.vertices, axis=1, keepdims=True)
    assert np.degrees(np.arccos(np.clip((n * radial).sum(1), -1, 1))).max() < 0.5
    box = trimesh.creation.box((2, 2, 2))
    v, f = np.asarray(box.vertices), np.asarray(box.faces)
    n = vertex_normals(v, f)
    d = offset_directions(v, f, n)
    # at a cube's corner, moving by d offsets all three faces by exactly 1 mm
    assert np.allclose(np.abs(d), 1.0, atol=1e-9)


def test_flips_remove_the_fans_of_slivers():
    # a CAD-style strip: two 40 x 0.5 mm slivers make a flat rectangle
    tm = trimesh.creation.box((40.0, 0.5, 3.0))
    v, f = np.asarray(tm.vertices), np.asarray(tm.faces)
    V, F, _ = refine(v, f, np.ones(len(f), bool), 0.5)
    t = trimesh.Trimesh(V, F, process=False)
    assert t.is_watertight and t.is_winding_consistent and abs(t.volume - 60.0) < 1e-9
    # close to the area / triangle of edge-0.5 right triangles, not the fans' many more
    assert len(F) < 2.0 * tm.area / (0.5 * 0.5 * 0.5 / 2)
    ang = _min_angles(V, F)
    assert np.median(ang) > 25.0 and np.quantile(ang, 0.01) > 1.0


@pytest.mark.parametrize("pitch", [0.23, 0.35, 0.5, 0.77, 1.3])
def test_refine_stays_closed_for_any_pitch(pitch):
    # many equal angles (ties in the flip order) on a finely tessellated cylinder
    from texcad.solid import edge_report

    tm = trimesh.creation.cylinder(radius=6, height=9, sections=64)
    v, f = np.asarray(tm.vertices), np.asarray(tm.faces)
    V, F, _ = refine(v, f, np.asarray(tm.face_normals)[:, 2] > -0.5, pitch)
    assert edge_report(F)["watertight"]
    assert abs(trimesh.Trimesh(V, F, process=False).volume - tm.volume) < 1e-9 * tm.volume


def test_ladder_cuts_cad_strips_into_well_shaped_triangles():
    """A 200-sided cylinder as a CAD program exports it (each side a 52 mm x 0.57 mm
    strip of two triangles): the ladder keeps it closed, oriented and of the same area
    and volume, every new face in its strip's plane, and leaves no sliver (shortest
    edge at least half the step); longest-edge bisection alone leaves slivers there."""
    import manifold3d as m3d

    from texcad.solid import edge_report
    from texcad.solid.subdivide import coarsen, edge_lengths, face_normals, ladder

    g = m3d.Manifold.cylinder(52.0, 18.0, 18.0, 200).to_mesh()
    v = np.asarray(g.vert_properties, np.float64)[:, :3]
    f = np.asarray(g.tri_verts, np.int64)
    fn, area = face_normals(v, f)
    act = np.abs(fn[:, 2]) < 0.5  # the side
    v1, f1, a1, p1 = ladder(v, f, act, 0.3)
    assert edge_report(f1)["watertight"]
    fn1, area1 = face_normals(v1, f1)
    assert abs(area1.sum() - area.sum()) < 1e-9 * area.sum()
    assert np.all((fn1 * fn[p1]).sum(1) > 1 - 1e-12)
    vol = lambda v, f: np.einsum("ij,ij->i", v[f[:, 0]], np.cross(v[f[:, 1]], v[f[:, 2]])).sum() / 6  # noqa: E731
    assert abs(vol(v1, f1) - vol(v, f)) < 1e-9 * vol(v, f)
    side = a1 & (np.abs(fn1[:, 2]) < 0.5)
    assert side.sum() >= 200 * 2 * 52 / 0.3
    assert edge_lengths(v1, f1[side]).min() >= 0.15
    _, fb, ab, _ = coarsen(v, f, act, 0.2)
    vb = coarsen(v, f, act, 0.2)[0]
    assert edge_lengths(vb, fb[ab]).min(axis=1).min() < 0.05  # bisection alone: slivers
    vl, fl, al, _ = coarsen(v, f, act, 0.2, ladders=True)
    assert edge_report(fl)["watertight"] and edge_lengths(vl, fl[al]).min() >= 0.15
