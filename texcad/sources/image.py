"""Reading and writing raster images as y-up float arrays.

This is the one place where image rows are flipped: images store row 0 at the top,
texcad stores row 0 at y = 0 (the bottom), so that a texture seen from +z looks like
its image. Everything else in texcad works in the y-up convention.
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np

from ..errors import InputError, ParameterError

__all__ = ["read_gray", "write_gray16", "write_rgb8", "rgb8_image", "save_image"]

#: How :func:`read_gray` treats transparency.
ALPHA_MODES = ("black", "white", "ignore")

# ITU-R BT.709 luma weights for converting colour to luminance.
_LUMA = np.array([0.2126, 0.7152, 0.0722])


def read_gray(path: str | os.PathLike, *, alpha: str = "black") -> np.ndarray:
    """Read an image as luminance in [0, 1], y-up.

    Reads PNG, JPEG and TIFF (and what else Pillow reads), 8- or 16-bit, grey, grey
    with alpha, palette (with or without a transparent colour) or colour. Colour is
    converted to luminance with the Rec. 709 weights ``Y = 0.2126 R + 0.7152 G +
    0.0722 B``. 16-bit grey keeps all 65536 levels (``Y = v / 65535``).

    Args:
        path: image file.
        alpha: what transparency means. ``"black"`` (default): composite over black,
            ``Y' = a Y`` with opacity ``a`` in [0, 1], so transparent pixels lie on the
            surface (0 mm) - the usual meaning of a logo on a transparent background.
            ``"white"``: composite over white, ``Y' = a Y + (1 - a)`` (transparent is
            the full height). ``"ignore"``: drop the alpha channel.

    Returns:
        ``(rows, cols)`` float64 array, 0 = black, 1 = white; row 0 is the bottom
        row of the image (y = 0).

    Raises:
        InputError: the file is missing, empty, not an image, or has no pixels.
        ParameterError: unknown ``alpha``.
    """
    from PIL import Image, UnidentifiedImageError

    if alpha not in ALPHA_MODES:
        raise ParameterError(f"alpha must be one of {', '.join(ALPHA_MODES)}, got {alpha!r}")
    p = Path(path)
    if not p.is_file():
        raise InputError(f"image {str(p)!r} does not exist; check the path")
    if p.stat().st_size == 0:
        raise InputError(f"image {str(p)!r} is empty (0 bytes); export it again")
    try:
        with Image.open(p) as im:
            pages = int(getattr(im, "n_frames", 1))
            if pages > 1:  # a multi-page TIFF, an animated GIF / PNG: which page is the texture is the user's choice
                raise InputError(
                    f"image {str(p)!r} holds {pages} pages (frames); texcad reads one: save the page you want as an "
                    "image of its own (e.g. PIL: Image.open(path).seek(k); .save('page.png')) and pass that"
                )
            _require_image_memory(p, im.size, len(im.getbands()))
            im.load()
            arr = _to_unit_gray(im)
            opacity = _opacity(im) if alpha != "ignore" else None
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if str(p) in msg else f"image {str(p)!r}: {msg}") from None
    except Image.DecompressionBombError as exc:  # Pillow's guard against huge images: no traceback
        raise InputError(
            f"image {str(p)!r} is too large to read safely ({exc}); scale it down to at most "
            f"{Image.MAX_IMAGE_PIXELS or 0:.0f} pixels (one tile of the texture needs no more) and try again"
        ) from None
    except UnidentifiedImageError:
        raise InputError(
            f"{str(p)!r} is not an image format texcad can read; "
            "save it as PNG, JPEG or TIFF"
        ) from None
    except (OSError, SyntaxError, ValueError, TypeError, KeyError, IndexError, EOFError, struct.error) as exc:  # truncated or corrupt data (what Pillow's readers raise)
        raise InputError(f"cannot read image {str(p)!r}: {exc}; export it again") from None
    if arr.size == 0:
        raise InputError(f"image {str(p)!r} has no pixels")
    if opacity is not None:
        arr = arr * opacity if alpha == "black" else arr * opacity + (1.0 - opacity)
    return np.ascontiguousarray(arr[::-1])


#: Peak bytes per pixel and band of :func:`read_gray`: Pillow's decoded image, its float64
#: copy, the luminance, the opacity and the flipped result.
IMAGE_BYTES = 40


def _require_image_memory(p: Path, size: tuple, bands: int) -> None:
    """ResourceError naming the largest image that fits, before a ``size`` (w, h) px
    image of ``bands`` channels is decoded."""
    from ..errors import ResourceError
    from ..util import available_memory

    w, h = size
    need, have = float(IMAGE_BYTES) * max(bands, 1) * w * h, available_memory()
    if need > have:
        k = (have / (1.2 * need)) ** 0.5
        raise ResourceError(
            f"reading image {str(p)!r} ({w} x {h} px, {bands} channel(s)) needs about {need / 2**30:.1f} GiB of memory but "
            f"this machine has {have / 2**30:.1f} GiB available; scale it down to at most {max(int(w * k), 1)} x "
            f"{max(int(h * k), 1)} px (one tile of the texture needs no more)"
        )


def _opacity(im) -> np.ndarray | None:
    """Opacity in [0, 1] (image row order), or None for images without alpha."""
    if im.mode in ("P", "PA"):
        if im.mode == "P" and "transparency" not in im.info:
            return None
        return np.asarray(im.convert("RGBA").getchannel("A"), dtype=np.float64) / 255.0
    if im.mode in ("LA", "La", "RGBA", "RGBa"):
        return np.asarray(im.getchannel("A"), dtype=np.float64) / 255.0
    if im.mode in ("L", "RGB", "I", "I;16") and "transparency" in im.info:
        # A single transparent grey level or colour (PNG tRNS chunk).
        return np.asarray(im.convert("RGBA" if im.mode == "RGB" else "LA").getchannel("A"), dtype=np.float64) / 255.0
    return None


def _to_unit_gray(im) -> np.ndarray:
    """Pillow image -> float64 luminance in [0, 1] (image row order), alpha ignored."""
    mode = im.mode
    if mode == "P" or mode == "PA":
        im = im.convert("RGBA")
        mode = im.mode
    if mode in ("1",):
        return np.asarray(im, dtype=np.float64)
    if mode in ("L", "LA", "La"):
        a = np.asarray(im.getchannel(0), dtype=np.float64)
        return a / 255.0
    if mode in ("I;16", "I;16B", "I;16L", "I;16N"):
        a = np.asarray(im, dtype=np.float64)
        return a / 65535.0
    if mode == "I":  # 32-bit int, Pillow's mode for many 16-bit PNGs
        a = np.asarray(im, dtype=np.float64)
        top = 65535.0 if a.max(initial=0) <= 65535 else float(np.iinfo(np.int32).max)
        return np.clip(a / top, 0.0, 1.0)
    if mode == "F":
        a = np.asarray(im, dtype=np.float64)
        lo, hi = float(np.nanmin(a)), float(np.nanmax(a))
        if not np.isfinite(a).all():
            bad = np.argwhere(~np.isfinite(a))[0]
            raise InputError(f"floating-point image holds {int((~np.isfinite(a)).sum())} NaN or infinite pixels (the first at "
                             f"row {int(bad[0])}, column {int(bad[1])} from the top left); fill them and save it again")
        return np.clip(a, 0.0, 1.0) if (lo >= 0 and hi <= 1) else (a - lo) / max(hi - lo, 1e-300)
    if mode in ("RGB", "RGBA", "RGBa", "RGBX", "CMYK", "YCbCr", "LAB", "HSV"):
        if mode not in ("RGB", "RGBA"):
            im = im.convert("RGB")
        rgb = np.asarray(im, dtype=np.float64)[..., :3] / 255.0
        return rgb @ _LUMA
    if mode.startswith("RGB") or mode.startswith("I;16"):
        a = np.asarray(im, dtype=np.float64)
        if a.ndim == 3:
            a = a[..., :3] @ _LUMA
        return a / 65535.0
    # Anything else: let Pillow convert to 8-bit grey.
    return np.asarray(im.convert("L"), dtype=np.float64) / 255.0


def write_gray16(path: str | os.PathLike, values: np.ndarray) -> None:
    """Write ``values`` in [0, 1] (y-up, ``(rows, cols)``) as a 16-bit grey PNG.

    The file is written to a temporary name in the same folder and renamed, so a
    failure leaves no half-written file.
    """
    from PIL import Image

    from ..util import atomic_path

    v = np.asarray(values, dtype=np.float64)
    if v.ndim != 2:
        raise ParameterError(f"a grey image needs a 2-D array, got shape {v.shape}")
    q = np.round(np.clip(v[::-1], 0.0, 1.0) * 65535.0).astype(np.uint16)
    im = Image.fromarray(q)  # mode I;16
    with atomic_path(path) as tmp:
        im.save(tmp, format="PNG")


def write_rgb8(path: str | os.PathLike, rgb: np.ndarray) -> None:
    """Write a ``(rows, cols, 3)`` float array in [0, 1] (y-up) as an 8-bit RGB PNG."""
    save_image(rgb8_image(rgb), path)


def rgb8_image(rgb: np.ndarray):
    """A ``(rows, cols, 3)`` float array in [0, 1] (y-up) as an 8-bit RGB Pillow
    image (row 0 at the top), for composing pictures such as contact sheets."""
    from PIL import Image

    a = np.asarray(rgb, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ParameterError(f"an RGB image needs shape (rows, cols, 3), got {a.shape}")
    q = np.round(np.clip(a[::-1], 0.0, 1.0) * 255.0).astype(np.uint8)
    return Image.fromarray(q, mode="RGB")


def save_image(im, path: str | os.PathLike) -> None:
    """Save a Pillow image as PNG atomically (temporary file, then rename)."""
    from ..util import atomic_path

    with atomic_path(path) as tmp:
        im.save(tmp, format="PNG")
