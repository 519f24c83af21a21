"""Mesh parts as other tools write them (session 12, fourth round of real files)."""

import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError

trimesh = pytest.importorskip("trimesh")


@pytest.mark.parametrize("union", [False, True])
def test_bodies_closer_than_their_textures_are_named(tmp_path, union):
    """lib3mf's WagonWithWheels.3mf: wheels 0.24 mm from the wagon's body. The gate
    refused the textured part, suggesting --union (also when given, which unites only
    bodies that touch). The message now names the bodies, their gap and a height that
    fits."""
    a = trimesh.creation.box(extents=(20, 20, 10))
    b = trimesh.creation.box(extents=(20, 20, 10))
    b.apply_translation((20.24, 0, 0))  # 0.24 mm beside the first
    path = tmp_path / "two.stl"
    trimesh.util.concatenate([a, b]).export(path)
    with pytest.raises(GeometryError, match=r"bodies 1 and 2 lie 0\.24 mm apart, closer than their textures reach "
                                            r".*use a height under 0\.12 mm, or move the bodies apart") as err:
        texcad.texture(path, "all", "builtin:stones", height=1.0, pitch=1.0, union=union or None)
    assert ("--union unites only bodies that overlap or touch" in str(err.value)) == union
    assert "unite the bodies first" not in str(err.value)
