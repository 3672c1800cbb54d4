"""The robust preset on the sensor: its stages against numpy, and agreement with the host.

The stage tests run on a 64x64 array (two tiles hold 70+ nodes there); the agreement tests
run the full 256x256 pipeline on short synthetic routes against
``WeightedNodeLocaliser(arithmetic="ppa8")`` with the same parameters: node estimates,
motion decisions, kept keyframes, weights (float32 registers: to 1e-4) and scores (the
sensor's integer ``T - T_out``, docs/onsensor.md).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.errors import PpalocError
from ppaloc.localise.params import (
    MAX_SHIFT,
    FilterParams,
    frame_scale,
    transition_costs,
    weight_read,
)
from ppaloc.localise.schedule import SCHEDULES, make_schedule
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.executor import SensorExecutor
from ppaloc.onsensor.mapping import upload_map
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.place import lbp_from_grid, normalise_contrast
from ppaloc.sim import A, B, C, D, F
from ppaloc.topomap import TopoMap

from .conftest import places_with_runs

SIZE = 64
SYNTHETIC = "synthetic:?places=60&query=winter&seed=2"
WITH_STOPS = "synthetic:?places=60&query=winter&seed=2&stops=2"


def _pipe(rep: str, n: int, store: str | None = None, **values):
    params = FilterParams.create(rep, arithmetic="ppa8", motion="always_forward", **values)
    plan = SCHEDULES["robust"].sensor
    if store is None and rep == "lowres" and n > 64:
        # two low-res tiles on one sensor for the stages' tile carry: the analogue store,
        # and a plan without the best distance's refinement (which takes one tile's planes)
        store, plan = "analogue", dataclasses.replace(plan, minimum=False)
    return make_pipeline(rep, n, params, plan=plan, size=SIZE, store=store)


def _put_weights(pipe, values: np.ndarray, fill: float = 99.0) -> None:
    """Weights at the node roots, ``fill`` at every other PE (which must not matter)."""
    t, br, bc = pipe.layout.node_to_block(np.arange(pipe.n_nodes))
    w = np.full((SIZE, SIZE), fill, np.float32)
    w[br * pipe.sensor.bh, bc * pipe.sensor.bw + t] = values
    pipe.sim.write(C, w)


@pytest.mark.parametrize("negated", [False, True])
def test_the_estimate_reads_each_weight_as_ppa8_does(negated):
    """One ADC read of a node's root gives ``floor(w + 1/2)``, halves up, as ppa8's
    :func:`weight_read`; where LBP keeps minus the weights (in ``A``), they are copied
    back first (a read of ``-w`` rounds the halves down)."""
    pipe = _pipe("lbp", 8)
    w = np.array([-3.5, -2.5, 0.5, 1.5, 0.25, -0.75, 2.5, 126.5], np.float32)
    _put_weights(pipe, w)
    if negated:
        pipe.sim.write(A, -pipe.sim.read(C))
        pipe.sim.write(C, np.zeros((SIZE, SIZE), np.float32))
        pipe.state.negated = True
    assert pipe.weight_reads(0, 7) == [weight_read(v) for v in w] == [-3, -2, 1, 2, 0, -1, 3, 127]
    assert pipe.weight_reads(2, 4) == [1, 2, 0]
    assert pipe.sensor.timing.counts_by_stage().get("estimate")


def _flat(tree):
    """``(builder, args)`` as the arguments of ``Sensor.run``."""
    build, args = tree
    return (build, *args)


def _normalised(w: np.ndarray, top: int, memory: int) -> np.ndarray:
    """docs/ppa8.md robust item 5: ``max(clip(w - T), -memory)``."""
    return np.maximum(np.clip(w.astype(np.float64) - top, -127, 127), -memory)


def _transition_reference(w: np.ndarray, costs, memory: int) -> np.ndarray:
    """docs/ppa8.md robust item 2: ``clip(max_d (w_{i-d} - c_d))``, where a node before
    node 0 reads ``-memory``, for every ``d`` (also ``d >= N``)."""
    n = len(w)
    best = w - costs[0]
    for d in range(1, len(costs)):
        shifted = np.r_[np.full(min(d, n), -float(memory)), w[: max(n - d, 0)]]
        best = np.maximum(best, np.clip(shifted - costs[d], -127, 127))
    return np.clip(best, -127, 127)


def _random_weights(n: int, seed: int, low: float = -127) -> np.ndarray:
    rng = np.random.default_rng(seed)
    w = (rng.integers(int(low) * 64, 127 * 64, n) / 64).astype(np.float32)
    w[:3] = (127, -127, 126.5)[: min(n, 3)]
    return w


@pytest.mark.parametrize(
    ("rep", "n"), [("lowres", 40), ("lowres", 100), ("lbp", 100), ("lbp", 200), ("lbp", 2)]
)
@pytest.mark.parametrize(
    ("costs", "memory"), [((4, 0, 4), 127), ((0, 4, 8), 20), ((5, 3, 130, 200), 64), ((0, 0), 8)]
)
@pytest.mark.parametrize("below", [0, 100])
def test_transition_normalises_then_takes_the_max_over_shifted_copies(rep, n, costs, memory, below):
    """The pending normalisation (``T`` from :meth:`normalise`) and the transition along
    the snake, against the host's two steps; ``below`` moves every weight down (T < 0)."""
    pipe = _pipe(rep, n, memory=memory)
    assert pipe.tiles == (2 if n > pipe.layout.capacity else 1)
    w = _random_weights(n, n + len(costs)) - np.float32(below)
    w = np.maximum(w, -127)
    top = int(np.floor(w.max()))
    _put_weights(pipe, w)
    pipe.normalise(top)
    pipe.transition(costs)
    want = _transition_reference(_normalised(w, top, memory), costs, memory)
    np.testing.assert_array_equal(pipe.weights(), want)
    assert {"transition", "normalise"} <= {s.name for s in pipe.timing.report().stages}


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
@pytest.mark.parametrize("n", [1, 2, 3])
@pytest.mark.parametrize("max_advance", [2, 3])
def test_a_map_no_longer_than_max_advance_reads_the_edge_for_every_advance(rep, n, max_advance):
    """Tiny maps: every node ``i < d`` takes the edge's ``-memory - c_d`` for every ``d``,
    also ``d >= N`` (the host's fix of 0e27f8c), with costs where that candidate wins."""
    params = FilterParams.create(
        rep, arithmetic="ppa8", motion="always_forward", memory=30, max_advance=max_advance
    )
    pipe = make_pipeline(rep, n, params, size=SIZE)
    costs = (64, 64, 5, 0)[: max_advance + 1]
    w = np.array([-29.5, -30.0, -30.0][:n], np.float32)
    _put_weights(pipe, w)
    pipe.normalise(0)
    pipe.transition(costs)
    want = _transition_reference(w, costs, 30)
    np.testing.assert_array_equal(pipe.weights(), want)
    # the last node's best candidate is the edge's, through an advance d >= N (which the
    # sensor and the host used to leave out)
    if n <= max_advance:
        inner = max(float(w[n - 1 - d]) - costs[d] for d in range(n))
        assert want[-1] == -30 - min(costs[n:]) > inner


