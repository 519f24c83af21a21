"""Small parsers (texcad.util.vectors)."""

import numpy as np
import pytest

from texcad.errors import ParameterError
from texcad.util import parse_vector


def test_vectors_and_axes():
    """Three numbers (commas or spaces) or an axis word give the vector; anything else,
    or all zeros, is refused naming both forms."""
    assert np.array_equal(parse_vector("0, -0.5 0.87"), [0.0, -0.5, 0.87])
    assert np.array_equal(parse_vector("+z"), [0.0, 0.0, 1.0])
    assert np.array_equal(parse_vector("-Y"), [0.0, -1.0, 0.0])
    assert np.array_equal(parse_vector("x"), [1.0, 0.0, 0.0])
    for bad in ("up", "+-z", "0,0,0", "1,2", "nan,0,1"):
        with pytest.raises(ParameterError, match="X,Y,Z"):
            parse_vector(bad)


def test_axis_words_are_one_vocabulary():
    """The command line's vectors and the projections' axes read axis words alike
    (texcad.util.axis_word): one sign at most, any case."""
    from texcad.mapping.projection import parse_axis
    from texcad.util import axis_word

    for word in ("+z", "-Y", "x", " -x "):
        assert np.array_equal(axis_word(word), parse_axis(word))
        assert np.array_equal(axis_word(word), parse_vector(word))
    for bad in ("++x", "+-z", "w", "x1"):
        assert axis_word(bad) is None
        with pytest.raises(ParameterError, match=r"\+x, -x"):
            parse_axis(bad)
