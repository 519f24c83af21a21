"""The gate: one independent check that every result passes before texcad returns or
writes it.

It reads only the output mesh and what the result must be (an :class:`Expectation`:
the base part's mesh and body count, the selected surface, the texture's height and
its integral), never the code that made the mesh, and checks:

1. **closed and oriented**: finite vertices; every directed edge ``(a, b)`` appears
   exactly once and its reverse ``(b, a)`` exactly once (what manifold3d requires of
   its input; manifold3d itself is asked as well up to :data:`MANIFOLD3D_MAX`
   triangles, where it costs a fraction of a second);
2. **shells**: each connected shell's signed volume ``V_s = sum (a . (b x c)) / 6``
   is positive (outward) unless the shell is a cavity: inside an odd number of other
   shells (ray parity), and then negative. A negative shell that is not a cavity is
   an inside-out shell; a positive shell inside another is a body inside a body;
3. **bodies**: the outer shells are as many as the base part's bodies, and with more
   than one they do not overlap (manifold3d's union of the shells encloses the sum
   of their volumes);
4. **volume**: ``V(mesh) - V(base)`` agrees with the texture's own integral
   ``sum h dA`` (raised +, engraved -) within the stated slack (the mesh tolerance
   times the area, and the curvature term); a **centred** texture's net integral is
   about 0 by design, so a relief the union lost or doubled passes that: its
   *displaced* volume ``int |t| dA`` (above and below the surface alike) is checked
   too, against what the mesh's surface encloses with the base's
   (:func:`displaced_volume`), within :data:`DISPLACED_MARGIN` of it plus the slack;
5. **reach**: no vertex lies farther than the texture's height (plus the slack) from
   the selected surface unless it lies on the base part's surface.

A violation raises :class:`~texcad.errors.GeometryError` naming the check, the
figures and the likely cause. A texture that the limits removed for the most part
(its integral, or a centred texture's displaced volume, below :data:`VANISHED` of
the nominal one) gives a
:class:`~texcad.errors.TexcadWarning` with the figures. :func:`texcad.check` runs
checks 1-3 on any file, so it can never call a file with an inside-out shell
manifold. Lengths in mm, volumes in mm^3.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ..errors import GeometryError, TexcadWarning
from ..solid import Mesh

__all__ = ["Expectation", "Displaced", "GateReport", "gate", "gate_shells", "shell_report", "ShellReport", "VANISHED",
           "MANIFOLD3D_MAX", "DISPLACED_MARGIN", "DISPLACED_MAX", "displaced_volume", "linear_abs_integral"]

#: Applied texture volume below this share of the nominal one: a TexcadWarning.
VANISHED = 0.5
#: manifold3d is asked too (check 1) up to this many triangles.
MANIFOLD3D_MAX = 300_000
#: Check 4 (centred): the mesh's displaced volume may differ from the texture's by
#: this share of it (plus the slack). Measured on stones and a diamond knurl at 0.5 mm
#: on planes, a cylinder, a sphere and a flattened patch: within 1.1 %.
DISPLACED_MARGIN = 0.25
#: Check 4 (centred) measures at most this many triangles (every k-th, weighted k).
DISPLACED_MAX = 400_000


@dataclass(frozen=True)
class Displaced:
    """What a texture displaces, above and below the surface alike (check 4 of a
    centred texture, whose net volume is about 0 by design).

    Attributes:
        volume: ``int |t| dA`` mm^3 over the textured area, ``t`` the offset (mm)
            of the part's new surface along the normal as applied.
        area: the textured area, mm^2.
        slack: the difference accepted besides :data:`DISPLACED_MARGIN` of
            ``volume`` (the lean mesh's measured error times the area), mm^3.
        nominal: ``volume`` before the overhang and curvature limits, or None.
    """

    volume: float
    area: float
    slack: float = 0.0
    nominal: Optional[float] = None


@dataclass(frozen=True)
class Expectation:
    """What a textured result must be; lengths mm, volumes mm^3.

    Attributes:
        bodies: closed bodies of the base part (outer shells).
        base: the untextured part's mesh, in the result's frame; None skips 4-5.
        selected: ``(vertices (N, 3), faces (M, 3))`` of the surface the texture was
            put on, or None (skips 5).
        height: the largest distance a texture vertex may have from ``selected``
            (the texture's height, plus its lift), mm.
        volume: the texture's integral ``sum h dA`` as applied (signed: engraved
            textures negative), or None (skips 4).
        volume_slack: the accepted difference for check 4, mm^3.
        nominal_volume: the integral before the overhang and curvature limits, or None.
        reach_slack: extra distance accepted by check 5 (ramps, chord sag), mm.
        displaced: a centred texture's :class:`Displaced`, or None (skips that part
            of check 4).
    """

    bodies: int
    base: Optional[Mesh] = None
    selected: Optional[tuple] = None
    height: float = 0.0
    volume: Optional[float] = None
    volume_slack: float = 0.0
    nominal_volume: Optional[float] = None
    reach_slack: float = 0.0
    displaced: Optional[Displaced] = None


@dataclass(frozen=True)
class ShellReport:
    """Checks 1-3 on a mesh: figures and the verdict.

    Attributes:
        closed: every directed edge once, its reverse once, finite vertices.
        open_edges, nonmanifold_edges, misoriented_edges: counts of edges that break it.
        volumes: signed volume of each shell, mm^3 (descending).
        nesting: for each shell (same order), how many other shells contain it.
        inside_out: shells with negative volume that are not cavities.
        nested_bodies: outward shells inside another shell (a body in a body).
        bodies: outer shells.
        overlap_mm3: volume shared by the outer shells (manifold3d's union against
            their sum), 0 for one body.
    """

    closed: bool
    open_edges: int
    nonmanifold_edges: int
    misoriented_edges: int
    volumes: tuple
    nesting: tuple
    inside_out: int
    nested_bodies: int
    bodies: int
    overlap_mm3: float = 0.0

    @property
    def manifold(self) -> bool:
        """A closed, oriented solid whose shells all face the right way and whose
        bodies do not overlap."""
        return self.closed and self.inside_out == 0 and self.nested_bodies == 0 and self.overlap_mm3 <= 0.0

    def problem(self) -> str:
        """What is wrong, in words with the figures ("" if nothing)."""
        if not self.closed:
            return (f"the mesh is not a closed oriented solid ({self.open_edges} open, {self.nonmanifold_edges} "
                    f"non-manifold, {self.misoriented_edges} misoriented edges)")
        vols = ", ".join(f"{v:+.1f}" for v in self.volumes[:6])
        if self.inside_out:
            return f"{self.inside_out} shell(s) face inwards without being a cavity (shell volumes {vols} mm3)"
        if self.nested_bodies:
            return f"{self.nested_bodies} body(ies) lie inside another body (shell volumes {vols} mm3)"
        if self.overlap_mm3 > 0:
            return f"its bodies overlap by {self.overlap_mm3:.3g} mm3 (shell volumes {vols} mm3)"
        return ""


@dataclass(frozen=True)
class GateReport:
    """What the gate measured; every figure the checks compared."""

    shells: ShellReport
    volume_change: Optional[float] = None
    expected_volume: Optional[float] = None
    volume_slack: Optional[float] = None
    farthest_mm: Optional[float] = None
    reach_mm: Optional[float] = None
    warnings: tuple = field(default=())
    displaced_mm3: Optional[float] = None
    expected_displaced_mm3: Optional[float] = None

    def to_dict(self) -> dict:
        s = self.shells
        return {
            "closed": s.closed, "bodies": s.bodies, "shell_volumes": list(s.volumes), "inside_out": s.inside_out,
            "overlap_mm3": s.overlap_mm3, "volume_change": self.volume_change, "expected_volume": self.expected_volume,
            "volume_slack": self.volume_slack, "farthest_mm": self.farthest_mm, "reach_mm": self.reach_mm,
            "warnings": list(self.warnings), "displaced_mm3": self.displaced_mm3,
            "expected_displaced_mm3": self.expected_displaced_mm3,
        }


# ------------------------------------------------------------------------------------------
# Checks 1-3: topology and shells
# ------------------------------------------------------------------------------------------
def _edge_counts(faces: np.ndarray, nv: int) -> tuple[int, int, int]:
    """``(open, nonmanifold, misoriented)`` edge counts of ``faces`` (vertices welded
    by position, :func:`_by_position`): each directed edge must
    appear once and its reverse once. One sort of the keys ``2 (lo nv + hi) + [a > b]``:
    closed and oriented exactly when they come in pairs ``(2u, 2u + 1)``."""
    f = faces.astype(np.int64)
    a = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    b = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    key = np.sort(2 * (np.minimum(a, b) * nv + np.maximum(a, b)) + (a > b), kind="stable")  # runs: timsort is faster here
    if len(key) % 2 == 0:
        even, odd = key[0::2], key[1::2]
        if np.all(odd - even == 1) and np.all(even & 1 == 0) and np.all(np.diff(even) > 0):
            return 0, 0, 0
    und, count = np.unique(key >> 1, return_counts=True)
    _, dcount = np.unique(key, return_counts=True)
    return int(np.count_nonzero(count == 1)), int(np.count_nonzero(count > 2)), int(np.count_nonzero(dcount > 1))


def _by_position(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """The faces with vertices at one float32 position made one (what an STL or 3MF
    reader and a slicer see: two vertices a union left apart at one point pinch the
    surface there; a needle, a face with two corners at one point, is then an open
    edge, as a file reader counts it). Equal positions (their bits) have equal 64-bit
    hashes, so when no two hashes are equal (one sort of ``N`` integers) no two
    positions are, and the faces are returned as they are; else the positions are
    compared in full."""
    p = np.ascontiguousarray(np.asarray(v, dtype=np.float32))
    if len(p) < 2:
        return f
    bits = p.view(np.uint32).reshape(-1, 3).astype(np.uint64)
    with np.errstate(over="ignore"):
        h = (bits[:, 0] * np.uint64(0x9E3779B97F4A7C15)) ^ (bits[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F)) \
            ^ (bits[:, 2] * np.uint64(0x165667B19E3779F9))
    h.sort()
    if not np.any(h[1:] == h[:-1]):
        return f
    key = p.view(np.dtype((np.void, 12))).reshape(-1)
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    if len(first) == len(key):
        return f
    return first[inv.reshape(-1)][f]  # a face with two corners at one point: an open edge


def _shell_labels(faces: np.ndarray, nv: int) -> tuple[np.ndarray, int]:
    """Connected shells: per face, its shell's label (faces joined by shared
    vertices), and the number of shells."""
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    f = faces.astype(np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1]]).astype(np.int32)
    cols = np.concatenate([f[:, 1], f[:, 2]]).astype(np.int32)
    g = csr_matrix((np.ones(len(rows), dtype=np.int8), (rows, cols)), shape=(nv, nv))
    _, lab = connected_components(g, directed=False)
    face_lab = lab[f[:, 0]]
    present = np.bincount(face_lab, minlength=int(lab.max()) + 1) > 0
    remap = np.cumsum(present) - 1
    return remap[face_lab], int(present.sum())


def _signed_volumes(v: np.ndarray, f: np.ndarray, label: np.ndarray, k: int) -> np.ndarray:
    """Signed volume of each shell, ``sum a . (b x c) / 6`` over its triangles (float64,
    coordinate by coordinate: the products and sums of ``np.cross`` and the row dot
    ``np.einsum`` made, in their order: the same bits)."""
    x = np.ascontiguousarray(np.asarray(v, dtype=np.float64).T)
    t = np.ascontiguousarray(np.asarray(f).T)
    (ax, ay, az), (bx, by, bz), (cx, cy, cz) = ([np.take(x[j], t[c]) for j in range(3)] for c in range(3))
    det = ax * (by * cz - bz * cy)
    det += az * (bx * cy - by * cx)  # the order numpy's einsum adds the three
    det += ay * (bz * cx - bx * cz)
    return np.bincount(label, weights=det, minlength=k) / 6.0


def _inside_count(point: np.ndarray, tris: np.ndarray) -> int:
    """Crossings of a ray from ``point`` (a slightly skewed +z) with the triangles
    ``(T, 3, 3)`` (Moller-Trumbore, vectorized over the triangles)."""
    d = np.array([1.234e-4, 2.345e-4, 1.0])
    e1, e2 = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    pv = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    t0 = point - tris[:, 0]
    u = np.einsum("ij,ij->i", t0, pv) * inv
    q = np.cross(t0, e1)
    w = (q @ d) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    return int(np.count_nonzero(ok & (u >= 0) & (w >= 0) & (u + w <= 1) & (t > 0)))


def _nesting(v: np.ndarray, f: np.ndarray, label: np.ndarray, k: int) -> np.ndarray:
    """For each shell, how many other shells contain it (ray parity from one of its
    vertices; a loop per pair of shells, vectorized over triangles)."""
    out = np.zeros(k, dtype=np.int64)
    if k < 2:
        return out
    p = v.astype(np.float64)
    first = np.zeros(k, dtype=np.int64)
    first[label[::-1]] = np.arange(len(f))[::-1]
    by_shell = [f[label == s] for s in range(k)]  # per shell
    for s in range(k):
        q = p[f[first[s], 0]]
        for o in range(k):  # per other shell
            if o != s and _inside_count(q, p[by_shell[o]]) % 2 == 1:
                out[s] += 1
    return out


def _overlap(v: np.ndarray, f: np.ndarray, label: np.ndarray, outer: np.ndarray, vols: np.ndarray) -> float:
    """Volume shared by the outer shells: sum of their volumes minus manifold3d's
    union (cavities included with their bodies)."""
    import manifold3d as m3d

    mans = []
    for s in np.flatnonzero(outer):  # per body
        sub = f[label == s]
        used, inv = np.unique(sub, return_inverse=True)
        mesh = m3d.Mesh(vert_properties=np.ascontiguousarray(v[used], dtype=np.float32),
                        tri_verts=np.ascontiguousarray(inv.reshape(-1, 3), dtype=np.uint32))
        man = m3d.Manifold(mesh)
        if man.status() != m3d.Error.NoError:
            return 0.0
        mans.append(man)
    union = m3d.Manifold.batch_boolean(mans, m3d.OpType.Add).volume()
    total = float(sum(m.volume() for m in mans))
    diff = total - union
    return float(diff) if diff > 1e-6 * max(total, 1.0) + 1e-6 else 0.0


def shell_report(mesh: Mesh, *, by_position: bool = True) -> ShellReport:
    """Checks 1-3 on ``mesh`` (any number of bodies, cavities allowed).
    ``by_position``: vertices at one float32 position count as one, as an STL
    reader sees them (the gate, before anything is written); False for a mesh read
    from a file, whose reader has settled that already (a 3MF keeps its indices)."""
    v = np.asarray(mesh.vertices)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if len(f) == 0:
        return ShellReport(False, 0, 0, 0, (), (), 0, 0, 0)
    opened, nonman, misor = _edge_counts(_by_position(v, f) if by_position else f, len(v))
    closed = not (opened or nonman or misor) and bool(np.isfinite(v).all())
    if closed and len(f) <= MANIFOLD3D_MAX:
        import manifold3d as m3d

        man = m3d.Manifold(m3d.Mesh(vert_properties=np.ascontiguousarray(v, dtype=np.float32),
                                    tri_verts=np.ascontiguousarray(f, dtype=np.uint32)))
        closed = man.status() == m3d.Error.NoError
    label, k = _shell_labels(f, len(v))
    vols = _signed_volumes(v, f, label, k)
    nest = _nesting(v, f, label, k) if closed else np.zeros(k, dtype=np.int64)
    cavity = nest % 2 == 1
    inside_out = int(np.count_nonzero((vols < 0) & ~cavity))
    nested = int(np.count_nonzero((vols > 0) & (nest > 0)))
    outer = (vols > 0) & (nest == 0)
    overlap = _overlap(v, f, label, outer, vols) if closed and outer.sum() > 1 and not inside_out else 0.0
    order = np.argsort(-np.abs(vols), kind="stable")
    return ShellReport(closed, opened, nonman, misor, tuple(float(x) for x in vols[order]), tuple(int(x) for x in nest[order]),
                       inside_out, nested, int(outer.sum()), overlap)


# ------------------------------------------------------------------------------------------
# Check 5: reach
# ------------------------------------------------------------------------------------------
def _distances(pts: np.ndarray, v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Exact distance (mm) of each point to the triangles ``(v, f)`` (libigl's
    AABB tree: ``point_mesh_squared_distance``)."""
    import igl

    d2, _, _ = igl.point_mesh_squared_distance(
        np.ascontiguousarray(pts, dtype=np.float64), np.ascontiguousarray(v, dtype=np.float64),
        np.ascontiguousarray(f, dtype=np.int64),
    )
    return np.sqrt(d2)


