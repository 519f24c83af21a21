"""Joining a texture's bodies to a part's mesh, and welding the result as a slicer
would read it. numpy and manifold3d only; lengths in mm, volumes in mm^3.

* :func:`join_bodies`: ``(base - cutter) + slab`` with manifold3d, checked to make
  no more bodies than the base has (a slab may join pieces of a base, never split one).
* :func:`grid_ids`: points that round to one point of a grid numbered as one (the
  numbers ``np.unique(..., axis=0, return_inverse=True)`` gives, several times faster).
* :func:`welded`: the union's mesh with vertices within :data:`WELD` mm merged, as an
  STL reader that merges by position does, or None where that would pinch an edge.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import GeometryError
from .boolean import WELD, drop_pillows, from_manifold, to_manifold, welded
from .mesh import Mesh

__all__ = ["WELD", "welded", "drop_pillows", "join_bodies", "SLIVER", "grid_ids"]

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


def grid_ids(points: np.ndarray, quantum: float) -> np.ndarray:
    """``(N,)`` int64: the number of the point of the grid of spacing ``quantum`` mm
    each of ``points`` ``(N, 3)`` (mm) rounds to, numbered in lexicographic order of the
    grid points: the inverse ``np.unique(np.round(points / quantum).astype(np.int64),
    axis=0, return_inverse=True)`` gives, to the integer. ``np.unique`` sorts rows as
    opaque bytes (2.4 M triangles' 7 M corners: 15 s); here one ``int64`` sort key where
    the three grid indices fit in 63 bits, else two (x and y in one, z; 3 s)."""
    q = np.round(np.asarray(points, dtype=np.float64) / float(quantum)).astype(np.int64)
    if len(q) == 0:
        return np.zeros(0, dtype=np.int64)
    q -= q.min(axis=0)
    span = q.max(axis=0) + 1
    bits = [int(b).bit_length() for b in span]
    if sum(bits) <= 63:
        key = (q[:, 0] << (bits[1] + bits[2])) | (q[:, 1] << bits[2]) | q[:, 2]
        order = np.argsort(key, kind="stable")
        k = key[order]
        new = np.r_[True, k[1:] != k[:-1]]
    elif (bits[0] + bits[1]) <= 63:
        xy = q[:, 0] * span[1] + q[:, 1]
        order = np.lexsort((q[:, 2], xy))
        a, b = xy[order], q[order, 2]
        new = np.r_[True, (a[1:] != a[:-1]) | (b[1:] != b[:-1])]
    else:  # beyond 2^63 grid steps in x and y together: numpy's own
        return np.unique(q, axis=0, return_inverse=True)[1].reshape(-1).astype(np.int64)
    ids = np.empty(len(q), dtype=np.int64)
    ids[order] = np.cumsum(new) - 1
    return ids
