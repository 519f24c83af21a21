"""The command line as a user reads it on real parts (session 9, real files)."""

import subprocess
import sys
import warnings

from texcad.errors import TexcadWarning


def test_warnings_print_on_one_line_without_the_library_source(tmp_path):
    """A warning on the command line read '/.../texcad/pipeline/driver.py:62:
    TexcadWarning: ...' followed by a line of texcad's source; now 'texcad: warning: ...'."""
    from build123d import Box, Compound, Pos, export_step

    export_step(Compound([Box(10, 10, 5), Pos(9, 0, 0) * Box(10, 10, 5)]), str(tmp_path / "two.step"))
    r = subprocess.run([sys.executable, "-m", "texcad", "texture", str(tmp_path / "two.step"), "--face", "4",
                        "--pitch", "0.5", "-o", str(tmp_path / "out.stl")], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = [s for s in r.stderr.splitlines() if not s.startswith("[")]  # progress lines aside
    assert lines and lines[0].startswith("texcad: warning: the assembly's solids meet"), r.stderr
    assert not any(".py:" in s or "TexcadWarning" in s or s.startswith("  ") for s in lines), r.stderr


def test_other_warnings_and_recorders_are_left_as_they_were():
    from texcad.cli import _one_line_warnings

    before = warnings.formatwarning  # Python's, or what another library put there
    other = before(UserWarning("y"), UserWarning, "f.py", 1)
    with _one_line_warnings():
        assert warnings.formatwarning(TexcadWarning("x"), TexcadWarning, "f.py", 1) == "texcad: warning: x\n"
        assert warnings.formatwarning(UserWarning("y"), UserWarning, "f.py", 1) == other
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            warnings.warn("z", TexcadWarning)
        assert [str(w.message) for w in seen] == ["z"]
    assert warnings.formatwarning is before


def test_faces_of_a_mesh_describe_it_as_texture_reads_it(tmp_path):
    """An STL written inside out (all normals inward): texcad faces said 'top' was at
    z = -10 (the bottom, by the raw normals) while texcad texture --region top repairs
    the winding first and textures the real top (session 10)."""
    import trimesh

    box = trimesh.creation.box((20, 20, 20))
    box.invert()
    box.export(tmp_path / "inv.stl")
    r = subprocess.run([sys.executable, "-m", "texcad", "faces", str(tmp_path / "inv.stl")], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    top = next(s for s in r.stdout.splitlines() if s.startswith("top "))
    assert top.rstrip().endswith(" 10.000)"), r.stdout
    (tmp_path / "open.stl").write_text("solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                        "vertex 0 1 0\nendloop\nendfacet\nendsolid x\n")
    r = subprocess.run([sys.executable, "-m", "texcad", "faces", str(tmp_path / "open.stl")], capture_output=True,
                       text=True, timeout=300)
    assert r.returncode == 0 and "triangles    1 of" in r.stdout, r.stderr  # an open mesh: listed as read
