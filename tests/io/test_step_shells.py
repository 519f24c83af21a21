"""texcad.io.read_step on STEP files that mesh converters write (issue 28: files other
tools wrote): a face per triangle that shares no edge with its neighbours, no solid,
and angle units written with parameters OCCT's parser faults. The faces are sewn, the
closed shell made an outward solid and its coplanar faces merged, so that ``top`` is
the whole top; a length unit at fault is still refused. Lengths in mm."""

from __future__ import annotations

import re

import pytest
import trimesh

pytest.importorskip("OCP")


def _soup_step(path, mesh: trimesh.Trimesh) -> None:
    """A STEP (OCCT's writer) of ``mesh`` as one planar face per triangle, none sharing
    an edge, in no shell or solid: how STL-to-STEP converters write a mesh."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.gp import gp_Pnt
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopoDS import TopoDS_Compound

    out, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(out)
    for tri in mesh.faces:  # per triangle: 12 for a box
        poly = BRepBuilderAPI_MakePolygon(*[gp_Pnt(*map(float, mesh.vertices[i])) for i in tri], True)
        builder.Add(out, BRepBuilderAPI_MakeFace(poly.Wire(), True).Face())
    writer = STEPControl_Writer()
    writer.Transfer(out, STEPControl_AsIs)
    writer.Write(str(path))


def _converter_units(path) -> None:
    """Rewrite the angle units as an online STL-to-STEP converter does
    (``(NAMED_UNIT(#N)SOLID_ANGLE_UNIT()SI_UNIT($,.STERADIAN.))``), which OCCT's
    parser reports as faults ("Count of Parameters is not 2 for si_unit")."""
    text = path.read_text()
    text = re.sub(r"\( NAMED_UNIT\(\*\) PLANE_ANGLE_UNIT\(\) SI_UNIT\(\$,\.RADIAN\.\) \)",
                  "(NAMED_UNIT(#999999)PLANE_ANGLE_UNIT()SI_UNIT($,.RADIAN.))", text)
    text = re.sub(r"\( NAMED_UNIT\(\*\) SI_UNIT\(\$,\.STERADIAN\.\) SOLID_ANGLE_UNIT\(\) \)",
                  "(NAMED_UNIT(#999999)SOLID_ANGLE_UNIT()SI_UNIT($,.STERADIAN.))", text)
    text = text.replace("ENDSEC;\nEND-ISO", "#999999=DIMENSIONAL_EXPONENTS(0.,0.,0.,0.,0.,0.,0.);\nENDSEC;\nEND-ISO")
    path.write_text(text)


def test_a_triangle_soup_step_reads_as_one_solid_with_whole_faces(tmp_path):
    from build123d import Compound

    from texcad.brep import check_shape, occt_volume
    from texcad.io import read_step

    p = tmp_path / "soup.step"
    _soup_step(p, trimesh.creation.box((20.0, 10.0, 5.0)))
    part = Compound(read_step(p))
    assert len(part.solids()) == 1 and len(part.faces()) == 6  # 12 triangles sewn, coplanar pairs merged
    chk = check_shape(part.wrapped)
    assert chk["valid"] and chk["solids"] == 1
    assert occt_volume(part.wrapped) == pytest.approx(1000.0, rel=1e-9)  # outward: a positive volume
    assert max(f.area for f in part.faces()) == pytest.approx(200.0, rel=1e-9)


def test_converter_angle_units_are_read_and_the_part_textured(tmp_path):
    import warnings

    import texcad
    from build123d import Axis, Compound

    from texcad.io import read_step

    p = tmp_path / "converted.step"
    _soup_step(p, trimesh.creation.box((20.0, 10.0, 5.0)))
    _converter_units(p)
    assert "SOLID_ANGLE_UNIT()SI_UNIT($,.STERADIAN.)" in p.read_text()
    part = Compound(read_step(p))
    top = part.faces().sort_by(Axis.Z)[-1]
    assert top.area == pytest.approx(200.0, rel=1e-9)  # the whole top, one face
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        tx = texcad.texture(part, top, "builtin:ridges", height=0.5, pitch=0.5)
    assert tx.mesh.is_watertight and tx.gate.shells.bodies == 1 and tx.mesh.volume > 1000.0 + 10.0  # the ridges on the whole 200 mm2 top


def test_a_length_unit_at_fault_is_still_refused(tmp_path):
    from texcad.errors import InputError
    from texcad.io import read_step

    p = tmp_path / "bad_length.step"
    _soup_step(p, trimesh.creation.box((20.0, 10.0, 5.0)))
    text = p.read_text()
    text, n = re.subn(r"\( LENGTH_UNIT\(\) NAMED_UNIT\(\*\) SI_UNIT\(\.MILLI\.,\.METRE\.\) \)",
                      "( LENGTH_UNIT() NAMED_UNIT(#999999) SI_UNIT(.MILLI.,.METRE.,3.) )", text)
    assert n > 0
    p.write_text(text.replace("ENDSEC;\nEND-ISO", "#999999=DIMENSIONAL_EXPONENTS(1.,0.,0.,0.,0.,0.,0.);\nENDSEC;\nEND-ISO"))
    with pytest.raises(InputError, match=r"cannot be read"):
        read_step(p)
