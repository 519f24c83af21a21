"""The extruded-face adapter (texcad.targets.extrusion): a full strip of a cylinder or
an extruded profile runs the one driver's stages and passes the gate; a partial strip
is declined to the faces path; options that do not apply are refused; a broken mesh
is stopped by the gate; CAD operations on the result work or raise a TexcadError."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError, ParameterError, TexcadError
from texcad.solid import Mesh, edge_report
from texcad.options import Options
from texcad.targets import Decline, ExtrusionAdapter
from texcad.targets.extrusion import LIFT, lift

PITCH, HEIGHT = 0.5, 0.5


@pytest.fixture(scope="module")
def cylinder():
    from build123d import Cylinder, GeomType

    part = Cylinder(6, 10)
    return part, part.faces().filter_by(GeomType.CYLINDER)[0]


def _texture(part, face, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return texcad.texture(part, face, "builtin:stones", pitch=PITCH, height=HEIGHT, **kw)


def test_the_driver_runs_the_extrusion_adapters_stages(cylinder, monkeypatch):
    calls = []
    for name in ("place", "relief", "fuse"):
        real = getattr(ExtrusionAdapter, name)
        monkeypatch.setattr(ExtrusionAdapter, name, lambda self, *a, _r=real, _n=name: calls.append(_n) or _r(self, *a))
    part, face = cylinder
    res = _texture(part, face, mapping="distance")
    assert calls == ["place", "relief", "fuse"]
    assert isinstance(res.stages.adapter, ExtrusionAdapter) and res.info["face"] == "extrusion"
    assert res.gate.shells.bodies == 1 and res.gate.shells.closed
    assert edge_report(res.mesh.faces)["watertight"]
    assert res.volume > part.volume  # raised: the texture adds material
    tm = res.texture_mesh
    assert edge_report(tm.faces)["watertight"] and tm.volume > 0


@pytest.mark.parametrize("mapping", ["distance", "angle"])
def test_an_extruded_ellipse_is_textured_within_its_height(mapping):
    from build123d import Ellipse, GeomType, extrude

    part = extrude(Ellipse(10, 6), 8)
    face = [f for f in part.faces() if f.geom_type != GeomType.PLANE][0]
    res = _texture(part, face, mapping=mapping)
    assert isinstance(res.stages.adapter, ExtrusionAdapter)
    fr = res.stages.placement.data
    assert abs(fr.length - 8.0) < 1e-6 and fr.profile.closed
    # every vertex lies inside the ellipse grown by the texture's height (plus the lift)
    v = res.mesh.vertices.astype(np.float64)
    grown = HEIGHT + LIFT + 0.05
    assert np.hypot(v[:, 0] / (10 + grown), v[:, 1] / (6 + grown)).max() <= 1.0
    assert np.hypot(v[:, 0] / 10, v[:, 1] / 6).max() > 1.02  # and the texture stands out


def test_a_partial_strip_is_declined_to_the_faces_path():
    from build123d import Box, Cylinder, GeomType

    part = Cylinder(6, 10) - Box(4, 20, 4).translate((6, 0, 0))  # a notch: the side is no full strip
    face = part.faces().filter_by(GeomType.CYLINDER).sort_by(lambda f: -f.area)[0]
    with pytest.raises(Decline):
        ExtrusionAdapter().place(part, face, "builtin:stones", Options.make(pitch=1.0))


def test_options_that_do_not_apply_are_refused(cylinder):
    part, face = cylinder
    with pytest.raises(ParameterError, match="length"):
        _texture(part, face, length=5.0)
    with pytest.raises(ParameterError, match="projection"):
        _texture(part, face, projection="box")


def test_the_gate_stops_an_inside_out_mesh(cylinder, monkeypatch):
    real = ExtrusionAdapter.fuse

    def inside_out(self, placement, relief, options):
        f = real(self, placement, relief, options)
        return dataclasses.replace(f, mesh=Mesh(f.mesh.vertices, f.mesh.faces[:, ::-1].copy()))

    monkeypatch.setattr(ExtrusionAdapter, "fuse", inside_out)
    part, face = cylinder
    with pytest.raises(GeometryError, match="gate"):
        _texture(part, face)


def test_lift_keeps_the_grid_off_a_convex_profile():
    prof = texcad.Profile.circle(5.0)
    s = np.linspace(0, prof.length, 64, endpoint=False)
    p = prof.point(s)
    top = np.stack([np.stack([p[:, 0], np.full(64, y), p[:, 1]], -1) for y in (0.0, 1.0)])
    out = lift(top, prof, s, closed=True)
    ds = prof.length / 64
    dn = np.hypot(out[..., 0], out[..., 2]) - 5.0
    assert np.allclose(dn, LIFT + ds**2 / (8 * 5.0), atol=1e-6)


def test_brep_false_and_cad_operations(cylinder):
    from build123d import Cylinder

    part, face = cylinder
    res = _texture(part, face, brep=False)
    with pytest.raises(GeometryError, match="brep=False"):
        res.shape
    try:
        cut = res - Cylinder(2, 30)
    except TexcadError:
        return
    assert cut.volume < res.volume


# ------------------------------------------------------------------------------------------
# The texture's own integral (the gate's check 4)
# ------------------------------------------------------------------------------------------
def test_the_relief_states_its_integral_and_the_gate_checks_it(cylinder):
    """``Relief.volume`` (swept prisms between the profile and the lifted grid,
    :func:`texcad.targets.extrusion.extrusion_volume`) is what the union adds, within
    the slack ``(tolerance + tessellation) A``; the nominal integral (before the
    limits) is about the same when nothing limits the texture."""
    part, face = cylinder
    res = _texture(part, face)
    relief, g = res.stages.relief, res.gate
    area = 2 * np.pi * 6 * 10
    assert relief.volume_slack == pytest.approx((0.02 + 0.01) * area + 1e-3 * relief.volume + 1e-3, rel=0.05)
    assert g.expected_volume == relief.volume and abs(g.volume_change - relief.volume) <= relief.volume_slack
    assert abs(g.volume_change - relief.volume) < 0.02 * relief.volume  # in practice well inside the slack
    assert relief.nominal_volume == pytest.approx(relief.volume, rel=0.05)


def test_the_limiters_share_is_read_from_the_nominal_integral(cylinder):
    """With ``build_dir`` the applied integral is below the nominal one by what the
    overhang limiter took; the gate's change still matches the applied one."""
    part, face = cylinder
    free = _texture(part, face).stages.relief
    res = _texture(part, face, build_dir=(1, 0, 0))
    relief = res.stages.relief
    assert relief.nominal_volume == pytest.approx(free.nominal_volume)
    assert relief.volume < 0.99 * relief.nominal_volume
    assert abs(res.gate.volume_change - relief.volume) <= relief.volume_slack


def test_a_concave_face_adds_less_than_h_times_area():
    """Inside a tube (r 2 mm) the relief runs towards the axis: ``int (h - h^2 / (2 r))``,
    less than ``h A``; the gate measures it."""
    from build123d import Cylinder, GeomType

    tube = Cylinder(6, 8) - Cylinder(2, 8)
    face = [f for f in tube.faces() if f.geom_type == GeomType.CYLINDER and f.radius < 3][0]
    res = _texture(tube, face)
    relief, mapped = res.stages.relief, res.stages.relief.mapped
    area = 2 * np.pi * 2 * float(mapped.y[-1] - mapped.y[0])
    h = mapped.heightmap.heights.astype(np.float64)
    assert res.stages.adapter.kind == "extrusion"
    assert relief.volume < float(h.mean()) * area
    assert abs(res.gate.volume_change - relief.volume) <= relief.volume_slack
