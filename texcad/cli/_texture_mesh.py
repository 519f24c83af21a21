"""``texcad texture PART.stl|.3mf|.obj``: the mesh branch of ``texcad texture``
(:func:`texcad.targets.mesh.MeshAdapter`)."""

from __future__ import annotations

import argparse
import math
import time
import warnings

from ..options import DEFAULTS
from ._args import positive_float

MESH_SUFFIXES = (".stl", ".3mf", ".obj")


def _size(text: str) -> tuple[float, float]:
    """``W,D`` in mm: two positive numbers."""
    try:
        w, d = (float(c) for c in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected W,D in mm such as 20,20, got {text!r}") from None
    if not (w > 0 and d > 0) or not all(map(math.isfinite, (w, d))):
        raise argparse.ArgumentTypeError(f"expected two positive sizes in mm, got {text!r}")
    return w, d


def add_mesh_arguments(t: argparse.ArgumentParser) -> None:
    """The options only mesh parts take (regions, projections, modes)."""
    g = t.add_argument_group("mesh parts (.stl, .3mf, .obj)")
    g.add_argument("--region", action="append", default=None, metavar="REGION",
                   help="all / not-bottom (default; the bed face is never textured), all+bottom, normal:+x:70, "
                   "box:x0,y0,z0,x1,y1,z1, sphere:x,y,z,r; REGION@TEXTURE[@MODE] gives that region its own "
                   "texture (and mode); repeat for several textures in one part")
    g.add_argument("--projection", default="triplanar",
                   help="planar:+x (any axis), cylindrical[:+z], spherical, triplanar, cubic or solid (default triplanar)")
    g.add_argument("--border", type=float, default=DEFAULTS.border, help="fade width at the region's border, mm (default 2)")
    g.add_argument("--blend", type=float, default=DEFAULTS.blend, help="triplanar / cubic blend width, degrees (default 20)")
    g.add_argument("--scale", type=positive_float, default=DEFAULTS.scale, help="texture scale factor (default 1)")
    g.add_argument("--size", type=_size, default=None, metavar="W,D",
                   help="an image --texture: the size of one tile of the image, mm (e.g. 20,20)")
    g.add_argument("--union", action="store_true", default=DEFAULTS.union,
                   help="unite overlapping or touching bodies first (manifold3d) instead of refusing the part")


def run_mesh(args: argparse.Namespace) -> int:
    """Texture a mesh file: one layer per ``--region REGION[@TEXTURE[@MODE]]`` (the
    ``--texture`` and ``--mode`` where not given)."""
    from .. import texture
    from ..errors import TexcadWarning
    from ..util import StageReporter

    from ..errors import ParameterError
    from ._outputs import check_outputs, write_outputs

    from ..brep.selectors import DIRECTIONS

    words = [w.strip() for spec in (args.face or []) for w in spec.split("+")]
    for flag, given in (("--face", [w for w in words if w not in DIRECTIONS]), ("--gradient", args.gradient)):
        if given:  # CAD options: refused, not ignored
            what = f"--face {given[0]}" if flag == "--face" else flag
            raise ParameterError(f"{what} applies to STEP parts, not to the mesh "
                                 f"{args.part!r}; on a mesh --face takes {', '.join(DIRECTIONS)}, and --region picks any "
                                 "surface (e.g. --region normal:+z:30 or box:x0,y0,z0,x1,y1,z1)")
    check_outputs(args.out, (".stl", ".3mf", ".png"))
    t0 = time.perf_counter()
    regions = (args.region or []) + words or ["not-bottom"]
    layers = []
    for spec in regions:  # per layer
        region, _, rest = spec.partition("@")
        tex, _, mode = rest.rpartition("@") if rest.count("@") else (rest, "", "")
        layers.append((region, tex or args.texture, {"mode": mode} if mode else {}))
    with warnings.catch_warnings():
        if args.quiet:
            warnings.simplefilter("ignore", TexcadWarning)
        tx = texture(
            args.part, layers, height=args.height, pitch=args.pitch, projection=args.projection, mode=args.mode,
            border=args.border, blend=args.blend, scale=args.scale, build_dir=args.build_dir,
            critical_angle=args.critical_angle, tolerance=args.tolerance, progress=None if args.quiet else StageReporter(),
            union=args.union or None, size=args.size, max_memory=args.max_memory,
        )
    write_outputs(tx, args.out, separate_texture=args.separate_texture)
    m = tx.mesh
    print(f"mesh         {args.part}: {tx.info['input_triangles']} triangles in, {tx.info['bodies']} bodies")
    if tx.info.get("repaired"):
        print(f"repaired     {tx.info['repaired']}")
    print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
    print(f"max error    {tx.max_error:.4f} mm at the pitch grid's points (tolerance {args.tolerance:g} mm; 0: the pitch grid)")
    print(f"volume       {m.volume:.1f} mm3")
    if tx.limits is not None and tx.limits.lowered:
        print(f"limited      {tx.limits.lowered} vertices lowered, {tx.limits.removed_mm3:.1f} mm3 of relief removed")
    print(f"seconds      {time.perf_counter() - t0:.2f}")
    print(f"wrote        {', '.join(args.out)}")
    return 0
