import numpy as np
import pytest

import texcad
from texcad import GeometryError


def test_textured_plate_builtin(tmp_path):
    tp = texcad.pipeline.textured_plate("builtin:diamond_knurl", size=(20, 10), thickness=4, height=1.0, pitch=0.25)
    m = tp.mesh
    assert m.is_watertight
    lo, hi = m.bounds
    assert np.allclose(lo, [0, 0, -4], atol=1e-4) and np.allclose(hi[:2], [20, 10], atol=1e-4)
    assert np.isclose(hi[2], 1.0, atol=1e-3)
    assert len(texcad.solid.to_manifold(m).decompose()) == 1


def test_texture_larger_than_plate_is_rejected(small_hm):
    with pytest.raises(GeometryError, match="larger"):
        texcad.pipeline.textured_plate(small_hm, size=(10, 10))


def test_slab_deeper_than_plate_is_rejected(small_hm):
    with pytest.raises(GeometryError, match="reach"):
        texcad.pipeline.textured_plate(small_hm, size=small_hm.size, thickness=1.0, depth=2.0)


def test_same_inputs_same_bytes(tmp_path):
    for run in ("a", "b"):
        (tmp_path / run).mkdir()
        tp = texcad.pipeline.textured_plate("builtin:stones", size=(12, 12), thickness=2, pitch=0.25)
        texcad.export(tp.mesh, tmp_path / run / "part.stl")
        texcad.export(tp.mesh, tmp_path / run / "part.3mf")
    for f in ("part.stl", "part.3mf"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes()


def test_stl_of_a_fused_plate_reads_back_exactly(tmp_path):
    """More than one STL chunk (65536 triangles): records in order, corners exact,
    unit outward normals."""
    tp = texcad.pipeline.textured_plate("builtin:stones", size=(50, 50), thickness=2, pitch=0.25, tolerance=0)
    m = tp.mesh
    assert m.num_triangles > 65536
    texcad.io.write_stl(m, tmp_path / "p.stl")
    raw = (tmp_path / "p.stl").read_bytes()
    dt = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    assert np.frombuffer(raw[80:84], "<u4")[0] == m.num_triangles and len(raw) == 84 + 50 * m.num_triangles
    rec = np.frombuffer(raw[84:], dt)
    assert np.array_equal(rec["v"], m.vertices[m.faces]) and not rec["attr"].any()
    n = rec["normal"].astype(np.float64)
    assert np.allclose(np.linalg.norm(n, axis=1), 1, atol=1e-6)
    assert np.allclose(n, m.face_normals(), atol=1e-6)
