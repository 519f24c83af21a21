"""The data that passes between the stages of :func:`texcad.texture`: small frozen
dataclasses with documented fields (lengths mm, volumes mm^3, arrays in the part's
frame unless said otherwise).

    Options --adapter.place--> Placement --adapter.relief--> Relief
            --adapter.fuse--> Fused --gate--> GateReport --> Textured

What is common to every target is a field here; what one kind of target needs for
itself (a face frame, a profile, a layer list) is that adapter's own frozen
dataclass in the ``data`` field, read only by that adapter.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

from .solid import Mesh

__all__ = ["Placement", "Relief", "Fused", "Stages"]


@dataclass(frozen=True)
class Placement:
    """Where the texture goes (made by the adapter's ``place``).

    Attributes:
        kind: the target kind (``"plane"``, ``"extrusion"``, ``"faces"``,
            ``"surface"``, ``"plate"``, ``"mesh"``).
        base: the untextured part's closed mesh, mm.
        bodies: its closed bodies (the gate's body count).
        selected: ``(vertices (N, 3) float, faces (M, 3) int)``: the surface the
            texture is put on, mm.
        topo: the part's OCCT shape (CAD targets; None for meshes and surfaces).
        face_ids: indices of the selected faces among ``topo``'s faces.
        previous: the earlier result when this one is chained onto it, or None.
        data: the adapter's own placement (its frozen dataclass).
    """

    kind: str
    base: Mesh
    bodies: int
    selected: Optional[tuple] = None
    topo: Any = None
    face_ids: tuple = ()
    previous: Any = None
    data: Any = None


@dataclass(frozen=True)
class Relief:
    """The texture as made on the target: heights after ramps and limits, and the
    relief's mesh (made by the adapter's ``relief``).

    Attributes:
        heightmap: the texture as applied (mm; ramped, clipped, limited), or None
            where there is no single grid (several patches, a mesh).
        limits: the overhang limiter's report for ``build_dir``, or None.
        volume: the texture's own integral as applied, mm^3 (raised +, engraved -),
            the gate's expected volume change: ``sum h dA`` on a plane, the swept
            volume ``int (h + H h^2 + K h^3 / 3) dA`` on a curved face (H mean, K
            Gaussian curvature; ``int (h + k h^2 / 2) ds dy`` on an extruded profile).
        volume_slack: the difference accepted between ``volume`` and the mesh's
            volume change, mm^3 (mesh tolerance times area, curvature terms).
        nominal_volume: the integral before the overhang and curvature limits, mm^3.
        reach: the largest distance of a texture vertex from the selected surface, mm.
        max_error: the measured largest distance between the relief mesh and the
            exact texture, mm, or None when it is measured on demand.
        height_limits: where the height was limited so that the relief cannot cross
            itself (curved faces).
        distortion: texture scale against the nominal mm, or None (exact).
        mapped: the mapped 2.5D surface (surfaces and extruded faces), or None.
        data: the adapter's own relief (slabs, grids...).
    """

    heightmap: Any
    limits: Any
    volume: float
    volume_slack: float
    nominal_volume: Optional[float] = None
    reach: float = 0.0
    max_error: Optional[float] = None
    height_limits: tuple = ()
    distortion: Any = None
    mapped: Any = None
    data: Any = None


@dataclass(frozen=True)
class Fused:
    """The textured part's mesh (made by the adapter's ``fuse``).

    Attributes:
        mesh: the fused, closed mesh, mm (a :class:`~texcad.solid.Mesh`; a plate too
            large for memory keeps it as its tiles' recipe,
            :class:`texcad.pipeline.tiled.TiledMesh`, gated and written tile by tile).
        base_mesh: the base as the texture meshes are measured against (the part's
            mesh, or for meshes the part with every texture at its lowest).
        info: what was done, for people (face kind, grid size, fuse path ...):
            plain values only.
        data: the adapter's own (a stitched relief, layer bodies ...).
    """

    mesh: Mesh
    base_mesh: Mesh
    info: dict = field(default_factory=dict)
    data: Any = None


@dataclass(frozen=True)
class Stages:
    """Everything a :class:`texcad.Textured` came from: the adapter that made it and
    the data of each stage, so that its texture mesh, error and B-rep are made on
    demand by the adapter's methods (no closures)."""

    adapter: Any
    options: Any
    placement: Placement
    relief: Relief
    fused: Fused
    gate: Any
