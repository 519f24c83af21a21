import numpy as np
import pytest

import texcad
from texcad import GeometryError, ParameterError, fuse, heightfield_slab, shape_to_mesh


def test_shape_to_mesh_build123d_and_cadquery():
    import cadquery as cq
    from build123d import Cylinder

    cyl = shape_to_mesh(Cylinder(10, 20), tolerance=0.01)
    assert cyl.is_watertight
    assert abs(cyl.volume - np.pi * 100 * 20) / (np.pi * 100 * 20) < 2e-3
    box = shape_to_mesh(cq.Workplane("XY").box(10, 20, 30))
    assert box.is_watertight and np.isclose(box.volume, 6000)
    with pytest.raises(ParameterError, match="base body"):
        shape_to_mesh("not a shape")


@pytest.mark.parametrize("kernel", ["build123d", "cadquery"])
def test_fuse_texture_onto_plate_is_one_watertight_shell(kernel, small_hm):
    w, d = small_hm.size
    if kernel == "build123d":
        from build123d import Align, Box

        base = Box(w, d, 3, align=(Align.MIN, Align.MIN, Align.MAX))
    else:
        import cadquery as cq

        base = cq.Workplane("XY").box(w, d, 3, centered=(False, False, False)).translate((0, 0, -3))
    slab = heightfield_slab(small_hm, depth=0.5)
    part = fuse(base, slab)
    assert part.is_watertight
    man = texcad.to_manifold(part)
    assert len(man.decompose()) == 1
    # Union volume = base + slab - the part of the slab inside the base.
    rows, cols = small_hm.shape
    inside = (cols - 1) * small_hm.pitch[0] * (rows - 1) * small_hm.pitch[1] * 0.5
    assert np.isclose(part.volume, w * d * 3 + slab.volume - inside, rtol=1e-6)


def test_fuse_rejects_open_meshes():
    open_mesh = texcad.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]))
    with pytest.raises(GeometryError, match="closed"):
        fuse(open_mesh)
