"""Several ``-o`` outputs of one command: all written, or none.

:func:`check_outputs` runs before any work (every folder exists and is writable, no
output named twice); :func:`write_outputs` writes each output to a temporary file in
its own folder and renames them all at the end, so a failure (or SIGTERM, see
:func:`texcad.cli.main`) leaves neither a half-written file nor some outputs without
the others.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Any, Sequence

from ..errors import InputError, ParameterError
from ..util.atomic import pending, renaming

__all__ = ["check_outputs", "write_outputs"]


def check_outputs(outs: Sequence[str], suffixes: Sequence[str]) -> None:
    """ParameterError / InputError naming the first output that cannot be written:
    a suffix not in ``suffixes``, a folder that does not exist or cannot be written,
    or one file named twice."""
    seen = set()
    for out in outs:  # per output
        p = Path(out)
        if p.suffix.lower() not in suffixes:
            raise ParameterError(f"output {out!r}: texcad writes {', '.join(suffixes)} files; use one of these suffixes")
        key = os.path.abspath(p)
        if key in seen:
            raise ParameterError(f"output {out!r} is named twice; give each -o its own file")
        seen.add(key)
        folder = p.parent if str(p.parent) else Path(".")
        if not folder.is_dir():
            raise InputError(f"output folder {str(folder)!r} of {out!r} does not exist; create it first")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise InputError(f"output folder {str(folder)!r} of {out!r} cannot be written (permission denied); choose another folder")
        if p.is_dir():
            raise InputError(f"output {out!r} is a folder; give a file name")


def write_outputs(result: Any, outs: Sequence[str], *, separate_texture: bool = False) -> None:
    """``result.export`` to every path of ``outs``, all or none: each to a
    temporary file beside it (same suffix), then all renamed. ``separate_texture``
    applies to the 3MF outputs only."""
    done: list[tuple[str, Path]] = []
    stack = contextlib.ExitStack()
    try:
        for k, out in enumerate(outs):  # per output: to a temporary file
            p = Path(out)
            tmp = p.with_name(f".{p.stem}.texcad-{os.getpid()}-{k}.part{p.suffix}")
            done.append((str(tmp), p))
            stack.enter_context(pending(tmp))
            kw = {"separate_texture": True} if separate_texture and p.suffix.lower() == ".3mf" else {}
            if p.suffix.lower() in (".3mf", ".step", ".stp", ".stl"):
                kw["name"] = p.stem
            result.export(tmp, **kw)
        with renaming():
            for tmp, p in done:  # all written: into place
                os.replace(tmp, p)
            done = []
    finally:
        for tmp, _ in done:  # a failure: no output at all
            with contextlib.suppress(OSError):
                os.unlink(tmp)
        stack.close()
