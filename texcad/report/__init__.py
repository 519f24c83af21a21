"""Checks on finished parts: watertight, manifold, volume, overhang area, seam gap.
"""


from .report import (
    CheckReport,
    check,
    render_check,
)
from .seams import (
    SeamGap,
    seam_gap,
)
from .slicer import (
    find_slicer,
    SliceReport,
    slice_mesh,
    read_gcode,
    support_near,
    SUPPORT_TYPES,
)

__all__ = [
    'CheckReport',
    'check',
    'render_check',
    'SeamGap',
    'seam_gap',
    'find_slicer',
    'SliceReport',
    'slice_mesh',
    'read_gcode',
    'support_near',
    'SUPPORT_TYPES',
]
