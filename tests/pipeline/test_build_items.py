"""A 3MF of several build items is written back as as many objects, each placed by
its item's transform (session 12): texcad wrote nine 20 x 20 x 10 mm boxes, nine build
items in, as one object of nine bodies, which a slicer cannot arrange; and, with the
texture separate, as one object of nine bases and nine textures (session 13): now
one object per item of its own base and texture parts."""

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
    both, so they are written as one object, said in a warning (with the texture
    separate too)."""
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
    sep = tmp_path / "separate.3mf"  # the texture separate: one object of base and texture, said alike
    with pytest.warns(texcad.TexcadWarning, match=r"grew from more than one of the 3MF's 2 build items"):
        tx.export(sep, separate_texture=True)
    objects, items = _items(sep)
    assert len(objects) == 1 and len(items) == 1 and _volume_names(sep) == [["base", "texture 1"]]


@pytest.fixture(scope="module")
def separate(nine, tmp_path_factory):
    """The nine boxes textured, written whole (``plain.3mf``) and with the texture
    separate (``separate.3mf``): ``(textured, plain, separate)``."""
    tx = texcad.texture(nine, "not-bottom", "builtin:stones", height=1.0, pitch=1.0)
    folder = tmp_path_factory.mktemp("separate")
    tx.export(folder / "plain.3mf")
    tx.export(folder / "separate.3mf", separate_texture=True)
    return tx, folder / "plain.3mf", folder / "separate.3mf"


def _volume_names(path) -> list:
    """PrusaSlicer's part names of each object (``Metadata/Slic3r_PE_model.config``)."""
    config = zipfile.ZipFile(path).read("Metadata/Slic3r_PE_model.config").decode()
    return [re.findall(r'<volume\b[^>]*>\s*<metadata type="volume" key="name" value="([^"]*)"', o)
            for o in re.findall(r"<object\b.*?</object>", config, re.S)]


def test_separate_texture_keeps_each_build_item(nine, separate, tmp_path):
    """--separate-texture on nine build items: nine objects, each of its own base and
    texture parts (closed, outward), holding what its item printed, placed by its
    item's transform (was one object holding nine bases and nine textures)."""
    from texcad.io.read import build_items

    tx, plain, out = separate
    objects, items = _items(out)
    assert len(objects) == 9 and len(items) == 9  # was 1 and 1
    assert _volume_names(out) == [["base", "texture 1"]] * 9  # was one object of two parts holding all nine
    assert 'name="slic3rpe:Version3mf">1<' in zipfile.ZipFile(out).read("3D/3dmodel.model").decode()  # every part moves with its item
    source, whole, after = build_items(nine), build_items(plain), build_items(out)
    for (_, tf0, m0), (_, _, (printed,)), (_, tf1, parts) in zip(source, whole, after):  # per item
        assert np.allclose(tf1, tf0, atol=1e-9)  # its transform kept
        base, texture = parts
        assert base.is_watertight and texture.is_watertight and base.volume > 0 and texture.volume > 0  # closed, outward
        assert 3900.0 < base.volume < 4000.0 and 0.0 < texture.volume < 20 * 20 * 1.0 + 4 * 20 * 10 * 1.0
        assert base.volume + texture.volume == pytest.approx(printed.volume, rel=1e-6)  # what the item printed
        lo0, hi0 = m0[0].vertices.min(axis=0), m0[0].vertices.max(axis=0)
        lo, hi = base.vertices.min(axis=0), base.vertices.max(axis=0)
        assert np.allclose((lo0 + hi0)[:2] / 2, (lo + hi)[:2] / 2, atol=1e-3) and abs(lo[2] - lo0[2]) < 1e-4  # where the item put it
    turned = after[4][1][:3, :3]
    assert np.allclose(turned[:2, :2], [[np.cos(np.radians(30)), np.sin(np.radians(30))],
                                        [-np.sin(np.radians(30)), np.cos(np.radians(30))]], atol=1e-9)  # the 5th turned 30 degrees
    assert sum(m.volume for _, _, ms in after for m in ms) == pytest.approx(tx.mesh.volume, rel=1e-6)
    assert len(trimesh.load(out).geometry) == 9  # another reader: nine objects
    again = tmp_path / "again.3mf"
    tx.export(again, separate_texture=True)
    assert again.read_bytes() == out.read_bytes()  # the same inputs give the same bytes


