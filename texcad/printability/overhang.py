"""Printability constraints: overhang-free textures for a chosen build direction.

Definitions (used by every function here and by :mod:`texcad.report`)
---------------------------------------------------------------------
*Build direction* ``d``: unit vector in which the layers grow ("up" in the printer),
given in the frame of the texture or part. The *build plate* is the plane normal to
``d`` through the part's lowest point.

*Critical overhang angle* ``alpha_crit`` (paper, section 2.1.3, figure 4): the smallest
angle between a downward-facing face and the build plate that prints without
support; 45 degrees by default (FDM and LPBF, paper ref. [31]); the number given to
a slicer as its support threshold. A face with unit outward normal ``n`` makes the
angle ``theta = arccos(-n . d)`` with the build plate when it faces down (``n . d <
0``), and it **overhangs** when the slicers support it at that threshold
(:mod:`texcad.printability.rule`): when ``theta < overhang_angle(alpha_crit)``
(46 degrees at 45: PrusaSlicer makes its threshold inclusive by one degree), i.e.
``-n . d > cos(overhang_angle)``. Vertical walls (``theta = 90``) and upward faces
never overhang. Faces lying on the build plate are supported by it and are not
counted. The limiters keep texture facets ``slicer_margin`` degrees above
``alpha_crit`` (:func:`texcad.printability.rule.support_free_angle`).

*Tilt*: a flat textured plate lying on the build plate has ``d = +z`` (tilt 0, the
paper's "orientation to build plate", Table 2). Tilting it by ``a`` degrees so that
the texture's ``toward`` direction rises gives ``d = (sin a cos phi, sin a sin phi,
cos a)`` (see :func:`orientation`).

What can overhang (paper, sections 3.1 and 3.2)
-----------------------------------------------
A heightfield facet of a texture on a flat surface with slope angle ``beta`` along
the in-plane direction of ``d`` makes ``theta = 180 - a - beta`` with the build plate,
so it is safe for every ``beta < 90`` while ``a <= 90 - alpha_crit`` (section 3.1: flat
textures have no undercuts); beyond that, facets rising towards the top of the
printer faster than ``beta_max = 180 - alpha_crit - a`` overhang. The texture's
border walls (normal ``m`` in the surface, the slab's side walls) overhang when
``-m . d > cos(alpha_crit)``: the bottom border once ``a > 90 - alpha_crit``
(figure 11). On curved and sine surfaces the local tilt of the surface adds to ``a``
(section 3.1, last paragraph).

The fixes
---------
* **M-I, edge ramp** (section 2.1.3, figures 4 and 12): heights at every border whose
  wall would overhang are brought down to 0 mm with a ramp no steeper than
  ``beta_max``; borders that face up keep their texture.
* **Slope limiter** (beyond the paper): the largest heightmap ``h' <= h`` whose
  *triangulated* facets (texcad splits cell ``(r, c)`` into ``(a, b, c)`` and
  ``(a, c, d)``, see :func:`texcad.solid.grid_faces`) none overhang, for one build
  direction or for every direction of a set. The per-facet condition
  ``grad h . e <= tan(beta_max)`` (``e`` the unit in-plane direction of ``d``; a slope
  across ``e`` only turns the facet away from ``-d``, so this half-plane is exact for
  facets without cross slope and safe for all) is written as bounds on the height
  differences along the three edge directions of the triangulation (x, y and the
  diagonal), ``h[j] - h[i] <= u``. For a single edge direction (``e`` along x or y)
  this is exact; otherwise the bound is split between the two neighbouring edge
  directions (a slightly stricter wedge; the split that removes the least volume is
  kept). The largest ``h'`` that satisfies a system of difference bounds is a
  greyscale erosion, computed exactly with running minima along the grid lines,
  ``h'_i = U_i + min_{j <= i} (h_j - U_j)``, ``U`` the cumulative bounds, swept until
  nothing changes. Heights only ever go down.

Every result is verified on the triangulated grid (the actual facets, in float64
after rounding the heights to float32); where a facet still overhangs (curved
surfaces, where the model above is linearised) the bounds of that column are
tightened and the erosion repeated.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from ..errors import ParameterError, TexcadWarning
from ..sources import Heightmap
from ..solid import Mesh, grid_faces
from .rule import DEFAULT_LAYER_HEIGHT, check_critical_angle, overhang_angle, slicer_margin

__all__ = [
    "orientation",
    "check_critical_angle",
    "unit_normals",
    "face_areas",
    "build_directions",
    "print_rotation",
    "LimitReport",
    "edge_ramp",
    "limit_overhangs",
    "limit_overhangs_mapped",
    "face_angles",
    "overhang_mask",
    "overhang_area",
    "ThinFeatures",
    "thin_features",
    "DEFAULT_CRITICAL_ANGLE",
    "ANGLE_TOLERANCE",
    "SLICER_MARGIN",
    "printable_lean_slab",
    "DEFAULT_LAYER_HEIGHT",
    "limit_overhangs_tiled",
    "limiter_halo",
    "LimitPlan",
    "TiledLimit",
    "LeanFacets",
    "lean_facets",
]

#: Default critical overhang angle in degrees (paper, section 2.1.3).
DEFAULT_CRITICAL_ANGLE = 45.0
#: Faces within this many degrees of a limit angle given with ``rule="angle"`` count
#: as printable, so that a face at exactly the limit is not flagged by floating-point
#: noise.
ANGLE_TOLERANCE = 1e-3
#: Degrees the limiters add to the default critical angle (45) for 0.2 mm layers:
#: :func:`texcad.printability.rule.slicer_margin` (eq. 4 there), which derives it
#: from PrusaSlicer's and CuraEngine's layer-wise overhang test. Functions that take
#: ``critical_angle`` compute it for that angle (``margin=None``).
SLICER_MARGIN = slicer_margin(DEFAULT_CRITICAL_ANGLE, DEFAULT_LAYER_HEIGHT)

_TOWARD = {"+x": 0.0, "x": 0.0, "+y": 90.0, "y": 90.0, "-x": 180.0, "-y": 270.0}


# ---------------------------------------------------------------------------------
# Build directions
# ---------------------------------------------------------------------------------
def orientation(tilt: float, toward: "str | float" = "+y") -> np.ndarray:
    """Build direction for a surface tilted by ``tilt`` degrees from the build plate.

    The surface's own normal is +z. Tilting it by ``tilt`` degrees so that it rises
    towards ``toward`` (the in-surface direction that points up in the printer)
    gives ``d = (sin a cos phi, sin a sin phi, cos a)``, ``a = tilt``,
    ``phi`` = azimuth of ``toward``. ``tilt = 0`` lays the plate flat, texture up
    (paper, Table 2: "orientation to build plate"); ``tilt = 90`` stands it on the
    border opposite ``toward`` (paper, section 2.1.3: "oriented perpendicular to the
    substrate plate"), which then faces down.

    Args:
        tilt: degrees between the surface and the build plate, 0..180.
        toward: ``"+x"``, ``"-x"``, ``"+y"``, ``"-y"`` or an azimuth in degrees
            (0 = +x, 90 = +y).

    Returns:
        ``(3,)`` float64 unit vector.
    """
    try:
        a = float(tilt)
    except (TypeError, ValueError):
        raise ParameterError(f"tilt must be a number of degrees, got {tilt!r}") from None
    if not (np.isfinite(a) and 0.0 <= a <= 180.0):
        raise ParameterError(f"tilt must be between 0 and 180 degrees, got {tilt!r}")
    if isinstance(toward, str):
        key = toward.strip().lower()
        if key not in _TOWARD:
            raise ParameterError(f"toward must be '+x', '-x', '+y', '-y' or degrees, got {toward!r}")
        phi = _TOWARD[key]
    else:
        phi = float(toward)
        if not np.isfinite(phi):
            raise ParameterError(f"toward must be finite degrees, got {toward!r}")
    ar, pr = np.radians(a), np.radians(phi)
    d = np.array([np.sin(ar) * np.cos(pr), np.sin(ar) * np.sin(pr), np.cos(ar)])
    d[np.abs(d) < 1e-15] = 0.0
    return d


def print_rotation(build_dir) -> np.ndarray:
    """``(3, 3)`` float64 rotation that turns a part from its own frame into the
    printer's, taking the build direction ``build_dir`` (the first, for a set) to +z:
    the smallest rotation doing so (about ``d x z``; a half turn about x for ``-z``).
    The slicer check and the 3MF writer place parts with it."""
    from ..util import rotation_to_z

    return rotation_to_z(build_directions(build_dir)[0])


def build_directions(build_dir) -> np.ndarray:
    """Normalise one build direction ``(3,)`` or a set ``(K, 3)`` to ``(K, 3)`` unit
    float64 vectors (any length > 0; e.g. ``(0, -1, 1)``); an axis word (``"+z"``,
    ``"-y"``) or a list of them names the axis."""
    from ..util import axis_word

    words = [build_dir] if isinstance(build_dir, str) else build_dir
    if isinstance(words, (list, tuple)) and words and all(isinstance(w, str) for w in words):
        axes = [axis_word(w) for w in words]
        if any(a is None for a in axes):
            raise ParameterError(f"build direction {build_dir!r}: use an axis (+x, -x, +y, -y, +z, -z) or three numbers (x, y, z)")
        build_dir = axes
    try:
        d = np.asarray(build_dir, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError(f"build direction {build_dir!r}: use an axis (+x, -x, +y, -y, +z, -z) or three numbers (x, y, z)") from None
    if d.ndim == 1:
        d = d[None, :]
    if d.ndim != 2 or d.shape[1] != 3 or len(d) == 0:
        raise ParameterError(f"a build direction is a 3-vector (x, y, z) or a list of them, got shape {d.shape}")
    n = np.linalg.norm(d, axis=1)
    if not (np.isfinite(d).all() and (n > 0).all()):
        raise ParameterError(f"build directions must be finite, non-zero vectors, got {build_dir!r}")
    return d / n[:, None]


# ---------------------------------------------------------------------------------
# Overhang detection on any mesh
# ---------------------------------------------------------------------------------
def face_angles(mesh: Mesh, build_dir) -> np.ndarray:
    """Angle in degrees between each face and the build plate, signed by direction.

    ``90 - angle(n, d)``: +90 for a face looking straight up, 0 for a vertical
    wall, -90 for a face looking straight down. A downward face (negative value)
    makes ``|value|`` degrees with the build plate. Degenerate faces get +90.

    Returns:
        ``(M,)`` float64 degrees.
    """
    d = build_directions(build_dir)[0]
    n = unit_normals(mesh)
    cosang = np.clip(n @ d, -1.0, 1.0)
    out = 90.0 - np.degrees(np.arccos(cosang))
    out[~np.any(n != 0, axis=1)] = 90.0
    return out


def unit_normals(mesh: Mesh) -> np.ndarray:
    """``(M, 3)`` float64 unit normals of a mesh's faces (zero for degenerate faces)."""
    v = mesh.vertices.astype(np.float64)
    f = mesh.faces
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)


