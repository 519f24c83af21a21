"""Benchmark: the B-rep for further CAD work (issues 6 and 16). Prints seconds per
stage, file sizes and how far OCCT's shown mesh lies from texcad's.

Demo plate: a 100 x 100 x 5 mm plate, its top face textured with ``builtin:stones``
(2 mm) at 800 x 800 px (0.125 mm). Stages: the B-rep (texture tiles carrying texcad's
mesh) built and checked; STEP written (AP242 with the tiles' tessellation) and its
size; the STEP read back and meshed by OCCT at 0.1 mm as a CAD viewer does
(``BRepMesh_IncrementalMesh``, angular 0.5 rad); distances between that mesh and
texcad's; then CAD work on the result: a hole drilled through, a boss united, the
bottom edges filleted, a mirror image (each: mesh + B-rep + checks), and STEP written
again.

    python benchmarks/bench_step.py [--pixels 800] [--plain] [--occt-volume] [--paper] [--sledgehammer]
    python benchmarks/bench_step.py --open 0.125
    python benchmarks/bench_step.py --holes [--pixels 800] [--occt-volume]
    python benchmarks/bench_step.py --sizes [--size 100] [--table docs/benchmarks/step.md] [--rows band,flattened]

``--sizes`` (issue 28): the demo plate (``--size`` mm, stones 2 mm at 0.125 mm, the
demo's default tolerance), the same drilled through, a 30 mm plate drilled through, a
cylinder (stones, knurl), a cone and three faces trimmed inside their (u, v)
rectangle (a drilled full cylinder, a fluted knob cone, a wall with a window), faces
textured together (a box's sides and rounded edges, a band; a top, fillet and side
flattened together; a box's top and two fillets meeting at a mitre, a cylinder's cap
and its fillet: outlines that turn a corner): STEP size against the binary STL's at the same tolerance, seconds to write the STEP, to read it back (OCCT's
``STEPControl_Reader``, as FreeCAD) and to mesh it at 0.1 mm, validity and OCCT's
volume against the mesh; written as a markdown table (machine, date, command) to
``--table``. ``--rows a,b``: only those rows (names as printed).

``--open PITCH``: instead of the plate, the paper's sine and curved samples (open
profiles, tiles sewn in place) with the diamond knurl at PITCH mm: B-rep, OCCT's own
volume, STEP re-read and meshed, and a 4 mm hole drilled through (B-rep checked).
``--holes``: instead, a plate with two holes and a pocket, raised and engraved (tiles
around the holes, planar faces between), STEP, and a hole drilled through.

``--plain`` also writes the plain AP214 STEP (no tessellation; size and time only:
OCCT's mesher then meshes the B-spline tiles itself). ``--paper`` writes the nine
paper samples' STEP at 0.125 mm (recipes/paper_samples.py), ``--sledgehammer`` times
the sledgehammer's B-rep (recipes/sledgehammer.py).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

import texcad
from texcad.brep import check_shape, occt_volume, shape_to_mesh

ROOT = Path(__file__).resolve().parents[1]


def _clock(label: str, fn, times: dict):
    t0, c0 = time.perf_counter(), time.process_time()
    out = fn()
    times[label] = time.perf_counter() - t0
    times[label + " CPU"] = time.process_time() - c0
    print(f"  {label:48s} {times[label]:8.2f} s wall {time.process_time() - c0:8.2f} s CPU", flush=True)
    return out


def _distance(points: np.ndarray, mesh, n: int = 200_000) -> float:
    """Largest distance (mm) from ``n`` of the points (evenly picked) to a mesh's
    triangles (libigl AABB tree)."""
    import igl

    pick = np.asarray(points, np.float64)[np.linspace(0, len(points) - 1, min(n, len(points))).astype(np.int64)]
    d2 = igl.point_mesh_squared_distance(pick, mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64))[0]
    return float(np.sqrt(d2.max()))


def run_plate(pixels: int, out: Path, plain: bool, occt: bool) -> None:
    from build123d import Axis, Cylinder, Pos

    t: dict = {}
    plate = texcad.pipeline.plate_base((100, 100), 5)
    top = plate.faces().sort_by(Axis.Z)[-1]
    print(f"demo plate 100 x 100 mm, stones at {pixels} x {pixels} px ({100 / pixels:g} mm)")
    tx = _clock("texture() (meshes; the B-rep waits)", lambda: texcad.texture(plate, top, "builtin:stones", height=2.0, pitch=100 / pixels), t)
    shape = _clock("B-rep: tiles + checks (BRepCheck, volume)", lambda: tx.shape, t)
    print(f"    {check_shape(shape)['faces']} faces, texcad volume {tx.info['brep_volume']:.1f} mm3, mesh {tx.volume:.1f} mm3")
    if occt:
        vo = _clock("OCCT volume (BRepGProp, eps 1e-4)", lambda: occt_volume(shape), t)
        print(f"    OCCT {vo:.1f} mm3: {abs(vo - tx.volume) / tx.volume:.1e} from the mesh")
    _clock("write STEP (AP242 + tessellation)", lambda: tx.export(out / "plate.step"), t)
    print(f"    {(out / 'plate.step').stat().st_size / 1e6:.1f} MB")
    if plain:
        _clock("write STEP (plain AP214)", lambda: texcad.io.write_step(shape, out / "plain.step", tessellated=False), t)
        print(f"    {(out / 'plain.step').stat().st_size / 1e6:.1f} MB")
    back = _clock("read STEP back (OCCT)", lambda: texcad.io.read_step(out / "plate.step"), t)
    from OCP.BRepMesh import BRepMesh_IncrementalMesh

    _clock("BRepMesh_IncrementalMesh of the re-read STEP, 0.1 mm", lambda: BRepMesh_IncrementalMesh(back, 0.1, False, 0.5, True), t)
    shown = shape_to_mesh(back, tolerance=0.1, angular_tolerance=0.5)  # the triangles it made, as arrays
    chk = check_shape(back)
    print(f"    re-read: valid {chk['valid']}, {chk['solids']} solid; shown mesh {shown.num_triangles} triangles")
    d1, d2 = _distance(shown.vertices, tx.mesh), _distance(tx.mesh.vertices, shown)
    print(f"    shown mesh -> texcad mesh {d1 * 1000:.1f} um, texcad mesh -> shown mesh {d2 * 1000:.1f} um")

    def checked(r):
        s = r.shape  # checked by ops: BRepCheck, solids, texcad's volume
        return r, check_shape(s), r.info["brep_volume"]

    ops = [
        ("hole: - Cylinder(4, 30) at the centre", lambda: tx - Pos(50, 50, 0) * Cylinder(4, 30)),
        ("boss: + Cylinder(5, 6) standing on the texture", lambda: tx + Pos(30, 30, 2) * Cylinder(5, 6)),
        ("fillet r 2 mm on the 4 bottom edges", lambda: tx.fillet(plate.edges().sort_by(Axis.Z)[:4], 2.0)),
        ("mirror about x = 0", lambda: tx.mirrored((0, 0, 0), (1, 0, 0))),
        ("pattern: 2 copies, 120 mm apart", lambda: tx.patterned([Pos(0, 0, 0), Pos(120, 0, 0)])),
    ]
    for label, make in ops:  # one per operation
        r, c, v = _clock(label, lambda: checked(make()), t)
        if label.startswith("pattern"):
            _clock("  write STEP of the pattern", lambda: r.export(out / "pattern.step"), t)
        print(f"    valid {c['valid']}, {c['solids']} solid, B-rep {v:.1f} mm3 vs mesh {r.volume:.1f} mm3 "
              f"({abs(v - r.volume) / r.volume:.1e})")  # fmt: skip
        if label.startswith("hole"):
            _clock("  write STEP of the drilled plate", lambda: r.export(out / "drilled.step"), t)


def _step_shown(tx, path: Path, t: dict, what: str) -> None:
    """STEP written, read back, meshed by OCCT at 0.1 mm; distances to texcad's mesh."""
    from OCP.BRepMesh import BRepMesh_IncrementalMesh

    _clock(f"write STEP of {what}", lambda: tx.export(path), t)
    print(f"    {path.stat().st_size / 1e6:.1f} MB")
    back = _clock("read STEP back (OCCT)", lambda: texcad.io.read_step(path), t)
    _clock("BRepMesh_IncrementalMesh of the re-read STEP, 0.1 mm", lambda: BRepMesh_IncrementalMesh(back, 0.1, False, 0.5, True), t)
    shown = shape_to_mesh(back, tolerance=0.1, angular_tolerance=0.5)
    chk = check_shape(back)
    d1, d2 = _distance(shown.vertices, tx.mesh), _distance(tx.mesh.vertices, shown)
    print(f"    re-read: valid {chk['valid']}, {chk['solids']} solid; shown mesh -> texcad mesh {d1 * 1000:.1f} um, "
          f"texcad mesh -> shown mesh {d2 * 1000:.1f} um")  # fmt: skip


