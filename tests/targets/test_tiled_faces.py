"""Planar faces of CAD parts made in tiles (texcad.targets.tiled_faces, issue 30): the
tiled result against the untiled one where both fit, the gate tile by tile, refusals,
the memory estimate and the memory bound under an address-space limit."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import texcad

pytest.importorskip("build123d")
from build123d import Axis, Box, Cylinder, Polygon, Pos, Rot, extrude  # noqa: E402

import texcad.targets.plane as plane  # noqa: E402
import texcad.targets.tiled as tiled  # noqa: E402
from texcad.targets.tiled_faces import TiledFaceMesh  # noqa: E402

KW = dict(pitch=0.25, height=0.8, tolerance=0)


def _top(part, z):
    """The largest planar face of ``part`` whose centre is at height ``z`` mm."""
    return max([f for f in part.faces() if abs(f.center().Z - z) < 1e-6], key=lambda f: f.area)


def _tiled(monkeypatch, part, face, tile=40, **kw):
    """``texcad.texture`` with the untiled estimate made larger than any machine (the
    switch is what is tested) and tiles of ``tile`` nodes."""
    with monkeypatch.context() as m:
        m.setattr(plane, "texture_bytes", lambda pixels, tolerance: 1e18)
        m.setattr(tiled, "tile_for_memory", lambda bound, nodes, **kw: tile)
        return texcad.texture(part, face, "builtin:stones", **dict(KW, **kw))


def _texture_vertices(tx, mesh):
    """The vertices above the textured face's plane, as a set of their float32 bytes."""
    n, o = np.asarray(tx.info["normal"]), np.asarray(tx.info["origin"])
    v = np.asarray(mesh.vertices, np.float32)
    return set(map(bytes, v[(v.astype(np.float64) - o) @ n > 1e-6]))


def _triangles_above(tx, *meshes):
    """Per mesh, its triangles with every vertex above the textured face's plane, as
    sorted rows of vertex numbers shared by all the meshes (equal float32 points, one
    number), each rotated to start at its smallest (orientation kept)."""
    n, o = np.asarray(tx.info["normal"]), np.asarray(tx.info["origin"])
    v = [np.asarray(m.vertices, np.float32) for m in meshes]
    _, inv = np.unique(np.concatenate(v), axis=0, return_inverse=True)
    out, start = [], 0
    for m, vm in zip(meshes, v):
        ids = inv.reshape(-1)[start : start + len(vm)]
        start += len(vm)
        f = np.asarray(m.faces, np.int64)
        f = ids[f[((vm.astype(np.float64) - o) @ n > 1e-6)[f].all(axis=1)]]
        k = np.argmin(f, axis=1)[:, None]
        out.append(np.unique(np.take_along_axis(f, (k + np.arange(3)) % 3, axis=1), axis=0))
    return out


def _holed():
    return Box(40, 30, 5) - Pos(5, 3, 0) * Cylinder(4, 10) - Pos(-10, -5, 0) * Box(6, 4, 10)


CASES = {
    "box top": (lambda: Box(40, 30, 5), lambda p: _top(p, 2.5), {}),
    "box top with two holes": (_holed, lambda p: _top(p, 2.5), {}),
    "tilted side, rotated and offset texture": (lambda: Rot(10, 20, 30) * Box(40, 30, 5),
                                                lambda p: p.faces().sort_by(Axis.X)[-1], dict(rotation=15, offset=(1.3, -0.7))),
    "box top round a boss": (lambda: Box(40, 30, 5) + Pos(5, 3, 5) * Cylinder(4, 6), lambda p: _top(p, 2.5), dict(edge_angle=60)),
    "cylinder top (a disc)": (lambda: Cylinder(15, 8), lambda p: p.faces().sort_by(Axis.Z)[-1], {}),
    "L-shaped bottom face": (lambda: extrude(Polygon((0, 0), (30, 0), (30, 10), (12, 10), (12, 25), (0, 25), align=None), 6),
                             lambda p: p.faces().sort_by(Axis.Z)[0], dict(rotation=30)),
    "box top with a hole and a mask": (lambda: Box(30, 20, 5) - Pos(5, 2, 0) * Cylinder(3, 10), lambda p: _top(p, 2.5),
                                       dict(mask=np.clip(np.mgrid[0:50, 0:80][1] / 79.0, 0, 1) * (np.mgrid[0:50, 0:80][0] > 10))),
}


