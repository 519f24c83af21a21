"""Assemblies and multi-solid parts: which solid owns the selected faces, and side
names restricted to one solid (``solid:K/top``).

A STEP file of several solids (a case with the phone and its buttons) is textured one
solid at a time: the solid that owns the selected faces is textured, every other solid
is kept as it was, as a separate body. Solids are numbered in the order of
``shape.solids()`` (build123d), from 0, as ``texcad faces`` lists them.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from typing import Any, Sequence

from ..errors import ParameterError

__all__ = ["solid_selector", "owner_solid", "split_assembly", "AssemblySplit", "assembly_split", "assembly_result", "write_assembly",
           "all_bodies", "body_names"]

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


# -- the API: texcad.texture(assembly, face_of_solid_k, ...) ------------------------------------

@dataclass(frozen=True)
class AssemblySplit:
    """A CAD target of several solids split at the solid that owns the selected faces.

    Attributes:
        index: that solid's index among the target's solids (explorer order, from 0).
        solid: that solid (OCP ``TopoDS_Solid``), textured alone.
        others: the other solids (``TopoDS_Solid``), in order, kept as they are.
    """

    index: int
    solid: Any
    others: tuple

    @property
    def count(self) -> int:
        """Solids of the assembly."""
        return len(self.others) + 1


def assembly_split(target: Any, where: Any) -> "AssemblySplit | None":
    """The split of a CAD ``target`` of two or more solids at the solid that owns the
    faces ``where``; None for anything else (one solid, a mesh, a surface, a chained
    result, no faces). OCCT is not loaded for a target that cannot be a CAD part.

    Raises:
        ParameterError: the faces belong to several solids (texture one at a time).
    """
    import sys

    if where is None or "OCP" not in sys.modules or hasattr(target, "stages"):  # no OCCT loaded: not a CAD part
        return None
    from OCP.TopAbs import TopAbs_FACE

    from ..errors import TexcadError
    from .occt import explore, solids_of, to_topods

    try:
        topo = to_topods(target)
        from ..targets.cad import face_list

        faces = [to_topods(f) for f in face_list(where)]
    except (TexcadError, TypeError, AttributeError):
        return None
    solids = solids_of(topo)
    if len(solids) < 2 or any(f.ShapeType() != TopAbs_FACE for f in faces):
        return None
    owners = set()
    for f in faces:  # per selected face: the solid that holds it
        k = next((k for k, s in enumerate(solids) if any(g.IsSame(f) for g in explore(s, TopAbs_FACE))), None)
        if k is None:
            return None  # not a face of this part: the adapters say so
        owners.add(k)
    if len(owners) > 1:
        raise ParameterError(
            f"the selected faces belong to solids {', '.join(map(str, sorted(owners)))} of the assembly; texture one solid "
            "at a time (its solids are part.solids(), numbered from 0; texcad faces PART.step lists them)"
        )
    k = owners.pop()
    return AssemblySplit(k, solids[k], tuple(s for j, s in enumerate(solids) if j != k))


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


def write_assembly(textured: Any, index: int, others: Sequence[Any], other_meshes: Sequence[Any], path: Any, *,
                   separate_texture: bool = False, name: "str | None" = None):
    """Write a textured solid with the other solids of its assembly, atomically: STL
    one file of several closed bodies, 3MF one named part per solid (the textured
    one as base and texture parts with ``separate_texture``), STEP a compound, PNG a
    picture of all. Returns the path."""
    from pathlib import Path

    from ..io import export, write_3mf, write_step
    from ..render import render_part

    p = Path(path)
    suffix = p.suffix.lower()
    names = body_names(index, len(others) + 1)
    if suffix == ".png":
        return render_part(all_bodies(textured.mesh, other_meshes), p)
    if suffix == ".3mf":
        first = [("base", textured.base_mesh), ("texture", textured.texture_mesh)] if separate_texture else \
            [(names[0], textured.mesh)]
        write_3mf(first + list(zip(names[1:], other_meshes)), p, name=name or p.stem)
        return p
    if suffix in (".step", ".stp"):
        from . import compound, to_topods

        write_step(compound([to_topods(textured.shape)] + [to_topods(s) for s in others]), p, name=name or p.stem)
        return p
    return export(all_bodies(textured.mesh, other_meshes), p, name=name)


def assembly_result(textured: Any, split: AssemblySplit, *, tolerance: float = 0.01):
    """The :class:`texcad.Textured` of solid ``split.index`` (its mesh, volume, gate:
    that solid's) made the result of the whole assembly: ``info["solid"]`` is the
    solid textured, ``info["solids"]`` their number; ``others`` / ``other_meshes``
    the other solids as they were; ``bodies`` every body's mesh; ``export`` writes
    all of them as separate bodies (:func:`write_assembly`)."""
    from ..pipeline.result import Textured

    out = object.__new__(_textured_class())
    out.__dict__.update(textured.__dict__)
    out.info = dict(textured.info, solid=split.index, solids=split.count)
    out.solid_index, out.others, out.tolerance = split.index, split.others, tolerance
    out._other_meshes = None
    assert isinstance(out, Textured)
    return out


@functools.lru_cache(maxsize=None)
def _textured_class():
    """The result class, made on first use (the pipeline imports this module: no import cycle)."""
    from ..pipeline.result import Textured

    class AssemblyTextured(Textured):
        """A :class:`texcad.Textured` of one solid of an assembly, with the other
        solids kept as they were (see :func:`assembly_result`). Lengths in mm."""

        @property
        def other_meshes(self) -> list:
            """The other solids' meshes (their tessellation at ``tolerance`` mm), in order."""
            if self._other_meshes is None:
                from .tessellation import shape_to_mesh

                self._other_meshes = [shape_to_mesh(s, tolerance=self.tolerance) for s in self.others]  # per kept solid
            return self._other_meshes

        @property
        def bodies(self) -> list:
            """Every body's mesh: the textured solid first, then the others in order."""
            return [self.mesh] + self.other_meshes

        @property
        def assembly_mesh(self):
            """All bodies as one mesh of several closed bodies (what the STL holds)."""
            return all_bodies(self.mesh, self.other_meshes)

        def export(self, path: Any, *, separate_texture: bool = False, name: "str | None" = None):
            """Write the textured solid with the others as separate bodies (:func:`write_assembly`)."""
            return write_assembly(self, self.solid_index, self.others, self.other_meshes, path,
                                  separate_texture=separate_texture, name=name)

        def render(self, path: Any, **kwargs: Any):
            """PNG picture of every body."""
            from ..render import render_part

            return render_part(self.assembly_mesh, path, **kwargs)

        def __repr__(self) -> str:
            return f"{Textured.__repr__(self)[:-1]}, solid {self.solid_index} of {len(self.others) + 1})"

    return AssemblyTextured
