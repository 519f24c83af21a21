"""``texcad scan``: a 3-D scan (point cloud or mesh, mm) to a 16-bit heightmap PNG."""

from __future__ import annotations

import argparse
import time

from ._args import positive_float


def run(args: argparse.Namespace) -> int:
    from ..pipeline import scan_to_png

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


def add(sub: argparse._SubParsersAction) -> None:
    s = sub.add_parser("scan", help="turn a 3-D scan (PLY, STL, OBJ, XYZ, CSV, PCD) into a 16-bit heightmap PNG")
    s.add_argument("scan", help="point cloud or scanned mesh, coordinates in mm")
    s.add_argument("-o", "--out", required=True, metavar="OUT.png", help="heightmap PNG to write")
    s.add_argument("--pitch", type=positive_float, required=True, help="mm per pixel (aim for >= 2 scan points per pixel)")
    s.add_argument("--form-degree", type=int, default=1, help="0 keep z, 1 remove the plane (default), 2..6 also a polynomial form")
    s.add_argument("--outlier-sigma", type=positive_float, default=3.5, help="outlier threshold in robust sigmas (default 3.5)")
    s.add_argument("--base-percentile", type=float, default=0.5, help="height percentile put at 0 mm (default 0.5)")
    s.add_argument("--no-crop", action="store_true", help="keep the bounding rectangle instead of the largest covered one")
    s.add_argument("--no-fill", action="store_true", help="let the crop avoid holes instead of filling them")
    s.add_argument("--preview", metavar="PREVIEW.png", default=None, help="also write a hill-shaded picture")
    s.set_defaults(func=run)
