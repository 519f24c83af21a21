"""Objective quality measures of a synthesized texture against its sample.

Pure functions of height arrays (mm), each returning one number; lower is better for
the distances, 1 is ideal for the ratios. They back the tests of
:mod:`texcad.synthesis` (synthesis must beat random patch pasting,
:func:`texcad.synthesis.naive_quilt`) and ``texcad synth --report``.

- :func:`histogram_distance`: do the heights have the sample's distribution?
- :func:`spectrum_distance`: do the features have the sample's sizes (power at each
  spatial frequency)?
- :func:`blur_ratio`: are the overlaps, where patches are blended, as sharp as the rest?
- :func:`wrap_seam_error`: does the texture continue across its edges (tiling)?
- :func:`coherence`: does every small window of the output look like some window of
  the sample (how close synthesis comes to copying the sample verbatim)?
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ParameterError
from ..sources import Heightmap

__all__ = [
    "histogram_distance",
    "spectrum_distance",
    "radial_power_spectrum",
    "blur_ratio",
    "wrap_seam_error",
    "coherence",
    "report",
    "natural_sample",
]


def natural_sample(
    rows: int = 200, cols: int = 200, seed: int = 1, *, periodic: bool = True, sensor_noise: float = 0.0
) -> np.ndarray:
    """A photograph-like stochastic height field, ``(rows, cols)`` float32 in 0..1 mm:
    filtered noise at two scales (sigma 4 and 1.2 px) minus a network of grooves
    (near the zero crossings of a smooth field, sigma 6 px), optionally plus white
    "sensor" noise. The non-procedural reference sample that the synthesis tests,
    the benchmark and the docs figure measure against. Seeded: same arguments, same
    array.

    Args:
        rows, cols: size in px.
        seed: ``numpy.random.default_rng`` seed.
        periodic: filter with wrap-around (the field tiles) instead of reflection.
        sensor_noise: standard deviation of added white noise, before normalization.
    """
    from scipy import ndimage

    mode = "wrap" if periodic else "reflect"
    rng = np.random.default_rng(seed)
    a = 4 * ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 4, mode=mode)
    a += ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 1.2, mode=mode)
    r = ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 6, mode=mode)
    a -= 1.5 * np.exp(-0.5 * (r / 0.01) ** 2)
    if sensor_noise:
        a += sensor_noise * rng.standard_normal((rows, cols))
    return ((a - a.min()) / (a.max() - a.min())).astype(np.float32)


def _heights(h: Heightmap | np.ndarray, name: str = "heights") -> np.ndarray:
    a = h.heights if isinstance(h, Heightmap) else np.asarray(h)
    if a.ndim != 2 or min(a.shape) < 2:
        raise InputError(f"{name} must be a 2-D array of at least 2 x 2 px, got shape {a.shape}")
    a = a.astype(np.float64)
    if not np.isfinite(a).all():
        raise InputError(f"{name} holds NaN or infinite heights; fill them first")
    return a


def histogram_distance(output: Heightmap | np.ndarray, sample: Heightmap | np.ndarray) -> float:
    """Earth mover's distance between the height distributions, relative to the sample's range.

        D_hist = W_1(h_out, h_sample) / (max h_sample - min h_sample),
        W_1 = integral_0^1 |Q_out(q) - Q_sample(q)| dq,

    ``Q`` the quantile function of the heights, evaluated at 1000 levels. 0 for the
    same distribution; random patch pasting with feathering pulls heights towards the
    mean and scores higher.

    Args:
        output, sample: heightmaps or 2-D arrays of heights in mm.

    Returns:
        Dimensionless distance >= 0 (a fraction of the sample's height range).
    """
    a, b = _heights(output, "output"), _heights(sample, "sample")
    q = (np.arange(1000) + 0.5) / 1000
    span = float(b.max() - b.min())
    w1 = float(np.mean(np.abs(np.quantile(a, q) - np.quantile(b, q))))
    return w1 / span if span > 0 else w1


def radial_power_spectrum(
    heights: Heightmap | np.ndarray, bins: np.ndarray, *, segment: int | None = None
) -> np.ndarray:
    """Radially averaged power spectrum of a heightmap (Welch's method).

        P(f) = mean over segments, mean over |k| in bin f of
               |F[w (h_seg - mean h_seg)](k)|^2 / sum w^2,

    with ``w`` a separable Hann window (against edge leakage), ``|k|`` the radial
    frequency in cycles per pixel and ``h_seg`` the ``segment x segment`` px windows
    of the heightmap on a grid of step ``segment / 2`` (the whole map if ``segment``
    is None). Comparing two maps with the same ``segment`` gives both the same
    window, so the leakage of the window does not differ between them.

    Args:
        heights: heightmap or 2-D array in mm.
        bins: ``(n + 1,)`` bin edges in cycles/px, increasing, within (0, 0.5].
        segment: side of the square segments in px (>= 8), or None.

    Returns:
        ``(n,)`` power in mm^2 px^2 per bin (NaN for an empty bin).
    """
    h = _heights(heights)
    if segment is None:
        segs = [h]
    else:
        L = int(segment)
        if L < 8 or L > min(h.shape):
            raise ParameterError(f"segment must be 8 .. {min(h.shape)} px for a {h.shape} map, got {segment}")
        step = max(1, L // 2)
        ys = range(0, h.shape[0] - L + 1, step)
        xs = range(0, h.shape[1] - L + 1, step)
        segs = [h[y: y + L, x: x + L] for y in ys for x in xs]
    rows, cols = segs[0].shape
    w = np.hanning(rows)[:, None] * np.hanning(cols)[None, :]
    stack = np.stack(segs)
    stack = (stack - stack.mean(axis=(1, 2), keepdims=True)) * w
    F = np.fft.rfft2(stack, axes=(1, 2))
    power = ((F.real**2 + F.imag**2) / float((w**2).sum())).mean(axis=0)
    fy = np.fft.fftfreq(rows)[:, None]
    fx = np.fft.rfftfreq(cols)[None, :]
    f = np.sqrt(fy**2 + fx**2)
    which = np.digitize(f.ravel(), bins) - 1
    ok = (which >= 0) & (which < len(bins) - 1)
    n = len(bins) - 1
    total = np.bincount(which[ok], weights=power.ravel()[ok], minlength=n)
    count = np.bincount(which[ok], minlength=n)
    with np.errstate(invalid="ignore", divide="ignore"):
        return total / count


def spectrum_distance(
    output: Heightmap | np.ndarray, sample: Heightmap | np.ndarray, *, n_bins: int = 24
) -> float:
    """RMS distance between the log radial power spectra, in decades.

        D_spec = sqrt( mean_f (log10 P_out(f) - log10 P_sample(f))^2 ),

    over ``n_bins`` logarithmic bins of radial frequency from ``4 / L`` to 0.5
    cycles/px, where both spectra are Welch averages over ``L x L`` px segments,
    ``L`` the smaller side of the sample and the output (see
    :func:`radial_power_spectrum`), and both are floored at ``1e-6 max P_sample``
    (60 dB: the gaps between the lines of a periodic texture's spectrum hold no
    information). 0 for equal spectra; blur lowers the high frequencies, steps at
    seams raise them, missing structure changes the low ones.

    Args:
        output, sample: heightmaps or 2-D arrays in mm, at the same pitch.
        n_bins: number of frequency bins.

    Returns:
        Distance >= 0 in decades of power.
    """
    if int(n_bins) < 1:
        raise ParameterError(f"n_bins must be at least 1, got {n_bins}")
    a, b = _heights(output, "output"), _heights(sample, "sample")
    L = min(min(a.shape), min(b.shape))
    if L < 16:
        raise InputError(
            f"output {a.shape} and sample {b.shape} must both be at least 16 x 16 px for a spectrum"
        )
    bins = np.geomspace(4.0 / L, 0.5, int(n_bins) + 1)
    pa = radial_power_spectrum(a, bins, segment=L)
    pb = radial_power_spectrum(b, bins, segment=L)
    ok = np.isfinite(pa) & np.isfinite(pb)
    if not ok.any():
        return 0.0
    floor = max(1e-6 * float(pb[ok].max()), 1e-300)
    d = np.log10(np.maximum(pa[ok], floor)) - np.log10(np.maximum(pb[ok], floor))
    return float(np.sqrt(np.mean(d**2))) if d.size else 0.0


def _gradient_energy(h: np.ndarray) -> np.ndarray:
    """``|grad h|^2`` per pixel (central differences, mm^2/px^2)."""
    gy, gx = np.gradient(h)
    return gx * gx + gy * gy


def blur_ratio(output: Heightmap | np.ndarray, bands: np.ndarray) -> float:
    """Gradient energy in the blend bands relative to the rest of the output.

        R_blur = mean_{bands} |grad h|^2 / mean_{elsewhere} |grad h|^2.

    Feathering two unrelated patches averages them and lowers the gradient energy
    (about 1/2 at equal weights): ``R_blur ~ 1`` means the overlaps are as sharp as the
    patch interiors, values well below 1 mean visible blur. Get ``bands`` from
    :func:`texcad.synthesis.seam_bands`.

    Args:
        output: heightmap or 2-D array in mm.
        bands: bool array of the same shape, True in the blend bands.

    Returns:
        Dimensionless ratio (NaN if either region is empty or flat).
    """
    h = _heights(output, "output")
    m = np.asarray(bands, dtype=bool)
    if m.shape != h.shape:
        raise ParameterError(f"bands has shape {m.shape} but the output has {h.shape}; pass seam_bands(output shape, ...)")
    g = _gradient_energy(h)
    inside, outside = g[m], g[~m]
    if inside.size == 0 or outside.size == 0 or outside.mean() == 0:
        return float("nan")
    return float(inside.mean() / outside.mean())


def wrap_seam_error(output: Heightmap | np.ndarray, axis: str = "x") -> float:
    """RMS height jump across the wrap seam relative to typical neighbour differences.

    For ``axis="x"`` (the output wrapped around a cylinder whose axis is y: its last
    column meets its first)

        S_x = sqrt(mean_r (h[r, 0] - h[r, -1])^2) / sqrt(mean_{r,c} (h[r, c+1] - h[r, c])^2),

    and likewise along y with rows. ``S ~ 1``: the seam is like any other pair of
    neighbouring pixels (``np.concatenate([h, h], axis=1)`` shows no seam); a texture
    that does not tile scores several times more.

    Args:
        output: heightmap or 2-D array in mm.
        axis: ``"x"`` (columns wrap) or ``"y"`` (rows wrap).

    Returns:
        Dimensionless ratio >= 0 (NaN for a flat output).
    """
    if axis not in ("x", "y"):
        raise ParameterError(f"axis must be 'x' or 'y', got {axis!r}")
    h = _heights(output, "output")
    if axis == "y":
        h = h.T
    jump = np.sqrt(np.mean((h[:, 0] - h[:, -1]) ** 2))
    typical = np.sqrt(np.mean(np.diff(h, axis=1) ** 2))
    return float(jump / typical) if typical > 0 else float("nan")


def coherence(
    output: Heightmap | np.ndarray,
    sample: Heightmap | np.ndarray,
    *,
    window: int = 16,
    n_windows: int = 400,
    seed: int = 0,
) -> float:
    """Mean distance of random output windows to their nearest sample window.

        C = (1 / N) sum_n min_s sqrt( (1 / w^2) sum_{u,v} (o_n(u, v) - s(u, v))^2 ) / sigma,

    over ``N = n_windows`` windows ``o_n`` of ``w x w`` px (``w = window``) at
    positions drawn uniformly from the output with ``numpy.random.default_rng(seed)``,
    the minimum over *every* ``w x w`` window ``s`` of the sample (exhaustive: the
    sum of squares ``|o|^2 - 2 <o, s> + |s|^2`` with the cross term ``<o, s>`` the
    FFT correlation of the sample with ``o`` and ``|s|^2`` a box sum of the squared
    sample), and ``sigma`` the standard deviation of the sample's heights (mm). A
    window copied from the sample scores 0; seams that join mismatched patches,
    blur and invented structure raise it. It is the "coherence" of patch-based
    synthesis (Liang et al. 2001 pick patches to keep it low along the boundary
    zones): lower is better, dimensionless, in units of the sample's spread.

    Args:
        output, sample: heightmaps or 2-D arrays of heights in mm, at the same pitch.
        window: side ``w`` of the compared windows in px (>= 2, at most the smaller
            side of either map).
        n_windows: how many output windows to average over (>= 1).
        seed: seed of the window positions (same inputs and seed, same value).

    Returns:
        ``C >= 0`` (0 for a flat sample that equals the output; NaN if the sample is
        flat and the output is not).
    """
    o, s = _heights(output, "output"), _heights(sample, "sample")
    w, n = int(window), int(n_windows)
    if w < 2 or w > min(min(o.shape), min(s.shape)):
        raise ParameterError(
            f"window must be 2 .. {min(min(o.shape), min(s.shape))} px for an output of {o.shape} "
            f"and a sample of {s.shape} px, got {window}"
        )
    if n < 1:
        raise ParameterError(f"n_windows must be at least 1, got {n_windows}")
    mu, sigma = float(s.mean()), float(s.std())
    s = s - mu
    o = o - mu
    rng = np.random.default_rng(seed)
    ys = rng.integers(0, o.shape[0] - w + 1, n)
    xs = rng.integers(0, o.shape[1] - w + 1, n)
    wins = np.lib.stride_tricks.sliding_window_view(o, (w, w))[ys, xs]  # (n, w, w)
    # |s|^2 of every sample window: box sums of s^2 by a 2-D cumulative sum.
    c = np.zeros((s.shape[0] + 1, s.shape[1] + 1))
    c[1:, 1:] = np.cumsum(np.cumsum(s * s, axis=0), axis=1)
    s2 = c[w:, w:] - c[:-w, w:] - c[w:, :-w] + c[:-w, :-w]  # (R - w + 1, C - w + 1)
    ny, nx = s2.shape
    # Correlation on a grid large enough that no valid window wraps around.
    shape = (s.shape[0], s.shape[1])
    S_hat = np.fft.rfft2(s, shape)
    best = np.empty(n)
    for k0 in range(0, n, 32):
        k1 = min(n, k0 + 32)
        K = np.fft.rfft2(wins[k0:k1], shape, axes=(1, 2))
        cross = np.fft.irfft2(S_hat[None] * np.conj(K), shape, axes=(1, 2))[:, :ny, :nx]
        o2 = np.einsum("kij,kij->k", wins[k0:k1], wins[k0:k1])
        d2 = s2[None] - 2.0 * cross
        best[k0:k1] = d2.reshape(k1 - k0, -1).min(axis=1) + o2
    rms = np.sqrt(np.clip(best, 0.0, None) / (w * w))
    if sigma == 0:
        return 0.0 if float(rms.max()) == 0 else float("nan")
    return float(rms.mean() / sigma)


def report(
    output: Heightmap | np.ndarray,
    sample: Heightmap | np.ndarray,
    bands: np.ndarray | None = None,
) -> dict[str, float]:
    """All measures at once, for printing.

    Returns:
        ``{"histogram": D_hist, "spectrum": D_spec, "blur": R_blur (if bands),
        "seam_x": S_x, "seam_y": S_y}``.
    """
    r = {
        "histogram": histogram_distance(output, sample),
        "spectrum": spectrum_distance(output, sample),
    }
    if bands is not None:
        r["blur"] = blur_ratio(output, bands)
    r["seam_x"] = wrap_seam_error(output, "x")
    r["seam_y"] = wrap_seam_error(output, "y")
    return r
