"""texcad.texture on build123d and CadQuery parts: meshes, B-rep STEP, 3MF, previews."""

import warnings
import zipfile

import numpy as np
import pytest
import trimesh

from texcad.brep import solids as brep
import texcad
from texcad.errors import GeometryError, ParameterError, TexcadWarning

PITCH = 1.0  # mm per pixel: coarse, for speed
TEX = "builtin:hexagons"  # has relief at 1 mm pitch
XS = np.linspace(0, 60, 49)
ZS = 10 + 3 * np.cos(2 * np.pi * XS / 30)  # the sine sample: 2 periods over 60 mm


# -- the parts: (part, selected face) for each library ----------------------------------
def b123d_part(kind):
    from build123d import Axis, Box, BuildLine, BuildPart, BuildSketch, Cylinder, GeomType, Plane, Polyline, Spline, extrude, make_face

    if kind == "plate":
        part = Box(60, 40, 10)
        return part, part.faces().sort_by(Axis.Z)[-1]
    if kind == "cylinder":
        part = Cylinder(10, 30)
        return part, part.faces().filter_by(GeomType.CYLINDER)[0]
    with BuildPart() as bp:
        with BuildSketch(Plane.XZ):
            with BuildLine():
                Spline(*[(float(x), float(z)) for x, z in zip(XS, ZS)])
                Polyline((60, float(ZS[-1])), (60, 0), (0, 0), (0, float(ZS[0])))
            make_face()
        extrude(amount=-30)
    return bp.part, bp.part.faces().filter_by(GeomType.EXTRUSION)[0]


def cq_part(kind):
    import cadquery as cq

    if kind == "plate":
        wp = cq.Workplane("XY").box(60, 40, 10)
        return wp, wp.faces(">Z")
    if kind == "cylinder":
        wp = cq.Workplane("XY").cylinder(30, 10)
        return wp, wp.faces("%CYLINDER")
    pts = [(float(x), float(z)) for x, z in zip(XS[::-1], ZS[::-1])]
    wp = cq.Workplane("XZ").moveTo(0, 0).lineTo(60, 0).lineTo(*pts[0]).spline(pts[1:], includeCurrent=True).close().extrude(-30)
    return wp, wp.faces("%EXTRUSION")


def classify(kind, v, base):
    """``(on_base, over_face)`` masks of points ``v`` (N, 3) mm: on the base body's
    surface (within 2 um; 20 um on the tessellated spline), and strictly outside the
    base right over the selected face (where texture may be)."""
    lo, hi = base.bounds
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    t = 2e-3
    within = np.all((v > lo - t) & (v < hi + t), axis=1)
    if kind == "plate":
        on_plane = np.zeros(len(v), bool)
        for ax in range(3):
            on_plane |= (np.abs(v[:, ax] - lo[ax]) < t) | (np.abs(v[:, ax] - hi[ax]) < t)
        inner = (x > lo[0] + t) & (x < hi[0] - t) & (y > lo[1] + t) & (y < hi[1] - t)
        return on_plane & within, inner & (z > hi[2] + t)
    if kind == "cylinder":
        r = np.hypot(x, y)
        on = ((np.abs(r - 10) < t) & (np.abs(z) < 15 + t)) | ((np.abs(np.abs(z) - 15) < t) & (r < 10 + t))
        return on, (r > 10 + t) & (np.abs(z) < 15 - t)
    # sine: the profile z(x) from the base mesh's vertices on the spline face
    bv = base.vertices
    top = bv[(bv[:, 2] > 1.0) & (np.abs(bv[:, 1] - lo[1]) < t)]
    order = np.argsort(top[:, 0])
    zf = np.interp(x, top[order, 0], top[order, 2])
    t2 = 2e-2
    on_plane = (np.abs(x - lo[0]) < t) | (np.abs(x - hi[0]) < t) | (np.abs(y - lo[1]) < t) | (np.abs(y - hi[1]) < t) | (np.abs(z) < t)
    on = (on_plane & (z < zf + t2) & within) | (np.abs(z - zf) < t2)
    inner = (x > lo[0] + t) & (x < hi[0] - t) & (y > lo[1] + t) & (y < hi[1] - t)
    return on, inner & (z > zf + t2)


