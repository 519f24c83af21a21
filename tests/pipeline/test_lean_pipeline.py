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
        grid = texcad.texture(surf, None, "builtin:stones", height=1.0, tolerance=0, build_dir=d, mapping="distance")
        lean = texcad.texture(surf, None, "builtin:stones", height=1.0, tolerance=0.02, build_dir=d, mapping="distance")
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
    from texcad.solid import volume

    assert abs(volume(r.shape) - r.mesh.volume) <= 1e-3 * r.mesh.volume + slack
    cut = r - Pos(8, 0, 0) * Box(4, 4, 30)
    assert cut.mesh.is_watertight and cut.mesh.volume < r.mesh.volume
