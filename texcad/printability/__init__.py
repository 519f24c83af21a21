"""Stage 3, AM constraints: build direction, overhang measurement, the M-I edge
modification and the overhang limiter (paper section 2.1.3), thin features, and the
slicers' overhang rule they share (:mod:`texcad.printability.rule`).
"""


from .overhang import (
    orientation,
    check_critical_angle,
    unit_normals,
    face_areas,
    build_directions,
    print_rotation,
    LimitReport,
    edge_ramp,
    limit_overhangs,
    limit_overhangs_mapped,
    face_angles,
    overhang_mask,
    overhang_area,
    ThinFeatures,
    thin_features,
    DEFAULT_CRITICAL_ANGLE,
    ANGLE_TOLERANCE,
    SLICER_MARGIN,
    printable_lean_slab,
)
from .rule import (
    DEFAULT_LAYER_HEIGHT,
    SLICE_DEVIATION,
    allowance,
    overhang_angle,
    support_free_angle,
    slicer_margin,
)
from .profile import (
    limit_on_profile,
    measured,
)
from .relief import (
    ReliefLimit,
    limit_relief,
)

__all__ = [
    'orientation',
    'check_critical_angle',
    'unit_normals',
    'face_areas',
    'build_directions',
    'print_rotation',
    'LimitReport',
    'edge_ramp',
    'limit_overhangs',
    'limit_overhangs_mapped',
    'face_angles',
    'overhang_mask',
    'overhang_area',
    'ThinFeatures',
    'thin_features',
    'DEFAULT_CRITICAL_ANGLE',
    'ANGLE_TOLERANCE',
    'SLICER_MARGIN',
    'printable_lean_slab',
    'DEFAULT_LAYER_HEIGHT',
    'SLICE_DEVIATION',
    'allowance',
    'overhang_angle',
    'support_free_angle',
    'slicer_margin',
    'limit_on_profile',
    'measured',
    'ReliefLimit',
    'limit_relief',
]
