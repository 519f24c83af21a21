"""A mesh textured from a 3MF of several build items written back as a 3MF of as
many objects, each placed by its item's transform (as PrusaSlicer and lib3mf lay out
such files), so that a slicer can still arrange them. Lengths in mm, volumes mm^3.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

__all__ = ["write_build_items", "item_bodies"]


def item_bodies(textured: Any, items: list) -> "list[tuple[str, Any, Any]] | None":
    """The textured mesh split back into the build ``items`` (:func:`texcad.io.read.build_items`):
    ``(name, mesh, transform)`` per item, its mesh the bodies that grew from its own
    (:func:`texcad.solid.overlap.body_owners`), each gated alone (closed, outward, no
    bodies overlapping: :func:`texcad.report.gate.gate_shells`) and holding as many
    bodies as the item had. None, with a TexcadWarning, where a body grew from two
    items (they overlapped and were united): then they are one object.

    Raises:
        GeometryError: an item got no body or another number of bodies than it had,
            or a body grew from no item.
    """
    from ..errors import GeometryError, TexcadWarning
    from ..report.gate import gate_shells
    from ..solid import Mesh
    from ..solid.overlap import body_owners, split_bodies

    mesh = textured.mesh
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    split, owner = body_owners(v, f, [list(m) for _, _, m in items])
    if np.any(owner == -2):
        warnings.warn(f"{int(np.sum(owner == -2))} textured bod(ies) grew from more than one of the 3MF's {len(items)} "
                      "build items (they overlapped and were united): written as one object", TexcadWarning, stacklevel=3)
        return None
    face_body = split.body[split.shell]
    out = []
    for k, (name, tf, meshes) in enumerate(items):  # per build item
        bodies = np.flatnonzero(owner == k)
        had = sum(len(split_bodies(np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)).solids) for m in meshes)
        if len(bodies) != had:
            raise GeometryError(f"build item {k} ({name!r}) of the 3MF had {had} bod(ies) but {len(bodies)} textured "
                                "bod(ies) grew from it; write STL, and please report this")
        keep = np.isin(face_body, bodies)
        used, local = np.unique(f[keep], return_inverse=True)
        part = Mesh(v[used].astype(np.float32), local.reshape(-1, 3).astype(np.uint32))
        gate_shells(part, what=f"object {name!r}")
        out.append((name, part, tf))
    if np.any(owner == -1):
        raise GeometryError(f"{int(np.sum(owner == -1))} textured bod(ies) grew from none of the 3MF's build items; "
                            "write STL, and please report this")
    return out


def write_build_items(textured: Any, path: Any) -> bool:
    """Write ``textured`` (a mesh result whose part was a 3MF, ``info["source_3mf"]``)
    as one object per build item of that 3MF (:func:`item_bodies`,
    :func:`texcad.io.write_3mf_items`), each with the slicer settings
    :func:`texcad.io.export` writes for one object, turned for the build direction.
    False (nothing written) where the 3MF has one item, its bodies cannot be told
    apart, or the mesh is kept in tiles (warned)."""
    from ..errors import TexcadWarning
    from ..io import cura_settings, slicer_settings
    from ..io.export import write_3mf_items
    from ..io.read import build_items

    source = textured.info.get("source_3mf")
    items = build_items(source) if source else []
    if len(items) < 2:
        return False
    if callable(getattr(textured.stages.fused.mesh, "write", None)):  # kept in tiles: streamed whole, never gathered
        warnings.warn(f"the 3MF's {len(items)} build items are written as one object: the textured mesh is kept in "
                      "tiles (too large to split by item in memory)", TexcadWarning, stacklevel=3)
        return False
    objects = item_bodies(textured, items)
    if objects is None:
        return False
    d = textured.stages.options.directions
    up = None if d is None else d[0]
    write_3mf_items(objects, path, build_dir=up, settings=[slicer_settings(m, up) for _, m, _ in objects],
                    cura_settings=[cura_settings(m, up) for _, m, _ in objects])  # per object, as export writes one
    return True
