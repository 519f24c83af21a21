"""Build texcad's API reference (HTML, pdoc) from the docstrings: one chapter per
pipeline stage, in the order data flows through them.

    pip install -e ".[docs]"
    python docs/make_api.py [OUT]        # default docs/api/; open OUT/texcad.html
"""

from __future__ import annotations

import sys
from pathlib import Path

import pdoc

#: The chapters: the package, then its stages in pipeline order.
MODULES = [
    "texcad",
    "texcad.sources",
    "texcad.synthesis",
    "texcad.synthesis.quality",
    "texcad.printability",
    "texcad.mapping",
    "texcad.solid",
    "texcad.io",
    "texcad.render",
    "texcad.report",
    "texcad.pipeline",
    "texcad.cli",
    "texcad.util",
    "texcad.errors",
]


def main(out: str | None = None) -> Path:
    target = Path(out) if out else Path(__file__).parent / "api"
    pdoc.render.configure(docformat="google", show_source=False)
    pdoc.pdoc(*MODULES, output_directory=target)
    return target


if __name__ == "__main__":
    print(main(sys.argv[1] if len(sys.argv) > 1 else None) / "texcad.html")
