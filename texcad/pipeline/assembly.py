"""The result of texturing one solid of an assembly: the textured solid with the
other solids as they were, written as separate bodies (one STL of several closed
bodies, one 3MF part per solid, a STEP compound, a picture of all). Lengths in mm.
"""

from __future__ import annotations

import functools
from typing import Any, Sequence

from ..brep.assembly import all_bodies, body_names
from ..targets.assembly import AssemblySplit
from .result import Textured

__all__ = ["AssemblyTextured", "assembly_result", "write_assembly", "one_mesh", "check_printed"]


def write_assembly(textured: Any, index: int, others: Sequence[Any], other_meshes: Sequence[Any], path: Any, *,
                   separate_texture: bool = False, name: "str | None" = None):
    """Write a textured solid with the other solids of its assembly, atomically: STL
    one file of several closed bodies, 3MF one named part per solid (the textured
    one as base and texture parts with ``separate_texture``), STEP a compound, PNG a
    picture of all. Returns the path."""
    from pathlib import Path

    from ..io import export, write_3mf, write_step
    from ..render import render_part

    p = Path(path)
    suffix = p.suffix.lower()
    names = body_names(index, len(others) + 1)
    if suffix == ".png":
        return render_part(all_bodies(textured.mesh, other_meshes), p)
    if suffix == ".3mf":
        first = [("base", textured.base_mesh), ("texture", textured.texture_mesh)] if separate_texture else \
            [(names[0], textured.mesh)]
        write_3mf(first + list(zip(names[1:], other_meshes)), p, name=name or p.stem)
        return p
    if suffix in (".step", ".stp"):
        from ..brep import compound, to_topods

        write_step(compound([to_topods(textured.shape)] + [to_topods(s) for s in others]), p, name=name or p.stem)
        return p
    printed = getattr(textured, "printed_mesh", None)  # an AssemblyTextured's, made and checked once
    return export(printed if printed is not None else one_mesh(all_bodies(textured.mesh, other_meshes)), p, name=name)


def one_mesh(mesh: Any):
    """An assembly's bodies as one mesh an STL can hold: as they are when they lie
    apart; where they overlap or touch (solids side by side, a solid stacked on a
    raised texture), their union (manifold3d, :func:`texcad.solid.overlap.union_bodies`),
    which is what a slicer prints from such a file, told in a TexcadWarning. Either
    way gated as a closed, oriented, non-overlapping mesh (:func:`texcad.report.gate.gate_shells`).
    Lengths in mm."""
    import warnings

    import numpy as np

    from ..errors import TexcadWarning
    from ..report.gate import gate_shells
    from ..solid import Mesh
    from ..solid.overlap import describe_overlaps, overlapping_bodies, split_bodies, union_bodies

    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    split = split_bodies(v, f)
    found = overlapping_bodies(v, f, split=split)
    if found:
        uv, uf, note = union_bodies(v, f, split=split)
        warnings.warn(f"the assembly's solids meet ({describe_overlaps(found, split)}): the STL holds their union ({note}), "
                      "as a slicer prints them; the 3MF and STEP keep them apart", TexcadWarning, stacklevel=3)
        mesh = Mesh(uv.astype(np.float32), uf.astype(np.uint32))
    gate_shells(mesh, what="assembly's STL")
    return mesh


class AssemblyTextured(Textured):
    """A :class:`texcad.Textured` of one solid of an assembly, with the other solids
    kept as they were (made by :func:`assembly_result`). Lengths in mm.

    Attributes:
        solid_index: the textured solid's index in the assembly (from 0).
        others: the other solids (OCP ``TopoDS_Solid``), in order.
        tolerance: the chord tolerance of the other solids' meshes, mm.
    """

    def __init__(self, textured: Textured, split: AssemblySplit, tolerance: float = 0.01) -> None:
        super().__init__(textured.stages)
        self.info = dict(textured.info, solid=split.index, solids=split.count)
        for key in ("faces", "zone_reliefs"):  # the patches' faces as texcad faces numbers the assembly's
            if isinstance(self.info.get(key), list) and split.face_numbers:
                self.info[key] = _renumbered(self.info[key], split.face_numbers)
        self.solid_index, self.others, self.tolerance = split.index, split.others, tolerance

    @functools.cached_property
    def other_meshes(self) -> list:
        """The other solids' meshes (their tessellation at ``tolerance`` mm), in order."""
        from ..brep import closed_shape_mesh

        return [closed_shape_mesh(s, tolerance=self.tolerance) for s in self.others]  # per kept solid: healed if OCCT meshes it open

    @property
    def bodies(self) -> list:
        """Every body's mesh: the textured solid first, then the others in order."""
        return [self.mesh] + self.other_meshes

    @property
    def assembly_mesh(self):
        """All bodies as one mesh of several closed bodies, as they are (the STL holds
        :func:`one_mesh` of it: their union where they meet)."""
        return all_bodies(self.mesh, self.other_meshes)

    @functools.cached_property
    def printed_mesh(self):
        """All bodies as the STL holds them and a slicer prints them: as they are
        where they lie apart, their union where they meet (:func:`one_mesh`, with its
        warning), its volume checked against the bodies' (:func:`check_printed`).
        ``printed_mesh.volume`` is the assembly's printed volume, mm^3 (not the sum of
        the solids' volumes where they overlap)."""
        mesh = one_mesh(self.assembly_mesh)
        check_printed(mesh, self.mesh, self.other_meshes, slack=float(self.gate.volume_slack or 0.0))
        return mesh

    @functools.cached_property
    def buried_mm3(self) -> float:
        """mm^3 of the texture that lies inside the other solids, so is not printed:
        the textured solid's volume inside them less the plain solid's (negative for an
        engraving that another solid fills); 0 when the solids lie apart."""
        from ..solid.overlap import volume_inside

        return volume_inside(self.mesh, self.other_meshes) - volume_inside(self.base_mesh, self.other_meshes)

    def export(self, path: Any, *, separate_texture: bool = False, name: "str | None" = None):
        """Write the textured solid with the others as separate bodies (:func:`write_assembly`)."""
        return write_assembly(self, self.solid_index, self.others, self.other_meshes, path,
                              separate_texture=separate_texture, name=name)

    def render(self, path: Any, **kwargs: Any):
        """PNG picture of every body, seen from the side that shows the texture unless
        ``view=`` says otherwise (:func:`texcad.render.texture_view`)."""
        from ..render import render_part, texture_view

        if kwargs.get("view") is None:
            kwargs["view"] = texture_view(self.mesh, self.base_mesh)
        return render_part(self.assembly_mesh, path, **kwargs)

    def __repr__(self) -> str:
        return f"{Textured.__repr__(self)[:-1]}, solid {self.solid_index} of {len(self.others) + 1})"


