"""repair_closed: a triangle soup back to closed, consistently wound, outward bodies,
checked against manifold3d and trimesh (independent implementations)."""

from __future__ import annotations

import manifold3d as m3d
import numpy as np
import pytest
import trimesh

from texcad.errors import InputError
from texcad.solid import edge_report, repair_closed


def _bodies() -> tuple[np.ndarray, np.ndarray, float]:
    part = m3d.Manifold.cylinder(20.0, 8.0, 8.0, 48) + m3d.Manifold.sphere(8.0, 48).translate((0, 0, 20.0))
    part = part + m3d.Manifold.cube((5, 5, 5)).translate((30, 0, 0))  # a second body
    g = part.to_mesh()
    return np.asarray(g.vert_properties)[:, :3].astype(np.float64), np.asarray(g.tri_verts).astype(np.int64), part.volume()


def _soup(v, f, seed=0):
    """Every triangle with its own three vertices, a third of them flipped, order shuffled."""
    rng = np.random.default_rng(seed)
    f = f[rng.permutation(len(f))].copy()
    flip = rng.random(len(f)) < 0.3
    f[flip] = f[flip][:, ::-1]
    return v[f].reshape(-1, 3), np.arange(3 * len(f)).reshape(-1, 3)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_soup_becomes_the_closed_outward_bodies(seed):
    v, f, vol = _bodies()
    sv, sf = _soup(v, f, seed)
    rv, rf, bodies = repair_closed(sv, sf)
    assert bodies == 2 and len(rv) == len(v) and len(rf) == len(f)
    rep = edge_report(rf)
    assert rep["watertight"] and rep["misoriented"] == 0
    tm = trimesh.Trimesh(rv, rf, process=False)
    assert tm.is_winding_consistent and tm.is_watertight
    assert [b.volume > 0 for b in tm.split(only_watertight=False)] == [True, True]
    assert tm.volume == pytest.approx(vol, rel=1e-6)


def test_a_body_inside_out_is_turned_and_the_other_kept():
    v, f, vol = _bodies()
    tm = trimesh.Trimesh(v, f, process=False)
    lab = trimesh.graph.connected_component_labels(tm.face_adjacency, node_count=len(f))
    f2 = f.copy()
    f2[lab == lab[0]] = f2[lab == lab[0]][:, ::-1]
    rv, rf, _ = repair_closed(v, f2)
    assert trimesh.Trimesh(rv, rf, process=False).volume == pytest.approx(vol, rel=1e-6)
    assert np.array_equal(np.sort(rf, axis=1)[np.lexsort(np.sort(rf, axis=1).T)], np.sort(f, axis=1)[np.lexsort(np.sort(f, axis=1).T)])


def test_degenerate_and_duplicate_triangles_and_near_vertices():
    v, f, vol = _bodies()
    v2 = np.concatenate([v, v[:10] + 1e-10])  # copies within the merge distance
    extra = np.array([[0, 0, 1], [len(v), 0, 1], f[5], f[7][::-1]])  # degenerate, degenerate after merging, duplicates
    rv, rf, bodies = repair_closed(v2, np.concatenate([f, extra]))
    assert len(rv) == len(v) and len(rf) == len(f) and bodies == 2
    assert trimesh.Trimesh(rv, rf, process=False).volume == pytest.approx(vol, rel=1e-6)


def test_open_and_non_manifold_meshes_are_refused_with_counts():
    v, f, _ = _bodies()
    with pytest.raises(InputError, match=r"not closed after repair \(3 open edges, 0 non-manifold"):
        repair_closed(v, f[1:])
    fan = np.concatenate([f, [[f[0, 0], f[0, 1], len(v)]]])  # a fin on an edge
    with pytest.raises(InputError, match=r"1 non-manifold"):
        repair_closed(np.concatenate([v, [[50.0, 50, 50]]]), fan)


