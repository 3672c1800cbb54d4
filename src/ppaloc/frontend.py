"""The sensor front-end: any frame becomes the 256x256 grey image the PPA sees.

It sits at the bottom of the layers (with `errors` and `fileio`): datasets feed it, and
the map builder and every localiser rely on its output. `ppaloc.datasets` re-exports it.
"""

from __future__ import annotations

import numpy as np
from PIL import Image

from ppaloc.errors import DataError

__all__ = ["SENSOR_SHAPE", "to_grey", "to_sensor"]

SENSOR_SHAPE = (256, 256)
"""(rows, cols) of the SCAMP-5 pixel array."""


def to_grey(frame: np.ndarray) -> np.ndarray:
    """Return a 2-D ``uint8`` grey image from a grey, RGB or RGBA frame.

    Colour is converted with the ITU-R 601 luma weights (0.299 R + 0.587 G + 0.114 B),
    the rule Pillow's ``convert("L")`` uses; alpha is ignored; float frames are taken as
    [0, 1] and scaled to [0, 255]; uint16 frames are 16-bit images, scaled to 8 bits as
    :func:`ppaloc.datasets.images.read_grey` scales a 16-bit file; other integer frames
    must hold grey levels 0-255.

    Raises
    ------
    DataError
        A frame of another shape, of values that are not real numbers (text, objects,
        complex), holding NaN or infinite values (no grey level stands for them), or of
        integers outside 0-255 (other than uint16).
    """
    a = np.asarray(frame)
    if a.dtype.kind not in "biuf":
        raise DataError(
            f"a frame must hold real numbers, got dtype {a.dtype}: give a uint8 image "
            "(or floats in [0, 1])"
        )
    if a.dtype.kind == "f" and not np.isfinite(a).all():
        bad = int(np.count_nonzero(~np.isfinite(a)))
        raise DataError(
            f"a frame of shape {a.shape} holds {bad} NaN or infinite value(s), which no grey "
            "level stands for: give finite values"
        )
    if a.dtype == np.uint16:  # a 16-bit image: scaled to 8 bits as read_grey scales one
        a = np.rint(a * (255.0 / 65535.0)).astype(np.uint8)
    elif a.dtype.kind in "iu" and a.dtype != np.uint8 and a.size:
        lo, hi = int(a.min()), int(a.max())
        if lo < 0 or hi > 255:  # clipped, it was a frame almost all black or white
            raise DataError(
                f"a frame of {a.dtype} holds values from {lo} to {hi}, outside the grey levels "
                "0-255: give uint8 (0-255), uint16 (a 16-bit image) or floats in [0, 1]"
            )
    if a.ndim == 3 and a.shape[2] in (3, 4):
        a = a[..., :3].astype(np.float32) @ np.array([0.299, 0.587, 0.114], np.float32)
        a = np.rint(a) if np.issubdtype(np.asarray(frame).dtype, np.integer) else a
    elif a.ndim == 3 and a.shape[2] == 1:
        a = a[..., 0]
    elif a.ndim != 2:
        raise DataError(f"a frame must be 2-D grey or HxWx3/4 colour, got shape {a.shape}")
    if np.issubdtype(a.dtype, np.floating) and a.size and float(np.max(a)) <= 1.0:
        a = a * 255.0
    return np.clip(a, 0, 255).astype(np.uint8)


def to_sensor(frame: np.ndarray) -> np.ndarray:
    """Return the (256, 256) ``uint8`` image the PPA sees for any input frame.

    The rule, the same for every method: convert to grey (:func:`to_grey`), then resize
    the *whole* frame to 256x256 with Pillow's bilinear filter (which widens its support
    when shrinking, so downsampling is anti-aliased). Nothing is cropped: the aspect ratio
    is not kept (Nordland's 64x32 is stretched 4x by 8x, Gardens Point's 960x540 squeezed),
    so every method sees the full field of view, as in OpenSeqSLAM's resize to 64x32.
    A frame :func:`to_grey` refuses, or an empty one, raises :class:`~ppaloc.errors.DataError`.

    Examples
    --------
    >>> to_sensor(np.zeros((32, 64), np.uint8)).shape
    (256, 256)
    """
    grey = to_grey(frame)
    if grey.shape == SENSOR_SHAPE:
        return grey
    if grey.size == 0:
        raise DataError(f"an empty frame (shape {grey.shape}) cannot be shown to the sensor")
    size = (SENSOR_SHAPE[1], SENSOR_SHAPE[0])  # Pillow takes (width, height)
    out = Image.fromarray(grey).resize(size, Image.Resampling.BILINEAR)
    return np.asarray(out, dtype=np.uint8)
