"""The map handling every baseline shares (MapLocaliser / ImageLocaliser)."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.baselines import ABLEM, ParticleFilter, SeqSLAM, SingleFrame
from ppaloc.errors import PpalocError
from ppaloc.topomap import TopoMap

ALL = [SeqSLAM, ABLEM, ParticleFilter, SingleFrame]


@pytest.mark.parametrize("cls", ALL)
def test_reset_repeats_the_run_and_use_map_matches_build_map(cls, toy_route) -> None:
    ref, query = toy_route
    a = cls()
    m = a.build_map(ref[:20])
    assert m.kind == cls.kind and m.descriptors.shape[1:] == a.descriptor_shape
    first = [a.step(f).node for f in query[:8]]
    a.reset()
    assert [a.step(f).node for f in query[:8]] == first
    b = cls()
    b.use_map(m)
    assert [b.step(f).node for f in query[:8]] == first


@pytest.mark.parametrize("cls", ALL)
def test_map_refusals_name_the_fix(cls, toy_route) -> None:
    _, query = toy_route
    loc = cls()
    with pytest.raises(PpalocError, match="no map yet; call build_map"):
        loc.step(query[0])
    with pytest.raises(PpalocError, match="reference traversal is empty"):
        loc.build_map([])
    other = TopoMap("lowres", np.zeros((3, 8, 8), np.uint8))
    with pytest.raises(PpalocError, match=f"needs kind '{cls.kind}'"):
        loc.use_map(other)


@pytest.mark.parametrize("cls", [SeqSLAM, ParticleFilter, SingleFrame])
def test_image_maps_from_other_sizes_are_refused(cls, toy_route) -> None:
    ref, _ = toy_route
    m = cls(size=(16, 32)).build_map(ref[:4])
    with pytest.raises(PpalocError, match=r"shape \(16, 32\) but these parameters give \(32, 64\)"):
        cls().use_map(m)


def test_difference_column_is_the_mean_absolute_difference(toy_route) -> None:
    ref, query = toy_route
    s = SingleFrame()
    s.build_map(ref[:5])
    q = s.describe(query[0]).astype(np.float64)
    expected = [np.mean(np.abs(s.map.descriptors[i].astype(np.float64) - q)) for i in range(5)]
    np.testing.assert_allclose(s.difference_column(query[0]), expected, rtol=1e-6)


@pytest.mark.parametrize(
    ("method", "param", "message"),
    [
        ("seqslam", {"patch": 7}, "SeqSLAM: patch=7 must divide both sides of size=(32, 64) (e.g."),
        ("single-frame", {"size": [1, 1]}, "SingleFrame: patch=8 must divide both sides of size="),
        ("particle-filter", {"size": [32, 60]}, "ParticleFilter: size=(32, 60) must be two"),
        ("able-m", {"side": 100}, "ABLE-M: side=100 must divide 256, the sensor frame's side"),
        ("seqslam", {"patch": 1}, "method 'seqslam': patch=1 must be in [2, 256]"),
    ],
)
def test_an_image_the_method_cannot_make_is_refused_before_any_frame(method, param, message):
    # values inside the declared ranges failed only at the first frame, in words about a
    # "downsample size" or a shape the user never gave, and a sweep ran such cells
    from ppaloc.evaluate.sweep_grid import expand, sweep_config_from_mapping, validate
    from ppaloc.methods import check_method

    with pytest.raises(PpalocError) as info:
        check_method(method, param)
    assert message in str(info.value)
    config = sweep_config_from_mapping(
        {
            "methods": [method],
            "datasets": ["synthetic:?places=6"],
            "params": {method: {k: [v, v] for k, v in param.items()}},
        }
    )
    with pytest.raises(PpalocError) as info:  # before any cell runs
        validate(config, expand(config))
    assert message in str(info.value)
    check_method(method, {})  # the defaults make their image
