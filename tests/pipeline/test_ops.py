"""CAD work on textured parts: booleans, fillets, mirrors; the B-rep (OCCT) checked
against the same operation on texcad's mesh (manifold3d)."""

import re

import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError, ParameterError
from texcad.pipeline import ops
from texcad.brep import check_shape, occt_volume


@pytest.fixture(scope="module")
def part():
    from build123d import Axis, Box

    box = Box(40, 30, 8)
    top = box.faces().sort_by(Axis.Z)[-1]
    return box, texcad.texture(box, top, "builtin:stones", height=1.0, pitch=0.5)


def _agree(result, bodies=1):
    """The B-rep of an operation: one valid solid per mesh body, OCCT's adaptive volume
    within 0.1 % of the mesh's."""
    shape = result.shape
    chk = check_shape(shape)
    assert chk["valid"] and chk["closed"] and chk["solids"] == bodies
    assert occt_volume(shape) == pytest.approx(result.volume, rel=1e-3)
    return shape


def test_textured_b_rep_is_tiles_with_texcads_mesh(part):
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS
    from texcad.brep import explore, surface_grid
    from OCP.TopAbs import TopAbs_FACE

    _, tx = part
    shape = tx.shape
    tiles = 0
    for f in explore(shape, TopAbs_FACE):
        face = TopoDS.Face_s(f)
        got = surface_grid(BRep_Tool.Surface_s(face))
        if got is None:
            continue
        tiles += 1
        rows, cols = got[0].shape[:2]
        assert max(rows, cols) - 1 <= texcad.solid.TILE
        tri = BRep_Tool.Triangulation_s(face, TopLoc_Location())
        assert tri is not None and tri.NbNodes() == rows * cols and tri.NbTriangles() == 2 * (rows - 1) * (cols - 1)
    assert tiles >= 9
    assert check_shape(shape)["valid"] and check_shape(shape)["solids"] == 1
    # Both integrators agree with the mesh: texcad's exact one and OCCT's adaptive one.
    assert tx.info["brep_volume"] == pytest.approx(tx.volume, rel=1e-6)
    assert occt_volume(shape) == pytest.approx(tx.volume, rel=1e-4)


def test_drill_union_and_cross_hole(part):
    from build123d import Cylinder, Pos, Rot

    box, tx = part
    drilled = tx - Cylinder(3, 50)
    removed = tx.volume - drilled.volume
    # The hole removes the box's 8 mm and the texture above (at most 1 mm).
    assert np.pi * 9 * 8 < removed < np.pi * 9 * 9
    _agree(drilled)
    boss = tx + Pos(0, 0, 6) * Cylinder(4, 6)
    added = boss.volume - tx.volume
    assert np.pi * 16 * 4 < added < np.pi * 16 * 5  # the boss above z = 4, less the texture it swallows
    _agree(boss)  # one solid, not two
    both = drilled + Pos(8, 5, 6) * Cylinder(3, 6)  # operations chain (replayed on fine tiles)
    _agree(both)
    cross = tx - Pos(5, 0, 3.3) * Rot(90, 0, 0) * Cylinder(2, 60)
    assert tx.volume - cross.volume > 100
    _agree(cross)


def test_fillet_mirror_and_moved(part, tmp_path):
    from build123d import Axis, Cylinder, Pos

    box, tx = part
    bottom = box.edges().filter_by(Axis.X).sort_by(Axis.Z)[:2]
    rounded = tx.fillet(bottom, 2.0)
    # Two 40 mm edges rounded by r = 2 mm: (1 - pi / 4) r^2 L removed each.
    assert tx.volume - rounded.volume == pytest.approx(2 * (1 - np.pi / 4) * 4 * 40, rel=5e-3)
    _agree(rounded)
    upright = tx.fillet(tx.part.edges().filter_by(Axis.Z), 1.0)  # edges of the textured B-rep
    _agree(upright)
    mirrored = tx.mirrored((30, 0, 0), (1, 0, 0))
    assert mirrored.volume == pytest.approx(tx.volume, rel=1e-6)
    assert mirrored.mesh.vertices[:, 0].min() > 39.9  # x -> 60 - x
    _agree(mirrored)
    _agree(mirrored - Pos(60, 0, 0) * Cylinder(3, 50))
    _agree(Pos(10, 0, 0) * tx - Pos(10, 0, 0) * Cylinder(3, 50))
    rounded.export(tmp_path / "rounded.step")  # STEP again after CAD work
    back = texcad.io.read_step(tmp_path / "rounded.step")
    assert check_shape(back)["valid"] and occt_volume(back) == pytest.approx(rounded.volume, rel=1e-3)


