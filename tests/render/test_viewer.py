"""``texcad.show`` against the standalone OCP CAD viewer in headless Chromium (issue 6).

The viewer is ``ocp_viewer`` (``python -m ocp_viewer --port P``): since ocp_vscode 4.x
the standalone viewer lives in that package, and ``python -m ocp_vscode`` only prints
where it went. Both speak ocp_viewer_core's websocket protocol, so ``ocp_vscode.show``
(which :func:`texcad.show` calls) draws in it when given its port.

The test starts the viewer on a free localhost port, opens its page in headless
Chromium (driven over the DevTools protocol with ``websockets``, which the viewer
already depends on: no browser download, no driver), screenshots the empty viewer
(the splash logo on a grid), calls ``texcad.show(part, port=P)`` on a small textured
box and screenshots again. It asserts, on the pixels of the 3D viewport (toolbar and
object tree left out), that the model is there: the area covered by the viewer's
face colour (violet, where texcad's display mesh is drawn) goes from ~0 to a large
part of the viewport, the non-background area grows by a clear margin, and the
textured top face shows relief (shades that the flat faces of the same box, shown
just before, do not have).

``docs/make_viewer_screenshot.py`` runs the same session and keeps ``docs/viewer.png``.
"""

from __future__ import annotations

import base64
import contextlib
import io
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from typing import Iterator

import numpy as np

import texcad
import ocp_vscode  # noqa: F401  (imported here: on import it resets the filter of its camera warning)
import pytest

