"""Scale: peak memory and time of a textured plate against its pixels, and batch
throughput against local Dask workers; writes ``docs/benchmarks/scale.md``.

Plate: a square plate of ``builtin:stones`` at 0.1 mm per pixel (1 M px: 100 x 100
mm; 9 M px: 300 x 300 mm; 36 M px: 600 x 600 mm; 100 M px: 1 x 1 m), one vertex per
pixel (``tolerance=0``), each size in a fresh process (so its peak resident memory is
its own; imports are done before the clock starts):

* ``texture``: ``texcad.texture(texcad.Plate(...), None, "builtin:stones",
  max_memory=...)`` and ``.export("plate.stl")``: the one driver, made in tiles when
  the untiled relief does not fit in ``max_memory``, checked by the gate (tile by
  tile), streamed to STL;
* ``limited`` (at ``--limited-mpx``): the same with ``build_dir`` standing upright
  (+y up), so the overhang limiter runs too, block by block in tiles; its time
  against the unlimited tiled plate of the same size and bound;
* ``lean`` (at ``--lean-mpx``): the same at texcad's default tolerance (0.02 mm: the
  lean mesh, made in tiles too when they are needed), the smallest plate both as
  texcad makes it by default (untiled) and at ``--baseline-memory`` (in tiles);
* at 1 M px also with ``--baseline-memory`` (small enough that it is made in tiles
  too: the linear baseline for the 100 M px target), and ``tiled``:
  :func:`texcad.pipeline.tiled.textured_plate_tiled` alone (no gate), up to
  ``--tiled-max-mpx``.

Batch: ``--parts`` STEP boxes (100 x 100 x 5 mm, top face, stones at 0.1 mm, a few
seconds each) as one :func:`texcad.batch` per worker count, on a fresh local cluster
each whose workers have imported texcad before the clock starts (the cluster's start
is shown apart: it is paid once per batch, not per job). Efficiency = t(1 worker) /
(workers x t(workers)); on a machine with fewer cores than workers it cannot pass
cores / workers, and on a busy machine it says how busy the machine was: the CPU
seconds per job (:attr:`texcad.batch.JobResult.cpu_seconds`) say whether the jobs
themselves got dearer with more workers.

    python benchmarks/bench_scale.py [--only plates|batch] [--max-mpx 100] [--limited-mpx 1 9] [--lean-mpx 1 100] [--workers 1 2 4] [--parts 8] [--out docs/benchmarks/scale.md]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PIXELS = (1, 9, 36, 100)  # M px
PITCH = 0.1
BATCH_BOX = (100.0, 100.0, 5.0)  # mm, each batch job's STEP box (its top face textured)
BATCH_PITCH = 0.1  # mm

_CHILD = r"""
import json, resource, sys, time
from pathlib import Path
import texcad, texcad.pipeline.tiled, texcad.printability, build123d  # imports before the clock
mpx, pitch, out, mode, max_memory = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
side = round((mpx * 1e6) ** 0.5) * pitch
def cpu():
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime
t0, c0 = time.perf_counter(), cpu()
if mode == "tiled":
    from texcad.pipeline.tiled import textured_plate_tiled
    r = textured_plate_tiled((side, side), 5.0, "builtin:stones", pitch, height=1.0, out=out, max_memory=max_memory)
    tris, tiles, how = r.triangles, r.tiles, "textured_plate_tiled (no gate)"
else:
    limited = mode == "limited"  # standing upright: the overhang limiter, block by block when tiled
    bd = texcad.printability.orientation(90, "+y") if limited else None
    tol = {} if mode == "lean" else {"tolerance": 0}  # lean: texcad's default tolerance (0.02 mm)
    tx = texcad.texture(texcad.Plate((side, side), 5.0), None, "builtin:stones", pitch=pitch, height=1.0,
                        max_memory=max_memory, build_dir=bd, **tol)
    tx.export(out)
    assert tx.gate.shells.closed
    tiled = tx.info["fuse"] == "tiled"
    tris, tiles = tx.mesh.num_triangles, tx.info.get("tiles", 1)
    how = (f"texcad.texture, {'tiled' if tiled else 'untiled'}, gated" + (", limited upright" if limited else "")
           + (", lean (tolerance 0.02 mm)" if mode == "lean" else ""))
