"""A small orthographic z-buffer rasterizer in numpy, for pictures of meshes.

Used by ``texcad check --png`` (overhang faces in red) and for figures. Plain
numpy: no OpenGL, no display.

How it works
------------
1. *Camera.* An orthonormal basis ``(right, up, back)``: the camera looks along
   ``-back``; ``up`` is the screen's up. Vertices are projected orthographically,
   ``(x, y) = (v . right, v . up)`` scaled to pixels, ``depth = v . back`` (larger
   is closer to the viewer).
2. *Culling.* Faces whose screen-space winding is clockwise face away from the
   camera and are dropped (closed meshes only show their front).
3. *Rasterization.* Each triangle's pixel-centre bounding box is enumerated in
   chunks of a few million candidate pixels (``np.repeat`` of the box sizes, no
   Python loop per triangle); barycentric coordinates ``w_i`` (edge functions
   divided by twice the area) decide coverage (``w_i >= -1e-7``, so that shared
   edges leave no cracks) and interpolate depth. Within a chunk the nearest
   candidate per pixel is found by one ``lexsort``; across chunks a depth buffer
   keeps the nearest.
4. *Shading.* Flat Lambert shading per face, ``c = colour * (ambient + (1 -
   ambient) max(0, n . l))``, looked up through the per-pixel face index.

Images are y-up arrays (row 0 at the bottom), texcad's convention; they are
flipped once when written (:func:`texcad.sources.image.write_rgb8`).
"""

from __future__ import annotations

import os
from typing import Sequence

import numpy as np

from ..errors import ParameterError
from ..solid import Mesh

__all__ = ["camera", "rasterize", "render_mesh", "height_image", "write_png"]


def _unit(v, name: str) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64).reshape(-1)
    n = float(np.linalg.norm(a)) if a.shape == (3,) else 0.0
    if not (a.shape == (3,) and np.isfinite(a).all() and n > 0):
        raise ParameterError(f"{name} must be a non-zero 3-vector (x, y, z), got {v!r}")
    return a / n


