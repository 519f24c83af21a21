"""Slicer check (issues 15, 29): slice texcad's outputs with PrusaSlicer's and
CuraEngine's CLIs (texcad.report.slicer) and read the G-code.

    python benchmarks/bench_slicer.py table       [--pitch 0.25]
    python benchmarks/bench_slicer.py cost        [--pitch 0.25] [--demo-pitch 0.25] [--demo-side 100] [--no-demo]
    python benchmarks/bench_slicer.py levers      [--demo-pitch 0.25] [--demo-side 40]
    python benchmarks/bench_slicer.py demo        [--timeout 900]
    python benchmarks/bench_slicer.py support     [--pitch 0.25]
    python benchmarks/bench_slicer.py perimeters  [--side 40]
    python benchmarks/bench_slicer.py recipes     [--pitch 0.5] [--only T1-flat,sledgehammer] [--fast] [--compare]

* ``table``: recipes' parts limited for their build direction (small and at
  ``--pitch``, as the slicer tests make them), bare and textured, in both slicers
  with support on at threshold 45 (the critical angle): support in m and CPU
  seconds of each slice; written to docs/benchmarks/slicer.md (machine, date,
  command) for the printing guide.
* ``cost``: PrusaSlicer's CPU seconds at its defaults for the demo plate (stones
  grown over 100 x 100 mm at ``--demo-pitch``) and the ``table`` parts: bare,
  textured as an STL, textured as the 3MF texcad writes (per-object settings from
  ``texcad.io.slicer_settings``), and the largest per-layer distance between the
  STL's and the 3MF's toolpaths; written to docs/benchmarks/slicer_cost.md.
* ``levers``: candidate ways to cut the slicing time (per-object settings, the
  print profile's slice resolution, a coarser mesh), each on a 40 x 40 mm piece
  of the demo plate: CPU seconds and how far the toolpaths move from the STL's at
  PrusaSlicer's defaults; written to docs/benchmarks/slicer_levers.md.
* ``demo``: the demo plate (800 x 800 px stones, 100 x 100 mm, as ``texcad demo``
  makes it) with one vertex per pixel (tolerance 0) and lean (default tolerance),
  side by side: slicing time and peak memory with PrusaSlicer's defaults, and with
  "detect bridging perimeters" (``overhangs``) off. A slice that runs past
  ``--timeout`` is reported as such.
* ``support``: parts limited for their build direction, sliced with
  ``support_material = 1, support_material_threshold = 45`` (the critical angle):
  support path length in total, next to the texture (support points below a
  texture face, within 1 mm across), and for the bare part (what it needs anyway);
  the old limiter margin (0.1 deg) next to the new one (SLICER_MARGIN).
* ``recipes``: the recipes that print along a build direction (the paper samples,
  the sledgehammer, the enclosure, the lever ball; lean at their default
  tolerance) run at ``--pitch`` and sliced with support on at the critical angle
  (threshold 45): support in total, support points within 1 mm below the texture
  (its own part of the 3MF), and the bare base part's support (sliced when there
  is support at all). ``--fast`` turns "detect bridging perimeters" off, which
  does not change the support but the slice time (a 74 k-triangle flat sample at
  0.5 mm took 750 s with it on at load average 5). ``--compare`` makes every part
  on the pixel grid (tolerance 0) too and slices both, side by side.
* ``perimeters``: what makes the default perimeter analysis slow: a smaller stones
  plate at several tolerances, ``overhangs`` on and off, with the G-code's
  perimeter and overhang-perimeter lengths.

Other processes slow every figure: the load average is printed with them.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

NOZZLE = 0.4  # mm, both slicers' default
SUPPORT = {"support-material": True, "support-material-threshold": 45}
#: mm: how closely the table's bare parts follow their CAD surfaces (``_table_parts``).
BARE_TOLERANCE = 0.002


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def row(label: str, rep, extra: str = "") -> None:
    if rep is None:
        print(f"{label:44s} timed out")
        return
    ov = rep.lengths.get("Overhang perimeter", 0.0) / 1000
    print(
        f"{label:44s} {rep.seconds:8.1f} s ({rep.cpu_seconds:7.1f} s CPU) {rep.peak_mb:8.0f} MB  support {rep.support_mm / 1000:8.2f} m  "
        f"overhang perimeter {ov:7.2f} m  layers {rep.layers:4d}  rc {rep.returncode} {extra}"
    )


def sliced(mesh, timeout: float, **kw):
    from texcad.errors import ResourceError
    from texcad.report.slicer import slice_mesh

    try:
        return slice_mesh(mesh, timeout=timeout, **kw)
    except ResourceError:
        return None


def demo(args) -> None:
    from build123d import Axis

    from bench_lean import demo_heightmap
    from texcad import texture
    from texcad.solid import DEFAULT_TOLERANCE
    from texcad.pipeline import plate_base

    plate = plate_base((100.0, 100.0), 5.0)
    face = plate.faces().sort_by(Axis.Z)[-1]
    hm = demo_heightmap()
    for tol in (0.0, DEFAULT_TOLERANCE):
        part = texture(plate, face, hm, brep=False, tolerance=tol)
        m = part.mesh
        for cfg, what in (({}, "defaults"), ({"overhangs": False}, "overhangs off")):
            print(f"  load {load()}", flush=True)
            row(f"demo tol {tol:g} ({m.num_triangles} tri), {what}", sliced(m, args.timeout, config=cfg))


def support(args) -> None:
    import numpy as np
    from build123d import Align, Axis, Box

    import texcad
    from texcad.printability import SLICER_MARGIN, limit_overhangs, orientation
    from texcad.report.slicer import support_near

    def report(label, mesh, tex, d, bare):
        r = sliced(mesh, args.timeout, build_dir=d, config=SUPPORT)
        if r is None:
            row(label, None)
            return
        near = support_near(r.support_points, tex, np.arange(tex.num_triangles), d)
        rb = sliced(bare, args.timeout, build_dir=d, config=SUPPORT)
        bare_m = rb.support_mm / 1000 if rb else float("nan")
        row(label, r, f" near texture {near} pts  bare part {bare_m:.2f} m")

    pitch = args.pitch
    hm = texcad.builtin("diamond_knurl", size=(20, 20), pitch=pitch, height=1.0)
    for tilt in (90, 60):
        d = orientation(tilt, "+y")
        for margin in (0.1, SLICER_MARGIN):
            lim, _ = limit_overhangs(hm, d, margin=margin)
            tp = texcad.pipeline.textured_plate(lim, size=(20, 20), thickness=4, tolerance=0)
            report(f"knurl plate tilt {tilt}, margin {margin:g}", tp.mesh, tp.texture_mesh, d, tp.base_mesh)
        tp = texcad.pipeline.textured_plate(hm, size=(20, 20), thickness=4, tolerance=0)
        report(f"knurl plate tilt {tilt}, not limited", tp.mesh, tp.texture_mesh, d, tp.base_mesh)
    box = Box(20, 16, 12, align=(Align.MIN, Align.MIN, Align.MIN))
    side = box.faces().sort_by(Axis.X)[-1]
    up = (0.0, 0.0, 1.0)
    bare = texcad.brep.shape_to_mesh(box)
    for name in ("diamond_knurl", "stones"):
        t = texcad.builtin(name, size=(16, 12), pitch=pitch, height=1.0)
        for bd in (None, up):
            tx = texcad.texture(box, side, t, brep=False, build_dir=bd)
            label = f"box side wall {name}, {'limited' if bd else 'not limited'}"
            report(label, tx.mesh, tx.texture_mesh, up, bare)
    if args.sledgehammer:
        os.environ.setdefault("TEXCAD_PITCH", str(pitch))
        os.environ.setdefault("TEXCAD_OUT", "/tmp/texcad-bench-sledgehammer")
        import runpy

        g = runpy.run_path(str(Path(__file__).resolve().parents[1] / "recipes" / "sledgehammer.py"))
        part = g["part"]
        report("sledgehammer (recipe), +y", part.mesh, part.texture_mesh, (0, 1, 0), texcad.brep.shape_to_mesh(g["handle"]))


#: Recipes that print along a build direction: script -> build direction (world frame).
RECIPE_DIRS = {"sledgehammer": (0, 1, 0), "enclosure": (0, 0, 1), "lever_ball": (0, 0, 1)}


def _run_recipe(script: str, out: Path, pitch: float, tolerance: "float | None") -> None:
    import subprocess

    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, TEXCAD_OUT=str(out), TEXCAD_PITCH=str(pitch), PYTHONPATH=str(root))
    if tolerance is not None:
        env["TEXCAD_TOLERANCE"] = str(tolerance)
    r = subprocess.run([sys.executable, str(root / "recipes" / f"{script}.py")], env=env, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{script} failed:\n{r.stderr[-2000:]}")


def _outputs(out: Path) -> list[tuple[str, Path, tuple]]:
    """(name, 3MF with base and texture parts, build direction) of a recipe's outputs."""
    import json

    js = out / "paper_samples.json"
    if js.exists():
        return [(s["sample"], out / f"{s['sample']}.3mf", tuple(s["build_dir"])) for s in json.loads(js.read_text())["samples"]]
    name = out.name
    return [(name, p, RECIPE_DIRS[name]) for p in sorted(out.glob("*.3mf")) if p.with_suffix(".stl").exists()]


