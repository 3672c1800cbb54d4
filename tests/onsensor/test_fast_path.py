"""A kernel's run while nothing observes its simulator (``Scamp5._kernel_runner``, its
choices and its cost bound once) against the run an observer sees (``Scamp5._run_ops``):
the same planes, noise draws, clock, energy and timing report, frame by frame."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.onsensor import OnSensorLocaliser

SIZE = 64


def route() -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Six blocky places of a 64 x 64 array, and a query that stops, skips and moves on."""
    rng = np.random.default_rng(7)
    places = [
        np.kron(rng.integers(0, 256, (8, 8)), np.ones((8, 8), int)).astype(np.uint8)
        for _ in range(6)
    ]
    query = []
    for i in (0, 1, 1, 2, 3, 5, 4):
        noise = rng.integers(-10, 11, places[i].shape)
        query.append(np.clip(places[i] + noise, 0, 255).astype(np.uint8))
    return places, query


def state(sim) -> dict:
    """Everything a run leaves in a simulator: planes, draws, clock and charges."""
    report = sim.timing.report()
    return {
        "analog": sim._a.copy(),  # every deferred fill written
        "digital": sim._d.copy(),
        "latch": sim._latch.copy(),
        "droop": sim._droop_us.copy(),
        "draw": (sim.noise._batch, sim.noise._k),
        "rng": sim.rng.bit_generator.state,
        "clock": (sim.timing.now_us, sim.timing.energy_uj, sim.timing.charges),
        "report": (report.as_dict(), [(s.name, s.kernels, s.icws, s.us) for s in report.stages]),
    }


def assert_same(a: dict, b: dict) -> None:
    for key in a:
        if isinstance(a[key], np.ndarray):
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
            assert a[key].tobytes() == b[key].tobytes(), key  # signed zeros too
        else:
            assert a[key] == b[key], key


@pytest.mark.parametrize("noise", ["ideal", "typical"])
@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_an_unobserved_run_leaves_what_an_observed_run_does(rep: str, noise: str) -> None:
    places, query = route()
    topomap = OnSensorLocaliser(rep, size=SIZE).build_map(places)
    events: list[str] = []
    locs = [
        OnSensorLocaliser(rep, size=SIZE, noise=noise, motion="image", observers=observers)
        for observers in ((), [lambda sim, event: events.append(type(event).__name__)])
    ]
    for loc in locs:
        loc.use_map(topomap)
    for frame in query:
        fast, slow = (loc.step(frame) for loc in locs)
        assert (fast.node, fast.score, fast.modelled_latency_ms, fast.energy_mj) == (
            slow.node,
            slow.score,
            slow.modelled_latency_ms,
            slow.energy_mj,
        )
        sims = [[loc.pipeline.sim, *(lane.sim for lane in loc.schedule.lanes)] for loc in locs]
        for a, b in zip(*sims, strict=True):
            assert_same(state(a), state(b))
    assert "KernelRun" in events  # the observed localiser did run through the observed path


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_a_roots_pe_is_its_blocks_corner_asked_once_or_again(rep: str) -> None:
    """``Sensor.root_of`` keeps each node's root: the same PE on every call, the corner of
    the node's block in the snake layout plus its tile's column offset."""
    loc = OnSensorLocaliser(rep, size=SIZE)
    loc.use_map(loc.build_map(route()[0]))
    sensor = loc.pipeline.sensor
    layout = sensor.layout
    nodes = np.arange(sensor.n_nodes)
    tile, br, bc = layout.node_to_block(nodes)
    rows, cols = br * sensor.bh, bc * sensor.bw + tile
    want = [(int(r), int(c)) for r, c in zip(rows, cols, strict=True)]
    for _ in range(2):
        assert [sensor.root_of(int(n)) for n in nodes] == want
        assert [sensor.root_of(np.int64(n)) for n in nodes[::-1]] == want[::-1]
