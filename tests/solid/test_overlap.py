"""Overlapping and touching bodies of a mesh (texcad.solid.overlap), their union, the
mesh adapter's refusal (never an inside-out shell), and the broad phase of
self_intersections (issue 27)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import texcad
from texcad.errors import InputError
from texcad.solid import repair_closed, self_intersections
from texcad.solid import intersect
from texcad.solid.overlap import describe_overlaps, overlapping_bodies, split_bodies, union_bodies


def _boxes(*specs):
    """One mesh of several boxes ``(extents, centre)`` mm, repaired as the mesh adapter does."""
    parts = []
    for ext, centre in specs:
        b = trimesh.creation.box(ext)
        b.apply_translation(centre)
        parts.append(b)
    m = trimesh.util.concatenate(parts)
    v, f, _ = repair_closed(m.vertices, m.faces)
    return v, f


CASES = {  # name: (boxes, expected kinds, shared volume mm3)
    "apart": ((((10, 10, 10), (0, 0, 0)), ((10, 10, 10), (20, 0, 0))), [], 0.0),
    "crossing": ((((10, 10, 10), (0, 0, 0)), ((10, 10, 10), (5, 5, 5))), ["overlap"], 125.0),
    # the crossings lie on triangle edges and coplanar faces: self_intersections sees none
    "stacked on one footprint": ((((10, 10, 10), (0, 0, 5)), ((10, 10, 10), (0, 0, 10))), ["overlap"], 500.0),
    "inside, sharing the sides": ((((10, 10, 10), (0, 0, 0)), ((10, 10, 4), (0, 0, 0))), ["overlap"], 400.0),
    "touching": ((((10, 10, 10), (0, 0, 0)), ((6, 6, 10), (0, 0, 10))), ["touch"], 0.0),
    # a CAD export: the upper body's face 0.5 um above the lower one's (a real beer-tap handle)
    "stacked 0.5 um apart": ((((10, 10, 10), (0, 0, 0)), ((6, 2, 10), (0, 0, 10.0005))), ["touch"], 0.0),
    "cavity": ((((10, 10, 10), (0, 0, 0)), ((4, 4, 4), (0, 0, 0))), [], 0.0),
    "cavity at the wall": ((((10, 10, 10), (0, 0, 0)), ((4, 4, 4), (0, 0, -3))), ["cavity"], 0.0),
}


@pytest.mark.parametrize("name", list(CASES))
def test_overlapping_bodies_are_found(name):
    specs, kinds, shared = CASES[name]
    v, f = _boxes(*specs)
    split = split_bodies(v, f)
    found = overlapping_bodies(v, f, split=split)
    assert [o.kind for o in found] == kinds
    assert sum(o.volume for o in found) == pytest.approx(shared, abs=1e-3)
    if found:
        text = describe_overlaps(found, split)
        assert "body 1" in text and "mm3" in text
    if name == "cavity":
        assert split.volumes.tolist() == pytest.approx([1000.0 - 64.0])


def test_stacked_bodies_hide_from_self_intersections():
    v, f = _boxes(((10, 10, 10), (0, 0, 5)), ((10, 10, 10), (0, 0, 10)))
    assert len(self_intersections(v, f)) == 0  # why the volume test is needed
    assert overlapping_bodies(v, f)[0].volume == pytest.approx(500.0)


@pytest.mark.parametrize("name", ["crossing", "stacked on one footprint", "touching", "stacked 0.5 um apart"])
def test_union_gives_one_outward_body(name):
    specs, _, shared = CASES[name]
    v, f = _boxes(*specs)
    total = sum(float(np.prod(e)) for e, _ in specs)
    uv, uf, note = union_bodies(v, f)
    rv, rf, bodies = repair_closed(uv, uf)
    assert bodies == 1 and "united 2 bodies into 1" in note
    p = rv[rf]
    vol = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0
    assert vol == pytest.approx(total - shared, rel=1e-5)  # the gap closed: 12 mm2 x 0.5 um
    assert overlapping_bodies(rv, rf) == []


def _signed_shell_volumes(mesh):
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    split = split_bodies(v, f)
    return split.signed


@pytest.mark.parametrize("name", ["crossing", "stacked on one footprint", "inside, sharing the sides"])
def test_texture_refuses_or_unites_never_inside_out(tmp_path, name):
    specs, _, shared = CASES[name]
    parts = []
    for ext, centre in specs:
        b = trimesh.creation.box(ext)
        b.apply_translation(centre)
        parts.append(b)
    stl = tmp_path / "two.stl"
    trimesh.util.concatenate(parts).export(stl)
    with pytest.raises(InputError, match=r"body 1 \(1000.0 mm3\).*overlap by .*union"):
        texcad.texture(str(stl), "all", "builtin:ridges", height=0.5, pitch=2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        tx = texcad.texture(str(stl), "all", "builtin:ridges", height=0.5, pitch=2.0, union=True)
    assert "united 2 bodies into 1" in tx.info["repaired"] and tx.info["bodies"] == 1
    assert tx.mesh.is_watertight
    signed = _signed_shell_volumes(tx.mesh)
    assert np.all(signed > 0), signed  # no inside-out shell
    total = sum(float(np.prod(e)) for e, _ in specs) - shared
    assert tx.mesh.volume > total  # raised texture on the united body


def test_bodies_a_cad_export_left_apart_are_refused_up_front_and_united(tmp_path):
    """A texture raised on both faces of a 0.5 um gap would push them into each other:
    refused before any work, naming --union; with it, one textured body."""
    specs = CASES["stacked 0.5 um apart"][0]
    stl = tmp_path / "stack.stl"
    trimesh.util.concatenate([trimesh.creation.box(e).apply_translation(c) for e, c in specs]).export(stl)
    with pytest.raises(InputError, match=r"body 1 \(1000.0 mm3\) and body 2 \(120.0 mm3\) touch.*--union"):
        texcad.texture(str(stl), "all", "builtin:ridges", height=0.5, pitch=2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        tx = texcad.texture(str(stl), "all", "builtin:ridges", height=0.5, pitch=2.0, union=True)
    assert tx.info["bodies"] == 1 and tx.mesh.is_watertight and len(split_bodies(tx.mesh.vertices, tx.mesh.faces).volumes) == 1
    assert np.all(_signed_shell_volumes(tx.mesh) > 0)


def test_bodies_closer_than_the_texture_fail_the_gate_saying_why(tmp_path):
    """Two boxes 0.2 mm apart pass the input check; a 0.5 mm raised texture on their
    facing faces pushes them into each other, which the gate refuses by name."""
    stl = tmp_path / "near.stl"
    boxes = [trimesh.creation.box((10, 10, 10)), trimesh.creation.box((10, 10, 10)).apply_translation((10.2, 0, 0))]
    trimesh.util.concatenate(boxes).export(stl)
    with pytest.raises(texcad.GeometryError, match=r"overlap by .*bodies 1 and 2 lie 0\.20 mm apart, closer "
                                                  r"than their textures reach.*move the bodies apart"):
        texcad.texture(str(stl), "all", "builtin:ridges", height=0.5, pitch=0.5, border=0.0)


def test_union_option_is_checked_and_refused_elsewhere():
    with pytest.raises(texcad.ParameterError, match="union"):
        texcad.texture(trimesh.creation.box((10, 10, 10)), "all", "builtin:ridges", union="yes")


# --- self_intersections' broad phase -------------------------------------------------

TETRA = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
#: two tetrahedra whose edges pierce each other's faces (found by a random search)
PIERCING = np.array([[5.12, 9.5, 1.44], [9.49, 3.12, 4.23], [8.28, 4.09, 5.5], [0.28, 7.54, 5.38],
                     [3.3, 7.88, 3.03], [4.53, 1.34, 4.03], [2.03, 2.62, 7.5], [2.8, 4.85, 9.81]])


def _brute(v, f):
    """Every crossing pair, all pairs tested (the reference)."""
    tri = v[f]
    a, b = np.triu_indices(len(f), 1)
    share = np.zeros(len(a), bool)
    for i in range(3):
        for j in range(3):
            share |= f[a, i] == f[b, j]
    a, b = a[~share], b[~share]
    hit = intersect._edges_cross(tri[a], tri[b]) | intersect._edges_cross(tri[b], tri[a])
    return sorted(zip(a[hit].tolist(), b[hit].tolist()))


def _with_fine_sphere(p):
    """The tetrahedra beside a finely meshed sphere (small median triangle: small grid cells)."""
    s = trimesh.creation.icosphere(3, radius=1.0)
    s.apply_translation((30, 30, 30))
    return np.vstack([p, s.vertices]), np.vstack([TETRA, TETRA + 4, s.faces + 8])


def test_pierced_faces_are_found_on_the_whole_mesh():
    alone = self_intersections(PIERCING, np.vstack([TETRA, TETRA + 4]))
    v, f = _with_fine_sphere(PIERCING)
    whole = self_intersections(v, f)
    assert len(alone) > 0
    assert whole.tolist() == alone.tolist() == [list(p) for p in _brute(v, f)]


def test_broad_phase_matches_all_pairs():
    rng = np.random.default_rng(7)
    for _ in range(40):  # random crossing tetrahedra beside a fine sphere
        v, f = _with_fine_sphere(rng.uniform(0, 10, (8, 3)))
        assert self_intersections(v, f).tolist() == [list(p) for p in _brute(v, f)]


def test_union_cannot_undo_a_fold_and_says_so():
    b = trimesh.creation.box((10.0, 10.0, 10.0))
    v = np.array(b.vertices)
    v[int(np.argmax(v.sum(1)))] = (-2.0, -1.5, -12.0)  # a corner pushed through the far side
    with pytest.raises(InputError, match="inside one body.*cannot undo a fold"):
        texcad.texture(trimesh.Trimesh(v, b.faces, process=False), "all", "builtin:ridges", pitch=2.0, union=True)


def test_a_cavity_is_held_when_manifold3d_reads_its_body_otherwise(monkeypatch):
    """A body's manifold3d volume can differ from its shell's signed sum (manifold3d
    drops degenerate triangles of a shell that crosses itself: 2.5 mm3 on PrusaSlicer's
    extruder_idler_quads.obj). The cavity inside was then taken for an inside-out body
    of its own (and a 0.0009 mm3 void on Prusa's Core One L gantry for a body 0.00 mm
    from another). Here every outer shell reads 0.3 % larger in manifold3d: the 2 mm
    cavity is still the 10 mm box's."""
    import texcad.solid.overlap as ov

    made = ov._manifold

    def larger_outer(v, f):
        m = made(v, f)
        return m.scale((1.001, 1.001, 1.001)) if m.volume() > 100.0 else m

    monkeypatch.setattr(ov, "_manifold", larger_outer)
    box, cav = trimesh.creation.box((10.0, 10.0, 10.0)), trimesh.creation.box((2.0, 2.0, 2.0))
    v = np.vstack([box.vertices, cav.vertices])
    f = np.vstack([box.faces, cav.faces[:, ::-1] + 8]).astype(np.int64)
    split = split_bodies(v, f)
    assert len(split.solids) == 1 and split.body.tolist() == [0, 0]
    assert split.volumes[0] == pytest.approx((1000.0 - 8.0) * 1.001**3, rel=1e-9)  # the box with its cavity, as read


