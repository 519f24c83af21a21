"""texcad.util.runs: consecutive items in runs of bounded weight."""

from texcad.util import runs_within


def test_runs_hold_at_most_their_bound_and_keep_the_order():
    weights = [3, 5, 2, 8, 1, 1, 30, 4]
    runs = runs_within(weights, 10)
    assert [i for r in runs for i in r] == list(range(len(weights)))
    assert runs == [[0, 1, 2], [3, 4, 5], [6], [7]]  # a heavier item than the bound runs alone
    assert all(sum(weights[i] for i in r) <= 10 for r in runs if len(r) > 1)


def test_greedy_runs_are_the_fewest():
    """Each run ends only where the next item would pass the bound, so no cut into
    fewer runs exists (checked against every cut of a short list)."""
    from itertools import combinations

    weights, most = [4, 4, 3, 2, 6, 1, 5], 9
    fewest = min(
        k + 1
        for k in range(len(weights))
        for cuts in combinations(range(1, len(weights)), k)
        if all(sum(weights[a:b]) <= most for a, b in zip((0, *cuts), (*cuts, len(weights))))
    )
    assert len(runs_within(weights, most)) == fewest


def test_no_items_one_empty_run():
    assert runs_within([], 5) == [[]]
