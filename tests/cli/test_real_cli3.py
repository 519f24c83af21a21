"""The command line on files other tools wrote (session 11, third round of real files)."""

import subprocess
import sys

import pytest


def _texcad(*args):
    return subprocess.run([sys.executable, "-m", "texcad", *map(str, args)], capture_output=True, text=True)


@pytest.mark.parametrize("command", ["texture", "faces", "check"])
def test_a_mesh_format_texcad_does_not_read_is_named(tmp_path, command):
    """trimesh's ballA.off: texcad texture said "'ballA.off' is not a STEP file (it does
    not start with 'ISO-10303-21;'); give a .step / .stp file", texcad check said
    "cannot check" and texcad faces gave no way out. Each now names the suffix, the
    formats texcad reads and how to convert."""
    part = tmp_path / "ball.off"
    part.write_text("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    extra = ["-o", tmp_path / "out.stl"] if command == "texture" else []
    r = _texcad(command, part, *extra)
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert "not '.off' files" in lines[0] and ".step / .stp" in lines[0] and "convert it to STL or 3MF" in lines[0]
    assert "not a STEP file" not in lines[0] and "cannot check" not in lines[0]
    assert not (tmp_path / "out.stl").exists()


def test_a_missing_part_is_told_missing(tmp_path):
    r = _texcad("texture", tmp_path / "gone.ply", "-o", tmp_path / "out.stl")
    assert r.returncode == 2 and "part" in r.stderr and "does not exist" in r.stderr and "STEP file" not in r.stderr
