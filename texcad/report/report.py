"""``texcad check``: is a part printable? Watertight, manifold, overhangs, thin features.

A part is read from STL or 3MF (or given as meshes) and measured:

* **watertight**: every edge is shared by exactly two faces in opposite directions
  (:func:`texcad.solid.edge_report`), for every object in the file;
* **manifold**: every object is a closed, oriented 2-manifold, as manifold3d
  requires (tested with sorts for a single object; several objects are handed to
  manifold3d, which unites them), and passes the gate's shell checks
  (:func:`texcad.report.gate.shell_report`): no shell faces inwards unless it is a
  cavity, no body lies in or across another (a note names the figures);
* **shells, volume, bounding box, triangles** of the whole part (several objects
  are united with manifold3d first, as a slicer would);
* **overhang area** (mm^2) for a build direction and critical angle, by the rule of
  :func:`texcad.printability.overhang_mask` (downward faces flatter than the
  critical angle, not counting faces on the build plate), for the whole part and
  for the textured surface alone when the input says which faces are texture;
* **thin features** (optional, ``nozzle``): texture features narrower than the nozzle,
  :func:`texcad.printability.thin_features`;
* optionally a **PNG** of the part in print orientation, overhang faces in red.

Which faces are texture: a :class:`~texcad.solid.Mesh` with a ``"texture"`` group
(e.g. :func:`texcad.solid.heightfield_slab`), or several named objects, e.g. a 3MF
written as ``write_3mf([("base", base), ("texture", slab)], path)``: objects whose
name starts with ``texture`` are texture. The objects are united with manifold3d,
which records for every output triangle the object it came from, so the texture's
share is the texture slab's exposed surface (its top and any border walls
standing above the base). Where the slab touches the base's own surface (its buried
border walls lie in the plane of the base's side walls, zero-height areas on the
base's top) the union may attribute the coincident faces to either object; faces of
the texture object that lie on a base triangle (within a few um) are counted as
base, so a base wall that overhangs is never reported as texture. An STL carries no
such information: whole-part numbers only.
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

from ..errors import ParameterError
from ..util import one_blas_thread, threads
from ..sources import Heightmap
from ..io import read_part
from ..solid import Mesh, box_cells, closed_and_oriented, edge_report, shared_faces, shells
from .gate import shell_report
from ..printability import (
    DEFAULT_CRITICAL_ANGLE,
    ThinFeatures,
    check_critical_angle,
    face_areas,
    build_directions,
    overhang_mask,
    thin_features,
)

__all__ = ["CheckReport", "check", "render_check"]

_RED = np.array([0.86, 0.12, 0.10])
_TEXTURE = np.array([0.83, 0.76, 0.62])
_BODY = np.array([0.70, 0.73, 0.78])


# ---------------------------------------------------------------------------------
# The report
# ---------------------------------------------------------------------------------
@dataclass
class CheckReport:
    """What :func:`check` measured. Units: mm, mm^2, mm^3, degrees.

    Attributes:
        source: file path or ``"<mesh>"``.
        objects: names of the objects read.
        watertight: every object is closed (each edge used twice, opposite ways).
        manifold: every object is a closed, oriented 2-manifold (what manifold3d requires).
        shells: connected pieces of the whole part.
        volume_mm3: enclosed volume of the whole part.
        bounds_mm: ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``.
        triangles: triangles of the whole part.
        build_dir: unit build direction used.
        critical_angle_deg: critical overhang angle used.
        overhang_area_mm2: area of overhanging faces of the whole part.
        overhang_faces: how many faces overhang.
        texture_area_mm2: area of the textured surface (None if unknown).
        texture_overhang_area_mm2: overhang area on the textured surface alone
            (None if the input does not say which faces are texture).
        nozzle_mm: nozzle width checked (None if not asked).
        thin_features: :class:`~texcad.printability.ThinFeatures` as a dict, or None.
        png: picture written, if any.
        notes: remarks (e.g. why a number is missing).
    """

    source: str
    objects: list[str]
    watertight: bool
    manifold: bool
    shells: int
    volume_mm3: float
    bounds_mm: list[list[float]]
    triangles: int
    build_dir: list[float]
    critical_angle_deg: float
    overhang_area_mm2: float
    overhang_faces: int
    texture_area_mm2: float | None = None
    texture_overhang_area_mm2: float | None = None
    nozzle_mm: float | None = None
    thin_features: dict | None = None
    png: str | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Watertight, manifold, and no overhang on the textured surface (or the
        whole part, if the texture is unknown)."""
        over = self.texture_overhang_area_mm2 if self.texture_overhang_area_mm2 is not None else self.overhang_area_mm2
        return self.watertight and self.manifold and over == 0.0

    def to_dict(self) -> dict:
        """The report as plain JSON types."""
        return {
            "source": self.source,
            "objects": list(self.objects),
            "watertight": bool(self.watertight),
            "manifold": bool(self.manifold),
            "shells": int(self.shells),
            "volume_mm3": float(self.volume_mm3),
            "bounds_mm": [[float(x) for x in r] for r in self.bounds_mm],
            "triangles": int(self.triangles),
            "build_dir": [float(x) for x in self.build_dir],
            "critical_angle_deg": float(self.critical_angle_deg),
            "overhang_area_mm2": float(self.overhang_area_mm2),
            "overhang_faces": int(self.overhang_faces),
            "texture_area_mm2": None if self.texture_area_mm2 is None else float(self.texture_area_mm2),
            "texture_overhang_area_mm2": None
            if self.texture_overhang_area_mm2 is None
            else float(self.texture_overhang_area_mm2),
            "nozzle_mm": self.nozzle_mm,
            "thin_features": self.thin_features,
            "png": self.png,
            "notes": list(self.notes),
        }

    def to_json(self) -> str:
        """One JSON object (one line)."""
        return json.dumps(self.to_dict())

    def summary(self) -> str:
        """Human-readable lines for the terminal."""
        lo, hi = np.asarray(self.bounds_mm)
        size = hi - lo
        d = np.asarray(self.build_dir, dtype=np.float64) + 0.0  # + 0.0: no "-0" printed
        lines = [
            f"part          {self.source} ({len(self.objects)} object{'s' if len(self.objects) != 1 else ''}: {', '.join(self.objects)})",
            f"watertight    {'yes' if self.watertight else 'NO'}",
            f"manifold      {'yes' if self.manifold else 'NO'}",
            f"shells        {self.shells}",
            f"triangles     {self.triangles}",
            f"volume        {self.volume_mm3:.1f} mm3",
            f"bbox          ({lo[0]:.2f}, {lo[1]:.2f}, {lo[2]:.2f}) .. ({hi[0]:.2f}, {hi[1]:.2f}, {hi[2]:.2f}) mm, "
            f"size {size[0]:.2f} x {size[1]:.2f} x {size[2]:.2f} mm",
            f"build dir     ({d[0]:.4g}, {d[1]:.4g}, {d[2]:.4g}), critical angle {self.critical_angle_deg:g} deg",
            f"overhang      {self.overhang_area_mm2:.2f} mm2 whole part ({self.overhang_faces} faces)",
        ]
        if self.texture_overhang_area_mm2 is not None:
            lines.append(
                f"texture       {self.texture_overhang_area_mm2:.2f} mm2 overhang of {self.texture_area_mm2:.1f} mm2 textured surface"
            )
        if self.thin_features is not None:
            t = self.thin_features
            lines.append(
                f"thin features {t['thin_area_mm2']:.2f} mm2 ({100 * t['thin_fraction']:.1f} % of features) narrower than "
                f"the {t['nozzle_mm']:g} mm nozzle at {t['level_mm']:.2f} mm; narrow grooves {t['narrow_gap_area_mm2']:.2f} mm2"
            )
        if self.png:
            lines.append(f"picture       {self.png}")
        lines += [f"note          {n}" for n in self.notes]
        return "\n".join(lines)


