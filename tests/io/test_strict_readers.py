"""Strict readers (issue 27): a malformed or non-finite number, a bad index, a
truncated file is an InputError naming the file, the line and the fix; never a
quietly dropped vertex or a raw traceback."""

from __future__ import annotations

import re
import zipfile

import numpy as np
import pytest
import trimesh

from texcad.errors import InputError
from texcad.io import read_mesh
from texcad.solid import repair_closed


@pytest.fixture
def box(tmp_path):
    return trimesh.creation.box((10.0, 20.0, 20.0))  # 4000 mm3


def _lines_with(path, first: str, text: str):
    lines = path.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.strip().startswith(first))
    lines[k] = text
    path.write_text("\n".join(lines) + "\n")
    return k + 1  # 1-based line number


@pytest.mark.parametrize("bad", ["v nan 0 0", "v 1.2.3 0 0", "v 1 2", "v inf 0 0"])
def test_obj_vertex_is_refused_with_its_line(tmp_path, box, bad):
    p = tmp_path / "p.obj"
    box.export(p)
    assert read_mesh(p).volume == pytest.approx(4000.0)
    line = _lines_with(p, "v ", bad)
    with pytest.raises(InputError, match=rf"p\.obj'?, line {line}: .*export it again"):
        read_mesh(p)


@pytest.mark.parametrize("bad", ["f 1 2 99", "f 0 1 2", "f 1 x 2", "f 1 2", "f -99 1 2"])
def test_obj_face_index_is_refused_with_its_line(tmp_path, box, bad):
    p = tmp_path / "p.obj"
    box.export(p)
    line = _lines_with(p, "f ", bad)
    with pytest.raises(InputError, match=rf"line {line}: "):
        read_mesh(p)


def test_obj_polygons_slashes_and_relative_indices(tmp_path):
    p = tmp_path / "q.obj"
    p.write_text(
        "# a unit cube of quads\no cube\n"
        + "".join(f"v {x} {y} {z}\n" for x in (0, 1) for y in (0, 1) for z in (0, 1))
        + "vn 0 0 1\nf 1//1 3//1 4//1 2//1\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf -7 -3 -1 -5\n"
    )
    m = read_mesh(p)
    v, f, bodies = repair_closed(m.vertices, m.faces)  # closed: every quad fanned, -7 .. -1 resolved
    p = v[f]
    assert m.num_triangles == 12 and bodies == 1
    assert np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6 == pytest.approx(1.0)


@pytest.mark.parametrize("bad", ["vertex 1.2.3 0 0", "vertex nan 0 0", "vertex 1 2"])
def test_ascii_stl_number_is_refused_with_its_line(tmp_path, box, bad):
    p = tmp_path / "a.stl"
    box.export(p, file_type="stl_ascii")
    assert read_mesh(p).volume == pytest.approx(4000.0)
    line = _lines_with(p, "vertex", "      " + bad)
    with pytest.raises(InputError, match=rf"a\.stl'?, line {line}: .*export it again"):
        read_mesh(p)


