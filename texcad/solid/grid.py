"""The triangles of a vertex grid (row-major indices): the one connectivity every
heightfield and mapped slab shares."""

from __future__ import annotations

import numpy as np

__all__ = ["grid_faces"]


def grid_faces(rows: int, cols: int, *, wrap_x: bool = False, flip: bool = False) -> np.ndarray:
    """Triangles of a ``rows x cols`` vertex grid (row-major indices).

    Each cell ``(r, c)`` becomes two triangles, counter-clockwise when the grid is
    seen with x (columns) to the right and y (rows) up. With ``wrap_x`` the last
    column connects back to the first (a closed band).

    Returns:
        ``(2 (rows-1) cols', 3)`` uint32 indices, ``cols' = cols`` if ``wrap_x``
        else ``cols - 1``.
    """
    idx = np.arange(rows * cols, dtype=np.uint32).reshape(rows, cols)
    right = np.roll(idx, -1, axis=1) if wrap_x else idx[:, 1:]
    left = idx if wrap_x else idx[:, :-1]
    a, b = left[:-1], right[:-1]  # bottom-left, bottom-right of each cell
    d, c = left[1:], right[1:]  # top-left, top-right
    tri = np.empty((a.size * 2, 3), dtype=np.uint32)
    tri[0::2, 0], tri[0::2, 1], tri[0::2, 2] = a.ravel(), b.ravel(), c.ravel()
    tri[1::2, 0], tri[1::2, 1], tri[1::2, 2] = a.ravel(), c.ravel(), d.ravel()
    if flip:
        tri[:, [1, 2]] = tri[:, [2, 1]]
    return tri
