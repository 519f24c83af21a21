import numpy as np
import pytest

import texcad
from texcad.sources import BUILTINS


def test_at_least_three_builtins_default_first():
    names = texcad.sources.builtin_names()
    assert len(names) >= 3
    assert names[0] == texcad.sources.DEFAULT_TEXTURE


@pytest.mark.parametrize("name", list(BUILTINS))
def test_builtin_tiles_seamlessly(name):
    tx, ty = BUILTINS[name].tile
    two = texcad.builtin(name, size=(2 * tx, 2 * ty), pitch=0.1, height=1.0).heights
    rows, cols = two.shape
    # Exactly periodic: the second tile repeats the first, in x and in y.
    assert np.abs(two[:, : cols // 2] - two[:, cols // 2 :]).max() < 1e-5
    assert np.abs(two[: rows // 2] - two[rows // 2 :]).max() < 1e-5
    one = texcad.builtin(name, size=(tx, ty), pitch=0.1, height=1.0).heights
    # The wrap seam (last column -> first) is no bigger than steps inside.
    seam = np.abs(one[:, -1] - one[:, 0]).max()
    assert seam <= np.abs(np.diff(one, axis=1)).max() + 1e-6
    assert np.isclose(one.min(), 0.0) and np.isclose(one.max(), 1.0)


def test_builtin_prefix_and_errors():
    a = texcad.load_texture("builtin:pins", size=(6, 6), pitch=0.25, height=2.0)
    assert a.shape == (24, 24) and np.isclose(a.max_height, 2.0)
    with pytest.raises(texcad.ParameterError, match="unknown built-in texture 'nope'.*stones"):
        texcad.builtin("nope")
    with pytest.raises(texcad.ParameterError):
        texcad.builtin("pins", pitch=-1)


def test_deterministic():
    a = texcad.builtin("stones", size=30, pitch=0.2).heights
    b = texcad.builtin("stones", size=30, pitch=0.2).heights
    assert a.tobytes() == b.tobytes()


# -- the library: parametric, periodic, rendered ------------------------------------------
REQUIRED = {
    "stones", "diamond_knurl", "straight_knurl", "pins", "hexagons", "dimples",
    "scales", "leather", "sand", "wood", "weave", "brick", "ridges",
}


def test_library_has_the_textures_for_am_parts():
    names = texcad.sources.builtin_names()
    assert len(names) >= 12 and REQUIRED <= set(names)
    for name in names:
        tex = BUILTINS[name]
        assert tex.description and tex.params, name
        assert all(p.unit in ("mm", "deg", "count", "seed") for p in tex.params.values())


@pytest.mark.parametrize(
    "name,params",
    [
        ("pins", {"period": 4.0, "diameter": 2.0}),
        ("stones", {"cell": 3.0, "count": 4, "seed": 5}),
        ("hexagons", {"period": 3.3}),
        ("sand", {"grain": 0.7, "tile": 7.0}),
        ("wood", {"rings": 3, "length": 17.0}),
        ("chevrons", {"angle": 45.0}),
        ("scales", {"scale": 1.37}),
        ("weave", {"scale": 0.8}),
    ],
)
def test_parametric_textures_tile_seamlessly(name, params):
    params = dict(params)
    scale = params.pop("scale", 1.0)
    (tx, ty), _ = BUILTINS[name].configure(scale=scale, **params)
    two = texcad.builtin(name, size=(2 * tx, 2 * ty), pitch=0.1, scale=scale, **params).heights
    rows, cols = two.shape
    assert rows % 2 == 0 and cols % 2 == 0
    assert np.abs(two[:, : cols // 2] - two[:, cols // 2 :]).max() < 1e-5
    assert np.abs(two[: rows // 2] - two[rows // 2 :]).max() < 1e-5
    one = two[: rows // 2, : cols // 2]
    for axis in (0, 1):  # wrap seam no bigger than the steps inside
        seam = np.abs(np.take(one, -1, axis) - np.take(one, 0, axis)).max()
        assert seam <= np.abs(np.diff(one, axis=axis)).max() + 1e-6


def test_parameters_set_feature_size_in_mm():
    default = texcad.builtin("pins", pitch=0.1)
    assert np.allclose(default.size, (3.0, 3.0))
    big = texcad.builtin("pins", pitch=0.1, period=6.0, diameter=2.4, flank=0.4)
    scaled = texcad.builtin("pins", pitch=0.1, scale=2.0)
    assert np.allclose(big.size, (6.0, 6.0)) and big.heights.tobytes() == scaled.heights.tobytes()
    # Pin footprint: area fraction above half height = pi d^2 / 4 / p^2.
    frac = np.mean(big.heights > 0.5)
    assert abs(frac - np.pi * 2.4**2 / 4 / 36) < 0.01
    # The same through a builtin:NAME spec string (CLI, recipes, load_texture).
    spec = texcad.load_texture("builtin:pins:period=6,diameter=2.4,flank=0.4", pitch=0.1, height=1.0)
    assert spec.heights.tobytes() == big.heights.tobytes()
    assert texcad.load_texture("builtin:pins:scale=2", pitch=0.1).heights.tobytes() == scaled.heights.tobytes()


def test_parameter_errors_name_the_problem():
    with pytest.raises(texcad.ParameterError, match="unknown parameter 'perod'.*period, diameter, flank"):
        texcad.builtin("pins", perod=4)
    with pytest.raises(texcad.ParameterError, match=r"diameter \+ flank .* less than the period"):
        texcad.builtin("pins", diameter=3.0)
    with pytest.raises(texcad.ParameterError, match="length and must be > 0 mm"):
        texcad.builtin("brick", length=-1)
    with pytest.raises(texcad.ParameterError, match="whole number"):
        texcad.builtin("stones", count=2.5)
    with pytest.raises(texcad.ParameterError, match=r"\[0, 90\) degrees"):
        texcad.builtin("chevrons", angle=95)
    with pytest.raises(texcad.ParameterError, match="key=number"):
        texcad.load_texture("builtin:pins:period", pitch=0.1)
    with pytest.raises(texcad.ParameterError, match="scale"):
        texcad.builtin("pins", scale=0)


@pytest.mark.parametrize("name", ["sand", "leather", "wood", "stones"])
def test_random_textures_are_seeded(name):
    a = texcad.builtin(name, size=10, pitch=0.2).heights
    assert a.tobytes() == texcad.builtin(name, size=10, pitch=0.2).heights.tobytes()
    assert a.tobytes() != texcad.builtin(name, size=10, pitch=0.2, seed=99).heights.tobytes()


def test_contact_sheet_renders_every_texture(tmp_path):
    from PIL import Image

    from texcad.render import contact_sheet

    path = contact_sheet(tmp_path / "sheet.png", cell=64, columns=5)
    with Image.open(path) as im:
        a = np.asarray(im.convert("L"), dtype=np.float64)
    n = len(BUILTINS)
    assert a.shape == (24 + -(-n // 5) * (64 + 18 + 8), 8 + 5 * (64 + 8))
    for k in range(n):  # every picture shows relief (not blank, not flat)
        r, c = divmod(k, 5)
        x0, y0 = 8 + c * 72, 24 + r * 90 + 18
        pic = a[y0 : y0 + 64, x0 : x0 + 64]
        assert pic.std() > 5, texcad.sources.builtin_names()[k]
    with pytest.raises(texcad.ParameterError):
        contact_sheet(tmp_path / "bad.png", ["nope"])
    assert not (tmp_path / "bad.png").exists()