def test_wrong_occt_result_raises(part, monkeypatch):
    from build123d import Cylinder

    _, tx = part
    drilled = tx - Cylinder(3, 50)
    # An OCCT boolean that keeps the material (as on one large grid face) must not pass.
    monkeypatch.setattr(ops, "occt_boolean", lambda shape, tool, op: shape)
    with pytest.raises(GeometryError, match="mm3"):
        drilled.shape
    with pytest.raises(ParameterError, match="radius"):
        tx.fillet(tx.part.edges()[:1], -1.0)


def test_a_small_hole_left_out_of_a_large_part_is_caught(part, monkeypatch):
    """A hole whose volume is under 0.1 % of the part's, which OCCT leaves out of the
    B-rep (as it did on a real keyboard case's knurled wall), is within the whole
    part's tolerance but not within the change's: GeometryError names both changes."""
    from build123d import Cylinder, Pos

    _, tx = part
    drilled = tx - Pos(5, 5, 0) * Cylinder(0.3, 50)
    assert 0 < tx.volume - drilled.volume < ops.OP_VOLUME_TOLERANCE * tx.volume
    monkeypatch.setattr(ops, "occt_boolean", lambda shape, tool, op: shape)
    with pytest.raises(GeometryError, match=r"changed its volume by [+-]0\.00 mm3 but .* by -\d"):
        drilled.shape


def test_another_tiling_when_occt_keeps_the_material(part, monkeypatch):
    """When OCCT's cut on the first tiling keeps the material, the B-rep is made again
    with the next tile size under the tool (ops.FINE_TRIES) and checked again."""
    from build123d import Cylinder

    _, tx = part
    drilled = tx - Cylinder(3, 50)
    real, calls = ops.occt_boolean, []

    def first_wrong(shape, tool, op):
        calls.append(op)
        return shape if len(calls) == 1 else real(shape, tool, op)

    monkeypatch.setattr(ops, "occt_boolean", first_wrong)
    _agree(drilled)
    assert len(calls) == 2 and tx.volume - drilled.volume > np.pi * 9 * 8


def test_hole_in_textured_demo_plate():
    from build123d import Axis, Cylinder, Pos

    plate = texcad.pipeline.plate_base((100, 100), 5)
    top = plate.faces().sort_by(Axis.Z)[-1]
    tx = texcad.texture(plate, top, "builtin:stones", height=2.0, pitch=0.5)
    drilled = tx - Pos(50, 50, 0) * Cylinder(4, 30)
    _agree(drilled)
    assert tx.volume - drilled.volume > np.pi * 16 * 5


def test_pattern_of_textured_part(part, tmp_path):
    from build123d import Cylinder, GridLocations, Pos, Rot

    box, tx = part
    grid = tx.patterned(GridLocations(50, 40, 2, 2))  # 40 x 30 mm copies, 10 mm apart
    assert grid.volume == pytest.approx(4 * tx.volume, rel=1e-9)
    _agree(grid, bodies=4)
    turned = tx.patterned([Pos(0, 0, 0), Pos(100, 0, 0) * Rot(0, 0, 90)])
    _agree(turned, bodies=2)
    drilled = grid - Pos(25, 20, 0) * Cylinder(3, 50)  # through one copy
    assert np.pi * 9 * 8 < grid.volume - drilled.volume < np.pi * 9 * 9  # 8 mm of body + up to 1 mm of texture
    _agree(drilled, bodies=4)
    grid.export(tmp_path / "grid.step")  # STEP of the pattern: four solids at the mesh's tolerance
    texcad.io.write_step(grid.shape, tmp_path / "tess.step", tessellated=True)  # each with its tiles' meshes
    assert (tmp_path / "tess.step").read_bytes().count(b"TESSELLATED_SOLID(") == 4
    for name in ("grid.step", "tess.step"):
        back = texcad.io.read_step(tmp_path / name)
        chk = check_shape(back)
        assert chk["valid"] and chk["solids"] == 4 and occt_volume(back) == pytest.approx(grid.volume, rel=1e-3)
    with pytest.raises(GeometryError, match="overlap"):
        tx.patterned([Pos(0, 0, 0), Pos(20, 0, 0)])
    with pytest.raises(ParameterError, match="rigid"):
        tx.patterned([np.diag([2.0, 1.0, 1.0, 1.0])])


