"""Make docs/build_direction.png: the build direction and the critical overhang angle.

    python docs/make_build_direction.py [--out docs/build_direction.png] [--pitch 0.25]

Left: the rule (paper, section 2.1.3, figure 4). The build direction d points where
the layers grow; a face that looks down makes the angle theta with the build plate
and overhangs (needs support) when theta < alpha, the critical angle (45 degrees by
default). Middle: a textured plate printed upright, standing on its y = 0 border
(build direction +y), texture as designed: overhang faces red. Right: the same after
``limit_overhangs`` (M-I edge ramp at the downward border plus the slope limiter):
no red on the texture. Numbers in the captions come from :func:`texcad.check`.
Deterministic: same inputs, same bytes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from _figure import font
from PIL import Image, ImageDraw

import texcad
from texcad.sources import rgb8_image
from texcad.report import check
from texcad.printability import limit_overhangs, orientation, overhang_mask
from texcad.render import render_mesh

RED = (0.86, 0.12, 0.10)
SAND = (0.83, 0.76, 0.62)
GREY = (0.70, 0.73, 0.78)
W, H = 470, 470






def _arrow(d: ImageDraw.ImageDraw, x: float, y0: float, y1: float, colour, width: int = 4) -> None:
    d.line([(x, y0), (x, y1 + 14)], fill=colour, width=width)
    d.polygon([(x, y1), (x - 9, y1 + 18), (x + 9, y1 + 18)], fill=colour)


def _rule_panel(alpha: float) -> Image.Image:
    """The overhang rule as a side view: faces hanging out of a wall at several angles."""
    img = Image.new("RGB", (W, H), "white")
    d = ImageDraw.Draw(img)
    small = font(14)
    plate_y = H - 60
    d.rectangle([20, plate_y, W - 20, plate_y + 14], fill=(90, 90, 90))
    d.text((24, plate_y + 18), "build plate (layers are added upwards)", fill=(60, 60, 60), font=small)
    _arrow(d, 40, plate_y - 10, 110, (20, 60, 160))
    d.text((50, 110), "d", fill=(20, 60, 160), font=font(22))
    d.text((50, 136), "build\ndirection", fill=(20, 60, 160), font=small)
    # A wall with faces hanging out of it, at theta degrees below the horizontal.
    px, py = 140, 190
    d.rectangle([px - 16, py - 40, px, plate_y], fill=(200, 200, 205))
    red, grey = tuple(int(255 * c) for c in RED), (70, 130, 70)
    length = 200
    for theta in (10, 25, 45, 60, 80):  # face angles to the build plate (degrees)
        t = np.radians(theta)
        end = (px + length * np.cos(t), py + length * np.sin(t))
        over = theta < alpha
        colour = red if over else grey
        if theta == alpha:
            colour = (0, 0, 0)
        d.line([(px, py), end], fill=colour, width=5 if theta != alpha else 3)
        label = f"{theta}\u00b0 " + ("overhang" if over else ("= \u03b1, critical" if theta == alpha else "prints"))
        d.text((end[0] + 6, end[1] - 10), label, fill=colour, font=small)
    # The critical angle as an arc between the horizontal and the 45 degree face.
    d.line([(px, py), (px + 300, py)], fill=(150, 150, 150), width=1)
    r = 80
    d.arc([px - r, py - r, px + r, py + r], start=0, end=alpha, fill=(0, 0, 0), width=2)
    d.text((20, 12), "The rule", fill=(0, 0, 0), font=font(20))
    d.text(
        (20, 38),
        "A face looking down makes the angle \u03b8 with the\nbuild plate. \u03b8 < \u03b1 (critical angle): overhang, needs\n"
        "support. Upward faces and walls always print.",
        fill=(60, 60, 60),
        font=small,
    )
    return img


def _part_panel(hm: texcad.Heightmap, build_dir: np.ndarray, title: str, caption: str) -> Image.Image:
    part = texcad.pipeline.textured_plate(hm, size=hm.size, thickness=4.0)
    mesh = part.mesh
    over = overhang_mask(mesh, build_dir)
    cen_z = mesh.vertices[mesh.faces].astype(np.float64)[:, :, 2].mean(axis=1)
    cols = np.tile(GREY, (mesh.num_triangles, 1))
    cols[cen_z > 1e-4] = SAND  # texture (above the plate's top face, z = 0)
    cols[over] = RED
    view = -(np.array([0.55, -0.35, 1.0]))  # from above the texture, a little to the side
    rgb, info = render_mesh(
        mesh, face_colors=cols, view=view, up=build_dir, width=W, height=H - 90, supersample=2, margin=0.08, return_info=True
    )
    img = Image.new("RGB", (W, H), "white")
    img.paste(rgb8_image(rgb), (0, 60))
    d = ImageDraw.Draw(img)
    # Build plate: the lowest level of the part along d, on screen.
    scr = mesh.vertices.astype(np.float64) @ info["basis"].T
    y_img = (H - 90) - (scr[:, 1].min() * info["scale"] + info["offset"][1]) + 60
    d.rectangle([20, y_img, W - 20, y_img + 8], fill=(90, 90, 90))
    _arrow(d, W - 40, y_img - 10, 90, (20, 60, 160))
    d.text((W - 60, 64), "d", fill=(20, 60, 160), font=font(22))
    d.text((20, 12), title, fill=(0, 0, 0), font=font(20))
    d.text((20, 38), caption, fill=(60, 60, 60), font=font(14))
    d.text((20, y_img + 14), "standing on its y = 0 border", fill=(60, 60, 60), font=font(14))
    return img


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(Path(__file__).with_name("build_direction.png")))
    ap.add_argument("--pitch", type=float, default=0.25, help="texture pitch in mm")
    args = ap.parse_args()
    alpha = 45.0
    hm = texcad.builtin("stones", size=40.0, pitch=args.pitch, height=2.0)
    d = orientation(90, "+y")  # upright: the paper's figure 4

    def measure(h):
        part = texcad.pipeline.textured_plate(h, size=h.size, thickness=4.0)
        return check([("base", part.base_mesh), ("texture", part.texture_mesh)], build_dir=d, critical_angle=alpha)

    off = measure(hm)
    fixed, rep = limit_overhangs(hm, d, alpha)
    on = measure(fixed)
    panels = [
        _rule_panel(alpha),
        _part_panel(hm, d, "Texture as designed", f"overhang on the texture: {off.texture_overhang_area_mm2:.0f} mm\u00b2 (red)"),
        _part_panel(
            fixed,
            d,
            "limit_overhangs (M-I + slope limiter)",
            f"overhang on the texture: {on.texture_overhang_area_mm2:.0f} mm\u00b2; "
            f"removed {rep.removed_volume_mm3:.0f} mm\u00b3",
        ),
    ]
    fig = Image.new("RGB", (W * len(panels), H), "white")
    for k, p in enumerate(panels):
        fig.paste(p, (k * W, 0))
    out = Path(args.out)
    fig.save(out, optimize=True)
    print(f"wrote {out} ({fig.width} x {fig.height}); texture overhang {off.texture_overhang_area_mm2:.1f} -> {on.texture_overhang_area_mm2:.1f} mm2")


if __name__ == "__main__":
    main()
