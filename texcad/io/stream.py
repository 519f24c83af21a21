"""Streaming writers: binary STL and 3MF written block by block (mm).

A large result (a tiled plate, :mod:`texcad.targets.tiled`) is made tile by tile;
these writers take each tile's triangles as it comes, so the whole mesh never sits in
memory, let alone twice. Both write to a temporary file in the target folder and
rename it when closed without error (:func:`texcad.util.atomic_path`).

* :class:`StlStream`: records are written as blocks arrive; the triangle count in
  the header is written last (seek back to byte 80).
* :class:`ThreeMFStream`: a 3MF's ``<vertices>`` must all come before its
  ``<triangles>``: vertices go straight into the (deflated, ZIP64) model entry,
  triangles into a temporary file beside the output, appended when it is closed.
  Vertices shared between blocks (a tile's border rows) are written once: a block
  says which of its vertices are new through their global numbers.

Both take a block as ``add(vertices, faces, ids=None)``: ``vertices`` ``(k, 3)``
float32 mm, ``faces`` ``(m, 3)`` indices into them (counter-clockwise seen from
outside), ``ids`` ``(k,)`` each vertex's number in the whole mesh (None: the block's
vertices are all new and numbered on from the last).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import zipfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Iterable, Mapping, Optional

import numpy as np

from ..errors import GeometryError, ParameterError
from ..util import atomic_path, threads
from ..util.atomic import track, untrack
from .export import (CURA_NAMESPACE, GRID_BITS, SLIC3R_CONFIG, _CT, _RELS, _STL_CHUNK, _STL_DTYPE, _cura_metadata, _grid_vertex_rows,
                     _one_volume, _slic3r_config, _stl_records, _transform, _triangle_rows, _xml_escape, _zip_info, _on_grid)

__all__ = ["StlStream", "ThreeMFStream", "open_stream"]


class _Stream:
    """Shared parts: the atomic temporary path, counts, context manager."""

    def __init__(self, path: "str | os.PathLike") -> None:
        self.path = Path(path)
        self._atomic = atomic_path(self.path)
        self._tmp = self._atomic.__enter__()
        self.triangles = 0
        self.vertices = 0
        self._closed = False

    def __enter__(self):
        return self

    def __exit__(self, kind, exc, tb) -> None:
        if exc is None:
            self.close()
        else:
            self.abort(exc)

    def _finish(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def close(self) -> Path:
        """Finish the file and rename it to its name."""
        if self._closed:
            return self.path
        self._closed = True
        try:
            self._finish()
        except BaseException as exc:
            self._atomic.__exit__(type(exc), exc, exc.__traceback__)
            raise
        self._atomic.__exit__(None, None, None)
        return self.path

    def abort(self, exc: Optional[BaseException] = None) -> None:
        """Drop the temporary file: the output is left as it was."""
        if self._closed:
            return
        self._closed = True
        self._release()
        exc = exc or RuntimeError("aborted")
        with contextlib.suppress(BaseException):
            self._atomic.__exit__(type(exc), exc, exc.__traceback__)

    def _release(self) -> None:
        pass

    @staticmethod
    def _check(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        v = np.ascontiguousarray(vertices, dtype=np.float32)
        f = np.ascontiguousarray(faces, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
            raise ParameterError(f"a block is vertices (k, 3) and faces (m, 3), got {v.shape} and {f.shape}")
        if len(f) and (f.min() < 0 or f.max() >= len(v)):
            raise ParameterError(f"a block's faces index vertices 0..{len(v) - 1}, got {f.min()}..{f.max()}")
        if not np.all(np.isfinite(v)):
            raise GeometryError("a block has vertices that are not finite numbers")
        return v, f


class StlStream(_Stream):
    """A binary STL written block by block (float32, mm); the header's triangle count
    is written when the stream is closed. ``ids`` are not needed (an STL repeats each
    triangle's corners) and are ignored."""

    def __init__(self, path: "str | os.PathLike", *, header: str = "texcad binary STL, units mm") -> None:
        head = header.encode("ascii", "replace")[:80].ljust(80, b" ")
        if head.lower().startswith(b"solid"):
            raise ParameterError("an STL header must not start with 'solid'")
        super().__init__(path)
        self._pool: "ThreadPoolExecutor | None" = None
        self._fh = open(self._tmp, "wb")
        self._fh.write(head)
        self._fh.write(b"\0\0\0\0")

    def add(self, vertices: np.ndarray, faces: np.ndarray, ids: Optional[np.ndarray] = None) -> None:
        v, f = self._check(vertices, faces)
        n = threads()

        def records(a: int) -> np.ndarray:
            rec = np.empty(min(_STL_CHUNK, len(f) - a), dtype=_STL_DTYPE)
            _stl_records(v, f[a : a + _STL_CHUNK], rec)
            return rec

        starts = list(range(0, len(f), _STL_CHUNK))
        if n > 1 and len(starts) > 1:  # a chunk per thread at a time, written in order: the same bytes
            if self._pool is None:
                self._pool = ThreadPoolExecutor(n)
            for g in range(0, len(starts), n):  # per group of chunks
                for rec in self._pool.map(records, starts[g : g + n]):
                    rec.tofile(self._fh)
        else:
            for a in starts:  # per chunk of records
                records(a).tofile(self._fh)
        self.triangles += len(f)
        if self.triangles >= 1 << 32:
            raise ParameterError("an STL holds at most 2^32 - 1 triangles; write .3mf")

    def _finish(self) -> None:
        self._fh.seek(80)
        self._fh.write(np.uint32(self.triangles).tobytes())
        self._release()

    def _release(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        self._fh.close()


class ThreeMFStream(_Stream):
    """A 3MF package (one object, ``unit="millimeter"``) written block by block.
    Triangles wait in a temporary file in the output's folder, not in memory.

    As :func:`texcad.io.write_3mf` writes a one-part object: ``build_dir`` (None: as
    placed) turned to +z with the lowest point on the bed, PrusaSlicer's per-object
    ``settings`` and Cura's ``cura_settings`` (:func:`texcad.io.cura_settings`), the
    vertices on its grid of ``2^-14`` mm (the same bytes for coordinates under 256 mm;
    past that write_3mf's grid is coarser, chosen from the whole mesh)."""

    def __init__(self, path: "str | os.PathLike", *, name: str = "texcad part", build_dir: Any = None,
                 settings: Mapping[str, Any] | None = None, cura_settings: Mapping[str, Any] | None = None) -> None:
        super().__init__(path)
        from ..util import rotation_to_z

        self._name, self._settings = name, settings
        self._R = None if build_dir is None else rotation_to_z(np.asarray(build_dir, dtype=np.float64).reshape(-1, 3)[0])
        self._z0 = np.inf
        meta = _cura_metadata(cura_settings)
        self._zip = zipfile.ZipFile(self._tmp, "w")
        for arcname, data in (("[Content_Types].xml", _CT), ("_rels/.rels", _RELS)):
            self._zip.writestr(_zip_info(arcname), data, compresslevel=1)
        info = _zip_info("3D/3dmodel.model")
        info._compresslevel = 1
        self._model = self._zip.open(info, "w", force_zip64=True)
        self._model.write(
            b'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xml:lang="en-US" '
            b'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"'
            + (f' xmlns:cura="{CURA_NAMESPACE}"'.encode() if meta else b"")
            + b'>\n<metadata name="Application">texcad</metadata>\n<resources>\n'
            + f'<object id="1" type="model" name="{_xml_escape(name)}">'.encode() + meta + b"<mesh><vertices>\n"
        )
        fd, self._tri_path = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".triangles", dir=self.path.parent)
        track(self._tri_path)
        self._tri = os.fdopen(fd, "w+b")

    def add(self, vertices: np.ndarray, faces: np.ndarray, ids: Optional[np.ndarray] = None) -> None:
        v, f = self._check(vertices, faces)
        if ids is None:
            ids = np.arange(self.vertices, self.vertices + len(v), dtype=np.int64)
        ids = np.asarray(ids, dtype=np.int64)
        if ids.shape != (len(v),):
            raise ParameterError(f"ids must give one number per vertex ({len(v)}), got shape {ids.shape}")
        new = ids >= self.vertices
        order = np.argsort(ids[new], kind="stable")
        if not np.array_equal(ids[new][order], np.arange(self.vertices, self.vertices + int(new.sum()))):
            raise ParameterError("a block's new vertices must be numbered on from the last block's, without gaps")
        g = _on_grid(v[new][order], GRID_BITS)  # write_3mf's grid for coordinates under 256 mm
        self._model.write(_grid_vertex_rows(g, GRID_BITS))
        if self._R is not None and new.any():  # the lowest point along build_dir so far
            self._z0 = min(self._z0, float((g.astype(np.float64) @ self._R[2]).min()))
        self.vertices += int(new.sum())
        self._tri.write(_triangle_rows(ids[f]))
        self.triangles += len(f)

    def _finish(self) -> None:
        self._model.write(b"</vertices><triangles>\n")
        self._tri.seek(0)
        shutil.copyfileobj(self._tri, self._model, 1 << 22)
        place = b"" if self._R is None else f' transform="{_transform(self._R, self._z0)}"'.encode()
        self._model.write(b"</triangles></mesh></object>\n</resources>\n<build><item objectid=\"1\"" + place + b"/></build>\n</model>\n")
        self._model.close()
        if self._settings and self.triangles:
            self._zip.writestr(_zip_info(SLIC3R_CONFIG), _slic3r_config(self._name, self._settings, _one_volume(self._name, self.triangles)),
                               compresslevel=1)
        self._zip.close()
        self._release()

    def _release(self) -> None:
        with contextlib.suppress(Exception):
            self._model.close()
        with contextlib.suppress(Exception):
            self._zip.close()
        self._tri.close()
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self._tri_path)
        untrack(self._tri_path)


def open_stream(path: "str | os.PathLike", **kwargs) -> "StlStream | ThreeMFStream":
    """A streaming writer by the file's extension: ``.stl`` or ``.3mf``."""
    suffix = Path(path).suffix.lower()
    if suffix == ".stl":
        return StlStream(path, **kwargs)
    if suffix == ".3mf":
        return ThreeMFStream(path, **kwargs)
    raise ParameterError(f"streamed output {str(path)!r}: use .stl or .3mf (a STEP needs the whole B-rep)")


def write_blocks(path: "str | os.PathLike", blocks: Iterable[tuple]) -> Path:
    """Write ``(vertices, faces[, ids])`` blocks to ``path`` (.stl / .3mf) as they come."""
    with open_stream(path) as s:
        for block in blocks:  # per block
            s.add(*block)
    return Path(path)
