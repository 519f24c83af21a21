"""Mesh files in: STL (binary and ASCII) and 3MF (components, transforms and the
model's ``unit`` applied), vectorized, as named :class:`~texcad.solid.Mesh` objects in mm.
"""

from __future__ import annotations

import os
import re
import zipfile
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import InputError
from ..solid import Mesh

__all__ = ["read_part", "read_mesh", "load_mesh", "UNITS_MM"]

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


def _read_stl(path: Path) -> Mesh:
    data = path.read_bytes()
    if len(data) >= 84:
        n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
        if len(data) == 84 + 50 * n:
            rec = np.frombuffer(
                data, dtype=np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")]), count=n, offset=84
            )
            tri = rec["v"]
            verts, faces = _weld(tri)
            return Mesh(verts, faces)
    text = data.decode("ascii", errors="replace")
    if not text.lstrip().lower().startswith("solid"):
        raise InputError(f"{str(path)!r} is neither a binary nor an ASCII STL; export it again")
    nums = re.findall(r"vertex\s+([-+0-9.eE]+)\s+([-+0-9.eE]+)\s+([-+0-9.eE]+)", text)
    if not nums or len(nums) % 3:
        raise InputError(f"{str(path)!r}: ASCII STL without complete triangles")
    tri = np.array(nums, dtype=np.float64).astype(np.float32).reshape(-1, 3, 3)
    verts, faces = _weld(tri)
    return Mesh(verts, faces)


_ATTR = re.compile(rb'([A-Za-z_:][-\w:.]*)\s*=\s*"([^"]*)"')


def _attrs(blob: bytes) -> dict[str, str]:
    return {k.decode(): v.decode("utf-8", "replace") for k, v in _ATTR.findall(blob)}


def _xml_unescape(s: str) -> str:
    return s.replace("&quot;", '"').replace("&lt;", "<").replace("&gt;", ">").replace("&apos;", "'").replace("&amp;", "&")


def _parse_decimals(a: np.ndarray, start: np.ndarray, stop: np.ndarray) -> np.ndarray | None:
    """Parse the byte ranges ``a[start:stop]`` as plain decimals (``-12.345``, ``7``),
    vectorized over the values (in cache-sized chunks) with a loop over character
    positions: mantissa as int64, then one correctly rounded division by
    ``10**decimals`` (the same double as ``float(text)``). ``None`` if any value has
    another form (exponents, ...)."""
    n = len(start)
    if n == 0:
        return np.zeros(0)
    out = np.empty(n, dtype=np.float64)
    step = 1 << 17
    last = len(a) - 1
    for k in range(0, n, step):  # per chunk of values
        st, length = start[k : k + step], stop[k : k + step] - start[k : k + step]
        width = int(length.max())
        if width > 19 or length.min() < 1:
            return None
        m = len(st)
        mant = np.zeros(m, dtype=np.int64)
        ndig = np.zeros(m, dtype=np.int64)
        dec = np.zeros(m, dtype=np.int64)
        seen_dot = np.zeros(m, dtype=bool)
        neg = a[st] == 45  # '-'
        lead = neg | (a[st] == 43)  # '+'
        for j in range(width):  # per character position
            live = j < length
            c = a[np.minimum(st + j, last)].astype(np.int64) - 48
            dig = live & (c >= 0) & (c <= 9)
            dot = live & (c == -2)  # '.'
            bad = live & ~dig & ~dot
            if j == 0:
                bad &= ~lead
            if bad.any() or (dot & seen_dot).any():
                return None
            mant = np.where(dig, mant * 10 + c, mant)
            ndig += dig
            dec += dig & seen_dot
            seen_dot |= dot
        if ndig.min() < 1 or ndig.max() > 15:  # mantissa < 2**53: exact
            return None
        vals = mant.astype(np.float64) / 10.0**dec
        out[k : k + step] = np.where(neg, -vals, vals)
    return out


