"""Stage 5, solids: meshes, watertight slabs, the manifold3d union, OCCT shapes and the
B-rep (the texture as B-spline faces sewn into the body).
"""


from .boolean import (
    shape_to_mesh,
    to_manifold,
    from_manifold,
    fuse,
    retain_freed_memory,
)
from .brep import (
    grid_surface,
    grid_face,
    grid_brep,
    textured_plane_face,
    replace_face,
    fuse_solids,
    check_shape,
    volume,
    surface_grid,
    grid_flux,
    shape_mesh,
    mesh_face,
    edge_points,
    face_segments,
    inside,
    sample_segments,
)
from .mesh import (
    Mesh,
    grid_faces,
    heightfield_slab,
    grid_solid,
    edge_report,
)
from .occt import (
    to_topods,
    explore,
    solids_of,
    faces_of,
    as_array,
    compound,
)

__all__ = [
    'shape_to_mesh',
    'to_manifold',
    'from_manifold',
    'fuse',
    'retain_freed_memory',
    'grid_surface',
    'grid_face',
    'grid_brep',
    'textured_plane_face',
    'replace_face',
    'fuse_solids',
    'check_shape',
    'volume',
    'surface_grid',
    'grid_flux',
    'shape_mesh',
    'mesh_face',
    'edge_points',
    'face_segments',
    'inside',
    'sample_segments',
    'Mesh',
    'grid_faces',
    'heightfield_slab',
    'grid_solid',
    'edge_report',
    'to_topods',
    'explore',
    'solids_of',
    'faces_of',
    'as_array',
    'compound',
]