# ---------------------------------------------------------------------------------
# Checking
# ---------------------------------------------------------------------------------
#: Chord (mm) and angle (radians) a STEP part is tessellated at to be checked (the
#: angle as CAD viewers take it), without OCCT's angle check inside the faces
#: (``refine=False``): a textured face's degree-1 B-spline tiles kink at every knot,
#: and refined by angle a 40 x 30 mm knurled plate's STEP took minutes; by distance
#: alone the demo plate's STEP meshes in seconds within 0.05 % of its mesh's volume
#: (meshed on the knots alone, 1 % low). CAD parts' faces mesh the same either way.
#: The chord is texcad's default tolerance.
STEP_CHORD = 0.02
STEP_ANGLE = 0.5


def _items(part: Any, exact: "dict | None" = None) -> tuple[str, list[tuple[str, Mesh]], Heightmap | None]:
    """``(source, [(name, mesh)], heightmap)`` of what check() is given; for a STEP
    part ``exact["volume"]`` is set to its B-rep's own volume, mm^3 (:func:`texcad.brep.volume`:
    OCCT's tessellation here, at :data:`STEP_CHORD` / :data:`STEP_ANGLE`, is a few
    tenths of a percent short on curved faces), where it holds a solid."""
    if isinstance(part, (str, os.PathLike)) and os.fspath(part).lower().endswith((".step", ".stp")):
        from ..brep import closed_shape_mesh, solids_of, to_topods, volume
        from ..io import read_step

        shape = read_step(part)
        mesh = closed_shape_mesh(shape, tolerance=STEP_CHORD, angular_tolerance=STEP_ANGLE, refine=False)
        if exact is not None and solids_of(to_topods(shape)):
            exact["volume"] = float(volume(shape))
        elif exact is not None:
            exact["surface"] = True
        return os.fspath(part), [(os.path.splitext(os.path.basename(part))[0], mesh)], None
    if isinstance(part, (str, os.PathLike)):
        return os.fspath(part), read_part(part), None
    if isinstance(part, Mesh):
        return "<mesh>", [("part", part)], None
    if hasattr(part, "texture") and hasattr(part, "base") and isinstance(getattr(part, "texture"), Mesh):
        return "<part>", [("base", part.base), ("texture", part.texture)], getattr(part, "heightmap", None)
    try:
        items = [(str(n), m) for n, m in part]
    except (TypeError, ValueError):
        items = []
    if not items or not all(isinstance(m, Mesh) for _, m in items):
        raise ParameterError(
            f"check() takes a .stl/.3mf path, a Mesh, a TexturedPart or a list of (name, Mesh); got {type(part).__name__}"
        )
    return "<meshes>", items, None


