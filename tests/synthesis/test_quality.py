"""Tests of texcad.synthesis.quality: each measure on inputs whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from texcad.synthesis import quality as Q
from texcad.errors import InputError, ParameterError
from texcad.sources import Heightmap


def field(rows: int = 128, cols: int = 128, sigma: float = 2.0, seed: int = 0, wrap: bool = True) -> np.ndarray:
    rng = np.random.default_rng(seed)
    mode = "wrap" if wrap else "reflect"
    return ndimage.gaussian_filter(rng.standard_normal((rows, cols)), sigma, mode=mode)


# -- histogram ------------------------------------------------------------------------
def test_histogram_distance_known_values() -> None:
    a = field()
    span = float(np.ptp(a))
    assert Q.histogram_distance(a, a) == pytest.approx(0.0, abs=1e-12)
    # Shifting all heights by c moves the distribution by c: D = c / range.
    assert Q.histogram_distance(a + 0.1 * span, a) == pytest.approx(0.1, rel=1e-6)
    # Invariant to the arrangement of the heights and to the sample's units.
    perm = np.random.default_rng(1).permutation(a.ravel()).reshape(a.shape)
    assert Q.histogram_distance(perm, a) == pytest.approx(0.0, abs=1e-12)
    assert Q.histogram_distance(3 * a, 3 * a.T) == pytest.approx(0.0, abs=1e-12)
    # Averaging towards the mean (what feathering of unrelated patches does) is seen.
    assert Q.histogram_distance(0.5 * a + 0.5 * field(seed=9), a) > 0.03


def test_accepts_heightmaps_and_rejects_bad_input() -> None:
    a = field()
    hm = Heightmap.from_array(a, pitch=0.1)
    assert Q.histogram_distance(hm, hm) == pytest.approx(0.0, abs=1e-7)
    with pytest.raises(InputError):
        Q.histogram_distance(np.zeros(5), a)
    with pytest.raises(InputError):
        Q.histogram_distance(np.full((4, 4), np.nan), a)


# -- spectrum -------------------------------------------------------------------------
def test_radial_spectrum_finds_a_sine() -> None:
    y, x = np.mgrid[:128, :128]
    h = np.sin(2 * np.pi * x / 8.0)  # 0.125 cycles/px
    bins = np.linspace(0.01, 0.5, 50)
    p = Q.radial_power_spectrum(h, bins)
    centre = 0.5 * (bins[1:] + bins[:-1])
    assert abs(centre[np.nanargmax(p)] - 0.125) < 0.011
    # White noise: flat within a factor 2 over the middle frequencies.
    w = np.random.default_rng(0).standard_normal((128, 128))
    pw = Q.radial_power_spectrum(w, np.linspace(0.1, 0.45, 8), segment=64)
    assert pw.max() / pw.min() < 2.0
    assert np.mean(pw) == pytest.approx(1.0, rel=0.2)  # unit variance, unit density


def test_spectrum_distance_orders_blur_and_scale() -> None:
    a = field(256, 256, seed=0)
    same = field(256, 256, seed=1)  # another realisation of the same process
    blurred = ndimage.gaussian_filter(same, 2.0)
    coarser = field(256, 256, sigma=6.0, seed=1)
    d_same = Q.spectrum_distance(same, a)
    assert d_same < 0.15
    assert Q.spectrum_distance(blurred, a) > 3 * d_same
    assert Q.spectrum_distance(coarser, a) > 3 * d_same
    # Size of the output does not bias the comparison (Welch segments).
    assert Q.spectrum_distance(field(400, 300, seed=2), a[:128, :128]) < 0.2


def test_spectrum_distance_errors() -> None:
    with pytest.raises(InputError):
        Q.spectrum_distance(field(), np.zeros((8, 8)))
    with pytest.raises(ParameterError):
        Q.spectrum_distance(field(), field(), n_bins=0)


# -- blur -----------------------------------------------------------------------------
def test_blur_ratio() -> None:
    a = field(128, 128, sigma=1.5)
    bands = np.zeros(a.shape, bool)
    bands[:, 40:60] = True
    assert Q.blur_ratio(a, bands) == pytest.approx(1.0, abs=0.25)
    # Averaging two unrelated textures in the band halves the gradient energy.
    mixed = a.copy()
    mixed[:, 40:60] = 0.5 * (a[:, 40:60] + field(128, 128, sigma=1.5, seed=5)[:, 40:60])
    assert Q.blur_ratio(mixed, bands) == pytest.approx(0.5, abs=0.15)
    with pytest.raises(ParameterError):
        Q.blur_ratio(a, bands[:10])
    assert np.isnan(Q.blur_ratio(a, np.zeros(a.shape, bool)))


# -- wrap seam ------------------------------------------------------------------------
def test_wrap_seam_error() -> None:
    tiling = field(96, 128, sigma=3.0, wrap=True)
    assert Q.wrap_seam_error(tiling, "x") == pytest.approx(1.0, abs=0.3)
    assert Q.wrap_seam_error(tiling, "y") == pytest.approx(1.0, abs=0.3)
    # Two unrelated edges: the jump is of the order of the height spread, many
    # times a neighbour difference of a smooth texture.
    not_tiling = field(96, 128, sigma=3.0, wrap=False)
    assert Q.wrap_seam_error(not_tiling, "x") > 3
    assert Q.wrap_seam_error(not_tiling, "y") > 3
    # np.concatenate([h, h]) shows the seam where the measure looks.
    h = not_tiling
    t = np.concatenate([h, h], axis=1)
    d = np.sqrt(np.mean(np.diff(t, axis=1) ** 2, axis=0))
    assert d[h.shape[1] - 1] / np.sqrt(np.mean(np.diff(h, axis=1) ** 2)) == pytest.approx(
        Q.wrap_seam_error(h, "x")
    )
    with pytest.raises(ParameterError):
        Q.wrap_seam_error(h, "z")
    assert np.isnan(Q.wrap_seam_error(np.ones((5, 5))))


def test_report() -> None:
    a = field()
    r = Q.report(a, a, np.zeros(a.shape, bool) | (np.arange(128) % 20 < 5)[None, :])
    assert set(r) == {"histogram", "spectrum", "blur", "seam_x", "seam_y"}
    assert r["histogram"] == pytest.approx(0.0, abs=1e-12) and r["spectrum"] < 1e-9
    assert "blur" not in Q.report(a, a)


def test_natural_sample_is_seeded_normalized_and_tiles_when_periodic():
    a = Q.natural_sample(64, 80, seed=2)
    assert a.shape == (64, 80) and a.dtype == np.float32 and a.min() == 0.0 and a.max() == 1.0
    assert np.array_equal(a, Q.natural_sample(64, 80, seed=2)) and not np.array_equal(a, Q.natural_sample(64, 80, seed=3))
    # Periodic: the jump across the wrap is like any neighbour step; reflected: not.
    assert Q.wrap_seam_error(a, axis="x") < 1.5
    assert Q.wrap_seam_error(Q.natural_sample(64, 80, seed=2, periodic=False), axis="x") > 1.5


# -- coherence ------------------------------------------------------------------------
def _coherence_brute_force(out: np.ndarray, sample: np.ndarray, w: int, n: int, seed: int) -> float:
    rng = np.random.default_rng(seed)
    ys = rng.integers(0, out.shape[0] - w + 1, n)
    xs = rng.integers(0, out.shape[1] - w + 1, n)
    S = np.lib.stride_tricks.sliding_window_view(sample.astype(float), (w, w))
    d = [np.sqrt(((S - out[y: y + w, x: x + w]) ** 2).mean(axis=(2, 3)).min()) for y, x in zip(ys, xs)]
    return float(np.mean(d) / sample.std())


def test_coherence_matches_brute_force() -> None:
    s = field(40, 50, sigma=1.5, seed=3)
    o = field(30, 35, sigma=1.5, seed=4)
    for w, n, seed in ((8, 25, 0), (5, 7, 2)):
        assert Q.coherence(o, s, window=w, n_windows=n, seed=seed) == pytest.approx(
            _coherence_brute_force(o, s, w, n, seed), rel=1e-9
        )


def test_coherence_known_values() -> None:
    s = field(96, 96, sigma=2.0, seed=1)
    # Every window of the sample (or of a crop of it) is a sample window: 0.
    assert Q.coherence(s, s) == pytest.approx(0.0, abs=1e-6)
    assert Q.coherence(s[10:70, 20:90], s) == pytest.approx(0.0, abs=1e-6)
    # Units: invariant to a height offset and to the scale of both maps.
    o = field(80, 80, sigma=2.0, seed=2)
    c = Q.coherence(o, s)
    assert Q.coherence(3.0 * o + 1.0, 3.0 * s + 1.0) == pytest.approx(c, rel=1e-9)
    # Another realisation of the same process is far from verbatim, blur farther
    # still, and the same seed gives the same windows.
    assert 0.2 < c < 1.5
    assert Q.coherence(ndimage.gaussian_filter(s, 2.0), s) > 0.2
    assert Q.coherence(o, s, seed=5) == Q.coherence(o, s, seed=5)
    # A mosaic of sample pieces scores between the sample itself and unrelated content.
    mosaic = np.concatenate([s[:, :48], s[:, 48:][::-1]], axis=1)
    assert 0.0 < Q.coherence(mosaic, s) < c
    with pytest.raises(ParameterError):
        Q.coherence(o, s, window=1)
    with pytest.raises(ParameterError):
        Q.coherence(o[:10, :10], s, window=16)
    with pytest.raises(ParameterError):
        Q.coherence(o, s, n_windows=0)
    assert np.isnan(Q.coherence(o, np.ones((20, 20))))
