"""Which place a map gets on the sensor: the best one its length leaves room for.

A SCAMP-5 array holds a fixed number of PEs, so the information a place may carry falls
as the map grows: 16x16 images take 16x16 PEs a node (256 nodes a tile), the 192 Haar
signs 16x16 PEs of a digital register (256), 8x8 images 8x8 PEs (1024), 32-bit LBP
descriptors 4x8 PEs of a digital register (2048). How many tiles one sensor holds
depends on the registers the preset's working set leaves free (the robust preset's
low-res maps one tile beside the best-distance refinement, the binary places two digital
tiles; :meth:`ppaloc.onsensor.places.Places.max_tiles`). ``representation="auto"``
(:class:`~ppaloc.onsensor.localiser.OnSensorLocaliser`, the method ``onsensor-auto``)
takes the first place of :data:`BEST_FIRST` the preset runs on whose map fits the
sensors given (``sensors``, default one: the device on a desk), and the place that needs
the fewest sensors when none fits (a bank of them, docs/onsensor.md, "Sensor banks").

The order is the robust filter's mean max F1 on the five real routes of
``benchmarks/eval_robust.py``, not every route: 0.788 with 16x16 images, 0.785 with the
Haar signs, 0.672 with 8x8 images and 0.634 with LBP (2026-12-06). Over all 65 routes
the 8x8 images lead the signs by 0.015 (0.804 against 0.789; 16x16 0.879, LBP 0.603),
on the generated routes whose speed swings; before the local term both orders were this
one (docs/localise.md, "More values a place" and "Signs instead of values").

Examples
--------
>>> from ppaloc.localise.schedule import RobustSchedule
>>> [(n, choose_place(n, 1, RobustSchedule.sensor)) for n in (200, 256, 257, 1500, 5000)]
[(200, 'lowres16'), (256, 'lowres16'), (257, 'haar'), (1500, 'lbp'), (5000, 'lbp')]
>>> choose_place(1500, 2, RobustSchedule.sensor)
'lowres'
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams, check_int, runs_on
from ppaloc.localise.schedule import SCHEDULES, Schedule, SensorPlan, make_schedule
from ppaloc.localise.weighted import keyframe_test
from ppaloc.onsensor.executor import PLACES
from ppaloc.onsensor.precursor import REPLACED_STAGES
from ppaloc.place import SENSOR_SIZE
from ppaloc.topomap import layout_for

__all__ = [
    "AUTO",
    "BEST_FIRST",
    "MAX_SENSORS",
    "AutoPlace",
    "choose_place",
    "place_table",
    "sensor_capacity",
]

MAX_SENSORS = 2**16
"""The most sensors ``sensors=`` may name."""

BEST_FIRST = ("lowres16", "haar", "lowres", "lbp")
"""The sensor's places, best first by the robust filter's mean max F1 (module doc): 256
values, 192 signs, 64 values, 32 bits."""


def sensor_capacity(
    representation: str, plan: SensorPlan, store: str | None = None, size: int = SENSOR_SIZE
) -> int:
    """Nodes one sensor holds of ``representation`` under a schedule's ``plan``: the tiles
    its store leaves room for times the nodes of a tile (an array of ``size`` PEs a side).

    Examples
    --------
    >>> from ppaloc.localise.schedule import PaperSchedule, RobustSchedule
    >>> [sensor_capacity(r, RobustSchedule.sensor) for r in BEST_FIRST]
    [256, 512, 1024, 4096]
    >>> sensor_capacity("lowres", PaperSchedule.sensor)
    2048
    """
    places = PLACES[representation]
    store = places.choose_store(plan, store)
    return places.max_tiles(plan, store) * layout_for(representation, (size, size)).capacity


def _sensors_needed(n_nodes: int, representation: str, plan: SensorPlan, size: int) -> int:
    return math.ceil(n_nodes / sensor_capacity(representation, plan, size=size))


def choose_place(
    n_nodes: int,
    sensors: int,
    plan: SensorPlan,
    *,
    runs_on: tuple[str, ...] = BEST_FIRST,
    size: int = SENSOR_SIZE,
) -> str:
    """The place a map of ``n_nodes`` nodes gets on ``sensors`` sensors.

    The first of ``runs_on`` (in the order of :data:`BEST_FIRST`: the places the
    preset runs on) whose map fits; when none fits, the one that needs the fewest sensors
    (the best of those on a tie). A map of one sensor's preset (``plan.bank`` False)
    counts one sensor whatever ``sensors`` says.
    """
    if n_nodes < 1:
        raise PpalocError(f"a map of {n_nodes} nodes has no place to choose: it needs a node")
    check_int("sensors", sensors, 1, MAX_SENSORS)
    candidates = [r for r in BEST_FIRST if r in runs_on]
    if not candidates:
        raise PpalocError(f"no sensor place among {', '.join(runs_on) or 'none'}")
    budget = sensors if plan.bank else 1
    need = {r: _sensors_needed(n_nodes, r, plan, size) for r in candidates}
    fitting = [r for r in candidates if need[r] <= budget]
    if fitting:
        return fitting[0]
    return min(candidates, key=lambda r: need[r])  # min keeps the best on a tie


def place_table(
    plan: SensorPlan, sensors: int = 1, *, runs_on: tuple[str, ...] = BEST_FIRST
) -> list[tuple[int, str]]:
    """``[(most nodes, place), ...]``: the longest map each place is chosen for on
    ``sensors`` sensors, in order (the table of docs/onsensor.md).

    Examples
    --------
    >>> from ppaloc.localise.schedule import RobustSchedule
    >>> place_table(RobustSchedule.sensor)
    [(256, 'lowres16'), (512, 'haar'), (1024, 'lowres'), (4096, 'lbp')]
    >>> place_table(RobustSchedule.sensor, 4)
    [(1024, 'lowres16'), (2048, 'haar'), (4096, 'lowres'), (16384, 'lbp')]
    """
    budget = sensors if plan.bank else 1
    out: list[tuple[int, str]] = []
    for r in BEST_FIRST:
        if r not in runs_on:
            continue
        most = budget * sensor_capacity(r, plan)
        if not out or most > out[-1][0]:
            out.append((most, r))
    return out


AUTO = "auto"
"""``representation="auto"``: the best place the map's length leaves room for."""


