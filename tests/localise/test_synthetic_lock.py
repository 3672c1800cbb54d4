"""The weighted-node filter with its default parameters on a short generated route.

Regression test for the choice of alpha: a query under other conditions than the map
(snow against a summer map) scores every node worse than unrelated map places score each
other. An alpha taken at the map's own 0.99 quantile then sits below the true match's
likelihood, every weight sinks below the 0 that enters node 0 on each forward move, and
the estimate sticks to the start of the map (max F1 0.02 with the old rule; 0.52 now).
"""

import numpy as np
import pytest

from ppaloc.datasets import make_synthetic, to_sensor
from ppaloc.evaluate.metrics import is_correct, max_f1, pr_curve
from ppaloc.localise.weighted import WeightedNodeLocaliser


@pytest.fixture(scope="module")
def winter_route():
    """60 places, summer map, winter query, one query frame per place (seeded)."""
    ds = make_synthetic(places=60, ref="summer", query="winter", seed=0, sync=True)
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]
    return ref, query, list(ds.ground_truth)


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
def test_lowres_filter_locks_on_a_summer_to_winter_route(winter_route, arithmetic):
    ref, query, truth = winter_route
    loc = WeightedNodeLocaliser("lowres", motion="always_forward", arithmetic=arithmetic)
    loc.build_map(ref)
    est = loc.localise(query)
    correct = is_correct(np.array([e.node for e in est]), truth)
    has_match = np.array([len(t) > 0 for t in truth])
    f1 = max_f1(pr_curve([e.score for e in est], correct, has_match, recall="A"))[0]
    assert f1 > 0.35
    assert correct[30:].mean() > 0.5  # locked on for the second half of the route
    assert not np.all(np.array([e.node for e in est[30:]]) < 5)  # not stuck at the start
