"""``texcad synth``: grow a texture sample into a larger heightmap (paper section 2.1)."""

from __future__ import annotations

import argparse
import time

from ._args import positive_float, shape

#: Outputs of at least this many pixels report their progress on stderr.
PROGRESS_PIXELS = 1_000_000
#: Quality figures are computed on at most this many px along each side of the output.
REPORT_PIXELS = 1024


def run(args: argparse.Namespace) -> int:
    from ..synthesis import quality
    from ..errors import ParameterError
    from ..util import StageReporter
    from ..render import render_heightmap
    from ..synthesis import seam_bands, synthesize
    from ..sources import PREFIX, load_texture

    if not str(args.out).lower().endswith(".png"):
        raise ParameterError(f"the output must be a .png file, got {args.out!r}; e.g. -o texture.png")
    if args.preview is not None and not str(args.preview).lower().endswith(".png"):
        raise ParameterError(f"the preview must be a .png file, got {args.preview!r}")
    builtin = str(args.sample).startswith(PREFIX)
    size = None
    if builtin:
        size = args.sample_size if args.sample_size is not None else 25.0
    elif args.sample_size is not None:
        raise ParameterError(
            "--sample-size applies to built-in samples only; an image's size is its pixels times --pitch"
        )
    sample = load_texture(args.sample, size=size, pitch=args.pitch, height=args.height)
    rows, cols = args.shape if args.shape is not None else (4 * sample.shape[0], 4 * sample.shape[1])
    wrap = None if args.wrap == "none" else args.wrap
    progress = StageReporter() if rows * cols >= PROGRESS_PIXELS else None

    t0 = time.perf_counter()
    out = synthesize(
        sample,
        (rows, cols),
        patch=args.patch,
        overlap=args.overlap,
        tolerance=args.tolerance,
        seed=args.seed,
        blend=args.blend,
        wrap=wrap,
        progress=progress,
    )
    secs = time.perf_counter() - t0
    out.to_png(args.out)
    if args.preview:
        render_heightmap(out, args.preview)

    # Quality against the sample (texcad.synthesis.quality), on the first REPORT_PIXELS^2 px.
    r, c = min(rows, REPORT_PIXELS), min(cols, REPORT_PIXELS)
    crop = out.heights[:r, :c]
    bands = seam_bands((r, c), args.patch, args.overlap)
    figures = [f"histogram {quality.histogram_distance(crop, sample):.3f}"]
    if min(r, c, *sample.shape) >= 16:
        figures.append(f"spectrum {quality.spectrum_distance(crop, sample):.3f} dec")
    figures.append(f"blur {quality.blur_ratio(crop, bands):.2f}")
    seams = [f"{a} {quality.wrap_seam_error(out, a):.2f}" for a in ("x", "y")]

    sr, sc = sample.shape
    print(f"sample       {args.sample} ({sr} x {sc} px rows x cols, pitch {sample.pitch[0]:g} x {sample.pitch[1]:g} mm)")
    print(
        f"output       {rows} x {cols} px = {out.size[0]:g} x {out.size[1]:g} mm (x by y), patch {args.patch} px, "
        f"overlap {args.overlap} px, blend {args.blend}, wrap {args.wrap}, seed {args.seed}"
    )
    print(f"quality      {', '.join(figures)} (0 and 1 ideal)")
    print(f"wrap seam    {', '.join(seams)} (about 1: tiles, several: does not)")
    print(f"seconds      {secs:.2f}")
    print(
        f"wrote        {args.out} (16-bit grey: black 0 mm, white {out.max_height:.4f} mm)"
        + (f", {args.preview}" if args.preview else "")
    )
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    s = sub.add_parser(
        "synth",
        help="grow a texture sample (image or built-in) into a larger seamless heightmap PNG",
        description=(
            "Texture synthesis by patch-based sampling (Liang et al. 2001; paper section 2.1) "
            "with feathering or the minimum-error boundary cut (paper eq. 1), optionally "
            "tiling along x and/or y for closed surfaces. Lengths in mm, sizes in pixels."
        ),
    )
    s.add_argument("sample", help="sample: an image (PNG, JPEG, TIFF) or builtin:NAME[:key=value,...]")
    s.add_argument("-o", "--out", required=True, metavar="OUT.png", help="16-bit heightmap PNG to write")
    s.add_argument(
        "--shape", type=shape, default=None, metavar="ROWSxCOLS",
        help="output size in pixels at the sample's pitch (default: 4 x the sample)",
    )
    s.add_argument("--patch", type=int, default=45, help="patch side w_B in px (default 45)")
    s.add_argument("--overlap", type=int, default=25, help="boundary-zone width w_E in px, < patch (default 25)")
    s.add_argument(
        "--tolerance", type=float, default=0.1,
        help="candidates within (1 + tolerance) x the best boundary distance (default 0.1)",
    )
    s.add_argument("--seed", type=int, default=0, help="random seed (default 0); same seed, same bytes")
    s.add_argument("--blend", choices=("feather", "cut"), default="feather", help="feather (Liang) or cut (eq. 1)")
    s.add_argument(
        "--wrap", choices=("none", "x", "y", "xy"), default="none",
        help="make the output tile along x, y or both (for closed surfaces; default none)",
    )
    s.add_argument("--pitch", type=positive_float, default=0.125, help="mm per pixel of the sample (default 0.125)")
    s.add_argument("--height", type=positive_float, default=1.0, help="sample height: white in mm (default 1)")
    s.add_argument(
        "--sample-size", type=positive_float, default=None, metavar="MM",
        help="side in mm of a built-in sample (default 25, i.e. 200 px at 0.125 mm)",
    )
    s.add_argument("--preview", metavar="PREVIEW.png", default=None, help="also write a hill-shaded picture")
    s.set_defaults(func=run)
