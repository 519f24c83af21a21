"""Mesh files in: STL (binary and ASCII) and 3MF (components, transforms and the
model's ``unit`` applied), vectorized, as named :class:`~texcad.solid.Mesh` objects in mm.

A 3MF's model is inflated on a second thread while the main thread parses its
``<vertex>`` and ``<triangle>`` elements as their bytes arrive, with numpy: the
numbers are the same doubles as ``float()`` gives for their text.
"""

from __future__ import annotations

import mmap
import bisect
import functools
import os
import re
import threading
import zipfile
import zlib
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import InputError, TexcadError
from ..util import threads
from ..solid import Mesh

__all__ = ["read_part", "read_mesh", "load_mesh", "unreadable", "UNITS_MM", "build_items"]

#: mm per unit of the 3MF ``unit`` attribute (3MF core specification, 2.1).
UNITS_MM = {"micron": 0.001, "millimeter": 1.0, "centimeter": 10.0, "inch": 25.4, "foot": 304.8, "meter": 1000.0}


def _weld(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge bit-identical vertices of a triangle soup ``(M, 3, 3)`` float32.

    Vertices are compared by their float32 bit patterns (``-0.0`` made ``+0.0``),
    sorted with one ``lexsort``: no tolerance, as STL writers repeat vertices
    exactly.
    """
    pts = np.ascontiguousarray(tri.reshape(-1, 3).astype(np.float32) + np.float32(0.0))
    bits = pts.view(np.uint32)
    k1 = (bits[:, 0].astype(np.uint64) << np.uint64(32)) | bits[:, 1].astype(np.uint64)
    k2 = bits[:, 2]
    order = np.lexsort((k2, k1))
    s1, s2 = k1[order], k2[order]
    new = np.ones(len(order), dtype=bool)
    new[1:] = (s1[1:] != s1[:-1]) | (s2[1:] != s2[:-1])
    uid = np.cumsum(new) - 1
    inv = np.empty(len(order), dtype=np.int64)
    inv[order] = uid
    verts = pts[order[new]]
    return verts, inv.reshape(-1, 3)


def _line_of(text: "str | bytes", pos: int) -> int:
    """1-based line number of character ``pos`` of ``text``."""
    return text.count("\n" if isinstance(text, str) else b"\n", 0, pos) + 1


def _read_stl(path: Path) -> Mesh:
    """A binary or ASCII STL, strictly: a binary file's size must match its triangle
    count, every number must be finite, an ASCII file must hold whole facets of
    three ``vertex X Y Z`` lines of numbers (InputError naming the line otherwise)."""
    data = path.read_bytes()
    if len(data) >= 84:
        n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if len(data) == 84 + 50 * n:
            rec = np.frombuffer(
                data, dtype=np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")]), count=n, offset=84
            )
            tri = rec["v"]
            bad = np.flatnonzero(~np.isfinite(tri).all(axis=(1, 2)))
            if len(bad):
                raise InputError(f"{str(path)!r}: triangle {int(bad[0])} (of {n}) has a coordinate that is not a finite "
                                 f"number ({len(bad)} such triangles); the file is damaged, export it again")
            verts, faces = _weld(tri)
            return Mesh(verts, faces)
    head = data[:1024].lstrip().lower()
    if not head.startswith(b"solid") or b"\x00" in data[:4096]:
        if len(data) >= 84:
            raise InputError(f"{str(path)!r}: a binary STL of {n} triangles has {84 + 50 * n} bytes, this file {len(data)}: "
                             "it is truncated or damaged; export it again")
        raise InputError(f"{str(path)!r} is neither a binary nor an ASCII STL (only {len(data)} bytes); export it again")
    return _read_ascii_stl(path, data.decode("ascii", errors="replace"))


_VERTEX = re.compile(r"\bvertex\b([^\n\r]*)", re.IGNORECASE)  # lines end in LF, CRLF or CR alone (classic Mac)


def _read_ascii_stl(path: Path, text: str) -> Mesh:
    """An ASCII STL's ``vertex`` lines as a Mesh (see :func:`_read_stl`)."""
    rows = _VERTEX.findall(text)
    facets = len(re.findall(r"\bfacet\b", text, re.IGNORECASE))
    where = lambda k: _line_of(text, [m.start() for m in _VERTEX.finditer(text)][k])  # noqa: E731 (error path only)
    parts = [r.split() for r in rows]
    if not rows:
        raise InputError(f"{str(path)!r}: an ASCII STL without a single 'vertex' line; export it again")
    bad = next((k for k, p in enumerate(parts) if len(p) != 3), None)
    if bad is not None:
        raise InputError(f"{str(path)!r}, line {where(bad)}: a vertex needs three numbers, got {rows[bad].strip()[:60]!r}; "
                         "the file is damaged, export it again")
    try:
        vals = np.array(parts, dtype=np.float64)
    except ValueError:
        bad = next(k for k, p in enumerate(parts) if not all(map(_is_number, p)))
        raise InputError(f"{str(path)!r}, line {where(bad)}: {rows[bad].strip()[:60]!r} is not three numbers; "
                         "the file is damaged, export it again") from None
    fin = np.isfinite(vals).all(axis=1)
    if not fin.all():
        bad = int(np.flatnonzero(~fin)[0])
        raise InputError(f"{str(path)!r}, line {where(bad)}: vertex {rows[bad].strip()[:60]!r} is not finite; "
                         "the file is damaged, export it again")
    if len(rows) % 3 or (facets and len(rows) != 3 * facets):  # one 'facet normal' per three vertices
        raise InputError(f"{str(path)!r}: an ASCII STL of {len(rows)} vertex lines and {facets} facets: not three "
                         "vertices per facet, the file is truncated or damaged; export it again")
    if not re.search(r"\bendsolid\b[^\n]*\s*$", text[-4096:], re.IGNORECASE):
        raise InputError(f"{str(path)!r}: an ASCII STL that does not end with 'endsolid' (line {_line_of(text, len(text))} "
                         "is its last): the file is truncated; export it again")
    if np.abs(vals).max() > 3e38:
        raise InputError(f"{str(path)!r}: a coordinate beyond float32 ({np.abs(vals).max():g}); export it again")
    tri = vals.astype(np.float32).reshape(-1, 3, 3)
    verts, faces = _weld(tri)
    return Mesh(verts, faces)


_ATTR = re.compile(rb'([A-Za-z_:][-\w:.]*)\s*=\s*"([^"]*)"')


def _attrs(blob: bytes) -> dict[str, str]:
    return {k.decode(): v.decode("utf-8", "replace") for k, v in _ATTR.findall(blob)}


def _xml_unescape(s: str) -> str:
    return s.replace("&quot;", '"').replace("&lt;", "<").replace("&gt;", ">").replace("&apos;", "'").replace("&amp;", "&")


_CHUNK = 1 << 16  # values per chunk of the decimal parser (its arrays stay in cache)
_TEN = 10.0 ** np.arange(23)  # exact powers of ten as doubles, 10^0 .. 10^22


def _parse_decimals(a: np.ndarray, start: np.ndarray, stop: np.ndarray, *, integer: bool = False) -> np.ndarray:
    """The byte ranges ``a[start:stop]`` as numbers, each the same double as
    ``float(text)`` (int64 with ``integer=True`` when all are plain integers).

    Plain decimals (``-12.345``, ``7``, ``+.5``; at most 15 characters) are parsed with
    numpy, in chunks: the values right-aligned in a ``(width, n)`` byte matrix, the
    digits weighted by their powers of ten in one matrix product (integers below
    ``10^15 < 2^53``: exact), then one correctly rounded division by
    ``10**decimals``. Any other form (exponents, longer values, spaces, ``inf``) goes
    through numpy's string-to-float conversion.

    Raises:
        InputError: a value that is not a number.
    """
    out = np.empty(len(start), dtype=np.int64 if integer else np.float64)
    for k in range(0, len(start), _CHUNK):  # per chunk of values
        vals = _decimal_chunk(a, start[k : k + _CHUNK], stop[k : k + _CHUNK], integer)
        if integer and vals.dtype != np.int64:
            return _parse_decimals(a, start, stop)
        out[k : k + _CHUNK] = vals
    return out


def _decimal_chunk(a: np.ndarray, start: np.ndarray, stop: np.ndarray, integer: bool) -> np.ndarray:
    """:func:`_parse_decimals` of one chunk: int64 if ``integer`` and every value is a
    plain integer, else float64."""
    length = stop - start
    if len(length) == 0:
        return np.zeros(0, dtype=np.int64 if integer else np.float64)
    width = int(min(length.max(), 15))
    rows = np.arange(width)[:, None]
    t = np.take(a, (stop - width)[None, :] + rows, mode="clip")  # (width, n), right-aligned
    used = rows >= width - length  # the value's own bytes
    dig = (t - np.uint8(48) < 10) & used
    lead = a[start]
    neg = lead == 45  # '-'
    if integer:  # indices: digits only (a sign allowed), read as one integer each
        count = (dig + np.uint16(32) * (used & ~dig)).sum(axis=0, dtype=np.uint16)
        if np.all((count >> 5 == (neg | (lead == 43))) & (count & 31 >= 1) & (length <= width)):
            mant = np.einsum("i,ij->j", _TEN[width - 1 :: -1], (t - np.uint8(48)) * dig).astype(np.int64)
            return np.where(neg, -mant, mant)
    dot = (t == 46) & used
    # One sum counts digits (bits 0-4), dots (bits 5-9) and other characters (10-14).
    count = (dig + np.uint16(32) * dot + np.uint16(1024) * (used & ~dig & ~dot)).sum(axis=0, dtype=np.uint16)
    ndig = count & 31
    plain = (length <= width) & (count >> 10 == (neg | (lead == 43))) & (count >> 5 & 31 <= 1) & (ndig >= 1)
    d = (t - np.uint8(48)) * dig
    has_dot = dot.any(axis=0)
    at = (dot * rows.astype(np.uint8)).sum(axis=0, dtype=np.uint8)  # the dot's row
    if not has_dot.any() or (has_dot.all() and (at == at[0]).all()):  # one layout: digits by weight
        weight, dec = _TEN[width - 1 :: -1].copy(), 0  # 10^(width - 1 - row)
        if has_dot[0]:
            dec = width - 1 - int(at[0])
            weight[: at[0]] /= 10.0  # digits before the dot
            weight[at[0]] = 0.0
        mant = np.einsum("i,ij->j", weight, d)  # exact: integers < 2^53
        vals = mant / _TEN[dec]  # one correctly rounded division: float(text)
    else:  # dots in several places: the digits with the dot as a 0, then the 0 dropped
        big = np.einsum("i,ij->j", _TEN[width - 1 :: -1], d)  # int * 10^(dec + 1) + frac, exact
        dec = np.where(has_dot, width - 1 - at, 0)
        head = np.floor(big / _TEN[dec + 1])
        vals = np.where(has_dot, head * _TEN[dec] + (big - head * _TEN[dec + 1]), big) / _TEN[dec]
    vals = np.where(neg, -vals, vals)
    if not plain.all():
        other = np.flatnonzero(~plain)
        vals[other] = _parse_general(a, start[other], stop[other])
    return vals


def _parse_general(a: np.ndarray, start: np.ndarray, stop: np.ndarray) -> np.ndarray:
    """float64 of ``a[start:stop]`` in any form ``float()`` takes, by numpy's
    string-to-float conversion (vectorized, slower than the plain path)."""
    width = int((stop - start).max())
    rows = np.arange(width)[None, :]
    txt = np.take(a, start[:, None] + rows, mode="clip")
    txt[rows >= (stop - start)[:, None]] = 0  # bytes past the value's end
    try:
        return np.ascontiguousarray(txt).view(f"S{width}").ravel().astype(np.float64)
    except ValueError:
        bad = next(bytes(a[i:j]) for i, j in zip(start, stop) if not _is_number(bytes(a[i:j])))
        raise InputError(f"3MF: {bad[:40]!r} is not a number; the file is damaged, export it again") from None


def _is_number(text: bytes) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


_BLOCK = 1 << 20  # bytes per piece of a <vertices> or <triangles> block read at once


def _fast_column(xml: bytes, span: tuple[int, int], tag: bytes, names: Sequence[bytes], integer: bool = False) -> np.ndarray | None:
    """:func:`_column` for the common layout (``name="value"``, double quotes), on
    the bytes with numpy, in pieces of about 1 MB that end after a ``>`` (arrays that
    stay in cache): quote positions delimit values, the bytes before ``="`` name them,
    and all wanted values of a piece are parsed at once. ``None`` if the layout
    differs (the regex path then handles it)."""
    a = np.frombuffer(xml, dtype=np.uint8)
    words = np.ndarray((max(len(a) - 7, 0),), dtype="<u8", buffer=xml, strides=(1,))
    parts, (s, end) = [], span
    while s < end:  # per piece
        e = xml.find(b">", min(s + _BLOCK, end - 1), end) + 1 or end
        part = _column_piece(xml, a, words, (s, e), tag, names, integer)
        if part is None:
            return None
        parts.append(part)
        s = e
    return _joined(parts, tag, integer)


def _joined(parts: list[np.ndarray], tag: bytes, integer: bool) -> np.ndarray | None:
    """The pieces of a column as one array (int64 for indices, checked to be whole
    numbers), or None if there are none."""
    if not parts or sum(len(p) for p in parts) == 0:
        return None
    out = np.concatenate(parts)
    if integer and out.dtype != np.int64 and not np.array_equal(out, np.round(out)):
        raise InputError(f"3MF: a <{tag.decode()}> element has a non-integer index")
    return out.astype(np.int64 if integer else np.float64, copy=False)


def _column_piece(block: bytes, a: np.ndarray, words: np.ndarray, span: tuple[int, int], tag: bytes,
                  names: Sequence[bytes], integer: bool, strict: bool = False) -> np.ndarray | None:
    """The ``names`` values of the ``<tag>`` elements in ``block[span[0]:span[1]]`` as
    an ``(m, len(names))`` array (see :func:`_fast_column`), or None. ``strict``: None
    also if the piece holds any other markup (every ``<`` opens one of the elements)."""
    s, e = span
    q = np.flatnonzero(a[s:e] == 34) + s  # '"'
    k = len(names)
    if len(q) % 2 or (len(q) and (q[0] < 8 or ((q[1::2] - q[0::2]) < 2).any())):  # room for a name, non-empty
        return None
    op, cl = q[0::2], q[1::2]
    m = int(np.count_nonzero(a[s:e] == 60))  # '<': elements, if they all are <tag .../>
    if m and len(op) == m * k:
        nid = _attribute_names(a, words, op[:k], names)
        if nid is not None and sorted(nid) == list(range(k)) and _same_names(a, words, op, tag, names, nid):
            vals = _parse_decimals(a, op + 1, cl, integer=integer).reshape(m, k)  # the same order in every element
            return vals[:, np.argsort(nid)]
    lt, m = m, block[s:e].count(b"<" + tag)
    if m == 0 or (strict and lt != m):
        return np.zeros((0, k)) if len(op) == 0 and not (strict and lt) else None
    nid = _attribute_names(a, words, op, names)
    if nid is None or any(int((nid == j).sum()) != m for j in range(k)):
        return None
    sel = nid >= 0
    vals = _parse_decimals(a, op[sel] + 1, cl[sel], integer=integer)
    ids = nid[sel]
    return np.stack([vals[ids == j] for j in range(k)], axis=1)


_SPACE = np.zeros(256, dtype=bool)
_SPACE[[9, 10, 13, 32]] = True  # XML white space


def _name_key(pat: bytes) -> tuple[int, int]:
    """``(key, mask)``: ``pat`` (at most 8 bytes, e.g. ``b' x='``) as the last bytes
    of a little-endian uint64 (the 8 bytes before an opening quote)."""
    shift = 8 * (8 - len(pat))
    return int.from_bytes(pat, "little") << shift, ((1 << (8 * len(pat))) - 1) << shift


def _attribute_names(a: np.ndarray, words: np.ndarray, op: np.ndarray, names: Sequence[bytes]) -> np.ndarray | None:
    """For each opening quote ``op``, which of ``names`` the attribute is (-1: another
    one): white space, the name, ``=`` just before the quote. ``words`` are the 8 bytes
    at each position as a little-endian uint64 (a strided view: one gather); ``None``
    if a name is longer than 7 bytes or a quote has no ``=`` before it."""
    if (a[op - 1] != 61).any() or max(len(nm) for nm in names) > 6:
        return None
    w = words[op - 8]
    nid = np.full(len(op), -1, dtype=np.int64)
    for k, nm in enumerate(names):  # per attribute name
        key, mask = _name_key(nm + b"=")
        hit = (w & np.uint64(mask)) == np.uint64(key)
        hit &= _SPACE[a[op - 2 - len(nm)]]
        nid[hit] = k
    return nid


def _same_names(a: np.ndarray, words: np.ndarray, op: np.ndarray, tag: bytes, names: Sequence[bytes], nid: np.ndarray) -> bool:
    """Every element is ``<tag`` with its attributes ``names[nid[0]], names[nid[1]],
    ...`` in this order, each after one space: one gather and one compare for all
    quotes (the 8 bytes before the first quote hold the tag's end)."""
    keys = np.array([_name_key(b" " + names[j] + b"=") for j in nid], dtype=np.uint64)
    keys[0] = _name_key((b"<" + tag + b" " + names[nid[0]] + b"=")[-8:])
    w = words[op - 8].reshape(-1, len(nid))
    return bool(np.array_equal(w & keys[:, 1], np.broadcast_to(keys[:, 0], w.shape)))


def _column(xml: bytes, span: tuple[int, int], tag: bytes, names: Sequence[bytes], dtype, known: dict | None = None) -> np.ndarray:
    """All ``names`` attributes of every ``<tag .../>`` in ``xml[span[0]:span[1]]`` as
    an array ``(n, len(names))``, parsed in C (numpy on the bytes, or one regex per
    attribute for unusual layouts); taken from ``known`` (``{start: (end, array)}``,
    blocks read while the file was inflated) where it holds this very span."""
    if known and known.get(span[0], (None,))[0] == span[1]:
        return known[span[0]][1].astype(dtype, copy=False)
    fast = _fast_column(xml, span, tag, names, np.issubdtype(np.dtype(dtype), np.integer))
    if fast is not None:
        return fast.astype(dtype, copy=False)
    block = bytes(xml[span[0] : span[1]])
    elems = re.findall(rb"<" + tag + rb"\b([^>]*)>", block)
    if not elems:
        return np.zeros((0, len(names)), dtype=dtype)
    joined = b"\x00".join(elems) + b"\x00"
    cols = []
    for nm in names:
        vals = re.findall(rb"\b" + nm + rb"""\s*=\s*["']([^"'\x00]*)["'][^\x00]*\x00""", joined)
        if len(vals) != len(elems):
            raise InputError(f"3MF: a <{tag.decode()}> element lacks its {nm.decode()} attribute")
        cols.append(np.array(vals).astype(dtype))
    return np.stack(cols, axis=1)


def _elements(xml: bytes, tag: bytes) -> list[tuple[bytes, bytes]]:
    """``(attributes, content)`` of every non-nested ``<tag ...>content</tag>`` (or
    empty ``<tag .../>``), found with ``bytes.find`` (no regex over megabytes)."""
    return [(xml[h0:h1], xml[c0:c1]) for h0, h1, c0, c1 in _spans(xml, tag)]


def _spans(
    xml: bytes, tag: bytes, lo: int = 0, hi: int | None = None, *, first: bool = False, last: bool = False,
    known: "_Blocks | None" = None,
) -> list[tuple[int, int, int, int]]:
    """``(attributes start, end, content start, end)`` offsets of every non-nested
    ``<tag ...>content</tag>`` (or empty ``<tag .../>``) in ``xml[lo:hi]``, found with
    ``bytes.find`` (no copies, no regex over megabytes). ``first``: only the first one.
    ``last``: only the first one, its end tag looked for from ``hi`` backwards (an
    element that is the last in the range, as a ``<mesh>`` in its object: no scan
    over its megabytes). ``known``: blocks ``{start: (end, ...)}`` that hold no end
    tag (read while inflating): end tags are not looked for inside them."""
    out: list[tuple[int, int, int, int]] = []
    hi = len(xml) if hi is None else hi
    open_, close = b"<" + tag, b"</" + tag + b">"
    pos = lo
    while not ((first or last) and out):  # per element
        i = xml.find(open_, pos, hi)
        if i < 0:
            return out
        j = i + len(open_)
        if j < hi and xml[j : j + 1] not in (b" ", b"\t", b"\r", b"\n", b">", b"/"):
            pos = j  # a longer tag name (e.g. <objects>)
            continue
        k = xml.find(b">", j, hi)
        if k < 0:
            raise InputError(f"3MF: unterminated <{tag.decode()}> element")
        if xml[k - 1 : k] == b"/":
            out.append((j, k - 1, k, k))
            pos = k + 1
            continue
        e = xml.rfind(close, k + 1, hi) if last else _find_outside(xml, close, k + 1, hi, known)
        if e < 0:
            raise InputError(f"3MF: <{tag.decode()}> element without </{tag.decode()}>")
        out.append((j, k, k + 1, e))
        pos = e + len(close)
    return out


class _Blocks(dict):
    """Blocks read while inflating, ``{start: (end, values)}``; ``starts`` sorted
    (made once, after they are all read)."""

    @functools.cached_property
    def starts(self) -> list[int]:
        return sorted(self)


def _find_outside(xml: bytes, sub: bytes, pos: int, hi: int, known: "_Blocks | None") -> int:
    """``xml.find(sub, pos, hi)``, jumping over the ``known`` blocks (which hold no
    other ``<`` than their elements'); the first block at or after ``pos`` is found by
    bisection, so a model of many objects reads in time linear in its size."""
    if not known:
        return xml.find(sub, pos, hi)
    starts = known.starts
    for start in starts[bisect.bisect_left(starts, pos):]:  # per known block from pos on
        if start >= hi:
            break
        i = xml.find(sub, pos, start)
        if i >= 0:
            return i
        pos = known[start][0]
    return xml.find(sub, pos, hi)


def _transform(text: str | None) -> np.ndarray:
    """3MF ``transform`` attribute (12 numbers, row-vector convention) as a 4x4."""
    m = np.eye(4)
    if text:
        v = np.array(text.split(), dtype=np.float64)
        if v.size != 12:
            raise InputError(f"3MF transform must have 12 numbers, got {text!r}")
        m[:3, :3] = v[:9].reshape(3, 3)
        m[3, :3] = v[9:]
    return m


def _unit_scale(xml: bytes, path: Path) -> float:
    """mm per model unit: the ``unit`` attribute of ``<model>`` (default millimeter)."""
    i = xml.find(b"<model")
    head = xml[i : xml.find(b">", i)] if i >= 0 else b""
    unit = _attrs(head).get("unit", "millimeter").strip().lower()
    if unit not in UNITS_MM:
        raise InputError(f"{str(path)!r}: unknown 3MF unit {unit!r}; use one of {', '.join(UNITS_MM)}")
    return UNITS_MM[unit]


_XYZ, _V123 = (b"x", b"y", b"z"), (b"v1", b"v2", b"v3")


class _Inflating:
    """A zip entry inflated on a second thread (zlib releases the GIL) into a
    buffer of its final size, ``data`` (anonymous memory: its pages are zeroed as
    the inflating thread first writes them, not all at once here), of which the first
    ``ready`` bytes are there; the CRC and size are checked at the end."""

    def __init__(self, path: Path, info: zipfile.ZipInfo) -> None:
        self.data = mmap.mmap(-1, info.file_size)
        self.ready, self.done, self.error = 0, False, None
        self._cond = threading.Condition()
        self._thread = threading.Thread(target=self._run, args=(path, info), daemon=True)
        if threads() > 1:
            self._thread.start()
        else:  # TEXCAD_THREADS=1: all of it first, on this thread
            self._thread.run()

    @classmethod
    def start(cls, path: Path, info: zipfile.ZipInfo) -> "_Inflating | None":
        """Start inflating ``info``; None for what this does not read (encrypted,
        other methods than deflate and store, empty)."""
        if info.flag_bits & 1 or info.compress_type not in (zipfile.ZIP_DEFLATED, zipfile.ZIP_STORED) or not info.file_size:
            return None
        return cls(path, info)

    def _run(self, path: Path, info: zipfile.ZipInfo) -> None:
        try:
            with open(path, "rb") as fh:
                fh.seek(info.header_offset)
                head = fh.read(30)
                if head[:4] != b"PK\x03\x04":
                    raise zipfile.BadZipFile("bad local file header")
                fh.seek(info.header_offset + 30 + int.from_bytes(head[26:28], "little") + int.from_bytes(head[28:30], "little"))
                unz = zlib.decompressobj(-15) if info.compress_type == zipfile.ZIP_DEFLATED else None
                left, crc = info.compress_size, 0
                while left > 0:  # per MB of compressed input
                    raw = fh.read(min(left, 1 << 20))
                    if not raw:
                        raise zipfile.BadZipFile("truncated")
                    left -= len(raw)
                    out = raw if unz is None else unz.decompress(raw) + (unz.flush() if left == 0 else b"")
                    crc = self._put(out, crc)
                if self.ready != len(self.data) or crc != info.CRC:
                    raise zipfile.BadZipFile("bad CRC-32 or size")
        except (OSError, zlib.error, zipfile.BadZipFile) as exc:
            self.error = exc
        finally:
            with self._cond:
                self.done = True
                self._cond.notify_all()

    def _put(self, out: bytes, crc: int) -> int:
        pos = self.ready
        if pos + len(out) > len(self.data):
            raise zipfile.BadZipFile("longer than its stated size")
        self.data[pos : pos + len(out)] = out
        with self._cond:
            self.ready = pos + len(out)
            self._cond.notify_all()
        return zlib.crc32(out, crc)

    def wait(self, n: int) -> int:
        """Block until ``n`` bytes are there (or all there are); returns how many."""
        with self._cond:
            while self.ready < n and not self.done:
                self._cond.wait()
            return self.ready

    def find(self, sub: bytes, pos: int) -> int:
        """``data.find(sub, pos)``, waiting for the bytes as they come."""
        while True:  # per wait for more bytes
            ready = self.ready
            i = self.data.find(sub, pos, ready)
            if i >= 0 or (self.done and ready == self.ready):
                return i
            pos = max(pos, ready - len(sub) + 1)
            self.wait(ready + 1)

    def finish(self, path: Path) -> mmap.mmap:
        """All the bytes, once inflated and checked."""
        if self._thread.ident is not None:  # started (not run on this thread)
            self._thread.join()
        if self.error is not None:
            raise InputError(f"{str(path)!r}: its 3D model is damaged ({self.error}); export it again")
        return self.data


def _stream_meshes(src: _Inflating) -> dict[int, tuple[int, np.ndarray]]:
    """While the model inflates: each ``<vertices>`` block and the ``<triangles>``
    block after it parsed as its bytes arrive (:func:`_column_piece`, piece by piece),
    as ``{content start: (content end, array)}``. Best effort: a block of another
    layout, or any error, ends this and the rest is read once inflated."""
    xml = src.data
    a = np.frombuffer(xml, dtype=np.uint8)
    words = np.ndarray((max(len(a) - 7, 0),), dtype="<u8", buffer=xml, strides=(1,))
    found = _Blocks()
    pos = 0
    try:
        while True:  # per mesh
            for block, tag, names, integer in ((b"vertices", b"vertex", _XYZ, False), (b"triangles", b"triangle", _V123, True)):
                i = src.find(b"<" + block, pos)
                k = src.find(b">", i) if i >= 0 else -1
                if k < 0 or xml[k - 1] == 47:  # no more, or empty
                    return found
                got = _stream_column(src, a, words, (k + 1, b"</" + block + b">"), tag, names, integer)
                if got is None:
                    return found
                found[k + 1] = got
                pos = got[0]
    except InputError:
        return found


def _stream_column(src: _Inflating, a: np.ndarray, words: np.ndarray, where: tuple[int, bytes], tag: bytes,
                   names: Sequence[bytes], integer: bool) -> tuple[int, np.ndarray] | None:
    """``(end, array)`` of the block starting at ``where[0]`` and ending at its end tag
    ``where[1]``, read in pieces of about 1 MB as they are inflated. None if not read,
    or if it holds any other markup than its elements (a known block has no ``</``)."""
    xml, parts, (s, close_tag) = src.data, [], where
    while True:  # per piece
        ready = src.wait(s + _BLOCK + 1)
        e = xml.find(b">", min(s + _BLOCK, ready - 1), ready) + 1
        close = xml.find(close_tag, s, e or ready)
        if close < 0 and e == 0:
            if src.done:
                return None
            src.wait(ready + 1)
            continue
        part = _column_piece(xml, a, words, (s, close if close >= 0 else e), tag, names, integer, strict=True)
        if part is None:
            return None
        parts.append(part)
        if close >= 0:
            out = _joined(parts, tag, integer)
            return None if out is None else (close, out)
        s = e


def _read_3mf(path: Path, record: "list | None" = None) -> list[tuple[str, Mesh]]:
    """The meshes a 3MF's build reaches (:func:`read_part`): the root model streamed
    (:class:`_Inflating`), other model parts (3MF production extension: components
    with ``p:path``, as BambuStudio and OrcaSlicer write) read when a component names
    them. ``record``: a list that gets ``(name, transform, count)`` per build item (its
    meshes are the next ``count`` of the list returned)."""
    try:
        z = zipfile.ZipFile(path)
    except zipfile.BadZipFile:
        raise InputError(f"{str(path)!r} is not a 3MF (zip) package; export it again") from None
    with z:
        target = _root_part(z)
        try:
            info = z.getinfo(target)
        except KeyError:
            raise InputError(f"{str(path)!r} has no 3D model part ({target}); is it a 3MF file?") from None
        src = _Inflating.start(path, info)
        xml = z.read(target) if src is None else b""
        try:  # multi-part objects (texcad.io.write_3mf, PrusaSlicer): triangle ranges per part
            volumes = _slic3r_volumes(z.read("Metadata/Slic3r_PE_model.config"))
        except KeyError:
            volumes = {}
        known: dict = {}
        if src is not None:
            known = _stream_meshes(src)
            xml = src.finish(path)
        parts = {target: _model_objects(xml, path, target, known)}
        build = _spans(xml, b"build", xml.rfind(b"<build"), last=True) if xml.rfind(b"<build") >= 0 else []
        where = xml[build[0][2] : build[0][3]] if build else xml
        items = [(_attrs(i).get("objectid"), _transform(_attrs(i).get("transform"))) for i in re.findall(rb"<item\b([^>]*)/?>", where)]
        if not items:
            items = [(oid, np.eye(4)) for oid, e in parts[target][0].items() if "mesh" in e]
        out: list[tuple[str, Mesh]] = []

        def objects(part: str) -> tuple[dict, float]:
            if part not in parts:
                try:
                    parts[part] = _model_objects(z.read(part), path, part, {})
                except KeyError:
                    raise InputError(f"{str(path)!r}: a component refers to the missing model part {part!r}; "
                                     "export it again") from None
            return parts[part]

        subtypes = _part_subtypes(z)

        def walk(part: str, oid: str | None, tf: np.ndarray, depth: int, top: str | None, got: list) -> None:
            table, scale = objects(part)
            if oid not in table or depth > 16:
                raise InputError(f"3MF build refers to a missing or cyclic object {oid!r}")
            e = table[oid]
            if "mesh" in e:
                got.extend(_placed(e, tf, scale, volumes.get(oid) if depth == 0 and part == target else None,
                                   subtypes.get((top, oid), "part")))
            for cid, ctf, cpart in e["components"]:
                walk(cpart or part, cid, ctf @ tf, depth + 1, top, got)

        for oid, tf in items:  # per build item: its material, its negative volumes cut out
            got: list = []
            walk(target, oid, tf, 0, oid, got)
            mat = [(n, m) for n, m, k in got if k == "part"]
            neg = [m for _, m, k in got if k == "negative"]
            before = len(out)
            out.extend(_cut(path, parts[target][0].get(oid, {}).get("name", str(oid)), mat, neg) if neg and mat else mat)
            if record is not None:
                scale = parts[target][1]
                record.append((parts[target][0].get(oid, {}).get("name") or f"object {oid}", tf, scale, len(out) - before))
    if not out:
        raise InputError(f"{str(path)!r} holds no mesh objects")
    return out


def _root_part(z: zipfile.ZipFile) -> str:
    """The zip name of a 3MF's root model part (from ``_rels/.rels``)."""
    try:
        rels = z.read("_rels/.rels")
    except KeyError:
        return "3D/3dmodel.model"
    m = re.search(rb'Target="/?([^"]+)"[^>]*Type="[^"]*3dmodel"', rels) or re.search(
        rb'Type="[^"]*3dmodel"[^>]*Target="/?([^"]+)"', rels
    )
    return m.group(1).decode() if m else "3D/3dmodel.model"


def _model_objects(xml: "bytes | mmap.mmap", path: Path, part: str, known: dict) -> tuple[dict, float]:
    """``({object id: {"name", "mesh" (optional), "components"}}, mm per unit)`` of
    one model part; each component ``(object id, 4x4, zip name of its part or None)``."""
    end = bytes(xml[max(0, len(xml) - 4096):]).rstrip()
    if not end.endswith(b"</model>"):
        raise InputError(f"{str(path)!r}: its 3D model ({part}) ends before </model>: the XML is cut short; export it again")
    if xml.find(b"<model") < 0:
        raise InputError(f"{str(path)!r}: its 3D model ({part}) holds no <model> element; export it again")
    _required_extensions(xml, path, part)
    objects: dict[str, dict[str, Any]] = {}
    for h0, h1, b0, b1 in _spans(xml, b"object", known=known):  # per object
        a = _attrs(xml[h0:h1])
        oid = a.get("id")
        if oid is None:
            continue
        _whole_geometry(xml, path, a, (b0, b1))
        entry: dict[str, Any] = {"name": _xml_unescape(a.get("name", f"object {oid}"))}
        rest = xml[b0:b1] if xml.find(b"<mesh", b0, b1) < 0 else b""
        for _, _, m0, m1 in _spans(xml, b"mesh", b0, b1, last=True):  # its mesh, if any
            entry["mesh"] = _mesh_arrays(xml, (m0, m1), oid, known)
            rest = xml[b0 : xml.rfind(b"<mesh", b0, m0)] + xml[m1:b1]  # components lie outside the mesh
        comps = [_attrs(c) for c in re.findall(rb"<component\b([^>]*)/?>", rest)]
        entry["components"] = [(c.get("objectid"), _transform(c.get("transform")), c["p:path"].lstrip("/") if c.get("p:path") else None)
                               for c in comps]  # fmt: skip
        objects[oid] = entry
    return objects, _unit_scale(xml, path)


#: 3MF extensions whose content texcad reads or may leave aside without changing the
#: part's shape: materials and colours, production (components in other model parts,
#: UUIDs), slices (an object whose mesh is only a stand-in for them is refused by
#: :func:`_whole_geometry`) and triangle sets.
SHAPE_NEUTRAL_EXTENSIONS = frozenset({
    "http://schemas.microsoft.com/3dmanufacturing/material/2015/02",
    "http://schemas.microsoft.com/3dmanufacturing/production/2015/06",
    "http://schemas.microsoft.com/3dmanufacturing/slice/2015/07",
    "http://schemas.microsoft.com/3dmanufacturing/trianglesets/2021/07",
})


def _required_extensions(xml: "bytes | mmap.mmap", path: Path, part: str) -> None:
    """InputError where a model part's ``requiredextensions`` names an extension
    outside :data:`SHAPE_NEUTRAL_EXTENSIONS` (beam lattices, booleans, displacement,
    volumetric or one texcad does not know): its producer says the part's shape needs
    it, so the triangles alone are not the part (3MF core specification, 2.3.1)."""
    start = xml.find(b"<model")
    head = bytes(xml[start:xml.find(b">", start) + 1])
    spaces = {k.decode(): v.decode() for k, v in re.findall(rb'xmlns:([\w.-]+)\s*=\s*"([^"]*)"', head)}
    wanted = re.search(rb'requiredextensions\s*=\s*"([^"]*)"', head)
    unread = [spaces.get(p, p) for p in (wanted.group(1).decode().split() if wanted else ())]
    unread = [u for u in unread if u not in SHAPE_NEUTRAL_EXTENSIONS]
    if unread:
        raise InputError(f"{str(path)!r} ({part}) requires the 3MF extension(s) {', '.join(unread)}, which texcad does "
                         "not read: its triangles alone are not the part. Export the part as plain triangle meshes "
                         "(STL or a 3MF without these extensions)")


def _whole_geometry(xml: "bytes | mmap.mmap", path: Path, attrs: dict, span: tuple[int, int]) -> None:
    """InputError for an object (its attributes, its element's byte span) whose
    triangles are not its whole shape: a slice extension object whose mesh is a
    low-resolution stand-in for its slices (``meshresolution="lowres"``), or a mesh
    with a beam lattice (beams of some radius along its edges)."""
    name = attrs.get("name", attrs.get("id"))
    if any(k.endswith("meshresolution") and v == "lowres" for k, v in attrs.items()):
        raise InputError(f"{str(path)!r}: object {name!r} is given by slices, its mesh only a low-resolution stand-in; "
                         "texcad reads triangle meshes: export the part as a full-resolution mesh (STL or 3MF)")
    end = xml.rfind(b"</triangles>", span[0], span[1])
    if end >= 0 and re.search(rb"<(?:[\w.-]+:)?beamlattice\b", bytes(xml[end:span[1]])):
        raise InputError(f"{str(path)!r}: object {name!r} has a beam lattice (beams along its edges), which texcad does "
                         "not read; export the part as a triangle mesh with its beams meshed")


def _placed(e: dict, tf: np.ndarray, scale: float, parts: "list | None", kind: str = "part") -> list[tuple[str, Mesh, str]]:
    """An object's mesh moved by ``tf`` (4x4, row vectors) and scaled to mm: one
    ``(name, Mesh, kind)``, or one per part of a multi-part object (``parts``: name,
    first and last triangle, kind: :data:`VOLUME_KINDS`). A mirroring ``tf``
    (negative determinant) reverses the triangles' winding, as the 3MF core
    specification asks of consumers (else the mesh is inside out, its volume negative)."""
    v, t = e["mesh"]
    vv = v if np.array_equal(tf, np.eye(4)) else v @ tf[:3, :3] + tf[3, :3]
    t = t[:, [0, 2, 1]] if np.linalg.det(tf[:3, :3]) < 0 else t  # the first corner kept: triangle ids and corners as written
    vv = vv if scale == 1.0 else vv * scale
    if parts and parts[-1][2] == len(t) - 1 and all(p[1] <= p[2] for p in parts):
        out = []
        for vname, first, last, vkind in parts:  # each part with its own vertices
            used, tt = np.unique(t[first : last + 1], return_inverse=True)
            out.append((vname, Mesh(vv[used].astype(np.float32), tt.reshape(-1, 3).astype(np.uint32)), vkind))
        return out
    return [(e["name"], Mesh(vv.astype(np.float32), t.astype(np.uint32)), kind)]


def _mesh_arrays(xml: bytes, span: tuple[int, int], oid: str, known: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (N, 3) float64, triangles (M, 3) int64)`` of the ``<mesh>`` whose
    content is ``xml[span[0]:span[1]]`` (blocks in ``known`` are taken from there)."""
    vs = next(iter(_spans(xml, b"vertices", *span, first=True, known=known)), None)
    ts = next(iter(_spans(xml, b"triangles", vs[3] if vs else span[0], span[1], last=True)), None)
    v = _column(xml, vs[2:] if vs else (0, 0), b"vertex", _XYZ, np.float64, known)
    t = _column(xml, ts[2:] if ts else (0, 0), b"triangle", _V123, np.int64, known)
    if len(t) and (t.min() < 0 or t.max() >= len(v)):
        k = int(np.flatnonzero((t < 0).any(axis=1) | (t >= len(v)).any(axis=1))[0])
        raise InputError(f"3MF object {oid}: triangle {k} refers to vertex {t[k].tolist()} but the object has "
                         f"{len(v)} vertices (0..{len(v) - 1}); the file is damaged, export it again")
    bad = np.flatnonzero(~np.isfinite(v).all(axis=1))
    if len(bad):
        raise InputError(f"3MF object {oid}: vertex {int(bad[0])} is {v[bad[0]].tolist()}, not finite numbers "
                         f"({len(bad)} such vertices); the file is damaged, export it again")
    return v, t


#: What a slicer volume is (PrusaSlicer's ``volume_type``, BambuStudio's and
#: OrcaSlicer's part ``subtype``): material, a volume cut out of its object, or
#: neither (a modifier, a support enforcer or blocker: settings, not material).
#: Anything else is taken as material.
VOLUME_KINDS = {"ParameterModifier": "setting", "SupportEnforcer": "setting", "SupportBlocker": "setting",
                "modifier_part": "setting", "support_enforcer": "setting", "support_blocker": "setting",
                "NegativeVolume": "negative", "negative_part": "negative"}


def _slic3r_volumes(xml: bytes) -> dict[str, list[tuple[str, int, int, str]]]:
    """``{object id: [(part name, first triangle, last triangle, kind), ...]}`` from a
    ``Metadata/Slic3r_PE_model.config`` (multi-part objects; kind
    :data:`VOLUME_KINDS`, ``"part"`` for material)."""
    out: dict[str, list[tuple[str, int, int, str]]] = {}
    for head, body in _elements(xml, b"object"):
        oid = _attrs(head).get("id")
        parts = []
        for k, (vhead, vbody) in enumerate(_elements(body, b"volume")):
            va = _attrs(vhead)
            try:
                first, last = int(va.get("firstid", "")), int(va.get("lastid", ""))
            except ValueError:
                continue
            m = re.search(rb'key="name"\s+value="([^"]*)"', vbody)
            t = re.search(rb'key="volume_type"\s+value="([^"]*)"', vbody)
            kind = VOLUME_KINDS.get(t.group(1).decode() if t else "", "part")
            parts.append((_xml_unescape(m.group(1).decode()) if m else f"part {k + 1}", first, last, kind))
        if oid is not None and parts:
            out[oid] = parts
    return out


def _part_subtypes(z: zipfile.ZipFile) -> dict[tuple, str]:
    """``{(build object id, part object id): kind}`` of the parts that are not
    material (:data:`VOLUME_KINDS`) from BambuStudio's / OrcaSlicer's
    ``Metadata/model_settings.config``."""
    try:
        cfg = z.read("Metadata/model_settings.config")
    except KeyError:
        return {}
    out = {}
    for head, body in _elements(cfg, b"object"):  # per object
        oid = _attrs(head).get("id")
        for ph in re.findall(rb"<part\b([^>]*)>", body):  # per part
            pa = _attrs(ph)
            kind = VOLUME_KINDS.get(pa.get("subtype", "normal_part"), "part")
            if kind != "part":
                out[(oid, pa.get("id"))] = kind
    return out


def _cut(path: Path, name: str, parts: list, negatives: list) -> list[tuple[str, Mesh]]:
    """An object's material parts ``(name, Mesh)`` with its negative volumes cut out
    (manifold3d), as the slicer prints them; parts cut away whole are dropped."""
    from ..errors import GeometryError
    from ..solid import from_manifold, to_manifold

    try:
        hole = to_manifold(negatives[0])
        for m in negatives[1:]:
            hole = hole + to_manifold(m)
        out = [(n, from_manifold(to_manifold(m) - hole)) for n, m in parts]
    except GeometryError as exc:
        raise InputError(f"{str(path)!r}: object {name!r} has a negative volume, which texcad cuts out of it, but "
                         f"{exc}; apply the cut in the slicer or CAD program and export the part again") from None
    return [(n, m) for n, m in out if len(m.faces)]


def read_part(path: str | os.PathLike) -> list[tuple[str, Mesh]]:
    """Read an STL (binary or ASCII), a 3MF or an OBJ into named meshes (mm).

    STL: one mesh named after the file, vertices welded where bit-identical. OBJ:
    one mesh named after the file (:func:`read_mesh`).
    3MF: every mesh object reached from the build items (components and
    ``transform`` attributes applied), named by its ``name`` attribute; a
    multi-part object (``Metadata/Slic3r_PE_model.config``, as
    :func:`texcad.io.write_3mf` and PrusaSlicer write) gives one mesh per part.
    A slicer project's modifiers and support enforcers / blockers (PrusaSlicer's
    volume types, BambuStudio's and OrcaSlicer's part subtypes) are left out and
    its negative volumes cut out of their object (manifold3d), as the slicer prints it.

    Raises:
        InputError: missing, empty or unreadable file, or unknown suffix.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"part {str(p)!r} does not exist; check the path")
    if p.stat().st_size == 0:
        raise InputError(f"part {str(p)!r} is empty (0 bytes); export it again")
    suffix = p.suffix.lower()
    if suffix == ".stl":
        return [(p.stem, _read_stl(p))]
    if suffix == ".obj":
        return [(p.stem, _read_obj(p))]
    if suffix == ".3mf":
        return _guarded_3mf(p)
    raise unreadable(p)


