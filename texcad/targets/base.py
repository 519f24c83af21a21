"""What every target adapter is: a small class that places the texture on one kind
of target and says how to make its meshes and B-rep. The driver
(:func:`texcad.pipeline.driver.run`) calls, in order::

    adapter.place(target, where, texture, options) -> Placement
    adapter.relief(placement, texture, options)    -> Relief     (texture, ramps, limits, mesh)
    adapter.fuse(placement, relief, options)       -> Fused
    gate(fused.mesh, adapter.expectation(...))     -> GateReport

and, on demand, :meth:`Adapter.texture_mesh`, :meth:`Adapter.max_error` and
:meth:`Adapter.brep` from a result's :class:`~texcad.contracts.Stages`.
"""

from __future__ import annotations

from typing import Any

from ..contracts import Fused, Placement, Relief, Stages
from ..errors import GeometryError
from ..options import Options
from ..report.gate import Expectation
from ..solid import Mesh, to_manifold
from ..solid.boolean import welded_mesh

__all__ = ["Adapter", "Decline"]


class Decline(Exception):
    """Raised by an adapter's :meth:`~Adapter.place` when the target is not its kind
    after all (e.g. a cylinder face that is not a full strip of its extrusion); the
    driver then asks the next adapter."""


class Adapter:
    """One kind of target. Subclasses set :attr:`kind`, :attr:`label`,
    :attr:`options` and implement :meth:`accepts`, :meth:`place`, :meth:`relief`
    and :meth:`fuse`."""

    #: the target kind (``Placement.kind``)
    kind: str = ""
    #: how messages name the target ("a planar face")
    label: str = ""
    #: the option names this kind uses (others the caller gives are refused)
    options: frozenset = frozenset()
    #: the result's ``kind`` ("face", "surface", "plate", "mesh")
    result_kind: str = "face"

    def accepts(self, target: Any, where: Any, options: Options) -> bool:
        """Whether this adapter textures ``target`` at ``where``."""
        raise NotImplementedError

    def place(self, target: Any, where: Any, texture: Any, options: Options) -> Placement:
        raise NotImplementedError

    def relief(self, placement: Placement, texture: Any, options: Options) -> Relief:
        raise NotImplementedError

    def fuse(self, placement: Placement, relief: Relief, options: Options) -> Fused:
        raise NotImplementedError

    # -- the gate's expectation ---------------------------------------------------------
    def expectation(self, placement: Placement, relief: Relief, fused: Fused) -> Expectation:
        """What the gate checks the fused mesh against (volumes mm^3, lengths mm)."""
        return Expectation(
            bodies=placement.bodies,
            base=placement.base,
            selected=placement.selected,
            height=relief.reach,
            volume=relief.volume,
            volume_slack=relief.volume_slack,
            nominal_volume=relief.nominal_volume,
        )

    # -- on demand ----------------------------------------------------------------------
    def texture_mesh(self, stages: Stages) -> Mesh:
        """The texture alone: ``fused - base`` (manifold3d), mm."""
        return welded_mesh(to_manifold(stages.fused.mesh) - to_manifold(stages.fused.base_mesh))

    def max_error(self, stages: Stages) -> "float | None":
        """The measured largest distance (mm) between the relief mesh and the texture."""
        return stages.relief.max_error

    def brep(self, stages: Stages, fine: Any = None) -> Any:
        """The textured B-rep (an OCP ``TopoDS_Shape``) before its check; ``fine``:
        regions to tile finely (CAD operations). Raises GeometryError where there is none."""
        raise GeometryError(f"{self.label} has no B-rep; write STL or 3MF instead")

    def textured_on(self, stages: Stages) -> Any:
        """The B-rep this result's texture was put on (CAD operations replay on it,
        :mod:`texcad.pipeline.ops`): the untextured part, or None."""
        return stages.placement.topo

    def fine_frame(self, stages: Stages) -> Any:
        """The frame in which CAD operations ask for fine tiles (see
        :mod:`texcad.pipeline.ops`), or None."""
        return None

    def layer_meshes(self, stages: Stages) -> list:
        """One texture body per layer (several textures on one part), mm."""
        return [self.texture_mesh(stages)]
