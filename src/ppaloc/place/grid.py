"""Block means of sensor frames: the grid every place representation starts from."""

from __future__ import annotations

import numpy as np

from ppaloc.errors import PpalocError

__all__ = [
    "LOWRES_GRIDS",
    "SENSOR_SIZE",
    "block_means",
    "block_sums",
    "lowres_grid",
    "lowres_image",
    "tile_cells",
]

SENSOR_SIZE = 256
"""Rows (= columns) of a sensor frame, the SCAMP-5 pixel array."""

LOWRES_GRIDS: dict[str, int] = {"lowres": 8, "lowres16": 16}
"""The low-res place representations and the blocks per side of their images: the paper's
8x8 grid of 32x32-pixel blocks (``"lowres"``, 64 values a place) and a 16x16 grid of
16x16-pixel blocks (``"lowres16"``, 256 values a place)."""


def _check_frames(frames: np.ndarray) -> np.ndarray:
    a = np.asarray(frames)
    if a.ndim < 2 or a.shape[-2:] != (SENSOR_SIZE, SENSOR_SIZE):
        raise PpalocError(
            f"sensor frames must have shape (..., 256, 256), got {a.shape}; "
            "convert frames with ppaloc.datasets.to_sensor first"
        )
    if a.dtype != np.uint8:
        raise PpalocError(
            f"sensor frames must be uint8, got {a.dtype}; "
            "convert frames with ppaloc.datasets.to_sensor first"
        )
    return a


def block_sums(frames: np.ndarray, grid: int = 8) -> np.ndarray:
    """Return the exact pixel sums over a ``grid`` x ``grid`` partition of each frame.

    Parameters
    ----------
    frames : ndarray of uint8, shape (..., 256, 256)
        Sensor frames (any number of leading axes).
    grid : int
        Blocks per side; must divide 256. Each block is ``256 // grid`` pixels square.

    Returns
    -------
    ndarray of uint32, shape (..., grid, grid)
        Sum of the pixels of each block (at most ``255 * 256**2``, so uint32 is exact).
    """
    a = _check_frames(frames)
    if not isinstance(grid, int | np.integer) or grid < 1 or SENSOR_SIZE % grid:
        raise ValueError(f"grid={grid!r} must be a positive integer dividing 256 (e.g. 8)")
    b = SENSOR_SIZE // grid
    lead = a.shape[:-2]
    # Sum along columns first (contiguous), then along rows.
    cols = a.reshape(*lead, SENSOR_SIZE, grid, b).sum(axis=-1, dtype=np.uint32)
    return cols.reshape(*lead, grid, b, grid).sum(axis=-2, dtype=np.uint32)


def block_means(frames: np.ndarray, grid: int = 8) -> np.ndarray:
    """Return the exact block means of sensor frames.

    Parameters
    ----------
    frames : ndarray of uint8, shape (..., 256, 256)
        Sensor frames (any number of leading axes).
    grid : int
        Blocks per side; must divide 256 (default 8: 32x32-pixel blocks, the paper's grid).

    Returns
    -------
    ndarray of float64, shape (..., grid, grid)
        Mean pixel value of each block, in [0, 255]. Exact: a block sum divided by a
        power of two is representable in float64.

    Examples
    --------
    >>> import numpy as np
    >>> block_means(np.full((256, 256), 7, np.uint8), grid=2)
    array([[7., 7.],
           [7., 7.]])
    """
    sums = block_sums(frames, grid)
    b = SENSOR_SIZE // grid
    return sums / float(b * b)


def lowres_grid(kind: str) -> int | None:
    """Blocks per side of a low-res representation's image, None for any other kind.

    Examples
    --------
    >>> lowres_grid("lowres16"), lowres_grid("lbp")
    (16, None)
    """
    return LOWRES_GRIDS.get(kind)


def tile_cells(grid: int, patch: int | None) -> int | None:
    """Cells a side of a contrast tile on a ``grid`` x ``grid`` image.

    ``patch`` counts 32x32-pixel blocks (the paper's grid, ``FilterParams.contrast_patch``),
    so a tile covers the same pixels on every grid: ``patch`` cells on the 8x8 grid,
    ``2 patch`` on the 16x16 one. None (the whole image) stays None.

    Examples
    --------
    >>> tile_cells(8, 2), tile_cells(16, 2), tile_cells(16, None)
    (2, 4, None)
    """
    return None if patch is None else patch * grid // 8


def lowres_image(frames: np.ndarray, grid: int = 8) -> np.ndarray:
    """Return the low-resolution node image: the block means rounded down.

    This is the node held in a map of kind ``"lowres"`` (docs/ppa8.md): the 8x8 block
    means ``floor(block sum / 1024)``, so a node fits one uint8 per block. ``grid=16``
    gives the ``"lowres16"`` node, ``floor(block sum / 256)`` over 16x16-pixel blocks.

    Parameters
    ----------
    frames : ndarray of uint8, shape (..., 256, 256)
    grid : {8, 16}
        Blocks per side (:data:`LOWRES_GRIDS`).

    Returns
    -------
    ndarray of uint8, shape (..., grid, grid)

    Examples
    --------
    >>> import numpy as np
    >>> frame = np.zeros((256, 256), np.uint8)
    >>> frame[:32, :32] = 200
    >>> frame[0, 0] = 0  # the top-left block's mean drops to 199.8...
    >>> lowres_image(frame)[0, :2]
    array([199,   0], dtype=uint8)
    """
    if grid not in LOWRES_GRIDS.values():
        raise ValueError(f"grid={grid!r} is not a low-res grid; use 8 or 16")
    pixels = (SENSOR_SIZE // grid) ** 2  # a power of two: the floor is a shift
    return (block_sums(frames, grid) >> (pixels.bit_length() - 1)).astype(np.uint8)
