import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.errors import PpalocError
from ppaloc.localise import Localiser
from ppaloc.localise.weighted import WeightedNodeLocaliser, choose_candidate, suggest_alpha
from ppaloc.place import block_sums
from ppaloc.topomap import TopoMap

from .conftest import blocky


def naive_ppa8(nodes, frames, moves, alpha, shift, gamma, k):
    """docs/ppa8.md written out literally for low-res maps: weights after every frame."""
    w = np.zeros(len(nodes))
    q = np.asarray(nodes, float).reshape(len(nodes), 64)
    out, prev = [], None
    for n, (frame, moved) in enumerate(zip(frames, moves, strict=True), start=1):
        if moved:
            w = np.concatenate(([0.0], w[:-1]))
        f = block_sums(frame).reshape(64) / 2048 - 64
        mu = np.minimum(np.abs(f - (q / 2 - 64)), 127).mean(axis=1)
        t = np.clip(alpha - mu * 2.0**-shift, -128, 127)
        w = np.clip(w + t, -127, 127)
        top = math.floor(w.max())
        cands = np.flatnonzero(w >= top)
        node = cands[0] if prev is None else cands[np.argmin(np.abs(cands - prev))]
        prev = node
        if n % k == 0:
            w = np.clip(w - math.floor(gamma * top), -127, 127)
        out.append((int(node), w.copy()))
    return out


def lowres_map(route):
    return TopoMap("lowres", np.stack([block_sums(f) >> 10 for f in route]).astype(np.uint8))


def test_is_a_localiser():
    assert isinstance(WeightedNodeLocaliser("lbp"), Localiser)


@pytest.mark.parametrize("arithmetic", ["float", "ppa8"])
@pytest.mark.parametrize("representation", ["lowres", "lowres16", "lbp"])
def test_perfect_match_locks_on(route, representation, arithmetic):
    loc = WeightedNodeLocaliser(representation, motion="always_forward", arithmetic=arithmetic)
    loc.build_map(route)
    assert [e.node for e in loc.localise(route[5:15])] == list(range(5, 15))


def test_ppa8_saturates_like_the_register():
    grey = np.full((8, 8), 200)
    nodes = [grey, grey - 20, np.zeros((8, 8))]  # mu = 0, 10, 100 register units
    nodes = np.stack(nodes).astype(np.uint8)
    loc = WeightedNodeLocaliser(
        "lowres",
        preset="paper",
        arithmetic="ppa8",
        alpha=100,
        shift=0,
        gamma=0.5,
        k=2,
        motion="oracle",
        oracle_moves=[False] * 4,
        record_weights=True,
        ranking_k=0,
    )
    loc.use_map(TopoMap("lowres", nodes))
    got = [loc.step(blocky(grey)).weights.tolist() for _ in range(4)]
    # t = [100, 90, 0]; frame 2: [127, 127, 0] after the clip, T = 127, g = floor(63.5) = 63
    assert got == [[100, 90, 0], [64, 64, -63], [127, 127, -63], [64, 64, -126]]


def test_ppa8_negative_saturation_is_minus_127():
    nodes = np.stack([np.full((8, 8), 255), np.zeros((8, 8))]).astype(np.uint8)
    loc = WeightedNodeLocaliser(
        "lowres",
        preset="paper",
        arithmetic="ppa8",
        alpha=0,
        shift=0,
        gamma=0.0,
        motion="oracle",
        oracle_moves=[False] * 3,
        record_weights=True,
    )
    loc.use_map(TopoMap("lowres", nodes))
    # live all 0 vs node 0 all 255: mu = min(127.5, 127) = 127; t = -127; then clip -127
    got = [loc.step(np.zeros((256, 256), np.uint8)).weights.tolist() for _ in range(3)]
    assert got == [[-127, 0], [-127, 0], [-127, 0]]


