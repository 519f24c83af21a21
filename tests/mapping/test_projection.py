"""Projections give texture coordinates in mm, seam-free where they wrap; solid
textures are periodic in 3-D."""

from __future__ import annotations

import numpy as np
import pytest

from texcad.errors import ParameterError
from texcad.mapping.projection import Projection, TileSampler, frame, parse_axis, sample_heights
from texcad.sources import builtin
from texcad.sources.solid_textures import solid_texture


def test_frames_are_right_handed():
    rng = np.random.default_rng(1)
    for a in list(rng.normal(size=(20, 3))) + ["+x", "-y", "z"]:
        ax = parse_axis(a)
        eu, ev = frame(ax)
        assert np.allclose(np.cross(eu, ev), ax) and abs(eu @ ax) < 1e-12
    assert np.allclose(frame(parse_axis("+z"))[0], [1, 0, 0])
    with pytest.raises(ParameterError):
        parse_axis("w")


def test_planar_is_the_plane_coordinates_in_mm():
    p = np.array([[1.0, 2.0, 3.0], [-4.0, 5.0, 0.5]])
    (u, v, w), = Projection("planar", axis="+z", origin=(0, 0, 0)).samples(p, np.tile([0, 0, 1.0], (2, 1)), (1, 1))[0]
    assert np.allclose(u, p[:, 0]) and np.allclose(v, p[:, 1]) and np.allclose(w, 1)
    (u, v, _), = Projection("planar", axis="-z", origin=(0, 0, 0)).samples(p, -np.tile([0, 0, 1.0], (2, 1)), (1, 1))[0]
    assert np.allclose(u, -p[:, 0]) and np.allclose(v, p[:, 1])  # seen from below, not mirrored


def test_tile_sampler_is_periodic_and_exact_at_pixels():
    hm = builtin("pins", pitch=0.25, height=2.0)
    s = TileSampler(hm)
    tx, ty = s.tile
    rng = np.random.default_rng(2)
    u, v = rng.uniform(-50, 50, 500), rng.uniform(-50, 50, 500)
    assert np.allclose(s(u, v), s(u + 3 * tx, v - 2 * ty), atol=1e-5)
    px, py = hm.pitch
    assert np.allclose(s((np.arange(4) + 0.5) * px, np.full(4, 0.5 * py)), hm.heights[0, :4], atol=1e-6)


def test_cylindrical_and_spherical_wrap_without_a_seam():
    hm = builtin("diamond_knurl", pitch=0.1, height=1.0)
    s = TileSampler(hm)
    for kind in ("cylindrical", "spherical"):
        eps = 1e-7
        th = np.array([np.pi - eps, -np.pi + eps])
        p = np.stack([7.3 * np.cos(th), 7.3 * np.sin(th), [1.7, 1.7]], 1)
        samples, info = Projection(kind, axis="+z", origin=(0, 0, 0)).samples(p, p / 7.3, s.tile)
        h = sample_heights(samples, s)
        assert abs(h[0] - h[1]) < 1e-4, kind
        assert abs(info["stretch"] - 1) <= 0.5 * s.tile[0] / (2 * np.pi * 7.3) + 1e-12


def test_triplanar_and_cubic_weights():
    n = np.array([[1.0, 0, 0], [0, 0, -1], [1, 1, 0], [1, 1, 1]])
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    p = np.zeros((4, 3))
    for kind in ("triplanar", "cubic"):
        samples, _ = Projection(kind, blend=20).samples(p, n, (1, 1))
        w = np.stack([s[2] for s in samples], 1)
        assert np.allclose(w.sum(1), 1)
        assert np.allclose(w[0], [1, 0, 0]) and np.allclose(w[1], [0, 0, 1])
        assert np.allclose(w[2], [0.5, 0.5, 0])  # on the diagonal: halfway
        assert np.allclose(w[3], 1 / 3)  # a cube corner: all three, equally
    q = np.array([[2.0, 3.0, 0.0], [2.0, 3.0, 0.0]])
    nn = np.array([[1.0, 0, 0], [-1.0, 0, 0]])
    sx = Projection("cubic", origin=(0, 0, 0)).samples(q, nn, (1, 1))[0][0]
    assert sx[0][0] == -sx[0][1]  # -x face seen from outside: u flips


def test_solid_textures_are_periodic_and_seam_free():
    rng = np.random.default_rng(3)
    p = rng.uniform(-30, 30, (2000, 3))
    for name, tile in (("stones", 24.0), ("sand", 12.0), ("leather", 1.2 * 14)):
        f = solid_texture(name)
        a, b = f(p), f(p + tile * np.array([1.0, -2.0, 1.0]))
        assert np.allclose(a, b, atol=1e-9), name
        assert a.min() >= 0 and a.max() <= 1 and a.std() > 0.05
    f = solid_texture("diamond_knurl", origin=(0, 0, 0))
    th = np.array([np.pi - 1e-9, -np.pi + 1e-9])
    q = np.stack([10 * np.cos(th), 10 * np.sin(th), [3.3, 3.3]], 1)
    assert abs(f(q)[0] - f(q)[1]) < 1e-6
    with pytest.raises(ParameterError, match="no solid"):
        solid_texture("brick")
