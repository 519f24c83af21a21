"""Tests of texcad.synthesis: patch-based sampling (Liang 2001), eq. 1 cuts, wrap.

Samples are small (<= 150 px) and outputs a few hundred px so the file runs in seconds.
Quality is asserted with the measures of texcad.synthesis.quality against random patch pasting
(naive_quilt) on the same grid.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from texcad.synthesis import quality as Q
from texcad.errors import InputError, ParameterError, TexcadError
from texcad.sources import Heightmap
from texcad.synthesis import (
    BLENDS,
    WRAPS,
    naive_quilt,
    patch_grid,
    seam_bands,
    synthesize,
)
from texcad.synthesis.quilt import _min_error_paths

P, O = 32, 14  # patch and overlap used with the 128 px samples (step 18)


def natural_sample(rows: int = 128, cols: int = 128, seed: int = 1) -> np.ndarray:
    """A photograph-like stochastic height field in mm (:func:`texcad.synthesis.quality.natural_sample`)."""
    return Q.natural_sample(rows, cols, seed)


def periodic_sample(rows: int = 128, cols: int = 128) -> np.ndarray:
    """A structured texture: ribs of period 8 px along x, grooves every 16 px along y."""
    y, x = np.mgrid[:rows, :cols].astype(float)
    a = np.sin(2 * np.pi * x / 16) ** 2 * np.cos(np.pi * y / 16) ** 2 + 0.5 * ((y % 16) < 3)
    return (a / a.max()).astype(np.float32)


@pytest.fixture(scope="module")
def natural() -> Heightmap:
    return Heightmap(natural_sample(), (0.125, 0.125))


# -- contract ------------------------------------------------------------------------
@pytest.mark.parametrize("blend", BLENDS)
@pytest.mark.parametrize("wrap", WRAPS)
def test_shape_pitch_range(natural: Heightmap, blend: str, wrap: str | None) -> None:
    hm = Heightmap(natural.heights, (0.2, 0.25))
    out = synthesize(hm, (131, 97), patch=P, overlap=O, blend=blend, wrap=wrap)
    assert isinstance(out, Heightmap)
    assert out.shape == (131, 97)
    assert out.pitch == (0.2, 0.25)
    assert out.heights.dtype == np.float32
    # Convex combinations of sample heights stay in the sample's range.
    lo, hi = float(hm.heights.min()), float(hm.heights.max())
    assert out.heights.min() >= lo - 1e-6 and out.heights.max() <= hi + 1e-6


def test_array_sample_gets_unit_pitch() -> None:
    out = synthesize(natural_sample(), (60, 70), patch=P, overlap=O)
    assert out.pitch == (1.0, 1.0) and out.shape == (60, 70)
    out = synthesize(natural_sample().tolist(), (40, 40), patch=P, overlap=O)
    assert out.shape == (40, 40)


@pytest.mark.parametrize("blend", BLENDS)
def test_same_seed_same_bytes(natural: Heightmap, blend: str) -> None:
    kw = dict(patch=P, overlap=O, blend=blend, wrap="xy")
    a = synthesize(natural, (120, 150), seed=7, **kw)
    b = synthesize(natural, (120, 150), seed=7, **kw)
    c = synthesize(natural, (120, 150), seed=8, **kw)
    assert a.heights.tobytes() == b.heights.tobytes()
    assert a.heights.tobytes() != c.heights.tobytes()
    # A Generator is accepted as the seed and gives the same stream as its seed.
    d = synthesize(natural, (120, 150), seed=np.random.default_rng(7), **kw)
    assert d.heights.tobytes() == a.heights.tobytes()


@pytest.mark.parametrize("blend", BLENDS)
@pytest.mark.parametrize("wrap", WRAPS)
def test_wavefront_equals_scan_line_order(
    natural: Heightmap, blend: str, wrap: str | None, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Patches are matched and pasted a diagonal front at a time (_levels); every
    # patch must still see exactly what scan-line order (Liang 2001) shows it, so
    # the output is byte-identical to pasting one patch at a time in scan-line order.
    import texcad.synthesis.quilt as syn

    shape = (150, 203)  # 8 x 11 patches, the last ones cropped (or closing the torus)
    w = wrap or ""
    levels = syn._levels(syn._axis(shape[0], P, O, "y" in w), syn._axis(shape[1], P, O, "x" in w), P)
    if wrap in (None, "y"):
        assert levels.max() + 1 < levels.size // 2  # the front holds several patches
    front = synthesize(natural, shape, patch=P, overlap=O, blend=blend, wrap=wrap, seed=4)
    monkeypatch.setattr(
        syn, "_levels", lambda ay, ax, p: np.arange(len(ay.starts) * len(ax.starts)).reshape(len(ay.starts), -1)
    )
    scan = synthesize(natural, shape, patch=P, overlap=O, blend=blend, wrap=wrap, seed=4)
    assert front.heights.tobytes() == scan.heights.tobytes()


def test_paper_parameters_non_square_sample() -> None:
    # Paper, Table 1: a 150 x 100 px sample with patch 25 and overlap 10; an output
    # size that is not a multiple of the step (15 px) is covered and cropped.
    sample = natural_sample(100, 150, seed=3)
    out = synthesize(sample, (203, 241), patch=25, overlap=10)
    assert out.shape == (203, 241)
    assert Q.histogram_distance(out, sample) < 0.05


def test_output_smaller_than_sample_and_patch(natural: Heightmap) -> None:
    out = synthesize(natural, (50, 40), patch=P, overlap=O)
    assert out.shape == (50, 40)
    tiny = synthesize(natural, (5, 3), patch=P, overlap=O, seed=2)
    assert tiny.shape == (5, 3)
    # A single patch is a crop of the sample.
    s = natural.heights
    hit = [
        np.array_equal(tiny.heights, s[y: y + 5, x: x + 3])
        for y in range(s.shape[0] - P + 1)
        for x in range(s.shape[1] - P + 1)
    ]
    assert any(hit)


def test_patch_equal_to_sample() -> None:
    s = natural_sample(40, 50)
    out = synthesize(s, (90, 90), patch=40, overlap=15)  # a single candidate column
    assert out.shape == (90, 90)


def test_flat_sample_gives_flat_output() -> None:
    out = synthesize(np.full((60, 60), 0.7), (100, 100), patch=20, overlap=8, blend="cut")
    assert np.allclose(out.heights, 0.7)


def test_progress_is_called_per_patch_row(natural: Heightmap) -> None:
    calls: list[tuple[float, str]] = []
    synthesize(natural, (100, 80), patch=P, overlap=O, progress=lambda f, m: calls.append((f, m)))
    rows, _ = patch_grid((100, 80), P, O)
    assert len(calls) == len(rows)
    fr = [f for f, _ in calls]
    assert fr == sorted(fr) and fr[-1] == 1.0 and 0 < fr[0]
    assert all(isinstance(m, str) and m for _, m in calls)


# -- errors ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, words",
    [
        (dict(patch=200), ["patch 200", "128 x 128", "patch <= 128"]),
        (dict(patch=32, overlap=32), ["overlap 32", "smaller than patch 32"]),
        (dict(patch=32, overlap=40), ["overlap 40"]),
        (dict(overlap=0), ["overlap", "at least 1"]),
        (dict(patch=1), ["patch", "at least 2"]),
        (dict(patch=32.0), ["whole number"]),
        (dict(blend="smooth"), ["'smooth'", "'feather'", "'cut'"]),
        (dict(wrap="z"), ["'z'", "'x'", "'xy'"]),
        (dict(tolerance=-0.1), ["tolerance", "-0.1"]),
        (dict(tolerance=float("nan")), ["tolerance"]),
        (dict(shape=(1, 50)), ["shape[0]", "at least 2"]),
        (dict(shape=(50,)), ["shape", "(rows, cols)"]),
        (dict(shape=(20, 100), wrap="y"), ["20 px along y", "at least 32"]),
        (dict(progress="yes"), ["progress", "callable"]),
        (dict(seed=-1), ["seed", "-1"]),
        (dict(seed="abc"), ["seed", "'abc'"]),
        (dict(search="fast"), ["'fast'", "'approximate'", "'exact'"]),
    ],
)
def test_bad_parameters_raise_parameter_error(natural: Heightmap, kwargs: dict, words: list[str]) -> None:
    args = dict(shape=(100, 100), patch=P, overlap=O)
    args.update(kwargs)
    shape = args.pop("shape")
    with pytest.raises(ParameterError) as e:
        synthesize(natural, shape, **args)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_sample_smaller_than_patch_names_the_fix() -> None:
    with pytest.raises(ParameterError, match=r"patch 45 px is larger than the sample \(30 x 60 px\); use patch <= 30"):
        synthesize(np.zeros((30, 60)), (100, 100))


@pytest.mark.parametrize("bad", [np.zeros(10), np.full((40, 40), np.nan), "sample.png", np.zeros((40, 40), bool)])
def test_bad_samples_raise_texcad_errors(bad: object) -> None:
    with pytest.raises(TexcadError):
        synthesize(bad, (50, 50), patch=20, overlap=8)  # type: ignore[arg-type]
    with pytest.raises((InputError, ParameterError)):
        synthesize(bad, (50, 50), patch=20, overlap=8)  # type: ignore[arg-type]


# -- quality against random patch pasting ---------------------------------------------
@pytest.mark.parametrize("blend", BLENDS)
def test_beats_naive_quilt(natural: Heightmap, blend: str) -> None:
    shape = (220, 220)
    bands = seam_bands(shape, P, O)
    seeds = (0, 1, 2, 3)  # the histogram of a 220 px output varies from seed to seed
    syn = [synthesize(natural, shape, patch=P, overlap=O, blend=blend, seed=s) for s in seeds]
    naive = [naive_quilt(natural, shape, patch=P, overlap=O, blend=blend, seed=s) for s in seeds]

    def mean(f, outs):  # noqa: ANN001
        return float(np.mean([f(o) for o in outs]))

    hist = lambda o: Q.histogram_distance(o, natural)  # noqa: E731
    spec = lambda o: Q.spectrum_distance(o, natural)  # noqa: E731
    blur = lambda o: abs(1.0 - Q.blur_ratio(o, bands))  # noqa: E731
    if blend == "feather":
        # Feathering unrelated content blurs (ratio ~0.6) and pulls heights to the
        # mean; matched content much less.
        assert mean(spec, syn) < 0.75 * mean(spec, naive)
        assert mean(blur, syn) < 0.8 * mean(blur, naive)
        assert mean(hist, syn) < 0.7 * mean(hist, naive)
    else:
        # Cuts through unrelated content leave steps (excess high frequencies);
        # cuts keep heights unmixed, so the histograms are alike for both.
        assert mean(spec, syn) < 0.9 * mean(spec, naive)
        assert mean(hist, syn) < 1.2 * mean(hist, naive) + 1e-3
        assert mean(blur, syn) < 0.1


def test_cut_is_sharper_than_feather(natural: Heightmap) -> None:
    # Feathering matched patches still averages two textures in the overlaps
    # (blur ratio ~0.83 here: where a patch continues its neighbour's source the two
    # agree); the eq. 1 cut keeps them nearly as sharp as the rest (~0.96; 1 = as
    # sharp as the patch interiors).
    shape = (220, 220)
    bands = seam_bands(shape, P, O)
    rf, rc = [], []
    for seed in (0, 1, 2):
        f = synthesize(natural, shape, patch=P, overlap=O, blend="feather", seed=seed)
        c = synthesize(natural, shape, patch=P, overlap=O, blend="cut", seed=seed)
        rf.append(Q.blur_ratio(f, bands))
        rc.append(Q.blur_ratio(c, bands))
        assert rc[-1] > rf[-1] + 0.05
    assert np.mean(rc) > np.mean(rf) + 0.1
    assert np.mean(rf) < 0.9
    assert abs(1 - np.mean(rc)) < 0.12


def test_periodic_structure_is_continued() -> None:
    s = periodic_sample()
    out = synthesize(s, (200, 200), patch=P, overlap=O, blend="cut").heights.astype(float)
    # The output keeps the sample's periods (16 px along x, 16 px along y).
    ex = np.sqrt(np.mean((out[:, 16:] - out[:, :-16]) ** 2))
    ey = np.sqrt(np.mean((out[16:, :] - out[:-16, :]) ** 2))
    assert ex < 0.02 * np.ptp(s) and ey < 0.02 * np.ptp(s)
    naive = naive_quilt(s, (200, 200), patch=P, overlap=O).heights.astype(float)
    assert np.sqrt(np.mean((naive[16:, :] - naive[:-16, :]) ** 2)) > 10 * ey


def test_builtin_texture_sample() -> None:
    from texcad import sources as textures
    stones = textures.builtin("stones", size=(16, 16), pitch=0.125)  # 128 x 128 px
    out = synthesize(stones, (200, 200), patch=40, overlap=16, blend="cut")
    naive = naive_quilt(stones, (200, 200), patch=40, overlap=16, blend="cut")
    assert out.pitch == stones.pitch
    assert Q.spectrum_distance(out, stones) < Q.spectrum_distance(naive, stones)


# -- seamless closure (paper M-II, done on a torus) ------------------------------------
def _column_jumps(h: np.ndarray) -> np.ndarray:
    """RMS jump across every column boundary of the tiled texture; the last is the wrap."""
    t = np.concatenate([h, h[:, :1]], axis=1).astype(float)
    return np.sqrt(np.mean(np.diff(t, axis=1) ** 2, axis=0))


@pytest.mark.parametrize("blend", BLENDS)
@pytest.mark.parametrize("width", [180, 187])  # a multiple of the step, and not
def test_wrap_x_tiles(natural: Heightmap, blend: str, width: int) -> None:
    shape = (150, width)
    seams, plain = [], []
    for seed in (0, 1, 2):
        out = synthesize(natural, shape, patch=P, overlap=O, blend=blend, wrap="x", seed=seed)
        no = synthesize(natural, shape, patch=P, overlap=O, blend=blend, seed=seed)
        seams.append(Q.wrap_seam_error(out, "x"))
        plain.append(Q.wrap_seam_error(no, "x"))
        j = _column_jumps(out.heights)
        # The wrap seam is no worse than the worst interior column of the same output.
        assert j[-1] <= 1.05 * j[:-1].max()
    assert np.mean(seams) < 1.25  # like any pair of neighbouring columns (~1)
    assert np.mean(seams) < 0.4 * np.mean(plain)  # unwrapped outputs do not tile


@pytest.mark.parametrize("blend", BLENDS)
def test_wrap_y_and_xy_tile(natural: Heightmap, blend: str) -> None:
    shape = (171, 160)
    ys, xys_x, xys_y, plain = [], [], [], []
    for seed in (0, 1, 2):
        y = synthesize(natural, shape, patch=P, overlap=O, blend=blend, wrap="y", seed=seed)
        xy = synthesize(natural, shape, patch=P, overlap=O, blend=blend, wrap="xy", seed=seed)
        no = synthesize(natural, shape, patch=P, overlap=O, blend=blend, seed=seed)
        ys.append(Q.wrap_seam_error(y, "y"))
        xys_x.append(Q.wrap_seam_error(xy, "x"))
        xys_y.append(Q.wrap_seam_error(xy, "y"))
        plain.append(Q.wrap_seam_error(no, "y"))
        # Each wrap seam is no worse than the worst interior row (column) boundary,
        # which lies on an interior patch seam.
        for h in (y.heights.T, xy.heights, xy.heights.T):
            j = _column_jumps(h)
            assert j[-1] <= 1.05 * j[:-1].max()
    for seam in (ys, xys_x, xys_y):
        assert np.mean(seam) < 1.35  # ~1: like any pair of neighbouring rows
        assert np.mean(seam) < 0.4 * np.mean(plain)


@pytest.mark.parametrize("blend", BLENDS)
def test_wrap_closing_bands_are_as_sharp_as_interior_ones(natural: Heightmap, blend: str) -> None:
    # The closing patches' overlaps across the wrap lie at the start of the output;
    # rolled to mid-image, their blend bands must be as sharp as the interior ones.
    shape = (150, 187)
    ratios = []
    for seed in (0, 1, 2):
        out = synthesize(natural, shape, patch=P, overlap=O, blend=blend, wrap="x", seed=seed)
        h = np.roll(out.heights, 60, axis=1)
        bands = np.roll(seam_bands(shape, P, O, "x"), 60, axis=1)
        closing = np.zeros(shape, bool)
        closing[:, 60: 60 + P] = True  # columns 0 .. P-1 before the roll
        gy, gx = np.gradient(h.astype(float))
        e = gx**2 + gy**2
        r_close = e[bands & closing].mean() / e[~bands].mean()
        r_int = e[bands & ~closing].mean() / e[~bands].mean()
        ratios.append(r_close / r_int)
    assert np.mean(ratios) > 0.85


def test_periodic_sample_wraps_exactly() -> None:
    # A size that holds whole periods (16 px) tiles exactly: the 2 x 2 tiling keeps
    # the period everywhere, across both wrap seams.
    s = periodic_sample()
    out = synthesize(s, (128, 176), patch=P, overlap=O, wrap="xy", blend="cut").heights
    t = np.tile(out.astype(float), (2, 2))
    assert np.sqrt(np.mean((t[:, 16:] - t[:, :-16]) ** 2)) < 1e-3
    assert np.sqrt(np.mean((t[16:, :] - t[:-16, :]) ** 2)) < 1e-3


# -- grid and helpers -----------------------------------------------------------------
def test_patch_grid_covers_the_output() -> None:
    rows, cols = patch_grid((203, 241), 25, 10)
    assert rows[0] == 0 and np.all(np.diff(rows) == 15)
    assert rows[-1] + 25 >= 203 and rows[-1] - 15 + 25 < 203
    assert cols[-1] + 25 >= 241
    # On a torus the last patch passes the end by at least the overlap.
    _, wc = patch_grid((203, 241), 25, 10, wrap="x")
    assert wc[-1] + 25 - 241 >= 10 and len(wc) == -(-241 // 15)


def test_seam_bands_lie_in_overlaps() -> None:
    m = seam_bands((100, 100), 30, 10)
    col = m[50]  # a row inside a patch: bands along x only where columns overlap
    assert not col[:20].any()
    assert col[22:27].all() and not col[27:42].any()  # middle half of cols 20..29
    assert m.mean() < 0.6


def _brute_force_cost(e: np.ndarray, start: int | None) -> float:
    n, w = e.shape
    best = np.inf
    for j0 in range(w) if start is None else [start]:
        for steps in itertools.product((-1, 0, 1), repeat=n - 1):
            path = np.cumsum((j0,) + steps)
            if path.min() >= 0 and path.max() < w:
                best = min(best, float(e[np.arange(n), path].sum()))
    return best


@settings(max_examples=40, deadline=None)
@given(
    arrays(np.float64, st.tuples(st.integers(1, 5), st.integers(1, 4)), elements=st.floats(0, 10)),
    st.booleans(),
)
def test_min_error_path_is_optimal(e: np.ndarray, fix_start: bool) -> None:
    # Eq. 1 dynamic programming finds the cheapest 8-connected top-to-bottom path.
    start = e.shape[1] // 2 if fix_start else None
    e2 = e[:, ::-1].copy()
    paths = _min_error_paths([e, e2], [start, None])
    for err, path, s in zip((e, e2), paths, (start, None)):
        assert path.shape == (e.shape[0],)
        assert np.all(np.abs(np.diff(path)) <= 1)
        assert path.min() >= 0 and path.max() < e.shape[1]
        if s is not None:
            assert path[0] == s
        cost = float(err[np.arange(e.shape[0]), path].sum())
        assert cost == pytest.approx(_brute_force_cost(err, s), abs=1e-9)


def test_large_sample_candidates_are_thinned(monkeypatch: pytest.MonkeyPatch, natural: Heightmap) -> None:
    import texcad.synthesis.quilt as syn

    monkeypatch.setattr(syn, "_MAX_CANDIDATES", 500)
    out = synthesize(natural, (100, 100), patch=P, overlap=O)
    assert out.shape == (100, 100)
    assert Q.histogram_distance(out, natural) < 0.1


@pytest.mark.parametrize("key", [(0, O, 0, 0), (O, 0, 0, 0), (O, O, 0, 0), (O, O, 20, 0), (O, O, 20, 20)])
def test_fft_features_match_projection_and_bound_the_distance(natural: Heightmap, key: tuple) -> None:
    # The features of every candidate, computed at once by FFT correlation, equal
    # the projection of its boundary zone used for the query. For the three base
    # zones their distances never exceed the exact zone distance (QTP weighting +
    # orthonormal PCA): the k-d tree's coarse level bounds the fine level. (The
    # torus's closing zones concatenate parts that share their corners.)
    import texcad.synthesis.quilt as syn

    s = syn._Synthesizer(natural.heights, P, O, np.random.default_rng(0), "approximate")
    z = s.zone(key)
    feats = z.feats if z.tree is None else z.tree.data
    rng = np.random.default_rng(1)
    pick = rng.choice(len(s.cy), 300, replace=False)
    zones = s.S_flat.take(s.offsets[pick][:, None] + z.sflat).astype(np.float64)
    proj = zones @ z.kernels.T.astype(np.float64)
    scale = np.abs(feats[pick]).max()
    assert np.abs(proj - feats[pick]).max() < 1e-4 * scale
    a, b = pick[:150], pick[150:]
    d_feat = np.linalg.norm(feats[a] - feats[b], axis=1)
    d_exact = np.linalg.norm(zones[:150] - zones[150:], axis=1)
    if key[2:] == (0, 0):
        assert np.all(d_feat <= d_exact * (1 + 1e-4) + 1e-6)
    assert np.mean(d_feat / d_exact) > 0.3  # and not a trivial bound


def test_min_error_paths_of_many_strips_match_one_at_a_time() -> None:
    # Many strips (a front of patches) are backtracked by one vectorized step per
    # row; each path must be the one found for its strip alone.
    rng = np.random.default_rng(3)
    errs = [rng.random((45, int(w))) ** 3 for w in rng.integers(1, 24, size=40)]
    errs[5][:] = 1.0  # ties everywhere: the same tie-breaking
    starts = [None if k % 3 else int(e.shape[1] // 2) for k, e in enumerate(errs)]
    together = _min_error_paths(errs, starts)
    for e, s, path in zip(errs, starts, together):
        alone = _min_error_paths([e], [s])[0]
        assert np.array_equal(path, alone)


# -- exhaustive search, coherent candidates, quality against exact matching -----------
def test_exact_search_is_exhaustive(natural: Heightmap) -> None:
    # query_exact (FFT correlation) returns the r-th window, in candidate order, of
    # {B : d(B) <= (1 + tol) d_min} over *all* windows, d by brute force here.
    import texcad.synthesis.quilt as syn

    s = syn._Synthesizer(natural.heights, P, O, np.random.default_rng(0), "exact")
    rng = np.random.default_rng(5)
    for key in [(O, 0, 0, 0), (0, O, 0, 0), (O, O, 0, 0), (O, O, 20, 0), (O, O, 20, 20)]:
        z = s.zone(key)
        ys, xs = rng.integers(0, 128 - P + 1, 2), rng.integers(0, 128 - P + 1, 2)
        old = np.stack([natural.heights[y: y + P, x: x + P] for y, x in zip(ys, xs)])
        old = (old + 0.05 * rng.standard_normal(old.shape)).astype(np.float32)
        zones = s.S_flat.take(s.offsets[:, None] + z.sflat).astype(np.float64)
        for tol in (0.0, 0.3):
            u = rng.random(2)
            got = s.query_exact(z, old, tol, u)
            for k in range(2):
                d2 = ((zones - old[k].reshape(-1)[z.pflat]) ** 2).sum(axis=1)
                eligible = np.flatnonzero(d2 <= d2.min() * (1 + tol) ** 2 * (1 + 1e-9))
                assert got[k] == eligible[int(u[k] * len(eligible))]


def test_neighbour_table_and_coherent_candidates() -> None:
    import texcad.synthesis.quilt as syn

    ay, ax = syn._axis(100, P, O, False), syn._axis(150, P, O, True)  # 5 x 9 patches, x wraps
    nb, dy, dx = syn._neighbour_table(ay, ax)
    n_cols = len(ax.starts)
    step = P - O
    got = {(int(f) // n_cols, int(f) % n_cols, int(a), int(b)) for f, a, b in zip(nb[1 * n_cols + 3], dy[1 * n_cols + 3], dx[1 * n_cols + 3]) if f >= 0}
    assert got == {(0, 2, -step, -step), (0, 3, -step, 0), (0, 4, -step, step), (1, 2, 0, -step)}
    # The closing patch of a row also continues patch 0 of its row, across the wrap.
    last = 2 * n_cols + n_cols - 1
    got = {(int(f) // n_cols, int(f) % n_cols, int(b)) for f, b in zip(nb[last], dx[last]) if f >= 0}
    assert (2, 0, ax.canvas - int(ax.starts[-1])) in got and (1, 0, ax.canvas - int(ax.starts[-1])) in got
    assert (2, n_cols - 2, -step) in got
    # The first patch has none.
    assert (nb[0] < 0).all()
    # Coherent candidates: the window continuing each neighbour's source window.
    s = syn._Synthesizer(natural_sample(), P, O, np.random.default_rng(0), "approximate")
    chosen = np.full(len(ay.starts) * n_cols, -1, dtype=np.intp)
    chosen[1 * n_cols + 2] = int(s.lookup[50, 60])  # left neighbour from window (50, 60)
    chosen[0 * n_cols + 3] = int(s.lookup[10, 5])  # top neighbour from window (10, 5)
    chosen[0 * n_cols + 4] = int(s.lookup[90, 2])  # top-right: its continuation leaves the sample
    c = syn._coherent_candidates(np.array([1 * n_cols + 3]), chosen, (nb, dy, dx), s)[0]
    pos = {(int(s.cy[k]), int(s.cx[k])) for k in c if k >= 0}
    assert pos == {(50, 60 + step), (10 + step, 5)}


def _photo(name: str, y: int = 0, x: int = 0) -> np.ndarray:
    """A 200 x 200 px crop of one of scikit-image's CC0 texture photographs (grey / 255
    as heights in mm): gravel and grass are irregular, the brick wall structured."""
    import skimage.data  # the `test` extra of pyproject.toml

    return np.ascontiguousarray(getattr(skimage.data, name)()[y: y + 200, x: x + 200].astype(np.float32) / 255.0)


#: 200 x 200 px crops (name, row, col) on which approximate and exact search are compared.
#: Irregular ones where the coherent candidates put the approximate search well ahead
#: (4-seed means at 400 x 400 px: 0.63-0.72 of exact matching's distance) ...
_AHEAD = [("gravel", 0, 0), ("gravel", 300, 300), ("grass", 0, 0)]
#: ... and the hardest ones, at parity: a brick wall (structured) and the grass crop
#: on which the approximate search was 17 % worse before the eligible coherent
#: candidates were preferred (0.86-1.06 each; 0.97 on average).
_PARITY = [("brick", 0, 0), ("brick", 300, 300), ("brick", 0, 300), ("grass", 300, 300)]


@pytest.fixture(scope="module")
def coherence_of_photos() -> dict[tuple[str, int, int], tuple[float, float, float]]:
    """``{crop: (approximate, exact, naive)}``: mean coherence over seeds 0..3 of a
    400 x 400 px output (patch 45, overlap 25; 1000 windows, lower is better)."""
    out = {}
    for crop in _AHEAD + _PARITY:
        s = _photo(*crop)
        kw = dict(patch=45, overlap=25)

        def mean(make):  # noqa: ANN001, ANN202
            return float(np.mean([Q.coherence(make(k), s, n_windows=1000) for k in range(4)]))

        out[crop] = (
            mean(lambda k: synthesize(s, (400, 400), seed=k, **kw)),  # noqa: B023
            mean(lambda k: synthesize(s, (400, 400), seed=k, search="exact", **kw)),  # noqa: B023
            mean(lambda k: naive_quilt(s, (400, 400), seed=k, **kw)),  # noqa: B023
        )
    return out


@pytest.mark.slow
@pytest.mark.parametrize("crop", _AHEAD, ids=lambda c: f"{c[0]}@{c[1]},{c[2]}")
def test_coherence_ahead_of_exact_matching(coherence_of_photos, crop) -> None:  # noqa: ANN001
    # The criterion (within 2 % of exhaustive matching or better) with room
    # to spare on irregular photographs.
    approx, exact, naive = coherence_of_photos[crop]
    assert exact < 0.8 * naive  # the measure sees matching at all
    assert approx <= 0.9 * exact, (approx, exact)


@pytest.mark.slow
def test_coherence_within_2_percent_of_exact_matching_on_hard_photographs(coherence_of_photos) -> None:  # noqa: ANN001
    # On the structured and the hardest irregular crops the approximate search is at
    # parity with exhaustive matching. The 4-seed mean of one crop scatters by about
    # +-5 % (single seeds by up to 25 %: see benchmarks/bench_synthesis.py), so the
    # 2 % criterion is asserted on the mean ratio over these crops, and each crop
    # within 10 %.
    ratios = []
    for crop in _PARITY:
        approx, exact, naive = coherence_of_photos[crop]
        assert exact < 0.8 * naive
        ratios.append(approx / exact)
        assert ratios[-1] <= 1.10, (crop, ratios[-1])
    assert np.mean(ratios) <= 1.02, ratios


@pytest.mark.slow
@pytest.mark.parametrize("blend", BLENDS)
def test_wrap_seams_of_a_structured_photograph(blend: str) -> None:
    # Brick wall: the closing patches must reconcile the phases of both neighbours.
    # The squared jump across each wrap seam, pooled over seeds, is at most 1.2 times
    # the mean squared jump between neighbouring columns (rows). (A single seam of
    # a brick wall varies several-fold with where the mortar lines fall, so the
    # figure is a mean over 12 seeds of one crop and 6 of another.)
    seams: dict[str, list[float]] = {"x": [], "y": [], "xy-x": [], "xy-y": []}
    for s, seed in [(_photo("brick"), k) for k in range(12)] + [(_photo("brick", 300, 300), k) for k in range(6)]:
        for wrap in ("x", "y", "xy"):
            out = synthesize(s, (400, 400), patch=45, overlap=25, wrap=wrap, blend=blend, seed=seed)
            for a in "xy":
                if a in wrap:
                    seams[wrap if len(wrap) == 1 else f"xy-{a}"].append(Q.wrap_seam_error(out, a) ** 2)
    for key, v in seams.items():
        assert np.mean(v) <= 1.2, (key, np.mean(v))
