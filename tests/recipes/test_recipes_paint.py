"""recipes/paint_grip.py runs as a plain script, coarse."""

import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

from conftest import assert_picture

RECIPES = Path(__file__).resolve().parents[2] / "recipes"


def test_paint_grip(tmp_path):
    env = dict(os.environ, TEXCAD_OUT=str(tmp_path), TEXCAD_PITCH="0.8")
    r = subprocess.run([sys.executable, str(RECIPES / "paint_grip.py")], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    fig = json.loads((tmp_path / "paint_grip.json").read_text())
    assert fig["watertight"] and fig["painted_triangles"] > 100 and min(fig["zone_faces"]) > 100
    with zipfile.ZipFile(tmp_path / "paint_grip.3mf") as z:
        cfg = z.read("Metadata/Slic3r_PE_model.config").decode()
    assert re.findall(r'key="name" value="([^"]*)"', cfg)[1:] == ["base", "paint:2 builtin:diamond_knurl:period=2.5", "paint:3 builtin:stones"]
    assert re.findall(r'key="extruder" value="(\d+)"', cfg) == ["2", "3"]
    assert_picture(tmp_path / "paint_grip.png")