def test_operations_on_a_part_without_brep_run_on_its_mesh():
    """A part textured without a B-rep (``brep=False``): a hole drilled into it still
    gives the exact mesh result, and ``.shape`` of the result says why there is none
    (never a silently missing STEP)."""
    import warnings

    import trimesh
    from build123d import Axis, BuildPart, Box, Cylinder, Pos, fillet

    with BuildPart() as bp:
        Box(30, 20, 8)
        fillet(bp.edges().filter_by(Axis.Z), 3)
    sides = bp.part.faces().filter_by(lambda f: abs(f.normal_at().Z) < 0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tx = texcad.texture(bp.part, sides, "builtin:stones", height=0.5, pitch=0.3, brep=False)
    with pytest.raises(GeometryError):
        tx.shape
    drilled = tx - Pos(0, 0, 0) * Cylinder(2, 20)
    assert tx.mesh.volume - drilled.mesh.volume == pytest.approx(np.pi * 4 * 8, rel=0.01)
    assert trimesh.Trimesh(drilled.mesh.vertices, drilled.mesh.faces).is_watertight
    with pytest.raises(GeometryError, match="STL or 3MF"):
        drilled.shape
    mirrored = drilled.mirrored((0, 0, 0), (1, 0, 0))
    assert mirrored.mesh.volume == pytest.approx(drilled.mesh.volume, rel=1e-6)
    with pytest.raises(GeometryError, match="no B-rep"):
        mirrored.shape


def _on_foot(kind):
    """``(part, face)``: a body of ``kind`` on a square foot 40 mm wide (its upright
    edges untextured, to fillet): a knob's cone with four slanted flutes (a face
    trimmed inside its (u, v) rectangle: texcad.brep.uvtrim), a sphere, a torus."""
    from build123d import Align, Box, Cone, GeomType, Pos, Rot, Sphere, Torus, Cylinder

    up = (Align.CENTER, Align.CENTER, Align.MIN)
    if kind == "cone_flutes":
        body, kind_of = Cone(10, 6, 12, align=up), GeomType.CONE
        for k in range(4):  # four flutes, each leaning 15 degrees
            body = body - Rot(0, 0, 90 * k) * Pos(9.5, 0, 6) * Rot(0, -15, 0) * Cylinder(1.6, 20)
    elif kind == "sphere":
        body, kind_of = Pos(0, 0, 9) * Sphere(10), GeomType.SPHERE
    else:
        body, kind_of = Pos(0, 0, 3) * Torus(12, 4), GeomType.TORUS
    part = body + Pos(0, 0, -1.5) * Box(40, 40, 4)
    return part, max(part.faces().filter_by(kind_of), key=lambda f: f.area)


def _plain_too(result, own: float, bodies: int = 1):
    """:func:`_agree` with ``own`` (mm^3 the textured part's B-rep holds beyond its
    mesh), and OCCT's plain Gauss rule (build123d's ``.volume``) within 0.1 % too."""
    from build123d import Part

    from texcad.brep.solids import flat_solids

    shape = result.shape
    chk = check_shape(shape)
    assert chk["valid"] and chk["solids"] == bodies
    assert abs(occt_volume(shape) - own - result.volume) <= 1e-3 * result.volume
    assert abs(Part(flat_solids(shape)).volume - own - result.volume) <= 1e-3 * result.volume


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_every_operation_on_a_trimmed_face():
    """A knob cone trimmed by flutes (tiles on its own (u, v)) on a foot: a hole
    through the texture, a boss on the foot, a fillet of the foot's upright edges, a
    mirror and a pattern of two each give a valid B-rep whose OCCT volumes (adaptive
    and plain: build123d's ``.volume``) are within 0.1 % of the mesh's."""
    from build123d import Axis, Box, Cylinder, Pos, Rot

    part, face = _on_foot("cone_flutes")
    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5)
    own = occt_volume(tx.shape) - tx.volume
    assert abs(own) <= 1e-3 * tx.volume
    cut = tx - Pos(0, 0, 7) * Rot(0, 90, 0) * Cylinder(1.5, 40)
    assert cut.volume < tx.volume - 20
    _plain_too(cut, own)
    boss = tx + Pos(0, 17, 1.5) * Box(4, 4, 4)
    assert boss.volume > tx.volume + 10
    _plain_too(boss, own)
    rounded = tx.fillet(tx.part.edges().filter_by(Axis.Z).group_by(Axis.X)[0], 1.0)
    assert tx.volume - 2 < rounded.volume < tx.volume - 0.1
    _plain_too(rounded, own)
    _plain_too(tx.mirrored((30, 0, 0), (1, 0, 0)), own)
    _plain_too(tx.patterned([Pos(0, 0, 0), Pos(50, 0, 0)]), 2 * own, bodies=2)


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", ["sphere", "torus"])
def test_operation_on_a_curved_face_keeps_the_plain_volume(kind):
    """A sphere or torus face (textured on its own (u, v)) after a boss on the foot
    or a fillet of the foot: the plain part operated and the face textured again in
    tiles (texcad.brep.uvtrim), so OCCT's plain rule (build123d's ``.volume``) is
    within 0.1 % as well (one re-textured face each: +0.21 % and -0.21 %)."""
    from build123d import Axis, Box, Pos

    part, face = _on_foot(kind)
    tx = texcad.texture(part, face, "builtin:stones", height=0.4, pitch=0.5)
    own = occt_volume(tx.shape) - tx.volume
    if kind == "sphere":
        result = tx + Pos(0, 17, 1.5) * Box(4, 4, 4)
    else:
        result = tx.fillet(tx.part.edges().filter_by(Axis.Z).group_by(Axis.X)[0], 1.0)
    _plain_too(result, own)