def test_a_one_sided_surface_is_refused():
    """A Klein bottle grid (closed, every edge twice, but one-sided): no winding fits."""
    n, m = 6, 8
    idx = lambda i, j: (i % n) + n * (j % m)  # noqa: E731
    faces = []
    for j in range(m):  # per row; the last row joins the first with x mirrored
        for i in range(n):
            a, b = idx(i, j), idx(i + 1, j)
            c, d = (idx(i, j + 1), idx(i + 1, j + 1)) if j < m - 1 else (idx(n - i, 0), idx(n - i - 1, 0))
            faces += [[a, b, d], [a, d, c]]
    f = np.array(faces)
    v = np.random.default_rng(0).normal(size=(n * m, 3))
    assert edge_report(f)["boundary"] == 0 and edge_report(f)["nonmanifold"] == 0
    with pytest.raises(InputError, match="one-sided"):
        repair_closed(v, f)


def test_a_cavity_faces_into_the_cavity_and_an_island_in_it_outward():
    """A ball with a spherical cavity holding a free ball (three shells, each written
    outward as trimesh's repair leaves them): the cavity's wall is turned to face into
    the cavity, so the volume is outer - cavity + island (manifold3d's)."""
    outer = m3d.Manifold.sphere(20.0, 64)
    cavity = m3d.Manifold.sphere(12.0, 48)
    island = m3d.Manifold.cube((6, 6, 6), True)
    part = (outer - cavity) + island
    shells = [outer, cavity, island]
    vs, fs, off = [], [], 0
    for s in shells:  # each shell written outward
        g = s.to_mesh()
        vs.append(np.asarray(g.vert_properties)[:, :3].astype(np.float64))
        fs.append(np.asarray(g.tri_verts).astype(np.int64) + off)
        off += len(vs[-1])
    rv, rf, bodies = repair_closed(np.concatenate(vs), np.concatenate(fs))
    assert bodies == 2  # the outer ball and the island: a cavity is no body
    tm = trimesh.Trimesh(rv, rf, process=False)
    assert tm.volume == pytest.approx(part.volume(), rel=1e-6)
    vols = sorted(b.volume for b in tm.split(only_watertight=False))
    assert vols[0] < 0 < vols[1]  # exactly one shell (the cavity's wall) inward


def test_non_finite_vertices_and_bad_indices_are_refused():
    v, f, _ = _bodies()
    v2 = v.copy()
    v2[f[3, 0]] = np.nan
    with pytest.raises(InputError, match="1 vertices that are not finite"):
        repair_closed(v2, f)
    with pytest.raises(InputError, match="index missing vertices"):
        repair_closed(v, np.concatenate([f, [[0, 1, len(v)]]]))


# --- small self-intersections repaired (issue 27: 3DBenchy's 23 crossing pairs) ----------

def _spiked_box(depth: float = 0.3):
    """A 10 mm box (subdivided) with one vertex of its top pulled down through its bottom
    by ``depth`` mm: a thin inward spike whose tip crosses the bottom face, the kind of
    small crossing an exported mesh has where a feature pokes through a wall."""
    b = trimesh.creation.box((10.0, 10.0, 10.0))
    for _ in range(3):
        b = b.subdivide()
    v, f = np.array(b.vertices), np.array(b.faces, dtype=np.int64)
    top = np.flatnonzero(np.isclose(v[:, 2], 5.0))
    k = top[np.argmin(np.linalg.norm(v[top, :2] - (1.25, 1.25), axis=1))]
    v[k, 2] = -5.0 - depth
    return v, f


