"""Solid (3-D) textures: heights as a function of the point in space, in mm.

A solid texture needs no projection, so it has no seam and no stretch anywhere on
a part: ``h(p)`` for a point ``p`` (mm) of the surface, periodic in x, y and z with
the tile of the texture. They are the 3-D forms of built-ins where that makes sense:

* ``stones``: a periodic 3-D Voronoi diagram of ``count^3`` jittered seeds per
  tile of ``cell * count`` mm; height ``sqrt(clip((F2 - F1) / (2 dome), 0, 1))``
  (``F1``, ``F2`` the distances to the nearest and second-nearest seed, so
  ``(F2 - F1)/2`` is the distance to the cell wall), the 3-D analogue of the flat
  stones;
* ``leather``: the same with small cells and a fine noise;
* ``sand``: periodic 3-D value noise with feature size ``grain`` mm (seeded values
  on a periodic lattice, interpolated with the quintic fade ``6t^5 - 15t^4 + 10t^3``),
  two octaves;
* ``diamond_knurl`` (and ``knurl_fine``) / ``straight_knurl``: knurls as helices about the z axis (or the
  ``axis`` given) through ``origin``: with ``theta`` the angle about the axis and
  ``z`` along it, ``N = round(2 pi r / period)`` starts at the reference radius ``r``,
  ``s = theta N / 2 pi``: the diamond knurl is ``min(tri(s + z/period + 1/2),
  tri(s - z/period + 1/2))`` (left- and right-hand helices), the straight knurl
  ``tri(s + 1/2)``; whole starts round, so no seam.

Every function returns unit heights in [0, 1]; randomness from
``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import ParameterError

__all__ = ["SOLID_TEXTURES", "solid_texture"]

Func3 = Callable[[np.ndarray], np.ndarray]
_CHUNK = 200_000


def _tri(t: np.ndarray) -> np.ndarray:
    return 1.0 - 2.0 * np.abs(t - np.floor(t) - 0.5)


def _voronoi3(p: np.ndarray, cell: float, count: int, jitter: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Distances ``F1 <= F2`` (mm) to the two nearest seeds of a periodic jittered grid."""
    rng = np.random.default_rng(seed)
    off = 0.5 + jitter * (rng.random((count, count, count, 3)) - 0.5)  # seed offsets in cells
    f1 = np.full(len(p), np.inf)
    f2 = np.full(len(p), np.inf)
    for s in range(0, len(p), _CHUNK):  # per chunk of points
        q = p[s : s + _CHUNK] / cell
        base = np.floor(q).astype(np.int64)
        a = np.full(len(q), np.inf)
        b = np.full(len(q), np.inf)
        for dx in (-1, 0, 1):  # per neighbouring cell (27)
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    c = base + (dx, dy, dz)
                    o = off[c[:, 0] % count, c[:, 1] % count, c[:, 2] % count]
                    d = np.linalg.norm(c + o - q, axis=1)
                    b = np.minimum(b, np.maximum(a, d))
                    a = np.minimum(a, d)
        f1[s : s + _CHUNK], f2[s : s + _CHUNK] = a * cell, b * cell
    return f1, f2