def test_transition_costs_come_from_the_host_decision():
    params = FilterParams.create("lbp", stay_cost=5, move_cost=3, skip_cost=2, max_advance=3)
    pipe = make_pipeline("lbp", 90, params, size=SIZE)
    w = np.linspace(-100, 0, 90).astype(np.float32)
    for moved in (True, False):
        _put_weights(pipe, w)
        pipe.normalise(0)
        costs = transition_costs(moved, params)
        pipe.transition(costs)
        np.testing.assert_array_equal(pipe.weights(), _transition_reference(w, costs, 127))


@pytest.mark.parametrize("memory", [8, 127])
def test_normalise_is_applied_by_the_next_transition(memory):
    """``normalise`` writes nothing: ``weights()`` reports the pending normalisation, the
    register keeps the weights until the next transition subtracts ``T`` and floors."""
    pipe = _pipe("lowres", 100, memory=memory)
    w = np.maximum(_random_weights(100, memory, low=-90) - np.float32(40), -127)
    top = int(np.floor(w.max()))
    _put_weights(pipe, w)
    before = pipe.timing.now_us
    pipe.normalise(top)
    assert pipe.timing.now_us == before
    np.testing.assert_array_equal(pipe.weights(), _normalised(w, top, memory))
    t, br, bc = pipe.layout.node_to_block(np.arange(100))
    np.testing.assert_array_equal(pipe.sim.read(C)[br * pipe.sensor.bh, bc * pipe.sensor.bw + t], w)
    pipe.transition((0,))  # stay on every node for free: the normalisation alone
    np.testing.assert_array_equal(pipe.weights(), _normalised(w, top, memory))
    assert pipe.state.pending_top is None


