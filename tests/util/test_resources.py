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
    texcad.texture(box, box.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.0, pitch=0.05, tolerance=0)
except texcad.ResourceError as e:
    print("ResourceError:", e)
    sys.exit(3)
"""


def test_an_address_space_limit_gives_a_resource_error_not_a_crash():
    """The issue's case: a 157 x 128 mm face at 0.05 mm under a 3 GiB limit (it used
    8.7 GB, and under a 6 GB limit the process died with a segmentation fault)."""
    r = subprocess.run([sys.executable, "-c", LIMITED], capture_output=True, text=True, timeout=300)
    assert r.returncode == 3, r.stderr[-2000:]
    assert "GiB of memory" in r.stdout and "use pitch >=" in r.stdout


def test_available_memory_is_positive():
    assert available_memory() > 2**20
