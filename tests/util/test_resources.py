"""texcad.util.resources: the memory guard estimates before allocating and says which
pitch fits, under the machine's memory and under a process's own limits."""

from __future__ import annotations

import subprocess
import sys

import pytest

from texcad.util import available_memory, fitting_pitch, texture_bytes


def test_estimates_scale_with_pixels_and_fitting_pitch_fits():
    assert texture_bytes(1e6, 0.0) > texture_bytes(1e6, 0.02) > 0
    need = texture_bytes(4e6, 0.0)
    p = fitting_pitch(0.05, need, have=need / 4)
    assert p == pytest.approx(0.05 * 2 * 1.2**0.5)
    assert texture_bytes(4e6 * (0.05 / p) ** 2, 0.0) < need / 4


LIMITED = """
import resource, sys
resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, resource.RLIM_INFINITY))
import texcad
from texcad.util import available_memory
assert available_memory() < 3 * 2**30
from build123d import Box, Axis
box = Box(157, 128, 10)
try:
    # engraved: not made in tiles (a raised planar face is, limited or not: tests/targets/test_tiled_faces.py)
    texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.0, pitch=0.05, tolerance=0, mode="engraved")
except texcad.ResourceError as e:
    print("ResourceError:", e)
    sys.exit(3)
"""


def test_an_address_space_limit_gives_a_resource_error_not_a_crash():
    """The issue's case: a 157 x 128 mm face at 0.05 mm under a 3 GiB limit (it used
    8.7 GB, and under a 6 GB limit the process died with a segmentation fault)."""
    r = subprocess.run([sys.executable, "-c", LIMITED], capture_output=True, text=True, timeout=300)
    assert r.returncode == 3, r.stderr[-2000:]
    assert "GiB of memory" in r.stdout and "use a pitch of at least" in r.stdout


def test_available_memory_is_positive():
    assert available_memory() > 2**20


def test_a_bound_is_what_the_job_has_whatever_the_machine_has_free(monkeypatch):
    """Under max_memory the job has what the bound leaves over what the process
    holds, however little the machine (or its container) has free just then: the
    plans made from it go with the bound alone. Without a bound the machine's free
    memory counts."""
    from texcad.util import memory_limit
    from texcad.util import resources

    monkeypatch.setattr(resources, "_meminfo_available", lambda: 1 << 20)
    monkeypatch.setattr(resources, "_cgroup_left", lambda: 1 << 20)
    assert available_memory() <= 1 << 20
    with memory_limit(resources._rss() + (100 << 20)):
        assert 90 << 20 < available_memory() <= 100 << 20


# --- every path estimates before it allocates and names a pitch that fits (issue 27) ---

def _named(exc: BaseException, what: str = "pitch") -> float:
    import re

    m = re.search(rf"use a {what} of (?:at least|at most) ([0-9.e+-]+)", str(exc))
    assert m, str(exc)
    return float(m.group(1))


def _refused_quickly(call) -> BaseException:
    """The ResourceError ``call`` raises, asserting that it came before any large
    allocation: in well under 2 s and with the process's peak memory barely grown."""
    import resource
    import time

    import texcad

    peak0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t = time.perf_counter()
    with pytest.raises(texcad.ResourceError) as info:
        call()
    assert time.perf_counter() - t < 2.0
    assert (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak0) * 1024 < 100 * 2**20
    return info.value


def test_finest_pitch_fits_and_rounds_up():
    from texcad.util import finest_pitch

    p = finest_pitch(0.01, scaled=8e9, fixed=1e8, have=1e9)
    assert 1e8 + 8e9 * (0.01 / p) ** 2 <= 1e9 / 1.2  # fits with its 20 % spare
    assert p == pytest.approx(0.01 * (8e9 / (1e9 / 1.2 - 1e8)) ** 0.5, rel=5e-3)
    assert finest_pitch(0.01, 1e9, fixed=2e9, have=1e9) == float("inf")


@pytest.mark.parametrize("kind", ["plane", "cylinder"])
def test_a_tiny_pitch_on_a_step_face_is_refused_before_allocating(kind):
    """The issue's case: 1e-6 mm on a 20 mm box face allocated 1.8 GiB in
    face_segments before any check; now refused up front, naming a pitch that fits."""
    build123d = pytest.importorskip("build123d")
    import texcad
    from texcad.util.resources import _rss

    if kind == "plane":
        part = build123d.Box(20, 20, 20)
        face = part.faces().sort_by(build123d.Axis.Z)[-1]
    else:
        part = build123d.Cylinder(10, 20)
        face = [f for f in part.faces() if f.geom_type.name == "CYLINDER"][0]
    bound = int(_rss() + 150 * 2**20)
    exc = _refused_quickly(lambda: texcad.texture(part, face, "builtin:stones", height=0.5, pitch=1e-6, max_memory=bound))
    assert "GiB of memory" in str(exc)
    p = _named(exc)
    assert 0.01 < p < 1.0
    tx = texcad.texture(part, face, "builtin:stones", height=0.5, pitch=p, max_memory=bound)  # the named pitch fits
    assert tx.mesh.is_watertight


