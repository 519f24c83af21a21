"""texcad.io: writers beside readers. Round trips (write, read, same mesh) over random
meshes, and files written by other tools (trimesh, lib3mf) in every 3MF unit."""

from __future__ import annotations

import zipfile

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from texcad import InputError, Mesh, ParameterError
from texcad.io import UNITS_MM, export, read_mesh, read_part, write_3mf

lib3mf = pytest.importorskip("lib3mf")


def _mesh(sub: int, scale: float, shift: tuple[float, float, float], seed: int) -> Mesh:
    tm = trimesh.creation.icosphere(subdivisions=sub, radius=1.0)
    rng = np.random.default_rng(seed)
    v = tm.vertices * scale * (1 + 0.2 * rng.random((len(tm.vertices), 1))) + np.asarray(shift)
    return Mesh(v.astype(np.float32), tm.faces.astype(np.uint32))


def _triangles(m: Mesh) -> np.ndarray:
    """The triangles as sorted rows of 9 float32 (vertex order within a face kept,
    rotated so the smallest vertex comes first): equal sets mean the same mesh."""
    tri = m.vertices[m.faces].astype(np.float32)  # (M, 3, 3)
    key = tri.reshape(len(tri), 3, 3)
    rot = np.argmin(key[:, :, 0] + 1e3 * key[:, :, 1] + 1e6 * key[:, :, 2], axis=1)
    idx = (rot[:, None] + np.arange(3)[None, :]) % 3
    out = np.take_along_axis(key, idx[:, :, None], axis=1).reshape(len(tri), 9)
    return out[np.lexsort(out.T[::-1])]


meshes = st.builds(
    _mesh,
    st.integers(0, 3),
    st.floats(0.01, 500.0),
    st.tuples(*[st.floats(-1e3, 1e3)] * 3),
    st.integers(0, 2**16),
)


@settings(max_examples=25, deadline=None)
@given(m=meshes, suffix=st.sampled_from([".stl", ".3mf"]))
def test_round_trip_same_mesh(tmp_path_factory, m, suffix):
    p = tmp_path_factory.mktemp("rt") / f"part{suffix}"
    export(m, p)
    back = read_mesh(p)
    assert back.num_triangles == m.num_triangles and back.is_watertight
    if suffix == ".stl":  # float32 as written, vertices welded where bit-identical
        assert np.array_equal(_triangles(back), _triangles(m))
    else:  # the same vertex list and triangles, coordinates on the 3MF's grid (2^-14 mm under 256 mm, coarser past it: within 2 float32 eps)
        assert np.array_equal(back.faces, m.faces)
        tol = 5e-5 + 2 * np.finfo(np.float32).eps * float(np.abs(m.vertices).max())
        assert np.abs(back.vertices.astype(np.float64) - m.vertices).max() <= tol


def test_round_trip_named_objects(tmp_path):
    a, b = _mesh(1, 5.0, (0, 0, 0), 1), _mesh(2, 3.0, (20, 0, 0), 2)
    write_3mf([("base", a), ("texture", b)], tmp_path / "two.3mf")
    back = dict(read_part(tmp_path / "two.3mf"))
    assert sorted(back) == ["base", "texture"]
    for got, want in ((back["base"], a), (back["texture"], b)):
        assert np.array_equal(got.faces, want.faces)
        assert np.abs(got.vertices.astype(np.float64) - want.vertices).max() <= 5e-5 + 1e-5


def _lib3mf_file(path, unit: str, tm: trimesh.Trimesh) -> None:
    w = lib3mf.get_wrapper()
    model = w.CreateModel()
    model.SetUnit({"micron": lib3mf.ModelUnit.MicroMeter, "millimeter": lib3mf.ModelUnit.MilliMeter,
                   "centimeter": lib3mf.ModelUnit.CentiMeter, "inch": lib3mf.ModelUnit.Inch,
                   "foot": lib3mf.ModelUnit.Foot, "meter": lib3mf.ModelUnit.Meter}[unit])
    obj = model.AddMeshObject()
    obj.SetName("box")
    pos, tri = [], []
    for v in tm.vertices:  # 8 vertices: lib3mf's Python API takes structs one by one
        p = lib3mf.Position()
        p.Coordinates[0], p.Coordinates[1], p.Coordinates[2] = (float(x) for x in v)
        pos.append(p)
    for f in tm.faces:  # 12 triangles
        t = lib3mf.Triangle()
        t.Indices[0], t.Indices[1], t.Indices[2] = (int(i) for i in f)
        tri.append(t)
    obj.SetGeometry(pos, tri)
    model.AddBuildItem(obj, w.GetIdentityTransform())
    model.QueryWriter("3mf").WriteToFile(str(path))


@pytest.mark.parametrize("unit", sorted(UNITS_MM))
def test_lib3mf_files_in_every_unit_are_read_in_mm(tmp_path, unit):
    tm = trimesh.creation.box((1.0, 2.0, 3.0))
    _lib3mf_file(tmp_path / "box.3mf", unit, tm)
    (name, m), = read_part(tmp_path / "box.3mf")
    s = UNITS_MM[unit]
    assert name == "box"
    assert m.volume == pytest.approx(6.0 * s**3, rel=1e-6)
    assert np.allclose(np.ptp(m.vertices, axis=0), np.array([1.0, 2.0, 3.0]) * s, rtol=1e-6)


