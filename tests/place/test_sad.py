"""SAD between low-resolution images: golden values and properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.place import sad

images = arrays(np.uint8, (8, 8), elements=st.integers(0, 255))


def test_sad_golden() -> None:
    q = np.zeros((8, 8), np.uint8)
    a = q.copy()
    a[0, 0] = 255
    b = np.full((8, 8), 3, np.uint8)
    c = q.copy()
    c[7, 7] = 10
    d = sad(q, np.stack([q, a, b, c]))
    assert d.dtype == np.int64
    np.testing.assert_array_equal(d, [0, 255, 192, 10])
    # the largest possible distance, 64 * 255, does not overflow
    assert sad(q, np.full((1, 8, 8), 255, np.uint8))[0] == 64 * 255


def test_sad_chunked_path_matches_a_naive_sum() -> None:
    rng = np.random.default_rng(5)
    nodes = rng.integers(0, 256, (20_001, 8, 8), dtype=np.uint8)
    q = rng.integers(0, 256, (8, 8), dtype=np.uint8)
    naive = np.abs(nodes.astype(np.int64) - q).sum(axis=(1, 2))
    np.testing.assert_array_equal(sad(q, nodes), naive)


def test_sad_accepts_integer_arrays_in_range_and_rejects_others() -> None:
    q = np.arange(64).reshape(8, 8)
    assert sad(q, q[None])[0] == 0
    with pytest.raises(ValueError, match=r"integers in 0\.\.255"):
        sad(q - 1, q[None])
    with pytest.raises(ValueError, match=r"3 axes \(\.\.\., 8, 8\), got shape \(8, 8\)"):
        sad(q, q)
    with pytest.raises(ValueError, match=r"nodes have images of shape \(4, 16\)"):
        sad(q, q.reshape(1, 4, 16))


@given(images, images)
def test_sad_is_symmetric_and_zero_on_self(a: np.ndarray, b: np.ndarray) -> None:
    assert sad(a, b[None])[0] == sad(b, a[None])[0]
    assert sad(a, a[None])[0] == 0
    assert sad(a, b[None])[0] == np.abs(a.astype(int) - b.astype(int)).sum()


@given(images, images, images)
def test_sad_triangle_inequality(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
    assert sad(a, c[None])[0] <= sad(a, b[None])[0] + sad(b, c[None])[0]
