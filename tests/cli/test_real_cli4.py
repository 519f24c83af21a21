"""The command line on files other tools wrote (session 12, fourth round of real files)."""

import subprocess
import sys

import pytest


def _texcad(*args):
    return subprocess.run([sys.executable, "-m", "texcad", *map(str, args)], capture_output=True, text=True)


@pytest.fixture(scope="module")
def open_box(tmp_path_factory):
    """A STEP surface model: five faces of a 20 x 20 x 10 mm box, no top, no solid."""
    from build123d import Box, Compound, export_step

    path = tmp_path_factory.mktemp("surface") / "open_box.step"
    export_step(Compound(list(Box(20, 20, 10).faces())[:5]), str(path))
    return path


@pytest.mark.parametrize("face", [["--face", "top"], ["--zone", "top@builtin:dots"], []])
def test_a_surface_step_says_it_holds_no_solid_first(tmp_path, open_box, face):
    """A surface-only STEP with --face top said 'face selector top: no planar face looks
    top; use a face index (0..4)', and with that index, that the part holds no solid.
    The first error now names the real problem, the file and the fix."""
    r = _texcad("texture", open_box, *face, "-o", tmp_path / "out.stl")
    lines = r.stderr.strip().splitlines()
    assert r.returncode != 0 and len(lines) == 1, r.stderr
    assert "open_box.step' holds no solid" in lines[0] and "5 face(s) but no closed body" in lines[0]
    assert "close or thicken the surface" in lines[0] and "selector" not in lines[0]
    assert not (tmp_path / "out.stl").exists()
