"""Mapping a texture onto a 2.5D surface (paper, section 2.2, algorithms 1 and 2).

A :class:`~texcad.sources.Heightmap` ``h[row, col]`` (mm) is laid on a
:class:`~texcad.mapping.Profile` extruded along +Y: texture x runs along the
profile's arc length ``s``, texture y along the extrusion. Pixel column ``c`` sits at
``s_c = s_0 + (c + 1/2) p_x`` and row ``r`` at ``y_r = y_0 + (r + 1/2) p_y``, so the
distances between texture points along the surface are the texture's own (eq. 4:
arc-length parameterization). The base point of vertex ``(r, c)`` is
``(X(s_c), y_r, Z(s_c))``; the height is added

* **distance-preserving** (algorithm 1): along z, ``Z -> Z + sigma h`` with
  ``sigma = +1`` on upward-looking and ``-1`` on downward-looking function pieces
  (the sign of the outward normal's z, which equals the sign of ``dx/ds``). Within a
  function piece the textured surface stays a graph ``z(x, y)``: it cannot fold, and
  every texture flank stays vertical (support-free when built along z);
* **angle-preserving** (algorithm 2): along the unit outward normal,
  ``(X, Z) -> (X, Z) + h (n_x, n_z)``.

Intersection analysis and treatment (section 2.2.1)
---------------------------------------------------
The height actually applied is ``w(s) h`` with a smooth factor ``0 <= w <= 1`` per
column, the product of

* a *fade* to 0 over ``transition`` mm (smoothstep) around the division points between
  function pieces and on vertical stretches (distance mode: there the vertical
  offset runs along the surface and flips sign; this is the paper's "remove the
  intersecting textures near the division planes, then smooth the transition"), and
  around corners (angle mode: the normal jumps there);
* a *limit* from the geometry, evaluated on a dense arc-length grid: angle mode keeps
  ``h <= 0.8 reach(s)``, where ``reach(A) = min_B |B - A|^2 / (2 (B - A) . n_A)`` over
  profile points ``B`` on the outward side is the distance along the normal to the
  profile's medial axis. It equals the radius of curvature ``1/|kappa|`` inside a
  concave bend (so ``h |kappa| <= 0.8``: the offset cannot fold, which happens at
  ``h |kappa| >= 1``), the distance to a concave corner near one, and half the gap
  where the profile comes back across (two textures share it). Normal segments shorter
  than the reach never meet (they lie in the points' Voronoi cells), so the textured
  cross-section cannot cross itself. Distance mode keeps ``h <= 0.4 g(s)``, ``g`` the
  vertical gap from the profile to the next profile crossing on the texture's side
  (the function piece across, whose texture comes the other way: ``0.4 + 0.4 < 1``).
  The limit is eroded (running minimum over ``transition`` mm) and box-smoothed twice
  over ``transition / 2`` mm, so it is smooth and never above the raw limit; a
  :class:`~texcad.errors.TexcadWarning` says where and by how much it cut the height.

Open profiles end in two planar end walls. In distance mode the wall runs vertically
(the texture's own direction), so where the profile is steep at an end (``|n_z| <
0.5``) the texture fades out towards that end like towards a division point and the
wall follows the normal instead (a vertical wall would run along the surface).

The slab under the texture reaches ``depth`` mm into the base along a smoothed inward
normal (box-smoothed over ``2 depth`` mm twice, so it cannot fold at convex corners),
limited to 0.4 of the inward gap to the profile; near the open ends its direction
turns smoothly (over ``max(4 depth, 8 p_x)`` mm) into the end wall's. At a corner
the bottom leaves along the bisector of the two sides' normals. The bottom's
cross-section is then checked exactly (segment-pair orientation tests): where it
crosses itself, the profile or an end wall (inside a sharp convex tip the inner
offsets of both sides meet), the depth is halved locally until it does not.

Before returning, every grid cell of the textured surface is checked: (angle mode)
the top advances along the profile chord, (distance mode) x advances monotonically
within each function piece; a violation raises
:class:`~texcad.errors.GeometryError` rather than emitting a folded mesh.

Closed profiles
---------------
The texture must be seamless in x (a built-in, or a Heightmap the caller declares
periodic in x). Built-ins are synthesized to the exact perimeter by
:func:`fit_texture` (a whole number of tiles, scaled in x and y together). Any other
periodic texture of width ``W`` is repeated ``N = round(L / W)`` times and its x pitch
rescaled by ``L / (N W)`` so that the repeats fill the perimeter exactly (reported as
``x_scale``; a warning when it differs from 1 by more than 0.5 %). Column ``C - 1``
connects to column 0 on shared vertices (:func:`texcad.solid.grid_solid` with
``wrap_x``): the seam gap is exactly zero.
"""

from __future__ import annotations

import os
import warnings
from typing import Any, Callable
from dataclasses import dataclass, field

import numpy as np

from ..util import require_memory
from ..util import positive, smoothstep
from ..errors import GeometryError, ParameterError, TexcadWarning
from ..sources import Heightmap
from ..solid import Mesh
from ..util import Progress, report
from .surface import Profile

__all__ = [
    "MAPPINGS",
    "HeightLimit",
    "MappedSurface",
    "fit_texture",
    "map_texture",
    "column_positions",
    "slab_mesh",
    "lean_slab_mesh",
    "developed_field",
]

#: The two mappings of the paper: algorithm 1 and algorithm 2.
MAPPINGS = ("distance", "angle")

#: Angle mode: h <= FOLD_SHARE * reach (the brief's "h <= margin / kappa").
FOLD_SHARE = 0.8
#: Distance mode and slab depth: h <= GAP_SHARE * gap (two offsets share a gap).
GAP_SHARE = 0.4


@dataclass(frozen=True)
class HeightLimit:
    """A stretch of the profile where the texture height was limited.

    Attributes:
        s0, s1: arc-length range in mm.
        point: ``(x, z)`` in mm where the limit is strongest.
        factor: smallest fraction of the height kept (0..1).
        height: largest height kept there, mm.
        reason: why (concave radius, gap to the profile across, ...).
    """

    s0: float
    s1: float
    point: tuple[float, float]
    factor: float
    height: float
    reason: str

    def __str__(self) -> str:
        return (
            f"s = {self.s0:.1f}..{self.s1:.1f} mm around (x, z) = ({self.point[0]:.2f}, {self.point[1]:.2f}) mm: "
            f"at most {self.height:.3g} mm ({100 * self.factor:.0f} %), {self.reason}"
        )


@dataclass(frozen=True, eq=False)
class MappedSurface:
    """A texture mapped onto a profile: the two vertex grids of the slab.

    Attributes:
        top: ``(R, C, 3)`` float32 textured surface in mm (row along +y, column along s).
        bottom: ``(2, C, 3)`` float32: the first and last row of the bottom surface
            ``depth`` mm inside the base, an extrusion along y (:attr:`bottom_grid`
            gives all ``R`` rows, e.g. for :func:`texcad.solid.grid_solid`).
        closed: columns wrap around (closed profile).
        s: ``(C,)`` float64 arc length of every column in mm.
        y: ``(R,)`` float64 y of every row in mm.
        factor: ``(C,)`` float64 fraction of the texture height applied per column.
        heightmap: the texture as mapped (x pitch fitted on closed profiles).
        mapping: ``"distance"`` or ``"angle"``.
        x_scale: texture x stretch (1 = physical scale kept; closed profiles fit a
            whole number of repeats).
        limits: where the height was limited to avoid self-intersection.
        offset: ``(C, 2)`` float64 (x, z) offset per mm of texture height of every
            column (the normal or +-z, times ``factor``): ``top = P + h offset``
            (:mod:`texcad.mapping.modes` moves points along it).
    """

    top: np.ndarray
    bottom: np.ndarray
    closed: bool
    s: np.ndarray
    y: np.ndarray
    factor: np.ndarray
    heightmap: Heightmap
    mapping: str
    x_scale: float = 1.0
    limits: list[HeightLimit] = field(default_factory=list)
    offset: np.ndarray | None = None

    @property
    def bottom_grid(self) -> np.ndarray:
        """``(R, C, 3)`` float32 bottom with one row per texture row."""
        g = np.repeat(self.bottom[:1], len(self.y), axis=0)
        g[..., 1] = np.float32(self.y)[:, None]
        return g

    def solid(self) -> Mesh:
        """The watertight slab between ``top`` and ``bottom`` (see :func:`slab_mesh`;
        closed on shared vertices for closed profiles: zero seam gap)."""
        return slab_mesh(self.top, self.bottom, closed=self.closed)


