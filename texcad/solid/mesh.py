"""Triangle meshes of textured slabs.

A :class:`Mesh` is plain data: ``vertices`` ``(N, 3)`` float32 in mm and ``faces``
``(M, 3)`` uint32 vertex indices, counter-clockwise seen from outside (outward
normals). The builders here make closed (watertight) meshes from vertex grids:

* :func:`heightfield_slab` - the paper's flat mapping (section 2.2): one vertex per
  pixel on top, vertical side walls, a flat bottom with no interior vertices.
* :func:`grid_solid` - the general case used by the curved mappings: a top grid and
  a bottom grid of the same shape joined by walls, optionally closed in x (tubes).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Sequence

import numpy as np

from .grid import grid_faces

from ..util import argsort_ints, require_memory
from ..errors import GeometryError, ParameterError
from ..sources import Heightmap

__all__ = ["Mesh", "grid_faces", "heightfield_slab", "grid_solid", "edge_report", "closed_and_oriented", "edge_slot_pairs", "shells", "surface_slab", "heightfield_volume", "shared_faces"]


@dataclass(frozen=True, eq=False)
class Mesh:
    """A triangle mesh in mm.

    Attributes:
        vertices: ``(N, 3)`` float32 vertex positions in mm.
        faces: ``(M, 3)`` uint32 vertex indices, counter-clockwise from outside.
        groups: optional ``{name: (M_k,) face indices}``, e.g. ``{"texture": ...}``
            naming the faces that carry the texture.
    """

    vertices: np.ndarray
    faces: np.ndarray
    groups: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        v = np.ascontiguousarray(self.vertices, dtype=np.float32)
        f = np.ascontiguousarray(self.faces, dtype=np.uint32)
        if v.ndim != 2 or v.shape[1] != 3:
            raise ParameterError(f"vertices must have shape (N, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3:
            raise ParameterError(f"faces must have shape (M, 3), got {f.shape}")
        if f.size and int(f.max()) >= len(v):
            raise ParameterError(f"faces index vertex {int(f.max())} but there are only {len(v)} vertices")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)

    @property
    def num_triangles(self) -> int:
        """Number of triangles."""
        return int(len(self.faces))

    @cached_property
    def volume(self) -> float:
        """Enclosed volume in mm^3 (divergence theorem, accumulated in float64)."""
        v = self.vertices.astype(np.float64)
        a, b, c = v[self.faces[:, 0]], v[self.faces[:, 1]], v[self.faces[:, 2]]
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    @cached_property
    def bounds(self) -> np.ndarray:
        """``(2, 3)`` float64 min and max corner in mm."""
        v = self.vertices
        return np.array([v.min(axis=0), v.max(axis=0)], dtype=np.float64)

    @cached_property
    def area(self) -> float:
        """Surface area in mm^2."""
        v = self.vertices.astype(np.float64)
        a, b, c = v[self.faces[:, 0]], v[self.faces[:, 1]], v[self.faces[:, 2]]
        return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())

    @cached_property
    def is_watertight(self) -> bool:
        """True if every edge is shared by exactly two faces with opposite directions."""
        return edge_report(self.faces)["watertight"]

    def face_normals(self) -> np.ndarray:
        """``(M, 3)`` float32 unit outward face normals (zero for degenerate faces)."""
        v = self.vertices
        n = np.cross(v[self.faces[:, 1]] - v[self.faces[:, 0]], v[self.faces[:, 2]] - v[self.faces[:, 0]])
        ln = np.linalg.norm(n, axis=1, keepdims=True)
        return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)

    def translated(self, offset: Sequence[float]) -> "Mesh":
        """A copy moved by ``offset`` ``(dx, dy, dz)`` in mm."""
        return Mesh(self.vertices + np.asarray(offset, dtype=np.float32), self.faces, self.groups)

    def __repr__(self) -> str:
        lo, hi = self.bounds
        ext = " x ".join(f"{e:g}" for e in np.round(hi - lo, 3))
        return f"Mesh({len(self.vertices)} vertices, {self.num_triangles} triangles, {ext} mm)"


def edge_report(faces: np.ndarray) -> dict:
    """Count boundary and non-manifold edges of a triangle soup (vectorized).

    An edge is *manifold* when exactly two faces use it, once in each direction.

    Returns:
        ``{"edges": E, "boundary": B, "nonmanifold": N, "misoriented": O,
        "watertight": B == N == O == 0}``.
    """
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return {"edges": 0, "boundary": 0, "nonmanifold": 0, "misoriented": 0, "watertight": False}
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    n = int(f.max()) + 1
    key = directed[:, 0] * n + directed[:, 1]
    key.sort()
    dup_directed = int(np.count_nonzero(key[1:] == key[:-1]))
    und = np.sort(directed, axis=1)
    ukey = und[:, 0] * n + und[:, 1]
    _, counts = np.unique(ukey, return_counts=True)
    boundary = int(np.count_nonzero(counts == 1))
    nonmanifold = int(np.count_nonzero(counts > 2))
    return {
        "edges": int(len(counts)),
        "boundary": boundary,
        "nonmanifold": nonmanifold,
        "misoriented": dup_directed,
        "watertight": boundary == 0 and nonmanifold == 0 and dup_directed == 0,
    }


def _edge_keys(faces: np.ndarray, n: int) -> np.ndarray:
    """Sorted keys of the directed edges of ``faces`` over ``n`` vertices: the
    undirected edge ``(lo, hi)`` as ``2 (lo n + hi)``, plus 1 where it runs hi -> lo
    (one sort finds boundary, duplicated and unpaired edges alike)."""
    f = np.asarray(faces, dtype=np.int64)
    a = f.reshape(-1)
    b = f[:, [1, 2, 0]].reshape(-1)
    return np.sort(2 * (np.minimum(a, b) * n + np.maximum(a, b)) + (a > b), kind="stable")  # runs: timsort is faster


def closed_and_oriented(faces: np.ndarray, num_vertices: int) -> bool:
    """True if every directed edge of ``faces`` appears once and its reverse once
    (one sort of the edge keys)."""
    k = _edge_keys(faces, int(num_vertices))
    if len(k) == 0 or len(k) % 2:
        return False
    first, second = k[0::2], k[1::2]
    return bool((first % 2 == 0).all() and (second == first + 1).all() and (first[1:] > second[:-1]).all())


def edge_slot_pairs(faces: np.ndarray) -> "np.ndarray | None":
    """``(E, 2)``: for each undirected edge of ``faces`` ``(M, 3)`` its two *slots*
    ``3 face + k`` (slot ``k`` runs from corner ``k`` to ``k + 1``), edges in the order
    of their keys; None unless every edge belongs to exactly two slots (closed and
    manifold; :func:`edge_report` counts what is wrong)."""
    f = np.asarray(faces, dtype=np.int64)
    if not f.size:
        return None
    n = int(f.max()) + 1
    a, b = f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)
    key = np.minimum(a, b) * n + np.maximum(a, b)
    order = argsort_ints(key)
    k = key[order]
    if len(k) % 2 or np.any(k[0::2] != k[1::2]) or np.any(k[2::2] == k[1:-1:2]):
        return None
    return order.reshape(-1, 2)


def shells(faces: np.ndarray, num_vertices: int) -> int:
    """Connected pieces of the surface ``faces`` ``(M, 3)`` (through shared vertices;
    vertices no face uses do not count)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return 0
    n = int(num_vertices)
    g = coo_matrix((np.ones(2 * len(f), dtype=np.int8), (np.r_[f[:, 0], f[:, 1]], np.r_[f[:, 1], f[:, 2]])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    return int(np.count_nonzero(np.bincount(lab[f[:, 0]])))  # components that own a face


def _ring(rows: int, cols: int) -> np.ndarray:
    """Indices of a grid's boundary vertices, counter-clockwise from (0, 0)."""
    idx = np.arange(rows * cols, dtype=np.uint32).reshape(rows, cols)
    return np.concatenate([idx[0, :], idx[1:, -1], idx[-1, -2::-1], idx[-2:0:-1, 0]])


def heightfield_slab(
    heightmap: Heightmap,
    *,
    depth: float = 0.5,
    origin: Sequence[float] = (0.0, 0.0, 0.0),
    tolerance: float = 0.0,
    lean: "tuple[np.ndarray, np.ndarray] | None" = None,
) -> Mesh:
    """The paper's flat mapping (section 2.2) as a closed slab.

    One vertex per pixel: vertex ``(r, c)`` sits at ``origin + ((c + 1/2) px,
    (r + 1/2) py, h[r, c])`` in mm. Each side of the top grid is closed by a vertical
    wall down to a flat bottom at ``z = origin_z - depth``. A wall is one planar
    polygon, the side's row (or column) of top vertices plus the two bottom corners
    below its ends, triangulated as such; the bottom is a rectangle of two triangles.
    So the slab adds only four vertices to its top surface, and only a few of its
    edges cross the base body's face at ``z = origin_z``: the union with the base
    (:func:`texcad.solid.fuse`) has little to cut and nothing to re-triangulate but
    a handful of faces. The top faces are named ``"texture"`` in ``Mesh.groups``.

    Where a wall polygon would be degenerate (a boundary height reaches down to the
    bottom, e.g. heights of ``-depth`` mm), the walls are instead quads from every
    boundary vertex down to a bottom ring below it.

    Args:
        heightmap: the texture.
        depth: how far in mm the slab reaches below the surface (into the base body,
            so that the union with the base is one solid). > 0.
        origin: ``(x, y, z)`` in mm of the surface point under the texture's corner.
        tolerance: largest height error in mm of the top surface at any pixel centre.
            0 (default here): one vertex per pixel, as above. > 0: a lean top
            surface (:func:`texcad.solid.lean.triangulate`): only the pixel centres
            needed to stay within ``tolerance`` mm, at their exact heights; the walls
            are built on the boundary vertices it keeps, so the slab stays
            watertight; where that would keep more than half of the grid's
            triangles (:data:`texcad.solid.lean.MAX_FRACTION`: noisy textures), the grid
            is used. Measure the result with :func:`texcad.solid.lean.mesh_error`.
        lean: with ``tolerance`` > 0, a lean top already made, ``(rc, faces)`` as
            :func:`texcad.solid.lean.triangulate` returns it (e.g. from
            :func:`texcad.solid.lean.tiled_triangulation`, its tiles checked).

    Returns:
        A watertight :class:`Mesh` with ``R C + 4`` vertices and
        ``2 (R-1)(C-1) + 2 (R + C) + 2`` triangles for an ``R x C`` px heightmap
        (walls on a bottom ring: ``R C + P`` vertices and ``2 (R-1)(C-1) + 3 P - 2``
        triangles, ``P = 2 (R + C) - 4``).
    """
    if not (np.isfinite(depth) and depth > 0):
        raise ParameterError(f"depth must be a positive number of mm, got {depth!r}")
    rows, cols = heightmap.shape
    require_memory(rows * cols * 60.0, f"a {rows} x {cols} px slab", "use a larger pitch")
    ox, oy, oz = (float(o) for o in origin)
    from .lean import check_tolerance

    if check_tolerance(tolerance) > 0:
        slab = _lean_slab(heightmap, depth, (ox, oy, oz), float(tolerance), lean)
        if slab is not None:
            return slab
    n = rows * cols
    verts = np.empty((n + 4, 3), dtype=np.float32)
    top = verts[:n].reshape(rows, cols, 3)
    top[..., 0] = (ox + heightmap.x).astype(np.float32)[None, :]
    top[..., 1] = (oy + heightmap.y).astype(np.float32)[:, None]
    top[..., 2] = heightmap.heights + np.float32(oz)
    top_faces = grid_faces(rows, cols)
    groups = {"texture": np.arange(len(top_faces), dtype=np.uint32)}
    zb = np.float32(oz - depth)
    walls = _polygon_walls(verts[:n], rows, cols, float(zb), depth)
    if walls is None:
        return _ring_walls_slab(verts[:n], rows, cols, zb, top_faces, groups)
    idx = np.arange(n, dtype=np.uint32).reshape(rows, cols)
    corners = [idx[0, 0], idx[0, -1], idx[-1, -1], idx[-1, 0]]  # counter-clockwise from +z
    verts[n:, :2] = verts[corners, :2]
    verts[n:, 2] = zb
    # Bottom rectangle, facing -z: clockwise seen from +z.
    bottom = np.array([[n, n + 2, n + 1], [n, n + 3, n + 2]], dtype=np.uint32)
    return Mesh(verts, np.concatenate([top_faces, walls, bottom]), groups)


def _lean_slab(heightmap: Heightmap, depth: float, origin: tuple, tolerance: float, lean=None) -> "Mesh | None":
    """:func:`heightfield_slab` with a lean top (``tolerance`` mm > 0): the kept pixel
    centres, walls on the kept boundary chains, the same bottom. None where the lean
    top would keep more than :data:`texcad.solid.lean.MAX_FRACTION` of the grid."""
    from .lean import boundary_chains, triangulate

    ox, oy, oz = origin
    rows, cols = heightmap.shape
    if lean is None:
        lean = triangulate(heightmap.heights, tolerance)
    if lean is None:
        return None
    rc, top_faces = lean
    n = len(rc)
    verts = np.empty((n + 4, 3), dtype=np.float32)
    verts[:n, 0] = (ox + heightmap.x).astype(np.float32)[rc[:, 1]]
    verts[:n, 1] = (oy + heightmap.y).astype(np.float32)[rc[:, 0]]
    verts[:n, 2] = heightmap.heights[rc[:, 0], rc[:, 1]] + np.float32(oz)
    groups = {"texture": np.arange(len(top_faces), dtype=np.uint32)}
    zb = np.float32(oz - depth)
    sides = tuple(s.astype(np.uint32) for s in boundary_chains(rc, rows, cols))
    walls = _polygon_walls(verts[:n], rows, cols, float(zb), depth, sides=sides)
    if walls is None:
        ring = np.concatenate([s[:-1] for s in sides])
        return _ring_walls_slab(verts[:n], rows, cols, zb, top_faces, groups, ring=ring)
    verts[n:, :2] = verts[[s[0] for s in sides], :2]  # the four corners, counter-clockwise
    verts[n:, 2] = zb
    bottom = np.array([[n, n + 2, n + 1], [n, n + 3, n + 2]], dtype=np.uint32)
    return Mesh(verts, np.concatenate([top_faces, walls, bottom]), groups)


def _polygon_walls(
    top: np.ndarray, rows: int, cols: int, zb: float, depth: float, sides: "tuple | None" = None
) -> "np.ndarray | None":
    """Triangles closing the four sides of a top grid down to ``z = zb`` (mm).

    Side ``k`` (counter-clockwise from +z, starting along row 0) is the planar polygon
    of its top vertices plus bottom corners ``N + k`` and ``N + (k+1) % 4`` (``N`` =
    number of top vertices), triangulated by manifold3d in the wall's plane. Returns
    ``None`` when a polygon is degenerate or its triangulation is not a valid,
    counter-clockwise (outward) cover of it. ``sides``: the four chains of top vertex
    indices (a lean top's kept boundary vertices), default the full grid's.
    """
    import manifold3d

    n = len(top)
    ring = _ring(rows, cols) if sides is None else np.concatenate([s[:-1] for s in sides])
    # A boundary vertex (almost) on the bottom would pinch its wall polygon.
    if float(top[ring, 2].min()) - zb < max(1e-3 * depth, 1e-4):
        return None
    if sides is None:
        idx = np.arange(n, dtype=np.uint32).reshape(rows, cols)
        sides = (idx[0, :], idx[:, -1], idx[-1, ::-1], idx[::-1, 0])
    out = []
    for k, chain in enumerate(sides):  # one polygon per side
        p = top[chain].astype(np.float64)
        u = np.abs(p[:, k % 2] - p[0, k % 2])  # distance along the side, increasing
        # Seen from outside, u runs to the right on every side (the ring is counter-
        # clockwise from +z): counter-clockwise = bottom left to right, then the top
        # vertices from right to left. Counter-clockwise triangles face outwards.
        poly = np.empty((len(chain) + 2, 2))
        poly[0] = (0.0, zb)
        poly[1] = (u[-1], zb)
        poly[2:, 0] = u[::-1]
        poly[2:, 1] = p[::-1, 2]
        tri = np.asarray(manifold3d.triangulate([poly]), dtype=np.int64).reshape(-1, 3)
        a, b, c = poly[tri[:, 0]], poly[tri[:, 1]], poly[tri[:, 2]]
        area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        x, y = poly[:, 0], poly[:, 1]
        poly_area2 = float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))
        if len(tri) != len(poly) - 2 or not np.all(area2 > 0) or not np.isclose(area2.sum(), poly_area2, rtol=1e-9):
            return None
        ids = np.concatenate([np.array([n + k, n + (k + 1) % 4], dtype=np.uint32), chain[::-1]])
        out.append(ids[tri])
    return np.concatenate(out)


