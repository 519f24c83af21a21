"""Heightmaps from 3-D scans: point clouds and scanned meshes (paper, abstract and
section 2.1: "the heightmap information from a physical sample can be obtained by 3D
scanning the sample and using the information from the acquired point cloud").

:func:`scan_to_heightmap` turns a scan in mm into a :class:`~texcad.Heightmap` and a
:class:`ScanReport`, in these steps:

1. **Read** (:func:`read_scan`): PLY (ASCII or binary, points or mesh), STL, OBJ,
   OFF through trimesh; XYZ / CSV / TXT / ASC / PTS columns ``x y z ...`` and ASCII
   PCD with small numpy readers. Points with NaN or infinite coordinates are dropped.
2. **Level** (:func:`fit_plane`): a robust best-fit plane - least median of squares
   over seeded random point triples, refined by iteratively reweighted total least
   squares with Tukey's biweight (outliers get weight 0, so they cannot tilt it). The
   scan is rotated into the plane's frame: height ``h`` runs along the plane normal
   (the side of the scan's +z), ``x`` along the scan's x projected onto the plane.
3. **Bin and reject outliers**: points fall into square cells of ``pitch`` mm whose
   centres are the pixel centres; each cell keeps the median height of its points.
   A point is an outlier when it lies more than ``outlier_sigma`` robust standard
   deviations outside the range of the cell medians around it (3 x 3 cells), so
   steep texture flanks survive and flying points do not. Two passes.
4. **Remove form** (``form_degree >= 2``): a robust 2-D polynomial of that degree in
   ``x, y`` fitted to the cell medians is subtracted (a curved or warped sample).
5. **Crop**: the covered area is the set of cells holding data, closed over gaps of
   up to 4 cells and (``fill_holes``) with enclosed holes counted as covered; the
   output is the largest axis-aligned rectangle inside it (:func:`largest_rectangle`).
6. **Fill**: empty cells inside the rectangle get heights by linear interpolation
   (Delaunay) from the measured cells around each hole, and nearest values where that
   cannot reach.
7. **Base**: heights are shifted so the ``base_percentile`` (default 0.5th) percentile
   of the result lies at 0 mm (the surface) and the few pixels below it are clipped to
   0 - a robust minimum: a single deep speck does not lift the whole texture.

Meshes skip step 3: after levelling, vertical rays through every pixel centre are
intersected with the triangles and the highest hit is kept (a vectorized z-buffer),
so closed scans (with sides and a bottom) give their top surface.
"""

from __future__ import annotations

import io
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..util import require_memory
from ..util import positive
from ..errors import InputError, ParameterError
from .heightmap import Heightmap

__all__ = [
    "ScanData",
    "ScanReport",
    "SCAN_SUFFIXES",
    "read_scan",
    "fit_plane",
    "largest_rectangle",
    "scan_to_heightmap",
]

_MESH_SUFFIXES = (".stl", ".obj", ".off", ".ply")
_TEXT_SUFFIXES = (".xyz", ".csv", ".txt", ".asc", ".pts")
#: File suffixes :func:`read_scan` reads.
SCAN_SUFFIXES = _MESH_SUFFIXES + _TEXT_SUFFIXES + (".pcd",)


@dataclass(frozen=True, eq=False)
class ScanData:
    """A scan as plain arrays.

    Attributes:
        points: ``(N, 3)`` float64 point or vertex coordinates in mm.
        faces: ``(M, 3)`` int64 vertex indices for a mesh, ``None`` for a point cloud.
        source: where it came from (a path, or ``"<array>"``).
    """

    points: np.ndarray
    faces: np.ndarray | None = None
    source: str = "<array>"

    @property
    def kind(self) -> str:
        """``"mesh"`` or ``"points"``."""
        return "points" if self.faces is None else "mesh"


@dataclass(frozen=True)
class ScanReport:
    """What :func:`scan_to_heightmap` did, with figures to judge the scan by.

    Attributes:
        source: the scan's path or ``"<array>"``.
        kind: ``"points"`` or ``"mesh"``.
        points_read: points (or mesh vertices) in the input.
        points_used: finite inlier points that made the heightmap.
        nonfinite_dropped: points with NaN or infinite coordinates.
        outliers_dropped: points rejected as outliers (0 for meshes).
        plane_tilt: angle in degrees between the fitted plane's normal and the scan's
            z axis (0 with ``form_degree=0``).
        form_degree: degree of the removed form (0: none, 1: plane, >= 2: polynomial).
        coverage: fraction of the output pixels that held scan data before holes were
            filled (for meshes: that a vertical ray hit).
        noise_rms: RMS in mm of the used points' heights about the heightmap
            (bilinear between pixel centres): sensor noise plus relief finer than
            the pitch.
        crop_box: ``(x0, y0, x1, y1)`` in mm of the output in the plane frame.
        shape: ``(rows, cols)`` of the heightmap.
        pitch: mm per pixel.
        max_height: largest height in mm after the base shift.
        base_offset: mm subtracted so the base lies at 0 (the base percentile).
        origin: scan coordinates (mm) of the heightmap's corner at height 0.
        axes: ``(ex, ey, n)`` unit vectors in scan coordinates: the heightmap point
            ``(x, y, h)`` is the scan point ``origin + x ex + y ey + h n`` (exact for
            ``form_degree <= 1``; with a polynomial form, ``h`` is measured from it).
    """

    source: str
    kind: str
    points_read: int
    points_used: int
    nonfinite_dropped: int
    outliers_dropped: int
    plane_tilt: float
    form_degree: int
    coverage: float
    noise_rms: float
    crop_box: tuple[float, float, float, float]
    shape: tuple[int, int]
    pitch: float
    max_height: float
    base_offset: float
    origin: tuple[float, float, float]
    axes: tuple[tuple[float, float, float], ...]

    def summary(self) -> str:
        """The report as aligned ``label  value`` lines (units mm, degrees)."""
        x0, y0, x1, y1 = self.crop_box
        return "\n".join(
            [
                f"scan         {self.source} ({self.kind})",
                f"points       {self.points_read} read, {self.points_used} used, "
                f"{self.outliers_dropped} outliers, {self.nonfinite_dropped} non-finite dropped",
                f"plane tilt   {self.plane_tilt:.3f} deg (form degree {self.form_degree})",
                f"crop         {x1 - x0:.3f} x {y1 - y0:.3f} mm "
                f"(x {x0:.3f}..{x1:.3f}, y {y0:.3f}..{y1:.3f} mm in the plane)",
                f"heightmap    {self.shape[1]} x {self.shape[0]} px at {self.pitch:g} mm, "
                f"heights 0..{self.max_height:.4f} mm",
                f"coverage     {100 * self.coverage:.1f} % of pixels measured, the rest filled",
                f"noise        {self.noise_rms:.4f} mm RMS",
            ]
        )


