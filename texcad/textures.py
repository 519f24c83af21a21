"""Built-in procedural textures, seamless in both directions.

Every built-in texture is a periodic function of ``(x, y)`` in mm with a period
(its *tile*). Sampled over a whole number of tiles at a pitch that divides the tile,
it tiles exactly: the last column continues into the first. Wherever texcad accepts
a texture file, ``"builtin:NAME"`` names one of these.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ._resources import require_memory
from .errors import ParameterError
from .heightmap import Heightmap

__all__ = ["BuiltinTexture", "BUILTINS", "DEFAULT_TEXTURE", "builtin", "builtin_names", "load_texture"]

#: Prefix that names a built-in texture wherever a texture file is accepted.
PREFIX = "builtin:"


@dataclass(frozen=True)
class BuiltinTexture:
    """A procedural texture: ``func(x, y) -> unit heights in [0, 1]``, periodic.

    Attributes:
        name: the name used in ``builtin:NAME``.
        description: one line for ``texcad textures``.
        tile: ``(tx, ty)`` period in mm along x and y.
        func: maps broadcastable x, y arrays in mm to heights in [0, 1].
    """

    name: str
    description: str
    tile: tuple[float, float]
    func: Callable[[np.ndarray, np.ndarray], np.ndarray]


def _tri(t: np.ndarray) -> np.ndarray:
    """Triangle wave of period 1: 0 at integers, 1 at half-integers."""
    return 1.0 - np.abs(2.0 * (t - np.floor(t)) - 1.0)


def _diamond_knurl(x: np.ndarray, y: np.ndarray, p: float = 2.0) -> np.ndarray:
    # Two sets of 45-degree V-grooves; the pyramids between them are the knurl.
    # Shifting x by p shifts u and v by 1, so the pattern has period p in x and y.
    u, v = (x + y) / p, (x - y) / p
    return np.minimum(_tri(u + 0.5), _tri(v + 0.5))


def _lattice_distance(x: np.ndarray, y: np.ndarray, p: float, hexagonal: bool) -> np.ndarray:
    """Distance in mm to the nearest point of a square or hexagonal lattice of spacing p."""
    if not hexagonal:
        dx = x - p * np.round(x / p)
        dy = y - p * np.round(y / p)
        return np.hypot(dx, dy)
    # Hexagonal lattice as two offset rectangular lattices p x (p*sqrt3).
    q = p * np.sqrt(3.0)
    d1 = np.hypot(x - p * np.round(x / p), y - q * np.round(y / q))
    xs, ys = x - p / 2, y - q / 2
    d2 = np.hypot(xs - p * np.round(xs / p), ys - q * np.round(ys / q))
    return np.minimum(d1, d2)


def _smoothstep(e0: float, e1: float, t: np.ndarray) -> np.ndarray:
    s = np.clip((t - e0) / (e1 - e0), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def _pins(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    # Pin fins (paper, section 2; Sahiti et al.): 1.2 mm pins on a 3 mm square lattice,
    # with a short fillet so the flanks stay steep but not vertical.
    d = _lattice_distance(x, y, 3.0, hexagonal=False)
    return 1.0 - _smoothstep(0.5, 0.7, d)


def _dimples(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    # Spherical dimples (radius 1.4 mm) on a hexagonal lattice of 3 mm pitch.
    d = _lattice_distance(x, y, 3.0, hexagonal=True)
    r = 1.4
    depth = np.sqrt(np.clip(r * r - d * d, 0.0, None)) / r
    return 1.0 - depth


def _ridges(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    # Grip ridges across x: rounded crests every 2.5 mm.
    return np.sin(np.pi * x / 2.5) ** 2


_STONES_TILE = 24.0
_STONES_CELLS = 36


def _stones(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    # Irregular stones: a periodic Voronoi diagram (seeded), each cell domed and
    # separated from its neighbours by a groove. Height = (F2 - F1) distance to the
    # cell border, rounded off.
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(20011)
    # Jittered grid of seeds, so cells are irregular but of even size.
    n = int(np.sqrt(_STONES_CELLS))
    g = (np.stack(np.meshgrid(np.arange(n), np.arange(n)), -1).reshape(-1, 2) + 0.5) / n
    pts = (g + rng.uniform(-0.35, 0.35, g.shape) / n) % 1.0 * _STONES_TILE
    tree = cKDTree(pts, boxsize=_STONES_TILE)
    xb, yb = np.broadcast_arrays(x, y)
    q = np.stack([np.mod(xb, _STONES_TILE).ravel(), np.mod(yb, _STONES_TILE).ravel()], 1)
    q = np.minimum(q, np.nextafter(_STONES_TILE, 0))
    d, _ = tree.query(q, k=2)
    border = 0.5 * (d[:, 1] - d[:, 0])  # distance to the bisector, mm
    dome = np.sqrt(np.clip(border / 1.6, 0.0, 1.0))
    return dome.reshape(xb.shape)


BUILTINS: dict[str, BuiltinTexture] = {
    t.name: t
    for t in (
        BuiltinTexture("stones", "irregular stones (periodic Voronoi), 24 mm tile", (_STONES_TILE, _STONES_TILE), _stones),
        BuiltinTexture("diamond_knurl", "diamond knurl, 45 deg grooves, 2 mm pitch", (2.0, 2.0), _diamond_knurl),
        BuiltinTexture("pins", "pin fins for heat transfer, 1.2 mm pins on a 3 mm grid", (3.0, 3.0), _pins),
        BuiltinTexture("dimples", "spherical dimples on a 3 mm hexagonal grid", (3.0, 3.0 * np.sqrt(3.0)), _dimples),
        BuiltinTexture("ridges", "grip ridges across x, 2.5 mm pitch", (2.5, 2.5), _ridges),
    )
}

#: The texture ``texcad demo`` uses.
DEFAULT_TEXTURE = "stones"


def builtin_names() -> list[str]:
    """Names of the built-in textures, default first."""
    return list(BUILTINS)


def builtin(
    name: str,
    *,
    size: float | Sequence[float] | None = None,
    pitch: float = 0.125,
    height: float = 1.0,
) -> Heightmap:
    """Sample a built-in texture as a :class:`Heightmap`.

    Args:
        name: one of :func:`builtin_names` (with or without the ``builtin:`` prefix).
        size: ``(width, depth)`` in mm (or one number for a square); default one tile.
        pitch: mm per pixel. It is adjusted slightly so that a whole number of pixels
            spans each tile, which keeps the texture exactly periodic.
        height: maximum height in mm.

    Returns:
        Heightmap with heights in ``[0, height]`` mm. Over a whole number of tiles
        it tiles seamlessly in x and y.

    Raises:
        ParameterError: unknown name, non-positive size, pitch or height.
    """
    key = name[len(PREFIX):] if name.startswith(PREFIX) else name
    if key not in BUILTINS:
        raise ParameterError(
            f"unknown built-in texture {key!r}; choose one of {', '.join(BUILTINS)} "
            "(`texcad textures` lists them)"
        )
    tex = BUILTINS[key]
    for label, v in (("pitch", pitch), ("height", height)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
            raise ParameterError(f"{label} must be a positive number of mm, got {v!r}")
    if size is None:
        w, d = tex.tile
    elif np.ndim(size) == 0:
        w = d = float(size)  # type: ignore[arg-type]
    else:
        w, d = (float(s) for s in size)  # type: ignore[union-attr]
    if not (w > 0 and d > 0 and np.isfinite(w) and np.isfinite(d)):
        raise ParameterError(f"size must be positive mm, got {size!r}")
    # Whole number of pixels per tile keeps the sampling periodic.
    px = tex.tile[0] / max(1, round(tex.tile[0] / pitch))
    py = tex.tile[1] / max(1, round(tex.tile[1] / pitch))
    cols, rows = max(2, int(round(w / px))), max(2, int(round(d / py)))
    require_memory(rows * cols * 8 * 6, f"a {rows} x {cols} px texture", "use a larger pitch or a smaller size")
    x = (np.arange(cols) + 0.5) * px
    y = (np.arange(rows) + 0.5) * py
    unit = tex.func(x[None, :], y[:, None])
    unit = np.broadcast_to(unit, (rows, cols)).astype(np.float64)
    # Normalise what was sampled, so the lowest pixel lies on the surface (black)
    # and the highest is exactly ``height`` (white), as for an image (section 2.1.4).
    lo, hi = float(unit.min()), float(unit.max())
    unit = (unit - lo) / (hi - lo) if hi > lo else np.zeros_like(unit)
    return Heightmap((unit * height).astype(np.float32), (px, py))


def load_texture(
    spec: "str | os.PathLike | Heightmap",
    *,
    size: float | Sequence[float] | None = None,
    pitch: float | None = None,
    height: float = 1.0,
) -> Heightmap:
    """Resolve a texture given as ``builtin:NAME``, an image path, or a Heightmap.

    Args:
        spec: ``"builtin:NAME"``, a PNG/JPEG/TIFF path, or a Heightmap (returned as is
            unless ``height`` differs from its maximum, then rescaled).
        size: ``(width, depth)`` in mm the texture covers.
        pitch: mm per pixel (default 0.125 mm for built-ins).
        height: maximum height in mm.
    """
    if isinstance(spec, Heightmap):
        return spec if np.isclose(spec.max_height, height) else spec.scaled(height)
    s = os.fspath(spec)
    if s.startswith(PREFIX):
        return builtin(s, size=size, pitch=0.125 if pitch is None else pitch, height=height)
    if size is None and pitch is None:
        raise ParameterError(
            f"say how large the image {s!r} is: give its size in mm (e.g. size=(100, 100)) or its pitch in mm per pixel"
        )
    return Heightmap.from_image(s, size=size, pitch=pitch, height=height)
