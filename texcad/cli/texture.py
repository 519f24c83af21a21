"""``texcad texture``: texture faces of a STEP part; write STL, 3MF, STEP or PNG.

``--face`` is repeatable; every selected face is textured in one call (faces that
meet smoothly share one texture). A selector is a direction word (``top``...), a
face index, ``TYPE`` (the largest face of that kind: ``cylinder``, ``cone``,
``sphere``, ``torus``, ``bspline``, ``revolution``, ``extrusion``...), ``TYPE:i``
(the i-th face of that kind in the part's order), ``TYPE:all``, or
``normal:x,y,z`` (every face whose normal at its centre is within 10 degrees of
that direction); ``solid:K/SELECTOR`` restricts any of these to solid K of an
assembly. In an assembly the solid that owns the faces is textured and the other
solids are written beside it as they were (``texcad faces PART.step`` lists faces
and solids).

``--zone FACES@TEXTURE[@OPTIONS]`` (repeatable, in place of ``--face``) gives each
group of faces its own texture and options in one call (``top@builtin:diamond_knurl@height=0.8``,
``right+left@builtin:stones@engraved``; ``FACES`` joins selectors with ``+``), as
``texcad.texture(part, [(faces, texture, {options}), ...])`` does; ``--separate-texture``
writes each zone as its own part of the 3MF.
"""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from ..options import DEFAULTS
from ._args import add_orientation, add_tolerance, limits_line, positive_float, step_part, zone_spec
from ._outputs import check_outputs, write_outputs
from ._texture_mesh import MESH_SUFFIXES, add_mesh_arguments, run_mesh

def _gradient(text: str) -> tuple:
    """``X0,Y0,Z0,X1,Y1,Z1`` in mm: two different points."""
    try:
        g = tuple(float(c) for c in text.split(","))
    except ValueError:
        g = ()
    if len(g) != 6 or g[:3] == g[3:]:
        raise argparse.ArgumentTypeError(f"expected X0,Y0,Z0,X1,Y1,Z1 (mm, two different points), got {text!r}")
    return g[:3], g[3:]


def _faces(part, selectors: list, path: str) -> list:
    """The faces the ``--face`` selectors name (:func:`texcad.brep.selectors.faces_named`),
    each once. In an assembly the solid that owns them is textured and the others are
    kept (texcad's driver: :mod:`texcad.targets.assembly`)."""
    from ..brep.selectors import faces_named
    from ..targets.cad import require_solid

    require_solid(part, f"the STEP file {path!r}")  # a surface model: say so, not that a selector matched no face of its open shell
    faces: list = []
    for which in selectors:  # per --face
        faces += [f for f in faces_named(part, which) if not any(f.is_same(g) for g in faces)]
    return faces


def run(args: argparse.Namespace) -> int:
    from ..errors import ParameterError

    if Path(args.part).suffix.lower() in MESH_SUFFIXES:  # STL / 3MF / OBJ: _texture_mesh.py, no CAD library
        if getattr(args, "zone", None):
            raise ParameterError(f"--zone names faces of a STEP part; give the mesh {args.part!r} its zones with "
                                 "--region REGION@TEXTURE[@MODE] (repeatable)")
        return run_mesh(args)

    step_part(args.part)  # a PLY, OFF, GLB...: refused naming the formats texcad reads
    for flag, given in (("--region", args.region), ("--union", args.union), ("--size", args.size)):  # mesh options: refused
        if given:
            raise ParameterError(f"{flag} applies to mesh parts (.stl, .3mf, .obj), not to the STEP part {args.part!r}; "
                                 "pick its faces with --face (list them with: texcad faces PART.step)")
    check_outputs(args.out, (".stl", ".3mf", ".step", ".stp", ".png"))
    from build123d import Compound

    from .. import texture
    from ..io import read_step
    from ..errors import TexcadWarning
    from ..util import StageReporter

    t0 = time.perf_counter()
    part = Compound(read_step(args.part))
    zones = getattr(args, "zone", None)
    if zones and args.face:
        raise ParameterError("give faces with --face or with --zone, not both (each --zone names its own faces)")
    selectors = [s for sels, _, _ in zones for s in sels] if zones else (args.face or ["top"])
    faces = _faces(part, selectors, args.part)
    where = [(_faces(part, sels, args.part), tex, opts) for sels, tex, opts in zones] if zones else (faces[0] if len(faces) == 1 else faces)
    with warnings.catch_warnings():
        if args.quiet:
            warnings.simplefilter("ignore", TexcadWarning)
        tx = texture(part, where, args.texture, height=args.height, pitch=args.pitch, mapping=args.mapping,
                     rotation=args.rotation, build_dir=args.build_dir, critical_angle=args.critical_angle,
                     tolerance=args.tolerance, mode=args.mode, gradient=args.gradient, max_memory=args.max_memory,
                     progress=None if args.quiet else StageReporter())
        write_outputs(tx, args.out, separate_texture=args.separate_texture)
    _summary(args, tx, selectors, faces, t0)
    return 0


