"""Stage adapters, one per kind of target: each places the texture on its target
(frames, parameterization, outline, region) and says how to make the relief, join
it to the part and make its B-rep (:class:`~texcad.targets.base.Adapter`).

:data:`ADAPTERS` is the registry the driver (:func:`texcad.pipeline.driver.run`)
asks in order; the first adapter that accepts a target (and does not decline on a
closer look) textures it.
"""

from .base import Adapter, Decline
from .extrusion import ExtrusionAdapter
from .faces import FacesAdapter
from .mesh import MeshAdapter
from .plane import PlaneAdapter
from .plate import Plate, PlateAdapter
from .surface import SurfaceAdapter

#: The adapters, in the order the driver asks them (the any-faces adapter last: it
#: takes every CAD target with faces).
ADAPTERS: list = [MeshAdapter(), PlaneAdapter(), ExtrusionAdapter(), SurfaceAdapter(), PlateAdapter(), FacesAdapter()]

__all__ = ["ADAPTERS", "Adapter", "Decline", "ExtrusionAdapter", "FacesAdapter", "MeshAdapter", "PlaneAdapter", "Plate",
           "PlateAdapter", "SurfaceAdapter"]
