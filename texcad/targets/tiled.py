"""Targets too large for memory, made in tiles: a plate (:class:`TiledMesh`, chosen
by the plate adapter under ``max_memory``; :func:`textured_plate_tiled` straight to a
file) and a closed 2.5D surface (:class:`TiledSurfaceMesh`, chosen by the surface
adapter under ``max_memory``: :func:`surface_tiles`; :func:`tiled_surface` alone). Re-exported by
:mod:`texcad.pipeline.tiled`.

A large textured plate in bounded memory: :func:`textured_plate_tiled`.

The plate of :func:`texcad.pipeline.textured_plate` (texture centred on the top face
at z = 0, one vertex per pixel centre), made tile by tile: each tile's texture is
sampled, meshed (:mod:`texcad.solid.tiles`: exact shared seams, no duplicate
vertex) and streamed to the output (:mod:`texcad.io.stream`), then dropped. Peak
memory goes with one tile, whatever the plate's size; the tile is chosen from
``max_memory``.

Where both fit, the tiled plate's texture triangles are the untiled slab's, one for
one (same float32 vertices, same diagonals: tested). It differs in one documented
place, the plate's rim: the untiled slab ends in a vertical wall at the outer pixel
centres, fused onto the flat plate; the tiled top slopes from the outer pixel
centres down to the plate's edge (half a pixel plus the margin the texture leaves),
so the volumes differ by at most ``perimeter x (margin + px / 2) x height / 2``.

With a build direction the texture is limited first, block by block
(:class:`LimitedSource`, :func:`texcad.printability.overhang.limit_overhangs_tiled`: each
block from the block grown by a halo as wide as a limited height can reach), the
same heights as the untiled limiter, bit for bit.

With ``tolerance`` > 0 the tiles are lean (:meth:`TiledMesh.blocks`,
:func:`texcad.solid.tiles.lean_plate_tile`): each tile's texture pixels are
triangulated within the tolerance (greedy insertion, the untiled lean mesh's
:func:`texcad.solid.lean.triangulate`) with the tile's border rows and columns kept
whole, so that neighbouring tiles meet on the same vertices and edges (no gap, no
duplicate vertex) and the bound holds across the border (its points are exact). A tile
is within the tolerance by construction, in one greedy insertion (the inside
triangulated, joined to the whole border by a strip one pixel wide that adds no
error), triangulated once and kept in a temporary file for the next pass
(:class:`_LeanStore`); its error is measured at every pixel centre by the gate (or
the writer, when not gated) against the source's heights. Lean tiles are at most
:data:`LEAN_TILE` nodes a side. Only the kept nodes are numbered (the streamed 3MF holds each
once). What differs from the untiled lean mesh: the kept border lines (and the
texture's outer rows and columns, whose cells to the rim stay the grid's) add
triangles, about ``2 (a + b)`` per ``a x b`` tile (tested: at most 1.3 x the untiled
lean plate's on a 30 x 22 mm plate at 0.25 mm in tiles of 40 nodes), and the
untiled rule that falls back to the grid when the lean mesh keeps more than half of
its triangles is applied per tile. With ``build_dir`` the lean triangles must also
keep the limiter's facet angle (:func:`texcad.printability.overhang.lean_facets`,
the untiled lean slab's rule), in blocks of :data:`texcad.solid.lean.TILE` px, a
block that fails made finer, down to the grid.
"""

from __future__ import annotations

import os
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from ..errors import GeometryError, ParameterError, ResourceError
from ..sources import Heightmap
from ..util import Progress, peak_rss, report
from ..util.atomic import track, untrack

__all__ = ["textured_plate_tiled", "TiledPlate", "TiledMesh", "CountedTiles", "TiledSurfaceMesh", "tiled_surface", "surface_tiles", "gate_tiled", "plate_source", "builtin_grid", "LimitedSource", "tile_for_memory", "cluster_client", "in_order", "BYTES_PER_TILE_NODE", "BYTES_PER_LEAN_NODE", "LEAN_TILE"]

#: Peak bytes per node of one tile: the texture function's temporaries (float64),
#: the float32 vertices, int64 faces and ids, STL records or 3MF text (measured on
#: stones, the heaviest built-in, with room to spare).
BYTES_PER_TILE_NODE = 600.0
#: Peak bytes per node a lean tile adds (``tolerance`` > 0): the greedy insertion's
#: raster and queue (:func:`texcad.solid.lean.triangulate`: 80), the error measure's
#: (triangle, pixel) pairs (:func:`texcad.solid.lean.surface_error`) and the kept
#: nodes' numbers (measured on stones, with room to spare).
BYTES_PER_LEAN_NODE = 400.0
#: Largest side of a lean tile, nodes: greedy insertion costs more a pixel on a larger
#: block (stones at 0.02 mm, a lean tile triangulated and measured: 0.53 CPU s per
#: M px at 512, 0.91 at 1024, 1.27 at 1400), while the lines kept whole along the
#: tiles' borders add about 1.5 % of triangles at 512.
LEAN_TILE = 512
#: Largest block of pixels a built-in texture is sampled in (a side, px): sampling
#: temporaries stay small, whatever the tile.
SAMPLE_BLOCK = 1024
#: Bytes the process needs besides the tile (numpy, texcad, the writer's buffers).
OVERHEAD = 64 << 20
#: Largest window (a block and its halo, a side, px) the overhang limiter works on in
#: tiles: its erosion and facet check hold some 300 bytes a pixel, more than a mesh
#: tile's node, and blocks this large already make the halo's share small.
LIMIT_BLOCK = 1024


@dataclass(frozen=True)
class TiledPlate:
    """What :func:`textured_plate_tiled` wrote.

    Attributes:
        path: the output file.
        size: ``(w, d)`` mm; thickness: mm.
        grid: ``(R, C)`` texture pixels; pitch: ``(px, py)`` mm.
        tile: nodes per tile side; tiles: how many.
        triangles, vertices: of the closed mesh (vertices counted once).
        volume: enclosed volume, mm^3 (float64, summed tile by tile).
        seconds: wall time.
        peak_rss: the process's peak resident memory when it finished, bytes.
        tolerance: mm (0: every pixel centre kept); max_error: mm, the largest
            height error measured at a pixel centre (0 without a tolerance).
    """

    path: Path
    size: tuple
    thickness: float
    grid: tuple
    pitch: tuple
    tile: int
    tiles: int
    triangles: int
    vertices: int
    volume: float
    seconds: float
    peak_rss: int
    tolerance: float = 0.0
    max_error: float = 0.0


