"""Small parsers shared by the command line and the checks."""

from __future__ import annotations

import re

import numpy as np

from ..errors import ParameterError

__all__ = ["axis_word", "parse_vector", "smoothstep", "rotation_to_z"]


_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def axis_word(text: str) -> "np.ndarray | None":
    """The unit ``(3,)`` float64 axis an axis word names (``"+z"``, ``"-x"``, ``"y"``,
    any case, one sign at most), or None when ``text`` is not one."""
    word = str(text).strip().lower()
    key = word.lstrip("+-")
    if key not in _AXES or len(word) - len(key) > 1:
        return None
    return (-1.0 if word.startswith("-") else 1.0) * np.array(_AXES[key]) + 0.0  # + 0.0: no -0


def parse_vector(text: str) -> np.ndarray:
    """``"X,Y,Z"`` (commas or spaces), or an axis (``"+z"``, ``"-x"``, ``"y"``) to a
    ``(3,)`` float64 vector.

    Raises:
        ParameterError: not three finite numbers, or all zero.
    """
    axis = axis_word(text)
    if axis is not None:
        return axis
    parts = [p for p in re.split(r"[,\s]+", str(text).strip()) if p]
    try:
        v = np.array([float(p) for p in parts], dtype=np.float64)
    except ValueError:
        raise ParameterError(f"expected three numbers X,Y,Z (e.g. 0,-0.5,0.87) or an axis (+z, -y), got {text!r}") from None
    if v.shape != (3,) or not np.isfinite(v).all() or not np.any(v):
        raise ParameterError(f"expected three numbers X,Y,Z, not all zero (e.g. 0,0,1), got {text!r}")
    return v


def smoothstep(e0: float, e1: float, t: np.ndarray) -> np.ndarray:
    """0 below ``e0``, 1 above ``e1``, ``3s^2 - 2s^3`` in between (C1), with
    ``s = (t - e0) / (e1 - e0)``: the fade of the M-I ramps and the textures' edges."""
    s = np.clip((np.asarray(t) - e0) / (e1 - e0), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def rotation_to_z(direction) -> np.ndarray:
    """``(3, 3)`` float64 rotation taking the direction ``(3,)`` (any length > 0) to
    +z: the smallest one (Rodrigues, about ``d x z``: ``I + [v]x + [v]x^2 / (1 + c)``
    with ``v = d x z``, ``c = d . z``; a half turn about x for ``-z``).

    Raises:
        ParameterError: not a finite, non-zero 3-vector.
    """
    d = np.asarray(direction, dtype=np.float64).reshape(-1)
    n = float(np.linalg.norm(d)) if d.shape == (3,) else 0.0
    if not (np.isfinite(n) and n > 0):
        raise ParameterError(f"a direction is a finite, non-zero 3-vector (x, y, z), got {direction!r}")
    d = d / n
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(d, z)
    c = float(d @ z)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)