def test_ppa8_adjustment_after_every_weight_hit_the_floor():
    # alpha 0 against a map 127 register units away: every weight is pushed below -127
    # and clipped there, so max(W) is -127 (not the unclipped sum), T = -127 and
    # g = floor(-127 / 8) = -16 lifts every weight to -111 on the adjustment frame.
    nodes = np.full((3, 8, 8), 255, np.uint8)
    loc = WeightedNodeLocaliser(
        "lowres",
        preset="paper",
        arithmetic="ppa8",
        alpha=0,
        shift=0,
        gamma=0.125,
        k=2,
        motion="oracle",
        oracle_moves=[False] * 2,
        record_weights=True,
    )
    loc.use_map(TopoMap("lowres", nodes))
    got = [loc.step(np.zeros((256, 256), np.uint8)).weights.tolist() for _ in range(2)]
    assert got == [[-127, -127, -127], [-111, -111, -111]]


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(2, 12),
    alpha=st.integers(-1, 127),
    shift=st.integers(0, 3),
    gamma=st.sampled_from([0.0, 0.125, 0.5, 1.0]),
    k=st.integers(1, 3),
)
def test_ppa8_equals_the_contract_written_out(seed, n, alpha, shift, gamma, k):
    rng = np.random.default_rng(seed)
    nodes = rng.integers(0, 256, (n, 8, 8), dtype=np.uint8)
    frames = rng.integers(0, 256, (6, 256, 256), dtype=np.uint8)
    moves = rng.random(6) < 0.6
    loc = WeightedNodeLocaliser(
        "lowres",
        preset="paper",
        arithmetic="ppa8",
        alpha=alpha,
        shift=shift,
        gamma=gamma,
        k=k,
        motion="oracle",
        oracle_moves=moves,
        record_weights=True,
    )
    loc.use_map(TopoMap("lowres", nodes))
    for est, (node, w) in zip(
        loc.localise(frames), naive_ppa8(nodes, frames, moves, alpha, shift, gamma, k), strict=True
    ):
        assert est.node == node
        np.testing.assert_array_equal(est.weights, w)
        assert np.all(np.abs(est.weights) <= 127)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31), alpha=st.integers(0, 127), gamma=st.sampled_from([0.5, 1.0]))
def test_adjustment_keeps_float_weights_in_range(seed, alpha, gamma):
    rng = np.random.default_rng(seed)
    frames = rng.integers(0, 256, (12, 256, 256), dtype=np.uint8)
    loc = WeightedNodeLocaliser(
        "lbp",
        preset="paper",
        alpha=alpha,
        gamma=gamma,
        k=2,
        motion="always_forward",
        record_weights=True,
    )
    loc.build_map(frames[:6])
    for est in loc.localise(frames[6:]):
        assert np.all(est.weights >= -127) and np.all(est.weights <= 127)


def test_adjustment_lowers_the_best_weight():
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 256, (8, 256, 256), dtype=np.uint8)
    common = dict(
        preset="paper", alpha=20, motion="always_forward", record_weights=True, arithmetic="ppa8"
    )
    free = WeightedNodeLocaliser("lbp", gamma=0.0, **common)
    held = WeightedNodeLocaliser("lbp", gamma=1.0, k=1, **common)
    free.build_map(frames)
    held.build_map(frames)
    top_free = [e.weights.max() for e in free.localise(frames)]
    top_held = [e.weights.max() for e in held.localise(frames)]
    assert max(top_free) == 127  # saturates without the adjustment
    assert max(top_held) < 1  # gamma = 1 every frame: the best weight is taken to < 1


def test_tie_break_golden():
    assert choose_candidate(np.array([2, 7, 12]), None) == 2
    assert choose_candidate(np.array([2, 7, 12]), 9) == 7
    assert choose_candidate(np.array([2, 7, 12]), 10) == 12
    assert choose_candidate(np.array([4, 8]), 6) == 4


def test_tie_follows_the_previous_estimate(route):
    # Nodes 3 and 9 show the same place. The query sees node 8's place, then node 9's
    # twice. After frame 3 nodes 3 and 9 tie exactly (50 - mu, +50, +50) above node 8
    # (50, + 50 - mu, + 50 - mu): the tie goes to 9, nearest to the previous estimate 8.
    frames = route.copy()
    frames[3] = frames[9]
    loc = WeightedNodeLocaliser(
        "lowres",
        preset="paper",
        arithmetic="ppa8",
        alpha=50,
        shift=0,
        gamma=0.0,
        motion="oracle",
        oracle_moves=[False] * 3,
        ranking_k=0,
        record_weights=True,
    )
    loc.build_map(frames)
    nodes = [loc.step(f).node for f in (frames[8], frames[9])]
    last = loc.step(frames[9])
    assert last.weights[3] == last.weights[9] == last.weights.max()
    assert [*nodes, last.node] == [8, 8, 9]
    loc.reset()
    assert loc.step(frames[9]).node == 3  # first frame: the smallest candidate


def test_ppa8_and_float_agree_on_an_easy_sequence(route):
    rng = np.random.default_rng(5)
    noisy = np.clip(route + rng.normal(0, 3, route.shape).round(), 0, 255).astype(np.uint8)
    results = []
    for arithmetic in ("float", "ppa8"):
        loc = WeightedNodeLocaliser("lowres", motion="always_forward", arithmetic=arithmetic)
        loc.build_map(route)
        results.append([e.node for e in loc.localise(noisy)])
    assert results[0] == results[1] == list(range(20))


