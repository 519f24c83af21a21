"""Raised, engraved and centred textures and the depth gradient on 2.5D surfaces
(`texcad.texture(Surface, None, ..., mode=..., gradient=...)`, issue 14: modes on every
entry point; the sheets are `texcad.mapping.mode_sheets`)."""

import hashlib
import warnings

import numpy as np
import pytest
import trimesh

import texcad
from texcad.errors import ParameterError
from texcad.printability import overhang_area
from texcad.solid import edge_report, to_manifold

H = 0.8


def _make(surface, mode, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return texcad.texture(surface, None, kw.pop("texture", "builtin:diamond_knurl"), height=H, pitch=0.2, mode=mode, **kw)


def _solid_ok(res):
    m = res.mesh
    assert edge_report(m.faces)["watertight"]
    tm = trimesh.Trimesh(m.vertices, m.faces)  # merged by position, as a slicer reads the STL
    assert tm.is_watertight and tm.is_winding_consistent and tm.body_count == 1
    assert to_manifold(m).volume() == pytest.approx(m.volume, rel=1e-6)


def _envelope_area(res, profile) -> float:
    """The textured area weighted by the offset's normal component per mm of height
    (mm2): the fade factor w along the normal, w |n_z| along z (distance mapping).
    The envelope slab has this area times H (to first order in H curvature)."""
    mp = res.mapped
    n = profile.at(mp.s).normal
    w = mp.factor * (1.0 if mp.mapping == "angle" else np.abs(n[:, 1]))
    prof_len = np.diff(mp.s)
    ds = np.concatenate([[prof_len[0]], 0.5 * (prof_len[1:] + prof_len[:-1]), [prof_len[-1]]]) if not mp.closed else np.full(len(mp.s), mp.s[1] - mp.s[0])
    return float(np.sum(w * ds) * (mp.y[-1] - mp.y[0] + (mp.y[1] - mp.y[0])))


SURFACES = {
    "cylinder-angle": (lambda: texcad.Surface.cylinder(10, 24), "angle"),
    "sine-distance": (lambda: texcad.Surface.sine(3.0, 20.0, 30.0, 12.0, 5.0), "distance"),
    "sine-angle": (lambda: texcad.Surface.sine(3.0, 20.0, 30.0, 12.0, 5.0), "angle"),
}


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_engraved_keeps_the_envelope_and_cuts_what_raised_adds(name):
    make, mapping = SURFACES[name]
    surf = make()
    raised = _make(surf, "raised", mapping=mapping)
    engraved = _make(surf, "engraved", mapping=mapping)
    for res in (raised, engraved):
        _solid_ok(res)
        assert res.max_error <= 0.02
    base = to_manifold(engraved.base_mesh)
    assert (to_manifold(engraved.mesh) - base).volume() < 1e-3  # nothing outside the part
    added = raised.mesh.volume - raised.base_mesh.volume
    removed = engraved.base_mesh.volume - engraved.mesh.volume
    assert removed > 0.2 * added
    # raised adds int h w dA, engraved removes int (H - h) w dA (plus its 0.01 mm floor):
    # together the envelope, H int w dA.
    area = _envelope_area(engraved, surf.profile)
    assert added + removed == pytest.approx(H * area, rel=0.05, abs=0.02 * area)


def test_engraved_knurl_keeps_the_diameter_and_centred_straddles_it():
    surf = texcad.Surface.cylinder(10, 24)
    r = {}
    for mode in ("engraved", "centred"):
        res = _make(surf, mode, mapping="angle")
        _solid_ok(res)
        v = res.mesh.vertices.astype(np.float64)
        mid = np.abs(v[:, 1] - 12.0) < 8.0  # away from the end faces
        r[mode] = np.hypot(v[mid, 0], v[mid, 2])
    assert r["engraved"].max() <= 10.0 + 1e-3
    assert r["engraved"].min() == pytest.approx(10.0 - H, abs=0.05)
    assert r["centred"].max() == pytest.approx(10.0 + H / 2, abs=0.05)
    assert r["centred"].min() == pytest.approx(10.0 - H / 2 - 0.02, abs=0.05)


def test_gradient_fades_the_engraving_along_its_axis():
    surf = texcad.Surface.cylinder(10, 24)
    res = _make(surf, "engraved", mapping="angle", gradient=((0, 0, 0), (0, 24, 0)))
    _solid_ok(res)
    v = res.mesh.vertices.astype(np.float64)
    r = np.hypot(v[:, 0], v[:, 2])
    near, far = (v[:, 1] > 2) & (v[:, 1] < 6), (v[:, 1] > 20) & (v[:, 1] < 22)
    depth_near, depth_far = 10.0 - r[near].min(), 10.0 - r[far].min()
    assert depth_near > 0.7 * H and depth_far < 0.2 * H


@pytest.mark.parametrize("mode", ["engraved", "centred"])
def test_build_dir_cut_textures_add_no_overhang(mode):
    d = (0.0, 0.0, 1.0)
    surf = texcad.Surface.arc(30.0, 60.0, 12.0, 5.0)
    res = _make(surf, mode, mapping="angle", build_dir=d, texture="builtin:stones")
    _solid_ok(res)
    assert res.limits.remaining_overhang_mm2 == 0.0
    # Independently, on the whole part: no more overhanging area than the bare base has.
    assert overhang_area(res.mesh, np.array(d), 45.0) <= overhang_area(res.base_mesh, np.array(d), 45.0) + 0.5


def test_texture_alone_and_same_bytes():
    surf = texcad.Surface.sine(3.0, 20.0, 30.0, 12.0, 5.0)
    a, b = (_make(surf, "centred", mapping="distance") for _ in range(2))
    digest = [hashlib.sha256(x.mesh.vertices.tobytes() + x.mesh.faces.tobytes()).hexdigest() for x in (a, b)]
    assert digest[0] == digest[1]
    tex = a.texture_mesh
    assert edge_report(tex.faces)["watertight"] and 0 < tex.volume < a.mesh.volume


def test_bad_mode_is_refused():
    with pytest.raises(ParameterError, match="engraved"):
        _make(texcad.Surface.cylinder(10, 24), "sunken", mapping="angle")


def test_cli_make_engraved(tmp_path):
    from texcad.cli import main

    out = tmp_path / "knurl.stl"
    code = main(["make", "--surface", "cylinder", "--radius", "8", "--length", "10", "--texture", "builtin:diamond_knurl",
                 "--height", "0.5", "--mapping", "angle", "--pitch", "0.25", "--mode", "engraved", "-o", str(out)])
    assert code == 0
    m = texcad.load_mesh(out)
    r = np.hypot(m.vertices[:, 0], m.vertices[:, 2])
    assert r.max() <= 8.0 + 1e-3 and r.min() < 8.0 - 0.4


from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402


@settings(max_examples=6, deadline=None, suppress_health_check=list(HealthCheck))
@given(
    kind=st.sampled_from(["cylinder", "sine", "arc"]),
    mode=st.sampled_from(["engraved", "centred"]),
    mapping=st.sampled_from(["angle", "distance"]),
    height=st.floats(0.2, 1.2),
    tolerance=st.sampled_from([0.0, 0.02]),
)
def test_any_surface_mode_gives_one_closed_body(kind, mode, mapping, height, tolerance):
    if kind == "cylinder":
        surf, mapping = texcad.Surface.cylinder(8, 10), "angle"
    elif kind == "sine":
        surf = texcad.Surface.sine(2.0, 15.0, 20.0, 8.0, 4.0)
    else:
        surf = texcad.Surface.arc(20.0, 70.0, 8.0, 4.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = texcad.texture(surf, None, "builtin:stones", height=height, pitch=0.25, mode=mode, mapping=mapping,
                             tolerance=tolerance)
    _solid_ok(res)
    outside = (to_manifold(res.mesh) - to_manifold(res.base_mesh)).volume()
    if mode == "engraved":
        assert outside < 1e-3
    else:
        assert 0 < outside < height * 0.6 * 2 * surf.profile.length * surf.length


def test_a_cut_deeper_than_the_wall_is_limited_with_a_warning():
    """A 4 mm engraving in a 3 mm wall (a tube, R 10 mm): cut less deep where the wall
    is too thin, with a TexcadWarning, and 0.4 of the wall left standing."""
    from texcad.errors import TexcadWarning

    surf = texcad.Surface.cylinder(10, 20, 3.0)
    with pytest.warns(TexcadWarning, match="cut less deep"):
        res = texcad.texture(surf, None, "builtin:stones", height=4.0, pitch=0.3, mode="engraved")
    _solid_ok(res)
    v = res.mesh.vertices.astype(np.float64)
    r = np.hypot(v[:, 0], v[:, 2])
    outer = r > 7.0 + 1e-3  # not the bore (r 7)
    assert r[outer].min() >= 7.0 + 0.4 * 3.0 - 1e-3


def test_raised_gradient_keeps_its_outline_on_the_surface():
    """Raised with a gradient: full height at the start end, none at the other; the
    texture's first row stands on the surface (not dipped under it as a centred slab's
    outline is)."""
    surf = texcad.Surface.cylinder(10, 24)
    res = _make(surf, "raised", mapping="angle", texture="builtin:diamond_knurl", gradient=((0, 0, 0), (0, 24, 0)))
    _solid_ok(res)
    first = res.mapped.top[0].astype(np.float64)  # the grid's first row, as mapped
    top = res.texture_mesh.vertices.astype(np.float64)
    row0 = np.abs(top[:, 1] - first[0, 1]) < 1e-4
    r = np.hypot(top[row0, 0], top[row0, 2])
    assert r.max() > 10.0 + 0.7 * H  # the knurl's ridges at full height
    v = res.mesh.vertices.astype(np.float64)
    far = v[:, 1] > 22.5
    assert np.hypot(v[far, 0], v[far, 2]).max() < 10.0 + 0.15 * H
