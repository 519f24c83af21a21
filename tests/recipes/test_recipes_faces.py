"""The recipes of "Any face of a CAD part" run as plain scripts at a coarse pitch:
watertight single-body STL, a 3MF, a picture and the distortion figures they report."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import trimesh

RECIPES = Path(__file__).resolve().parents[2] / "recipes"


def run_recipe(name: str, out: Path, pitch: str = "0.5") -> dict:
    # The texcad of this checkout (not whichever one is installed).
    root = str(RECIPES.parent)
    env = dict(os.environ, TEXCAD_OUT=str(out), TEXCAD_PITCH=pitch, PYTHONPATH=os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, str(RECIPES / f"{name}.py")], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    stl = trimesh.load(out / f"{name}.stl")
    assert stl.is_watertight and stl.is_winding_consistent
    assert len(stl.split(only_watertight=False)) == 1
    assert (out / f"{name}.3mf").stat().st_size > 1000
    assert (out / f"{name}.png").stat().st_size > 5000
    figures = json.loads((out / f"{name}.json").read_text())
    figures["stl"] = stl
    figures["stdout"] = r.stdout
    return figures


def test_knob(tmp_path):
    f = run_recipe("knob", tmp_path)
    assert [i["kinds"] for i in f["faces"]] == [["cone"], ["plane"]]
    # The cone: radius 15 -> 12.5 mm round whole 2 mm tiles: y scale r / R_ref.
    per = f["faces"][0]["period_y"]
    r_ref = per / (2 * 3.141592653589793)
    lo, hi = f["distortion"]["y"][0], f["distortion"]["y"][1]
    assert 12.5 / r_ref - 0.03 < lo < hi < 15 / r_ref + 0.03
    assert f["faces"][1]["distortion"]["x"][2] == pytest.approx(1.0, abs=1e-6)  # planar: exact


def test_lever_ball(tmp_path):
    f = run_recipe("lever_ball", tmp_path)
    assert 0 < f["distortion"]["faded_fraction"] < 0.3 and any("fades out" in w for w in f["warnings"])
    assert f["limits"]["remaining_overhang_mm2"] < 0.01


def test_grip(tmp_path):
    f = run_recipe("grip", tmp_path)
    assert f["faces"][0]["kinds"] == ["bsplinesurface"] and f["faces"][0]["period_y"] is not None
    assert 0.8 < f["distortion"]["y"][0] and f["distortion"]["y"][1] < 1.3


def test_enclosure(tmp_path):
    f = run_recipe("enclosure", tmp_path)
    assert f["sides"] == 8 and len(f["faces"]) == 1 and len(f["faces"][0]["faces"]) == 8
    assert f["limits"]["remaining_overhang_mm2"] < 0.01
    assert 0.97 < f["distortion"]["y"][0] and f["distortion"]["y"][1] < 1.03
