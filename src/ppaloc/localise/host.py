"""The weighted-node filter's steps on the host: the executor the schedules run.

:class:`HostExecutor` holds one weight per node in a contiguous array and does what a
schedule (:mod:`ppaloc.localise.schedule`) asks of it, in one of two arithmetics:

- ``"float"``: float32 weights clipped to the register's range [-127, 127] (the bound is
  what gives the filter a finite memory: without it one long run of good matches
  outweighs any later evidence), ties only between equal weights, the live low-res image
  quantised like a node (uint8 SAD, the fast path);
- ``"ppa8"``: the register arithmetic of docs/ppa8.md exactly (saturation of every write,
  integer DAC constants, integer detection thresholds), in float64 (every value is a
  dyadic rational with few bits): the reference the sensor is checked against.

The weights live in a rotated frame: node ``i`` is element ``(i + offset) % N``. The
paper's forward move decrements ``offset`` and zeroes one element instead of moving N
weights; the robust transition keeps offset 0 (its max over shifted copies moves every
weight anyway).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.enhance import (
    ENHANCE_UNITS,
    closer_count,
    contrast_enhance,
    count_closer,
    place_neighbours,
)
from ppaloc.localise.likelihood import (
    BINARY_PLACES,
    FLOAT_PLACES,
    HAAR_EXPONENT,
    NodeDistances,
    distance_scale,
    float_divisor,
)
from ppaloc.localise.motion import AlwaysForward, ImageMotion, MotionModel
from ppaloc.localise.params import (
    FilterParams,
    choose_candidate,
    local_step,
    refined_minimum,
    weight_read,
)
from ppaloc.topomap import TopoMap

__all__ = ["ARITHMETICS", "HostExecutor", "motion_model", "read_values", "top_k"]

ARITHMETICS = ("float", "ppa8")
_W_MIN, _W_MAX = -127.0, 127.0  # the weight clip of the ``add`` macro (docs/ppa8.md)
_T_MIN, _T_MAX = -128.0, 127.0  # any other register write
_RANK_ROWS = 256  # the two-level top-k search splits the weights into 256 rows


def _clip(a: np.ndarray, low: float, high: float) -> float:
    """Clip ``a`` in place to [low, high] and return its maximum.

    Checking the extremes first (two fast reductions) and clipping only a side that is
    out of range is several times cheaper than ``np.clip`` on every frame.
    """
    top = float(a.max())
    if top > high:
        np.minimum(a, high, out=a)
        top = high
    if float(a.min()) < low:
        np.maximum(a, low, out=a)
        top = max(top, low)  # every weight may have been below the bound
    return top


def top_k(w: np.ndarray, k: int) -> np.ndarray:
    """Physical indices of ``k`` largest weights (unordered), in about one pass over ``w``.

    The weights are viewed as 256 rows; the element-wise maximum of the rows gives one
    maximum per column. The ``k`` largest column maxima are ``k`` distinct weights, so
    the ``k``-th largest weight is at least the ``k``-th largest column maximum: only
    columns whose maximum reaches it can hold a top-``k`` weight. A full
    ``argpartition`` of 10**6 weights costs several times more.
    """
    n = len(w)
    if k >= n:
        return np.arange(n)
    cols = n // _RANK_ROWS
    if cols <= 4 * k:
        return np.argpartition(w, n - k)[n - k :]
    head = w[: cols * _RANK_ROWS].reshape(_RANK_ROWS, cols)
    maxima = head.max(axis=0)
    bound = np.partition(maxima, cols - k)[cols - k]
    chosen = np.flatnonzero(maxima >= bound)
    idx = (np.arange(_RANK_ROWS)[:, None] * cols + chosen).reshape(-1)
    idx = np.concatenate((idx, np.arange(cols * _RANK_ROWS, n)))
    return idx[np.argpartition(w[idx], len(idx) - k)[len(idx) - k :]]


def read_values(kind: str, raw: np.ndarray, exact: bool) -> np.ndarray:
    """The per-node values the controller reads to scale the likelihood (docs/ppa8.md);
    ``exact``: the readout's integers, which every executor's robust schedule reads.

    LBP: ``mu = 2h``, exact. Haar signs: ``mu = h/4``; in ``ppa8`` the ADC code of the
    halving tree's root ``+h/4`` (``code = floor(128.5 + h/4)``) read back as
    ``code - 128 = floor((h + 2) / 4)``. Low-res ``ppa8``: the ADC code of ``-mu/2`` (the
    halving tree's result, ``code = floor(128.5 - mu/2)``) read back as ``2 (128 - code)``.
    Low-res ``float``: ``mu`` itself (the SAD over :func:`float_divisor`). Distances
    ``enhance`` has made floats (float arithmetic only) are read by the same factors. The
    host's float places (``"patch"``): ``mu`` itself.
    """
    if kind in FLOAT_PLACES:  # mu itself, a float (never ``exact``: no register holds it)
        return raw.astype(np.float64)
    if kind == "lbp":
        return raw.astype(np.int64) * 2 if raw.dtype.kind in "iu" else raw * 2.0
    if kind == "haar":
        if exact:  # round half up: + 2**(e - 1), then the shift
            return (raw.astype(np.int64) + (1 << (HAAR_EXPONENT - 1))) >> HAAR_EXPONENT
        return raw.astype(np.float64) / float(1 << HAAR_EXPONENT)
    if exact:  # raw = T, mu = T / 2**17, mu / 2 = T / 2**18
        code = (257 * 2**17 - raw.astype(np.int64)) >> 18
        return 2 * (128 - code)
    return raw.astype(np.float64) / float(float_divisor(kind))


def _enhanced(kind: str, raw: np.ndarray, window: int) -> np.ndarray:
    """``raw`` distances contrast-enhanced along the map (``enhance``, float only), in
    raw units such that :func:`read_values` reads :data:`ENHANCE_UNITS` a deviation."""
    z = contrast_enhance(raw, window)
    if kind in FLOAT_PLACES:
        return z * float(ENHANCE_UNITS)
    if kind == "lbp":
        return z * (ENHANCE_UNITS / 2.0)
    if kind == "haar":
        return z * float(ENHANCE_UNITS << HAAR_EXPONENT)
    return z * float(ENHANCE_UNITS * float_divisor(kind))


def motion_model(params: FilterParams) -> MotionModel | None:
    """The host's own motion test of ``params.motion`` (None for the oracle, whose
    decisions the schedule hands over)."""
    if params.motion == "always_forward":
        return AlwaysForward()
    if params.motion == "image":
        return ImageMotion.of(params)
    return None


class HostExecutor:
    """The weighted-node filter's weights on the host, and every step a schedule calls.

    Parameters
    ----------
    representation : {"lowres", "lowres16", "lbp", "haar", "patch"}
    params : FilterParams
    arithmetic : {"float", "ppa8"}
    ranking_k : int
        How many nodes :attr:`ranking` lists after each frame (0: none).

    Attributes
    ----------
    exact : bool
        Register arithmetic (``"ppa8"``).
    integer_readout : bool
        The frame's scale is decided on the register readout's integers (in either
        arithmetic; not on distances ``enhance`` has made floats, nor on a float place).
    ranking : ndarray of int or None
        The last frame's best nodes, best first (the estimate first), taken before the
        normalisation or adjustment.
    last_shift : int or None
        Robust: the likelihood shift of the last frame that added a likelihood.
    motion_model : MotionModel or None
        The image or always-forward test (None with the oracle).
    """

    def __init__(
        self,
        representation: str,
        params: FilterParams,
        *,
        arithmetic: str = "float",
        ranking_k: int = 10,
    ) -> None:
        if arithmetic not in ARITHMETICS:
            raise PpalocError(f"arithmetic={arithmetic!r} is not one of {', '.join(ARITHMETICS)}")
        self.representation = representation
        self.params = params
        self.exact = arithmetic == "ppa8"
        # the frame's scale is decided on the readout's integers (the robust preset's
        # distances), not on distances ``enhance`` (float only) has made floats
        self.integer_readout = (
            not params.enhance
            and representation not in FLOAT_PLACES
            and (representation in BINARY_PLACES or params.contrast is not None)
        )
        self.ranking_k = ranking_k
        self.motion_model = motion_model(params)
        self._dtype = np.float64 if self.exact else np.float32
        self._distances: NodeDistances | None = None
        self._w = np.zeros(0, self._dtype)
        self._lift: np.ndarray | None = None
        self._places: np.ndarray | None = None
        self._neighbours: dict[int, np.ndarray] = {}  # place_neighbours per window
        self.ranking: np.ndarray | None = None
        self.last_shift: int | None = None
        self._topomap: TopoMap | None = None
        self._source: HostExecutor | None = None  # a twin's: whose frame distances it reads
        self.reset()

    # -- map and state -----------------------------------------------------------------
    def use_map(self, topomap: TopoMap) -> None:
        """Compare frames with ``topomap``'s nodes from now on (weights zeroed)."""
        distances = NodeDistances(
            self.representation,
            topomap.descriptors,
            exact=self.exact,
            contrast=None
            if self.representation in BINARY_PLACES + FLOAT_PLACES
            else self.params.contrast,
            patch=self.params.contrast_patch,
        )
        self._use_map(topomap, distances)

    def _use_map(self, topomap: TopoMap, distances: NodeDistances) -> None:
        n = len(topomap)
        self._topomap = topomap
        self._distances = distances
        self._w = np.zeros(n, self._dtype)
        # a map's runs (nodes of one place): the places lifted 256 apart, so one running
        # maximum over ``w + lift`` is a maximum within each run (|w| <= 127)
        self._lift = 256.0 * topomap.places if topomap.has_runs else None  # type: ignore[operator]
        self._places = topomap.places if topomap.has_runs else None
        self._neighbours = {}
        self._pred = np.empty(n, self._dtype)
        self._shifted = np.empty(n, self._dtype)
        self.reset()

    def twin(self) -> HostExecutor:
        """A second set of weights on this executor's map in the same arithmetic, reading
        this executor's distances of the frame both take (a robust schedule's speed
        lane: the distances are computed once a frame) and sharing its map's nodes."""
        if self._topomap is None:
            raise PpalocError("no map: call use_map(topomap) before twin()")
        arithmetic = "ppa8" if self.exact else "float"
        twin = HostExecutor(self.representation, self.params, arithmetic=arithmetic, ranking_k=0)
        twin._use_map(self._topomap, self._distances.sharing())  # type: ignore[union-attr]
        twin._source = self
        return twin

    def reset(self) -> None:
        """Zero weights, no frame, the motion test's previous frame forgotten."""
        self._w[:] = 0
        self._offset = 0
        self._frame: np.ndarray | None = None
        self._raw: np.ndarray | None = None
        self._memo: dict[Any, np.ndarray] = {}  # values of the frame's distances alone
        self._top: float | None = None
        self.ranking = None
        if self.motion_model is not None:
            self.motion_model.reset()

    def weights(self) -> np.ndarray:
        """A copy of the weights in map order (node 0 first)."""
        return np.roll(self._w, -self._offset)

    def set_weights(self, weights: np.ndarray) -> None:
        """Set the weights, given in map order (for tests and experiments)."""
        self._w[:] = np.roll(np.asarray(weights, self._dtype), self._offset)
        self._top = None

    # -- the steps ---------------------------------------------------------------------
    def begin(self, frame: np.ndarray) -> None:
        """Take the frame (its distances are computed when a likelihood step asks)."""
        self._frame = frame
        self._raw = None
        self._memo = {}
        self._top = None

    def motion(self, decided: bool | None) -> bool:
        """``decided`` when given (the oracle's), else the host's motion test."""
        if decided is not None:
            return decided
        assert self.motion_model is not None, "the oracle's decisions come from the schedule"
        return self.motion_model.step(self._frame)  # type: ignore[arg-type]

    def _of_frame(self, key: Any, make: Callable[[], np.ndarray]) -> np.ndarray:
        """``make()``, a value of the frame's distances alone, computed once a frame: a
        twin reading its source's frame takes the source's (so a speed lane adds only its
        weights' work). Read-only to the caller."""
        source = self._source
        owner = source if source is not None and source._frame is self._frame else self
        if key not in owner._memo:
            owner._memo[key] = make()
        return owner._memo[key]

    def _raw_distances(self) -> np.ndarray:
        if self._distances is None:
            raise PpalocError("no map: call build_map(frames) or use_map(topomap) first")
        source = self._source
        if self._raw is None and source is not None and source._frame is self._frame:
            self._raw = source._raw_distances()
        if self._raw is None:
            raw = self._distances(self._frame)  # type: ignore[arg-type]
            if self.params.enhance:  # robust, float: FilterParams refuses it in ppa8
                raw = _enhanced(self.representation, raw, self.params.enhance)
            self._raw = raw
        return self._raw

    def transition(self, costs: tuple[int, ...]) -> None:
        """Robust: ``w_i := clip(max_d (w_{i-d} - c_d))``; nodes before node 0 read the
        floor (the array edge's "no hypothesis"). On a map with runs (``TopoMap.places``)
        each weight then flows along its run for free: ``w_i := max(w_j, j <= i in the
        run of i)``, as if the nodes of one place were one node."""
        w, pred, tmp = self._w, self._pred, self._shifted
        floor = -float(self.params.memory)  # type: ignore[arg-type]
        np.subtract(w, self._dtype(costs[0]), out=pred)
        n = len(w)
        for d, cost in enumerate(costs[1:], start=1):
            if d < n:
                np.subtract(w[:-d], self._dtype(cost), out=tmp[d:])
                np.maximum(pred[d:], tmp[d:], out=pred[d:])
            # nodes i < d take the array edge's "no hypothesis"
            np.maximum(pred[: min(d, n)], self._dtype(floor - cost), out=pred[: min(d, n)])
        w[:] = pred
        _clip(w, _W_MIN, _W_MAX)  # every candidate is a register write (the add macro)
        if self._lift is not None:
            assert self._offset == 0, "a run is along the map, the robust weights unshifted"
            w[:] = np.maximum.accumulate(w + self._lift) - self._lift
        self._top = None

    def node_values(self) -> np.ndarray:
        """Robust: each node's value as the controller reads it (:func:`read_values`), in
        either arithmetic: the frame's scale is decided on the readout, so float and
        ``ppa8`` decide it alike (docs/ppa8.md, "Register arithmetic against float").
        Distances ``enhance`` has made floats, which no register holds, are read by
        the float factors of :func:`read_values`."""
        return self._of_frame("values", self._read_values)

    def _read_values(self) -> np.ndarray:
        raw = self._raw_distances()
        if not self.integer_readout:
            return read_values(self.representation, raw, False)
        assert self._distances is not None  # _raw_distances refuses a missing map
        return read_values(self.representation, self._distances.registers(raw), True)

    def minimum(self, values: np.ndarray) -> int | float:
        """The frame's best distance as the controller has it: the LBP readout's least
        value (exact), the low-res one refined from the register's distances as the sensor
        refines it on the array (:func:`refined_minimum`), the Haar-sign readout's least
        value as read (the sensor reads no finer); the least value where the distances
        are ``enhance``'s floats."""
        if not self.integer_readout:
            return float(values.min())
        if self.representation not in BINARY_PLACES:
            assert self._distances is not None  # the least T is the least SAD's
            t = self._distances.registers(self._raw_distances().min(keepdims=True))
            return refined_minimum(int(t[0]) / 2.0**17)  # mu = T / 2**17
        return int(values.min())

    def add_scaled(self, shift: int, alpha: float) -> None:
        """Robust: ``w += alpha_t - mu 2**-s`` (the term clipped to a register in ppa8)."""
        self.last_shift = shift
        self._add_term(shift, alpha)

    def add_local(self, gain: int, window: int) -> None:
        """``w := clip(w - gain * closer_share(distances, window))`` (``local_gain``); on
        a map with runs a node's neighbours are the nodes next to its run
        (:func:`~ppaloc.localise.enhance.place_neighbours`). In ppa8 each closer
        neighbour costs the integer ``gain / (2 window)``
        (:func:`~ppaloc.localise.params.local_step`; ``FilterParams`` checks it), so the
        term is exact; the sensor subtracts it once per closer neighbour, and the lower
        clip makes that the same."""
        self._add_to_weights(
            self._of_frame(("local", gain, window), lambda: self._local(gain, window))
        )

    def _local(self, gain: int, window: int) -> np.ndarray:
        """The local term in map order: per node, ``-gain`` times the share of its ``2
        window`` neighbours closer to the frame; on a map with runs the nodes next to its
        run (the map's table, once per window)."""
        raw = self._raw_distances()
        if self._places is None:
            count = closer_count(raw, window)
        else:
            if window not in self._neighbours:
                self._neighbours[window] = place_neighbours(self._places, window)
            count = count_closer(raw, self._neighbours[window])
        if self.exact:
            step = local_step(gain, window)
            assert step is not None, "FilterParams refuses a fractional step in ppa8"
            return (-step * count).astype(self._dtype)
        return self._dtype(-gain) * (count / (2 * int(window))).astype(self._dtype)

    def shift(self) -> None:
        """Paper: ``w_i := max(w_{i-d} for d in advance)``; indices below 0 read the
        edge's 0 (``advance = (1, 1)``: one node, an offset change and one zero)."""
        w, n = self._w, len(self._w)
        lo, hi = self.params.advance  # type: ignore[misc]
        for _ in range(min(lo, n)):  # shift by one: an offset change and one zero
            self._offset = (self._offset - 1) % n
            w[self._offset] = 0
        for _ in range(hi - lo):  # w_i := max(w_i, w_{i-1}) for all i at once
            first, last = self._offset, float(w[-1])
            head = float(w[first])
            np.maximum(w[1:], w[:-1], out=w[1:])  # numpy buffers the overlap
            w[0] = max(float(w[0]), last)
            w[first] = max(head, 0.0)  # node 0's predecessor is the edge
        self._top = None

    def add_likelihood(self, alpha: float, shift: int) -> None:
        """Paper: ``w += alpha - mu 2**-shift`` (the term clipped to a register in ppa8)."""
        self._add_term(shift, alpha)

    def _add_term(self, shift: int, alpha: float) -> None:
        self._add_to_weights(
            self._of_frame(("term", shift, alpha), lambda: self._term_of(shift, alpha))
        )

    def _term_of(self, shift: int, alpha: float) -> np.ndarray:
        """The frame's likelihood term ``alpha - mu 2**-shift`` in map order (clipped to a
        register in ppa8)."""
        raw = self._raw_distances()
        term = np.empty(len(raw), self._dtype)
        np.multiply(
            raw, self._dtype(-distance_scale(self.representation, shift, self.exact)), out=term
        )
        term += self._dtype(alpha)
        if self.exact:
            _clip(term, _T_MIN, _T_MAX)
        return term

    def _add_to_weights(self, term: np.ndarray) -> None:
        """``w := clip(w + term)``, ``term`` in map order (the weights may be offset)."""
        w, off = self._w, self._offset
        n = len(w)
        w[off:] += term[: n - off]
        w[:off] += term[n - off :]
        self._top = _clip(w, _W_MIN, _W_MAX)

    def detect(self, prev: int | None, bits: int = 0) -> tuple[int, float]:
        """``(node, T)``: ``T = max W`` (``floor(max W)`` in ppa8), the candidate nearest
        ``prev`` (:func:`choose_candidate`) among ``w >= T`` (ppa8: ``w >=
        floor(2**bits max W) / 2**bits``)."""
        w = self._w
        top = float(w.max()) if self._top is None else self._top
        threshold = math.floor(top) if self.exact else top
        cut = math.floor(top * 2**bits) / 2**bits if self.exact else top
        if cut == top and np.count_nonzero(w == top) == 1:  # no tie: skip the search
            return int(self._to_node(int(w.argmax()))), threshold
        candidates = self._to_node(np.flatnonzero(w >= cut))
        if len(candidates) == 1:
            return int(candidates[0]), threshold
        return choose_candidate(np.sort(candidates), prev), threshold

    def confidence(self, node: int, top: float, window: tuple[int, int], bits: int = 0) -> float:
        """Best weight minus the best weight outside the nodes ``window`` (0 when none is
        outside). In ppa8 with ``bits``: ``floor(2**bits max W) / 2**bits`` (the
        detection's refined threshold) minus the outside maximum floored to the same
        ``2**-bits``, as the sensor's threshold searches find them."""
        outside = self._max_outside(*window)
        if outside is None:
            return 0.0
        if self.exact and bits:
            step = 2**bits
            top_w = float(self._w.max()) if self._top is None else self._top  # as detect's
            top_b = math.floor(top_w * step) / step
            return top_b - math.floor(outside * step) / step
        return float(self._w[(node + self._offset) % len(self._w)]) - outside

    def weight_reads(self, a: int, b: int) -> list[float]:
        """The weights of nodes ``a .. b``: one ADC read each in ppa8
        (:func:`weight_read`), the values in float."""
        w = self._w
        values = [float(w[(i + self._offset) % len(w)]) for i in range(a, b + 1)]
        return [weight_read(v) for v in values] if self.exact else values

    def rank(self, node: int) -> None:
        """:attr:`ranking`: the ``ranking_k`` best nodes, best first, the estimate first."""
        self.ranking = self._ranking(node) if self.ranking_k else None

    def normalise(self, top: float) -> None:
        """Robust: ``w := max(clip(w - T), -memory)``: the best weight returns to [0, 1)
        and every hypothesis stays within ``memory`` of it."""
        w = self._w
        w -= self._dtype(top)
        _clip(w, _W_MIN, _W_MAX)
        np.maximum(w, self._dtype(-self.params.memory), out=w)  # type: ignore[operator]
        self._top = None

    def adjust(self, amount: float) -> None:
        """Paper: ``w := clip(w - amount)``. Only the lower bound can be crossed: for
        ``max(W) >= 0`` every weight falls, and for ``max(W) < 0`` the largest becomes
        ``max(W) - g < 1``; so one subtraction and one ``maximum`` pass."""
        w = self._w
        g = amount if self.exact else self._dtype(amount)
        w -= g
        if g > 0:
            np.maximum(w, _W_MIN, out=w)
        self._top = None

    # -- helpers -----------------------------------------------------------------------
    def _to_node(self, physical: np.ndarray | int) -> np.ndarray | int:
        return (physical - self._offset) % len(self._w)

    def _max_outside(self, a: int, b: int) -> float | None:
        """The largest weight outside nodes ``a .. b`` (None if there is none)."""
        n = len(self._w)
        lo, hi = max(a, 0), min(b + 1, n)
        best = None
        for a, b in ((0, lo), (hi, n)):  # logical ranges [a, b)
            for pa, pb in self._physical(a, b):
                m = float(self._w[pa:pb].max())
                best = m if best is None else max(best, m)
        return best

    def _physical(self, a: int, b: int) -> list[tuple[int, int]]:
        """Physical slices covering logical nodes [a, b)."""
        if b <= a:
            return []
        n, off = len(self._w), self._offset
        pa, pb = (a + off) % n, (b + off) % n or n
        if pa < pb:
            return [(pa, pb)]
        return [(pa, n), (0, pb)]

    def _ranking(self, node: int) -> np.ndarray:
        return self.ranking_for(node, self.ranking_k)

    def ranking_for(self, node: int, k: int) -> np.ndarray:
        """The ``k`` best nodes by these weights, best first, ``node`` (the reported
        estimate) first: a speed lane's ranking where the filter reports its estimate."""
        w = self._w
        top = top_k(w, min(k + 1, len(w)))
        nodes = self._to_node(top)
        nodes = nodes[np.lexsort((nodes, -w[top]))]  # by weight, then node index
        nodes = nodes[nodes != node]
        return np.concatenate(([node], nodes))[:k].astype(np.int64)