def check_printed(printed: Any, textured: Any, others: Sequence[Any], *, slack: float = 0.0) -> None:
    """Check an assembly's printed mesh (``printed``: the union of the bodies where
    they meet) against its bodies: it must enclose ``vol(A) + vol(O) - vol(A ^ O)``
    mm^3, ``A`` the textured solid's mesh and ``O`` the union of the ``others``,
    within ``slack`` mm^3 (the gate's) plus 1e-6 of the volume and the textured solid's
    area times :data:`texcad.solid.overlap.CONTACT_GAP` (the union snaps bodies a
    micrometre apart onto each other).

    Raises:
        GeometryError: naming both volumes: the union lost or doubled a body or texture.
    """
    from ..errors import GeometryError
    from ..solid.overlap import CONTACT_GAP, union_volume, volume_inside

    if not others:
        return
    want = float(textured.volume) + union_volume(others) - volume_inside(textured, others)
    got = float(printed.volume)
    slack = slack + CONTACT_GAP * float(textured.area)
    if abs(got - want) > slack + 1e-6 * abs(want) + 1e-6:
        raise GeometryError(
            f"the assembly's bodies united for the STL enclose {got:.1f} mm3 but the textured solid and the others "
            f"give {want:.1f} mm3 (accepted difference {slack:.2f} mm3): the union lost or doubled part of them; "
            "write 3MF or STEP (bodies kept apart), or move the solids apart, and please report this")


def _renumbered(items: list, numbers: tuple) -> list:
    """``items`` (dicts of a result's info) with each ``"faces"`` list of face indices
    of the solid mapped through ``numbers`` (new dicts; the rest as they are)."""
    return [dict(d, faces=[int(numbers[i]) for i in d["faces"]]) if isinstance(d, dict) and isinstance(d.get("faces"), list)
            else d for d in items]  # fmt: skip


def assembly_result(textured: Textured, split: AssemblySplit, *, tolerance: float = 0.01) -> AssemblyTextured:
    """The result of solid ``split.index`` (its mesh, volume, gate: that solid's)
    made the result of the whole assembly: ``info["solid"]`` is the solid textured,
    ``info["solids"]`` their number; ``others`` / ``other_meshes`` the other solids
    as they were; ``bodies`` every body's mesh; ``export`` writes all of them as
    separate bodies (:func:`write_assembly`). Where more than 1 % of the texture lies
    inside the other solids (a textured face partly covered by another solid) a
    TexcadWarning says how much (``buried_mm3``): that part is not printed."""
    import warnings

    from ..errors import TexcadWarning

    out = AssemblyTextured(textured, split, tolerance)
    change = float(out.mesh.volume) - float(out.base_mesh.volume)
    buried = out.buried_mm3 if abs(change) > 0 else 0.0
    if abs(buried) > 0.01 * abs(change):
        what = "lies inside" if buried > 0 else "is engraved where"
        warnings.warn(f"{abs(buried):.1f} mm3 of the texture ({100 * abs(buried / change):.0f} % of its {abs(change):.1f} mm3) "
                      f"{what} the other solid(s) of the assembly, so it is not printed (the STL holds their union): "
                      "texture a face no other solid covers, or move the solids apart", TexcadWarning, stacklevel=3)
    out.info["buried_mm3"] = buried
    return out
