"""Do the bodies of a closed mesh overlap or touch? (:func:`overlapping_bodies`), and
their union (:func:`union_bodies`), with manifold3d.

A downloaded STL often holds several closed shells. Some are separate bodies, some are
the walls of cavities, and some overlap or touch: two boxes pushed into each other, a
body stacked on another on one footprint, a cavity that reaches the outer wall. Such a
mesh encloses no well-defined solid; displacing it gives an inside-out shell. Crossing
surfaces (:func:`texcad.solid.self_intersections`) miss crossings that fall on triangle
edges and coplanar overlaps, so the test here compares volumes, which sees them all:

1. *shells*: the faces connected through shared edges, each with its signed volume
   ``sum det(a, b, c) / 6`` mm3 (the mesh is wound as :func:`texcad.solid.repair_closed`
   leaves it: outward, cavity walls inward);
2. *bodies*: each outward shell is a body; an inward shell (a cavity's wall) belongs to
   the smallest body whose box holds it and which holds all of it
   (``vol(P + C) = vol(P)``) without touching it (``P - C`` keeps two shells);
   an inward shell that no body holds is a body of its own (an overlap, read inside
   out);
3. *pairs*: bodies whose boxes meet (broad phase, vectorized) are united with
   manifold3d; they overlap when ``vol(A) + vol(B) - vol(A + B)`` exceeds a relative
   1e-6 of the smaller, and touch when their gap (``Manifold.min_gap``) is below
   1e-6 of the part's size or :data:`CONTACT_GAP` (1 um), whichever is larger: CAD
   programs export bodies stacked on one another with their shared face a few tenths
   of a micrometre apart, and a raised texture then pushes the two faces into each
   other.

Before the union, a body within :data:`CONTACT_GAP` of another is moved onto it where
the two are that close (its vertices there snapped to the closest points of the other
body's surface, libigl's AABB tree), so that manifold3d, which unites bodies that touch
exactly, makes one body of them.

Volumes in mm3, lengths in mm.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .mesh import edge_slot_pairs

__all__ = ["Overlap", "BodySplit", "split_bodies", "overlapping_bodies", "union_bodies", "describe_overlaps",
           "volume_inside", "union_volume", "body_owners", "close_bodies"]

#: Relative volume tolerance of the overlap test (of the smaller body's volume).
REL_VOLUME = 1e-6
#: Relative gap (of the part's largest extent) below which two bodies touch.
REL_GAP = 1e-6
#: Absolute gap (mm) below which two bodies touch, whatever the part's size.
CONTACT_GAP = 1e-3


@dataclass(frozen=True)
class Overlap:
    """Two bodies that overlap or touch.

    Attributes:
        a, b: body numbers (0-based, in the order of their first face), ``a < b``.
        volume: the volume they share, mm3 (0 when they only touch).
        kind: ``"overlap"`` (they share volume), ``"touch"`` (they meet along a face,
            an edge or a point) or ``"cavity"`` (``b`` is a cavity wall that touches
            or leaves body ``a``).
    """

    a: int
    b: int
    volume: float
    kind: str


@dataclass(frozen=True)
class BodySplit:
    """The bodies of a closed mesh (module docstring, steps 1-2).

    Attributes:
        shell: ``(M,)`` int64 shell of each face.
        body: ``(S,)`` int64 body of each shell.
        signed: ``(S,)`` float64 signed volume of each shell, mm3.
        volumes: ``(B,)`` float64 volume of each body (its cavities taken out), mm3.
        solids: the bodies as manifold3d Manifolds (outward, cavities inward).
        cavity_faults: ``(body, shell)`` pairs: an inward shell inside ``body`` that
            touches its wall.
    """

    shell: np.ndarray
    body: np.ndarray
    signed: np.ndarray
    volumes: np.ndarray
    solids: tuple
    cavity_faults: tuple


def _shell_labels(faces: np.ndarray) -> np.ndarray:
    """``(M,)`` shell of each face: faces joined through shared edges (a closed,
    edge-manifold mesh), numbered in the order of their first face."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = len(faces)
    slot = edge_slot_pairs(faces)
    if slot is None:  # not edge-manifold: join through shared vertices instead
        f = faces.astype(np.int64)
        rows, cols = np.r_[f[:, 0], f[:, 1]], np.r_[f[:, 1], f[:, 2]]
        n = int(f.max()) + 1
        _, lab = connected_components(coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n)), directed=False)
        lab = lab[f[:, 0]]
    else:
        tri = slot // 3
        _, lab = connected_components(coo_matrix((np.ones(len(tri)), (tri[:, 0], tri[:, 1])), shape=(m, m)), directed=False)
    first = np.full(int(lab.max()) + 1, m, dtype=np.int64)
    np.minimum.at(first, lab, np.arange(m))
    rank = np.empty(len(first), dtype=np.int64)
    rank[np.argsort(first)] = np.arange(len(first))
    return rank[lab]



