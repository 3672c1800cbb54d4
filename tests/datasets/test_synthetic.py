"""The procedural route generator: determinism, ground truth, motion and appearance."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.datasets import load_dataset, make_synthetic
from ppaloc.datasets.synthetic.conditions import CONDITIONS, Condition, M
from ppaloc.datasets.synthetic.motion import variable_speed_positions
from ppaloc.datasets.synthetic.render import LANE_CENTRE, Renderer
from ppaloc.datasets.synthetic.world import make_world
from ppaloc.errors import DataError


def test_same_seed_same_bytes_any_access_order():
    a = load_dataset("synthetic:?places=40&query=winter&seed=5&size=96")
    b = load_dataset("synthetic:?places=40&query=winter&seed=5&size=96")
    assert len(a.query) == len(b.query)
    for i in (7, 3, len(a.query) - 1, 0):  # b is read in a different order
        assert a.query[i].tobytes() == b.query[len(b.query) - 1 - (len(b.query) - 1 - i)].tobytes()
    assert a.reference[12].tobytes() == b.reference[12].tobytes()
    assert np.array_equal(a.query_positions, b.query_positions)
    other = load_dataset("synthetic:?places=40&query=winter&seed=6&size=96")
    assert a.reference[12].tobytes() != other.reference[12].tobytes()


def test_frames_are_grey_uint8_with_detail():
    ds = make_synthetic(places=20, query="night", seed=1, sync=True, size=128)
    for frame in (ds.reference[3], ds.query[3]):
        assert frame.shape == (128, 128) and frame.dtype == np.uint8
        assert frame.std() > 10  # not a flat image
    assert ds.reference[3].mean() > ds.query[3].mean() + 30  # night is darker


def test_sync_ground_truth_and_positions():
    ds = make_synthetic(places=30, seed=2, sync=True, size=32, tolerance=2, spacing=5.0)
    assert len(ds.query) == 30
    assert ds.ground_truth[0].tolist() == [0, 1, 2]
    assert ds.ground_truth[10].tolist() == [8, 9, 10, 11, 12]
    assert np.allclose(ds.reference_positions[:, 0], np.arange(30) * 5.0)
    assert np.allclose(ds.query_positions[:, 0], ds.reference_positions[:, 0])
    assert ds.query_moved.tolist() == [False] + [True] * 29


def test_variable_speed_query_stops_and_moved_flags():
    ds = make_synthetic(places=300, seed=3, stops=3, size=32, tolerance=0)
    s = ds.query_positions[:, 0]
    assert np.all(np.diff(s) >= 0) and s[0] == 0 and s[-1] == pytest.approx(299 * 4.0)
    assert len(ds.query) != 300
    stopped = np.flatnonzero(np.diff(s) == 0)
    assert stopped.size >= 3 * 6  # three stops of at least 6 frames
    nearest = np.floor(s / 4.0 + 0.5).astype(int)
    assert ds.query_moved.tolist() == [False, *(np.diff(nearest) > 0).tolist()]
    assert all(g.tolist() == [n] for g, n in zip(ds.ground_truth, nearest, strict=True))


def test_motion_profile_speeds():
    # default: cruising within +-20% of the mapping speed, averaging it
    for seed in range(3):
        s = variable_speed_positions(end=8000.0, spacing=4.0, speed=1.0, stops=0, seed=seed)
        v = np.diff(s) / 4.0
        assert 0.8 - 1e-9 <= v[10:-5].min() and v.max() <= 1.2 + 1e-9
        assert 0.97 < v[10:-5].mean() < 1.03
    # the wide profile reaches well below and above
    s = variable_speed_positions(8000.0, 4.0, 1.0, 0, seed=0, speed_var=0.65)
    v = np.diff(s)[10:-5] / 4.0
    assert 0.3 < v.min() < 0.6 and 1.4 < v.max() < 1.7 and 0.95 < v.mean() < 1.05


def test_speed_var_spec_key_and_bad_value():
    narrow = load_dataset("synthetic:?places=200&size=16&seed=2")
    wide = load_dataset("synthetic:?places=200&size=16&seed=2&speed_var=0.65")
    v_n = np.diff(narrow.query_positions[:, 0]) / 4.0
    v_w = np.diff(wide.query_positions[:, 0]) / 4.0
    assert v_n.max() <= 1.2 + 1e-9 < v_w.max()
    with pytest.raises(DataError, match=r"speed_var=1.5.*must be in \[0, 0.9\]"):
        make_synthetic(places=20, size=16, speed_var=1.5)


def test_stops_brake_wait_and_resume():
    s = variable_speed_positions(end=800.0, spacing=4.0, speed=1.0, stops=2, seed=5)
    v = np.diff(s) / 4.0
    waiting = np.flatnonzero(v == 0)
    runs = np.split(waiting, np.flatnonzero(np.diff(waiting) > 1) + 1)
    assert len(runs) == 2 and all(6 <= len(r) <= 24 for r in runs)
    for r in runs:  # slowing into the stop, then speeding up again
        assert v[r[0] - 1] < 0.5 and v[r[-1] + 1] < 0.2


def test_extra_places_have_no_true_match():
    ds = make_synthetic(places=20, seed=1, sync=True, extra=5, size=32, tolerance=1)
    assert len(ds.query) == 25
    assert ds.ground_truth[19].tolist() == [18, 19]
    assert ds.ground_truth[20].tolist() == [19]  # within tolerance of the last place
    assert [g.size for g in ds.ground_truth[21:]] == [0, 0, 0, 0]


def test_selection_keeps_places_and_nearest_queries():
    ds = load_dataset("synthetic:?places=60&sync=1&size=32&start=10&stop=40&step=3&tolerance=0")
    assert len(ds.reference) == 10 and len(ds.query) == 10
    assert np.allclose(ds.reference_positions[:, 0], np.arange(10, 40, 3) * 4.0)
    assert [g.tolist() for g in ds.ground_truth] == [[k] for k in range(10)]


def test_same_position_same_condition_same_image_whatever_the_speed():
    world = make_world(200.0, seed=4)
    quiet = Condition("quiet", noise_sigma=0.0)
    r1 = Renderer(world, quiet, 64, seed=0)
    r2 = Renderer(world, quiet, 64, seed=0)
    a = r1.render(80.0, LANE_CENTRE, key=(0, 20))
    b = r2.render(80.0, LANE_CENTRE, key=(1, 999))  # another frame index, another traversal
    assert np.array_equal(a, b)
    assert not np.array_equal(a, r1.render(84.0, LANE_CENTRE, key=(0, 21)))


def test_forward_motion_flows_outwards():
    # Geometry only: a roadside object's image moves away from the vanishing point
    # and grows as the camera approaches it.
    world = make_world(400.0, seed=8)
    r = Renderer(world, CONDITIONS["summer"], 128)
    s0 = float(world.sprites.s[np.searchsorted(world.sprites.s, 120.0)])
    cols = []
    for d in (40.0, 30.0, 20.0):
        _mat, _, depth = r.geometry(s0 - d, LANE_CENTRE)
        hit = np.isclose(depth, d, atol=1e-3)
        assert hit.any()
        cols.append(np.abs(np.flatnonzero(hit.any(axis=0)) + 0.5 - r.cx).mean())
    assert cols[0] < cols[1] < cols[2]


def test_conditions_change_appearance_not_geometry():
    world = make_world(200.0, seed=9)
    frames = {n: Renderer(world, c, 64).render(60.0, LANE_CENTRE) for n, c in CONDITIONS.items()}
    assert {"summer", "autumn", "winter", "night"} <= set(frames)
    means = {n: float(f.mean()) for n, f in frames.items()}
    assert means["night"] < 0.65 * means["summer"]
    assert means["winter"] > means["summer"]  # snow
    geo = {n: Renderer(world, c, 64).geometry(60.0, LANE_CENTRE) for n, c in CONDITIONS.items()}
    # Summer and night trees are in leaf: identical geometry. Winter trees are bare and
    # conifers carry snow: the scene differs only where summer shows leaves or needles.
    assert np.array_equal(geo["summer"][0], geo["night"][0])
    assert np.array_equal(geo["summer"][2], geo["night"][2])
    leaves = np.isin(geo["summer"][0], [M["leaves0"], M["leaves1"], M["conifer"]])
    assert leaves.any()
    assert np.array_equal(geo["summer"][0][~leaves], geo["winter"][0][~leaves])


def test_bad_generator_arguments():
    with pytest.raises(DataError, match="unknown condition 'spring'"):
        make_synthetic(places=10, query="spring")
    with pytest.raises(DataError, match="places=1"):
        make_synthetic(places=1)


def test_ground_depth_follows_the_pinhole_model():
    # Camera 1.6 m high, f = 0.6 * 100 = 60 px, horizon at row 47: the bottom row's centre
    # (y = 99.5) sees the road at 60 * 1.6 / (99.5 - 47) = 1.8286 m.
    r = Renderer(make_world(100.0, seed=1), CONDITIONS["summer"], 100)
    mat, _, depth = r.geometry(10.0, LANE_CENTRE)
    assert depth[99, 50] == pytest.approx(60 * 1.6 / 52.5, rel=1e-6)
    assert depth[60, 50] == pytest.approx(60 * 1.6 / 13.5, rel=1e-6)
    assert mat[99, 50] == M["road"] and mat[0, 50] == M["sky"]
    assert np.isinf(depth[0, 50])


def test_figures_are_written(tmp_path):
    from PIL import Image

    from ppaloc.datasets.synthetic import conditions_montage, sequence_strip

    path = conditions_montage(tmp_path / "fig" / "m.png", size=48)
    with Image.open(path) as im:  # 5 tiles and a label margin across, one row per condition
        assert im.size == (5 * 48 + 90, len(CONDITIONS) * 48 + 26)
    path = sequence_strip(tmp_path / "s.png", "synthetic:?places=120&seed=2&size=40", frames=4)
    with Image.open(path) as im:
        assert im.size == (4 * 40, 40 + 24)
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["fig", "m.png", "s.png"]  # no temp


def test_datasets_pickle_and_render_the_same_frames():
    import pickle

    ds = load_dataset("synthetic:?places=20&seed=3&size=32")
    again = pickle.loads(pickle.dumps(ds))
    assert again.query[5].tobytes() == ds.query[5].tobytes()
    assert [g.tolist() for g in again.ground_truth] == [g.tolist() for g in ds.ground_truth]


def test_sync_with_stops_moves_one_place_per_frame_or_stays():
    ds = make_synthetic(places=40, seed=3, sync=True, stops=2, size=32, tolerance=0)
    steps = np.diff(ds.query_positions[:, 0]) / 4.0
    assert set(np.round(steps, 9).tolist()) == {0.0, 1.0}
    assert 40 + 12 <= len(ds.query) <= 40 + 48
    assert ds.query_moved[1:].tolist() == (steps > 0).tolist()
    assert [g.tolist() for g in ds.ground_truth[:1]] == [[0]]


def test_sync_without_stops_is_one_frame_per_place():
    ds = make_synthetic(places=25, seed=3, sync=True, size=32)
    assert len(ds.query) == 25
