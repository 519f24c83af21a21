"""Atomic file output: write to a temporary file in the target folder, then rename."""

from __future__ import annotations

import contextlib
import os
import tempfile
import threading
from pathlib import Path
from typing import Iterator

from ..errors import InputError

__all__ = ["atomic_path", "pending", "track", "untrack", "renaming", "remove_pending"]

#: Temporary outputs being written (removed by :func:`remove_pending` when the
#: process is ended from another thread, :mod:`texcad.cli._signals`).
_PENDING: set = set()
#: Held while finished outputs are renamed into place, so that an ending process
#: renames all of them or none.
_RENAMING = threading.Lock()


def track(path: "str | os.PathLike") -> None:
    """Register ``path``, a temporary file, as pending until :func:`untrack`."""
    _PENDING.add(os.fspath(path))


def untrack(path: "str | os.PathLike") -> None:
    """``path`` is no longer pending (removed or renamed into place)."""
    _PENDING.discard(os.fspath(path))


@contextlib.contextmanager
def pending(path: "str | os.PathLike") -> Iterator[str]:
    """Register ``path`` (a temporary file) as pending while the block runs."""
    track(path)
    try:
        yield os.fspath(path)
    finally:
        untrack(path)


@contextlib.contextmanager
def renaming() -> Iterator[None]:
    """Hold off :func:`remove_pending` while finished outputs are moved into place."""
    with _RENAMING:
        yield


def remove_pending() -> None:
    """Remove every pending temporary file (after a rename in progress ends)."""
    with _RENAMING:
        for p in list(_PENDING):  # a few files
            with contextlib.suppress(OSError):
                os.unlink(p)


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[str]:
    """Yield a temporary path beside ``path``; rename it to ``path`` on success.

    On any exception the temporary file is removed and ``path`` is left untouched,
    so a failed export never leaves a half-written file behind.
    """
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    if not folder.is_dir():
        raise InputError(f"output folder {str(folder)!r} does not exist; create it first")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".part", dir=folder)
    except OSError as exc:  # a read-only or full folder: one line, not a traceback
        raise InputError(f"cannot write {str(target)!r} in folder {str(folder)!r} ({exc.strerror}); choose another output folder") from None
    os.close(fd)
    try:
        with pending(tmp):
            yield tmp
            # mkstemp makes 0600 files; give the result the usual umask-based mode.
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
            with renaming():
                os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
