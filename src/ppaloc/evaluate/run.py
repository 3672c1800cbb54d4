"""Run localisation methods over a dataset: build each map, step every query frame once.

For each method the map is built from the dataset's reference frames (through
:func:`ppaloc.datasets.to_sensor`, the same front-end for every method), then every query
frame is handed to ``step`` once, in order. Only ``step`` is timed (host wall clock, with
``time.perf_counter_ns``), in the same process and run for every method, so the latencies
compare side by side. Modelled on-sensor latency and energy come from the estimates of
methods that model them.

Frames stream: each is read (or rendered), converted and consumed when a method needs it
and then dropped (:func:`sensor_stream`), and a run keeps only per-query numbers, so peak
memory does not grow with the route (the maps and the per-query arrays aside). Only when
several methods run and both traversals fit in :data:`SHARED_FRAMES_BYTES` are the
converted frames kept for the next method instead of being read again.
"""

from __future__ import annotations

import logging
import sys
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

import numpy as np

from ppaloc import __version__
from ppaloc.datasets import RouteDataset, to_sensor
from ppaloc.datasets.frames import FrameSequence, as_frames
from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.errors import PpalocError
from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.difference import DifferenceMatrix, DifferenceRecorder
from ppaloc.evaluate.metrics import Metrics, evaluate_estimates
from ppaloc.evaluate.speed import speed_checks
from ppaloc.localise.base import Estimate, Localiser
from ppaloc.methods import (
    accepted_parameters,
    available_methods,
    check_method,
    dataset_arguments,
    dataset_needs,
    make_localiser,
    registry,
)

__all__ = [
    "PREDICTION_RULE",
    "SHARED_FRAMES_BYTES",
    "MethodRun",
    "ProgressBar",
    "ReportedFrames",
    "RunResult",
    "check_oracle_moves",
    "hand_query",
    "localiser_params",
    "method_metrics",
    "predicted_frames",
    "register_planes",
    "resolve_methods",
    "run_evaluation",
    "run_method",
    "scoring_protocol",
    "sensor_frames",
    "sensor_stream",
]

log = logging.getLogger(__name__)

SHARED_FRAMES_BYTES = 256 * 2**20
"""Largest size of both traversals as sensor frames (65,536 bytes each: 4,096 frames) that
an evaluation of several methods keeps for the next method; a longer route is read again
by each method, so memory stays flat whatever its length."""

_SENSOR_FRAME_BYTES = 256 * 256

PREDICTION_RULE = (
    "one reference frame per query, the predicted node's own frame (TopoMap.frame_index); "
    "it never depends on the ground truth"
)
"""How every method's prediction becomes a reference frame (recorded in results.json)."""

ProgressHook = Callable[[str, int], None]
"""Called as ``hook(method, frames_done)`` while a method runs."""


