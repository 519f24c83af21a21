"""paint:N regions and zones on meshes: only the painted area moves (checked against
the paint's own geometry, decoded by a plain sequential reader, not texcad's), each
zone gets its own texture with a clean border, and the 3MF keeps each zone a part."""

import re
import shutil
import subprocess
import zipfile

import numpy as np
import pytest

import texcad
from texcad.errors import InputError, ParameterError
from texcad.io.paint import encode_states, paint_by_points, write_painted_3mf
from texcad.mapping.region import Region


def _leaves(s):
    """[(corners (3, 3) barycentric, state)] of one paint string (PrusaSlicer's
    TriangleSelector::deserialize, written out plainly)."""
    nib, pos, out = [int(c, 16) for c in reversed(s or "0")], [0], []

    def nxt():
        pos[0] += 1
        return nib[pos[0] - 1]

    def node(c):
        code = nxt()
        k = code & 3
        if k == 0:
            st = code >> 2
            out.append((c, st if st < 3 else 3 + nxt()))
            return
        a, b, cc = c[(code >> 2) % 3], c[((code >> 2) + 1) % 3], c[((code >> 2) + 2) % 3]
        mab, mbc, mca = (a + b) / 2, (b + cc) / 2, (cc + a) / 2
        kids = {1: [(a, b, mbc), (mbc, cc, a)], 2: [(a, mab, mca), (mab, b, mca), (b, cc, mca)],
                3: [(a, mab, mca), (mab, b, mbc), (mbc, cc, mca), (mab, mbc, mca)]}[k]
        for i in range(k, -1, -1):
            node(np.array(kids[i]))

    node(np.eye(3))
    return out


def _box():
    import trimesh

    m = trimesh.creation.box(extents=[40, 30, 20])
    m.apply_translation([0, 0, 10])
    return np.asarray(m.vertices), np.asarray(m.faces)


def _zones(p):
    """Two touching zones on the +y face (y = 15): 1 for -14 < x < 0, 2 for 0 < x < 14,
    both 4 < z < 16 mm."""
    on = (p[:, 1] > 14.99) & (p[:, 2] > 4) & (p[:, 2] < 16)
    return np.where(on & (p[:, 0] > -14) & (p[:, 0] < 0), 1, np.where(on & (p[:, 0] > 0) & (p[:, 0] < 14), 2, 0))


@pytest.fixture(params=["prusa", "bambu"])
def painted_box(request, tmp_path):
    v, f = _box()
    strings = paint_by_points(v[f], _zones, 5)
    path = tmp_path / f"box_{request.param}.3mf"
    tf = np.array([[1, 0, 0, 100], [0, 1, 0, 100], [0, 0, 1, 0]], float)
    write_painted_3mf(path, [("box", v, f, {"color": strings}, tf)], dialect=request.param)
    tri = v[f] + [100, 100, 0]
    leaves = {1: [], 2: []}
    for t, s in zip(tri, strings):  # per painted triangle: its leaves in space
        for c, st in _leaves(s):
            if st in leaves:
                leaves[st].append(c @ t)
    return path, {k: np.array(x) for k, x in leaves.items()}


def _part_names(path):
    """The part names of a written project (PrusaSlicer volumes or BambuStudio parts)."""
    with zipfile.ZipFile(path) as z:
        if "Metadata/Slic3r_PE_model.config" in z.namelist():
            return re.findall(r'<volume\b.*?key="name" value="([^"]*)"', z.read("Metadata/Slic3r_PE_model.config").decode(), re.S)
        return re.findall(r'<part\b.*?key="name" value="([^"]*)"', z.read("Metadata/model_settings.config").decode(), re.S)


def _inside(pts, tris, tol=1e-3):
    """Which points (x, z) lie in any of the triangles (x, z) (brute force)."""
    a, b, c = tris[:, 0][:, [0, 2]], tris[:, 1][:, [0, 2]], tris[:, 2][:, [0, 2]]
    p = pts[:, None, [0, 2]]

    def side(u, w):
        return (w[None, :, 0] - u[None, :, 0]) * (p[..., 1] - u[None, :, 1]) - (w[None, :, 1] - u[None, :, 1]) * (p[..., 0] - u[None, :, 0])

    s1, s2, s3 = side(a, b), side(b, c), side(c, a)
    return (((s1 >= -tol) & (s2 >= -tol) & (s3 >= -tol)) | ((s1 <= tol) & (s2 <= tol) & (s3 <= tol))).any(axis=1)


