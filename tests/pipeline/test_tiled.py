"""The tiled plate: the untiled plate's texture triangles one for one, watertight
(manifold3d), the volume within the documented rim difference, no duplicate vertex,
the same file for any tile size; texcad.texture switches to it when the untiled plate
does not fit, through the driver and the gate (checked tile by tile: a broken seam is
caught); and a plate that does not fit untiled is made under an address-space limit.
The same for a full cylinder (tiled_surface, and texcad.texture's switch to it)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import zipfile

import numpy as np
import pytest

import texcad
from texcad.errors import ParameterError
from texcad.io.export import _STL_DTYPE
from texcad.pipeline import textured_plate
from texcad.pipeline.tiled import textured_plate_tiled

SIZE, THICK, PITCH, HEIGHT = (30.0, 22.0), 4.0, 0.5, 1.2


def _triangles(path) -> np.ndarray:
    rec = np.fromfile(path, dtype=_STL_DTYPE, offset=84)
    return rec["v"]  # (n, 3, 3) float32


def _key(tri: np.ndarray) -> np.ndarray:
    """Triangles as sortable rows, each rotated to start at its smallest corner."""
    rows = tri.reshape(len(tri), 3, 3)
    k = np.argmin(rows[:, :, 0] * 1e6 + rows[:, :, 1] * 1e3 + rows[:, :, 2], axis=1)
    idx = (k[:, None] + np.arange(3)[None, :]) % 3
    rot = np.take_along_axis(rows, idx[:, :, None], axis=1).reshape(len(rows), 9)
    return rot[np.lexsort(rot.T[::-1])]


@pytest.fixture(scope="module")
def untiled():
    return textured_plate("builtin:stones", size=SIZE, thickness=THICK, height=HEIGHT, pitch=PITCH, tolerance=0)


@pytest.mark.parametrize("tile", [9, 17, 64])
def test_tiled_equals_untiled_where_both_fit(tmp_path, untiled, tile):
    import manifold3d

    r = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "t.stl", tile=tile)
    hm = untiled.heightmap
    assert r.grid == hm.shape and np.allclose(r.pitch, hm.pitch)
    tri = _triangles(tmp_path / "t.stl")
    assert len(tri) == r.triangles and not list(tmp_path.glob(".*"))  # the heights' cache is gone
    # the texture: every triangle between pixel centres is the untiled slab's, bit for bit
    w, d = SIZE
    inner = np.all((tri[:, :, 0] > 0) & (tri[:, :, 0] < w) & (tri[:, :, 1] > 0) & (tri[:, :, 1] < d), axis=1)
    slab = untiled.texture_mesh
    mine, theirs = _key(tri[inner]), _key(slab.vertices[slab.faces[slab.groups["texture"]]])
    assert mine.shape == theirs.shape and np.array_equal(mine, theirs)
    # closed and manifold: merge the STL's corners, manifold3d accepts it
    verts, inv = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
    faces = inv.reshape(-1, 3).astype(np.uint32)
    man = manifold3d.Manifold(manifold3d.Mesh(vert_properties=verts.astype(np.float32), tri_verts=faces))
    assert man.status() == manifold3d.Error.NoError and man.genus() == 0
    assert len(verts) == r.vertices  # no vertex made twice at a seam
    assert np.isclose(man.volume(), r.volume, rtol=1e-6)
    # the volume: the untiled one plus the rim wedge (documented bound)
    margin = max(w - hm.size[0], d - hm.size[1]) / 2 + max(hm.pitch) / 2
    bound = 2 * (w + d) * margin * HEIGHT / 2
    assert 0 <= r.volume - untiled.mesh.volume <= bound, (r.volume, untiled.mesh.volume, bound)
    # the seams: the same triangles for any tiling (in another order)
    r2 = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "u.stl", tile=tile + 5)
    assert (r2.tiles != r.tiles or r.tiles == 1) and np.array_equal(_key(_triangles(tmp_path / "u.stl")), _key(tri))


def test_3mf_vertices_once_and_heightmap_source(tmp_path, untiled):
    r = textured_plate_tiled(SIZE, THICK, untiled.heightmap, out=tmp_path / "t.3mf", tile=12)
    m = texcad.io.read_mesh(tmp_path / "t.3mf")
    assert m.is_watertight and len(m.vertices) == r.vertices == len(np.unique(m.vertices, axis=0))
    assert np.isclose(m.volume, r.volume, rtol=1e-5)
    s = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "t.stl", tile=12)
    assert np.isclose(s.volume, r.volume, rtol=1e-9)


def test_refusals(tmp_path):
    with pytest.raises(texcad.ParameterError, match="tolerance must be a number of mm >= 0"):
        textured_plate_tiled(SIZE, THICK, "builtin:stones", out=tmp_path / "a.stl", tolerance=-0.02)
    with pytest.raises(texcad.ParameterError, match="streams .stl or .3mf"):
        textured_plate_tiled(SIZE, THICK, "builtin:stones", out=tmp_path / "a.step")
    with pytest.raises(texcad.ParameterError, match="unknown built-in texture"):
        textured_plate_tiled(SIZE, THICK, "builtin:nope", out=tmp_path / "a.stl")
    with pytest.raises(texcad.ResourceError, match="max_memory leaves"):
        textured_plate_tiled(SIZE, THICK, "builtin:stones", out=tmp_path / "a.stl", max_memory="10MB")
    with pytest.raises(texcad.ParameterError, match="build_dir with client="):
        textured_plate_tiled(SIZE, THICK, "builtin:stones", out=tmp_path / "a.stl", build_dir=(0, 1, 1), client=object())
    with pytest.raises(texcad.ParameterError, match="the limiter's reach is the whole plate"):
        from texcad.printability import orientation

        textured_plate_tiled(SIZE, THICK, "builtin:stones", out=tmp_path / "a.stl", build_dir=orientation(133, "-y"))
    assert not list(tmp_path.iterdir())


def test_memory_bound_on_a_plate_that_does_not_fit_untiled(tmp_path):
    """Under an address-space limit of the process (RLIMIT_AS), the plate through
    texcad.texture is made in tiles (its untiled relief would not fit) and the tiled
    one is written, its peak memory under the limit."""
    script = textwrap.dedent(f"""
        import resource, sys
        import build123d, scipy.optimize, scipy.spatial  # libraries loaded first: the limit is for the job's arrays
        import texcad
        from texcad.pipeline import textured_plate
        from texcad.pipeline.tiled import textured_plate_tiled
        def vm():
            return int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        limit = vm() + (600 << 20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        print("through texcad.texture:", textured_plate("builtin:stones", size=(150, 150), thickness=4, pitch=0.125,
                                                        tolerance=0).info["fuse"])
        r = textured_plate_tiled((150, 150), 4, "builtin:stones", 0.125, out={str(tmp_path / "big.stl")!r}, max_memory=600 << 20)
        peak = int(open("/proc/self/status").read().split("VmPeak:")[1].split()[0]) * 1024
        print("tiled", r.grid[0] * r.grid[1], r.tiles, r.triangles, peak <= limit, r.peak_rss)
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    lines = out.stdout.split("\n")
    assert lines[0] == "through texcad.texture: tiled", out.stdout
    px, tiles, tris, under, rss = lines[1].split()[1:]
    assert int(px) == 1200 * 1200 and int(tiles) > 1 and under == "True"
    size = (tmp_path / "big.stl").stat().st_size
    assert size == 84 + 50 * int(tris)


def test_tiles_on_a_dask_cluster_give_the_same_bytes(tmp_path):
    distributed = pytest.importorskip("distributed")
    here = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "here.3mf", tile=10)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=50) as cluster, distributed.Client(cluster, set_as_default=False) as client:
        there = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "there.3mf",
                                     tile=10, client=client)
        lean = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "lean-there.3mf",
                                    tile=10, client=client, tolerance=0.05)
    assert there.tiles == here.tiles > 4 and there.volume == here.volume
    assert (tmp_path / "here.3mf").read_bytes() == (tmp_path / "there.3mf").read_bytes()
    # lean tiles (triangulated on the workers): the same bytes too
    textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "lean-here.3mf", tile=10,
                         tolerance=0.05)
    assert lean.triangles < here.triangles
    assert (tmp_path / "lean-here.3mf").read_bytes() == (tmp_path / "lean-there.3mf").read_bytes()


