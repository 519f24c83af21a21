"""The B-rep of a textured face of an extruded profile (:class:`texcad.targets.ExtrusionAdapter`):
:func:`extrusion_brep`."""

from __future__ import annotations

from typing import Any

import numpy as np


__all__ = ["extrusion_brep", "snapped_grid"]


def extrusion_brep(topo: Any, face: Any, top, bottom, *, closed: bool, base=None, fine=None, mesh=None,
                   max_error: float = 0.0):
    """The textured B-rep of a face of an extruded profile (grids in world mm, as
    :func:`texcad.brep.textured_extrusion_solid`; ``base`` ``(C, 3)``: the face
    under the grid's first row): an open profile's face is replaced in place by tiles
    (:func:`texcad.brep.open_extrusion_solid`, no boolean; ``fine``: boxes ``(lo,
    hi)`` mm where the tiles are small, for a CAD operation's tool); closed bands and
    anything else go to :func:`texcad.brep.textured_extrusion_solid`. ``mesh``: the
    textured part's lean mesh, within ``max_error`` mm of the grid: the grid's inner
    points are put on it (:func:`snapped_grid`)."""
    from .uvfaces import open_extrusion_solid
    from .solids import textured_extrusion_solid

    if mesh is not None and max_error > 0:
        top = snapped_grid(top, mesh, max_error, closed=closed)

    if not closed:
        out = open_extrusion_solid(topo, face, top, base, fine=fine)
        if out is not None:
            return out
    return textured_extrusion_solid(topo, face, top, bottom, closed=closed, fine=fine)


def snapped_grid(top: np.ndarray, mesh: Any, max_error: float, *, closed: bool) -> np.ndarray:
    """``top`` (``(R, C, 3)`` mm, a texture grid, ``d/dc x d/dr`` outward) moved along
    its normals by the mean offset of ``mesh`` (texcad's lean mesh, within
    ``max_error`` mm of the grid; nearest points by AABB search, each within ``1.5
    max_error``) over :data:`LEAN_SMOOTH` x :data:`LEAN_SMOOTH` points around each:
    the B-rep then encloses the mesh's volume (a 16 mm stones cylinder at 0.25 mm
    read 0.12 % above its lean mesh) and keeps the grid's shape (its STEP tiles fit
    as few poles as before). The first and last rows stay (a closed band's ends lie
    in planes), and an open grid's first and last columns."""
    import igl
    from scipy.ndimage import uniform_filter

    g = np.asarray(top, np.float64)
    roll = (lambda a, k: np.roll(a, k, axis=1)) if closed else None
    dc = roll(g, -1) - roll(g, 1) if closed else np.gradient(g, axis=1)
    n = np.cross(dc, np.gradient(g, axis=0))
    n /= np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-18)
    inner = (slice(1, -1), slice(None) if closed else slice(1, -1))
    q = np.ascontiguousarray(g[inner].reshape(-1, 3))
    d2, _, near = igl.point_mesh_squared_distance(q, mesh.vertices.astype(np.float64), mesh.faces.astype(np.int64))
    ok = (d2 <= (1.5 * max_error) ** 2).reshape(g[inner].shape[:2])
    d = np.where(ok, np.einsum("ij,ij->i", near - q, n[inner].reshape(-1, 3)).reshape(ok.shape), 0.0)
    mode = ("nearest", "wrap") if closed else "nearest"
    w = uniform_filter(ok.astype(np.float64), LEAN_SMOOTH, mode=mode)
    mean = uniform_filter(d, LEAN_SMOOTH, mode=mode) / np.maximum(w, 1e-12)
    out = g.copy()
    out[inner] = g[inner] + np.where(ok, mean, 0.0)[..., None] * n[inner]
    return out


#: Grid points a side over which the lean mesh's offset from the grid is averaged
#: (:func:`snapped_grid`; the faces on their own (u, v) too,
#: :attr:`texcad.targets.patches.PatchRelief.brep_top`).
LEAN_SMOOTH = 5
