"""The one driver: :func:`run` takes every target through the same stages.

    options (validated once)
      -> adapter.place    where the texture goes (frames, parameterization, region)
      -> adapter.relief   the texture loaded, fitted, ramped, limited and meshed
      -> adapter.fuse     the relief joined to the part
      -> gate             the one independent check (texcad.report.gate)
      -> Textured         the one result

The adapter is chosen from :data:`texcad.targets.ADAPTERS` (the first that accepts
the target; one may decline after looking closer, e.g. a cylinder face that is not a
full strip of its extrusion). Progress fractions and the memory bound are the
driver's; what differs per target kind is in its adapter.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..contracts import Stages
from ..errors import GeometryError, ParameterError
from ..options import Options
from ..report.gate import gate
from ..solid import Mesh
from ..targets import ADAPTERS, Decline
from ..targets.assembly import assembly_split
from ..targets.budget import require_faces_memory
from ..targets.cad import FACE_NUMBERS, named_where
from ..util import memory_limit
from .assembly import assembly_result
from .result import Textured

__all__ = ["run"]


def _bodies_met(exc: Exception, placement: Any, ex: Any, options: Any) -> Exception:
    """The gate's failure ``exc`` on a part of several bodies whose shells now meet,
    told with the input bodies that lie closer than their textures reach (twice the
    height: a texture on each facing face), mm; ``exc`` itself otherwise."""
    from ..solid.overlap import close_bodies

    text = str(exc)
    if placement.bodies < 2 or ex.height <= 0 or not any(w in text for w in ("inside another body", "overlap")):
        return exc
    base = placement.base
    near = close_bodies(np.asarray(base.vertices), np.asarray(base.faces, np.int64), 2.0 * ex.height)
    if not near:
        return exc
    pairs = ", ".join(f"bodies {a + 1} and {b + 1} lie {d:.2f} mm apart" for a, b, d in near[:3])
    union = " (--union unites only bodies that overlap or touch)" if options.union else ""
    problem = text.split("; ")[0]
    return GeometryError(
        f"{problem}: in the input {pairs}{' ...' if len(near) > 3 else ''}, closer than their textures reach "
        f"(2 x {ex.height:.2f} mm), so the textures met{union}; leave their facing faces out of the region, use a "
        f"height under {min(d for _, _, d in near) / 2:.2f} mm, or move the bodies apart")


def _refused(target: Any, where: Any) -> ParameterError:
    from ..targets.cad import is_cad_target

    if where is None and is_cad_target(target):
        return ParameterError(
            "say which face to texture: texcad.texture(part, part.faces().sort_by(Axis.Z)[-1], texture) "
            "(build123d) or texcad.texture(wp, wp.faces('>Z'), texture) (CadQuery)"
        )
    return ParameterError(
        f"cannot texture a {type(target).__name__}: pass a build123d / CadQuery part with its face(s), a "
        "texcad.Surface or Profile, a texcad.Plate, or a mesh (a .stl / .3mf / .obj path, a texcad Mesh, a trimesh)"
    )


def run(target: Any, where: Any, texture: Any, options: Options) -> Textured:
    """Texture ``target`` at ``where`` with ``texture`` (see :func:`texcad.texture`):
    place, relief, fuse, gate. Lengths in mm, angles in degrees.

    Raises:
        TexcadError: a bad target, option or texture (ParameterError, InputError), a
            geometry that cannot be made or fails the gate (GeometryError), or more
            memory than allowed (ResourceError).
    """
    where = named_where(target, where)  # "top", "cylinder:all": the command line's face selectors
    split = assembly_split(target, where)  # several solids: the one that owns the faces alone, the others kept
    if split is not None:
        numbered = FACE_NUMBERS.set(split.face_numbers)  # messages name faces as texcad faces lists the assembly's
        try:
            return assembly_result(run(split.solid, where, texture, options), split)
        finally:
            FACE_NUMBERS.reset(numbered)
    with memory_limit(options.max_memory):
        require_faces_memory(target, where, texture, options)  # CAD faces: memory estimated before any allocation
        declined = None
        for adapter in ADAPTERS:  # asked in order (lazily: a mesh never loads OCCT); the first that does not decline
            if not adapter.accepts(target, where, options):
                continue
            try:
                placement = adapter.place(target, where, texture, options)
            except Decline as exc:
                declined = exc
                continue
            options.refuse(adapter.options, adapter.label)  # by the adapter that keeps the target
            relief = adapter.relief(placement, texture, options)
            fused = adapter.fuse(placement, relief, options)
            options.report(0.92, "checking the result (texcad's gate)")
            ex = adapter.expectation(placement, relief, fused)
            # a mesh kept in tiles (a plate too large for memory, texcad.pipeline.tiled) is gated tile by tile
            try:
                report = gate(fused.mesh, ex) if isinstance(fused.mesh, Mesh) else fused.mesh.gate(ex)
            except GeometryError as exc:
                raise _bodies_met(exc, placement, ex, options) from None
            options.report(1.0, "textured")
            return Textured(Stages(adapter, options, placement, relief, fused, report))
    if declined is not None:  # every adapter that took the target declined it on a closer look
        raise ParameterError(f"cannot texture this target: {declined}") from declined
    raise _refused(target, where)