def _fast_column(block: bytes, tag: bytes, names: Sequence[bytes]) -> np.ndarray | None:
    """:func:`_column` for the common layout (``name="value"``, double quotes), on
    the bytes with numpy: quote positions delimit values, the bytes before ``="``
    name them, and all wanted values are parsed at once. ``None`` if the layout
    differs (the regex path then handles it)."""
    n = block.count(b"<" + tag)
    a = np.frombuffer(block, dtype=np.uint8)
    q = np.flatnonzero(a == 34)  # '"'
    if n == 0 or len(q) % 2:
        return None
    op, cl = q[0::2], q[1::2]
    if (op < 3).any() or (a[op - 1] != 61).any() or ((cl - op) < 2).any():  # '=' before, non-empty
        return None
    nid = np.full(len(op), -1, dtype=np.int64)
    for k, nm in enumerate(names):  # per attribute name
        L = len(nm)
        ok = np.isin(a[np.maximum(op - 2 - L, 0)], np.frombuffer(b" \t\r\n", dtype=np.uint8))
        for i, ch in enumerate(nm):
            ok &= a[op - 1 - L + i] == ch
        nid[ok] = k
    sel = nid >= 0
    if any(int((nid == k).sum()) != n for k in range(len(names))):
        return None
    vals = _parse_decimals(a, op[sel] + 1, cl[sel])
    if vals is None:
        return None
    ids = nid[sel]
    return np.stack([vals[ids == k] for k in range(len(names))], axis=1)


def _column(block: bytes, tag: bytes, names: Sequence[bytes], dtype) -> np.ndarray:
    """All ``names`` attributes of every ``<tag .../>`` in ``block`` as an array
    ``(n, len(names))``, parsed in C (numpy on the bytes, or one regex per
    attribute for unusual layouts)."""
    fast = _fast_column(block, tag, names)
    if fast is not None:
        if np.issubdtype(np.dtype(dtype), np.integer):
            if not np.array_equal(fast, np.round(fast)):
                raise InputError(f"3MF: a <{tag.decode()}> element has a non-integer index")
            return fast.astype(dtype)
        return fast.astype(dtype)
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
    out = []
    open_, close = b"<" + tag, b"</" + tag + b">"
    pos = 0
    while True:  # per element
        i = xml.find(open_, pos)
        if i < 0:
            return out
        j = i + len(open_)
        if j < len(xml) and xml[j : j + 1] not in (b" ", b"\t", b"\r", b"\n", b">", b"/"):
            pos = j  # a longer tag name (e.g. <objects>)
            continue
        k = xml.find(b">", j)
        if k < 0:
            raise InputError(f"3MF: unterminated <{tag.decode()}> element")
        if xml[k - 1 : k] == b"/":
            out.append((xml[j : k - 1], b""))
            pos = k + 1
            continue
        e = xml.find(close, k + 1)
        if e < 0:
            raise InputError(f"3MF: <{tag.decode()}> element without </{tag.decode()}>")
        out.append((xml[j:k], xml[k + 1 : e]))
        pos = e + len(close)


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


