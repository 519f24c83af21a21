"""Stage 5, solids as meshes: watertight slabs, lean triangulations, the manifold3d union,
repair. numpy, scipy and manifold3d only; everything OCCT is in :mod:`texcad.brep`.
"""


from .boolean import (
    to_manifold,
    from_manifold,
    fuse,
    retain_freed_memory,
)
from .lean import (
    DEFAULT_TOLERANCE,
    MAX_FRACTION,
    check_tolerance,
    triangulate,
    surface_error,
    mesh_error,
    boundary_chains,
    grid_distance,
    tiled_triangulation,
    BORDER_GRID,
    TILE,
)
from .mesh import (
    Mesh,
    grid_faces,
    heightfield_slab,
    grid_solid,
    edge_report,
    closed_and_oriented,
    shells,
    edge_slot_pairs,
    surface_slab,
    shared_faces,
)
from .rtin import (
    BLOCK,
    rtin_triangles,
    grid_error,
    lean_grid,
)
from .intersect import box_cells, self_intersections
from .repair import cavity_faces, repair_closed
from .subdivide import (
    refine,
    tessellate,
    flip_edges,
    vertex_normals,
    offset_directions,
    face_normals,
    edge_lengths,
)

__all__ = [
    'to_manifold',
    'from_manifold',
    'fuse',
    'retain_freed_memory',
    'TILE',
    'DEFAULT_TOLERANCE',
    'MAX_FRACTION',
    'check_tolerance',
    'triangulate',
    'surface_error',
    'mesh_error',
    'grid_distance',
    'tiled_triangulation',
    'BORDER_GRID',
    'TILE',
    'boundary_chains',
    'Mesh',
    'grid_faces',
    'heightfield_slab',
    'grid_solid',
    'edge_report',
    'closed_and_oriented',
    'shells',
    'edge_slot_pairs',
    'surface_slab',
    'shared_faces',
    'BLOCK',
    'rtin_triangles',
    'grid_error',
    'lean_grid',
    'self_intersections',
    'repair_closed',
    'cavity_faces',
    'box_cells',
    'refine',
    'tessellate',
    'flip_edges',
    'vertex_normals',
    'offset_directions',
    'face_normals',
    'edge_lengths',
]