def test_a_small_crossing_is_resolved_by_a_self_union():
    from texcad.solid import self_intersections
    from texcad.solid.repair import resolve_crossings

    v, f = _spiked_box()
    assert len(self_intersections(v, f)) > 0
    rv, rf, rep = resolve_crossings(v, f)
    assert rep is not None and rep.pairs == len(self_intersections(v, f)) and rep.bodies == 1
    assert len(self_intersections(rv, rf)) == 0
    m = m3d.Manifold(m3d.Mesh(vert_properties=rv.astype(np.float32), tri_verts=rf.astype(np.uint32)))
    assert m.status() == m3d.Error.NoError
    assert m.volume() == pytest.approx(rep.volume[1], rel=1e-6)
    assert abs(rep.volume[1] - rep.volume[0]) < 0.01  # only the spike's tip beyond the bottom is outside
    assert "pairs of crossing triangles resolved by a self-union" in rep.note
    # a mesh that does not cross comes back as it is; a fold through the whole part is left to be refused
    bv, bf = np.array(trimesh.creation.box((10.0, 10.0, 10.0)).vertices), np.array(trimesh.creation.box().faces)
    assert resolve_crossings(bv, bf)[2] is None
    fold = bv.copy()
    fold[int(np.argmax(fold.sum(1)))] = (-2.0, -1.5, -12.0)
    assert resolve_crossings(fold, bf)[2] is None


def _inside_out_tetra(at, size=0.1):
    """A tetrahedron ``size`` mm across at ``at``, wound into itself (negative volume)."""
    v = np.array(at) + size * np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
    return v, np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]], dtype=np.int64)


def test_a_cavity_the_union_leaves_inside_the_body_stays(monkeypatch):
    """A void 0.1 mm across inside the spiked box, left by the self-union, stays a
    void of that box (one body, its volume taken out)."""
    import igl.copyleft.cgal as cgal

    from texcad.solid.repair import _shell_volumes, resolve_crossings

    union = cgal.mesh_boolean

    def with_void(*args):
        uv, uf, j = union(*args)
        tv, tf = _inside_out_tetra((2.0, 2.0, 0.0))
        return np.vstack([uv, tv]), np.vstack([uf, tf + len(uv)]), j

    monkeypatch.setattr(cgal, "mesh_boolean", with_void)
    rv, rf, rep = resolve_crossings(*_spiked_box())
    assert rep is not None and rep.bodies == 1
    vols = _shell_volumes(rv, rf)[1]
    assert len(vols) == 2 and vols.min() == pytest.approx(-0.1**3 / 6, rel=1e-5)  # float32 corners


