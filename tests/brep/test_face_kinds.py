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


def _drilled(part, face, tool, tmp_path):
    """Texture ``face`` (stones 0.4 mm at 0.5 mm), write its STEP and read it back (one
    valid solid within 0.1 % of the mesh), then drill ``tool`` through the texture."""
    from texcad.brep import shape_to_mesh

    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5)
    slack = tx.info.get("volume_slack", 0.0)
    tx.export(tmp_path / "part.step")
    back = texcad.io.read_step(tmp_path / "part.step")
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert abs(occt_volume(back) - tx.volume) <= 1e-3 * tx.volume + slack
    assert shape_to_mesh(back, tolerance=0.1, angular_tolerance=0.5).is_watertight  # OCCT meshes it closed
    return tx, tx - tool


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", ["cone", "sphere"])
def test_hole_through_curved_face(kind, tmp_path):
    """A 3 mm hole through a textured cone / sphere: a valid B-rep (one solid) within
    0.1 % of the same cut on the mesh, which removed material."""
    from build123d import Cone, Cylinder, GeomType, Rot, Sphere

    part = Cone(10, 6, 12) if kind == "cone" else Sphere(10)
    face = part.faces().filter_by(GeomType.CONE)[0] if kind == "cone" else part.faces()[0]
    tx, cut = _drilled(part, face, Rot(0, 90, 0) * Cylinder(1.5, 30), tmp_path)
    assert cut.volume < tx.volume - 50  # two 3 mm holes through the wall
    shape = cut.shape  # checked by ops: valid, one solid, volume against the mesh
    chk = check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1
    assert abs(occt_volume(shape) - cut.volume) <= 1e-3 * cut.volume + cut.info.get("volume_slack", 0.0)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_hole_through_torus_says_which_face(tmp_path):
    """Where OCCT's cut of a textured torus misses the hole, ``.shape`` raises a
    GeometryError naming the face kind and STL/3MF; the mesh result is there."""
    from build123d import Cylinder, Pos, Torus

    part = Torus(12, 4)
    tx, cut = _drilled(part, part.faces()[0], Pos(12, 0, 0) * Cylinder(1.5, 30), tmp_path)
    assert cut.volume < tx.volume - 30
    try:
        shape = cut.shape
    except texcad.TexcadError as exc:
        assert "torus face" in str(exc) and "STL or 3MF" in str(exc)
    else:  # if OCCT gets it right, it must be right
        chk = check_shape(shape)
        assert chk["valid"] and chk["solids"] == 1
        assert abs(occt_volume(shape) - cut.volume) <= 1e-3 * cut.volume + cut.info.get("volume_slack", 0.0)


def test_chained_result_has_a_brep():
    """Texturing a face of an earlier result (chained): the mesh holds both textures,
    and so does the B-rep (the second texture put on the first result's B-rep): one
    valid solid within 0.1 % of the mesh."""
    from build123d import Axis, Box

    box = Box(20, 20, 6)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=0.6, pitch=0.5)
    side = tx.part.faces().sort_by(Axis.X)[-1]
    chained = texcad.texture(tx, side, "builtin:diamond_knurl", height=0.4, pitch=0.5)
    assert chained.volume > tx.volume  # the second texture is on the mesh
    _check(chained)
    assert check_shape(chained.shape)["faces"] > check_shape(tx.shape)["faces"]  # and on the B-rep