def _drilled(kind):
    """``(textured part, 3 mm drill through its texture)`` (stones 0.4 mm at 0.5 mm
    unless said): a raised box top, a full cylinder, a diamond-knurled r 11 mm grip,
    a box top on a foot."""
    from build123d import Axis, Box, Cylinder, GeomType, Pos, Rot

    if kind in ("box top", "top on a foot"):
        part = Box(20, 20, 4) if kind == "box top" else Box(30, 30, 4) + Pos(0, 0, 4) * Box(20, 20, 4)
        tx = texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=0.4, pitch=0.5)
        return tx, Pos(1, 2, 0) * Cylinder(1.5, 30)
    r, texture = (11, "builtin:diamond_knurl") if kind == "knurl" else (8, "builtin:stones")
    cyl = Cylinder(r, 16)
    tx = texcad.texture(cyl, cyl.faces().filter_by(GeomType.CYLINDER)[0], texture, height=0.4, pitch=0.5)
    return tx, Rot(90, 0, 0) * Cylinder(1.5, 40)  # radially, through both walls


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("kind", ["box top", "top on a foot", "cylinder", "knurl"])
def test_plain_volume_after_a_drill(kind):
    """A hole through the small tiles a tool gets (texcad.brep.solids, FINE): OCCT's
    plain Gauss rule (build123d's ``.volume``, FreeCAD's) is within 0.1 % of the mesh
    cut, as the adaptive one: the small tiles carry knots placed for the rule OCCT
    uses on each of them (with their runs' knots: box top +0.53 %, full cylinder
    +1.7 %, knurled grip +0.2 %)."""
    tx, tool = _drilled(kind)
    own = occt_volume(tx.shape) - tx.volume
    assert abs(own) <= 1e-3 * tx.volume
    drilled = tx - tool
    assert tx.volume - drilled.volume > 10.0  # the drill went through the texture
    _plain_too(drilled, own)


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("angle", [0, 71])
def test_boss_next_to_a_full_cylinders_relief(angle):
    """A 3 mm boss on the foot of a textured full cylinder, 0.1 mm from the relief's
    highest point there (its small tiles under the tool reach the band's first
    column at 71 degrees): a valid B-rep whose OCCT volumes (adaptive and plain)
    are within 0.1 % of the mesh's."""
    from build123d import Align, Box, Cylinder, GeomType, Pos, Rot

    up = (Align.CENTER, Align.CENTER, Align.MIN)
    part = Box(24, 24, 3) + Pos(0, 0, 1.5) * Cylinder(8, 12, align=up)
    tx = texcad.texture(part, part.faces().filter_by(GeomType.CYLINDER)[0], "builtin:stones", height=0.4, pitch=0.5)
    d = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
    v = tx.mesh.vertices.astype(np.float64)
    near = (np.abs(v[:, :2] @ np.array([-d[1], d[0]])) < 1.6) & (v[:, 2] > 1.0) & (v[:, 2] < 4.5)
    c = float((v[near, :2] @ d).max()) + 0.1 + 1.5  # the box's inner side 0.1 mm from the relief
    boss = tx + Pos(c * d[0], c * d[1], 3) * Rot(0, 0, angle) * Box(3, 3, 3)
    assert boss.volume > tx.volume + 20
    _plain_too(boss, 0.0)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_drilled_torus_plain_volume():
    """A 3 mm hole through a textured torus (r 4 mm tube, stones 0.4 mm at 0.5 mm):
    the B-rep follows the mesh where the relief dips under the face (the part's
    tessellation there, finer than the grid's chords on the tube: the textured B-rep
    was -0.071 % off its mesh, the drilled one -0.118 % by OCCT's plain rule), so
    both OCCT volumes are within 0.1 % of the mesh's without any allowance."""
    from build123d import Cylinder, Pos, Torus

    part = Torus(12, 4)
    tx = texcad.texture(part, part.faces()[0], "builtin:stones", height=0.4, pitch=0.5)
    assert abs(occt_volume(tx.shape) - tx.volume) <= 3e-4 * tx.volume
    drilled = tx - Pos(0, 12, 0) * Cylinder(1.5, 30)
    assert tx.volume - drilled.volume > 40  # through the tube, top and bottom
    _plain_too(drilled, 0.0)
    _plain_too(drilled.mirrored((20, 0, 0), (1, 0, 0)), 0.0)  # the drill made again on the plain part, mirrored


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_lean_sphere_b_rep_follows_its_mesh():
    """A sphere textured with a lean mesh (tolerance 0.05 mm at 0.25 mm): the B-rep is
    made of the lean top at every grid point, so its OCCT volumes (adaptive and
    plain) are within 0.02 % of the mesh's (of the grid's points: +0.036 %)."""
    from build123d import Part, Sphere

    from texcad.brep.solids import flat_solids

    part = Sphere(10)
    tx = texcad.texture(part, part.faces()[0], "builtin:stones", height=0.4, pitch=0.25, tolerance=0.05)
    assert tx.info["volume_slack"] > 0  # the mesh is lean
    shape = flat_solids(tx.shape)
    assert abs(occt_volume(shape) - tx.volume) <= 2e-4 * tx.volume
    assert abs(Part(shape).volume - tx.volume) <= 2e-4 * tx.volume


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_fillet_of_a_textured_faces_edge_says_so():
    """The top circle of a textured cone, picked from ``textured.part.edges()`` (a
    piece of it: the strips cut it), is found on the plain part; where the B-rep's
    fillet and the mesh's disagree (the mesh's takes the relief off, the B-rep's
    keeps it up to the fillet) the error says the edge borders the textured face
    and names STL or 3MF, while the mesh result is made."""
    from build123d import Align, Axis, Box, Cone, GeomType, Pos

    up = (Align.CENTER, Align.CENTER, Align.MIN)
    part = Box(30, 30, 3) + Pos(0, 0, 1.5) * Cone(10, 6, 12, align=up)
    tx = texcad.texture(part, part.faces().filter_by(GeomType.CONE)[0], "builtin:stones", height=0.4, pitch=0.5)
    rounded = tx.fillet(tx.part.edges().filter_by(GeomType.CIRCLE).sort_by(Axis.Z)[-1:], 0.8)
    assert tx.volume - 5 < rounded.volume < tx.volume - 0.5  # the mesh's fillet took the rim off
    with pytest.raises(GeometryError, match="STL or 3MF.*borders the textured face"):
        rounded.shape


def test_a_volume_build123d_misreads_is_told():
    """Half a textured sphere cut off: the B-rep encloses the mesh's volume (texcad's
    exact integration), but OCCT's plain Gauss integration, which build123d's
    ``.volume`` and FreeCAD use, misses the fine tiles the cut trimmed (-0.54 %): a
    TexcadWarning says so and where to read the volume, instead of a silently wrong
    figure."""
    import warnings

    from build123d import Box, Pos, Sphere

    from texcad.brep import volume

    s = Sphere(10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tx = texcad.texture(s, s.faces()[0], "builtin:dimples", height=0.5, pitch=0.5, mode="engraved")
    cut = tx - Pos(0, 0, 12) * Box(30, 30, 20)
    with pytest.warns(texcad.TexcadWarning, match=r"build123d's \.volume") as told:
        part = cut.part
    assert volume(part) == pytest.approx(cut.mesh.volume, rel=1e-3)
    off = float(re.search(r"reads it ([-+][\d.]+) % off", str(told[-1].message)).group(1))
    assert off == pytest.approx((part.volume / cut.mesh.volume - 1) * 100, abs=0.01)  # the figure build123d gives
