"""Seam gap between pieces textured separately (paper section 3.4)."""

import numpy as np
import pytest

import texcad
from texcad import ParameterError
from texcad.report import seam_gap

R = 10.0


def halves(mapping: str, pitch: float = 0.5):
    """A cylinder's texture in two halves: columns 0..n/2 and n/2..n (= 0)."""
    n = 2 * round(np.pi * R / pitch)
    p = 2 * np.pi * R / n
    rng = np.random.default_rng(1)
    h = (0.2 + 0.8 * rng.random((12, n))).astype(np.float32)
    a = texcad.Heightmap(h[:, : n // 2 + 1], (p, 0.5))
    b = texcad.Heightmap(np.concatenate([h[:, n // 2 :], h[:, :1]], axis=1), (p, 0.5))
    upper = texcad.Profile.arc(R, 180)
    lower = texcad.Profile.parametric(lambda t: (R * np.cos(t), R * np.sin(t)), 0.0, -np.pi)
    ma = texcad.mapping.map_texture(upper, a, mapping=mapping, length=6.0)
    mb = texcad.mapping.map_texture(lower, b, mapping=mapping, length=6.0)
    return ma, mb, h


def test_angle_preserving_halves_meet():
    a, b, _ = halves("angle")
    for gap in (seam_gap(a, b), seam_gap(b, a)):
        assert gap.max_um < 1e-3 and gap.rows == 12
    # Where the joints are: (R, 0) and (-R, 0), lifted by the joint column's height.
    assert abs(abs(seam_gap(a, b).where[0]) - R) <= 1.0 + 1e-6


def test_gap_measures_displacement_in_um():
    a, b, _ = halves("angle")
    moved = b.top.copy()
    moved[3, 0, 2] += 0.062  # the paper's 62 um, in one row
    gap = seam_gap(a, moved)
    assert gap.max_um == pytest.approx(62.0, abs=0.01)
    assert gap.rms_um == pytest.approx(62.0 / np.sqrt(12), abs=0.01)


def test_distance_preserving_halves_fade_at_the_joints():
    a, b, h = halves("distance")
    # texcad's algorithm 1 fades the texture to 0 where the surface is vertical, so the
    # copies meet only because the texture is gone there.
    assert seam_gap(a, b).max_um < 1e-3
    assert a.factor[-1] == 0.0 and b.factor[0] == 0.0 and h[:, -1].min() > 0.1


def test_rows_must_match():
    a, b, _ = halves("angle")
    with pytest.raises(ParameterError, match="rows"):
        seam_gap(a, b.top[:5])
    with pytest.raises(ParameterError, match="grid"):
        seam_gap(np.zeros((3, 3)), b)