CHROMIUM = next(
    (p for p in (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")) if p), None
)
WIDTH, HEIGHT = 1000, 700  # CSS px of the browser viewport, device scale 1
# The 3D viewport without the viewer's overlays: the toolbar (top ~50 px), the object
# tree and info panel (left ~255 px) and the axes triad (bottom left) are left out.
VIEWPORT = (slice(60, HEIGHT - 10), slice(270, WIDTH - 10))  # rows, cols of a screenshot


# ------------------------------------------------------------------------------------------
# The standalone viewer
# ------------------------------------------------------------------------------------------
def free_port() -> int:
    """A TCP port nothing listens on at the moment, on 127.0.0.1."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait(condition, timeout: float, what: str, proc: subprocess.Popen | None = None, log: Path | None = None):
    """Poll ``condition()`` every 50 ms until it is truthy; fail naming ``what`` (and
    the process's log) after ``timeout`` seconds or when ``proc`` has exited."""
    end = time.monotonic() + timeout
    while True:
        value = condition()
        if value:
            return value
        if proc is not None and proc.poll() is not None:
            break
        if time.monotonic() > end:
            break
        time.sleep(0.05)
    text = log.read_text(errors="replace")[-2000:] if log is not None and log.exists() else ""
    raise AssertionError(f"timed out after {timeout} s waiting for {what}\n{text}")


def _stop(proc: subprocess.Popen, sig: int) -> None:
    """End ``proc`` (one we started) with ``sig``, then SIGKILL after 5 s."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError):
            proc.send_signal(sig)
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


@contextlib.contextmanager
def ocp_viewer(workdir: Path) -> Iterator[tuple[int, Path]]:
    """Run ``python -m ocp_viewer`` on a free port; yields ``(port, log path)``.

    HOME is ``workdir``, so the viewer's port registry (``~/.ocpvscode``) and config
    file stay out of the user's home, and stopping it with SIGTERM (SIGINT may be
    ignored by a process started in the background) leaves nothing stale behind.
    """
    home = workdir / "home"
    home.mkdir(parents=True, exist_ok=True)
    log = workdir / "ocp_viewer.log"
    port = free_port()
    env = dict(os.environ, HOME=str(home), PYTHONUNBUFFERED="1")
    with open(log, "wb") as out:
        proc = subprocess.Popen(
            [sys.executable, "-m", "ocp_viewer", "--host", "127.0.0.1", "--port", str(port)],
            stdout=out, stderr=subprocess.STDOUT, env=env, cwd=workdir,
        )
    try:
        _wait(lambda: "runs at" in log.read_text(errors="replace"), 30, "ocp_viewer to start", proc, log)
        yield port, log
    finally:
        _stop(proc, signal.SIGTERM)


# ------------------------------------------------------------------------------------------
# Headless Chromium over the DevTools protocol
# ------------------------------------------------------------------------------------------
class Page:
    """One browser tab, driven with DevTools protocol calls over a websocket."""

    def __init__(self, ws) -> None:
        self._ws = ws
        self._id = 0

    def call(self, method: str, **params):
        """Send one DevTools command and return its result (events are skipped)."""
        self._id += 1
        self._ws.send(json.dumps({"id": self._id, "method": method, "params": params}))
        while True:
            msg = json.loads(self._ws.recv(timeout=30))
            if msg.get("id") == self._id:
                if "error" in msg:
                    raise RuntimeError(f"{method}: {msg['error']}")
                return msg["result"]

    def screenshot(self) -> bytes:
        """The viewport as PNG bytes."""
        return base64.b64decode(self.call("Page.captureScreenshot", format="png")["data"])

    def settled_screenshot(self, unlike: bytes | None = None, until=None, timeout: float = 20.0) -> bytes:
        """A screenshot once the page has stopped changing: three identical
        screenshots in a row, 0.2 s apart, that differ from ``unlike`` and for which
        ``until(png)`` (if given) is true."""
        end = time.monotonic() + timeout
        last, same = b"", 0
        while time.monotonic() < end:
            shot = self.screenshot()
            ok = shot == last and shot != unlike and (until is None or until(shot))
            same = same + 1 if ok else 0
            if same >= 2:
                return shot
            last = shot
            time.sleep(0.2)
        what = "changed and settled" if unlike is not None else "settled"
        raise AssertionError(f"the viewer page had not {what} within {timeout} s (nothing shown?)")


@contextlib.contextmanager
def chromium_page(workdir: Path) -> Iterator[Page]:
    """Headless Chromium with a fresh profile in ``workdir``; yields its tab.

    WebGL runs on SwiftShader (software), since the machine has no GPU. Network
    features that call home are off (the machine's network is closed).
    """
    from websockets.sync.client import connect

    profile = workdir / "chromium-profile"
    profile.mkdir(parents=True, exist_ok=True)
    log = workdir / "chromium.log"
    args = [
        CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        "--disable-extensions", "--hide-scrollbars", "--mute-audio",
        "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
        f"--user-data-dir={profile}", "--remote-debugging-port=0", f"--window-size={WIDTH},{HEIGHT}",
        "about:blank",
    ]
    with open(log, "wb") as out:
        proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        active = profile / "DevToolsActivePort"
        _wait(lambda: active.exists() and active.read_text().strip(), 30, "Chromium's DevTools port", proc, log)
        port = int(active.read_text().split()[0])
        direct = urllib.request.build_opener(urllib.request.ProxyHandler({}))  # localhost: never a proxy
        with direct.open(f"http://127.0.0.1:{port}/json/list", timeout=10) as r:
            tabs = json.load(r)
        url = next(t["webSocketDebuggerUrl"] for t in tabs if t["type"] == "page")
        with connect(url, max_size=None, open_timeout=10, proxy=None) as ws:
            page = Page(ws)
            page.call(
                "Emulation.setDeviceMetricsOverride", width=WIDTH, height=HEIGHT, deviceScaleFactor=1, mobile=False
            )
            yield page
    finally:
        # The whole session (renderer, GPU and utility processes), started by us.
        if proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)
            try:
                proc.wait(5)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(5)


@contextlib.contextmanager
def viewer_session(workdir: Path) -> Iterator[tuple[int, Page]]:
    """The viewer and a headless Chromium tab showing it, the browser registered
    with the viewer and the splash screen drawn; yields ``(port, page)``."""
    with ocp_viewer(workdir) as (port, log), chromium_page(workdir) as page:
        page.call("Page.navigate", url=f"http://127.0.0.1:{port}/viewer")
        _wait(lambda: "Browser as viewer client registered" in log.read_text(errors="replace"), 30,
              "the page to connect to the viewer", log=log)
        yield port, page


def drawn(png: bytes) -> bool:
    """Whether the viewport holds a drawing (the splash logo or a model): over 1 % of
    its pixels are off its most frequent colour."""
    return measures(png, background_of(png))["not_background"] > 0.01


# ------------------------------------------------------------------------------------------
# Pixels
# ------------------------------------------------------------------------------------------
def rgb(png: bytes) -> np.ndarray:
    """``(H, W, 3)`` int16 RGB of a PNG screenshot."""
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.int16)


def measures(png: bytes, background: np.ndarray) -> dict[str, float]:
    """Three fractions of the 3D viewport (:data:`VIEWPORT`): pixels that are not
    ``background`` (any channel off by more than 16); violet pixels (the viewer's face
    colour, in which the display mesh is drawn: R and B both above G by 40 or more);
    and, of the violet pixels, those whose luminance is more than 4 levels (of 255)
    from their median: the shading that relief makes (a flat face is one shade)."""
    img = rgb(png)[VIEWPORT]
    not_bg = np.abs(img - background).max(axis=2) > 16
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    violet = (r - g >= 40) & (b - g >= 40)
    lum = (0.299 * r + 0.587 * g + 0.114 * b)[violet]
    relief = float((np.abs(lum - np.median(lum)) > 4).mean()) if lum.size else 0.0
    return {"not_background": float(not_bg.mean()), "violet": float(violet.mean()), "relief": relief}


def background_of(png: bytes) -> np.ndarray:
    """The most frequent colour of the viewport: the viewer's background."""
    img = rgb(png)[VIEWPORT].reshape(-1, 3)
    colours, counts = np.unique(img, axis=0, return_counts=True)
    return colours[np.argmax(counts)]


def small_textured_box():
    """A 20 x 20 x 5 mm box, its top face knurled at 0.5 mm pitch (mesh only), and
    the plain box."""
    from build123d import Axis, Box

    import texcad

    box = Box(20, 20, 5)
    part = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:diamond_knurl", pitch=0.5, brep=False)
    return part, box


# ------------------------------------------------------------------------------------------
# The test
# ------------------------------------------------------------------------------------------
# ocp_vscode warns that the camera is kept between shows (wanted here); ocp_tessellate
# warns when it normalises the zero normal of a zero-area triangle of the display mesh.
@pytest.mark.filterwarnings("ignore:reset_camera")
@pytest.mark.filterwarnings("ignore:invalid value encountered in divide:RuntimeWarning")
@pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (apt-get install chromium)")
def test_show_draws_the_part_in_the_standalone_viewer(tmp_path):
    import texcad

    part, box = small_textured_box()
    with viewer_session(tmp_path) as (port, page):
        empty = page.settled_screenshot(until=drawn)  # the splash screen
        texcad.show(box.faces(), port=port)  # faces are drawn in the face colour too
        plain = page.settled_screenshot(unlike=empty)
        texcad.show(part, port=port)
        shown = page.settled_screenshot(unlike=plain)
    for name, png in (("empty", empty), ("plain", plain), ("textured", shown)):
        (tmp_path / f"viewer_{name}.png").write_bytes(png)

    bg = background_of(empty)
    e, p, s = (measures(x, bg) for x in (empty, plain, shown))
    print(f"\nviewer port {port}; empty {e}; plain box {p}; textured {s}; screenshots in {tmp_path}")
    assert rgb(shown).shape == (HEIGHT, WIDTH, 3)
    # Empty viewer: the splash logo (blue, black) on a grid, no violet.
    assert e["violet"] < 0.005, e
    # The part: a large violet area, much more of the viewport covered than before.
    assert s["violet"] > 0.15, s
    assert s["not_background"] > e["not_background"] + 0.10, (e, s)
    # The texture: its relief shades the top face; the plain box's faces are flat.
    assert s["relief"] > 0.02 and s["relief"] > 5 * p["relief"], (p, s)


def test_a_picture_of_a_textured_part_shows_its_texture(tmp_path):
    """A box textured on its bottom face is seen from below (texture_view picks the
    mirror image of the usual view that sees the texture), a knurled cylinder from the
    usual view; the picture shows relief: its texture faces cover a large share of it."""
    from build123d import Axis, Box, Cylinder

    from texcad.render import DEFAULT_VIEW, render_mesh, texture_view
    from texcad.solid import shared_faces

    box = Box(20, 20, 4)
    under = texcad.texture(box, box.faces().sort_by(Axis.Z)[0], "builtin:stones", height=0.5, pitch=0.5)
    view = texture_view(under.mesh, under.base_mesh)
    assert view[2] > 0 and np.allclose(np.abs(view), np.abs(DEFAULT_VIEW))  # looking up at it
    img, info = render_mesh(under.mesh, view=view, width=300, return_info=True)
    tex = ~shared_faces(under.mesh, under.base_mesh)[0]
    hit = info["face"][info["face"] >= 0]
    assert tex[hit].mean() > 0.5  # most of what the picture shows is texture
    _, usual = render_mesh(under.mesh, view=DEFAULT_VIEW, width=300, return_info=True)
    assert tex[usual["face"][usual["face"] >= 0]].mean() < 0.05  # the usual view would show none

    cyl = Cylinder(8, 20)
    knurled = texcad.texture(cyl, cyl.faces().filter_by(lambda f: f.geom_type.name == "CYLINDER")[0],
                             "builtin:diamond_knurl", height=0.4, pitch=0.5)
    assert texture_view(knurled.mesh, knurled.base_mesh) == tuple(DEFAULT_VIEW)
    from PIL import Image

    grey = np.asarray(Image.open(under.render(tmp_path / "under.png", width=300)).convert("L")) / 255.0
    assert grey[grey < 0.99].mean() > 0.5  # turned over and lit from the camera's side (0.41 lit from above)
