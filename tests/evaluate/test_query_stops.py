"""``benchmarks/eval_query_stops.py``: the surest wrong estimates it lists."""

from __future__ import annotations

import numpy as np


def test_the_surest_wrong_estimates_come_first(bench_script):
    query_stops = bench_script("eval_query_stops")
    truth = [
        np.array([0, 1]),
        np.array([2]),
        np.array([], np.int64),
        np.array([5, 6]),
        np.array([7]),
    ]
    predicted = np.array([1, 9, 4, 3, 8])
    score = np.array([50.0, 10.0, 30.0, 30.0, 40.0])
    got = query_stops.surest_wrong(predicted, score, truth, 3)
    # query 0 is right; of the wrong ones 4 (40) first, then 2 and 3 (30, query order)
    assert [(q, ref, sc) for q, ref, _, sc in got] == [(4, 8, 40.0), (2, 4, 30.0), (3, 3, 30.0)]
    assert got[0][2].tolist() == [7] and got[1][2].size == 0  # no true match: always wrong
    assert query_stops.surest_wrong(predicted, score, truth, 0) == []