def _guarded_3mf(p: Path, record: "list | None" = None) -> list[tuple[str, Mesh]]:
    """:func:`_read_3mf`, a damaged package's failure told as an InputError."""
    try:
        return _read_3mf(p, record)
    except TexcadError:
        raise
    except (zipfile.BadZipFile, zlib.error, EOFError, OSError, RuntimeError, NotImplementedError, ValueError, IndexError) as exc:
        raise InputError(f"{str(p)!r}: the 3MF package is damaged ({type(exc).__name__}: {exc}); export it again") from None


def build_items(path: str | os.PathLike) -> list[tuple[str, np.ndarray, tuple]]:
    """A 3MF's build items, in order: ``(name, transform, meshes)`` with ``transform``
    the item's ``(4, 4)`` matrix (row vectors, ``p' = p M``, mm: the file's unit
    applied to its translation) and ``meshes`` what :func:`read_part` gives for the
    item (placed: the transform applied). A slicer arranges the items apart.

    Raises:
        InputError: as :func:`read_part`; a file that is not a 3MF.
    """
    p = Path(path)
    if p.suffix.lower() != ".3mf":
        raise InputError(f"{str(p)!r} is not a 3MF; build items are a 3MF's")
    if not p.is_file() or p.stat().st_size == 0:
        read_part(p)  # missing or empty: its message
    record: list = []
    meshes = _guarded_3mf(p, record)
    out, at = [], 0
    for name, tf, scale, count in record:  # per build item
        m = np.array(tf, dtype=np.float64)
        m[3, :3] *= scale
        out.append((name, m, tuple(mesh for _, mesh in meshes[at : at + count])))
        at += count
    return out


