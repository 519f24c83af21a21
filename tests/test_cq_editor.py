"""CQ-editor opens a texcad recipe script, runs it and draws the textured part.

The test starts a virtual X server (Xvfb), runs this file as a launcher in a subprocess
(``python tests/test_cq_editor.py RECIPE OUT_DIR``): it builds CQ-editor's own
``MainWindow`` on the recipe (what ``cq-editor RECIPE`` does), screenshots the window,
triggers the Render action (F5, ``Debugger.render``), screenshots again and writes what
it saw to ``OUT_DIR/result.json``. The test then checks the 3D view: many of its pixels
changed by the render and differ from the view's plain background.

The screenshots are read back from the X server (``QScreen.grabWindow``), so they show
what OCCT's OpenGL view really drew (Mesa's software GLX under Xvfb).
docs/make_cq_editor_screenshot.py reuses :func:`cq_editor_session` for the docs picture.

Needs the ``xvfb`` package and Qt's xcb libraries (.ci/run installs them) and
``cq-editor`` (in the ``test`` and ``preview`` extras). Skipped only without Xvfb.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

XVFB = shutil.which("Xvfb")
HERE = Path(__file__).resolve()
ROOT = HERE.parent.parent

# The recipe CQ-editor runs: a 20 x 20 x 5 mm box, its top face diamond-knurled at
# 0.5 mm pitch, shown as a CadQuery Workplane holding texcad's B-rep.
RECIPE = '''\
from build123d import Axis, Box

import texcad

box = Box(20, 20, 5)
part = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:diamond_knurl", pitch=0.5)
show_object(part.workplane, name="knurled_box")
'''

WINDOW = (1100, 800)  # CQ-editor's window, px


# ------------------------------------------------------------------------------------------
# Xvfb and the CQ-editor subprocess
# ------------------------------------------------------------------------------------------
def _free_display() -> int:
    """A display number with neither an X lock file nor a socket."""
    for n in range(91, 400):
        if not Path(f"/tmp/.X{n}-lock").exists() and not Path(f"/tmp/.X11-unix/X{n}").exists():
            return n
    raise RuntimeError("no free X display number")


def _stop(proc: subprocess.Popen | None) -> None:
    """Terminate ``proc`` (and its process group), then kill it if it lingers."""
    if proc is None or proc.poll() is not None:
        return
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGTERM)
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=5)


@contextlib.contextmanager
def xvfb(size: tuple[int, int] = (1280, 1024)):
    """A running Xvfb; yields its DISPLAY string (e.g. ``":91"``)."""
    for _ in range(5):  # another process may take the number between the check and the start
        n = _free_display()
        proc = subprocess.Popen([XVFB, f":{n}", "-screen", "0", f"{size[0]}x{size[1]}x24", "-nolisten", "tcp"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and proc.poll() is None and not Path(f"/tmp/.X11-unix/X{n}").exists():
            time.sleep(0.05)
        if proc.poll() is None and Path(f"/tmp/.X11-unix/X{n}").exists():
            break
        _stop(proc)
    else:
        raise RuntimeError("Xvfb did not start")
    try:
        yield f":{n}"
    finally:
        _stop(proc)


def run_cq_editor(recipe: Path, out_dir: Path, display: str, timeout: float = 90.0,
                  window: tuple[int, int] = WINDOW) -> dict:
    """Run the launcher (this file) on ``recipe`` in CQ-editor on ``display``; returns
    its result.json (paths of the screenshots, the objects shown, a traceback if any)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    home = out_dir / "home"  # CQ-editor's settings (QSettings) kept out of the user's
    home.mkdir(mode=0o700, exist_ok=True)
    env = dict(os.environ, DISPLAY=display, QT_QPA_PLATFORM="xcb", HOME=str(home),
               XDG_CONFIG_HOME=str(home / ".config"), XDG_RUNTIME_DIR=str(home),
               PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep),
               LIBGL_ALWAYS_SOFTWARE="1")
    log = out_dir / "cq_editor.log"
    with open(log, "wb") as f:
        proc = subprocess.Popen([sys.executable, str(HERE), str(recipe), str(out_dir), f"{window[0]}x{window[1]}"], env=env, cwd=str(out_dir),
                                stdout=f, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            raise AssertionError(f"CQ-editor did not finish in {timeout:.0f} s:\n{log.read_text(errors='replace')[-3000:]}")
        finally:
            _stop(proc)
    result = out_dir / "result.json"
    if not result.exists():
        raise AssertionError(f"CQ-editor exited ({proc.returncode}) without a result:\n"
                             f"{log.read_text(errors='replace')[-3000:]}")
    return json.loads(result.read_text())


@contextlib.contextmanager
def cq_editor_session(work: Path, recipe_text: str = RECIPE, window: tuple[int, int] = WINDOW):
    """Xvfb, the recipe written to ``work/recipe.py`` and CQ-editor run on it; yields
    the launcher's result (see :func:`run_cq_editor`)."""
    recipe = work / "recipe.py"
    recipe.write_text(recipe_text)
    with xvfb() as display:
        yield run_cq_editor(recipe, work / "out", display, window=window)


# ------------------------------------------------------------------------------------------
# Screenshot measures
# ------------------------------------------------------------------------------------------
def view_pixels(result: dict, which: str):
    """The 3D view's pixels in a screenshot (``"before"`` or ``"after"``), int16 RGB."""
    import numpy as np
    from PIL import Image

    x, y, w, h = result["view"]
    img = np.asarray(Image.open(result[which]).convert("RGB"), dtype=np.int16)
    return img[y:y + h, x:x + w]


def changed_fraction(a, b, tol: int = 24) -> float:
    """The fraction of pixels whose colour differs by more than ``tol`` (any channel)."""
    import numpy as np

    return float(np.mean(np.abs(a - b).max(axis=-1) > tol))


def off_background_fraction(view, tol: int = 24) -> float:
    """The fraction of pixels away from the view's background colour (its most common
    colour, the view's corners being empty)."""
    import numpy as np

    flat = view.reshape(-1, 3)
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    bg = colours[np.argmax(counts)]
    return float(np.mean(np.abs(flat - bg).max(axis=-1) > tol))


# ------------------------------------------------------------------------------------------
# The test
# ------------------------------------------------------------------------------------------
def test_cq_editor_runs_a_recipe_and_draws_the_textured_part(tmp_path):
    import pytest

    if XVFB is None:
        pytest.skip("Xvfb is not installed (apt-get install xvfb)")
    t0 = time.monotonic()
    with cq_editor_session(tmp_path) as result:
        pass
    assert result["traceback"] is None, result["traceback"]
    assert result["objects"] == ["knurled_box"]
    before, after = view_pixels(result, "before"), view_pixels(result, "after")
    assert before.shape[0] > 200 and before.shape[1] > 200, result["view"]
    # Before Render the view is empty: (nearly) all background.
    assert off_background_fraction(before) < 0.02
    # After: the part covers a good share of the view (fitted automatically) ...
    assert off_background_fraction(after) > 0.10, off_background_fraction(after)
    assert changed_fraction(before, after) > 0.10
    # ... and is shaded: the knurled top shows many distinct colours, not a flat fill.
    import numpy as np

    drawn = after[np.abs(after - before).max(axis=-1) > 24]
    assert len(np.unique(drawn // 8, axis=0)) > 50
    assert time.monotonic() - t0 < 90


# ------------------------------------------------------------------------------------------
# The launcher: run as a script inside the X session
# ------------------------------------------------------------------------------------------
def _launch(recipe: str, out_dir: str, window: tuple[int, int] = WINDOW, settle_ms: int = 1500,
            render_timeout_s: float = 60.0) -> None:
    """CQ-editor's MainWindow on ``recipe`` (as ``cq-editor RECIPE`` opens it), a
    screenshot, Render (F5), another screenshot; writes ``out_dir/result.json``."""
    from PyQt5.QtCore import Qt, QTimer
    from PyQt5.QtWidgets import QApplication

    # the QApplication before cq_editor's modules, as cq_editor.__main__ does (svg icons)
    app = QApplication([sys.argv[0]], applicationName="CQ-editor")
    from cq_editor.main_window import MainWindow

    out = Path(out_dir)
    result: dict = {"traceback": None, "objects": None}
    win = MainWindow(filename=recipe)
    debugger = win.components["debugger"]
    tree = win.components["object_tree"]

    def on_traceback(exc_info, _code):
        if exc_info is not None:
            import traceback

            result["traceback"] = "".join(traceback.format_exception(*exc_info))

    debugger.sigTraceback.connect(on_traceback)
    debugger.sigRendered.connect(lambda objs: result.__setitem__("objects", list(objs)))
    win.resize(*window)
    win.move(0, 0)
    win.show()
    # the editor wide enough for the recipe's lines, the bottom panes low: a larger 3D view
    win.resizeDocks([win.docks["editor"]], [int(window[0] * 0.36)], Qt.Horizontal)
    win.resizeDocks([win.docks["console"]], [int(window[1] * 0.22)], Qt.Vertical)

    def pump(ms: int) -> None:
        end = time.monotonic() + ms / 1000
        while time.monotonic() < end:
            app.processEvents()
            time.sleep(0.01)

    def grab(name: str) -> str:
        win.viewer.redraw()
        pump(300)
        path = out / f"{name}.png"
        # from the X server: what OCCT's OpenGL view drew, not Qt's widget backing store
        app.primaryScreen().grabWindow(win.winId()).save(str(path))
        return str(path)

    def run() -> None:
        try:
            pump(settle_ms)
            canvas = win.viewer.canvas
            top_left = canvas.mapTo(win, canvas.rect().topLeft())
            result["view"] = [top_left.x(), top_left.y(), canvas.width(), canvas.height()]
            result["before"] = grab("before")
            t = time.monotonic()
            # the Run menu's "Render" action (F5)
            action = next(a for a in debugger.menuActions()["Run"] if a.text() == "Render")
            action.trigger()
            result["render_s"] = round(time.monotonic() - t, 2)
            pump(settle_ms)
            result["objects"] = result["objects"] if result["objects"] is not None else []
            result["after"] = grab("after")
        except Exception:  # written to the result, the test shows it
            import traceback

            result["traceback"] = traceback.format_exc()
        finally:
            (out / "result.json").write_text(json.dumps(result, indent=1))
            win.components["editor"].document().setModified(False)  # no "save changes?" dialog
            app.exit(0)

    QTimer.singleShot(0, run)
    QTimer.singleShot(int(render_timeout_s * 1000), lambda: app.exit(3))
    app.exec_()


if __name__ == "__main__":
    _launch(sys.argv[1], sys.argv[2], tuple(int(v) for v in sys.argv[3].split("x")) if len(sys.argv) > 3 else WINDOW)