def _ring_walls_slab(
    top: np.ndarray, rows: int, cols: int, zb: np.float32, top_faces: np.ndarray, groups: dict, ring=None
) -> Mesh:
    """A slab whose walls are quads from every boundary vertex down to a bottom ring at
    ``z = zb`` mm, and whose bottom is the ring polygon (triangulated by manifold3d).
    ``ring``: the boundary vertices counter-clockwise (default: the full grid's)."""
    import manifold3d

    n = len(top)
    ring = _ring(rows, cols) if ring is None else ring
    p = len(ring)
    verts = np.empty((n + p, 3), dtype=np.float32)
    verts[:n] = top
    verts[n:, :2] = top[ring, :2]
    verts[n:, 2] = zb
    bi = np.arange(n, n + p, dtype=np.uint32)
    t0, t1 = ring, np.roll(ring, -1)
    b0, b1 = bi, np.roll(bi, -1)
    walls = np.concatenate([np.stack([t0, b0, b1], 1), np.stack([t0, b1, t1], 1)])
    # The ring runs counter-clockwise seen from +z; the bottom faces -z, so reverse.
    tri = np.asarray(manifold3d.triangulate([verts[n:, :2].astype(np.float64)]), dtype=np.uint32)
    bottom = bi[tri[:, ::-1]]
    return Mesh(verts, np.concatenate([top_faces, walls, bottom]), groups)