def unreadable(path: str | os.PathLike) -> InputError:
    """The InputError for a part in a format texcad does not read (a PLY, OFF, GLB...),
    naming its suffix, the formats texcad reads and how to get one."""
    p = Path(path)
    what = f"{p.suffix!r} files" if p.suffix else "files without a suffix"
    return InputError(f"{str(p)!r}: texcad reads .stl, .3mf and .obj meshes and .step / .stp CAD parts, not "
                      f"{what}; convert it to STL or 3MF first (MeshLab, Blender or trimesh write them)")


def _obj_error(path: Path, lines: list[str], k: int, what: str) -> InputError:
    return InputError(f"{str(path)!r}, line {k + 1}: {what} ({lines[k].strip()[:60]!r}); the file is damaged, export it again")


def _read_obj(path: Path) -> Mesh:
    """A Wavefront OBJ's ``v`` and ``f`` lines (every group and object merged;
    polygons split into triangles (:func:`_polygon_triangles`; a face line may be
    continued with a backslash); ``v/vt/vn`` and negative, relative indices
    taken), in the file's units taken as mm. Strict: a malformed or non-finite
    number or an index that names no vertex is an InputError naming the line."""
    text = path.read_bytes().decode("utf-8", errors="replace")
    # a backslash at a line's end continues it (Blender, 3ds Max), whatever the line ends (CR LF, CR)
    lines = re.sub(r"\\[ \t]*(?:\r\n|\r|\n)", " ", text).splitlines()
    head = [ln[:2] for ln in lines]  # one pass per line in C: the record kinds
    vk = [k for k, h in enumerate(head) if h == "v " or h == "v\t"]
    fk = [k for k, h in enumerate(head) if h == "f " or h == "f\t"]
    if not vk or not fk:
        raise InputError(f"{str(path)!r}: an OBJ needs 'v' and 'f' lines, it has {len(vk)} and {len(fk)}; export it again")
    vparts = [lines[k].split()[1:] for k in vk]
    bad = next((i for i, p in enumerate(vparts) if len(p) not in (3, 4, 6, 7)), None)
    if bad is not None:
        raise _obj_error(path, lines, vk[bad], "a vertex needs three numbers")
    try:
        v = np.array([p[:3] for p in vparts], dtype=np.float64)
    except ValueError:
        bad = next(i for i, p in enumerate(vparts) if not all(map(_is_number, p[:3])))
        raise _obj_error(path, lines, vk[bad], "not three numbers") from None
    fin = np.isfinite(v).all(axis=1)
    if not fin.all():
        raise _obj_error(path, lines, vk[int(np.flatnonzero(~fin)[0])], "a coordinate that is not a finite number")
    fparts = [lines[k].split()[1:] for k in fk]
    size = np.array([len(p) for p in fparts], dtype=np.int64)
    if (size < 3).any():
        raise _obj_error(path, lines, fk[int(np.flatnonzero(size < 3)[0])], "a face needs at least three vertices")
    tokens = [t.split("/", 1)[0] for p in fparts for t in p]
    try:
        idx = np.array(tokens, dtype=np.int64)
    except ValueError:
        at = np.repeat(np.arange(len(fk)), size)[next(i for i, t in enumerate(tokens) if not t.lstrip("-+").isdigit())]
        raise _obj_error(path, lines, fk[int(at)], "a vertex index that is not a whole number") from None
    before = np.searchsorted(np.asarray(vk), np.asarray(fk))  # vertices defined above each face line
    idx = np.where(idx < 0, idx + np.repeat(before, size), idx - 1)  # 0-based, relative indices resolved
    wrong = (idx < 0) | (idx >= len(v)) | (np.asarray(tokens) == "0")
    if wrong.any():
        at = int(np.repeat(np.arange(len(fk)), size)[int(np.flatnonzero(wrong)[0])])
        raise _obj_error(path, lines, fk[at], f"a vertex index outside 1..{len(v)}")
    return Mesh(v.astype(np.float32), _polygon_triangles(v, idx, size).astype(np.uint32))


