"""CAD parts as other tools write them (session 11, third round of real files)."""

import pytest
from build123d import Compound, Face, Rectangle

import texcad
from texcad.errors import ParameterError


def test_a_surface_model_is_refused_saying_what_it_holds():
    """OCCT's trj7_c2-ug-214.stp is a SHELL_BASED_SURFACE_MODEL: one planar face in an
    open shell. texcad texture said only 'the Compound holds no solid to texture';
    it now says what the part holds and what to do."""
    sheet = Compound([Face(Rectangle(25.4, 25.4).wire())])
    with pytest.raises(ParameterError, match=r"1 face\(s\) but no closed body: a surface.*close or thicken"):
        texcad.texture(sheet, sheet.faces()[0], "builtin:dots")
