"""``benchmarks/eval_offmap.py``'s cut routes: the ground truth follows the cut reference."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from ppaloc.datasets.registry import load_dataset

BENCHMARKS = Path(__file__).resolve().parents[2] / "benchmarks"
SPEC = "synthetic:?places=30&seed=3&speed_var=0.2"


@pytest.fixture(scope="module")
def offmap():
    sys.path.insert(0, str(BENCHMARKS))
    try:
        import eval_offmap
    finally:
        sys.path.remove(str(BENCHMARKS))
    return eval_offmap


@pytest.mark.parametrize("gap", [None, (0.4, 0.55)])
def test_a_cut_reference_keeps_every_true_match_it_still_holds(offmap, gap):
    """Each query's accepted frames are the original ones the cut kept, renumbered as
    the cut reference's frames (the same pictures); the off-map queries are exactly
    those whose accepted frames were all cut."""
    ds = load_dataset(SPEC)
    reference, query, truth, off = offmap.cut_route(SPEC, 2 / 3, gap)
    n = len(ds.reference)
    kept = np.ones(n, bool)
    if gap is None:
        kept[round(2 / 3 * n) :] = False
    else:
        kept[round(gap[0] * n) : round(gap[1] * n)] = False
    original = np.flatnonzero(kept)  # the cut reference's frame i is original[i]
    assert len(reference) == len(original) and len(query) == len(ds.query)
    frames = list(ds.reference)
    for i in (0, len(original) // 2, len(original) - 1):
        np.testing.assert_array_equal(reference[i], offmap.to_sensor(frames[original[i]]))
    for g, cut, is_off in zip(ds.ground_truth, truth, off, strict=True):
        assert sorted(original[cut].tolist()) == sorted(r for r in g if kept[r])
        assert is_off == (len(g) > 0 and not kept[list(g)].any())
    assert off.any() and not off.all()