def grid_solid(top: np.ndarray, bottom: np.ndarray, *, wrap_x: bool = False) -> Mesh:
    """Close the space between two vertex grids into a watertight solid.

    ``top`` is the textured surface and ``bottom`` the surface it stands on, pushed
    into the base body; both are ``(R, C, 3)`` float arrays in mm with matching
    ``(r, c)``. The grids must be oriented so that ``d(top)/dc x d(top)/dr`` (column
    direction cross row direction) points out of the solid; flip the column order
    if it points in. With ``wrap_x`` the
    grids close on themselves in x (column ``C-1`` joins column 0 on shared
    vertices: a seam gap of exactly zero) and only the two end rows get walls.

    Returns:
        Watertight :class:`Mesh`; faces of the top grid are the group ``"texture"``.
    """
    top = np.asarray(top, dtype=np.float32)
    bottom = np.asarray(bottom, dtype=np.float32)
    if top.shape != bottom.shape or top.ndim != 3 or top.shape[2] != 3:
        raise ParameterError(f"top and bottom must both be (R, C, 3); got {top.shape} and {bottom.shape}")
    rows, cols = top.shape[:2]
    if rows < 2 or cols < 2:
        raise GeometryError(f"a grid solid needs at least 2 x 2 vertices, got {rows} x {cols}")
    n = rows * cols
    verts = np.concatenate([top.reshape(-1, 3), bottom.reshape(-1, 3)])
    ftop = grid_faces(rows, cols, wrap_x=wrap_x)
    fbot = grid_faces(rows, cols, wrap_x=wrap_x, flip=True) + np.uint32(n)
    idx = np.arange(n, dtype=np.uint32).reshape(rows, cols)
    if wrap_x:
        # End walls at y = first row and y = last row (closed loops).
        # End walls at the first and last row, each a closed loop running the same
        # way as the boundary ring of an open grid.
        loops = [idx[0, :], idx[-1, ::-1]]
    else:
        loops = [_ring(rows, cols)]
    walls = []
    for loop in loops:
        loop = np.concatenate([loop, loop[:1]])
        t0, t1 = loop[:-1], loop[1:]
        b0, b1 = t0 + np.uint32(n), t1 + np.uint32(n)
        walls.append(np.stack([t0, b0, b1], 1))
        walls.append(np.stack([t0, b1, t1], 1))
    faces = np.concatenate([ftop, fbot, *walls])
    return Mesh(verts, faces, {"texture": np.arange(len(ftop), dtype=np.uint32)})