# -- reading -----------------------------------------------------------------------
def read_scan(path: str | os.PathLike) -> ScanData:
    """Read a point cloud or a scanned mesh (coordinates in mm).

    Formats: PLY (ASCII or binary; with faces it is a mesh), STL, OBJ and OFF (via
    trimesh), XYZ / CSV / TXT / ASC / PTS (one point per line, the first three
    numeric columns are x y z; separators: spaces, tabs, commas or semicolons; a
    header line and ``#`` comments are skipped) and ASCII PCD.

    Raises:
        InputError: missing, empty, unreadable or unknown file; no points in it.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"scan {str(p)!r} does not exist; check the path")
    if p.stat().st_size == 0:
        raise InputError(f"scan {str(p)!r} is empty (0 bytes); export it again")
    suffix = p.suffix.lower()
    if suffix not in SCAN_SUFFIXES:
        raise InputError(
            f"scan {str(p)!r} has an unknown format {suffix or '(no suffix)'!r}; "
            f"texcad reads {', '.join(SCAN_SUFFIXES)}"
        )
    require_memory(p.stat().st_size * 12.0, f"reading scan {str(p)!r}", "decimate the scan first")
    if suffix in _TEXT_SUFFIXES:
        pts, faces = _read_columns(p), None
    elif suffix == ".pcd":
        pts, faces = _read_pcd(p), None
    else:
        pts, faces = _read_trimesh(p)
    if len(pts) == 0:
        raise InputError(f"scan {str(p)!r} holds no points; export it again with its points")
    return ScanData(pts, faces, str(p))


def _read_trimesh(p: Path) -> tuple[np.ndarray, np.ndarray | None]:
    import trimesh

    try:
        obj = trimesh.load(p, process=False)
    except Exception as exc:  # trimesh raises many types for corrupt files
        raise InputError(f"cannot read scan {str(p)!r}: {exc}; export it again") from None
    if isinstance(obj, trimesh.Scene):
        geoms = list(obj.dump()) if obj.geometry else []
        if not geoms:
            raise InputError(f"scan {str(p)!r} holds no geometry; export it again with its points or triangles")
        meshes = [g for g in geoms if isinstance(g, trimesh.Trimesh) and len(g.faces)]
        if meshes:
            obj = trimesh.util.concatenate(meshes)
        else:
            obj = trimesh.PointCloud(np.concatenate([np.asarray(g.vertices) for g in geoms]))
    verts = np.asarray(getattr(obj, "vertices", np.zeros((0, 3))), dtype=np.float64).reshape(-1, 3)
    faces = getattr(obj, "faces", None)
    faces = None if faces is None or len(faces) == 0 else np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    _check_read(p, verts, faces)
    return verts, faces


def _ply_counts(p: Path) -> dict:
    """``{element: count}`` declared by a PLY file's header ({} for other files)."""
    if p.suffix.lower() != ".ply":
        return {}
    with open(p, "rb") as fh:
        head = fh.read(65536)
    end = head.find(b"end_header")
    counts = {}
    for line in head[: max(end, 0)].decode("latin-1").splitlines():  # per header line
        tok = line.split()
        if len(tok) == 3 and tok[0] == "element" and tok[2].isdigit():
            counts[tok[1]] = int(tok[2])
    return counts


#: mm; a scan vertex farther from the origin is refused as a damaged number.
MAX_COORDINATE_MM = 1.0e6


def _check_read(p: Path, verts: np.ndarray, faces: "np.ndarray | None") -> None:
    """InputError naming the file, the place and the fix for what trimesh lets through:
    non-finite coordinates, faces that index missing vertices, fewer vertices or faces
    than a PLY header declares (a truncated file)."""
    bad = ~np.isfinite(verts).all(axis=1)
    if bad.any():
        raise InputError(f"scan {str(p)!r} has {int(bad.sum())} vertices that are not finite numbers (NaN or inf; the "
                         f"first is vertex {int(np.argmax(bad))}, from 0); export it again")
    far = np.abs(verts).max(axis=1) > MAX_COORDINATE_MM if len(verts) else np.zeros(0, bool)
    if far.any():  # a damaged number (a flipped byte of a binary file): no scanned part is a kilometre across
        k = int(np.argmax(far))
        raise InputError(f"scan {str(p)!r}: vertex {k} (from 0) is at {verts[k].round(3).tolist()} mm, more than "
                         f"{MAX_COORDINATE_MM:g} mm from the origin ({int(far.sum())} such vertices); the file is "
                         "damaged, export it again")
    if faces is not None and (faces.min() < 0 or faces.max() >= len(verts)):
        k = int(np.argmax((faces < 0).any(axis=1) | (faces >= len(verts)).any(axis=1)))
        raise InputError(f"scan {str(p)!r}: face {k} (from 0) indexes vertex {faces[k].tolist()} but the file has "
                         f"{len(verts)} vertices (0 .. {len(verts) - 1}); export it again")
    counts = _ply_counts(p)
    for element, got in (("vertex", len(verts)), ("face", 0 if faces is None else len(faces))):  # per declared element
        if element in counts and got < counts[element]:
            raise InputError(f"scan {str(p)!r} is truncated: its header declares {counts[element]} {element} elements but "
                             f"the file holds {got}; export it again")


