"""Contrast normalisation of low-resolution images, in integers a PPA controller can do.

An 8x8 image of block means carries the scene and the light: a dusk, night or winter
frame of a place differs from the summer day frame of the same place mostly by an
offset and a contrast. :func:`normalise_contrast` removes both, per image, before the
sum of absolute differences compares a frame with the map:

- the offset: ``o = floor(mean)`` of the image's 64 values;
- the contrast: a gain from the fixed set :data:`CONTRAST_SCALES` (quarters: x1/2, x3/4,
  x1, x3/2, x2, x3, x4) nearest, on a log scale, to ``target / mad``, with ``mad`` the
  mean absolute deviation from ``o``, so that the result's deviation lands near
  ``target`` grey levels (within about a factor 1.2);
- ``q' = clip(round(128 + (q - o) * gain), 1, 255)``, rounding halves up. The lowest level
  is 1, not 0: the sensor loads ``q' - 128`` through its DAC and negates it in one write,
  and the array's -128 has no negation (it saturates to 127).

Only integer sums, comparisons of integer products and one shift: the sensor's
controller applies it to the 64 codes it reads from the array (docs/onsensor.md), and
the host applies the same function to its images, so both see the same integers.
``target=0`` leaves images as they are (but for that lowest level).

With ``patch``, each ``patch`` x ``patch`` tile of the image is one "image" of the rule
above, with its own offset and gain: light that changes across the image (a lit road
under a dark sky) is taken out tile by tile. The robust filter normalises the sixteen
2x2 tiles of its 8x8 images (docs/localise.md, "Local contrast").
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np

__all__ = ["CONTRAST_SCALES", "MAX_CONTRAST", "contrast_scale", "normalise_contrast"]

CONTRAST_SCALES = (2, 3, 4, 6, 8, 12, 16)
"""The gains in quarters (x1/2 .. x4): each about a factor 1.4 from the next, so the
chosen gain is within a factor 1.2 of the wanted one; two terms of halvings and doublings
at most, should an array apply one."""

MAX_CONTRAST = 127
"""The largest ``target`` (grey levels of mean absolute deviation)."""


def _as_values(images: np.ndarray) -> np.ndarray:
    a = np.asarray(images)
    if a.ndim < 2 or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(
            f"images must be integer arrays of shape (..., H, W), got {a.shape} {a.dtype}"
        )
    if a.size and (a.min() < 0 or a.max() > 255):
        raise ValueError("images must hold grey levels in 0..255")
    return a.reshape(*a.shape[:-2], -1).astype(np.int64)


def contrast_scale(images: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """The offset and gain :func:`normalise_contrast` applies to each image.

    Parameters
    ----------
    images : ndarray of int, shape (..., H, W)
        Grey levels in 0..255.
    target : int
        Wanted mean absolute deviation, in grey levels (1 .. :data:`MAX_CONTRAST`).

    Returns
    -------
    (offset, quarters) : ndarrays of int64, shape (...)
        ``offset = floor(mean)``; ``quarters`` one of :data:`CONTRAST_SCALES`, the gain
        ``quarters / 4``. A flat image (no deviation) takes the largest gain.

    Notes
    -----
    With ``n`` values and ``dev = sum |q - offset|`` (so ``mad = dev / n``), the wanted
    gain in quarters is ``r / dev`` with ``r = 4 * target * n``. Between two neighbouring
    scales ``a < b`` the larger is nearer on a log scale exactly when ``r**2 > a * b *
    dev**2`` (above their geometric mean): integers throughout.

    Examples
    --------
    >>> img = np.array([[100, 140], [100, 140]])  # mean 120, mad 20
    >>> contrast_scale(img, 40)  # gain 2 = 8 quarters
    (array(120), array(8))
    >>> contrast_scale(img, 20), contrast_scale(np.full((2, 2), 7), 20)
    ((array(120), array(4)), (array(7), array(16)))
    """
    return _offset_quarters(_as_values(images), target)


def _offset_quarters(v: np.ndarray, target: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`contrast_scale` of values already flattened to (..., n) int64."""
    n = v.shape[-1]
    if not 1 <= int(target) <= MAX_CONTRAST:
        raise ValueError(f"target={target!r} must be in [1, {MAX_CONTRAST}]")
    offset = np.asarray(v.sum(axis=-1) // n)
    dev = np.abs(v - offset[..., None]).sum(axis=-1)
    r2 = (4 * int(target) * n) ** 2
    quarters = np.full(offset.shape, CONTRAST_SCALES[0], np.int64)
    for a, b in pairwise(CONTRAST_SCALES):
        quarters = np.where(r2 > a * b * dev * dev, b, quarters)
    return offset, quarters


def normalise_contrast(images: np.ndarray, target: int, patch: int | None = None) -> np.ndarray:
    """Images with their offset removed and their contrast brought near ``target``.

    Parameters
    ----------
    images : ndarray of int, shape (..., H, W)
        Grey levels in 0..255 (low-res images, :func:`ppaloc.place.lowres_image`).
    target : int
        Wanted mean absolute deviation in grey levels (1 .. :data:`MAX_CONTRAST`); 0
        returns the images unchanged but for the lowest level.
    patch : int, optional
        Normalise each ``patch`` x ``patch`` tile of the image on its own (its own offset
        and gain), which takes out light that changes across the image (a lit sky over a
        dark road, headlights): local contrast normalisation, as OpenSeqSLAM's patch
        normalisation but in integers. ``patch`` must divide ``H`` and ``W``. None: the
        whole image is one tile.

    Returns
    -------
    ndarray of uint8, same shape
        ``clip(floor((512 + (q - offset) * quarters + 2) / 4), 1, 255)``: 128 plus the
        deviation from the offset times the gain, rounded half up (:func:`contrast_scale`),
        in the levels 1..255 (module doc).

    Examples
    --------
    >>> dark = np.array([[10, 14], [10, 14]])
    >>> normalise_contrast(dark, 8)  # mean 12 -> 128; mad 2 x4 -> 8
    array([[120, 136],
           [120, 136]], dtype=uint8)
    >>> bright = dark * 4 + 100  # the same place under more light and contrast
    >>> np.array_equal(normalise_contrast(bright, 8), normalise_contrast(dark, 8))
    True
    >>> img = np.array([[10, 14, 200, 208], [10, 14, 200, 208]])  # a dark and a bright half
    >>> normalise_contrast(img, 8, patch=2)  # each 2x2 tile brought to mean 128 on its own
    array([[120, 136, 120, 136],
           [120, 136, 120, 136]], dtype=uint8)
    """
    a = np.asarray(images)
    if patch is not None:
        return _per_patch(a, target, patch)
    v = _as_values(a)
    if int(target) == 0:
        return np.maximum(v, 1).reshape(a.shape).astype(np.uint8)
    offset, quarters = _offset_quarters(v, target)
    out = (512 + (v - offset[..., None]) * quarters[..., None] + 2) >> 2
    return np.clip(out, 1, 255).astype(np.uint8).reshape(a.shape)


def _per_patch(a: np.ndarray, target: int, patch: int) -> np.ndarray:
    """:func:`normalise_contrast` of every ``patch`` x ``patch`` tile of ``a`` on its own."""
    if a.ndim < 2:
        raise ValueError(f"images must have shape (..., H, W), got {a.shape}")
    h, w = a.shape[-2:]
    if isinstance(patch, bool) or not isinstance(patch, int | np.integer) or patch < 1:
        raise ValueError(f"patch={patch!r} must be a positive integer")
    if h % patch or w % patch:
        raise ValueError(f"patch={patch} must divide the image's sides, got {h}x{w}")
    lead = a.shape[:-2]
    tiles = a.reshape(*lead, h // patch, patch, w // patch, patch)
    tiles = np.moveaxis(tiles, -3, -2)  # (..., rows, cols, patch, patch)
    out = normalise_contrast(tiles, target)
    return np.moveaxis(out, -2, -3).reshape(a.shape)