def test_only_the_painted_zones_move_each_with_its_texture(painted_box, tmp_path):
    path, leaves = painted_box
    zones = {"paint:1": ("builtin:stones", {"height": 0.4}), "paint:2": ("builtin:diamond_knurl", {"height": 0.8}), "normal:+z:30": None}
    tx = texcad.texture(path, zones, pitch=0.5, border=1.0)
    v = tx.mesh.vertices.astype(np.float64)
    assert tx.mesh.is_watertight and tx.info["zones"] == ["paint:1 builtin:stones", "paint:2 builtin:diamond_knurl"]
    lo, hi = np.array([80, 85, 0.0]), np.array([120, 115, 20.0])
    inside_box = np.all((v >= lo - 1e-3) & (v <= hi + 1e-3), axis=1)
    on_surface = inside_box & np.any((np.abs(v - lo) < 1e-3) | (np.abs(v - hi) < 1e-3), axis=1)
    moved = ~on_surface
    assert moved.sum() > 500
    # every moved vertex stands out of the +y face, over the paint of its zone
    assert np.all(v[moved, 1] > 115)
    in1, in2 = _inside(v[moved], leaves[1]), _inside(v[moved], leaves[2])
    assert np.all(in1 | in2)
    rise = v[moved, 1] - 115
    assert rise[in1 & ~in2].max() <= 0.4 + 1e-3 and rise[in2 & ~in1].max() > 0.5  # each zone its own height
    # clean border between the zones: nothing on x = 100 moves
    assert not np.any(moved & (np.abs(v[:, 0] - 100) < 1e-3))
    # and inside the zones, away from their borders (1 mm), most vertices moved
    face = on_surface & (np.abs(v[:, 1] - 115) < 1e-3) | moved
    core = face & (np.abs(v[:, 0] - 100) > 1.5) & (np.abs(v[:, 0] - 100) < 12.5) & (v[:, 2] > 5.5) & (v[:, 2] < 14.5)
    assert moved[core].mean() > 0.5
    # the zones stay parts: one object, base + one part per zone
    out = tmp_path / "zones.3mf"
    tx.export(out, separate_texture=True)
    assert _part_names(out) == ["base", "paint:1 builtin:stones", "paint:2 builtin:diamond_knurl"]
    if shutil.which("prusa-slicer") and "bambu" not in path.name:  # PrusaSlicer 2.5 reads no BambuStudio project
        info = subprocess.run(["prusa-slicer", "--info", str(out)], capture_output=True, text=True, timeout=300).stdout
        assert info.count("number_of_parts") == 1 and re.search(r"number_of_parts\s*=\s*3", info)
        assert "manifold = yes" in info


def test_whole_painted_triangles(tmp_path):
    """Triangles painted whole (no subdivision): the region is those faces."""
    import trimesh

    m = trimesh.creation.cylinder(radius=10, height=30, sections=24)
    m.apply_translation([0, 0, 15])
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    c = v[f].mean(axis=1)
    side = np.abs(np.einsum("ij,ij->i", np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), [[0, 0, 1]])) < 1e-6
    state = (side & (c[:, 0] > 3)).astype(int) * 2
    path = tmp_path / "cyl.3mf"
    write_painted_3mf(path, [("cyl", v, f, {"color": encode_states(state)}, None)])
    tx = texcad.texture(path, "paint:2", "builtin:diamond_knurl", height=0.5, pitch=0.5, border=1.0)
    out = tx.mesh.vertices.astype(np.float64)
    r = np.hypot(out[:, 0], out[:, 1])
    moved = r > 10 + 1e-3  # outside the cylinder's circumscribed radius: raised
    painted = f[state == 2]
    ang = np.degrees(np.arctan2(v[painted][..., 1], v[painted][..., 0]))
    assert moved.sum() > 100
    a = np.degrees(np.arctan2(out[moved, 1], out[moved, 0]))
    assert a.min() >= ang.min() - 1e-6 and a.max() <= ang.max() + 1e-6
    assert np.all(out[moved, 0] > 0)


