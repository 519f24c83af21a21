"""Faces by name: the selectors of ``texcad texture --face``, for every caller.

One vocabulary picks faces of a CAD part wherever a face can be named by text: the
command line (``--face``, ``--zone``), a batch job's ``where`` and
``texcad.texture(part, "top", ...)`` in Python. A selector is

* a direction word (:data:`DIRECTIONS`): the largest planar face whose outward
  normal points that way (within 2.6 degrees);
* a face index, in the order of ``part.faces()`` (``texcad faces PART.step`` lists them);
* ``TYPE``: the largest face of that kind (``cylinder``, ``cone``, ``sphere``,
  ``torus``, ``bspline``, ``revolution``, ``extrusion``: the largest cylinder,
  extrusion or B-spline face); ``TYPE:i``, the i-th of that kind; ``TYPE:all``;
* ``normal:x,y,z``: every face whose normal at its centre is within 10 degrees of
  that direction;
* any of these after ``solid:K/``: on solid K of an assembly alone;
* several of these joined by ``+``: their faces, each once, in order.
"""

from __future__ import annotations

from typing import Any

from ..errors import ParameterError
from .assembly import solid_selector

__all__ = ["DIRECTIONS", "faces_named", "named", "check_selector"]

#: Direction words: the planar face whose outward normal points that way (the largest
#: if several).
DIRECTIONS = {"top": (0, 0, 1), "bottom": (0, 0, -1), "front": (0, -1, 0), "back": (0, 1, 0), "left": (-1, 0, 0), "right": (1, 0, 0)}

_ALIASES = {"extrusion": "EXTRUSION", "bspline": "BSPLINE", "b-spline": "BSPLINE", "bezier": "BEZIER"}


def faces_named(shape: Any, which: str) -> list:
    """The faces of the build123d ``shape`` that the selector ``which`` names (the
    module's vocabulary, ``+`` joins and ``solid:K/`` included), each once.

    Raises:
        ParameterError: a selector that names no face, naming the selector and what
            the part has.
    """
    faces: list = []
    for one in (w.strip() for w in which.split("+")):  # per joined selector
        k, sel = solid_selector(one)
        solids = shape.solids()
        if k is not None and k >= len(solids):
            raise ParameterError(f"face selector {one!r}: the part has {len(solids)} solid(s), 0..{len(solids) - 1}")
        scope = shape if k is None else solids[k]
        faces += [f for f in named(scope, sel) if not any(f.is_same(g) for g in faces)]
    return faces


def named(shape: Any, which: str) -> list:
    """The faces of ``shape`` one selector (no ``+``, no ``solid:``) names."""
    faces = shape.faces()
    if which.isdigit():
        if int(which) >= len(faces):
            raise ParameterError(f"face selector {which}: the part has only {len(faces)} faces (0..{len(faces) - 1})")
        return [faces[int(which)]]
    head, _, tail = which.partition(":")
    if head == "normal":
        return _by_normal(faces, which, tail)
    if _kind(head) is not None:
        return _by_kind(faces, which, head, tail)
    if which not in DIRECTIONS:
        raise ParameterError(
            f"face selector {which!r}: use one of {', '.join(DIRECTIONS)}, a face type (cone, sphere, bspline...), "
            "TYPE:i, TYPE:all, normal:x,y,z or a face index"
        )
    return [_by_direction(faces, which)]


def check_selector(which: str) -> None:
    """Refuse a selector whose form is not in the vocabulary, before any part is read
    (a batch's jobs are checked so before one runs).

    Raises:
        ParameterError: naming the selector and the forms there are.
    """
    for one in which.split("+"):  # per joined selector
        _, sel = solid_selector(one)
        head, _, tail = sel.strip().partition(":")
        if sel.strip().isdigit() or sel.strip() in DIRECTIONS or head == "normal":
            continue
        if _kind(head) is not None and (not tail or tail == "all" or tail.isdigit()):
            continue
        raise ParameterError(
            f"face selector {one.strip()!r}: use one of {', '.join(DIRECTIONS)}, a face type (cylinder, cone, "
            "bspline...), TYPE:i, TYPE:all, normal:x,y,z or a face index (solid:K/SELECTOR on one solid, + to join)"
        )


def _kind(word: str):
    """The build123d ``GeomType`` a face-type word names, or None."""
    from build123d import GeomType

    name = _ALIASES.get(word, word.upper())
    return GeomType[name] if name in GeomType.__members__ else None


def _by_normal(faces: Any, which: str, tail: str) -> list:
    """Every face whose normal at its centre is within 10 degrees of ``tail`` (x,y,z)."""
    from build123d import Vector

    from ..util import parse_vector

    d = Vector(*parse_vector(tail)).normalized()
    hit = [f for f in faces if f.normal_at(f.center()).dot(d) > 0.985]
    if not hit:
        raise ParameterError(f"face selector {which}: no face looks that way (within 10 degrees)")
    return hit


def _by_kind(faces: Any, which: str, head: str, tail: str) -> list:
    """``TYPE`` (the largest), ``TYPE:i`` or ``TYPE:all``."""
    from build123d import GeomType

    if head == "extrusion" and not tail:
        cands = [f for f in faces if f.geom_type in (GeomType.CYLINDER, GeomType.EXTRUSION, GeomType.BSPLINE)]
    else:
        cands = [f for f in faces if f.geom_type == _kind(head)]
    if not cands:
        raise ParameterError(f"face selector {which}: the part has no {head} face; use top, bottom, ... or a face index")
    if not tail:
        return [max(cands, key=lambda f: f.area)]
    if tail == "all":
        return cands
    if not tail.isdigit() or int(tail) >= len(cands):
        raise ParameterError(f"face selector {which}: the part has {len(cands)} {head} face(s): use {head}:0..{len(cands) - 1} or {head}:all")
    return [cands[int(tail)]]


def _by_direction(faces: Any, which: str) -> Any:
    """The largest planar face looking along the direction word ``which``."""
    from build123d import GeomType, Vector

    d = Vector(*DIRECTIONS[which])
    planar = [f for f in faces.filter_by(GeomType.PLANE) if f.normal_at().dot(d) > 0.999]
    if not planar:
        raise ParameterError(f"face selector {which}: no planar face looks {which}; use a face index (0..{len(faces) - 1})")
    return max(planar, key=lambda f: f.area)