def recipes(args) -> None:
    import tempfile

    import numpy as np

    from texcad.io import read_part, read_mesh
    from texcad.report.slicer import support_near

    scripts = ["paper_samples", *RECIPE_DIRS]
    only = set(args.only.split(",")) if args.only else None
    tols = (0.0, None) if args.compare else (None,)  # the grid and/or the recipes' own (default) tolerance
    with tempfile.TemporaryDirectory() as tmp:
        for script in scripts:  # one recipe run per script and tolerance
            for tol in tols:
                out = Path(tmp) / ("grid" if tol == 0.0 else "lean") / script
                out.mkdir(parents=True)
                if script == "paper_samples" and only:
                    os.environ["TEXCAD_SAMPLES"] = ",".join(n for n in only if n[:1] == "T")
                elif only and script not in only:
                    continue
                _run_recipe(script, out, args.pitch, tol)
                for name, path, d in _outputs(out):  # one per written part
                    if not path.exists():
                        continue
                    parts = dict(read_part(path))
                    tex = next((m for k, m in parts.items() if "texture" in k.lower()), None)
                    whole = read_mesh(path.with_suffix(".stl"))
                    print(f"  load {load()}", flush=True)
                    cfg = {**SUPPORT, **({"overhangs": False} if args.fast else {})}
                    r = sliced(whole, args.timeout, build_dir=d, config=cfg)
                    label = f"{name} {'grid' if tol == 0.0 else 'lean'} ({whole.num_triangles} tri)"
                    if r is None or tex is None:
                        row(label, r, "" if tex is not None else "(no texture part)")
                        continue
                    near = support_near(r.support_points, tex, np.arange(tex.num_triangles), d)
                    base = next((m for k, m in parts.items() if m is not tex), None)
                    rb = sliced(base, args.timeout, build_dir=d, config=cfg) if (base is not None and r.support_mm > 0) else None
                    bare = f"{rb.support_mm / 1000:.2f} m" if rb else ("-" if r.support_mm == 0 else "n/a")
                    row(label, r, f" near texture {near} pts  bare part {bare}")


def perimeters(args) -> None:
    import texcad

    side = args.side
    hm = texcad.builtin("stones", size=(side, side), pitch=0.125, height=2.0)
    for tol in args.tolerances:
        tp = texcad.pipeline.textured_plate(hm, size=(side, side), thickness=3, tolerance=tol)
        # PrusaSlicer's "resolution" simplifies the slice contours (0 = off): if the
        # time goes with the contours' vertex count, it goes down with it.
        cfgs = [({}, "defaults"), ({"overhangs": False}, "overhangs off"), ({"resolution": args.resolution}, f"resolution {args.resolution:g}")]
        for cfg, what in cfgs:
            print(f"  load {load()}", flush=True)
            row(f"stones {side:g} mm tol {tol:g} ({tp.mesh.num_triangles} tri), {what}", sliced(tp.mesh, args.timeout, config=cfg))