def run_open(out: Path, pitch: float) -> None:
    """The paper's sine and curved samples (open profiles: tiles sewn in place), the
    diamond knurl at ``pitch`` mm: B-rep, OCCT's volume, STEP, a hole drilled through."""
    from build123d import Cylinder, Pos

    sys.path.insert(0, str(ROOT / "recipes"))
    import paper_samples as p

    for kind in ("sine", "curved"):
        t: dict = {}
        build, mapping, _ = p.SAMPLES[kind]
        part, face, _ = build()
        print(f"{kind} sample, builtin:diamond_knurl 0.8 mm at {pitch:g} mm, mapping {mapping}")
        tx = _clock("texture() (meshes; the B-rep waits)", lambda: texcad.texture(part, face, "builtin:diamond_knurl", height=0.8, pitch=pitch, mapping=mapping), t)
        shape = _clock("B-rep: tiles sewn in place + checks", lambda: tx.shape, t)
        print(f"    {check_shape(shape)['faces']} faces, texcad volume {tx.info['brep_volume']:.1f} mm3, mesh {tx.volume:.1f} mm3")
        vo = _clock("OCCT volume (BRepGProp, eps 1e-4)", lambda: occt_volume(shape, 1e-4), t)
        print(f"    OCCT {vo:.1f} mm3: {abs(vo - tx.volume) / tx.volume:.1e} from the mesh")
        _step_shown(tx, out / f"{kind}.step", t, kind)
        bb = part.bounding_box()  # the hole at 61.3 % and 22.7 % of the part's x and y (on the sine: (61.3, 22.7) mm)
        at = (bb.min.X + 0.613 * bb.size.X, bb.min.Y + 0.227 * bb.size.Y, 0.5 * (bb.min.Z + bb.max.Z))
        cut = _clock(f"hole: - Cylinder(4, 60) at ({at[0]:.1f}, {at[1]:.1f}), mesh + B-rep + checks",
                     lambda: tx - Pos(*at) * Cylinder(4, 60), t)  # fmt: skip
        s = _clock("  its B-rep (fine tiles under the tool, OCCT cut, checks)", lambda: cut.shape, t)
        c = check_shape(s)
        vo = _clock("  OCCT volume of it (eps 1e-4)", lambda: occt_volume(s, 1e-4), t)
        print(f"    valid {c['valid']}, {c['solids']} solid, OCCT volume {vo:.1f} mm3 vs mesh {cut.volume:.1f} mm3 "
              f"({abs(vo - cut.volume) / cut.volume:.1e}); removed {tx.volume - cut.volume:.1f} mm3")  # fmt: skip


