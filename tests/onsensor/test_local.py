"""The local term (``local_gain``) on the sensor equals the host's ppa8 filter."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams, local_step
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.bank import SensorBank
from ppaloc.topomap import build_topomap

from .conftest import STOP_AND_SKIP, agree, assert_same_estimates, places_with_runs


@pytest.mark.parametrize("rep", ["lowres", "lowres16", "lbp", "haar"])
@pytest.mark.parametrize("gain, window", [(2, 1), (8, 2)])
def test_one_sensor_equals_the_host_ppa8_filter(blocky_route, rep, gain, window):
    kw = {"motion": "image", "local_gain": gain, "local_window": window}
    a, b, _ = agree(rep, blocky_route(8, 11, STOP_AND_SKIP), 8, **kw)
    assert_same_estimates(a, b)
    # the term is there: without it the weights differ
    plain, _, _ = agree(rep, blocky_route(8, 11, STOP_AND_SKIP), 8, motion="image", local_gain=0)
    pairs = zip(a, plain, strict=True)
    assert max(float(np.abs(x.weights - y.weights).max()) for x, y in pairs) > 1


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_a_bank_equals_the_host(blocky_route, rep):
    kw = {"motion": "always_forward", "local_gain": 4, "local_window": 2}
    a, b, sensor = agree(rep, blocky_route(8, 12, STOP_AND_SKIP), 8, {"sensor_nodes": 3}, **kw)
    assert_same_estimates(a, b)
    assert isinstance(sensor.pipeline, SensorBank) and sensor.pipeline.offsets == [0, 3, 6]


def test_two_tiles_and_banks_equal_the_host(blocky_route):
    """260 Haar-sign nodes take both tiles of one sensor (windows 1 and 3); a bank of
    two such sensors has a tile cut and a sensor cut; a bank of parts of 2 nodes, fewer
    than the window of 3, has pairs across two cuts."""
    ref, query = blocky_route(260, 12, [248, 249, 250, 250, 252, 253, 254, 255, 256, 258])
    topomap = build_topomap(ref, "haar")
    short = build_topomap(ref[248:], "haar")  # a bank of 130 small sensors is slow
    kw = {"motion": "always_forward", "record_weights": True, "local_gain": 6}
    cases = (  # parts of 2 nodes take max_advance=2: a part holds what a frame may advance
        (1, topomap, {}, [0], 3),
        (3, topomap, {}, [0], 3),
        (3, topomap, {"sensor_nodes": 258}, [0, 258], 3),
        (3, short, {"sensor_nodes": 2}, list(range(0, 12, 2)), 2),
    )
    for window, tmap, sensor_kw, offsets, advance in cases:
        both = {**kw, "local_window": window, "max_advance": advance}
        host = WeightedNodeLocaliser("haar", arithmetic="ppa8", **both)
        host.use_map(tmap)
        want = host.localise(query)
        sensor = OnSensorLocaliser("haar", **both, **sensor_kw)
        sensor.use_map(tmap)
        assert_same_estimates(want, sensor.localise(query))
        if sensor_kw:
            assert isinstance(sensor.pipeline, SensorBank)
            assert sensor.pipeline.offsets == offsets
        else:
            assert sensor.pipeline.tiles == 2
            assert {e.node for e in want} & {255, 256}  # the estimate crossed the tiles


def test_the_noisy_sensor_runs_the_term(blocky_route):
    """Under the typical preset the stage runs on noisy values (exact reads, the moved
    copies) and changes the weights, as in ideal mode. (The confidence's window is 2
    nodes: the default 10 leaves no node of this 12-node map outside a middle
    estimate's window, so a speed lane at the map's end, sure of it by the one node left
    outside, leads the filter on whichever frames the noise draws favour it.)"""
    ref, query = blocky_route(12, 14, list(range(12)))
    weights = []
    for gain in (0, 2):
        loc = OnSensorLocaliser(
            "lowres", noise="typical", motion="always_forward", record_weights=True,
            sensor_nodes=6, local_gain=gain, local_window=1, confidence_radius=2,
        )  # fmt: skip
        loc.build_map(ref)
        est = loc.localise(query)
        assert [e.node for e in est] == list(range(12))
        weights.append(est[-1].weights)
    assert np.abs(weights[1] - weights[0]).max() > 0.5


def test_the_stage_is_timed():
    ref = [np.full((256, 256), 40 * i, np.uint8) for i in range(5)]
    loc = OnSensorLocaliser("lbp", motion="always_forward", local_gain=2, local_window=1)
    loc.build_map(ref)
    loc.localise(ref)
    assert loc.pipeline.timing.counts_by_stage().get("local")


@pytest.mark.parametrize(
    "gain, window, step", [(2, 1, 1), (4, 1, 2), (4, 2, 1), (8, 2, 2), (3, 1, None), (2, 2, None)]
)
def test_the_step_is_an_integer_or_none(gain, window, step):
    assert local_step(gain, window) == step


def test_a_fractional_step_is_refused_in_register_arithmetic():
    with pytest.raises(PpalocError, match=r"^local_gain=3 with local_window=1: in ppa8"):
        FilterParams.create("lbp", arithmetic="ppa8", local_gain=3, local_window=1)
    with pytest.raises(PpalocError, match=r"local_gain / \(2 local_window\)"):
        OnSensorLocaliser("lowres", local_gain=2, local_window=2)
    assert FilterParams.create("lbp", local_gain=3, local_window=1).local_gain == 3


@pytest.mark.parametrize(
    "window, sensor_nodes, offsets",
    [(1, None, None), (2, None, None), (2, 7, [0, 4, 11, 17, 24, 30, 37, 43])],
)
def test_a_run_of_one_place_compares_with_the_nodes_next_to_it(
    blocky_route, window, sensor_nodes, offsets
):
    """On a map with runs (a stop of the reference, ``keyframes=false``) every node of a
    run is compared with the nodes next to its run, on the array along the snake and by
    the controller across tiles and sensors: the sensor equals the host's ppa8 filter
    with a run over the tiles' boundary (Haar signs: 256 nodes a tile) and runs over a
    bank's cuts, and the term is not the one that compares neighbouring nodes."""
    from ppaloc.localise.enhance import closer_count
    from ppaloc.topomap import TopoMap

    ref, query = blocky_route(284, 14, [250, 251, 252, 252, 254, 255, 256, 258, 259, 262, 265])
    full = build_topomap(ref, "haar")
    places = places_with_runs(284, 3, ((240, 244), (253, 259), (262, 263)))
    if sensor_nodes is None:
        tmap = TopoMap("haar", full.descriptors, places=places)
    else:  # a bank of small sensors, cut between places
        part = places[236:] - places[236]
        tmap = TopoMap("haar", full.descriptors[236:], places=part)
        query = [ref[i] for i in (240, 241, 242, 244, 246, 248, 250, 252, 253, 256, 259, 262)]
    kw = {"motion": "always_forward", "record_weights": True, "local_gain": 2 * window}
    kw |= {"local_window": window, "max_advance": 2}
    host = WeightedNodeLocaliser("haar", arithmetic="ppa8", **kw)
    host.use_map(tmap)
    want = host.localise(query)
    sensor = OnSensorLocaliser(
        "haar", **kw, **({"sensor_nodes": sensor_nodes} if sensor_nodes else {})
    )
    sensor.use_map(tmap)
    assert_same_estimates(want, sensor.localise(query))
    if sensor_nodes is None:
        assert sensor.pipeline.tiles == 2 and tmap.places[255] == tmap.places[256]
    else:
        assert isinstance(sensor.pipeline, SensorBank) and sensor.pipeline.offsets == offsets
        assert tmap.places[17] == tmap.places[23]  # a part that is one run
    # the places' neighbours are not the nodes': some frame's counts differ
    raw = [host.executor._distances(q) for q in query]
    assert any((closer_count(d, window, tmap.places) != closer_count(d, window)).any() for d in raw)
