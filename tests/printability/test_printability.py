"""Overhang-aware textures: M-I edge ramp, slope limiter, paper Table 2.

Curved and sine samples are built here from our own grids (texcad.solid.grid_solid),
independent of the mapping module: the profile is parametrised by arc length, texture
x runs along it, heights are offset along the surface normal (angle-preserving,
paper Algorithm 2) or along z (distance-preserving, Algorithm 1).
"""

from __future__ import annotations


import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import texcad
from texcad.report import check
from texcad.errors import ParameterError, TexcadWarning
from texcad.solid import grid_solid
from texcad.printability import (
    edge_ramp,
    face_angles,
    limit_overhangs,
    limit_overhangs_mapped,
    orientation,
    overhang_area,
    overhang_mask,
    thin_features,
)

PITCH = 0.5  # mm, coarse for test speed
SIZE = 100.0  # mm, the paper's samples (Figure 13)
HEIGHT = 2.0  # mm, the paper's texture height (section 3.3)


# -- textures (paper, Table 1: two structured, one unstructured) --------------------
def noise_texture(size=SIZE, pitch=PITCH, height=HEIGHT, seed=7) -> texcad.Heightmap:
    from scipy import ndimage

    n = int(round(size / pitch))
    rng = np.random.default_rng(seed)
    a = ndimage.gaussian_filter(rng.random((n, n)), 0.8, mode="wrap")
    return texcad.Heightmap.from_array(a, pitch=pitch, height=height)


@pytest.fixture(scope="module")
def textures():
    return {
        1: texcad.builtin("diamond_knurl", size=SIZE, pitch=PITCH, height=HEIGHT),
        2: texcad.builtin("stones", size=SIZE, pitch=PITCH, height=HEIGHT),
        3: noise_texture(),
    }


# -- synthetic 2.5D samples -----------------------------------------------------------
def profile(kind: str, cols: int, pitch: float):
    """Surface points (X, Z) and tangent angle psi (rad) at the texture columns,
    whose arc lengths are (c + 1/2) pitch. 'curved': circular arc, radius 80 mm,
    bulging up (paper Eq. 5-8); 'sine': z = 5 sin(2 pi x / 50) (Eq. 9)."""
    s = (np.arange(cols) + 0.5) * pitch
    if kind == "flat":
        return s, np.zeros(cols), np.zeros(cols)
    if kind == "curved":
        R = 80.0
        th = (s - s.mean()) / R
        return R * np.sin(th), R * np.cos(th) - R, -th
    if kind == "sine":
        A, L = 5.0, 50.0
        x = np.linspace(0.0, 1.2 * cols * pitch, 200001)
        dz = A * 2 * np.pi / L * np.cos(2 * np.pi * x / L)
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(x), 0.5 * (dz[1:] + dz[:-1]) * np.diff(x)))])
        xs = np.interp(s, arc, x)
        return xs, A * np.sin(2 * np.pi * xs / L), np.arctan(A * 2 * np.pi / L * np.cos(2 * np.pi * xs / L))
    raise ValueError(kind)


def mapped_sample(hm: texcad.Heightmap, kind: str, offset: str = "normal", thickness=5.0, depth=0.5):
    """(base, texture slab, tilt in degrees per column) for a texture on a profile."""
    R, C = hm.shape
    X, Z, psi = profile(kind, C, hm.pitch[0])
    nx, nz = (-np.sin(psi), np.cos(psi)) if offset == "normal" else (np.zeros(C), np.ones(C))
    y = (np.arange(R) + 0.5) * hm.pitch[1]
    h = hm.heights.astype(np.float64)

    def grid(off, rows):
        g = np.empty((len(rows), C, 3))
        g[..., 0] = X[None, :] + off * nx[None, :]
        g[..., 1] = rows[:, None]
        g[..., 2] = Z[None, :] + off * nz[None, :]
        return g

    slab = grid_solid(grid(h, y), grid(np.full((R, 1), -depth), y))
    yb = np.array([0.0, R * hm.pitch[1]])
    base = grid_solid(grid(np.zeros((2, 1)), yb), grid(np.full((2, 1), -thickness), yb))
    return base, slab, np.degrees(psi)


def flat_part(hm):
    return texcad.pipeline.textured_plate(hm, size=hm.size, thickness=5.0)


