"""Built-in procedural textures, seamless in both directions, sized in mm.

Every built-in texture is a periodic function of ``(x, y)`` in mm with a period
(its *tile*). Sampled over a whole number of tiles at a pitch that divides the tile,
it tiles exactly: the last column continues into the first. Wherever texcad accepts
a texture file, ``"builtin:NAME"`` names one of these.

Textures are parametric: each has named parameters (lengths in mm, angles in
degrees, counts, a seed) with defaults, and one ``scale`` factor that multiplies
every length at once::

    builtin("pins", pitch=0.1, height=2.0)                  # defaults
    builtin("pins", period=4.0, diameter=1.6)               # pins 1.6 mm on 4 mm
    builtin("stones", scale=0.5)                            # stones half as large
    load_texture("builtin:pins:period=4,diameter=1.6", ...) # the same as a string

Random textures (stones, leather, sand, wood) draw their randomness from
``numpy.random.default_rng(seed)`` with the texture's ``seed`` parameter, and their
noise is periodic by construction (seeded values on a periodic lattice, interpolated
with a periodic cubic B-spline), so the same parameters always give the same bytes.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from ..util import require_pitch
from ..util import positive, smoothstep
from ..errors import ParameterError
from .heightmap import Heightmap

__all__ = [
    "PREFIX",
    "BuiltinTexture",
    "Param",
    "BUILTINS",
    "DEFAULT_TEXTURE",
    "builtin",
    "builtin_names",
    "load_texture",
    "parse_texture_spec",
]

#: Prefix that names a built-in texture wherever a texture file is accepted.
PREFIX = "builtin:"

Func = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Param:
    """One parameter of a built-in texture.

    Attributes:
        default: default value.
        unit: ``"mm"`` (a length, > 0, multiplied by ``scale``), ``"deg"`` (an angle
            in degrees, 0 <= a < 90), ``"count"`` (an integer >= 1) or ``"seed"``
            (an integer >= 0 for ``numpy.random.default_rng``).
        doc: what the parameter sets.
    """

    default: float
    unit: str
    doc: str


@dataclass(frozen=True)
class BuiltinTexture:
    """A procedural texture: ``func(x, y) -> unit heights in [0, 1]``, periodic.

    Attributes:
        name: the name used in ``builtin:NAME``.
        description: one line for ``texcad textures`` (with the default parameters).
        tile: ``(tx, ty)`` period in mm along x and y, at the default parameters.
        func: maps broadcastable x, y arrays in mm to heights in [0, 1], at the
            default parameters.
        params: the parameters, ``{name: Param}``.
        make: ``make(**params) -> (tile, func)`` builds the texture for other
            parameter values (all parameters given, lengths in mm).
    """

    name: str
    description: str
    tile: tuple[float, float]
    func: Func
    params: Mapping[str, Param] = field(default_factory=dict)
    make: Callable[..., tuple[tuple[float, float], Func]] | None = None

    def configure(self, *, scale: float = 1.0, **params: Any) -> tuple[tuple[float, float], Func]:
        """The tile ``(tx, ty)`` in mm and the unit-height function for these parameters.

        Args:
            scale: factor (> 0) applied to every length parameter (unit ``"mm"``),
                after ``params``; the texture grows by ``scale`` in x and y.
            **params: parameter values overriding the defaults (see ``params``).

        Raises:
            ParameterError: unknown parameter or value out of range.
        """
        scale = positive(f"scale of texture {self.name!r}", scale, unit="")
        unknown = sorted(set(params) - set(self.params))
        if unknown:
            known = ", ".join(self.params) or "none"
            raise ParameterError(
                f"unknown parameter {unknown[0]!r} for texture {self.name!r}; its parameters are: {known}"
            )
        if self.make is None:
            if scale != 1.0:
                tx, ty = self.tile
                f = self.func
                return (tx * scale, ty * scale), lambda x, y: f(x / scale, y / scale)
            return self.tile, self.func
        values = {k: _check_param(self.name, k, p, params.get(k, p.default)) for k, p in self.params.items()}
        for k, p in self.params.items():
            if p.unit == "mm":
                values[k] *= scale
        tile, func = self.make(**values)
        return (float(tile[0]), float(tile[1])), func




def _check_param(tex: str, name: str, p: Param, value: Any) -> float:
    where = f"of texture {tex!r}"
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"parameter {name} {where} must be a number, got {value!r}") from None
    if not np.isfinite(v):
        raise ParameterError(f"parameter {name} {where} must be finite, got {value!r}")
    if p.unit == "mm":
        if v <= 0:
            raise ParameterError(f"parameter {name} {where} is a length and must be > 0 mm, got {value!r}")
        return v
    if p.unit == "deg":
        if not 0.0 <= v < 90.0:
            raise ParameterError(f"parameter {name} {where} is an angle and must be in [0, 90) degrees, got {value!r}")
        return v
    if v != round(v):
        raise ParameterError(f"parameter {name} {where} must be a whole number, got {value!r}")
    if p.unit == "count" and not 1 <= v <= 256:
        raise ParameterError(f"parameter {name} {where} must be a count from 1 to 256, got {value!r}")
    if p.unit == "seed" and v < 0:
        raise ParameterError(f"parameter {name} {where} must be a seed >= 0, got {value!r}")
    return int(v)


# -- building blocks ---------------------------------------------------------------
def _tri(t: np.ndarray) -> np.ndarray:
    """Triangle wave of period 1: 0 at integers, 1 at half-integers."""
    return 1.0 - np.abs(2.0 * (t - np.floor(t)) - 1.0)




def _wrap(t: np.ndarray, p: float) -> np.ndarray:
    """Signed offset of ``t`` from the nearest multiple of ``p``: in [-p/2, p/2]."""
    return t - p * np.round(t / p)


def _lattice_distance(x: np.ndarray, y: np.ndarray, p: float, hexagonal: bool) -> np.ndarray:
    """Distance in mm to the nearest point of a square or hexagonal lattice of spacing p."""
    if not hexagonal:
        return np.hypot(_wrap(x, p), _wrap(y, p))
    dx, dy = _hex_offset(x, y, p)
    return np.hypot(dx, dy)


def _hex_offset(x: np.ndarray, y: np.ndarray, p: float) -> tuple[np.ndarray, np.ndarray]:
    """Offset ``(dx, dy)`` in mm from the nearest point of the hexagonal lattice with
    nearest-neighbour spacing ``p`` and points at ``(i p + j p/2, j p sqrt3/2)``.

    The lattice is the union of two rectangular lattices ``p x p sqrt3`` offset by
    ``(p/2, p sqrt3/2)``; the nearer of the two nearest points wins. Period
    ``(p, p sqrt3)``.
    """
    q = p * np.sqrt(3.0)
    d1x, d1y = _wrap(x, p), _wrap(y, q)
    d2x, d2y = _wrap(x - p / 2, p), _wrap(y - q / 2, q)
    first = d1x * d1x + d1y * d1y <= d2x * d2x + d2y * d2y
    return np.where(first, d1x, d2x), np.where(first, d1y, d2y)


def _periodic_noise(
    x: np.ndarray,
    y: np.ndarray,
    tile: tuple[float, float],
    cells: tuple[int, int],
    rng: np.random.Generator,
    octaves: int = 1,
    gain: float = 0.5,
) -> np.ndarray:
    """Periodic smooth noise of unit standard deviation (about).

    Octave ``k`` draws standard-normal values on a ``(cells_y 2^k) x (cells_x 2^k)``
    lattice that wraps around the tile, and interpolates them with a periodic cubic
    B-spline (``scipy.ndimage.map_coordinates``, ``mode="grid-wrap"``); octaves add
    with amplitude ``gain^k``. Because the lattice wraps, the noise has exactly the
    tile's period. Feature size of octave 0: ``tile / cells`` mm.
    """
    from scipy import ndimage

    xb, yb = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
    out = np.zeros(xb.shape)
    total = 0.0
    for k in range(octaves):  # per octave, not per pixel
        nx, ny = cells[0] << k, cells[1] << k
        lattice = rng.standard_normal((ny, nx))
        u = np.mod(xb / tile[0], 1.0) * nx
        v = np.mod(yb / tile[1], 1.0) * ny
        coeffs = ndimage.spline_filter(lattice, order=3, mode="grid-wrap")
        val = ndimage.map_coordinates(coeffs, [v.ravel(), u.ravel()], order=3, mode="grid-wrap", prefilter=False)
        out += gain**k * val.reshape(xb.shape)
        total += gain ** (2 * k)
    # A cubic B-spline through unit-variance values has variance about 0.45.
    return out / np.sqrt(0.45 * total)


def _voronoi(
    x: np.ndarray, y: np.ndarray, tile: float, n: int, jitter: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Distances ``(F1, F2)`` in mm to the nearest and second-nearest seed of a
    periodic Voronoi diagram on a square tile.

    Seeds: an ``n x n`` grid jittered by up to ``jitter`` of a cell, wrapped into the
    tile; distances are measured on the torus (``cKDTree(boxsize=tile)``), so the
    diagram has exactly the tile's period.
    """
    from scipy.spatial import cKDTree

    g = (np.stack(np.meshgrid(np.arange(n), np.arange(n)), -1).reshape(-1, 2) + 0.5) / n
    pts = (g + rng.uniform(-jitter, jitter, g.shape) / n) % 1.0 * tile
    tree = cKDTree(pts, boxsize=tile)
    xb, yb = np.broadcast_arrays(x, y)
    q = np.stack([np.mod(xb, tile).ravel(), np.mod(yb, tile).ravel()], 1)
    q = np.minimum(q, np.nextafter(tile, 0))
    d, _ = tree.query(q, k=2)
    return d[:, 0].reshape(xb.shape), d[:, 1].reshape(xb.shape)


