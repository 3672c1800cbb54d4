"""A map of low-resolution nodes laid out for fast distance queries (many frames, one map)."""

from __future__ import annotations

import numpy as np

from ppaloc.place.sad import _as_images

__all__ = ["LowresIndex"]


class LowresIndex:
    """Low-resolution node images stored cell-major in cache-sized blocks.

    Building the index once lets every later query run at memory speed: the nodes are
    stored as ``(n_blocks, cells, block)`` uint8, so each step reads contiguous rows of one
    cell across ``block`` nodes, and the per-node sum over cells is a reduction along the
    first (slow) axis, which numpy vectorises far better than a reduction along 64
    contiguous bytes. Scratch buffers of one block stay in the L2 cache.

    Parameters
    ----------
    nodes : ndarray of uint8, shape (N, H, W)
        Node images (usually (N, 8, 8), see :func:`ppaloc.place.lowres_image`). H*W <= 257
        so that a SAD fits uint16.
    block : int
        Nodes per block (default 2048: a block of 8x8 nodes is 128 KiB).

    Examples
    --------
    >>> import numpy as np
    >>> nodes = np.stack([np.zeros((8, 8), np.uint8), np.full((8, 8), 2, np.uint8)])
    >>> index = LowresIndex(nodes)
    >>> index.sad(np.ones((8, 8), np.uint8))
    array([64, 64], dtype=uint16)
    """

    def __init__(self, nodes: np.ndarray, *, block: int = 2048) -> None:
        n = _as_images(nodes, "nodes", 1)
        if block < 1:
            raise ValueError(f"block={block} must be a positive number of nodes")
        self.image_shape: tuple[int, int] = (int(n.shape[1]), int(n.shape[2]))
        cells = self.image_shape[0] * self.image_shape[1]
        if cells * 255 >= 2**16:
            raise ValueError(f"images of {cells} cells are too large for a uint16 SAD (max 257)")
        self._n = len(n)
        self._block = int(block)
        n_blocks = -(-self._n // self._block)
        padded = np.zeros((n_blocks * self._block, cells), np.uint8)
        padded[: self._n] = n.reshape(self._n, cells)
        self._blocks = np.ascontiguousarray(
            padded.reshape(n_blocks, self._block, cells).transpose(0, 2, 1)
        )

    def __len__(self) -> int:
        return self._n

    @property
    def cells(self) -> int:
        """Cells per image (64 for 8x8 nodes)."""
        return self._blocks.shape[1]

    def nodes(self) -> np.ndarray:
        """Return the node images, shape (N, H, W) uint8 (a copy)."""
        flat = self._blocks.transpose(0, 2, 1).reshape(-1, self.cells)[: self._n]
        return flat.reshape(self._n, *self.image_shape).copy()

    def _query(self, query: np.ndarray) -> np.ndarray:
        q = np.asarray(query)
        if q.shape != self.image_shape:
            raise ValueError(f"the query has shape {q.shape}, the nodes {self.image_shape}")
        return q.reshape(self.cells, 1)

    def _out(self, out: np.ndarray | None, dtype: type) -> np.ndarray:
        if out is None:
            return np.empty(self._n, dtype)
        if out.shape != (self._n,) or out.dtype != dtype:
            raise ValueError(
                f"out must have shape ({self._n},) and dtype {np.dtype(dtype)}, "
                f"got {out.shape} {out.dtype}"
            )
        return out

    def sad(self, query: np.ndarray, *, out: np.ndarray | None = None) -> np.ndarray:
        """Return the SAD between an integer image and every node.

        Parameters
        ----------
        query : ndarray of uint8, shape (H, W)
        out : ndarray of uint16, shape (N,), optional

        Returns
        -------
        ndarray of uint16, shape (N,)
            Equal to :func:`ppaloc.place.sad` (which returns int64).
        """
        q = _as_images(self._query(query), "query", 0)
        # A full block-shaped query is faster to stream than a broadcast column.
        q = np.ascontiguousarray(np.broadcast_to(q, (self.cells, self._block)))
        out = self._out(out, np.uint16)
        hi = np.empty((self.cells, self._block), np.uint8)
        lo = np.empty_like(hi)
        tail = np.empty(self._block, np.uint16)
        for i, nb in enumerate(self._blocks):
            np.maximum(nb, q, out=hi)
            np.minimum(nb, q, out=lo)
            np.subtract(hi, lo, out=hi)
            self._reduce_into(hi, i, out, tail)
        return out

    def _reduce_into(self, d: np.ndarray, i: int, out: np.ndarray, tail: np.ndarray) -> None:
        start = i * self._block
        stop = min(start + self._block, self._n)
        if stop - start == self._block:
            np.add.reduce(d, axis=0, dtype=out.dtype, out=out[start:stop])
        else:
            np.add.reduce(d, axis=0, dtype=out.dtype, out=tail)
            out[start:stop] = tail[: stop - start]

    def sad_to_sums(self, sums: np.ndarray, *, cap: int | None = None) -> np.ndarray:
        """Return the exact L1 distance from unquantised block means to every node.

        With block sums ``S`` over ``P`` pixels (``P = 1024`` for 32x32 blocks), the live
        frame's exact block means are ``m = S / P``; this returns, per node ``n``,

        ``D = sum over cells of min(|S - P * n|, P * cap)``

        in integers, i.e. ``P`` times the sum of ``min(|m - n|, cap)``. This is what the
        ``ppa8`` low-res likelihood needs (docs/ppa8.md: ``|f - n| = |m - n| / 2`` in
        register units, clipped at 127, i.e. ``cap=254``), without widening the map.

        Parameters
        ----------
        sums : ndarray of int, shape (H, W)
            Block sums of the live frame (:func:`ppaloc.place.block_sums`), each in
            ``[0, 255 * P]``.
        cap : int, optional
            Per-cell clip of ``|m - n|`` in grey levels; None for no clip.

        Returns
        -------
        ndarray of int64, shape (N,)

        Notes
        -----
        With ``m = a + r / P`` (``a = floor(m)``), for an integer node value ``n``:
        ``P |m - n| = P |a - n| + r`` if ``n <= a`` and ``P |a - n| - r`` otherwise, so
        ``D = P * SAD(a, n) + sum(r) - 2 * sum(r * [n > a])``: one uint8 SAD plus one
        mask-weighted sum in uint16 (``sum(r) <= 64 * 1023 < 2**16``), both in one pass
        over each cache-resident block. Cells where the cap can bind are corrected one
        row at a time (for ``cap=254`` only cells with ``m > 254`` or ``m < 1``).
        """
        s = np.asarray(sums)
        if s.shape != self.image_shape or not np.issubdtype(s.dtype, np.integer):
            raise ValueError(f"sums must be integers of shape {self.image_shape}, got {s.shape}")
        s = s.reshape(self.cells).astype(np.int64)
        p = 1024
        if s.min() < 0 or s.max() > 255 * p:
            raise ValueError(f"block sums must lie in [0, {255 * p}] (32x32 blocks of uint8)")
        a = (s // p).astype(np.uint8).reshape(self.cells, 1)
        r = (s % p).astype(np.uint16).reshape(self.cells, 1)
        r_total = int(r.sum())
        a = np.ascontiguousarray(np.broadcast_to(a, (self.cells, self._block)))
        out = np.empty(self._n, np.int64)
        hi = np.empty((self.cells, self._block), np.uint8)
        lo = np.empty_like(hi)
        masked = np.empty((self.cells, self._block), np.uint16)
        sad = np.empty(self._block, np.uint16)
        weighted = np.empty(self._block, np.uint16)  # sum(r) <= 64 * 1023 < 2**16
        total = np.empty(self._block, np.int64)
        for i, nb in enumerate(self._blocks):
            # One pass over the block while it is in cache: SAD to floor(m), then the
            # mask-weighted sum of the remainders.
            np.maximum(nb, a, out=hi)
            np.minimum(nb, a, out=lo)
            np.subtract(hi, lo, out=hi)
            np.add.reduce(hi, axis=0, dtype=np.uint16, out=sad)
            np.greater(nb, a, out=masked)
            np.multiply(masked, r, out=masked)
            np.add.reduce(masked, axis=0, out=weighted)
            np.multiply(sad, p, out=total, dtype=np.int64)
            total += r_total
            total -= weighted
            total -= weighted
            start = i * self._block
            stop = min(start + self._block, self._n)
            out[start:stop] = total[: stop - start]
        if cap is not None:
            self._apply_cap(out, s, int(cap), p)
        return out

    def _apply_cap(self, out: np.ndarray, s: np.ndarray, cap: int, p: int) -> None:
        if cap < 0:
            raise ValueError(f"cap={cap} must be a non-negative number of grey levels")
        limit = cap * p
        # |S - P n| over n in 0..255 is largest at n = 0 or n = 255.
        binding = np.flatnonzero(np.maximum(s, 255 * p - s) > limit)
        for c in binding:
            row = self._blocks[:, c, :].reshape(-1)[: self._n].astype(np.int64) * p
            excess = np.abs(row - s[c]) - limit
            out -= np.maximum(excess, 0)
