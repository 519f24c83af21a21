"""Make docs/viewer.png: a textured part shown with ``texcad.show`` in the standalone
OCP CAD viewer (``ocp_viewer``), screenshotted in headless Chromium.

Runs the session of tests/test_viewer.py (same viewer, browser and part: a 20 x 20 x
5 mm box, its top face diamond-knurled at 0.5 mm pitch) and keeps the screenshot.
Needs Chromium (``apt-get install chromium``) and ``pip install ocp_viewer``.

    python docs/make_viewer_screenshot.py [OUT.png]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import texcad

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _figure import load_test  # noqa: E402


def main(out: Path = HERE / "viewer.png") -> Path:
    tv = load_test("render/test_viewer.py")
    if tv.CHROMIUM is None:
        raise SystemExit("Chromium is not installed: apt-get install chromium")
    part, _ = tv.small_textured_box()
    with tempfile.TemporaryDirectory() as tmp, tv.viewer_session(Path(tmp)) as (port, page):
        empty = page.settled_screenshot(until=tv.drawn)
        texcad.show(part, port=port)
        png = page.settled_screenshot(unlike=empty)
    out.write_bytes(png)
    print(f"wrote {out} ({len(png) / 1024:.0f} KiB)")
    return out


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE / "viewer.png")
