"""Same inputs and seed, same bytes: the demo and two recipes with one vertex per
pixel (``tolerance=0``) give exactly the STL files texcad 0.1 (before the layout of
issue 17) wrote.

The SHA-256 sums below were taken from texcad 0.1 (commit 9603649) on the pinned
stack, with the same commands. The 3MF files changed on purpose (written compressed,
a textured part's texture a part of one object: issue 15), and so did the STEP files
(the texture as tiles that carry their triangulation, issue 16): their contents are
compared with the STL instead, and a second run must give the same bytes.
handle_flange.stl changed on purpose in issue 29: the recipe now states its print
orientation (build_dir +z), so its knurl is limited for it (sum taken then, same
command); the heat sink's did not change (its pins face up: nothing to limit).
"""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

TEXCAD_0_1 = {
    "demo/demo.stl": "e225e38aff7b9b16197d2e5e79248141fa890df3f1fe4f38e231d6d07faa06bd",
    "demo/demo.3mf": "38cdae58a44423bd7366ef664b111cd831e8c410b585aa3d68d1ad940835a687",
    "demo/demo.step": "50a1ae8bf051e9946e3b2cc588be4d8b32f750213b6d11d2cbbcb54b6aa966f6",
    "hs/heat_sink.stl": "74be5cbdb7357007516ca746e3f7eb60e8c8fc66c6f9a2b47a3cea16efb2f690",
    "hs/heat_sink.3mf": "ed230b3396a86dec2567dbf081012f58f877ae59598b1180fc97ce843fcc448a",
    "hs/heat_sink.step": "d8875a10934398544444cb1439ca727b38a2f8f1d7161b088e75c82ba516725c",
    "hf/handle_flange.stl": "da27e9ebe30bb7ed9ff1a8cd00a337ac345a1be88843eb519c023665ab50a38b",
    "hf/handle_flange.3mf": "edf3258003065c0bba23b4109be47e5c982d57064e998fc1ad16aa203a9418ad",
    "hf/handle_flange.step": "e6edae9e333c496f6dc79f27bc8de81ab13dd6cd4f952c74470b17ef77f4cf2c",
}


def _run(args: list[str], out: Path) -> None:
    env = dict(os.environ, TEXCAD_OUT=str(out), TEXCAD_PITCH="0.5", TEXCAD_TOLERANCE="0")
    r = subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]


@pytest.fixture(scope="module")
def outputs(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("repro")
    for d in ("demo", "demo_again"):
        _run(["-m", "texcad", "demo", "--out", str(out / d), "--size", "20", "--pitch", "0.5", "--tolerance", "0"], out)
    _run([str(ROOT / "recipes" / "heat_sink.py")], out / "hs")
    _run([str(ROOT / "recipes" / "handle_flange.py")], out / "hf")
    return out


@pytest.mark.parametrize("name", sorted(n for n in TEXCAD_0_1 if n.endswith(".stl")))
def test_same_bytes_as_texcad_0_1(outputs, name):
    digest = hashlib.sha256((outputs / name).read_bytes()).hexdigest()
    assert digest == TEXCAD_0_1[name], f"{name} changed"


@pytest.mark.parametrize("name", sorted(n for n in TEXCAD_0_1 if n.endswith(".3mf")))
def test_3mf_holds_the_same_mesh_as_the_stl(outputs, name):
    from texcad.io import read_mesh, read_part

    stl = read_mesh(outputs / name.replace(".3mf", ".stl"))
    parts = read_part(outputs / name)
    assert all(m.is_watertight for _, m in parts)
    total = sum(m.volume for _, m in parts)
    assert total == pytest.approx(stl.volume, rel=2e-3)  # base + texture touch, no overlap


@pytest.mark.parametrize("name", sorted(n for n in TEXCAD_0_1 if n.endswith(".step")))
def test_step_is_the_stl_solid(outputs, name):
    from texcad.io import read_mesh, read_step
    from texcad.brep import check_shape, volume

    shape = read_step(outputs / name)
    chk = check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1
    assert volume(shape) == pytest.approx(read_mesh(outputs / name.replace(".step", ".stl")).volume, rel=1e-3)


def test_a_second_run_gives_the_same_bytes(outputs):
    for f in ("demo.stl", "demo.3mf", "demo.step"):
        assert (outputs / "demo" / f).read_bytes() == (outputs / "demo_again" / f).read_bytes(), f


@pytest.mark.parametrize("mode", ["raised", "engraved"])
def test_any_face_lean_relief_gives_the_same_bytes_twice(tmp_path, mode):
    """The general face path with its lean relief (texcad.solid.lean_grid) is deterministic."""
    import warnings

    import texcad

    from build123d import Axis, BuildLine, BuildPart, BuildSketch, GeomType, Plane, Polyline, make_face, revolve

    with BuildPart() as k:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Polyline((0, 0), (12, 0), (9, 12), (0, 12), close=True)
            make_face()
        revolve(axis=Axis.Z)
    cone = k.part.faces().filter_by(GeomType.CONE)
    out = []
    for run in range(2):  # the same inputs twice
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tx = texcad.texture(k.part, cone, "builtin:stones", height=0.5, pitch=0.25, mode=mode)
        assert tx.max_error > 0  # lean
        tx.export(tmp_path / f"{run}.stl")
        out.append((tmp_path / f"{run}.stl").read_bytes())
    assert out[0] == out[1]
