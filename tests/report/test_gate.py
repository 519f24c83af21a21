"""texcad.report.gate: the one independent check of every result (issue 26).

Each test crafts what must be refused and checks the figures in the message: an
inside-out shell, overlapping bodies, a body inside a body, a relief the union lost,
a relief that landed off its face, a texture the limits removed.
"""

from __future__ import annotations

import warnings

import manifold3d as m3d
import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError, TexcadWarning
from texcad.report.gate import Expectation, gate, shell_report
from texcad.solid import Mesh


def _mesh(man) -> tuple[np.ndarray, np.ndarray]:
    m = man.to_mesh()
    return np.array(m.vert_properties[:, :3], np.float32), np.array(m.tri_verts, np.int64)


def _together(*parts) -> Mesh:
    vs, fs, off = [], [], 0
    for v, f in parts:  # per shell
        vs.append(v)
        fs.append(f + off)
        off += len(v)
    return Mesh(np.concatenate(vs), np.concatenate(fs))


BOX = _mesh(m3d.Manifold.cube((10, 10, 10)))
FAR = _mesh(m3d.Manifold.cube((10, 10, 10)).translate((30, 0, 0)))
OVER = _mesh(m3d.Manifold.cube((10, 10, 10)).translate((5, 5, 5)))
SMALL = _mesh(m3d.Manifold.cube((4, 4, 4)).translate((3, 3, 3)))


def test_one_box_passes_with_its_figures():
    sr = shell_report(_together(BOX))
    assert sr.manifold and sr.bodies == 1 and sr.volumes == pytest.approx((1000.0,))


def test_inside_out_shell_is_refused():
    inside_out = (BOX[0], BOX[1][:, ::-1])
    sr = shell_report(_together(inside_out, FAR))
    assert sr.closed and sr.inside_out == 1 and not sr.manifold
    with pytest.raises(GeometryError, match=r"face inwards.*-1000.0"):
        gate(_together(inside_out, FAR), Expectation(bodies=2))


def test_cavity_is_a_cavity_not_an_inside_out_shell():
    sr = shell_report(_together(BOX, (SMALL[0], SMALL[1][:, ::-1])))
    assert sr.manifold and sr.bodies == 1 and sum(sr.volumes) == pytest.approx(1000.0 - 64.0)


def test_overlapping_bodies_are_refused_with_the_shared_volume():
    sr = shell_report(_together(BOX, OVER))
    assert sr.overlap_mm3 == pytest.approx(125.0, rel=1e-6)
    with pytest.raises(GeometryError, match="overlap by 125 mm3"):
        gate(_together(BOX, OVER), Expectation(bodies=2))


def test_body_inside_a_body_is_refused():
    assert shell_report(_together(BOX, SMALL)).nested_bodies == 1


def test_body_count_must_match_the_part():
    with pytest.raises(GeometryError, match="2 bodies where the part has 1"):
        gate(_together(BOX, FAR), Expectation(bodies=1))


def test_open_mesh_is_refused_with_its_edge_counts():
    v, f = BOX
    with pytest.raises(GeometryError, match=r"3 open"):
        gate(Mesh(v, f[1:]), Expectation(bodies=1))


def test_volume_change_against_the_texture_integral():
    base = _together(BOX)
    bigger = _together(_mesh(m3d.Manifold.cube((10, 10, 11))))
    ok = gate(bigger, Expectation(bodies=1, base=base, volume=100.0, volume_slack=1.0))
    assert ok.volume_change == pytest.approx(100.0)
    with pytest.raises(GeometryError, match=r"changed by \+100.00 mm3 where the texture's integral is \+150.00"):
        gate(bigger, Expectation(bodies=1, base=base, volume=150.0, volume_slack=1.0))


def test_a_texture_the_limits_removed_warns_with_the_figures():
    base = _together(BOX)
    with pytest.warns(TexcadWarning, match=r"removed 90 % of the texture"):
        gate(base, Expectation(bodies=1, base=base, volume=1.0, volume_slack=2.0, nominal_volume=10.0))


def test_reach_refuses_material_far_from_the_selected_face():
    base = _together(BOX)
    top = (np.array([[0, 0, 10], [10, 0, 10], [10, 10, 10], [0, 10, 10]], np.float64), np.array([[0, 1, 2], [0, 2, 3]]))
    tall = _together(_mesh(m3d.Manifold.cube((10, 10, 11))))
    assert gate(tall, Expectation(bodies=1, base=base, selected=top, height=1.0)).farthest_mm <= 1.3
    side = (np.array([[10, 0, 0], [10, 10, 0], [10, 10, 10], [10, 0, 10]], np.float64), np.array([[0, 1, 2], [0, 2, 3]]))
    with pytest.raises(GeometryError, match="from the selected surface"):
        gate(tall, Expectation(bodies=1, base=base, selected=side, height=0.2))


