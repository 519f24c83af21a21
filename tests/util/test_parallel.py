"""Row-parallel work gives the bytes of one pass, in order, for any thread count."""

from __future__ import annotations

import numpy as np
import pytest

from texcad.util import split_rows, threads


def _rowwise(x: np.ndarray) -> np.ndarray:
    return np.sin(x) * np.sqrt(np.abs(x)) + x**3


@pytest.mark.parametrize("n_threads", ["1", "2", "3", "7"])
@pytest.mark.parametrize("n", [0, 1, 99, 100_001, 250_003])
def test_pieces_cover_the_rows_in_order(monkeypatch, n_threads, n):
    monkeypatch.setenv("TEXCAD_THREADS", n_threads)
    x = np.random.default_rng(n).normal(size=n) * 10
    seen = []

    def fn(r: slice) -> np.ndarray:
        seen.append((r.start, r.stop))
        return _rowwise(x[r])

    got = np.concatenate(split_rows(fn, n, min_rows=1000))
    assert got.tobytes() == _rowwise(x).tobytes()
    spans = sorted(seen)
    assert spans[0][0] == 0 and spans[-1][1] == n
    assert all(a[1] == b[0] for a, b in zip(spans[:-1], spans[1:]))  # no gap, no overlap
    assert len(spans) == max(1, min(int(n_threads), n // 1000))


def test_thread_count_from_the_environment(monkeypatch):
    monkeypatch.setenv("TEXCAD_THREADS", "3")
    assert threads() == 3
    monkeypatch.setenv("TEXCAD_THREADS", "zero")
    assert threads() >= 1
    monkeypatch.delenv("TEXCAD_THREADS")
    assert threads() >= 1


def test_an_error_in_a_piece_reaches_the_caller(monkeypatch):
    monkeypatch.setenv("TEXCAD_THREADS", "2")

    def fn(r: slice):
        if r.start > 0:
            raise ValueError("second piece")
        return r

    with pytest.raises(ValueError, match="second piece"):
        split_rows(fn, 10_000, min_rows=10)


@pytest.mark.parametrize("n_threads", ["1", "2"])
def test_beside_runs_a_job_and_hands_back_its_result_or_error(monkeypatch, n_threads):
    import threading

    from texcad.util import beside

    monkeypatch.setenv("TEXCAD_THREADS", n_threads)
    seen = []

    def job(x):
        seen.append(threading.get_ident())
        if x < 0:
            raise ValueError("negative")
        return 2 * x

    with beside(job, 21) as j:
        pass
    assert j.result() == 42
    assert (seen[0] == threading.get_ident()) == (n_threads == "1")  # a second thread only when allowed
    with beside(job, -1) as j:
        pass
    with pytest.raises(ValueError, match="negative"):
        j.result()
