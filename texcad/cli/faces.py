"""``texcad faces PART.step``: every face of a part with its number, and the
``--face`` selectors that pick it; ``--png faces.png`` draws the part with the face
numbers on it. ``texcad faces PART.stl`` (3MF, OBJ): a mesh has no faces to name, so
what each usual ``--region`` spec picks on it (faces, area, centre).

One line per face: index, solid, type, area (mm2), centre (mm), the normal at the
centre (planar and free-form faces) or the axis (cylinders, cones, tori, surfaces of
revolution; the centre for spheres), then the selectors of ``texcad texture --face``
that pick it (``top``, ``cylinder``, ``cylinder:2``, ``normal:0,0,1``, its index).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["face_table", "add", "run"]

_AXIS_KINDS = ("CYLINDER", "CONE", "TORUS", "REVOLUTION", "EXTRUSION", "SPHERE")


def _axis(face: Any) -> tuple[str, tuple[float, ...]] | None:
    """``("axis" | "centre" | "direction", numbers)`` of a curved face, from OCCT's
    surface adaptor, or None for planes and free-form faces."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.GeomAbs import GeomAbs_Cone, GeomAbs_Cylinder, GeomAbs_Sphere, GeomAbs_SurfaceOfExtrusion, GeomAbs_SurfaceOfRevolution, GeomAbs_Torus

    ad = BRepAdaptor_Surface(face.wrapped)
    t = ad.GetType()
    ax = None
    if t == GeomAbs_Cylinder:
        ax = ad.Cylinder().Axis()
    elif t == GeomAbs_Cone:
        ax = ad.Cone().Axis()
    elif t == GeomAbs_Torus:
        ax = ad.Torus().Axis()
    elif t == GeomAbs_SurfaceOfRevolution:
        ax = ad.AxeOfRevolution()
    elif t == GeomAbs_Sphere:
        return "sphere_centre", tuple(ad.Sphere().Location().Coord())
    elif t == GeomAbs_SurfaceOfExtrusion:
        return "direction", tuple(ad.Direction().Coord())
    if ax is None:
        return None
    return "axis", tuple(ax.Location().Coord()) + tuple(ax.Direction().Coord())


def _solid_of(part: Any, faces: list) -> list[int]:
    """Per face, the index of the solid of ``part`` that owns it (-1: none)."""
    owner = [-1] * len(faces)
    by_hash: dict[int, list[int]] = {}
    for i, f in enumerate(faces):  # per face
        by_hash.setdefault(hash(f), []).append(i)
    for k, solid in enumerate(part.solids()):  # per solid
        for g in solid.faces():
            for i in by_hash.get(hash(g), []):
                if owner[i] < 0 and faces[i].is_same(g):
                    owner[i] = k
    return owner


def _selectors(part: Any, faces: list) -> list[list[str]]:
    """Per face, the ``--face`` selectors (:func:`texcad.brep.selectors.named`)
    that pick it (alone, or among others for ``normal:``)."""
    from ..brep.selectors import DIRECTIONS, named as pick_faces

    sel: list[list[str]] = [[] for _ in faces]

    def mark(which: str) -> None:
        try:
            hit = pick_faces(part, which)
        except Exception:  # a selector that picks nothing on this part
            return
        for h in hit:
            for i, f in enumerate(faces):
                if f.is_same(h):
                    sel[i].append(which)

    for word in DIRECTIONS:  # per direction word
        mark(word)
    kinds: dict[str, list[int]] = {}
    for i, f in enumerate(faces):
        kinds.setdefault(f.geom_type.name.lower(), []).append(i)
    for kind, idx in kinds.items():  # per face type: the largest, then TYPE:i
        mark(kind)
        for j, i in enumerate(idx):
            sel[i].append(f"{kind}:{j}")
    for i, f in enumerate(faces):
        if f.geom_type.name == "PLANE":
            n = f.normal_at(f.center())
            sel[i].append("normal:" + ",".join(f"{c:.3g}" for c in (n.X + 0.0, n.Y + 0.0, n.Z + 0.0)))
        sel[i].append(str(i))
    return sel


