"""What the CAD adapters (planar face, extruded face, any faces) share: the part's
OCCT shape, the selected faces, chaining onto an earlier result, and the common
fields of their :class:`~texcad.contracts.Placement` (the part's tessellation as the
base, the selected faces' triangles as the selected surface). Lengths in mm.
"""

from __future__ import annotations

import os
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..brep import PartMesh, explore, part_tessellation, solids_of, to_topods
from ..contracts import Stages
from ..errors import GeometryError, ParameterError

__all__ = ["named_where", "require_solid", "selected_faces", "CadPart", "CadZone", "ZONE_OPTIONS", "cad_part", "cad_zones", "face_list", "is_cad_target", "is_zones",
           "zone_options", "FACE_NUMBERS", "face_numbers"]

#: The options a zone of a CAD part may set for itself (the rest are the call's: one
#: build direction, one B-rep for the whole part).
ZONE_OPTIONS = ("height", "pitch", "mode", "depth", "edge_angle", "rotation", "tolerance", "gradient", "mask", "mask_size")


#: While one solid of an assembly is textured alone: for each of its faces the
#: number ``texcad faces`` gives it among the assembly's faces (messages name those).
FACE_NUMBERS: ContextVar = ContextVar("texcad_face_numbers", default=None)


def face_numbers(ids: Any) -> list:
    """The face indices ``ids`` of the part being textured as the user numbers them:
    the assembly's numbers while one of its solids is textured alone
    (:data:`FACE_NUMBERS`), else as they are."""
    table = FACE_NUMBERS.get()
    return [int(i) if table is None or int(i) >= len(table) else int(table[int(i)]) for i in ids]


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


@dataclass(frozen=True)
class CadZone:
    """One zone of a CAD call: faces with their own texture and options.

    Attributes:
        part: the zone's faces resolved on the part (:class:`CadPart`).
        texture: the zone's texture as given (``"builtin:..."``, an image path or a
            Heightmap).
        options: the zone's own options as given (names of :data:`ZONE_OPTIONS`;
            validated by :func:`zone_options`).
        name: how outputs name the zone (a 3MF part): ``"zone K TEXTURE"``.
    """

    part: CadPart
    texture: Any
    options: dict
    name: str


def _texture_like(x: Any) -> bool:
    from ..sources import Heightmap

    return x is None or isinstance(x, (str, os.PathLike, Heightmap))


def is_zones(where: Any) -> bool:
    """Whether ``where`` gives zones: a list of ``(faces, texture[, {options}])`` or a
    mapping ``{face: texture}`` (not a plain face selection)."""
    if isinstance(where, dict):
        return True
    if type(where) not in (list, tuple):  # a build123d ShapeList is a selection of faces
        return False
    return any(isinstance(z, tuple) and len(z) >= 2 and _texture_like(z[1]) for z in where)


def cad_zones(target: Any, where: Any, texture: Any) -> tuple:
    """The zones of a CAD call (:class:`CadZone`), each resolved on the part.

    ``where`` is a list of ``(faces, texture)`` or ``(faces, texture, {options})``
    (``texture`` None: the call's ``texture``), or a mapping ``{faces: texture or
    (texture, {options})}`` (None leaves the faces alone, as on meshes).

    Raises:
        ParameterError: a zone that is not such a tuple, an empty zone, a face not of
            the part, or a face in two zones (the message names the zone and face).
    """
    from ..mapping.region import zone_layers

    raw = zone_layers(where, texture) if isinstance(where, dict) else list(where)
    if not raw:
        raise ParameterError("no zone given; pass [(faces, texture, {options}), ...]")
    zones, owner = [], {}
    for k, z in enumerate(raw):  # per zone
        if not (isinstance(z, tuple) and len(z) in (2, 3) and _texture_like(z[1]) and (len(z) == 2 or isinstance(z[2], dict))):
            raise ParameterError(f"zone {k + 1} is {z!r}; give each zone as (faces, texture) or (faces, texture, {{options}})")
        faces, tex = z[0], texture if z[1] is None else z[1]
        opts = dict(z[2]) if len(z) == 3 else {}
        try:
            cp = cad_part(target, faces)
        except ParameterError as e:
            raise ParameterError(f"zone {k + 1}: {e}") from None
        for i in cp.face_ids:  # per face of the zone
            if i in owner:
                raise ParameterError(f"face {i} is in zone {owner[i] + 1} and in zone {k + 1}; give each face to one zone")
            owner[i] = k
        label = os.fspath(tex) if isinstance(tex, (str, os.PathLike)) else type(tex).__name__
        zones.append(CadZone(cp, tex, opts, f"zone {k + 1} {label}"))
    return tuple(zones)


