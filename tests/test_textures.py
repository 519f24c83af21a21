import numpy as np
import pytest

import texcad
from texcad.textures import BUILTINS


def test_at_least_three_builtins_default_first():
    names = texcad.builtin_names()
    assert len(names) >= 3
    assert names[0] == texcad.DEFAULT_TEXTURE


@pytest.mark.parametrize("name", list(BUILTINS))
def test_builtin_tiles_seamlessly(name):
    tx, ty = BUILTINS[name].tile
    two = texcad.builtin(name, size=(2 * tx, 2 * ty), pitch=0.1, height=1.0).heights
    rows, cols = two.shape
    # Exactly periodic: the second tile repeats the first, in x and in y.
    assert np.abs(two[:, : cols // 2] - two[:, cols // 2 :]).max() < 1e-5
    assert np.abs(two[: rows // 2] - two[rows // 2 :]).max() < 1e-5
    one = texcad.builtin(name, size=(tx, ty), pitch=0.1, height=1.0).heights
    # The wrap seam (last column -> first) is no bigger than steps inside.
    seam = np.abs(one[:, -1] - one[:, 0]).max()
    assert seam <= np.abs(np.diff(one, axis=1)).max() + 1e-6
    assert np.isclose(one.min(), 0.0) and np.isclose(one.max(), 1.0)


def test_builtin_prefix_and_errors():
    a = texcad.load_texture("builtin:pins", size=(6, 6), pitch=0.25, height=2.0)
    assert a.shape == (24, 24) and np.isclose(a.max_height, 2.0)
    with pytest.raises(texcad.ParameterError, match="unknown built-in texture 'nope'.*stones"):
        texcad.builtin("nope")
    with pytest.raises(texcad.ParameterError):
        texcad.builtin("pins", pitch=-1)


def test_deterministic():
    a = texcad.builtin("stones", size=30, pitch=0.2).heights
    b = texcad.builtin("stones", size=30, pitch=0.2).heights
    assert a.tobytes() == b.tobytes()
