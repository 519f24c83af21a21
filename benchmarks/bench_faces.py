"""Benchmark: the knob's knurled grip (a cone, any-face method; the knob of
recipes/knob.py at twice its size: about 1 M relief triangles) at 0.125 mm to a
fused, checked binary STL, seconds per stage (issue 13; target 3 s on 2 cores).

    python benchmarks/bench_faces.py [--pitch 0.125] [--repeat 3] [--scale 2]

Stages: tessellate (OCCT, the part's welded, checked mesh), parameterize (the face's
(u, v) by arc length, whole tiles around), map (texture grid on the face, heights,
M-I ramp, curvature limit, slab), fuse (manifold3d union, welded and checked: every
edge on two triangles), export (binary STL). The load average is printed with them:
other processes on the machine slow every figure down.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))


def knob(scale: float = 1.0):
    from build123d import Axis, BuildLine, BuildPart, BuildSketch, Plane, Polyline, make_face, revolve

    with BuildPart() as k:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                pts = [(3, 0), (15, 0), (15, 2), (12.5, 14), (11, 15.5), (3, 15.5)]
                Polyline(*[(scale * x, scale * z) for x, z in pts], close=True)
            make_face()
        revolve(axis=Axis.Z)
    return k.part


def run(pitch: float, out: Path, scale: float, tolerance: float) -> dict:
    import manifold3d as m3d
    from build123d import Axis, GeomType

    from texcad.io import write_stl
    from texcad.brep import part_tessellation
    from texcad.options import Options
    from texcad.solid import to_manifold
    from texcad.targets import faces as A
    from texcad.solid.weld import welded
    from texcad.targets import patches as F

    part = knob(scale)
    cone = part.faces().filter_by(GeomType.CONE).sort_by(Axis.Z)[0]
    topo = part.wrapped
    opts = A.patch_options(Options.make(height=0.6, pitch=pitch, depth=0.5, edge_angle=45.0, rotation=0.0, critical_angle=45.0,
                                        tolerance=tolerance))
    tex = "builtin:diamond_knurl:period=2"
    t, c = {}, {}
    t0, c0 = time.perf_counter(), time.process_time()
    pm = part_tessellation(topo)
    idx = [next(k for k, fm in enumerate(pm.faces) if fm is not None and fm.face.IsSame(cone.wrapped))]
    t["tessellate"], c["tessellate"] = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    hm, periodic = F.texture_tile(tex, pitch, 0.6)
    F.patch_param(pm, idx, hm.size, 0.0)
    t["parameterize"], c["parameterize"] = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    relief = F.patch_relief(pm, idx, tex, opts)  # (parameterizes again: subtracted below)
    t["map"], c["map"] = time.perf_counter() - t0, time.process_time() - c0 - c["parameterize"]
    t0, c0 = time.perf_counter(), time.process_time()
    man = A.union_patches(to_manifold(pm.mesh), [relief])
    mesh = welded(man)
    assert mesh is not None and len(man.decompose()) == 1
    t["fuse"], c["fuse"] = time.perf_counter() - t0, time.process_time() - c0
    t0, c0 = time.perf_counter(), time.process_time()
    write_stl(mesh, out / "knob_grip.stl")
    t["export"], c["export"] = time.perf_counter() - t0, time.process_time() - c0
    t["total"], c["total"] = sum(t.values()), sum(c.values())
    t["cpu"] = c
    t["triangles"] = mesh.num_triangles
    t["slab_triangles"] = relief.bodies.slab.num_triangles
    t["distortion"] = str(relief.distortion)
    t["max_error"] = relief.max_error
    return t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--pitch", type=float, default=0.125)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--tolerance", type=float, default=0.02, help="mm; 0: one vertex per grid point")
    ap.add_argument("--scale", type=float, default=2.0, help="knob size (2: a 60 mm knob, about 1 M relief triangles)")
    a = ap.parse_args()
    from texcad.solid import retain_freed_memory

    retain_freed_memory()
    with tempfile.TemporaryDirectory() as d:
        runs = [run(a.pitch, Path(d), a.scale, a.tolerance) for _ in range(a.repeat)]  # per repeat
    print(f"knob x{a.scale:g} grip (cone) at {a.pitch} mm: {runs[0]['triangles']} triangles fused ({runs[0]['slab_triangles']} in the relief)")
    print(f"distortion   {runs[0]['distortion']}")
    print(f"max error    {runs[0]['max_error']:.4f} mm (tolerance {a.tolerance} mm; measured at every grid point)")
    for k in ("tessellate", "parameterize", "map", "fuse", "export", "total"):
        vals, cpu = [r[k] for r in runs], [r["cpu"][k] for r in runs]
        print(f"{k:13s} median {statistics.median(vals):6.2f} s   (first {vals[0]:.2f}, range {min(vals):.2f}..{max(vals):.2f})"
              f"   cpu median {statistics.median(cpu):5.2f} s")
    print(f"load average {os.getloadavg()[0]:.2f} {os.getloadavg()[1]:.2f} {os.getloadavg()[2]:.2f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