class _BuiltinSource:
    """A built-in texture sampled block by block: the pixels
    :func:`texcad.sources.builtin` samples for the plate (same pitch adjustment,
    same count, same normalisation by the whole grid's lowest and highest unit
    height, found in a first pass), so each block holds the same float32 heights as
    the untiled heightmap."""

    def __init__(self, spec: str, size: Sequence[float], pitch: float, height: float, block: int, pool: Any = None,
                 cache: "Path | None" = None) -> None:
        from ..sources.textures import BUILTINS, parse_texture_spec

        key, params = parse_texture_spec(spec)
        if key not in BUILTINS:
            from ..sources import builtin

            builtin(spec)  # raises the usual ParameterError naming the built-ins
        scale = float(params.pop("scale", 1.0))
        tile, self.func = BUILTINS[key].configure(scale=scale, **params)
        px = tile[0] / max(1, round(tile[0] / pitch))
        py = tile[1] / max(1, round(tile[1] / pitch))
        w, d = (float(s) for s in size)
        self.pitch = (px, py)
        self.shape = (max(2, int(np.floor(d / py + 1e-6))), max(2, int(np.floor(w / px + 1e-6))))
        self.height = float(height)
        self.lo, self.hi = 0.0, 1.0
        self._cache = None
        block = min(block, SAMPLE_BLOCK)  # the samples do not depend on the blocks (pixel by pixel)
        blocks = [(slice(r0, min(r0 + block, self.shape[0])), slice(c0, min(c0 + block, self.shape[1])))
                  for r0 in range(0, self.shape[0], block) for c0 in range(0, self.shape[1], block)]
        # first pass: the grid's range, per block (min and max are exact over any split), and the
        # trapezoid-weighted sum of the unit heights (the texture's integral, heightfield_volume's weights)
        if pool is not None:
            ranges = pool(_unit_range, [(self, b) for b in blocks])
        else:  # here: the unit heights kept on disk (8 bytes a pixel) for the second pass, not sampled twice
            if cache is not None:
                with open(cache, "r+b") as fh:
                    fh.truncate(8 * self.shape[0] * self.shape[1])
            ranges = []
            for b, u in _sampled(self, blocks):  # per block, in order (sampled a block per thread ahead)
                if cache is not None:
                    rows = self._rows(cache, b[0], "r+")
                    rows[:, b[1]] = u
                    del rows
                ranges.append((float(u.min()), float(u.max()), self._weighted(u, *b)))
            self._cache = cache
        self.lo, self.hi = min(r[0] for r in ranges), max(r[1] for r in ranges)
        self._usum = float(np.sum([r[2] for r in ranges]))  # in block order: the same float for any pool

    def _weighted(self, u: np.ndarray, rows: slice, cols: slice) -> float:
        """``sum w u`` over a block, ``w`` the trapezoid weights of the whole grid
        (1/2 on its first and last row and column: :func:`texcad.solid.mesh.heightfield_volume`)."""
        wr = np.where((np.arange(rows.start, rows.stop) == 0) | (np.arange(rows.start, rows.stop) == self.shape[0] - 1), 0.5, 1.0)
        wc = np.where((np.arange(cols.start, cols.stop) == 0) | (np.arange(cols.start, cols.stop) == self.shape[1] - 1), 0.5, 1.0)
        return float(wr @ u @ wc)

    def integral(self) -> tuple[float, float]:
        """``(volume, slack)`` mm^3: :func:`texcad.solid.mesh.heightfield_volume` of the
        whole grid's heights (``h = height (u - lo) / (hi - lo)`` is linear in ``u``, so
        the weighted sum of the first pass gives it without a second)."""
        (r, c), (px, py) = self.shape, self.pitch
        if self.hi <= self.lo:
            return 0.0, 0.0
        total = (self._usum - self.lo * (r - 1) * (c - 1)) / (self.hi - self.lo) * self.height
        return total * px * py, px * py * self.height

    def _rows(self, path: Path, rows: slice, mode: str) -> np.ndarray:
        """Rows ``rows`` of the unit heights on disk, mapped (only those rows: the
        address space goes with a tile too)."""
        c = self.shape[1]
        return np.memmap(path, dtype=np.float64, mode=mode, offset=8 * c * rows.start, shape=(rows.stop - rows.start, c))

    def _unit(self, rows: slice, cols: slice) -> np.ndarray:
        x = (np.arange(cols.start, cols.stop) + 0.5) * self.pitch[0]
        y = (np.arange(rows.start, rows.stop) + 0.5) * self.pitch[1]
        u = self.func(x[None, :], y[:, None])
        return np.broadcast_to(u, (len(y), len(x))).astype(np.float64)

    def close(self) -> None:
        """Remove the unit heights' file (if any); the source cannot be read after."""
        f, self._file = getattr(self, "_file", None), None
        if f is not None:
            f.close()
            untrack(f.name)
        self._cache = None

    def __getstate__(self) -> dict:  # to a Dask worker: no open file
        state = dict(self.__dict__)
        state["_file"] = None
        return state

    def heights(self, rows: slice, cols: slice) -> np.ndarray:
        if self._cache is not None:
            m = self._rows(self._cache, rows, "r")
            u = np.array(m[:, cols])
            del m
        else:
            u = self._unit(rows, cols)
        u = (u - self.lo) / (self.hi - self.lo) if self.hi > self.lo else np.zeros_like(u)
        return (u * self.height).astype(np.float32)


def _sampled(source: "_BuiltinSource", blocks: list) -> Any:
    """``(block, unit heights)`` in order, sampled on :func:`texcad.util.threads`
    threads, at most one block per thread ahead of the one handed over."""
    from concurrent.futures import ThreadPoolExecutor

    from ..util import threads

    n = threads()
    if n < 2 or len(blocks) < 2:
        for b in blocks:  # per block
            yield b, source._unit(*b)
        return
    with ThreadPoolExecutor(n) as pool:
        for g in range(0, len(blocks), n):  # per group of blocks, one per thread
            yield from zip(blocks[g : g + n], pool.map(lambda b: source._unit(*b), blocks[g : g + n]))


def _unit_range(source: "_BuiltinSource", block: tuple) -> tuple[float, float, float]:
    u = source._unit(*block)
    return float(u.min()), float(u.max()), source._weighted(u, *block)


def _tile_vertices(source: Any, grid: Any, t: Any) -> np.ndarray:
    """One tile's ``(r c, 3)`` float32 vertices (in a Dask worker or here)."""
    rows, cols, _, _ = grid.texture_block(t)
    return grid.vertices(t, source.heights(rows, cols))


def _lean_tile_block(source: Any, grid: Any, t: Any, tolerance: float = 0.0, check: Any = None) -> tuple:
    """One lean tile (in a Dask worker or here): its ``(r c, 3)`` float32 vertices and
    its :class:`texcad.solid.tiles.LeanTile` within ``tolerance`` mm."""
    from ..solid.lean import MAX_FRACTION
    from ..solid.tiles import lean_plate_tile

    v = _tile_vertices(source, grid, t)
    return v, lean_plate_tile(grid, t, v, tolerance, accept=check, max_fraction=MAX_FRACTION, measure=False)


class _LeanStore:
    """Lean tiles kept between passes over a :class:`TiledMesh` (the gate's, the
    writer's): each tile's kept nodes (bits), their float32 vertices and its int32
    local triangles, appended to an anonymous temporary file (removed when closed or
    dropped), so a tile is triangulated once and the memory still goes with one tile.
    Each tile is read back by its offset, so passes may run side by side."""

    def __init__(self) -> None:
        self.file = tempfile.TemporaryFile()
        self.index: list = []
        self.size = 0
        self.complete = False

    def add(self, keep: np.ndarray, v: np.ndarray, faces: np.ndarray) -> None:
        data = b"".join(a.tobytes() for a in (np.packbits(keep.ravel()), np.ascontiguousarray(v, np.float32),
                                                np.ascontiguousarray(faces, np.int32)))
        self.file.seek(self.size)
        self.file.write(data)
        self.index.append((self.size, keep.shape, len(v), len(faces)))
        self.size += len(data)

    def tiles(self) -> Any:
        """``(keep, vertices, faces)`` per tile in the order they were added."""
        self.file.flush()
        for offset, shape, nv, nf in self.index:  # per tile
            n = shape[0] * shape[1]
            nk = (n + 7) // 8
            raw = np.array(np.memmap(self.file, dtype=np.uint8, mode="r", offset=offset, shape=(nk + 12 * (nv + nf),)))
            keep = np.unpackbits(raw[:nk], count=n).astype(bool).reshape(shape)
            v = raw[nk : nk + 12 * nv].view(np.float32).reshape(nv, 3).copy()
            yield keep, v, raw[nk + 12 * nv :].view(np.int32).reshape(nf, 3).astype(np.int64)


class _HeightmapSource:
    """A heightmap (or an image, loaded whole) read block by block."""

    def __init__(self, hm: Heightmap) -> None:
        self.hm, self.shape, self.pitch = hm, hm.shape, tuple(float(p) for p in hm.pitch)

    def heights(self, rows: slice, cols: slice) -> np.ndarray:
        return np.asarray(self.hm.heights[rows, cols], dtype=np.float32)

    def close(self) -> None:
        pass

    def integral(self) -> tuple[float, float]:
        """``(volume, slack)`` mm^3 (:func:`texcad.solid.mesh.heightfield_volume`)."""
        from ..solid.mesh import heightfield_volume

        return heightfield_volume(self.hm.heights, self.hm.pitch)


class LimitedSource:
    """A plate's texture after the overhang limiter, made block by block
    (:func:`texcad.printability.overhang.limit_overhangs_tiled`: each block limited from the
    block grown by its halo, the same float32 heights as the untiled limiter), its
    limited heights kept in a temporary file (4 bytes a pixel) and read a block at a
    time, as the other sources.

    Attributes:
        shape: ``(R, C)`` pixels; pitch: ``(px, py)`` mm (the source's).
        limit: the :class:`texcad.printability.overhang.TiledLimit` (its report, the limited
            integral, the highest limited height).
        nominal: ``(volume, slack)`` mm^3 of the heights before the limiter (the
            source's ``integral()``, or as given).
    """

    def __init__(self, source: Any, build_dir: Any, critical_angle: float, block: int, *,
                 cache_dir: "Path | None" = None, progress: Progress = None, nominal: "tuple | None" = None) -> None:
        from ..printability.overhang import limit_overhangs_tiled

        self.shape, self.pitch = tuple(source.shape), tuple(source.pitch)
        self.nominal = source.integral() if nominal is None else tuple(nominal)
        r, c = self.shape
        self._file = tempfile.NamedTemporaryFile(prefix=".texcad-", suffix=".limited", dir=cache_dir)
        track(self._file.name)
        self._file.truncate(4 * r * c)
        self._cache = Path(self._file.name)

        def store(rows: slice, cols: slice, h: np.ndarray) -> None:
            m = self._rows(rows, "r+")
            m[:, cols] = h
            del m  # written back by the system when it likes (no sync per block: the reads see the pages)

        try:
            self.limit = limit_overhangs_tiled(source.heights, self.shape, self.pitch, build_dir, critical_angle,
                                               block=min(int(block), LIMIT_BLOCK), store=store, progress=progress)
        except BaseException:
            self.close()
            raise

    def _rows(self, rows: slice, mode: str) -> np.ndarray:
        c = self.shape[1]
        return np.memmap(self._cache, dtype=np.float32, mode=mode, offset=4 * c * rows.start, shape=(rows.stop - rows.start, c))

    def heights(self, rows: slice, cols: slice) -> np.ndarray:
        """The limited heights of a block, float32 mm."""
        m = self._rows(rows, "r")
        h = np.array(m[:, cols])
        del m
        return h

    def integral(self) -> tuple[float, float]:
        """``(volume, slack)`` mm^3 of the limited heights (:func:`texcad.solid.mesh.heightfield_volume`)."""
        return self.limit.volume, self.limit.slack

    def close(self) -> None:
        """Remove the limited heights' file; the source cannot be read after."""
        f, self._file = getattr(self, "_file", None), None
        if f is not None:
            f.close()
            untrack(f.name)

    def __getstate__(self) -> dict:  # to a Dask worker on this machine: the file by name, not the handle
        state = dict(self.__dict__)
        state["_file"] = None
        return state


