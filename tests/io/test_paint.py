"""Slicer paint strings (texcad.io.paint): decoded against an independent sequential
reader written from PrusaSlicer's TriangleSelector::deserialize, against strings slicers
write, and read back by PrusaSlicer itself."""

import shutil
import subprocess
import zipfile

import numpy as np
import pytest

from texcad.errors import InputError
from texcad.io.paint import decode, encode_states, paint_by_points, read_project, split_painted, tree_string, write_painted_3mf
from texcad.solid import edge_report

# OrcaSlicer / BambuStudio Model.cpp, CONST_FILAMENTS: the whole-triangle string of
# filaments 1..32 as those slicers write them (PrusaSlicer writes 1..16 the same way).
CONST_FILAMENTS = ["4", "8", "0C", "1C", "2C", "3C", "4C", "5C", "6C", "7C", "8C", "9C", "AC", "BC", "CC", "DC",
                   "EC", "0FC", "1FC", "2FC", "3FC", "4FC", "5FC", "6FC", "7FC", "8FC", "9FC", "AFC", "BFC", "CFC", "DFC", "EFC"]

# Written by PrusaSlicer 2.x (``prusa-slicer --export-3mf`` of a project whose -y face
# of a 40 x 30 x 20 mm box, the triangle (20,-15,20) (-20,-15,20) (20,-15,0) here, is
# painted with extruder 2 for -3 < x < 7.5 mm and 4 < z < 13 mm, 6 levels deep).
SLICER_WRITTEN = (
    "000000888388083080033888380083000300030080030038808008330800830003330388000300803808833000"
    "30008808083388080083300808300338808838300008083003003800030880800833008008300033333"
)


def reference_decode(s):
    """PrusaSlicer's deserialize as a plain recursive reader: [(corners, state, depth)]."""
    nib = [int(c, 16) for c in reversed(s or "0")]
    pos = [0]

    def nxt():
        pos[0] += 1
        return nib[pos[0] - 1]

    out = []

    def node(c, d):
        code = nxt()
        k = code & 3
        if k == 0:
            st = code >> 2
            if st == 3:
                e = nxt()
                st = 3 + e if e != 15 else 18 + nxt()
            out.append((c, st, d))
            return
        s_ = code >> 2
        a, b, cc = c[s_ % 3], c[(s_ + 1) % 3], c[(s_ + 2) % 3]
        mab, mbc, mca = (a + b) / 2, (b + cc) / 2, (cc + a) / 2
        kids = {1: [(a, b, mbc), (mbc, cc, a)], 2: [(a, mab, mca), (mab, b, mca), (b, cc, mca)],
                3: [(a, mab, mca), (mab, b, mbc), (mbc, cc, mca), (mab, mbc, mca)]}[k]
        for i in range(k, -1, -1):  # children serialized last first
            node(np.array(kids[i]), d + 1)

    node(np.eye(3), 0)
    assert pos[0] == len(nib)
    return out


def random_tree(rng, depth, min_depth, max_depth):
    if depth >= max_depth or (depth >= min_depth and rng.random() < 0.45):
        return int(rng.choice([0, 1, 2, 3, 7, 16, 17, 18, 32]))
    k = int(rng.integers(1, 4))
    s = 0 if k == 3 else int(rng.integers(0, 3))
    first = random_tree(rng, depth + 1, min_depth, max_depth)  # one child goes at least min_depth deep
    return (k, s, [first] + [random_tree(rng, depth + 1, 0 if rng.random() < 0.5 else min_depth, max_depth) for _ in range(k)])


def _leaves(p, i):
    m = p.triangle == i
    return sorted((tuple(np.round(c, 12).ravel()), int(s), int(d)) for c, s, d in zip(p.corners[m], p.state[m], p.depth[m]))


def test_whole_triangles_match_the_slicers_table():
    assert encode_states(range(1, 33)) == CONST_FILAMENTS
    assert encode_states([0]) == [""]
    p = decode(CONST_FILAMENTS + ["", "0"])
    assert p.state.tolist() == list(range(1, 33)) + [0, 0]
    assert np.all(p.depth == 0) and np.allclose(p.corners, np.eye(3))


def test_random_trees_at_least_three_levels_deep_round_trip(rng):
    trees = [random_tree(rng, 0, 3, 6) for _ in range(200)]
    strings = [tree_string(t) for t in trees]
    p = decode(strings)
    assert p.depth.max() >= 5 and np.mean([max(d for *_, d in reference_decode(s)) >= 3 for s in strings]) == 1.0
    for i, s in enumerate(strings):  # per tree: the same leaves as the sequential reader
        ref = sorted((tuple(np.round(c, 12).ravel()), st, d) for c, st, d in reference_decode(s))
        assert _leaves(p, i) == ref
    # the leaves tile each triangle: barycentric areas add up to 1
    c = p.corners
    area = np.abs(np.linalg.det(c)) / 1.0  # |det| of the barycentric corners = area ratio
    assert np.allclose(np.bincount(p.triangle, area), 1.0)


