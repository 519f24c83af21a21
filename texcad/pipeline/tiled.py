"""Large parts in bounded memory, made in tiles (see :mod:`texcad.targets.tiled`, where
they live below the driver so that the plate adapter can choose them):

* :func:`textured_plate_tiled`: a textured plate tile by tile straight into a STL or
  3MF (its tiles on a Dask cluster with ``client=``);
* :class:`TiledMesh`: the fused mesh of a plate that :func:`texcad.texture` made in
  tiles (``max_memory``), gated by :func:`gate_tiled` and streamed by its ``write``;
* :func:`tiled_surface`: a closed 2.5D surface (a full cylinder) in tiles.
"""

from __future__ import annotations

from ..targets.tiled import (  # noqa: F401 - the public names, re-exported
    textured_plate_tiled,
    TiledPlate,
    TiledMesh,
    TiledSurfaceMesh,
    tiled_surface,
    gate_tiled,
    plate_source,
    builtin_grid,
    tile_for_memory,
    BYTES_PER_TILE_NODE,
    BYTES_PER_LEAN_NODE,
)

__all__ = ["textured_plate_tiled", "TiledPlate", "TiledMesh", "TiledSurfaceMesh", "tiled_surface", "gate_tiled", "plate_source", "builtin_grid", "tile_for_memory", "BYTES_PER_TILE_NODE", "BYTES_PER_LEAN_NODE"]
