"""The weighted-node filter (Algorithm 1 of the paper) on the host.

Per frame, in this order (docs/ppa8.md; docs/localise.md has the reasoning):

1. motion: forward or stay; on forward ``w_i := w_{i-1}`` along the map and ``w_0 := 0``;
2. likelihood ``mu_i`` in register units, scaled to ``mu_s = mu * 2**-shift``;
3. update ``w_i += alpha - mu_s_i``;
4. detection: the highest weight, ties to the candidate nearest the previous estimate;
5. every ``k``-th frame the adjustment ``w_i -= gamma * max(W)``.

``arithmetic="float"`` runs this in float32 with the weights kept in the register's range
[-127, 127] (the bound is what gives the filter a finite memory: without it one long run
of good matches outweighs any later evidence); ``arithmetic="ppa8"`` in the register
arithmetic of docs/ppa8.md (saturation of every write, integer DAC constants, an integer
detection threshold), exactly, in float64 (every value is a dyadic rational with few bits).

The weights live in one contiguous array in a rotated frame: node ``i`` is element
``(i + offset) % N``. A forward move decrements ``offset`` and zeroes one element instead
of moving N weights.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.base import Estimate
from ppaloc.localise.likelihood import NodeDistances, distance_scale
from ppaloc.localise.motion import AlwaysForward, ImageMotion, MotionModel, OracleMotion
from ppaloc.topomap import TopoMap, build_topomap

__all__ = [
    "ALPHA_CAP",
    "ALPHA_FACTOR",
    "DEFAULT_SHIFT",
    "GAMMAS",
    "WeightedNodeLocaliser",
    "choose_candidate",
    "suggest_alpha",
]

GAMMAS = (0.0, 0.125, 0.25, 0.5, 1.0)
"""Adjustment factors a PPA applies by halving (docs/ppa8.md)."""

_REPRESENTATIONS = ("lowres", "lbp")
_MOTIONS = ("image", "always_forward", "oracle")
_ARITHMETICS = ("float", "ppa8")
_W_MIN, _W_MAX = -127.0, 127.0  # the weight clip of the ``add`` macro (docs/ppa8.md)
_T_MIN, _T_MAX = -128.0, 127.0  # any other register write


def _far_mu(topomap: TopoMap, shift: int) -> np.ndarray:
    """``mu_s`` between each node and the node half the map away (unrelated places)."""
    d = topomap.descriptors
    n = len(d)
    far = (np.arange(n) + n // 2) % n
    if topomap.kind == "lbp":
        x = np.asarray(d, np.uint32)
        raw = np.bitwise_count(x ^ x[far]).astype(np.float64)
    else:
        x = np.asarray(d, np.int64).reshape(n, -1)
        raw = np.abs(x - x[far]).sum(axis=1).astype(np.float64) * 1024
    return raw * distance_scale(topomap.kind, shift, exact=True)


ALPHA_FACTOR = 3.0
"""How far above the map's unrelated-place likelihoods :func:`suggest_alpha` puts alpha."""

ALPHA_CAP = 63
"""The largest suggested alpha: with ``gamma = 1/2`` every frame the best weight settles
near ``2 * (alpha - mu_true)``, which must stay below the 127 bound (no ties there)."""

DEFAULT_SHIFT = {"lowres": 2, "lbp": 1}
"""Default likelihood shift per representation: one frame's term spans 0-32 units in both
(low-res ``mu`` is in [0, 127], LBP ``mu`` in [0, 64])."""


