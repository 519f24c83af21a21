"""Row-parallel numpy work on the machine's cores (threads: numpy releases the GIL
inside its loops over large arrays).

A function of rows (one point, one sample: no reduction over rows) gives the same
bytes whether it runs on all rows at once or on pieces of them, so
:func:`split_rows` cuts the rows into one contiguous piece per thread and returns
the pieces' results in order. ``TEXCAD_THREADS`` (an integer >= 1) caps the threads;
by default every core is used. :func:`beside` runs one independent job on a second
thread while the caller goes on.
"""

from __future__ import annotations

import contextlib
import os
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable, Iterator, TypeVar

__all__ = ["threads", "split_rows", "beside", "one_blas_thread"]

T = TypeVar("T")


def threads() -> int:
    """Threads for row-parallel work: ``TEXCAD_THREADS`` if set (>= 1), else the
    number of cores."""
    env = os.environ.get("TEXCAD_THREADS", "").strip()
    if env.isdigit() and int(env) >= 1:
        return int(env)
    return max(1, os.cpu_count() or 1)


def split_rows(fn: Callable[[slice], T], n: int, *, min_rows: int = 50_000) -> list[T]:
    """``[fn(slice(a, b)), ...]`` over contiguous pieces covering ``range(n)`` in
    order, one per thread (:func:`threads`), each at least ``min_rows`` rows; a
    single piece (no thread) when ``n < 2 min_rows`` or one thread is allowed. ``fn``
    must treat rows independently, so that the concatenated results do not depend on
    the cut."""
    k = max(1, min(threads(), n // max(1, min_rows)))
    if k == 1:
        return [fn(slice(0, n))]
    cuts = [n * i // k for i in range(k + 1)]
    with ThreadPoolExecutor(k) as pool:
        return list(pool.map(fn, [slice(a, b) for a, b in zip(cuts[:-1], cuts[1:])]))


@contextlib.contextmanager
def beside(fn: Callable[..., T], *args: Any) -> Iterator["Future[T]"]:
    """``with beside(fn, *args) as job: ...``: ``fn(*args)`` runs on a second thread
    while the block runs (first, on this thread, where :func:`threads` is 1);
    ``job.result()`` returns its value or raises its exception. Leaving the block
    waits for the job."""
    if threads() < 2:
        job: Future = Future()
        try:
            job.set_result(fn(*args))
        except Exception as exc:  # handed to the caller by job.result()
            job.set_exception(exc)
        yield job
        return
    with ThreadPoolExecutor(1) as pool:
        yield pool.submit(fn, *args)


def one_blas_thread():
    """A context in which numpy's BLAS runs on one thread (threadpoolctl; nothing
    when it is not installed), for blocks where texcad runs its own threads (the
    BLAS threads would only spin against them). Values do not change: BLAS splits
    rows between its threads, and each row's sum is the same."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(1, user_api="blas")
