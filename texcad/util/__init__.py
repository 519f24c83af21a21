"""Shared plumbing for every stage: atomic file writes, parameter checks, memory
estimates before big allocations, progress reporting, row-parallel work on threads.
"""


from .atomic import (
    atomic_path,
)
from .checks import (
    positive,
)
from .parallel import (
    beside,
    one_blas_thread,
    split_rows,
    threads,
)
from .progress import (
    Progress,
    StageReporter,
    report,
    subrange,
)
from .runs import (
    runs_within,
)
from .rows import (
    argsort_ints,
    colmax,
    colmin,
    rowall,
    rowany,
    rowdot,
    rowmax,
    rowmin,
    rownorm,
    rowsum,
)
from .resources import (
    peak_rss,
    available_memory,
    require_memory,
    texture_bytes,
    fitting_pitch,
    finest_pitch,
    require_pitch,
    memory_limit,
)
from .vectors import (
    axis_word,
    parse_vector,
    rotation_to_z,
    smoothstep,
)

__all__ = [
    "one_blas_thread",
    'atomic_path',
    'positive',
    'beside',
    'split_rows',
    'threads',
    'Progress',
    'StageReporter',
    'report',
    'subrange',
    'argsort_ints',
    'colmax',
    'colmin',
    'rowall',
    'rowany',
    'rowdot',
    'rowmax',
    'rowmin',
    'rownorm',
    'rowsum',
    'runs_within',
    'peak_rss',
    'available_memory',
    'require_memory',
    'texture_bytes',
    'fitting_pitch',
    'finest_pitch',
    'require_pitch',
    'memory_limit',
    'axis_word',
    'parse_vector',
    'smoothstep',
    'rotation_to_z',
]
