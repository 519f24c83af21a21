"""The textured B-rep handed out as a flat compound of solids (issue 28): build123d's
``Part(...).volume`` sees every solid, on a plane and on a full cylinder."""

import warnings

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
    adaptive = occt_volume(flat)
    assert abs(adaptive - tx.volume) <= 1e-3 * tx.volume + slack  # adaptive Gauss, eps 1e-4
    _plain_volumes_agree(flat, tx.volume, slack=slack)
    _plain_volumes_agree(flat, adaptive, rel=5e-4)  # the plain rule as right as the adaptive one


def _plain_volumes_agree(shape, mesh_volume: float, rel: float = 1e-3, slack: float = 0.0):
    """OCCT's plain (default, non-adaptive) Gauss integration of ``shape``
    (``BRepGProp::VolumeProperties(shape, props)``) and build123d's ``.volume`` (the
    same call) are within ``rel`` of the mesh's volume (mm^3, plus ``slack`` mm^3):
    texcad's knots are placed for that rule (texcad.brep.gprop)."""
    from build123d import Part
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    assert abs(props.Mass() - mesh_volume) <= rel * mesh_volume + slack
    assert abs(Part(shape).volume - mesh_volume) <= rel * mesh_volume + slack


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


def _revolved():
    """A solid of revolution whose side is a spline profile turned about z."""
    from build123d import Axis, BuildLine, BuildPart, BuildSketch, GeomType, Plane, Polyline, Spline, make_face, revolve

    with BuildPart() as bp:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Spline((6, 0), (8, 4), (6.5, 8), (7, 12))
                Polyline((7, 12), (0, 12), (0, 0), (6, 0))
            make_face()
        revolve(axis=Axis.Z)
    return bp.part, bp.part.faces().filter_by(GeomType.REVOLUTION)[0]


def _bspline():
    """A B-spline sheet (5 x 5 points) thickened to 4 mm; its B-spline face."""
    import numpy as np
    from build123d import Face, GeomType, Solid

    pts = [[(x, y, 1.5 * np.sin(x / 6) * np.cos(y / 7)) for y in np.linspace(-10, 10, 5)] for x in np.linspace(-10, 10, 5)]
    part = Solid.thicken(Face.make_surface_from_array_of_points(pts), 4)
    return part, max(part.faces().filter_by(GeomType.BSPLINE), key=lambda f: f.area)


def _kind(kind):
    """``(part, face, 3 mm drill through the textured region, mode)`` of a face kind."""
    from build123d import Axis, Box, Cone, Cylinder, GeomType, Pos, Rot, Sphere, Torus

    base, _, mode = kind.partition("_")
    across = Rot(0, 90, 0) * Cylinder(1.5, 40)  # along x through the axis
    if base == "plane":
        part = Box(20, 20, 4)
        return part, part.faces().sort_by(Axis.Z)[-1], Cylinder(1.5, 30), mode or "raised"
    if base in ("cylinder", "partial"):
        part = Cylinder(8, 12, arc_size=180 if base == "partial" else 360)
        return part, part.faces().filter_by(GeomType.CYLINDER)[0], Rot(90, 0, 0) * Cylinder(1.5, 40), mode or "raised"
    if base == "cone":
        part = Cone(10, 6, 12)
        return part, part.faces().filter_by(GeomType.CONE)[0], across, mode or "raised"
    if base == "sphere":
        part = Sphere(10)
        return part, part.faces()[0], across, mode or "raised"
    if base == "torus":
        part = Torus(12, 4)
        return part, part.faces()[0], Pos(0, 12, 0) * Cylinder(1.5, 30), mode or "raised"
    part, face = _revolved() if base == "revolved" else _bspline()
    return part, face, (Pos(0, 0, 6) * across if base == "revolved" else Cylinder(1.5, 30)), "raised"


