"""The result of texturing one solid of an assembly: the textured solid plus the
other solids as they were, written as separate bodies (one STL of several closed
bodies, one 3MF object of one part per solid, a STEP compound, a picture of all).
The writing is :func:`texcad.brep.assembly.write_assembly`, which the API's
assembly results use too."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

__all__ = ["AssemblyResult"]


class AssemblyResult:
    """``textured`` (a :class:`texcad.Textured` of solid ``index``) with ``others``
    (build123d solids, in assembly order) for :meth:`export`; lengths in mm."""

    def __init__(self, textured: Any, index: int, others: Sequence[Any], *, tolerance: float = 0.01) -> None:
        from ..brep import shape_to_mesh

        self.textured, self.index, self.others = textured, index, list(others)
        self.other_meshes = [shape_to_mesh(s, tolerance=tolerance) for s in self.others]  # per kept solid

    @property
    def mesh(self):
        """All bodies as one mesh (each closed)."""
        from ..brep.assembly import all_bodies

        return all_bodies(self.textured.mesh, self.other_meshes)

    def export(self, path: "str | Path", *, separate_texture: bool = False, name: str | None = None) -> Path:
        from ..brep.assembly import write_assembly

        return Path(write_assembly(self.textured, self.index, self.others, self.other_meshes, path,
                                   separate_texture=separate_texture, name=name))
