"""``enhance`` and ``local_gain``: local contrast of the distances in the host's filter
(``enhance`` in float only; ``local_gain`` in ppa8 too, whose sensor stage
tests/onsensor/test_local.py checks)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.baselines import seqslam
from ppaloc.errors import PpalocError
from ppaloc.localise import enhance
from ppaloc.localise.enhance import (
    ENHANCE_UNITS,
    closer_count,
    closer_share,
    contrast_enhance,
    place_neighbours,
)
from ppaloc.localise.host import read_values
from ppaloc.localise.params import FilterParams, frame_scale
from ppaloc.localise.weighted import WeightedNodeLocaliser

from .conftest import blocky


@pytest.fixture
def hubbed() -> np.ndarray:
    """30 random 8x8 places, each drawn to the grey level of its neighbours' mean in half
    its cells: neighbouring places share structure, as on a densely sampled route."""
    rng = np.random.default_rng(11)
    base = rng.integers(0, 256, (30, 8, 8)).astype(float)
    smooth = (base + np.roll(base, 1, 0) + np.roll(base, -1, 0)) / 3
    return np.stack([blocky(np.clip(s, 0, 255).astype(np.uint8)) for s in smooth])


def test_seqslam_and_the_filter_share_one_function() -> None:
    assert seqslam.contrast_enhance is enhance.contrast_enhance


@pytest.mark.parametrize("kind", ["lowres", "lowres16", "lbp"])
@pytest.mark.parametrize("window", [4, 10])
def test_the_values_read_are_the_z_scores_of_the_plain_ones(hubbed, kind, window) -> None:
    plain = WeightedNodeLocaliser(kind, keyframes=False)
    enhanced = WeightedNodeLocaliser(kind, keyframes=False, enhance=window)
    for loc in (plain, enhanced):
        loc.build_map(hubbed)
        loc.executor.begin(hubbed[7])
    # the plain distances in register units, unrounded (the readout rounds them)
    mu = read_values(kind, plain.executor._raw_distances(), exact=False)
    expected = ENHANCE_UNITS * contrast_enhance(mu, window)
    np.testing.assert_allclose(enhanced.executor.node_values(), expected, rtol=1e-9)


def test_the_first_frame_weighs_every_node_by_its_enhanced_value(hubbed) -> None:
    loc = WeightedNodeLocaliser("lowres", keyframes=False, enhance=10, local_gain=0)
    loc.build_map(hubbed)
    loc.executor.begin(hubbed[12])
    mu = loc.executor.node_values()
    shift, _ = frame_scale(mu, float(mu.min()), loc.params.gain, exact=False)
    loc.reset()
    loc.step(hubbed[12])
    expected = np.maximum(-(mu - mu.min()) * 2.0**-shift, -loc.params.memory)
    np.testing.assert_allclose(loc.executor.weights(), expected, atol=1e-4)


def test_off_by_default_and_the_same_filter_at_zero(hubbed) -> None:
    assert FilterParams.create("lowres").enhance == 0
    a = WeightedNodeLocaliser("lowres16", keyframes=False)
    b = WeightedNodeLocaliser("lowres16", keyframes=False, enhance=0)
    for loc in (a, b):
        loc.build_map(hubbed)
    for frame in hubbed[::-1]:
        ea, eb = a.step(frame), b.step(frame)
        assert (ea.node, ea.score) == (eb.node, eb.score)


def test_the_estimates_follow_the_enhanced_likelihood(hubbed) -> None:
    a = WeightedNodeLocaliser("lowres", keyframes=False, motion="always_forward")
    b = WeightedNodeLocaliser("lowres", keyframes=False, motion="always_forward", enhance=4)
    scores = []
    for loc in (a, b):
        loc.build_map(hubbed)
        scores.append([loc.step(f).score for f in hubbed])
    assert scores[0] != scores[1]


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (
            lambda: FilterParams.create("lowres", arithmetic="ppa8", enhance=10),
            "float arithmetic only",
        ),
        (
            lambda: WeightedNodeLocaliser("lbp", arithmetic="ppa8", enhance=10),
            "float arithmetic only",
        ),
        (lambda: FilterParams.create("lbp", preset="paper", enhance=10), "preset 'robust'"),
        (lambda: FilterParams.create("lbp", enhance=1), "at least 2"),
        (lambda: FilterParams.create("lbp", enhance=-3), "enhance=-3"),
        (
            lambda: FilterParams.create("lowres", arithmetic="ppa8", local_window=2),
            r"^local_gain=2 with local_window=2: in ppa8 arithmetic .* a multiple of 4",
        ),
        (lambda: FilterParams.create("lbp", preset="paper", local_gain=2), "preset 'robust'"),
        (lambda: FilterParams.create("lbp", local_gain=33), "local_gain=33"),
        (lambda: FilterParams.create("lbp", local_window=0), "local_window=0"),
    ],
)
def test_refusals_name_the_cause(make, message) -> None:
    with pytest.raises(PpalocError, match=message):
        make()


@pytest.mark.parametrize(
    ("kind", "option", "message"),
    [
        ("lowres", {"enhance": 10}, "float arithmetic only"),
        ("lbp", {"local_gain": 3, "local_window": 1}, "a multiple of 2"),
    ],
)
def test_the_sensor_refuses_what_it_cannot_run(kind, option, message) -> None:
    from ppaloc.onsensor import OnSensorLocaliser

    with pytest.raises(PpalocError, match=message):
        OnSensorLocaliser(kind, **option)


# -- local_gain: the share of closer neighbours ----------------------------------------


def test_closer_share_golden() -> None:
    d = np.array([4.0, 1.0, 3.0, 3.0, 0.0, 9.0])
    # window 2: node 0 (4.0) has 1.0 and 3.0 closer (two places past the start never are);
    # node 2 (3.0) has 1.0 and 0.0 among 4.0, 1.0, 3.0, 0.0 (a tie is not closer)
    np.testing.assert_allclose(closer_share(d, 2), [0.5, 0.0, 0.5, 0.5, 0.0, 0.5])


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.integers(0, 50), min_size=1, max_size=40),
    st.integers(1, 6),
)
def test_closer_share_is_a_share_and_the_best_pays_nothing(values, window) -> None:
    d = np.array(values, dtype=float)
    share = closer_share(d, window)
    assert ((share >= 0) & (share <= 1)).all()
    assert share[int(np.argmin(d))] == 0.0  # nothing is strictly closer than the minimum
    # the exact count, written out
    for i in range(len(d)):
        near = [d[j] for j in range(i - window, i + window + 1) if j != i and 0 <= j < len(d)]
        assert share[i] == sum(x < d[i] for x in near) / (2 * window)


@pytest.mark.parametrize(
    ("kind", "arithmetic", "gain"),
    [("lowres", "float", 3), ("lbp", "float", 3), ("lowres", "ppa8", 4)],
)
def test_the_local_term_is_added_to_the_first_frames_weights(hubbed, kind, arithmetic, gain):
    kw = {"keyframes": False, "arithmetic": arithmetic}
    plain = WeightedNodeLocaliser(kind, **kw, local_gain=0)
    local = WeightedNodeLocaliser(kind, **kw, local_gain=gain, local_window=2)
    for loc in (plain, local):
        loc.build_map(hubbed)
        loc.step(hubbed[9])
    raw = local.executor._raw_distances()
    expected = plain.executor.weights() - gain * closer_share(raw, 2)
    top = np.floor(expected.max()) if arithmetic == "ppa8" else expected.max()  # T in ppa8
    expected = np.maximum(expected - top, -local.params.memory)
    np.testing.assert_allclose(local.executor.weights(), expected, atol=1e-4)
    assert not np.allclose(local.executor.weights(), plain.executor.weights())


def test_the_ppa8_term_is_whole_steps() -> None:
    """In ppa8 a node loses ``gain / (2 window)`` whole units per closer neighbour, as the
    sensor subtracts them: ``22 * (15 / 22)`` is ``14.999999999999998`` in float64."""
    from ppaloc.localise.host import HostExecutor
    from ppaloc.topomap import TopoMap

    params = FilterParams.create("lowres", arithmetic="ppa8", local_gain=22, local_window=11)
    ex = HostExecutor("lowres", params, arithmetic="ppa8")
    ex.use_map(TopoMap("lowres", np.zeros((23, 8, 8), np.uint8)))
    column = np.arange(23, dtype=np.float64)
    column[11] = 15.5  # 15 of its 22 neighbours are closer
    ex.begin(np.zeros((256, 256), np.uint8))
    ex._raw = column
    ex.add_local(22, 11)
    assert ex.weights()[11] == -15.0
    np.testing.assert_array_equal(ex.weights(), -closer_count(column, 11))


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.booleans(), min_size=1, max_size=40),
    st.integers(1, 4),
    st.integers(0, 2**32 - 1),
)
def test_place_neighbours_are_the_nodes_next_to_a_run(same, window, seed):
    """Each node's neighbour ``k`` places back is the last node of the place ``k``
    before its own (forward: the first of the place ``k`` after), -1 past the map; on a
    map of one node a place they are the nodes ``i -+ k``, and ``closer_count`` is the
    nodes' count."""
    same[0] = False
    places = np.cumsum(~np.asarray(same)) - 1
    n = len(places)
    near = place_neighbours(places, window)
    for i in range(n):
        for k in range(1, window + 1):
            before = np.flatnonzero(places == places[i] - k)
            after = np.flatnonzero(places == places[i] + k)
            assert near[0, k - 1, i] == (before[-1] if len(before) else -1)
            assert near[1, k - 1, i] == (after[0] if len(after) else -1)
    nodes = np.arange(n)
    plain = place_neighbours(nodes, window)
    for k in range(1, window + 1):
        np.testing.assert_array_equal(plain[0, k - 1], np.where(nodes - k >= 0, nodes - k, -1))
        np.testing.assert_array_equal(plain[1, k - 1], np.where(nodes + k < n, nodes + k, -1))
    d = np.random.default_rng(seed).integers(0, 5, n).astype(float)
    np.testing.assert_array_equal(closer_count(d, window, nodes), closer_count(d, window))


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
def test_the_host_compares_a_run_with_the_nodes_next_to_it(arithmetic) -> None:
    """On a map with runs (``TopoMap.places``) the host's term counts the nodes next to
    a run: the nodes of a run that grow closer along it are not penalised by one
    another."""
    from ppaloc.localise.host import HostExecutor
    from ppaloc.topomap import TopoMap

    d = np.array([3.0, 2.0, 1.0, 0.5, 5.0])
    places = np.array([0, 1, 1, 1, 2])
    assert closer_count(d, 1).tolist() == [1, 1, 1, 0, 1]
    assert closer_count(d, 1, places).tolist() == [1, 0, 0, 0, 1]
    params = FilterParams.create("lowres", arithmetic=arithmetic, local_gain=4, local_window=1)
    ex = HostExecutor("lowres", params, arithmetic=arithmetic)
    ex.use_map(TopoMap("lowres", np.zeros((5, 8, 8), np.uint8), places=places))
    ex.begin(np.zeros((256, 256), np.uint8))
    ex._raw = d
    ex.add_local(4, 1)
    assert ex.weights().tolist() == [-2.0, 0.0, 0.0, 0.0, -2.0]


def test_place_neighbours_refuse_places_that_skip_or_fall() -> None:
    with pytest.raises(ValueError, match="rise by 0 or 1"):
        place_neighbours(np.array([0, 2, 3]), 1)
    with pytest.raises(ValueError, match="rise by 0 or 1"):
        place_neighbours(np.array([0, 1, 0]), 1)
