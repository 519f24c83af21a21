"""A scan to a heightmap PNG: the job behind ``texcad scan``."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..render import render_heightmap
from ..sources import Heightmap, ScanData, ScanReport, scan_to_heightmap

__all__ = ["scan_to_png"]


def scan_to_png(
    scan: "str | os.PathLike | np.ndarray | ScanData",
    out: str | os.PathLike,
    *,
    pitch: float,
    preview: str | os.PathLike | None = None,
    **options: Any,
) -> tuple[Heightmap, ScanReport]:
    """:func:`scan_to_heightmap`, then write the heightmap as a 16-bit grey PNG
    (black 0 mm, white ``report.max_height`` mm) and optionally a hill-shaded preview.

    The output folders are checked first and both files are written atomically, so a
    bad scan or a missing folder leaves nothing behind.

    Args:
        scan: as for :func:`scan_to_heightmap`.
        out: the heightmap PNG.
        pitch: mm per pixel.
        preview: optional PNG rendered with :func:`texcad.render.render_heightmap`.
        **options: passed to :func:`scan_to_heightmap`.
    """
    for target in (out, preview):
        if target is not None:
            folder = Path(target).parent
            if not folder.is_dir():
                raise InputError(f"output folder {str(folder)!r} does not exist; create it first")
    hm, report = scan_to_heightmap(scan, pitch=pitch, **options)
    if preview is not None:
        render_heightmap(hm, preview)
    hm.to_png(out)
    return hm, report
