"""Small parsers shared by the command line and the checks."""

from __future__ import annotations

import re

import numpy as np

from ..errors import ParameterError

__all__ = ["parse_vector"]


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
