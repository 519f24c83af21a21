"""texcad check: the Python function and the CLI on texcad-made STL and 3MF parts."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import trimesh
from PIL import Image

import texcad
from texcad.report import check
from texcad.util import parse_vector
from texcad.io import read_part
from texcad.cli import main
from texcad.errors import InputError, ParameterError
from texcad.io import write_3mf, write_stl
from texcad.printability import edge_ramp, limit_overhangs, orientation, overhang_area

SIZE, PITCH = 20.0, 0.5  # mm: a small demo-like plate


@pytest.fixture(scope="module")
def plate():
    return texcad.pipeline.textured_plate("builtin:stones", size=(SIZE, SIZE), thickness=3.0, height=1.0, pitch=PITCH)


@pytest.fixture(scope="module")
def files(plate, tmp_path_factory):
    d = tmp_path_factory.mktemp("parts")
    write_stl(plate.mesh, d / "plate.stl")
    write_3mf([("base", plate.base_mesh), ("texture", plate.texture_mesh)], d / "plate.3mf")
    return d


def _trimesh_overhang(path, d, crit=45.0):
    """Independent reference: trimesh's normals and areas, same rule."""
    tm = trimesh.load(path, force="mesh")
    d = np.asarray(d, float) / np.linalg.norm(d)
    level = tm.vertices @ d
    on_plate = (level[tm.faces] <= level.min() + 0.01).all(axis=1)
    over = (-(tm.face_normals @ d) > np.cos(np.radians(crit - 1e-3))) & ~on_plate
    return float(tm.area_faces[over].sum())


def _cli(capsys, *argv):
    code = main(["check", *map(str, argv)])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_stl_text_report(files, plate, capsys):
    code, out, _ = _cli(capsys, files / "plate.stl")
    assert code == 0
    assert "watertight    yes" in out and "manifold      yes" in out and "shells        1" in out
    assert f"triangles     {plate.mesh.num_triangles}" in out and "bbox          (0.00, 0.00, -3.00) .. (20.00, 20.00, " in out
    assert f"volume        {plate.mesh.volume:.1f} mm3" in out
    assert "overhang      0.00 mm2 whole part" in out  # lying flat: only the bottom faces down
    assert "which faces are texture" in out  # an STL cannot say


def test_stl_json_matches_trimesh(files, plate, capsys):
    d = (0.0, -1.0, 0.4)  # tipped over towards -y: the y = SIZE wall and more look down
    code, out, _ = _cli(capsys, files / "plate.stl", "--build-dir", "0,-1,0.4", "--json")
    assert code == 0
    rep = json.loads(out)  # exactly one JSON object
    assert set(rep) >= {"watertight", "manifold", "shells", "volume_mm3", "bounds_mm", "triangles", "overhang_area_mm2"}
    tm = trimesh.load(files / "plate.stl", force="mesh")
    assert rep["watertight"] and tm.is_watertight and rep["shells"] == 1
    assert rep["triangles"] == len(tm.faces)
    assert rep["volume_mm3"] == pytest.approx(tm.volume, rel=1e-6)
    assert np.allclose(rep["bounds_mm"], tm.bounds, atol=1e-5)
    assert rep["overhang_area_mm2"] > 0
    assert rep["overhang_area_mm2"] == pytest.approx(_trimesh_overhang(files / "plate.stl", d), rel=1e-6)
    assert rep["texture_overhang_area_mm2"] is None


def test_3mf_reports_texture_alone(files, plate, capsys):
    # Upside down: the texture faces the build plate; its top overhangs.
    code, out, _ = _cli(capsys, files / "plate.3mf", "--build-dir", "0,0,-1", "--json")
    rep = json.loads(out)
    assert code == 0 and rep["objects"] == ["base", "texture"] and rep["watertight"]
    # The check unions the two parts with manifold3d; the plate's own mesh is stitched
    # without a boolean (fuse_on_plane), which keeps a few more short edges at the
    # relief's foot: the same solid (volume below), up to 5 % more triangles.
    assert rep["shells"] == 1 and rep["triangles"] <= plate.mesh.num_triangles <= 1.05 * rep["triangles"]
    assert rep["volume_mm3"] == pytest.approx(plate.mesh.volume, rel=1e-5)
    # Reference: the slab's textured top (its "texture" group) seen from below.
    slab = plate.texture_mesh
    ref = texcad.printability.overhang_area(slab, (0, 0, -1), faces=slab.groups["texture"])
    assert 0.5 * SIZE**2 < rep["texture_overhang_area_mm2"] <= rep["overhang_area_mm2"]
    assert rep["texture_overhang_area_mm2"] == pytest.approx(ref, rel=0.02)
    assert rep["texture_area_mm2"] >= rep["texture_overhang_area_mm2"]
    # Lying flat, texture up: nothing overhangs, and the text report says so.
    code, out, _ = _cli(capsys, files / "plate.3mf")
    assert code == 0 and "texture       0.00 mm2 overhang" in out


