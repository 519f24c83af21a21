"""Mesh targets in blocks (issue 30, :mod:`texcad.targets.tiled_mesh`): the same
triangles and float32 vertices as the untiled pitch grid, closed across block borders
with each border vertex once, the volume change against the swept volume; a mesh that
does not fit untiled made in blocks under an address-space limit; what is not made in
blocks refused, naming a pitch that fits."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from dataclasses import replace

import numpy as np
import pytest
import trimesh

import texcad
from texcad.errors import GeometryError
from texcad.io import read_mesh
from texcad.targets import mesh as mesh_target
from texcad.targets import tiled_mesh

KW = dict(height=0.6, tolerance=0, border=1.5)


def _box():
    b = trimesh.creation.box((30.0, 20.0, 10.0))
    b.apply_translation((0, 0, 5.0))
    return b


def _two():
    """Two bodies: a box and a sphere apart."""
    a = trimesh.creation.box((10.0, 10.0, 10.0))
    b = trimesh.creation.icosphere(2, 5.0)
    b.apply_translation((20.0, 0, 0))
    return trimesh.util.concatenate([a, b])


def _cylinder():
    c = trimesh.creation.cylinder(radius=9.0, height=16.0, sections=40)
    c.apply_translation((0, 0, 8.0))
    return c


CASES = {
    "sphere triplanar": (lambda: trimesh.creation.icosphere(3, 10.0), "all", dict(pitch=0.5)),
    "box raised, bed face kept": (_box, "all", dict(pitch=0.5, projection="planar:+x")),
    "cylinder cylindrical centred": (_cylinder, "all", dict(pitch=0.5, mode="centred", projection="cylindrical")),
    "two bodies, a normal region": (_two, "normal:+z:60", dict(pitch=0.3)),
    "box with build_dir, no overhang at a border": (_box, "all", dict(pitch=0.5, projection="planar:+x", build_dir=(0, 0, 1))),
    "sphere, two zones apart, each its own pitch and height, build_dir": (
        lambda: trimesh.creation.icosphere(3, 10.0),
        [("normal:+z:60", "builtin:stones", {"pitch": 0.4}), ("normal:-z:60", "builtin:pins", {"pitch": 0.6, "height": 0.4})],
        dict(pitch=0.5, build_dir=(0, 0, 1))),
}


def _blocks(monkeypatch, target, where, per_block, **kw):
    """``texcad.texture`` with the untiled estimate made larger than any machine (the
    switch is what is tested) and blocks of ``per_block`` refined triangles."""
    with monkeypatch.context() as m:
        m.setattr(mesh_target, "untiled_bytes", lambda triangles: 1e18)
        m.setattr(tiled_mesh, "_block_triangles", lambda coarse, pitch, *per: per_block)
        return texcad.texture(target, where, "builtin:stones", **kw)


def _triangles(v, f):
    """Triangles as sets of their corners' float32 bytes (rotation-free)."""
    v = np.asarray(v, np.float32)
    return {tuple(sorted(map(bytes, v[t]))) for t in np.asarray(f)}


@pytest.mark.parametrize("case", list(CASES))
def test_blocks_make_the_untiled_mesh(case, monkeypatch, tmp_path):
    make, where, kw = CASES[case]
    part = make()
    flat = texcad.texture(part, where, "builtin:stones", **KW, **kw)
    tx = _blocks(monkeypatch, part, where, 3000, **KW, **kw)
    assert tx.info["fuse"] == "tiled" and tx.info["blocks"] >= 3
    whole = tx.mesh.to_mesh()
    # the same triangles on the same float32 points (the blocks' vertex normals and samples are the untiled ones)
    assert _triangles(whole.vertices, whole.faces) == _triangles(flat.mesh.vertices, flat.mesh.faces)
    # every vertex once: no border vertex twice, none unused
    assert len(np.unique(whole.vertices, axis=0)) == len(whole.vertices) == len(flat.mesh.vertices)
    assert np.array_equal(np.unique(whole.faces), np.arange(len(whole.vertices)))
    assert whole.is_watertight and tx.gate.shells.closed
    assert tx.gate.shells.bodies == flat.gate.shells.bodies
    assert abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack
    assert whole.volume == pytest.approx(flat.mesh.volume, rel=1e-9)
    # streamed: the STL's triangles and the 3MF's vertices (each once) and triangles
    tx.export(tmp_path / "t.stl")
    tx.export(tmp_path / "t.3mf")
    assert (tmp_path / "t.stl").stat().st_size == 84 + 50 * len(whole.faces)
    back = read_mesh(tmp_path / "t.3mf")
    assert len(back.vertices) == len(whole.vertices) and len(back.faces) == len(whole.faces)