def _textured_items(part: Any) -> tuple[str, list[tuple[str, Mesh]], Heightmap | None]:
    """A texture() result: the fused mesh it prints from (an assembly's: all its
    bodies as printed, their union where they meet). Its texture faces are those on
    the texture's surface and not on the base's (re-uniting the two touching bodies
    would only add rounding slivers along their contact)."""
    printed = getattr(part, "printed_mesh", None)
    return "<textured part>", [("part", part.mesh if printed is None else printed)], part.heightmap


def _is_textured(part: Any) -> bool:
    """A :func:`texcad.texture` result (fused mesh plus base and texture meshes)."""
    if isinstance(part, (str, os.PathLike, Mesh, list, tuple)):
        return False
    return all(hasattr(type(part), a) for a in ("mesh", "texture_mesh", "base_mesh"))


def _is_texture(name: str) -> bool:
    return name.strip().lower().startswith("texture")


def _manifolds(meshes: list[Mesh]) -> tuple[list, np.ndarray]:
    """One ``manifold3d.Manifold`` per mesh (None where manifold3d refuses it: not a
    closed oriented 2-manifold, or empty), each tagged with a fresh original ID (its triangles' provenance
    in a union), and those IDs."""
    import manifold3d as m3d

    first = int(m3d.Manifold.reserve_ids(len(meshes)))
    ids = np.arange(first, first + len(meshes), dtype=np.int64)
    out = []
    for m, oid in zip(meshes, ids):  # per object
        if m.num_triangles == 0:
            out.append(None)
            continue
        try:
            man = m3d.Manifold(
                m3d.Mesh(
                    vert_properties=np.ascontiguousarray(m.vertices, dtype=np.float32),
                    tri_verts=np.ascontiguousarray(m.faces, dtype=np.uint32),
                    run_index=np.array([0, 3 * m.num_triangles], dtype=np.uint32),
                    run_original_id=np.array([oid], dtype=np.uint32),
                )
            )
        except Exception:  # noqa: BLE001 - any refusal means "not a manifold solid"
            man = None
        out.append(man if man is not None and man.status() == m3d.Error.NoError else None)
    return out, ids


