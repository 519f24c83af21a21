"""``texcad render``: an offscreen PNG picture of a part (STL, 3MF or STEP)."""

from __future__ import annotations

import argparse
import time

from ._args import vector


def run(args: argparse.Namespace) -> int:
    from ..io import load_mesh
    from ..render import render_part as render

    t0 = time.perf_counter()
    mesh = load_mesh(args.part, tolerance=args.tolerance)
    render(mesh, args.out, width=args.width, view=args.view, up=args.up, supersample=args.supersample)
    lo, hi = mesh.bounds
    print(f"part         {args.part} ({mesh.num_triangles} triangles, {hi[0] - lo[0]:.2f} x {hi[1] - lo[1]:.2f} x {hi[2] - lo[2]:.2f} mm)")
    print(f"seconds      {time.perf_counter() - t0:.2f}")
    print(f"wrote        {args.out}")
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    r = sub.add_parser("render", help="render a part (STL, 3MF or STEP) to a PNG picture, offscreen")
    r.add_argument("part", help="PART.stl, PART.3mf or PART.step (mm)")
    r.add_argument("-o", "--out", required=True, metavar="OUT.png", help="picture to write")
    r.add_argument("--width", type=int, default=1200, help="image width in pixels (default 1200)")
    r.add_argument(
        "--view", type=vector, default=(-1.0, 2.0, -1.2), metavar="X,Y,Z",
        help="direction the camera looks along (default -1,2,-1.2: from the front left, above)",
    )
    r.add_argument("--up", type=vector, default=(0.0, 0.0, 1.0), metavar="X,Y,Z", help="direction shown as up (default 0,0,1)")
    r.add_argument("--supersample", type=int, default=2, help="anti-aliasing factor (default 2)")
    r.add_argument(
        "--tolerance", type=float, default=0.01,
        help="STEP only: tessellation tolerance in mm (default 0.01; large B-spline faces tessellate slowly)",
    )
    r.set_defaults(func=run)
