"""Contrast normalisation of low-res images: goldens, the integer rule, its invariances."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.place import CONTRAST_SCALES, contrast_scale, normalise_contrast

images = arrays(np.int64, (8, 8), elements=st.integers(0, 255))


def test_golden_tiny_image() -> None:
    img = np.array([[0, 10], [20, 30]])  # mean 15, deviations 15, 5, 5, 15: mad 10
    offset, quarters = contrast_scale(img, 20)
    assert (int(offset), int(quarters)) == (15, 8)  # gain 2
    # 128 + 2 * (-15, -5, 5, 15)
    np.testing.assert_array_equal(normalise_contrast(img, 20), [[98, 118], [138, 158]])
    # gain 3/4 (mad 10 -> 7.5, wanted 7): 128 + (-11.25, -3.75, 3.75, 11.25), halves up
    assert int(contrast_scale(img, 7)[1]) == 3
    np.testing.assert_array_equal(normalise_contrast(img, 7), [[117, 124], [132, 139]])


def test_rounding_is_half_up_and_the_range_is_clipped() -> None:
    img = np.full((8, 8), 128)
    img[0, 0], img[0, 1] = 0, 255  # mean 127.98 -> offset 127; mad 317/64, about 5
    assert int(contrast_scale(img, 20)[1]) == 16  # gain x4
    out = normalise_contrast(img, 20)
    assert (out[0, 0], out[0, 1]) == (1, 255)  # 128 - 508 and 128 + 512, clipped to 1..255
    assert (out.reshape(-1)[2:] == 132).all()  # 128 + 4 * 1
    half = np.array([[0, 7], [0, 7]])  # offset 3 (floor of 3.5), mad 3.5, gain 1/2:
    assert int(contrast_scale(half, 1)[1]) == 2
    # 128 - 1.5 = 126.5 (up to 127) and 128 + 2
    np.testing.assert_array_equal(normalise_contrast(half, 1), [[127, 130], [127, 130]])


def test_a_flat_image_takes_the_largest_gain_and_maps_to_128() -> None:
    flat = np.full((8, 8), 37)
    assert int(contrast_scale(flat, 48)[1]) == CONTRAST_SCALES[-1]
    assert (normalise_contrast(flat, 48) == 128).all()


def test_target_zero_leaves_images_as_they_are_and_leading_axes_are_kept() -> None:
    rng = np.random.default_rng(0)
    stack = rng.integers(0, 256, (3, 2, 8, 8))
    stack[0, 0, 0, 0] = 0
    np.testing.assert_array_equal(normalise_contrast(stack, 0), np.maximum(stack, 1))
    out = normalise_contrast(stack, 48)
    assert out.shape == stack.shape and out.dtype == np.uint8
    np.testing.assert_array_equal(out[1, 0], normalise_contrast(stack[1, 0], 48))


@settings(max_examples=200, deadline=None)
@given(img=images, shift=st.integers(-255, 255), target=st.integers(1, 127))
def test_an_added_light_level_changes_nothing(img, shift, target) -> None:
    """The offset is the floor of the mean: adding an integer keeps every deviation."""
    moved = img + shift
    if moved.min() < 0 or moved.max() > 255:
        moved = img  # only shifts that stay in range
    want = normalise_contrast(img, target)
    np.testing.assert_array_equal(normalise_contrast(moved, target), want)


@settings(max_examples=200, deadline=None)
@given(img=images, target=st.integers(1, 127))
def test_the_gain_is_the_scale_nearest_the_wanted_one(img, target) -> None:
    """On a log scale, no other scale of the set is nearer to target / mad."""
    offset, quarters = (int(x) for x in contrast_scale(img, target))
    assert offset == int(np.floor(img.mean()))
    mad = np.abs(img - offset).mean()
    if mad == 0:
        assert quarters == CONTRAST_SCALES[-1]
        return
    wanted = math.log(4 * target / mad)
    dist = [abs(math.log(q) - wanted) for q in CONTRAST_SCALES]
    assert abs(math.log(quarters) - wanted) <= min(dist) + 1e-12


def test_bad_input_names_the_cause() -> None:
    with pytest.raises(ValueError, match="target=0"):
        contrast_scale(np.zeros((8, 8), np.int64), 0)
    with pytest.raises(ValueError, match="target=200"):
        normalise_contrast(np.zeros((8, 8), np.int64), 200)
    with pytest.raises(ValueError, match=r"0\.\.255"):
        normalise_contrast(np.full((8, 8), 256), 48)
    with pytest.raises(ValueError, match="integer"):
        normalise_contrast(np.zeros((8, 8)), 48)


@settings(max_examples=50, deadline=None)
@given(
    img=arrays(np.int64, (2, 8, 8), elements=st.integers(0, 255)),
    patch=st.sampled_from([1, 2, 4, 8]),
    target=st.integers(0, 127),
)
def test_each_tile_is_normalised_on_its_own(img, patch, target) -> None:
    out = normalise_contrast(img, target, patch)
    assert out.shape == img.shape and out.dtype == np.uint8
    for r in range(0, 8, patch):
        for c in range(0, 8, patch):
            tile = img[:, r : r + patch, c : c + patch]
            np.testing.assert_array_equal(
                out[:, r : r + patch, c : c + patch], normalise_contrast(tile, target)
            )
    if patch == 8:
        np.testing.assert_array_equal(out, normalise_contrast(img, target))


def test_a_bad_tile_names_the_cause() -> None:
    img = np.zeros((8, 8), np.int64)
    with pytest.raises(ValueError, match=r"^patch=3 must divide the image's sides, got 8x8$"):
        normalise_contrast(img, 48, 3)
    with pytest.raises(ValueError, match=r"^patch=0 must be a positive integer$"):
        normalise_contrast(img, 48, 0)
    with pytest.raises(ValueError, match=r"^patch=True must be a positive integer$"):
        normalise_contrast(img, 48, True)