def run_holes(out: Path, pixels: int, occt: bool) -> None:
    """A 100 x 100 x 5 mm plate with two holes and a pocket, its top textured
    (stones, raised) and the same plate engraved: B-rep (tiles around the holes,
    planar faces between), STEP, a hole drilled through the texture."""
    from build123d import Axis, Box, Cylinder, Pos

    plate = (Box(100, 100, 5) - Pos(-25, 20, 0) * Cylinder(8, 10) - Pos(25, -20, 0) * Cylinder(5, 10)
             - Pos(25, 25, 1.5) * Box(20, 14, 4))  # fmt: skip
    top = plate.faces().sort_by(Axis.Z)[-1]
    for mode in ("raised", "engraved"):
        t: dict = {}
        print(f"plate with 2 holes and a pocket, stones {mode} at {pixels} x {pixels} px ({100 / pixels:g} mm)")
        tx = _clock("texture() (meshes; the B-rep waits)", lambda: texcad.texture(plate, top, "builtin:stones", height=1.0, pitch=100 / pixels, mode=mode), t)
        shape = _clock("B-rep: tiles + planar faces + checks", lambda: tx.shape, t)
        print(f"    {check_shape(shape)['faces']} faces, texcad volume {tx.info['brep_volume']:.1f} mm3, mesh {tx.volume:.1f} mm3")
        if occt:
            vo = _clock("OCCT volume (BRepGProp, eps 1e-4)", lambda: occt_volume(shape, 1e-4), t)
            print(f"    OCCT {vo:.1f} mm3: {abs(vo - tx.volume) / tx.volume:.1e} from the mesh")
        _step_shown(tx, out / f"holes-{mode}.step", t, f"the {mode} plate")
        cut = _clock("hole: - Cylinder(4, 30) at (10, -5), mesh + B-rep + checks", lambda: tx - Pos(10, -5, 0) * Cylinder(4, 30), t)
        s = _clock("  its B-rep (fine tiles under the tool, OCCT cut, checks)", lambda: cut.shape, t)
        c = check_shape(s)
        print(f"    valid {c['valid']}, {c['solids']} solid, B-rep {cut.info['brep_volume']:.1f} mm3 vs mesh {cut.volume:.1f} mm3")


