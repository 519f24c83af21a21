"""Slicer paint: PrusaSlicer's / OrcaSlicer's / BambuStudio's per-triangle paint
strings (``TriangleSelector``), decoded to sub-triangles and encoded back.

A slicer stores the paint of one mesh triangle as a subdivision tree written as a
hexadecimal string (PrusaSlicer ``src/libslic3r/TriangleSelector.cpp``,
``serialize``/``deserialize``; ``Model.cpp``, ``get_triangle_as_string``):

* the string is read **backwards**: its last character is the first nibble, and
  bit ``i`` of a hex digit is bit ``i`` of that nibble;
* each node of the tree, in pre-order, is one nibble: its two low bits are the number
  of split sides ``k`` (0: a leaf); a split node's two high bits are its *special
  side* ``s`` and its ``k + 1`` children follow, **last child first**; a leaf's two
  high bits are its state ``0..2``, or ``0b11``, and then the next nibble ``n`` gives
  the state ``3 + n`` (OrcaSlicer / BambuStudio: ``n = 15`` is followed by one more
  nibble ``m``, state ``18 + m``);
* a split node with corners ``(v_s, v_s+1, v_s+2)`` renamed ``(a, b, c)`` has children
  (``TriangleSelector::perform_split``): ``k = 1``: ``(a, b, m_bc)``, ``(m_bc, c, a)``;
  ``k = 2``: ``(a, m_ab, m_ca)``, ``(m_ab, b, m_ca)``, ``(b, c, m_ca)``; ``k = 3``:
  ``(a, m_ab, m_ca)``, ``(m_ab, b, m_bc)``, ``(m_bc, c, m_ca)``, ``(m_ab, m_bc, m_ca)``
  (``m`` the edge midpoints).

States: multi-material paint (``slic3rpe:mmu_segmentation``, BambuStudio's
``paint_color``): state ``n`` is extruder / filament ``n`` (0: the object's own);
paint-on supports (``slic3rpe:custom_supports``, ``paint_supports``) and seams
(``slic3rpe:custom_seam``, ``paint_seam``): 1 enforce, 2 block; fuzzy skin
(PrusaSlicer 2.9 ``slic3rpe:fuzzy_skin``, OrcaSlicer ``paint_fuzzy_skin``): 1.

:func:`decode` parses many strings at once with numpy: the nibbles of all strings in
one array, the tree's shape from a running sum (a subtree ends where the count of
open child slots first drops below its start's), then one vectorized step per tree
depth places the children. Corners are barycentric, exact (dyadic fractions).
"""

from __future__ import annotations

import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ..errors import InputError, ParameterError

__all__ = ["PAINT_KINDS", "ATTRIBUTES", "Painted", "decode", "encode_states", "paint_by_points", "tree_string", "Project", "read_project", "split_painted", "write_painted_3mf", "write_zones"]

#: What each kind of paint is called in a project's ``<triangle>`` attributes
#: (PrusaSlicer first, then BambuStudio / OrcaSlicer).
ATTRIBUTES = {
    "color": ("slic3rpe:mmu_segmentation", "paint_color"),
    "support": ("slic3rpe:custom_supports", "paint_supports"),
    "seam": ("slic3rpe:custom_seam", "paint_seam"),
    "fuzzy": ("slic3rpe:fuzzy_skin", "paint_fuzzy_skin"),
}
PAINT_KINDS = tuple(ATTRIBUTES)

# Children of a split node as corners among (a, b, c, m_ab, m_bc, m_ca), by the number
# of split sides k and the child's index (TriangleSelector::perform_split).
_CHILDREN = {
    1: ((0, 1, 4), (4, 2, 0)),
    2: ((0, 3, 5), (3, 1, 5), (1, 2, 5)),
    3: ((0, 3, 5), (3, 1, 4), (4, 2, 5), (3, 4, 5)),
}
_TABLE = np.zeros((4, 4, 3), dtype=np.int64)
for _k, _ch in _CHILDREN.items():
    _TABLE[_k, : len(_ch)] = _ch
_HEX = np.full(256, 255, dtype=np.uint8)
for _i, _c in enumerate(b"0123456789ABCDEF"):
    _HEX[_c] = _i
    _HEX[ord(chr(_c).lower())] = _i


@dataclass(frozen=True)
class Painted:
    """Decoded paint: every leaf of every tree (painted or not).

    Attributes:
        triangle: ``(L,)`` int64, the index (into the strings given) each leaf lies in.
        corners: ``(L, 3, 3)`` float64, barycentric coordinates of each leaf's corners
            (row ``j``: the weights of the triangle's vertices 1, 2, 3), in the
            triangle's orientation.
        state: ``(L,)`` int64, the leaf's state (0 = unpainted).
        depth: ``(L,)`` int64, how many splits lie above the leaf (0: whole triangle).
    """

    triangle: np.ndarray
    corners: np.ndarray
    state: np.ndarray
    depth: np.ndarray

    def points(self, tri: np.ndarray) -> np.ndarray:
        """``(L, 3, 3)`` the leaves' corners in space, from each triangle's corners
        ``tri`` ``(T, 3, 3)`` (mm, any frame)."""
        return np.einsum("lij,ljk->lik", self.corners, np.asarray(tri, np.float64)[self.triangle])


