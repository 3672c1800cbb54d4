"""``OnSensorLocaliser``: the weighted-node filter run as PPA programs on the simulator.

It implements :class:`ppaloc.localise.base.Localiser`, so evaluation treats it like any
other method. The map lives in the simulated sensor's registers (written by
:func:`ppaloc.onsensor.mapping.upload_map`), and every frame is the preset's schedule
(:mod:`ppaloc.localise.schedule`, the host's own) run on the sensor executor of
:func:`ppaloc.onsensor.pipeline.make_pipeline`, or on a bank of them. In ideal mode the
estimates equal those of ``WeightedNodeLocaliser(arithmetic="ppa8")`` with the same
parameters (docs/ppa8.md, docs/onsensor.md); with a noise preset they show what the
analogue array does to them.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.base import DatasetNeed, Estimate, MethodParam
from ppaloc.localise.likelihood import FLOAT_PLACES
from ppaloc.localise.params import (
    DeclaredSpeeds,
    FilterParams,
    check_int,
    filter_method_params,
)
from ppaloc.localise.schedule import Schedule, make_schedule
from ppaloc.localise.weighted import (
    MAX_RANKING,
    check_map,
    check_representation,
    oracle_needs,
    place_test,
)
from ppaloc.onsensor.bank import SensorBank
from ppaloc.onsensor.choose import AUTO, MAX_SENSORS, AutoPlace
from ppaloc.onsensor.executor import PLACES, SensorExecutor
from ppaloc.onsensor.mapping import upload_map
from ppaloc.onsensor.pipeline import make_pipeline
from ppaloc.onsensor.precursor import (
    REPLACED_STAGES,
    STRUCTURES,
    loop_counts,
    structure_counts,
)
from ppaloc.seeds import SEED_MAX
from ppaloc.sim import NoiseParams
from ppaloc.sim.engines import check_environment
from ppaloc.sim.observe import SimObserver, check_observers
from ppaloc.sim.timing import Interval, add_counts, diff_counts
from ppaloc.topomap import KIND_SPECS, TopoMap, layout_for

__all__ = ["NOISE_PRESETS", "SENSOR_REPRESENTATIONS", "OnSensorLocaliser"]

NOISE_PRESETS = ("ideal", "low", "typical", "high")

SENSOR_REPRESENTATIONS = ("lowres", "lowres16", "lbp", "haar")
"""The representations the sensor's programs run (the host runs every one of
:data:`ppaloc.localise.weighted.REPRESENTATIONS`)."""

LANE_INDEX = 1000
"""Speed lane ``k``'s sensors (fastest first, :func:`ppaloc.localise.params.lane_speeds`)
are numbered from ``(k + 1) LANE_INDEX``: sensor ``i`` of a localiser has the noise seed
``seed + 7919 i``, so each lane's differ from the bank's and from the other lanes'."""


def _check_options(representation: str, noise: Any, arithmetic: str, timing_structure: str) -> None:
    """A one-line error for an option the sensor does not run, before any work."""
    check_representation(representation)
    if representation not in SENSOR_REPRESENTATIONS:
        why = ": no register holds its values" if representation in FLOAT_PLACES else " so far"
        raise PpalocError(
            f"representation={representation!r} runs on the host only{why} "
            f"(weighted-node-{representation}); the sensor runs "
            f"{', '.join(SENSOR_REPRESENTATIONS)} (docs/onsensor.md)"
        )
    if timing_structure not in STRUCTURES:
        raise PpalocError(
            f"timing_structure={timing_structure!r} is not one of {', '.join(STRUCTURES)}"
        )
    if timing_structure == "precursor" and representation not in REPLACED_STAGES:
        raise PpalocError(
            f"timing_structure='precursor' has no structure for {representation!r} (the "
            f"precursor's code compares {' and '.join(REPLACED_STAGES)}); use "
            "timing_structure='ppaloc'"
        )
    if not isinstance(noise, NoiseParams) and noise not in NOISE_PRESETS:
        raise PpalocError(
            f"noise={noise!r} is not one of {', '.join(NOISE_PRESETS)} or a ppaloc.sim.NoiseParams"
        )
    if arithmetic != "ppa8":
        raise PpalocError(
            f"arithmetic={arithmetic!r}: the sensor computes in register arithmetic; "
            "use arithmetic='ppa8' (or the host WeightedNodeLocaliser for 'float')"
        )
    check_environment()  # $PPALOC_ENGINE and the engine's settings, before any method runs


