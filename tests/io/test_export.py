import os
import zipfile

import numpy as np
import pytest
import trimesh

import texcad
from texcad import GeometryError, ParameterError, export


@pytest.fixture
def part(small_hm):
    return texcad.pipeline.textured_plate(small_hm, size=small_hm.size, thickness=3).mesh


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

    tp = texcad.pipeline.textured_plate(small_hm, size=small_hm.size, thickness=3)
    p = tmp_path / "two.3mf"
    texcad.io.write_3mf([("base", tp.base_mesh), ("texture", tp.texture_mesh)], p)
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


def test_3mf_rows_in_bulk_are_the_bytes_percent_gives():
    """The numpy formatter of the 3MF's vertex and triangle rows writes exactly what
    ``%.4f`` / ``%d`` write: random float32 coordinates of every size, values that
    round to 0 (``-0.0000`` keeps its sign), exact ties (``1/32`` rounds to even),
    and indices up to 2^32 - 1."""
    from texcad.io.export import _fmt_rows, _triangle_rows, _vertex_rows

    rng = np.random.default_rng(7)
    ties = np.arange(-3000, 3000) / 32768.0
    v = np.concatenate([rng.normal(0, 50, (20000, 3)), rng.uniform(-2e-4, 2e-4, (3000, 3)),
                        np.stack([ties, 3 * ties, -ties], 1), [[0.0, -0.0, 1e5], [123456.789, -99999.99995, 5e8]]])
    v = v.astype(np.float32)
    assert _vertex_rows(v) == _fmt_rows('<vertex x="%.4f" y="%.4f" z="%.4f"/>\n', v.astype(np.float64))
    t = rng.integers(0, 2**32, (20000, 3), dtype=np.int64).astype(np.uint32)
    t[:4] = [[0, 9, 10], [99, 100, 101], [2**32 - 1, 0, 1], [999999, 1000000, 7]]
    assert _triangle_rows(t) == _fmt_rows('<triangle v1="%d" v2="%d" v3="%d"/>\n', t)
    big = np.array([[1e10, 0, -2.5]], np.float32)  # too large for the bulk path: written as % would
    assert _vertex_rows(big) == b'<vertex x="10000000000.0000" y="0.0000" z="-2.5000"/>\n'


def test_3mf_streamed_is_the_bytes_writestr_gives(tmp_path, monkeypatch):
    """The model is formatted in pieces and compressed on a second thread while the
    next piece is formatted: the file is byte for byte the one ``writestr`` of the
    whole model gives (one piece or hundreds, one part or two)."""
    import importlib

    ex = importlib.import_module("texcad.io.export")  # the module (texcad.io.export is also a function)
    tm = trimesh.creation.icosphere(subdivisions=5, radius=20.0)  # 20 480 triangles
    sphere = texcad.Mesh(tm.vertices.astype(np.float32), tm.faces.astype(np.uint32))
    parts = [("base", sphere), ("texture", sphere.translated((50, 0, 0)))]
    streamed = {}
    for rows in (ex._ROWS, 1000):
        monkeypatch.setattr(ex, "_ROWS", rows)
        for label, obj in (("one", sphere), ("two", parts)):
            ex.write_3mf(obj, tmp_path / f"{label}{rows}.3mf")
            streamed[label, rows] = (tmp_path / f"{label}{rows}.3mf").read_bytes()

    def whole(z, info, pieces, bound):  # the writer before streaming
        z.writestr(info, b"".join(pieces), compresslevel=1)

    monkeypatch.setattr(ex, "_write_streamed", whole)
    for label, obj in (("one", sphere), ("two", parts)):
        ex.write_3mf(obj, tmp_path / f"{label}.3mf")
        ref = (tmp_path / f"{label}.3mf").read_bytes()
        assert streamed[label, ex._ROWS] == ref and streamed[label, 1000] == ref
    with zipfile.ZipFile(tmp_path / "two.3mf") as z:
        assert z.testzip() is None and len(z.read("3D/3dmodel.model")) > 2_000_000


@pytest.mark.parametrize("suffix", [".3mf", ".stl"])
def test_one_thread_writes_and_reads_the_same_bytes(tmp_path, monkeypatch, suffix):
    """``TEXCAD_THREADS=1`` (no second thread for deflating, inflating or STL rows)
    gives the file and the mesh that two threads give."""
    import manifold3d as m3d

    from texcad.io import read_mesh
    from texcad.solid import Mesh

    g = m3d.Manifold.sphere(10.0, 400).to_mesh()  # ~320 k triangles: several pieces
    mesh = Mesh(g.vert_properties[:, :3], g.tri_verts)
    files, meshes = [], []
    for n in ("1", "2"):
        monkeypatch.setenv("TEXCAD_THREADS", n)
        (tmp_path / n).mkdir()
        out = tmp_path / n / f"part{suffix}"  # the same name: a 3MF holds it
        export(mesh, out)
        files.append(out.read_bytes())
        meshes.append(read_mesh(out))
    assert files[0] == files[1]
    assert np.array_equal(meshes[0].vertices, meshes[1].vertices) and np.array_equal(meshes[0].faces, meshes[1].faces)
