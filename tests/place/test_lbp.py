"""LBP descriptor, bit packing and Hamming distance: golden values and properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.place import (
    hamming,
    lbp_descriptor,
    lbp_from_grid,
    lbp_grid,
    pack_bits,
    unpack_bits,
)

# A hand-made 6x6 grid. Cells (3x3) and their centres:
#   top-left     rows 0-2, cols 0-2, centre 5     top-right    rows 0-2, cols 3-5, centre 5
#   bottom-left  rows 3-5, cols 0-2, centre 4     bottom-right rows 3-5, cols 3-5, centre 9
GRID = np.array(
    [
        [9, 1, 5, 0, 0, 0],
        [2, 5, 7, 0, 5, 0],
        [5, 3, 6, 0, 0, 0],
        [4, 4, 4, 9, 9, 9],
        [4, 4, 4, 9, 9, 9],
        [4, 4, 4, 9, 9, 8],
    ]
)
# Bits MSB first: TL, T, TR, R, BR, B, BL, L (neighbour >= centre).
# top-left:     9>=5 1 | 1>=5 0 | 5>=5 1 | 7>=5 1 | 6>=5 1 | 3>=5 0 | 5>=5 1 | 2>=5 0
#               -> 1011 1010 = 0xBA
# top-right:    all neighbours 0 < 5 -> 0x00
# bottom-left:  all neighbours equal the centre -> 0xFF
# bottom-right: all 9 >= 9 except the bottom-right neighbour 8 -> 1111 0111 = 0xF7
GOLDEN = 0xBA00FFF7


def blocky(values: np.ndarray) -> np.ndarray:
    return np.kron(values.astype(np.uint8), np.ones((32, 32), np.uint8))


def test_lbp_golden_grid() -> None:
    assert int(lbp_from_grid(GRID)) == GOLDEN


def test_lbp_descriptor_of_a_frame_uses_the_central_six_by_six() -> None:
    values = np.full((8, 8), 200)  # the outer ring must not matter
    values[1:7, 1:7] = GRID * 10
    frame = blocky(values)
    np.testing.assert_array_equal(lbp_grid(frame), GRID * 10.0)
    d = lbp_descriptor(frame)
    assert d.dtype == np.uint32 and d.shape == ()
    assert int(d) == GOLDEN


def test_lbp_compares_exact_means_not_rounded_ones() -> None:
    frame = blocky(np.full((8, 8), 50))
    frame[33, 33] = 49  # block (1, 1), the top-left cell's top-left neighbour, mean 50 - 1/1024
    assert int(lbp_descriptor(frame)) == 0x7FFFFFFF


def test_lbp_descriptor_is_vectorised_over_leading_axes() -> None:
    rng = np.random.default_rng(7)
    frames = rng.integers(0, 256, (2, 3, 256, 256), dtype=np.uint8)
    d = lbp_descriptor(frames)
    assert d.shape == (2, 3)
    for idx in np.ndindex(2, 3):
        assert d[idx] == lbp_descriptor(frames[idx])
        assert d[idx] == lbp_from_grid(lbp_grid(frames[idx]))


def test_lbp_from_grid_rejects_a_wrong_shape() -> None:
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 6, 6\), got \(8, 8\)"):
        lbp_from_grid(np.zeros((8, 8)))


def test_unpack_bits_is_msb_first() -> None:
    bits = unpack_bits(np.uint32(GOLDEN))
    assert "".join(map(str, bits)) == f"{GOLDEN:032b}"
    assert int(pack_bits(bits)) == GOLDEN


def test_pack_bits_rejects_non_bits() -> None:
    with pytest.raises(ValueError, match="0 or 1"):
        pack_bits(np.full(32, 2))
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 32\), got \(8,\)"):
        pack_bits(np.zeros(8))


def test_hamming_golden() -> None:
    nodes = np.array([GOLDEN, 0, 0xFFFFFFFF, GOLDEN ^ 0x80000001], np.uint32)
    # popcount(0xBA00FFF7) = 5 + 0 + 8 + 7 = 20
    np.testing.assert_array_equal(hamming(np.uint32(GOLDEN), nodes), [0, 20, 12, 2])
    assert hamming(GOLDEN, nodes).dtype == np.uint8


def test_hamming_chunked_path_matches_the_direct_path() -> None:
    rng = np.random.default_rng(3)
    nodes = rng.integers(0, 2**32, 100_003, dtype=np.uint32)
    q = np.uint32(0xDEADBEEF)
    naive = unpack_bits(nodes ^ q).sum(axis=1)
    np.testing.assert_array_equal(hamming(q, nodes), naive)
    out = np.empty(len(nodes), np.uint8)
    assert hamming(q, nodes, out=out) is out


def test_hamming_rejects_non_uint32_nodes() -> None:
    with pytest.raises(ValueError, match="must be uint32, got int64"):
        hamming(1, np.array([1, 2]))
    with pytest.raises(ValueError, match="query=-1 is not a 32-bit descriptor"):
        hamming(-1, np.array([1, 2], np.uint32))


codes = st.integers(0, 2**32 - 1)
code_arrays = arrays(np.uint32, st.integers(0, 40), elements=codes)


@given(codes, codes)
def test_hamming_is_symmetric_and_equals_a_bit_by_bit_count(a: int, b: int) -> None:
    ab = int(hamming(a, np.array([b], np.uint32))[0])
    ba = int(hamming(b, np.array([a], np.uint32))[0])
    naive = sum(((a >> k) & 1) != ((b >> k) & 1) for k in range(32))
    assert ab == ba == naive


@given(code_arrays)
def test_hamming_is_zero_on_self_and_bits_round_trip(nodes: np.ndarray) -> None:
    for i, q in enumerate(nodes):
        assert hamming(q, nodes)[i] == 0
    np.testing.assert_array_equal(pack_bits(unpack_bits(nodes)), nodes)


grids = arrays(np.int64, (6, 6), elements=st.integers(0, 255 * 1024))


@given(grids, st.integers(1, 5), st.integers(-1000, 1000))
def test_lbp_is_invariant_to_increasing_transforms(
    grid: np.ndarray, gain: int, offset: int
) -> None:
    code = lbp_from_grid(grid)
    assert lbp_from_grid(gain * grid + offset) == code
    assert lbp_from_grid(np.sqrt(grid.astype(np.float64))) == code
    # A grid and its negation disagree exactly where a neighbour differs from its centre.
    ties = sum(
        int(grid[r0 + dr, c0 + dc] == grid[r0 + 1, c0 + 1])
        for r0, c0 in ((0, 0), (0, 3), (3, 0), (3, 3))
        for dr, dc in ((0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0))
    )
    assert hamming(code, lbp_from_grid(-grid).reshape(1))[0] == 32 - ties