def _shell_volumes(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle's shell ``(M,)`` and each shell's signed volume ``(S,)`` mm^3
    (``sum det(a, b, c) / 6``)."""
    label = _shell_labels(f)
    p = v[f]
    return label, np.bincount(label, weights=np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])) / 6.0)


#: A shell enclosing less than this (mm^3) is a speck: debris a mesh tool left (a
#: PrusaSlicer 3MF of dice holds tetrahedra 30 nm across), nothing a printer makes.
SPECK = 1e-6

def _manifold(v: np.ndarray, f: np.ndarray):
    """A manifold3d Manifold of the faces ``f`` ``(K, 3)`` of ``v`` (their own vertices)."""
    import manifold3d as m3d

    used, local = np.unique(f, return_inverse=True)
    mesh = m3d.Mesh(vert_properties=np.ascontiguousarray(v[used], dtype=np.float32),
                    tri_verts=np.ascontiguousarray(local.reshape(-1, 3), dtype=np.uint32))
    return m3d.Manifold(mesh)


def split_bodies(vertices: np.ndarray, faces: np.ndarray) -> BodySplit:
    """The bodies of a closed, consistently wound mesh (module docstring, steps 1-2).

    Args:
        vertices: ``(N, 3)`` mm. faces: ``(M, 3)`` vertex indices, wound outward
            (cavity walls inward), as :func:`texcad.solid.repair_closed` leaves them.
    """
    import manifold3d as m3d

    v, f = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    shell = _shell_labels(f)
    ns = int(shell.max()) + 1
    p = v[f]
    det = np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2]))
    signed = np.bincount(shell, weights=det, minlength=ns) / 6.0
    lo = np.full((ns, 3), np.inf)
    hi = np.full((ns, 3), -np.inf)
    np.minimum.at(lo, shell, p.min(axis=1))
    np.maximum.at(hi, shell, p.max(axis=1))
    order = np.argsort(shell, kind="stable")
    cut = np.searchsorted(shell[order], np.arange(ns + 1))
    faces_of = [f[order[cut[s] : cut[s + 1]]] for s in range(ns)]
    # every shell as an outward solid of its own
    own = [_manifold(v, fs if signed[s] >= 0 else fs[:, ::-1]) for s, fs in enumerate(faces_of)]
    body = np.full(ns, -1, dtype=np.int64)
    outer = np.flatnonzero(signed >= 0)
    body[outer] = np.arange(len(outer))
    members: list[list[int]] = [[int(s)] for s in outer]
    faults = []
    for c in np.flatnonzero(signed < 0):  # per cavity wall: the smallest body that holds it
        vc = own[c].volume()  # manifold3d's volumes throughout: its solids can differ from the signed sums
        cands = outer[np.all((lo[outer] <= lo[c]) & (hi[outer] >= hi[c]), axis=1)]
        for s in cands[np.argsort(signed[cands])]:
            if own[s].volume() + vc - (own[s] + own[c]).volume() >= vc * (1 - REL_VOLUME):  # all of it inside
                body[c] = body[s]
                members[body[s]].append(int(c))
                if len((own[s] - own[c]).decompose()) < 2:  # it reaches the wall
                    faults.append((int(body[s]), int(c)))
                break
        else:  # held by no body: an inside-out body of its own
            body[c] = len(members)
            members.append([int(c)])
    solids, volumes = [], []
    for ms in members:  # per body: its shell with its cavities (as wound) or the lone inward shell outward
        if len(ms) == 1:
            solids.append(own[ms[0]])
        elif any(b == body[ms[0]] for b, _ in faults):  # a cavity open to the wall: the solid is the difference
            solids.append(m3d.Manifold.batch_boolean([own[s] for s in ms], m3d.OpType.Subtract))
        else:
            solids.append(_manifold(v, np.concatenate([faces_of[s] for s in ms])))
            if solids[-1].status() != m3d.Error.NoError:
                solids[-1] = m3d.Manifold.batch_boolean([own[ms[0]]] + [own[s] for s in ms[1:]], m3d.OpType.Subtract)
        volumes.append(solids[-1].volume())
    return BodySplit(shell, body, signed, np.array(volumes, dtype=np.float64), tuple(solids), tuple(faults))


def _box_pairs(lo: np.ndarray, hi: np.ndarray, gap: float) -> np.ndarray:
    """``(P, 2)`` pairs ``i < j`` of boxes ``lo``/``hi`` ``(B, 3)`` that meet (within
    ``gap`` mm): the broad phase."""
    order = np.argsort(lo[:, 0], kind="stable")  # sweep along x: each box against those starting before it ends
    lo, hi = lo[order], hi[order]
    end = np.searchsorted(lo[:, 0], hi[:, 0] + gap, side="right")
    cnt = np.maximum(end - np.arange(len(lo)) - 1, 0)
    i = np.repeat(np.arange(len(lo)), cnt)
    j = i + 1 + np.arange(int(cnt.sum())) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    ok = np.all((lo[i] <= hi[j] + gap) & (lo[j] <= hi[i] + gap), axis=1)
    a, b = order[i[ok]], order[j[ok]]
    return np.stack([np.minimum(a, b), np.maximum(a, b)], axis=1)


def overlapping_bodies(vertices: np.ndarray, faces: np.ndarray, *, split: BodySplit | None = None) -> list[Overlap]:
    """Bodies of a closed mesh that overlap or touch (module docstring).

    Args:
        vertices: ``(N, 3)`` mm. faces: ``(M, 3)``, wound as
            :func:`texcad.solid.repair_closed` leaves them.
        split: the mesh's :func:`split_bodies`, if already made.

    Returns:
        The overlapping or touching pairs, by body (empty: the bodies are apart).
    """
    v = np.asarray(vertices, np.float64)
    split = split or split_bodies(v, faces)
    out = [Overlap(b, len(split.volumes) + s, 0.0, "cavity") for b, s in split.cavity_faults]
    nb = len(split.solids)
    if nb < 2:
        return out
    boxes = np.array([s.bounding_box() for s in split.solids], dtype=np.float64)
    gap = _touch_gap(v)
    for a, b in _box_pairs(boxes[:, :3], boxes[:, 3:], gap):  # per pair whose boxes meet
        sa, sb = split.solids[a], split.solids[b]
        shared = split.volumes[a] + split.volumes[b] - (sa + sb).volume()
        if shared > REL_VOLUME * min(split.volumes[a], split.volumes[b]):
            out.append(Overlap(int(a), int(b), float(shared), "overlap"))
        elif sa.min_gap(sb, 2 * gap) <= gap:
            out.append(Overlap(int(a), int(b), 0.0, "touch"))
    return out


def describe_overlaps(found: list[Overlap], split: BodySplit) -> str:
    """One sentence naming the first pairs (body numbers 1-based, volumes mm3)."""
    def name(k: int) -> str:
        if k >= len(split.volumes):
            return f"a cavity wall ({-split.signed[k - len(split.volumes)]:.1f} mm3)"
        return f"body {k + 1} ({split.volumes[k]:.1f} mm3)"

    parts = []
    for o in found[:3]:
        if o.kind == "overlap":
            parts.append(f"{name(o.a)} and {name(o.b)} overlap by {o.volume:.1f} mm3")
        elif o.kind == "touch":
            parts.append(f"{name(o.a)} and {name(o.b)} touch")
        else:
            parts.append(f"{name(o.b)} in {name(o.a)} touches its wall")
    more = f" (and {len(found) - 3} more pairs)" if len(found) > 3 else ""
    return "; ".join(parts) + more


#: mm^3: a void a union leaves enclosing less is a gap of micrometres between walls that
#: nearly touched (a 0.1 mm cube's worth; the heat sink assembly's: 7-22 um x 1.55 x 0.1 mm,
#: about 3e-6 mm^3 each), nothing a printer makes: filled.
VOID = 1e-3


def _without_union_slivers(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, int, int]:
    """``(faces without the slivers, how many there were, how many bodies are left)``:
    the shells that enclose less than :data:`SPECK` mm^3, and the
    voids under :data:`VOID` mm^3. manifold3d's union of bodies whose walls touch or
    nearly touch leaves them where the walls met (50 voids of about 3e-6 mm^3 on a
    heat sink competition assembly STEP's nine solids), each counted a body of the
    STL. A cavity of a printable size stays."""
    shell, vol = _shell_volumes(v, f)
    sliver = (np.abs(vol) < SPECK) | ((vol < 0) & (-vol < VOID))
    return f[~sliver[shell]], int(sliver.sum()), int(np.sum(vol >= SPECK))


def union_bodies(vertices: np.ndarray, faces: np.ndarray, *, split: BodySplit | None = None) -> tuple[np.ndarray, np.ndarray, str]:
    """The union of a mesh's bodies (manifold3d ``batch_boolean``): one closed,
    non-overlapping mesh. Crossings inside one shell are not undone (a boolean
    takes each operand as a valid solid).

    Returns:
        ``(vertices (N, 3) float64 mm, faces (M, 3) int64, note)``: the note says
        what was united (bodies before and after, volume shared, mm3).
    """
    import manifold3d as m3d

    v = np.asarray(vertices, np.float64)
    split = split or split_bodies(v, faces)
    solids = _closed_gaps(split.solids, _touch_gap(v))
    u = m3d.Manifold.batch_boolean(solids, m3d.OpType.Add) if len(solids) > 1 else solids[0]
    out = u.to_mesh()
    uv = np.asarray(out.vert_properties, dtype=np.float64)[:, :3]
    uf, dropped, after = _without_union_slivers(uv, np.asarray(out.tri_verts, dtype=np.int64))
    if dropped:  # their points go too
        used, inv = np.unique(uf, return_inverse=True)
        uv, uf = uv[used], inv.reshape(-1, 3)
    shared = float(split.volumes.sum() - u.volume())
    specks = f", {dropped} slivers or voids of micrometres where their walls met left out" if dropped else ""
    note = (f"united {len(split.solids)} bodies into {after} ({shared:.1f} mm3 shared; "
            f"volume {u.volume():.1f} mm3{specks})")
    return uv, uf, note


def _solids_of(meshes) -> list:
    """manifold3d Manifolds of closed :class:`~texcad.solid.Mesh` es (checked: a mesh
    manifold3d refuses raises GeometryError, :func:`texcad.solid.to_manifold`)."""
    from .boolean import to_manifold

    return [to_manifold(m) for m in meshes]


def union_volume(meshes) -> float:
    """mm3 enclosed by the union of the closed meshes ``meshes`` (manifold3d), 0 for none."""
    import manifold3d as m3d

    solids = _solids_of(meshes)
    if not solids:
        return 0.0
    return float((m3d.Manifold.batch_boolean(solids, m3d.OpType.Add) if len(solids) > 1 else solids[0]).volume())


def volume_inside(body, others) -> float:
    """mm3 of the closed mesh ``body`` that lies inside the union of the closed meshes
    ``others`` (manifold3d ``body ^ (o1 + o2 + ...)``); 0 where their boxes do not meet
    (no boolean is made then)."""
    import manifold3d as m3d

    lo, hi = np.asarray(body.vertices, np.float64).min(axis=0), np.asarray(body.vertices, np.float64).max(axis=0)
    near = [o for o in others if len(o.vertices) and np.all(np.asarray(o.vertices, np.float64).min(axis=0) <= hi)
            and np.all(np.asarray(o.vertices, np.float64).max(axis=0) >= lo)]  # per other body: its box
    if not near:
        return 0.0
    solids = _solids_of(near)
    union = m3d.Manifold.batch_boolean(solids, m3d.OpType.Add) if len(solids) > 1 else solids[0]
    return float((_solids_of([body])[0] ^ union).volume())


def body_owners(vertices: np.ndarray, faces: np.ndarray, groups, *, split: "BodySplit | None" = None) -> tuple[BodySplit, np.ndarray]:
    """Which group of closed meshes (``groups``: a list of lists of meshes, e.g. a
    3MF's build items) each body of the closed mesh ``(vertices, faces)`` grew from:
    the group it shares the most volume with (manifold3d ``body ^ mesh``, only where
    their boxes meet).

    Returns:
        ``(split, owner)``: the bodies (:func:`split_bodies`) and ``(B,)`` int64 the
        group of each body, -1 where it shares no volume with any group, -2 where it
        shares more than 1e-6 of its volume with two groups (they were united).
    """
    v = np.asarray(vertices, np.float64)
    split = split or split_bodies(v, faces)
    shared = np.zeros((len(split.solids), len(groups)))
    for g, meshes in enumerate(groups):  # per group: its bodies against the ones whose boxes meet theirs
        for m in meshes:  # per mesh of the group
            lo, hi = np.asarray(m.vertices, np.float64).min(axis=0), np.asarray(m.vertices, np.float64).max(axis=0)
            man = None
            for b, body in enumerate(split.solids):  # per body
                blo, bhi = np.asarray(body.bounding_box()[:3]), np.asarray(body.bounding_box()[3:])
                if np.all(blo <= hi) and np.all(bhi >= lo):
                    man = man if man is not None else _solids_of([m])[0]
                    shared[b, g] += (body ^ man).volume()
    owner = np.where(shared.max(axis=1) > 0, shared.argmax(axis=1), -1) if len(groups) else np.full(len(split.solids), -1)
    rel = shared / np.maximum(np.asarray([s.volume() for s in split.solids]), 1e-12)[:, None]
    owner[(rel > 1e-6).sum(axis=1) > 1] = -2
    return split, owner.astype(np.int64)


def close_bodies(vertices: np.ndarray, faces: np.ndarray, gap: float) -> list[tuple[int, int, float]]:
    """``(a, b, distance)`` for the bodies ``a < b`` (numbered from 0 as
    :func:`split_bodies` finds them) of the closed mesh that lie less than ``gap`` mm
    apart, their distance in mm (manifold3d ``min_gap``; boxes first)."""
    split = split_bodies(np.asarray(vertices, np.float64), faces)
    if len(split.solids) < 2:
        return []
    boxes = np.array([s.bounding_box() for s in split.solids], dtype=np.float64)
    out = []
    for a, b in _box_pairs(boxes[:, :3], boxes[:, 3:], gap):  # per pair of boxes within the gap
        d = float(split.solids[a].min_gap(split.solids[b], gap))
        if d < gap:
            out.append((int(a), int(b), d))
    return out


def _touch_gap(v: np.ndarray) -> float:
    """mm: bodies of the mesh ``v`` closer than this touch (module docstring, step 3)."""
    extent = float(np.ptp(v, axis=0).max()) if len(v) else 1.0
    return max(REL_GAP * extent, CONTACT_GAP)


def _closed_gaps(solids: tuple, gap: float) -> list:
    """The bodies, each one that lies within ``gap`` mm of an earlier one (but does
    not touch it) snapped onto it there (:func:`_snapped`)."""
    out = list(solids)
    if len(out) < 2:
        return out
    boxes = np.array([s.bounding_box() for s in out], dtype=np.float64)
    for a, b in _box_pairs(boxes[:, :3], boxes[:, 3:], gap):
        if 0.0 < out[a].min_gap(out[b], 2 * gap) <= gap:
            out[b] = _snapped(out[b], out[a], gap)
    return out


def _snapped(body, onto, gap: float):
    """``body`` (a Manifold) with its vertices that lie within ``gap`` mm of
    ``onto``'s surface moved to their closest points on it (libigl's AABB tree)."""
    import igl
    import manifold3d as m3d

    mb, mo = body.to_mesh(), onto.to_mesh()
    vb = np.asarray(mb.vert_properties, np.float64)[:, :3].copy()
    vo = np.asarray(mo.vert_properties, np.float64)[:, :3]
    d2, _, closest = igl.point_mesh_squared_distance(vb, vo, np.asarray(mo.tri_verts, np.int64))
    near = d2 <= gap * gap
    vb[near] = closest[near]
    mesh = m3d.Mesh(vert_properties=np.ascontiguousarray(vb, np.float32), tri_verts=np.asarray(mb.tri_verts, np.uint32))
    return m3d.Manifold(mesh)
