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
    lean_slab_mesh,
    developed_field,
)
from .param import (
    Distortion,
    FaceGrid,
    locate,
    lay_grid,
    measure_distortion,
    separable_coordinates,
    lscm_coordinates,
    band_coordinates,
    vertex_normals,
    concave_convex,
    point_scales,
    metric_tables,
    cell_mask,
    grid_slab,
)
from .modes import (
    CUT_FLOOR,
    ModeSheets,
    mode_sheets,
)
from .projection import (
    PROJECTIONS,
    Projection,
    TileSampler,
    parse_axis,
    sample_heights,
    frame,
)
from .region import (
    Region,
    REGION_KINDS,
    bed_faces,
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
    'lean_slab_mesh',
    'developed_field',
    'Distortion',
    'FaceGrid',
    'locate',
    'lay_grid',
    'measure_distortion',
    'separable_coordinates',
    'lscm_coordinates',
    'band_coordinates',
    'vertex_normals',
    'concave_convex',
    'point_scales',
    'metric_tables',
    'cell_mask',
    'grid_slab',
    'CUT_FLOOR',
    'ModeSheets',
    'mode_sheets',
    'PROJECTIONS',
    'Projection',
    'TileSampler',
    'parse_axis',
    'sample_heights',
    'frame',
    'Region',
    'REGION_KINDS',
    'bed_faces',
    'Profile',
    'ProfileSample',
    'FunctionPiece',
    'Corner',
    'Surface',
    'SURFACE_KINDS',
]