@pytest.fixture(scope="module")
def made():
    """Every (library, kind) textured once: {(lib, kind): (result, Textured, base)}."""
    out = {}
    for lib, maker in (("build123d", b123d_part), ("cadquery", cq_part)):
        for kind in ("plate", "cylinder", "sine"):
            part, face = maker(kind)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", TexcadWarning)  # the cylinder's texture is stretched to fit
                res = texcad.texture(part, face, TEX, height=1.0, pitch=PITCH)
            out[lib, kind] = (res, res, part)
    return out


CASES = [(lib, kind) for lib in ("build123d", "cadquery") for kind in ("plate", "cylinder", "sine")]


@pytest.mark.parametrize("lib,kind", CASES)
def test_step_stl_3mf(made, tmp_path, lib, kind):
    res, tx, _ = made[lib, kind]
    if lib == "cadquery":
        import cadquery as cq

        assert isinstance(res.workplane, cq.Workplane) and res.workplane.val().isValid()
    stl, mf, step = tx.export(tmp_path / "p.stl"), tx.export(tmp_path / "p.3mf", separate_texture=True), tx.export(tmp_path / "p.step")
    m = trimesh.load(stl)
    assert m.is_watertight and m.is_winding_consistent
    shape = texcad.io.read_step(step)
    chk = brep.check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1 and chk["closed"]
    assert brep.volume(shape) == pytest.approx(m.volume, rel=1e-3)
    scene = trimesh.load(mf)
    assert scene.units == "millimeter"
    assert sum(g.volume for g in scene.geometry.values()) == pytest.approx(m.volume, rel=1e-3)
    xml = zipfile.ZipFile(mf).read("3D/3dmodel.model").decode()
    assert xml.count("<item ") == 1 and xml.count("<object ") == 1  # one object of two parts
    from texcad.io import read_part

    assert [n for n, _ in read_part(mf)] == ["base", "texture"]


@pytest.mark.parametrize("lib,kind", CASES)
def test_texture_lies_on_the_selected_face_only(made, lib, kind):
    """Every vertex of the fused mesh is either unchanged on the base body's surface
    or texture right over the selected face; the same for the texture alone."""
    _, tx, _ = made[lib, kind]
    base = trimesh.Trimesh(tx.base_mesh.vertices, tx.base_mesh.faces)
    for m in (tx.mesh, tx.texture_mesh):
        v = m.vertices.astype(np.float64)
        on_base, over_face = classify(kind, v, base)
        assert (on_base | over_face).all(), v[~(on_base | over_face)][:5]
        assert (over_face & ~on_base).sum() > 100  # there is texture
    # Nothing sticks out further than the texture height (+ the 10 um lift, sag).
    lo, hi = base.bounds
    mlo, mhi = tx.mesh.bounds
    assert (mhi - hi).max() <= 1.0 + 0.05 and (lo - mlo).max() <= 1.0 + 0.05


def test_planar_face_of_any_outline(tmp_path):
    """A plate with a hole and a notch: the texture is clipped to the outline, 0 mm
    on every cell the outline crosses, so the B-rep keeps the face's own edges."""
    from build123d import Axis, Box, Cylinder, Pos

    part = Box(50, 30, 6) - Cylinder(6, 10) - Pos(25, 15, 0) * Box(20, 10, 10)
    top = part.faces().sort_by(Axis.Z)[-1]
    tx = texcad.texture(part, top, "builtin:stones", height=0.8, pitch=0.5)
    assert "brep_volume" not in tx.info  # the B-rep is made on first use
    chk = brep.check_shape(tx)
    assert chk["valid"] and chk["solids"] == 1 and chk["faces"] > len(part.faces())  # tiles, planar faces around them
    # (the mesh's hole is OCCT's 10 um tessellation of the circle: 3e-5 smaller; the
    # B-rep has one pole per pixel, the lean mesh is within 0.02 mm of it)
    assert abs(tx.info["brep_volume"] - tx.mesh.volume) <= 1e-4 * tx.mesh.volume + 0.02 * 50 * 30
    assert tx.max_error <= 0.02 + 1e-6
    v = tx.mesh.vertices.astype(np.float64)
    up = v[:, 2] > 3 + 1e-4
    r = np.hypot(v[up, 0], v[up, 1])
    assert r.min() > 6 + 0.5  # away from the hole by the border band
    assert not ((v[up, 0] > 15 - 0.5) & (v[up, 1] > 10 - 0.5)).any()  # not in the notch
    # The M-I ramp: nowhere steeper than the edge angle near the outline.
    h = tx.heightmap.heights
    assert float(h.max()) == pytest.approx(0.8, abs=1e-3)