def slab_mesh(top: np.ndarray, bottom: np.ndarray, *, closed: bool = False) -> Mesh:
    """Close a top vertex grid and a bottom surface (mm) into a watertight slab.

    ``top`` is ``(R, C, 3)``. ``bottom`` is either ``(R, C, 3)`` (a full grid, as for
    :func:`texcad.solid.grid_solid`) or ``(2, C, 3)``: a *ruled* bottom given by its
    first and last row only, for a bottom that is an extrusion along y (the offset
    profile), so its interior rows would be collinear points. The ruled bottom costs
    ``2 C`` vertices instead of ``R C`` (like the flat slab's polygon bottom), which
    keeps the manifold3d union as fast as in the flat case.

    Faces: the top grid (group ``"texture"``), the bottom (group ``"bottom"``), and
    end walls. The walls
    at the first and last row are plane cross-sections ``y = const`` and are
    triangulated as polygons (manifold3d ``triangulate``: top row plus bottom row, or
    the two loops of a closed profile) rather than by straight top-to-bottom
    "fibres", which can cross where the texture goes vertically and the bottom along
    the normal (distance-preserving mapping on a slope). With a ruled bottom, the
    walls at the two end columns of an open grid must be planar (each top column on
    a straight line, bottom on that line too, as :func:`map_texture` makes them) and
    are triangulated as polygons too. Columns wrap on shared vertices when
    ``closed``: the seam gap is exactly zero.

    Returns:
        Watertight :class:`~texcad.solid.Mesh`.
    """
    import manifold3d as m3d

    from ..solid import grid_faces

    top = np.asarray(top, dtype=np.float32)
    bottom = np.asarray(bottom, dtype=np.float32)
    if top.ndim != 3 or top.shape[2] != 3 or bottom.ndim != 3 or bottom.shape[1:] != top.shape[1:]:
        raise ParameterError(f"top must be (R, C, 3) and bottom (R, C, 3) or (2, C, 3); got {top.shape} and {bottom.shape}")
    rows, cols = top.shape[:2]
    brows = bottom.shape[0]
    if rows < 2 or cols < 2 or brows not in (2, rows):
        raise GeometryError(f"a slab needs at least 2 x 2 vertices and a bottom of 2 or {rows} rows; got {top.shape}, {bottom.shape}")
    n = rows * cols
    verts = np.concatenate([top.reshape(-1, 3), bottom.reshape(-1, 3)])
    ftop = grid_faces(rows, cols, wrap_x=closed)
    fbot = grid_faces(brows, cols, wrap_x=closed, flip=True) + np.uint32(n)
    idx = np.arange(n, dtype=np.int64).reshape(rows, cols)
    bidx = np.arange(brows * cols, dtype=np.int64).reshape(brows, cols) + n
    parts = [ftop.astype(np.int64), fbot.astype(np.int64)]
    for r, rb in ((0, 0), (rows - 1, brows - 1)):  # the two end cross-sections
        t_xz = top[r][:, [0, 2]].astype(np.float64)
        b_xz = bottom[rb][:, [0, 2]].astype(np.float64)
        ti, bi = idx[r], bidx[rb]
        if closed:
            loops = []
            for pts, ids in ((t_xz, ti), (b_xz, bi)):
                if _area(pts) < 0:
                    pts, ids = pts[::-1], ids[::-1]
                loops.append((pts, ids))
            # The larger loop is the outer boundary (CCW), the other a hole (CW).
            loops.sort(key=lambda pl: -_area(pl[0]))
            polys = [loops[0][0], loops[1][0][::-1]]
            ids = np.concatenate([loops[0][1], loops[1][1][::-1]])
        else:
            poly = np.concatenate([t_xz, b_xz[::-1]])
            ids = np.concatenate([ti, bi[::-1]])
            if _area(poly) < 0:
                poly, ids = poly[::-1], ids[::-1]
            polys = [poly]
        tri = ids[np.asarray(m3d.triangulate(polys), dtype=np.int64)]
        # Counter-clockwise in (x, z) is an outward normal of -y: right for row 0.
        parts.append(tri if r == 0 else tri[:, ::-1])
    if not closed:
        for c, sense in ((0, -1), (cols - 1, 1)):  # the two end columns
            if brows == rows:
                r0, r1 = idx[:-1, c], idx[1:, c]
                a, b = (r0, r1) if sense > 0 else (r1, r0)
                parts.append(np.stack([a, a + n, b + n], 1))
                parts.append(np.stack([a, b + n, b], 1))
                continue
            # Outward: against the bottom's advance at column 0, along it at the end.
            nb = 1 if c == 0 else cols - 2
            out = sense * (bottom[0, max(c, nb), [0, 2]] - bottom[0, min(c, nb), [0, 2]]).astype(np.float64)
            parts.append(_end_wall(top[:, c], bottom[:, c], idx[:, c], bidx[:, c], out))
    faces = np.concatenate(parts).astype(np.uint32)
    bottom = np.arange(len(ftop), len(ftop) + len(fbot), dtype=np.uint32)
    return Mesh(verts, faces, {"texture": np.arange(len(ftop), dtype=np.uint32), "bottom": bottom})


def developed_field(top: np.ndarray, profile: Profile, s: np.ndarray, *, closed: bool) -> np.ndarray:
    """A scalar field over a mapped grid whose linear-interpolation error models the
    3-D error of flat triangles on the curved surface, for greedy insertion.

    The 3-D point of grid vertex ``(r, c)`` is ``P = B(s_c) + y_r e_y + offset``
    (:func:`map_texture`). A flat triangle spanning columns ``i..j`` misses ``P`` by
    (to first order, along the normal) the interpolation error of the offset's normal
    component ``H = offset . n`` plus the sagitta of the base's chord. The sagitta is
    the interpolation error of the *developed* profile ``q`` with ``q'' = -kappa``
    (``R (1 - cos(ds / 2R)) ~ ds^2 / 8R`` on a circle), so the field is ``H + q``:
    ``q`` integrates the turning angles of the polyline through the columns (convex
    positive, exact corners included) over chords taken on the offset at the
    largest height (the outer surface of a convex bend has the longer chords, hence
    the larger sagitta). Closed profiles get one more column, the seam again
    (``C + 1``), where ``q`` has kept integrating.

    Args:
        top: ``(R, C, 3)`` mapped grid (mm), columns at arc lengths ``s``.
        profile: the base profile (x, z in mm).
        s: ``(C,)`` arc length of every column, mm.

    Returns:
        ``(R, C)`` or, closed, ``(R, C + 1)`` float32 field in mm.
    """
    t = np.asarray(top, dtype=np.float64)
    fc = profile.at(np.asarray(s, dtype=np.float64))
    p, n = fc.point, fc.normal
    H = np.einsum("rcj,cj->rc", t[..., [0, 2]] - p[None], n)
    hmax = float(max(H.max(initial=0.0), 0.0))
    if closed:
        p, n, H = np.concatenate([p, p[:1]]), np.concatenate([n, n[:1]]), np.concatenate([H, H[:, :1]], axis=1)
    chord = np.diff(p, axis=0)
    ell = np.maximum(np.linalg.norm(chord, axis=1), np.linalg.norm(np.diff(p + hmax * n, axis=0), axis=1))
    tang = chord / np.maximum(np.linalg.norm(chord, axis=1, keepdims=True), 1e-300)
    # Turning angle at every inner column; convex (away from the normal) positive.
    beta = -np.arctan2(tang[:-1, 0] * tang[1:, 1] - tang[:-1, 1] * tang[1:, 0], np.einsum("ij,ij->i", tang[:-1], tang[1:]))
    slope = -np.concatenate([[0.0], np.cumsum(beta)])  # dq/ds on each chord
    q = np.concatenate([[0.0], np.cumsum(slope * ell)])
    return (H + q[None, :]).astype(np.float32)


