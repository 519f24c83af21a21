"""Make docs/cq_editor.png: a texcad recipe opened in CQ-editor and rendered (F5).

Runs the session of tests/test_cq_editor.py (same launcher, Xvfb and recipe: a 20 x 20 x
5 mm box, its top face diamond-knurled at 0.5 mm pitch, ``show_object(part.workplane)``)
in a larger window and keeps the screenshot taken after Render. Needs Xvfb
(``apt-get install xvfb``), Qt's xcb libraries and ``pip install -e ".[preview]"``.

    python docs/make_cq_editor_screenshot.py [OUT.png]
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from _figure import load_test  # noqa: E402


def main(out: Path = HERE / "cq_editor.png") -> Path:
    from PIL import Image

    tc = load_test("test_cq_editor.py")
    if tc.XVFB is None:
        raise SystemExit("Xvfb is not installed: apt-get install xvfb")
    with tempfile.TemporaryDirectory() as tmp, tc.cq_editor_session(Path(tmp), window=(1280, 860)) as result:
        if result["traceback"]:
            raise SystemExit(result["traceback"])
        Image.open(result["after"]).convert("RGB").save(out, optimize=True)
    print(f"{out} (render {result['render_s']} s)")
    return out


if __name__ == "__main__":
    main(*(Path(a) for a in sys.argv[1:2]))