def test_a_union_leaves_no_void_of_micrometres_and_keeps_a_cavity():
    """manifold3d's union of a heat sink assembly STEP's nine solids left 50 voids
    of about 3e-6 mm3 (gaps of 7-22 um where walls nearly touched), each a body of
    the STL. The voids under VOID mm3 and slivers under SPECK (texcad.solid.repair's) go; a 1 mm cavity
    stays, and so does the volume."""
    from texcad.solid.overlap import VOID, _without_union_slivers
    from texcad.solid.repair import SPECK

    def box(lo, size, inward=False):
        b = trimesh.creation.box(bounds=(lo, np.add(lo, size)))
        return np.asarray(b.vertices, np.float64), np.asarray(b.faces[:, ::-1] if inward else b.faces, np.int64)

    parts = [box((0, 0, 0), (10, 10, 10)), box((2, 2, 2), (1, 1, 1), inward=True),
             box((5, 5, 5), (0.007, 1.0, 0.05), inward=True), box((20, 0, 0), (1e-3, 1e-3, 1e-3))]
    v = np.vstack([p[0] for p in parts])
    f = np.vstack([p[1] + 8 * k for k, p in enumerate(parts)])
    assert 0.007 * 1.0 * 0.05 < VOID and 1e-9 < SPECK
    kept, dropped, bodies = _without_union_slivers(v, f)
    assert dropped == 2 and bodies == 1 and len(kept) == 24
    split = split_bodies(v, kept)
    assert len(split.solids) == 1 and split.volumes[0] == pytest.approx(999.0, rel=1e-9)
