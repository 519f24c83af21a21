"""Make docs/scan.png: a scanned surface turned into a texture, then into a part.

    python docs/make_scan_figure.py [--out docs/scan.png]

A synthetic 40 x 40 mm scan of the built-in "stones" (640 000 points, tilted 5 deg,
30 um sensor noise, 2 % outliers up to 3 mm off) is shown as raw point heights binned
to pixels (the tilt dominates; outliers are the speckles), then the heightmap
texcad.sources.scan_to_heightmap recovers from it (texcad.render.render_heightmap), then that heightmap on a
45 x 45 mm plate (texcad.pipeline.textured_plate, rendered). Deterministic (seeded).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

import texcad
from texcad.render import render_mesh

SIDE, PITCH, N = 40.0, 0.1, 640_000
PANEL = 400  # px


def synthetic_scan(seed: int = 0) -> np.ndarray:
    """(N, 3) points in mm: stones relief, tilted 5 deg about y, noise and outliers."""
    rng = np.random.default_rng(seed)
    truth = texcad.builtin("stones", size=(SIDE, SIDE), pitch=0.05, height=1.2)
    xy = rng.uniform(0, SIDE, (N, 2))
    c = np.clip((xy / 0.05).astype(int), 0, truth.shape[1] - 1)
    z = truth.heights[c[:, 1], c[:, 0]].astype(np.float64)
    z += rng.normal(0, 0.03, N)
    out = rng.random(N) < 0.02
    z[out] += rng.uniform(-3, 3, out.sum())
    z += np.tan(np.radians(5)) * xy[:, 0]
    return np.column_stack([xy, z])


def _binned(points: np.ndarray) -> np.ndarray:
    """Raw heights binned to a PANEL x PANEL grey image (mean per bin, min..max)."""
    ij = np.clip((points[:, :2] / SIDE * PANEL).astype(int), 0, PANEL - 1)
    flat = ij[:, 1] * PANEL + ij[:, 0]
    s = np.bincount(flat, points[:, 2], PANEL * PANEL)
    n = np.maximum(np.bincount(flat, minlength=PANEL * PANEL), 1)
    img = (s / n).reshape(PANEL, PANEL)
    lo, hi = np.percentile(img, [0.5, 99.5])
    return (np.clip((img - lo) / (hi - lo), 0, 1) * 255).astype(np.uint8)[::-1]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).with_name("scan.png")))
    args = ap.parse_args(argv)

    pts = synthetic_scan()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scan.xyz"
        np.savetxt(path, pts, fmt="%.5f")
        hm, report = texcad.sources.scan_to_heightmap(path, pitch=PITCH)
        texcad.render.render_heightmap(hm, Path(tmp) / "hm.png")
        rec = Image.open(Path(tmp) / "hm.png").convert("RGB").resize((PANEL, PANEL))
    print(report)
    part = texcad.pipeline.textured_plate(hm, size=(45, 45), thickness=3)
    img = render_mesh(part.mesh, view=(-1.0, 2.0, -1.2), up=(0, 0, 1), width=PANEL + 100, supersample=2)
    rend = Image.fromarray((img[::-1] * 255).astype(np.uint8))

    raw = Image.fromarray(_binned(pts)).convert("RGB")
    w = PANEL * 2 + rend.width + 40
    h = max(PANEL, rend.height) + 40
    sheet = Image.new("RGB", (w, h), "white")
    draw = ImageDraw.Draw(sheet)
    for x, im, label in (
        (0, raw, "raw scan heights (tilt 5 deg, 2 % outliers)"),
        (PANEL + 20, rec, f"texcad scan: {hm.shape[1]} x {hm.shape[0]} px at {PITCH} mm"),
        (2 * PANEL + 40, rend, "textured_plate(hm, size=(45, 45))"),
    ):
        sheet.paste(im, (x, 30))
        draw.text((x + 4, 8), label, fill="black")
    sheet.save(args.out, optimize=True)
    print(f"wrote {args.out} ({sheet.width} x {sheet.height} px)")


if __name__ == "__main__":
    main()
