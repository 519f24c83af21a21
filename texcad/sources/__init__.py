"""Stage 1, input: textures as heights in mm.

A :class:`Heightmap` (``heights[row, col]`` in mm, ``pitch`` mm per pixel) from an
image (white = ``height``, black = on the surface), a built-in procedural texture, or
a 3-D scan (point cloud or mesh).
"""


from .heightmap import (
    Heightmap,
)
from .image import (
    read_gray,
    write_gray16,
    write_rgb8,
    rgb8_image,
    save_image,
)
from .scan import (
    ScanData,
    ScanReport,
    SCAN_SUFFIXES,
    read_scan,
    fit_plane,
    largest_rectangle,
    scan_to_heightmap,
)
from .solid_textures import (
    SOLID_TEXTURES,
    solid_texture,
)
from .textures import (
    PREFIX,
    BuiltinTexture,
    Param,
    BUILTINS,
    DEFAULT_TEXTURE,
    builtin,
    builtin_names,
    load_texture,
    parse_texture_spec,
)

__all__ = [
    'Heightmap',
    'read_gray',
    'write_gray16',
    'write_rgb8',
    'rgb8_image',
    'save_image',
    'ScanData',
    'ScanReport',
    'SCAN_SUFFIXES',
    'read_scan',
    'fit_plane',
    'largest_rectangle',
    'scan_to_heightmap',
    'SOLID_TEXTURES',
    'solid_texture',
    'PREFIX',
    'BuiltinTexture',
    'Param',
    'BUILTINS',
    'DEFAULT_TEXTURE',
    'builtin',
    'builtin_names',
    'load_texture',
    'parse_texture_spec',
]
