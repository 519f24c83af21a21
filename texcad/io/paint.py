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

from dataclasses import dataclass
from typing import Any, Callable, Sequence

import numpy as np

from ..errors import InputError, ParameterError

__all__ = ["PAINT_KINDS", "ATTRIBUTES", "Painted", "decode", "encode_states", "paint_by_points", "tree_string"]

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
    order = np.lexsort((np.arange(len(s)), s))
    key_s, key_i = s[order], np.arange(len(s))[order]
    # end of the subtree at t: first t' >= t with s[t'] == before[t] - 1
    lo = np.searchsorted(key_s, before - 1, side="left")
    hi = np.searchsorted(key_s, before - 1, side="right")
    end = np.full(len(s), -1, dtype=np.int64)
    if len(s):
        pos = lo + _count_below(key_s, key_i, lo, hi, np.arange(len(s)))
        okp = pos < hi
        end[okp] = key_i[np.minimum(pos, len(key_i) - 1)][okp]
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


def _count_below(key_s, key_i, lo, hi, t):
    """For each query, how many of ``key_i[lo:hi]`` (sorted) are below ``t``."""
    # key_i is sorted within each run of equal key_s: binary search inside [lo, hi)
    out = np.zeros(len(t), dtype=np.int64)
    width = hi - lo
    step = 1 << int(max(int(width.max(initial=0)), 1)).bit_length()
    while step:  # branch-free binary search, all queries at once
        cand = out + step
        idx = lo + cand - 1
        take = (cand <= width) & (key_i[np.clip(idx, 0, len(key_i) - 1)] < t)
        out = np.where(take, cand, out)
        step >>= 1
    return out


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
    boxes = [np.broadcast_to(np.eye(3), (n, 1, 3, 3)).copy()]
    for _ in range(depth):  # per level from the root: every node into its 4 children, in child order
        b = boxes[-1]
        six = np.concatenate([b, 0.5 * (b + b[:, :, [1, 2, 0]])], axis=2)
        kids = [six[:, :, _TABLE[3, j]] for j in range(4)]
        boxes.append(np.stack(kids, axis=2).reshape(n, -1, 3, 3))
    fine = boxes[-1]
    cen = np.einsum("tnj,tjk->tnk", fine.mean(axis=2), tri)
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
