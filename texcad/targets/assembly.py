"""A CAD target of several solids (an assembly): the solid that owns the selected
faces is textured alone, the others are kept as they were (the result and its
writing: :mod:`texcad.pipeline.assembly`). Solids are numbered in explorer order
from 0, as ``texcad faces`` lists them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..errors import ParameterError
from .cad import selected_faces

__all__ = ["AssemblySplit", "assembly_split"]


@dataclass(frozen=True)
class AssemblySplit:
    """A CAD target of several solids split at the solid that owns the selected faces.

    Attributes:
        index: that solid's index among the target's solids (explorer order, from 0).
        solid: that solid (OCP ``TopoDS_Solid``), textured alone.
        others: the other solids (``TopoDS_Solid``), in order, kept as they are.
        face_numbers: for each face of ``solid`` (explorer order) its number among
            the assembly's faces, as ``texcad faces`` lists them.
    """

    index: int
    solid: Any
    others: tuple
    face_numbers: tuple = ()

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

    from ..brep.occt import explore, solids_of, to_topods
    from ..errors import TexcadError

    try:
        topo = to_topods(target)
        faces = [to_topods(f) for f in selected_faces(where)]
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
    return AssemblySplit(k, solids[k], tuple(s for j, s in enumerate(solids) if j != k), _face_numbers(topo, solids[k]))


def _face_numbers(topo: Any, solid: Any) -> tuple:
    """For each face of ``solid`` its number among the faces of ``topo`` (OCCT's
    indexed map: the order of ``part.faces()`` and ``texcad faces``)."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedMapOfShape

    from ..brep.occt import explore

    index = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(topo, TopAbs_FACE, index)
    return tuple(index.FindIndex(f) - 1 for f in explore(solid, TopAbs_FACE))
