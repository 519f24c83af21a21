import itertools

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import texcad
import texcad.sources
from texcad import Heightmap, InputError, ParameterError
from texcad.sources import ScanData, fit_plane, largest_rectangle, read_scan, scan_to_heightmap

SIGMA = 0.02  # mm, sensor noise of the synthetic scans


def relief(x, y):
    """A known heightfield in mm (about +-0.6 mm)."""
    return 0.4 * np.sin(2 * np.pi * x / 6) * np.cos(2 * np.pi * y / 5) + 0.2 * np.sin(2 * np.pi * (x + y) / 3.7)


def synthetic_scan(rng, *, n=60_000, size=24.0, outliers=0.02, footprint=None):
    """Points on `relief` with noise and outliers, then tilted and moved.

    Returns (scan points, rotation R, offset t, outlier mask): scan = R p + t.
    """
    xy = rng.uniform(0, size, (n, 2))
    if footprint is not None:
        xy = xy[footprint(xy)]
    z = relief(xy[:, 0], xy[:, 1]) + rng.normal(0, SIGMA, len(xy))
    p = np.column_stack([xy, z])
    out = rng.random(len(p)) < outliers
    p[out, 2] += rng.choice([-1.0, 1.0], out.sum()) * rng.uniform(0.3, 5.0, out.sum())
    R = Rotation.from_euler("xyz", [4.0, -6.0, 20.0], degrees=True).as_matrix()
    t = np.array([10.0, -5.0, 30.0])
    return p @ R.T + t, R, t, out


def truth_on_grid(hm, report, R, t):
    """`relief` at the heightmap's pixel centres, in the heightmap's frame."""
    X, Y = np.meshgrid(hm.x, hm.y)
    o = np.array(report.origin)
    ex, ey, _ = (np.array(a) for a in report.axes)
    q = (o + X[..., None] * ex + Y[..., None] * ey - t) @ R  # back to the sample's frame
    return relief(q[..., 0], q[..., 1]) - q[..., 2]


def test_recovers_known_heightfield_through_tilt_noise_and_outliers():
    rng = np.random.default_rng(7)
    pts, R, t, out = synthetic_scan(rng)
    hm, rep = scan_to_heightmap(pts, pitch=0.25)
    d = hm.heights - truth_on_grid(hm, rep, R, t)
    d -= d.mean()
    rms = float(np.sqrt(np.mean(d**2)))
    assert rms <= 1.5 * SIGMA, rms
    # The report: tilt of the plane, outliers, noise, coverage.
    true_tilt = np.degrees(np.arccos((R @ [0, 0, 1])[2]))
    assert abs(rep.plane_tilt - true_tilt) < 0.05
    assert abs(rep.outliers_dropped - out.sum()) <= 0.15 * out.sum()
    assert 0.8 * SIGMA <= rep.noise_rms <= 1.5 * SIGMA
    assert rep.coverage > 0.99 and rep.nonfinite_dropped == 0
    assert rep.points_read == len(pts) and rep.points_used > 0.5 * len(pts)
    assert hm.shape == rep.shape and np.isclose(hm.heights.min(), 0.0)
    assert "outliers" in rep.summary() and "noise" in rep.summary()
    # Same input, same bytes.
    again, _ = scan_to_heightmap(pts, pitch=0.25)
    assert again.heights.tobytes() == hm.heights.tobytes()


def test_base_is_robust_low_percentile():
    rng = np.random.default_rng(3)
    pts, *_ = synthetic_scan(rng, n=20_000, outliers=0.0)
    hm, rep = scan_to_heightmap(pts, pitch=0.4, base_percentile=0.5)
    # The 0.5 % lowest pixels are clipped to the surface, the rest stand above it.
    assert hm.heights.min() == 0.0
    assert 0.002 <= np.mean(hm.heights == 0.0) <= 0.01
    assert np.isclose(rep.max_height, hm.max_height)


def test_crop_to_largest_covered_rectangle_of_a_round_scan():
    rng = np.random.default_rng(11)
    r = 10.0
    pts, R, t, _ = synthetic_scan(rng, n=40_000, size=24.0, outliers=0.0, footprint=lambda xy: np.hypot(xy[:, 0] - 12, xy[:, 1] - 12) < r)
    hm, rep = scan_to_heightmap(pts, pitch=0.25)
    x0, y0, x1, y1 = rep.crop_box
    w, d = x1 - x0, y1 - y0
    # Inside the disc (corners within r plus a pixel), and nearly the inscribed square 2 r^2.
    assert np.hypot(w / 2, d / 2) <= r + 0.25
    assert w * d >= 0.9 * 2 * r * r
    assert np.allclose(hm.size, (w, d))
    diff = hm.heights - truth_on_grid(hm, rep, R, t)
    assert np.sqrt(np.mean((diff - diff.mean()) ** 2)) <= 1.5 * SIGMA


