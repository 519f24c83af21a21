"""Assemblies (issue 27): the solid that owns the selected faces is textured, the
others are kept as they were, as separate bodies; ``solid:K/top`` restricts a
selector to one solid. A case with a phone and a button that overlap it, made here
with build123d and exported to STEP."""

from __future__ import annotations

import pytest

from texcad.cli import main
from texcad.errors import ParameterError

build123d = pytest.importorskip("build123d")


@pytest.fixture(scope="module")
def assembly(tmp_path_factory):
    from build123d import Box, Compound, Pos, export_step

    case = Box(30, 20, 10) - Pos(0, 0, 3) * Box(26, 16, 6)  # an open tray, 3920 mm3
    phone = Pos(0, 0, 2) * Box(25, 15, 4)  # stands on the tray's floor
    button = Pos(15.5, 0, 2) * Box(2, 4, 2)  # overlaps the tray's wall
    p = tmp_path_factory.mktemp("asm") / "asm.step"
    export_step(Compound([case, phone, button]), str(p))
    return p


def test_solid_selector_and_owner(assembly):
    from build123d import Compound

    from texcad.brep.assembly import owner_solid, solid_selector, split_assembly
    from texcad.brep.selectors import named as pick_faces
    from texcad.io import read_step

    assert solid_selector("solid:2/top") == (2, "top") and solid_selector("top") == (None, "top")
    with pytest.raises(ParameterError, match="solid:K/SELECTOR"):
        solid_selector("solid:x")
    part = Compound(read_step(assembly))
    solids = part.solids()
    top1 = pick_faces(solids[1], "top")
    k, solid, others = split_assembly(part, top1)
    assert k == 1 and solid.volume == pytest.approx(1500.0) and len(others) == 2
    with pytest.raises(ParameterError, match="solids 0, 1"):
        owner_solid(part, pick_faces(solids[0], "bottom") + top1)


def test_one_solid_textured_the_others_kept(assembly, tmp_path, capsys):
    import texcad

    stl, m3f = tmp_path / "a.stl", tmp_path / "a.3mf"
    args = ["texture", str(assembly), "--face", "solid:0/bottom", "--texture", "builtin:ridges", "--pitch", "1",
            "--height", "0.5", "-q", "-o", str(stl), "-o", str(m3f)]
    assert main(args) == 0
    assert "solid        0 of 3 textured" in capsys.readouterr().out
    parts = texcad.io.read_part(m3f)
    assert [n for n, _ in parts] == ["solid 0 (textured)", "solid 1", "solid 2"]
    assert all(m.is_watertight for _, m in parts)
    assert parts[0][1].volume > 3920.0 + 1.0  # the tray with its texture
    assert parts[1][1].volume == pytest.approx(1500.0, rel=1e-6)  # kept as they were
    assert parts[2][1].volume == pytest.approx(16.0, rel=1e-6)
    one = texcad.io.read_mesh(stl)  # the solids united: the button's 4 mm3 in the tray's wall counted once
    assert one.is_watertight and one.volume == pytest.approx(sum(m.volume for _, m in parts) - 4.0, abs=0.05)


def test_faces_of_several_solids_are_one_line(assembly, tmp_path, capsys):
    args = ["texture", str(assembly), "--face", "solid:0/bottom", "--face", "solid:1/top", "-o", str(tmp_path / "x.stl")]
    assert main(args) == 2
    assert "texture one solid at a time" in capsys.readouterr().err
    assert main(["texture", str(assembly), "--face", "solid:7/top", "-o", str(tmp_path / "x.stl")]) == 2
    assert "3 solid(s)" in capsys.readouterr().err


# --- an open OCCT tessellation, healed by sewing (texcad.brep.tessellation) -----------

def _unsewn_solid():
    """A tube whose faces do not share edges: the planar ends as NURBS copies, the
    cylinders as copies, put in one shell unsewn (as some CAD exports are): each face
    discretizes its own copy of an edge differently, so the default tessellation is open."""
    from build123d import Cylinder, Pos
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy, BRepBuilderAPI_NurbsConvert
    from OCP.TopoDS import TopoDS_Shell, TopoDS_Solid

    b, shell = BRep_Builder(), TopoDS_Shell()
    b.MakeShell(shell)
    for f in (Cylinder(10, 20) - Pos(3, 0, 0) * Cylinder(2, 20)).faces():  # per face: its own edges
        w = BRepBuilderAPI_NurbsConvert(f.wrapped, True).Shape() if f.geom_type.name == "PLANE" else BRepBuilderAPI_Copy(f.wrapped).Shape()
        b.Add(shell, w)
    solid = TopoDS_Solid()
    b.MakeSolid(solid)
    b.Add(solid, shell)
    return solid


