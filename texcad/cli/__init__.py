"""The ``texcad`` command line: a thin layer over the public API.

One module per command (``demo``, ``textures``, ``scan``, ...), each with ``add(sub)``
that registers its parser and ``run(args)`` that does the work. Every command prints
errors as one line (``texcad: error: ...``) and exits non-zero; numerics live in the
library, not here.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import pkgutil
import re
import sys
import warnings
from typing import Callable, Sequence

from ..errors import TexcadError, TexcadWarning
from ._signals import Terminated, signals_unwind

__all__ = ["main", "entry", "build_parser", "commands"]

#: Commands listed first by ``texcad --help``; every other public module of this
#: package is a command too and follows in alphabetical order.
FIRST = ("demo", "make", "texture", "faces", "synth", "check", "render", "textures", "scan")


def commands() -> list[str]:
    """Names of the command modules in ``texcad/cli/``, in ``--help`` order."""
    found = {m.name for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")}
    return [n for n in FIRST if n in found] + sorted(found.difference(FIRST))


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    p = argparse.ArgumentParser(
        prog="texcad",
        description="Support-free textured solids for 3D printing (units: mm, degrees).",
    )
    p.add_argument("--version", action="version", version=f"texcad {__import__('texcad').__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in commands():
        importlib.import_module(f"{__name__}.{name}").add(sub)
    return p


#: A list of numbers that starts with a minus (``-1,2,-0.5``): a value, not an option.
_NEGATIVE_LIST = re.compile(r"-[0-9.][0-9.eE+-]*(,[-+]?[0-9.][0-9.eE+-]*)+|-[xyzXYZ]")


def _join_negative_values(argv: Sequence[str]) -> list[str]:
    """``--view -1,2,-0.5`` as ``--view=-1,2,-0.5``, ``--build-dir -y`` as
    ``--build-dir=-y`` (argparse takes a value that starts with ``-`` for an option;
    no texcad option is ``-x``, ``-y`` or ``-z``)."""
    out: list[str] = []
    for a in argv:  # per argument
        if out and _NEGATIVE_LIST.fullmatch(a) and out[-1].startswith("--") and "=" not in out[-1]:
            out[-1] = f"{out[-1]}={a}"
        else:
            out.append(a)
    return out


@contextlib.contextmanager
def _one_line_warnings():
    """Texcad's warnings formatted as ``texcad: warning: ...`` on one line (Python's
    default adds the library's file, line number and source line); any other
    warning as Python formats it. Whoever records warnings still gets them."""
    formatted = warnings.formatwarning

    def format_one(message, category, filename, lineno, line=None):  # warnings.formatwarning's signature
        if issubclass(category, TexcadWarning):
            return f"texcad: warning: {message}\n"
        return formatted(message, category, filename, lineno, line)

    warnings.formatwarning = format_one
    try:
        yield
    finally:
        warnings.formatwarning = formatted


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (2: a texcad error, printed on one line;
    130: interrupted; 128 + the signal for SIGTERM and SIGHUP; 141: the output's reader
    closed the pipe)."""
    parser = build_parser()
    args = parser.parse_args(_join_negative_values(sys.argv[1:] if argv is None else list(argv)))
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        with signals_unwind(), _one_line_warnings():
            return func(args)
    except TexcadError as exc:
        print(f"texcad: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("texcad: interrupted", file=sys.stderr)
        return 130
    except Terminated as exc:
        print(f"texcad: terminated by signal {exc.signum}; no output was left half-written", file=sys.stderr)
        return 128 + exc.signum
    except BrokenPipeError:  # the reader went away (texcad check part.stl | head): nothing more to say
        with contextlib.suppress(OSError, ValueError):  # Python's flush at exit would raise again
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141


def entry() -> None:
    """The ``texcad`` program (console script and ``python -m texcad``): a one-shot
    process, so glibc is told to reuse freed memory instead of returning it to the
    system (:func:`texcad.solid.retain_freed_memory`: 0.3-0.5 s less per 800 x 800 px
    job). ``main()`` alone leaves the host process's allocator as it is."""
    from ..solid import retain_freed_memory

    retain_freed_memory()
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    entry()