def test_holes_are_filled_or_avoided():
    rng = np.random.default_rng(5)
    hole = lambda xy: np.hypot(xy[:, 0] - 12, xy[:, 1] - 12) > 2.0  # noqa: E731
    pts, R, t, _ = synthetic_scan(rng, n=40_000, outliers=0.0, footprint=hole)
    hm, rep = scan_to_heightmap(pts, pitch=0.25)
    assert rep.coverage < 0.98  # the hole was filled inside the crop
    assert hm.size[0] > 18 and hm.size[1] > 18  # the 24 mm square turned by 20 deg
    X, Y = np.meshgrid(hm.x, hm.y)
    ex, ey, _ = (np.array(a) for a in rep.axes)
    q = (np.array(rep.origin) + X[..., None] * ex + Y[..., None] * ey - t) @ R
    r = np.hypot(q[..., 0] - 12, q[..., 1] - 12)
    in_hole = r < 1.5
    assert in_hole.sum() > 80
    diff = hm.heights - truth_on_grid(hm, rep, R, t)
    diff -= np.median(diff)
    assert np.sqrt(np.mean(diff[r > 2.5] ** 2)) <= 1.5 * SIGMA
    # Linear interpolation from the hole's rim: no new extremes inside.
    rim = ~in_hole & (r < 3.0)
    assert hm.heights[rim].min() - 1e-6 <= hm.heights[in_hole].min()
    assert hm.heights[in_hole].max() <= hm.heights[rim].max() + 1e-6
    hm2, rep2 = scan_to_heightmap(pts, pitch=0.25, fill_holes=False)
    X2, Y2 = np.meshgrid(hm2.x, hm2.y)
    ex2, ey2, _ = (np.array(a) for a in rep2.axes)
    q2 = (np.array(rep2.origin) + X2[..., None] * ex2 + Y2[..., None] * ey2 - t) @ R
    assert np.hypot(q2[..., 0] - 12, q2[..., 1] - 12).min() > 1.5  # the crop avoided the hole
    assert hm2.heights.size < hm.heights.size


def test_form_removal_takes_out_a_bow():
    rng = np.random.default_rng(2)
    xy = rng.uniform(0, 24, (40_000, 2))
    bow = 0.004 * ((xy[:, 0] - 12) ** 2 + (xy[:, 1] - 12) ** 2)  # 1.15 mm at the corners
    z = relief(xy[:, 0], xy[:, 1]) + bow + rng.normal(0, SIGMA, len(xy))
    pts = np.column_stack([xy, z])
    flat, rep2 = scan_to_heightmap(pts, pitch=0.3, form_degree=2)
    X, Y = np.meshgrid(flat.x, flat.y)
    o, (ex, ey, _) = np.array(rep2.origin), (np.array(a) for a in rep2.axes)
    q = o + X[..., None] * ex + Y[..., None] * ey
    d = flat.heights - relief(q[..., 0], q[..., 1])
    d -= d.mean()
    assert np.sqrt(np.mean(d**2)) < 3 * SIGMA
    curved, _ = scan_to_heightmap(pts, pitch=0.3, form_degree=1)
    assert curved.max_height > flat.max_height + 0.5
    level, rep0 = scan_to_heightmap(pts, pitch=0.3, form_degree=0)
    assert rep0.plane_tilt == 0.0 and rep0.axes == ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def test_fit_plane_ignores_outliers():
    rng = np.random.default_rng(0)
    xy = rng.uniform(-10, 10, (5000, 2))
    z = 0.1 * xy[:, 0] - 0.05 * xy[:, 1] + 2 + rng.normal(0, 0.01, 5000)
    z[:1000] += rng.uniform(5, 50, 1000)  # 20 % gross outliers, all on one side
    c, n = fit_plane(np.column_stack([xy, z]))
    expected = np.array([-0.1, 0.05, 1.0]) / np.linalg.norm([-0.1, 0.05, 1.0])
    assert np.degrees(np.arccos(min(1.0, n @ expected))) < 0.05
    assert abs(c[2] - (0.1 * c[0] - 0.05 * c[1] + 2)) < 0.01


