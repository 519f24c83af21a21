"""Texture continuity across joints: surfaces textured in pieces and assembled.

The paper's sledgehammer (section 3.4) splits a cylindrical handle into two halves,
textures each separately with a texture made seamless by M-II (section 2.1.4), and
assembles them; it reports the angle-preserving result continuous "within a tolerance
of 62 um" and the distance-preserving one failing on the closed shape (figure 15).

Two pieces ``A`` and ``B`` meet along a joint line where ``A``'s last texture column
and ``B``'s first column are the same texture column mapped twice (from both sides).
The **seam gap** is the distance between the two mapped copies of that column,

    gap_r = || top_A[r, C_A - 1] - top_B[r, 0] ||,   r = 0 .. R - 1,

reported as its maximum and RMS in micrometres. With algorithm 2 (angle-preserving)
both copies are ``P(s_joint) + h_r n(s_joint)`` and the gap is rounding only; with
algorithm 1 (distance-preserving) each piece offsets along its own ``sigma e_z``, so at
a joint where the profile is vertical the copies move apart by ``2 h_r``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ParameterError

__all__ = ["SeamGap", "seam_gap"]


@dataclass(frozen=True)
class SeamGap:
    """The gap between two textured pieces along their joint.

    Attributes:
        max_um: largest distance between the two copies of the joint column, um.
        rms_um: root mean square of that distance over the rows, um.
        where: ``(3,)`` mm, the point of piece ``A`` where the gap is largest.
        rows: number of texture rows compared.
    """

    max_um: float
    rms_um: float
    where: tuple[float, float, float]
    rows: int

    def __str__(self) -> str:
        x, y, z = self.where
        return f"seam gap max {self.max_um:.3g} um, RMS {self.rms_um:.3g} um over {self.rows} rows (worst at ({x:.2f}, {y:.2f}, {z:.2f}) mm)"


def _top(obj: Any, name: str) -> np.ndarray:
    top = getattr(obj, "top", obj)
    arr = np.asarray(top, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise ParameterError(
            f"{name} must be a MappedSurface or an (R, C, 3) grid of mm coordinates, got shape {arr.shape}"
        )
    return arr


def seam_gap(a: Any, b: Any) -> SeamGap:
    """Gap between piece ``a``'s last texture column and piece ``b``'s first, um.

    Args:
        a: the piece before the joint: a :class:`texcad.mapping.MappedSurface` or its
            ``(R, C_a, 3)`` top grid in mm.
        b: the piece after the joint: likewise ``(R, C_b, 3)``, same ``R``.

    Returns:
        :class:`SeamGap` (``max_um``, ``rms_um``, ``where``).

    Raises:
        ParameterError: the pieces have different numbers of rows (they must share
            the joint's texture rows), or are not grids.
    """
    ta, tb = _top(a, "a"), _top(b, "b")
    if ta.shape[0] != tb.shape[0]:
        raise ParameterError(
            f"the pieces have {ta.shape[0]} and {tb.shape[0]} texture rows; a joint compares the same rows, "
            "so texture both pieces from one heightmap with the same rows"
        )
    d = np.linalg.norm(ta[:, -1] - tb[:, 0], axis=1) * 1e3
    k = int(np.argmax(d))
    return SeamGap(
        max_um=float(d[k]),
        rms_um=float(np.sqrt(np.mean(d**2))),
        where=tuple(float(v) for v in ta[k, -1]),
        rows=int(ta.shape[0]),
    )
