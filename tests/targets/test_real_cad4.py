"""CAD parts as other tools write them (session 12, fourth round of real files)."""

import pytest
from build123d import Box, Compound

import texcad
from texcad.errors import ParameterError


def test_a_surface_named_by_a_selector_is_refused_as_a_surface():
    """An open box (five faces, no solid) with the selector "top" said 'face selector
    top: no planar face looks top'; now that the part holds no solid."""
    shell = Compound(list(Box(20, 20, 10).faces())[:5])
    with pytest.raises(ParameterError, match=r"holds no solid to texture \(5 face\(s\) but no closed body"):
        texcad.texture(shell, "top", "builtin:dots")
