"""Plate tiles: every node numbered exactly once whatever the tiling, shared seam
nodes computed identically by both tiles, triangles covering each cell once, the
walls closing the surface facing out."""

from __future__ import annotations

import numpy as np
import pytest

from texcad.solid.tiles import Numbering, PlateGrid, block_volume, walls


@pytest.mark.parametrize("shape,tile", [((5, 7), 2), ((5, 7), 3), ((10, 4), 4), ((9, 9), 11), ((1, 1), 2)])
def test_numbering_and_seams(shape, tile):
    px = 0.5
    grid = PlateGrid((shape[1] * px + 0.3, shape[0] * px + 0.1), shape, (px, px), tile)
    nr, nc = grid.nodes
    num = Numbering(grid)
    where = {}  # global number -> (x, y) of every tile that holds it
    cells = np.zeros((nr - 1, nc - 1), dtype=int)
    tris = []
    for t in grid.tiles():
        ids = num.ids(t)
        rows, cols, _, _ = grid.texture_block(t)
        h = np.random.default_rng(t.i0 * 1000 + t.j0).random((rows.stop - rows.start, cols.stop - cols.start)).astype(np.float32)
        v = grid.vertices(t, h)
        for g, p in zip(ids.ravel(), v[:, :2]):
            where.setdefault(int(g), set()).add(tuple(p.tolist()))
        cells[t.i0 : t.i1, t.j0 : t.j1] += 1
        tris.append(ids.ravel()[grid.faces(t)])
    assert num.next == nr * nc and sorted(where) == list(range(nr * nc))
    assert all(len(p) == 1 for p in where.values())  # a seam node: the same numbers from both tiles
    assert (cells == 1).all()  # tiles cover every cell once
    v, f, ids = walls(grid, num, 2.0)
    tris.append(ids[f])
    allt = np.concatenate(tris)
    edges = np.sort(np.concatenate([allt[:, [0, 1]], allt[:, [1, 2]], allt[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert (counts == 2).all()  # closed: every edge in two triangles
    directed = np.concatenate([allt[:, [0, 1]], allt[:, [1, 2]], allt[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)  # consistently oriented
    assert num.ring["left"].min() >= 0 and num.ring["top"].min() >= 0


def test_flat_plate_volume_and_refusals():
    grid = PlateGrid((10.0, 6.0), (4, 6), (1.0, 1.0), 3)
    num = Numbering(grid)
    vol = 0.0
    for t in grid.tiles():
        rows, cols, _, _ = grid.texture_block(t)
        v = grid.vertices(t, np.zeros((rows.stop - rows.start, cols.stop - cols.start), np.float32))
        num.ids(t)
        vol += block_volume(v, grid.faces(t))
    v, f, _ = walls(grid, num, 2.0)
    vol += block_volume(v, f)
    assert np.isclose(vol, 10 * 6 * 2)  # outward: positive
    with pytest.raises(Exception, match="larger than the plate"):
        PlateGrid((3.0, 6.0), (4, 6), (1.0, 1.0), 3)
    with pytest.raises(Exception, match="at least 2 nodes"):
        PlateGrid((10.0, 6.0), (4, 6), (1.0, 1.0), 1)


def test_top_volume_is_block_volume_of_the_tile_faces(rng):
    grid = PlateGrid((9.0, 7.0), (5, 6), (1.25, 1.1), 4)
    for t in grid.tiles():
        rows, cols, _, _ = grid.texture_block(t)
        v = grid.vertices(t, rng.random((rows.stop - rows.start, cols.stop - cols.start)).astype(np.float32))
        assert np.isclose(grid.top_volume(t, v), block_volume(v, grid.faces(t)), rtol=1e-12, atol=1e-12)
