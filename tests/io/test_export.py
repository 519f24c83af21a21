import os
import zipfile

import numpy as np
import pytest
import trimesh

import texcad
from texcad import GeometryError, ParameterError, export


@pytest.fixture
def part(small_hm):
    return texcad.textured_plate(small_hm, size=small_hm.size, thickness=3).mesh


def test_binary_stl_round_trip(tmp_path, part):
    p = tmp_path / "p.stl"
    export(part, p)
    assert os.path.getsize(p) == 84 + 50 * part.num_triangles
    tm = trimesh.load(p)
    assert tm.is_watertight and tm.is_winding_consistent
    assert np.isclose(tm.volume, part.volume, rtol=1e-6)


def test_3mf_millimetres_and_watertight(tmp_path, part):
    p = tmp_path / "p.3mf"
    export(part, p)
    with zipfile.ZipFile(p) as z:
        assert 'unit="millimeter"' in z.read("3D/3dmodel.model").decode()
    scene = trimesh.load(p)
    assert scene.units == "millimeter"
    (g,) = scene.geometry.values()
    assert g.is_watertight
    assert np.isclose(g.volume, part.volume, rtol=1e-5)


def test_3mf_one_object_of_two_parts(tmp_path, small_hm):
    import zipfile

    from texcad.io import read_part

    tp = texcad.textured_plate(small_hm, size=small_hm.size, thickness=3)
    p = tmp_path / "two.3mf"
    texcad.write_3mf([("base", tp.base_mesh), ("texture", tp.texture_mesh)], p)
    z = zipfile.ZipFile(p)
    xml = z.read("3D/3dmodel.model").decode()
    assert xml.count("<object ") == 1 and xml.count("<item ") == 1 and "<component" not in xml
    assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in z.infolist())
    cfg = z.read("Metadata/Slic3r_PE_model.config").decode()
    nb, nt = tp.base_mesh.num_triangles, tp.texture_mesh.num_triangles
    assert f'firstid="0" lastid="{nb - 1}"' in cfg and f'firstid="{nb}" lastid="{nb + nt - 1}"' in cfg
    # a plain 3MF reader sees one object holding both closed shells
    tm = trimesh.load(p, force="mesh")
    assert len(tm.faces) == nb + nt and tm.volume == pytest.approx(tp.base_mesh.volume + tp.texture_mesh.volume, rel=1e-5)
    # texcad's reader gives the parts back, each the mesh that was written
    parts = read_part(p)
    assert [n for n, _ in parts] == ["base", "texture"]
    for (_, m), ref in zip(parts, (tp.base_mesh, tp.texture_mesh)):
        assert m.num_triangles == ref.num_triangles and m.is_watertight
        assert m.volume == pytest.approx(ref.volume, rel=1e-6)


def test_failed_export_leaves_no_file(tmp_path, part, monkeypatch):
    broken = texcad.Mesh(part.vertices, part.faces[:-1])
    with pytest.raises(GeometryError, match="not watertight"):
        export(broken, tmp_path / "broken.stl")
    with pytest.raises(ParameterError, match=".obj"):
        export(part, tmp_path / "p.obj")

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(zipfile.ZipFile, "writestr", boom)
    with pytest.raises(OSError, match="disk full"):
        export(part, tmp_path / "p.3mf")
    assert list(tmp_path.iterdir()) == []
