"""Make docs/paper_samples.png: the paper's Figure 13 / Table 2 samples as texcad makes them.

    TEXCAD_OUT=out python recipes/paper_samples.py      # writes out/T1-flat.png, ...
    python docs/make_paper_samples_figure.py [--src out] [--out docs/paper_samples.png]

A 3 x 3 sheet of the recipe's renders: rows are the textures T1-T3 (Table 1), columns
the flat, curved and sinusoidal samples; each caption gives the Table 2 print
orientation and the texture overhang measured by ``texcad.check`` on the 3MF, with
and without the overhang limiter (from the recipe's paper_samples.json).
Deterministic: same inputs, same bytes.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from PIL import Image, ImageDraw, ImageFont

CELL = 420  # px per picture


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--src", default="out", help="folder the recipe wrote (default ./out)")
    ap.add_argument("--out", default=str(Path(__file__).with_name("paper_samples.png")))
    a = ap.parse_args()
    src = Path(a.src)
    table = {r["sample"]: r for r in json.loads((src / "paper_samples.json").read_text())["samples"]}
    font = ImageFont.load_default()
    caption = 34
    sheet = Image.new("RGB", (3 * CELL, 3 * (CELL * 5 // 9 + caption)), "white")
    draw = ImageDraw.Draw(sheet)
    h = CELL * 5 // 9
    for i, tex in enumerate(("T1", "T2", "T3")):  # per row
        for j, kind in enumerate(("flat", "curved", "sine")):  # per column
            name = f"{tex}-{kind}"
            x, y = j * CELL, i * (h + caption)
            if name not in table:
                continue
            pic = Image.open(src / f"{name}.png").convert("RGB")
            pic.thumbnail((CELL, h))
            sheet.paste(pic, (x + (CELL - pic.width) // 2, y + (h - pic.height) // 2))
            r = table[name]
            draw.text((x + 8, y + h + 2), f"{name}, printed at {r['tilt_deg']} deg", fill="black", font=font)
            draw.text(
                (x + 8, y + h + 16),
                f"texture overhang {r['overhang_mm2']:.2f} mm2 (as synthesized {r['overhang_without_limiter_mm2']:.1f})",
                fill="black",
                font=font,
            )
    sheet.save(a.out, optimize=True)
    print(f"wrote {a.out}")


if __name__ == "__main__":
    main()