@pytest.mark.parametrize("case", list(CASES))
def test_tiled_face_equals_the_untiled_one(case, monkeypatch, tmp_path):
    make, pick, kw = CASES[case]
    part = make()
    face = pick(part)
    untiled = texcad.texture(part, face, "builtin:stones", **dict(KW, **kw))
    tx = _tiled(monkeypatch, part, face, **kw)
    assert isinstance(tx.mesh, TiledFaceMesh) and tx.info["fuse"] == "tiled" and tx.info["tiles"] > 1
    assert tx.heightmap is None and tx.max_error == 0.0
    whole = tx.mesh.to_mesh()
    # the texture: the same float32 vertices, bit for bit, as the untiled face's
    tex = _texture_vertices(tx, whole)
    assert len(tex) > 1000 and tex == _texture_vertices(tx, untiled.mesh)
    # and the same triangles wherever all three corners stand above the face (those that touch
    # the face at the texture's foot differ: the untiled union re-triangulates them there)
    a, b = _triangles_above(tx, whole, untiled.mesh)
    assert len(a) > 1000 and np.array_equal(a, b)
    # the face round it is flat in its plane either way: the same solid, to float rounding
    assert np.isclose(tx.volume, untiled.volume, rtol=1e-6, atol=0)
    assert whole.is_watertight and np.isclose(whole.volume, tx.volume, rtol=1e-9)
    assert len(np.unique(whole.vertices, axis=0)) == len(whole.vertices) == tx.mesh.num_vertices  # no duplicate vertex
    g = tx.gate
    assert g.shells.manifold and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    # the heights' integral, summed tile by tile (read back from the float32 vertices), is the untiled relief's
    assert np.isclose(g.expected_volume, untiled.gate.expected_volume, rtol=1e-6)
    # streamed: an STL of every triangle, a 3MF with each vertex once
    tx.export(tmp_path / "t.stl")
    assert (tmp_path / "t.stl").stat().st_size == 84 + 50 * tx.mesh.num_triangles
    tx.export(tmp_path / "t.3mf")
    m = texcad.io.read_mesh(tmp_path / "t.3mf")
    assert m.is_watertight and len(m.vertices) == tx.mesh.num_vertices and np.isclose(m.volume, tx.volume, rtol=2e-5)  # 3MF: text, 4 decimals
    assert not list(tmp_path.glob(".*"))


@pytest.mark.parametrize("seed", [3, 11])
def test_tiled_face_with_random_holes_has_the_untiled_texture(seed, monkeypatch):
    """Holes anywhere (overlapping the outline and each other), any pitch, offset and
    rotation: the same texture vertices, bit for bit, and the same volume."""
    rng = np.random.default_rng(seed)
    part = Box(30, 20, 5)
    for _ in range(6):
        part = part - Pos(rng.uniform(-13, 13), rng.uniform(-8, 8), 0) * Cylinder(rng.uniform(0.5, 3), 10)
    face = _top(part, 2.5)
    kw = dict(pitch=float(rng.uniform(0.15, 0.4)), offset=(float(rng.uniform(-1, 1)), 0.3), rotation=float(rng.uniform(0, 90)))
    untiled = texcad.texture(part, face, "builtin:stones", **dict(KW, **kw))
    tx = _tiled(monkeypatch, part, face, tile=33, **kw)
    whole = tx.mesh.to_mesh()
    assert whole.is_watertight and tx.info["tiles"] > 4
    assert _texture_vertices(tx, whole) == _texture_vertices(tx, untiled.mesh)
    assert np.isclose(tx.volume, untiled.volume, rtol=1e-6, atol=0)