def face_table(part: Any) -> list[dict]:
    """One dict per face of a build123d shape, in ``part.faces()`` order: ``index``,
    ``solid``, ``type``, ``area`` (mm2), ``centre`` (mm), ``normal`` (unit, at the
    centre) or, for a curved face, ``axis`` (point and unit direction, mm),
    ``sphere_centre`` or ``direction`` (extrusions), and ``selectors``."""
    faces = list(part.faces())
    solids = _solid_of(part, faces)
    sels = _selectors(part, faces)
    rows = []
    for i, f in enumerate(faces):  # per face
        c = f.center()
        row = {"index": i, "solid": solids[i], "type": f.geom_type.name.lower(), "area": float(f.area),
               "centre": (c.X, c.Y, c.Z), "selectors": sels[i]}
        geo = _axis(f) if f.geom_type.name in _AXIS_KINDS else None
        if geo is None:
            n = f.normal_at(c)
            row["normal"] = (n.X, n.Y, n.Z)
        else:
            row[geo[0]] = geo[1]
        rows.append(row)
    return rows


def _fmt(v: tuple) -> str:
    return "(" + ", ".join(f"{round(x, 3) + 0.0:.3f}" for x in v) + ")"


def _line(row: dict) -> str:
    if "axis" in row:
        text = f"axis {_fmt(row['axis'][3:])} through {_fmt(row['axis'][:3])}"
    elif "sphere_centre" in row:
        text = f"sphere centre {_fmt(row['sphere_centre'])}"
    elif "direction" in row:
        text = f"direction {_fmt(row['direction'])}"
    else:
        text = f"normal {_fmt(row['normal'])}"
    return (f"{row['index']:>5}  {row['solid']:>5}  {row['type']:<10} {row['area']:>12.3f}  {_fmt(row['centre']):<30} "
            f"{text:<55} {' '.join(row['selectors'])}")