# -- table (issue 29): both slicers, bare and textured --------------------------------
def _table_parts(pitch: float):
    """(name, build direction (label), bare mesh, textured mesh, build direction) of
    recipes' parts, small: the same parts the slicer tests slice."""
    import warnings

    import numpy as np
    from build123d import Align, Axis, Box, BuildPart, BuildSketch, Cylinder, Ellipse, GeomType, Plane, Polyline, Pos, SortBy, Sphere, Spline, extrude, loft, make_face

    import texcad

    up = np.array([0.0, 0.0, 1.0])
    out = []
    # The bare parts tessellated finer than the textures' pitch: at the default (0.01 mm,
    # 0.1 rad) a sphere's facets span 5.7 degrees and move its own overhang boundary
    # (the lever ball's bare support: 6.94 m at the default, 7.01 m at this).
    bare = lambda shape: texcad.brep.shape_to_mesh(shape, tolerance=BARE_TOLERANCE, angular_tolerance=0.05)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        box = Box(20, 16, 12, align=(Align.MIN, Align.MIN, Align.MIN))
        hm = texcad.builtin("diamond_knurl", size=(16, 12), pitch=pitch, height=1.0)
        tx = texcad.texture(box, box.faces().sort_by(Axis.X)[-1], hm, brep=False, build_dir=up)
        out.append(("enclosure-like box side, diamond knurl", "+z", bare(box), tx.mesh, up))
        k, L = 2 * np.pi / 25.0, 30.0
        x = np.linspace(0, L, 49)
        top = Spline(*[(a, 3.0 * np.sin(k * a)) for a in x], tangents=[(1, 3.0 * k), (1, 3.0 * k * np.cos(k * L))])
        part = extrude(Plane.XZ * make_face([top, Polyline(top @ 1, (L, -7.0), (0, -7.0), (0, 0))]), amount=-20)
        d = texcad.orientation(30, "+x")
        hm = texcad.builtin("leather", size=(texcad.Profile.sine(3.0, 25.0, L).length, 20), pitch=pitch, height=1.0, scale=2.0)
        tx = texcad.texture(part, part.faces().sort_by(SortBy.AREA)[-1], hm, mapping="distance", build_dir=d, brep=False)
        out.append(("paper T3 sine (30 x 20 mm)", "tilt 30 +x", bare(part), tx.mesh, d))
        d = texcad.orientation(90, "+y")
        tp = texcad.pipeline.textured_plate(texcad.builtin("stones", size=(20, 20), pitch=pitch, height=1.0), size=(20, 20), thickness=4, build_dir=d)
        out.append(("flat plate stones (20 x 20 mm)", "upright +y", tp.base_mesh, tp.mesh, d))
        lever = Cylinder(3, 20, align=(Align.CENTER, Align.CENTER, Align.MIN)) + Pos(0, 0, 26) * Sphere(8)
        tx = texcad.texture(lever, lever.faces().filter_by(GeomType.SPHERE), "builtin:dimples", height=0.5, pitch=pitch, build_dir=up, brep=False)
        out.append(("lever ball, dimples", "+z", bare(lever), tx.mesh, up))
        with BuildPart() as grip:
            for z, (a, b) in zip((0, 30, 60, 90), ((12, 9), (15, 11), (13, 10), (11, 8))):
                with BuildSketch(Plane.XY.offset(z)):
                    Ellipse(a, b)
            loft()
        tx = texcad.texture(grip.part, grip.part.faces().filter_by(GeomType.BSPLINE), "builtin:leather", height=0.6, pitch=pitch,
                            build_dir=up, brep=False)
        out.append(("grip, leather", "+z", bare(grip.part), tx.mesh, up))
    return out


# -- the recipes' parts (issue 29): every recipe and the paper's nine samples -----------
#: The recipes that make parts to print (recipes/*.py but the gallery); paper_samples
#: gives nine (:func:`recipe_parts`).
RECIPES = ("enclosure", "flat_plate", "grip", "handle_flange", "heat_sink", "knob", "lever_ball", "mesh_part",
           "paint_grip", "paper_samples", "sledgehammer", "zones_knob")
#: mm: the coarse pitch each recipe is sliced at (the recipe tests' pitch: about a
#: second per slice; the knob's and zones knob's faces keep no texture at 1 mm).
COARSE_PITCH = {"enclosure": 0.5, "flat_plate": 2.0, "grip": 0.5, "handle_flange": 1.0, "heat_sink": 0.5, "knob": 0.5,
                "lever_ball": 0.5, "mesh_part": 1.0, "paint_grip": 0.8, "paper_samples": 2.0, "sledgehammer": 1.0,
                "zones_knob": 0.5}


