"""Max F1 on straight and turning frames."""

import json

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.evaluate.metrics import evaluate_estimates


def test_split_by_turning():
    nodes = [0, 1, 9, 3, 4, 9]
    scores = [0.9, 0.8, 0.7, 0.6, 0.5, 0.4]
    gt = [[0], [1], [2], [3], [4], [5]]
    turning = np.array([False, False, False, True, True, True])
    m = evaluate_estimates(nodes, scores, gt, turning=turning)
    straight = evaluate_estimates(nodes[:3], scores[:3], gt[:3])
    turn = evaluate_estimates(nodes[3:], scores[3:], gt[3:])
    assert m.f1_max_straight == straight.f1_max
    assert m.f1_max_turning == turn.f1_max
    summary = json.loads(json.dumps(m.summary()))
    assert summary["f1_max_turning"] == pytest.approx(turn.f1_max)


def test_unknown_or_empty_split_is_none():
    m = evaluate_estimates([0, 1], [0.9, 0.8], [[0], [1]])
    assert m.f1_max_straight is None and m.f1_max_turning is None
    m = evaluate_estimates([0, 1], [0.9, 0.8], [[0], [1]], turning=[False, False])
    assert m.f1_max_straight == m.f1_max and m.f1_max_turning is None
    with pytest.raises(PpalocError, match="turning has 1 flags for 2 queries"):
        evaluate_estimates([0, 1], [0.9, 0.8], [[0], [1]], turning=[True])
