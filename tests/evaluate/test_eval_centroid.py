"""``benchmarks/eval_centroid.py``: the weights' local centroid as the reported estimate."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st


@settings(max_examples=60, deadline=None)
@given(
    weights=st.lists(st.integers(-127, 127), min_size=1, max_size=12),
    data=st.data(),
    radius=st.integers(0, 3),
    temperature=st.sampled_from([0.5, 1.0, 2.0, 8.0]),
    rounded=st.booleans(),
)
def test_the_centroid_stays_within_radius_and_a_lone_peak_keeps_it(
    bench_script, weights, data, radius, temperature, rounded
):
    eval_centroid = bench_script("eval_centroid")
    w = np.asarray(weights, np.float64) + 0.25
    node = data.draw(st.integers(0, len(w) - 1))
    got = eval_centroid.offline_centroid(w, node, radius, temperature, rounded)
    assert max(0, node - radius) <= got <= min(len(w) - 1, node + radius)
    peak = w.copy()
    peak[node] = 1000.0  # far above its neighbours: nothing to pull the estimate away
    assert eval_centroid.offline_centroid(peak, node, radius, temperature, rounded) == node


def test_a_route_gives_the_estimates_figure_and_every_variant(bench_script):
    eval_centroid = bench_script("eval_centroid")
    spec = "synthetic:?places=30&seed=1&query=winter"
    rec = eval_centroid.evaluate_route("synthetic seed=1", spec, ["weighted-node-lowres"], "ppa8")
    row = rec["results"]["weighted-node-lowres"]
    names = [eval_centroid.variant_name(*v) for v in eval_centroid.VARIANTS]
    assert list(row) == ["estimate", *names]
    assert all(0.0 <= f1 <= 1.0 for f1 in row.values())
    text = eval_centroid.summary([rec], ["weighted-node-lowres"])
    assert "| T2 r2 int |" in text and "| estimate |" in text
