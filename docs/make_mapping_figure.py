"""Make docs/mapping.png: both mappings of the paper (algorithms 1 and 2) on a sine.

    python docs/make_mapping_figure.py [--out docs/mapping.png] [--pitch 0.2]

Top: the fused parts rendered (texcad.render.raster). Bottom: one cross-section of each,
with the profile (grey) and the textured surface (black): pins stand along z in the
distance-preserving mapping and along the surface normal in the angle-preserving one.
Deterministic: same inputs, same bytes.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np
from _figure import font
from PIL import Image, ImageDraw

from texcad.sources import rgb8_image, save_image
from texcad.pipeline import textured_surface
from texcad.render import render_mesh
from texcad.mapping import Surface

PANEL_W = 640






def _section(part, profile, width: int, height: int, x_range, z_range) -> Image.Image:
    """The middle row of the textured grid (black) over its profile (grey), in
    (x, z) at equal scale, x and z ranges in mm."""
    img = Image.new("RGB", (width, height), "white")
    d = ImageDraw.Draw(img)
    ms = part.mapped
    (x0, x1), (z0, z1) = x_range, z_range
    s = min((width - 20) / (x1 - x0), (height - 20) / (z1 - z0))

    def px(x, z):
        return list(zip((10 + (np.asarray(x) - x0) * s).tolist(), (height - 10 - (np.asarray(z) - z0) * s).tolist()))

    row = ms.top[ms.top.shape[0] // 2].astype(np.float64)
    keep = (row[:, 0] > x0 - 1) & (row[:, 0] < x1 + 1)
    p = profile.point(np.linspace(0, profile.length, 4000))
    pk = (p[:, 0] > x0 - 1) & (p[:, 0] < x1 + 1)
    d.line(px(p[pk, 0], p[pk, 1]), fill=(160, 160, 160), width=3)
    d.line(px(row[keep, 0], row[keep, 2]), fill=(0, 0, 0), width=2)
    return img


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).with_name("mapping.png")))
    ap.add_argument("--pitch", type=float, default=0.2)
    args = ap.parse_args()

    surf = Surface.sine(amplitude=6.0, period=40.0, width=80.0, length=30.0, thickness=4.0)
    texture = "builtin:pins:period=3,diameter=1.4"
    parts = {}
    for mode in ("distance", "angle"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            parts[mode] = textured_surface(surf, texture, height=2.5, mapping=mode, pitch=args.pitch)

    title_font, label, small = font(22), font(18), font(15)
    renders, sections = [], []
    for mode, part in parts.items():
        rgb = render_mesh(part.mesh, view=(0.35, 1.0, -0.45), width=PANEL_W, supersample=2)
        renders.append(rgb8_image(rgb))
    # The sections zoom on a trough and a flank of the sine (x 45..75 mm).
    for mode, part in parts.items():
        sections.append(_section(part, surf.profile, PANEL_W, 260, (45.0, 75.0), (-7.0, 9.0)))

    rh = max(im.height for im in renders)
    head, gap = 64, 8
    W = 2 * PANEL_W + gap
    H = head + 36 + rh + 36 + 260 + 10
    fig = Image.new("RGB", (W, H), "white")
    d = ImageDraw.Draw(fig)
    d.text((12, 10), "texcad: texture mapped onto a 2.5D surface (sine, A 6 mm, L 40 mm; pins 2.5 mm high)", fill=(0, 0, 0), font=title_font)
    d.text((12, 40), "left: distance-preserving (paper, algorithm 1)   right: angle-preserving (algorithm 2)", fill=(60, 60, 60), font=small)
    captions = {
        "distance": "distance-preserving: x = arc length, height along z",
        "angle": "angle-preserving: x = arc length, height along the normal",
    }
    for i, (mode, part) in enumerate(parts.items()):
        x = i * (PANEL_W + gap)
        d.text((x + 12, head + 6), captions[mode], fill=(0, 0, 0), font=label)
        fig.paste(renders[i], (x, head + 36 + (rh - renders[i].height) // 2))
        y = head + 36 + rh + 6
        d.text((x + 12, y), f"cross-section y = {part.mapped.y[len(part.mapped.y) // 2]:.1f} mm, x 45..75 mm (grey: profile)", fill=(60, 60, 60), font=small)
        fig.paste(sections[i], (x, y + 28))
        m = part.mesh
        d.text((x + 12, H - 28), f"{m.num_triangles} triangles, watertight {m.is_watertight}, {m.volume:.0f} mm3", fill=(60, 60, 60), font=small)
    out = Path(args.out)
    save_image(fig, out)  # atomic (texcad.sources.save_image)
    print(f"wrote {out} ({W} x {H} px)")


if __name__ == "__main__":
    main()
