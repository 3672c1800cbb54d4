"""A global LDB-style binary descriptor of a whole image (the descriptor of ABLE-M).

LDB (Local Difference Binary; Yang & Cheng, ISMAR 2012 / TPAMI 2014) splits a patch into
grids of several sizes and compares grid cells pairwise on three features: the mean
intensity and the mean horizontal and vertical gradients of the cell. ABLE-M (Arroyo et
al.) applies it once to the whole image, resized to a 64x64 patch, to get one global binary
code per frame.

The exact variant implemented here:

- the image is the whole sensor frame reduced to ``side`` x ``side`` block means
  (default 64, OpenABLE's ``Patch_size``);
- grid levels ``(2, 3, 4, 5)``: level ``g`` cuts the image into ``g`` x ``g`` cells with
  edges ``floor(i * side / g)``;
- per cell: ``I`` = mean intensity, ``dx`` = mean of the right half minus mean of the left
  half, ``dy`` = mean of the bottom half minus mean of the top half (halves split at
  ``lo + (hi - lo) // 2``);
- per level, for every pair of cells ``i < j`` in row-major order and every feature in the
  order ``(I, dx, dy)``: one bit, ``f(i) > f(j)`` (strict; equal values give 0);
- levels concatenated in order: 3 x (6 + 36 + 120 + 300) = 1386 comparisons;
- ``n_bits`` of them are kept: a fixed subset drawn with
  ``numpy.random.default_rng(bit_seed)`` and kept in comparison order. ABLE-M's default is
  OpenABLE's: its copy of the LDB code is built with the training switch on, which keeps
  a random 1384 of the 1386 comparisons (173 bytes) instead of the 256 bits (32 bytes)
  of LDB's learned table.
- bits are packed most-significant first into bytes (:func:`numpy.packbits`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ppaloc.errors import PpalocError

__all__ = [
    "cell_features",
    "comparison_count",
    "hamming_distances",
    "ldb_comparisons",
    "naive_hamming",
    "selected_bits",
]


def _integral(image: np.ndarray) -> np.ndarray:
    a = np.asarray(image, dtype=np.float64)
    out = np.zeros((a.shape[0] + 1, a.shape[1] + 1))
    out[1:, 1:] = a.cumsum(axis=0).cumsum(axis=1)
    return out


def _box_mean(ii: np.ndarray, r0, r1, c0, c1) -> np.ndarray:
    total = ii[r1, c1] - ii[r0, c1] - ii[r1, c0] + ii[r0, c0]
    return total / ((r1 - r0) * (c1 - c0))


def cell_features(image: np.ndarray, grid: int) -> np.ndarray:
    """Mean intensity and mean gradients of every cell of a ``grid`` x ``grid`` partition.

    Parameters
    ----------
    image : ndarray, shape (H, W)
        Grey image; each cell must be at least 2 pixels on each side.
    grid : int
        Cells per side.

    Returns
    -------
    ndarray of float64, shape (grid * grid, 3)
        Rows in row-major cell order; columns ``(I, dx, dy)``.

    Examples
    --------
    >>> cell_features(np.array([[0, 1, 2, 3]] * 4), 2).tolist()
    [[0.5, 1.0, 0.0], [2.5, 1.0, 0.0], [0.5, 1.0, 0.0], [2.5, 1.0, 0.0]]
    """
    a = np.asarray(image)
    h, w = a.shape
    if grid < 1 or h // grid < 2 or w // grid < 2:
        raise PpalocError(
            f"an LDB grid of {grid}x{grid} cells needs an image of at least {2 * grid} pixels "
            f"per side, got shape {a.shape}; use a larger side or fewer levels"
        )
    ii = _integral(a)
    re = (np.arange(grid + 1) * h) // grid
    ce = (np.arange(grid + 1) * w) // grid
    r0, c0 = np.meshgrid(re[:-1], ce[:-1], indexing="ij")
    r1, c1 = np.meshgrid(re[1:], ce[1:], indexing="ij")
    r0, r1, c0, c1 = (x.ravel() for x in (r0, r1, c0, c1))
    rm = r0 + (r1 - r0) // 2
    cm = c0 + (c1 - c0) // 2
    mean = _box_mean(ii, r0, r1, c0, c1)
    dx = _box_mean(ii, r0, r1, cm, c1) - _box_mean(ii, r0, r1, c0, cm)
    dy = _box_mean(ii, rm, r1, c0, c1) - _box_mean(ii, r0, rm, c0, c1)
    return np.stack((mean, dx, dy), axis=1)


def comparison_count(levels: tuple[int, ...]) -> int:
    """Number of binary comparisons over ``levels``: 3 x sum of C(g*g, 2)."""
    return sum(3 * (g * g) * (g * g - 1) // 2 for g in levels)


def ldb_comparisons(image: np.ndarray, levels: tuple[int, ...] = (2, 3, 4, 5)) -> np.ndarray:
    """All LDB comparisons of one image, unpacked.

    Returns
    -------
    ndarray of bool, shape (comparison_count(levels),)
        Level by level; within a level, pair ``(i, j)``, ``i < j`` in row-major cell order
        (``numpy.triu_indices``), and within a pair the features ``I, dx, dy``.

    Examples
    --------
    >>> ldb_comparisons(np.array([[0, 1, 2, 3]] * 4), (2,)).astype(int).tolist()
    [0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0]
    """
    out = []
    for g in levels:
        f = cell_features(image, g)
        i, j = np.triu_indices(g * g, k=1)
        out.append((f[i] > f[j]).ravel())
    return np.concatenate(out)


@lru_cache(maxsize=16)
def _selection(total: int, n_bits: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = np.sort(rng.choice(total, size=n_bits, replace=False))
    out.flags.writeable = False  # shared by every caller through the cache
    return out


def selected_bits(total: int, n_bits: int | None, seed: int) -> np.ndarray:
    """Indices of the comparisons kept: all of them, or a fixed seeded subset of ``n_bits``.

    Returns
    -------
    ndarray of int64, shape (n_bits,), increasing
        Read-only when it is a cached subset.
    """
    if n_bits is None or n_bits == total:
        return np.arange(total)
    if not 1 <= n_bits <= total:
        raise PpalocError(
            f"n_bits={n_bits} must be between 1 and the {total} comparisons the levels give "
            "(or None for all of them)"
        )
    return _selection(total, int(n_bits), int(seed))


def hamming_distances(query: np.ndarray, codes: np.ndarray) -> np.ndarray:
    """Hamming distance between one packed code and every packed code, by true popcount.

    Parameters
    ----------
    query : ndarray of uint8, shape (B,)
    codes : ndarray of uint8, shape (N, B)

    Returns
    -------
    ndarray of int64, shape (N,)
        Number of differing *bits* (XOR, then a population count of each byte). Summing the
        XOR-ed byte values instead, as one public ABLE implementation does, weighs bit k of a
        byte by 2**k and is not a Hamming distance.
    """
    x = np.bitwise_xor(np.asarray(codes, np.uint8), np.asarray(query, np.uint8))
    return np.bitwise_count(x).sum(axis=-1, dtype=np.int64)


def naive_hamming(a: np.ndarray, b: np.ndarray) -> int:
    """Reference Hamming distance of two packed codes, one bit at a time (slow; for tests)."""
    total = 0
    xs, ys = np.asarray(a, np.uint8).tolist(), np.asarray(b, np.uint8).tolist()
    for x, y in zip(xs, ys, strict=True):
        z = x ^ y
        for bit in range(8):
            total += (z >> bit) & 1
    return total
