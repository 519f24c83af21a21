"""texcad: support-free textured solids for additive manufacturing.

Turn a texture sample (an image, a scan, or a built-in) into a watertight textured
solid on a build123d or CadQuery part, exported as STL/3MF. Units are millimetres
and degrees everywhere.

Pipeline (one module per stage)::

    Heightmap (heightmap, imageio, textures) -> mesh -> solid (fuse) -> export / render
"""

from __future__ import annotations

from .errors import GeometryError, InputError, ParameterError, ResourceError, TexcadError, TexcadWarning
from .export import export, write_3mf, write_stl
from .heightmap import Heightmap
from .mesh import Mesh, edge_report, grid_solid, heightfield_slab
from .pipeline import TexturedPart, plate_base, textured_plate
from .render import render_heightmap
from .solid import fuse, shape_to_mesh, to_manifold
from .scan import ScanReport, read_scan, scan_to_heightmap, scan_to_png
from .textures import DEFAULT_TEXTURE, builtin, builtin_names, contact_sheet, load_texture

from . import brep, quality
from .brep import read_step, write_step
from .check import CheckReport, check, read_part
from .mapping import MAPPINGS, HeightLimit, MappedSurface, TexturedSurface, fit_texture, map_texture, slab_mesh, textured_surface
from .printability import (
    LimitReport,
    edge_ramp,
    limit_overhangs,
    limit_overhangs_mapped,
    orientation,
    overhang_area,
    thin_features,
)
from .seams import SeamGap, seam_gap
from .surface import SURFACE_KINDS, Profile, Surface
from .synthesis import naive_quilt, synthesize

__version__ = "0.1.0"

# The CAD layer (texcad.cad) imports build123d and OCP, about 4 s; it is loaded on
# first use of one of these names, so that `import texcad` and the CLI's light
# commands (textures, synth, scan, check) start fast.
_CAD_NAMES = {
    "Textured": "Textured",
    "texture": "texture",
    "textured": "textured",
    "show": "show",
    "display_shape": "display_shape",
    "load_mesh": "load_mesh",
    "render_part": "render",
}


def __getattr__(name: str):
    if name in _CAD_NAMES:
        from . import cad

        value = getattr(cad, _CAD_NAMES[name])
        globals()[name] = value
        return value
    raise AttributeError(f"module 'texcad' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_CAD_NAMES))

__all__ = [
    "TexcadError",
    "InputError",
    "ParameterError",
    "GeometryError",
    "ResourceError",
    "TexcadWarning",
    "Heightmap",
    "builtin",
    "builtin_names",
    "load_texture",
    "DEFAULT_TEXTURE",
    "contact_sheet",
    "scan_to_heightmap",
    "scan_to_png",
    "read_scan",
    "ScanReport",
    "Mesh",
    "heightfield_slab",
    "grid_solid",
    "edge_report",
    "shape_to_mesh",
    "to_manifold",
    "fuse",
    "TexturedPart",
    "plate_base",
    "textured_plate",
    "write_stl",
    "write_3mf",
    "export",
    "render_heightmap",
    "synthesize",
    "naive_quilt",
    "quality",
    "check",
    "CheckReport",
    "read_part",
    "LimitReport",
    "edge_ramp",
    "limit_overhangs",
    "limit_overhangs_mapped",
    "orientation",
    "overhang_area",
    "thin_features",
    "Profile",
    "Surface",
    "SURFACE_KINDS",
    "MAPPINGS",
    "HeightLimit",
    "MappedSurface",
    "TexturedSurface",
    "fit_texture",
    "map_texture",
    "slab_mesh",
    "textured_surface",
    "SeamGap",
    "seam_gap",
    "brep",
    "Textured",
    "texture",
    "textured",
    "show",
    "display_shape",
    "load_mesh",
    "render_part",
    "read_step",
    "write_step",
]
