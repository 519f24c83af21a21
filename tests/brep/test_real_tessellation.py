"""Meshes of CAD parts for viewing and for an assembly's other solids, on parts
OCCT's mesher leaves open (session 9, real files: a Fusion 360 knob whose chamfer cone
under 24 flutes meshed with holes, so `texcad render knob.step` showed it gapped)."""

import pytest
from build123d import Box, Compound, Pos

import texcad
from texcad.brep import shape_mesh


def _box_with_an_open_face(at=(0, 0, 0)):
    """A 10 mm box whose top face carries a one-triangle triangulation marked finer
    than any chord asked for (as tests/brep/test_tessellation.py): it meshes open."""
    from OCP.BRep import BRep_Builder
    from OCP.gp import gp_Pnt
    from OCP.Poly import Poly_Triangle, Poly_Triangulation

    box = Pos(*at) * Box(10, 10, 10)
    top = box.faces().sort_by()[-1]
    tri = Poly_Triangulation(3, 1, False)
    for i, (x, y) in enumerate(((-5, -5), (5, -5), (5, 5))):
        tri.SetNode(i + 1, gp_Pnt(x + at[0], y + at[1], 5 + at[2]))
    tri.SetTriangle(1, Poly_Triangle(1, 2, 3))
    tri.Deflection(1e-9)
    BRep_Builder().UpdateFace(top.wrapped, tri)
    return box


def test_a_part_meshed_for_viewing_is_healed_where_occt_leaves_it_open():
    m = shape_mesh(_box_with_an_open_face())
    assert m.is_watertight and m.volume == pytest.approx(1000.0, rel=1e-6)


def test_an_assemblys_other_solid_is_written_closed(tmp_path):
    """The solids kept as they were go into the STL and 3MF: closed, not with OCCT's holes."""
    other = _box_with_an_open_face(at=(30, 0, 0))
    part = Compound([Box(10, 10, 10), other])
    top = part.solids()[0].faces().sort_by()[-1]
    tx = texcad.texture(part, top, "builtin:dots", pitch=0.5, height=0.3)
    (m,) = tx.other_meshes
    assert m.is_watertight and m.volume == pytest.approx(1000.0, rel=1e-6)
    tx.export(tmp_path / "two.3mf")