def _prusa():
    from texcad.report.slicer import find_slicer

    return find_slicer("prusaslicer")


@pytest.mark.skipif(_prusa() is None, reason="prusa-slicer is not installed")
def test_prusaslicer_loads_nine_objects_of_base_and_texture(separate, tmp_path):
    """PrusaSlicer loads the separate-texture 3MF as nine objects of two parts each
    (``--info``) and, written back without arranging, every part where it was."""
    import subprocess

    from texcad.io.read import build_items

    _, plain, out = separate
    info = subprocess.run([_prusa(), "--info", str(out)], capture_output=True, text=True, timeout=300).stdout
    assert info.count(f"[{out.name}]") == 9 and info.count("number_of_parts =  2") == 9, info  # was 1 object of 18 parts
    volumes = [float(v) for v in re.findall(r"^volume = (\S+)", info, re.M)]
    whole = [ms[0].volume for _, _, ms in build_items(plain)]
    assert np.allclose(volumes, whole, rtol=1e-4)  # each object what its item printed (PrusaSlicer's float32)
    back = tmp_path / "back.3mf"
    subprocess.run([_prusa(), "--export-3mf", "--dont-arrange", "--output", str(back), str(out)], capture_output=True,
                   timeout=300, check=True)
    for (_, _, ours), (_, _, theirs) in zip(build_items(out), build_items(back), strict=True):  # per item: its parts placed
        assert len(theirs) == 2
        for a, b in zip(ours, theirs):
            assert np.allclose(a.vertices.min(axis=0), b.vertices.min(axis=0), atol=1e-4)
            assert np.allclose(a.vertices.max(axis=0), b.vertices.max(axis=0), atol=1e-4)
            assert b.volume == pytest.approx(a.volume, rel=1e-6)


def test_separate_texture_of_an_item_inside_another_items_box(tmp_path):
    """A box standing in a ring's hole (two build items, the box within the ring's
    bounding box): each part's bodies go to the item that holds them by shared
    volume, not by box, so each item gets its own base and texture."""
    from texcad.io.read import build_items

    scene = trimesh.Scene()
    scene.add_geometry(trimesh.creation.annulus(r_min=15, r_max=20, height=8, sections=48), node_name="ring",
                       transform=trimesh.transformations.translation_matrix((0, 0, 4)))
    scene.add_geometry(trimesh.creation.box(extents=(10, 10, 6)), node_name="core",
                       transform=trimesh.transformations.translation_matrix((0, 0, 3)))
    src, plain, out = tmp_path / "ring.3mf", tmp_path / "plain.3mf", tmp_path / "separate.3mf"
    scene.export(src)
    tx = texcad.texture(src, "not-bottom", "builtin:stones", height=1.0, pitch=1.0)
    tx.export(plain)
    tx.export(out, separate_texture=True)
    objects, items = _items(out)
    assert len(objects) == 2 and len(items) == 2 and _volume_names(out) == [["base", "texture 1"]] * 2  # was 1 and 1
    for (_, _, parts), (_, _, (printed,)), box in zip(build_items(out), build_items(plain), (False, True)):  # ring, box
        assert all(m.is_watertight and m.volume > 0 for m in parts)
        assert sum(m.volume for m in parts) == pytest.approx(printed.volume, rel=1e-6)
        assert bool(np.ptp(parts[0].vertices[:, 0]) < 12.0) is box  # the box's base is the box's, the ring's the ring's
