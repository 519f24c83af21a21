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


# -- image input options -----------------------------------------------------------------
def test_sixteen_bit_ramp_survives_exactly(tmp_path):
    levels = np.arange(65536, dtype=np.uint16).reshape(256, 256)  # every 16-bit level
    Image.fromarray(levels).save(tmp_path / "ramp.png")
    hm = Heightmap.from_image(tmp_path / "ramp.png", pitch=0.1, height=1.0)
    # y-up: image row 0 (levels 0..255) is the top, i.e. the last heightmap row.
    assert np.abs(hm.heights[::-1].ravel() - np.arange(65536) / 65535).max() < 0.5 / 65535
    hm.to_png(tmp_path / "back.png", height=1.0)
    with Image.open(tmp_path / "back.png") as im:
        back = np.asarray(im).astype(np.int64)
    assert np.array_equal(back, levels.astype(np.int64))


def test_alpha_and_palette_images(tmp_path):
    la = np.zeros((4, 6, 2), np.uint8)
    la[..., 0] = 200  # grey level
    la[:, :3, 1] = 255  # left half opaque, right half transparent
    Image.fromarray(la, mode="LA").save(tmp_path / "la.png")
    black = Heightmap.from_image(tmp_path / "la.png", pitch=1.0, height=1.0)
    assert np.allclose(black.heights[:, :3], 200 / 255, atol=1e-6) and np.all(black.heights[:, 3:] == 0)
    white = Heightmap.from_image(tmp_path / "la.png", pitch=1.0, height=1.0, alpha="white")
    assert np.allclose(white.heights[:, 3:], 1.0)
    ignore = Heightmap.from_image(tmp_path / "la.png", pitch=1.0, height=1.0, alpha="ignore")
    assert np.allclose(ignore.heights, 200 / 255, atol=1e-6)
    # Palette image with a transparent index.
    p = Image.new("P", (4, 4))
    p.putpalette([0, 0, 0, 255, 255, 255] + [0] * 762)
    p.putdata([1, 1, 0, 0] * 4)
    p.info["transparency"] = 0
    p.save(tmp_path / "p.png", transparency=0)
    hp = Heightmap.from_image(tmp_path / "p.png", pitch=1.0, height=2.0)
    assert np.allclose(hp.heights[:, :2], 2.0) and np.allclose(hp.heights[:, 2:], 0.0)
    with pytest.raises(ParameterError, match="alpha"):
        Heightmap.from_image(tmp_path / "p.png", pitch=1.0, alpha="grey")


def test_crop_in_pixels_and_mm(tmp_path):
    img = np.zeros((10, 20), np.uint8)
    img[:4, :5] = 255  # white block at the image's top-left
    Image.fromarray(img).save(tmp_path / "c.png")
    px = Heightmap.from_image(tmp_path / "c.png", pitch=0.5, height=1.0, crop=(0, 0, 5, 4))
    assert px.shape == (4, 5) and np.all(px.heights == 1.0)
    mm = Heightmap.from_image(tmp_path / "c.png", pitch=0.5, height=1.0, crop=(0, 0, 2.5, 2.0), crop_units="mm")
    assert mm.heights.tobytes() == px.heights.tobytes()
    # size describes the whole image; a crop keeps its scale.
    sized = Heightmap.from_image(tmp_path / "c.png", size=(10, 5), height=1.0, crop=(0, 0, 10, 4))
    assert np.allclose(sized.size, (5.0, 2.0))
    # Bottom-left of the image is y = 0 (row 0): crop the bottom two image rows.
    bottom = Heightmap.from_image(tmp_path / "c.png", pitch=1.0, height=1.0, crop=(0, 8, 20, 10))
    assert bottom.shape == (2, 20) and np.all(bottom.heights == 0)
    for bad in [(0, 0, 25, 4), (5, 0, 5, 4), (0, 0, 1, 1), (-1, 0, 4, 4)]:
        with pytest.raises(ParameterError, match="crop box"):
            Heightmap.from_image(tmp_path / "c.png", pitch=1.0, crop=bad)


def test_normalize_gamma_and_smooth(tmp_path):
    a = np.full((20, 40), 100, np.uint8)
    a[:, 20:] = 150
    a[0, 0] = 255  # one bright speck
    Image.fromarray(a).save(tmp_path / "n.png")
    plain = Heightmap.from_image(tmp_path / "n.png", pitch=0.5, height=2.0)
    assert np.isclose(plain.heights.max(), 2.0) and np.isclose(np.median(plain.heights), 2.0 * 125 / 255, atol=0.2)
    full = Heightmap.from_image(tmp_path / "n.png", pitch=0.5, height=2.0, normalize=True)
    assert np.isclose(full.heights.min(), 0.0) and np.isclose(full.heights.max(), 2.0)
    clipped = Heightmap.from_image(tmp_path / "n.png", pitch=0.5, height=2.0, normalize=(1, 99))
    # The speck is clipped; the two halves span the whole height.
    assert np.allclose(clipped.heights[:, :20][:-1], 0.0) and np.allclose(clipped.heights[:, 20:], 2.0)
    g = Heightmap.from_image(tmp_path / "n.png", pitch=0.5, height=1.0, gamma=2.0)
    assert np.allclose(g.heights, plain.heights.astype(np.float64) ** 2 / 4.0, atol=1e-6)
    s = Heightmap.from_image(tmp_path / "n.png", pitch=0.5, height=2.0, normalize=(1, 99), smooth=1.0)
    row = s.heights[10]
    # A Gaussian of sigma 1 mm = 2 px: the step spreads over about +-3 sigma = 12 px.
    ramp = np.flatnonzero((row > 0.05) & (row < 1.95))
    assert 6 <= len(ramp) <= 14 and abs(row[19] + row[20] - 2.0) < 0.1
    with pytest.raises(ParameterError, match="gamma"):
        Heightmap.from_image(tmp_path / "n.png", pitch=1.0, gamma=0)
    with pytest.raises(ParameterError, match="smooth"):
        Heightmap.from_image(tmp_path / "n.png", pitch=1.0, smooth=-1)
    with pytest.raises(ParameterError, match="percentile"):
        Heightmap.from_image(tmp_path / "n.png", pitch=1.0, normalize=(50, 10))


def test_no_contrast_is_an_error_when_normalizing(tmp_path):
    Image.fromarray(np.full((8, 8), 77, np.uint8)).save(tmp_path / "flat.png")
    with pytest.raises(InputError, match="flat.png.*no contrast"):
        Heightmap.from_image(tmp_path / "flat.png", pitch=1.0, normalize=True)
