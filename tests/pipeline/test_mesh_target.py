"""Texturing meshes (issue 14): every projection and mode on a sharp-edged and a
curved mesh is watertight, keeps its bodies, leaves the bed face alone, respects
its region, keeps engraved textures inside the envelope, and has no texture overhang
for the build direction."""

from __future__ import annotations

import warnings

import manifold3d as m3d
import numpy as np
import pytest
import trimesh

import texcad
from texcad.errors import InputError, ParameterError
from texcad.mapping.region import Region
from texcad import Textured
from texcad.printability import face_areas, overhang_mask
from texcad.solid import Mesh

PROJECTIONS = ["planar:+x", "cylindrical", "spherical", "triplanar", "cubic", "solid"]
MODES = ["raised", "engraved", "centred"]
H = 0.8


def _box():
    b = trimesh.creation.box((20.0, 20.0, 16.0))
    b.apply_translation((0, 0, 8.0))
    return b


def _cylinder():
    c = trimesh.creation.cylinder(radius=9.0, height=16.0, sections=40)
    c.apply_translation((0, 0, 8.0))
    return c


def _dome():
    """Doubly curved: a half sphere (r 10 mm) standing on its flat face."""
    s = m3d.Manifold.sphere(10.0, 48) ^ m3d.Manifold.cube((30, 30, 15)).translate((-15, -15, 0))
    g = s.to_mesh()
    return trimesh.Trimesh(np.asarray(g.vert_properties)[:, :3], np.asarray(g.tri_verts), process=False)


SHAPES = {"box": _box, "cylinder": _cylinder, "dome": _dome}


def _man(m):
    return m3d.Manifold(m3d.Mesh(vert_properties=np.asarray(m.vertices, np.float32), tri_verts=np.asarray(m.faces, np.uint32)))


def _convex_distance(tm, p):
    """max over the face planes of a convex mesh of n . p - c: 0 exactly on its surface,
    > 0 outside, < 0 inside."""
    n = np.asarray(tm.face_normals)
    c = (n * np.asarray(tm.triangles_center)).sum(1)
    return (p @ n.T - c).max(axis=1)


def _bed_area(v, f):
    m = Mesh(np.asarray(v, np.float32), np.asarray(f, np.uint32))
    n = np.cross(m.vertices[m.faces[:, 1]] - m.vertices[m.faces[:, 0]], m.vertices[m.faces[:, 2]] - m.vertices[m.faces[:, 0]])
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    low = np.all(m.vertices[m.faces][:, :, 2] <= m.vertices[:, 2].min() + 1e-5, axis=1)
    return float(face_areas(m)[low & (n[:, 2] < -0.9999)].sum())


def _texture(tm, proj, mode, **kw):
    tex = "builtin:stones:scale=0.5" if proj == "solid" else "builtin:pins"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        return texcad.texture(tm, kw.pop("region", "all"), tex, height=H, pitch=1.0, projection=proj, mode=mode,
                              build_dir=(0, 0, 1), border=1.5, **kw)


@pytest.mark.parametrize("shape", list(SHAPES))
@pytest.mark.parametrize("proj", PROJECTIONS)
@pytest.mark.parametrize("mode", MODES)
def test_projection_mode_guarantees(shape, proj, mode):
    tm = SHAPES[shape]()
    r = _texture(tm, proj, mode)
    assert isinstance(r, Textured) and r.kind == "mesh"
    out = r.mesh
    t = trimesh.Trimesh(out.vertices, out.faces, process=False)
    assert t.is_watertight and t.is_winding_consistent
    man = _man(out)
    assert man.status() == m3d.Error.NoError
    assert len(man.decompose()) == 1  # one body in, one body out
    # the bed face is untouched: same area at the lowest z, facing down
    assert _bed_area(out.vertices, out.faces) == pytest.approx(_bed_area(tm.vertices, tm.faces), rel=1e-5)
    assert out.bounds[0, 2] == pytest.approx(0.0, abs=1e-5)
    # the texture is really there: the surface moved by a good part of H somewhere
    orig = _man(Mesh(tm.vertices, tm.faces))
    grown, lost = (man - orig).volume(), (orig - man).volume()
    assert grown + lost > 0.05 * H * 100.0
    if mode == "raised":
        assert lost < 1e-3  # the part is kept whole under a raised texture
    if mode == "engraved":
        assert grown < 1e-3  # the outer envelope is kept
        assert np.all(out.bounds[1] <= np.asarray(tm.bounds[1]) + 1e-4)
    if mode == "centred":
        assert grown > 1.0 and lost > 1.0
    # no displacement beyond H (times the sharp-edge offset factor <= sqrt 3)
    assert np.all(out.bounds[1] <= np.asarray(tm.bounds[1]) + H * np.sqrt(3) + 1e-4)
    # zero texture overhang for +z
    tex = np.zeros(out.num_triangles, bool)
    tex[out.groups["texture"]] = True
    assert tex.sum() > 100
    over = overhang_mask(out, (0, 0, 1), 45.0)
    assert float(face_areas(out)[over & tex].sum()) == 0.0


