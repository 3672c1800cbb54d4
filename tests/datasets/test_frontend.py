"""The sensor front-end: any frame -> (256, 256) uint8, by the documented stretch rule."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.datasets import to_grey, to_sensor
from ppaloc.errors import DataError


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


@pytest.mark.parametrize(
    ("frame", "message"),
    [
        (np.full((4, 4), np.nan), r"holds 16 NaN or infinite value\(s\)"),
        (np.array([[np.inf, 0.5], [0.0, 1.0]], np.float32), r"holds 1 NaN or infinite"),
        (np.full((4, 4, 3), np.nan), r"holds 48 NaN or infinite"),
        (np.full((4, 4), "a"), r"must hold real numbers, got dtype <U1"),
        (np.ones((4, 4), complex), r"must hold real numbers, got dtype complex128"),
        (np.zeros((4, 4), object), r"must hold real numbers, got dtype object"),
        (np.zeros((4, 4, 2)), r"must be 2-D grey or HxWx3/4 colour, got shape \(4, 4, 2\)"),
        (np.zeros((0, 5), np.uint8), r"an empty frame \(shape \(0, 5\)\) cannot be shown"),
        # clipped to 0-255 before, a frame almost all black or white
        (np.full((4, 4), 300, np.int64), r"int64 holds values from 300 to 300, outside"),
        (np.array([[-3, 9]], np.int16), r"int16 holds values from -3 to 9, outside the grey"),
    ],
)
def test_a_frame_no_grey_level_stands_for_is_refused(frame, message):
    # NaN became black (0) with a warning; text stopped in numpy's clip; complex lost its
    # imaginary part with a warning
    with pytest.raises(DataError, match=message) as err:
        to_sensor(frame)
    assert "\n" not in str(err.value)


def test_a_16_bit_frame_is_scaled_as_a_16_bit_file_is():
    # uint16 was clipped at 255: a 16-bit ramp came out 99.6% white
    ramp = np.rint(np.linspace(0, 65535, 256))[None, :].repeat(4, axis=0).astype(np.uint16)
    grey = to_grey(ramp)
    assert grey[0, 0] == 0 and grey[0, -1] == 255 and grey[0, 128] in (128, 129)
    assert to_grey(np.stack([ramp] * 3, axis=-1)).tolist() == grey.tolist()  # colour alike
    assert to_grey(np.full((2, 2), 200, np.int32)).tolist() == [[200, 200], [200, 200]]


def test_a_16_bit_frame_reads_as_its_file_does(tmp_path):
    from PIL import Image

    from ppaloc.datasets.images import read_grey

    ramp = np.rint(np.linspace(0, 65535, 64))[None, :].repeat(4, axis=0).astype(np.uint16)
    Image.fromarray(ramp).save(tmp_path / "ramp.png")
    got = read_grey(tmp_path / "ramp.png")
    got = got[0] if isinstance(got, tuple) else got
    assert to_grey(ramp).tolist() == np.asarray(got).tolist()
