"""Where on a mesh a texture goes: :class:`Region` (mm and degrees).

A region selects faces of a triangle mesh:

* ``all``: every face;
* ``normal``: faces whose outward normal lies within ``angle`` degrees of
  ``direction`` (``n . d >= cos(angle)``);
* ``box``: faces whose centroid lies in the axis-aligned box ``lo..hi`` (mm);
* ``sphere``: faces whose centroid lies within ``radius`` mm of ``center``;
* ``face``: a direction word as on a CAD part (``top``, ``bottom``, ``front``,
  ``back``, ``left``, ``right``): the largest flat patch facing that way, the
  connected faces whose normals lie within 2.6 degrees of it
  (:func:`flat_patch`, resolved on the mesh by :func:`resolve_faces`).

The bed face is left out unless ``bottom=True``: faces whose normal is within 1
degree of ``-build_dir`` and whose vertices all lie within ``tolerance`` mm of the
part's lowest point along ``build_dir`` (the face the part stands on).

String forms (CLI): ``"all"``, ``"not-bottom"`` (the same: the bed face is never
textured by default), ``"all+bottom"``, ``"normal:+x:70"`` or ``"normal:0,1,1:30"``,
``"box:x0,y0,z0,x1,y1,z1"``, ``"sphere:x,y,z,r"``, ``"top"`` (``"bottom"`` includes the
bed face it names); ``"not:SPEC"`` is every face but
those of ``SPEC`` (e.g. ``"not:normal:+z:30"``: the sides and below, not the top).

Slicer paint (``kind="paint"``, on a 3MF project: :mod:`texcad.io.paint`):
``"paint:2"`` is the surface painted with state 2 (multi-material paint: extruder /
filament 2), ``"paint:fuzzy"`` the fuzzy-skin paint, ``"paint:support"`` /
``"paint:seam"`` the enforcers (``"paint:support:2"``: the blockers). The project's
painted triangles are first cut along their sub-triangles
(:func:`resolve_paint`), so the painted area's border is made of mesh edges and the
region is exactly the painted faces.

Several zones (:func:`zone_layers`): a mapping ``{region: texture}`` (``None``: leave
that region alone) becomes one texture layer per zone.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..errors import InputError, ParameterError
from .projection import parse_axis
from ..io.paint import PAINT_KINDS

__all__ = ["Region", "REGION_KINDS", "bed_faces", "bed_plane", "hold_above", "flat_patch", "resolve_faces", "resolve_paint", "zone_layers", "PaintedTarget", "region_table"]

REGION_KINDS = ("all", "normal", "box", "sphere", "paint", "face")
#: Largest angle between a ``face`` region's direction and its faces' normals, degrees
#: (as a CAD part's direction words: :data:`texcad.brep.selectors.DIRECTIONS`).
FLAT_ANGLE = 2.6
#: ``paint:WORD`` names: the kind of paint (:data:`texcad.io.paint.ATTRIBUTES`) and its default state.
PAINT_WORDS = {"fuzzy": ("fuzzy", 1), "support": ("support", 1), "supports": ("support", 1), "seam": ("seam", 1),
               "color": ("color", None), "colour": ("color", None)}


def _numbers(text: str, count: int, what: str) -> list[float]:
    try:
        vals = [float(t) for t in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) != count or not all(np.isfinite(vals)):
        raise ParameterError(f"region {what!r} needs {count} numbers separated by commas (mm), got {text!r}")
    return vals


def flat_patch(vertices: np.ndarray, faces: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """``(M,)`` bool: the largest flat patch of a welded mesh facing ``direction`` (a
    unit vector): of the faces whose normal ``n`` has ``n . d >= cos(FLAT_ANGLE)``, the
    set joined by shared edges with the largest area (connected components of their
    edge graph, scipy)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    cross = np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]], vertices[faces[:, 2]] - vertices[faces[:, 0]])
    area = np.linalg.norm(cross, axis=1)
    facing = (cross @ np.asarray(direction, np.float64)) >= np.cos(np.radians(FLAT_ANGLE)) * area
    idx = np.flatnonzero(facing & (area > 0))
    mask = np.zeros(len(faces), dtype=bool)
    if not len(idx):
        return mask
    e = np.sort(faces[idx][:, [[0, 1], [1, 2], [2, 0]]], axis=2).reshape(-1, 2).astype(np.int64)
    key = e[:, 0] * (int(e.max()) + 1) + e[:, 1]
    owner = np.repeat(np.arange(len(idx)), 3)[np.argsort(key, kind="stable")]
    key = np.sort(key)
    same = key[1:] == key[:-1]
    graph = coo_matrix((np.ones(int(same.sum())), (owner[:-1][same], owner[1:][same])), shape=(len(idx), len(idx)))
    _, label = connected_components(graph, directed=False)
    mask[idx[label == np.argmax(np.bincount(label, weights=area[idx]))]] = True
    return mask


