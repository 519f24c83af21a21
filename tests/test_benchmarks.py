"""The benchmark scripts name only what texcad has: every ``from texcad... import
name`` and every ``texcad.a.b`` attribute chain they use resolves (a script that
called a function since renamed crashed only when its long part ran)."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
SCRIPTS = sorted(p for p in BENCH.glob("bench_*.py"))


def _chains(tree: ast.AST, aliases: dict) -> set:
    """``texcad.x.y`` chains used as attributes (``import texcad.x as tx`` aliases resolved)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            parts, n = [], node
            while isinstance(n, ast.Attribute):
                parts.append(n.attr)
                n = n.value
            if isinstance(n, ast.Name) and n.id in aliases:
                out.add(".".join([aliases[n.id]] + parts[::-1]))
    return out


def _resolves(dotted: str) -> bool:
    """Whether ``texcad.a.b.c`` names a module or an attribute (a prefix that resolves
    to a non-module object ends the check: methods of results are not looked up)."""
    parts = dotted.split(".")
    obj = importlib.import_module(parts[0])
    for k in range(1, len(parts)):
        name = ".".join(parts[: k + 1])
        if hasattr(obj, parts[k]):
            obj = getattr(obj, parts[k])
        else:
            try:
                obj = importlib.import_module(name)
            except ImportError:
                return False
        if not isinstance(obj, type(importlib)):
            return True
    return True


@pytest.mark.parametrize("script", SCRIPTS, ids=lambda p: p.stem)
def test_every_texcad_name_a_benchmark_uses_exists(script):
    tree = ast.parse(script.read_text())
    aliases, missing = {}, []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "texcad":
                    aliases[a.asname or a.name.split(".")[0]] = a.name if a.asname else "texcad"
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "texcad":
            mod = importlib.import_module(node.module)
            missing += [f"{node.module}.{a.name}" for a in node.names
                        if not hasattr(mod, a.name) and importlib.util.find_spec(f"{node.module}.{a.name}") is None]
    missing += [c for c in sorted(_chains(tree, aliases)) if not _resolves(c)]
    assert not missing, f"{script.name} uses names texcad does not have: {missing}"