def test_builder_mode_and_further_use():
    from build123d import Axis, Box, BuildPart, Cylinder, Hole, Location, Part, Pos, Rot, add

    with BuildPart() as bp:
        Box(40, 30, 8)
    tx = texcad.texture(bp, bp.faces().sort_by(Axis.Z)[-1], TEX, height=1.0, pitch=PITCH)
    assert isinstance(tx, texcad.Textured) and isinstance(tx.part, Part)
    lo, hi = tx.mesh.bounds
    assert hi[2] == pytest.approx(5.0, abs=1e-4) and lo[2] == pytest.approx(-4.0)
    # Location: the meshes follow the part.
    moved = Pos(10, 0, 0) * tx
    assert isinstance(moved, texcad.Textured)
    assert moved.mesh.bounds[0][0] == pytest.approx(lo[0] + 10, abs=1e-4)
    turned = tx.moved(Location((0, 0, 0), (0, 0, 90)))
    assert turned.mesh.bounds[1][1] == pytest.approx(20, abs=1e-4)
    rot = Rot(0, 0, 90) * tx
    assert np.allclose(rot.mesh.bounds, turned.mesh.bounds, atol=1e-4)
    # Further booleans give textured parts whose mesh and B-rep agree.
    cut = tx - Cylinder(3, 50)
    assert cut.mesh.is_watertight
    removed = tx.volume - cut.volume  # the hole: 8 mm of body and up to 1 mm of texture
    assert np.pi * 9 * 8 < removed < np.pi * 9 * 9
    # The B-rep is OCCT's boolean, checked against the mesh: right, or an error (OCCT's
    # cut through a large B-spline face can keep material: never silently).
    try:
        shape = cut.shape
    except GeometryError as e:
        assert "write STL or 3MF" in str(e)
    else:
        assert brep.check_shape(shape)["valid"] and brep.volume(shape) == pytest.approx(cut.volume, rel=2e-3)
    with BuildPart() as bp2:
        add(tx.part)
        Hole(2)
    assert bp2.part.is_valid and bp2.part.volume < tx.volume


def test_cadquery_shape_in_shape_out():
    import cadquery as cq

    box = cq.Solid.makeBox(20, 20, 10)
    out = texcad.texture(box, box.faces(">Z"), "builtin:stones", height=0.5, pitch=0.5)
    assert isinstance(out, texcad.Textured) and out.mesh.is_watertight
    wp = out.workplane
    assert isinstance(wp, cq.Workplane) and wp.val().isValid()
    # the B-rep keeps one pole per pixel, the mesh is lean: within its tolerance x area
    assert abs(wp.val().Volume() - out.volume) <= 1e-3 * out.volume + out.info["volume_slack"]


def test_errors_name_the_problem():
    from build123d import Axis, Box, Sphere

    box = Box(10, 10, 10)
    other = Box(5, 5, 5).faces().sort_by(Axis.Z)[-1]
    with pytest.raises(ParameterError, match="not a face of this part"):
        texcad.texture(box, other, TEX)
    with pytest.raises(ParameterError, match="not a face of this part"):  # several faces (issue 13): each checked
        texcad.texture(box, [box.faces()[0], other], TEX)
    with pytest.raises(ParameterError, match="flat"):
        texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:pins", pitch=1.0)
    ball = Sphere(5)  # spheres are textured since issue 13 (tests/test_faces.py); a 4 mm pixel is too coarse here:
    # the hexagons fitted at it are flat (named as such since the real-parts run), or the sphere too small for it
    with pytest.raises((GeometryError, ParameterError), match="no texture is left|smaller than a few|is flat .* use a smaller pitch"):
        texcad.texture(ball, ball.faces()[0], TEX, pitch=4.0)
    with pytest.raises(ParameterError, match="mapping"):
        texcad.texture(box, box.faces()[0], TEX, mapping="bent")


