"""Mesh files as other tools write them (session 11, third round of real files)."""

import numpy as np
import trimesh

import texcad
from texcad.io.read import read_mesh

L = [(20, 0), (20, 8), (8, 8), (8, 20), (0, 20), (0, 0)]  # mm, concave at (8, 8); a fan from (20, 0) leaves it


def _prism_obj(path, outline, newline="\n"):
    """An OBJ of ``outline`` (mm) extruded 10 mm: each cap one polygon (the top's
    face line continued with a backslash, as Blender and trimesh's wallhole.obj
    write long faces), the sides quads."""
    n = len(outline)
    lines = [f"v {x} {y} {z}" for z in (0, 10) for x, y in outline]
    lines.append("f " + " ".join(str(i + 1) for i in reversed(range(n))))
    lines += ["f " + " ".join(str(n + i + 1) for i in range(3)) + " \\", "  " + " ".join(str(n + i + 1) for i in range(3, n))]
    lines += [f"f {i + 1} {(i + 1) % n + 1} {n + (i + 1) % n + 1} {n + i + 1}" for i in range(n)]
    path.write_bytes((newline.join(lines) + newline).encode())
    return path


def _areas(m) -> np.ndarray:
    p = np.asarray(m.vertices, dtype=np.float64)[np.asarray(m.faces, dtype=np.int64)]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def test_a_continued_face_line_with_cr_lf_is_read(tmp_path):
    """trimesh's wallhole.obj (CR LF line ends, long faces continued with a backslash)
    was refused: 'a vertex index that is not a whole number ... the file is damaged'."""
    m = read_mesh(_prism_obj(tmp_path / "l.obj", L, "\r\n"))
    body = trimesh.Trimesh(m.vertices, m.faces)
    assert body.is_watertight and abs(body.volume - 2560.0) < 1e-6


def test_a_concave_polygon_is_split_inside_its_outline(tmp_path):
    """wallhole.obj's side walls are 11-gons around a notch: fanned from their first
    vertex, the triangles covered area outside the wall (the L cap below: 352 mm2 of
    triangles for 256 mm2 of cap), and texturing the part failed texcad's gate with
    'a stage made a broken mesh; please report this'. Ear clipping covers the cap
    exactly; the part is textured and closed."""
    path = _prism_obj(tmp_path / "l.obj", L)
    m = read_mesh(path)
    z = np.asarray(m.vertices)[np.asarray(m.faces, dtype=np.int64)][:, :, 2]
    top = np.all(z == 10, axis=1)
    assert top.sum() == 4 and abs(_areas(m)[top].sum() - 256.0) < 1e-6
    tx = texcad.texture(path, None, "builtin:dots", height=0.5, pitch=0.7)
    out = trimesh.Trimesh(tx.mesh.vertices, tx.mesh.faces, process=False)
    assert out.is_watertight and out.volume > 2560.0


def test_straight_corners_give_no_empty_triangles(tmp_path):
    """A rectangle written with its sides' midpoints (wallhole.obj's slot floor and
    walls): the fan made a triangle of no area and an edge skipping the midpoint the
    wall beside has (the mesh open: an edge used four times). Every triangle now has
    area and the box is closed."""
    box = [(0, 0), (5, 0), (10, 0), (10, 5), (5, 5), (0, 5)]  # counter-clockwise, a midpoint on two sides
    m = read_mesh(_prism_obj(tmp_path / "box.obj", box))
    assert _areas(m).min() > 1.0
    body = trimesh.Trimesh(m.vertices, m.faces)
    assert body.is_watertight and abs(body.volume - 500.0) < 1e-6