def _closed_manifold(mesh: Mesh) -> bool:
    """What manifold3d requires of a mesh: finite vertices, and every directed edge
    used once with its reverse used once (:func:`texcad.solid.closed_and_oriented`,
    one sort; a triangle repeating a vertex has an edge with no reverse). manifold3d's
    own constructor takes 25 s of CPU on a 5.5 M-triangle part, this 1 s."""
    return bool(len(mesh.faces)) and bool(np.all(np.isfinite(mesh.vertices))) and closed_and_oriented(mesh.faces, len(mesh.vertices))


def _union_with_provenance(mans: list, ids: np.ndarray):
    """Unite manifolds (from :func:`_manifolds`); returns (mesh, per-face object index)."""
    import manifold3d as m3d

    result = m3d.Manifold.batch_boolean(mans, m3d.OpType.Add)
    if result.status() != m3d.Error.NoError or result.is_empty():
        return None, None
    gl = result.to_mesh()
    mesh = Mesh(np.array(np.asarray(gl.vert_properties)[:, :3], dtype=np.float32), np.array(gl.tri_verts, dtype=np.uint32))
    mesh.__dict__["is_watertight"] = True  # manifold3d output is an oriented closed manifold
    run_index = np.asarray(gl.run_index, dtype=np.int64) // 3
    run_ids = np.asarray(gl.run_original_id, dtype=np.int64)
    owner_of_run = np.full(len(run_ids), -1, dtype=np.int64)
    for k, oid in enumerate(ids):  # per object
        owner_of_run[run_ids == oid] = k
    owner = np.repeat(owner_of_run, np.diff(run_index))
    return mesh, owner


def _on_surface(points: np.ndarray, meshes: Sequence[Mesh], tol: float | None = None) -> np.ndarray:
    """Which ``points`` ``(P, 3)`` (mm) lie on a triangle of ``meshes`` (within ``tol`` mm).

    Exact point-on-triangle tests (plane distance and barycentric coordinates) on
    candidate pairs from a uniform grid: every triangle is entered in the cells its
    bounding box (grown by ``tol``) meets, every point looked up in its own cell
    (cells about twice the median triangle, doubled while the entries would exceed a
    budget). Work is chunked to a few million pairs at a time.

    Returns:
        ``(P,)`` bool.
    """
    pts = np.asarray(points, dtype=np.float64)
    out = np.zeros(len(pts), dtype=bool)
    tris = [m.vertices.astype(np.float64)[m.faces.astype(np.int64)] for m in meshes if m.num_triangles]
    if not len(pts) or not tris:
        return out
    tri = np.concatenate(tris)
    if tol is None:
        span = np.ptp(np.concatenate([tri.reshape(-1, 3), pts]), axis=0)
        tol = max(1e-5, 2e-6 * float(np.linalg.norm(span)))
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    n = np.cross(e1, e2)
    ln = np.linalg.norm(n, axis=1)
    keep = ln > 1e-12
    a, e1, e2, n = a[keep], e1[keep], e2[keep], n[keep] / ln[keep, None]
    lo = np.minimum(a, np.minimum(a + e1, a + e2)) - tol
    hi = np.maximum(a, np.maximum(a + e1, a + e2)) + tol
    geo = (a, e1, e2, n, (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1))
    for t, p in _grid_pairs(lo, hi, pts):  # per chunk of candidate pairs
        out[p[_holds(geo, t, pts[p], tol)]] = True
    return out


