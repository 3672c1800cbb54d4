"""The weighted-node filter's frame, once per preset: schedules run by executors.

A *schedule* states the steps of one frame in order (motion, transition or shift,
likelihood, detection, confidence, normalisation or adjustment) and makes every
decision between them with the shared decision functions of
:mod:`ppaloc.localise.params`. An *executor* does the steps on one set of weights:

- the host in float arithmetic and in the register arithmetic of docs/ppa8.md
  (:class:`ppaloc.localise.host.HostExecutor`);
- one simulated sensor (:class:`ppaloc.onsensor.executor.SensorExecutor`);
- a bank of simulated sensors, each running the sensor executor's stages on its part of
  the map (:class:`ppaloc.onsensor.bank.SensorBank`).

So a preset is written once, and the host filter, the sensor and the bank cannot drift
apart. A new preset is one :class:`Schedule` subclass and one :func:`register_schedule`
call: it reads the parameters of the group it names (:attr:`Schedule.uses`), runs on every
executor that has the steps it calls, and is offered by every weighted-node and
on-sensor method as ``preset=NAME``.

Examples
--------
A preset that never moves (every frame adds its likelihood to the node it is on):

>>> class Stay(PaperSchedule):
...     def step(self, ex, frame):
...         self.frames += 1
...         ex.begin(frame)
...         moved = ex.motion(self.decided())
...         ex.add_likelihood(self.alpha, self.params.shift)
...         return self.finish(ex, moved)
>>> sorted(SCHEDULES)
['paper', 'robust']
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.motion import OracleMotion, check_moves
from ppaloc.localise.params import (
    DETECT_BITS,
    VARY_AGE,
    VARY_RECORD,
    FilterParams,
    PathSpeed,
    adjustment,
    centroid_window,
    concentration,
    frame_scale,
    lane_reported,
    lane_speed_led,
    lane_speed_taken,
    lane_speeds,
    local_centroid,
    past_map_end,
    path_speed,
    path_stalled,
    speed_off,
    speed_varies,
    still_score,
    stood_at_or_next,
    transition_costs,
)

if TYPE_CHECKING:
    from ppaloc.topomap import TopoMap

__all__ = [
    "SCHEDULES",
    "Executor",
    "FrameResult",
    "PaperSchedule",
    "RobustSchedule",
    "Schedule",
    "SensorPlan",
    "make_schedule",
    "register_schedule",
]


class Executor(Protocol):
    """The steps a schedule calls, on one set of weights (host, sensor or bank).

    An executor need not offer every step: a schedule calls only its own (the robust
    schedule never shifts, the paper's never transitions). Values are in register units
    (docs/ppa8.md); ``exact`` executors compute in register arithmetic (integer
    thresholds and DAC constants), the others in float. ``integer_readout`` executors
    read each node's value as the controller's readout integer, from which the robust
    schedule decides the frame's scale in integers: True everywhere but the host on
    distances ``enhance`` has made floats and on its float place (``"patch"``).
    """

    exact: bool
    integer_readout: bool

    def begin(self, frame: np.ndarray) -> None:
        """Take the frame (on a sensor: refresh, capture, block means)."""

    def motion(self, decided: bool | None) -> bool:
        """The motion decision: ``decided`` (the controller's, e.g. the oracle's) when
        given, else the executor's own test (image motion, or forward after the first)."""
        ...

    def transition(self, costs: tuple[int, ...]) -> None:
        """Robust: ``w_i := clip(max_d (w_{i-d} - c_d))`` (after the pending normalisation)."""

    def node_values(self) -> np.ndarray:
        """Robust: each node's distance as the controller reads it (docs/ppa8.md)."""
        ...

    def minimum(self, values: np.ndarray) -> float:
        """Robust: the frame's best distance (on an integer readout refined beyond its
        resolution where the sensor refines it,
        :func:`~ppaloc.localise.params.refined_minimum`)."""
        ...

    def add_scaled(self, shift: int, alpha: float) -> None:
        """Robust: ``w_i += alpha - mu_i 2**-shift`` from the values just read."""

    def add_local(self, gain: int, window: int) -> None:
        """Robust, ``local_gain``: ``w_i -= gain * closer_share(distances, window,
        places)_i`` (:func:`~ppaloc.localise.enhance.closer_share`; on a map with runs the
        neighbours are the nodes next to a run) from the distances just compared."""

    def shift(self) -> None:
        """Paper: every weight one node along the map (``advance`` nodes on the host)."""

    def add_likelihood(self, alpha: float, shift: int) -> None:
        """Paper: ``w_i += alpha - mu_i 2**-shift``."""

    def detect(self, prev: int | None, bits: int = 0) -> tuple[int, float]:
        """``(node, T)``: the threshold ``T`` (``floor(max W)`` when exact) and the
        candidate nearest ``prev`` among ``w >= T`` (exact: ``w >= floor(2**bits max W) /
        2**bits``, the threshold refined by ``bits`` fraction bits; ``T`` stays the
        integer)."""
        ...

    def confidence(self, node: int, top: float, window: tuple[int, int], bits: int = 0) -> float:
        """The best weight minus the best outside the nodes ``window = (a, b)``
        (inclusive; 0 when no node is outside). Exact with ``bits``: the detection's
        refined threshold ``floor(2**bits max W) / 2**bits`` minus the outside maximum
        floored the same way (what a sensor's threshold searches find)."""
        ...

    def weight_reads(self, a: int, b: int) -> list[float]:
        """Robust, ``centroid_radius`` and ``concentration_radius``: the weights of nodes
        ``a .. b`` (inclusive, on the map) after the confidence, as the controller reads
        them: one ADC read each where ``exact`` (the nearest integer,
        :func:`~ppaloc.localise.params.weight_read`), the values themselves in float."""
        ...

    def rank(self, node: int) -> None:
        """Keep what the frame's estimate reports before the weights change again (the
        host's ranking, the reported estimate first); nothing on executors that report
        none."""

    def normalise(self, top: float) -> None:
        """Robust: ``w := max(clip(w - T), -memory)`` (a sensor may defer it)."""

    def adjust(self, amount: float) -> None:
        """Paper: ``w := clip(w - amount)``."""


@dataclass(frozen=True)
class FrameResult:
    """What a schedule's frame decided: the reported estimate, its confidence, the
    motion decision and the detection threshold ``top`` (``T``); ``detected``: the node
    the detection found, which the filter goes on from (the tie-break, the path), the
    reported node or another (:meth:`Schedule.report`; None where a caller builds a
    result without one: :attr:`found` is then the node); ``lane``: the speed lane whose
    estimate and confidence these are (its index, fastest first), None for the filter's
    own (:func:`~ppaloc.localise.params.lane_reported`); ``share``: the weights'
    concentration about the detected node
    (:func:`~ppaloc.localise.params.concentration`; 1 where a preset reads none), which
    the robust filter's reported confidence is multiplied by as its frame ends (its
    lanes' results keep the margin their gates read)."""

    node: int
    score: float
    moved: bool
    top: float
    lane: int | None = None
    detected: int | None = None
    share: float = 1.0

    @property
    def found(self) -> int:
        """The detected node (:attr:`detected`, or :attr:`node` where they are one)."""
        return self.node if self.detected is None else self.detected


@dataclass(frozen=True)
class SensorPlan:
    """What a schedule asks of the sensor executor besides its steps.

    Attributes
    ----------
    stores : tuple of str
        Map stores in order of preference; the sensor takes the first its
        representation has (docs/onsensor.md, "Map store").
    spread : {"copies", "tree"}
        How the block means are spread over their blocks: masked copies from the block
        roots (a few writes per PE) or the paper's doubling tree over a zero background.
    keep_scale : bool
        Calibrate the array's transfer gain at start-up and restore the weights' scale
        in steps (:mod:`ppaloc.onsensor.gain`): for weights that live through many writes.
    bank : bool
        Whether the schedule's frame runs on a bank of sensors (its exchange points are
        the ones :class:`ppaloc.onsensor.bank.SensorBank` implements).
    minimum : bool
        Whether the schedule asks for the frame's best distance (:meth:`Executor.minimum`),
        which the sensor refines on the array next to the tree's values: a low-res
        sensor then holds one tile (:mod:`ppaloc.onsensor.minimum`).
    """

    stores: tuple[str, ...] = ("levels", "digital")
    spread: str = "copies"
    keep_scale: bool = True
    bank: bool = True
    minimum: bool = True


class Schedule:
    """One preset's frame: the steps in order and the decisions between them.

    Parameters
    ----------
    params : FilterParams
        The filter's parameters (resolved for this preset).
    oracle_moves : sequence of bool, optional
        The true moves for ``motion="oracle"`` (a dataset's ``query_moved``): the
        schedule hands frame ``n``'s to the executor as the controller's decision.

    Attributes
    ----------
    uses : {"robust", "paper"}
        The parameter group the schedule reads (:class:`FilterParams`).
    sensor : SensorPlan
        What it asks of a sensor executor.
    frames : int
        Frames since :meth:`reset`.
    prev : int or None
        The last frame's detected node (the tie-break's; the node reported may be
        another, :meth:`report`).
    """

    uses: ClassVar[str] = "robust"
    sensor: ClassVar[SensorPlan] = SensorPlan()
    #: Fraction bits of the detection threshold in register arithmetic (0: the integer
    #: ``floor(max W)``, as Algorithm 1).
    detect_bits: ClassVar[int] = 0
    #: Whether a map of one node per frame records its places (a stop of the reference
    #: is a run of nodes of one place, ``TopoMap.places``), which the schedule's
    #: transition and confidence then use.
    runs: ClassVar[bool] = False

    def __init__(self, params: FilterParams, oracle_moves: Any = None) -> None:
        self.params = params
        if oracle_moves is not None:  # checked whatever the motion model: results keep it
            oracle_moves = check_moves(oracle_moves)
        self._oracle: OracleMotion | None = None
        if params.motion == "oracle":
            if oracle_moves is None:
                raise PpalocError(
                    "motion='oracle' needs oracle_moves= (e.g. the dataset's query_moved)"
                )
            self._oracle = OracleMotion(oracle_moves)
        self.alpha: float | None = None
        self.topomap: TopoMap | None = None
        self.reset()

    @property
    def max_advance(self) -> int:
        """The most nodes one frame may move a weight (what a bank carries across)."""
        return 1

    def use_map(self, topomap: TopoMap) -> None:
        """Take the per-map constants once the map is known (the places of its nodes; the
        paper's ``alpha``)."""
        self.topomap = topomap

    #: The executors of the speed lanes (:class:`RobustSchedule`), fastest first.
    lanes: tuple[Executor, ...] = ()

    @property
    def wants_lanes(self) -> int:
        """How many speed lanes the frame runs, whose executors the localiser hands over
        with :meth:`use_lanes` (only the robust schedule's, with ``lane_speed`` or
        ``slow_lane``)."""
        return 0

    def use_lanes(self, executors: Sequence[Executor]) -> None:
        """Run the speed lanes on ``executors`` (only schedules that want them)."""
        if tuple(executors):
            raise PpalocError(f"preset {self.params.preset!r} runs no speed lane")

    def window(self, node: int) -> tuple[int, int]:
        """The nodes the confidence leaves out around ``node``: ``node +-
        confidence_radius``, counted in places where the schedule uses the map's runs."""
        radius = int(self.params.confidence_radius)  # type: ignore[arg-type]
        if self.runs and self.topomap is not None:
            return self.topomap.place_window(node, radius)
        return node - radius, node + radius

    def place(self, node: int) -> int:
        """The place of ``node``: its run's on a map with runs, else the node itself."""
        places = self.topomap.places if self.runs and self.topomap is not None else None
        return node if places is None else int(places[node])

    def reset(self) -> None:
        """A new query: no frame, no previous estimate, the oracle from its first move."""
        self.frames = 0
        self.prev: int | None = None
        if self._oracle is not None:
            self._oracle.reset()

    def decided(self) -> bool | None:
        """The controller's motion decision for this frame (the oracle's), or None."""
        return None if self._oracle is None else self._oracle.step(None)  # type: ignore[arg-type]

    def step(self, ex: Executor, frame: np.ndarray) -> FrameResult:  # pragma: no cover
        """Run one frame on ``ex``."""
        raise NotImplementedError

    def finish(self, ex: Executor, moved: bool) -> FrameResult:
        """The end of every preset's frame: detection, confidence, the estimate reported
        (:meth:`report`) and ranking, then :meth:`end_frame` (the normalisation or the
        adjustment)."""
        node, top = ex.detect(self.prev, self.detect_bits)
        score = ex.confidence(node, top, self.window(node), self.detect_bits)
        reported, share = self.report(ex, node)
        ex.rank(reported)
        self.end_frame(ex, top)
        self.prev = node
        return FrameResult(reported, score, moved, top, detected=node, share=share)

    def report(self, ex: Executor, node: int) -> tuple[int, float]:
        """The estimate the frame reports, given the detected ``node``, and the weights'
        concentration about ``node`` (:attr:`FrameResult.share`): the node itself and 1
        (the paper's)."""
        return node, 1.0

    def end_frame(self, ex: Executor, top: float) -> None:
        """What the weights undergo after detection (nothing by default)."""


class RobustSchedule(Schedule):
    """The robust filter (docs/localise.md, "The robust filter"; docs/ppa8.md).

    Per frame: motion; the transition over stay/+1 .. +max_advance nodes at the costs
    the motion decision sets (from the second frame), a forward frame's centred on the
    speed of the detected nodes' own path (:func:`~ppaloc.localise.params.path_speed`), or
    where it shows none on the speed of the first speed lane's path, fastest first, that
    shows one outside the filter's own range and did not stall (further sets of weights
    whose forward costs centre on the lanes' speeds,
    :func:`~ppaloc.localise.params.lane_speeds`, each run on its own executor,
    :meth:`use_lanes`, with the same frame and motion decision;
    :func:`~ppaloc.localise.params.lane_speed_taken`), or, where none shows one and
    the speeds the path showed lately varied, at half scale
    (:func:`~ppaloc.localise.params.speed_varies`); on
    the first frame and on frames the motion test calls forward, every node's value
    read, the frame's best distance, this frame's scale chosen from them
    (:func:`~ppaloc.localise.params.frame_scale`) and the
    likelihood added, then the local term of ``local_gain`` (a still frame repeats the
    last one: no new evidence); detection
    (in register arithmetic at :data:`~ppaloc.localise.params.DETECT_BITS` fraction
    bits), confidence (0 where the estimate's path stood still while the query moved,
    and on the still frames after it, :func:`~ppaloc.localise.params.path_stalled`,
    and, on the filter's own estimate, where its path held the map's last place for
    two forward frames, :func:`~ppaloc.localise.params.past_map_end`;
    on still frames less ``still_decay`` a frame where the map did not stand still,
    :func:`~ppaloc.localise.params.still_score`); normalisation. The frame reports a
    speed lane's estimate and confidence instead where the lane's leads the filter's by
    ``lane_lead`` (:func:`~ppaloc.localise.params.lane_reported`). The node reported
    is the local centroid of the weights around the one detected (``centroid_radius``,
    :meth:`report`); the filter goes on from the detected one. The confidence reported
    is the frame's (or the lane's) times the weights' concentration about its detected
    node (``concentration_radius``); the path and the lanes read it before that.
    """

    uses = "robust"
    sensor = SensorPlan(stores=("levels", "digital"), spread="copies", keep_scale=True, bank=True)
    detect_bits = DETECT_BITS
    runs = True
    #: Per node: whether its place stands for several reference frames (:meth:`use_map`).
    _stood_at: np.ndarray | None = None

    def __init__(
        self, params: FilterParams, oracle_moves: Any = None, *, centre: PathSpeed | None = None
    ) -> None:
        self.centre = centre
        #: The speed lanes' schedules, fastest first (:func:`~ppaloc.localise.params.
        #: lane_speeds`; none in a lane itself).
        self.lane_schedules: tuple[RobustSchedule, ...] = ()
        if centre is None:
            # a lane takes its filter's motion decisions (``step(..., moved)``)
            lane = replace(params, motion="always_forward")
            speeds = lane_speeds(params)
            self.lane_schedules = tuple(RobustSchedule(lane, centre=v) for v in speeds)
        self.lanes = ()  # their executors (:meth:`use_lanes`)
        #: Forward frames whose costs a lane's speed set since :meth:`reset`.
        self.lane_frames = 0
        self._end_place: int | None = None  # the map's last place (:meth:`use_map`)
        super().__init__(params, oracle_moves)

    @property
    def max_advance(self) -> int:
        return int(self.params.max_advance)  # type: ignore[arg-type]

    @property
    def wants_lanes(self) -> int:
        return len(self.lane_schedules)

    def use_lanes(self, executors: Sequence[Executor]) -> None:
        """Run the speed lanes on ``executors``, fastest first: further sets of weights on
        the same map that take the same frames (the host's
        :meth:`~ppaloc.localise.host.HostExecutor.twin`, further sensors). The caller
        resets them with the filter's."""
        executors = tuple(executors)
        if len(executors) != len(self.lane_schedules):
            raise PpalocError(
                f"{len(self.lane_schedules)} speed lanes (lane_speeds) run on as many "
                f"executors; got {len(executors)}"
            )
        self.lanes = executors

    def step(self, ex: Executor, frame: np.ndarray, moved: bool | None = None) -> FrameResult:
        """Run one frame on ``ex``; ``moved`` is the motion decision where the caller has
        made it (a lane takes its filter's)."""
        p = self.params
        self.frames += 1
        first = self.frames == 1
        ex.begin(frame)
        moved = bool(ex.motion(self.decided() if moved is None else moved))
        self.run_lanes(frame, moved)
        if not first:
            speed = None
            if moved:  # a lane's fixed speed; else the path's; else the first sure lane's
                speed = self.centre or self.path_speed()
                if speed is None and (speed := self.lane_speed()) is not None:
                    self.lane_frames += 1
            varies = self.note_speed(moved, speed)
            ex.transition(transition_costs(moved, p, speed, varies))
        if first or moved:
            values = ex.node_values()
            best = ex.minimum(values)
            shift, alpha = frame_scale(
                values,
                best,
                int(p.gain),  # type: ignore[arg-type]
                exact=ex.integer_readout,
            )
            ex.add_scaled(shift, alpha)
            if p.local_gain:
                ex.add_local(int(p.local_gain), int(p.local_window))  # type: ignore[arg-type]
        result = self.finish(ex, moved)
        self._still = 0 if moved else self._still + 1  # since the last forward decision
        if self._still:
            score = still_score(result.score, self._still, self._stood(result.found), p)
            result = replace(result, score=score)
        keep = max(int(p.speed_window or 0), int(p.lost_window or 0))
        if moved and not first and keep:
            self._path_places.append(self.place(result.found))
            self._path_scores.append(result.score)
            if len(self._path_places) > keep + 1:  # the longer window's two ends
                self._path_places.pop(0)
                self._path_scores.pop(0)
        # the path does not explain the frames; a still frame keeps the last forward
        # frame's record (the query stopped where the path had already stalled)
        stalled = path_stalled(self._path_places, p)
        if stalled:
            result = replace(result, score=min(result.score, 0.0))
        k = lane_reported(result.score, [r.score for r in self._lane_results], p, stalled)
        if k is not None:  # a lane holds the frames the filter's own costs lost
            lane = self._lane_results[k]
            result = replace(result, node=lane.node, score=lane.score, lane=k, share=lane.share)
        if self.centre is None:  # the confidence reported; a lane's result keeps its margin
            result = replace(result, score=result.score * result.share)
        end = self._end_place  # the filter's own estimate, where the route went on past it
        if self.centre is None and result.lane is None and end is not None:
            if past_map_end(self._path_places, end, p):
                result = replace(result, score=min(result.score, 0.0))
        return result

    def run_lanes(self, frame: np.ndarray, moved: bool) -> None:
        """Each speed lane's frame on its executor (with this frame's motion decision); the
        filter reads their paths where its own shows no speed (:meth:`lane_speed`) and
        their results where one leads its own (:meth:`step`)."""
        self._lane_results: list[FrameResult] = []
        if not self.lane_schedules:
            return
        if len(self.lanes) != len(self.lane_schedules):
            raise PpalocError(
                f"the filter runs {len(self.lane_schedules)} speed lane(s): hand their "
                "executors to the schedule with use_lanes(...) (the localisers do), or pass "
                "lane_speed=0 and slow_lane=False"
            )
        for lane, ex in zip(self.lane_schedules, self.lanes, strict=True):
            self._lane_results.append(lane.step(ex, frame, moved))

    def lane_speed(self) -> PathSpeed | None:
        """The path speed of the first speed lane, fastest first, whose path the filter
        takes (its path's gate at ``lane_confidence``;
        :func:`~ppaloc.localise.params.lane_speed_taken`) and did not stall
        (:func:`~ppaloc.localise.params.path_stalled`: a path that held one place while
        the query moved shows no speed); else the path speed of the lane that leads on
        this frame near the filter's place
        (:func:`~ppaloc.localise.params.lane_speed_led`; its path with no confidence
        asked, taken and not stalled as above), or None."""
        p = self.params
        gate = int(p.lane_confidence or 0)
        for lane in self.lane_schedules:
            if path_stalled(lane._path_places, p):
                continue  # a lane whose path stood still while the query moved
            taken = lane_speed_taken(lane.path_speed(gate), p)
            if taken is not None:
                return taken
        own = (self._path_places[-1], self._path_scores[-1]) if self._path_places else None
        lanes = [(self.place(r.found), r.score) for r in self._lane_results]
        k = lane_speed_led(own, lanes, p)
        if k is None or path_stalled(self.lane_schedules[k]._path_places, p):
            return None
        return lane_speed_taken(self.lane_schedules[k].path_speed(0), p)

    def path_speed(self, confidence: int | None = None) -> PathSpeed | None:
        """The speed of the detected nodes' own path (:func:`~ppaloc.localise.params.
        path_speed`), or None where its gate passes none; ``confidence`` in place of
        ``speed_confidence`` where given (a lane's path read by its filter)."""
        return path_speed(self._path_places, self._path_scores, self.params, confidence)

    def note_speed(self, moved: bool, speed: PathSpeed | None) -> bool:
        """Count a frame after the first into the record of the speeds the path's gate
        passed (``speed``, None where it passed none) and say whether the query's speed
        varies (:func:`~ppaloc.localise.params.speed_varies`, over the speeds of the last
        :data:`~ppaloc.localise.params.VARY_AGE` forward frames)."""
        self._forward += bool(moved)
        if speed is not None and self.params.speed_vary:
            self._speeds_off.append((self._forward, speed_off(speed)))
            del self._speeds_off[:-VARY_RECORD]
        recent = [off for f, off in self._speeds_off if self._forward - f < VARY_AGE]
        return speed_varies(recent, self.params)

    def use_map(self, topomap: TopoMap) -> None:
        """The map, and which of its nodes' places, or the places next after them, stand
        for several reference frames."""
        super().use_map(topomap)
        self._stood_at = stood_at_or_next(topomap.place_frames())
        self._end_place = self.place(len(topomap) - 1)
        for lane in self.lane_schedules:
            lane.use_map(topomap)

    def _stood(self, node: int) -> bool:
        """Whether the map stood still at ``node``'s place or the next (several reference
        frames): :func:`~ppaloc.localise.params.stood_at_or_next`."""
        stood = self._stood_at
        return stood is not None and 0 <= node < len(stood) and bool(stood[node])

    @property
    def path(self) -> tuple[tuple[int, float], ...]:
        """The ``(place, confidence)`` of the detected node on the last ``speed_window + 1``
        forward frames, or ``lost_window + 1`` if longer (after the first frame), oldest
        first: what :func:`~ppaloc.localise.params.path_speed` and
        :func:`~ppaloc.localise.params.path_stalled` read. The confidences are the
        weights' own, before the stalled path's 0."""
        return tuple(zip(self._path_places, self._path_scores, strict=True))

    def reset(self) -> None:
        """A new query: the schedule's state and the path's record cleared."""
        super().reset()
        for lane in self.lane_schedules:
            lane.reset()
        self.lane_frames = 0
        self._lane_results = []
        self._path_places: list[int] = []
        self._path_scores: list[float] = []
        self._speeds_off: list[tuple[int, bool]] = []
        self._forward = 0
        self._still = 0  # frames since the last forward decision

    def report(self, ex: Executor, node: int) -> tuple[int, float]:
        """With ``centroid_radius``: the local centroid of the weights around ``node``
        (:func:`~ppaloc.localise.params.local_centroid`), else ``node``; with
        ``concentration_radius``: the weights' concentration about ``node``
        (:func:`~ppaloc.localise.params.concentration`), else 1. The executor reads
        the nodes of the wider window once."""
        p, topomap = self.params, self.topomap
        centroid, spread = int(p.centroid_radius or 0), int(p.concentration_radius or 0)
        if spread < 2:  # a window of the node and its neighbours alone: a share of 1
            spread = 0
        if not (centroid or spread) or topomap is None:
            return node, 1.0
        n = len(topomap)
        a, b = centroid_window(node, max(centroid, spread), n)
        reads = ex.weight_reads(a, b)
        reported, share = node, 1.0
        if centroid:
            lo, hi = centroid_window(node, centroid, n)
            t = int(p.centroid_temperature)  # type: ignore[arg-type]
            reported = local_centroid(reads[lo - a : hi - a + 1], lo, t)
        if spread:
            lo, hi = centroid_window(node, spread, n)
            t = int(p.concentration_temperature)  # type: ignore[arg-type]
            share = concentration(reads[lo - a : hi - a + 1], lo, node, t)
        return reported, share

    def end_frame(self, ex: Executor, top: float) -> None:
        """The normalisation ``w := max(clip(w - T), -memory)``."""
        ex.normalise(top)


class PaperSchedule(Schedule):
    """Algorithm 1 of the paper (docs/localise.md, "The paper's preset").

    Per frame: motion; on forward every weight one node along the map; ``w += alpha -
    mu 2**-shift``; detection, confidence; every ``k``-th frame ``w -= gamma T``.
    ``alpha`` is the given one, or chosen from the map (:func:`suggest_alpha`; 0 for a
    map of fewer than 3 nodes).
    """

    uses = "paper"
    sensor = SensorPlan(
        stores=("analogue", "digital"), spread="tree", keep_scale=False, bank=False, minimum=False
    )

    @property
    def max_advance(self) -> int:
        return int(self.params.advance[1])  # type: ignore[index]

    def use_map(self, topomap: TopoMap) -> None:
        from ppaloc.localise.alpha import suggest_alpha

        super().use_map(topomap)
        p = self.params
        if p.alpha is not None:
            self.alpha = p.alpha
        else:
            self.alpha = suggest_alpha(topomap, p.shift) if len(topomap) >= 3 else 0  # type: ignore[arg-type]

    def step(self, ex: Executor, frame: np.ndarray) -> FrameResult:
        self.frames += 1
        ex.begin(frame)
        moved = bool(ex.motion(self.decided()))
        if moved:
            ex.shift()
        ex.add_likelihood(self.alpha, self.params.shift)  # type: ignore[arg-type]
        return self.finish(ex, moved)

    def end_frame(self, ex: Executor, top: float) -> None:
        """Every ``k``-th frame the adjustment ``w -= gamma T`` (nothing when it is 0)."""
        p = self.params
        if self.frames % p.k == 0 and p.gamma:  # type: ignore[operator]
            amount = adjustment(p.gamma, top, exact=ex.exact)
            if amount:
                ex.adjust(amount)


SCHEDULES: dict[str, type[Schedule]] = {"robust": RobustSchedule, "paper": PaperSchedule}
"""Preset name -> schedule class; ``FilterParams.create(preset=...)`` and every weighted-node
and on-sensor method accept these names."""


def register_schedule(name: str, schedule: type[Schedule]) -> None:
    """Offer ``schedule`` as ``preset=name`` everywhere (a new preset in one place)."""
    if not (isinstance(schedule, type) and issubclass(schedule, Schedule)):
        raise PpalocError(f"{schedule!r} is not a Schedule subclass")
    if schedule.uses not in ("robust", "paper"):
        raise PpalocError(f"{name}: uses={schedule.uses!r} must be 'robust' or 'paper'")
    SCHEDULES[name] = schedule


def make_schedule(
    params: FilterParams, oracle_moves: Sequence[bool] | np.ndarray | None = None
) -> Schedule:
    """The schedule of ``params.preset``, built on ``params``."""
    return SCHEDULES[params.preset](params, oracle_moves)