@dataclass(eq=False)
class MethodRun:
    """Per-query arrays and metrics of one method on one dataset.

    Attributes
    ----------
    method : str
        Registered method name.
    params : dict
        Keyword arguments the localiser was built with (on top of the method's defaults).
    map_kind : str
        ``TopoMap.kind`` of the map it built.
    n_nodes : int
        Map size.
    build_s : float or None
        Host time to build the map, in seconds (None: no map was built, e.g. predictions
        read from a file).
    node : ndarray of int, shape (M,)
        Predicted map node per query.
    ref_index : ndarray of int, shape (M,)
        Predicted reference frame per query: each node's own frame
        (:func:`predicted_frames`), never depending on the ground truth.
    score : ndarray of float, shape (M,)
        Confidence per query.
    moved : ndarray of int8, shape (M,)
        Motion decision: 1 forward, 0 stay, -1 where the method has no motion model.
    ranking : ndarray of int, shape (M, K)
        Best K reference indices per query, best first; -1 pads; K = 0 when not ranked.
    latency_ms : ndarray of float, shape (M,)
        Host wall-clock time of each ``step``, in milliseconds (NaN where not measured).
    weights : ndarray of float32, shape (M, N), optional
        Per-node weights after each frame, in map order, where recorded.
    modelled_latency_ms, energy_mj : ndarray of float, shape (M,), optional
        Modelled on-sensor time and energy per frame, where the method models them.
    modelled_time_ms : dict, optional
        ``{"chip": {"low", "mid", "high"}, "loop": {...}}``: the median modelled time per
        frame at the two timing boundaries (docs/onsensor.md), on-sensor methods only.
    metrics : Metrics
    motion_accuracy : float, optional
        Agreement of ``moved`` with the dataset's ``query_moved``, where both exist.
    registers : dict of str to ndarray, optional
        Register planes after the last frame (:func:`register_planes`), on-sensor only.
    reads_future : bool
        The method read frames after the one it localised (offline, e.g. seqslam-centred).
    speed_check : dict, optional
        :func:`ppaloc.evaluate.speed.check_speed` for a method that declares its speeds.
    frame_index : ndarray of int, shape (N,), optional
        The map's ``TopoMap.frame_index``: each node's own reference frame (the weights
        figure carries the truth from frames to nodes with it).
    """

    method: str
    params: dict[str, Any]
    map_kind: str
    n_nodes: int
    build_s: float | None
    node: np.ndarray
    ref_index: np.ndarray
    score: np.ndarray
    moved: np.ndarray
    ranking: np.ndarray
    latency_ms: np.ndarray
    metrics: Metrics
    weights: np.ndarray | None = None
    modelled_latency_ms: np.ndarray | None = None
    energy_mj: np.ndarray | None = None
    modelled_time_ms: dict[str, dict[str, float]] | None = None
    motion_accuracy: float | None = None
    registers: dict[str, np.ndarray] | None = None
    reads_future: bool = False
    speed_check: dict[str, Any] | None = None
    frame_index: np.ndarray | None = None

    def summary(self) -> dict[str, Any]:
        """The method's entry of ``results.json`` (scalars only)."""
        lat = self.latency_ms
        out: dict[str, Any] = {
            "f1_max": self.metrics.f1_max,
            "precision_at_f1": self.metrics.precision_at_f1,
            "recall_at_f1": self.metrics.recall_at_f1,
            "auc": self.metrics.auc,
            "recall_at_100p": self.metrics.recall_at_100p,
            "precision_at_100r": self.metrics.precision_at_100r,
            "latency_ms_median": _median_or_none(lat),
            "latency_ms_p95": _p95_or_none(lat),
            "modelled_latency_ms": _median_or_none(self.modelled_latency_ms),
            "energy_mj": _mean_or_none(self.energy_mj),
            "modelled_time_ms": self.modelled_time_ms,
            "recall_definition": self.metrics.recall_definition,
        }
        out.update({k: v for k, v in self.metrics.summary().items() if k not in out})
        out.update(
            {
                "modelled_latency_ms_mean": _mean_or_none(self.modelled_latency_ms),
                "motion_accuracy": self.motion_accuracy,
                "map_kind": self.map_kind,
                "n_nodes": self.n_nodes,
                "build_s": self.build_s,
                "params": self.params,
                "reads_future": self.reads_future,
                "speed_check": self.speed_check,
            }
        )
        return out


def _median_or_none(a: np.ndarray | None) -> float | None:
    """Median of the finite values (frames a method did not model are NaN); None if none."""
    finite = None if a is None else a[np.isfinite(a)]
    return None if finite is None or not finite.size else float(np.median(finite))


def _p95_or_none(a: np.ndarray | None) -> float | None:
    finite = None if a is None else a[np.isfinite(a)]
    return None if finite is None or not finite.size else float(np.percentile(finite, 95))


def _mean_or_none(a: np.ndarray | None) -> float | None:
    finite = None if a is None else a[np.isfinite(a)]
    return None if finite is None or not finite.size else float(np.mean(finite))


