"""The estimate reported: the weights' local centroid about the detected node."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ppaloc.localise.params import centroid_window, local_centroid, weight_read
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.topomap import TopoMap

weights = st.lists(st.integers(-127, 127), min_size=1, max_size=17)


@given(w=weights, first=st.integers(0, 1000), t=st.integers(1, 64))
def test_the_centroid_stays_in_its_window_and_a_lone_peak_keeps_it(w, first, t):
    """Within the window always; where one weight is 200 units above every other, its
    node (at ``t`` up to 4: ``exp(-200 / 64)`` still pulls a little)."""
    assert first <= local_centroid(w, first, t) < first + len(w)
    best = int(np.argmax(w))
    lifted = [v - 200 if i != best else v for i, v in enumerate(w)]
    assert local_centroid(lifted, first, min(t, 4)) == first + best


@given(w=weights, t=st.integers(1, 64), lift=st.integers(1, 100))
def test_raising_a_weight_never_moves_the_centroid_away_from_it(w, t, lift):
    before = local_centroid(w, 0, t)
    for i in range(len(w)):
        raised = [v + lift * (j == i) for j, v in enumerate(w)]
        after = local_centroid(raised, 0, t)
        assert (after - before) * (i - before) >= 0 or after == before


def test_golden():
    """Equal neighbours pull it to their middle; flat weights give the window's middle,
    halves up; a neighbour a frame of evidence (4 units) below barely counts."""
    assert local_centroid([0, 10, 30, 29, 29], 5, 2) == 8
    assert local_centroid([3, 3], 0, 2) == 1  # 0.5 rounds up
    assert local_centroid([0, 4, 0], 0, 2) == 1
    assert local_centroid([0, 0, 4, 0, 0], 0, 2) == 2
    assert local_centroid([4, 0, 0], 0, 2) == 0  # the window cut short by the map's start
    e, f = math.exp(-0.5), math.exp(-1.0)  # 1 and 2 units below the best, at T = 2
    centre = (f + 2 + 7 * e) / (2 * f + 1 + 2 * e)  # 2.24
    assert local_centroid([0, 0, 2, 1, 1], 0, 2) == math.floor(centre + 0.5) == 2
    assert local_centroid([0, 0, 2, 2, 2], 0, 2) == 3  # (f + 9) / (2 f + 3) = 2.51
    assert centroid_window(1, 2, 10) == (0, 3) and centroid_window(8, 2, 10) == (6, 9)
    assert [weight_read(v) for v in (-2.5, -0.5, 0.49, 0.5, 126.5)] == [-2, 0, 0, 1, 127]


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
def test_only_the_reported_node_moves(route, arithmetic):
    """A query that stands between the map's places every other frame (a blend of the
    two): with the centroid the confidences and the weights are those of the filter
    without it (the filter goes on from the detected node), each reported node within
    the radius of the detected one, and some frames report another node."""
    ref = route[:10]
    between = ((ref[:-1].astype(np.uint16) + ref[1:]) // 2).astype(np.uint8)
    query = np.stack([f for pair in zip(ref[:-1], between, strict=True) for f in pair])
    kw = dict(arithmetic=arithmetic, motion="always_forward", confidence_radius=2)
    kw |= dict(record_weights=True, lane_speed=0, slow_lane=False, local_gain=0)
    runs = {}
    for radius in (0, 2):
        loc = WeightedNodeLocaliser("lowres", centroid_radius=radius, **kw)
        loc.build_map(ref)
        runs[radius] = loc.localise(query)
    detected, centroid = runs[0], runs[2]
    assert [e.score for e in centroid] == [e.score for e in detected]
    for a, b in zip(detected, centroid, strict=True):
        np.testing.assert_array_equal(a.weights, b.weights)
        assert abs(a.node - b.node) <= 2
    assert any(a.node != b.node for a, b in zip(detected, centroid, strict=True))
    assert all(e.ranking[0] == e.node for e in centroid)  # the reported node ranks first


def test_a_map_of_one_node_reports_it():
    loc = WeightedNodeLocaliser("lbp", motion="always_forward")
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 256, (3, 256, 256), dtype=np.uint8)
    loc.use_map(TopoMap("lbp", loc.build_map(frames[:1]).descriptors))
    assert [e.node for e in loc.localise(frames)] == [0, 0, 0]