class OnSensorLocaliser(DeclaredSpeeds):
    """The weighted-node filter on a simulated SCAMP-5: map in registers, PPA programs.

    Both presets of the host filter run on the sensor: ``preset="robust"`` (the default:
    transition over stay/+1/+2/+3 nodes with motion-evidence costs, per-frame likelihood
    scale, normalisation and floor, keyframe maps) and ``preset="paper"`` (Algorithm 1).

    Parameters
    ----------
    representation : {"lowres", "lowres16", "lbp", "haar", "auto"}
        8x8 images in an analogue register (8x8 PEs per node, 1024 per tile), 16x16
        images (16x16 PEs per node, 256 per tile; robust preset only, a longer map on a
        bank), 32-bit LBP descriptors in a digital register (4x8 PEs per node, 2048
        per tile) or the 192 Haar signs in one (16x16 PEs per node, 256 per tile, two
        tiles a sensor; robust preset only). ``"auto"``: the best whose map fits
        ``sensors`` sensors, chosen with the map
        (:class:`~ppaloc.onsensor.choose.AutoPlace`).
    sensors : int, optional
        ``"auto"``: how many sensors the map may fill (default 1).
    noise : {"ideal", "low", "typical", "high"} or NoiseParams
        The simulator's noise preset, or custom parameters (e.g. a preset without the
        analogue droop, to separate its effect).
    seed : int
        Seed of the simulator's noise.
    arithmetic : {"ppa8"}
        Always the register arithmetic (anything else is an error).
    record_weights : bool
        Put the weights (read from the register, untimed) in every Estimate.
    size : int
        Array side, 256 as on SCAMP-5 (smaller arrays are for tests of the stages).
    store : str, optional
        How the map is held (docs/onsensor.md, "Map store"): low-res ``"levels"`` (the
        robust default: two 4-bit halves as restorable levels, one tile per sensor) or
        ``"analogue"`` (the paper default: one analogue value per pixel, two tiles per
        sensor, droops); LBP ``"digital"``. A map larger than one sensor runs on a
        :class:`~ppaloc.onsensor.bank.SensorBank` (robust preset).
    sensor_nodes : int, optional
        At most this many nodes per sensor (default: a sensor's capacity); smaller values
        make small banks, e.g. for tests.
    observers : sequence of SimObserver
        Attached to every simulator the localiser creates (the mapping sensor of
        :meth:`build_map`, the sensor or bank holding the map): each receives
        ``observer(sim, event)`` for every kernel run, controller call and frame
        (:mod:`ppaloc.sim.observe`), e.g. a :class:`ppaloc.cpp.Tracer` to export the run.
    ranking_k : int
        Accepted (as the host filter's) but the sensor reports no ranking.
    oracle_moves : sequence of bool, optional
        Ground-truth moves for ``motion="oracle"`` (the controller's input).
    **filter_params
        The filter's parameters, each with its one default and range
        (:class:`ppaloc.localise.params.FilterParams`, :attr:`params`, the host's
        object): ``preset``, ``motion``, ``motion_margin``, ``motion_shift``,
        ``motion_min_support``, ``confidence_radius``, ``keyframes``; robust ``gain``,
        ``memory``, ``stay_cost``, ``move_cost``, ``skip_cost``, ``max_advance``,
        ``contrast``; paper ``alpha``, ``gamma``, ``k``, ``shift``, ``advance`` (must be
        (1, 1)).

    Attributes
    ----------
    params : FilterParams
        The resolved parameters, the host's object: the executor reads the same one.
    schedule : Schedule
        The preset's frame (:mod:`ppaloc.localise.schedule`), the host's own.
    preset : {"robust", "paper"}
    pipeline : SensorExecutor, SensorBank or None
        The simulated sensor holding the map (the schedule's executor), or the bank of
        them for a map larger than one sensor (None before a map).

    Notes
    -----
    ``score`` is the detection threshold minus the same threshold outside nodes ``node -
    R .. node + R``, both found by ``global_or`` searches: with the robust preset each to
    1/16, equal to the host's ppa8 score; with the paper's the integer ``T = floor(max
    W)`` (the host reports the unrounded difference). The robust schedule reports 0
    while the estimate has held one place over its last ``lost_window`` forward frames,
    still frames after them included (:func:`~ppaloc.localise.params.path_stalled`),
    and lowers it on still frames where the map kept moving
    (:func:`~ppaloc.localise.params.still_score`), or reports a leading speed lane's
    (:func:`~ppaloc.localise.params.lane_reported`). ``weights`` (``record_weights``)
    are untimed reads of the weight register.
    """

    def __init__(
        self,
        representation: str = "lowres",
        noise: str | NoiseParams = "ideal",
        seed: int = 0,
        *,
        arithmetic: str = "ppa8",
        record_weights: bool = False,
        size: int = 256,
        timing_structure: str = "ppaloc",
        store: str | None = None,
        sensor_nodes: int | None = None,
        ranking_k: int = 10,
        oracle_moves: Sequence[bool] | np.ndarray | None = None,
        observers: Sequence[SimObserver] = (),
        sensors: int | None = None,
        **filter_params: Any,
    ) -> None:
        self._auto = AutoPlace.create(
            representation, sensors, store, filter_params=dict(filter_params),
            timing_structure=timing_structure, size=int(size), oracle_moves=oracle_moves,
        )  # fmt: skip
        if self._auto is not None:
            representation = self._auto.candidates[0]
        _check_options(representation, noise, arithmetic, timing_structure)
        self.params: FilterParams = FilterParams.create(
            representation, arithmetic="ppa8", **filter_params
        )
        check_int("ranking_k", ranking_k, 0, MAX_RANKING)  # accepted; the sensor ranks none
        self.schedule: Schedule = make_schedule(self.params, oracle_moves)
        p = self.params
        if p.advance is not None and p.advance != (1, 1):
            raise PpalocError(
                f"advance={p.advance!r}: the sensor shifts weights by exactly one node "
                "per forward move (the paper's motion model); use advance=(1, 1)"
            )
        if p.shift is not None and p.shift > 8:
            raise PpalocError(f"shift={p.shift} is too large for the sensor; use 0..8")
        self.preset = p.preset
        self.representation = representation
        self.noise = noise
        self.seed = int(seed)
        self.size = int(size)
        self.store = PLACES[representation].choose_store(self.schedule.sensor, store)
        self.sensor_nodes = _check_sensor_nodes(sensor_nodes, self.schedule)
        self.observers = check_observers(observers)
        self.record_weights = bool(record_weights)
        self.timing_structure = timing_structure
        self.frame_times: list[tuple[Interval, Interval]] = []
        self.motion = p.motion
        self.name = f"onsensor-{AUTO if self._auto else representation}"
        self.topomap: TopoMap | None = None
        self.pipeline: SensorExecutor | SensorBank | None = None
        self._last_counts: tuple[Any, int, dict] | None = None

    @property
    def map_kinds(self) -> tuple[str, ...]:
        """Node kinds of a saved map :meth:`use_map` takes (``"auto"``: any it chooses among)."""
        return tuple(self._auto.candidates) if self._auto is not None else (self.representation,)

    @classmethod
    def parameters(cls) -> tuple[MethodParam, ...]:
        """Every keyword this localiser takes: its own options, then the filter's
        parameters (:class:`~ppaloc.localise.params.FilterParams`)."""
        return (
            MethodParam("representation", str, "lowres"),
            MethodParam("noise", str | NoiseParams, "ideal", doc="ideal, low, typical, high"),
            MethodParam("seed", int, 0, 0, SEED_MAX, "seed of the simulator's noise"),
            MethodParam("arithmetic", str, "ppa8", doc="ppa8 only: the registers' arithmetic"),
            MethodParam("record_weights", bool, False, doc="keep every frame's weights"),
            MethodParam("size", int, 256, 16, 256, "array side, a multiple of 64 (commands: 256)"),
            MethodParam("timing_structure", str, "ppaloc", doc="timed as " + ", ".join(STRUCTURES)),
            MethodParam("store", str | None, None, doc="the map store (docs/onsensor.md)"),
            MethodParam("sensor_nodes", int | None, None, doc="at most this many nodes a sensor"),
            MethodParam("ranking_k", int, 10, 0, MAX_RANKING, "accepted; the sensor ranks none"),
            MethodParam("oracle_moves", Any, None, doc="the true moves, for motion='oracle'"),
            MethodParam("sensors", int | None, None, 1, MAX_SENSORS, "for representation='auto'"),
            *filter_method_params(),
        )

    def _use(self, kind: str) -> None:
        """``"auto"``: run ``kind`` (the parameters, schedule and store resolved for it)."""
        self.params, self.schedule, self.store = self._auto.resolve(kind)  # type: ignore[union-attr]
        self.representation = kind

    @classmethod
    def dataset_needs(cls, params: Mapping[str, Any]) -> dict[str, DatasetNeed]:
        """The true moves for ``motion="oracle"`` (the controller's input)."""
        return oracle_needs(params)

    @property
    def alpha(self) -> float | None:
        """Paper: the likelihood offset in use (chosen from the map when not given).

        None for the robust preset (``alpha_t`` is chosen per frame: the executor's
        ``last_alpha``).
        """
        return self.schedule.alpha

    # -- map ---------------------------------------------------------------------------
    def build_map(self, frames: Iterable[np.ndarray]) -> TopoMap:
        """Map a reference traversal on the sensor and write the map into its registers.

        Every frame is captured and described by the sensor itself
        (:meth:`SensorExecutor.sense_node`: the block means read through the ADC, or the
        descriptor compared on the array), so with noise the map carries the same
        fixed-pattern errors as the queries. One node per frame, or with ``keyframes``
        (the robust default with the image motion model) one per distinct place: the
        sensor's own motion stage runs over consecutive reference frames and a frame
        starts a node when it says forward (:meth:`SensorExecutor.map_keyframes`);
        ``frame_index`` holds the kept frames and ``params["n_frames"]`` the frame
        count. Without keyframes, with the image motion model and a preset that uses
        runs (robust), the motion stage marks instead where the reference stood still, and
        the map keeps those frames as runs of one place (``TopoMap.places``;
        :meth:`SensorExecutor.map_places`). In ideal mode the kept frames, nodes and places
        equal the host's ``build_map``. The nodes are then written into the database registers
        (:func:`ppaloc.onsensor.mapping.upload_map`).
        """
        frames = list(frames)
        if not frames:
            raise PpalocError("the reference traversal is empty: a map needs at least one frame")
        for frame in frames:
            check_frame(frame, self.size)
        frames = [np.asarray(f) for f in frames]
        if self._auto is not None:
            self._use(self._auto.for_frames(frames, self.schedule.sensor))
        capacity = layout_for(self.representation, (self.size, self.size)).capacity
        mapper = self._new_pipeline(min(len(frames), capacity))
        places: list[int] | None = None
        if self.params.keyframes:
            nodes, kept = mapper.map_keyframes(frames)
        elif place_test(self.params) is not None:
            nodes, places = mapper.map_places(frames)
            kept = list(range(len(frames)))
        else:
            nodes = [mapper.sense_node(f) for f in frames]
            kept = list(range(len(frames)))
        dtype = KIND_SPECS[self.representation][0]
        noise = self.noise if isinstance(self.noise, str) else "custom"
        params = {
            "kind": self.representation,
            "keyframe_threshold": None,
            "keyframes": "motion test" if self.params.keyframes else None,
            "keyframe_units": None,
            "n_frames": len(frames),
            "mapped_on": f"simulated SCAMP-5, noise={noise}",
        }
        if places is not None:
            params["places"] = "motion test"
        topomap = TopoMap(
            self.representation,
            np.asarray(nodes, dtype=dtype),
            frame_index=np.asarray(kept, dtype=np.int64),
            params=params,
            places=None if places is None else np.asarray(places, dtype=np.int64),
        )
        pipe = self._place(len(kept), mapper, self._runs_of(topomap))
        self._install(topomap, pipe)
        return topomap

    def use_map(self, topomap: TopoMap) -> None:
        """Write ``topomap`` (e.g. loaded from a file) into a fresh simulated sensor
        (``"auto"`` takes the map's own place)."""
        if self._auto is not None:
            self._use(self._auto.for_kind(topomap.kind))
        check_map(topomap, self.representation)
        capacity = layout_for(self.representation, (self.size, self.size)).capacity
        pipe = self._new_pipeline(capacity)
        self._install(topomap, self._place(len(topomap), pipe, self._runs_of(topomap)))

    def _runs_of(self, topomap: TopoMap) -> np.ndarray | None:
        """The map's places where the schedule runs its runs (None otherwise)."""
        return topomap.places if self.schedule.runs and topomap.has_runs else None

    def _new_pipeline(self, n_nodes: int, index: int = 0) -> SensorExecutor:
        # sensor i of a bank has its own noise seed (sensor 0's is the localiser's)
        return make_pipeline(
            self.representation,
            n_nodes,
            self.params,
            plan=self.schedule.sensor,
            noise=self.noise,
            seed=self.seed + 7919 * index,
            size=self.size,
            store=self.store,
            observers=self.observers,
        )

    def _place(
        self,
        n_nodes: int,
        first: SensorExecutor,
        places: np.ndarray | None = None,
        index: int = 0,
    ) -> SensorExecutor | SensorBank:
        """``first`` holding ``n_nodes`` nodes, or a bank starting with it if they don't fit
        (cut between ``places`` where the map's runs are run; the bank's sensors numbered
        from ``index``, which sets their noise seeds)."""
        per = first.capacity if self.sensor_nodes is None else self.sensor_nodes
        if n_nodes <= min(per, first.capacity):
            first.set_nodes(n_nodes)
            return first
        carry = self.schedule.max_advance
        if per < carry:
            raise PpalocError(
                f"sensor_nodes={per} is too small for a bank: each sensor must hold at least "
                f"the {carry} node(s) a frame may advance into the next sensor"
            )

        def make(n: int, i: int) -> SensorExecutor:
            return self._new_pipeline(n, index + i)

        return SensorBank(first, n_nodes, make, per, places, carry)

    def _lane_pipeline(self, topomap: TopoMap, k: int) -> SensorExecutor | SensorBank:
        """Speed lane ``k``'s sensor (or bank) holding ``topomap``: the filter's pipeline,
        its sensors numbered from ``(k + 1)`` :data:`LANE_INDEX` (own noise seeds)."""
        n, index = len(topomap), (k + 1) * LANE_INDEX
        capacity = layout_for(self.representation, (self.size, self.size)).capacity
        first = self._new_pipeline(min(n, capacity), index)
        lane = self._place(n, first, self._runs_of(topomap), index)
        upload(lane, topomap, self.schedule.runs)
        return lane

    def _install(self, topomap: TopoMap, pipe: SensorExecutor | SensorBank) -> None:
        check_map(topomap, self.representation)
        self.schedule.use_map(topomap)  # the paper's alpha, chosen from the map
        upload(pipe, topomap, self.schedule.runs)
        self.pipeline = pipe
        lanes = range(self.schedule.wants_lanes)
        self.schedule.use_lanes([self._lane_pipeline(topomap, k) for k in lanes])
        self.topomap = topomap
        self.reset()

    # -- per query ---------------------------------------------------------------------
    def reset(self) -> None:
        """Zero the weight register and forget the previous frame (the map stays)."""
        if self.pipeline is not None:
            self.pipeline.reset()
        for lane in self.schedule.lanes:
            lane.reset()
        self.schedule.reset()
        self.frame_times = []

    def step(self, frame: np.ndarray) -> Estimate:
        """Localise one sensor frame ((size, size) uint8): the schedule on the sensor."""
        pipe = self.pipeline
        if pipe is None:
            raise PpalocError("no map: call build_map(frames) or use_map(topomap) first")
        frame = np.asarray(frame)
        check_frame(frame, self.size)
        # the filter's sensor (a bank's timing: the slowest per phase plus the exchanges)
        # and its speed lanes'
        sensors = (pipe, *self.schedule.lanes)
        marks = [(p.timing, p.timing.now_us, p.timing.energy_uj) for p in sensors]
        counts = pipe.sim.timing  # a bank's chip and loop intervals are sensor 0's
        last = self._last_counts  # the last frame's end, if nothing was charged since
        if last is not None and last[0] is counts and last[1] == counts.charges:
            before = last[2]
        else:
            before = counts.counts_by_stage()
        r = self.schedule.step(pipe, frame)
        after = counts.counts_by_stage()
        self._last_counts = (counts, counts.charges, after)
        self._time_frame(frame, diff_counts(after, before), bool(r.moved))
        weights = pipe.weights() if self.record_weights else None
        latency, energy = frame_cost(marks)
        return Estimate(
            node=int(r.node),
            score=float(r.score),
            moved=r.moved,
            ranking=None,
            weights=weights,
            modelled_latency_ms=latency / 1000.0,
            energy_mj=energy / 1000.0,
        )

    def _time_frame(self, frame: np.ndarray, stages: dict, moved: bool) -> None:
        """Record the frame's ``chip`` and ``loop`` intervals (docs/onsensor.md, Timing)."""
        pipe = self.pipeline
        precursor = self.timing_structure == "precursor"
        chip = structure_counts(
            stages,
            self.representation,
            self.timing_structure,
            forward=moved,
            weights=pipe.weights() if precursor else None,
        )
        timing = pipe.sim.timing
        loop = add_counts(chip, loop_counts(frame))
        self.frame_times.append((timing.interval(chip), timing.interval(loop)))

    def modelled_time_ms(self) -> dict[str, dict[str, float]] | None:
        """Median modelled time per frame since :meth:`reset`, per boundary and level, ms.

        ``{"chip": {"low", "mid", "high"}, "loop": {...}}`` (None before any frame):
        ``chip`` is the frame's kernels and controller calls, ``loop`` adds the host's
        frame injection, the frame-loop control and the estimate sent back. With the
        default ``timing_structure``, ``chip.mid`` is the median ``modelled_latency_ms``
        wherever the filter's sensor is the slowest of it and the speed lanes' (which skip
        the motion stage: in ideal mode always).
        """
        return median_times(self.frame_times)

    def register_planes(self) -> dict[str, np.ndarray]:
        """The sensor's registers worth a picture after the last frame, by label.

        Untimed inspection (``Scamp5.read``, no readout noise); empty before a map exists.
        The report draws them (:func:`ppaloc.evaluate.run.register_planes`).
        """
        return {} if self.pipeline is None else self.pipeline.register_planes()

    def localise(self, frames: Iterable[np.ndarray]) -> list[Estimate]:
        """``reset()``, then ``step`` every frame in order."""
        self.reset()
        return [self.step(f) for f in frames]


