"""Zones on CAD parts (issue 31): ``texcad.texture(part, [(faces, texture, {options}), ...])``
textures several face groups in one pass of the any-faces adapter, each with its own
texture, height and mode. Every zone's relief is measured on the result's vertices,
against the part's own planes and cylinder (not against texcad's figures); the zones
stay apart in the 3MF; bad zones are refused naming the zone."""

from __future__ import annotations

import re
import warnings
import zipfile

import numpy as np
import pytest

import texcad
from texcad.brep import check_shape
from texcad.errors import GeometryError, ParameterError
from texcad.targets import FacesAdapter

PITCH = 0.5
#: mm: the relief's top against the height asked (lean mesh within tolerance 0.02, OCCT's chord 0.01)
TOL = 0.04
#: mm: a vertex this far off a face has moved
OFF = 1e-3


def _quiet(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return texcad.texture(*args, **kw)


def _names_3mf(path) -> list:
    with zipfile.ZipFile(path) as z:
        cfg = z.read("Metadata/Slic3r_PE_model.config").decode()
    return re.findall(r'key="name" value="([^"]*)"', cfg)[1:]


@pytest.fixture(scope="module")
def box_zones():
    """A 30 x 30 x 20 mm box (faces at x, y = +-15, z = +-10): the top knurled 0.8 mm,
    the +x side with stones 0.4 mm; they touch along the edge x = 15, z = 10."""
    from build123d import Axis, Box

    box = Box(30, 30, 20)
    top, side = box.faces().sort_by(Axis.Z)[-1], box.faces().sort_by(Axis.X)[-1]
    tx = _quiet(box, [(top, "builtin:diamond_knurl", {"height": 0.8}), (side, "builtin:stones", {"height": 0.4})],
                pitch=PITCH)
    return box, tx


def test_box_zones_run_once_through_the_faces_adapter(box_zones):
    _, tx = box_zones
    assert isinstance(tx.stages.adapter, FacesAdapter)
    fp = tx.stages.placement.data
    assert fp.zoned and len(fp.zones) == 2 and fp.zone_of == (0, 1)
    assert [z.options.height for z in fp.zones] == [0.8, 0.4]
    assert tx.info["zones"] == ["zone 1 builtin:diamond_knurl", "zone 2 builtin:stones"]


def test_box_zones_each_reach_their_own_height_on_their_own_face(box_zones):
    _, tx = box_zones
    m = tx.mesh
    assert m.is_watertight and tx.gate.shells.bodies == 1 and tx.gate.shells.closed
    v = m.vertices.astype(np.float64)
    x, y, z = v.T
    above_top, beyond_side = z > 10 + OFF, x > 15 + OFF
    # the top zone: over the top face only, up to its 0.8 mm
    assert above_top.sum() > 1000
    assert np.all(np.abs(x[above_top]) <= 15 + OFF) and np.all(np.abs(y[above_top]) <= 15 + OFF)
    assert abs(z[above_top].max() - 10 - 0.8) < TOL
    # the side zone: on the +x face only, up to its 0.4 mm (the top's 0.8 mm texture never reaches it)
    assert beyond_side.sum() > 1000
    assert np.all(z[beyond_side] <= 10 + OFF) and np.all(np.abs(y[beyond_side]) <= 15 + OFF)
    assert abs(x[beyond_side].max() - 15 - 0.4) < TOL
    assert not np.any(above_top & beyond_side)  # the shared edge: nothing sticks out over it
    # the other faces did not move
    assert x.min() >= -15 - OFF and np.abs(y).max() <= 15 + OFF and z.min() >= -10 - OFF
    # each zone's own texture: the side's stones are not the top's knurl (their height profiles differ)
    hz = [r.heightmap.heights for r in tx.stages.fused.data.patches]
    assert abs(float(hz[0].max()) - 0.8) < TOL and abs(float(hz[1].max()) - 0.4) < TOL


def test_each_zone_is_checked_against_its_own_height(box_zones):
    """The adapter's per-zone check measures each zone's farthest vertex from its own
    faces, and refuses a relief that landed on another zone's faces (here: the zones'
    faces swapped after the fact, so the 0.8 mm knurl stands on the 0.4 mm zone)."""
    import dataclasses

    from texcad.targets.faces import _zone_reach

    _, tx = box_zones
    zr = tx.info["zone_reliefs"]
    assert abs(zr[0]["farthest_mm"] - 0.8) < TOL and abs(zr[1]["farthest_mm"] - 0.4) < TOL
    assert zr[1]["reach_mm"] < 0.8 < zr[0]["reach_mm"]
    st = tx.stages
    fp = st.placement.data
    a, b = fp.zones
    swapped = dataclasses.replace(fp, zones=(dataclasses.replace(a, faces=b.faces), dataclasses.replace(b, faces=a.faces)))
    with pytest.raises(GeometryError, match=r"zone 2 builtin:stones: \d+ vertices lie up to 0.8\d* mm from its faces"):
        _zone_reach(st.fused.mesh, st.placement.base, swapped, st.relief.data, list(st.fused.data.patches), [{}, {}])


def test_box_zones_meet_cleanly_at_the_shared_edge(box_zones):
    """Within 1 mm of the edge both reliefs have ramped down (no step, no overhang at the edge)."""
    _, tx = box_zones
    v = tx.mesh.vertices.astype(np.float64)
    x, z = v[:, 0], v[:, 2]
    near_top = (z > 10 + OFF) & (x > 14)
    near_side = (x > 15 + OFF) & (z > 9)
    assert z[near_top].max(initial=10) - 10 < 0.1 and x[near_side].max(initial=15) - 15 < 0.1


def test_box_zones_layers_and_3mf_parts(box_zones, tmp_path):
    _, tx = box_zones
    a, b = tx.layer_meshes
    assert a.is_watertight and b.is_watertight and a.volume > 10 and b.volume > 10
    va, vb = a.vertices.astype(np.float64), b.vertices.astype(np.float64)
    assert va[:, 2].min() >= 10 - OFF and va[:, 2].max() <= 10.8 + TOL  # the top zone's body lies on the top face
    assert vb[:, 0].min() >= 15 - OFF and vb[:, 0].max() <= 15.4 + TOL  # the side zone's on the side
    assert abs(tx.base_mesh.volume + a.volume + b.volume - tx.mesh.volume) < 1e-4 * tx.mesh.volume  # they split the part
    tx.export(tmp_path / "zones.3mf", separate_texture=True)
    assert _names_3mf(tmp_path / "zones.3mf") == ["base", "zone 1 builtin:diamond_knurl", "zone 2 builtin:stones"]
    tx.export(tmp_path / "zones.stl")
    back = texcad.load_mesh(tmp_path / "zones.stl")
    assert back.is_watertight and abs(back.volume - tx.mesh.volume) < 1e-3 * tx.mesh.volume


def test_box_zones_same_bytes_twice(box_zones, tmp_path):
    from build123d import Axis

    box, tx = box_zones
    top, side = box.faces().sort_by(Axis.Z)[-1], box.faces().sort_by(Axis.X)[-1]
    again = _quiet(box, [(top, "builtin:diamond_knurl", {"height": 0.8}), (side, "builtin:stones", {"height": 0.4})], pitch=PITCH)
    tx.export(tmp_path / "a.stl")
    again.export(tmp_path / "b.stl")
    assert (tmp_path / "a.stl").read_bytes() == (tmp_path / "b.stl").read_bytes()


def test_box_zones_step_has_both_zones(box_zones, tmp_path):
    """Planar zones have a B-rep: the STEP's volume is the mesh's."""
    box, tx = box_zones
    tx.export(tmp_path / "zones.step")
    step = texcad.load_mesh(tmp_path / "zones.step")
    assert abs(step.volume - tx.mesh.volume) < 0.01 * (tx.mesh.volume - box.volume)


@pytest.fixture(scope="module")
def cylinder_zones():
    """A cylinder r 12 mm, z = +-10: its side knurled 0.6 mm raised, its top engraved
    0.4 mm with stones."""
    from build123d import Axis, Cylinder, GeomType

    cyl = Cylinder(12, 20)
    side, top = cyl.faces().filter_by(GeomType.CYLINDER), cyl.faces().sort_by(Axis.Z)[-1]
    tx = _quiet(cyl, [(side, "builtin:diamond_knurl", {"height": 0.6}), (top, "builtin:stones", {"height": 0.4, "mode": "engraved"})],
                pitch=PITCH)
    return cyl, tx


def test_cylinder_zones_heights_and_modes(cylinder_zones):
    _, tx = cylinder_zones
    m = tx.mesh
    assert m.is_watertight and tx.gate.shells.bodies == 1
    v = m.vertices.astype(np.float64)
    r, z = np.hypot(v[:, 0], v[:, 1]), v[:, 2]
    out = r > 12 + 0.02  # beyond the tessellated cylinder (chord error 0.01 mm)
    assert out.sum() > 1000 and np.all(np.abs(z[out]) <= 10 + OFF)
    assert abs(r.max() - 12 - 0.6) < TOL  # the side zone: its 0.6 mm, raised
    assert z.max() <= 10 + OFF  # the top zone is engraved: nothing above the top face, not even the side's knurl
    cut = (r < 10) & (z < 10 - OFF) & (z > 9)
    assert cut.sum() > 500 and abs(10 - z[cut].min() - 0.4) < TOL  # engraved 0.4 mm deep
    assert z.min() >= -10 - OFF  # the bottom did not move
    zr = tx.info["zone_reliefs"]
    assert [z["mode"] for z in zr] == ["raised", "engraved"] and abs(zr[1]["max_depth"] - 0.4) < TOL


def test_cylinder_zones_3mf_each_zone_a_part(cylinder_zones, tmp_path):
    cyl, tx = cylinder_zones
    layers = tx.layer_meshes
    assert len(layers) == 2 and all(m.is_watertight and m.volume > 5 for m in layers)
    side, top = (m.vertices.astype(np.float64) for m in layers)
    assert np.hypot(side[:, 0], side[:, 1]).min() >= 12 - 0.02
    assert top[:, 2].min() >= 10 - 0.4 - TOL and top[:, 2].max() <= 10 + OFF
    # the base part is the part with the engraving at its deepest: base and zones split the
    # textured part's volume, with no overlap and nothing left out
    assert tx.base_mesh.volume < cyl.volume - 0.9 * layers[1].volume
    assert abs(tx.base_mesh.volume + sum(m.volume for m in layers) - tx.mesh.volume) < 1e-4 * tx.mesh.volume
    tx.export(tmp_path / "cyl.3mf", separate_texture=True)
    assert _names_3mf(tmp_path / "cyl.3mf") == ["base", "zone 1 builtin:diamond_knurl", "zone 2 builtin:stones"]


def test_zones_touching_along_a_smooth_edge_stay_apart(tmp_path):
    """A top face and the fillet tangent to it: one patch when textured together, but
    in two zones each keeps its own texture and ramps at the tangent edge."""
    from build123d import Axis, Box, GeomType, fillet

    b = fillet(Box(30, 30, 20).edges().group_by(Axis.Z)[-1].group_by(Axis.X)[-1], radius=6)
    top, side = b.faces().sort_by(Axis.Z)[-1], b.faces().sort_by(Axis.X)[-1]
    (fil,) = b.faces().filter_by(GeomType.CYLINDER)
    one = _quiet(b, [top, fil], "builtin:stones", pitch=PITCH, height=0.3)
    assert len(one.stages.fused.data.patches) == 1  # tangent: flattened together
    tx = _quiet(b, [(top, "builtin:diamond_knurl", {"height": 0.6}), ([fil, side], "builtin:stones", {"height": 0.3})],
                pitch=PITCH)
    patches = [set(p.faces) for p in tx.stages.fused.data.patches]
    assert len(patches) == 2 and not (patches[0] & patches[1])
    assert tx.mesh.is_watertight and tx.gate.shells.bodies == 1
    v = tx.mesh.vertices.astype(np.float64)
    assert abs(v[:, 2].max() - 10 - 0.6) < TOL and abs(v[:, 0].max() - 15 - 0.3) < TOL
    zr = tx.info["zone_reliefs"]
    assert abs(zr[0]["farthest_mm"] - 0.6) < TOL and abs(zr[1]["farthest_mm"] - 0.3) < TOL
    # faces flattened together (the fillet and the side, LSCM) have a B-rep too (issue 28): the STEP reads back valid
    tx.export(tmp_path / "x.step")
    assert check_shape(texcad.io.read_step(tmp_path / "x.step"))["valid"]


def test_cadquery_selections_as_zones():
    cq = pytest.importorskip("cadquery")
    wp = cq.Workplane().box(30, 30, 20)
    tx = _quiet(wp, [(wp.faces(">Z"), "builtin:diamond_knurl", {"height": 0.8}), (wp.faces(">X"), "builtin:stones", {"height": 0.4})],
                pitch=PITCH)
    assert [round(z["farthest_mm"], 2) for z in tx.info["zone_reliefs"]] == [0.8, 0.4] and tx.mesh.is_watertight
    one = _quiet(wp, [(wp.faces(">Z").val(), "builtin:stones")], pitch=PITCH)  # one zone, one planar face
    assert isinstance(one.stages.adapter, FacesAdapter) and one.info["zones"] == ["zone 1 builtin:stones"]


def test_zone_forms_mapping_default_texture_and_heightmap():
    """A mapping {face: texture} (None leaves a face alone), a zone texture None (the
    call's texture), and a Heightmap zone keeping its own heights."""
    from build123d import Axis, Box

    box = Box(20, 20, 10)
    top, side = box.faces().sort_by(Axis.Z)[-1], box.faces().sort_by(Axis.X)[-1]
    tx = _quiet(box, {top: "builtin:stones", side: None}, pitch=PITCH, height=0.5)
    assert tx.info["zones"] == ["zone 1 builtin:stones"] and tx.mesh.vertices[:, 0].max() <= 10 + OFF
    hm = texcad.builtin("stones", size=(10, 10), pitch=PITCH, height=0.3)
    tx = _quiet(box, [(top, None), (side, hm)], "builtin:diamond_knurl", pitch=PITCH, height=0.7)
    zs = tx.stages.placement.data.zones
    assert zs[0].texture == "builtin:diamond_knurl" and zs[0].options.height == 0.7
    assert abs(zs[1].options.height - hm.max_height) < 1e-9
    v = tx.mesh.vertices.astype(np.float64)
    assert abs(v[:, 0].max() - 10 - hm.max_height) < TOL and abs(v[:, 2].max() - 5 - 0.7) < TOL


def test_zone_pitch_and_rotation_are_the_zones_own(tmp_path):
    """A zone's pitch lays its own grid, its rotation turns its own texture, in the
    mesh and in the B-rep (the STEP encloses the mesh's volume)."""
    from build123d import Axis, Box

    from texcad import brep

    box = Box(30, 30, 20)
    top, side = box.faces().sort_by(Axis.Z)[-1], box.faces().sort_by(Axis.X)[-1]
    tx = _quiet(box, [(top, "builtin:ridges", {"height": 0.8, "rotation": 45, "pitch": 0.25}), (side, "builtin:ridges", {"height": 0.4})],
                pitch=PITCH)
    a, b = tx.stages.fused.data.patches
    assert a.heightmap.pitch == (0.25, 0.25) and b.heightmap.pitch == (PITCH, PITCH)
    assert a.info["rotation"] == 45.0 and b.info["rotation"] == 0.0
    tx.export(tmp_path / "rot.step")
    shape = texcad.io.read_step(tmp_path / "rot.step")
    # within the lean mesh's tolerance (0.02 mm) over the textured area (1500 mm2); the top's
    # grid read in an unturned frame misses by 174 mm3
    assert brep.check_shape(shape)["valid"] and abs(brep.volume(shape) - tx.mesh.volume) < 0.02 * 1500


@pytest.mark.parametrize(
    "zones, match",
    [
        (lambda t, s, c: [(t, "builtin:stones"), ([t, s], "builtin:diamond_knurl")], r"face \d+ is in zone 1 and in zone 2"),
        (lambda t, s, c: [(t, "builtin:stones"), (c, "builtin:stones")], r"zone 2: no face selected"),
        (lambda t, s, c: [(t, "builtin:stones", {"heigth": 1.0})], r"zone 1 \(builtin:stones\): heigth: not an option"),
        (lambda t, s, c: [(t, "builtin:stones", {"build_dir": (0, 0, 1)})], r"zone 1 .*build_dir: an option of the whole call"),
        (lambda t, s, c: [(t, "builtin:stones"), (s, "builtin:stones", {"height": -1})], r"zone 2 .*height must be a positive"),
        (lambda t, s, c: [(t, "builtin:stones"), (s, "builtin:stones", "engraved")], r"zone 2 is .*\(faces, texture, \{options\}\)"),
    ],
    ids=["same-face-twice", "empty-zone", "unknown-option", "call-option", "bad-value", "not-a-zone"],
)
def test_bad_zones_are_refused_naming_the_zone(zones, match):
    from build123d import Axis, Box, GeomType

    box = Box(20, 20, 10)
    top, side = box.faces().sort_by(Axis.Z)[-1], box.faces().sort_by(Axis.X)[-1]
    none = box.faces().filter_by(GeomType.CYLINDER)  # empty
    with pytest.raises(ParameterError, match=match):
        texcad.texture(box, zones(top, side, none), pitch=PITCH)


def test_cli_zones_on_a_step_part(tmp_path, capsys):
    from build123d import Box, export_step

    from texcad.cli import main

    export_step(Box(30, 30, 20), str(tmp_path / "box.step"))
    out = tmp_path / "box.3mf"
    assert main(["texture", str(tmp_path / "box.step"), "--zone", "top@builtin:diamond_knurl@height=0.8",
                 "--zone", "right+front@builtin:stones@engraved,height=0.5", "--pitch", str(PITCH), "-q",
                 "--separate-texture", "-o", str(out)]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert re.search(r"zone 1 +faces \[5\]: builtin:diamond_knurl raised, height 0.8 mm, reached 0.80 mm", text)
    assert re.search(r"zone 2 +faces \[1, 2\]: builtin:stones engraved, height 0.5 mm", text)
    assert _names_3mf(out) == ["base", "zone 1 builtin:diamond_knurl", "zone 2 builtin:stones"]
    bad = main(["texture", str(tmp_path / "box.step"), "--zone", "top@builtin:stones@heigth=1", "-o", str(tmp_path / "x.stl")])
    assert bad == 2 and "zone 1 (builtin:stones): heigth: not an option" in capsys.readouterr().err
    both = main(["texture", str(tmp_path / "box.step"), "--face", "top", "--zone", "right@", "-o", str(tmp_path / "x.stl")])
    assert both == 2 and "not both" in capsys.readouterr().err
