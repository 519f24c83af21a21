"""Slicer paint as slicers write it (session 10, real files: BambuStudio's
painted_seams.3mf from AdelinoGP/pinch_n_print_cli, a seam painted 12 levels deep, 553 k
leaves: split_painted took 161 s, 145 s of it looking structured keys up)."""

import numpy as np
import trimesh

from texcad.io.paint import _keys, _point_keys, decode, paint_by_points, split_painted
from texcad.solid import edge_report


def _area(v, f):
    t = v[f]
    return np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1) / 2


def test_a_seam_painted_deep_splits_closed_with_its_area():
    """A thin line painted 9 levels deep beside whole faces (big leaves next to tiny
    ones: each big leaf's edges hold many lattice points to look up)."""
    m = trimesh.creation.icosphere(1, radius=10)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    strings = paint_by_points(v[f], lambda p: (np.abs(p[:, 2] - 1.0) < 0.3).astype(int) + 1, 9)
    V, F, S, P = split_painted(v, f, strings)
    rep = edge_report(F)
    assert rep["boundary"] == 0 and rep["nonmanifold"] == 0 and rep["misoriented"] == 0
    assert np.isclose(_area(V, F).sum(), _area(v, f).sum(), rtol=1e-12)
    p = decode(strings)
    la = _area(p.points(v[f]).reshape(-1, 3), np.arange(3 * len(p.state)).reshape(-1, 3))
    for st in (1, 2):
        assert np.isclose(_area(V, F)[S == st].sum(), la[p.state == st].sum())
    assert p.depth.max() == 9


def test_packed_keys_order_as_the_structured_ones(rng):
    """The lookups use one int64 per point ((t, a, b) ranked, then c): the same order
    and the same matches as the structured keys (t, a, b, c) they replace."""
    from texcad.io.paint import _Points

    rows = np.stack([rng.integers(0, 3, 5000), rng.integers(0, 1 << 30, 5000) % 50,
                     rng.integers(0, 1 << 30, 5000) % 40, rng.integers(0, 1 << 24, 5000) % 30], axis=1)
    pts = _Points(rows)
    ref, first = np.unique(_keys(rows), return_index=True)
    assert np.array_equal(pts.first, first)
    assert np.array_equal(pts.find(rows), np.searchsorted(ref, _keys(rows)))
    other = rows + [[0, 0, 0, 31]]  # c out of the table's range: none found
    assert np.all(pts.find(other) < 0)
    assert _point_keys is not None