def test_a_zone_with_a_tiny_pitch_is_refused_before_allocating():
    """Zones on a CAD part: each zone's faces at its own pitch are estimated before
    any adapter allocates."""
    build123d = pytest.importorskip("build123d")
    import texcad
    from texcad.util.resources import _rss

    part = build123d.Box(20, 20, 20)
    faces = part.faces().sort_by(build123d.Axis.Z)
    bound = int(_rss() + 150 * 2**20)
    zones = [(faces[-1], "builtin:stones", {"pitch": 1e-6}), (faces[0], "builtin:diamond_knurl")]
    exc = _refused_quickly(lambda: texcad.texture(part, zones, height=0.5, pitch=0.5, max_memory=bound))
    assert "GiB of memory" in str(exc) and 0.01 < _named(exc) < 1.0


def test_face_segments_estimates_its_outline_first():
    build123d = pytest.importorskip("build123d")
    from texcad.brep import face_segments
    from texcad.util import memory_limit
    from texcad.util.resources import _rss

    face = build123d.Box(20, 20, 20).faces()[0].wrapped
    with memory_limit(_rss() + 50 * 2**20):
        exc = _refused_quickly(lambda: face_segments(face, 1e-6))
    assert "sample it every" in str(exc)
    assert len(face_segments(face, 0.5)) == 160


def test_a_tiny_pitch_on_a_mesh_is_refused_before_refining():
    trimesh = pytest.importorskip("trimesh")
    import texcad
    from texcad.util.resources import _rss

    m = trimesh.creation.icosphere(subdivisions=2, radius=10)
    bound = int(_rss() + 150 * 2**20)
    exc = _refused_quickly(lambda: texcad.texture(m, None, "builtin:stones", height=0.5, pitch=1e-6, max_memory=bound))
    p = _named(exc)
    tx = texcad.texture(m, None, "builtin:stones", height=0.5, pitch=p, max_memory=bound)  # the named pitch fits
    assert tx.mesh.is_watertight


def test_a_huge_picture_is_refused_naming_a_width_that_fits(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    from texcad.render import render_part
    from texcad.solid import Mesh
    from texcad.util import memory_limit
    from texcad.util.resources import _rss

    b = trimesh.creation.box((20, 10, 5))
    mesh = Mesh(b.vertices, b.faces)
    with memory_limit(_rss() + 100 * 2**20):
        exc = _refused_quickly(lambda: render_part(mesh, tmp_path / "x.png", width=200000))
        w = int(_named(exc, "width"))
        assert 100 < w < 200000
        render_part(mesh, tmp_path / "x.png", width=w)
    assert (tmp_path / "x.png").stat().st_size > 0


def test_a_large_image_is_refused_before_decoding_naming_a_size_that_fits(tmp_path):
    import numpy as np
    from PIL import Image

    from texcad.sources.image import read_gray
    from texcad.util import memory_limit
    from texcad.util.resources import _rss

    p = tmp_path / "big.png"
    Image.fromarray(np.zeros((3000, 4000), np.uint8)).save(p)  # 12 Mpx: 480 MB to read
    with memory_limit(_rss() + 100 * 2**20):
        exc = _refused_quickly(lambda: read_gray(p))
        import re

        w, h = map(int, re.search(r"at most (\d+) x (\d+) px", str(exc)).groups())
        assert w < 4000 and h < 3000 and abs(w / h - 4 / 3) < 0.01
        small = tmp_path / "small.png"
        Image.fromarray(np.zeros((h, w), np.uint8)).save(small)
        assert read_gray(small).shape == (h, w)  # the size named fits


def test_peak_rss_is_the_child_s_own_peak_not_its_parent_s():
    """A small child of a process that held 300 MB reads its own high-water mark
    (VmHWM), where ``ru_maxrss`` carries the parent's over exec."""
    import subprocess
    import sys

    big = bytearray(300 << 20)
    big[::4096] = b"x" * len(big[::4096])  # touched: resident
    code = "import resource, texcad.util as u; print(u.peak_rss() >> 20, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss >> 10)"
    own, inherited = map(int, subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split())
    del big
    print(f"child's own peak {own} MB, ru_maxrss {inherited} MB")
    assert own < 250  # ru_maxrss reads >= 300 here (Linux keeps it over fork and exec)


def test_a_bound_below_what_the_process_holds_is_named():
    """Under a max_memory bound the process already exceeds, the refusal names the
    bound and what the process holds in MiB (not "0.0 GiB available")."""
    from texcad.errors import ResourceError
    from texcad.util.resources import _rss, memory_limit, require_memory

    held = _rss()
    bound = min(held // 2, 512 * 2**20)  # under 1 GiB: said in MiB (a full-suite worker holds GiBs)
    with memory_limit(bound), pytest.raises(ResourceError) as err:
        require_memory(2**20, "a 1 MiB job", "allow more (max_memory)")
    said = str(err.value)
    import re

    got = re.search(r"max_memory bound of (\d+) MiB leaves 0 MiB \(the process holds ([\d.]+) (MiB|GiB)\)", said)
    assert got and abs(int(got[1]) - bound / 2**20) <= 1
    assert float(got[2]) * (2**10 if got[3] == "GiB" else 1) >= int(got[1])  # holds more than the bound
    assert "0.0 GiB" not in said