def test_the_block_gate_catches_a_gap(monkeypatch):
    """Block 2's vertices moved by 1 um: its border vertices differ from its
    neighbours' and the gate says so."""
    made = tiled_mesh._displace

    def shifted(plan, b, *rest):
        r = made(plan, b, *rest)
        if not np.array_equal(np.unique(b.near[b.src[b.own]]), plan.blocks[0]):  # not the first block
            return replace(r, v=r.v + np.float32(1e-3))
        return r

    monkeypatch.setattr(tiled_mesh, "_displace", shifted)
    with pytest.raises(GeometryError, match="differ between neighbouring blocks"):
        _blocks(monkeypatch, trimesh.creation.icosphere(3, 10.0), "all", 6000, pitch=0.5, **KW)


def test_layers_that_meet_are_made_in_blocks_with_the_untiled_relief_volume(monkeypatch):
    """Two layers that meet and overlap (stones on a cylinder's top, pins on all of
    it, a cylindrical projection fixed from its own region): the regions are bisected
    layer by layer and each edge cut by the finest pitch of its faces' layers, where
    the untiled refinement cuts the mesh its first layer refined again: other
    triangles (and so another mean radius for the projection), closed with each
    vertex once, the relief volume to 0.5 %."""
    part = _cylinder()
    where = [("normal:+z:30", "builtin:stones", {}), ("all", "builtin:pins", {"projection": "cylindrical", "height": 0.3})]
    flat = texcad.texture(part, where, "builtin:stones", **KW, pitch=0.5)
    tx = _blocks(monkeypatch, part, where, 3000, **KW, pitch=0.5)
    whole = tx.mesh.to_mesh()
    assert tx.info["fuse"] == "tiled" and tx.info["blocks"] >= 3 and len(tx.mesh.plan.layers) == 2
    assert whole.is_watertight and len(np.unique(whole.vertices, axis=0)) == len(whole.vertices)
    assert 0.85 * len(flat.mesh.faces) < len(whole.faces) < 1.15 * len(flat.mesh.faces)
    assert _triangles(whole.vertices, whole.faces) != _triangles(flat.mesh.vertices, flat.mesh.faces)
    assert tx.gate.volume_change == pytest.approx(flat.gate.volume_change, rel=5e-3)
    assert abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack


def test_painted_zones_in_blocks(monkeypatch, tmp_path):
    """Two painted zones that touch on a box's side (a PrusaSlicer project), each its
    own texture and height, with build_dir: made in blocks, closed with each vertex
    once, the zones named as untiled, the relief volume to 0.5 %."""
    from texcad.io.paint import paint_by_points, write_painted_3mf

    box = trimesh.creation.box((40.0, 30.0, 20.0))
    box.apply_translation((0, 0, 10.0))
    v, f = np.asarray(box.vertices), np.asarray(box.faces)

    def zones(p):  # 1 for -14 < x < 0, 2 for 0 < x < 14 on the +y face, 4 < z < 16 mm
        on = (p[:, 1] > 14.99) & (p[:, 2] > 4) & (p[:, 2] < 16)
        return np.where(on & (p[:, 0] > -14) & (p[:, 0] < 0), 1, np.where(on & (p[:, 0] > 0) & (p[:, 0] < 14), 2, 0))

    path = tmp_path / "box.3mf"
    write_painted_3mf(path, [("box", v, f, {"color": paint_by_points(v[f], zones, 5)}, np.eye(3, 4))], dialect="prusa")
    where = {"paint:1": ("builtin:stones", {"height": 0.4}), "paint:2": ("builtin:diamond_knurl", {"height": 0.8})}
    kw = dict(pitch=0.5, border=1.0, tolerance=0, build_dir=(0, 0, 1))
    flat = texcad.texture(path, where, **kw)
    with monkeypatch.context() as m:
        m.setattr(mesh_target, "untiled_bytes", lambda triangles: 1e18)
        m.setattr(tiled_mesh, "_block_triangles", lambda coarse, pitch, *per: 3000)
        tx = texcad.texture(path, where, **kw)
    whole = tx.mesh.to_mesh()
    assert tx.info["fuse"] == "tiled" and tx.info["blocks"] >= 2 and tx.info["zones"] == flat.info["zones"]
    assert whole.is_watertight and len(np.unique(whole.vertices, axis=0)) == len(whole.vertices)
    assert tx.gate.volume_change == pytest.approx(flat.gate.volume_change, rel=5e-3)
    assert abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack


def _on_untiled(flat, tx):
    """The blocks' displacements (mm, after their limiters) on the untiled mesh's
    vertices (matched by their undisplaced float64 bytes), and the blocks' border
    vertices there (bool)."""
    r = flat.stages.relief.data
    parts = list(tx.mesh.displaced())
    v0 = np.concatenate([p.v0 for p in parts])
    both = np.concatenate([r.v, v0]).view(np.dtype((np.void, 24))).ravel()
    _, inv = np.unique(both, return_inverse=True)
    inv = inv.ravel()
    at = np.full(inv.max() + 1, -1)
    at[inv[:len(r.v)]] = np.arange(len(r.v))
    where = at[inv[len(r.v):]]
    assert (where >= 0).all()
    d = np.zeros(len(r.v))
    d[where] = np.concatenate([p.d for p in parts])
    border = np.zeros(len(r.v), dtype=bool)
    start = np.cumsum([0] + [len(p.v0) for p in parts])
    for k, p in enumerate(parts):  # per block: its open edges' ends
        border[where[start[k] + np.unique(tiled_mesh.open_edges(p.f)[0])]] = True
    return d, border


def test_the_overhang_limiter_in_blocks_leaves_no_overhang_and_differs_only_next_to_borders(monkeypatch):
    """build_dir on a sphere (its lower half overhangs) in 7 blocks: each block limits
    its own faces and the faces across its border (an open surface: ridges tested at
    its edges of two faces), a point next to a border it lowers is pinned for all
    blocks and the blocks whose pins changed made again (from where their limiters
    left them) until none lowers one. The limiter run again on the blocks' result (the untiled mesh's
    vertices and offset directions) lowers nothing: no face overhangs or folds and no
    ridge is too flat, across the borders too. The displacements equal the untiled
    ones except in clusters the limiter lowered across a border (its rounds start
    there from the pinned depth): a few percent of the vertices, each within a few
    pitches of a border, and the relief volume within 0.5 %."""
    from texcad.printability.relief import limit_relief

    kw = dict(KW, pitch=0.5, build_dir=(0, 0, 1))
    part = trimesh.creation.icosphere(3, 10.0)
    flat = texcad.texture(part, "all", "builtin:stones", **kw)
    tx = _blocks(monkeypatch, part, "all", 3000, **kw)
    whole = tx.mesh.to_mesh()
    assert tx.info["blocks"] >= 5 and tx.mesh.__dict__["passes"] > 1 and len(tx.mesh.__dict__["pins"][0]) > 0
    assert whole.is_watertight and len(np.unique(whole.vertices, axis=0)) == len(whole.vertices) == len(flat.mesh.vertices)
    r = flat.stages.relief.data
    d, border = _on_untiled(flat, tx)
    again, rep = limit_relief(r.v, r.f, r.normals, d, build_dir=(0, 0, 1))
    assert rep.lowered == rep.overhang_faces == rep.folded_faces == rep.steep_ridges == 0
    differ = d != r.d
    assert 0 < differ.sum() <= 0.05 * len(d)
    from scipy.spatial import cKDTree

    assert cKDTree(r.v[border]).query(r.v[differ])[0].max() <= 6 * kw["pitch"]
    assert tx.gate.volume_change == pytest.approx(flat.gate.volume_change, rel=5e-3)
    assert abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack


def test_the_limiter_on_an_open_block_is_the_limiter_on_it_closed_by_a_copy():
    """A block's faces are an open surface: the limiter tests the ridges at its
    edges of two faces and none at its border, and so lowers exactly what it lowers
    on that surface closed by a copy of it (every face and its copy test alike, a
    border edge lies in a face and its copy: one plane, no ridge), as the blocks did
    before at twice the cost (and where no edge inside joins two border points: the copy
    would put it in four faces). On the lower half of a sphere (overhanging) with
    random displacements: steep ridges found, the same displacements to the bit."""
    from texcad.printability.relief import limit_relief

    s = trimesh.creation.icosphere(4, 10.0)
    used, f = np.unique(s.faces[s.triangles_center[:, 2] < 0.0], return_inverse=True)
    f = f.reshape(-1, 3)
    v, n = np.asarray(s.vertices)[used], np.asarray(s.vertex_normals)[used]
    d = np.random.default_rng(3).uniform(0.0, 0.8, len(v))
    rim = np.zeros(len(v), dtype=bool)
    rim[tiled_mesh.open_edges(f)[0].ravel()] = True
    copy = np.flatnonzero(~rim)
    to = np.arange(len(v))
    to[copy] = len(v) + np.arange(len(copy))
    opened, rep = limit_relief(v, f, n, d, build_dir=(0, 0, 1))
    closed, _ = limit_relief(np.concatenate([v, v[copy]]), np.concatenate([f, to[f]]), np.concatenate([n, n[copy]]),
                             np.concatenate([d, d[copy]]), build_dir=(0, 0, 1))
    assert rep.steep_ridges > 0 and rep.lowered > 0
    assert np.array_equal(opened, closed[:len(v)])