def _occt_meshes_closed(shape) -> bool:
    """OCCT's mesher (``BRepMesh_IncrementalMesh``, 0.1 mm, 0.5 rad) gives every face
    a triangulation, and every edge of two faces the same nodes on both (the mesh is
    closed: no crack along any edge; a texture wall of zero height at a corner gives
    triangles of no area, which a weld by position would drop)."""
    import numpy as np
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    BRepMesh_IncrementalMesh(shape, 0.1, False, 0.5, True)
    owners = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, owners)
    for i in range(1, owners.Extent() + 1):  # one per edge
        edge = TopoDS.Edge_s(owners.FindKey(i))
        faces = [TopoDS.Face_s(f) for f in owners.FindFromIndex(i)]
        if BRep_Tool.Degenerated_s(edge):
            continue
        if len(faces) != 2:
            return False  # a free edge: the shell is open
        if faces[0].IsSame(faces[1]):  # a seam: both sides on one face
            faces = faces[:1]
        nodes = []
        for f in faces:  # the faces along it
            loc = TopLoc_Location()
            tri = BRep_Tool.Triangulation_s(f, loc)
            if tri is None:
                return False
            poly = BRep_Tool.PolygonOnTriangulation_s(edge, tri, loc)
            if poly is None:
                return False
            nodes.append(np.array([tri.Node(poly.Node(k)).Transformed(loc.Transformation()).Coord()
                                   for k in range(1, poly.NbNodes() + 1)]))  # fmt: skip
        if len(nodes) == 2 and not (nodes[0].shape == nodes[1].shape and np.allclose(nodes[0], nodes[1], rtol=0, atol=1e-9)):
            return False
    return True


KINDS = ["plane", "cylinder", "partial", "cone", "sphere", "torus", "revolved", "bspline", "plane_engraved", "plane_centred",
         "cylinder_engraved", "cylinder_centred", "torus_engraved", "sphere_engraved", "cone_centred"]


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", KINDS)
def test_face_kind_step_and_hole(kind, tmp_path):
    """Every single face kind (stones 0.4 mm at 0.5 mm): the B-rep's and the STEP
    re-read's volume by OCCT's plain Gauss rule and build123d's ``.volume`` are within
    0.1 % of the mesh's; the STEP re-read is one valid solid whose OCCT volume (eps
    1e-4) is within 0.1 % of the mesh's and which OCCT meshes closed; a 3 mm hole through the texture gives a valid one-solid B-rep within
    0.1 % of the same cut on the mesh (plus what the textured B-rep itself is off)."""
    part, face, tool, mode = _kind(kind)
    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5, mode=mode)
    _plain_volumes_agree(flat_solids(tx.shape), tx.volume)
    tx.export(tmp_path / "part.step")
    back = flat_solids(texcad.io.read_step(tmp_path / "part.step"))
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    own = occt_volume(back) - tx.volume
    assert abs(own) <= 1e-3 * tx.volume
    _plain_volumes_agree(back, tx.volume)
    assert _occt_meshes_closed(back)
    cut = tx - tool
    assert cut.volume < tx.volume - 20  # the hole went through the textured wall
    shape = cut.shape  # checked by ops: valid, one solid, volume against the mesh
    chk = check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1
    assert abs(occt_volume(shape) - cut.volume) <= 1e-3 * cut.volume + abs(own)


