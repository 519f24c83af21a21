"""The result type (texcad.pipeline.result): its B-rep checked before it is given."""

import pytest

import texcad
from texcad.brep import to_topods
from texcad.errors import GeometryError
from texcad.pipeline.result import VOLUME_TOLERANCE, Textured


def _post():
    """A tall 10 x 10 x 400 mm post textured on its top: the texture's volume is under
    0.1 % of the part's."""
    from build123d import Box

    post = Box(10, 10, 400)
    tx = texcad.texture(post, "top", "builtin:stones", height=0.5, pitch=0.25)
    assert 0 < tx.stages.relief.volume < VOLUME_TOLERANCE * tx.volume
    return post, tx


def test_brep_holds_the_texture():
    """The B-rep's volume beyond the part is the texture's integral within the gate's
    accepted difference (the same figure the gate checks on the mesh)."""
    post, tx = _post()
    assert tx.shape is not None
    change = tx.info["brep_volume"] - post.volume
    assert abs(change - tx.stages.relief.volume) <= tx.stages.relief.volume_slack
    assert abs(change - tx.stages.relief.volume) < 0.05 * tx.stages.relief.volume


def test_brep_without_the_texture_is_refused(monkeypatch):
    """A B-rep that lost its texture (here: the plain part given as the B-rep) is within
    0.1 % of the whole part's mesh, but not within the texture's integral: refused,
    naming both figures, rather than handed to CAD."""
    post, tx = _post()
    monkeypatch.setattr(Textured, "brep", lambda self: to_topods(post))
    with pytest.raises(GeometryError, match=r"encloses \+0\.00 mm3 beyond the part but the texture's integral is \+\d"):
        tx.shape


def test_an_occt_failure_in_the_brep_is_a_geometry_error(monkeypatch):
    """OCCT's exceptions (OCP's Standard_* classes) raised while the B-rep is built
    reached the user as they were; they are a GeometryError naming the mesh outputs,
    as every other refusal."""
    from build123d import Axis, Box
    from OCP.Standard import Standard_ConstructionError

    box = Box(10, 10, 4)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=0.5, pitch=1.0)

    def fails(*args, **kwargs):
        raise Standard_ConstructionError("BSpline curve: Knots interval values too close")

    monkeypatch.setattr(tx.stages.adapter, "brep", fails)
    with pytest.raises(GeometryError, match="OCCT failed .*Knots interval values too close.*write STL or 3MF"):
        tx.shape