@dataclass(eq=False)
class RunResult:
    """Everything one evaluation produced: what was run, on what, and each method's run.

    Attributes
    ----------
    dataset : str
        The dataset spec as run (tolerance applied).
    dataset_name : str
        ``RouteDataset.name``.
    tolerance : int
        Ground-truth tolerance in reference frames.
    ground_truth : PackedSets
        Accepted reference indices per query (packed: two arrays, not one per query).
    n_reference : int
        Reference frames (the map is built from them).
    runs : dict of str to MethodRun
        In the order run.
    config : dict
        The resolved configuration.
    reference_positions, query_positions : ndarray, optional
        Route positions in metres, where the dataset has them.
    query_moved : ndarray of bool, optional
        Ground-truth motion, where known.
    query_turning, reference_turning : ndarray of bool, optional
        Which query and reference frames were taken in a turn (the dataset's
        ``meta["query_turning"]`` and ``meta["reference_turning"]``), where known.
    protocol : dict
        How predictions were scored, the same for every method: ``"prediction"`` (each
        method's predicted reference frame, :data:`PREDICTION_RULE`) and
        ``"ground_truth"`` (the dataset's own description of its accepted sets, its
        ``meta["ground_truth_rule"]``, where it gives one).
    difference : DifferenceMatrix, optional
        The method-independent frame difference of sampled (query, reference) pairs
        (:mod:`ppaloc.evaluate.difference`), recorded as the run streams the frames.
    ppaloc_version, created : str
        Provenance.
    roles : dict of str to str, optional
        What the database (reference) and the query traversals are (the dataset's
        ``meta["roles"]``).
    """

    dataset: str
    dataset_name: str
    tolerance: int
    ground_truth: Sequence[np.ndarray]
    n_reference: int
    runs: dict[str, MethodRun]
    config: dict[str, Any] = field(default_factory=dict)
    reference_positions: np.ndarray | None = None
    query_positions: np.ndarray | None = None
    query_moved: np.ndarray | None = None
    query_turning: np.ndarray | None = None
    reference_turning: np.ndarray | None = None
    protocol: dict[str, Any] = field(default_factory=dict)
    difference: DifferenceMatrix | None = None
    ppaloc_version: str = __version__
    created: str = ""
    roles: dict[str, str] | None = None

    def summary(self) -> dict[str, Any]:
        """The content of ``results.json``."""
        return {
            "dataset": self.dataset,
            "dataset_name": self.dataset_name,
            "roles": self.roles,
            "tolerance": self.tolerance,
            "n_reference": self.n_reference,
            "n_queries": len(self.ground_truth),
            "methods": {name: run.summary() for name, run in self.runs.items()},
            "protocol": self.protocol,
            "config": self.config,
            "ppaloc_version": self.ppaloc_version,
            "created": self.created,
        }


def _flags(value: Any) -> np.ndarray | None:
    """Per-frame flags as a bool array (None stays None)."""
    return None if value is None else np.asarray(value, dtype=bool)


def resolve_methods(names: Sequence[str]) -> list[str]:
    """Check method names against the registry; an empty list means every available one.

    Raises
    ------
    PpalocError
        For an unknown or unavailable name, listing the available ones.
    """
    available = available_methods()
    if not names:
        if not available:
            raise PpalocError("no localisation method is available in this install")
        return available
    out: list[str] = []
    for name in names:
        parts = [p.strip() for p in str(name).split(",")]
        if name not in available and len(parts) > 1 and all(p in available for p in parts):
            raise PpalocError(
                f"method {name!r} names {len(parts)} methods in one: give each its own "
                f"--method ({' '.join(f'-m {p}' for p in parts)}), or list them in a "
                "configuration file (methods = [...])"
            )
        if name not in available:
            why = "is not available in this install" if name in registry() else "is unknown"
            raise PpalocError(
                f"method {name!r} {why}; choose from: {', '.join(available)} "
                "(see `ppaloc evaluate --help`)"
            )
        if name not in out:
            out.append(name)
    return out


def localiser_params(
    name: str, user: Mapping[str, Any], *, seed: int, record_weights: bool
) -> dict[str, Any]:
    """The user's parameters for method ``name`` plus ``seed`` and ``record_weights=True``
    where its class accepts them (the user's own values win)."""
    accepted = accepted_parameters(name)
    params = dict(user)
    if accepted is None or "seed" in accepted:
        params.setdefault("seed", seed)
    if record_weights and (accepted is None or "record_weights" in accepted):
        params.setdefault("record_weights", True)
    return params


