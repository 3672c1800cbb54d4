"""OnSensorLocaliser: agreement with the host ppa8 filter, protocol, errors, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.base import Localiser
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.methods import make_localiser
from ppaloc.onsensor import OnSensorLocaliser


def _order(n: int) -> list[int]:
    """The query's order: each place once, with two stops when the route is long enough."""
    order = list(range(n))
    if n > 12:
        order[4:4] = [3, 3]  # the vehicle stops at place 3
        order[12:12] = [10]
    return order


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_estimates_and_weights_equal_the_host_ppa8_filter(blocky_route, rep):
    ref, query = blocky_route(16, 1, _order(16))
    kw = {"preset": "paper", "motion": "image", "alpha": 10, "shift": 2, "k": 3}
    kw["record_weights"] = True
    host = WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)
    topomap = host.build_map(ref)
    sensor = OnSensorLocaliser(rep, **kw)
    sensor.use_map(topomap)
    a = host.localise(query)
    b = sensor.localise(query)
    assert [e.node for e in a] == [e.node for e in b]
    assert [e.moved for e in a] == [e.moved for e in b]
    assert not all(e.moved for e in b[1:])  # the stops were seen
    for x, y in zip(a, b, strict=True):
        # float32 registers vs the host's float64: equal up to the last bit of a weight
        np.testing.assert_allclose(y.weights, x.weights, rtol=0, atol=1e-4)
        assert y.modelled_latency_ms > 0 and y.energy_mj > 0
    assert b[0].ranking is None


@pytest.mark.parametrize(
    ("method", "preset"), [("onsensor-lbp", "robust"), ("onsensor-paper-lbp", "paper")]
)
def test_protocol_registry_and_rebuild(blocky_route, method, preset):
    loc = make_localiser(method, motion="always_forward")
    assert isinstance(loc, Localiser) and loc.name == "onsensor-lbp"
    assert loc.preset == preset == loc.params.preset
    ref, query = blocky_route(6, 2)
    topomap = loc.build_map(ref)
    assert topomap.kind == "lbp" and len(topomap) == 6
    first = [loc.step(f).node for f in query[:4]]
    loc.reset()
    assert [loc.step(f).node for f in query[:4]] == first


def test_noise_is_seeded(blocky_route):
    ref, query = blocky_route(6, 3)
    runs = []
    for _ in range(2):
        loc = OnSensorLocaliser("lowres", noise="typical", seed=7, motion="always_forward")
        loc.build_map(ref)
        runs.append([(e.node, e.score) for e in loc.localise(query[:4])])
    assert runs[0] == runs[1]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"noise": "loud"}, "noise='loud' is not one of"),
        ({"arithmetic": "float"}, "use arithmetic='ppa8'"),
        ({"preset": "paper", "gamma": 0.3}, "gamma=0.3 must be one of"),
        ({"preset": "paper", "alpha": 2.5}, "alpha=2.5 must be an integer"),
        ({"preset": "paper", "advance": (0, 2)}, "advance=\\(0, 2\\): the sensor shifts"),
        ({"alpha": 4}, "alpha=4 is a parameter of preset 'paper'"),
        ({"gain": 0}, "gain=0 must be in \\[1, 32\\]"),
        ({"max_advance": 4}, "max_advance=4 must be in \\[1, 3\\]"),
        ({"preset": "fast"}, "preset='fast' is not one of"),
        ({"colour": 1}, "unknown filter parameter 'colour'"),
    ],
)
def test_bad_parameters_name_the_value(kwargs, message):
    with pytest.raises(PpalocError, match=message):
        OnSensorLocaliser("lowres", **kwargs)


