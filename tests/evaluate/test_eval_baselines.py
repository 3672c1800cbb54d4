"""``benchmarks/eval_baselines.py``: every method judged by the evaluation's own runner."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ppaloc.datasets import load_dataset, to_sensor
from ppaloc.evaluate.metrics import evaluate_estimates


def test_a_keyframe_node_is_read_as_its_frame(bench_script):
    """A reference that stands 5 frames at place 10 is one node there: the node numbers
    after it are 4 below the frames they predict, and the table judges the frames."""
    eval_baselines = bench_script("eval_baselines")
    route = [to_sensor(f) for f in load_dataset("synthetic:?places=30&seed=3").reference]
    ref = route[:10] + [route[10]] * 5 + route[11:]
    frames = [np.array([p]) if p < 10 else np.arange(10, 15) if p == 10 else np.array([p + 4])
              for p in range(len(route))]  # fmt: skip
    ds = SimpleNamespace(ground_truth=frames)
    result = eval_baselines.run("weighted-node-lowres16", ds, ref, route)
    assert result.n_nodes == len(route)
    assert np.array_equal(result.ref_index, result.frame_index[result.node])
    by_frame = evaluate_estimates(result.ref_index, result.score, frames)
    by_node = evaluate_estimates(result.node, result.score, frames)
    assert result.metrics.f1_max == by_frame.f1_max > 0.9
    assert by_node.f1_max < 0.5  # what the table showed for a keyframe map before


def test_an_offline_method_is_handed_the_query(bench_script):
    eval_baselines = bench_script("eval_baselines")
    ds = load_dataset("synthetic:?places=30&query=autumn&seed=2&tolerance=1")
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]
    result = eval_baselines.run("seqslam-centred", ds, ref, query)
    assert result.reads_future and len(result.node) == len(query)