def _rss() -> int:
    """Bytes this process holds now (resident set; 0 where /proc is missing)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _connect(address: str, timeout: float = 5.0):
    """A Dask client of the scheduler at ``address``, or ResourceError in ``timeout`` s."""
    try:
        import distributed
    except ImportError:
        raise ParameterError("client= needs Dask: pip install 'texcad[dask]'") from None
    try:
        return distributed.Client(address, timeout=f"{timeout}s", set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ResourceError(f"cannot reach the Dask scheduler at {address!r} within {timeout:g} s ({type(exc).__name__}); "
                            "check the address, or leave out client= to make the tiles here") from None


def cluster_client(client: Any, *, limited: bool = False) -> Any:
    """The Dask client that ``client=`` names (:class:`texcad.options.Options`): None
    (here), a ``dask.distributed.Client``, or one connected to a scheduler address
    (ResourceError if it cannot be reached in 5 s).

    Raises:
        ParameterError: ``limited`` (``build_dir``) with a client: the limited heights
            are kept in a file here, which the cluster's workers cannot read.
    """
    if client is None:
        return None
    if limited:
        raise ParameterError("build_dir with client=: the limited heights are kept in a file here, which the cluster's "
                             "workers cannot read; leave out client= (the limiter runs here, block by block)")
    return _connect(client) if isinstance(client, str) else client


def tile_for_memory(max_memory: Optional[int], nodes: tuple, *, lean: bool = False) -> int:
    """Nodes per tile side that keep a tile within ``max_memory`` bytes (what the
    process holds now counted; None: half of :func:`texcad.util.available_memory`),
    at most the grid's own size, at least 64; ``lean``: lean tiles
    (:data:`BYTES_PER_LEAN_NODE` more a node, at most :data:`LEAN_TILE`)."""
    from ..util import available_memory

    per_node = BYTES_PER_TILE_NODE + (BYTES_PER_LEAN_NODE if lean else 0.0)
    have = available_memory() // 2 if max_memory is None else int(max_memory) - _rss()
    budget = have - OVERHEAD
    if budget < 64 * 64 * per_node:
        raise ResourceError(
            f"max_memory leaves {max(budget, 0) / 2**20:.0f} MiB for a tile after the {_rss() / 2**20:.0f} MiB "
            f"this process holds; allow at least {(_rss() + OVERHEAD + 64 * 64 * per_node) / 2**20:.0f} MiB"
        )
    side = int((budget / per_node) ** 0.5)
    return max(64, min(side, LEAN_TILE if lean else 4096, max(nodes)))


def textured_plate_tiled(
    size: Sequence[float],
    thickness: float,
    texture: "str | os.PathLike | Heightmap",
    pitch: float = 0.125,
    *,
    height: Optional[float] = None,
    out: "str | os.PathLike",
    tile: Optional[int] = None,
    max_memory: Any = None,
    tolerance: float = 0.0,
    build_dir: Any = None,
    critical_angle: float = 45.0,
    progress: Progress = None,
    client: Any = None,
) -> TiledPlate:
    """Texture the top of a ``size[0] x size[1] x thickness`` mm plate, tile by tile,
    straight into ``out`` (.stl or .3mf), in memory bounded by ``max_memory``.

    Args:
        size: ``(w, d)`` plate size in mm (x, y); the top face at z = 0, the corner at
            the origin, as :func:`texcad.pipeline.plate_base`.
        thickness: plate thickness, mm.
        texture: ``"builtin:NAME[:k=v]"`` (sampled tile by tile), an image path or a
            :class:`~texcad.Heightmap` (held whole: its own pixels, centred).
        pitch: mm per pixel for built-ins (adjusted to whole pixels per period, as
            :func:`texcad.builtin`) and images.
        height: largest texture height, mm (default 1; a Heightmap keeps its own
            heights unless given).
        out: ``.stl`` (binary) or ``.3mf`` output; written atomically.
        tile: nodes per tile side (default: from ``max_memory``).
        max_memory: bound on the process's memory, bytes or text (``"4GB"``); default
            half of what the machine has available.
        tolerance: mm; 0 (the default) keeps every pixel centre, more makes each tile
            lean within it (:class:`TiledMesh`: the tiles' borders kept whole, the
            error measured at every pixel centre).
        build_dir: a build direction ``(3,)`` (or a set ``(K, 3)``) to limit the
            texture's overhangs for, as :func:`texcad.printability.limit_overhangs`
            (block by block from a halo: the same heights; not with ``client``); lean
            tiles then keep the limiter's facet angle as the untiled lean slab does
            (:func:`texcad.printability.overhang.lean_facets`).
        critical_angle: degrees, with ``build_dir``.
        progress: ``progress(fraction, message)``: tiles done / total.
        client: a ``dask.distributed.Client`` or a scheduler address: the tiles are
            sampled and meshed on its workers (a few in flight per worker, so memory
            here stays bounded) and written here in order: the same bytes as without.
            ``max_memory`` then bounds each worker's tile as well as this process.

    Returns:
        :class:`TiledPlate` (counts, volume, time, peak memory).

    Raises:
        ParameterError: bad size, thickness, height, output format or tolerance,
            or build_dir with client.
        ResourceError: ``max_memory`` leaves no room for a tile.
    """
    from ..options import memory_bytes

    t0 = time.perf_counter()
    w, d = (float(s) for s in size)
    if height is None:
        height = float(texture.max_height) if isinstance(texture, Heightmap) else 1.0
    for label, v in (("plate width", w), ("plate depth", d), ("thickness", thickness), ("height", height), ("pitch", pitch)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v > 0):
            raise ParameterError(f"{label} must be a positive number of mm, got {v!r}")
    from ..solid.lean import check_tolerance

    tolerance = check_tolerance(tolerance)
    if build_dir is not None and client is not None:
        raise ParameterError("build_dir with client=: the limited heights are kept in a file here, which the cluster's "
                             "workers cannot read; leave out client= (the limiter runs here, block by block)")
    if Path(out).suffix.lower() not in (".stl", ".3mf"):
        raise ParameterError(f"out {os.fspath(out)!r}: the tiled plate streams .stl or .3mf")
    bound = None if max_memory is None else memory_bytes(max_memory)
    own = isinstance(client, str)
    if own:
        client = _connect(client)
    try:
        return _tiled(w, d, float(thickness), texture, pitch, float(height), Path(out), tile, bound, progress, client, t0,
                      (build_dir, critical_angle), tolerance)
    finally:
        if own:
            client.close()


def _tiled(w, d, thickness, texture, pitch, height, out, tile, bound, progress, client, t0, limit, tolerance) -> TiledPlate:
    """The texture's source (limited for ``limit = (build_dir, critical_angle)`` when a
    direction is given) and the tile size, then :func:`_write` (lean tiles within
    ``tolerance`` mm when > 0)."""
    pool = None
    if client is not None:
        def pool(fn, args):  # noqa: E306 - map on the cluster, results in order
            return client.gather(client.map(fn, *zip(*args), pure=False))
    source, side = plate_source(texture, (w, d), pitch, height, tile=tile, bound=bound, pool=pool,
                                cache_dir=None if pool is not None else out.parent, progress=progress, tolerance=tolerance)
    check = None
    if limit[0] is not None and tolerance > 0:
        from ..printability.overhang import lean_facets

        check = lean_facets(limit[0], limit[1])
    if limit[0] is not None:
        try:
            limited = LimitedSource(source, limit[0], limit[1], side, cache_dir=out.parent, progress=progress)
        finally:
            source.close()
        source = limited
    try:
        mesh = TiledMesh(_grid_of(source, w, d, side), source, thickness, client, tolerance=tolerance, check=check)
        return _write(mesh, out, progress, t0)
    finally:
        source.close()


def builtin_grid(texture: Any, size: Sequence[float], pitch: float) -> "tuple[int, int] | None":
    """``(R, C)`` pixels of a built-in texture (``"builtin:NAME[:k=v]"``) on a plate of
    ``size`` mm at ``pitch`` mm (adjusted to whole pixels per period, as
    :func:`texcad.builtin`), without sampling it; None for other textures."""
    if isinstance(texture, Heightmap) or not os.fspath(texture).startswith("builtin:"):
        return None
    from ..sources.textures import BUILTINS, parse_texture_spec

    key, params = parse_texture_spec(os.fspath(texture))
    if key not in BUILTINS:
        return 2, 2
    tl = BUILTINS[key].configure(scale=float(params.pop("scale", 1.0)), **params)[0]
    nx = max(2, int(np.floor(float(size[0]) / (tl[0] / max(1, round(tl[0] / pitch))) + 1e-6)))
    ny = max(2, int(np.floor(float(size[1]) / (tl[1] / max(1, round(tl[1] / pitch))) + 1e-6)))
    return ny, nx


def plate_source(texture: Any, size: Sequence[float], pitch: float, height: float, *, tile: Optional[int] = None,
                 bound: Optional[int] = None, pool: Any = None, cache_dir: "Path | None" = None,
                 progress: Progress = None, tolerance: float = 0.0) -> tuple[Any, int]:
    """``(source, side)``: the texture's heights (mm; ``height`` the largest, None: a
    Heightmap's own) on a plate of ``size`` mm, read a
    block at a time, and the nodes per tile side (``tile``, or from ``bound`` bytes:
    :func:`tile_for_memory`). A built-in is sampled in a first pass (its range and
    integral) whose unit heights wait in a temporary file in ``cache_dir`` (default:
    the system's temporary folder; 8 bytes a pixel) until ``source.close()`` or the
    source is dropped; with ``pool`` (a map on a cluster) it is sampled again per tile
    instead. An image or :class:`~texcad.Heightmap` is held whole (as the untiled plate).
    ``tolerance`` > 0 (mm): the tiles will be lean, whose memory the tile size allows for."""
    w, d = (float(s) for s in size)
    shape = builtin_grid(texture, (w, d), pitch)
    lean = {"lean": True} if tolerance > 0 else {}
    if shape is None:
        from ..sources import load_texture

        hm = texture if isinstance(texture, Heightmap) and height is None else load_texture(texture, size=(w, d), pitch=pitch, height=height)
        source: Any = _HeightmapSource(hm)
        side = int(tile) if tile else tile_for_memory(bound, (source.shape[0] + 2, source.shape[1] + 2), **lean)
        return source, side
    side = int(tile) if tile else tile_for_memory(bound, (shape[0] + 2, shape[1] + 2), **lean)
    report(progress, 0.0, "finding the texture's range")
    cache = None
    if pool is None:
        cache = tempfile.NamedTemporaryFile(prefix=".texcad-", suffix=".heights", dir=cache_dir)
        track(cache.name)
    try:
        source = _BuiltinSource(os.fspath(texture), (w, d), pitch, height, block=max(side - 1, 1), pool=pool,
                                cache=None if cache is None else Path(cache.name))
    except BaseException:
        if cache is not None:
            cache.close()
            untrack(cache.name)
        raise
    source._file = cache  # removed with the source
    return source, side


def _grid_of(source: Any, w: float, d: float, side: int):
    """The plate's node grid for ``source``'s pixels."""
    from ..solid.tiles import PlateGrid

    return PlateGrid((w, d), source.shape, source.pitch, side)


def _write(mesh: "TiledMesh", out: Path, progress: Progress, t0: float) -> TiledPlate:
    """Mesh and stream every tile, then the walls: the :class:`TiledPlate`."""
    triangles, volume = mesh.write(out, progress)
    peak = peak_rss()
    grid, source = mesh.grid, mesh.source
    return TiledPlate(
        path=Path(out), size=tuple(grid.size), thickness=mesh.thickness, grid=tuple(source.shape), pitch=tuple(source.pitch),
        tile=int(grid.tile), tiles=grid.count, triangles=triangles, vertices=mesh.num_vertices, volume=volume,
        seconds=time.perf_counter() - t0, peak_rss=int(peak), tolerance=mesh.tolerance, max_error=mesh.max_error,
    )


class TiledMesh:
    """A textured plate's closed mesh kept as the recipe of its tiles (mm): the node
    grid (:class:`texcad.solid.tiles.PlateGrid`), the texture's source (sampled or
    read a tile at a time) and the plate's thickness. Its blocks are made on demand,
    one tile at a time (:meth:`blocks`), for the gate (:func:`gate_tiled`) and the
    streaming writers (:meth:`write`); the whole mesh is made only when asked for
    (:meth:`to_mesh`, :attr:`vertices`, :attr:`faces`: refused where it does not fit).

    With ``tolerance`` > 0 each tile is lean (:func:`texcad.solid.tiles.lean_plate_tile`):
    its texture pixels triangulated within ``tolerance`` mm of every pixel centre,
    measured, with the tile's border rows and columns (and the texture's outer ones)
    kept whole, so that neighbouring tiles meet on the same vertices and edges and the
    error bound holds across their border; ``check(points, faces)`` may reject a
    tile's lean triangles (the overhang limiter's facets:
    :class:`texcad.printability.overhang.LeanFacets`), which are then tightened, down
    to the grid.

    Attributes:
        grid: the plate's node grid and tile size.
        source: the texture's heights, block by block (``heights(rows, cols)`` mm).
        thickness: mm; the plate spans z from ``-thickness`` to 0 under the texture.
        client: a ``dask.distributed.Client`` making the tiles' vertices, or None.
        progress: ``progress(fraction, message)`` told of the gate's tiles, or None.
        tolerance: mm, 0 for every pixel centre; check: a lean tile's check or None.
    """

    tolerance: float = 0.0
    check: Any = None

    def __init__(self, grid: Any, source: Any, thickness: float, client: Any = None, progress: Progress = None, *,
                 tolerance: float = 0.0, check: Any = None) -> None:
        self.grid, self.source, self.thickness, self.client = grid, source, float(thickness), client
        self.progress = progress  # told of the gate's tiles
        self.tolerance, self.check = float(tolerance), check

    @property
    def num_vertices(self) -> int:
        """Vertices counted once: every node and the four bottom corners (lean: the
        nodes kept, counted in one pass over the tiles the first time)."""
        if self.tolerance > 0:
            return self._lean_counts()[0]
        nr, nc = self.grid.nodes
        return nr * nc + 4

    @property
    def num_triangles(self) -> int:
        """Triangles: two per cell of the node grid, one per ring node on the walls, two on the bottom
        (lean: counted as :attr:`num_vertices`)."""
        if self.tolerance > 0:
            return self._lean_counts()[1]
        nr, nc = self.grid.nodes
        return 2 * (nr - 1) * (nc - 1) + 2 * nr + 2 * nc + 2

    def _lean_counts(self) -> tuple[int, int]:
        if "counts" not in self.__dict__:
            for _ in self.blocks():  # per tile: the counts are kept at the end
                pass
        return self.__dict__["counts"]

    @property
    def max_error(self) -> float:
        """The largest height error at a pixel centre, mm (0 for every pixel centre;
        lean: measured tile by tile against the source's heights (:meth:`tile_error`)
        by the gate or the writer, else in one pass the first time)."""
        if self.tolerance <= 0:
            return 0.0
        if "max_error" not in self.__dict__:
            self.__dict__["max_error"] = max((self.tile_error(t, v, f) for t, v, f, _ in self.blocks() if t is not None),
                                             default=0.0)
        return self.__dict__["max_error"]

    def blocks(self, progress: Progress = None) -> "Any":
        """``(tile, vertices, faces, ids)`` per tile in :meth:`PlateGrid.tiles` order,
        then ``(None, ...)`` for the walls and bottom (:func:`texcad.solid.tiles.walls`):
        float32 mm vertices, int64 local faces, int64 global vertex numbers."""
        from ..solid.tiles import Numbering, walls

        grid = self.grid
        numbering = Numbering(grid)
        total = grid.count
        if self.tolerance > 0:
            yield from self._lean_blocks(numbering, progress)
            return
        for k, (t, v) in enumerate(_tile_vertex_blocks(grid, self.source, self.client)):  # per tile, in order
            yield t, v, self._faces(t), numbering.ids(t).ravel()
            report(progress, (k + 1) / (total + 1), f"tile {k + 1}/{total}")
        self.__dict__.pop("_faces_by_shape", None)  # not kept between passes
        yield (None, *walls(grid, numbering, self.thickness))

    def _lean_blocks(self, numbering: Any, progress: Progress) -> Any:
        """:meth:`blocks` with lean tiles: each tile's kept nodes only (numbered on, the
        border's numbers shared), its lean triangles; keeps the counts. The tiles are
        triangulated in the first pass and kept on disk for the next (:class:`_LeanStore`)."""
        from ..solid.tiles import walls

        grid, total = self.grid, self.grid.count
        triangles = 0
        store = self.__dict__.get("_store")
        fresh = store is None or not store.complete
        if fresh:  # triangulate (a pass left unfinished is started again; its file goes with it)
            store = self.__dict__["_store"] = _LeanStore()
        for k, (t, (keep, v, f)) in enumerate(zip(grid.tiles(), self._lean_tiles() if fresh else store.tiles())):  # per tile
            if fresh:
                store.add(keep, v, f)
            ids = numbering.ids(t, keep).ravel()[keep.ravel()]
            triangles += len(f)
            yield t, v, f, ids
            report(progress, (k + 1) / (total + 1), f"tile {k + 1}/{total}")
        store.complete = True
        rest = walls(grid, numbering, self.thickness)
        self.__dict__.update(counts=(numbering.next + 4, triangles + len(rest[1])))
        yield (None, *rest)

    def _lean_tiles(self) -> Any:
        """``(keep, kept vertices, local faces)`` per tile, triangulated (here or on the
        cluster: :func:`_lean_tile_block`)."""
        from functools import partial

        make = partial(_lean_tile_block, tolerance=self.tolerance, check=self.check)
        for _, (v, lt) in _tile_vertex_blocks(self.grid, self.source, self.client, make):  # per tile, in order
            keep = lt.keep.ravel()
            local = np.cumsum(keep) - 1
            yield lt.keep, v[keep], local[lt.faces]

    def __getstate__(self) -> dict:  # no open file in a copy: its tiles are made again
        state = dict(self.__dict__)
        state.pop("_store", None)
        return state

    def _stream_blocks(self, progress: Progress = None) -> Any:
        """:meth:`blocks` as the streaming writers take them (each new vertex once)."""
        return self.blocks(progress)

    def _unmeasured(self) -> bool:
        """Lean tiles whose error no pass has measured yet (:meth:`tile_error`)."""
        return self.tolerance > 0 and "max_error" not in self.__dict__

    def _faces(self, t: Any) -> np.ndarray:
        """Tile ``t``'s local triangles (:meth:`PlateGrid.faces`), kept for the last two
        tile shapes (most tiles have one shape: the grid rule is made once for them)."""
        cache = self.__dict__.setdefault("_faces_by_shape", {})
        f = cache.get(t.shape)
        if f is None:
            if len(cache) >= 2:
                cache.pop(next(iter(cache)))
            f = cache[t.shape] = self.grid.faces(t)
        return f

    def write(self, out: "str | os.PathLike", progress: Progress = None, **kwargs: Any) -> tuple[int, float]:
        """Stream the mesh into ``out`` (.stl / .3mf, atomically): ``(triangles, volume mm^3)``
        (the volume summed on the way unless the gate has it already)."""
        from ..io.stream import open_stream
        from ..solid.tiles import block_volume

        known = "volume" in self.__dict__
        measure = self._unmeasured()  # lean, not gated: measured on the way
        volume, error = 0.0, 0.0
        with open_stream(out, **kwargs) as stream:
            for t, v, f, ids in self._stream_blocks(progress):  # per tile
                stream.add(v, f, ids)
                if not known:
                    volume += block_volume(v, f) if t is None else self.share(t, v, f)
                if measure and t is not None:
                    error = max(error, self.tile_error(t, v, f))
                del v, f
        report(progress, 1.0, f"wrote {stream.triangles} triangles")
        if not known:
            self.__dict__["volume"] = volume
        if measure:
            self.__dict__["max_error"] = error
        return stream.triangles, self.__dict__["volume"]

    @property
    def volume(self) -> float:
        """Enclosed volume, mm^3 (float64, summed tile by tile; one pass over the tiles
        the first time)."""
        if "volume" not in self.__dict__:
            from ..solid.tiles import block_volume

            self.__dict__["volume"] = sum(block_volume(v, f) if t is None else self.share(t, v, f)
                                          for t, v, f, _ in self.blocks())
        return self.__dict__["volume"]

    @property
    def bounds(self) -> np.ndarray:
        """``(2, 3)`` float64 min and max corner, mm (the texture's highest point from
        the gate, else one pass over the tiles)."""
        if "top" not in self.__dict__:
            self.__dict__["top"] = max(float(v[:, 2].max()) for t, v, _, _ in self.blocks() if t is not None)
        w, d = self.grid.size
        return np.array([[0.0, 0.0, -self.thickness], [w, d, self.__dict__["top"]]])

    def to_mesh(self) -> Any:
        """The whole mesh as one :class:`texcad.Mesh` (vertices once, by their global
        numbers), mm.

        Raises:
            ResourceError: it does not fit in the memory available (or ``max_memory``).
        """
        from ..solid import Mesh
        from ..util import require_memory

        n, m = self.num_vertices, self.num_triangles
        require_memory(3 * (12 * n + 12 * m), f"the whole tiled mesh ({m:,} triangles)",
                       "write it with .export('part.stl') or '.3mf', which streams it tile by tile")
        verts = np.empty((n, 3), np.float32)
        faces = []
        for _, v, f, ids in self.blocks():  # per tile
            verts[ids] = v
            faces.append(ids[f].astype(np.uint32))
        return Mesh(verts, np.concatenate(faces))

    @property
    def vertices(self) -> np.ndarray:
        """``(N, 3)`` float32 mm, the whole mesh made (:meth:`to_mesh`)."""
        return self._whole().vertices

    @property
    def faces(self) -> np.ndarray:
        """``(M, 3)`` uint32, the whole mesh made (:meth:`to_mesh`)."""
        return self._whole().faces

    def _whole(self) -> Any:
        if "whole" not in self.__dict__:
            self.__dict__["whole"] = self.to_mesh()
        return self.__dict__["whole"]

    def gate(self, ex: Any) -> Any:
        """texcad's gate on this mesh, tile by tile (:func:`gate_tiled`)."""
        return gate_tiled(self, ex)

    def share(self, t: Any, v: np.ndarray, f: np.ndarray) -> float:
        """Tile ``t``'s share of the volume, mm^3."""
        if self.tolerance > 0:
            from ..solid.tiles import block_volume

            return block_volume(v, f)
        return self.grid.top_volume(t, v)

    def tile_error(self, t: Any, v: np.ndarray, f: np.ndarray) -> float:
        """The largest height error (mm) of lean tile ``t``'s triangles (``v``, ``f``)
        at its texture pixel centres, against the source's heights read again
        (:func:`texcad.solid.lean.surface_error` on the triangles between pixel
        centres; the cells to the rim keep the grid's). Raises GeometryError when a
        vertex is not on one of the tile's nodes."""
        from ..solid.lean import surface_error

        rows, cols, nrs, ncs = self.grid.texture_block(t)
        if nrs.stop - nrs.start < 2 or ncs.stop - ncs.start < 2:
            return 0.0
        xs, ys = self.grid.xs(t.j0, t.j1), self.grid.ys(t.i0, t.i1)
        j, i = np.searchsorted(xs, v[:, 0]), np.searchsorted(ys, v[:, 1])
        if (j >= len(xs)).any() or (i >= len(ys)).any() or (xs[np.minimum(j, len(xs) - 1)] != v[:, 0]).any() \
                or (ys[np.minimum(i, len(ys) - 1)] != v[:, 1]).any():
            raise GeometryError("the textured plate failed texcad's gate: a lean tile's vertex is off its node grid; "
                                "please report this")
        rc = np.stack([i - nrs.start, j - ncs.start], 1)
        a, b = nrs.stop - nrs.start, ncs.stop - ncs.start
        inside = (rc[:, 0] >= 0) & (rc[:, 0] < a) & (rc[:, 1] >= 0) & (rc[:, 1] < b)
        on = inside[f].all(axis=1)
        return surface_error(self.source.heights(rows, cols), np.where(inside[:, None], rc, 0), v[:, 2], f[on])

    def reach(self, t: Any, v: np.ndarray) -> tuple[float, float]:
        """``(farthest, highest)``: tile ``t``'s largest distance from the top face (inf
        off its rectangle) and its highest z, mm."""
        w, d = self.grid.size
        inside = (v[:, 0].min() >= 0) & (v[:, 0].max() <= w) & (v[:, 1].min() >= 0) & (v[:, 1].max() <= d)
        high = float(v[:, 2].max())
        return (max(high, -float(v[:, 2].min())) if inside else float("inf")), high

    def __repr__(self) -> str:
        nr, nc = self.grid.nodes
        return f"TiledMesh({nr} x {nc} nodes in {self.grid.count} tiles, {self.num_triangles:,} triangles)"


