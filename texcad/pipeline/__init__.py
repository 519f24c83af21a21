"""The orchestration: one verb, :func:`texture`, that runs the stages on a target
(a plate, a 2.5D surface, a face of a CAD part) and returns a :class:`Textured`.
"""


from .ops import (
    cad_op,
    fillet,
    mirror,
    pattern,
    OPS,
    OP_VOLUME_TOLERANCE,
)
from .plate import (
    plate_base,
    textured_plate,
)
from .result import (
    Textured,
    as_textured,
)
from .scan import (
    scan_to_png,
)
from .surface import (
    textured_surface,
)
from .texture import (
    texture,
)

__all__ = [
    'cad_op',
    'fillet',
    'mirror',
    'pattern',
    'OPS',
    'OP_VOLUME_TOLERANCE',
    'plate_base',
    'textured_plate',
    'Textured',
    'as_textured',
    'scan_to_png',
    'textured_surface',
    'texture',
]
