import numpy as np
import pytest

import texcad


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


@pytest.fixture
def small_hm():
    """A 40 x 60 px stones texture, 0.5 mm pitch, 1.5 mm high."""
    return texcad.builtin("stones", size=(30, 20), pitch=0.5, height=1.5)
