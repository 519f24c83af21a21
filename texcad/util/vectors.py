"""Small parsers shared by the command line and the checks."""

from __future__ import annotations

import re

import numpy as np

from ..errors import ParameterError

__all__ = ["parse_vector", "smoothstep"]


def parse_vector(text: str) -> np.ndarray:
    """``"X,Y,Z"`` (commas or spaces) to a ``(3,)`` float64 vector.

    Raises:
        ParameterError: not three finite numbers, or all zero.
    """
    parts = [p for p in re.split(r"[,\s]+", str(text).strip()) if p]
    try:
        v = np.array([float(p) for p in parts], dtype=np.float64)
    except ValueError:
        raise ParameterError(f"expected three numbers X,Y,Z (e.g. 0,-0.5,0.87), got {text!r}") from None
    if v.shape != (3,) or not np.isfinite(v).all() or not np.any(v):
        raise ParameterError(f"expected three numbers X,Y,Z, not all zero (e.g. 0,0,1), got {text!r}")
    return v


def smoothstep(e0: float, e1: float, t: np.ndarray) -> np.ndarray:
    """0 below ``e0``, 1 above ``e1``, ``3s^2 - 2s^3`` in between (C1), with
    ``s = (t - e0) / (e1 - e0)``: the fade of the M-I ramps and the textures' edges."""
    s = np.clip((np.asarray(t) - e0) / (e1 - e0), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)
