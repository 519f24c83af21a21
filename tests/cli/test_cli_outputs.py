"""The CLI's outputs, signals and refusals (issue 27): several ``-o`` all or none,
unwritable folders, SIGTERM / SIGHUP leave no temporary file, options that do not
apply are refused, ``--view -1,2,-0.5`` without ``=``, a render too wide for memory."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
import trimesh

import texcad
from texcad.cli import main
from texcad.util import atomic_path


def _box_stl(tmp_path, name="box.stl"):
    p = tmp_path / name
    trimesh.creation.box((20.0, 20.0, 10.0)).export(p)
    return p


def _one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert err and err[-1].startswith("texcad: error: ") and "Traceback" not in "\n".join(err)
    return err[-1]


def test_view_takes_negative_numbers_without_equals(tmp_path, capsys):
    stl = _box_stl(tmp_path)
    out = tmp_path / "v.png"
    assert main(["render", str(stl), "-o", str(out), "--width", "120", "--view", "-1,2,-0.5", "--up", "0,0,1"]) == 0
    assert out.stat().st_size > 0


def test_build_dir_takes_a_negative_axis_word_without_equals(tmp_path, capsys):
    """``--build-dir -y`` (a user's first try) is the direction -y, not an unknown
    option: the check counts the box's downward face as overhang for -y only."""
    stl = _box_stl(tmp_path)
    assert main(["check", str(stl), "--build-dir", "-y"]) in (0, 1)
    down = capsys.readouterr().out
    assert main(["check", str(stl), "--build-dir=-y"]) in (0, 1)
    assert capsys.readouterr().out == down and "overhang" in down


def test_render_too_wide_names_a_width_that_fits(tmp_path, capsys):
    stl = _box_stl(tmp_path)
    assert main(["render", str(stl), "-o", str(tmp_path / "w.png"), "--width", "200000"]) == 2
    line = _one_line_error(capsys)
    assert "GiB" in line and "--width" in line
    fit = int(line.split("use --width ")[1].split()[0])
    assert 0 < fit < 200000
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob(".*"))


def test_max_memory_bounds_the_job_and_names_a_pitch_that_fits(tmp_path, capsys):
    """``--max-memory`` (the API's max_memory): a job too large for it is refused up
    front in one line naming a pitch, and that pitch then works under the same bound."""
    from texcad.util.resources import _rss

    stl = _box_stl(tmp_path)
    out = tmp_path / "m.stl"
    bound = f"{int(_rss() / 2**20) + 300}MB"  # 300 MB above what this process already holds (a test worker holds more)
    args = ["texture", str(stl), "-o", str(out), "--quiet", "--max-memory", bound]
    assert main(args + ["--pitch", "0.0005"]) == 2
    line = _one_line_error(capsys)
    pitch = float(line.split("use a pitch of at least ")[1].split()[0])
    assert not out.exists() and 0.0005 < pitch < 1.0
    assert main(args + ["--pitch", str(max(pitch, 0.3))]) == 0 and out.stat().st_size > 0
    assert main(["texture", str(stl), "-o", str(out), "--max-memory", "lots"]) == 2
    assert "4GB" in _one_line_error(capsys)


def test_an_output_folder_that_is_missing_fails_before_any_work(tmp_path, capsys):
    stl = _box_stl(tmp_path)
    a = tmp_path / "a.stl"
    t0 = time.perf_counter()
    rc = main(["texture", str(stl), "--texture", "builtin:ridges", "-o", str(a), "-o", str(tmp_path / "nodir" / "b.stl"), "-q"])
    assert rc == 2 and time.perf_counter() - t0 < 30
    assert "nodir" in _one_line_error(capsys)
    assert not a.exists()


def test_an_unwritable_folder_is_one_line(tmp_path, capsys):
    stl = _box_stl(tmp_path)
    # /proc takes no new files, not even from root (for whom os.access says yes)
    assert main(["render", str(stl), "-o", "/proc/texcad-test.png", "--width", "100"]) == 2
    assert "/proc" in _one_line_error(capsys)


def test_several_outputs_are_all_written(tmp_path, capsys):
    stl = _box_stl(tmp_path)
    outs = [tmp_path / "x.stl", tmp_path / "x.3mf"]
    args = ["texture", str(stl), "--texture", "builtin:ridges", "--pitch", "2", "--height", "0.5", "-q", "--separate-texture"]
    assert main(args + sum([["-o", str(o)] for o in outs], [])) == 0
    assert all(o.stat().st_size > 0 for o in outs)
    assert len(texcad.io.read_part(outs[1])) == 2  # base and texture as parts
    assert sorted(p.name for p in tmp_path.iterdir()) == ["box.stl", "x.3mf", "x.stl"]  # no temporaries


def test_options_that_do_not_apply_are_refused(tmp_path, capsys):
    stl = _box_stl(tmp_path)
    assert main(["texture", str(stl), "--face", "cylinder", "-o", str(tmp_path / "o.stl")]) == 2
    line = _one_line_error(capsys)
    assert "--face cylinder" in line and "box.stl" in line and "top, bottom" in line
    step = tmp_path / "part.step"
    step.write_text("not read: the refusal comes first")
    assert main(["texture", str(step), "--region", "all", "-o", str(tmp_path / "o.stl")]) == 2
    line = _one_line_error(capsys)
    assert "--region" in line and "part.step" in line
    assert main(["texture", str(step), "--union", "-o", str(tmp_path / "o.stl")]) == 2
    assert "--union" in _one_line_error(capsys)
    assert not (tmp_path / "o.stl").exists()