def _border(tri: np.ndarray, nv: int) -> np.ndarray:
    """Directed edges of a triangulated surface whose reverse is not in it ``(k, 2)``."""
    ed = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    und = np.minimum(ed[:, 0], ed[:, 1]) * nv + np.maximum(ed[:, 0], ed[:, 1])
    order = np.argsort(und, kind="stable")
    su = und[order]
    single = np.ones(len(su), bool)
    single[1:] &= su[1:] != su[:-1]
    single[:-1] &= su[:-1] != su[1:]
    return ed[order[single]]


def surface_slab(
    top: np.ndarray,
    bottom: np.ndarray,
    tri: np.ndarray,
    *,
    bottom_tri: np.ndarray | None = None,
    bottom_of: np.ndarray | None = None,
) -> Mesh:
    """A closed slab from a triangulated top surface and a bottom surface under it.

    Args:
        top: ``(N, 3)`` mm, the top surface's vertices.
        bottom: ``(Nb, 3)`` mm, the bottom's vertices (default: vertex ``i`` under
            top vertex ``i``, ``Nb = N``).
        tri: ``(M, 3)`` triangles of the top (an oriented surface with a boundary;
            either winding: it is turned to face along ``top - bottom``).
        bottom_tri: ``(Mb, 3)`` triangles of the bottom, wound like ``tri`` (default
            ``tri``): the bottom may be triangulated more coarsely, with the same
            boundary.
        bottom_of: ``(N,)`` the bottom vertex under each top vertex (-1: none; every
            boundary vertex needs one).

    Returns:
        The slab: the top outward, the bottom reversed, and a wall of two triangles
        on every boundary edge of the top (vertices: top then bottom).

    Raises:
        GeometryError: the bottom's boundary is not the top's.
    """
    tri = np.asarray(tri, dtype=np.int64)
    vt, vb = np.asarray(top), np.asarray(bottom)
    nv = len(vt)
    btri = tri if bottom_tri is None else np.asarray(bottom_tri, dtype=np.int64)
    under = np.arange(nv) if bottom_of is None else np.asarray(bottom_of, dtype=np.int64)
    e = np.cross(vt[tri[:, 1]] - vt[tri[:, 0]], vt[tri[:, 2]] - vt[tri[:, 0]])
    ref = np.where((under >= 0)[:, None], vt - vb[np.maximum(under, 0)], 0.0)
    if (ref[tri].mean(axis=1) * e).sum() < 0:  # orient the top along top - bottom
        tri, btri = tri[:, ::-1], btri[:, ::-1]
    border = _border(tri, nv)
    i, j = under[border[:, 0]], under[border[:, 1]]
    if bottom_tri is not None:
        bb = _border(btri, len(vb))
        mine = np.sort(i * len(vb) + j)
        if (i < 0).any() or (j < 0).any() or len(bb) != len(border) or not np.array_equal(mine, np.sort(bb[:, 0] * len(vb) + bb[:, 1])):
            raise GeometryError("the slab's bottom does not share the top's boundary (a texcad bug)")
    ti, tj = border[:, 0], border[:, 1]
    walls = np.concatenate([np.stack([tj, ti, i + nv], 1), np.stack([tj, i + nv, j + nv], 1)])
    faces = np.concatenate([tri, btri[:, ::-1] + nv, walls]).astype(np.uint32)
    return Mesh(np.concatenate([vt, vb]).astype(np.float32), faces)


