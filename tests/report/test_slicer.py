"""Slicer check (PrusaSlicer's and CuraEngine's CLIs; each skipped where it is not
installed): textures limited for their build direction get no more support than the
bare part at the slicers' threshold set to the critical angle; the same textures
unlimited do; ``texcad check`` and both slicers agree on the boundary (a plate
tilted exactly 45 degrees overhangs, one at 47 does not).

Parts are small and coarse (0.25 mm pitch) so that each slice takes about a second."""

import os
import warnings

import numpy as np
import pytest

import texcad
from texcad.report import slicer

HAVE = [s for s in slicer.SLICERS if slicer.find_slicer(s) is not None]
pytestmark = pytest.mark.skipif(not HAVE, reason="neither prusa-slicer nor CuraEngine is installed")
prusa = pytest.mark.skipif(slicer.find_slicer("prusaslicer") is None, reason="prusa-slicer is not installed")

SUPPORT = slicer.support_config("prusaslicer", 45)
CRIT = 45.0


def supports(mesh, build_dir=(0.0, 0.0, 1.0), slicers=None, threshold=CRIT, lines=None) -> dict:
    """Support length (mm) per installed slicer (or the ``slicers`` named), threshold
    ``threshold`` degrees (``lines``: slicer.support_config)."""
    out = {}
    for s in HAVE if slicers is None else slicers:
        r = slicer.slice_mesh(mesh, slicer=s, build_dir=build_dir, config=slicer.support_config(s, threshold, lines=lines))
        assert r.returncode == 0, r.log
        out[s] = r.support_mm
    return out


def leaning(angle: float, length: float = 20.0, thick: float = 4.0, width: float = 20.0) -> texcad.Mesh:
    """A plate leaning at ``angle`` degrees on the bed (a prism whose section is a
    parallelogram): its underside is its only downward face."""
    a = np.radians(angle)
    dx, dz = length * np.cos(a), length * np.sin(a)
    sec = [(0, 0), (thick, 0), (thick + dx, dz), (dx, dz)]
    v = np.array([[x, y, z] for y in (0.0, width) for x, z in sec], dtype=np.float32)
    f = [[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6]]
    for i in range(4):
        j = (i + 1) % 4
        f += [[i, 4 + j, j], [i, 4 + i, 4 + j]]
    return texcad.Mesh(v, np.array(f, dtype=np.uint32))


@pytest.fixture(scope="module")
def box_side():
    from build123d import Align, Axis, Box

    box = Box(20, 16, 12, align=(Align.MIN, Align.MIN, Align.MIN))
    return box, box.faces().sort_by(Axis.X)[-1]  # the +x wall: printed as placed, its texture faces sideways and down


def test_read_gcode_lengths_by_type(tmp_path):
    g = tmp_path / "t.gcode"
    g.write_text(
        ";LAYER_CHANGE\n;TYPE:Perimeter\nG1 X0 Y0 F600\nG1 X10 Y0 E0.5\nG1 X10 Y5 E0.2\n"
        ";TYPE:Support material\nG1 X10 Y9 E0.1\nG1 X13 Y13 E0.1\nG1 X20 Y13\nG1 E-0.8\n"
        ";LAYER_CHANGE\n;TYPE:Support material interface\nG1 Z0.4\nG1 X20 Y16 E0.1\n"
    )
    lengths, pts, layers = slicer.read_gcode(g)
    assert lengths["Perimeter"] == pytest.approx(15.0)
    assert lengths["Support material"] == pytest.approx(4.0 + 5.0)  # the travel X20 does not count
    assert lengths["Support material interface"] == pytest.approx(3.0)
    assert layers == 2 and np.allclose(pts, [[10, 9, 0], [13, 13, 0], [20, 16, 0.4]])


def test_read_gcode_of_curaengine(tmp_path):
    # CuraEngine: ;LAYER:n, G0 travels, F before the axes, ;TYPE:SUPPORT.
    g = tmp_path / "c.gcode"
    g.write_text(
        ";LAYER:0\n;TYPE:WALL-OUTER\nG0 F6000 X0 Y0 Z0.2\nG1 F1500 X10 Y0 E0.5\n"
        ";TYPE:SUPPORT\nG0 F6000 X20 Y0\nG1 F1500 X20 Y5 E0.2\nG1 X23 Y9 E0.1\n"
        ";LAYER:1\n;TYPE:SUPPORT-INTERFACE\nG0 X0 Y0 Z0.4\nG1 X0 Y2 E0.1\n"
    )
    lengths, pts, layers = slicer.read_gcode(g)
    assert lengths == pytest.approx({"WALL-OUTER": 10.0, "SUPPORT": 10.0, "SUPPORT-INTERFACE": 2.0})
    assert layers == 2 and np.allclose(pts, [[20, 5, 0.2], [23, 9, 0.2], [0, 2, 0.4]])