def zone_options(options: Any, zone: CadZone, k: int) -> Any:
    """The zone's :class:`texcad.options.Options`: the call's with the zone's own
    options over them, validated by the same rules (a Heightmap texture keeps its own
    heights unless the zone gives ``height``; the call's ``height`` is for the
    other zones).

    Raises:
        ParameterError: an unknown option, one a zone cannot set, or a bad value,
            naming the zone.
    """
    import dataclasses

    from ..options import option_names
    from ..sources import Heightmap

    bad = sorted(set(zone.options) - set(ZONE_OPTIONS))
    if bad:
        what = "not an option of texcad.texture" if set(bad) - set(option_names()) else "an option of the whole call"
        raise ParameterError(f"zone {k + 1} ({zone.name.split(' ', 2)[-1]}): {', '.join(map(str, bad))}: {what}; a zone sets "
                             f"{', '.join(ZONE_OPTIONS)} for itself (give the others to the call)")
    try:
        out = options.replace(**zone.options)
    except ParameterError as e:
        raise ParameterError(f"zone {k + 1} ({zone.name.split(' ', 2)[-1]}): {e}") from None
    if isinstance(zone.texture, Heightmap) and "height" not in zone.options and zone.texture.max_height > 0:
        out = dataclasses.replace(out, height=float(zone.texture.max_height))
    return out


def is_cad_target(target: Any) -> bool:
    """A build123d / CadQuery / OCP shape, or an earlier CAD result (chaining)."""
    if isinstance(getattr(target, "stages", None), Stages):
        return True
    try:
        to_topods(target)
    except (ParameterError, TypeError, AttributeError):
        return False
    return True


def named_where(target: Any, where: Any) -> Any:
    """``where`` with each face selector given as text (``"top"``, ``"cylinder:all"``,
    ``"solid:1/top+right"``: :mod:`texcad.brep.selectors`, the command line's
    vocabulary) or as a face index (an int) replaced by the faces it names on the CAD ``target``; zones' faces
    too. Anything else (faces, a mesh's region) is returned as it is.

    Raises:
        ParameterError: a selector that names no face of the part.
    """
    scope = _named_scope(target) if isinstance(where, (str, list, tuple)) or _index(where) else None
    if scope is None:
        return where
    require_solid(scope)  # a surface's first error is that it holds no solid, not that "top" names no face
    from ..brep.selectors import faces_named

    def named(w: Any) -> bool:
        return isinstance(w, str) or _index(w)

    def faces(w: Any) -> Any:
        return faces_named(scope, str(int(w)) if _index(w) else w) if named(w) else w

    if named(where):
        return faces(where)
    if is_zones(where):
        return [(faces(z[0]), *z[1:]) for z in where]
    return [f for w in where for f in (faces(w) if named(w) else [w])]


def _index(w: Any) -> bool:
    """A face index (an int, as ``texcad faces`` lists them), not a bool."""
    return isinstance(w, (int, np.integer)) and not isinstance(w, bool)


def _named_scope(target: Any) -> Any:
    """The build123d shape whose faces selectors name: the part (an earlier CAD
    result's part), or None for a target that is not a CAD part."""
    from .mesh import is_mesh_target

    if is_mesh_target(target) or not is_cad_target(target):  # a mesh never loads OCCT
        return None
    stages = getattr(target, "stages", None)
    topo = stages.placement.topo if isinstance(stages, Stages) else to_topods(target)
    if topo is None:  # a textured mesh: its where is a region
        return None
    from build123d import Shape

    return Shape.cast(topo)


def selected_faces(where: Any) -> list:
    """Every face ``where`` selects: a face selection (:func:`face_list`) or the
    faces of all zones (:func:`is_zones`), in order."""
    if not is_zones(where):
        return face_list(where)
    items = [k for k, v in where.items() if v is not None] if isinstance(where, dict) else [z[0] for z in where]
    return [f for faces in items for f in face_list(faces)]


def face_list(faces: Any) -> list:
    """A list of faces from one face, a build123d ``ShapeList``, a list or a
    CadQuery selection."""
    if callable(getattr(faces, "vals", None)) and hasattr(faces, "objects"):
        faces = faces.vals()
    items = list(faces) if isinstance(faces, (list, tuple)) or type(faces).__name__ == "ShapeList" else [faces]
    if not items:
        raise ParameterError("no face selected; pass a face or a list of faces of the part")
    return items


