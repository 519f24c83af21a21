"""The any-faces adapter (texcad.targets.faces, issue 26): the driver runs its stages,
the results pass the gate, options that do not apply are refused, the stage data are
frozen dataclasses, and CAD operations on its results work or raise a TexcadError."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import texcad
from texcad.brep import check_shape
from texcad.errors import GeometryError, ParameterError, TexcadError
from texcad.targets import ADAPTERS, FacesAdapter
from texcad.targets.faces import FacesFused, FacesPlacement, FacesRelief
from texcad.targets.patches import PatchRelief

KW = dict(pitch=0.5, height=0.6)


def _quiet(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return texcad.texture(*args, **kw)


def _spy(monkeypatch) -> list:
    """Record the adapter's stages as the driver calls them."""
    calls = []
    for name in ("place", "relief", "fuse", "expectation"):
        real = getattr(FacesAdapter, name)

        def spy(self, *a, _real=real, _name=name, **k):
            calls.append(_name)
            return _real(self, *a, **k)

        monkeypatch.setattr(FacesAdapter, name, spy)
    return calls


def test_faces_adapter_is_last():
    assert isinstance(ADAPTERS[-1], FacesAdapter)


def test_driver_runs_the_faces_stages_on_a_cone(monkeypatch):
    from build123d import Cone, GeomType

    calls = _spy(monkeypatch)
    cone = Cone(10, 5, 10)
    tx = _quiet(cone, cone.faces().filter_by(GeomType.CONE), "builtin:stones", **KW)
    assert calls == ["place", "relief", "fuse", "expectation"]
    st = tx.stages
    assert isinstance(st.adapter, FacesAdapter) and st.placement.kind == "faces"
    assert isinstance(st.placement.data, FacesPlacement) and isinstance(st.relief.data, FacesRelief)
    assert isinstance(st.fused.data, FacesFused) and all(isinstance(p, PatchRelief) for p in st.fused.data.patches)
    for d in (st.placement.data, st.relief.data, st.fused.data, st.fused.data.patches[0], st.fused.data.patches[0].bodies):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(d, dataclasses.fields(d)[0].name, None)
    # the gate ran and measured: closed, one body, the reach from the cone face
    assert tx.gate.shells.bodies == 1 and tx.mesh.is_watertight
    assert 0.6 <= tx.gate.farthest_mm <= tx.gate.reach_mm
    assert tx.volume > cone.volume + 1.0
    assert tx.max_error == 0.0 or tx.max_error <= 0.02 + 1e-9
    tm = tx.texture_mesh
    assert tm.is_watertight and tm.volume == pytest.approx(tx.volume - cone.volume, rel=0.05)


def test_several_faces_and_a_band_in_one_call():
    from build123d import Axis, Box, fillet

    box = Box(20, 20, 10)
    tx = _quiet(box, [box.faces().sort_by(Axis.Z)[-1], box.faces().sort_by(Axis.X)[-1]], "builtin:stones", **KW)
    assert len(tx.stages.fused.data.patches) == 2 and tx.heightmap is None and tx.info["face"] == "faces"
    rb = fillet(Box(30, 20, 10).edges().filter_by(Axis.Z), 4)
    band = _quiet(rb, rb.faces().filter_by(Axis.Z, reverse=True), "builtin:diamond_knurl", **KW)
    (p,) = band.stages.fused.data.patches  # the 8 side faces are one smooth band
    assert len(p.faces) == 8 and p.info["parameterization"].startswith("band")
    assert band.gate.shells.bodies == 1
    assert check_shape(band.shape)["valid"]  # flattened together: tiles with walls (issue 28)


def test_cadquery_faces_engraved_and_chained():
    cq = pytest.importorskip("cadquery")

    wp = cq.Workplane().box(20, 20, 10)
    tx = _quiet(wp, wp.faces(">Z or <X"), "builtin:stones", mode="engraved", **KW)
    assert isinstance(tx.stages.adapter, FacesAdapter)
    assert tx.volume < 20 * 20 * 10 - 1.0  # engraved: material removed
    again = _quiet(tx, wp.faces(">Y"), "builtin:stones", mode="engraved", **KW)
    assert again.stages.placement.previous is tx.stages and again.volume < tx.volume
    with pytest.raises(ParameterError, match="textured already"):
        _quiet(again, wp.faces(">Z"), "builtin:stones", **KW)
    assert check_shape(again.shape)["valid"]  # chained: on the first result's B-rep (issue 28)


@pytest.mark.parametrize("option", [dict(offset=(1, 0)), dict(periodic_x=True), dict(projection="box"), dict(length=3.0)])
def test_options_that_do_not_apply_are_refused(option):
    from build123d import Cone, GeomType

    cone = Cone(10, 5, 10)
    with pytest.raises(ParameterError, match="not an option"):
        _quiet(cone, cone.faces().filter_by(GeomType.CONE), "builtin:stones", **KW, **option)