def test_the_boundary_agrees_between_check_and_the_slicers():
    """At threshold 45 both slicers support a plate leaning at exactly 45 degrees
    (PrusaSlicer makes its threshold inclusive by one degree) and texcad check counts
    its underside; at 47 degrees neither slicer supports it and check counts nothing.
    A textured plate's bare base tilted by 45 degrees likewise."""
    from texcad.printability import overhang_angle, support_free_angle

    assert overhang_angle(CRIT) == pytest.approx(46.0)
    for angle, over in ((45.0, True), (47.0, False)):
        m = leaning(angle)
        area = texcad.check(m, build_dir=(0, 0, 1), critical_angle=CRIT).overhang_area_mm2
        got = supports(m)
        assert (area > 0) is over, (angle, area)
        assert all((v > 0) is over for v in got.values()), (angle, got)
    d = texcad.orientation(45, "+y")
    plate = texcad.pipeline.textured_plate(texcad.builtin("stones", size=(20, 20), pitch=0.5, height=1.0), size=(20, 20), thickness=4).base_mesh
    assert texcad.check(plate, build_dir=d).overhang_area_mm2 > 0
    assert all(v > 0 for v in supports(plate, d).values())
    assert support_free_angle(CRIT) > overhang_angle(CRIT)


def test_limited_texture_needs_no_support_at_the_critical_angle(box_side):
    box, side = box_side
    hm = texcad.builtin("diamond_knurl", size=(16, 12), pitch=0.25, height=1.0)
    up = (0.0, 0.0, 1.0)
    free = texcad.texture(box, side, hm, brep=False)
    fixed = texcad.texture(box, side, hm, brep=False, build_dir=up, critical_angle=CRIT)
    bare = supports(texcad.brep.shape_to_mesh(box))
    a, b = supports(free.mesh), supports(fixed.mesh)
    assert all(v == 0.0 for v in bare.values())  # a box needs none
    assert all(v > 10.0 for v in a.values()), a  # the unlimited knurl does (the check can fail)
    assert all(v == 0.0 for v in b.values()), b
    assert texcad.check(fixed.mesh, build_dir=up).overhang_area_mm2 == 0.0
    if "prusaslicer" in HAVE and os.path.exists("/usr/bin/time"):  # read from /usr/bin/time -v
        r = slicer.slice_mesh(fixed.mesh, config=SUPPORT)
        assert 0 < r.cpu_seconds < 3600 and r.peak_mb > 1
        assert r.support_mm == 0.0 and len(r.support_points) == 0 and r.lengths.get("External perimeter", 0) > 0


def _sine_part(length=30.0, amplitude=3.0, period=25.0, width=20.0):
    """The paper's sinusoidal sample (eq. 9), scaled down: z = A sin(2 pi x / L) on a
    plate with a flat bottom; its top face and arc length (eq. 13)."""
    from build123d import Plane, Polyline, SortBy, Spline, extrude, make_face

    k = 2 * np.pi / period
    x = np.linspace(0, length, 49)
    top = Spline(*[(a, amplitude * np.sin(k * a)) for a in x], tangents=[(1, amplitude * k), (1, amplitude * k * np.cos(k * length))])
    section = make_face([top, Polyline(top @ 1, (length, -(amplitude + 4)), (0, -(amplitude + 4)), (0, 0))])
    part = extrude(Plane.XZ * section, amount=-width)
    return part, part.faces().sort_by(SortBy.AREA)[-1], texcad.Profile.sine(amplitude, period, length).length


def _lever():
    from build123d import Align, Cylinder, GeomType, Pos, Sphere

    lever = Cylinder(3, 20, align=(Align.CENTER, Align.CENTER, Align.MIN)) + Pos(0, 0, 26) * Sphere(8)
    return lever, lever.faces().filter_by(GeomType.SPHERE)


