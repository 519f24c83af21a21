import numpy as np
import pytest

import texcad


@pytest.fixture
def rng():
    return np.random.default_rng(1234)


@pytest.fixture
def small_hm():
    """A 40 x 60 px stones texture, 0.5 mm pitch, 1.5 mm high."""
    return texcad.builtin("stones", size=(30, 20), pitch=0.5, height=1.5)


def assert_picture(path, *, min_part: float = 0.05, max_part: float = 0.98, min_size: int = 100) -> np.ndarray:
    """A PNG that shows something: at least ``min_size`` px each way, a part (pixels
    that differ from the background colour, the most common one) covering between
    ``min_part`` and ``max_part`` of the picture, and shading on it (not one flat
    colour). Returns the image as an array."""
    from PIL import Image

    img = np.asarray(Image.open(path).convert("RGB")).astype(np.int16)
    h, w, _ = img.shape
    assert h >= min_size and w >= min_size, (w, h)
    flat = img.reshape(-1, 3)
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    background = colours[np.argmax(counts)]
    part = np.abs(flat - background).sum(axis=1) > 12
    frac = float(part.mean())
    assert min_part <= frac <= max_part, f"{path}: the part covers {frac:.3f} of the picture"
    grey = flat[part].mean(axis=1)
    assert grey.std() > 4.0, f"{path}: the part is one flat colour"
    return img


def assert_heightmap_picture(path, *, min_size: int = 20) -> np.ndarray:
    """A hill-shaded heightmap PNG: at least ``min_size`` px each way and relief on it
    (grey levels spread, not one flat colour)."""
    from PIL import Image

    img = np.asarray(Image.open(path).convert("L")).astype(np.float64)
    assert min(img.shape) >= min_size, img.shape
    assert img.std() > 8.0 and np.ptp(img) > 64, f"{path}: no relief shown"
    return img