def test_brep_false_is_mesh_only(tmp_path):
    from build123d import Axis, Box

    box = Box(20, 20, 5)
    tx = texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], TEX, height=1.0, pitch=PITCH, brep=False)
    assert tx.mesh.is_watertight and tx.volume > box.volume
    with pytest.raises(GeometryError, match="brep=True"):
        tx.export(tmp_path / "x.step")


def test_render_and_cli_render(made, tmp_path):
    from PIL import Image

    _, tx, _ = made["build123d", "cylinder"]
    png = texcad.render.render_part(tx, tmp_path / "a.png", width=160)
    img = np.asarray(Image.open(png))
    assert img.shape[1] == 160 and img.std() > 10  # a picture, not a blank
    tx.export(tmp_path / "c.step")
    tx.export(tmp_path / "c.stl")
    from texcad.cli import main

    for src in ("c.step", "c.stl"):
        assert main(["render", str(tmp_path / src), "-o", str(tmp_path / f"{src}.png"), "--width", "120", "--view", "0,1,-0.5"]) == 0
        assert Image.open(tmp_path / f"{src}.png").size[0] == 120
    assert main(["render", str(tmp_path / "missing.stl"), "-o", str(tmp_path / "x.png")]) == 2


@pytest.mark.filterwarnings("ignore:reset_camera")
def test_show_sends_texcads_mesh(made, monkeypatch):
    """``show()`` hands the viewer texcad's mesh (a triangulation-only face), which
    the viewer's own tessellation pipeline passes through unchanged."""
    import warnings

    ocp_vscode = pytest.importorskip("ocp_vscode")
    from OCP.BRep import BRep_Tool
    from OCP.TopLoc import TopLoc_Location

    monkeypatch.setattr(warnings, "formatwarning", warnings.formatwarning)  # the viewer's converter replaces it
    sent = {}
    monkeypatch.setattr(ocp_vscode, "show", lambda *objs, **kw: sent.setdefault("objs", objs))
    _, tx, _ = made["build123d", "plate"]
    texcad.show(tx)
    (face,) = sent["objs"]
    tri = BRep_Tool.Triangulation_s(face, TopLoc_Location())
    assert tri.NbTriangles() == tx.mesh.num_triangles and tri.HasNormals()
    offline = pytest.importorskip("ocp_viewer_core.offline")
    monkeypatch.setenv("OCP_VIEWER_PYTEST", "1")
    instances = offline._convert(face)[0][0]
    verts = np.concatenate([np.asarray(i["vertices"]).reshape(-1, 3) for i in instances if "vertices" in i])
    assert len(verts) == 3 * tx.mesh.num_triangles
    assert np.allclose(verts.min(axis=0), tx.mesh.bounds[0], atol=1e-3)


def test_show_leaves_the_warning_format_as_it_was(made, monkeypatch):
    """The viewer (ocp_vscode, ocp_viewer_core) sets its own one-line warning format
    for the whole process when it shows a part; texcad.show puts the caller's back."""
    import warnings

    ocp_vscode = pytest.importorskip("ocp_vscode")
    before = warnings.formatwarning
    monkeypatch.setattr(warnings, "formatwarning", before)

    def viewer(*objs, **kw):
        warnings.formatwarning = lambda *a, **k: "one line\n"

    monkeypatch.setattr(ocp_vscode, "show", viewer)
    texcad.show(made["build123d", "plate"][1])
    assert warnings.formatwarning is before


def test_cli_texture_step_part(tmp_path):
    from build123d import Cylinder, export_step

    from texcad.cli import main

    src = tmp_path / "cyl.step"
    export_step(Cylinder(10, 30), str(src))
    outs = [tmp_path / "o.step", tmp_path / "o.stl"]
    argv = ["texture", str(src), "--face", "cylinder", "--texture", TEX, "--pitch", "1", "-q"]
    assert main(argv + sum((["-o", str(o)] for o in outs), [])) == 0
    stl = trimesh.load(outs[1])
    assert stl.is_watertight and stl.bounds[1][0] > 10.5  # the texture is on the side
    assert brep.volume(texcad.io.read_step(outs[0])) == pytest.approx(stl.volume, rel=1e-3)
    assert main(["texture", str(src), "--face", "top", "-o", str(tmp_path / "x.stl")]) == 0
    assert main(["texture", str(src), "--face", "up", "-o", str(tmp_path / "x.stl")]) == 2
