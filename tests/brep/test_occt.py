"""texcad.brep.occt: the one adapter from build123d, CadQuery and OCP objects to OCCT
shapes, used by every stage (meshing, B-rep, faces, profiles)."""

from __future__ import annotations

import cadquery as cq
import numpy as np
import pytest
from build123d import Box, BuildPart, Pos

from texcad import ParameterError
from texcad.brep import faces_of, shape_to_mesh, solids_of, to_topods


def test_every_wrapper_gives_the_same_shape():
    b = Box(10, 10, 10)
    with BuildPart() as bp:
        Box(10, 10, 10)
    wp = cq.Workplane().box(10, 10, 10)
    for obj in (b, b.wrapped, bp, wp, wp.val(), [b]):
        topo = to_topods(obj)
        assert len(solids_of(topo)) == 1 and len(faces_of(topo)) == 6
        assert shape_to_mesh(obj).volume == pytest.approx(1000.0, rel=1e-6)


def test_a_workplane_with_several_objects_is_all_of_them():
    wp = cq.Workplane().newObject([cq.Solid.makeBox(10, 10, 10), cq.Solid.makeBox(10, 10, 10, pnt=cq.Vector(30, 0, 0))])
    assert len(wp.vals()) == 2
    assert len(solids_of(wp)) == 2 and len(faces_of(wp)) == 12
    assert shape_to_mesh(wp).volume == pytest.approx(2000.0, rel=1e-6)
    both = [Box(10, 10, 10), Pos(30, 0, 0) * Box(10, 10, 10)]
    assert len(solids_of(both)) == 2


def test_bad_objects_are_refused_by_name():
    for bad, name in ((42, "int"), ("box", "str"), (np.zeros(3), "ndarray")):
        with pytest.raises(ParameterError, match=f"cannot use a {name} as a CAD shape"):
            to_topods(bad)
    with pytest.raises(ParameterError, match="empty list"):
        to_topods([])
    with pytest.raises(ParameterError, match="holds no shape"):
        to_topods(cq.Workplane())
