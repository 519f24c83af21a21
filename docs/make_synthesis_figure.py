"""Make docs/synthesis.png: texture samples beside their synthesized textures.

    python docs/make_synthesis_figure.py [--out docs/synthesis.png]

Each row: a 200 x 200 px sample (shown at scale), the texture grown from it with
texcad.synthesize (patch 45 px, overlap 25 px, feathering), random patch pasting on
the same grid (texcad.synthesis.naive_quilt, the baseline the quality tests beat) and
a 240 x 240 px output made with wrap="xy" and blend="cut", shown tiled 2 x 2 so any
seam would cross its middle. Top: the built-in "stones"; bottom: a scan-like,
non-procedural height field (filtered noise with grooves and sensor noise). All
panels are hill-shaded (texcad.render.hillshade) at the same pitch; the quality
figures of texcad.synthesis.quality are printed under each output. Deterministic.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _figure import font
from PIL import Image, ImageDraw

from texcad.synthesis import quality as Q
from texcad.sources import Heightmap
from texcad.render import hillshade
from texcad.synthesis import naive_quilt, seam_bands, synthesize
from texcad.sources import builtin

OUT = 400  # output panels, px (1 px of texture = 1 px of picture)
PATCH, OVERLAP = 45, 25
GAP, TOP, BELOW = 16, 30, 42




def scan_like(rows: int = 200, cols: int = 200, seed: int = 4) -> Heightmap:
    """A non-procedural sample: two scales of filtered noise, a network of grooves
    and white 'sensor' noise, 0..1 mm at 0.125 mm/px (a stand-in for a scan)."""
    return Heightmap(Q.natural_sample(rows, cols, seed, periodic=False, sensor_noise=0.05), (0.125, 0.125))


def shaded(hm: Heightmap, lo: float, hi: float) -> Image.Image:
    """Hill-shaded grey picture with the sample's height range ``lo .. hi`` mm."""
    level = np.clip((hm.heights - lo) / (hi - lo), 0, 1)
    grey = 0.2 + 0.45 * level + 0.35 * hillshade(hm)
    rgb = np.repeat(grey[..., None], 3, axis=2) * np.array([1.0, 0.97, 0.92])
    return Image.fromarray((np.clip(rgb[::-1], 0, 1) * 255 + 0.5).astype(np.uint8))


def figures(out: Heightmap, sample: Heightmap) -> str:
    bands = seam_bands(out.shape, PATCH, OVERLAP)
    return (
        f"hist {Q.histogram_distance(out, sample):.3f}  spec {Q.spectrum_distance(out, sample):.2f}  "
        f"blur {Q.blur_ratio(out, bands):.2f}"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default=str(Path(__file__).with_name("synthesis.png")))
    args = ap.parse_args()

    rows = [
        ("built-in 'stones'", builtin("stones", size=(25, 25), pitch=0.125, height=1.0)),
        ("scan-like height field", scan_like()),
    ]
    big, small = font(17), font(14)
    width = 200 + 3 * OUT + 4 * GAP
    height = len(rows) * (TOP + OUT + BELOW) + GAP
    sheet = Image.new("RGB", (width, height), "white")
    d = ImageDraw.Draw(sheet)
    for i, (label, sample) in enumerate(rows):
        y0 = GAP + i * (TOP + OUT + BELOW)
        lo, hi = float(sample.heights.min()), float(sample.heights.max())
        syn = synthesize(sample, (OUT, OUT), patch=PATCH, overlap=OVERLAP, seed=0)
        naive = naive_quilt(sample, (OUT, OUT), patch=PATCH, overlap=OVERLAP, seed=0)
        wrapped = synthesize(sample, (OUT // 2, OUT // 2), patch=PATCH, overlap=OVERLAP, seed=0, wrap="xy", blend="cut")
        tiled = Heightmap(np.tile(wrapped.heights, (2, 2)), wrapped.pitch)
        panels = [
            ("sample", sample, f"{label},\n{sample.shape[0]} x {sample.shape[1]} px"),
            ("synthesize (feather)", syn, figures(syn, sample)),
            ("naive_quilt: random patches", naive, figures(naive, sample)),
            (f"wrap='xy', cut: {OUT // 2} px tiled 2 x 2", tiled,
             f"wrap seam x {Q.wrap_seam_error(wrapped, 'x'):.2f}  y {Q.wrap_seam_error(wrapped, 'y'):.2f}"),
        ]
        x = GAP
        for title, hm, caption in panels:
            d.text((x, y0), title, fill="black", font=big)
            sheet.paste(shaded(hm, lo, hi), (x, y0 + TOP))
            if caption:
                d.multiline_text((x, y0 + TOP + hm.shape[0] + 6), caption, fill=(60, 60, 60), font=small)
            x += hm.shape[1] + GAP
    sheet.save(args.out, optimize=True)
    print(f"wrote {args.out} ({width} x {height} px)")


if __name__ == "__main__":
    main()
