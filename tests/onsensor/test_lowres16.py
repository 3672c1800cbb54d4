"""The 16x16 low-res place on the sensor: the grid's readout, the host's map and estimates."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams
from ppaloc.methods import make_localiser
from ppaloc.onsensor import OnSensorLocaliser, localiser
from ppaloc.onsensor.bank import SensorBank
from ppaloc.onsensor.capture import block_means, capture
from ppaloc.onsensor.lowres import LOWRES16_ROLES, Lowres16Places, tree_steps
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.place import block_sums, lowres_image, normalise_contrast
from ppaloc.sim import R1, R2, D

from .conftest import STOP_AND_SKIP, agree, assert_maps_as_the_host, assert_same_estimates


def test_the_reduce_stage_reads_the_hosts_16x16_image_exactly(blocky_route):
    """``floor(S / 256)`` per 16x16-pixel block through the ADC, saturating cases too,
    and the 8x8 block roots after it are the exact means of the 32x32 blocks."""
    ref, _ = blocky_route(1, 9)
    noise = np.random.default_rng(9).integers(0, 256, (256, 256), dtype=np.uint8)
    frames = [ref[0], np.zeros((256, 256), np.uint8), np.full((256, 256), 255, np.uint8), noise]
    assert (lowres_image(noise, 16) != np.round(block_sums(noise, 16) / 256)).any()
    params = FilterParams.create("lowres16", arithmetic="ppa8", motion="always_forward")
    pipe = make_pipeline("lowres16", 4, params)
    for frame in frames:
        capture(pipe.sensor, frame)
        codes = block_means(pipe.sensor, None, 16)
        np.testing.assert_array_equal(codes, lowres_image(frame, 16))
        roots = pipe.sim.read(D)[::32, ::32]
        means = frame.reshape(8, 32, 8, 32).mean(axis=(1, 3)) / 2 - 64
        np.testing.assert_array_equal(roots, -means.astype(np.float32))


def test_the_live_grid_is_loaded_normalised_into_every_node_block(blocky_route):
    ref, _ = blocky_route(1, 10)
    params = FilterParams.create("lowres16", arithmetic="ppa8", motion="always_forward")
    pipe = make_pipeline("lowres16", 4, params)
    pipe.capture(ref[0])
    pipe.places.prepare_live()
    want = normalise_contrast(lowres_image(ref[0], 16), params.contrast, 4)  # 4x4-cell tiles
    np.testing.assert_array_equal(pipe.places.live_image, want)
    f = -pipe.sim.read(pipe.sensor.roles.means)
    np.testing.assert_array_equal(f, np.tile(want / 2.0 - 64, (16, 16)).astype(np.float32))


def test_the_tree_halves_over_the_16x16_block_and_the_roles_free_the_class_masks():
    assert tree_steps(16) == (1, 2, 4, 8) and tree_steps(8) == (1, 2, 4)
    assert LOWRES16_ROLES.check().static == (LOWRES16_ROLES.d.valid,)
    assert not {R1, R2} & {reg for _, reg in LOWRES16_ROLES.kept()}
    assert Lowres16Places.CLASS_DONT_CARE == 0xF0 and Lowres16Places.grid == 16


def test_mapping_on_the_sensor_gives_the_host_nodes():
    assert_maps_as_the_host("lowres16", (6, 16, 16))


def test_estimates_equal_the_host_ppa8_filter_with_image_motion(blocky_route):
    a, b, sensor = agree("lowres16", blocky_route(8, 11, STOP_AND_SKIP), 8, motion="image")
    assert_same_estimates(a, b)
    assert not all(e.moved for e in b[1:])  # the stop was seen
    assert sensor.pipeline.tiles == 1 and sensor.pipeline.store == "levels"
    assert b[1].modelled_latency_ms > b[3].modelled_latency_ms > 0  # a stay frame is cheaper


def test_a_bank_of_sensors_equals_the_host(blocky_route):
    a, b, sensor = agree(
        "lowres16",
        blocky_route(8, 12, STOP_AND_SKIP),
        8,
        {"sensor_nodes": 3},
        motion="always_forward",
    )
    assert_same_estimates(a, b)
    assert isinstance(sensor.pipeline, SensorBank) and sensor.pipeline.offsets == [0, 3, 6]
    assert {e.node for e in b} & {2, 3, 5, 6}  # the estimate crossed sensor boundaries


def test_the_analogue_store_agrees_too(blocky_route):
    a, b, sensor = agree(
        "lowres16",
        blocky_route(5, 13, [0, 1, 1, 2, 4]),
        5,
        {"store": "analogue"},
        motion="always_forward",
    )
    assert_same_estimates(a, b)
    assert sensor.pipeline.store == "analogue"


def test_the_difference_figure_draws_the_16x16_grid(blocky_route, tmp_path, monkeypatch):
    from ppaloc.onsensor import figures

    ref, query = blocky_route(3, 14)
    loc = OnSensorLocaliser("lowres16", motion="always_forward")
    loc.build_map(ref)
    drawn = {}
    monkeypatch.setattr(figures, "render_montage", lambda planes, path, scale: drawn.update(planes))
    figures.difference_figure(loc, query[1], tmp_path / "diff.png")
    grid = drawn["replicated 16x16 grid (-F)"]
    want = normalise_contrast(lowres_image(query[1], 16), loc.params.contrast, 4) / 2.0 - 64
    np.testing.assert_array_equal(grid, np.tile(want, (16, 16)).astype(np.float32))


def test_the_method_is_registered():
    loc = make_localiser("onsensor-lowres16")
    assert isinstance(loc, OnSensorLocaliser) and loc.name == "onsensor-lowres16"
    assert loc.params.contrast is not None


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"preset": "paper"},
            r"^preset='paper' does not run on the lowres16 place, which compares "
            r"contrast-normalised images only; use a robust preset, or lowres or lbp$",
        ),
        (
            {"timing_structure": "precursor"},
            r"^timing_structure='precursor' has no structure for 'lowres16' \(the "
            r"precursor's code compares lowres and lbp\); use timing_structure='ppaloc'$",
        ),
    ],
)
def test_what_lowres16_does_not_run_is_refused_in_one_line(kwargs, message):
    with pytest.raises(PpalocError, match=message):
        OnSensorLocaliser("lowres16", **kwargs)


def test_a_host_only_representation_is_still_refused_in_one_line(monkeypatch):
    monkeypatch.setattr(localiser, "SENSOR_REPRESENTATIONS", ("lowres", "lbp"))
    with pytest.raises(
        PpalocError,
        match=r"^representation='lowres16' runs on the host only so far \(weighted-node-"
        r"lowres16\); the sensor runs lowres, lbp \(docs/onsensor.md\)$",
    ):
        OnSensorLocaliser("lowres16")