def shared_faces(mesh: Mesh, *others: Mesh) -> list[np.ndarray]:
    """For each of ``others``, ``(M,)`` bool: which faces of ``mesh`` are also its faces
    (the same three vertex positions, bit for bit in float32, in any order). Sorting, no
    geometry: a fused part's faces that are not its base part's are its texture's."""
    meshes = (mesh, *others)
    verts = np.concatenate([m.vertices for m in meshes]).astype(np.float32) + np.float32(0.0)  # -0.0 -> 0.0
    _, vid = np.unique(np.ascontiguousarray(verts).view(np.dtype((np.void, 12))).ravel(), return_inverse=True)
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes])
    keys = [np.sort(vid[m.faces.astype(np.int64) + off], axis=1) for m, off in zip(meshes, offsets)]
    _, fid = np.unique(np.concatenate(keys), axis=0, return_inverse=True)
    bounds = np.cumsum([0] + [len(k) for k in keys])
    fid = fid.ravel()
    own = fid[: bounds[1]]
    return [np.isin(own, fid[lo:hi]) for lo, hi in zip(bounds[1:-1], bounds[2:])]


def heightfield_volume(heights: np.ndarray, pitch: Sequence[float]) -> tuple[float, float]:
    """The volume in mm^3 between z = 0 and a heightfield's pixel-grid surface where it
    is above z = 0, as a sum of h dA over the pixel centres (trapezoid weights: 1/2 on
    the sides, 1/4 at the corners), and the most by which the grid mesh's own volume
    can differ from that sum, in mm^3: its corner triangles weigh 1/3 or 1/6 of a
    pixel, and a cell with corners above and below z = 0 is counted in full.

    Args:
        heights: ``(R, C)`` mm.
        pitch: ``(px, py)`` mm.

    Returns:
        ``(volume, slack)`` in mm^3.
    """
    g = np.asarray(heights, dtype=np.float64)
    h = np.maximum(g, 0.0)
    px, py = (float(p) for p in pitch)
    if min(h.shape) > 1:  # trapezoid weights without a weight array: all, minus half the sides, plus a quarter of the corners
        total = float(h.sum()) - 0.5 * float(h[[0, -1], :].sum() + h[:, [0, -1]].sum()) \
            + 0.25 * float(h[[0, 0, -1, -1], [0, -1, 0, -1]].sum())
    else:  # one row or column: its weights halved twice over
        w = np.ones(h.shape)
        w[[0, -1], :] *= 0.5
        w[:, [0, -1]] *= 0.5
        total = float((h * w).sum())
    corners = [g[:-1, :-1], g[:-1, 1:], g[1:, :-1], g[1:, 1:]]
    lo, hi = np.minimum.reduce(corners), np.maximum.reduce(corners)
    crossing = float(np.where((lo < 0) & (hi > 0), hi, 0.0).sum())
    return total * px * py, px * py * (float(h.max()) + crossing)
