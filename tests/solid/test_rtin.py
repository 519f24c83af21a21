"""Lean triangulation of mapped grids (texcad.solid.rtin): conforming, exact tiling
of the cells, and the error bound checked against an independent distance."""

import numpy as np
import pytest
from conftest import distance_to_mesh
from hypothesis import given, settings
from hypothesis import strategies as st

from texcad.solid import grid_error, lean_grid
from texcad.solid.rtin import _stencil


def cylinder_grid(R=180, C=240, radius=12.0, pitch=0.125, amp=0.3, seed=0):
    r, c = np.meshgrid(np.arange(R) * pitch, np.arange(C) * pitch, indexing="ij")
    th = c / radius
    rng = np.random.default_rng(seed)
    bumps = sum(rng.uniform(0.2, 1) * np.sin(2 * np.pi * (c * fx + r * fy) / 6 + ph)
                for fx, fy, ph in rng.uniform(0, 1, (3, 3)))
    h = amp * (1.5 + bumps / 3)
    P = np.stack([radius * np.sin(th), r, radius * np.cos(th)], -1)
    N = np.stack([np.sin(th), 0 * r, np.cos(th)], -1)
    return P, N, h


def edges(faces):
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    return e


def assert_conforming(out, cells):
    rc, f = out["rc"], out["faces"]
    a, b = rc[f[:, 1]] - rc[f[:, 0]], rc[f[:, 2]] - rc[f[:, 0]]
    cross = a[:, 1] * b[:, 0] - a[:, 0] * b[:, 1]
    assert (cross > 0).all()  # one winding
    assert cross.sum() / 2 == cells.sum()  # the triangles tile exactly the cells' area
    e = edges(f)
    directed = e[:, 0] * len(rc) + e[:, 1]
    assert len(np.unique(directed)) == len(directed)  # no edge twice the same way
    und = np.sort(e, axis=1)
    _, count = np.unique(und[:, 0] * len(rc) + und[:, 1], return_counts=True)
    assert count.max() == 2
    # Every boundary edge lies on the outline of the cells (no T-junction inside).
    single = np.unique(und[:, 0] * len(rc) + und[:, 1], return_counts=True)
    key1 = single[0][single[1] == 1]
    i, j = key1 // len(rc), key1 % len(rc)
    mid = (rc[i] + rc[j]) / 2.0
    R, C = cells.shape
    pad = np.zeros((R + 2, C + 2), bool)
    pad[1:-1, 1:-1] = cells
    # The midpoint of a boundary edge has an outside cell on one side.
    horiz = rc[i, 0] == rc[j, 0]
    r0, c0 = mid[:, 0], mid[:, 1]
    side_a = np.where(horiz, pad[(r0).astype(int), np.floor(c0).astype(int) + 1], pad[np.floor(r0).astype(int) + 1, (c0).astype(int)])
    side_b = np.where(horiz, pad[(r0).astype(int) + 1, np.floor(c0).astype(int) + 1], pad[np.floor(r0).astype(int) + 1, (c0).astype(int) + 1])
    assert (side_a != side_b).all()


def test_lean_cylinder_is_conforming_and_within_tolerance():
    P, N, h = cylinder_grid()
    cells = np.ones((P.shape[0] - 1, P.shape[1] - 1), bool)
    cells[:20] = False
    cells[70:110, 90:150] = False  # a hole
    out = lean_grid(P, N, [h], cells, 0.02)
    assert out is not None and out["error"] <= 0.02
    assert len(out["faces"]) < 0.5 * 2 * cells.sum()
    assert_conforming(out, cells)
    # Independent: 3-D distance from every covered exact point to the lean mesh.
    V = P + h[..., None] * N
    rc = out["rc"]
    need = np.zeros(h.shape, bool)
    for dr in (0, 1):
        for dc in (0, 1):
            need[dr : dr + cells.shape[0], dc : dc + cells.shape[1]] |= cells
    dist = distance_to_mesh(V[need], V[rc[:, 0], rc[:, 1]], out["faces"])
    assert 0.005 < dist.max() <= 0.02 + 1e-9


