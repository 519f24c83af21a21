"""The ``texcad`` command line: a thin layer over the public API.

Every command prints errors as one line (``texcad: error: ...``) and exits non-zero;
numerics live in the library, not here.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Callable, Sequence

from .errors import TexcadError
from .progress import StageReporter, subrange

__all__ = ["main"]


def _cmd_textures(args: argparse.Namespace) -> int:
    from .textures import BUILTINS

    for name, tex in BUILTINS.items():
        print(f"{name}\t{tex.description}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from . import export, render_heightmap, textured_plate
    from .textures import DEFAULT_TEXTURE

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    progress = StageReporter()
    t0 = time.perf_counter()
    texture = f"builtin:{args.texture or DEFAULT_TEXTURE}"
    part = textured_plate(
        texture,
        size=(args.size, args.size),
        thickness=args.thickness,
        height=args.height,
        pitch=args.pitch,
        progress=subrange(progress, 0.0, 0.8),
    )
    progress(0.8, "writing demo.stl, demo.3mf and demo_heightmap.png")
    export(part.mesh, out / "demo.stl")
    export(part.mesh, out / "demo.3mf")
    render_heightmap(part.heightmap, out / "demo_heightmap.png")
    progress(1.0, "done")
    secs = time.perf_counter() - t0
    m = part.mesh
    lo, hi = m.bounds
    print(f"texture      {texture} ({part.heightmap.shape[1]} x {part.heightmap.shape[0]} px, pitch {part.heightmap.pitch[0]:g} mm)")
    print(f"triangles    {m.num_triangles}")
    print(f"watertight   {m.is_watertight}")
    print(f"volume       {m.volume:.1f} mm3")
    print(f"size         {hi[0] - lo[0]:.2f} x {hi[1] - lo[1]:.2f} x {hi[2] - lo[2]:.2f} mm")
    print(f"seconds      {secs:.2f}")
    print(f"wrote        {out / 'demo.stl'}, {out / 'demo.3mf'}, {out / 'demo_heightmap.png'}")
    return 0


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not v > 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return v


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    p = argparse.ArgumentParser(
        prog="texcad",
        description="Support-free textured solids for 3D printing (units: mm, degrees).",
    )
    p.add_argument("--version", action="version", version=f"texcad {__import__('texcad').__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)

    d = sub.add_parser("demo", help="texture a 100 x 100 mm plate with a built-in texture; write STL, 3MF, PNG")
    d.add_argument("--out", default="texcad-demo", help="output folder (default: ./texcad-demo)")
    d.add_argument("--texture", default=None, help="built-in texture name (default: stones)")
    d.add_argument("--size", type=_positive_float, default=100.0, help="plate side in mm (default 100)")
    d.add_argument("--thickness", type=_positive_float, default=5.0, help="plate thickness in mm (default 5)")
    d.add_argument("--height", type=_positive_float, default=2.0, help="texture height in mm (default 2)")
    d.add_argument("--pitch", type=_positive_float, default=0.125, help="mm per pixel (default 0.125)")
    d.set_defaults(func=_cmd_demo)

    t = sub.add_parser("textures", help="list the built-in textures, one per line, name first")
    t.set_defaults(func=_cmd_textures)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except TexcadError as exc:
        print(f"texcad: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("texcad: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
