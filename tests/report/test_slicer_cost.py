"""Slicing cost (issue 29): the 3MF texcad writes tells PrusaSlicer that a part has
no bridging perimeters to look for (``overhangs = 0``, texcad.io.slicer_settings)
and not to rank seams by visibility over a texture (``seam_position = rear``),
and where layers are crowded with small islands it cuts the part in two there, the
upper part with ``extra_perimeters = 0`` (texcad.io.slicer_layout): the two passes
that take most of the time PrusaSlicer spends on a texture. The toolpaths stay the
same.

The slicer tests are skipped where PrusaSlicer is not installed; the rest runs
everywhere. The one timing assertion compares two slices of the same mesh on the
same machine, one after the other, with a wide margin (about 0.55 measured)."""

import zipfile

import numpy as np
import pytest

import texcad
from texcad.io import extra_perimeter_cut, read_part, slicer_layout, slicer_settings, write_3mf
from texcad.io.export import TEXTURE_SEAM
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
    seam = {"seam_position": TEXTURE_SEAM}
    assert slicer_settings(tp.mesh) == {"overhangs": 0, **seam}
    assert slicer_settings(tp.mesh, (0, 0, -1)) == seam
    assert slicer_settings(_leaning(60.0), textured=False) == {"overhangs": 0}
    assert slicer_settings(_leaning(30.0), textured=False) == {}


def test_a_cad_shape_keeps_the_profiles_seam(tmp_path):
    """A textured result's 3MF carries the texture's seam setting; a CAD shape's
    3MF (no texture) does not."""
    from build123d import Box

    box = Box(10, 10, 10)
    texcad.export(box, tmp_path / "box.3mf")
    tx = texcad.texture(box, box.faces().sort_by()[-1], "builtin:stones", height=1.0, pitch=0.5, brep=False)
    tx.export(tmp_path / "tx.3mf")
    cfg = lambda n: zipfile.ZipFile(tmp_path / n).read("Metadata/Slic3r_PE_model.config").decode()
    assert f'key="seam_position" value="{TEXTURE_SEAM}"' in cfg("tx.3mf")
    assert "seam_position" not in cfg("box.3mf")


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


def _stones(side: float, pitch: float = 0.5):
    tex = texcad.builtin("stones", size=(side, side), pitch=pitch, height=2.0)
    return texcad.pipeline.textured_plate(tex, size=(side, side), thickness=3)


def _largest_share(man, z: float) -> float:
    """Largest share of the cross-section's contour length at ``z`` one island holds."""
    lengths = [sum(np.linalg.norm(np.diff(np.vstack([q, q[:1]]), axis=0), axis=1).sum() for q in isl.to_polygons())
               for isl in man.slice(z).decompose()]
    return max(lengths) / sum(lengths) if sum(lengths) > 0 else 0.0


def test_layout_cuts_where_islands_crowd_and_keeps_the_solid():
    """A 30 mm stones plate: cut above the plate, where every cross-section from
    the cut up has hundreds of islands, none holding a tenth of the contour, halfway
    between two multiples of 0.025 mm (no usual slicing plane on it); the two parts are closed and together hold the mesh's volume; the upper
    one carries extra_perimeters = 0. A one-island part (a plate leaning at 60
    degrees) and a part with bridges are not cut."""
    tp = _stones(30.0)
    assert slicer_layout(tp.mesh).cut is None  # small: the cut would cost more than the pass (CUT_MIN_WORK)
    lay = slicer_layout(tp.mesh, name="plate", min_work=0)
    low, top = float(tp.mesh.vertices[:, 2].min()), float(tp.mesh.vertices[:, 2].max())  # the plate's top at low + 3
    assert lay.cut is not None and 3.0 < lay.cut < top - low
    assert (lay.cut / 0.0125) % 2 == pytest.approx(1.0)
    cut = low + lay.cut
    (n0, below), (n1, above) = lay.parts
    assert n0 == "plate" and lay.part_settings == ({}, {"extra_perimeters": 0})
    assert below.is_watertight and above.is_watertight
    assert below.volume + above.volume == pytest.approx(tp.mesh.volume, rel=1e-6)
    assert float(below.vertices[:, 2].max()) == pytest.approx(cut, abs=1e-4)
    from texcad.solid import to_manifold

    man = to_manifold(tp.mesh)
    shares = [_largest_share(man, z) for z in np.arange(cut, top, 0.05)]  # twice as fine as texcad looks
    assert max(shares) <= 0.2, shares  # well under PrusaSlicer's 30 %, between texcad's sections too
    assert _largest_share(man, low + 3.2) > 0.3  # the plate's own top layers: one island, left as they are
    assert extra_perimeter_cut(_leaning(60.0), min_work=0) is None
    assert slicer_layout(tp.mesh, (0, 0, -1), min_work=0).parts == (("part", tp.mesh),)  # upside down: it bridges


