"""The node descriptors an image baseline can compare: its own image or the filter's place.

SeqSLAM, the particle filter and single-frame matching compare, by default, SeqSLAM's
patch-normalised 64x32 image (2048 values per place, :mod:`ppaloc.place.patch`). To
tell a method's filter from its descriptor, each of them also takes exactly the place the
weighted-node filter stores (``descriptor=``):

``"patch"`` (default)
    the method's published image: 32x64 block means, 8x8 patches normalised, compared by
    the mean absolute difference per pixel;
``"lowres"``
    the weighted-node filter's low-res place: the 8x8 block means of the sensor frame
    (:func:`ppaloc.place.lowres_image`) contrast-normalised as its robust preset does
    (:func:`ppaloc.place.normalise_contrast` with :data:`LOWRES_CONTRAST`), 64 ``uint8``
    values, compared by the mean absolute difference per cell (the filter's SAD / 64);
``"lowres16"``
    the same on the 16x16 grid (16x16-pixel blocks, tiles of the same 64x64 pixels), 256
    ``uint8`` values, the filter's ``lowres16`` place;
``"lbp"``
    the weighted-node filter's 32-bit LBP code (:func:`ppaloc.place.lbp_descriptor`),
    compared by the Hamming distance (0 .. 32 bits);
``"haar"``
    the weighted-node filter's 192 Haar signs (:func:`ppaloc.place.haar_descriptor`),
    compared by the Hamming distance (0 .. 192 bits).

The functions of :mod:`ppaloc.place` compute both, so a baseline and the filter see the
same integers. Everything else a method does (contrast enhancement of the difference
column, the line search, the particles, the uniqueness confidence) is unchanged.
"""

from __future__ import annotations

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.params import DEFAULT_CONTRAST, DEFAULT_CONTRAST_PATCH
from ppaloc.place import (
    LOWRES_GRIDS,
    haar_descriptor,
    hamming,
    hamming_words,
    lbp_descriptor,
    lowres_image,
    normalise_contrast,
    sad,
    tile_cells,
)
from ppaloc.place.patch import check_frame

__all__ = [
    "DESCRIPTORS",
    "LOWRES_CONTRAST",
    "LOWRES_PATCH",
    "check_descriptor",
    "haar_distances",
    "haar_place",
    "lbp_distances",
    "lbp_place",
    "lowres_distances",
    "lowres_place",
]

DESCRIPTORS = ("patch", "lowres", "lowres16", "lbp", "haar")
"""The values of an image baseline's ``descriptor`` parameter, the default first."""

LOWRES_CONTRAST = DEFAULT_CONTRAST
"""Mean absolute deviation (grey levels) the ``"lowres"`` place is normalised to: the
robust weighted-node filter's default ``contrast`` (48)."""

LOWRES_PATCH = DEFAULT_CONTRAST_PATCH
"""Side (blocks) of the tiles the ``"lowres"`` place normalises each on its own: the
robust weighted-node filter's default ``contrast_patch`` (2)."""

_WHAT = {
    "patch": "its own 64x32 patch-normalised image",
    "lowres": "the weighted-node filter's contrast-normalised 8x8 image",
    "lowres16": "the weighted-node filter's contrast-normalised 16x16 image",
    "lbp": "the weighted-node filter's 32-bit LBP code",
    "haar": "the weighted-node filter's 192 Haar signs",
    "ldb": "its own LDB code",
}


def lowres_place(frame: np.ndarray, kind: str = "lowres") -> np.ndarray:
    """The weighted-node filter's low-res place of one sensor frame.

    Parameters
    ----------
    frame : ndarray of uint8, shape (256, 256)
    kind : {"lowres", "lowres16"}
        The 8x8 or the 16x16 grid (:data:`ppaloc.place.LOWRES_GRIDS`).

    Returns
    -------
    ndarray of uint8, shape (grid, grid)
        ``normalise_contrast(lowres_image(frame), LOWRES_CONTRAST, LOWRES_PATCH)``: the
        floored 8x8 block means, each 2x2 tile of blocks offset to 128 and scaled to a
        mean absolute deviation near 48 grey levels (on the 16x16 grid each 4x4 tile, the
        same pixels).

    Examples
    --------
    >>> frame = np.zeros((256, 256), np.uint8)
    >>> frame[:, 32:64] = 100  # block column 1 is 100, the rest 0
    >>> lowres_place(frame)[0].tolist()  # tile (0, 1): mean 50 -> 128, gain x1; flat: 128
    [78, 178, 128, 128, 128, 128, 128, 128]
    """
    grid = LOWRES_GRIDS[kind]
    image = lowres_image(check_frame(frame), grid)
    return normalise_contrast(image, LOWRES_CONTRAST, tile_cells(grid, LOWRES_PATCH))


