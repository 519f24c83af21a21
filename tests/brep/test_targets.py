"""The B-rep of faces textured by the general method (texcad.brep.targets,
texcad.brep.uv_textured_solid): each face kind's STEP re-read is one valid solid
whose OCCT volume (BRepGProp, eps 1e-4) is within 0.1 % of texcad's mesh, and whose
shown mesh (BRepMesh_IncrementalMesh at 0.1 mm, what CAD viewers run) lies within
the deflection of texcad's mesh both ways."""

import warnings

import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError, TexcadWarning
from texcad.brep import check_shape, occt_volume, shape_to_mesh

DEFLECTION = 0.1  # mm


def _distance(points, mesh) -> float:
    import igl

    d2 = igl.point_mesh_squared_distance(
        np.asarray(points, np.float64), mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64)
    )[0]
    return float(np.sqrt(d2.max()))


def _cone():
    from build123d import Cone, GeomType

    part = Cone(10, 6, 12)
    return part, part.faces().filter_by(GeomType.CONE)[0]


def _sphere():
    from build123d import Sphere

    part = Sphere(10)
    return part, part.faces()[0]


def _torus():
    from build123d import Torus

    part = Torus(20, 8)
    return part, part.faces()[0]


def _revolved():
    from build123d import Axis, BuildLine, BuildPart, BuildSketch, GeomType, Line, Plane, Polyline, Spline, make_face, revolve

    with BuildPart() as p:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Polyline((0, 12), (0, 0), (8, 0))
                Spline((8, 0), (10, 5), (7, 12))
                Line((7, 12), (0, 12))
            make_face()
        revolve(axis=Axis.Z)
    return p.part, p.part.faces().filter_by(GeomType.REVOLUTION)[0]


def _bspline():
    from build123d import BuildPart, BuildSketch, Ellipse, GeomType, Plane, Rectangle, loft

    with BuildPart() as p:
        with BuildSketch():
            Rectangle(20, 14)
        with BuildSketch(Plane.XY.offset(20)):
            Ellipse(9, 6)
        loft()
    return p.part, p.part.faces().filter_by(GeomType.BSPLINE)[0]


def _fillet():
    from build123d import Axis, Cylinder, GeomType, fillet

    part = fillet(Cylinder(12, 20).edges().sort_by(Axis.Z)[-1], 4)  # the rounded rim: a torus face
    return part, part.faces().filter_by(GeomType.TORUS)[0]


def _reread(tx, path, eps=None):
    """``tx`` written as STEP to ``path`` and read back: one valid closed solid whose
    OCCT volume (``eps``, None: OCCT's default) is the mesh's within 0.1 %."""
    tx.export(path)
    back = texcad.io.read_step(path)
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    vol = occt_volume(back) if eps is None else occt_volume(back, eps)
    assert vol == pytest.approx(tx.volume, rel=1e-3)
    return back


@pytest.mark.parametrize("make", [_cone, _sphere, _torus, _revolved, _bspline, _fillet], ids=lambda f: f.__name__[1:])
def test_face_kind_step_is_one_solid_shown_as_texcads_mesh(make, tmp_path):
    from OCP.BRep import BRep_Tool

    from texcad.brep import faces_of
    from texcad.brep.uvstrips import strip_origin

    part, face = make()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)  # the sphere fades at its poles
        tx = texcad.texture(part, face, "builtin:stones", height=0.6, pitch=0.5)
    shape = tx.shape  # checked: valid, one solid, texcad's volume within 0.1 %
    # the face replaced in place (no boolean) by strips of its own (u, v) (texcad.brep.uvstrips)
    strips = sum(strip_origin(BRep_Tool.Surface_s(f)) is not None for f in faces_of(shape))
    assert check_shape(shape)["faces"] == len(part.faces()) - 1 + max(strips, 1)
    path = tmp_path / "part.step"
    tx.export(path)
    assert b"TRIANGULATED_FACE" not in path.read_bytes()  # the B-rep at the mesh's tolerance; OCCT meshes it
    back = texcad.io.read_step(path)
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert occt_volume(back) == pytest.approx(tx.volume, rel=1e-3)
    shown = shape_to_mesh(back, tolerance=DEFLECTION, angular_tolerance=0.5)
    assert _distance(shown.vertices, tx.mesh) < DEFLECTION
    # OCCT meshes the B-spline tiles itself (no tessellation in the default STEP): + half the pitch
    assert _distance(tx.mesh.vertices, shown) < DEFLECTION + 0.5 * 0.5