def _need(cond: bool, tex: str, msg: str) -> None:
    if not cond:
        raise ParameterError(f"texture {tex!r}: {msg}")


# -- the textures --------------------------------------------------------------------
# Each maker takes every parameter (lengths in mm) and returns (tile, func).


def _make_stones(cell: float, count: int, dome: float, seed: int):
    # Irregular stones: a periodic Voronoi diagram of count x count jittered seeds,
    # each cell domed and separated from its neighbours by a groove. Height: the
    # distance to the cell border, (F2 - F1)/2 mm, rounded off as sqrt(border/dome).
    tile = cell * count

    def f(x, y):
        f1, f2 = _voronoi(x, y, tile, count, 0.35, np.random.default_rng(seed))
        border = 0.5 * (f2 - f1)  # distance to the bisector, mm
        return np.sqrt(np.clip(border / dome, 0.0, 1.0))

    return (tile, tile), f


def _make_diamond_knurl(period: float):
    # Two sets of 45-degree V-grooves; the pyramids between them are the knurl.
    # Shifting x by p shifts u and v by 1, so the pattern has period p in x and y.
    def f(x, y):
        u, v = (x + y) / period, (x - y) / period
        return np.minimum(_tri(u + 0.5), _tri(v + 0.5))

    return (period, period), f