def lbp_place(frame: np.ndarray) -> np.ndarray:
    """The weighted-node filter's 32-bit LBP place descriptor of one sensor frame.

    Returns
    -------
    ndarray of uint32, shape ()
        :func:`ppaloc.place.lbp_descriptor` of the frame.
    """
    return np.asarray(lbp_descriptor(check_frame(frame)), dtype=np.uint32)


def lowres_distances(query: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Mean absolute difference per cell between one low-res place and every node.

    Parameters
    ----------
    query : ndarray of uint8, shape (H, W)
    nodes : ndarray of uint8, shape (N, H, W)

    Returns
    -------
    ndarray of float64, shape (N,)
        ``sad(query, nodes) / (H W)``, exactly (a SAD is an integer).

    Examples
    --------
    >>> q = np.full((8, 8), 128, np.uint8)
    >>> nodes = np.stack([q, q + 2, q - 64])
    >>> lowres_distances(q, nodes).tolist()
    [0.0, 2.0, 64.0]
    """
    return sad(query, nodes) / float(np.asarray(query).size)


def lbp_distances(query: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Hamming distance between one LBP code and every node's, in bits.

    Parameters
    ----------
    query : uint32 scalar or 0-d array
    nodes : ndarray of uint32, shape (N,)

    Returns
    -------
    ndarray of float64, shape (N,)
        ``popcount(query XOR nodes[i])`` in 0 .. 32.

    Examples
    --------
    >>> lbp_distances(np.uint32(0b1011), np.array([0, 0b1011, 0xFFFFFFFF], np.uint32)).tolist()
    [3.0, 0.0, 29.0]
    """
    return hamming(query, nodes).astype(np.float64)


def haar_place(frame: np.ndarray) -> np.ndarray:
    """The weighted-node filter's Haar-sign place of one sensor frame: uint32, shape (8,)
    (:func:`ppaloc.place.haar_descriptor`)."""
    return haar_descriptor(check_frame(frame))


def haar_distances(query: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Hamming distance between one Haar-sign place and every node's, in bits (0 .. 192).

    Examples
    --------
    >>> q = np.zeros(8, np.uint32)
    >>> haar_distances(q, np.array([q, q + 3], np.uint32)).tolist()
    [0.0, 16.0]
    """
    return hamming_words(np.asarray(query, np.uint32), nodes).astype(np.float64)


def check_descriptor(
    method: str,
    descriptor: str,
    own: dict[str, tuple[object, object]],
    *,
    allowed: tuple[str, ...] = DESCRIPTORS,
) -> str:
    """Check a baseline's ``descriptor`` and that its own image parameters are left alone.

    Parameters
    ----------
    method : str
        The class's name, for the message.
    descriptor : str
        The value given.
    own : dict
        The parameters that shape only the method's own descriptor (the first of
        ``allowed``): name -> (value given, default). Another descriptor ignores them, so
        a value other than the default is a contradiction.
    allowed : tuple of str
        The values the method takes, its own descriptor first.

    Returns
    -------
    str
        ``descriptor``.

    Raises
    ------
    PpalocError
        One line naming the bad value and the choices, or the parameter that only the
        method's own descriptor uses.

    Examples
    --------
    >>> check_descriptor("SeqSLAM", "lbp", {"patch": (8, 8)})
    'lbp'
    >>> check_descriptor("SeqSLAM", "lbp", {"patch": (4, 8)})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: SeqSLAM patch=4 shapes descriptor='patch' only; with ...
    """
    if descriptor not in allowed:
        choices = ", ".join(f"{d!r} ({_WHAT.get(d, d)})" for d in allowed)
        raise PpalocError(f"{method} descriptor={descriptor!r} is unknown; choose {choices}")
    if descriptor != allowed[0]:
        for name, (value, default) in own.items():
            if value != default:
                raise PpalocError(
                    f"{method} {name}={value!r} shapes descriptor={allowed[0]!r} only; with "
                    f"descriptor={descriptor!r} leave it at its default {default!r}, or use "
                    f"descriptor={allowed[0]!r}"
                )
    return descriptor
