"""Where on a mesh a texture goes: :class:`Region` (mm and degrees).

A region selects faces of a triangle mesh:

* ``all``: every face;
* ``normal``: faces whose outward normal lies within ``angle`` degrees of
  ``direction`` (``n . d >= cos(angle)``);
* ``box``: faces whose centroid lies in the axis-aligned box ``lo..hi`` (mm);
* ``sphere``: faces whose centroid lies within ``radius`` mm of ``center``.

The bed face is left out unless ``bottom=True``: faces whose normal is within 1
degree of ``-build_dir`` and whose vertices all lie within ``tolerance`` mm of the
part's lowest point along ``build_dir`` (the face the part stands on).

String forms (CLI): ``"all"``, ``"not-bottom"`` (the same: the bed face is never
textured by default), ``"all+bottom"``, ``"normal:+x:70"`` or ``"normal:0,1,1:30"``,
``"box:x0,y0,z0,x1,y1,z1"``, ``"sphere:x,y,z,r"``; ``"not:SPEC"`` is every face but
those of ``SPEC`` (e.g. ``"not:normal:+z:30"``: the sides and below, not the top).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import ParameterError
from .projection import parse_axis

__all__ = ["Region", "REGION_KINDS", "bed_faces"]

REGION_KINDS = ("all", "normal", "box", "sphere")


def _numbers(text: str, count: int, what: str) -> list[float]:
    try:
        vals = [float(t) for t in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) != count or not all(np.isfinite(vals)):
        raise ParameterError(f"region {what!r} needs {count} numbers separated by commas (mm), got {text!r}")
    return vals


def bed_faces(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, build_dir: np.ndarray, tolerance: float) -> np.ndarray:
    """``(M,)`` bool: the faces the part stands on (normal within 1 degree of
    ``-build_dir``, all three vertices within ``tolerance`` mm of the lowest point)."""
    h = vertices @ build_dir
    low = float(h.min()) if len(h) else 0.0
    down = normals @ -build_dir >= np.cos(np.radians(1.0))
    return down & np.all(h[faces] <= low + tolerance, axis=1)


@dataclass(frozen=True)
class Region:
    """A set of faces to texture (module docstring). Lengths mm, angles degrees.

    Attributes:
        kind: one of :data:`REGION_KINDS`.
        direction: ``normal``: the direction (``"+x"`` or a 3-vector).
        angle: ``normal``: half-angle of the cone of normals, degrees (0..180).
        lo, hi: ``box`` corners, mm.
        center, radius: ``sphere``, mm.
        bottom: texture the bed face too (default False).
        invert: every face *not* selected by the rest (the bed face still left out).
    """

    kind: str = "all"
    direction: "str | Sequence[float]" = "+z"
    angle: float = 90.0
    lo: "Sequence[float] | None" = None
    hi: "Sequence[float] | None" = None
    center: "Sequence[float] | None" = None
    radius: float | None = None
    bottom: bool = False
    invert: bool = False

    def __post_init__(self) -> None:
        if self.kind not in REGION_KINDS:
            raise ParameterError(f"region kind {self.kind!r}: use one of {', '.join(REGION_KINDS)}")
        if self.kind == "normal":
            parse_axis(self.direction)
            if not (0 < float(self.angle) <= 180):
                raise ParameterError(f"region angle must be in (0, 180] degrees, got {self.angle!r}")
        if self.kind == "box":
            if self.lo is None or self.hi is None or np.any(np.asarray(self.hi, float) <= np.asarray(self.lo, float)):
                raise ParameterError(f"a box region needs lo < hi in x, y and z (mm), got {self.lo!r}, {self.hi!r}")
        if self.kind == "sphere" and (self.center is None or self.radius is None or not self.radius > 0):
            raise ParameterError("a sphere region needs a center (x, y, z) and a positive radius in mm")

    @classmethod
    def parse(cls, spec: "str | Region | None") -> "Region":
        """A region from its string form (module docstring), a Region, or None (all)."""
        if spec is None:
            return cls()
        if isinstance(spec, Region):
            return spec
        if not isinstance(spec, str):
            raise ParameterError(f"a mesh region is a texcad Region or a string like 'normal:+x:70', got {type(spec).__name__}")
        s = spec.strip().lower()
        if s.startswith("not:"):
            inner = cls.parse(s[4:])
            return cls(**{**inner.__dict__, "invert": not inner.invert})
        if s in ("all", "not-bottom", "everything-but-bottom"):
            return cls()
        if s in ("all+bottom", "everything"):
            return cls(bottom=True)
        kind, _, rest = s.partition(":")
        if kind == "normal":
            d, _, a = rest.rpartition(":")
            try:
                ang = float(a)
            except ValueError:
                raise ParameterError(f"region {spec!r}: write normal:DIRECTION:DEGREES, e.g. normal:+x:70") from None
            direction = d if d.lstrip("+-") in ("x", "y", "z") else _numbers(d, 3, "normal direction")
            return cls("normal", direction=direction, angle=ang)
        if kind == "box":
            v = _numbers(rest, 6, spec)
            return cls("box", lo=tuple(v[:3]), hi=tuple(v[3:]))
        if kind == "sphere":
            v = _numbers(rest, 4, spec)
            return cls("sphere", center=tuple(v[:3]), radius=v[3])
        raise ParameterError(
            f"unknown region {spec!r}; use all, not-bottom, all+bottom, normal:+x:70, box:x0,y0,z0,x1,y1,z1, "
            "sphere:x,y,z,r or not:REGION"
        )

    def settled(self, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
        """``(M,)`` bool: faces whose every piece after subdivision is selected as the
        face is (``all`` and ``normal`` regions: every face; ``box`` and ``sphere``:
        faces with all three corners inside, or whose bounding box misses the
        region's; the rest straddle its boundary)."""
        if self.kind in ("all", "normal"):
            return np.ones(len(faces), dtype=bool)
        tri = vertices[faces]
        if self.kind == "box":
            lo, hi = np.asarray(self.lo, float), np.asarray(self.hi, float)
            inside = np.all((tri >= lo) & (tri <= hi), axis=(1, 2))
            meets = np.all(tri.max(axis=1) >= lo, axis=1) & np.all(tri.min(axis=1) <= hi, axis=1)
        else:
            c0, r = np.asarray(self.center, float), float(self.radius)
            inside = np.all(np.linalg.norm(tri - c0, axis=2) <= r, axis=1)
            meets = np.all(tri.max(axis=1) >= c0 - r, axis=1) & np.all(tri.min(axis=1) <= c0 + r, axis=1)
        return inside | ~meets

    def select(
        self,
        vertices: np.ndarray,
        faces: np.ndarray,
        normals: np.ndarray,
        *,
        build_dir: np.ndarray,
        tolerance: float,
        loose: bool = False,
    ) -> np.ndarray:
        """``(M,)`` bool: the faces in the region.

        ``loose``: box and sphere regions take every face whose bounding box meets
        the region's (a superset, used before subdivision; afterwards the centroid
        decides).
        """
        tri = vertices[faces]
        if self.kind == "all":
            sel = np.ones(len(faces), dtype=bool)
        elif self.kind == "normal":
            sel = normals @ parse_axis(self.direction) >= np.cos(np.radians(float(self.angle))) - 1e-12
        elif self.kind == "box":
            lo, hi = np.asarray(self.lo, float), np.asarray(self.hi, float)
            if loose:
                sel = np.all(tri.max(axis=1) >= lo, axis=1) & np.all(tri.min(axis=1) <= hi, axis=1)
            else:
                c = tri.mean(axis=1)
                sel = np.all((c >= lo) & (c <= hi), axis=1)
        else:
            c0, r = np.asarray(self.center, float), float(self.radius)
            if loose:
                sel = np.all(tri.max(axis=1) >= c0 - r, axis=1) & np.all(tri.min(axis=1) <= c0 + r, axis=1)
            else:
                sel = np.linalg.norm(tri.mean(axis=1) - c0, axis=1) <= r
        if self.invert:
            sel = np.ones(len(faces), dtype=bool) if (loose and self.kind in ("box", "sphere")) else ~sel
        if not self.bottom:
            sel &= ~bed_faces(vertices, faces, normals, build_dir, tolerance)
        return sel
