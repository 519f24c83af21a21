"""``texcad texture``: texture one face of a STEP part; write STL, 3MF, STEP or PNG."""

from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

from ._args import add_orientation, limits_line, positive_float
from ._texture_mesh import MESH_SUFFIXES, add_mesh_arguments, run_mesh

#: ``--face`` words: the planar face whose outward normal points that way (largest
#: if several), or the largest cylindrical / extruded face.
DIRECTIONS = {"top": (0, 0, 1), "bottom": (0, 0, -1), "front": (0, -1, 0), "back": (0, 1, 0), "left": (-1, 0, 0), "right": (1, 0, 0)}


def pick_face(shape, which: str):
    """The face of a build123d shape named by ``which``: a word of :data:`DIRECTIONS`,
    ``cylinder`` / ``extrusion`` (the largest such face) or a face index."""
    from build123d import GeomType, Vector

    from ..errors import ParameterError

    faces = shape.faces()
    if which.isdigit():
        i = int(which)
        if i >= len(faces):
            raise ParameterError(f"--face {i}: the part has only {len(faces)} faces (0..{len(faces) - 1})")
        return faces[i]
    if which in ("cylinder", "extrusion"):
        kinds = (GeomType.CYLINDER,) if which == "cylinder" else (GeomType.CYLINDER, GeomType.EXTRUSION, GeomType.BSPLINE)
        cands = [f for f in faces if f.geom_type in kinds]
        if not cands:
            raise ParameterError(f"--face {which}: the part has no such face; use top, bottom, ... or a face index")
        return max(cands, key=lambda f: f.area)
    if which not in DIRECTIONS:
        raise ParameterError(f"--face {which!r}: use one of {', '.join(DIRECTIONS)}, cylinder, extrusion or a face index")
    d = DIRECTIONS[which]
    planar = [f for f in faces.filter_by(GeomType.PLANE) if f.normal_at().dot(Vector(*d)) > 0.999]
    if not planar:
        raise ParameterError(f"--face {which}: no planar face looks {which}; use a face index (0..{len(faces) - 1})")
    return sorted(planar, key=lambda f: f.area, reverse=True)[0] if len(planar) > 1 else planar[0]


def run(args: argparse.Namespace) -> int:
    from build123d import Compound

    from .. import texture
    from ..io import read_step
    from ..errors import TexcadWarning
    from ..util import StageReporter

    if Path(args.part).suffix.lower() in MESH_SUFFIXES:  # STL / 3MF / OBJ: _texture_mesh.py
        return run_mesh(args)
    t0 = time.perf_counter()
    part = Compound(read_step(args.part))
    face = pick_face(part, args.face)
    with warnings.catch_warnings():
        if args.quiet:
            warnings.simplefilter("ignore", TexcadWarning)
        tx = texture(
            part,
            face,
            args.texture,
            height=args.height,
            pitch=args.pitch,
            mapping=args.mapping,
            rotation=args.rotation,
            build_dir=args.build_dir,
            critical_angle=args.critical_angle,
            progress=None if args.quiet else StageReporter(),
        )
    for out in args.out:
        tx.export(out, separate_texture=args.separate_texture)
    m = tx.mesh
    print(f"face         {args.face} ({tx.info['face']}, grid {tx.info['grid'][0]} x {tx.info['grid'][1]})")
    print(f"triangles    {m.num_triangles}, watertight {m.is_watertight}")
    print(f"volume       {m.volume:.1f} mm3")
    line = limits_line(tx.limits)
    if line:
        print(line)
    print(f"seconds      {time.perf_counter() - t0:.2f}")
    print(f"wrote        {', '.join(args.out)}")
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    t = sub.add_parser("texture", help="texture one face of a STEP part; write STL, 3MF, STEP and/or PNG")
    t.add_argument("part", help="PART.step, or a mesh PART.stl / .3mf / .obj (mm)")
    t.add_argument("--face", default="top", help="top, bottom, front, back, left, right, cylinder, extrusion or a face index (default top)")
    t.add_argument("--texture", default="builtin:stones", help="builtin:NAME[:k=v] or an image (default builtin:stones)")
    t.add_argument("--height", type=positive_float, default=1.0, help="texture height in mm (default 1)")
    t.add_argument("--pitch", type=positive_float, default=0.25, help="mm per pixel (default 0.25)")
    t.add_argument("--mapping", choices=("angle", "distance"), default="angle", help="curved faces: algorithm 2 (angle) or 1 (distance)")
    t.add_argument("--rotation", type=float, default=0.0, help="planar faces: turn the texture, degrees")
    add_orientation(t)
    add_mesh_arguments(t)
    t.add_argument("--separate-texture", action="store_true", help="3MF: the texture as its own object of the build item")
    t.add_argument("-o", "--out", action="append", required=True, metavar="OUT", help="OUT.stl, .3mf, .step or .png (repeatable)")
    t.add_argument("-q", "--quiet", action="store_true", help="no progress or warnings")
    t.set_defaults(func=run)
