"""SeqSLAM's patch-normalised image: the place of the pixel-based baselines (SeqSLAM, the
particle filter, single-frame matching) and of the weighted-node filter's host-only
``"patch"`` place.

Every method is fed the same (256, 256) ``uint8`` sensor frames and reduces them itself.
This place follows OpenSeqSLAM: a small grey image (64x32 by default) that is *patch
normalised* (each 8x8 patch to zero mean and unit standard deviation) and compared by the
mean absolute difference per pixel. Its 2048 float values a place are no register's: the
PPA holds the 8x8 and 16x16 images, the LBP codes and the Haar signs, not this one.
"""

from __future__ import annotations

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.place.grid import SENSOR_SIZE

__all__ = [
    "PATCH_SHAPE",
    "check_frame",
    "check_patch_image",
    "downsample",
    "mean_abs_diff",
    "patch_image",
    "patch_normalise",
    "preprocess",
]

PATCH_SHAPE = (32, 64)
"""Rows and columns of the place (OpenSeqSLAM's 64x32 image, width x height)."""

_CHUNK_ELEMENTS = 1 << 22
"""Upper bound on the temporary array of :func:`mean_abs_diff` (elements, float32)."""


def check_frame(frame: np.ndarray) -> np.ndarray:
    """Return ``frame`` as an array after checking it is one (256, 256) ``uint8`` sensor frame.

    Raises
    ------
    PpalocError
        If the shape or dtype is not that of a sensor frame.
    """
    a = np.asarray(frame)
    if a.shape != (SENSOR_SIZE, SENSOR_SIZE) or a.dtype != np.uint8:
        raise PpalocError(
            f"a sensor frame must be a (256, 256) uint8 array, got shape {a.shape} and dtype "
            f"{a.dtype}; convert frames with ppaloc.datasets.to_sensor first"
        )
    return a


def check_patch_image(method: str, size: tuple[int, int], patch: int) -> None:
    """Refuse a downsampled ``size`` and ``patch`` that :func:`preprocess` cannot use, when
    a method is built rather than at its first frame: each side of ``size`` a divisor of
    256 (the sensor frame's side) and a multiple of ``patch``, ``patch`` at least 2 (a
    tile's deviation needs two pixels).

    Raises
    ------
    PpalocError
        One line naming ``method``, both values and an example that works.

    Examples
    --------
    >>> check_patch_image("SeqSLAM", (32, 64), 8)
    >>> check_patch_image("SeqSLAM", (32, 60), 8)
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: SeqSLAM: size=(32, 60) must be two divisors of 256, ...
    >>> check_patch_image("SeqSLAM", (32, 64), 7)
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: SeqSLAM: patch=7 must divide both sides of size=(32, 64) ...
    """
    rows, cols = size
    example = "(e.g. size=(32, 64), patch=8, SeqSLAM's)"
    if rows < 1 or cols < 1 or SENSOR_SIZE % rows or SENSOR_SIZE % cols:
        raise PpalocError(
            f"{method}: size=({rows}, {cols}) must be two divisors of {SENSOR_SIZE}, the "
            f"sensor frame's side {example}"
        )
    if patch < 2:
        raise PpalocError(
            f"{method}: patch={patch} must be at least 2: a tile's deviation needs two pixels"
        )
    if rows % patch or cols % patch:
        fits = [p for p in range(2, min(rows, cols) + 1) if rows % p == 0 and cols % p == 0]
        near = min(fits, key=lambda p: (abs(p - patch), -p)) if fits else None
        hint = f"e.g. patch={near}" if near else example[1:-1]
        raise PpalocError(
            f"{method}: patch={patch} must divide both sides of size=({rows}, {cols}) ({hint})"
        )


def downsample(frame: np.ndarray, size: tuple[int, int] = (32, 64)) -> np.ndarray:
    """Return the exact block means of a sensor frame on a ``size`` grid.

    Parameters
    ----------
    frame : ndarray of uint8, shape (256, 256)
        A sensor frame.
    size : (rows, cols)
        Output size; each must divide 256. The default (32, 64) is OpenSeqSLAM's 64x32
        (width x height) image; each output pixel is the mean of an 8x4 block.

    Returns
    -------
    ndarray of float32, shape ``size``
        Block means in grey levels (0-255), unrounded.

    Notes
    -----
    Area averaging replaces OpenSeqSLAM's Lanczos resize of the original image. On Nordland
    (64x32 originals stretched bilinearly to 256x256 by the front-end) the block means give
    back almost exactly the original pixels.
    """
    a = check_frame(frame)
    rows, cols = size
    if rows < 1 or cols < 1 or SENSOR_SIZE % rows or SENSOR_SIZE % cols:
        raise PpalocError(
            f"downsample size {size!r} must be two positive divisors of 256, e.g. (32, 64)"
        )
    br, bc = SENSOR_SIZE // rows, SENSOR_SIZE // cols
    sums = a.reshape(rows, br, cols, bc).sum(axis=(1, 3), dtype=np.uint32)
    return (sums / float(br * bc)).astype(np.float32)