def test_stepping_equals_batch_and_is_past_only(route):
    loc = WeightedNodeLocaliser("lbp", record_weights=True)
    loc.build_map(route)
    batch = loc.localise(route[::-1])
    loc.reset()
    single = [loc.step(f) for f in route[::-1]]
    prefix = loc.localise(route[::-1][:7])
    for a, b in zip(batch, single, strict=True):
        assert (a.node, a.score, a.moved) == (b.node, b.score, b.moved)
        np.testing.assert_array_equal(a.weights, b.weights)
    assert [e.node for e in prefix] == [e.node for e in batch[:7]]


def test_confidence_and_ranking_golden():
    grey = np.full((8, 8), 200)
    nodes = np.stack([grey, grey - 20, np.zeros((8, 8)), grey - 40]).astype(np.uint8)
    common = dict(preset="paper", arithmetic="ppa8", alpha=100, shift=0, motion="always_forward")
    loc = WeightedNodeLocaliser("lowres", confidence_radius=0, ranking_k=3, **common)
    loc.use_map(TopoMap("lowres", nodes))
    est = loc.step(blocky(grey))  # weights [100, 90, 0, 80]
    assert est.node == 0 and est.score == 10.0
    np.testing.assert_array_equal(est.ranking, [0, 1, 3])
    loc = WeightedNodeLocaliser("lowres", confidence_radius=1, **common)
    loc.use_map(TopoMap("lowres", nodes))
    assert loc.step(blocky(grey)).score == 20.0  # outside nodes 0..1: max(0, 80)
    loc = WeightedNodeLocaliser("lowres", confidence_radius=5, **common)
    loc.use_map(TopoMap("lowres", nodes))
    assert loc.step(blocky(grey)).score == 0.0  # the window covers the map


def test_suggest_alpha_is_an_integer_and_used(route):
    loc = WeightedNodeLocaliser("lowres", preset="paper", arithmetic="ppa8")
    m = loc.build_map(route)
    assert isinstance(suggest_alpha(m), int)
    assert loc.alpha == suggest_alpha(m, shift=loc.shift)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"representation": "rgb"}, r"representation='rgb' is not one of lowres, lowres16, lbp"),
        ({"preset": "paper", "arithmetic": "ppa8", "alpha": 2.5}, r"alpha=2.5 must be an integer"),
        (
            {"preset": "paper", "gamma": 0.3},
            r"gamma=0.3 must be one of .* \(a PPA scales only by halving\)",
        ),
        ({"motion": "oracle"}, r"motion='oracle' needs oracle_moves="),
        ({"motion": "walk"}, r"motion='walk' is not one of image, always_forward, oracle"),
        ({"preset": "paper", "k": 0}, r"k=0 must be in \[1, 1000000\]"),
        ({"k": 2}, r"k=2 is a parameter of preset 'paper', not of preset 'robust'"),
        ({"preset": "paper", "gain": 4}, r"gain=4 is a parameter of preset 'robust'"),
        ({"preset": "fast"}, r"preset='fast' is not one of robust, paper"),
        ({"gain": 0}, r"gain=0 must be in \[1, 32\]"),
        ({"gain": 2.5}, r"gain=2.5 must be an integer"),
        ({"memory": 200}, r"memory=200 must be in \[8, 127\]"),
        ({"stay_cost": -1}, r"stay_cost=-1 must be in \[0, 64\]"),
        ({"move_cost": 65}, r"move_cost=65 must be in \[0, 64\]"),
        ({"skip_cost": "x"}, r"skip_cost='x' must be an integer"),
        ({"max_advance": 4}, r"max_advance=4 must be in \[1, 3\]"),
        ({"centroid_radius": 9}, r"centroid_radius=9 must be in \[0, 8\]"),
        ({"centroid_temperature": 0}, r"centroid_temperature=0 must be in \[1, 64\]"),
        ({"centroid_radius": 2, "preset": "paper"}, "parameter of preset 'robust'"),
        ({"concentration_radius": 9}, r"concentration_radius=9 must be in \[0, 8\]"),
        ({"concentration_temperature": 0}, r"concentration_temperature=0 must be in \[1, 64\]"),
        ({"concentration_radius": 4, "preset": "paper"}, "parameter of preset 'robust'"),
        ({"keyframes": "yes"}, r"keyframes='yes' must be True or False"),
        ({"contrast_patch": 3}, r"^contrast_patch=3 must be one of 2, 4, 8 \(blocks of the"),
        ({"contrast_patch": True}, r"^contrast_patch=True must be one of 2, 4, 8"),
        ({"preset": "paper", "contrast_patch": 2}, r"contrast_patch=2 is a parameter of preset"),
        (
            {"representation": "lowres16", "preset": "paper"},
            r"^preset='paper' does not run on the lowres16 place, which compares contrast-",
        ),
    ],
)
def test_user_errors(kwargs, message):
    kwargs = {"representation": "lbp", **kwargs}
    with pytest.raises(PpalocError, match=message):
        WeightedNodeLocaliser(**kwargs)


