"""The strips of a face textured on its own (u, v) (texcad.brep.uvstrips)."""

import numpy as np
import pytest

from texcad.brep.uvstrips import _params, _remapped

T0, T1 = 5.67229064597633, 5.672459342790377  # a rim's short pcurve, far from 0 (as read on a loft's side)


@pytest.mark.parametrize("cut", [4e-12, 1.0 - 4e-12])
def test_a_grid_line_a_hair_from_an_end_makes_no_span_occt_refuses(cut):
    """Five B-spline faces of a loft textured together: a rim's pcurve crossed a grid
    line one float64 step of its parameter from its end, and OCCT refused the broken
    line ("BSpline curve: Knots interval values too close"), an OCCT exception where a
    B-rep or a GeometryError was due."""
    u, v = np.array([0.0, cut, 0.5, 1.0]), np.array([0.0, 1.0])
    p0, p1 = np.array([0.0, 0.5]), np.array([1.0, 0.5])
    t = np.concatenate([[T0], _params(T0, T1, p0, p1, 0, u), [T1]])
    assert np.diff(t).min() < 1e-15  # the span OCCT refused
    c = _remapped(T0, T1, p0, p1, u, v, u * 3.0, v * 2.0)
    assert c.FirstParameter() == T0 and c.LastParameter() == T1
    for s in (0.0, 0.25, 0.5, 0.75, 1.0):  # the same straight line, on the strips' knots
        p = c.Value(T0 + s * (T1 - T0))
        assert p.X() == pytest.approx(3.0 * s, abs=1e-6) and p.Y() == pytest.approx(1.0, abs=1e-12)