@dataclass(frozen=True)
class AutoPlace:
    """``representation="auto"`` of :class:`~ppaloc.onsensor.localiser.OnSensorLocaliser`:
    what its choice reads, checked when the localiser is made (:meth:`create`).

    Attributes
    ----------
    filter_params : dict
        The filter's parameters as given (resolved again for the chosen place).
    sensors : int
        How many sensors the map may fill.
    timing_structure : str
        The precursor's structure has only 8x8 images and LBP.
    size : int
        The array's side (a smaller one is a test's).
    oracle_moves : Any
        The controller's moves for ``motion="oracle"``.
    """

    filter_params: Mapping[str, Any]
    sensors: int = 1
    timing_structure: str = "ppaloc"
    size: int = SENSOR_SIZE
    oracle_moves: Any = None

    @classmethod
    def create(
        cls, representation: str, sensors: int | None, store: str | None, **kw: Any
    ) -> AutoPlace | None:
        """The choice for ``representation`` (None unless it is ``"auto"``), every
        candidate's parameters checked; a one-line error for ``sensors`` without
        ``"auto"`` or a ``store`` with it."""
        if representation != AUTO:
            if sensors is not None:
                raise PpalocError(
                    f"sensors={sensors!r} is for representation='auto' (how many sensors "
                    f"its choice may fill); representation={representation!r} takes a bank "
                    "of as many sensors as its map needs"
                )
            return None
        if store is not None:
            raise PpalocError(
                f"store={store!r}: representation='auto' takes each place's default store; "
                "give the representation to choose its store"
            )
        n = 1 if sensors is None else check_int("sensors", sensors, 1, MAX_SENSORS)
        auto = cls(sensors=n, **kw)
        for candidate in auto.candidates:
            FilterParams.create(candidate, arithmetic="ppa8", **auto.filter_params)
        return auto

    @property
    def candidates(self) -> tuple[str, ...]:
        """The places to choose among, best first: those the preset runs on (and the
        precursor's timing structure has, when it is asked for)."""
        preset = self.filter_params.get("preset") or "robust"
        if preset not in SCHEDULES:
            FilterParams.create(BEST_FIRST[-1], preset=preset)  # its one-line error
        precursor = self.timing_structure == "precursor"
        return tuple(
            r
            for r in BEST_FIRST
            if runs_on(r, preset) and not (precursor and r not in REPLACED_STAGES)
        )

    def for_frames(self, frames: Sequence[np.ndarray], plan: SensorPlan) -> str:
        """The place of a map of ``frames``: its length the places the host's motion
        test keeps with ``keyframes`` (the sensor's own test keeps the same in ideal
        mode), else its frames (also on a test's array, whose frames the host's test
        does not read)."""
        keep = keyframe_test(FilterParams.create(self.candidates[0], **self.filter_params))
        n = len(frames)
        if keep is not None and self.size == SENSOR_SIZE:
            n = sum(1 for i, f in enumerate(frames) if keep(f) or i == 0)
        return choose_place(n, self.sensors, plan, runs_on=self.candidates, size=self.size)

    def for_kind(self, kind: str) -> str:
        """A loaded map's own place, if it is one of :attr:`candidates`."""
        if kind not in self.candidates:
            raise PpalocError(
                f"the map holds {kind!r} nodes, which representation='auto' does not run "
                f"with this preset; it chooses among {', '.join(self.candidates)}"
            )
        return kind

    def resolve(self, kind: str) -> tuple[FilterParams, Schedule, str]:
        """``(params, schedule, store)`` of the localiser running ``kind``."""
        params = FilterParams.create(kind, arithmetic="ppa8", **self.filter_params)
        schedule = make_schedule(params, self.oracle_moves)
        return params, schedule, PLACES[kind].choose_store(schedule.sensor, None)