def test_robust_stages_leave_the_means_of_the_replication_alone():
    pipe = _pipe("lowres", 100)
    pipe.sim.write(F, np.full((SIZE, SIZE), 5.5, np.float32))
    _put_weights(pipe, np.zeros(100, np.float32))
    pipe.transition((4, 0, 4))
    assert (pipe.sim.read(F) == 5.5).all()


def _frame_means(frame: np.ndarray) -> np.ndarray:
    v = frame.astype(np.float64) / 2 - 64
    b = SIZE // 8
    return v.reshape(8, b, 8, b).mean(axis=(1, 3))


@pytest.mark.parametrize(("rep", "n"), [("lowres", 60), ("lbp", 200), ("lowres", 5)])
@pytest.mark.parametrize("gain", [1, 4, 32])
def test_scale_readout_and_update_follow_the_frame_statistics(rep, n, gain):
    """``w += alpha_t - mu 2**-s`` with ``s``, ``alpha_t`` from the readout of every node
    and the frame's best distance (low-res: refined on the array to 1/16)."""
    rng = np.random.default_rng(n + gain)
    pipe = _pipe(rep, n, gain=gain)
    if rep == "lowres":
        nodes = rng.integers(0, 256, (n, 8, 8), dtype=np.uint8)
    else:
        nodes = rng.integers(0, 2**32, n, dtype=np.uint32)
    upload_map(pipe, TopoMap(rep, nodes))
    frame = np.kron(rng.integers(0, 256, (16, 16)), np.ones((4, 4))).astype(np.uint8)
    _put_weights(pipe, np.zeros(n, np.float32))
    pipe.capture(frame)
    values = pipe.node_values()
    best = pipe.minimum(values)
    s, alpha = frame_scale(values, best, gain, exact=True)
    pipe.add_scaled(s, alpha)
    f = _frame_means(frame)
    if rep == "lowres":  # live and nodes contrast-normalised (docs/ppa8.md, robust)
        c, tile = pipe.params.contrast, pipe.params.contrast_patch
        q = np.floor(2 * (f + 64)).astype(np.int64)  # floor of the block means of p
        f = normalise_contrast(q, c, tile).astype(np.float64) / 2 - 64
        stored = normalise_contrast(nodes, c, tile).astype(np.float64)
        diff = np.abs(f[None] - (stored / 2 - 64))
        mu = np.minimum(diff, 127).mean(axis=(1, 2))
        r = 2 * (128 - np.floor(128.5 - mu / 2)).astype(np.int64)
        want_best = math.ceil(16 * mu.min()) / 16 - 1 / 32  # the middle of mu_min's 1/16
    else:
        code = int(lbp_from_grid(f[1:7, 1:7]))
        mu = 2.0 * np.bitwise_count(nodes ^ np.uint32(code))
        r = mu.astype(np.int64)
        want_best = float(r.min())
    np.testing.assert_array_equal(values, r)
    assert best == want_best
    want_s = 0
    while want_s < MAX_SHIFT and 2 * (r.mean() - want_best) > 3 * gain * 2**want_s:
        want_s += 1
    want_alpha = math.floor(want_best * 2.0**-want_s)
    assert (pipe.last_shift, pipe.last_alpha) == (want_s, want_alpha)
    want = np.clip(want_alpha - mu * 2.0**-want_s, -127, 127)
    np.testing.assert_array_equal(pipe.weights(), want)
    assert pipe.tiles == (2 if n > pipe.layout.capacity else 1)


