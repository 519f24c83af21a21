"""Build directions (texcad.printability.overhang.build_directions): vectors and axis
words alike, in the API as on the command line."""

import numpy as np
import pytest

import texcad
from texcad.errors import ParameterError
from texcad.printability import build_directions


def test_axis_words_and_vectors():
    assert np.array_equal(build_directions("+z"), [[0.0, 0.0, 1.0]])
    assert np.array_equal(build_directions(["-y", "x"]), [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0]])
    assert np.allclose(build_directions((0, -1, 1)), [[0.0, -np.sqrt(0.5), np.sqrt(0.5)]])
    for bad in ("up", ["z", "q"], ("a", 1, 2), (0, 0, 0)):
        with pytest.raises(ParameterError, match="build direction"):
            build_directions(bad)


def test_texture_takes_an_axis_word_for_build_dir():
    """``build_dir="+z"`` (as the CLI's ``--build-dir +z``) was a raw ValueError."""
    from build123d import Axis, Box

    box = Box(20, 20, 6)
    side = box.faces().sort_by(Axis.Y)[0]
    word = texcad.texture(box, side, "builtin:diamond_knurl", height=0.4, pitch=0.5, build_dir="+z")
    vector = texcad.texture(box, side, "builtin:diamond_knurl", height=0.4, pitch=0.5, build_dir=(0, 0, 1))
    assert word.volume == vector.volume and np.array_equal(word.mesh.vertices, vector.mesh.vertices)