def test_faces_flattened_together_have_a_brep():
    from build123d import Axis, Box, fillet

    part = fillet(Box(30, 20, 10).edges().filter_by(Axis.Z), 4)
    sides = part.faces().filter_by(Axis.Z, reverse=True)  # 4 planes + 4 fillets: one band
    tx = texcad.texture(part, sides, "builtin:stones", height=0.5, pitch=0.5)
    assert tx.volume > part.volume
    chk = check_shape(tx.shape)  # tiles with walls (texcad.brep.bands), issue 28
    assert chk["valid"] and chk["solids"] == 1 and occt_volume(tx.shape) == pytest.approx(tx.volume, rel=1e-3)


def _sine():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "recipes"))
    import paper_samples

    sine, top, _ = paper_samples.sine_sample()
    return sine, top


def _poles(shape):
    """``(faces, largest pole count of a B-spline face)`` of a shape."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    from texcad.brep import explore

    faces = explore(shape, TopAbs_FACE)
    most = 0
    for f in faces:  # every face
        s = BRep_Tool.Surface_s(TopoDS.Face_s(f))
        if hasattr(s, "NbUPoles"):
            most = max(most, s.NbUPoles() * s.NbVPoles())
    return len(faces), most


def test_open_extrusion_faces_are_tiles_sewn_in_place(tmp_path):
    """Open profiles (the paper's sine sample, a box's fillet) get their B-rep without
    OCCT's union: the face replaced by tiles of at most (TILE + 1)^2 poles sewn to its
    own boundary edges (split at the tile corners, the neighbours too); texcad's exact
    volume and OCCT's own (BRepGProp, eps 1e-3) within 0.1 % of the mesh; the STEP one
    valid solid shown as texcad's mesh."""
    from build123d import Axis, Box, GeomType, fillet

    sine, top = _sine()
    box = fillet(Box(30, 20, 10).edges().filter_by(Axis.Z), 4)
    rounded = box.faces().filter_by(GeomType.CYLINDER)[0]  # a quarter of its cylinder: an open profile
    for part, face, mapping in ((sine, top, "distance"), (box, rounded, "angle")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TexcadWarning)
            tx = texcad.texture(part, face, "builtin:diamond_knurl", height=0.8, pitch=0.5, mapping=mapping,
                                build_dir=texcad.orientation(15, "+x"))  # fmt: skip
        shape = tx.shape
        faces, most = _poles(shape)
        assert most <= (texcad.solid.TILE + 1) ** 2
        if part is sine:
            assert faces > 100  # 200 x 200 cells in tiles
        assert tx.info["brep_volume"] == pytest.approx(tx.volume, rel=1e-3)
        assert occt_volume(shape, 1e-3) == pytest.approx(tx.volume, rel=1e-3)
        back = _reread(tx, tmp_path / "part.step", 1e-3)
        shown = shape_to_mesh(back, tolerance=DEFLECTION, angular_tolerance=0.5)
        # OCCT meshes the tiles itself (the default STEP carries no triangulation): its nodes sample the
        # bilinear grid between pixel centres, where the lean mesh's bound does not hold (the same with
        # the exact B-rep: 0.11 / 0.23 mm on the plate with holes at 0.5 mm): + the pitch
        assert _distance(shown.vertices, tx.mesh) < DEFLECTION + 0.5
        assert _distance(tx.mesh.vertices, shown) < DEFLECTION + 0.5


def test_hole_through_the_textured_sine():
    """A hole drilled through the textured sine sample (inside, and across its side
    wall) is one valid solid whose volume, OCCT's own and texcad's, is within 0.1 % of
    the same cut on texcad's mesh (manifold3d)."""
    from build123d import Cylinder, Pos

    part, face = _sine()
    tx = texcad.texture(part, face, "builtin:diamond_knurl", height=0.8, pitch=0.5, mapping="distance")
    for x, y in ((61.3, 22.7), (0.0, 40.0)):
        cut = tx - Pos(x, y, 0) * Cylinder(4, 60)
        assert tx.volume - cut.volume > 250  # the mesh lost the hole's material
        shape = cut.shape  # checked by ops: valid, one solid, texcad's volume
        chk = check_shape(shape)
        assert chk["valid"] and chk["solids"] == 1
        assert cut.info["brep_volume"] == pytest.approx(cut.volume, rel=1e-3)
        assert occt_volume(shape, 1e-3) == pytest.approx(cut.volume, rel=1e-3)


@pytest.mark.parametrize("mode", ["engraved", "centred"])
@pytest.mark.parametrize("make", [_cone, _sphere], ids=lambda f: f.__name__[1:])
def test_engraved_and_centred_faces_have_their_step(make, mode, tmp_path):
    """The face's B-rep follows the cut-in surface, and OCCT's own volume of it agrees
    with texcad's mesh (lean where that saves triangles) within 0.1 %."""
    part, face = make()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        tx = texcad.texture(part, face, "builtin:stones", height=0.6, pitch=0.3, mode=mode)
    assert 0 <= tx.max_error <= 0.02
    back = _reread(tx, tmp_path / "part.step")
    if mode == "engraved":  # cut in: less than the part
        assert occt_volume(back) < part.volume
    shown = shape_to_mesh(back, tolerance=DEFLECTION, angular_tolerance=0.5)
    assert _distance(shown.vertices, tx.mesh) < DEFLECTION


