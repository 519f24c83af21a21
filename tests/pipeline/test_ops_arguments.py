"""What CAD operations take (texcad.pipeline.ops): mesh tools (trimesh, manifold3d),
mirror planes as numbers, axis words or a build123d Plane, and what they refuse."""

import manifold3d as m3d
import numpy as np
import pytest
import trimesh

import texcad


@pytest.fixture(scope="module")
def tx():
    from build123d import Box

    return texcad.texture(Box(20, 20, 6), "top", "builtin:stones", height=0.4, pitch=0.5)


def test_mesh_tools_cut_the_mesh_and_say_why_there_is_no_brep(tx):
    """A trimesh or manifold3d cylinder cuts as the same cylinder given as a texcad
    Mesh; the result's B-rep is refused naming the mesh tool."""
    cyl = trimesh.creation.cylinder(2.0, 20.0, sections=32)
    by_trimesh = tx - cyl
    by_mesh = tx - texcad.Mesh(cyl.vertices, cyl.faces)
    by_manifold = tx - m3d.Manifold(m3d.Mesh(vert_properties=np.asarray(cyl.vertices, np.float32),
                                             tri_verts=np.asarray(cyl.faces, np.uint32)))
    assert by_trimesh.volume == by_mesh.volume == pytest.approx(by_manifold.volume, rel=1e-9)
    assert tx.volume - by_trimesh.volume > 0.9 * np.pi * 4 * 6  # the hole went through
    with pytest.raises(texcad.GeometryError, match="mesh tool"):
        by_trimesh.shape
    with pytest.raises(texcad.ParameterError, match="as a tool"):
        tx - "hole"


def test_mirror_planes(tx):
    """``mirrored`` takes an origin and a normal (numbers, a Vector, an axis word) or a
    build123d Plane; the same plane gives the same mesh. A word as the origin, or two
    numbers as the normal, is a ParameterError."""
    from build123d import Plane, Vector

    a = tx.mirrored((20, 0, 0), (1, 0, 0))
    assert np.array_equal(a.mesh.vertices, tx.mirrored(Plane.YZ.offset(20)).mesh.vertices)
    assert np.array_equal(a.mesh.vertices, tx.mirrored(Vector(20, 0, 0), "+x").mesh.vertices)
    assert a.mesh.vertices[:, 0].min() == pytest.approx(30.0)
    with pytest.raises(texcad.ParameterError, match="origin"):
        tx.mirrored("x")
    with pytest.raises(texcad.ParameterError, match="normal"):
        tx.mirrored((0, 0, 0), (0, 0))


def test_a_texture_edge_cannot_be_filleted_and_says_so(tx):
    from build123d import Axis

    top = tx.part.edges().sort_by(Axis.Z)[-1:]  # an edge of the relief's tiles
    with pytest.raises(texcad.ParameterError, match="edge of the texture"):
        tx.fillet(top, 1.0)
