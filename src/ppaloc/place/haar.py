"""The 192-bit Haar-sign place: three signs per 32x32-pixel block, Hamming distance.

Each 32x32-pixel block of the sensor frame (the paper's 8x8 grid) is split into its four
16x16-pixel quarters ``a b / c d``, whose means are the 16x16 grid's codes
``floor(S / 256)`` (:func:`ppaloc.place.lowres_image` with ``grid=16``, the codes the
sensor's reduce stage reads). The block gives three bits, the signs of its three Haar
wavelets:

- horizontal: ``b + d >= a + c`` (the right half at least as bright as the left);
- vertical: ``c + d >= a + b`` (the bottom half at least as bright as the top);
- diagonal: ``a + d >= b + c``.

A sign is unchanged by a positive gain and an offset of its block's brightness, much of what a
change from day to night or summer to winter is, and the three of them keep a block's
coarse structure where an LBP code keeps one comparison per pair of blocks.
A place is 64 blocks x 3 = 192 bits, laid out on the 16x16 grid itself (:func:`haar_plane`:
the bits of block ``(i, j)`` at cells ``(2i, 2j)``, ``(2i, 2j + 1)`` and ``(2i + 1, 2j)``;
cell ``(2i + 1, 2j + 1)`` is always 0), so on the sensor a node is a 16x16 block of PEs,
one bit per PE, and the host packs the 256 cells into 8 uint32 words
(:func:`pack_plane`). Places are compared by the number of differing bits
(:func:`hamming_words`).
"""

from __future__ import annotations

import numpy as np

from ppaloc.place.grid import lowres_image

__all__ = [
    "HAAR_BITS",
    "HAAR_GRID",
    "HAAR_WORDS",
    "haar_descriptor",
    "haar_plane",
    "hamming_words",
    "pack_plane",
    "unpack_plane",
]

HAAR_GRID = 16
"""Cells a side of the plane a place is laid out on (and of the grid it is computed from)."""
HAAR_BITS = 192
"""Bits that can differ between two places: three per 32x32-pixel block."""
HAAR_WORDS = HAAR_GRID * HAAR_GRID // 32
"""uint32 words of a packed place (the 256 cells, MSB first, row by row)."""


def haar_plane(image: np.ndarray) -> np.ndarray:
    """Return the Haar-sign bits of 16x16 images, laid out on the 16x16 grid.

    Parameters
    ----------
    image : ndarray of integers, shape (..., 16, 16)
        The 16x16 grid's block means or codes (any integers that order like them).

    Returns
    -------
    ndarray of uint8, shape (..., 16, 16)
        0/1; block ``(i, j)``'s horizontal, vertical and diagonal signs at cells
        ``(2i, 2j)``, ``(2i, 2j + 1)``, ``(2i + 1, 2j)``; 0 at ``(2i + 1, 2j + 1)``.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.zeros((16, 16), np.uint8)
    >>> g[0, 1] = 9  # block (0, 0): the top-right quarter bright
    >>> haar_plane(g)[:2, :2].tolist()  # right >= left; bottom < top; a + d < b + c
    [[1, 0], [0, 0]]
    >>> int(haar_plane(np.zeros((16, 16), np.uint8)).sum())  # flat: every sign ties to 1
    192
    """
    g = np.asarray(image)
    if g.ndim < 2 or g.shape[-2:] != (HAAR_GRID, HAAR_GRID):
        raise ValueError(f"a Haar-sign image must have shape (..., 16, 16), got {g.shape}")
    g = g.astype(np.int32)
    a, b = g[..., 0::2, 0::2], g[..., 0::2, 1::2]
    c, d = g[..., 1::2, 0::2], g[..., 1::2, 1::2]
    plane = np.zeros(g.shape, np.uint8)
    plane[..., 0::2, 0::2] = b + d >= a + c
    plane[..., 0::2, 1::2] = c + d >= a + b
    plane[..., 1::2, 0::2] = a + d >= b + c
    return plane


def pack_plane(plane: np.ndarray) -> np.ndarray:
    """Pack 16x16 0/1 planes into 8 uint32 words, row by row, MSB first.

    Cell ``(r, c)`` is bit ``31 - (16 r + c) % 32`` of word ``(16 r + c) // 32``.

    Examples
    --------
    >>> import numpy as np
    >>> p = np.zeros((16, 16), np.uint8)
    >>> p[0, 0] = p[15, 15] = 1
    >>> [hex(int(w)) for w in pack_plane(p)[[0, 7]]]
    ['0x80000000', '0x1']
    """
    p = np.asarray(plane)
    if p.ndim < 2 or p.shape[-2:] != (HAAR_GRID, HAAR_GRID):
        raise ValueError(f"a Haar-sign plane must have shape (..., 16, 16), got {p.shape}")
    bits = p.reshape(*p.shape[:-2], HAAR_WORDS, 32).astype(np.uint32)
    shifts = np.arange(31, -1, -1, dtype=np.uint32)
    return np.bitwise_or.reduce(bits << shifts, axis=-1).astype(np.uint32)


def unpack_plane(words: np.ndarray) -> np.ndarray:
    """Inverse of :func:`pack_plane`: (..., 8) uint32 words to (..., 16, 16) uint8 0/1."""
    w = np.asarray(words, dtype=np.uint32)
    if w.ndim < 1 or w.shape[-1] != HAAR_WORDS:
        raise ValueError(f"a packed Haar-sign place must have shape (..., 8), got {w.shape}")
    shifts = np.arange(31, -1, -1, dtype=np.uint32)
    bits = (w[..., None] >> shifts) & np.uint32(1)
    return bits.reshape(*w.shape[:-1], HAAR_GRID, HAAR_GRID).astype(np.uint8)


def haar_descriptor(frames: np.ndarray) -> np.ndarray:
    """Return the packed Haar-sign place of sensor frames.

    Parameters
    ----------
    frames : ndarray of uint8, shape (..., 256, 256)

    Returns
    -------
    ndarray of uint32, shape (..., 8)
        ``pack_plane(haar_plane(lowres_image(frames, 16)))``.
    """
    return pack_plane(haar_plane(lowres_image(frames, HAAR_GRID)))


def hamming_words(
    query: np.ndarray, nodes: np.ndarray, *, out: np.ndarray | None = None
) -> np.ndarray:
    """Return the Hamming distances between one packed place and N packed places.

    Parameters
    ----------
    query : ndarray of uint32, shape (W,)
    nodes : ndarray of uint32, shape (N, W)
    out : ndarray of uint16, shape (N,), optional
        Where to write the result.

    Returns
    -------
    ndarray of uint16, shape (N,)

    Examples
    --------
    >>> import numpy as np
    >>> nodes = np.array([[0, 0], [0xFF, 1], [0xFFFFFFFF, 0xFFFFFFFF]], np.uint32)
    >>> hamming_words(np.array([0, 1], np.uint32), nodes).tolist()
    [1, 8, 63]
    """
    n = np.asarray(nodes)
    q = np.asarray(query)
    if n.dtype != np.uint32 or q.dtype != np.uint32:
        raise ValueError(f"packed places must be uint32, got {q.dtype} and {n.dtype}")
    if n.ndim != 2 or q.shape != n.shape[1:]:
        raise ValueError(f"a place of shape {q.shape} cannot be compared with nodes {n.shape}")
    if out is None:
        out = np.empty(len(n), np.uint16)
    out[:] = 0
    word = np.empty(len(n), np.uint8)
    for k in range(n.shape[1]):  # word by word: no (N, W) temporary
        np.bitwise_count(np.bitwise_xor(n[:, k], q[k]), out=word)
        out += word
    return out
