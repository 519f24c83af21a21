"""``texcad demo``: the main job on the built-in default texture."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..progress import StageReporter, subrange
from ._args import positive_float


def run(args: argparse.Namespace) -> int:
    from .. import export, render_heightmap, textured_plate
    from ..textures import DEFAULT_TEXTURE

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


def add(sub: argparse._SubParsersAction) -> None:
    d = sub.add_parser("demo", help="texture a 100 x 100 mm plate with a built-in texture; write STL, 3MF, PNG")
    d.add_argument("--out", default="texcad-demo", help="output folder (default: ./texcad-demo)")
    d.add_argument("--texture", default=None, help="built-in texture name (default: stones)")
    d.add_argument("--size", type=positive_float, default=100.0, help="plate side in mm (default 100)")
    d.add_argument("--thickness", type=positive_float, default=5.0, help="plate thickness in mm (default 5)")
    d.add_argument("--height", type=positive_float, default=2.0, help="texture height in mm (default 2)")
    d.add_argument("--pitch", type=positive_float, default=0.125, help="mm per pixel (default 0.125)")
    d.set_defaults(func=run)