def test_base_walls_are_not_counted_as_texture():
    # A flat (zero-height) texture on a plate tilted 60 degrees: the plate's bottom
    # side wall overhangs; the slab's buried wall lies in the same plane and must not
    # be reported as texture (whatever the union attributes it to).
    hm = texcad.Heightmap(np.zeros((20, 20), np.float32), 0.5)
    part = texcad.pipeline.textured_plate(hm, size=hm.size, thickness=3.0)
    d = orientation(60, "+y")
    rep = check([("base", part.base_mesh), ("texture", part.texture_mesh)], build_dir=d)
    wall = 10.0 * 3.0  # the y = 0 wall of the plate, 10 x 3 mm
    assert rep.overhang_area_mm2 == pytest.approx(wall, rel=1e-6)
    assert rep.texture_overhang_area_mm2 == 0.0


def test_texture_border_wall_counts_until_ramped():
    # Standing upright on its y = 0 border (paper, figure 4): the texture's border wall
    # above the base overhangs (a texture problem) besides steep top facets; M-I ramps
    # the wall away, the slope limiter the facets.
    hm = texcad.builtin("stones", size=10, pitch=0.25, height=1.0)
    d = orientation(90, "+y")

    def texture_overhang(h):
        # one vertex per pixel: the wall's area is the trapezoid of the pixel heights
        part = texcad.pipeline.textured_plate(h, size=hm.size, thickness=2.0, tolerance=0)
        rep = check([("base", part.base_mesh), ("texture", part.texture_mesh)], build_dir=d)
        top = overhang_area(part.texture_mesh, d, faces=part.texture_mesh.groups["texture"])
        return rep.texture_overhang_area_mm2, top

    off, top = texture_overhang(hm)
    wall = np.trapezoid(hm.heights[0].astype(np.float64), dx=hm.pitch[0])  # mm2 above the base
    assert wall > 1.0 and off == pytest.approx(top + wall, rel=1e-6)
    ramped, rep = edge_ramp(hm, d)
    on, top = texture_overhang(ramped)
    assert rep.ramped_borders == ("y0",) and on == pytest.approx(top, abs=1e-9)  # wall gone
    fixed, rep = limit_overhangs(hm, d)
    assert texture_overhang(fixed) == (0.0, 0.0) and rep.removed_volume_mm3 > 0


def test_not_watertight_exits_1(tmp_path, plate, capsys):
    m = plate.mesh
    hole = texcad.Mesh(m.vertices, m.faces[1:])
    path = tmp_path / "hole.stl"
    tm = trimesh.Trimesh(hole.vertices, hole.faces, process=False)
    tm.export(path)
    code, out, _ = _cli(capsys, path, "--json")
    rep = json.loads(out)
    assert code == 1 and rep["watertight"] is False and not trimesh.load(path).is_watertight
    code, out, _ = _cli(capsys, path)
    assert code == 1 and "watertight    NO" in out


def test_unreadable_files_exit_2_with_one_line(tmp_path):
    bad = tmp_path / "junk.stl"
    bad.write_bytes(b"\x00\x01not an stl at all" * 3)
    cases = [
        (bad, "neither a binary nor an ASCII STL"),
        (tmp_path / "missing.3mf", "does not exist"),
        (tmp_path / "x.3mf", "not a 3MF"),
        (tmp_path / "part.obj", "an OBJ needs 'v' and 'f' lines"),
        (tmp_path / "part.ply", "reads .stl, .3mf and .obj"),
    ]
    (tmp_path / "x.3mf").write_bytes(b"PK? no zip")
    (tmp_path / "part.obj").write_text("v 0 0 0\n")
    (tmp_path / "part.ply").write_text("ply\n")
    for path, msg in cases:
        r = subprocess.run([sys.executable, "-m", "texcad", "check", str(path)], capture_output=True, text=True)
        assert r.returncode == 2, (path, r.stderr)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("texcad: error:") and msg in lines[0]
        assert r.stdout == ""


def test_bad_options(files, capsys):
    assert main(["check", str(files / "plate.stl"), "--build-dir", "0,0,0"]) == 2
    assert "not all zero" in capsys.readouterr().err
    assert main(["check", str(files / "plate.stl"), "--critical-angle", "95"]) == 2
    assert "critical_angle" in capsys.readouterr().err
    with pytest.raises(ParameterError):
        parse_vector("1,2")
    assert np.allclose(parse_vector("0 -0.5, 0.87"), [0, -0.5, 0.87])


