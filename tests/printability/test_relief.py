"""The overhang limiter for displaced meshes (texcad.printability.limit_relief).

Every result is checked with an independent computation (np.cross on the positions as
the STL and 3MF writers store them): no displaced face overhangs or folds over, the
displacements only shrink, and the figures of the report match a plain count. The
limiter works block by block and on two threads: the bytes must not depend on either.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from texcad.printability import limit_relief, relief

from texcad.printability import slicer_margin

CRIT = 45.0  # degrees
MARGIN = slicer_margin(CRIT)  # degrees, limit_relief's default (the slicers' margin, 2.5)


def sphere(seed: int, subdivisions: int = 4, radius: float = 10.0):
    """An icosphere (mm) with a rough relief ``d`` (mm, raised and sunk, 0 on a third
    of the vertices): plenty of overhanging faces, and folds where it sinks deeper
    than the radius."""
    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=radius)
    rng = np.random.default_rng(seed)
    v = np.asarray(m.vertices, dtype=np.float64)
    d = rng.uniform(-1.0, 2.0, len(v))
    d[rng.random(len(v)) < 0.3] = 0.0
    d[rng.random(len(v)) < 0.01] = -1.5 * radius  # through the centre: folds
    return v, np.asarray(m.faces, dtype=np.int64), np.asarray(m.vertex_normals, dtype=np.float64), d


def written_normals(p: np.ndarray, f: np.ndarray) -> list[np.ndarray]:
    """Unit face normals ``(M, 3)`` of the positions ``p`` as float32 (STL) and float32
    rounded to 0.1 um (3MF); NaN for a degenerate face."""
    p32 = p.astype(np.float32).astype(np.float64)
    out = []
    for q in (p32, np.round(p32, 4)):
        t = q[f]
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        with np.errstate(invalid="ignore", divide="ignore"):
            out.append(n / np.linalg.norm(n, axis=1)[:, None])
    return out


def offending(v, f, nrm, d, dirs, angle) -> tuple[np.ndarray, np.ndarray]:
    """Faces with a displaced corner that overhang (beyond ``angle`` degrees) or fold
    over (turned by 90 degrees or more, or degenerate) as either writer stores them."""
    t = v[f]
    n0 = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    live = (d[f] != 0).any(axis=1)
    over, fold = np.zeros(len(f), bool), np.zeros(len(f), bool)
    for n in written_normals(v + nrm * d[:, None], f):
        fold |= ~((n * n0).sum(1) > 0)  # NaN counts as folded
        if dirs is not None:
            dd = np.atleast_2d(np.asarray(dirs, dtype=np.float64))
            dd = dd / np.linalg.norm(dd, axis=1)[:, None]
            over |= (-(n @ dd.T) > np.cos(np.radians(angle))).any(axis=1)
    return over & live, fold & live


@pytest.mark.parametrize("dirs", [(0, 0, 1), (0, 0, -1), (0, -0.5, 1), [(0, 0, 1), (1, 0, 1)]])
def test_no_displaced_face_overhangs_or_folds_as_written(dirs):
    v, f, nrm, d = sphere(seed=3)
    over, fold = offending(v, f, nrm, d, dirs, CRIT)
    assert over.sum() > 100 and fold.sum() > 10  # the input is bad where it should be
    d2, rep = limit_relief(v, f, nrm, d, build_dir=dirs, critical_angle=CRIT)
    over, fold = offending(v, f, nrm, d2, dirs, CRIT)
    assert over.sum() == 0 and fold.sum() == 0
    assert np.all(np.abs(d2) <= np.abs(d)) and np.all(d2 * d >= 0)  # only lowered, never flipped
    assert rep.lowered == int((d2 != d).sum()) > 0
    assert rep.zeroed == int(((d2 != d) & (d2 == 0)).sum())


def test_report_counts_what_overhung_and_folded_before():
    v, f, nrm, d = sphere(seed=5)
    over, fold = offending(v, f, nrm, d, (0, 0, 1), CRIT + MARGIN)
    _, rep = limit_relief(v, f, nrm, d, build_dir=(0, 0, 1), critical_angle=CRIT)
    assert (rep.overhang_faces, rep.folded_faces) == (int(over.sum()), int(fold.sum()))
    t = v[f]
    area = np.zeros(len(v))
    a = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1)
    np.add.at(area, f.ravel(), np.repeat(a / 3.0, 3))
    d2, _ = limit_relief(v, f, nrm, d, build_dir=(0, 0, 1), critical_angle=CRIT)
    assert rep.removed_mm3 == pytest.approx(float((np.abs(d - d2) * area).sum()), rel=1e-9)


def test_without_a_build_direction_only_folds_are_undone():
    v, f, nrm, d = sphere(seed=7)
    d2, rep = limit_relief(v, f, nrm, d)
    assert rep.overhang_faces == 0 and rep.folded_faces > 10
    over, fold = offending(v, f, nrm, d2, (0, 0, 1), CRIT)
    assert fold.sum() == 0 and over.sum() > 0  # overhangs were left alone


def test_same_bytes_for_any_block_size_and_thread_count(monkeypatch):
    v, f, nrm, d = sphere(seed=11, subdivisions=5)  # 20 480 faces
    runs = []
    for block, threads in [(relief._BLOCK, False), (relief._BLOCK, True), (1000, True), (64, False)]:
        monkeypatch.setattr(relief, "_BLOCK", block)
        monkeypatch.setattr(relief, "_THREADS", threads)
        d2, rep = limit_relief(v, f, nrm, d, build_dir=[(0, 0, 1), (0.3, 0.2, 1)], critical_angle=40.0)
        runs.append((d2.tobytes(), rep))
    assert runs[0][1].lowered > 0
    assert all(r == runs[0] for r in runs[1:])


def test_nothing_to_do_on_an_undisplaced_mesh():
    v, f, nrm, d = sphere(seed=1)
    d2, rep = limit_relief(v, f, nrm, np.zeros_like(d), build_dir=(0, 0, 1))
    assert not d2.any() and rep.lowered == rep.overhang_faces == rep.folded_faces == 0


def _steep_ridges_trimesh(v: np.ndarray, f: np.ndarray, d=(0.0, 0.0, 1.0), limit_deg: float = 45.0, moved=None) -> int:
    """Convex edges (trimesh's face adjacency) rising less than ``limit_deg`` whose
    contour corner moves between their faces' horizontal normals: counted edge by
    edge, independently of texcad's code (with ``moved`` ``(N,)`` bool: only edges
    with a moved end; the others are the part's own surface)."""
    import trimesh

    tm = trimesh.Trimesh(v, f, process=False)
    d = np.asarray(d, float)
    n = tm.face_normals
    count = 0
    for (f1, f2), (a, b), convex in zip(tm.face_adjacency, tm.face_adjacency_edges, tm.face_adjacency_convex):
        e = v[b] - v[a]
        if not convex or abs(e @ d) < 1e-9 * np.linalg.norm(e) or (moved is not None and not (moved[a] or moved[b])):
            continue
        e = e if e @ d > 0 else -e
        u = e - (e @ d) * d
        if np.degrees(np.arctan2(e @ d, np.linalg.norm(u))) >= limit_deg:
            continue
        h1, h2 = n[f1] - (n[f1] @ d) * d, n[f2] - (n[f2] @ d) * d
        s12, s1u, su2 = np.cross(h1, h2) @ d, np.cross(h1, u) @ d, np.cross(u, h2) @ d
        count += bool(s12 != 0 and s1u * s12 >= 0 and su2 * s12 >= 0)
    return count


def test_no_steep_ridge_is_left_where_the_faces_alone_would_leave_many():
    """Pyramids (a diamond knurl) on a cylinder's side: limited facet by facet only,
    many of their edges rise less than 45 degrees while moving outwards (a slicer
    supports those); limited at the ridges too, none does (trimesh's adjacency, edge
    by edge), and no face overhangs either."""
    from conftest import knurled_cylinder
    from texcad.printability import face_areas, overhang_mask

    tx = knurled_cylinder(6.0, 8.0, 64, ridges=True, pitch=0.3, tolerance=0)
    flat = knurled_cylinder(6.0, 8.0, 64, ridges=False, pitch=0.3, tolerance=0)
    f = tx.mesh.faces.astype(np.int64)
    assert tx.limits.steep_ridges > 50
    assert _steep_ridges_trimesh(flat.mesh.vertices.astype(np.float64), flat.mesh.faces.astype(np.int64)) > 50  # the check can fail
    assert _steep_ridges_trimesh(tx.mesh.vertices.astype(np.float64), f) == 0
    assert face_areas(tx.mesh)[overhang_mask(tx.mesh, (0, 0, 1), 45.0)].sum() == 0.0


def test_sunk_ridges_move_their_lower_end():
    """An engraved relief on a ball: a steep ridge is mended by moving its *lower* end
    back towards the surface (moving the upper one outwards would flatten it), so the
    ridges cost little beyond the faces' limits, and none is left (checked edge by
    edge with trimesh's adjacency)."""
    m = trimesh.creation.icosphere(subdivisions=4, radius=10.0)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    n = v / np.linalg.norm(v, axis=1)[:, None]
    d = -np.random.default_rng(0).uniform(0.2, 2.0, len(v))
    faces_only, a = limit_relief(v, f, n, d, build_dir=(0, 0, 1), ridges=False)
    ridged, b = limit_relief(v, f, n, d, build_dir=(0, 0, 1))
    assert b.steep_ridges > 50 and _steep_ridges_trimesh(v + n * faces_only[:, None], f, moved=faces_only != 0) > 50
    assert _steep_ridges_trimesh(v + n * ridged[:, None], f, moved=ridged != 0) == 0
    assert b.removed_mm3 < 1.25 * a.removed_mm3  # 289 against 267 mm3; the upper ends cost 394


def test_ridge_test_for_an_axis_direction_is_the_general_one_bit_for_bit():
    """The ridge test's shortcut for an axis build direction (the two horizontal
    coordinates) gives what the general formula gives for the same direction."""
    v, f, nrm, d = sphere(seed=5, subdivisions=4)
    tab = relief._edge_table(np.ascontiguousarray(f.T))
    tan_limit = float(np.tan(np.radians(CRIT + MARGIN)))
    for axis in ((0, 0, 1.0), (0, -1.0, 0), (-1.0, 0, 0)):
        dirs = np.array([axis])
        ctx = relief._Ctx(np.ascontiguousarray(v.T), np.ascontiguousarray(nrm.T), np.ascontiguousarray(f.T), dirs,
                          relief._directions(dirs), 0.0, None)
        general = ctx._replace(plan=((None, tuple(axis)),))
        sel = np.arange(len(tab.a))
        fast, slow = relief._steep_ridges(ctx, d, tab, sel, tan_limit), relief._steep_ridges(general, d, tab, sel, tan_limit)
        assert fast[0].sum() > 0
        assert np.array_equal(fast[0], slow[0]) and np.array_equal(fast[1], slow[1])
