"""The part's tessellation (:func:`texcad.brep.part_tessellation`): closed, and each
face's triangles where ``texcad faces`` says that face is, whichever healing step
made it (a face split into pieces, faces sewn)."""

from __future__ import annotations

import numpy as np
import pytest
from build123d import Box, Cone, Cylinder, Pos, fillet

from texcad.brep import explore, part_tessellation, tessellation
from texcad.errors import GeometryError


def _part():
    """Curved faces of several kinds (cylinder, cone, torus-like fillet) and planes."""
    body = Cylinder(10, 8) + Pos(0, 0, 6) * Cone(8, 4, 4)
    body = fillet(body.edges().sort_by()[0:1], 1.0) + Pos(15, 0, 0) * Box(8, 8, 8)
    return body.solids()[0] if len(body.solids()) == 1 else body


def _forced(monkeypatch, step: str):
    """Make every healing attempt before ``step`` fail its closed check, so the
    tessellation comes from ``step`` ("split": faces cut into pieces of at most 90
    degrees; "sew": faces sewn)."""
    real = tessellation.to_manifold
    order = {"split": 4, "sew": 5}[step]
    calls = {"n": 0}

    def failing(mesh):
        calls["n"] += 1
        if calls["n"] <= order:
            raise GeometryError("forced: try the next healing step")
        return real(mesh)

    monkeypatch.setattr(tessellation, "to_manifold", failing)
    return calls


@pytest.mark.parametrize("step", ["split", "sew"])
def test_healed_tessellation_keeps_the_part_face_numbers(step, monkeypatch):
    """Made by a healing step, ``faces[k]`` is still the part's own face ``k`` and
    the triangles marked ``k`` cover that face: their area is the face's own
    (OCCT, within the chord error), and the whole is closed."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_FACE

    part = _part()
    calls = _forced(monkeypatch, step)
    pm = part_tessellation(part.wrapped)
    assert calls["n"] == {"split": 5, "sew": 6}[step]  # it was this step that made it
    own = list(explore(part.wrapped, TopAbs_FACE))
    assert len(pm.faces) == len(own)
    v = pm.mesh.vertices.astype(np.float64)[pm.mesh.faces]
    area = 0.5 * np.linalg.norm(np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]), axis=1)
    for k, face in enumerate(own):  # a dozen faces
        assert pm.faces[k].face.IsSame(face)
        props = GProp_GProps()
        BRepGProp.SurfaceProperties_s(face, props)
        mine = float(area[pm.face_of_tri == k].sum())
        assert mine == pytest.approx(props.Mass(), rel=2e-3), (k, pm.faces[k].kind)
    f = pm.mesh.faces.astype(np.int64)
    key = np.sort(np.stack([f.reshape(-1), f[:, [1, 2, 0]].reshape(-1)], 1), axis=1)
    assert (np.unique(key, axis=0, return_counts=True)[1] == 2).all()  # closed: every edge twice


def test_split_pieces_come_back_to_their_face():
    """Splitting cuts the cylinder and the cone into pieces (more faces than the
    part's); each piece is mapped to the face it came from."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopoDS import TopoDS

    part = _part()
    own = [TopoDS.Face_s(f) for f in explore(part.wrapped, TopAbs_FACE)]
    shape, whose = tessellation._split(part.wrapped, own)
    assert len(whose) > len(own) and min(whose) == 0 and sorted(set(whose)) == list(range(len(own)))


def _box_with_an_open_face():
    """A 10 mm box whose top face carries a triangulation of one triangle (as a
    file's own mesh can be), marked finer than any chord asked for, so that OCCT's
    mesher keeps it: the box meshes open."""
    from OCP.BRep import BRep_Builder
    from OCP.gp import gp_Pnt
    from OCP.Poly import Poly_Triangle, Poly_Triangulation

    box = Box(10, 10, 10)
    top = box.faces().sort_by()[-1]
    tri = Poly_Triangulation(3, 1, False)
    for i, (x, y) in enumerate(((-5, -5), (5, -5), (5, 5))):
        tri.SetNode(i + 1, gp_Pnt(x, y, 5))
    tri.SetTriangle(1, Poly_Triangle(1, 2, 3))
    tri.Deflection(1e-9)
    BRep_Builder().UpdateFace(top.wrapped, tri)
    return box


def test_closed_shape_mesh_heals_an_open_tessellation():
    """A shape OCCT's mesher leaves open (a face of a real STEP file meshed as a
    few triangles) is tessellated again the way texcad tessellates parts: closed,
    with the box's volume; a closed shape keeps OCCT's first mesh."""
    from texcad.brep import closed_shape_mesh, shape_to_mesh

    box = _box_with_an_open_face()
    assert not shape_to_mesh(box).is_watertight
    healed = closed_shape_mesh(box)
    assert healed.is_watertight and healed.volume == pytest.approx(1000.0, rel=1e-9)
    whole = Box(10, 10, 10)
    assert np.array_equal(closed_shape_mesh(whole).faces, shape_to_mesh(whole).faces)


def test_bulk_read_of_occt_triangles_matches_node_by_node():
    """shape_to_mesh reads OCCT's triangles through its STL writer: the same
    triangles, corner for corner (float32), as OCP's node-by-node access."""
    import numpy as np
    from build123d import Box, Cylinder

    from texcad.brep import shape_to_mesh
    from texcad.brep.tessellation import _node_corners, _stl_corners

    part = Box(20, 20, 8) - Cylinder(4, 10)
    shape_to_mesh(part, tolerance=0.01)  # meshes the faces
    (a, fa), (b, fb) = _stl_corners(part.wrapped), _node_corners(part.wrapped)
    assert len(fa) == len(fb) > 0
    ta, tb = a[fa].astype(np.float32).astype(np.float64), b[fb].astype(np.float32).astype(np.float64)

    def canon(t):  # each triangle's corners in order, the triangles sorted: the same set
        rows = np.sort(t.reshape(len(t), 3, 3).view([("x", "f8"), ("y", "f8"), ("z", "f8")]).ravel().reshape(-1, 3), axis=1)
        flat = rows.view("f8").reshape(len(t), 9)
        return flat[np.lexsort(flat.T[::-1])]

    assert np.array_equal(canon(ta), canon(tb))
    signed = lambda t: np.einsum("ij,ij->i", t[:, 0], np.cross(t[:, 1], t[:, 2])).sum() / 6  # outward alike
    assert signed(ta) == pytest.approx(signed(tb), rel=1e-9) and signed(ta) > 0


def test_closed_shape_mesh_repairs_a_tessellation_wound_wrong(monkeypatch):
    """A heat sink enclosure STEP (sdu-multiphysics' competition files) has a solid
    that OCCT meshes with an edge in four triangles and two wound the wrong way;
    both tessellations gave it so, the 3MF writer refused it ("not watertight") and
    the textured assembly could not be written. Here both give a box with one
    triangle turned over: texcad's repair winds it back, closed, with the box's
    volume."""
    from texcad.brep import closed_shape_mesh, shape_to_mesh
    from texcad.solid import Mesh

    box = Box(10, 10, 10)
    m = shape_to_mesh(box)
    f = m.faces.copy()
    f[0] = f[0, ::-1]
    bad = Mesh(m.vertices, f)
    assert not bad.is_watertight

    monkeypatch.setattr(tessellation, "shape_to_mesh", lambda *a, **k: bad)
    monkeypatch.setattr(tessellation, "part_tessellation", lambda *a, **k: type("P", (), {"mesh": bad})())
    out = closed_shape_mesh(box)
    assert out.is_watertight and out.volume == pytest.approx(1000.0, rel=1e-6)
