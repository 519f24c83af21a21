"""Benchmark: lean meshes (texcad.solid.lean, issue 15). For the demo plate (800 x 800 px
of stones grown by synthesis from a 25 mm sample, as ``texcad demo`` makes it, on a
100 x 100 mm plate) and for built-ins on the same plate: triangles, measured maximum
height error at every pixel centre, seconds texture-to-STL and STL size in MB, for
tolerance 0 (one vertex per pixel) and the default tolerance; and pydelatin's own
triangle count for the same heightmap at the same error.

    python benchmarks/bench_lean.py [--repeat 3] [--tolerance 0.02] [--builtins stones,pins]
    python benchmarks/bench_lean.py --curved [--builtins stones,diamond_knurl]
    python benchmarks/bench_lean.py --stages [--repeat 5]
    python benchmarks/bench_lean.py --samples [--pitch 0.125]

``--stages``: the demo plate's texture-to-STL path stage by stage (wall and CPU
seconds, medians), as texcad runs it (the relief stitched into the plate's mesh,
:func:`texcad.solid.boolean.fuse_on_plane`) and with manifold3d's union instead (the
path before, still the fallback): each stage is timed where the pipeline calls it.

``--samples``: the paper's nine samples (recipes/paper_samples.py, with their build
directions) and the sledgehammer's grip (recipes/sledgehammer.py, 0.25 mm), each at
tolerance 0 and the default: triangles, measured maximum error, seconds (wall and
CPU) and STL MB. Meshes only (``brep=False``), no STEP.

``--curved``: the same figures on curved surfaces instead: a 2.5D cylinder
(``Surface.cylinder(20, 60)``, angle mapping) and a 40 x 60 mm sine
(``Surface.sine``, distance mapping), the error measured in 3-D
(:func:`texcad.solid.grid_distance`).

Targets (issue 15, demo plate, default tolerance): triangles no more than
pydelatin's at the same error, texture-to-STL <= 0.6 s, STL <= 1/3 of the
one-vertex-per-pixel STL. Seconds are the median of ``--repeat`` runs in one
process (after one warm-up), with glibc's allocator told to keep freed memory
(:func:`texcad.solid.retain_freed_memory`, as the CLI does). "texture-to-STL" is
``texcad.texture(..., brep=False)`` plus ``write_stl``; measuring the error
(``Textured.max_error``) is timed on its own. Other processes slow every figure:
the load average is printed with them.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def demo_heightmap(pitch: float = 0.125, side: float = 100.0):
    """The demo's texture: a 25 mm sample of builtin:stones grown to the plate
    (texcad/cli/demo.py, seed 0)."""
    from texcad import builtin, synthesize

    sample = builtin("stones", size=(25.0, 25.0), pitch=pitch, height=2.0)
    px = round(side / pitch)
    patch = min(45, px, *sample.shape)
    return synthesize(sample, (px, px), patch=patch, overlap=max(1, patch * 5 // 9), seed=0)


def one(plate, face, hm, tol: float, out: Path, repeat: int) -> dict:
    from texcad import texture
    from texcad.io import write_stl

    secs, cpus = [], []
    for _ in range(repeat + 1):  # first run warms up
        t0, c0 = time.perf_counter(), time.process_time()
        part = texture(plate, face, hm, brep=False, tolerance=tol)
        write_stl(part.mesh, out)
        secs.append(time.perf_counter() - t0)
        cpus.append(time.process_time() - c0)
    t0 = time.perf_counter()
    err = part.max_error
    t_err = time.perf_counter() - t0
    return {
        "triangles": part.mesh.num_triangles,
        "max_error": err,
        "seconds": statistics.median(secs[1:]) if repeat else secs[0],
        "cpu": statistics.median(cpus[1:]) if repeat else cpus[0],
        "range": (min(secs[1:] or secs), max(secs[1:] or secs)),
        "error_seconds": t_err,
        "MB": out.stat().st_size / 1e6,
        "info": part.info,
    }


def curved(args) -> None:
    import warnings

    from texcad import texture
    from texcad.io import write_stl
    from texcad.mapping import Surface

    surfaces = [("cylinder R20", Surface.cylinder(20.0, 60.0, 5.0), "angle"),
                ("sine 40 mm", Surface.sine(length=60.0, thickness=5.0, amplitude=5.0, period=40.0, width=40.0), "distance")]
    print(f"{'surface':14s} {'texture':16s} {'tol mm':>6s} {'triangles':>10s} {'max err mm':>10s} {'s tex->STL':>10s} {'cpu s':>6s} {'STL MB':>7s}")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "part.stl"
        for label, surf, mapping in surfaces:  # one per surface
            for name in [n for n in args.builtins.split(",") if n]:
                for tol in (0.0, args.tolerance):
                    secs, cpus = [], []
                    for _ in range(args.repeat + 1):  # first run warms up
                        t0, c0 = time.perf_counter(), time.process_time()
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            part = texture(surf, None, f"builtin:{name}", height=1.0, pitch=args.pitch, mapping=mapping, tolerance=tol)
                        write_stl(part.mesh, out)
                        secs.append(time.perf_counter() - t0)
                        cpus.append(time.process_time() - c0)
                    sec = statistics.median(secs[1:]) if args.repeat else secs[0]
                    cpu = statistics.median(cpus[1:]) if args.repeat else cpus[0]
                    print(f"{label:14s} {name:16s} {tol:6.3f} {part.mesh.num_triangles:10d} {part.max_error:10.4f} "
                          f"{sec:10.2f} {cpu:6.2f} {out.stat().st_size / 1e6:7.1f}", flush=True)


def _timed(module, name: str, label: str, log: dict):
    """Wrap ``module.name`` so that each call adds its wall and CPU seconds to
    ``log[label]``; returns a function that restores it."""
    orig = getattr(module, name)

    def wrapper(*a, **k):
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            return orig(*a, **k)
        finally:
            w, c = log.get(label, (0.0, 0.0))
            log[label] = (w + time.perf_counter() - t0, c + time.process_time() - c0)

    setattr(module, name, wrapper)
    return lambda: setattr(module, name, orig)


def stages(args) -> None:
    """The demo plate's path stage by stage, stitched and with manifold3d's union."""
    import pydelatin
    from build123d import Axis

    import texcad.targets.plane as cad  # the planar-face adapter: where the slab is made and fused
    import texcad.solid.lean as lean
    from texcad import texture
    from texcad.errors import GeometryError
    from texcad.io import write_stl
    from texcad.pipeline import plate_base
    from texcad.solid import retain_freed_memory

    retain_freed_memory()
    plate = plate_base((100.0, 100.0), 5.0)
    face = plate.faces().sort_by(Axis.Z)[-1]
    hm = demo_heightmap(args.pitch)
    hooks = [(pydelatin, "Delatin", "greedy insertion (pydelatin)"), (lean, "triangulate", "lean top, pydelatin included"),
             (cad, "heightfield_slab", "slab, lean top included"), (cad, "fuse_on_plane", "stitch with its checks"),
             (cad, "to_manifold", "manifold3d: build the meshes"), (cad, "fuse", "manifold3d: trim + union")]
    print(f"load average before: {load()}   (2-core machine; figures are noisy under load)")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "demo.stl"
        for how in ("stitched", "manifold3d union"):
            runs = []
            for k in range(args.repeat + 1):  # the first run warms up
                log: dict = {}
                undo = [_timed(m, n, label, log) for m, n, label in hooks]
                if how != "stitched":
                    undo.append(_timed(cad, "fuse_on_plane", "stitch with its checks", log))
                    cad.fuse_on_plane = lambda *a, **kw: (_ for _ in ()).throw(GeometryError("benchmark: union"))
                try:
                    t0, c0 = time.perf_counter(), time.process_time()
                    part = texture(plate, face, hm, brep=False, tolerance=args.tolerance)
                    log["texture (all stages)"] = (time.perf_counter() - t0, time.process_time() - c0)
                    t1, c1 = time.perf_counter(), time.process_time()
                    write_stl(part.mesh, out)
                    log["STL writer"] = (time.perf_counter() - t1, time.process_time() - c1)
                    log["texture-to-STL"] = (time.perf_counter() - t0, time.process_time() - c0)
                finally:
                    for u in reversed(undo):
                        u()
                if k:
                    runs.append(log)
            print(f"\n{how}: {part.mesh.num_triangles} triangles ({part.info['fuse'][:40]}), median of {len(runs)}, wall / CPU s")
            for label in runs[0]:
                w = statistics.median(r[label][0] for r in runs)
                c = statistics.median(r[label][1] for r in runs)
                print(f"  {label:32s} {w:6.3f} / {c:6.3f}")
    print(f"load average after: {load()}")


def samples(args) -> None:
    """The paper's nine samples and the sledgehammer's grip at tolerance 0 and the default."""
    import importlib.util
    import warnings

    import texcad
    from texcad.io import write_stl
    from texcad.solid import retain_freed_memory

    retain_freed_memory()
    os.environ["TEXCAD_PITCH"] = str(args.pitch)
    spec = importlib.util.spec_from_file_location("paper_samples", Path(__file__).resolve().parents[1] / "recipes" / "paper_samples.py")
    ps = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(ps)
    jobs = []
    for tex, kind, tilt in ps.TABLE2:  # one per sample
        build, mapping, toward = ps.SAMPLES[kind]
        jobs.append((f"{tex}-{kind}", lambda b=build, t=tex, m=mapping, d=texcad.orientation(tilt, toward): (*_sample(ps, b, t), dict(mapping=m, build_dir=d))))
    jobs.append(("sledgehammer grip", _sledgehammer))
    print(f"load average before: {load()}   (2-core machine; figures are noisy under load)")
    print(f"{'part':18s} {'tol mm':>6s} {'triangles':>10s} {'max err mm':>10s} {'wall s':>7s} {'CPU s':>6s} {'STL MB':>7s}")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "part.stl"
        for label, make in jobs:
            part, face, hm, opts = make()
            for tol in (0.0, args.tolerance):
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    t0, c0 = time.perf_counter(), time.process_time()
                    res = texcad.texture(part, face, hm, brep=False, tolerance=tol, **opts)
                    write_stl(res.mesh, out)
                    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
                print(f"{label:18s} {tol:6.3f} {res.mesh.num_triangles:10d} {res.max_error:10.4f} {wall:7.2f} {cpu:6.2f} "
                      f"{out.stat().st_size / 1e6:7.1f}", flush=True)
    print(f"load average after: {load()}")


def _sample(ps, build, tex: str):
    part, face, width = build()
    return part, face, ps.synthesized(tex, width)


def _sledgehammer():
    """recipes/sledgehammer.py's handle and grip texture (0.25 mm pitch, printed upright)."""
    import numpy as np
    from build123d import Circle, Cone, GeomType, Plane, Pos, Rot, SortBy, extrude

    import texcad

    R, GRIP, PITCH = 16.0, 120.0, 0.25
    butt = Pos(0, -3, 0) * (Rot(-90, 0, 0) * Cone(R + 3, R, 6))
    grip_body = extrude(Plane.XZ * Circle(R), amount=-GRIP)
    collar = Pos(0, GRIP + 1, 0) * (Rot(-90, 0, 0) * Cone(R, R - 2, 2))
    neck = Pos(0, GRIP + 2, 0) * extrude(Plane.XZ * Circle(R - 2), amount=-130)
    handle = butt + grip_body + collar + neck
    face = handle.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1]
    n = 2 * round(np.pi * R / PITCH)
    sample = texcad.builtin("stones", size=(25, 25), pitch=PITCH, height=1.0)
    patch = min(45, *sample.shape)
    grown = texcad.synthesize(sample, (round(GRIP / PITCH), n), patch=patch, overlap=patch * 5 // 9, seed=0, wrap="x")
    hm = texcad.Heightmap(grown.heights, (2 * np.pi * R / n, PITCH))
    return handle, face, hm, dict(mapping="angle", periodic_x=True, build_dir=(0, 1, 0))


def delatin_count(heights, err: float) -> tuple[int, float]:
    from pydelatin import Delatin

    t0 = time.perf_counter()
    d = Delatin(heights.astype("float32"), max_error=err)
    return len(d.triangles), time.perf_counter() - t0


def main() -> None:
    from texcad.solid import DEFAULT_TOLERANCE

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tolerance", type=float, default=DEFAULT_TOLERANCE)
    ap.add_argument("--builtins", default="stones,diamond_knurl,pins,leather,sand")
    ap.add_argument("--pitch", type=float, default=0.125)
    ap.add_argument("--curved", action="store_true", help="curved surfaces instead of the plate")
    ap.add_argument("--stages", action="store_true", help="the demo plate's path stage by stage")
    ap.add_argument("--samples", action="store_true", help="the paper's nine samples and the sledgehammer")
    args = ap.parse_args()
    if args.stages:
        return stages(args)
    if args.samples:
        return samples(args)
    if args.curved:
        print(f"load average before: {load()}   (2-core machine; figures are noisy under load)")
        curved(args)
        print(f"load average after: {load()}")
        return

    from build123d import Axis

    from texcad import builtin
    from texcad.pipeline import plate_base
    from texcad.solid import retain_freed_memory

    retain_freed_memory()
    plate = plate_base((100.0, 100.0), 5.0)
    face = plate.faces().sort_by(Axis.Z)[-1]
    jobs = [("demo (stones, grown)", demo_heightmap(args.pitch))]
    for name in [n for n in args.builtins.split(",") if n]:
        jobs.append((f"builtin:{name}", builtin(name, size=(100.0, 100.0), pitch=args.pitch, height=2.0)))
    print(f"load average before: {load()}   (2-core machine; figures are noisy under load)")
    print(
        f"{'texture':22s} {'tol mm':>6s} {'triangles':>10s} {'max err mm':>10s} {'s tex->STL':>10s} "
        f"{'range':>11s} {'cpu s':>6s} {'s err':>6s} {'STL MB':>7s} {'pydelatin':>9s} {'s delatin':>9s}"
    )
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "part.stl"
        for label, hm in jobs:
            rows = []
            for tol in (0.0, args.tolerance):
                r = one(plate, face, hm, tol, out, args.repeat)
                rows.append(r)
                dl = ds = ""
                if tol > 0 and r["max_error"] > 0:  # (0: the grid was kept, MAX_FRACTION)
                    # pydelatin alone on the texture itself, at the error texcad measured
                    n_dl, s_dl = delatin_count(hm.heights, max(r["max_error"], 1e-6))
                    dl, ds = f"{n_dl:9d}", f"{s_dl:9.2f}"
                lo, hi = r["range"]
                print(
                    f"{label:22s} {tol:6.3f} {r['triangles']:10d} {r['max_error']:10.4f} {r['seconds']:10.2f} "
                    f"{lo:5.2f}-{hi:5.2f} {r['cpu']:6.2f} {r['error_seconds']:6.2f} {r['MB']:7.1f} {dl:>9s} {ds:>9s}"
                )
            d, lean_r = rows
            print(
                f"{'':22s} lean/grid: triangles {lean_r['triangles'] / d['triangles']:.3f}, "
                f"STL {lean_r['MB'] / d['MB']:.3f}, seconds {lean_r['seconds'] / d['seconds']:.2f}"
            )
    print(f"load average after: {load()}")


if __name__ == "__main__":
    main()
