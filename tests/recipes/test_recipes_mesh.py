"""recipes/mesh_part.py at coarse pitch: an STL textured on its sides and engraved on
its top, support-free, with every texture its own 3MF object."""

import json
import os
import subprocess
import sys
from pathlib import Path

import manifold3d as m3d
import numpy as np
import pytest
import trimesh

import texcad
from texcad.io import read_part

ROOT = Path(__file__).resolve().parents[2]


def test_mesh_part_recipe(tmp_path):
    env = dict(os.environ, TEXCAD_OUT=str(tmp_path), TEXCAD_PITCH="1.0", PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, str(ROOT / "recipes" / "mesh_part.py")], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    fig = json.loads((tmp_path / "mesh_part.json").read_text())
    assert fig["watertight"] and fig["objects"] == ["base", "texture 1", "texture 2"]
    assert fig["texture_overhang_mm2"] == 0.0 and fig["texture_area_mm2"] > 4000.0
    src = trimesh.load(tmp_path / "mesh_part_input.stl")
    out = trimesh.load(tmp_path / "mesh_part.stl")
    assert out.is_watertight and out.body_count == 1
    # sides raised: the part grew sideways; top engraved: no higher than before
    assert out.bounds[1][0] > src.bounds[1][0] + 0.3 and out.bounds[1][2] <= src.bounds[1][2] + 1e-4
    # the bed face is untouched: the same lowest z and the same area down there
    def bed(m):
        low = np.all(m.vertices[m.faces][:, :, 2] <= 1e-5, axis=1) & (m.face_normals[:, 2] < -0.9999)
        return m.area_faces[low].sum()
    assert out.bounds[0][2] == pytest.approx(0.0, abs=1e-5) and bed(out) == pytest.approx(bed(src), rel=1e-4)
    # the flat top is engraved inside the original envelope (nothing sticks out of it)
    a = m3d.Manifold(m3d.Mesh(vert_properties=np.asarray(out.vertices, np.float32), tri_verts=np.asarray(out.faces, np.uint32)))
    top = m3d.Manifold.cube((40, 25, 50)).translate((-20, -12.5, src.bounds[1][2] - 1.0))
    s = m3d.Manifold(m3d.Mesh(vert_properties=np.asarray(src.vertices, np.float32), tri_verts=np.asarray(src.faces, np.uint32)))
    assert ((a ^ top) - s).volume() < 1e-3 and (s ^ top).volume() - (a ^ top).volume() > 10.0
    # every object of the 3MF is closed
    items = read_part(tmp_path / "mesh_part.3mf")
    assert all(trimesh.Trimesh(m.vertices, m.faces, process=False).is_watertight for _, m in items)
    rep = texcad.check(tmp_path / "mesh_part.3mf", build_dir=(0, 0, 1))
    assert rep.watertight and rep.texture_overhang_area_mm2 == 0.0