def face_areas(mesh: Mesh) -> np.ndarray:
    """``(M,)`` float64 areas of a mesh's faces, mm^2."""
    v = mesh.vertices.astype(np.float64)
    f = mesh.faces
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def overhang_mask(
    mesh: Mesh,
    build_dir=(0.0, 0.0, 1.0),
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    *,
    plate_tolerance: float = 0.01,
    rule: str = "slicers",
) -> np.ndarray:
    """Faces that overhang when ``mesh`` is printed along ``build_dir``.

    ``rule="slicers"`` (``texcad check``): a face overhangs when PrusaSlicer or
    CuraEngine would support it with their threshold at ``critical_angle``, i.e.
    when it faces down at less than :func:`~texcad.printability.rule.overhang_angle`
    degrees to the build plate (46 at 45; module docstring). ``rule="angle"``: at
    less than ``critical_angle`` itself, minus ``ANGLE_TOLERANCE`` (for checking a
    limit angle, e.g. the limiter's). Faces whose three vertices all lie within
    ``plate_tolerance`` mm of the lowest point along ``d`` rest on the build plate
    and do not count.

    Args:
        mesh: any triangle mesh (mm).
        build_dir: ``(3,)`` build direction in the mesh's frame (any length).
        critical_angle: degrees between face and build plate, 0 < angle < 90.
        plate_tolerance: mm; how close to the lowest point a face must be to count
            as lying on the build plate.
        rule: ``"slicers"`` or ``"angle"``.

    Returns:
        ``(M,)`` bool.
    """
    d = build_directions(build_dir)[0]
    crit = check_critical_angle(critical_angle)
    n = unit_normals(mesh)
    over = -(n @ d) > np.cos(np.radians(_boundary(crit, rule)))
    if len(mesh.vertices):
        level = mesh.vertices.astype(np.float64) @ d
        low = level <= level.min() + float(plate_tolerance)
        on_plate = low[mesh.faces].all(axis=1)
        over &= ~on_plate
    return over


def _boundary(crit: float, rule: str) -> float:
    """Degrees from the build plate below which a face overhangs, by ``rule``."""
    if rule == "slicers":
        return overhang_angle(crit)
    if rule == "angle":
        return crit - ANGLE_TOLERANCE
    raise ParameterError(f"rule must be 'slicers' (what PrusaSlicer and CuraEngine support) or 'angle', got {rule!r}")


def overhang_area(
    mesh: Mesh,
    build_dir=(0.0, 0.0, 1.0),
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    *,
    faces: np.ndarray | None = None,
    plate_tolerance: float = 0.01,
    rule: str = "slicers",
) -> float:
    """Area in mm^2 of the overhanging faces (:func:`overhang_mask`, same ``rule``),
    optionally only among ``faces`` (indices or a bool mask, e.g.
    ``mesh.groups["texture"]``)."""
    over = overhang_mask(mesh, build_dir, critical_angle, plate_tolerance=plate_tolerance, rule=rule)
    if faces is not None:
        sel = np.zeros(len(over), dtype=bool)
        sel[np.asarray(faces)] = True
        over &= sel
    return float(face_areas(mesh)[over].sum())


# ---------------------------------------------------------------------------------
# The slope limiter and M-I
# ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class LimitReport:
    """What :func:`limit_overhangs` / :func:`edge_ramp` changed.

    Attributes:
        removed_volume_mm3: sum over pixels of the height removed times the pixel
            area (mm^3).
        max_removed_mm: largest height removed at one pixel (mm).
        touched_fraction: fraction of pixels lowered by more than 1 nm.
        ramped_borders: borders ramped to 0 mm by M-I: ``"x0"`` (column 0),
            ``"x1"`` (last column), ``"y0"`` (row 0), ``"y1"`` (last row).
        critical_angle_deg: the critical overhang angle used (degrees).
        margin_deg: safety margin added to it for the facets (degrees).
        directions: ``(K, 3)`` unit build directions honoured.
        remaining_overhang_mm2: area (mm^2, on the verification grid) of texture
            facets that still overhang: 0 unless the surface itself overhangs.
        surface_overhang: True if the bare surface faces down past the critical
            angle somewhere (the texture there was left alone; it needs support).
        iterations: verification rounds used (1 = exact on the first try).
    """

    removed_volume_mm3: float
    max_removed_mm: float
    touched_fraction: float
    ramped_borders: tuple[str, ...]
    critical_angle_deg: float
    margin_deg: float
    directions: np.ndarray = field(repr=False)
    remaining_overhang_mm2: float = 0.0
    surface_overhang: bool = False
    iterations: int = 1

    def to_dict(self) -> dict:
        """Plain-type dict (JSON-ready)."""
        return {
            "removed_volume_mm3": self.removed_volume_mm3,
            "max_removed_mm": self.max_removed_mm,
            "touched_fraction": self.touched_fraction,
            "ramped_borders": list(self.ramped_borders),
            "critical_angle_deg": self.critical_angle_deg,
            "margin_deg": self.margin_deg,
            "directions": np.asarray(self.directions).tolist(),
            "remaining_overhang_mm2": self.remaining_overhang_mm2,
            "surface_overhang": self.surface_overhang,
            "iterations": self.iterations,
        }


