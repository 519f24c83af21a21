"""The one driver (texcad.pipeline.driver, issue 26): every target kind runs the same
stages (place, relief, fuse, gate) and ends in a result that passed the gate or in a
TexcadError; a property test drives random targets, faces, textures and options."""

from __future__ import annotations

import warnings

import manifold3d as m3d
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import texcad
from texcad.errors import TexcadError
from texcad.solid import Mesh


def _box_mesh(size=(20.0, 16.0, 8.0)) -> Mesh:
    m = m3d.Manifold.cube(size).to_mesh()
    return Mesh(np.array(m.vert_properties[:, :3], np.float32), np.array(m.tri_verts, np.uint32))


def _targets():
    from build123d import Axis, Box, Cone, Cylinder, GeomType, Sphere

    box = Box(20, 16, 8)
    cyl = Cylinder(6, 12)
    cone = Cone(8, 4, 10)
    ball = Sphere(8)
    return {
        "plane": (box, box.faces().sort_by(Axis.Z)[-1]),
        "extrusion": (cyl, cyl.faces().filter_by(GeomType.CYLINDER)[0]),
        "faces": (cone, cone.faces().filter_by(GeomType.CONE)[0]),
        "sphere": (ball, ball.faces()[0]),
        "surface": (texcad.Surface.cylinder(8.0, 12.0), None),
        "mesh": (_box_mesh(), "normal:+z:30"),
    }


@pytest.fixture(scope="module")
def targets():
    return _targets()


@pytest.mark.parametrize("kind", ["plane", "extrusion", "faces", "sphere", "surface", "mesh"])
def test_every_target_kind_runs_the_drivers_stages(kind, targets, monkeypatch):
    """The driver's four stages run once for each kind, in order, and the result
    carries its stages and the gate's figures."""
    import texcad.pipeline.driver as driver

    calls = []
    real_gate = driver.gate
    monkeypatch.setattr(driver, "gate", lambda mesh, ex, **k: calls.append("gate") or real_gate(mesh, ex, **k))
    part, where = targets[kind]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tx = texcad.texture(part, where, "builtin:stones", pitch=0.5, height=0.6)
    assert calls == ["gate"]
    st_ = tx.stages
    assert st_.placement.kind and st_.relief is not None and st_.fused.mesh is tx.stages.fused.mesh
    assert tx.gate.shells.manifold and tx.gate.shells.bodies == st_.placement.bodies
    if tx.gate.expected_volume is not None:
        assert abs(tx.gate.volume_change - tx.gate.expected_volume) <= tx.gate.volume_slack


def test_options_that_do_not_apply_are_refused(targets):
    part, top = targets["plane"]
    with pytest.raises(texcad.ParameterError, match="projection: not an option when texturing a planar face"):
        texcad.texture(part, top, "builtin:stones", projection="cylindrical")
    with pytest.raises(texcad.ParameterError, match="edge_angle: not an option when texturing a mesh"):
        texcad.texture(_box_mesh(), "normal:+z:30", "builtin:stones", edge_angle=30)
    with pytest.raises(texcad.ParameterError, match="hieght: not an option"):
        texcad.texture(part, top, "builtin:stones", hieght=1)


def test_api_and_cli_share_their_defaults():
    from texcad.cli import build_parser
    from texcad.options import DEFAULTS

    args = build_parser().parse_args(["texture", "part.step", "-o", "x.stl"])
    assert (args.height, args.pitch, args.tolerance, args.critical_angle) == (
        DEFAULTS.height, DEFAULTS.pitch, DEFAULTS.tolerance, DEFAULTS.critical_angle)


def test_an_option_given_at_its_default_changes_nothing():
    """The command line passes every option (``rotation=0.0`` among them): a cylinder
    is textured by the same adapter, into the same mesh, as when the options are left
    out (it went the general faces path, whose B-rep failed on a real knob), and an
    option at its default is not refused where it does not apply."""
    from build123d import Cylinder

    cyl = Cylinder(6, 8)
    side = cyl.faces().filter_by(lambda f: f.geom_type.name == "CYLINDER")[0]
    plain = texcad.texture(cyl, side, "builtin:stones", height=0.3, pitch=0.5)
    as_cli = texcad.texture(cyl, side, "builtin:stones", height=0.3, pitch=0.5, rotation=0.0, critical_angle=45.0,
                            mode="raised", tolerance=0.02)
    assert plain.stages.adapter.kind == as_cli.stages.adapter.kind == "extrusion"
    assert as_cli.volume == plain.volume
    turned = texcad.texture(cyl, side, "builtin:stones", height=0.3, pitch=0.5, rotation=10.0)
    assert turned.stages.adapter.kind == "faces"  # a rotation the extrusion path has not


_OPTIONS = st.fixed_dictionaries({}, optional={
    "height": st.one_of(st.floats(0.05, 2.0), st.sampled_from([0.0, -1.0, float("nan")])),
    "pitch": st.one_of(st.floats(0.35, 1.2), st.sampled_from([0.0, -0.5, float("inf")])),
    "mode": st.sampled_from(["raised", "engraved", "centred", "sideways"]),
    "tolerance": st.sampled_from([0.0, 0.02, 0.1, -1.0]),
    "build_dir": st.sampled_from([None, (0, 0, 1), (1, 0, 1), (0, 0, 0)]),
    "critical_angle": st.sampled_from([30.0, 45.0, 60.0, 95.0]),
})


@settings(max_examples=24, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(kind=st.sampled_from(["plane", "extrusion", "faces", "mesh"]),
       texture=st.sampled_from(["builtin:stones", "builtin:diamond_knurl", "builtin:pins", "builtin:no_such"]),
       options=_OPTIONS)
def test_every_path_ends_in_a_gated_result_or_a_texcad_error(targets, kind, texture, options):
    part, where = targets[kind]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tx = texcad.texture(part, where, texture, **options)
    except TexcadError:
        return
    assert tx.gate is not None and tx.gate.shells.manifold
    assert tx.gate.shells.bodies == tx.stages.placement.bodies
    assert tx.mesh.is_watertight
