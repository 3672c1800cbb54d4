"""The sensor front-end: any frame -> (256, 256) uint8, by the documented stretch rule."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.datasets import to_grey, to_sensor


@pytest.mark.parametrize(
    "frame",
    [
        np.zeros((32, 64), np.uint8),
        np.full((540, 960, 3), 200, np.uint8),
        np.full((360, 640, 4), 30, np.uint8),
        np.linspace(0, 1, 100 * 50, dtype=np.float32).reshape(100, 50),
        np.full((256, 256), 7, np.uint8),
    ],
)
def test_shape_dtype_and_range(frame):
    out = to_sensor(frame)
    assert out.shape == (256, 256) and out.dtype == np.uint8
    lo, hi = float(np.min(to_grey(frame))), float(np.max(to_grey(frame)))
    assert lo <= out.min() and out.max() <= hi  # bilinear never overshoots


def test_stretch_keeps_the_whole_field_of_view():
    # A 32x64 frame whose left half is black and right half white: after stretching,
    # the boundary sits in the middle column of the sensor, nothing is cropped.
    frame = np.zeros((32, 64), np.uint8)
    frame[:, 32:] = 255
    out = to_sensor(frame)
    assert out[:, :120].max() == 0 and out[:, 136:].min() == 255


def test_colour_uses_601_luma():
    px = np.array([[[255, 0, 0], [0, 255, 0], [0, 0, 255]]], np.uint8)
    assert to_grey(px).tolist() == [[76, 150, 29]]