def test_cad_operations_on_a_faces_result():
    """A planar face engraved (the any-faces path): a hole through it works on the
    B-rep; a sphere's result has one too; a band's has none and raises a TexcadError."""
    from build123d import Axis, Box, Cylinder, Sphere

    box = Box(30, 30, 10)
    tx = _quiet(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", mode="engraved", **KW)
    assert isinstance(tx.stages.adapter, FacesAdapter) and tx.fine_frame() is not None
    holed = tx - Cylinder(3, 20)
    assert holed.mesh.is_watertight and holed.volume < tx.volume - 200.0
    ball = Sphere(8)
    s = _quiet(ball, ball.faces()[0], "builtin:stones", **KW)
    try:
        cut = s - Box(4, 4, 40)
    except TexcadError:
        pass  # a clear error is allowed; a TypeError or AttributeError is not
    else:
        assert cut.mesh.is_watertight


def test_no_brep_when_told():
    from build123d import Cone, GeomType

    cone = Cone(10, 5, 10)
    tx = _quiet(cone, cone.faces().filter_by(GeomType.CONE), "builtin:stones", brep=False, **KW)
    assert not tx.has_brep
    with pytest.raises(GeometryError, match="brep=False"):
        tx.shape


def test_a_failed_brep_names_the_faces_and_the_mesh_outputs(monkeypatch):
    """``info`` carries no "no_brep" (it read as if there were none); when the B-rep
    cannot be made, the error names the faces, OCCT's reason and STL/3MF."""
    import texcad.brep
    from build123d import Cone, GeomType

    cone = Cone(10, 5, 10)
    tx = _quiet(cone, cone.faces().filter_by(GeomType.CONE), "builtin:stones", **KW)
    assert "no_brep" not in tx.info

    def fails(*a, **k):
        raise GeometryError("OCCT's splitter left a gap")

    monkeypatch.setattr(texcad.brep, "uv_textured_solid", fails)
    with pytest.raises(GeometryError, match=r"no B-rep of the textured cone face\(s\): OCCT's splitter left a gap; .*part\.stl"):
        tx.shape


def test_a_face_not_of_the_part_is_refused():
    from build123d import Box, Cone, GeomType

    cone, other = Cone(10, 5, 10), Box(5, 5, 5)
    with pytest.raises(ParameterError, match="not a face of this part"):
        _quiet(other, cone.faces().filter_by(GeomType.CONE), "builtin:stones", **KW)


def test_patch_numerics_are_plain_data():
    """A patch's stages take and return frozen dataclasses of arrays (tested alone)."""
    from build123d import Sphere

    from texcad.brep import part_tessellation, to_topods
    from texcad.options import Options
    from texcad.targets.faces import patch_options
    from texcad.targets.patches import patch_grid, patch_surface

    pm = part_tessellation(to_topods(Sphere(8)))
    k = next(i for i, f in enumerate(pm.faces) if f is not None)
    opts = patch_options(Options.make(**KW))
    g = patch_grid(pm, [k], "builtin:stones", opts)
    s = patch_surface(g, opts)
    assert g.H.shape == g.d.shape == s.surface.shape == g.grid.valid.shape
    assert np.all(s.surface[g.keep & ~s.band] >= s.floor_c - 1e-12)  # raised: at least the floor inside
    assert g.fade.min() == 0.0 and g.fade.max() == pytest.approx(1.0)  # the poles fade out, the equator keeps it all


# --- masks on any face (issue 31): the height scaled by a grey-level mask over the patch's texture coordinates ---

def _added(part, face, **kw) -> float:
    import texcad

    tx = texcad.texture(part, face, "builtin:pins", height=0.8, pitch=0.4, brep=False, **kw)
    assert tx.mesh.is_watertight and tx.gate is not None
    return float(tx.mesh.volume - part.volume)


def test_a_mask_on_a_curved_face_keeps_the_texture_where_it_is_white():
    from build123d import Cylinder, GeomType

    part = Cylinder(10, 30)
    side = part.faces().filter_by(GeomType.CYLINDER)[0]
    full = _added(part, side)
    square = np.zeros((40, 40))
    square[10:30, 10:30] = 1.0  # the middle quarter of the patch's texture coordinates
    quarter = _added(part, side, mask=square)
    assert 0.12 * full < quarter < 0.4 * full  # a quarter of the area (and the mask's bilinear rim), less its ramps
    half = _added(part, side, mask=np.full((4, 4), 0.5))
    assert half == pytest.approx(0.5 * full, rel=0.05)  # heights halved everywhere


def test_each_zone_takes_its_own_mask():
    import texcad
    from build123d import Box, Axis

    part = Box(30, 30, 10)
    top, bottom = part.faces().sort_by(Axis.Z)[-1], part.faces().sort_by(Axis.Z)[0]
    middle = np.zeros((40, 40))
    middle[10:30, 10:30] = 1.0  # white in the middle quarter of the top only
    tx = texcad.texture(part, [(top, "builtin:pins", {"mask": middle}), (bottom, "builtin:pins")], height=0.6, pitch=0.5)
    v = tx.mesh.vertices
    up = v[v[:, 2] > 5.0 + 0.05]
    assert len(up) and np.abs(up[:, :2]).max() < 7.5 + 1.0  # raised on the top only inside the mask's white square
    assert v[:, 2].min() < -5.0 - 0.4  # the bottom is textured all over
    low = v[v[:, 2] < -5.0 - 0.05]
    assert np.abs(low[:, :2]).max() > 12.0
    with pytest.raises(GeometryError, match="zone 1"):  # a black mask leaves nothing: said, with the zone
        texcad.texture(part, [(top, "builtin:pins", {"mask": np.zeros((4, 4))}), (bottom, "builtin:pins")], height=0.6, pitch=0.5)