def test_a_string_prusaslicer_wrote():
    p = decode([SLICER_WRITTEN])
    assert set(p.state.tolist()) == {0, 2} and p.depth.max() == 6
    assert [x for x in _leaves(p, 0)] == sorted((tuple(np.round(c, 12).ravel()), st, d) for c, st, d in reference_decode(SLICER_WRITTEN))
    tri = np.array([[[20, -15, 20], [-20, -15, 20], [20, -15, 0]]], float)
    pts = p.points(tri)
    painted = pts[p.state == 2].reshape(-1, 3)
    # the painted box of that face, to within a depth-6 leaf (40 / 64 mm)
    assert painted[:, 0].min() >= -3 - 0.7 and painted[:, 0].max() <= 7.5 + 0.7
    assert painted[:, 2].min() >= 4 - 0.7 and painted[:, 2].max() <= 13 + 0.7
    cen = pts.mean(axis=1)
    inside = (cen[:, 0] > -3 + 0.7) & (cen[:, 0] < 7.5 - 0.7) & (cen[:, 2] > 4 + 0.7) & (cen[:, 2] < 13 - 0.7)
    assert np.all(p.state[inside] == 2)


@pytest.mark.parametrize("bad", ["G1", "C", "3", "13", "F3", "0C0C", "44"])
def test_damaged_strings_are_refused(bad):
    with pytest.raises(InputError, match="paint string 1"):
        decode(["4", bad])


def test_paint_by_points_paints_what_the_function_says(rng):
    tri = rng.normal(size=(50, 3, 3)) * 10

    def state(p):
        return (p[:, 0] > 0).astype(int) + 2 * (p[:, 1] > 3)

    strings = paint_by_points(tri, state, 4)
    p = decode(strings)
    pts = p.points(tri)
    assert np.all(state(pts.mean(axis=1)) == p.state)
    area = np.linalg.norm(np.cross(pts[:, 1] - pts[:, 0], pts[:, 2] - pts[:, 0]), axis=1) / 2
    whole = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1) / 2
    assert np.allclose(np.bincount(p.triangle, area, len(tri)), whole)
    assert p.depth.max() == 4 and (p.depth < 4).any()  # uniform sub-trees merged
    for i, s in enumerate(strings[:10]):  # the sequential reader agrees
        assert len(reference_decode(s)) == int((p.triangle == i).sum())


def _icosphere():
    import trimesh

    m = trimesh.creation.icosphere(1, radius=10)
    return np.asarray(m.vertices), np.asarray(m.faces)


def test_split_painted_is_closed_and_keeps_the_area(rng):
    v, f = _icosphere()
    strings = [tree_string(random_tree(rng, 0, 3, 5)) if rng.random() < 0.6 else "" for _ in range(len(f))]
    V, F, S, P = split_painted(v, f, strings)
    rep = edge_report(F)
    assert rep["boundary"] == 0 and rep["nonmanifold"] == 0 and rep["misoriented"] == 0

    def area(a, b):
        t = a[b]
        return np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1) / 2

    assert np.isclose(area(V, F).sum(), area(v, f).sum(), rtol=1e-12)
    # each state's area is the decoded leaves' area, triangle by triangle
    p = decode([s for s in strings])
    la = area(p.points(v[f]).reshape(-1, 3), np.arange(3 * len(p.state)).reshape(-1, 3))
    for st in np.unique(p.state):
        assert np.isclose(area(V, F)[S == st].sum(), la[p.state == st].sum())
    assert np.all(np.bincount(P, minlength=len(f)) >= 1)


@pytest.mark.parametrize("dialect", ["prusa", "bambu"])
def test_projects_in_both_dialects(tmp_path, dialect):
    v, f = _icosphere()
    strings = paint_by_points(v[f], lambda p: (p[:, 2] > 4).astype(int) * 3, 3)
    fuzzy = encode_states((v[f].mean(axis=1)[:, 0] > 5).astype(int))
    tf = np.array([[0, -1, 0, 50], [1, 0, 0, 20], [0, 0, 1, 10]], float)  # 90 degrees about z, then moved
    path = tmp_path / f"p_{dialect}.3mf"
    write_painted_3mf(path, [("ball", v, f, {"color": strings, "fuzzy": fuzzy}, tf), ("plain", v + 30, f, {}, None)], dialect=dialect)
    with zipfile.ZipFile(path) as z:
        blob = b"".join(z.read(n) for n in z.namelist() if n.endswith(".model"))
    assert (b"slic3rpe:mmu_segmentation" in blob) == (dialect == "prusa") and (b"paint_color" in blob) == (dialect == "bambu")
    p = read_project(path)
    assert p.dialect == dialect and len(p.faces) == 2 * len(f) and len(p.parts) == 2
    assert p.states("color") == [3] and p.states("fuzzy") == [1] and p.states("seam") == []
    assert np.allclose(p.vertices[: len(v)], v @ tf[:, :3].T + tf[:, 3], atol=1e-4)
    assert p.paint["color"][: len(f)] == strings and p.paint["color"][len(f):] == [""] * len(f)


