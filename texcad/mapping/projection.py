"""Projections of a texture onto the points of a mesh (BumpMesh's set, in mm).

A :class:`Projection` turns points ``p`` (mm) and their unit normals ``n`` into one
or more texture coordinates ``(u, v)`` in mm with weights summing to 1; the height
at ``p`` is ``sum_k w_k h(u_k, v_k)`` (:func:`sample_heights`). The texture keeps its
size in mm on every part (``scale`` only multiplies it):

* ``planar`` along ``axis`` a: ``(u, v)`` are the coordinates of ``p - origin`` in a
  right-handed frame ``(e_u, e_v, a)`` of the plane normal to ``a``;
* ``cylindrical`` about ``axis`` through ``origin``: ``u = theta r_ref`` (mm of arc
  at the reference radius ``r_ref``, default the mean distance of the textured
  points from the axis; ``local_radius=True`` uses each point's own radius, with a
  whole number of tiles round at that radius, which changes in steps on a cone or a
  disc), ``v`` along the axis. The tile width is stretched (by less than half a tile over
  the circumference) so that a whole number of tiles goes round: no seam;
* ``spherical`` about ``origin``: ``u`` the longitude and ``v`` the latitude, both
  as arc at ``r_ref``, the tile width fitted around the equator like a cylinder;
* ``triplanar``: the three planar projections along x, y, z blended by the normal:
  plane ``k`` has weight ``s(|n_k|)``, ``s`` a smoothstep from ``cos(45 + b/2)`` to
  ``cos(45 - b/2)`` (``b`` = ``blend`` degrees), so a face within 45 - b/2 degrees
  of an axis takes that plane alone and the switch between two planes is spread over
  ``b`` degrees of normal direction (corners where no weight is left take the
  dominant axis);
* ``cubic``: like triplanar, but the six faces of the cube (+x, -x, ...) are each
  seen from outside, so the texture is not mirrored on opposite sides;
* ``solid``: no projection; a 3-D texture ``h(x, y, z)`` (see
  :mod:`texcad.sources.solid_textures`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from ..errors import ParameterError
from ..sources import Heightmap
from ..util import axis_word, colmax, colmin, rowsum

__all__ = ["PROJECTIONS", "Projection", "TileSampler", "parse_axis", "sample_heights", "frame"]

PROJECTIONS = ("planar", "cylindrical", "spherical", "triplanar", "cubic", "solid")

def parse_axis(axis: "str | Sequence[float]") -> np.ndarray:
    """A unit axis from ``"+x"``, ``"-z"``, ``"y"`` or a 3-vector (any length)."""
    if isinstance(axis, str):
        unit = axis_word(axis)
        if unit is None:
            raise ParameterError(f"axis {axis!r}: use +x, -x, +y, -y, +z, -z or three numbers")
        return unit
    a = np.asarray(axis, dtype=np.float64).reshape(-1)
    n = float(np.linalg.norm(a)) if a.shape == (3,) else 0.0
    if not (np.isfinite(n) and n > 0):
        raise ParameterError(f"axis must be three numbers not all 0 (or +x ...), got {axis!r}")
    return a / n


def frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit ``(e_u, e_v)`` with ``(e_u, e_v, axis)`` right-handed: for the coordinate
    axes ``e_u`` is the next axis in x -> y -> z order (z: x, y; x: y, z; y: z, x)."""
    a = np.asarray(axis, dtype=np.float64)
    k = int(np.argmax(np.abs(a)))
    ref = np.eye(3)[(k + 2) % 3]  # z -> y-ish reference so that e_u = x for z
    eu = np.cross(ref, a)  # ref is not the dominant axis, so never parallel to a
    eu /= np.linalg.norm(eu)
    ev = np.cross(a, eu)
    return eu, ev