def test_tiled_face_with_a_heightmap_has_the_untiled_texture(monkeypatch):
    """A Heightmap is held whole (its own pitch) and read a tile at a time."""
    part = Box(30, 20, 5) - Pos(5, 2, 0) * Cylinder(3, 10)
    face = _top(part, 2.5)
    hm = texcad.builtin("builtin:ridges", size=(12, 9), pitch=0.2, height=0.7)
    untiled = texcad.texture(part, face, hm, tolerance=0)
    with monkeypatch.context() as m:
        m.setattr(plane, "texture_bytes", lambda pixels, tolerance: 1e18)
        m.setattr(tiled, "tile_for_memory", lambda bound, nodes, **kw: 33)
        tx = texcad.texture(part, face, hm, tolerance=0)
    whole = tx.mesh.to_mesh()
    assert whole.is_watertight and tx.info["tiles"] > 4
    assert _texture_vertices(tx, whole) == _texture_vertices(tx, untiled.mesh)
    assert np.isclose(tx.volume, untiled.volume, rtol=1e-6, atol=0)


def test_the_parts_other_faces_are_kept(monkeypatch):
    """The faces round the textured one are the part's tessellation as it was: the
    holes' walls keep their vertices (no T-junction: the face's outline is theirs)."""
    part = _holed()
    tx = _tiled(monkeypatch, part, _top(part, 2.5))
    base = tx.base_mesh
    whole = tx.mesh.to_mesh()
    below = base.vertices[:, 2] < 2.5 - 1e-6
    assert set(map(bytes, base.vertices)) <= set(map(bytes, whole.vertices))
    assert below.sum() == int((whole.vertices[:, 2] < 2.5 - 1e-6).sum())


class _Broken(TiledFaceMesh):
    """A tiled face with one defect in the blocks it hands the gate."""

    def __init__(self, tiles, defect):
        super().__init__(tiles)
        self.defect = defect

    def blocks(self, progress=None):
        for k, (t, v, f, ids) in enumerate(super().blocks(progress)):
            if k == 5 and self.defect == "gap":
                v = v.copy()
                v[0, 0] += np.float32(1e-3)
            if k == 5 and self.defect == "lowered":
                v = v.copy()
                v[:, :] -= np.float32(0.1) * np.asarray(self.grid.axes[2], np.float32)
            if t is None and self.defect == "hole":
                f = f[1:]
            yield t, v, f, ids


@pytest.mark.parametrize("defect, message", [("gap", "differ between neighbouring blocks|volume changed"),
                                             ("lowered", "differ between neighbouring blocks"),
                                             ("hole", r"not a closed oriented solid \(3 open")])
def test_the_tiled_gate_catches_a_defect(defect, message, monkeypatch):
    part = Box(40, 30, 5)
    tx = _tiled(monkeypatch, part, _top(part, 2.5))
    ex = tx.stages.adapter.expectation(tx.stages.placement, tx.stages.relief, tx.stages.fused)
    assert TiledFaceMesh(tx.stages.relief.data).gate(ex).shells.closed
    with pytest.raises(texcad.GeometryError, match=message):
        _Broken(tx.stages.relief.data, defect).gate(ex)


def test_faces_not_made_in_tiles_are_refused_naming_a_pitch(monkeypatch):
    part = Box(40, 30, 5) + Pos(5, 3, 2.8) * Box(4, 4, 0.6) + Pos(5, 6, 2.95) * Box(4, 6, 0.3)  # a ledge over the face
    with monkeypatch.context() as m:
        m.setattr(plane, "texture_bytes", lambda pixels, tolerance: pixels * 1e12)
        with pytest.raises(texcad.ResourceError, match=r"part material over it .* not made in tiles; use pitch >= [0-9.e+]+ mm"):
            texcad.texture(part, _top(part, 2.5), "builtin:stones", **KW)


def test_a_large_planar_face_passes_the_memory_estimate():
    """The driver's estimate lets a face through that the plane adapter makes in tiles
    (its pixels are never all in memory), and refuses what it would not tile."""
    from texcad.options import Options
    from texcad.targets.budget import require_faces_memory
    from texcad.util import memory_limit

    part = Box(1000, 1000, 5)
    top = _top(part, 2.5)
    rss = int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    with memory_limit(rss + (1 << 30)):  # 1 GiB for the job, whatever this test process already holds
        require_faces_memory(part, top, "builtin:stones", Options.make(pitch=0.1))
        with pytest.raises(texcad.ResourceError, match=r"use a pitch of at least [0-9.]+ mm"):
            require_faces_memory(part, top, "builtin:stones", Options.make(pitch=0.1, mode="engraved"))
        require_faces_memory(part, top, "builtin:stones", Options.make(pitch=0.1, build_dir=(0, 1, 1)))  # limited in tiles


