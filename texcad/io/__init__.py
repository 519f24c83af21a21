"""Files: STL and 3MF for slicers (writers beside readers), STEP for CAD, one
:func:`export` that dispatches on the file's extension.
"""


from .export import (
    write_stl,
    write_3mf,
    export,
    slicer_settings,
    cura_settings,
    single_run,
    slicer_layout,
    extra_perimeter_cut,
    SlicerLayout,
)
from .read import (
    read_part,
    read_mesh,
    load_mesh,
    UNITS_MM,
)
from .step import (
    write_step,
    read_step,
)

__all__ = [
    'write_stl',
    'write_3mf',
    'export',
    'slicer_settings',
    'cura_settings',
    'single_run',
    'slicer_layout',
    'extra_perimeter_cut',
    'SlicerLayout',
    'read_part',
    'read_mesh',
    'load_mesh',
    'UNITS_MM',
    'write_step',
    'read_step',
]