def test_3mf_of_a_cut_part_names_both_parts_and_the_setting(tmp_path):
    tp = _stones(30.0)
    lay = slicer_layout(tp.mesh, min_work=0)
    write_3mf(list(lay.parts), tmp_path / "p.3mf", name="p", settings=lay.settings, part_settings=lay.part_settings)
    cfg = zipfile.ZipFile(tmp_path / "p.3mf").read("Metadata/Slic3r_PE_model.config").decode()
    assert cfg.count("<volume ") == 2 and cfg.count('key="extra_perimeters" value="0"') == 1
    assert cfg.index('key="extra_perimeters"') > cfg.index("above")  # on the upper part
    parts = read_part(tmp_path / "p.3mf")
    t = tp.mesh.vertices.astype(np.float64)[tp.mesh.faces]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum()
    # written on the 3MF's grid (2^-14 mm): every vertex moved by at most half a step
    assert abs(sum(m.volume for _, m in parts) - tp.mesh.volume) <= 2 * area * np.sqrt(3) * 2.0**-15


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
    """A 40 x 40 mm stones plate (0.25 mm pitch, 51 k triangles) at PrusaSlicer's
    defaults: texcad's 3MF (overhangs = 0; too small to be worth a cut) against the
    same mesh as a plain 3MF (same coordinates, nothing added). It takes less than
    0.8x the CPU time (about 0.55 measured when this test was written), and no path
    moves by a nozzle width on any layer once specks are left out (unbroken
    extrusions under 0.4 mm across: perimeters of 0.1 mm islands, which come and go
    when a coordinate moves by a micrometre)."""
    tp = _stones(40.0, 0.25)
    tp.export(tmp_path / "plate.3mf")
    cfg = zipfile.ZipFile(tmp_path / "plate.3mf").read("Metadata/Slic3r_PE_model.config").decode()
    assert 'key="overhangs" value="0"' in cfg and "extra_perimeters" not in cfg
    a, b = _plain_and_laid_out(tp.mesh, tmp_path)
    assert b.cpu_seconds < 0.8 * a.cpu_seconds, (a.cpu_seconds, b.cpu_seconds)


def _plain_and_laid_out(mesh, tmp_path, build_dir=(0.0, 0.0, 1.0)):
    """PrusaSlicer's reports on ``mesh`` as a plain one-part 3MF and as texcad's 3MF
    (its layout and settings), after checking that both print the same: the same
    layers, every path within a nozzle width (specks left out), the same length
    within 1 %."""
    a = slicer.slice_mesh(mesh, build_dir=build_dir, keep=tmp_path / "plain.gcode", file="3mf", layout=False)
    b = slicer.slice_mesh(mesh, build_dir=build_dir, keep=tmp_path / "3mf.gcode", file="3mf")
    assert a.returncode == 0 and b.returncode == 0, (a.log, b.log)
    ta, tb = (slicer.read_toolpaths(tmp_path / f"{n}.gcode") for n in ("plain", "3mf"))
    assert np.array_equal(ta.z, tb.z)
    moved = slicer.toolpath_deviation(ta.without_specks(NOZZLE), tb.without_specks(NOZZLE))
    assert moved.max() <= NOZZLE, moved
    assert tb.lengths.sum() == pytest.approx(ta.lengths.sum(), rel=0.01)
    return a, b


@prusa
def test_a_cut_plate_prints_the_same_texture(tmp_path, monkeypatch):
    """A 30 mm stones plate (0.5 mm pitch) cut where its islands crowd (the cut made
    however small the saving, ``min_work=0``), at PrusaSlicer's defaults, against
    the same mesh as a plain 3MF: the same layers, the outer walls (the texture as
    printed, ``OUTER_WALLS``) within a nozzle width on every layer (specks left out;
    0.28 mm measured, where Arachne routes a one-line wall in a sliver at the plate's
    edge another way, about 0.03 mm elsewhere) and the same path length within 1 %.
    Inner paths are not held here: next to a cut PrusaSlicer can lay an island's
    solid infill a line further on, as it does when the plain mesh moves by a
    micrometre (docs/benchmarks/slicer_cost.md)."""
    from functools import partial

    import texcad.io

    tp = _stones(30.0)
    monkeypatch.setattr(texcad.io, "slicer_layout", partial(slicer_layout, min_work=0))
    a = slicer.slice_mesh(tp.mesh, keep=tmp_path / "plain.gcode", file="3mf", layout=False)
    b = slicer.slice_mesh(tp.mesh, keep=tmp_path / "cut.gcode", file="3mf")
    assert a.returncode == 0 and b.returncode == 0, (a.log, b.log)
    assert slicer_layout(tp.mesh, min_work=0).cut is not None
    walls = [slicer.read_toolpaths(tmp_path / f"{n}.gcode", only=slicer.OUTER_WALLS) for n in ("plain", "cut")]
    assert np.array_equal(walls[0].z, walls[1].z)
    moved = slicer.toolpath_deviation(*(w.without_specks(NOZZLE) for w in walls))
    assert moved.max() <= NOZZLE, moved
    ta, tb = (slicer.read_toolpaths(tmp_path / f"{n}.gcode") for n in ("plain", "cut"))
    assert tb.lengths.sum() == pytest.approx(ta.lengths.sum(), rel=0.01)


