"""Faces by name (texcad.brep.selectors): one vocabulary for ``--face``, batch jobs'
``where`` and ``texcad.texture(part, "top", ...)``."""

from __future__ import annotations

import pytest

from texcad.brep.selectors import check_selector, faces_named
from texcad.errors import ParameterError

build123d = pytest.importorskip("build123d")


@pytest.fixture(scope="module")
def drilled():
    """A 30 x 20 x 8 mm block with a 6 mm bore through it (mm)."""
    from build123d import Box, Cylinder

    return Box(30, 20, 8) - Cylinder(3, 8)


def test_each_form_names_the_faces_build123d_selects(drilled):
    from build123d import Axis, GeomType

    faces = drilled.faces()
    assert faces_named(drilled, "top")[0].is_same(faces.sort_by(Axis.Z)[-1])
    assert faces_named(drilled, "cylinder")[0].is_same(faces.filter_by(GeomType.CYLINDER)[0])
    assert faces_named(drilled, "3")[0].is_same(faces[3])
    sides = faces_named(drilled, "right+left+right")  # each once, in order
    assert len(sides) == 2 and sides[0].center().X > 14 and sides[1].center().X < -14
    assert len(faces_named(drilled, "normal:0,0,1")) == 1
    assert len(faces_named(drilled, "plane:all")) == 6


@pytest.mark.parametrize("which, words", [("cone", "no cone face"), ("99", "only 7 faces"), ("upside", "use one of top"),
                                          ("plane:9", "plane:0..5"), ("normal:1,1,0", "no face looks that way"),
                                          ("solid:3/top", "has 1 solid")])
def test_a_selector_that_names_no_face_says_why(drilled, which, words):
    with pytest.raises(ParameterError, match=words):
        faces_named(drilled, which)


def test_forms_are_checked_before_a_part_is_read():
    for ok in ("top", "7", "cylinder:all", "bspline:2", "normal:0,0,1", "solid:1/top+cone"):
        check_selector(ok)
    for bad in ("upside", "cylinder:first", "top+sideways"):
        with pytest.raises(ParameterError, match="face selector"):
            check_selector(bad)


def test_texture_takes_names_as_the_command_line_does(drilled):
    """``texcad.texture(part, "top")`` gives the same triangles as the face itself;
    zones' faces may be names too."""
    import numpy as np

    import texcad
    from build123d import Axis

    opts = dict(pitch=1.0, height=0.4)
    by_name = texcad.texture(drilled, "top", "builtin:stones", **opts)
    by_face = texcad.texture(drilled, drilled.faces().sort_by(Axis.Z)[-1], "builtin:stones", **opts)
    assert np.array_equal(by_name.mesh.vertices, by_face.mesh.vertices)
    assert np.array_equal(by_name.mesh.faces, by_face.mesh.faces)
    zoned = texcad.texture(drilled, [("top", "builtin:stones", {"height": 0.4}),
                                     ("front+back", "builtin:ridges", {"height": 0.3})], pitch=0.5)
    assert zoned.gate.shells.closed and zoned.mesh.volume > drilled.volume
    with pytest.raises(ParameterError, match="no cone face"):
        texcad.texture(drilled, "cone", "builtin:stones", **opts)
