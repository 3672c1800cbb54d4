"""The robust filter on the baselines' own place, SeqSLAM's patch-normalised 64x32 image
(``representation="patch"``: host, float only)."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.localise import WeightedNodeLocaliser
from ppaloc.localise.host import HostExecutor, read_values
from ppaloc.localise.likelihood import PATCH_UNITS, NodeDistances, distance_scale
from ppaloc.localise.params import FilterParams
from ppaloc.place import mean_abs_diff, patch_image
from ppaloc.topomap import TopoMap, build_topomap


def _frames(n: int, seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (n, 256, 256), dtype=np.uint8)


def test_a_node_is_its_image_and_mu_is_64_units_a_deviation():
    frames = _frames(3, 0)
    m = build_topomap(list(frames), "patch")
    assert m.descriptors.dtype == np.float32 and m.descriptors.shape == (3, 32, 64)
    np.testing.assert_array_equal(m.descriptors[1], patch_image(frames[1]))
    assert m.layout is None  # no PE layout: no register holds it
    got = NodeDistances("patch", m.descriptors, exact=False)(frames[1])
    want = PATCH_UNITS * mean_abs_diff(patch_image(frames[1]), m.descriptors)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    assert got[1] == 0.0 and got[0] > 60  # an unrelated image: about 2/sqrt(pi) deviations
    # the readout is mu itself; the likelihood scale only the shift
    np.testing.assert_array_equal(read_values("patch", got, False), got)
    assert distance_scale("patch", 3, False) == 1 / 8


def test_the_patch_place_has_no_register_arithmetic_and_no_paper_preset():
    with pytest.raises(PpalocError, match=r"ppa8.*patch place.*arithmetic='float'"):
        FilterParams.create("patch", arithmetic="ppa8")
    with pytest.raises(PpalocError, match=r"paper.*patch"):
        FilterParams.create("patch", preset="paper")
    with pytest.raises(PpalocError, match="no register arithmetic"):
        NodeDistances("patch", np.zeros((1, 32, 64), np.float32), exact=True)


def test_the_scale_is_read_from_the_floats_so_a_power_of_two_in_the_units_changes_nothing(
    monkeypatch,
):
    import ppaloc.localise.likelihood as likelihood
    from ppaloc.datasets.registry import load_dataset
    from ppaloc.frontend import to_sensor

    assert not HostExecutor("patch", FilterParams.create("patch")).integer_readout
    ds = load_dataset("synthetic:?places=40&query=dusk&seed=2&speed_var=0.65")
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]

    def run(units: float) -> list[tuple[int, float]]:
        monkeypatch.setattr(likelihood, "PATCH_UNITS", units)
        loc = WeightedNodeLocaliser("patch")
        loc.build_map(ref)
        return [(e.node, e.score) for e in loc.localise(query)]

    # the frame's shift is a power of two chosen from the frame's own spread: the filter
    # sees the same scaled likelihood at 64 and 256 units a deviation, to the last bit
    assert run(64.0) == run(256.0)


def test_the_filter_follows_a_route_on_the_patch_place_and_its_map_reloads(tmp_path):
    from ppaloc.datasets.registry import load_dataset
    from ppaloc.evaluate.metrics import is_correct
    from ppaloc.frontend import to_sensor

    ds = load_dataset("synthetic:?places=60&query=autumn&seed=1")
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]
    loc = WeightedNodeLocaliser("patch")
    built = loc.build_map(ref)
    nodes = np.array([built.frame_index[e.node] for e in loc.localise(query)])
    assert is_correct(nodes, ds.ground_truth).mean() > 0.9  # 0.99 (16x16 images: 1.00)
    again = WeightedNodeLocaliser("patch")
    again.use_map(TopoMap.load(built.save(tmp_path / "patch.npz")))
    assert [e.node for e in again.localise(query)] == [
        built.frame_index.tolist().index(n) for n in nodes
    ]
    with pytest.raises(PpalocError, match="holds 'patch' nodes"):
        WeightedNodeLocaliser("lowres").use_map(built)


def test_the_sensor_refuses_the_patch_place_in_one_line():
    from ppaloc.onsensor import OnSensorLocaliser

    with pytest.raises(PpalocError, match="host only: no register holds its values"):
        OnSensorLocaliser("patch")
