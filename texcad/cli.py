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
    from .textures import BUILTINS, contact_sheet

    for name, tex in BUILTINS.items():
        print(f"{name}\t{tex.description}")
    if args.sheet:
        contact_sheet(args.sheet, field=args.field)
        print(f"wrote {args.sheet}", file=sys.stderr)  # stderr keeps stdout parseable
    return 0


def _cmd_scan(args: argparse.Namespace) -> int:
    from .scan import scan_to_png

    t0 = time.perf_counter()
    hm, report = scan_to_png(
        args.scan,
        args.out,
        pitch=args.pitch,
        preview=args.preview,
        form_degree=args.form_degree,
        outlier_sigma=args.outlier_sigma,
        crop=not args.no_crop,
        fill_holes=not args.no_fill,
        base_percentile=args.base_percentile,
    )
    print(report.summary())
    print(f"seconds      {time.perf_counter() - t0:.2f}")
    print(
        f"wrote        {args.out} (16-bit grey: black 0 mm, white {hm.max_height:.4f} mm, pitch {args.pitch:g} mm)"
        + (f", {args.preview}" if args.preview else "")
    )
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
    t.add_argument("--sheet", metavar="OUT.png", default=None, help="also write a labelled contact sheet of all textures")
    t.add_argument("--field", type=_positive_float, default=24.0, help="side in mm of the square shown per texture (default 24)")
    t.set_defaults(func=_cmd_textures)

    s = sub.add_parser("scan", help="turn a 3-D scan (PLY, STL, OBJ, XYZ, CSV, PCD) into a 16-bit heightmap PNG")
    s.add_argument("scan", help="point cloud or scanned mesh, coordinates in mm")
    s.add_argument("-o", "--out", required=True, metavar="OUT.png", help="heightmap PNG to write")
    s.add_argument("--pitch", type=_positive_float, required=True, help="mm per pixel (aim for >= 2 scan points per pixel)")
    s.add_argument("--form-degree", type=int, default=1, help="0 keep z, 1 remove the plane (default), 2..6 also a polynomial form")
    s.add_argument("--outlier-sigma", type=_positive_float, default=3.5, help="outlier threshold in robust sigmas (default 3.5)")
    s.add_argument("--base-percentile", type=float, default=0.5, help="height percentile put at 0 mm (default 0.5)")
    s.add_argument("--no-crop", action="store_true", help="keep the bounding rectangle instead of the largest covered one")
    s.add_argument("--no-fill", action="store_true", help="let the crop avoid holes instead of filling them")
    s.add_argument("--preview", metavar="PREVIEW.png", default=None, help="also write a hill-shaded picture")
    s.set_defaults(func=_cmd_scan)
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
