"""Print orientation on the curved-surface and CAD paths: ``build_dir`` / ``critical_angle``.

``texcad.pipeline.textured_surface`` and ``texcad.texture`` take the same option as
``texcad.pipeline.textured_plate``: with it, ``texcad.check`` finds no overhanging texture face
for that build direction (paper, sections 3.1-3.3); without it, it does.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from build123d import Align, Axis, Box, CenterArc, GeomType, Line, Plane, SortBy, extrude, make_face

import texcad
from texcad.errors import ParameterError
from texcad.printability import LimitReport, orientation

PITCH = 0.5  # mm, coarse for test speed
HEIGHT = 2.0  # mm (paper, section 3.3)


def noise(rows: int, cols: int, pitch: float = PITCH, seed: int = 7) -> texcad.Heightmap:
    """Smoothed random heights, 0..2 mm: facets slope every way."""
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    a = ndimage.gaussian_filter(rng.random((rows, cols)), 0.8, mode="wrap")
    return texcad.Heightmap.from_array(a, pitch=pitch, height=HEIGHT)


def arc_surface() -> texcad.Surface:
    """Circular arc, radius 80 mm, 100 mm arc length, bulging up (paper, eq. 5-8)."""
    return texcad.Surface.arc(80.0, np.degrees(100.0 / 80.0), 100.0, 5.0)


def texture_overhang(part, d) -> float:
    rep = texcad.check(part, build_dir=d)
    assert rep.watertight and rep.shells == 1
    return rep.texture_overhang_area_mm2


# -- textured_surface --------------------------------------------------------------------
def sine_surface() -> texcad.Surface:
    """z = 5 sin(2 pi x / 50), 0 <= x <= 100 mm, flat bottom (paper, eq. 9)."""
    return texcad.Surface.sine(5.0, 50.0, 100.0, 100.0, 5.0)


@pytest.mark.parametrize(
    "surface, mapping, pitch",
    [(arc_surface, "angle", PITCH), (arc_surface, "distance", PITCH), (sine_surface, "distance", 1.0)],
    ids=["arc-angle", "arc-distance", "sine-distance"],
)
def test_textured_surface_build_dir_removes_texture_overhang(surface, mapping, pitch):
    surf = surface()
    hm = noise(int(100 / pitch) - 1, int(surf.profile.length / pitch) - 1, pitch)
    d = orientation(60, "+x")
    plain = texcad.pipeline.textured_surface(surf, hm, mapping=mapping)
    fixed = texcad.pipeline.textured_surface(surf, hm, mapping=mapping, build_dir=d)
    assert plain.limits is None
    assert texture_overhang(plain, d) > 10.0  # mm2
    assert texture_overhang(fixed, d) == 0.0
    rep = fixed.limits
    assert isinstance(rep, LimitReport) and rep.remaining_overhang_mm2 == 0.0
    assert rep.removed_volume_mm3 > 0 and rep.touched_fraction < 0.2
    # Heights only go down (the ramped bottom border sinks a little into the base).
    assert np.all(fixed.heightmap.heights <= hm.heights)
    assert "x0" in rep.ramped_borders and "x1" not in rep.ramped_borders


def test_textured_surface_build_dir_leaves_printable_texture_alone():
    # Tilted 0 degrees the arc's steepest point tilts 36 degrees: nothing overhangs.
    surf = arc_surface()
    hm = noise(199, 199)
    part = texcad.pipeline.textured_surface(surf, hm, mapping="distance", build_dir=(0, 0, 1))
    assert part.limits.removed_volume_mm3 == 0.0 and part.limits.ramped_borders == ()
    assert np.array_equal(part.heightmap.heights, hm.heights)


@pytest.mark.filterwarnings("ignore::texcad.TexcadWarning")
def test_textured_surface_closed_profile_upright():
    # A cylinder printed standing on its end (build direction along its axis, +y):
    # its lower border and every texture facet facing down are fixed, across the seam too.
    surf = texcad.Surface.cylinder(20.0, 60.0)
    d = (0.0, 1.0, 0.0)
    plain = texcad.pipeline.textured_surface(surf, "builtin:stones:scale=0.5", pitch=PITCH, mapping="angle")
    fixed = texcad.pipeline.textured_surface(surf, "builtin:stones:scale=0.5", pitch=PITCH, mapping="angle", build_dir=d)
    assert texture_overhang(plain, d) > 100.0
    assert texture_overhang(fixed, d) == 0.0
    assert fixed.limits.ramped_borders == ("y0",)
    assert fixed.mapped.closed and fixed.mapped.x_scale == pytest.approx(plain.mapped.x_scale)


@pytest.mark.filterwarnings("ignore::texcad.TexcadWarning")
def test_textured_surface_build_dir_errors():
    surf = arc_surface()
    hm = noise(40, 40)
    with pytest.raises(ParameterError, match="non-zero"):
        texcad.pipeline.textured_surface(surf, hm, build_dir=(0, 0, 0))
    with pytest.raises(ParameterError, match="critical_angle"):
        texcad.pipeline.textured_surface(surf, hm, build_dir=(0, 0, 1), critical_angle=95)
    with pytest.raises(ParameterError, match="mapping='angle'"):
        texcad.pipeline.textured_surface(texcad.Surface.cylinder(10.0, 20.0), "builtin:sand", pitch=1.0, mapping="distance", build_dir=(0, 0, 1))


# -- texcad.texture on build123d parts (build direction in world coordinates) -------------
def check_3mf(tx, d, path) -> float:
    """Texture overhang of the 3MF a result writes, for build direction ``d``: a result
    limited for a build direction is written placed as printed (that direction is +z
    in the file), an unlimited one as it is."""
    tx.export(path, separate_texture=True)
    return texture_overhang(path, d if tx.stages.options.directions is None else (0.0, 0.0, 1.0))


def test_texture_planar_face_world_build_dir(tmp_path):
    # The box's +x side face: its frame is (y, z, x) in world terms. Printed as placed
    # (world +z up) the texture on the wall has facets facing down.
    box = Box(40, 30, 30, align=(Align.MIN, Align.MIN, Align.MIN))
    side = box.faces().sort_by(Axis.X)[-1]
    hm = noise(56, 56)
    d = (0.0, 0.0, 1.0)
    plain = texcad.texture(box, side, hm, brep=False)
    fixed = texcad.texture(box, side, hm, brep=False, build_dir=d)
    assert check_3mf(plain, d, tmp_path / "plain.3mf") > 1.0
    assert check_3mf(fixed, d, tmp_path / "fixed.3mf") < 1e-6  # float32 vertices turned as printed
    assert fixed.limits.removed_volume_mm3 > 0 and fixed.info["build_dir"] == [[0.0, 0.0, 1.0]]
    # Tilted the other way round: the same face printed lying on its back needs nothing.
    flat = texcad.texture(box, side, hm, brep=False, build_dir=(1.0, 0.0, 0.0))
    assert flat.limits.removed_volume_mm3 == 0.0


def test_texture_top_face_tilted(tmp_path):
    box = Box(40, 40, 5, align=(Align.MIN, Align.MIN, Align.MAX))
    top = box.faces().sort_by(SortBy.AREA)[-1]
    d = orientation(100, "+y")  # leaning past upright: facets steeper than 35 deg overhang
    hm = noise(76, 76)
    plain = texcad.texture(box, top, hm, brep=False)
    fixed = texcad.texture(box, top, hm, build_dir=d)  # with the B-rep
    assert check_3mf(plain, d, tmp_path / "plain.3mf") > 0.0
    assert check_3mf(fixed, d, tmp_path / "fixed.3mf") < 1e-6  # float32 vertices turned as printed
    assert texcad.brep.solids.check_shape(fixed.wrapped)["valid"]


def test_texture_curved_face_world_build_dir(tmp_path):
    angle = np.degrees(100.0 / 80.0)
    outer = CenterArc((0, 0), 80.0, 90 - angle / 2, angle)
    inner = CenterArc((0, 0), 75.0, 90 - angle / 2, angle)
    part = extrude(Plane.XZ * make_face([outer, Line(outer @ 1, inner @ 1), inner, Line(inner @ 0, outer @ 0)]), amount=-60.0)
    face = part.faces().filter_by(GeomType.CYLINDER).sort_by(SortBy.AREA)[-1]
    hm = noise(119, 199)
    d = orientation(60, "+x")
    plain = texcad.texture(part, face, hm, mapping="angle", brep=False)
    fixed = texcad.texture(part, face, hm, mapping="angle", build_dir=d)
    assert check_3mf(plain, d, tmp_path / "plain.3mf") > 10.0
    assert check_3mf(fixed, d, tmp_path / "fixed.3mf") < 1e-6  # float32 vertices turned as printed
    # One end of the arc faces down: its border is ramped (which one depends on the face frame).
    assert fixed.limits.remaining_overhang_mm2 == 0.0 and len(fixed.limits.ramped_borders) == 1
    # STEP: one valid solid.
    fixed.export(tmp_path / "fixed.step")
    shape = texcad.io.read_step(tmp_path / "fixed.step")
    chk = texcad.brep.solids.check_shape(shape)
    assert chk["valid"] and chk["solids"] == 1


def test_texture_planar_knurl_valleys_stay_manifold(tmp_path, monkeypatch):
    # A knurl's valleys reach 0 mm inside the face: without the 1 um floor the relief
    # touches the face along lines, and the STL (welded by position) is not watertight.
    import texcad
    from texcad.targets import plane as cad

    box = Box(20, 20, 4, align=(Align.MIN, Align.MIN, Align.MAX))
    top = box.faces().sort_by(SortBy.AREA)[-1]

    def stl_watertight(tolerance: float = 0.0) -> bool:  # 0: manifold3d's union; > 0: the lean relief stitched in
        tx = texcad.texture(box, top, "builtin:diamond_knurl", height=1.0, pitch=0.125, brep=False, tolerance=tolerance)
        tx.export(tmp_path / "knurl.stl")
        return trimesh.load(tmp_path / "knurl.stl").is_watertight

    assert stl_watertight() and stl_watertight(0.02)
    monkeypatch.setattr(cad, "FLOOR", 0.0)  # without the floor: welded by the union, or refused by the gate, never a broken file
    try:
        assert stl_watertight()
    except texcad.GeometryError as exc:
        assert "gate" in str(exc)
    assert stl_watertight(0.02)  # the stitch follows the relief's boundary through the points where it touches itself