# -- orientation and the overhang rule --------------------------------------------------
def test_orientation_convention():
    assert np.allclose(orientation(0), [0, 0, 1])
    assert np.allclose(orientation(90, "+y"), [0, 1, 0])
    assert np.allclose(orientation(90, "-x"), [-1, 0, 0])
    d = orientation(30, 45)
    assert np.isclose(np.linalg.norm(d), 1) and np.isclose(np.degrees(np.arccos(d[2])), 30)
    with pytest.raises(ParameterError, match="tilt"):
        orientation(200)
    with pytest.raises(ParameterError, match="toward"):
        orientation(10, "up")


def _tri(normal_angle_deg):
    """A single triangle whose normal makes normal_angle_deg with +z, tilted in xz."""
    a = np.radians(normal_angle_deg)
    n = np.array([np.sin(a), 0, np.cos(a)])
    u = np.array([0, 1.0, 0])
    w = np.cross(n, u)
    v = np.array([[0, 0, 5.0], [0, 0, 5] + u, [0, 0, 5] + w])
    return texcad.Mesh(v, [[0, 1, 2]])


@pytest.mark.parametrize(
    "normal_deg, expect, rule",
    [
        (0, False, "slicers"), (90, False, "slicers"), (133.9, False, "slicers"), (134, False, "slicers"),
        (134.1, True, "slicers"), (135, True, "slicers"), (180, True, "slicers"),
        (134.9, False, "angle"), (135, False, "angle"), (135.1, True, "angle"),
    ],
)
def test_overhang_rule_45(normal_deg, expect, rule):
    # The slicers' rule (texcad check): PrusaSlicer at threshold 45 supports a face
    # flatter than 46 deg (its threshold + 1, inclusive), so a face whose normal is
    # 135 deg from the build direction (45 deg to the build plate) overhangs, one at
    # 134 deg (46 deg) does not. rule="angle": exactly 45 deg is printable.
    m = _tri(normal_deg)
    # Put a lower point elsewhere so the face is not on the build plate.
    m = texcad.Mesh(np.vstack([m.vertices, [[0, 0, -10]]]), m.faces)
    assert np.isclose(face_angles(m, (0, 0, 1))[0], 90 - normal_deg, atol=1e-3)
    assert bool(overhang_mask(m, (0, 0, 1), 45.0, rule=rule)[0]) is expect


def test_faces_on_build_plate_do_not_count():
    slab = texcad.solid.heightfield_slab(texcad.builtin("ridges", size=5, pitch=0.5, height=1), depth=1.0)
    bottom = slab.face_normals()[:, 2] < -0.99
    assert bottom.any() and not overhang_mask(slab, (0, 0, 1))[bottom].any()
    # Upside down: the bottom is now on top and the texture faces the build plate.
    assert overhang_area(slab, (0, 0, -1), faces=slab.groups["texture"]) > 0


# -- M-I and the slope limiter on flat textures ----------------------------------------
def test_edge_ramp_upright_plate_paper_figure_4(textures):
    hm = textures[2]
    d = orientation(90, "+y")  # standing on its y = 0 border
    out, rep = edge_ramp(hm, d)
    assert rep.ramped_borders == ("y0",)
    h, h0 = out.heights, hm.heights
    assert np.all(h[0] == 0) and np.all(h <= h0)
    # The upward-facing border and the sides keep their texture.
    assert np.array_equal(h[-1], h0[-1]) and np.array_equal(h[5:, 0], h0[5:, 0])
    # The ramp rises at most tan(45 deg) per mm away from the bottom border.
    y = (np.arange(hm.shape[0]) + 0.5) * hm.pitch[1]
    assert np.all(h <= (y - y[0])[:, None] * np.tan(np.radians(45.1)) + 1e-5)
    # Interior untouched beyond the ramp's reach.
    assert np.array_equal(h[10:], h0[10:])
    assert rep.removed_volume_mm3 > 0 and rep.max_removed_mm > 0


def test_edge_ramp_keeps_upward_borders_at_low_tilt(textures):
    out, rep = edge_ramp(textures[1], orientation(30, "+y"))
    assert rep.ramped_borders == () and np.array_equal(out.heights, textures[1].heights)


