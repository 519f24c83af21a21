"""Slicing cost in CuraEngine (issue 29): the 3MF texcad writes carries Cura
per-object settings (``texcad.io.cura_settings``: skin edge support off), which
Cura's 3MF reader applies to the object and which ``slice_mesh`` passes to
CuraEngine's command line as that mesh's settings. On a textured top, CuraEngine
4.13 combines the terraced skin parts of the layers above every infill layer one
by one (``FffGcodeWriter::partitionInfillBySkinAbove``), most of its slicing time;
without it, the walls and the skin (what prints the texture) stay where they were.

The slicer test is skipped where CuraEngine is not installed; its one timing
assertion compares two slices of the same mesh, one after the other, with a wide
margin (about 0.5 measured)."""

import xml.etree.ElementTree as ET
import zipfile

import pytest

import texcad
from texcad.io import cura_settings
from texcad.io.export import CURA_NAMESPACE, CURA_SINGLE_RUN_SETTINGS, CURA_TEXTURE_SETTINGS
from texcad.report import slicer

cura = pytest.mark.skipif(slicer.find_slicer("curaengine") is None, reason="CuraEngine is not installed")
CORE = "{http://schemas.microsoft.com/3dmanufacturing/core/2015/02}"
NOZZLE = 0.4  # mm, texcad's CuraEngine definition
INSIDE = ("FILL", "SUPPORT", "SUPPORT-INTERFACE")  # what prints inside the part or beside it


def _cura_object_settings(path) -> dict:
    """The ``cura:`` settings of the 3MF's object as libSavitar reads them: the
    ``<metadatagroup>`` of the ``<object>``, each ``cura:key`` (the prefix bound to
    Cura's namespace) as the setting ``key``."""
    with zipfile.ZipFile(path) as z:
        model = z.read("3D/3dmodel.model").decode()
    root = ET.fromstring(model)
    assert not root.findall(f".//{CORE}object/{CORE}metadatagroup") or f'xmlns:cura="{CURA_NAMESPACE}"' in model
    out = {}
    for obj in root.iter(f"{CORE}object"):
        for m in obj.findall(f"{CORE}metadatagroup/{CORE}metadata"):
            prefix, _, key = m.get("name").partition(":")
            assert prefix == "cura"
            out[key] = m.text
    return out


def _plate(side: float = 40.0, pitch: float = 2.0):
    """A ``side`` mm square plate, 4 mm thick, under 2 mm high stones at ``pitch`` mm."""
    hm = texcad.builtin("stones", size=(side, side), pitch=pitch, height=2.0)
    return texcad.pipeline.textured_plate(hm, size=(side, side), thickness=4)


def test_the_3mf_carries_the_cura_settings_of_a_texture(tmp_path):
    """A textured result's 3MF (one part, or base and texture apart) holds skin edge
    support off as Cura's per-object metadata; a CAD shape's 3MF holds none."""
    from build123d import Box

    box = Box(10, 10, 10)
    tx = texcad.texture(box, box.faces().sort_by()[-1], "builtin:stones", height=1.0, pitch=1.0, brep=False)
    assert CURA_TEXTURE_SETTINGS == {"skin_edge_support_thickness": 0, "skin_edge_support_layers": 0}
    # stones on the top of a box printed +z: one run of solid on every vertical line
    want = {k: str(v) for k, v in {**CURA_TEXTURE_SETTINGS, **CURA_SINGLE_RUN_SETTINGS}.items()}
    tx.export(tmp_path / "t.3mf")
    assert _cura_object_settings(tmp_path / "t.3mf") == want
    texcad.export(tx, tmp_path / "s.3mf", separate_texture=True)
    assert _cura_object_settings(tmp_path / "s.3mf") == want
    texcad.export(box, tmp_path / "box.3mf")
    assert _cura_object_settings(tmp_path / "box.3mf") == {}
    assert cura_settings(textured=False) == {}
    # the mesh is the one the STL holds, whatever the metadata
    assert texcad.io.read_mesh(tmp_path / "t.3mf").num_triangles == tx.mesh.num_triangles


