"""Runs of edges between the same two faces written as one edge (texcad.io.step_edges):
the joined edge's breaks sit at the partial sums of OCCT's Gauss weights, keep every
kink and every knot a rising pcurve crosses, and a corner patch's STEP re-reads valid,
within 0.1 % in both of OCCT's rules, meshes closed and stays near its binary STL."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import texcad
from texcad.brep import check_shape, occt_volume, shape_to_mesh
from texcad.brep.gprop import GAUSS_POINTS, PAD_SPANS, gauss_knots
from texcad.io.step_edges import _crossed, _needed, _placed


def test_placed_breaks_are_gauss_partial_sums():
    """Three pieces (1, 2 and 1 mm) padded to 16 spans: the breaks and the spans
    between are partial sums of the 61-point weights over the 4 mm (to 1e-6 mm), each
    piece holds at least one span, the longest the most; unplaced (no rule along the
    edge): by length."""
    p = np.array([[0.0, 0, 0], [1, 0, 0], [3, 0, 0], [4, 0, 0]])
    T, sub = _placed(p, PAD_SPANS, GAUSS_POINTS)
    assert len(sub) == PAD_SPANS + 1 and len(T) == 4
    assert np.abs(sub - gauss_knots(0.0, 4.0, PAD_SPANS, GAUSS_POINTS)).max() <= 5e-7
    at = np.searchsorted(sub, T)
    assert np.isin(T, sub).all() and (np.diff(at) >= 1).all() and np.argmax(np.diff(at)) == 1
    T0, sub0 = _placed(p, 3, 0)
    assert np.allclose(T0, [0, 1, 3, 4]) and np.array_equal(T0, sub0)


def test_needed_keeps_kinks_and_crossed_knots():
    """Samples along a straight run at one pace are dropped; a turn of the 3-D curve,
    a change of pace of one pcurve, and a rising pcurve crossing a ``v`` knot of its
    face are kept (its ends always)."""
    s = np.arange(6.0)
    p = np.c_[s, np.zeros(6), np.zeros(6)]
    p[4:, 1] = s[4:] - 3.0  # turns at sample 3
    q0 = np.c_[np.zeros(6), s]  # rises along v, crossing the knot v = 2
    q1 = np.c_[np.r_[s[:2], 1.0 + 2.0 * (s[2:] - 1.0)], np.full(6, 1.0)]  # its pace changes at sample 1
    keep = _needed(s, p, [q0, q1], [(np.array([0.0, 1.0]), np.array([0.0, 2.0, 9.0])), None])
    assert keep.tolist() == [True, True, True, True, False, True]


def test_crossed_inserts_the_knots_a_pcurve_crosses():
    """A pcurve from v = 0 to 3 between two samples gets one at its face's knot v =
    1.5, all curves interpolated there; the cuts follow."""
    s = np.array([0.0, 3.0, 4.0])
    p = np.c_[s, s, s]
    q = np.c_[np.zeros(3), s]
    s2, p2, (q2,), cuts = _crossed(s, p, [q], np.array([0, 2]), [(np.array([0.0, 1.0]), np.array([0.0, 1.5, 4.0]))])
    assert s2.tolist() == [0.0, 1.5, 3.0, 4.0] and p2[1].tolist() == [1.5, 1.5, 1.5] and q2[1].tolist() == [0.0, 1.5]
    assert cuts.tolist() == [0, 3]


def _cap():
    from build123d import Axis, Cylinder, GeomType, fillet

    cap = fillet(Cylinder(10, 8).edges().sort_by(Axis.Z)[-1:], 2)
    return cap, [cap.faces().sort_by()[-1], *cap.faces().filter_by(GeomType.TORUS)]


def _runs_left(shape) -> int:
    """Vertices of ``shape`` that join two edges between the same two faces."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_VERTEX
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape

    fm = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_FACE, fm)
    ef, ve = TopTools_IndexedDataMapOfShapeListOfShape(), TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, ef)
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_VERTEX, TopAbs_EDGE, ve)

    def pair(e):
        return sorted(fm.FindIndex(f) for f in ef.FindFromKey(e))

    return sum(len(es) == 2 and pair(es[0]) == pair(es[1]) for es in (list(ve.FindFromIndex(i)) for i in range(1, ve.Extent() + 1)))


def test_corner_patch_step_joined(tmp_path, monkeypatch):
    """A cylinder's cap and fillet flattened together (an outline across the grid: a
    staircase of tiles and walls), stones 0.6 mm at 0.5 mm: the STEP at the mesh's
    tolerance re-reads one valid solid within 0.1 % of the mesh in OCCT's adaptive and
    plain rules, meshes closed, at most 2x its binary STL; without the runs joined it
    is 9 % larger (5 % at least), with twice as many vertices between two edges of the same two
    faces or more."""

    from texcad.io import step_tiles

    part, faces = _cap()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tx = texcad.texture(part, faces, "builtin:stones", height=0.6, pitch=0.5)
    tx.export(tmp_path / "cap.step")
    tx.export(tmp_path / "cap.stl")
    size = (tmp_path / "cap.step").stat().st_size
    assert size <= 2.0 * (tmp_path / "cap.stl").stat().st_size
    back = _assert_reads_back_whole(tmp_path / "cap.step", tx)
    monkeypatch.setattr(step_tiles, "joined_edges", lambda shape, knots_of: shape)
    tx.export(tmp_path / "apart.step")
    assert (tmp_path / "apart.step").stat().st_size >= 1.05 * size
    assert 2 * _runs_left(back) <= _runs_left(texcad.io.read_step(tmp_path / "apart.step"))


