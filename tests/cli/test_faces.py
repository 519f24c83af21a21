"""``texcad faces PART.step`` (issue 27): every face listed with its solid, type,
area, centre, normal or axis and the selectors that pick it; ``--png`` draws the
numbers. On a build123d part exported to STEP here."""

from __future__ import annotations

import math

import pytest

from conftest import assert_picture
from texcad.cli import main

build123d = pytest.importorskip("build123d")


@pytest.fixture
def part_step(tmp_path):
    from build123d import Box, Compound, Cylinder, Pos, export_step

    body = Box(20, 20, 10) - Cylinder(4, 10)  # a plate with a hole: 6 planes and a cylinder
    p = tmp_path / "part.step"
    export_step(Compound([body, Pos(30, 0, 0) * Box(4, 4, 4)]), str(p))  # and a second solid
    return p


def _rows(out: str) -> dict[int, str]:
    rows = {}
    for line in out.splitlines()[1:]:
        head = line.split()
        if head and head[0].isdigit():
            rows[int(head[0])] = line
    return rows


def test_faces_lists_every_face_with_selectors(part_step, capsys):
    from build123d import Compound

    from texcad.brep.selectors import named as pick_faces
    from texcad.io import read_step

    assert main(["faces", str(part_step)]) == 0
    out = capsys.readouterr().out
    rows = _rows(out)
    part = Compound(read_step(part_step))
    faces = part.faces()
    assert sorted(rows) == list(range(len(faces))) == list(range(13))
    assert "13 in 2 solid(s)" in out
    for i, line in rows.items():  # every selector listed picks that face
        f = line.split()
        solid, kind, area = int(f[1]), f[2], float(f[3])
        assert area == pytest.approx(faces[i].area, abs=6e-4)
        selectors = line.rsplit(")", 1)[1].split()
        assert selectors[-1] == str(i)
        for s in selectors:
            assert any(g.is_same(faces[i]) for g in pick_faces(part, s)), (s, i)
        assert solid == (0 if faces[i].center().X < 15 else 1)
    top = next(line for line in rows.values() if " top " in line)
    assert float(top.split()[3]) == pytest.approx(400 - math.pi * 16, abs=6e-4)
    assert "normal (0.000, 0.000, 1.000)" in top
    cyl = next(line for line in rows.values() if " cylinder " in line)
    assert "axis (0.000, 0.000, 1.000)" in cyl and "cylinder:0" in cyl


def test_faces_png_shows_the_numbers(part_step, tmp_path, capsys):
    png = tmp_path / "faces.png"
    assert main(["faces", str(part_step), "--png", str(png), "--width", "400"]) == 0
    assert "face numbers shown" in capsys.readouterr().out
    assert_picture(png)


def test_faces_of_a_mesh_is_one_line(tmp_path, capsys):
    stl = tmp_path / "m.stl"
    stl.write_text("solid x\nendsolid x\n")
    assert main(["faces", str(stl)]) == 2
    assert capsys.readouterr().err.strip().startswith("texcad: error: texcad faces lists the faces of a STEP part")