def _noise3(p: np.ndarray, grain: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """Periodic value noise in [0, 1]: lattice spacing ``grain`` mm, period ``n`` cells."""
    lat = rng.random((n, n, n))
    q = p / grain
    i = np.floor(q).astype(np.int64)
    t = q - i
    w = t * t * t * (t * (6 * t - 15) + 10)
    out = np.zeros(len(p))
    for cx in (0, 1):  # per lattice corner (8)
        for cy in (0, 1):
            for cz in (0, 1):
                val = lat[(i[:, 0] + cx) % n, (i[:, 1] + cy) % n, (i[:, 2] + cz) % n]
                wx = w[:, 0] if cx else 1 - w[:, 0]
                wy = w[:, 1] if cy else 1 - w[:, 1]
                wz = w[:, 2] if cz else 1 - w[:, 2]
                out += val * wx * wy * wz
    return out


def _stones(cell: float = 4.0, count: int = 6, dome: float = 1.6, seed: int = 20011, **_) -> Func3:
    def f(p):
        f1, f2 = _voronoi3(p, cell, count, 0.7, seed)
        return np.sqrt(np.clip(0.5 * (f2 - f1) / dome, 0.0, 1.0))

    return f


def _leather(cell: float = 1.2, count: int = 14, seed: int = 7, **_) -> Func3:
    def f(p):
        f1, f2 = _voronoi3(p, cell, count, 0.9, seed)
        pebble = np.sqrt(np.clip(0.5 * (f2 - f1) / (0.3 * cell), 0.0, 1.0))
        return 0.9 * pebble + 0.1 * _noise3(p, cell / 3, 3 * count, np.random.default_rng(seed + 1))

    return f


def _sand(grain: float = 0.4, tile: float = 12.0, seed: int = 3, **_) -> Func3:
    n = max(1, int(round(tile / grain)))
    g = tile / n

    def f(p):
        rng = np.random.default_rng(seed)
        return (_noise3(p, g, n, rng) + 0.5 * _noise3(p, g / 2, 2 * n, rng)) / 1.5

    return f


def _helix(p: np.ndarray, period: float, origin, axis) -> tuple[np.ndarray, np.ndarray]:
    a = np.asarray(axis, dtype=np.float64)
    a = a / np.linalg.norm(a)
    q = p - np.asarray(origin, dtype=np.float64)
    z = q @ a
    r = q - z[:, None] * a
    k = int(np.argmax(np.abs(a)))
    eu = np.cross(np.eye(3)[(k + 2) % 3], a)
    eu /= np.linalg.norm(eu)
    ev = np.cross(a, eu)
    theta = np.arctan2(r @ ev, r @ eu)
    rho = float(np.linalg.norm(r, axis=1).mean()) if len(r) else period
    starts = max(1, int(round(2 * np.pi * rho / period)))
    return theta * starts / (2 * np.pi), z / period


def _diamond_knurl(period: float = 2.0, origin=(0, 0, 0), axis=(0, 0, 1), **_) -> Func3:
    def f(p):
        s, z = _helix(p, period, origin, axis)
        return np.minimum(_tri(s + z + 0.5), _tri(s - z + 0.5))

    return f


def _straight_knurl(period: float = 1.0, origin=(0, 0, 0), axis=(0, 0, 1), **_) -> Func3:
    def f(p):
        s, _z = _helix(p, period, origin, axis)
        return _tri(s + 0.5)

    return f


#: Built-ins with a solid form: ``name -> make(**params) -> func(points) -> [0, 1]``.
SOLID_TEXTURES: dict[str, Callable[..., Func3]] = {
    "stones": _stones,
    "leather": _leather,
    "sand": _sand,
    "diamond_knurl": _diamond_knurl,
    "knurl_fine": _diamond_knurl,
    "straight_knurl": _straight_knurl,
}


def solid_texture(name: str, *, scale: float = 1.0, origin=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), **params: float) -> Func3:
    """The solid form of built-in ``name``: ``func(points (N, 3) mm) -> (N,)`` unit
    heights in [0, 1]. ``scale`` multiplies every length (the knurls' ``period``,
    the stones' ``cell`` ...); ``params`` are the built-in's parameters (mm, counts,
    seed); ``origin`` and ``axis`` place the knurls' helix axis (mm).

    Raises:
        ParameterError: no solid form for ``name``, or an unknown parameter.
    """
    key = name[len("builtin:"):] if name.startswith("builtin:") else name
    if key not in SOLID_TEXTURES:
        raise ParameterError(
            f"texture {key!r} has no solid (3-D) form; solid textures are {', '.join(SOLID_TEXTURES)} "
            "(or use a projection: planar, cylindrical, spherical, triplanar, cubic)"
        )
    from .textures import BUILTINS

    known = BUILTINS[key].params
    bad = sorted(set(params) - set(known))
    if bad:
        raise ParameterError(f"unknown parameter {bad[0]!r} for texture {key!r}; its parameters are {', '.join(known)}")
    values = {k: float(params.get(k, p.default)) * (scale if p.unit == "mm" else 1.0) for k, p in known.items()}
    for k, p in known.items():
        if p.unit in ("count", "seed"):
            values[k] = int(values[k])
        elif not values[k] > 0:
            raise ParameterError(f"parameter {k} of texture {key!r} must be positive, got {values[k]!r}")
    return SOLID_TEXTURES[key](origin=origin, axis=axis, **values)