_KINDS = {"CARTESIAN_POINT": "points", "B_SPLINE_SURFACE_WITH_KNOTS": "surfaces", "B_SPLINE_CURVE_WITH_KNOTS": "curves",
          "COMPLEX_TRIANGULATED_FACE": "mesh", "COORDINATES_LIST": "mesh"}  # fmt: skip


def _bytes_by_kind(path: Path) -> dict:
    """Share of a STEP file's bytes per kind of entity: points, B-spline surfaces (their
    pole lists and knots), B-spline curves (3-D and pcurves), the grid mesh (AP242),
    and the rest (topology, lines, placements)."""
    import re

    data = path.read_bytes()
    names = ("points", "surfaces", "curves", "mesh", "rest")
    found = [(m.start(), names.index(_KINDS.get(m.group(1).decode(), "rest")))
             for m in re.finditer(rb"#\d+ ?= ?([A-Z0-9_]*)\(", data)]  # fmt: skip
    at = np.array([a for a, _ in found] + [data.rindex(b"ENDSEC;")], np.int64)
    kind = np.array([k for _, k in found], np.int64)
    out = dict(zip(names, np.bincount(kind, weights=np.diff(at), minlength=len(names)).tolist()))
    total = sum(out.values()) or 1
    return {k: v / total for k, v in out.items()}


def _sizes_row(name: str, tx, out: Path, tessellated: bool = False) -> dict:
    from OCP.BRepGProp import BRepGProp
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.GProp import GProp_GProps

    t: dict = {}
    print(name)
    tx.export(out / f"{name}.stl")
    _clock("B-rep (built and checked; not part of the write)", lambda: tx.shape, t)
    if tessellated:  # every pole and the tiles' grid meshes (AP242)
        _clock("write STEP", lambda: texcad.io.write_step(tx.shape, out / f"{name}.step", tessellated=True), t)
    else:  # what tx.export writes: the B-rep at the mesh's tolerance
        _clock("write STEP", lambda: tx.export(out / f"{name}.step"), t)
    back = _clock("read STEP back (OCCT STEPControl_Reader)", lambda: texcad.io.read_step(out / f"{name}.step"), t)
    _clock("mesh it at 0.1 mm (BRepMesh_IncrementalMesh)", lambda: BRepMesh_IncrementalMesh(back, 0.1, False, 0.5, True), t)
    chk = check_shape(back)
    vo = occt_volume(back)
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(back, props)  # OCCT's default rule (no precision): FreeCAD's, build123d's
    plain = props.Mass()
    row = {
        "part": name,
        "STL MB": (out / f"{name}.stl").stat().st_size / 1e6,
        "STEP MB": (out / f"{name}.step").stat().st_size / 1e6,
        "write s": (t["write STEP"], t["write STEP CPU"]),
        "read s": (t["read STEP back (OCCT STEPControl_Reader)"], t["read STEP back (OCCT STEPControl_Reader) CPU"]),
        "mesh s": (t["mesh it at 0.1 mm (BRepMesh_IncrementalMesh)"], t["mesh it at 0.1 mm (BRepMesh_IncrementalMesh) CPU"]),
        "valid": chk["valid"] and chk["solids"] == 1,
        "volume": (vo - tx.volume) / tx.volume,
        "plain": (plain - tx.volume) / tx.volume,
    }
    row["ratio"] = row["STEP MB"] / row["STL MB"]
    row["kinds"] = _bytes_by_kind(out / f"{name}.step")
    print("    bytes: " + ", ".join(f"{k} {100 * v:.0f} %" for k, v in row["kinds"].items() if v > 0))
    print(f"    STEP {row['STEP MB']:.2f} MB, binary STL {row['STL MB']:.2f} MB: {row['ratio']:.2f}x; valid {row['valid']}; "
          f"OCCT volume {row['volume']:+.1e} from the mesh, plain rule {row['plain']:+.1e}")  # fmt: skip
    return row


