"""Signals while a command runs: SIGTERM and SIGHUP unwind like KeyboardInterrupt,
and a signal that arrives while the main thread is inside a long native call
(OCCT meshing or writing a STEP, which run no Python bytecode for minutes) still
stops the command within :data:`GRACE` seconds.

Python runs a signal handler only between bytecodes of the main thread. The C-level
handler also writes the signal's number to a *wakeup* pipe (``signal.set_wakeup_fd``);
a watchdog thread reads it, and when the main thread has not handled the signal
:data:`GRACE` seconds later, it removes every temporary output still pending
(:func:`texcad.util.atomic.remove_pending`, after any rename of finished outputs in
progress), prints the same one line the command would and ends the process
(``os._exit``: 130 for SIGINT, 128 + the signal otherwise). No output is left
half-written either way.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from typing import Iterator

from ..util.atomic import remove_pending

__all__ = ["Terminated", "signals_unwind", "GRACE"]

#: Seconds the main thread has to handle a signal before the watchdog ends the process.
GRACE = 2.0


class Terminated(BaseException):
    """SIGTERM or SIGHUP arrived: unwinds like KeyboardInterrupt, so that every
    temporary output is removed on the way out (:func:`texcad.util.atomic_path`)."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


_handled = threading.Event()


def _terminate(signum: int, frame: object) -> None:
    _handled.set()
    raise Terminated(signum)


def _interrupt(signum: int, frame: object) -> None:
    _handled.set()
    raise KeyboardInterrupt


def _watch(fd: int, watched: frozenset) -> None:
    """Read signal numbers from the wakeup pipe until it closes; end the process
    when one of ``watched`` is not handled by the main thread within :data:`GRACE`."""
    while True:
        try:
            data = os.read(fd, 64)
        except OSError:
            return
        if not data:
            return
        for signum in data:  # one byte per signal
            if signum in watched and not _handled.wait(GRACE):
                remove_pending()  # waits for a rename of finished outputs in progress
                what = "interrupted" if signum == signal.SIGINT else f"terminated by signal {signum}"
                os.write(2, f"texcad: {what}; no output was left half-written\n".encode())
                os._exit(130 if signum == signal.SIGINT else 128 + signum)


def _install() -> dict:
    """Our handlers for SIGTERM and SIGHUP, and for SIGINT where Python's own is in
    place (a job started with SIGINT ignored keeps it ignored); the old ones."""
    old = {}
    for name in ("SIGTERM", "SIGHUP"):  # SIGHUP does not exist on Windows
        sig = getattr(signal, name, None)
        if sig is not None:
            old[sig] = signal.signal(sig, _terminate)
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        old[signal.SIGINT] = signal.signal(signal.SIGINT, _interrupt)
    return old


@contextlib.contextmanager
def signals_unwind() -> Iterator[None]:
    """SIGTERM and SIGHUP raise :class:`Terminated` while the command runs, and the
    watchdog ends a command stuck in native code (main thread only; the previous
    handlers and wakeup fd are put back)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    _handled.clear()
    old = _install()
    r, w = os.pipe()
    os.set_blocking(w, False)
    try:
        prev = signal.set_wakeup_fd(w, warn_on_full_buffer=False)
    except (ValueError, OSError):
        prev = None
    if prev not in (None, -1):  # someone else's (an event loop): leave it to them
        signal.set_wakeup_fd(prev)
        prev = None
    watcher = threading.Thread(target=_watch, args=(r, frozenset(old)), daemon=True, name="texcad-signals") if prev == -1 else None
    if watcher is not None:
        watcher.start()
    try:
        yield
    finally:
        if prev == -1:
            signal.set_wakeup_fd(-1)
        os.close(w)  # the watcher reads the end of the pipe and stops
        if watcher is not None:
            watcher.join(GRACE + 1)
        os.close(r)
        for sig, handler in old.items():
            signal.signal(sig, handler)
