"""Checks on finished parts: the gate every result passes, watertight, manifold, volume,
overhang area, seam gap, slicers.
"""


from .gate import (
    Expectation,
    GateReport,
    ShellReport,
    gate,
    gate_shells,
    shell_report,
)
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
    extra_support,
    SUPPORT_TYPES,
)

__all__ = [
    'Expectation',
    'GateReport',
    'ShellReport',
    'gate',
    'gate_shells',
    'shell_report',
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
    'extra_support',
    'SUPPORT_TYPES',
]
