"""Engraved and centred textures on a patch whose faces meet at a crease (issue 28): a
box with only its top edges filleted, textured on the top and two or four of the
fillets, which meet along mitre creases at the corners. The grid's normals are
smoothed over a crease (and along the fillets' long facet strips), so a cutter's top
a constant ``CUT_ABOVE`` mm out along them dipped under the ridge and cut it off as
loose bodies; now it rises there until it clears the faces
(:func:`texcad.targets.patches._cut_above`)."""

import warnings

import numpy as np
import pytest

import texcad
from texcad.brep import check_shape, occt_volume
from texcad.errors import TexcadWarning
from texcad.targets import patches


def _box_patch(n: int):
    from build123d import Box, GeomType, fillet

    box = fillet(Box(24, 18, 8).edges().group_by()[-1], 2)
    top = box.faces().sort_by()[-1]
    cyl = box.faces().filter_by(GeomType.CYLINDER)
    return box, [top, *cyl[:n]]


def _texture(box, faces, mode):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        return texcad.texture(box, faces, "builtin:stones", height=0.4, pitch=0.5, mode=mode)


@pytest.mark.parametrize("n, mode", [(2, "engraved"), (4, "engraved"), (2, "centred"), (4, "centred")])
def test_texture_across_mitre_creases_is_one_solid(n, mode):
    box, faces = _box_patch(n)
    tx = _texture(box, faces, mode)  # the gate passed (else GeometryError)
    g = tx.gate
    assert g.shells.bodies == 1 and g.shells.closed
    assert abs(g.volume_change - g.expected_volume) <= g.volume_slack  # the gate's volume check, restated
    # the texture is there: the engraving removed material, the centred relief made the surface rough
    if mode == "engraved":
        assert g.volume_change < -0.04 * 0.4 * box.faces().sort_by()[-1].area
    assert tx.mesh.area > 1.003 * tx.base_mesh.area and tx.mesh.num_triangles > 10 * tx.base_mesh.num_triangles
    shape = tx.shape
    chk = check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert occt_volume(shape, 1e-4) == pytest.approx(tx.mesh.volume, rel=1e-3)


def test_constant_cutter_top_cuts_the_ridge_off(monkeypatch):
    """Before the fix (the cutter's top a constant CUT_ABOVE out) the same call
    fails: the test above can fail."""
    monkeypatch.setattr(patches, "_cut_above", lambda grid, faces: np.full(grid.points.shape[:2], patches.CUT_ABOVE))
    box, faces = _box_patch(2)
    with pytest.raises(texcad.errors.GeometryError, match="bodies"):
        _texture(box, faces, "engraved")