def _grid_pairs(lo: np.ndarray, hi: np.ndarray, pts: np.ndarray, budget: int = 4_000_000):
    """Chunks ``(triangles, points)`` of candidate pairs: a point and a triangle whose
    box ``lo..hi`` meets the point's grid cell and holds the point."""
    origin = np.minimum(lo.min(axis=0), pts.min(axis=0))
    cell = max(2.0 * float(np.median((hi - lo).max(axis=1))), 1e-9)
    while True:  # coarser cells while huge triangles would enter too many
        c0 = np.floor((lo - origin) / cell).astype(np.int64)
        c1 = np.floor((hi - origin) / cell).astype(np.int64)
        ncell = (c1 - c0 + 1).prod(axis=1)
        if ncell.sum() <= 8 * len(lo) + budget:
            break
        cell *= 2.0
    dim = np.maximum(c1.max(axis=0), np.floor((pts.max(axis=0) - origin) / cell).astype(np.int64)) + 1
    owner, ix, iy, iz = box_cells(c0, c1)
    key = ix + dim[0] * (iy + dim[1] * iz)
    order = np.argsort(key, kind="stable")
    key, owner = key[order], owner[order]
    pc = np.floor((pts - origin) / cell).astype(np.int64)
    pkey = pc[:, 0] + dim[0] * (pc[:, 1] + dim[1] * pc[:, 2])
    start, stop = np.searchsorted(key, pkey, side="left"), np.searchsorted(key, pkey, side="right")
    cnt = stop - start
    csum = np.cumsum(cnt)
    first = 0
    while first < len(pts):  # per chunk of points
        base = csum[first - 1] if first else 0
        last = min(len(pts), max(first + 1, int(np.searchsorted(csum, base + budget, side="right"))))
        c = cnt[first:last]
        total = int(c.sum())
        if total:
            p = np.repeat(np.arange(first, last), c)
            t = owner[np.repeat(start[first:last], c) + np.arange(total) - np.repeat(np.cumsum(c) - c, c)]
            inbox = np.all((pts[p] >= lo[t]) & (pts[p] <= hi[t]), axis=1)
            yield t[inbox], p[inbox]
        first = last


def _holds(geo, t: np.ndarray, q: np.ndarray, tol: float) -> np.ndarray:
    """``(K,)`` bool: point ``q[k]`` lies on triangle ``t[k]`` within ``tol`` mm."""
    a, e1, e2, n, d00, d01, d11 = geo
    w = q - a[t]
    near = np.abs((w * n[t]).sum(1)) <= tol
    out = np.zeros(len(t), dtype=bool)
    t, w = t[near], w[near]
    d20, d21 = (w * e1[t]).sum(1), (w * e2[t]).sum(1)
    den = d00[t] * d11[t] - d01[t] * d01[t]
    v = (d11[t] * d20 - d01[t] * d21) / den
    u = (d00[t] * d21 - d01[t] * d20) / den
    eps = tol / np.sqrt(np.maximum(d00[t], d11[t]))  # tol in mm, as a fraction
    out[np.flatnonzero(near)] = (v >= -eps) & (u >= -eps) & (u + v <= 1.0 + eps)
    return out


def _texture_faces(fused: Mesh, texture: Mesh, base: Mesh) -> np.ndarray:
    """``(M,)`` bool: the faces of a fused part that belong to its texture.

    A face shared with the texture mesh and not with the base mesh is texture; the
    few faces the union re-triangulated (along the contact) are decided by where
    they lie: on the texture's surface and not on the base's.
    """
    on_tex, on_base = shared_faces(fused, texture, base)
    mask = on_tex & ~on_base
    rest = np.flatnonzero(~on_tex & ~on_base)
    if len(rest):
        cen = fused.vertices[fused.faces[rest]].astype(np.float64).mean(axis=1)
        mask[rest] = _on_surface(cen, [texture]) & ~_on_surface(cen, [base])
    return mask