def _red(img):
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r > 40) & (r > 1.8 * g) & (r > 1.8 * b)


def test_png_shows_overhangs_in_red(files, tmp_path, capsys):
    out = tmp_path / "over.png"
    code, text, _ = _cli(capsys, files / "plate.3mf", "--build-dir", "0,0,-1", "--png", out)
    assert code == 0 and f"picture       {out}" in text
    img = np.asarray(Image.open(out).convert("RGB")).astype(int)
    red = _red(img)
    assert red.mean() > 0.05
    out2 = tmp_path / "ok.png"
    _cli(capsys, files / "plate.3mf", "--png", out2)
    img = np.asarray(Image.open(out2).convert("RGB")).astype(int)
    assert _red(img).sum() == 0 and img.std() > 10


def test_nozzle_thin_features(files, capsys):
    code, out, _ = _cli(capsys, files / "plate.3mf", "--nozzle", "0.4", "--json")
    rep = json.loads(out)
    tf = rep["thin_features"]
    assert code == 0 and rep["nozzle_mm"] == 0.4
    assert 0.0 <= tf["thin_fraction"] < 0.5 and tf["feature_area_mm2"] > 0.1 * SIZE**2
    code, out, _ = _cli(capsys, files / "plate.3mf", "--nozzle", "3", "--json")
    assert json.loads(out)["thin_features"]["thin_fraction"] > tf["thin_fraction"]


def test_read_part_ascii_and_binary_agree(tmp_path, plate):
    small = texcad.solid.heightfield_slab(texcad.builtin("ridges", size=4, pitch=0.5, height=0.5), depth=0.5)
    tm = trimesh.Trimesh(small.vertices, small.faces, process=False)
    (tmp_path / "a.stl").write_text(trimesh.exchange.stl.export_stl_ascii(tm))
    write_stl(small, tmp_path / "b.stl")
    (_, a), = read_part(tmp_path / "a.stl")
    (_, b), = read_part(tmp_path / "b.stl")
    assert a.num_triangles == b.num_triangles == small.num_triangles
    assert a.is_watertight and b.is_watertight
    assert a.volume == pytest.approx(small.volume, rel=1e-6) and b.volume == pytest.approx(small.volume, rel=1e-6)
    with pytest.raises(InputError, match="empty"):
        (tmp_path / "e.stl").write_bytes(b"")
        read_part(tmp_path / "e.stl")


def test_check_dataclass_api(plate):
    rep = check(plate.mesh)
    assert rep.watertight and rep.manifold and rep.ok and rep.overhang_area_mm2 == 0.0
    assert json.loads(rep.to_json()) == rep.to_dict()
    # Tilted by 30 degrees the bottom no longer rests on the build plate: it overhangs.
    rep = check(plate.mesh, build_dir=orientation(30, "+y"), critical_angle=50)
    assert rep.critical_angle_deg == 50.0 and np.allclose(rep.build_dir, orientation(30, "+y"))
    assert rep.overhang_area_mm2 == pytest.approx(SIZE * SIZE, rel=1e-6) and not rep.ok


def test_3mf_other_layouts(tmp_path):
    """Attribute order, single quotes, exponents and transforms (the regex path) give
    the same part as texcad's own layout (the numpy path)."""
    import zipfile

    slab = texcad.solid.heightfield_slab(texcad.builtin("ridges", size=3, pitch=0.5, height=0.5), depth=0.5)
    v, f = slab.vertices.astype(np.float64), slab.faces
    verts = "".join(f"<vertex z='{z:.6e}' y='{y:.6e}' x='{x:.6e}'/>" for x, y, z in v)
    tris = "".join(f'<triangle v3="{c}" p1="0" v1="{a}" v2="{b}"/>' for a, b, c in f)
    model = (
        '<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02">'
        f'<resources><object id="7" type="model" name="texture &amp; co"><mesh><vertices>{verts}</vertices>'
        f"<triangles>{tris}</triangles></mesh></object></resources>"
        '<build><item objectid="7" transform="1 0 0 0 1 0 0 0 1 10 20 30"/></build></model>'
    )
    path = tmp_path / "other.3mf"
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("3D/3dmodel.model", model)
    (name, m), = read_part(path)
    assert name == "texture & co" and m.num_triangles == slab.num_triangles
    assert np.allclose(m.vertices, v + [10, 20, 30], atol=1e-5)
    assert m.is_watertight and m.volume == pytest.approx(slab.volume, rel=1e-5)
    # The same mesh in texcad's layout reads identically (to the 0.1 um it is written with).
    write_3mf(slab, tmp_path / "own.3mf")
    (_, own), = read_part(tmp_path / "own.3mf")
    assert np.array_equal(own.faces, slab.faces) and np.allclose(own.vertices, slab.vertices, atol=6e-5)


