"""Slicer check (PrusaSlicer's CLI; skipped where it is not installed): a texture
limited for its build direction gets no support under it at the slicer's threshold
set to the critical angle; the same texture unlimited does."""

import os
import numpy as np
import pytest

import texcad
from texcad.report import slicer

pytestmark = pytest.mark.skipif(slicer.find_slicer() is None, reason="prusa-slicer is not installed")

SUPPORT = {"support-material": True, "support-material-threshold": 45}


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


def test_limited_texture_needs_no_support_at_the_critical_angle(box_side):
    box, side = box_side
    hm = texcad.builtin("diamond_knurl", size=(16, 12), pitch=0.25, height=1.0)
    up = (0.0, 0.0, 1.0)
    free = texcad.texture(box, side, hm, brep=False)
    fixed = texcad.texture(box, side, hm, brep=False, build_dir=up, critical_angle=45)
    bare = slicer.slice_mesh(texcad.brep.shape_to_mesh(box), config=SUPPORT)
    a = slicer.slice_mesh(free.mesh, config=SUPPORT)
    b = slicer.slice_mesh(fixed.mesh, config=SUPPORT)
    assert bare.returncode == a.returncode == b.returncode == 0
    if os.path.exists("/usr/bin/time"):  # read from /usr/bin/time -v
        assert 0 < a.cpu_seconds < 3600 and a.peak_mb > 1
    assert bare.support_mm == 0.0  # a box needs none
    assert a.support_mm > 10.0  # the unlimited knurl does (the check can fail)
    assert b.support_mm == 0.0 and len(b.support_points) == 0
    assert b.lengths.get("External perimeter", 0) > 0


def test_limiter_margin_is_what_the_slicer_needs():
    # A plate standing upright on its y = 0 border: PrusaSlicer counts a face as
    # overhanging below threshold + 1 degree, so the old 0.1-degree margin left
    # support under the texture at threshold 45; SLICER_MARGIN (1.5) leaves none.
    from texcad.printability import SLICER_MARGIN, limit_overhangs, orientation

    hm = texcad.builtin("diamond_knurl", size=(20, 20), pitch=0.25, height=1.0)
    d = orientation(90, "+y")
    out = {}
    for margin in (0.1, SLICER_MARGIN):
        lim, _ = limit_overhangs(hm, d, margin=margin)
        tp = texcad.pipeline.textured_plate(lim, size=(20, 20), thickness=4, tolerance=0)
        out[margin] = slicer.slice_mesh(tp.mesh, build_dir=d, config=SUPPORT)
    bare = slicer.slice_mesh(tp.base_mesh, build_dir=d, config=SUPPORT)
    assert bare.support_mm == 0.0
    assert out[0.1].support_mm > 100.0
    assert out[SLICER_MARGIN].support_mm == 0.0


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
