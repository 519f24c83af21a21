"""Every recipe, sliced as printed (issue 29): each states its print orientation and
passes it as ``build_dir``, and each part it makes, at a coarse pitch, gets no
support beyond what the same part untextured gets, in PrusaSlicer and in CuraEngine,
support on at threshold = the critical angle (45 degrees).

"Beyond" is located, not a total: the textured part's support paths farther than
4.2 mm across (a cell's diagonal of PrusaSlicer's support grid) or 1 mm in height from all of the bare part's
(texcad.report.slicer.extra_support). Where both need support the totals differ
anyway (PrusaSlicer rests a column standing beside a textured wall on the texture's
upward facets). The recipes are run by benchmarks/bench_slicer.py's
``recipe_parts``, the same parts its table slices. Each slicer is skipped where it is
not installed."""

import sys
from pathlib import Path

import numpy as np
import pytest

from texcad.report import slicer

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import bench_slicer  # noqa: E402

HAVE = [s for s in slicer.SLICERS if slicer.find_slicer(s) is not None]
needs_slicer = pytest.mark.skipif(not HAVE, reason="neither prusa-slicer nor CuraEngine is installed")

#: The paper's samples sliced here (all nine are in the benchmark's table): each
#: texture, the curved and sine shapes, three of Table 2's tilts (30, 45, 30
#: degrees); the flat samples, whose CuraEngine slices take longest, in the table only.
PAPER = ("T1-curved", "T2-curved", "T3-sine")


#: mm: coarser than the benchmark's table where a slice would take long (CuraEngine
#: spends 16 CPU-s on the 100 mm flat plate's stones at 2 mm).
TEST_PITCH = {"flat_plate": 4.0}


def _cases():
    for script in bench_slicer.RECIPES:
        if script == "paper_samples":
            for name in PAPER:
                yield pytest.param(script, (name,), id=f"paper-{name}")
        else:
            yield pytest.param(script, (), id=script)


def test_every_recipe_is_listed():
    """The table and these tests cover every recipe that makes a part."""
    scripts = {p.stem for p in (Path(__file__).resolve().parents[2] / "recipes").glob("*.py")} - {"gallery"}
    assert scripts == set(bench_slicer.RECIPES)


def test_every_recipe_states_its_print_orientation():
    """Each recipe names its print orientation once, ``BUILD_DIR = (...)  # print
    orientation: ...``, and passes it to texcad.texture (the paper's samples: one per
    row of Table 2, ``texcad.orientation(tilt, toward)``)."""
    import re

    for script in bench_slicer.RECIPES:
        src = (Path(__file__).resolve().parents[2] / "recipes" / f"{script}.py").read_text()
        if script == "paper_samples":
            assert "build_dir=d" in src and "texcad.orientation(tilt, toward)" in src
            continue
        assert re.search(r"^BUILD_DIR = \([-0-9., ]+\)  # print orientation: \S", src, re.M), script
        assert re.search(r"build_dir=BUILD_DIR\b", src), script


@needs_slicer
@pytest.mark.parametrize("script, samples", list(_cases()))
def test_recipe_parts_need_no_support_beyond_bare(script, samples):
    """Each part in each installed slicer (one recipe run for both)."""
    made = bench_slicer.recipe_parts(script, TEST_PITCH.get(script, bench_slicer.COARSE_PITCH[script]), samples)
    assert made, f"{script} made no textured part"
    for name, bare, textured, d in made:
        assert d is not None, f"{name}: no build_dir given"
        for slicer_name in HAVE:
            a, b, extra = bench_slicer.compare(bare, textured, d, slicer_name, 600.0)
            assert a is not None and b is not None and a.returncode == 0 and b.returncode == 0, (name, slicer_name)
            assert extra == 0.0, (name, slicer_name, a.support_mm, b.support_mm, extra)


@needs_slicer
def test_a_column_beside_a_textured_wall_is_the_bare_parts_support(tmp_path):
    """The slotted handle (a mesh, knurled in a cylindrical projection, limited for
    +z): its slot's ceiling needs support, whose column stands beside the knurl down
    to the bed. PrusaSlicer rests that column on the knurl (more layers, more path),
    but none of the support lies beyond the bare handle's."""
    (name, bare, textured, d), = bench_slicer.slotted_handle(1.0, tmp_path)
    for slicer_name in HAVE:
        a, b, extra = bench_slicer.compare(bare, textured, d, slicer_name, 600.0)
        assert a.support_mm > 1000.0 and b.support_mm > 1000.0, (slicer_name, a.support_mm, b.support_mm)
        assert extra == 0.0, (slicer_name, a.support_mm, b.support_mm, extra)


def test_extra_support_finds_support_the_bare_part_does_not_need():
    """The measure can fail: support paths of a report beside an empty one all count;
    of the same paths moved 4.5 mm across, the one left 4.5 mm from both counts."""
    seg = np.array([[[0.0, 0.0, 1.0], [10.0, 0.0, 1.0]], [[0.0, 1.0, 1.3], [10.0, 1.0, 1.3]]])
    rep = lambda p: slicer.SliceReport(seconds=0.0, peak_mb=0.0, support_paths=p)
    assert slicer.extra_support(rep(seg), rep(np.zeros((0, 2, 3)))) == pytest.approx(20.0)
    assert slicer.extra_support(rep(seg), rep(seg + [0.0, 1.0, 0.0])) == 0.0
    assert slicer.extra_support(rep(seg + [0.0, 4.5, 0.0]), rep(seg)) == pytest.approx(10.0)  # y = 5.5 is 4.5 mm from y = 1
    assert slicer.extra_support(rep(seg + [0.0, 0.0, 2.0]), rep(seg)) == pytest.approx(20.0)  # 2 mm higher
