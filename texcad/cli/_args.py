"""Argument types shared by the commands (values in mm and degrees)."""

from __future__ import annotations

import argparse

__all__ = ["positive_float", "shape"]


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
