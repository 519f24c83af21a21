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
from .batch import batch
from .targets.plate import Plate

__version__ = "0.3.0"

__all__ = [
    "texture",
    "Textured",
    "Heightmap",
    "Surface",
    "Profile",
    "Plate",
    "Mesh",
    "builtin",
    "load_texture",
    "synthesize",
    "orientation",
    "check",
    "batch",
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
