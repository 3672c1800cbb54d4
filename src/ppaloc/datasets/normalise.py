"""Per-frame transforms a spec key applies to both traversals (``patch_norm=P``).

Applied lazily (:meth:`FrameSequence.transformed`): a frame is transformed when it is read,
so a traversal stays a lazy sequence.
"""

from __future__ import annotations

import numpy as np

from ppaloc.frontend import to_grey

__all__ = ["PatchNormalise", "patch_normalise_frame"]

CENTRE = 128.0
"""Grey level of a tile's mean after patch normalisation."""
SCALE = 32.0
"""Grey levels per standard deviation after patch normalisation."""
_FLAT = 1e-6
"""A tile whose standard deviation is at most this is flat (all its pixels become 0 z)."""


def patch_normalise_frame(frame: np.ndarray, patch: int) -> np.ndarray:
    """Normalise every ``patch`` x ``patch`` tile of a frame, at its native resolution.

    Each non-overlapping tile (from the top-left corner; the partial tiles along the right
    and bottom edges when a side is not a multiple of ``patch`` are tiles of their own) is
    brought to zero mean and unit standard deviation (the population deviation of its
    pixels), ``z = (x - mean) / std``; a flat tile gives ``z = 0``. The result is stored
    back as ``uint8``: ``clip(round(128 + 32 z), 0, 255)`` (``round`` is numpy's, ties to
    even), so a tile's mean maps to 128 and +-1 deviation to 96..160.

    Parameters
    ----------
    frame : ndarray
        A 2-D grey frame (colour is converted to grey first, as ``to_grey`` does).
    patch : int
        Tile side in pixels (>= 1).

    Returns
    -------
    ndarray of uint8, the frame's shape

    Examples
    --------
    >>> patch_normalise_frame(np.array([[0, 2, 5], [4, 6, 5]], np.uint8), 2).tolist()
    [[85, 114, 128], [142, 171, 128]]
    """
    patch = int(patch)
    if patch < 1:
        raise ValueError(f"patch must be >= 1, got {patch}")
    a = to_grey(frame).astype(np.float64)
    h, w = a.shape
    if a.size == 0:
        return a.astype(np.uint8)
    rows, cols = np.arange(0, h, patch), np.arange(0, w, patch)
    heights = np.diff(np.append(rows, h))
    widths = np.diff(np.append(cols, w))
    counts = np.outer(heights, widths).astype(np.float64)

    def tile_sums(x: np.ndarray) -> np.ndarray:
        return np.add.reduceat(np.add.reduceat(x, rows, axis=0), cols, axis=1)

    def per_pixel(t: np.ndarray) -> np.ndarray:
        return np.repeat(np.repeat(t, heights, axis=0), widths, axis=1)

    d = a - per_pixel(tile_sums(a) / counts)
    std = np.sqrt(tile_sums(d * d) / counts)
    inv = np.divide(1.0, std, out=np.zeros_like(std), where=std > _FLAT)
    z = d * per_pixel(inv)
    return np.clip(np.rint(CENTRE + SCALE * z), 0, 255).astype(np.uint8)


class PatchNormalise:
    """``patch_normalise_frame(frame, patch)`` as a picklable callable.

    Examples
    --------
    >>> PatchNormalise(4)(np.full((3, 5), 200, np.uint8)).tolist()[0]
    [128, 128, 128, 128, 128]
    """

    def __init__(self, patch: int) -> None:
        self.patch = int(patch)

    def __call__(self, frame: np.ndarray) -> np.ndarray:
        return patch_normalise_frame(frame, self.patch)

    def __repr__(self) -> str:
        return f"PatchNormalise({self.patch})"