@pytest.mark.parametrize("tilt, toward", [(80, "+y"), (90, "-x"), (88, 30.0), (100, 200.0)])
def test_limiter_no_facet_overhangs_on_mesh(textures, tilt, toward):
    hm = textures[3]
    d = orientation(tilt, toward)
    slab0 = texcad.solid.heightfield_slab(hm, origin=(3.0, -7.0, 0.0))
    before = overhang_area(slab0, d, faces=slab0.groups["texture"])
    out, rep = limit_overhangs(hm, d)
    slab = texcad.solid.heightfield_slab(out, origin=(3.0, -7.0, 0.0))
    assert before > 0
    assert overhang_area(slab, d, faces=slab.groups["texture"]) == 0.0
    assert np.all(out.heights <= hm.heights)
    assert rep.remaining_overhang_mm2 == 0.0 and 0 < rep.touched_fraction < 1


def test_limiter_is_tight_along_an_axis(textures):
    # Upright along +y with 45 deg critical: facets may rise at most 45 deg along +y,
    # and the limiter uses that budget up to the slicers' margin (SLICER_MARGIN, 2.5
    # deg at 0.2 mm layers, texcad.printability.rule).
    from texcad.printability import SLICER_MARGIN

    hm = textures[3]
    out, _ = limit_overhangs(hm, orientation(90, "+y"), edges=False)
    dy = np.diff(out.heights.astype(np.float64), axis=0) / hm.pitch[1]
    assert dy.max() <= np.tan(np.radians(45 - SLICER_MARGIN)) + 1e-5
    assert dy.max() > np.tan(np.radians(45 - SLICER_MARGIN - 0.1))


def test_limiter_for_a_set_of_directions(textures):
    hm = textures[2].resampled(1.0)
    dirs = [orientation(a, "+y") for a in (0, 15, 30, 45, 60, 75, 90)] + [orientation(70, "-x")]
    out, rep = limit_overhangs(hm, dirs)
    slab = texcad.solid.heightfield_slab(out)
    for d in dirs:
        assert overhang_area(slab, d, faces=slab.groups["texture"]) == 0.0
    assert set(rep.ramped_borders) == {"y0", "x1"}
    # Only the steepest directions matter: the set gives the same as those two.
    out2, _ = limit_overhangs(hm, [orientation(90, "+y"), orientation(70, "-x")])
    assert np.allclose(out.heights, out2.heights, atol=1e-6)


def test_limiter_changes_nothing_when_nothing_overhangs(textures):
    for tilt in (0, 15, 30, 43):
        out, rep = limit_overhangs(textures[1], orientation(tilt))
        assert rep.removed_volume_mm3 == 0.0 and np.array_equal(out.heights, textures[1].heights)
    # At 45 deg the bottom border's wall makes 45 deg with the build plate: both
    # slicers support it at threshold 45 (texcad.printability.rule), so M-I ramps it
    # and nothing else.
    out, rep = limit_overhangs(textures[1], orientation(45))
    assert rep.ramped_borders == ("y0",) and np.array_equal(out.heights[8:], textures[1].heights[8:])


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    rows=st.integers(2, 24),
    cols=st.integers(2, 24),
    seed=st.integers(0, 2**31),
    tilt=st.floats(0, 130),
    toward=st.floats(0, 360),
    px=st.floats(0.1, 2.0),
    py=st.floats(0.1, 2.0),
)
def test_property_limited_slab_never_overhangs(rows, cols, seed, tilt, toward, px, py):
    rng = np.random.default_rng(seed)
    hm = texcad.Heightmap((rng.random((rows, cols)) * 3).astype(np.float32), (px, py))
    d = orientation(tilt, toward)
    out, rep = limit_overhangs(hm, d)
    slab = texcad.solid.heightfield_slab(out, origin=(11.0, 23.0, 1.0))
    assert slab.is_watertight
    assert np.all(out.heights <= hm.heights)
    assert overhang_area(slab, d, faces=slab.groups["texture"]) == 0.0
    # Walls of ramped borders carry no texture.
    if "y0" in rep.ramped_borders:
        assert np.all(out.heights[0] <= 0)