def test_step_needs_a_map_and_a_sensor_frame(blocky_route):
    loc = OnSensorLocaliser("lbp")
    with pytest.raises(PpalocError, match="no map"):
        loc.step(np.zeros((256, 256), np.uint8))
    loc.build_map(blocky_route(3, 4)[0])
    with pytest.raises(PpalocError, match="to_sensor"):
        loc.step(np.zeros((100, 100), np.uint8))
    with pytest.raises(PpalocError, match="empty"):
        loc.build_map([])


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_figures_are_written(blocky_route, tmp_path, rep):
    from PIL import Image

    from ppaloc.onsensor.figures import (
        database_figure,
        difference_figure,
        weights_figure,
        weights_history_image,
    )

    ref, query = blocky_route(5, 5)
    loc = OnSensorLocaliser(rep, motion="always_forward", record_weights=True)
    loc.build_map(ref)
    paths = [
        database_figure(loc, tmp_path / "db.png", scale=1),
        weights_figure(loc, query[:3], tmp_path / "w.png", snapshots=2, scale=1),
        difference_figure(loc, query[0], tmp_path / "diff.png", scale=1),
        weights_history_image(loc.localise(query[:3]), tmp_path / "hist.png"),
    ]
    sizes = []
    for p in paths:
        with Image.open(p) as im:
            sizes.append(im.size)
    assert sizes[0][0] >= 256 and sizes[1][0] >= 2 * 256 and sizes[2][0] >= 4 * 256
    assert sizes[3] == (5, 3)
    with pytest.raises(PpalocError, match="record_weights"):
        weights_history_image([], tmp_path / "none.png")


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_mapping_on_the_sensor_gives_the_host_nodes(blocky_route, rep):
    from ppaloc.topomap import build_topomap

    ref, _ = blocky_route(4, 6)
    ref.append(np.zeros((256, 256), np.uint8))  # block sums of 0: the saturating case
    ref.append(np.full((256, 256), 255, np.uint8))
    ramp = np.tile(np.arange(256, dtype=np.uint8), (256, 1))
    ref.append(ramp)
    sensor = OnSensorLocaliser(rep, motion="always_forward")
    got = sensor.build_map(ref)
    want = build_topomap(ref, rep)
    np.testing.assert_array_equal(got.descriptors, want.descriptors)
    assert got.params["n_frames"] == len(ref)
    assert sensor.pipeline.sim.timing.report().stage("mapping").n_calls > len(ref)


@pytest.mark.parametrize(("shift", "gamma"), [(0, 1.0), (3, 0.0)])
def test_oracle_motion_and_other_scales_agree_with_the_host(blocky_route, shift, gamma):
    ref, query = blocky_route(14, 8, _order(14))
    moves = [False, True, True, True, False, False] + [True] * (len(query) - 6)
    kw = {"motion": "oracle", "oracle_moves": moves, "alpha": 6, "shift": shift, "gamma": gamma}
    kw["preset"] = "paper"
    host = WeightedNodeLocaliser("lowres", arithmetic="ppa8", **kw)
    sensor = OnSensorLocaliser("lowres", **kw)
    sensor.use_map(host.build_map(ref))
    a, b = host.localise(query), sensor.localise(query)
    assert [e.node for e in a] == [e.node for e in b]
    assert [e.moved for e in b] == moves


@pytest.mark.parametrize(
    ("rep", "tiles"),
    [
        (
            "lowres",
            [
                "A: map tile 0, high 4 bits (levels 16 h - 120)",
                "B: map tile 0, low 4 bits (levels 16 l - 128)",
            ],
        ),
        ("lbp", ["R10: map tile 0"]),
    ],
)
def test_register_planes_name_their_roles_and_hold_the_map(blocky_route, rep, tiles):
    loc = OnSensorLocaliser(rep, motion="always_forward")
    assert loc.register_planes() == {}
    ref, query = blocky_route(6, 3)
    loc.build_map(ref)
    for f in query[:3]:
        loc.step(f)
    planes = loc.register_planes()
    assert [k for k in planes if "map tile" in k] == tiles  # one tile holds 6 nodes
    assert "C: weights" in planes and "R9: detection candidates" in planes
    assert all(p.shape == (256, 256) for p in planes.values())
    db = planes[tiles[0]]
    assert db.dtype == (np.float32 if rep == "lowres" else bool)
    assert np.any(db != db.flat[-1])  # the map was written into the register
