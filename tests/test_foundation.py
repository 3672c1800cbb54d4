"""The interfaces that tie the layers."""

import numpy as np
import pytest

from ppaloc.datasets import RouteDataset, to_grey, to_sensor
from ppaloc.errors import PpalocError
from ppaloc.localise import Estimate
from ppaloc.methods import make_localiser
from ppaloc.seeds import SEED_MAX
from ppaloc.topomap import TopoMap


@pytest.mark.parametrize("shape", [(32, 64), (540, 960), (256, 256), (360, 640, 3), (7, 5, 4)])
def test_to_sensor_shape_and_dtype(shape):
    frame = np.random.default_rng(0).integers(0, 256, shape, dtype=np.uint8)
    out = to_sensor(frame)
    assert out.shape == (256, 256)
    assert out.dtype == np.uint8


def test_to_sensor_keeps_constant_image_constant():
    assert np.all(to_sensor(np.full((32, 64), 77, np.uint8)) == 77)


def test_to_grey_uses_601_luma():
    rgb = np.zeros((1, 3, 3), np.uint8)
    rgb[0, 0, 0] = rgb[0, 1, 1] = rgb[0, 2, 2] = 200
    assert to_grey(rgb).tolist() == [[60, 117, 23]]


def test_to_sensor_top_left_stays_top_left():
    frame = np.zeros((32, 64), np.uint8)
    frame[:16, :32] = 255
    out = to_sensor(frame)
    assert out[10, 10] == 255 and out[200, 200] == 0 and out[10, 200] == 0


def test_estimate_and_topomap_basics():
    est = Estimate(node=3, score=0.5)
    assert est.moved is None and est.ranking is None
    m = TopoMap("lbp", np.arange(5, dtype=np.uint32))
    assert len(m) == 5 and m.frame_index.tolist() == [0, 1, 2, 3, 4]


def test_route_dataset_checks_ground_truth_length():
    with pytest.raises(ValueError, match="ground truth has 1 rows for 2 queries"):
        RouteDataset("x", [np.zeros((2, 2))], [np.zeros((2, 2))] * 2, [np.array([0])])
    # the speed check and the motion agreement read one entry per query frame
    with pytest.raises(ValueError, match="query_moved has 3 entries for 2 queries"):
        gt = [np.array([0])] * 2
        RouteDataset("x", [np.zeros((2, 2))], [np.zeros((2, 2))] * 2, gt, query_moved=[1] * 3)


def test_unknown_method_names_choices():
    with pytest.raises(PpalocError, match="unknown method 'nope'"):
        make_localiser("nope")


def test_unknown_method_parameter_names_the_accepted_ones():
    with pytest.raises(
        PpalocError,
        match=r"method 'single-frame': unknown parameter 'nope'; its parameters: size, patch, ",
    ):
        make_localiser("single-frame", nope=1)


@pytest.mark.parametrize(
    ("method", "key"),
    [("particle-filter", "seed"), ("able-m", "bit_seed"), ("onsensor-lowres", "seed")],
)
def test_every_method_seed_takes_the_one_seed_range(method, key):
    make_localiser(method, **{key: SEED_MAX})
    with pytest.raises(PpalocError, match=f"{key}={SEED_MAX + 1} must be in \\[0, {SEED_MAX}\\]"):
        make_localiser(method, **{key: SEED_MAX + 1})


def test_the_generator_the_configuration_and_cpp_take_the_one_seed_range():
    from ppaloc.cpp import command
    from ppaloc.datasets.registry import parse_dataset_spec
    from ppaloc.errors import DatasetSpecError
    from ppaloc.evaluate.config import LIMITS

    parse_dataset_spec(f"synthetic:?seed={SEED_MAX}")
    with pytest.raises(DatasetSpecError, match=f"in \\[0, {SEED_MAX}\\]"):
        parse_dataset_spec(f"synthetic:?seed={SEED_MAX + 1}")
    assert LIMITS["seed"] == (0, SEED_MAX)
    assert command.SEED_MAX is SEED_MAX
