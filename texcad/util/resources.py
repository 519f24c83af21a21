"""Memory guard: refuse jobs that would need more memory than the machine has."""

from __future__ import annotations

import contextlib
import contextvars
import math

import os

from ..errors import ResourceError

__all__ = ["peak_rss", "available_memory", "require_memory", "texture_bytes", "fitting_pitch", "finest_pitch", "require_pitch", "round_up"]

#: Peak bytes per texture pixel of the whole texturing job (slab, manifold3d union,
#: fused mesh, writers), measured on a 100 x 100 mm stones plate at 0.125 mm: 1.10 KB
#: per pixel with one vertex per pixel, 0.37 KB with the lean mesh at 0.02 mm (which
#: keeps at most half the grid's triangles, so 0.8 KB bounds it).
BYTES_PER_PIXEL = {"grid": 1300.0, "lean": 800.0}


def _meminfo_available() -> int:
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - exotic OS
        return 1 << 62


def _address_space_left() -> int:
    """Bytes left under this process's address-space limit (``ulimit -v``), if any:
    beyond it allocations fail (and native code may crash) whatever RAM is free."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft in (resource.RLIM_INFINITY, -1):
            return 1 << 62
        with open("/proc/self/statm", encoding="ascii") as fh:
            used = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        return max(int(soft) - used, 0)
    except (ImportError, OSError, ValueError):  # pragma: no cover - not Linux
        return 1 << 62


def _cgroup_left() -> int:
    """Bytes left under the cgroup (v2) memory limit of a container, if any."""
    try:
        with open("/sys/fs/cgroup/memory.max", encoding="ascii") as fh:
            limit = fh.read().strip()
        if limit == "max":
            return 1 << 62
        with open("/sys/fs/cgroup/memory.current", encoding="ascii") as fh:
            return max(int(limit) - int(fh.read().strip()), 0)
    except (OSError, ValueError):
        return 1 << 62


#: The caller's bound on the job's memory (bytes), set by :func:`memory_limit`.
_BOUND: "contextvars.ContextVar[int | None]" = contextvars.ContextVar("texcad_max_memory", default=None)


def _rss() -> int:
    """Bytes this process holds now (resident set)."""
    try:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def peak_rss() -> int:
    """Bytes this process has held at most (its resident high-water mark, VmHWM).
    Not ``getrusage``'s ``ru_maxrss``: Linux carries that over ``exec`` from the
    parent, so a small child of a large process reads the parent's peak."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            return int(next(l for l in fh if l.startswith("VmHWM:")).split()[1]) * 1024
    except (OSError, ValueError, IndexError, StopIteration):
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


@contextlib.contextmanager
def memory_limit(nbytes: "int | None"):
    """Within the block, :func:`available_memory` leaves ``nbytes`` bytes to the job
    in all (what the process holds counts; whatever the machine has free), so the
    memory guards refuse what would not fit in it and name the pitch that does, and
    the planners size tiles and blocks from it. None: no bound of its own (what the
    machine has)."""
    token = _BOUND.set(None if nbytes is None else int(nbytes))
    try:
        yield
    finally:
        _BOUND.reset(token)


def available_memory() -> int:
    """Bytes of memory this process can still use now. Where the caller set a bound
    (:func:`memory_limit`, ``max_memory=``): what that bound leaves over what the
    process holds, capped only by what its address-space limit (``ulimit -v``)
    leaves: the bound is the user's word, so what other processes happen to leave
    free (the machine's MemAvailable, a container's limit) does not enter, and the
    plans made from it (tiles, blocks, and so the bytes where an overhang crosses
    their borders) go with the bound and the input alone. Without a bound: the least
    of the machine's available memory (MemAvailable), what the address-space limit
    leaves and what the container's memory limit (cgroup v2) leaves."""
    bound = _BOUND.get()
    if bound is not None:
        return max(0, min(_address_space_left(), bound - _rss()))
    return min(_meminfo_available(), _address_space_left(), _cgroup_left())


