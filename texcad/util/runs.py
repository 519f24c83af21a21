"""Consecutive items grouped into runs of bounded weight (a B-rep's tile edges or
wall strips joined into one face up to a number of cells)."""

from __future__ import annotations

from typing import Sequence

__all__ = ["runs_within"]


def runs_within(weights: Sequence[int], most: int) -> list[list[int]]:
    """The indices ``0 .. len(weights) - 1`` in order, cut into runs: each item joins
    the current run unless that would take the run's summed weight past ``most``
    (a run holds at least one item, however heavy). The greedy cut gives the fewest
    runs for that bound. No items: one empty run."""
    out, run, total = [], [], 0
    for i, n in enumerate(weights):  # per item, in order
        if run and total + n > most:
            out.append(run)
            run, total = [], 0
        run.append(i)
        total += n
    out.append(run)
    return out