def test_largest_rectangle_matches_brute_force():
    rng = np.random.default_rng(1)
    for _ in range(40):
        m = rng.random((rng.integers(1, 8), rng.integers(1, 8))) > rng.uniform(0.1, 0.6)
        best = 0
        for r0, r1 in itertools.combinations(range(m.shape[0] + 1), 2):
            for c0, c1 in itertools.combinations(range(m.shape[1] + 1), 2):
                if m[r0:r1, c0:c1].all():
                    best = max(best, (r1 - r0) * (c1 - c0))
        box = largest_rectangle(m)
        if best == 0:
            assert box is None
            continue
        r0, r1, c0, c1 = box
        assert m[r0:r1, c0:c1].all() and (r1 - r0) * (c1 - c0) == best


# -- readers ---------------------------------------------------------------------------
@pytest.fixture
def cloud():
    rng = np.random.default_rng(4)
    xy = rng.uniform(0, 12, (6000, 2))
    return np.column_stack([xy, relief(xy[:, 0], xy[:, 1])])


def _write_pcd(path, pts):
    head = (
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
        f"WIDTH {len(pts)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(pts)}\nDATA ascii\n"
    )
    body = np.column_stack([pts, np.ones(len(pts))])
    with open(path, "w") as fh:
        fh.write(head)
        np.savetxt(fh, body, fmt="%.9g")


@pytest.mark.parametrize("fmt", ["ply_ascii", "ply_binary", "xyz", "csv", "txt", "pcd"])
def test_point_cloud_readers(tmp_path, cloud, fmt):
    if fmt.startswith("ply"):
        path = tmp_path / "c.ply"
        trimesh.PointCloud(cloud).export(path, encoding="ascii" if fmt == "ply_ascii" else "binary")
    elif fmt == "xyz":
        path = tmp_path / "c.xyz"
        np.savetxt(path, cloud, fmt="%.9g")
    elif fmt == "csv":  # header, commas, extra columns (normals)
        path = tmp_path / "c.csv"
        np.savetxt(path, np.column_stack([cloud, np.zeros_like(cloud)]), fmt="%.9g", delimiter=",", header="x,y,z,nx,ny,nz", comments="")
    elif fmt == "txt":  # tabs and a comment
        path = tmp_path / "c.txt"
        np.savetxt(path, cloud, fmt="%.9g", delimiter="\t", header="exported by a scanner")
    else:
        path = tmp_path / "c.pcd"
        _write_pcd(path, cloud)
    data = read_scan(path)
    assert data.faces is None and data.kind == "points"
    assert np.allclose(data.points, cloud, atol=1e-5)
    hm, rep = scan_to_heightmap(path, pitch=0.3)
    assert rep.kind == "points" and rep.source == str(path) and hm.shape[0] > 30
    assert texcad.sources.scan_to_heightmap(path, pitch=0.3)[0].heights.tobytes() == hm.heights.tobytes()


def _surface_mesh(n=61, size=12.0):
    from texcad.solid import grid_faces

    xs = np.linspace(0, size, n)
    X, Y = np.meshgrid(xs, xs)
    V = np.column_stack([X.ravel(), Y.ravel(), relief(X, Y).ravel()])
    return trimesh.Trimesh(V, grid_faces(n, n).astype(np.int64), process=False)


@pytest.mark.parametrize("ext", ["stl", "obj", "ply"])
def test_mesh_readers_and_top_surface(tmp_path, ext):
    mesh = _surface_mesh()
    path = tmp_path / f"m.{ext}"
    mesh.export(path)
    data = read_scan(path)
    assert data.kind == "mesh" and len(data.faces) == len(mesh.faces)
    hm, rep = scan_to_heightmap(path, pitch=0.2, form_degree=0, base_percentile=0)
    # Unlevelled, pixel centres fall on the mesh's vertices: the heights are the
    # relief exactly (up to float32 files and the base shift).
    truth = relief(*np.meshgrid(hm.x - 0.1, hm.y - 0.1))
    assert hm.shape == (61, 61) and rep.coverage == 1.0 and rep.outliers_dropped == 0
    assert np.abs(hm.heights - (truth - truth.min()) - np.median(hm.heights - (truth - truth.min()))).max() < 1e-4


def test_closed_mesh_gives_its_top_surface(tmp_path):
    hm0 = texcad.builtin("pins", size=9, pitch=0.2, height=1.0)
    slab = texcad.solid.heightfield_slab(hm0, depth=2.0)
    texcad.io.write_stl(slab, tmp_path / "slab.stl")
    hm, rep = scan_to_heightmap(tmp_path / "slab.stl", pitch=0.2)
    assert hm.shape == hm0.shape
    assert np.abs(hm.heights - hm0.heights).max() < 1e-4
    assert rep.noise_rms < 1e-4 and rep.plane_tilt < 1e-3
    # Mesh objects work directly too.
    hm2, _ = scan_to_heightmap(slab, pitch=0.2)
    assert np.abs(hm2.heights - hm0.heights).max() < 1e-4


