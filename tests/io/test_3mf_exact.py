"""How PrusaSlicer loads texcad's 3MF (issue 29): every coordinate is written on a
binary grid, as its exact decimal, so that the float32 PrusaSlicer reads is the value
written and centring each part of an object on its own bounding box
(``ModelVolume::center_geometry_after_creation``) and adding the offset back is exact;
and an object of several parts carries PrusaSlicer's 3MF version, so that the build
item's transform moves every part (PrusaSlicer bakes it into the first part only of
a 3MF without it).

The slicer test is skipped where PrusaSlicer is not installed; the rest runs
everywhere."""

import re
import subprocess
import zipfile
from decimal import Decimal

import numpy as np
import pytest
import trimesh

import texcad
from texcad.io import read_part, write_3mf
from texcad.report import slicer

prusa = pytest.mark.skipif(slicer.find_slicer("prusaslicer") is None, reason="prusa-slicer is not installed")


def _cut(mesh: texcad.Mesh, height: float) -> list:
    """``mesh`` cut in two closed parts at ``height`` mm above its lowest point, as
    :func:`slicer_layout` cuts a crowded texture: ``[(name, below), (name, above)]``."""
    from texcad.solid import from_manifold, to_manifold

    z = float(mesh.vertices[:, 2].astype(np.float64).min()) + height
    above, below = to_manifold(mesh).split_by_plane((0.0, 0.0, 1.0), z)
    return [("plate", from_manifold(below)), ("plate above", from_manifold(above))]


def _plate(offset=(0.0, 0.0, 0.0)) -> texcad.Mesh:
    """A 12 x 10 mm stones plate, moved by ``offset`` mm (off-grid coordinates)."""
    tp = texcad.pipeline.textured_plate(texcad.builtin("stones", size=(12, 10), pitch=0.4, height=1.0), size=(12, 10), thickness=3)
    return tp.mesh.translated(offset)


def _model(path) -> tuple[list[np.ndarray], np.ndarray, list[tuple[int, int]]]:
    """(each coordinate's decimal as written, float64 (N, 3) parsed from them, the
    parts' triangle ranges) of a texcad 3MF."""
    z = zipfile.ZipFile(path)
    model = z.read("3D/3dmodel.model").decode()
    text = re.findall(r'<vertex x="([^"]+)" y="([^"]+)" z="([^"]+)"', model)
    tri = np.array(re.findall(r'<triangle v1="(\d+)" v2="(\d+)" v3="(\d+)"', model), dtype=np.int64)
    names = z.namelist()
    cfg = z.read("Metadata/Slic3r_PE_model.config").decode() if "Metadata/Slic3r_PE_model.config" in names else ""
    ranges = [(int(a), int(b)) for a, b in re.findall(r'firstid="(\d+)" lastid="(\d+)"', cfg)] or [(0, len(tri) - 1)]
    return text, np.array(text, dtype=np.float64), [tri[a : b + 1] for a, b in ranges]