@pytest.mark.parametrize("shape", list(SHAPES))
def test_check_reports_zero_texture_overhang(shape):
    r = _texture(SHAPES[shape](), "triplanar", "raised")
    rep = r.check(build_dir=(0, 0, 1))
    assert rep.watertight and rep.manifold and rep.shells == 1
    assert rep.texture_area_mm2 > 200.0
    assert rep.texture_overhang_area_mm2 == 0.0
    with pytest.raises(texcad.GeometryError, match="no B-rep"):
        r.shape


def test_overhang_limiter_lowers_texture_on_a_tilted_build():
    tm = _box()
    free = _texture(tm, "triplanar", "raised")
    tilted = texcad.texture(tm, "all", "builtin:pins", height=H, pitch=1.0, build_dir=(0, -0.5, 1), border=1.5)
    assert tilted.limits.lowered > 0 and tilted.limits.removed_mm3 > 0
    out = tilted.mesh
    tex = np.zeros(out.num_triangles, bool)
    tex[out.groups["texture"]] = True
    assert float(face_areas(out)[overhang_mask(out, (0, -0.5, 1), 45.0) & tex].sum()) == 0.0
    assert tilted.volume < free.volume


def test_region_normal_respected():
    tm = _box()
    for mode in ("raised", "engraved"):
        r = _texture(tm, "planar:+x", mode, region="normal:+x:30")
        v = r.mesh.vertices.astype(np.float64)
        on_box = np.any(np.isclose(np.abs(v[:, :2]), 10.0, atol=1e-5), axis=1) | np.isclose(v[:, 2], 0, atol=1e-5) | np.isclose(v[:, 2], 16, atol=1e-5)
        moved = v[~on_box]
        assert len(moved) > 50
        # every displaced vertex lies over the +x face, within the relief depth of it
        assert np.all(np.abs(moved[:, 1]) <= 10.0) and np.all((moved[:, 2] >= 0) & (moved[:, 2] <= 16))
        assert np.all(np.abs(moved[:, 0] - 10.0) <= H + 1e-4)
        # and no closer than the border to the face's edges the fade starts from 0
        assert np.all(np.abs(moved[:, 1]) < 10.0 - 1e-3) and np.all(moved[:, 2] > 1e-3)


def test_region_box_and_sphere_on_a_curved_mesh():
    tm = _cylinder()
    for spec, inside in (
        ("box:0,-20,4,20,20,12", lambda p: (p[:, 0] >= -1e-6) & (p[:, 2] >= 4 - 1e-6) & (p[:, 2] <= 12 + 1e-6)),
        ("sphere:9,0,8,5", lambda p: np.linalg.norm(p - [9, 0, 8], axis=1) <= 5 + H + 1e-4),
    ):
        r = _texture(tm, "cylindrical", "raised", region=spec)
        v = r.mesh.vertices.astype(np.float64)
        moved = v[np.abs(_convex_distance(tm, v)) > 1e-4]  # off the input's surface: displaced
        assert len(moved) > 20
        assert np.all(inside(moved))


@pytest.mark.parametrize("proj", PROJECTIONS)
@pytest.mark.parametrize("mode", MODES)
def test_region_respected_for_every_projection_and_mode(proj, mode):
    """A sphere region on the dome's flank: every displaced vertex lies in a region face
    (within a triangle of the sphere), and those within the border width of the
    region's edge are displaced by at most the M-I ramp (H s / border)."""
    tm = _dome()
    c, rad, border, pitch = np.array([7.0, 0.0, 6.0]), 6.0, 1.5, 0.5
    tex = "builtin:stones:scale=0.5" if proj == "solid" else "builtin:pins"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", texcad.TexcadWarning)
        r = texcad.texture(tm, f"sphere:{c[0]},{c[1]},{c[2]},{rad}", tex, height=H, pitch=pitch, projection=proj,
                           mode=mode, build_dir=(0, 0, 1), border=border)
    v = r.mesh.vertices.astype(np.float64)
    off = np.abs(_convex_distance(tm, v))
    moved = off > 1e-4
    assert moved.sum() > 50
    # in a region face: its centroid is in the sphere, so its corners within a pitch of it
    assert np.all(np.linalg.norm(v[moved] - c, axis=1) <= rad + pitch + H * np.sqrt(3))
    # the ramp: a vertex s mm inside the sphere is within s + 2 pitch of the region's
    # border vertices, so it moves by at most H (s + 2 pitch) / border (< H here)
    s = rad - np.linalg.norm(v - c, axis=1)
    near = moved & (s < 0.25)
    assert np.all(off[near] <= 1.05 * H * np.maximum(s[near] + 2 * pitch, 0) / border + 1e-4)


