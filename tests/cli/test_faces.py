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


def test_faces_of_a_mesh_lists_its_regions(tmp_path, capsys):
    """A mesh has no faces to name: ``texcad faces`` says what each usual
    ``--region`` picks (an L-shaped block: two tops, the larger is ``top``), and the
    region it names textures those faces."""
    import trimesh

    block = trimesh.creation.box((30, 10, 10), trimesh.transformations.translation_matrix((15, 5, 5)))
    step = trimesh.creation.box((10, 10, 10), trimesh.transformations.translation_matrix((5, 15, 5)))
    stl = tmp_path / "l.stl"
    trimesh.boolean.union([block, step], engine="manifold").export(stl)
    assert main(["faces", str(stl)]) == 0
    rows = {line.split()[0]: line.split() for line in capsys.readouterr().out.splitlines()[1:14]}
    assert float(rows["top"][2]) == pytest.approx(400.0) and float(rows["not-bottom"][2]) == pytest.approx(1400.0)
    assert float(rows["front"][2]) == pytest.approx(300.0) and rows["normal:-z:45"][1] == "0"
    assert main(["faces", str(stl), "--png", str(tmp_path / "x.png")]) == 2
    assert "texcad render" in capsys.readouterr().err


def test_faces_of_an_empty_mesh_is_one_line(tmp_path, capsys):
    stl = tmp_path / "m.stl"
    stl.write_text("solid x\nendsolid x\n")
    assert main(["faces", str(stl)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("texcad: error: ") and len(err.splitlines()) == 1