def _reach(mesh: Mesh, ex: Expectation) -> tuple[float, float, int]:
    """``(farthest, allowed, count)``: the largest distance (mm) of a vertex off the
    base surface from the selected surface, what is allowed (the texture's reach,
    the slack and a margin of a quarter of the height, at least 0.05 mm), and how
    many vertices exceed it. Distances are exact point-triangle distances; a vertex
    within the margin of the base's surface is not relief. The distance to any point
    of the selected surface bounds the distance to the surface from above, and a
    vertex within the allowance there passes without an exact distance: first the
    vertex of the selected surface with the same index (a displaced mesh keeps its
    vertices' numbers), then, for the vertices still beyond the allowance, the
    nearest vertex of the selected surface within it (a kd-tree query bounded by the
    allowance)."""
    from scipy.spatial import cKDTree

    margin = max(0.25 * ex.height, 0.05)
    allowed = ex.height + ex.reach_slack + margin
    pts = np.asarray(mesh.vertices, dtype=np.float64)
    sv, sf = np.asarray(ex.selected[0], dtype=np.float64), np.asarray(ex.selected[1], dtype=np.int64)
    used = np.zeros(len(sv), dtype=bool)
    used[sf.ravel()] = True
    d_sel = np.full(len(pts), np.inf)
    same = np.flatnonzero(used[: len(pts)])
    e = pts[same] - sv[same]
    d_sel[same] = np.sqrt((e * e).sum(axis=1))  # to a point of the surface: an upper bound
    rest = np.flatnonzero(d_sel > allowed)
    if len(rest) and used.any():  # to the nearest selected vertex within the allowance: an upper bound too
        near, _ = cKDTree(sv[used]).query(pts[rest], workers=2, distance_upper_bound=allowed)
        d_sel[rest] = np.minimum(d_sel[rest], near)
    far = np.flatnonzero(d_sel > allowed)
    if len(far):  # exact distances for those
        d_sel[far] = _distances(pts[far], sv, sf)
        far = far[d_sel[far] > allowed]
    if len(far) and ex.base is not None:
        far = far[_distances(pts[far], ex.base.vertices, ex.base.faces) > margin + ex.reach_slack]
    farthest = float(d_sel[far].max()) if len(far) else float(min(d_sel.max(initial=0.0), allowed))
    return farthest, allowed, len(far)