def _numeric_start(lines: list[str]) -> int:
    """Index of the first line that starts with a number (header lines before it)."""
    for i, line in enumerate(lines):
        tok = line.replace(",", " ").replace(";", " ").split()
        if not tok or tok[0].startswith(("#", "//")):
            continue
        try:
            float(tok[0])
            return i
        except ValueError:
            continue
    return len(lines)


def _parse_table(text: str, source: Path, cols: tuple[int, int, int] = (0, 1, 2)) -> np.ndarray:
    body = text.replace(",", " ").replace(";", " ").replace("\t", " ")
    try:
        a = np.loadtxt(io.StringIO(body), comments=("#", "//"), usecols=cols, ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise InputError(
            f"cannot read points from {str(source)!r}: {exc}; every line needs at least x y z numbers"
        ) from None
    return a.reshape(-1, 3)


def _read_columns(p: Path) -> np.ndarray:
    text = p.read_text(encoding="utf-8", errors="replace")
    head = text[:20000].splitlines()[:50]
    start = _numeric_start(head)
    if start == len(head):
        raise InputError(f"scan {str(p)!r} holds no numeric x y z lines; is it a point list?")
    if start:
        text = text.split("\n", start)[-1]
    first = next((ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith(("#", "//"))), "")
    ncol = len(first.replace(",", " ").replace(";", " ").split())
    if ncol < 3:
        raise InputError(f"scan {str(p)!r} has {ncol} column(s) per line; a point list needs x y z")
    return _parse_table(text, p)


def _read_pcd(p: Path) -> np.ndarray:
    raw = p.read_bytes()
    end = raw.find(b"DATA")
    if end < 0:
        raise InputError(f"{str(p)!r} is not a PCD file (no DATA line)")
    line_end = raw.find(b"\n", end)
    header = raw[:end].decode("ascii", "replace").splitlines()
    data_kind = raw[end:line_end if line_end >= 0 else None].decode("ascii", "replace").split()
    if len(data_kind) < 2 or data_kind[1].lower() != "ascii":
        raise InputError(
            f"PCD file {str(p)!r} stores {' '.join(data_kind[1:]) or 'unknown'} data; texcad reads ASCII PCD - "
            "save it as ASCII PCD, PLY or XYZ"
        )
    fields: list[str] = []
    for line in header:
        tok = line.split()
        if tok and tok[0].upper() == "FIELDS":
            fields = [t.lower() for t in tok[1:]]
    if not all(k in fields for k in ("x", "y", "z")):
        raise InputError(f"PCD file {str(p)!r} has fields {fields}; it needs x, y and z")
    body = raw[line_end + 1:].decode("ascii", "replace") if line_end >= 0 else ""
    if not body.strip():
        return np.zeros((0, 3))
    return _parse_table(body, p, (fields.index("x"), fields.index("y"), fields.index("z")))


def _as_scan(scan: Any) -> ScanData:
    if isinstance(scan, ScanData):
        return scan
    if isinstance(scan, (str, os.PathLike)):
        return read_scan(scan)
    if hasattr(scan, "vertices") and hasattr(scan, "faces"):
        v = np.asarray(scan.vertices, dtype=np.float64).reshape(-1, 3)
        f = np.asarray(scan.faces, dtype=np.int64).reshape(-1, 3)
        return ScanData(v, f if len(f) else None, f"<{type(scan).__name__}>")
    try:
        a = np.asarray(scan, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"a scan is a path, an (N, 3) array of points in mm or a mesh, got {type(scan).__name__}") from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise ParameterError(f"scan points must be an (N, 3) array of x, y, z in mm, got shape {a.shape}")
    return ScanData(a)


# -- robust plane ----------------------------------------------------------------------
def fit_plane(
    points: np.ndarray, *, seed: int = 0, trials: int = 256, sample: int = 2000, max_points: int = 200_000
) -> tuple[np.ndarray, np.ndarray]:
    """Robust best-fit plane through points in mm.

    1. Least median of squares: ``trials`` planes through seeded random point
       triples; keep the one whose median absolute distance over a random subsample
       of ``sample`` points is smallest (survives up to half the points being off).
    2. Iteratively reweighted total least squares from there: weights are Tukey's
       biweight ``w = (1 - (r / c)^2)^2`` for ``|r| < c``, else 0, with ``r`` the
       distance to the plane and ``c = 4.685 * 1.4826 * MAD(r)``; the plane is the
       weighted centroid and the eigenvector of the smallest eigenvalue of the
       weighted covariance. Stops when the normal turns by less than 1e-9 rad. Runs
       on a seeded random subset of ``max_points`` points when there are more.

    Args:
        points: ``(N, 3)`` finite points, N >= 3.
        seed: seed for ``numpy.random.default_rng``.

    Returns:
        ``(centroid, normal)``: a point on the plane (mm) and the unit normal, turned
        to the scan's +z side (``normal[2] >= 0``).

    Raises:
        InputError: fewer than 3 points, all points equal, or all on one line.
    """
    P = np.asarray(points, dtype=np.float64)
    n_pts = len(P)
    if n_pts < 3:
        raise InputError(f"a plane needs at least 3 points, the scan has {n_pts}; scan more of the sample")
    c0 = np.median(P, axis=0)
    X = P - c0
    ev, evec = np.linalg.eigh(X.T @ X / n_pts)
    spread = np.sqrt(np.clip(ev, 0.0, None))  # ascending
    if spread[2] == 0.0:
        at = ", ".join(f"{v:.6g}" for v in c0)
        raise InputError(f"all {n_pts} scan points coincide at ({at}) mm; there is no surface to read")
    if spread[1] <= 1e-6 * spread[2]:
        raise InputError(
            f"the {n_pts} scan points lie on one line (spread {spread[2]:.3g} mm along it, "
            f"{spread[1]:.3g} mm across); a surface scan must cover an area"
        )
    rng = np.random.default_rng(seed)
    sub = X[rng.choice(n_pts, size=min(n_pts, sample), replace=False)]
    tri = X[rng.integers(0, n_pts, size=(trials, 3))]
    normals = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normals, axis=1)
    good = length > 1e-12 * spread[2] ** 2
    if good.any():
        normals = normals[good] / length[good, None]
        offsets = np.einsum("ij,ij->i", normals, tri[good, 0])
        med = np.median(np.abs(sub @ normals.T - offsets), axis=0)
        k = int(np.argmin(med))
        n, d = normals[k], offsets[k]
    else:  # every triple degenerate (e.g. heavy duplication): start from PCA
        n, d = evec[:, 0], 0.0
    if n_pts > max_points:  # the plane is well determined by a random subset
        X = X[rng.choice(n_pts, size=max_points, replace=False)]
    for _ in range(50):  # iterations, each vectorized over the points
        r = X @ n - d
        mad = np.median(np.abs(r - np.median(r)))
        c = 4.685 * max(1.4826 * mad, 1e-12 * spread[2])
        u = r / c
        w = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        sw = w.sum()
        if np.count_nonzero(w) < 3:
            break
        cen = (w[:, None] * X).sum(axis=0) / sw
        Y = X - cen
        _, vec = np.linalg.eigh((Y * w[:, None]).T @ Y / sw)
        n_new = vec[:, 0] * (1.0 if vec[:, 0] @ n >= 0 else -1.0)
        turn = np.linalg.norm(n_new - n)
        n, d = n_new, cen @ n_new
        if turn < 1e-9:
            break
    if n[2] < 0 or (n[2] == 0 and (n[1] < 0 or (n[1] == 0 and n[0] < 0))):
        n, d = -n, -d
    return c0 + d * n, n


