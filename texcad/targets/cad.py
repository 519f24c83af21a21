"""What the CAD adapters (planar face, extruded face, any faces) share: the part's
OCCT shape, the selected faces, chaining onto an earlier result, and the common
fields of their :class:`~texcad.contracts.Placement` (the part's tessellation as the
base, the selected faces' triangles as the selected surface). Lengths in mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..brep import PartMesh, explore, part_tessellation, solids_of, to_topods
from ..contracts import Stages
from ..errors import GeometryError, ParameterError

__all__ = ["CadPart", "cad_part", "face_list", "is_cad_target"]


@dataclass(frozen=True)
class CadPart:
    """A CAD target resolved once.

    Attributes:
        topo: the part's ``TopoDS_Shape`` (the base part when chained).
        faces: the selected faces as they lie in ``topo`` (OCP ``TopoDS_Face``).
        face_ids: their indices among ``topo``'s faces (explorer order).
        previous: the :class:`~texcad.contracts.Stages` of the result this one is
            chained onto, or None.
        done: faces textured by the chain so far (indices).
    """

    topo: Any
    faces: tuple
    face_ids: tuple
    previous: Any = None
    done: tuple = ()


def is_cad_target(target: Any) -> bool:
    """A build123d / CadQuery / OCP shape, or an earlier CAD result (chaining)."""
    if isinstance(getattr(target, "stages", None), Stages):
        return True
    try:
        to_topods(target)
    except (ParameterError, TypeError, AttributeError):
        return False
    return True


def face_list(faces: Any) -> list:
    """A list of faces from one face, a build123d ``ShapeList``, a list or a
    CadQuery selection."""
    if callable(getattr(faces, "vals", None)) and hasattr(faces, "objects"):
        faces = faces.vals()
    items = list(faces) if isinstance(faces, (list, tuple)) or type(faces).__name__ == "ShapeList" else [faces]
    if not items:
        raise ParameterError("no face selected; pass a face or a list of faces of the part")
    return items


def _chain(target: Any) -> tuple[Any, Any, tuple]:
    """``(topo, previous stages, faces done)`` of a target that may be an earlier result."""
    stages = getattr(target, "stages", None)
    if not isinstance(stages, Stages):
        topo = to_topods(target)
        if not solids_of(topo):
            raise ParameterError(f"the {type(target).__name__} holds no solid to texture; pass a solid part")
        return topo, None, ()
    pl = stages.placement
    if pl.topo is None or not getattr(target, "is_unmoved", True):
        raise ParameterError(
            f"this textured {'mesh' if pl.topo is None else 'result, moved since,'} cannot be textured again as a CAD "
            "part; texture all faces in one call: texcad.texture(part, [face1, face2, ...], texture)"
        )
    done = tuple(pl.face_ids) + (tuple(pl.previous.placement.face_ids) if pl.previous is not None else ())
    return pl.topo, stages, done


def cad_part(target: Any, where: Any) -> CadPart:
    """Resolve a CAD target and its selected faces (in the part, with orientation).

    Raises:
        ParameterError: no solid, no face, a face not of this part, a face textured
            already in the chain.
    """
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    if where is None:
        raise ParameterError(
            "say which face to texture: texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], texture) "
            "(build123d) or texcad.texture(wp, wp.faces('>Z'), texture) (CadQuery)"
        )
    topo, previous, done = _chain(target)
    all_faces = list(explore(topo, TopAbs_FACE))
    faces, ids = [], []
    for face in face_list(where):  # per selected face
        f = to_topods(face)
        if f.ShapeType() != TopAbs_FACE:
            raise ParameterError(f"expected faces, got a {f.ShapeType().name.removeprefix('TopAbs_').lower()}")
        hit = next((k for k, c in enumerate(all_faces) if c.IsSame(f)), None)
        if hit is None:
            raise ParameterError(
                "a face is not a face of this part; select it from the part itself, e.g. "
                "part.faces().sort_by(Axis.Z)[-1] (build123d) or wp.faces('>Z') (CadQuery)"
            )
        if hit not in ids:
            ids.append(hit)
            faces.append(TopoDS.Face_s(all_faces[hit]))
    again = sorted(set(done) & set(ids))
    if again:
        raise ParameterError(f"face(s) {again} are textured already; texture each face once (all faces in one call)")
    return CadPart(topo, tuple(faces), tuple(ids), previous, done)


def selected_surface(pm: PartMesh, face_ids: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The selected faces' triangles in the part's tessellation: ``(vertices, faces)``."""
    keep = np.isin(pm.face_of_tri, np.asarray(face_ids, dtype=np.int64))
    if not keep.any():
        raise GeometryError(f"the selected face(s) {list(face_ids)} have no triangles in OCCT's tessellation (no area?)")
    return pm.mesh.vertices, pm.mesh.faces[keep]


def tessellation(topo) -> PartMesh:
    """The part's tessellation (:func:`texcad.brep.part_tessellation`)."""
    return part_tessellation(topo)


def body_count(topo) -> int:
    """Closed bodies of the part: its solids."""
    return len(solids_of(topo))