def _trimmed_parts() -> dict:
    """Faces trimmed inside their (u, v) rectangle (``texcad.brep.uvtrim``), as
    ``{name: (part, face)}``: a full cylinder drilled through, a knob's cone with four
    slanted flutes, a wall of revolution (spline profile) with a window."""
    from build123d import Align, Axis, Box, BuildLine, BuildPart, BuildSketch, Cone, Cylinder, GeomType, Plane, Polyline
    from build123d import Pos, Rot, SortBy, Spline, make_face, revolve

    drilled = Cylinder(8, 12) - Rot(90, 0, 0) * Cylinder(1.5, 40)
    knob = Cone(10, 6, 12, align=(Align.CENTER, Align.CENTER, Align.MIN))
    for k in range(4):  # four flutes, each leaning 15 degrees
        knob = knob - Rot(0, 0, 90 * k) * Pos(9.5, 0, 6) * Rot(0, -15, 0) * Cylinder(1.6, 20)
    with BuildPart() as wall:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Spline((6, 0), (8, 4), (6.5, 8), (7, 12))
                Polyline((7, 12), (0, 12), (0, 0), (6, 0))
            make_face()
        revolve(axis=Axis.Z)
    window = wall.part - Pos(0, 8, 6) * Rot(0, 0, 30) * Box(3, 6, 7)
    return {
        "trimmed-cylinder": (drilled, drilled.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1]),
        "trimmed-cone": (knob, knob.faces().filter_by(GeomType.CONE).sort_by(SortBy.AREA)[-1]),
        "trimmed-window": (window, window.faces().filter_by(GeomType.REVOLUTION).sort_by(SortBy.AREA)[-1]),
    }


def _band_parts() -> dict:
    """Faces textured together across smooth edges (``texcad.brep.bands``), as
    ``{name: (part, faces)}``: a box's four sides with the rounded vertical edges
    between them (a band), and a box's top, one rounded top edge and the side below
    it flattened together (a flattened patch, conformal)."""
    from build123d import Axis, Box, GeomType, fillet

    box = fillet(Box(30, 20, 10).edges().filter_by(Axis.Z), 4)
    roof = fillet(Box(30, 20, 10).edges().filter_by(Axis.Y).sort_by(Axis.Z)[-1:], 4)
    return {
        "band": (box, [f for f in box.faces() if abs(f.normal_at().Z) < 0.5]),
        "flattened": (roof, [f for f in roof.faces() if f.center().Z > 4.9 or f.center().X > 14.9 or f.geom_type == GeomType.CYLINDER]),
    }


def _corner_parts() -> dict:
    """Faces flattened together whose outline turns a corner
    (``tests/brep/test_band_corners.py``), as ``{name: (part, faces)}``: a 24 x 18 x 8
    mm box, its top edges rounded r 2, its top and the two fillets that meet at a
    mitre; a cylinder r 10 x 8 mm, its top edge rounded r 2, its cap and that fillet;
    an L plate (outline (0, 0), (30, 0), (30, 12), (12, 12), (12, 30), (0, 30), 6 mm
    thick), its top edges rounded r 2, its top and those fillets (a concave mitre at
    the inner corner)."""
    from build123d import Axis, Box, Cylinder, GeomType, Polyline, extrude, fillet, make_face

    box = fillet(Box(24, 18, 8).edges().group_by()[-1], 2)
    cap = fillet(Cylinder(10, 8).edges().sort_by(Axis.Z)[-1:], 2)
    outline = Polyline((0, 0), (30, 0), (30, 12), (12, 12), (12, 30), (0, 30), close=True)
    plate = fillet(extrude(make_face(outline), 6).edges().group_by()[-1], 2)
    return {
        "mitre": (box, [box.faces().sort_by()[-1], *box.faces().filter_by(GeomType.CYLINDER)[:2]]),
        "cap": (cap, [cap.faces().sort_by()[-1], *cap.faces().filter_by(GeomType.TORUS)]),
        "lplate": (plate, [plate.faces().sort_by()[-1], *plate.faces().filter_by(GeomType.CYLINDER)]),
    }