def lean_slab_mesh(
    top: np.ndarray,
    bottom: np.ndarray,
    profile: Profile,
    s: np.ndarray,
    *,
    closed: bool = False,
    tolerance: float,
    facets_ok: "Callable[[np.ndarray, np.ndarray], bool] | None" = None,
) -> tuple[Mesh, float]:
    """:func:`slab_mesh` with a lean textured surface: only the grid vertices needed
    to stay within ``tolerance`` mm of every grid vertex in 3-D.

    Greedy insertion (:func:`texcad.solid.triangulate`) runs on
    :func:`developed_field`, so the bound covers the texture's relief and the
    curvature of the base (a cylinder's flat facets); the border rows and columns
    keep every vertex (the end walls and, closed, the seam column are those of the
    full grid: watertight, zero seam gap). The error is then measured independently
    (:func:`texcad.solid.grid_distance`: every grid vertex to the mesh, in 3-D) and
    the insertion repeated with a tighter bound until it is within ``tolerance``;
    after four tries, or when the lean surface would keep more than
    :data:`texcad.solid.lean.MAX_FRACTION` of the grid, the full grid is used.

    Args:
        top: ``(R, C, 3)`` exact mapped grid (mm), columns at arc lengths ``s`` (mm).
        bottom: ``(2, C, 3)`` or ``(R, C, 3)`` (see :func:`slab_mesh`).
        profile: the base profile the grid was mapped on (mm).
        closed: columns wrap (closed profile).
        tolerance: largest distance in mm from any grid vertex to the surface, > 0.
        facets_ok: optional ``facets_ok(vertices (N, 3) mm, faces (M, 3)) -> mm2``,
            the area of facets that must not be there (e.g. overhanging for a build
            direction). Given, the surface is made in tiles
            (:func:`texcad.solid.lean.tiled_triangulation`), each checked for its
            error and accepted where that area is 0 or no more than the pixel grid's
            own on the tile; a rejected tile is redone tighter, then as the grid, and
            the other tiles stay lean.

    Returns:
        ``(slab, max_error)``: the watertight slab (group ``"texture"``: the lean
        surface) and the measured largest distance in mm (0 for the full grid).
    """
    from ..solid import check_tolerance

    tol = check_tolerance(tolerance)
    full = slab_mesh(top, bottom, closed=closed)
    if tol <= 0:
        return full, 0.0
    t64 = np.asarray(top, dtype=np.float64)
    rows, cols = t64.shape[:2]
    field = developed_field(t64, profile, s, closed=closed)
    pts = np.concatenate([t64, t64[:, :1]], axis=1) if closed else t64
    lean = _lean_top(field, pts, full.vertices, cols, tol, facets_ok)
    if lean is None:
        return full, 0.0
    flat, faces, err = lean
    ntop = len(full.groups["texture"])
    top_faces = flat[faces.astype(np.int64)]
    faces_all = np.concatenate([top_faces, full.faces[ntop:].astype(np.int64)])
    mask = np.zeros(len(full.vertices), dtype=bool)
    mask[faces_all.ravel()] = True
    used = np.flatnonzero(mask)
    remap = np.cumsum(mask) - 1
    groups = {"texture": np.arange(len(top_faces), dtype=np.uint32),
              "bottom": (full.groups["bottom"] - ntop + len(top_faces)).astype(np.uint32)}
    mesh = Mesh(full.vertices[used], remap[faces_all].astype(np.uint32), groups)
    return mesh, err


def _lean_top(field, pts, verts, cols: int, tol: float, facets_ok):
    """The lean top of :func:`lean_slab_mesh`: ``(flat grid index per kept vertex,
    faces, measured error mm)`` or None (use the grid)."""
    from ..solid import BORDER_GRID, grid_distance, grid_faces, tiled_triangulation, triangulate

    def measure(rc, faces):
        flat = rc[:, 0] * cols + np.mod(rc[:, 1], cols)  # the wrap column is column 0
        lo, hi = rc.min(axis=0), rc.max(axis=0)
        sub = pts[lo[0] : hi[0] + 1, lo[1] : hi[1] + 1]
        return flat, float(grid_distance(sub, rc - lo, verts[flat], faces).max())

    if facets_ok is not None:

        def accept(rc, faces):
            flat, err = measure(rc, faces)
            if err > tol:
                return err / tol
            lean_area = facets_ok(verts[flat], faces)
            if lean_area <= 0:
                return True
            # Where the grid itself overhangs (a profile facing down), no worse than it.
            lo, hi = rc.min(axis=0), rc.max(axis=0)
            g = pts[lo[0] : hi[0] + 1, lo[1] : hi[1] + 1]
            return bool(lean_area <= facets_ok(g.reshape(-1, 3), grid_faces(*g.shape[:2]).astype(np.int64)))

        lean = tiled_triangulation(field, tol, accept=accept, border_grid=BORDER_GRID)
        if lean is None:
            return None
        flat, err = measure(*lean)
        return (flat, lean[1], err) if err <= tol else None
    run = tol
    for _ in range(4):  # tighter bounds until the measured error is within tolerance
        lean = triangulate(field, run, full_border=True)
        if lean is None:
            return None
        flat, err = measure(*lean)
        if err <= tol:
            return flat, lean[1], err
        run *= 0.9 * tol / err
    return None


def _end_wall(tcol: np.ndarray, bcol: np.ndarray, tid: np.ndarray, bid: np.ndarray, outward: np.ndarray) -> np.ndarray:
    """Triangles of a planar end wall between a top column ``tcol`` (R, 3) and the
    two bottom corners ``bcol`` (2, 3), facing ``outward`` (an (x, z) direction)."""
    import manifold3d as m3d

    t = tcol.astype(np.float64)
    b = bcol.astype(np.float64)
    # In-plane coordinates (y, q), q along e: from the bottom towards the top.
    e = t[0, [0, 2]] - b[0, [0, 2]]
    e /= max(float(np.linalg.norm(e)), 1e-300)
    q_t = (t[:, [0, 2]] - b[0, [0, 2]]) @ e
    q_b = (b[:, [0, 2]] - b[0, [0, 2]]) @ e
    poly = np.concatenate([np.stack([t[:, 1], q_t], 1), np.stack([b[::-1, 1], q_b[::-1]], 1)])
    ids = np.concatenate([tid, bid[::-1]])
    if _area(poly) < 0:
        poly, ids = poly[::-1], ids[::-1]
    tri = ids[np.asarray(m3d.triangulate([poly]), dtype=np.int64)]
    # Counter-clockwise in (y, q) has the 3-D normal y x e = (e_z, 0, -e_x).
    return tri if float(np.array([e[1], -e[0]]) @ outward) > 0 else tri[:, ::-1]


