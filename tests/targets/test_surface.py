"""The 2.5D surface adapter (texcad.targets.surface): a texcad.Surface or Profile runs
the one driver's stages (through texcad.texture and through the public
textured_surface), in every mode, and passes the gate; options that do not apply are
refused; a broken mesh is stopped by the gate; CAD operations raise a TexcadError."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError, ParameterError, TexcadError
from texcad.solid import Mesh, edge_report
from texcad.solid.weld import join_bodies, welded
from texcad.targets import SurfaceAdapter
from texcad.targets.surface import gradient_gain

PITCH, HEIGHT = 0.5, 0.6


@pytest.fixture(scope="module")
def surface():
    return texcad.Surface.cylinder(6.0, 8.0)


def _texture(target, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return texcad.texture(target, None, "builtin:stones", pitch=PITCH, height=HEIGHT, **kw)


def _spy(monkeypatch) -> list:
    calls = []
    for name in ("place", "relief", "fuse"):
        real = getattr(SurfaceAdapter, name)
        monkeypatch.setattr(SurfaceAdapter, name, lambda self, *a, _r=real, _n=name: calls.append(_n) or _r(self, *a))
    return calls


@pytest.mark.parametrize("mode", ["raised", "engraved", "centred"])
def test_the_driver_runs_the_surface_adapters_stages(surface, mode, monkeypatch):
    calls = _spy(monkeypatch)
    res = _texture(surface, mode=mode)
    assert calls == ["place", "relief", "fuse"]
    assert isinstance(res.stages.adapter, SurfaceAdapter) and res.kind == "surface" and res.info["mode"] == mode
    assert res.gate.shells.bodies == 1 and edge_report(res.mesh.faces)["watertight"]
    base = float(res.base_mesh.volume)
    if mode == "raised":
        assert res.volume > base
    elif mode == "engraved":
        assert res.volume < base
    tm = res.texture_mesh
    assert edge_report(tm.faces)["watertight"] and tm.volume > 0


def test_textured_surface_runs_the_driver_with_its_own_defaults(monkeypatch):
    calls = _spy(monkeypatch)
    prof = texcad.Profile.sine(2.0, 10.0, 20.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = texcad.pipeline.textured_surface(prof, "builtin:pins", length=6.0, pitch=0.5, height=0.5)
    assert calls == ["place", "relief", "fuse"]
    assert res.stages.options.mapping.value == "distance" and res.info["mapping"] == "distance"
    assert res.gate.shells.bodies == 1


def test_a_gradient_fades_the_texture(surface):
    full = _texture(surface)
    faded = _texture(surface, gradient=((0, 0, 0), (0, 8, 0)))
    base = float(full.base_mesh.volume)
    assert 0 < faded.volume - base < full.volume - base


def test_gradient_gain_is_linear_and_clipped():
    g = gradient_gain(np.array([[0, -1, 0], [0, 0, 0], [0, 2, 0], [0, 4, 0], [0, 9, 0]], float), ((0, 0, 0), (0, 4, 0)))
    assert np.allclose(g, [1, 1, 0.5, 0, 0])


def test_options_that_do_not_apply_are_refused(surface):
    with pytest.raises(ParameterError, match="edge_angle"):
        _texture(surface, edge_angle=30.0)
    with pytest.raises(ParameterError, match="where=None"):
        texcad.texture(surface, "normal:+z", "builtin:stones", pitch=PITCH)


def test_the_gate_stops_an_inside_out_mesh(surface, monkeypatch):
    real = SurfaceAdapter.fuse

    def inside_out(self, placement, relief, options):
        f = real(self, placement, relief, options)
        return dataclasses.replace(f, mesh=Mesh(f.mesh.vertices, f.mesh.faces[:, ::-1].copy()))

    monkeypatch.setattr(SurfaceAdapter, "fuse", inside_out)
    with pytest.raises(GeometryError, match="gate"):
        _texture(surface)


def test_join_bodies_refuses_a_texture_that_splits_the_base():
    import manifold3d as m3d

    def mesh(man):
        m = man.to_mesh()
        return Mesh(np.array(m.vert_properties[:, :3], np.float32), np.array(m.tri_verts, np.uint32))

    base = mesh(m3d.Manifold.cube((10.0, 10.0, 2.0)))
    cutter = mesh(m3d.Manifold.cube((2.0, 20.0, 4.0)).translate((4.0, -5.0, -1.0)))  # cuts the plate in two
    with pytest.raises(GeometryError, match="2 bodies"):
        join_bodies(base, None, cutter)
    fused, man = join_bodies(base, mesh(m3d.Manifold.cube((2.0, 2.0, 1.0)).translate((4.0, 4.0, 1.5))), None)
    assert edge_report(fused.faces)["watertight"] and abs(fused.volume - 202.0) < 1e-3  # 2 x 2 x 0.5 mm above the plate
    assert welded(man) is not None


def test_cad_operations_raise_a_texcad_error(surface):
    from build123d import Cylinder

    res = _texture(surface)
    with pytest.raises(TexcadError):
        res.shape
    try:
        cut = res - Cylinder(2, 30)
    except TexcadError:
        return
    assert cut.volume < res.volume


# ------------------------------------------------------------------------------------------
# The texture's own integral (the gate's check 4) and its helpers
# ------------------------------------------------------------------------------------------
def test_swept_volume_is_exact_between_two_polygonal_sheets():
    """A cylinder's polygon moved out (in) by h along its normals: the annulus
    between the two polygons exactly, + out, - in."""
    from texcad.mapping.surface import grid_triangles, swept_volume

    r, length, C = 6.0, 2.0, 96
    th = np.linspace(0, 2 * np.pi, C, endpoint=False)
    y = np.array([0.0, length])
    P = np.stack([np.broadcast_to(r * np.cos(th), (2, C)), np.broadcast_to(y[:, None], (2, C)),
                  np.broadcast_to(r * np.sin(th), (2, C))], -1).reshape(-1, 3)
    N = P.copy()
    N[:, 1] = 0
    N /= r
    tri = grid_triangles(2, C, closed=True)
    polygon = lambda rad: 0.5 * C * np.sin(2 * np.pi / C) * rad**2  # noqa: E731
    for h in (0.5, -0.5):
        exact = (polygon(r + h) - polygon(r)) * length
        assert swept_volume(P, P + h * N, tri, N) == pytest.approx(exact, rel=1e-9)
        assert swept_volume(P, P + h * N, tri[:, ::-1], N) == pytest.approx(exact, rel=1e-9)  # either orientation


def test_chord_excess_and_relief_integral_on_a_circle():
    from texcad.mapping.surface import chord_excess, mean_curvature, relief_integral

    r = 5.0
    prof = texcad.Profile.circle(r)
    s = np.linspace(0, prof.length, 48, endpoint=False)
    polygon = 0.5 * 48 * np.sin(2 * np.pi / 48) * r**2
    assert chord_excess(prof, s, closed=True) == pytest.approx(np.pi * r**2 - polygon, rel=2e-3)
    assert mean_curvature(prof, s, closed=True) == pytest.approx(1 / r, rel=1e-4)
    area = 2 * np.pi * r * 3.0
    h = np.full((4, 6), 0.4)
    assert relief_integral(h, area, 1 / r) == pytest.approx(np.pi * ((r + 0.4) ** 2 - r**2) * 3.0)
    assert relief_integral(-h, area, 1 / r) == pytest.approx(-np.pi * (r**2 - (r - 0.4) ** 2) * 3.0)
    assert relief_integral(np.full((4, 6), 9.0), area, -1 / r) == pytest.approx(np.pi * r**2 * 3.0)  # capped: the hole filled


@pytest.mark.parametrize("mode", ["raised", "engraved", "centred"])
def test_every_mode_states_its_integral(surface, mode):
    """:func:`texcad.targets.surface.surface_volume`: raised +, engraved -, centred
    about 0 (no nominal share); the gate's change agrees within the slack."""
    res = _texture(surface, mode=mode)
    relief, g = res.stages.relief, res.gate
    assert g.expected_volume == relief.volume and abs(g.volume_change - relief.volume) <= relief.volume_slack
    if mode == "centred":
        assert relief.nominal_volume is None and abs(relief.volume) < relief.volume_slack
    else:
        sign = 1 if mode == "raised" else -1
        assert sign * relief.volume > 2 * relief.volume_slack and sign * relief.nominal_volume > 0


