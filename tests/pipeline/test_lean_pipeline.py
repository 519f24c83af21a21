"""Lean meshes with a build direction (issue 15): the overhang limiter changes heights
only, so the limited texture is triangulated lean in tiles; a tile whose lean facets
would overhang (critical angle + 1 degree, the slicer's rule) is redone or kept as
the grid. The result stays lean, within its tolerance and free of texture overhang."""

import warnings

import numpy as np
import pytest

import texcad
from texcad.mapping import Surface
from texcad.printability import orientation, overhang_mask
from texcad.solid import Mesh, edge_report


def _texture_overhang(res, d, angle):
    tm = res.texture_mesh
    f = tm.faces[tm.groups["texture"]] if "texture" in tm.groups else tm.faces
    return int(overhang_mask(Mesh(tm.vertices, f), d, angle, plate_tolerance=-1.0).sum())


@pytest.mark.parametrize("name", ["stones", "diamond_knurl"])
def test_plate_with_build_dir_is_lean_and_support_free(name):
    from texcad.pipeline import textured_plate

    d = orientation(60, "+x")
    kw = dict(size=(20, 20), pitch=0.125, height=1.5, build_dir=d)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        grid = textured_plate(f"builtin:{name}", tolerance=0, **kw)
        lean = textured_plate(f"builtin:{name}", tolerance=0.02, **kw)
    assert lean.mesh.num_triangles < 0.7 * grid.mesh.num_triangles
    assert lean.max_error <= 0.02
    assert lean.mesh.is_watertight and edge_report(lean.mesh.faces)["watertight"]
    assert abs(lean.mesh.volume - grid.mesh.volume) <= 0.02 * 20 * 20
    assert lean.limits.remaining_overhang_mm2 == 0.0
    assert lean.check(build_dir=d).texture_overhang_area_mm2 == 0.0


def test_surface_with_build_dir_is_lean_and_support_free():
    surf = Surface.sine(length=12.0, thickness=5.0, amplitude=3.0, period=20.0, width=30.0)
    d = orientation(30, "+x")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        grid = texcad.texture(surf, None, "builtin:stones", height=1.0, pitch=0.125, tolerance=0, build_dir=d, mapping="distance")
        lean = texcad.texture(surf, None, "builtin:stones", height=1.0, pitch=0.125, tolerance=0.02, build_dir=d, mapping="distance")
    assert lean.mesh.num_triangles < 0.6 * grid.mesh.num_triangles
    assert 0 < lean.max_error <= 0.02
    assert edge_report(lean.mesh.faces)["watertight"]
    assert lean.limits.remaining_overhang_mm2 == 0.0
    assert _texture_overhang(lean, d, 46.0) == 0  # the slicer's threshold + 1 degree


