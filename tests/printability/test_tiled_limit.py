"""The overhang limiter block by block (limit_overhangs_tiled): each block limited from
the block grown by its halo gives the untiled limiter's heights bit for bit, for
build directions upright, tilted, oblique (the split chosen over the blocks), a set
of directions and facing down (M-I ramps on each border); the report is the same;
the halo is what makes it so (one row short and the heights differ), its width is
the documented bound; a direction whose reach is the whole grid is refused."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import texcad
import texcad.printability.overhang as overhang
from texcad.printability import limit_overhangs, orientation
from texcad.printability.overhang import limit_overhangs_tiled, limiter_halo
from texcad.solid.mesh import heightfield_volume
from texcad.sources import load_texture

DIRECTIONS = {
    "upright +y": orientation(90, "+y"),
    "tilted 60 +x": orientation(60, "+x"),
    "oblique 70 at 30 deg": orientation(70, 30.0),
    "flat": (0.0, 0.0, 1.0),
    "a set 0-60": [orientation(a) for a in (0, 30, 60)],
    "facing down 120 -y": orientation(120, "-y"),
    "upright -x": orientation(90, "-x"),
}


@pytest.fixture(scope="module")
def hm():
    return load_texture("builtin:stones", size=(30, 22), pitch=0.25, height=1.2)


def _tiled(hm, d, block, **kw):
    out = np.full(hm.shape, np.nan, np.float32)
    seen = np.zeros(hm.shape, np.int64)

    def store(rows, cols, h):
        out[rows, cols] = h
        seen[rows, cols] += 1

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = limit_overhangs_tiled(lambda r, c: hm.heights[r, c], hm.shape, hm.pitch, d, block=block, store=store, **kw)
    return out, res, seen


@pytest.mark.parametrize("name", sorted(DIRECTIONS))
def test_tiled_limiter_equals_untiled_bit_for_bit(hm, name):
    d = DIRECTIONS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref, rep = limit_overhangs(hm, d)
    out, res, seen = _tiled(hm, d, block=40)
    assert res.plan.halo[0] < hm.shape[0] and res.plan.halo[1] < hm.shape[1]  # a block reads less than the grid
    assert (seen >= 1).all() and seen.max() == res.report.iterations  # every pixel stored once per pass
    assert out.dtype == ref.heights.dtype and np.array_equal(out, ref.heights), np.nanmax(np.abs(out - ref.heights))
    t = res.report
    assert t.ramped_borders == rep.ramped_borders and t.iterations == rep.iterations
    assert t.max_removed_mm == rep.max_removed_mm and t.touched_fraction == rep.touched_fraction
    assert np.isclose(t.removed_volume_mm3, rep.removed_volume_mm3, rtol=1e-12, atol=1e-12)
    assert np.isclose(t.remaining_overhang_mm2, rep.remaining_overhang_mm2, rtol=1e-9, atol=1e-12)
    assert t.surface_overhang == rep.surface_overhang and t.margin_deg == rep.margin_deg
    vol, slack = heightfield_volume(ref.heights, hm.pitch)  # the limited integral, summed block by block
    assert np.isclose(res.volume, vol, rtol=1e-12) and np.isclose(res.slack, slack, rtol=1e-12)
    assert res.top == float(ref.heights.max())


def test_some_directions_remove_texture_and_ramp_borders(hm):
    """The cases above are not trivial: the limiter lowers texture and ramps the border
    that faces down, and facing down ramps the opposite one."""
    up = _tiled(hm, DIRECTIONS["upright +y"], block=40)[1].report
    down = _tiled(hm, DIRECTIONS["facing down 120 -y"], block=40)[1].report
    assert up.removed_volume_mm3 > 1.0 and up.ramped_borders == ("y0",)
    assert down.removed_volume_mm3 > up.removed_volume_mm3 and down.ramped_borders == ("y1",)


@pytest.mark.parametrize("block", [33, 64, 500])
def test_the_same_heights_for_any_block(hm, block):
    d = DIRECTIONS["oblique 70 at 30 deg"]
    a = _tiled(hm, d, block=block)[0]
    b = _tiled(hm, d, block=47)[0]
    assert np.array_equal(a, b)


def test_the_halo_is_what_makes_it_exact(hm, monkeypatch):
    """A halo of one or two rows (instead of the bound, 9 here) changes the heights
    near the blocks' borders: the test above can fail."""
    d = DIRECTIONS["upright +y"]
    ref = limit_overhangs(hm, d)[0].heights
    for rows in (1, 2):
        monkeypatch.setattr(overhang, "limiter_halo", lambda bounds, h_range: (rows, 0))
        out = _tiled(hm, d, block=33)[0]
        assert not np.array_equal(out, ref) and np.abs(out - ref).max() > 1e-2


