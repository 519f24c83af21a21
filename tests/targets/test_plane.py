"""The planar-face adapter (texcad.targets.plane): a mask on the face's texture
coordinates scales the height (issue 31), and keeps the ramps and the gate."""

from __future__ import annotations

import numpy as np
import pytest

import texcad


@pytest.fixture(scope="module")
def box():
    from build123d import Axis, Box

    b = Box(40, 20, 5)
    return b, b.faces().sort_by(Axis.Z)[-1]


def test_a_mask_keeps_the_texture_only_where_it_is_white(box):
    part, top = box
    half = np.zeros((20, 40))
    half[:, 20:] = 1.0  # the right half (+x) white
    full = texcad.texture(part, top, "builtin:stones", pitch=0.5, height=1.0)
    masked = texcad.texture(part, top, "builtin:stones", pitch=0.5, height=1.0, mask=half)
    xs = masked.stages.relief.data.xs
    h, h0 = masked.heightmap.heights, full.heightmap.heights
    assert h[:, xs < -1.0].max() <= 0.0011  # the 1 um floor, no texture
    np.testing.assert_array_equal(h[:, xs > 1.0], h0[:, xs > 1.0])
    # the gate checked the volume against the masked texture's own integral: about half
    added, added0 = masked.mesh.volume - 4000.0, full.mesh.volume - 4000.0
    assert 0.4 * added0 < added < 0.6 * added0
    assert masked.gate.shells.bodies == 1


def test_a_grey_mask_scales_the_height(box):
    part, top = box
    r = texcad.texture(part, top, "builtin:stones", pitch=0.5, height=1.0, mask=np.full((4, 4), 0.5))
    full = texcad.texture(part, top, "builtin:stones", pitch=0.5, height=1.0)
    assert r.heightmap.heights.max() == pytest.approx(0.5 * full.heightmap.heights.max(), abs=0.01)


def test_a_bad_mask_is_refused(box):
    part, top = box
    with pytest.raises(texcad.ParameterError, match="mask"):
        texcad.texture(part, top, "builtin:stones", pitch=0.5, mask=np.full((4, 4), 2.0))


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_cell_offsets_are_made_once_and_carried_to_the_b_rep(box):
    """The lean top's cell offsets are made with the relief (the crossing test) and
    carried in PlaneRelief for the B-rep, whose heights are those made from the slab
    again, bit for bit; without a B-rep (brep=False) or a lean top nothing is kept."""
    import dataclasses

    import texcad.targets.plane as plane

    part, top = box
    tx = texcad.texture(part, top, "builtin:stones", pitch=0.25, height=1.0)
    r = tx.stages.relief.data
    assert r.tolerance > 0 and r.offsets is not None
    assert r.offsets.cells.shape == (r.h.shape[0] - 1, r.h.shape[1] - 1) and r.offsets.centres.shape == r.h.shape
    again = plane._brep_heights(dataclasses.replace(r, offsets=None))
    np.testing.assert_array_equal(plane._brep_heights(r), again)
    assert texcad.texture(part, top, "builtin:stones", pitch=0.25, height=1.0, brep=False).stages.relief.data.offsets is None
    assert texcad.texture(part, top, "builtin:stones", pitch=0.25, height=1.0, tolerance=0).stages.relief.data.offsets is None


def test_far_from_lean_searches_only_nearby_triangles_with_the_same_answer():
    """plane._far_from_lean (the AABB built on the triangles within reach of the
    points) answers as a search of the whole lean top: points over pixel centres
    moved up and down by up to 3 x limit, limits below and above a pitch."""
    import igl

    import texcad.targets.plane as plane
    from texcad.solid import lean

    rng = np.random.default_rng(4)
    h = (np.cumsum(rng.normal(size=(41, 57)), axis=0) * 0.2).astype(np.float32)
    rc, f = lean.triangulate(h, 0.1, max_fraction=1.0)
    xs, ys = -3.0 + 0.25 * np.arange(57), 1.0 + 0.25 * np.arange(41)
    V = np.stack([xs[rc[:, 1]], ys[rc[:, 0]], h[rc[:, 0], rc[:, 1]]], axis=1).astype(np.float32).astype(np.float64)
    F = np.asarray(f, np.int64)
    for limit in (0.02, 0.1, 0.4):
        rr, cc = rng.integers(0, 41, 400), rng.integers(0, 57, 400)
        q = np.stack([xs[cc], ys[rr], h[rr, cc] + rng.uniform(-3, 3, 400) * limit], axis=1)
        want = igl.point_mesh_squared_distance(q, V, F)[0] > limit ** 2
        got = plane._far_from_lean(q, rr, cc, V, F, xs, ys, h.shape, limit)
        assert 0 < want.sum() < len(want)
        np.testing.assert_array_equal(got, want)


def _box_with_an_edge_off_its_top(off: float, tol: float):
    """A 20 x 20 x 4 mm box whose top face's edge along y = -10 has its 3-D curve
    ``off`` mm above the top plane and the tolerance ``tol`` mm (its vertices too), as
    a STEP file from another CAD program can have it."""
    from build123d import Axis, Box
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.Geom import Geom_Line
    from OCP.gp import gp_Vec

    part = Box(20, 20, 4)
    edge = part.faces().sort_by(Axis.Z)[-1].edges().sort_by(Axis.Y)[0]
    curve = BRep_Tool.Curve_s(edge.wrapped, 0.0, 0.0)  # a Geom_Line: the same parameters once moved
    line = Geom_Line(curve.Position().Translated(gp_Vec(0, 0, off)))
    b = BRep_Builder()
    b.UpdateEdge(edge.wrapped, line, tol)
    for v in edge.vertices():
        b.UpdateVertex(v.wrapped, tol)
    return part


def test_a_planar_face_within_its_edges_tolerance_is_textured():
    """Edges up to their own tolerance off the plane (a SolidWorks knob's rim: 11 um)
    are the file's accuracy, not a curved face: textured, watertight; farther than
    their tolerance they are refused, naming both figures."""
    import texcad
    from texcad.errors import GeometryError
    from build123d import Axis

    part = _box_with_an_edge_off_its_top(0.01, 0.012)
    tx = texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=0.4, pitch=0.5)
    assert tx.mesh.is_watertight and tx.volume > 20 * 20 * 4 + 20
    part = _box_with_an_edge_off_its_top(0.01, 1e-7)
    with pytest.raises(GeometryError, match="leave its plane by 0.01 mm, more than their own tolerance"):
        texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=0.4, pitch=0.5)