# -- mapped surfaces (section 3.1): surface tilt adds to the texture slope --------------
@pytest.mark.parametrize("kind", ["curved", "sine"])
@pytest.mark.parametrize("offset", ["normal", "vertical"])
def test_mapped_limiter_on_real_grid(textures, kind, offset):
    hm = textures[3]
    d = orientation(60, "+x")
    _, slab0, tilt = mapped_sample(hm, kind, offset)
    out, rep = limit_overhangs_mapped(hm, tilt, d, offset=offset)
    _, slab, _ = mapped_sample(out, kind, offset)
    tex = slab.groups["texture"]
    assert overhang_area(slab, d, faces=tex) == 0.0
    assert np.all(out.heights <= hm.heights)
    if offset == "normal":
        assert overhang_area(slab0, d, faces=tex) > 0


def test_mapped_limiter_warns_where_the_surface_itself_overhangs():
    hm = texcad.Heightmap(np.ones((4, 40), np.float32), 1.0)
    tilt = np.linspace(60, -60, 40)
    with pytest.warns(TexcadWarning, match="surface itself"):
        _, rep = limit_overhangs_mapped(hm, tilt, orientation(100, "+x"))
    assert rep.surface_overhang


def test_mapped_limiter_rejects_bad_tilt():
    hm = texcad.Heightmap(np.ones((4, 5), np.float32), 1.0)
    with pytest.raises(ParameterError, match="per texture column"):
        limit_overhangs_mapped(hm, [0, 1, 2], (0, 0, 1))
    with pytest.raises(ParameterError, match="upward-looking"):
        limit_overhangs_mapped(hm, [0, 0, 95, 0, 0], (0, 0, 1), offset="vertical")


# -- paper Table 2: three textures on flat, curved and sine samples ---------------------
TABLE2 = [
    (1, "flat", 0), (1, "curved", 30), (1, "sine", 15),
    (2, "flat", 45), (2, "curved", 45), (2, "sine", 0),
    (3, "flat", 15), (3, "curved", 60), (3, "sine", 30),
]  # fmt: skip
# Where the unmodified texture overhangs with alpha_crit = 45 deg: flat plates tilted
# by at most 45 deg cannot (section 3.1); the sine at 0 deg tilts at most 32 deg.
# (2, "flat") at 45 deg: its bottom border's wall makes exactly 45 deg with the build
# plate, which both slicers support at threshold 45 (texcad.printability.rule): M-I ramps it.
EXPECT_OVERHANG = {(1, "curved"), (1, "sine"), (2, "curved"), (2, "flat"), (3, "curved"), (3, "sine")}


@pytest.mark.parametrize("tex, kind, tilt", TABLE2)
def test_table2(textures, tex, kind, tilt):
    hm = textures[tex]
    if kind == "flat":
        d = orientation(tilt, "+y")
        off = check(flat_part(hm), build_dir=d)
        fixed, rep = limit_overhangs(hm, d)
        on = check(flat_part(fixed), build_dir=d)
    else:
        d = orientation(tilt, "+x")
        base, slab, psi = mapped_sample(hm, kind)
        off = check([("base", base), ("texture", slab)], build_dir=d)
        fixed, rep = limit_overhangs_mapped(hm, psi, d)
        base, slab, _ = mapped_sample(fixed, kind)
        on = check([("base", base), ("texture", slab)], build_dir=d)
    assert off.watertight and on.watertight and on.shells == 1
    assert on.texture_overhang_area_mm2 == 0.0
    if (tex, kind) in EXPECT_OVERHANG:
        assert off.texture_overhang_area_mm2 > 0 and rep.removed_volume_mm3 > 0
    else:
        assert off.texture_overhang_area_mm2 == 0.0 and rep.removed_volume_mm3 == 0.0


# -- thin features -----------------------------------------------------------------------
def test_thin_features_ridges():
    # Grip ridges, 2.5 mm pitch: at half height each ridge is 1.25 mm wide.
    hm = texcad.builtin("ridges", size=(25, 10), pitch=0.05, height=1.0)
    assert thin_features(hm, 0.4).thin_fraction < 0.05
    thin = thin_features(hm, 1.6)
    assert thin.thin_fraction > 0.95 and thin.narrow_gap_area_mm2 > 0
    with pytest.raises(ParameterError, match="nozzle"):
        thin_features(hm, 0)