def test_gradient_fades_along_an_axis():
    tm = _cylinder()
    r = texcad.texture(tm, "normal:+z:100", "builtin:ridges", height=H, pitch=1.0, projection="cylindrical",
                       gradient=((0, 0, 0), (0, 0, 16)), border=0.5)
    v = r.mesh.vertices.astype(np.float64)
    rho = np.hypot(v[:, 0], v[:, 1])
    low, high = (v[:, 2] > 1) & (v[:, 2] < 5), (v[:, 2] > 13) & (v[:, 2] < 15.5)
    assert rho[low].max() - 9.0 > 0.5 * H
    assert rho[high].max() - 9.0 < 0.25 * H + 1e-3


def test_two_bodies_and_layers_to_3mf(tmp_path):
    a, b = _box(), _cylinder()
    b.apply_translation((40, 0, 0))
    both = trimesh.util.concatenate([a, b])
    r = texcad.texture(
        both,
        [("normal:+z:80", "builtin:diamond_knurl", {"mode": "engraved"}), ("normal:+x:60", "builtin:ridges", {"height": 0.5})],
        height=H, pitch=1.0, build_dir=(0, 0, 1), projection="triplanar",
    )
    assert len(_man(r.mesh).decompose()) == 2
    layers = r.layer_meshes
    assert len(layers) == 2 and all(m.volume > 1.0 for m in layers)
    p = r.export(tmp_path / "two.3mf", separate_texture=True)
    from texcad.io import read_part

    names = [n for n, _ in read_part(p)]
    assert names == ["base", "texture 1", "texture 2"]
    rep = texcad.check(p, build_dir=(0, 0, 1))
    assert rep.watertight and rep.texture_overhang_area_mm2 == 0.0
    # base + textures add up to the textured part
    assert r.base_mesh.volume + sum(m.volume for m in layers) == pytest.approx(r.mesh.volume, rel=1e-3)


def test_read_files_and_refuse_bad_input(tmp_path):
    tm = _box()
    path = tmp_path / "part.stl"
    tm.export(path)
    r = texcad.texture(str(path), "not-bottom", "builtin:ridges", height=0.5, pitch=1.5)
    assert r.mesh.is_watertight
    r.export(tmp_path / "out.3mf")
    assert (tmp_path / "out.3mf").stat().st_size > 1000
    from texcad.io import write_3mf

    tmf = tmp_path / "part.3mf"
    write_3mf(Mesh(tm.vertices, tm.faces), tmf)
    assert texcad.texture(tmf, "normal:+z:10", "builtin:dots", height=0.5, pitch=1.5).mesh.is_watertight
    obj = tmp_path / "part.obj"
    tm.export(obj)
    assert texcad.texture(obj, "all", "builtin:ridges", height=0.5, pitch=1.5).mesh.is_watertight
    open_mesh = trimesh.Trimesh(tm.vertices, tm.faces[:-1], process=False)
    with pytest.raises(InputError, match="not closed"):
        texcad.texture(open_mesh, "all", "builtin:ridges")
    # two overlapping boxes in one "closed" mesh, and a box folded through itself
    other = _box()
    other.apply_translation((5.0, 4.0, 3.0))
    fold = np.array(tm.vertices)
    fold[int(np.argmax(fold.sum(1)))] = (-3.0, -2.0, -4.0)  # the top corner pushed through the bottom
    for bad in (trimesh.util.concatenate([tm, other]), trimesh.Trimesh(fold, tm.faces, process=False)):
        stl = tmp_path / "bad.stl"
        bad.export(stl)
        with pytest.raises(InputError, match="intersects itself.*manifold3d"):
            texcad.texture(str(stl), "all", "builtin:ridges", pitch=1.5)
    with pytest.raises(ParameterError, match="holds no face"):
        texcad.texture(tm, "sphere:100,100,100,1", "builtin:ridges")
    with pytest.raises(ParameterError, match="region"):
        texcad.texture(tm, "cone:1", "builtin:ridges")
    with pytest.raises(ParameterError, match="mode"):
        texcad.texture(tm, "all", "builtin:ridges", mode="embossed")
    with pytest.raises(ParameterError, match="no solid"):
        texcad.texture(tm, "all", "builtin:brick", projection="solid")
    assert not list(tmp_path.glob("*.tmp*"))


