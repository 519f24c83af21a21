"""CAD faces as real parts from other tools have them (session 9, real files): what a
user reads when a texture cannot be made, and which faces it names."""

import pytest

import texcad
from texcad.errors import ParameterError


def test_a_texture_flat_at_the_pitch_is_named_on_curved_and_several_faces():
    """knurl_fine (1 mm period) at a 0.5 mm pitch samples to 0 mm: a real enclosure's
    top plane with its two bends was refused as 'too small or narrow for the border
    band' (an 8900 mm2 face), one warning per face, on the generic faces path."""
    from build123d import Axis, Cylinder, GeomType, Sphere

    c = Cylinder(10, 20)
    top, side = c.faces().sort_by(Axis.Z)[-1], c.faces().filter_by(GeomType.CYLINDER)[0]
    s = Sphere(10)
    for part, where in ((c, [top, side]), (s, s.faces()[0])):  # several faces; one sphere face
        with pytest.raises(ParameterError, match="flat .* at a pitch of 0.5 mm.*use a smaller pitch"):
            texcad.texture(part, where, "builtin:knurl_fine", pitch=0.5)
