"""The column-wise reductions give numpy's own results, byte for byte."""

from __future__ import annotations

import numpy as np
import pytest

from texcad.util import colmax, colmin, rowall, rowany, rowdot, rowmax, rowmin, rownorm, rowsum


@pytest.mark.parametrize("shape", [(1000, 3), (7, 2), (50, 4, 3), (0, 3)])
def test_same_bytes_as_numpy(shape):
    rng = np.random.default_rng(1)
    a = rng.normal(size=shape) * rng.uniform(0, 1e6, size=shape)
    b = rng.normal(size=shape)
    a.flat[::97] = -0.0
    assert rowsum(a).tobytes() == a.sum(axis=-1).tobytes()
    assert rowmax(a).tobytes() == a.max(axis=-1, initial=-np.inf).tobytes()
    assert rowmin(a).tobytes() == a.min(axis=-1, initial=np.inf).tobytes()
    m = a > 0
    assert np.array_equal(rowany(m), m.any(axis=-1)) and np.array_equal(rowall(m), m.all(axis=-1))
    if shape[-1] == 3:
        assert rowdot(a, b).tobytes() == (a * b).sum(axis=-1).tobytes()
        assert rownorm(a).tobytes() == np.linalg.norm(a, axis=-1).tobytes()
    if len(shape) == 2 and shape[0]:
        assert colmin(a).tobytes() == a.min(axis=0).tobytes() and colmax(a).tobytes() == a.max(axis=0).tobytes()


def test_nan_propagates_as_in_numpy():
    a = np.array([[1.0, np.nan, 0.0], [2.0, 3.0, 1.0]])
    assert np.array_equal(rowmax(a), a.max(axis=1), equal_nan=True)
    assert np.array_equal(rowmin(a), a.min(axis=1), equal_nan=True)


@pytest.mark.parametrize("top", [3, 10**6, 2**40, 2**62])
def test_argsort_ints_is_the_stable_argsort(top):
    from texcad.util import argsort_ints

    key = np.random.default_rng(top % 97).integers(0, top, 100_000)  # many ties for small tops
    assert np.array_equal(argsort_ints(key), np.argsort(key, kind="stable"))
    assert argsort_ints(np.zeros(0, np.int64)).shape == (0,)