def sensor_stream(frames: Sequence[np.ndarray], *, keep: bool = False) -> FrameSequence:
    """A traversal through the sensor front-end, lazily: frame ``i`` is read (or rendered)
    and converted (:func:`ppaloc.datasets.to_sensor`) when it is accessed.

    Only the last few converted frames are kept, so iterating over a route of any length
    holds a handful of frames; ``keep=True`` keeps every frame once converted (for several
    passes over a short route).

    Examples
    --------
    >>> seq = sensor_stream([np.zeros((32, 64), np.uint8)] * 3)
    >>> len(seq), seq[2].shape
    (3, (256, 256))
    """
    seq = as_frames(frames)
    return seq.transformed(to_sensor, cache=len(seq) if keep else None)


class ReportedFrames(Sequence[np.ndarray]):
    """A traversal whose iteration calls ``hook(frames_done)`` after each frame: the
    progress of a ``build_map``, which reads its frames in one pass; indexing and slicing
    pass through unreported."""

    def __init__(self, frames: Sequence[np.ndarray], hook: Callable[[int], None]) -> None:
        self._frames, self._hook = frames, hook

    def __len__(self) -> int:
        return len(self._frames)

    def __getitem__(self, item: Any) -> Any:
        return self._frames[item]

    def __iter__(self) -> Iterator[np.ndarray]:
        for done, frame in enumerate(self._frames, 1):
            yield frame
            self._hook(done)


def sensor_frames(
    frames: Sequence[np.ndarray], progress: ProgressHook | None = None, *, task: str = ""
) -> list[np.ndarray]:
    """Every frame of a (lazy) traversal through the sensor front-end, in order, in memory.

    For scripts that pass over one short route many times; 65,536 bytes a frame, so
    evaluations and ``ppaloc map`` stream instead (:func:`sensor_stream`).
    ``progress(task, frames_done)`` is called after every frame when given.
    """
    out = []
    for i in range(len(frames)):
        out.append(to_sensor(frames[i]))
        if progress:
            progress(task, i + 1)
    return out


def method_metrics(
    ref_index: np.ndarray,
    score: np.ndarray,
    ground_truth: Sequence[np.ndarray],
    ranking: np.ndarray,
    *,
    recall: str,
    reference_positions: np.ndarray | None = None,
    query_positions: np.ndarray | None = None,
    turning: np.ndarray | None = None,
) -> Metrics:
    """The metrics of one method's per-query arrays: the same function after a run and when
    a results folder is read back, so a report rebuilt from files shows the run's figures.

    ``ranking`` is (M, K) reference indices padded with -1 (K may be 0: no rankings).
    """
    return evaluate_estimates(
        ref_index,
        score,
        ground_truth,
        recall=recall,
        rankings=ranking if ranking.shape[1] else None,  # rows padded with -1, which never match
        reference_positions=reference_positions,
        query_positions=query_positions,
        turning=turning,
    )


def predicted_frames(nodes: np.ndarray, frame_index: np.ndarray) -> np.ndarray:
    """The reference frame each predicted (or ranked) node stands for: the node's own frame.

    A node of a keyframe map stands for the reference frames from its own to the next
    node's, but it is the picture of its own frame (``TopoMap.frame_index``), so that is
    the prediction, for every method alike: it never depends on the ground truth (which
    reference frames show one place, such as a stop, is the dataset's to say, and every
    method is scored against the same accepted sets). With one node per frame this is
    the node itself.

    Parameters
    ----------
    nodes : ndarray of int, shape (M,) or (M, K)
        Predicted (or ranked) nodes per query; -1 pads a ranking and stays -1.
    frame_index : ndarray of int, shape (N,)
        Each node's reference frame (``TopoMap.frame_index``).

    Examples
    --------
    >>> predicted_frames(np.array([[1, 2], [0, -1]]), np.array([0, 1, 5]))
    array([[ 1,  5],
           [ 0, -1]])
    """
    nodes = np.asarray(nodes, dtype=np.int64)
    first = np.asarray(frame_index, dtype=np.int64)
    return np.where(nodes >= 0, first[np.maximum(nodes, 0)], -1)


