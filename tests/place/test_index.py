"""LowresIndex: the blocked layout agrees with the plain SAD and with exact float sums."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.place import LowresIndex, block_sums, sad


@pytest.fixture(scope="module")
def nodes() -> np.ndarray:
    rng = np.random.default_rng(11)
    n = rng.integers(0, 256, (5003, 8, 8), dtype=np.uint8)
    n[0] = 0  # extremes, where a cap binds
    n[1] = 255
    return n


def test_index_sad_equals_sad_for_a_partial_last_block(nodes: np.ndarray) -> None:
    index = LowresIndex(nodes, block=1024)
    assert len(index) == len(nodes) and index.cells == 64
    np.testing.assert_array_equal(index.nodes(), nodes)
    rng = np.random.default_rng(12)
    for _ in range(3):
        q = rng.integers(0, 256, (8, 8), dtype=np.uint8)
        d = index.sad(q)
        assert d.dtype == np.uint16
        np.testing.assert_array_equal(d, sad(q, nodes))
    out = np.empty(len(nodes), np.uint16)
    assert index.sad(q, out=out) is out


@pytest.mark.parametrize("cap", [None, 254, 100, 0])
def test_sad_to_sums_is_the_exact_l1_distance_to_the_block_means(
    nodes: np.ndarray, cap: int | None
) -> None:
    rng = np.random.default_rng(13)
    frame = rng.integers(0, 256, (256, 256), dtype=np.uint8)
    frame[:32, :32] = 255  # block mean 255: |m - 0| = 255 > 254, the ppa8 cap binds
    frame[:32, 32:64] = 0
    frame[0, 32] = 1  # block mean 1/1024: |m - 255| > 254
    s = block_sums(frame)
    exact = np.abs(nodes.astype(np.float64) - s / 1024.0)
    if cap is not None:
        exact = np.minimum(exact, cap)
    expected = exact.sum(axis=(1, 2)) * 1024
    got = LowresIndex(nodes, block=512).sad_to_sums(s, cap=cap)
    assert got.dtype == np.int64
    np.testing.assert_array_equal(got, expected)


def test_index_rejects_mismatched_queries(nodes: np.ndarray) -> None:
    index = LowresIndex(nodes[:10])
    with pytest.raises(ValueError, match=r"the query has shape \(4, 4\), the nodes \(8, 8\)"):
        index.sad(np.zeros((4, 4), np.uint8))
    with pytest.raises(ValueError, match=r"out must have shape \(10,\) and dtype uint16"):
        index.sad(nodes[0], out=np.empty(10, np.int64))
    with pytest.raises(ValueError, match=r"block sums must lie in \[0, 261120\]"):
        index.sad_to_sums(np.full((8, 8), 300_000))


@given(
    arrays(np.uint8, st.tuples(st.integers(1, 40), st.just(8), st.just(8))),
    arrays(np.int64, (8, 8), elements=st.integers(0, 255 * 1024)),
    st.integers(1, 16),
    st.one_of(st.none(), st.integers(0, 255)),
)
def test_index_matches_the_obvious_formula(
    nodes: np.ndarray, sums: np.ndarray, block: int, cap: int | None
) -> None:
    index = LowresIndex(nodes, block=block)
    d = np.abs(sums - 1024 * nodes.astype(np.int64))
    if cap is not None:
        d = np.minimum(d, 1024 * cap)
    np.testing.assert_array_equal(index.sad_to_sums(sums, cap=cap), d.sum(axis=(1, 2)))
    q = (sums // 1024).astype(np.uint8)
    np.testing.assert_array_equal(index.sad(q), sad(q, nodes))