def camera(view: Sequence[float], up: Sequence[float] = (0.0, 0.0, 1.0)) -> np.ndarray:
    """Orthonormal camera basis ``(3, 3)``: rows ``right, up, back``.

    Args:
        view: direction the camera looks along (from the eye into the scene).
        up: direction that should point up on the screen (made orthogonal to
            ``view``; any other vector is used if it is parallel to ``view``).
    """
    back = -_unit(view, "view")
    u = _unit(up, "up")
    u = u - (u @ back) * back
    if np.linalg.norm(u) < 1e-9:
        alt = np.array([0.0, 1.0, 0.0]) if abs(back[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
        u = alt - (alt @ back) * back
    u /= np.linalg.norm(u)
    right = np.cross(u, back)
    return np.stack([right, u, back])


def rasterize(
    xy: np.ndarray,
    depth: np.ndarray,
    faces: np.ndarray,
    width: int,
    height: int,
    *,
    cull: bool = True,
    chunk: int = 4_000_000,
) -> tuple[np.ndarray, np.ndarray]:
    """Z-buffer rasterization of triangles given in pixel coordinates.

    Pixel ``(i, j)`` (column, row from the bottom) is covered by a triangle when
    its centre ``(i + 1/2, j + 1/2)`` is inside; the nearest triangle (largest
    ``depth``) wins.

    Args:
        xy: ``(N, 2)`` vertex positions in pixels.
        depth: ``(N,)`` vertex depths, larger = nearer.
        faces: ``(M, 3)`` vertex indices.
        width, height: image size in pixels.
        cull: drop triangles that are clockwise on screen (back faces).
        chunk: candidate pixels per batch (memory ~ 100 bytes each).

    Returns:
        ``(zbuf, face)``: ``(height, width)`` float64 depth (``-inf`` where empty)
        and int64 index of the face seen at each pixel (``-1`` where empty).
    """
    W, H = int(width), int(height)
    zbuf = np.full(H * W, -np.inf)
    fbuf = np.full(H * W, -1, dtype=np.int64)
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return zbuf.reshape(H, W), fbuf.reshape(H, W)
    z = np.asarray(depth, dtype=np.float64)
    f, edges, box, keep = _edge_functions(np.asarray(xy, dtype=np.float64), f, W, H, cull)
    i0, i1, j0, j1 = box
    ny = np.where(keep, np.maximum(j1 - j0 + 1, 0), 0)
    ids = np.flatnonzero(ny * (i1 >= i0))
    if len(ids) == 0:
        return zbuf.reshape(H, W), fbuf.reshape(H, W)
    fr, row, c0, count = _spans(ids, ny[ids], edges, box)
    zabc = (z[f[:, 0]], z[f[:, 1]], z[f[:, 2]])
    _draw_spans(zbuf, fbuf, W, fr, row, c0, count, edges, zabc, chunk)
    return zbuf.reshape(H, W), fbuf.reshape(H, W)


#: Edge-function slack: pixel centres on an edge belong to both triangles (no gaps).
_EPS = -1e-7


def _edge_functions(xy: np.ndarray, f: np.ndarray, W: int, H: int, cull: bool):
    """Per face: the normalised edge functions ``w1 = A1 x + B1 y + C1`` (weight of
    vertex b) and ``w2`` (of c), ``w0 = 1 - w1 - w2``; its pixel bounding box; and
    which faces are drawn (counter-clockwise, or all with ``cull=False``, whose
    clockwise faces are flipped)."""
    a, b, c = xy[f[:, 0]], xy[f[:, 1]], xy[f[:, 2]]
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    keep = area2 > 0 if cull else area2 != 0
    # Two-sided: flip clockwise triangles so that all are counter-clockwise.
    if not cull:
        flip = area2 < 0
        b, c = np.where(flip[:, None], c, b), np.where(flip[:, None], b, c)
        f = f.copy()
        f[flip, 1], f[flip, 2] = f[flip, 2], f[flip, 1]
        area2 = np.abs(area2)
    lo = np.minimum(np.minimum(a, b), c)
    hi = np.maximum(np.maximum(a, b), c)
    i0 = np.maximum(np.ceil(lo[:, 0] - 0.5), 0).astype(np.int64)
    i1 = np.minimum(np.floor(hi[:, 0] - 0.5), W - 1).astype(np.int64)
    j0 = np.maximum(np.ceil(lo[:, 1] - 0.5), 0).astype(np.int64)
    j1 = np.minimum(np.floor(hi[:, 1] - 0.5), H - 1).astype(np.int64)
    inv = np.divide(1.0, area2, out=np.zeros_like(area2), where=area2 != 0)  # degenerate: never drawn
    A1, B1 = (c[:, 1] - a[:, 1]) * inv, (a[:, 0] - c[:, 0]) * inv  # weight of b: area(a, p, c)
    C1 = -(A1 * a[:, 0] + B1 * a[:, 1])
    A2, B2 = (a[:, 1] - b[:, 1]) * inv, (b[:, 0] - a[:, 0]) * inv  # weight of c: area(a, b, p)
    C2 = -(A2 * a[:, 0] + B2 * a[:, 1])
    return f, (A1, B1, C1, A2, B2, C2), (i0, i1, j0, j1), keep


def _spans(ids: np.ndarray, rows_per: np.ndarray, edges, box):
    """Scan-line spans: one (face, pixel row) pair per row of each face's bounding
    box, with the column range where all three edge functions are >= eps (widened by
    a pixel for rounding; the exact test decides), so that large triangles cost their
    area, not their bounding box. Returns ``(face, row, first column, count)``."""
    A1, B1, C1, A2, B2, C2 = edges
    i0, i1, j0, _ = box
    fr = np.repeat(ids, rows_per)
    first = np.concatenate([[0], np.cumsum(rows_per)[:-1]])
    row = j0[fr] + np.arange(len(fr), dtype=np.int64) - np.repeat(first, rows_per)
    y = row + 0.5
    xl = i0[fr].astype(np.float64) + 0.5
    xr = i1[fr].astype(np.float64) + 0.5
    for A, rest in (
        (A1[fr], B1[fr] * y + C1[fr]),
        (A2[fr], B2[fr] * y + C2[fr]),
        (-(A1[fr] + A2[fr]), 1.0 - (B1[fr] + B2[fr]) * y - C1[fr] - C2[fr]),
    ):  # A x + rest >= eps
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = (_EPS - rest) / A
        xl = np.where(A > 0, np.maximum(xl, bound), xl)
        xr = np.where(A < 0, np.minimum(xr, bound), xr)
        xr = np.where((A == 0) & (rest < _EPS), -np.inf, xr)
    c0 = np.maximum(np.ceil(xl - 0.5) - 1, i0[fr]).astype(np.int64)
    c1 = np.minimum(np.floor(xr - 0.5) + 1, i1[fr]).astype(np.int64)
    count = np.maximum(c1 - c0 + 1, 0)
    span = np.flatnonzero(count)
    return fr[span], row[span], c0[span], count[span]


def _draw_spans(zbuf, fbuf, W: int, fr, row, c0, count, edges, zabc, chunk: int) -> None:
    """Test every pixel of the spans (``chunk`` pixels at a time) and keep the
    nearest depth per pixel (``np.maximum.at``); ties go to the last face in order."""
    A1, B1, C1, A2, B2, C2 = edges
    za, zb, zc = zabc
    csum = np.cumsum(count)
    start = 0
    while start < len(fr):  # per chunk of pixels
        base = csum[start - 1] if start else 0
        stop = max(int(np.searchsorted(csum, base + chunk, side="right")), start + 1)
        cnt = count[start:stop]
        first = np.concatenate([[0], np.cumsum(cnt)[:-1]])
        local = np.arange(int(cnt.sum()), dtype=np.int64) - np.repeat(first, cnt)
        fi = np.repeat(fr[start:stop], cnt)
        ix = np.repeat(c0[start:stop], cnt) + local
        iy = np.repeat(row[start:stop], cnt)
        px, py = ix + 0.5, iy + 0.5
        w1 = A1[fi] * px + B1[fi] * py + C1[fi]
        w2 = A2[fi] * px + B2[fi] * py + C2[fi]
        inside = (w1 >= _EPS) & (w2 >= _EPS) & (w1 + w2 <= 1.0 - _EPS)
        if inside.any():
            fi, w1, w2 = fi[inside], w1[inside], w2[inside]
            pix = iy[inside] * W + ix[inside]
            zz = za[fi] + w1 * (zb[fi] - za[fi]) + w2 * (zc[fi] - za[fi])
            np.maximum.at(zbuf, pix, zz)  # z-buffer: nearest depth per pixel
            won = zz == zbuf[pix]
            fbuf[pix[won]] = fi[won]  # ties: the last face in order, deterministic
        start = stop


def _fit(points2: np.ndarray, width: int, height: int | None, margin: float):
    lo = points2.min(axis=0)
    hi = points2.max(axis=0)
    ext = np.maximum(hi - lo, 1e-9)
    if height is None:
        height = max(1, min(int(round(width * ext[1] / ext[0])), 4 * width))
    usable = np.array([width, height], dtype=np.float64) * (1 - 2 * margin)
    s = float(min(usable[0] / ext[0], usable[1] / ext[1]))
    centre = 0.5 * (lo + hi)
    off = np.array([width, height], dtype=np.float64) / 2 - s * centre
    return s, off, int(width), int(height)


#: Bytes per supersampled pixel of :func:`render_mesh` (float64 RGB image, depth and
#: face buffers, their temporaries): an upper estimate.
PIXEL_BYTES = 96


def _require_picture_memory(W: int, H: int, ss: int, width: int) -> None:
    """ResourceError naming the widest picture that fits, before a ``W x H`` px
    picture supersampled ``ss`` times is allocated."""
    from ..errors import ResourceError
    from ..util import available_memory

    need, have = PIXEL_BYTES * float(W * ss) * float(H * ss), available_memory()
    if need > have:
        fit = max(1, int(width * (have / (1.2 * need)) ** 0.5))
        raise ResourceError(
            f"a {W} x {H} px picture (supersample {ss}) needs about {need / 2**30:.1f} GiB of memory but this machine "
            f"has {have / 2**30:.1f} GiB available; use a width of at most {fit} px (or a smaller supersample)"
        )


def render_mesh(
    mesh: Mesh,
    *,
    face_colors: np.ndarray | Sequence[float] | None = None,
    view: Sequence[float] = (-1.0, 2.0, -1.2),
    up: Sequence[float] = (0.0, 0.0, 1.0),
    width: int = 800,
    height: int | None = None,
    light: Sequence[float] | None = None,
    ambient: float = 0.35,
    background: Sequence[float] = (1.0, 1.0, 1.0),
    supersample: int = 1,
    margin: float = 0.04,
    cull: bool = True,
    return_info: bool = False,
):
    """Render a mesh to an RGB image (orthographic, flat Lambert shading).

    Args:
        mesh: the mesh (mm).
        face_colors: ``(M, 3)`` RGB in [0, 1] per face, or one RGB for all
            (default light grey).
        view: direction the camera looks along (default: from the front left,
            above).
        up: direction shown as up on the image.
        width, height: image size in pixels; ``height`` defaults to the mesh's
            aspect ratio.
        light: direction *towards* the light (default: from the camera's upper
            left).
        ambient: share of light that reaches every face, 0..1.
        background: RGB in [0, 1].
        supersample: render at this many times the size and average down
            (anti-aliasing).
        margin: empty border as a fraction of the image size.
        cull: draw only faces turned towards the camera (closed meshes).
        return_info: also return ``{"scale": px_per_mm, "offset": (2,), "basis":
            (3, 3), "face": (H, W) face index}`` to draw overlays.

    Returns:
        ``(H, W, 3)`` float64 in [0, 1], y-up (row 0 at the bottom); with
        ``return_info``, ``(image, info)``.
    """
    if not isinstance(mesh, Mesh):
        raise ParameterError(f"render_mesh needs a texcad Mesh, got {type(mesh).__name__}")
    ss = int(supersample)
    if ss < 1 or int(width) < 1:
        raise ParameterError(f"width and supersample must be positive integers, got {width!r}, {supersample!r}")
    basis = camera(view, up)
    v = mesh.vertices.astype(np.float64)
    scr = v @ basis.T  # (N, 3): right, up, back
    s, off, W, H = _fit(scr[:, :2], int(width), height, margin)
    Ws, Hs = W * ss, H * ss
    _require_picture_memory(W, H, ss, int(width))
    xy = scr[:, :2] * (s * ss) + off * ss
    _, fidx = rasterize(xy, scr[:, 2], mesh.faces, Ws, Hs, cull=cull)
    M = mesh.num_triangles
    if face_colors is None:
        cols = np.tile([0.78, 0.78, 0.80], (M, 1))
    else:
        cols = np.asarray(face_colors, dtype=np.float64)
        cols = np.tile(cols, (M, 1)) if cols.shape == (3,) else cols
        if cols.shape != (M, 3):
            raise ParameterError(f"face_colors must be (faces, 3) = ({M}, 3) or one RGB, got {cols.shape}")
    n = mesh.face_normals().astype(np.float64)
    lt = _unit(light, "light") if light is not None else basis[2] * 0.75 + basis[1] * 0.55 - basis[0] * 0.35
    lt = lt / np.linalg.norm(lt)
    lam = np.abs(n @ lt) if not cull else np.clip(n @ lt, 0.0, 1.0)
    shade = cols * (ambient + (1.0 - ambient) * lam)[:, None]
    img = np.empty((Hs, Ws, 3))
    img[:] = np.asarray(background, dtype=np.float64)
    hit = fidx >= 0
    img[hit] = shade[fidx[hit]]
    if ss > 1:
        img = img.reshape(H, ss, W, ss, 3).mean(axis=(1, 3))
    img = np.clip(img, 0.0, 1.0)
    if return_info:
        return img, {"scale": s, "offset": off, "basis": basis, "face": fidx[::ss, ::ss]}
    return img


def height_image(
    mesh: Mesh,
    direction: Sequence[float],
    pitch: float,
    *,
    faces: np.ndarray | None = None,
    max_pixels: int = 4096,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Heights of a surface seen along ``direction``, sampled every ``pitch`` mm.

    Projects the (selected) faces orthographically onto the plane normal to
    ``direction`` and keeps the highest point along ``direction`` per pixel: a
    heightfield of what is visible from ``+direction``.

    Args:
        mesh: the mesh (mm).
        direction: the "up" of the heightfield (e.g. a flat texture's normal).
        pitch: pixel size in mm (> 0).
        faces: optional face indices to use (e.g. the texture faces).
        max_pixels: cap on each side; the pitch is enlarged to respect it.

    Returns:
        ``(heights, mask, pitch)``: ``(rows, cols)`` float64 heights in mm above the
        lowest covered pixel (y-up), bool coverage mask, and the pitch used (mm).
    """
    p = float(pitch)
    if not (np.isfinite(p) and p > 0):
        raise ParameterError(f"pitch must be a positive number of mm, got {pitch!r}")
    d = _unit(direction, "direction")
    basis = camera(-d, np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.9 else np.array([1.0, 0.0, 0.0]))
    f = mesh.faces if faces is None else mesh.faces[np.asarray(faces)]
    used = np.unique(f)
    scr = mesh.vertices.astype(np.float64) @ basis.T
    lo = scr[used, :2].min(axis=0)
    hi = scr[used, :2].max(axis=0)
    p = max(p, float((hi - lo).max()) / max_pixels)
    W = max(1, int(np.ceil((hi[0] - lo[0]) / p)))
    H = max(1, int(np.ceil((hi[1] - lo[1]) / p)))
    xy = (scr[:, :2] - lo) / p
    zb, fid = rasterize(xy, scr[:, 2], f, W, H, cull=True)
    mask = fid >= 0
    heights = np.where(mask, zb, 0.0)
    if mask.any():
        heights = np.where(mask, heights - zb[mask].min(), 0.0)
    return heights, mask, p


def write_png(path: str | os.PathLike, rgb: np.ndarray) -> None:
    """Write a y-up ``(H, W, 3)`` image in [0, 1] as an 8-bit PNG (atomic)."""
    from ..sources import write_rgb8

    write_rgb8(path, rgb)
