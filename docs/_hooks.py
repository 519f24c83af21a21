"""MkDocs hooks: the CLI reference is generated from texcad's own argument parser at
build time (``<!-- texcad-help -->`` in docs/cli.md), so it lists every command that
exists and never goes stale."""

from __future__ import annotations

import os

MARKER = "<!-- texcad-help -->"


def _help_sections() -> str:
    os.environ["COLUMNS"] = "88"  # argparse wraps at $COLUMNS
    from texcad.cli import build_parser, commands

    parser = build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    out = ["## `texcad`", "", "```text", parser.format_help().rstrip(), "```", ""]
    for name in commands():
        p = sub.choices[name]
        out += [f"## `texcad {name}`", "", "```text", p.format_help().rstrip(), "```", ""]
    return "\n".join(out)


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ANN001
    if MARKER in markdown:
        return markdown.replace(MARKER, _help_sections())
    return markdown


ADAPTERS_MARKER = "<!-- texcad-adapters -->"


def _adapter_table() -> str:
    """The registry the driver asks, in its order: kind, class, module, first line."""
    import inspect

    from texcad.targets import ADAPTERS

    rows = ["| order | kind | adapter | what it places |", "|---|---|---|---|"]
    for i, a in enumerate(ADAPTERS, 1):
        mod = inspect.getmodule(type(a))
        doc = (inspect.getdoc(mod) or "").strip().split("\n\n")[0].replace("\n", " ")
        rows.append(f"| {i} | `{a.kind}` | `{mod.__name__}.{type(a).__name__}` | {doc} |")
    return "\n".join(rows)


_page_markdown = on_page_markdown


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ANN001, F811
    markdown = _page_markdown(markdown, page, config, files)
    if ADAPTERS_MARKER in markdown:
        markdown = markdown.replace(ADAPTERS_MARKER, _adapter_table())
    return markdown
