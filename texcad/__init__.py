"""texcad: support-free textured solids for additive manufacturing.

Turn a texture sample (an image, a scan, or a built-in) into a watertight textured
solid on a build123d or CadQuery part, exported as STL/3MF for slicers and STEP for
CAD. Units are millimetres and degrees everywhere.

One verb and one result::

    import texcad
    result = texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], "builtin:stones", height=1.0)
    result.export("part.stl")       # or .3mf, .step, .png

The pipeline's stages are subpackages, in the order data flows through them::

    sources (images, built-ins, scans -> Heightmap) -> synthesis -> printability
      -> mapping (surfaces, faces) -> solid (meshes, union, B-rep)
      -> io (STL, 3MF, STEP) / render (PNG, viewer) / report (check)

:mod:`texcad.pipeline` runs them; :mod:`texcad.cli` is the ``texcad`` command.
"""

from __future__ import annotations

import importlib
import warnings

from .errors import GeometryError, InputError, ParameterError, ResourceError, TexcadError, TexcadWarning
from .sources import Heightmap, builtin, load_texture
from .mapping import Profile, Surface
from .solid import Mesh
from .synthesis import synthesize
from .printability import orientation
from .io import export, load_mesh
from .render import show
from .report import check
from .pipeline import Textured, texture

__version__ = "0.2.0"

__all__ = [
    "texture",
    "Textured",
    "Heightmap",
    "Surface",
    "Profile",
    "Mesh",
    "builtin",
    "load_texture",
    "synthesize",
    "orientation",
    "check",
    "export",
    "load_mesh",
    "show",
    "TexcadError",
    "InputError",
    "ParameterError",
    "GeometryError",
    "ResourceError",
    "TexcadWarning",
]

#: Names of texcad 0.1, kept for one release: ``old name -> (subpackage, new name)``.
ALIASES = {
    "textured_plate": ("pipeline", "textured_plate"),
    "textured_surface": ("pipeline", "textured_surface"),
    "plate_base": ("pipeline", "plate_base"),
    "textured": ("pipeline", "as_textured"),
    "render_part": ("render", "render_part"),
    "render_heightmap": ("render", "render_heightmap"),
    "display_shape": ("render", "display_shape"),
    "contact_sheet": ("render", "contact_sheet"),
    "write_stl": ("io", "write_stl"),
    "write_3mf": ("io", "write_3mf"),
    "read_step": ("io", "read_step"),
    "write_step": ("io", "write_step"),
    "read_part": ("io", "read_part"),
    "builtin_names": ("sources", "builtin_names"),
    "DEFAULT_TEXTURE": ("sources", "DEFAULT_TEXTURE"),
    "scan_to_heightmap": ("sources", "scan_to_heightmap"),
    "read_scan": ("sources", "read_scan"),
    "ScanReport": ("sources", "ScanReport"),
    "scan_to_png": ("pipeline", "scan_to_png"),
    "naive_quilt": ("synthesis", "naive_quilt"),
    "quality": ("synthesis", "quality"),
    "heightfield_slab": ("solid", "heightfield_slab"),
    "grid_solid": ("solid", "grid_solid"),
    "edge_report": ("solid", "edge_report"),
    "shape_to_mesh": ("solid", "shape_to_mesh"),
    "to_manifold": ("solid", "to_manifold"),
    "fuse": ("solid", "fuse"),
    "brep": ("solid", "brep"),
    "CheckReport": ("report", "CheckReport"),
    "seam_gap": ("report", "seam_gap"),
    "SeamGap": ("report", "SeamGap"),
    "LimitReport": ("printability", "LimitReport"),
    "edge_ramp": ("printability", "edge_ramp"),
    "limit_overhangs": ("printability", "limit_overhangs"),
    "limit_overhangs_mapped": ("printability", "limit_overhangs_mapped"),
    "overhang_area": ("printability", "overhang_area"),
    "thin_features": ("printability", "thin_features"),
    "SURFACE_KINDS": ("mapping", "SURFACE_KINDS"),
    "MAPPINGS": ("mapping", "MAPPINGS"),
    "HeightLimit": ("mapping", "HeightLimit"),
    "MappedSurface": ("mapping", "MappedSurface"),
    "fit_texture": ("mapping", "fit_texture"),
    "map_texture": ("mapping", "map_texture"),
    "slab_mesh": ("mapping", "slab_mesh"),
}


def __getattr__(name: str):
    if name in ALIASES:
        pkg, new = ALIASES[name]
        warnings.warn(
            f"texcad.{name} is deprecated and goes in the next release; use texcad.{pkg}.{new}",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(f"{__name__}.{pkg}"), new)
    raise AttributeError(f"module 'texcad' has no attribute {name!r}")