def _check_sensor_nodes(sensor_nodes: Any, schedule: Schedule) -> int | None:
    """``sensor_nodes`` as an int (None: a sensor's capacity), refused when the localiser is
    built rather than once its map is: a bank's sensor holds at least the nodes a frame
    may advance into the next, and only the robust preset runs on a bank."""
    if sensor_nodes is None:
        return None
    if isinstance(sensor_nodes, bool) or int(sensor_nodes) < 1:
        raise PpalocError(f"sensor_nodes={sensor_nodes!r} must be a positive integer")
    n = int(sensor_nodes)
    if not schedule.sensor.bank:
        raise PpalocError(
            f"sensor_nodes={n} sets the sensors of a bank, and a bank runs the robust preset "
            f"only (preset {schedule.params.preset!r} runs on one sensor): leave sensor_nodes "
            "out, or use the robust preset"
        )
    if n < schedule.max_advance:
        raise PpalocError(
            f"sensor_nodes={n} is too small for a bank: each sensor must hold at least the "
            f"{schedule.max_advance} node(s) a frame may advance into the next sensor"
        )
    return n


def check_frame(frame: np.ndarray, size: int) -> None:
    """A one-line error unless ``frame`` is a sensor frame: uint8 of shape (size, size)."""
    frame = np.asarray(frame)
    if frame.dtype == np.uint8 and frame.shape == (256, 256) and size != 256:
        raise PpalocError(
            f"size={size} simulates a {size} x {size} array, but the frames are the sensor's "
            "256 x 256 (as ppaloc evaluate, map and localise give them): leave size at 256 "
            "there; a smaller array takes frames of its own size from Python"
        )
    if frame.dtype != np.uint8 or frame.shape != (size, size):
        raise PpalocError(
            f"a sensor frame must be uint8 of shape ({size}, {size}), got "
            f"{frame.dtype} {frame.shape}: convert frames with ppaloc.datasets.to_sensor"
        )