def _make_straight_knurl(period: float):
    # V-grooves along y (the extrusion, the axis of a knurled cylinder), crests
    # every `period` mm across x: h = tri(x / p + 1/2), 90-degree-ish V for h ~ p/2.
    def f(x, y):
        return np.broadcast_to(_tri(x / period + 0.5), np.broadcast_shapes(np.shape(x), np.shape(y)))

    return (period, period), f


def _make_pins(period: float, diameter: float, flank: float, hexagonal: bool = False, name: str = "pins"):
    # Pin fins (paper, section 2; Sahiti et al.): flat-topped round pins with a
    # sloped flank `flank` mm wide, so the sides are steep but not vertical:
    # h = 1 - smoothstep(r - flank/2, r + flank/2, d), d = distance to the pin axis.
    _need(diameter + flank < period, name, f"diameter + flank ({diameter:g} + {flank:g} mm) must be less than the period ({period:g} mm)")
    r = diameter / 2

    def f(x, y):
        d = _lattice_distance(x, y, period, hexagonal=hexagonal)
        return 1.0 - smoothstep(r - flank / 2, r + flank / 2, d)

    return (period, period * np.sqrt(3.0) if hexagonal else period), f


def _make_pins_staggered(period: float, diameter: float, flank: float):
    return _make_pins(period, diameter, flank, hexagonal=True, name="pins_staggered")


def _make_dimples(period: float, radius: float):
    # Spherical dimples on a hexagonal lattice: depth sqrt(r^2 - d^2) / r.
    def f(x, y):
        d = _lattice_distance(x, y, period, hexagonal=True)
        return 1.0 - np.sqrt(np.clip(radius * radius - d * d, 0.0, None)) / radius

    return (period, period * np.sqrt(3.0)), f


def _make_ridges(period: float):
    # Grip ridges: rounded crests parallel to y, every `period` mm along x:
    # h = sin^2(pi x / p).
    def f(x, y):
        return np.broadcast_to(np.sin(np.pi * x / period) ** 2, np.broadcast_shapes(np.shape(x), np.shape(y)))

    return (period, period), f


def _make_chevrons(period: float, width: float, angle: float):
    # Herringbone grip: ridges h = sin^2(pi (y + tan(a) w/2 tri(x/w)) / p) folded
    # into V shapes `width` mm wide, arms at `angle` degrees to x.
    t = math.tan(math.radians(angle))

    def f(x, y):
        return np.sin(np.pi * (y + t * (width / 2) * _tri(x / width)) / period) ** 2

    return (width, period), f


def _make_hexagons(period: float, groove: float, bevel: float):
    # Raised hexagonal tiles (honeycomb) on a hexagonal lattice of centre spacing
    # `period`, separated by grooves `groove` mm wide with `bevel` mm chamfers.
    # Hexagonal distance of the offset (dx, dy) from the cell centre:
    # max(|dx|, |dx/2 + dy sqrt3/2|, |-dx/2 + dy sqrt3/2|); the border lies at p/2.
    _need(groove + 2 * bevel < period, "hexagons", f"groove + 2 bevel ({groove:g} + 2 x {bevel:g} mm) must be less than the period ({period:g} mm)")

    def f(x, y):
        return smoothstep(groove / 2, groove / 2 + bevel, _hex_border(x, y, period))

    return (period, period * np.sqrt(3.0)), f


