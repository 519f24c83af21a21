"""Benchmark tables for the docs: each benchmark script writes what it measured as a
markdown table, with the machine, the date and the command that made it, to
``docs/benchmarks/<name>.md``; ``docs/benchmarks.md`` includes those files (the
pymdownx.snippets ``--8<--`` include), so no figure in the docs is typed by hand.

    from _table import write_table
    write_table("mapping", ["job", "median s"], [["map_texture distance", 0.014]],
                title="Mapping onto a spline", notes="800 x 800 px, 108 mm of arc length")

Run the script again to refresh its table; commit the file it writes.
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import subprocess
import sys
from pathlib import Path
from typing import Any, Sequence

__all__ = ["write_table", "write_output", "write_readme_block", "machine", "command", "markdown_table", "TABLE_DIR", "README"]

ROOT = Path(__file__).resolve().parents[1]
#: Where the tables go (one file per benchmark table).
TABLE_DIR = ROOT / "docs" / "benchmarks"
#: The README, whose few figures are blocks written by the benchmark scripts too.
README = ROOT / "README.md"


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine() -> str:
    """One line about the machine: OS, CPU, cores, memory, Python, numpy, load average."""
    import numpy

    parts = [f"{platform.system()} {platform.machine()}", _cpu_model(), f"{os.cpu_count()} cores"]
    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
        parts.append(f"{pages * size / 2**30:.0f} GiB")
    except (ValueError, OSError, AttributeError):
        pass
    parts += [f"Python {platform.python_version()}", f"numpy {numpy.__version__}"]
    try:
        parts.append("load average " + " ".join(f"{x:.1f}" for x in os.getloadavg()))
    except OSError:
        pass
    return ", ".join(parts)


def _texcad_version() -> str:
    try:
        import texcad

        version = f"texcad {texcad.__version__}"
    except Exception:  # noqa: BLE001 - the table is still worth writing
        version = "texcad"
    try:
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10)
        if rev.returncode == 0 and rev.stdout.strip():
            dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True, timeout=10)
            version += f" (commit {rev.stdout.strip()}{', modified' if dirty.stdout.strip() else ''})"
    except (OSError, subprocess.SubprocessError):
        pass
    return version


def command() -> str:
    """The command line that is running, as a user would type it from the repository root."""
    argv = list(sys.argv)
    try:
        argv[0] = str(Path(argv[0]).resolve().relative_to(ROOT))
    except ValueError:
        pass
    return "python " + " ".join(argv)


def _cell(x: Any) -> str:
    if isinstance(x, float):
        x = f"{x:.3g}" if abs(x) < 1e5 else f"{x:,.0f}"
    elif isinstance(x, int) and not isinstance(x, bool):
        x = f"{x:,}"
    return str(x).replace("|", "\\|").replace("\n", " ")


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A markdown table; floats to 3 significant digits, ints with thousands separators."""
    if any(len(r) != len(headers) for r in rows):
        raise ValueError(f"every row needs {len(headers)} cells ({', '.join(headers)})")
    out = ["| " + " | ".join(_cell(h) for h in headers) + " |", "|" + "---|" * len(headers)]
    out += ["| " + " | ".join(_cell(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def write_table(name: str, headers: Sequence[str], rows: Sequence[Sequence[Any]], *, title: str | None = None,
                notes: str = "", cmd: str | None = None, out_dir: "str | os.PathLike | None" = None) -> Path:
    """Write ``docs/benchmarks/<name>.md``: an optional title, the table, the notes, and a
    line with the command, the date (UTC) and the machine. Written to a temporary file
    and renamed. Returns the path."""
    if not name or any(c in name for c in "/\\. "):
        raise ValueError(f"name {name!r}: a plain file stem such as 'mapping'")
    folder = Path(out_dir) if out_dir is not None else TABLE_DIR
    folder.mkdir(parents=True, exist_ok=True)
    when = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    text = [f"<!-- written by {cmd or command()}; do not edit, run the command again -->", ""]
    if title:
        text += [f"**{title}**", ""]
    text += [markdown_table(headers, rows), ""]
    if notes:
        text += [notes.strip(), ""]
    text += [f"*Command:* `{cmd or command()}`  ", f"*Date:* {when}, {_texcad_version()}  ", f"*Machine:* {machine()}", ""]
    path = folder / f"{name}.md"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text("\n".join(text))
    os.replace(tmp, path)
    return path


def write_output(script: str, args: Sequence[str] = ()) -> Path:
    """Run ``benchmarks/<script>`` with ``args`` and write what it printed (its own
    figures, as it prints them) to ``docs/benchmarks/<stem>.md``, with the command, the
    date and the machine: for the scripts that print their figures but build no table
    of their own. Written to a temporary file and renamed; a script that fails writes
    nothing (its exit status is raised)."""
    cmd = [sys.executable, str(ROOT / "benchmarks" / script), *args]
    shown = " ".join(["python", f"benchmarks/{script}", *args])
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, check=True).stdout
    when = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    name = Path(script).stem.removeprefix("bench_")
    text = [f"<!-- written by python benchmarks/_table.py {' '.join([script, *args])}; do not edit, run the command again -->", "",
            "```text", out.rstrip(), "```", "",
            f"*Command:* `{shown}`  ", f"*Date:* {when}, {_texcad_version()}  ", f"*Machine:* {machine()}", ""]
    TABLE_DIR.mkdir(parents=True, exist_ok=True)
    path = TABLE_DIR / f"{name}.md"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text("\n".join(text))
    os.replace(tmp, path)
    return path


def write_readme_block(name: str, text: str, *, cmd: str | None = None, path: "str | os.PathLike" = README) -> Path:
    """Replace the README's block ``<!-- bench:NAME ... -->`` ... ``<!-- /bench:NAME -->``
    with ``text`` and a line naming the command and the date, so that the README's few
    figures are written by the script that measured them, like the docs' tables. The
    README must hold the block's two marker lines (a missing block is a ValueError, so
    a renamed block is noticed). Written to a temporary file and renamed."""
    path = Path(path)
    doc = path.read_text()
    start, end = f"<!-- bench:{name}", f"<!-- /bench:{name} -->"
    i, j = doc.find(start), doc.find(end)
    if i < 0 or j < i:
        raise ValueError(f"{path.name} has no block {start} ... {end}")
    when = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d")
    head = f"{start}: written by {cmd or command()}; do not edit, run the command again -->"
    body = f"{head}\n{text.strip()}\n\n<sub>Measured {when} by `{cmd or command()}` ({_texcad_version()}).</sub>\n"
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(doc[:i] + body + doc[j:])
    os.replace(tmp, path)
    return path


if __name__ == "__main__":  # python benchmarks/_table.py SCRIPT [ARGS...]
    print(write_output(sys.argv[1], sys.argv[2:]))
