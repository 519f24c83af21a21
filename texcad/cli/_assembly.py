"""The result of texturing one solid of an assembly: the textured solid plus the
other solids as they were, written as separate bodies (one STL of several closed
bodies, one 3MF object of one part per solid, a STEP compound, a picture of all)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

__all__ = ["AssemblyResult"]


class AssemblyResult:
    """``textured`` (a :class:`texcad.Textured` of solid ``index``) with ``others``
    (build123d solids, in assembly order) for :meth:`export`; lengths in mm."""

    def __init__(self, textured: Any, index: int, others: Sequence[Any], *, tolerance: float = 0.01) -> None:
        from ..brep import shape_to_mesh

        self.textured, self.index, self.others = textured, index, list(others)
        self.other_meshes = [shape_to_mesh(s, tolerance=tolerance) for s in self.others]  # per kept solid

    def _names(self) -> list[str]:
        n = len(self.others) + 1
        order = [k for k in range(n) if k != self.index]
        return [f"solid {self.index} (textured)"] + [f"solid {k}" for k in order]

    @property
    def mesh(self):
        """All bodies as one mesh (each closed)."""
        from ..solid import Mesh

        meshes = [self.textured.mesh] + self.other_meshes
        offs = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
        return Mesh(np.concatenate([m.vertices for m in meshes]).astype(np.float32),
                    np.concatenate([m.faces.astype(np.int64) + o for m, o in zip(meshes, offs)]).astype(np.uint32))

    def export(self, path: "str | Path", *, separate_texture: bool = False, name: str | None = None) -> Path:
        from ..io import export, write_3mf, write_step
        from ..render import render_part

        p = Path(path)
        suffix = p.suffix.lower()
        if suffix == ".png":
            return render_part(self.mesh, p)
        if suffix == ".3mf":
            first = [("base", self.textured.base_mesh), ("texture", self.textured.texture_mesh)] if separate_texture else \
                [(self._names()[0], self.textured.mesh)]
            write_3mf(first + list(zip(self._names()[1:], self.other_meshes)), p, name=name or p.stem)
            return p
        if suffix in (".step", ".stp"):
            from ..brep import compound, to_topods

            write_step(compound([to_topods(self.textured.shape)] + [to_topods(s) for s in self.others]), p, name=name or p.stem)
            return p
        return export(self.mesh, p, name=name)