def test_sheet_excess_is_the_volume_between_a_sphere_and_its_triangles():
    """The 2D chord excess: an octahedron refined on a sphere r 5 mm; the volume
    between the sphere and the triangles matches ``4/3 pi r^3 - V(polyhedron)``."""
    from texcad.mapping.surface import sheet_excess

    r = 5.0
    v = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], np.float64)
    f = np.array([[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]])
    for _ in range(4):  # per refinement: split every triangle in four, project on the sphere
        e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(e, axis=0, return_inverse=True)
        mid = v[uniq].mean(axis=1)
        m = len(v) + inv.reshape(3, -1).T
        v = np.concatenate([v, mid / np.linalg.norm(mid, axis=1, keepdims=True)])
        a, b, c = f.T
        f = np.concatenate([np.stack([a, m[:, 0], m[:, 2]], 1), np.stack([m[:, 0], b, m[:, 1]], 1),
                            np.stack([m[:, 2], m[:, 1], c], 1), np.stack(m.T, 1)])
    p = r * v
    poly = float(np.einsum("ij,ij->i", p[f[:, 0]], np.cross(p[f[:, 1]], p[f[:, 2]])).sum() / 6.0)
    assert sheet_excess(p, v, f) == pytest.approx(4 / 3 * np.pi * r**3 - poly, rel=0.03)


