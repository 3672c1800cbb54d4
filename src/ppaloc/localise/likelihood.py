"""Per-frame distances from the live frame to every map node, exact and in one pass.

Both representations give an integer distance per node, which the filter scales by a power
of two (docs/ppa8.md, "Likelihood"):

- ``"lowres"``: ``T_i = sum over the 64 cells of min(|S_c - 1024 q_ic|, 260096)``, where
  ``S_c`` is the live frame's exact block sum and ``q_ic`` the node's uint8 image. In
  register units ``mu_i = T_i / 2**17`` (the mean over the cells of
  ``min(|f - n_i|, 127)``), because ``|f - n| = |S/1024 - q| / 2`` and a register holds
  at most 127. ``T_i < 2**24``, so it is exact in float32 as well as float64.
- ``"lbp"``: ``h_i = popcount(x XOR d_i)`` in [0, 32]; on the PPA each differing bit of the
  node's 4x8-PE block loads the DAC constant 64 and a halving tree over the 32 PEs leaves
  their mean, so in register units ``mu_i = 2 * h_i`` in [0, 64].

The live frame is *not* quantised: ``S_c = 1024 a_c + R_c`` with ``a_c = S_c >> 10`` and
``0 <= R_c < 1024``, and
``sum_c |S_c - 1024 q_c| = 1024 SAD(a, q) + sum_c R_c - 2 sum_{c: q_c > a_c} R_c``.
Both sums run byte-parallel (SWAR) on 64-bit words, the last one as two 5-bit halves of
``R`` masked by ``q > a``, so the node array is never widened. The exact distance costs
about 2.5 times the quantised SAD (:meth:`LowresDistance.sad`), which the float filter
uses.
"""

from __future__ import annotations

import numpy as np

from ppaloc.place import block_sums, hamming

__all__ = ["CLIP_TOTAL", "LbpDistance", "LowresDistance", "lowres_total_reference"]

CLIP_TOTAL = 127 * 2048
"""Per-cell cap of ``|S - 1024 q|``: a register difference of 127."""

_CHUNK = 8192  # nodes per chunk: 512 KiB of node bytes, scratch of the same size
_LOW_BYTES = np.uint64(0x00FF00FF00FF00FF)
_LANES = np.uint64(0x0001000100010001)