def _small_budget(monkeypatch):
    """Make the plate adapter's untiled estimate larger than any machine, so that a
    small plate takes the tiled path (the switch itself is what is tested)."""
    import texcad.targets.plate as plate

    monkeypatch.setattr(plate, "texture_bytes", lambda pixels, tolerance: 1e18)


def test_texture_switches_to_tiles_and_equals_the_untiled_plate(tmp_path, untiled, monkeypatch):
    _small_budget(monkeypatch)
    tx = texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", pitch=PITCH, height=HEIGHT, max_memory="2GB",
                        tolerance=0)
    assert isinstance(tx, texcad.Textured) and tx.info["fuse"] == "tiled" and tx.heightmap is None and tx.max_error == 0.0
    g = tx.gate
    assert g.shells.manifold and g.shells.bodies == 1 and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    # the texture's integral is the untiled plate's (computed from the first pass, not from a whole heightmap)
    assert np.isclose(g.expected_volume, untiled.gate.expected_volume, rtol=1e-6)
    tx.export(tmp_path / "t.stl")
    tri = _triangles(tmp_path / "t.stl")
    assert len(tri) == tx.mesh.num_triangles and not list(tmp_path.glob(".*"))
    w, d = SIZE
    inner = np.all((tri[:, :, 0] > 0) & (tri[:, :, 0] < w) & (tri[:, :, 1] > 0) & (tri[:, :, 1] < d), axis=1)
    slab = untiled.texture_mesh
    assert np.array_equal(_key(tri[inner]), _key(slab.vertices[slab.faces[slab.groups["texture"]]]))
    # the same triangles as textured_plate_tiled, and a 3MF with each vertex once, closed, of the gate's volume
    ref = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "r.stl", tile=13)
    assert np.array_equal(_key(_triangles(tmp_path / "r.stl")), _key(tri)) and np.isclose(ref.volume, tx.volume, rtol=1e-9)
    tx.export(tmp_path / "t.3mf")
    m = texcad.io.read_mesh(tmp_path / "t.3mf")
    assert m.is_watertight and len(m.vertices) == len(np.unique(m.vertices, axis=0)) == tx.mesh.num_vertices
    assert np.isclose(m.volume, g.shells.volumes[0], rtol=1e-5)
    with zipfile.ZipFile(tmp_path / "t.3mf") as z:  # the slicers' settings, as export() writes a whole mesh's
        assert b"cura:skin_edge_support_layers" in z.read("3D/3dmodel.model")
        assert b'key="seam_position" value="rear"' in z.read("Metadata/Slic3r_PE_model.config")
    whole = tx.mesh.to_mesh()
    assert whole.is_watertight and np.isclose(whole.volume, tx.volume, rtol=1e-6)
    with pytest.raises(texcad.GeometryError, match="keeps no separate texture body"):
        tx.texture_mesh


def test_tiles_refused_where_they_are_not_made(monkeypatch):
    from build123d import Align, Box, Cylinder, Pos

    base = Box(*SIZE, THICK, align=(Align.MIN, Align.MIN, Align.MAX)) - Pos(15, 11, -THICK) * Cylinder(3, 2)
    _small_budget(monkeypatch)
    with pytest.raises(texcad.ResourceError, match=r"a plate with its own base is not made in tiles; use pitch >="):
        texcad.texture(texcad.Plate(SIZE, THICK, base=base), None, "builtin:stones", pitch=PITCH)


@pytest.mark.parametrize("tilt, toward", [(90, "+y"), (70, 30.0), (120, "-x")])
def test_texture_limited_in_tiles_equals_the_untiled_limited_plate(tmp_path, monkeypatch, tilt, toward):
    """build_dir on a plate made in tiles: the limiter runs block by block (each from
    its halo), and the texture's triangles are the untiled limited plate's, bit for
    bit, with the same report; the gate passes tile by tile; the whole part
    overhangs no more than the untiled one (the sloped rim adds no overhang); the
    STL holds the same triangles as textured_plate_tiled's with the same build_dir."""
    import texcad.targets.tiled as tiled
    from texcad.printability import orientation, overhang_area

    d = orientation(tilt, toward)
    un = texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", pitch=PITCH, height=HEIGHT, build_dir=d, tolerance=0)
    slab = un.texture_mesh
    _small_budget(monkeypatch)
    monkeypatch.setattr(tiled, "tile_for_memory", lambda bound, nodes, **kw: 13)  # many tiles, and limiter blocks
    tx = texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", pitch=PITCH, height=HEIGHT, build_dir=d,
                        max_memory="2GB", tolerance=0)
    assert tx.info["fuse"] == "tiled" and tx.info["tiles"] > 9
    assert tx.limits.removed_volume_mm3 > 1.0 and tx.limits.ramped_borders == un.limits.ramped_borders
    assert tx.limits.max_removed_mm == un.limits.max_removed_mm and tx.limits.iterations == un.limits.iterations
    assert np.isclose(tx.limits.removed_volume_mm3, un.limits.removed_volume_mm3, rtol=1e-12)
    g = tx.gate
    assert g.shells.closed and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    assert np.isclose(g.expected_volume, un.gate.expected_volume, rtol=1e-9)  # the limited integral
    tx.export(tmp_path / "t.stl")
    tri = _triangles(tmp_path / "t.stl")
    w, dd = SIZE
    inner = np.all((tri[:, :, 0] > 0) & (tri[:, :, 0] < w) & (tri[:, :, 1] > 0) & (tri[:, :, 1] < dd), axis=1)
    assert np.array_equal(_key(tri[inner]), _key(slab.vertices[slab.faces[slab.groups["texture"]]]))
    whole = tx.mesh.to_mesh()
    assert whole.is_watertight
    assert overhang_area(whole, d) <= overhang_area(un.mesh, d) + 1e-6
    ref = textured_plate_tiled(SIZE, THICK, "builtin:stones", PITCH, height=HEIGHT, out=tmp_path / "r.stl", tile=17,
                               build_dir=d)
    assert np.array_equal(_key(_triangles(tmp_path / "r.stl")), _key(tri)) and not list(tmp_path.glob(".*"))