def _along(q: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``q @ e`` for points ``(N, 3)``: a coordinate axis's column (or its negative)
    where ``e`` is one, which is the same values (up to the sign of a zero) at a
    fraction of the cost."""
    k = np.flatnonzero(e)
    if len(k) == 1 and abs(e[k[0]]) == 1.0:
        return q[:, k[0]] * e[k[0]]
    return q @ e


@dataclass(frozen=True)
class TileSampler:
    """A periodic texture tile sampled bilinearly in mm: ``h(u, v)`` with
    ``h(u + tx, v) = h(u, v + ty) = h(u, v)``.

    Attributes:
        heightmap: one tile (heights mm, pixel centres at ``(i + 1/2) pitch``).
        scale: ``(sx, sy)`` stretch of the tile (1 = its own size in mm).
    """

    heightmap: Heightmap
    scale: tuple[float, float] = (1.0, 1.0)

    @property
    def tile(self) -> tuple[float, float]:
        """Tile size ``(tx, ty)`` in mm after ``scale``."""
        w, d = self.heightmap.size
        return w * self.scale[0], d * self.scale[1]

    def __call__(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        h = self.heightmap.heights
        rows, cols = h.shape
        px, py = self.heightmap.pitch
        fu = np.asarray(u, dtype=np.float64) / (px * self.scale[0]) - 0.5
        fv = np.asarray(v, dtype=np.float64) / (py * self.scale[1]) - 0.5
        iu, iv = np.floor(fu), np.floor(fv)
        tu, tv = fu - iu, fv - iv
        c0 = np.mod(iu, cols).astype(np.int64)
        r0 = np.mod(iv, rows).astype(np.int64)
        c1, r1 = (c0 + 1) % cols, (r0 + 1) % rows
        hf, r0, r1 = h.reshape(-1), r0 * cols, r1 * cols  # flat gathers: the same values, faster
        top = np.take(hf, r0 + c0) * (1 - tu) + np.take(hf, r0 + c1) * tu
        bot = np.take(hf, r1 + c0) * (1 - tu) + np.take(hf, r1 + c1) * tu
        return top * (1 - tv) + bot * tv


@dataclass(frozen=True)
class Projection:
    """How texture coordinates are found (module docstring). Lengths mm, angles deg.

    Attributes:
        kind: one of :data:`PROJECTIONS`.
        axis: planar: the direction the texture is seen along; cylindrical: the
            cylinder's axis (``"+z"`` or a 3-vector).
        origin: a point of the axis / the sphere's centre / the planar origin, mm
            (None: the centre of the textured points' bounding box).
        radius: reference radius in mm for cylindrical and spherical (None: the mean
            distance of the textured points).
        local_radius: cylindrical: measure ``u`` as arc at each point's own radius.
        blend: triplanar / cubic blend width in degrees (0..90).
        rotation: turn the texture in its plane, degrees.
    """

    kind: str = "triplanar"
    axis: "str | Sequence[float]" = "+z"
    origin: "Sequence[float] | None" = None
    radius: "float | None" = None
    local_radius: bool = False
    blend: float = 20.0
    rotation: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in PROJECTIONS:
            raise ParameterError(f"projection {self.kind!r}: use one of {', '.join(PROJECTIONS)}")
        if not (0.0 <= float(self.blend) <= 90.0):
            raise ParameterError(f"blend must be 0..90 degrees, got {self.blend!r}")
        if self.radius is not None and not (np.isfinite(self.radius) and self.radius > 0):
            raise ParameterError(f"radius must be a positive length in mm, got {self.radius!r}")
        parse_axis(self.axis)

    def fixed(self, points: np.ndarray) -> "Projection":
        """This projection with ``origin`` and ``radius`` taken from ``points``
        ``(N, 3)`` mm where they are None (as :meth:`samples` would take them), so that
        later calls on other points use the same ones."""
        p = np.asarray(points, dtype=np.float64)
        o = np.asarray(self.origin, dtype=np.float64) if self.origin is not None else (
            0.5 * (colmin(p) + colmax(p)) if len(p) else np.zeros(3)
        )
        r = self.radius
        if r is None and self.kind in ("cylindrical", "spherical") and len(p):
            a = parse_axis(self.axis)
            eu, ev = frame(a)
            q = p - o
            x, y = q @ eu, q @ ev
            rho = np.hypot(x, y) if self.kind == "cylindrical" else np.sqrt(x * x + y * y + (q @ a) ** 2)
            r = float(rho.mean())
        return replace(self, origin=tuple(float(t) for t in o), radius=r)

    def samples(
        self, points: np.ndarray, normals: np.ndarray, tile: tuple[float, float]
    ) -> tuple[list[tuple[np.ndarray, np.ndarray, np.ndarray]], dict]:
        """Texture coordinates of ``points`` ``(N, 3)`` mm with unit ``normals``.

        Returns:
            ``([(u, v, weight), ...], info)``: one to six samples per point (weights
            ``(N,)`` summing to 1), and ``info`` (origin, radius, tile stretch).
        """
        p = np.asarray(points, dtype=np.float64)
        n = np.asarray(normals, dtype=np.float64)
        o = np.asarray(self.origin, dtype=np.float64) if self.origin is not None else (
            0.5 * (colmin(p) + colmax(p)) if len(p) else np.zeros(3)
        )
        q = p - o
        info: dict = {"origin": o.tolist(), "stretch": 1.0}
        if self.kind == "planar":
            a = parse_axis(self.axis)
            eu, ev = frame(a)
            return [(*self._turn(q @ eu, q @ ev), np.ones(len(p)))], info
        if self.kind in ("cylindrical", "spherical"):
            return self._round(q, tile, info)
        if self.kind in ("triplanar", "cubic"):
            return self._box(q, n), info
        raise ParameterError("a solid texture needs no projection: sample it with its own 3-D function")

    def _turn(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if not self.rotation:
            return u, v
        c, s = np.cos(np.radians(self.rotation)), np.sin(np.radians(self.rotation))
        return c * u - s * v, s * u + c * v

    def _round(self, q: np.ndarray, tile: tuple[float, float], info: dict):
        a = parse_axis(self.axis)
        eu, ev = frame(a)
        x, y, z = q @ eu, q @ ev, q @ a
        theta = np.arctan2(y, x)  # -pi..pi
        if self.kind == "cylindrical":
            rho = np.hypot(x, y)
        else:
            rho = np.sqrt(x * x + y * y + z * z)
        r_ref = float(self.radius) if self.radius is not None else (float(rho.mean()) if len(rho) else 1.0)
        circ = 2 * np.pi * r_ref
        count = max(1, int(round(circ / tile[0])))
        stretch = circ / (count * tile[0])  # whole tiles around: no seam at theta = pi
        info.update(radius=r_ref, tiles_around=count, stretch=stretch)
        if self.kind == "cylindrical":
            if self.local_radius:  # whole tiles round at each point's own radius
                k = np.maximum(1.0, np.round(2 * np.pi * rho / tile[0]))
                u = theta * k * tile[0] / (2 * np.pi)
            else:
                u = theta * r_ref / stretch
            v = z
        else:
            lat = np.arctan2(z, np.hypot(x, y))
            u, v = theta * r_ref / stretch, lat * r_ref
        return [(u, v, np.ones(len(q)))], info

    def _box(self, q: np.ndarray, n: np.ndarray):
        b = np.radians(float(self.blend))
        lo, hi = np.cos(np.pi / 4 + b / 2), np.cos(np.pi / 4 - b / 2)
        an = np.abs(n)
        if hi - lo > 1e-9:
            t = np.clip((an - lo) / (hi - lo), 0.0, 1.0)
            w = t * t * (3 - 2 * t)
        else:
            w = (an >= np.cos(np.pi / 4)).astype(np.float64)
        none = rowsum(w) <= 1e-9
        w[none] = np.eye(3)[np.argmax(an[none], axis=1)]
        w /= rowsum(w)[:, None]
        out = []
        for k in range(3):  # per axis
            a = np.eye(3)[k]
            eu, ev = frame(a)
            u, v = _along(q, eu), _along(q, ev)
            if self.kind == "cubic":
                u = np.where(n[:, k] < 0, -u, u)  # seen from outside on the -k face
            out.append((*self._turn(u, v), w[:, k]))
        return out


def sample_heights(
    samples: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    func: Callable[[np.ndarray, np.ndarray], np.ndarray],
) -> np.ndarray:
    """``sum_k w_k func(u_k, v_k)`` in mm, evaluating only where ``w_k > 0``."""
    out = np.zeros(len(samples[0][0]), dtype=np.float64)
    for u, v, w in samples:  # per projection plane
        sel = w > 0
        if sel.all():
            out += w * func(u, v)
        elif sel.any():
            out[sel] += w[sel] * func(u[sel], v[sel])
    return out