def _area(pts: np.ndarray) -> float:
    x, z = pts[:, 0], pts[:, 1]
    return 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)


def _smoothstep(t: np.ndarray) -> np.ndarray:
    return smoothstep(0.0, 1.0, t)




# -- texture fitting -----------------------------------------------------------------------
def fit_texture(
    profile: Profile,
    texture: "str | os.PathLike | Heightmap",
    *,
    length: float,
    pitch: float = 0.125,
    height: float = 2.0,
    periodic_x: bool | None = None,
) -> tuple[Heightmap, bool]:
    """Make a texture the size of a surface: ``profile.length x length`` mm.

    * ``"builtin:NAME[:params]"``: sampled at ``pitch`` mm over the whole surface. On a
      closed profile of perimeter ``L`` it is synthesized to the exact length: its
      ``scale`` is multiplied by ``L / (N tile)``, ``N = max(1, round(L / tile))``, so
      ``N`` whole tiles fill the perimeter and the texture is seamless around it
      (features keep their shape: x and y scale together; a
      :class:`~texcad.errors.TexcadWarning` says so when the scale changes by more
      than 0.5 %).
    * an image path: stretched over ``L x length`` mm (one vertex per pixel).
    * a :class:`Heightmap`: used as it is.

    Args:
        profile: the surface's profile.
        texture: see above.
        length: extrusion length in mm.
        pitch: mm per pixel for built-ins.
        height: maximum height in mm (built-ins and images).
        periodic_x: whether the texture tiles in x (built-ins: always).

    Returns:
        ``(heightmap, periodic_x)``.
    """
    from ..sources import PREFIX, builtin, load_texture

    ln = positive("length", length)
    if isinstance(texture, Heightmap):
        return texture, bool(periodic_x)
    spec = os.fspath(texture)
    if spec.startswith(PREFIX):
        positive("pitch", pitch)
        if profile.closed:
            L = profile.length
            tile = builtin(spec, pitch=pitch, height=height).size[0]
            n = max(1, int(round(L / tile)))
            scale = L / (n * tile)
            if abs(scale - 1.0) > 0.005:
                warnings.warn(
                    f"the texture {spec!r} was scaled by {100 * (scale - 1):+.2f} % (x and y) so that {n} whole "
                    f"{tile:.3g} mm tile(s) fill the {L:.3f} mm perimeter seamlessly; pass scale= in the texture "
                    "spec to choose another tile size",
                    TexcadWarning,
                    stacklevel=2,
                )
            # Sampled just over L (whole pixels per tile): exactly n tiles, n * tile * scale = L.
            hm = builtin(spec, size=(L * (1 + 1e-9), ln), pitch=pitch * scale, height=height, scale=scale)
            return hm, True
        return builtin(spec, size=(profile.length, ln), pitch=pitch, height=height), True
    return load_texture(spec, size=(profile.length, ln), height=height), bool(periodic_x)