def _nibbles(strings: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """All strings' nibbles in reading order (each string reversed) and each string's
    start; InputError on a character that is not a hex digit."""
    lens = np.fromiter((len(s) for s in strings), dtype=np.int64, count=len(strings))
    raw = np.frombuffer("".join(s[::-1] for s in strings).encode("ascii", "replace"), dtype=np.uint8)
    nib = _HEX[raw]
    if (nib == 255).any():
        k = int(np.searchsorted(np.cumsum(lens), int(np.argmax(nib == 255)), side="right"))
        raise InputError(f"paint string {k} ({strings[k][:40]!r}) holds a character that is not a hex digit; the file is damaged")
    starts = np.concatenate([[0], np.cumsum(lens)[:-1]]) if len(lens) else lens
    return nib.astype(np.int64), starts


def _roles(nib: np.ndarray, first: np.ndarray) -> np.ndarray:
    """Per nibble: 0 a node, 1 the state nibble after a ``0b1100`` leaf, 2 the third
    nibble after a state nibble 15 (OrcaSlicer). A nibble after one that is neither
    ``0xC`` nor ``0xF`` (or a string's first) is a node whatever came before, so only
    runs of those need the pass per position (vectorized over all runs; a few passes)."""
    n = len(nib)
    role = np.zeros(n, dtype=np.int8)
    prev = np.r_[0, nib[:-1]]
    sync = first | ((prev != 12) & (prev != 15))
    last = np.maximum.accumulate(np.where(sync, np.arange(n), 0))
    off = np.arange(n) - last
    for k in range(1, int(off.max(initial=0)) + 1):  # per position in the runs
        i = np.flatnonzero(off == k)
        p = role[i - 1]
        role[i] = np.where((p == 0) & (nib[i - 1] == 12), 1, np.where((p == 1) & (nib[i - 1] == 15), 2, 0))
    return role


def decode(strings: Sequence[str]) -> Painted:
    """Decode paint strings (module docstring) into their leaves: sub-triangles as
    barycentric corners and states. An empty string is one unpainted leaf.

    Raises:
        InputError: a string that is not hex, ends inside a node, holds a special side
            3, or whose tree ends before or after its last character (damaged).
    """
    strings = [s or "0" for s in strings]
    nib, starts = _nibbles(strings)
    first = np.zeros(len(nib), dtype=bool)
    first[starts] = True
    role = _roles(nib, first)
    owner = np.cumsum(first) - 1  # string of each nibble
    tok = np.flatnonzero(role == 0)
    code, own = nib[tok], owner[tok]
    nxt1 = np.minimum(tok + 1, len(nib) - 1)
    nxt2 = np.minimum(tok + 2, len(nib) - 1)
    sides = code & 3
    leaf = sides == 0
    ext = leaf & (code == 12)
    ok1 = (tok + 1 < len(nib)) & (owner[nxt1] == own) & (role[nxt1] == 1)
    long = ext & ok1 & (nib[nxt1] == 15)
    ok2 = (tok + 2 < len(nib)) & (owner[nxt2] == own) & (role[nxt2] == 2)
    bad = (ext & ~ok1) | (long & ~ok2) | (~leaf & (code >> 2 == 3))
    state = np.where(long, 18 + nib[nxt2], np.where(ext, 3 + nib[nxt1], code >> 2))
    state = np.where(leaf, state, -1)
    # the tree's shape: w = open child slots added (k for a split node, -1 a leaf)
    w = np.where(leaf, -1, sides)
    s = np.cumsum(w)
    before = s - w
    # end of the subtree at t: the first t' >= t with s[t'] == before[t] - 1 (s falls by
    # one at a time), found by one search in the nodes sorted by (s, position)
    big = np.int64(len(s) + 1)
    comb = np.sort((s - s.min(initial=0) + 1) * big + np.arange(len(s)))
    q = (before - 1 - s.min(initial=0) + 1) * big + np.arange(len(s))
    pos = np.minimum(np.searchsorted(comb, q), max(len(comb) - 1, 0))
    hit = comb[pos] // big == (before - 1 - s.min(initial=0) + 1) if len(s) else np.zeros(0, dtype=bool)
    end = np.where(hit, comb[pos] % big, -1) if len(s) else np.zeros(0, dtype=np.int64)
    tstart = np.searchsorted(own, np.arange(len(strings)))  # each string's root node
    tlast = np.r_[tstart[1:], len(tok)] - 1
    good = (tlast >= tstart) & (end[np.minimum(tstart, len(tok) - 1)] == tlast)
    badstr = np.zeros(len(strings), dtype=bool)
    np.logical_or.at(badstr, own, bad)
    badstr |= ~good
    if badstr.any():
        k = int(np.argmax(badstr))
        raise InputError(f"paint string {k} ({strings[k][:40]!r}) is damaged (its subdivision tree is incomplete or "
                         "malformed); paint that triangle again in the slicer and save the project")
    return _place(tstart, code, sides, state, end, len(strings))


def _place(tstart, code, sides, state, end, n):
    """Walk the trees one depth at a time (all nodes of a depth at once) and collect
    the leaves with their barycentric corners."""
    node = tstart
    tri = np.arange(n)
    corners = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    out_t, out_c, out_s, out_d = [], [], [], []
    depth = 0
    while len(node):  # per tree depth
        lf = sides[node] == 0
        out_t.append(tri[lf]), out_c.append(corners[lf]), out_s.append(state[node[lf]]), out_d.append(np.full(int(lf.sum()), depth))
        sp = np.flatnonzero(~lf)
        node, tri, corners = node[sp], tri[sp], corners[sp]
        k, spec = sides[node], code[node] >> 2
        rot = (spec[:, None] + np.arange(3)) % 3
        abc = np.take_along_axis(corners, rot[:, :, None], axis=1)
        six = np.concatenate([abc, 0.5 * (abc + abc[:, [1, 2, 0]])], axis=1)  # a, b, c, m_ab, m_bc, m_ca
        kids, kt, kc = [], [], []
        slot = node + 1
        for t in range(4):  # serialized slot t holds child k - t (children last first)
            has = t <= k
            idx = np.flatnonzero(has)
            child = k[idx] - t
            kids.append(slot[idx])
            kt.append(tri[idx])
            kc.append(np.take_along_axis(six[idx], _TABLE[k[idx], child][:, :, None], axis=1))
            slot = np.where(has, end[np.minimum(slot, len(end) - 1)] + 1, slot)
        node, tri, corners = np.concatenate(kids), np.concatenate(kt), np.concatenate(kc)
        depth += 1
    return Painted(np.concatenate(out_t), np.concatenate(out_c), np.concatenate(out_s).astype(np.int64), np.concatenate(out_d))


def _code_nibbles(state: int) -> list[int]:
    """A leaf's nibbles in reading order."""
    if not 0 <= state <= 33:
        raise ParameterError(f"a paint state is 0..33 (PrusaSlicer: 0..16), got {state!r}")
    if state < 3:
        return [state << 2]
    if state < 18:
        return [12, state - 3]
    return [12, 15, state - 18]


def _string(nibbles: list[int]) -> str:
    return "".join("0123456789ABCDEF"[n] for n in reversed(nibbles))


def encode_states(states: Sequence[int]) -> list[str]:
    """Whole-triangle paint strings (``""`` for state 0), e.g. ``[1, 2, 3] ->
    ["4", "8", "0C"]``."""
    table = {}
    out = []
    for s in np.asarray(states, dtype=np.int64).tolist():  # per triangle (a table look-up)
        if s not in table:
            table[s] = "" if s == 0 else _string(_code_nibbles(s))
        out.append(table[s])
    return out


def tree_string(tree: Any) -> str:
    """One triangle's paint string from a nested tree: a leaf is its state (int), a
    split node ``(sides, special_side, [children in PrusaSlicer's child order])`` with
    ``sides`` 1..3 and ``len(children) == sides + 1`` (special side 0 for 3 sides)."""
    out: list[int] = []

    def walk(t: Any) -> None:
        if isinstance(t, (int, np.integer)):
            out.extend(_code_nibbles(int(t)))
            return
        k, s, kids = t
        if k not in (1, 2, 3) or s not in (0, 1, 2) or len(kids) != k + 1:
            raise ParameterError(f"a split node is (sides 1..3, special side 0..2, sides + 1 children), got {t!r}")
        out.append(k | s << 2)
        for c in reversed(kids):  # serialized last child first (PrusaSlicer 2.3.1 order)
            walk(c)

    walk(tree)
    return "" if out == [0] else _string(out)


def paint_by_points(tri: np.ndarray, state_at: Callable[[np.ndarray], np.ndarray], depth: int) -> list[str]:
    """Paint strings for triangles ``tri`` ``(T, 3, 3)`` (mm): each split ``depth``
    levels deep (3-side splits: each level halves the edges), the finest
    sub-triangles taking ``state_at(centroids (P, 3) mm) -> (P,) int``, and every
    sub-tree of one state merged into one leaf (what a slicer's brush leaves).

    Vectorized: all triangles' nodes of one level at once; the nodes are put in the
    slicer's pre-order by one sort of their child paths.
    """
    tri = np.asarray(tri, np.float64)
    n, depth = len(tri), int(depth)
    if not 0 <= depth <= 12:
        raise ParameterError(f"paint depth must be 0..12 levels, got {depth!r}")
    box = np.eye(3)[None]  # the same for every triangle: barycentric, in child order
    for _ in range(depth):  # per level from the root: every node into its 4 children
        six = np.concatenate([box, 0.5 * (box + box[:, [1, 2, 0]])], axis=1)
        box = np.stack([six[:, _TABLE[3, j]] for j in range(4)], axis=1).reshape(-1, 3, 3)
    cen = box.mean(axis=1)[None] @ tri  # (T, 4**depth, 3) mm
    st = np.asarray(state_at(cen.reshape(-1, 3)), dtype=np.int64).reshape(n, -1)
    states, uniform = [st], [np.ones_like(st, dtype=bool)]
    for _ in range(depth):  # bottom up: a node is uniform when its 4 children are, with one state
        q, u = states[-1].reshape(n, -1, 4), uniform[-1].reshape(n, -1, 4)
        states.append(q[:, :, 0])
        uniform.append(u.all(axis=2) & (q == q[:, :, :1]).all(axis=2))
    states, uniform = states[::-1], uniform[::-1]  # index = level from the root
    tris, keys, nibs, cnts = [], [], [], []
    alive = np.ones((n, 1), dtype=bool)  # the node exists: its parent was split
    for lev in range(depth + 1):  # per level from the root
        leaf = alive & (uniform[lev] | (lev == depth))
        split = alive & ~leaf
        for mask, is_leaf in ((leaf, True), (split, False)):
            ti, ni = np.nonzero(mask)
            tris.append(ti)
            keys.append(_preorder_key(ni, lev, depth))
            code = _leaf_codes(states[lev][ti, ni]) if is_leaf else np.tile([3, -1, -1], (len(ti), 1))
            nibs.append(code)
        alive = np.repeat(split, 4, axis=1)
    t, key, code = np.concatenate(tris), np.concatenate(keys), np.concatenate(nibs)
    order = np.lexsort((key, t))
    t, code = t[order], code[order]
    whole = np.bincount(t, minlength=n) == 1  # a triangle that is one leaf
    zero = whole & (np.bincount(t, weights=(code[:, 0] == 0), minlength=n) == 1)
    flat = code.ravel()
    keep = flat >= 0
    chars = np.frombuffer(b"0123456789ABCDEF", dtype=np.uint8)[flat[keep]][::-1].tobytes().decode()
    lens = np.bincount(np.repeat(t, 3)[keep], minlength=n)[::-1]
    ends = np.cumsum(lens)
    out = [chars[e - ln : e] for e, ln in zip(ends.tolist(), lens.tolist())][::-1]  # per triangle: a slice
    return ["" if z else s for s, z in zip(out, zero.tolist())]


def _preorder_key(ni: np.ndarray, lev: int, depth: int) -> np.ndarray:
    """Sort key of node ``ni`` (index among its level's ``4**lev`` nodes, child digits
    base 4) in the slicer's pre-order: children serialized last first, a node before
    its descendants (digits ``4 - child`` in 1..4, 0 below the node's level)."""
    key = np.zeros(len(ni), dtype=np.int64)
    for m in range(lev):  # per level above: the child digit
        c = (ni // 4 ** (lev - 1 - m)) % 4
        key = key * 5 + (4 - c)
    return key * 5 ** (depth - lev)


def _leaf_codes(state: np.ndarray) -> np.ndarray:
    """``(L, 3)`` nibbles of leaves (reading order, -1 unused)."""
    s = np.asarray(state, dtype=np.int64)
    if len(s) and (s.min() < 0 or s.max() > 33):
        raise ParameterError(f"a paint state is 0..33 (PrusaSlicer: 0..16), got {int(s.min() if s.min() < 0 else s.max())}")
    out = np.full((len(s), 3), -1, dtype=np.int64)
    out[:, 0] = np.where(s < 3, s << 2, 12)
    out[:, 1] = np.where(s < 3, -1, np.where(s < 18, s - 3, 15))
    out[:, 2] = np.where(s < 18, -1, s - 18)
    return out


# --- projects: PrusaSlicer / OrcaSlicer (one model part) and BambuStudio (object files) ---

_UNITS = {"micron": 0.001, "millimeter": 1.0, "centimeter": 10.0, "inch": 25.4, "foot": 304.8, "meter": 1000.0}
_TRI = re.compile(rb"<(?:\w+:)?triangle\b([^>]*?)/?>")
_V123 = re.compile(rb'^\s*v1="(\d+)"\s+v2="(\d+)"\s+v3="(\d+)"')
_VERT = re.compile(rb'<(?:\w+:)?vertex\s+x="([^"]*)"\s+y="([^"]*)"\s+z="([^"]*)"')
_ATTR = re.compile(rb'([\w:]+)\s*=\s*"([^"]*)"')
_OBJECT = re.compile(rb"<(?:\w+:)?object\b([^>]*)>(.*?)</(?:\w+:)?object>", re.S)
_COMPONENT = re.compile(rb"<(?:\w+:)?component\b([^>]*?)/?>")
_ITEM = re.compile(rb"<(?:\w+:)?item\b([^>]*?)/?>")


@dataclass(frozen=True)
class Project:
    """A slicer project's meshes with their paint, placed as the build places them.

    Attributes:
        vertices: ``(N, 3)`` float64, mm, in the build's frame (item, component and
            unit transforms applied).
        faces: ``(M, 3)`` int64 (one triangle per ``<triangle>`` read, in file order).
        paint: ``{kind: list of M strings}`` for each kind in :data:`ATTRIBUTES` the
            file holds (``""``: not painted).
        parts: ``(build item index, object name, part name, first face, end face)``
            per mesh placed.
        items: ``(object id, 4x4 transform)`` per build item (row-vector convention:
            ``x' = x @ T[:3, :3] + T[3, :3]``).
        dialect: ``"prusa"`` (``slic3rpe:`` attributes) or ``"bambu"`` (``paint_*``),
            ``""`` without paint.
        path: the file read.
        negatives: ``(build item index, vertices (n, 3) mm, faces (m, 3))`` per
            negative volume (PrusaSlicer) or negative part (BambuStudio), in the
            build's frame: what the slicer cuts out of that item's object.
    """

    vertices: np.ndarray
    faces: np.ndarray
    paint: dict
    parts: tuple
    dialect: str
    path: str
    items: tuple = ()
    negatives: tuple = ()

    def states(self, kind: str = "color") -> list[int]:
        """The painted states of ``kind`` (sorted, 0 left out)."""
        if kind not in self.paint:
            return []
        s = [x for x in self.paint[kind] if x]
        return sorted(int(v) for v in np.unique(decode(s).state) if v) if s else []


def _attrs(blob: bytes) -> dict:
    return {k.decode(): v.decode("utf-8", "replace") for k, v in _ATTR.findall(blob)}


def _matrix(text: "str | None") -> np.ndarray:
    m = np.eye(4)
    if text:
        v = np.array(text.split(), dtype=np.float64)
        if v.size != 12:
            raise InputError(f"3MF transform must have 12 numbers, got {text!r}")
        m[:3, :3], m[3, :3] = v[:9].reshape(3, 3), v[9:]
    return m


def _model_objects(xml: bytes, where: str) -> dict:
    """``{id: {"name", "mesh": (v, f, paint), "components": [(path, id, 4x4)]}}`` of a
    model part (the regex reads the layout slicers write: ``x y z`` and ``v1 v2 v3``
    first)."""
    out = {}
    for head, body in _OBJECT.findall(xml):  # per object
        a = _attrs(head)
        entry = {"name": a.get("name", f"object {a.get('id')}"), "components": [], "mesh": None}
        if b"<mesh" in body or b":mesh" in body:
            v = np.array(_VERT.findall(body), dtype=np.float64).reshape(-1, 3)
            tris = _TRI.findall(body)
            idx = [_V123.match(t) for t in tris]
            if any(m is None for m in idx):
                raise InputError(f"{where}: a <triangle> of object {a.get('id')} lacks v1, v2, v3; export the project again")
            f = np.array([m.groups() for m in idx], dtype=np.int64).reshape(-1, 3)
            if len(f) and (f.min() < 0 or f.max() >= len(v)):
                raise InputError(f"{where}: object {a.get('id')} has a triangle that refers to a missing vertex")
            paint = {}
            for kind, names in ATTRIBUTES.items():  # per kind of paint
                for name in names:
                    key = name.encode() + b'="'
                    if key in body:
                        pat = re.compile(re.escape(name.encode()) + rb'="([^"]*)"')
                        paint[kind] = [(m.group(1).decode() if (m := pat.search(t)) else "") for t in tris]
                        paint.setdefault("_dialect", "prusa" if name.startswith("slic3rpe:") else "bambu")
            entry["mesh"] = (v, f, paint)
        for c in _COMPONENT.findall(body):  # per component
            ca = _attrs(c)
            path = next((val for k, val in ca.items() if k.endswith("path")), None)
            entry["components"].append((path, ca.get("objectid"), _matrix(ca.get("transform"))))
        out[a.get("id")] = entry
    return out


def _not_model_parts(z: zipfile.ZipFile, names: set) -> tuple[dict, dict]:
    """What is not part of an object's surface (:data:`texcad.io.read.VOLUME_KINDS`):
    PrusaSlicer's volumes of another type (modifiers, negative volumes, support
    enforcers / blockers) as ``{object id: [(first, last triangle, kind)]}``, and
    BambuStudio's parts of another subtype as ``{(object id, part id): kind}``."""
    from .read import _part_subtypes, _slic3r_volumes

    vols = _slic3r_volumes(z.read(_PE_CONFIG)) if _PE_CONFIG in names else {}
    ranges = {oid: [(a, b, kind) for _, a, b, kind in parts if kind != "part"] for oid, parts in vols.items()}
    return {oid: r for oid, r in ranges.items() if r}, _part_subtypes(z)


def read_project(path: "str | os.PathLike") -> Project:
    """Read a 3MF project's meshes and paint (PrusaSlicer, OrcaSlicer, BambuStudio):
    build items, components (also in other model parts, ``p:path``) and transforms
    applied, the model's unit made mm; modifiers and support enforcers / blockers
    (PrusaSlicer volume types, BambuStudio part subtypes) left out, negative volumes
    kept apart (:attr:`Project.negatives`: the slicer cuts them out of their object).

    Raises:
        InputError: not a 3MF, no model, a damaged mesh or a cyclic component.
    """
    p = Path(os.fspath(path))
    try:
        z = zipfile.ZipFile(p)
    except (zipfile.BadZipFile, FileNotFoundError, IsADirectoryError):
        raise InputError(f"{str(p)!r} is not a 3MF (zip) project; save the project again from the slicer") from None
    with z:
        names = set(z.namelist())
        root = "3D/3dmodel.model"
        if "_rels/.rels" in names:
            m = re.search(rb'Target="/?([^"]+\.model)"', z.read("_rels/.rels"))
            root = m.group(1).decode() if m else root
        if root not in names:
            raise InputError(f"{str(p)!r} has no 3D model part ({root}); is it a 3MF project?")
        models: dict = {}

        def model(name: str) -> tuple[dict, float]:
            if name not in models:
                if name not in names:
                    raise InputError(f"{str(p)!r}: a component refers to the missing part {name!r}")
                xml = z.read(name)
                head = re.search(rb"<(?:\w+:)?model\b([^>]*)>", xml)
                unit = _attrs(head.group(1)).get("unit", "millimeter") if head else "millimeter"
                if unit not in _UNITS:
                    raise InputError(f"{str(p)!r}: unknown 3MF unit {unit!r}")
                models[name] = (_model_objects(xml, f"{p.name}:{name}"), _UNITS[unit])
            return models[name]

        objs, scale = model(root)
        ranges, others = _not_model_parts(z, names)
        xml = z.read(root)
        items = [(_attrs(i).get("objectid"), _matrix(_attrs(i).get("transform"))) for i in _ITEM.findall(xml[xml.rfind(b"<build"):])]
        verts, faces, paint, parts, off, negatives = [], [], {}, [], 0, []
        dialect = ""

        def walk(part: str, oid: str, tf: np.ndarray, top: tuple, depth: int) -> None:
            nonlocal off, dialect
            table, sc = model(part)
            if oid not in table or depth > 16:
                raise InputError(f"{str(p)!r}: the build refers to a missing or cyclic object {oid!r}")
            e = table[oid]
            kind = others.get((items[top[0]][0], oid), "part")
            if e["mesh"] is not None and kind == "negative":  # BambuStudio: a part cut out of its object
                negatives.append((top[0], (e["mesh"][0] * sc) @ tf[:3, :3] + tf[3, :3], e["mesh"][1]))
            elif e["mesh"] is not None and kind == "part":
                v, f, pt = e["mesh"]
                if depth == 0 and oid in ranges:  # modifiers and the like are not the part's surface
                    keep = np.ones(len(f), dtype=bool)
                    for a, b, what in ranges[oid]:
                        keep[a : b + 1] = False
                        if what == "negative":  # PrusaSlicer: a volume cut out of its object
                            negatives.append((top[0], (v * sc) @ tf[:3, :3] + tf[3, :3], f[a : b + 1]))
                    f, pt = f[keep], {k: ([x for x, q in zip(val, keep) if q] if k != "_dialect" else val) for k, val in pt.items()}
                vv = (v * sc) @ tf[:3, :3] + tf[3, :3]
                verts.append(vv)
                faces.append(f + off)
                for kind in ATTRIBUTES:  # per kind: this mesh's strings (or none)
                    if kind in pt or kind in paint:
                        paint.setdefault(kind, [""] * sum(len(x) for x in faces[:-1]))
                        paint[kind].extend(pt.get(kind, [""] * len(f)))
                dialect = dialect or pt.get("_dialect", "")
                n0 = sum(len(x) for x in faces[:-1])
                parts.append((*top, e["name"], n0, n0 + len(f)))
                off += len(v)
            for cpath, cid, ctf in e["components"]:  # per component
                walk(cpath.lstrip("/") if cpath else part, cid, ctf @ tf, top, depth + 1)

        for k, (oid, tf) in enumerate(items):  # per build item
            walk(root, oid, tf, (k, objs.get(oid, {}).get("name", str(oid))), 0)
    if not faces:
        raise InputError(f"{str(p)!r} holds no mesh objects in its build")
    return Project(np.concatenate(verts), np.concatenate(faces), paint, tuple(parts), dialect, str(p), tuple(items),
                   tuple(negatives))


# --- splitting painted triangles into their sub-triangles, conforming ---

_KEY = np.dtype([("t", "<i8"), ("a", "<i8"), ("b", "<i8"), ("c", "<i8")])


def _keys(rows: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(rows, dtype=np.int64).view(_KEY).ravel()


class _Points:
    """The distinct lattice points of key rows ``(P, 4)`` (:func:`_point_keys`), sorted
    as their keys ``(t, a, b, c)``, and looked up by one int64 each: ``(t, a, b)``
    packed into a uint64 and ranked among the table's, then ``rank << 26 | c``
    (``a, b < 2**31``, ``c <= 2**24``). numpy sorts and searches structured keys
    field by field in a generic loop: a seam painted 12 levels deep (553 k leaves, some
    200 M lookups) took 145 s that way.

    Attributes: rows: ``(T, 4)`` the table's keys, sorted. first: each one's first
    row in the input."""

    def __init__(self, rows: np.ndarray) -> None:
        hi = self._hi(rows)
        self._his = np.unique(hi)
        codes, self.first = np.unique(np.searchsorted(self._his, hi) << 26 | rows[:, 3], return_index=True)
        self._codes, self.rows = codes, rows[self.first]

    @staticmethod
    def _hi(rows: np.ndarray) -> np.ndarray:
        r = np.asarray(rows, np.int64)
        if len(r) and (r[:, 1:3].max() >= 1 << 31 or r[:, 3].max() > 1 << 24):  # pragma: no cover - 2**31 vertices
            raise InputError("paint on a mesh of more than 2**31 vertices or faces; texture it in parts")
        return (r[:, 0].astype(np.uint64) << np.uint64(62)) | (r[:, 1].astype(np.uint64) << np.uint64(31)) | r[:, 2].astype(np.uint64)

    def find(self, rows: np.ndarray) -> np.ndarray:
        """``(Q,)`` each key row's index in :attr:`rows`, -1 where it is not there."""
        if not len(self._codes):
            return np.full(len(rows), -1, dtype=np.int64)
        hi = self._hi(rows)
        r = np.minimum(np.searchsorted(self._his, hi), len(self._his) - 1)
        code = r.astype(np.int64) << 26 | np.asarray(rows, np.int64)[:, 3]
        pos = np.minimum(np.searchsorted(self._codes, code), len(self._codes) - 1)
        return np.where((self._his[r] == hi) & (self._codes[pos] == code), pos, -1)


def _point_keys(face: np.ndarray, lat: np.ndarray, faces: np.ndarray, full: int) -> np.ndarray:
    """Global key rows ``(P, 4)`` of lattice points ``lat`` ``(P, 3)`` (barycentric
    times ``full``) of faces ``face``: ``(0, vertex)`` at a corner, ``(1, u, v, t)`` on
    the edge ``u < v`` (``t`` the weight of ``v``), ``(2, face, i, j)`` inside."""
    zero = lat == 0
    nz = zero.sum(axis=1)
    fv = faces[face]
    out = np.zeros((len(lat), 4), dtype=np.int64)
    corner = nz == 2
    out[corner, 0] = 0
    out[corner, 1] = fv[corner, np.argmax(lat[corner], axis=1)]
    edge = np.flatnonzero(nz == 1)
    z = np.argmax(zero[edge], axis=1)
    i1, i2 = (z + 1) % 3, (z + 2) % 3
    u, v = fv[edge, i1], fv[edge, i2]
    wu, wv = lat[edge, i1], lat[edge, i2]
    out[edge, 0] = 1
    out[edge, 1], out[edge, 2] = np.minimum(u, v), np.maximum(u, v)
    out[edge, 3] = np.where(u < v, wv, wu)
    inner = nz == 0
    out[inner, 0] = 2
    out[inner, 1], out[inner, 2], out[inner, 3] = face[inner], lat[inner, 1], lat[inner, 2]
    return out


def split_painted(vertices: np.ndarray, faces: np.ndarray, strings: Sequence[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The mesh with every painted triangle cut into its sub-triangles, conforming:
    where a sub-triangle's edge holds a vertex of another (a finer neighbour, in the
    same triangle or across a mesh edge) it is cut into a fan around its centroid, so
    the mesh stays closed and the paint's borders are mesh edges.

    Args:
        vertices: ``(N, 3)`` mm. faces: ``(M, 3)``. strings: ``M`` paint strings.

    Returns:
        ``(vertices (N', 3) float64 mm, faces (M', 3) int64, state (M',) int64,
        parent (M',) int64)``: equal vertices welded; each face's state and the input
        triangle it lies in.
    """
    v = np.asarray(vertices, np.float64)
    uniq, inv = np.unique(v, axis=0, return_inverse=True)
    v, f = uniq, inv.ravel()[np.asarray(faces, np.int64)]
    m = len(f)
    painted = np.flatnonzero(np.fromiter((bool(s) for s in strings), dtype=bool, count=m))
    dec = decode([strings[i] for i in painted])
    ltri = painted[dec.triangle]
    depth_f = np.zeros(m, dtype=np.int64)
    np.maximum.at(depth_f, ltri, dec.depth)
    whole = np.zeros(m, dtype=np.int64)
    flat = dec.depth == 0
    whole[ltri[flat]] = dec.state[flat]
    G = int(depth_f.max(initial=0))
    if G == 0:  # whole triangles only: nothing to cut
        return v, f, whole, np.arange(m)
    if G > 24:
        raise InputError(f"paint subdivided {G} levels deep (more than 24); paint with a larger brush in the slicer")
    full = 1 << G
    # neighbours across each edge; a face is cut if it or a neighbour is subdivided
    e = np.sort(np.stack([f, f[:, [1, 2, 0]]], axis=2).reshape(-1, 2), axis=1)
    _, eid = np.unique(e, axis=0, return_inverse=True)
    eid = eid.ravel()
    deep = np.zeros(eid.max() + 1, dtype=np.int64)
    np.maximum.at(deep, eid, np.repeat(depth_f, 3))
    local = np.maximum(depth_f, deep[eid].reshape(m, 3).max(axis=1))  # lattice level a face needs
    cut = local > 0
    # leaves of cut faces: decoded ones, and whole faces as one leaf
    sub = cut[ltri] & (depth_f[ltri] > 0)
    lone = np.flatnonzero(cut & (depth_f == 0))
    lf = np.concatenate([ltri[sub], lone])
    lat = np.concatenate([np.rint(dec.corners[sub] * full).astype(np.int64), np.broadcast_to(np.eye(3, dtype=np.int64) * full, (len(lone), 3, 3))])
    lstate = np.concatenate([dec.state[sub], whole[lone]])
    rows = _point_keys(np.repeat(lf, 3), lat.reshape(-1, 3), f, full)
    points = _Points(rows)
    table, first = _keys(points.rows), points.first
    corner_id = points.find(rows).reshape(-1, 3)
    extra_leaf, extra_edge, extra_id, extra_m = _edge_points(lat, lf, local, G, points, f, full)
    # new vertices: the lattice points, then the centroids of leaves that get a fan
    pts_lat = lat.reshape(-1, 3)[first]
    pts_face = np.repeat(lf, 3)[first]
    pos_new = np.einsum("pj,pjk->pk", pts_lat / full, v[f[pts_face]])
    is_vertex = table["t"] == 0
    vid = np.where(is_vertex, table["a"], len(v) + np.cumsum(~is_vertex) - 1)
    verts = np.concatenate([v, pos_new[~is_vertex]])
    fan = np.zeros(len(lf), dtype=bool)
    fan[extra_leaf] = True
    cen = len(verts) + np.cumsum(fan) - 1
    verts = np.concatenate([verts, np.einsum("lj,ljk->lk", lat[fan].mean(axis=1) / full, v[f[lf[fan]]])])
    # plain leaves as they are; fanned ones: their boundary (corners and extra points in order) to the centroid
    plain = ~fan
    tri_plain = vid[corner_id[plain]]
    ring_leaf = np.concatenate([np.repeat(np.flatnonzero(fan), 3), extra_leaf])
    ring_edge = np.concatenate([np.tile(np.arange(3), int(fan.sum())), extra_edge])
    ring_m = np.concatenate([np.zeros(3 * int(fan.sum()), dtype=np.int64), extra_m])
    ring_v = np.concatenate([vid[corner_id[fan].ravel()], vid[extra_id]])
    order = np.lexsort((ring_m, ring_edge, ring_leaf))
    rl, rv = ring_leaf[order], ring_v[order]
    nxt = np.r_[rv[1:], 0]
    startpos = np.r_[True, rl[1:] != rl[:-1]]
    endpos = np.r_[rl[1:] != rl[:-1], True]
    nxt[endpos] = rv[np.flatnonzero(startpos)]  # close each ring
    tri_fan = np.stack([rv, nxt, cen[rl]], axis=1)
    keep = np.flatnonzero(~cut)
    out_f = np.concatenate([f[keep], tri_plain, tri_fan])
    out_s = np.concatenate([whole[keep], lstate[plain], lstate[rl]])
    out_p = np.concatenate([keep, lf[plain], lf[rl]])
    return verts, out_f, out_s, out_p


def _edge_points(lat, lf, local, G, points: _Points, f, full):
    """The known points (``points``) that lie inside the leaves' edges. A leaf's edge
    is a dyadic piece of a side both its neighbours split by halving, so a point lies
    inside it only if its midpoint does: the midpoints of the edges are looked up,
    then those of the halves of the edges whose midpoint was there, level by level
    (each edge's lattice points at its face's level ``2**local`` looked up one by one
    were 200 M lookups on a seam painted 12 levels deep). Returns, per point found,
    its leaf, edge (0..2), row in ``points.rows`` and step along the edge."""
    P = lat.reshape(-1, 3)
    step = np.repeat(1 << (G - local[lf]), 3)[:, None]
    d = (lat[:, [1, 2, 0]].reshape(-1, 3) - P) // step
    g = np.gcd.reduce(np.abs(d), axis=1)  # (L * 3,) lattice steps along each edge
    unit = d // np.maximum(g, 1)[:, None] * step  # one step, in full-lattice units
    e = np.flatnonzero(g >= 2)  # per segment to look inside: its edge, start and length in steps
    m0, n = np.zeros(len(e), dtype=np.int64), g[e]
    out = []
    while len(e):  # per level of halving
        even = n % 2 == 0
        e, m0, n = e[even], m0[even], n[even] // 2
        mid = m0 + n
        pos = points.find(_point_keys(lf[e // 3], P[e] + unit[e] * mid[:, None], f, full))
        on = pos >= 0
        out.append((e[on] // 3, e[on] % 3, pos[on], mid[on]))
        e, m0, n = np.repeat(e[on], 2), np.stack([m0[on], mid[on]], axis=1).ravel(), np.repeat(n[on], 2)
    return tuple(np.concatenate([o[k] for o in out]) if out else np.zeros(0, dtype=np.int64) for k in range(4))


_CT = (b'<?xml version="1.0" encoding="UTF-8"?>\n<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">'
       b'<Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>'
       b'<Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>\n')
_RELS = (b'<?xml version="1.0" encoding="UTF-8"?>\n<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">'
         b'<Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/></Relationships>\n')
_NS = 'xmlns="http://schemas.microsoft.com/3dmanufacturing/core/2015/02"'


def _mesh_xml(v: np.ndarray, f: np.ndarray, attrs: dict) -> str:
    rows = [f'<vertex x="{x:.9g}" y="{y:.9g}" z="{z:.9g}"/>' for x, y, z in np.asarray(v, np.float64).tolist()]
    tris = []
    for k, (a, b, c) in enumerate(np.asarray(f, np.int64).tolist()):  # per triangle (a test/recipe writer)
        extra = "".join(f' {name}="{vals[k]}"' for name, vals in attrs.items() if vals[k])
        tris.append(f'<triangle v1="{a}" v2="{b}" v3="{c}"{extra}/>')
    return "<mesh><vertices>" + "\n".join(rows) + "</vertices><triangles>" + "\n".join(tris) + "</triangles></mesh>"


def write_painted_3mf(path: "str | os.PathLike", objects: Sequence[tuple], *, dialect: str = "prusa") -> None:
    """Write a slicer project with paint (for tests, recipes and examples).

    Args:
        objects: ``(name, vertices (N, 3) mm, faces (M, 3), {kind: M strings},
            transform)`` per object; ``transform`` a 3x4 / 4x4 matrix (the build
            item's, column-vector convention: ``x' = R x + t``) or None.
        dialect: ``"prusa"`` (PrusaSlicer / OrcaSlicer: ``slic3rpe:`` attributes in
            the model) or ``"bambu"`` (BambuStudio: ``paint_*`` attributes, each mesh
            in ``3D/Objects/object_N.model`` reached through a component).
    """
    if dialect not in ("prusa", "bambu"):
        raise ParameterError(f"dialect must be 'prusa' or 'bambu', got {dialect!r}")
    col = 0 if dialect == "prusa" else 1
    res, items, extra = [], [], {}
    for k, (name, v, f, paint, tf) in enumerate(objects):  # per object
        attrs = {ATTRIBUTES[kind][col]: list(vals) for kind, vals in paint.items()}
        m = np.eye(4) if tf is None else np.vstack([np.asarray(tf, np.float64)[:3, :4], [0, 0, 0, 1]])
        t = " ".join(f"{x:.9g}" for x in [*m[:3, :3].T.ravel(), *m[:3, 3]])
        oid = 2 * k + 1
        if dialect == "prusa":
            res.append(f'<object id="{oid}" type="model" name="{name}">{_mesh_xml(v, f, attrs)}</object>')
        else:
            part = f"3D/Objects/object_{oid}.model"
            extra[part] = (f'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" {_NS} '
                           'xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06" requiredextensions="p">'
                           f'<resources><object id="{oid}" type="model">{_mesh_xml(v, f, attrs)}</object></resources><build/></model>\n')
            res.append(f'<object id="{oid + 1}" type="model" name="{name}"><components>'
                       f'<component p:path="/{part}" objectid="{oid}"/></components></object>')
            oid += 1
        items.append(f'<item objectid="{oid}" transform="{t}" printable="1"/>')
    ns = _NS + (' xmlns:slic3rpe="http://schemas.slic3r.org/3mf/2017/06"' if dialect == "prusa" else
                ' xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06" requiredextensions="p"')
    app = "PrusaSlicer-2.9.0" if dialect == "prusa" else "BambuStudio-02.00.00.00"
    model = (f'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xml:lang="en-US" {ns}>\n'
             f'<metadata name="Application">{app}</metadata>\n'
             + (' <metadata name="slic3rpe:Version3mf">1</metadata>\n' if dialect == "prusa" else "")
             + f'<resources>\n{chr(10).join(res)}\n</resources>\n<build>{"".join(items)}</build>\n</model>\n')
    from ..util import atomic_path

    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("[Content_Types].xml", _CT)
            z.writestr("_rels/.rels", _RELS)
            z.writestr("3D/3dmodel.model", model)
            for name, text in extra.items():  # per object file (BambuStudio)
                z.writestr(name, text)


# --- writing the zones back into the project ---

_PE_CONFIG = "Metadata/Slic3r_PE_model.config"


def _object_element(oid: str, name: str, meshes: Sequence, inv: np.ndarray) -> tuple[str, list]:
    """The ``<object>`` of the zones (one mesh, the parts one after the other, in the
    object's frame ``x @ inv[:3, :3] + inv[3, :3]``) and each part's triangle range."""
    vs, fs, ranges, voff, foff = [], [], [], 0, 0
    for m in meshes:  # per part
        v = np.asarray(m.vertices, np.float64) @ inv[:3, :3] + inv[3, :3]
        vs.append(v)
        fs.append(np.asarray(m.faces, np.int64) + voff)
        ranges.append((foff, foff + len(m.faces) - 1))
        voff, foff = voff + len(v), foff + len(m.faces)
    v, f = np.concatenate(vs), np.concatenate(fs)
    vtx = "\n".join(f'<vertex x="{x:.6f}" y="{y:.6f}" z="{z:.6f}"/>' for x, y, z in v.tolist())
    tri = "\n".join(f'<triangle v1="{a}" v2="{b}" v3="{c}"/>' for a, b, c in f.tolist())
    xml = (f'<object id="{oid}" type="model" name="{_esc(name)}"><mesh><vertices>\n{vtx}\n</vertices>'
           f'<triangles>\n{tri}\n</triangles></mesh></object>')
    return xml, ranges


def _esc(s: str) -> str:
    return s.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def write_zones(paint: dict, base: Any, zones: Sequence, names: Sequence[str], path: "str | os.PathLike") -> None:
    """Write textured zones back into their slicer project (PrusaSlicer / OrcaSlicer
    dialect): the painted object becomes one object made of parts, ``base`` and one
    part per zone (named ``names``; a ``paint:N`` zone of multi-material paint gets
    extruder ``N``); every other object, the build, the print settings and the other
    objects' paint are copied unchanged. In a BambuStudio project the object's
    components are replaced by the parts, in a new object file
    (``3D/Objects/texcad_zones_ID.model``) named in the model's relationships and in
    ``Metadata/model_settings.config``. Without a dialect (no paint read), a new
    3MF of the parts (:func:`texcad.io.write_3mf`).

    Args:
        paint: ``info["paint"]`` of a result textured with paint regions (``project``
            path, ``dialect``, ``items`` textured, ``extruders`` per zone).
        base, zones: meshes in the build's frame (mm). path: the ``.3mf`` to write.
    """
    from ..util import atomic_path
    from .export import write_3mf

    parts = [("base", base)] + [(n, z) for n, z in zip(names, zones)]
    src = Path(paint["project"])
    project = read_project(src)
    items = list(paint["items"])
    oid, tf = project.items[items[0]]
    with zipfile.ZipFile(src) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    extruders = [None] + list(paint.get("extruders", [None] * len(zones)))
    if paint.get("dialect") == "bambu" and "3D/3dmodel.model" in entries:
        _bambu_zones(entries, project, items, parts, extruders)
    elif paint.get("dialect") != "prusa":
        write_3mf(parts, path, name=src.stem)
        return
    else:
        _prusa_zones(entries, project, items, parts, extruders, src)
    with atomic_path(path) as tmp:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            for n, data in entries.items():  # per entry: copied, or rewritten above
                z.writestr(n, data)


def _prusa_zones(entries: dict, project: Project, items: list, parts: list, extruders: list, src: Path) -> None:
    """The PrusaSlicer project's model and config with the textured object replaced."""
    oid, tf = project.items[items[0]]
    model = entries["3D/3dmodel.model"].decode("utf-8")
    gone = {project.items[k][0] for k in items}
    for obj in re.findall(r"<object\b[^>]*>.*?</object>", model, flags=re.S):  # per object: the textured ones go
        m = re.search(r'\bid="([^"]*)"', obj)
        if m and m.group(1) in gone:
            model = model.replace(obj, "" if m.group(1) != oid else "\x00")
    name = next((n for k, n, *_ in project.parts if k == items[0]), src.stem)
    xml, ranges = _object_element(oid, name, [m for _, m in parts], np.linalg.inv(tf))
    model = model.replace("\x00", xml)
    for k in items[1:]:  # the other textured items are in this object now
        model = re.sub(r'<item\b[^>]*objectid="%s"[^>]*/>' % re.escape(project.items[k][0]), "", model, count=1)
    entries["3D/3dmodel.model"] = model.encode("utf-8")
    entries[_PE_CONFIG] = _zone_config(entries.get(_PE_CONFIG, b"").decode("utf-8"), oid, name, parts, ranges, extruders)


def _bambu_zones(entries: dict, project: Project, items: list, parts: list, extruders: list) -> None:
    """The BambuStudio project with the textured object's components replaced by one
    mesh per part in a new object file (``3D/Objects/texcad_zones_ID.model``), listed
    in the model's relationships and in ``Metadata/model_settings.config``."""
    oid, tf = project.items[items[0]]
    inv = np.linalg.inv(tf)
    name = f"3D/Objects/texcad_zones_{oid}.model"
    objs = []
    for k, (pname, m) in enumerate(parts):  # per part: its own mesh object
        xml, _ = _object_element(str(k + 1), pname, [m], inv)
        objs.append(xml)
    entries[name] = (f'<?xml version="1.0" encoding="UTF-8"?>\n<model unit="millimeter" xml:lang="en-US" {_NS} '
                     'xmlns:p="http://schemas.microsoft.com/3dmanufacturing/production/2015/06" requiredextensions="p">\n'
                     f'<resources>\n{chr(10).join(objs)}\n</resources>\n<build/>\n</model>\n').encode("utf-8")
    model = entries["3D/3dmodel.model"].decode("utf-8")
    comps = "".join(f'<component p:path="/{name}" objectid="{k + 1}"/>' for k in range(len(parts)))
    m = re.search(r'(<object\b[^>]*\bid="%s"[^>]*>)(.*?)(</object>)' % re.escape(oid), model, flags=re.S)
    if m is None:
        raise InputError(f"{project.path!r}: the textured object {oid} is not in the model; save the project again")
    model = model[: m.start()] + m.group(1) + f"<components>{comps}</components>" + m.group(3) + model[m.end():]
    for k in items[1:]:  # the other textured items are in this object now
        model = re.sub(r'<item\b[^>]*objectid="%s"[^>]*/>' % re.escape(project.items[k][0]), "", model, count=1)
    entries["3D/3dmodel.model"] = model.encode("utf-8")
    rels = entries.get("3D/_rels/3dmodel.model.rels", b'<?xml version="1.0" encoding="UTF-8"?>\n<Relationships '
                       b'xmlns="http://schemas.openxmlformats.org/package/2006/relationships">\n</Relationships>\n').decode("utf-8")
    rel = f' <Relationship Target="/{name}" Id="rel-texcad-{oid}" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>\n'
    entries["3D/_rels/3dmodel.model.rels"] = rels.replace("</Relationships>", rel + "</Relationships>").encode("utf-8")
    vols = "".join(
        f'    <part id="{k + 1}" subtype="normal_part">\n      <metadata key="name" value="{_esc(n)}"/>\n'
        '      <metadata key="matrix" value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"/>\n'
        + (f'      <metadata key="extruder" value="{e}"/>\n' if e else "") + "    </part>\n"
        for k, ((n, _), e) in enumerate(zip(parts, extruders)))
    cfg = entries.get("Metadata/model_settings.config", b"").decode("utf-8")
    m = re.search(r'<object\s+id="%s"[^>]*>(.*?)</object>' % re.escape(oid), cfg, flags=re.S)
    if m:
        keep = "".join(re.findall(r'\s*<metadata key="[^"]*" value="[^"]*"/>', m.group(1).split("<part")[0]))
        cfg = cfg[: m.start()] + f'<object id="{oid}">{keep}\n{vols}  </object>' + cfg[m.end():]
    else:
        body = f'  <object id="{oid}">\n{vols}  </object>\n'
        cfg = cfg.replace("</config>", body + "</config>") if "</config>" in cfg else (
            f'<?xml version="1.0" encoding="UTF-8"?>\n<config>\n{body}</config>\n')
    entries["Metadata/model_settings.config"] = cfg.encode("utf-8")


def _zone_config(cfg: str, oid: str, name: str, parts: Sequence, ranges: Sequence, extruders: Sequence) -> bytes:
    """PrusaSlicer's model config with the textured object's volumes replaced (its
    object settings kept), or a new config naming the parts."""
    vols = "".join(
        f'  <volume firstid="{a}" lastid="{b}">\n   <metadata type="volume" key="name" value="{_esc(n)}"/>\n'
        '   <metadata type="volume" key="volume_type" value="ModelPart"/>\n'
        + (f'   <metadata type="volume" key="extruder" value="{e}"/>\n' if e else "") + "  </volume>\n"
        for (n, _), (a, b), e in zip(parts, ranges, extruders))
    m = re.search(r'<object\s+id="%s"[^>]*>(.*?)</object>' % re.escape(oid), cfg, flags=re.S)
    if m:
        keep = "".join(re.findall(r'\s*<metadata type="object"[^>]*/>', m.group(1)))
        new = f'<object id="{oid}" instances_count="1">{keep}\n{vols} </object>'
        return (cfg[: m.start()] + new + cfg[m.end():]).encode("utf-8")
    body = f' <object id="{oid}" instances_count="1">\n  <metadata type="object" key="name" value="{_esc(name)}"/>\n{vols} </object>\n'
    if "</config>" in cfg:
        return cfg.replace("</config>", body + "</config>").encode("utf-8")
    return f'<?xml version="1.0" encoding="UTF-8"?>\n<config>\n{body}</config>\n'.encode("utf-8")