# ------------------------------------------------------------------------------------------
# Check 4, centred: the displaced volume
# ------------------------------------------------------------------------------------------
def linear_abs_integral(values: np.ndarray, areas: np.ndarray) -> float:
    """``sum int_T |f| dA`` over triangles ``T`` of ``areas`` (mm^2) on which ``f`` is
    linear with the corner ``values`` ``(T, 3)`` (mm): exact, vectorized. With the
    corners sorted ``f1 <= f2 <= f3`` and the mean ``m``, a triangle of one sign
    gives ``A |m|``; one corner below 0 gives ``A (m + 2 (-f1)^3 / (3 (f2 - f1)
    (f3 - f1)))`` (the part below 0 is the corner's similar triangle), one corner
    above 0 the mirror image."""
    f = np.sort(np.asarray(values, np.float64), axis=1)
    f1, f2, f3 = f[:, 0], f[:, 1], f[:, 2]
    m = (f1 + f2 + f3) / 3.0
    one_below, one_above = (f1 < 0) & (f2 >= 0) & (f3 > 0), (f1 < 0) & (f2 < 0) & (f3 > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        below = np.where(one_below, (-f1) ** 3 / (3.0 * (f2 - f1) * (f3 - f1)), 0.0)
        above = np.where(one_above, f3**3 / (3.0 * (f3 - f1) * (f3 - f2)), 0.0)
    out = np.where(one_below, m + 2.0 * below, np.where(one_above, -m + 2.0 * above, np.abs(m)))
    return float(np.dot(np.asarray(areas, np.float64), out))


def displaced_volume(mesh: Mesh, base: Mesh, bound: float) -> float:
    """``int |d| dA`` mm^3: how much the surface of ``mesh`` lies off the surface of
    ``base`` (closed), above and below it alike. ``d`` is the signed distance (mm)
    of each vertex from ``base`` (libigl, pseudonormal sign; beyond ``bound`` mm it
    is ``bound``), linear over each triangle (:func:`linear_abs_integral`), whose
    area is projected on the base's normal at its corners (a wall of the relief
    adds no area of its own). At most :data:`DISPLACED_MAX` triangles are measured
    (every k-th, weighted k)."""
    import igl

    v = np.asarray(mesh.vertices, np.float64)
    f = np.asarray(mesh.faces, np.int64)
    step = -(-len(f) // DISPLACED_MAX) if len(f) else 1
    f = f[::step]
    used, inv = np.unique(f, return_inverse=True)
    inv = inv.reshape(-1, 3)
    d, _, _, nrm = igl.signed_distance(v[used], np.asarray(base.vertices, np.float64), np.asarray(base.faces, np.int64),
                                       sign_type=igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL, lower_bound=-bound, upper_bound=bound)
    nb = nrm[inv].sum(axis=1)
    nb /= np.maximum(np.linalg.norm(nb, axis=1, keepdims=True), 1e-18)
    p = v[f]
    areas = 0.5 * np.abs((np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]) * nb).sum(axis=1))
    return step * linear_abs_integral(np.clip(d[inv], -bound, bound), areas)


