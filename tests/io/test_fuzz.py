"""Fuzzing the readers (issue 27): valid files of every format, mutated (bytes
flipped, cut short, lines duplicated or dropped), give a result or a TexcadError,
never another exception."""

from __future__ import annotations

import io
import zipfile

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from texcad.errors import TexcadError
from texcad.io import read_mesh

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _valid() -> dict[str, bytes]:
    box = trimesh.creation.box((10.0, 20.0, 5.0))
    out = {}
    for name, kind in (("ascii.stl", "stl_ascii"), ("binary.stl", "stl"), ("part.obj", "obj"), ("part.3mf", "3mf")):
        out[name] = box.export(file_type=kind) if kind != "obj" else box.export(file_type="obj").encode()
        if isinstance(out[name], str):
            out[name] = out[name].encode()
    buf = io.BytesIO()
    from PIL import Image

    Image.fromarray((np.arange(64 * 64) % 251).astype(np.uint8).reshape(64, 64)).save(buf, format="PNG")
    out["tex.png"] = buf.getvalue()
    pages = [Image.fromarray((np.arange(32 * 32) * k % 251).astype(np.uint8).reshape(32, 32)) for k in (1, 3)]
    buf = io.BytesIO()
    pages[0].save(buf, format="TIFF", save_all=True, append_images=pages[1:])  # multi-page: refused whole
    out["pages.tif"] = buf.getvalue()
    buf = io.BytesIO()
    Image.fromarray(np.linspace(0, 1, 32 * 32, dtype=np.float32).reshape(32, 32), mode="F").save(buf, format="TIFF")
    out["float.tif"] = buf.getvalue()
    return out


VALID = _valid()


def _mutate(data: bytes, how: str, at: float, value: int, length: int) -> bytes:
    k = int(at * max(len(data) - 1, 0))
    if how == "flip":
        b = bytearray(data)
        for j in range(k, min(k + length, len(b))):  # per byte flipped
            b[j] = value
        return bytes(b)
    if how == "cut":
        return data[:k]
    lines = data.split(b"\n")
    i = int(at * max(len(lines) - 1, 0))
    if how == "dup":
        return b"\n".join(lines[: i + 1] + lines[i : i + length] + lines[i + 1 :])
    return b"\n".join(lines[:i] + lines[i + length :])  # drop lines


def _read(path):
    if path.suffix in (".png", ".tif"):
        from texcad.sources.image import read_gray

        a = read_gray(path)
        assert np.isfinite(a).all() and a.min() >= 0 and a.max() <= 1  # luminance, never a NaN let through
        return a
    return read_mesh(path)


def _3mf_model_mutated(data: bytes, mutate) -> bytes:
    """The 3MF with its model XML mutated (inside the zip: the XML parser's cases)."""
    src = zipfile.ZipFile(io.BytesIO(data))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as o:
        for n in src.namelist():
            d = src.read(n)
            o.writestr(n, mutate(d) if n.endswith(".model") else d)
    return buf.getvalue()


MUTATION = st.tuples(st.sampled_from(["flip", "cut", "dup", "drop"]), st.floats(0, 1), st.integers(0, 255), st.integers(1, 8))


@pytest.mark.parametrize("name", sorted(VALID))
@SETTINGS
@given(m=MUTATION)
def test_mutated_files_give_a_result_or_a_texcad_error(tmp_path, name, m):
    p = tmp_path / name
    p.write_bytes(_mutate(VALID[name], *m))
    try:
        _read(p)
    except TexcadError:
        pass


@SETTINGS
@given(m=MUTATION)
def test_mutated_3mf_models_give_a_result_or_a_texcad_error(tmp_path, m):
    p = tmp_path / "inner.3mf"
    p.write_bytes(_3mf_model_mutated(VALID["part.3mf"], lambda d: _mutate(d, *m)))
    try:
        mesh = read_mesh(p)
    except TexcadError:
        return
    assert np.isfinite(mesh.vertices).all()  # what is read is numbers, never a NaN let through


@pytest.mark.parametrize("name", ["ascii.stl", "part.obj"])
@SETTINGS
@given(m=MUTATION)
def test_text_meshes_read_are_finite(tmp_path, name, m):
    p = tmp_path / name
    p.write_bytes(_mutate(VALID[name], *m))
    try:
        mesh = read_mesh(p)
    except TexcadError:
        return
    assert np.isfinite(mesh.vertices).all() and mesh.faces.max(initial=0) < len(mesh.vertices)
