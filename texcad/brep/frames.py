"""Frames of B-rep faces: where a texture's (x, y, height) axes lie on a face (mm,
degrees)."""

from __future__ import annotations

import numpy as np

from .occt import as_array

__all__ = ["plane_frame"]


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def plane_frame(face, rotation: float = 0.0):
    """``(point, xdir, ydir, normal)`` of a planar face; ``normal`` points out of the
    body, ``(xdir, ydir, normal)`` is right-handed, ``ydir`` points towards world +z
    (x along world x on horizontal faces), turned by ``rotation`` degrees about the
    normal."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.TopAbs import TopAbs_REVERSED

    ad = BRepAdaptor_Surface(face)
    pln = ad.Plane()
    p0 = as_array(pln.Location())
    # The surface's own normal is XDir x YDir: the axis for a right-handed plane
    # frame, minus the axis for a left-handed one (e.g. the bottom annulus of a
    # revolved part); the face's orientation flips it once more.
    pos = pln.Position()
    n = np.cross(as_array(pos.XDirection()), as_array(pos.YDirection()))
    n = n / np.linalg.norm(n)
    if face.Orientation() == TopAbs_REVERSED:
        n = -n
    if abs(n[2]) > 0.999:
        ex = _unit(np.array([1.0, 0.0, 0.0]) - n[0] * n)
        ey = np.cross(n, ex)
    else:
        ey = _unit(np.array([0.0, 0.0, 1.0]) - n[2] * n)
        ex = np.cross(ey, n)
    a = np.radians(float(rotation))
    ex, ey = np.cos(a) * ex + np.sin(a) * ey, -np.sin(a) * ex + np.cos(a) * ey
    return p0, ex, ey, n