def test_an_open_tessellation_is_healed_by_sewing():
    import math

    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    from texcad.brep import explore, part_tessellation
    from texcad.brep import tessellation as tess
    from texcad.errors import GeometryError
    from texcad.solid import to_manifold

    solid = _unsewn_solid()
    BRepMesh_IncrementalMesh(solid, tess.TESSELLATION, False, 0.1, True)
    own = [TopoDS.Face_s(f) for f in explore(solid, TopAbs_FACE)]
    plain = tess._weld([tess._face_triangles(f) for f in own], 1e-3)
    with pytest.raises(GeometryError):  # the default tessellation, even welded wide, is open
        to_manifold(plain.mesh)
    assert "open or non-manifold edges on faces" in tess._open_faces(plain)
    pm = part_tessellation(solid)
    m = to_manifold(pm.mesh)
    assert m.volume() == pytest.approx(math.pi * (100 - 4) * 20, rel=5e-3)
    for fm in pm.faces:  # the sewn faces' triangles stand for the part's own faces
        assert any(fm.face.IsSame(f) for f in own)
    assert len(pm.faces) == len(own)


# --- the API: texcad.texture(assembly, face of solid k) (brep/assembly.py, driver hook) ----

@pytest.fixture(scope="module")
def overlapping():
    from build123d import Box, Compound, Pos

    case = Box(30, 20, 10) - Pos(0, 0, 3) * Box(26, 16, 6)  # 3920 mm3
    phone = Pos(0, 0, 2) * Box(25, 15, 4)  # 1500 mm3, stands on the tray's floor
    button = Pos(15.5, 0, 2) * Box(2, 4, 2)  # 16 mm3, overlaps the tray's wall
    return Compound([case, phone, button])


def test_api_textures_the_solid_that_owns_the_face_and_keeps_the_others(overlapping, tmp_path):
    import numpy as np
    from build123d import Axis, import_step

    import texcad
    from texcad.solid.overlap import split_bodies

    phone_top = overlapping.solids()[1].faces().sort_by(Axis.Z)[-1]
    tx = texcad.texture(overlapping, phone_top, "builtin:ridges", pitch=1.0, height=0.5)
    assert tx.info["solid"] == 1 and tx.info["solids"] == 3 and "solid 1 of 3" in repr(tx)
    assert tx.gate.shells.bodies == 1 and tx.mesh.is_watertight  # the gate saw the textured solid alone
    assert tx.mesh.volume > 1500.0 + 1.0  # the phone with its texture
    stl, m3f, step = tmp_path / "a.stl", tmp_path / "a.3mf", tmp_path / "a.step"
    for p in (m3f, step):
        tx.export(p)
    with pytest.warns(texcad.TexcadWarning, match=r"solids meet \(body 1 .* overlap by .*the STL holds their union"):
        tx.export(stl)
    parts = texcad.io.read_part(m3f)  # one named part per solid, the others unchanged
    assert [n for n, _ in parts] == ["solid 1 (textured)", "solid 0", "solid 2"]
    assert all(m.is_watertight for _, m in parts)
    assert parts[1][1].volume == pytest.approx(3920.0, rel=1e-6) and parts[2][1].volume == pytest.approx(16.0, rel=1e-6)
    for (_, part), kept in zip(parts[1:], tx.other_meshes):
        assert np.array_equal(np.asarray(part.vertices, np.float32), np.asarray(kept.vertices, np.float32))
    # the STL: the overlapping solids united (what a slicer prints), one closed body, gated
    one = texcad.io.read_mesh(stl)
    split = split_bodies(one.vertices, one.faces)
    assert one.is_watertight and len(split.volumes) == 1
    assert one.volume == pytest.approx(sum(m.volume for _, m in parts) - 4.0, abs=0.05)  # the button's overlap once
    assert [round(s.volume) for s in import_step(str(step)).solids()][1:] == [3920, 16]
    # the same through OCP's compound, and a face of the case (solid 0, which the others overlap)
    tx0 = texcad.texture(overlapping.wrapped, overlapping.solids()[0].faces().sort_by(Axis.Z)[0], "builtin:ridges",
                         pitch=1.0, height=0.5)
    assert tx0.info["solid"] == 0 and tx0.mesh.volume > 3920.0 + 1.0 and len(tx0.bodies) == 3


def test_api_faces_of_two_solids_are_refused(overlapping):
    from build123d import Axis

    import texcad

    faces = [overlapping.solids()[0].faces().sort_by(Axis.Z)[0], overlapping.solids()[1].faces().sort_by(Axis.Z)[-1]]
    with pytest.raises(ParameterError, match="solids 0, 1 of the assembly; texture one solid at a time"):
        texcad.texture(overlapping, faces, "builtin:ridges", pitch=1.0, height=0.5)
