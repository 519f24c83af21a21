"""Meshes as other tools write them (session 11, third round of real files)."""

import numpy as np
import pytest
import trimesh

import texcad


def _chamfered_plate(w: float = 30.0, t: float = 8.0, run: float = 4.0, rise: float = 0.5) -> trimesh.Trimesh:
    """A ``w`` x ``w`` x ``t`` mm plate standing on its bottom face at z = 0, its
    bottom edges chamfered ``run`` mm in and ``rise`` mm up (7 degrees off the bed: the
    faces beside the bed look nearly straight down, as a fillet's do where it meets
    the bed face)."""
    a, b = w / 2, w / 2 - run
    pts = [(x, y, z) for z, r in ((0.0, b), (rise, a), (t, a)) for x in (-r, r) for y in (-r, r)]
    return trimesh.convex.convex_hull(np.array(pts))


def test_raised_texture_beside_the_bed_face_stays_above_it():
    """trimesh's plate_holes.STL (a plate with rounded bottom edges), textured with
    the default region (every face but the bed face): the knurl on the rounded edges
    reached 0.2 mm under the bed face, so the part stood on the texture's crests and
    texcad check counted the whole bottom (55 000 mm2) as overhang. The relief is now
    held at the bed plane; the bed face stays the lowest and the crests elsewhere keep
    their height."""
    plate = _chamfered_plate()
    tx = texcad.texture(plate, None, "builtin:diamond_knurl", height=0.5, pitch=0.7)
    z = tx.mesh.vertices[:, 2]
    assert z.min() >= -1e-5, z.min()  # was -0.19 mm
    assert tx.info["bed_held"] > 0
    assert z.max() > 8.3  # the top keeps its relief
    out = trimesh.Trimesh(tx.mesh.vertices, tx.mesh.faces, process=False)
    assert out.is_watertight and out.volume > plate.volume
    # the bed face's own patch stays flat on z = 0: the area lying there is at least the input's
    n = out.face_normals
    on_bed = (np.abs(out.triangles_center[:, 2]) < 1e-5) & (n[:, 2] < -0.999)
    assert out.area_faces[on_bed].sum() >= 22.0 ** 2 - 1e-3


def test_a_textured_bed_face_is_not_held():
    """With the bed face in the region (all+bottom) the part is textured underneath too,
    as asked: nothing is held at the bed plane."""
    tx = texcad.texture(_chamfered_plate(), "all+bottom", "builtin:diamond_knurl", height=0.5, pitch=0.7)
    assert tx.info["bed_held"] == 0
    assert tx.mesh.vertices[:, 2].min() < -0.3


def test_a_mesh_made_in_blocks_stays_above_its_bed_face(monkeypatch):
    """The same hold where the job is made in blocks (texcad.targets.tiled_mesh): the
    same triangles as the whole mesh's, the bed face the lowest."""
    from texcad.targets import mesh as mesh_target
    from texcad.targets import tiled_mesh

    plate = _chamfered_plate(w=16.0, t=4.0, run=3.0, rise=0.4)
    kw = dict(height=0.5, pitch=0.5, tolerance=0)
    flat = texcad.texture(plate, None, "builtin:diamond_knurl", **kw)
    with monkeypatch.context() as m:
        m.setattr(mesh_target, "untiled_bytes", lambda triangles: 1e18)
        m.setattr(tiled_mesh, "_block_triangles", lambda coarse, pitch, *per: 3000)
        tx = texcad.texture(plate, None, "builtin:diamond_knurl", **kw)
    assert tx.info["fuse"] == "tiled" and tx.info["blocks"] >= 3
    whole = tx.mesh.to_mesh()
    assert whole.vertices[:, 2].min() >= -1e-5 and flat.mesh.vertices[:, 2].min() >= -1e-5
    assert whole.volume == pytest.approx(flat.mesh.volume, rel=1e-9)
