"""Shared by the docs/make_*.py scripts (run as ``python docs/make_NAME.py``)."""

from PIL import ImageFont


def font(size: int):
    """DejaVu Sans at ``size`` px if installed, else Pillow's default font."""
    for name in ("DejaVuSans.ttf", "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"):
        try:
            return ImageFont.truetype(name, size)
        except OSError:
            continue
    return ImageFont.load_default()