def _agree(result, own: float):
    """``result.shape`` valid, one solid per body, within 0.1 % of its mesh (plus
    ``own``, mm^3: what the textured part's B-rep is off its mesh)."""
    shape = result.shape
    chk = check_shape(shape)
    assert chk["valid"]
    assert abs(occt_volume(shape) - result.volume) <= 1e-3 * result.volume + abs(own)
    return chk


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", ["cylinder", "cone"])
def test_fillet_mirror_pattern_and_boss_on_curved_face(kind):
    """A textured cylinder / cone on a square foot: fillet of the foot's upright
    edges (untextured), a mirror, a pattern of two and a boss on the texture each
    give a valid B-rep within 0.1 % of the same operation on the mesh."""
    from build123d import Align, Axis, Box, Cone, Cylinder, GeomType, Pos

    up = (Align.CENTER, Align.CENTER, Align.MIN)
    body = Cylinder(8, 12, align=up) if kind == "cylinder" else Cone(10, 6, 12, align=up)
    part = Box(24, 24, 3) + Pos(0, 0, 1.5) * body
    face = part.faces().filter_by(GeomType.CYLINDER if kind == "cylinder" else GeomType.CONE)[0]
    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5)
    own = occt_volume(tx.shape) - tx.volume
    assert abs(own) <= 1e-3 * tx.volume
    rounded = tx.fillet(tx.part.edges().filter_by(Axis.Z).group_by(Axis.X)[0], 1.0)
    assert tx.volume - 2 < rounded.volume < tx.volume - 0.1  # two 1 mm fillets took material off
    assert check_shape(rounded.shape)["solids"] == 1
    _agree(rounded, own)
    mirrored = tx.mirrored((20, 0, 0), (1, 0, 0))
    assert mirrored.volume == pytest.approx(tx.volume, rel=1e-6) and mirrored.mesh.vertices[:, 0].min() > 15
    _agree(mirrored, own)
    two = tx.patterned([Pos(0, 0, 0), Pos(40, 0, 0)])
    assert check_shape(two.shape)["solids"] == 2
    _agree(two, 2 * own)
    boss = tx + Pos(0, 0, 14) * Box(4, 4, 4)  # into the top, off the texture
    assert boss.volume > tx.volume + 10
    _agree(boss, own)


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", ["torus", "bspline"])
def test_plain_part_first_takes_big_cuts(kind, monkeypatch):
    """The operation made on the plain part and the texture put again (OCCT's boolean
    of the textured B-rep switched off): half a textured torus cut off along its seam
    (the cut's edge is the old seam, with its two pcurves, used once), a slot through
    a B-spline face: valid, one solid, within 0.1 % of the mesh."""
    from build123d import Box, Pos

    from texcad.pipeline import ops

    def no_boolean(*args, **kwargs):
        raise texcad.GeometryError("the boolean of the textured B-rep was used")

    monkeypatch.setattr(ops, "_replay", no_boolean)
    part, face, _, mode = _kind(kind)
    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5, mode=mode)
    own = occt_volume(tx.shape) - tx.volume
    cut = tx - (Pos(0, 20, 0) * Box(40, 40, 20) if kind == "torus" else Box(4, 12, 20))
    assert cut.volume < tx.volume - 200
    chk = _agree(cut, own)
    assert check_shape(cut.shape)["solids"] == 1 and chk["closed"]


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


def test_chained_result_drilled_replays_on_the_earlier_b_rep():
    """A hole through the second texture of a chained result: the operation is made
    on the B-rep that texture was put on (the earlier result's, with its texture),
    not on the plain part, whose replay lost the first texture (-0.44 %) so that only
    OCCT's cut of the textured B-rep was left (+0.097 %, at the edge of the check)."""
    from build123d import Axis, Cylinder, GeomType, Rot

    part = Cylinder(8, 20)
    first = texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], "builtin:diamond_knurl", height=0.4, pitch=0.5)
    chained = texcad.texture(first, part.faces().filter_by(GeomType.CYLINDER)[0], "builtin:stones", height=0.4, pitch=0.5)
    cut = chained - Rot(90, 0, 0) * Cylinder(1.5, 40)
    assert cut.volume < chained.volume - 20
    chk = check_shape(cut.shape)
    assert chk["valid"] and chk["solids"] == 1
    assert abs(occt_volume(cut.shape) - cut.volume) <= 3e-4 * cut.volume


