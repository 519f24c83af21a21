"""Pictures of results: heightmaps (and later parts) rendered to PNG.

Rendering is plain numpy: a heightmap is shown as a hill-shaded grey image lit from
the upper left, so relief reads at a glance; colour encodes nothing but light.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import ParameterError
from ..sources import PREFIX, Heightmap, builtin, builtin_names, rgb8_image, save_image, write_rgb8
from ..util import positive

__all__ = ["hillshade", "render_heightmap", "contact_sheet"]


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


def contact_sheet(
    path: str | os.PathLike,
    names: Sequence[str] | None = None,
    *,
    field: float = 24.0,
    cell: int = 200,
    columns: int = 5,
) -> Path:
    """Write a PNG contact sheet of built-in textures, hill-shaded and labelled.

    Each texture is sampled over the same ``field x field`` mm square (so sizes
    compare) at ``field / cell`` mm per pixel, 1 mm high, and shown like
    :func:`texcad.render.render_heightmap`: brightness ``0.25 + 0.45 h + 0.30 s``
    with ``s`` the Lambertian hill-shade (light from the upper left, 45 degrees).

    Args:
        path: output PNG (written atomically).
        names: textures to show (default: all, in :func:`builtin_names` order); each
            may carry parameters, e.g. ``"pins:period=4"``.
        field: side of the square shown per texture, mm.
        cell: side of each picture in pixels (32 to 1024).
        columns: pictures per row.

    Returns:
        The path written.

    Raises:
        ParameterError: unknown texture, bad field, cell or columns.
    """
    from PIL import Image, ImageDraw


    names = list(builtin_names() if names is None else names)
    if not names:
        raise ParameterError("names is empty; give at least one built-in texture name")
    field = positive("field", field)
    if not (isinstance(cell, (int, np.integer)) and 32 <= cell <= 1024):
        raise ParameterError(f"cell must be a whole number of pixels from 32 to 1024, got {cell!r}")
    if not (isinstance(columns, (int, np.integer)) and columns >= 1):
        raise ParameterError(f"columns must be a whole number >= 1, got {columns!r}")
    columns = min(columns, len(names))
    tiles = []
    for n in names:  # per texture
        hm = builtin(n, size=field, pitch=field / cell, height=1.0)
        shade = hillshade(hm)
        grey = 0.25 + 0.45 * hm.heights + 0.30 * shade
        rgb = np.repeat(grey[..., None], 3, axis=2) * np.array([1.0, 0.97, 0.92])
        tiles.append(rgb8_image(rgb).resize((cell, cell), Image.Resampling.BILINEAR))
    pad, label = 8, 18
    rows = -(-len(names) // columns)
    title = 24
    sheet = Image.new("RGB", (pad + columns * (cell + pad), title + rows * (cell + label + pad)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    draw.text((pad, 6), f"texcad built-in textures - each square {field:g} x {field:g} mm", fill=(0, 0, 0))
    for k, (n, im) in enumerate(zip(names, tiles)):
        r, c = divmod(k, columns)
        x0, y0 = pad + c * (cell + pad), title + r * (cell + label + pad)
        sheet.paste(im, (x0, y0 + label))
        draw.text((x0, y0 + 3), n.removeprefix(PREFIX), fill=(0, 0, 0))
    save_image(sheet, path)
    return Path(path)
