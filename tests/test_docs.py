"""The docs are tested like code: the site builds with warnings as errors, every Python
block of the README and the docs runs, the API reference names every public name, the
README stays a front door, and every relative link resolves.

A block that cannot run here (it needs the reader's own file, a viewer, a slicer) is
marked by ``<!-- no-run: why -->`` on the line just before its fence
(docs/contributing.md). The blocks of one page run in order in one namespace, in a
temporary folder into which ``benchmarks/`` and ``recipes/`` are linked.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
README = ROOT / "README.md"
TABLES = DOCS / "benchmarks"  # written by the benchmark scripts (benchmarks/_table.py), included by docs/benchmarks.md

SETUP = '```sh\npip install -e ".[test]" && texcad demo\npython -m pytest -q\n```'
NO_RUN = re.compile(r"^\s*<!--\s*no-run:\s*\S.*-->\s*$")
FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})(?P<info>[^`\n]*)$")


def _pages() -> list[Path]:
    """README and every markdown page of the site (not the generated benchmark tables)."""
    pages = [README] + sorted(p for p in DOCS.rglob("*.md") if TABLES not in p.parents)
    return pages


def _blocks(path: Path) -> list[tuple[int, str, str, bool]]:
    """``(line, language, code, run)`` for every fenced block of ``path``."""
    lines = path.read_text(encoding="utf-8").splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, fence, info = m.group("indent"), m.group("fence"), m.group("info").strip()
        start, body = i, []
        i += 1
        while i < len(lines) and not re.match(rf"^{re.escape(indent)}{re.escape(fence[0])}{{{len(fence)},}}\s*$", lines[i]):
            body.append(lines[i][len(indent):] if lines[i].startswith(indent) else lines[i].lstrip())
            i += 1
        i += 1
        prev = next((lines[k] for k in range(start - 1, -1, -1) if lines[k].strip()), "")
        lang = info.split()[0].lower() if info else ""
        out.append((start + 1, lang, "\n".join(body) + "\n", not NO_RUN.match(prev)))
    return out


def _python_pages() -> list[Path]:
    return [p for p in _pages() if any(lang in ("python", "py") for _, lang, _, _ in _blocks(p))]


def _rel(p: Path) -> str:
    return str(p.relative_to(ROOT))


# --------------------------------------------------------------------------------------
# The site builds with warnings as errors
# --------------------------------------------------------------------------------------
def test_mkdocs_build_strict(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs", reason="pip install -e '.[docs]'")
    pytest.importorskip("mkdocstrings_handlers.python", reason="pip install -e '.[docs]'")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]), NO_MKDOCS_2_WARNING="1")
    r = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site"), "--config-file", str(ROOT / "mkdocs.yml")],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=600,
    )
    assert r.returncode == 0, f"mkdocs build --strict failed:\n{r.stdout}\n{r.stderr}"
    site = tmp_path / "site"
    for page in ("index.html", "getting-started/index.html", "api/index.html", "design/index.html", "benchmarks/index.html", "cli/index.html"):
        assert (site / page).is_file(), page
    api = (site / "api" / "index.html").read_text(encoding="utf-8")
    import texcad

    for name in texcad.__all__:  # each public name has its own entry (an anchor id) in the built reference
        assert re.search(rf'id="texcad\.{re.escape(name)}"', api), f"texcad.{name} has no entry in the built API reference"
    cli = (site / "cli" / "index.html").read_text(encoding="utf-8")
    from texcad.cli import commands

    for name in commands():  # the generated CLI reference has every command
        assert f"usage: texcad {name}" in cli, f"texcad {name} is missing from the CLI reference"


# --------------------------------------------------------------------------------------
# Every Python block runs
# --------------------------------------------------------------------------------------
@pytest.mark.parametrize("page", _python_pages(), ids=_rel)
def test_code_blocks_run(page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for name in ("benchmarks", "recipes"):
        (tmp_path / name).symlink_to(ROOT / name, target_is_directory=True)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(ROOT))
    ns: dict = {"__name__": "__docs__"}
    ran = 0
    for line, lang, code, run in _blocks(page):
        if lang not in ("python", "py") or not run:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a TexcadWarning in an example is not a failure
            try:
                exec(compile(code, f"{_rel(page)}:{line}", "exec"), ns)  # noqa: S102 - the docs' own examples
            except Exception as e:  # noqa: BLE001
                raise AssertionError(f"{_rel(page)}, the python block at line {line} fails: {type(e).__name__}: {e}") from e
        ran += 1
    assert ran or page != README, "the README's recipe must run"


def test_no_run_markers_say_why() -> None:
    """Every skipped block says why, and only python blocks are marked."""
    for page in _pages():
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"<!--\s*no-run(.*?)-->", text):
            assert re.match(r":\s*\S", m.group(1)), f"{_rel(page)}: a no-run marker without a reason: {m.group(0)}"
        for line, lang, _, run in _blocks(page):
            assert run or lang in ("python", "py"), f"{_rel(page)}:{line}: only python blocks are run, so only they are marked"


# --------------------------------------------------------------------------------------
# The API reference names every public name
# --------------------------------------------------------------------------------------
def test_api_reference_names_every_public_name() -> None:
    import texcad

    api = (DOCS / "api.md").read_text(encoding="utf-8")
    documented = set(re.findall(r"^:::\s*texcad\.(\w+)\s*$", api, flags=re.M))
    missing = [n for n in texcad.__all__ if n not in documented]
    assert not missing, f"docs/api.md has no '::: texcad.NAME' entry for {missing}"
    for mod in ("texcad.options.Options", "texcad.contracts", "texcad.report.gate"):
        assert re.search(rf"^:::\s*{re.escape(mod)}\s*$", api, flags=re.M), f"docs/api.md does not document {mod}"


# --------------------------------------------------------------------------------------
# The README is a front door
# --------------------------------------------------------------------------------------
def test_readme_is_short_and_starts_with_the_two_commands() -> None:
    data = README.read_bytes()
    assert len(data) < 10_000, f"README.md is {len(data)} bytes; keep it under 10 KB and move the rest into docs/"
    text = data.decode("utf-8")
    first = text.split("\n", 2)
    assert first[0].startswith("# "), "the README starts with its title"
    assert text.split("\n", 2)[2].startswith(SETUP), "the two set-up commands come first, byte for byte"
    assert "python -m pytest -q\n" in text  # CI (.ci/run) runs exactly this


def test_every_benchmark_table_is_included() -> None:
    page = (DOCS / "benchmarks.md").read_text(encoding="utf-8")
    included = set(re.findall(r'^--8<--\s+"benchmarks/([\w-]+\.md)"\s*$', page, flags=re.M))
    tables = {p.name for p in TABLES.glob("*.md")}
    assert tables <= included, f"docs/benchmarks.md does not include {sorted(tables - included)}"
    assert included <= tables, f"docs/benchmarks.md includes missing tables {sorted(included - tables)}"
    for name in tables:  # written by a benchmark script: the command, the date and the machine are there
        text = (TABLES / name).read_text(encoding="utf-8").lower()
        assert re.search(r"command:?\*? `python benchmarks/", text), f"docs/benchmarks/{name} does not say its command"
        for field in ("date:", "machine:"):
            assert field in text.replace("*", ""), f"docs/benchmarks/{name} lacks {field!r}: write it with benchmarks/_table.py"


# --------------------------------------------------------------------------------------
# Every relative link resolves
# --------------------------------------------------------------------------------------
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)|<img[^>]*\bsrc=\"([^\"]+)\"")


def _strip_code(text: str) -> str:
    text = re.sub(r"^([ \t]*)(`{3,}|~{3,}).*?^\1\2[ \t]*$", "", text, flags=re.M | re.S)
    return re.sub(r"`[^`\n]*`", "", text)


def test_relative_links_resolve() -> None:
    broken = []
    for page in _pages():
        for m in LINK.finditer(_strip_code(page.read_text(encoding="utf-8"))):
            target = m.group(1) or m.group(2)
            if re.match(r"^[a-z][a-z0-9+.-]*:", target, flags=re.I) or target.startswith("#"):
                continue  # http:, mailto:, anchors in the page (mkdocs checks those)
            path = (page.parent / target.split("#", 1)[0]).resolve()
            if not path.exists():
                broken.append(f"{_rel(page)}: {target}")
    assert not broken, "broken relative links:\n" + "\n".join(broken)


# --------------------------------------------------------------------------------------
# What the docs name exists
# --------------------------------------------------------------------------------------
def _resolves(dotted: str) -> bool:
    import importlib

    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        try:
            for attr in parts[i:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return False
        return True
    return False


def test_named_modules_files_and_functions_exist() -> None:
    """Every ``texcad.x.y`` the docs name resolves, and every repository file they name
    in backticks (``texcad/...py``, ``tests/...``, ``benchmarks/...``, ``recipes/...``) exists."""
    missing = []
    for page in _pages():
        text = page.read_text(encoding="utf-8")
        for path in set(re.findall(r"`((?:texcad|tests|benchmarks|recipes|docs)/[\w/.-]+\.py)`", text)):
            if not (ROOT / path).exists():
                missing.append(f"{_rel(page)}: {path}")
        for name in set(re.findall(r"\btexcad(?:\.[A-Za-z_]\w*)+", text)):
            if not _resolves(name.rstrip(".")):
                missing.append(f"{_rel(page)}: {name}")
    assert not missing, "the docs name things that do not exist:\n" + "\n".join(sorted(missing))