def lowres_total_reference(sums: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """Slow, obvious reference for :class:`LowresDistance` (tests cross-check it).

    Parameters
    ----------
    sums : ndarray of int, shape (8, 8)
        Live block sums.
    nodes : ndarray of uint8, shape (N, 8, 8)

    Returns
    -------
    ndarray of int64, shape (N,)
    """
    s = np.asarray(sums, dtype=np.int64).reshape(1, 64)
    q = np.asarray(nodes, dtype=np.int64).reshape(-1, 64) * 1024
    return np.minimum(np.abs(s - q), CLIP_TOTAL).sum(axis=1)


class LowresDistance:
    """Distances from a live frame to N low-res nodes: exact ``T_i`` or quantised SAD.

    Parameters
    ----------
    nodes : ndarray of uint8, shape (N, 8, 8)
        The map's node images. They are stored once, chunk by chunk, as the eight 64-bit
        words of each image laid out word-major (shape (chunks, 8, K)), so every step of
        the byte-parallel sum runs over long contiguous rows.
    """

    def __init__(self, nodes: np.ndarray) -> None:
        n = np.asarray(nodes)
        if n.dtype != np.uint8 or n.ndim != 3 or n.shape[1:] != (8, 8):
            raise ValueError(f"low-res nodes must be uint8 (N, 8, 8), got {n.dtype} {n.shape}")
        self.n = len(n)
        self.chunk = k = min(_CHUNK, max(self.n, 1))
        chunks = -(-self.n // k)
        flat = np.zeros((chunks * k, 64), np.uint8)
        flat[: self.n] = n.reshape(self.n, 64)
        words = flat.view(np.uint64).reshape(chunks, k, 8)
        self.words = np.ascontiguousarray(words.transpose(0, 2, 1))
        self.cells = np.ascontiguousarray(n.reshape(self.n, 64))  # for the clip correction
        self._hi = np.empty((8, k), np.uint64)
        self._lo = np.empty((8, k), np.uint64)
        self._mask = np.empty((8, 8 * k), bool)
        self._t = np.empty((8, k), np.uint64)
        self._acc = np.empty(k, np.uint64)
        self._acc2 = np.empty(k, np.uint64)

    def __len__(self) -> int:
        return self.n

    def _tile(self, cells: np.ndarray) -> np.ndarray:
        """The 64 bytes of a live image, repeated as (8, 8K) bytes in the chunk layout."""
        row = np.ascontiguousarray(cells.reshape(64).astype(np.uint8)).view(np.uint64)
        return np.repeat(row[:, None], self.chunk, axis=1).view(np.uint8)

    def _lane_sum(self, x: np.ndarray, out: np.ndarray) -> None:
        """``out[j] = sum of the 64 bytes of node j`` for x of shape (8, K) uint64 (clobbered)."""
        t = self._t
        np.right_shift(x, np.uint64(8), out=t)
        np.bitwise_and(t, _LOW_BYTES, out=t)
        np.bitwise_and(x, _LOW_BYTES, out=x)
        np.add(x, t, out=x)  # four 16-bit lanes per word, each <= 510
        np.add(x[:4], x[4:], out=x[:4])
        np.add(x[:2], x[2:4], out=x[:2])
        np.add(x[0], x[1], out=out)  # lanes <= 4080
        np.multiply(out, _LANES, out=out)  # the top lane gathers all four (<= 16320)
        np.right_shift(out, np.uint64(48), out=out)

    def sad(self, image: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Write ``SAD(image, q_i)`` (grey levels, in [0, 16320]) into ``out`` (shape (N,)).

        ``image`` is a uint8 (8, 8) low-res image (the live frame quantised like a node).
        """
        live = self._tile(np.asarray(image))
        hb, lb = self._hi.view(np.uint8), self._lo.view(np.uint8)
        for c, block in enumerate(self.words):
            x = block.view(np.uint8)
            np.maximum(x, live, out=hb)
            np.minimum(x, live, out=lb)
            np.subtract(hb, lb, out=hb)
            self._lane_sum(self._hi, self._acc)
            start = c * self.chunk
            stop = min(start + self.chunk, self.n)
            out[start:stop] = self._acc[: stop - start]
        return out

    def exact(self, frame_sums: np.ndarray, out: np.ndarray) -> np.ndarray:
        """Write the exact ``T_i`` (module doc) into ``out`` (shape (N,)).

        ``frame_sums`` are the live frame's (8, 8) block sums. ``T_i < 2**24`` is exact in
        float32.
        """
        s = np.asarray(frame_sums, dtype=np.int64).reshape(64)
        r = s & 1023
        live = self._tile(s >> 10)
        r_lo, r_hi = self._tile(r & 31), self._tile(r >> 5)
        base = np.uint64(int(r.sum()))
        hb, lb = self._hi.view(np.uint8), self._lo.view(np.uint8)
        mb = self._mask.view(np.uint8)
        acc, acc2 = self._acc, self._acc2
        for c, block in enumerate(self.words):
            x = block.view(np.uint8)
            np.maximum(x, live, out=hb)
            np.minimum(x, live, out=lb)
            np.subtract(hb, lb, out=hb)
            self._lane_sum(self._hi, acc)  # SAD(a, q)
            np.greater(x, live, out=self._mask)  # cells with q > a
            np.multiply(mb, r_hi, out=hb)
            np.multiply(mb, r_lo, out=lb)
            self._lane_sum(self._hi, acc2)
            np.left_shift(acc2, np.uint64(5), out=acc2)
            np.left_shift(acc, np.uint64(9), out=acc)
            acc -= acc2  # modulo 2**64: the final value is non-negative
            self._lane_sum(self._lo, acc2)
            acc -= acc2  # 512 SAD - sum_{q > a} R
            np.left_shift(acc, np.uint64(1), out=acc)
            acc += base
            start = c * self.chunk
            stop = min(start + self.chunk, self.n)
            out[start:stop] = acc[: stop - start]
        # Cells where the register clip can bite: |S - 1024 q| > CLIP_TOTAL for some q.
        for c in np.flatnonzero((s > CLIP_TOTAL) | (s < 255 * 1024 - CLIP_TOTAL)):
            e = np.abs(self.cells[:, c].astype(np.int64) * 1024 - s[c]) - CLIP_TOTAL
            np.maximum(e, 0, out=e)
            out -= e.astype(out.dtype)
        return out


class LbpDistance:
    """``h_i = popcount(x XOR d_i)`` from a live descriptor to N LBP nodes.

    Parameters
    ----------
    nodes : ndarray of uint32, shape (N,)
    """

    def __init__(self, nodes: np.ndarray) -> None:
        n = np.asarray(nodes)
        if n.dtype != np.uint32 or n.ndim != 1:
            raise ValueError(f"LBP nodes must be uint32 (N,), got {n.dtype} {n.shape}")
        self.nodes = np.ascontiguousarray(n)

    def __len__(self) -> int:
        return len(self.nodes)

    def __call__(self, descriptor: np.uint32 | int, out: np.ndarray) -> np.ndarray:
        """Write ``h_i`` for every node into ``out`` (uint8, shape (N,))."""
        return hamming(np.uint32(descriptor), self.nodes, out=out)


def frame_block_sums(frame: np.ndarray) -> np.ndarray:
    """Return the exact (8, 8) block sums of a sensor frame as int64."""
    return block_sums(frame, 8).astype(np.int64)
