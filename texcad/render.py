"""Pictures of results: heightmaps (and later parts) rendered to PNG.

Rendering is plain numpy: a heightmap is shown as a hill-shaded grey image lit from
the upper left, so relief reads at a glance; colour encodes nothing but light.
"""

from __future__ import annotations

import os

import numpy as np

from .heightmap import Heightmap
from .imageio import write_rgb8

__all__ = ["hillshade", "render_heightmap"]


def hillshade(hm: Heightmap, *, azimuth: float = 315.0, altitude: float = 45.0, exaggeration: float = 1.0) -> np.ndarray:
    """Lambertian shading of a heightmap.

    The surface normal is ``n = (-dh/dx, -dh/dy, 1) / |.|`` from central differences
    (mm/mm); the light comes from ``azimuth`` (degrees clockwise from +y, as on a
    map) at ``altitude`` degrees above the surface.

    Returns:
        ``(rows, cols)`` float64 in [0, 1], y-up.
    """
    h = hm.heights.astype(np.float64) * exaggeration
    gy, gx = np.gradient(h, hm.pitch[1], hm.pitch[0])
    az, alt = np.radians(azimuth), np.radians(altitude)
    light = np.array([np.sin(az) * np.cos(alt), np.cos(az) * np.cos(alt), np.sin(alt)])
    n = np.stack([-gx, -gy, np.ones_like(h)], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.clip(n @ light, 0.0, 1.0)


def render_heightmap(hm: Heightmap, path: str | os.PathLike, *, max_pixels: int = 1600) -> None:
    """Write a PNG showing the heightmap: height as brightness, shaded for relief.

    Args:
        hm: the heightmap (mm).
        path: output PNG.
        max_pixels: larger heightmaps are subsampled to at most this many pixels
            along each side.
    """
    step = max(1, int(np.ceil(max(hm.shape) / max_pixels)))
    small = Heightmap(hm.heights[::step, ::step], (hm.pitch[0] * step, hm.pitch[1] * step)) if step > 1 else hm
    shade = hillshade(small)
    top = small.max_height
    level = small.heights / top if top > 0 else np.zeros(small.shape)
    grey = 0.25 + 0.45 * level + 0.30 * shade
    write_rgb8(path, np.repeat(grey[..., None], 3, axis=2) * np.array([1.0, 0.97, 0.92]))
