"""What the CAD adapters share (texcad.targets.cad): faces resolved on the part, and
on an earlier result when chained."""

import warnings

import pytest

import texcad
from texcad.brep import check_shape, occt_volume


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_chained_face_next_to_a_trimmed_face():
    """A face of the result's B-rep that the texture rebuilt (a drilled cylinder's
    side textured in tiles on its own (u, v) splits the top's rim where its tiles end)
    is still the base part's face: chaining onto it textures the top, and the
    B-rep holds both textures, one valid solid within 0.1 % of the mesh."""
    from build123d import Axis, Cylinder, GeomType, Rot, SortBy

    part = Cylinder(8, 12) - Rot(90, 0, 0) * Cylinder(1.5, 40)
    side = part.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tx = texcad.texture(part, side, "builtin:stones", height=0.4, pitch=0.5)
    top = tx.part.faces().sort_by(Axis.Z)[-1]
    assert not any(top.wrapped.IsSame(f.wrapped) for f in part.faces())  # rebuilt, not the base's face
    chained = texcad.texture(tx, top, "builtin:diamond_knurl", height=0.3, pitch=0.5)
    assert chained.volume > tx.volume + 5  # the knurl is on the top
    chk = check_shape(chained.shape)
    assert chk["valid"] and chk["solids"] == 1
    assert abs(occt_volume(chained.shape) - chained.volume) <= 1e-3 * chained.volume
    with pytest.raises(texcad.ParameterError, match="textured already"):
        texcad.texture(chained, chained.part.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=0.3, pitch=0.5)


def test_a_face_of_another_part_is_refused():
    """A face of another part, even one lying where the part's face lies, is refused
    with a message that says to select it from the part itself."""
    from build123d import Axis, Box

    a, b = Box(10, 10, 4), Box(10, 10, 4)
    with pytest.raises(texcad.ParameterError, match="select it from the part itself"):
        texcad.texture(a, b.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=0.3, pitch=0.5)


def test_a_face_index_and_a_bad_texture_in_the_api():
    """An int selects a face by its index, as ``texcad faces`` lists it and the CLI's
    ``--face 5`` takes it; one past the part's faces, or a texture that is no name,
    path or Heightmap, is a ParameterError saying what to pass."""
    from build123d import Box

    box = Box(20, 20, 6)
    by_index = texcad.texture(box, 5, "builtin:stones", height=0.4, pitch=0.5)
    by_word = texcad.texture(box, "5", "builtin:stones", height=0.4, pitch=0.5)
    assert by_index.volume == by_word.volume > box.volume
    with pytest.raises(texcad.ParameterError, match=r"only 6 faces \(0..5\)"):
        texcad.texture(box, 99, "builtin:stones", height=0.4, pitch=0.5)
    with pytest.raises(texcad.ParameterError, match="builtin:NAME"):
        texcad.texture(box, 5, None, height=0.4, pitch=0.5)
