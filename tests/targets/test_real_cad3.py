"""CAD parts as other tools write them (session 11, third round of real files)."""

import pytest
from build123d import Axis, Box, Compound, Face, Pos, Rectangle

import texcad
from texcad.errors import ParameterError, TexcadWarning


def test_a_surface_model_is_refused_saying_what_it_holds():
    """OCCT's trj7_c2-ug-214.stp is a SHELL_BASED_SURFACE_MODEL: one planar face in an
    open shell. texcad texture said only 'the Compound holds no solid to texture';
    it now says what the part holds and what to do."""
    sheet = Compound([Face(Rectangle(25.4, 25.4).wire())])
    with pytest.raises(ParameterError, match=r"1 face\(s\) but no closed body: a surface.*close or thicken"):
        texcad.texture(sheet, sheet.faces()[0], "builtin:dots")


def test_a_surface_beside_the_solid_is_left_out():
    """OCCT's trj6_c1-ug-214.stp holds a cube (MANIFOLD_SOLID_BREP) and, beside it, a
    face in an open shell (SHELL_BASED_SURFACE_MODEL). Texturing the cube's top was
    refused: 'OCCT's tessellation of the part is not a closed solid even after
    healing ... on faces 6; sew them in the CAD program'. The loose face encloses no
    volume: it is left out, with a warning, and the cube is textured."""
    box = Box(20, 20, 10)
    sheet = Pos(0, 0, 30) * Face(Rectangle(20, 20).wire())
    part = Compound([box, sheet])
    top = part.faces().sort_by(Axis.Z)[-2]  # the cube's top (the sheet is higher)
    with pytest.warns(TexcadWarning, match=r"1 face\(s\) of the part belong to no solid"):
        tx = texcad.texture(part, top, "builtin:dots", height=0.5, pitch=0.5)
    assert len(tx.part.solids()) == 1 and tx.part.is_valid
    assert 4000.0 < tx.part.volume < 4000.0 + 20 * 20 * 0.5
    assert tx.part.bounding_box().max.Z < 11.0  # the sheet at z = 30 is not in the result


def test_the_surface_beside_the_solid_is_not_textured():
    """Picking trj6_c1-ug-214.stp's loose face (face 6, solid -1 in texcad faces) said
    'a face is not a face of this part'; it now says the face belongs to no solid."""
    sheet = Pos(0, 0, 30) * Face(Rectangle(20, 20).wire())
    part = Compound([Box(20, 20, 10), sheet])
    with pytest.warns(TexcadWarning), pytest.raises(ParameterError, match="belongs to no solid"):
        texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], "builtin:dots", height=0.5, pitch=0.5)
