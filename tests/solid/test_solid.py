import numpy as np
import pytest

import texcad
from texcad import GeometryError, ParameterError
from texcad.solid import fuse, heightfield_slab
from texcad.brep import shape_to_mesh


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
    part = fuse(shape_to_mesh(base), slab)  # texcad.solid takes meshes: the CAD part tessellated first
    assert part.is_watertight
    man = texcad.solid.to_manifold(part)
    assert len(man.decompose()) == 1
    # Union volume = base + slab - the part of the slab inside the base.
    rows, cols = small_hm.shape
    inside = (cols - 1) * small_hm.pitch[0] * (rows - 1) * small_hm.pitch[1] * 0.5
    assert np.isclose(part.volume, w * d * 3 + slab.volume - inside, rtol=1e-6)


def test_fuse_rejects_open_meshes():
    open_mesh = texcad.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]))
    with pytest.raises(GeometryError, match="closed"):
        fuse(open_mesh)


def test_fuse_is_a_manifold3d_union_whatever_the_wall_layout(small_hm):
    """Polygon walls (few edges through the plate's face) and bottom-ring walls describe
    the same slab: the union has the same volume, checked independently by trimesh."""
    import trimesh

    from texcad.solid.mesh import _ring_walls_slab, grid_faces

    w, d = small_hm.size
    base = shape_to_mesh(texcad.pipeline.plate_base((w, d), 3))
    slab = heightfield_slab(small_hm, depth=0.5)
    rows, cols = small_hm.shape
    n = rows * cols
    ring_slab = _ring_walls_slab(slab.vertices[:n], rows, cols, np.float32(-0.5), grid_faces(rows, cols), {})
    assert len(ring_slab.vertices) > len(slab.vertices) and np.isclose(ring_slab.volume, slab.volume, rtol=1e-9)
    vols = []
    for s in (slab, ring_slab):
        part = fuse(base, s)
        tm = trimesh.Trimesh(part.vertices, part.faces, process=False)
        assert tm.is_watertight and tm.is_winding_consistent and len(tm.split(only_watertight=False)) == 1
        assert np.isclose(tm.volume, part.volume, rtol=1e-9)
        vols.append(part.volume)
        # Nothing of the slab is left inside the plate, nothing of the plate's top face
        # inside the slab's footprint.
        z = part.vertices[:, 2]
        assert z.min() == pytest.approx(-3.0) and not np.any((z < -1e-6) & (z > -3 + 1e-6))
    assert np.isclose(vols[0], vols[1], rtol=1e-7)
    inside = (cols - 1) * small_hm.pitch[0] * (rows - 1) * small_hm.pitch[1] * 0.5
    assert np.isclose(vols[0], w * d * 3 + slab.volume - inside, rtol=1e-6)


def test_fuse_is_deterministic(small_hm):
    base = shape_to_mesh(texcad.pipeline.plate_base(small_hm.size, 3))
    a = fuse(base, heightfield_slab(small_hm, depth=0.5))
    b = fuse(base, heightfield_slab(small_hm, depth=0.5))
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


def test_retain_freed_memory_keeps_fuse_exact(small_hm):
    """The allocator setting changes where memory comes from, not the result (run in a
    fresh process: the setting is process-wide)."""
    import subprocess
    import sys

    code = (
        "import sys, numpy as np, texcad\n"
        "from texcad.solid import retain_freed_memory\n"
        "tuned = retain_freed_memory()\n"
        "hm = texcad.builtin('stones', size=(30, 20), pitch=0.5, height=1.5)\n"
        "part = texcad.solid.fuse(texcad.brep.shape_to_mesh(texcad.pipeline.plate_base(hm.size, 3)), texcad.solid.heightfield_slab(hm, depth=0.5))\n"
        "print(tuned, repr(part.volume), part.num_triangles)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout.split()
    base = shape_to_mesh(texcad.pipeline.plate_base(small_hm.size, 3))
    here = fuse(base, heightfield_slab(small_hm, depth=0.5))
    assert out[0] == ("True" if sys.platform.startswith("linux") else out[0])
    assert float(out[1]) == here.volume and int(out[2]) == here.num_triangles