def test_a_block_skipped_in_a_later_pass_is_numbered_as_when_made(monkeypatch):
    """The blocks not made again in a later pass (their pins unchanged) still take
    their numbers from their coarse faces alone, the same as made."""
    part = trimesh.creation.icosphere(3, 10.0)
    tx = _blocks(monkeypatch, part, "all", 3000, **KW, pitch=0.5, build_dir=(0, 0, 1))
    plan = tx.mesh.plan
    made, skipped = tiled_mesh._Numbering(plan), tiled_mesh._Numbering(plan)
    for blk in plan.blocks:  # per block
        made.ids(plan, tiled_mesh.fine_block(plan, blk))
        skipped.skip(plan, blk)
        assert (made.start, made.next) == (skipped.start, skipped.next)
    assert np.array_equal(made.coarse, skipped.coarse) and np.array_equal(made.edge, skipped.edge)


def test_coarse_faces_of_more_pitches_where_the_untiled_ones_would_not_fit(monkeypatch):
    """Where even the coarse mesh of 3 pitches would not fit, its faces span more
    (here 12: the box's input faces are not bisected at all): other triangles than
    untiled, still closed with each vertex once, and the same relief volume to 0.1 %."""
    part = _box()
    flat = texcad.texture(part, "all", "builtin:stones", **KW, pitch=0.3)
    monkeypatch.setattr(tiled_mesh, "_coarse_factor", lambda refined, faces, pitch: 12.0)
    tx = _blocks(monkeypatch, part, "all", 20000, **KW, pitch=0.3)
    whole = tx.mesh.to_mesh()
    assert tx.info["coarse_pitches"] == 12 and tx.info["coarse_triangles"] < len(flat.mesh.faces) / 50
    assert whole.is_watertight and len(np.unique(whole.vertices, axis=0)) == len(whole.vertices)
    assert 0.5 * len(flat.mesh.faces) < len(whole.faces) < 1.5 * len(flat.mesh.faces)
    assert tx.gate.volume_change == pytest.approx(flat.gate.volume_change, rel=1e-3)
    assert abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack


def test_folds_across_block_borders_are_limited_alike_on_both_sides(monkeypatch):
    """An engraved texture folds along a box's edges, across block borders: each
    block limits its own faces, a border vertex it lowers is pinned for all blocks and
    the blocks made again until they agree. The mesh is closed with each border
    vertex once, and differs from the untiled one at most at a few vertices round the
    pinned ones (the fold limiter's rounds start there from the pinned depth)."""
    kw = dict(KW, pitch=0.5, mode="engraved", projection="planar:+x")
    with pytest.warns(texcad.TexcadWarning, match="fold over"):
        flat = texcad.texture(_box(), "all", "builtin:stones", **kw)
    with pytest.warns(texcad.TexcadWarning, match="fold over"):
        tx = _blocks(monkeypatch, _box(), "all", 6000, **kw)
    whole = tx.mesh.to_mesh()
    assert tx.mesh.__dict__["passes"] > 1 and len(tx.mesh.__dict__["pins"][0]) > 0  # the case this test is for
    assert whole.is_watertight and len(np.unique(whole.vertices, axis=0)) == len(whole.vertices) == len(flat.mesh.vertices)
    ours = {bytes(x) for x in whole.vertices}
    differ = len(ours - {bytes(x) for x in np.asarray(flat.mesh.vertices, np.float32)})
    assert differ <= 0.01 * len(whole.vertices)
    assert whole.volume == pytest.approx(flat.mesh.volume, rel=1e-3)
    assert abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack


#: The start of the child scripts run under an address-space limit: imports, a warm-up,
#: ``vm(key)`` (bytes of a /proc/self/status line), ``limit`` (400 MB over the process's
#: size) and ``held`` (what it holds).
_LIMITED = textwrap.dedent("""
    import resource, time
    import scipy.sparse.csgraph, scipy.spatial, trimesh
    import texcad
    from texcad.targets import mesh as mesh_target
    from texcad.util.resources import _rss
    texcad.texture(trimesh.creation.icosphere(1, 5.0), "all", "builtin:stones", pitch=1.0, tolerance=0)  # warmed up
    def vm(key):
        return int(open("/proc/self/status").read().split(key)[1].split()[0]) * 1024
    limit = vm("VmSize:") + (400 << 20)
    held = _rss()
""")


def test_a_mesh_that_does_not_fit_untiled_is_made_in_blocks_under_an_address_space_limit(tmp_path):
    """A sphere of radius 40 mm at 0.25 mm (1.3 M triangles; about 550 MB untiled, by
    the estimate more than the bound; 545 MB measured) through texcad.texture under
    max_memory 220 MB over what the process holds and an address-space limit
    (RLIMIT_AS) of 400 MB over its size: made in blocks, gated, streamed to an STL."""
    out = tmp_path / "big.stl"
    script = _LIMITED + textwrap.dedent(f"""
        bound = held + (220 << 20)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        part = trimesh.creation.icosphere(5, 40.0)
        t0 = time.process_time()
        tx = texcad.texture(part, "all", "builtin:stones", pitch=0.25, height=0.5, tolerance=0, max_memory=bound)
        tx.export({str(out)!r})
        g = tx.gate
        print(tx.info["fuse"], tx.info["blocks"], tx.mesh.num_triangles, g.shells.closed,
              abs(g.volume_change - g.expected_volume) <= g.volume_slack, vm("VmPeak:") <= limit,
              mesh_target.untiled_bytes(tx.mesh.num_triangles) > (220 << 20), time.process_time() - t0)
    """)
    env = dict(os.environ, MALLOC_ARENA_MAX="1")  # the limit is for the job's arrays, not glibc's per-thread arenas
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600, env=env)
    assert res.returncode == 0, res.stderr[-2000:]
    how, blocks, tris, closed, volume_ok, under, too_big, cpu = res.stdout.split()
    print(f"blocks {blocks}, {tris} triangles, {float(cpu):.1f} CPU s")
    assert how == "tiled" and int(blocks) > 1 and int(tris) > 1_000_000
    assert closed == volume_ok == under == too_big == "True"
    assert out.stat().st_size == 84 + 50 * int(tris)


@pytest.mark.slow
def test_build_dir_in_blocks_under_an_address_space_limit(tmp_path):
    """build_dir on a sphere of radius 25 mm at 0.3 mm (296 K triangles; by the
    estimate more than the bound untiled) under max_memory 70 MB over what the
    process holds and an address-space limit of 400 MB over its size, on a machine
    that has (the child is told) only 16 MB free: the blocks are sized from the bound
    (LIMITED_BYTES a triangle), not from what the machine has free, limited across
    their borders, gated, streamed to an STL, the peak resident memory over the
    process within 1.25 times the bound. The peak is the child's own high-water mark
    (VmHWM): its ru_maxrss starts at its parent's (Linux keeps the replaced memory
    map's high-water mark across exec), the pytest worker's hundreds of MB in a
    full run."""
    out = tmp_path / "limited.stl"
    script = _LIMITED + textwrap.dedent(f"""
        from texcad.util import resources
        resources._meminfo_available = resources._cgroup_left = lambda: 16 << 20  # a loaded machine
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        part = trimesh.creation.icosphere(5, 25.0)
        tx = texcad.texture(part, "all", "builtin:stones", pitch=0.3, height=0.5, tolerance=0, max_memory=held + (70 << 20),
                            build_dir=(0, 0, 1))
        tx.export({str(out)!r})
        g = tx.gate
        peak = vm("VmHWM:") - held
        print(tx.info["fuse"], tx.info["blocks"], tx.mesh.num_triangles, tx.mesh.__dict__["passes"], g.shells.closed,
              abs(g.volume_change - g.expected_volume) <= g.volume_slack, vm("VmPeak:") <= limit, peak <= 1.25 * (70 << 20),
              mesh_target.untiled_bytes(tx.mesh.num_triangles) > (70 << 20), peak >> 20)
    """)
    env = dict(os.environ, MALLOC_ARENA_MAX="1")
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=900, env=env)
    assert res.returncode == 0, res.stderr[-2000:]
    how, blocks, tris, passes, closed, volume_ok, under, bounded, too_big, peak = res.stdout.split()
    assert how == "tiled" and int(blocks) > 4 and int(tris) > 250_000 and int(passes) > 1, res.stdout
    assert closed == volume_ok == under == bounded == too_big == "True", res.stdout
    assert out.stat().st_size == 84 + 50 * int(tris)