# -- geometry analysis (vectorized over sample pairs) -----------------------------------
def _pairs_within(a: np.ndarray, b: np.ndarray, r: float, *, box: tuple[float, float] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``(i, j)`` with ``|a_i - b_j| <= r`` (k-d tree, no Python loop); with
    ``box = (rx, rz)``: ``|dx| <= rx`` and ``|dz| <= rz`` instead (Chebyshev distance
    on scaled coordinates)."""
    from scipy.spatial import cKDTree

    if box is not None:
        scale = 1.0 / np.maximum(np.asarray(box, dtype=np.float64), 1e-300)
        ta, tb = cKDTree(a * scale), cKDTree(b * scale)
        m = ta.sparse_distance_matrix(tb, 1.0, p=np.inf, output_type="ndarray")
    else:
        ta, tb = cKDTree(a), cKDTree(b)
        m = ta.sparse_distance_matrix(tb, r, output_type="ndarray")
    return m["i"].astype(np.int64), m["j"].astype(np.int64)


def _normal_reach(pts: np.ndarray, nrm: np.ndarray, cap: float) -> np.ndarray:
    """Distance along the outward normal to the medial axis, capped at ``cap`` mm:
    ``reach(A) = min_B |B - A|^2 / (2 (B - A) . n_A)`` over ``B`` with
    ``(B - A) . n_A > 0``. ``reach(A) < cap`` iff some ``B`` lies in the disc of radius
    ``cap`` centred at ``A + cap n_A`` (``|B - A|^2 < 2 cap (B - A) . n_A``), so only
    those pairs are examined."""
    reach = np.full(len(pts), np.inf)
    i, j = _pairs_within(pts + cap * nrm, pts, cap * (1.0 + 1e-9))
    d = pts[j] - pts[i]
    dd = np.einsum("ij,ij->i", d, d)
    dn = np.einsum("ij,ij->i", d, nrm[i])
    ok = (dn > 1e-9 * np.sqrt(dd)) & (dd > 1e-18)
    np.minimum.at(reach, i[ok], dd[ok] / (2.0 * dn[ok]))
    return np.minimum(reach, cap)


def _ray_clearance(
    origins: np.ndarray, dirs: np.ndarray, seg_a: np.ndarray, seg_b: np.ndarray, own: np.ndarray, cap: float, closed: bool
) -> np.ndarray:
    """Distance from each origin along its unit direction to the first crossing of the
    polyline ``seg_a[k] -> seg_b[k]`` (segments ``own[i] - 1`` and ``own[i]``, which
    meet at origin ``i``, excluded), capped at ``cap`` mm.

    Candidates: segments whose midpoint lies within ``half`` (half the longest
    segment) of the ray ``o + t u``, ``0 <= t <= cap``: a box around vertical rays
    (distance mode), else the disc around the ray's middle, filtered by the distance
    across the ray."""
    out = np.full(len(origins), np.inf)
    mid = 0.5 * (seg_a + seg_b)
    half = 0.5 * float(np.linalg.norm(seg_b - seg_a, axis=1).max(initial=0.0)) * (1.0 + 1e-9) + 1e-12
    centre = origins + 0.5 * cap * dirs
    if not np.any(dirs[:, 0]):
        i, k = _pairs_within(centre, mid, 0.0, box=(half, 0.5 * cap + half))
    else:
        i, k = _pairs_within(centre, mid, 0.5 * cap + half)
        dm = mid[k] - origins[i]
        across = np.abs(dirs[i, 0] * dm[:, 1] - dirs[i, 1] * dm[:, 0])
        keep = across <= half
        i, k = i[keep], k[keep]
    nseg = len(seg_a)
    adj = (k == own[i]) | (k == (own[i] - 1) % nseg if closed else k == own[i] - 1)
    i, k = i[~adj], k[~adj]
    u = dirs[i]
    e = seg_b[k] - seg_a[k]
    w = seg_a[k] - origins[i]
    den = u[:, 0] * e[:, 1] - u[:, 1] * e[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den
        f = (w[:, 0] * u[:, 1] - w[:, 1] * u[:, 0]) / den
    hit = (np.abs(den) > 1e-15) & (f >= 0) & (f <= 1) & (t > 1e-9)
    np.minimum.at(out, i[hit], t[hit])
    return np.minimum(out, cap)


def _erode_smooth(v: np.ndarray, radius: int, closed: bool) -> np.ndarray:
    """Running minimum over +-2 radius samples, then two box means over +-radius: a
    smooth function that is nowhere above ``v``."""
    from scipy.ndimage import minimum_filter1d, uniform_filter1d

    mode = "wrap" if closed else "nearest"
    r = max(1, int(radius))
    out = minimum_filter1d(v, 4 * r + 1, mode=mode)
    for _ in range(2):
        out = uniform_filter1d(out, 2 * r + 1, mode=mode)
    return np.minimum(out, v)


def _box_smooth(v: np.ndarray, radius: int, closed: bool) -> np.ndarray:
    """Two box means over +-radius samples along axis 0 (periodic if ``closed``;
    otherwise padded by point reflection, ``2 v_0 - v_k``, so a linearly varying
    quantity keeps its end values)."""
    from scipy.ndimage import uniform_filter1d

    r = max(1, int(radius))
    if closed:
        for _ in range(2):
            v = uniform_filter1d(v, 2 * r + 1, axis=0, mode="wrap")
        return v
    p = min(2 * r + 1, len(v) - 1)
    ext = np.concatenate([2 * v[:1] - v[p:0:-1], v, 2 * v[-1:] - v[-2 : -p - 2 : -1]])
    for _ in range(2):
        ext = uniform_filter1d(ext, 2 * r + 1, axis=0, mode="nearest")
    return ext[p : p + len(v)]


def _distance_to_intervals(s: np.ndarray, iv: np.ndarray, period: float | None) -> np.ndarray:
    """Arc-length distance from ``s`` to the nearest interval ``[a, b]`` (rows of ``iv``)."""
    if len(iv) == 0:
        return np.full(len(s), np.inf)
    a, b = iv[:, 0][None, :], iv[:, 1][None, :]
    x = s[:, None]
    if period is None:
        d = np.maximum(0.0, np.maximum(a - x, x - b))
    else:
        d = np.full((len(s), len(iv)), np.inf)
        for shift in (-period, 0.0, period):  # three copies of the loop
            d = np.minimum(d, np.maximum(0.0, np.maximum(a + shift - x, x - b - shift)))
    return d.min(axis=1)


def _interp(x: np.ndarray, xp: np.ndarray, fp: np.ndarray, period: float | None) -> np.ndarray:
    if fp.ndim == 1:
        return np.interp(x, xp, fp, period=period)
    return np.stack([np.interp(x, xp, fp[:, k], period=period) for k in range(fp.shape[1])], axis=1)


def _runs(mask: np.ndarray, closed: bool) -> list[tuple[int, int]]:
    """Index ranges ``[i, j]`` (inclusive) of the True runs of ``mask`` (wrapping)."""
    if not mask.any():
        return []
    if mask.all():
        return [(0, len(mask) - 1)]
    d = np.diff(mask.astype(np.int8))
    starts = list(np.flatnonzero(d == 1) + 1)
    ends = list(np.flatnonzero(d == -1))
    if mask[0]:
        starts.insert(0, 0)
    if mask[-1]:
        ends.append(len(mask) - 1)
    runs = list(zip(starts, ends))
    if closed and len(runs) > 1 and mask[0] and mask[-1]:
        first = runs.pop(0)
        last = runs.pop()
        runs.append((last[0], first[1]))
    return [(int(a), int(b)) for a, b in runs]


# -- the mapping ---------------------------------------------------------------------------
def column_positions(profile: Profile, heightmap: Heightmap, *, periodic_x: bool = False) -> tuple[np.ndarray, Heightmap]:
    """Where :func:`map_texture` puts the texture's columns (eq. 4: arc length).

    Open profiles: the texture is centred, column ``c`` at ``s_c = (L - C p_x) / 2 +
    (c + 1/2) p_x``. Closed profiles: a texture that tiles in x (``periodic_x``) is
    repeated ``N = round(L / (C p_x))`` times, and the x pitch becomes ``L / (N C)`` so
    that the repeats fill the perimeter ``L`` exactly; column ``c`` at ``(c + 1/2)
    p_x``.

    Args:
        profile: the surface's profile (mm).
        heightmap: the texture (heights mm, pitch mm/px).
        periodic_x: closed profiles: the texture tiles in x.

    Returns:
        ``(s, heightmap')``: ``(C',)`` float64 arc lengths in mm and the texture as
        laid (closed profiles: repeated, x pitch fitted; else ``heightmap`` itself).
    """
    rows, cols = heightmap.shape
    px, py = heightmap.pitch
    L = profile.length
    if not profile.closed:
        return (L - cols * px) / 2 + (np.arange(cols) + 0.5) * px, heightmap
    n_rep = max(1, int(round(L / (cols * px)))) if periodic_x else 1
    heights = np.tile(heightmap.heights, (1, n_rep)) if n_rep > 1 else heightmap.heights
    px_fit = L / heights.shape[1]
    return (np.arange(heights.shape[1]) + 0.5) * px_fit, Heightmap(heights, (px_fit, py))


def map_texture(
    profile: Profile,
    heightmap: Heightmap,
    *,
    mapping: str = "distance",
    length: float | None = None,
    depth: float = 0.5,
    periodic_x: bool = False,
    transition: float | None = None,
    progress: Progress = None,
) -> MappedSurface:
    """Map a heightmap onto a profile extruded along +Y (algorithms 1 and 2).

    Texture x runs along the arc length ``s`` (eq. 4) and texture y along +Y; one
    grid column per pixel column (plus one at each corner of the profile), one row
    per pixel row. Open profiles: the texture is centred on the profile and must not
    be longer than it. Closed profiles: see the module docstring (whole repeats,
    seam on shared vertices). The height goes along z (``mapping="distance"``,
    algorithm 1: ``Z -> Z + sigma h``, ``sigma`` the facing of the function piece) or
    along the normal (``"angle"``, algorithm 2: ``(X, Z) + h (n_x, n_z)``), scaled
    by the fade and limit factor ``w(s)`` described in the module docstring.

    Args:
        profile: the surface's profile (XZ plane, mm).
        heightmap: heights in mm, pitch in mm per pixel.
        mapping: ``"distance"`` or ``"angle"``.
        length: extrusion length in mm (the surface spans ``0 <= y <= length``; the
            texture is centred). Default: the texture's depth.
        depth: how far the slab reaches into the base, mm (keep it below the base's
            wall thickness; it is reduced locally where the profile's own material is
            thinner than ``2.5 depth``).
        periodic_x: closed profiles: the texture tiles in x (else it is stretched once
            around, with a warning about the seam).
        transition: fade and smoothing length in mm (default ``max(2 h_max, 4 p_x)``).
        progress: optional ``progress(fraction, message)`` callback.

    Returns:
        :class:`MappedSurface`; ``.solid()`` closes it into a watertight slab.

    Raises:
        ParameterError: unknown mapping, non-positive depth or transition.
        GeometryError: the texture is longer than an open profile or the extrusion, or
            the base is too thin for ``depth``.
    """
    if mapping not in MAPPINGS:
        raise ParameterError(f"unknown mapping {mapping!r}; use 'distance' (algorithm 1) or 'angle' (algorithm 2)")
    depth = positive("depth", depth)
    rows, cols = heightmap.shape
    report(progress, 0.0, f"fitting {cols} x {rows} px texture to the {profile.length:.1f} mm profile")
    s_cols, heightmap, x_scale, y = _fit_columns(profile, heightmap, periodic_x, length)
    px = heightmap.pitch[0]
    hmax = float(heightmap.heights.max()) if heightmap.heights.size else 0.0
    trans = max(2.0 * hmax, 4.0 * px) if transition is None else positive("transition", transition)
    s_all, h_all = _corner_columns(profile, s_cols, heightmap.heights, px)
    ncol = len(s_all)
    require_memory(rows * ncol * 40.0, f"a {rows} x {ncol} vertex mapped grid", "use a larger pitch")
    report(progress, 0.2, "intersection analysis")
    an = _analyse(profile, px, hmax, trans, mapping)
    n_smooth_a, d_a = _bottom_depth(profile, an, depth)
    report(progress, 0.5, f"mapping {rows} x {ncol} vertices ({mapping}-preserving)")
    fc = profile.at(s_all)
    w_lim = np.minimum(_interp(s_all, an.s, an.w_lim, an.period), 1.0)
    w, direction = _column_weights(profile, fc, s_all, w_lim, mapping, trans)
    v = direction * w[:, None]
    u_c = _unit(_interp(s_all, an.s, n_smooth_a, an.period))
    d_c = _interp(s_all, an.s, d_a, an.period)
    if not profile.closed:
        _end_wall_bottoms(fc, s_all, direction, w, u_c, d_c, depth, px)
    _bottom_into_material(profile, fc, s_all, u_c, px, an.period)
    base_b = _resolve_bottom(fc.point, u_c, d_c, profile.closed, depth, px)
    top, bottom = _grids(h_all, v, fc.point, y, base_b)
    _check_cells(profile, fc, np.asarray(h_all, dtype=np.float32), v, base_b, mapping, w)
    limits = _limits(profile, s_all, w_lim, fc, an.s, an.raw, an.clearance, hmax, mapping)
    if limits:
        shown = "; ".join(str(lim) for lim in limits[:5])
        more = f" (and {len(limits) - 5} more)" if len(limits) > 5 else ""
        warnings.warn(
            f"texture height limited in {len(limits)} place(s) to keep the {mapping}-preserving mapping free of "
            f"self-intersection: {shown}{more}. Lower the height or enlarge the radius/gap to keep it all",
            TexcadWarning,
            stacklevel=2,
        )
    report(progress, 1.0, "mapped")
    return MappedSurface(top, bottom, profile.closed, s_all, y, w, heightmap, mapping, x_scale, limits, v)


def _fit_columns(profile: Profile, heightmap: Heightmap, periodic_x: bool, length: float | None):
    """Columns along ``s`` (eq. 4): ``(s_cols, heightmap (repeated and stretched
    around closed profiles), x_scale, y rows (mm))``."""
    rows, cols = heightmap.shape
    px, py = heightmap.pitch
    L = profile.length
    heights = heightmap.heights
    width = cols * px
    if profile.closed:
        if not periodic_x:
            if abs(width - L) > 0.1 * L:
                raise ParameterError(
                    f"the texture is {width:.1f} mm wide but the closed profile is {L:.1f} mm around; give a "
                    "seamless texture (a built-in, or a Heightmap that tiles in x with periodic_x=True) or one "
                    f"{L:.1f} mm wide"
                )
            step = float(np.abs(heights[:, 0] - heights[:, -1]).max())
            typical = float(np.abs(np.diff(heights, axis=1)).max())
            warnings.warn(
                f"the texture is not declared seamless in x (periodic_x=False): it meets itself at s = 0, "
                f"(x, z) = ({profile.start[0]:.2f}, {profile.start[1]:.2f}) mm with height steps up to {step:.3g} mm "
                f"(largest step elsewhere {typical:.3g} mm); synthesize it with wrap='x' and pass periodic_x=True",
                TexcadWarning,
                stacklevel=3,
            )
    elif (cols - 1) * px > L + 1e-9:
        raise GeometryError(
            f"the texture spans {(cols - 1) * px:.2f} mm along the profile but the profile is only {L:.2f} mm long; "
            "crop the texture or lengthen the profile"
        )
    s_cols, heightmap = column_positions(profile, heightmap, periodic_x=periodic_x)
    x_scale = 1.0
    if profile.closed:
        x_scale = heightmap.pitch[0] / px
        if abs(x_scale - 1.0) > 0.005:
            warnings.warn(
                f"the texture ({width:.3f} mm wide, repeated {heightmap.shape[1] // cols} time(s)) was stretched by "
                f"{100 * (x_scale - 1):+.2f} % along the profile to fill its {L:.3f} mm perimeter exactly",
                TexcadWarning,
                stacklevel=3,
            )
    length = positive("length", rows * py if length is None else length)
    if (rows - 1) * py > length + 1e-9:
        raise GeometryError(
            f"the texture spans {(rows - 1) * py:.2f} mm along y but the surface is only {length:.2f} mm long; "
            "crop the texture or lengthen the extrusion"
        )
    y = (length - rows * py) / 2 + (np.arange(rows) + 0.5) * py
    return s_cols, heightmap, x_scale, y


def _corner_columns(profile: Profile, s_cols: np.ndarray, heights: np.ndarray, px: float):
    """Extra columns at the profile's corners (exact corner vertex; height
    interpolated in x): ``(s_all, h_all)``."""
    cols_t = heights.shape[1]
    corners = np.array([c.s for c in profile.corners])
    if corners.size and not profile.closed:
        corners = corners[(corners > s_cols[0]) & (corners < s_cols[-1])]
    if corners.size:
        near = np.min(np.abs(corners[:, None] - s_cols[None, :]), axis=1) < 1e-6 * px
        corners = corners[~near]
    if not corners.size:
        return s_cols, heights
    pos = np.searchsorted(s_cols, corners)
    f = (corners - s_cols[0]) / px
    i0 = np.floor(f).astype(np.int64)
    frac = (f - i0).astype(np.float32)
    i0 = np.mod(i0, cols_t)
    i1 = np.mod(i0 + 1, cols_t)
    hins = heights[:, i0] * (1 - frac) + heights[:, i1] * frac
    return np.insert(s_cols, pos, corners), np.insert(heights, pos, hins, axis=1)


@dataclass(frozen=True)
class _Analysis:
    """The dense analysis grid along the profile: samples ``s`` every ``delta`` mm,
    their frame ``fa``, the profile's segments, the raw and smoothed height factor
    (self-intersection limit) and the clearance it came from."""

    s: np.ndarray
    delta: float
    fa: Any
    period: float | None
    segs: tuple[np.ndarray, np.ndarray, np.ndarray]
    raw: np.ndarray
    w_lim: np.ndarray
    clearance: np.ndarray


def _analyse(profile: Profile, px: float, hmax: float, trans: float, mapping: str) -> _Analysis:
    L = profile.length
    delta = max(px / 2, L / 20000)
    na = max(8, int(np.ceil(L / delta)))
    s_a = np.linspace(0.0, L, na, endpoint=False) if profile.closed else np.linspace(0.0, L, na + 1)
    delta = L / na
    fa = profile.at(s_a)
    period = L if profile.closed else None
    segs_a = fa.point if profile.closed else fa.point[:-1]
    segs_b = np.roll(fa.point, -1, axis=0) if profile.closed else fa.point[1:]
    own = np.arange(len(s_a))
    if hmax > 0:
        if mapping == "angle":
            reach = _normal_reach(fa.point, fa.normal, hmax / FOLD_SHARE)
            raw, clearance = np.minimum(1.0, FOLD_SHARE * reach / hmax), reach
        else:
            up = np.stack([np.zeros(len(s_a)), fa.facing.astype(np.float64)], axis=1)
            gap = _ray_clearance(fa.point, up, segs_a, segs_b, own, hmax / GAP_SHARE, profile.closed)
            # Vertical stretches get no texture (the fade below); no limit from them.
            raw, clearance = np.where(fa.facing == 0, 1.0, np.minimum(1.0, GAP_SHARE * gap / hmax)), gap
        w_lim_a = _erode_smooth(raw, int(np.ceil(trans / 2 / delta)), profile.closed)
    else:
        raw = w_lim_a = np.ones(len(s_a))
        clearance = np.full(len(s_a), np.inf)
    return _Analysis(s_a, delta, fa, period, (segs_a, segs_b, own), raw, w_lim_a, clearance)


def _bottom_depth(profile: Profile, an: _Analysis, depth: float) -> tuple[np.ndarray, np.ndarray]:
    """The bottom along the smoothed inward normal (box-smoothed twice over 2 depth:
    its turning rate stays below 1 / depth even at convex corners, so the bottom
    cannot fold), depth limited to 0.4 of the inward gap to the profile:
    ``(smoothed normals, depth per analysis sample)``."""
    segs_a, segs_b, own = an.segs
    rad_n = int(np.ceil(2 * depth / an.delta))
    n_smooth_a = _unit(_box_smooth(an.fa.normal, rad_n, profile.closed))
    gap_in = _ray_clearance(an.fa.point, -n_smooth_a, segs_a, segs_b, own, depth / GAP_SHARE, profile.closed)
    d_a = _erode_smooth(np.minimum(depth, GAP_SHARE * gap_in), int(np.ceil(depth / an.delta)), profile.closed)
    # Locally thin material (a sharp tip, a sliver) only makes the slab thin there;
    # a profile whose material is thin almost everywhere cannot take this depth.
    if np.median(d_a) < 0.1 * depth or d_a.min() <= 0:
        k = int(np.argmin(d_a))
        x, z = an.fa.point[k]
        raise GeometryError(
            f"the profile's material is only about {gap_in[k]:.3g} mm thick at s = {an.s[k]:.2f} mm, "
            f"(x, z) = ({x:.2f}, {z:.2f}) mm: too thin for a {depth:g} mm deep texture slab; use a smaller depth"
        )
    return n_smooth_a, d_a


def _column_weights(profile: Profile, fc, s_all: np.ndarray, w_lim: np.ndarray, mapping: str, trans: float):
    """Per column: the height factor ``w`` (limit times the fades of section 2.2.1:
    no texture near division planes, smooth transitions) and the offset direction
    (the normal, or +-z by the piece's facing)."""
    period = profile.length if profile.closed else None
    if mapping == "distance":
        iv = [(a, b) for a, b, f in profile.function_pieces() if f == 0]
        iv += [(d, d) for d in profile.division_points()]
    else:
        iv = [(c.s, c.s) for c in profile.corners]
    iv_arr = np.array(iv, dtype=np.float64).reshape(-1, 2)
    w = w_lim * _smoothstep(_distance_to_intervals(s_all, iv_arr, period) / trans)
    if mapping == "angle":
        return w, fc.normal
    ncol = len(s_all)
    direction = np.stack([np.zeros(ncol), fc.facing.astype(np.float64)], axis=1)
    w = np.where(fc.facing == 0, 0.0, w)
    if not profile.closed:
        # An open end where the profile is steep (|n_z| < 0.5: the vertical is within
        # 60 degrees of the tangent) cannot take a vertical end wall: it would run
        # along the surface. Fade the texture out towards that end like towards a
        # division point; the wall then follows the normal.
        for k, dist in ((0, s_all - s_all[0]), (ncol - 1, s_all[-1] - s_all)):  # the two ends
            if abs(float(fc.normal[k, 1])) < 0.5:
                w = w * _smoothstep(dist / trans)
    return w, direction


def _end_wall_bottoms(fc, s_all, direction, w, u_c, d_c, depth: float, px: float) -> None:
    """The end walls of an open slab (in place on ``u_c``, ``d_c``): the bottom
    straight below the top's own direction (vertical, or the normal), so each end
    wall is one plane that the texture and bottom lie on one side of. Depth: `depth`
    along the normal, at most 2 depth along that direction. The bottom's direction
    turns from the smoothed normal to the end's direction over `ramp` mm
    (smoothstep), so neighbouring bottom points never swap places."""
    ncol = len(s_all)
    ramp = max(4.0 * depth, 8.0 * px)
    from_start = s_all - s_all[0]
    from_end = s_all[-1] - s_all
    for k, dist in ((0, from_start), (ncol - 1, from_end)):  # the two ends
        dk = direction[k] if (np.any(direction[k]) and w[k] > 0) else u_c[k]
        near = dist < min(ramp, 0.5 * (s_all[-1] - s_all[0]) + 1e-9)
        near &= (from_start > from_end) if k == ncol - 1 else (from_start <= from_end)  # the nearer end
        b = _smoothstep(dist[near] / ramp)[:, None]
        uu = _unit((1.0 - b) * dk[None, :] + b * u_c[near])
        cosn = np.maximum(np.einsum("ij,ij->i", uu, fc.normal[near]), 0.5)
        d_c[near] = d_c[near] * ((1.0 - b[:, 0]) / cosn + b[:, 0])
        u_c[near] = uu


def _bottom_into_material(profile: Profile, fc, s_all, u_c, px: float, period: float | None) -> None:
    """The bottom must leave every column into the material (in place on ``u_c``): at
    a corner inside the normal cone (else along the bisector of the two sides'
    normals; the smoothed normal turns fast at a sharp tip), elsewhere within 78
    degrees of the local normal. The end columns of an open profile keep their
    end-wall direction."""
    ncol = len(s_all)
    inner = np.ones(ncol, bool)
    if not profile.closed:
        inner[[0, -1]] = False
    at_corner = np.zeros(ncol, bool)
    for corner in profile.corners:  # one per corner
        gap_s = np.abs(s_all - corner.s)
        if period is not None:
            gap_s = np.minimum(gap_s, period - gap_s)
        k = int(np.argmin(gap_s))
        if gap_s[k] < 1e-6 * max(px, 1e-9) and inner[k]:
            before = profile.at(np.array([corner.s - 1e-7 * profile.length])).normal[0]
            at_corner[k] = True
            if min(float(u_c[k] @ before), float(u_c[k] @ fc.normal[k])) < 0.05:
                u_c[k] = _unit((before + fc.normal[k])[None, :])[0]
    off = (np.einsum("ij,ij->i", u_c, fc.normal) < 0.2) & ~at_corner & inner
    if off.any():
        u_c[off] = _unit(u_c[off] + 2.0 * fc.normal[off])


def _grids(h_all, v: np.ndarray, point: np.ndarray, y: np.ndarray, base_b: np.ndarray):
    """The top grid ``(R, C, 3)`` (profile point + h v) and the bottom's first and
    last row ``(2, C, 3)`` (the offset profile extruded along y), float32."""
    rows, ncol = np.shape(h_all)
    top = np.empty((rows, ncol, 3), dtype=np.float32)
    hf = np.asarray(h_all, dtype=np.float32)
    top[..., 0] = hf * v[:, 0].astype(np.float32)
    top[..., 0] += point[:, 0].astype(np.float32)
    top[..., 1] = y.astype(np.float32)[:, None]
    top[..., 2] = hf * v[:, 1].astype(np.float32)
    top[..., 2] += point[:, 1].astype(np.float32)
    bottom = np.empty((2, ncol, 3), dtype=np.float32)
    bottom[..., 0] = base_b[:, 0].astype(np.float32)[None, :]
    bottom[..., 1] = np.float32(y[[0, -1]])[:, None]
    bottom[..., 2] = base_b[:, 1].astype(np.float32)[None, :]
    return top, bottom


def _segment_crossings(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray, *, same: bool) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs ``(i, j)`` of 2-D segments ``p0[i] -> p1[i]`` and ``q0[j] -> q1[j]``
    (mm) that cross or touch, found by a k-d tree on midpoints and exact orientation
    tests. With ``same`` (the two sets are one polyline), pairs ``i < j`` that share an
    end point are neighbours and skipped."""
    mp, mq = 0.5 * (p0 + p1), 0.5 * (q0 + q1)
    reach = 0.5 * (float(np.linalg.norm(p1 - p0, axis=1).max(initial=0.0)) + float(np.linalg.norm(q1 - q0, axis=1).max(initial=0.0)))
    i, j = _pairs_within(mp, mq, reach * (1 + 1e-9) + 1e-12)
    if same:
        keep = i < j
        i, j = i[keep], j[keep]
        shared = (
            (np.abs(p0[i] - q0[j]).max(1) == 0)
            | (np.abs(p0[i] - q1[j]).max(1) == 0)
            | (np.abs(p1[i] - q0[j]).max(1) == 0)
            | (np.abs(p1[i] - q1[j]).max(1) == 0)
        )
        i, j = i[~shared], j[~shared]

    def orient(a, b, c):
        return np.sign((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))

    a, b, c, d = p0[i], p1[i], q0[j], q1[j]
    hit = (orient(a, b, c) * orient(a, b, d) <= 0) & (orient(c, d, a) * orient(c, d, b) <= 0)
    # Collinear, disjoint segments give all-zero orientations: require overlapping boxes.
    lo1, hi1 = np.minimum(a, b), np.maximum(a, b)
    lo2, hi2 = np.minimum(c, d), np.maximum(c, d)
    hit &= np.all((lo1 <= hi2) & (lo2 <= hi1), axis=1)
    return i[hit], j[hit]


def _resolve_bottom(p: np.ndarray, u: np.ndarray, d: np.ndarray, closed: bool, depth: float, px: float) -> np.ndarray:
    """The slab's bottom ``p - d u`` (``(C, 2)`` mm), with the depth halved locally
    until its cross-section polyline crosses neither itself nor the profile polyline.

    For an open profile the two end-wall spokes (profile to bottom at the end columns)
    are checked against both polylines too.

    Offsetting inwards along smoothed normals is safe on smooth material, but inside
    a sharp convex tip the offsets of the two sides cross (the inner offset of a wedge
    swallowtails at ``depth / sin(half angle)`` from the tip). Checked exactly
    (segment-pair orientation tests), resolved by halving the depth within
    ``2 depth`` mm of each crossing, up to 16 times (depth ``2^-16`` of the start).

    Raises:
        GeometryError: crossings remain (the profile crosses itself).
    """
    d = d.copy()
    n = len(p)
    nxt = np.roll(np.arange(n), -1) if closed else np.arange(1, n)
    cur = np.arange(n) if closed else np.arange(n - 1)
    spread = max(1, int(np.ceil(2.0 * depth / max(px, 1e-9))))
    for _ in range(17):  # a few halvings at most
        b = p - d[:, None] * u
        i1, j1 = _segment_crossings(b[cur], b[nxt], b[cur], b[nxt], same=True)
        i2, j2 = _segment_crossings(b[cur], b[nxt], p[cur], p[nxt], same=False)
        segs = np.concatenate([i1, j1, i2])
        if not closed and n > 2:
            # The open slab's end walls run from the profile to the bottom at the two
            # end columns: neither may cut the bottom or the profile elsewhere.
            ends = np.array([0, n - 1])
            own_seg = np.array([0, n - 2])  # the segment each spoke touches
            si, sj = _segment_crossings(p[ends], b[ends], b[cur], b[nxt], same=False)
            far = sj != own_seg[si]
            pi_, pj = _segment_crossings(p[ends], b[ends], p[cur], p[nxt], same=False)
            far_p = pj != own_seg[pi_]
            segs = np.concatenate([segs, sj[far], pj[far_p], own_seg[si[far]], own_seg[pi_[far_p]]])
        if segs.size == 0:
            return b
        bad = np.zeros(n, bool)
        bad[cur[segs]] = True
        bad[nxt[segs]] = True
        from scipy.ndimage import maximum_filter1d

        bad = maximum_filter1d(bad.astype(np.uint8), 2 * spread + 1, mode="wrap" if closed else "constant") > 0
        d[bad] *= 0.5
    k = int(cur[segs[0]])
    raise GeometryError(
        f"the texture slab's bottom crosses the profile at (x, z) = ({p[k, 0]:.2f}, {p[k, 1]:.2f}) mm even at "
        f"{d[k]:.2g} mm depth; does the profile cross itself there?"
    )


def _check_cells(profile: Profile, fc, hf: np.ndarray, v: np.ndarray, base_b: np.ndarray, mapping: str, w: np.ndarray) -> None:
    """Last line of defence for the textured surface: every cross-section cell must
    advance along the profile (the bottom is made simple by :func:`_resolve_bottom`)."""
    p = fc.point
    if profile.closed:
        nxt = np.roll(np.arange(len(p)), -1)
        cur = np.arange(len(p))
    else:
        cur, nxt = np.arange(len(p) - 1), np.arange(1, len(p))
    chord = p[nxt] - p[cur]
    c2 = np.einsum("ij,ij->i", chord, chord)
    if mapping == "angle":
        a = np.einsum("ij,ij->i", v[nxt], chord).astype(np.float32)
        b = np.einsum("ij,ij->i", v[cur], chord).astype(np.float32)
        adv = c2.astype(np.float32)[None, :] + hf[:, nxt] * a[None, :] - hf[:, cur] * b[None, :]
        bad = (adv <= 0).any(axis=0)
        where = "the textured surface"
    else:
        sig = fc.facing
        same = (sig[cur] == sig[nxt]) & (sig[cur] != 0) & (w[cur] > 0) & (w[nxt] > 0)
        bad = same & (np.sign(chord[:, 0]) != sig[cur])
        where = "the textured surface (x not monotonic within a function piece)"
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        x, z = p[cur[k]]
        raise GeometryError(
            f"{where} would fold at s = {fc.s[cur[k]]:.3f} mm, (x, z) = ({x:.2f}, {z:.2f}) mm; "
            "use a coarser pitch there, a smaller depth or a lower texture"
        )


def _limits(profile, s_all, w_lim, fc, s_a, raw, clearance, hmax, mapping) -> list[HeightLimit]:
    out = []
    for i, j in _runs(w_lim < 0.999, profile.closed):  # one per limited stretch
        idx = np.arange(i, j + 1) if i <= j else np.concatenate([np.arange(i, len(s_all)), np.arange(0, j + 1)])
        k = idx[np.argmin(w_lim[idx])]
        a = int(np.argmin(np.abs(s_a - s_all[k])))
        lo = max(0, a - 3)
        a = lo + int(np.argmin(raw[lo : a + 4]))
        c = float(clearance[a])
        if mapping == "angle":
            kap = float(profile.at(s_a[a]).curvature[0])
            if kap < 0 and c >= 0.9 / -kap:
                reason = f"concave radius of curvature {1 / -kap:.3g} mm (folds where h >= radius)"
            else:
                reason = f"the profile comes back within {2 * c:.3g} mm across (gap shared by both sides)"
        else:
            reason = f"vertical gap of {c:.3g} mm to the profile {'above' if fc.facing[k] > 0 else 'below'}"
        out.append(
            HeightLimit(
                float(s_all[i]),
                float(s_all[j]),
                (float(fc.point[k, 0]), float(fc.point[k, 1])),
                float(w_lim[k]),
                float(w_lim[k] * hmax),
                reason,
            )
        )
    return out

