"""The 3MF reader's numbers: the numpy parser gives the same doubles as ``float()``
for every form writers use (texcad's ``%.4f``, ``%g``, ``%.9g``, ``repr``, exponents,
signs, long values), and other layouts (other attributes, attribute order, white
space, several pieces) read the same mesh as texcad's own."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from texcad import InputError
from texcad.io import read_part, write_3mf
from texcad.io import read as rd
from texcad.solid import Mesh

FORMATS = ["%.4f", "%g", "%.9g", "%.6e", "%.17g", "%r", "%+.3f", "%.0f", "%.15g", "%.12f"]


def _parse(texts: list[bytes], *, integer: bool = False) -> np.ndarray:
    """Parse ``texts`` laid out as quoted values in one buffer, as in a 3MF."""
    buf = b"".join(b' x="' + t + b'"' for t in texts)
    a = np.frombuffer(buf, dtype=np.uint8)
    q = np.flatnonzero(a == 34)
    return rd._parse_decimals(a, q[0::2] + 1, q[1::2], integer=integer)


def _same(got: np.ndarray, want: list[float]) -> bool:
    want = np.array(want, dtype=np.float64)
    return bool(np.array_equal(got, want) and np.array_equal(np.signbit(got), np.signbit(want)))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(allow_nan=False, allow_infinity=False, width=32), min_size=1, max_size=300),
    st.sampled_from(FORMATS),
    st.sampled_from(FORMATS),
)
def test_numbers_are_the_doubles_float_gives(xs, fmt_a, fmt_b):
    """Two formats mixed in one chunk (dots in different places, some values on the
    general path): every value is bit for bit ``float(text)``, signed zeros too."""
    texts = [((fmt_a if i % 3 else fmt_b) % x if fmt_a != "%r" else repr(x)).encode() for i, x in enumerate(xs)]
    assert _same(_parse(texts), [float(t) for t in texts])


def test_plain_decimals_at_the_edges():
    texts = [b"-0.0000", b"0", b"+1.5", b".5", b"5.", b"-.25", b"999999999999999", b"123456789.012345",
             b"0.000000000000001", b"1234567890123456789", b"1_000", b" 2.5", b"3.5 ", b"1e-7", b"-1E+3", b"inf",
             b"00000000000000000001.5"] + [b"%.4f" % x for x in np.linspace(-1e6, 1e6, 70001)]
    assert _same(_parse(texts), [float(t) for t in texts])


def test_integers_stay_integers_and_bad_text_is_refused():
    got = _parse([b"0", b"7", b"4294967295", b"123456789012"], integer=True)
    assert got.dtype == np.int64 and got.tolist() == [0, 7, 4294967295, 123456789012]
    assert _parse([b"1", b"2.0"], integer=True).tolist() == [1.0, 2.0]  # read as numbers, checked later
    for bad in (b"1.2.3", b"--1", b"abc", b"1e", b".", b"-"):
        with pytest.raises(InputError, match="not a number"):
            _parse([b"1.5", bad])


def _model(verts: str, tris: str) -> str:
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" '
        'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">\n<resources>\n'
        f'<object id="3" type="model" name="part"><mesh><vertices>{verts}</vertices>\n'
        f"<triangles>{tris}</triangles></mesh></object>\n</resources>\n"
        '<build><item objectid="3"/></build>\n</model>\n'
    )


def _sphere(n: int = 40) -> Mesh:
    import trimesh

    tm = trimesh.creation.uv_sphere(radius=12.5, count=(n, n))
    return Mesh(tm.vertices.astype(np.float32), tm.faces.astype(np.uint32))


@pytest.mark.parametrize("layout", ["prusa", "tabs", "order", "extra", "compact", "unicode_name"])
def test_other_writers_layouts_read_as_texcad_own(tmp_path, layout, monkeypatch):
    """PrusaSlicer/Bambu-style (indented, %.9g, paint attributes on some triangles),
    tabs and newlines between attributes, another attribute order, extra attributes
    on every triangle, no white space between elements: the same mesh as texcad's
    own file; and the same again when the blocks are read in pieces of 200 bytes."""
    m = _sphere()
    v, f = m.vertices.astype(np.float64), m.faces
    fmt = {"prusa": "%.9g", "compact": "%.6f"}.get(layout, "%.4f")
    if layout == "prusa":
        vs = "".join(f'\n     <vertex x="{fmt % x}" y="{fmt % y}" z="{fmt % z}"/>' for x, y, z in v)
        ts = "".join(f'\n     <triangle v1="{a}" v2="{b}" v3="{c}"' + (' slic3rpe:mmu_segmentation="4"' if i % 7 == 0 else "") + "/>"
                     for i, (a, b, c) in enumerate(f))
    elif layout == "tabs":
        vs = "".join(f'<vertex\tx="{x:.4f}"\n y="{y:.4f}"\r\nz="{z:.4f}" />\n' for x, y, z in v)
        ts = "".join(f'<triangle\tv1="{a}"\n v2="{b}"  v3="{c}"/>\n' for a, b, c in f)
    elif layout == "order":
        vs = "".join(f'<vertex z="{z:.4f}" x="{x:.4f}" y="{y:.4f}"/>' for x, y, z in v)
        ts = "".join(f'<triangle v2="{b}" v3="{c}" v1="{a}"/>' for a, b, c in f)
    elif layout == "extra":
        vs = "".join(f'<vertex x="{x:.4f}" y="{y:.4f}" z="{z:.4f}"/>' for x, y, z in v)
        ts = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}" pid="1" p1="{i % 3}"/>' for i, (a, b, c) in enumerate(f))
    else:
        vs = "".join(f'<vertex x="{fmt % x}" y="{fmt % y}" z="{fmt % z}"/>' for x, y, z in v)
        ts = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in f)
    model = _model(vs, ts)
    if layout == "unicode_name":
        model = model.replace('name="part"', 'name="Teil &quot;Würfel&quot;"')
    path = tmp_path / "other.3mf"
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("3D/3dmodel.model", model.encode())
    want = np.array([[float(fmt % x) for x in row] for row in v])  # what the text says
    for block in (rd._BLOCK, 200):
        monkeypatch.setattr(rd, "_BLOCK", block)
        (name, got), = read_part(path)
        assert np.array_equal(got.faces, f)
        assert np.array_equal(got.vertices, want.astype(np.float32))
    assert name == ("Teil \"Würfel\"" if layout == "unicode_name" else "part")
    write_3mf(m, tmp_path / "own.3mf")
    (_, own), = read_part(tmp_path / "own.3mf")
    # the other writer's rounding (half its last digit) plus texcad's (half a step of its 2^-14 mm grid, and float32)
    bound = (5e-5 if fmt == "%.4f" else 1e-4) + 2.0 ** -15 + 2.0 ** -20
    assert np.array_equal(own.faces, got.faces) and np.abs(own.vertices - got.vertices).max() <= bound


def test_a_broken_number_is_an_input_error(tmp_path):
    m = _sphere(8)
    vs = "".join(f'<vertex x="{x:.4f}" y="{y:.4f}" z="{z:.4f}"/>' for x, y, z in m.vertices.astype(np.float64))
    vs = vs.replace('"', '"1.2.', 1)
    ts = "".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in m.faces)
    path = tmp_path / "broken.3mf"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("3D/3dmodel.model", _model(vs, ts))
    with pytest.raises(InputError, match="not a number"):
        read_part(path)


def test_a_damaged_model_is_an_input_error(tmp_path):
    """The model is inflated on a second thread while it is parsed: a flipped byte
    in the compressed data (bad deflate stream or CRC) is an InputError, and the
    intact file reads the same as ever."""
    m = _sphere(30)
    path = tmp_path / "ok.3mf"
    write_3mf(m, path)
    (_, back), = read_part(path)
    assert np.array_equal(back.faces, m.faces)
    info = zipfile.ZipFile(path).getinfo("3D/3dmodel.model")
    data = bytearray(path.read_bytes())
    start = info.header_offset + 30 + len(info.filename.encode()) + len(info.extra)
    for k, at in enumerate((start + info.compress_size // 2, start + info.compress_size - 3)):
        bad = bytearray(data)
        bad[at] ^= 0x5A
        (tmp_path / f"bad{k}.3mf").write_bytes(bytes(bad))
        with pytest.raises(InputError, match="damaged"):
            read_part(tmp_path / f"bad{k}.3mf")


@pytest.mark.parametrize("block", [rd._BLOCK, 300])
def test_several_objects_stream_in_order(tmp_path, monkeypatch, block):
    """A trimesh scene of two meshes (two objects, build items, namespaces): each
    object's blocks are read as they are inflated, whole or in pieces of 300 bytes."""
    import trimesh

    a = trimesh.creation.icosphere(3, 5.0)
    b = trimesh.creation.box((3, 4, 5))
    b.apply_translation((20, 0, 0))
    trimesh.Scene([a, b]).export(tmp_path / "scene.3mf")
    monkeypatch.setattr(rd, "_BLOCK", block)
    parts = read_part(tmp_path / "scene.3mf")
    assert [m.num_triangles for _, m in parts] == [len(a.faces), len(b.faces)]
    assert [m.volume for _, m in parts] == pytest.approx([a.volume, b.volume], rel=1e-6)
