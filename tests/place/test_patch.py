"""Downsampling and patch normalisation: golden values on tiny arrays."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.errors import PpalocError
from ppaloc.place.patch import downsample, mean_abs_diff, patch_normalise, preprocess


def test_patch_normalise_golden_2x2() -> None:
    # mean 3, deviations -3 -1 1 3, Bessel std sqrt(20/3).
    s = np.sqrt(20.0 / 3.0)
    expected = np.array([[-3, -1], [1, 3]]) / s
    got = patch_normalise(np.array([[0, 2], [4, 6]]), patch=2)
    np.testing.assert_allclose(got, expected, rtol=1e-6)


def test_patch_normalise_tiles_are_independent_and_constant_tile_is_zero() -> None:
    image = np.array([[0, 2, 5, 5], [4, 6, 5, 5]])
    got = patch_normalise(image, patch=2)
    np.testing.assert_array_equal(got[:, 2:], 0.0)
    np.testing.assert_allclose(got[:, :2], patch_normalise(image[:, :2], patch=2))


def test_patch_normalise_quantised_like_openseqslam() -> None:
    # z = -1.16, -0.39, 0.39, 1.16 -> 127 + round(z) = 126, 127, 127, 128.
    got = patch_normalise(np.array([[0, 2], [4, 6]]), patch=2, quantise=True)
    np.testing.assert_array_equal(got, [[126, 127], [127, 128]])
    # Halves round away from zero (MATLAB), not to even: z = -0.5 -> 126, 1.5 -> 129.
    z = patch_normalise(np.array([[0, 0], [0, 4]]), patch=2)  # z = -0.5, -0.5, -0.5, 1.5
    np.testing.assert_allclose(z, [[-0.5, -0.5], [-0.5, 1.5]])
    q = patch_normalise(np.array([[0, 0], [0, 4]]), patch=2, quantise=True)
    np.testing.assert_array_equal(q, [[126, 126], [126, 129]])


@settings(max_examples=30, deadline=None)
@given(arrays(np.float64, (8, 16), elements=st.floats(0, 255)))
def test_patch_normalise_gives_zero_mean_unit_std_tiles(image: np.ndarray) -> None:
    z = patch_normalise(image, patch=8).astype(np.float64)
    for tile in (z[:, :8], z[:, 8:]):
        if np.all(tile == 0):
            continue
        assert abs(tile.mean()) < 1e-5
        assert abs(tile.std(ddof=1) - 1.0) < 1e-4


def test_downsample_is_exact_block_means() -> None:
    frame = np.zeros((256, 256), np.uint8)
    frame[:8, :4] = 255  # one 8x4 block of the 32x64 grid
    frame[8:16, 0] = 40  # a quarter of the block below
    out = downsample(frame)
    assert out.shape == (32, 64)
    assert out[0, 0] == 255.0
    assert out[1, 0] == 10.0
    assert out.sum() == 265.0


def test_preprocess_shape_and_dtype() -> None:
    frame = np.random.default_rng(0).integers(0, 256, (256, 256), dtype=np.uint8)
    out = preprocess(frame)
    assert out.shape == (32, 64) and out.dtype == np.float32


def test_mean_abs_diff_matches_direct_formula() -> None:
    rng = np.random.default_rng(3)
    q = rng.normal(size=(4, 8))
    nodes = rng.normal(size=(5, 4, 8))
    expected = np.abs(nodes - q).mean(axis=(1, 2))
    np.testing.assert_allclose(mean_abs_diff(q, nodes), expected, rtol=1e-6)


def test_bad_frame_is_a_user_error_naming_the_fix() -> None:
    with pytest.raises(PpalocError, match=r"got shape \(32, 64\) .*to_sensor"):
        downsample(np.zeros((32, 64), np.uint8))


def test_bad_sizes_are_user_errors() -> None:
    frame = np.zeros((256, 256), np.uint8)
    with pytest.raises(PpalocError, match=r"size \(30, 64\) must be two positive divisors"):
        downsample(frame, (30, 64))
    with pytest.raises(PpalocError, match="multiples of patch=8"):
        patch_normalise(np.zeros((12, 16)), patch=8)