sec, cpu_sec = time.perf_counter() - t0, cpu() - c0
peak = texcad.util.peak_rss()  # VmHWM: ru_maxrss starts at the parent's peak
print(json.dumps({"side": side, "seconds": sec, "cpu": cpu_sec, "peak": peak, "triangles": tris, "tiles": tiles, "how": how,
                  "max_memory": max_memory, "bytes": Path(out).stat().st_size}))
"""


def plate_row(mpx: float, mode: str, max_memory: str) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = str(Path(tmp) / "plate.stl")
        p = subprocess.run(["nice", "-n", "10", sys.executable, "-c", _CHILD, str(mpx), str(PITCH), out, mode, max_memory],
                           capture_output=True, text=True)
        if p.returncode:
            return {"mpx": mpx, "mode": mode, "max_memory": max_memory, "error": (p.stderr.strip().splitlines() or ["?"])[-1][:120]}
        return {"mpx": mpx, "mode": mode, **json.loads(p.stdout.strip().splitlines()[-1])}


def _warm() -> None:
    import texcad, build123d, texcad.targets.plane  # noqa: F401  (a worker's imports, before the clock)


def batch_rows(workers: list[int], parts: int) -> list[dict]:
    from build123d import Box, export_step

    from texcad.batch import batch, local_cluster

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        step = Path(tmp) / "box.step"
        export_step(Box(*BATCH_BOX), str(step))
        for n in workers:  # per cluster size
            jobs = [{"name": f"part {k}", "part": str(step), "where": "top", "texture": f"builtin:stones:seed={k + 1}",
                     "options": {"pitch": BATCH_PITCH, "height": 0.6}, "outputs": [str(Path(tmp) / f"w{n}-{k}.stl")]}
                    for k in range(parts)]
            t0 = time.perf_counter()
            cluster, client = local_cluster(n)
            try:
                client.run(_warm)
                t1 = time.perf_counter()
                res = batch(jobs, client)
                t2 = time.perf_counter()
            finally:
                client.close()
                cluster.close()
            rows.append({"workers": n, "start": t1 - t0, "seconds": t2 - t1, "ok": sum(r.ok for r in res), "jobs": parts,
                         "job_seconds": sum(r.seconds for r in res),
                         "job_cpu": sum(r.cpu_seconds for r in res) / parts})
    t1 = rows[0]["seconds"] if rows and rows[0]["workers"] == 1 else None
    for r in rows:
        r["efficiency"] = t1 / (r["workers"] * r["seconds"]) if t1 else None
    return rows


def machine() -> str:
    """This machine and its load now, one line."""
    uname = platform.uname()
    cpu = ""
    try:
        cpu = next(l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name"))
    except (OSError, StopIteration):
        pass
    mem = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") / 2**30
    return (f"{uname.system} {uname.machine}, {os.cpu_count()} cores ({cpu}), {mem:.0f} GiB; "
            f"load average {os.getloadavg()[0]:.1f} at the end (shared machine)")


def provenance(run: dict) -> list[str]:
    """A section's machine, date and command (each section is measured on its own)."""
    return [f"- machine: {run['machine']}", f"- date: {run['date']}", f"- command: `{run['command']}`", ""]