def upload(pipe: SensorExecutor | SensorBank, topomap: TopoMap, runs: bool) -> None:
    """Write ``topomap`` into a sensor's registers, or each part into a bank's sensor."""
    if isinstance(pipe, SensorBank):
        pipe.upload(topomap, runs)
    else:
        upload_map(pipe, topomap, runs)


def median_times(
    frame_times: list[tuple[Interval, Interval]],
) -> dict[str, dict[str, float]] | None:
    """The median ``chip`` and ``loop`` intervals of the frames, ms (None without frames)."""
    if not frame_times:
        return None
    out = {}
    for i, boundary in enumerate(("chip", "loop")):
        values = np.array([t[i].as_list() for t in frame_times]) / 1000.0
        med = np.median(values, axis=0)
        out[boundary] = {"low": float(med[0]), "mid": float(med[1]), "high": float(med[2])}
    return out


def frame_cost(marks: list[tuple[Any, float, float]]) -> tuple[float, float]:
    """A frame's modelled latency and energy (us, uJ) from each sensor's ``(timing,
    time, energy)`` at its start: the filter's and its speed lanes' sensors work side by
    side, so the slowest sets the latency, and the energy is all of theirs."""
    spent = [(t.now_us - t0, t.energy_uj - e0) for t, t0, e0 in marks]
    return max(s[0] for s in spent), sum(s[1] for s in spent)