def _frame(normal: np.ndarray) -> np.ndarray:
    """Rows ``(ex, ey, n)``: ex is the scan's x projected onto the plane (or y if the
    plane is perpendicular to x), ey = n x ex; right-handed."""
    n = normal / np.linalg.norm(normal)
    for axis in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        e = axis - (axis @ n) * n
        if np.linalg.norm(e) > 1e-6:
            ex = e / np.linalg.norm(e)
            return np.stack([ex, np.cross(n, ex), n])
    raise AssertionError("unreachable")  # pragma: no cover


# -- grid helpers --------------------------------------------------------------------
def largest_rectangle(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """Largest axis-aligned all-True rectangle of a boolean grid.

    For every cell, ``H`` counts the consecutive True cells ending there along the
    rows; each row is then a histogram, and the largest rectangle with its bottom on
    that row and height ``H[r, c]`` spans from the previous to the next column with a
    smaller ``H``, found for all rows at once by pointer jumping (``L <- L[L]`` while
    ``H[L] >= H``, only over the cells still moving; the cells between ``L[L]`` and
    ``L`` are all ``>= H[L] >= H``, so every jump is safe). Area ``H (R - L - 1)``; the largest wins (first in row-major
    order on ties).

    Returns:
        ``(r0, r1, c0, c1)`` with rows ``r0:r1`` and columns ``c0:c1`` (half-open), or
        ``None`` if the mask has no True cell.
    """
    m = np.asarray(mask, dtype=bool)
    if m.ndim != 2:
        raise ParameterError(f"mask must be 2-D, got shape {m.shape}")
    if not m.any():
        return None
    rows, cols = m.shape
    cs = np.cumsum(m, axis=0, dtype=np.int64)
    reset = np.maximum.accumulate(np.where(m, 0, cs), axis=0)
    H = cs - reset

    def nearest_smaller(h: np.ndarray) -> np.ndarray:
        hf = h.ravel()
        L = np.tile(np.arange(cols) - 1, rows)
        base = np.repeat(np.arange(rows) * cols, cols)
        active = np.flatnonzero(L >= 0)
        while active.size:  # rounds, each over the cells still moving
            j = base[active] + L[active]
            move = hf[j] >= hf[active]
            active, j = active[move], j[move]
            L[active] = L[j]
            active = active[L[active] >= 0]
        return L.reshape(rows, cols)

    L = nearest_smaller(H)
    R = cols - 1 - nearest_smaller(H[:, ::-1])[:, ::-1]
    area = H * (R - L - 1)
    k = int(np.argmax(area))
    r, c = divmod(k, cols)
    h = int(H[r, c])
    return (r - h + 1, r + 1, int(L[r, c]) + 1, int(R[r, c]))


def _cell_medians(cell: np.ndarray, h: np.ndarray, ncell: int) -> tuple[np.ndarray, np.ndarray]:
    """Median of ``h`` per cell (NaN for empty cells) and the count, by one sort."""
    # One float sort on "cell + rank-preserving fraction of h" orders by cell, then h.
    lo, hi = float(h.min(initial=0.0)), float(h.max(initial=0.0))
    frac = (h - lo) * (0.5 / (hi - lo)) if hi > lo else np.zeros_like(h)
    order = np.argsort(cell + frac)
    hs = h[order]
    cnt = np.bincount(cell, minlength=ncell)
    start = np.concatenate([[0], np.cumsum(cnt)[:-1]])
    med = np.full(ncell, np.nan)
    has = cnt > 0
    lo = start[has] + (cnt[has] - 1) // 2
    hi = start[has] + cnt[has] // 2
    med[has] = 0.5 * (hs[lo] + hs[hi])
    return med, cnt


def _robust_sigma(values: np.ndarray) -> float:
    v = values[np.isfinite(values)]
    return float(1.4826 * np.median(np.abs(v))) if v.size else 0.0


def _reject_outliers(
    cell: np.ndarray, h: np.ndarray, shape: tuple[int, int], k: float, passes: int = 2
) -> np.ndarray:
    """Boolean inlier mask: a point is an outlier when it lies more than ``k sigma``
    below the lowest or above the highest cell median around it (its 8 neighbours,
    plus its own cell if that holds >= 3 points). ``sigma`` is the larger of the
    robust (MAD) spread of points about their cell median and of the differences
    between neighbouring cell medians (divided by sqrt 2)."""
    from scipy import ndimage

    rows, cols = shape
    keep = np.ones(len(h), dtype=bool)
    fp = np.ones((3, 3), dtype=bool)
    fp[1, 1] = False
    for _ in range(passes):  # passes, each vectorized
        idx = np.flatnonzero(keep)
        med, cnt = _cell_medians(cell[idx], h[idx], rows * cols)
        M = med.reshape(rows, cols)
        hi8 = ndimage.maximum_filter(np.where(np.isnan(M), -np.inf, M), footprint=fp, mode="constant", cval=-np.inf)
        lo8 = ndimage.minimum_filter(np.where(np.isnan(M), np.inf, M), footprint=fp, mode="constant", cval=np.inf)
        own = (cnt >= 3).reshape(rows, cols) | ~np.isfinite(lo8)
        lo = np.where(own, np.fmin(lo8, M), lo8).ravel()
        hi = np.where(own, np.fmax(hi8, M), hi8).ravel()
        many = cnt[cell[idx]] >= 3
        s_within = _robust_sigma(h[idx][many] - med[cell[idx][many]]) if many.any() else 0.0
        diffs = np.concatenate([(M[:, 1:] - M[:, :-1]).ravel(), (M[1:] - M[:-1]).ravel()])
        s_between = _robust_sigma(diffs) / np.sqrt(2.0)
        t = k * max(s_within, s_between)
        c = cell[idx]
        bad = (h[idx] < lo[c] - t) | (h[idx] > hi[c] + t)
        if not bad.any():
            break
        keep[idx[bad]] = False
    return keep


def _poly_design(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    return np.stack([x**i * y**j for i in range(degree + 1) for j in range(degree + 1 - i)], axis=-1)


def _fit_form(G: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Robust polynomial ``sum c_ij x^i y^j`` (i + j <= degree, x and y scaled to
    [-1, 1] over the grid) fitted to the finite cells of ``G`` by least squares
    reweighted with Tukey's biweight (6 rounds). Returns the coefficients and the
    form sampled on the grid."""
    rows, cols = G.shape
    yy, xx = np.meshgrid(np.linspace(-1, 1, rows), np.linspace(-1, 1, cols), indexing="ij")
    ok = np.isfinite(G)
    A = _poly_design(xx[ok], yy[ok], degree)
    b = G[ok]
    if len(b) < A.shape[1]:
        raise InputError(f"form degree {degree} needs at least {A.shape[1]} measured pixels, the scan has {len(b)}; lower form_degree or the pitch")
    w = np.ones_like(b)
    coef = np.zeros(A.shape[1])
    for _ in range(6):  # reweighting rounds
        sw = np.sqrt(w)
        coef = np.linalg.lstsq(A * sw[:, None], b * sw, rcond=None)[0]
        r = b - A @ coef
        c = 4.685 * max(1.4826 * float(np.median(np.abs(r - np.median(r)))), 1e-12)
        u = r / c
        w = np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0)
        if np.count_nonzero(w) < A.shape[1]:
            break
    return coef, _poly_design(xx, yy, degree) @ coef


def _fill(G: np.ndarray) -> np.ndarray:
    """Fill NaN cells: linear interpolation over a Delaunay triangulation of the
    measured cells that border a hole, then the nearest measured cell for what lies
    outside their hull."""
    from scipy import ndimage

    miss = np.isnan(G)
    if not miss.any():
        return G
    out = G.copy()
    known = ~miss
    border = known & ndimage.binary_dilation(miss, structure=np.ones((3, 3), bool))
    pts = np.argwhere(border).astype(np.float64)
    q = np.argwhere(miss)
    if len(pts) >= 3:
        from scipy.interpolate import griddata
        from scipy.spatial import QhullError

        try:
            out[miss] = griddata(pts, G[border], q.astype(np.float64), method="linear")
        except QhullError:  # border cells on one line
            pass
    still = np.isnan(out)
    if still.any():
        idx = ndimage.distance_transform_edt(still, return_distances=False, return_indices=True)
        out = out[tuple(idx)]
    return out


def _rasterize_top(L: np.ndarray, faces: np.ndarray, u0: float, v0: float, pitch: float, shape: tuple[int, int]) -> np.ndarray:
    """Highest triangle hit by vertical rays through the pixel centres (z-buffer).

    ``L`` holds vertex coordinates ``(x, y, h)`` in the plane frame. Each triangle is
    tested against the pixel centres in its bounding box with barycentric
    coordinates; the hit height is ``l0 h0 + l1 h1 + l2 h2``; the largest per pixel
    is kept (``np.maximum.at``). Triangles are processed in chunks of about two
    million candidate pixels. Returns NaN where no triangle covers a pixel centre.
    """
    rows, cols = shape
    top = np.full(rows * cols, -np.inf)
    T = L[faces]
    a = (T[..., 0] - u0) / pitch - 0.5  # column coordinate of the vertices
    b = (T[..., 1] - v0) / pitch - 0.5  # row coordinate
    hz = T[..., 2]
    det = (b[:, 1] - b[:, 2]) * (a[:, 0] - a[:, 2]) + (a[:, 2] - a[:, 1]) * (b[:, 0] - b[:, 2])
    tol = 1e-4  # pixel centres within 1e-4 px of a triangle (float32 files) count as inside
    cmin = np.maximum(np.ceil(a.min(axis=1) - tol), 0).astype(np.int64)
    cmax = np.minimum(np.floor(a.max(axis=1) + tol), cols - 1).astype(np.int64)
    rmin = np.maximum(np.ceil(b.min(axis=1) - tol), 0).astype(np.int64)
    rmax = np.minimum(np.floor(b.max(axis=1) + tol), rows - 1).astype(np.int64)
    nc, nr = cmax - cmin + 1, rmax - rmin + 1
    npx = np.where((nc > 0) & (nr > 0) & (np.abs(det) > 1e-12), nc * nr, 0)
    tids = np.flatnonzero(npx)
    require_memory(2e6 * 200, "rasterizing the scanned mesh", "use a larger pitch")
    cum = np.cumsum(npx[tids])
    bounds = np.searchsorted(cum, np.arange(2_000_000, int(cum[-1]) if len(cum) else 0, 2_000_000), side="left")
    for chunk in np.split(tids, bounds):  # per chunk of triangles
        if not len(chunk):
            continue
        n = npx[chunk]
        t = np.repeat(chunk, n)
        k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
        cc = cmin[t] + k % nc[t]
        rr = rmin[t] + k // nc[t]
        a0, a1, a2 = a[t, 0], a[t, 1], a[t, 2]
        b0, b1, b2 = b[t, 0], b[t, 1], b[t, 2]
        l0 = ((b1 - b2) * (cc - a2) + (a2 - a1) * (rr - b2)) / det[t]
        l1 = ((b2 - b0) * (cc - a2) + (a0 - a2) * (rr - b2)) / det[t]
        l2 = 1.0 - l0 - l1
        eps = -tol
        inside = (l0 >= eps) & (l1 >= eps) & (l2 >= eps)
        z = l0 * hz[t, 0] + l1 * hz[t, 1] + l2 * hz[t, 2]
        np.maximum.at(top, (rr * cols + cc)[inside], z[inside])
    top[~np.isfinite(top)] = np.nan
    return top.reshape(rows, cols)


def _closed(faces: np.ndarray, points: np.ndarray) -> bool:
    """Whether the mesh is closed: every edge used by exactly two faces, after
    merging coincident vertices."""
    _, inv = np.unique(points, axis=0, return_inverse=True)
    f = inv.reshape(-1)[faces]
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return bool(len(counts) and np.all(counts == 2))


# -- the whole conversion ----------------------------------------------------------------
def scan_to_heightmap(
    scan: "str | os.PathLike | np.ndarray | ScanData",
    *,
    pitch: float,
    form_degree: int = 1,
    outlier_sigma: float = 3.5,
    crop: bool = True,
    fill_holes: bool = True,
    base_percentile: float = 0.5,
    min_coverage: float = 0.5,
    seed: int = 0,
) -> tuple[Heightmap, ScanReport]:
    """Turn a 3-D scan into a heightmap at ``pitch`` mm per pixel (steps in the
    module docstring).

    Args:
        scan: a scan file (see :func:`read_scan`), an ``(N, 3)`` array of points in
            mm, a :class:`ScanData`, or a mesh object with ``vertices`` and ``faces``
            (trimesh, :class:`texcad.Mesh`).
        pitch: pixel size of the output in mm (> 0). Pick it so each pixel holds at
            least one or two scan points.
        form_degree: 0 keeps the scan's own z as the height (no levelling); 1
            removes the robust best-fit plane; 2..6 also remove a robust polynomial
            form of that degree (a curved sample).
        outlier_sigma: outlier threshold in robust standard deviations (> 0); see
            step 3. ``float("inf")`` keeps every finite point.
        crop: cut to the largest rectangle fully covered by the scan (else keep the
            bounding rectangle and fill everything outside the scan too).
        fill_holes: count holes enclosed by the scan as covered (and fill them);
            otherwise the crop avoids them.
        base_percentile: percentile (0 to 50) of the heights put at 0 mm; lower
            pixels are clipped to 0.
        min_coverage: least fraction (0 to 1] of the output pixels that must hold
            scan data; below it the pitch is too fine for the scan.
        seed: seed for the plane fit's random triples.

    Returns:
        ``(heightmap, report)``: heights in mm (row along y, column along x of the
        plane frame, see :class:`ScanReport`), and the report.

    Raises:
        InputError: unreadable or empty file; no finite points; points all equal or
            on one line; a mesh with no area; too few points for the pitch.
        ParameterError: bad pitch, form_degree, outlier_sigma, base_percentile or
            min_coverage.
        ResourceError: the grid would not fit in memory.
    """
    pitch = positive("pitch", pitch)
    form_degree, k_out = _check_options(form_degree, outlier_sigma, base_percentile, min_coverage)
    data = _as_scan(scan)
    pts = _usable_points(data)
    # Step 2: level.
    origin, axes, tilt = _level(pts.fit, form_degree, seed, data.source)
    L = (pts.P - origin) @ axes.T  # (x, y, h) in the plane frame, mm
    grid = _grid(L[pts.used_v] if pts.is_mesh else L, pitch, data.source)
    require_memory(grid.rows * grid.cols * 8.0 * 12 + len(L) * 8.0 * 12, f"a {grid.rows} x {grid.cols} px scan grid", "use a larger pitch")
    # Step 3: bin (points) or rasterize (mesh); step 4: remove the form.
    G, ref, n_out = _bin(L, pts, grid, k_out)
    if form_degree >= 2:
        G, ref = _remove_form(G, ref, grid, form_degree)
    # Step 5: crop; step 6: fill.
    (r0, r1, c0, c1), coverage = _crop(G, ref, grid, crop, fill_holes, min_coverage)
    F = _fill(G[r0:r1, c0:c1])
    noise, used = _noise(F, ref, grid, r0, r1, c0, c1)
    # Step 7: base.
    base = float(np.percentile(F, base_percentile))
    hm = Heightmap(np.clip(F - base, 0.0, None).astype(np.float32), (pitch, pitch))
    x0, y0 = grid.u0 + c0 * pitch, grid.v0 + r0 * pitch
    corner = origin + x0 * axes[0] + y0 * axes[1] + base * axes[2]
    report = ScanReport(
        source=data.source,
        kind=data.kind,
        points_read=pts.n_read,
        points_used=used if not pts.is_mesh else int(len(pts.used_v)),
        nonfinite_dropped=pts.nonfinite,
        outliers_dropped=n_out,
        plane_tilt=tilt,
        form_degree=form_degree,
        coverage=coverage,
        noise_rms=noise,
        crop_box=(x0, y0, grid.u0 + c1 * pitch, grid.v0 + r1 * pitch),
        shape=hm.shape,
        pitch=pitch,
        max_height=hm.max_height,
        base_offset=base,
        origin=tuple(float(v) for v in corner),  # type: ignore[arg-type]
        axes=tuple(tuple(float(v) for v in a) for a in axes),
    )
    return hm, report


def _check_options(form_degree: Any, outlier_sigma: Any, base_percentile: Any, min_coverage: Any) -> tuple[int, float]:
    if isinstance(form_degree, bool) or not isinstance(form_degree, (int, np.integer)) or not 0 <= form_degree <= 6:
        raise ParameterError(f"form_degree must be a whole number from 0 to 6, got {form_degree!r}")
    try:
        k_out = float(outlier_sigma)
    except (TypeError, ValueError):
        k_out = float("nan")
    if not k_out > 0:
        raise ParameterError(f"outlier_sigma must be a positive number (robust standard deviations), got {outlier_sigma!r}")
    if not (isinstance(base_percentile, (int, float)) and 0.0 <= base_percentile < 50.0):
        raise ParameterError(f"base_percentile must be a number from 0 to 50, got {base_percentile!r}")
    if not (isinstance(min_coverage, (int, float)) and 0.0 < min_coverage <= 1.0):
        raise ParameterError(f"min_coverage must be a fraction in (0, 1], got {min_coverage!r}")
    return int(form_degree), k_out


@dataclass(frozen=True)
class _Points:
    """Step 1's result: the scan's points (``P``, mm; all of them for a mesh, the
    finite ones for a cloud), the ones the plane is fitted to, and for a mesh its
    usable faces, used vertices and whether it is closed."""

    P: np.ndarray
    fit: np.ndarray
    faces: np.ndarray | None
    used_v: np.ndarray | None
    closed: bool
    n_read: int
    nonfinite: int

    @property
    def is_mesh(self) -> bool:
        return self.faces is not None


def _usable_points(data: "ScanData") -> _Points:
    P = np.asarray(data.points, dtype=np.float64)
    n_read = len(P)
    finite = np.isfinite(P).all(axis=1)
    nonfinite = int(n_read - np.count_nonzero(finite))
    faces, used_v, closed = data.faces, None, False
    if faces is not None:
        if faces.size and (faces.min() < 0 or faces.max() >= n_read):
            raise InputError(f"mesh {data.source!r} has faces indexing missing vertices; repair it and export again")
        faces = faces[finite[faces].all(axis=1)]
        tri = P[faces]
        area = 0.5 * float(np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1).sum())
        if not area > 0:
            raise InputError(
                f"mesh {data.source!r} has no area ({len(faces)} usable triangles, total 0 mm2); "
                "export the scanned surface, not just its points or edges"
            )
        used_v = np.unique(faces)
        fit_pts = P[used_v]
        closed = _closed(faces, P)
        if closed:  # fit the plane to the up-facing side only
            fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            up = np.unique(faces[fn[:, 2] > 0])
            if len(up) >= 3:
                fit_pts = P[up]
    else:
        P = P[finite]
        if len(P) == 0:
            raise InputError(f"scan {data.source!r} holds no finite points ({n_read} read, all NaN or infinite)")
        fit_pts = P
    if len(fit_pts) < 3:
        raise InputError(f"scan {data.source!r} has {len(fit_pts)} usable points; a surface needs many more")
    return _Points(P, fit_pts, faces, used_v, closed, n_read, nonfinite)


def _level(fit_pts: np.ndarray, form_degree: int, seed: int, source: str) -> tuple[np.ndarray, np.ndarray, float]:
    """``(origin, axes (3, 3), tilt degrees)`` of the plane frame (step 2)."""
    if form_degree >= 1:
        origin, normal = fit_plane(fit_pts, seed=seed)
        return origin, _frame(normal), float(np.degrees(np.arccos(np.clip(normal[2], -1.0, 1.0))))
    if len(np.unique(fit_pts, axis=0)) < 3:  # still reject degenerate input
        raise InputError(f"scan {source!r} has fewer than 3 distinct points; there is no surface to read")
    return np.zeros(3), np.eye(3), 0.0


@dataclass(frozen=True)
class _Grid:
    """The pixel grid in the plane frame: corner ``(u0, v0)`` mm, ``pitch``, shape,
    and the scan's extent ``width x depth`` mm."""

    u0: float
    v0: float
    pitch: float
    rows: int
    cols: int
    width: float
    depth: float


def _grid(ext: np.ndarray, pitch: float, source: str) -> _Grid:
    umin, vmin = float(ext[:, 0].min()), float(ext[:, 1].min())
    width, depth = float(ext[:, 0].max()) - umin, float(ext[:, 1].max()) - vmin
    cols, rows = int(np.floor(width / pitch + 1e-3)) + 1, int(np.floor(depth / pitch + 1e-3)) + 1
    if rows < 2 or cols < 2:
        raise InputError(
            f"scan {source!r} spans only {width:.4g} x {depth:.4g} mm, less than 2 x 2 pixels at pitch {pitch:g} mm; "
            "use a smaller pitch"
        )
    # Centre the grid on the scan: it overhangs by at most half a pixel per side, and
    # every pixel centre lies within the scan's extent.
    u0 = umin - (cols * pitch - width) / 2
    v0 = vmin - (rows * pitch - depth) / 2
    return _Grid(u0, v0, pitch, rows, cols, width, depth)


def _bin(L: np.ndarray, pts: _Points, g: _Grid, k_out: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Step 3: ``(G (rows, cols) heights with NaN where no data, reference points,
    outliers dropped)``."""
    if pts.is_mesh:
        G = _rasterize_top(L, pts.faces, g.u0, g.v0, g.pitch, (g.rows, g.cols))
        ref = L[pts.used_v]
        if pts.closed:  # the top surface's vertices, not the sides' and bottom's
            T = L[pts.faces]
            up = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])[:, 2] > 0
            ref = L[np.unique(pts.faces[up])]
        return G, ref, 0
    col = np.clip(((L[:, 0] - g.u0) / g.pitch).astype(np.int64), 0, g.cols - 1)
    row = np.clip(((L[:, 1] - g.v0) / g.pitch).astype(np.int64), 0, g.rows - 1)
    cell = row * g.cols + col
    keep = _reject_outliers(cell, L[:, 2], (g.rows, g.cols), k_out) if np.isfinite(k_out) else np.ones(len(L), bool)
    med, _ = _cell_medians(cell[keep], L[keep, 2], g.rows * g.cols)
    return med.reshape(g.rows, g.cols), L[keep], int(len(L) - np.count_nonzero(keep))


def _remove_form(G: np.ndarray, ref: np.ndarray, g: _Grid, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Step 4: subtract the robust polynomial form from the grid and the points."""
    coef, form = _fit_form(G, degree)
    # Grid x spans pixel centres 0..cols-1 -> [-1, 1]; map point positions alike.
    fx = ((ref[:, 0] - g.u0) / g.pitch - 0.5) / max(g.cols - 1, 1) * 2 - 1
    fy = ((ref[:, 1] - g.v0) / g.pitch - 0.5) / max(g.rows - 1, 1) * 2 - 1
    return G - form, np.column_stack([ref[:, 0], ref[:, 1], ref[:, 2] - _poly_design(fx, fy, degree) @ coef])


def _crop(G: np.ndarray, ref: np.ndarray, g: _Grid, crop: bool, fill_holes: bool, min_coverage: float):
    """Step 5: ``((r0, r1, c0, c1), coverage)`` of the largest covered rectangle."""
    from scipy import ndimage

    have = np.isfinite(G)
    if not have.any():
        raise InputError(f"no pixel of the {g.rows} x {g.cols} grid at pitch {g.pitch:g} mm received scan data; use a larger pitch")
    pad = 3
    closed_mask = ndimage.binary_closing(np.pad(have, pad), structure=np.ones((3, 3), bool), iterations=2)[pad:-pad, pad:-pad] | have
    if fill_holes:
        closed_mask = ndimage.binary_fill_holes(closed_mask)
    box = largest_rectangle(closed_mask) if crop else (0, g.rows, 0, g.cols)
    if box is None:  # pragma: no cover - have.any() above
        raise InputError(f"no covered rectangle in the scan at pitch {g.pitch:g} mm; use a larger pitch")
    r0, r1, c0, c1 = box
    density = len(ref) / max(g.width * g.depth, g.pitch * g.pitch)
    suggest = max(g.pitch * 1.5, float(np.sqrt(2.0 / max(density, 1e-300))))
    if r1 - r0 < 2 or c1 - c0 < 2:
        raise InputError(
            f"the scan's {len(ref)} points are too sparse for pitch {g.pitch:g} mm: the largest covered rectangle is only "
            f"{c1 - c0} x {r1 - r0} px; use pitch >= {suggest:.3g} mm"
        )
    sub = G[r0:r1, c0:c1]
    coverage = float(np.count_nonzero(np.isfinite(sub))) / sub.size
    if coverage < min_coverage:
        raise InputError(
            f"only {100 * coverage:.1f} % of the {r1 - r0} x {c1 - c0} px at pitch {g.pitch:g} mm hold scan data "
            f"(need {100 * min_coverage:.0f} %): {len(ref)} points are fewer than this grid needs; "
            f"use pitch >= {suggest:.3g} mm"
        )
    return (r0, r1, c0, c1), coverage


def _noise(F: np.ndarray, ref: np.ndarray, g: _Grid, r0: int, r1: int, c0: int, c1: int) -> tuple[float, int]:
    """RMS of the used points inside the crop about the (bilinear) heightmap, mm, and
    how many points that is."""
    from scipy import ndimage

    cx = (ref[:, 0] - g.u0) / g.pitch - 0.5 - c0
    cy = (ref[:, 1] - g.v0) / g.pitch - 0.5 - r0
    inside = (cx >= -0.5) & (cx <= c1 - c0 - 0.5) & (cy >= -0.5) & (cy <= r1 - r0 - 0.5)
    if not inside.any():  # pragma: no cover - the crop always holds points
        return 0.0, 0
    at = ndimage.map_coordinates(F, [cy[inside], cx[inside]], order=1, mode="nearest")
    return float(np.sqrt(np.mean((ref[inside, 2] - at) ** 2))), int(np.count_nonzero(inside))


