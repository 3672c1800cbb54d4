"""Block means and the low-resolution image: exact values on hand-made frames."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import PpalocError
from ppaloc.place import block_means, block_sums, lbp_grid, lowres_image


def blocky(values: np.ndarray) -> np.ndarray:
    """A (256, 256) frame whose 32x32 blocks are constant, given the (8, 8) block values."""
    return np.kron(values.astype(np.uint8), np.ones((32, 32), np.uint8))


def test_block_means_of_a_blocky_frame_are_its_block_values() -> None:
    values = np.arange(64, dtype=np.uint8).reshape(8, 8) * 4
    np.testing.assert_array_equal(block_means(blocky(values)), values.astype(np.float64))


def test_block_means_are_exact_fractions() -> None:
    frame = np.zeros((256, 256), np.uint8)
    frame[0, 0] = 1  # one pixel in the top-left 32x32 block
    frame[255, 255] = 255
    means = block_means(frame)
    assert means[0, 0] == 1 / 1024
    assert means[7, 7] == 255 / 1024
    assert means.sum() == 256 / 1024


def test_block_means_grid_sizes_and_leading_axes() -> None:
    rng = np.random.default_rng(1)
    frames = rng.integers(0, 256, (2, 3, 256, 256), dtype=np.uint8)
    for grid in (1, 2, 8, 32, 256):
        m = block_means(frames, grid)
        assert m.shape == (2, 3, grid, grid)
        b = 256 // grid
        ref = frames.reshape(2, 3, grid, b, grid, b).astype(np.float64).mean(axis=(3, 5))
        np.testing.assert_allclose(m, ref, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(block_means(frames, 256), frames.astype(np.float64))


@pytest.mark.parametrize("grid", [0, 3, 7, 100, -8])
def test_block_means_rejects_a_grid_that_does_not_divide_256(grid: int) -> None:
    with pytest.raises(ValueError, match=f"grid={grid} must be a positive integer dividing 256"):
        block_means(np.zeros((256, 256), np.uint8), grid)


@pytest.mark.parametrize(
    ("frames", "message"),
    [
        (np.zeros((128, 256), np.uint8), r"shape \(\.\.\., 256, 256\), got \(128, 256\)"),
        (np.zeros((256, 256), np.float32), "must be uint8, got float32"),
    ],
)
def test_block_sums_rejects_non_sensor_frames(frames: np.ndarray, message: str) -> None:
    with pytest.raises(PpalocError, match=message):  # a user's frame: one line from the CLI
        block_sums(frames)


def test_lowres_image_floors_the_block_mean() -> None:
    frame = blocky(np.full((8, 8), 100))
    frame[0, 0] = 99  # block (0, 0): mean 100 - 1/1024 -> 99
    frame[40, 40] = 101  # block (1, 1): mean 100 + 1/1024 -> 100
    frame[255, :] = 255  # block row 7: +155 * 32 per block, mean 104.84 -> 104
    q = lowres_image(frame)
    assert q.dtype == np.uint8 and q.shape == (8, 8)
    assert q[0, 0] == 99 and q[1, 1] == 100 and q[0, 1] == 100
    np.testing.assert_array_equal(q[7], np.full(8, 104))
    np.testing.assert_array_equal(lowres_image(np.full((256, 256), 255, np.uint8)), 255)


def test_lbp_grid_is_the_central_six_by_six() -> None:
    values = np.arange(64).reshape(8, 8)
    np.testing.assert_array_equal(lbp_grid(blocky(values)), values[1:7, 1:7])


def test_lowres16_image_floors_the_means_of_16_pixel_blocks() -> None:
    frame = np.kron(np.arange(256).reshape(16, 16).astype(np.uint8), np.ones((16, 16), np.uint8))
    frame[0, 0] = 255  # block (0, 0): sum 255 over 256 pixels -> floor(0.996) = 0
    frame[16, 17] = 0  # block (1, 1) of value 17: mean 17 - 17/256 -> 16
    q = lowres_image(frame, 16)
    assert q.dtype == np.uint8 and q.shape == (16, 16)
    want = np.arange(256).reshape(16, 16)
    want[1, 1] = 16
    np.testing.assert_array_equal(q, want)
    # the 8x8 image of the same frame is the floor of the mean of each 2x2 group
    sums = block_sums(frame, 16).reshape(8, 2, 8, 2).sum(axis=(1, 3))
    np.testing.assert_array_equal(lowres_image(frame), sums >> 10)
    with pytest.raises(ValueError, match="not a low-res grid"):
        lowres_image(frame, 4)
