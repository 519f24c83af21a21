"""The textured B-rep handed out as a flat compound of solids (issue 28): build123d's
``Part(...).volume`` sees every solid, on a plane and on a full cylinder."""

import pytest

import texcad
from texcad.brep import check_shape, occt_volume
from texcad.brep.solids import flat_solids


def _solid_count(shape) -> int:
    from OCP.TopoDS import TopoDS_Iterator

    it, kinds = TopoDS_Iterator(shape), []
    while it.More():  # one per child
        kinds.append(it.Value().ShapeType().name)
        it.Next()
    assert set(kinds) == {"TopAbs_SOLID"}  # flat: solids only, directly in the compound
    return len(kinds)


def test_flat_solids_of_a_bare_solid_and_nested_compounds():
    from build123d import Box, Part, Pos

    from texcad.brep import compound

    solid = Box(1, 2, 3).solids()[0].wrapped
    assert Part(solid).volume == 0  # build123d: a bare solid has no compound children
    flat = flat_solids(solid)
    assert _solid_count(flat) == 1 and Part(flat).volume == pytest.approx(6.0)
    other = (Pos(5, 0, 0) * Box(1, 1, 1)).solids()[0].wrapped
    nested = compound([compound([solid]), compound([compound([other])])])
    flat = flat_solids(nested)
    assert _solid_count(flat) == 2 and Part(flat).volume == pytest.approx(7.0)


def _check(tx):
    flat = flat_solids(tx.shape)
    assert _solid_count(flat) == 1 and check_shape(flat)["valid"]
    slack = tx.info.get("volume_slack", 0.0)
    assert abs(occt_volume(flat) - tx.volume) <= 1e-3 * tx.volume + slack  # adaptive Gauss, eps 1e-4
    from build123d import Part

    # build123d's .volume is OCCT's plain (non-adaptive) Gauss integration: one Gauss
    # rule over a whole tile of 24 x 24 bilinear cells, 0.1-0.3 % off; not 0.
    assert Part(flat).volume == pytest.approx(tx.volume, rel=5e-3)


def test_plane_part_volume():
    from build123d import Axis, Box

    box = Box(20, 20, 4)
    _check(texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.0, pitch=0.5))


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_cylinder_part_volume():
    from build123d import Cylinder, GeomType

    cyl = Cylinder(8, 12)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    _check(texcad.texture(cyl, side, "builtin:stones", height=0.6, pitch=0.5))