def _displaced(mesh: Mesh, ex: Expectation, what: str, notes: list) -> float:
    """Check 4 of a centred texture (module docstring): the mesh's displaced volume,
    or GeometryError; a TexcadWarning (in ``notes``) when the limits removed most."""
    d = ex.displaced
    got = displaced_volume(mesh, ex.base, 2.0 * ex.height + 1.0)
    if abs(got - d.volume) > DISPLACED_MARGIN * d.volume + d.slack:
        area = max(d.area, 1e-12)
        raise GeometryError(
            f"the {what} failed texcad's gate: its surface lies off the part's by {got:.2f} mm3 (a mean {got / area:.4f} mm "
            f"over the textured {d.area:.1f} mm2) where the texture displaces {d.volume:.2f} mm3 (mean |h| "
            f"{d.volume / area:.4f} mm; accepted difference {DISPLACED_MARGIN * d.volume + d.slack:.2f} mm3); a centred "
            "relief's net volume is about 0, so the relief was lost or doubled in the union: try another pitch or "
            "height, and please report this"
        )
    if d.nominal is not None and d.nominal > 0 and d.volume < VANISHED * d.nominal:
        msg = (f"the limits removed {100 * (1 - d.volume / d.nominal):.0f} % of the centred texture ({d.volume:.2f} of "
               f"{d.nominal:.2f} mm3 displaced kept): the face is too small, too curved or too steep for this texture at "
               "this height; use a smaller height, a finer texture, or another build direction")
        warnings.warn(msg, TexcadWarning, stacklevel=4)
        notes.append(msg)
    return got