def test_texture_makes_lean_tiles_within_its_tolerance(tmp_path, monkeypatch):
    """texcad.texture on a plate made in tiles: lean tiles within its tolerance (no
    warning), gated tile by tile, its max_error the tiles' measured one within the
    tolerance, the same triangles as textured_plate_tiled's at that tolerance and tile
    size; the default tolerance makes lean tiles too; tolerance=0 keeps every pixel centre."""
    import warnings

    import texcad.targets.tiled as tiled

    _small_budget(monkeypatch)
    monkeypatch.setattr(tiled, "tile_for_memory", lambda bound, nodes, **kw: 40)
    plate = texcad.Plate(SIZE, THICK)
    with warnings.catch_warnings():
        warnings.simplefilter("error", texcad.TexcadWarning)
        tx = texcad.texture(plate, None, "builtin:stones", pitch=LEAN_PITCH, height=HEIGHT, tolerance=TOL, max_memory="2GB")
        grid = texcad.texture(plate, None, "builtin:stones", pitch=LEAN_PITCH, height=HEIGHT, max_memory="2GB", tolerance=0)
        default = texcad.texture(plate, None, "builtin:stones", pitch=LEAN_PITCH, height=HEIGHT, max_memory="2GB")
    assert tx.info["fuse"] == "tiled" and tx.info["tolerance"] == TOL and tx.info["tiles"] > 1 and 0 < tx.max_error <= TOL
    g = tx.gate
    assert g.shells.closed and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    assert grid.info["tolerance"] == 0.0 and grid.max_error == 0.0
    assert default.info["tolerance"] == 0.02 and 0 < default.max_error <= 0.02
    assert tx.mesh.num_triangles < 0.6 * grid.mesh.num_triangles
    tx.export(tmp_path / "t.stl")
    ref = textured_plate_tiled(SIZE, THICK, "builtin:stones", LEAN_PITCH, height=HEIGHT, out=tmp_path / "r.stl", tile=40,
                               tolerance=TOL)
    assert np.array_equal(_key(_triangles(tmp_path / "t.stl")), _key(_triangles(tmp_path / "r.stl")))
    assert ref.max_error == tx.max_error and not list(tmp_path.glob(".*"))


def _under_limit(imports: str) -> str:
    """The start of a child script: texcad and ``imports`` loaded, then an address
    space limit (RLIMIT_AS) 600 MiB above what the process maps already, as ``limit``."""
    return textwrap.dedent("""
        import resource
        import build123d, scipy.optimize, scipy.spatial  # libraries loaded first: the limit is for the job's arrays
        import texcad
        {imports}
        texcad.Plate((10, 10), 4)
        def vm():
            return int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        limit = vm() + (600 << 20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    """).replace("{imports}", imports)


def test_limited_plate_under_an_address_space_limit_is_made_in_tiles(tmp_path):
    """A plate limited for standing upright, whose untiled relief needs more than
    max_memory (and than the process may map: RLIMIT_AS), completes in tiles: limited
    block by block, gated, its STL streamed, nothing left to overhang."""
    out = tmp_path / "big.stl"
    script = _under_limit("from texcad.printability import orientation") + textwrap.dedent(f"""
        tx = texcad.texture(texcad.Plate((150, 150), 4), None, "builtin:stones", pitch=0.125, max_memory=600 << 20,
                            build_dir=orientation(90, "+y"))
        tx.export({str(out)!r})
        peak = int(open("/proc/self/status").read().split("VmPeak:")[1].split()[0]) * 1024
        print(tx.info["fuse"], tx.info["tiles"], tx.info["grid"][0] * tx.info["grid"][1], tx.mesh.num_triangles,
              tx.gate.shells.closed, abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack,
              peak <= limit, tx.limits.removed_volume_mm3 > 10, tx.limits.remaining_overhang_mm2 == 0.0,
              tx.limits.ramped_borders == ("y0",))
    """)
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    how, tiles, px, tris, *flags = res.stdout.split()
    assert how == "tiled" and int(tiles) > 1 and int(px) == 1200 * 1200
    assert flags == ["True"] * 6, res.stdout
    assert out.stat().st_size == 84 + 50 * int(tris)


def test_the_tiled_gate_catches_a_broken_seam(tmp_path, monkeypatch):
    from texcad.pipeline.tiled import TiledMesh

    _small_budget(monkeypatch)
    tx = texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", pitch=PITCH, height=HEIGHT, max_memory="2GB")
    good: TiledMesh = tx.stages.fused.mesh
    ex = tx.stages.adapter.expectation(tx.stages.placement, tx.stages.relief, tx.stages.fused)
    assert good.gate(ex).shells.closed

    class Shifted(TiledMesh):  # the second tile numbers its first column one node off: a seam that does not meet
        def blocks(self, progress=None):
            for k, (t, v, f, ids) in enumerate(super().blocks(progress)):
                if k == 1:
                    ids = ids.reshape(t.shape).copy()
                    ids[1:, 0] = ids[:-1, 0]
                    ids = ids.ravel()
                yield t, v, f, ids

    from texcad.solid.tiles import PlateGrid

    grid = PlateGrid(good.grid.size, good.grid.texture_shape, good.grid.pitch, 20)
    assert TiledMesh(grid, good.source, THICK).gate(ex).shells.closed
    with pytest.raises(texcad.GeometryError, match="seam vertices differ|not a closed oriented solid"):
        Shifted(grid, good.source, THICK).gate(ex)

    class Gap(TiledMesh):  # the second tile's first column a micrometre higher: the same numbers, not the same points
        def blocks(self, progress=None):
            for k, (t, v, f, ids) in enumerate(super().blocks(progress)):
                if k == 1:
                    v = v.reshape(*t.shape, 3).copy()
                    v[1:-1, 0, 2] += 1e-3
                    v = v.reshape(-1, 3)
                yield t, v, f, ids

    with pytest.raises(texcad.GeometryError, match="seam vertices differ"):
        Gap(grid, good.source, THICK).gate(ex)

    class Lower(TiledMesh):  # a tile lowered by 0.5 mm: the volume no longer matches the texture's integral
        def blocks(self, progress=None):
            for k, (t, v, f, ids) in enumerate(super().blocks(progress)):
                if k == 0:  # inside its border
                    v = v.reshape(*t.shape, 3).copy()
                    v[1:-1, 1:-1, 2] -= 0.5
                    v = v.reshape(-1, 3)
                yield t, v, f, ids

    with pytest.raises(texcad.GeometryError, match="volume changed by"):
        Lower(grid, good.source, THICK).gate(ex)


