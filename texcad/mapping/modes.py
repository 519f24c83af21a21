"""Raised, engraved and centred textures on a mapped 2.5D surface (paper section 2.2).

On a :class:`~texcad.mapping.MappedSurface` the textured point of grid vertex
``(r, c)`` is ``T = P + h v``: ``P`` the profile point of column ``c`` extruded to row
``r``, ``v = w(s) d(s)`` the column's offset direction (``d`` the unit outward normal,
algorithm 2, or ``+-z``, algorithm 1) times its fade and limit factor ``w``. A mode
with share ``c`` (0 raised, 1/2 centred, 1 engraved) and a depth gain ``g`` in [0, 1]
moves that point to

    ``S = P + t v``,  ``t = g (h - c H)``,

``H`` the texture's full height: the texture's top lies ``g (1 - c) H`` above the
surface and its bottom ``g c H`` below it, and where the mapping fades the texture out
(``w = 0``) it meets the untouched surface at height 0. Engraved (``c = 1``) keeps the
outer envelope: nothing lies above the surface.

The part is then ``(base - cutter) + slab``: the *cutter* reaches from ``CUT_ABOVE`` mm
outside the surface down to ``S``, but never to less than ``floor`` mm under it (so no
face of it lies on the base's own surface), and for the centred mode the *slab* (the
raised texture's slab, top ``S``) adds back what stands above that cut.
"""

from __future__ import annotations

import numpy as np

from .map import MappedSurface
from .surface import Profile

__all__ = ["ModeSheets", "mode_sheets", "CUT_ABOVE", "CUT_FLOOR"]

#: mm: the cutter's outer side lies this far outside the exact surface (clear of the
#: base's tessellation, whose chords lie inside it).
CUT_ABOVE = 0.05
#: mm: the cutter reaches at least this far under the surface.
CUT_FLOOR = 0.01
#: Share of the base's wall thickness a cut leaves standing.
WALL_KEPT = 0.4
#: mm: the deepest cut stays this far above the slab's bottom (``depth`` mm in, less
#: where the base is thin).
SLAB_CLEARANCE = 0.1


class ModeSheets(dict):
    """The grids of a mode (all float32, mm, the mapped surface's frame):

    * ``"surface"``: ``(R, C, 3)`` the textured surface ``S = P + t v``;
    * ``"cut"``: ``(R, C, 3)`` the cutter's textured side, ``S`` where it lies at
      least ``floor`` mm under the surface, else ``floor`` mm under it (centred:
      ``floor`` mm deeper still, under the slab that fills it back up to ``S``);
    * ``"outer"``: ``(2, C, 3)`` the cutter's outer side (first and last row: an
      extrusion along y), ``CUT_ABOVE`` mm outside the surface;
    * ``"slab"``: ``(R, C, 3)`` the centred slab's top: ``S``, but ``floor`` mm under
      the cut along the grid's outline;
    * ``"low"``: ``(R, C, 3)`` the envelope's bottom ``P - g c H v``, 2 ``floor`` mm
      lower: what lies above it is the texture (for ``texture_mesh``);
    * ``"limited"``: how many grid points were cut less deep than ``t`` because the
      base is not that thick under them (the cut stays :data:`SLAB_CLEARANCE` mm
      above the slab's bottom, which :func:`texcad.mapping.map_texture` keeps
      within 0.4 of the profile's material, and leaves :data:`WALL_KEPT` of the
      base's wall ``thickness``).
    """


def _frames(profile: Profile, mapped: MappedSurface):
    """Per column: ``(P_xz (C, 2), unit normal (C, 2), v (C, 2))`` in mm and mm/mm
    (``v``: the mapping's own offset, :attr:`MappedSurface.offset`)."""
    fc = profile.at(mapped.s)
    return fc.point, fc.normal, mapped.offset


def _within(tv: np.ndarray, n: np.ndarray, reach: np.ndarray) -> tuple[np.ndarray, int]:
    """Offsets ``tv`` ``(R, C, 2)`` mm scaled back where their normal component goes
    deeper than ``reach`` ``(C,)`` mm under the surface; ``(offsets, how many were)``."""
    tn = np.einsum("rck,ck->rc", tv, n)
    deep = tn < -reach[None, :]
    scale = np.where(deep, reach[None, :] / np.maximum(-tn, 1e-12), 1.0)
    return tv * scale[..., None], int(deep.sum())


