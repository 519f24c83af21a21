"""A 3MF of several build items is written back as as many objects, each placed by
its item's transform (session 12): texcad wrote nine 20 x 20 x 10 mm boxes, nine build
items in, as one object of nine bodies, which a slicer cannot arrange."""

from __future__ import annotations

import re
import zipfile

import numpy as np
import pytest

import texcad

trimesh = pytest.importorskip("trimesh")


@pytest.fixture(scope="module")
def nine(tmp_path_factory):
    """Nine boxes as trimesh writes a scene: one object and one build item each, the
    item's transform placing it (the fifth turned 30 degrees about z)."""
    scene = trimesh.Scene()
    for i in range(9):  # per box
        t = trimesh.transformations.translation_matrix((30.0 * (i % 3), 30.0 * (i // 3), 5.0))
        if i == 4:
            t = t @ trimesh.transformations.rotation_matrix(np.radians(30.0), (0, 0, 1))
        scene.add_geometry(trimesh.creation.box(extents=(20, 20, 10)), node_name=f"box{i}", transform=t)
    path = tmp_path_factory.mktemp("items") / "nine.3mf"
    scene.export(path)
    return path


def _items(path):
    xml = zipfile.ZipFile(path).read("3D/3dmodel.model").decode()
    return re.findall(r"<object\b", xml), re.findall(r"<item\b[^>]*>", xml)


def test_each_build_item_is_its_own_object(nine, tmp_path):
    tx = texcad.texture(nine, "not-bottom", "builtin:stones", height=1.0, pitch=1.0)
    out = tmp_path / "out.3mf"
    tx.export(out)
    objects, items = _items(out)
    assert len(objects) == 9 and len(items) == 9  # was 1 and 1
    from texcad.io.read import build_items

    before, after = build_items(nine), build_items(out)
    for (_, tf0, m0), (_, tf1, m1) in zip(before, after):  # per item: its transform kept, its body textured
        assert np.allclose(tf0, tf1, atol=1e-9)
        assert len(m1) == 1 and m1[0].is_watertight and 4000.0 < m1[0].volume < 4000.0 + 20 * 20 * 1.0 + 4 * 20 * 10 * 1.0
        lo0, hi0 = m0[0].vertices.min(axis=0), m0[0].vertices.max(axis=0)
        lo1, hi1 = m1[0].vertices.min(axis=0), m1[0].vertices.max(axis=0)
        assert np.allclose((lo0 + hi0)[:2] / 2, (lo1 + hi1)[:2] / 2, atol=0.6) and abs(lo1[2] - lo0[2]) < 1e-4  # on the bed
    assert sum(m.volume for _, _, ms in after for m in ms) == pytest.approx(tx.mesh.volume, rel=1e-6)
    scene = trimesh.load(out)  # another reader: nine geometries
    assert len(scene.geometry) == 9


def test_one_item_stays_one_object(tmp_path):
    box = trimesh.creation.box(extents=(20, 20, 10))
    src = tmp_path / "one.3mf"
    box.export(src)
    out = tmp_path / "out.3mf"
    texcad.texture(src, "not-bottom", "builtin:stones", height=1.0, pitch=1.0).export(out)
    objects, items = _items(out)
    assert len(objects) == 1 and len(items) == 1


def test_items_are_turned_for_the_build_direction_with_their_settings(nine, tmp_path):
    """With a build direction every item is turned with the rest and all rest on the
    bed together; each object gets the slicer settings one object gets."""
    from texcad.io.read import build_items

    out = tmp_path / "down.3mf"
    texcad.texture(nine, "not-bottom", "builtin:stones", height=1.0, pitch=1.0, build_dir="-z").export(out)
    items = build_items(out)
    assert len(items) == 9
    low = min(float(m.vertices[:, 2].min()) for _, _, ms in items for m in ms)
    assert abs(low) < 1e-4  # the lowest point on the bed
    turn = np.diag([1.0, -1.0, -1.0])  # -z turned up
    assert all(np.allclose(tf[:3, :3], tf0[:3, :3] @ turn) for (_, tf, _), (_, tf0, _) in zip(items, build_items(nine)))
    config = zipfile.ZipFile(out).read("Metadata/Slic3r_PE_model.config").decode()
    assert config.count("<object id=") == 9 and config.count('key="seam_position"') == 9


def test_items_united_by_union_are_one_object(tmp_path):
    """Two build items that overlap, textured with union=True: one body grew from
    both, so they are written as one object, said in a warning."""
    a = trimesh.creation.box(extents=(60, 40, 20))
    a.apply_translation((30, 20, 10))
    b = trimesh.creation.box(extents=(30, 30, 30))
    b.apply_translation((65, 25, 15))
    scene = trimesh.Scene()
    scene.add_geometry(a, node_name="a")
    scene.add_geometry(b, node_name="b")
    src, out = tmp_path / "two.3mf", tmp_path / "out.3mf"
    scene.export(src)
    tx = texcad.texture(src, "not-bottom", "builtin:stones", height=1.0, pitch=1.0, union=True)
    with pytest.warns(texcad.TexcadWarning, match=r"grew from more than one of the 3MF's 2 build items"):
        tx.export(out)
    objects, items = _items(out)
    assert len(objects) == 1 and len(items) == 1
    assert texcad.io.read_mesh(out).volume == pytest.approx(tx.mesh.volume, rel=1e-6)
