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
