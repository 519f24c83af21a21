"""grid_ids: the weld numbering of np.unique(axis=0), vectorized as one or two int64
sort keys (session 12: np.unique's row sort took 15 s of a 2.4 M-triangle STEP check)."""

import numpy as np
import pytest

from texcad.solid.weld import grid_ids


@pytest.mark.parametrize("size, quantum", [(100.0, 1e-3), (640.0, 2e-5), (1e6, 1e-9)])  # one key, two keys, numpy's
def test_grid_ids_are_numpys_unique_inverse(size, quantum):
    rng = np.random.default_rng(7)
    pts = rng.uniform(-size / 2, size / 2, (5000, 3))
    pts[:, 2] *= 0.01  # a plate: thin along z
    corners = np.concatenate([pts, pts[rng.integers(0, 5000, 20000)] + rng.normal(0, quantum * 0.2, (20000, 3))])
    want = np.unique(np.round(corners / quantum).astype(np.int64), axis=0, return_inverse=True)[1].reshape(-1)
    got = grid_ids(corners, quantum)
    assert got.dtype == np.int64 and np.array_equal(got, want)
    assert got.max() + 1 == len(np.unique(want))


def test_grid_ids_of_nothing():
    assert grid_ids(np.zeros((0, 3)), 1e-3).shape == (0,)
