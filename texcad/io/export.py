"""Writing meshes as binary STL and 3MF (millimetre units).

Both writers go through :func:`texcad._atomic.atomic_path`: the file is written under
a temporary name in the target folder and renamed when complete, so a failure never
leaves a half-written file.
"""

from __future__ import annotations

import collections
import itertools
import os
import zipfile
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Sequence

import numpy as np

from ..util import atomic_path, threads
from ..errors import GeometryError, ParameterError
from ..solid import Mesh

__all__ = [
    "write_stl",
    "write_3mf",
    "write_3mf_items",
    "export",
    "slicer_settings",
    "cura_settings",
    "CURA_TEXTURE_SETTINGS",
    "CURA_SINGLE_RUN_SETTINGS",
    "single_run",
    "slicer_layout",
    "extra_perimeter_cut",
    "SlicerLayout",
    "BRIDGING_FREE_ANGLE",
    "TEXTURE_SEAM",
    "EXTRA_PERIMETER_SHARE",
    "CUT_MIN_WORK",
]

_STL_DTYPE = np.dtype([("normal", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])


def _require_watertight(mesh: Mesh, path: str | os.PathLike) -> None:
    if not mesh.is_watertight:
        raise GeometryError(
            f"refusing to write {os.fspath(path)!r}: the mesh is not watertight; "
            "fuse it with texcad.fuse() or report a bug"
        )


def write_stl(mesh: Mesh, path: str | os.PathLike, *, header: str = "texcad binary STL, units mm") -> None:
    """Write a binary STL (little-endian float32, units mm).

    Args:
        mesh: a watertight mesh.
        path: output file.
        header: up to 80 ASCII characters for the STL header (must not start with
            ``solid``, which would make readers think the file is ASCII).
    """
    _require_watertight(mesh, path)
    head = header.encode("ascii", "replace")[:80].ljust(80, b" ")
    if head.lower().startswith(b"solid"):
        raise ParameterError("an STL header must not start with 'solid'")
    f = mesh.faces
    rec = np.empty(len(f), dtype=_STL_DTYPE)
    # Records in cache-sized chunks, on two threads (numpy releases the GIL); each
    # chunk's bytes do not depend on the split.
    starts = range(0, len(f), _STL_CHUNK)
    if len(starts) > 1 and threads() > 1:
        with ThreadPoolExecutor(2) as pool:
            list(pool.map(lambda a: _stl_records(mesh.vertices, f[a : a + _STL_CHUNK], rec[a : a + _STL_CHUNK]), starts))
    else:
        for a in starts:
            _stl_records(mesh.vertices, f[a : a + _STL_CHUNK], rec[a : a + _STL_CHUNK])
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            fh.write(head)
            fh.write(np.uint32(len(f)).tobytes())
            rec.tofile(fh)


_STL_CHUNK = 1 << 16


def _stl_records(vertices: np.ndarray, faces: np.ndarray, out: np.ndarray) -> None:
    """Fill STL records ``out`` (``_STL_DTYPE``) for ``faces``: the unit normal (zero for a
    degenerate triangle), the three corners in mm, attribute 0; float32 throughout."""
    tri = vertices[faces]  # (m, 3, 3)
    e1 = tri[:, 1] - tri[:, 0]
    e2 = tri[:, 2] - tri[:, 0]
    n = np.empty_like(e1)
    n[:, 0] = e1[:, 1] * e2[:, 2] - e1[:, 2] * e2[:, 1]
    n[:, 1] = e1[:, 2] * e2[:, 0] - e1[:, 0] * e2[:, 2]
    n[:, 2] = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    length = np.sqrt(n[:, 0] * n[:, 0] + n[:, 1] * n[:, 1] + n[:, 2] * n[:, 2])[:, None]
    np.divide(n, length, out=n, where=length > 0)
    out["normal"] = n
    out["v"] = tri
    out["attr"] = 0


_CT = """<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">
 <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>
 <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>
</Types>
"""
_RELS = """<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>
"""


def _fmt_rows(template: str, arr: np.ndarray) -> bytes:
    """Format every row of ``arr`` with a ``%``-template in one C-level call.

    Repeating the template ``len(arr)`` times and applying ``%`` to the flattened
    array formats all rows without a Python loop per vertex.
    """
    return ((template * len(arr)) % tuple(arr.ravel().tolist())).encode("ascii")


_ROWS = 1 << 15  # rows per chunk of the bulk formatter and per piece the writer compresses


def _digits(k: np.ndarray, width: int, keep: int) -> np.ndarray:
    """``(n, width)`` ASCII digits of the integers ``0 <= k < 10^width``, right-aligned,
    with 0 (no byte) for leading zeros left of the last ``keep`` columns."""
    out = np.empty((len(k), width), dtype=np.uint8)
    rest = k.copy()
    for j in range(width - 1, -1, -1):  # per column, right to left
        rest, d = np.divmod(rest, 10)
        out[:, j] = 48 + d
        if j < width - keep:
            out[:, j] *= k >= 10 ** (width - 1 - j)  # a leading zero: no byte
    return out


def _fixed4(x: np.ndarray) -> np.ndarray | None:
    """``"%.4f"`` of float32 values ``x`` (as float64) as ``(n, w + 6)`` bytes, 0 = none;
    None if a value needs more than 9 integer digits or is not finite. ``|x| 10^4`` is
    exact for a float32 (24 + 14 bits), so ``rint`` (ties to even) rounds as ``%``."""
    if not np.all(np.isfinite(x)) or (len(x) and np.abs(x).max() >= 1e9):
        return None
    k = np.rint(np.abs(x) * 1e4).astype(np.int64)
    ip, fp = np.divmod(k, 10000)
    w = _width(ip)
    out = np.zeros((len(x), w + 6), dtype=np.uint8)
    out[:, 0] = np.where(np.signbit(x), 45, 0)  # '-', also for -0.0 and what rounds to 0
    out[:, 1 : w + 1] = _digits(ip, w, 1)
    out[:, w + 1] = 46  # '.'
    out[:, w + 2 :] = _digits(fp, 4, 4)
    return out


def _width(k: np.ndarray) -> int:
    """Digits of the largest of ``k >= 0`` (at least 1)."""
    return len(str(int(k.max()))) if len(k) else 1


def _bulk_rows(parts: list, n: int) -> bytes:
    """Rows made of literal byte strings and ``(n, w)`` byte fields (0 = none),
    concatenated and the zeros dropped: one array pass per column block."""
    width = sum(len(p) if isinstance(p, bytes) else p.shape[1] for p in parts)
    mat = np.empty((n, width), dtype=np.uint8)
    c = 0
    for p in parts:  # per piece of the row (a handful)
        w = len(p) if isinstance(p, bytes) else p.shape[1]
        mat[:, c : c + w] = np.frombuffer(p, dtype=np.uint8) if isinstance(p, bytes) else p
        c += w
    flat = mat.ravel()
    return flat[flat != 0].tobytes()


def _vertex_rows(v: np.ndarray) -> bytes:
    """``<vertex x="%.4f" y="%.4f" z="%.4f"/>`` rows, formatted in bulk with numpy
    (the same bytes as ``%``; tested), ``%`` where a value does not fit."""
    out = []
    for a in range(0, len(v), _ROWS):  # per chunk of rows
        c = v[a : a + _ROWS].astype(np.float64)
        f = [_fixed4(c[:, k]) for k in range(3)]
        if any(x is None for x in f):
            out.append(_fmt_rows('<vertex x="%.4f" y="%.4f" z="%.4f"/>\n', c))
            continue
        out.append(_bulk_rows([b'<vertex x="', f[0], b'" y="', f[1], b'" z="', f[2], b'"/>\n'], len(c)))
    return b"".join(out)


#: Fraction bits of the finest grid :func:`write_3mf` puts vertices on: 2^-14 mm (61 nm).
GRID_BITS = 14
_GRID_SPARE = 22  # grid = 2^(E - 22) for |x| < 2^E: 2 bits of float32's 24 to spare (see _grid_bits)


def _grid_bits(v: np.ndarray) -> int:
    """Fraction bits ``k`` of the binary grid ``2^-k`` mm on which :func:`write_3mf`
    writes the coordinates ``v``, so that PrusaSlicer's loading is exact.

    With every ``|x| < 2^E`` and ``x`` a multiple of ``g = 2^(E - 22)`` (so
    ``k = 22 - E``, at most :data:`GRID_BITS`): ``x`` has at most 22 significant bits,
    exact in float32 (24); a bounding-box centre ``s = (lo + hi) / 2`` is a multiple
    of ``g / 2`` under ``2^E`` (23 bits: exact in float32, where PrusaSlicer rounds
    it, ``ModelVolume::center_geometry_after_creation``); ``x - s`` is a multiple of
    ``g / 2`` of at most ``2^(E + 1)`` (24 bits: exact); and adding the part's
    offset back (``s`` and a lift ``-z0`` on the same grid) gives ``x`` (or
    ``x - z0``) exactly. So every part of an object loads with, along the build
    direction, the very float32 coordinates the whole mesh loads with, wherever
    PrusaSlicer centres it."""
    m = float(np.abs(v).max()) if len(v) else 0.0
    if not np.isfinite(m):
        return GRID_BITS
    e = max(int(np.floor(np.log2(m))) + 1, 0) if m > 0 else 0  # smallest E with m < 2^E
    if m >= 2.0**e:  # log2 rounding
        e += 1
    return min(GRID_BITS, _GRID_SPARE - e)


def _on_grid(v: np.ndarray, bits: int) -> np.ndarray:
    """``v`` (mm) rounded to the nearest multiples of ``2^-bits`` mm (ties to even),
    float32 (exact there for ``|v| < 2^(24 - bits)``)."""
    return (np.rint(np.asarray(v, dtype=np.float64) * 2.0**bits) / 2.0**bits).astype(np.float32)


def _exact(x: np.ndarray, bits: int) -> np.ndarray | None:
    """The exact decimal of each ``x`` (float64 multiples of ``2^-bits``, ``0 <= bits
    <= 16``) as ``(n, w)`` bytes (0 = none), trailing zeros of the fraction (and a
    bare point) left out: ``m 2^-bits = m 5^bits / 10^bits``, so the digits of the
    integer ``|m| 5^bits`` with ``bits`` of them after the point. None if
    ``|m| 5^bits`` would pass int64 or a value is not finite."""
    if not np.all(np.isfinite(x)):
        return None
    m = np.rint(np.abs(x) * 2.0**bits).astype(np.int64) if len(x) else np.zeros(0, np.int64)
    if len(m) and int(m.max()) >= (2**62) // 5**bits:
        return None
    k = m * 5**bits
    ip, fp = np.divmod(k, 10**bits)
    w = _width(ip)
    out = np.zeros((len(x), w + 2 + bits), dtype=np.uint8)
    out[:, 0] = np.where(np.signbit(x) & (m > 0), 45, 0)  # '-' (not for 0)
    out[:, 1 : w + 1] = _digits(ip, w, 1)
    if bits:
        out[:, w + 1] = 46  # '.'
        frac = _digits(fp, bits, bits)
        last = np.zeros(len(x), dtype=bool)  # a nonzero digit at or right of this column
        for j in range(bits - 1, -1, -1):  # per fraction column, right to left: drop trailing zeros
            last |= frac[:, j] != 48
            frac[:, j] *= last
        out[:, w + 2 :] = frac
        out[:, w + 1] *= fp > 0  # no bare point
    return out


def _grid_vertex_rows(v: np.ndarray, bits: int) -> bytes:
    """``<vertex x=".." y=".." z=".."/>`` rows of ``v`` (multiples of ``2^-bits``
    mm), each coordinate as its exact decimal (:func:`_exact`), which every reader
    parses to that very float32, formatted in bulk with numpy; ``%r`` of the float64
    (also exact, longer) where a value does not fit."""
    out = []
    for a in range(0, len(v), _ROWS):  # per chunk of rows
        c = v[a : a + _ROWS].astype(np.float64)
        f = [_exact(c[:, k], bits) if 0 <= bits <= 16 else None for k in range(3)]
        if any(x is None for x in f):
            out.append(_fmt_rows('<vertex x="%r" y="%r" z="%r"/>\n', c))
            continue
        out.append(_bulk_rows([b'<vertex x="', f[0], b'" y="', f[1], b'" z="', f[2], b'"/>\n'], len(c)))
    return b"".join(out)


def _triangle_rows(t: np.ndarray) -> bytes:
    """``<triangle v1="%d" v2="%d" v3="%d"/>`` rows, formatted in bulk with numpy."""
    out = []
    for a in range(0, len(t), _ROWS):  # per chunk of rows
        c = t[a : a + _ROWS].astype(np.int64)
        f = [_digits(c[:, k], _width(c[:, k]), 1) for k in range(3)]
        out.append(_bulk_rows([b'<triangle v1="', f[0], b'" v2="', f[1], b'" v3="', f[2], b'"/>\n'], len(c)))
    return b"".join(out)


def _object_parts(oid: int, name: str, mesh: Mesh, meta: bytes = b"", bits: int | None = None) -> Iterator[bytes]:
    """The ``<object>`` element of ``mesh`` in pieces of at most ``_ROWS`` rows, each
    formatted when asked for (a generator), so that a writer can compress one piece
    while the next is formatted. Joined, they are the same bytes for any split.
    ``meta``: the object's ``<metadatagroup>`` (:func:`_cura_metadata`), or empty.
    ``bits``: the vertices lie on the grid ``2^-bits`` mm (:func:`_grid_bits`) and are
    written as exact decimals; None: ``%.4f`` (0.1 um)."""
    yield f'<object id="{oid}" type="model" name="{name}">'.encode() + meta + b"<mesh><vertices>\n"
    for a in range(0, len(mesh.vertices), _ROWS):  # per chunk of rows
        c = mesh.vertices[a : a + _ROWS]
        yield _vertex_rows(c) if bits is None else _grid_vertex_rows(c, bits)
    yield b"</vertices><triangles>\n"
    for a in range(0, len(mesh.faces), _ROWS):  # per chunk of rows
        yield _triangle_rows(mesh.faces[a : a + _ROWS])
    yield b"</triangles></mesh></object>\n"


def _size_bound(mesh: Mesh) -> int:
    """An upper bound of the bytes :func:`_object_parts` writes for ``mesh``: rows times
    their widest form (``%.4f`` of ``|x| < 10^9`` takes at most 15 characters, an
    exact grid decimal at most 1 + 19 + 1 + 16 = 37; larger values at most 50;
    indices at most 10 digits); the name, head and tail not counted."""
    big = len(mesh.vertices) and not float(np.abs(mesh.vertices).max()) < 1e9
    return len(mesh.vertices) * (27 + 3 * (50 if big else 37)) + len(mesh.faces) * 62


def write_3mf(
    mesh: Mesh | Sequence[tuple[str, Mesh]],
    path: str | os.PathLike,
    *,
    name: str = "texcad part",
    build_dir=None,
    settings: Mapping[str, Any] | None = None,
    part_settings: Sequence[Mapping[str, Any]] | None = None,
    cura_settings: Mapping[str, Any] | None = None,
) -> None:
    """Write a 3MF package (3MF core spec, ``unit="millimeter"``), zip-deflated.

    Args:
        mesh: a watertight mesh, or a list of ``(name, mesh)`` parts (e.g. base and
            texture) to write as **one object made of several parts**, the way
            slicers read multi-part objects: one ``<object>`` whose mesh holds the
            parts' triangles one after the other (each part keeps its own
            vertices, so each stays a closed shell), and
            ``Metadata/Slic3r_PE_model.config`` naming the triangle range of each
            part (PrusaSlicer's, SuperSlicer's and OrcaSlicer's convention). The
            slicer then loads one object with the parts placed together, each of
            which can get its own extruder, colour or settings. (3MF
            ``<components>`` of separate objects are loaded by PrusaSlicer 2.5 as
            separate objects, which it arranges apart.)
        path: output ``.3mf`` file.
        name: object name shown by slicers.
        build_dir: the part's print orientation, ``(3,)`` in its own frame (for a
            set of directions the first): the build item gets a ``transform`` that
            turns it so ``build_dir`` points up (+z,
            :func:`texcad.util.rotation_to_z`) and rests on the bed (lowest
            point at z = 0), so a slicer loads it as it is meant to print. The
            vertices themselves stay in the part's frame. None: no transform.
        settings: PrusaSlicer per-object settings ``{option: value}`` (its config
            keys, e.g. ``{"overhangs": 0}``; :func:`slicer_settings` gives the ones
            :func:`export` writes), stored as the object's metadata in
            ``Metadata/Slic3r_PE_model.config`` (a one-part object then names its one
            part there too: PrusaSlicer 2.5 loads no part of an object listed there
            without one). The slicer applies them to this object only, over the
            print profile; the user sees and can remove them in its object list.
            None or empty: none written.
        part_settings: with several parts, PrusaSlicer per-part settings, one
            mapping per part (written as the part's metadata in the same file; the
            slicer gives that part's slices its own print region), or None.
        cura_settings: Cura per-object settings ``{setting key: value}``
            (:func:`cura_settings`), written as the object's ``<metadatagroup>`` of
            ``cura:`` metadata (3MF core spec metadata, Cura's namespace), which
            Cura's 3MF reader applies to this object over the print profile, as
            its own project files do. None or empty: none written.

    Every coordinate is written on the binary grid ``2^-k`` mm of :func:`_grid_bits`
    (``k = 14``, 61 nm, for coordinates under 256 mm; it moves a vertex by at most
    31 nm, far below any mesh tolerance) as its exact decimal, so that a reader's
    float32 is the value written, and PrusaSlicer's centring of each part of an
    object on its own bounding box in float32 and the offset it adds back are
    exact: a part's vertices are, to the bit, the whole mesh's along the build
    direction. An object of several parts says it is PrusaSlicer's 3MF version 1
    (``slic3rpe:Version3mf``): PrusaSlicer bakes the build item's transform into the
    first part only of a 3MF without it, leaving the others where they are.
    """
    items = [(name, mesh)] if isinstance(mesh, Mesh) else list(mesh)
    if not items:
        raise ParameterError("write_3mf needs a mesh or at least one (name, mesh) part")
    for _, m in items:
        _require_watertight(m, path)
    config = None
    if len(items) == 1:
        label, part = _xml_escape(name if isinstance(mesh, Mesh) else items[0][0]), items[0][1]
        if settings:
            _, _, config = _merged([(name if isinstance(mesh, Mesh) else items[0][0], part)], name, settings)
    else:
        label, part, config = _merged(items, name, settings, part_settings)
    bits = _grid_bits(part.vertices)
    part = Mesh(_on_grid(part.vertices, bits), part.faces)  # moves each coordinate by at most 2^-(bits + 1) mm
    meta = _cura_metadata(cura_settings)
    head = _model_head(bool(meta), len(items) > 1)
    item = b'<item objectid="1"/>' if build_dir is None else f'<item objectid="1" transform="{_print_transform(part, build_dir)}"/>'.encode()
    tail = b"</resources>\n<build>" + item + b"</build>\n</model>\n"
    model = itertools.chain([head], _object_parts(1, label, part, meta, bits), [tail])
    bound = len(head) + len(tail) + len(label.encode()) + len(meta) + 128 + _size_bound(part)
    _write_package(path, model, bound, config)


def write_3mf_items(objects: Sequence[tuple[str, "Mesh | Sequence[tuple[str, Mesh]]", Any]], path: str | os.PathLike, *,
                    build_dir=None, settings: "Sequence[Mapping[str, Any]] | None" = None,
                    cura_settings: "Sequence[Mapping[str, Any]] | None" = None) -> None:
    """Write a 3MF of several objects, one build item each, as a 3MF of several
    build items is laid out by PrusaSlicer and lib3mf: each ``<object>`` holds its
    mesh in its own frame and its ``<item>`` places it with a ``transform``, so that a
    slicer loads as many objects, each where the item puts it, and can arrange them.

    Args:
        objects: ``(name, mesh, transform)`` per object: the watertight mesh where it
            is (mm), or a list of ``(part name, mesh)`` watertight parts (e.g. the
            item's base and texture) written as one object of several parts as
            :func:`write_3mf` writes them (its mesh the parts' triangles in turn,
            ``Metadata/Slic3r_PE_model.config`` naming each part's range,
            ``slic3rpe:Version3mf`` so that PrusaSlicer moves every part with the
            item); and the item's ``(4, 4)`` matrix (row vectors, ``p' = p M``,
            mm) or None (the identity). The object's vertices are the mesh's moved
            by the inverse of ``transform`` (winding reversed where it mirrors, as a
            reader reverses it back), so the item puts them where they are now.
        path: output ``.3mf`` file (atomic: a failure leaves no file).
        build_dir: the parts' print orientation (as :func:`write_3mf`): every item's
            transform is followed by the turn that points it up, all lifted together
            so that the lowest point rests on z = 0. None: as they are.
        settings, cura_settings: per object, PrusaSlicer's and Cura's per-object
            settings (as :func:`write_3mf` writes them for one object), or None.
    """
    if not objects:
        raise ParameterError("write_3mf_items needs at least one (name, mesh, transform) object")
    parts = [[(str(name), mesh)] if isinstance(mesh, Mesh) else [(str(n), m) for n, m in mesh] for name, mesh, _ in objects]
    for (name, _, _), ps in zip(objects, parts):  # per object
        if not ps:
            raise ParameterError(f"write_3mf_items: object {name!r} has no part; give it a mesh or (name, mesh) parts")
        for _, m in ps:
            _require_watertight(m, path)
    turn = _print_turn([m for ps in parts for _, m in ps], build_dir)
    pieces, items, bound = [], [], 0
    for k, ((name, _, tf), ps) in enumerate(zip(objects, parts), start=1):  # per object
        m = np.eye(4) if tf is None else np.asarray(tf, dtype=np.float64).reshape(4, 4)
        part, bits = _in_item(_joined(ps), m)
        meta = _cura_metadata(cura_settings[k - 1] if cura_settings else None)
        pieces.append(_object_parts(k, _xml_escape(str(name)), part, meta, bits))
        bound += _size_bound(part) + len(str(name).encode()) + len(meta) + 256
        placed = m if turn is None else m @ turn
        items.append(f'<item objectid="{k}"' + ("" if tf is None and turn is None else f' transform="{_matrix_text(placed)}"') + "/>")
    several = any(len(ps) > 1 for ps in parts)
    head = _model_head(bool(cura_settings and any(cura_settings)), several)
    tail = ("</resources>\n<build>" + "".join(items) + "</build>\n</model>\n").encode()
    model = itertools.chain([head], *pieces, [tail])
    config = None
    if several or (settings and any(settings)):  # every object listed names its parts (PrusaSlicer loads none otherwise)
        config = _config([_config_object(k, str(name), settings[k - 1] if settings else None,
                                         _volumes([(n, len(m.faces)) for n, m in ps]))
                          for k, ((name, _, _), ps) in enumerate(zip(objects, parts), start=1)])
    _write_package(path, model, bound + len(head) + len(tail), config)


def _in_item(mesh: Mesh, m: np.ndarray) -> tuple[Mesh, int]:
    """``(mesh in the frame of the build item whose (4, 4) row-vector transform is m, on
    the grid of :func:`_grid_bits`; those bits)``: the vertices moved by the inverse of
    ``m``, the winding reversed where ``m`` mirrors (a reader reverses it back)."""
    v = mesh.vertices.astype(np.float64)
    local = v if np.allclose(m, np.eye(4)) else (np.c_[v, np.ones(len(v))] @ np.linalg.inv(m))[:, :3]
    faces = mesh.faces[:, [0, 2, 1]] if np.linalg.det(m[:3, :3]) < 0 else mesh.faces
    bits = _grid_bits(local)
    return Mesh(_on_grid(local, bits), faces), bits


def _model_head(cura: bool, parts: bool) -> bytes:
    """The 3MF model's head up to ``<resources>``: Cura's namespace where ``cura``
    metadata follows, and ``slic3rpe:Version3mf`` where an object has several ``parts``."""
    return (
        b'<?xml version="1.0" encoding="UTF-8"?>\n'
        b'<model unit="millimeter" xml:lang="en-US" '
        b'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"'
        + (f' xmlns:cura="{CURA_NAMESPACE}"'.encode() if cura else b"")
        + b'>\n<metadata name="Application">texcad</metadata>\n'
        # PrusaSlicer bakes a build item's transform into the first part of an object from
        # a 3MF without this, and leaves the other parts where they are (_3MF_Importer::
        # _generate_volumes, 2.5 and later): with it the transform stays the instance's
        + (b'<metadata name="slic3rpe:Version3mf">1</metadata>\n' if parts else b"")
        + b"<resources>\n"
    )


def _write_package(path: str | os.PathLike, model: Iterable[bytes], bound: int, config: "bytes | None") -> None:
    """The 3MF zip at ``path`` (atomic): its content types and relationships, the
    model streamed from ``model`` (pieces of bytes, at most ``bound`` of them in all)
    and PrusaSlicer's config where there is one."""
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w") as z:
            for arcname, data in (("[Content_Types].xml", _CT), ("_rels/.rels", _RELS)):
                z.writestr(_zip_info(arcname), data, compresslevel=1)
            _write_streamed(z, _zip_info("3D/3dmodel.model"), model, bound)
            if config is not None:
                z.writestr(_zip_info(SLIC3R_CONFIG), config, compresslevel=1)


def _print_turn(meshes: Sequence[Mesh], build_dir) -> "np.ndarray | None":
    """The ``(4, 4)`` row-vector matrix that turns ``build_dir`` to +z and lifts the
    lowest point of all ``meshes`` (where they are) to z = 0; None without ``build_dir``."""
    if build_dir is None:
        return None
    from ..util import rotation_to_z

    R = rotation_to_z(np.asarray(build_dir, dtype=np.float64).reshape(-1, 3)[0])
    z0 = min((float((m.vertices.astype(np.float64) @ R[2]).min()) for m in meshes if len(m.vertices)), default=0.0)
    turn = np.eye(4)
    turn[:3, :3], turn[3, 2] = R.T, -z0
    return turn


#: The XML namespace of Cura's 3MF metadata (Cura's and libSavitar's ``cura`` prefix).
CURA_NAMESPACE = "http://software.ultimaker.com/xml/cura/3mf/2015/10"


def _cura_metadata(settings: Mapping[str, Any] | None) -> bytes:
    """An ``<object>``'s ``<metadatagroup>`` of ``cura:`` settings, sorted by key, the
    way Cura writes per-object settings (libSavitar reads each ``cura:key`` as the
    setting ``key``); empty bytes for none."""
    if not settings:
        return b""
    rows = "".join(
        f'<metadata name="cura:{_xml_escape(str(k))}" preserve="true" type="xs:string">{_xml_escape(_cura_value(v))}</metadata>'
        for k, v in sorted(settings.items())
    )
    return f"<metadatagroup>{rows}</metadatagroup>".encode()


def _cura_value(v: Any) -> str:
    """A setting's value as Cura writes it (booleans as ``True`` / ``False``)."""
    return str(bool(v)) if isinstance(v, (bool, np.bool_)) else str(v)


def _print_transform(mesh: Mesh, build_dir) -> str:
    """3MF item transform (``m00 .. m32``, row vectors: ``p' = p M``) that turns
    ``build_dir`` to +z and puts the lowest point on z = 0 (:func:`_print_turn`)."""
    return _matrix_text(_print_turn([mesh], build_dir))


def _transform(R: np.ndarray, z0: float) -> str:
    """The 3MF item transform of the rotation ``R`` (rows: the new axes) that lifts
    the rotated lowest point ``z0`` (mm) to z = 0."""
    return _matrix_text(np.vstack([np.c_[R.T, np.zeros(3)], [0.0, 0.0, -z0, 1.0]]))


def _matrix_text(M: np.ndarray) -> str:
    """A ``(4, 4)`` row-vector matrix as a 3MF ``transform`` (its first three columns)."""
    M = np.array(M[:, :3], dtype=np.float64)
    M[np.abs(M) < 1e-15] = 0.0
    return " ".join(_number(float(x)) for x in M.ravel())


def _number(x: float) -> str:
    """``x`` as ``%.9g`` where that reads back as ``x`` (float64), else its shortest
    exact form (``repr``): a lift on :func:`write_3mf`'s vertex grid stays exact."""
    short = f"{x:.9g}"
    return short if float(short) == x else repr(x)


def _merged(
    items: list[tuple[str, Mesh]], name: str, settings: Mapping[str, Any] | None = None, part_settings=None
) -> tuple[str, Mesh, bytes]:
    """Parts as one object: (escaped name, the parts' meshes one after the other
    (:func:`_joined`), ``Metadata/Slic3r_PE_model.config`` naming each part's triangle
    range, with the object's ``settings`` and each part's ``part_settings`` as their
    metadata)."""
    vols = _volumes([(n, len(m.faces)) for n, m in items], part_settings)
    return _xml_escape(name), _joined(items), _slic3r_config(name, settings, vols)


def _joined(parts: Sequence[tuple[str, Mesh]]) -> Mesh:
    """The ``(name, mesh)`` parts' meshes one after the other in one mesh (each part
    keeps its own vertices, so each stays a closed shell); the mesh itself for one part."""
    if len(parts) == 1:
        return parts[0][1]
    v_off = np.cumsum([0] + [len(m.vertices) for _, m in parts])
    return Mesh(
        np.concatenate([m.vertices for _, m in parts]),
        np.concatenate([m.faces.astype(np.int64) + int(o) for (_, m), o in zip(parts, v_off)]),
    )


def _volumes(parts: Sequence[tuple[str, int]], part_settings=None) -> str:
    """The ``<volume>`` elements of an object's ``(name, triangles)`` parts in
    ``Metadata/Slic3r_PE_model.config``: each part's triangle range in the object's
    mesh (the parts one after the other), its name and its ``part_settings``."""
    t_off = np.cumsum([0] + [t for _, t in parts])
    return "".join(
        f'  <volume firstid="{int(t_off[i])}" lastid="{int(t_off[i + 1]) - 1}">\n'
        f'   <metadata type="volume" key="name" value="{_xml_escape(n)}"/>\n'
        '   <metadata type="volume" key="volume_type" value="ModelPart"/>\n'
        f"{_metadata('volume', part_settings[i] if part_settings else None, '   ')}"
        "  </volume>\n"
        for i, (n, _) in enumerate(parts)
    )


def _slic3r_config(name: str, settings: Mapping[str, Any] | None, volumes: str) -> bytes:
    """``Metadata/Slic3r_PE_model.config`` of object 1: its name, its ``settings`` and
    its ``<volume>`` elements (the parts' triangle ranges)."""
    return _config([_config_object(1, name, settings, volumes)])


def _config(objects: Sequence[str]) -> bytes:
    """``Metadata/Slic3r_PE_model.config`` of the ``<object>`` elements ``objects``
    (:func:`_config_object`)."""
    return ('<?xml version="1.0" encoding="UTF-8"?>\n<config>\n' + "".join(objects) + "</config>\n").encode()


def _config_object(k: int, name: str, settings: Mapping[str, Any] | None, volumes: str) -> str:
    """Object ``k``'s ``<object>`` element in ``Metadata/Slic3r_PE_model.config``: its
    name, its ``settings`` and its ``<volume>`` elements (:func:`_volumes`)."""
    return (f' <object id="{k}" instances_count="1">\n  <metadata type="object" key="name" value="{_xml_escape(name)}"/>\n'
            f'{_metadata("object", settings, "  ")}{volumes} </object>\n')


def _one_volume(name: str, triangles: int) -> str:
    """The ``<volume>`` element of a one-part object of ``triangles`` triangles."""
    return _volumes([(name, triangles)])


def _metadata(kind: str, settings: Mapping[str, Any] | None, indent: str) -> str:
    """``<metadata type=kind key=... value=.../>`` lines of ``settings``, sorted by key."""
    return "".join(
        f'{indent}<metadata type="{kind}" key="{_xml_escape(str(k))}" value="{_xml_escape(_setting(v))}"/>\n'
        for k, v in sorted((settings or {}).items())
    )


def _setting(v: Any) -> str:
    """A setting's value as PrusaSlicer's config writes it (booleans as 0 / 1)."""
    return str(int(v)) if isinstance(v, (bool, np.bool_)) else str(v)


#: Steepest downward facet, degrees from the build plate, of a part on which
#: PrusaSlicer's "detect bridging perimeters" finds nothing (:func:`slicer_settings`).
BRIDGING_FREE_ANGLE = 45.0


#: PrusaSlicer's ``seam_position`` :func:`slicer_settings` writes for a textured part.
#: Its default, ``aligned`` (and ``nearest``), ranks seam candidates by how visible
#: they are: PrusaSlicer 2.5's SeamPlacer casts rays from 30,000 points sampled on the
#: mesh, whatever the part: about 0.9 CPU-s on the flat plate recipe's 20 mm plate
#: (13 k triangles), which otherwise slices in 0.4 s. ``rear`` and ``random`` skip
#: that pass; ``rear`` keeps the seams of smooth walls in one line at the back, as
#: ``aligned`` keeps them in one line, where ``random`` would scatter them over every
#: wall; on a texture a seam's blob (a few tenths of a mm) lies among the texture's
#: own relief. A seam moves where a loop starts, not where it runs: the paths stay
#: the same within 0.03 mm (docs/benchmarks/slicer_cost.md).
TEXTURE_SEAM = "rear"


def slicer_settings(mesh: Mesh, build_dir=None, *, textured: bool = True) -> dict[str, Any]:
    """The PrusaSlicer per-object settings :func:`export` writes into a 3MF of
    ``mesh`` printed along ``build_dir`` (None: +z as placed).

    ``seam_position`` = :data:`TEXTURE_SEAM` when ``textured`` (texcad's meshes;
    :func:`export` passes False for a CAD shape), so that PrusaSlicer does not rank
    seams by visibility over the whole texture.

    ``{"overhangs": 0}`` ("detect bridging perimeters" off) when no facet of the part
    faces down flatter than :data:`BRIDGING_FREE_ANGLE` (45) degrees from the build
    plate, other than those resting on it; otherwise ``{}``. PrusaSlicer 2.5 calls a
    perimeter bridging where it lies more than half a nozzle width outside the
    layer below (its perimeter generator grows the lower layer by ``nozzle / 2``);
    a perimeter's centre line lies at least half a bead inside its contour, so a
    contour that moves outwards by at most ``h / tan(45 deg) = h`` per layer of
    height ``h`` mm never makes one while ``h`` is under ``nozzle / 2`` plus half a
    bead (0.3 mm layers with a 0.4 mm nozzle and less). On such a part the setting
    only decides whether the slicer looks, and on a texture looking is most of the
    slicing time: it clips every perimeter of a layer with the whole layer below,
    islands times vertices (docs/guides/printing.md, "Slicing time"). Textures
    limited for their build direction (at least 45 degrees) and reliefs facing up
    qualify; a part with its own overhangs or bridges keeps the profile's setting.
    """
    seam = {"seam_position": TEXTURE_SEAM} if textured else {}
    if not len(mesh.faces):
        return seam
    d = np.array([0.0, 0.0, 1.0]) if build_dir is None else np.asarray(build_dir, dtype=np.float64).reshape(-1, 3)[0]
    d = d / np.linalg.norm(d)
    v = mesh.vertices.astype(np.float64)
    tri = v[mesh.faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    down = -(n @ d) > np.cos(np.radians(BRIDGING_FREE_ANGLE)) * length
    level = v @ d
    on_bed = (level[mesh.faces] <= level.min() + 0.01).all(axis=1)  # within 0.01 mm of the lowest point
    return seam if np.any(down & ~on_bed & (length > 0)) else {"overhangs": 0, **seam}


#: Cura's per-object settings :func:`cura_settings` writes for a textured part: "skin
#: edge support" off (Cura's default is 0.8 mm, 4 layers of 0.2 mm). It draws an infill
#: wall under every edge of top skin on the layers below it; on a texture the top skin
#: is terraced into as many edges as the texture has contours, and CuraEngine 4.13
#: (``FffGcodeWriter::partitionInfillBySkinAbove``) combines the skin parts of those
#: layers one by one, each clipped against all the parts combined so far: parts squared
#: per layer, most of the slicing time on a textured top (docs/benchmarks/slicer.md).
#: The walls it draws lie inside the part, under the skin; what prints outside (walls,
#: skin, the texture) stays where it was. The layers are written too, as CuraEngine
#: reads them (it computes no setting from another).
CURA_TEXTURE_SETTINGS = {"skin_edge_support_thickness": 0, "skin_edge_support_layers": 0}

#: Cura's per-object setting :func:`cura_settings` adds for a part that every line
#: along its build direction crosses at most once (:func:`single_run`): "no skin in
#: z gaps" on. CuraEngine 4.13 finds a layer's top skin by intersecting the layers
#: above it, up to ``top_layers`` (and its bottom skin from the layers below); with
#: the setting on it takes only the farthest of them. Each part of a layer is clipped
#: against every part of those layers whose bounding box it meets, so one part that
#: spans the plate (the texture's lower, connected levels) is clipped again for each
#: of the hundreds of islands above or below it (``SkinInfillAreaComputation::
#: calculateTopSkin`` / ``calculateBottomSkin``): islands times the whole layer, most
#: of the slicing time of a textured top (docs/benchmarks/slicer.md). Where every
#: vertical line meets the part in one run, whatever lies solid in the farthest layer
#: lies solid in every layer between, so the intersection is that layer and the skin
#: the same: the G-code is the same (tested). A part with a gap along the build
#: direction gets it too where the gap cannot change the skin (:func:`skin_gap_area`:
#: gaps within the walls' depth, such as between the bumps of a knurled side, or
#: taller than the top thickness); a thin slot, a ledge just over air does not.
CURA_SINGLE_RUN_SETTINGS = {"skin_no_small_gaps_heuristic": True}
#: mm: spacing of the lines along the build direction :func:`single_run` tests, a
#: 0.4 mm nozzle's width: Cura drops skin narrower than its "skin removal width"
#: (0.8 mm by default), so a gap narrower than this changes no skin.
SINGLE_RUN_STEP = 0.4


def single_run(mesh: Mesh, build_dir=None, *, step: float = SINGLE_RUN_STEP) -> bool:
    """Whether every line along ``build_dir`` (None: +z) crosses the watertight
    ``mesh`` (mm) in at most one run of solid: no gap in the part along the build
    direction, as on a plate textured on its top face printed texture up.

    Tested on lines ``step`` mm apart across the build plate (shifted off the grid by
    a fraction of ``step`` so that no line runs along an edge): a line crosses one run
    per upward-facing surface it passes, so the part has one run on every line where
    no two upward-facing triangles lie over each other. Triangles are taken in
    chunks (each lists the lines inside its bounding box), so memory stays bounded
    on large meshes. A gap narrower than ``step`` can be missed."""
    from ..util import rotation_to_z

    if not len(mesh.faces):
        return True
    R = rotation_to_z(np.array([0.0, 0.0, 1.0]) if build_dir is None else np.asarray(build_dir, dtype=np.float64).reshape(-1, 3)[0])
    tri = (mesh.vertices.astype(np.float64) @ R.T)[mesh.faces][:, :, :2]  # (F, 3, 2) on the plate
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area2 = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]  # twice the signed shadow area: > 0 faces up
    up = area2 > 1e-9 * np.maximum(1.0, np.abs(area2).max())
    tri, area2 = tri[up], area2[up]
    origin = tri.reshape(-1, 2).min(axis=0) - step * np.array([0.3183, 0.2718])  # off the grid of the mesh
    lo = np.floor((tri.min(axis=1) - origin) / step).astype(np.int64)
    hi = np.floor((tri.max(axis=1) - origin) / step).astype(np.int64)
    width = int(hi[:, 0].max()) + 2
    hits = np.zeros(0, dtype=np.int64)
    for chunk in np.array_split(np.arange(len(tri)), max(1, len(tri) // 100_000)):
        ids = _covered_lines(tri[chunk], area2[chunk], lo[chunk], hi[chunk], origin, step, width)
        hits = np.concatenate([hits, ids])
        if len(hits) != len(np.unique(hits)):
            return False
    return True


def _covered_lines(tri, area2, lo, hi, origin, step, width) -> np.ndarray:
    """Ids (``row * width + col``) of the grid lines inside each of the upward-facing
    triangles ``tri`` ``(T, 3, 2)`` (twice their areas ``area2``), one entry per
    triangle and line inside it."""
    nx, ny = hi[:, 0] - lo[:, 0] + 1, hi[:, 1] - lo[:, 1] + 1
    n = nx * ny
    owner = np.repeat(np.arange(len(tri)), n)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(n) - n, n)
    col, row = lo[owner, 0] + k % nx[owner], lo[owner, 1] + k // nx[owner]
    p = origin + step * np.stack([col, row], axis=1)
    t = tri[owner]
    inside = np.ones(len(owner), dtype=bool)
    for i in range(3):  # the point on the left of all three edges (counter-clockwise; a line on an edge counts for neither side)
        a, b = t[:, i], t[:, (i + 1) % 3]
        inside &= (b[:, 0] - a[:, 0]) * (p[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (p[:, 0] - a[:, 0]) > 0
    return row[inside] * width + col[inside]


#: mm: how far inside a layer's outline CuraEngine 4.13's skin begins with Cura's
#: defaults for a 0.4 mm nozzle: two walls of 0.4 mm
#: (``SkinInfillAreaComputation::generateSkinAndInfillAreas``, the innermost wall's
#: inner edge); more walls or a wider nozzle put it deeper.
SKIN_INSET = 0.8
#: mm: how far it grows the other layers' outlines before it compares them with that
#: skin (its "skin removal width", by default the walls' width, less the walls'
#: insets: half the outer wall).
SKIN_REACH = 0.2
#: mm: the top and bottom skin thickness :func:`skin_gap_area` allows for: Cura's
#: default is 0.8 mm, texcad's CuraEngine definition 6 layers of 0.2 mm. A gap
#: along the build direction taller than this is seen the same way with or without
#: "no skin in z gaps" (both see air on the farthest layer).
SKIN_WINDOW = 1.2
#: mm between the cross-sections :func:`skin_gap_area` compares (finer than the usual layers).
SKIN_STEP = 0.1
#: mm^2: area below which :func:`cura_settings` takes a layer's skin to be the same
#: (what the slicers' own rounding of the outlines, 0.025 mm, moves).
SKIN_GAP_AREA = 0.01


def skin_gap_area(mesh: Mesh, build_dir=None, *, inset: float = SKIN_INSET, reach: float = SKIN_REACH,
                  window: float = SKIN_WINDOW, step: float = SKIN_STEP, limit: float | None = None) -> float:
    """The largest area (mm^2) of one cross-section of ``mesh`` (mm) printed along
    ``build_dir`` (None: +z) where CuraEngine 4.13's skin could differ with "no skin
    in z gaps": 0 where it is the same on every layer.

    For a layer's top skin CuraEngine takes the part at least ``inset`` mm inside
    the layer's outline and removes what lies within ``reach`` mm of every layer
    above it up to the top thickness; with the setting, only of the farthest of
    them. The two differ at a point only where the part is deep there on a layer
    below, more than ``reach`` from it on a layer, and within ``reach`` on a layer
    above, all within ``window`` mm (and the same downwards for bottom skin): a gap
    along the build direction that reaches deeper than the walls and is thinner than
    the top thickness. Gaps in the walls' depth (between the bumps of a knurl on a
    side) or taller than the window change nothing. Cross-sections every ``step``
    mm, from the bottom up in runs of :data:`_SKIN_RUN` windows; the unions over
    the window are made in blocks of its length, two per cross-section (van Herk /
    Gil-Werman). ``limit`` (mm^2): stop at the first run where an area passes it
    (the figure returned is then above ``limit``, not necessarily the largest). A
    mesh that is not one closed solid: infinity."""
    try:
        man = _upright(mesh, build_dir)[0]
    except GeometryError:
        return float("inf")
    lo, hi = man.bounding_box()[2], man.bounding_box()[5]
    heights = lo + np.arange(step / 2, hi - lo, step)
    w = max(1, int(round(window / step)))
    offsets = _SkinOffsets(man, heights, inset, reach)
    worst, run = 0.0, _SKIN_RUN * w
    for s in range(0, len(heights), run):  # per run of cross-sections, from the bottom up
        worst = max(worst, _skin_gaps(offsets, s, min(len(heights), s + run), w))
        if limit is not None and worst > limit:
            break
    return worst


#: Windows of cross-sections :func:`skin_gap_area` takes at a time before it may stop.
_SKIN_RUN = 8


class _SkinOffsets:
    """The cross-sections of an upright manifold at ``heights`` (mm), each grown
    inwards by ``inset`` and outwards by ``reach`` mm, made once on first use."""

    def __init__(self, man, heights: np.ndarray, inset: float, reach: float) -> None:
        self.man, self.heights, self.inset, self.reach = man, heights, inset, reach
        self.made: dict = {}

    def __call__(self, k: int) -> tuple:
        """``(section k, deep: inset inwards, near: reach outwards)``."""
        import manifold3d as m3d

        if k not in self.made:
            s = self.man.slice(float(self.heights[k]))
            self.made[k] = (s, s.offset(-self.inset, m3d.JoinType.Miter), s.offset(self.reach, m3d.JoinType.Miter))
        return self.made[k]


def _skin_gaps(offsets: _SkinOffsets, a: int, b: int, w: int) -> float:
    """The largest skin-gap area (:func:`skin_gap_area`) of cross-sections ``a:b``,
    their windows of ``w`` on either side taken from ``offsets``; the sections no
    later run needs are dropped."""
    lo, hi = max(0, a - w), min(len(offsets.heights), b + w)
    got = [offsets(k) for k in range(lo, hi)]
    deep_below, deep_above = _window_unions([g[1] for g in got], w)
    near_below, near_above = _window_unions([g[2] for g in got], w)
    worst = 0.0
    for j in range(a - lo, b - lo):  # per cross-section of the run
        near = got[j][2]
        top = ((deep_below[j] - near) ^ near_above[j]).area()
        bottom = ((deep_above[j] - near) ^ near_below[j]).area()
        worst = max(worst, top, bottom)
    for k in range(lo, b - w):  # below the next run's window
        offsets.made.pop(k, None)
    return worst


def _window_unions(sections: list, w: int) -> tuple[list, list]:
    """``(below, above)``: for each ``j`` the union of ``sections[j-w:j]`` and of
    ``sections[j+1:j+1+w]`` (manifold3d CrossSections), from prefix and suffix
    unions within blocks of ``w``."""
    import manifold3d as m3d

    n, empty = len(sections), m3d.CrossSection()
    pre, suf = [empty] * n, [empty] * n
    for s in range(0, n, w):  # per block
        acc = empty
        for t in range(s, min(n, s + w)):
            acc = pre[t] = acc + sections[t]
        acc = empty
        for t in range(min(n, s + w) - 1, s - 1, -1):
            acc = suf[t] = acc + sections[t]

    def union(a: int, b: int):  # sections[a:b], b - a <= w
        if b <= a:
            return empty
        if a // w != (b - 1) // w:
            return suf[a] + pre[b - 1]
        if a % w == 0:
            return pre[b - 1]
        return suf[a] if b == n or b % w == 0 else m3d.CrossSection.batch_boolean(sections[a:b], m3d.OpType.Add)

    return [union(max(0, j - w), j) for j in range(n)], [union(j + 1, min(n, j + 1 + w)) for j in range(n)]


def cura_settings(mesh: Mesh | None = None, build_dir=None, *, textured: bool = True) -> dict[str, Any]:
    """The Cura per-object settings :func:`export` writes into a 3MF (Cura's 3MF
    reader applies them to the object): :data:`CURA_TEXTURE_SETTINGS` for a textured
    part (texcad's meshes), and :data:`CURA_SINGLE_RUN_SETTINGS` when ``mesh``
    printed along ``build_dir`` (None: +z) has one run of solid on every line along
    it (:func:`single_run`) or, with Cura's defaults for a 0.4 mm nozzle, no gap
    along it that its skin can see (:func:`skin_gap_area` at most
    :data:`SKIN_GAP_AREA`); none for a CAD shape (``textured=False``). Without a
    mesh, the texture settings alone. CuraEngine's command line, which reads no 3MF,
    takes the same settings as ``-s key=value`` after the mesh's ``-l``
    (:func:`texcad.report.slicer.slice_mesh`)."""
    if not textured:
        return {}
    out = dict(CURA_TEXTURE_SETTINGS)
    if mesh is not None and (single_run(mesh, build_dir) or skin_gap_area(mesh, build_dir, limit=SKIN_GAP_AREA) <= SKIN_GAP_AREA):
        out.update(CURA_SINGLE_RUN_SETTINGS)
    return out


#: Largest share of a cross-section's contour length that one island may hold where
#: texcad turns PrusaSlicer's "extra perimeters" off (:func:`extra_perimeter_cut`): a
#: third of the 30 % at which PrusaSlicer 2.5 adds one.
EXTRA_PERIMETER_SHARE = 0.1
#: Islands times contour vertices, summed over the cross-sections above the cut (every
#: 0.1 mm), below which texcad does not cut (:func:`extra_perimeter_cut`). The pass
#: costs PrusaSlicer about 0.1 us of CPU per pair (the demo plate: 1.7e8, 16.8 CPU-s
#: saved), the cut itself about a second (a second print region and the cut's
#: triangles; a 40 mm stones plate, 8e6: 4.8 CPU-s cut against 3.9 uncut), so it is
#: made where the pass would take more than about 5 s.
CUT_MIN_WORK = 5e7
_CUT_STEP = 0.1  # mm between the cross-sections extra_perimeter_cut examines
_CUT_GRID = 0.025  # mm: slicers' planes lie on multiples of this for 0.05-0.35 mm layers


@dataclass(frozen=True)
class SlicerLayout:
    """How :func:`export` writes a mesh into a 3MF for slicers.

    Attributes:
        parts: ``((name, Mesh), ...)``: one part (the mesh), or the mesh cut in two
            at ``cut`` (below, above), the two closed parts of one object that
            together are the mesh (mm, the part's own frame).
        settings: PrusaSlicer per-object settings (:func:`slicer_settings`).
        part_settings: one ``{option: value}`` per part (empty for one part).
        cut: height of the cut above the part's lowest point along the build
            direction, mm, or None.
    """

    parts: tuple
    settings: dict
    part_settings: tuple = ()
    cut: float | None = None


def extra_perimeter_cut(mesh: Mesh, build_dir=None, *, min_work: float = CUT_MIN_WORK) -> float | None:
    """Height (mm above the lowest point along ``build_dir``; None: +z) above which
    PrusaSlicer 2.5's "extra perimeters" pass can add nothing to ``mesh``, or None.

    That pass (``PrintObject::make_perimeters``) takes every island of a layer in
    turn and clips the whole layer above with a ring inside the island's perimeters;
    it adds a perimeter only where the clipped length passes 30 % of the layer
    above's whole contour length. On a texture with hundreds of islands per layer
    this costs islands times contour vertices, most of the slicing time of the demo
    plate, and adds nothing: no island holds that much. The cut is the lowest height
    from which every cross-section (every ``0.1`` mm) is empty or has no island
    holding more than :data:`EXTRA_PERIMETER_SHARE` of its contour length, put
    halfway between two multiples of 0.025 mm, where no usual slicing plane lies.
    (The last layer under the cut is compared by PrusaSlicer with nothing, since the
    layer above it belongs to the other part; starting the cut lower is what keeps
    the costly layer pairs where the islands begin out of the pass. The cut parts
    load with the whole mesh's coordinates (:func:`write_3mf`'s grid), but the
    triangles the cut splits end on the cut plane at float32-rounded points, a few
    nanometres off the whole triangles: PrusaSlicer's paths on the layers next to
    the cut can move by about a line width where a texture's web breaks into
    islands, as they do when the uncut mesh is nudged by a micrometre,
    docs/benchmarks/slicer_cost.md.) None when no such height
    leaves a cross-section with islands above it, or when the pass above it would
    cost less than the cut: islands times contour vertices summed over the
    cross-sections above it under ``min_work`` (:data:`CUT_MIN_WORK`).
    """
    return _cut_height(_upright(mesh, build_dir)[0], min_work)


def _upright(mesh: Mesh, build_dir):
    """``(manifold of mesh turned so build_dir is +z, unit build direction)``; the
    mesh is not turned when it prints along +z already."""
    from ..solid import to_manifold
    from ..util import rotation_to_z

    d = np.array([0.0, 0.0, 1.0]) if build_dir is None else np.asarray(build_dir, dtype=np.float64).reshape(-1, 3)[0]
    d = d / np.linalg.norm(d)
    if np.allclose(d, (0.0, 0.0, 1.0), atol=1e-12):
        return to_manifold(mesh), d
    R = rotation_to_z(d)
    return to_manifold(Mesh((mesh.vertices.astype(np.float64) @ R.T).astype(np.float32), mesh.faces)), d


def _cut_height(man, min_work: float = 0.0) -> float | None:
    """:func:`extra_perimeter_cut` of a manifold printed along +z."""
    lo, hi = man.bounding_box()[2], man.bounding_box()[5]
    heights = lo + np.arange(_CUT_STEP / 2, hi - lo, _CUT_STEP)
    last, work = -1, []  # the highest cross-section where one island holds too much, from the top down
    for k in range(len(heights) - 1, -1, -1):  # per cross-section
        share, pairs = _largest_share(man.slice(float(heights[k])))
        if share > EXTRA_PERIMETER_SHARE:
            last = k
            break
        work.append((heights[k], pairs))
    if last < 0 or last == len(heights) - 1:
        return None
    cut = heights[last] + _CUT_STEP / 2 - lo  # clear of it
    # between the slicing planes of the usual layer heights (multiples of 0.025 mm): a
    # plane on the cut would slice both parts' caps
    cut = np.ceil(cut / _CUT_GRID) * _CUT_GRID + _CUT_GRID / 2
    if cut >= hi - lo - _CUT_STEP or sum(w for z, w in work if z >= lo + cut) < min_work:
        return None
    return float(round(cut, 4))


def _largest_share(section) -> tuple[float, int]:
    """(the largest share of a cross-section's contour length one island holds (0 if
    empty), islands times contour vertices: the extra-perimeter pass's work there)."""
    lengths, vertices = [], 0
    for island in section.decompose():  # per island
        loops = island.to_polygons()
        vertices += sum(len(q) for q in loops)
        lengths.append(sum(float(np.linalg.norm(np.diff(np.vstack([q, q[:1]]), axis=0), axis=1).sum()) for q in loops))
    total = sum(lengths)
    return (max(lengths) / total if total > 0 else 0.0), len(lengths) * vertices


def slicer_layout(
    mesh: Mesh, build_dir=None, name: str = "part", *, min_work: float = CUT_MIN_WORK, textured: bool = True
) -> SlicerLayout:
    """How :func:`export` writes ``mesh`` (printed along ``build_dir``) for slicers:
    the per-object settings of :func:`slicer_settings`, and, when they hold
    ``overhangs = 0`` and :func:`extra_perimeter_cut` finds a height, the mesh cut
    there into two parts, the upper one with ``extra_perimeters = 0`` (``min_work``:
    as there). PrusaSlicer
    then skips the extra-perimeter pass in the crowded layers and runs it as before
    below them; the parts are one object, so every slicer prints the same solid.
    ``textured``: as in :func:`slicer_settings`."""
    settings = slicer_settings(mesh, build_dir, textured=textured)
    if settings.get("overhangs") != 0:
        return SlicerLayout(((name, mesh),), settings)
    from ..solid import from_manifold, to_manifold

    try:
        man, d = _upright(mesh, build_dir)
    except GeometryError:  # not one closed manifold3d solid (e.g. bodies that touch): written whole
        return SlicerLayout(((name, mesh),), settings)
    cut = _cut_height(man, min_work)
    if cut is None:
        return SlicerLayout(((name, mesh),), settings)
    if d[2] < 1.0:  # turned for the cross-sections: cut the part in its own frame
        man = to_manifold(mesh)
    low = float((mesh.vertices.astype(np.float64) @ d).min())
    above, below = man.split_by_plane(tuple(d), low + cut)
    if above.is_empty() or below.is_empty():
        return SlicerLayout(((name, mesh),), settings)
    parts = ((name, from_manifold(below)), (f"{name} above {cut:g} mm", from_manifold(above)))
    if not _cut_holds(mesh, parts[0][1], parts[1][1]):  # an optimisation only: never a different solid
        return SlicerLayout(((name, mesh),), settings)
    return SlicerLayout(parts, settings, ({}, {"extra_perimeters": 0}), cut)


def _cut_holds(mesh: Mesh, below: Mesh, above: Mesh) -> bool:
    """The two parts of a cut are closed and hold the mesh's volume together (within
    a millionth): the solid every slicer
    prints from them is the mesh's."""
    if not (below.is_watertight and above.is_watertight):
        return False
    whole = float(mesh.volume)
    return abs(float(below.volume) + float(above.volume) - whole) <= 1e-6 * abs(whole)


def _zip_info(arcname: str) -> zipfile.ZipInfo:
    """A deflated entry with a fixed timestamp (identical bytes for identical inputs)."""
    info = zipfile.ZipInfo(arcname, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_DEFLATED
    return info


def _write_streamed(z: zipfile.ZipFile, info: zipfile.ZipInfo, pieces: Iterable[bytes], bound: int) -> None:
    """Write an entry made of ``pieces`` (formatted lazily), deflated at level 1: the
    same bytes as ``z.writestr(info, b"".join(pieces), compresslevel=1)`` (zlib's
    stream does not depend on how its input is split; the local header is rewritten
    with the CRC and sizes at the end either way), but each piece is checksummed and
    compressed on a second thread (zlib releases the GIL) while the next is formatted.
    ``bound`` (bytes, at least the entry's size) decides ZIP64 as ``writestr`` would
    with the true size; an entry that might need ZIP64 goes through ``writestr``."""
    if bound * 1.05 > zipfile.ZIP64_LIMIT:
        z.writestr(info, b"".join(pieces), compresslevel=1)
        return
    info._compresslevel = 1  # what writestr(..., compresslevel=1) sets
    if threads() < 2:  # TEXCAD_THREADS=1: formatted and deflated in turn on this thread
        with z.open(info, "w") as dest:
            for piece in pieces:  # per chunk of rows
                dest.write(piece)
        return
    pending: collections.deque = collections.deque()
    with z.open(info, "w") as dest, ThreadPoolExecutor(1) as pool:
        for piece in pieces:  # per chunk of rows
            pending.append(pool.submit(dest.write, piece))
            while len(pending) > _QUEUE:  # hold a few formatted pieces, not the file
                pending.popleft().result()
        for job in pending:
            job.result()


_QUEUE = 4  # pieces formatted ahead of the compressor


#: The part list of a multi-part object (PrusaSlicer's 3MF metadata).
SLIC3R_CONFIG = "Metadata/Slic3r_PE_model.config"


def _xml_escape(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def export(obj: Any, path: str | os.PathLike, *, separate_texture: bool = False, name: str | None = None) -> Path:
    """Write ``obj`` in the format named by the file's extension, atomically.

    Args:
        obj: a :class:`texcad.Textured` (``.stl``/``.3mf`` from its mesh,
            ``.step``/``.stp`` from its B-rep), a :class:`~texcad.solid.Mesh`, a list
            of ``(name, Mesh)`` objects (3MF), or a build123d / CadQuery / OCP shape
            (STEP as it is; STL/3MF from its tessellation).
        path: ``.stl`` (binary, mm), ``.3mf`` (``unit="millimeter"``) or ``.step``.
        separate_texture: 3MF of a textured result: the base and the texture as two
            parts of one object, so that a slicer can give the texture another filament.
        name: object / product name (default: the file name).

    Raises:
        ParameterError: unknown extension, or a format the object cannot give.
        GeometryError: the mesh is not watertight (nothing is written).
    """
    p = Path(path)
    suffix = p.suffix.lower()
    label = name or p.stem
    if suffix not in (".stl", ".3mf", ".step", ".stp"):
        raise ParameterError(f"unknown output format {p.suffix!r} for {str(p)!r}; use .stl, .3mf or .step")
    textured = hasattr(type(obj), "texture_mesh") and hasattr(type(obj), "base_mesh")  # texcad.Textured
    if suffix in (".step", ".stp"):
        from .step import write_step

        # a textured part's B-rep at its mesh's tolerance (mm), as its STL (issue 28)
        write_step(obj.shape if textured else obj, p, name=label, tolerance=obj.info.get("tolerance") or 0.0 if textured else 0.0)
        return p
    cad = not textured and not isinstance(obj, (Mesh, list, tuple))  # a CAD shape: no texture
    if textured:
        meshes: Any = [("base", obj.base_mesh), ("texture", obj.texture_mesh)] if separate_texture else obj.mesh
    elif isinstance(obj, Mesh) or isinstance(obj, (list, tuple)):
        meshes = obj
    else:  # a CAD shape: healed where OCCT meshes it open, as texcad textures and checks parts
        from ..brep import closed_shape_mesh

        meshes = closed_shape_mesh(obj)
    if suffix == ".stl":
        if not isinstance(meshes, Mesh):
            raise ParameterError("an STL holds one mesh; write several objects as .3mf")
        write_stl(meshes, p)
    else:
        up = _build_dir_of(obj) if textured else None
        whole = obj.mesh if textured else (meshes if isinstance(meshes, Mesh) else None)
        if isinstance(meshes, Mesh):  # one part: cut for the slicers where that pays (slicer_layout)
            lay = slicer_layout(meshes, up, label, textured=not cad)
            parts = meshes if len(lay.parts) == 1 else list(lay.parts)
            write_3mf(parts, p, name=label, build_dir=up, settings=lay.settings, part_settings=lay.part_settings or None,
                      cura_settings=cura_settings(meshes, up, textured=not cad))
        else:
            settings = slicer_settings(whole, up, textured=not cad) if whole is not None else None
            write_3mf(meshes, p, name=label, build_dir=up, settings=settings,
                      cura_settings=cura_settings(whole, up, textured=not cad))
    return p


def _build_dir_of(obj: Any):
    """The build direction a textured result was made for (``info["build_dir"]`` or
    its limiter's report's ``directions``; the first of a set), or None."""
    d = (getattr(obj, "info", None) or {}).get("build_dir")
    if d is None:
        d = getattr(getattr(obj, "limits", None), "directions", None)
    if d is None or np.size(d) < 3:
        return None
    d = np.asarray(d, dtype=np.float64)
    return d if d.ndim == 1 else d[0]
