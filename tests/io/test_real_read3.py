"""Mesh files as other tools write them (session 11, third round of real files)."""

import zipfile

import numpy as np
import pytest
import trimesh

import texcad
from texcad.errors import InputError
from texcad.io import read_part
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


CORE = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
BEAMS = "http://schemas.microsoft.com/3dmanufacturing/beamlattice/2017/02"
SLICES = "http://schemas.microsoft.com/3dmanufacturing/slice/2015/07"
MATERIALS = "http://schemas.microsoft.com/3dmanufacturing/material/2015/02"


def _box_3mf(path, head="", obj="", extra=""):
    """A 3MF of a 20 mm box (lib3mf's test files' layout), with ``head`` on <model>,
    ``obj`` on <object> and ``extra`` inside <mesh> after the triangles."""
    b = trimesh.creation.box((20.0, 20.0, 20.0))
    vs = "".join(f'<vertex x="{x:g}" y="{y:g}" z="{z:g}"/>' for x, y, z in b.vertices)
    ts = "".join(f'<triangle v1="{i}" v2="{j}" v3="{k}"/>' for i, j, k in b.faces)
    model = (f'<?xml version="1.0"?><model unit="millimeter" xmlns="{CORE}" {head}><resources>'
             f'<object id="1" name="Box" type="model" {obj}><mesh><vertices>{vs}</vertices><triangles>{ts}</triangles>'
             f'{extra}</mesh></object></resources><build><item objectid="1"/></build></model>')
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("3D/3dmodel.model", model)
    return path


@pytest.mark.parametrize("head, needs", [
    (f'xmlns:b="{BEAMS}" requiredextensions="b"', "beamlattice"),
    ('xmlns:us="http://example.com/unknown/2999/12" requiredextensions="us"', "unknown/2999/12"),
])
def test_a_3mf_that_requires_an_extension_texcad_does_not_read_is_refused(tmp_path, head, needs):
    """lib3mf's RequiredExtensions/Unsupported.3mf requires a beam lattice and an
    unknown extension; SphereInACage.3mf the implicit extension. texcad read their
    triangles as the whole part (or said 'holds no mesh objects'): the producer says
    the shape needs the extension, so the file is refused naming it."""
    with pytest.raises(InputError, match=f"requires the 3MF extension.*{needs}.*does not read"):
        read_part(_box_3mf(tmp_path / "x.3mf", head))


def test_a_slice_stand_in_and_a_beam_lattice_are_refused(tmp_path):
    """lib3mf's MultiSliceStack_OneFile.3mf and PS_505_02_non_planar_transform.3mf: the
    objects are slice stacks, their meshes marked meshresolution="lowres" (stand-ins);
    BeamLattice/Box_Simple.3mf: beams of 10 mm radius along the box's edges, the
    extension not declared required. Each was read as a plain box."""
    lowres = _box_3mf(tmp_path / "s.3mf", f'xmlns:s="{SLICES}" requiredextensions="s"', 's:meshresolution="lowres" s:slicestackid="3"')
    with pytest.raises(InputError, match="given by slices.*low-resolution stand-in"):
        read_part(lowres)
    beams = '<b:beamlattice radius="10" minlength="0.01"><b:beams><b:beam v1="0" v2="1"/></b:beams></b:beamlattice>'
    with pytest.raises(InputError, match="beam lattice"):
        read_part(_box_3mf(tmp_path / "b.3mf", f'xmlns:b="{BEAMS}"', "", beams))


def test_shape_neutral_extensions_are_read(tmp_path):
    """Materials, production and slices (on an object with its full mesh) are read as before."""
    head = f'xmlns:m="{MATERIALS}" xmlns:s="{SLICES}" requiredextensions="m s"'
    (name, mesh), = read_part(_box_3mf(tmp_path / "m.3mf", head))
    assert name == "Box" and len(mesh.faces) == 12


def test_a_mirrored_build_item_keeps_its_triangles_outward(tmp_path):
    """A build item mirrored by its transform (negative determinant, as lib3mf's
    displacement_mirrored_build_item.3mf places its part): read with the winding as
    written, the box was inside out, and texcad check said 'manifold NO' and -1000 mm3.
    The winding is reversed with the mirror: +1000 mm3, outward."""
    path = _box_3mf(tmp_path / "m.3mf")
    with zipfile.ZipFile(path) as z:
        model = z.read("3D/3dmodel.model").decode()
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("3D/3dmodel.model", model.replace('<item objectid="1"/>', '<item objectid="1" transform="-0.5 0 0 0 1 0 0 0 1 50 0 0"/>'))
    (_, mesh), = read_part(path)
    body = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert abs(body.volume - 4000.0) < 1e-3 and body.is_winding_consistent
    assert np.isclose(body.bounds[:, 0], [45.0, 55.0]).all()
    assert texcad.check(path).manifold
