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