def _case(name):
    """(bare mesh, textured mesh, build direction) of a recipe's part, small and coarse."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        if name == "T3-sine-30":  # recipes/paper_samples.py: pebbled leather on the sine, tilted 30 deg
            part, face, width = _sine_part()
            d = texcad.orientation(30, "+x")
            hm = texcad.builtin("leather", size=(width, 20), pitch=0.25, height=1.0, scale=2.0)
            tx = texcad.texture(part, face, hm, mapping="distance", build_dir=d, brep=False)
        elif name == "stones-upright":  # recipes/flat_plate.py: stones, the plate standing on its y = 0 border
            # (a plate tilted by 0 < a < 90 deg needs support under its bottom face or its lower wall anyway)
            d = texcad.orientation(90, "+y")
            tx = texcad.pipeline.textured_plate(
                texcad.builtin("stones", size=(20, 20), pitch=0.25, height=1.0), size=(20, 20), thickness=4, build_dir=d
            )
            return tx.base_mesh, tx.mesh, d
        elif name == "lever_ball":  # recipes/lever_ball.py: dimples on a ball, standing on its foot
            part, face = _lever()
            d = np.array([0.0, 0.0, 1.0])
            tx = texcad.texture(part, face, "builtin:dimples", height=0.5, pitch=0.25, build_dir=d, brep=False)
        return texcad.brep.shape_to_mesh(part, tolerance=0.002, angular_tolerance=0.05), tx.mesh, d


#: How the recipe test lays CuraEngine's support: plain lines two nozzle widths apart,
#: so that its length measures its area (slicer.support_config); PrusaSlicer at its default.
LINES = {"curaengine": 0.8, "prusaslicer": None}


@pytest.mark.parametrize("name", ["T3-sine-30", "stones-upright", "lever_ball"])
@pytest.mark.parametrize("slicer_name", slicer.SLICERS)
def test_limited_recipe_parts_need_no_more_support_than_bare(name, slicer_name):
    """Support at threshold 45 (the critical angle), textured against bare. In
    CuraEngine as plain lines 0.8 mm apart, so that its length measures its area: at
    its sparse zigzag the connectors follow the support's border, and the lever's
    ball took 7.06 m textured against 7.02 m bare (13.3 mm zigzag) while its support
    area is smaller (12.43 m against 12.78 m of lines, less on every layer). The bare
    CAD part is tessellated finer than the texture's pitch (0.002 mm), since a coarse
    tessellation moves a curved part's own overhang boundary."""
    if slicer_name not in HAVE:
        pytest.skip(f"{slicer_name} is not installed")
    bare, textured, d = _case(name)
    a = supports(bare, d, (slicer_name,), lines=LINES[slicer_name])[slicer_name]
    b = supports(textured, d, (slicer_name,), lines=LINES[slicer_name])[slicer_name]
    assert b <= a + 1.0, (slicer_name, a, b)  # 1 mm: the support's own pattern shifts with the outline


def test_limiter_margin_is_what_the_slicers_need():
    # A plate standing upright on its y = 0 border: with a 0.1-degree margin
    # PrusaSlicer supports the texture at threshold 45 (it supports below 46); with
    # the slicers' margin (texcad.printability.slicer_margin) neither slicer does.
    from texcad.printability import SLICER_MARGIN, limit_overhangs, orientation, slicer_margin

    assert SLICER_MARGIN == pytest.approx(slicer_margin(CRIT, 0.2)) and SLICER_MARGIN > 1.0
    hm = texcad.builtin("diamond_knurl", size=(20, 20), pitch=0.25, height=1.0)
    d = orientation(90, "+y")
    out = {}
    for margin in (0.1, None):
        lim, _ = limit_overhangs(hm, d, margin=margin)
        tp = texcad.pipeline.textured_plate(lim, size=(20, 20), thickness=4, tolerance=0)
        out[margin] = supports(tp.mesh, d)
    assert all(v == 0.0 for v in supports(tp.base_mesh, d).values())
    assert out[0.1].get("prusaslicer", 101.0) > 100.0
    assert all(v == 0.0 for v in out[None].values()), out[None]