def _loaded(v: np.ndarray, parts: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """PrusaSlicer 2.5's loading, per part: (the part's float32 vertices as read, its
    centre ``s`` = bounding-box centre in float64, the centred float32 vertices
    ``v - float(s)`` computed in float32), as ``_3MF_Importer::_generate_volumes`` and
    ``center_geometry_after_creation`` do."""
    f = v.astype(np.float32)
    out = []
    for tri in parts:
        p = f[tri.min() : tri.max() + 1]
        s = (p.min(axis=0).astype(np.float64) + p.max(axis=0).astype(np.float64)) / 2
        out.append((p, s, p - s.astype(np.float32)))  # float32 - float32: IEEE single
    return out


@pytest.mark.parametrize("offset", [(0.0, 0.0, 0.0), (87.123456, -41.3, 12.345678)])
def test_parts_load_as_the_whole_mesh(tmp_path, offset):
    """A plate cut in two parts (as :func:`slicer_layout` cuts a crowded texture) and
    the same plate whole, anywhere on the bed: every coordinate written is the exact
    decimal of a float32, the float32 a reader gets; centring each part on its own
    bounding box in float32 and adding the float64 offset back gives the written
    value exactly, for every vertex of every part; and every vertex of the whole mesh
    is, to the bit, a vertex of the parts."""
    mesh = _plate(offset)
    write_3mf(_cut(mesh, 3.4375), tmp_path / "cut.3mf", name="plate", settings={"overhangs": 0},
              part_settings=({}, {"extra_perimeters": 0}))
    write_3mf(mesh, tmp_path / "whole.3mf", name="plate")
    for name in ("cut.3mf", "whole.3mf"):
        text, v, parts = _model(tmp_path / name)
        flat = [t for row in text for t in row]
        assert all(Decimal(t) == Decimal(float(np.float32(t))) for t in flat[:: max(1, len(flat) // 3000)])  # exact decimals
        assert np.array_equal(v.astype(np.float32).astype(np.float64), v)  # float32 values
        for p, s, centred in _loaded(v, parts):
            assert np.array_equal(centred.astype(np.float64), p.astype(np.float64) - s)  # no rounding in the centring
            assert np.array_equal(centred.astype(np.float64) + s, p.astype(np.float64))  # nor adding the offset back
    _, vw, _ = _model(tmp_path / "whole.3mf")
    _, vc, _ = _model(tmp_path / "cut.3mf")
    whole, cut = {tuple(r) for r in vw}, {tuple(r) for r in vc}
    assert whole <= cut
    # the written mesh is the mesh: within the grid's half step, closed, same volume
    assert np.abs(vw - mesh.vertices.astype(np.float64)).max() <= 2.0**-15
    t = mesh.vertices.astype(np.float64)[mesh.faces]
    area = 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum()
    moved = area * np.sqrt(3) * 2.0**-15  # mm^3: the surface moved by at most half a grid step
    (_, back), = read_part(tmp_path / "whole.3mf")
    assert back.is_watertight and abs(back.volume - mesh.volume) <= moved
    parts = read_part(tmp_path / "cut.3mf")
    assert all(m.is_watertight for _, m in parts) and abs(sum(m.volume for _, m in parts) - mesh.volume) <= 2 * moved


def test_grid_decimals_are_exact_and_reproducible(tmp_path):
    """The bulk formatter writes each grid value's exact decimal (Python's Decimal of
    the float), trailing zeros left out, for random values of every size and sign;
    the same mesh gives the same bytes twice, and trimesh reads the same mesh."""
    from texcad.io.export import _grid_bits, _grid_vertex_rows, _on_grid

    rng = np.random.default_rng(3)
    v = np.concatenate([rng.normal(0, 60, (5000, 3)), rng.uniform(-1e-3, 1e-3, (500, 3)), [[0.0, -0.0, 255.99], [-0.5, 2.0, 1e-9]]])
    bits = _grid_bits(v)
    assert bits == 14
    g = _on_grid(v, bits)
    rows = _grid_vertex_rows(g, bits).decode().splitlines()
    got = [re.findall(r'"([^"]+)"', r) for r in rows]
    want = [[format(Decimal(float(x)).normalize(), "f") if x != 0 else "0" for x in r] for r in g.astype(np.float64)]
    assert got == want
    assert _grid_bits(np.array([[300.0, 0, 0]])) == 13 and _grid_bits(np.array([[1000.0, 0, 0]])) == 12

    mesh = _plate((3.3, 1.1, 0.7))
    write_3mf(mesh, tmp_path / "a.3mf")
    write_3mf(mesh, tmp_path / "b.3mf")
    assert (tmp_path / "a.3mf").read_bytes() == (tmp_path / "b.3mf").read_bytes()
    tm = trimesh.load(tmp_path / "a.3mf", force="mesh")
    assert tm.is_watertight and tm.volume == pytest.approx(mesh.volume, rel=1e-5)


def test_several_parts_carry_prusaslicers_3mf_version(tmp_path):
    """An object of several parts says it is PrusaSlicer's 3MF version 1 (so the
    build item's transform stays the instance's, for every part); one part does
    not (PrusaSlicer bakes the transform into it, as before); the lift to the bed
    is written exactly."""
    mesh = _plate((0.0, 0.0, -5.00003))
    write_3mf(_cut(mesh, 3.4375), tmp_path / "cut.3mf", build_dir=(0, 0, 1))
    write_3mf(mesh, tmp_path / "one.3mf", build_dir=(0, 0, 1))
    cut = zipfile.ZipFile(tmp_path / "cut.3mf").read("3D/3dmodel.model").decode()
    one = zipfile.ZipFile(tmp_path / "one.3mf").read("3D/3dmodel.model").decode()
    assert '<metadata name="slic3rpe:Version3mf">1</metadata>' in cut and "Version3mf" not in one
    lift = float(re.search(r'transform="(?:\S+ ){11}(\S+)"', cut).group(1))
    _, v, _ = _model(tmp_path / "cut.3mf")
    assert lift == -v[:, 2].min()


def _boxes(lo_z: float) -> list:
    """A 20 x 20 x 10 mm block cut at half height into two 5 mm parts, the lower
    one 20 x 20 mm, the upper one 10 x 20 mm (x from 0), lowest point at ``lo_z``."""
    def box(lo, hi):
        b = trimesh.creation.box(bounds=[lo, hi])
        return texcad.Mesh(b.vertices.astype(np.float32), b.faces.astype(np.uint32))

    return [("lower", box([0, 0, lo_z], [20, 20, lo_z + 5])), ("upper", box([0, 0, lo_z + 5], [10, 20, lo_z + 10]))]


@prusa
@pytest.mark.parametrize("build_dir, height", [((0, 0, 1), 10.0), ((1, 0, 0), 20.0)])
def test_prusaslicer_moves_every_part_with_the_build_item(tmp_path, build_dir, height):
    """PrusaSlicer slices a two-part object with a build item transform (lifted by
    10 mm; turned so +x is up) as one solid: as tall as the parts together in print
    orientation, and (lifted) the upper part's layers half as long as the lower's.
    Without the 3MF version the upper part stayed where it was (10 mm below, or not
    turned: 25 mm tall)."""
    path = tmp_path / "parts.3mf"
    write_3mf(_boxes(-10.0), path, name="block", build_dir=build_dir)
    gcode = tmp_path / "parts.gcode"
    subprocess.run([slicer.find_slicer(), "--export-gcode", "--dont-arrange", "--use-relative-e-distances", "--output", str(gcode), str(path)],
                   capture_output=True, timeout=300, check=True)
    paths = slicer.read_toolpaths(gcode)
    assert paths.z.max() == pytest.approx(height, abs=0.3)
    if build_dir == (0, 0, 1):
        per_layer = paths.lengths
        low, high = per_layer[paths.z < 4].mean(), per_layer[(paths.z > 6) & (paths.z < 9)].mean()
        assert high == pytest.approx(low / 2, rel=0.25)
