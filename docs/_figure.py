"""Shared by the docs/make_*.py scripts (run as ``python docs/make_NAME.py``)."""

import importlib.util
from pathlib import Path

from PIL import ImageFont

TESTS = Path(__file__).resolve().parent.parent / "tests"


def load_test(relative: str):
    """A test file under ``tests/`` (e.g. ``"render/test_viewer.py"``) loaded as a
    module, for the screenshot scripts that run the same session as its test."""
    path = TESTS / relative
    spec = importlib.util.spec_from_file_location("texcad_docs_" + path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def font(size: int):
    """DejaVu Sans at ``size`` px if installed, else Pillow's default font."""
    for name in ("DejaVuSans.ttf", "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"):
        try:
            return ImageFont.truetype(name, size)
        except OSError:
            continue
    return ImageFont.load_default()
