"""Lean meshes on curved (mapped) surfaces (texcad.mapping.lean_slab_mesh): the 3-D
distance from every pixel centre of the exact mapped surface to the mesh stays within
the tolerance (measured here independently with libigl's closest points), the slab
is watertight, its volume is within tolerance x area of the tolerance=0 slab, and the
curvature of the base is part of the bound (a flat texture on a cylinder)."""

import warnings

import manifold3d
import numpy as np
import pytest
import trimesh

import texcad
from texcad.mapping import Profile, Surface, developed_field, fit_texture, lean_slab_mesh, map_texture
from texcad.solid import edge_report, grid_distance, triangulate


def _closed_spline():
    from build123d import BuildLine, Plane, Spline

    with BuildLine(Plane.XZ) as bl:
        Spline((0, 0), (30, -5), (50, 10), (35, 30), (5, 25), periodic=True)
    return bl.line


def _surface(kind: str, length: float) -> Surface:
    if kind == "cylinder":
        return Surface.cylinder(6.0, length, 3.0)
    if kind == "sine":
        return Surface.sine(length=length, thickness=5.0, amplitude=3.0, period=20.0, width=30.0)
    return Surface.from_profile(_closed_spline(), length)


def _mapped(kind: str, texture: str, mapping: str, pitch: float = 0.125, height: float = 0.8):
    surf = _surface(kind, 8.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hm, per = fit_texture(surf.profile, texture, length=surf.length, pitch=pitch, height=height, periodic_x=None)
        m = map_texture(surf.profile, hm, mapping=mapping, length=surf.length, depth=0.4, periodic_x=per)
    return surf, m


def _trimesh_distance(points: np.ndarray, slab) -> np.ndarray:
    """Distance in mm from every exact grid point to the lean surface's triangles
    (libigl's AABB closest point: independent of texcad's rasterization)."""
    import igl

    f = slab.faces[slab.groups["texture"]].astype(np.int64)
    d2, _, _ = igl.point_mesh_squared_distance(points.reshape(-1, 3), slab.vertices.astype(np.float64), f)
    return np.sqrt(d2)


@pytest.mark.parametrize("kind,mapping,texture", [
    ("cylinder", "angle", "builtin:stones"),
    ("sine", "distance", "builtin:diamond_knurl"),
    ("closed_spline", "angle", "builtin:stones"),
])
@pytest.mark.parametrize("tol", [0.02, 0.05])
def test_lean_mapped_slab_error_watertight_volume(kind, mapping, texture, tol):
    surf, m = _mapped(kind, texture, mapping)
    dense = m.solid()
    slab, err = lean_slab_mesh(m.top, m.bottom, surf.profile, m.s, closed=m.closed, tolerance=tol)
    assert 0 < err <= tol
    assert slab.num_triangles < 0.6 * dense.num_triangles
    # independent: libigl's exact closest point from every pixel centre of the exact surface
    d = _trimesh_distance(m.top.astype(np.float64), slab)
    assert d.max() <= err + 1e-5  # texcad's figure is an upper bound (float32 vertices)
    assert d.max() <= tol + 1e-5
    assert edge_report(slab.faces)["watertight"]
    assert manifold3d.Manifold(manifold3d.Mesh(slab.vertices, slab.faces)).status() == manifold3d.Error.NoError
    assert trimesh.Trimesh(slab.vertices, slab.faces, process=True).is_watertight
    area = float(np.ptp(m.s)) * float(np.ptp(m.y)) if not m.closed else surf.profile.length * float(np.ptp(m.y))
    assert abs(slab.volume - dense.volume) <= tol * area
    # the border rows and columns are the full grid's (walls; closed: the seam column)
    border = np.concatenate([m.top[0], m.top[-1], m.top[:, 0]] + ([] if m.closed else [m.top[:, -1]]))
    kept = {tuple(v) for v in slab.vertices.tolist()}
    assert all(tuple(v) in kept for v in border.tolist())


def test_the_base_curvature_is_in_the_bound():
    """A constant texture on a cylinder: the relief alone needs only the corners, the
    chord sag R (1 - cos(ds / 2R)) of flat facets is what limits them."""
    from texcad.sources import Heightmap

    surf = Surface.cylinder(5.0, 6.0, 3.0)
    tol = 0.01
    hm = Heightmap(np.full((40, int(round(surf.profile.length / 0.125))), 0.5, np.float32), (0.125, 0.125))
    m = map_texture(surf.profile, hm, mapping="angle", length=6.0, depth=0.4, periodic_x=True)
    slab, err = lean_slab_mesh(m.top, m.bottom, surf.profile, m.s, closed=True, tolerance=tol)
    assert 0 < err <= tol
    assert _trimesh_distance(m.top.astype(np.float64), slab).max() <= tol + 1e-5
    # columns needed: facets of at most sqrt(8 (R + h) tol) around the 5.5 mm radius
    cols_kept = len(np.unique(np.round(np.arctan2(slab.vertices[:, 2], slab.vertices[:, 0]), 5)))
    assert cols_kept >= 2 * np.pi * 5.5 / np.sqrt(8 * 5.5 * tol)
    # the relief's own field (no developed profile) would keep far too few
    H = developed_field(m.top, surf.profile, m.s, closed=True)
    q = H - 0.5
    assert np.ptp(q) > 1.0  # the developed profile carries the curvature
    rc, f = triangulate(np.full_like(H, 0.5), tol, full_border=True)
    pts = np.concatenate([m.top, m.top[:, :1]], axis=1).astype(np.float64)
    flat = rc[:, 0] * m.top.shape[1] + np.mod(rc[:, 1], m.top.shape[1])
    naive = grid_distance(pts, rc, m.top.reshape(-1, 3)[flat], f).max()
    assert naive > 10 * tol


def test_grid_distance_is_an_upper_bound_of_the_true_distance():
    surf, m = _mapped("sine", "builtin:stones", "angle", pitch=0.25)
    slab, err = lean_slab_mesh(m.top, m.bottom, surf.profile, m.s, closed=False, tolerance=0.05)
    d = _trimesh_distance(m.top.astype(np.float64), slab).reshape(m.top.shape[:2])
    rc_all = np.stack(np.meshgrid(np.arange(m.top.shape[0]), np.arange(m.top.shape[1]), indexing="ij"), -1)
    # a wrong vertex is seen
    top = m.top.astype(np.float64).copy()
    top[5, 7, 2] += 0.3
    rows, cols = top.shape[:2]
    from texcad.solid import grid_faces

    f = grid_faces(rows, cols).astype(np.int64)
    g = grid_distance(top, rc_all.reshape(-1, 2), m.top.reshape(-1, 3), f)
    import igl

    d2, _, _ = igl.point_mesh_squared_distance(top[5:6, 7], m.top.reshape(-1, 3).astype(np.float64), f)
    assert 0.2 < np.sqrt(d2[0]) <= g[5, 7] + 1e-9 <= 0.3 + 1e-5  # off the tilted surface, upper bound
    assert np.delete(g.ravel(), 5 * cols + 7).max() < 1e-5
    assert d.max() <= err + 1e-5


@pytest.mark.parametrize("tol", [0.0, 0.02])
def test_texture_on_a_surface_and_an_extruded_face(tol):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = texcad.texture(Surface.cylinder(6.0, 8.0, 3.0), None, "builtin:stones", height=0.8, tolerance=tol)
    assert r.max_error <= tol and (r.max_error > 0) == (tol > 0)
    assert edge_report(r.mesh.faces)["watertight"]
    from build123d import Axis, Cylinder

    part = Cylinder(6.0, 10.0)
    face = part.faces().sort_by(Axis.Z)[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # pitch 0.125 mm (the default was then): at 0.25 mm every knurl pixel matters and the
        # lean mesh would keep more than MAX_FRACTION of the grid (then the grid, error 0)
        c = texcad.texture(part, face, "builtin:diamond_knurl", height=0.6, tolerance=tol, brep=False, pitch=0.125)
    assert c.max_error <= tol and (c.max_error > 0) == (tol > 0)
    assert edge_report(c.mesh.faces)["watertight"]