def edge_ramp(
    heightmap: Heightmap,
    build_dir,
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    *,
    tilt: "np.ndarray | Sequence[float] | None" = None,
    offset: str = "normal",
) -> tuple[Heightmap, LimitReport]:
    """Edge modification M-I (paper, section 2.1.3, figures 4, 11 and 12).

    Every border whose side wall would overhang for some build direction (wall
    normal ``m``: ``-m . d > cos(alpha_crit)``) is brought down to 0 mm, and the
    texture next to it is cut by the ramp ``R`` that rises from 0 at that border
    no faster than the steepest facet that does not overhang (``beta_max = 180 -
    alpha_crit - a``, e.g. 45 degrees for a plate standing upright with
    ``alpha_crit = 45``): ``h' = min(h, R)``. Borders that face up or sideways keep
    their texture; the interior of the texture is not changed (use
    :func:`limit_overhangs` for that).

    Args:
        heightmap: the texture (mm).
        build_dir: ``(3,)`` or ``(K, 3)`` build direction(s), texture frame (flat)
            or part frame (``tilt`` given; see :func:`limit_overhangs_mapped`).
        critical_angle: degrees, 0..90.
        tilt: optional per-column surface tangent angle in degrees (mapped
            surfaces, see :func:`limit_overhangs_mapped`).
        offset: ``"normal"`` or ``"vertical"`` (mapped surfaces).

    Returns:
        ``(heightmap', report)``.
    """
    return _limit(heightmap, build_dir, critical_angle, tilt=tilt, offset=offset, edges=True, facets=False, margin=None)


def limit_overhangs(
    heightmap: Heightmap,
    build_dir,
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    *,
    edges: bool = True,
    margin: float | None = None,
    layer_height: float = DEFAULT_LAYER_HEIGHT,
) -> tuple[Heightmap, LimitReport]:
    """Lower a flat texture as little as possible so that no facet overhangs.

    Returns the largest heightmap ``h' <= h`` whose triangulated facets (as meshed
    by :func:`texcad.solid.heightfield_slab`) make at least ``critical_angle +
    margin`` degrees with the build plate whenever they face down, for every
    build direction given (module docstring: difference bounds along the mesh's
    edge directions, solved by running-minimum erosion). With ``edges`` the
    borders whose walls would overhang are ramped to 0 mm first (M-I,
    :func:`edge_ramp`). Exact (maximal) when each direction's in-plane part is
    along x or y; slightly conservative for oblique directions.

    Args:
        heightmap: the texture (mm), on a flat surface with normal +z.
        build_dir: ``(3,)`` build direction in the texture frame (x, y along the
            texture, z = surface normal), or ``(K, 3)`` directions the texture must
            print in (e.g. ``[orientation(a) for a in (0, 15, 30, 45, 60)]``).
        critical_angle: critical overhang angle in degrees (0..90, default 45).
        edges: also apply M-I at the borders.
        margin: degrees added to ``critical_angle`` for the facets; None (the
            default): :func:`texcad.printability.rule.slicer_margin` for
            ``critical_angle`` and ``layer_height`` (2.7 at 45 and 0.2 mm), so that
            PrusaSlicer and CuraEngine with their overhang threshold set to
            ``critical_angle`` put no support under the texture. The result is
            verified to keep ``critical_angle + max(margin / 2, margin - 0.25)``.
        layer_height: the layer height in mm the part will be sliced with (the
            margin grows for thinner layers).

    Returns:
        ``(heightmap', report)``; ``report.removed_volume_mm3``,
        ``max_removed_mm`` and ``touched_fraction`` say how much was removed.

    Raises:
        ParameterError: bad direction or angle.
    """
    return _limit(heightmap, build_dir, critical_angle, tilt=None, offset="normal", edges=edges, facets=True, margin=margin,
                  layer_height=layer_height)


def limit_overhangs_mapped(
    heightmap: Heightmap,
    tilt: "np.ndarray | Sequence[float]",
    build_dir,
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    *,
    offset: str = "normal",
    edges: bool = True,
    margin: float | None = None,
    layer_height: float = DEFAULT_LAYER_HEIGHT,
) -> tuple[Heightmap, LimitReport]:
    """The slope limiter for a texture mapped on a 2.5D surface (paper, section 3.1).

    The surface is an extrusion along y of a profile in the xz-plane (paper, Eq.
    (2)-(3)); texture x runs along the profile's arc length and texture y along the
    extrusion. At texture column ``c`` the profile's tangent makes ``tilt[c]``
    degrees with +x, measured towards +z: the surface runs along
    ``t = (cos tilt, 0, sin tilt)`` and its outward normal is
    ``nu = (-sin tilt, 0, cos tilt)`` (tilt 0 everywhere = the flat plate). The
    local tilt of the surface adds to the texture's slope: a facet with local
    gradient ``(p, q)`` (mm/mm along arc length and y) has the normal

    * ``offset="normal"`` (angle-preserving mapping, Algorithm 2: heights along
      ``nu``): ``n ~ nu - p t - q y``;
    * ``offset="vertical"`` (distance-preserving mapping, Algorithm 1: heights added
      to z; needs ``cos(tilt) > 0``): ``n ~ (-(tan tilt + p / cos tilt), -q, 1)``;

    and must satisfy ``-n . d <= cos(critical_angle + margin)``. Each cell column
    gets its own half-plane bound on ``(p, q)``, turned into difference bounds as in
    :func:`limit_overhangs`. The profile is rebuilt from ``tilt`` (chord between
    columns ``c`` and ``c+1`` of length ``pitch_x`` at the mean angle), every facet
    is checked in 3-D, and columns that still overhang (surface curvature changes
    the spacing of offset points) are tightened until none does. Where the bare
    surface itself overhangs the texture is left alone and a
    :class:`~texcad.errors.TexcadWarning` names the columns.

    Args:
        heightmap: the texture (mm), x along the arc length.
        tilt: ``(cols,)`` surface tangent angle per texture column, degrees.
        build_dir: ``(3,)`` or ``(K, 3)`` build direction(s) in the part frame
            (x across the profile, y along the extrusion, z up in the profile).
        critical_angle: degrees, 0..90.
        offset: ``"normal"`` or ``"vertical"``, as the mapping applies heights.
        edges: also apply M-I at the borders whose walls would overhang (walls
            along ``nu`` at the profile's ends for ``"normal"``, vertical for
            ``"vertical"``).
        margin: degrees added to the critical angle for the facets (default
            None: the slicers' margin; see :func:`limit_overhangs`).
        layer_height: mm (see :func:`limit_overhangs`).

    Returns:
        ``(heightmap', report)``.
    """
    if tilt is None:
        raise ParameterError("tilt is required: one surface angle in degrees per texture column")
    return _limit(heightmap, build_dir, critical_angle, tilt=tilt, offset=offset, edges=edges, facets=True, margin=margin,
                  layer_height=layer_height)


# -- internals -------------------------------------------------------------------
_BORDERS = ("x0", "x1", "y0", "y1")


def _edge_vectors(px: float, py: float) -> np.ndarray:
    """The six oriented edge directions of the triangulation, counter-clockwise:
    +x, +diagonal, +y, -x, -diagonal, -y (mm)."""
    return np.array([[px, 0.0], [px, py], [0.0, py], [-px, 0.0], [-px, -py], [0.0, -py]])


