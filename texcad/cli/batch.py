"""``texcad batch JOBS.toml|JOBS.csv``: many texturing jobs on a Dask cluster
(:func:`texcad.batch.batch`): a local one (``--workers N``, default the cores) or an
existing one (``--scheduler tcp://HOST:PORT``). Exits 1 when a job failed (the others
still ran), 2 when the job file is refused (nothing ran)."""

from __future__ import annotations

import argparse
import os
import time


def _workers(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        n = 0
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a number of workers >= 1, got {text!r}")
    return n


def run(args: argparse.Namespace) -> int:
    from .. import batch as api  # the root's texcad.batch: the function once exported there, else its module
    from ..errors import ParameterError
    from ..util import StageReporter

    if args.workers is not None and args.scheduler:
        raise ParameterError("give --workers (a local cluster) or --scheduler (an existing one), not both")
    t0 = time.perf_counter()
    where = args.scheduler or f"a local cluster of {args.workers or os.cpu_count()} worker(s)"
    print(f"jobs         {args.jobs}, on {where}")
    run_batch = getattr(api, "batch", api)
    # the jobs are read and checked before the cluster starts: a refused file runs nothing
    results = run_batch(args.jobs, args.scheduler, workers=args.workers, progress=None if args.quiet else StageReporter())
    for r in results:  # per job
        if r.ok:
            print(f"ok           {r.name}: {r.triangles} triangles, {r.seconds:.1f} s -> {', '.join(r.outputs)}")
        else:
            print(f"FAILED       {r.name}: {r.error}")
    failed = sum(not r.ok for r in results)
    print(f"done         {len(results) - failed}/{len(results)} jobs ok in {time.perf_counter() - t0:.1f} s")
    return 1 if failed else 0


def add(sub: argparse._SubParsersAction) -> None:
    b = sub.add_parser("batch", help="run many texturing jobs (a TOML or CSV job file) on a local or remote Dask cluster")
    b.add_argument("jobs", help="JOBS.toml ([[job]] tables: part, where, texture, options, outputs) or JOBS.csv")
    b.add_argument("--workers", type=_workers, default=None, help="local cluster: worker processes (default: the cores)")
    b.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT", help="run on this existing Dask scheduler")
    b.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
    b.set_defaults(func=run)
