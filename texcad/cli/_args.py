"""Argument types shared by the commands (values in mm and degrees)."""

from __future__ import annotations

from ..options import DEFAULTS

import argparse

__all__ = ["positive_float", "shape", "vector", "add_orientation", "limits_line", "nonnegative_float", "add_tolerance",
           "zone_spec"]


def positive_float(text: str) -> float:
    """A strictly positive number (mm, degrees, ...)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not v > 0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return v


def nonnegative_float(text: str) -> float:
    """A number >= 0 (mm)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not v >= 0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return v


def add_tolerance(parser: argparse.ArgumentParser) -> None:
    """``--tolerance MM``: largest height error of the lean texture mesh (texcad.solid.lean)."""
    from ..solid import DEFAULT_TOLERANCE

    parser.add_argument(
        "--tolerance",
        type=nonnegative_float,
        default=DEFAULTS.tolerance,
        metavar="MM",
        help=f"largest error of the texture mesh, mm: at every pixel centre (CAD faces, surfaces) or every point of "
        f"the pitch grid (meshes) (default {DEFAULT_TOLERANCE:g}; 0 = one vertex per pixel / the pitch grid)",
    )


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
    """``X,Y,Z``: a direction, any length, not zero (:func:`texcad.util.parse_vector`)."""
    from ..util import parse_vector
    from ..errors import ParameterError

    try:
        return tuple(float(c) for c in parse_vector(text))
    except ParameterError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_orientation(parser: argparse.ArgumentParser) -> None:
    """``--build-dir X,Y,Z`` and ``--critical-angle DEG``: make the texture print
    without support in that orientation (texcad.printability)."""
    parser.add_argument(
        "--build-dir",
        type=vector,
        default=None,
        metavar="X,Y,Z",
        help="print the texture support-free along this build direction (up in the printer, any length, or +z, "
        "-y...; "
        "see texcad.orientation); default: texture as is",
    )
    parser.add_argument(
        "--critical-angle",
        type=positive_float,
        default=DEFAULTS.critical_angle,
        metavar="DEG",
        help="with --build-dir: smallest printable angle between a downward face and the build plate (default 45)",
    )


def limits_line(limits) -> str | None:
    """One summary line for a LimitReport (None when no limiter ran)."""
    if limits is None:
        return None
    return (
        f"overhangs    limited to {limits.critical_angle_deg:g} deg for {len(limits.directions)} direction(s): "
        f"{limits.removed_volume_mm3:.1f} mm3 removed, {limits.remaining_overhang_mm2:.2f} mm2 still overhanging"
    )


def zone_spec(text: str) -> tuple:
    """``SEL[+SEL...]@TEXTURE[@OPTIONS]``: one zone of a CAD part, ``(selectors,
    texture or None, {options})``. ``OPTIONS`` is a mode word (``engraved``) or
    ``key=value`` pairs split by commas (``height=0.8,mode=engraved``; lengths in mm,
    angles in degrees); an empty TEXTURE is the command's ``--texture``. The option
    names are checked by :func:`texcad.texture` (ParameterError naming the zone)."""
    import re

    parts = text.split("@")
    if len(parts) not in (2, 3) or not parts[0].strip():
        raise argparse.ArgumentTypeError(
            f"expected FACES@TEXTURE[@OPTIONS] such as top+right@builtin:stones@height=0.8,mode=engraved, got {text!r}"
        )
    sels = [p for p in re.split(r"(?<![:,])\+", parts[0].strip()) if p]  # top+right; normal:+x keeps its sign
    opts: dict = {}
    for item in (parts[2].split(",") if len(parts) == 3 and parts[2].strip() else []):  # per key=value
        key, eq, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not eq:
            key, value = "mode", key  # a mode word alone
        try:
            opts[key] = float(value)
        except ValueError:
            opts[key] = value
    return sels, (parts[1].strip() or None), opts


def step_part(path: str) -> None:
    """Refuse a part that is neither a mesh texcad reads nor a STEP file (a PLY, OFF,
    GLB...) with an InputError naming the formats texcad reads; a missing part is
    told so. A STEP file is known by its suffix (.step, .stp) or its first line."""
    from pathlib import Path

    from ..errors import InputError
    from ..io.read import unreadable

    p = Path(path)
    if not p.is_file():
        raise InputError(f"part {path!r} does not exist; check the path")
    if p.suffix.lower() in (".step", ".stp"):
        return
    with open(p, "rb") as fh:
        if not fh.read(4096).lstrip().startswith(b"ISO-10303-21"):
            raise unreadable(p)