def _halfplanes(psi_m: np.ndarray, d: np.ndarray, cos_crit: float, cos_nominal: float, offset: str):
    """Per cell column: the bound ``p wx + q wy <= g`` on the local gradient, and
    whether the bare surface itself overhangs there (then no bound, ``g = inf``).

    ``psi_m`` are the cells' tangent angles (radians), ``d`` one unit direction,
    ``cos_crit = cos(critical + margin)``, ``cos_nominal = cos(critical - tol)``.
    """
    crit = np.arccos(cos_crit)
    c, s = np.cos(psi_m), np.sin(psi_m)
    d_nu = -s * d[0] + c * d[2]  # d . nu: the surface normal's component
    surface_bad = -d_nu > cos_nominal
    if offset == "normal":
        ex, ey, dz = c * d[0] + s * d[2], np.full_like(c, d[1]), d_nu
    else:
        ex, ey, dz = np.full_like(c, d[0]), np.full_like(c, d[1]), np.full_like(c, d[2])
    en = np.hypot(ex, ey)
    a = np.arctan2(en, dz)  # angle between the (local or global) z and d
    beta = np.pi - crit - a  # steepest safe slope angle along e
    with np.errstate(divide="ignore", invalid="ignore"):
        smax = np.where(beta >= np.pi / 2, np.inf, np.tan(np.clip(beta, 0.0, np.pi / 2)))
        ux, uy = np.where(en > 0, ex / en, 0.0), np.where(en > 0, ey / en, 0.0)
    if offset == "normal":
        wx, wy, g = ux, uy, smax
    else:
        # Global heightfield: grad = (tan psi + p / cos psi, q); grad . e <= smax.
        wx, wy = ux / c, uy
        g = smax - ux * np.tan(psi_m)
    g = np.where(surface_bad | ~np.isfinite(g), np.inf, np.maximum(g, 0.0))
    return wx, wy, g, surface_bad


def _edge_bounds(h_range: float, psi_m, dirs, cos_crit, cos_nominal, offset, px, py, split: float, scale):
    """Difference bounds per edge direction (module docstring).

    Returns ``(bounds, oblique, surface_bad)``: ``bounds`` is ``(6, C-1)`` float64
    per cell column (``inf`` = unbounded), in the order of :func:`_edge_vectors`.
    """
    ncell = len(psi_m)
    bounds = np.full((6, ncell), np.inf)
    vec = _edge_vectors(px, py)
    ang = np.arctan2(vec[:, 1], vec[:, 0]) % (2 * np.pi)
    oblique = False
    surface_bad = np.zeros(ncell, dtype=bool)
    for d in dirs:  # per build direction
        wx, wy, g, bad = _halfplanes(psi_m, d, cos_crit, cos_nominal, offset)
        surface_bad |= bad
        act = np.isfinite(g) & (np.hypot(wx, wy) > 0)
        if not act.any():
            continue
        th = np.arctan2(wy, wx) % (2 * np.pi)
        k = np.clip(np.searchsorted(ang, th, side="right") - 1, 0, 5)
        k2 = (k + 1) % 6
        v1, v2 = vec[k], vec[k2]
        det = v1[:, 0] * v2[:, 1] - v1[:, 1] * v2[:, 0]
        l1 = (wx * v2[:, 1] - wy * v2[:, 0]) / det
        l2 = (v1[:, 0] * wy - v1[:, 1] * wx) / det
        tiny = 1e-9 * (np.abs(l1) + np.abs(l2))
        only1 = l2 <= tiny
        only2 = (l1 <= tiny) & ~only1
        both = act & ~only1 & ~only2
        oblique |= bool(both.any())
        with np.errstate(divide="ignore", invalid="ignore"):
            u1 = np.where(only1, g / l1, np.where(both, split * g / l1, np.inf))
            u2 = np.where(only2, g / l2, np.where(both, (1.0 - split) * g / l2, np.inf))
        cols = np.arange(ncell)
        for kk, uu in ((k, u1), (k2, u2)):
            sel = act & np.isfinite(uu)
            np.minimum.at(bounds, (kk[sel], cols[sel]), uu[sel])
    bounds = np.where(np.isfinite(bounds), bounds * scale[None, :], np.inf)
    big = h_range + 1.0  # a bound larger than the height range never binds
    return np.minimum(bounds, big), oblique, surface_bad


def _erode(h: np.ndarray, bounds: np.ndarray, max_sweeps: int = 500) -> np.ndarray:
    """Largest ``h' <= h`` with ``h'[j] - h'[i] <= u`` along every bounded edge.

    ``bounds`` ``(6, C-1)`` per cell column in the order +x, +diag, +y, -x, -diag,
    -y; +y/-y bounds hold for the cell's two vertical edges (the tighter of the two
    cells wins). Each pass is a running minimum along grid lines:
    ``h'_i = U_i + min_{j <= i}(h_j - U_j)`` (``U`` = cumulative bound); passes are
    swept until nothing changes (the bounds vary by column).
    """
    return _erode_window(h, _erosion_lines(bounds), 0, 0, h.shape[0], max_sweeps)


@dataclass(frozen=True)
class _Lines:
    """The erosion's cumulative bounds for the whole grid (float64 mm, 1-D: ``O(C)``):
    along +x and -x (``ux_p``, ``ux_m``, length C; ``ux_m`` indexed from the last
    column), along the diagonals (``ud_p``, ``ud_m``), and the per-column +y / -y
    bounds (``by_p``, ``by_m``, length C). A window of the grid slices them, so its
    running minima use the very numbers the whole grid's do."""

    ux_p: np.ndarray
    ux_m: np.ndarray
    ud_p: np.ndarray
    ud_m: np.ndarray
    by_p: np.ndarray
    by_m: np.ndarray


def _erosion_lines(bounds: np.ndarray) -> _Lines:
    """:class:`_Lines` of ``bounds`` ``(6, C-1)`` (see :func:`_erode`)."""
    bx_p, bd_p, by_pc, bx_m, bd_m, by_mc = bounds
    by_p = np.minimum(np.concatenate([by_pc, by_pc[-1:]]), np.concatenate([by_pc[:1], by_pc]))
    by_m = np.minimum(np.concatenate([by_mc, by_mc[-1:]]), np.concatenate([by_mc[:1], by_mc]))
    return _Lines(
        ux_p=np.concatenate([[0.0], np.cumsum(bx_p)]),
        ux_m=np.concatenate([[0.0], np.cumsum(bx_m[::-1])]),
        ud_p=np.concatenate([[0.0], np.cumsum(bd_p)]),
        ud_m=np.concatenate([[0.0], np.cumsum(bd_m[::-1])]),
        by_p=by_p,
        by_m=by_m,
    )


def _erode_window(h: np.ndarray, lines: _Lines, r0: int, c0: int, rows: int, max_sweeps: int = 500) -> np.ndarray:
    """:func:`_erode` on the window ``h`` of a grid of ``rows`` rows whose first
    pixel is ``(r0, c0)``: the same running minima as on the whole grid, restricted
    to the window (the cumulative bounds sliced from ``lines``), swept until the
    window does not change."""
    h = h.copy()
    n, m = h.shape
    C = len(lines.ux_p)
    cols, back = slice(c0, c0 + m), slice(C - c0 - m, C - c0)
    ux_p, ux_m = lines.ux_p[cols], lines.ux_m[back]
    ud_p, ud_m = lines.ud_p[cols], lines.ud_m[back]
    uy_p = np.arange(r0, r0 + n, dtype=np.float64)[:, None] * lines.by_p[None, cols]
    uy_m = np.arange(rows - r0 - n, rows - r0, dtype=np.float64)[:, None] * lines.by_m[None, cols]

    def line_min(a: np.ndarray, U: np.ndarray, axis: int) -> np.ndarray:
        return U + np.minimum.accumulate(a - U, axis=axis)

    def diag_min(a: np.ndarray, U: np.ndarray) -> np.ndarray:
        z = a - U[None, :]
        for r in range(1, z.shape[0]):  # per row (a pass), vectorized over columns
            np.minimum(z[r, 1:], z[r - 1, :-1], out=z[r, 1:])
        return z + U[None, :]

    for _ in range(max_sweeps):
        before = h.copy()
        h = line_min(h, ux_p[None, :], 1)
        h = line_min(h[:, ::-1], ux_m[None, :], 1)[:, ::-1]
        h = line_min(h, uy_p, 0)
        h = line_min(h[::-1], uy_m, 0)[::-1]
        h = diag_min(h, ud_p)
        h = diag_min(h[::-1, ::-1], ud_m)[::-1, ::-1]
        if np.array_equal(h, before):
            break
    return h


