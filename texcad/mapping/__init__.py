"""Stage 4, mapping: 2.5D surfaces (a profile curve extruded, paper section 2.2) and the
distance- and angle-preserving mappings of a texture onto them (algorithms 1 and 2).
"""


from .map import (
    MAPPINGS,
    HeightLimit,
    MappedSurface,
    fit_texture,
    map_texture,
    column_positions,
    slab_mesh,
)
from .surface import (
    Profile,
    ProfileSample,
    FunctionPiece,
    Corner,
    Surface,
    SURFACE_KINDS,
)

__all__ = [
    'MAPPINGS',
    'HeightLimit',
    'MappedSurface',
    'fit_texture',
    'map_texture',
    'column_positions',
    'slab_mesh',
    'Profile',
    'ProfileSample',
    'FunctionPiece',
    'Corner',
    'Surface',
    'SURFACE_KINDS',
]