def _polygon_triangles(v: np.ndarray, idx: np.ndarray, size: np.ndarray) -> np.ndarray:
    """``(T, 3)`` triangles of the polygons ``idx`` (their vertex indices one after
    another, ``size`` each) on the points ``v`` (mm): a convex polygon fanned from its
    first vertex; a concave one (a wall with a notch, written as one 11-gon) or one with
    a straight corner (a rectangle with its sides' midpoints) split by ear clipping in
    its plane (manifold3d's ``triangulate``), in its winding. A fan of a concave
    polygon covers area outside it; across a straight corner it makes a triangle of
    no area and an edge that skips the midpoint its neighbour has (an open seam)."""
    start = np.cumsum(size) - size  # fans: (first, k, k + 1) for k in 1 .. n - 2
    ntri = size - 2
    owner = np.repeat(np.arange(len(size)), ntri)
    k = np.arange(int(ntri.sum())) - np.repeat(np.cumsum(ntri) - ntri, ntri) + 1
    first = start[owner]
    faces = np.stack([idx[first], idx[first + k], idx[first + k + 1]], axis=1)
    slot = np.cumsum(ntri) - ntri  # each polygon's first triangle
    for i in np.flatnonzero(_bent(v, idx, start, size)):  # a loop per polygon that is not strictly convex (few)
        ring = idx[start[i]:start[i] + size[i]]
        tri = _ear_clip(v[ring])
        if len(tri) == size[i] - 2:  # a simple polygon: as many triangles as the fan, in its place
            faces[slot[i]:slot[i] + size[i] - 2] = ring[tri]
    return faces