@prusa
def test_prusaslicer_keeps_base_and_texture_as_one_object(tmp_path, box_side):
    import subprocess
    import zipfile

    box, side = box_side
    tx = texcad.texture(box, side, "builtin:stones", height=1.0, pitch=0.5, brep=False)
    src, out = tmp_path / "part.3mf", tmp_path / "resaved.3mf"
    tx.export(src, separate_texture=True)
    r = subprocess.run([slicer.find_slicer(), "--export-3mf", "--output", str(out), str(src)], capture_output=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    cfg = zipfile.ZipFile(out).read("Metadata/Slic3r_PE_model.config").decode()
    assert cfg.count("<object ") == 1 and cfg.count("<volume ") == 2
    assert 'key="name" value="base"' in cfg and 'key="name" value="texture"' in cfg


@prusa
def test_a_knurled_mesh_limited_at_its_ridges_needs_almost_no_support():
    """A diamond knurl (pyramids) on a cylinder mesh, limited facet by facet only: its
    pyramids' edges rise less steeply than their faces, and the slicer supports them
    (43 m on a 24 mm cylinder when this test was written). Limited at the ridges too
    (the default) the support falls to under a tenth."""
    from conftest import knurled_cylinder

    ridged = knurled_cylinder(8.0, 12.0, 96, ridges=True, pitch=0.3)
    facets_only = knurled_cylinder(8.0, 12.0, 96, ridges=False, pitch=0.3)
    assert ridged.limits.steep_ridges > 100
    a = slicer.slice_mesh(ridged.mesh, config={**SUPPORT, "overhangs": False})
    b = slicer.slice_mesh(facets_only.mesh, config={**SUPPORT, "overhangs": False})
    assert a.returncode == 0 and b.returncode == 0
    assert b.support_mm > 2000.0  # the check can fail: facet limits alone leave support
    assert a.support_mm < 0.1 * b.support_mm, (a.support_mm, b.support_mm)


@prusa
def test_3mf_puts_the_part_on_the_bed_as_it_prints(tmp_path):
    """A plate textured for printing upright on its y = 0 border: its 3MF's build item
    turns it so (texcad.printability.print_rotation), resting on the bed; PrusaSlicer
    loads it 20 mm tall. Without a build direction the item has no transform."""
    import subprocess
    import zipfile

    from build123d import Align, Axis, Box

    box = Box(30, 20, 4, align=(Align.MIN, Align.MIN, Align.MIN))
    hm = texcad.builtin("stones", size=(30, 20), pitch=0.5, height=1.0)
    up = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], hm, build_dir=texcad.orientation(90, "+y"), brep=False)
    flat = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], hm, brep=False)
    for tx, name, size_z in ((up, "up.3mf", 20.0), (flat, "flat.3mf", 5.0)):
        tx.export(tmp_path / name)
        model = zipfile.ZipFile(tmp_path / name).read("3D/3dmodel.model").decode()
        assert ("transform=" in model) is (tx is up)
        info = subprocess.run([slicer.find_slicer(), "--info", str(tmp_path / name)], capture_output=True, text=True, timeout=120).stdout
        got = {k.strip(): float(v) for k, v in (ln.split("=") for ln in info.splitlines() if ln.startswith(("size_z", "min_z")))}
        assert got["size_z"] == pytest.approx(size_z, abs=0.01) and got["min_z"] == pytest.approx(0.0, abs=1e-6), got


@prusa
def test_3mf_of_a_textured_mesh_stands_as_it_prints(tmp_path):
    """A mesh textured for build direction +y (its limiter's directions): the 3MF
    turns it so, 30 mm tall on the bed (the block's y extent) where it lies 12 mm
    tall as modelled."""
    import subprocess

    from build123d import Box, export_stl

    stl = tmp_path / "block.stl"
    export_stl(Box(20, 30, 12), str(stl))
    part = texcad.texture(stl, [("normal:+x:10", "builtin:stones", {"height": 0.5, "projection": "planar:+x"})],
                          pitch=1.0, build_dir=(0, 1, 0))
    assert np.allclose(part.limits.directions, [[0.0, 1.0, 0.0]])
    part.export(tmp_path / "block.3mf")
    info = subprocess.run([slicer.find_slicer(), "--info", str(tmp_path / "block.3mf")], capture_output=True, text=True, timeout=120).stdout
    got = {k.strip(): float(v) for k, v in (ln.split("=") for ln in info.splitlines() if ln.startswith(("size_z", "min_z")))}
    assert got["size_z"] == pytest.approx(30.0, abs=0.01) and got["min_z"] == pytest.approx(0.0, abs=1e-6), got