@pytest.mark.skipif(shutil.which("prusa-slicer") is None, reason="needs prusa-slicer")
def test_prusaslicer_reads_and_writes_our_strings(tmp_path):
    """PrusaSlicer slices our paint where we put it (extruder 2 between x -3 and 7.5 mm
    and z 4 and 13 mm of the box's -y face) and writes the strings back unchanged."""
    import trimesh

    m = trimesh.creation.box(extents=[40, 30, 20])
    m.apply_translation([0, 0, 10])
    v, f = np.asarray(m.vertices), np.asarray(m.faces)

    def state(p):
        return ((p[:, 1] < -14.99) & (p[:, 0] > -3) & (p[:, 0] < 7.5) & (p[:, 2] > 4) & (p[:, 2] < 13)).astype(int) * 2

    strings = paint_by_points(v[f], state, 6)
    src = tmp_path / "box.3mf"
    write_painted_3mf(src, [("box", v, f, {"color": strings}, None)])
    again = tmp_path / "again.3mf"
    subprocess.run(["prusa-slicer", "--export-3mf", "-o", str(again), str(src)], check=True, capture_output=True, timeout=300)
    assert sorted(s for s in read_project(again).paint["color"] if s) == sorted(s for s in strings if s)
    assert SLICER_WRITTEN in read_project(again).paint["color"]
    gcode = tmp_path / "box.gcode"
    subprocess.run(["nice", "-n", "10", "prusa-slicer", "--export-gcode", "-o", str(gcode), "--nozzle-diameter", "0.4,0.4",
                    "--no-wipe-tower", "--layer-height", "0.2", "--perimeters", "1", "--fill-density", "0",
                    "--top-solid-layers", "0", "--bottom-solid-layers", "0", "--skirts", "0", str(src)],
                   check=True, capture_output=True, timeout=600)
    tool, x, y, z, t1, t0 = 0, 0.0, 0.0, 0.0, [], []
    for line in gcode.read_text().splitlines():  # per G-code line
        if line[:1] == "T" and line[1:].strip().isdigit():
            tool = int(line[1:])
        elif line.startswith("G1"):
            w = dict((c[0], float(c[1:])) for c in line.split(";")[0].split()[1:] if c[0] in "XYZE")
            nx, ny, z = w.get("X", x), w.get("Y", y), w.get("Z", z)
            if w.get("E", 0) > 0 and ("X" in w or "Y" in w):
                (t1 if tool == 1 else t0).append((x, nx, min(y, ny), z))
            x, y = nx, ny
    t0, t1 = np.array(t0), np.array(t1)
    lo = t0[:, :2].min()  # the box's -x side, 0.2 mm in (perimeter half width)
    face = t1[t1[:, 2] < t0[:, 2].min() + 1.0]  # extruder 2 on the -y face
    assert len(face) > 20
    assert abs(face[:, :2].min() - lo - 17.0) < 0.8 and abs(face[:, :2].max() - lo - 27.5) < 0.8
    assert 4.0 <= face[:, 3].min() <= 4.8 and 12.6 <= face[:, 3].max() <= 13.4


def test_modifiers_are_not_the_surface(tmp_path):
    """A PrusaSlicer object whose mesh holds a modifier volume: its triangles are left out."""
    v, f = _icosphere()
    strings = encode_states(np.ones(len(f), dtype=int))
    vv, ff = np.concatenate([v, v * 0.3]), np.concatenate([f, f + len(v)])
    path = tmp_path / "mod.3mf"
    write_painted_3mf(path, [("ball", vv, ff, {"color": strings + [""] * len(f)}, None)])
    with zipfile.ZipFile(path, "a") as z:
        z.writestr("Metadata/Slic3r_PE_model.config",
                   f'<config><object id="1" instances_count="1"><volume firstid="0" lastid="{len(f) - 1}">'
                   '<metadata type="volume" key="volume_type" value="ModelPart"/></volume>'
                   f'<volume firstid="{len(f)}" lastid="{2 * len(f) - 1}">'
                   '<metadata type="volume" key="volume_type" value="ParameterModifier"/></volume></object></config>')
    p = read_project(path)
    assert len(p.faces) == len(f) and p.paint["color"] == strings
