"""Argument types shared by the commands (values in mm and degrees)."""

from __future__ import annotations

import argparse

__all__ = ["positive_float", "shape", "vector"]


def positive_float(text: str) -> float:
    """A strictly positive number (mm, degrees, ...)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not v > 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return v


def shape(text: str) -> tuple[int, int]:
    """``ROWSxCOLS`` in pixels, e.g. ``800x800``."""
    try:
        r, c = (int(t) for t in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected ROWSxCOLS in pixels such as 800x800, got {text!r}") from None
    if r <= 0 or c <= 0:
        raise argparse.ArgumentTypeError(f"expected positive ROWSxCOLS, got {text!r}")
    return r, c


def vector(text: str) -> tuple[float, float, float]:
    """``X,Y,Z``: a direction, any length, not zero (:func:`texcad.check.parse_vector`)."""
    from ..check import parse_vector
    from ..errors import ParameterError

    try:
        return tuple(float(c) for c in parse_vector(text))
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
