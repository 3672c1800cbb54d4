"""Sensor banks and the low-res levels store: agreement with the host, carry, refresh."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.bank import SYNC_US, SensorBank
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.sim import NoiseParams
from ppaloc.sim.registers import C
from ppaloc.topomap import TopoMap

#: The bank tests' query: stops (2, 7) and skips (4, 10, 15, 21) across the sensors.
_ORDER = [0, 1, 2, 2, 3, 5, 6, 7, 7, 8, 9, 11, 12, 13, 14, 16, 17, 18, 19, 20, 22, 23]


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_a_bank_of_three_sensors_equals_the_host(blocky_route, rep):
    ref, query = blocky_route(24, 3, _ORDER)
    kw = {"motion": "always_forward", "record_weights": True}
    host = WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)
    topomap = host.build_map(ref)
    sensor = OnSensorLocaliser(rep, sensor_nodes=9, **kw)
    sensor.use_map(topomap)
    bank = sensor.pipeline
    assert isinstance(bank, SensorBank) and bank.offsets == [0, 9, 18]
    a, b = host.localise(query), sensor.localise(query)
    assert [e.node for e in a] == [e.node for e in b]
    assert {e.node for e in b} & {8, 9, 17, 18}  # the estimate crossed sensor boundaries
    for x, y in zip(a, b, strict=True):
        assert y.score == x.score  # both refined to 2**-4 (DETECT_BITS)
        np.testing.assert_allclose(y.weights, x.weights, rtol=0, atol=1e-4)
        # per phase the slowest sensor plus the exchanges; energy the sum of the sensors'
        assert y.modelled_latency_ms * 1000 > 5 * SYNC_US[1]
    assert bank.timing.energy_uj == pytest.approx(
        sum(s.timing.energy_uj for s in bank.sensors), rel=1e-12
    )


def test_the_carry_reads_and_writes_a_weight_exactly():
    params = FilterParams.create("lowres", motion="always_forward")
    pipe = make_pipeline("lowres", 40, params, size=64)
    nodes = np.arange(40)
    tile, br, bc = pipe.layout.node_to_block(nodes)
    rows, cols = br * pipe.sensor.bh, bc * pipe.sensor.bw + tile
    plane = pipe.sim.read(C).copy()
    want = [float(np.float32(w)) for w in (-3.0 + 2.0**-21 * 12345, 17.5 - 2.0**-17, -126.25)]
    plane[rows[-3:], cols[-3:]] = want[::-1]
    pipe.sim.write(C, plane)
    pipe.state.pending_top = None
    got = pipe.carry_out(3)
    assert got == [max(w, -params.memory) for w in want]
    receiver = make_pipeline("lowres", 40, params, size=64)
    receiver.carry_in(got)
    parked = receiver.sim.read(C)[1, [64 - 8 * (j + 1) for j in range(3)]]
    np.testing.assert_array_equal(parked, np.float32(got))


def test_the_levels_store_survives_droop_the_analogue_store_does_not(blocky_route):
    """Droop only (1 unit/ms): after a dozen frames the refreshed levels still give n."""
    ref, query = blocky_route(24, 4, _ORDER)
    droop = NoiseParams(decay_per_ms=1.0)
    errors = {}
    for store in ("levels", "analogue"):
        loc = OnSensorLocaliser("lowres", noise=droop, store=store, motion="always_forward")
        topomap = loc.build_map(ref)
        loc.localise(query[:13])  # refreshes at frames 1, 5, 9, 13
        pipe = loc.pipeline
        stored = pipe.node_blocks(topomap)  # the robust preset's normalised images
        want = pipe.layout.to_planes(stored, fill=128)[0] / 2.0 - 64
        valid = pipe.layout.to_planes(topomap.node_blocks() * 0 + 1, fill=0)[0] > 0
        errors[store] = float(np.abs(pipe.places.map_plane(0) - want)[valid].max())
    assert errors["levels"] < 1.0  # the droop of one frame after the last refresh
    assert errors["analogue"] > 5.0


def test_bank_and_store_mistakes_name_the_value():
    with pytest.raises(PpalocError, match="store='levels'"):
        OnSensorLocaliser("lbp", store="levels")
    with pytest.raises(PpalocError, match="sensor_nodes"):
        OnSensorLocaliser("lbp", sensor_nodes=0)
    # refused when the localiser is built, not once a map (minutes of mapping) is made
    with pytest.raises(PpalocError, match="sensor_nodes=4 sets the sensors of a bank, and a"):
        OnSensorLocaliser("lbp", preset="paper", alpha=8, sensor_nodes=4)
    paper = OnSensorLocaliser("lbp", preset="paper", alpha=8)  # a map beyond one sensor
    with pytest.raises(PpalocError, match="robust preset only"):
        SensorBank(paper._new_pipeline(4), 10, paper._new_pipeline)
    # a frame may advance max_advance nodes into the next sensor: each must hold that many
    with pytest.raises(PpalocError, match="sensor_nodes=1 is too small for a bank"):
        OnSensorLocaliser("lbp", sensor_nodes=1)
    OnSensorLocaliser("lbp", sensor_nodes=3).use_map(TopoMap("lbp", np.arange(10, dtype=np.uint32)))


def test_a_noisy_read_below_the_weight_range_is_carried_as_its_edge():
    """A weight read as -127.9 (noise) under a low pending T is carried as -127."""
    params = FilterParams.create("lowres", motion="always_forward")
    pipe = make_pipeline("lowres", 10, params, size=64)
    _, br, bc = pipe.layout.node_to_block(np.array([9]))
    plane = pipe.sim.read(C).copy()
    plane[br[0] * pipe.sensor.bh, bc[0] * pipe.sensor.bw] = -127.9
    pipe.sim.write(C, plane)
    pipe.state.pending_top = -5  # floor -5 - memory, below the register's range
    (got,) = pipe.carry_out(1)
    assert got == -127.0
    make_pipeline("lowres", 10, params, size=64).carry_in([got])  # the DAC takes it


def test_a_small_array_given_the_commands_frames_says_to_leave_size_alone():
    # the commands give 256 x 256 sensor frames: size=64 failed asking to convert them
    loc = OnSensorLocaliser("lowres", size=64)
    with pytest.raises(PpalocError, match="size=64 simulates a 64 x 64 array, but the frames"):
        loc.build_map([np.zeros((256, 256), np.uint8)] * 3)
    loc.build_map([np.zeros((64, 64), np.uint8)] * 3)  # its own size, from Python
