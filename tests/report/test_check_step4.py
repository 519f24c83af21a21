"""texcad check on STEP parts other tools write (session 12)."""

import math

import pytest

import texcad

build123d = pytest.importorskip("build123d")


def test_a_step_volume_is_its_b_reps(tmp_path):
    """CadQuery's red_cube_blue_cylinder.step (a 10 mm cube and an r 5 x 10 mm
    cylinder): texcad check said 1783.3 mm3, OCCT's tessellation at 0.5 rad; the
    B-rep encloses 1785.4. The B-rep's own volume is now reported, the mesh's in a note."""
    from build123d import Box, Compound, Cylinder, Pos, export_step

    path = tmp_path / "cube_cylinder.step"
    export_step(Compound([Box(10, 10, 10), Pos(20, 0, 0) * Cylinder(5, 10)]), str(path))
    want = 1000.0 + math.pi * 25.0 * 10.0
    rep = texcad.check(path)
    assert rep.volume_mm3 == pytest.approx(want, rel=1e-6)
    assert any("the tessellation checked here encloses" in n for n in rep.notes)


def test_a_surface_step_is_said_to_hold_no_solid(tmp_path):
    from build123d import Compound, Face, Rectangle, export_step

    path = tmp_path / "sheet.step"
    export_step(Compound([Face(Rectangle(25.4, 25.4).wire())]), str(path))
    rep = texcad.check(path)
    assert not rep.watertight and any("holds no solid" in n for n in rep.notes)
