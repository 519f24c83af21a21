"""The Heightmap: a texture as heights in mm on a regular grid.

A :class:`Heightmap` is ``heights[row, col]`` in millimetres with a pixel ``pitch``
``(px, py)`` in millimetres per pixel. Row index runs along +y and column index along
+x, so a texture seen from +z looks like its image. Sample ``(r, c)`` sits at the
centre of its pixel, ``x = (c + 1/2) px``, ``y = (r + 1/2) py``, and the texture
covers ``size = (cols px, rows py)`` (800 px at 0.125 mm cover 100 mm, paper section
2.2). Heights are measured outward from the surface: 0 lies on the surface (black in
an image), the maximum is white (paper, section 2.1.4).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..util import positive
from ..util import require_memory
from ..errors import InputError, ParameterError

__all__ = ["Heightmap"]




def _nonnegative(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number in mm, got {value!r}") from None
    if not np.isfinite(v) or v < 0:
        raise ParameterError(f"{name} must be zero or a positive number of mm, got {value!r}")
    return v


def _percentiles(normalize: "bool | Sequence[float]") -> tuple[float, float] | None:
    """``normalize`` as a percentile pair, or None for no normalisation."""
    if normalize is False or normalize is None:
        return None
    if normalize is True:
        return (0.0, 100.0)
    try:
        lo, hi = (float(v) for v in normalize)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ParameterError(
            f"normalize must be True, False or a (low, high) percentile pair such as (1, 99), got {normalize!r}"
        ) from None
    if not (0.0 <= lo < hi <= 100.0):
        raise ParameterError(f"normalize percentiles must satisfy 0 <= low < high <= 100, got {normalize!r}")
    return (lo, hi)


def _crop(gray: np.ndarray, box: Sequence[float], units: str, src: tuple[float, float], path) -> np.ndarray:
    """Cut ``box = (left, top, right, bottom)`` (image orientation, px or mm at the
    image pitch ``src``) out of the y-up array ``gray``."""
    rows, cols = gray.shape
    try:
        left, top, right, bottom = (float(v) for v in box)
    except (TypeError, ValueError):
        raise ParameterError(f"crop must be (left, top, right, bottom), got {box!r}") from None
    if units == "mm":
        left, right = left / src[0], right / src[0]
        top, bottom = top / src[1], bottom / src[1]
    c0, c1, r0, r1 = (int(round(v)) for v in (left, right, top, bottom))
    if not (0 <= c0 < c1 <= cols and 0 <= r0 < r1 <= rows) or c1 - c0 < 2 or r1 - r0 < 2:
        full = (cols, rows) if units == "px" else (cols * src[0], rows * src[1])
        raise ParameterError(
            f"crop box {tuple(box)!r} {units} does not fit image {os.fspath(path)!r} of {full[0]:g} x {full[1]:g} {units}; "
            f"give 0 <= left < right <= {full[0]:g} and 0 <= top < bottom <= {full[1]:g}, at least 2 x 2 pixels"
        )
    # Image rows r0..r1-1 (from the top) are y-up rows rows-r1 .. rows-r0-1.
    return gray[rows - r1 : rows - r0, c0:c1]


def _pair(name: str, value: float | Sequence[float]) -> tuple[float, float]:
    if np.ndim(value) == 0:
        v = positive(name, value)  # type: ignore[arg-type]
        return (v, v)
    vals = list(value)  # type: ignore[arg-type]
    if len(vals) != 2:
        raise ParameterError(f"{name} must be one number or (x, y) in mm, got {value!r}")
    return (positive(f"{name}[0]", vals[0]), positive(f"{name}[1]", vals[1]))


@dataclass(frozen=True, eq=False)
class Heightmap:
    """Texture heights in mm on a regular grid.

    Attributes:
        heights: ``(rows, cols)`` float32 array of heights in mm; row along +y,
            column along +x.
        pitch: ``(px, py)`` pixel pitch in mm per pixel along x and y.
    """

    heights: np.ndarray
    pitch: tuple[float, float]

    def __post_init__(self) -> None:
        h = np.asarray(self.heights)
        if h.ndim != 2:
            raise ParameterError(f"heights must be a 2-D array (rows, cols), got shape {h.shape}")
        if h.shape[0] < 2 or h.shape[1] < 2:
            raise InputError(f"a heightmap needs at least 2 x 2 pixels, got {h.shape}")
        if not np.issubdtype(h.dtype, np.number):
            raise ParameterError(f"heights must be numbers, got dtype {h.dtype}")
        h = np.ascontiguousarray(h, dtype=np.float32)
        if not np.isfinite(h).all():
            bad = int(np.count_nonzero(~np.isfinite(h)))
            raise InputError(
                f"heights hold {bad} NaN or infinite values; fill or crop them first"
            )
        h.setflags(write=False)
        object.__setattr__(self, "heights", h)
        object.__setattr__(self, "pitch", _pair("pitch", self.pitch))

    # -- construction ------------------------------------------------------------
    @classmethod
    def from_array(
        cls,
        values: np.ndarray,
        *,
        pitch: float | Sequence[float] | None = None,
        size: Sequence[float] | None = None,
        height: float | None = None,
    ) -> "Heightmap":
        """Make a heightmap from a y-up array.

        Args:
            values: ``(rows, cols)`` array. If ``height`` is given, values are
                treated as grey levels and rescaled linearly so that the array's
                minimum lies on the surface (0 mm) and its maximum is ``height`` mm;
                otherwise they are heights in mm as they are.
            pitch: mm per pixel (one number, or ``(px, py)``).
            size: ``(width, depth)`` in mm that the array covers; alternative to
                ``pitch`` (``pitch = size / (cols, rows)``).
            height: maximum height in mm (optional, see ``values``).
        """
        a = np.asarray(values, dtype=np.float64)
        if a.ndim != 2:
            raise ParameterError(f"values must be a 2-D array (rows, cols), got shape {a.shape}")
        p = _resolve_pitch(a.shape, pitch, size)
        if height is not None:
            hmax = positive("height", height)
            lo, hi = float(np.nanmin(a)), float(np.nanmax(a))
            a = (a - lo) / (hi - lo) * hmax if hi > lo else np.zeros_like(a)
        return cls(a.astype(np.float32), p)

    @classmethod
    def from_image(
        cls,
        path: str | os.PathLike,
        *,
        size: Sequence[float] | None = None,
        pitch: float | Sequence[float] | None = None,
        height: float = 1.0,
        invert: bool = False,
        crop: Sequence[float] | None = None,
        crop_units: str = "px",
        normalize: bool | Sequence[float] = False,
        gamma: float = 1.0,
        smooth: float = 0.0,
        alpha: str = "black",
    ) -> "Heightmap":
        """Read a heightmap from an image (paper, section 2.1.4).

        Black lies on the surface (0 mm), white is ``height`` mm, linear in between.
        Colour images are converted to luminance; 8- and 16-bit PNG, JPEG and TIFF
        are read at full precision (a 16-bit grey PNG keeps all 65536 levels, so
        :meth:`to_png` and ``from_image`` round-trip to 1/65535 of the height).

        The grey level ``Y`` in [0, 1] becomes the height, in this order::

            Y  <- alpha (composite), crop, Gaussian smoothing (sigma ``smooth`` mm)
            Y  <- 1 - Y                                   if invert
            Y  <- clip((Y - lo) / (hi - lo), 0, 1)        if normalize (lo, hi: the
                                                          chosen percentiles of Y)
            h  =  height * Y ** gamma                     (mm)

        then, if both ``size`` and ``pitch`` are given, ``h`` is resampled (cubic).

        Args:
            path: PNG, JPEG or TIFF file.
            size: ``(width, depth)`` in mm the whole image covers. With ``size``
                alone the pitch is ``size / (cols, rows)``.
            pitch: mm per pixel. With ``pitch`` alone the size is
                ``(cols, rows) * pitch``. With both, the image is resampled (cubic)
                to ``pitch`` (``size`` then fixes the image's own scale).
            height: height of white in mm (> 0).
            invert: make black the maximum height and white the surface.
            crop: ``(left, top, right, bottom)`` box to keep, measured from the
                image's top-left corner as in an image editor (right and bottom
                exclusive), in pixels or, with ``crop_units="mm"``, in mm at the
                image's own pitch. The result covers the box only.
            crop_units: ``"px"`` or ``"mm"``.
            normalize: stretch the grey levels that are used to the full height:
                ``True`` maps the darkest pixel (after crop and smoothing) to 0 mm and
                the brightest to ``height``; a pair ``(lo, hi)`` of percentiles, e.g.
                ``(1, 99)``, maps those instead and clips the rest (ignores specks).
            gamma: exponent (> 0) on the grey level: > 1 deepens the dark side, < 1
                lifts it. 1 is linear (the paper's mapping).
            smooth: standard deviation in mm (>= 0) of a Gaussian blur applied to the
                image at its own pitch, against scan noise and JPEG blocks.
            alpha: transparency handling: ``"black"`` (default: composite over
                black, so transparent pixels are 0 mm), ``"white"`` (composite over
                white) or ``"ignore"``.

        Raises:
            InputError: unreadable, empty or unknown-format image; normalize on an
                image with no contrast.
            ParameterError: non-positive size, pitch, height or gamma; a crop box
                outside the image; unknown crop_units or alpha.
            ResourceError: the resampled grid would not fit in memory.
        """
        from .image import read_gray

        hmax = positive("height", height)
        g_exp = positive("gamma", gamma)
        sigma = _nonnegative("smooth", smooth)
        if size is None and pitch is None:
            raise ParameterError(
                "say how large the image is: pass size=(width_mm, depth_mm) or pitch=mm_per_pixel"
            )
        if size is not None:
            _pair("size", size)
        if pitch is not None:
            _pair("pitch", pitch)
        if crop_units not in ("px", "mm"):
            raise ParameterError(f"crop_units must be 'px' or 'mm', got {crop_units!r}")
        pct = _percentiles(normalize)
        gray = read_gray(path, alpha=alpha)
        rows, cols = gray.shape
        # The image's own pitch (mm per pixel).
        if size is not None:
            w, d = _pair("size", size)
            src = (w / cols, d / rows)
        else:
            src = _pair("pitch", pitch)  # type: ignore[arg-type]
        if crop is not None:
            gray = _crop(gray, crop, crop_units, src, path)
        if sigma > 0:
            from scipy import ndimage

            gray = ndimage.gaussian_filter(gray, (sigma / src[1], sigma / src[0]), mode="nearest")
        if invert:
            gray = 1.0 - gray
        if pct is not None:
            lo, hi = (float(v) for v in np.percentile(gray, pct))
            if not hi - lo > 1e-9:
                raise InputError(
                    f"image {os.fspath(path)!r} has no contrast to normalize: the used pixels "
                    f"between the {pct[0]:g}th and {pct[1]:g}th percentile all have grey level {lo:.4g}; "
                    "use an image with relief, a wider crop or wider percentiles"
                )
            gray = np.clip((gray - lo) / (hi - lo), 0.0, 1.0)
        if g_exp != 1.0:
            gray = np.power(np.clip(gray, 0.0, 1.0), g_exp)
        if size is not None and pitch is not None:
            w, d = gray.shape[1] * src[0], gray.shape[0] * src[1]
            px, py = _pair("pitch", pitch)
            shape = (max(2, int(round(d / py))), max(2, int(round(w / px))))
            gray = _resample(gray, shape)
            return cls((gray * hmax).astype(np.float32), (w / shape[1], d / shape[0]))
        return cls((gray * hmax).astype(np.float32), src)

    # -- properties --------------------------------------------------------------
    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)`` in pixels."""
        return self.heights.shape  # type: ignore[return-value]

    @property
    def size(self) -> tuple[float, float]:
        """``(width, depth)`` in mm covered by the texture: ``(cols px, rows py)``."""
        r, c = self.shape
        return (c * self.pitch[0], r * self.pitch[1])

    @property
    def max_height(self) -> float:
        """Largest height in mm."""
        return float(self.heights.max())

    @property
    def x(self) -> np.ndarray:
        """``(cols,)`` float64 x of the pixel centres in mm."""
        return (np.arange(self.shape[1]) + 0.5) * self.pitch[0]

    @property
    def y(self) -> np.ndarray:
        """``(rows,)`` float64 y of the pixel centres in mm."""
        return (np.arange(self.shape[0]) + 0.5) * self.pitch[1]

    # -- derived heightmaps ------------------------------------------------------
    def inverted(self) -> "Heightmap":
        """Swap high and low: ``h' = max(h) - h`` (mm); black becomes white."""
        return Heightmap(self.heights.max() - self.heights, self.pitch)

    def scaled(self, height: float) -> "Heightmap":
        """Rescale linearly so the lowest pixel is 0 mm and the highest ``height`` mm."""
        return Heightmap.from_array(self.heights, pitch=self.pitch, height=height)

    def resampled(self, pitch: float | Sequence[float]) -> "Heightmap":
        """Resample (cubic) to a new pitch in mm, keeping the physical size."""
        px, py = _pair("pitch", pitch)
        w, d = self.size
        shape = (max(2, int(round(d / py))), max(2, int(round(w / px))))
        out = _resample(self.heights.astype(np.float64), shape)
        lo, hi = float(self.heights.min()), float(self.heights.max())
        return Heightmap(np.clip(out, lo, hi).astype(np.float32), (w / shape[1], d / shape[0]))

    # -- output ------------------------------------------------------------------
    def to_png(self, path: str | os.PathLike, *, height: float | None = None) -> None:
        """Save as a 16-bit grey PNG: 0 mm is black, ``height`` mm (default: the
        maximum height) is white. The write is atomic."""
        from .image import write_gray16

        top = self.max_height if height is None else positive("height", height)
        write_gray16(path, self.heights / top if top > 0 else np.zeros(self.shape))

    def __repr__(self) -> str:
        r, c = self.shape
        w, d = self.size
        return (
            f"Heightmap({r} x {c} px, {w:g} x {d:g} mm, pitch {self.pitch[0]:g} x "
            f"{self.pitch[1]:g} mm, heights {float(self.heights.min()):g}..{self.max_height:g} mm)"
        )


def _resolve_pitch(
    shape: tuple[int, ...],
    pitch: float | Sequence[float] | None,
    size: Sequence[float] | None,
) -> tuple[float, float]:
    if pitch is not None and size is not None:
        raise ParameterError("give pitch or size, not both")
    if pitch is not None:
        return _pair("pitch", pitch)
    if size is not None:
        w, d = _pair("size", size)
        return (w / shape[1], d / shape[0])
    raise ParameterError("say how large the array is: pass pitch=mm_per_pixel or size=(w_mm, d_mm)")


def _resample(a: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Cubic resampling of a 2-D array to ``shape`` (pixel-centre aligned)."""
    from scipy import ndimage

    require_memory(
        shape[0] * shape[1] * 8 * 3,
        f"a {shape[0]} x {shape[1]} px heightmap",
        "use a larger pitch or a smaller size",
    )
    zr, zc = shape[0] / a.shape[0], shape[1] / a.shape[1]
    rr = (np.arange(shape[0]) + 0.5) / zr - 0.5
    cc = (np.arange(shape[1]) + 0.5) / zc - 0.5
    coords = np.meshgrid(rr, cc, indexing="ij")
    return ndimage.map_coordinates(a, coords, order=3, mode="nearest", prefilter=True)
