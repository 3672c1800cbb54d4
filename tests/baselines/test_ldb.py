"""The LDB-style global descriptor and the Hamming distance by popcount."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.baselines.ldb import (
    cell_features,
    comparison_count,
    hamming_distances,
    ldb_comparisons,
    naive_hamming,
    selected_bits,
)
from ppaloc.errors import PpalocError

# A 4x4 image; the 2x2 grid has cells of 2x2 pixels:
#   cell 0 = [[1, 2], [3, 4]]   cell 1 = [[9, 0], [0, 0]]
#   cell 2 = [[5, 5], [5, 5]]   cell 3 = [[0, 0], [8, 8]]
TINY = np.array(
    [
        [1, 2, 9, 0],
        [3, 4, 0, 0],
        [5, 5, 0, 0],
        [5, 5, 8, 8],
    ]
)


def test_cell_features_golden() -> None:
    # (mean, right - left, bottom - top) per cell, row-major.
    expected = [
        [2.5, 1.0, 2.0],
        [2.25, -4.5, -4.5],
        [5.0, 0.0, 0.0],
        [4.0, 0.0, 8.0],
    ]
    np.testing.assert_allclose(cell_features(TINY, 2), expected)


def test_comparisons_golden() -> None:
    # Pairs (0,1) (0,2) (0,3) (1,2) (1,3) (2,3); per pair the bits I>, dx>, dy>.
    expected = [
        1, 1, 1,  # 2.5>2.25, 1>-4.5, 2>-4.5
        0, 1, 1,  # 2.5>5 no, 1>0, 2>0
        0, 1, 0,  # 2.5>4 no, 1>0, 2>8 no
        0, 0, 0,  # 2.25>5, -4.5>0, -4.5>0: no
        0, 0, 0,  # 2.25>4, -4.5>0, -4.5>8: no
        1, 0, 0,  # 5>4, 0>0 no (strict), 0>8 no
    ]  # fmt: skip
    np.testing.assert_array_equal(ldb_comparisons(TINY, (2,)).astype(int), expected)


def test_uneven_cells_use_floor_edges() -> None:
    # 5 columns in 2 cells: edges 0, 2, 5; the right cell is 3 wide (halves 1 and 2).
    image = np.array([[0, 0, 1, 2, 3]] * 4)
    f = cell_features(image, 2)
    np.testing.assert_allclose(f[1], [2.0, 1.5, 0.0])


def test_comparison_count_of_ldb_levels() -> None:
    assert comparison_count((2, 3, 4, 5)) == 1386
    image = np.random.default_rng(0).integers(0, 256, (64, 64))
    assert ldb_comparisons(image).shape == (1386,)


def test_selected_bits_are_fixed_sorted_and_seeded() -> None:
    a = selected_bits(1386, 256, 0)
    np.testing.assert_array_equal(a, selected_bits(1386, 256, 0))
    assert len(np.unique(a)) == 256 and np.all(np.diff(a) > 0)
    assert not np.array_equal(a, selected_bits(1386, 256, 1))
    np.testing.assert_array_equal(selected_bits(1386, None, 0), np.arange(1386))
    with pytest.raises(PpalocError, match="n_bits=2000 must be between 1 and the 1386"):
        selected_bits(1386, 2000, 0)


def test_selected_bits_cannot_be_changed_through_the_cache() -> None:
    # The subset is cached per (total, n_bits, seed); a caller writing into the returned
    # array must not change what every later ABLEM gets.
    a = selected_bits(1386, 300, 7)
    with pytest.raises(ValueError, match="read-only"):
        a[0] = 5
    assert not np.shares_memory(selected_bits(1386, None, 0), selected_bits(1386, None, 0))


def test_hamming_counts_bits_not_byte_values() -> None:
    q = np.array([0b1000_0000, 0b0000_0011], np.uint8)
    codes = np.array([[0, 0], [0b1000_0000, 0b0000_0011], [0xFF, 0xFF]], np.uint8)
    np.testing.assert_array_equal(hamming_distances(q, codes), [3, 0, 13])
    # The summed-XOR-bytes "distance" would give 128 + 3 = 131 for the first code.
    assert int(np.bitwise_xor(q, codes[0]).astype(int).sum()) == 131


@settings(max_examples=50, deadline=None)
@given(
    arrays(np.uint8, st.integers(1, 40)).flatmap(
        lambda q: st.tuples(st.just(q), arrays(np.uint8, (3, len(q))))
    )
)
def test_hamming_equals_naive_bit_count(pair: tuple[np.ndarray, np.ndarray]) -> None:
    q, codes = pair
    expected = [naive_hamming(q, c) for c in codes]
    np.testing.assert_array_equal(hamming_distances(q, codes), expected)


def test_grid_too_fine_for_image_is_a_user_error() -> None:
    with pytest.raises(PpalocError, match=r"5x5 cells needs an image of at least 10 pixels"):
        cell_features(np.zeros((8, 8)), 5)