def test_texture_under_an_address_space_limit_is_made_in_tiles(tmp_path):
    """texcad.texture on a plate whose untiled relief needs more than max_memory (and
    than the process may map: RLIMIT_AS) completes in tiles, gated, its STL streamed."""
    out = tmp_path / "big.stl"
    script = textwrap.dedent(f"""
        import resource
        import build123d, scipy.optimize, scipy.spatial  # libraries loaded first: the limit is for the job's arrays
        import texcad
        texcad.Plate((10, 10), 4)
        def vm():
            return int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        limit = vm() + (600 << 20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        tx = texcad.texture(texcad.Plate((150, 150), 4), None, "builtin:stones", pitch=0.125, max_memory=600 << 20)
        tx.export({str(out)!r})
        peak = int(open("/proc/self/status").read().split("VmPeak:")[1].split()[0]) * 1024
        print(tx.info["fuse"], tx.info["tiles"], tx.info["grid"][0] * tx.info["grid"][1], tx.mesh.num_triangles,
              tx.gate.shells.closed, abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack, peak <= limit)
    """)
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    how, tiles, px, tris, closed, volume_ok, under = res.stdout.split()
    assert how == "tiled" and int(tiles) > 1 and int(px) == 1200 * 1200
    assert closed == volume_ok == under == "True"
    assert out.stat().st_size == 84 + 50 * int(tris)


