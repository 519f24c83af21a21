"""Mesh repair on meshes as other tools write them (session 10, real files)."""

import numpy as np
import trimesh

from texcad.solid.repair import drop_specks, repair_closed


def _soup(*meshes):
    m = trimesh.util.concatenate(list(meshes))
    return np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)


def test_a_cavity_is_no_body():
    """PrusaSlicer's extruder_idler.obj holds two small shells inside the part, wound
    outward: the repair makes them cavities, so the part is one body (the gate counts
    outer shells), not three (texturing it failed the gate: '1 bodies where the part
    has 3')."""
    outer, hole = trimesh.creation.box((20, 20, 20)), trimesh.creation.box((4, 4, 4))
    for inner in (hole, hole.copy()):  # written outward, and written as a cavity
        if inner is not hole:
            inner.invert()
        v, f, bodies = repair_closed(*_soup(outer, inner))
        assert bodies == 1
        assert trimesh.Trimesh(v, f, process=False).volume == 8000 - 64
        assert drop_specks(v, f)[2] == 1
    island = trimesh.creation.box((1, 1, 1))  # a free body inside the cavity is a body
    assert repair_closed(*_soup(outer, hole, island))[2] == 2

