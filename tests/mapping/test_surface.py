"""Profiles and surfaces (paper, section 2.2, eq. 2-13): arc length against closed
forms and OCCT, normals, curvature, function pieces, CAD input, base bodies."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ellipeinc

from texcad.errors import InputError, ParameterError
from texcad.mapping import Profile, Surface

UM = 1e-3  # one micrometre in mm


def test_circle_arc_length_is_r_theta():
    """Eq. 7-8: rho = R theta, to 1 um over the 125.7 mm perimeter."""
    r = 20.0
    p = Profile.circle(r, center=(3.0, -2.0))
    assert abs(p.length - 2 * np.pi * r) < UM
    s = np.linspace(0, p.length, 2001)[:-1]
    f = p.at(s)
    d = f.point - np.array([3.0, -2.0])
    theta = np.unwrap(np.arctan2(d[:, 1], d[:, 0]))
    assert np.abs(np.hypot(d[:, 0], d[:, 1]) - r).max() < UM
    assert np.abs(r * (theta[0] - theta) - s).max() < UM  # clockwise from (p + R, q)
    # Outward normal, convex curvature 1/R.
    assert np.allclose(f.normal, d / r, atol=1e-9)
    assert np.allclose(f.curvature, 1 / r, rtol=1e-6)
    inside = Profile.circle(r, side="inside")
    assert np.allclose(inside.at(s).curvature, -1 / r, rtol=1e-6)


def test_sine_arc_length_is_the_elliptic_integral():
    """Eq. 9-13: s(x) = L / (2 pi) sqrt(1 + k^2) E(2 pi x / L | m), k = 2 pi A / L,
    m = k^2 / (1 + k^2), to 1 um over 100 mm."""
    for amp, period, phase in ((5.0, 50.0, 0.0), (12.0, 20.0, 0.0), (2.0, 33.0, 0.0)):
        p = Profile.sine(amp, period, 100.0, phase=phase)
        k = 2 * np.pi * amp / period
        m = k * k / (1 + k * k)

        def s_exact(x):
            return period / (2 * np.pi) * np.sqrt(1 + k * k) * ellipeinc(2 * np.pi * x / period, m)

        assert abs(p.length - s_exact(100.0)) < UM
        s = np.linspace(0, p.length, 3001)
        pt = p.point(s)
        assert np.abs(pt[:, 1] - amp * np.sin(2 * np.pi * pt[:, 0] / period)).max() < UM
        assert np.abs(s_exact(pt[:, 0]) - s).max() < UM


def test_plane_and_function_profiles():
    p = Profile.plane(100.0, z=1.5)
    s = np.linspace(0, 100, 11)
    assert np.allclose(p.point(s), np.stack([s, np.full(11, 1.5)], 1), atol=1e-12)
    assert [f.facing for f in p.function_pieces()] == [1]
    q = Profile.function(lambda x: 0.01 * x**2, 0.0, 100.0)  # s = closed form of a parabola
    a = 0.01

    def s_par(x):
        u = 2 * a * x
        return (u * np.sqrt(1 + u * u) + np.arcsinh(u)) / (4 * a)

    pts = q.point(np.linspace(0, q.length, 501))
    assert abs(q.length - s_par(100.0)) < UM
    assert np.abs(s_par(pts[:, 0]) - np.linspace(0, q.length, 501)).max() < UM
    # Scalar-only functions are accepted too.
    r = Profile.function(lambda x: float(np.sin(x)), 0.0, 3.0, samples=64)
    assert r.length == pytest.approx(Profile.function(np.sin, 0.0, 3.0).length, abs=1e-4)


def test_build123d_inputs_agree_with_occt_lengths():
    from build123d import (
        BuildLine,
        BuildSketch,
        CenterArc,
        Edge,
        Line,
        Plane,
        Rectangle,
        Spline,
        Wire,
        fillet,
    )

    circle = Edge.make_circle(20.0, Plane.XZ)
    p = Profile.from_cad(circle)
    assert p.closed and abs(p.length - 2 * np.pi * 20) < UM
    # Builder mode: a closed periodic spline on Plane.XZ.
    with BuildLine(Plane.XZ) as bl:
        Spline((0, 0), (30, -5), (50, 10), (35, 30), (5, 25), periodic=True)
    sp = Profile.from_cad(bl.line)
    assert sp.closed and abs(sp.length - bl.line.edges()[0].length) < UM
    assert sp.signed_area < 0  # clockwise in the XZ view: normal points outward
    n = sp.at(np.linspace(0, sp.length, 400, endpoint=False))
    c = sp.bounds.mean(axis=0)
    assert np.mean(np.einsum("ij,ij->i", n.point - c, n.normal) > 0) > 0.9
    # Algebra mode: a filleted rectangle sketch (drawn on Plane.XY: y read as z).
    sk = fillet(Rectangle(30, 20).vertices(), 3)
    rp = Profile.from_cad(sk)
    assert rp.closed and abs(rp.length - (2 * 24 + 2 * 14 + 2 * np.pi * 3)) < UM
    assert np.allclose(rp.bounds, [[-15, -10], [15, 10]], atol=UM)
    assert not rp.corners  # fillets make it G1
    with BuildSketch(Plane.XZ) as bs:  # builder mode, drawn on Plane.XZ
        Rectangle(30, 20)
        fillet(bs.vertices(), 3)
    bp = Profile.from_cad(bs.sketch)
    assert abs(bp.length - rp.length) < UM and np.allclose(bp.bounds, rp.bounds, atol=UM)
    facings = [f.facing for f in rp.function_pieces()]
    assert sorted(facings) == [-1, 0, 0, 1]
    # A wire of lines and an arc, with corners.
    w = Wire([Line((0, 0), (10, 0)), CenterArc((10, 5), 5, -90, 180), Line((10, 10), (0, 10))])
    wp = Profile.from_cad(w)
    assert abs(wp.length - (20 + 5 * np.pi)) < UM and not wp.corners
    box = Profile.polyline([(0, 0), (10, 0), (10, 5)])
    (corner,) = box.corners
    assert corner.s == pytest.approx(10.0) and corner.angle == pytest.approx(90.0)  # concave
    # Edges in any order (a BuildLine whose pieces were drawn out of sequence).
    with BuildLine(Plane.XZ) as bl2:
        Line((10, 0), (20, 5))
        Line((0, 0), (10, 0))
    assert Profile.from_cad(bl2.line).length == pytest.approx(10 + np.hypot(10, 5), abs=UM)
    assert Profile.from_cad(bl2.line.edges()).length == pytest.approx(10 + np.hypot(10, 5), abs=UM)


def test_cadquery_input():
    import cadquery as cq

    wp = cq.Workplane("XZ").spline([(0, 0), (20, 5), (40, -3), (60, 0)])
    p = Profile.from_cad(wp)
    e = wp.val()
    assert abs(p.length - e.Length()) < UM


def test_function_pieces_of_a_non_function_curve():
    """The paper splits Fig. 8's curve by hand; here dx/ds changes sign at the
    division points, found automatically, and up/down-looking is labelled."""
    from build123d import Spline

    hook = Profile.from_cad(Spline((0, 0), (40, 5), (55, 25), (40, 40), (25, 32)))
    pieces = hook.function_pieces()
    assert [p.facing for p in pieces] == [1, -1]
    (d,) = hook.division_points()
    f = hook.at(np.array([d]))
    assert abs(f.tangent[0, 0]) < 1e-6  # vertical tangent at the division point
    s = np.linspace(0, hook.length, 2000)
    fs = hook.at(s)
    up = s < d
    assert np.all(np.diff(fs.point[up, 0]) > 0) and np.all(np.diff(fs.point[~up, 0]) < 0)  # x monotonic per piece
    assert np.all(fs.normal[up & (s < d - 1), 1] > 0) and np.all(fs.normal[~up & (s > d + 1), 1] < 0)
    # A circle has two: its top (upward-looking) and bottom halves.
    c = Profile.circle(10.0)
    assert sorted(p.facing for p in c.function_pieces()) == [-1, 1]
    # It starts at (R, 0), where the tangent is vertical: divisions at s = 0, pi R.
    assert np.allclose(np.sort(c.division_points()), [0.0, np.pi * 10], atol=1e-6)


def test_reversed_flips_the_normal():
    p = Profile.sine(3.0, 20.0, 40.0)
    q = p.reversed()
    s = np.linspace(0, p.length, 50)
    assert np.allclose(q.point(p.length - s), p.point(s), atol=1e-9)
    assert np.allclose(q.normal(p.length - s), -p.normal(s), atol=1e-9)
    assert np.allclose(q.curvature(p.length - s), -p.curvature(s), atol=1e-6)


def test_bad_profiles_are_refused_with_reasons():
    from build123d import Line, Spline

    with pytest.raises(InputError, match="separate pieces"):
        Profile.from_cad(Line((0, 0), (1, 0)) + Line((5, 0), (6, 0)))
    with pytest.raises(InputError, match="not planar"):
        Profile.from_cad(Spline((0, 0, 0), (10, 5, 5), (20, 0, 10)))
    with pytest.raises(InputError, match="cannot read a profile"):
        Profile.from_cad(42)
    with pytest.raises(ParameterError, match="x0 < x1"):
        Profile.function(np.sin, 3.0, 1.0)
    with pytest.raises(ParameterError, match="radius"):
        Profile.circle(-1.0)
    with pytest.raises(ParameterError, match="unknown surface"):
        Surface.named("torus")


@pytest.mark.parametrize("kind", ["plate", "cylinder", "arc", "sine"])
def test_named_surfaces_have_the_profile_on_their_base(kind):
    from texcad.brep import shape_to_mesh

    surf = Surface.named(kind, length=10.0, width=40.0, period=20.0)
    mesh = shape_to_mesh(surf.base)
    assert mesh.is_watertight
    # The profile is the base body's boundary: a point 0.05 mm out along the
    # normal is outside the body, 0.05 mm in is inside (winding numbers).
    s = np.linspace(0, surf.profile.length, 60)[1:-1]
    f = surf.profile.at(s)
    for sign, expect in ((1, 0.0), (-1, 1.0)):
        q = f.point + sign * 0.05 * f.normal
        xyz = np.stack([q[:, 0], np.full(len(q), 5.0), q[:, 1]], 1)
        assert np.allclose(_winding_numbers(mesh, xyz), expect, atol=1e-3)


def _winding_numbers(mesh, pts: np.ndarray) -> np.ndarray:
    """Generalized winding number of a closed mesh at points (solid angles summed,
    Van Oosterom and Strackee): 1 inside, 0 outside."""
    tri = np.asarray(mesh.vertices, np.float64)[np.asarray(mesh.faces)]
    out = []
    for p in pts:  # a few dozen points
        a, b, c = (tri[:, k] - p for k in range(3))
        la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = la * lb * lc + np.einsum("ij,ij->i", a, b) * lc + np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb
        out.append(np.sum(2 * np.arctan2(num, den)) / (4 * np.pi))
    return np.array(out)


def test_base_body_of_a_profile():
    p = Profile.circle(10.0)
    solid = p.base_body(5.0)
    assert solid.volume == pytest.approx(np.pi * 100 * 5, rel=1e-4)
    tube = p.base_body(5.0, 2.0)
    assert tube.volume == pytest.approx(np.pi * (100 - 64) * 5, rel=1e-3)
    band = Profile.plane(20.0).base_body(4.0, 3.0)
    assert band.volume == pytest.approx(20 * 4 * 3, rel=1e-6)
    assert band.bounds[1][2] == pytest.approx(0.0, abs=1e-6)  # under the profile
