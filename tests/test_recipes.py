"""Every recipe runs as a plain script, at reduced resolution."""

import os
import subprocess
import sys
from pathlib import Path

import pytest
import trimesh

RECIPES = Path(__file__).resolve().parent.parent / "recipes"


def run_recipe(name: str, out: Path, pitch: str = "1.0") -> subprocess.CompletedProcess:
    env = dict(os.environ, TEXCAD_OUT=str(out), TEXCAD_PITCH=pitch)
    r = subprocess.run([sys.executable, str(RECIPES / name)], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return r


def test_flat_plate(tmp_path):
    run_recipe("flat_plate.py", tmp_path)
    stl = trimesh.load(tmp_path / "flat_plate.stl")
    assert stl.is_watertight
    assert stl.bounds[1][2] == pytest.approx(2.0, abs=1e-3)
    assert (tmp_path / "flat_plate.3mf").exists() and (tmp_path / "flat_plate.png").exists()
