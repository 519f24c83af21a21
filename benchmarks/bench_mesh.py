"""Time texturing a mesh: a 100 k-triangle input part (a dome-topped cylinder, r 36
mm, 52 mm + the dome: 19 900 mm2 besides its bed face, written as an STL like a
downloaded part: long slivers on the side, a fine dome) textured everywhere but the
bed face with the default stones (4 mm cells, 1 mm high) in a triplanar projection at a 0.2 mm pitch (longest
edge), at the default tolerance (0.02 mm, adaptive subdivision; ``--tolerance 0``: the
uniform pitch grid), with the overhang limiter for +z, written as a 3MF and checked.

Prints seconds per stage (read + repair, subdivide, sample + displace + limit + the
manifold3d check, write 3MF, texcad.check of the 3MF), triangle counts, and peak
memory (resident set size). ``--allocator retain`` (the default) lets glibc keep
freed memory for reuse, as the ``texcad`` CLI does
(:func:`texcad.solid.retain_freed_memory`); ``default`` keeps glibc's defaults, as in
a host process that calls the library. Usage:

    python benchmarks/bench_mesh.py [--pitch 0.2] [--segments 624] [--tolerance 0.02] [--allocator retain]
    python benchmarks/bench_mesh.py --table --against /tmp/base0d4 [--rounds 2]

``--against DIR``: a checkout of another commit (``git worktree add DIR REV``); the
same job runs ``--rounds`` times in each, alternately, each in a fresh process, and the
texture stage's median CPU seconds of both are printed (and noted under the table).
On a shared machine CPU seconds vary by 2x with the load, so only runs made side by
side compare.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import manifold3d as m3d
import numpy as np

import texcad
from texcad.io import write_stl
from texcad.solid import Mesh


def stages(progress_log: list):
    """A progress callback that records when each stage starts."""
    def cb(fraction: float, message: str) -> None:
        progress_log.append((time.perf_counter(), time.process_time(), message))

    return cb


def bench_part(n: int = 624) -> Mesh:
    """The input part: a cylinder (r 36 mm, 52 mm high, ``n`` sides) with a dome on top,
    as manifold3d tessellates them (long strips on the side, a fine dome)."""
    dome = m3d.Manifold.sphere(36.0, n).translate((0, 0, 52.0)) ^ m3d.Manifold.cube((80, 80, 40)).translate((-40, -40, 52.0))
    g = (m3d.Manifold.cylinder(52.0, 36.0, 36.0, n) + dome).to_mesh()
    return Mesh(np.asarray(g.vert_properties)[:, :3], np.asarray(g.tri_verts))


def _texture_cpu(checkout: Path, args) -> float:
    """The texture stage's CPU seconds of one run of this script as it is in
    ``checkout`` (a fresh process with that checkout's texcad), same job."""
    env = dict(os.environ, PYTHONPATH=str(checkout))
    cmd = [sys.executable, str(checkout / "benchmarks" / "bench_mesh.py"), "--pitch", str(args.pitch), "--segments",
           str(args.segments), "--texture", args.texture, "--tolerance", str(args.tolerance), "--allocator", args.allocator]
    out = subprocess.run(cmd, cwd=checkout, env=env, capture_output=True, text=True, check=True).stdout
    m = re.search(r"^texture\s+[\d.]+ s, CPU\s+([\d.]+) s", out, re.M)
    if m is None:
        raise RuntimeError(f"no texture line in the output of {checkout}: {out[-500:]}")
    return float(m.group(1))


def _compare(other: Path, args) -> str:
    """Alternate runs here and in ``other``: a sentence with both medians."""
    here = Path(__file__).resolve().parents[1]
    ours, theirs = [], []
    for _ in range(args.rounds):  # per round: one run in each checkout, alternately
        ours.append(_texture_cpu(here, args))
        theirs.append(_texture_cpu(other, args))
    rev = subprocess.run(["git", "-C", str(other), "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    a, b = statistics.median(ours), statistics.median(theirs)
    return (f"Side by side with commit {rev or other} ({args.rounds} runs each, alternated, fresh processes): texture stage "
            f"{a:.2f} CPU s here against {b:.2f} there (x {a / b:.2f}; runs {', '.join(f'{x:.2f}' for x in ours)} / "
            f"{', '.join(f'{x:.2f}' for x in theirs)}).")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pitch", type=float, default=0.2)
    ap.add_argument("--segments", type=int, default=624)
    ap.add_argument("--texture", default="builtin:stones")
    ap.add_argument("--tolerance", type=float, default=0.02, help="mm (0: the uniform pitch grid)")
    ap.add_argument("--allocator", choices=["retain", "default"], default="retain")
    ap.add_argument("--table", action="store_true", help="write the stages to docs/benchmarks/mesh.md")
    ap.add_argument("--against", type=Path, default=None, help="a checkout of another commit to compare with, side by side")
    ap.add_argument("--rounds", type=int, default=2, help="runs per checkout with --against")
    args = ap.parse_args()
    if args.allocator == "retain":
        from texcad.solid import retain_freed_memory

        retain_freed_memory()
    src = bench_part(args.segments)
    with tempfile.TemporaryDirectory() as tmp:
        stl = Path(tmp) / "part.stl"
        write_stl(src, stl)
        log: list = []
        t0, c0 = time.perf_counter(), time.process_time()
        tx = texcad.texture(stl, "not-bottom", args.texture, height=1.0, pitch=args.pitch, projection="triplanar",
                            build_dir=(0, 0, 1), tolerance=args.tolerance, progress=stages(log))
        t1, c1 = time.perf_counter(), time.process_time()
        out = Path(tmp) / "part.3mf"
        tx.export(out)
        t2, c2 = time.perf_counter(), time.process_time()
        rep = texcad.check(out, build_dir=(0, 0, 1))
        t3, c3 = time.perf_counter(), time.process_time()
        size = out.stat().st_size
    marks = [(t0, c0)] + [(t, c) for t, c, _ in log] + [(t1, c1)]
    names = [m for _, _, m in log]
    print(f"input        {src.num_triangles} triangles, {src.area:.0f} mm2 with the bed face (STL)")
    print(f"textured     {tx.mesh.num_triangles} triangles at pitch {args.pitch} mm, {args.texture}, triplanar, +z limiter, "
          f"tolerance {args.tolerance:g} mm: measured error {tx.max_error:.4f} mm")
    lim = tx.limits
    print(f"limiter      {lim.overhang_faces} facets overhanging at first; {lim.lowered} vertices lowered, {lim.zeroed} of them to 0, "
          f"{lim.removed_mm3:.0f} mm3 of relief removed")
    print("  stage (wall s / CPU s)")
    for (a, b), name in zip(zip(marks[:-1], marks[1:]), ["start"] + names):
        print(f"  {name:<24s} {b[0] - a[0]:6.2f} {b[1] - a[1]:6.2f}")
    print(f"texture      {t1 - t0:6.2f} s, CPU {c1 - c0:6.2f} s ({tx.mesh.num_triangles / (t1 - t0) / 1e6:.2f} M output triangles/s)")
    print(f"write 3mf    {t2 - t1:6.2f} s, CPU {c2 - c1:6.2f} s ({size / 1e6:.1f} MB)")
    from texcad.printability import face_areas, overhang_mask

    m = tx.mesh
    tex = np.zeros(m.num_triangles, bool)
    tex[m.groups["texture"]] = True
    over = float(face_areas(m)[overhang_mask(m, (0, 0, 1), 45.0) & tex].sum())
    print(f"check 3mf    {t3 - t2:6.2f} s, CPU {c3 - c2:6.2f} s: watertight {rep.watertight}, manifold {rep.manifold}, shells {rep.shells}, "
          f"overhang {rep.overhang_area_mm2:.2f} mm2; texture {float(face_areas(m)[tex].sum()):.0f} mm2, {over:.2f} mm2 of it overhanging")
    print(f"total        {t3 - t0:6.2f} s, CPU {c3 - c0:6.2f} s")
    print(f"peak memory  {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB (RSS)")
    print(f"load         {os.getloadavg()[0]:.1f} (1-min load average, {os.cpu_count()} CPUs); allocator: {args.allocator}, "
          f"{texcad.util.threads()} threads")
    versus = ""
    if args.against is not None:
        versus = _compare(args.against.resolve(), args)
        print(versus)
    if args.table:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from _table import write_table

        rows = [[name, f"{b[0] - a[0]:.2f}", f"{b[1] - a[1]:.2f}"] for (a, b), name in zip(zip(marks[:-1], marks[1:]), ["start"] + names)]
        rows += [["texture (all stages)", f"{t1 - t0:.2f}", f"{c1 - c0:.2f}"], ["write 3MF", f"{t2 - t1:.2f}", f"{c2 - c1:.2f}"],
                 ["texcad check of the 3MF", f"{t3 - t2:.2f}", f"{c3 - c2:.2f}"]]
        path = write_table(
            "mesh", ["stage", "wall s", "CPU s"], rows,
            title=f"Texturing a {src.num_triangles:,}-triangle STL everywhere but its bed face ({tx.mesh.num_triangles:,} triangles out)",
            notes=f"builtin:stones, triplanar projection, pitch {args.pitch} mm, tolerance {args.tolerance:g} mm, limited for +z "
            f"at 45 degrees (the slicers' margin); measured error {tx.max_error:.4f} mm; peak memory "
            f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB; load average {os.getloadavg()[0]:.1f}. " + versus)
        print(f"table written to {path}")


if __name__ == "__main__":
    main()
