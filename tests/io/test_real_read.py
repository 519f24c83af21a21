"""Reading meshes as other tools wrote them (session 10, real files)."""

import numpy as np

from texcad.io import read_mesh


def test_an_ascii_stl_with_classic_mac_line_ends(tmp_path):
    """PrusaSlicer's tests/data/test_stl/ASCII/20mmbox-CR.stl ends its lines with CR
    alone (classic Mac OS): it was refused, 'a vertex needs three numbers'."""
    rows = ["solid box"]
    tri = np.array([[0, 0, 0], [20, 0, 0], [0, 20, 0]], float)
    for t in (tri, tri[::-1] + [0, 0, 5]):
        rows += ["facet normal 0 0 1", "outer loop", *[f"vertex {x:e} {y:e} {z:e}" for x, y, z in t], "endloop", "endfacet"]
    rows.append("endsolid box")
    for end in ("\r", "\r\n", "\n"):
        (tmp_path / "box.stl").write_bytes(end.join(rows).encode())
        m = read_mesh(tmp_path / "box.stl")
        assert m.faces.shape == (2, 3) and np.isclose(np.asarray(m.vertices).max(), 20)
