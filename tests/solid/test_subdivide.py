"""Longest-edge subdivision stays conforming and keeps its angles; normals."""

from __future__ import annotations

import pytest
import numpy as np
import trimesh

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
    assert edge_lengths(V, F[act]).max() <= 0.7 + 1e-12
    # Rivara: angles stay bounded away from 0 (at least half the smallest input angle)
    assert _min_angles(V, F[act]).min() >= 0.5 * _min_angles(v, f[active]).min() - 1e-9
    # the caps are only split along the strip's border (a fan per border edge), not refined
    caps = np.abs(n[:, 2]) > 0.9
    assert np.count_nonzero(caps[parent]) < 8 * np.count_nonzero(caps)
    # every child lies in its parent's plane
    c = V[F].mean(axis=1)
    assert np.abs(((c - v[f[parent, 0]]) * n[parent]).sum(1)).max() < 1e-9
    assert len(F) > 20 * np.count_nonzero(active)


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
    assert np.median(ang) > 30.0 and np.quantile(ang, 0.01) > 2.0


@pytest.mark.parametrize("pitch", [0.23, 0.35, 0.5, 0.77, 1.3])
def test_refine_stays_closed_for_any_pitch(pitch):
    # many equal angles (ties in the flip order) on a finely tessellated cylinder
    from texcad.solid import edge_report

    tm = trimesh.creation.cylinder(radius=6, height=9, sections=64)
    v, f = np.asarray(tm.vertices), np.asarray(tm.faces)
    V, F, _ = refine(v, f, np.asarray(tm.face_normals)[:, 2] > -0.5, pitch)
    assert edge_report(F)["watertight"]
    assert abs(trimesh.Trimesh(V, F, process=False).volume - tm.volume) < 1e-9 * tm.volume