def test_paint_errors_list_what_the_file_holds(painted_box, tmp_path):
    path, _ = painted_box
    with pytest.raises(InputError, match=r"no triangle is painted paint:5; the file holds color 1, 2"):
        texcad.texture(path, "paint:5", "builtin:stones")
    with pytest.raises(InputError, match=r"holds no fuzzy paint \(it holds: color 1, 2\)"):
        texcad.texture(path, "paint:fuzzy", "builtin:stones")
    v, f = _box()
    plain = tmp_path / "plain.3mf"
    write_painted_3mf(plain, [("box", v, f, {}, None)])
    with pytest.raises(InputError, match="no paint at all"):
        texcad.texture(plain, "paint:1", "builtin:stones")
    stl = tmp_path / "box.stl"
    texcad.Mesh(v, f).export(stl) if hasattr(texcad.Mesh, "export") else texcad.io.write_stl(texcad.Mesh(v, f), stl)
    with pytest.raises(ParameterError, match="painted project's .3mf"):
        texcad.texture(stl, "paint:1", "builtin:stones")
    damaged = tmp_path / "damaged.3mf"
    write_painted_3mf(damaged, [("box", v, f, {"color": ["13"] + [""] * (len(f) - 1)}, None)])
    with pytest.raises(InputError, match="damaged"):
        texcad.texture(damaged, "paint:1", "builtin:stones")


def test_region_strings():
    assert Region.parse("paint:2") == Region("paint", paint="color", state=2)
    assert Region.parse("paint:fuzzy") == Region("paint", paint="fuzzy", state=1)
    assert Region.parse("paint:support:2") == Region("paint", paint="support", state=2)
    assert Region.parse("not:paint:3").invert
    with pytest.raises(ParameterError, match="paint:N"):
        Region.parse("paint:x")


def test_cli_region_paint(painted_box, tmp_path, capsys):
    from texcad.cli import main

    path, _ = painted_box
    out = tmp_path / "cli.3mf"
    assert main(["texture", str(path), "--region", "paint:2@builtin:diamond_knurl", "--region", "paint:1@builtin:stones",
                 "--pitch", "0.5", "--height", "0.5", "-o", str(out), "--separate-texture", "-q"]) == 0
    assert _part_names(out) == ["base", "paint:2 builtin:diamond_knurl", "paint:1 builtin:stones"]
    assert main(["texture", str(path), "--region", "paint:7", "-o", str(tmp_path / "x.stl"), "-q"]) != 0
    assert "the file holds color 1, 2" in capsys.readouterr().err


def test_the_rest_of_the_project_survives(tmp_path):
    """A project of two objects: the painted box is textured and written back as one
    object of parts (each colour zone on its extruder); the other object, its support
    paint and the project's other files are kept."""
    import trimesh

    from texcad.io.paint import read_project

    v, f = _box()
    strings = paint_by_points(v[f], _zones, 5)
    peg = trimesh.creation.cylinder(radius=5, height=10)
    peg.apply_translation([0, 0, 5])
    pv, pf = np.asarray(peg.vertices), np.asarray(peg.faces)
    support = encode_states((pv[pf].mean(axis=1)[:, 2] < 1).astype(int))
    src = tmp_path / "project.3mf"
    write_painted_3mf(src, [("box", v, f, {"color": strings}, np.array([[1, 0, 0, 100], [0, 1, 0, 100], [0, 0, 1, 0]], float)),
                            ("peg", pv, pf, {"support": support}, np.array([[1, 0, 0, 150], [0, 1, 0, 60], [0, 0, 1, 0]], float))])
    with zipfile.ZipFile(src, "a") as z:
        z.writestr("Metadata/Slic3r_PE.config", "; layer_height = 0.15\n")
        z.writestr("Metadata/Slic3r_PE_model.config", '<?xml version="1.0" encoding="UTF-8"?>\n<config>\n <object id="1" instances_count="1">\n'
                   '  <metadata type="object" key="name" value="box"/>\n  <metadata type="object" key="fill_density" value="35%"/>\n'
                   '  <volume firstid="0" lastid="11"><metadata type="volume" key="name" value="box"/></volume>\n </object>\n</config>\n')
    tx = texcad.texture(src, {"paint:1": "builtin:stones", "paint:2": "builtin:diamond_knurl"}, height=0.6, pitch=0.5, border=1.0)
    assert np.allclose(tx.mesh.bounds[0], [80, 85, 0]) and tx.mesh.bounds[1][0] <= 120 + 1e-4  # the box only
    out = tmp_path / "out.3mf"
    tx.export(out, separate_texture=True)
    p = read_project(out)
    assert [(k, n) for k, n, *_ in p.parts] == [(0, "box"), (1, "peg")]
    assert p.states("support") == [1] and p.paint["support"][p.parts[1][3]:] == support  # the peg's paint, unchanged
    assert np.allclose(p.vertices[-len(pv):], pv + [150, 60, 0], atol=1e-4)
    with zipfile.ZipFile(out) as z:
        assert z.read("Metadata/Slic3r_PE.config") == b"; layer_height = 0.15\n"
        cfg = z.read("Metadata/Slic3r_PE_model.config").decode()
    assert 'key="fill_density" value="35%"' in cfg
    assert re.findall(r'key="name" value="([^"]*)"', cfg) == ["box", "base", "paint:1 builtin:stones", "paint:2 builtin:diamond_knurl"]
    assert re.findall(r'key="extruder" value="(\d+)"', cfg) == ["1", "2"]
    if shutil.which("prusa-slicer"):
        info = subprocess.run(["prusa-slicer", "--info", str(out)], capture_output=True, text=True, timeout=300).stdout
        assert [int(n) for n in re.findall(r"number_of_parts\s*=\s*(\d+)", info)] == [3, 1]