@cura
def test_cura_slices_texcads_output_faster_with_the_same_walls_and_skin(tmp_path):
    """A 40 mm stones plate at 2 mm pitch in CuraEngine: texcad's output (the STL
    with the 3MF's Cura settings) against the same STL alone. The infill walls
    under every skin edge are gone (less infill), the walls and the skin lie where
    they lay (within a bead), and the slice takes well under the plain STL's CPU time
    (about half measured)."""
    m = _plate().mesh
    cfg = slicer.support_config("curaengine", 45)
    plain = slicer.slice_mesh(m, slicer="curaengine", config=cfg, file="3mf", layout=False, keep=tmp_path / "plain.gcode")
    ours = slicer.slice_mesh(m, slicer="curaengine", config=cfg, file="3mf", keep=tmp_path / "ours.gcode")
    assert plain.returncode == 0 and ours.returncode == 0
    assert ours.support_mm == plain.support_mm == 0.0
    assert ours.lengths["FILL"] < 0.8 * plain.lengths["FILL"]
    moved = slicer.toolpath_deviation(
        slicer.read_toolpaths(tmp_path / "plain.gcode", exclude=INSIDE), slicer.read_toolpaths(tmp_path / "ours.gcode", exclude=INSIDE)
    )
    assert len(moved) and moved.max() < NOZZLE
    assert ours.cpu_seconds < 0.8 * plain.cpu_seconds


def test_single_run_finds_every_gap_along_the_build_direction():
    """``single_run``: a plate textured on its top meets every vertical line once
    (texture up or down), but not a horizontal one (through the stones); a slot
    through a cylinder is a gap along its axis, not across it; a slab on two legs
    has none along z and one along x (between the legs). Only such a part gets
    Cura's "no skin in z gaps"."""
    from build123d import Align, Box, Cylinder, Pos

    from texcad.brep import shape_to_mesh
    from texcad.io import single_run

    plate = _plate(20.0, 1.0).mesh
    assert single_run(plate) and single_run(plate, (0, 0, -1))
    assert not single_run(plate, (0, 1, 0)) and not single_run(plate, (1, 0, 0))
    slotted = _slotted(0.6)
    assert not single_run(slotted) and single_run(slotted, (1, 0, 0))
    table = shape_to_mesh(Box(30, 10, 2) + Pos(-12, 0, -5) * Box(6, 10, 10) + Pos(12, 0, -5) * Box(6, 10, 10))
    assert single_run(table) and not single_run(table, (1, 0, 0))
    assert CURA_SINGLE_RUN_SETTINGS.items() <= cura_settings(plate).items()
    assert cura_settings(slotted) == CURA_TEXTURE_SETTINGS and cura_settings(plate, textured=False) == {}


def _slotted(height: float):
    """A cylinder 20 mm across and 20 mm tall with a slot 6 mm wide and ``height`` mm
    tall through it at 10 mm: a gap along its axis."""
    from build123d import Align, Box, Cylinder, Pos

    from texcad.brep import shape_to_mesh

    return shape_to_mesh(Cylinder(10, 20, align=(Align.CENTER, Align.CENTER, Align.MIN)) - Pos(0, 0, 10) * Box(30, 6, height))


def _knurled_block(pitch: float = 1.0):
    """A 20 x 16 x 12 mm block with a 0.8 mm diamond knurl on its four sides (triplanar),
    limited for +z: gaps along z between the bumps, in the walls' depth."""
    import tempfile
    import warnings
    from pathlib import Path

    from build123d import Align, Box, export_stl

    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        stl = Path(tmp) / "block.stl"
        export_stl(Box(20, 16, 12, align=(Align.MIN, Align.MIN, Align.MIN)), str(stl))
        spec = ("not:normal:+z:30", "builtin:diamond_knurl:period=2.5", {"height": 0.8, "projection": "triplanar"})
        return texcad.texture(stl, [spec], pitch=pitch, build_dir=(0, 0, 1)).mesh


def test_skin_gap_area_sees_only_gaps_the_skin_can_see():
    """``skin_gap_area``: a slot thinner than the top thickness (0.6 mm) is a gap the
    skin sees (the layers under and over it get skin only without the setting); an
    8 mm slot, taller than the top thickness, and the gaps
    between a knurl's bumps on a side, within the walls' depth, are not: those parts
    get "no skin in z gaps" though a line along z meets them more than once."""
    from texcad.io.export import SKIN_GAP_AREA, skin_gap_area

    thin, tall, knurl = _slotted(0.6), _slotted(8.0), _knurled_block()
    assert skin_gap_area(thin) > 10.0  # mm^2: the slot's floor and ceiling, across the cylinder
    assert skin_gap_area(tall) <= SKIN_GAP_AREA and skin_gap_area(thin, (1, 0, 0)) <= SKIN_GAP_AREA
    assert not texcad.io.single_run(knurl) and skin_gap_area(knurl) <= SKIN_GAP_AREA
    assert CURA_SINGLE_RUN_SETTINGS.items() <= cura_settings(knurl).items()
    assert CURA_SINGLE_RUN_SETTINGS.items() <= cura_settings(tall).items()