def _hex_border(x: np.ndarray, y: np.ndarray, period: float) -> np.ndarray:
    """Distance (mm, hexagonal metric) from ``(x, y)`` to its lattice cell's border."""
    s3 = np.sqrt(3.0) / 2
    dx, dy = _hex_offset(x, y, period)
    hexd = np.maximum(np.abs(dx), np.maximum(np.abs(0.5 * dx + s3 * dy), np.abs(-0.5 * dx + s3 * dy)))
    return period / 2 - hexd


def _make_scales(period: float, radius: float, bevel: float):
    # Fish scales: discs of `radius` mm in rows `period/2` apart, alternate rows
    # shifted by period/2. Where discs overlap the one of the higher row lies on top,
    # so every scale shows its lower arc as a free edge. On its scale the height
    # rises linearly towards the free edge, h = 0.2 + 0.8 (1 + (yc - y)/R)/2, and is
    # rounded off over the last `bevel` mm of the rim.
    _need(period / 2 < radius <= 1.5 * period, "scales", f"radius ({radius:g} mm) must be more than half the period and at most 1.5 periods ({period / 2:g} < r <= {1.5 * period:g} mm)")
    _need(bevel < radius, "scales", f"bevel ({bevel:g} mm) must be less than the radius ({radius:g} mm)")
    q = period / 2

    def f(x, y):
        xb, yb = np.broadcast_arrays(np.asarray(x, np.float64), np.asarray(y, np.float64))
        j0 = np.floor(yb / q)
        best_j = np.full(xb.shape, -np.inf)
        h = np.zeros(xb.shape)
        for dj in range(-3, 4):  # candidate rows, not pixels
            j = j0 + dj
            off = np.where(np.mod(j, 2.0) == 1.0, period / 2, 0.0)
            dx = _wrap(xb - off, period)
            dy = yb - j * q
            d = np.hypot(dx, dy)
            inside = (d < radius) & (j > best_j)
            hj = (0.2 + 0.4 * (1.0 - dy / radius)) * smoothstep(0.0, bevel, radius - d)
            h = np.where(inside, hj, h)
            best_j = np.where(inside, j, best_j)
        return h

    return (period, period), f


def _make_brick(length: float, course: float, mortar: float, bevel: float):
    # Running-bond brick: bricks `length` x `course` mm (centre to centre), every
    # other course shifted by half a brick; mortar grooves `mortar` mm wide with
    # `bevel` mm chamfers: h = smoothstep(m/2, m/2 + b, distance to the joint).
    _need(mortar + 2 * bevel < min(length, course), "brick", f"mortar + 2 bevel ({mortar:g} + 2 x {bevel:g} mm) must be less than the course ({course:g} mm) and the length ({length:g} mm)")

    def f(x, y):
        row = np.floor(y / course)
        u = np.mod(x - np.mod(row, 2.0) * length / 2, length)
        v = np.mod(y, course)
        dist = np.minimum(np.minimum(u, length - u), np.minimum(v, course - v))
        return smoothstep(mortar / 2, mortar / 2 + bevel, dist)

    return (length, 2 * course), f


def _make_weave(spacing: float, width: float):
    # Plain weave: warp threads along y at x = (i + 1/2) s, weft threads along x at
    # y = (j + 1/2) s, each with an elliptic cross-section c = sqrt(1 - (2d/w)^2)
    # and going over and under: warp height z = cos(pi (y/s - 1/2 + i)), weft
    # z = -cos(pi (x/s - 1/2 + j)), so at crossing (i, j) the warp is on top when i + j
    # is even. h = max over both threads of c (0.55 + 0.45 z).
    _need(width <= spacing, "weave", f"thread width ({width:g} mm) must not exceed the spacing ({spacing:g} mm)")

    def f(x, y):
        u, v = x / spacing, y / spacing
        i, j = np.floor(u), np.floor(v)
        cw = np.sqrt(np.clip(1.0 - (2.0 * np.abs(u - i - 0.5) * spacing / width) ** 2, 0.0, None))
        cf = np.sqrt(np.clip(1.0 - (2.0 * np.abs(v - j - 0.5) * spacing / width) ** 2, 0.0, None))
        zw = np.cos(np.pi * (v - 0.5 + i))
        zf = -np.cos(np.pi * (u - 0.5 + j))
        return np.maximum(cw * (0.55 + 0.45 * zw), cf * (0.55 + 0.45 * zf))

    return (2 * spacing, 2 * spacing), f