@pytest.mark.parametrize("size", [64, 256])
def test_robust_live_image_takes_one_write_instead_of_summing_the_write_noise(size):
    """Typical noise: the robust preset loads each normalised cell through the DAC, one
    write per PE; the paper's doubling sums the zero background's write noise (units)."""
    rng = np.random.default_rng(5)
    cells = np.kron(rng.integers(20, 236, (8, 8)), np.ones((size // 8, size // 8)))
    frame = (cells + rng.integers(-20, 21, (size, size))).astype(np.uint8)  # a textured scene
    f = (frame.astype(np.float64) / 2 - 64).reshape(8, size // 8, 8, size // 8).mean((1, 3))
    err = {}
    for preset in ("robust", "paper"):
        kw = {"alpha": 8} if preset == "paper" else {}
        params = FilterParams.create(
            "lowres", preset=preset, arithmetic="ppa8", motion="always_forward", **kw
        )
        pipe = make_pipeline("lowres", 40, params, size=size, noise="typical", seed=1)
        pipe.capture(frame)
        pipe.places.prepare_live()
        if preset == "robust":  # the cells the controller read and normalised
            q = np.floor(2 * (f + 64)).astype(np.int64)
            # the noisy readout (write noise and offsets of the reduce tree, the spread
            # and the readout; its transfer gain shrinks the means by a few percent, which
            # can move the normalisation to the next gain) gives the same picture
            ideal = normalise_contrast(q, 48, pipe.params.contrast_patch).reshape(-1)
            assert np.corrcoef(pipe.places.live_image.reshape(-1), ideal)[0, 1] > 0.98
            want = pipe.places.live_image / 2.0 - 64
        else:
            want = f
        err[preset] = float(np.std(-pipe.sim.read(F) - np.tile(want, (size // 8, size // 8))))
    assert err["robust"] < 1.0 < 3 * err["robust"] < err["paper"]


def test_robust_hamming_tree_halves_instead_of_summing_the_write_noise():
    """Typical noise: the robust LBP tree (64 per differing bit, halving) reads ``mu`` to
    about one unit; the paper's adding tree (2 per bit) sums 32 PEs' write noise."""
    rng = np.random.default_rng(6)
    nodes = rng.integers(0, 2**32, 200, dtype=np.uint32)
    frame = np.kron(rng.integers(0, 256, (16, 16)), np.ones((4, 4))).astype(np.uint8)
    err = {}
    for preset in ("robust", "paper"):
        kw = {"alpha": 8} if preset == "paper" else {}
        params = FilterParams.create(
            "lbp", preset=preset, arithmetic="ppa8", motion="always_forward", **kw
        )
        pipe = make_pipeline("lbp", 200, params, size=SIZE, noise="typical", seed=2)
        upload_map(pipe, TopoMap("lbp", nodes))
        pipe.capture(frame)
        code = pipe.places.descriptor()
        pipe.places.load_descriptor(code)
        halving = preset == "robust"  # the scaled readout's tree, or the paper's adding tree
        pipe.places.tree_calls(0, halving=halving)
        pipe.sensor.run(*_flat(pipe.places.tree(0, halving=halving)))
        _, br, bc = pipe.sensor.tile_nodes[0]
        got = pipe.sim.read(D)[br * pipe.sensor.bh, bc * pipe.sensor.bw]
        want = 2.0 * np.bitwise_count(nodes[: len(br)] ^ np.uint32(code))
        err[preset] = float(np.std(got - want))
    assert err["robust"] < 1.5 < 3 * err["robust"] < err["paper"]


@pytest.mark.parametrize(("rep", "free"), [("lbp", A), ("lowres", B)])
def test_robust_frames_leave_the_free_register_alone(rep, free):
    # lowres: one tile of the analogue store, so B holds no map (the levels store's
    # low halves are in B)
    # one sensor's registers: no speed lane (a second sensor)
    pipe = _pipe(
        rep, 40, store="analogue" if rep == "lowres" else None, lane_speed=0, slow_lane=False
    )
    schedule = make_schedule(pipe.params)
    pipe.sim.write(free, np.full((SIZE, SIZE), 7.0, np.float32))
    rng = np.random.default_rng(0)
    for _ in range(3):
        schedule.step(pipe, rng.integers(0, 256, (SIZE, SIZE), dtype=np.uint8))
    keep = np.ones((SIZE, SIZE), bool)
    if pipe.sensor.roles.negated is free:  # lbp: the update writes -w at the weights' PEs only
        assert pipe.state.negated
        keep[:: pipe.sensor.bh, :: pipe.sensor.bw] = False
        keep[:: pipe.sensor.bh, 1 :: pipe.sensor.bw] = False
    assert (pipe.sim.read(free)[keep] == 7.0).all()


# ------------------------------------------------------------------ agreement, full size
@pytest.fixture(scope="module")
def routes():
    out = {}
    for spec in (SYNTHETIC, WITH_STOPS):
        ds = load_dataset(spec)
        out[spec] = ([to_sensor(f) for f in ds.reference], [to_sensor(f) for f in ds.query])
    return out


def _agree(rep: str, ref, query, **kw) -> tuple[WeightedNodeLocaliser, OnSensorLocaliser]:
    """Both filters map ``ref`` themselves and localise ``query``; assert they agree."""
    host = WeightedNodeLocaliser(rep, arithmetic="ppa8", record_weights=True, **kw)
    sensor = OnSensorLocaliser(rep, record_weights=True, **kw)
    want, got = host.build_map(ref), sensor.build_map(ref)
    np.testing.assert_array_equal(got.frame_index, want.frame_index)
    np.testing.assert_array_equal(got.descriptors, want.descriptors)
    assert got.params["n_frames"] == want.params["n_frames"] == len(ref)
    a, b = host.localise(query), sensor.localise(query)
    assert [e.node for e in b] == [e.node for e in a]
    assert [e.moved for e in b] == [e.moved for e in a]
    robust = host.params.preset == "robust"
    for x, y in zip(a, b, strict=True):
        np.testing.assert_allclose(y.weights, x.weights, rtol=0, atol=1e-4)
        if robust:
            # score: the refined threshold minus the outside maximum, each to 2**-4,
            # found by the sensor's searches as the host floors them
            assert y.score == x.score
    return host, sensor


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
@pytest.mark.parametrize("preset", ["robust", "paper"])
@pytest.mark.parametrize("motion", ["image", "always_forward"])
@pytest.mark.parametrize("spec", [SYNTHETIC, WITH_STOPS])
def test_the_sensor_equals_the_host_on_a_synthetic_route(routes, rep, preset, motion, spec):
    ref, query = routes[spec]
    if spec == SYNTHETIC:
        query = query[:60]
    _, sensor = _agree(rep, ref, query, preset=preset, motion=motion)
    if preset == "robust":
        stages = [s.name for s in sensor.pipeline.timing.report().stages]
        assert {"transition", "scale", "normalise"} <= set(stages)
        assert "adjust" not in stages and "shift" not in stages


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_the_sensor_reports_a_query_that_leaves_the_map_lost_as_the_host_does(rep):
    """The map is a route's first 10 places and the query drives on through 10 more:
    the estimate holds the last node while the frames move, so the score falls to 0
    (``past_map_end``: two forward frames on the map's last place), on the sensor as on
    the host's ppa8 filter."""
    rng = np.random.default_rng(7)
    cells = rng.integers(0, 256, (20, 8, 8)).astype(np.uint8)
    frames = [np.kron(c, np.ones((32, 32), np.uint8)) for c in cells]
    kw = dict(motion="always_forward", confidence_radius=1)
    _, sensor = _agree(rep, frames[:10], frames, **kw)
    est = sensor.localise(frames)
    assert [e.node for e in est][10:] == [9] * 10
    # held on node 9, the map's last, from frame 9: frames 11-19 close a window of two
    assert [e.score == 0 for e in est[10:]] == [False] * 1 + [True] * 9
    assert min(e.score for e in est[3:10]) > 0


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_the_sensor_widens_the_transition_where_the_speed_varies_as_the_host_does(rep):
    """The query crosses 15 places at half a place a frame, then skips 10 places and goes
    on at one a frame: the path's gate passes speeds of 1/2 before the skip and fails
    for a window after the estimate's jump, where the speed is known to vary
    (``speed_vary``) and the transition's costs are halved, on the sensor as on the
    host's ppa8 filter (a gate of 0 units: these places' margins are small)."""
    rng = np.random.default_rng(11)
    cells = rng.integers(0, 256, (40, 8, 8)).astype(np.uint8)
    frames = [np.kron(c, np.ones((32, 32), np.uint8)) for c in cells]
    query = [frames[i] for i in [i // 2 for i in range(30)] + list(range(25, 40))]
    kw = dict(motion="always_forward", confidence_radius=1, speed_confidence=0, memory=16)
    host, _ = _agree(rep, frames, query, **kw)
    fixed = WeightedNodeLocaliser(rep, arithmetic="ppa8", record_weights=True, speed_vary=0, **kw)
    fixed.build_map(frames)
    a, b = host.localise(query), fixed.localise(query)
    changed = [not np.array_equal(x.weights, y.weights) for x, y in zip(a, b, strict=True)]
    assert not any(changed[:30]) and any(changed[30:])  # only after the skip


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_the_sensor_runs_the_speed_lane_as_the_host_does(rep):
    """A query at two places a frame: the speed lane (a second sensor) passes its gate
    and sets the filter's costs on the same frames as the host's lane, and the
    estimates, confidences and weights agree; the frame's modelled energy is all the
    sensors' (the filter's and one per lane). Without the lanes the estimates differ.
    (20 blocky places there and back; a gate of 16 units over 4 frames, which the
    lagging filter passes late.)"""
    rng = np.random.default_rng(7)
    cells = rng.integers(0, 256, (20, 8, 8)).astype(np.uint8)
    route = [np.kron(c, np.ones((32, 32), np.uint8)) for c in cells]
    frames = route + route[::-1]
    query = frames[::2]
    kw = dict(motion="always_forward", speed_window=4, speed_confidence=16)
    if rep == "lowres":
        kw["contrast"] = 0
    host, sensor = _agree(rep, frames, query, **kw)
    assert sensor.schedule.lane_frames == host.schedule.lane_frames > 0
    pipes = (sensor.pipeline, *sensor.schedule.lanes)
    assert all(isinstance(p, SensorExecutor) for p in pipes)
    assert len({id(p.sim) for p in pipes}) == 4  # the filter's sensor and one per lane
    before = sum(p.timing.energy_uj for p in pipes)
    spent = sensor.step(query[0]).energy_mj
    after = sum(p.timing.energy_uj for p in pipes)
    assert spent == pytest.approx((after - before) / 1000.0)
    alone = WeightedNodeLocaliser(rep, arithmetic="ppa8", lane_speed=0, slow_lane=False, **kw)
    alone.build_map(frames)
    assert [e.node for e in alone.localise(query)] != [e.node for e in host.localise(query)]


def test_the_sensor_reports_a_leading_lane_as_the_host_does():
    """A query at three places a frame, beyond the filter's own costs: where a speed
    lane's confidence leads the filter's by ``lane_lead`` (8 units here) the sensor
    reports the lane's sensor's estimate and confidence on the same frames as the host,
    and the filter's own weights agree; without the reports the estimates differ."""
    rng = np.random.default_rng(7)
    cells = rng.integers(0, 256, (20, 8, 8)).astype(np.uint8)
    route = [np.kron(c, np.ones((32, 32), np.uint8)) for c in cells]
    frames = route + route[::-1]
    query = frames[::3]
    kw = dict(motion="always_forward", speed_window=4, speed_confidence=16, contrast=0)
    host, _ = _agree("lowres", frames, query, lane_lead=8, **kw)
    own = WeightedNodeLocaliser("lowres", arithmetic="ppa8", lane_lead=0, **kw)
    own.build_map(frames)
    assert [e.node for e in own.localise(query)] != [e.node for e in host.localise(query)]


def _stop_route(seed: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Blocky random places; the reference stops twice (repeated frames), the query once."""
    rng = np.random.default_rng(seed)
    base = rng.integers(0, 256, (24, 16, 16)).astype(np.uint8)
    places = [np.kron(b, np.ones((16, 16), np.uint8)) for b in base]
    ref_order = list(range(24))
    ref_order[5:5] = [4, 4, 4]
    ref_order[15:15] = [11]
    query_order = list(range(2, 24))
    query_order[6:6] = [7, 7]
    query = []
    for i in query_order:
        noise = rng.integers(-12, 13, places[i].shape)
        query.append(np.clip(places[i].astype(int) + noise, 0, 255).astype(np.uint8))
    return [places[i] for i in ref_order], query


def _run_reference(w: np.ndarray, places: np.ndarray) -> np.ndarray:
    """The host's running maximum within each run of one place, written out."""
    out = np.array(w, np.float64)
    for i in range(1, len(out)):
        if places[i] == places[i - 1]:
            out[i] = max(out[i], out[i - 1])
    return out


@pytest.mark.parametrize(("rep", "n"), [("lowres", 40), ("lowres", 100), ("lbp", 90), ("lbp", 200)])
def test_the_transition_lets_weights_flow_along_runs(rep, n):
    """On a map with runs the sensor's transition ends with the running maximum within
    each run: one and two tiles (a run across the tiles' boundary), runs across block
    rows (8 nodes a row at 64 x 64), the edge and the floor around it."""
    from ppaloc.onsensor.runs import longest_run, plan_runs

    pipe = _pipe(rep, n, memory=40)
    cap = pipe.layout.capacity
    places = places_with_runs(n, n, tuple((i - 3, i + 2) for i in (8, 23, cap) if i < n - 3))
    plan_runs(pipe.sensor, places)
    assert pipe.sensor.run_steps == longest_run(places) - 1 >= 4
    assert pipe.sensor.tiles == (2 if n > cap else 1)
    w = np.maximum(_random_weights(n, n + 1, low=-60) - np.float32(20), -127)
    top = int(np.floor(w.max()))
    costs = (3, 0, 6)
    _put_weights(pipe, w)
    pipe.normalise(top)
    pipe.transition(costs)
    moved = np.maximum(_transition_reference(_normalised(w, top, 40), costs, 40), -40)
    want = _run_reference(moved, places)
    assert (want != moved).sum() >= 3  # the runs change the weights
    np.testing.assert_array_equal(pipe.weights(), want)
    assert "runs" in {s.name for s in pipe.timing.report().stages}


def test_a_bank_cuts_a_map_with_runs_between_places():
    from ppaloc.onsensor.runs import bank_offsets

    places = np.array([0, 1, 2, 2, 2, 3, 4, 5, 5, 6])
    assert bank_offsets(places, 10, 4) == [0, 2, 6]
    assert bank_offsets(None, 10, 4) == [0, 4, 8]
    assert bank_offsets(np.arange(10), 10, 4) == [0, 4, 8]
    with pytest.raises(PpalocError, match=r"cannot cut this map between places: the run of "
                       r"nodes 1\.\.6 .* leaves sensor 0 1 node\(s\), fewer than 2"):  # fmt: skip
        bank_offsets(np.array([0, 1, 1, 1, 1, 1, 1, 2]), 8, 4, least=2)


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
@pytest.mark.parametrize("sensor_nodes", [None, 6])
def test_a_map_of_every_frame_keeps_its_stops_as_runs_on_the_sensor(rep, sensor_nodes):
    """keyframes=false with the image motion test: the sensor maps the same places as the
    host and localises as the host's ppa8 filter on every frame, on one sensor and on a
    bank of 6-node sensors (cut between places)."""
    ref, query = _stop_route(3)
    if sensor_nodes is None:  # each maps the reference itself
        host, sensor = _agree(rep, ref, query, keyframes=False)
    else:  # the host's map on the bank
        host = WeightedNodeLocaliser(rep, arithmetic="ppa8", record_weights=True, keyframes=False)
        sensor = OnSensorLocaliser(
            rep, record_weights=True, sensor_nodes=sensor_nodes, keyframes=False
        )
        sensor.use_map(host.build_map(ref))
        a, b = host.localise(query), sensor.localise(query)
        assert [e.node for e in b] == [e.node for e in a]
        for x, y in zip(a, b, strict=True):
            np.testing.assert_allclose(y.weights, x.weights, rtol=0, atol=1e-4)
        offsets = sensor.pipeline.offsets
        assert len(offsets) > 3
        assert all(host.topomap.places[o] != host.topomap.places[o - 1] for o in offsets[1:])
    np.testing.assert_array_equal(sensor.topomap.places, host.topomap.places)
    assert host.topomap.has_runs and sensor.topomap.params["places"] == "motion test"


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_keyframe_map_on_the_sensor_drops_the_reference_stops(rep):
    ref, query = _stop_route(3)
    _, sensor = _agree(rep, ref, query)  # robust default: image motion, keyframes
    topomap = sensor.topomap
    assert len(ref) == 28 and len(topomap) == 24  # the four repeated frames were dropped
    assert topomap.params["keyframes"] == "motion test"
    first, end = topomap.frame_spans()
    assert end[-1] == len(ref) and first[4] == 4 and end[4] == first[5] == 8  # a stop: 1 node
    assert sensor.pipeline.n_nodes == 24
    assert sensor.pipeline.timing.report().stage("mapping").n_calls > len(ref)


@pytest.mark.parametrize(
    "values",
    [
        {"gain": 1, "memory": 8},
        {"gain": 32, "memory": 127, "max_advance": 1},
        {"gain": 2, "stay_cost": 0, "move_cost": 0, "skip_cost": 0, "max_advance": 3},
        {"gain": 8, "stay_cost": 64, "move_cost": 1, "skip_cost": 64, "max_advance": 3},
        {"memory": 30, "stay_cost": 9, "move_cost": 17, "skip_cost": 2, "max_advance": 2},
        {"contrast": 0},
        {"contrast": 1, "gain": 8},
        {"contrast": 127},
        {"speed_window": 2, "speed_confidence": 0},
        {"speed_window": 4, "speed_confidence": 8, "stay_cost": 3, "skip_cost": 5},
        {"preset": "paper", "keyframes": True, "k": 2},
    ],
)
@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_the_sensor_equals_the_host_over_parameter_values(routes, rep, values):
    ref, query = routes[WITH_STOPS]
    _agree(rep, ref[:30], query[:45], motion="image", **values)


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
@pytest.mark.parametrize("n", [1, 2, 3])
def test_the_sensor_equals_the_host_on_a_map_no_longer_than_max_advance(rep, n):
    ref, query = _stop_route(5)
    _agree(rep, ref[:n], query[:16], motion="always_forward", max_advance=3, memory=20)


def test_oracle_motion_runs_the_robust_transition_with_the_given_moves():
    ref, query = _stop_route(4)
    moves = [i % 3 != 1 for i in range(len(query))]
    _, sensor = _agree("lowres", ref, query, motion="oracle", oracle_moves=moves)
    assert sensor.pipeline.last_shift is not None and sensor.alpha is None


@pytest.mark.data
@pytest.mark.slow
@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_the_sensor_equals_the_host_on_a_nordland_slice(nordland_dir, rep):
    """Real data: keyframes of Nordland summer and the winter query, robust defaults."""
    ds = load_dataset(f"nordland:{nordland_dir}?ref=summer&query=winter&stop=160")
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]
    _, sensor = _agree(rep, ref, query)
    assert len(sensor.topomap) < len(ref)  # Nordland's stops became single nodes


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
@pytest.mark.parametrize("sensor_nodes", [None, 6])
def test_the_sensor_lowers_the_confidence_on_still_frames_as_the_host_does(rep, sensor_nodes):
    """The query stands at a place where the reference did not stop: on its still frames
    the confidence falls by ``still_decay`` a frame, on the sensor (one, or a bank of
    6-node sensors on the host's map of every frame) as on the host's ppa8 filter, every
    score the same; the estimates are those of the rule off."""
    ref, query = _stop_route(3)
    kw = dict(confidence_radius=1, still_decay=4)
    if sensor_nodes is None:
        host, _ = _agree(rep, ref, query, **kw)  # compares every score
    else:
        kw["keyframes"] = False
        host = WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)
        bank = OnSensorLocaliser(rep, sensor_nodes=sensor_nodes, **kw)
        bank.use_map(host.build_map(ref))
        assert [e.score for e in bank.localise(query)] == [e.score for e in host.localise(query)]
    off = WeightedNodeLocaliser(rep, arithmetic="ppa8", **{**kw, "still_decay": 0})
    off.use_map(host.topomap)
    a, b = host.localise(query), off.localise(query)
    assert [e.node for e in a] == [e.node for e in b]
    lowered = [i for i, (x, y) in enumerate(zip(a, b, strict=True)) if x.score != y.score]
    assert lowered and all(not a[i].moved and a[i].score < b[i].score for i in lowered)