def require_solid(part: Any, name: "str | None" = None) -> None:
    """Refuse a CAD part (build123d / CadQuery / OCP shape) that holds no solid (a
    STEP surface model: faces in an open shell) before its faces are selected, so the
    error names that, not a face selector the open shell happens not to match.

    Raises:
        ParameterError: the part (called ``name``, e.g. its file, where given) holds no
            solid, saying what it holds and what to do.
    """
    topo = to_topods(part)
    if not solids_of(topo):
        raise ParameterError(_no_solid(part, topo, name))


def _no_solid(target: Any, topo: Any, name: "str | None" = None) -> str:
    """What a part (``name``, or its type) with no solid holds (a STEP surface model:
    faces in an open shell) and what to do."""
    from OCP.TopAbs import TopAbs_FACE

    n = len(explore(topo, TopAbs_FACE))
    held = f"{n} face(s) but no closed body: a surface" if n else "no faces"
    return (f"{name or 'the ' + type(target).__name__} holds no solid to texture ({held}); pass a solid part: export the body as a "
            "solid, or close or thicken the surface in the CAD program first")


def _solids_only(topo: Any) -> Any:
    """``topo`` without its faces that belong to no solid (a STEP's surface model
    beside the body, OCCT's trj6_c1-ug-214.stp: they enclose no volume, and left in,
    the part's tessellation is open along them and the part refused), with a
    warning; ``topo`` itself when every face is a solid's."""
    import warnings

    from OCP.BRep import BRep_Builder
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS_Compound

    from ..errors import TexcadWarning

    solids = solids_of(topo)
    loose = len(explore(topo, TopAbs_FACE)) - sum(len(explore(s, TopAbs_FACE)) for s in solids)
    if loose <= 0:
        return topo
    warnings.warn(f"{loose} face(s) of the part belong to no solid (a surface beside the body, enclosing no volume): "
                  "left out of the textured part", TexcadWarning, stacklevel=2)
    out, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(out)
    for solid in solids:  # per solid
        builder.Add(out, solid)
    return out


def _chain(target: Any) -> tuple[Any, Any, tuple]:
    """``(topo, previous stages, faces done)`` of a target that may be an earlier result."""
    stages = getattr(target, "stages", None)
    if not isinstance(stages, Stages):
        topo = to_topods(target)
        if not solids_of(topo):
            raise ParameterError(_no_solid(target, topo))
        return _solids_only(topo), None, ()
    pl = stages.placement
    if pl.topo is None or not getattr(target, "is_unmoved", True):
        raise ParameterError(
            f"this textured {'mesh' if pl.topo is None else 'result, moved since,'} cannot be textured again as a CAD "
            "part; texture all faces in one call: texcad.texture(part, [face1, face2, ...], texture)"
        )
    done = tuple(pl.face_ids) + (tuple(pl.previous.placement.face_ids) if pl.previous is not None else ())
    return pl.topo, stages, done


def _face_index(faces: list, face: Any, previous: Any) -> int | None:
    """The index of ``face`` among the part's ``faces``: the same face, or, chained
    onto an earlier result, the base part's face that ``face`` of the result's B-rep
    took the place of (rebuilt where its edges meet the texture's tiles: the same kind
    of surface, area and centre; :func:`texcad.brep.face_in`)."""
    from ..brep.occt import compound, face_in

    hit = next((k for k, c in enumerate(faces) if c.IsSame(face)), None)
    if hit is not None or previous is None:
        return hit
    base = face_in(compound(faces), face)
    return None if base is None else next(k for k, c in enumerate(faces) if c.IsSame(base))


def cad_part(target: Any, where: Any) -> CadPart:
    """Resolve a CAD target and its selected faces (in the part, with orientation).

    Raises:
        ParameterError: no solid, no face, a face not of this part, a face textured
            already in the chain.
        Decline: ``where`` gives zones (:func:`is_zones`): the any-faces adapter
            takes them (:func:`cad_zones`).
    """
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    from .base import Decline

    if is_zones(where):  # zones: the any-faces adapter's (texcad.targets.faces)
        raise Decline("several zones are textured by the any-faces adapter")
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
        hit = _face_index(all_faces, f, previous)
        if hit is None and previous is not None:
            raise ParameterError(
                "a face is neither a face of the textured result's part nor one its texture left plain (a tile of "
                "a texture is textured already); select a plain face from result.part or from the base part"
            )
        if hit is None and any(f.IsSame(g) for g in explore(to_topods(target), TopAbs_FACE)):
            raise ParameterError("a selected face belongs to no solid of the part (a surface beside the body, left "
                                 "out); select a face of a solid (texcad faces PART.step lists each face's solid)")
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