def test_the_halo_is_the_height_range_over_the_smallest_bound(hm):
    """Upright along +y at 45 degrees: facets rising towards +y may rise at
    tan(beta_max), beta_max = 90 - (45 + margin), per mm; a limited height can depend
    on pixels up to h_range / (py tan(beta_max)) rows away (plus the two of margin),
    and on no other column."""
    from texcad.printability.rule import slicer_margin

    res = _tiled(hm, DIRECTIONS["upright +y"], block=40)[1]
    beta = np.radians(90.0 - 45.0 - slicer_margin(45.0, 0.2))
    h_range = float(hm.heights.max())
    assert res.plan.halo == (int(np.floor(h_range / (hm.pitch[1] * np.tan(beta)))) + 2, 0)
    bounds = np.full((6, 5), 0.5)
    assert limiter_halo(bounds, 1.2) == (4, 4)
    bounds[2] = 0.0
    assert limiter_halo(bounds, 1.2) is None  # a zero bound: the reach is the whole grid


def test_a_direction_with_a_zero_bound_is_refused(hm):
    with pytest.raises(texcad.ParameterError, match="the limiter's reach is the whole plate"):
        _tiled(hm, orientation(133, "-y"), block=40)


def test_a_block_needs_only_its_window(hm):
    """The reads: every read is a block grown by at most the halo (memory goes with one
    block and its halo), apart from the first pass over the blocks for the range."""
    d = DIRECTIONS["upright +y"]
    sizes = []

    def read(r, c):
        sizes.append((r.stop - r.start, c.stop - c.start))
        return hm.heights[r, c]

    res = limit_overhangs_tiled(read, hm.shape, hm.pitch, d, block=40, store=lambda *a: None)
    hr, hc = res.plan.halo
    inner = max(32, 40 - 2 * max(hr, hc))  # the blocks: the window less twice the halo, at least 32
    assert max(s[0] for s in sizes) <= max(40, inner + 1 + 2 * hr) and max(s[1] for s in sizes) <= max(40, inner + 1 + 2 * hc)
    assert max(s[0] * s[1] for s in sizes) < hm.shape[0] * hm.shape[1] / 2
    assert hr > 0 and hc == 0


@pytest.mark.parametrize("seed", range(12))
def test_random_heightfields_and_directions(seed):
    """Random fields (some below 0, rough or smooth, either pitch), random directions
    (one or two, any tilt short of the zero-bound band, any azimuth), random blocks:
    the tiled limiter gives the untiled heights bit for bit."""
    from texcad.sources import Heightmap

    rng = np.random.default_rng(seed)
    r, c = rng.integers(20, 70, size=2)
    h = rng.random((r, c)) * rng.uniform(0.2, 2.0)
    if seed % 3 == 0:  # smooth
        from scipy.ndimage import gaussian_filter

        h = gaussian_filter(h, 2.0) * 4
    if seed % 4 == 1:
        h -= 0.3 * h.max()  # partly below the surface
    hm = Heightmap(h.astype(np.float32), (float(rng.uniform(0.1, 0.5)), float(rng.uniform(0.1, 0.5))))
    tilts = [a for a in rng.uniform(0, 180, size=4) if not 125 < a < 140][: 1 + seed % 2]
    dirs = [orientation(float(a), float(rng.uniform(0, 360))) for a in tilts] or [orientation(90, "+y")]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref, rep = limit_overhangs(hm, dirs)
    out, res, _ = _tiled(hm, dirs, block=int(rng.integers(32, 80)))
    assert np.array_equal(out, ref.heights), (tilts, np.nanmax(np.abs(out - ref.heights)))
    assert res.report.iterations == rep.iterations and res.report.ramped_borders == rep.ramped_borders