def test_a_full_cylinder_in_tiles_has_the_untiled_texture_vertices(tmp_path):
    """A tiled curved face: Surface.cylinder textured in tiles along its unwrapped grid
    (the seam column shared), every texture vertex the untiled slab's top grid vertex
    bit for bit, closed (the gate tile by tile, trimesh on the 3MF), the volume the
    untiled one's within the documented end difference, the same for any tile size."""
    import warnings

    from texcad.pipeline.tiled import tiled_surface

    surf = texcad.Surface.cylinder(8.0, 12.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the texture scaled to whole repeats round the cylinder (both paths)
        untiled = texcad.texture(surf, None, "builtin:stones", pitch=0.5, height=0.6, tolerance=0)
        mesh, ex = tiled_surface(surf, "builtin:stones", pitch=0.5, height=0.6, tile=9)
    top = untiled.stages.relief.mapped.top
    r, c = mesh.grid.texture_shape
    assert top.shape == (r, c, 3) and mesh.grid.count > 4
    seen = np.zeros((r, c), bool)
    for t, v, f, ids in mesh.blocks():  # every tile's texture vertices against the untiled grid
        if t is None:
            continue
        rows, cols, nrs = mesh.grid.texture_block(t)
        mine = v.reshape(*t.shape, 3)[nrs]
        assert np.array_equal(mine, top[rows][:, cols % c])
        seen[rows, cols % c] = True
    assert seen.all()
    g = mesh.gate(ex)
    assert g.shells.closed and g.shells.bodies == 1 and g.farthest_mm <= 0.6 + 1e-5
    mesh.write(tmp_path / "cyl.3mf")
    back = texcad.io.read_mesh(tmp_path / "cyl.3mf")
    assert back.is_watertight and len(back.vertices) == mesh.num_vertices == len(np.unique(back.vertices, axis=0))
    assert len(back.faces) == mesh.num_triangles and np.isclose(back.volume, mesh.volume, rtol=1e-6)
    # the ends: the untiled slab ends in walls at the first and last row; the tiled surface slopes from there to
    # the profile at y = 0 and length: at most 2 x perimeter x (margin + py / 2) x height / 2
    py = float(untiled.stages.relief.mapped.heightmap.pitch[1])
    margin = (12.0 - r * py) / 2 + py / 2
    bound = 2 * surf.profile.length * margin * 0.6 / 2
    assert 0 <= mesh.volume - untiled.mesh.volume <= bound, (mesh.volume, untiled.mesh.volume, bound)
    whole = mesh.to_mesh()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        other, _ = tiled_surface(surf, "builtin:stones", pitch=0.5, height=0.6, tile=31)
    assert other.grid.count < mesh.grid.count
    o = other.to_mesh()
    assert np.array_equal(_key(o.vertices[o.faces]), _key(whole.vertices[whole.faces]))


def test_tiled_surface_refusals():
    from texcad.pipeline.tiled import tiled_surface

    with pytest.raises(texcad.ParameterError, match="closed profile"):
        tiled_surface(texcad.Surface.arc(20.0, 90.0, 10.0, 2.0), "builtin:stones", pitch=0.5)
    with pytest.raises(texcad.ParameterError, match="a tube"), pytest.warns(texcad.TexcadWarning):
        tiled_surface(texcad.Surface.cylinder(8.0, 10.0, thickness=2.0), "builtin:stones", pitch=0.5)


def test_texture_switches_to_tiles_with_a_heightmap(tmp_path, untiled, monkeypatch):
    """A Heightmap texture (held whole, its own pitch and heights) takes the tiled path
    too, with the untiled plate's texture triangles and integral."""
    _small_budget(monkeypatch)
    tx = texcad.texture(texcad.Plate(SIZE, THICK), None, untiled.heightmap, max_memory="2GB")
    assert tx.info["fuse"] == "tiled" and tx.info["grid"] == untiled.heightmap.shape
    assert np.isclose(tx.gate.expected_volume, untiled.gate.expected_volume, rtol=1e-9)
    tx.export(tmp_path / "h.stl")
    tri = _triangles(tmp_path / "h.stl")
    w, d = SIZE
    inner = np.all((tri[:, :, 0] > 0) & (tri[:, :, 0] < w) & (tri[:, :, 1] > 0) & (tri[:, :, 1] < d), axis=1)
    slab = untiled.texture_mesh
    assert np.array_equal(_key(tri[inner]), _key(slab.vertices[slab.faces[slab.groups["texture"]]]))


def _small_surface_budget(monkeypatch):
    """Make the surface adapter's untiled estimate larger than any machine (the switch
    itself is what is tested)."""
    import texcad.util

    monkeypatch.setattr(texcad.util, "texture_bytes", lambda pixels, tolerance: 1e18)


@pytest.mark.parametrize("mapping", ["angle", "distance"])
def test_texture_switches_a_cylinder_to_tiles_with_the_untiled_texture_vertices(tmp_path, monkeypatch, mapping):
    """texcad.texture on a full cylinder that would not fit untiled goes through tiles:
    a Textured gated tile by tile (closed, the volume change the untiled texture's
    integral within its slack plus the ends), every texture vertex the untiled one's,
    the volume the untiled one's within the documented end difference, STL and 3MF
    streamed (the seam column written once where one tile runs all the way round)."""
    import warnings

    surf = texcad.Surface.cylinder(8.0, 12.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the texture scaled to whole repeats round the cylinder (both paths)
        untiled = texcad.texture(surf, None, "builtin:stones", pitch=0.5, height=0.6, tolerance=0, mapping=mapping)
        _small_surface_budget(monkeypatch)
        tx = texcad.texture(surf, None, "builtin:stones", pitch=0.5, height=0.6, mapping=mapping, max_memory="2GB")
    assert isinstance(tx, texcad.Textured) and tx.info["fuse"] == "tiled" and tx.max_error == 0.0
    assert tx.info["grid"] == untiled.info["grid"] and tx.info["tiles"] == 1  # one tile all the way round
    g = tx.gate
    assert g.shells.closed and g.shells.bodies == 1 and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    assert np.isclose(g.expected_volume, untiled.gate.expected_volume, rtol=1e-6)
    assert g.farthest_mm <= 0.6 + 1e-5
    mesh = tx.mesh
    top = untiled.stages.relief.mapped.top
    r, c = mesh.grid.texture_shape
    assert top.shape == (r, c, 3)
    for t, v, f, ids in mesh.blocks():  # every tile's texture vertices against the untiled grid
        if t is not None:
            rows, cols, nrs = mesh.grid.texture_block(t)
            assert np.array_equal(v.reshape(*t.shape, 3)[nrs], top[rows][:, cols % c])
    py = float(untiled.stages.relief.mapped.heightmap.pitch[1])
    bound = 2 * surf.profile.length * ((12.0 - r * py) / 2 + py / 2) * 0.6 / 2  # the ends (tiled_surface)
    assert 0 <= tx.volume - untiled.mesh.volume <= bound, (tx.volume, untiled.mesh.volume, bound)
    tx.export(tmp_path / "cyl.stl")
    assert (tmp_path / "cyl.stl").stat().st_size == 84 + 50 * mesh.num_triangles
    tx.export(tmp_path / "cyl.3mf")
    back = texcad.io.read_mesh(tmp_path / "cyl.3mf")
    assert back.is_watertight and len(back.vertices) == mesh.num_vertices == len(np.unique(back.vertices, axis=0))
    assert np.isclose(back.volume, g.shells.volumes[0], rtol=1e-5)  # the 3MF's decimal vertices
    whole = mesh.to_mesh()  # the STL's triangles, one for one
    assert np.array_equal(_key(_triangles(tmp_path / "cyl.stl")), _key(whole.vertices[whole.faces]))
    assert not list(tmp_path.glob(".*"))
    with pytest.raises(texcad.GeometryError, match="keeps no separate texture body"):
        tx.texture_mesh


def test_a_cylinder_in_tiles_keeps_every_pixel_centre_where_the_untiled_one_is_lean(monkeypatch):
    """The documented difference of curved surfaces in tiles: at the default tolerance
    (0.02 mm) the untiled cylinder is lean within it, the tiled one keeps every pixel
    centre (error 0, every node of every tile a vertex)."""
    import warnings

    surf = texcad.Surface.cylinder(8.0, 12.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the texture scaled to whole repeats round the cylinder (both paths)
        lean = texcad.texture(surf, None, "builtin:pins", pitch=0.5, height=0.6)
        _small_surface_budget(monkeypatch)
        tx = texcad.texture(surf, None, "builtin:pins", pitch=0.5, height=0.6, max_memory="2GB")
    assert tx.info["fuse"] == "tiled" and tx.max_error == 0.0 and tx.info["grid"] == lean.info["grid"]
    assert 0 < lean.max_error <= 0.02
    assert all(len(v) == t.shape[0] * t.shape[1] for t, v, _, _ in tx.mesh.blocks() if t is not None)


GRADIENT = ((0.0, 0.0, 0.0), (0.0, 12.0, 0.0))  # full depth at y = 0, none at y = 12 mm


@pytest.mark.parametrize("mode, mapping, gradient", [("engraved", "angle", None), ("engraved", "distance", None),
                                                     ("centred", "angle", None), ("raised", "angle", GRADIENT),
                                                     ("engraved", "angle", GRADIENT)])
def test_engraved_and_centred_cylinders_in_tiles(tmp_path, monkeypatch, mode, mapping, gradient):
    """Engraved and centred modes (and a gradient) on a tiled cylinder: the tiles'
    sheet is the untiled one's (t = g (h - c H) along the mapping's offset) to float32
    rounding, except that the untiled engraving's cutter reaches at least CUT_FLOOR
    under the surface (the texture's top there lies up to that much deeper); gated
    tile by tile with the signed integral; the volume the untiled one's within the
    ends' difference and the floor; the STL streamed."""
    import warnings

    from texcad.mapping import CUT_FLOOR

    surf, height = texcad.Surface.cylinder(8.0, 12.0), 0.6
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the texture scaled to whole repeats round the cylinder (both paths)
        un = texcad.texture(surf, None, "builtin:stones", pitch=0.5, height=height, tolerance=0, mode=mode, mapping=mapping,
                            gradient=gradient)
        _small_surface_budget(monkeypatch)
        tx = texcad.texture(surf, None, "builtin:stones", pitch=0.5, height=height, mode=mode, mapping=mapping,
                            max_memory="2GB", gradient=gradient)
    assert tx.info["fuse"] == "tiled" and tx.info["mode"] == mode and tx.max_error == 0.0
    g = tx.gate
    assert g.shells.closed and g.shells.bodies == 1 and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    assert g.farthest_mm <= (0.5 if mode == "centred" else 1.0) * height + 1e-5
    assert (g.volume_change < 0) == (mode == "engraved")
    assert (tx.stages.relief.nominal_volume is None) == (mode == "centred")
    slab_top, cut = un.stages.relief.data.bodies.sheets
    mesh = tx.mesh
    r, c = mesh.grid.texture_shape
    across = np.einsum("ck,ck->c", mesh.grid.offset.astype(np.float64), surf.profile.at(un.stages.relief.mapped.s).normal)
    for t, v, f, ids in mesh.blocks():  # every tile's texture vertices against the untiled sheet
        if t is None:
            continue
        rows, cols, nrs = mesh.grid.texture_block(t)
        mine = v.reshape(*t.shape, 3)[nrs]
        if mode == "engraved":
            apart = np.abs(mine - cut[rows][:, cols % c]).max(axis=2)
            down = mesh.heights[rows][:, cols % c] * across[cols % c]  # t's component along the profile's normal
            deep = down < -CUT_FLOOR - 1e-4  # where the cutter's floor does not reach
            assert apart.max() <= CUT_FLOOR + 2e-5 and apart[deep].max(initial=0.0) <= 2e-5
            assert deep.any()
        else:  # the slab's top, but for a centred one's first and last row (tucked under the cut at the ends)
            keep = (np.arange(rows.start, rows.stop) > 0) & (np.arange(rows.start, rows.stop) < r - 1) | (mode == "raised")
            assert np.abs(mine - slab_top[rows][:, cols % c])[keep].max(initial=0.0) <= 2e-5
    py = float(un.stages.relief.mapped.heightmap.pitch[1])
    ends = 2 * surf.profile.length * ((12.0 - r * py) / 2 + py / 2) * height / 2
    assert abs(tx.volume - un.mesh.volume) <= ends + CUT_FLOOR * surf.profile.length * 12.0, (tx.volume, un.mesh.volume)
    tx.export(tmp_path / "cyl.stl")
    assert (tmp_path / "cyl.stl").stat().st_size == 84 + 50 * mesh.num_triangles


def test_surfaces_not_made_in_tiles_are_refused_naming_a_pitch(monkeypatch):
    import warnings

    _small_surface_budget(monkeypatch)
    cyl = texcad.Surface.cylinder(8.0, 12.0)
    cases = [
        (cyl, {"build_dir": (0, 0, 1)}, r"build_dir \(the overhang limiter\)"),
        (texcad.Surface.cylinder(8.0, 12.0, thickness=2.0), {}, "a base that is not its profile's solid"),
        (texcad.Surface.arc(20.0, 90.0, 10.0, 2.0), {}, "an open profile"),
    ]
    for surf, kw, why in cases:
        with warnings.catch_warnings(), pytest.raises(texcad.ResourceError, match=why + r" is not made in tiles; use pitch >= "):
            warnings.simplefilter("ignore")
            texcad.texture(surf, None, "builtin:stones", pitch=0.5, height=0.6, **kw)


def test_cylinder_under_an_address_space_limit_is_made_in_tiles(tmp_path):
    """texcad.texture on a full cylinder whose untiled relief needs more than
    max_memory (and than the process may map: RLIMIT_AS) completes in tiles, gated, its
    STL and 3MF streamed; the same surface with build_dir (not tiled) is refused naming a pitch."""
    out = tmp_path / "roller"
    script = textwrap.dedent(f"""
        import resource, warnings
        import build123d, scipy.optimize, scipy.spatial  # libraries loaded first: the limit is for the job's arrays
        import texcad
        texcad.Surface.cylinder(5.0, 5.0)
        def vm():
            return int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        limit = vm() + (600 << 20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        warnings.simplefilter("ignore")  # the texture scaled to whole repeats round the cylinder
        surf = texcad.Surface.cylinder(20.0, 100.0)
        try:
            texcad.texture(surf, None, "builtin:stones", pitch=0.125, height=0.8, build_dir=(0, 0, 1), max_memory=600 << 20)
        except texcad.ResourceError as exc:
            print("limited:", "is not made in tiles; use pitch >=" in str(exc))
        tx = texcad.texture(surf, None, "builtin:stones", pitch=0.125, height=0.8, max_memory=600 << 20)
        tx.export({str(out) + ".stl"!r})
        tx.export({str(out) + ".3mf"!r})
        peak = int(open("/proc/self/status").read().split("VmPeak:")[1].split()[0]) * 1024
        g = tx.gate
        print(tx.info["fuse"], tx.info["tiles"], tx.info["grid"][0] * tx.info["grid"][1], tx.mesh.num_triangles,
              g.shells.closed, abs(g.volume_change - g.expected_volume) <= g.volume_slack, peak <= limit)
    """)
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    lines = res.stdout.split("\n")
    assert lines[0] == "limited: True", res.stdout
    how, tiles, px, tris, closed, volume_ok, under = lines[1].split()
    assert how == "tiled" and int(tiles) > 1 and int(px) * 1300 > 600 << 20  # the untiled estimate does not fit
    assert closed == volume_ok == under == "True"
    assert (tmp_path / "roller.stl").stat().st_size == 84 + 50 * int(tris)
    assert (tmp_path / "roller.3mf").stat().st_size > 0 and not list(tmp_path.glob(".*"))


# ---------------------------------------------------------------------------------
# Lean tiles (tolerance > 0)
# ---------------------------------------------------------------------------------
LEAN_PITCH, TOL = 0.25, 0.02


@pytest.fixture(scope="module")
def untiled_lean():
    return textured_plate("builtin:stones", size=SIZE, thickness=THICK, height=HEIGHT, pitch=LEAN_PITCH, tolerance=TOL)


def _texture_error(mesh, hm, size=SIZE) -> float:
    """The largest height error (mm) at every pixel centre of ``hm`` of the plate's
    triangles whose corners are all pixel centres (the texture; the rim's cells and
    the walls are not): surface_error also checks that they cover every pixel."""
    from texcad.solid.lean import surface_error

    v, f = mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64)
    (r, c), (px, py) = hm.shape, hm.pitch
    ox, oy = (size[0] - c * px) / 2, (size[1] - r * py) / 2
    col, row = (v[:, 0] - ox) / px - 0.5, (v[:, 1] - oy) / py - 0.5
    ci, ri = np.rint(col).astype(np.int64), np.rint(row).astype(np.int64)
    on = (np.abs(col - ci) < 1e-3) & (np.abs(row - ri) < 1e-3) & (ci >= 0) & (ci < c) & (ri >= 0) & (ri < r) & (v[:, 2] > -1e-6)
    rc = np.where(on[:, None], np.stack([ri, ci], 1), 0)
    return surface_error(hm.heights, rc, v[:, 2], f[on[f].all(axis=1)])


@pytest.mark.parametrize("tile", [40, 97])
def test_lean_tiles_keep_the_untiled_error_bound_across_their_borders(tmp_path, untiled_lean, tile):
    """Lean tiles (tolerance 0.02 mm): within the tolerance of the exact heightfield at
    every pixel centre, tile borders included; watertight, one body, each vertex once
    (none doubled at a seam), the volume the grid's within tolerance x area and the
    3MF's the streamed one; at most 1.3 x the untiled lean mesh's triangles (the
    tiles' borders and the texture's outer rows are kept whole) and under 0.6 x the
    grid's."""
    from texcad.report.gate import shell_report

    hm = untiled_lean.heightmap
    r = textured_plate_tiled(SIZE, THICK, "builtin:stones", LEAN_PITCH, height=HEIGHT, out=tmp_path / "t.3mf", tile=tile,
                             tolerance=TOL)
    assert r.grid == hm.shape and r.tiles > 1 and 0 < r.max_error <= TOL and r.tolerance == TOL
    m = texcad.io.read_mesh(tmp_path / "t.3mf")
    sh = shell_report(m)
    assert m.is_watertight and sh.bodies == 1 and sh.closed
    assert len(m.vertices) == r.vertices == len(np.unique(m.vertices, axis=0))
    assert np.isclose(m.volume, r.volume, rtol=1e-5)
    grid = textured_plate_tiled(SIZE, THICK, "builtin:stones", LEAN_PITCH, height=HEIGHT, out=tmp_path / "g.stl", tile=tile)
    (rows, cols), (px, py) = hm.shape, hm.pitch
    assert abs(r.volume - grid.volume) <= TOL * rows * cols * px * py
    # against the texture's integral: the plate, the heights' integral, the rim wedge (documented) and tolerance x area
    from texcad.solid.mesh import heightfield_volume

    w, d = SIZE
    rim = 2 * (w + d) * (max(w - hm.size[0], d - hm.size[1]) / 2 + max(px, py) / 2) * HEIGHT / 2
    change = r.volume - w * d * THICK - heightfield_volume(hm.heights, hm.pitch)[0]
    assert -TOL * rows * cols * px * py <= change <= rim + TOL * rows * cols * px * py, change
    assert r.triangles <= 1.3 * untiled_lean.mesh.num_triangles and r.triangles < 0.6 * grid.triangles
    # the STL: the same triangles, each corner one of the 3MF's vertices
    s = textured_plate_tiled(SIZE, THICK, "builtin:stones", LEAN_PITCH, height=HEIGHT, out=tmp_path / "t.stl", tile=tile,
                             tolerance=TOL)
    corners, inv = np.unique(_triangles(tmp_path / "t.stl").reshape(-1, 3), axis=0, return_inverse=True)
    assert s.triangles == r.triangles and len(corners) == r.vertices and s.volume == r.volume
    # the error at every pixel centre, from the STL's float32 corners (the 3MF's text has 4 decimals)
    err = _texture_error(texcad.Mesh(corners, inv.reshape(-1, 3).astype(np.uint32)), hm)
    assert err <= TOL and np.isclose(err, r.max_error, rtol=1e-6)


def test_lean_tiles_are_triangulated_once_for_every_pass(monkeypatch):
    """Lean tiles are triangulated in the first pass over the mesh and read back in the
    next (the gate's, then the writer's; two side by side too): the same blocks, no
    second greedy insertion;
    the error is measured against the source's heights and within the tolerance."""
    from texcad.pipeline.tiled import TiledMesh, plate_source
    from texcad.solid import lean
    from texcad.solid.tiles import PlateGrid

    hm = texcad.builtin("builtin:stones", size=(12, 10), pitch=0.25, height=HEIGHT)
    src, side = plate_source(hm, (13, 11), 0.25, None, tile=20)
    mesh = TiledMesh(PlateGrid((13, 11), src.shape, src.pitch, side), src, THICK, tolerance=TOL)
    runs = []
    real = lean.triangulate
    monkeypatch.setattr(lean, "triangulate", lambda *a, **k: runs.append(1) or real(*a, **k))
    first = list(mesh.blocks())
    n = len(runs)
    both = list(zip(mesh.blocks(), mesh.blocks()))  # two passes side by side, read back
    assert mesh.grid.count > 4 and 0 < n <= mesh.grid.count and len(runs) == n
    assert len(first) == len(both) == mesh.grid.count + 1
    for (t, v, f, ids), pair in zip(first, both):
        for t2, v2, f2, ids2 in pair:
            assert t == t2 and np.array_equal(v, v2) and np.array_equal(f, f2) and np.array_equal(ids, ids2)
    assert 0 < mesh.max_error <= TOL and len(runs) == n


def test_lean_tiles_are_gated_tile_by_tile(monkeypatch):
    """The gate on lean tiles: passes on good ones; a lean vertex moved off the
    heightfield (inside a tile) is caught by the per-tile error check; a lean
    triangle flipped by the closed-and-oriented check."""
    import dataclasses

    from texcad.pipeline.tiled import TiledMesh

    _small_budget(monkeypatch)
    tx = texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", pitch=LEAN_PITCH, height=HEIGHT, max_memory="2GB",
                        tolerance=0)
    src, grid = tx.stages.fused.mesh.source, tx.stages.fused.mesh.grid
    ex = tx.stages.adapter.expectation(tx.stages.placement, tx.stages.relief, tx.stages.fused)
    ex = dataclasses.replace(ex, volume_slack=ex.volume_slack + TOL * SIZE[0] * SIZE[1])
    lean = TiledMesh(grid, src, THICK, tolerance=TOL)
    g = lean.gate(ex)
    assert g.shells.closed and lean.max_error <= TOL and lean.num_triangles < 0.6 * tx.mesh.num_triangles

    class Off(TiledMesh):  # a kept vertex inside the first tile 0.05 mm up
        def blocks(self, progress=None):
            for k, (t, v, f, ids) in enumerate(super().blocks(progress)):
                if k == 0:
                    inner = (v[:, 0] > v[:, 0].min()) & (v[:, 0] < v[:, 0].max()) & (v[:, 1] > v[:, 1].min()) & (v[:, 1] < v[:, 1].max())
                    v = v.copy()
                    v[np.flatnonzero(inner)[len(np.flatnonzero(inner)) // 2], 2] += 0.05
                yield t, v, f, ids

    with pytest.raises(texcad.GeometryError, match="lean tiles lie up to"):
        Off(grid, src, THICK, tolerance=TOL).gate(ex)

    class Flipped(TiledMesh):  # one lean triangle the wrong way round
        def blocks(self, progress=None):
            for k, (t, v, f, ids) in enumerate(super().blocks(progress)):
                if k == 1:
                    f = f.copy()
                    f[len(f) // 2] = f[len(f) // 2, [0, 2, 1]]
                yield t, v, f, ids

    with pytest.raises(texcad.GeometryError, match="used twice the same way|not a closed oriented solid"):
        Flipped(grid, src, THICK, tolerance=TOL).gate(ex)


def test_lean_tiles_of_a_limited_plate_keep_the_limiters_facets(tmp_path):
    """build_dir with a tolerance in tiles: every lean facet above the plate keeps the
    angle the untiled lean slab keeps (lean_facets), so the part overhangs no more
    than the limited grid tiles; the error bound holds."""
    from texcad.printability import orientation, overhang_area
    from texcad.printability.overhang import lean_facets

    d = orientation(70, 30.0)
    kw = dict(height=HEIGHT, tile=40, build_dir=d)
    r = textured_plate_tiled(SIZE, THICK, "builtin:stones", LEAN_PITCH, out=tmp_path / "l.3mf", tolerance=TOL, **kw)
    g = textured_plate_tiled(SIZE, THICK, "builtin:stones", LEAN_PITCH, out=tmp_path / "g.3mf", **kw)
    lean, grid = texcad.io.read_mesh(tmp_path / "l.3mf"), texcad.io.read_mesh(tmp_path / "g.3mf")
    assert lean.is_watertight and r.triangles < 0.8 * g.triangles and r.max_error <= TOL
    assert lean_facets(d, 45.0)(lean.vertices, lean.faces)
    assert overhang_area(lean, d) <= overhang_area(grid, d) + 1e-6
    assert not list(tmp_path.glob(".*"))


def test_lean_plate_that_does_not_fit_untiled_under_an_address_space_limit(tmp_path):
    """A lean plate (tolerance 0.02 mm) whose untiled lean mesh needs more than the
    process may map (RLIMIT_AS, by texcad's own estimate) is made in lean tiles within
    the limit: under half the grid's triangles, within the tolerance."""
    out = tmp_path / "big.stl"
    script = _under_limit("from texcad.pipeline.tiled import textured_plate_tiled\n"
                          "from texcad.util import available_memory, texture_bytes") + textwrap.dedent(f"""
        r = textured_plate_tiled((150, 150), 4, "builtin:stones", 0.125, out={str(out)!r}, max_memory=600 << 20, tolerance=0.02)
        peak = int(open("/proc/self/status").read().split("VmPeak:")[1].split()[0]) * 1024
        print(r.grid[0] * r.grid[1], r.tiles, r.triangles, texture_bytes(r.grid[0] * r.grid[1], 0.02) > available_memory(),
              peak <= limit, r.max_error <= 0.02)
    """)
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    px, tiles, tris, *flags = res.stdout.split()
    assert int(px) == 1200 * 1200 and int(tiles) > 1 and flags == ["True"] * 3, res.stdout
    assert int(tris) < 0.5 * 2 * 1202 * 1202 and out.stat().st_size == 84 + 50 * int(tris)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_lean_and_grid_tiles_meet_on_random_heightmaps(tmp_path, seed):
    """Random heightmaps (smooth hills with a noisy patch, so that some tiles stay the
    grid and others are lean), random tile sizes and tolerances: closed, each vertex
    once, within the tolerance at every pixel centre across every seam."""
    rng = np.random.default_rng(seed)
    r, c = int(rng.integers(40, 90)), int(rng.integers(40, 90))
    y, x = np.mgrid[0:r, 0:c] / 10.0
    h = 0.5 + 0.4 * np.sin(x * rng.uniform(0.5, 2)) * np.cos(y * rng.uniform(0.5, 2))
    a, b = int(rng.integers(0, r // 2)), int(rng.integers(0, c // 2))
    h[a : a + r // 3, b : b + c // 3] += rng.uniform(0, 0.3, (len(h[a : a + r // 3]), len(h[0, b : b + c // 3])))
    hm = texcad.Heightmap(h.astype(np.float32), (0.25, 0.25))
    size = (c * 0.25 + 1.0, r * 0.25 + 0.5)
    tol, tile = float(rng.uniform(0.01, 0.05)), int(rng.integers(12, 45))
    res = textured_plate_tiled(size, 3.0, hm, out=tmp_path / "t.stl", tile=tile, tolerance=tol)
    corners, inv = np.unique(_triangles(tmp_path / "t.stl").reshape(-1, 3), axis=0, return_inverse=True)
    m = texcad.Mesh(corners, inv.reshape(-1, 3).astype(np.uint32))
    assert m.is_watertight and len(corners) == res.vertices and res.tiles > 1
    err = _texture_error(m, hm, size)
    assert err <= tol and np.isclose(err, res.max_error, rtol=1e-6)
    from texcad.pipeline.tiled import TiledMesh, plate_source
    from texcad.solid.tiles import PlateGrid

    src, side = plate_source(hm, size, 0.25, None, tile=tile)
    mesh = TiledMesh(PlateGrid(size, src.shape, src.pitch, side), src, 3.0, tolerance=tol)
    grid_tiles = [len(v) == t.shape[0] * t.shape[1] for t, v, _, _ in mesh.blocks() if t is not None]
    assert 0 < sum(grid_tiles) < len(grid_tiles)  # lean tiles beside grid tiles
    assert res.triangles < 2 * (r + 1) * (c + 1) + 2 * (r + c) + 10  # leaner than the grid


def test_texture_makes_its_tiles_on_the_cluster_given_as_client(tmp_path, monkeypatch):
    """``texcad.texture(Plate, client=)``: the tiles made on a local cluster of two
    worker processes, gated, written with the bytes made here; a client that is not
    one is refused, and with build_dir too (its limited heights are a file here)."""
    distributed = pytest.importorskip("distributed")
    _small_budget(monkeypatch)
    kw = dict(pitch=PITCH, height=HEIGHT, max_memory="2GB")
    here = texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", **kw)
    here.export(tmp_path / "here.stl")
    with pytest.raises(ParameterError, match="client must be a dask.distributed.Client"):
        texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", client="localhost", **kw)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=50) as cluster, distributed.Client(cluster, set_as_default=False) as client:
        there = texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", client=client, **kw)
        assert there.info["fuse"] == "tiled" and there.mesh.client is client and there.gate.shells.closed
        there.export(tmp_path / "there.stl")
        with pytest.raises(ParameterError, match="build_dir with client="):
            texcad.texture(texcad.Plate(SIZE, THICK), None, "builtin:stones", client=client, build_dir=(0, 0, 1), **kw)
    assert (tmp_path / "there.stl").read_bytes() == (tmp_path / "here.stl").read_bytes()
