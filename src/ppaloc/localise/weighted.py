"""The weighted-node filter on the host, as a :class:`~ppaloc.localise.base.Localiser`.

:class:`WeightedNodeLocaliser` is the filter of Castillo-Elizalde et al. (ICRA 2021) over a
1-D topological map: the schedule of its preset (:mod:`ppaloc.localise.schedule`;
``"robust"``, the default, or ``"paper"``, Algorithm 1) run on the host's executor
(:class:`ppaloc.localise.host.HostExecutor`, float or ppa8 arithmetic). The same
schedules run on the simulated sensor (:mod:`ppaloc.onsensor`), so host and sensor
cannot drift apart.

``preset="robust"`` (docs/localise.md, "The robust filter"; docs/ppa8.md), per frame:

1. transition: ``w_i := max over d of (w_{i-d} - c_d)``, ``d = 0 .. max_advance``, with
   the costs ``c_d`` set by the motion test (:func:`ppaloc.localise.params.transition_costs`),
   a forward frame's centred on the speed of the estimate's own path
   (:func:`~ppaloc.localise.params.path_speed`), or at half scale where the path shows
   none and its speeds varied lately (:func:`~ppaloc.localise.params.speed_varies`);
   nodes before node 0 read the floor;
2. likelihood scaled per frame (low-res images contrast-normalised first,
   :func:`ppaloc.place.normalise_contrast`): ``mu_s = mu * 2**-s_t`` with ``s_t`` chosen from the
   frame's own best and mean distance (:func:`~ppaloc.localise.params.frame_scale`);
3. update ``w_i += alpha_t - mu_s_i`` with ``alpha_t = best * 2**-s_t``, then the local
   term: ``local_gain / (2 local_window)`` units less for each of the ``2 local_window``
   neighbours whose distance is strictly smaller (:func:`~ppaloc.localise.enhance.closer_count`;
   on a map with runs the nodes next to a run, :func:`~ppaloc.localise.enhance.place_neighbours`);
4. detection: the highest weight, ties to the candidate nearest the previous estimate;
   its confidence 0 where the estimate's path stood still while the query moved
   (:func:`~ppaloc.localise.params.path_stalled`) and lower on still frames where the
   map kept moving (:func:`~ppaloc.localise.params.still_score`);
5. normalisation ``w_i := max(w_i - max(W), -memory)``.

``preset="paper"``, Algorithm 1, per frame in this order:

1. motion: forward or stay; on forward ``w_i := w_{i-1}`` along the map and ``w_0 := 0``;
2. likelihood ``mu_i`` in register units, scaled to ``mu_s = mu * 2**-shift``;
3. update ``w_i += alpha - mu_s_i``;
4. detection as above;
5. every ``k``-th frame the adjustment ``w_i -= gamma * max(W)``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Literal

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.alpha import ALPHA_CAP, ALPHA_FACTOR, suggest_alpha
from ppaloc.localise.base import DatasetNeed, Estimate, MethodParam
from ppaloc.localise.host import ARITHMETICS, HostExecutor
from ppaloc.localise.motion import ImageMotion, MotionModel
from ppaloc.localise.params import (
    DEFAULT_SHIFT,
    GAMMAS,
    DeclaredSpeeds,
    FilterParams,
    check_int,
    choose_candidate,
    filter_method_params,
)
from ppaloc.localise.schedule import SCHEDULES, Schedule, make_schedule
from ppaloc.place.patch import check_frame
from ppaloc.topomap import TopoMap, build_topomap

__all__ = [
    "ALPHA_CAP",
    "ALPHA_FACTOR",
    "DEFAULT_SHIFT",
    "GAMMAS",
    "MAX_RANKING",
    "ORACLE_NEED",
    "REPRESENTATIONS",
    "WeightedNodeLocaliser",
    "check_map",
    "choose_candidate",
    "keyframe_test",
    "place_test",
    "suggest_alpha",
]

REPRESENTATIONS = ("lowres", "lowres16", "lbp", "haar", "patch")
"""Place representations of the weighted-node filter (docs/ppa8.md; ``"patch"``, the
baselines' own image, on the host only)."""

MAX_RANKING = 10_000
"""The longest ranking an estimate lists (``ranking_k``)."""

ORACLE_NEED = DatasetNeed(
    "query_moved",
    "motion='oracle' needs the true query motion",
    "use motion='image' or a dataset with query_moved (synthetic)",
    stand_in=np.zeros(1, dtype=bool),
)
"""What ``motion="oracle"`` reads from a dataset: the true moves, as ``oracle_moves``."""


def oracle_needs(params: Mapping[str, Any]) -> dict[str, DatasetNeed]:
    """``{"oracle_moves": ORACLE_NEED}`` when ``params`` ask for the oracle motion model
    without giving its moves; nothing otherwise."""
    if params.get("motion") == "oracle" and params.get("oracle_moves") is None:
        return {"oracle_moves": ORACLE_NEED}
    return {}


def keyframe_test(params: FilterParams):
    """``keep(frame) -> bool`` for :func:`ppaloc.topomap.build_topomap`, or None.

    With ``params.keyframes`` a reference frame starts a new node when the image motion
    test says forward from the previous reference frame (the same test, with the same
    parameters, as the query's); a stop in the reference becomes one node.
    """
    if not params.keyframes:
        return None
    motion = ImageMotion.of(params)
    return motion.step


def place_test(params: FilterParams):
    """``new_place(frame) -> bool`` for :func:`ppaloc.topomap.build_topomap`, or None.

    A map of one node per frame (``keyframes=False``) with the image motion model records
    where the reference stood still when the preset's schedule uses runs (the robust
    preset): the motion test over consecutive reference frames, as in
    :func:`keyframe_test`, marks a frame that shows the previous frame's place, and the
    filter treats a run of such nodes as one place. Other motion models (a
    frame-synchronised query) map every frame as a place of its own.
    """
    if params.keyframes or params.motion != "image" or not SCHEDULES[params.preset].runs:
        return None
    motion = ImageMotion.of(params)
    return motion.step


def check_map(topomap: TopoMap, representation: str) -> None:
    """A one-line error unless ``topomap`` holds at least one node of ``representation``
    (the host and the sensor localisers alike)."""
    if topomap.kind != representation:
        raise PpalocError(
            f"the map holds {topomap.kind!r} nodes but this localiser uses "
            f"{representation!r} nodes; localise it with representation="
            f"{topomap.kind!r}, or build a map with representation={representation!r}"
        )
    if len(topomap) == 0:
        raise PpalocError("the map has no nodes")


def check_representation(representation: str) -> str:
    """``representation`` if it is one of :data:`REPRESENTATIONS`, else a one-line error."""
    if representation not in REPRESENTATIONS:
        raise PpalocError(
            f"representation={representation!r} is not one of {', '.join(REPRESENTATIONS)}"
        )
    return representation


class WeightedNodeLocaliser(DeclaredSpeeds):
    """The weighted-node filter over a 1-D topological map: robust (default) or the paper's.

    Parameters
    ----------
    representation : {"lowres", "lowres16", "lbp", "haar", "patch"}
        Node kind: 8x8 or 16x16 low-res images compared by mean absolute difference (the
        16x16 ones with the robust preset only), 32-bit LBP descriptors or the 192 Haar
        signs (robust only) compared by Hamming distance, or SeqSLAM's patch-normalised
        64x32 image, the baselines' own (robust, float, host only; docs/localise.md).
    arithmetic : {"float", "ppa8"}
        ``"float"``: float32 weights clipped to [-127, 127], ties only between equal
        weights, the live low-res image quantised like a node (uint8 SAD, the fast path).
        ``"ppa8"``: the register arithmetic of docs/ppa8.md, exactly (the live frame's
        exact block means, integer thresholds and DAC constants).
    ranking_k : int
        How many nodes ``Estimate.ranking`` lists, best first (default 10; 0 = none).
    record_weights : bool
        Put a copy of the weights (map order, after the frame) in every Estimate.
    oracle_moves : sequence of bool, optional
        Ground-truth moves for ``motion="oracle"`` (a dataset's ``query_moved``).
    **filter_params
        The filter's parameters, each with its one default and range
        (:class:`ppaloc.localise.params.FilterParams`, docs/localise.md): ``preset``
        (``"robust"``, the default, or ``"paper"``), ``motion``, ``motion_margin``,
        ``motion_shift``, ``motion_min_support``, ``confidence_radius``, ``keyframes``;
        robust ``gain``, ``memory``, ``stay_cost``, ``move_cost``, ``skip_cost``,
        ``max_advance``, ``contrast``; paper ``alpha`` (None: chosen from the map by
        :func:`suggest_alpha`), ``gamma``, ``k``, ``shift``, ``advance``.

    Attributes
    ----------
    params : FilterParams
        The resolved parameters.
    schedule : Schedule
        The preset's frame (:mod:`ppaloc.localise.schedule`).
    executor : HostExecutor
        The weights and the steps on them (:mod:`ppaloc.localise.host`).

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
        arithmetic: str = "float",
        ranking_k: int = 10,
        record_weights: bool = False,
        oracle_moves: Sequence[bool] | np.ndarray | None = None,
        **filter_params: Any,
    ) -> None:
        check_representation(representation)
        if arithmetic not in ARITHMETICS:
            raise PpalocError(f"arithmetic={arithmetic!r} is not one of {', '.join(ARITHMETICS)}")
        self.params = FilterParams.create(representation, arithmetic=arithmetic, **filter_params)
        self.ranking_k = check_int("ranking_k", ranking_k, 0, MAX_RANKING)
        self.schedule: Schedule = make_schedule(self.params, oracle_moves)
        self.executor = HostExecutor(
            representation, self.params, arithmetic=arithmetic, ranking_k=self.ranking_k
        )
        self.representation = representation
        self.arithmetic = arithmetic
        self.preset = self.params.preset
        self.motion = self.params.motion
        self.record_weights = bool(record_weights)
        self.name = f"weighted-node-{representation}"
        self.topomap: TopoMap | None = None

    @classmethod
    def parameters(cls) -> tuple[MethodParam, ...]:
        """Every keyword this localiser takes (:class:`~ppaloc.localise.base.MethodParam`):
        its own options, then the filter's parameters (:class:`FilterParams`)."""
        return (
            MethodParam(
                "representation", Literal["lowres", "lowres16", "lbp", "haar", "patch"], "lowres"
            ),
            MethodParam(
                "arithmetic",
                Literal["float", "ppa8"],
                "float",
                doc="float, or ppa8: the sensor's register arithmetic, exactly",
            ),
            MethodParam("ranking_k", int, 10, 0, MAX_RANKING, "nodes each estimate ranks"),
            MethodParam("record_weights", bool, False, doc="keep every frame's weights"),
            MethodParam("oracle_moves", Any, None, doc="the true moves, for motion='oracle'"),
            *filter_method_params(),
        )

    @classmethod
    def dataset_needs(cls, params: Mapping[str, Any]) -> dict[str, DatasetNeed]:
        """What the localiser reads from its dataset with ``params``: the true moves for
        ``motion="oracle"`` (:func:`oracle_needs`)."""
        return oracle_needs(params)

    @property
    def alpha(self) -> float | None:
        """Paper: the likelihood offset in use (given, or chosen from the map); None for
        the robust preset (``alpha_t`` is chosen per frame)."""
        return self.schedule.alpha

    @property
    def shift(self) -> int | None:
        """Paper: the likelihood shift (None for the robust preset)."""
        return self.params.shift

    @property
    def last_shift(self) -> int | None:
        """Robust: the likelihood shift of the last frame that added a likelihood."""
        return self.executor.last_shift

    @property
    def motion_model(self) -> MotionModel | None:
        """The host's motion test (its parameters are the ``motion_*`` arguments; None
        with the oracle, whose decisions the schedule hands over)."""
        return self.executor.motion_model

    # -- map -------------------------------------------------------------------------------
    def build_map(self, frames: Iterable[np.ndarray]) -> TopoMap:
        """Build the map from a reference traversal and use it.

        One node per frame, or with ``keyframes`` one per distinct place
        (:func:`keyframe_test`); ``TopoMap.frame_index`` keeps each node's first frame.
        A map of one node per frame records its places where the preset uses them
        (:func:`place_test`).
        The frames are read once, in order, and only their descriptors are kept.
        """
        empty = "the reference traversal is empty: a map needs at least one frame"
        if hasattr(frames, "__len__") and not len(frames):  # type: ignore[arg-type]
            raise PpalocError(empty)
        topomap = build_topomap(
            frames,
            self.representation,
            keep=keyframe_test(self.params),
            new_place=place_test(self.params),
        )
        if not len(topomap):
            raise PpalocError(empty)
        self.use_map(topomap)
        return topomap

    def use_map(self, topomap: TopoMap) -> None:
        """Localise against ``topomap`` (e.g. one loaded from a file) from now on."""
        check_map(topomap, self.representation)
        self.schedule.use_map(topomap)
        self.executor.use_map(topomap)
        # the speed lanes' weights, on the same distances
        self.schedule.use_lanes([self.executor.twin() for _ in range(self.schedule.wants_lanes)])
        self.topomap = topomap
        self.reset()

    # -- per query ---------------------------------------------------------------------------
    def reset(self) -> None:
        """Forget the query: zero weights, no previous estimate or frame, frame count 0."""
        self.schedule.reset()
        self.executor.reset()
        for lane in self.schedule.lanes:
            lane.reset()

    def step(self, frame: np.ndarray) -> Estimate:
        """Localise one new sensor frame ((256, 256) uint8) by the preset's schedule."""
        if self.topomap is None:
            raise PpalocError("no map: call build_map(frames) or use_map(topomap) first")
        # checked before the schedule counts the frame or moves the weights: a refused
        # frame leaves the filter as it was
        r = self.schedule.step(self.executor, check_frame(frame))
        ranking = self.executor.ranking
        if r.lane is not None and ranking is not None:  # a speed lane's estimate
            ranking = self.schedule.lanes[r.lane].ranking_for(r.node, self.ranking_k)  # type: ignore[attr-defined]
        return Estimate(
            node=r.node,
            score=r.score,
            moved=r.moved,
            ranking=ranking,
            weights=self.executor.weights() if self.record_weights else None,
        )

    def localise(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """``reset()``, then ``step`` every frame in order (a convenience; still past-only)."""
        self.reset()
        return [self.step(f) for f in frames]

    def weights(self) -> np.ndarray:
        """A copy of the current weights in map order (node 0 first)."""
        return self.executor.weights()
