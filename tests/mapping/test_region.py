"""Mesh regions (texcad.mapping.region): the direction words, as on a CAD part."""

import numpy as np
import pytest
import trimesh

import texcad
from texcad.errors import ParameterError
from texcad.mapping.region import FLAT_ANGLE, Region, flat_patch


def _stepped():
    """Two flat tops facing +z: a 30 x 20 mm block 10 mm high with a 10 x 20 mm step
    5 mm higher (the larger top is 20 x 20 mm), as one welded closed mesh."""
    low = trimesh.creation.box((30, 20, 10), trimesh.transformations.translation_matrix((15, 10, 5)))
    high = trimesh.creation.box((10, 20, 15), trimesh.transformations.translation_matrix((35, 10, 7.5)))
    m = trimesh.boolean.union([low, high], engine="manifold")
    m.merge_vertices()
    return m


def test_flat_patch_is_the_largest_connected_one():
    """``top`` on a stepped block is the larger of its two flat tops (400 against
    200 mm2), not both; ``bottom`` the whole underside."""
    m = _stepped()
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    top = flat_patch(v, f, np.array([0.0, 0, 1]))
    assert m.area_faces[top].sum() == pytest.approx(30 * 20)
    assert np.allclose(m.triangles_center[top][:, 2], 10)
    assert m.area_faces[flat_patch(v, f, np.array([0.0, 0, -1]))].sum() == pytest.approx(40 * 20)


def test_flat_patch_leaves_out_tilted_faces():
    """A face tilted by more than FLAT_ANGLE from the direction is not in the patch; one
    tilted by less is."""
    for tilt, inside in ((FLAT_ANGLE * 0.9, True), (FLAT_ANGLE * 1.1, False)):
        m = trimesh.creation.box((10, 10, 10))
        m.apply_transform(trimesh.transformations.rotation_matrix(np.radians(tilt), (1, 0, 0)))
        got = flat_patch(np.asarray(m.vertices), np.asarray(m.faces), np.array([0.0, 0, 1]))
        assert got.any() == inside


def test_direction_words_parse_and_texture_a_mesh():
    """``"top"`` is a face region; on a box mesh it textures the top alone (the texture's
    volume is the top's, as for a CAD part's top face); ``"bottom"`` includes the bed
    face it names."""
    assert Region.parse("top").kind == "face" and Region.parse("bottom").bottom
    box = trimesh.creation.box((20, 20, 5))
    tx = texcad.texture(box, "top", "builtin:stones", height=0.4, pitch=0.5)
    assert tx.mesh.is_watertight
    top_z = tx.mesh.vertices[:, 2] > 2.5 + 1e-6
    assert top_z.any()
    moved = np.abs(tx.mesh.vertices[:, :2]).max(axis=1) < 10 - 1e-6
    assert not np.any(top_z & ~moved)  # nothing raised at the sides
    with pytest.raises(ParameterError, match="top, bottom"):
        Region.parse("upper")


def test_region_table_of_a_box():
    """Each listed spec picks what texturing with it would: the default leaves the
    bed face out, a direction word its flat patch, nothing faces down but the bed."""
    import trimesh

    from texcad.mapping.region import LISTED_REGIONS, region_table
    from texcad.solid import Mesh

    box = trimesh.creation.box((20, 10, 4))
    rows = {r["region"]: r for r in region_table(Mesh(box.vertices, box.faces))}
    assert list(rows) == list(LISTED_REGIONS)
    assert rows["not-bottom"]["area"] == pytest.approx(2 * (200 + 80 + 40) - 200)
    assert rows["top"]["area"] == pytest.approx(200) and rows["top"]["centre"] == pytest.approx((0, 0, 2))
    assert rows["normal:-z:45"]["faces"] == 0 and rows["normal:-z:45"]["centre"] is None
    assert rows["bottom"]["area"] == pytest.approx(200)  # the word names the bed face and takes it