def _make_leather(cell: float, count: int, seed: int):
    # Pebbled leather: small domed Voronoi cells (count x count per tile, F2 - F1
    # border distance, h = sqrt(border / (0.3 cell))) plus fine periodic wrinkles.
    tile = cell * count

    def f(x, y):
        rng = np.random.default_rng(seed)
        f1, f2 = _voronoi(x, y, tile, count, 0.45, rng)
        pebble = np.sqrt(np.clip(0.5 * (f2 - f1) / (0.3 * cell), 0.0, 1.0))
        wrinkle = _periodic_noise(x, y, (tile, tile), (3 * count, 3 * count), rng, octaves=2)
        return 0.8 * pebble + 0.07 * wrinkle

    return (tile, tile), f


def _make_sand(grain: float, tile: float, seed: int):
    # Sand-blasted / cast roughness: two octaves of periodic cubic-spline noise with
    # feature size `grain` mm (the lattice spacing, rounded so a whole number of
    # lattice cells spans the tile).
    _need(grain < tile, "sand", f"grain ({grain:g} mm) must be smaller than the tile ({tile:g} mm)")
    n = max(1, int(round(tile / grain)))

    def f(x, y):
        return _periodic_noise(x, y, (tile, tile), (n, n), np.random.default_rng(seed), octaves=2)

    return (tile, tile), f