def test_edges_too_short_after_the_union_are_collapsed(monkeypatch):
    """A spike leaving the bottom 1 um beside a vertex: with the union's vertices
    snapped at 1e-8 mm only, its edges of about 1 um are too short to texture
    (a real flashlight handle's union left 6e-8 mm); manifold3d's edge collapse
    (repair.COLLAPSE) removes them, keeping the volume, or the mesh is refused."""
    import texcad.solid.repair as repair
    from texcad.solid import self_intersections

    v, f = _spiked_box()
    top = np.argmin(v[:, 2])
    v[top, :2] += 1e-6  # the spike's tip beside the bottom's grid vertex
    monkeypatch.setattr(repair, "MERGE", (1e-8,))
    monkeypatch.setattr(repair, "COLLAPSE", ())
    assert repair.resolve_crossings(v, f)[2].bodies == 1  # merged as vertices closer than repair.NEAR
    monkeypatch.setattr(repair, "NEAR", 0.0)  # the collapse's own test
    with pytest.raises(InputError, match=r"edges of .* mm, too short to texture"):
        repair.resolve_crossings(v, f)
    monkeypatch.setattr(repair, "COLLAPSE", (1e-5, 1e-4))
    rv, rf, rep = repair.resolve_crossings(v, f)
    e = rf[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    assert np.linalg.norm(rv[e[:, 0]] - rv[e[:, 1]], axis=1).min() >= repair.MIN_EDGE
    assert len(self_intersections(rv, rf)) == 0 and rep.bodies == 1
    assert abs(rep.volume[1] - rep.volume[0]) < 0.01


def test_a_mesh_with_a_small_crossing_is_textured_with_a_note():
    import texcad
    from texcad.errors import TexcadWarning
    from texcad.solid import self_intersections

    v, f = _spiked_box()
    with pytest.warns(TexcadWarning, match="pairs of crossing triangles resolved"):
        tx = texcad.texture(trimesh.Trimesh(v, f, process=False), "normal:+x:10", "builtin:ridges", pitch=1.0, height=0.5)
    assert tx.info["crossings_repaired"] > 0 and "self-union" in tx.info["repaired"]
    assert tx.mesh.is_watertight and tx.gate.shells.bodies == 1
    assert len(self_intersections(tx.mesh.vertices, tx.mesh.faces)) == 0


def test_pinched_vertices_are_counted_and_split():
    from texcad.solid.repair import split_pinches

    t = trimesh.creation.box((1.0, 1.0, 1.0))
    v, f = np.array(t.vertices), np.array(t.faces, dtype=np.int64)
    assert split_pinches(v, f)[2] == 0
    corner = int(np.argmax(v.sum(1)))  # a second box touching the first at that corner only
    v2 = np.vstack([v, v - v[int(np.argmin(v.sum(1)))] + v[corner]])
    f2 = np.vstack([f, f + len(v)])
    v2, f2, bodies = repair_closed(v2, f2)
    assert bodies == 2
    sv, sf, n = split_pinches(v2, f2)
    assert n == 1 and len(sv) == len(v2) + 1 and edge_report(sf)["boundary"] == 0


def test_self_intersections_remembers_the_last_mesh_without_sharing_its_answer():
    from texcad.solid import self_intersections

    v, f = _spiked_box()
    a = self_intersections(v, f)
    a[:] = -1
    assert (self_intersections(v, f) >= 0).all()
    v2 = v.copy()
    v2[0, 0] += 1e-3  # another mesh: tested afresh
    assert len(self_intersections(v2, f)) == len(self_intersections(v, f))


def test_a_small_crossing_whose_union_is_no_clean_solid_is_refused_saying_so(monkeypatch):
    """Where the self-union leaves edges too short to texture (here: any edge, by a
    bound raised for the test), the refusal says a repair was tried, and where."""
    from texcad.solid import repair

    monkeypatch.setattr(repair, "MIN_EDGE", 1e3)
    v, f = _spiked_box()
    with pytest.raises(InputError, match=r"8 pairs of its triangles cross \(one near .*texcad's repair, a self-union.*"
                                         r"too short to texture.*export it again"):
        repair.resolve_crossings(v, f)


def _stacked_boxes(same_wall: bool):
    """Two unit boxes in one mesh, one on the other (a shaft in its bore, a lid on its
    box, exported as one STL), each wound outward: the shared wall is the same two
    triangles wound both ways (``same_wall``), or the upper box's own two, cut along
    the other diagonal; volume 2."""
    a = trimesh.creation.box((1.0, 1.0, 1.0))
    a.apply_translation((0.5, 0.5, 0.5))
    top = a.faces[np.isclose(a.triangles_center[:, 2], 1.0)]
    upper = a.faces[~np.isclose(a.triangles_center[:, 2], 0.0)] + 8  # the upper box but its bottom
    if same_wall:
        wall = top[:, ::-1]
    else:
        diag = np.intersect1d(top[0], top[1])
        other = np.setdiff1d(top.ravel(), diag)
        wall = np.array([[other[0], other[1], diag[0]], [other[1], other[0], diag[1]]])
        p = a.vertices[wall]
        down = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])[:, 2] < 0
        wall[~down] = wall[~down][:, ::-1]
    return np.vstack([a.vertices, a.vertices + (0.0, 0.0, 1.0)]), np.vstack([a.faces, upper, wall])