def test_truncated_stl_is_refused(tmp_path, box):
    a = tmp_path / "a.stl"
    box.export(a, file_type="stl_ascii")
    lines = a.read_text().splitlines()
    a.write_text("\n".join(lines[: len(lines) // 2]) + "\n")  # cut at a facet's end: still whole facets
    with pytest.raises(InputError, match="truncated"):
        read_mesh(a)
    b = tmp_path / "b.stl"
    box.export(b)
    b.write_bytes(b.read_bytes()[:-20])
    with pytest.raises(InputError, match="12 triangles has 684 bytes, this file 664"):
        read_mesh(b)


def test_binary_stl_nan_is_refused(tmp_path, box):
    b = tmp_path / "b.stl"
    box.export(b)
    data = bytearray(b.read_bytes())
    data[84 + 12 : 84 + 16] = np.float32(np.nan).tobytes()  # triangle 0, first vertex, x
    b.write_bytes(bytes(data))
    with pytest.raises(InputError, match="triangle 0 .*not a finite"):
        read_mesh(b)


def _rewrite_model(src, dst, change):
    with zipfile.ZipFile(src) as z, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as o:
        for n in z.namelist():
            data = z.read(n)
            o.writestr(n, change(data) if n.endswith(".model") else data)


def test_3mf_cut_short_or_non_finite_is_refused(tmp_path, box):
    src = tmp_path / "ok.3mf"
    box.export(src)
    assert read_mesh(src).volume == pytest.approx(4000.0)
    cut = tmp_path / "cut.3mf"
    _rewrite_model(src, cut, lambda d: d[: len(d) * 2 // 3])
    with pytest.raises(InputError, match="cut short"):
        read_mesh(cut)
    nan = tmp_path / "nan.3mf"
    _rewrite_model(src, nan, lambda d: re.sub(rb'x="[^"]*"', b'x="nan"', d, count=1))
    with pytest.raises(InputError, match="not finite"):
        read_mesh(nan)
    idx = tmp_path / "idx.3mf"
    _rewrite_model(src, idx, lambda d: d.replace(b'v1="', b'v1="9', 1))
    with pytest.raises(InputError, match="refers to vertex"):
        read_mesh(idx)


def test_huge_image_is_an_input_error(tmp_path, monkeypatch):
    from PIL import Image

    from texcad.sources.image import read_gray

    p = tmp_path / "big.png"
    Image.fromarray(np.zeros((100, 100), np.uint8)).save(p)
    monkeypatch.setattr(Image, "MAX_IMAGE_PIXELS", 1000)  # 10000 px is then a "decompression bomb"
    with pytest.raises(InputError, match="too large.*scale it down"):
        read_gray(p)


# --- images: a multi-page TIFF, NaN pixels (issue 27) -----------------------------------

def test_a_multi_page_tiff_is_refused_naming_its_pages(tmp_path):
    from PIL import Image

    from texcad.sources.image import read_gray

    pages = [Image.fromarray((np.arange(64).reshape(8, 8) * k).astype(np.uint8)) for k in (1, 2, 3)]
    p = tmp_path / "stack.tif"
    pages[0].save(p, save_all=True, append_images=pages[1:])
    with pytest.raises(InputError, match=r"stack\.tif' holds 3 pages .*save the page you want"):
        read_gray(p)
    pages[1].save(tmp_path / "one.tif")  # one page: read as it is
    assert read_gray(tmp_path / "one.tif")[-1, 1] == pytest.approx(2 / 255)


def test_nan_pixels_of_a_float_tiff_are_refused_with_their_place(tmp_path):
    from PIL import Image

    from texcad.sources.image import read_gray

    a = np.full((4, 4), 0.5, np.float32)
    a[1, 2] = np.nan
    p = tmp_path / "nan.tif"
    Image.fromarray(a, mode="F").save(p)
    with pytest.raises(InputError, match=r"nan\.tif'.*1 NaN or infinite pixels \(the first at row 1, column 2"):
        read_gray(p)


# --- PLY scans: what trimesh lets through (issue 27) --------------------------------------

@pytest.mark.parametrize("how, message", [
    ("nan", r"1 vertices that are not finite numbers .*vertex 0"),
    ("index", r"face 11 \(from 0\) indexes vertex \[0, 1, 99\] but the file has 8 vertices"),
    ("cut", r"truncated: its header declares 12 face elements but the file holds 9"),
])
def test_a_bad_ply_scan_is_refused_with_its_place(tmp_path, box, how, message):
    from texcad.sources.scan import read_scan

    small = trimesh.creation.box((10.0, 10.0, 2.0))
    text = small.export(file_type="ply", encoding="ascii")
    lines = (text.decode() if isinstance(text, bytes) else text).splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("end_header")) + 1
    if how == "nan":
        lines[k] = "nan 0 0"
    elif how == "index":
        lines[-1] = "3 0 1 99"
    else:
        lines = lines[:-3]
    p = tmp_path / "scan.ply"
    p.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"scan\.ply'.*" + message + ".*export it again"):
        read_scan(p)
    small.export(tmp_path / "ok.ply")
    assert read_scan(tmp_path / "ok.ply").faces.shape == (12, 3)