def suggest_alpha(
    topomap: TopoMap,
    shift: int = 2,
    quantile: float = 0.99,
    factor: float = ALPHA_FACTOR,
) -> int:
    """Choose ``alpha`` from the map alone: a multiple of the unrelated-place likelihoods.

    ``alpha`` is the scaled likelihood at which a node neither gains nor loses weight.
    Only *differences* between nodes decide the estimate, so ``alpha`` matters in two
    places: a true match seen under new conditions (season, light) scores worse than
    anything in the map itself, and if ``alpha`` sits below it the true node's weight
    sinks below the 0 that enters node 0 on every forward move (the estimate then sticks
    to node 0); too high and every weight climbs to the register bound (ppa8) faster than
    the adjustment takes it off. The map gives an upper reference without any query:
    nodes half the map apart are unrelated places. A true match under other conditions
    can be worse than any of them (snow or dusk against a summer map shifts every block
    mean: on the synthetic route the winter query's true match scores about twice the
    map's 0.99 quantile), so alpha is ``factor`` (3) times the ``quantile`` of their
    ``mu_s``, rounded up to an integer (the PPA loads it through the DAC) and capped at
    :data:`ALPHA_CAP`. A generous alpha costs little: with the adjustment every frame
    (``k = 1``, ``gamma = 1/2``) only differences between weights matter until the best
    weight would reach the 127 bound, which the cap prevents.

    Parameters
    ----------
    topomap : TopoMap
        A map of kind ``"lowres"`` or ``"lbp"`` with at least 3 nodes.
    shift : int
        The filter's likelihood shift ``s`` (``mu_s = mu * 2**-s``).
    quantile : float
        Which quantile of the unrelated-pair likelihoods (default 0.99).
    factor : float
        Multiple of that quantile (default :data:`ALPHA_FACTOR`).

    Returns
    -------
    int
        ``alpha`` in [0, :data:`ALPHA_CAP`].

    Examples
    --------
    >>> from ppaloc.topomap import TopoMap
    >>> m = TopoMap("lbp", np.array([0, 0xF, 0xFF, 0xFFF], np.uint32))
    >>> suggest_alpha(m, shift=0, factor=1)  # far pairs differ in 8 bits: mu = 16
    16
    >>> suggest_alpha(m, shift=0)  # 3 * 16, capped
    48
    """
    if topomap.kind not in _REPRESENTATIONS:
        raise PpalocError(f"cannot suggest alpha for a map of kind {topomap.kind!r}")
    if len(topomap) < 3:
        raise PpalocError(
            f"a map of {len(topomap)} nodes is too small to choose alpha from; pass alpha= "
            "explicitly"
        )
    if not 0.0 <= quantile <= 1.0:
        raise PpalocError(f"quantile={quantile!r} must be in [0, 1]")
    if not (math.isfinite(factor) and factor > 0):
        raise PpalocError(f"factor={factor!r} must be a positive number")
    away = _far_mu(topomap, shift)
    value = factor * float(np.quantile(away, quantile))
    return int(min(max(math.ceil(value), 0), ALPHA_CAP))


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


def _top_k(w: np.ndarray, k: int) -> np.ndarray:
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


def choose_candidate(candidates: np.ndarray, previous: int | None) -> int:
    """The detection tie-break: the candidate nearest ``previous``, then the smaller index.

    Parameters
    ----------
    candidates : ndarray of int, shape (C,)
        Sorted node indices whose weight reached the detection threshold (C >= 1).
    previous : int or None
        The previous estimate; None on the first frame (the smallest candidate wins).

    Examples
    --------
    >>> choose_candidate(np.array([2, 7, 12]), 10), choose_candidate(np.array([4, 8]), 6)
    (12, 4)
    """
    if previous is None:
        return int(candidates[0])
    # argmin returns the first minimum, i.e. the smaller index on equal distance
    return int(candidates[np.argmin(np.abs(candidates - previous))])


def _check_int(name: str, value: Any, low: int, high: int | None = None) -> int:
    if not isinstance(value, int | np.integer) or isinstance(value, bool):
        raise PpalocError(f"{name}={value!r} must be an integer")
    if value < low or (high is not None and value > high):
        hint = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise PpalocError(f"{name}={value!r} must be {hint}")
    return int(value)


