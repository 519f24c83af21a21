"""Make docs/projections.png: the mesh projections side by side on one part.

    python docs/make_projections_figure.py [--out docs/projections.png] [--pitch 0.3]

One dome-topped cylinder (a curved mesh with a seam line and a pole, r 12 mm),
textured with the same stones (1 mm) by each projection of texcad.targets.mesh:
planar along +x, cylindrical about z, spherical, triplanar and cubic (20 degree blend),
and the solid 3-D stones, which need no projection. The bed face stays flat in every
one. Deterministic: same inputs, same bytes.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
import trimesh
from PIL import Image, ImageDraw

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _figure import font  # noqa: E402

import texcad  # noqa: E402
from texcad.render import render_mesh  # noqa: E402
from texcad.sources import rgb8_image, save_image  # noqa: E402

PANEL = 420
PROJECTIONS = [
    ("planar:+x", "planar along +x"),
    ("cylindrical", "cylindrical about z"),
    ("spherical", "spherical"),
    ("triplanar", "triplanar, 20 deg blend"),
    ("cubic", "cubic, 20 deg blend"),
    ("solid", "solid 3-D stones"),
]


def part() -> trimesh.Trimesh:
    """A cylinder r 12 mm, 14 mm tall, with a hemispherical top: the input mesh."""
    import manifold3d as m3d

    m = m3d.Manifold.cylinder(14.0, 12.0, 12.0, 64) + m3d.Manifold.sphere(12.0, 64).translate((0, 0, 14.0))
    g = m.to_mesh()
    return trimesh.Trimesh(np.asarray(g.vert_properties)[:, :3], np.asarray(g.tri_verts), process=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "projections.png"))
    ap.add_argument("--pitch", type=float, default=0.3)
    a = ap.parse_args()
    base = part()
    renders = []
    for proj, _label in PROJECTIONS:  # per panel
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", texcad.TexcadWarning)
            tx = texcad.texture(base, "not-bottom", "builtin:stones:scale=0.35", height=0.8, pitch=a.pitch,
                                projection=proj, border=1.5, origin=(0, 0, 13))
        rgb = render_mesh(tx.mesh, view=(0.55, 1.0, -0.55), width=PANEL, supersample=2)
        renders.append(rgb8_image(rgb))
    cols, head = 3, 46
    rh = max(r.height for r in renders)
    fig = Image.new("RGB", (cols * PANEL, head + 2 * (rh + 34)), "white")
    d = ImageDraw.Draw(fig)
    d.text((12, 10), "texcad.texture(mesh, 'not-bottom', 'builtin:stones', projection=...): the same 0.8 mm stones on one mesh", fill="black", font=font(18))
    for i, (r, (_p, label)) in enumerate(zip(renders, PROJECTIONS)):
        x, y = (i % cols) * PANEL, head + (i // cols) * (rh + 34)
        d.text((x + 12, y + 4), label, fill="black", font=font(17))
        fig.paste(r, (x, y + 30))
    out = Path(a.out)
    save_image(fig, out)  # atomic (texcad.sources.save_image)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
