"""An assembly of overlapping solids: every figure texcad reports or gates is that of
what it writes (session 12). A 60 x 40 x 20 mm box and a 30 x 30 x 30 mm box that
covers 10 x 30 mm of its top: 48 000 + 27 000 mm3, sharing 6 000 mm3, union 69 000 mm3.
The first box's top is textured, so part of its texture lies inside the second box."""

from __future__ import annotations

import warnings

import pytest

import texcad
from texcad.cli import main
from texcad.errors import GeometryError, TexcadWarning

build123d = pytest.importorskip("build123d")


def _boxes():
    from build123d import Align, Box, Compound, Pos

    low = (Align.MIN,) * 3
    a = Box(60, 40, 20, align=low)
    b = Pos(50, 10, 0) * Box(30, 30, 30, align=low)
    return a, b, Compound([a, b])


@pytest.fixture(scope="module")
def textured():
    from build123d import Axis

    a, _, both = _boxes()
    with pytest.warns(TexcadWarning, match=r"mm3 of the texture \(\d+ % of its .* lies inside the other solid"):
        return texcad.texture(both, a.faces().sort_by(Axis.Z)[-1], "builtin:stones", pitch=1.0, height=1.0)


def test_the_printed_volume_is_the_union_written(textured, tmp_path):
    """The summary gave 'all solids' as the plain sum of the solids' volumes (75 887.9
    mm3) where the STL holds their union (69 818.4 mm3); result.check() checked the
    textured solid alone (48 887.9 mm3). Both now give the STL's volume."""
    stl = tmp_path / "a.stl"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        textured.export(stl)
    written = texcad.io.read_mesh(stl).volume
    total = sum(m.volume for m in textured.bodies)
    assert total - written == pytest.approx(6000.0 + textured.buried_mm3, abs=0.5)  # shared once, buried texture not printed
    assert textured.printed_mesh.volume == pytest.approx(written, rel=1e-6)
    assert textured.check().volume_mm3 == pytest.approx(written, rel=1e-6)
    change = textured.mesh.volume - 48000.0
    assert 0.03 * change < textured.buried_mm3 < 0.125 * change  # under 10 x 30 of the 60 x 40 mm top (ramped edges)


def test_the_printed_mesh_is_checked_against_the_bodies(textured):
    """A union that lost a body (here: the textured solid alone given as printed) is
    refused naming both volumes."""
    from texcad.pipeline.assembly import check_printed

    check_printed(textured.printed_mesh, textured.mesh, textured.other_meshes, slack=textured.gate.volume_slack)
    with pytest.raises(GeometryError, match=r"enclose 4\d{4}\.\d mm3 but the textured solid and the others give 6\d{4}"):
        check_printed(textured.mesh, textured.mesh, textured.other_meshes, slack=textured.gate.volume_slack)


def test_the_cli_summary_gives_the_printed_volume(tmp_path, capsys):
    from build123d import export_step

    step, stl = tmp_path / "boxes.step", tmp_path / "out.stl"
    export_step(_boxes()[2], str(step))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TexcadWarning)
        assert main(["texture", str(step), "--face", "top", "--pitch", "1", "-q", "-o", str(stl)]) == 0
    line = [x for x in capsys.readouterr().out.splitlines() if x.startswith("volume")][0]
    written = texcad.io.read_mesh(stl).volume
    assert f"all solids {written:.1f} mm3 as printed, their union: they share 60" in line, line
    assert "mm3 of the texture inside other solids" in line


@pytest.mark.parametrize("suffix", [".stl", ".step"])
def test_check_gives_the_union_of_overlapping_bodies(tmp_path, suffix):
    """texcad check on one file of two overlapping bodies reported their sum (75 000
    mm3) with a note that they overlap; it now reports their union (69 000 mm3, as a
    slicer prints them) and says the shells' sum in a note."""
    from build123d import export_step, export_stl

    path = tmp_path / f"boxes{suffix}"
    both = _boxes()[2]
    export_step(both, str(path)) if suffix == ".step" else export_stl(both, str(path))
    rep = texcad.check(path)
    assert rep.volume_mm3 == pytest.approx(69000.0, rel=1e-6)
    assert any("the shells' sum is 75000.0 mm3" in n for n in rep.notes) and not rep.manifold