def _bent(v: np.ndarray, idx: np.ndarray, start: np.ndarray, size: np.ndarray, block: int = 1 << 18) -> np.ndarray:
    """``(P,)`` bool: the polygons of ``v`` (mm) with a corner that does not turn with
    their winding (about their Newell normal, by more than 1e-6 of its edges' lengths:
    concave or straight), polygons of one size at a time, ``block`` at once."""
    out = np.zeros(len(size), dtype=bool)
    for n in np.unique(size[size > 3]):
        for part in np.array_split(np.flatnonzero(size == n), max(1, -(-int(np.sum(size == n)) // block))):
            p = v[idx[start[part][:, None] + np.arange(n)]]  # (P, n, 3) mm
            e = np.roll(p, -1, axis=1) - p
            normal = np.cross(p, np.roll(p, -1, axis=1)).sum(axis=1)  # Newell: twice the area vector
            turn = np.einsum("pni,pi->pn", np.cross(e, np.roll(e, -1, axis=1)), normal)
            length = np.linalg.norm(e, axis=2)
            scale = length * np.roll(length, -1, axis=1) * np.linalg.norm(normal, axis=1)[:, None]
            out[part] = (turn <= 1e-6 * scale).any(axis=1)
    return out


def _ear_clip(p: np.ndarray) -> np.ndarray:
    """``(T, 3)`` indices into the polygon ``p`` ``(n, 3)`` mm: its triangles, made in
    its plane (the Newell normal's) by manifold3d's ear clipping, wound as ``p``."""
    import manifold3d as m3d

    normal = np.cross(p, np.roll(p, -1, axis=0)).sum(axis=0)
    normal /= np.linalg.norm(normal)
    u = np.cross(normal, np.eye(3)[int(np.argmin(np.abs(normal)))])
    u /= np.linalg.norm(u)
    w = np.cross(normal, u)  # (u, w, normal) right-handed: the polygon runs counter-clockwise in (u, w)
    flat = np.stack([p @ u, p @ w], axis=1)
    return np.asarray(m3d.triangulate([flat]), dtype=np.int64).reshape(-1, 3)


def read_mesh(path: str | os.PathLike) -> Mesh:
    """Read an STL, 3MF or OBJ file as one :class:`Mesh` in mm (every object of a 3MF
    merged; OBJ: every group merged, in the file's own units taken as mm).

    Raises:
        InputError: missing, empty or unreadable file, or unknown suffix.
    """
    p = Path(path)
    if p.suffix.lower() == ".obj":
        if not p.is_file():
            raise InputError(f"part {str(p)!r} does not exist; check the path")
        return _read_obj(p)
    meshes = [m for _, m in read_part(p)]
    if not meshes or sum(m.num_triangles for m in meshes) == 0:
        raise InputError(f"{str(p)!r} holds no triangles")
    if len(meshes) == 1:
        return meshes[0]
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
    return Mesh(
        np.concatenate([m.vertices for m in meshes]),
        np.concatenate([m.faces + np.uint32(o) for m, o in zip(meshes, offsets)]),
    )


def load_mesh(path: str | os.PathLike, *, tolerance: float = 0.01) -> Mesh:
    """Read an STL, 3MF or OBJ (all objects merged, mm) or a STEP file as one Mesh.

    STEP: texcad's texture faces (degree-1 B-spline grids) are meshed from their
    poles, every other face by OCCT with ``tolerance`` mm (see
    :func:`texcad.brep.shape_mesh`): a mesh for looking at, not for printing.

    Raises:
        InputError: missing or unreadable file.
        ParameterError: unknown suffix.
    """
    from ..errors import ParameterError

    p = Path(path)
    if not p.is_file():
        raise InputError(f"{str(p)!r} does not exist")
    suffix = p.suffix.lower()
    if suffix in (".step", ".stp"):
        from ..brep import shape_mesh
        from .step import read_step

        return shape_mesh(read_step(p), tolerance=tolerance)
    if suffix not in (".stl", ".3mf", ".obj"):
        raise ParameterError(f"cannot read {p.suffix!r} files; use .stl, .3mf, .obj or .step")
    return read_mesh(p)
