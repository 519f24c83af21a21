"""Joining a texture's bodies to a part's mesh, and welding the result as a slicer
would read it. numpy and manifold3d only; lengths in mm, volumes in mm^3.

* :func:`join_bodies`: ``(base - cutter) + slab`` with manifold3d, checked to make
  no more bodies than the base has (a slab may join pieces of a base, never split one).
* :func:`welded`: the union's mesh with vertices within :data:`WELD` mm merged, as an
  STL reader that merges by position does, or None where that would pinch an edge.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import GeometryError
from .boolean import WELD, drop_pillows, from_manifold, to_manifold, welded
from .mesh import Mesh

__all__ = ["WELD", "welded", "drop_pillows", "join_bodies", "SLIVER"]

#: mm^3: bodies a boolean leaves below this volume are flat slivers, dropped.
SLIVER = 1e-6


def join_bodies(base_mesh: Mesh, slab: "Mesh | None", cutter: "Mesh | None") -> tuple[Mesh, Any]:
    """``(base - cutter) + slab`` with manifold3d (either may be None), bodies below
    :data:`SLIVER` mm^3 dropped, and the result welded (:func:`welded`; manifold3d's
    own mesh where welding would pinch an edge).

    Returns:
        ``(fused Mesh, fused manifold3d Manifold)`` (the Manifold, unwelded, for
        differences against the base later).

    Raises:
        GeometryError: manifold3d failed, the result is empty, or it has more bodies
            than the base (a texture came off the surface or cut through the base).
    """
    import manifold3d as m3d

    base = to_manifold(base_mesh)
    man = base - to_manifold(cutter) if cutter is not None else base
    if slab is not None:
        man = man + to_manifold(slab)
    parts = man.decompose()
    real = [p for p in parts if p.volume() > SLIVER]
    if len(real) < len(parts):
        man = m3d.Manifold.compose(real)
    want, got = len(base.decompose()), len(real)
    if man.status() != m3d.Error.NoError or man.is_empty() or got > want:
        raise GeometryError(
            f"putting the texture on gave {got} bodies from the base's {want} (manifold3d: {man.status().name}): "
            "a texture came off the surface or cut through the base; use a smaller height, or a thicker base"
        )
    return welded(man) or from_manifold(man), man
