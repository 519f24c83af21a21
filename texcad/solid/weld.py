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
from .boolean import from_manifold, to_manifold
from .mesh import Mesh, edge_report

__all__ = ["WELD", "welded", "drop_pillows", "join_bodies", "SLIVER"]

#: mm: vertices closer than this are one vertex (what a slicer reading the STL does).
WELD = 1e-5
#: mm^3: bodies a boolean leaves below this volume are flat slivers, dropped.
SLIVER = 1e-6


def drop_pillows(f: np.ndarray) -> np.ndarray:
    """``f`` ``(M, 3)`` without the pairs of triangles on the same three vertices
    (zero volume: two booleans can leave such flat pillows)."""
    key = np.sort(f, axis=1)
    _, inv, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    return f[count[inv.ravel()] == 1]


def welded(man: Any) -> "Mesh | None":
    """A manifold3d ``Manifold``'s mesh with vertices within :data:`WELD` mm merged
    (positions quantized to ``round(v / WELD)``), the zero-area needles along a cut
    edge (two corners at one position) and the flat pillows dropped; None unless
    every edge then lies on exactly two triangles, opposite ways. When no two
    vertices are that close, the mesh is manifold3d's own, taken as it is."""
    out = man.to_mesh()
    v = np.asarray(out.vert_properties)[:, :3].astype(np.float32)
    f = np.asarray(out.tri_verts).astype(np.int64)
    q = np.round(v.astype(np.float64) / WELD).astype(np.int64)
    order = np.lexsort((q[:, 2], q[:, 1], q[:, 0]))
    sq = q[order]
    new = np.ones(len(v), bool)
    new[1:] = np.any(sq[1:] != sq[:-1], axis=1)
    if new.all():
        mesh = Mesh(np.ascontiguousarray(v), f.astype(np.uint32))
        mesh.__dict__["is_watertight"] = True
        return mesh
    inv = np.empty(len(v), np.int64)
    inv[order] = np.cumsum(new) - 1
    uniq = v[order][new]
    f = inv[f]
    f = drop_pillows(f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])])
    if not len(f) or not edge_report(f)["watertight"]:  # every edge on two triangles, opposite ways
        return None
    used = np.unique(f)
    remap = np.full(len(uniq), -1, np.int64)
    remap[used] = np.arange(len(used))
    mesh = Mesh(np.ascontiguousarray(uniq[used]), remap[f].astype(np.uint32))
    mesh.__dict__["is_watertight"] = True
    return mesh


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
