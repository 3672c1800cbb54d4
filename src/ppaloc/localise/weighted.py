"""The weighted-node filter on the host: the robust filter (default) and the paper's Algorithm 1.

``preset="robust"`` (docs/localise.md, "The robust filter"; docs/ppa8.md): per frame,

1. transition: ``w_i := max over d of (w_{i-d} - c_d)``, ``d = 0 .. max_advance``, with
   the costs ``c_d`` set by the motion test (:func:`ppaloc.localise.params.transition_costs`);
   nodes before node 0 read the floor ("no hypothesis");
2. likelihood scaled per frame (low-res images contrast-normalised first,
   :func:`ppaloc.place.normalise_contrast`): ``mu_s = mu * 2**-s_t`` with ``s_t`` chosen from the
   frame's own best and mean distance (:func:`~ppaloc.localise.params.likelihood_shift`);
3. update ``w_i += alpha_t - mu_s_i`` with ``alpha_t = best * 2**-s_t``;
4. detection as below;
5. normalisation ``w_i := max(w_i - max(W), -memory)``.

``preset="paper"``, Algorithm 1, per frame in this order:

1. motion: forward or stay; on forward ``w_i := w_{i-1}`` along the map and ``w_0 := 0``;
2. likelihood ``mu_i`` in register units, scaled to ``mu_s = mu * 2**-shift``;
3. update ``w_i += alpha - mu_s_i``;
4. detection: the highest weight, ties to the candidate nearest the previous estimate;
5. every ``k``-th frame the adjustment ``w_i -= gamma * max(W)``.

``arithmetic="float"`` runs either in float32 with the weights kept in the register's range
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
from ppaloc.localise.motion import (
    AlwaysForward,
    ImageMotion,
    MotionModel,
    OracleMotion,
    check_moves,
)
from ppaloc.localise.params import (
    DEFAULT_SHIFT,
    GAMMAS,
    FilterParams,
    check_int,
    frame_statistics,
    likelihood_shift,
    transition_costs,
)
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

_REPRESENTATIONS = ("lowres", "lbp")
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


def make_motion_model(params: FilterParams, oracle_moves: Any = None) -> MotionModel:
    """The motion model ``params.motion`` names, with its parameters."""
    if params.motion == "oracle":
        if oracle_moves is None:
            raise PpalocError(
                "motion='oracle' needs oracle_moves= (e.g. the dataset's query_moved)"
            )
        return OracleMotion(oracle_moves)
    if params.motion == "always_forward":
        return AlwaysForward()
    return ImageMotion(params.motion_margin, params.motion_shift, params.motion_min_support)


def keyframe_test(params: FilterParams):
    """``keep(frame) -> bool`` for :func:`ppaloc.topomap.build_topomap`, or None.

    With ``params.keyframes`` a reference frame starts a new node when the image motion
    test says forward from the previous reference frame (the same test, with the same
    parameters, as the query's); a stop in the reference becomes one node.
    """
    if not params.keyframes:
        return None
    motion = ImageMotion(params.motion_margin, params.motion_shift, params.motion_min_support)
    return motion.step


def _read_values(kind: str, raw: np.ndarray, exact: bool) -> np.ndarray:
    """The per-node integers the controller reads to scale the likelihood (docs/ppa8.md).

    LBP: ``mu = 2h``, exact. Low-res ``ppa8``: the ADC code of ``-mu/2`` (the halving
    tree's result, ``code = floor(128.5 - mu/2)``) read back as ``2 (128 - code)``.
    Low-res ``float``: ``mu`` itself.
    """
    if kind == "lbp":
        return raw.astype(np.int64) * 2
    if exact:  # raw = T, mu = T / 2**17, mu / 2 = T / 2**18
        code = (257 * 2**17 - raw.astype(np.int64)) >> 18
        return 2 * (128 - code)
    return raw.astype(np.float64) / 128.0


class WeightedNodeLocaliser:
    """The weighted-node filter over a 1-D topological map: robust (default) or the paper's.

    Parameters
    ----------
    representation : {"lowres", "lbp"}
        Node kind: 8x8 low-res images compared by mean absolute difference, or 32-bit LBP
        descriptors compared by Hamming distance.
    preset : {"robust", "paper"}
        ``"robust"`` (default): the max-product filter of docs/localise.md ("The robust
        filter"), which absorbs motion-test errors, stops and speed changes. ``"paper"``:
        Algorithm 1 of the paper, exactly (forward-or-stay shift, ``alpha``, ``gamma``).
    gain, memory, stay_cost, move_cost, skip_cost, max_advance, contrast : int, optional
        The robust filter's parameters (:class:`ppaloc.localise.params.FilterParams`):
        per-frame likelihood span (4), floor below the best weight (127), transition
        costs (4, 4, 4), the most nodes one frame may advance (2) and the contrast low-res
        images are normalised to (48 grey levels; 0: none).
    keyframes : bool, optional
        One node per distinct place (a reference frame starts a node when the motion
        test says forward). Default: on for the robust preset with the image motion
        model, off otherwise.
    alpha : int or float, optional
        Paper: likelihood at which a node neither gains nor loses weight. None (default)
        takes :func:`suggest_alpha` of the map when it is built or loaded (0 for a map of
        fewer than 3 nodes). Must be an integer in [-128, 127] for ``arithmetic="ppa8"``.
    gamma : float, optional
        Paper: adjustment factor, one of 0, 1/8, 1/4, 1/2, 1 (default 1/2).
    k : int, optional
        Paper: frames between adjustments (default 1).
    shift : int, optional
        Paper: likelihood scale ``mu_s = mu * 2**-shift``. Default: 2 for low-res, 1 for
        LBP, so one frame's term spans 0-32 units in both.
    advance : (int, int), optional
        Paper: nodes a forward move may advance, ``(lo, hi)`` (default ``(1, 1)``, the
        paper's one-node shift); host only. See docs/localise.md.
    motion : {"image", "always_forward", "oracle"}
        Motion model (default ``"image"``, see :mod:`ppaloc.localise.motion`).
    arithmetic : {"float", "ppa8"}
        ``"float"``: float32 weights clipped to [-127, 127], ties only between equal
        weights, the live low-res image quantised like a node (uint8 SAD, the fast path).
        ``"ppa8"``: the register arithmetic of docs/ppa8.md, exactly (the live frame's
        exact block means, integer thresholds and DAC constants).
    confidence_radius : int
        ``R`` of the confidence score (default 10 nodes): the best weight minus the best
        weight outside nodes ``node - R .. node + R``.
    ranking_k : int
        How many nodes ``Estimate.ranking`` lists, best first (default 10; 0 = none).
    record_weights : bool
        Put a copy of the weights (map order, after the frame) in every Estimate.
    oracle_moves : sequence of bool, optional
        Ground-truth moves for ``motion="oracle"`` (a dataset's ``query_moved``).
    motion_margin, motion_shift, motion_min_support : int
        Parameters of the image motion model (:class:`ImageMotion`); ``motion_margin``
        defaults to the preset's (4 robust, 3 paper).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> frames = rng.integers(0, 256, (6, 256, 256), dtype=np.uint8)
    >>> loc = WeightedNodeLocaliser("lbp", motion="always_forward")
    >>> _ = loc.build_map(frames)
    >>> [loc.step(f).node for f in frames[2:5]]
    [2, 3, 4]
    """

    def __init__(
        self,
        representation: str = "lowres",
        *,
        preset: str = "robust",
        gain: int | None = None,
        memory: int | None = None,
        stay_cost: int | None = None,
        move_cost: int | None = None,
        skip_cost: int | None = None,
        max_advance: int | None = None,
        contrast: int | None = None,
        keyframes: bool | None = None,
        alpha: float | None = None,
        gamma: float | None = None,
        k: int | None = None,
        shift: int | None = None,
        advance: tuple[int, int] | None = None,
        motion: str = "image",
        arithmetic: str = "float",
        confidence_radius: int = 10,
        ranking_k: int = 10,
        record_weights: bool = False,
        oracle_moves: Sequence[bool] | np.ndarray | None = None,
        motion_margin: int | None = None,
        motion_shift: int = 6,
        motion_min_support: int = 1024,
    ) -> None:
        if representation not in _REPRESENTATIONS:
            raise PpalocError(
                f"representation={representation!r} is not one of {', '.join(_REPRESENTATIONS)}"
            )
        if arithmetic not in _ARITHMETICS:
            raise PpalocError(f"arithmetic={arithmetic!r} is not one of {', '.join(_ARITHMETICS)}")
        given = {
            "gain": gain,
            "memory": memory,
            "stay_cost": stay_cost,
            "move_cost": move_cost,
            "skip_cost": skip_cost,
            "max_advance": max_advance,
            "contrast": contrast,
            "keyframes": keyframes,
            "alpha": alpha,
            "gamma": gamma,
            "k": k,
            "shift": shift,
            "advance": advance,
            "motion_margin": motion_margin,
        }
        self.params = FilterParams.create(
            representation,
            preset=preset,
            arithmetic=arithmetic,
            motion=motion,
            confidence_radius=confidence_radius,
            motion_shift=motion_shift,
            motion_min_support=motion_min_support,
            **{key: v for key, v in given.items() if v is not None},
        )
        p = self.params
        self.ranking_k = check_int("ranking_k", ranking_k, 0)
        if oracle_moves is not None:  # checked whatever the motion model: results keep it
            oracle_moves = check_moves(oracle_moves)
        self._motion = make_motion_model(p, oracle_moves)
        self.representation = representation
        self.arithmetic = arithmetic
        self.preset = p.preset
        self.motion = p.motion
        self.confidence_radius = p.confidence_radius
        self.robust = p.preset == "robust"
        if self.robust:
            self.gamma, self.k, self.shift, self.advance = 0.0, 1, 0, (1, 1)
        else:
            self.gamma, self.k, self.shift = float(p.gamma), int(p.k), int(p.shift)
            self.advance = p.advance
        self.alpha_given = p.alpha
        self.alpha: float | None = p.alpha
        self.record_weights = bool(record_weights)
        self.name = f"weighted-node-{representation}"
        self._exact = arithmetic == "ppa8"
        self._dtype = np.float64 if self._exact else np.float32
        self.topomap: TopoMap | None = None
        self._distances: NodeDistances | None = None
        self._w = np.zeros(0, self._dtype)
        self.last_shift: int | None = None

    # -- map -------------------------------------------------------------------------------

    def build_map(self, frames: Iterable[np.ndarray]) -> TopoMap:
        """Build the map from a reference traversal and use it.

        One node per frame, or with ``keyframes`` one per distinct place
        (:func:`keyframe_test`); ``TopoMap.frame_index`` keeps each node's first frame.
        The frames are read once, in order, and only their descriptors are kept.
        """
        empty = "the reference traversal is empty: a map needs at least one frame"
        if hasattr(frames, "__len__") and not len(frames):  # type: ignore[arg-type]
            raise PpalocError(empty)
        topomap = build_topomap(frames, self.representation, keep=keyframe_test(self.params))
        if not len(topomap):
            raise PpalocError(empty)
        self.use_map(topomap)
        return topomap

    def use_map(self, topomap: TopoMap) -> None:
        """Localise against ``topomap`` (e.g. one loaded from a file) from now on."""
        if topomap.kind != self.representation:
            raise PpalocError(
                f"the map holds {topomap.kind!r} nodes but this localiser uses "
                f"{self.representation!r} nodes; localise it with representation="
                f"{topomap.kind!r}, or build a map with representation={self.representation!r}"
            )
        if len(topomap) == 0:
            raise PpalocError("the map has no nodes")
        contrast = self.params.contrast if self.robust and self.representation == "lowres" else None
        self._distances = NodeDistances(
            self.representation, topomap.descriptors, exact=self._exact, contrast=contrast
        )
        self.topomap = topomap
        if self.robust:
            self.alpha = None  # chosen per frame from the frame's own distances
        elif self.alpha_given is None:
            self.alpha = float(suggest_alpha(topomap, self.shift)) if len(topomap) >= 3 else 0.0
        self._w = np.zeros(len(topomap), self._dtype)
        self._term = np.empty(len(topomap), self._dtype)
        self._pred = np.empty(len(topomap), self._dtype)
        self._shifted = np.empty(len(topomap), self._dtype)
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
        if self.robust:
            first = self._frames == 1
            if not first:
                self._transition(transition_costs(moved, self.params))
            # a frame the motion test calls still repeats the last one: no new evidence
            if first or moved:
                top = self._add_in_map_order(self._robust_term(frame))
            else:
                top = float(self._w.max())
        else:
            if moved:
                self._forward()
            top = self._add_in_map_order(self._likelihood_term(frame))
        node, top = self._detect(top)
        score = self._confidence(node)
        ranking = self._ranking(node) if self.ranking_k else None
        if self.robust:
            self._normalise(top)
        elif self._frames % self.k == 0 and self.gamma:
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

    def _transition(self, costs: tuple[int, ...]) -> None:
        """Robust: ``w_i := clip(max_d (w_{i-d} - c_d))``; nodes before node 0 read the floor.

        The weights of the robust filter are kept in map order (offset 0): the max over
        shifted copies moves every weight anyway.
        """
        w, pred, tmp = self._w, self._pred, self._shifted
        floor = -float(self.params.memory)
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

    def _robust_term(self, frame: np.ndarray) -> np.ndarray:
        """Robust: ``alpha_t - mu * 2**-s_t`` per node, scaled from the frame's distances.

        ``best`` and ``mean`` of the frame's distances to all nodes (what the controller
        reads back from the array, :func:`_read_values`) give ``s_t =
        likelihood_shift(mean - best, gain)`` and ``alpha_t = best * 2**-s_t`` (floored
        to an integer in ppa8), so the best node gains about 0 and the mean node loses
        about ``gain``, whatever the season, light or contrast.
        """
        raw, term = self._distances(frame), self._term
        values = _read_values(self.representation, raw, self._exact)
        if self._exact:
            best, mean = frame_statistics(values)
        else:
            best, mean = float(values.min()), float(values.mean())
        s = likelihood_shift(mean - best, self.params.gain)
        self.last_shift = s
        alpha = (best >> s) if self._exact else best * 2.0**-s
        np.multiply(
            raw, self._dtype(-distance_scale(self.representation, s, self._exact)), out=term
        )
        term += self._dtype(alpha)
        if self._exact:
            _clip(term, _T_MIN, _T_MAX)
        return term

    def _normalise(self, top: float) -> None:
        """Robust: ``w := max(clip(w - T), -memory)``, ``T`` the detection threshold.

        The best weight returns to [0, 1) every frame (no saturation at the top, so no
        ties there), and every hypothesis stays within ``memory`` of it, so a wrong lock
        is overturned by about ``memory / gain`` frames of better evidence.
        """
        w = self._w
        w -= self._dtype(top)
        _clip(w, _W_MIN, _W_MAX)
        np.maximum(w, self._dtype(-self.params.memory), out=w)

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