def bed_faces(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, build_dir: np.ndarray, tolerance: float) -> np.ndarray:
    """``(M,)`` bool: the faces the part stands on (normal within 1 degree of
    ``-build_dir``, all three vertices within ``tolerance`` mm of the lowest point)."""
    h = vertices @ build_dir
    low = float(h.min()) if len(h) else 0.0
    down = normals @ -build_dir >= np.cos(np.radians(1.0))
    return down & np.all(h[faces] <= low + tolerance, axis=1)


def bed_plane(v: np.ndarray, f: np.ndarray, fn: np.ndarray, dirs: Any, regions: Sequence, tol: float) -> "tuple | None":
    """``(up, level)``: the build direction (unit, ``dirs[0]`` else +z) and the height
    (mm along it) of the bed plane a mesh ``(v, f)`` (mm, face normals ``fn``) stands
    on when it has a bed face (``tol`` mm) that none of the ``regions`` textures (none
    says ``bottom``), else None (:func:`texcad.targets.mesh.keep_bed` for a mesh made
    in blocks)."""
    up = np.asarray(dirs[0] if dirs is not None else (0.0, 0.0, 1.0), dtype=np.float64)
    up = up / np.linalg.norm(up)
    if any(getattr(r, "bottom", False) for r in regions) or not bed_faces(v, f, fn, up, tol).any():
        return None
    return up, float((v @ up).min())


def hold_above(v: np.ndarray, normals: np.ndarray, d: np.ndarray, up: np.ndarray, level: float) -> np.ndarray:
    """The displacements ``d`` (mm, of the points ``v`` along ``normals``) capped so
    that no point moves under the plane ``level`` mm along the unit ``up``."""
    above = np.maximum(v @ up - level, 0.0)  # mm over the plane
    nu = normals @ up  # how far one mm of displacement moves a point up (the offset directions are mitred)
    out = np.where(nu < 0, above / np.where(nu < 0, -nu, 1.0), np.inf)  # the most a point may move out, mm
    into = np.where(nu > 0, -above / np.where(nu > 0, nu, 1.0), -np.inf)  # the most it may move in (negative)
    return np.clip(d, into, out)