def _make_wood(spacing: float, rings: int, length: float, wobble: float, seed: int):
    # Brushed wood grain along x: growth rings every `spacing` mm across y, bent by
    # low-frequency periodic noise (amplitude `wobble` mm) and stand proud as narrow
    # latewood ridges, h = exp(-((frac(t) - 1/2) / 0.18)^2), t = (y + wobble n(x, y))
    # / spacing, plus fine fibres stretched along x. Tile: `length` x rings spacing.
    ty = spacing * rings

    def f(x, y):
        rng = np.random.default_rng(seed)
        bend = _periodic_noise(x, y, (length, ty), (3, max(1, rings // 3)), rng)
        fibre = _periodic_noise(x, y, (length, ty), (6, 8 * rings), rng)
        t = (y + wobble * bend) / spacing
        ring = np.exp(-(((t - np.floor(t)) - 0.5) / 0.18) ** 2)
        return 0.85 * ring + 0.06 * fibre

    return (length, ty), f


def _register(name: str, description: str, make: Callable[..., tuple[tuple[float, float], Func]], **params: Param) -> BuiltinTexture:
    values = {k: (p.default if p.unit in ("mm", "deg") else int(p.default)) for k, p in params.items()}
    tile, func = make(**values)
    shown = ", ".join(
        f"{k} {p.default:g} {p.unit}" if p.unit in ("mm", "deg") else f"{k} {int(p.default)}" for k, p in params.items()
    )
    return BuiltinTexture(name, f"{description} ({shown})" if shown else description, (float(tile[0]), float(tile[1])), func, dict(params), make)


_MM, _DEG, _COUNT, _SEED = "mm", "deg", "count", "seed"

BUILTINS: dict[str, BuiltinTexture] = {
    t.name: t
    for t in (
        _register(
            "stones", "irregular stones, periodic Voronoi, 24 mm tile", _make_stones,
            cell=Param(4.0, _MM, "mean stone size"), count=Param(6, _COUNT, "stones per tile side"),
            dome=Param(1.6, _MM, "distance from the joint over which a stone rounds up"), seed=Param(20011, _SEED, "random seed"),
        ),
        _register("diamond_knurl", "diamond knurl, 45 deg V-grooves", _make_diamond_knurl, period=Param(2.0, _MM, "groove pitch")),
        _register(
            "pins", "pin fins for heat transfer, square grid", _make_pins,
            period=Param(3.0, _MM, "pin spacing"), diameter=Param(1.2, _MM, "pin diameter at mid-flank"),
            flank=Param(0.2, _MM, "radial width of the sloped flank"),
        ),
        _register("dimples", "spherical dimples on a hexagonal grid", _make_dimples, period=Param(3.0, _MM, "dimple spacing"), radius=Param(1.4, _MM, "dimple radius")),
        _register("ridges", "grip ridges, rounded crests parallel to y", _make_ridges, period=Param(2.5, _MM, "ridge spacing")),
        _register("straight_knurl", "straight knurl, V-grooves parallel to y", _make_straight_knurl, period=Param(1.0, _MM, "groove pitch")),
        _register(
            "pins_staggered", "pin fins for heat transfer, staggered (hexagonal) grid", _make_pins_staggered,
            period=Param(3.0, _MM, "pin spacing"), diameter=Param(1.2, _MM, "pin diameter at mid-flank"),
            flank=Param(0.2, _MM, "radial width of the sloped flank"),
        ),
        _register(
            "hexagons", "raised hexagonal tiles, honeycomb", _make_hexagons,
            period=Param(5.0, _MM, "tile centre spacing"), groove=Param(0.6, _MM, "groove width"), bevel=Param(0.5, _MM, "chamfer width"),
        ),
        _register(
            "scales", "overlapping fish scales", _make_scales,
            period=Param(4.0, _MM, "scale spacing along x"), radius=Param(2.6, _MM, "scale radius"), bevel=Param(0.3, _MM, "rim rounding"),
        ),
        _register(
            "chevrons", "herringbone grip ridges", _make_chevrons,
            period=Param(3.0, _MM, "ridge spacing along y"), width=Param(12.0, _MM, "width of one V"), angle=Param(30.0, _DEG, "arm angle to x"),
        ),
        _register(
            "brick", "running-bond brick", _make_brick,
            length=Param(8.0, _MM, "brick length"), course=Param(4.0, _MM, "course height"),
            mortar=Param(0.8, _MM, "joint width"), bevel=Param(0.4, _MM, "chamfer width"),
        ),
        _register("weave", "plain-woven fabric", _make_weave, spacing=Param(1.5, _MM, "thread spacing"), width=Param(1.3, _MM, "thread width")),
        _register(
            "leather", "pebbled leather grain", _make_leather,
            cell=Param(1.2, _MM, "pebble size"), count=Param(14, _COUNT, "pebbles per tile side"), seed=Param(7, _SEED, "random seed"),
        ),
        _register("sand", "sand-blasted roughness, periodic noise", _make_sand, grain=Param(0.4, _MM, "grain size"), tile=Param(12.0, _MM, "tile size"), seed=Param(3, _SEED, "random seed")),
        _register(
            "wood", "brushed wood grain along x", _make_wood,
            spacing=Param(1.5, _MM, "growth ring spacing"), rings=Param(8, _COUNT, "rings per tile"),
            length=Param(40.0, _MM, "tile length along the grain"), wobble=Param(1.0, _MM, "ring waviness"), seed=Param(11, _SEED, "random seed"),
        ),
    )
}

#: The texture ``texcad demo`` uses.
DEFAULT_TEXTURE = "stones"

_RESERVED = {"size", "pitch", "height", "scale", "name"}
assert not any(_RESERVED & set(t.params) for t in BUILTINS.values())


def builtin_names() -> list[str]:
    """Names of the built-in textures, default first."""
    return list(BUILTINS)


def parse_texture_spec(spec: str) -> tuple[str, dict[str, float]]:
    """Split ``"builtin:NAME[:key=value,key=value...]"`` into the name and parameters.

    Example: ``"builtin:pins:period=4,diameter=1.5"`` ->
    ``("pins", {"period": 4.0, "diameter": 1.5})``. ``scale=`` is accepted too. The
    ``builtin:`` prefix is optional. Values are numbers (mm, degrees, counts).

    Raises:
        ParameterError: a ``key=value`` pair is malformed.
    """
    s = spec[len(PREFIX):] if spec.startswith(PREFIX) else spec
    name, _, rest = s.partition(":")
    params: dict[str, float] = {}
    for item in filter(None, (t.strip() for t in rest.split(","))):
        key, eq, val = item.partition("=")
        try:
            if not eq or not key.strip():
                raise ValueError
            params[key.strip()] = float(val)
        except ValueError:
            raise ParameterError(
                f"cannot read texture parameter {item!r} in {spec!r}; write key=number pairs separated by commas, "
                "e.g. builtin:pins:period=4,diameter=1.5"
            ) from None
    return name.strip(), params


def builtin(
    name: str,
    *,
    size: float | Sequence[float] | None = None,
    pitch: float = 0.125,
    height: float = 1.0,
    scale: float = 1.0,
    **params: float,
) -> Heightmap:
    """Sample a built-in texture as a :class:`Heightmap`.

    Args:
        name: one of :func:`builtin_names` (with or without the ``builtin:`` prefix,
            optionally with ``:key=value,...`` parameters, see
            :func:`parse_texture_spec`).
        size: ``(width, depth)`` in mm (or one number for a square); default one tile.
            The texture covers the largest whole number of pixels that fits in it.
        pitch: mm per pixel. It is adjusted slightly so that a whole number of pixels
            spans each tile, which keeps the texture exactly periodic.
        height: maximum height in mm.
        scale: factor (> 0) on every length parameter: 2 makes the features twice as
            large (in x and y; the height is ``height``).
        **params: texture parameters (lengths in mm, angles in degrees, counts,
            seed), e.g. ``period=4.0``; ``BUILTINS[name].params`` lists them.

    Returns:
        Heightmap with heights in ``[0, height]`` mm: the sampled unit heights are
        stretched so their minimum is 0 and maximum ``height``. Over a whole number
        of tiles it tiles seamlessly in x and y.

    Raises:
        ParameterError: unknown name or parameter, non-positive size, pitch or
            height, or parameters that do not fit together.
    """
    key, spec_params = parse_texture_spec(name)
    if key not in BUILTINS:
        raise ParameterError(
            f"unknown built-in texture {key!r}; choose one of {', '.join(BUILTINS)} "
            "(`texcad textures` lists them)"
        )
    tex = BUILTINS[key]
    merged = {**spec_params, **params}
    scale = float(merged.pop("scale", 1.0)) * positive("scale", scale, unit="")
    for label, v in (("pitch", pitch), ("height", height)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
            raise ParameterError(f"{label} must be a positive number of mm, got {v!r}")
    tile, func = tex.configure(scale=scale, **merged)
    if size is None:
        w, d = tile
    elif np.ndim(size) == 0:
        w = d = float(size)  # type: ignore[arg-type]
    else:
        w, d = (float(s) for s in size)  # type: ignore[union-attr]
    if not (w > 0 and d > 0 and np.isfinite(w) and np.isfinite(d)):
        raise ParameterError(f"size must be positive mm, got {size!r}")
    # Whole number of pixels per tile keeps the sampling periodic.
    px = tile[0] / max(1, round(tile[0] / pitch))
    py = tile[1] / max(1, round(tile[1] / pitch))
    # The largest whole number of pixels that fits in the size (never more: a texture
    # must not overhang the face it is asked to cover).
    cols, rows = max(2, int(np.floor(w / px + 1e-6))), max(2, int(np.floor(d / py + 1e-6)))
    require_pitch(f"a {rows} x {cols} px texture", min(px, py), rows * cols * 8.0 * 12)
    x = (np.arange(cols) + 0.5) * px
    y = (np.arange(rows) + 0.5) * py
    unit = func(x[None, :], y[:, None])
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
        spec: ``"builtin:NAME"`` (optionally ``"builtin:NAME:key=value,..."`` with
            texture parameters in mm / degrees), a PNG/JPEG/TIFF path, or a
            Heightmap (returned as is unless ``height`` differs from its maximum,
            then rescaled).
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


# -- more textures (issue 14: the library grows to BumpMesh's set and beyond) -----------
def _make_knurl_fine(period: float):
    # A fine diamond knurl (1 mm pitch by default): the diamond knurl's V-grooves.
    return _make_diamond_knurl(period)


def _make_crosshatch(period: float, width: float):
    # Two sets of rounded beads `width` mm wide along the diagonals, crossing:
    # u = (x + y)/p, v = (x - y)/p (period p in x and y, as the diamond knurl);
    # a bead at distance s (mm) from its axis is sqrt(1 - (2s/w)^2) high.
    _need(width < period / np.sqrt(2.0), "crosshatch", f"width ({width:g} mm) must be less than period / sqrt 2 ({period / np.sqrt(2):.3g} mm)")

    def f(x, y):
        u, v = (x + y) / period, (x - y) / period
        su = np.abs(u - np.round(u)) * period / np.sqrt(2.0)
        sv = np.abs(v - np.round(v)) * period / np.sqrt(2.0)
        bead = lambda s: np.sqrt(np.clip(1.0 - (2.0 * s / width) ** 2, 0.0, None))  # noqa: E731
        return np.maximum(bead(su), bead(sv))

    return (period, period), f


def _make_waves(period: float, length: float, amplitude: float):
    # Wavy ridges: h = sin^2(pi (y + a sin(2 pi x / L)) / p); crests every `period`
    # mm across y, bent sideways by `amplitude` mm with wavelength `length` mm.
    def f(x, y):
        return np.sin(np.pi * (y + amplitude * np.sin(2 * np.pi * x / length)) / period) ** 2

    return (length, period), f


def _make_basketweave(cell: float, strands: int):
    # Basket weave: square cells `cell` mm, `strands` rounded strands per cell, along
    # x in cells (i + j) even and along y in the others; each strand is
    # |sin(pi n t / cell)|^0.7, t across it.
    def f(x, y):
        i, j = np.floor(x / cell), np.floor(y / cell)
        along_x = np.mod(i + j, 2.0) == 0
        sx = np.abs(np.sin(np.pi * strands * y / cell)) ** 0.7
        sy = np.abs(np.sin(np.pi * strands * x / cell)) ** 0.7
        return np.where(along_x, sx, sy)

    return (2 * cell, 2 * cell), f


def _make_carbon_fiber(tow: float):
    # 2 x 2 twill of tows `tow` mm wide: warp tow i (along y) lies over weft tow j
    # (along x) where (i - j) mod 4 < 2; each tow is a flattened arch
    # sin(pi s)^0.5 across it (s its fractional position), the one on top 0.35 higher.
    def f(x, y):
        u, v = x / tow, y / tow
        i, j = np.floor(u), np.floor(v)
        warp_top = np.mod(i - j, 4.0) < 2.0
        aw = np.sqrt(np.abs(np.sin(np.pi * (u - i))))
        af = np.sqrt(np.abs(np.sin(np.pi * (v - j))))
        return np.where(warp_top, 0.35 + 0.65 * aw, 0.35 + 0.65 * af)

    return (4 * tow, 4 * tow), f


def _make_honeycomb(period: float, wall: float, bevel: float):
    # Honeycomb walls: raised hexagon outlines on a hexagonal lattice of centre
    # spacing `period`, walls `wall` mm wide with `bevel` mm slopes (the negative of
    # `hexagons`): h = 1 - smoothstep(w/2, w/2 + b, distance to the cell border).
    _need(wall + 2 * bevel < period, "honeycomb", f"wall + 2 bevel ({wall:g} + 2 x {bevel:g} mm) must be less than the period ({period:g} mm)")

    def f(x, y):
        return 1.0 - smoothstep(wall / 2, wall / 2 + bevel, _hex_border(x, y, period))

    return (period, period * np.sqrt(3.0)), f


def _make_grid(period: float, width: float, bevel: float):
    # Raised square grid: lines `width` mm wide every `period` mm in x and y, with
    # `bevel` mm slopes: h = 1 - smoothstep(w/2, w/2 + b, distance to the nearest line).
    _need(width + 2 * bevel < period, "grid", f"width + 2 bevel ({width:g} + 2 x {bevel:g} mm) must be less than the period ({period:g} mm)")

    def f(x, y):
        d = np.minimum(np.abs(_wrap(x, period)), np.abs(_wrap(y, period)))
        return 1.0 - smoothstep(width / 2, width / 2 + bevel, d)

    return (period, period), f


def _make_dots(period: float, radius: float):
    # Hemispherical dots on a square grid: h = sqrt(r^2 - d^2) / r inside radius r.
    _need(2 * radius < period, "dots", f"the diameter ({2 * radius:g} mm) must be less than the period ({period:g} mm)")

    def f(x, y):
        d = _lattice_distance(x, y, period, hexagonal=False)
        return np.sqrt(np.clip(radius * radius - d * d, 0.0, None)) / radius

    return (period, period), f


def _make_bumps(period: float):
    # Smooth egg-crate bumps: h = (sin(pi x / p) sin(pi y / p))^2.
    def f(x, y):
        return (np.sin(np.pi * x / period) * np.sin(np.pi * y / period)) ** 2

    return (period, period), f


def _make_cracks(cell: float, count: int, width: float, seed: int):
    # Cracked earth: flat periodic Voronoi plates with V-shaped cracks `width` mm
    # wide along the cell borders: h = smoothstep(0, w/2, (F2 - F1)/2).
    tile = cell * count

    def f(x, y):
        f1, f2 = _voronoi(x, y, tile, count, 0.4, np.random.default_rng(seed))
        return smoothstep(0.0, width / 2, 0.5 * (f2 - f1))

    return (tile, tile), f


BUILTINS.update(
    {
        t.name: t
        for t in (
            _register("knurl_fine", "fine diamond knurl", _make_knurl_fine, period=Param(1.0, _MM, "groove pitch")),
            _register("crosshatch", "crossing diagonal beads", _make_crosshatch, period=Param(3.0, _MM, "bead spacing along x"), width=Param(0.8, _MM, "bead width")),
            _register(
                "waves", "wavy ridges", _make_waves,
                period=Param(3.0, _MM, "crest spacing"), length=Param(12.0, _MM, "wavelength of the bends"), amplitude=Param(1.0, _MM, "bend amplitude"),
            ),
            _register("basketweave", "basket weave of strand blocks", _make_basketweave, cell=Param(4.0, _MM, "block size"), strands=Param(3, _COUNT, "strands per block")),
            _register("carbon_fiber", "2 x 2 twill, carbon-fibre look", _make_carbon_fiber, tow=Param(1.5, _MM, "tow width")),
            _register(
                "honeycomb", "raised honeycomb walls", _make_honeycomb,
                period=Param(5.0, _MM, "cell centre spacing"), wall=Param(0.6, _MM, "wall width"), bevel=Param(0.5, _MM, "wall slope width"),
            ),
            _register(
                "grid", "raised square grid lines", _make_grid,
                period=Param(4.0, _MM, "line spacing"), width=Param(0.6, _MM, "line width"), bevel=Param(0.4, _MM, "line slope width"),
            ),
            _register("dots", "hemispherical dots, square grid", _make_dots, period=Param(3.0, _MM, "dot spacing"), radius=Param(1.0, _MM, "dot radius")),
            _register("bumps", "smooth egg-crate bumps", _make_bumps, period=Param(4.0, _MM, "bump spacing")),
            _register(
                "cracks", "cracked earth, periodic Voronoi plates", _make_cracks,
                cell=Param(5.0, _MM, "plate size"), count=Param(5, _COUNT, "plates per tile side"),
                width=Param(0.8, _MM, "crack width"), seed=Param(5, _SEED, "random seed"),
            ),
        )
    }
)