def test_uncovered_face_names_itself():
    """A face no texture grid point lies on gets no B-rep: the error names the face
    (its kind, centre, (u, v) rectangle), how much is off it, and STL/3MF (a face
    trimmed inside its rectangle gets one: test_trimmed_face_kind)."""
    import numpy as np
    from build123d import Cone, GeomType

    from texcad.brep import uv_textured_solid

    cone = Cone(10, 6, 12)
    face = cone.faces().filter_by(GeomType.CONE)[0]
    R, C = 12, 10
    zeros = np.zeros((R, C))
    item = {"face": face, "points": np.zeros((R, C, 3)), "normals": np.zeros((R, C, 3)), "heights": zeros,
            "valid": zeros.astype(bool), "xs": np.linspace(0.0, 1.0, C), "ys": np.linspace(0.0, 1.0, R),
            "u_table": np.array([[0.0, 2 * np.pi], [0.0, 1.0]]), "v_table": np.array([[0.0, 12.65], [0.0, 1.0]]),
            "closed_u": True}
    with pytest.raises(texcad.GeometryError) as err:
        uv_textured_solid(cone, [item])
    said = str(err.value)
    c = face.center()
    assert "cone face centred at" in said and f"{c.Z:.2f}" in said
    assert f"of {(R - 2) * (C - 2)} grid points off it" in said and "STL and 3MF" in said


