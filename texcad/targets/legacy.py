"""Targets whose handlers still run their stages themselves (until each has its own
adapter): their output is wrapped in the same :class:`~texcad.contracts.Stages` and
passes the same gate (checks 1-3: closed, oriented shells, body count) before a
:class:`texcad.Textured` is made of it. Lengths in mm.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

from ..contracts import Fused, Placement, Relief, Stages
from ..errors import GeometryError
from ..options import Options
from ..report.gate import Expectation, gate, shell_report
from ..solid import Mesh
from .base import Adapter

__all__ = ["LegacyAdapter", "legacy_stages"]


@dataclass(frozen=True)
class LegacyParts:
    """What a handler made on demand: the texture body, the measured error, the
    B-rep's maker (each a zero-argument callable or a value), and why there is no B-rep."""

    texture_mesh: Any
    max_error: Any
    shape: Any
    layers: Any = None
    no_brep: str = "made from a mesh"


def _value(x: Any) -> Any:
    return x() if callable(x) and not isinstance(x, Mesh) else x


class LegacyAdapter(Adapter):
    """The adapter of a handler's finished result."""

    def __init__(self, kind: str, result_kind: str) -> None:
        self.kind, self.result_kind, self.label = kind, result_kind, f"a {kind}"

    def texture_mesh(self, stages: Stages) -> Mesh:
        tm = stages.fused.data.texture_mesh
        return super().texture_mesh(stages) if tm is None else _value(tm)

    def max_error(self, stages: Stages) -> "float | None":
        e = _value(stages.fused.data.max_error)
        return None if e is None else float(e)

    def brep(self, stages: Stages, fine: Any = None) -> Any:
        make = stages.fused.data.shape
        if make is None:
            raise GeometryError(f"this {self.result_kind} result has no B-rep ({stages.fused.data.no_brep}); write STL or 3MF instead")
        return make(fine=fine) if fine is not None else make()

    def layer_meshes(self, stages: Stages) -> list:
        layers = stages.fused.data.layers
        return super().layer_meshes(stages) if layers is None else list(_value(layers))


def legacy_stages(*, mesh: Mesh, base_mesh: Any, kind: str, result_kind: str, texture_mesh: Any = None,
                  max_error: Any = None, shape: "Callable | None" = None, heightmap: Any = None, limits: Any = None,
                  height_limits: Any = None, distortion: Any = None, mapped: Any = None, info: "dict | None" = None,
                  topo: Any = None, face_ids: tuple = (), bodies: "int | None" = None, layers: Any = None,
                  previous: Any = None, brep: bool = True) -> Stages:
    """Wrap a handler's result and put its mesh through the gate (checks 1-3)."""
    base = _value(base_mesh)
    if bodies is None:
        bodies = shell_report(base).bodies
    info = dict(info or {})
    parts = LegacyParts(texture_mesh, max_error, shape, layers, info.get("no_brep", "made from a mesh"))
    placement = Placement(kind, base, bodies, None, topo, tuple(face_ids), previous)
    relief = Relief(heightmap, limits, 0.0, 0.0, height_limits=tuple(height_limits or ()), distortion=distortion, mapped=mapped)
    fused = Fused(mesh, base, info, parts)
    report = gate(mesh, Expectation(bodies=bodies))
    return Stages(LegacyAdapter(kind, result_kind), Options(brep=brep), placement, relief, fused, report)