def test_faces_with_a_seam_keep_their_edges():
    """A drilled hole's wall has a seam: runs along its rim stay unjoined (joined, the
    wall of the demo plate's 8 mm hole re-read invalid from its STEP)."""
    from build123d import Box, Cylinder, GeomType
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedMapOfShape

    from texcad.io.step_edges import _linked, _seamed

    part = Box(20, 20, 5) - Cylinder(4, 10)
    fmap = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(part.wrapped, TopAbs_FACE, fmap)
    wall = part.faces().filter_by(GeomType.CYLINDER)[0].wrapped
    assert _seamed(part.wrapped, fmap) == {fmap.FindIndex(wall)}
    assert not any(f.IsSame(wall) for _, faces in _linked(part.wrapped) for f in faces)


def test_iso_param_and_line():
    """A pcurve's samples along an iso line give its running coordinate as an
    increasing parameter (negated where it falls) and a unit direction; a line in it
    is a Geom2d_Line with Value(T) the samples, a broken line or a slower one none."""
    from texcad.io.step_edges import _iso_param, _line2d

    q = np.array([[3.0, 5.0], [3.0, 4.2], [3.0, 1.5]])  # iso-u, v falling
    T, w = _iso_param(q)
    assert np.allclose(T, [-5.0, -4.2, -1.5]) and np.allclose(w, [0.0, -1.0])
    line = _line2d(q, T)
    assert np.allclose([line.Value(t).Coord() for t in T.tolist()], q)
    assert _iso_param(np.array([[0.0, 1.0], [1.0, 1.0], [0.5, 1.0]])) is None  # not one way
    assert _iso_param(np.array([[0.0, 1.0], [1.0, 1.5]])) is None  # not an iso line
    assert _line2d(np.array([[0.0, 0.0], [1.0, 0.0], [3.0, 0.0]]), np.array([0.0, 1.0, 2.0])) is None  # broken
    assert _line2d(np.array([[0.0, 0.0], [2.0, 0.0]]), np.array([0.0, 1.0])) is None  # twice as fast


def test_free_edges_become_lines(tmp_path, monkeypatch):
    """An edge along which neither face's plain volume rule integrates (a tile side
    along u, a low-u side: texcad.io.step_edges.lined_edges) is parametrised by its
    pcurve's running coordinate on a face where that is an iso line, so that pcurve
    (and the other where it runs as fast) is a LINE instead of a broken line: on a box
    top and two mitred fillets at 0.5 mm the STEP has fewer B-spline curves and is
    smaller, and re-reads as the same valid solid (both of OCCT's rules within 0.1 %,
    meshed closed)."""
    from build123d import Box, GeomType, fillet

    from texcad.io import step_tiles

    part = fillet(Box(24, 18, 8).edges().group_by()[-1], 2)
    faces = [part.faces().sort_by()[-1], *part.faces().filter_by(GeomType.CYLINDER)[:2]]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tx = texcad.texture(part, faces, "builtin:stones", height=0.6, pitch=0.5)
    tx.export(tmp_path / "lined.step")
    _assert_reads_back_whole(tmp_path / "lined.step", tx)
    monkeypatch.setattr(step_tiles, "lined_edges", lambda shape: shape)
    tx.export(tmp_path / "broken.step")
    lined, broken = (tmp_path / "lined.step").read_bytes(), (tmp_path / "broken.step").read_bytes()
    assert len(broken) >= 1.015 * len(lined)  # 563.6 kB / 552.9 kB
    assert broken.count(b"B_SPLINE_CURVE_WITH_KNOTS") >= lined.count(b"B_SPLINE_CURVE_WITH_KNOTS") + 25  # 934 / 898


def _assert_reads_back_whole(path, tx):
    """The STEP at ``path`` reads back one valid closed solid whose OCCT volume, by
    the adaptive and the plain rule, is the mesh's within 0.1 % (and the gate's
    slack), and that OCCT meshes closed at 0.1 mm / 0.5 rad."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    back = texcad.io.read_step(path)
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    room = 1e-3 * tx.volume + tx.info.get("volume_slack", 0.0)
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(back, props)
    assert abs(occt_volume(back) - tx.volume) <= room and abs(props.Mass() - tx.volume) <= room
    assert shape_to_mesh(back, tolerance=0.1, angular_tolerance=0.5).is_watertight
    return back


def test_shapes_in_lists_what_iterating_lists():
    """texcad.io.step_edges.shapes_in gives the shapes of a TopTools_ListOfShape in
    the order OCP's (slow) Python iteration gives them: an edge's two faces, a
    vertex's three edges, a list of one and an empty one; the list is left as it was."""
    from build123d import Box
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_VERTEX
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_ListOfShape

    from texcad.io.step_edges import shapes_in

    box = Box(3, 2, 1).wrapped
    lists = []
    for kind, up in ((TopAbs_EDGE, TopAbs_FACE), (TopAbs_VERTEX, TopAbs_EDGE)):  # edge -> faces, vertex -> edges
        m = TopTools_IndexedDataMapOfShapeListOfShape()
        TopExp.MapShapesAndAncestors_s(box, kind, up, m)
        lists += [m.FindFromIndex(k) for k in range(1, m.Extent() + 1)]
    one = TopTools_ListOfShape()
    one.Append(lists[0].First())
    lists += [one, TopTools_ListOfShape()]
    sizes = {x.Size() for x in lists}
    assert {0, 1, 2} <= sizes and max(sizes) > 2, sizes
    for x in lists:  # one per list
        want = [s for s in x]
        got = shapes_in(x)
        assert len(got) == len(want) == x.Size()
        assert all(a.IsEqual(b) for a, b in zip(got, want))
        assert x.Size() == len(want) and all(a.IsEqual(b) for a, b in zip([s for s in x], want))