def test_plate_with_holes_in_tiles(tmp_path):
    """A planar face with holes and a pocket: tiles where the texture is (halved near
    the outlines, never touching them), planar faces around them (islands around the
    holes), no boolean; one valid solid whose OCCT volume is within 0.1 % of the
    mesh, its STEP shown as texcad's mesh, and a hole drilled through the texture
    checked against manifold3d."""
    from build123d import Axis, Box, Cylinder, GeomType, Pos

    plate = Box(60, 40, 6) - Pos(-15, 0, 0) * Cylinder(5, 10) - Pos(15, 5, 0) * Cylinder(3, 10) - Pos(20, -12, 2) * Box(8, 6, 4)
    top = plate.faces().sort_by(Axis.Z)[-1]
    assert len(top.wires()) == 4
    tx = texcad.texture(plate, top, "builtin:stones", height=1.0, pitch=0.5)
    shape = tx.shape
    faces, most = _poles(shape)
    assert most <= (texcad.solid.TILE + 1) ** 2 and faces > 60  # tiles, not one large face
    slack = tx.info.get("volume_slack", 0.0)
    assert abs(occt_volume(shape, 1e-3) - tx.volume) <= 1e-3 * tx.volume + slack
    path = tmp_path / "holes.step"
    tx.export(path)
    (tmp_path / "again").mkdir()
    texcad.texture(plate, top, "builtin:stones", height=1.0, pitch=0.5).export(tmp_path / "again" / "holes.step")
    assert (tmp_path / "again" / "holes.step").read_bytes() == path.read_bytes()  # same inputs, same bytes
    back = texcad.io.read_step(path)
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    shown = shape_to_mesh(back, tolerance=DEFLECTION, angular_tolerance=0.5)
    # OCCT meshes the tiles itself: + the pitch (see test_open_extrusion_faces_are_tiles_sewn_in_place)
    assert _distance(shown.vertices, tx.mesh) < DEFLECTION + 0.5
    assert _distance(tx.mesh.vertices, shown) < DEFLECTION + 0.5
    cut = tx - Pos(0, 0, 0) * Cylinder(4, 30)
    assert tx.volume - cut.volume > 300
    cs = cut.shape  # checked: valid, one solid, volume within 0.1 % of manifold3d's
    assert abs(occt_volume(cs, 1e-3) - cut.volume) <= 1e-3 * cut.volume + slack
    assert len(plate.faces().filter_by(GeomType.CYLINDER)) == 2


@pytest.mark.parametrize("mode", ["engraved", "centred"])
def test_engraved_and_centred_planar_faces_have_their_step(mode, tmp_path):
    """A planar face engraved or centred (the general method's grid in the face's
    frame) gets tiles in place, around a hole too: one valid solid, OCCT's volume
    within 0.1 % of texcad's mesh, the shown mesh within the deflection of it."""
    from build123d import Axis, Box, Cylinder, Pos

    plate = Box(40, 30, 8) - Pos(-8, 0, 0) * Cylinder(4, 10)
    top = plate.faces().sort_by(Axis.Z)[-1]
    tx = texcad.texture(plate, top, "builtin:stones", height=0.6, pitch=0.3, mode=mode)
    faces, most = _poles(tx.shape)
    assert faces > len(plate.faces()) + 10 and most <= (texcad.solid.TILE + 1) ** 2
    back = _reread(tx, tmp_path / "part.step", 1e-3)
    if mode == "engraved":  # cut in: less than the part
        assert occt_volume(back, 1e-3) < plate.volume - 100
    shown = shape_to_mesh(back, tolerance=DEFLECTION, angular_tolerance=0.5)
    # OCCT meshes the tiles itself: + the pitch (see test_open_extrusion_faces_are_tiles_sewn_in_place)
    assert _distance(shown.vertices, tx.mesh) < DEFLECTION + 0.3
    assert _distance(tx.mesh.vertices, shown) < DEFLECTION + 0.3
    cut = tx - Pos(8, 3, 0) * Cylinder(3, 30)  # a hole drilled through the texture
    assert tx.volume - cut.volume > 200
    chk = check_shape(cut.shape)  # checked by ops against manifold3d's cut
    assert chk["valid"] and chk["solids"] == 1
    assert occt_volume(cut.shape, 1e-3) == pytest.approx(cut.volume, rel=1e-3)