@pytest.mark.parametrize("build_dir", [None, (0.0, 1.0, 0.0)])
def test_a_face_that_does_not_fit_untiled_is_made_in_tiles_under_an_address_space_limit(tmp_path, build_dir):
    """A 150 mm box top with a hole at 0.125 mm (1.45 M px: about 1.9 GB untiled)
    through texcad.texture under max_memory 600 MB and an address-space limit
    (RLIMIT_AS) of 600 MB over the process's size: made in tiles, gated, streamed;
    limited block by block for a build direction (the part standing upright), nothing
    left to overhang."""
    out = tmp_path / "big.stl"
    script = textwrap.dedent(f"""
        import resource
        import build123d, scipy.ndimage, scipy.optimize, scipy.spatial  # libraries first: the limit is for the job's arrays
        from build123d import Axis, Box, Cylinder, Pos
        import texcad
        w = Box(10, 10, 4)
        texcad.texture(w, w.faces().sort_by(Axis.Z)[-1], "builtin:stones", pitch=1.0)  # OCCT and the tessellation loaded
        def vm(key):
            return int(open("/proc/self/status").read().split(key)[1].split()[0]) * 1024
        limit = vm("VmSize:") + (600 << 20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        part = Box(150, 150, 4) - Pos(37.5, 0, 0) * Cylinder(15, 10)
        tx = texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], "builtin:stones", pitch=0.125, max_memory=600 << 20,
                            build_dir={build_dir!r})
        tx.export({str(out)!r})
        g = tx.gate
        lim = tx.limits
        print(tx.info["fuse"], tx.info["tiles"], tx.info["grid"][0] * tx.info["grid"][1], tx.mesh.num_triangles,
              g.shells.closed, abs(g.volume_change - g.expected_volume) <= g.volume_slack, vm("VmPeak:") <= limit,
              lim is None or (lim.removed_volume_mm3 > 10 and lim.remaining_overhang_mm2 == 0.0))
    """)
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    how, tiles, px, tris, closed, volume_ok, under, limited = res.stdout.split()
    assert how == "tiled" and int(tiles) > 1 and int(px) > 1200 * 1200
    assert closed == volume_ok == under == limited == "True"
    assert out.stat().st_size == 84 + 50 * int(tris)


def test_texcad_texture_makes_a_step_face_in_tiles(tmp_path, monkeypatch, capsys):
    """The CLI on a STEP part: the face made in tiles (lean: the CLI gives its default
    tolerance), its summary, STL and 3MF written."""
    from build123d import export_step

    from texcad.cli import main

    step = tmp_path / "plate.step"
    export_step(Box(40, 30, 5) - Pos(8, 0, 0) * Cylinder(4, 10), str(step))
    outs = [tmp_path / "p.stl", tmp_path / "p.3mf"]
    with monkeypatch.context() as m:
        m.setattr(plane, "texture_bytes", lambda pixels, tolerance: 1e18)
        m.setattr(tiled, "tile_for_memory", lambda bound, nodes, **kw: 64)
        assert main(["texture", str(step), "--face", "top", "--pitch", "0.25", "-o", str(outs[0]), "-o", str(outs[1])]) == 0
    out = capsys.readouterr().out
    # the CLI's default tolerance (0.02 mm) is given: lean tiles, within it
    err = float(out.split("max error")[1].split()[0])
    assert "watertight True" in out and 0 < err <= 0.02 and "(tolerance 0.02 mm)" in out
    meshes = [texcad.io.read_mesh(p) for p in outs]
    assert all(mm.is_watertight for mm in meshes) and np.isclose(meshes[0].volume, meshes[1].volume, rtol=2e-5)