def test_components_in_other_model_parts_are_read(tmp_path):
    """BambuStudio and OrcaSlicer keep each object's mesh in its own model part
    (``3D/Objects/object_N.model``) reached through a component with ``p:path``
    (3MF production extension); lib3mf writes the same. Both components are read,
    each moved by its transform and the build item's."""
    w = lib3mf.get_wrapper()
    model = w.CreateModel()
    box = trimesh.creation.box((20.0, 20.0, 10.0))
    obj = model.AddMeshObject()
    obj.SetName("box")
    obj.SetGeometry([lib3mf.Position((lib3mf.ctypes.c_float * 3)(*map(float, p))) for p in box.vertices],
                    [lib3mf.Triangle((lib3mf.ctypes.c_uint32 * 3)(*map(int, t))) for t in box.faces])
    obj.SetPackagePart(model.FindOrCreatePackagePart("/3D/Objects/object_1.model"))
    comp = model.AddComponentsObject()
    comp.AddComponent(obj, w.GetIdentityTransform())
    comp.AddComponent(obj, w.GetTranslationTransform(30.0, 0.0, 0.0))
    model.AddBuildItem(comp, w.GetTranslationTransform(100.0, 100.0, 5.0))
    model.QueryWriter("3mf").WriteToFile(str(tmp_path / "parts.3mf"))
    with zipfile.ZipFile(tmp_path / "parts.3mf") as z:
        assert b"<mesh" not in z.read("3D/3dmodel.model") and b"<mesh" in z.read("3D/Objects/object_1.model")
    meshes = read_part(tmp_path / "parts.3mf")
    assert [n for n, _ in meshes] == ["box", "box"]
    lo = [np.asarray(m.vertices).min(axis=0).tolist() for _, m in meshes]
    assert lo == [[90.0, 90.0, 0.0], [120.0, 90.0, 0.0]]
    with zipfile.ZipFile(tmp_path / "parts.3mf") as z, zipfile.ZipFile(tmp_path / "cut.3mf", "w") as out:
        for name in z.namelist():  # the same package without the object's model part
            if name != "3D/Objects/object_1.model":
                out.writestr(name, z.read(name))
    with pytest.raises(InputError, match=r"missing model part '3D/Objects/object_1.model'"):
        read_part(tmp_path / "cut.3mf")


def test_texcad_3mf_reads_in_lib3mf(tmp_path):
    m = _mesh(2, 10.0, (1, 2, 3), 0)
    write_3mf(m, tmp_path / "t.3mf")
    model = lib3mf.get_wrapper().CreateModel()
    model.QueryReader("3mf").ReadFromFile(str(tmp_path / "t.3mf"))
    assert model.GetUnit() == lib3mf.ModelUnit.MilliMeter
    it = model.GetMeshObjects()
    assert it.MoveNext()
    obj = it.GetCurrentMeshObject()
    assert obj.GetVertexCount() == len(m.vertices) and obj.GetTriangleCount() == m.num_triangles


@pytest.mark.parametrize("kind", ["stl", "stl_ascii", "3mf"])
def test_trimesh_files_are_read(tmp_path, kind):
    tm = trimesh.creation.icosphere(subdivisions=2, radius=7.0)
    tm.apply_translation((3, -4, 5))
    suffix = ".3mf" if kind == "3mf" else ".stl"
    path = tmp_path / f"sphere{suffix}"
    if kind == "stl_ascii":
        path.write_text(trimesh.exchange.stl.export_stl_ascii(tm))
    else:
        tm.export(path)
    m = read_mesh(path)
    assert m.is_watertight and m.num_triangles == len(tm.faces)
    assert m.volume == pytest.approx(tm.volume, rel=1e-5)


def test_obj_is_read_through_trimesh(tmp_path):
    tm = trimesh.creation.box((2.0, 3.0, 4.0))
    tm.export(tmp_path / "box.obj")
    m = read_mesh(tmp_path / "box.obj")
    assert m.is_watertight and m.volume == pytest.approx(24.0)
    (name, part), = read_part(tmp_path / "box.obj")  # what texcad check reads
    assert name == "box" and part.volume == pytest.approx(24.0)


def test_bad_files_and_units(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        read_mesh(tmp_path / "missing.stl")
    p = tmp_path / "odd.3mf"
    m = _mesh(0, 1.0, (0, 0, 0), 0)
    write_3mf(m, p)
    import zipfile

    data = zipfile.ZipFile(p).read("3D/3dmodel.model").replace(b'unit="millimeter"', b'unit="furlong"')
    with zipfile.ZipFile(tmp_path / "furlong.3mf", "w") as z:
        for n in zipfile.ZipFile(p).namelist():
            z.writestr(n, data if n == "3D/3dmodel.model" else zipfile.ZipFile(p).read(n))
    with pytest.raises(InputError, match="unknown 3MF unit 'furlong'"):
        read_part(tmp_path / "furlong.3mf")
    with pytest.raises(ParameterError, match="unknown output format"):
        export(m, tmp_path / "x.ply")
    assert not (tmp_path / "x.ply").exists()
    with pytest.raises(ParameterError, match="one mesh"):
        export([("a", m)], tmp_path / "x.stl")