def test_face_sag_counts_in_the_error():
    """A flat relief on a tight cylinder: the chord error alone forces small triangles."""
    for radius, tol in ((4.0, 0.005), (40.0, 0.005)):
        P, N, h = cylinder_grid(R=64, C=256, radius=radius, amp=0.0)
        h = np.zeros_like(h)
        cells = np.ones((63, 255), bool)
        out = lean_grid(P, N, [h], cells, tol, max_fraction=1.0)
        assert out["error"] <= tol
        rc = out["rc"]
        f = out["faces"]
        span = np.abs(rc[f[:, 0], 1] - rc[f[:, 1], 1]).max() * 0.125  # mm along the arc
        assert span <= np.sqrt(8 * radius * tol) * 2.0 + 0.25  # the sag (L/2)^2 / 2R stays below tol


def test_fine_cells_stay_at_grid_resolution():
    P, N, h = cylinder_grid(R=100, C=100, amp=0.0)
    h = np.zeros_like(h)
    cells = np.ones((99, 99), bool)
    fine = np.zeros_like(cells)
    fine[40:50, 40:50] = True
    out = lean_grid(P, N, [h], cells, 0.05, fine=fine, max_fraction=1.0)
    rc = out["rc"]
    inside = (rc[:, 0] >= 40) & (rc[:, 0] <= 50) & (rc[:, 1] >= 40) & (rc[:, 1] <= 50)
    assert inside.sum() == 11 * 11  # every grid point of the fine block is a vertex


def test_weights_and_measure_flag():
    P, N, h = cylinder_grid(R=120, C=120)
    cells = np.ones((119, 119), bool)
    a = lean_grid(P, N, [h, 0 * h], cells, 0.02, weights=[1.0, 1.0], max_fraction=1.0)
    b = lean_grid(P, N, [h, 0 * h], cells, 0.02, weights=[1.0, 4.0], max_fraction=1.0)
    assert len(b["faces"]) > len(a["faces"])  # the face itself 4x stricter: more triangles
    c = lean_grid(P, N, [h], cells, 0.02, measure=False, max_fraction=1.0)
    assert np.isnan(c["error"])


def test_too_detailed_returns_none():
    rng = np.random.default_rng(1)
    P, N, _ = cylinder_grid(R=80, C=80)
    noise = rng.uniform(0, 1, P.shape[:2])
    assert lean_grid(P, N, [noise], np.ones((79, 79), bool), 0.01) is None


def test_stencil_weights():
    rr, cc, lam = _stencil(np.array([4, 0]), np.array([0, 4]))
    q = lam[:, 0:1] * np.array([4, 0]) + lam[:, 1:2] * np.array([0, 4])
    assert np.allclose(q, np.stack([rr, cc], 1))
    assert ((lam >= -1e-12) & (lam <= 1 + 1e-12)).all()
    assert len(rr) == 15 - 3  # 15 grid points in the triangle, its 3 vertices excluded


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 10_000), st.floats(3.0, 60.0), st.floats(0.005, 0.05))
def test_random_masks_and_surfaces(seed, radius, tol):
    rng = np.random.default_rng(seed)
    R, C = rng.integers(20, 140, 2)
    P, N, h = cylinder_grid(R=int(R), C=int(C), radius=radius, seed=seed)
    cells = rng.uniform(size=(R - 1, C - 1)) > 0.02  # scattered holes
    cells[: rng.integers(0, R // 3)] = False
    out = lean_grid(P, N, [h], cells, tol, max_fraction=1.0)
    assert out is not None and out["error"] <= tol
    assert_conforming(out, cells)
    rc = out["rc"]
    worst, _ = grid_error({"P": P, "N": N, "h": [h], "V": [P + h[..., None] * N], "w": [1.0]},
                          rc[:, 0][out["faces"]] * C + rc[:, 1][out["faces"]])
    assert worst == pytest.approx(out["error"], abs=1e-12)
