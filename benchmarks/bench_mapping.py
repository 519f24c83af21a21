"""Benchmark: texture mapping onto 2.5D surfaces (issue 4). Prints median seconds.

1. Mapping an 800 x 800 px heightmap (0.125 mm) onto a build123d spline profile
   (~108 mm of arc length), both mappings: the profile is sampled once through OCCT
   (not counted in the mapping), then map_texture builds the top and bottom grids.
   Target: <= 0.1 s (>= 6.4 M vertices/s).
2. The whole make-to-STL job for a cylinder of 20 mm radius, 100 mm long (5 mm wall),
   stones texture 2 mm high at 0.125 mm pitch (fitted to 5 whole tiles around), per
   stage, and the same job through texcad.texture + write_stl as `texcad make`
   runs it.

    python benchmarks/bench_mapping.py [--repeat 5] [--pitch 0.125]
    python benchmarks/bench_mapping.py --quick --table   # 1. only (seconds); writes docs/benchmarks/mapping.md
"""

from __future__ import annotations

import argparse
import resource
import sys
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import texcad
from texcad.mapping import fit_texture, map_texture
from texcad.mapping import Profile, Surface

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _table import write_table  # noqa: E402


def bench_spline(repeat: int) -> list:
    """Prints the figures; returns table rows (job, median s, M vertices/s)."""
    from build123d import Spline

    spline = Spline((0, 0), (25, 6), (50, -4), (75, 5), (100, 0))
    t0 = time.perf_counter()
    prof = Profile.from_cad(spline)
    t_prof = time.perf_counter() - t0
    hm = texcad.builtin("stones", size=(100, 100), pitch=0.125, height=2.0)
    hm = texcad.Heightmap(hm.heights[:800, :800], hm.pitch)
    nverts = hm.shape[0] * hm.shape[1]
    print(f"spline profile {prof.length:.1f} mm, heightmap {hm.shape[1]} x {hm.shape[0]} px ({nverts} top vertices)")
    print(f"  {'profile from build123d (OCCT, once)':40s} {t_prof:6.3f} s")
    rows = [["profile from build123d (OCCT, once)", t_prof, "-"]]
    for mode in ("distance", "angle"):
        fresh = Profile.from_cad(spline)  # first call: also finds the function pieces (cached after)
        t0 = time.perf_counter()
        map_texture(fresh, hm, mapping=mode, length=100.0)
        first = time.perf_counter() - t0
        print(f"  {'map_texture ' + mode + ' (first call)':40s} {first:6.3f} s  ({nverts / first / 1e6:.1f} M vertices/s)")
        ts, tsol = [], []
        for _ in range(repeat):
            t0 = time.perf_counter()
            ms = map_texture(prof, hm, mapping=mode, length=100.0)
            t1 = time.perf_counter()
            ms.solid()
            t2 = time.perf_counter()
            ts.append(t1 - t0)
            tsol.append(t2 - t1)
        med = statistics.median(ts)
        print(f"  {'map_texture ' + mode:40s} {med:6.3f} s  ({nverts / med / 1e6:.1f} M vertices/s)")
        print(f"  {'  + close slab (' + mode + ')':40s} {statistics.median(tsol):6.3f} s")
        rows += [[f"map_texture, {mode} (first call)", first, nverts / first / 1e6],
                 [f"map_texture, {mode} (median of {repeat})", med, nverts / med / 1e6],
                 [f"close the slab, {mode} (median of {repeat})", statistics.median(tsol), "-"]]
    return rows


def bench_cylinder(repeat: int, pitch: float, out: Path) -> None:
    runs = []
    for _ in range(repeat):
        t = {}
        t0 = time.perf_counter()
        surf = Surface.cylinder(20.0, 100.0, 5.0)
        t1 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the tile-fit warning (stones scaled by 4.7 %)
            hm, periodic = fit_texture(surf.profile, "builtin:stones", length=100.0, pitch=pitch, height=2.0)
        t2 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ms = map_texture(surf.profile, hm, mapping="angle", length=100.0, depth=0.5, periodic_x=periodic)
        t3 = time.perf_counter()
        slab = ms.solid()
        t4 = time.perf_counter()
        base = texcad.brep.shape_to_mesh(surf.base)
        t5 = time.perf_counter()
        fused = texcad.solid.fuse(base, slab)
        t6 = time.perf_counter()
        texcad.io.write_stl(fused, out / "cylinder.stl")
        t7 = time.perf_counter()
        t["surface (build123d tube + profile)"] = t1 - t0
        t["texture (not counted)"] = t2 - t1
        t["map_texture (angle, analysis + grids)"] = t3 - t2
        t["close slab"] = t4 - t3
        t["base to mesh"] = t5 - t4
        t["fuse (manifold3d)"] = t6 - t5
        t["binary STL"] = t7 - t6
        t["TOTAL make -> STL"] = (t7 - t0) - (t2 - t1)
        t["_grid"] = ms.top.shape
        t["_tris"] = fused.num_triangles
        t["_mb"] = (out / "cylinder.stl").stat().st_size / 1e6
        runs.append(t)
    ends = []
    for _ in range(repeat):  # the same job through the public API, as `texcad make` runs it
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            part = texcad.texture(
                Surface.cylinder(20.0, 100.0, 5.0), None, "builtin:stones", height=2.0, mapping="angle", pitch=pitch
            )
        texcad.io.write_stl(part.mesh, out / "cylinder_api.stl")
        ends.append(time.perf_counter() - t0)
    r0 = runs[0]
    print(
        f"cylinder R 20 x 100 mm, stones 2 mm at {pitch:g} mm: grid {r0['_grid'][1]} x {r0['_grid'][0]}, "
        f"{r0['_tris']} triangles, STL {r0['_mb']:.1f} MB"
    )
    for key in r0:
        if not key.startswith("_"):
            print(f"  {key:40s} {statistics.median(r[key] for r in runs):6.3f} s")
    print(f"  {'texcad.texture + write_stl (make)':40s} {statistics.median(ends):6.3f} s  (incl. texture synthesis)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--pitch", type=float, default=0.125)
    ap.add_argument("--quick", action="store_true", help="only the spline mapping (seconds, not the cylinder job)")
    ap.add_argument("--table", action="store_true", help="write the spline table to docs/benchmarks/mapping.md")
    args = ap.parse_args()
    import build123d  # noqa: F401  (import cost is not part of the job)

    rows = bench_spline(args.repeat)
    if args.table:
        path = write_table(
            "mapping", ["job", "wall s", "M vertices/s"], rows,
            title="Mapping an 800 x 800 px texture onto a build123d spline (108 mm of arc length)",
            notes="map_texture builds the top and bottom grids of the textured slab; the profile "
            "is sampled once through OCCT first (not part of the mapping). Target: at most 0.1 s.")
        print(f"table written to {path}")
    if args.quick:
        return
    with tempfile.TemporaryDirectory() as d:
        bench_cylinder(args.repeat, args.pitch, Path(d))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  {'peak memory (max RSS)':40s} {peak:6.0f} MB")


if __name__ == "__main__":
    main()
