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

__all__ = [
    'CheckReport',
    'check',
    'render_check',
    'SeamGap',
    'seam_gap',
]