LIMITED = {
    "box top with a hole, lying on its side": (_holed, lambda p: _top(p, 2.5), (120, "-x"), {}),
    "tilted side, rotated texture, oblique": (lambda: Rot(10, 20, 30) * Box(40, 30, 5), lambda p: p.faces().sort_by(Axis.X)[-1],
                                              80.0, dict(rotation=15)),
    "box top with a mask, upright": (lambda: Box(30, 20, 5), lambda p: _top(p, 2.5), (90, "+y"),
                                     dict(mask=np.clip(np.mgrid[0:50, 0:80][1] / 79.0, 0, 1))),
}


@pytest.mark.parametrize("case", list(LIMITED))
def test_tiled_face_limited_for_a_build_direction_equals_the_untiled_one(case, monkeypatch, tmp_path):
    """build_dir on a face made in tiles: the ramped heights limited block by block
    are the untiled limited heights, bit for bit (so are the report's figures), the
    texture's vertices and triangles above the face are the untiled ones, the volume
    agrees, the gate passes tile by tile and the part overhangs no more than the
    untiled one."""
    from texcad.printability import orientation, overhang_area

    make, pick, how, kw = LIMITED[case]
    part = make()
    face = pick(part)
    if isinstance(how, float):  # tilted by that many degrees from the face's normal, obliquely to its edges
        n = np.array(tuple(face.normal_at()))
        e = face.edges()[0]
        u = np.array(tuple(e.end_point() - e.start_point()))
        u = u / np.linalg.norm(u) + 0.5 * np.cross(n, u / np.linalg.norm(u))
        u /= np.linalg.norm(u)
        d = np.cos(np.radians(how)) * n + np.sin(np.radians(how)) * u
    else:
        d = orientation(*how)
    untiled = texcad.texture(part, face, "builtin:stones", build_dir=d, **dict(KW, **kw))
    tx = _tiled(monkeypatch, part, face, tile=40, build_dir=d, **kw)
    assert tx.info["fuse"] == "tiled" and tx.info["tiles"] > 2 and tx.info["build_dir"] == untiled.info["build_dir"]
    lim = tx.stages.relief.data.limited
    assert max(lim.limit.plan.halo) > 0 and lim.shape == untiled.heightmap.shape
    h = lim.heights(slice(0, lim.shape[0]), slice(0, lim.shape[1]))
    assert np.array_equal(h, untiled.heightmap.heights)
    assert tx.limits.removed_volume_mm3 > 0.01 and tx.limits.removed_volume_mm3 == untiled.limits.removed_volume_mm3
    assert tx.limits.ramped_borders == untiled.limits.ramped_borders and tx.limits.iterations == untiled.limits.iterations
    whole = tx.mesh.to_mesh()
    assert _texture_vertices(tx, whole) == _texture_vertices(tx, untiled.mesh)
    a, b = _triangles_above(tx, whole, untiled.mesh)
    assert len(a) > 1000 and np.array_equal(a, b)
    assert np.isclose(tx.volume, untiled.volume, rtol=1e-6, atol=0) and whole.is_watertight
    g = tx.gate
    assert g.shells.manifold and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    assert overhang_area(whole, d) <= overhang_area(untiled.mesh, d) * (1 + 1e-7) + 1e-6  # the part's own faces: to float rounding
    tx.export(tmp_path / "t.stl")
    assert (tmp_path / "t.stl").stat().st_size == 84 + 50 * tx.mesh.num_triangles


