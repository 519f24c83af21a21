"""Streaming writers: STL bytes equal to write_stl however the triangles are split
into blocks; a 3MF with shared vertices written once reads back as the same mesh;
a failure leaves no file."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest

import texcad
from texcad.io import write_stl
from texcad.io.stream import StlStream, ThreeMFStream, open_stream, write_blocks


@pytest.fixture
def part(small_hm):
    return texcad.pipeline.textured_plate(small_hm, size=small_hm.size, thickness=3).mesh


def test_stl_blocks_give_write_stl_bytes(tmp_path, part):
    write_stl(part, tmp_path / "whole.stl")
    cuts = [0, 7, len(part.faces) // 3, len(part.faces) - 1, len(part.faces)]
    blocks = [(part.vertices, part.faces[a:b]) for a, b in zip(cuts[:-1], cuts[1:])]
    write_blocks(tmp_path / "blocks.stl", blocks)
    assert (tmp_path / "blocks.stl").read_bytes() == (tmp_path / "whole.stl").read_bytes()


def test_3mf_shared_vertices_written_once(tmp_path, part):
    """Blocks of faces, each with the vertices it uses under their global numbers:
    the file holds every vertex once, in order, and reads back as the mesh."""
    f = part.faces
    cuts = np.linspace(0, len(f), 5).astype(int)
    written = 0
    with ThreeMFStream(tmp_path / "p.3mf", name="plate") as s:
        # renumber vertices in order of first use, so each block's new ones follow on
        first = np.unique(f.ravel(), return_index=True)
        order = first[0][np.argsort(first[1])]
        new_id = np.empty(len(part.vertices), dtype=np.int64)
        new_id[order] = np.arange(len(order))
        for a, b in zip(cuts[:-1], cuts[1:]):  # per block
            used = np.unique(f[a:b].ravel())
            local = np.searchsorted(used, f[a:b])
            s.add(part.vertices[used], local, ids=new_id[used])
            written = s.vertices
    assert written == len(order) and s.triangles == len(f)
    with zipfile.ZipFile(tmp_path / "p.3mf") as z:
        xml = z.read("3D/3dmodel.model").decode()
    assert xml.count("<vertex ") == len(order) and xml.count("<triangle ") == len(f) and 'unit="millimeter"' in xml
    back = texcad.io.read_mesh(tmp_path / "p.3mf")
    assert back.is_watertight and back.num_triangles == part.num_triangles
    assert np.isclose(back.volume, part.volume, rtol=1e-5)
    assert not list(tmp_path.glob(".*"))  # the triangles' temporary file is gone


def test_failure_leaves_no_file(tmp_path, part):
    for suffix in (".stl", ".3mf"):
        out = tmp_path / f"x{suffix}"
        with pytest.raises(ZeroDivisionError):
            with open_stream(out) as s:
                s.add(part.vertices, part.faces[:10])
                1 / 0
        assert not out.exists() and not list(tmp_path.glob(".*"))
    with pytest.raises(texcad.ParameterError, match="new vertices must be numbered on"):
        with ThreeMFStream(tmp_path / "y.3mf") as s:
            s.add(part.vertices[:3], np.array([[0, 1, 2]]), ids=np.array([0, 1, 5]))
    assert not (tmp_path / "y.3mf").exists()
    with pytest.raises(texcad.ParameterError, match="use .stl or .3mf"):
        open_stream(tmp_path / "z.step")
    with pytest.raises(texcad.ParameterError, match="faces index vertices"):
        with StlStream(tmp_path / "w.stl") as s:
            s.add(part.vertices[:3], np.array([[0, 1, 3]]))


def test_stl_records_made_on_threads_give_the_same_bytes(tmp_path, monkeypatch):
    """A block of several record chunks is made a chunk per thread and written in
    order: the bytes do not depend on TEXCAD_THREADS."""
    from texcad.solid import grid_faces

    n = 300
    yy, xx = np.mgrid[0:n, 0:n].astype(np.float32)
    v = np.stack([xx.ravel(), yy.ravel(), np.sin(xx.ravel() * 0.3) * np.cos(yy.ravel() * 0.2)], 1).astype(np.float32)
    f = grid_faces(n, n).astype(np.int64)  # 178,802 triangles: three chunks
    out = {}
    for k in ("1", "2", "3"):
        monkeypatch.setenv("TEXCAD_THREADS", k)
        with StlStream(tmp_path / f"t{k}.stl") as s:
            s.add(v, f)
            s.add(v, f[:10])
        out[k] = (tmp_path / f"t{k}.stl").read_bytes()
    assert out["1"] == out["2"] == out["3"] and len(out["1"]) == 84 + 50 * (len(f) + 10)


def test_3mf_stream_writes_what_write_3mf_writes_placement_and_slicer_settings_included(tmp_path, part):
    """Streamed in blocks with a build direction, PrusaSlicer's and Cura's per-object
    settings: every member of the package is the bytes :func:`write_3mf` writes for
    the whole mesh (the item's transform from the lowest point seen while streaming)."""
    from texcad.io import cura_settings, write_3mf

    up, settings = (0.0, 1.0, 1.0), {"seam_position": "rear"}
    write_3mf(part, tmp_path / "whole.3mf", name="plate", build_dir=up, settings=settings, cura_settings=cura_settings())
    cuts = [0, len(part.faces) // 2, len(part.faces)]
    with ThreeMFStream(tmp_path / "blocks.3mf", name="plate", build_dir=up, settings=settings,
                       cura_settings=cura_settings()) as s:
        s.add(part.vertices, part.faces[: cuts[1]], ids=np.arange(len(part.vertices)))
        s.add(part.vertices, part.faces[cuts[1]:], ids=np.arange(len(part.vertices)))  # no new vertex
    with zipfile.ZipFile(tmp_path / "whole.3mf") as a, zipfile.ZipFile(tmp_path / "blocks.3mf") as b:
        assert sorted(a.namelist()) == sorted(b.namelist())
        for member in a.namelist():
            assert a.read(member) == b.read(member), member
        assert b"cura:skin_edge_support_layers" in b.read("3D/3dmodel.model") and b"transform=" in b.read("3D/3dmodel.model")
