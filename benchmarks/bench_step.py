"""Benchmark: STEP (B-rep), STL and 3MF of a textured 100 x 100 mm plate face at
800 x 800 px (issue 6). Prints median seconds per stage, file sizes and peak memory.
Targets on a 2-core machine: STEP export <= 10 s and <= 80 MB.

The plate is textured with ``texcad.texture(plate, top_face, ...)`` (planar face: the
texture's B-spline surface replaces the face in place, no OCCT boolean); "STEP export"
is building that B-rep face plus writing the file, the part a STEP adds to the job.

    python benchmarks/bench_step.py [--repeat 3] [--pixels 800] [--cylinder]

``--cylinder`` also times a 30 mm x 60 mm cylinder's side face at the same pitch
(mapped texture, OCCT boolean of the slab with the base).
"""

from __future__ import annotations

import argparse
import resource
import statistics
import tempfile
import time
import warnings
from pathlib import Path

import texcad
from texcad.solid import brep


def run_plate(pixels: int, out: Path) -> dict[str, float]:
    from build123d import Axis

    t: dict[str, float] = {}
    pitch = 100.0 / pixels
    plate = texcad.pipeline.plate_base((100, 100), 5)
    top = plate.faces().sort_by(Axis.Z)[-1]
    t0 = time.perf_counter()
    mesh_only = texcad.texture(plate, top, "builtin:stones", height=2.0, pitch=pitch, brep=False)
    t1 = time.perf_counter()
    part = texcad.texture(plate, top, "builtin:stones", height=2.0, pitch=pitch)
    t2 = time.perf_counter()
    part.export_step(out / "bench.step")
    t3 = time.perf_counter()
    part.export_stl(out / "bench.stl")
    t4 = time.perf_counter()
    part.export_3mf(out / "bench.3mf")
    t5 = time.perf_counter()
    shape = texcad.io.read_step(out / "bench.step")
    t6 = time.perf_counter()
    chk = brep.check_shape(shape)
    vol_step = brep.volume(shape)
    t["texture(), mesh only (brep=False)"] = t1 - t0
    t["texture(), mesh + B-rep + checks"] = t2 - t1
    t["write STEP"] = t3 - t2
    t["STEP export (B-rep part + write)"] = (t2 - t1) - (t1 - t0) + (t3 - t2)
    t["write STL"] = t4 - t3
    t["write 3MF"] = t5 - t4
    t["read STEP back (not counted)"] = t6 - t5
    t["_grid"] = part.info["grid"]
    t["_triangles"] = mesh_only.mesh.num_triangles
    t["_step_mb"] = (out / "bench.step").stat().st_size / 1e6
    t["_stl_mb"] = (out / "bench.stl").stat().st_size / 1e6
    t["_3mf_mb"] = (out / "bench.3mf").stat().st_size / 1e6
    t["_valid"] = chk["valid"] and chk["solids"] == 1
    t["_dvol"] = abs(vol_step - part.mesh.volume) / part.mesh.volume
    return t


def run_cylinder(pixels: int, out: Path) -> dict[str, float]:
    from build123d import Cylinder, GeomType

    cyl = Cylinder(15, 60)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        part = texcad.texture(cyl, side, "builtin:stones", height=1.0, pitch=100.0 / pixels)
    t1 = time.perf_counter()
    part.export_step(out / "cyl.step")
    t2 = time.perf_counter()
    return {
        "cylinder texture() with B-rep": t1 - t0,
        "cylinder write STEP": t2 - t1,
        "_grid": part.info["grid"],
        "_step_mb": (out / "cyl.step").stat().st_size / 1e6,
    }


def _print(title: str, runs: list[dict]) -> None:
    print(title)
    for key in runs[0]:
        if not key.startswith("_"):
            print(f"  {key:36s} median {statistics.median(r[key] for r in runs):7.3f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--pixels", type=int, default=800)
    ap.add_argument("--cylinder", action="store_true", help="also time a textured cylinder face")
    args = ap.parse_args()
    import build123d  # noqa: F401  (import cost is not part of the job)

    with tempfile.TemporaryDirectory() as d:
        runs = [run_plate(args.pixels, Path(d)) for _ in range(args.repeat)]
        r = runs[0]
        _print(
            f"plate 100 x 100 mm, {args.pixels} x {args.pixels} px (grid {r['_grid'][0]} x {r['_grid'][1]}), "
            f"{r['_triangles']} triangles",
            runs,
        )
        print(f"  sizes: STEP {r['_step_mb']:.1f} MB, STL {r['_stl_mb']:.1f} MB, 3MF {r['_3mf_mb']:.1f} MB")
        print(f"  STEP re-imports as one valid solid: {r['_valid']}, |V_step - V_stl| / V_stl = {r['_dvol']:.2e}")
        if args.cylinder:
            cruns = [run_cylinder(args.pixels, Path(d)) for _ in range(args.repeat)]
            _print(
                f"cylinder r 15 x 60 mm side face at {100 / args.pixels:g} mm pitch (grid {cruns[0]['_grid']}), "
                f"STEP {cruns[0]['_step_mb']:.1f} MB",
                cruns,
            )
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"  peak memory (max RSS)                {peak:7.0f} MB")


if __name__ == "__main__":
    main()