def _read_3mf(path: Path) -> list[tuple[str, Mesh]]:
    try:
        z = zipfile.ZipFile(path)
    except zipfile.BadZipFile:
        raise InputError(f"{str(path)!r} is not a 3MF (zip) package; export it again") from None
    with z:
        target = "3D/3dmodel.model"
        try:
            rels = z.read("_rels/.rels")
            m = re.search(rb'Target="/?([^"]+)"[^>]*Type="[^"]*3dmodel"', rels) or re.search(
                rb'Type="[^"]*3dmodel"[^>]*Target="/?([^"]+)"', rels
            )
            if m:
                target = m.group(1).decode()
        except KeyError:
            pass
        try:
            xml = z.read(target)
        except KeyError:
            raise InputError(f"{str(path)!r} has no 3D model part ({target}); is it a 3MF file?") from None
        try:  # multi-part objects (texcad.io.write_3mf, PrusaSlicer): triangle ranges per part
            volumes = _slic3r_volumes(z.read("Metadata/Slic3r_PE_model.config"))
        except KeyError:
            volumes = {}
    scale = _unit_scale(xml, path)
    objects: dict[str, dict[str, Any]] = {}
    for head, body in _elements(xml, b"object"):  # per object
        a = _attrs(head)
        oid = a.get("id")
        if oid is None:
            continue
        entry: dict[str, Any] = {"name": _xml_unescape(a.get("name", f"object {oid}"))}
        if b"<mesh" in body:
            vs = next(iter(_elements(body, b"vertices")), (b"", b""))[1]
            ts = next(iter(_elements(body, b"triangles")), (b"", b""))[1]
            v = _column(vs, b"vertex", (b"x", b"y", b"z"), np.float64)
            t = _column(ts, b"triangle", (b"v1", b"v2", b"v3"), np.int64)
            if len(t) and (t.min() < 0 or t.max() >= len(v)):
                raise InputError(f"3MF object {oid}: a triangle refers to a missing vertex")
            entry["mesh"] = (v, t)
        comps = [(_attrs(c).get("objectid"), _transform(_attrs(c).get("transform"))) for c in re.findall(rb"<component\b([^>]*)/?>", body)]
        entry["components"] = comps
        objects[oid] = entry
    items = [(_attrs(i).get("objectid"), _transform(_attrs(i).get("transform"))) for i in re.findall(rb"<item\b([^>]*)/?>", xml)]
    if not items:
        items = [(oid, np.eye(4)) for oid, e in objects.items() if "mesh" in e]
    out: list[tuple[str, Mesh]] = []

    def walk(oid: str | None, tf: np.ndarray, depth: int) -> None:
        if oid not in objects or depth > 16:
            raise InputError(f"3MF build refers to a missing or cyclic object {oid!r}")
        e = objects[oid]
        if "mesh" in e:
            v, t = e["mesh"]
            vv = v if np.array_equal(tf, np.eye(4)) else v @ tf[:3, :3] + tf[3, :3]
            vv = vv if scale == 1.0 else vv * scale
            parts = volumes.get(oid) if depth == 0 else None
            if parts and parts[-1][2] == len(t) - 1 and all(a <= b for _, a, b in parts):
                for vname, first, last in parts:  # each part with its own vertices
                    used, tt = np.unique(t[first : last + 1], return_inverse=True)
                    out.append((vname, Mesh(vv[used].astype(np.float32), tt.reshape(-1, 3).astype(np.uint32))))
            else:
                out.append((e["name"], Mesh(vv.astype(np.float32), t.astype(np.uint32))))
        for cid, ctf in e["components"]:
            walk(cid, ctf @ tf, depth + 1)

    for oid, tf in items:  # per build item
        walk(oid, tf, 0)
    if not out:
        raise InputError(f"{str(path)!r} holds no mesh objects")
    return out


def _slic3r_volumes(xml: bytes) -> dict[str, list[tuple[str, int, int]]]:
    """``{object id: [(part name, first triangle, last triangle), ...]}`` from a
    ``Metadata/Slic3r_PE_model.config`` (multi-part objects)."""
    out: dict[str, list[tuple[str, int, int]]] = {}
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
            parts.append((_xml_unescape(m.group(1).decode()) if m else f"part {k + 1}", first, last))
        if oid is not None and parts:
            out[oid] = parts
    return out


def read_part(path: str | os.PathLike) -> list[tuple[str, Mesh]]:
    """Read an STL (binary or ASCII) or a 3MF into named meshes (mm).

    STL: one mesh named after the file, vertices welded where bit-identical.
    3MF: every mesh object reached from the build items (components and
    ``transform`` attributes applied), named by its ``name`` attribute; a
    multi-part object (``Metadata/Slic3r_PE_model.config``, as
    :func:`texcad.io.write_3mf` and PrusaSlicer write) gives one mesh per part.

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
    if suffix == ".3mf":
        return _read_3mf(p)
    raise InputError(f"cannot check {str(p)!r}: texcad reads .stl and .3mf parts")


def read_mesh(path: str | os.PathLike) -> Mesh:
    """Read an STL, 3MF or OBJ file as one :class:`Mesh` in mm (every object of a 3MF
    merged; OBJ through trimesh, in the file's own units taken as mm).

    Raises:
        InputError: missing, empty or unreadable file, or unknown suffix.
    """
    p = Path(path)
    if p.suffix.lower() == ".obj":
        import trimesh

        if not p.is_file():
            raise InputError(f"part {str(p)!r} does not exist; check the path")
        tm = trimesh.load(p, force="mesh", process=True)
        if len(tm.faces) == 0:
            raise InputError(f"{str(p)!r} holds no triangles")
        return Mesh(np.asarray(tm.vertices, np.float32), np.asarray(tm.faces, np.uint32))
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
    :func:`texcad.solid.shape_mesh`): a mesh for looking at, not for printing.

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
        from ..solid import shape_mesh
        from .step import read_step

        return shape_mesh(read_step(p), tolerance=tolerance)
    if suffix not in (".stl", ".3mf", ".obj"):
        raise ParameterError(f"cannot read {p.suffix!r} files; use .stl, .3mf, .obj or .step")
    return read_mesh(p)
