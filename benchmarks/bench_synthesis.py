"""Benchmark of texcad.synthesis: speed, memory and quality figures.

Run from the repository root:

    python benchmarks/bench_synthesis.py            # everything (~10 min)
    python benchmarks/bench_synthesis.py --quick    # skip 4000 x 4000
    python benchmarks/bench_synthesis.py --photos   # only the photographs' figures
    python benchmarks/bench_synthesis.py --speed    # only the timings
    python benchmarks/bench_synthesis.py --seams    # only the photographs' wrap seams

Prints the median wall time of several runs and the peak memory (tracemalloc peak of
one run, and the process's peak resident set size), then quality measures of the
output against the sample and against random patch pasting (naive_quilt), and the
wrap seam of the torus closure against the paper's closing cut (M-II, section 2.1.4).
The sample is a 200 x 200 px photograph-like height field (filtered noise at two
scales with a network of grooves), the paper's patch 45 px and overlap 25 px.

Then, on real photographs (scikit-image's CC0 gravel, brick wall and grass, 200 x 200
px crops at three places each, grey level / 255 as heights in mm): coherence
(texcad.synthesis.quality.coherence) and time of the approximate search (and of variants of
it) against the exhaustive search (search="exact", straightforward Liang 2001), and
the wrap seam (squared jump across the wrap over the mean squared jump between
neighbouring columns, i.e. wrap_seam_error**2) for wrap "x", "y" and "xy", with the
torus's closing patches matched exhaustively (default) or by the k-d tree.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from texcad.synthesis import quality as Q  # noqa: E402
from texcad.synthesis import naive_quilt, patch_grid, seam_bands, synthesize  # noqa: E402
from texcad.synthesis.quilt import _min_error_paths  # noqa: E402
from texcad.sources import builtin  # noqa: E402

PATCH, OVERLAP = 45, 25


CPU: list[float] = []  # process CPU seconds of the runs of the last timed() call


def timed(fn, runs: int) -> tuple[float, list[float]]:  # noqa: ANN001
    """Median wall seconds and all runs; the CPU seconds of each run go to CPU (on
    a machine shared with other work, wall time overstates the cost, CPU time not)."""
    times = []
    CPU.clear()
    for _ in range(runs):
        t, c = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - t)
        CPU.append(time.process_time() - c)
    return statistics.median(times), times


def peak_traced(fn) -> float:  # noqa: ANN001
    """Peak bytes allocated (numpy included) during one call, MiB."""
    tracemalloc.start()
    fn()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return peak / 2**20


def paper_closing_cut(h: np.ndarray, extra: int) -> tuple[np.ndarray, float]:
    """The paper's M-II: from a texture ``extra`` px wider than needed, overlay its
    last ``extra`` columns on its first ones and cut along the minimum-error path
    (eq. 1). Returns the closed texture and the RMS mismatch ``right - left`` along
    the cut relative to the typical neighbour difference."""
    w = h.shape[1] - extra
    right, left = h[:, w:].astype(float), h[:, :extra].astype(float)
    path = _min_error_paths([(right - left) ** 2], [None])[0]
    cols = np.arange(extra)[None, :]
    merged = np.where(cols <= path[:, None], right, left)
    out = np.concatenate([merged, h[:, extra:w]], axis=1)
    rows = np.arange(h.shape[0])
    mismatch = np.sqrt(np.mean((right[rows, path] - left[rows, path]) ** 2))
    typical = np.sqrt(np.mean(np.diff(out, axis=1) ** 2))
    return out, float(mismatch / typical)


def photos() -> dict[str, np.ndarray]:
    """200 x 200 px crops of scikit-image's texture photographs (CC0: brick "Bricks25",
    gravel "Gravel04" from cc0textures.com, grass from DeviantArt's linolafett, as
    skimage.data's docstrings state), grey level / 255 as heights in mm."""
    import skimage.data as data

    out = {}
    for name in ("gravel", "brick", "grass"):
        img = getattr(data, name)().astype(np.float32) / 255.0
        for y, x in ((0, 0), (300, 300), (0, 300)):
            out[f"{name}@{y},{x}"] = np.ascontiguousarray(img[y: y + 200, x: x + 200])
    return out


#: Variants of the approximate search measured against the exhaustive one.
VARIANTS = {
    "no coherent candidates": dict(_COHERENT=False),
    "coherent, not preferred": dict(_PREFER_COHERENT=False),
    "2 x 2 px QTP blocks (level 1)": dict(_COARSE_PIXELS_PER_STRIP=320, _MAX_COARSE_PIXELS=640),
    "default (16 nn + coherent, preferred)": {},
}