def test_a_mask_inside_a_painted_zone(painted_box):
    """A mask in a planar projection scales the height inside the paint: its black
    half (x < 100 mm) leaves the painted zone 1 flat, its white half textures zone 2."""
    path, leaves = painted_box
    mask = np.zeros((80, 4))  # planar +y: u along +z (columns), v along +x (rows, 0.5 mm each)
    mask[40:, :] = 1.0  # white on the +x half (bilinear: grey over the middle 0.5 mm)
    tx = texcad.texture(path, {"paint:1": "builtin:stones", "paint:2": "builtin:stones"}, projection="planar:+y",
                        origin=(100, 115, 10), mask=mask, mask_size=(20, 40), height=0.6, pitch=0.5, border=1.0)
    v = tx.mesh.vertices.astype(np.float64)
    moved = v[:, 1] > 115 + 1e-3
    assert moved.sum() > 200 and np.all(v[moved, 0] > 100 - 0.5)
    assert np.all(_inside(v[moved], leaves[1]) | _inside(v[moved], leaves[2]))
    assert (v[moved, 0] > 101).mean() > 0.8  # the white half of the mask is zone 2


@pytest.mark.skipif(shutil.which("prusa-slicer") is None, reason="needs prusa-slicer")
def test_a_project_prusaslicer_saved(tmp_path):
    """A project saved by PrusaSlicer itself (its model config, volume matrices and
    print settings): textured and written back, it re-opens as one object of a base
    and the zone, the zone on extruder 2, the print settings kept."""
    v, f = _box()
    src = tmp_path / "ours.3mf"
    write_painted_3mf(src, [("box", v, f, {"color": paint_by_points(v[f], _zones, 5)}, None)])
    saved = tmp_path / "saved.3mf"
    subprocess.run(["prusa-slicer", "--export-3mf", "-o", str(saved), str(src)], check=True, capture_output=True, timeout=300)
    tx = texcad.texture(saved, "paint:2", "builtin:diamond_knurl", height=0.6, pitch=0.5, border=1.0)
    out = tmp_path / "out.3mf"
    tx.export(out, separate_texture=True)
    with zipfile.ZipFile(saved) as a, zipfile.ZipFile(out) as b:
        assert set(a.namelist()) <= set(b.namelist())
        for name in a.namelist():  # everything but the model and its config is copied as it was
            if name not in ("3D/3dmodel.model", "Metadata/Slic3r_PE_model.config"):
                assert a.read(name) == b.read(name), name
        cfg = b.read("Metadata/Slic3r_PE_model.config").decode()
    assert re.findall(r'key="extruder" value="(\d+)"', cfg) == ["2"]
    info = subprocess.run(["prusa-slicer", "--info", str(out)], capture_output=True, text=True, timeout=300).stdout
    assert re.findall(r"number_of_parts\s*=\s*(\d+)", info) == ["2"] and "manifold = yes" in info
    size = [float(x) for x in re.findall(r"size_[xyz] = ([\d.]+)", info)]
    assert np.allclose(size, [40, 30.6, 20], atol=0.01)  # the box, 0.6 mm of knurl on its +y face