def test_bodies_touching_face_to_face_are_united_or_taken_apart():
    """The same wall wound both ways goes (their union, one body); walls of their own
    are kept, and the edges around them (4 triangles each) are taken apart: two closed
    bodies at the same place (for ``union=True``). Either way volume 2."""
    v, f = _stacked_boxes(same_wall=True)
    rv, rf, bodies = repair_closed(v, f)
    assert bodies == 1 and len(rf) == 20 and edge_report(rf)["watertight"]
    assert trimesh.Trimesh(rv, rf, process=False).volume == pytest.approx(2.0, rel=1e-9)
    v, f = _stacked_boxes(same_wall=False)
    rv, rf, bodies = repair_closed(v, f)
    rep = edge_report(rf)
    assert bodies == 2 and rep["watertight"] and rep["misoriented"] == 0 and len(rv) == 12 + 4
    assert trimesh.Trimesh(rv, rf, process=False).volume == pytest.approx(2.0, rel=1e-9)


def test_repairs_beyond_merging_are_noted_and_warned():
    """A repair that changes the surface (a wall two bodies share dropped, edges taken
    apart) is said in ``notes``, and texturing such a mesh warns with it: a silent
    union could be the wrong part. A mesh closed as it is adds no note."""
    import texcad
    from texcad.errors import TexcadWarning

    notes = []
    repair_closed(*_stacked_boxes(same_wall=True), notes=notes)
    assert len(notes) == 1 and "2 triangles of walls shared face to face dropped" in notes[0]
    notes = []
    repair_closed(*_stacked_boxes(same_wall=False), notes=notes)
    assert len(notes) == 1 and "4 edges shared by more than two triangles taken apart" in notes[0]
    notes = []
    a = trimesh.creation.box((1.0, 1.0, 1.0))
    repair_closed(a.vertices, a.faces, notes=notes)
    assert notes == []
    v, f = _stacked_boxes(same_wall=True)
    with pytest.warns(TexcadWarning, match="was repaired: 2 triangles of walls shared face to face dropped"):
        tx = texcad.texture(trimesh.Trimesh(v * 20.0, f, process=False), "top", "builtin:stones", height=0.5, pitch=1.0)
    assert "walls shared face to face" in tx.info["repaired"] and tx.mesh.is_watertight


def test_bodies_touching_along_an_edge_are_taken_apart():
    """Two boxes sharing only an edge (4 triangles on it): the edge's two vertices are
    split per body; two closed, outward bodies of volume 1 each."""
    a = trimesh.creation.box((1.0, 1.0, 1.0))
    v = np.vstack([a.vertices, a.vertices + (1.0, 1.0, 0.0)])
    f = np.vstack([a.faces, a.faces + 8])
    rv, rf, bodies = repair_closed(v, f)
    assert bodies == 2 and edge_report(rf)["watertight"] and len(rv) == 16
    vols = [b.volume for b in trimesh.Trimesh(rv, rf, process=False).split(only_watertight=False)]
    assert vols == pytest.approx([1.0, 1.0], rel=1e-9)


def test_touching_bodies_are_textured_with_union():
    """A mesh of two bodies touching face to face: refused naming ``union=True``
    without it; with it, one watertight body (the texture on the top)."""
    import texcad

    v, f = _stacked_boxes(same_wall=False)
    mesh = trimesh.Trimesh(v * 20.0, f, process=False)
    with pytest.raises(InputError, match="union=True"):
        texcad.texture(mesh, "top", "builtin:stones", height=0.5, pitch=1.0)
    tx = texcad.texture(mesh, "top", "builtin:stones", height=0.5, pitch=1.0, union=True)
    assert tx.gate.shells.bodies == 1 and tx.mesh.is_watertight
    assert tx.volume > 2 * 20.0**3


def _needle_box():
    """A unit box whose edge ``p q`` is split at its middle ``m`` on one side, the
    T-junction stitched with the needle ``(p, q, m)`` (zero area), as PrusaSlicer's
    3MF stitches them: closed, every edge in two triangles."""
    b = trimesh.creation.box((1.0, 1.0, 1.0))
    v, f = np.array(b.vertices), np.array(b.faces, dtype=np.int64)
    p, q, x = f[0]
    m = len(v)
    v = np.vstack([v, 0.5 * (v[p] + v[q])])
    f = np.vstack([f[1:], [[p, m, x], [m, q, x], [p, q, m]]])
    return v, f


