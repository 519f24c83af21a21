"""Benchmark: the paper's flat sample, 800 x 800 px heightmap over 100 x 100 mm,
to fused solid to binary STL (issue: foundation). Prints median seconds per stage
and peak memory. Targets on a 2-core machine: <= 1.5 s total, <= 1.5 GB peak.

    python benchmarks/bench_flat.py [--repeat 5] [--pixels 800]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import tempfile
import time
from pathlib import Path

import texcad


def run(pixels: int, out: Path) -> dict[str, float]:
    t = {}
    t0 = time.perf_counter()
    hm = texcad.builtin("stones", size=(100, 100), pitch=100 / pixels, height=2.0)
    t1 = time.perf_counter()
    slab = texcad.heightfield_slab(hm, depth=0.5)
    t2 = time.perf_counter()
    base = texcad.shape_to_mesh(texcad.plate_base((100, 100), 5))
    fused = texcad.fuse(base, slab)
    t3 = time.perf_counter()
    texcad.write_stl(fused, out / "bench.stl")
    t4 = time.perf_counter()
    texcad.write_3mf(fused, out / "bench.3mf")
    t5 = time.perf_counter()
    t["texture (not counted)"] = t1 - t0
    t["heightmap -> slab mesh"] = t2 - t1
    t["fuse with base (manifold3d)"] = t3 - t2
    t["binary STL"] = t4 - t3
    t["TOTAL heightmap -> STL"] = t4 - t1
    t["3MF (not counted)"] = t5 - t4
    t["_triangles"] = fused.num_triangles
    t["_stl_mb"] = (out / "bench.stl").stat().st_size / 1e6
    return t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--pixels", type=int, default=800)
    args = ap.parse_args()
    import build123d  # noqa: F401  (import cost is not part of the job)

    with tempfile.TemporaryDirectory() as d:
        runs = [run(args.pixels, Path(d)) for _ in range(args.repeat)]
    print(f"flat plate {args.pixels} x {args.pixels} px, 100 x 100 mm, {runs[0]['_triangles']} triangles, STL {runs[0]['_stl_mb']:.1f} MB")
    for key in runs[0]:
        if key.startswith("_"):
            continue
        print(f"  {key:32s} median {statistics.median(r[key] for r in runs):6.3f} s")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  peak memory (max RSS)            {peak:6.0f} MB")


if __name__ == "__main__":
    main()
