"""Meshes as other tools write them (session 9, real files)."""

import pytest
import trimesh

import texcad
from texcad.errors import InputError


def test_a_mesh_in_metres_is_refused_naming_the_scale(tmp_path):
    """An OBJ written in metres (a 0.18 m ball read as 0.18 mm, Pacotinho/CalcularVolume
    model.obj) was 'textured' without a word: 0.0 mm3, the bbox nearly doubled."""
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.09)
    ball.export(tmp_path / "ball.obj")
    with pytest.raises(InputError, match=r"0\.18 x 0\.18 x 0\.18 mm: under 4 pitches \(1 mm\).*metres.*x1000"):
        texcad.texture(tmp_path / "ball.obj", None, "builtin:stones")
    small = texcad.texture(trimesh.creation.box((2.0, 2.0, 2.0)), "all", "builtin:dots", height=0.2, pitch=0.25)
    assert small.mesh.is_watertight  # 2 mm spans 8 pitches: textured as before


def test_a_hollow_mesh_is_textured(tmp_path):
    """A closed part with an inner void (PrusaSlicer's extruder_idler.obj: two nut
    pockets written as shells inside the part) failed the gate: 'it has 1 bodies where
    the part has 3'. The void is kept, the part textured and one body."""
    outer, hole = trimesh.creation.box((20, 20, 20)), trimesh.creation.box((4, 4, 4))
    trimesh.util.concatenate([outer, hole]).export(tmp_path / "hollow.stl")
    part = texcad.texture(tmp_path / "hollow.stl", "top", "builtin:dots", height=0.3, pitch=0.5)
    body = trimesh.Trimesh(part.mesh.vertices, part.mesh.faces, process=False)
    shells = sorted(s.volume for s in body.split(only_watertight=False))
    assert len(shells) == 2 and abs(shells[0] + 64) < 1e-3 and body.volume > 8000 - 64