def table(plates: list[dict], batches: list[dict], runs: dict) -> str:
    lines = [
        "# Scale: large plates and batches",
        "",
        "## Plate of stones at 0.1 mm: time and peak memory against pixels",
        "",
        *provenance(runs["plates"]),
        "| pixels | plate mm | how | max_memory | tiles | triangles | seconds | s per M px | CPU s per M px | peak memory | STL |",
        "|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for p in plates:
        if "error" in p:
            lines.append(f"| {p['mpx']:g} M | | {p['mode']} | {p['max_memory']} | | | | | | | refused: {p['error']} |")
            continue
        lines.append(
            f"| {p['mpx']:g} M | {p['side']:g} | {p['how']} | {p['max_memory']} | {p['tiles']} | {p['triangles']:,} | "
            f"{p['seconds']:.1f}{' (median of %d)' % p['runs'] if p.get('runs', 1) > 1 else ''} | {p['seconds'] / p['mpx']:.2f} | {p['cpu'] / p['mpx']:.2f} | {p['peak'] / 2**30:.2f} GiB | {p['bytes'] / 2**20:,.0f} MiB |"
        )
    plain = [p for p in plates if "error" not in p and p["how"] == "texcad.texture, tiled, gated"]
    lines += _scaling(plates, plain, "made in tiles through texcad.texture, one vertex per pixel")
    lean = [p for p in plates if "error" not in p and p["how"].endswith("lean (tolerance 0.02 mm)")]
    lines += _scaling(plates, [p for p in lean if "untiled" in p["how"] or p["mpx"] > min(q["mpx"] for q in plates)],
                      "made by texcad.texture as it is by default (untiled, lean within 0.02 mm)")
    lines += _scaling(plates, [p for p in lean if "untiled" not in p["how"]], "made lean in tiles")
    pairs = [(q, p) for q in plates if "error" not in q and q["how"].endswith("limited upright")
             for p in plain if p["mpx"] == q["mpx"] and p["max_memory"] == q["max_memory"]]
    if pairs:
        lines += ["", "The overhang limiter in tiles (build_dir standing upright, +y up; each block limited from its halo): "
                  + ", ".join(f"{q['mpx']:g} M px {q['seconds'] / p['seconds']:.2f} x the unlimited tiled plate's time "
                              f"({q['cpu'] / p['cpu']:.2f} x its CPU time), peak {q['peak'] / 2**30:.2f} against "
                              f"{p['peak'] / 2**30:.2f} GiB" for q, p in pairs) + "."]
    lines += ["", "## Batch throughput against local Dask workers", "", *provenance(runs["batch"]),
              "| workers | jobs ok | cluster start s | jobs s | jobs per minute | efficiency | CPU s per job |", "|---:|---:|---:|---:|---:|---:|---:|"]
    for b in batches:
        eff = "" if b["efficiency"] is None else f"{b['efficiency']:.2f}"
        lines.append(f"| {b['workers']} | {b['ok']}/{b['jobs']} | {b['start']:.1f} | {b['seconds']:.1f} | {60 * b['jobs'] / b['seconds']:.1f} | {eff} | {b['job_cpu']:.2f} |")
    return "\n".join(lines) + "\n"


def _scaling(plates: list[dict], rows: list[dict], what: str) -> list[str]:
    """The scaling sentence: each larger plate's time and CPU time per M px against
    the smallest of ``rows`` (the linear baseline)."""
    base = [p for p in rows if p["mpx"] == min(q["mpx"] for q in plates)]
    big = [p for p in rows if p["mpx"] > min(q["mpx"] for q in plates)]
    if not (base and big):
        return []
    b = base[0]
    return ["", f"Time per M px against the {b['mpx']:g} M px plate {what} "
            f"({b['seconds'] / b['mpx']:.2f} s and {b['cpu'] / b['mpx']:.2f} CPU s per M px, the linear baseline): "
            + ", ".join(f"{p['mpx']:g} M px {(p['seconds'] / p['mpx']) / (b['seconds'] / b['mpx']):.2f} x in time, "
                        f"{(p['cpu'] / p['mpx']) / (b['cpu'] / b['mpx']):.2f} x in CPU time" for p in big)
            + ". CPU time (user + system, this process) is the steadier measure on a shared machine."]


def readme_block(plates: list[dict], batches: list[dict]) -> str:
    """The README's few scale figures: each plate made through texcad.texture (peak
    memory, time per M px), then the batch's jobs per minute and efficiency."""
    rows = [p for p in plates if "error" not in p and p["how"].startswith("texcad.texture")
            and ("lean" in p["how"] or "untiled" not in p["how"]) and "limited" not in p["how"]]  # the rest: the docs' table
    big = max((p["mpx"] for p in rows), default=0)
    rows = [p for p in rows if "lean" not in p["how"] or "untiled" in p["how"] or p["mpx"] == big]  # lean: default, largest
    lines = ["| plate of stones at 0.1 mm | mesh | max_memory | tiles | peak memory | CPU s per M px |",
             "|---|---|---:|---:|---:|---:|"]
    lines += [f"| {p['side']:g} x {p['side']:g} mm ({p['mpx']:g} M px){', limited upright' if 'limited' in p['how'] else ''} | "
              f"{'lean 0.02 mm' if 'lean' in p['how'] else 'every pixel'} | {p['max_memory']} | {p['tiles']} | "
              f"{p['peak'] / 2**30:.2f} GiB | {p['cpu'] / p['mpx']:.2f} |" for p in rows]
    lines += ["", "| local Dask workers | jobs per minute | efficiency | CPU s per job |", "|---:|---:|---:|---:|"]
    lines += [f"| {b['workers']} | {60 * b['jobs'] / b['seconds']:.1f} | "
              f"{'' if b['efficiency'] is None else format(b['efficiency'], '.2f')} | {b['job_cpu']:.2f} |" for b in batches]
    return "\n".join(lines)


def plate_runs(args) -> list[tuple]:
    """``(M px, mode, max_memory)`` of every plate row the arguments ask for."""
    runs = []
    for mpx in (m for m in args.mpx if m <= args.max_mpx):  # per size
        small = mpx == min(args.mpx) and args.baseline_memory
        runs.append((mpx, "texture", args.max_memory))
        runs += [(mpx, "texture", args.baseline_memory)] if small else []
        if mpx in args.lean_mpx:
            runs.append((mpx, "lean", args.max_memory))
            runs += [(mpx, "lean", args.baseline_memory)] if small else []
        if mpx <= args.tiled_max_mpx:
            runs.append((mpx, "tiled", args.max_memory))
        if mpx in args.limited_mpx:
            runs.append((mpx, "limited", args.baseline_memory if small else args.max_memory))
    return runs


def plate_rows(args) -> list[dict]:
    """Each plate row, each run in its own process; small ones several times (the median)."""
    plates = []
    for mpx, mode, mm in plate_runs(args):
        rows = [plate_row(mpx, mode, mm) for _ in range(args.repeat if mpx <= 1 else 1)]
        ok = sorted((r for r in rows if "error" not in r), key=lambda r: r["seconds"])
        row = ok[len(ok) // 2] if ok else rows[0]
        if len(ok) > 1:
            row = {**row, "peak": max(r["peak"] for r in ok), "runs": len(ok)}
        print(row, flush=True)
        plates.append(row)
    return plates


def measured(args, command: str) -> dict:
    """The sections ``--only`` asks for, measured now; the others as the rows file
    (``--rows``) has them from their own run."""
    old = json.loads(args.rows.read_text()) if args.rows.exists() else {}
    out = {}
    for section, measure in (("plates", plate_rows), ("batch", lambda a: batch_rows(sorted(set(a.workers)), a.parts))):
        if args.only in (None, section):
            rows = measure(args)
            stamp = f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC"
            out[section] = {"rows": rows, "machine": machine(), "date": stamp, "command": command}
        elif section in old:
            out[section] = old[section]
        else:
            raise SystemExit(f"--only {args.only}: {args.rows} has no {section} rows; run without --only first")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mpx", type=float, nargs="+", default=list(PIXELS), help="plate sizes, M px (1, 9, 36, 100)")
    ap.add_argument("--max-mpx", type=float, default=100, help="largest plate, M px")
    ap.add_argument("--tiled-max-mpx", type=float, default=1, help="largest plate also made by textured_plate_tiled alone, M px")
    ap.add_argument("--max-memory", default="4GB", help="texcad.texture's bound (max_memory)")
    ap.add_argument("--baseline-memory", default="1GB", help="the 1 M px plate's bound again, small enough to make it in tiles ('' for none)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each plate of 1 M px or less (the median is shown)")
    ap.add_argument("--limited-mpx", type=float, nargs="*", default=[1, 9],
                    help="plates also made limited for standing upright (build_dir), M px; in tiles "
                         "(the smallest at --baseline-memory)")
    ap.add_argument("--lean-mpx", type=float, nargs="*", default=[1, 100],
                    help="plates also made lean (texcad's default tolerance, 0.02 mm), M px; the smallest also "
                         "at --baseline-memory (in tiles)")
    ap.add_argument("--workers", type=int, nargs="*", default=[1, 2, 4])
    ap.add_argument("--parts", type=int, default=8)
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "docs" / "benchmarks" / "scale.md")
    ap.add_argument("--readme", action="store_true", help="also write the README's scale figures (its bench:scale block)")
    ap.add_argument("--only", choices=("plates", "batch"), default=None,
                    help="measure one section; the other is kept from --rows (each section shows its own run)")
    ap.add_argument("--rows", type=Path, default=Path(__file__).resolve().parent.parent / "docs" / "benchmarks" / "scale.json",
                    help="the measured rows, written by every run (what --only keeps)")
    args = ap.parse_args()
    command = "python benchmarks/bench_scale.py " + " ".join(sys.argv[1:])
    runs = measured(args, command)
    args.rows.write_text(json.dumps(runs, indent=1) + "\n")
    plates, batches = runs["plates"]["rows"], runs["batch"]["rows"]
    text = table(plates, batches, runs)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text)
    print(text)
    if args.readme:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from _table import write_readme_block

        cmds = sorted({runs["plates"]["command"], runs["batch"]["command"]})
        write_readme_block("scale", readme_block(plates, batches), cmd="; ".join(cmds))


if __name__ == "__main__":
    main()