@dataclass(frozen=True)
class Region:
    """A set of faces to texture (module docstring). Lengths mm, angles degrees.

    Attributes:
        kind: one of :data:`REGION_KINDS`.
        direction: ``normal``: the direction (``"+x"`` or a 3-vector).
        angle: ``normal``: half-angle of the cone of normals, degrees (0..180).
        lo, hi: ``box`` corners, mm.
        center, radius: ``sphere``, mm.
        bottom: texture the bed face too (default False).
        invert: every face *not* selected by the rest (the bed face still left out).
        paint, state: ``paint``: the kind of slicer paint (``color``, ``fuzzy``,
            ``support``, ``seam``) and its state (``color``: extruder number).
        faces: ``paint``: ``(M,)`` bool, the painted faces of the mesh after
            :func:`resolve_paint` (set by it; not compared).
        cavity: ``(M,)`` bool, the faces of the mesh that line a sealed cavity, in no
            region (set by :func:`mark_cavities`; not compared).
    """

    kind: str = "all"
    direction: "str | Sequence[float]" = "+z"
    angle: float = 90.0
    lo: "Sequence[float] | None" = None
    hi: "Sequence[float] | None" = None
    center: "Sequence[float] | None" = None
    radius: float | None = None
    bottom: bool = False
    invert: bool = False
    paint: str = "color"
    state: int = 1
    faces: Any = field(default=None, compare=False, repr=False)
    cavity: Any = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if self.kind not in REGION_KINDS:
            raise ParameterError(f"region kind {self.kind!r}: use one of {', '.join(REGION_KINDS)}")
        if self.kind == "normal":
            parse_axis(self.direction)
            if not (0 < float(self.angle) <= 180):
                raise ParameterError(f"region angle must be in (0, 180] degrees, got {self.angle!r}")
        if self.kind == "box":
            if self.lo is None or self.hi is None or np.any(np.asarray(self.hi, float) <= np.asarray(self.lo, float)):
                raise ParameterError(f"a box region needs lo < hi in x, y and z (mm), got {self.lo!r}, {self.hi!r}")
        if self.kind == "paint" and (self.paint not in PAINT_KINDS or not isinstance(self.state, (int, np.integer)) or not 1 <= self.state <= 33):
            raise ParameterError(f"a paint region is paint:N (N = 1..33, the painted state / extruder) or paint:fuzzy, "
                                 f"paint:support, paint:seam; got kind {self.paint!r}, state {self.state!r}")
        if self.kind == "sphere" and (self.center is None or self.radius is None or not self.radius > 0):
            raise ParameterError("a sphere region needs a center (x, y, z) and a positive radius in mm")

    def __str__(self) -> str:
        """The string form :meth:`parse` reads (``normal:+z:60``, ``not:top``...), as
        messages name the region."""
        g = lambda xs: ",".join(f"{float(x):g}" for x in xs)  # noqa: E731
        if self.kind == "face":
            body = next((w for w, d in _directions().items() if np.allclose(d, self.direction) and (w == "bottom") == self.bottom), "face")
        elif self.kind == "normal":
            d = self.direction if isinstance(self.direction, str) else g(self.direction)
            body = f"normal:{d}:{float(self.angle):g}"
        elif self.kind in ("box", "sphere"):
            body = f"box:{g([*self.lo, *self.hi])}" if self.kind == "box" else f"sphere:{g([*self.center, self.radius])}"
        elif self.kind == "paint":
            body = _region_name(self)
        else:
            body = "all+bottom" if self.bottom else "all"
        return f"not:{body}" if self.invert else body

    @classmethod
    def parse(cls, spec: "str | Region | None") -> "Region":
        """A region from its string form (module docstring), a Region, or None (all)."""
        if spec is None:
            return cls()
        if isinstance(spec, Region):
            return spec
        if not isinstance(spec, str):
            raise ParameterError(f"a mesh region is a texcad Region or a string like 'normal:+x:70', got {type(spec).__name__}")
        s = spec.strip().lower()
        if s.startswith("not:"):
            inner = cls.parse(s[4:])
            return cls(**{**inner.__dict__, "invert": not inner.invert})
        if s in ("all", "not-bottom", "everything-but-bottom"):
            return cls()
        if s in ("all+bottom", "everything"):
            return cls(bottom=True)
        if s in _directions():
            return cls("face", direction=_directions()[s], bottom=s == "bottom")
        kind, _, rest = s.partition(":")
        if kind == "paint":
            return cls._parse_paint(spec, rest)
        if kind == "normal":
            d, _, a = rest.rpartition(":")
            try:
                ang = float(a)
            except ValueError:
                raise ParameterError(f"region {spec!r}: write normal:DIRECTION:DEGREES, e.g. normal:+x:70") from None
            direction = d if d.lstrip("+-") in ("x", "y", "z") else _numbers(d, 3, "normal direction")
            return cls("normal", direction=direction, angle=ang)
        if kind == "box":
            v = _numbers(rest, 6, spec)
            return cls("box", lo=tuple(v[:3]), hi=tuple(v[3:]))
        if kind == "sphere":
            v = _numbers(rest, 4, spec)
            return cls("sphere", center=tuple(v[:3]), radius=v[3])
        raise ParameterError(
            f"unknown region {spec!r}; use all, not-bottom, all+bottom, normal:+x:70, box:x0,y0,z0,x1,y1,z1, "
            f"sphere:x,y,z,r, paint:N, paint:fuzzy, {', '.join(_directions())} or not:REGION"
        )

    @classmethod
    def _parse_paint(cls, spec: str, rest: str) -> "Region":
        """``paint:N``, ``paint:color:N``, ``paint:fuzzy``, ``paint:support[:N]``, ``paint:seam[:N]``."""
        word, _, num = rest.partition(":")
        if word in PAINT_WORDS:
            kind, state = PAINT_WORDS[word]
        else:
            kind, state, num = "color", None, word
        try:
            state = int(num) if num else state
        except ValueError:
            state = None
        if state is None:
            raise ParameterError(f"region {spec!r}: write paint:N (N the painted state, e.g. paint:2 for extruder 2), "
                                 "paint:fuzzy, paint:support or paint:seam")
        return cls("paint", paint=kind, state=state)

    def settled(self, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """``(M,)`` bool: faces whose every piece after subdivision is selected as the
        face is (``all`` and ``normal`` regions: every face; ``box`` and ``sphere``:
        faces with all three corners inside, or whose bounding box misses the
        region's; the rest straddle its boundary)."""
        if self.kind in ("all", "normal", "paint", "face"):
            return np.ones(len(faces), dtype=bool)
        tri = vertices[faces]
        if self.kind == "box":
            lo, hi = np.asarray(self.lo, float), np.asarray(self.hi, float)
            inside = np.all((tri >= lo) & (tri <= hi), axis=(1, 2))
            meets = np.all(tri.max(axis=1) >= lo, axis=1) & np.all(tri.min(axis=1) <= hi, axis=1)
        else:
            c0, r = np.asarray(self.center, float), float(self.radius)
            inside = np.all(np.linalg.norm(tri - c0, axis=2) <= r, axis=1)
            meets = np.all(tri.max(axis=1) >= c0 - r, axis=1) & np.all(tri.min(axis=1) <= c0 + r, axis=1)
        return inside | ~meets

    def select(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        normals: np.ndarray,
        *,
        build_dir: np.ndarray,
        tolerance: float,
        loose: bool = False,
        ids: "np.ndarray | None" = None,
    ) -> np.ndarray:
        """``(M,)`` bool: the faces in the region.

        ``loose``: box and sphere regions take every face whose bounding box meets
        the region's (a superset, used before subdivision; afterwards the centroid
        decides). ``ids``: each face's face of the mesh the region was resolved on
        (``paint`` regions: faces after subdivision inherit their parent's paint).
        """
        tri = vertices[faces]
        if self.kind in ("paint", "face"):
            sel = self._painted(len(faces), ids)
        elif self.kind == "all":
            sel = np.ones(len(faces), dtype=bool)
        elif self.kind == "normal":
            sel = normals @ parse_axis(self.direction) >= np.cos(np.radians(float(self.angle))) - 1e-12
        elif self.kind == "box":
            lo, hi = np.asarray(self.lo, float), np.asarray(self.hi, float)
            if loose:
                sel = np.all(tri.max(axis=1) >= lo, axis=1) & np.all(tri.min(axis=1) <= hi, axis=1)
            else:
                c = tri.mean(axis=1)
                sel = np.all((c >= lo) & (c <= hi), axis=1)
        else:
            c0, r = np.asarray(self.center, float), float(self.radius)
            if loose:
                sel = np.all(tri.max(axis=1) >= c0 - r, axis=1) & np.all(tri.min(axis=1) <= c0 + r, axis=1)
            else:
                sel = np.linalg.norm(tri.mean(axis=1) - c0, axis=1) <= r
        if self.invert:
            sel = np.ones(len(faces), dtype=bool) if (loose and self.kind in ("box", "sphere")) else ~sel
        if not self.bottom:
            sel &= ~bed_faces(vertices, faces, normals, build_dir, tolerance)
        if self.cavity is not None:  # a sealed void's wall: never textured
            if ids is None and len(self.cavity) != len(faces):
                raise ParameterError(f"a region's cavity marks {len(self.cavity)} faces but the mesh has {len(faces)}: "
                                     "pass ids (each face's face of the mesh the region was resolved on)")
            sel &= ~(self.cavity if ids is None else self.cavity[ids])
        return sel

    def _painted(self, m: int, ids: "np.ndarray | None") -> np.ndarray:
        if self.faces is None and self.kind == "face":
            raise ParameterError("a face region (top, bottom, ...) is found on the mesh it textures; pass it to "
                                 "texcad.texture with that mesh")
        if self.faces is None:
            raise ParameterError(f"the region paint:{self.state} reads a slicer project's paint: texture the project's "
                                 ".3mf file itself (texcad.texture('project.3mf', 'paint:2', ...))")
        mask = np.asarray(self.faces, dtype=bool)
        if ids is None:
            if len(mask) != m:
                raise ParameterError(f"a paint region marks {len(mask)} faces but the mesh has {m}")
            return mask.copy()
        return mask[np.asarray(ids)]


@dataclass(frozen=True)
class PaintedTarget:
    """A slicer project made ready for paint regions (:func:`resolve_paint`).

    Attributes:
        mesh: the project's meshes (build frame, mm) with the painted triangles cut
            into their sub-triangles, repaired (what texturing reads unchanged).
        state: ``(M,)`` int64, each face's state of the kind of paint used.
        kind: the kind of paint (``color``, ``fuzzy``, ``support``, ``seam``).
        project: the :class:`texcad.io.paint.Project` read.
        items: the build items textured (those painted with a state asked for; the
            others are left out of ``mesh`` and kept as they are on export).
    """

    mesh: Any
    state: np.ndarray
    kind: str
    project: Any
    items: tuple = ()


def _paint_summary(project) -> str:
    parts = []
    for kind in project.paint:  # per kind of paint in the file
        st = project.states(kind)
        if st:
            parts.append(f"{kind} " + ", ".join(str(s) for s in st))
    return "; ".join(parts)


def _region_name(r: "Region") -> str:
    return f"paint:{r.state}" if r.paint == "color" else f"paint:{r.paint}" + (f":{r.state}" if r.state != 1 else "")


def _directions() -> dict:
    from ..brep.selectors import DIRECTIONS

    return DIRECTIONS


def resolve_faces(vertices: np.ndarray, faces: np.ndarray, regions: "list[Region]") -> "list[Region]":
    """``regions`` with each ``face`` region's faces marked on the mesh
    (:func:`flat_patch`); the others as they are."""
    return [Region("face", direction=r.direction, bottom=r.bottom, invert=r.invert,
                   faces=flat_patch(vertices, faces, parse_axis(r.direction))) if r.kind == "face" else r for r in regions]


def mark_cavities(vertices: np.ndarray, faces: np.ndarray, regions: "list[Region]") -> "list[Region]":
    """``regions`` with the walls of the sealed cavities of a closed, repaired mesh
    (:func:`texcad.solid.repair_closed`: a cavity's wall faces into it) marked as in
    none of them (``cavity``): nobody sees or touches them, and relief raised into a
    narrow void turns it inside out. As they are when the mesh has no cavity."""
    from dataclasses import replace

    from ..solid import cavity_faces

    cav = cavity_faces(vertices, faces)
    return [replace(r, cavity=cav) for r in regions] if cav.any() else list(regions)


def resolve_paint(target: Any, regions: "list[Region]") -> "tuple[Any, list[Region], PaintedTarget | None]":
    """Give ``paint`` regions their faces: read the project ``target`` (a ``.3mf``
    path), cut its painted triangles along their sub-triangles
    (:func:`texcad.io.paint.split_painted`), repair the mesh and mark each region's
    faces. Returns ``(mesh, regions, PaintedTarget)``; without paint regions the
    target and regions unchanged and None.

    Raises:
        InputError: the project holds no paint of that kind or no face of that state
            (the message lists the paint the file holds), or a damaged paint string.
        ParameterError: paint regions on a target that is not a 3MF project, or of
            two kinds of paint in one call.
    """
    from ..io.paint import read_project, split_painted
    from ..solid import Mesh, repair_closed

    wanted = [r for r in regions if r.kind == "paint"]
    if not wanted:
        return target, regions, None
    if not (isinstance(target, (str, os.PathLike)) and os.fspath(target).lower().endswith(".3mf")):
        raise ParameterError(f"{_region_name(wanted[0])} reads slicer paint: texture the painted project's .3mf file "
                             "(PrusaSlicer, OrcaSlicer or BambuStudio), not a mesh")
    kinds = sorted({r.paint for r in wanted})
    if len(kinds) > 1:
        raise ParameterError(f"paint regions of one kind per call, got {', '.join(kinds)}; texture the result again for the other")
    kind = kinds[0]
    project = read_project(target)
    name = repr(os.path.basename(os.fspath(target)))
    have = _paint_summary(project)
    if kind not in project.paint or not any(project.paint[kind]):
        raise InputError(f"{name} holds no {kind} paint" + (f" (it holds: {have})" if have else " (no paint at all)")
                         + "; paint the zone in PrusaSlicer, OrcaSlicer or BambuStudio and save the project")
    v, f, state, parent = split_painted(project.vertices, project.faces, project.paint[kind])
    for r in wanted:  # per paint region: is its state there?
        if not (state == r.state).any():
            raise InputError(f"{name}: no triangle is painted {_region_name(r)}; the file holds {have}")
    item = np.zeros(len(project.faces), dtype=np.int64)
    for k, *_, a, b in project.parts:  # per mesh placed: its build item
        item[a:b] = k
    items = np.unique(item[parent[np.isin(state, [r.state for r in wanted])]])
    first: dict = {}
    for k in items.tolist():  # instances of one object: texture the first (written back, every instance has it)
        first.setdefault(project.items[k][0], k)
    items = np.array(sorted(first.values()), dtype=np.int64)
    keep = np.isin(item[parent], items)  # the painted objects only: the rest stays as it is
    used, f = np.unique(f[keep], return_inverse=True)
    v, f, state = v[used], f.reshape(-1, 3), state[keep]
    v32 = v.astype(np.float32).astype(np.float64)
    v2, f2, _ = repair_closed(v32, f, name=name)
    state2 = _match_faces(v32, f, v2, f2, state)
    v2, f2, state2 = _cut_negatives(project, items, v2, f2, state2, name)
    mesh = Mesh(v2, f2)
    out = [Region("paint", paint=r.paint, state=r.state, bottom=r.bottom, invert=r.invert, faces=state2 == r.state)
           if r.kind == "paint" else r for r in regions]
    return mesh, out, PaintedTarget(mesh, state2, kind, project, tuple(int(i) for i in items))


def _cut_negatives(project: Any, items: np.ndarray, v: np.ndarray, f: np.ndarray, state: np.ndarray, name: str):
    """The painted objects as the slicer prints them: the negative volumes of build
    ``items`` (:attr:`texcad.io.paint.Project.negatives`) cut out (manifold3d), every
    face keeping its paint ``state`` through manifold3d's face ids, the cut's new walls
    unpainted (0). Returns ``(v, f, state)``; as they are without negative volumes.

    Raises:
        InputError: a negative volume that is not a closed solid, or a cut that fails."""
    import manifold3d as m3d

    from ..errors import GeometryError
    from ..solid import Mesh, to_manifold

    kept = set(items.tolist())
    negs = [Mesh(nv.astype(np.float32), np.asarray(nf, np.uint32)) for k, nv, nf in project.negatives if k in kept]
    if not negs:
        return v, f, state
    oid = int(m3d.Manifold.reserve_ids(1))
    body = m3d.Manifold(m3d.Mesh(vert_properties=np.ascontiguousarray(v, np.float32), tri_verts=np.ascontiguousarray(f, np.uint32),
                                 run_index=np.array([0, 3 * len(f)], np.uint32), run_original_id=np.array([oid], np.uint32),
                                 face_id=np.arange(len(f), dtype=np.uint32)))
    try:
        cut = body - m3d.Manifold.batch_boolean([to_manifold(m) for m in negs], m3d.OpType.Add)
    except GeometryError as exc:
        raise InputError(f"{name}: a negative volume of the painted object is not a closed solid ({exc}); apply the cut "
                         "in the slicer or CAD program, or mend the volume, and save the project again") from None
    if body.status() != m3d.Error.NoError or cut.status() != m3d.Error.NoError or cut.is_empty():
        raise InputError(f"{name}: cutting the painted object's negative volumes out of it failed or left nothing "
                         f"(manifold3d: {cut.status().name}); apply the cut in the slicer and save the project again")
    gl = cut.to_mesh()
    runs = np.repeat(np.asarray(gl.run_original_id, np.int64), np.diff(np.asarray(gl.run_index, np.int64)) // 3)
    ids = np.asarray(gl.face_id, np.int64)
    out = np.where(runs == oid, state[np.where(runs == oid, ids, 0)], 0)
    return np.asarray(gl.vert_properties, np.float64)[:, :3], np.asarray(gl.tri_verts, np.int64), out


def _match_faces(v, f, v2, f2, values):
    """``values`` of faces ``f`` carried to the repaired faces ``f2`` (the same
    triangles, some dropped or turned: matched by their sorted corners)."""
    if len(f2) == len(f) and np.allclose(np.sort(v[f].sum(axis=1), axis=0), np.sort(v2[f2].sum(axis=1), axis=0)):
        same = np.all(np.isclose(v[f].sum(axis=1), v2[f2].sum(axis=1)), axis=1)
        if same.all():
            return values.copy()
    from scipy.spatial import cKDTree

    _, idx = cKDTree(v[f].mean(axis=1)).query(v2[f2].mean(axis=1))
    return values[idx]


def zone_layers(where: Any, texture: Any) -> list:
    """Texture layers ``(region, texture, {options})`` from ``where``: a mapping
    ``{region: texture}`` (a texture, ``(texture, {options})``, or ``None`` to leave
    the region alone), a list of layers (as it is), or one region (with ``texture``)."""
    if isinstance(where, dict):
        out = []
        for region, spec in where.items():  # per zone
            if spec is None:
                continue
            tex, opts = (spec[0], dict(spec[1])) if isinstance(spec, tuple) else (spec, {})
            out.append((region, tex, opts))
        if not out:
            raise ParameterError("every zone of the mapping has texture None: give at least one zone a texture")
        return out
    return where if isinstance(where, list) else [(where, texture, {})]


#: The ``--region`` specs :func:`region_table` lists for a mesh: the default, each
#: direction word's flat patch, and the faces within 45 degrees of each axis.
LISTED_REGIONS = ("not-bottom", "top", "bottom", "front", "back", "left", "right",
                  "normal:+z:45", "normal:-z:45", "normal:+x:45", "normal:-x:45", "normal:+y:45", "normal:-y:45")


def region_table(mesh: Any, *, tolerance: float = 0.01, repaired: bool = False) -> list[dict]:
    """What each ``--region`` spec of :data:`LISTED_REGIONS` picks on a
    :class:`~texcad.solid.Mesh` printed along +z (``tolerance`` mm: the bed face's,
    :func:`bed_faces`): one dict per spec with ``region``, ``faces`` (count), ``area``
    (mm2) and ``centre`` (mm, the area-weighted centroid of its faces; None when it
    picks none). ``repaired`` (:func:`texcad.solid.repair_closed`'s output): a sealed
    cavity's walls are in no region, as texturing takes them (:func:`mark_cavities`)."""
    from ..solid import face_normals

    v, f = mesh.vertices.astype(np.float64), np.asarray(mesh.faces, np.int64)
    (normals, area), centroid = face_normals(v, f), v[f].mean(axis=1)
    rows = []
    for spec in LISTED_REGIONS:  # thirteen specs, each vectorized over the faces
        (region,) = resolve_faces(v, f, [Region.parse(spec)])
        (region,) = mark_cavities(v, f, [region]) if repaired else (region,)
        sel = region.select(v, f, normals, build_dir=np.array([0.0, 0.0, 1.0]), tolerance=tolerance)
        a = float(area[sel].sum())
        rows.append({"region": spec, "faces": int(sel.sum()), "area": a,
                     "centre": tuple(float(c) for c in area[sel] @ centroid[sel] / a) if a > 0 else None})
    return rows
