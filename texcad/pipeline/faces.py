"""Nothing of its own any more: the any-faces method is the adapter
:class:`texcad.targets.FacesAdapter` (numerics in :mod:`texcad.targets.patches`).

``welded`` is re-exported here for :mod:`texcad.pipeline.surface` only, until the
union's welding has its own module in :mod:`texcad.solid`; then this module goes.
"""

from ..targets.patches import welded

__all__ = ["welded"]
