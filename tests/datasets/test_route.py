"""The common keys (start, stop, step, tolerance), applied in one place for every layout."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.datasets.frames import RenderedFrames
from ppaloc.datasets.route import RawRoute, assemble, moved_from_places
from ppaloc.errors import DataError


def _raw(n_ref: int, places=None, accepted=None) -> RawRoute:
    n_q = len(places) if places is not None else len(accepted)
    return RawRoute(
        name="t",
        reference=RenderedFrames(lambda i: np.full((1, 1), i, np.uint8), n_ref),
        query=RenderedFrames(lambda i: np.full((1, 1), i, np.uint8), n_q),
        default_tolerance=1,
        query_place=None if places is None else np.asarray(places, float),
        accepted=accepted,
        motion_known=places is not None,
    )


@settings(max_examples=200, deadline=None)
@given(
    st.integers(5, 60),
    st.one_of(st.none(), st.integers(0, 30)),
    st.one_of(st.none(), st.integers(1, 70)),
    st.integers(1, 5),
    st.integers(0, 3),
)
def test_synchronised_selection_keeps_pairs(n, start, stop, step, tol):
    if start is not None and stop is not None and stop <= start:
        stop = start + 1
    options = {"start": start, "stop": stop, "step": step, "tolerance": tol}
    kept = np.arange(n)[slice(start, stop, step)]
    if kept.size == 0:
        with pytest.raises(DataError, match="keeps none of the"):
            assemble(_raw(n, places=np.arange(n)), options)
        return
    ds = assemble(_raw(n, places=np.arange(n)), options)
    assert [int(f[0, 0]) for f in ds.reference] == kept.tolist()
    assert [int(f[0, 0]) for f in ds.query] == kept.tolist()
    for j, g in enumerate(ds.ground_truth):
        assert g.tolist() == list(range(max(j - tol, 0), min(j + tol, len(kept) - 1) + 1))


def test_explicit_sets_are_remapped_then_dilated():
    raw = _raw(10, accepted=[np.array([0]), np.array([3, 4]), np.array([9]), np.array([], int)])
    ds = assemble(raw, {"start": None, "stop": None, "step": 2, "tolerance": 0})
    # References 0, 2, 4, 6, 8 kept; queries 0 and 2 kept.
    assert [g.tolist() for g in ds.ground_truth] == [[0], []]
    ds = assemble(raw, {"start": 1, "stop": None, "step": 1, "tolerance": 1})
    assert [g.tolist() for g in ds.ground_truth] == [[1, 2, 3, 4], [7, 8], []]


def test_moved_from_places_golden():
    assert moved_from_places(np.array([0, 0.2, 0.5, 0.5, 2.4, 2.6])).tolist() == [
        False, False, True, False, True, True
    ]  # fmt: skip
