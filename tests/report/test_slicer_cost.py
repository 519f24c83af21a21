"""Slicing cost (issue 29): the 3MF texcad writes tells PrusaSlicer that a part has
no bridging perimeters to look for (``overhangs = 0``, texcad.io.slicer_settings),
which is most of the time it spends on a texture; the toolpaths stay the same.

The slicer tests are skipped where PrusaSlicer is not installed; the rest runs
everywhere. The one timing assertion compares two slices of the same mesh on the
same machine, one after the other, with a wide margin (about 0.55 measured)."""

import zipfile

import numpy as np
import pytest

import texcad
from texcad.io import read_part, slicer_settings, write_3mf
from texcad.report import slicer

prusa = pytest.mark.skipif(slicer.find_slicer("prusaslicer") is None, reason="prusa-slicer is not installed")
NOZZLE = 0.4  # PrusaSlicer's default nozzle, mm


def _leaning(angle: float) -> texcad.Mesh:
    """A 20 x 20 x 4 mm plate leaning at ``angle`` degrees on the bed."""
    a = np.radians(angle)
    dx, dz = 20 * np.cos(a), 20 * np.sin(a)
    sec = [(0, 0), (4, 0), (4 + dx, dz), (dx, dz)]
    v = np.array([[x, y, z] for y in (0.0, 20.0) for x, z in sec], dtype=np.float32)
    f = [[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6]]
    for i in range(4):
        j = (i + 1) % 4
        f += [[i, 4 + j, j], [i, 4 + i, 4 + j]]
    return texcad.Mesh(v, np.array(f, dtype=np.uint32))


def test_settings_only_where_nothing_bridges():
    """A relief facing up and a plate leaning at 60 degrees have no facet facing down
    flatter than 45 degrees: "detect bridging perimeters" goes off. Leaning at 30
    degrees, or the same part turned over (its top faces down), it stays as the
    profile has it."""
    tp = texcad.pipeline.textured_plate(texcad.builtin("stones", size=(10, 10), pitch=0.5, height=1.0), size=(10, 10), thickness=3)
    assert slicer_settings(tp.mesh) == {"overhangs": 0}
    assert slicer_settings(tp.mesh, (0, 0, -1)) == {}
    assert slicer_settings(_leaning(60.0)) == {"overhangs": 0}
    assert slicer_settings(_leaning(30.0)) == {}


def test_3mf_holds_the_settings_and_the_same_mesh(tmp_path):
    """The settings sit in the object's metadata; a one-part object names its one part
    (PrusaSlicer loads none otherwise) and reads back as the same mesh and name."""
    tp = texcad.pipeline.textured_plate(texcad.builtin("stones", size=(10, 10), pitch=0.5, height=1.0), size=(10, 10), thickness=3)
    write_3mf(tp.mesh, tmp_path / "a.3mf", name="plate", settings={"overhangs": 0})
    write_3mf(tp.mesh, tmp_path / "b.3mf", name="plate")
    cfg = zipfile.ZipFile(tmp_path / "a.3mf").read("Metadata/Slic3r_PE_model.config").decode()
    assert '<metadata type="object" key="overhangs" value="0"/>' in cfg and cfg.count("<volume ") == 1
    assert f'lastid="{tp.mesh.num_triangles - 1}"' in cfg
    assert "Metadata/Slic3r_PE_model.config" not in zipfile.ZipFile(tmp_path / "b.3mf").namelist()
    (na, ma), (nb, mb) = read_part(tmp_path / "a.3mf")[0], read_part(tmp_path / "b.3mf")[0]
    assert na == nb == "plate"
    assert np.array_equal(ma.vertices, mb.vertices) and np.array_equal(ma.faces, mb.faces)


def test_toolpath_deviation_is_the_farthest_path_point(tmp_path):
    """Two layers; the second one's square moved 0.3 mm: 0 on the first layer, 0.3 mm
    on the second; a layer printed by one G-code only is infinitely far."""
    def gcode(path, shift, extra=False):
        sq = lambda x0: "".join(f"G1 X{x0 + x:.3f} Y{y:.3f} E0.1\n" for x, y in ((10, 0), (10, 10), (0, 10), (0, 0)))
        text = ";LAYER_CHANGE\nG1 Z0.2\nG1 X0 Y0\n;TYPE:External perimeter\n" + sq(0.0)
        text += f";LAYER_CHANGE\nG1 Z0.4\nG1 X{shift:.3f} Y0\n" + sq(shift)
        if extra:
            text += ";LAYER_CHANGE\nG1 Z0.6\nG1 X0 Y0\n" + sq(0.0)
        path.write_text(text)
        return slicer.read_toolpaths(path)

    a, b = gcode(tmp_path / "a.gcode", 0.0), gcode(tmp_path / "b.gcode", 0.3, extra=True)
    assert np.allclose(a.z, [0.2, 0.4]) and np.allclose(a.lengths, [40.0, 40.0])
    d = slicer.toolpath_deviation(a, b, step=0.01)
    assert d[0] == pytest.approx(0.0, abs=1e-9) and d[1] == pytest.approx(0.3, abs=0.006) and np.isinf(d[2])


@prusa
def test_3mf_slices_faster_with_the_same_toolpaths(tmp_path):
    """A 40 x 40 mm stones plate (0.25 mm pitch, 51 k triangles): PrusaSlicer at its
    defaults takes about 7.4 CPU-s on the STL and 4.3 on texcad's 3MF (measured when
    this test was written). What the 3MF's settings change in the print: nothing
    beyond a nozzle width on any layer (the STL sliced with them given on the command
    line against the STL at the defaults; the 3MF itself is compared only for its
    layers and path length, since another file format's rounding alone can move a
    path grazing a flat facet by a few tenths of a mm)."""
    tp = texcad.pipeline.textured_plate(texcad.builtin("stones", size=(40, 40), pitch=0.25, height=2.0), size=(40, 40), thickness=3)
    tp.export(tmp_path / "plate.3mf")
    cfg = zipfile.ZipFile(tmp_path / "plate.3mf").read("Metadata/Slic3r_PE_model.config").decode()
    assert 'key="overhangs" value="0"' in cfg
    a = slicer.slice_mesh(tp.mesh, keep=tmp_path / "stl.gcode")
    b = slicer.slice_mesh(tp.mesh, keep=tmp_path / "3mf.gcode", file="3mf")
    c = slicer.slice_mesh(tp.mesh, keep=tmp_path / "set.gcode", config={"overhangs": False})
    assert a.returncode == 0 and b.returncode == 0 and c.returncode == 0, (a.log, b.log, c.log)
    ta, tb, tc = (slicer.read_toolpaths(tmp_path / f"{n}.gcode") for n in ("stl", "3mf", "set"))
    assert np.array_equal(ta.z, tb.z) and np.array_equal(ta.z, tc.z)
    moved = slicer.toolpath_deviation(ta, tc)
    assert moved.max() <= NOZZLE, moved
    assert tb.lengths.sum() == pytest.approx(ta.lengths.sum(), rel=0.01)
    assert b.cpu_seconds < 0.8 * a.cpu_seconds, (a.cpu_seconds, b.cpu_seconds)
