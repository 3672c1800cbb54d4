"""The real copies in ../shared/data (skipped cleanly when absent)."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.datasets import load_dataset, to_sensor

pytestmark = pytest.mark.data


def test_nordland_summer_winter(nordland_dir):
    ds = load_dataset(f"nordland:{nordland_dir}?ref=summer&query=winter")
    assert len(ds.reference) == len(ds.query) == 1788
    assert ds.reference[100].shape == (32, 64) and ds.reference[100].dtype == np.uint8
    assert ds.ground_truth[100].tolist() == [99, 100, 101]
    assert to_sensor(ds.query[100]).shape == (256, 256)


def test_nordland_drop_dark_keeps_both_synchronised(nordland_dir):
    ds = load_dataset(f"nordland:{nordland_dir}?drop_dark=1&tolerance=0")
    kept = ds.meta["file_index"]
    assert 1600 < len(ds.reference) < 1788 and len(ds.query) == len(ds.reference)
    assert kept[0] >= 3  # the first three frames are blank
    assert min(float(ds.reference[k].mean()) for k in range(0, len(ds.reference), 40)) >= 30
    assert ds.ground_truth[7].tolist() == [7]


def test_gardens_point_index_matches_vprbench_file(gardens_point_dir):
    base = f"gardens-point:{gardens_point_dir}?ref=day_left&query=night_right"
    by_index = load_dataset(base)
    by_file = load_dataset(base + "&gt=vprbench")
    assert len(by_index.query) == len(by_file.query) == 200
    assert by_index.query[0].shape == (360, 640) and by_index.reference[0].shape == (540, 960)
    # VPR-Bench's +-2 rows equal the index ground truth at tolerance 2, ends clipped.
    assert all(
        np.array_equal(a, b)
        for a, b in zip(by_index.ground_truth, by_file.ground_truth, strict=True)
    )


def test_nordland_summer_stops_are_closed_and_tunnels_are_not(nordland_dir):
    ds = load_dataset(f"nordland:{nordland_dir}?ref=summer&query=winter")
    groups = [tuple(g) for g in ds.reference_groups.tolist()]
    rule = ds.meta["ground_truth_rule"]["same_place"]
    assert (rule["rule"], rule["groups"], rule["grouped_frames"]) == ("still-frames", 17, 235)
    # the station stops measured by grey difference (128-177, 221-227, 250-263, 340-363,
    # 506-539, 606-619, 708-724, 777-785) lie inside groups
    for a, b in [(128, 177), (221, 227), (250, 263), (340, 363), (506, 539), (606, 619),
                 (708, 724), (777, 785)]:  # fmt: skip
        assert any(g0 <= a and b < g1 for g0, g1 in groups), (a, b)
    # the blank start and the dark frames (a tunnel at 187-201, 1191-1202) are in none
    for frame in (0, 10, 190, 195, 1195):
        assert not any(g0 <= frame < g1 for g0, g1 in groups)
    # the winter train stood there too (a query group, 128-177): each of its frames
    # accepts what any of them accepts
    assert ds.ground_truth[150].tolist() == list(range(127, 179))
    assert ds.ground_truth[100].tolist() == [99, 100, 101]
    assert (rule["query_groups"], rule["query_grouped_frames"]) == (15, 249)
    assert rule["queries_changed"] == 283
    # it stands at the station of reference frames 505-542 until query frame 545, past the
    # reference's stop: its last still frames accept the station
    assert [505, 546] in ds.query_groups.tolist()  # [first, end)
    assert ds.ground_truth[545].tolist() == list(range(504, 547))


def test_gardens_point_walks_have_no_stops(gardens_point_dir):
    for ref in ("day_left", "day_right", "night_right"):
        ds = load_dataset(
            f"gardens-point:{gardens_point_dir}?ref={ref}"
            f"&query={'day_right' if ref == 'day_left' else 'day_left'}"
        )
        assert ds.reference_groups.shape == (0, 2), ref
        assert ds.meta["ground_truth_rule"]["same_place"]["queries_changed"] == 0