# -- through texcad.texture ------------------------------------------------------------------
def _plate():
    from build123d import Axis, Box

    part = Box(30, 20, 6)
    return part, part.faces().sort_by(Axis.Z)[-1]


def test_every_planar_result_carries_the_gate_figures():
    part, top = _plate()
    tx = texcad.texture(part, top, "builtin:stones", pitch=0.5, height=0.8)
    g = tx.gate
    assert g.shells.manifold and g.shells.bodies == 1
    assert abs(g.volume_change - g.expected_volume) <= g.volume_slack
    assert g.farthest_mm <= g.reach_mm


def test_a_union_that_loses_the_relief_is_refused(monkeypatch):
    """A crafted fault: the fuse stage hands back the bare part (the relief lost)."""
    import texcad.targets.plane as plane

    part, top = _plate()
    monkeypatch.setattr(plane, "fuse_on_plane", lambda *a, **k: (_ for _ in ()).throw(GeometryError("no stitch")))
    monkeypatch.setattr(plane, "fuse", lambda base, slab: base)
    with pytest.raises(GeometryError, match="texture's integral"):
        texcad.texture(part, top, "builtin:stones", pitch=0.5, height=0.8)


def test_overlapping_bodies_in_a_mesh_never_give_an_inside_out_shell(tmp_path):
    """Two boxes that overlap, their crossings on triangle edges (issue 26): refused,
    never written with an inside-out shell."""
    a = _mesh(m3d.Manifold.cube((20, 20, 10)))
    b = _mesh(m3d.Manifold.cube((20, 20, 10)).translate((10, 0, 5)))
    with pytest.raises(texcad.TexcadError):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            texcad.texture(_together(a, b), "normal:+z:30", "builtin:stones", pitch=1.0)


def test_check_never_calls_an_inside_out_shell_manifold(tmp_path):
    from texcad.io import write_stl

    path = tmp_path / "inside_out.stl"
    write_stl(_together((BOX[0], BOX[1][:, ::-1]), FAR), path)
    rep = texcad.check(path)
    assert not rep.manifold and any("face inwards" in n for n in rep.notes)


def test_cad_operations_work_on_mesh_results():
    from build123d import Cylinder, Pos

    mesh = _together(_mesh(m3d.Manifold.cube((30, 30, 10))))
    tx = texcad.texture(mesh, "normal:+z:30", "builtin:stones", pitch=1.0, height=0.6)
    cut = tx - Pos(15, 15, 0) * Cylinder(3, 40)  # a 6 mm hole through the 10 mm slab: about 290 mm3
    assert cut.mesh.is_watertight and cut.volume == pytest.approx(tx.volume - np.pi * 9 * 10, rel=0.002, abs=15)
    with pytest.raises(GeometryError, match="STL or 3MF"):
        cut.shape
    assert (tx + Cylinder(2, 40)).volume > tx.volume
    assert tx.mirrored().volume == pytest.approx(tx.volume, rel=1e-6)


def test_weld_by_position_finds_repeated_positions_and_leaves_distinct_ones():
    """The float32 weld's hash pass: faces unchanged when no two positions are equal,
    and vertices at one position made one when some are (as np.unique of the bytes)."""
    from texcad.report.gate import _by_position

    v, f = _mesh(m3d.Manifold.sphere(5.0, 48))
    assert _by_position(v, f) is f
    v2 = np.concatenate([v, v[:7]])  # 7 copies of existing positions
    f2 = f.copy()
    f2[:7, 0] = len(v) + np.arange(7)
    welded = _by_position(v2, f2)
    assert np.array_equal(welded, np.where(f2 >= len(v), f2 - len(v), f2))


def test_reach_takes_no_bound_from_vertices_of_the_same_index_off_the_surface():
    """Check 5's same-index bound is a distance to a point of the selected surface,
    so a vertex far from it is refused even when the selected surface's vertex of the
    same index is near (or the numbers do not correspond at all)."""
    base = _together(BOX)
    tall = _together(_mesh(m3d.Manifold.cube((10, 10, 11))))
    side = (np.array([[10, 0, 0], [10, 10, 0], [10, 10, 10], [10, 0, 10]], np.float64), np.array([[0, 1, 2], [0, 2, 3]]))
    # the selected surface's vertices renumbered to sit where the tall box's vertices are
    pts = np.asarray(tall.vertices, dtype=np.float64)
    sv = np.concatenate([pts, side[0]])
    sel = (sv, side[1] + len(pts))
    with pytest.raises(GeometryError, match="from the selected surface"):
        gate(tall, Expectation(bodies=1, base=base, selected=sel, height=0.2))
