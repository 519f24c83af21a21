"""Assemblies and multi-solid parts: which solid owns the selected faces, and side
names restricted to one solid (``solid:K/top``).

A STEP file of several solids (a case with the phone and its buttons) is textured one
solid at a time: the solid that owns the selected faces is textured, every other solid
is kept as it was, as a separate body. Solids are numbered in the order of
``shape.solids()`` (build123d), from 0, as ``texcad faces`` lists them.
"""

from __future__ import annotations

import re
from typing import Any, Sequence

from ..errors import ParameterError

__all__ = ["solid_selector", "owner_solid", "split_assembly", "all_bodies", "body_names"]

_SOLID = re.compile(r"solid:(\d+)/(.+)")


def solid_selector(which: str) -> tuple[int | None, str]:
    """``"solid:2/top"`` -> ``(2, "top")``; a selector without a solid -> ``(None, which)``."""
    m = _SOLID.fullmatch(which.strip())
    if m:
        return int(m.group(1)), m.group(2)
    if which.strip().startswith("solid:"):
        raise ParameterError(f"--face {which!r}: write solid:K/SELECTOR, e.g. solid:1/top or solid:0/cylinder")
    return None, which


def owner_solid(shape: Any, faces: Sequence[Any]) -> int:
    """The index of the solid of ``shape`` (build123d) that owns every face of
    ``faces``.

    Raises:
        ParameterError: the faces belong to several solids (texture one at a time), or
            to none.
    """
    solids = shape.solids()
    owners = set()
    for f in faces:  # per selected face: the solid that holds it
        k = next((k for k, s in enumerate(solids) if any(g.is_same(f) for g in s.faces())), None)
        if k is None:
            raise ParameterError("a selected face belongs to no solid of the part; texcad textures faces of solids")
        owners.add(k)
    if len(owners) > 1:
        raise ParameterError(
            f"the selected faces belong to solids {', '.join(map(str, sorted(owners)))} of the assembly; texture one solid "
            "at a time (restrict a selector to one solid: --face solid:K/top; list them with texcad faces PART.step)"
        )
    return owners.pop()


def split_assembly(shape: Any, faces: Sequence[Any]) -> tuple[int, Any, list]:
    """``(k, solid, others)``: the solid ``k`` of ``shape`` that owns ``faces`` and the
    other solids (kept as they are), in ``shape.solids()`` order."""
    solids = list(shape.solids())
    k = owner_solid(shape, faces)
    return k, solids[k], [s for j, s in enumerate(solids) if j != k]


def body_names(index: int, count: int) -> list[str]:
    """Names of the bodies as written: the textured solid first, then the others in order."""
    return [f"solid {index} (textured)"] + [f"solid {k}" for k in range(count) if k != index]


def all_bodies(first: Any, others: Sequence[Any]):
    """One :class:`~texcad.solid.Mesh` of several closed bodies, ``first`` then ``others``."""
    import numpy as np

    from ..solid import Mesh

    meshes = [first] + list(others)
    offs = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return Mesh(np.concatenate([m.vertices for m in meshes]).astype(np.float32),
                np.concatenate([m.faces.astype(np.int64) + o for m, o in zip(meshes, offs)]).astype(np.uint32))
