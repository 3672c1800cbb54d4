"""One schedule, three executors: a preset written once runs on the host (float and ppa8)
and on the simulated sensor, and they agree; every kernel is cached by what it is."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.localise.params import frame_scale
from ppaloc.localise.schedule import (
    SCHEDULES,
    Executor,
    FrameResult,
    Schedule,
    SensorPlan,
    register_schedule,
)
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.program import CHECK_KERNELS

ROUTE = "synthetic:?places=24&query=winter&seed=2&sync=1"


class AlwaysAdvance(Schedule):
    """A toy preset: every frame after the first moves every weight one node on (whatever
    the motion test says; staying and skipping cost 64 units), adds its scaled likelihood
    and normalises (the robust group's parameters). The whole preset is this class:
    nothing else is written for it, on the host or on the sensor."""

    uses = "robust"
    sensor = SensorPlan(stores=("levels", "digital"), spread="copies", keep_scale=True)

    def step(self, ex: Executor, frame: np.ndarray) -> FrameResult:
        self.frames += 1
        ex.begin(frame)
        moved = bool(ex.motion(self.decided()))  # reported, not used
        if self.frames > 1:
            ex.transition((64, 0, 64))
        values = ex.node_values()
        best = ex.minimum(values)
        shift, alpha = frame_scale(values, best, int(self.params.gain), exact=ex.integer_readout)
        ex.add_scaled(shift, alpha)
        return self.finish(ex, moved)

    def end_frame(self, ex: Executor, top: float) -> None:
        ex.normalise(top)


@pytest.fixture
def advance(monkeypatch):
    monkeypatch.setitem(SCHEDULES, "advance", AlwaysAdvance)
    return "advance"


@pytest.fixture(scope="module")
def frames():
    ds = load_dataset(ROUTE)
    return [to_sensor(f) for f in ds.reference], [to_sensor(f) for f in ds.query]


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_a_new_preset_runs_on_every_executor_and_they_agree(advance, frames, rep):
    ref, query = frames
    kw = {"preset": advance, "keyframes": False, "record_weights": True}
    runs = {}
    for name, loc in (
        ("float", WeightedNodeLocaliser(rep, arithmetic="float", **kw)),
        ("ppa8", WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)),
        ("sensor", OnSensorLocaliser(rep, **kw)),
    ):
        assert isinstance(loc.schedule, AlwaysAdvance)
        loc.build_map(ref)
        runs[name] = loc.localise(query[:12])
    nodes = {name: [e.node for e in est] for name, est in runs.items()}
    assert nodes["sensor"] == nodes["ppa8"] == nodes["float"]
    for a, b in zip(runs["ppa8"], runs["sensor"], strict=True):
        np.testing.assert_allclose(a.weights, b.weights, atol=1e-4)
    # it is its own preset: it advances one node every frame, even while the camera
    # stands still (the motion test says so), which the robust preset would not; the
    # map's own frames make the start unambiguous
    still = WeightedNodeLocaliser("lowres", arithmetic="ppa8", **kw)
    still.build_map(ref)
    held = still.localise([ref[0]] * 3 + ref[3:8])
    assert [e.moved for e in held[1:3]] == [False, False]
    assert [e.node for e in held] == list(range(8))


def test_register_schedule_checks_what_it_is_given():
    from ppaloc.errors import PpalocError

    with pytest.raises(PpalocError, match="is not a Schedule subclass"):
        register_schedule("x", object)  # type: ignore[arg-type]

    class Odd(Schedule):
        uses = "fast"

    with pytest.raises(PpalocError, match="uses='fast' must be 'robust' or 'paper'"):
        register_schedule("odd", Odd)
    assert "odd" not in SCHEDULES


@pytest.mark.parametrize(
    ("rep", "kw"),
    [
        ("lowres", {}),
        ("lbp", {}),
        ("lowres", {"preset": "paper", "store": "analogue"}),
        ("lbp", {"preset": "paper"}),
        ("lbp", {"sensor_nodes": 10}),
    ],
)
def test_every_kernel_is_cached_by_what_it_is(monkeypatch, frames, rep, kw):
    """With the check on, every replayed kernel is recorded again and must give the same
    body as the cached one: no stage builds a kernel from a value its key does not hold
    (mapping, set-up, every preset's frame, a bank)."""
    monkeypatch.setenv(CHECK_KERNELS, "1")
    ref, query = frames
    loc = OnSensorLocaliser(rep, motion="image", **kw)
    loc.build_map(ref)
    loc.localise(query[:6])