# ------------------------------------------------------------------------------------------
# The gate
# ------------------------------------------------------------------------------------------
def gate_shells(mesh: Mesh, *, what: str = "result") -> ShellReport:
    """Checks 1-3 alone (a result whose body count and volume are not known ahead,
    e.g. after a CAD operation): the figures, or GeometryError."""
    sr = shell_report(mesh)
    if not sr.manifold:
        raise GeometryError(f"the {what} failed texcad's gate: {sr.problem()}; please report this")
    return sr


def gate(mesh: Mesh, ex: Expectation, *, what: str = "textured part") -> GateReport:
    """Check ``mesh`` against ``ex`` (module docstring): return the figures, or raise.

    Raises:
        GeometryError: a check failed; the message names it, the figures and the
            likely cause.
    """
    sr = shell_report(mesh)
    if not sr.manifold:
        cause = ("two bodies of the input overlap, or lie closer than the texture's height so that it pushed them into "
                 "each other, or a shell of the input faces inwards: unite the bodies first (union=True, --union), move "
                 "them further apart than the texture's height, or leave their facing faces out of the region"
                 if sr.closed else "a stage made a broken mesh; please report this")
        raise GeometryError(f"the {what} failed texcad's gate: {sr.problem()}; {cause}")
    if sr.bodies != ex.bodies:
        raise GeometryError(
            f"the {what} failed texcad's gate: it has {sr.bodies} bodies where the part has {ex.bodies} "
            f"(shell volumes {', '.join(f'{x:+.1f}' for x in sr.volumes[:6])} mm3); a relief came off the part "
            "or joined two bodies: use a smaller height or depth"
        )
    notes = []
    change = expected = slack = None
    if ex.base is not None and ex.volume is not None:
        change = float(sum(sr.volumes)) - float(_signed_volumes(ex.base.vertices, np.asarray(ex.base.faces, np.int64),
                                                                 np.zeros(len(ex.base.faces), np.int64), 1)[0])
        expected, slack = float(ex.volume), float(ex.volume_slack)
        if abs(change - expected) > slack:
            raise GeometryError(
                f"the {what} failed texcad's gate: its volume changed by {change:+.2f} mm3 where the texture's integral "
                f"is {expected:+.2f} mm3 (accepted difference {slack:.2f} mm3); the relief was lost or doubled in the "
                "union: try another pitch or height, and please report this"
            )
    if ex.nominal_volume is not None and ex.volume is not None and abs(ex.nominal_volume) > 0:
        kept = abs(ex.volume) / abs(ex.nominal_volume)
        if kept < VANISHED:
            msg = (f"the limits removed {100 * (1 - kept):.0f} % of the texture ({abs(ex.volume):.2f} of "
                   f"{abs(ex.nominal_volume):.2f} mm3 kept): the face is too small, too curved or too steep for this "
                   "texture at this height; use a smaller height, a finer texture, or another build direction")
            warnings.warn(msg, TexcadWarning, stacklevel=3)
            notes.append(msg)
    got = None
    if ex.displaced is not None and ex.base is not None:
        got = _displaced(mesh, ex, what, notes)
    farthest = reach = None
    if ex.selected is not None and ex.height > 0:
        farthest, reach, n_far = _reach(mesh, ex)
        if n_far:
            raise GeometryError(
                f"the {what} failed texcad's gate: {n_far} vertices lie up to {farthest:.3f} mm from the selected "
                f"surface, where the texture reaches {reach:.3f} mm; the relief landed off its faces: please report this"
            )
    return GateReport(sr, change, expected, slack, farthest, reach, tuple(notes), got,
                      None if ex.displaced is None else float(ex.displaced.volume))