def test_skin_gap_area_stops_at_the_first_gap_past_its_limit(monkeypatch):
    """With ``limit`` (what :func:`cura_settings` asks) the cross-sections are made
    from the bottom up and stop at the first run where a gap passes it: a 120 mm tall
    part with a thin slot 4 mm up is decided from its lowest few mm (a 118 mm tap
    handle took 51 CPU-s for every cross-section), with the same figure."""
    import importlib

    from build123d import Box, Cylinder, Pos

    ex = importlib.import_module("texcad.io.export")  # the module (texcad.io.export is also its function)

    part = Cylinder(8, 120) - Pos(0, 0, -56) * Box(20, 20, 0.6)
    m = texcad.brep.shape_to_mesh(part)
    made = []
    real = ex._SkinOffsets.__call__
    monkeypatch.setattr(ex._SkinOffsets, "__call__", lambda self, k: made.append(k) or real(self, k))
    limited = ex.skin_gap_area(m, limit=ex.SKIN_GAP_AREA)
    assert limited > 10.0 and max(made) < 250  # of 1200 cross-sections
    assert ex.skin_gap_area(m) == pytest.approx(limited, rel=1e-9)


@cura
def test_no_skin_in_z_gaps_gives_the_same_gcode_in_less_time(tmp_path):
    """A 30 mm stones plate at 1 mm pitch, 2 mm high (islands of stones over the
    connected lower levels of the texture): with "no skin in z gaps", which texcad
    writes for a part with one run along its build direction, every path CuraEngine
    lays (walls, skin, infill) is where it was without it, and the slice takes well
    under its CPU time (0.6 of it measured): each island's skin no longer intersects
    the whole web of the layers below and above it, layer by layer."""
    m = _plate(30.0, 1.0).mesh
    cfg = slicer.support_config("curaengine", 45)
    before = slicer.slice_mesh(m, slicer="curaengine", config={**cfg, **CURA_TEXTURE_SETTINGS}, keep=tmp_path / "before.gcode")
    ours = slicer.slice_mesh(m, slicer="curaengine", config=cfg, file="3mf", keep=tmp_path / "ours.gcode")
    assert before.returncode == 0 and ours.returncode == 0
    moved = slicer.toolpath_deviation(slicer.read_toolpaths(tmp_path / "before.gcode"), slicer.read_toolpaths(tmp_path / "ours.gcode"))
    assert len(moved) == before.layers and moved.max() < 0.01
    assert ours.cpu_seconds < 0.85 * before.cpu_seconds


@cura
@pytest.mark.parametrize("which", ["knurl", "tall slot", "thin slot"])
def test_no_skin_in_z_gaps_where_skin_gap_area_allows_it(tmp_path, which):
    """CuraEngine with and without "no skin in z gaps" on parts a line along z meets
    more than once: where ``skin_gap_area`` allows the setting (a knurled block, an
    8 mm slot) every path lies where it lay; where it does not (a 1 mm slot, thinner
    than the top thickness) the skin moves by more than a bead, which is why texcad
    does not write it there."""
    from texcad.io.export import SKIN_GAP_AREA, skin_gap_area

    m = {"knurl": _knurled_block, "tall slot": lambda: _slotted(8.0), "thin slot": lambda: _slotted(1.0)}[which]()
    cfg = {**slicer.support_config("curaengine", 45), **CURA_TEXTURE_SETTINGS}
    off = slicer.slice_mesh(m, slicer="curaengine", config=cfg, keep=tmp_path / "off.gcode")
    on = slicer.slice_mesh(m, slicer="curaengine", config={**cfg, **CURA_SINGLE_RUN_SETTINGS}, keep=tmp_path / "on.gcode")
    assert off.returncode == 0 and on.returncode == 0 and on.support_mm == off.support_mm
    moved = slicer.toolpath_deviation(slicer.read_toolpaths(tmp_path / "off.gcode"), slicer.read_toolpaths(tmp_path / "on.gcode"))
    allowed = skin_gap_area(m) <= SKIN_GAP_AREA
    assert allowed == (which != "thin slot")
    assert len(moved) == off.layers and (moved.max() < 0.01 if allowed else moved.max() > NOZZLE)
