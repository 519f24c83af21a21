"""The plate adapter (texcad.targets.plate) and the public target texcad.Plate: the
driver runs its stages, the result passes the full gate (volume and reach), options
that do not apply are refused, and textured_plate (the CLI's) is the same code."""

from __future__ import annotations

import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError, ParameterError
from texcad.targets import PlateAdapter


def test_plate_through_the_driver(monkeypatch):
    calls = []
    for name in ("place", "relief", "fuse"):
        real = getattr(PlateAdapter, name)
        monkeypatch.setattr(PlateAdapter, name, lambda self, *a, _r=real, _n=name: calls.append(_n) or _r(self, *a))
    tx = texcad.texture(texcad.Plate((20, 20), 3), None, "builtin:stones", pitch=0.25)
    assert calls == ["place", "relief", "fuse"]
    assert tx.kind == "plate" and tx.mesh.is_watertight and tx.info["fuse"] == "stitched"
    g = tx.gate
    assert g.shells.bodies == 1 and g.volume_change == pytest.approx(g.expected_volume, abs=g.volume_slack)
    assert g.farthest_mm <= g.reach_mm
    assert tx.volume == pytest.approx(20 * 20 * 3 + g.volume_change)
    assert 0 < tx.max_error <= 0.02 + 1e-6
    assert tx.heightmap.max_height == pytest.approx(1.0, abs=0.01)  # the API's default height


def test_textured_plate_is_the_same_code():
    a = texcad.pipeline.textured_plate("builtin:stones", size=(20, 20), thickness=3, pitch=0.25, height=1.0)
    b = texcad.texture(texcad.Plate((20, 20), 3), None, "builtin:stones", pitch=0.25, height=1.0)
    assert np.array_equal(a.mesh.vertices, b.mesh.vertices) and np.array_equal(a.mesh.faces, b.mesh.faces)
    assert isinstance(a.stages.adapter, PlateAdapter)


def test_a_heightmap_is_used_as_it_is():
    hm = texcad.builtin("stones", size=(10, 10), pitch=0.25, height=0.7)
    tx = texcad.texture(texcad.Plate((12, 12), 2), None, hm)
    assert np.array_equal(tx.heightmap.heights, hm.heights)
    with pytest.raises(GeometryError, match="only"):
        texcad.texture(texcad.Plate((8, 8), 2), None, hm)  # larger than the plate


def test_bad_plates_and_options_are_refused():
    with pytest.raises(ParameterError, match="plate width"):
        texcad.Plate((0, 10), 3)
    with pytest.raises(ParameterError, match="thickness"):
        texcad.Plate((10, 10), -1)
    with pytest.raises(ParameterError, match="not an option"):
        texcad.texture(texcad.Plate((10, 10), 3), None, "builtin:stones", rotation=10)
    with pytest.raises(ParameterError, match="where=None"):
        texcad.texture(texcad.Plate((10, 10), 3), "normal:+z", "builtin:stones")
    with pytest.raises(GeometryError, match="reach"):
        texcad.texture(texcad.Plate((10, 10), 1), None, "builtin:stones", depth=2.0)


def test_limits_and_cad_operations_on_a_plate():
    tx = texcad.texture(texcad.Plate((20, 20), 3), None, "builtin:stones", pitch=0.25, build_dir=(1, 0, 0))
    assert tx.limits is not None and tx.limits.removed_volume_mm3 > 0
    with pytest.raises(GeometryError, match="no B-rep"):
        tx.shape
    from build123d import Cylinder, Pos

    try:
        holed = tx - Pos(10, 10, 0) * Cylinder(2, 20)
    except texcad.TexcadError:
        pass  # a clear TexcadError is allowed, never a TypeError
    else:
        assert holed.mesh.is_watertight and holed.volume < tx.volume
