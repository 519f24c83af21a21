import numpy as np
import pytest
from PIL import Image

import texcad
from texcad import Heightmap, InputError, ParameterError, ResourceError


def _ramp(rows=20, cols=30):
    """Image-row-order ramp: bright at the top row of the image."""
    return np.linspace(1.0, 0.0, rows)[:, None] * np.ones((1, cols))


@pytest.mark.parametrize(
    "fmt,mode,scale",
    [("png", "L", 255), ("png", "I;16", 65535), ("jpeg", "L", 255), ("tiff", "I;16", 65535), ("tiff", "L", 255)],
)
def test_from_image_formats_and_depths(tmp_path, fmt, mode, scale):
    a = _ramp()
    dtype = np.uint16 if scale == 65535 else np.uint8
    path = tmp_path / f"ramp.{fmt}"
    Image.fromarray(np.round(a * scale).astype(dtype)).save(path)
    hm = Heightmap.from_image(path, size=(30, 20), height=2.0)
    assert hm.shape == (20, 30)
    assert hm.pitch == (1.0, 1.0)
    tol = 0.05 if fmt == "jpeg" else 2.0 / scale
    # Image row 0 (top, white) is the largest y: y-up storage.
    assert abs(hm.heights[-1].mean() - 2.0) < tol
    assert abs(hm.heights[0].mean() - 0.0) < tol
    # Linear in between (paper section 2.1.4).
    expected = np.linspace(0.0, 2.0, 20)
    assert np.abs(hm.heights.mean(axis=1) - expected).max() < tol + 1e-6


def test_colour_is_luminance(tmp_path):
    rgb = np.zeros((4, 4, 3), np.uint8)
    rgb[..., 1] = 255  # pure green
    Image.fromarray(rgb).save(tmp_path / "g.png")
    hm = Heightmap.from_image(tmp_path / "g.png", pitch=1.0, height=1.0)
    assert np.allclose(hm.heights, 0.7152, atol=1e-3)


def test_sixteen_bit_precision_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    h = rng.random((50, 70)) * 3.0
    hm = Heightmap.from_array(h, pitch=0.2)
    hm.to_png(tmp_path / "h.png")
    with Image.open(tmp_path / "h.png") as im:
        assert im.mode.startswith("I")
    back = Heightmap.from_image(tmp_path / "h.png", pitch=0.2, height=hm.max_height)
    # 16-bit quantisation of 3 mm: 46 nm steps.
    assert np.abs(back.heights - hm.heights).max() < 3.0 / 65535 + 1e-6


def test_invert_and_scaled():
    hm = Heightmap.from_array(np.array([[0.0, 1.0], [2.0, 0.5]]), pitch=1.0)
    inv = hm.inverted()
    assert np.allclose(inv.heights, [[2.0, 1.0], [0.0, 1.5]])
    assert np.isclose(hm.scaled(4.0).max_height, 4.0)
    assert np.allclose(hm.size, (2.0, 2.0))


def test_size_and_pitch_resample(tmp_path):
    Image.fromarray(np.full((10, 10), 128, np.uint8)).save(tmp_path / "g.png")
    hm = Heightmap.from_image(tmp_path / "g.png", size=(20, 20), pitch=0.5, height=1.0)
    assert hm.shape == (40, 40) and np.allclose(hm.pitch, 0.5)
    assert np.allclose(hm.heights, 128 / 255, atol=1e-4)


@pytest.mark.parametrize("content", [b"", b"this is not an image at all"])
def test_unreadable_images(tmp_path, content):
    p = tmp_path / "bad.png"
    p.write_bytes(content)
    with pytest.raises(InputError, match="bad.png"):
        Heightmap.from_image(p, pitch=1, height=1)


def test_missing_file_and_bad_parameters(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        Heightmap.from_image(tmp_path / "nope.png", pitch=1, height=1)
    Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "z.png")
    for kw in ({"pitch": 0, "height": 1}, {"size": (-1, 5), "height": 1}, {"pitch": 1, "height": 0}, {"pitch": 1, "height": float("nan")}):
        with pytest.raises(ParameterError):
            Heightmap.from_image(tmp_path / "z.png", **kw)
    with pytest.raises(ParameterError, match="size"):
        Heightmap.from_image(tmp_path / "z.png", height=1)
    assert issubclass(ParameterError, texcad.TexcadError)


def test_nan_heights_rejected():
    with pytest.raises(InputError, match="NaN"):
        Heightmap(np.array([[0.0, np.nan], [1.0, 1.0]]), (1.0, 1.0))


def test_size_too_large_for_memory(tmp_path):
    Image.fromarray(np.zeros((4, 4), np.uint8)).save(tmp_path / "z.png")
    with pytest.raises(ResourceError, match="GiB"):
        Heightmap.from_image(tmp_path / "z.png", size=(1e5, 1e5), pitch=0.01, height=1)
