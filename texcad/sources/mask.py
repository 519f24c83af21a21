"""Masks: where a texture goes, and how high, on a target's texture coordinates
(lengths in mm)."""

from __future__ import annotations

import os
from typing import Any, Callable

import numpy as np

from ..errors import ParameterError
from .heightmap import Heightmap

__all__ = ["mask_sampler", "mask_on_grid"]


def mask_sampler(mask: Any, size: Any) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """A function ``f(u, v)`` (mm, arrays) sampling ``mask`` bilinearly, not
    periodically, stretched over ``size`` ``(w, d)`` mm and centred on ``(0, 0)``; 0
    outside. ``mask``: values in [0, 1] (0 no texture, 1 the full height) as a 2-D
    array (row 0 at ``v = -d / 2``), a Heightmap (scaled to its maximum) or an image
    path (white 1).

    Raises:
        ParameterError: a bad ``size`` or mask values outside [0, 1]."""
    if size is None or np.size(size) != 2 or not all(np.isfinite(size)) or min(size) <= 0:
        raise ParameterError(f"mask_size must be (w, d) in mm (the texture coordinates the mask covers), got {size!r}")
    w, d = (float(t) for t in size)
    if isinstance(mask, Heightmap):
        a = np.asarray(mask.heights, np.float64)
        a = a / a.max() if a.max() > 0 else a
    elif isinstance(mask, (str, os.PathLike)):
        a = np.asarray(Heightmap.from_image(os.fspath(mask), size=(w, d), height=1.0).heights, np.float64)
    else:
        a = np.asarray(mask, dtype=np.float64)
    if a.ndim != 2 or min(a.shape) < 2 or not np.all(np.isfinite(a)) or a.min() < 0 or a.max() > 1:
        raise ParameterError(f"a mask is a 2-D array (at least 2 x 2) of values in [0, 1] (y up), got shape {a.shape}")
    rows, cols = a.shape

    def f(u, v):
        fu = (np.asarray(u) / w + 0.5) * cols - 0.5
        fv = (np.asarray(v) / d + 0.5) * rows - 0.5
        inside = (fu >= -0.5) & (fu <= cols - 0.5) & (fv >= -0.5) & (fv <= rows - 0.5)
        fu, fv = np.clip(fu, 0, cols - 1), np.clip(fv, 0, rows - 1)
        c0, r0 = np.minimum(fu.astype(np.int64), cols - 2), np.minimum(fv.astype(np.int64), rows - 2)
        tu, tv = fu - c0, fv - r0
        val = (a[r0, c0] * (1 - tu) + a[r0, c0 + 1] * tu) * (1 - tv) + (a[r0 + 1, c0] * (1 - tu) + a[r0 + 1, c0 + 1] * tu) * tv
        return np.where(inside, val, 0.0)

    return f


def mask_on_grid(mask: Any, size: Any, xs: np.ndarray, ys: np.ndarray, centre=(0.0, 0.0)) -> np.ndarray:
    """``mask`` (:func:`mask_sampler`) over ``size`` ``(w, d)`` mm centred on ``centre``
    (mm), sampled at the grid of texture coordinates ``xs`` (columns) and ``ys``
    (rows), mm: an ``(len(ys), len(xs))`` array in [0, 1]."""
    gx, gy = np.meshgrid(np.asarray(xs, np.float64) - centre[0], np.asarray(ys, np.float64) - centre[1])
    return mask_sampler(mask, size)(gx, gy)