def _sizes_rows(size: float) -> dict:
    """The ``--sizes`` rows, ``{name: () -> (textured, tessellated)}`` (made when run)."""
    from build123d import Axis, Cone, Cylinder, GeomType, Pos

    made: dict = {}

    def plate():  # made once, shared by the plate rows
        if "plate" not in made:
            p = texcad.pipeline.plate_base((size, size), 5)
            made["plate"] = texcad.texture(p, p.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=2.0, pitch=0.125)
        return made["plate"]

    def small():  # the same hole weighs more on a small plate
        p = texcad.pipeline.plate_base((30, 30), 5)
        tx30 = texcad.texture(p, p.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=2.0, pitch=0.125)
        return tx30 - Pos(15, 15, 0) * Cylinder(4, 30)

    def side(part, kind):
        return part.faces().filter_by(kind)[0]

    cyl, cone = Cylinder(10, 30), Cone(12, 8, 20)
    rows = {
        f"plate{size:g}": lambda: (plate(), False),
        f"plate{size:g}-tess": lambda: (plate(), True),
        f"drilled{size:g}": lambda: (plate() - Pos(size / 2, size / 2, 0) * Cylinder(4, 30), False),
        "drilled30-small": lambda: (small(), False),
        "cylinder": lambda: (texcad.texture(cyl, side(cyl, GeomType.CYLINDER), "builtin:stones", height=0.6, pitch=0.125), False),
        "knurl": lambda: (texcad.texture(cyl, side(cyl, GeomType.CYLINDER), "builtin:diamond_knurl", height=0.6, pitch=0.25), False),
        "cone": lambda: (texcad.texture(cone, side(cone, GeomType.CONE), "builtin:stones", height=0.6, pitch=0.125), False),
    }
    for name, (part, face) in _trimmed_parts().items():  # faces trimmed inside their (u, v) rectangle
        rows[name] = lambda part=part, face=face: (texcad.texture(part, face, "builtin:stones", height=0.6, pitch=0.125), False)
    for name, (part, faces) in {**_band_parts(), **_corner_parts()}.items():  # faces textured together
        rows[name] = lambda part=part, faces=faces: (texcad.texture(part, faces, "builtin:stones", height=0.6, pitch=0.125), False)
    return rows


