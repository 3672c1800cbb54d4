"""Cost of the metrics against the number of queries (``make bench``).

The PR curve sorts the scores once and reads every distinct threshold off cumulative
sums, so one evaluation is O(M log M) plus an O(M) pass over the ground-truth sets.
Target: a Nordland-sized run (M = 30,000 queries with unique scores) evaluates in < 1 s.
"""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.evaluate.metrics import evaluate_estimates, pr_curve


def _run(m: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    rng = np.random.default_rng(seed)
    truth = np.arange(m)
    nodes = np.where(rng.random(m) < 0.7, truth, rng.integers(0, m, m))
    scores = rng.random(m)
    gt = [np.arange(max(0, t - 2), min(m, t + 3)) for t in truth]
    return nodes, scores, gt


@pytest.mark.parametrize("m", [1_000, 30_000])
def test_evaluate_estimates(benchmark, m: int) -> None:
    nodes, scores, gt = _run(m)
    result = benchmark(evaluate_estimates, nodes, scores, gt)
    assert 0.6 < result.precision_at_100r < 0.8
    assert benchmark.stats.stats.median < 1.0


@pytest.mark.parametrize("m", [100_000, 1_000_000])
def test_pr_curve_sweep(benchmark, m: int) -> None:
    rng = np.random.default_rng(1)
    scores, correct = rng.random(m), rng.random(m) < 0.5
    curve = benchmark(pr_curve, scores, correct, np.ones(m, bool))
    assert len(curve.thresholds) == len(np.unique(scores))
