"""ABLE-M (Arroyo et al.): global binary codes of image sequences, matched by Hamming distance.

Each frame is described by one global LDB-style binary code of the whole downsampled image
(:mod:`ppaloc.baselines.ldb`), or with ``descriptor="lbp"`` by the weighted-node filter's
32-bit LBP code (:func:`ppaloc.place.lbp_descriptor`, packed into 4 bytes most significant
first), or with ``"haar"`` by its 192 Haar signs (:func:`ppaloc.place.haar_descriptor`,
its 8 words in 32 bytes). ABLE-M is binary by construction: it takes these codes, never an
image (the weighted-node filter's low-res image or SeqSLAM's patch-normalised one). The code of a
*place* is the concatenation of the codes of the last ``L`` frames; a query sequence is
compared with the map sequence ending at every node, ``e - L + 1 .. e``, by Hamming
distance. As the Hamming distance of concatenations is
the sum of the per-frame distances, the online form keeps the per-frame distance vectors of
the last ``L`` frames and updates the sequence distance of every node in O(N) per frame:

``S_t[e] = S_{t-1}[e - 1] + h_t[e] - h_{t-L}[e - L]``

where ``h_t[e]`` is the Hamming distance between query frame ``t`` and node ``e``. Frames
before the start of the query or nodes before the start of the map count as half the bits
(the expected distance of unrelated codes), so every node can be matched from the first
frame on and the sums stay comparable.

References
----------
R. Arroyo, P. F. Alcantarilla, L. M. Bergasa, E. Romera, "Towards life-long visual
localization using an efficient matching of binary sequences from images", ICRA 2015;
OpenABLE (R. Arroyo, 2016). X. Yang and K.-T. Cheng, "LDB: An ultra-fast feature for
scalable augmented reality on mobile devices", ISMAR 2012.
"""

from __future__ import annotations

from typing import ClassVar, Literal

import numpy as np

from ppaloc.baselines._common import MapLocaliser, require_map, top_k, uniqueness_ratio
from ppaloc.baselines._descriptors import check_descriptor, haar_place, lbp_place
from ppaloc.baselines.ldb import comparison_count, hamming_distances, ldb_comparisons, selected_bits
from ppaloc.errors import PpalocError
from ppaloc.localise.base import Estimate
from ppaloc.place import HAAR_BITS, HAAR_WORDS, LBP_BITS, LOWRES_GRIDS
from ppaloc.place.grid import SENSOR_SIZE
from ppaloc.place.patch import downsample
from ppaloc.seeds import SEED_MAX
from ppaloc.topomap import TopoMap

__all__ = ["ABLEM", "sequence_distances"]

KIND = "able-m"


def sequence_distances(history: np.ndarray, fill: float) -> np.ndarray:
    """Reference (direct) sequence distance of the newest query frame to every node.

    Parameters
    ----------
    history : ndarray, shape (T, N)
        Per-frame Hamming distances ``h_0 .. h_{T-1}`` of query frames to the N nodes,
        oldest first; the last ``L = T`` frames form the sequence.
    fill : float
        Distance counted for a frame pair before the start of the map.

    Returns
    -------
    ndarray of float64, shape (N,)
        ``sum_k history[T-1-k, e-k]`` over ``k = 0 .. T-1``, with ``fill`` where ``e - k < 0``.
    """
    t, n = history.shape
    out = np.zeros(n)
    for k in range(t):
        row = history[t - 1 - k]
        out[k:] += row[: n - k] if k < n else 0.0
        out[: min(k, n)] += fill
    return out


