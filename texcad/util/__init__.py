"""Shared plumbing for every stage: atomic file writes, parameter checks, memory
estimates before big allocations, progress reporting.
"""


from .atomic import (
    atomic_path,
)
from .checks import (
    positive,
)
from .progress import (
    Progress,
    StageReporter,
    report,
    subrange,
)
from .resources import (
    available_memory,
    require_memory,
    texture_bytes,
    fitting_pitch,
)
from .vectors import (
    parse_vector,
    smoothstep,
)

__all__ = [
    'atomic_path',
    'positive',
    'Progress',
    'StageReporter',
    'report',
    'subrange',
    'available_memory',
    'require_memory',
    'texture_bytes',
    'fitting_pitch',
    'parse_vector',
    'smoothstep',
]
