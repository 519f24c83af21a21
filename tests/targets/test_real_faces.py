"""CAD faces as real parts from other tools have them (session 9, real files): what a
user reads when a texture cannot be made, and which faces it names."""

import pytest

import texcad
from texcad.errors import ParameterError


def test_a_texture_flat_at_the_pitch_is_named_on_curved_and_several_faces():
    """knurl_fine (1 mm period) at a 0.5 mm pitch samples to 0 mm: a real enclosure's
    top plane with its two bends was refused as 'too small or narrow for the border
    band' (an 8900 mm2 face), one warning per face, on the generic faces path."""
    from build123d import Axis, Cylinder, GeomType, Sphere

    c = Cylinder(10, 20)
    top, side = c.faces().sort_by(Axis.Z)[-1], c.faces().filter_by(GeomType.CYLINDER)[0]
    s = Sphere(10)
    for part, where in ((c, [top, side]), (s, s.faces()[0])):  # several faces; one sphere face
        with pytest.raises(ParameterError, match="flat .* at a pitch of 0.5 mm.*use a smaller pitch"):
            texcad.texture(part, where, "builtin:knurl_fine", pitch=0.5)


def _split_washer():
    """A washer whose top is two half-rings (as SolidWorks, Inventor and CATIA split
    periodic faces): one solid, fused without merging the halves."""
    from build123d import Compound, Cylinder, Keep, Plane, split
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse

    a, b = split(Cylinder(15, 4) - Cylinder(6, 4), bisect_by=Plane.XZ, keep=Keep.BOTH).solids()
    op = BRepAlgoAPI_Fuse(a.wrapped, b.wrapped)
    op.Build()
    return Compound(op.Shape()).solids()[0]


def _panel_with_a_hole():
    """A box's top, rounded edge and side as one sheet with a vent hole in the side
    (a sheet-metal enclosure's lid, Protocase via Autodesk): a disk with a hole."""
    from build123d import Axis, Box, Cylinder, GeomType, Pos, Rot, fillet

    b = Box(30, 24, 16)
    b = fillet(b.edges().filter_by(Axis.Y).sort_by(Axis.X)[-2:].sort_by(Axis.Z)[-1:], 3)
    b = b - Pos(15, 0, -2) * Rot(0, 90, 0) * Cylinder(2, 6)
    top = b.faces().sort_by(Axis.Z)[-1]
    side = b.faces().filter_by(GeomType.PLANE).sort_by(Axis.X)[-1]
    bend = b.faces().filter_by(GeomType.CYLINDER).sort_by(Axis.Z)[-1]
    return b, [top, bend, side]


@pytest.mark.parametrize("make", ["washer", "panel"])
def test_a_sheet_with_one_hole_is_flattened_not_refused_as_a_band(make):
    """Faces joined into a disk with one hole have an annulus' topology (Euler
    characteristic 0) but do not run around an axis: they were refused as 'a closed
    band that does not run around one axis'."""
    from build123d import Axis

    if make == "washer":
        part = _split_washer()
        faces = list(part.faces().filter_by(Axis.Z).group_by(Axis.Z)[-1])
        assert len(faces) == 2
    else:
        part, faces = _panel_with_a_hole()
    tx = texcad.texture(part, faces, "builtin:stones", pitch=0.5, height=0.5)
    assert tx.mesh.is_watertight
    area = sum(f.area for f in faces)
    assert 0.05 * area < tx.volume - part.volume < 0.5 * area  # raised stones on those faces only


