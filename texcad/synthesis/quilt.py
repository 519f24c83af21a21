"""Texture synthesis by patch-based sampling (paper section 2.1; Liang et al. 2001).

A small texture sample (a :class:`~texcad.sources.Heightmap`) is grown into a larger
heightmap with the same local statistics, following

    L. Liang, C. Liu, Y.-Q. Xu, B. Guo, H.-Y. Shum, "Real-time texture synthesis by
    patch-based sampling", ACM Transactions on Graphics 20(3), 2001 ("Liang 2001"),

which the paper (section 2.1.2) uses, with the minimum-error boundary cut of Efros and
Freeman (2001; the paper's eq. 1) as an alternative blend, and seamless closure for
closed surfaces (the paper's modification M-II, section 2.1.4) done by synthesizing on
a torus.

The algorithm (Liang 2001, section 3)
-------------------------------------
Square patches of ``patch`` px (Liang's ``w_B``) are pasted in scan-line order on a
grid of step ``patch - overlap`` px, so that each patch overlaps its left and top
neighbours by ``overlap`` px (Liang's boundary-zone width ``w_E``). The *boundary zone*
``E`` of a new patch is the part of its footprint that is already synthesized: the
L-shaped band made of its top and left strips (only the left strip in the first patch
row, only the top strip in the first column; with ``wrap`` also right and bottom strips
at the closing patches). Every ``patch x patch`` window of the sample is a candidate
``B``; its distance to the output is the RMS height difference over the zone,

    d(E_B, E_out) = sqrt( (1/A) sum_{k in E} (p_B(k) - p_out(k))^2 )   [mm],

with ``A`` the number of pixels in the zone. The candidate set is

    Psi_B = { B : d(E_B, E_out) <= (1 + tolerance) d_min },

the Efros-Freeman form of Liang's ``d_max`` (a tolerance relative to the best match
rather than to the zone's intensity, because heights in mm have an arbitrary offset),
and one member is picked uniformly at random with ``numpy.random.default_rng(seed)``.

The search is Liang's accelerated one (section 4): each zone type (top, left, L) is
reduced by the quadtree pyramid (QTP: the means of its ``2^L x 2^L`` blocks, weighted
so that distances between block vectors bound the full-resolution distance from
below; ``L`` is the smallest level with at most 160 blocks per strip, 4 x 4 px blocks
for patch 45, overlap 25) and principal component analysis (PCA, up to 8 components
per strip of the zone, fitted to 1024 random candidates); every principal component,
pulled back to full resolution, is a ``patch x patch`` kernel, so the features of
*all* candidates are computed at once by FFT correlation of the sample with the
kernels; a k-d tree over those features returns the ``_NEIGHBOURS`` (16) approximate
nearest candidates (the coarse level of the QTP search) and their exact
full-resolution distances ``d`` decide among them (the fine level).

Coherent candidates. Besides the tree's neighbours, the fine level gets, for every
earlier neighbour patch (left, top-left, top, top-right, and across the wrap) copied
from the sample window at ``(y, x)`` and placed ``(dy, dx)`` px from the new patch,
the window ``(y - dy, x - dx)`` that continues it (Ashikhmin 2001; Tong et al. 2002's
k-coherence). Its zone equals the output wherever that neighbour alone made it, so
it is the match an exhaustive search finds first, and one that a k-d tree over 8-16
principal components of block means often misses. The candidate set is the members
of ``Psi_B`` among these (at most 16 + 8, each counted once); when some of its
members are coherent candidates, the pick is among those (the coherence rule of
Ashikhmin 2001 and Hertzmann et al. 2001 with their ``kappa`` equal to the
tolerance: a continuation wins whenever it is eligible).

Why (benchmarks/bench_synthesis.py, 200 x 200 px crops of CC0 photographs from
scikit-image grown to 800 x 800 px, :func:`texcad.synthesis.quality.coherence`,
the ratio to the exhaustive search ``search="exact"``, Liang's straightforward
algorithm by FFT): without coherent candidates the approximate search was 9-68 %
worse on grass (the tree's 16 neighbours miss the best window for ~30 % of the
patches: grass is fine detail that 4 x 4 px block means do not see); more neighbours
(64, 256) or more components (16 per strip) closed only part of the gap at 2-5 times
the time; with coherent candidates one grass crop was still 17 % worse. Preferring
the eligible coherent candidates closed it: 1.01 +- 0.02 on that crop, 0.96-1.01 on
three brick-wall crops and 0.64-0.90 on the others (6 seeds). The exhaustive search's
best window added as an oracle candidate reaches only 1.00-1.01 on a brick wall, so
on structured textures the approximate search is at the exhaustive one's level (the
figures per crop are in the README). PCA on 2 x 2 px blocks instead of 4 x 4 was
within the errors of these figures on all nine crops at about 1.3 times the CPU
time, so the default stays at 4 x 4; a DCT basis instead of the PCA, the zone's norm
outside the components' span as a feature, and a coherence bias ``kappa`` above the
tolerance were tried and were no better.

Scan-line order, a front at a time
----------------------------------
A patch's zone is the output of the patches it overlaps that come before it in scan
line order, and nothing else. So patch ``(i, j)`` may be pasted as soon as those are:
at step ``1 + max(step of the earlier patches it overlaps)`` (``j + 3 i`` for patch 45,
overlap 25, a diagonal front; see ``_levels``). The patches of one step share no
pixel, and every pair of overlapping patches is pasted in scan-line order, so the
output is byte-identical to pasting one patch at a time (tested), while the patches
of a front (about a third of a patch row) are matched together: one k-d tree query,
one matrix product for their features, one gather of their neighbours' zones, one
dynamic programme for their cuts. Each patch's random pick is drawn before the run
(a uniform number per patch), so it does not depend on the schedule. With wrap
along x the first patch of a row overlaps the last one of the row above, which
makes the schedule plain scan-line order (one patch per step).

Blending
--------
``blend="feather"`` (Liang 2001, section 3.3): in the overlap the new patch gets the
weight ``alpha = min_s (k_s + 1) / (w_s + 1)`` (``k_s`` the pixel's distance into strip
``s`` of width ``w_s``), the output there becomes ``(1 - alpha) old + alpha new``.

``blend="cut"`` (Efros and Freeman 2001; the paper's eq. 1): the error
``e_ij = (B1_ij - B2_ij)^2`` between old and new in each strip is accumulated by dynamic
programming,

    E_ij = e_ij                                          (i = 1)
    E_ij = e_ij + min(E_{i-1,j-1}, E_{i-1,j}, E_{i-1,j+1})  (i > 1),      (eq. 1)

and the new patch replaces the old content beyond the minimum-error path, taking over
within 2 px after it (a hard cut would leave a small step). Details stay sharp where
feathering averages two textures.

Seamless closure (paper M-II, section 2.1.4)
--------------------------------------------
With ``wrap`` the output is synthesized on a torus: along a wrapped axis of ``L`` px
there are ``n = ceil(L / step)`` patches and those that pass the end continue at pixel
0. Their boundary zone then includes a right (bottom) strip, the first patches of the
row (column) across the wrap, and they are feathered or cut on both sides. Every seam
of the torus is thus an ordinary patch seam. The closing patches are the hardest to
match (their zone holds both neighbours, whose phases a structured texture such as
a brick wall need not reconcile), and there are only ``rows + cols`` of them, so they
are matched by the exhaustive search (:meth:`_Synthesizer.query_exact`, one FFT
correlation each) rather than the k-d tree, and take the best match (tolerance
``_CLOSING_TOLERANCE`` = 0: variety is not at stake in so few patches). The wrap seam's squared height jump is
then about the mean squared jump between neighbouring columns (rows) on irregular
and structured photographs alike (benchmarks/bench_synthesis.py). The
paper instead synthesizes 100 px extra and joins the two unrelated ends with one
eq. 1 cut; the mismatch along that cut is 1.3-1.5 times the mismatch along the
interior cuts (0.79-0.89 vs 0.59 neighbour differences), so it is not used.

Edges of the parameter space
----------------------------
``patch`` larger than the sample, ``overlap >= patch``, ``overlap < 1``, sizes below
2 px, or a wrapped axis shorter than ``patch`` raise :class:`ParameterError` naming
the value and the fix. An output smaller than the sample or a patch is the crop of
a (partly) synthesized grid; non-square samples and outputs that are not a whole
number of steps are fine (the grid is extended past the output and cropped). A
sample larger than ``2^18`` candidate windows is searched on a regular sub-grid of
positions.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np
from scipy import fft as _fft
from scipy.spatial import cKDTree

from ..util import require_memory
from ..errors import InputError, ParameterError
from ..sources import Heightmap

__all__ = ["BLENDS", "SEARCHES", "WRAPS", "synthesize", "naive_quilt", "seam_bands", "patch_grid"]

#: Valid values of ``blend``.
BLENDS: tuple[str, ...] = ("feather", "cut")
#: Valid values of ``search``: Liang 2001's accelerated search (section 4) or the
#: exhaustive one (section 3.2), the baseline it is measured against.
SEARCHES: tuple[str, ...] = ("approximate", "exact")
#: Valid values of ``wrap``.
WRAPS: tuple[str | None, ...] = (None, "x", "y", "xy")

#: ``progress(fraction, message)``: fraction of patch rows done in [0, 1].
ProgressFn = Callable[[float, str], None]

# -- search constants (Liang 2001, section 4) ----------------------------------------
#: Approximate nearest neighbours returned by the k-d tree and refined exactly.
_NEIGHBOURS = 16
#: Add the coherent candidates (continuations of the neighbours' sources).
_COHERENT = True
#: Also continue the diagonal neighbours (top-left, top-right) of each patch.
_COHERENT_DIAGONALS = True
#: Match the closing patches of a torus (zones with a right or bottom strip) by the
#: exhaustive search.
_EXACT_CLOSING = True
#: Tolerance of the closing patches' candidate sets (see _closing_tolerance).
_CLOSING_TOLERANCE = 0.0
#: k-d tree approximation factor: returned neighbours are within (1 + eps) of the
#: true k-th neighbour distance in feature space (Arya et al.), refined exactly after.
_KD_EPS = 2.0
#: Prefer the eligible coherent candidates (see _Synthesizer.query).
_PREFER_COHERENT = True
#: Principal components kept per strip type (at most; fewer if they hold 99.5 %).
_COMPONENTS_PER_STRIP = 8
_MIN_COMPONENTS = 3
_VARIANCE_KEPT = 0.995
#: Subspace iterations of the PCA (see _top_components).
_SUBSPACE_ITERATIONS = 12
#: The QTP level is the smallest at which the zone has at most this many blocks per
#: strip (top, left, right, bottom) it holds, and at most _MAX_COARSE_PIXELS (level 2,
#: 4 x 4 px blocks, for patch 45 and overlap 25: level 1 measured no better).
_COARSE_PIXELS_PER_STRIP = 160
_MAX_COARSE_PIXELS = 320
#: Kernels correlated with the sample per FFT batch (bounds the memory: each holds
#: about 12 bytes per sample pixel).
_FFT_CHUNK = 8
#: Rows of the feature matrix products (see _Synthesizer.query).
_MATMUL_ROWS = 32
#: Candidates used to fit the PCA.
_PCA_SUBSET = 1024
#: More candidate windows than this are thinned to a regular grid of positions.
_MAX_CANDIDATES = 1 << 18


# ------------------------------------------------------------------------------------
# Parameters
# ------------------------------------------------------------------------------------
def _as_sample(sample: Heightmap | np.ndarray) -> Heightmap:
    if isinstance(sample, Heightmap):
        return sample
    try:
        a = np.asarray(sample)
    except Exception:  # noqa: BLE001 - ragged lists and the like
        a = None
    if a is None or a.ndim != 2 or not np.issubdtype(a.dtype, np.number):
        raise InputError(
            "sample must be a Heightmap or a 2-D array of heights in mm, got "
            f"{type(sample).__name__}" + (f" of shape {a.shape}" if a is not None else "")
        )
    return Heightmap(a, (1.0, 1.0))


def _int(name: str, value: object, lo: int, fix: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParameterError(f"{name} must be a whole number of pixels, got {value!r}")
    if value < lo:
        raise ParameterError(f"{name} must be at least {lo} px, got {value}; {fix}")
    return int(value)


def _shape(shape: object) -> tuple[int, int]:
    try:
        rows, cols = shape  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ParameterError(
            f"shape must be (rows, cols) in pixels, got {shape!r}; e.g. shape=(800, 800)"
        ) from None
    fix = "a heightmap needs at least 2 x 2 px"
    return _int("shape[0] (rows)", rows, 2, fix), _int("shape[1] (cols)", cols, 2, fix)


def _wrap_axes(wrap: object) -> tuple[bool, bool]:
    """``(wrap_y, wrap_x)`` from the ``wrap`` option."""
    if wrap not in WRAPS:
        raise ParameterError(
            f"unknown wrap {wrap!r}; use one of None, 'x', 'y', 'xy' (the axes along which "
            "the output must tile)"
        )
    w = wrap or ""
    return "y" in w, "x" in w


def _check_blend(blend: object) -> str:
    if blend not in BLENDS:
        raise ParameterError(f"unknown blend {blend!r}; use one of {', '.join(map(repr, BLENDS))}")
    return str(blend)


def _check_patch(sample: Heightmap, patch: object, overlap: object) -> tuple[int, int]:
    p = _int("patch", patch, 2, "use a patch of a few times the texture's feature size")
    o = _int("overlap", overlap, 1, "use about a third to a half of the patch (e.g. 25 for patch 45)")
    if o >= p:
        raise ParameterError(
            f"overlap {o} px must be smaller than patch {p} px; use about a third to a half "
            f"of the patch, e.g. overlap={max(1, p // 3)}"
        )
    rows, cols = sample.shape
    if p > min(rows, cols):
        raise ParameterError(
            f"patch {p} px is larger than the sample ({rows} x {cols} px); use patch <= "
            f"{min(rows, cols)} (and overlap < patch), or a larger sample"
        )
    return p, o


def _check_wrap_size(shape: tuple[int, int], wrap_y: bool, wrap_x: bool, p: int) -> None:
    for axis, size, on in (("y (rows)", shape[0], wrap_y), ("x (cols)", shape[1], wrap_x)):
        if on and size < p:
            raise ParameterError(
                f"the output is {size} px along {axis}, smaller than the patch ({p} px), so it "
                f"cannot tile along that axis; make it at least {p} px or use a smaller patch"
            )


# ------------------------------------------------------------------------------------
# The patch grid
# ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Axis:
    """Patch positions along one axis.

    ``starts[j]`` is the first pixel of patch ``j``; ``before[j]`` the width in px of the
    strip it shares with patch ``j - 1``; ``after[j]`` the width of the strip it shares,
    across the wrap, with patch 0 (torus closure); ``canvas`` the working length in px
    (the output length for a wrapped axis, else the patch grid's extent, cropped later).
    """

    starts: np.ndarray
    before: np.ndarray
    after: np.ndarray
    canvas: int
    wrap: bool


def _axis(length: int, patch: int, overlap: int, wrap: bool) -> _Axis:
    step = patch - overlap
    if wrap:
        # On a circle of `length` px: n = ceil(length / step) patches. The last one
        # overlaps patch 0 by after[n-1] = n*step - length + overlap in [overlap, patch).
        n = -(-length // step)
        canvas = length
    else:
        # Fewest patches covering `length`; the surplus is cropped.
        n = 1 + max(0, -(-(length - patch) // step))
        canvas = (n - 1) * step + patch
    starts = np.arange(n) * step
    before = np.where(np.arange(n) > 0, overlap, 0)
    after = np.clip(starts + patch - length, 0, None) if wrap else np.zeros(n, dtype=int)
    return _Axis(starts, before, after, canvas, wrap)


def patch_grid(
    shape: tuple[int, int], patch: int = 45, overlap: int = 25, wrap: str | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Top-left pixels of the patches that :func:`synthesize` pastes.

    Args:
        shape: output ``(rows, cols)`` in px.
        patch, overlap: patch and overlap size in px.
        wrap: None, ``"x"``, ``"y"`` or ``"xy"``.

    Returns:
        ``(row_starts, col_starts)``, int arrays in px. Without wrap the grid covers at
        least ``shape`` (the surplus is cropped); with wrap along an axis, patches that
        pass the end continue at pixel 0.
    """
    rows, cols = _shape(shape)
    wy, wx = _wrap_axes(wrap)
    p = _int("patch", patch, 2, "use a larger patch")
    o = _int("overlap", overlap, 1, "use a larger overlap")
    if o >= p:
        raise ParameterError(f"overlap {o} px must be smaller than patch {p} px")
    return _axis(rows, p, o, wy).starts, _axis(cols, p, o, wx).starts


def seam_bands(
    shape: tuple[int, int], patch: int = 45, overlap: int = 25, wrap: str | None = None
) -> np.ndarray:
    """Where :func:`synthesize` blends two patches: the middle half of every overlap.

    Args:
        shape: output ``(rows, cols)`` in px.
        patch, overlap: patch and overlap in px, as given to :func:`synthesize`.
        wrap: as given to :func:`synthesize`; the closing patches' strips across the
            wrap (which lie at the start of the output) are included.

    Returns:
        ``(rows, cols)`` bool mask, True in the central half ``[w/4, 3w/4)`` of each
        overlap strip of width ``w``, where feathering weights both patches by about a
        half (use it with :func:`texcad.synthesis.quality.blur_ratio`).
    """
    rows, cols = _shape(shape)
    wy, wx = _wrap_axes(wrap)
    p, o = int(patch), int(overlap)
    if not (2 <= p and 1 <= o < p):
        raise ParameterError(f"need 1 <= overlap < patch, got patch {patch}, overlap {overlap}")

    def bands(length: int, ax: _Axis) -> np.ndarray:
        m = np.zeros(length, dtype=bool)
        for s, b, a in zip(ax.starts, ax.before, ax.after):
            for lo, w in ((s, b), (s + p - a, a)):
                if w:
                    idx = np.arange(lo + w // 4, lo + max(w // 4 + 1, (3 * w) // 4)) % ax.canvas
                    m[idx[idx < length]] = True
        return m

    by = bands(rows, _axis(rows, p, o, wy))
    bx = bands(cols, _axis(cols, p, o, wx))
    return by[:, None] | bx[None, :]


# ------------------------------------------------------------------------------------
# Features: QTP + PCA per zone type, computed for all candidates by FFT correlation
# ------------------------------------------------------------------------------------
def _qtp_blocks(mask: np.ndarray, max_blocks: int) -> tuple[np.ndarray, np.ndarray, int]:
    """Quadtree-pyramid blocks of a zone at the coarsest useful level (Liang 2001, s. 4).

    Args:
        mask: ``(p, p)`` bool, True on the zone's ``A`` pixels.
        max_blocks: most blocks wanted.

    Returns:
        ``(block, count, level)``: ``block`` is ``(A,)`` int, the block of each zone
        pixel (``np.nonzero(mask)`` order); ``count`` is ``(n_blocks,)``, the zone
        pixels in each ``2^level x 2^level`` block (partial blocks at the zone's edges
        are averaged over their own pixels); ``level`` is the smallest with at most
        ``max_blocks`` blocks.
    """
    uu, vv = np.nonzero(mask)
    level = 0
    while True:
        ids = (uu >> level) * (mask.shape[1] + 1) + (vv >> level)
        blocks, block = np.unique(ids, return_inverse=True)
        if len(blocks) <= max_blocks:
            return block.ravel(), np.bincount(block.ravel()), level
        level += 1


def _rows_matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` in blocks of ``_MATMUL_ROWS`` rows of ``a``, which OpenBLAS runs on one
    thread (a multithreaded product stalls for tens of ms on a busy 2-core machine)."""
    return np.concatenate([a[s: s + _MATMUL_ROWS] @ b for s in range(0, len(a), _MATMUL_ROWS)])


def _orthonormal(Y: np.ndarray) -> np.ndarray:
    """``(n, m')`` orthonormal basis of the span of the columns of ``Y`` (``(n, m)``,
    ``m' <= m``): twice ``Y V diag(1 / sqrt(w))`` with ``(w, V)`` the eigenpairs of the
    small Gram matrix ``Y^T Y`` (directions with ``w <= 1e-12 max w`` dropped)."""
    for _ in range(2):
        w, V = np.linalg.eigh(np.einsum("ij,ik->jk", Y, Y))
        keep = w > 1e-12 * float(w.max(initial=0.0))
        if not keep.any():  # all zero (a flat sample)
            return Y[:, :0]
        Y = np.einsum("ij,jk->ik", Y, V[:, keep] / np.sqrt(w[keep]))
    return Y


def _top_components(cov: np.ndarray, kmax: int) -> np.ndarray:
    """``(n, k)`` leading eigenvectors of a covariance, enough to hold ``_VARIANCE_KEPT``.

    Subspace iteration on ``kmax + 8`` vectors (started from the coordinate vectors
    of the largest variances, so it is deterministic), then Rayleigh-Ritz. Only
    small LAPACK calls and row-blocked products are made: a multithreaded OpenBLAS
    ``eigh``, ``qr`` or product of more than ~32 rows stalls for 20-400 ms on a busy
    2-core machine.
    """
    n = cov.shape[0]
    kmax = min(kmax, n)
    m = min(n, kmax + 8)
    if m == n:
        evals, evecs = np.linalg.eigh(cov)
    else:
        start = np.argsort(-np.diag(cov), kind="stable")[:m]
        Q = _orthonormal(cov[:, start])
        for _ in range(_SUBSPACE_ITERATIONS):
            if Q.shape[1] == 0:
                break
            Q = _orthonormal(_rows_matmul(cov, Q))
        if Q.shape[1] == 0:  # a flat sample: any basis
            Q = np.eye(n)[:, start[:1]]
        T = np.einsum("ij,ik->jk", Q, _rows_matmul(cov, Q))
        evals, U = np.linalg.eigh(0.5 * (T + T.T))
        evecs = np.einsum("ij,jk->ik", Q, U)
    evals, evecs = evals[::-1][:kmax], evecs[:, ::-1][:, :kmax]
    total = float(np.trace(cov))
    if total > 0:
        k = int(np.searchsorted(np.cumsum(evals) / total, _VARIANCE_KEPT) + 1)
    else:
        k = 1
    k = int(np.clip(k, min(_MIN_COMPONENTS, len(evals)), len(evals)))
    V = evecs[:, :k]
    # Sign convention so the basis (hence the features) depends only on the data.
    return V * np.where(V[np.abs(V).argmax(axis=0), np.arange(k)] < 0, -1.0, 1.0)


# ------------------------------------------------------------------------------------
# Zone types: which strips of a patch are already synthesized
# ------------------------------------------------------------------------------------
def _rectangles(mask: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Disjoint rectangles ``(row, col, rows, cols)`` in px whose union is ``mask``.

    Runs of identical mask rows, each split into its runs of True columns: a few
    rectangles for a boundary zone (the L: the top strip and the left strip below it).
    """
    rects = []
    r0 = 0
    n = mask.shape[0]
    for r in range(1, n + 1):
        if r < n and np.array_equal(mask[r], mask[r0]):
            continue
        edges = np.flatnonzero(np.diff(np.r_[0, mask[r0].astype(np.int8), 0]))
        rects += [(r0, int(a), r - r0, int(b - a)) for a, b in zip(edges[::2], edges[1::2])]
        r0 = r
    return rects


@dataclass
class _Zone:
    """Everything about one boundary-zone type ``(top, left, right, bottom)`` widths.

    ``kernels`` is ``(K, A)`` float32: feature ``k`` of a zone (its ``A`` heights in
    ``pflat`` order, mm) is ``kernels[k] @ zone``, its projection on the ``k``-th
    principal component of the zone's QTP block means (Liang 2001, section 4).
    ``tree`` is a k-d tree over those features of every candidate window.

    Only the three zone types of the plain scan-line order, top, left and L (``(o, 0,
    0, 0)``, ``(0, o, 0, 0)``, ``(o, o, 0, 0)``) get their own PCA. The closing zones
    of a torus, which add a right and/or bottom strip, concatenate the features of
    their top/left part with those of the left (top) zone's PCA applied to the strip
    on the far side (``shifted``); narrower slivers enter only the exact distance.
    They serve one patch per row or column, so they share the PCAs.
    """

    key: tuple[int, int, int, int]
    mask: np.ndarray  # (p, p) bool, True where the output is already synthesized
    pflat: np.ndarray  # (A,) indices of the zone in a flattened patch
    sflat: np.ndarray  # (A,) indices of the zone in the flattened sample, patch at (0, 0)
    alpha: np.ndarray  # (p, p) float32 feathering weight of the new patch
    rects: list[tuple[int, int, int, int]]  # (row, col, rows, cols) px: the zone as rectangles
    tree: cKDTree | None = None  # over the QTP + PCA features of every candidate
    kernels: np.ndarray | None = None  # (K, A) float32
    feats: np.ndarray | None = None  # (candidates, K) float64, features of each candidate
    shifted: np.ndarray | None = None  # (candidates, K): of the strip at the far side
    uses: int = 0  # patches it serves in this run (one: a linear scan, no tree)
    s2: np.ndarray | None = None  # (candidates,) float64 sum of S^2 over each candidate's zone


def _tree(z: _Zone) -> cKDTree:
    """k-d tree over the principal-component features of every candidate."""
    return cKDTree(z.feats, leafsize=16, balanced_tree=False, compact_nodes=False)


class _Synthesizer:
    """State of one synthesis run: sample, candidates, zone PCAs and k-d trees."""

    def __init__(self, S: np.ndarray, p: int, o: int, rng: np.random.Generator, search: str | None):
        self.S = S
        self.S_flat = S.ravel()
        self.p, self.o = p, o
        self.rng = rng
        rows, cols = S.shape
        ny, nx = rows - p + 1, cols - p + 1
        stride = 1
        while -(-ny // stride) * -(-nx // stride) > _MAX_CANDIDATES:
            stride += 1
        gy, gx = np.meshgrid(np.arange(0, ny, stride), np.arange(0, nx, stride), indexing="ij")
        self.cy, self.cx = gy.ravel(), gx.ravel()
        self.offsets = self.cy * cols + self.cx
        # Candidate index of each window position (-1 off the thinned grid).
        self.lookup = np.full((ny, nx), -1, dtype=np.intp)
        self.lookup[self.cy, self.cx] = np.arange(len(self.cy))
        n_near = max(1, min(_NEIGHBOURS, len(self.cy)))
        self.k: int | list[int] = n_near if n_near > 1 else [1]  # a list keeps arrays
        self.search = search
        self.zones: dict[tuple[int, int, int, int], _Zone] = {}
        self.S_hat: np.ndarray | None = None
        self.S_hat64: np.ndarray | None = None
        self._windows: dict[tuple[int, int], np.ndarray] = {}

    def windows(self, h: int, w: int) -> np.ndarray:
        """``(rows - h + 1, cols - w + 1, h, w)`` read-only view: every ``h x w`` window
        of the sample (mm)."""
        v = self._windows.get((h, w))
        if v is None:
            v = self._windows[(h, w)] = np.lib.stride_tricks.sliding_window_view(self.S, (h, w))
        return v

    def zone(self, key: tuple[int, int, int, int]) -> _Zone:
        z = self.zones.get(key)
        if z is None:
            z = self._make_zone(key)
            self.zones[key] = z
        return z

    def _make_zone(self, key: tuple[int, int, int, int]) -> _Zone:
        p, o = self.p, self.o
        t, l, r, b = key
        mask = np.zeros((p, p), dtype=bool)
        mask[:t, :] = True
        mask[:, :l] = True
        if r:
            mask[:, p - r:] = True
        if b:
            mask[p - b:, :] = True
        k = np.arange(p, dtype=np.float64)
        alpha = np.ones((p, p))
        for w, ramp, axis in ((t, k, 0), (l, k, 1), (r, k[::-1], 1), (b, k[::-1], 0)):
            if w:
                ww = min(w, o)  # feather over at most `overlap` px at the outer edge
                a = np.minimum(1.0, (ramp + 1.0) / (ww + 1.0))
                alpha = np.minimum(alpha, a[:, None] if axis == 0 else a[None, :])
        uu, vv = np.nonzero(mask)
        z = _Zone(
            key=key,
            mask=mask,
            pflat=(uu * p + vv).astype(np.intp),
            sflat=(uu * self.S.shape[1] + vv).astype(np.intp),
            alpha=alpha.astype(np.float32),
            rects=_rectangles(mask),
        )
        if self.search == "approximate" and mask.any():
            parts = []  # (base zone, row shift, col shift) whose features make this zone's
            if t or l:
                parts.append(((t, l, 0, 0), 0, 0))
            if r >= o:
                parts.append(((0, o, 0, 0), 0, p - o))
            if b >= o:
                parts.append(((o, 0, 0, 0), p - o, 0))
            if key == (t, l, 0, 0) or not parts:
                self._fit(z)  # a base zone (or, for safety, one without a base part)
            else:
                feats, proj = [], []
                for base_key, dy, dx in parts:
                    base = self.zone(base_key)
                    shift = dy or dx
                    feats.append(base.shifted if shift else base.feats)
                    kp = np.zeros((len(base.kernels), p, p), dtype=np.float32)  # type: ignore[arg-type]
                    kp.reshape(len(kp), p * p)[:, base.pflat] = base.kernels
                    kp = np.roll(kp, (dy, dx), axis=(1, 2))
                    proj.append(kp.reshape(len(kp), p * p)[:, z.pflat])
                z.kernels = np.ascontiguousarray(np.concatenate(proj, axis=0), dtype=np.float32)
                z.feats = np.concatenate(feats, axis=1)  # the tree: at its first query (see uses)
        return z

    def _fit(self, z: _Zone) -> None:
        """QTP + PCA of the zone, features of every candidate, k-d tree (Liang 2001, s. 4).

        The PCA is fitted to the QTP block means of the zone at a random subset of
        candidates; each component, pulled back to full resolution, is a ``p x p``
        kernel (zero off the zone), and the features of *all* sample windows are the
        correlations of the sample with these kernels, computed by FFT at once.
        """
        S, p = self.S, self.p
        strips = sum(1 for w in z.key if w)
        n = min(len(self.cy), _PCA_SUBSET)
        pick = np.sort(self.rng.choice(len(self.cy), size=n, replace=False))
        self._features(z, self._pca_kernels(z, pick, strips))

    def _pca_kernels(self, z: _Zone, pick: np.ndarray, strips: int) -> np.ndarray:
        """``(K, A)`` kernels: the principal components of the zone's QTP block means
        at the candidates ``pick``, pulled back to full resolution."""
        n = len(pick)
        block, count, _ = _qtp_blocks(z.mask, min(_COARSE_PIXELS_PER_STRIP * strips, _MAX_COARSE_PIXELS))
        # The zones' pixels grouped by QTP block, then the block means: (n, blocks) mm.
        order = np.argsort(block, kind="stable")
        zones = self.S_flat.take(self.offsets[pick][:, None] + z.sflat[order])
        first = np.concatenate([[0], np.cumsum(count)[:-1]])
        # Block sums / sqrt(count): then ||X(a) - X(b)|| <= ||a - b|| (Cauchy-Schwarz),
        # and the PCA features, an orthonormal projection of X, keep that bound.
        X = np.add.reduceat(zones.astype(np.float64), first, axis=1) / np.sqrt(count)
        X -= X.mean(axis=0)
        # (einsum, not BLAS: a multithreaded BLAS call stalls on a busy 2-core machine.)
        X32 = X.astype(np.float32)  # (the covariance in single precision: half the time)
        cov = np.einsum("ni,nj->ij", X32, X32).astype(np.float64) / max(1, n - 1)
        V = _top_components(cov, _COMPONENTS_PER_STRIP * strips)
        return (V / np.sqrt(count)[:, None])[block].T  # (K, A): feature = kernels @ zone

    def _features(self, z: _Zone, kernels: np.ndarray) -> None:
        """Features of every candidate (FFT correlation with the kernels), k-d tree."""
        S, p = self.S, self.p
        K = len(kernels)
        # Correlation of the sample with each kernel: C[y, x] = sum S[y+u, x+v] k[u, v].
        # (Single precision: the features only guide the search, the exact distances
        # decide; it halves the cost of the transforms.)
        if self.S_hat is None:
            self.S_hat = _fft.rfft2(S.astype(np.float32))
        kp = np.zeros((K, p * p), dtype=np.float32)
        kp[:, z.pflat] = kernels
        t, l = z.key[:2]
        # The same strip on the far side of the patch, for the torus's closing zones.
        far = (t, l) in ((self.o, 0), (0, self.o))
        dy, dx = (p - self.o, 0) if t else (0, p - self.o)
        z.feats = np.empty((len(self.cy), K))
        z.shifted = np.empty((len(self.cy), K)) if far else None
        for k0 in range(0, K, _FFT_CHUNK):  # a few kernels at a time bounds the memory
            k1 = min(K, k0 + _FFT_CHUNK)
            Kpad = np.zeros((k1 - k0,) + S.shape, dtype=np.float32)
            Kpad[:, :p, :p] = kp[k0:k1].reshape(k1 - k0, p, p)
            spec = _fft.rfft2(Kpad, axes=(1, 2))
            np.conjugate(spec, out=spec)
            spec *= self.S_hat
            C = _fft.irfft2(spec, s=S.shape, axes=(1, 2))
            z.feats[:, k0:k1] = C[:, self.cy, self.cx].T  # (candidates, K)
            if z.shifted is not None:
                z.shifted[:, k0:k1] = C[:, self.cy + dy, self.cx + dx].T
        z.kernels = np.ascontiguousarray(kernels, dtype=np.float32)
        z.tree = _tree(z)

    def query_exact(self, zone: _Zone, old: np.ndarray, tolerance: float, u: np.ndarray) -> np.ndarray:
        """Exhaustive search: the candidate set ``Psi_B`` over *every* candidate window.

        The straightforward Liang 2001 (section 3.2) without the acceleration of its
        section 4, the baseline that the approximate search is measured against. The
        zone distance of all candidates ``B`` at once, in mm^2 times ``A``:

            A d^2(B) = sum_E S_B^2 - 2 sum_E S_B E_out + sum_E E_out^2,

        the first term a correlation of ``S^2`` with the zone's mask (once per zone
        type), the cross term the correlation of the sample with the masked output
        (FFT, float64), for the ``b`` patches of a front together. The
        ``floor(u m)``-th of the ``m`` candidates with ``d <= (1 + tolerance) d_min``
        (in candidate order) is taken.

        Returns:
            ``(b,)`` int, indices into the candidate windows (``cy``, ``cx``).
        """
        S, p = self.S, self.p
        b = len(old)
        shape = S.shape
        if self.S_hat64 is None:
            self.S_hat64 = _fft.rfft2(S.astype(np.float64))
        if zone.s2 is None:
            m = np.zeros(shape)
            m[:p, :p] = zone.mask
            c = _fft.irfft2(_fft.rfft2(S.astype(np.float64) ** 2) * np.conj(_fft.rfft2(m)), s=shape)
            zone.s2 = c[self.cy, self.cx]
        e = np.zeros((b,) + shape)
        e[:, :p, :p] = old
        e[:, :p, :p] *= zone.mask
        e2 = np.einsum("bij,bij->b", e[:, :p, :p], e[:, :p, :p])
        spec = _fft.rfft2(e, axes=(1, 2))
        np.conjugate(spec, out=spec)
        spec *= self.S_hat64
        cross = _fft.irfft2(spec, s=shape, axes=(1, 2))[:, self.cy, self.cx]  # (b, candidates)
        d2 = zone.s2[None, :] - 2.0 * cross + e2[:, None]
        np.maximum(d2, 0.0, out=d2)
        # Round-off of the FFT (~1e-12 of the sums) must not split ties.
        slack = 1e-9 * (float(zone.s2.max()) + e2[:, None])
        ok = d2 <= d2.min(axis=1, keepdims=True) * (1.0 + tolerance) ** 2 + slack
        r = (u * ok.sum(axis=1)).astype(np.intp)
        return (np.cumsum(ok, axis=1) > r[:, None]).argmax(axis=1)

    def query(
        self, zone: _Zone, old: np.ndarray, tolerance: float, u: np.ndarray, extra: np.ndarray | None = None
    ) -> np.ndarray:
        """Candidates chosen for ``b`` patches under ``zone`` (Liang 2001, sections 3.2, 4).

        Args:
            zone: the boundary-zone type the ``b`` patches share.
            old: ``(b, p, p)`` float32, the output (mm) under each patch's footprint.
            tolerance: relative tolerance of the candidate set.
            u: ``(b,)`` uniform numbers in [0, 1), the random pick of each patch.
            extra: ``(b, m')`` int or None: more candidates of each patch (-1 for
                none), the coherent candidates of :func:`_coherent_candidates`,
                refined exactly with the tree's (duplicates count once).

        Coarse level: the k-d tree returns the ``_NEIGHBOURS`` approximate nearest
        candidates in QTP + PCA feature space (one batched query for the ``b``
        patches). Fine level: their exact zone distances ``d`` at full resolution;
        the ``floor(u m)``-th of the ``m`` candidates with ``d <= (1 + tolerance)
        d_min`` (in order of feature distance) is taken, a uniform random pick;
        if some of those ``m`` are coherent candidates (``extra``), the pick is among
        them (``_PREFER_COHERENT``).

        Returns:
            ``(b,)`` int, indices into the candidate windows (``cy``, ``cx``).
        """
        b = len(old)
        e_out = old.reshape(b, -1).take(zone.pflat, axis=1)  # (b, A) mm
        # Features, (b, K): matrix products of at most _MATMUL_ROWS patches, which
        # OpenBLAS runs single-threaded (a multithreaded one stalls on a busy machine).
        f = np.empty((b, len(zone.kernels)), dtype=np.float32)  # type: ignore[arg-type]
        for s in range(0, b, _MATMUL_ROWS):
            np.matmul(e_out[s: s + _MATMUL_ROWS], zone.kernels.T, out=f[s: s + _MATMUL_ROWS])  # type: ignore[union-attr]
        f = f.astype(np.float64)
        if zone.tree is None and zone.uses <= 1:
            # A closing zone serving a single patch (the corner of a torus): a linear
            # scan of the features costs less than building its tree.
            d = np.einsum("ik,ik->i", zone.feats - f, zone.feats - f)[None, :]  # type: ignore[operator]
            k = min(_NEIGHBOURS, d.shape[1])
            nn = np.argpartition(d, k - 1, axis=1)[:, :k]
            order = np.argsort(np.take_along_axis(d, nn, axis=1), axis=1, kind="stable")
            nn = np.take_along_axis(nn, order, axis=1)
        else:
            if zone.tree is None:
                zone.tree = _tree(zone)
            # (One thread: scipy's ``workers`` starts threads per call, which cost
            # more than they save on a front of ~30-70 patches on a busy 2-core machine.)
            _, nn = zone.tree.query(f, k=self.k, eps=_KD_EPS)
        nn = nn.reshape(b, -1)
        invalid = None
        if extra is not None and extra.shape[1]:
            # Coherent candidates join the exact refinement; those missing (-1) or
            # already present are marked invalid (infinite distance) so every
            # candidate counts once in the uniform pick.
            dup = (extra[:, :, None] == nn[:, None, :]).any(axis=2)
            dup |= np.triu(extra[:, :, None] == extra[:, None, :], 1).any(axis=1)
            bad = dup | (extra < 0)
            keep = ~bad.all(axis=0)  # (the neighbours that no patch of the batch has)
            extra, bad = extra[:, keep], bad[:, keep]
            nn = np.concatenate([nn, np.where(bad, nn[:, :1], extra)], axis=1)
            invalid = np.concatenate([np.zeros((b, nn.shape[1] - extra.shape[1]), bool), bad], axis=1)
        # Exact distances of the approximate neighbours, (b, m) in mm^2 * A: the
        # zone's rectangles of each neighbour, copied out of the sample's windows.
        cy, cx = self.cy.take(nn), self.cx.take(nn)
        d2 = None
        for dy, dx, h, w in zone.rects:
            g = self.windows(h, w)[cy + dy, cx + dx]  # (b, m, h, w)
            g -= old[:, None, dy: dy + h, dx: dx + w]
            g = g.reshape(b, nn.shape[1], h * w)
            if d2 is None:
                d2 = np.einsum("bmi,bmi->bm", g, g)
            else:
                d2 += np.einsum("bmi,bmi->bm", g, g)
        if invalid is not None:
            d2[invalid] = np.inf
        ok = d2 <= d2.min(axis=1, keepdims=True) * (1.0 + tolerance) ** 2
        if _PREFER_COHERENT and invalid is not None:
            coh = np.zeros_like(ok)
            coh[:, nn.shape[1] - extra.shape[1]:] = True
            okc = ok & coh
            ok = np.where(okc.any(axis=1, keepdims=True), okc, ok)
        r = (u * ok.sum(axis=1)).astype(np.intp)  # the r-th eligible candidate
        pos = (np.cumsum(ok, axis=1) > r[:, None]).argmax(axis=1)
        return nn[np.arange(b), pos]


# ------------------------------------------------------------------------------------
# Blending
# ------------------------------------------------------------------------------------
def _min_error_paths(
    errs: Sequence[np.ndarray],
    starts: Sequence[int | None],
    work: dict | None = None,
) -> list[np.ndarray]:
    """Minimum-error boundary cuts (the paper's eq. 1) through several strips at once.

    Each ``errs[s]`` is an ``(n, w_s)`` error ``e_ij = (B1_ij - B2_ij)^2`` (mm^2) with
    the same ``n``; the cut runs from its first row to its last, one column per row:

        E_1j = e_1j,   E_ij = e_ij + min(E_{i-1,j-1}, E_{i-1,j}, E_{i-1,j+1}),

    (Efros and Freeman 2001), then backtracks from the smallest ``E_nj``. The strips
    are laid side by side with infinite error between them, so one vectorized step
    per row serves all of them (all the strips of a batch of patches: see
    :func:`_cut_alphas`), and so does one vectorized backtracking step when there
    are many strips. ``starts[s]``, if not None, fixes the path's column in the
    first row. ``work``, a dict kept by the caller, caches the buffers and row views
    of each table size (half the cost of the per-row loop is slicing).

    Returns:
        One ``(n,)`` int array per strip: the path's column in each row.
    """
    n = errs[0].shape[0]
    widths = [e.shape[1] for e in errs]
    offsets = np.cumsum([1] + [w + 1 for w in widths[:-1]])
    total = sum(widths) + len(widths) + 1
    ws = work.get((n, total)) if work is not None else None
    if ws is None:
        E = np.empty((n, total))
        buf = np.empty(total - 2)
        steps = [(E[i - 1, :-2], E[i - 1, 1:-1], E[i - 1, 2:], E[i, 1:-1]) for i in range(1, n)]
        ws = (E, buf, steps)
        if work is not None:
            work[(n, total)] = ws
    E, buf, steps = ws
    E.fill(np.inf)
    for off, err, st in zip(offsets.tolist(), errs, starts):
        E[:, off: off + err.shape[1]] = err
        if st is not None:
            keep = E[0, off + st]
            E[0, off: off + err.shape[1]] = np.inf
            E[0, off + st] = keep
    minimum, add = np.minimum, np.add
    for a, b, c, row in steps:
        minimum(a, b, out=buf)
        minimum(buf, c, out=buf)
        add(row, buf, out=row)
    # Backtrack from the smallest E_nj: each step moves to the first of (j-1, j, j+1)
    # with the least cumulative error.
    last = E[-1]
    if len(errs) > _VECTOR_BACKTRACK:
        # First column of each strip where the last row reaches the strip's minimum.
        lowest = np.minimum.reduceat(last, offsets)
        at = np.flatnonzero(last[1:] == np.repeat(lowest, np.diff(np.r_[offsets, total]))) + 1
        j = at[np.searchsorted(at, offsets)]
        # The step of every cell at once (column j - 1 of `step` is column j of E),
        # then one gather per row for all the strips.
        a, b, c = E[:-1, :-2], E[:-1, 1:-1], E[:-1, 2:]
        step = np.where((a <= b) & (a <= c), np.int8(-1), (c < b).astype(np.int8))
        paths = np.empty((len(errs), n), dtype=np.intp)
        paths[:, -1] = j
        for i in range(n - 2, -1, -1):
            j = j + step[i].take(j - 1)
            paths[:, i] = j
        return list(paths - offsets[:, None])
    j = np.array([off + int(np.argmin(last[off: off + w])) for off, w in zip(offsets.tolist(), widths)])
    rows = E.tolist()
    out = []
    for jj, off in zip(j.tolist(), offsets.tolist()):
        path = [jj] * n
        for i in range(n - 2, -1, -1):
            r = rows[i]
            a, b, c = r[jj - 1], r[jj], r[jj + 1]
            if a <= b and a <= c:
                jj -= 1
            elif c < b:
                jj += 1
            path[i] = jj
        out.append(np.asarray(path) - off)
    return out


#: More strips than this are backtracked by one numpy step per row for all of them.
_VECTOR_BACKTRACK = 6
#: Width in px of the ramp that softens each minimum-error cut (0 = hard cut).
_CUT_RAMP = 2


def _cut_alphas(
    old: np.ndarray,
    new: np.ndarray,
    key: tuple[int, int, int, int],
    anchor: np.ndarray,
    work: dict | None = None,
) -> np.ndarray:
    """``(b, p, p)`` float32 weights of ``b`` new patches from minimum-error boundary cuts.

    ``old``, ``new``: ``(b, p, p)`` float32 heights in mm of the output under each
    patch and of the patch; all share the zone ``key`` = ``(top, left, right,
    bottom)`` widths in px. One cut (eq. 1) per synthesized strip of the zone,
    through the squared difference ``(old - new)^2`` in mm^2; the cuts of all ``b``
    patches are found by one dynamic programme (:func:`_min_error_paths`).
    The old output is kept up to the path; the new patch takes over within
    ``_CUT_RAMP`` px after it (weights ``1/3, 2/3`` for 2 px), which removes the small
    step a hard cut leaves without blurring detail. Paths are confined so that the
    ramps stay inside their strips; the weights of the strips combine by ``min``
    (in the corner of the L the old output stays where either cut keeps it).

    ``anchor`` (``(b,)`` bool; the first patch of a row on a torus wrapped along x):
    the output left of the patch is already synthesized in the top (and bottom)
    strip's rows, so those cuts start at the strip's inner edge in the first column,
    keeping the old output along the patch's left edge there; the closing patch of
    the row later cuts against this patch as its right neighbour. ``work``: see
    :func:`_min_error_paths`.
    """
    nb, p = old.shape[0], old.shape[1]
    t, l, r, b = key
    g = [max(0, min(_CUT_RAMP, w - 1)) for w in key]
    err = old - new
    err *= err
    errT = err.transpose(0, 2, 1)
    strips: list[np.ndarray] = []
    starts: list[int | None] = []
    kinds: list[tuple[bool, bool, int, int]] = []  # (transposed, leading, offset, ramp)
    free = [None] * nb
    if l:
        strips += [e[:, : l - g[1]] for e in err]
        starts += free
        kinds.append((False, True, 0, g[1]))
    if r:
        c0 = min(max(p - r + g[2], l), p - 1)
        strips += [e[:, c0:] for e in err]
        starts += free
        kinds.append((False, False, c0, g[2]))
    if t:
        strips += [e[:, : t - g[0]] for e in errT]
        starts += [t - g[0] - 1 if a else None for a in anchor.tolist()]
        kinds.append((True, True, 0, g[0]))
    if b:
        c0 = min(max(p - b + g[3], t), p - 1)
        strips += [e[:, c0:] for e in errT]
        starts += [0 if a else None for a in anchor.tolist()]
        kinds.append((True, False, c0, g[3]))
    if not kinds:
        return np.ones((nb, p, p), dtype=np.float32)
    paths = _min_error_paths(strips, starts, work)
    alpha: np.ndarray | None = None
    for s, (transposed, leading, off, ramp) in enumerate(kinds):
        # Row q of the table: the weight along a row whose cut lies at column q.
        tkey = ("ramp", p, leading, ramp)
        table = work.get(tkey) if work is not None else None
        if table is None:
            k = np.arange(p, dtype=np.float32)
            d = (k[None, :] - k[:, None]) if leading else (k[:, None] - k[None, :])
            table = np.clip(d / np.float32(ramp + 1.0), 0.0, 1.0).astype(np.float32)
            if work is not None:
                work[tkey] = table
        a = table[np.stack(paths[s * nb: (s + 1) * nb]) + off]  # (b, p, p)
        if transposed:
            a = a.transpose(0, 2, 1)
        alpha = a if alpha is None else np.minimum(alpha, a)
    return alpha  # type: ignore[return-value]


# ------------------------------------------------------------------------------------
# Driver
# ------------------------------------------------------------------------------------
def _overlaps(ax: _Axis, p: int) -> np.ndarray:
    """``(n, n)`` bool: do patches ``j`` and ``j'`` of the axis share pixels (cyclically
    on a wrapped axis)?"""
    d = np.abs(ax.starts[:, None] - ax.starts[None, :])
    if ax.wrap:
        d = np.minimum(d, ax.canvas - d)
    return d < p


def _levels(ay: _Axis, ax: _Axis, p: int) -> np.ndarray:
    """``(rows, cols)`` int: the wavefront step at which each patch is pasted.

    A patch must come after every patch that precedes it in scan-line order and shares
    pixels with it (its zone is their output), and the patches of one step must not
    share pixels; the earliest such schedule is ``level = 1 + max(level of the earlier
    patches it overlaps)``. Every pair of overlapping patches is then pasted in
    scan-line order, so each patch sees exactly the output it would see in scan-line
    order, and the result is the scan-line result (Liang 2001, section 3.2), while
    the patches of a step (about ``cols / ceil(patch / step)`` of them for a large
    output without wrap along x, a diagonal front) are matched and pasted together.
    With wrap along x the first patch of a row overlaps the last one of the row
    above: the schedule is then plain scan-line order.
    """
    oy, ox = _overlaps(ay, p), _overlaps(ax, p)
    n = len(ax.starts)
    # Overlaps of column j, grouped by j, for a max over each group (reduceat).
    jj, jp = np.nonzero(ox)
    first = np.flatnonzero(np.r_[True, jj[1:] != jj[:-1]])
    ramp = np.arange(n)
    lev = np.zeros((len(ay.starts), n), dtype=np.int64)
    for i in range(len(ay.starts)):
        need = np.zeros(n, dtype=np.int64)
        for i2 in np.flatnonzero(oy[i, :i]):
            np.maximum(need, np.maximum.reduceat(lev[i2].take(jp), first) + 1, out=need)
        # Along the row each patch follows its left neighbour.
        lev[i] = np.maximum.accumulate(need - ramp) + ramp
    return lev


def _closing_tolerance(key: tuple[int, int, int, int], tolerance: float) -> float:
    """The tolerance of a patch's candidate set: ``_CLOSING_TOLERANCE`` (at most
    ``tolerance``) for the closing patches of a torus (a right or bottom strip), which
    are few and hardest to match, so they take (nearly) the best match."""
    return min(tolerance, _CLOSING_TOLERANCE) if (key[2] or key[3]) else tolerance


def _neighbour_table(ay: _Axis, ax: _Axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The earlier neighbours of every patch, for its coherent candidates.

    For patch ``(i, j)``, the patches ``(i + di, j + dj)``, ``di, dj`` in ``{-1, 0, 1}``
    (cyclically along a wrapped axis), that come before it in scan-line order: the
    ones whose output forms its boundary zone.

    Returns:
        ``(nb, dy, dx)``, each ``(rows * cols, 8)`` int: the flat index of each
        neighbour (-1 for none) and its top-left pixel relative to the patch's, in px
        (across the wrap: as the torus places it).
    """
    n_rows, n_cols = len(ay.starts), len(ax.starts)
    i, j = np.divmod(np.arange(n_rows * n_cols), n_cols)
    cols_nb, cols_dy, cols_dx = [], [], []
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            if (di == 0 and dj == 0) or (di and dj and not _COHERENT_DIAGONALS):
                continue
            i2, j2 = i + di, j + dj
            ok = np.ones(len(i), bool)
            dy = np.zeros(len(i), np.int64)
            dx = np.zeros(len(i), np.int64)
            for a, a2, d, step, axis in ((i, i2, dy, di, ay), (j, j2, dx, dj, ax)):
                n = len(axis.starts)
                if axis.wrap:
                    a2 %= n
                else:
                    ok &= (a2 >= 0) & (a2 < n)
                a2c = np.clip(a2, 0, n - 1)
                d[:] = axis.starts[a2c] - axis.starts[a]
                if axis.wrap:  # the neighbour across the wrap sits past the end
                    d[(step > 0) & (a2c < a)] += axis.canvas
                    d[(step < 0) & (a2c > a)] -= axis.canvas
            i2c, j2c = np.clip(i2 % n_rows, 0, n_rows - 1), np.clip(j2 % n_cols, 0, n_cols - 1)
            flat2 = i2c * n_cols + j2c
            ok &= flat2 < i * n_cols + j  # earlier in scan-line order (not itself)
            cols_nb.append(np.where(ok, flat2, -1))
            cols_dy.append(dy)
            cols_dx.append(dx)
    return np.stack(cols_nb, 1), np.stack(cols_dy, 1), np.stack(cols_dx, 1)


def _coherent_candidates(
    flat: np.ndarray,
    chosen: np.ndarray,
    table: tuple[np.ndarray, np.ndarray, np.ndarray],
    syn: "_Synthesizer",
) -> np.ndarray:
    """``(b, 8)`` candidate indices (-1 for none) that continue the neighbours' sources.

    If an earlier neighbour of a patch was copied from the sample window at
    ``(y, x)`` and sits ``(dy, dx)`` px from the patch, the window at ``(y - dy,
    x - dx)`` continues it: its boundary zone equals the output wherever that
    neighbour alone made it (the "coherent" candidates of Ashikhmin 2001 and
    Tong et al. 2002's k-coherence, here added to Liang 2001's approximate nearest
    neighbours). These are the matches an exhaustive search finds first and a
    k-d tree over a few principal components tends to miss.
    """
    nb, dy, dx = (t[flat] for t in table)
    c2 = np.where(nb >= 0, chosen[np.maximum(nb, 0)], -1)
    y = syn.cy[np.maximum(c2, 0)] - dy
    x = syn.cx[np.maximum(c2, 0)] - dx
    ny, nx = syn.lookup.shape
    ok = (c2 >= 0) & (y >= 0) & (y < ny) & (x >= 0) & (x < nx)
    idx = syn.lookup[np.where(ok, y, 0), np.where(ok, x, 0)]
    return np.where(ok, idx, -1)


def _quilt(
    sample: Heightmap | np.ndarray,
    shape: tuple[int, int],
    patch: int,
    overlap: int,
    tolerance: float,
    seed: int | np.random.Generator,
    blend: str,
    wrap: str | None,
    progress: ProgressFn | None,
    search: str | None,
) -> Heightmap:
    hm = _as_sample(sample)
    out_shape = _shape(shape)
    blend = _check_blend(blend)
    wrap_y, wrap_x = _wrap_axes(wrap)
    p, o = _check_patch(hm, patch, overlap)
    _check_wrap_size(out_shape, wrap_y, wrap_x, p)
    if progress is not None and not callable(progress):
        raise ParameterError(f"progress must be a callable(fraction, message) or None, got {progress!r}")
    if isinstance(seed, np.random.Generator):
        rng = seed
    elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
        rng = np.random.default_rng(int(seed))
    else:
        raise ParameterError(f"seed must be a whole number >= 0 or a numpy Generator, got {seed!r}")
    ay = _axis(out_shape[0], p, o, wrap_y)
    ax = _axis(out_shape[1], p, o, wrap_x)
    require_memory(
        ay.canvas * ax.canvas * 4 * 3 + hm.heights.size * 8 * 40,
        f"synthesizing a {out_shape[0]} x {out_shape[1]} px texture",
        "synthesize a smaller output or use a larger pitch",
    )
    q = _Quilter(hm.heights, ay, ax, p, o, rng, search, tolerance, blend == "feather", wrap_x)
    canvas = q.run(progress, f"synthesizing {out_shape[0]} x {out_shape[1]} px ({len(ay.starts)} patch rows)")
    return Heightmap(np.ascontiguousarray(canvas[: out_shape[0], : out_shape[1]]), hm.pitch)


class _Quilter:
    """One synthesis run: the canvas, the patch grid with the zone type of every
    patch, the random pick of each patch (same seed, same picks, whatever the
    schedule) and the wavefront schedule (:func:`_levels`)."""

    def __init__(self, S, ay, ax, p: int, o: int, rng, search, tolerance: float, feather: bool, wrap_x: bool):
        self.S, self.ay, self.ax, self.p = S, ay, ax, p
        self.syn = _Synthesizer(S, p, o, rng, search)
        self.search, self.tolerance, self.feather, self.wrap_x = search, tolerance, feather, wrap_x
        self.n_rows, self.n_cols = len(ay.starts), len(ax.starts)
        self.ncand = len(self.syn.cy)
        self.code, self.zone_keys = self._zone_types()
        self.u = rng.random((self.n_rows, self.n_cols))
        self.canvas = np.zeros((ay.canvas, ax.canvas), dtype=np.float32)
        self.windows = np.lib.stride_tricks.sliding_window_view(self.canvas, (p, p))
        self.Swin = self.syn.windows(p, p)
        self.row_wraps = ay.starts + p > ay.canvas
        self.col_wraps = ax.starts + p > ax.canvas
        self.rows_px = (ay.starts[:, None] + np.arange(p)) % ay.canvas  # (rows, p) for wrapped patches
        self.cols_px = (ax.starts[:, None] + np.arange(p)) % ax.canvas
        self.cut_work: dict = {}
        self.table = _neighbour_table(ay, ax) if search == "approximate" and _COHERENT else None
        self.chosen = np.full(self.n_rows * self.n_cols, -1, dtype=np.intp)  # candidate pasted at each patch

    def _zone_types(self):
        """Zone type of every patch: (top, left, right, bottom) strip widths in px."""
        ay, ax = self.ay, self.ax
        rkind, rtype = np.unique(np.stack([ay.before, ay.after], axis=1), axis=0, return_inverse=True)
        ckind, ctype = np.unique(np.stack([ax.before, ax.after], axis=1), axis=0, return_inverse=True)
        code = rtype.reshape(-1, 1) * len(ckind) + ctype.reshape(1, -1)  # (rows, cols)
        codes, first_at, counts = np.unique(code, return_index=True, return_counts=True)
        zone_keys: dict[int, tuple[int, int, int, int]] = {}
        for c, at, m in sorted(zip(codes.tolist(), first_at.tolist(), counts.tolist()), key=lambda x: x[1]):
            (t, b), (l, r) = rkind[c // len(ckind)].tolist(), ckind[c % len(ckind)].tolist()
            zone_keys[c] = (t, l, r, b)
            if (t, l, r, b) != (0, 0, 0, 0):
                self.syn.zone((t, l, r, b)).uses = m  # fitted in scan-line order of first use
        return code, zone_keys

    def run(self, progress, message: str) -> np.ndarray:
        levels = _levels(self.ay, self.ax, self.p)
        flat = levels.ravel()
        order = np.argsort(flat, kind="stable")
        bounds = np.flatnonzero(np.diff(flat[order])) + 1
        row_done = levels.max(axis=1)  # rows finish in order
        next_row = 0
        code_rows = self.code.tolist()
        for batch in np.split(order, bounds):  # per wavefront step
            if len(batch) == 1:
                self._paste_one(int(batch[0]), batch, code_rows)
            else:
                self._paste_batch(batch)
            if progress is not None:
                lev = int(flat[batch[0]])
                while next_row < self.n_rows and row_done[next_row] == lev:
                    next_row += 1
                    progress(next_row / self.n_rows, message)  # one message: reporters may throttle
        return self.canvas

    def _pick(self, key, old, gu, ids):
        """Candidates for patches of zone type ``key`` over ``old`` (b, p, p)."""
        syn = self.syn
        if key == (0, 0, 0, 0) or not self.search:  # the first patch: anywhere in the sample
            return np.minimum((gu * self.ncand).astype(np.intp), self.ncand - 1)
        if self.search == "exact" or (_EXACT_CLOSING and (key[2] or key[3])):
            return syn.query_exact(syn.zone(key), old, _closing_tolerance(key, self.tolerance), gu)
        extra = None if self.table is None else _coherent_candidates(ids, self.chosen, self.table, syn)
        return syn.query(syn.zone(key), old, self.tolerance, gu, extra)

    def _blend(self, key, old, new, wrap_first):
        """``new`` blended over ``old`` in the overlaps (feathered or cut, eq. 1), in place."""
        if key != (0, 0, 0, 0):
            alpha = self.syn.zone(key).alpha if self.feather else _cut_alphas(old, new, key, wrap_first, self.cut_work)
            new -= old
            new *= alpha
            new += old
        return new

    def _paste_one(self, pid: int, batch: np.ndarray, code_rows) -> None:
        """One patch (a serial schedule): the same arithmetic on views and scalars."""
        i, j = divmod(pid, self.n_cols)
        p = self.p
        key = self.zone_keys[code_rows[i][j]]
        if self.row_wraps[i] or self.col_wraps[j]:
            idx: tuple = np.ix_(self.rows_px[i], self.cols_px[j])
        else:
            y0, x0 = int(self.ay.starts[i]), int(self.ax.starts[j])
            idx = (slice(y0, y0 + p), slice(x0, x0 + p))
        old = self.canvas[idx][None]  # (1, p, p)
        c0 = int(np.asarray(self._pick(key, old, self.u[i, j].reshape(1), batch)).reshape(-1)[0])
        self.chosen[pid] = c0
        y0, x0 = int(self.syn.cy[c0]), int(self.syn.cx[c0])
        new = self.S[y0: y0 + p, x0: x0 + p][None].copy()
        self.canvas[idx] = self._blend(key, old, new, np.array([self.wrap_x and j == 0]))[0]

    def _paste_batch(self, batch: np.ndarray) -> None:
        """Match and paste the patches of one wavefront step, a zone type at a time."""
        bi, bj = np.divmod(batch, self.n_cols)
        bcode = self.code[bi, bj]
        groups = [slice(None)] if (bcode == bcode[0]).all() else [bcode == c for c in np.unique(bcode)]
        for sel in groups:  # per zone type
            gi, gj = bi[sel], bj[sel]
            key = self.zone_keys[int(self.code[gi[0], gj[0]])]
            wrapped = self.row_wraps[gi] | self.col_wraps[gj]
            old = self._old(gi, gj, wrapped)
            c = self._pick(key, old, self.u[gi, gj], batch[sel])
            self.chosen[batch[sel]] = c
            new = self.Swin[self.syn.cy[c], self.syn.cx[c]]  # (b, p, p) float32 copy
            new = self._blend(key, old, new, self.wrap_x & (gj == 0))
            self._put(gi, gj, wrapped, new)

    def _old(self, gi, gj, wrapped):
        """The canvas under patches ``(gi, gj)``: ``(b, p, p)``."""
        p = self.p
        if not wrapped.any():
            return self.windows[self.ay.starts[gi], self.ax.starts[gj]]
        old = np.empty((len(gi), p, p), dtype=np.float32)
        plain = ~wrapped
        old[plain] = self.windows[self.ay.starts[gi[plain]], self.ax.starts[gj[plain]]]
        for k in np.flatnonzero(wrapped).tolist():  # per wrapped patch
            old[k] = self.canvas[np.ix_(self.rows_px[gi[k]], self.cols_px[gj[k]])]
        return old

    def _put(self, gi, gj, wrapped, new) -> None:
        # (One slice assignment per patch: a fancy assignment through the overlapping
        # windows costs several times more.)
        p = self.p
        for k, (y, x, w) in enumerate(zip(self.ay.starts[gi].tolist(), self.ax.starts[gj].tolist(), wrapped.tolist())):
            if w:
                self.canvas[np.ix_(self.rows_px[gi[k]], self.cols_px[gj[k]])] = new[k]
            else:
                self.canvas[y: y + p, x: x + p] = new[k]


def synthesize(
    sample: Heightmap | np.ndarray,
    shape: tuple[int, int],
    *,
    patch: int = 45,
    overlap: int = 25,
    tolerance: float = 0.1,
    seed: int | np.random.Generator = 0,
    blend: str = "feather",
    wrap: str | None = None,
    progress: ProgressFn | None = None,
    search: str = "approximate",
) -> Heightmap:
    """Grow a texture sample into a larger heightmap (paper section 2.1.2; Liang 2001).

    Patches of the sample are pasted in scan-line order; each new patch is chosen at
    random among the sample windows whose boundary zone (the already synthesized
    strips of its footprint) matches the output within ``tolerance`` of the best match,

        d(E_B, E_out) = sqrt((1/A) sum_E (p_B - p_out)^2) <= (1 + tolerance) d_min,

    found with Liang's accelerated search (quadtree pyramid + PCA features computed by
    FFT correlation, one k-d tree per zone type, exact refinement of the approximate
    nearest neighbours). The overlap is blended by feathering (Liang 2001) or by the
    minimum-error boundary cut (the paper's eq. 1).

    Args:
        sample: the texture sample, a Heightmap (heights in mm, pitch in mm/px), or a
            2-D array of heights in mm (pitch then 1.0 mm/px). It must be at least
            ``patch`` px in both directions; non-square samples are fine.
        shape: ``(rows, cols)`` of the output in px (rows along y, cols along x), at the
            sample's pitch. Any size >= 2 x 2 px: the patch grid is extended past it and
            cropped; an output smaller than the sample or a patch is fine.
        patch: patch size ``w_B`` in px (Liang's patch; the paper uses 25 for a 150 x 100
            px sample and 45 for 200 x 200 px samples). Make it larger than the
            texture's features (a few feature sizes): larger patches keep more
            structure, smaller ones give more variety. ``2 <= patch <= min(sample shape)``.
        overlap: boundary-zone width ``w_E`` in px: how far neighbouring patches
            overlap, and so how much context decides each match and the width of the
            blend (paper: 10 for patch 25, 25 for patch 45). ``1 <= overlap < patch``;
            a third to a half of ``patch`` works well.
        tolerance: relative tolerance ``epsilon`` of the candidate set: every candidate
            whose zone distance is at most ``(1 + tolerance)`` times the best found is
            eligible (Efros and Freeman's 0.1; Liang's ``d_max`` rule with the bound
            relative to the best match). 0 always takes the best match (least
            variety); larger values trade matching quality for randomness. Among the
            ``16`` approximate nearest neighbours of the k-d tree and the coherent
            candidates (``search="approximate"``), or among all sample windows
            (``"exact"``).
        seed: seed of ``numpy.random.default_rng`` (or a Generator), which chooses the
            first patch, the PCA subset and each patch among its candidates. Same
            inputs and seed give byte-identical output.
        blend: ``"feather"`` (Liang 2001: linear weights across the overlap, smooth) or
            ``"cut"`` (the paper's eq. 1 minimum-error boundary cut: sharp detail, a
            small step may remain along the cut).
        wrap: ``None``, ``"x"``, ``"y"`` or ``"xy"``: make the output tile along these
            axes (for a closed surface such as a cylinder, the paper's M-II). The
            texture is synthesized on a torus: the patches that close a row (column)
            overlap the first patches across the wrap, are matched against both
            neighbours and are blended on both sides. The output size along a wrapped
            axis needs no particular value (>= ``patch``): the closing patch's overlap
            across the wrap is ``n step - size + overlap`` px with
            ``n = ceil(size / step)``, ``step = patch - overlap``.
        progress: optional ``callable(fraction, message)``, called after each patch
            row with the fraction of rows done in (0, 1] (the message is the same
            for every call, so reporters can throttle it).
        search: ``"approximate"`` (default; Liang 2001 section 4: QTP + PCA k-d tree,
            exact re-ranking of the nearest candidates) or ``"exact"`` (the
            exhaustive zone distance to every sample window by FFT correlation,
            Liang's section 3.2; tens of times slower, the quality baseline).

    Returns:
        Heightmap of exactly ``shape`` px with the sample's pitch (mm/px); heights are
        convex combinations of sample heights, so they stay within the sample's range.

    Raises:
        ParameterError: patch, overlap, shape, tolerance, blend or wrap out of range or
            unknown (the message names the value and the fix).
        InputError: the sample is not a heightmap or has NaN heights.
        ResourceError: the output would not fit in memory.
    """
    tol = _tolerance(tolerance)
    if search not in SEARCHES:
        raise ParameterError(f"unknown search {search!r}; use one of {', '.join(map(repr, SEARCHES))}")
    return _quilt(sample, shape, patch, overlap, tol, seed, blend, wrap, progress, search=search)


def naive_quilt(
    sample: Heightmap | np.ndarray,
    shape: tuple[int, int],
    *,
    patch: int = 45,
    overlap: int = 25,
    seed: int | np.random.Generator = 0,
    blend: str = "feather",
    wrap: str | None = None,
) -> Heightmap:
    """Baseline without matching: random sample patches pasted on the same grid.

    Exactly :func:`synthesize` with the candidate set replaced by all sample windows
    (uniformly random patches, Liang 2001's "random patch pasting"), blended the same
    way. Quality measures of :mod:`texcad.synthesis.quality` compare synthesis against it.

    Args: as :func:`synthesize` (``patch``, ``overlap`` in px).

    Returns:
        Heightmap of ``shape`` px at the sample's pitch.
    """
    return _quilt(sample, shape, patch, overlap, 0.0, seed, blend, wrap, None, search=None)


def _tolerance(tolerance: object) -> float:
    try:
        t = float(tolerance)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ParameterError(f"tolerance must be a number >= 0, got {tolerance!r}") from None
    if not np.isfinite(t) or t < 0:
        raise ParameterError(
            f"tolerance must be a finite number >= 0 (e.g. 0.1 for 10 % of the best match), got {tolerance!r}"
        )
    return t