def test_step_without_map_and_wrong_map(route):
    loc = WeightedNodeLocaliser("lbp")
    with pytest.raises(PpalocError, match=r"no map: call build_map\(frames\) or use_map"):
        loc.step(route[0])
    with pytest.raises(PpalocError, match=r"the map holds 'lowres' nodes but this localiser"):
        loc.use_map(lowres_map(route))
    with pytest.raises(PpalocError, match="the reference traversal is empty"):
        loc.build_map([])


BAD_FRAMES = [
    np.zeros((256, 256)),
    np.zeros((32, 32), np.uint8),
    np.zeros((256, 256, 3), np.uint8),
    np.zeros((256, 256), np.uint16),
    np.zeros((2, 256, 256), np.uint8),  # a batch: past the place layer's (..., 256, 256)
    np.zeros((0, 256, 256), np.uint8),
]


@pytest.mark.parametrize("frame", BAD_FRAMES)
def test_a_frame_that_is_not_a_sensor_frame_is_a_user_error(route, frame):
    # it was a ValueError from the place layer (SeqSLAM and the sensor: PpalocError)
    loc = WeightedNodeLocaliser("lbp")
    loc.build_map(route)
    with pytest.raises(PpalocError, match=r"convert frames with ppaloc\.datasets\.to_sensor"):
        loc.step(frame)


@pytest.mark.parametrize(
    ("representation", "kw"),
    [
        ("lowres", {"motion": "always_forward"}),
        ("lowres", {}),
        ("haar", {"motion": "always_forward"}),
        ("lbp", {"preset": "paper", "motion": "always_forward"}),
        ("lbp", {"motion": "oracle", "oracle_moves": [True] * 12}),
        ("patch", {"arithmetic": "float"}),
    ],
)
def test_a_refused_frame_leaves_the_filter_as_it_was(route, representation, kw):
    # the schedule counted the frame, took a motion decision (an oracle move) and moved the
    # weights before the frame was refused: every later estimate changed
    loc = WeightedNodeLocaliser(representation, **kw)
    loc.build_map(route)
    query = list(route[:12])
    clean = [(e.node, e.score) for e in loc.localise(query)]
    loc.reset()
    got = []
    for i, frame in enumerate(query):
        if i in (0, 3):
            for bad in BAD_FRAMES:
                with pytest.raises(PpalocError):
                    loc.step(bad)
        e = loc.step(frame)
        got.append((e.node, e.score))
    assert got == clean


@pytest.mark.parametrize("n", [5, 300, 5000, 70001])
def test_top_k_finds_the_largest(n):
    from ppaloc.localise.host import top_k

    rng = np.random.default_rng(n)
    w = rng.normal(size=n).astype(np.float32)
    got = np.sort(w[top_k(w, 4)])
    np.testing.assert_array_equal(got, np.sort(w)[-4:])


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(1, 9),
    lo=st.integers(0, 2),
    extra=st.integers(0, 2),
)
def test_forward_advance_window(seed, n, lo, extra):
    hi = max(lo + extra, 1)
    rng = np.random.default_rng(seed)
    loc = WeightedNodeLocaliser("lbp", preset="paper", advance=(lo, hi), motion="always_forward")
    loc.use_map(TopoMap("lbp", np.zeros(n, np.uint32)))
    ex = loc.executor
    for _ in range(int(rng.integers(0, 3))):  # rotate the buffer a little first
        ex.shift()
    old = rng.integers(-100, 100, n).astype(np.float32)
    ex.set_weights(old)
    ex.shift()
    padded = np.concatenate((np.zeros(hi), old))  # the edge reads 0
    want = [max(padded[hi + i - d] for d in range(lo, hi + 1)) for i in range(n)]
    np.testing.assert_array_equal(loc.weights(), want)