def test_lean_extruded_face_keeps_its_brep_and_ops():
    """A lean cylinder face: the B-rep (one pole per pixel) is made and checked
    against the lean mesh within its tolerance x area (``info["volume_slack"]``), and
    a checked CAD operation works on it."""
    from build123d import Axis, Box, Cylinder, Pos

    part = Cylinder(8, 20)
    face = part.faces().sort_by(Axis.Z)[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = texcad.texture(part, face, "builtin:stones", height=0.6, pitch=0.25, tolerance=0.02)
    assert 0 < r.max_error <= 0.02
    slack = r.info["volume_slack"]
    assert slack == pytest.approx(0.02 * 2 * np.pi * 8 * 20, rel=0.02)
    from texcad.brep import volume

    assert abs(volume(r.shape) - r.mesh.volume) <= 1e-3 * r.mesh.volume + slack
    cut = r - Pos(8, 0, 0) * Box(4, 4, 30)
    assert cut.mesh.is_watertight and cut.mesh.volume < r.mesh.volume


def _union_instead(monkeypatch):
    """Make the planar-face and plate paths use manifold3d's union (the stitch refused)."""
    import texcad.targets.plane as cad
    import texcad.targets.plate as plate
    from texcad.errors import GeometryError

    def refuse(*a, **k):
        raise GeometryError("refused by the test")

    monkeypatch.setattr(cad, "fuse_on_plane", refuse)
    monkeypatch.setattr(plate, "fuse_on_plane", refuse)


def _one_watertight_body(mesh):
    import trimesh

    from texcad.solid import to_manifold

    t = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert t.is_watertight and t.is_winding_consistent
    assert edge_report(mesh.faces)["watertight"]
    assert len(to_manifold(mesh).decompose()) == 1


@pytest.mark.parametrize("holes", [False, True])
def test_lean_planar_face_is_stitched_as_the_union_would_make_it(monkeypatch, holes):
    """A lean relief on an unobstructed planar face is stitched into the body's mesh
    without a boolean: the same volume as manifold3d's union, watertight, one body,
    and its texture mesh is the union's bumps."""
    from build123d import Axis, Box, BuildPart, Hole, Locations

    with BuildPart() as bp:
        Box(30, 20, 8)
        if holes:
            with Locations((4, 2, 0), (-8, -3, 0)):
                Hole(2.5)
    top = bp.part.faces().sort_by(Axis.Z)[-1]
    kw = dict(height=1.0, pitch=0.25, brep=False, tolerance=0.02)
    lean = texcad.texture(bp.part, top, "builtin:stones", **kw)
    assert lean.info["fuse"] == "stitched"
    _one_watertight_body(lean.mesh)
    assert 0 < lean.max_error <= 0.02
    _union_instead(monkeypatch)
    union = texcad.texture(bp.part, top, "builtin:stones", **kw)
    assert union.info["fuse"].startswith("manifold3d")
    assert lean.mesh.volume == pytest.approx(union.mesh.volume, rel=1e-6)
    assert lean.texture_mesh.volume == pytest.approx(union.texture_mesh.volume, rel=1e-5)
    # manifold3d merges a few short edges along the relief's foot; the stitch keeps them
    assert lean.mesh.num_triangles <= 1.05 * union.mesh.num_triangles


def test_lean_plate_is_stitched_and_tolerance_0_keeps_the_union(monkeypatch):
    from texcad.pipeline import textured_plate

    kw = dict(size=(20, 16), pitch=0.125, height=1.5)
    lean = textured_plate("builtin:stones", tolerance=0.02, **kw)
    grid = textured_plate("builtin:stones", tolerance=0, **kw)
    assert lean.info["fuse"] == "stitched" and grid.info["fuse"] == "manifold3d"
    _one_watertight_body(lean.mesh)
    assert abs(lean.mesh.volume - grid.mesh.volume) <= 0.02 * 20 * 16
    _union_instead(monkeypatch)
    union = textured_plate("builtin:stones", tolerance=0.02, **kw)
    assert lean.mesh.volume == pytest.approx(union.mesh.volume, rel=1e-6)


def test_an_obstructed_face_uses_the_union():
    from build123d import Align, Axis, Box, BuildPart, Locations

    with BuildPart() as bp:
        Box(30, 20, 8)  # top face at z = 4
        with Locations((-14, 0, 4), (14, 0, 4)):  # two pillars
            Box(2, 20, 3, align=(Align.CENTER, Align.CENTER, Align.MIN))
        with Locations((0, 0, 4.8)):  # a beam 0.8 mm above the face, below the texture's top
            Box(30, 4, 1, align=(Align.CENTER, Align.CENTER, Align.MIN))
    top = bp.part.faces().filter_by_position(Axis.Z, 3.99, 4.01).sort_by(Axis.Z)[0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = texcad.texture(bp.part, top, "builtin:stones", height=1.0, pitch=0.25, brep=False, tolerance=0.02)
    assert r.info["obstructed"] and r.info["fuse"] == "manifold3d"
    _one_watertight_body(r.mesh)
