"""``texcad check``: is a part printable? Watertight, manifold, overhangs, thin features.

A part is read from STL or 3MF (or given as meshes) and measured:

* **watertight**: every edge is shared by exactly two faces in opposite directions
  (:func:`texcad.mesh.edge_report`), for every object in the file;
* **manifold**: manifold3d accepts every object as a closed, oriented solid;
* **shells, volume, bounding box, triangles** of the whole part (several objects
  are united with manifold3d first, as a slicer would);
* **overhang area** (mm^2) for a build direction and critical angle, by the rule of
  :func:`texcad.printability.overhang_mask` (downward faces flatter than the
  critical angle, not counting faces on the build plate), for the whole part and
  for the textured surface alone when the input says which faces are texture;
* **thin features** (optional, ``nozzle``): texture features narrower than the nozzle,
  :func:`texcad.printability.thin_features`;
* optionally a **PNG** of the part in print orientation, overhang faces in red.

Which faces are texture: a :class:`~texcad.mesh.Mesh` with a ``"texture"`` group
(e.g. :func:`texcad.mesh.heightfield_slab`), or several named objects, e.g. a 3MF
written as ``write_3mf([("base", base), ("texture", slab)], path)``: objects whose
name starts with ``texture`` are texture. The objects are united with manifold3d,
which records for every output triangle the object it came from, so the texture's
share is the texture slab's exposed surface (its top and any border walls
standing above the base). Where the slab touches the base's own surface (its buried
border walls lie in the plane of the base's side walls, zero-height areas on the
base's top) the union may attribute the coincident faces to either object; faces of
the texture object that lie on a base triangle (within a few um) are counted as
base, so a base wall that overhangs is never reported as texture. An STL carries no
such information: whole-part numbers only.
"""

from __future__ import annotations

import json
import os
import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .errors import InputError, ParameterError
from .heightmap import Heightmap
from .mesh import Mesh, edge_report
from .printability import (
    DEFAULT_CRITICAL_ANGLE,
    ThinFeatures,
    _critical,
    _face_areas,
    build_directions,
    overhang_mask,
    thin_features,
)

__all__ = ["CheckReport", "check", "read_part", "parse_vector", "render_check"]

_RED = np.array([0.86, 0.12, 0.10])
_TEXTURE = np.array([0.83, 0.76, 0.62])
_BODY = np.array([0.70, 0.73, 0.78])


# ---------------------------------------------------------------------------------
# Reading
# ---------------------------------------------------------------------------------
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
        try:  # multi-part objects (texcad.export.write_3mf, PrusaSlicer): triangle ranges per part
            volumes = _slic3r_volumes(z.read("Metadata/Slic3r_PE_model.config"))
        except KeyError:
            volumes = {}
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
    :func:`texcad.export.write_3mf` and PrusaSlicer write) gives one mesh per part.

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


def parse_vector(text: str) -> np.ndarray:
    """``"X,Y,Z"`` (commas or spaces) to a ``(3,)`` float64 vector.

    Raises:
        ParameterError: not three finite numbers, or all zero.
    """
    parts = [p for p in re.split(r"[,\s]+", str(text).strip()) if p]
    try:
        v = np.array([float(p) for p in parts], dtype=np.float64)
    except ValueError:
        raise ParameterError(f"expected three numbers X,Y,Z (e.g. 0,-0.5,0.87), got {text!r}") from None
    if v.shape != (3,) or not np.isfinite(v).all() or not np.any(v):
        raise ParameterError(f"expected three numbers X,Y,Z, not all zero (e.g. 0,0,1), got {text!r}")
    return v


