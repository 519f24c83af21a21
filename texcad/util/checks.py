"""Argument checks shared by the stages (one wording for every module)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = ["positive"]


def positive(name: str, value: Any, unit: str = "mm") -> float:
    """``value`` as a finite float > 0, else a :class:`ParameterError` naming
    ``name``, the offending value and the ``unit`` expected (e.g. ``"mm"``)."""
    of = f" of {unit}" if unit else ""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number{of}, got {value!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise ParameterError(f"{name} must be a positive number{of}, got {value!r}")
    return v
