"""recipes/zones_knob.py runs as a plain script, coarse: two zones of a CAD part in one
call, each reaching its own height, each its own part of the 3MF."""

import json
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import trimesh

from conftest import assert_picture

RECIPES = Path(__file__).resolve().parents[2] / "recipes"


def test_zones_knob(tmp_path):
    root = str(RECIPES.parent)  # the texcad of this checkout
    env = dict(os.environ, TEXCAD_OUT=str(tmp_path), TEXCAD_PITCH="0.5",
               PYTHONPATH=os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, str(RECIPES / "zones_knob.py")], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    stl = trimesh.load(tmp_path / "zones_knob.stl")
    assert stl.is_watertight and stl.is_winding_consistent and len(stl.split(only_watertight=False)) == 1
    fig = json.loads((tmp_path / "zones_knob.json").read_text())
    knurl, stones = fig["zone_reliefs"]
    assert knurl["mode"] == "raised" and abs(knurl["max_height"] - 0.6) < 0.03
    assert stones["mode"] == "engraved" and abs(stones["max_depth"] - 0.4) < 0.03
    assert min(fig["layer_volumes_mm3"]) > 5
    with zipfile.ZipFile(tmp_path / "zones_knob.3mf") as z:
        cfg = z.read("Metadata/Slic3r_PE_model.config").decode()
    assert re.findall(r'key="name" value="([^"]*)"', cfg)[1:] == ["base", "zone 1 builtin:diamond_knurl:period=2",
                                                                 "zone 2 builtin:stones"]
    assert_picture(tmp_path / "zones_knob.png")
    # the STEP re-imports as one valid solid enclosing the mesh's volume (0.1 %, plus the
    # lean mesh's 0.02 mm tolerance over the textured area, about 2000 mm2)
    import texcad
    from texcad import brep

    shape = texcad.io.read_step(tmp_path / "zones_knob.step")
    chk = brep.check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1
    assert abs(brep.volume(shape) - stl.volume) <= 1e-3 * stl.volume + 0.02 * 2000
