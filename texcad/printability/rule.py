"""The slicers' overhang rule: which facet angles get support, and the limiter's margin.

texcad's *critical angle* ``alpha`` is the number a user types into the slicer as its
support threshold (PrusaSlicer: "overhang threshold", degrees from the horizontal;
CuraEngine: "support overhang angle" ``90 - alpha``, degrees from the vertical). This
module says, in one place, what the slicers then do with a facet, so that the limiter
(:mod:`texcad.printability.overhang`, :mod:`~texcad.printability.relief`,
:mod:`~texcad.printability.profile`) and ``texcad check`` (:func:`overhang_mask`)
use the same rule as the slicers, the boundary included.

The layer-wise test
-------------------
Both slicers cut the part into layers of height ``h`` and compare each layer with the
one below: the part of layer ``i`` farther than an *allowance* ``a`` (mm) from layer
``i - 1`` is an overhang and gets support. A planar facet making ``phi`` degrees with
the build plate (``theta = 90 - phi`` from the vertical) moves its contour outwards
by the *step*

    s = h * tan(theta) = h / tan(phi)                                      (1)

per layer, so the slicer supports it exactly when ``s > a``. The allowances:

* PrusaSlicer 2.5 (``SupportMaterial.cpp``, ``contact_layers``): the threshold is
  raised by one degree "to make it inclusive" and the lower layer is grown by
  ``lower_layer_offset = h / tan(alpha + 1)`` (square joins), so

      a_P = h / tan(alpha + 1 deg)                                          (2)

* CuraEngine 4.13 (``src/support.cpp``, ``computeBasicAndFullOverhang``, lines
  1272-1283 at tag 4.13.0): the lower layer is grown by
  ``max_dist_from_lower_layer = (tan(support_angle) - 0.01) h`` with
  ``support_angle = 90 - alpha``, held in whole micrometres (``coord_t``,
  truncated: 197 um at 45 degrees and 0.2 mm, not 198), so

      a_C = floor(h (1 / tan(alpha) - 0.01) / 1 um) 1 um                    (3)

  Both layers are the layer parts' ``print_outline`` (``sliceDataStorage.cpp``
  65-77), which with *fill outline gaps* on (Cura's default) is the sliced
  outline itself (``WallsComputation.cpp`` 58-60, 113-120).

Putting (1) into ``s > a`` the layer height cancels: a planar facet gets support from
PrusaSlicer below ``alpha + 1`` degrees, from CuraEngine below
``atan(h / a_C)`` (``alpha + 0.44`` at 45 and 0.2 mm). :func:`overhang_angle`
is the larger of the two (46 degrees at ``alpha = 45``): the boundary ``texcad check``
uses, so that a plate tilted by exactly 45 degrees, which both slicers support at
threshold 45, counts as an overhang there too.

The limiter's margin
--------------------
A texture is not a plane: its slices are polygons with thousands of short edges,
which the slicers clean before they compare them, and their outlines are rounded
to the slicers' integer grids (1 nm in PrusaSlicer, 1 um in CuraEngine). CuraEngine
simplifies each sliced outline once, with ``Polygons::simplify``'s defaults
(``slicer.cpp`` 784, ``utils/polygon.h`` 943): it drops a vertex only next to a
segment under 10 um and only where that moves the outline by at most 5 um. Its
coarser ``meshfix_maximum_deviation`` (25 um) applies to the walls and skins, not
to the outlines the overhang test compares (it would reach them with *fill outline
gaps* off: the outline then is the outer wall's, opened by half a line width).
PrusaSlicer closes each slice by ``slice_closing_radius`` (0.049 mm), which only
adds material. So a contour moves by up to ``e`` = 5 um in either direction, and a
facet is safe in every layer only when ``s + 2 e <= a``:

    phi_free = atan(h / (min(a_P, a_C) - 2 e))                               (4)

:func:`support_free_angle` computes (4); :func:`slicer_margin` is ``phi_free -
alpha``, the degrees the limiters add to the critical angle. ``e`` =
:data:`SLICE_DEVIATION`, CuraEngine's bound. With it the slicer tests' parts
(tests/report/test_slicer.py) get no more support than their bare parts in either
slicer. (The lever recipe's ball once seemed to get 40 mm more in CuraEngine:
7.06 m of its sparse zigzag against 7.02 m bare. Laid as plain lines, whose
length measures the area, it gets less, 12.43 m against 12.78 m, less on every
layer: the zigzag's connectors run along the support's border, which the texture
makes more jagged; ``texcad.report.slicer.support_config``.) Thinner layers need a
wider margin, because the deviation does not shrink with ``h``. At ``alpha = 45``,
``h = 0.2``: 46.0 degrees for a plane, 47.5 for a limited texture (margin 2.5).

All angles in degrees, lengths in mm.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

__all__ = [
    "check_critical_angle",
    "DEFAULT_LAYER_HEIGHT",
    "SLICE_DEVIATION",
    "SLICERS",
    "allowance",
    "overhang_angle",
    "support_free_angle",
    "slicer_margin",
]

#: Layer height in mm the margin is computed for unless told otherwise (PrusaSlicer's
#: and CuraEngine's default for a 0.4 mm nozzle).
DEFAULT_LAYER_HEIGHT = 0.2
#: mm: how far a slicer may move a texture's contour in one layer before comparing it
#: with the next, the ``e`` of eq. (4): CuraEngine 4.13's simplification of the
#: sliced outlines (``Polygons::simplify`` defaults, 5 um).
SLICE_DEVIATION = 0.005
#: The slicers whose rules are modelled (:func:`allowance`).
SLICERS = ("prusaslicer", "curaengine")


def check_critical_angle(angle: float) -> float:
    """``angle`` as a float in (0, 90) degrees, else a ParameterError saying so."""
    try:
        a = float(angle)
    except (TypeError, ValueError):
        raise ParameterError(f"critical_angle must be a number of degrees, got {angle!r}") from None
    if not (np.isfinite(a) and 0.0 < a < 90.0):
        raise ParameterError(
            f"critical_angle must be between 0 and 90 degrees (typical: 45 for FDM/LPBF), got {angle!r}"
        )
    return a


_angle = check_critical_angle


def _layer(layer_height) -> float:
    try:
        h = float(layer_height)
    except (TypeError, ValueError):
        raise ParameterError(f"layer_height must be a number of mm, got {layer_height!r}") from None
    if not (np.isfinite(h) and 0.0 < h <= 2.0):
        raise ParameterError(f"layer_height must be between 0 and 2 mm (typical: 0.2 for a 0.4 mm nozzle), got {layer_height!r}")
    return h


def allowance(slicer: str, critical_angle: float, layer_height: float = DEFAULT_LAYER_HEIGHT) -> float:
    """How far (mm) a layer may reach past the one below before ``slicer`` supports it,
    with its threshold set to ``critical_angle`` degrees: eq. (2) for
    ``"prusaslicer"``, eq. (3) for ``"curaengine"`` (module docstring)."""
    a, h = _angle(critical_angle), _layer(layer_height)
    if slicer == "prusaslicer":
        return h / np.tan(np.radians(min(a + 1.0, 89.999)))
    if slicer == "curaengine":  # coord_t: whole micrometres, truncated
        return max(np.floor((np.tan(np.radians(90.0 - a)) - 0.01) * round(h * 1000.0)) / 1000.0, 0.0)
    raise ParameterError(f"slicer must be one of {', '.join(SLICERS)}, got {slicer!r}")


def overhang_angle(critical_angle: float, slicers=SLICERS) -> float:
    """Degrees from the build plate below which a planar downward facet gets support
    from at least one of ``slicers`` at threshold ``critical_angle`` (the layer
    height cancels, module docstring): 46.0 at 45 for PrusaSlicer and CuraEngine.
    ``texcad check`` counts faces flatter than this as overhangs."""
    h = DEFAULT_LAYER_HEIGHT
    return float(max(np.degrees(np.arctan2(h, allowance(s, critical_angle, h))) for s in slicers))


def support_free_angle(
    critical_angle: float,
    layer_height: float = DEFAULT_LAYER_HEIGHT,
    *,
    deviation: float = SLICE_DEVIATION,
    slicers=SLICERS,
) -> float:
    """Eq. (4): the smallest facet angle (degrees from the build plate) that none of
    ``slicers`` supports at threshold ``critical_angle`` when each slice may move by
    ``deviation`` mm, for layers ``layer_height`` mm high. The limiters keep texture
    facets at least this steep."""
    h = _layer(layer_height)
    e = float(deviation)
    if not (np.isfinite(e) and e >= 0.0):
        raise ParameterError(f"deviation must be a length >= 0 mm, got {deviation!r}")
    room = min(allowance(s, critical_angle, h) for s in slicers) - 2.0 * e
    if room <= 0.0:
        return 90.0
    return float(max(np.degrees(np.arctan2(h, room)), overhang_angle(critical_angle, slicers)))


def slicer_margin(
    critical_angle: float,
    layer_height: float = DEFAULT_LAYER_HEIGHT,
    *,
    deviation: float = SLICE_DEVIATION,
    slicers=SLICERS,
) -> float:
    """Degrees the limiters add to ``critical_angle``: ``support_free_angle - critical_angle``."""
    return support_free_angle(critical_angle, layer_height, deviation=deviation, slicers=slicers) - _angle(critical_angle)
