"""``texcad textures``: list the built-in textures, optionally as a contact sheet."""

from __future__ import annotations

import argparse
import sys

from ._args import positive_float


def run(args: argparse.Namespace) -> int:
    from ..render import contact_sheet
    from ..sources import BUILTINS

    for name, tex in BUILTINS.items():
        print(f"{name}\t{tex.description}")
    if args.sheet:
        contact_sheet(args.sheet, field=args.field)
        print(f"wrote {args.sheet}", file=sys.stderr)  # stderr keeps stdout parseable
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    t = sub.add_parser("textures", help="list the built-in textures, one per line, name first")
    t.add_argument("--sheet", metavar="OUT.png", default=None, help="also write a labelled contact sheet of all textures")
    t.add_argument("--field", type=positive_float, default=24.0, help="side in mm of the square shown per texture (default 24)")
    t.set_defaults(func=run)