def test_a_bambu_project_survives(tmp_path):
    """BambuStudio dialect: the painted object's components become one part per zone
    (a new object file), the other object and its paint and the settings are kept."""
    import trimesh

    from texcad.io.paint import read_project

    v, f = _box()
    peg = trimesh.creation.cylinder(radius=5, height=10)
    peg.apply_translation([0, 0, 5])
    pv, pf = np.asarray(peg.vertices), np.asarray(peg.faces)
    support = encode_states((pv[pf].mean(axis=1)[:, 2] < 1).astype(int))
    src = tmp_path / "bambu.3mf"
    write_painted_3mf(src, [("box", v, f, {"color": paint_by_points(v[f], _zones, 5)}, np.array([[1, 0, 0, 100], [0, 1, 0, 100], [0, 0, 1, 0]], float)),
                            ("peg", pv, pf, {"support": support}, np.array([[1, 0, 0, 150], [0, 1, 0, 60], [0, 0, 1, 0]], float))],
                      dialect="bambu")
    with zipfile.ZipFile(src, "a") as z:
        z.writestr("Metadata/project_settings.config", '{"layer_height": "0.16"}')
        z.writestr("Metadata/model_settings.config", '<?xml version="1.0" encoding="UTF-8"?>\n<config>\n  <object id="2">\n'
                   '    <metadata key="name" value="box"/>\n    <metadata key="wall_loops" value="4"/>\n'
                   '    <part id="1" subtype="normal_part">\n      <metadata key="name" value="box"/>\n    </part>\n  </object>\n</config>\n')
    tx = texcad.texture(src, {"paint:1": "builtin:stones", "paint:2": "builtin:diamond_knurl"}, height=0.6, pitch=0.5, border=1.0)
    out = tmp_path / "out.3mf"
    tx.export(out, separate_texture=True)
    p = read_project(out)
    assert [(k, n) for k, _, n, *_ in p.parts] == [(0, "base"), (0, "paint:1 builtin:stones"), (0, "paint:2 builtin:diamond_knurl"), (1, "object 3")]
    box = p.vertices[: -len(pv)]
    assert np.allclose(box.min(axis=0), tx.mesh.bounds[0], atol=1e-4) and np.allclose(box.max(axis=0), tx.mesh.bounds[1], atol=1e-4)
    assert p.paint["support"][-len(pf):] == support and np.allclose(p.vertices[-len(pv):], pv + [150, 60, 0], atol=1e-4)
    with zipfile.ZipFile(out) as z:
        assert z.read("Metadata/project_settings.config") == b'{"layer_height": "0.16"}'
        cfg = z.read("Metadata/model_settings.config").decode()
        assert "texcad_zones_2.model" in z.read("3D/_rels/3dmodel.model.rels").decode()
    assert 'key="wall_loops" value="4"' in cfg
    assert re.findall(r'key="extruder" value="(\d+)"', cfg) == ["1", "2"]


def test_instances_of_a_painted_object(tmp_path):
    """Two build items of one painted object: it is textured once, and written back
    every instance carries the texture (the items keep their places)."""
    from texcad.io.paint import read_project

    v, f = _box()
    src = tmp_path / "two.3mf"
    write_painted_3mf(src, [("box", v, f, {"color": paint_by_points(v[f], _zones, 4)}, None)])
    with zipfile.ZipFile(src) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    model = entries["3D/3dmodel.model"].decode()
    item = re.search(r"<item\b[^>]*/>", model).group(0)
    entries["3D/3dmodel.model"] = model.replace(item, item + item.replace("1 0 0 0 1 0 0 0 1 0 0 0", "1 0 0 0 1 0 0 0 1 60 0 0")).encode()
    with zipfile.ZipFile(src, "w") as z:
        for n, data in entries.items():
            z.writestr(n, data)
    assert len(read_project(src).items) == 2
    tx = texcad.texture(src, "paint:2", "builtin:diamond_knurl", height=0.6, pitch=0.8, border=1.0)
    assert tx.mesh.bounds[1][0] <= 20 + 1e-4  # the first instance only
    out = tmp_path / "out.3mf"
    tx.export(out, separate_texture=True)
    p = read_project(out)
    assert len(p.items) == 2 and len(p.parts) == 2
    (k0, *_, a0, b0), (k1, *_, a1, b1) = p.parts
    f0, f1 = p.faces[a0:b0], p.faces[a1:b1]
    assert np.allclose(p.vertices[f1].reshape(-1, 3).max(axis=0) - p.vertices[f0].reshape(-1, 3).max(axis=0), [60, 0, 0], atol=1e-4)
    assert p.vertices[f0].reshape(-1, 3).max(axis=0)[1] > 15.5  # the knurl on both


