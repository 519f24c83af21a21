"""``texcad check``: is a part printable? Watertight, shells, volume, overhangs (mm2).

Exit status: 0 when the part is watertight and manifold, 1 when it is not, 2 when
the file cannot be read or an option is wrong (one-line error).
"""

from __future__ import annotations

import argparse

from ._args import positive_float


def run(args: argparse.Namespace) -> int:
    from ..report import check
    from ..util import parse_vector

    rep = check(
        args.part,
        build_dir=parse_vector(args.build_dir),
        critical_angle=args.critical_angle,
        nozzle=args.nozzle,
        png=args.png,
    )
    print(rep.to_json() if args.json else rep.summary())
    return 0 if (rep.watertight and rep.manifold) else 1


def add(sub: argparse._SubParsersAction) -> None:
    c = sub.add_parser(
        "check",
        help="check a part (STL/3MF/OBJ/STEP): watertight, shells, volume, overhang area for a build direction",
        description=(
            "Measure a part for printing: watertight, manifold, shells, volume (mm3), bounding box, "
            "triangles, and the overhang area (mm2: faces looking down flatter than the critical angle, "
            "not counting faces on the build plate), for the whole part and, for a texcad 3MF with a "
            "'texture' object, for the textured surface alone. Exit status 1 if the part is not "
            "watertight, 2 if it cannot be read."
        ),
    )
    c.add_argument("part", metavar="PART", help="part to check: .stl (binary or ASCII), .3mf, .obj or .step "
                   "(tessellated to 0.02 mm)")
    c.add_argument(
        "--build-dir",
        default="0,0,1",
        metavar="X,Y,Z",
        help="build direction (up in the printer) in the part's frame, any length (default 0,0,1)",
    )
    c.add_argument(
        "--critical-angle",
        type=positive_float,
        default=45.0,
        metavar="DEG",
        help="smallest printable angle between a downward face and the build plate, degrees (default 45)",
    )
    c.add_argument("--nozzle", type=positive_float, default=None, metavar="MM", help="also report texture features narrower than this nozzle (mm)")
    c.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    c.add_argument("--png", default=None, metavar="OUT.png", help="write a picture in print orientation, overhang faces red")
    c.set_defaults(func=run)