def run_method(
    name: str,
    reference: Sequence[np.ndarray],
    query: Sequence[np.ndarray],
    ground_truth: Sequence[np.ndarray],
    *,
    params: Mapping[str, Any] | None = None,
    recall: str = "A",
    max_weight_values: int = 4_000_000,
    reference_positions: np.ndarray | None = None,
    query_positions: np.ndarray | None = None,
    query_moved: np.ndarray | None = None,
    progress: ProgressHook | None = None,
    localiser: Localiser | None = None,
    query_turning: np.ndarray | None = None,
) -> MethodRun:
    """Build the map of one method from sensor frames and step every query frame once.

    Parameters
    ----------
    name : str
        Registered method name (or a label when ``localiser`` is given).
    reference, query : sequence of ndarray, shape (256, 256), uint8
        Sensor frames, read once in order by ``build_map`` and by the query loop
        (:func:`sensor_stream`: nothing is held beyond the current frames).
    ground_truth : sequence of ndarray of int
        Accepted reference indices per query.
    params : mapping, optional
        Keyword arguments for :func:`ppaloc.methods.make_localiser`.
    recall : {"A", "B", "C"}
    max_weight_values : int
        Recorded weights are kept only when queries x nodes is at most this.
    reference_positions, query_positions, query_moved : optional
        From the dataset, for the error in metres and the motion accuracy.
    query_turning : ndarray of bool, optional
        Which queries were taken in a turn (the dataset's ``meta["query_turning"]``), for
        ``f1_max_straight`` and ``f1_max_turning``.
    progress : callable, optional
        ``progress(name, frames_done)`` as frames are consumed: the reference frames read
        by ``build_map`` count first (1 .. R), then the query frames (R + 1 .. R + M).
    localiser : Localiser, optional
        Use this object instead of ``make_localiser(name, **params)`` (tests, scripts).

    Returns
    -------
    MethodRun
    """
    params = dict(params or {})
    loc = localiser if localiser is not None else make_localiser(name, **params)
    n_ref = len(reference)
    if progress:
        progress(name, 0)
        reference = ReportedFrames(reference, lambda done: progress(name, done))
    log.info("%s: mapping %d reference frames", name, n_ref)
    t0 = time.perf_counter()
    topomap = loc.build_map(reference)
    build_s = time.perf_counter() - t0
    loc.reset()
    reads_future = hand_query(loc, query)
    n_nodes = len(topomap)
    m = len(query)
    log.info("%s: %d nodes; localising %d query frames", name, n_nodes, m)
    record = _Record(m, n_nodes if m * n_nodes <= max_weight_values else None)
    if progress:
        progress(name, n_ref)
    clock = time.perf_counter_ns
    for i in range(m):
        frame = query[i]
        t = clock()
        est = loc.step(frame)
        record.add(i, est, (clock() - t) / 1e6)
        if progress:
            progress(name, n_ref + i + 1)
    node, score, moved, latency = record.node, record.score, record.moved, record.latency
    if m and (node.min() < 0 or node.max() >= n_nodes):
        raise RuntimeError(f"{name} returned a node outside its map of {n_nodes} nodes")
    ref_index = predicted_frames(node, topomap.frame_index)
    ranking = predicted_frames(record.ranking, topomap.frame_index)
    modelled, energy, weights = record.modelled, record.energy, record.weights
    del record
    metrics = method_metrics(
        ref_index,
        score,
        ground_truth,
        ranking,
        recall=recall,
        reference_positions=reference_positions,
        query_positions=query_positions,
        turning=query_turning,
    )
    motion_acc = None
    if query_moved is not None and m and (moved >= 0).all():
        motion_acc = float(np.mean((moved == 1) == np.asarray(query_moved, dtype=bool)))
    return MethodRun(
        method=name,
        params={k: _jsonable(v) for k, v in params.items()},
        map_kind=topomap.kind,
        n_nodes=n_nodes,
        build_s=build_s,
        node=node,
        ref_index=ref_index,
        score=score,
        moved=moved,
        ranking=ranking,
        latency_ms=latency,
        metrics=metrics,
        weights=weights,
        modelled_latency_ms=modelled,
        energy_mj=energy,
        modelled_time_ms=modelled_time(loc),
        motion_accuracy=motion_acc,
        registers=register_planes(loc),
        reads_future=reads_future,
        frame_index=np.asarray(topomap.frame_index, dtype=np.int64),
    )


