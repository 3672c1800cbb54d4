"""The confidence reported: the margin times the weights' concentration about the node."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ppaloc.localise.params import centroid_window, concentration, weight_read
from ppaloc.localise.weighted import WeightedNodeLocaliser

weights = st.lists(st.integers(-127, 127), min_size=3, max_size=17)


@given(w=weights, t=st.integers(1, 64), data=st.data())
def test_a_share_in_0_1_that_the_node_raises_and_a_far_hill_lowers(w, t, data):
    """In (0, 1], 1 where the window is the node and its neighbours; raising a weight
    within one node of ``node`` never lowers it, raising one farther never raises it."""
    node = data.draw(st.integers(0, len(w) - 1))
    share = concentration(w, 0, node, t)
    assert 0 < share <= 1
    assert concentration(w[max(node - 1, 0) : node + 2], max(node - 1, 0), node, t) == 1.0
    for i in range(len(w)):
        raised = [v + 20 * (j == i) for j, v in enumerate(w)]
        after = concentration(raised, 0, node, t)
        if abs(i - node) <= 1:
            assert after >= share - 1e-12
        else:
            assert after <= share + 1e-12


def test_golden():
    """A lone peak holds it all; two equal hills two nodes apart halve it; a broad hill
    (neighbours at one frame's evidence, ``gain`` 4 units, below the best) keeps most;
    the window cut short by the map's start counts what is left of it."""
    assert concentration([0, 0, 40, 0, 0], 0, 2, 4) == pytest.approx(1.0, abs=1e-3)
    assert concentration([40, 0, 40, 0, 0], 0, 2, 4) == pytest.approx(0.5, abs=1e-4)
    e = math.exp(-1.0)  # 4 units below the best at T = 4
    assert concentration([0, 36, 40, 36, 0], 0, 2, 4) == pytest.approx(1.0, abs=1e-4)
    near, far = 1 + 2 * e, 2 * math.exp(-2.5)
    assert concentration([30, 36, 40, 36, 30], 10, 12, 4) == pytest.approx(near / (near + far))
    assert concentration([40, 40, 0, 40], 0, 0, 4) == pytest.approx(2 / 3, abs=1e-4)
    assert centroid_window(2, 4, 20) == (0, 6)


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
def test_only_the_reported_confidence_moves(route, arithmetic):
    """With the concentration the nodes and the weights are those of the filter without
    it (the path and the lanes read the margin), and each reported confidence is the
    margin times the share read from the frame's weights about the detected node: the
    weights recorded after the normalisation, which subtracts an integer in ppa8 (and
    the exact best in float), so the reads' share is the filter's own. Some frames
    report less than their margin, none more."""
    query = np.concatenate([route[:8], route[8:16:2], route[16:]])
    kw = dict(arithmetic=arithmetic, motion="always_forward", record_weights=True)
    kw |= dict(lane_speed=0, slow_lane=False, centroid_radius=0)
    runs = {}
    for radius in (0, 4):
        loc = WeightedNodeLocaliser("lowres", concentration_radius=radius, **kw)
        loc.build_map(route)
        runs[radius] = loc.localise(query)
    lowered = 0
    for a, b in zip(runs[0], runs[4], strict=True):
        assert a.node == b.node
        np.testing.assert_array_equal(a.weights, b.weights)
        lo, hi = centroid_window(a.node, 4, len(a.weights))
        values = [float(v) for v in a.weights[lo : hi + 1]]
        reads = [weight_read(v) for v in values] if arithmetic == "ppa8" else values
        assert b.score == pytest.approx(a.score * concentration(reads, lo, a.node, 4), rel=1e-9)
        assert b.score <= a.score
        lowered += b.score < a.score
    assert lowered > 0


def test_a_radius_of_one_is_off(route):
    """``concentration_radius`` 1: the window is the node and its neighbours, a share of
    1 (the margin reported), as with 0."""
    runs = []
    for radius in (0, 1):
        loc = WeightedNodeLocaliser("lowres", motion="always_forward", concentration_radius=radius)
        loc.build_map(route)
        runs.append([e.score for e in loc.localise(route[::-1])])
    assert runs[0] == runs[1]