class WeightedNodeLocaliser:
    """The paper's weighted-node filter over a 1-D topological map (Algorithm 1).

    Parameters
    ----------
    representation : {"lowres", "lbp"}
        Node kind: 8x8 low-res images compared by mean absolute difference, or 32-bit LBP
        descriptors compared by Hamming distance.
    alpha : int or float, optional
        Likelihood at which a node neither gains nor loses weight. None (default) takes
        :func:`suggest_alpha` of the map when it is built or loaded (0 for a map of fewer
        than 3 nodes). Must be an integer in [-128, 127] for ``arithmetic="ppa8"``.
    gamma : float
        Adjustment factor, one of 0, 1/8, 1/4, 1/2, 1 (default 1/2): every ``k`` frames
        ``gamma * max(W)`` is taken off every weight, so the best weight stays away from the
        saturation bound and ties at 127 are rare.
    k : int
        Frames between adjustments (default 1: every frame, so the best weight settles at
        ``(alpha - mu_true) / gamma`` whatever alpha is, and alpha's choice is forgiving).
    shift : int, optional
        Likelihood scale ``mu_s = mu * 2**-shift``. Default (None): 2 for low-res (``mu``
        in [0, 127]) and 1 for LBP (``mu`` in [0, 64]), so one frame's term spans 0-32
        units in both and a weight needs several consistent frames to cross the 254-unit
        range (the filter's memory).
    motion : {"image", "always_forward", "oracle"}
        Motion model (default ``"image"``, see :mod:`ppaloc.localise.motion`).
    arithmetic : {"float", "ppa8"}
        ``"float"``: float32 weights clipped to [-127, 127], ties only between equal
        weights, ``gamma * max(W)`` unrounded, the live low-res image quantised like a node
        (uint8 SAD, the fast path). ``"ppa8"``: the register arithmetic of docs/ppa8.md,
        exactly (the live frame's exact block means, integer threshold and DAC constants).
    confidence_radius : int
        ``R`` of the confidence score (default 10 nodes): the best weight minus the best
        weight outside nodes ``node - R .. node + R``.
    ranking_k : int
        How many nodes ``Estimate.ranking`` lists, best first (default 10; 0 = none).
    record_weights : bool
        Put a copy of the weights (map order, after the frame) in every Estimate.
    oracle_moves : sequence of bool, optional
        Ground-truth moves for ``motion="oracle"`` (a dataset's ``query_moved``).
    advance : (int, int)
        Nodes a forward move may advance, ``(lo, hi)``: on forward
        ``w_i := max(w_{i-lo}, ..., w_{i-hi})`` (indices below 0 read 0). Default
        ``(1, 1)``: the paper's one-node shift, right for frame-synchronised routes.
        ``(0, 2)`` lets each weight stay or advance one or two nodes, for routes where
        the speed varies (one frame covers 0.8-1.2 places on the default synthetic route,
        0.35-1.65 with ``speed_var=0.65``); host only (not in the ppa8 contract), and it
        hurts frame-synchronised routes: see docs/localise.md for the measured effect.
    motion_margin, motion_shift, motion_min_support : int
        Parameters of the image motion model (:class:`ImageMotion`).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> frames = rng.integers(0, 256, (6, 256, 256), dtype=np.uint8)
    >>> loc = WeightedNodeLocaliser("lbp", motion="always_forward", alpha=8)
    >>> _ = loc.build_map(frames)
    >>> [loc.step(f).node for f in frames[2:5]]
    [2, 3, 4]
    """

    def __init__(
        self,
        representation: str = "lowres",
        *,
        alpha: float | None = None,
        gamma: float = 0.5,
        k: int = 1,
        shift: int | None = None,
        motion: str = "image",
        arithmetic: str = "float",
        confidence_radius: int = 10,
        ranking_k: int = 10,
        record_weights: bool = False,
        oracle_moves: Sequence[bool] | np.ndarray | None = None,
        advance: tuple[int, int] = (1, 1),
        motion_margin: int = 3,
        motion_shift: int = 6,
        motion_min_support: int = 1024,
    ) -> None:
        if representation not in _REPRESENTATIONS:
            raise PpalocError(
                f"representation={representation!r} is not one of {', '.join(_REPRESENTATIONS)}"
            )
        if arithmetic not in _ARITHMETICS:
            raise PpalocError(f"arithmetic={arithmetic!r} is not one of {', '.join(_ARITHMETICS)}")
        if motion not in _MOTIONS:
            raise PpalocError(f"motion={motion!r} is not one of {', '.join(_MOTIONS)}")
        if gamma not in GAMMAS:
            raise PpalocError(
                f"gamma={gamma!r} must be one of {GAMMAS} (a PPA scales only by halving)"
            )
        self.k = _check_int("k", k, 1)
        if shift is None and representation in DEFAULT_SHIFT:
            shift = DEFAULT_SHIFT[representation]
        self.shift = _check_int("shift", shift, 0, 16)
        self.confidence_radius = _check_int("confidence_radius", confidence_radius, 0)
        self.ranking_k = _check_int("ranking_k", ranking_k, 0)
        lo, hi = advance
        if not (0 <= _check_int("advance[0]", lo, 0) <= _check_int("advance[1]", hi, 1)):
            raise PpalocError(f"advance={advance!r} must be (lo, hi) with 0 <= lo <= hi, hi >= 1")
        self.advance = (int(lo), int(hi))
        if alpha is not None:
            if arithmetic == "ppa8":
                alpha = _check_int("alpha", alpha, -128, 127)  # a DAC constant
            elif not math.isfinite(float(alpha)):
                raise PpalocError(f"alpha={alpha!r} must be a finite number")
        if motion == "oracle":
            if oracle_moves is None:
                raise PpalocError(
                    "motion='oracle' needs oracle_moves= (e.g. the dataset's query_moved)"
                )
            self._motion: MotionModel = OracleMotion(oracle_moves)
        elif motion == "always_forward":
            self._motion = AlwaysForward()
        else:
            self._motion = ImageMotion(motion_margin, motion_shift, motion_min_support)
        self.representation = representation
        self.arithmetic = arithmetic
        self.motion = motion
        self.gamma = float(gamma)
        self.alpha_given = alpha
        self.alpha: float | None = alpha
        self.record_weights = bool(record_weights)
        self.name = f"weighted-node-{representation}"
        self._exact = arithmetic == "ppa8"
        self._dtype = np.float64 if self._exact else np.float32
        self.topomap: TopoMap | None = None
        self._distances: NodeDistances | None = None
        self._w = np.zeros(0, self._dtype)

    # -- map -------------------------------------------------------------------------------

    def build_map(self, frames: Iterable[np.ndarray]) -> TopoMap:
        """Build the map from a reference traversal (one node per sensor frame) and use it."""
        frames = list(frames)
        if not frames:
            raise PpalocError("the reference traversal is empty: a map needs at least one frame")
        topomap = build_topomap(frames, self.representation)
        self.use_map(topomap)
        return topomap

    def use_map(self, topomap: TopoMap) -> None:
        """Localise against ``topomap`` (e.g. one loaded from a file) from now on."""
        if topomap.kind != self.representation:
            raise PpalocError(
                f"the map holds {topomap.kind!r} nodes but this localiser uses "
                f"{self.representation!r}; build the map with representation="
                f"{topomap.kind!r} or choose a matching map"
            )
        if len(topomap) == 0:
            raise PpalocError("the map has no nodes")
        self._distances = NodeDistances(self.representation, topomap.descriptors, exact=self._exact)
        self.topomap = topomap
        if self.alpha_given is None:
            self.alpha = float(suggest_alpha(topomap, self.shift)) if len(topomap) >= 3 else 0.0
        self._w = np.zeros(len(topomap), self._dtype)
        self._term = np.empty(len(topomap), self._dtype)
        self.reset()

    # -- per query ---------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget the query: zero weights, no previous estimate or frame, frame count 0."""
        self._w[:] = 0
        self._offset = 0
        self._prev: int | None = None
        self._frames = 0
        self._motion.reset()

    def _require_map(self) -> None:
        if self._distances is None:
            raise PpalocError("no map: call build_map(frames) or use_map(topomap) first")

    def step(self, frame: np.ndarray) -> Estimate:
        """Localise one new sensor frame ((256, 256) uint8); see the module doc."""
        self._require_map()
        self._frames += 1
        moved = self._motion.step(frame)
        if moved:
            self._forward()
        term = self._likelihood_term(frame)
        top = self._add_in_map_order(term)
        node, top = self._detect(top)
        score = self._confidence(node)
        ranking = self._ranking(node) if self.ranking_k else None
        if self._frames % self.k == 0 and self.gamma:
            self._adjust(top)
        weights = self.weights() if self.record_weights else None
        self._prev = node
        return Estimate(node=node, score=score, moved=moved, ranking=ranking, weights=weights)

    def localise(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """``reset()``, then ``step`` every frame in order (a convenience; still past-only)."""
        self.reset()
        return [self.step(f) for f in frames]

    @property
    def motion_model(self) -> MotionModel:
        """The motion model in use (its parameters are the ``motion_*`` arguments)."""
        return self._motion

    def weights(self) -> np.ndarray:
        """A copy of the current weights in map order (node 0 first)."""
        return np.roll(self._w, -self._offset)

    # -- the steps ---------------------------------------------------------------------------

    def _forward(self) -> None:
        """``w_i := max(w_{i-d} for d in advance)``; indices below 0 read the edge's 0."""
        w, n = self._w, len(self._w)
        lo, hi = self.advance
        for _ in range(min(lo, n)):  # shift by one: an offset change and one zero
            self._offset = (self._offset - 1) % n
            w[self._offset] = 0
        for _ in range(hi - lo):  # w_i := max(w_i, w_{i-1}) for all i at once
            first, last = self._offset, float(w[-1])
            head = float(w[first])
            np.maximum(w[1:], w[:-1], out=w[1:])  # numpy buffers the overlap
            w[0] = max(float(w[0]), last)
            w[first] = max(head, 0.0)  # node 0's predecessor is the edge

    def _likelihood_term(self, frame: np.ndarray) -> np.ndarray:
        """``alpha - mu_s`` per node, in map order (clipped to a register in ppa8)."""
        raw, term = self._distances(frame), self._term
        scale = distance_scale(self.representation, self.shift, self._exact)
        np.multiply(raw, self._dtype(-scale), out=term)
        term += self._dtype(self.alpha)
        if self._exact:
            _clip(term, _T_MIN, _T_MAX)
        return term

    def _add_in_map_order(self, term: np.ndarray) -> float:
        """``w += term`` in map order, then the weight clip; returns ``max(W)``."""
        w, off = self._w, self._offset
        n = len(w)
        w[off:] += term[: n - off]
        w[:off] += term[n - off :]
        return _clip(w, _W_MIN, _W_MAX)

    def _to_node(self, physical: np.ndarray | int) -> np.ndarray | int:
        return (physical - self._offset) % len(self._w)

    def _detect(self, top: float) -> tuple[int, float]:
        """Return (node, threshold): the candidate nearest the previous estimate."""
        w = self._w
        threshold = math.floor(top) if self._exact else top
        if threshold == top and np.count_nonzero(w == top) == 1:  # no tie: skip the search
            return int(self._to_node(int(w.argmax()))), threshold
        candidates = self._to_node(np.flatnonzero(w >= threshold))
        if len(candidates) == 1:
            return int(candidates[0]), threshold
        return choose_candidate(np.sort(candidates), self._prev), threshold

    def _max_outside(self, node: int) -> float | None:
        """The largest weight outside nodes ``node - R .. node + R`` (None if there is none)."""
        n, r = len(self._w), self.confidence_radius
        lo, hi = max(node - r, 0), min(node + r + 1, n)
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

    def _confidence(self, node: int) -> float:
        """Best weight minus the best weight outside +-R nodes (0 when the map is smaller)."""
        best = float(self._w[(node + self._offset) % len(self._w)])
        outside = self._max_outside(node)
        return 0.0 if outside is None else best - outside

    def _ranking(self, node: int) -> np.ndarray:
        """The ``ranking_k`` best nodes, best first, starting with the estimate."""
        w = self._w
        k = min(self.ranking_k + 1, len(w))
        top = _top_k(w, k)
        nodes = self._to_node(top)
        nodes = nodes[np.lexsort((nodes, -w[top]))]  # by weight, then node index
        nodes = nodes[nodes != node]
        return np.concatenate(([node], nodes))[: self.ranking_k].astype(np.int64)

    def _adjust(self, top: float) -> None:
        """``w = clip(w - g)``, ``g = gamma * max(W)`` (floored to an integer in ppa8).

        Only the lower bound can be crossed: for ``max(W) >= 0`` every weight falls, and
        for ``max(W) < 0`` the largest becomes ``max(W) - g < 1``. So one subtraction and
        one ``maximum`` pass (with ``k = 1`` many weights sit at the bound every frame).
        """
        w = self._w
        g = math.floor(self.gamma * top) if self._exact else self._dtype(self.gamma * top)
        if not g:
            return
        w -= g
        if g > 0:
            np.maximum(w, _W_MIN, out=w)
