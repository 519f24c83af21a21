"""Memory guard: refuse jobs that would need more memory than the machine has."""

from __future__ import annotations

import os

from ..errors import ResourceError

__all__ = ["available_memory", "require_memory"]


def available_memory() -> int:
    """Bytes of memory available to this process now (MemAvailable, or total RAM)."""
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


def require_memory(nbytes: float, what: str, fix: str) -> None:
    """Raise :class:`ResourceError` if ``nbytes`` exceeds the available memory.

    Args:
        nbytes: estimated peak bytes the job needs.
        what: what the job is, e.g. ``"a 90000 x 90000 px heightmap"``.
        fix: what the user can change, e.g. ``"use a larger pitch"``.
    """
    have = available_memory()
    if nbytes > have:
        raise ResourceError(
            f"{what} needs about {nbytes / 2**30:.1f} GiB of memory but this machine has "
            f"{have / 2**30:.1f} GiB available; {fix}"
        )