def test_grid_swept_is_swept_volume_on_a_grid():
    """The sliced grid form (float32 products about the centre, float64 sums) gives
    the swept prisms' volume and the sheet excess of the triangulated grid, with the
    columns wrapped (a closed profile) or the rows (a face closed around)."""
    from texcad.mapping.surface import grid_swept, grid_triangles, sheet_excess, swept_volume

    rng = np.random.default_rng(1)
    R, C = 40, 60
    th = np.linspace(0, 2 * np.pi, C, endpoint=False)
    y = np.linspace(0, 5, R)
    P = np.stack([np.broadcast_to(6 * np.cos(th), (R, C)), np.broadcast_to(y[:, None], (R, C)),
                  np.broadcast_to(6 * np.sin(th), (R, C))], -1) + 100.0
    N = P - 100.0
    N[..., 1] = 0
    N /= 6
    Q = P + rng.uniform(-0.5, 0.8, (R, C))[..., None] * N
    for wrap in (True, False):
        tri = grid_triangles(R, C, closed=wrap)
        g = grid_swept(P, Q, N, wrap_cols=wrap)
        assert g.volume == pytest.approx(swept_volume(P.reshape(-1, 3), Q.reshape(-1, 3), tri, N.reshape(-1, 3)), rel=1e-6)
        assert g.excess == pytest.approx(sheet_excess(P.reshape(-1, 3), N.reshape(-1, 3), tri), rel=1e-5)
    rows = grid_swept(*(a.transpose(1, 0, 2) for a in (P, Q, N)), wrap_rows=True)
    assert rows.volume == pytest.approx(grid_swept(P, Q, N, wrap_cols=True).volume, rel=1e-6)
    cells = np.ones((R - 1, C), bool)
    cells[:, ::2] = False
    half = grid_swept(P, Q, N, cells=cells, wrap_cols=True).volume
    assert 0.3 < half / grid_swept(P, Q, N, wrap_cols=True).volume < 0.7
