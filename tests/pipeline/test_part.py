"""``Textured.part`` (texcad.pipeline.part.TexturedPart): build123d's own ``-``,
``+``, ``&`` on a textured part go through texcad's checked operations, so a hole
drilled the build123d way is there (OCCT's boolean alone returned a textured full
cylinder uncut, as a valid solid: +4.8 % against the mesh's cut)."""

import copy
import warnings

import pytest
from build123d import Box, Cylinder, GeomType, Part, Pos, Rot

import texcad
from texcad.brep import check_shape, occt_volume
from texcad.pipeline.part import TexturedPart


@pytest.fixture(scope="module")
def tx():
    part = Cylinder(8, 12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return texcad.texture(part, part.faces().filter_by(GeomType.CYLINDER)[0], "builtin:stones", height=0.4, pitch=0.5)


def test_a_hole_drilled_the_build123d_way_is_there(tx):
    tool = Rot(90, 0, 0) * Cylinder(1.5, 40)  # radially through the axis
    drilled = tx.part - tool
    assert isinstance(drilled, TexturedPart)
    chk = check_shape(drilled.wrapped)
    assert chk["valid"] and chk["solids"] == 1
    want = (tx - tool).volume
    assert tx.volume - want > 100  # the hole: 3 mm across 16 mm of cylinder
    assert abs(occt_volume(drilled.wrapped) - want) <= 1e-3 * want
    again = drilled - Pos(0, 0, 3) * Rot(90, 0, 0) * Cylinder(1.0, 40)  # the result is linked too: chained
    assert occt_volume(again.wrapped) < occt_volume(drilled.wrapped) - 40
    assert abs(occt_volume(tx.part.cut(tool).wrapped) - want) <= 1e-3 * want


def test_fuse_and_common_go_through_texcad(tx):
    boss = Pos(0, 0, 7) * Box(4, 4, 4)  # into the top, off the texture: 48 mm3 more
    fused = tx.part + boss
    assert abs(occt_volume(fused.wrapped) - (tx.volume + 48)) <= 1e-3 * tx.volume
    half = tx.part & Pos(0, 10, 0) * Box(20, 20, 20)
    assert abs(occt_volume(half.wrapped) - (tx & Pos(0, 10, 0) * Box(20, 20, 20)).volume) <= 1e-3 * tx.volume / 2


def test_copies_are_plain_parts_again(tx):
    """A copy (moved, mirrored, deep-copied) is another solid: its booleans are
    build123d's own, and copying does not copy the meshes."""
    moved = copy.deepcopy(tx.part)
    assert type(moved) is TexturedPart and moved.__dict__["_texcad_link"].textured is None
    plain = moved - Pos(0, 0, 20) * Box(1, 1, 1)  # away from the part: OCCT's own, nothing cut
    assert isinstance(plain, Part) and not isinstance(plain, TexturedPart)