def test_a_needle_is_flipped_away():
    from texcad.solid.repair import flip_needles

    v, f = _needle_box()
    assert edge_report(f)["watertight"]
    g, n = flip_needles(v, f)
    p = v[g]
    area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
    assert n == 1 and area.min() > 0.1 and edge_report(g)["watertight"] and edge_report(g)["misoriented"] == 0
    assert trimesh.Trimesh(v, g, process=False).volume == pytest.approx(1.0, rel=1e-12)
    rv, rf, _ = repair_closed(v, f)  # the repair does it too
    p = rv[rf]
    assert np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).min() > 0.1


def test_walls_touching_by_position_are_pulled_apart():
    """Two boxes indexed apart but touching along an edge (what a reader that joins
    points by position sees as 4 triangles on one edge): the 4 points there move
    ``PULL`` mm inwards, after which every edge is in two triangles by position too."""
    from texcad.report.gate import shell_report
    from texcad.solid import Mesh
    from texcad.solid.repair import PULL, pull_apart

    a = trimesh.creation.box((1.0, 1.0, 1.0))
    v = np.vstack([a.vertices, a.vertices + (1.0, 1.0, 0.0)])
    f = np.vstack([a.faces, a.faces + 8]).astype(np.int64)
    assert not shell_report(Mesh(v, f)).closed
    out = pull_apart(v, f)
    moved = np.linalg.norm(out - v, axis=1)
    assert np.count_nonzero(moved) == 4 and moved.max() == pytest.approx(PULL, rel=1e-9)
    assert shell_report(Mesh(out, f)).closed
    touched = np.isin(f, np.flatnonzero(moved)).any(axis=1)
    area = trimesh.Trimesh(v, f[touched], process=False).area  # the volume moves by at most PULL x this
    assert 0 < 2.0 - trimesh.Trimesh(out, f, process=False).volume <= PULL * area


def test_specks_are_dropped_and_said():
    """A box with a tetrahedron 30 nm across beside it (debris PrusaSlicer's 3MF
    carried): the speck goes, the box stays one body, and the result says so."""
    import texcad
    from texcad.solid.repair import drop_specks

    box = trimesh.creation.box((20.0, 20.0, 6.0))
    tet = trimesh.creation.box((3e-5, 3e-5, 3e-5))
    tet.apply_translation((15.0, 0.0, 0.0))
    v = np.vstack([box.vertices, tet.vertices])
    f = np.vstack([box.faces, tet.faces + len(box.vertices)]).astype(np.int64)
    rv, rf, bodies = repair_closed(v, f)
    assert bodies == 2
    dv, df, bodies, n = drop_specks(rv, rf)
    assert n == 1 and bodies == 1 and len(df) == len(box.faces)
    tx = texcad.texture(trimesh.Trimesh(v, f, process=False), "top", "builtin:stones", height=0.5, pitch=1.0)
    assert tx.gate.shells.bodies == 1 and "1 speck dropped" in tx.info["repaired"]


def test_a_mesh_closed_but_non_manifold_is_not_told_to_close_holes():
    """A FreeCAD 3MF of 18 touching plates (floookay/klappbrettle): 0 open edges, 5952
    non-manifold ones, and the advice was 'close the holes'. Here two cubes with one
    wall between them: its rim's 4 edges each in three triangles."""
    a, b = trimesh.creation.box((1, 1, 1)), trimesh.creation.box((1, 1, 1))
    b.apply_translation((1, 0, 0))
    keep = ~np.isclose(b.triangles_center[:, 0], 0.5)  # the wall once, from the first cube
    v = np.concatenate([a.vertices, b.vertices])
    f = np.concatenate([a.faces, b.faces[keep] + len(a.vertices)])
    with pytest.raises(InputError, match=r"\(0 open edges, 4 non-manifold edges\).*overlap or touch") as e:
        repair_closed(v, f)
    assert "close the holes" not in str(e.value)
