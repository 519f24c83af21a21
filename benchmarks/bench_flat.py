"""Benchmark: the paper's flat sample, 800 x 800 px heightmap over 100 x 100 mm,
to fused solid to binary STL (issue: foundation). Targets on a 2-core machine:
<= 1.5 s total, <= 1.5 GB peak memory.

    python benchmarks/bench_flat.py [--repeat 5] [--pixels 800] [--allocator both] [--fuse union]

``--fuse stitch`` fuses the slab with :func:`texcad.solid.boolean.fuse_on_plane` (the
relief stitched into the plate's mesh, checked, no boolean: what ``textured_plate``
does with a tolerance > 0) instead of manifold3d's union (what it does with
``tolerance=0``, byte for byte as texcad 0.1). "cpu" is the process's CPU seconds
for the counted stages.

Each allocator setting runs in a fresh process (``--allocator retain``: glibc keeps
freed memory for reuse, as the ``texcad`` CLI sets it with
:func:`texcad.solid.retain_freed_memory`; ``default``: glibc's defaults, as in a
host process that calls the library). A process runs the job ``--repeat`` times;
the first run is cold (every page is new to the process), so it is shown on its
own next to the median and range of all runs. Other processes on the machine slow
every figure down: the load average is printed with them.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

STAGES = [
    ("slab", "heightmap -> slab mesh"),
    ("fuse", "fuse with base (--fuse)"),
    ("stl", "binary STL"),
    ("total", "TOTAL heightmap -> STL"),
    ("cpu", "CPU seconds of the TOTAL"),
    ("texture", "texture (not counted)"),
    ("3mf", "3MF (not counted)"),
]


def run(pixels: int, out: Path, how: str = "union") -> dict[str, float]:
    """One job; seconds per stage."""
    import texcad
    from texcad.solid.boolean import fuse_on_plane

    t = {}
    t0 = time.perf_counter()
    hm = texcad.builtin("stones", size=(100, 100), pitch=100 / pixels, height=2.0)
    t1, c1 = time.perf_counter(), time.process_time()
    slab = texcad.solid.heightfield_slab(hm, depth=0.5)
    t2 = time.perf_counter()
    base = texcad.brep.shape_to_mesh(texcad.pipeline.plate_base((100, 100), 5))
    fused = texcad.solid.fuse(base, slab) if how == "union" else fuse_on_plane(base, slab.vertices, slab.faces)[0]
    t3 = time.perf_counter()
    texcad.io.write_stl(fused, out / "bench.stl")
    t4, c4 = time.perf_counter(), time.process_time()
    texcad.io.write_3mf(fused, out / "bench.3mf")
    t5 = time.perf_counter()
    t["texture"] = t1 - t0
    t["slab"] = t2 - t1
    t["fuse"] = t3 - t2
    t["stl"] = t4 - t3
    t["total"] = t4 - t1
    t["cpu"] = c4 - c1
    t["3mf"] = t5 - t4
    t["_triangles"] = fused.num_triangles
    t["_stl_mb"] = (out / "bench.stl").stat().st_size / 1e6
    return t


def child(args: argparse.Namespace) -> None:
    """Run the job ``--repeat`` times in this process; print one JSON line."""
    tuned = False
    if args.allocator == "retain":
        from texcad.solid import retain_freed_memory

        tuned = retain_freed_memory()
    import build123d  # noqa: F401  (import cost is not part of the job)

    import texcad  # noqa: F401

    with tempfile.TemporaryDirectory() as d:
        runs = [run(args.pixels, Path(d), args.fuse) for _ in range(args.repeat)]
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"runs": runs, "peak_mb": peak, "tuned": tuned}))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--pixels", type=int, default=800)
    ap.add_argument("--allocator", choices=["both", "retain", "default", "child-retain", "child-default"], default="both")
    ap.add_argument("--fuse", choices=["union", "stitch"], default="union")
    args = ap.parse_args()
    if args.allocator.startswith("child-"):
        args.allocator = args.allocator[len("child-") :]
        child(args)
        return
    settings = ["retain", "default"] if args.allocator == "both" else [args.allocator]
    load0 = os.getloadavg()[0]
    results = {}
    for s in settings:
        cmd = [sys.executable, __file__, "--repeat", str(args.repeat), "--pixels", str(args.pixels), "--allocator", f"child-{s}", "--fuse", args.fuse]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
        results[s] = json.loads(out.strip().splitlines()[-1])
    load1 = os.getloadavg()[0]
    first = next(iter(results.values()))["runs"][0]
    print(
        f"flat plate {args.pixels} x {args.pixels} px, 100 x 100 mm: {first['_triangles']} triangles, "
        f"STL {first['_stl_mb']:.1f} MB; fuse: {args.fuse}; {os.cpu_count()} cores, load average {load0:.2f} -> {load1:.2f}"
    )
    for s, res in results.items():
        label = "glibc keeps freed memory (as the CLI)" if s == "retain" else "glibc defaults (library in a host process)"
        if s == "retain" and not res["tuned"]:
            label = "retain requested, but the C library is not glibc: defaults"
        runs = res["runs"]
        print(f"allocator: {label}; {len(runs)} runs in one process")
        print(f"  {'stage':32s} {'first':>7s} {'median':>7s}  range")
        for key, name in STAGES:
            vals = [r[key] for r in runs]
            print(f"  {name:32s} {vals[0]:7.3f} {statistics.median(vals):7.3f}  {min(vals):.3f}-{max(vals):.3f} s")
        print(f"  {'peak memory (max RSS)':32s} {res['peak_mb']:7.0f} MB")


if __name__ == "__main__":
    main()