class _Record:
    """What a run keeps of each query's :class:`Estimate`: its numbers, written into arrays
    of M rows made before the first query (the ranking's K columns when the first ranking
    arrives), so no per-query object outlives its step; the weights only into the (M, N)
    matrix when it is kept (an estimate's own copy of N weights is dropped with it)."""

    def __init__(self, m: int, weight_nodes: int | None) -> None:
        self.node = np.empty(m, dtype=np.int64)
        self.score = np.empty(m, dtype=np.float64)
        self.moved = np.empty(m, dtype=np.int8)
        self.latency = np.empty(m, dtype=np.float64)
        self.ranking = np.full((m, 0), -1, dtype=np.int64)  # best first, -1 pads
        self._modelled = np.full(m, np.nan)
        self._energy = np.full(m, np.nan)
        self._has_modelled = self._has_energy = False
        self.weights: np.ndarray | None = None
        self._m, self._weight_nodes = m, weight_nodes

    def add(self, i: int, est: Estimate, latency_ms: float) -> None:
        self.node[i] = est.node
        self.score[i] = est.score
        self.moved[i] = -1 if est.moved is None else int(est.moved)
        self.latency[i] = latency_ms
        if est.ranking is not None and len(est.ranking):
            r = np.asarray(est.ranking, dtype=np.int64)
            if len(r) > self.ranking.shape[1]:  # the first (or a longer) ranking: widen
                wider = np.full((self._m, len(r)), -1, dtype=np.int64)
                wider[:, : self.ranking.shape[1]] = self.ranking
                self.ranking = wider
            self.ranking[i, : len(r)] = r
        if est.modelled_latency_ms is not None:
            self._modelled[i], self._has_modelled = float(est.modelled_latency_ms), True
        if est.energy_mj is not None:
            self._energy[i], self._has_energy = float(est.energy_mj), True
        if est.weights is not None and self._weight_nodes is not None:
            if self.weights is None:
                self.weights = np.full((self._m, self._weight_nodes), np.nan, dtype=np.float32)
            self.weights[i] = np.asarray(est.weights, dtype=np.float32)

    @property
    def modelled(self) -> np.ndarray | None:
        """Modelled on-sensor time per query (NaN where not modelled); None if never."""
        return self._modelled if self._has_modelled else None

    @property
    def energy(self) -> np.ndarray | None:
        """Modelled energy per query (NaN where not modelled); None if never."""
        return self._energy if self._has_energy else None


def hand_query(localiser: Any, query: Sequence[np.ndarray]) -> bool:
    """Hand an offline localiser (``reads_future`` true, e.g. ``seqslam-centred``) the whole
    query before its first ``step``, through its ``read_ahead``; an online one is left alone.

    Returns
    -------
    bool
        Whether the localiser reads future frames.
    """
    if not getattr(localiser, "reads_future", False):
        return False
    localiser.read_ahead(query)
    return True


def modelled_time(localiser: Any) -> dict[str, dict[str, float]] | None:
    """Median modelled time per frame at the chip and loop boundaries, if modelled.

    A localiser that simulates a sensor offers ``modelled_time_ms()`` (over the frames since
    its last ``reset``); None for every other method.
    """
    fn = getattr(localiser, "modelled_time_ms", None)
    return fn() if callable(fn) else None


def register_planes(localiser: Any) -> dict[str, np.ndarray] | None:
    """Register planes of a simulated sensor after its last frame, for the report.

    A localiser that simulates a sensor offers ``register_planes() -> {label: 2-D array}``
    (untimed reads); None for every other method.
    """
    fn = getattr(localiser, "register_planes", None)
    if not callable(fn):
        return None
    planes = {str(k): np.asarray(v) for k, v in fn().items()}
    return planes or None


