"""Regions on meshes as other tools write them (session 10, real files)."""

import numpy as np
import trimesh

import texcad
from texcad.mapping.region import Region, mark_cavities, resolve_faces
from texcad.solid import cavity_faces


def _hollow(inner=(1.4, 5.0, 6.0)):
    """A 20 mm cube with a closed void (PrusaSlicer's extruder_idler.obj has two nut
    pockets 1.4 mm wide sealed inside it)."""
    outer, hole = trimesh.creation.box((20, 20, 20)), trimesh.creation.box(inner)
    hole.invert()
    return trimesh.util.concatenate([outer, hole])


def test_a_closed_cavity_is_in_no_region():
    """Nobody sees or touches a sealed void's wall: texturing it put relief into the
    1.4 mm pocket, which turned inside out ('2 body(ies) lie inside another body')."""
    m = _hollow()
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    cav = cavity_faces(v, f)
    assert cav.sum() == 12 and not cav[:12].any()
    fn = m.face_normals
    for spec in ("all", "normal:+z:30", "box:-20,-20,-20,20,20,20", "not:normal:+z:30", "top"):
        r = mark_cavities(v, f, resolve_faces(v, f, [Region.parse(spec)]))[0]
        sel = r.select(v, f, fn, build_dir=np.array([0.0, 0, 1]), tolerance=0.01, ids=np.arange(len(f)))
        assert not sel[cav].any(), spec
    part = texcad.texture(m, "all", "builtin:stones", height=0.5, pitch=0.5)
    body = trimesh.Trimesh(part.mesh.vertices, part.mesh.faces, process=False)
    shells = sorted(s.volume for s in body.split(only_watertight=False))
    assert len(shells) == 2 and abs(shells[0] + 1.4 * 5 * 6) < 1e-3  # the void as it was


def test_an_inside_out_mesh_lists_its_regions():
    """texcad faces reads the mesh as it is (not repaired): an STL written inside out
    lists its faces as before (no face taken for a cavity's)."""
    from texcad.mapping.region import region_table
    from texcad.solid import Mesh

    b = trimesh.creation.box((20, 20, 20))
    b.invert()
    rows = {r["region"]: r for r in region_table(Mesh(np.asarray(b.vertices, np.float32), np.asarray(b.faces, np.uint32)))}
    assert rows["normal:-z:45"]["faces"] == 2  # inside out: the top's normals point down


def test_the_region_table_of_a_repaired_mesh_leaves_its_cavity_out():
    """texcad faces on a hollow mesh (repaired, as texturing reads it) counts the
    faces texturing would take: not the void's walls."""
    from texcad.mapping.region import region_table
    from texcad.solid import Mesh, repair_closed

    v, f, _ = repair_closed(*(np.asarray(a) for a in (_hollow().vertices, _hollow().faces)))
    mesh = Mesh(v.astype(np.float32), f.astype(np.uint32))
    rows = {r["region"]: r for r in region_table(mesh, repaired=True)}
    raw = {r["region"]: r for r in region_table(mesh)}
    assert rows["not-bottom"]["faces"] == 10 and raw["not-bottom"]["faces"] > 10
    assert rows["not-bottom"]["area"] == 5 * 400
    assert rows["normal:+z:45"]["faces"] == 2 and raw["normal:+z:45"]["faces"] == 4  # the void's floor faces up


def test_a_region_is_named_as_the_user_wrote_it():
    """'region 1 (Region(kind='normal', direction='+z', angle=60.0, lo=None, hi=None,
    center=None, radius=None, bottom=False, invert=False, paint='color', state=1)) holds no
    face' (a BambuStudio project's cone and cylinder): now 'region 1 (normal:-z:10)'."""
    import pytest

    from texcad.errors import ParameterError

    specs = ["all", "all+bottom", "normal:+z:60", "normal:0,1,1:30", "box:0,0,0,1,2,3", "sphere:1,2,3,4", "top",
             "bottom", "not:normal:+z:30", "paint:2", "paint:seam:2", "paint:fuzzy", "not:front"]
    for spec in specs:
        assert str(Region.parse(spec)) == spec and Region.parse(str(Region.parse(spec))) == Region.parse(spec)
    with pytest.raises(ParameterError, match=r"region 1 \(normal:-z:10\) holds no face"):
        texcad.texture(trimesh.creation.box((20, 20, 20)), "normal:-z:10", "builtin:dots", height=0.3, pitch=0.5)


def test_a_cavity_mask_of_another_mesh_is_refused():
    """A region whose cavity was marked on another mesh, asked about faces without
    their ids, says so instead of texturing the cavity's walls."""
    import pytest

    from texcad.errors import ParameterError

    m = _hollow()
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    r = mark_cavities(v, f, resolve_faces(v, f, [Region.parse("all")]))[0]
    with pytest.raises(ParameterError, match="cavity marks 24 faces but the mesh has 12"):
        r.select(v, f[:12], m.face_normals[:12], build_dir=np.array([0.0, 0, 1]), tolerance=0.01)