def _summary(args: argparse.Namespace, tx, selectors: list, faces: list, t0: float) -> None:
    """What was done, one line each (solid, faces, zones, distortion, mesh, volume, limits)."""
    m = tx.mesh
    if "solid" in tx.info:
        print(f"solid        {tx.info['solid']} of {tx.info['solids']} textured; the other {tx.info['solids'] - 1} kept as "
              "they were (separate bodies)")
    print(f"faces        {', '.join(selectors)}: {len(faces)} face(s) ({tx.info['face']}, grid {tx.info['grid'][0]} x {tx.info['grid'][1]})")
    for z in tx.info.get("zone_reliefs") or []:  # per zone
        depth = f", depth {z['max_depth']:.2f} mm" if "max_depth" in z else ""
        print(f"{' '.join(z['name'].split(' ')[:2]):<12} faces {z['faces']}: {z['texture']} {z['mode']}, "
              f"height {z['height']:g} mm, reached {z['max_height']:.2f} mm{depth}")
    for k, patch in enumerate(tx.info.get("faces") or []):  # per patch of smoothly joined faces
        dx, dy = patch["distortion"]["x"], patch["distortion"]["y"]
        print(
            f"distortion   patch {k} ({'+'.join(patch['kinds'])}, {patch['parameterization']}): texture scale "
            f"x {dx[0]:.3f}..{dx[1]:.3f} (worst {dx[2]:.3f}), y {dy[0]:.3f}..{dy[1]:.3f} (worst {dy[2]:.3f}), "
            f"faded {100 * patch['distortion']['faded_fraction']:.1f} %"
        )
    if not tx.info.get("faces"):
        print("distortion   none (planar face: exact; extruded profile: arc length, see the mapping's limits)")
    print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
    if tx.max_error is not None:
        print(f"max error    {tx.max_error:.4f} mm at the pixel centres (tolerance {args.tolerance:g} mm)")
    whole = f" (solid {tx.info['solid']}; all solids {_printed(tx)})" if "solid" in tx.info else ""
    print(f"volume       {m.volume:.1f} mm3{whole}")
    line = limits_line(tx.limits)
    if line:
        print(line)
    print(f"seconds      {time.perf_counter() - t0:.2f}")
    print(f"wrote        {', '.join(args.out)}")


def _printed(tx) -> str:
    """An assembly's printed volume (the union the STL holds: not the solids' sum
    where they overlap) and what of the texture lies inside other solids."""
    parts = [f"{tx.printed_mesh.volume:.1f} mm3 as printed"]
    total = sum(float(m.volume) for m in tx.bodies)
    if total - tx.printed_mesh.volume > 1e-6 * total:
        parts.append(f"their union: they share {total - tx.printed_mesh.volume:.1f} mm3")
    if abs(tx.info.get("buried_mm3", 0.0)) > 0.0:
        parts.append(f"{abs(tx.info['buried_mm3']):.1f} mm3 of the texture inside other solids")
    return ", ".join(parts)


def add(sub: argparse._SubParsersAction) -> None:
    t = sub.add_parser("texture", help="texture faces of a STEP part; write STL, 3MF, STEP and/or PNG")
    t.add_argument("part", help="PART.step, or a mesh PART.stl / .3mf / .obj (mm)")
    t.add_argument(
        "--face",
        action="append",
        help="repeatable: top, bottom, front, back, left, right; a face type (cylinder, cone, sphere, torus, bspline, "
        "revolution, extrusion: the largest), TYPE:i, TYPE:all, normal:x,y,z, or a face index (default top); on a mesh "
        "the direction words: its largest flat patch facing that way",
    )
    t.add_argument(
        "--zone",
        action="append",
        type=zone_spec,
        default=None,
        metavar="FACES@TEXTURE[@OPTIONS]",
        help="repeatable, in place of --face: these faces (selectors joined by +) get their own texture and options "
        "(a mode word or key=value,... of height, pitch, mode, depth, edge_angle, rotation, tolerance), e.g. "
        "top@builtin:diamond_knurl@height=0.8 --zone right@builtin:stones@engraved",
    )
    t.add_argument("--max-memory", default=None, metavar="SIZE",
                   help="bound on the job's memory, e.g. 4GB or 512MB (default: what the machine has); a job that needs "
                   "more is refused up front, naming the finest pitch that fits")
    t.add_argument("--texture", default="builtin:stones", help="builtin:NAME[:k=v] or an image (default builtin:stones)")
    t.add_argument("--height", type=positive_float, default=DEFAULTS.height, help=f"texture height in mm (default {DEFAULTS.height:g})")
    t.add_argument("--pitch", type=positive_float, default=DEFAULTS.pitch, help=f"mm per pixel; on meshes the longest edge (default {DEFAULTS.pitch:g})")
    t.add_argument("--mapping", choices=("angle", "distance"), default=None, help="extruded faces: algorithm 2 (angle, the default) or 1 (distance)")
    t.add_argument("--rotation", type=float, default=0.0, help="planar faces: turn the texture, degrees")
    t.add_argument("--mode", choices=("raised", "engraved", "centred"), default="raised",
                   help="raised (outward), engraved (cut in: the part's envelope is kept) or centred (default raised)")
    t.add_argument("--gradient", type=_gradient, default=None, metavar="X0,Y0,Z0,X1,Y1,Z1",
                   help="CAD faces: full height at the first point (mm), fading to 0 at the second")
    add_orientation(t)
    add_tolerance(t)
    add_mesh_arguments(t)
    t.add_argument("--separate-texture", action="store_true", help="3MF: base and texture as separate parts of each object (one object per build item)")
    t.add_argument("-o", "--out", action="append", required=True, metavar="OUT", help="OUT.stl, .3mf, .step or .png (repeatable)")
    t.add_argument("-q", "--quiet", action="store_true", help="no progress or warnings")
    t.set_defaults(func=run)