def draw_faces(part: Any, path: str, *, width: int = 1200, view=(-1.0, 2.0, -1.2), tolerance: float = 0.05) -> int:
    """A PNG of ``part`` with each visible face in its own colour and its number at
    the middle of what is seen of it; returns how many numbers were drawn."""
    from PIL import Image, ImageDraw, ImageFont

    from ..render import render_mesh
    from ..solid import Mesh
    from ..util import atomic_path

    verts, tris, owner = [], [], []
    off = 0
    for i, f in enumerate(part.faces()):  # per face: its own triangles
        pts, tri = f.tessellate(tolerance, 0.2)
        if not tri:
            continue
        verts.append(np.array([(p.X, p.Y, p.Z) for p in pts], dtype=np.float64))
        tris.append(np.asarray(tri, dtype=np.int64) + off)
        owner.append(np.full(len(tri), i))
        off += len(pts)
    mesh = Mesh(np.concatenate(verts).astype(np.float32), np.concatenate(tris).astype(np.uint32))
    owner = np.concatenate(owner)
    golden = (np.arange(owner.max() + 1) * 0.618034) % 1.0  # distinct hues, pale
    hue = np.stack([0.55 + 0.35 * np.cos(2 * np.pi * (golden + k / 3)) for k in range(3)], axis=1)
    img, info = render_mesh(mesh, view=view, width=int(width), supersample=1, face_colors=hue[owner], return_info=True)
    from scipy.ndimage import distance_transform_edt

    fid = info["face"]
    label = np.where(fid >= 0, owner[np.maximum(fid, 0)], -1)  # B-rep face seen at each pixel
    inner = np.ones(label.shape, dtype=bool)  # pixels whose neighbours show the same face
    inner[1:] &= label[1:] == label[:-1]
    inner[:-1] &= label[:-1] == label[1:]
    inner[:, 1:] &= label[:, 1:] == label[:, :-1]
    inner[:, :-1] &= label[:, :-1] == label[:, 1:]
    depth = distance_transform_edt(inner)  # distance to the face's seen outline, px
    seen = np.flatnonzero(label.ravel() >= 0)
    who, dist = label.ravel()[seen], depth.ravel()[seen]
    order = np.lexsort((-dist, who))  # per face, its deepest pixel first
    first = order[np.r_[True, who[order][1:] != who[order][:-1]]]
    pic = Image.fromarray((np.clip(img[::-1], 0, 1) * 255).astype(np.uint8))  # y-up to image rows
    draw = ImageDraw.Draw(pic)
    try:
        font = ImageFont.load_default(size=max(12, int(width) // 60))
    except TypeError:  # Pillow < 10.1: one size
        font = ImageFont.load_default()
    h, w = label.shape
    drawn = 0
    for k in first[dist[first] >= 4]:  # per face seen: its number where it is widest
        y, x = divmod(int(seen[k]), w)
        draw.text((x, h - 1 - y), str(int(who[k])), fill=(0, 0, 0), anchor="mm", font=font, stroke_width=2,
                  stroke_fill=(255, 255, 255))
        drawn += 1
    with atomic_path(path) as tmp:
        pic.save(tmp, format="PNG")
    return drawn


def _as_textured(part: str, load_mesh: Any) -> tuple[Any, bool]:
    """``(mesh, repaired)``: the mesh as texturing reads it (repaired: merged, wound
    outward), so that the regions listed are those ``texcad texture`` picks; as read
    (``repaired`` False) if it cannot be repaired."""
    from ..errors import InputError
    from ..solid import Mesh
    from ..targets.mesh import load_closed

    try:
        v, f, _, _ = load_closed(part, crossing=False)
    except InputError:  # open or non-manifold: listed as it is (texture would refuse it, saying why)
        return load_mesh(part), False
    return Mesh(v.astype(np.float32), f.astype(np.uint32)), True


def _mesh_regions(args: argparse.Namespace) -> int:
    """A mesh has no faces to name: what each ``--region`` spec picks on it."""
    from ..errors import ParameterError
    from ..io import load_mesh
    from ..mapping.region import region_table

    if args.png:
        raise ParameterError(f"--png draws a STEP part's face numbers; {args.part!r} is a mesh: draw it with texcad render")
    t0 = time.perf_counter()
    mesh, repaired = _as_textured(args.part, load_mesh)
    print(f"{'region':<14} {'faces':>9} {'area mm2':>12}  centre mm")
    for row in region_table(mesh, repaired=repaired):  # thirteen rows
        centre = _fmt(row["centre"]) if row["centre"] is not None else "-"
        print(f"{row['region']:<14} {row['faces']:>9} {row['area']:>12.3f}  {centre}")
    print(f"triangles    {len(mesh.faces)} of {args.part}, printed along +z (texcad texture PART --region SPEC; "
          "box:, sphere: and paint: regions too, see --help)")
    print(f"seconds      {time.perf_counter() - t0:.2f}")
    return 0


def run(args: argparse.Namespace) -> int:
    from build123d import Compound

    from ..io import read_step
    from ._args import step_part
    from ._outputs import check_outputs

    suffix = Path(args.part).suffix.lower()
    if suffix in (".stl", ".3mf", ".obj"):
        return _mesh_regions(args)
    step_part(args.part)  # a PLY, OFF, GLB...: refused naming the formats texcad reads
    if args.png:
        check_outputs([args.png], (".png",))
    t0 = time.perf_counter()
    part = Compound(read_step(args.part))
    rows = face_table(part)
    print(f"{'face':>5}  {'solid':>5}  {'type':<10} {'area mm2':>12}  {'centre mm':<30} {'normal / axis':<55} selectors")
    for row in rows:  # per face
        print(_line(row))
    print(f"faces        {len(rows)} in {len(part.solids())} solid(s) of {args.part}")
    if args.png:
        drawn = draw_faces(part, args.png, width=args.width, view=args.view)
        print(f"wrote        {args.png} ({drawn} face numbers shown from this view)")
    print(f"seconds      {time.perf_counter() - t0:.2f}")
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    from ._args import vector

    p = sub.add_parser("faces", help="list a STEP part's faces (number, type, area, centre, normal, selectors), "
                       "or what each --region picks on an STL/3MF/OBJ mesh")
    p.add_argument("part", help="PART.step, or a mesh PART.stl / .3mf / .obj (mm)")
    p.add_argument("--png", default=None, metavar="OUT.png", help="also draw the part with the face numbers on it")
    p.add_argument("--width", type=int, default=1200, help="--png: picture width in pixels (default 1200)")
    p.add_argument("--view", type=vector, default=(-1.0, 2.0, -1.2), metavar="X,Y,Z",
                   help="--png: direction the camera looks along (default -1,2,-1.2)")
    p.set_defaults(func=run)
