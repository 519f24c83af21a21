"""Time the slope limiter on the demo texture and ``texcad check`` on the demo plate (100 x 100 mm, pitch 0.125 mm: 800 x 800 px,
about 1.3 million triangles), as STL and as a texcad 3MF (base + texture objects).

Prints median wall seconds per stage (reading the file; the whole check, its read
included) with the CPU seconds of both threads beside them (the 3MF is inflated on
a second thread while it is parsed, and the measures run on two), the load average,
and peak memory. Usage:

    python benchmarks/bench_check.py [--pitch 0.125] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import tempfile
import time
from pathlib import Path

import texcad
from texcad.report import check
from texcad.io import read_part
from texcad.io import write_3mf, write_stl


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pitch", type=float, default=0.125)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    t = time.perf_counter()
    part = texcad.pipeline.textured_plate("builtin:stones", size=(100, 100), pitch=args.pitch)
    print(f"demo plate   {part.mesh.num_triangles} triangles, built in {time.perf_counter() - t:.1f} s")
    with tempfile.TemporaryDirectory() as tmp:
        stl, tmf = Path(tmp) / "demo.stl", Path(tmp) / "demo.3mf"
        write_stl(part.mesh, stl)
        write_3mf([("base", part.base_mesh), ("texture", part.texture_mesh)], tmf)
        for label, path, extra in (
            ("stl", stl, {}),
            ("3mf", tmf, {}),
            ("3mf tilted 60", tmf, {"build_dir": texcad.printability.orientation(60, "+y")}),
            ("3mf + png", tmf, {"png": Path(tmp) / "c.png"}),
        ):
            reads, totals = [], []
            for _ in range(args.repeat):
                t0, c0 = time.perf_counter(), time.process_time()
                read_part(path)
                t1, c1 = time.perf_counter(), time.process_time()
                rep = check(path, **extra)
                t2, c2 = time.perf_counter(), time.process_time()
                reads.append((t1 - t0, c1 - c0))
                totals.append((t2 - t1, c2 - c1))
            tex = rep.texture_overhang_area_mm2
            r, c = _median(reads), _median(totals)
            print(
                f"{label:14s} read {r[0]:6.2f} s (CPU {r[1]:5.2f})   check (incl. read) {c[0]:6.2f} s (CPU {c[1]:5.2f})"
                f"   overhang {rep.overhang_area_mm2:9.2f} mm2   texture {'-' if tex is None else f'{tex:.2f}'} mm2"
            )
    from texcad.printability import limit_overhangs, orientation

    hm = part.heightmap
    for label, dirs in (
        ("upright +y", orientation(90, "+y")),
        ("tilt 80, azimuth 30", orientation(80, 30.0)),
        ("set 0..90 +y", [orientation(a, "+y") for a in (0, 15, 30, 45, 60, 75, 90)]),
    ):
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            _, rep = limit_overhangs(hm, dirs)
            times.append(time.perf_counter() - t0)
        print(
            f"limit_overhangs {hm.shape[1]} x {hm.shape[0]} px, {label:20s} {statistics.median(times):6.2f} s"
            f"   removed {rep.removed_volume_mm3:8.1f} mm3 (max {rep.max_removed_mm:.2f} mm)"
        )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory  {peak:.0f} MB")
    print(f"load         {os.getloadavg()[0]:.2f} (1-min load average, {os.cpu_count()} CPUs)")


def _median(runs: list[tuple[float, float]]) -> tuple[float, float]:
    """Median wall and CPU seconds of ``(wall, cpu)`` runs."""
    return statistics.median(w for w, _ in runs), statistics.median(c for _, c in runs)


if __name__ == "__main__":
    main()