def _place(P: np.ndarray, y: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """``(R, C, 3)`` float32 points ``P + offset`` at rows ``y`` (offset ``(R, C, 2)``
    or ``(C, 2)`` mm, in the xz plane)."""
    off = np.broadcast_to(offset, (len(y), len(P), 2))
    g = np.empty((len(y), len(P), 3), dtype=np.float32)
    g[..., 0] = P[None, :, 0] + off[..., 0]
    g[..., 1] = np.asarray(y, dtype=np.float32)[:, None]
    g[..., 2] = P[None, :, 1] + off[..., 1]
    return g


def mode_sheets(
    profile: Profile,
    mapped: MappedSurface,
    *,
    share: float,
    height: float,
    gain: np.ndarray | None = None,
    floor: float = CUT_FLOOR,
    above: float = CUT_ABOVE,
    overlap: float = CUT_FLOOR,
    thickness: float = float("inf"),
) -> ModeSheets:
    """The sheets of a raised, centred or engraved texture on a mapped surface.

    Args:
        profile: the profile ``mapped`` was made on (mm).
        mapped: the *raised* mapping of the texture (:func:`texcad.mapping.map_texture`).
        share: ``c``: 0 raised, 0.5 centred, 1 engraved.
        height: ``H``, the texture's full height in mm (the envelope).
        gain: ``(R, C)`` depth gain ``g`` in [0, 1] per grid point (None: 1).
        floor: mm: the cutter reaches at least this far under the surface.
        above: mm: the cutter's outer side lies this far outside the surface.
        overlap: mm: centred: the cut reaches this much deeper than ``S``, under the
            slab that fills it back up (more than twice the two sheets' own
            triangulation error, so they cannot cross).
        thickness: mm: the base's wall under the surface; a cut keeps at least
            :data:`WALL_KEPT` of it.

    Returns:
        :class:`ModeSheets` (see there); the offsets follow the module docstring,
        ``t = g (h - c H)``.
    """
    P, n, v = _frames(profile, mapped)
    hv = mapped.top[..., [0, 2]].astype(np.float64) - P[None]  # h v, (R, C, 2) mm
    g = 1.0 if gain is None else np.asarray(gain, dtype=np.float64)[..., None]
    # The cut stays above the slab's bottom (map_texture keeps that within 0.4 of the
    # profile's own material) and leaves WALL_KEPT of the base's wall: deeper offsets
    # are scaled back to that reach.
    below = np.minimum(np.einsum("ck,ck->c", P - mapped.bottom[0][:, [0, 2]], n), (1.0 - WALL_KEPT) * thickness)
    reach = np.maximum(below - SLAB_CLEARANCE - (overlap if share < 1 else 0.0) - floor, 0.0)
    tv, limited = _within(g * (hv - share * height * v[None]), n, reach)  # t v
    tn = np.einsum("rck,ck->rc", tv, n)  # its normal component, mm (negative: under the surface)
    cut = np.where((tn < 0)[..., None], tv, 0.0) - np.maximum(0.0, floor + np.minimum(tn, 0.0))[..., None] * n[None]
    if share < 1:  # a slab fills the cut back up to S: cut deeper, so no face of the two lies on the other
        cut = cut - overlap * n[None]
    low = _within(-g * share * height * v[None], n, reach)[0] - 2.0 * floor * n[None]
    outer = _place(P, np.asarray(mapped.y)[[0, -1]], above * n)
    # The slab's outline dips under the cut: its end walls stay inside the base, apart
    # from the cutter's (two walls in one plane make a union pinch).
    slab = tv.copy()
    edge = np.zeros(tv.shape[:2], bool)
    edge[[0, -1], :] = True
    if not mapped.closed:
        edge[:, [0, -1]] = True
    slab[edge] = (cut - floor * n[None])[edge]
    return ModeSheets(surface=_place(P, mapped.y, tv), cut=_place(P, mapped.y, cut), outer=outer,
                      low=_place(P, mapped.y, low), slab=_place(P, mapped.y, slab), limited=limited)
