"""The gate's check of a centred texture (issue 28): its net volume is about 0 by
design, so the volume check (the change against the texture's integral) passes a
relief the union lost; the displaced volume ``int |t| dA``, above and below the
surface alike, is checked against what the mesh's surface encloses with the part's."""

from __future__ import annotations

import manifold3d as m3d
import numpy as np
import pytest

import texcad
from texcad.errors import GeometryError, TexcadWarning
from texcad.report.gate import Displaced, Expectation, displaced_volume, gate, linear_abs_integral
from texcad.solid import Mesh


def _mesh(man) -> Mesh:
    m = man.to_mesh()
    return Mesh(np.array(m.vert_properties[:, :3], np.float32), np.array(m.tri_verts, np.int64))


BOX = m3d.Manifold.cube((10, 10, 10))


def _boss(h: float) -> Mesh:
    """The box with a 6 x 6 mm boss ``h`` mm high on its top (a pocket for h < 0)."""
    step = m3d.Manifold.cube((6, 6, abs(h))).translate((2, 2, 10 if h > 0 else 10 + h))
    return _mesh(BOX + step if h > 0 else BOX - step)


def test_linear_abs_integral_is_exact():
    """Against a fine sampling of random linear functions on random triangles (the
    barycentric midpoint rule on 4^6 sub-triangles)."""
    rng = np.random.default_rng(3)
    vals, areas = rng.normal(size=(200, 3)), rng.uniform(0.5, 2.0, 200)
    n = 64
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up = (i + j) < n  # sub-triangle centroids of the n x n split: up and down ones
    b = np.concatenate([np.stack([i[up] + 1 / 3, j[up] + 1 / 3], 1), np.stack([i[(i + j) < n - 1] + 2 / 3, j[(i + j) < n - 1] + 2 / 3], 1)]) / n
    w = np.stack([b[:, 0], b[:, 1], 1 - b.sum(1)], 1)
    sampled = float((np.abs(vals @ w.T).mean(axis=1) * areas).sum())
    assert linear_abs_integral(vals, areas) == pytest.approx(sampled, rel=2e-3)
    assert linear_abs_integral(np.array([[1.0, 1.0, 1.0], [-2.0, -2.0, -2.0], [-1.0, 0.0, 0.0]]), np.ones(3)) == pytest.approx(3 + 1 / 3)


def test_displaced_volume_above_and_below_alike():
    base = _mesh(BOX)
    assert displaced_volume(_boss(1.0), base, 3.0) == pytest.approx(36.0, rel=1e-6)
    assert displaced_volume(_boss(-1.0), base, 3.0) == pytest.approx(36.0, rel=1e-6)
    assert displaced_volume(base, base, 3.0) == pytest.approx(0.0, abs=1e-9)


def test_crafted_lost_doubled_and_limited_centred_reliefs():
    base = _mesh(BOX)
    ex = Expectation(bodies=1, base=base, volume=0.0, volume_slack=100.0, height=1.0, displaced=Displaced(36.0, 36.0, 0.5))
    assert gate(_boss(1.0), ex).displaced_mm3 == pytest.approx(36.0)
    with pytest.raises(GeometryError, match=r"off the part's by 0.00 mm3 .* displaces 36.00 mm3"):
        gate(base, ex)  # lost: the volume check alone passes it (0 within 100 of 0)
    with pytest.raises(GeometryError, match=r"by 72.00 mm3 .*lost or doubled"):
        gate(_boss(2.0), ex)
    limited = Expectation(bodies=1, base=base, height=1.0, displaced=Displaced(36.0, 36.0, 0.5, nominal=360.0))
    with pytest.warns(TexcadWarning, match=r"removed 90 % of the centred texture"):
        gate(_boss(1.0), limited)


def _top():
    from build123d import Axis, Box

    part = Box(20, 20, 4)
    return part, part.faces().sort_by(Axis.Z)[-1]


def test_a_centred_result_carries_its_displaced_figures():
    part, top = _top()
    tx = texcad.texture(part, top, "builtin:diamond_knurl", height=0.4, pitch=0.5, mode="centred")
    g = tx.gate
    assert g.expected_displaced_mm3 > 20.0  # 0.09 mm a mean over 342 mm2
    assert g.displaced_mm3 == pytest.approx(g.expected_displaced_mm3, rel=0.02)
    assert abs(g.expected_volume) < g.volume_slack  # the net: the volume check alone cannot tell it from nothing


def test_a_union_that_loses_a_centred_relief_is_refused(monkeypatch):
    """A crafted fault: the fuse hands back the bare part. Its volume change (0)
    is within the volume check's slack of the centred texture's net integral; the
    displaced volume is not."""
    import texcad.targets.faces as faces

    part, top = _top()
    monkeypatch.setattr(faces, "union_patches", lambda base_man, reliefs: base_man)
    with pytest.raises(GeometryError, match=r"off the part's by 0.00 mm3.*where the texture displaces"):
        texcad.texture(part, top, "builtin:stones", height=0.4, pitch=0.5, mode="centred")


def test_a_centred_texture_the_ramps_removed_warns_with_the_figures():
    """A centred diamond knurl on a ring r 6 mm x 2.5 mm: the M-I ramps along both
    edges leave only the outline band's floor. Its net volume says nothing (about
    0 either way); what it displaces against the texture as sampled does: a
    TexcadWarning with the figures, and the mesh agrees with what is left."""
    from build123d import Cylinder, GeomType

    part = Cylinder(6, 2.5) - Cylinder(4, 2.5)
    face = [f for f in part.faces() if f.geom_type == GeomType.CYLINDER and f.radius > 5][0]
    with pytest.warns(TexcadWarning, match=r"the limits removed \d+ % of the centred texture"):
        tx = texcad.texture(part, face, "builtin:diamond_knurl", pitch=0.25, height=1.0, mode="centred")
    g = tx.gate
    assert g.displaced_mm3 == pytest.approx(g.expected_displaced_mm3, rel=0.25)