def run_sizes(out: Path, size: float, table: str | None, only: list | None = None) -> None:
    """STEP size against binary STL, re-read and mesh seconds (issue 28): the demo
    plate, the same with a hole drilled through (texcad's ops: fine tiles under the
    tool), a cylinder, a cone, faces trimmed inside their (u, v) rectangle and faces
    textured together (a band, a flattened patch); ``only``: those rows."""
    import platform
    from datetime import datetime, timezone

    makers = _sizes_rows(size)
    unknown = sorted(set(only or ()) - set(makers))
    if unknown:
        raise SystemExit(f"--rows: no row {', '.join(unknown)}; rows: {', '.join(makers)}")
    rows = []
    for name, make in makers.items():  # one per row
        if only and name not in only:
            continue
        tx, tessellated = make()
        rows.append(_sizes_row(name, tx, out, tessellated=tessellated))
    if table:
        parts = {f"plate{size:g}": f"demo plate {size:g} x {size:g} mm, stones 2 mm at 0.125 mm",
                 f"plate{size:g}-tess": "the same, `write_step(tessellated=True)`: every pole + the grid mesh (AP242)",
                 f"drilled{size:g}": "the demo plate with a 8 mm hole drilled through (`tx - Cylinder(4, 30)`)",
                 "drilled30-small": "a 30 x 30 mm plate, stones 2 mm at 0.125 mm, the same hole drilled through",
                 "cylinder": "cylinder r 10 x 30 mm, stones 0.6 mm at 0.125 mm",
                 "knurl": "cylinder r 10 x 30 mm, diamond knurl 0.6 mm at 0.25 mm",
                 "cone": "cone r 12 / 8 x 20 mm, stones 0.6 mm at 0.125 mm (general method: a face in strips)",
                 "trimmed-cylinder": "full cylinder r 8 x 12 mm drilled through (3 mm) before texturing, stones 0.6 mm at 0.125 mm",
                 "trimmed-cone": "knob cone r 10 / 6 x 12 mm with 4 slanted flutes, the same",
                 "trimmed-window": "wall of revolution (spline profile) with a 3 x 7 mm window, the same",
                 "band": "box 30 x 20 x 10 mm, vertical edges rounded r 4: its 4 sides and 4 rounded edges textured together (a band), the same",
                 "flattened": "box 30 x 20 x 10 mm, a top edge rounded r 4, top, fillet and side flattened together, the same",
                 "mitre": "box 24 x 18 x 8 mm, top edges rounded r 2: top and the two fillets meeting at a mitre, the same",
                 "cap": "cylinder r 10 x 8 mm, top edge rounded r 2: cap and fillet flattened together, the same",
                 "lplate": "L plate 30 x 30 x 6 mm (12 mm arms), top edges rounded r 2: top and fillets, the same"}  # fmt: skip
        lines = [
            "# STEP size and re-read time",
            "",
            "Written by `benchmarks/bench_step.py --sizes`; do not edit by hand.",
            "",
            f"- command: `python benchmarks/bench_step.py --sizes --size {size:g} --table {table}"
            + (f" --rows {','.join(only)}`" if only else "`"),
            f"- machine: {platform.machine()}, {os.cpu_count()} cores, {platform.python_version()}, "
            f"load {os.getloadavg()[0]:.1f} (1 min; the machine was shared)",
            f"- date: {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC",
            "",
            "Seconds are wall (CPU): on a shared machine the CPU seconds are what one free core takes.",
            "`Textured.export` writes the B-rep at the mesh's tolerance (0.02 mm; `texcad.io.step_tiles`): each",
            "tile keeps the rows and columns of poles it needs to stay within it of every grid point (inner",
            "poles fitted at even parameters, least squares reweighted towards the smallest largest miss: the",
            "distance to the written tile, whatever its knots), each edge between two tiles the points its",
            "fitted polyline needs, those the tiles beside it keep already first (beside a planar face, fitted",
            "at its own knots), the tiles' straight pcurves short (16 spans where the Gauss order needs them),",
            "knots with 9 decimals, 3 decimals inside the tiles, every point once, the same geometry once,",
            "entities numbered densely, and the whole fine tiles a tool left merged back into tiles; each run of",
            "edges between the same two faces is one edge, parametrised for OCCT's plain rule, and a tile is",
            "mirrored where that puts fewer of its edges on the side that rule integrates to; an edge along",
            "which no face's plain rule integrates is parametrised by one face's iso coordinate, so that its",
            "pcurves there are lines, and the entities are numbered by how often they are used. A hole's",
            "rim adds OCCT's intersection curves and the small tiles it trims (most on a small plate); the fine",
            "tiles a tool leaves are merged only where the merged knots suit OCCT's plain rule. Faces textured",
            "by the general method (the cone, faces trimmed inside their (u, v) rectangle) are written at the",
            "tolerance too, the sides of their strips and pieces along v kept one edge per run (one Gauss rule",
            "each). OCCT then meshes the B-spline tiles itself. The tessellated STEP",
            "carries texcad's grid mesh, which viewers show at once. OCCT volume: the re-read STEP's",
            "(`BRepGProp`: adaptive to 1e-4, texcad's `occt_volume`; plain: its default rule, FreeCAD's and",
            "build123d's); the mesh may differ by its own tolerance times its area (a lean mesh's",
            "`volume_slack`). Binary STL: the lean mesh at the same tolerance; a tile keeps whole rows and",
            "columns of poles where the STL keeps single vertices, so the ratio is highest on low reliefs at",
            "fine pitches (the cylinder rows).",
            "",
            "Bytes: the STEP's share in points (`CARTESIAN_POINT`), B-spline surfaces (pole lists, knots), B-spline",
            "curves (3-D and pcurves), the grid mesh (AP242) and the rest (topology, lines, placements).",
            "",
            "| part | binary STL MB | STEP MB | STEP / STL | bytes: points / surfaces / curves / mesh / rest % | write s | OCCT read s | OCCT mesh 0.1 mm s | valid solid | OCCT volume vs mesh | plain |",
            "|---|---:|---:|---:|---|---:|---:|---:|---|---:|---:|",
        ]
        for r in rows:  # one per part
            w, rd, m = (f"{r[k][0]:.1f} ({r[k][1]:.1f})" for k in ("write s", "read s", "mesh s"))
            kinds = " / ".join(f"{100 * v:.0f}" for v in r["kinds"].values())
            lines.append(f"| {parts[r['part']]} | {r['STL MB']:.2f} | {r['STEP MB']:.2f} | {r['ratio']:.2f} | {kinds} | {w} | {rd} | {m} | "
                         f"{'yes' if r['valid'] else 'NO'} | {100 * r['volume']:+.3f} % | {100 * r['plain']:+.3f} % |")  # fmt: skip
        Path(table).parent.mkdir(parents=True, exist_ok=True)
        Path(table).write_text("\n".join(lines) + "\n")
        print(f"wrote {table}")