def patch_normalise(image: np.ndarray, patch: int = 8, *, quantise: bool = False) -> np.ndarray:
    """Normalise every ``patch`` x ``patch`` tile of ``image`` to zero mean, unit deviation.

    Parameters
    ----------
    image : ndarray, shape (H, W)
        A grey image; ``H`` and ``W`` must be multiples of ``patch``.
    patch : int
        Side of the square tiles (OpenSeqSLAM: 8).
    quantise : bool
        If True, return OpenSeqSLAM's stored form ``127 + round(z)`` (rounding half away
        from zero) instead of the float z-scores. That keeps only about seven grey levels,
        which is why the float form is the default.

    Returns
    -------
    ndarray of float32, shape (H, W)
        ``(x - mean) / std`` per tile, ``std`` with Bessel's correction (as MATLAB's
        ``std``). A constant tile (``std`` zero up to rounding) becomes all zeros
        (OpenSeqSLAM divides by zero there).

    Examples
    --------
    >>> np.round(patch_normalise(np.array([[0, 2], [4, 6]]), patch=2).astype(float), 4).tolist()
    [[-1.1619, -0.3873], [0.3873, 1.1619]]
    """
    a = np.asarray(image, dtype=np.float64)
    if a.ndim != 2 or patch < 1 or a.shape[0] % patch or a.shape[1] % patch:
        raise PpalocError(
            f"patch normalisation needs a 2-D image whose sides are multiples of "
            f"patch={patch}, got shape {a.shape}"
        )
    if patch * patch < 2:
        raise PpalocError(f"patch={patch} must be at least 2 to have a standard deviation")
    h, w = a.shape
    tiles = a.reshape(h // patch, patch, w // patch, patch)
    mean = tiles.mean(axis=(1, 3), keepdims=True)
    std = tiles.std(axis=(1, 3), ddof=1, keepdims=True)
    # A tile is constant when its deviation is rounding noise relative to its level.
    flat = std <= 1e-9 * np.maximum(np.abs(mean), 1.0)
    z = np.where(flat, 0.0, (tiles - mean) / np.where(flat, 1.0, std)).reshape(h, w)
    if quantise:
        z = 127.0 + np.sign(z) * np.floor(np.abs(z) + 0.5)
    return z.astype(np.float32)


def preprocess(
    frame: np.ndarray, size: tuple[int, int] = (32, 64), patch: int = 8, *, quantise: bool = False
) -> np.ndarray:
    """Downsample a sensor frame and patch normalise it (the SeqSLAM image).

    Returns
    -------
    ndarray of float32, shape ``size``
    """
    return patch_normalise(downsample(frame, size), patch, quantise=quantise)


def patch_image(frame: np.ndarray) -> np.ndarray:
    """The ``"patch"`` place of one sensor frame: :func:`preprocess` at OpenSeqSLAM's
    defaults (64x32, 8x8 patches), float32, shape :data:`PATCH_SHAPE`; the image the
    baselines compare by default."""
    return preprocess(frame, PATCH_SHAPE)


def mean_abs_diff(query: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Mean absolute difference per pixel between one image and every node image.

    Parameters
    ----------
    query : ndarray, shape (H, W)
    nodes : ndarray, shape (N, H, W)

    Returns
    -------
    ndarray of float64, shape (N,)
        ``mean(|nodes[i] - query|)`` for each node, computed in float32 chunks so the
        temporary stays small for large maps.
    """
    q = np.asarray(query, dtype=np.float32).ravel()
    flat = np.asarray(nodes, dtype=np.float32).reshape(len(nodes), -1)
    if flat.shape[1] != q.size:
        raise PpalocError(
            f"the query image has {q.size} pixels but the map's node images have "
            f"{flat.shape[1]}; build the map with the same downsampling parameters"
        )
    out = np.empty(len(flat), dtype=np.float64)
    step = max(1, _CHUNK_ELEMENTS // max(q.size, 1))
    for lo in range(0, len(flat), step):
        block = np.abs(flat[lo : lo + step] - q)
        out[lo : lo + step] = block.sum(axis=1, dtype=np.float64)
    return out / q.size