class ABLEM(MapLocaliser):
    """ABLE-M over a 1-D map: sequences of global binary codes, online and past-only.

    Parameters
    ----------
    length : int
        Frames per sequence ``L`` (see docs/baselines.md for the choice of default).
    descriptor : {"ldb", "lbp", "haar"}
        The binary code of a frame: its own global LDB code (default), or the weighted-node
        filter's 32-bit LBP code (4 bytes) or its 192 Haar signs (32 bytes, 64 bits always
        0). Only binary codes: an image (``"lowres"``,
        ``"patch"``) is refused.
    side : int
        Side of the square image the descriptor is computed on (OpenABLE ``Patch_size``: 64);
        must divide 256; ``descriptor="ldb"`` only.
    levels : tuple of int
        LDB grid levels (LDB: 2, 3, 4, 5); ``descriptor="ldb"`` only.
    n_bits : int or None
        Comparisons kept per frame (OpenABLE: 1384 of 1386, 173 bytes; LDB's learned
        table: 256, 32 bytes); None keeps all of them; ``descriptor="ldb"`` only.
    bit_seed : int
        Seed of the fixed subset of comparisons; ``descriptor="ldb"`` only.
    confidence : {"similarity", "ratio"}
        ``"similarity"``: ``1 - d_min / (L x bits)``, the normalised similarity OpenABLE
        thresholds; ``"ratio"``: the uniqueness of the best node against the best outside
        ``+- rwindow // 2`` (as SeqSLAM).
    rwindow : int
        Window of the ``"ratio"`` confidence.
    top_k : int
        Length of ``Estimate.ranking``.
    record_weights : bool
        Put minus the sequence distance of every node in ``Estimate.weights``.
    """

    name = "able-m"
    kind = KIND
    DESCRIPTORS: ClassVar[tuple[str, ...]] = ("ldb", "lbp", "haar")

    #: Accepted range of each numeric parameter, where a value drives memory or time or
    #: leaves the method's meaning; the published defaults lie inside.
    RANGES: ClassVar[dict[str, tuple[float, float]]] = {
        "length": (1, 1000),
        "side": (8, 256),
        "levels": (1, 64),
        "n_bits": (1, 1_000_000),
        "bit_seed": (0, SEED_MAX),
        "rwindow": (0, 1_000_000),
        "top_k": (1, 10_000),
    }

    def __init__(
        self,
        *,
        length: int = 10,
        descriptor: Literal["ldb", "lbp", "haar"] = "ldb",
        side: int = 64,
        levels: tuple[int, ...] = (2, 3, 4, 5),
        n_bits: int | None = 1384,
        bit_seed: int = 0,
        confidence: Literal["similarity", "ratio"] = "similarity",
        rwindow: int = 10,
        top_k: int = 10,
        record_weights: bool = False,
    ) -> None:
        if int(length) < 1:
            raise PpalocError(f"ABLE-M length={length!r} must be at least 1 frame")
        if confidence not in ("similarity", "ratio"):
            raise PpalocError(
                f"ABLE-M confidence={confidence!r} is unknown; choose 'similarity' or 'ratio'"
            )
        if top_k < 1 or rwindow < 0:
            raise PpalocError(f"ABLE-M needs top_k >= 1 and rwindow >= 0, got {top_k}, {rwindow}")
        if descriptor in ("patch", *LOWRES_GRIDS):
            raise PpalocError(
                f"ABLE-M descriptor={descriptor!r} is an image, and ABLE-M matches binary "
                "codes by Hamming distance; choose 'ldb' (its own LDB code), 'lbp' (the "
                "weighted-node filter's 32-bit LBP code) or 'haar' (its 192 Haar signs)"
            )
        self.length = int(length)
        self.side = int(side)
        self.levels = tuple(int(g) for g in levels)
        own = {
            "side": (self.side, 64),
            "levels": (self.levels, (2, 3, 4, 5)),
            "n_bits": (n_bits, 1384),
            "bit_seed": (int(bit_seed), 0),
        }
        self.descriptor = check_descriptor("ABLE-M", descriptor, own, allowed=self.DESCRIPTORS)
        if self.descriptor == "ldb" and SENSOR_SIZE % self.side:  # at build, not the first frame
            sides = ", ".join(str(d) for d in range(8, SENSOR_SIZE + 1) if SENSOR_SIZE % d == 0)
            raise PpalocError(
                f"ABLE-M: side={self.side} must divide {SENSOR_SIZE}, the sensor frame's side "
                f"(one of {sides}; OpenABLE's 64)"
            )
        if self.descriptor == "lbp":
            self._bits = np.arange(LBP_BITS)
        elif self.descriptor == "haar":
            self._bits = np.arange(HAAR_BITS)  # the bits that can differ
        else:
            self._bits = selected_bits(comparison_count(self.levels), n_bits, bit_seed)
        self.n_bits = len(self._bits)
        self.bit_seed = int(bit_seed)
        self.confidence = confidence
        self.rwindow = int(rwindow)
        self.top_k = int(top_k)
        self.record_weights = bool(record_weights)
        self.n_bytes = 4 * HAAR_WORDS if self.descriptor == "haar" else (self.n_bits + 7) // 8
        self.fill = self.n_bits / 2.0
        self.map: TopoMap | None = None
        self.reset()

    @property
    def speed_range(self) -> tuple[float, float]:
        """The query speed the sequence assumes, in map nodes (reference frames) per query
        frame: query frame ``t - k`` is compared with node ``e - k``, one node a frame."""
        return (1.0, 1.0)

    def params(self) -> dict:
        """The parameters that shape the map (JSON-serialisable)."""
        if self.descriptor in ("lbp", "haar"):
            return {"descriptor": self.descriptor, "n_bits": self.n_bits, "length": self.length}
        return {
            "descriptor": "ldb",
            "side": self.side,
            "levels": list(self.levels),
            "n_bits": self.n_bits,
            "bit_seed": self.bit_seed,
            "length": self.length,
        }

    def describe(self, frame: np.ndarray) -> np.ndarray:
        """The packed binary code of one sensor frame, shape (n_bytes,) uint8 (the LBP code:
        its 4 bytes, most significant first; the Haar signs: their 8 words so)."""
        if self.descriptor == "lbp":
            return np.asarray(lbp_place(frame), dtype=">u4").reshape(1).view(np.uint8)
        if self.descriptor == "haar":
            return np.asarray(haar_place(frame), dtype=">u4").view(np.uint8)
        image = downsample(frame, (self.side, self.side))
        bits = ldb_comparisons(image, self.levels)[self._bits]
        return np.packbits(bits)

    @property
    def descriptor_shape(self) -> tuple[int, ...]:
        """``(n_bytes,)``: one packed code per node."""
        return (self.n_bytes,)

    def reset(self) -> None:
        """Forget the query history; keep the map."""
        n = 0 if self.map is None else len(self.map)
        self._history = np.zeros((self.length, n))
        self._seq = np.full(n, self.length * self.fill)
        self._count = 0

    def step(self, frame: np.ndarray) -> Estimate:
        """Localise one new query frame from the sequence of the last ``length`` frames."""
        topomap = require_map(self.map, self.name)
        h = hamming_distances(self.describe(frame), topomap.descriptors).astype(np.float64)
        n, big_l = len(h), self.length
        slot = self._count % big_l
        # The term leaving the sequence: frame t - L against node e - L.
        leaving = np.full(n, self.fill)
        if self._count >= big_l and n > big_l:
            leaving[big_l:] = self._history[slot, : n - big_l]
        shifted = np.empty(n)
        shifted[0] = big_l * self.fill
        shifted[1:] = self._seq[:-1]
        self._seq = shifted + h - leaving
        self._history[slot] = h
        self._count += 1
        seq = self._seq
        best = int(np.argmin(seq))
        if self.confidence == "similarity":
            score = 1.0 - float(seq[best]) / (big_l * self.n_bits)
        else:
            score = uniqueness_ratio(seq, best, self.rwindow // 2)
        return Estimate(
            node=best,
            score=score,
            ranking=top_k(-seq, self.top_k),
            weights=-seq.copy() if self.record_weights else None,
        )