def check(
    part: Any,
    *,
    build_dir=(0.0, 0.0, 1.0),
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    nozzle: float | None = None,
    heightmap: Heightmap | None = None,
    png: str | os.PathLike | None = None,
    plate_tolerance: float = 0.01,
    png_width: int = 900,
) -> CheckReport:
    """Check a part for printing (module docstring lists what is measured).

    Args:
        part: ``.stl`` / ``.3mf`` path, a :class:`~texcad.solid.Mesh` (its
            ``"texture"`` group, if any, is the textured surface), a
            :class:`~texcad.pipeline.TexturedPart` (base and texture slab), a
            :func:`texcad.texture` result (its fused mesh; texture faces found on its
            texture mesh), or a list of ``(name, Mesh)`` (names starting with
            ``texture`` are texture).
        build_dir: build direction ``(x, y, z)`` in the part's frame (any length;
            default +z, the part as placed); see :func:`texcad.printability.orientation`.
        critical_angle: critical overhang angle in degrees between face and build
            plate (0..90, default 45; paper, section 2.1.3).
        nozzle: nozzle width in mm to look for thin texture features (None: skip).
            Uses ``heightmap`` if given, else the texture faces rasterised along
            their mean normal (flat textures), else nothing (noted).
        heightmap: the texture's heightmap, for the thin-feature check.
        png: write a picture (print orientation, seen from above and from below;
            overhangs red, texture sand, rest grey).
        plate_tolerance: mm; faces this close to the lowest point along the build
            direction lie on the build plate and are not overhangs.
        png_width: width of the picture in pixels.

    Returns:
        :class:`CheckReport`.

    Raises:
        InputError: unreadable file.
        ParameterError: bad direction, angle or nozzle.
    """
    d = build_directions(build_dir)[0]
    crit = check_critical_angle(critical_angle)
    if nozzle is not None and not (np.isfinite(float(nozzle)) and float(nozzle) > 0):
        raise ParameterError(f"nozzle must be a positive width in mm (e.g. 0.4), got {nozzle!r}")
    textured_part = _is_textured(part)
    exact: dict = {}
    source, items, hm_from_part = _textured_items(part) if textured_part else _items(part, exact)
    heightmap = heightmap if heightmap is not None else hm_from_part
    notes: list[str] = []
    with ThreadPoolExecutor(min(2, threads())) as pool, one_blas_thread():  # independent measures side by side (numpy releases the GIL)
        if len(items) == 1:  # nothing to unite: the same test as manifold3d's, vectorized (below)
            mans, ids, manif = [None], None, []
        else:
            mans, ids = _manifolds([m for _, m in items])
            manif = [man is not None for man in mans]
        if textured_part:
            mesh = items[0][1]
            texture_mask = _texture_faces(mesh, part.texture_mesh, part.base_mesh)
        else:
            mesh, texture_mask = _mesh_and_texture(items, mans, ids, manif, notes)
        over_f = pool.submit(overhang_mask, mesh, d, crit, plate_tolerance=plate_tolerance)  # the longest first
        volume_f = pool.submit(lambda: (float(mesh.volume), mesh.bounds))
        shells_f = pool.submit(shells, mesh.faces, len(mesh.vertices))
        manif = manif or [pool.submit(_closed_manifold, items[0][1]).result()]
        manif, shared = _gate_shells(items, manif, notes)
        # manifold3d accepts only closed, consistently oriented 2-manifolds (every edge
        # shared by exactly two faces, opposite ways): those are watertight; the others
        # are counted edge by edge.
        water = [ok or bool(edge_report(m.faces)["watertight"]) for ok, (_, m) in zip(manif, items)]
        over = over_f.result()
        area = _areas_of(mesh, over if texture_mask is None else over | texture_mask)
        volume, (lo, hi) = volume_f.result()
    volume = _exact_volume(volume, exact.get("volume"), notes)
    if exact.get("surface"):
        notes.append("the STEP holds no solid (faces with no closed body: a surface); close or thicken it to print it")
    if shared > 0.0 and len(items) == 1:  # overlapping bodies: a slicer prints their union, not the shells' sum
        notes.append(f"volume: the bodies' union, as a slicer prints them (the shells' sum is {volume:.1f} mm3)")
        volume -= shared
    if texture_mask is None:
        notes.append("the input does not say which faces are texture (use a texcad 3MF with a 'texture' object); whole-part numbers only")
    rep = CheckReport(
        source=source,
        objects=[n for n, _ in items],
        watertight=all(water),
        manifold=all(manif),
        shells=shells_f.result(),
        volume_mm3=volume,
        bounds_mm=[lo.tolist(), hi.tolist()],
        triangles=mesh.num_triangles,
        build_dir=d.tolist(),
        critical_angle_deg=crit,
        overhang_area_mm2=float(area[over].sum()),
        overhang_faces=int(over.sum()),
        notes=notes,
    )
    if texture_mask is not None:
        rep.texture_area_mm2 = float(area[texture_mask].sum())
        rep.texture_overhang_area_mm2 = float(area[over & texture_mask].sum())
    if nozzle is not None:
        rep.nozzle_mm = float(nozzle)
        tf = _thin(mesh, texture_mask, heightmap, float(nozzle), notes)
        rep.thin_features = None if tf is None else tf.to_dict()
    if png is not None:
        render_check(mesh, d, over, texture_mask, png, width=png_width)
        rep.png = os.fspath(png)
    return rep