def texture_bytes(pixels: float, tolerance: float) -> float:
    """Estimated peak bytes of texturing ``pixels`` texture pixels (see
    :data:`BYTES_PER_PIXEL`; ``tolerance`` 0 = one vertex per pixel)."""
    return float(pixels) * BYTES_PER_PIXEL["grid" if tolerance <= 0 else "lean"]


def fitting_pitch(pitch: float, need: float, have: float | None = None) -> float:
    """The pitch in mm at which a job that needs ``need`` bytes at ``pitch`` fits in
    ``have`` bytes (default: :func:`available_memory`), with 20 % to spare: memory
    goes with the pixel count, ``1 / pitch^2``."""
    have = available_memory() if have is None else have
    return float(pitch) * (1.2 * need / max(have, 1.0)) ** 0.5


def round_up(x: float, digits: int = 3) -> float:
    """``x`` rounded up to ``digits`` significant figures (a named pitch must not be finer
    than the one computed)."""
    if not (math.isfinite(x) and x > 0):
        return x
    e = math.floor(math.log10(x)) - digits + 1
    return math.ceil(x / 10.0**e - 1e-9) * 10.0**e


def finest_pitch(pitch: float, scaled: float, fixed: float = 0.0, have: float | None = None) -> float:
    """The finest pitch in mm at which a job fits in ``have`` bytes (default:
    :func:`available_memory`) with 20 % to spare, when at ``pitch`` mm it needs
    ``fixed`` bytes whatever the pitch plus ``scaled`` bytes that go with the pixel
    count, ``1 / pitch^2``; rounded up to 3 significant figures; inf when the fixed
    part alone does not fit."""
    have = available_memory() if have is None else have
    budget = have / 1.2 - fixed
    if budget <= 0:
        return math.inf
    return round_up(float(pitch) * math.sqrt(max(scaled, 0.0) / budget))


def _size(nbytes: float) -> str:
    """``nbytes`` as GiB, or MiB under 1 GiB (so that small figures are not 0.0 GiB)."""
    return f"{nbytes / 2**30:.1f} GiB" if nbytes >= 2**30 else f"{nbytes / 2**20:.0f} MiB"


def _have_text(have: float) -> str:
    """What :func:`available_memory` said, and under a ``max_memory`` bound what the
    process already holds of it."""
    bound = _BOUND.get()
    if bound is None:
        return f"this machine has {_size(have)} available"
    return f"the max_memory bound of {_size(bound)} leaves {_size(have)} (the process holds {_size(_rss())})"


def require_pitch(what: str, pitch: float, scaled: float, fixed: float = 0.0, *, unit: str = "pitch") -> None:
    """Raise :class:`ResourceError` naming the finest ``pitch`` (mm) that fits when a
    job of ``fixed + scaled`` bytes at ``pitch`` mm (``scaled`` going with
    ``1 / pitch^2``, see :func:`finest_pitch`) exceeds the available memory.

    Args:
        what: what the job is, e.g. ``"a 90000 x 90000 px texture on the face"``.
        pitch: the pitch asked for, mm.
        scaled: bytes at ``pitch`` that go with the pixel count.
        fixed: bytes whatever the pitch (the part's own mesh...).
        unit: the name of the option to change (``"pitch"``, ``"--pitch"``).
    """
    have = available_memory()
    need = fixed + scaled
    if need <= have:
        return
    p = finest_pitch(pitch, scaled, fixed, have)
    fix = (f"use a {unit} of at least {p:.3g} mm" if math.isfinite(p) else
           f"the part alone needs about {_size(fixed)}: free memory or allow more (max_memory)")
    raise ResourceError(f"{what} at a {unit} of {pitch:.3g} mm needs about {_size(need)} of memory but {_have_text(have)}; {fix}")


def require_memory(nbytes: float, what: str, fix: str) -> None:
    """Raise :class:`ResourceError` if ``nbytes`` exceeds the available memory.

    Args:
        nbytes: estimated peak bytes the job needs.
        what: what the job is, e.g. ``"a 90000 x 90000 px heightmap"``.
        fix: what the user can change, e.g. ``"use a larger pitch"``.
    """
    have = available_memory()
    if nbytes > have:
        raise ResourceError(f"{what} needs about {_size(nbytes)} of memory but {_have_text(have)}; {fix}")
