"""``texcad make``: texture a plate, cylinder, arc or sine surface; write STL or 3MF.

    texcad make --surface cylinder --radius 20 --length 100 --texture builtin:stones \\
        --height 2 --mapping angle -o grip.stl

Numerics live in :func:`texcad.mapping.textured_surface`; this module only parses,
reports progress and the summary, and writes the file (atomically: a failure never
leaves a half-written or stale output).
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from ..errors import ParameterError
from ..util import StageReporter, subrange
from ._args import add_orientation, add_tolerance, limits_line, positive_float
from .texture import _gradient

SUFFIXES = (".stl", ".3mf")


def run(args: argparse.Namespace) -> int:
    from .. import export
    from ..errors import TexcadWarning
    from ..pipeline import textured_surface
    from ..mapping import Surface

    out = Path(args.out)
    if out.suffix.lower() not in SUFFIXES:
        raise ParameterError(f"output {str(out)!r} must end in .stl or .3mf")
    if not out.parent.exists():
        raise ParameterError(f"the output folder {str(out.parent)!r} does not exist; create it first")
    progress = StageReporter()
    t0 = time.perf_counter()
    progress(0.0, f"building the {args.surface} surface")
    dims = {
        k: getattr(args, k)
        for k in ("width", "length", "radius", "angle", "amplitude", "period", "thickness")
        if getattr(args, k) is not None
    }
    surface = Surface.named(args.surface, **dims)
    texture = args.texture
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TexcadWarning)
        part = textured_surface(
            surface,
            texture,
            height=args.height,
            mapping=args.mapping,
            pitch=args.pitch,
            depth=args.depth,
            build_dir=args.build_dir,
            critical_angle=args.critical_angle,
            tolerance=args.tolerance,
            mode=args.mode,
            gradient=args.gradient,
            progress=subrange(progress, 0.02, 0.85),
        )
    notes = [str(w.message) for w in caught if issubclass(w.category, TexcadWarning)]
    progress(0.9, f"writing {out.name}")
    export(part.mesh, out)
    progress(1.0, "done")
    secs = time.perf_counter() - t0
    m = part.mesh
    hm = part.heightmap
    lo, hi = m.bounds
    print(f"surface      {args.surface} ({surface.profile.name}, {surface.profile.length:.2f} x {surface.length:.2f} mm)")
    print(f"texture      {texture} ({hm.shape[1]} x {hm.shape[0]} px, pitch {hm.pitch[0]:.4g} mm, height {args.height:g} mm)")
    print(f"mapping      {args.mapping}-preserving (algorithm {1 if args.mapping == 'distance' else 2}), {args.mode}")
    print(f"triangles    {m.num_triangles}")
    print(f"max error    {part.max_error:.4f} mm at the pixel centres, in 3-D (tolerance {args.tolerance:g} mm)")
    print(f"watertight   {m.is_watertight}")
    print(f"volume       {m.volume:.1f} mm3")
    print(f"size         {hi[0] - lo[0]:.2f} x {hi[1] - lo[1]:.2f} x {hi[2] - lo[2]:.2f} mm")
    print(f"seconds      {secs:.2f}")
    line = limits_line(part.limits)
    if line:
        print(line)
    limits = part.height_limits
    print(f"limits       {len(limits) if limits else 'none'}")
    for lim in limits:
        print(f"  - {lim}")
    for note in notes:
        if "limited" not in note:
            print(f"note         {note}")
    print(f"wrote        {out}")
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    from ..mapping import MAPPINGS
    from ..mapping import SURFACE_KINDS

    d = sub.add_parser(
        "make",
        help="texture a plate, cylinder, arc or sine surface (paper algorithms 1 and 2); write STL or 3MF",
        description="Map a texture onto a 2.5D surface and fuse it onto the base body. Units: mm, degrees.",
    )
    d.add_argument("--surface", required=True, choices=SURFACE_KINDS, help="surface kind")
    d.add_argument("--texture", required=True, help="builtin:NAME[:key=value,...] or an image FILE.png")
    d.add_argument("--height", type=positive_float, default=2.0, help="texture height in mm (default 2)")
    d.add_argument(
        "--mapping",
        choices=MAPPINGS,
        default="distance",
        help="distance: texture along z, distances kept (algorithm 1); angle: along the normal (algorithm 2)",
    )
    d.add_argument("-o", "--out", required=True, help="output file, .stl or .3mf")
    g = d.add_argument_group("surface dimensions (mm, degrees; defaults per surface)")
    g.add_argument("--width", type=positive_float, help="plate / sine: x extent (default 100)")
    g.add_argument("--length", type=positive_float, help="extrusion length along y (default 100)")
    g.add_argument("--radius", type=positive_float, help="cylinder (default 20) / arc (default 50) radius")
    g.add_argument("--angle", type=positive_float, help="arc: opening angle in degrees (default 90)")
    g.add_argument("--amplitude", type=positive_float, help="sine: amplitude (default 5)")
    g.add_argument("--period", type=positive_float, help="sine: period (default 50)")
    g.add_argument("--thickness", type=positive_float, help="base wall thickness (default 5; a cylinder with thickness >= radius is solid)")
    d.add_argument("--pitch", type=positive_float, default=0.125, help="mm per texture pixel (default 0.125)")
    add_orientation(d)
    add_tolerance(d)
    d.add_argument("--depth", type=positive_float, default=None, help="how far the slab reaches into the base, mm")
    d.add_argument("--mode", choices=("raised", "engraved", "centred"), default="raised",
                   help="raised: on the surface; engraved: cut in, the outer envelope kept; centred: half and half")
    d.add_argument("--gradient", type=_gradient, default=None, metavar="X0,Y0,Z0,X1,Y1,Z1",
                   help="full depth at the first point (mm), none at the second")
    d.set_defaults(func=run)