def scoring_protocol(dataset: RouteDataset) -> dict[str, Any]:
    """The rules every method of a run is scored by, for results.json: the prediction rule
    and the dataset's ground-truth rule (its ``meta["ground_truth_rule"]``, if any)."""
    out: dict[str, Any] = {"prediction": PREDICTION_RULE}
    rule = dataset.meta.get("ground_truth_rule")
    if rule is not None:
        out["ground_truth"] = _jsonable(rule)
    return out


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, tuple | list):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    return v


class ProgressBar:
    """A rich progress bar on stderr, one task per method; silent when not a terminal.

    Use as a context manager; ``add(name, total)`` declares a task and calling the bar as
    ``bar(name, done)`` advances it (the :data:`ProgressHook` signature).
    """

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self._bar = None
        self._tasks: dict[str, Any] = {}

    def __enter__(self) -> ProgressBar:
        if self.enabled:
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeRemainingColumn,
            )

            self._bar = Progress(
                TextColumn("{task.description:<36}"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeRemainingColumn(),
                console=Console(stderr=True),
                transient=False,
            )
            self._bar.__enter__()
        return self

    def add(self, name: str, total: int, *, label: str | None = None) -> None:
        if self._bar is not None:
            self._tasks[name] = self._bar.add_task(label or name, total=total)

    def set_total(self, name: str, total: int) -> None:
        """Change task ``name``'s total (work found as it goes)."""
        if self._bar is not None and name in self._tasks:
            self._bar.update(self._tasks[name], total=total)

    def __call__(self, name: str, done: int) -> None:
        if self._bar is not None and name in self._tasks:
            self._bar.update(self._tasks[name], completed=done)

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.__exit__(None, None, None)


def check_oracle_moves(
    name: str,
    params: Mapping[str, Any],
    n_query: int,
    query: str,
    *,
    fix: str = "leave oracle_moves out to read the dataset's true motion",
) -> None:
    """Refuse, before any frame is read, ground-truth moves given by hand (``oracle_moves``)
    that stop short of the query: the oracle motion model reads one a frame, and failed at
    the first frame beyond them, after the map was built and the frames before it run.

    Parameters
    ----------
    name : str
        The method, as the message names it.
    params : mapping
        Its parameters (``motion``, ``oracle_moves``; a string there is a description of
        moves read from a dataset, which cover it by construction).
    n_query : int
        The query frames the run will give the method.
    query : str
        What the query is, as the message names it (``query frames of 'SPEC'``).
    fix : str
        The way out besides giving one move a frame.

    Raises
    ------
    PpalocError
        Fewer moves than query frames.
    """
    moves = params.get("oracle_moves")
    if params.get("motion") != "oracle" or moves is None or isinstance(moves, str):
        return
    try:
        given = len(moves)
    except TypeError:
        return  # not a list: the localiser refuses it with its own message
    if given < n_query:
        raise PpalocError(
            f"method {name!r}: oracle_moves holds {given} moves for the {n_query} {query}; "
            f"give one a query frame, or {fix}"
        )


def run_evaluation(
    config: EvaluateConfig,
    *,
    dataset: RouteDataset | None = None,
    localisers: Mapping[str, Localiser] | None = None,
    progress: bool = True,
) -> RunResult:
    """Run every method of ``config`` on its dataset and measure them.

    Parameters
    ----------
    config : EvaluateConfig
    dataset : RouteDataset, optional
        Use this dataset instead of loading ``config.dataset`` (tests, scripts); its
        ground truth is taken as is.
    localisers : mapping of str to Localiser, optional
        Ready localisers by label, run instead of the registry's methods (tests, scripts).
    progress : bool
        Show a progress bar on a terminal (never when stderr is not a TTY).

    Returns
    -------
    RunResult

    Raises
    ------
    PpalocError
        For an unknown method, a bad dataset spec or bad method parameters.
    """
    spec = config.resolved_dataset()
    # Construct every localiser before loading data, so a bad parameter fails fast.
    plan: dict[str, tuple[dict[str, Any], Localiser | None]] = {}
    if localisers is None:
        unknown = sorted(set(config.params) - set(registry()))
        if unknown:
            raise PpalocError(
                f"params given for unknown method {unknown[0]!r}; methods: {', '.join(registry())}"
            )
        for name in resolve_methods(config.methods):
            params = localiser_params(
                name,
                config.params.get(name, {}),
                seed=config.seed,
                record_weights=config.record_weights,
            )
            needs = dataset_needs(name, params)
            check_method(name, params)
            plan[name] = (params, None if needs else make_localiser(name, **params))
    else:
        plan = {name: (dict(config.params.get(name, {})), loc) for name, loc in localisers.items()}
    if dataset is None:
        from ppaloc.datasets.registry import load_dataset

        dataset = load_dataset(spec)
    else:
        spec = str(dataset.meta.get("spec", dataset.name))
    for name, (params, loc) in plan.items():
        if loc is None:  # the method reads the dataset (e.g. the oracle's true moves)
            given = dataset_arguments(name, params, dataset, spec)
            loc = make_localiser(name, **params, **given)
            needs = dataset_needs(name, params)
            shown = {arg: f"dataset {needs[arg].attribute}" for arg in given}
            plan[name] = ({**params, **shown}, loc)
    for name, (params, _) in plan.items():
        check_oracle_moves(name, params, len(dataset.query), f"query frames of {spec!r}")
    gt = PackedSets.from_sets(dataset.ground_truth)
    speeds = speed_checks(  # logs warnings
        {name: loc for name, (_, loc) in plan.items()}, gt, moved=dataset.query_moved
    )
    positions_ok = dataset.reference_positions is not None and dataset.query_positions is not None
    runs: dict[str, MethodRun] = {}
    names = list(plan)
    n_ref, n_query = len(dataset.reference), len(dataset.query)
    # Several methods on a short route share its converted frames; otherwise each reads
    # them again, one at a time.
    keep = len(plan) > 1 and (n_ref + n_query) * _SENSOR_FRAME_BYTES <= SHARED_FRAMES_BYTES
    reference = sensor_stream(dataset.reference, keep=keep)
    query = sensor_stream(dataset.query, keep=keep)
    # The difference matrix, from the frames the first method streams (evaluate.difference)
    difference = DifferenceRecorder(n_ref, n_query)
    with ProgressBar(progress) as bar:
        for name in names:
            bar.add(name, n_ref + n_query, label=f"{name} (map, queries)")
        for name, (params, loc) in plan.items():
            if localisers is None:
                params = {**registry()[name].defaults, **params}  # record the variant too
            first = not runs
            runs[name] = run_method(
                name,
                difference.watch_reference(reference) if first else reference,
                difference.watch_query(query) if first else query,
                gt,
                params=params,
                recall=config.recall,
                max_weight_values=config.max_weight_values,
                reference_positions=dataset.reference_positions if positions_ok else None,
                query_positions=dataset.query_positions if positions_ok else None,
                query_moved=dataset.query_moved,
                progress=bar,
                localiser=loc,
                query_turning=dataset.meta.get("query_turning"),
            )
            runs[name].speed_check = speeds.get(name)
            if first:  # the recorder's work during the map build is not the method's
                runs[name].build_s = max(0.0, runs[name].build_s - difference.reference_seconds)
    resolved = config.to_dict()
    resolved["dataset"] = spec
    resolved["methods"] = list(names)
    return RunResult(
        dataset=spec,
        dataset_name=dataset.name,
        tolerance=int(dataset.tolerance),
        ground_truth=gt,
        n_reference=n_ref,
        runs=runs,
        config=resolved,
        reference_positions=dataset.reference_positions,
        query_positions=dataset.query_positions,
        query_moved=dataset.query_moved,
        query_turning=_flags(dataset.meta.get("query_turning")),
        reference_turning=_flags(dataset.meta.get("reference_turning")),
        protocol=scoring_protocol(dataset),
        difference=difference.result(reference, query),
        created=datetime.now(UTC).isoformat(timespec="seconds"),
        roles=dataset.meta.get("roles"),
    )