def test_region_strings():
    assert Region.parse("normal:+x:70") == Region("normal", direction="+x", angle=70.0)
    assert Region.parse("box:0,0,0,1,2,3").hi == (1.0, 2.0, 3.0)
    assert Region.parse("sphere:1,2,3,4").radius == 4.0
    assert Region.parse("all+bottom").bottom and not Region.parse("not-bottom").bottom
    with pytest.raises(ParameterError):
        Region.parse("box:1,2")


def test_cli_texture_mesh(tmp_path, capsys):
    from texcad.cli import main

    part = tmp_path / "part.stl"
    _box().export(part)
    out = tmp_path / "out.3mf"
    rc = main(["texture", str(part), "--region", "normal:+z:30@builtin:diamond_knurl@engraved", "--region", "normal:+x:60",
               "--texture", "builtin:ridges", "--pitch", "1.0", "--build-dir", "0,0,1", "--separate-texture", "-o", str(out), "-q"])
    assert rc == 0 and "watertight True" in capsys.readouterr().out
    rep = texcad.check(out, build_dir=(0, 0, 1))
    assert rep.objects == ["base", "texture 1", "texture 2"]
    assert rep.watertight and rep.shells == 1 and rep.texture_overhang_area_mm2 == 0.0
    assert rep.bounds_mm[1][2] <= 16.0 + 1e-4  # the top is engraved: no higher than before
    assert main(["texture", str(part), "--region", "cone", "-o", str(tmp_path / "x.stl"), "-q"]) != 0
    assert not (tmp_path / "x.stl").exists()


def test_repairs_flipped_and_split_input_and_masks():
    tm = _box()
    f = np.asarray(tm.faces).copy()
    f[::3] = f[::3, ::-1]  # a third of the triangles flipped
    soup = trimesh.Trimesh(np.asarray(tm.vertices)[f.ravel()], np.arange(f.size).reshape(-1, 3), process=False)
    r = texcad.texture(soup, "normal:+x:30", "builtin:ridges", height=0.5, pitch=1.0, projection="planar:+x")
    assert r.mesh.is_watertight and r.volume > 3200.0  # welded, oriented outward, textured
    # a mask in the projection: only the left half (u < 0) of the +x face
    mask = np.zeros((4, 4))
    mask[:, :2] = 1.0
    m = texcad.texture(tm, "normal:+x:30", "builtin:ridges", height=0.5, pitch=1.0, projection="planar:+x",
                       origin=(10, 0, 8), mask=mask, mask_size=(20, 16), border=0.5)
    v = m.mesh.vertices.astype(np.float64)
    moved = v[v[:, 0] > 10 + 1e-4]
    assert len(moved) > 20 and np.all(moved[:, 1] < 2.5 + 1e-6)  # u along +y: left half only (+ blend)
    with pytest.raises(ParameterError, match="mask covers none"):
        texcad.texture(tm, "normal:+x:30", "builtin:ridges", projection="planar:+x", mask=mask, mask_size=(2, 2),
                       origin=(100, 100, 100))
    with pytest.raises(ParameterError, match="mask"):
        texcad.texture(tm, "normal:+x:30", "builtin:ridges", projection="planar:+x", mask=np.ones(5), mask_size=(2, 2))


def test_too_deep_for_the_curvature_is_limited_with_a_warning():
    thin = trimesh.creation.cylinder(radius=1.5, height=10.0, sections=24)
    thin.apply_translation((0, 0, 5.0))
    with pytest.warns(texcad.TexcadWarning, match="fold"):
        r = texcad.texture(thin, "not:normal:+z:30", "builtin:pins", height=2.5, mode="engraved", pitch=0.4,
                           projection="cylindrical", border=0.5)
    assert r.limits.folded_faces > 0 and r.limits.lowered > 0
    man = _man(r.mesh)
    assert man.status() == m3d.Error.NoError and len(man.decompose()) == 1
    assert (man - _man(Mesh(thin.vertices, thin.faces))).volume() < 1e-3  # still inside the envelope