def test_check_a_texture_result_uses_its_fused_mesh():
    from build123d import Axis, Box

    box = Box(20, 20, 5)
    top = box.faces().sort_by(Axis.Z)[-1]
    d = texcad.orientation(60, "+x")
    free = texcad.texture(box, top, "builtin:pins", height=1.0, pitch=0.25, brep=False)
    limited = texcad.texture(box, top, "builtin:pins", height=1.0, pitch=0.25, brep=False, build_dir=d)
    r_free, r_lim = texcad.check(free, build_dir=d), texcad.check(limited, build_dir=d)
    assert r_free.source == "<textured part>" and r_free.triangles == free.mesh.num_triangles
    assert r_free.watertight and r_free.shells == 1
    assert r_free.texture_overhang_area_mm2 > 1.0 and r_lim.texture_overhang_area_mm2 == 0.0
    # The texture faces lie on the top face (the pins' flanks and tops), not on the sides.
    assert 0.0 < r_free.texture_area_mm2 < 3 * 400.0
    assert r_free.overhang_area_mm2 < r_free.texture_overhang_area_mm2 + 20 * 5 + 1e-6  # + the -x side wall


def test_manifold_flag_agrees_with_manifold3d():
    """The vectorized manifold test of a single object says what manifold3d says: yes
    for closed solids, no for an open mesh, a flipped triangle and a repeated
    triangle. A triangle that repeats a vertex is refused too, where manifold3d drops
    it and accepts the rest (texcad is the stricter)."""
    import manifold3d as m3d
    import trimesh

    from texcad.report.report import _closed_manifold
    from texcad.solid import Mesh

    def m3d_ok(m):
        try:
            man = m3d.Manifold(m3d.Mesh(vert_properties=m.vertices, tri_verts=m.faces))
        except Exception:  # noqa: BLE001 - a refusal
            return False
        return man.status() == m3d.Error.NoError and not man.is_empty()

    sphere = trimesh.creation.icosphere(3)
    box = trimesh.creation.box((3, 2, 1))
    good = [Mesh(sphere.vertices, sphere.faces), Mesh(box.vertices, box.faces)]
    f = np.asarray(sphere.faces)
    bad = [
        Mesh(sphere.vertices, f[1:]),  # open
        Mesh(sphere.vertices, np.concatenate([f[:1, ::-1], f[1:]])),  # one triangle flipped
        Mesh(sphere.vertices, np.concatenate([f, f[:1]])),  # a triangle twice
    ]
    pinched = Mesh(sphere.vertices, np.concatenate([f, [[0, 0, 1]]]))  # a triangle repeating a vertex
    assert m3d_ok(pinched) and not _closed_manifold(pinched) and not check(pinched).manifold
    for m in good:
        assert _closed_manifold(m) and m3d_ok(m)
        assert check(m).manifold
    for m in bad:
        assert not _closed_manifold(m) and not m3d_ok(m)
        assert not check(m).manifold


def test_check_reads_a_step_part_and_texture_takes_its_path(tmp_path):
    """``texcad check part.step`` tessellates the part (0.02 mm): watertight, its
    volume within 0.1 %; ``texcad.texture("part.step", ...)`` reads it as the CLI does."""
    from build123d import Box, Cylinder, export_step

    part = Box(30, 20, 8) - Cylinder(4, 10)
    export_step(part, str(tmp_path / "part.step"))
    rep = check(tmp_path / "part.step")
    assert rep.watertight and rep.manifold and rep.shells == 1
    assert rep.volume_mm3 == pytest.approx(part.volume, rel=1e-3)
    tx = texcad.texture(tmp_path / "part.step", "top", "builtin:stones", height=0.5, pitch=0.5)
    assert tx.volume > part.volume and tx.gate.shells.bodies == 1


def test_check_meshes_a_textured_step_on_its_tiles(tmp_path):
    """``texcad check`` on texcad's own STEP: OCCT meshes the texture's B-spline tiles
    by distance, not by the angle between normals (by angle, a small knurled plate
    took minutes and over a million triangles: its tiles kink at every knot), closed,
    under 100 times texcad's lean mesh's triangles and the same volume within 0.1 %."""
    from build123d import Axis, Box

    box = Box(30, 20, 6)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:diamond_knurl", height=1.0, pitch=0.5)
    tx.export(tmp_path / "t.step")
    rep = check(tmp_path / "t.step")
    assert rep.watertight and rep.manifold and rep.shells == 1
    assert rep.triangles < 100 * tx.mesh.num_triangles, (rep.triangles, tx.mesh.num_triangles)
    assert rep.volume_mm3 == pytest.approx(tx.volume, rel=1e-3)