def test_blocks_go_with_max_memory_not_with_what_the_machine_has_free(monkeypatch, tmp_path):
    """Under max_memory the blocks (and so, with build_dir, the bytes where an
    overhang crosses their borders) are sized from the bound: the same STL with a
    terabyte free and with 16 MB free (the machine loaded by other processes)."""
    from texcad.util import resources
    from texcad.util.resources import _rss

    part = trimesh.creation.icosphere(3, 20.0)
    plans = []
    for k, free in enumerate((1 << 40, 16 << 20)):  # per machine
        bound = _rss() + (76 << 20)  # what the process holds counts: about 55 000 triangles a block (49 152 then)
        with monkeypatch.context() as m:
            m.setattr(mesh_target, "untiled_bytes", lambda triangles: 1e18)
            m.setattr(resources, "_meminfo_available", lambda: free)
            m.setattr(resources, "_cgroup_left", lambda: free)
            tx = texcad.texture(part, "all", "builtin:stones", **KW, pitch=0.5, build_dir=(0, 0, 1), max_memory=bound)
        tx.export(tmp_path / f"{k}.stl")
        plans.append((tx.info["fuse"], tx.info["blocks"], tx.info["coarse_pitches"], (tmp_path / f"{k}.stl").read_bytes()))
        del tx
    assert plans[0][0] == "tiled" and plans[0][1] >= 2 and plans[0] == plans[1]


def test_the_cli_makes_a_mesh_in_blocks(tmp_path, monkeypatch, capsys):
    """``texcad texture part.stl`` where the untiled mesh does not fit: made in
    blocks, summarised, its STL and 3MF streamed with the same triangles."""
    from texcad.cli import main

    part = tmp_path / "ball.stl"
    trimesh.creation.icosphere(3, 10.0).export(part)
    with monkeypatch.context() as m:
        m.setattr(mesh_target, "untiled_bytes", lambda triangles: 1e18)
        m.setattr(tiled_mesh, "_block_triangles", lambda coarse, pitch, *per: 6000)
        assert main(["texture", str(part), "-o", str(tmp_path / "t.stl"), "-o", str(tmp_path / "t.3mf"), "--pitch", "0.5",
                     "--max-memory", "4GB", "--quiet"]) == 0
    out = capsys.readouterr().out
    tris = int(out.split("triangles    ")[1].split(",")[0])
    assert "watertight True" in out and tris > 10_000
    assert (tmp_path / "t.stl").stat().st_size == 84 + 50 * tris
    stl, tmf = read_mesh(tmp_path / "t.stl"), read_mesh(tmp_path / "t.3mf")  # the 3MF's vertices in decimals
    assert len(tmf.faces) == len(stl.faces) == tris and len(tmf.vertices) == len(stl.vertices)
    assert np.abs(np.sort(tmf.vertices, axis=0) - np.sort(stl.vertices, axis=0)).max() < 1e-4  # 4 decimals


def test_blocks_on_a_local_dask_cluster_give_the_bytes_made_here(monkeypatch, tmp_path):
    """build_dir on a sphere in blocks (pins across borders, several passes) made on a
    local Dask cluster of two worker processes: the same STL bytes as made in this
    process (the blocks of one colour are made from the same pins, wherever)."""
    distributed = pytest.importorskip("distributed")
    part = trimesh.creation.icosphere(3, 10.0)
    kw = dict(KW, pitch=0.5, build_dir=(0, 0, 1))
    here = _blocks(monkeypatch, part, "all", 3000, **kw)
    here.export(tmp_path / "here.stl")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=50) as cluster, distributed.Client(cluster) as client:
        there = _blocks(monkeypatch, part, "all", 3000, client=client, **kw)
        assert there.mesh.client is client and len(client.scheduler_info()["workers"]) == 2
        there.export(tmp_path / "there.stl")
    assert here.mesh.__dict__["passes"] > 1 and len(here.mesh.__dict__["pins"][0]) > 0 and here.info["blocks"] >= 5
    assert there.mesh.__dict__["passes"] == here.mesh.__dict__["passes"]
    assert (tmp_path / "there.stl").read_bytes() == (tmp_path / "here.stl").read_bytes()
