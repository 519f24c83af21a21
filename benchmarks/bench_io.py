"""Time the two I/O stages of ``bench_mesh.py`` on its own textured mesh (983 620
triangles): writing the 3MF and ``texcad.check`` of it, each broken down.

Write: formatting the XML alone, deflating it alone (zlib level 1, one thread), and
``write_3mf``, which does both at once on two threads. Check: inflating the model
alone, ``read_part`` (inflating on a second thread while the numbers are parsed), and
``texcad.check(path, build_dir=(0, 0, 1))`` (the read, then the measures on two
threads). Median wall and CPU seconds (``time.process_time``: both threads), the
file's size and sha256 (the same bytes as before this work: d876833b... for the
default name), and the 1-minute load average before and after.

    python benchmarks/bench_io.py [--mesh MESH.npz] [--save MESH.npz] [--repeat 5]

Without ``--mesh`` the mesh is made as ``bench_mesh.py`` makes it (about 6 s);
``--save`` keeps it as an ``.npz`` for the next runs.
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import os
import statistics
import tempfile
import time
import zipfile
import zlib
from pathlib import Path

import numpy as np

import texcad
from texcad.io import read_part, write_3mf
from texcad.solid import Mesh

export_module = importlib.import_module("texcad.io.export")


def bench_mesh() -> Mesh:
    """The textured mesh of ``bench_mesh.py`` (default options)."""
    from bench_mesh import bench_part  # this script's folder is on the path

    from texcad.io import write_stl

    src = bench_part()
    with tempfile.TemporaryDirectory() as tmp:
        stl = Path(tmp) / "part.stl"
        write_stl(src, stl)
        tx = texcad.texture(stl, "not-bottom", "builtin:stones", height=1.0, pitch=0.2, projection="triplanar",
                            build_dir=(0, 0, 1), tolerance=0.02)
    return tx.mesh


def timed(fn, repeat: int) -> tuple[float, float, object]:
    """Median wall and CPU seconds of ``fn()`` over ``repeat`` runs, and its last result."""
    walls, cpus, out = [], [], None
    for _ in range(repeat):  # per run
        t, c = time.perf_counter(), time.process_time()
        out = fn()
        walls.append(time.perf_counter() - t)
        cpus.append(time.process_time() - c)
    return statistics.median(walls), statistics.median(cpus), out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh", type=Path, help=".npz with vertices and faces (from --save)")
    ap.add_argument("--save", type=Path, help="keep the mesh made here as this .npz")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    if args.mesh:
        d = np.load(args.mesh)
        mesh = Mesh(d["vertices"], d["faces"])
    else:
        mesh = bench_mesh()
        if args.save:
            np.savez(args.save, vertices=mesh.vertices, faces=mesh.faces)
    mesh.is_watertight  # known before writing, as texture() hands it over (cached)
    load0 = os.getloadavg()[0]
    r = args.repeat
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "part.3mf"
        name = "part"
        fmt = timed(lambda: b"".join(export_module._object_parts(1, name, mesh)), r)
        model = fmt[2]
        deflate = timed(lambda: zlib.compressobj(1, zlib.DEFLATED, -15).compress(model), r)
        write = timed(lambda: write_3mf(mesh, path, name=name), r)
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
        inflate = timed(lambda: zipfile.ZipFile(path).read("3D/3dmodel.model"), r)
        read = timed(lambda: read_part(path), r)
        check = timed(lambda: texcad.check(path, build_dir=(0, 0, 1)), r)
        size = path.stat().st_size
    rep = check[2]
    print(f"mesh         {mesh.num_triangles} triangles, {len(mesh.vertices)} vertices; 3MF {size / 1e6:.1f} MB "
          f"({len(model) / 1e6:.1f} MB of XML), sha256 {digest[:16]}")
    print("stage (median of %d)            wall s   CPU s" % r)
    for label, (w, c, _) in (
        ("format XML alone", fmt), ("deflate alone (level 1)", deflate), ("write_3mf (both, 2 threads)", write),
        ("inflate alone", inflate), ("read_part (inflate || parse)", read), ("texcad.check (read + measures)", check),
    ):
        print(f"  {label:30s} {w:6.3f}  {c:6.3f}")
    print(f"check        watertight {rep.watertight}, manifold {rep.manifold}, shells {rep.shells}, volume {rep.volume_mm3:.1f} mm3, "
          f"overhang {rep.overhang_area_mm2:.2f} mm2")
    print(f"load         {load0:.2f} before, {os.getloadavg()[0]:.2f} after (1-min load average, {os.cpu_count()} CPUs)")


if __name__ == "__main__":
    main()
