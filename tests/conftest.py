import numpy as np
from scipy.spatial import cKDTree
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


def _seg_dist(p, a, b):
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-300), 0, 1)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1)


def distance_to_mesh(q, V, F, k=12):
    """Exact point-to-triangle distances (nearest of the ``k`` triangles with the
    closest centroids): independent of the grid coordinates."""
    tri = V[F]
    _, cand = cKDTree(tri.mean(axis=1)).query(q, k=k)
    t = tri[cand]  # (n, k, 3, 3)
    a, b, c = t[:, :, 0], t[:, :, 1], t[:, :, 2]
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    p = q[:, None, :]
    d = ((p - a) * n).sum(-1)
    foot = p - d[..., None] * n
    inside = np.ones(d.shape, bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= (np.cross(v - u, foot - u) * n).sum(-1) >= -1e-12
    edge = np.minimum.reduce([_seg_dist(p, a, b), _seg_dist(p, b, c), _seg_dist(p, c, a)])
    return np.where(inside, np.abs(d), edge).min(axis=1)


def knurled_cylinder(r: float, h: float, sides: int, *, ridges: bool, **options):
    """A cylinder mesh (mm) with a raised diamond knurl (cylindrical projection,
    limited for +z), its ridges limited or (``ridges=False``) its facets only."""
    import functools
    import warnings

    import manifold3d as m3d

    import texcad.targets.mesh as pm
    from texcad.printability import limit_relief
    from texcad.solid import Mesh

    g = m3d.Manifold.cylinder(h, r, r, sides).to_mesh()
    part = Mesh(g.vert_properties[:, :3], g.tri_verts)
    keep = pm.limit_relief
    pm.limit_relief = functools.partial(limit_relief, ridges=ridges)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return texcad.texture(part, "not-bottom", "builtin:diamond_knurl", height=1.0, projection="cylindrical",
                                  build_dir=(0, 0, 1), **options)
    finally:
        pm.limit_relief = keep