def test_zones_knob_cone_and_chamfer_in_strips():
    """The zones knob recipe's grip cone and its chamfer (another cone, sharing the
    circle between them) are both textured on their own (u, v) and cut into strips
    (texcad.brep.uvstrips) one after the other, each taking the other's pieces of the
    shared circle: one valid closed solid (the two faces' strips cut it apart before,
    so both fell back to one face each), whose plain-rule volume (build123d's
    ``.volume``) is within 1e-4 of OCCT's adaptive one (one face each: 4.2e-4) and
    within 0.1 % of the mesh."""
    from build123d import Axis, BuildLine, BuildPart, BuildSketch, GeomType, Part, Plane, Polyline, make_face, revolve

    with BuildPart() as knob:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Polyline((3, 0), (15, 0), (15, 2), (12.5, 14), (11, 15.5), (3, 15.5), close=True)
            make_face()
        revolve(axis=Axis.Z)
    cones = knob.part.faces().filter_by(GeomType.CONE).sort_by(Axis.Z)
    top = knob.part.faces().sort_by(Axis.Z)[-1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tx = texcad.texture(knob.part, [(cones[0], "builtin:diamond_knurl:period=2", {"height": 0.6}),
                                        ([cones[-1], top], "builtin:stones", {"height": 0.4, "mode": "engraved"})],
                            pitch=0.5, build_dir=(0, 0, 1))
    shape = flat_solids(tx.shape)
    chk = check_shape(shape)
    assert chk["valid"] and chk["closed"] and chk["solids"] == 1
    exact = occt_volume(shape)
    assert abs(Part(shape).volume - exact) <= 1e-4 * exact
    assert abs(exact - tx.volume) <= 1e-3 * tx.volume + tx.info.get("volume_slack", 0.0)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_drilled_cylinder_volumes():
    """A full cylinder textured, then drilled across (the FreeCAD test's part): small
    tiles under the tool split the long sides of the whole tiles beside them; those
    pieces keep knots at the grid rows, so OCCT's adaptive volume at eps 1e-4 is
    within 1e-4 of its converged one (straight pieces: +0.28 %), and the plain rule
    (build123d's ``.volume``) within 0.1 %."""
    from build123d import Cylinder, GeomType, Part

    cyl = Cylinder(10, 16)
    tx = texcad.texture(cyl, cyl.faces().filter_by(GeomType.CYLINDER)[0], "builtin:stones", height=0.4, pitch=0.5)
    drilled = tx - Cylinder(1.5, 40, rotation=(90, 0, 0))
    shape = flat_solids(drilled.shape)
    exact = occt_volume(shape, 1e-7)
    assert abs(occt_volume(shape) - exact) <= 1e-4 * exact
    assert abs(Part(shape).volume - exact) <= 1e-3 * exact
    assert abs(exact - drilled.volume) <= 1e-3 * drilled.volume + drilled.info.get("volume_slack", 0.0)


def _trimmed(kind):
    """``(part, face, 3 mm drill through the texture)``: faces whose outline is not
    their (u, v) rectangle. A knob's cone with four slanted flutes (Fusion 360 style),
    a cone cut by a slanted plane, a cylinder drilled through, a cylinder with a slot
    in its side, a wall of revolution (B-spline profile) with a window."""
    from build123d import Align, Axis, Box, Cone, Cylinder, GeomType, Pos, Rot, SortBy

    up = (Align.CENTER, Align.CENTER, Align.MIN)
    across = Pos(0, 0, 6) * Rot(0, 90, 0) * Cylinder(1.5, 40)
    if kind == "cone_flutes":
        part = Cone(10, 6, 12, align=up)
        for k in range(4):  # four flutes, each leaning 15 degrees
            part = part - Rot(0, 0, 90 * k) * Pos(9.5, 0, 6) * Rot(0, -15, 0) * Cylinder(1.6, 20)
        return part, part.faces().filter_by(GeomType.CONE).sort_by(SortBy.AREA)[-1], across
    if kind == "cone_slanted":
        part = Cone(10, 6, 12, align=up) - Pos(0, 0, 11) * Rot(20, 0, 0) * Box(40, 40, 10, align=up)
        return part, part.faces().filter_by(GeomType.CONE)[0], Pos(0, 0, 5) * Rot(0, 90, 0) * Cylinder(1.5, 40)
    if kind == "cylinder_hole":
        part = Cylinder(8, 12) - Rot(90, 0, 0) * Cylinder(1.5, 40)
        return part, part.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1], Rot(0, 90, 0) * Cylinder(1.5, 40)
    if kind == "cylinder_slot":
        part = Cylinder(8, 12) - Pos(0, 8, 2) * Box(10, 6, 3)
        return part, part.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1], Rot(0, 90, 0) * Cylinder(1.5, 40)
    part, _ = _revolved()
    part = part - Pos(0, 8, 6) * Rot(0, 0, 30) * Box(3, 6, 7)
    return part, part.faces().filter_by(GeomType.REVOLUTION).sort_by(SortBy.AREA)[-1], across


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", ["cone_flutes", "cone_slanted", "cylinder_hole", "cylinder_slot", "revolved_window"])
def test_trimmed_face_kind(kind, tmp_path):
    """A face trimmed inside its (u, v) rectangle (texcad.brep.uvtrim: tiles on its
    own (u, v)), stones 0.4 mm at 0.5 mm: one valid closed solid, more faces than the
    plain part (the tiles), OCCT's plain and adaptive (eps 1e-4) volumes and
    build123d's ``.volume`` within 0.1 % of the mesh's, and OCCT meshes it closed
    (its STEP re-read: test_trimmed_face_step); a 3 mm hole through the texture gives
    a valid one-solid B-rep within 0.1 % of the same cut on the mesh."""
    from OCP.BRepTools import BRepTools

    part, face, tool = _trimmed(kind)
    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5)
    assert tx.volume > part.volume + 20  # the relief is there
    _check(tx)
    shape = flat_solids(tx.shape)
    assert check_shape(shape)["faces"] > len(part.faces()) + 10
    own = occt_volume(shape) - tx.volume
    BRepTools.Clean_s(shape)  # OCCT's own triangulation, not the tiles' grid meshes
    assert _occt_meshes_closed(shape)
    cut = tx - tool
    assert cut.volume < tx.volume - 20
    assert _agree(cut, own)["solids"] == 1


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", ["cone_flutes", "revolved_window"])
def test_trimmed_face_step(kind, tmp_path):
    """The STEP of a face trimmed inside its (u, v) rectangle re-reads as one valid
    closed solid whose OCCT volumes (adaptive eps 1e-4, plain, build123d's) are within
    0.1 % of the mesh's, and which OCCT meshes closed."""
    part, face, _ = _trimmed(kind)
    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5)
    tx.export(tmp_path / "part.step")
    back = flat_solids(texcad.io.read_step(tmp_path / "part.step"))
    chk = check_shape(back)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert abs(occt_volume(back) - tx.volume) <= 1e-3 * tx.volume
    _plain_volumes_agree(back, tx.volume)
    assert _occt_meshes_closed(back)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_b_rep_holds_the_mesh_that_keeps_every_pixel():
    """The B-rep goes through every pixel; the lean mesh (tolerance 0.02 mm) lies
    within that tolerance of it, so their volumes differ by up to ``volume_slack``
    (a fine cylinder's STEP reads 0.12 % above its lean mesh). Against the mesh that
    keeps every pixel (``tolerance=0``) OCCT's volumes, adaptive and plain, agree
    within 5e-5."""
    from build123d import Cylinder, GeomType, Part

    cyl = Cylinder(8, 12)
    side = cyl.faces().filter_by(GeomType.CYLINDER)[0]
    lean = texcad.texture(cyl, side, "builtin:stones", height=0.6, pitch=0.25)
    full = texcad.texture(cyl, side, "builtin:stones", height=0.6, pitch=0.25, tolerance=0.0)
    assert full.mesh.num_triangles > 2 * lean.mesh.num_triangles
    shape = flat_solids(full.shape)
    assert abs(occt_volume(shape) - full.volume) <= 5e-5 * full.volume
    assert abs(Part(shape).volume - full.volume) <= 5e-5 * full.volume
    assert abs(full.volume - lean.volume) <= lean.info["volume_slack"]


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("arc", [360, 180])
def test_lean_cylinder_b_rep_follows_its_mesh(arc):
    """A full and a half cylinder textured at 0.25 mm with a lean mesh (0.02 mm): the
    B-rep's grid is moved onto the lean mesh (texcad.brep.targets.snapped_grid), so OCCT's
    adaptive and plain volumes are within 0.1 % of the mesh's with no allowance (on
    the grid itself: +0.11 % and +0.12 %, plain +0.17 %)."""
    from build123d import Cylinder, GeomType

    cyl = Cylinder(8, 12, arc_size=arc)
    tx = texcad.texture(cyl, cyl.faces().filter_by(GeomType.CYLINDER)[0], "builtin:stones", height=0.6, pitch=0.25)
    assert tx.stages.relief.max_error > 0  # lean
    flat = flat_solids(tx.shape)
    assert check_shape(flat)["valid"]
    assert abs(occt_volume(flat) - tx.volume) <= 1e-3 * tx.volume
    _plain_volumes_agree(flat, tx.volume)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_lean_plane_b_rep_follows_its_mesh():
    """A box top textured with stones at 0.125 mm, lean (0.02 mm): the lean top's
    chords cut under the stones (its volume 0.1 % under the pixel grid's), and the
    B-rep's heights enclose the lean mesh's volume cell by cell
    (texcad.targets.plane._brep_heights), so OCCT's adaptive and plain volumes are
    within 2e-4 of the mesh's, and a hole drilled through within 1e-3."""
    from build123d import Axis, Box

    box = Box(20, 20, 4)
    top = box.faces().sort_by(Axis.Z)[-1]
    tx = texcad.texture(box, top, "builtin:stones", height=0.4, pitch=0.125)
    full = texcad.texture(box, top, "builtin:stones", height=0.4, pitch=0.125, tolerance=0.0)
    assert tx.info["tolerance"] > 0 and full.volume - tx.volume > 5e-4 * tx.volume  # the lean mesh is the smaller
    _b_rep_and_drilled_hold_their_meshes(tx)


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("pitch", [0.5, 0.25])
def test_pins_b_rep_holds_its_mesh(pitch):
    """Pins 4 mm tall (the heat sink recipe's texture). At 0.5 mm, 2 px across, a
    lean top would cross their edges between the pixel centres (0.26 % under the
    grid's volume, past the gate's allowance on a larger plate though every pixel
    centre is within 0.02 mm): the face keeps the pixel grid (tolerance 0). At 0.25
    mm the lean top stays and the B-rep encloses its volume. Either way OCCT's
    adaptive and plain volumes are within 2e-4 of the mesh's, a hole through the pins
    within 1e-3."""
    from build123d import Axis, Box

    box = Box(20, 20, 4)
    top = box.faces().sort_by(Axis.Z)[-1]
    pins = "builtin:pins:period=3,diameter=1.4"
    tx = texcad.texture(box, top, pins, height=4.0, pitch=pitch)
    assert (tx.info["tolerance"] == 0) == (pitch == 0.5)
    full = texcad.texture(box, top, pins, height=4.0, pitch=pitch, tolerance=0.0)
    assert abs(full.volume - tx.volume) <= (1e-9 if pitch == 0.5 else 2e-3) * tx.volume
    _b_rep_and_drilled_hold_their_meshes(tx)


