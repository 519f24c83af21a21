"""A mesh textured from a 3MF of several build items written back as a 3MF of as
many objects, each placed by its item's transform (as PrusaSlicer and lib3mf lay out
such files), so that a slicer can still arrange them; with the texture separate, each
object made of its item's base and texture parts. Lengths in mm, volumes mm^3.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

__all__ = ["write_build_items", "item_bodies", "item_parts"]


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
    from ..solid.overlap import body_owners

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
        had = _had(meshes)
        if len(bodies) != had:
            raise GeometryError(f"build item {k} ({name!r}) of the 3MF had {had} bod(ies) but {len(bodies)} textured "
                                "bod(ies) grew from it; write STL, and please report this")
        part = _piece(v, f, np.isin(face_body, bodies))
        gate_shells(part, what=f"object {name!r}")
        out.append((name, part, tf))
    if np.any(owner == -1):
        raise GeometryError(f"{int(np.sum(owner == -1))} textured bod(ies) grew from none of the 3MF's build items; "
                            "write STL, and please report this")
    return out


def _had(meshes: list) -> int:
    """How many bodies a build item's ``meshes`` hold (:func:`texcad.solid.overlap.split_bodies`)."""
    from ..solid.overlap import split_bodies

    return sum(len(split_bodies(np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)).solids) for m in meshes)


def _piece(v: np.ndarray, f: np.ndarray, keep: np.ndarray) -> Any:
    """The faces ``f[keep]`` of the mesh ``(v, f)`` as a mesh of their own vertices
    (float32 mm, as texcad's meshes)."""
    from ..solid import Mesh

    used, local = np.unique(f[keep], return_inverse=True)
    return Mesh(v[used].astype(np.float32), local.reshape(-1, 3).astype(np.uint32))


def item_parts(objects: list, parts: list, items: list) -> list:
    """The build ``items``' objects (:func:`item_bodies`) each made of its own pieces of
    the closed ``parts`` (``(part name, mesh)``, mm, which together make the
    textured mesh: the base first, then the texture layers): ``(name, [(part name,
    piece), ...], transform)`` per item. Each body of a part goes to the item whose
    textured bodies hold it (:func:`_holders`); each piece is gated alone (closed,
    outward, no bodies overlapping: :func:`texcad.report.gate.gate_shells`); an
    item's base holds as many bodies as the item had; a part with nothing on an item
    (a texture left off it) is left out of its object.

    Raises:
        GeometryError: a body of a part lies in no item's textured bodies or in two,
            or an item's base has another number of bodies than the item had.
    """
    from ..errors import GeometryError
    from ..report.gate import gate_shells

    pieces: list = [[] for _ in objects]
    for j, (pname, mesh) in enumerate(parts):  # per part: the base, each texture layer
        v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
        split, owner = _holders(v, f, [m for _, m, _ in objects])
        if np.any(owner < 0):
            raise GeometryError(f"{int(np.sum(owner < 0))} bod(ies) of the {pname!r} part lie in none or in several of "
                                f"the {len(objects)} build items' textured bodies; write without separate_texture, and "
                                "please report this")
        face_body = split.body[split.shell]
        for k, (name, _, _) in enumerate(objects):  # per build item
            keep = np.isin(face_body, np.flatnonzero(owner == k))
            if not keep.any():
                continue
            report = gate_shells(piece := _piece(v, f, keep), what=f"{pname!r} part of object {name!r}")
            if j == 0 and report.bodies != (had := _had(items[k][2])):
                raise GeometryError(f"the {pname!r} part of build item {k} ({name!r}) has {report.bodies} bod(ies) where "
                                    f"the item had {had}; write without separate_texture, and please report this")
            pieces[k].append((pname, piece))
    for k, (name, _, _) in enumerate(objects):  # per build item
        if not pieces[k] or pieces[k][0][0] != parts[0][0]:
            raise GeometryError(f"build item {k} ({name!r}) got no {parts[0][0]!r} part; write without separate_texture, "
                                "and please report this")
    return [(name, ps, tf) for (name, _, tf), ps in zip(objects, pieces)]


#: mm: how far a part's body may reach out of the box of the textured bodies that hold it
#: (:func:`_holders`): they share their outer surface, written in float32.
BOX_SLACK = 1e-3


def _holders(v: np.ndarray, f: np.ndarray, meshes: list) -> tuple:
    """``(split, owner)``: the bodies of the closed mesh ``(v, f)``
    (:func:`texcad.solid.overlap.split_bodies`), each lying inside one of ``meshes``,
    and which: the only one whose box holds the body's box (within
    :data:`BOX_SLACK` mm), or, where several do, the one it shares the most volume with
    (:func:`texcad.solid.overlap.body_owners`: manifold3d intersections, slow where
    the surfaces coincide, as a texture's outer face and the textured mesh's do);
    -1 where it lies in none, -2 in two."""
    from ..solid.overlap import body_owners, split_bodies

    split = split_bodies(v, f)
    box = np.array([s.bounding_box() for s in split.solids], dtype=np.float64).reshape(-1, 6)
    held = np.stack([np.all(box[:, :3] >= np.asarray(m.vertices, np.float64).min(axis=0) - BOX_SLACK, axis=1)
                     & np.all(box[:, 3:] <= np.asarray(m.vertices, np.float64).max(axis=0) + BOX_SLACK, axis=1)
                     for m in meshes], axis=1)
    count = held.sum(axis=1)
    owner = np.where(count == 1, held.argmax(axis=1), -1).astype(np.int64)
    if np.any(count > 1):  # a box within several boxes: by shared volume
        owner[count > 1] = body_owners(v, f, [[m] for m in meshes], split=split)[1][count > 1]
    return split, owner


def write_build_items(textured: Any, path: Any, parts: "list | None" = None) -> bool:
    """Write ``textured`` (a mesh result whose part was a 3MF, ``info["source_3mf"]``)
    as one object per build item of that 3MF (:func:`item_bodies`,
    :func:`texcad.io.write_3mf_items`), each with the slicer settings
    :func:`texcad.io.export` writes for one object (of the item's textured mesh, as
    printed), turned for the build direction. ``parts``: ``(part name, mesh)``
    closed meshes that together make the textured mesh (the base, then each texture
    layer): each object is made of its item's pieces of them (:func:`item_parts`),
    so that a slicer can give the texture another filament; None: of its textured
    mesh. False (nothing written) where the 3MF has one item, its bodies cannot be
    told apart, or the mesh is kept in tiles (warned)."""
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
    settings = [slicer_settings(m, up) for _, m, _ in objects]  # per object, as export writes one
    cura = [cura_settings(m, up) for _, m, _ in objects]
    write_3mf_items(objects if parts is None else item_parts(objects, parts, items), path, build_dir=up, settings=settings,
                    cura_settings=cura)
    return True