def _exact_volume(meshed: float, exact: "float | None", notes: list[str]) -> float:
    """A STEP part's volume: its B-rep's own, ``exact`` mm^3, where known (a note gives
    the tessellation's where it is more than 0.1 % off), else the mesh's."""
    if exact is None:
        return meshed
    if abs(meshed - exact) > 1e-3 * abs(exact):
        notes.append(f"volume: the B-rep's own; the tessellation checked here encloses {meshed:.1f} mm3 "
                     f"({100 * (meshed - exact) / exact:+.2f} %)")
    return exact


def _gate_shells(items: list, manif: list, notes: list[str]) -> tuple[list[bool], float]:
    """The gate's own shell checks, object by object (:func:`texcad.report.gate.shell_report`):
    no inside-out shell, no body in or across another; a note names each problem.
    Returns each object's verdict and the volume its bodies share, mm^3, summed."""
    out, shared = [], 0.0
    for (name, m), ok in zip(items, manif):  # per object
        rep = shell_report(m, by_position=False) if ok else None  # as the file's reader read it
        problem = rep.problem() if rep is not None else ""
        if problem:
            notes.append(f"{name}: {problem}")
        shared += rep.overlap_mm3 if rep is not None else 0.0
        out.append(ok and not problem)
    return out, shared


def _areas_of(mesh: Mesh, which: np.ndarray) -> np.ndarray:
    """``(M,)`` face areas in mm^2 (:func:`texcad.printability.face_areas`) where
    ``which`` is set, 0 elsewhere: the report sums only overhanging and texture faces
    (none, on a part without overhangs or texture objects). Each face's area is
    computed alone, so the values are those of the whole mesh's."""
    if which.all():
        return face_areas(mesh)
    area = np.zeros(len(which))
    idx = np.flatnonzero(which)
    if len(idx):
        area[idx] = face_areas(Mesh(mesh.vertices, mesh.faces[idx]))
    return area