def _border_walls(psi: np.ndarray, offset: str) -> dict[str, np.ndarray]:
    """Outward wall normals (part frame) of the four borders."""
    if offset == "normal":
        t0 = np.array([np.cos(psi[0]), 0.0, np.sin(psi[0])])
        t1 = np.array([np.cos(psi[-1]), 0.0, np.sin(psi[-1])])
    else:
        t0 = t1 = np.array([1.0, 0.0, 0.0])
    return {"x0": -t0, "x1": t1, "y0": np.array([0.0, -1.0, 0.0]), "y1": np.array([0.0, 1.0, 0.0])}


def _grid_points(h: np.ndarray, psi: np.ndarray, px: float, py: float, offset: str) -> np.ndarray:
    """Top-grid vertices ``(R, C, 3)`` float64 of the texture draped on the profile
    rebuilt from ``psi`` (chord ``px`` at the mean angle of its two columns)."""
    R, C = h.shape
    pm = 0.5 * (psi[:-1] + psi[1:])
    X = np.concatenate([[0.0], np.cumsum(px * np.cos(pm))])
    Z = np.concatenate([[0.0], np.cumsum(px * np.sin(pm))])
    if offset == "normal":
        nx, nz = -np.sin(psi), np.cos(psi)
    else:
        nx, nz = np.zeros(C), np.ones(C)
    P = np.empty((R, C, 3))
    P[..., 0] = X[None, :] + h * nx[None, :]
    P[..., 1] = ((np.arange(R) + 0.5) * py)[:, None]
    P[..., 2] = Z[None, :] + h * nz[None, :]
    return P


def _facet_violations(P: np.ndarray, dirs: np.ndarray, cos_limit: float):
    """Per triangle of :func:`grid_faces`: overhang for any direction (bool) and area."""
    R, C = P.shape[:2]
    v = P.reshape(-1, 3)
    f = grid_faces(R, C).astype(np.int64)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    ln = np.linalg.norm(n, axis=1)
    bad = np.zeros(len(f), dtype=bool)
    for d in dirs:
        bad |= -(n @ d) > cos_limit * ln
    return bad, 0.5 * ln