def slotted_handle(pitch: float, folder) -> list:
    """``[(name, bare mesh, textured mesh, build direction)]`` of a handle as a mesh:
    a cylinder 20 mm across and 100 mm tall with a 6 x 8 mm slot through it near the
    top (its ceiling at 98 mm overhangs), written as an STL into ``folder`` and
    knurled 0.5 mm deep in a cylindrical projection, limited for +z: support the bare
    part needs, next to a textured wall."""
    import warnings

    from build123d import Align, Box, Cylinder, Pos, export_stl

    import texcad

    shape = Cylinder(10, 100, align=(Align.CENTER, Align.CENTER, Align.MIN)) - Pos(0, 0, 94) * Box(30, 6, 8)
    stl = Path(folder) / "slotted_handle.stl"
    export_stl(shape, str(stl), tolerance=0.01, angular_tolerance=0.1)
    up = (0.0, 0.0, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        part = texcad.texture(stl, [("not-bottom", "builtin:diamond_knurl", {"height": 0.5, "projection": "cylindrical:+z"})],
                              pitch=pitch, build_dir=up)
    return [("slotted handle (mesh), knurl", texcad.load_mesh(stl), part.mesh, _printed(part))]


#: mm: how closely the recipes' bare parts follow their CAD surfaces (with 0.05 rad:
#: the angle is what moves a curved part's own overhang boundary).
RECIPE_BARE_TOLERANCE = 0.01


def _bare(part, tolerance: float = RECIPE_BARE_TOLERANCE):
    """A textured result's part untextured: its CAD shape tessellated finer than the
    texture's pitch, or (mesh targets) its base mesh (every texture at its lowest)."""
    from texcad.brep import shape_to_mesh

    shape = part.base_shape
    return part.base_mesh if shape is None else shape_to_mesh(shape, tolerance=tolerance, angular_tolerance=0.05)


def _printed(part):
    """The build direction a textured result was limited for (``info["build_dir"]``
    or its limiter's ``directions``; the first of a set), or None."""
    import numpy as np

    d = (part.info or {}).get("build_dir")
    if d is None:
        d = getattr(part.limits, "directions", None)
    return None if d is None or np.size(d) < 3 else np.asarray(d, dtype=np.float64).reshape(-1, 3)[0]


def recipe_parts(script: str, pitch: float, samples=None):
    """``[(name, bare mesh, textured mesh, build direction or None)]`` of what
    ``recipes/<script>.py`` makes at ``pitch`` mm: the recipe run as a script (its
    outputs into a scratch folder), every textured result it leaves in its globals;
    for ``paper_samples`` the rows of Table 2 (``samples``: their names, default all
    nine) textured by the recipe's own functions, as meshes."""
    import runpy
    import tempfile
    import warnings

    import texcad
    from texcad.pipeline import Textured

    path = Path(__file__).resolve().parents[1] / "recipes" / f"{script}.py"
    with tempfile.TemporaryDirectory() as out, warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        old = {k: os.environ.get(k) for k in ("TEXCAD_OUT", "TEXCAD_PITCH")}
        os.environ.update(TEXCAD_OUT=out, TEXCAD_PITCH=str(pitch))
        try:
            if script != "paper_samples":
                g = runpy.run_path(str(path), run_name="__main__")
                return [(script if k == "part" else f"{script} {k}", _bare(v), v.mesh, _printed(v))
                        for k, v in g.items() if isinstance(v, Textured)]
            g = runpy.run_path(str(path), run_name="paper_samples")  # its functions, not its main
            out_parts = []
            for tex, kind, tilt in g["selected"](list(samples or [])):
                build, mapping, toward = g["SAMPLES"][kind]
                shape, face, width = build()
                d = texcad.orientation(tilt, toward)
                v = texcad.texture(shape, face, g["synthesized"](tex, width), mapping=mapping, build_dir=d, brep=False)
                out_parts.append((f"paper {tex}-{kind}", _bare(v), v.mesh, _printed(v)))
            return out_parts
        finally:
            for k, val in old.items():
                if val is None:
                    os.environ.pop(k, None)
                else:
                    os.environ[k] = val


CURA_LINES = 0.8  # mm between CuraEngine's plain support lines in the table's area column


_NAMES = {"prusaslicer": "PrusaSlicer", "curaengine": "CuraEngine"}


def _direction(d) -> str:
    """A build direction as a short label: ``+z``, ``-y``, or its three components."""
    import numpy as np

    d = np.asarray(d, dtype=np.float64)
    k = int(np.argmax(np.abs(d)))
    if abs(abs(d[k]) - 1.0) < 1e-9:
        return f"{'+-'[int(d[k] < 0)]}{'xyz'[k]}"
    return "(" + ", ".join(f"{v:.2f}" for v in d) + ")"


def compare(bare, textured, d, slicer: str, timeout: float, keep=None):
    """``(bare report, textured report, extra support mm)`` of one part in one slicer,
    support on at threshold 45 (CuraEngine's as plain lines :data:`CURA_LINES` apart,
    so that its length measures its area). The bare part goes in as an STL; the
    textured part as what texcad writes for that slicer: PrusaSlicer gets texcad's
    3MF (its per-object settings and layout, ``texcad.io.slicer_layout``),
    CuraEngine, which reads no 3MF, the STL with the 3MF's Cura per-object settings
    (``texcad.io.cura_settings``). None for a slice that ran past ``timeout``.
    ``keep``: copy the textured part's G-code there."""
    from texcad.report.slicer import extra_support, support_config

    cfg = support_config(slicer, 45, lines=CURA_LINES if slicer == "curaengine" else None)
    a = sliced(bare, timeout, slicer=slicer, build_dir=d, config=cfg)
    b = sliced(textured, timeout, slicer=slicer, build_dir=d, config=cfg, file="3mf", keep=keep)
    return a, b, (extra_support(b, a) if a and b else float("nan"))


#: G-code sections that print inside the part (CuraEngine's infill) or beside it (support).
INSIDE = ("FILL", "SUPPORT", "SUPPORT-INTERFACE")


def plain_stl(textured, d, timeout: float, kept: str):
    """``(report, mm)``: CuraEngine on the textured part as a plain STL (without the
    3MF's Cura settings), and the farthest its walls and skin (every path but
    :data:`INSIDE`) lie from those of the G-code ``kept`` (texcad's output) in any
    layer: how far the settings move what prints outside. ``(None, nan)`` past the timeout."""
    import tempfile

    import numpy as np

    from texcad.report.slicer import read_toolpaths, support_config, toolpath_deviation

    with tempfile.TemporaryDirectory() as tmp:
        g = str(Path(tmp) / "plain.gcode")
        r = sliced(textured, timeout, slicer="curaengine", build_dir=d, config=support_config("curaengine", 45, lines=CURA_LINES),
                   keep=g)
        if r is None or not Path(g).exists():
            return r, float("nan")
        dev = toolpath_deviation(read_toolpaths(g, exclude=INSIDE), read_toolpaths(kept, exclude=INSIDE))
    return r, float(np.max(dev)) if len(dev) else float("nan")


def table(args) -> None:
    """Every recipe's part and the paper's nine samples at their coarse pitch, bare and
    textured, in both slicers: support m, support beyond the bare part's (m) and CPU s."""
    import tempfile

    import numpy as np

    from texcad.report.slicer import SLICERS, find_slicer, support_config

    have = [s for s in SLICERS if find_slicer(s)]
    only = set(args.only.split(",")) if args.only else None
    rows, summary = [], {s: [] for s in have}
    tmp = tempfile.mkdtemp()
    headers = ["part", "printed", "pitch mm", "triangles"]
    floor = {}  # each slicer's start-up and G-code writing: a bare 10 mm cube, the same settings
    for s in have:
        cube = sliced(_cube(10.0), args.timeout, slicer=s, config=support_config(s, 45, lines=CURA_LINES if s == "curaengine" else None))
        floor[s] = cube.cpu_seconds if cube else 0.0
        headers += [f"{_NAMES[s]} support m (bare / textured)", f"{_NAMES[s]} beyond bare m",
                    f"{_NAMES[s]} CPU s (bare / textured)", f"{_NAMES[s]} CPU s beyond its floor (bare / textured), textured / bare"]
    if "curaengine" in have:
        headers += ["CuraEngine CPU s, textured as a plain STL", "CuraEngine walls and skin moved mm"]
    makers = [(script, COARSE_PITCH[script], lambda sc, p: recipe_parts(sc, p)) for script in RECIPES]
    makers.append(("slotted_handle", 1.0, lambda sc, p: slotted_handle(p, tmp)))
    for script, pitch, make in makers:
        if only and script not in only:
            continue
        pitch = pitch if args.recipe_pitch is None else args.recipe_pitch
        for name, bare, textured, d in make(script, pitch):
            print(f"  {name}: load {load()}", flush=True)
            cells = [name, "not given" if d is None else _direction(d), f"{pitch:g}", f"{textured.num_triangles:,}"]
            for s in have:
                kept = str(Path(tmp) / "textured.gcode")
                Path(kept).unlink(missing_ok=True)
                a, b, extra = compare(bare, textured, (0.0, 0.0, 1.0) if d is None else d, s, args.timeout,
                                      keep=kept if s == "curaengine" else None)
                for label, rep in (("bare", a), ("textured", b)):
                    row(f"{name[:22]} {s[:5]} {label}", rep)
                if a is None or b is None:
                    cells += ["ran past the timeout", "-", "-"]
                    continue
                over = _beyond_floor(a.cpu_seconds, b.cpu_seconds, floor[s])
                summary[s].append((a.support_mm, b.support_mm, extra, over, name, b.cpu_seconds))
                cells += [f"{a.support_mm / 1000:.2f} / {b.support_mm / 1000:.2f}", f"{extra / 1000:.3f}",
                          f"{a.cpu_seconds:.1f} / {b.cpu_seconds:.1f}",
                          f"{max(a.cpu_seconds - floor[s], 0):.2f} / {max(b.cpu_seconds - floor[s], 0):.2f}, "
                          + (f"{over:.1f}x" if np.isfinite(over) else _at_floor(b.cpu_seconds))]
            if "curaengine" in have:
                plain, moved = plain_stl(textured, (0.0, 0.0, 1.0) if d is None else d, args.timeout, kept)
                cells += ["ran past the timeout" if plain is None else f"{plain.cpu_seconds:.1f}", f"{moved:.2f}"]
            rows.append(cells)
            _write_slicer_table(headers, rows, args)
    if args.readme:
        _write_readme_summary(summary, len(rows), floor)


#: CPU s beyond a slicer's floor under which a bare part's time is start-up and noise:
#: no ratio is taken to it.
FLOOR_MARGIN = 0.1


def _beyond_floor(bare: float, textured: float, floor: float) -> float:
    """Textured over bare CPU seconds, each less the slicer's ``floor`` (its time on a
    bare 10 mm cube): what the texture adds to the slicing work, not to the start-up.
    NaN where the bare part is within :data:`FLOOR_MARGIN` s of the floor."""
    return (textured - floor) / (bare - floor) if bare - floor >= FLOOR_MARGIN else float("nan")


#: CPU s: where the bare part slices at the floor (a plate, a box), the textured part is
#: held to issue 29's bound for the demo-sized plate (100 x 100 mm of stones) instead of
#: a ratio: no texture slices within 10x of nothing, and what it costs grows with the
#: islands it prints, not with the bare part.
ABSOLUTE_BOUND = 30.0


def _at_floor(textured: float) -> str:
    """The table's cell for a part whose bare slice is at the slicer's floor: its
    textured CPU s against :data:`ABSOLUTE_BOUND`."""
    return f"bare at the floor; {'within' if textured <= ABSOLUTE_BOUND else 'over'} {ABSOLUTE_BOUND:g} s"


def _write_slicer_table(headers, rows, args):
    from texcad.printability import overhang_angle, support_free_angle

    try:
        from _table import write_table
    except ImportError:  # the docs helper's table writer is not here yet: the same layout
        write_table = _write_table
    notes = (
        "Every recipe run as a script at the coarse pitch shown (the paper's nine samples by the recipe's own "
        "functions), each part it makes sliced as printed (the build direction it passes to `texcad.texture`) "
        "as texcad writes it for that slicer (PrusaSlicer: texcad's 3MF, with its per-object settings; CuraEngine, "
        "which reads no 3MF: the STL, with the 3MF's Cura per-object settings (`texcad.io.cura_settings`: skin edge "
        "support off; no skin in z gaps where every line along the build direction meets the part once, "
        "`texcad.io.single_run`, or where its gaps along it lie within the walls' depth or are taller than the top "
        "thickness, `texcad.io.export.skin_gap_area`) as that mesh's settings, as Cura passes them on when it loads the 3MF), and beside it the same part untextured as an STL (its CAD shape tessellated to "
        f"{RECIPE_BARE_TOLERANCE:g} mm and 0.05 rad; a mesh part's base). Support on everywhere, threshold 45 degrees "
        "(the critical angle), 0.4 mm nozzle, each slicer's default layers (PrusaSlicer 0.3 mm, CuraEngine 0.2 mm "
        "in texcad's definition); CuraEngine's support laid as plain lines "
        f"{CURA_LINES:g} mm apart (`support_config(..., lines=)`), so that its length times {CURA_LINES:g} mm is "
        "its area. The textures are limited with the slicers' margin: facets at least "
        f"{support_free_angle(45):.2f} degrees from the build plate; texcad check counts faces under "
        f"{overhang_angle(45):.1f} degrees. Beyond bare: the textured part's support paths farther than 4.2 mm "
        "across (a cell's diagonal of PrusaSlicer's support grid) or 1 mm in height from all of the bare part's (`texcad.report.slicer.extra_support`): support "
        "the texture alone needs. Where both need support the lengths differ anyway: the pattern follows the "
        "outline; PrusaSlicer snaps support areas to a grid fixed to the bed (cells of about 2.9 mm) while it "
        "centres each part's bounding box on the bed, so a texture anywhere on the part can move its support's "
        "edge by a cell (the diagonal at a corner of the first layer, whose support is widened); and it rests a column that stands beside a textured wall on the texture's upward "
        "facets, which adds bottom contacts, interfaces and thinner layers to it. CPU s = user + system "
        "time of the slicer process; beyond its floor: less the slicer's time on a bare 10 mm cube with the same "
        "settings (start-up and G-code writing, measured in the same run), and the ratio of what is left, which is "
        f"not taken where the bare part is within {FLOOR_MARGIN:g} s of the floor: there the textured part is held "
        f"to the {ABSOLUTE_BOUND:g} CPU s the issue sets for the demo-sized plate (`ABSOLUTE_BOUND`). Plain STL: CuraEngine on the textured part's STL alone (skin edge support on, "
        "4 layers, Cura's default), sliced in the same run; walls and skin moved: the farthest any of its paths but "
        "infill and support lies from those of texcad's output in the same layer (`texcad.report.slicer."
        "toolpath_deviation`), against a 0.4 mm bead."
    )
    return write_table("slicer", headers, rows, title="Support and slicing time of every recipe, bare and textured, in two slicers",
                       notes=notes)


def _write_readme_summary(summary: dict, parts: int, floor: dict) -> None:
    """The README's printability figures: one row per slicer over every part."""
    import numpy as np
    from _table import markdown_table, write_readme_block

    rows = []
    for s, got in summary.items():
        if not got:
            continue
        bare, tex, extra = (sum(x[k] for x in got) / 1000 for k in range(3))
        ratio = sorted((x[3], x[4]) for x in got if np.isfinite(x[3]))
        clean = sum(1 for x in got if x[2] == 0.0)
        at_floor = len(got) - len(ratio)
        worst = max((x[5] for x in got if not np.isfinite(x[3])), default=0.0)
        rows.append([_NAMES[s], f"{clean} of {len(got)}", f"{bare:.1f} / {tex:.1f}", f"{extra:.3f}", f"{floor[s]:.2f}",
                     f"{ratio[len(ratio) // 2][0]:.1f}x ({ratio[-1][0]:.1f}x, {ratio[-1][1]}); {at_floor} bare at the floor, "
                     f"textured at most {worst:.1f} s ({ABSOLUTE_BOUND:g} s bound)"
                     if ratio else "-"])
    headers = ["slicer", "parts with no support beyond bare", "support m, all parts (bare / textured)",
               "beyond bare m", "floor CPU s", "CPU beyond the floor, textured / bare: median (largest)"]
    write_readme_block("slicer", markdown_table(headers, rows) + "\n\nPer part: [the table in the docs](docs/benchmarks.md).")


# -- cost (issue 29): what slicing a textured part costs, STL against texcad's 3MF -----
def _demo_part(pitch: float, side: float = 100.0):
    """(bare mesh, textured mesh) of the demo plate: ``texcad demo``'s stones grown
    over a ``side`` mm plate at ``pitch`` mm (default tolerance)."""
    from build123d import Axis

    from bench_lean import demo_heightmap
    from texcad import texture
    from texcad.brep import shape_to_mesh
    from texcad.pipeline import plate_base

    plate = plate_base((side, side), 5.0)
    part = texture(plate, plate.faces().sort_by(Axis.Z)[-1], demo_heightmap(pitch, side), brep=False)
    return shape_to_mesh(plate), part.mesh


def _cube(side: float):
    """A ``side`` mm cube as a 12-triangle mesh."""
    import numpy as np

    from texcad.solid import Mesh

    v = np.array([[x, y, z] for x in (0, side) for y in (0, side) for z in (0, side)], dtype=np.float32)
    f = [[0, 1, 2], [1, 3, 2], [4, 6, 5], [5, 6, 7], [0, 4, 1], [1, 4, 5], [2, 3, 6], [3, 7, 6], [0, 2, 4], [2, 6, 4], [1, 5, 3], [3, 5, 7]]
    return Mesh(v, np.array(f, dtype=np.uint32))


#: mm: how far :func:`_nudged` moves a mesh's farthest vertex (a micrometre).
NUDGE = 0.001


#: How :func:`_nudged` moves the part: scaled out, scaled in, turned about the build axis.
NUDGES = ("out", "in", "turned")


def _nudged(mesh, build_dir=None, how: str = "out"):
    """``mesh`` moved across the build plate (the plane normal to ``build_dir``;
    None: +z) about its bounding box's centre so that its farthest vertex moves by
    :data:`NUDGE` mm: scaled by ``1 +- NUDGE / r`` (``how`` "out", "in") or turned
    by ``NUDGE / r`` rad about the build axis ("turned"), ``r`` the farthest
    vertex's distance across. The same part, every coordinate moved by at most a
    micrometre, its height along the build direction unchanged (a uniform shift
    would be undone when the part is centred on the bed; a changed height would
    change the layers)."""
    import numpy as np

    from texcad.printability import print_rotation

    R = np.eye(3) if build_dir is None else print_rotation(build_dir)
    v = mesh.vertices.astype(np.float64) @ R.T  # print frame: z along the build direction
    c = (v.min(axis=0) + v.max(axis=0)) / 2
    xy = v[:, :2] - c[:2]
    r = float(np.linalg.norm(xy, axis=1).max())
    if how == "turned":
        a = NUDGE / r
        xy = xy @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
    else:
        xy = xy * (1.0 + (NUDGE if how == "out" else -NUDGE) / r)
    v[:, :2] = c[:2] + xy
    out = type(mesh)((v @ R).astype(np.float32), mesh.faces)
    out.__dict__["is_watertight"] = mesh.is_watertight
    return out


#: mm: the spacing at which :func:`texcad.report.slicer.toolpath_deviation` samples paths
#: here; each figure it gives is exact to within half of it.
PATH_STEP = 0.05


def _same_print(walls: float, moved: float, nudge_walls: float, nudge: float) -> str:
    """The verdict on texcad's 3MF against the plain 3MF (specks left out): ``yes``
    when its outer walls (the texture as printed, ``OUTER_WALLS``) moved ``walls`` mm
    and every path ``moved`` mm, each at most the larger of the nozzle width and how
    far PrusaSlicer's own outer walls (``nudge_walls``) and paths (``nudge``) move in
    the plain 3MF under the largest of the :data:`NUDGES` (where they move farther
    than a nozzle under a micrometre, they are not defined closer than that). Each
    figure is exact to within ``PATH_STEP / 2``: a move past its bound by less than
    that is not told apart from it, and the verdict says so."""
    import numpy as np

    if not all(np.isfinite((walls, moved, nudge_walls, nudge))):
        return "-"
    bounds = (max(NOZZLE, nudge_walls), max(NOZZLE, nudge))
    figures = f"outer walls {walls:.3f} against {bounds[0]:.3f} mm; every path {moved:.3f} against {bounds[1]:.3f} mm"
    if walls > bounds[0] + PATH_STEP / 2 or moved > bounds[1] + PATH_STEP / 2:
        return f"no ({figures})"
    if walls > bounds[0] or moved > bounds[1]:
        return f"yes ({figures}, within the paths' sampling, {PATH_STEP / 2:g} mm)"
    return f"yes ({figures})"


def _moved(paths: dict, x: str, y: str, speck: float = 0.0):
    """``(largest per-layer move, mm, its print height z, mm)`` between the paths of
    runs ``x`` and ``y`` (specks under ``speck`` mm left out); NaN where either run
    is missing or a layer is printed by one only."""
    import numpy as np

    from texcad.report.slicer import toolpath_deviation

    if x not in paths or y not in paths:
        return float("nan"), float("nan")
    a, b = paths[x].without_specks(speck), paths[y].without_specks(speck)
    d = toolpath_deviation(a, b, step=PATH_STEP)
    if not len(d) or not np.all(np.isfinite(d)):
        return float("inf") if len(d) else float("nan"), float("nan")
    return float(d.max()), float(np.union1d(a.z, b.z)[int(np.argmax(d))])


def _moved_at(paths: dict, x: str, y: str, speck: float = 0.0) -> str:
    """:func:`_moved` as "0.45 at z 6.05"."""
    import numpy as np

    d, z = _moved(paths, x, y, speck)
    return f"{d:.2f} at z {z:g}" if np.isfinite(z) else "-"


def cost(args) -> None:
    """PrusaSlicer's CPU seconds at its defaults for each part bare (STL), textured as
    an STL, and textured as the 3MF texcad writes (its per-object settings), and how
    far the 3MF's toolpaths lie from the STL's (per layer Hausdorff, mm)."""
    import tempfile

    import numpy as np

    from texcad.io import slicer_layout
    from texcad.report.slicer import OUTER_WALLS, read_toolpaths

    parts = list(_table_parts(args.pitch))
    if not args.no_demo:  # last: the slow one (the table is written after every part)
        bare, tex = _demo_part(args.demo_pitch, args.demo_side)
        parts.append((f"demo plate {args.demo_side:g} x {args.demo_side:g} mm, stones at {args.demo_pitch:g} mm", "+z", bare, tex, (0.0, 0.0, 1.0)))
    headers = ["part", "printed", "triangles", "bare CPU s", "textured STL CPU s", "plain 3MF CPU s", "texcad's 3MF CPU s",
               "texcad's 3MF / bare", "what texcad's 3MF adds", "toolpaths moved by it, mm (specks left out, at the layer of print height z)",
               "outer walls (the texture) moved by it, mm (specks left out, at z)", "toolpaths STL vs texcad's 3MF, mm",
               f"plain 3MF nudged by {NUDGE * 1000:g} um (scaled out / in / turned): toolpaths moved, mm (specks left out)",
               "nudged: outer walls moved, mm (specks left out)",
               "the same print: outer walls and every path within the nozzle or the nudges' largest move"]
    notes = (
        "PrusaSlicer 2.5 at its defaults (0.3 mm layers, 0.4 mm nozzle, support off), each part in its print orientation. "
        "CPU s = user + system time of the slicer process (all threads), the slices of a row run one after the other. "
        "Plain 3MF: the textured mesh as a one-part 3MF with nothing added. texcad's 3MF: what `export()` writes "
        "(`texcad.io.slicer_layout`): the per-object settings, and where PrusaSlicer's extra-perimeter pass meets "
        "layers crowded with small islands, the mesh cut in two parts there, the upper one with extra_perimeters = 0. "
        "Toolpaths moved: the largest distance, over every layer, between the extrusion paths of the plain 3MF's G-code "
        "and texcad's (per-layer Hausdorff distance of the paths sampled every 0.05 mm; "
        "`texcad.report.slicer.toolpath_deviation`); in brackets the same with the specks left out (unbroken "
        "extrusions under a nozzle width across, `Toolpaths.without_specks(0.4)`: perimeters of islands a tenth of a "
        "mm wide, which appear or vanish when a coordinate moves by a micrometre). STL vs texcad's 3MF adds what "
        "the file format's rounding changes. Nudged: the plain 3MF with the mesh moved across the bed about its "
        f"centre so that its farthest vertex moves by {NUDGE * 1000:g} um, three ways (scaled out, scaled in, turned "
        "about the build axis), each against the plain 3MF: how far PrusaSlicer's own paths move when the same part's "
        "coordinates move by a micrometre. Both 3MFs put every coordinate on a binary grid "
        "(2^-14 mm) as its exact decimal, so that the parts of a cut load with the whole mesh's float32 coordinates "
        "(PrusaSlicer centres each part on its own bounding box in single precision, "
        "`ModelVolume::center_geometry_after_creation`, exactly on that grid); what is left of a cut's move is on "
        "the layers next to the cut (the height in brackets): the triangles the cut splits give the sections there a few "
        "more points, each a few nanometres off the whole mesh's section, and where a texture's web breaks into islands "
        "PrusaSlicer then lays the solid infill inside an island a line further on (its outer walls stay within a few "
        "hundredths of a mm), as it does when the uncut mesh moves by a micrometre. Outer walls: the same for the "
        "external perimeters alone (`OUTER_WALLS`), which print the part's surface, the texture itself. The same print: "
        "texcad's 3MF moves no outer wall and no path (specks left out) farther from the plain 3MF's than a nozzle "
        "width or, where PrusaSlicer's own outer walls or paths move farther than that under the largest of the three "
        "nudges, farther than they do (the slicer's paths are not defined closer than that on that part); each "
        "figure is exact to within half the paths' sampling step (0.025 mm), and a move that passes its bound by less "
        "than that is said to be within the sampling. "
        f"Small parts at texture pitch {args.pitch:g} mm; a slice that ran past {args.timeout:g} s of wall time "
        "(2 cores shared with other jobs) is marked so."
    )
    try:
        from _table import write_table
    except ImportError:
        write_table = _write_table
    rows = []
    cube = sliced(_cube(10.0), args.timeout)  # PrusaSlicer's own start-up and G-code writing: the floor of every row
    notes += f" PrusaSlicer's floor, a bare 10 mm cube: {cube.cpu_seconds:.2f} CPU-s." if cube else ""
    with tempfile.TemporaryDirectory() as tmp:
        for name, orient, bare, textured, d in parts:
            print(f"  {name}: load {load()}", flush=True)
            g_stl, g_3mf = Path(tmp) / "stl.gcode", Path(tmp) / "3mf.gcode"
            g_set = Path(tmp) / "plain.gcode"
            b = sliced(bare, args.timeout, build_dir=d)
            e = sliced(textured, args.timeout, build_dir=d, keep=g_set, file="3mf", layout=False)
            c = sliced(textured, args.timeout, build_dir=d, keep=g_3mf, file="3mf")
            a = sliced(textured, args.timeout, build_dir=d, keep=g_stl)
            g_nudge = {h: Path(tmp) / f"nudged_{h}.gcode" for h in NUDGES}
            n = {h: sliced(_nudged(textured, d, h), args.timeout, build_dir=d, keep=g_nudge[h], file="3mf", layout=False) for h in NUDGES}
            from texcad.printability import print_rotation

            R = print_rotation(d)
            placed = type(textured)((textured.vertices.astype(np.float64) @ R.T).astype(np.float32), textured.faces)
            lay = slicer_layout(placed)
            for label, rep in (("bare", b), ("textured STL", a), ("plain 3MF", e), ("texcad's 3MF", c)):
                row(f"{name[:30]} {label}", rep)
            cpu = lambda r: f"{r.cpu_seconds:.1f}" if r else f"ran past {args.timeout:g} s"
            runs = [("stl", g_stl, a), ("plain", g_set, e), ("3mf", g_3mf, c), *((h, g_nudge[h], n[h]) for h in NUDGES)]
            paths = {k: read_toolpaths(g) for k, g, r in runs if r}
            walls = {k: read_toolpaths(g, only=OUTER_WALLS) for k, g, r in runs if r}
            dev = lambda x, y, speck=0.0, within=paths: _moved(within, x, y, speck)[0]
            written = ", ".join(f"{k} = {v}" for k, v in lay.settings.items()) or "none"
            if lay.cut is not None:
                written += f"; cut at {lay.cut:g} mm, the upper part extra_perimeters = 0"
            f2 = lambda x: f"{x:.2f}" if np.isfinite(x) else "-"
            rows.append([name, orient, f"{textured.num_triangles:,}", cpu(b), cpu(a), cpu(e), cpu(c),
                         f"{c.cpu_seconds / b.cpu_seconds:.1f}x" if b and c else "-", written,
                         f"{f2(dev('plain', '3mf'))} ({_moved_at(paths, 'plain', '3mf', NOZZLE)})",
                         f"{f2(dev('plain', '3mf', within=walls))} ({_moved_at(walls, 'plain', '3mf', NOZZLE)})",
                         f2(dev("stl", "3mf")),
                         " / ".join(f2(dev("plain", h)) for h in NUDGES) + " (" + " / ".join(f2(dev("plain", h, NOZZLE)) for h in NUDGES) + ")",
                         " / ".join(f2(dev("plain", h, NOZZLE, walls)) for h in NUDGES),
                         _same_print(dev("plain", "3mf", NOZZLE, walls), dev("plain", "3mf", NOZZLE),
                                     max(dev("plain", h, NOZZLE, walls) for h in NUDGES), max(dev("plain", h, NOZZLE) for h in NUDGES))])
            path = write_table("slicer_cost", headers, rows, title="Slicing cost, bare and textured, STL and texcad's 3MF", notes=notes)
    print(f"wrote {path}")


def levers(args) -> None:
    """Candidate ways to cut PrusaSlicer's time on a piece of the demo plate, each
    measured against the STL at PrusaSlicer's defaults: CPU seconds and how far the
    toolpaths move (largest per-layer distance, and the number of layers where it
    passes a nozzle width)."""
    import tempfile

    import numpy as np

    from texcad.report.slicer import read_toolpaths, slice_mesh, toolpath_deviation

    side, pitch = args.demo_side if args.demo_side < 100 else 40.0, args.demo_pitch
    _, mesh = _demo_part(pitch, side)
    off = {"overhangs": False}
    cases = [
        ("texcad's 3MF: overhangs = 0 (detect bridging perimeters off)", "3MF, per object", mesh, {}, "3mf"),
        ("overhangs = 0, seam_position = random", "3MF, per object", mesh, {**off, "seam-position": "random"}, "stl"),
        ("overhangs = 0, extra_perimeters = 0", "3MF, per object", mesh, {**off, "extra-perimeters": False}, "stl"),
        ("overhangs = 0, perimeter_generator = classic", "3MF, per object", mesh, {**off, "perimeter-generator": "classic"}, "stl"),
        ("overhangs = 0, slice resolution 0.05 mm", "print profile only (not read per object)", mesh, {**off, "resolution": 0.05}, "stl"),
    ]
    for tol in (0.05, 0.1):
        _, lean = _demo_part_tol(pitch, side, tol)
        cases.append((f"overhangs = 0, mesh tolerance {tol:g} mm (texcad's default 0.02)", "texcad's mesh", lean, off, "stl"))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        ref_g = Path(tmp) / "ref.gcode"
        ref = slice_mesh(mesh, keep=ref_g, timeout=args.timeout)
        row("reference STL, defaults", ref)
        ref_t = read_toolpaths(ref_g)
        rows.append(["STL at PrusaSlicer's defaults (reference)", "-", f"{mesh.num_triangles:,}", f"{ref.cpu_seconds:.1f}", "0", "0"])
        for what, where, m, cfg, fmt in cases:
            g = Path(tmp) / "x.gcode"
            r = slice_mesh(m, keep=g, config=cfg, file=fmt, timeout=args.timeout)
            row(what[:44], r)
            dev = toolpath_deviation(ref_t, read_toolpaths(g))
            rows.append([what, where, f"{m.num_triangles:,}", f"{r.cpu_seconds:.1f}", f"{dev.max():.2f}", str(int(np.count_nonzero(dev > 0.4)))])
    headers = ["lever", "where it can live", "triangles", "CPU s", "toolpaths moved, mm (largest)", "layers moved > 0.4 mm"]
    notes = (
        f"A {side:g} x {side:g} mm piece of the demo plate (stones grown at {pitch:g} mm, 5 mm plate), PrusaSlicer 2.5, "
        "0.2 mm layers, 0.4 mm nozzle. Toolpaths moved: per layer, the Hausdorff distance between the reference's extrusion "
        "paths and the lever's (sampled every 0.05 mm), the largest over all layers; a lever with 0 layers moved prints "
        "the same within a nozzle width. The 3MF's coordinates are rounded to 0.1 um where the STL's are float32, "
        "which alone moves a path by up to about 0.3 mm on a layer that grazes a flat top. A coarser mesh or a slice "
        "resolution moves whole islands at the stones' tops (a flat top near a slicing plane appears or vanishes with "
        "a few hundredths of a mm of height)."
    )
    try:
        from _table import write_table
    except ImportError:
        write_table = _write_table
    path = write_table("slicer_levers", headers, rows, title="What cuts PrusaSlicer's time on a texture, and what it moves", notes=notes)
    print(f"wrote {path}")


def _demo_part_tol(pitch: float, side: float, tolerance: float):
    from build123d import Axis

    from bench_lean import demo_heightmap
    from texcad import texture
    from texcad.pipeline import plate_base

    plate = plate_base((side, side), 5.0)
    return None, texture(plate, plate.faces().sort_by(Axis.Z)[-1], demo_heightmap(pitch, side), brep=False, tolerance=tolerance).mesh


def _write_table(name, headers, rows, *, title="", notes=""):
    import datetime as dt
    import platform

    root = Path(__file__).resolve().parents[1]
    cmd = "python " + " ".join([f"benchmarks/{Path(sys.argv[0]).name}", *sys.argv[1:]])
    cpu = next((ln.split(":", 1)[1].strip() for ln in Path("/proc/cpuinfo").read_text().splitlines() if ln.startswith("model name")), platform.machine())
    text = [f"<!-- written by {cmd}; do not edit, run the command again -->", "", f"**{title}**", ""]
    text += ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    text += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    when = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    text += ["", notes, "", f"*Command:* `{cmd}`  ", f"*Date:* {when}  ", f"*Machine:* {cpu}, {os.cpu_count()} cores, load {load()}", ""]
    path = root / "docs" / "benchmarks" / f"{name}.md"
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text("\n".join(text))
    os.replace(tmp, path)
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", choices=("table", "cost", "levers", "demo", "support", "perimeters", "recipes"))
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per slice (default 900)")
    ap.add_argument("--readme", action="store_true", help="table: also write the README's printability figures (its bench:slicer block)")
    ap.add_argument("--pitch", type=float, default=0.25, help="support, cost: texture pitch in mm (default 0.25)")
    ap.add_argument("--recipe-pitch", type=float, default=None,
                    help="table: one pitch in mm for every recipe (default: each recipe's COARSE_PITCH)")
    ap.add_argument("--side", type=float, default=40.0, help="perimeters: plate side in mm (default 40)")
    ap.add_argument("--demo-pitch", type=float, default=0.25, help="cost: the demo plate's texture pitch in mm (default 0.25)")
    ap.add_argument("--demo-side", type=float, default=100.0, help="cost: the demo plate's side in mm (default 100)")
    ap.add_argument("--no-demo", action="store_true", help="cost: leave the demo plate out")
    ap.add_argument("--sledgehammer", action="store_true", help="support: also the sledgehammer recipe (slow)")
    ap.add_argument("--fast", action="store_true", help="recipes: 'detect bridging perimeters' off (support is unchanged)")
    ap.add_argument("--compare", action="store_true",
                    help="recipes: each part made twice, on the grid (tolerance 0) and lean (the default), sliced side by side")
    ap.add_argument("--only", default="", help="recipes, table: comma-separated paper sample names and recipe scripts")
    ap.add_argument("--tolerances", type=lambda t: [float(x) for x in t.split(",")], default=[0.0, 0.02, 0.05, 0.1],
                    help="perimeters: tolerances in mm (default 0,0.02,0.05,0.1)")
    ap.add_argument("--resolution", type=float, default=0.05, help="perimeters: PrusaSlicer resolution row, mm (default 0.05)")
    args = ap.parse_args()
    from texcad.report.slicer import find_slicer

    exe = find_slicer()
    if exe is None:
        sys.exit("prusa-slicer is not installed (Debian: apt-get install prusa-slicer)")
    print(f"slicers {exe}, {find_slicer('curaengine')}; load average {load()} (2-core machine)")
    t0 = time.perf_counter()
    {"table": table, "cost": cost, "levers": levers, "demo": demo, "support": support, "perimeters": perimeters, "recipes": recipes}[args.what](args)
    print(f"done in {time.perf_counter() - t0:.0f} s; load average {load()}")


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    main()
