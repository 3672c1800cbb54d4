"""The Haar-sign place: golden bits, packing, Hamming distance and their properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.place import (
    HAAR_BITS,
    haar_descriptor,
    haar_plane,
    hamming_words,
    lowres_image,
    pack_plane,
    unpack_plane,
)

images16 = arrays(np.uint8, (16, 16))


def test_golden_block():
    """One block ``a b / c d`` = ``10 20 / 30 0``: right 20 < left 40, bottom 30 >= top 30,
    diagonal 10 < 50; every other block is flat (all three ties count as 1)."""
    g = np.zeros((16, 16), np.uint8)
    g[2:4, 4:6] = [[10, 20], [30, 0]]  # block (1, 2)
    plane = haar_plane(g)
    assert plane[2:4, 4:6].tolist() == [[0, 1], [0, 0]]
    others = np.ones((8, 8, 2, 2), np.uint8)
    others[..., 1, 1] = 0
    others[1, 2] = [[0, 1], [0, 0]]
    assert np.array_equal(plane, others.transpose(0, 2, 1, 3).reshape(16, 16))
    assert int(plane.sum()) == HAAR_BITS - 2


def test_descriptor_of_a_frame_is_the_plane_of_its_16x16_codes():
    rng = np.random.default_rng(3)
    frames = rng.integers(0, 256, (3, 256, 256), dtype=np.uint8)
    words = haar_descriptor(frames)
    assert words.shape == (3, 8) and words.dtype == np.uint32
    assert np.array_equal(unpack_plane(words), haar_plane(lowres_image(frames, 16)))


@given(arrays(np.uint8, (3, 16, 16), elements=st.integers(0, 1)))
def test_pack_and_unpack_are_inverse(planes):
    words = pack_plane(planes)
    assert np.array_equal(unpack_plane(words), planes)
    # cell (r, c) is bit 31 - (16 r + c) % 32 of word (16 r + c) // 32
    r, c = np.nonzero(planes[0])
    idx = 16 * r + c
    assert all(int(words[0, i // 32]) >> (31 - i % 32) & 1 for i in idx)


@given(images16, images16)
def test_hamming_counts_the_differing_cells(a, b):
    pa, pb = haar_plane(a), haar_plane(b)
    h = hamming_words(pack_plane(pa), pack_plane(pb)[None])
    assert h.dtype == np.uint16
    assert int(h[0]) == int(np.count_nonzero(pa != pb)) <= HAAR_BITS


@given(images16, st.integers(1, 3), st.integers(0, 40))
def test_signs_survive_a_monotonic_change_of_brightness(g, gain, offset):
    """``gain * g + offset`` orders every sum of two quarters as ``g`` does: same bits."""
    brighter = g.astype(np.int64) * gain + offset
    assert np.array_equal(haar_plane(brighter), haar_plane(g))


def test_the_unused_cell_of_every_block_is_zero():
    rng = np.random.default_rng(0)
    plane = haar_plane(rng.integers(0, 256, (5, 16, 16)))
    assert not plane[:, 1::2, 1::2].any()


def test_bad_shapes_are_refused_in_one_line():
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 16, 16\), got \(8, 8\)"):
        haar_plane(np.zeros((8, 8)))
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 8\), got \(4,\)"):
        unpack_plane(np.zeros(4, np.uint32))
    with pytest.raises(ValueError, match="must be uint32"):
        hamming_words(np.zeros(8, np.int64), np.zeros((2, 8), np.uint32))
    with pytest.raises(ValueError, match="cannot be compared"):
        hamming_words(np.zeros(4, np.uint32), np.zeros((2, 8), np.uint32))


def test_descriptor_of_a_frame_lit_in_one_quarter_of_every_block_golden():
    """Every 32x32 block's top-left quarter at 200, the rest at 50: right < left (0),
    bottom < top (0), a + d > b + c (1), so each row pair packs to 0x0000AAAA."""
    x = np.arange(256) % 32 < 16
    frame = np.where(x[:, None] & x[None, :], 200, 50).astype(np.uint8)
    assert [hex(int(w)) for w in haar_descriptor(frame)] == ["0xaaaa"] * 8
