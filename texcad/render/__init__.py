"""Pictures: heightmaps (hill-shaded), meshes (a z-buffer rasterizer), PNG files.
"""


from .heightmap import (
    hillshade,
    render_heightmap,
    contact_sheet,
)
from .raster import (
    camera,
    rasterize,
    render_mesh,
    height_image,
    write_png,
)
from .viewer import (
    render_part,
    texture_view,
    DEFAULT_VIEW,
    show,
    display_shape,
)

__all__ = [
    'hillshade',
    'render_heightmap',
    'contact_sheet',
    'camera',
    'rasterize',
    'render_mesh',
    'height_image',
    'write_png',
    'render_part',
    'texture_view',
    'DEFAULT_VIEW',
    'show',
    'display_shape',
]