def _with_negative(path, dialect):
    """A 20 mm cube painted 2 on its top, whose object also holds a 5 x 5 mm negative
    volume through its corner (PrusaSlicer: a volume of the object's mesh; BambuStudio:
    a part of subtype negative_part), as the slicers save them."""
    import trimesh

    cube = trimesh.creation.box(bounds=np.array([[0, 0, 0], [20, 20, 20]], float))
    neg = trimesh.creation.box(bounds=np.array([[-5, -5, -5], [5, 5, 25]], float))
    top = encode_states((cube.face_normals[:, 2] > 0.9).astype(int) * 2)
    cv, cf, nv, nf = (np.asarray(a) for a in (cube.vertices, cube.faces, neg.vertices, neg.faces))
    if dialect == "prusa":
        write_painted_3mf(path, [("cube", np.concatenate([cv, nv]), np.concatenate([cf, nf + len(cv)]), {"color": top + [""] * len(nf)}, None)])
        cfg = ('<config><object id="1" instances_count="1"><volume firstid="0" lastid="11"><metadata type="volume" key="volume_type" '
               'value="ModelPart"/></volume><volume firstid="12" lastid="23"><metadata type="volume" key="volume_type" '
               'value="NegativeVolume"/></volume></object></config>')
        with zipfile.ZipFile(path, "a") as z:
            z.writestr("Metadata/Slic3r_PE_model.config", cfg)
        return
    write_painted_3mf(path, [("cube", cv, cf, {"color": top}, None), ("neg", nv, nf, {}, None)], dialect="bambu")
    with zipfile.ZipFile(path) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    model = entries["3D/3dmodel.model"].decode()
    model = re.sub(r'<object id="4".*?</object>', "", model, flags=re.S).replace('<item objectid="4"', '<item objectid="0"')
    model = re.sub(r'<item objectid="0"[^>]*/>', "", model)
    entries["3D/3dmodel.model"] = model.replace("</components>", '<component p:path="/3D/Objects/object_3.model" objectid="3"/></components>', 1).encode()
    entries["Metadata/model_settings.config"] = (b'<?xml version="1.0" encoding="UTF-8"?>\n<config><object id="2"><part id="1" subtype="normal_part"/>'
                                                 b'<part id="3" subtype="negative_part"/></object></config>\n')
    with zipfile.ZipFile(path, "w") as z:
        for n, data in entries.items():
            z.writestr(n, data)


@pytest.mark.parametrize("dialect", ["prusa", "bambu"])
def test_a_painted_object_keeps_its_negative_volume_cut(tmp_path, dialect):
    """The slicer cuts a negative volume out of its object; texturing the paint put the
    cut corner back (8065 mm3 where the project prints 7500) and wrote no cut."""
    import trimesh

    from texcad.mapping.region import resolve_paint

    src = tmp_path / "neg.3mf"
    _with_negative(src, dialect)
    assert texcad.check(src).volume_mm3 == pytest.approx(7500, abs=1e-2)
    mesh, (region,), _ = resolve_paint(src, [Region.parse("paint:2")])
    body = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert body.is_watertight and body.volume == pytest.approx(7500, abs=1e-2)
    assert body.area_faces[region.faces].sum() == pytest.approx(400 - 25, abs=1e-6)  # the top less the corner, painted
    assert np.allclose(mesh.vertices[mesh.faces[region.faces]][..., 2], 20)
    tx = texcad.texture(src, "paint:2", "builtin:diamond_knurl", height=0.5, pitch=0.5)
    out = tmp_path / "out.3mf"
    tx.export(out)
    lo, hi = 7500 + 375 * 0.05, 7500 + 375 * 0.5  # the relief adds between a tenth and all of its height over the top
    assert lo < tx.volume < hi and lo < texcad.check(out).volume_mm3 < hi