_SLOW_WRITE = r"""
import os, signal, sys, time
from pathlib import Path
import texcad.cli.textures as cmd
from texcad.cli import main
from texcad.util import atomic_path

# a job started in the background of a non-interactive shell (as a CI script may be)
# inherits SIGINT ignored, and Python then installs no KeyboardInterrupt handler
signal.signal(signal.SIGINT, signal.default_int_handler)

def run(args):
    with atomic_path(Path(sys.argv[1]) / "out.stl") as tmp:
        Path(tmp).write_bytes(b"half")
        os.kill(os.getpid(), getattr(signal, sys.argv[2]))
        time.sleep(30)
    return 0

cmd.run = run
sys.exit(main(["textures"]))
"""


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGHUP", "SIGINT"])
def test_signals_leave_no_partial_file(tmp_path, sig):
    script = tmp_path / "slow.py"
    script.write_text(_SLOW_WRITE)
    folder = tmp_path / "out"
    folder.mkdir()
    r = subprocess.run([sys.executable, str(script), str(folder), sig], capture_output=True, text=True, timeout=60)
    signum = int(getattr(signal, sig))
    assert r.returncode == (130 if sig == "SIGINT" else 128 + signum), r.stderr
    assert "Traceback" not in r.stderr
    assert list(folder.iterdir()) == []


_STUCK_IN_C = r"""
import ctypes, os, signal, sys, threading
from pathlib import Path
import texcad.cli.textures as cmd
from texcad.cli import main
from texcad.util import atomic_path

def run(args):
    with atomic_path(Path(sys.argv[1]) / "out.step") as tmp:
        Path(tmp).write_bytes(b"half")
        threading.Timer(0.5, os.kill, (os.getpid(), getattr(signal, sys.argv[2]))).start()
        # native code that runs on through signals, as OCCT's mesher does (system() waits again when
        # interrupted); the sleep holds none of our pipes, so the test sees our exit, not the sleep's
        ctypes.CDLL(None).system(b"exec sleep 20 </dev/null >/dev/null 2>&1")
    return 0

cmd.run = run
sys.exit(main(["textures"]))
"""


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGHUP"])
def test_signals_stop_a_command_inside_native_code(tmp_path, sig):
    """A signal that arrives while the main thread runs native code for long (no
    Python handler can run there) ends the command within the grace period, with
    the exit status and one line of a handled one, and no temporary output left."""
    import time

    from texcad.cli._signals import GRACE

    script = tmp_path / "stuck.py"
    script.write_text(_STUCK_IN_C)
    folder = tmp_path / "out"
    folder.mkdir()
    t = time.monotonic()
    r = subprocess.run([sys.executable, str(script), str(folder), sig], capture_output=True, text=True, timeout=60)
    assert time.monotonic() - t < 15 < 20  # not the native call's 20 s
    assert r.returncode == 128 + int(getattr(signal, sig)), r.stderr
    assert r.stderr.strip().splitlines() == [f"texcad: terminated by signal {int(getattr(signal, sig))}; no output was left half-written"]
    assert GRACE <= 5 and list(folder.iterdir()) == []


def test_signal_handlers_are_put_back():
    before = signal.getsignal(signal.SIGTERM)
    assert main(["textures"]) == 0
    assert signal.getsignal(signal.SIGTERM) is before


def test_a_write_that_fails_leaves_no_file(tmp_path):
    with pytest.raises(RuntimeError):
        with atomic_path(tmp_path / "f.stl") as tmp:
            open(tmp, "wb").write(b"x")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []
    os.chmod(tmp_path, 0o755)


def test_an_image_texture_on_a_mesh_takes_its_tile_size(tmp_path, capsys):
    import numpy as np
    from PIL import Image

    img = tmp_path / "tex.png"
    Image.fromarray((np.indices((64, 64)).sum(0) % 16 * 16).astype(np.uint8)).save(img)
    ball = tmp_path / "ball.stl"
    trimesh.creation.icosphere(3, radius=10.0).export(ball)
    out = tmp_path / "ballt.stl"
    base = ["texture", str(ball), "--texture", str(img), "--pitch", "2", "--height", "0.5", "-q", "-o", str(out)]
    assert main(base) == 2 and "size" in _one_line_error(capsys)
    assert main(base + ["--size", "10,10"]) == 0
    m = texcad.io.read_mesh(out)
    assert m.is_watertight and m.volume > trimesh.creation.icosphere(3, radius=10.0).volume
    with pytest.raises(SystemExit):
        main(base + ["--size", "10,-1"])


def test_a_mesh_with_a_small_crossing_is_repaired_and_says_so(tmp_path, capsys):
    """A mesh whose triangles cross a little (3DBenchy's case) is textured, and the
    summary says what was repaired."""
    import numpy as np

    b = trimesh.creation.box((10.0, 10.0, 10.0)).subdivide().subdivide().subdivide()
    v, f = np.array(b.vertices), np.array(b.faces)
    top = np.flatnonzero(np.isclose(v[:, 2], 5.0))
    v[top[np.argmin(np.linalg.norm(v[top, :2] - (1.25, 1.25), axis=1))], 2] = -5.3  # a spike 0.3 mm through the bottom
    stl = tmp_path / "spiked.stl"
    trimesh.Trimesh(v, f, process=False).export(stl)
    out = tmp_path / "out.stl"
    assert main(["texture", str(stl), "--region", "normal:+x:10", "--texture", "builtin:ridges", "--pitch", "1",
                 "--height", "0.5", "-q", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "repaired     8 pairs of crossing triangles resolved by a self-union" in text
    assert out.stat().st_size > 0
