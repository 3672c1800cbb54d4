"""The 32-bit LBP place descriptor, bit packing and Hamming distance by popcount."""

from __future__ import annotations

import numpy as np

from ppaloc.place.grid import block_sums

__all__ = [
    "LBP_BITS",
    "hamming",
    "lbp_descriptor",
    "lbp_from_grid",
    "lbp_grid",
    "pack_bits",
    "unpack_bits",
]

LBP_BITS = 32
"""Bits in one descriptor: four 3x3 cells, eight neighbour comparisons each."""

# (row, col) offsets of the eight neighbours within a 3x3 cell, MSB first: clockwise from
# the top-left (docs/ppa8.md).
_NEIGHBOURS = ((0, 0), (0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0))
# (row, col) of each cell's top-left corner in the 6x6 grid, in concatenation order (MSB first).
_CELLS = ((0, 0), (0, 3), (3, 0), (3, 3))


def lbp_grid(frames: np.ndarray) -> np.ndarray:
    """Return the 6x6 grid the descriptor is computed from: the central 6x6 of the 8x8 means.

    Parameters
    ----------
    frames : ndarray of uint8, shape (..., 256, 256)

    Returns
    -------
    ndarray of float64, shape (..., 6, 6)
        Exact means of the 32x32-pixel blocks in rows and columns 1..6 of the 8x8 grid
        (the outer ring of blocks is dropped, docs/ppa8.md).
    """
    return block_sums(frames, 8)[..., 1:7, 1:7] / 1024.0


def lbp_from_grid(grid: np.ndarray) -> np.ndarray:
    """Return the 32-bit LBP descriptor of 6x6 grids.

    The grid is cut into four 3x3 cells (top-left, top-right, bottom-left, bottom-right,
    concatenated MSB first). In each cell, bit = 1 where a neighbour >= the centre, the
    neighbours taken MSB first clockwise from the top-left: top-left, top, top-right,
    right, bottom-right, bottom, bottom-left, left.

    Parameters
    ----------
    grid : ndarray, shape (..., 6, 6)
        Any real or integer values (block means or block sums give the same codes).

    Returns
    -------
    ndarray of uint32, shape (...)

    Examples
    --------
    >>> import numpy as np
    >>> g = np.zeros((6, 6))  # every neighbour equals its centre: all bits set
    >>> hex(int(lbp_from_grid(g)))
    '0xffffffff'
    >>> g[1, 1] = 1.0  # the top-left cell's centre now exceeds all its neighbours
    >>> hex(int(lbp_from_grid(g)))
    '0xffffff'
    """
    g = np.asarray(grid)
    if g.ndim < 2 or g.shape[-2:] != (6, 6):
        raise ValueError(f"an LBP grid must have shape (..., 6, 6), got {g.shape}")
    code = np.zeros(g.shape[:-2], dtype=np.uint32)
    bit = LBP_BITS
    for r0, c0 in _CELLS:
        centre = g[..., r0 + 1, c0 + 1]
        for dr, dc in _NEIGHBOURS:
            bit -= 1
            ge = g[..., r0 + dr, c0 + dc] >= centre
            code |= ge.astype(np.uint32) << np.uint32(bit)
    return code


def lbp_descriptor(frames: np.ndarray) -> np.ndarray:
    """Return the 32-bit LBP place descriptor of sensor frames (docs/ppa8.md).

    Parameters
    ----------
    frames : ndarray of uint8, shape (..., 256, 256)

    Returns
    -------
    ndarray of uint32, shape (...)
        ``lbp_from_grid(lbp_grid(frames))``; comparisons are made on exact block sums.
    """
    # Block sums order exactly like the means (a common positive factor), in integers.
    return lbp_from_grid(block_sums(frames, 8)[..., 1:7, 1:7])


def unpack_bits(codes: np.ndarray) -> np.ndarray:
    """Return the bits of 32-bit descriptors, MSB first.

    Parameters
    ----------
    codes : ndarray of uint32, shape (...)

    Returns
    -------
    ndarray of uint8, shape (..., 32)
        Element ``k`` is bit ``31 - k`` of the code (0 or 1).
    """
    c = np.asarray(codes, dtype=np.uint32)
    shifts = np.arange(LBP_BITS - 1, -1, -1, dtype=np.uint32)
    return ((c[..., None] >> shifts) & np.uint32(1)).astype(np.uint8)


def pack_bits(bits: np.ndarray) -> np.ndarray:
    """Inverse of :func:`unpack_bits`: 32 bits (MSB first) per code to uint32.

    Parameters
    ----------
    bits : ndarray of 0/1 or bool, shape (..., 32)

    Returns
    -------
    ndarray of uint32, shape (...)
    """
    b = np.asarray(bits)
    if b.ndim < 1 or b.shape[-1] != LBP_BITS:
        raise ValueError(f"bits must have shape (..., 32), got {b.shape}")
    if b.size and not np.isin(b, (0, 1)).all():
        raise ValueError("bits must be 0 or 1")
    shifts = np.arange(LBP_BITS - 1, -1, -1, dtype=np.uint32)
    return np.bitwise_or.reduce(b.astype(np.uint32) << shifts, axis=-1).astype(np.uint32)


def hamming(
    query: np.ndarray | int, nodes: np.ndarray, *, out: np.ndarray | None = None
) -> np.ndarray:
    """Return the Hamming distances between one descriptor and N node descriptors.

    Parameters
    ----------
    query : uint32 scalar or 0-d array
        The live frame's descriptor.
    nodes : ndarray of uint32, shape (N,)
        The map's descriptors.
    out : ndarray of uint8, shape (N,), optional
        Where to write the result (saves an allocation per frame).

    Returns
    -------
    ndarray of uint8, shape (N,)
        ``popcount(query XOR nodes)``, in [0, 32].

    Examples
    --------
    >>> import numpy as np
    >>> hamming(np.uint32(0b1011), np.array([0, 0b1011, 0xFFFFFFFF], np.uint32))
    array([ 3,  0, 29], dtype=uint8)
    """
    n = np.asarray(nodes)
    if n.dtype != np.uint32:
        raise ValueError(f"node descriptors must be uint32, got {n.dtype}")
    if not 0 <= int(query) < 2**LBP_BITS:
        raise ValueError(f"query={int(query)} is not a 32-bit descriptor (0 .. 2**32 - 1)")
    q = np.uint32(query)
    if out is None:
        out = np.empty(n.shape, dtype=np.uint8)
    # XOR into a chunked scratch buffer so it stays in cache, then popcount into ``out``.
    flat_n = n.reshape(-1)
    flat_o = out.reshape(-1)
    step = _HAMMING_CHUNK
    if flat_n.size <= step:
        np.bitwise_count(np.bitwise_xor(flat_n, q), out=flat_o)
        return out
    scratch = np.empty(step, dtype=np.uint32)
    for start in range(0, flat_n.size, step):
        stop = min(start + step, flat_n.size)
        s = scratch[: stop - start]
        np.bitwise_xor(flat_n[start:stop], q, out=s)
        np.bitwise_count(s, out=flat_o[start:stop])
    return out


_HAMMING_CHUNK = 1 << 14