def run_paper(out: Path) -> None:
    env = dict(os.environ, TEXCAD_PITCH="0.125", TEXCAD_OUT=str(out / "paper"), PYTHONPATH=str(ROOT))
    code = (
        "import sys, time, warnings; sys.path.insert(0, 'recipes'); import paper_samples as p, texcad\n"
        "warnings.simplefilter('ignore')\n"
        "p.OUT.mkdir(parents=True, exist_ok=True)\n"
        "for tex, kind, tilt in p.TABLE2:\n"
        "    name = f'{tex}-{kind}'; build, mapping, toward = p.SAMPLES[kind]\n"
        "    part, face, width = build(); hm = p.synthesized(tex, width); d = texcad.orientation(tilt, toward)\n"
        "    tx = texcad.texture(part, face, hm, mapping=mapping, build_dir=d)\n"
        "    t0 = time.perf_counter()\n"
        "    try:\n"
        "        tx.export(p.OUT / f'{name}.step'); mb = (p.OUT / f'{name}.step').stat().st_size / 1e6\n"
        "        print(f'  {name:12s} STEP at 0.125 mm {time.perf_counter() - t0:7.1f} s {mb:7.1f} MB', flush=True)\n"
        "    except texcad.TexcadError as e:\n"
        "        print(f'  {name:12s} FAILED after {time.perf_counter() - t0:.1f} s: {e}', flush=True)\n"
    )
    print("paper samples (recipes/paper_samples.py), B-rep + STEP at 0.125 mm")
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, check=False)


def run_sledgehammer(out: Path) -> None:
    env = dict(os.environ, TEXCAD_OUT=str(out / "sledge"), PYTHONPATH=str(ROOT))
    code = (
        "import runpy, time, warnings, sys; warnings.simplefilter('ignore'); sys.argv = ['sledgehammer.py']\n"
        "import builtins; real_print = builtins.print; builtins.print = lambda *a, **k: None\n"
        "g = runpy.run_path('recipes/sledgehammer.py', run_name='bench')\n"
        "builtins.print = real_print\n"
        "import texcad\n"
        "part = texcad.texture(g['handle'], g['grip_face'], g['grip'], mapping='angle', periodic_x=True, build_dir=(0, 1, 0))\n"
        "t0 = time.perf_counter(); shape = part.shape; t1 = time.perf_counter()\n"
        "print(f'  sledgehammer grip B-rep (grid {part.info[\"grid\"]}, {texcad.brep.check_shape(shape)[\"faces\"]} faces) '\n"
        "      f'{t1 - t0:7.1f} s, {part.info[\"brep_volume\"]:.1f} mm3 vs mesh {part.volume:.1f} mm3', flush=True)\n"
    )
    print("sledgehammer (recipes/sledgehammer.py)")
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env, check=False)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pixels", type=int, default=800)
    ap.add_argument("--plain", action="store_true", help="also write the plain AP214 STEP")
    ap.add_argument("--occt-volume", action="store_true", help="also OCCT's adaptive volume of the plate (minutes)")
    ap.add_argument("--paper", action="store_true", help="the nine paper samples' STEP at 0.125 mm")
    ap.add_argument("--sledgehammer", action="store_true", help="the sledgehammer's B-rep")
    ap.add_argument("--open", type=float, default=None, metavar="PITCH", help="only the sine and curved samples at PITCH mm")
    ap.add_argument("--holes", action="store_true", help="only the plate with holes (raised and engraved)")
    ap.add_argument("--sizes", action="store_true", help="only STEP size vs binary STL and re-read seconds (issue 28)")
    ap.add_argument("--size", type=float, default=100.0, help="--sizes: the plate's side, mm")
    ap.add_argument("--table", default=None, help="--sizes: write the markdown table here")
    ap.add_argument("--rows", default=None, help="--sizes: only these rows (comma-separated names, e.g. band,flattened)")
    args = ap.parse_args()
    import build123d  # noqa: F401  (import cost is not part of the job)

    print(f"load: {os.getloadavg()[0]:.1f} (1 min), {os.cpu_count()} cores")
    with warnings.catch_warnings(), tempfile.TemporaryDirectory() as d:
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        if args.open is not None:
            run_open(Path(d), args.open)
        elif args.holes:
            run_holes(Path(d), args.pixels, args.occt_volume)
        elif args.sizes:
            run_sizes(Path(d), args.size, args.table, args.rows.split(",") if args.rows else None)
        else:
            run_plate(args.pixels, Path(d), args.plain, args.occt_volume)
        if args.paper:
            run_paper(Path(d))
        if args.sledgehammer:
            run_sledgehammer(Path(d))
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory (max RSS) {peak:.0f} MB; load now {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