def _b_rep_and_drilled_hold_their_meshes(tx) -> None:
    """OCCT's adaptive and plain volumes of ``tx``'s B-rep within 2e-4 of its mesh,
    and of a 3 mm hole drilled through it (which must remove something) within 1e-3."""
    from build123d import Cylinder

    flat = flat_solids(tx.shape)
    assert abs(occt_volume(flat) - tx.volume) <= 2e-4 * tx.volume
    _plain_volumes_agree(flat, tx.volume, rel=2e-4)
    drilled = tx - Cylinder(1.5, 30)
    assert tx.volume - drilled.volume > 20
    flat = flat_solids(drilled.shape)
    assert abs(occt_volume(flat) - drilled.volume) <= 1e-3 * drilled.volume
    _plain_volumes_agree(flat, drilled.volume)


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("pitch", [0.5, 0.25])
def test_filleted_plate_pins_step_plain_volume(pitch, tmp_path):
    """Issue 28: a plate whose top has rounded corners (the heat sink recipe's
    outline, 24 mm) with 4 mm pins at 0.5 mm (the pixel grid kept): the top is made
    of tiles that avoid the outline (holed_plane_solid), whose knots are placed for
    OCCT's plain Gauss rule like a rectangular top's. Its STEP, read back, and a
    hole through the pins: plain and adaptive volumes within 0.1 % of the mesh's
    (before: plain +0.36 %, drilled +0.59 %, at 0.25 mm (a lean top) +0.85 %; the
    60 mm heat sink +1.6 %; now 0.04 % at most)."""
    from build123d import Axis, BuildPart, BuildSketch, Cylinder, Rectangle, extrude, fillet
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    from texcad.io import read_step

    with BuildPart() as p:
        with BuildSketch():
            Rectangle(24, 24)
        extrude(amount=4)
        fillet(p.edges().filter_by(Axis.Z), radius=6)
    top = p.part.faces().sort_by(Axis.Z)[-1]
    tx = texcad.texture(p.part, top, "builtin:pins:period=3,diameter=1.4", height=4.0, pitch=pitch)
    assert (tx.info["tolerance"] == 0) == (pitch == 0.5)
    for i, t in enumerate((tx, tx - Cylinder(1.5, 30))):  # the plate, drilled through the pins
        t.export(tmp_path / f"plate{i}.step")
        back = read_step(tmp_path / f"plate{i}.step")
        props = GProp_GProps()
        BRepGProp.VolumeProperties_s(back, props)
        assert abs(props.Mass() - t.volume) <= 1e-3 * t.volume
        assert abs(occt_volume(back) - t.volume) <= 1e-3 * t.volume
        _plain_volumes_agree(flat_solids(t.shape), t.volume)
