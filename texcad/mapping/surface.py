"""Surfaces: a profile curve in the XZ plane extruded along +Y (paper, section 2.2).

The paper's 2.5D surfaces are ``f(x, z) = 0, a <= x <= b, c <= y <= d`` (eq. 2): a
planar curve, the *profile*, swept along y. A :class:`Profile` is that curve, in mm,
parameterized by arc length ``s`` (eq. 4); a :class:`Surface` is a profile, the
extrusion length along +Y (the surface spans ``0 <= y <= length``) and the base body
the texture is fused onto.

Profiles come from build123d (or CadQuery / OCP) edges, wires, curves and sketches
(:meth:`Profile.from_cad`), from the paper's closed-form cases (:meth:`Profile.plane`,
:meth:`Profile.circle` and :meth:`Profile.arc`, eq. 5-8; :meth:`Profile.sine`, eq.
9-13), from any ``z = f(x)`` (:meth:`Profile.function`, eq. 3) or any parametric curve.

Representation
--------------
Every piece of the profile (a CAD edge, or the curve of a helper) is sampled densely
**once**: positions ``P_k`` and derivatives ``P'_k`` at a few thousand parameter
values (for CAD edges through OCCT ``BRepAdaptor_Curve.D1``; straight lines need two).
Between samples the curve is the cubic Hermite interpolant ``H(tau)`` of those
positions and derivatives, ``0 <= tau <= 1`` on each interval, whose error is
``O(h^4)`` (far below 1 um for the default densities). The arc length of an interval
is ``int_0^1 |H'(tau)| dtau`` by 8-point Gauss-Legendre quadrature (eq. 4), tabulated
cumulatively; ``s -> (interval, tau)`` is inverted by Newton's method on the same
quadrature. Every query is vectorized over the ``s`` values: texture vertices never
call OCCT.

Conventions (mm, degrees)
-------------------------
* The profile lies in the XZ plane (``x`` right, ``z`` up); ``s`` runs from 0 at the
  start to ``length``.
* The *outward normal* is the tangent turned 90 degrees from +x towards +z:
  ``n = (-t_z, t_x)``. A profile running along +x has its texture on top (+z). Closed
  profiles are oriented so that ``n`` points away from the enclosed region (or into it
  with ``side="inside"``); reverse an open profile (:meth:`Profile.reversed`) to
  texture its other side.
* Curvature ``kappa`` is positive where the outward side is convex (a cylinder seen
  from outside: ``kappa = 1/R``) and negative where it is concave; there a texture of
  height ``h`` folds when ``h |kappa| >= 1``.
* A piece is *upward-looking* (``facing = +1``) where ``n_z > 0``, *downward-looking*
  (``-1``) where ``n_z < 0`` and vertical (0) where ``n_z = 0``. Because
  ``n_z = t_x = dx/ds``, the function pieces of eq. (3) are exactly the runs of equal
  facing: the profile is split where ``dx/ds`` changes sign.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, NamedTuple, Sequence

import numpy as np

from ..util import positive
from ..errors import GeometryError, InputError, ParameterError

__all__ = ["Profile", "ProfileSample", "FunctionPiece", "Corner", "Surface", "SURFACE_KINDS", "swept_volume",
           "grid_triangles", "grid_swept", "GridSweep", "chord_excess", "sheet_excess", "mean_curvature",
           "relief_integral"]

# 8-point Gauss-Legendre nodes and weights on [0, 1].
_GL_X, _GL_W = np.polynomial.legendre.leggauss(8)
_GL_X = (_GL_X + 1.0) / 2.0
_GL_W = _GL_W / 2.0

#: Tangents that turn by less than this (radians) at a joint count as smooth.
_CORNER_ANGLE = 1e-6
#: |dx/ds| below this counts as vertical (facing 0).
_VERTICAL_TOL = 1e-9
#: Joint gap in mm above which a wire is not connected.
_GAP_TOL = 1e-5




# -- cubic Hermite on one interval ---------------------------------------------------
def _h_pos(p0, d0, p1, d1, t):
    t = t[..., None]
    t2, t3 = t * t, t * t * t
    return (2 * t3 - 3 * t2 + 1) * p0 + (t3 - 2 * t2 + t) * d0 + (-2 * t3 + 3 * t2) * p1 + (t3 - t2) * d1


def _h_der(p0, d0, p1, d1, t):
    t = t[..., None]
    t2 = t * t
    return (6 * t2 - 6 * t) * p0 + (3 * t2 - 4 * t + 1) * d0 + (6 * t - 6 * t2) * p1 + (3 * t2 - 2 * t) * d1


def _h_der2(p0, d0, p1, d1, t):
    t = t[..., None]
    return (12 * t - 6) * p0 + (6 * t - 4) * d0 + (6 - 12 * t) * p1 + (6 * t - 2) * d1


class ProfileSample(NamedTuple):
    """The profile's frame at arc lengths ``s`` (all float64, mm).

    Attributes:
        s: ``(n,)`` arc lengths in mm (wrapped into ``[0, length)`` on closed profiles).
        point: ``(n, 2)`` ``(x, z)`` in mm.
        tangent: ``(n, 2)`` unit tangent ``dP/ds``.
        normal: ``(n, 2)`` unit outward normal ``(-t_z, t_x)``.
        curvature: ``(n,)`` curvature in 1/mm, positive where the outward side is convex.
        facing: ``(n,)`` int8: +1 upward-looking (``n_z > 0``), -1 downward, 0 vertical.
    """

    s: np.ndarray
    point: np.ndarray
    tangent: np.ndarray
    normal: np.ndarray
    curvature: np.ndarray
    facing: np.ndarray


class FunctionPiece(NamedTuple):
    """A run of the profile on which ``z`` is a function of ``x`` (eq. 3).

    Attributes:
        s0, s1: arc-length range in mm (``s1 < s0`` never; on a closed profile the last
            piece may run past ``length``, i.e. across the start).
        facing: +1 upward-looking, -1 downward-looking, 0 a vertical segment.
    """

    s0: float
    s1: float
    facing: int


class Corner(NamedTuple):
    """A point where the tangent jumps (a joint that is not G1).

    Attributes:
        s: arc length of the corner in mm.
        point: ``(x, z)`` in mm.
        angle: turning angle in degrees, in ``(-180, 180)``: negative where the
            outward side is convex (a box's edge), positive where it is concave.
    """

    s: float
    point: tuple[float, float]
    angle: float


# A piece as sampled: parameters t (K,), positions (K, 2), derivatives dP/dt (K, 2).
_Piece = tuple[np.ndarray, np.ndarray, np.ndarray]


class Profile:
    """A planar curve in the XZ plane, parameterized by arc length (mm).

    Build one with :meth:`from_cad`, :meth:`plane`, :meth:`circle`, :meth:`arc`,
    :meth:`sine`, :meth:`function`, :meth:`parametric` or :meth:`polyline`. All
    queries take arrays of arc lengths ``s`` in mm and are vectorized.

    Attributes:
        closed: True if the curve ends where it starts (a tube, not a sheet).
        name: a short description, used in messages.
    """

    def __init__(self, pieces: Sequence[_Piece], *, closed: bool, name: str = "profile", _orient: str | None = None):
        if not pieces:
            raise InputError("the profile is empty; give it at least one edge")
        p0, d0, p1, d1, first = [], [], [], [], []
        n = 0
        for t, pos, der in pieces:
            t = np.asarray(t, np.float64)
            pos = np.asarray(pos, np.float64)
            der = np.asarray(der, np.float64)
            if len(t) < 2 or pos.shape != (len(t), 2) or der.shape != (len(t), 2):
                raise InputError("a profile piece needs at least two samples of (x, z) and d(x, z)/dt")
            if not (np.isfinite(pos).all() and np.isfinite(der).all()):
                raise InputError("the profile has NaN or infinite coordinates; check the curve or function")
            dt = np.diff(t)[:, None]
            first.append(n)
            p0.append(pos[:-1])
            p1.append(pos[1:])
            d0.append(der[:-1] * dt)
            d1.append(der[1:] * dt)
            n += len(t) - 1
        self.closed = bool(closed)
        self.name = name
        self._p0 = np.concatenate(p0)
        self._d0 = np.concatenate(d0)
        self._p1 = np.concatenate(p1)
        self._d1 = np.concatenate(d1)
        starts = np.zeros(n, bool)
        starts[first] = True
        self._piece_start = starts
        self._check_joints()
        self._tabulate()
        if _orient is not None and self.closed:
            area = self.signed_area
            if (area > 0) == (_orient == "outside"):
                self._reverse_inplace()

    # -- construction helpers ------------------------------------------------------
    def _check_joints(self) -> None:
        nxt = np.roll(self._p0, -1, axis=0)
        gap = np.linalg.norm(self._p1 - nxt, axis=1)
        if not self.closed:
            gap = gap[:-1]
        if gap.size and gap.max() > _GAP_TOL:
            j = int(np.argmax(gap))
            x, z = self._p1[j]
            what = "its end and start" if (self.closed and j == len(gap) - 1) else "two of its pieces"
            raise InputError(
                f"the profile is not connected: {what} are {gap[j]:.3g} mm apart at (x, z) = ({x:.4g}, {z:.4g}) mm; "
                "join the edges (e.g. build one Wire) or close the curve"
            )
        # Snap joints so the polyline is exactly continuous.
        if self.closed:
            self._p1[:] = np.roll(self._p0, -1, axis=0)
        else:
            self._p1[:-1] = self._p0[1:]

    def _tabulate(self) -> None:
        lens = self._integrate(np.arange(len(self._p0)), np.ones(len(self._p0)))
        keep = lens > 1e-12
        if not keep.all():
            # Drop zero-length intervals; a piece start moves to the next interval.
            starts = self._piece_start.copy()
            idx = np.flatnonzero(~keep)
            nxt = np.minimum(idx + 1, len(starts) - 1)
            starts[nxt] |= starts[idx]
            self._p0, self._d0, self._p1, self._d1 = (a[keep] for a in (self._p0, self._d0, self._p1, self._d1))
            self._piece_start = starts[keep]
            if not self._piece_start.any():
                self._piece_start[0] = True
            lens = lens[keep]
            if not self.closed:
                self._p1[:-1] = self._p0[1:]
            else:
                self._p1[:] = np.roll(self._p0, -1, axis=0)
        if lens.size == 0 or lens.sum() <= 1e-9:
            raise InputError("the profile has zero length; give it a curve longer than 1 nm")
        self._len = lens
        self._s = np.concatenate([[0.0], np.cumsum(lens)])
        self._corners = self._find_corners()
        self._breaks_cache = None

    def _reverse_inplace(self) -> None:
        p0, d0, p1, d1 = self._p0, self._d0, self._p1, self._d1
        self._p0, self._p1 = p1[::-1].copy(), p0[::-1].copy()
        self._d0, self._d1 = -d1[::-1], -d0[::-1]
        # A piece that started at interval j now ends at interval J-1-j.
        ends = np.roll(self._piece_start, -1)
        if not self.closed:
            ends[-1] = True
        self._piece_start = ends[::-1].copy()
        self._len = self._len[::-1].copy()
        self._s = np.concatenate([[0.0], np.cumsum(self._len)])
        self._corners = self._find_corners()
        self._breaks_cache = None

    def _find_corners(self) -> list[Corner]:
        j = np.flatnonzero(self._piece_start)
        if not self.closed:
            j = j[j > 0]
        prev = (j - 1) % len(self._p0)
        t_in = self._d1[prev] / np.linalg.norm(self._d1[prev], axis=1, keepdims=True)
        t_out = self._d0[j] / np.linalg.norm(self._d0[j], axis=1, keepdims=True)
        cross = t_in[:, 0] * t_out[:, 1] - t_in[:, 1] * t_out[:, 0]
        dot = np.einsum("ij,ij->i", t_in, t_out)
        ang = np.arctan2(cross, dot)
        out = []
        for k in np.flatnonzero(np.abs(ang) > _CORNER_ANGLE):  # one per corner
            i = int(j[k])
            out.append(Corner(float(self._s[i]), (float(self._p0[i, 0]), float(self._p0[i, 1])), float(np.degrees(ang[k]))))
        return out

    # -- constructors ----------------------------------------------------------------
    @classmethod
    def parametric(
        cls,
        curve: Callable[[np.ndarray], Any],
        t0: float,
        t1: float,
        *,
        derivative: Callable[[np.ndarray], Any] | None = None,
        closed: bool = False,
        samples: int = 2048,
        side: str = "outside",
        name: str = "parametric curve",
    ) -> "Profile":
        """A profile ``(x, z) = curve(t)`` for ``t0 <= t <= t1`` (mm).

        Args:
            curve: vectorized ``t -> (x, z)`` (a pair of arrays, or an ``(n, 2)`` array).
            t0, t1: parameter range (``t1 < t0`` runs the curve backwards).
            derivative: ``t -> (dx/dt, dz/dt)``; default central differences with step
                ``1e-6 |t1 - t0|`` (error ~1e-10 mm).
            closed: the curve ends where it starts.
            samples: intervals of the Hermite table (error O(samples^-4)).
            side: closed profiles only: ``"outside"`` puts the outward normal away from
                the enclosed region, ``"inside"`` into it.
        """
        if samples < 1:
            raise ParameterError(f"samples must be >= 1, got {samples}")
        t = np.linspace(float(t0), float(t1), int(samples) + 1)
        pos = _as_xz(curve(t), len(t), "curve")
        if derivative is not None:
            der = _as_xz(derivative(t), len(t), "derivative")
        else:
            step = 1e-6 * abs(float(t1) - float(t0))
            der = (_as_xz(curve(t + step), len(t), "curve") - _as_xz(curve(t - step), len(t), "curve")) / (2 * step)
        if closed:
            pos[-1] = pos[0]
        return cls([(t, pos, der)], closed=closed, name=name, _orient=_side(side) if closed else None)

    @classmethod
    def function(
        cls,
        f: Callable[[np.ndarray], Any],
        x0: float,
        x1: float,
        *,
        derivative: Callable[[np.ndarray], Any] | None = None,
        samples: int = 2048,
        name: str = "z = f(x)",
    ) -> "Profile":
        """The graph ``z = f(x)`` for ``x0 <= x <= x1`` (eq. 3), texture on top (+z).

        Args:
            f: vectorized function of x in mm returning z in mm (scalar functions are
                vectorized with ``numpy.vectorize``, slower).
            x0, x1: x range in mm, ``x0 < x1``.
            derivative: optional ``dz/dx``; default central differences.
            samples: intervals of the Hermite table.
        """
        x0, x1 = float(x0), float(x1)
        if not (np.isfinite(x0) and np.isfinite(x1) and x1 > x0):
            raise ParameterError(f"need x0 < x1 (mm), got x0={x0!r}, x1={x1!r}")
        fv = _vectorized(f)
        dv = _vectorized(derivative) if derivative is not None else None

        def curve(t):
            return t, fv(t)

        def slope(t):
            return np.ones_like(t), dv(t)

        der = slope if dv is not None else None

        return cls.parametric(curve, x0, x1, derivative=der, samples=samples, name=name)

    @classmethod
    def plane(cls, width: float, *, z: float = 0.0) -> "Profile":
        """The straight line from ``(0, z)`` to ``(width, z)`` mm: a plate's top face."""
        w = positive("width", width)
        t = np.array([0.0, w])
        pos = np.array([[0.0, z], [w, z]])
        der = np.array([[1.0, 0.0], [1.0, 0.0]])
        return cls([(t, pos, der)], closed=False, name=f"plane {w:g} mm")

    @classmethod
    def circle(cls, radius: float, *, center: Sequence[float] = (0.0, 0.0), side: str = "outside", samples: int = 4096) -> "Profile":
        """A full circle of ``radius`` mm about ``center`` ``(x, z)`` (eq. 5, 7).

        Starts at ``(p + R, q)`` and runs clockwise in the XZ view (outward normal), so
        that ``s = R (theta_0 - theta)``: the arc length of eq. (8) measured clockwise.
        """
        r = positive("radius", radius)
        p, q = (float(c) for c in center)
        return cls.parametric(
            lambda th: (p + r * np.cos(th), q + r * np.sin(th)),
            0.0,
            -2 * np.pi,
            derivative=lambda th: (-r * np.sin(th), r * np.cos(th)),
            closed=True,
            samples=samples,
            side=side,
            name=f"circle R {r:g} mm",
        )

    @classmethod
    def arc(cls, radius: float, angle: float, *, center: Sequence[float] = (0.0, 0.0), samples: int = 2048) -> "Profile":
        """A circular arc of ``radius`` mm spanning ``angle`` degrees, symmetric about
        +z over ``center`` (the top of a cylinder), clockwise so the texture is on the
        convex side (eq. 7, 8: ``s = R (theta_0 - theta)``)."""
        r = positive("radius", radius)
        a = float(angle)
        if not (0 < a <= 360):
            raise ParameterError(f"angle must be in (0, 360] degrees, got {angle!r}")
        if a == 360:
            return cls.circle(r, center=center)
        p, q = (float(c) for c in center)
        th0, th1 = np.radians(90 + a / 2), np.radians(90 - a / 2)
        return cls.parametric(
            lambda th: (p + r * np.cos(th), q + r * np.sin(th)),
            th0,
            th1,
            derivative=lambda th: (-r * np.sin(th), r * np.cos(th)),
            samples=samples,
            name=f"arc R {r:g} mm, {a:g} deg",
        )

    @classmethod
    def sine(cls, amplitude: float, period: float, width: float, *, phase: float = 0.0, samples: int | None = None) -> "Profile":
        """``z = A sin(2 pi x / L + phase)`` for ``0 <= x <= width`` mm (eq. 9).

        Args:
            amplitude: ``A`` in mm (>= 0).
            period: ``L`` in mm.
            width: x extent in mm.
            phase: in degrees.
            samples: intervals of the Hermite table (default 256 per period, >= 2048).
        """
        amp = float(amplitude)
        if not (np.isfinite(amp) and amp >= 0):
            raise ParameterError(f"amplitude must be >= 0 mm, got {amplitude!r}")
        lp = positive("period", period)
        w = positive("width", width)
        ph = np.radians(float(phase))
        k = 2 * np.pi / lp
        n = samples if samples is not None else max(2048, int(np.ceil(256 * w / lp)))
        return cls.function(
            lambda x: amp * np.sin(k * x + ph),
            0.0,
            w,
            derivative=lambda x: amp * k * np.cos(k * x + ph),
            samples=n,
            name=f"sine A {amp:g} mm, L {lp:g} mm",
        )

    @classmethod
    def polyline(cls, points: Any, *, closed: bool = False, side: str = "outside") -> "Profile":
        """Straight segments through ``points`` ``(n, 2)`` ``(x, z)`` in mm; every
        vertex is a corner."""
        pts = np.asarray(points, np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
            raise InputError(f"points must be an (n >= 2, 2) array of (x, z) mm, got shape {pts.shape}")
        if closed and np.allclose(pts[0], pts[-1]):
            pts = pts[:-1]
        seq = np.concatenate([pts, pts[:1]]) if closed else pts
        pieces = []
        for a, b in zip(seq[:-1], seq[1:]):  # one piece per segment
            d = b - a
            pieces.append((np.array([0.0, 1.0]), np.stack([a, b]), np.stack([d, d])))
        return cls(pieces, closed=closed, name="polyline", _orient=_side(side) if closed else None)

    @classmethod
    def from_cad(cls, obj: Any, *, side: str = "outside", samples: int | None = None) -> "Profile":
        """A profile from a build123d / CadQuery / OCP curve or sketch.

        Accepts an ``Edge``, a ``Wire``, a ``Curve`` (``BuildLine`` result, edges in any
        order), a list of edges (e.g. ``part.edges()``), a ``Face`` or a one-face ``Sketch`` (its outer wire; holes are
        ignored), and the CadQuery and raw ``TopoDS`` equivalents. The curve must lie in
        a plane ``y = const`` (e.g. drawn on ``Plane.XZ``), which is used as is, or in a
        plane ``z = const`` (drawn on the default ``Plane.XY``), read as if drawn in XZ:
        its ``y`` becomes ``z``. Lines, arcs, splines, open or closed.

        Each edge is sampled once through OCCT (``BRepAdaptor_Curve.D1``): 2 samples
        for a line, otherwise one per 0.05 mm, 256 to 4096 per C1 span (``samples``
        overrides).

        Args:
            obj: the curve or sketch.
            side: closed profiles: texture ``"outside"`` (default) or ``"inside"``.
            samples: fixed number of intervals per curved edge.

        Raises:
            InputError: not a curve, several disconnected curves or faces, or not planar.
        """
        wire, closed = _cad_wire(obj)
        pieces = _sample_wire(wire, samples)
        pieces = _to_xz(pieces)
        return cls(pieces, closed=closed, name=f"{type(obj).__name__} profile", _orient=_side(side) if closed else None)

    # -- basic properties ----------------------------------------------------------
    @property
    def length(self) -> float:
        """Total arc length in mm (eq. 4)."""
        return float(self._s[-1])

    @property
    def corners(self) -> list[Corner]:
        """Joints where the tangent jumps (see :class:`Corner`)."""
        return list(self._corners)

    @property
    def signed_area(self) -> float:
        """Signed area in mm^2 enclosed by the (closed) profile's polygon of samples in
        the XZ view, positive when it runs counter-clockwise (``x`` right, ``z`` up)."""
        # Green's theorem, 1/2 closed-integral of (x dz - z dx) over the Hermite
        # curve (Gauss-Legendre, exact for the cubic's polynomial integrand).
        t = np.broadcast_to(_GL_X, (len(self._p0), len(_GL_X)))
        j = np.arange(len(self._p0))[:, None]
        pos = _h_pos(self._p0[j], self._d0[j], self._p1[j], self._d1[j], t)
        der = _h_der(self._p0[j], self._d0[j], self._p1[j], self._d1[j], t)
        return 0.5 * float(np.sum((pos[..., 0] * der[..., 1] - pos[..., 1] * der[..., 0]) @ _GL_W))

    @property
    def bounds(self) -> np.ndarray:
        """``(2, 2)`` min and max ``(x, z)`` in mm (of the dense samples)."""
        pts = self.sample()[1]
        return np.array([pts.min(axis=0), pts.max(axis=0)])

    @property
    def start(self) -> np.ndarray:
        """``(x, z)`` of ``s = 0`` in mm."""
        return self._p0[0].copy()

    @property
    def end(self) -> np.ndarray:
        """``(x, z)`` of ``s = length`` in mm."""
        return self._p1[-1].copy()

    def __repr__(self) -> str:
        kind = "closed" if self.closed else "open"
        return f"Profile({self.name}, {kind}, {self.length:.6g} mm, {len(self._corners)} corners)"

    # -- arc length machinery ------------------------------------------------------
    def _integrate(self, j: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Arc length from the start of interval ``j`` to ``tau`` (Gauss-Legendre)."""
        u = tau[:, None] * _GL_X[None, :]
        jj = j[:, None]
        d = _h_der(self._p0[jj], self._d0[jj], self._p1[jj], self._d1[jj], u)
        return tau * (np.linalg.norm(d, axis=-1) @ _GL_W)

    def _wrap(self, s: Any) -> np.ndarray:
        s = np.asarray(s, dtype=np.float64)
        if self.closed:
            return np.mod(s, self.length)
        return np.clip(s, 0.0, self.length)

    def _locate(self, s: np.ndarray, *, right: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Interval index and local parameter of arc lengths ``s`` (Newton on the
        Gauss-Legendre integral; converges to ~1e-13 mm in 4 steps)."""
        j = np.searchsorted(self._s, s, side="right" if right else "left") - 1
        j = np.clip(j, 0, len(self._len) - 1)
        base = self._s[j]
        tau = np.clip((s - base) / self._len[j], 0.0, 1.0)
        p0, d0, p1, d1 = self._p0[j], self._d0[j], self._p1[j], self._d1[j]
        for _ in range(4):
            f = base + self._integrate(j, tau) - s
            speed = np.linalg.norm(_h_der(p0, d0, p1, d1, tau), axis=-1)
            tau = np.clip(tau - f / np.maximum(speed, 1e-300), 0.0, 1.0)
        return j, tau

    def s_of(self, interval: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Arc length in mm of local parameters ``tau`` in Hermite intervals (internal
        helper, public for tests)."""
        interval = np.asarray(interval)
        return self._s[interval] + self._integrate(interval, np.asarray(tau, np.float64))

    def point(self, s: Any) -> np.ndarray:
        """``(n, 2)`` ``(x, z)`` in mm at arc lengths ``s`` (mm)."""
        s = np.atleast_1d(self._wrap(s))
        j, tau = self._locate(s)
        return _h_pos(self._p0[j], self._d0[j], self._p1[j], self._d1[j], tau)

    def at(self, s: Any) -> ProfileSample:
        """Point, unit tangent, outward normal, curvature and facing at ``s`` (mm).

        At a corner the values of the piece that starts there are returned.
        """
        s = np.atleast_1d(self._wrap(s))
        j, tau = self._locate(s)
        p0, d0, p1, d1 = self._p0[j], self._d0[j], self._p1[j], self._d1[j]
        pos = _h_pos(p0, d0, p1, d1, tau)
        der = _h_der(p0, d0, p1, d1, tau)
        dd = _h_der2(p0, d0, p1, d1, tau)
        speed = np.maximum(np.linalg.norm(der, axis=-1), 1e-300)
        tan = der / speed[:, None]
        nrm = np.stack([-tan[:, 1], tan[:, 0]], axis=1)
        # Signed curvature (x' z'' - z' x'') / |P'|^3 turns towards n; convex is the other way.
        k = -(der[:, 0] * dd[:, 1] - der[:, 1] * dd[:, 0]) / speed**3
        facing = np.where(np.abs(tan[:, 0]) <= _VERTICAL_TOL, 0, np.sign(tan[:, 0])).astype(np.int8)
        return ProfileSample(s, pos, tan, nrm, k, facing)

    def normal(self, s: Any) -> np.ndarray:
        """``(n, 2)`` unit outward normal ``(n_x, n_z)`` at ``s`` (mm)."""
        return self.at(s).normal

    def curvature(self, s: Any) -> np.ndarray:
        """``(n,)`` curvature in 1/mm at ``s`` (positive = convex outward side)."""
        return self.at(s).curvature

    def sample(self, spacing: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Dense points of the profile: ``(s (n,), points (n, 2))`` in mm.

        Without ``spacing``: the Hermite table's knots (chord error ~ ``h^2 kappa / 8``,
        below 1 um for the default densities) plus the end point of open profiles.
        With ``spacing``: uniform in arc length, at most ``spacing`` mm apart.
        """
        if spacing is None:
            s = self._s[:-1] if self.closed else self._s
            pts = self._p0 if self.closed else np.concatenate([self._p0, self._p1[-1:]])
            return s.copy(), pts.copy()
        sp = positive("spacing", spacing)
        n = max(2, int(np.ceil(self.length / sp)))
        s = np.linspace(0.0, self.length, n, endpoint=not self.closed) if self.closed else np.linspace(0.0, self.length, n + 1)
        return s, self.point(s)

    # -- function pieces (paper, section 2.2.1) -------------------------------------
    def function_pieces(self) -> list[FunctionPiece]:
        """Split the profile into function pieces ``z = f(x)`` (eq. 3).

        The paper divides non-function curves by hand (Fig. 8); here the division
        points are the roots of ``dx/ds`` where it changes sign (the roots of the
        quadratic ``H'_x(tau)`` on each Hermite interval, and tangent jumps at
        corners). Each piece is labelled upward-looking (+1, texture added to z in
        algorithm 1), downward-looking (-1, subtracted) or vertical (0).
        """
        b = self._facing_breaks()
        return [FunctionPiece(float(a), float(c), int(f)) for a, c, f in b]

    def _facing_breaks(self) -> list[tuple[float, float, int]]:
        # Cached: the profile does not change after construction (reversing resets it).
        cached = self.__dict__.get("_breaks_cache")
        if cached is None:
            cached = self._breaks_cache = self._compute_facing_breaks()
        return list(cached)

    def _compute_facing_breaks(self) -> list[tuple[float, float, int]]:
        # Roots of H'_x(tau) = a tau^2 + b tau + c on every interval, vectorized.
        p0, d0, p1, d1 = self._p0[:, 0], self._d0[:, 0], self._p1[:, 0], self._d1[:, 0]
        a = 6 * p0 + 3 * d0 - 6 * p1 + 3 * d1
        b = -6 * p0 - 4 * d0 + 6 * p1 - 2 * d1
        c = d0
        scale = np.abs(a) + np.abs(b) + np.abs(c) + 1e-300
        disc = b * b - 4 * a * c
        sq = np.sqrt(np.maximum(disc, 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            quad = np.abs(a) > 1e-12 * scale
            r1 = np.where(quad, (-b - sq) / (2 * a), np.where(np.abs(b) > 1e-12 * scale, -c / b, np.nan))
            r2 = np.where(quad, (-b + sq) / (2 * a), np.nan)
        r1 = np.where(disc >= 0, r1, np.nan)
        r2 = np.where(disc >= 0, r2, np.nan)
        taus = np.stack([np.zeros_like(a), r1, r2, np.ones_like(a)], axis=1)
        taus = np.where((taus > 0) & (taus < 1) | (taus == 0) | (taus == 1), taus, np.nan)
        taus = np.sort(taus, axis=1)
        lo, hi = taus[:, :-1], taus[:, 1:]
        ok = np.isfinite(lo) & np.isfinite(hi) & (hi - lo > 1e-12)
        jj = np.broadcast_to(np.arange(len(a))[:, None], lo.shape)[ok]
        lo, hi = lo[ok], hi[ok]
        mid = 0.5 * (lo + hi)
        der = _h_der(self._p0[jj], self._d0[jj], self._p1[jj], self._d1[jj], mid)
        tx = der[:, 0] / np.maximum(np.linalg.norm(der, axis=1), 1e-300)
        f = np.where(np.abs(tx) <= _VERTICAL_TOL, 0, np.sign(tx)).astype(int)
        s_lo = self.s_of(jj, lo)
        s_hi = self.s_of(jj, hi)
        # Vertical stretches shorter than 1 nm are the roots themselves: drop them.
        tiny = (f == 0) & (s_hi - s_lo < 1e-6)
        if tiny.any() and not tiny.all():
            f, s_lo, s_hi = f[~tiny], s_lo[~tiny], s_hi[~tiny]
        # Merge runs of equal facing.
        change = np.flatnonzero(np.diff(f) != 0) + 1
        starts = np.concatenate([[0], change])
        ends = np.concatenate([change, [len(f)]]) - 1
        runs = [(float(s_lo[i]), float(s_hi[k]), int(f[i])) for i, k in zip(starts, ends)]  # one per piece
        runs[0] = (0.0, runs[0][1], runs[0][2])
        runs[-1] = (runs[-1][0], self.length, runs[-1][2])
        if self.closed and len(runs) > 1 and runs[0][2] == runs[-1][2]:
            last = runs.pop()
            runs[0] = (last[0], runs[0][1] + self.length, last[2])
        return runs

    def division_points(self) -> np.ndarray:
        """Arc lengths (mm) where the facing changes: the paper's division planes
        between function pieces (section 2.2.1). The ends of an open profile are not
        included."""
        runs = self._facing_breaks()
        if len(runs) == 1:
            return np.zeros(0)
        if self.closed:
            return np.sort(np.mod([r[0] for r in runs], self.length))
        return np.array([r[0] for r in runs[1:]])

    # -- derived profiles ----------------------------------------------------------
    def reversed(self) -> "Profile":
        """The same curve run backwards: the outward normal flips, so the texture goes
        on the other side."""
        out = object.__new__(Profile)
        out.__dict__.update(self.__dict__)
        out._reverse_inplace()
        return out

    # -- base bodies ---------------------------------------------------------------
    def base_body(self, length: float, thickness: float | None = None):
        """A base body under this profile, extruded along +Y from ``y = 0`` to ``length`` mm.

        Closed profiles: the enclosed region (a solid), or a wall ``thickness`` mm
        thick inside the profile (outside it for ``side="inside"``). Open profiles: a
        band ``thickness`` mm thick on the inner side (opposite the outward normal).
        Helper profiles give build123d solids through :class:`Surface`; this generic
        version returns a :class:`~texcad.solid.Mesh` made with manifold3d from the
        dense polygon (chord error below 1 um).
        """
        import manifold3d as m3d

        from ..solid import from_manifold

        ln = positive("length", length)
        s, pts = self.sample()
        if self.closed:
            poly = pts if self.signed_area > 0 else pts[::-1]
            cs = m3d.CrossSection([poly], m3d.FillRule.NonZero)
            if thickness is not None:
                t = positive("thickness", thickness)
                # The inner side of the wall is the offset away from the normal.
                inner = cs.offset(-t if self.signed_area < 0 else t, m3d.JoinType.Round, 2.0, 64)
                cs = cs - inner if self.signed_area < 0 else inner - cs
        else:
            t = positive("thickness", 5.0 if thickness is None else thickness)
            smp = self.at(s)
            nrm = _smooth_unit(smp.normal, s, max(4 * t, 1e-3), False)
            inner = pts - t * nrm
            ring = np.concatenate([pts, inner[::-1]])
            if _polygon_area(ring) < 0:
                ring = ring[::-1]
            cs = m3d.CrossSection([ring], m3d.FillRule.NonZero)
            if len(cs.decompose()) > 1:  # the smoothed offset crossed itself (pieces facing each other)
                cs = _band(pts, smp.normal, t)
        if cs.is_empty():
            raise GeometryError(f"the base body under the {self.name} is empty; check thickness ({thickness!r} mm)")
        man = cs.extrude(ln).rotate((90.0, 0.0, 0.0)).translate((0.0, ln, 0.0))
        return from_manifold(man)


def _band(pts: np.ndarray, normals: np.ndarray, t: float):
    """The band ``t`` mm thick on the inner side of an open polyline ``pts`` (n, 2)
    with unit normals ``normals`` (n, 2) (the outward side): the union (non-zero fill)
    of one quadrilateral per segment, swept ``t`` mm against the segment's own
    normal, and a wedge at every vertex between its two segments' offsets (where the
    inner side is convex the quadrilaterals part). One region where the smoothed
    offset of :meth:`Profile.base_body` crosses itself (a slot textured inside: a
    downward-looking piece above an upward-looking one): the pieces' bases join
    along areas, not along edges only."""
    import manifold3d as m3d

    d = np.diff(pts, axis=0)
    keep = np.hypot(d[:, 0], d[:, 1]) > 1e-9
    a, b, d = pts[:-1][keep], pts[1:][keep], d[keep]
    n = np.stack([-d[:, 1], d[:, 0]], axis=1) / np.hypot(d[:, 0], d[:, 1])[:, None]
    n *= np.sign(np.einsum("ij,ij->i", n, 0.5 * (normals[:-1][keep] + normals[1:][keep])))[:, None]  # outward
    quads = np.stack([a, b, b - t * n, a - t * n], axis=1)
    wedges = np.stack([b[:-1], b[:-1] - t * n[:-1], b[:-1] - t * n[1:]], axis=1)  # at the inner vertices
    polys = [q if _polygon_area(q) > 0 else q[::-1] for q in quads]
    polys += [w if _polygon_area(w) > 0 else w[::-1] for w in wedges if abs(_polygon_area(w)) > 1e-12]
    return m3d.CrossSection(polys, m3d.FillRule.NonZero)


def _polygon_area(pts: np.ndarray) -> float:
    x, z = pts[:, 0], pts[:, 1]
    return 0.5 * float(np.sum(x * np.roll(z, -1) - np.roll(x, -1) * z))


def _smooth_unit(vec: np.ndarray, s: np.ndarray, radius: float, closed: bool, length: float | None = None) -> np.ndarray:
    """Unit vectors averaged over +-radius mm of arc length (two box passes), for
    non-uniform ``s``: a triangle-kernel smoothing via cumulative sums."""
    out = vec.astype(np.float64)
    for _ in range(2):
        out = _box(out, s, radius, closed, length)
    nrm = np.linalg.norm(out, axis=1, keepdims=True)
    bad = nrm[:, 0] < 1e-9
    out = np.where(bad[:, None], vec, out / np.maximum(nrm, 1e-300))
    return out


def _box(v: np.ndarray, s: np.ndarray, radius: float, closed: bool, length: float | None) -> np.ndarray:
    """Mean of ``v`` over arc-length windows ``[s - radius, s + radius]`` (trapezoid rule
    on the samples; periodic if ``closed``)."""
    if closed:
        ln = float(length)
        k = len(s)
        ext_s = np.concatenate([s[-k:] - ln, s, s[:k] + ln])
        ext_v = np.concatenate([v[-k:], v, v[:k]])
        r = min(radius, ln / 2)
        return _box(ext_v, ext_s, r, False, None)[k : 2 * k]
    ds = np.diff(s)
    seg = 0.5 * (v[1:] + v[:-1]) * ds[:, None]
    cum = np.concatenate([np.zeros((1, v.shape[1])), np.cumsum(seg, axis=0)])

    def integral(x):
        x = np.clip(x, s[0], s[-1])
        i = np.clip(np.searchsorted(s, x, side="right") - 1, 0, len(s) - 2)
        f = ((x - s[i]) / np.maximum(ds[i], 1e-300))[:, None]
        vi = v[i] + f * (v[i + 1] - v[i])
        return cum[i] + 0.5 * (v[i] + vi) * (x - s[i])[:, None]

    lo, hi = np.clip(s - radius, s[0], s[-1]), np.clip(s + radius, s[0], s[-1])
    width = np.maximum(hi - lo, 1e-300)[:, None]
    return (integral(hi) - integral(lo)) / width


def _side(side: str) -> str:
    if side not in ("outside", "inside"):
        raise ParameterError(f"side must be 'outside' or 'inside', got {side!r}")
    return side


def _vectorized(f: Callable) -> Callable[[np.ndarray], np.ndarray]:
    def g(x: np.ndarray) -> np.ndarray:
        try:
            y = np.asarray(f(x), dtype=np.float64)
            if y.shape == x.shape:
                return y
        except Exception:  # noqa: BLE001 - a scalar-only function; vectorize it
            pass
        return np.vectorize(lambda v: float(f(v)), otypes=[np.float64])(x)

    return g


def _as_xz(value: Any, n: int, what: str) -> np.ndarray:
    if isinstance(value, tuple) and len(value) == 2:
        x, z = (np.broadcast_to(np.asarray(v, np.float64), (n,)) for v in value)
        return np.stack([x, z], axis=1).copy()
    a = np.asarray(value, np.float64)
    if a.shape == (n, 2):
        return a.copy()
    if a.shape == (2, n):
        return a.T.copy()
    raise InputError(f"{what}(t) must return (x, z) arrays of the shape of t ({n},), got shape {a.shape}")


# -- CAD input -------------------------------------------------------------------------
def _cad_wire(obj: Any):
    """The one wire of a CAD curve or sketch, and whether it is closed."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_WIRE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS, TopoDS_Vertex

    from ..errors import ParameterError
    from ..brep import explore as _explore, to_topods as _topods

    try:
        shape = _topods(obj)
    except ParameterError:
        raise InputError(
            f"cannot read a profile from a {type(obj).__name__}; pass a build123d Edge, Wire, Curve, Face, Sketch "
            "or a list of edges (or Profile.function / Profile.parametric for formulas)"
        ) from None
    faces = _explore(shape, TopAbs_FACE)
    if len(faces) > 1:
        raise InputError(
            f"the sketch has {len(faces)} faces; a profile is one curve: pass one face, e.g. sketch.faces()[0]"
        )
    if faces:
        wire = BRepTools.OuterWire_s(TopoDS.Face_s(faces[0]))
    else:
        wires = _explore(shape, TopAbs_WIRE)
        if len(wires) == 1:
            wire = TopoDS.Wire_s(wires[0])
        else:
            edges = _explore(shape, TopAbs_EDGE)
            if not edges:
                raise InputError(f"the {type(obj).__name__} holds no edges to use as a profile")
            from build123d import Edge, Wire

            combined = Wire.combine([Edge(TopoDS.Edge_s(e)) for e in edges], tol=_GAP_TOL)
            if len(combined) != 1:
                raise InputError(
                    f"the curve falls into {len(combined)} separate pieces; connect its edges into one chain"
                )
            wire = combined[0].wrapped
    v1, v2 = TopoDS_Vertex(), TopoDS_Vertex()
    TopExp.Vertices_s(wire, v1, v2)
    closed = bool(BRep_Tool.IsClosed_s(wire))
    if not closed and not v1.IsNull() and not v2.IsNull():
        p1, p2 = BRep_Tool.Pnt_s(v1), BRep_Tool.Pnt_s(v2)
        closed = p1.Distance(p2) < _GAP_TOL
    return wire, closed


def _sample_wire(wire, samples: int | None) -> list[_Piece]:
    """Sample every edge of ``wire`` in order (OCCT), once: 3-D positions and
    derivatives per C1 span. A Python loop per sample is fine here: it runs a few
    thousand times per edge, never per texture vertex."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepTools import BRepTools_WireExplorer
    from OCP.GCPnts import GCPnts_AbscissaPoint
    from OCP.GeomAbs import GeomAbs_C1, GeomAbs_Line
    from OCP.gp import gp_Pnt, gp_Vec
    from OCP.TColStd import TColStd_Array1OfReal
    from OCP.TopAbs import TopAbs_REVERSED

    pieces: list[_Piece] = []
    exp = BRepTools_WireExplorer(wire)
    p, v = gp_Pnt(), gp_Vec()
    while exp.More():  # one iteration per edge
        edge = exp.Current()
        reverse = exp.Orientation() == TopAbs_REVERSED
        exp.Next()
        ad = BRepAdaptor_Curve(edge)
        u0, u1 = ad.FirstParameter(), ad.LastParameter()
        if ad.GetType() == GeomAbs_Line:
            spans = [(u0, u1, 1)]
        else:
            nint = ad.NbIntervals(GeomAbs_C1)
            arr = TColStd_Array1OfReal(1, nint + 1)
            ad.Intervals(arr, GeomAbs_C1)
            knots = [arr.Value(i) for i in range(1, nint + 2)]
            total = GCPnts_AbscissaPoint.Length_s(ad)
            spans = []
            for a, b in zip(knots[:-1], knots[1:]):  # one per C1 span
                frac = (b - a) / (u1 - u0) if u1 > u0 else 1.0
                n = samples if samples is not None else int(np.clip(np.ceil(total * frac / 0.05), 256, 4096))
                spans.append((a, b, max(1, int(n))))
        edge_pieces = []
        for a, b, n in spans:
            u = np.linspace(a, b, n + 1)
            eps = 1e-9 * (b - a)
            ue = u.copy()
            ue[0] += eps  # derivatives from inside the span at C0 knots
            ue[-1] -= eps
            out = np.empty((n + 1, 6))
            for i in range(n + 1):  # OCCT, once per sample
                ad.D1(float(ue[i]), p, v)
                out[i] = (p.X(), p.Y(), p.Z(), v.X(), v.Y(), v.Z())
            # Exact end positions.
            for i, uu in ((0, a), (n, b)):
                ad.D0(float(uu), p)
                out[i, :3] = (p.X(), p.Y(), p.Z())
            if reverse:
                edge_pieces.append((-u[::-1], out[::-1, :3].copy(), -out[::-1, 3:].copy()))
            else:
                edge_pieces.append((u, out[:, :3].copy(), out[:, 3:].copy()))
        if reverse:
            edge_pieces.reverse()
        pieces.extend(edge_pieces)
    if not pieces:
        raise InputError("the wire has no edges")
    return pieces  # type: ignore[return-value]


def _to_xz(pieces: list) -> list[_Piece]:
    """Map 3-D samples onto the XZ plane: y = const is used as is; z = const (a curve
    drawn on Plane.XY) is read with its y as z."""
    allp = np.concatenate([p for _, p, _ in pieces])
    ext = float(np.ptp(allp, axis=0).max()) or 1.0
    tol = 1e-6 * max(1.0, ext)
    yspan, zspan = float(np.ptp(allp[:, 1])), float(np.ptp(allp[:, 2]))
    if yspan <= tol:
        cols = (0, 2)
    elif zspan <= tol:
        cols = (0, 1)
    else:
        raise InputError(
            f"the profile is not planar in XZ (y varies by {yspan:.3g} mm) nor in XY (z varies by {zspan:.3g} mm); "
            "draw it on Plane.XZ (or Plane.XY, read as XZ)"
        )
    return [(t, p[:, cols], d[:, cols]) for t, p, d in pieces]


# -- surfaces ---------------------------------------------------------------------------
#: Names accepted by :meth:`Surface.named` (and ``texcad make --surface``).
SURFACE_KINDS = ("plate", "cylinder", "arc", "sine")


@dataclass(frozen=True, eq=False)
class Surface:
    """A profile extruded along +Y from ``y = 0`` to ``length`` mm, with its base body.

    Attributes:
        profile: the :class:`Profile` in the XZ plane.
        length: extrusion length along +Y in mm.
        base: the body the texture is fused onto: a build123d ``Part`` (helpers), a
            :class:`~texcad.solid.Mesh`, or anything :func:`texcad.fuse` accepts. Its
            surface must contain the extruded profile.
        thickness: the base's wall thickness under the profile in mm, if known (the
            texture slab reaches at most half of it into the base).
    """

    profile: Profile
    length: float
    base: Any = None
    thickness: float | None = None
    params: dict = field(default_factory=dict)

    @classmethod
    def plate(cls, width: float = 100.0, length: float = 100.0, thickness: float = 5.0) -> "Surface":
        """The paper's flat sample: a ``width x length x thickness`` mm plate, top face
        at ``z = 0`` over ``[0, width] x [0, length]``."""
        from build123d import Align, Box

        w, ln, t = (positive(n, v) for n, v in (("width", width), ("length", length), ("thickness", thickness)))
        base = Box(w, ln, t, align=(Align.MIN, Align.MIN, Align.MAX))
        return cls(Profile.plane(w), ln, base, t, {"kind": "plate", "width": w})

    @classmethod
    def cylinder(cls, radius: float = 20.0, length: float = 100.0, thickness: float | None = None) -> "Surface":
        """A cylinder of ``radius`` mm along +Y, axis through the origin (eq. 5-8).
        ``thickness`` makes it a tube with that wall (mm); None or >= radius: solid."""
        from build123d import Circle, Plane, extrude

        r, ln = positive("radius", radius), positive("length", length)
        t = None if thickness is None else positive("thickness", thickness)
        face = Circle(r) if (t is None or t >= r) else Circle(r) - Circle(r - t)
        base = extrude(Plane.XZ * face, amount=-ln)
        return cls(Profile.circle(r), ln, base, t if (t is not None and t < r) else r, {"kind": "cylinder", "radius": r})

    @classmethod
    def arc(cls, radius: float = 50.0, angle: float = 90.0, length: float = 100.0, thickness: float = 5.0) -> "Surface":
        """A cylindrical shell segment: outer radius ``radius`` mm, ``angle`` degrees
        symmetric about +z, wall ``thickness`` mm, along +Y (the paper's curved sample)."""
        from build123d import CenterArc, Line, Plane, extrude, make_face

        r, ln, t = (positive(n, v) for n, v in (("radius", radius), ("length", length), ("thickness", thickness)))
        a = float(angle)
        if not (0 < a < 360):
            raise ParameterError(f"arc angle must be in (0, 360) degrees, got {angle!r}; use cylinder for 360")
        if t >= r:
            raise ParameterError(f"thickness ({t:g} mm) must be less than the radius ({r:g} mm)")
        outer = CenterArc((0, 0), r, 90 - a / 2, a)
        inner = CenterArc((0, 0), r - t, 90 - a / 2, a)
        face = make_face([outer, Line(outer @ 1, inner @ 1), inner, Line(inner @ 0, outer @ 0)])
        base = extrude(Plane.XZ * face, amount=-ln)
        return cls(Profile.arc(r, a), ln, base, t, {"kind": "arc", "radius": r, "angle": a})

    @classmethod
    def sine(
        cls, amplitude: float = 5.0, period: float = 50.0, width: float = 100.0, length: float = 100.0, thickness: float = 5.0
    ) -> "Surface":
        """``z = A sin(2 pi x / L)``, ``0 <= x <= width`` (eq. 9), on a plate with a flat
        bottom at ``z = -(A + thickness)`` (the paper's sinusoidal sample, section 2.3)."""
        from build123d import Line, Plane, Polyline, Spline, extrude, make_face

        amp = float(amplitude)
        if not (np.isfinite(amp) and amp >= 0):
            raise ParameterError(f"amplitude must be >= 0 mm, got {amplitude!r}")
        lp, w, ln, t = (
            positive(n, v) for n, v in (("period", period), ("width", width), ("length", length), ("thickness", thickness))
        )
        prof = Profile.sine(amp, lp, w)
        # The base's top face: a spline through 64 points per period (error < 1e-5 mm
        # for A/L <= 1), tangent at the ends.
        n = max(16, int(np.ceil(64 * w / lp)))
        x = np.linspace(0, w, n + 1)
        k = 2 * np.pi / lp
        pts = [(float(a), float(amp * np.sin(k * a))) for a in x]
        zb = -(amp + t)
        if amp > 0:
            top = Spline(*pts, tangents=[(1, amp * k), (1, amp * k * np.cos(k * w))])
        else:
            top = Line((0, 0), (w, 0))
        face = make_face([top, Polyline((w, pts[-1][1]), (w, zb), (0, zb), (0, 0))])
        base = extrude(Plane.XZ * face, amount=-ln)
        return cls(prof, ln, base, t, {"kind": "sine", "amplitude": amp, "period": lp, "width": w})

    @classmethod
    def from_profile(cls, profile: Any, length: float, *, base: Any = None, thickness: float | None = None) -> "Surface":
        """A surface from any profile (a :class:`Profile` or a CAD curve/sketch).

        Without ``base``, :meth:`Profile.base_body` makes one (``thickness`` mm band
        under an open profile, default 5 mm; the filled region of a closed one)."""
        prof = profile if isinstance(profile, Profile) else Profile.from_cad(profile)
        ln = positive("length", length)
        if base is None:
            base = prof.base_body(ln, thickness)
            if thickness is None and not prof.closed:
                thickness = 5.0
        return cls(prof, ln, base, thickness, {"kind": "profile"})

    @classmethod
    def named(
        cls,
        kind: str,
        *,
        width: float = 100.0,
        length: float = 100.0,
        radius: float | None = None,
        angle: float = 90.0,
        amplitude: float = 5.0,
        period: float = 50.0,
        thickness: float = 5.0,
    ) -> "Surface":
        """One of :data:`SURFACE_KINDS` with the given dimensions (mm, degrees): what
        ``texcad make --surface`` builds. ``radius`` defaults to 20 mm (cylinder) and
        50 mm (arc); a cylinder with ``thickness >= radius`` is solid."""
        if kind == "plate":
            return cls.plate(width, length, thickness)
        if kind == "cylinder":
            r = 20.0 if radius is None else radius
            return cls.cylinder(r, length, thickness)
        if kind == "arc":
            return cls.arc(50.0 if radius is None else radius, angle, length, thickness)
        if kind == "sine":
            return cls.sine(amplitude, period, width, length, thickness)
        raise ParameterError(f"unknown surface {kind!r}; choose one of {', '.join(SURFACE_KINDS)}")


# -- the texture's own integral (the gate's check 4) ----------------------------------
def _tet(p: np.ndarray, q: np.ndarray, r: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Signed volumes of the tetrahedra ``(p, q, r, t)`` (rows), mm^3."""
    return np.einsum("ij,ij->i", np.cross(q - p, r - p), t - p) / 6.0


def swept_volume(base: np.ndarray, moved: np.ndarray, tri: np.ndarray, normals: np.ndarray) -> float:
    """The signed volume (mm^3) swept when the sheet ``(base, tri)`` moves to ``moved``:
    + where it moves along ``normals`` (the outward side: material added), - where
    it moves against them (material removed).

    Per triangle ``(a, b, c)`` the prism between it and its moved copy
    ``(a', b', c')`` is cut into the three tetrahedra ``(a b c a')``, ``(b c a' b')``,
    ``(c a' b' c')`` with the corners taken in the order of their vertex numbers,
    so that two triangles split the quadrilateral over their common side the same
    way and the sum is exactly the volume between the two triangulated sheets and
    the ruled walls over the sheet's outline. For a relief of height ``h`` along the
    normal of a surface with principal curvatures ``k1``, ``k2`` (mean ``H``,
    Gaussian ``K``, positive where the outward side is convex) this is the
    discretization of ``int (h + H h^2 + K h^3 / 3) dA`` (an extruded profile of
    curvature ``k``: ``int (h + k h^2 / 2) ds dy``), which ``sum h dA`` misses: a
    raised relief on a convex face adds more than ``h A``, an engraved one removes
    less. (Same construction as :func:`texcad.targets.mesh.offset_volume`.)

    Args:
        base, moved: ``(N, 3)`` points, mm (float64 is used).
        tri: ``(M, 3)`` int triangles of the sheet (either orientation).
        normals: ``(N, 3)`` the outward side at each point (any length); each
            triangle is oriented to agree with the mean of its corners' normals.

    Returns:
        The volume, mm^3 (float64).
    """
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    if not len(tri):
        return 0.0
    p = np.asarray(base, dtype=np.float64).reshape(-1, 3)
    q = np.asarray(moved, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    fs = np.sort(tri, axis=1)
    a, b, c = (p[fs[:, i]] for i in range(3))
    a2, b2, c2 = (q[fs[:, i]] for i in range(3))
    up = np.einsum("ij,ij->i", np.cross(b - a, c - a), n[fs].sum(axis=1))
    vol = _tet(a, b, c, a2) + _tet(b, c, a2, b2) + _tet(c, a2, b2, c2)
    return float((np.sign(up) * vol).sum())


class GridSweep(NamedTuple):
    """What :func:`grid_swept` measures on a grid: ``volume`` swept (mm^3, + along
    the normals), the cells' ``area`` (mm^2) and the ``excess`` (mm^3) between the
    curved surface and the cells' flat triangles (:func:`sheet_excess`)."""

    volume: float
    area: float
    excess: float


def grid_swept(base: np.ndarray, moved: np.ndarray, normals: np.ndarray, *, cells: "np.ndarray | None" = None,
               wrap_cols: bool = False, wrap_rows: bool = False, measure: bool = True) -> GridSweep:
    """:func:`swept_volume` and :func:`sheet_excess` of a grid sheet, by slicing
    (no gathers: a grid of 10^5 points takes milliseconds).

    Every cell ``a = (r, c)``, ``b = (r, c + 1)``, ``d = (r + 1, c)``,
    ``e = (r + 1, c + 1)`` is cut into the triangles ``(a, b, e)`` and ``(a, d, e)``,
    corners in row-major order (a wrapped column or row counts after the last), so
    the prisms over two cells split their common side the same way and the sum is
    exactly the volume between the two sheets and the ruled walls over the outline
    (:func:`swept_volume`'s three tetrahedra per prism).

    Args:
        base, moved: ``(R, C, 3)`` points, mm.
        normals: ``(R, C, 3)`` unit normals of the surface at ``base`` (the outward side).
        cells: bool ``(R', C')`` cells to count (None: all); ``R' = R`` with
            ``wrap_rows`` else ``R - 1``, likewise ``C'``.
        wrap_cols: the last column joins the first (a closed profile).
        wrap_rows: the last row joins the first (a face closed around).
        measure: also the area and the excess (else 0: half the work).
    """
    # Products in float32 about the grid's centre (1e-5 mm at 100 mm: far below any
    # slack), sums in float64: a third of the memory traffic of float64 throughout.
    centre = np.asarray(base, dtype=np.float64).reshape(-1, 3).mean(axis=0)
    p = (np.asarray(base, dtype=np.float64) - centre).astype(np.float32)
    q = (np.asarray(moved, dtype=np.float64) - centre).astype(np.float32)
    n = np.asarray(normals, dtype=np.float32)
    if wrap_cols:
        p, q, n = (np.concatenate([g, g[:, :1]], axis=1) for g in (p, q, n))
    if wrap_rows:
        p, q, n = (np.concatenate([g, g[:1]], axis=0) for g in (p, q, n))
    keep = np.ones((p.shape[0] - 1, p.shape[1] - 1), np.float32) if cells is None else np.asarray(cells, np.float32)
    if not keep.size:
        return GridSweep(0.0, 0.0, 0.0)
    P = (p[:-1, :-1], p[:-1, 1:], p[1:, :-1], p[1:, 1:])  # a, b, d, e
    Q = (q[:-1, :-1], q[:-1, 1:], q[1:, :-1], q[1:, 1:])
    N = (n[:-1, :-1], n[:-1, 1:], n[1:, :-1], n[1:, 1:])

    def dot(u, v):
        return u[..., 0] * v[..., 0] + u[..., 1] * v[..., 1] + u[..., 2] * v[..., 2]

    def triple(u, v, w):  # (u x v) . w, componentwise (np.cross copies its inputs)
        return ((u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1]) * w[..., 0]
                + (u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2]) * w[..., 1]
                + (u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]) * w[..., 2])

    def edge(i, j):  # the surface's sag over an edge's midpoint, mm
        return dot(N[j] - N[i], P[j] - P[i]) / 8.0

    vol = area = excess = 0.0
    e_ae = edge(0, 3) if measure else None
    for i, j, k in ((0, 1, 3), (0, 2, 3)):  # the two triangles, corners in row-major order
        x, y, z = P[i], P[j], P[k]
        x2, y2, z2 = Q[i], Q[j], Q[k]
        cr = np.cross(y - x, z - x)
        sign = np.sign(dot(cr, N[i] + N[j] + N[k]))
        prism = (dot(cr, x2 - x) + triple(z - y, x2 - y, y2 - y) + triple(x2 - z, y2 - z, z2 - z)) / 6.0
        vol += float((keep * sign * prism).sum(dtype=np.float64))
        if measure:
            a2 = 0.5 * np.sqrt(dot(cr, cr))
            area += float((keep * a2).sum(dtype=np.float64))
            excess += float((keep * a2 * (edge(i, j) + edge(j, k) + e_ae) / 3.0).sum(dtype=np.float64))
    return GridSweep(vol, area, excess)


def grid_triangles(rows: int, cols: int, *, closed: bool = False, cells: "np.ndarray | None" = None) -> np.ndarray:
    """Two triangles per cell of a ``(rows, cols)`` grid of points (row-major flat
    indices), ``(M, 3)`` int64; ``closed``: the last column joins the first (a closed
    profile); ``cells``: bool ``(rows - 1, cols - 1)`` (``cols`` when closed), the
    cells to keep (None: all)."""
    nc = cols if closed else cols - 1
    keep = np.ones((rows - 1, nc), bool) if cells is None else np.asarray(cells, bool)
    rr, cc = np.nonzero(keep)
    cn = (cc + 1) % cols
    a, b, d, e = rr * cols + cc, rr * cols + cn, (rr + 1) * cols + cc, (rr + 1) * cols + cn
    return np.concatenate([np.stack([a, b, e], 1), np.stack([a, e, d], 1)]).astype(np.int64)


def chord_excess(profile: "Profile", s: np.ndarray, *, closed: bool) -> float:
    """The area (mm^2) between the profile and the polygon through its points at the
    arc lengths ``s`` (C,) mm: ``sum kappa ds^3 / 12`` over the gaps (a circular
    segment of chord ``ds`` and curvature ``kappa``, to third order), positive where
    the profile is convex (it lies outside the polygon). Times the extrusion length
    it is the volume by which a relief measured from the polygon's sheet overstates
    what it adds outside the exact surface."""
    s = np.asarray(s, dtype=np.float64)
    ds = np.diff(s)
    mid = s[:-1] + 0.5 * ds
    if closed:
        gap = profile.length - (s[-1] - s[0])
        ds = np.append(ds, gap)
        mid = np.append(mid, (s[-1] + 0.5 * gap) % profile.length)
    if not len(ds):
        return 0.0
    return float((profile.curvature(mid) * ds ** 3).sum() / 12.0)


def sheet_excess(points: np.ndarray, normals: np.ndarray, tri: np.ndarray) -> float:
    """The volume (mm^3) between a curved surface and the triangles ``tri`` through
    its points ``points`` ``(N, 3)`` mm with unit normals ``normals`` ``(N, 3)``:
    positive where the surface is convex (it lies outside the triangles).

    Along an edge ``e = b - a`` the surface's normal curvature is
    ``(n_b - n_a) . e / |e|^2``, so the surface stands ``(n_b - n_a) . e / 8`` off
    the edge's midpoint; the gap over a triangle is a quadratic that vanishes at its
    corners, whose mean is the mean of its values at the three edge midpoints (the
    midpoint rule is exact for quadratics). Summed as ``area x mean gap`` per
    triangle: the 2D form of :func:`chord_excess`."""
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    if not len(tri):
        return 0.0
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    gap = np.zeros(len(tri))
    for i, j in ((0, 1), (1, 2), (2, 0)):  # the three edges
        gap += np.einsum("ij,ij->i", n[tri[:, j]] - n[tri[:, i]], p[tri[:, j]] - p[tri[:, i]]) / 8.0
    area = 0.5 * np.linalg.norm(np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]]), axis=1)
    return float((area * gap / 3.0).sum())


def mean_curvature(profile: "Profile", s: np.ndarray, *, closed: bool) -> float:
    """The profile's mean curvature (1/mm, positive convex) over the columns' span
    ``s`` (C,) mm: the turn of its normal over that span divided by its length
    (``2 pi / L`` around a closed convex profile), from the curvature at the gaps'
    middles weighted by the gaps."""
    s = np.asarray(s, dtype=np.float64)
    ds = np.diff(s)
    mid = s[:-1] + 0.5 * ds
    if closed:
        gap = profile.length - (s[-1] - s[0])
        ds, mid = np.append(ds, gap), np.append(mid, (s[-1] + 0.5 * gap) % profile.length)
    total = float(ds.sum())
    return float((profile.curvature(mid) * ds).sum() / total) if total > 0 else 0.0


def relief_integral(heights: np.ndarray, area: float, kappa: float = 0.0) -> float:
    """``int (t + kappa t^2 / 2) dA`` (mm^3): the volume of a relief of signed height
    ``t`` (mm, + outward) along the normal of a profile of curvature ``kappa``
    (1/mm, positive convex) extruded along y, over ``area`` mm^2, for a grid of
    heights ``heights`` ``(R, C)`` mm spread evenly over it. The relief between the
    grid points is linear on two triangles per cell (as it is meshed), so the mean
    of ``t`` and of ``t^2`` are those of that interpolant: over a triangle with
    corner heights ``a, b, c``, ``(a + b + c) / 3`` and ``(a^2 + b^2 + c^2 + ab +
    bc + ca) / 6``. Where the relief runs towards the centre of curvature
    (``kappa t < 0``) it is capped at ``1 / |kappa|`` (the formula's maximum: the
    relief has reached the axis)."""
    t = np.asarray(heights, dtype=np.float64)
    t = t.reshape(1, -1) if t.ndim == 1 else t
    k = float(kappa)
    if k != 0.0:
        t = np.where(k * t < 0, np.clip(t, -1.0 / abs(k), 1.0 / abs(k)), t)
    if t.shape[0] < 2 or t.shape[1] < 2:
        return float(np.mean(t + 0.5 * k * t * t)) * float(area) if t.size else 0.0
    a, b, d, e = t[:-1, :-1], t[:-1, 1:], t[1:, :-1], t[1:, 1:]
    mean = sum(float(np.mean(x + y + z)) / 3.0 for x, y, z in ((a, b, e), (a, e, d))) / 2.0
    square = sum(float(np.mean(x * x + y * y + z * z + x * y + y * z + z * x)) / 6.0 for x, y, z in ((a, b, e), (a, e, d))) / 2.0
    return (mean + 0.5 * k * square) * float(area)