def _tile_loop(ids: np.ndarray) -> np.ndarray:
    """The open directed edges ``(k, 2)`` of one tile's triangles (:func:`texcad.solid.grid_faces`
    on its ``(r, c)`` global numbers ``ids``): its border, counter-clockwise seen from +z."""
    bottom = np.stack([ids[0, :-1], ids[0, 1:]], 1)
    right = np.stack([ids[:-1, -1], ids[1:, -1]], 1)
    top = np.stack([ids[-1, 1:], ids[-1, :-1]], 1)
    left = np.stack([ids[1:, 0], ids[:-1, 0]], 1)
    return np.concatenate([bottom, right, top, left])


def _at(ids: np.ndarray, v: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Rows of ``v`` whose ``ids`` are ``wanted`` (every one present)."""
    order = np.argsort(ids, kind="stable")
    return v[order[np.searchsorted(ids, wanted, sorter=order)]]


def _open_edges(faces: np.ndarray) -> tuple[np.ndarray, int]:
    """``(open, bad)``: the directed edges of ``faces`` whose reverse is not among them
    (each once), and how many edges come more than once or twice the same way
    (non-manifold or misoriented). One sort of the undirected keys."""
    f = np.asarray(faces, dtype=np.int64)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]) if f.shape[1] == 3 else f
    lo, hi = np.minimum(e[:, 0], e[:, 1]), np.maximum(e[:, 0], e[:, 1])
    order = np.lexsort((e[:, 0] > e[:, 1], hi, lo))
    lo, hi, fwd = lo[order], hi[order], (e[:, 0] <= e[:, 1])[order]
    start = np.r_[True, (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])]
    gid = np.cumsum(start) - 1
    count = np.bincount(gid)
    nfwd = np.bincount(gid, weights=fwd)
    single = count[gid] == 1
    bad = int(np.sum((count > 2) | ((count == 2) & (nfwd != 1))))
    return e[order][single], bad


def gate_tiled(mesh: TiledMesh, ex: Any, *, what: str = "textured plate") -> Any:
    """texcad's gate (:func:`texcad.report.gate.gate`, checks 1-5) on a tiled mesh,
    one tile at a time, in memory that goes with one tile plus the tiles' borders:

    1. closed and oriented: each tile's triangles follow the grid rule of
       :func:`texcad.solid.grid_faces` (its open edges checked here to be exactly the
       tile's border loop, on a small grid), so inside a tile every edge is paired
       (a lean tile: its triangles' open edges are found and none may be used twice
       the same way);
       the tiles' border loops (by global vertex number) and the walls' edges must
       then pair up, each directed edge once and its reverse once; a node shared by
       two tiles is the same float32 point in both (no gap when a reader welds by
       position); every vertex finite;
    2-3. one body, facing out: the node grid is connected and the volume positive;
    4. the volume change against the base is the texture's integral ``ex.volume``
       within ``ex.volume_slack``;
    5. every texture vertex lies within ``ex.height`` mm of the surface it was put on
       (the mesh's ``reach``: the plate's top face, z = 0 inside its rectangle; a
       surface's profile point of its column);
    6. lean tiles (``mesh.tolerance`` > 0): each tile's largest height error at its
       pixel centres (``mesh.tile_error``, the source's heights read again) is
       within the tolerance.

    ``mesh`` is a :class:`TiledMesh` or :class:`TiledSurfaceMesh` (anything with
    ``blocks()``, ``share(tile, v, f)`` and ``reach(tile, v)``).

    Returns:
        :class:`texcad.report.gate.GateReport`; sets the mesh's volume and top.

    Raises:
        GeometryError: a check failed (the message names it and the figures).
    """
    from ..report.gate import ShellReport
    from ..solid.grid import grid_faces
    from ..solid.tiles import block_volume

    rule, bad = _open_edges(grid_faces(4, 5))
    loop = _tile_loop(np.arange(20).reshape(4, 5))
    if bad or sorted(map(tuple, rule)) != sorted(map(tuple, loop)):
        raise GeometryError(f"the {what} failed texcad's gate: the tile triangles' open edges are not their border; please report this")
    borders, seam_ids, seam_xyz = [], [], []
    volume, top, farthest, finite, error = 0.0, -np.inf, 0.0, True, 0.0
    lean = getattr(mesh, "tolerance", 0.0) > 0
    for t, v, f, ids in mesh.blocks(getattr(mesh, "progress", None)):  # per tile
        finite &= bool(np.isfinite(v).all())
        if t is None:
            volume += block_volume(v, f)
            borders.append(ids[f])
            seam_ids.append(ids)
            seam_xyz.append(v)
            continue
        volume += mesh.share(t, v, f)
        far, high = mesh.reach(t, v)
        farthest, top = max(farthest, far), max(top, high)
        if lean:
            loop, twice = _open_edges(ids[f])
            if twice:
                raise GeometryError(f"the {what} failed texcad's gate: a lean tile has {twice} edge(s) used twice the same "
                                    "way or by more than two triangles; please report this")
            borders.append(loop)
            error = max(error, mesh.tile_error(t, v, f))
        else:
            borders.append(_tile_loop(ids.reshape(t.shape)))
        ring = np.unique(borders[-1])  # the tile's border nodes: where it meets its neighbours
        seam_ids.append(ring)
        seam_xyz.append(_at(ids, v, ring))
    # a node on two tiles' borders is one point: the same float32 numbers from both
    sid, sxyz = np.concatenate(seam_ids), np.concatenate(seam_xyz)
    order = np.argsort(sid, kind="stable")
    sid, sxyz = sid[order], sxyz[order]
    same = sid[1:] == sid[:-1]
    apart = int(np.sum(np.any(sxyz[1:][same] != sxyz[:-1][same], axis=1)))
    if apart:
        raise GeometryError(f"the {what} failed texcad's gate: {apart} seam vertices differ between neighbouring tiles "
                            "(a gap at the seam); please report this")
    edges = np.concatenate([np.concatenate([b[:, [0, 1]], b[:, [1, 2]], b[:, [2, 0]]]) if b.shape[1] == 3 else b
                            for b in borders])
    open_, bad = _open_edges(edges)
    closed = finite and not len(open_) and not bad
    shells = ShellReport(closed=closed, open_edges=len(open_), nonmanifold_edges=bad, misoriented_edges=0,
                         volumes=(volume,), nesting=(0,), inside_out=int(volume <= 0), nested_bodies=0, bodies=1)
    if not shells.manifold:
        raise GeometryError(f"the {what} failed texcad's gate: {shells.problem() or 'its vertices are not finite'}; please report this")
    mesh.__dict__["volume"], mesh.__dict__["top"] = volume, top
    if lean:
        mesh.__dict__["max_error"] = error
    if lean and error > mesh.tolerance + 1e-6:
        raise GeometryError(f"the {what} failed texcad's gate: its lean tiles lie up to {error:.4f} mm from the texture's "
                            f"heights at a pixel centre, beyond tolerance={mesh.tolerance:g} mm; please report this")
    change = expected = slack = None
    if ex.base is not None and ex.volume is not None:
        change = volume - float(ex.base.volume)
        expected, slack = float(ex.volume), float(ex.volume_slack)
    return tiles_verdict(what, shells, change, expected, slack, farthest, float(ex.height), "surface")


def tiles_verdict(what: str, shells: Any, change: Any, expected: Any, slack: Any, farthest: float, height: float,
                  near: str) -> GateReport:
    """Checks 4 and 5 of a tiled result from its summed figures: the volume change
    against the texture's integral within ``slack`` (mm^3; skipped when ``change`` is
    None) and the farthest texture vertex (mm) within ``height`` of the ``near``
    surface. Returns the report, or raises GeometryError with the figures."""
    from ..report.gate import GateReport

    if change is not None and abs(change - expected) > slack:
        raise GeometryError(
            f"the {what} failed texcad's gate: its volume changed by {change:+.2f} mm3 where the texture's integral "
            f"is {expected:+.2f} mm3 (accepted difference {slack:.2f} mm3); please report this"
        )
    if farthest > height:
        raise GeometryError(f"the {what} failed texcad's gate: texture vertices lie up to {farthest:.3f} mm from the "
                            f"{near} (or off it), where the texture reaches {height:.3f} mm; please report this")
    return GateReport(shells, change, expected, slack, farthest, height)


def _tile_vertex_blocks(grid: Any, source: Any, client: Any, make: Any = _tile_vertices):
    """``(tile, make(source, grid, tile))`` in :meth:`PlateGrid.tiles` order (default:
    the tile's vertices; lean tiles: their vertices and triangulation): made here, or
    on the cluster's workers with at most two tiles per worker in flight."""
    if client is None:
        for t in grid.tiles():  # per tile
            yield t, make(source, grid, t)
        return
    [src] = client.scatter([source], broadcast=True)
    yield from in_order(client, ((t, make, (src, grid, t)) for t in grid.tiles()))


def in_order(client: Any, calls: Any) -> Any:
    """``(key, fn(*args))`` for each ``(key, fn, args)`` of ``calls``, in their order,
    made on the cluster of ``client``: at most two tasks per worker in flight, each
    retried once, each result released once handed over."""
    from collections import deque

    ahead = 2 * max(1, len(client.scheduler_info().get("workers", {})))
    pending: deque = deque()
    for key, fn, args in calls:  # per task: keep `ahead` in flight, hand them over in order
        pending.append((key, client.submit(fn, *args, pure=False, retries=1)))
        if len(pending) >= ahead:
            k0, fut = pending.popleft()
            yield k0, fut.result()
            fut.release()
    while pending:
        k0, fut = pending.popleft()
        yield k0, fut.result()
        fut.release()


class CountedTiles(TiledMesh):
    """A tiled mesh whose counts are known only by going over its blocks once (lean
    or irregular tiles, mesh blocks): vertices and triangles counted then, and
    closed as the gate found it."""

    @property
    def num_vertices(self) -> int:
        return self._counts()[0]

    @property
    def num_triangles(self) -> int:
        return self._counts()[1]

    @property
    def is_watertight(self) -> bool:
        """Closed and oriented, as the gate found it block by block (False before it ran)."""
        return bool(self.__dict__.get("closed", False))

    @property
    def bounds(self) -> np.ndarray:
        """``(2, 3)`` mm, over the blocks."""
        lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
        for _, v, _, _ in self.blocks():  # per block
            if len(v):
                lo, hi = np.minimum(lo, v.min(axis=0)), np.maximum(hi, v.max(axis=0))
        return np.array([lo, hi], dtype=np.float64)

    def _unmeasured(self) -> bool:  # its own error measure (max_error), not the plate's tiles'
        return False

    def _counts(self) -> tuple[int, int]:
        if "counts" not in self.__dict__:
            nv, nt = 0, 0
            for _, v, f, ids in self.blocks():  # per block
                nv, nt = max(nv, int(ids.max(initial=-1)) + 1), nt + len(f)
            self.__dict__["counts"] = (nv, nt)
        return self.__dict__["counts"]


class TiledSurfaceMesh(TiledMesh):
    """A closed 2.5D surface's textured solid kept as the recipe of its tiles (mm):
    the surface's node grid (:class:`texcad.solid.tiles.SurfaceGrid`: the texture's
    rows between the two ends, its columns all the way round), the texture's heights
    (``heights[rows, cols]`` mm, held whole: 4 bytes a pixel) and the two end caps.
    As :class:`TiledMesh`: blocks on demand, gated and written tile by tile.

    Attributes:
        grid: the node grid and tile size.
        heights: ``(R, C0)`` float32 mm, the offsets along the mapping's direction
            (the texture's heights less the mode's share of its height: negative
            under the surface); node column ``j`` reads texture column ``j mod C0``
            (a texture repeated round the profile).
        flip: the grid's triangles reversed (so that they face away from the profile).
    """

    def __init__(self, grid: Any, heights: np.ndarray, flip: bool = False) -> None:
        self.grid, self.heights, self.flip, self.client = grid, heights, bool(flip), None
        self.thickness, self.progress = 0.0, None

    @property
    def num_vertices(self) -> int:
        nr, nc = self.grid.nodes
        return nr * (nc - 1)

    @property
    def num_triangles(self) -> int:
        nr, nc = self.grid.nodes
        return 2 * (nr - 1) * (nc - 1) + 2 * (nc - 3)

    def blocks(self, progress: Progress = None) -> "Any":
        """``(tile, vertices, faces, ids)`` per tile, then ``(None, ...)`` for the caps."""
        from ..solid.tiles import WrapNumbering, caps

        grid, c0 = self.grid, self.heights.shape[1]
        numbering = WrapNumbering(grid)
        total = grid.count
        for k, t in enumerate(grid.tiles()):  # per tile, in order
            rows, cols, _ = grid.texture_block(t)
            v = grid.vertices(t, self.heights[rows][:, cols % c0])
            f = self._faces(t)
            yield t, v, (f[:, [0, 2, 1]] if self.flip else f), numbering.ids(t).ravel()
            report(progress, (k + 1) / (total + 1), f"tile {k + 1}/{total}")
        self.__dict__.pop("_faces_by_shape", None)
        yield (None, *caps(grid, numbering))

    def share(self, t: Any, v: np.ndarray, f: np.ndarray) -> float:
        from ..solid.tiles import block_volume

        return block_volume(v, f)

    def gate(self, ex: Any) -> Any:
        """texcad's gate on this mesh, tile by tile (:func:`gate_tiled`)."""
        return gate_tiled(self, ex, what="textured surface")

    def _stream_blocks(self, progress: Progress = None) -> Any:
        """:meth:`blocks` for the streaming writers: a tile that runs all the way round
        the profile holds its seam column twice (first and last, the same numbers):
        there it is given once."""
        nc = self.grid.nodes[1]
        for t, v, f, ids in self.blocks(progress):  # per tile
            if t is not None and t.j0 == 0 and t.j1 == nc - 1:
                r, c = t.shape
                local = np.arange(r * c).reshape(r, c)
                local[:, -1] = local[:, 0]  # the last column is the first
                keep = local[:, :-1].ravel()
                renum = np.empty(r * c, np.int64)
                renum[keep] = np.arange(len(keep))
                v, f, ids = v[keep], renum[local.ravel()[f]], ids[keep]
            yield t, v, f, ids

    def reach(self, t: Any, v: np.ndarray) -> tuple[float, float]:
        """``(farthest, farthest)``: the largest distance of tile ``t``'s vertices from
        their column's profile point, in the (x, z) plane, mm."""
        _, cols, _ = self.grid.texture_block(t)
        p = self.grid.point[cols].astype(np.float64)
        q = v.reshape(*t.shape, 3).astype(np.float64)
        far = float(np.hypot(q[..., 0] - p[None, :, 0], q[..., 2] - p[None, :, 1]).max())
        return far, far

    @property
    def bounds(self) -> np.ndarray:
        lo = np.full(3, np.inf)
        hi = -lo
        for _, v, _, _ in self.blocks():  # per tile
            lo, hi = np.minimum(lo, v.min(axis=0)), np.maximum(hi, v.max(axis=0))
        return np.array([lo, hi], dtype=np.float64)

    def __repr__(self) -> str:
        nr, nc = self.grid.nodes
        return f"TiledSurfaceMesh({nr} x {nc - 1} nodes in {self.grid.count} tiles, {self.num_triangles:,} triangles)"


def tiled_surface(surface: Any, texture: Any, *, pitch: float = 0.125, height: float = 1.0, mapping: str = "angle",
                  tile: Optional[int] = None, max_memory: Any = None, periodic_x: Optional[bool] = None,
                  transition: Optional[float] = None) -> tuple[TiledSurfaceMesh, Any]:
    """A closed 2.5D surface (a :class:`texcad.Surface` whose profile is closed and has
    no corners, its base the profile's solid: e.g. ``Surface.cylinder(r, length)``)
    textured whole, raised, as tiles: ``(mesh, expectation)``; ``mesh.gate(expectation)``
    checks it (checks 1-5, the volume against the texture's integral) and
    ``mesh.write("part.stl")`` streams it, tile by tile. ``texcad.texture`` takes this
    path by itself on such a surface when the untiled one would not fit in memory.

    The texture is fitted and mapped as :func:`texcad.texture` does on that surface
    (:func:`texcad.mapping.fit_texture`, :func:`texcad.mapping.map_texture` with
    ``mapping``: its columns' profile points and offsets, taken from a two-row strip
    holding the texture's highest row), so every texture vertex is the untiled
    slab's top grid vertex, the same float32 numbers (tested). What differs: the ends.
    The untiled slab ends in walls at the first and last texture row and is united
    with the base; the tiled surface runs from those rows down to the profile at y = 0
    and ``length`` (as the tiled plate's rim), closed by flat caps: the volume differs
    by at most ``2 x perimeter x (margin + py / 2) x height / 2`` (``margin`` the
    length the texture leaves at each end, ``py`` its row pitch). Lengths in mm.

    Raises:
        ParameterError: an open profile, a profile with corners, a base that is not
            the profile's solid, or a bad texture or parameter.
        ResourceError: ``max_memory`` leaves no room for a tile.
    """
    from ..mapping import fit_texture

    if not surface.profile.closed:
        raise ParameterError("tiled_surface takes a closed profile (a full cylinder, a closed spline); "
                             "texture open surfaces with texcad.texture")
    hm, periodic = fit_texture(surface.profile, texture, length=float(surface.length), pitch=pitch, height=height,
                               periodic_x=periodic_x)
    return surface_tiles(surface, hm, periodic, mapping=mapping, transition=transition, tile=tile, max_memory=max_memory)


class NotTiled(ParameterError):
    """A surface :func:`surface_tiles` does not make; ``reason`` names what (``"an
    open profile"``)."""

    def __init__(self, message: str, reason: str) -> None:
        super().__init__(message)
        self.reason = reason


#: Texture pixels per block when the tiled surface's integral is summed (a block of
#: whole rows, float64 temporaries: some 100 bytes a pixel).
INTEGRAL_BLOCK = 1 << 18


def surface_tiles(surface: Any, hm: Heightmap, periodic: bool, *, mapping: str = "angle", transition: Optional[float] = None,
                  tile: Optional[int] = None, max_memory: Any = None, base: Any = None,
                  share: float = 0.0, gain: Any = None) -> tuple[TiledSurfaceMesh, Any]:
    """:func:`tiled_surface` from the texture already fitted to the surface (``hm``,
    heights mm, and whether it is ``periodic`` round the profile, as
    :func:`texcad.mapping.fit_texture` returns them); ``base``: the surface's base
    as a :class:`texcad.Mesh` (default: meshed here). Returns ``(mesh, expectation)``.

    ``share``: the mode's share ``c`` of the full height ``H`` (the texture's highest
    point) that goes under the surface (:mod:`texcad.mapping.modes`): 0 raised, 1/2
    centred, 1 engraved. The tiles' texture sheet is ``P + (h - c H) v`` (``P`` the
    column's profile point, ``v`` the mapping's offset per mm): the sheet the untiled
    modes put there (their ``t = h - c H``), as one closed surface instead of a slab
    and a cutter united with and cut from the base. Where it differs: an engraved
    cutter reaches at least :data:`texcad.mapping.CUT_FLOOR` (0.01 mm) under the
    surface, so the untiled texture's top (``t > -CUT_FLOOR``) lies up to that much
    deeper than the tiles'; elsewhere the points agree to float32 rounding (tested).
    The ends slope from the first and last texture row (``t``) to the profile, as in
    raised mode. ``gain``: a gradient's gain, ``gain(points)`` -> ``g`` in [0, 1] at
    ``(N, 3)`` points mm (:func:`texcad.targets.surface.gradient_gain` with the
    gradient), taken at the raised sheet's points as the untiled surface takes it:
    ``t = g (h - c H)``.

    The expectation's volume is the texture's integral as the untiled surface sums it
    (:func:`texcad.targets.surface.surface_volume` at tolerance 0: the swept prisms
    between the profile's polygon and the texture sheet, signed: raised +, engraved
    -, less the chord excess), summed over blocks of rows; its slack is the untiled
    one's plus the ends' difference (see :func:`tiled_surface`). Its nominal volume is
    that integral (None when centred, as untiled: its net is about 0 by design).

    Raises:
        ParameterError: an open profile, a profile with corners or a base that is not
            the profile's solid (what the tiles do not make).
        ResourceError: ``max_memory`` leaves no room for a tile.
    """
    from ..mapping import map_texture
    from ..mapping.surface import chord_excess
    from ..options import memory_bytes
    from ..report.gate import Expectation
    from ..solid.tiles import SurfaceGrid

    prof, length = surface.profile, float(surface.length)
    if not prof.closed:
        raise NotTiled("tiled_surface takes a closed profile (a full cylinder, a closed spline); "
                       "texture open surfaces with texcad.texture", "an open profile")
    h = np.asarray(hm.heights, dtype=np.float32)
    top_row = int(np.unravel_index(int(np.argmax(h)), h.shape)[0])
    strip = Heightmap(np.ascontiguousarray(h[[0, top_row]]), hm.pitch)  # the columns depend on the highest point only
    m = map_texture(prof, strip, mapping=mapping, length=length, periodic_x=periodic, transition=transition)
    if len(m.s) != m.heightmap.shape[1]:
        raise NotTiled("the profile has corners (extra columns there): tiled_surface takes smooth closed profiles",
                       "a profile with corners")
    r, py = h.shape[0], float(hm.pitch[1])
    y = y_rows(length, r, py)
    point = np.asarray(prof.at(m.s).point, dtype=np.float32)
    offset = np.asarray(m.offset, dtype=np.float32)
    area = 0.5 * float(np.sum(point[:, 0].astype(np.float64) * np.roll(point[:, 1], -1) - np.roll(point[:, 0], -1) * point[:, 1]))
    if base is None:
        base = surface.base if hasattr(surface.base, "faces") and hasattr(surface.base, "vertices") else None
    if base is None:
        from ..brep import shape_to_mesh

        base = shape_to_mesh(surface.base)
    if abs(float(base.volume) - abs(area) * length) > 0.01 * abs(area) * length:
        raise NotTiled(f"tiled_surface takes a surface whose base is its profile's solid ({abs(area) * length:.0f} mm3); "
                       f"this base is {float(base.volume):.0f} mm3 (a tube?)", "a base that is not its profile's solid")
    full = float(h.max())  # the envelope H of engraved and centred textures, mm
    if gain is not None:
        h = _graded(h, share * full, point, offset, y, gain)
    elif share:
        h = h - np.float32(share * full)  # the offsets t = h - c H along v
    c = len(m.s)
    nodes = (r + 2, c + 1)
    side = int(tile) if tile else tile_for_memory(None if max_memory is None else memory_bytes(max_memory), nodes)
    grid = SurfaceGrid((r, c), y, length, point, offset, side)
    t = point[1].astype(np.float64) - point[0]
    normal = np.array([-t[1], t[0]])  # the grid triangles' normal, (x, z)
    flip = float(normal @ m.offset[0]) < 0
    top = float(np.abs(h).max())
    reach = top * float(np.hypot(offset[:, 0], offset[:, 1]).max()) + 1e-3
    # check 4: surface_volume (tolerance 0), block by block of rows
    s = np.asarray(m.s, np.float64)
    vol = _surface_integral(prof, s, y, point, offset, h, raised=not share)
    span = float(y[-1] - y[0])
    chord = chord_excess(prof, s, closed=True)
    vol -= chord * span
    sheet = prof.length * span
    slack = 0.01 * sheet + abs(chord) * span + 1e-3 * abs(vol) + 1e-3  # the untiled slack (tessellation, chords, float32)
    end = float(y[0])  # each end: the slope from the first (last) texture row to the profile, and the polygon's caps
    slack += 2 * (prof.length + 2 * np.pi * reach) * end * reach / 2 + 2 * abs(chord) * end
    nominal = None if share not in (0, 1) else vol
    ex = Expectation(bodies=1, base=base, height=reach, volume=vol, volume_slack=slack, nominal_volume=nominal)
    return TiledSurfaceMesh(grid, h, flip), ex


def y_rows(length: float, rows: int, py: float) -> np.ndarray:
    """``(rows,)`` float64 y (mm) of the texture's rows on a surface ``length`` mm long,
    centred, as :func:`texcad.mapping.map_texture` places them."""
    return (length - rows * py) / 2 + (np.arange(rows) + 0.5) * py


def _graded(h: np.ndarray, low: float, point: np.ndarray, offset: np.ndarray, y: np.ndarray, gain: Any) -> np.ndarray:
    """``g (h - low)`` float32 mm, ``g = gain(points)`` at the raised sheet's points
    ``point + h offset`` (float32, as the untiled mapped top), in blocks of whole rows."""
    r, c = h.shape
    out = np.empty((r, c), np.float32)
    rows = max(1, INTEGRAL_BLOCK // max(c, 1))
    for r0 in range(0, r, rows):  # per block of rows
        hb = h[r0 : r0 + rows]
        top = np.empty(hb.shape + (3,), np.float32)
        top[..., 0] = hb * offset[:, 0]
        top[..., 0] += point[:, 0]
        top[..., 1] = y[r0 : r0 + rows, None]
        top[..., 2] = hb * offset[:, 1]
        top[..., 2] += point[:, 1]
        g = np.asarray(gain(top.reshape(-1, 3).astype(np.float64)), np.float64).reshape(hb.shape)
        out[r0 : r0 + rows] = g * (hb.astype(np.float64) - low)
    return out


def _surface_integral(prof: Any, s: np.ndarray, y: np.ndarray, point: np.ndarray, offset: np.ndarray, h: np.ndarray,
                      raised: bool = True) -> float:
    """The swept volume (mm^3) between the profile's polygon through ``point`` (at arc
    lengths ``s``) and the sheet ``point + h offset`` (float32, as the tiles'
    vertices) over the texture rows ``y`` (mm), signed (under the profile:
    negative), or with ``raised`` only where it lies outside the profile (as the
    untiled raised surface counts it):
    :func:`texcad.mapping.surface.grid_swept` over blocks of whole rows (a block's
    last row is the next one's first)."""
    from ..mapping.surface import grid_swept

    r, c = h.shape
    fc = prof.at(s)
    nrm = np.zeros((c, 3))
    nrm[:, 0], nrm[:, 2] = fc.normal[:, 0], fc.normal[:, 1]
    p = np.asarray(fc.point, np.float64)
    rows = max(2, INTEGRAL_BLOCK // max(c, 1))
    vol = 0.0
    for r0 in range(0, r - 1, rows - 1):  # per block of rows
        r1 = min(r, r0 + rows)
        n = r1 - r0
        base = np.empty((n, c, 3))
        base[..., 0], base[..., 1], base[..., 2] = p[None, :, 0], y[r0:r1, None], p[None, :, 1]
        hb = h[r0:r1]
        top = np.empty((n, c, 3), np.float32)  # as SurfaceGrid.vertices (and map_texture's top grid)
        top[..., 0] = hb * offset[:, 0]
        top[..., 0] += point[:, 0]
        top[..., 1] = y[r0:r1, None]
        top[..., 2] = hb * offset[:, 1]
        top[..., 2] += point[:, 1]
        new = top.astype(np.float64)
        if raised:
            up = np.einsum("rck,ck->rc", new - base, nrm)
            new = np.where((up > 0)[..., None], new, base)
        vol += grid_swept(base, new, np.broadcast_to(nrm, (n, c, 3)), wrap_cols=True, measure=False).volume
    return vol