def _mesh_and_texture(items, mans, ids, manif, notes: list[str]) -> tuple[Mesh, np.ndarray | None]:
    """The whole part as one mesh (several objects united with manifold3d, which
    records each output face's object) and its texture faces (or None: unknown)."""
    if len(items) == 1:
        mesh = items[0][1]
        if "texture" in mesh.groups:
            mask = np.zeros(mesh.num_triangles, dtype=bool)
            mask[np.asarray(mesh.groups["texture"], dtype=np.int64)] = True
            return mesh, mask
        return mesh, (np.ones(mesh.num_triangles, dtype=bool) if _is_texture(items[0][0]) else None)
    mesh, owner = (None, None)
    if all(manif):
        mesh, owner = _union_with_provenance(mans, ids)
    if mesh is None:
        notes.append("objects could not be united; whole-part numbers are for the objects side by side")
        offsets = np.cumsum([0] + [len(m.vertices) for _, m in items[:-1]])
        mesh = Mesh(
            np.concatenate([m.vertices for _, m in items]),
            np.concatenate([m.faces.astype(np.int64) + off for (_, m), off in zip(items, offsets)]),
        )
        owner = np.repeat(np.arange(len(items)), [m.num_triangles for _, m in items])
    tex_objects = [k for k, (n, _) in enumerate(items) if _is_texture(n)]
    if not tex_objects:
        return mesh, None
    mask = np.isin(owner, tex_objects)
    others = [m for k, (_, m) in enumerate(items) if k not in tex_objects]
    if others and mask.any():
        # Where the slab's buried walls (or zero-height areas) coincide with the base's
        # own surface, the union attributes the coplanar faces to either object; they
        # belong to the base (e.g. its end walls), not the texture.
        idx = np.flatnonzero(mask)
        cen = mesh.vertices[mesh.faces[idx]].astype(np.float64).mean(axis=1)
        mask[idx[_on_surface(cen, others)]] = False
    return mesh, mask


def _thin(mesh: Mesh, texture_mask, heightmap, nozzle: float, notes: list[str]) -> ThinFeatures | None:
    if heightmap is not None:
        return thin_features(heightmap, nozzle)
    if texture_mask is None or not texture_mask.any():
        notes.append("thin features need the texture: pass its heightmap or a 3MF with a 'texture' object")
        return None
    from ..printability import unit_normals
    from ..render import height_image

    idx = np.flatnonzero(texture_mask)
    n = (unit_normals(mesh)[idx] * face_areas(mesh)[idx, None]).sum(axis=0)
    if not np.linalg.norm(n) > 0:
        notes.append("thin features: the texture has no dominant direction; skipped")
        return None
    n /= np.linalg.norm(n)
    heights, mask, pitch = height_image(mesh, n, nozzle / 4.0, faces=idx)
    if mask.sum() < 4 or heights.shape[0] < 2 or heights.shape[1] < 2:
        notes.append("thin features: texture too small to measure")
        return None
    notes.append(
        "thin features measured on the texture seen along its mean normal (exact for flat textures, "
        "widths foreshortened on curved ones)"
    )
    return thin_features(Heightmap(heights.astype(np.float32), (pitch, pitch)), nozzle, mask=mask)


def render_check(
    mesh: Mesh,
    build_dir,
    overhang: np.ndarray,
    texture_mask: np.ndarray | None,
    path: str | os.PathLike,
    *,
    width: int = 900,
) -> np.ndarray:
    """Picture of a part in print orientation: from above (left) and below (right).

    The build direction points up in both views (elevation +30 and -30 degrees);
    overhang faces are red, texture faces sand, other faces grey.

    Returns:
        The ``(H, W, 3)`` image written (y-up).
    """
    from ..render import render_mesh, write_png

    d = build_directions(build_dir)[0]
    cols = np.tile(_BODY, (mesh.num_triangles, 1))
    if texture_mask is not None:
        cols[texture_mask] = _TEXTURE
    cols[overhang] = _RED
    # Horizontal reference: the part's y axis (or x) seen from 35 degrees aside.
    ref = np.array([0.0, -1.0, 0.0]) if abs(d[1]) < 0.95 else np.array([-1.0, 0.0, 0.0])
    h = ref - (ref @ d) * d
    h /= np.linalg.norm(h)
    side = np.cross(d, h)
    az, el = np.radians(35.0), np.radians(30.0)
    hz = np.cos(az) * h + np.sin(az) * side
    half = max(1, width // 2)
    panels = []
    for sign in (1.0, -1.0):  # from above, from below
        eye = np.cos(el) * hz + sign * np.sin(el) * d
        panels.append(render_mesh(mesh, face_colors=cols, view=-eye, up=d, width=half, height=int(half * 0.8), supersample=2))
    img = np.concatenate(panels, axis=1)
    write_png(path, img)
    return img