# ---------------------------------------------------------------------------------
# The report
# ---------------------------------------------------------------------------------
@dataclass
class CheckReport:
    """What :func:`check` measured. Units: mm, mm^2, mm^3, degrees.

    Attributes:
        source: file path or ``"<mesh>"``.
        objects: names of the objects read.
        watertight: every object is closed (each edge used twice, opposite ways).
        manifold: manifold3d accepts every object as a solid.
        shells: connected pieces of the whole part.
        volume_mm3: enclosed volume of the whole part.
        bounds_mm: ``[[xmin, ymin, zmin], [xmax, ymax, zmax]]``.
        triangles: triangles of the whole part.
        build_dir: unit build direction used.
        critical_angle_deg: critical overhang angle used.
        overhang_area_mm2: area of overhanging faces of the whole part.
        overhang_faces: how many faces overhang.
        texture_area_mm2: area of the textured surface (None if unknown).
        texture_overhang_area_mm2: overhang area on the textured surface alone
            (None if the input does not say which faces are texture).
        nozzle_mm: nozzle width checked (None if not asked).
        thin_features: :class:`~texcad.printability.ThinFeatures` as a dict, or None.
        png: picture written, if any.
        notes: remarks (e.g. why a number is missing).
    """

    source: str
    objects: list[str]
    watertight: bool
    manifold: bool
    shells: int
    volume_mm3: float
    bounds_mm: list[list[float]]
    triangles: int
    build_dir: list[float]
    critical_angle_deg: float
    overhang_area_mm2: float
    overhang_faces: int
    texture_area_mm2: float | None = None
    texture_overhang_area_mm2: float | None = None
    nozzle_mm: float | None = None
    thin_features: dict | None = None
    png: str | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Watertight, manifold, and no overhang on the textured surface (or the
        whole part, if the texture is unknown)."""
        over = self.texture_overhang_area_mm2 if self.texture_overhang_area_mm2 is not None else self.overhang_area_mm2
        return self.watertight and self.manifold and over == 0.0

    def to_dict(self) -> dict:
        """The report as plain JSON types."""
        return {
            "source": self.source,
            "objects": list(self.objects),
            "watertight": bool(self.watertight),
            "manifold": bool(self.manifold),
            "shells": int(self.shells),
            "volume_mm3": float(self.volume_mm3),
            "bounds_mm": [[float(x) for x in r] for r in self.bounds_mm],
            "triangles": int(self.triangles),
            "build_dir": [float(x) for x in self.build_dir],
            "critical_angle_deg": float(self.critical_angle_deg),
            "overhang_area_mm2": float(self.overhang_area_mm2),
            "overhang_faces": int(self.overhang_faces),
            "texture_area_mm2": None if self.texture_area_mm2 is None else float(self.texture_area_mm2),
            "texture_overhang_area_mm2": None
            if self.texture_overhang_area_mm2 is None
            else float(self.texture_overhang_area_mm2),
            "nozzle_mm": self.nozzle_mm,
            "thin_features": self.thin_features,
            "png": self.png,
            "notes": list(self.notes),
        }

    def to_json(self) -> str:
        """One JSON object (one line)."""
        return json.dumps(self.to_dict())

    def summary(self) -> str:
        """Human-readable lines for the terminal."""
        lo, hi = np.asarray(self.bounds_mm)
        size = hi - lo
        d = self.build_dir
        lines = [
            f"part          {self.source} ({len(self.objects)} object{'s' if len(self.objects) != 1 else ''}: {', '.join(self.objects)})",
            f"watertight    {'yes' if self.watertight else 'NO'}",
            f"manifold      {'yes' if self.manifold else 'NO'}",
            f"shells        {self.shells}",
            f"triangles     {self.triangles}",
            f"volume        {self.volume_mm3:.1f} mm3",
            f"bbox          ({lo[0]:.2f}, {lo[1]:.2f}, {lo[2]:.2f}) .. ({hi[0]:.2f}, {hi[1]:.2f}, {hi[2]:.2f}) mm, "
            f"size {size[0]:.2f} x {size[1]:.2f} x {size[2]:.2f} mm",
            f"build dir     ({d[0]:.4g}, {d[1]:.4g}, {d[2]:.4g}), critical angle {self.critical_angle_deg:g} deg",
            f"overhang      {self.overhang_area_mm2:.2f} mm2 whole part ({self.overhang_faces} faces)",
        ]
        if self.texture_overhang_area_mm2 is not None:
            lines.append(
                f"texture       {self.texture_overhang_area_mm2:.2f} mm2 overhang of {self.texture_area_mm2:.1f} mm2 textured surface"
            )
        if self.thin_features is not None:
            t = self.thin_features
            lines.append(
                f"thin features {t['thin_area_mm2']:.2f} mm2 ({100 * t['thin_fraction']:.1f} % of features) narrower than "
                f"the {t['nozzle_mm']:g} mm nozzle at {t['level_mm']:.2f} mm; narrow grooves {t['narrow_gap_area_mm2']:.2f} mm2"
            )
        if self.png:
            lines.append(f"picture       {self.png}")
        lines += [f"note          {n}" for n in self.notes]
        return "\n".join(lines)


# ---------------------------------------------------------------------------------
# Checking
# ---------------------------------------------------------------------------------
def _items(part: Any) -> tuple[str, list[tuple[str, Mesh]], Heightmap | None]:
    if isinstance(part, (str, os.PathLike)):
        return os.fspath(part), read_part(part), None
    if isinstance(part, Mesh):
        return "<mesh>", [("part", part)], None
    if hasattr(part, "texture") and hasattr(part, "base") and isinstance(getattr(part, "texture"), Mesh):
        return "<part>", [("base", part.base), ("texture", part.texture)], getattr(part, "heightmap", None)
    try:
        items = [(str(n), m) for n, m in part]
    except (TypeError, ValueError):
        items = []
    if not items or not all(isinstance(m, Mesh) for _, m in items):
        raise ParameterError(
            f"check() takes a .stl/.3mf path, a Mesh, a TexturedPart or a list of (name, Mesh); got {type(part).__name__}"
        )
    return "<meshes>", items, None


def _is_textured(part: Any) -> bool:
    """A :func:`texcad.texture` result (fused mesh plus base and texture meshes)."""
    if isinstance(part, (str, os.PathLike, Mesh, list, tuple)):
        return False
    return all(hasattr(type(part), a) for a in ("mesh", "texture_mesh", "base_mesh"))


def _is_texture(name: str) -> bool:
    return name.strip().lower().startswith("texture")


def _manifolds(meshes: list[Mesh]) -> tuple[list, np.ndarray]:
    """One ``manifold3d.Manifold`` per mesh (None where manifold3d refuses it: not a
    closed oriented 2-manifold, or empty), each tagged with a fresh original ID (its triangles' provenance
    in a union), and those IDs."""
    import manifold3d as m3d

    first = int(m3d.Manifold.reserve_ids(len(meshes)))
    ids = np.arange(first, first + len(meshes), dtype=np.int64)
    out = []
    for m, oid in zip(meshes, ids):  # per object
        if m.num_triangles == 0:
            out.append(None)
            continue
        try:
            man = m3d.Manifold(
                m3d.Mesh(
                    vert_properties=np.ascontiguousarray(m.vertices, dtype=np.float32),
                    tri_verts=np.ascontiguousarray(m.faces, dtype=np.uint32),
                    run_index=np.array([0, 3 * m.num_triangles], dtype=np.uint32),
                    run_original_id=np.array([oid], dtype=np.uint32),
                )
            )
        except Exception:  # noqa: BLE001 - any refusal means "not a manifold solid"
            man = None
        out.append(man if man is not None and man.status() == m3d.Error.NoError else None)
    return out, ids


def _union_with_provenance(mans: list, ids: np.ndarray):
    """Unite manifolds (from :func:`_manifolds`); returns (mesh, per-face object index)."""
    import manifold3d as m3d

    result = m3d.Manifold.batch_boolean(mans, m3d.OpType.Add)
    if result.status() != m3d.Error.NoError or result.is_empty():
        return None, None
    gl = result.to_mesh()
    mesh = Mesh(np.array(np.asarray(gl.vert_properties)[:, :3], dtype=np.float32), np.array(gl.tri_verts, dtype=np.uint32))
    mesh.__dict__["is_watertight"] = True  # manifold3d output is an oriented closed manifold
    run_index = np.asarray(gl.run_index, dtype=np.int64) // 3
    run_ids = np.asarray(gl.run_original_id, dtype=np.int64)
    owner_of_run = np.full(len(run_ids), -1, dtype=np.int64)
    for k, oid in enumerate(ids):  # per object
        owner_of_run[run_ids == oid] = k
    owner = np.repeat(owner_of_run, np.diff(run_index))
    return mesh, owner


def _on_surface(points: np.ndarray, meshes: Sequence[Mesh], tol: float | None = None) -> np.ndarray:
    """Which ``points`` ``(P, 3)`` (mm) lie on a triangle of ``meshes`` (within ``tol`` mm).

    Exact point-on-triangle tests (plane distance and barycentric coordinates) on
    candidate pairs found with one sort of the points per axis: each triangle is
    matched against the points inside its bounding box (grown by ``tol``), searched
    along the axis where that box is thinnest, so a wall or a flat face only meets
    the points near its plane. Work is chunked to a few million pairs at a time.

    Returns:
        ``(P,)`` bool.
    """
    pts = np.asarray(points, dtype=np.float64)
    out = np.zeros(len(pts), dtype=bool)
    tris = [m.vertices.astype(np.float64)[m.faces.astype(np.int64)] for m in meshes if m.num_triangles]
    if not len(pts) or not tris:
        return out
    tri = np.concatenate(tris)
    if tol is None:
        span = np.ptp(np.concatenate([tri.reshape(-1, 3), pts]), axis=0)
        tol = max(1e-5, 2e-6 * float(np.linalg.norm(span)))
    a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    n = np.cross(e1, e2)
    ln = np.linalg.norm(n, axis=1)
    keep = ln > 1e-12
    a, e1, e2, n, ln = a[keep], e1[keep], e2[keep], n[keep] / ln[keep, None], ln[keep]
    lo = np.minimum(a, np.minimum(a + e1, a + e2)) - tol
    hi = np.maximum(a, np.maximum(a + e1, a + e2)) + tol
    thin = np.argmin(hi - lo, axis=1)
    d00, d01, d11 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    den = d00 * d11 - d01 * d01
    budget = 4_000_000
    for ax in range(3):  # per axis
        tsel = np.flatnonzero(thin == ax)
        if not len(tsel):
            continue
        order = np.argsort(pts[:, ax], kind="stable")
        sv = pts[order, ax]
        start = np.searchsorted(sv, lo[tsel, ax], side="left")
        count = np.searchsorted(sv, hi[tsel, ax], side="right") - start
        csum = np.cumsum(count)
        first = 0
        while first < len(tsel):  # per chunk of a few million pairs
            base = csum[first - 1] if first else 0
            last = max(first + 1, int(np.searchsorted(csum, base + budget, side="right")))
            last = min(last, len(tsel))
            cnt = count[first:last]
            total = int(cnt.sum())
            if total:
                t = np.repeat(tsel[first:last], cnt)
                offs = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
                p = order[np.repeat(start[first:last], cnt) + offs]
                q = pts[p]
                inbox = np.all((q >= lo[t]) & (q <= hi[t]), axis=1)
                t, p, q = t[inbox], p[inbox], q[inbox]
                w = q - a[t]
                near = np.abs((w * n[t]).sum(1)) <= tol
                t, p, w = t[near], p[near], w[near]
                d20, d21 = (w * e1[t]).sum(1), (w * e2[t]).sum(1)
                v = (d11[t] * d20 - d01[t] * d21) / den[t]
                u = (d00[t] * d21 - d01[t] * d20) / den[t]
                eps = tol / np.sqrt(np.maximum(d00[t], d11[t]))  # tol in mm, as a fraction
                inside = (v >= -eps) & (u >= -eps) & (u + v <= 1.0 + eps)
                out[p[inside]] = True
            first = last
    return out


def _shared_faces(mesh: Mesh, *others: Mesh) -> list[np.ndarray]:
    """For each of ``others``, ``(M,)`` bool: which faces of ``mesh`` are also its faces
    (the same three vertex positions, bit for bit, in any order). Sorting, no geometry."""
    meshes = (mesh, *others)
    verts = np.concatenate([m.vertices for m in meshes]).astype(np.float32) + np.float32(0.0)  # -0.0 -> 0.0
    _, vid = np.unique(np.ascontiguousarray(verts).view(np.dtype((np.void, 12))).ravel(), return_inverse=True)
    offsets = np.cumsum([0] + [len(m.vertices) for m in meshes])
    keys = [np.sort(vid[m.faces.astype(np.int64) + off], axis=1) for m, off in zip(meshes, offsets)]
    _, fid = np.unique(np.concatenate(keys), axis=0, return_inverse=True)
    bounds = np.cumsum([0] + [len(k) for k in keys])
    fid = fid.ravel()
    own = fid[: bounds[1]]
    return [np.isin(own, fid[lo:hi]) for lo, hi in zip(bounds[1:-1], bounds[2:])]


def _texture_faces(fused: Mesh, texture: Mesh, base: Mesh) -> np.ndarray:
    """``(M,)`` bool: the faces of a fused part that belong to its texture.

    A face shared with the texture mesh and not with the base mesh is texture; the
    few faces the union re-triangulated (along the contact) are decided by where
    they lie: on the texture's surface and not on the base's.
    """
    on_tex, on_base = _shared_faces(fused, texture, base)
    mask = on_tex & ~on_base
    rest = np.flatnonzero(~on_tex & ~on_base)
    if len(rest):
        cen = fused.vertices[fused.faces[rest]].astype(np.float64).mean(axis=1)
        mask[rest] = _on_surface(cen, [texture]) & ~_on_surface(cen, [base])
    return mask


def _shells(mesh: Mesh) -> int:
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = mesh.faces.astype(np.int64)
    if len(f) == 0:
        return 0
    n = len(mesh.vertices)
    i = np.concatenate([f[:, 0], f[:, 1]])
    j = np.concatenate([f[:, 1], f[:, 2]])
    g = coo_matrix((np.ones(len(i), dtype=np.int8), (i, j)), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    return int(np.count_nonzero(np.bincount(lab[f[:, 0]])))  # components that own a face


def check(
    part: Any,
    *,
    build_dir=(0.0, 0.0, 1.0),
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    nozzle: float | None = None,
    heightmap: Heightmap | None = None,
    png: str | os.PathLike | None = None,
    plate_tolerance: float = 0.01,
    png_width: int = 900,
) -> CheckReport:
    """Check a part for printing (module docstring lists what is measured).

    Args:
        part: ``.stl`` / ``.3mf`` path, a :class:`~texcad.mesh.Mesh` (its
            ``"texture"`` group, if any, is the textured surface), a
            :class:`~texcad.pipeline.TexturedPart` (base and texture slab), a
            :func:`texcad.texture` result (its fused mesh; texture faces found on its
            texture mesh), or a list of ``(name, Mesh)`` (names starting with
            ``texture`` are texture).
        build_dir: build direction ``(x, y, z)`` in the part's frame (any length;
            default +z, the part as placed); see :func:`texcad.printability.orientation`.
        critical_angle: critical overhang angle in degrees between face and build
            plate (0..90, default 45; paper, section 2.1.3).
        nozzle: nozzle width in mm to look for thin texture features (None: skip).
            Uses ``heightmap`` if given, else the texture faces rasterised along
            their mean normal (flat textures), else nothing (noted).
        heightmap: the texture's heightmap, for the thin-feature check.
        png: write a picture (print orientation, seen from above and from below;
            overhangs red, texture sand, rest grey).
        plate_tolerance: mm; faces this close to the lowest point along the build
            direction lie on the build plate and are not overhangs.
        png_width: width of the picture in pixels.

    Returns:
        :class:`CheckReport`.

    Raises:
        InputError: unreadable file.
        ParameterError: bad direction, angle or nozzle.
    """
    d = build_directions(build_dir)[0]
    crit = _critical(critical_angle)
    if nozzle is not None and not (np.isfinite(float(nozzle)) and float(nozzle) > 0):
        raise ParameterError(f"nozzle must be a positive width in mm (e.g. 0.4), got {nozzle!r}")
    textured_part = _is_textured(part)
    if textured_part:
        # A texture() result: check the fused mesh it prints from. Its texture faces
        # are those on the texture's surface and not on the base's (re-uniting the two
        # touching bodies would only add rounding slivers along their contact).
        source, items, hm_from_part = "<textured part>", [("part", part.mesh)], part.heightmap
    else:
        source, items, hm_from_part = _items(part)
    heightmap = heightmap if heightmap is not None else hm_from_part
    notes: list[str] = []
    mans, ids = _manifolds([m for _, m in items])
    manif = [man is not None for man in mans]
    # manifold3d accepts only closed, consistently oriented 2-manifolds (every edge
    # shared by exactly two faces, opposite ways): those are watertight; the others
    # are counted edge by edge.
    water = [ok or bool(edge_report(m.faces)["watertight"]) for ok, (_, m) in zip(manif, items)]
    texture_mask: np.ndarray | None = None
    if textured_part:
        mesh = items[0][1]
        texture_mask = _texture_faces(mesh, part.texture_mesh, part.base_mesh)
    elif len(items) == 1:
        mesh = items[0][1]
        if "texture" in mesh.groups:
            texture_mask = np.zeros(mesh.num_triangles, dtype=bool)
            texture_mask[np.asarray(mesh.groups["texture"], dtype=np.int64)] = True
        elif _is_texture(items[0][0]):
            texture_mask = np.ones(mesh.num_triangles, dtype=bool)
    else:
        mesh, owner = (None, None)
        if all(manif):
            mesh, owner = _union_with_provenance(mans, ids)
        if mesh is None:
            notes.append("objects could not be united; whole-part numbers are for the objects side by side")
            mesh = Mesh(
                np.concatenate([m.vertices for _, m in items]),
                np.concatenate([m.faces.astype(np.int64) + off for (_, m), off in zip(items, np.cumsum([0] + [len(m.vertices) for _, m in items[:-1]]))]),
            )
            owner = np.repeat(np.arange(len(items)), [m.num_triangles for _, m in items])
        tex_objects = [k for k, (n, _) in enumerate(items) if _is_texture(n)]
        if tex_objects:
            texture_mask = np.isin(owner, tex_objects)
            others = [m for k, (_, m) in enumerate(items) if k not in tex_objects]
            if others and texture_mask.any():
                # Where the slab's buried walls (or zero-height areas) coincide with the
                # base's own surface, the union attributes the coplanar faces to either
                # object; they belong to the base (e.g. its end walls), not the texture.
                idx = np.flatnonzero(texture_mask)
                cen = mesh.vertices[mesh.faces[idx]].astype(np.float64).mean(axis=1)
                texture_mask[idx[_on_surface(cen, others)]] = False
    if texture_mask is None:
        notes.append("the input does not say which faces are texture (use a texcad 3MF with a 'texture' object); whole-part numbers only")
    over = overhang_mask(mesh, d, crit, plate_tolerance=plate_tolerance)
    area = _face_areas(mesh)
    lo, hi = mesh.bounds
    rep = CheckReport(
        source=source,
        objects=[n for n, _ in items],
        watertight=all(water),
        manifold=all(manif),
        shells=_shells(mesh),
        volume_mm3=float(mesh.volume),
        bounds_mm=[lo.tolist(), hi.tolist()],
        triangles=mesh.num_triangles,
        build_dir=d.tolist(),
        critical_angle_deg=crit,
        overhang_area_mm2=float(area[over].sum()),
        overhang_faces=int(over.sum()),
        notes=notes,
    )
    if texture_mask is not None:
        rep.texture_area_mm2 = float(area[texture_mask].sum())
        rep.texture_overhang_area_mm2 = float(area[over & texture_mask].sum())
    if nozzle is not None:
        rep.nozzle_mm = float(nozzle)
        tf = _thin(mesh, texture_mask, heightmap, float(nozzle), notes)
        rep.thin_features = None if tf is None else tf.to_dict()
    if png is not None:
        render_check(mesh, d, over, texture_mask, png, width=png_width)
        rep.png = os.fspath(png)
    return rep


def _thin(mesh: Mesh, texture_mask, heightmap, nozzle: float, notes: list[str]) -> ThinFeatures | None:
    if heightmap is not None:
        return thin_features(heightmap, nozzle)
    if texture_mask is None or not texture_mask.any():
        notes.append("thin features need the texture: pass its heightmap or a 3MF with a 'texture' object")
        return None
    from .printability import _unit_normals
    from .raster import height_image

    idx = np.flatnonzero(texture_mask)
    n = (_unit_normals(mesh)[idx] * _face_areas(mesh)[idx, None]).sum(axis=0)
    if not np.linalg.norm(n) > 0:
        notes.append("thin features: the texture has no dominant direction; skipped")
        return None
    n /= np.linalg.norm(n)
    heights, mask, pitch = height_image(mesh, n, nozzle / 4.0, faces=idx)
    if mask.sum() < 4 or heights.shape[0] < 2 or heights.shape[1] < 2:
        notes.append("thin features: texture too small to measure")
        return None
    notes.append(
        "thin features measured on the texture seen along its mean normal (exact for flat textures, "
        "widths foreshortened on curved ones)"
    )
    return thin_features(Heightmap(heights.astype(np.float32), (pitch, pitch)), nozzle, mask=mask)


def render_check(
    mesh: Mesh,
    build_dir,
    overhang: np.ndarray,
    texture_mask: np.ndarray | None,
    path: str | os.PathLike,
    *,
    width: int = 900,
) -> np.ndarray:
    """Picture of a part in print orientation: from above (left) and below (right).

    The build direction points up in both views (elevation +30 and -30 degrees);
    overhang faces are red, texture faces sand, other faces grey.

    Returns:
        The ``(H, W, 3)`` image written (y-up).
    """
    from .raster import render_mesh, write_png

    d = build_directions(build_dir)[0]
    cols = np.tile(_BODY, (mesh.num_triangles, 1))
    if texture_mask is not None:
        cols[texture_mask] = _TEXTURE
    cols[overhang] = _RED
    # Horizontal reference: the part's y axis (or x) seen from 35 degrees aside.
    ref = np.array([0.0, -1.0, 0.0]) if abs(d[1]) < 0.95 else np.array([-1.0, 0.0, 0.0])
    h = ref - (ref @ d) * d
    h /= np.linalg.norm(h)
    side = np.cross(d, h)
    az, el = np.radians(35.0), np.radians(30.0)
    hz = np.cos(az) * h + np.sin(az) * side
    half = max(1, width // 2)
    panels = []
    for sign in (1.0, -1.0):  # from above, from below
        eye = np.cos(el) * hz + sign * np.sin(el) * d
        panels.append(render_mesh(mesh, face_colors=cols, view=-eye, up=d, width=half, height=int(half * 0.8), supersample=2))
    img = np.concatenate(panels, axis=1)
    write_png(path, img)
    return img
