"""Sum of absolute differences between low-resolution images."""

from __future__ import annotations

import numpy as np

__all__ = ["sad"]

_CHUNK = 8192  # nodes per chunk: 512 KiB of uint8 scratch, stays in L2


def _as_images(a: np.ndarray, name: str, lead: int | None) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype != np.uint8:
        if not np.issubdtype(a.dtype, np.integer) or (a.size and (a.min() < 0 or a.max() > 255)):
            raise ValueError(
                f"{name} must hold integers in 0..255 (low-res images), got dtype {a.dtype}"
            )
        a = a.astype(np.uint8)
    if lead is not None and a.ndim != 2 + lead:
        raise ValueError(f"{name} must have {2 + lead} axes (..., 8, 8), got shape {a.shape}")
    return a


def sad(query: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Return the sums of absolute differences between one image and N node images.

    Parameters
    ----------
    query : ndarray of uint8, shape (H, W)
        The low-resolution query image (usually (8, 8), see :func:`lowres_image`).
    nodes : ndarray of uint8, shape (N, H, W)
        Node images.

    Returns
    -------
    ndarray of int64, shape (N,)
        ``sum |query - nodes[i]|`` over the H*W cells.

    Notes
    -----
    ``max(a, b) - min(a, b)`` in uint8 is exact and avoids widening the node array. For
    many queries against one large map, :class:`ppaloc.place.LowresIndex` is faster.

    Examples
    --------
    >>> import numpy as np
    >>> q = np.array([[0, 10], [20, 255]], np.uint8)
    >>> sad(q, np.stack([q, np.zeros_like(q)]))
    array([  0, 285])
    """
    q = _as_images(query, "query", 0)
    n = _as_images(nodes, "nodes", 1)
    if n.shape[1:] != q.shape:
        raise ValueError(f"nodes have images of shape {n.shape[1:]}, the query {q.shape}")
    cells = q.size
    flat = n.reshape(len(n), cells)
    qf = q.reshape(cells)
    out = np.empty(len(n), dtype=np.int64)
    acc_dtype = np.uint16 if cells * 255 < 2**16 else np.uint32
    hi = np.empty((min(_CHUNK, len(n)), cells), np.uint8)
    lo = np.empty_like(hi)
    for start in range(0, len(n), _CHUNK):
        stop = min(start + _CHUNK, len(n))
        k = stop - start
        np.maximum(flat[start:stop], qf, out=hi[:k])
        np.minimum(flat[start:stop], qf, out=lo[:k])
        np.subtract(hi[:k], lo[:k], out=hi[:k])
        out[start:stop] = np.add.reduce(hi[:k], axis=1, dtype=acc_dtype)
    return out
