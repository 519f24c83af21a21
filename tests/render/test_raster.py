"""The numpy rasterizer behind ``texcad check --png`` and the figures."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

import texcad
from texcad.errors import ParameterError
from texcad.render import camera, height_image, rasterize, render_mesh, write_png


def test_camera_is_orthonormal_and_right_handed():
    b = camera((1.0, -2.0, 0.5), (0, 0, 1))
    assert np.allclose(b @ b.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(b), 1.0)
    assert np.allclose(b[2], -np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5]))
    # up parallel to the view: another up is chosen, still orthonormal
    b = camera((0, 0, -1), (0, 0, 1))
    assert np.allclose(b @ b.T, np.eye(3), atol=1e-12)
    with pytest.raises(ParameterError):
        camera((0, 0, 0))


def test_shared_edges_leave_no_cracks_or_double_cover():
    # A fan of triangles tiling a polygon: every pixel centre inside is covered once.
    rng = np.random.default_rng(3)
    ang = np.sort(rng.uniform(0, 2 * np.pi, 40))
    centre = np.array([50.3, 40.7])
    rim = centre + np.stack([30 * np.cos(ang), 25 * np.sin(ang)], axis=1)
    xy = np.vstack([centre, rim])
    faces = np.array([[0, 1 + i, 1 + (i + 1) % 40] for i in range(40)])
    _, fid = rasterize(xy, np.zeros(len(xy)), faces, 100, 80)
    # Reference coverage: pixel centres inside the polygon (fan is star-shaped from the centre).
    jj, ii = np.mgrid[0:80, 0:100]
    p = np.stack([ii + 0.5, jj + 0.5], axis=-1) - centre
    by_face = []
    for a, b in zip(rim - centre, np.roll(rim, -1, axis=0) - centre):  # per triangle of the fan
        det = a[0] * b[1] - a[1] * b[0]
        u = (p[..., 0] * b[1] - p[..., 1] * b[0]) / det
        v = (a[0] * p[..., 1] - a[1] * p[..., 0]) / det
        by_face.append((u > 1e-6) & (v > 1e-6) & (u + v < 1 - 1e-6))
    by_face = np.array(by_face)
    cover = by_face.sum(axis=0)
    inside = cover > 0
    assert inside.sum() > 1500
    assert np.all(fid[inside] >= 0)  # no cracks
    one = cover == 1  # strictly inside one triangle: that triangle is drawn there
    assert np.array_equal(fid[one], np.argmax(by_face, axis=0)[one])
    # Outside the polygon (away from its rim) nothing is drawn.
    far = np.ones((80, 100), dtype=bool)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            far &= ~np.roll(np.roll(inside, dx, axis=1), dy, axis=0)
    assert np.all(fid[far] == -1)


def test_nearest_face_wins_and_back_faces_are_culled():
    xy = np.array([[0, 0], [10, 0], [0, 10], [0, 0], [10, 0], [0, 10]], dtype=float)
    depth = np.array([1, 1, 1, 2, 2, 2], dtype=float)
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    zb, fid = rasterize(xy, depth, faces, 10, 10)
    assert fid[1, 1] == 1 and zb[1, 1] == 2.0
    _, fid = rasterize(xy, depth, np.array([[0, 1, 2], [3, 5, 4]]), 10, 10)  # second one clockwise
    assert fid[1, 1] == 0


def test_render_box_silhouette_area():
    # A 20 x 10 x 5 mm box seen straight from +z: its image is a 2:1 rectangle.
    import manifold3d as m3d

    from texcad.solid import from_manifold

    box = from_manifold(m3d.Manifold.cube([20.0, 10.0, 5.0]))
    img, info = render_mesh(box, view=(0, 0, -1), up=(0, 1, 0), width=200, margin=0.0, return_info=True)
    covered = info["face"] >= 0
    rows = np.flatnonzero(covered.any(axis=1))
    cols = np.flatnonzero(covered.any(axis=0))
    assert abs(len(cols) / len(rows) - 2.0) < 0.03
    assert covered.mean() > 0.97
    # Only the top faces are seen, all lit alike.
    seen = np.unique(info["face"][covered])
    assert np.allclose(box.face_normals()[seen], [0, 0, 1], atol=1e-6)


def test_height_image_of_a_slab_recovers_the_heightmap():
    hm = texcad.builtin("ridges", size=10, pitch=0.25, height=1.0)
    slab = texcad.solid.heightfield_slab(hm, depth=0.5)
    heights, mask, pitch = height_image(slab, (0, 0, 1), 0.25, faces=slab.groups["texture"])
    assert pitch == 0.25 and mask.mean() > 0.9
    assert abs(float(heights[mask].max()) - float(hm.heights.max() - hm.heights.min())) < 0.02


def test_write_png_is_y_up(tmp_path):
    rgb = np.zeros((4, 3, 3))
    rgb[0, :, 0] = 1.0  # bottom row red
    write_png(tmp_path / "a.png", rgb)
    img = np.asarray(Image.open(tmp_path / "a.png").convert("RGB"))
    assert img.shape == (4, 3, 3) and np.all(img[-1, :, 0] == 255) and np.all(img[0] == 0)