def test_a_cone_ring_in_two_faces_is_a_band_like_the_one_face():
    """A 45-degree cone ring split into two faces (as other CAD programs split
    periodic faces) was flattened as a sheet (LSCM, a seam of cut dots): about the
    origin its normals see its axis as much as any direction across it. It is a band,
    seamless, its texture scale kept in the middle as on the one-face cone: the
    around-scale's 5th and 95th percentiles within 0.1 of the one face's (ratio of
    radii 2; laid at the widest rim they were 0.5 and 1.0)."""
    import numpy as np
    from build123d import Compound, Cone, Cylinder, GeomType, Keep, Plane, split
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse

    whole = Cone(20, 10, 10) - Cylinder(5, 10)
    a, b = split(whole, bisect_by=Plane.XZ, keep=Keep.BOTH).solids()
    op = BRepAlgoAPI_Fuse(a.wrapped, b.wrapped)
    op.Build()
    part = Compound(op.Shape()).solids()[0]
    cones = list(part.faces().filter_by(GeomType.CONE))
    assert len(cones) == 2
    two = texcad.texture(part, cones, "builtin:dots", pitch=0.5, height=0.5)
    one = texcad.texture(whole, whole.faces().filter_by(GeomType.CONE), "builtin:dots", pitch=0.5, height=0.5)
    p2, p1 = two.info["faces"][0], one.info["faces"][0]
    assert p2["parameterization"].startswith("band") and two.mesh.is_watertight
    assert np.allclose(p2["distortion"]["y"][:2], p1["distortion"]["y"][:2], atol=0.1), (p2, p1)
    assert np.isclose(two.volume - part.volume, one.volume - whole.volume, rtol=0.15)


def test_a_band_around_an_axis_still_runs_around():
    """The four sides of a box are a band around z (wraps_around), a bent sheet is not."""
    import numpy as np
    import trimesh

    from texcad.targets.patches import wraps_around

    box = trimesh.creation.box((10, 10, 10))
    sides = np.abs(box.face_normals[:, 2]) < 0.5
    assert wraps_around(box.vertices, box.faces[sides])
    top_and_side = (box.face_normals[:, 2] > 0.5) | (box.face_normals[:, 0] > 0.5)
    assert not wraps_around(box.vertices, box.faces[top_and_side])


def test_narrow_faces_left_untextured_are_one_warning():
    """A fluted cap's forty flutes (gustebeast/superglue-cap nozzle) gave twenty
    identical warnings, one per flute too narrow for the border band."""
    import warnings

    from build123d import Axis, Box, chamfer

    from texcad.errors import TexcadWarning

    b = Box(20, 20, 8)
    b = chamfer(b.edges().group_by(Axis.Z)[-1], 0.6)
    top = b.faces().sort_by(Axis.Z)[-1]
    slopes = [f for f in b.faces() if 0.3 < f.normal_at().Z < 0.9]
    assert len(slopes) == 4
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        tx = texcad.texture(b, [top] + slopes, "builtin:dots", pitch=0.5, height=0.4)
    msgs = [str(w.message) for w in seen if issubclass(w.category, TexcadWarning) and "untextured" in str(w.message)]
    assert len(msgs) == 1 and msgs[0].startswith("4 patches of faces ("), msgs
    assert tx.volume > b.volume


def test_an_assemblys_faces_are_named_as_texcad_faces_numbers_them():
    """A Protocase (Autodesk) enclosure of two solids: faces 52, 69, 54 of its lid were
    reported as faces [36], [53], [38] (numbers within the lid alone)."""
    import warnings

    from build123d import Axis, Box, Compound, Pos, chamfer

    from texcad.errors import TexcadWarning

    lid = Pos(40, 0, 10) * chamfer(Box(20, 20, 8).edges().group_by(Axis.Z)[-1], 0.6)
    part = Compound([Box(10, 10, 10), lid])
    faces = part.faces()
    top = max(range(len(faces)), key=lambda i: faces[i].center().Z)
    slope = next(i for i, f in enumerate(faces) if 0.3 < f.normal_at().Z < 0.9)
    assert top >= 6 and slope >= 6  # the lid's faces follow the first box's 6
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        tx = texcad.texture(part, [faces[top], faces[slope]], "builtin:dots", pitch=0.5, height=0.4)
    msgs = [str(w.message) for w in seen if issubclass(w.category, TexcadWarning) and "untextured" in str(w.message)]
    assert len(msgs) == 1 and msgs[0].startswith(f"face(s) [{slope}] left untextured"), msgs
    assert [p["faces"] for p in tx.info["faces"]] == [[top]]