@pytest.mark.parametrize("case", ["box top with two holes", "L-shaped bottom face"])
def test_lean_tiles_on_a_face(case, monkeypatch):
    """A tolerance given on a face made in tiles: blocks wholly inside the textured
    region are lean (their borders whole), the rest stays cells. Closed, each vertex
    once, gated; within the tolerance at every node against the heights of the tiles
    made without a tolerance (the untiled heights, tested above), tile by tile; fewer
    triangles than those; the volume within tolerance x area of theirs and of
    the untiled lean face's."""
    from texcad.solid.lean import surface_error
    from texcad.targets.tiled_faces import TileCells, _cell_faces

    tol = 0.02
    make, pick, kw = CASES[case]
    part = make()
    face = pick(part)
    grid = _tiled(monkeypatch, part, face, tile=40, **kw)
    tx = _tiled(monkeypatch, part, face, tile=40, **dict(kw, tolerance=tol))
    untiled = texcad.texture(part, face, "builtin:stones", **dict(KW, **dict(kw, tolerance=tol)))
    assert tx.info["tolerance"] == tol and 0 < tx.max_error <= tol and grid.max_error == 0.0
    g = tx.gate
    assert g.shells.closed and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    whole = tx.mesh.to_mesh()
    assert whole.is_watertight and len(np.unique(whole.vertices, axis=0)) == len(whole.vertices) == tx.mesh.num_vertices
    assert tx.mesh.num_triangles < 0.8 * grid.mesh.num_triangles  # small faces at 0.25 mm: the edge bands stay cells
    assert abs(tx.volume - grid.volume) <= tol * face.area and abs(tx.volume - untiled.volume) <= 2 * tol * face.area
    fg, lean = grid.mesh.grid, 0
    for (t, v, f, _), (t2, v2, f2, _) in zip(tx.mesh.blocks(), grid.mesh.blocks()):  # per tile, the same tiles
        if t is None or len(v) == len(v2):
            continue
        lean += 1
        exact = TileCells.of(fg, t2, fg.to_local(v2), f2, "x")
        q = fg.to_local(v)
        i = np.rint((q[:, 1] - fg.ys(t.i0, t.i0)[0]) / fg.pitch[1]).astype(np.int64)
        j = np.rint((q[:, 0] - fg.xs(t.j0, t.j0)[0]) / fg.pitch[0]).astype(np.int64)
        r, c = t.shape
        z = exact.h.ravel().copy()
        z[i * c + j] = q[:, 2]
        rc = np.stack(np.divmod(np.arange(r * c), c), 1)
        filler = _cell_faces(t, ~exact.cells)  # the cells nothing textures: 0 error
        assert surface_error(exact.h, rc, z, np.concatenate([(i * c + j)[f], filler])) <= tol + 1e-5
    assert lean > 1
    # the gate re-measures each lean tile: a lean vertex 0.05 mm off is caught
    normal = np.asarray(tx.info["normal"], np.float32)

    class Off(TiledFaceMesh):
        def blocks(self, progress=None):
            moved = False
            for t, v, f, ids in super().blocks(progress):
                if t is not None and not moved and self.is_lean(t):
                    v, moved = v.copy(), True
                    v[len(v) // 2] += np.float32(0.05) * normal
                yield t, v, f, ids

    ex = tx.stages.adapter.expectation(tx.stages.placement, tx.stages.relief, tx.stages.fused)
    with pytest.raises(texcad.GeometryError, match="lean tiles lie up to|vertices differ"):
        Off(tx.stages.relief.data).gate(ex)


def test_lean_tiles_on_a_limited_face_keep_the_limiters_facets(monkeypatch):
    """build_dir and a tolerance on a face made in tiles: the lean blocks keep the
    limiter's facet angle (lean_facets, the untiled lean slab's rule, face frame), so
    the part overhangs no more than the limited cells; within the tolerance; gated."""
    from texcad.printability import orientation, overhang_area
    from texcad.printability.overhang import lean_facets

    part = _holed()
    face = _top(part, 2.5)
    d = orientation(120, "-x")
    grid = _tiled(monkeypatch, part, face, tile=40, build_dir=d)
    tx = _tiled(monkeypatch, part, face, tile=40, build_dir=d, tolerance=0.02)
    assert tx.info["tolerance"] == 0.02 and 0 < tx.max_error <= 0.02 and tx.mesh.num_triangles < grid.mesh.num_triangles
    g = tx.gate
    assert g.shells.closed and abs(g.volume_change - g.expected_volume) <= g.volume_slack
    whole = tx.mesh.to_mesh()
    fr = tx.stages.placement.data
    local = texcad.Mesh(tx.mesh.grid.to_local(whole.vertices).astype(np.float32), whole.faces)
    up = (local.vertices[local.faces, 2] > 1e-6).any(axis=1)
    assert lean_facets(np.asarray(d) @ fr.axes.T, 45.0)(local.vertices, local.faces[up])
    assert overhang_area(whole, d) <= overhang_area(grid.mesh.to_mesh(), d) * (1 + 1e-7) + 1e-6