def _limit(hm, build_dir, critical_angle, *, tilt, offset, edges, facets, margin, layer_height=DEFAULT_LAYER_HEIGHT):
    if not isinstance(hm, Heightmap):
        raise ParameterError(f"expected a texcad Heightmap, got {type(hm).__name__}")
    dirs = build_directions(build_dir)
    crit = check_critical_angle(critical_angle)
    margin = slicer_margin(crit, layer_height) if margin is None else float(margin)
    if not (np.isfinite(margin) and 0.0 <= margin < 90.0 - crit):
        raise ParameterError(f"margin must be between 0 and {90 - crit:g} degrees, got {margin!r}")
    if offset not in ("normal", "vertical"):
        raise ParameterError(f"offset must be 'normal' (angle-preserving) or 'vertical' (distance-preserving), got {offset!r}")
    R, C = hm.shape
    px, py = hm.pitch
    if tilt is None:
        psi = np.zeros(C)
    else:
        psi = np.radians(np.asarray(tilt, dtype=np.float64).ravel())
        if psi.shape != (C,) or not np.isfinite(psi).all():
            raise ParameterError(
                f"tilt must hold one finite angle in degrees per texture column ({C}), got shape {np.shape(tilt)}"
            )
        if offset == "vertical" and (np.cos(psi) <= 1e-6).any():
            raise ParameterError(
                "offset='vertical' (heights added to z) needs an upward-looking profile, |tilt| < 90 degrees; "
                "use offset='normal' for steeper or closed profiles"
            )
    h0 = hm.heights.astype(np.float64)
    psi_m = 0.5 * (psi[:-1] + psi[1:])
    cos_facet = np.cos(np.radians(crit + margin))
    cos_wall = np.cos(np.radians(overhang_angle(crit)))  # walls the slicers would support
    h_range = float(h0.max() - min(0.0, float(h0.min())))

    # Borders whose walls overhang (M-I).
    walls = _border_walls(psi, offset)
    ramped = tuple(b for b in _BORDERS if edges and bool((-(dirs @ walls[b]) > cos_wall).any()))
    start = h0.copy()
    if ramped:
        border = np.zeros((R, C), dtype=bool)
        border[:, 0] |= "x0" in ramped
        border[:, -1] |= "x1" in ramped
        border[0, :] |= "y0" in ramped
        border[-1, :] |= "y1" in ramped
        if facets:
            start[border] = np.minimum(start[border], 0.0)
        else:
            ramp_seed = np.full((R, C), h0.max())
            ramp_seed[border] = 0.0

    def run(split: float, scale: np.ndarray):
        bounds, oblique, bad = _edge_bounds(h_range, psi_m, dirs, cos_facet, cos_wall, offset, px, py, split, scale)
        if facets:
            out = _erode(start, bounds)
        elif ramped:
            out = np.minimum(h0, _erode(ramp_seed, bounds))
        else:
            out = h0.copy()
        return out.astype(np.float32), oblique, bad

    scale = np.ones(C - 1)
    out, oblique, bad = run(0.5, scale)
    split = 0.5
    if oblique:  # choose the split of oblique bounds that removes least
        best = (float((h0 - out).sum()), 0.5, out)
        for s in (0.2, 0.35, 0.65, 0.8):
            o, _, _ = run(s, scale)
            best = min(best, (float((h0 - o).sum()), s, o), key=lambda t: t[0])
        _, split, out = best
    iterations = 1
    remaining = 0.0
    if facets:
        cos_check = np.cos(np.radians(crit + max(0.5 * margin, margin - 0.25)))
        while True:  # verify on the triangulated facets; tighten where needed
            P = _grid_points(out.astype(np.float64), psi, px, py, offset)
            viol, area = _facet_violations(P, dirs, cos_check)
            cell_col = (np.arange(len(viol)) // 2) % (C - 1)
            fix = viol & ~bad[cell_col]
            if not fix.any() or iterations >= 40:
                break
            scale[np.unique(cell_col[fix])] *= 0.8
            out, _, _ = run(split, scale)
            iterations += 1
        remaining = float(area[viol].sum())
        if bad.any():
            xs = (np.flatnonzero(bad) + 1.0) * px
            warnings.warn(
                f"the surface itself faces down past {crit:g} degrees between x = {xs.min():.1f} and "
                f"{xs.max():.1f} mm (arc length) for a build direction; the texture there is left as is "
                "(it needs support anyway): choose a build direction closer to the surface normal",
                TexcadWarning,
                stacklevel=3,
            )
    removed = h0 - out.astype(np.float64)
    rep = LimitReport(
        removed_volume_mm3=float(removed.sum() * px * py),
        max_removed_mm=float(removed.max(initial=0.0)),
        touched_fraction=float(np.count_nonzero(removed > 1e-6) / removed.size),
        ramped_borders=ramped,
        critical_angle_deg=crit,
        margin_deg=margin,
        directions=dirs,
        remaining_overhang_mm2=remaining,
        surface_overhang=bool(bad.any()) if facets else False,
        iterations=iterations,
    )
    return Heightmap(out, hm.pitch), rep


# ---------------------------------------------------------------------------------
# The limiter tile by tile
# ---------------------------------------------------------------------------------
def limiter_halo(bounds: np.ndarray, h_range: float) -> "tuple[int, int] | None":
    """``(rows, cols)``: how far (pixels) a pixel's limited height can depend on other
    pixels under the difference ``bounds`` (``(6, C-1)`` mm per edge, as
    :func:`_erode` takes them) of a heightfield whose heights span ``h_range`` mm;
    None where that reach is unbounded (a zero bound).

    Why it is finite. The limiter's result is the largest ``h' <= s`` (``s`` the
    heights after M-I set the ramped borders to at most 0) with ``h'[j] - h'[i] <=
    u(i -> j)`` along every bounded edge: a system of difference bounds, whose
    largest solution is ``h'[k] = min_i (s[i] + dist(i, k))``, ``dist`` the shortest
    path from ``i`` to ``k`` with the edges weighted by their bounds (the greyscale
    erosion :func:`_erode` computes). Since ``h'[k] <= s[k] <= max s`` and ``s[i] >=
    min s``, a pixel ``i`` can be the minimiser only if ``dist(i, k) <= max s - min s
    <= h_range``. An edge of weight ``u`` costs ``u``; every edge that moves a column
    (``+-x``, ``+-diagonal``) weighs at least ``u_x`` (the smallest such bound; one
    larger than ``h_range`` never lies on such a path), every edge that moves a row
    (``+-y``, ``+-diagonal``) at least ``u_y``. So a path that matters moves at most
    ``h_range / u_x`` columns and ``h_range / u_y`` rows, and ``h'`` on a block of
    pixels is the limiter run on the block grown by that many columns and rows (its
    *halo*): a path from outside the halo is longer than the best one by at least
    one more edge (``u_x`` or ``u_y``, far above float64 rounding), so the window's
    running minima pick the same values as the whole grid's (with the same
    cumulative bounds: :class:`_Lines`), bit for bit. The halo holds two pixels more
    than that: one for the argument's margin, one for the facets of the block's last
    row and column, which the verification checks.

    In degrees: along the in-plane direction of ``d`` a bound is ``tan(beta_max)``
    per mm with ``beta_max = 180 - (critical + margin) - tilt``, so the halo is about
    ``h_range / (pitch tan(beta_max))`` pixels (8.7 rows, a halo of 10, for a 1 mm
    texture at 0.125 mm standing upright at 45 degrees; oblique directions split the
    bound over two edge directions, which at most doubles that).
    """
    def steps(ks: list) -> "int | None":
        b = bounds[ks]
        u = b[b <= h_range]
        if u.size == 0:
            return 0
        umin = float(u.min())
        return None if umin <= 0.0 else int(np.floor(h_range / umin)) + 2

    cols, rows = steps([0, 1, 3, 4]), steps([1, 2, 4, 5])
    return None if cols is None or rows is None else (rows, cols)


@dataclass(frozen=True)
class LimitPlan:
    """The overhang limiter's whole-grid state, with which any block of a flat
    heightfield is limited alone (:func:`limit_overhangs_tiled`).

    Attributes:
        shape: ``(R, C)`` pixels of the whole heightfield; pitch: ``(px, py)`` mm.
        ramped: the borders M-I brings down to 0 mm (as :class:`LimitReport`).
        halo: ``(rows, cols)`` pixels a block is grown by (:func:`limiter_halo`).
        lines: the erosion's cumulative bounds for the whole grid (``O(C)`` floats).
    """

    shape: tuple
    pitch: tuple
    ramped: tuple
    halo: tuple
    lines: _Lines = field(repr=False)

    def window(self, rows: slice, cols: slice) -> tuple[slice, slice]:
        """The block ``rows, cols`` grown by the halo, within the grid."""
        (R, C), (hr, hc) = self.shape, self.halo
        return slice(max(rows.start - hr, 0), min(rows.stop + hr, R)), slice(max(cols.start - hc, 0), min(cols.stop + hc, C))

    def limit(self, read, rows: slice, cols: slice) -> tuple[np.ndarray, np.ndarray]:
        """``(h0, h')``: the block's heights as read (float64) and limited (float32), mm;
        ``read(rows, cols)`` gives the unlimited heights of any block (mm)."""
        wr, wc = self.window(rows, cols)
        h0 = np.asarray(read(wr, wc), dtype=np.float64)
        start = h0.copy()
        R, C = self.shape
        for name, edge, sel in (("x0", wc.start == 0, np.s_[:, 0]), ("x1", wc.stop == C, np.s_[:, -1]),
                                ("y0", wr.start == 0, np.s_[0, :]), ("y1", wr.stop == R, np.s_[-1, :])):
            if name in self.ramped and edge:  # M-I: as _limit's border mask
                start[sel] = np.minimum(start[sel], 0.0)
        out = _erode_window(start, self.lines, wr.start, wc.start, R).astype(np.float32)
        inner = np.s_[rows.start - wr.start : rows.stop - wr.start, cols.start - wc.start : cols.stop - wc.start]
        return h0[inner], out[inner]


@dataclass(frozen=True)
class TiledLimit:
    """What :func:`limit_overhangs_tiled` found.

    Attributes:
        report: the :class:`LimitReport`, as :func:`limit_overhangs` gives it.
        plan: the :class:`LimitPlan` the stored blocks were limited with.
        volume: the limited heights' :func:`texcad.solid.mesh.heightfield_volume`,
            mm^3, and ``slack`` its slack (mm^3), summed block by block.
        top: the highest limited height, mm.
    """

    report: LimitReport
    plan: LimitPlan
    volume: float
    slack: float
    top: float


def _limit_angles(build_dir, critical_angle, margin, layer_height) -> tuple[np.ndarray, float, float]:
    """``(directions, critical, margin)`` checked, as :func:`_limit` takes them."""
    dirs = build_directions(build_dir)
    crit = check_critical_angle(critical_angle)
    margin = slicer_margin(crit, layer_height) if margin is None else float(margin)
    if not (np.isfinite(margin) and 0.0 <= margin < 90.0 - crit):
        raise ParameterError(f"margin must be between 0 and {90 - crit:g} degrees, got {margin!r}")
    return dirs, crit, margin


def _grid_blocks(shape: tuple, block: int) -> list:
    """The ``(rows, cols)`` slices of ``block`` x ``block`` pixels covering ``shape``, row-major."""
    R, C = shape
    return [(slice(r, min(r + block, R)), slice(c, min(c + block, C))) for r in range(0, R, block) for c in range(0, C, block)]


def limit_overhangs_tiled(read, shape, pitch, build_dir, critical_angle: float = DEFAULT_CRITICAL_ANGLE, *, block: int,
                          store, edges: bool = True, margin: float | None = None,
                          layer_height: float = DEFAULT_LAYER_HEIGHT, progress=None) -> TiledLimit:
    """:func:`limit_overhangs` on a flat heightfield too large to hold, a block at a
    time: the same heights, bit for bit (tested), in memory that goes with one block
    and its halo (:func:`limiter_halo`) plus ``O(C)`` numbers.

    The untiled limiter's steps, each a pass over the blocks: the height range; for
    an oblique direction, the split of its bound that removes least (summed over the
    blocks: the same choice unless two splits remove the same volume within float64
    rounding); then the verification on the triangulated facets, whose tightened
    columns (a 1-D scale, as in :func:`_limit`) start another pass until none is
    left (on a flat plate the first pass normally finds none). Each block is limited
    from the block grown by the halo, with the whole grid's cumulative bounds.

    Args:
        read: ``read(rows, cols)`` -> the unlimited heights (mm) of any block.
        shape: ``(R, C)`` pixels; pitch: ``(px, py)`` mm.
        build_dir, critical_angle, edges, margin, layer_height: as :func:`limit_overhangs`
            (degrees, mm).
        block: pixels per side of a block with its halo (memory goes with its
            square; the blocks are that less twice the halo, at least 32).
        store: ``store(rows, cols, heights)`` takes each block's limited float32
            heights (mm); a later pass stores every block again, the last is final.
        progress: ``progress(fraction, message)`` or None.

    Returns:
        :class:`TiledLimit`.

    Raises:
        ParameterError: bad direction or angle, or a bound of 0 (a direction just
            short of facing the texture down: its reach is the whole grid).
    """
    dirs, crit, margin = _limit_angles(build_dir, critical_angle, margin, layer_height)
    R, C = (int(n) for n in shape)
    px, py = (float(p) for p in pitch)
    blocks = _grid_blocks((R, C), int(block))
    lo = min(float(np.min(read(*b))) for b in blocks)  # per block: the range
    hi = max(float(np.max(read(*b))) for b in blocks)
    h_range = hi - min(0.0, lo)
    psi = np.zeros(C)
    cos_facet, cos_wall = np.cos(np.radians(crit + margin)), np.cos(np.radians(overhang_angle(crit)))
    walls = _border_walls(psi, "normal")
    ramped = tuple(b for b in _BORDERS if edges and bool((-(dirs @ walls[b]) > cos_wall).any()))

    def plan(split: float, scale: np.ndarray):
        bounds, oblique, bad = _edge_bounds(h_range, psi[1:], dirs, cos_facet, cos_wall, "normal", px, py, split, scale)
        halo = limiter_halo(bounds, h_range)
        if halo is None:
            raise ParameterError(f"a build direction {np.round(dirs, 4).tolist()} leaves the texture facets a slope of 0: "
                                 "the limiter's reach is the whole plate, which is not made in tiles; tilt it a degree less")
        return LimitPlan((R, C), (px, py), ramped, halo, _erosion_lines(bounds)), oblique, bad

    scale = np.ones(C - 1)
    first, oblique, bad = plan(0.5, scale)
    blocks = _grid_blocks((R, C), max(32, int(block) - 2 * max(first.halo)))  # a block and its halo: about block a side
    split = _tiled_split(plan, scale, read, blocks, progress) if oblique else 0.5
    cos_check = np.cos(np.radians(crit + max(0.5 * margin, margin - 0.25)))
    iterations = 1
    while True:  # per verification pass (as _limit's loop)
        p = plan(split, scale)[0]
        fix, stats = _tiled_pass(p, read, blocks, dirs, cos_check, bad, store, progress)
        if not fix.size or iterations >= 40:
            break
        scale[fix] *= 0.8
        iterations += 1
    if bad.any():
        xs = (np.flatnonzero(bad) + 1.0) * px
        warnings.warn(f"the surface itself faces down past {crit:g} degrees between x = {xs.min():.1f} and "
                      f"{xs.max():.1f} mm; the texture there is left as is (it needs support anyway): choose a build "
                      "direction closer to the surface normal", TexcadWarning, stacklevel=2)
    removed, most, touched, remaining, weighted, crossing, top = stats
    rep = LimitReport(removed_volume_mm3=removed * px * py, max_removed_mm=most, touched_fraction=touched / (R * C),
                      ramped_borders=ramped, critical_angle_deg=crit, margin_deg=margin, directions=dirs,
                      remaining_overhang_mm2=remaining, surface_overhang=bool(bad.any()), iterations=iterations)
    return TiledLimit(rep, p, weighted * px * py, px * py * (max(top, 0.0) + crossing), top)


def _tiled_split(plan, scale: np.ndarray, read, blocks: list, progress) -> float:
    """The split of oblique bounds that removes least (as :func:`_limit` chooses it:
    0.5 first, the first of equal ones kept), the removed heights summed block by block."""
    from ..util import report

    splits = (0.5, 0.2, 0.35, 0.65, 0.8)
    plans = [plan(s, scale)[0] for s in splits]
    removed = [0.0] * len(splits)
    for k, (rows, cols) in enumerate(blocks):  # per block
        for i, p in enumerate(plans):  # per split
            h0, out = p.limit(read, rows, cols)
            removed[i] += float((h0 - out).sum())
        report(progress, 0.5 * (k + 1) / len(blocks), f"limiting overhangs: choosing the split, block {k + 1}/{len(blocks)}")
    best = (removed[0], splits[0])
    for i in range(1, len(splits)):  # per split
        best = min(best, (removed[i], splits[i]), key=lambda t: t[0])
    return best[1]


def _tiled_pass(plan: LimitPlan, read, blocks: list, dirs, cos_check: float, bad: np.ndarray, store, progress):
    """One pass over the blocks: each limited (with its next row and column, for the
    facets between blocks) and stored, its triangulated facets verified as
    :func:`_limit` does. Returns ``(columns to tighten, stats)``, the stats being the
    removed height's sum, largest and count above 1 nm, the area still overhanging
    (mm^2), the trapezoid-weighted sum of ``max(h', 0)``, the crossing term of
    :func:`texcad.solid.mesh.heightfield_volume` (mm) and the highest ``h'`` (mm)."""
    from ..util import report

    (R, C), (px, py) = plan.shape, plan.pitch
    x = np.concatenate([[0.0], np.cumsum(np.full(C - 1, px))])  # _grid_points' profile on a flat plate
    fix, removed, most, touched, remaining, weighted, crossing, top = [], 0.0, 0.0, 0, 0.0, 0.0, 0.0, -np.inf
    for k, (rows, cols) in enumerate(blocks):  # per block
        er, ec = slice(rows.start, min(rows.stop + 1, R)), slice(cols.start, min(cols.stop + 1, C))
        h0, ext = plan.limit(read, er, ec)
        n, m = rows.stop - rows.start, cols.stop - cols.start
        out, h0 = ext[:n, :m], h0[:n, :m]
        store(rows, cols, out)
        gone = h0 - out.astype(np.float64)
        removed, most = removed + float(gone.sum()), max(most, float(gone.max(initial=0.0)))
        touched += int(np.count_nonzero(gone > 1e-6))
        g = ext.astype(np.float64)
        if g.shape[0] > 1 and g.shape[1] > 1:
            P = np.empty(g.shape + (3,))
            P[..., 0] = x[None, ec] + g * -0.0
            P[..., 1] = ((np.arange(er.start, er.stop) + 0.5) * py)[:, None]
            P[..., 2] = 0.0 + g * 1.0
            viol, area = _facet_violations(P, dirs, cos_check)
            cell_col = (np.arange(len(viol)) // 2) % (g.shape[1] - 1) + cols.start
            fix.append(np.unique(cell_col[viol & ~bad[cell_col]]))
            remaining += float(area[viol].sum())
            corners = [g[:-1, :-1], g[:-1, 1:], g[1:, :-1], g[1:, 1:]]
            lo, hi = np.minimum.reduce(corners), np.maximum.reduce(corners)
            crossing += float(np.where((lo < 0) & (hi > 0), hi, 0.0).sum())
        wr = np.where((np.arange(rows.start, rows.stop) == 0) | (np.arange(rows.start, rows.stop) == R - 1), 0.5, 1.0)
        wc = np.where((np.arange(cols.start, cols.stop) == 0) | (np.arange(cols.start, cols.stop) == C - 1), 0.5, 1.0)
        weighted += float(wr @ np.maximum(out.astype(np.float64), 0.0) @ wc)
        top = max(top, float(out.max()))
        report(progress, 0.5 + 0.5 * (k + 1) / len(blocks), f"limiting overhangs: block {k + 1}/{len(blocks)}")
    cols_fix = np.unique(np.concatenate(fix)) if fix else np.zeros(0, np.int64)
    return cols_fix, (removed, most, touched, remaining, weighted, crossing, top)


@dataclass(frozen=True)
class LeanFacets:
    """The check a lean tile of a limited texture must pass (a tiled plate's lean
    tiles: :class:`texcad.targets.tiled.TiledMesh`): no facet above the base
    (a corner above 1e-6 mm) faces down past ``limit`` degrees for any of the
    ``directions``, the rule :func:`printable_lean_slab` applies to its tiles. Called
    as ``check(points, faces)``: ``(k, 3)`` points mm in the texture frame (z the
    height over the surface), ``(m, 3)`` triangles; True when none overhangs.

    Attributes:
        directions: ``(K, 3)`` unit build directions (texture frame).
        limit: degrees, ``critical_angle + margin - 0.5``.
    """

    directions: np.ndarray
    limit: float

    def __call__(self, points: np.ndarray, faces: np.ndarray) -> bool:
        p = np.asarray(points, dtype=np.float64)
        f = np.asarray(faces, dtype=np.int64)
        f = f[p[f, 2].max(axis=1) > 1e-6]  # facets above the base
        if not len(f):
            return True
        top = Mesh(p.astype(np.float32), f.astype(np.uint32))
        # plate_tolerance < 0: no texture facet rests on the build plate.
        return not any(overhang_mask(top, d, self.limit, plate_tolerance=-1.0, rule="angle").any() for d in self.directions)


def lean_facets(build_dir, critical_angle: float = DEFAULT_CRITICAL_ANGLE, *, margin: float | None = None,
                layer_height: float = DEFAULT_LAYER_HEIGHT) -> LeanFacets:
    """The :class:`LeanFacets` check for ``build_dir`` and ``critical_angle`` (degrees;
    ``margin`` and ``layer_height`` mm as :func:`limit_overhangs`): the limit
    :func:`printable_lean_slab` keeps, ``critical_angle + margin - 0.5`` (at most 89.9)."""
    dirs, crit, margin = _limit_angles(build_dir, critical_angle, margin, layer_height)
    return LeanFacets(dirs, min(crit + margin - 0.5, 89.9))


# ---------------------------------------------------------------------------------
# Features thinner than the nozzle
# ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class ThinFeatures:
    """Texture features that an FDM nozzle cannot draw (see :func:`thin_features`).

    Attributes:
        nozzle_mm: nozzle (extrusion) width in mm.
        level_mm: height at which widths are measured (mm).
        feature_area_mm2: area of the texture above ``level_mm`` (mm^2).
        thin_area_mm2: part of it narrower than the nozzle (mm^2).
        thin_fraction: ``thin_area / feature_area`` (0 if no features).
        narrow_gap_area_mm2: area of grooves below ``level_mm`` narrower than the
            nozzle (they fill up when printed), mm^2.
    """

    nozzle_mm: float
    level_mm: float
    feature_area_mm2: float
    thin_area_mm2: float
    thin_fraction: float
    narrow_gap_area_mm2: float

    def to_dict(self) -> dict:
        """Plain-type dict (JSON-ready)."""
        return dict(self.__dict__)


def thin_features(
    heightmap: Heightmap,
    nozzle: float,
    *,
    level: float = 0.5,
    mask: np.ndarray | None = None,
) -> ThinFeatures:
    """Where a texture is narrower than the nozzle, measured at ``level`` x max height.

    The features are the pixels above ``level * max(h)``. A nozzle of diameter
    ``w`` draws a region only where a disc of diameter ``w`` fits inside it, so
    the printable part of the features is their morphological opening by that
    disc, and ``thin = features - opening`` (computed exactly with two Euclidean
    distance transforms at the pixel pitch: erosion = distance to the outside
    ``> w/2``, dilation = distance to the eroded set ``<= w/2``). Grooves narrower
    than the nozzle are found the same way in the complement. Heightmaps coarser
    than ``w / 4`` are resampled (cubic) to ``w / 4`` first.

    Args:
        heightmap: the texture (mm), in its own (unmapped) frame.
        nozzle: nozzle or extrusion width in mm (> 0), e.g. 0.4.
        level: fraction of the maximum height where widths are measured.
        mask: optional ``(rows, cols)`` bool, pixels that belong to the texture
            (others are ignored), e.g. from a rasterised mesh.

    Returns:
        :class:`ThinFeatures` (areas in mm^2).
    """
    from scipy import ndimage

    w = float(nozzle)
    if not (np.isfinite(w) and w > 0):
        raise ParameterError(f"nozzle must be a positive width in mm (e.g. 0.4), got {nozzle!r}")
    if not (0.0 < float(level) < 1.0):
        raise ParameterError(f"level must be a fraction of the height between 0 and 1, got {level!r}")
    hm = heightmap
    m = np.ones(hm.shape, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    if m.shape != hm.shape:
        raise ParameterError(f"mask has shape {m.shape} but the heightmap is {hm.shape}")
    target = w / 4.0
    if max(hm.pitch) > target * 1.001:
        new = (min(hm.pitch[0], target), min(hm.pitch[1], target))
        fine = hm.resampled(new)
        # Nearest-neighbour mask on the finer grid (pixel centres).
        ri = np.minimum(((np.arange(fine.shape[0]) + 0.5) * hm.shape[0] / fine.shape[0]).astype(np.int64), hm.shape[0] - 1)
        ci = np.minimum(((np.arange(fine.shape[1]) + 0.5) * hm.shape[1] / fine.shape[1]).astype(np.int64), hm.shape[1] - 1)
        m = m[ri[:, None], ci[None, :]]
        hm = fine
    px, py = hm.pitch
    top = float(hm.heights[m].max()) if m.any() else 0.0
    lvl = float(level) * top
    feat = (hm.heights > lvl) & m
    gaps = (hm.heights <= lvl) & m
    r = w / 2.0

    def thin(region: np.ndarray) -> np.ndarray:
        if not region.any():
            return region
        # Pad with "outside" so borders of the texture count as edges.
        inside = ndimage.distance_transform_edt(np.pad(region, 1), sampling=(py, px))
        core = inside > r
        if not core.any():
            return region
        grown = ndimage.distance_transform_edt(~core, sampling=(py, px)) <= r
        return region & ~grown[1:-1, 1:-1]

    pa = px * py
    fa = float(feat.sum() * pa)
    ta = float(thin(feat).sum() * pa)
    ga = float(thin(gaps).sum() * pa)
    return ThinFeatures(w, lvl, fa, ta, ta / fa if fa > 0 else 0.0, ga)


def printable_lean_slab(
    heightmap: Heightmap,
    build_dir,
    critical_angle: float = DEFAULT_CRITICAL_ANGLE,
    *,
    tolerance: float,
    depth: float,
    origin: Sequence[float],
    margin: float | None = None,
    layer_height: float = DEFAULT_LAYER_HEIGHT,
) -> tuple[Mesh, float]:
    """A :func:`texcad.solid.heightfield_slab` with a lean top (``tolerance`` mm) whose
    texture facets above the base (any vertex above ``origin_z``) keep
    ``critical_angle + margin - 0.5`` degrees from the build plate for every
    build direction, for a heightmap already limited by :func:`limit_overhangs`.

    The limiter bounds the one-vertex-per-pixel facets; a lean triangle's slope is
    only within about ``tolerance / width`` of theirs, so small lean triangles at
    sharp features can overhang where the pixel facets do not (measured: a stones
    texture limited for a 60-degree tilt keeps facets at 46.5 degrees on the pixel
    grid but down to 30 degrees in its lean mesh at 0.02 mm, and still 30 degrees
    at 0.00125 mm). So the lean top is made in tiles
    (:func:`texcad.solid.lean.tiled_triangulation`), each checked: a tile with an
    overhanging facet is redone with a tighter tolerance, then as the pixel grid
    (which the limiter guarantees); the other tiles stay lean.

    Returns:
        ``(slab, tolerance_used)`` (mm).
    """
    from ..solid import BORDER_GRID, heightfield_slab, tiled_triangulation

    dirs = build_directions(build_dir)
    crit = check_critical_angle(critical_angle)
    margin = slicer_margin(crit, layer_height) if margin is None else float(margin)
    limit = min(crit + margin - 0.5, 89.9)
    tol = float(tolerance)
    if tol <= 0:
        return heightfield_slab(heightmap, depth=depth, origin=origin), 0.0
    h = heightmap.heights
    px, py = heightmap.pitch

    def accept(rc: np.ndarray, faces: np.ndarray) -> bool:
        v = np.stack([(rc[:, 1] + 0.5) * px, (rc[:, 0] + 0.5) * py, h[rc[:, 0], rc[:, 1]]], axis=1)
        f = faces[v[faces, 2].max(axis=1) > 1e-6]  # facets above the base
        top = Mesh(v.astype(np.float32), f.astype(np.uint32))
        # plate_tolerance < 0: no texture facet rests on the build plate.
        return not any(overhang_mask(top, d, limit, plate_tolerance=-1.0, rule="angle").any() for d in dirs)

    lean = tiled_triangulation(h, tol, accept=accept, border_grid=BORDER_GRID)
    if lean is None:
        return heightfield_slab(heightmap, depth=depth, origin=origin), 0.0
    return heightfield_slab(heightmap, depth=depth, origin=origin, tolerance=tol, lean=lean), tol
