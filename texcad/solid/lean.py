"""Lean meshes: error-bounded adaptive triangulation of a heightfield.

A texture of ``R x C`` pixels is a surface through ``R C`` points, one per pixel
centre (the one-vertex-per-pixel mesh of :func:`texcad.solid.heightfield_slab`). Most
of those points carry nothing a printer can resolve: flat ground, straight ramps,
smooth stones. :func:`triangulate` keeps only the grid points needed so that the
triangulated surface stays within ``tolerance`` mm of every pixel centre's height,
by greedy insertion (Garland and Heckbert's algorithm, as implemented by fogleman's
``hmm`` and wrapped by pydelatin). Every kept vertex is a grid point at its exact
height, so M-I ramps and borders are approximated like any other part of the
heightfield; the grid's four corners are always kept and the boundary is a chain
of grid points on the grid's outer rows and columns, from which the slab's walls
are built (so the slab stays watertight).

:func:`surface_error` measures the error independently of the triangulation: it
rasterizes every triangle onto the pixel grid (exact integer barycentric tests,
vectorized) and compares the interpolated height with the heightmap at every pixel
centre. That number, not the triangulator's own estimate, is what texcad reports.

Functions here are pure: arrays in, arrays out (numpy, pydelatin); units are mm for
heights and tolerances, pixels for the ``(row, col)`` grid indices.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import GeometryError, ParameterError
from ..util import argsort_ints, rowmin

__all__ = [
    "DEFAULT_TOLERANCE",
    "MAX_FRACTION",
    "check_tolerance",
    "triangulate",
    "surface_error",
    "mesh_error",
    "boundary_chains",
    "grid_distance",
    "tiled_triangulation",
    "lean_tile",
    "TILE",
    "BORDER_GRID",
]

#: Default largest height error in mm of a lean mesh at any pixel centre: a tenth of
#: a fine 0.2 mm layer, far below what an FDM or resin printer resolves.
DEFAULT_TOLERANCE = 0.02


def check_tolerance(tolerance: float) -> float:
    """``tolerance`` as a float, or :class:`ParameterError` if it is not a number
    of mm >= 0 (0 = one vertex per pixel)."""
    try:
        t = float(tolerance)
    except (TypeError, ValueError):
        raise ParameterError(f"tolerance must be a number of mm >= 0, got {tolerance!r}") from None
    if not (np.isfinite(t) and t >= 0):
        raise ParameterError(f"tolerance must be a number of mm >= 0 (0 = one vertex per pixel), got {tolerance!r}")
    return t


#: Largest share of the pixel grid's triangles a lean mesh may keep; beyond it the
#: grid itself is used: noisy textures (leather, sand: 0.82 of the grid at 0.02 mm)
#: gain little, and greedy insertion and manifold3d's union were slower on the
#: lean mesh than on the grid (benchmarks/bench_lean.py).
MAX_FRACTION = 0.5


def triangulate(
    heights: np.ndarray,
    tolerance: float,
    *,
    max_fraction: float = MAX_FRACTION,
    full_border: bool = False,
    fans: bool = False,
) -> "tuple[np.ndarray, np.ndarray] | None":
    """Triangulate a heightfield so that it stays within ``tolerance`` mm of every
    grid point (greedy insertion, pydelatin).

    Args:
        heights: ``(R, C)`` heights in mm, one per pixel centre; finite; R, C >= 2.
        tolerance: largest height error in mm at a grid point, > 0.

        max_fraction: stop when the triangulation reaches this share of the
            pixel grid's ``2 (R-1)(C-1)`` triangles without meeting the tolerance.
        full_border: keep every grid point on the four sides: the sides are those of
            the pixel grid, for walls and seams built from the full grid's border. The
            grid without its outer ring is triangulated within the tolerance and
            joined to the ring by a strip one pixel wide whose triangles add no error
            (:func:`_framed`), so the result is within the tolerance by construction.
        fans: with ``full_border``, the whole grid triangulated and the triangles
            along the sides made fans onto every side point instead: their facets
            keep the slopes of the triangles they split (a strip one pixel wide has
            steep slivers where the inside's boundary edges are long, which an
            overhang check may refuse), but a fan can move the surface by up to the
            tolerance again: measure the result (:func:`surface_error`).

    Returns:
        None if the tolerance needs more than ``max_fraction`` of the grid's
        triangles (use the grid), else
        ``(rc, faces)``: ``rc`` ``(N, 2)`` int64 ``(row, col)`` of the kept grid
        points, sorted row-major (so the same heights give the same arrays), and
        ``faces`` ``(M, 3)`` uint32 indices into ``rc``, counter-clockwise with
        columns to the right and rows up (the orientation of
        :func:`texcad.solid.grid_faces`). Includes the four corners.

    Raises:
        ParameterError: bad tolerance or heights.
    """
    t = check_tolerance(tolerance)
    if t <= 0:
        raise ParameterError("triangulate needs a tolerance > 0 mm; tolerance 0 is the full pixel grid")
    h = np.ascontiguousarray(heights, dtype=np.float32)
    if h.ndim != 2 or min(h.shape) < 2:
        raise ParameterError(f"heights must be a 2-D array of at least 2 x 2 pixels, got shape {h.shape}")
    if not np.isfinite(h).all():
        raise ParameterError("heights must be finite (no NaN or inf)")
    rows, cols = h.shape
    # hmm keeps ~1 triangle per 3 px at worst on noise; 80 bytes per grid point is its
    # peak (float heights, error raster, priority queue) with ours on top.
    from ..util import require_memory

    require_memory(rows * cols * 80.0, f"a lean triangulation of {rows} x {cols} px", "use a larger pitch")
    budget = max(2, int(max_fraction * 2 * (rows - 1) * (cols - 1)))
    if full_border and not fans:
        got = _framed(h, t, budget)
    else:
        got = _greedy(h, t, budget)
    if got is None:
        return None
    rc, faces = got
    if full_border and fans:
        rc, faces = _fill_border(rc, faces, rows, cols)
    # Row-major faces (by their first vertex): manifold3d builds its half-edges from a
    # coherent order three times faster (0.6 s instead of 1.8 s CPU, demo plate).
    faces = faces[argsort_ints(np.minimum(np.minimum(faces[:, 0], faces[:, 1]), faces[:, 2]))].astype(np.uint32)
    r, c = rc[:, 0][faces], rc[:, 1][faces]  # (M, 3) each: one gather per column
    area2 = (c[:, 1] - c[:, 0]) * (r[:, 2] - r[:, 0]) - (r[:, 1] - r[:, 0]) * (c[:, 2] - c[:, 0])
    if not (area2 > 0).all():
        raise GeometryError(
            f"the lean triangulation has {int((area2 <= 0).sum())} degenerate or flipped triangles; "
            "use tolerance=0 (one vertex per pixel) and please report this"
        )
    if int(area2.sum()) != 2 * (rows - 1) * (cols - 1):
        raise GeometryError("the lean triangulation does not cover the grid; use tolerance=0 and please report this")
    return rc, faces


def _greedy(h: np.ndarray, t: float, budget: int) -> "tuple[np.ndarray, np.ndarray] | None":
    """Greedy insertion (pydelatin) on float32 heights ``h`` within ``t`` mm: ``(rc,
    faces)`` int64 (``rc`` row-major, faces counter-clockwise with columns right and
    rows up), or None past ``budget`` triangles."""
    from pydelatin import Delatin

    rows, cols = h.shape
    d = Delatin(h, max_error=t, max_triangles=budget)
    if d.error > t:
        return None
    v = d.vertices
    tri = d.triangles.astype(np.int64)
    # pydelatin's x is the column and y counts rows from the bottom (y = R - 1 - row).
    col = np.rint(v[:, 0]).astype(np.int64)
    row = rows - 1 - np.rint(v[:, 1]).astype(np.int64)
    order = np.argsort(row * cols + col)  # row-major (the keys are distinct)
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    # Counter-clockwise in (x, y_up) is clockwise in (col, row): swap two corners.
    return np.stack([row[order], col[order]], axis=1), inv[tri[:, [0, 2, 1]]]


def _framed(h: np.ndarray, t: float, budget: int) -> "tuple[np.ndarray, np.ndarray] | None":
    """:func:`triangulate` with every point of the four sides kept, exact by
    construction: the inside (the grid without its outer ring) is triangulated within
    ``t`` (:func:`_greedy`) and joined to the full outer ring by a strip one pixel
    wide on each side (:func:`_strip`). A strip triangle has its corners on the
    outer line and the inside's boundary line, so the pixel centres it covers are
    outer points (kept, exact) or lie on an edge of the inside's boundary, where the
    inside's triangles already are within ``t``: the whole grid is within ``t``
    with no second measure or retry. Grids under 4 px a side: the pixel grid."""
    from .grid import grid_faces

    rows, cols = h.shape
    if rows < 4 or cols < 4:
        g = np.stack(np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"), -1).reshape(-1, 2)
        return g, grid_faces(rows, cols).astype(np.int64)
    core = np.ascontiguousarray(h[1:-1, 1:-1])
    # hmm measures in float32: the bound lowered by a few ulps of the highest height, so
    # that the float64 measure (surface_error) is within t too.
    run = t - 16 * float(np.finfo(np.float32).eps) * max(float(np.abs(core).max()), 1.0)
    inner = _greedy(core, run, budget) if run > 0 else None
    if inner is None:
        return None
    irc, ifaces = inner
    irc = irc + 1
    ring = np.zeros((rows, cols), bool)
    ring[[0, -1], :] = True
    ring[:, [0, -1]] = True
    rkey = np.flatnonzero(ring)
    key = np.concatenate([irc[:, 0] * cols + irc[:, 1], rkey])  # distinct: the inside has no ring point
    order = np.argsort(key)
    slot = np.empty_like(order)
    slot[order] = np.arange(len(order))
    rc = np.stack([key[order] // cols, key[order] % cols], axis=1)
    inside_chains = boundary_chains(irc - 1, rows - 2, cols - 2)
    outer_chains = boundary_chains(np.stack([rkey // cols, rkey % cols], axis=1), rows, cols)
    n_in = len(irc)
    strips = [_strip(slot[n_in + o], slot[i], rc) for o, i in zip(outer_chains, inside_chains)]  # per side
    return rc, np.concatenate([slot[ifaces], *strips])


def _strip(outer: np.ndarray, inner: np.ndarray, rc: np.ndarray) -> np.ndarray:
    """The triangles between two parallel lines of points one pixel apart, both
    running counter-clockwise round the grid (``outer`` on the grid's side, ``inner``
    on the inside's boundary, corner to corner; indices into ``rc``): the two chains
    zipped in the order of their points along the side (an outer point first on a
    tie), each step a triangle onto the chain's next point. Any such order tiles the
    strip (its rungs do not cross); counter-clockwise with columns right, rows up."""
    d = rc[outer[-1]] - rc[outer[0]]
    d = np.sign(d)  # the side's direction: (0, 1), (1, 0), (0, -1) or (-1, 0)
    pos = np.concatenate([rc[outer[1:]] @ d, rc[inner[1:]] @ d])
    is_in = np.r_[np.zeros(len(outer) - 1, bool), np.ones(len(inner) - 1, bool)]
    ev = np.lexsort((is_in, pos))  # along the side, an outer point first on a tie
    kind = is_in[ev]
    k = np.cumsum(~kind)  # the outer chain's point after each step
    m = np.cumsum(kind)  # the inner chain's
    tri = np.where(kind[:, None],
                   np.stack([outer[k], inner[m], inner[np.maximum(m - 1, 0)]], 1),
                   np.stack([outer[np.maximum(k - 1, 0)], outer[k], inner[m]], 1))
    return tri.astype(np.int64)


#: Tile size in px of :func:`tiled_triangulation` (its tile borders keep every grid
#: point: about 2 / TILE more vertices than one triangulation of the whole grid).
TILE = 96
#: Width in px of the strips along the sides that :func:`tiled_triangulation` keeps as
#: the pixel grid when a build direction is given: measured on stones limited for a
#: 60-degree tilt, the lean facets that overhang (at the critical angle + 1 degree)
#: touch the side, at any tolerance; the rest are fixed by a tighter tile.
BORDER_GRID = 3


def tiled_triangulation(
    heights: np.ndarray,
    tolerance: float,
    *,
    tile: int = TILE,
    accept: "Callable[[np.ndarray, np.ndarray], bool | float] | None" = None,
    border_grid: int = 0,
    max_fraction: float = MAX_FRACTION,
) -> "tuple[np.ndarray, np.ndarray] | None":
    """:func:`triangulate` tile by tile, each tile checked on its own.

    The grid is cut into tiles of about ``tile`` px that share their border rows and
    columns; each is triangulated with every border point kept (``full_border``), so
    neighbouring tiles meet on the same vertices whatever each keeps inside, and a
    tile can be redone alone. Each tile is within ``tolerance`` (:func:`lean_tile`:
    by construction; with ``accept``, its sides joined by fans, measured and
    tightened where it misses), and ``accept(rc, faces)`` (grid points ``(row, col)`` of the
    whole grid and the tile's triangles) says whether a tile's triangulation is good
    (e.g. its 3-D error, or that no facet overhangs): True accepts it, False or a
    number ``x`` > 1 (the error came out ``x`` times the tolerance) rejects it, and
    the tile is redone with 0.6 (or ``0.9 / x``) of the bound, twice at most, then
    as the pixel grid (always accepted).

    Args:
        heights: ``(R, C)`` field in mm.
        tolerance: mm, > 0.
        tile: tile size in px (>= 2).
        accept: optional check of one tile (see above).
        border_grid: strips this many px wide along the four sides are kept as the
            pixel grid (the feet of the M-I ramps, where lean slivers along the side
            would overhang: :data:`BORDER_GRID`).
        max_fraction: None is returned when the result keeps more than this share of
            the grid's triangles, or (without finishing: noisy textures) when the
            tiles done, a quarter of the grid or more, keep more than that share.

    Returns:
        ``(rc, faces)`` as :func:`triangulate` (every tile border point kept), or None.
    """
    h = np.asarray(heights, dtype=np.float32)
    rows, cols = h.shape
    tile = max(2, int(tile))
    b = max(0, int(border_grid))

    def cuts(n: int) -> np.ndarray:
        if n - 1 <= 2 * b + 1:
            return np.array([0, n - 1])
        return np.unique(np.r_[0, np.arange(b, n - 1 - b, tile), n - 1 - b, n - 1])

    rcuts, ccuts = cuts(rows), cuts(cols)
    all_rc, all_f, base = [], [], 0
    total, done, kept = 2 * (rows - 1) * (cols - 1), 0, 0
    for r0, r1 in zip(rcuts[:-1], rcuts[1:]):  # per tile
        for c0, c1 in zip(ccuts[:-1], ccuts[1:]):
            strip = b > 0 and (r0 < b or c0 < b or r1 > rows - 1 - b or c1 > cols - 1 - b)
            here = None if accept is None else (lambda rc, f, o=np.array([r0, c0]): accept(rc + o, f))  # noqa: E731
            rc, f, _ = lean_tile(h[r0 : r1 + 1, c0 : c1 + 1], tolerance, accept=here, grid=strip, measure=False)
            all_rc.append(rc + np.array([r0, c0]))
            all_f.append(f + base)
            base += len(rc)
            done += 2 * (r1 - r0) * (c1 - c0)
            kept += len(f)
            if done >= total / 4 and kept > max_fraction * done:  # noisy: the grid it is
                return None
    rc = np.concatenate(all_rc)
    faces = np.concatenate(all_f)
    if len(faces) > max_fraction * 2 * (rows - 1) * (cols - 1):
        return None
    key, inv = np.unique(rc[:, 0] * cols + rc[:, 1], return_inverse=True)
    faces = inv.reshape(-1)[faces]
    faces = faces[argsort_ints(rowmin(faces))]  # row-major, as triangulate's
    return np.stack([key // cols, key % cols], axis=1), faces.astype(np.uint32)


def lean_tile(
    heights: np.ndarray,
    tolerance: float,
    *,
    accept: "Callable[[np.ndarray, np.ndarray], bool | float] | None" = None,
    grid: bool = False,
    max_fraction: "float | None" = None,
    measure: bool = True,
) -> tuple[np.ndarray, np.ndarray, float]:
    """One tile of a lean mesh whose border keeps every grid point, within
    ``tolerance`` mm of every pixel centre: ``(rc, faces, error)``.

    The tile is triangulated with its four sides at full resolution
    (:func:`triangulate` with ``full_border``: within the tolerance by construction,
    once), so a neighbouring tile that does the same meets it on the same points and
    edges whatever each keeps inside. ``accept(rc, faces)`` may reject it (True
    accepts; False or a number ``x`` > 1, e.g. a 3-D error ``x`` times the bound,
    rejects): a rejected tile is redone with 0.6 (or ``0.9 / x``) of the bound, twice
    at most, then made as the pixel grid (error 0, always accepted). With ``accept``
    the sides are joined by fans (``fans``: facets as the inside's, for a check of
    their angle), the error measured and the tile redone tighter where it misses.

    Args:
        heights: ``(r, c)`` heights in mm, r, c >= 2.
        tolerance: mm, > 0.
        accept: optional check of the tile's triangulation (tile-local ``rc``).
        grid: make the pixel grid straight away.
        max_fraction: the pixel grid when the lean tile keeps more than this share
            of the grid's ``2 (r-1)(c-1)`` triangles (None: no such limit).
        measure: measure the error at every pixel centre (:func:`surface_error`);
            False: ``error`` is NaN for a lean tile (the caller measures it, e.g.
            texcad's gate, tile by tile).

    Returns:
        ``rc`` ``(N, 2)`` int64 tile-local ``(row, col)`` of the kept points (the grid's
        row-major order for the pixel grid), ``faces`` ``(M, 3)`` int64 indices into
        ``rc`` (counter-clockwise with columns right and rows up), ``error`` mm (the
        measured largest height error, 0 for the grid).
    """
    from .grid import grid_faces

    sub = np.asarray(heights, dtype=np.float32)
    r, c = sub.shape
    run = float(tolerance)
    for _ in range(0 if grid else 3):  # tighter bounds (a missed error, the check's rejections), then the grid
        lean = triangulate(sub, run, max_fraction=1.0, full_border=True, fans=accept is not None)
        if lean is None:
            break
        rc, f = lean[0], lean[1].astype(np.int64)
        err = None
        if accept is not None:  # fans onto the border (their facets keep the inside's slopes): measured
            err = surface_error(sub, rc, sub[rc[:, 0], rc[:, 1]], f)
            if err > tolerance:
                run *= 0.9 * tolerance / err
                continue
        verdict = True if accept is None else accept(rc, f)
        if verdict is True:
            if max_fraction is not None and len(f) > max_fraction * 2 * (r - 1) * (c - 1):
                break
            if err is None:
                err = surface_error(sub, rc, sub[rc[:, 0], rc[:, 1]], f) if measure else float("nan")
            return rc, f, err
        run *= 0.6 if verdict is False else 0.9 / max(float(verdict), 1.0 + 1e-9)
    g = np.stack(np.meshgrid(np.arange(r), np.arange(c), indexing="ij"), -1).reshape(-1, 2)
    return g, grid_faces(r, c).astype(np.int64), 0.0


def _fill_border(rc: np.ndarray, faces: np.ndarray, rows: int, cols: int) -> tuple[np.ndarray, np.ndarray]:
    """Every grid point on the four sides added to a triangulation ``(rc, faces)``:
    a triangle whose edge runs along a side over skipped grid points becomes a fan
    from its opposite vertex onto them (same orientation); repeated for triangles
    with two such edges (at the corners)."""
    key = rc[:, 0] * cols + rc[:, 1]
    kept = np.zeros((rows, cols), dtype=bool)
    kept.ravel()[key] = True
    kept[[0, -1], :] = True
    kept[:, [0, -1]] = True
    allkey = np.flatnonzero(kept)  # row-major, like triangulate's rc
    slot = np.cumsum(kept.ravel()) - 1  # grid index -> index into allkey
    out = np.stack([allkey // cols, allkey % cols], axis=1)
    f = slot[key][faces]
    for _ in range(4):  # a triangle has at most two edges along the sides
        a, b = out[f], out[np.roll(f, -1, axis=1)]  # (M, 3, 2): edge k runs f[k] -> f[k+1]
        along_r = (a[..., 0] == b[..., 0]) & ((a[..., 0] == 0) | (a[..., 0] == rows - 1))
        along_c = (a[..., 1] == b[..., 1]) & ((a[..., 1] == 0) | (a[..., 1] == cols - 1))
        gap = np.where(along_r, np.abs(a[..., 1] - b[..., 1]), np.where(along_c, np.abs(a[..., 0] - b[..., 0]), 0))
        long = gap > 1
        if not long.any():
            return out, f
        tri = np.flatnonzero(long.any(axis=1))
        e = np.argmax(long[tri], axis=1)
        u, v, apex = f[tri, e], f[tri, (e + 1) % 3], f[tri, (e + 2) % 3]
        n = gap[tri, e]
        step = np.sign(out[v] - out[u])  # (T, 2): along the side
        k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        start = np.repeat(out[u], n, axis=0) + k[:, None] * np.repeat(step, n, axis=0)
        p0 = slot[start[:, 0] * cols + start[:, 1]]
        nxt = start + np.repeat(step, n, axis=0)
        p1 = slot[nxt[:, 0] * cols + nxt[:, 1]]
        keep = np.ones(len(f), bool)
        keep[tri] = False
        f = np.concatenate([f[keep], np.stack([p0, p1, np.repeat(apex, n)], axis=1)])
    raise GeometryError("could not fill the lean triangulation's border; use tolerance=0 and please report this")


def boundary_chains(rc: np.ndarray, rows: int, cols: int) -> tuple[np.ndarray, ...]:
    """Indices into ``rc`` of the kept vertices on the grid's four sides, each from
    corner to corner, counter-clockwise seen from +z (columns right, rows up): row 0
    by increasing column, the last column by increasing row, the last row by
    decreasing column, column 0 by decreasing row (the sides of
    :func:`texcad.solid.heightfield_slab`)."""
    r, c = rc[:, 0], rc[:, 1]
    idx = np.arange(len(rc))
    s0 = idx[r == 0][np.argsort(c[r == 0], kind="stable")]
    s1 = idx[c == cols - 1][np.argsort(r[c == cols - 1], kind="stable")]
    s2 = idx[r == rows - 1][np.argsort(-c[r == rows - 1], kind="stable")]
    s3 = idx[c == 0][np.argsort(-r[c == 0], kind="stable")]
    return s0, s1, s2, s3


def _pixel_pairs(rc: np.ndarray, faces: np.ndarray, rows: int, cols: int, chunk: int):
    """The (triangle, pixel) pairs of a triangulation of grid points: each triangle
    (vertices ``rc[faces]``, ``(row, col)``) rasterized by scanlines, for every grid row
    it spans the columns between its edges inclusive (shared edges belong to both
    neighbours). Yields ``(t, row, col)`` int arrays in batches of about ``chunk``
    (triangle, row) pairs; raises :class:`GeometryError` at the end if a pixel centre
    was not covered (the triangles do not tile the grid) or a triangle has no area."""
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        raise GeometryError("no triangles to measure")
    pr, pc = rc[f, 0].astype(np.float64), rc[f, 1].astype(np.float64)  # (M, 3)
    det = (pc[:, 1] - pc[:, 0]) * (pr[:, 2] - pr[:, 0]) - (pr[:, 1] - pr[:, 0]) * (pc[:, 2] - pc[:, 0])
    if not (det != 0).all():
        raise GeometryError(f"{int((det == 0).sum())} triangles have no area")
    # Vertices sorted by row: top (0), middle (1), bottom (2) of each triangle.
    o = np.argsort(pr, axis=1, kind="stable")
    sr = np.take_along_axis(pr, o, axis=1)
    sc = np.take_along_axis(pc, o, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        s02 = (sc[:, 2] - sc[:, 0]) / (sr[:, 2] - sr[:, 0])
        s01 = np.where(sr[:, 1] > sr[:, 0], (sc[:, 1] - sc[:, 0]) / (sr[:, 1] - sr[:, 0]), 0.0)
        s12 = np.where(sr[:, 2] > sr[:, 1], (sc[:, 2] - sc[:, 1]) / (sr[:, 2] - sr[:, 1]), 0.0)
    r0 = sr[:, 0].astype(np.int32)
    nrow = sr[:, 2].astype(np.int32) - r0 + 1
    covered = np.zeros(rows * cols, dtype=bool)
    ends = np.cumsum(nrow)
    cut = np.searchsorted(ends, np.arange(chunk, int(ends[-1]), chunk), side="left")
    lo = 0
    for hi in list(cut) + [len(f)]:  # per batch
        if hi <= lo:
            continue
        n = nrow[lo:hi]
        t = np.repeat(np.arange(lo, hi, dtype=np.int32), n)
        dri = np.arange(len(t), dtype=np.int32) - np.repeat((np.cumsum(n) - n).astype(np.int32), n)
        dr = dri.astype(np.float64)  # rows below the top
        x_long = sc[t, 0] + dr * s02[t]
        mid = sr[t, 1] - sr[t, 0]
        x_short = np.where(dr < mid, sc[t, 0] + dr * s01[t], sc[t, 1] + (dr - mid) * s12[t])
        x_short = np.where(dr == mid, sc[t, 1], x_short)
        cl = np.ceil(np.minimum(x_long, x_short) - 1e-9).astype(np.int32)
        cu = np.floor(np.maximum(x_long, x_short) + 1e-9).astype(np.int32)
        span = np.maximum(cu - cl + 1, 0)
        tt = np.repeat(t, span)
        rr = np.repeat(r0[t] + dri, span)
        cc = np.repeat(cl - (np.cumsum(span) - span).astype(np.int32), span) + np.arange(len(tt), dtype=np.int32)
        covered[rr.astype(np.int64) * cols + cc] = True
        yield tt, rr, cc
        lo = hi
    if not covered.all():
        raise GeometryError(
            f"{int((~covered).sum())} pixel centres are not covered by any triangle; the mesh does not tile the grid"
        )


def surface_error(
    heights: np.ndarray,
    rc: np.ndarray,
    z: np.ndarray,
    faces: np.ndarray,
    *,
    chunk: int = 1 << 21,
) -> float:
    """The largest ``|surface - height|`` in mm over every pixel centre.

    Each triangle (vertices at grid points ``rc`` with heights ``z`` mm) is
    rasterized onto the pixel grid by scanlines: for every grid row it spans, the
    columns between its edges (inclusive, so shared edges are measured by both
    neighbours) get the height of the triangle's plane there. Every pixel centre
    must be covered, else the triangles do not tile the grid
    (:class:`GeometryError`). Vectorized over (triangle, row) pairs in batches.

    Args:
        heights: ``(R, C)`` heightmap in mm.
        rc: ``(N, 2)`` integer ``(row, col)`` of the vertices.
        z: ``(N,)`` vertex heights in mm (e.g. the mesh's float32 z minus its origin).
        faces: ``(M, 3)`` vertex indices.
        chunk: (triangle, row) pairs per batch (bounds the memory, not the result).

    Returns:
        Max absolute error in mm (float64 arithmetic).
    """
    h = np.asarray(heights, dtype=np.float64)
    rows, cols = h.shape
    rc = np.asarray(rc, dtype=np.int64)
    z = np.asarray(z, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        raise GeometryError("no triangles to measure")
    pr, pc = rc[f, 0].astype(np.float64), rc[f, 1].astype(np.float64)  # (M, 3)
    pz = z[f]
    # The plane z = A col + B row + C of each triangle.
    e1c, e1r, e1z = pc[:, 1] - pc[:, 0], pr[:, 1] - pr[:, 0], pz[:, 1] - pz[:, 0]
    e2c, e2r, e2z = pc[:, 2] - pc[:, 0], pr[:, 2] - pr[:, 0], pz[:, 2] - pz[:, 0]
    det = e1c * e2r - e1r * e2c
    with np.errstate(invalid="ignore", divide="ignore"):
        A = (e1z * e2r - e1r * e2z) / det
        B = (e1c * e2z - e1z * e2c) / det
    C = pz[:, 0] - A * pc[:, 0] - B * pr[:, 0]
    hf = h.ravel()
    worst = 0.0
    for tt, rr, cc in _pixel_pairs(rc, f, rows, cols, chunk):  # per batch
        if len(tt):
            s = A[tt] * cc + B[tt] * rr + C[tt]
            worst = max(worst, float(np.abs(s - hf[rr.astype(np.int64) * cols + cc]).max()))
    return worst


def _point_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``(K,)`` distance in mm from points ``p`` to triangles ``a b c`` (all ``(K, 3)``
    float64): to the plane where the foot lies inside, else to the nearest edge."""

    def seg(q, u, v):
        d = v - u
        t = np.clip(np.einsum("ij,ij->i", q - u, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0.0, 1.0)
        return np.linalg.norm(q - u - t[:, None] * d, axis=1)

    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    dist = np.einsum("ij,ij->i", p - a, n)
    foot = p - dist[:, None] * n
    inside = np.ones(len(p), bool)
    for u, v in ((a, b), (b, c), (c, a)):  # the three edges
        inside &= np.einsum("ij,ij->i", np.cross(v - u, foot - u), n) >= 0
    edge = np.minimum(np.minimum(seg(p, a, b), seg(p, b, c)), seg(p, c, a))
    return np.where(inside, np.abs(dist), edge)


def grid_distance(
    points: np.ndarray,
    rc: np.ndarray,
    vertices: np.ndarray,
    faces: np.ndarray,
    *,
    chunk: int = 1 << 20,
) -> np.ndarray:
    """Distance in mm from every point of an exact surface grid to a lean mesh of it,
    for mapped (curved) surfaces.

    ``points[r, c]`` is the exact surface at pixel centre ``(r, c)`` (e.g. a mapped
    texture's vertex grid, :class:`texcad.mapping.MappedSurface`). The mesh's vertex
    ``i`` sits on grid point ``rc[i]`` at ``vertices[i]`` (the written float32 position)
    and its triangles ``faces`` tile the ``(row, col)`` grid. For each pixel centre the
    triangles covering it in the grid (on an edge: both neighbours) are found by
    rasterization; the distance to the nearest of them in 3-D is an upper bound on
    the distance to the whole mesh. Cheap first: the point of the triangle at the
    pixel's barycentric grid coordinates; the exact point-triangle distance where
    that one is above 1e-4 mm.

    Args:
        points: ``(R, C, 3)`` float64 mm.
        rc: ``(N, 2)`` int ``(row, col)``.
        vertices: ``(N, 3)`` mm.
        faces: ``(M, 3)`` indices into ``rc``.

    Returns:
        ``(R, C)`` float64 distances in mm.

    Raises:
        GeometryError: the triangles do not tile the grid.
    """
    P = np.asarray(points, dtype=np.float64)
    rows, cols = P.shape[:2]
    rc = np.asarray(rc, dtype=np.int64)
    V = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    pr, pc = rc[f, 0].astype(np.float64), rc[f, 1].astype(np.float64)
    det = (pc[:, 1] - pc[:, 0]) * (pr[:, 2] - pr[:, 0]) - (pr[:, 1] - pr[:, 0]) * (pc[:, 2] - pc[:, 0])
    best = np.full(rows * cols, np.inf)
    Pf = P.reshape(-1, 3)
    for tt, rr, cc in _pixel_pairs(rc, f, rows, cols, chunk):  # per batch
        if not len(tt):
            continue
        dc, dr = cc - pc[tt, 0], rr - pr[tt, 0]
        l1 = (dc * (pr[tt, 2] - pr[tt, 0]) - dr * (pc[tt, 2] - pc[tt, 0])) / det[tt]
        l2 = (dr * (pc[tt, 1] - pc[tt, 0]) - dc * (pr[tt, 1] - pr[tt, 0])) / det[tt]
        a, b, c = V[f[tt, 0]], V[f[tt, 1]], V[f[tt, 2]]
        flat = rr.astype(np.int64) * cols + cc
        p = Pf[flat]
        q = a + l1[:, None] * (b - a) + l2[:, None] * (c - a)
        d = np.linalg.norm(p - q, axis=1)
        far = d > 1e-4
        if far.any():
            d[far] = np.minimum(d[far], _point_triangle_distance(p[far], a[far], b[far], c[far]))
        np.minimum.at(best, flat, d)
    return best.reshape(rows, cols)


def mesh_error(
    heights: np.ndarray,
    pitch: tuple[float, float],
    origin: tuple[float, float, float],
    vertices: np.ndarray,
    faces: np.ndarray,
) -> float:
    """The largest height error in mm of a slab's top surface at every pixel centre.

    ``vertices`` and ``faces`` are the top surface as written (e.g. the ``"texture"``
    faces of :func:`texcad.solid.heightfield_slab`, float32 mm): each vertex's grid
    point is recovered from its x, y (pixel ``(r, c)`` sits at ``origin + ((c + 1/2)
    px, (r + 1/2) py)``), its height is its z minus ``origin_z``, and
    :func:`surface_error` compares the surface with ``heights`` (mm) at every pixel
    centre.

    Raises:
        GeometryError: a vertex is off the pixel grid, or the faces do not tile it.
    """
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces, dtype=np.int64)
    used = np.unique(f)
    px, py = (float(p) for p in pitch)
    ox, oy, oz = (float(o) for o in origin)
    col = (v[used, 0] - ox) / px - 0.5
    row = (v[used, 1] - oy) / py - 0.5
    ci, ri = np.rint(col).astype(np.int64), np.rint(row).astype(np.int64)
    rows, cols = np.shape(heights)
    off = max(float(np.abs(col - ci).max()), float(np.abs(row - ri).max()))
    if off > 1e-2 or ci.min() < 0 or ri.min() < 0 or ci.max() >= cols or ri.max() >= rows:
        raise GeometryError(f"the surface has vertices off the {rows} x {cols} px grid (by {off:.3g} px)")
    rc = np.zeros((len(v), 2), dtype=np.int64)
    rc[used, 0], rc[used, 1] = ri, ci
    return surface_error(heights, rc, v[:, 2] - oz, f)


def refined_heights(vertices: np.ndarray, faces: np.ndarray, origin: tuple, pitch: tuple, shape: tuple) -> np.ndarray:
    """``(2 R - 1, 2 C - 1)`` mm: a lean heightfield surface (``vertices`` ``(N, 3)``
    mm at pixel centres ``origin + ((c + 1/2) px, (r + 1/2) py, z)`` of an ``(R, C)``
    = ``shape`` grid, triangles ``faces``; a slab's ``"texture"`` group) at every
    point of the grid refined twice (point ``(i, j)`` at pixel ``(i / 2, j / 2)``),
    height above ``origin[2]``, NaN where no triangle lies: the values of
    :func:`texcad.targets.patches.lean_heights` with ``sub=2``, bit for bit, faster.

    A triangle's value at a point ``q`` of the refined grid is ``l0 z0 + l1 z1 + l2
    z2``, its barycentric coordinates ``l1 = n1 / det``, ``l2 = n2 / det``, ``l0 = 1
    - l1 - l2`` from the points' integer indices, where the last triangle (in
    ``faces`` order) holding ``q`` writes it. Half-cells (three corners of one pixel
    cell, most triangles of a lean top where the relief is busy) hold only their
    corners (``z``) and the middles of their sides (``z_a / 2 + z_b / 2``, the same
    in every triangle holding them: the triangles meet along whole sides), so they
    are written first, all at once;
    every other triangle is rasterized by rows (:func:`_row_spans`: exactly the
    points of the closed triangle, integer arithmetic) in ``faces`` order. Raises
    :class:`GeometryError` if a vertex is off the grid."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    col = np.rint((v[:, 0] - origin[0]) / pitch[0] - 0.5).astype(np.int64)
    row = np.rint((v[:, 1] - origin[1]) / pitch[1] - 0.5).astype(np.int64)
    z = v[:, 2] - origin[2]
    rows, cols, zf = 2 * row[f], 2 * col[f], z[f]
    out = np.full(((shape[0] - 1) * 2 + 1, (shape[1] - 1) * 2 + 1), np.nan)
    if f.size and (min(rows.min(), cols.min()) < 0 or rows.max() >= out.shape[0] or cols.max() >= out.shape[1]):
        raise GeometryError(f"the lean top has vertices off the {shape[0]} x {shape[1]} px grid")
    (ar, br, cr), (ac, bc, cc) = rows.T, cols.T
    det = (br - ar) * (cc - ac) - (cr - ar) * (bc - ac)
    extent = lambda g: np.maximum(np.maximum(g[:, 0], g[:, 1]), g[:, 2]) - np.minimum(np.minimum(g[:, 0], g[:, 1]), g[:, 2])  # noqa: E731
    half = (det != 0) & (extent(rows) == 2) & (extent(cols) == 2)
    hr, hc, hz = rows[half], cols[half], zf[half]
    out[hr, hc] = hz
    for a, b in ((0, 1), (1, 2), (2, 0)):  # the middles of the half-cells' sides
        out[(hr[:, a] + hr[:, b]) // 2, (hc[:, a] + hc[:, b]) // 2] = 0.5 * hz[:, a] + 0.5 * hz[:, b]
    rest = np.nonzero(~half & (det != 0))[0]
    flat_out = out.reshape(-1)
    for part in _row_chunks(rows[rest], REFINED_CHUNK):  # in faces order
        k, r, lo, span = _row_spans(rows[rest[part]], cols[rest[part]])
        t = rest[part][k]  # per (triangle, row) pair
        (ar, br, cr), (ac, bc, cc) = rows[t].T, cols[t].T
        # l1 = ((r - ar)(cc - ac) - (cr - ar)(c - ac)) / det = (p1 - s1 c) / det and
        # l2 = ((br - ar)(c - ac) - (r - ar)(bc - ac)) / det = (s2 c - p2) / det, integers
        p1, s1 = (r - ar) * (cc - ac) + (cr - ar) * ac, cr - ar
        p2, s2 = (br - ar) * ac + (r - ar) * (bc - ac), br - ar
        at = np.repeat(np.arange(len(t)), span)  # the pair of each point
        rep = lambda a: np.take(a, at)  # noqa: E731 - pair values at each of its points
        c = rep(lo - (np.cumsum(span) - span)) + np.arange(len(at))
        d = rep(det[t])
        l1, l2 = (rep(p1) - rep(s1) * c) / d, (rep(s2) * c - rep(p2)) / d
        zt = zf[t]
        # summed in this order, unfused: lean_heights' einsum("ij,ijk->ik") bit for bit
        flat_out[rep(r * out.shape[1]) + c] = ((1.0 - l1 - l2) * rep(zt[:, 0]) + l1 * rep(zt[:, 1])) + l2 * rep(zt[:, 2])
    return out


#: (triangle, row) pairs :func:`refined_heights` rasterizes at once (its arrays stay in the
#: processor's cache).
REFINED_CHUNK = 1 << 14


def _row_chunks(rows: np.ndarray, chunk: int) -> list:
    """Slices of consecutive triangles (grid rows ``rows`` ``(M, 3)``) spanning about
    ``chunk`` grid rows together."""
    n = rows.max(1) - rows.min(1) + 1
    ends = np.searchsorted(np.cumsum(n), np.arange(chunk, int(n.sum()) + chunk, chunk), side="right")
    bounds = np.unique(np.concatenate([[0], np.clip(ends, 1, len(rows))]))
    return [slice(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]


def _row_spans(rows: np.ndarray, cols: np.ndarray) -> tuple:
    """``(k, r, lo, n)``: the grid points of the closed triangles with grid corners
    ``rows``, ``cols`` ``(M, 3)`` (nonzero area), triangle by triangle and row by row:
    triangle ``k`` holds ``n`` points ``(r, lo)``, ``(r, lo + 1)``, ... of row ``r``.
    With its corners ``t``, ``m``, ``b`` by row, row ``r`` meets the side ``tb`` and
    ``tm`` (``r < r_m``) or ``mb`` at columns ``x = c_a + (r - r_a) (c_b - c_a) / (r_b
    - r_a)`` (``c_m`` on a side along the row); the triangle holds the columns from
    the least ``ceil(x)`` to the largest ``floor(x)``, exactly: ``x`` in floats is
    within a few units in the last place (``|x| < 1e6``: 1e-10) of a ratio with
    denominator ``r_b - r_a < 1e6``, which is an integer or at least ``1 / (r_b -
    r_a)`` from one."""
    o = np.argsort(rows, axis=1, kind="stable")
    (rt, rm, rb), (ct, cm, cb) = np.take_along_axis(rows, o, 1).T, np.take_along_axis(cols, o, 1).T
    n = rb - rt + 1
    k = np.repeat(np.arange(len(rows)), n)
    r = rt[k] + np.arange(len(k)) - np.repeat(np.cumsum(n) - n, n)
    x_long = ct[k] + (r - rt[k]) * (cb - ct)[k] / (rb - rt)[k]
    upper = r < rm[k]
    a_r, a_c = np.where(upper, rt[k], rm[k]), np.where(upper, ct[k], cm[k])
    d_r, d_c = np.where(upper, (rm - rt)[k], (rb - rm)[k]), np.where(upper, (cm - ct)[k], (cb - cm)[k])
    with np.errstate(invalid="ignore", divide="ignore"):
        x_short = np.where(d_r > 0, a_c + (r - a_r) * d_c / d_r, a_c)
    lo = np.minimum(np.ceil(x_long), np.ceil(x_short)).astype(np.int64)
    hi = np.maximum(np.floor(x_long), np.floor(x_short)).astype(np.int64)
    return k, r, lo, np.maximum(hi - lo + 1, 0)