# -- bad input -------------------------------------------------------------------------
def _bad_inputs(tmp_path):
    rng = np.random.default_rng(0)
    (tmp_path / "empty.ply").write_bytes(b"")
    (tmp_path / "empty.xyz").write_bytes(b"")
    (tmp_path / "header.csv").write_text("x,y,z\n")
    (tmp_path / "junk.ply").write_text("not a ply\n")
    trimesh.Trimesh([[0, 0, 0], [1, 1, 1], [2, 2, 2]], [[0, 1, 2]], process=False).export(tmp_path / "line.stl")
    t = rng.uniform(0, 10, 200)
    return [
        (tmp_path / "empty.ply", "empty"),
        (tmp_path / "empty.xyz", "empty"),
        (tmp_path / "header.csv", "no numeric"),
        (tmp_path / "junk.ply", "cannot read"),
        (tmp_path / "line.stl", "no area"),
        (tmp_path / "missing.ply", "does not exist"),
        (tmp_path / "scan.dxf", "does not exist"),
        (np.full((100, 3), np.nan), "no finite points"),
        (np.column_stack([t, 2 * t, 3 * t]), "one line"),
        (np.ones((50, 3)), "coincide"),
        (rng.uniform(0, 30, (60, 3)), r"too sparse.*use pitch >="),
        (np.column_stack([rng.uniform(0, 30, (4000, 2)), np.zeros(4000)]), r"fewer than this grid needs; use pitch >="),
    ]


def test_bad_scans_raise_clear_errors_and_write_nothing(tmp_path):
    out = tmp_path / "out.png"
    for scan, message in _bad_inputs(tmp_path):
        with pytest.raises(InputError, match=message):
            hm, _ = scan_to_heightmap(scan, pitch=0.1)
            hm.to_png(out)
        assert not out.exists()
    (tmp_path / "scan.dxf").write_text("0\nSECTION\n")
    with pytest.raises(InputError, match="unknown format '.dxf'"):
        read_scan(tmp_path / "scan.dxf")


@pytest.mark.parametrize(
    "kw",
    [{"pitch": 0}, {"pitch": -1}, {"pitch": 1, "form_degree": 7}, {"pitch": 1, "form_degree": 1.5}, {"pitch": 1, "outlier_sigma": 0}, {"pitch": 1, "base_percentile": 60}, {"pitch": 1, "min_coverage": 0}],
)
def test_bad_parameters(kw):
    with pytest.raises(ParameterError):
        scan_to_heightmap(np.random.default_rng(0).random((100, 3)), **kw)


def test_bad_array_shape():
    with pytest.raises(ParameterError, match=r"\(N, 3\)"):
        scan_to_heightmap(np.ones((10, 2)), pitch=1)
    assert ScanData(np.ones((3, 3))).kind == "points"


def test_scan_to_png_writes_heightmap_and_preview(tmp_path):
    rng = np.random.default_rng(9)
    pts, *_ = synthetic_scan(rng, n=20_000, outliers=0.01)
    np.savetxt(tmp_path / "s.xyz", pts, fmt="%.6f")
    hm, rep = texcad.pipeline.scan_to_png(tmp_path / "s.xyz", tmp_path / "h.png", pitch=0.4, preview=tmp_path / "p.png")
    back = Heightmap.from_image(tmp_path / "h.png", pitch=0.4, height=rep.max_height)
    assert np.abs(back.heights - hm.heights).max() <= rep.max_height / 65535 + 1e-6
    assert (tmp_path / "p.png").stat().st_size > 0
    # A bad scan or a missing folder: nothing is written.
    with pytest.raises(InputError):
        texcad.pipeline.scan_to_png(np.ones((9, 3)), tmp_path / "x.png", pitch=0.4, preview=tmp_path / "xp.png")
    with pytest.raises(InputError, match="does not exist"):
        texcad.pipeline.scan_to_png(tmp_path / "s.xyz", tmp_path / "x.png", pitch=0.4, preview=tmp_path / "no" / "xp.png")
    assert not (tmp_path / "x.png").exists() and not (tmp_path / "xp.png").exists()


def test_nan_points_are_dropped_and_counted(tmp_path):
    rng = np.random.default_rng(12)
    pts, *_ = synthetic_scan(rng, n=20_000, outliers=0.0)
    pts[:300, 2] = np.nan
    pts[300:310, 0] = np.inf
    np.savetxt(tmp_path / "nan.xyz", pts, fmt="%.6f")
    hm, rep = scan_to_heightmap(tmp_path / "nan.xyz", pitch=0.4)
    assert rep.nonfinite_dropped == 310 and np.isfinite(hm.heights).all()
