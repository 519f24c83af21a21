import subprocess
import sys

import trimesh

import texcad

from texcad.cli import main
from conftest import assert_heightmap_picture, assert_picture


def test_textures_lists_names_first(capsys):
    assert main(["textures"]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    assert len(lines) >= 3
    assert lines[0].split()[0] == "stones"


def test_demo_grows_a_sample_and_writes_files(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--size", "20", "--pitch", "0.5"]) == 0
    out = capsys.readouterr()
    assert_picture(tmp_path / "demo.png")
    for f in ("demo_heightmap.png", "demo_sample.png"):
        assert_heightmap_picture(tmp_path / f)
    (_, m3), = texcad.io.read_part(tmp_path / "demo.3mf")
    assert m3.is_watertight
    assert "watertight   True" in out.out and "triangles" in out.out and "seconds" in out.out
    assert "synthesized  40 x 40 px" in out.out  # grown from the 20 mm (40 px) sample
    assert "%]" in out.err  # progress lines
    stl = trimesh.load(tmp_path / "demo.stl")
    assert stl.is_watertight and stl.body_count == 1
    assert abs(m3.volume - stl.volume) < 1e-6 * stl.volume
    step = texcad.load_mesh(tmp_path / "demo.step")
    assert abs(step.volume - stl.volume) < 1e-3 * stl.volume


def test_demo_is_reproducible_and_can_skip_step(tmp_path, capsys):
    args = ["demo", "--size", "20", "--pitch", "0.5", "--no-step", "--texture", "leather"]
    assert main(args + ["--out", str(tmp_path / "a")]) == 0
    assert main(args + ["--out", str(tmp_path / "b")]) == 0
    assert not (tmp_path / "a" / "demo.step").exists()
    for f in ("demo.stl", "demo.3mf", "demo.png"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


def test_errors_are_one_line_without_traceback(tmp_path):
    r = subprocess.run(
        [sys.executable, "-m", "texcad", "demo", "--out", str(tmp_path), "--texture", "nope"],
        capture_output=True,
        text=True,
    )
    assert r.returncode != 0
    assert "Traceback" not in r.stderr
    assert r.stderr.strip().splitlines()[-1].startswith("texcad: error: unknown built-in texture 'nope'")
    assert not (tmp_path / "demo.stl").exists()


def test_a_closed_pipe_ends_quietly():
    """``texcad textures | head -0``: the reader is gone before texcad writes; no
    traceback, exit 141 (128 + SIGPIPE) as shell tools do."""
    p = subprocess.Popen([sys.executable, "-m", "texcad", "textures"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()  # before the child has imported anything
    err = p.stderr.read().decode()
    assert p.wait(timeout=120) == 141 and "Traceback" not in err and "BrokenPipe" not in err, err


def test_help_lists_every_command():
    r = subprocess.run([sys.executable, "-m", "texcad", "--help"], capture_output=True, text=True)
    for cmd in ("demo", "textures"):
        assert cmd in r.stdout


def test_scan_command_turns_points_into_png(tmp_path, capsys):
    import numpy as np

    import texcad

    rng = np.random.default_rng(0)
    xy = rng.uniform(0, 20, (40000, 2))
    z = 0.5 * np.sin(xy[:, 0]) * np.cos(xy[:, 1]) + 0.05 * xy[:, 0]  # relief on a tilted plane
    np.savetxt(tmp_path / "scan.xyz", np.column_stack([xy, z]), fmt="%.5f")
    out = tmp_path / "scan.png"
    assert main(["scan", str(tmp_path / "scan.xyz"), "-o", str(out), "--pitch", "0.5"]) == 0
    assert "noise" in capsys.readouterr().out
    hm = texcad.Heightmap.from_image(out, pitch=0.5, height=1.0)
    assert min(hm.shape) > 30


def test_textures_contact_sheet(tmp_path, capsys):
    assert main(["textures", "--sheet", str(tmp_path / "sheet.png")]) == 0
    img = assert_picture(tmp_path / "sheet.png", min_part=0.3)
    assert img.shape[1] > 5 * 200  # five columns of 200 px pictures


def test_make_and_texture_take_a_build_direction(tmp_path, capsys):
    d = "0.866,0,0.5"  # tilted 60 deg, +x rising
    common = ["make", "--surface", "arc", "--texture", "builtin:sand", "--mapping", "angle", "--pitch", "1"]
    assert main(common + ["-o", str(tmp_path / "free.stl")]) == 0
    assert "overhangs" not in capsys.readouterr().out
    assert main(common + ["--build-dir", d, "-o", str(tmp_path / "limited.stl")]) == 0
    out = capsys.readouterr().out
    assert "overhangs    limited to 45 deg for 1 direction(s)" in out and "0.00 mm2 still overhanging" in out
    free = texcad.check(tmp_path / "free.stl", build_dir=(0.866, 0, 0.5)).overhang_area_mm2
    limited = texcad.check(tmp_path / "limited.stl", build_dir=(0.866, 0, 0.5)).overhang_area_mm2
    assert limited < free - 100  # the texture's overhangs are gone; the shell's underside remains

    from build123d import Box, export_step

    export_step(Box(20, 20, 5), str(tmp_path / "box.step"))
    argv = ["texture", str(tmp_path / "box.step"), "--pitch", "0.5", "--build-dir", "0,1,1", "-o", str(tmp_path / "b.3mf")]
    assert main(argv + ["--separate-texture", "-q"]) == 0
    assert "overhangs    limited" in capsys.readouterr().out
    # the 3MF is placed as printed: (0, 1, 1) is +z there
    assert texcad.check(tmp_path / "b.3mf", build_dir=(0, 0, 1)).texture_overhang_area_mm2 == 0.0


def test_make_takes_a_tolerance(tmp_path, capsys):
    """``texcad make --tolerance``: 0 keeps one vertex per pixel, 0.05 mm a lean mesh
    whose measured 3-D error (printed) is within it; both watertight."""
    common = ["make", "--surface", "cylinder", "--radius", "8", "--length", "10", "--texture", "builtin:stones",
              "--height", "1", "--mapping", "angle", "--pitch", "0.25"]
    tris, errs = {}, {}
    for tol in ("0", "0.05"):
        assert main(common + ["--tolerance", tol, "-o", str(tmp_path / f"c{tol}.stl")]) == 0
        out = capsys.readouterr().out
        line = next(x for x in out.splitlines() if x.startswith("max error"))
        errs[tol] = float(line.split()[2])
        m = trimesh.load(tmp_path / f"c{tol}.stl")
        assert m.is_watertight
        tris[tol] = len(m.faces)
    assert errs["0"] == 0.0 and 0 < errs["0.05"] <= 0.05
    assert tris["0.05"] < 0.5 * tris["0"]


def test_texturing_a_mesh_file_loads_no_cad_library(tmp_path):
    """``texcad texture PART.stl`` is a mesh job: build123d, OCP and CadQuery (3 s to
    import) stay unloaded, and the 3MF it writes is watertight."""
    import manifold3d as m3d

    from texcad.io import write_stl
    from texcad.solid import Mesh

    g = (m3d.Manifold.cylinder(12.0, 8.0, 8.0, 48)).to_mesh()
    write_stl(Mesh(g.vert_properties[:, :3], g.tri_verts), tmp_path / "part.stl")
    out = tmp_path / "part.3mf"
    code = (
        "import sys; from texcad.cli import main; "
        f"rc = main(['texture', {str(tmp_path / 'part.stl')!r}, '--pitch', '1', '-q', '-o', {str(out)!r}]); "
        "print(rc, sorted(m for m in ('build123d', 'OCP', 'cadquery') if m in sys.modules))"
    )
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert r.stdout.strip().splitlines()[-1] == "0 []"
    m = texcad.io.read_mesh(out)
    assert trimesh.Trimesh(m.vertices, m.faces, process=False).is_watertight
