"""``benchmarks/eval_query_stops.py``: the ground truth closed over the query's stops."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.datasets.groundtruth import PackedSets


@pytest.fixture(scope="module")
def query_stops(bench_script):
    return bench_script("eval_query_stops")


def test_a_query_stop_accepts_what_any_of_its_frames_accepts(query_stops):
    truth = PackedSets.from_sets([[0, 1], [1, 2], [2, 3], [5], [4, 5, 6], [6, 7]])
    closed = query_stops.close_over_query_groups(truth, np.array([[1, 3], [3, 5]]))
    got = [np.asarray(closed[i]).tolist() for i in range(len(closed))]
    assert got == [[0, 1], [1, 2, 3], [1, 2, 3], [4, 5, 6], [4, 5, 6], [6, 7]]
