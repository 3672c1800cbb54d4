"""The Haar-sign place on the sensor: the live signs, the Hamming tree, the host's estimates."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.methods import make_localiser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.bank import SensorBank
from ppaloc.onsensor.haar import HaarPlaces
from ppaloc.onsensor.lbp import DESCRIPTOR
from ppaloc.onsensor.likelihood import node_values
from ppaloc.onsensor.mapping import upload_map
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.place import haar_descriptor, haar_plane, hamming_words, lowres_image, pack_plane
from ppaloc.topomap import TopoMap, build_topomap

from .conftest import STOP_AND_SKIP, agree, assert_maps_as_the_host, assert_same_estimates


def test_the_live_signs_are_the_hosts_in_every_node_block(blocky_route, monkeypatch):
    """A textured frame (about half the signs set), a black one (all 192 tie to 1: every
        sign's cell set, none cleared) and one lit from the top-left (only the diagonals tie to
    1): the plane is
        the host's, with at most 98 patterns a frame."""
    ref, _ = blocky_route(1, 3)
    x = np.arange(256)
    ramp = (255 - (x[None, :] + x[:, None]) // 2).astype(np.uint8)  # lit from the top-left
    params = FilterParams.create("haar", arithmetic="ppa8", motion="always_forward")
    pipe = make_pipeline("haar", 4, params)
    patterns = []
    real = pipe.sim.load_pattern
    monkeypatch.setattr(pipe.sim, "load_pattern", lambda *a: patterns.append(a) or real(*a))
    for frame, set_signs in ((ref[0], None), (np.zeros((256, 256), np.uint8), 192), (ramp, 64)):
        patterns.clear()
        pipe.capture(frame)
        pipe.places.prepare_live()
        want = haar_plane(lowres_image(frame, 16))
        assert set_signs is None or int(want.sum()) == set_signs
        np.testing.assert_array_equal(pipe.places.last_code, haar_descriptor(frame))
        np.testing.assert_array_equal(pipe.sim.read(DESCRIPTOR), np.tile(want, (16, 16)) == 1)
        assert len(patterns) <= 98


def test_the_tree_leaves_a_quarter_unit_per_differing_sign_and_reads_it_rounded():
    """Nodes of 0..192 differing signs: ``h/4`` at every root, read ``floor(h/4 + 1/2)``."""
    rng = np.random.default_rng(4)
    frame = rng.integers(0, 256, (256, 256), dtype=np.uint8)
    live = haar_plane(lowres_image(frame, 16))
    used = np.flatnonzero(~_unused())
    nodes = np.repeat(live[None], 193, axis=0).reshape(193, -1)
    for h in range(193):  # node h differs from the live place in its first h signs
        nodes[h, used[:h]] ^= 1
    nodes = nodes.reshape(193, 16, 16)
    topomap = TopoMap("haar", pack_plane(nodes))
    params = FilterParams.create("haar", arithmetic="ppa8", motion="always_forward")
    pipe = make_pipeline("haar", 193, params)
    upload_map(pipe, topomap)
    pipe.capture(frame)
    pipe.places.prepare_live()
    h = hamming_words(haar_descriptor(frame), topomap.descriptors)
    assert h.tolist() == list(range(193))
    values = node_values(pipe.sensor, pipe.places)
    np.testing.assert_array_equal(values, np.floor(np.arange(193) / 4 + 0.5))
    # the last tile's roots hold h/4 unrounded: the update reads them as they are
    roots = pipe.sim.read(pipe.sensor.roles.spare)[::16, ::16].reshape(-1)
    tile_nodes, br, bc = pipe.sensor.tile_nodes[0]
    np.testing.assert_array_equal(roots[br * 16 + bc], np.arange(193)[tile_nodes] / 4)


def _unused() -> np.ndarray:
    mask = np.zeros((16, 16), bool)
    mask[1::2, 1::2] = True
    return mask


def test_mapping_on_the_sensor_gives_the_host_nodes():
    assert_maps_as_the_host("haar", (6, 8))


def test_estimates_equal_the_host_ppa8_filter_with_image_motion(blocky_route):
    a, b, sensor = agree("haar", blocky_route(8, 11, STOP_AND_SKIP), 8, motion="image")
    assert_same_estimates(a, b)
    assert not all(e.moved for e in b[1:])  # the stop was seen
    assert sensor.pipeline.tiles == 1 and sensor.pipeline.store == "digital"


def test_two_tiles_and_a_bank_of_sensors_equal_the_host(blocky_route):
    """A tile holds 256 nodes: 260 take both digital tiles of one sensor, or a bank of
    three sensors of 100; the query crosses from tile 0 to tile 1."""
    ref, query = blocky_route(260, 12, [248, 249, 250, 250, 252, 253, 254, 255, 256, 258])
    topomap = build_topomap(ref, "haar")
    kw = {"motion": "always_forward", "record_weights": True}
    host = WeightedNodeLocaliser("haar", arithmetic="ppa8", **kw)
    host.use_map(topomap)
    want = host.localise(query)
    for sensor_kw, tiles in (({}, 2), ({"sensor_nodes": 100}, None)):
        sensor = OnSensorLocaliser("haar", **kw, **sensor_kw)
        sensor.use_map(topomap)
        assert_same_estimates(want, sensor.localise(query))
        if tiles:
            assert sensor.pipeline.tiles == tiles
        else:
            assert isinstance(sensor.pipeline, SensorBank)
            assert sensor.pipeline.offsets == [0, 100, 200]
    assert {e.node for e in want} & {255, 256}  # the estimate crossed the tiles


def test_the_place_and_the_method_are_registered():
    loc = make_localiser("onsensor-haar")
    assert isinstance(loc, OnSensorLocaliser) and loc.name == "onsensor-haar"
    assert HaarPlaces.grid == 16 and HaarPlaces.stores == {"digital": 2}


def test_the_paper_preset_is_refused_in_one_line():
    with pytest.raises(
        PpalocError, match=r"^preset='paper' does not run on the haar place, which the paper"
    ):
        OnSensorLocaliser("haar", preset="paper")


def test_under_typical_noise_the_signs_are_seeded_and_still_localise(blocky_route):
    """A noisy sensor maps and localises with the same bytes for the same seed, and the
    signs, read from codes whose noise is a fraction of a grey level, still find the
    places of a query that starts in the middle of the route."""
    order = [3, 4, 5, 6, 7]
    ref, query = blocky_route(8, 15, order)
    runs = []
    for _ in range(2):
        loc = OnSensorLocaliser("haar", noise="typical", seed=3, motion="always_forward")
        loc.build_map(ref)
        runs.append([(e.node, e.score) for e in loc.localise(query)])
    assert runs[0] == runs[1]
    assert sum(node == want for want, (node, _) in zip(order, runs[0], strict=True)) >= 4
