"""The weights' scale under a transfer gain: calibration, restoration, and the two together."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from ppaloc.localise.params import FilterParams
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser, gain
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.sim import PRESETS, C, NoiseParams

SIZE = 64


def _pipe(rep: str = "lowres", n: int = 40, noise="ideal", seed: int = 0, preset="robust"):
    params = FilterParams.create(rep, arithmetic="ppa8", motion="always_forward", preset=preset)
    return make_pipeline(rep, n, params, size=SIZE, noise=noise, seed=seed)


@pytest.mark.parametrize("g", [-0.005, -0.002, 0.001])
def test_calibration_reads_the_arrays_transfer_gain(g):
    pipe = _pipe(noise=NoiseParams(transfer_gain=g))
    # the ADC rounds the chain's mean to a code: at most 4% of g without other noise
    assert pipe.state.scale.log_gain == pytest.approx(math.log1p(g), rel=0.05)
    assert "calibrate" in [s.name for s in pipe.timing.report().stages]


@pytest.mark.parametrize("seed", [0, 1])
def test_calibration_sees_through_the_other_noise_terms(seed):
    typical = PRESETS["typical"]
    pipe = _pipe(noise="typical", seed=seed)
    assert pipe.state.scale.log_gain == pytest.approx(math.log1p(typical.transfer_gain), rel=0.15)


def test_the_calibration_chain_leaves_the_icw_stack_to_the_frames_kernels():
    from ppaloc.sim.kernel import icw_stack

    pipe = _pipe()
    chain = pipe.sensor.run(gain._chain)  # the cached start-up kernel, run again
    assert len(chain) == gain.CALIBRATION_WRITES and chain.on_heap
    # what the stack holds is every other cached kernel, the 128-ICW chain not among them
    assert icw_stack(pipe.sensor.sim).used == pipe.sensor.kernels.icws


def test_ideal_sensor_measures_no_gain_and_never_restores():
    pipe = _pipe()
    assert pipe.state.scale.log_gain == 0.0
    pipe.state.scale.charge(10_000)
    assert pipe.state.scale.due() == 0
    assert _pipe(preset="paper").state.scale.log_gain == 0.0  # the paper preset does not calibrate


def test_scale_is_due_after_one_step_of_drift_either_way():
    down = gain.WeightScale(math.log1p(-0.002), step=4)
    writes = 0
    while not down.due():
        down.charge(1)
        writes += 1
    assert down.due() == 1  # shrunk: expand
    assert (1 - 0.002) ** writes <= 1 / (1 + 1 / 16) < (1 - 0.002) ** (writes - 1)
    down.restored(1, gain.RESTORE_WRITES)
    assert down.due() == 0 and abs(down.log_scale) < 0.01
    up = gain.WeightScale(math.log1p(0.003), step=3)
    up.charge(100)
    assert up.due() == -1


@pytest.mark.parametrize("sign", [1, -1])
@pytest.mark.parametrize("step", [3, 4, 5])
def test_restore_scales_the_node_roots_only(sign, step):
    pipe = _pipe("lowres", 40)
    t, br, bc = pipe.layout.node_to_block(np.arange(pipe.n_nodes))
    rows, cols = br * pipe.sensor.bh, bc * pipe.sensor.bw + t
    rng = np.random.default_rng(step)
    w = np.full((SIZE, SIZE), 99.0, np.float32)
    values = rng.uniform(-127, 1, pipe.n_nodes).astype(np.float32)
    values[:2] = (-127, 0.5)
    w[rows, cols] = values
    pipe.sim.write(C, w)
    gain.restore(pipe.sensor, C, pipe.sensor.roles.d.valid, sign, step)
    got = pipe.sim.read(C)
    want = np.clip(values.astype(np.float64) * (1 + sign * 2.0**-step), -127, 127)
    np.testing.assert_allclose(got[rows, cols], want, atol=1e-5)
    others = np.ones((SIZE, SIZE), bool)
    others[rows, cols] = False
    assert (got[others] == 99.0).all()


def _weight_slope(route, restore: bool, g: float, monkeypatch) -> tuple[float, int]:
    """Slope of the sensor's weights against the host's after a route, under a transfer
    gain alone; and the number of restorations."""
    if not restore:
        monkeypatch.setattr(gain.WeightScale, "due", lambda self: 0)
    ref, query = route(12, seed=5, order=list(range(12)) * 2)
    kw = {"preset": "robust", "motion": "always_forward", "record_weights": True}
    host = WeightedNodeLocaliser("lowres", arithmetic="ppa8", **kw)
    noise = dataclasses.replace(NoiseParams(), transfer_gain=g)
    sensor = OnSensorLocaliser("lowres", noise=noise, **kw)
    sensor.use_map(host.build_map(ref))
    a, b = host.localise(query), sensor.localise(query)
    x, y = a[-1].weights, b[-1].weights
    keep = x > -100  # above the floor and its clip
    return float(np.polyfit(x[keep], y[keep], 1)[0]), sensor.pipeline.state.scale.restores


def test_restorations_keep_the_weights_scale_under_a_transfer_gain(blocky_route, monkeypatch):
    """24 forward frames at g = -0.4% (four writes a frame): six restorations by 17/16,
    and the weights' scale against the host's well above the drift without them (the
    rest of the slope is the trees' own gain, which scales every likelihood term alike)."""
    g = -0.004
    slope, restores = _weight_slope(blocky_route, True, g, monkeypatch)
    steps = 24 * 4 * math.log1p(g) / -math.log1p(2.0**-4)
    assert abs(restores - steps) <= 1
    with monkeypatch.context() as m:
        drifted, none = _weight_slope(blocky_route, False, g, m)
    assert none == 0
    assert slope > 0.88 and slope - drifted > 0.04


@pytest.mark.parametrize("costs", [(4, 0, 4), (2, 6, 9), (0, 5, 9)])
def test_a_transition_scales_the_weights_by_the_writes_it_counts(costs):
    """The cheapest candidate's path: a move (copy and take), a stay by 2 (one add), a
    free stay (no write); checked where that candidate wins, away from the row starts."""
    g = -0.01
    pipe = _pipe("lowres", 40, noise=NoiseParams(transfer_gain=g))
    pipe.state.scale.step = 30  # no restoration inside the test
    t, br, bc = pipe.layout.node_to_block(np.arange(pipe.n_nodes))
    rows, cols = br * pipe.sensor.bh, bc * pipe.sensor.bw + t
    rng = np.random.default_rng(1)
    w = rng.uniform(-60, 0, pipe.n_nodes)
    plane = np.zeros((SIZE, SIZE), np.float32)
    plane[rows, cols] = w
    pipe.sim.write(C, plane)
    before = pipe.state.scale.log_scale
    pipe.transition(costs)
    got = pipe.sim.read(C)[rows, cols].astype(np.float64)
    cands = np.full((len(costs), len(w)), -np.inf)
    for d, c in enumerate(costs):
        cands[d, d:] = w[: len(w) - d] - c
    cheapest = int(np.argmin(costs))
    wins = (cands.argmax(axis=0) == cheapest) & (cands.max(axis=0) > -60)
    # a snake's row starts take their moved candidates through a few more copies
    wins &= np.arange(len(w)) % pipe.layout.grid_shape[1] >= len(costs) - 1
    assert wins.sum() > 5
    factor = math.exp(pipe.state.scale.log_scale - before)
    np.testing.assert_allclose(got[wins], cands.max(axis=0)[wins] * factor, atol=0.05)
