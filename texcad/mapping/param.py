"""Parameterizations of any face in mm, and the texture grid laid on them.

A face (or a patch of faces that meet smoothly) arrives as a fine, accurate
tessellation: vertices ``V`` (mm), triangles ``F`` and, per vertex, texture
coordinates ``XY`` in mm (a *parameterization*: :func:`separable_coordinates` for
one face's own ``(u, v)`` corrected by its metric, :func:`lscm_coordinates` for a
conformal flattening, :func:`band_coordinates` for closed bands). The texture is then
laid on a regular grid in texture space, spacing the texture's pitch ``(px, py)``
mm: every grid point is located in the triangle of ``XY`` that contains it
(:func:`locate`) and placed on the surface by the barycentric interpolation of that
triangle's vertices (and normals). The grid carries the heights; the relief is a
closed slab over the grid (:func:`grid_slab`).

How well the parameterization keeps lengths is measured on the grid itself
(:func:`measure_distortion`): the 3-D distance between neighbouring grid points over
their texture spacing is the local texture scale (1 = the texture's nominal mm),
along x and y separately.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GeometryError
from ..solid import Mesh, surface_slab
from ..util import require_memory

__all__ = [
    "Distortion",
    "FaceGrid",
    "locate",
    "lay_grid",
    "measure_distortion",
    "separable_coordinates",
    "lscm_coordinates",
    "band_coordinates",
    "vertex_normals",
    "concave_convex",
    "point_scales",
    "metric_tables",
    "cell_mask",
    "grid_slab",
]


@dataclass(frozen=True)
class Distortion:
    """Local texture scale relative to the nominal mm, per texture direction.

    A value of 1.0 means one mm of texture is one mm on the surface; 1.2 means the
    texture is stretched by 20 % there. Figures are over the grid points that carry
    texture (area-weighted by the grid), in texture x and y separately.

    Attributes:
        x: ``(p5, p95, worst)`` of the scale along texture x (worst = farthest from 1).
        y: ``(p5, p95, worst)`` along texture y.
        faded_fraction: fraction of the textured grid points whose height was faded
            because the scale there left ``[FADE_FULL, 1 / FADE_FULL]``.
    """

    x: tuple[float, float, float]
    y: tuple[float, float, float]
    faded_fraction: float = 0.0

    def __str__(self) -> str:
        fx, fy = self.x, self.y
        return (
            f"texture scale x {fx[0]:.3f}..{fx[1]:.3f} (worst {fx[2]:.3f}), "
            f"y {fy[0]:.3f}..{fy[1]:.3f} (worst {fy[2]:.3f}); faded {100 * self.faded_fraction:.1f} %"
        )

    def to_dict(self) -> dict:
        return {"x": list(self.x), "y": list(self.y), "faded_fraction": self.faded_fraction}

    @staticmethod
    def combined(items: "list[Distortion]") -> "Distortion | None":
        """Several faces: the widest range of each figure."""
        items = [d for d in items if d is not None]
        if not items:
            return None

        def comb(axis):
            vals = [getattr(d, axis) for d in items]
            worst = max((v[2] for v in vals), key=lambda w: abs(np.log(max(w, 1e-9))))
            return (min(v[0] for v in vals), max(v[1] for v in vals), worst)

        return Distortion(comb("x"), comb("y"), float(max(d.faded_fraction for d in items)))


@dataclass
class FaceGrid:
    """The texture grid on a face: ``(R, C)`` points, row index along texture y,
    column index along texture x (as a Heightmap), mm.

    Attributes:
        xs, ys: texture coordinates of the columns and rows, mm.
        valid: ``(R, C)`` bool, the point lies on the face.
        points: ``(R, C, 3)`` float64 positions on the surface, mm (0 where invalid).
        normals: ``(R, C, 3)`` float64 unit outward normals.
        wrap_y: rows close around (the last row neighbours the first).
    """

    xs: np.ndarray
    ys: np.ndarray
    valid: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    wrap_y: bool = False


def vertex_normals(V: np.ndarray, F: np.ndarray, weld: float = 1e-6) -> np.ndarray:
    """Area-weighted unit vertex normals of a triangle mesh; vertices at the same
    position (within ``weld`` mm, e.g. the two sides of a seam) share one normal."""
    V = np.asarray(V, np.float64)
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    key = np.round(V / weld).astype(np.int64)
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    acc = np.zeros((inv.max() + 1, 3))
    for k in range(3):
        np.add.at(acc, inv[F[:, k]], fn)
    n = acc[inv]
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)


def locate(tri_xy: np.ndarray, x0: float, y0: float, px: float, py: float, shape: tuple[int, int]):
    """Which triangle holds each grid point ``(x0 + c px, y0 + r py)``.

    Every triangle is rasterized over the grid points of its bounding box (vectorized
    over all triangles at once) and the barycentric coordinates of each candidate are
    tested; a point on an edge shared by two triangles is kept once.

    Returns:
        ``(flat, tri, bary)``: flat grid indices ``r * C + c``, the triangle holding
        each, ``(N, 3)`` barycentric coordinates.
    """
    R, C = shape
    t = np.asarray(tri_xy, np.float64)
    c0 = np.ceil((t[..., 0].min(axis=1) - x0) / px - 1e-9).astype(np.int64).clip(0, C)
    c1 = np.floor((t[..., 0].max(axis=1) - x0) / px + 1e-9).astype(np.int64).clip(-1, C - 1)
    r0 = np.ceil((t[..., 1].min(axis=1) - y0) / py - 1e-9).astype(np.int64).clip(0, R)
    r1 = np.floor((t[..., 1].max(axis=1) - y0) / py + 1e-9).astype(np.int64).clip(-1, R - 1)
    w = np.maximum(c1 - c0 + 1, 0)
    h = np.maximum(r1 - r0 + 1, 0)
    n = w * h
    total = int(n.sum())
    require_memory(total * 96.0, f"locating {total} texture points on the face", "use a larger pitch")
    ti = np.repeat(np.arange(len(t)), n)
    start = np.concatenate([[0], np.cumsum(n)[:-1]])
    local = np.arange(total) - np.repeat(start, n)
    cc = c0[ti] + local % np.maximum(w[ti], 1)
    rr = r0[ti] + local // np.maximum(w[ti], 1)
    px_ = x0 + cc * px
    py_ = y0 + rr * py
    a, b, c = t[ti, 0], t[ti, 1], t[ti, 2]
    v0, v1 = b - a, c - a
    det = v0[:, 0] * v1[:, 1] - v0[:, 1] * v1[:, 0]
    ok = np.abs(det) > 1e-18
    det = np.where(ok, det, 1.0)
    qx, qy = px_ - a[:, 0], py_ - a[:, 1]
    l1 = (qx * v1[:, 1] - qy * v1[:, 0]) / det
    l2 = (v0[:, 0] * qy - v0[:, 1] * qx) / det
    l0 = 1.0 - l1 - l2
    eps = -1e-9
    inside = ok & (l0 >= eps) & (l1 >= eps) & (l2 >= eps)
    flat = (rr * C + cc)[inside]
    bary = np.stack([l0, l1, l2], axis=1)[inside]
    tri = ti[inside]
    flat, first = np.unique(flat, return_index=True)
    return flat, tri[first], np.clip(bary[first], 0.0, 1.0)


def lay_grid(
    V: np.ndarray,
    F: np.ndarray,
    XY: np.ndarray,
    pitch: tuple[float, float],
    *,
    normals: np.ndarray | None = None,
    origin: tuple[float, float] | None = None,
    period_y: float | None = None,
) -> FaceGrid:
    """Lay a texture grid of spacing ``pitch = (px, py)`` mm over a parameterized
    mesh (``V`` mm, ``F``, per-vertex texture coordinates ``XY`` mm).

    Grid point ``(r, c)`` sits at texture ``(x0 + (c + 1/2) px, y0 + (r + 1/2) py)``;
    its surface point is ``sum_k b_k V[F[t, k]]`` with the barycentric coordinates
    ``b`` of the point in triangle ``t`` of ``XY``. With ``period_y`` (closed faces:
    ``XY[:, 1]`` spans ``[y0, y0 + period_y]``) the rows close around.

    Raises:
        GeometryError: the parameterization covers no grid point (face too small).
    """
    px, py = float(pitch[0]), float(pitch[1])
    XY = np.asarray(XY, np.float64)
    lo, hi = XY.min(axis=0), XY.max(axis=0)
    if origin is None:
        origin = (float(lo[0]), float(lo[1]))
    x0, y0 = origin
    C = int(np.floor((hi[0] - x0) / px - 0.5)) + 1
    if period_y is not None:
        R = int(round(period_y / py))
    else:
        R = int(np.floor((hi[1] - y0) / py - 0.5)) + 1
    if C < 2 or R < 2:
        raise GeometryError(
            f"the face is {hi[0] - lo[0]:.2f} x {hi[1] - lo[1]:.2f} mm in texture space: smaller than a few "
            f"pixels at {px:.3g} mm; use a smaller pitch or a larger face"
        )
    require_memory(R * C * 120.0, f"a {R} x {C} texture grid on the face", "use a larger pitch")
    xs = x0 + (np.arange(C) + 0.5) * px
    ys = y0 + (np.arange(R) + 0.5) * py
    tri_xy = XY[F]
    if period_y is not None:
        # Triangles across the seam of a closed patch (coordinates that jump by the
        # period): move their low corners up by one period, locate on a taller grid
        # and fold the rows back.
        ty = tri_xy[..., 1]
        jump = (ty.max(axis=1) - ty.min(axis=1)) > 0.5 * period_y
        ty[jump] = np.where(ty[jump] < ty[jump].mean(axis=1, keepdims=True), ty[jump] + period_y, ty[jump])
        extra = int(np.ceil(max(0.0, float(ty.max()) - (y0 + period_y)) / py)) + 2
        flat, tri, bary = locate(tri_xy, xs[0], ys[0], px, py, (R + extra, C))
        flat = (flat // C % R) * C + flat % C
        flat, first = np.unique(flat, return_index=True)
        tri, bary = tri[first], bary[first]
    else:
        flat, tri, bary = locate(tri_xy, xs[0], ys[0], px, py, (R, C))
    V = np.asarray(V, np.float64)
    if normals is None:
        normals = vertex_normals(V, F)
    pts = np.zeros((R * C, 3))
    nrm = np.zeros((R * C, 3))
    corners = F[tri]
    pts[flat] = np.einsum("nk,nkd->nd", bary, V[corners])
    n = np.einsum("nk,nkd->nd", bary, normals[corners])
    nrm[flat] = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
    valid = np.zeros(R * C, bool)
    valid[flat] = True
    return FaceGrid(xs, ys, valid.reshape(R, C), pts.reshape(R, C, 3), nrm.reshape(R, C, 3), period_y is not None)


def _pairs(grid: FaceGrid):
    """Neighbour pairs along x and y: ``(scale_x (R, C-1), ok_x, scale_y, ok_y)``."""
    P, M = grid.points, grid.valid
    px = grid.xs[1] - grid.xs[0]
    py = grid.ys[1] - grid.ys[0]
    dx = np.linalg.norm(P[:, 1:] - P[:, :-1], axis=2) / px
    okx = M[:, 1:] & M[:, :-1]
    Pn = np.roll(P, -1, axis=0) if grid.wrap_y else P[1:]
    Mn = np.roll(M, -1, axis=0) if grid.wrap_y else M[1:]
    Pc, Mc = (P, M) if grid.wrap_y else (P[:-1], M[:-1])
    dy = np.linalg.norm(Pn - Pc, axis=2) / py
    oky = Mn & Mc
    return dx, okx, dy, oky


def point_scales(grid: FaceGrid) -> tuple[np.ndarray, np.ndarray]:
    """``(sx, sy)``: ``(R, C)`` local texture scale at every grid point (mean of its
    valid neighbour pairs along x and y; 1 where it has none)."""
    dx, okx, dy, oky = _pairs(grid)
    R, C = grid.valid.shape

    def spread(d, ok, axis, wrap):
        acc = np.zeros((R, C))
        cnt = np.zeros((R, C))
        dd = np.where(ok, d, 0.0)
        ok = ok.astype(np.float64)
        if axis == 1:
            acc[:, 1:] += dd
            acc[:, :-1] += dd
            cnt[:, 1:] += ok
            cnt[:, :-1] += ok
        else:
            if wrap:
                acc += dd + np.roll(dd, 1, axis=0)
                cnt += ok + np.roll(ok, 1, axis=0)
            else:
                acc[1:] += dd
                acc[:-1] += dd
                cnt[1:] += ok
                cnt[:-1] += ok
        return np.where(cnt > 0, acc / np.maximum(cnt, 1), 1.0)

    return spread(dx, okx, 1, False), spread(dy, oky, 0, grid.wrap_y)


def measure_distortion(grid: FaceGrid, where: np.ndarray, faded: np.ndarray | None = None) -> Distortion:
    """Distortion figures over the grid points ``where`` (``(R, C)`` bool)."""
    dx, okx, dy, oky = _pairs(grid)
    wx = okx & where[:, 1:] & where[:, :-1]
    wn = np.roll(where, -1, axis=0) if grid.wrap_y else where[1:]
    wc = where if grid.wrap_y else where[:-1]
    wy = oky & wn & wc

    def figs(d):
        if d.size == 0:
            return (1.0, 1.0, 1.0)
        p5, p95 = np.percentile(d, [5, 95])
        lo, hi = float(d.min()), float(d.max())
        worst = hi if abs(np.log(max(hi, 1e-9))) >= abs(np.log(max(lo, 1e-9))) else lo
        return (float(p5), float(p95), worst)

    ff = 0.0
    if faded is not None and where.any():
        ff = float((faded & where).sum() / where.sum())
    return Distortion(figs(dx[wx]), figs(dy[wy]), ff)


def concave_convex(grid: FaceGrid) -> tuple[np.ndarray, np.ndarray]:
    """``(concave, convex)``: ``(R, C)`` largest concave and convex curvature (1/mm,
    both >= 0) per grid point."""
    P, N, M = grid.points, grid.normals, grid.valid
    R, C = M.shape
    cc = np.zeros((R, C))
    cv = np.zeros((R, C))
    for a, b, ok, sa, sb in (
        ((P[:, :-1], N[:, :-1]), (P[:, 1:], N[:, 1:]), M[:, :-1] & M[:, 1:], np.s_[:, :-1], np.s_[:, 1:]),
        ((P[:-1], N[:-1]), (P[1:], N[1:]), M[:-1] & M[1:], np.s_[:-1, :], np.s_[1:, :]),
    ):  # two directions
        d = b[0] - a[0]
        k = np.einsum("...d,...d->...", b[1] - a[1], d) / np.maximum(np.einsum("...d,...d->...", d, d), 1e-18)
        k = np.where(ok, k, 0.0)
        for sl in (sa, sb):
            cc[sl] = np.maximum(cc[sl], -k)
            cv[sl] = np.maximum(cv[sl], k)
    return cc, cv


def separable_coordinates(
    uv: np.ndarray, u_table: tuple[np.ndarray, np.ndarray], v_table: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """Texture coordinates of a face's own parameters ``(u, v)`` corrected by its
    metric: ``x = X(v)``, ``y = Y(u)``, where ``X`` is the mean (over u) arc length
    along the v iso-lines and ``Y`` the mean (over v) arc length along the u
    iso-lines, each a monotone table ``(parameter, mm)``. On a face of revolution
    (OCCT: u = angle, v = meridian) ``X`` is exactly the meridian's arc length and
    ``Y = R_mean * theta``: the circumference changing with the radius shows as a
    texture scale ``r / R_mean`` along y, which :func:`measure_distortion` reports.

    Returns:
        ``(N, 2)`` texture x, y in mm.
    """
    x = np.interp(uv[:, 1], v_table[0], v_table[1])
    y = np.interp(uv[:, 0], u_table[0], u_table[1])
    return np.stack([x, y], axis=1)


def metric_tables(grid_pts: np.ndarray, us: np.ndarray, vs: np.ndarray):
    """The ``(u, Y(u))`` and ``(v, X(v))`` tables of :func:`separable_coordinates` from
    a ``(Nu, Nv, 3)`` sampling of the surface at ``us x vs`` (mm)."""
    du = np.linalg.norm(np.diff(grid_pts, axis=0), axis=2)  # (Nu-1, Nv)
    dv = np.linalg.norm(np.diff(grid_pts, axis=1), axis=2)  # (Nu, Nv-1)
    Y = np.concatenate([[0.0], np.cumsum(du.mean(axis=1))])
    X = np.concatenate([[0.0], np.cumsum(dv.mean(axis=0))])
    return (us, Y), (vs, X)


def lscm_coordinates(V: np.ndarray, F: np.ndarray, rotation: float = 0.0) -> np.ndarray:
    """Least-squares conformal flattening (libigl ``lscm``) of a disk-like mesh,
    scaled so that the flattened area equals the 3-D area (mm), turned so that x lies
    along the outline's edges where they run along two perpendicular directions (a
    box's top and fillets), else along the principal axis (:func:`_outline_turn`),
    then by ``rotation`` degrees (as a plane's frame, :func:`texcad.brep.frames.plane_frame`).

    Raises:
        GeometryError: the mesh has no boundary (a closed surface) or the flattening
            is degenerate.
    """
    import igl

    V = np.ascontiguousarray(V, np.float64)
    F = np.ascontiguousarray(F, np.int64)
    loop = igl.boundary_loop(F)
    if len(loop) < 3:
        raise GeometryError("the faces form a closed surface without a boundary; texture fewer faces at once")
    i0 = loop[0]
    d = np.linalg.norm(V[loop] - V[i0], axis=1)
    i1 = loop[int(np.argmax(d))]
    b = np.array([i0, i1], np.int64)
    bc = np.array([[0.0, 0.0], [float(d.max()), 0.0]])
    uv, _ = igl.lscm(V, F, b, bc)
    if not np.all(np.isfinite(uv)):
        raise GeometryError("the conformal flattening of the faces failed (degenerate triangles?)")
    a3 = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
    e0, e1 = uv[F[:, 1]] - uv[F[:, 0]], uv[F[:, 2]] - uv[F[:, 0]]
    a2s = 0.5 * (e0[:, 0] * e1[:, 1] - e0[:, 1] * e1[:, 0])
    if a2s.sum() < 0:
        uv[:, 1] = -uv[:, 1]
        a2s = -a2s
    if a2s.sum() <= 0:
        raise GeometryError("the conformal flattening of the faces is degenerate")
    uv *= np.sqrt(a3 / a2s.sum())
    c = uv - uv.mean(axis=0)
    turn = _outline_turn(c, loop)
    if rotation:
        a = np.radians(float(rotation))
        turn = np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]]) @ turn
    return c @ turn.T


#: How far the outline's edges must agree on one direction (modulo 90 degrees) for
#: :func:`_outline_turn` to square the texture with them: the length-weighted mean
#: resultant of their directions times 4 (1: all along two perpendicular directions).
OUTLINE_SQUARE = 0.5


def _outline_turn(c: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """The rotation ``(2, 2)`` that turns flattened coordinates ``c`` (N, 2) mm so that
    the texture's x lies along the outline's own edges where they mostly run along two
    perpendicular directions (a box's top and fillets: its edges), else along the
    principal axis. With ``theta_i`` the direction of outline edge ``i`` (``loop``:
    the boundary's vertices in order) and ``L_i`` its length,
    ``z = sum L_i exp(4 i theta_i) / sum L_i``; where ``|z|`` reaches
    :data:`OUTLINE_SQUARE` x is turned to ``arg(z) / 4`` plus the multiple of 90
    degrees nearest the principal axis (the long side stays along x)."""
    _, vec = np.linalg.eigh(c.T @ c)
    main = vec[:, 1]
    e = c[np.roll(loop, -1)] - c[loop]
    length = np.hypot(e[:, 0], e[:, 1])
    z = np.sum(length * np.exp(4j * np.arctan2(e[:, 1], e[:, 0]))) / max(float(length.sum()), 1e-300)
    if abs(z) >= OUTLINE_SQUARE:
        square = float(np.angle(z)) / 4.0
        a = square + np.pi / 2 * round((float(np.arctan2(main[1], main[0])) - square) / (np.pi / 2))
        main = np.array([np.cos(a), np.sin(a)])
    return np.array([[main[0], main[1]], [-main[1], main[0]]])


def band_coordinates(V: np.ndarray, F: np.ndarray, axis: np.ndarray, centre: np.ndarray) -> tuple[np.ndarray, float]:
    """Texture coordinates on a closed band around ``axis`` (e.g. the sides and
    rounded corners of a box): x = arc length around the cross-section (the 2.5D
    method's profile arc length), y = height along the surface (mm).

    The cross-section is the band's longest boundary loop seen along the axis (a
    polyline of the tessellation's own edge points); every vertex takes the share
    ``phi`` of the way around of its nearest point on it (exact for prismatic
    bands), times the band's mean perimeter (:func:`_mean_perimeter`: a cone band's
    cross-sections grow from one rim to the other, and the texture keeps its scale
    in the middle, not at the widest rim); y is the height along the surface
    (:func:`meridian_heights`: the meridian's arc length on a surface of revolution,
    the height on a prismatic band).

    Returns:
        ``(XY, perimeter)``: ``(N, 2)`` mm and the mean perimeter in mm.
    """
    V = np.asarray(V, np.float64)
    a = axis / np.linalg.norm(axis)
    e1 = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    q = V - centre
    import igl

    F = np.ascontiguousarray(F, np.int64)
    loop = igl.boundary_loop(F)
    if len(loop) < 8:
        raise GeometryError("cannot find the cross-section of the band of faces")
    ring = np.stack([q[loop] @ e1, q[loop] @ e2], axis=1)
    seg_a, seg_b = ring, np.roll(ring, -1, axis=0)
    seg = np.linalg.norm(seg_b - seg_a, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    perimeter = float(cum[-1])
    pts = np.stack([q @ e1, q @ e2], axis=1)
    x = np.empty(len(pts))
    best = np.full(len(pts), np.inf)
    d = seg_b - seg_a
    dd = np.maximum((d * d).sum(axis=1), 1e-18)
    for k0 in range(0, len(pts), 4096):  # per chunk of points: nearest segment of the section
        p = pts[k0 : k0 + 4096, None, :]
        t = np.clip(((p - seg_a) * d).sum(axis=2) / dd, 0.0, 1.0)
        dist = np.linalg.norm(p - (seg_a + t[..., None] * d), axis=2)
        j = np.argmin(dist, axis=1)
        r = np.arange(len(j))
        best[k0 : k0 + 4096] = dist[r, j]
        x[k0 : k0 + 4096] = cum[j] + t[r, j] * seg[j]
    mean = _mean_perimeter(V, F, x / perimeter, perimeter)
    return np.stack([x * (mean / perimeter), meridian_heights(V, F, a, q @ a)], axis=1), mean


def _mean_perimeter(V: np.ndarray, F: np.ndarray, phi: np.ndarray, perimeter: float) -> float:
    """The perimeter (mm) a band's texture is laid around at: the area-weighted
    geometric mean of the local perimeter ``1 / |grad_T phi|`` (``phi`` the share of
    the way around, unwrapped per triangle), so that the texture is stretched and
    squeezed alike across the band: ``2 pi r`` at a mean radius on a cone band, the
    cross-section's perimeter on a prismatic band; ``perimeter`` if there is no
    such mean."""
    p = phi[F]
    wrap = p.max(axis=1) - p.min(axis=1) > 0.5
    p = p + (wrap[:, None] & (p < 0.5))
    P = V[F]
    n = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    a2 = np.linalg.norm(n, axis=1)
    safe = np.maximum(a2, 1e-300)
    g = np.linalg.norm(np.einsum("ti,tik->tk", p, _corner_gradients(P, n / safe[:, None], safe)), axis=1)
    ok = (a2 > 0) & (g > 0) & np.isfinite(g)
    if not ok.any():
        return perimeter
    mean = float(np.exp(np.sum(a2[ok] * -np.log(g[ok])) / np.sum(a2[ok])))
    return mean if np.isfinite(mean) and mean > 0 else perimeter


def meridian_heights(V: np.ndarray, F: np.ndarray, axis: np.ndarray, heights: np.ndarray) -> np.ndarray:
    """Heights along a band's surface (mm): the function ``y`` on the mesh whose
    gradient is closest, in the least-squares sense over the area, to the unit
    tangent ``t = (a - (a . n) n) / |a - (a . n) n|`` (the axis ``a`` projected on
    each triangle's plane, normal ``n``: uphill along the surface),

        min_y  sum_T A_T |grad_T y - t_T|^2   =>   (G^T W G) y = G^T W t,

    with ``G`` the per-triangle gradient of a piecewise linear function
    (``grad_T y = sum_i y_i (n x e_i) / 2 A_T``, ``e_i`` the edge opposite corner ``i``)
    and ``W`` the triangle areas: the cotangent Laplacian (the heat method's Poisson
    step). On a surface of revolution ``y`` is the meridian's arc length, on a
    prismatic band the height itself, and a bulging or twisted band keeps its
    texture's scale along the surface instead of shrinking it by the cosine of the
    slope. A band whose triangles are all parallel to the axis returns ``heights``
    (``V @ a`` about any origin) as they are; otherwise ``y`` has their mean."""
    from scipy.sparse import coo_matrix, identity
    from scipy.sparse.linalg import spsolve

    a = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    P = V[F]
    N = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    twice = np.linalg.norm(N, axis=1)
    ok = twice > 1e-12 * max(1.0, float(twice.max(initial=0.0)))
    n = N[ok] / twice[ok, None]
    tilt = n @ a
    if not len(n) or float(np.abs(tilt).max()) < 1e-9:
        return heights
    t = a - tilt[:, None] * n
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-12)[:, None]
    Fk, area = F[ok], 0.5 * twice[ok]
    g = _corner_gradients(P[ok], n, twice[ok])  # (T, 3 corners, 3 coords)
    rows = (3 * np.arange(len(Fk)))[:, None, None] + np.arange(3)[None, None, :]  # gradient row per coordinate
    G = coo_matrix((g.ravel(), (np.broadcast_to(rows, g.shape).ravel(), np.repeat(Fk, 3, axis=1).ravel())),
                   shape=(3 * len(Fk), len(V))).tocsr()
    w = np.repeat(area, 3)
    L = (G.T.multiply(w) @ G).tocsc()
    rhs = G.T @ (w * t.ravel())
    y = spsolve(L + 1e-10 * float(L.diagonal().mean()) * identity(len(V), format="csc"), rhs)
    return y - y.mean() + float(np.mean(heights))


def _corner_gradients(P: np.ndarray, n: np.ndarray, twice: np.ndarray) -> np.ndarray:
    """``(T, 3, 3)`` the surface gradient of each corner's hat function on the
    triangles ``P`` ``(T, 3, 3)`` (unit normals ``n``, ``twice`` their areas):
    ``grad_T y = sum_i y_i (n x e_i) / 2 A_T``, ``e_i`` the edge opposite corner ``i``."""
    edges = np.stack([P[:, 2] - P[:, 1], P[:, 0] - P[:, 2], P[:, 1] - P[:, 0]], axis=1)  # opposite corner i
    return np.cross(n[:, None, :], edges) / twice[:, None, None]


def cell_mask(keep: np.ndarray, wrap_y: bool) -> np.ndarray:
    """Grid cells ``(r, c)`` (between points ``r, r+1`` and ``c, c+1``) whose four
    corners are all in ``keep``; cells that touch the rest only at a corner are
    dropped (a pinched vertex is not a manifold)."""
    K = keep
    Kn = np.roll(K, -1, axis=0) if wrap_y else K[1:]
    Kc = K if wrap_y else K[:-1]
    cells = Kc[:, :-1] & Kc[:, 1:] & Kn[:, :-1] & Kn[:, 1:]
    for _ in range(64):  # per cleaning round, vectorized over the grid
        Rc, Cc = cells.shape
        pad = np.zeros((Rc + 2, Cc + 2), bool)
        pad[1:-1, 1:-1] = cells
        if wrap_y:
            pad[0, 1:-1], pad[-1, 1:-1] = cells[-1], cells[0]
        a, b = pad[:-1, :-1], pad[:-1, 1:]
        c, d = pad[1:, :-1], pad[1:, 1:]
        pinch = (a & d & ~b & ~c) | (b & c & ~a & ~d)
        if not pinch.any():
            break
        # Drop the lower-left cell (a or b) of every pinched corner.
        drop = np.zeros_like(pad)
        drop[:-1, :-1] |= pinch & a & d
        drop[:-1, 1:] |= pinch & b & c
        cells &= ~drop[1:-1, 1:-1]
        if wrap_y:
            cells[-1] &= ~drop[0, 1:-1]
    return cells


def grid_slab(top: np.ndarray, bottom: np.ndarray, cells: np.ndarray, wrap_y: bool) -> Mesh:
    """A closed slab over the grid cells ``cells``: the top surface ``top`` (R, C, 3)
    outward, the bottom ``bottom`` facing in, and walls along the cells' outline.

    Raises:
        GeometryError: no cell.
    """
    R, C = top.shape[:2]
    if not cells.any():
        raise GeometryError("no texture cell is left on the face (too small or narrow at this pitch)")
    idx = np.arange(R * C).reshape(R, C)
    rr, cc = np.nonzero(cells)
    rn = (rr + 1) % R
    a, b = idx[rr, cc], idx[rr, cc + 1]
    d, c = idx[rn, cc], idx[rn, cc + 1]
    tri = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    mark = np.zeros(R * C, bool)
    mark[tri.ravel()] = True
    used = np.flatnonzero(mark)
    remap = np.full(R * C, -1, np.int64)
    remap[used] = np.arange(len(used))
    tri = remap[tri]
    return surface_slab(top.reshape(-1, 3)[used], bottom.reshape(-1, 3)[used], tri)
