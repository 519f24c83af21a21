"""``texcad demo``: the main job, end to end, on a built-in texture.

A small sample of the texture (25 x 25 mm, 200 x 200 px at the default pitch, the
size of the paper's samples) is grown into a texture for the whole plate by
patch-based sampling (:func:`texcad.synthesize`, paper section 2.1.2), put on the
top face of a build123d plate with M-I ramps at its borders (:func:`texcad.texture`),
fused with manifold3d, and written as STL, 3MF and STEP, with PNG pictures of the
sample, the grown heightmap and the part.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..util import StageReporter, subrange
from ._args import add_tolerance, positive_float

SAMPLE_MM = 25.0  # side of the built-in sample the demo grows its texture from


def run(args: argparse.Namespace) -> int:
    from build123d import Axis

    from .. import builtin, synthesize, texture
    from ..render import render_heightmap
    from ..pipeline import plate_base
    from ..sources import DEFAULT_TEXTURE

    name = args.texture or DEFAULT_TEXTURE
    side, pitch = float(args.size), float(args.pitch)
    progress = StageReporter()
    t0 = time.perf_counter()

    progress(0.0, f"cutting a {min(SAMPLE_MM, side):g} mm sample of builtin:{name}")
    sample_mm = min(SAMPLE_MM, side)
    sample = builtin(name, size=(sample_mm, sample_mm), pitch=pitch, height=args.height)
    px = max(2, round(side / pitch))
    patch = min(45, px, *sample.shape)
    grown = synthesize(
        sample,
        (px, px),
        patch=patch,
        overlap=max(1, patch * 5 // 9),  # the paper's 45 / 25
        seed=args.seed,
        progress=subrange(progress, 0.02, 0.15),
    )

    plate = plate_base((side, side), args.thickness)
    part = texture(
        plate,
        plate.faces().sort_by(Axis.Z)[-1],
        grown,
        brep=not args.no_step,
        tolerance=args.tolerance,
        progress=subrange(progress, 0.15, 0.7),
    )

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    files = ["demo.stl", "demo.3mf"] + ([] if args.no_step else ["demo.step"])
    progress(0.7, f"writing {', '.join(files)}")
    for f in files:
        part.export(out / f)
    progress(0.9, "rendering demo.png, demo_heightmap.png and demo_sample.png")
    part.render(out / "demo.png")
    render_heightmap(grown, out / "demo_heightmap.png")
    render_heightmap(sample, out / "demo_sample.png")
    files += ["demo.png", "demo_heightmap.png", "demo_sample.png"]
    progress(1.0, "done")

    secs = time.perf_counter() - t0
    m = part.mesh
    lo, hi = m.bounds
    print(f"sample       builtin:{name}, {sample.shape[1]} x {sample.shape[0]} px ({sample_mm:g} mm, pitch {pitch:g} mm)")
    print(f"synthesized  {grown.shape[1]} x {grown.shape[0]} px (patch {patch}, seed {args.seed})")
    print(f"triangles    {m.num_triangles}")
    print(f"max error    {part.max_error:.4f} mm at the pixel centres (tolerance {args.tolerance:g} mm)")
    print(f"watertight   {m.is_watertight}")
    print(f"volume       {m.volume:.1f} mm3")
    print(f"size         {hi[0] - lo[0]:.2f} x {hi[1] - lo[1]:.2f} x {hi[2] - lo[2]:.2f} mm")
    print(f"seconds      {secs:.2f}")
    print(f"wrote        {', '.join(str(out / f) for f in files)}")
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    d = sub.add_parser(
        "demo",
        help="grow a built-in texture sample, texture a 100 x 100 mm plate; write STL, 3MF, STEP, PNG",
        description=(
            "The whole pipeline on a built-in texture: a 25 x 25 mm sample is grown by "
            "patch-based synthesis over a plate's top face, fused, and written as "
            "demo.stl, demo.3mf, demo.step and PNG pictures."
        ),
    )
    d.add_argument("--out", default="texcad-demo", help="output folder (default: ./texcad-demo)")
    d.add_argument("--texture", default=None, help="built-in texture name (default: stones; see `texcad textures`)")
    d.add_argument("--size", type=positive_float, default=100.0, help="plate side in mm (default 100)")
    d.add_argument("--thickness", type=positive_float, default=5.0, help="plate thickness in mm (default 5)")
    d.add_argument("--height", type=positive_float, default=2.0, help="texture height in mm (default 2)")
    d.add_argument("--pitch", type=positive_float, default=0.125, help="mm per pixel (default 0.125: 800 x 800 px)")
    d.add_argument("--seed", type=int, default=0, help="synthesis seed (default 0; same seed, same bytes)")
    d.add_argument("--no-step", action="store_true", help="skip the B-rep and demo.step (faster)")
    add_tolerance(d)
    d.set_defaults(func=run)
