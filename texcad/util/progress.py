"""Progress reporting for long jobs.

A progress callback is any callable ``progress(fraction, message)`` with
``0 <= fraction <= 1``. Library functions take ``progress=None`` and stay silent;
the CLI passes :class:`StageReporter`, which prints one line per stage to stderr.
"""

from __future__ import annotations

import sys
import time
from typing import Callable, Optional, TextIO

__all__ = ["Progress", "StageReporter", "report", "subrange"]

Progress = Optional[Callable[[float, str], None]]


def report(progress: Progress, fraction: float, message: str) -> None:
    """Call ``progress`` if there is one."""
    if progress is not None:
        progress(min(max(fraction, 0.0), 1.0), message)


def subrange(progress: Progress, lo: float, hi: float) -> Progress:
    """A callback that maps ``[0, 1]`` onto ``[lo, hi]`` of ``progress``, so a job
    made of stages reports one rising fraction."""
    if progress is None:
        return None
    return lambda f, msg: progress(lo + (hi - lo) * f, msg)


class StageReporter:
    """Prints ``[ 42%] message (1.2 s)`` lines to a stream (stderr by default).

    Lines for the same message are throttled to a few per second so that callers
    may report from inner loops.
    """

    def __init__(self, stream: TextIO | None = None, min_interval: float = 0.5) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.start = time.perf_counter()
        self.min_interval = min_interval
        self._last_msg = ""
        self._last_t = -1e9

    def __call__(self, fraction: float, message: str) -> None:
        now = time.perf_counter()
        if message == self._last_msg and fraction < 1.0 and now - self._last_t < self.min_interval:
            return
        self._last_msg, self._last_t = message, now
        print(f"[{fraction * 100:3.0f}%] {message} ({now - self.start:.1f} s)", file=self.stream, flush=True)
