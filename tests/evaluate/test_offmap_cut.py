"""``benchmarks/eval_offmap.py``'s cut routes: the ground truth follows the cut reference."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from ppaloc.datasets.frames import FrameSequence
from ppaloc.datasets.registry import load_dataset
from ppaloc.errors import PpalocError

SPEC = "synthetic:?places=30&seed=3&speed_var=0.2"


@pytest.fixture(scope="module")
def offmap(bench_script):
    return bench_script("eval_offmap")


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


def test_a_query_with_no_match_anywhere_is_not_off_the_map(offmap, monkeypatch):
    """Only a query that had a match, all of it cut, is off the map: one with none at
    all (the dataset's own unmatched frames) is not counted as leaving it."""
    frames = FrameSequence(lambda i: np.full((32, 64), 10 * i, np.uint8), range(10))
    truth = [np.array([i]) for i in range(10)]
    truth[3] = truth[7] = np.array([], np.int64)
    fake = SimpleNamespace(reference=frames, query=frames, ground_truth=truth)
    monkeypatch.setattr(offmap, "load_dataset", lambda spec: fake)
    reference, _, cut, off = offmap.cut_route("fake", 2 / 3, (0.4, 0.6))
    assert len(reference) == 8
    assert np.flatnonzero(off).tolist() == [4, 5]  # 3 and 7 never had a match
    assert [c.tolist() for c in cut[6:9]] == [[4], [], [6]]
    with pytest.raises(PpalocError, match="no stretch"):
        offmap.cut_route("fake", 2 / 3, (0.41, 0.44))
