"""``texcad render``: an offscreen PNG picture of a part (STL, 3MF or STEP)."""

from __future__ import annotations

import argparse
import time

from ._args import vector


#: Bytes per supersampled pixel of the renderer (float64 RGB image, depth and face
#: buffers, their temporaries): an upper estimate.
BYTES_PER_PIXEL = 96


def check_render_memory(mesh, width: int, supersample: int, view, up) -> None:
    """ResourceError naming the widest picture that fits, when ``width`` px (height
    from the part's aspect, at most 4 x the width) times ``supersample`` squared
    would not fit in the memory available."""
    import numpy as np

    from ..errors import ParameterError, ResourceError
    from ..render import camera
    from ..util import available_memory

    if width < 1 or supersample < 1:
        raise ParameterError(f"--width and --supersample must be positive integers, got {width} and {supersample}")
    scr = mesh.vertices.astype(np.float64) @ camera(view, up).T
    ext = np.maximum(np.ptp(scr[:, :2], axis=0), 1e-9) if len(scr) else np.ones(2)
    aspect = min(float(ext[1] / ext[0]), 4.0)
    need = BYTES_PER_PIXEL * (width * supersample) ** 2 * max(aspect, 1.0 / width)
    have = available_memory()
    if need > have:
        fit = int(width * (have / (1.2 * need)) ** 0.5)
        raise ResourceError(
            f"a {width} px wide picture (supersample {supersample}) needs about {need / 2**30:.1f} GiB of memory but "
            f"{have / 2**30:.1f} GiB are available; use --width {max(fit, 1)} or less (or a smaller --supersample)"
        )


def run(args: argparse.Namespace) -> int:
    from ..io import load_mesh
    from ..render import render_part as render
    from ._outputs import check_outputs

    t0 = time.perf_counter()
    check_outputs([args.out], (".png",))
    mesh = load_mesh(args.part, tolerance=args.tolerance)
    check_render_memory(mesh, args.width, args.supersample, args.view, args.up)
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