def _with(settings: dict, fn):  # noqa: ANN001, ANN202
    import texcad.synthesis.quilt as syn

    old = {k: getattr(syn, k) for k in settings}
    for k, v in settings.items():
        setattr(syn, k, v)
    try:
        return fn()
    finally:
        for k, v in old.items():
            setattr(syn, k, v)


def photo_coherence(seeds: int, windows: int = 1000) -> None:
    print(f"coherence on photographs, 200 x 200 px crop -> 800 x 800 px, patch {PATCH}, overlap {OVERLAP},")
    print(f"{windows} windows, mean of seeds 0..{seeds - 1} (lower is better; ratio = approximate / exact,")
    print("+- its standard error from the per-seed spread; median wall and CPU s per run;")
    print(f"load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    for name, s in photos().items():
        res = {}
        for label, mode, settings in [("exact", "exact", {})] + [(k, "approximate", v) for k, v in VARIANTS.items()]:
            cs, ts, cpu = [], [], []
            for seed in range(seeds):
                t, c = time.perf_counter(), time.process_time()
                o = _with(settings, lambda: synthesize(s, (800, 800), patch=PATCH, overlap=OVERLAP, seed=seed, search=mode))  # noqa: B023
                ts.append(time.perf_counter() - t)
                cpu.append(time.process_time() - c)
                cs.append(Q.coherence(o, s, n_windows=windows))
            res[label] = (np.array(cs), statistics.median(ts), statistics.median(cpu))
        e = res["exact"][0]
        print(f"  {name:15s} exact {e.mean():.4f} ({res['exact'][1]:.2f} s, CPU {res['exact'][2]:.2f} s)")
        for label in VARIANTS:
            c, t, cp = res[label]
            r = c.mean() / e.mean()
            # Delta method: relative errors of the two independent means add in quadrature.
            se = r * np.sqrt((c.std(ddof=1) / c.mean()) ** 2 / seeds + (e.std(ddof=1) / e.mean()) ** 2 / seeds) if seeds > 1 else float("nan")
            print(f"      {label:38s} {c.mean():.4f} ratio {r:.3f} +- {se:.3f} ({t:.2f} s, CPU {cp:.2f} s)", flush=True)


def photo_wrap_seams(seeds: int) -> None:
    print(f"wrap seams on photographs, 800 x 800 px, mean over seeds 0..{seeds - 1} of the squared jump across")
    print("the wrap / mean squared jump between neighbouring columns (rows) (= wrap_seam_error**2; the")
    print("interior boundaries average 1 by definition); +- standard error of the mean over seeds")
    for name, s in photos().items():
        if not name.endswith("@0,0"):
            continue
        for blend in ("feather", "cut"):
            for exact_closing in (True, False):
                parts = []
                for wrap in ("x", "y", "xy"):
                    v = np.array([
                        [Q.wrap_seam_error(o, a) ** 2 for a in "xy" if a in wrap]
                        for o in (
                            _with(dict(_EXACT_CLOSING=exact_closing), lambda: synthesize(  # noqa: B023
                                s, (800, 800), patch=PATCH, overlap=OVERLAP, blend=blend, wrap=wrap, seed=seed))  # noqa: B023
                            for seed in range(seeds)
                        )
                    ])
                    m, se = v.mean(axis=0), v.std(axis=0) / np.sqrt(len(v))
                    parts.append(f"{wrap}: " + "/".join(f"{a:.2f}+-{b:.2f}" for a, b in zip(m, se)))
                how = "exact closing" if exact_closing else "k-d closing  "
                print(f"  {name:12s} {blend:7s} {how}: " + ", ".join(parts), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="skip the 4000 x 4000 px runs")
    ap.add_argument("--photos", action="store_true", help="only the photographs' coherence and wrap seams")
    ap.add_argument("--speed", action="store_true", help="only the timings")
    ap.add_argument("--seeds", type=int, default=6, help="seeds of the photographs' coherence")
    ap.add_argument("--seams", action="store_true", help="only the photographs' wrap seams")
    ap.add_argument("--wrap-seeds", type=int, default=12, help="seeds of the photographs' wrap seams")
    args = ap.parse_args()
    if args.seams:
        photo_wrap_seams(args.wrap_seeds)
        return
    if args.photos:
        photo_coherence(args.seeds)
        print()
        photo_wrap_seams(args.wrap_seeds)
        return

    sample = Q.natural_sample()
    print(f"sample {sample.shape[0]} x {sample.shape[1]} px, patch {PATCH}, overlap {OVERLAP}")
    print()
    print(f"speed (median of runs, wall clock and process CPU; load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)")
    cases = [((800, 800), "feather", None, 7), ((800, 800), "cut", None, 5), ((800, 800), "feather", "x", 5),
             ((800, 800), "feather", "xy", 5)]
    if not args.quick:
        cases += [((4000, 4000), "feather", None, 3), ((4000, 4000), "cut", None, 1)]
    for shape, blend, wrap, runs in cases:
        fn = lambda: synthesize(sample, shape, patch=PATCH, overlap=OVERLAP, blend=blend, wrap=wrap)  # noqa: E731
        fn()  # warm up (imports, caches)
        med, times = timed(fn, runs)
        mem = peak_traced(fn) if shape[0] <= 800 or blend == "feather" else float("nan")
        print(
            f"  {shape[0]} x {shape[1]} {blend:7s} wrap={str(wrap):4s}: median {med:6.3f} s, "
            f"CPU {statistics.median(CPU):6.3f} s (runs {', '.join(f'{t:.3f}' for t in times)}), "
            f"traced peak {mem:6.1f} MiB"
        )
    # What `texcad demo` runs: a 25 mm built-in sample grown to the 100 mm plate.
    stones = builtin("stones", size=(25, 25), pitch=0.125, height=2.0)
    fn = lambda: synthesize(stones, (800, 800), wrap="xy", seed=0)  # noqa: E731
    fn()
    med, times = timed(fn, 5)
    print(
        f"  demo: builtin('stones', size=(25, 25), pitch=0.125, height=2) {stones.shape[0]} x {stones.shape[1]} px "
        f"-> 800 x 800 wrap=xy: median {med:6.3f} s, CPU {statistics.median(CPU):.3f} s "
        f"(runs {', '.join(f'{t:.3f}' for t in times)})"
    )
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  process peak resident set size so far: {rss:.0f} MiB")
    print(f"  load average after the timings: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
    if args.speed:
        return

    print()
    print("quality, 800 x 800 px, mean of seeds 0..2 (synthesize | naive_quilt)")
    shape = (800, 800)
    bands = seam_bands(shape, PATCH, OVERLAP)
    for blend in ("feather", "cut"):
        rs, rn = [], []
        for seed in range(3):
            s = synthesize(sample, shape, patch=PATCH, overlap=OVERLAP, blend=blend, seed=seed)
            n = naive_quilt(sample, shape, patch=PATCH, overlap=OVERLAP, blend=blend, seed=seed)
            rs.append(Q.report(s, sample, bands))
            rn.append(Q.report(n, sample, bands))
        for key in ("histogram", "spectrum", "blur"):
            a = np.mean([r[key] for r in rs])
            b = np.mean([r[key] for r in rn])
            print(f"  {blend:7s} {key:9s}: {a:.3f} | {b:.3f}")

    print()
    print("quality on the built-in textures: 25 mm samples at 0.125 mm/px (200 x 200 px) grown to")
    print("400 x 400 px, mean of seeds 0..1 (synthesize | naive_quilt; lower is better, blur 1 = sharp)")
    builtin_quality(synthesize, naive_quilt)

    print()
    print("seamless closure along x, 800 x 790 px, mean of seeds 0..4")
    print("  S_x: RMS jump across the wrap / typical neighbour difference (1 = no seam)")
    print("  J_max: worst column of the closure region (RMS jump across a column boundary /")
    print("  typical), against the 99th percentile of all other columns")
    shape = (800, 790)
    cols_t = patch_grid(shape, PATCH, OVERLAP, "x")[1]
    last = int(cols_t[-1])
    torus_region = np.r_[last: shape[1], 0: last + PATCH - shape[1]]  # closing patch
    extra = 100  # the paper's 2 x 50 px
    for blend in ("feather", "cut"):
        rows = []
        for seed in range(5):
            w = synthesize(sample, shape, patch=PATCH, overlap=OVERLAP, blend=blend, wrap="x", seed=seed)
            p = synthesize(sample, shape, patch=PATCH, overlap=OVERLAP, blend=blend, seed=seed)
            wide = synthesize(sample, (shape[0], shape[1] + extra), patch=PATCH, overlap=OVERLAP, blend=blend, seed=seed)
            m2, step = paper_closing_cut(wide.heights, extra)
            jt, jm = column_jumps(w.heights), column_jumps(m2)
            rows.append([
                Q.wrap_seam_error(w, "x"), jt[torus_region].max(), np.percentile(np.delete(jt, torus_region), 99),
                Q.wrap_seam_error(p, "x"),
                jm[:extra].max(), np.percentile(jm[extra:], 99), step,
            ])
        r = np.mean(rows, axis=0)
        print(
            f"  {blend:7s} torus (wrap='x'): S_x {r[0]:.2f}, J_max {r[1]:.2f} vs {r[2]:.2f}; "
            f"no wrap: S_x {r[3]:.2f}"
        )
        print(
            f"  {blend:7s} paper M-II cut : J_max {r[4]:.2f} vs {r[5]:.2f}; RMS mismatch along its cut {r[6]:.2f}"
        )
    inner = np.mean([interior_cut_mismatch(sample, (800, 800), seed) for seed in range(3)])
    print(f"  for scale: RMS mismatch (old - new) along the interior cuts of blend='cut': {inner:.2f}")

    print()
    photo_coherence(args.seeds)
    print()
    photo_wrap_seams(args.wrap_seeds)


def builtin_quality(synth, naive, names: list[str] | None = None) -> None:  # noqa: ANN001
    """Print the quality measures of every built-in texture (or ``names``) grown from
    a 200 x 200 px sample to 400 x 400 px by ``synth`` and by ``naive``, and their
    means over the textures."""
    from texcad.sources import builtin_names

    shape = (400, 400)
    bands = seam_bands(shape, PATCH, OVERLAP)
    keys = ("histogram", "spectrum", "blur")
    totals: dict[str, list[np.ndarray]] = {"feather": [], "cut": []}
    for name in names or builtin_names():
        s = builtin(name, size=(25, 25), pitch=0.125)
        line = f"  {name:15s}"
        for blend in ("feather", "cut"):
            kw = dict(patch=PATCH, overlap=OVERLAP, blend=blend)
            rs = [Q.report(synth(s, shape, seed=seed, **kw), s, bands) for seed in (0, 1)]
            rn = [Q.report(naive(s, shape, seed=seed, **kw), s, bands) for seed in (0, 1)]
            a = np.array([[np.mean([r[k] for r in rs]), np.mean([r[k] for r in rn])] for k in keys])
            totals[blend].append(a)
            line += f"  {blend}: " + ", ".join(f"{k[:4]} {x:.3f}|{y:.3f}" for k, (x, y) in zip(keys, a))
        print(line)
    for blend, rows in totals.items():
        m = np.mean(rows, axis=0)
        print(f"  mean {blend:7s}: " + ", ".join(f"{k} {x:.3f} | {y:.3f}" for k, (x, y) in zip(keys, m)))


def interior_cut_mismatch(sample: np.ndarray, shape: tuple[int, int], seed: int) -> float:
    """RMS of (old - new) along every eq. 1 cut that synthesize(blend="cut") makes,
    divided by the output's typical neighbour difference: the same measure as the
    paper M-II's step along its cut."""
    import texcad.synthesis.quilt as syn

    found: list[float] = []
    original = syn._min_error_paths

    def recording(errs, starts, work=None):  # noqa: ANN001, ANN202
        paths = original(errs, starts, work)
        for e, p in zip(errs, paths):
            found.append(float(np.mean(e[np.arange(len(p)), p])))
        return paths

    syn._min_error_paths = recording
    try:
        out = synthesize(sample, shape, patch=PATCH, overlap=OVERLAP, blend="cut", seed=seed)
    finally:
        syn._min_error_paths = original
    typical = np.sqrt(np.mean(np.diff(out.heights.astype(float), axis=1) ** 2))
    return float(np.sqrt(np.mean(found)) / typical)


def column_jumps(h: np.ndarray) -> np.ndarray:
    """``(cols,)`` RMS jump across the boundary after each column of the tiled texture
    (the last is the wrap), divided by the typical neighbour difference."""
    h = h.astype(float)
    t = np.concatenate([h, h[:, :1]], axis=1)
    j = np.sqrt(np.mean(np.diff(t, axis=1) ** 2, axis=0))
    return j / np.sqrt(np.mean(np.diff(h, axis=1) ** 2))


if __name__ == "__main__":
    main()