def test_outer_walls_are_read_alone(tmp_path):
    """``only=OUTER_WALLS`` keeps PrusaSlicer's external perimeters and CuraEngine's
    outer wall and leaves out inner perimeters and infill."""
    sq = lambda x0: "".join(f"G1 X{x0 + x:.3f} Y{y:.3f} E0.1\n" for x, y in ((10, 0), (10, 10), (0, 10), (0, 0)))
    text = (";LAYER_CHANGE\nG1 Z0.2\nG1 X0 Y0\n;TYPE:External perimeter\n" + sq(0.0) + ";TYPE:Perimeter\n" + sq(20.0)
            + ";TYPE:WALL-OUTER\n" + sq(40.0) + ";TYPE:Solid infill\n" + sq(60.0))
    (tmp_path / "a.gcode").write_text(text)
    t = slicer.read_toolpaths(tmp_path / "a.gcode", only=slicer.OUTER_WALLS)
    assert np.allclose(t.lengths, [40.0 + 60.0])  # each square's moves, from where the one before ended
    assert np.allclose(slicer.read_toolpaths(tmp_path / "a.gcode").lengths, [40.0 + 3 * 60.0])


def test_specks_are_the_short_unbroken_extrusions(tmp_path):
    """A 10 mm square and, after a travel, a 0.1 mm square: without specks of 0.4 mm
    only the big one is left."""
    sq = lambda x0, w: "".join(f"G1 X{x0 + x:.3f} Y{y:.3f} E0.1\n" for x, y in ((w, 0), (w, w), (0, w), (0, 0)))
    text = ";LAYER_CHANGE\nG1 Z0.2\nG1 X0 Y0\n;TYPE:External perimeter\n" + sq(0.0, 10.0) + "G1 X20 Y0\n" + sq(20.0, 0.1)
    (tmp_path / "a.gcode").write_text(text)
    t = slicer.read_toolpaths(tmp_path / "a.gcode")
    assert len(t.layer) == 8 and len(np.unique(t.run)) == 2
    k = t.without_specks(0.4)
    assert len(k.layer) == 4 and np.allclose(k.lengths, [40.0])


@prusa
def test_upright_plate_slices_without_the_seam_pass(tmp_path):
    """The flat plate recipe's part (a 20 mm stones plate standing upright, 13 k
    triangles) at PrusaSlicer's defaults: ranking seams by visibility is most of
    its time (1.38 CPU-s as a plain 3MF, 0.45 with seam_position = rear, the bare
    plate 0.12, when this test was written). texcad's 3MF takes less than 0.6x the
    plain 3MF's CPU time, and its paths lie within a nozzle width of the plain
    one's on every layer (the seams move where a loop starts, not where it runs)."""
    d = texcad.orientation(90, "+y")
    tp = texcad.pipeline.textured_plate(texcad.builtin("stones", size=(20, 20), pitch=0.25, height=1.0), size=(20, 20), thickness=4, build_dir=d)
    a, b = _plain_and_laid_out(tp.mesh, tmp_path, build_dir=d)
    assert b.cpu_seconds < 0.6 * a.cpu_seconds, (a.cpu_seconds, b.cpu_seconds)


def test_a_cut_that_does_not_hold_the_mesh_is_not_written(monkeypatch):
    """The cut is an optimisation: parts that are not closed, or do not hold the
    mesh's volume together (a split gone wrong), leave the mesh whole."""
    import texcad.solid as solid
    from texcad.solid import Mesh

    tp = _stones(30.0)
    assert slicer_layout(tp.mesh, min_work=0).cut is not None
    real = solid.from_manifold

    def shrunk(man):  # a part 1 % smaller: still closed, the wrong solid
        m = real(man)
        c = m.vertices.mean(axis=0)
        return Mesh(c + 0.99 * (m.vertices - c), m.faces)

    monkeypatch.setattr(solid, "from_manifold", shrunk)
    lay = slicer_layout(tp.mesh, min_work=0)
    assert lay.cut is None and lay.parts == (("part", tp.mesh),)
