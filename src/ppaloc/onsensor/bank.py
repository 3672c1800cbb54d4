"""A map of any size on a bank of simulated sensors, combined by their controllers.

One simulated SCAMP-5 holds at most a few tiles (:attr:`SensorExecutor.capacity`: two
tiles of 2048 descriptors; one low-res tile with the levels store or where the
schedule refines the frame's best distance, as the robust preset does). A
:class:`SensorBank` cuts a longer snake into consecutive parts, one sensor per part, all
seeing the same frame. It is an executor of the schedules
(:class:`ppaloc.localise.schedule.Executor`): each of its steps runs the sensor
executor's stages on every part, and the controllers exchange only numbers (integers,
and values read exactly from the array) at five points of the frame, six with the local
term (docs/onsensor.md, "Sensor banks"):

1. the motion decision of sensor 0 (the others skip the motion stage);
2. the transition's carry: before any transition, each sensor reads the weights of its
   last ``max_advance`` nodes exactly (:meth:`SensorExecutor.carry_out`, five ADC
   digits) and the next sensor writes them where its snake start reads them, instead of
   the array edge (:meth:`SensorExecutor.carry_in`);
3. the likelihood scale: the schedule's ``frame_scale`` over every sensor's readout,
   then each sensor adds the terms with the common ``s`` and ``alpha_t``; with
   ``local_gain``, the exact values of each sensor's end nodes for the local term's
   pairs across the cuts (:mod:`ppaloc.onsensor.local`);
4. detection: ``T`` is the largest of the sensors' thresholds, the candidates the union
   of theirs at ``T`` (each gives all, or its one nearest the previous estimate);
5. confidence: the largest of the sensors' maxima outside the window; every sensor's
   normalisation then takes the common ``T``.

The modelled time of a frame is, per phase between two of those points, the slowest
sensor's time plus one exchange (:data:`SYNC_US`, an estimate); the energy is the sum of
the sensors'. In ideal mode the estimates equal the host's on the whole map.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.enhance import place_neighbours
from ppaloc.localise.params import FilterParams, choose_candidate
from ppaloc.onsensor.executor import SensorExecutor
from ppaloc.onsensor.local import cross_pairs
from ppaloc.onsensor.mapping import upload_map
from ppaloc.onsensor.runs import bank_offsets
from ppaloc.sim import Scamp5
from ppaloc.topomap import TopoMap

__all__ = ["SYNC_US", "BankTiming", "SensorBank"]

#: One exchange of a few integers between the controllers of a bank, in microseconds
#: (low, mid, high): an estimate (no bank of SCAMP-5 sensors is published): a word-wide
#: link between microcontrollers moves a few words in microseconds, a USB round trip
#: through a host takes 125 us microframes or more; mid is used.
SYNC_US = (5.0, 20.0, 125.0)


class BankTiming:
    """Modelled time and energy of a bank (the attributes the localiser reads).

    ``now_us`` grows by the slowest sensor's time of each phase plus one exchange per
    synchronisation point; ``energy_uj`` is the sum of the sensors' energies.
    """

    def __init__(self, sensors: list[SensorExecutor]) -> None:
        self._sensors = sensors
        self.now_us = 0.0
        self.syncs = 0
        self._last = [s.timing.now_us for s in sensors]

    @property
    def energy_uj(self) -> float:
        """The sum of the sensors' modelled energies, in microjoules."""
        return float(sum(s.timing.energy_uj for s in self._sensors))

    def sync(self) -> None:
        """Close a phase: add its slowest sensor's time and one exchange."""
        now = [s.timing.now_us for s in self._sensors]
        # a sensor's model reset since the last phase (e.g. by a timing report) counts from 0
        phase = [n - last if n >= last else n for n, last in zip(now, self._last, strict=True)]
        self.now_us += max(phase)
        self.now_us += SYNC_US[1]
        self.syncs += 1
        self._last = now


class SensorBank:
    """A map on several simulated sensors, run as one executor (see the module docstring).

    Parameters
    ----------
    first : SensorExecutor
        Sensor 0 (e.g. the one that mapped the route); it keeps the first part.
    n_nodes : int
        Nodes of the whole map.
    make : callable
        ``make(n_nodes, index)``: a new sensor for part ``index`` (>= 1) of ``n_nodes``
        nodes, with its own noise seed.
    per_sensor : int, optional
        Nodes per sensor (default and at most: a sensor's capacity; fewer make small
        banks for tests).
    places : ndarray of int, optional
        The map's places (``TopoMap.places``) where it has runs: the cuts between sensors
        then fall between places (:func:`ppaloc.onsensor.runs.bank_offsets`).
    least : int
        Nodes every sensor but the last must hold: the most a frame may advance into the
        next sensor (the schedule's ``max_advance``).

    Attributes
    ----------
    sensors : list of SensorExecutor
    offsets : list of int
        The map index of each sensor's node 0.
    """

    exact = True
    integer_readout = True

    def __init__(
        self,
        first: SensorExecutor,
        n_nodes: int,
        make: Callable[[int, int], SensorExecutor],
        per_sensor: int | None = None,
        places: np.ndarray | None = None,
        least: int = 1,
    ) -> None:
        if not first.plan.bank:
            raise PpalocError(
                f"a map of {n_nodes} nodes needs more than one sensor; a bank runs the robust "
                f"preset only (the paper preset holds at most {first.capacity} nodes): use "
                "preset='robust' or a shorter route"
            )
        per = first.capacity if per_sensor is None else min(int(per_sensor), first.capacity)
        if per < 1:
            raise PpalocError(f"per_sensor={per_sensor} must be at least 1 node")
        self.params: FilterParams = first.params
        self.representation = first.representation
        self.store = first.store
        self.n_nodes = int(n_nodes)
        self.offsets = bank_offsets(places, self.n_nodes, per, least)
        sizes = np.diff([*self.offsets, self.n_nodes]).tolist()
        first.set_nodes(sizes[0])
        self.sensors = [first] + [make(n, i) for i, n in enumerate(sizes[1:], start=1)]
        self.tiles = sum(s.tiles for s in self.sensors)
        self.timing = BankTiming(self.sensors)
        self._places: np.ndarray | None = None  # the map's places where it has runs
        self._local_plans: dict[int, tuple[list[tuple[int, int, int, int]], list[set[int]]]] = {}
        self.reset()

    # ------------------------------------------------------------------ map and state
    def upload(self, topomap: TopoMap, runs: bool = True) -> None:
        """Write each sensor's part of ``topomap`` into its registers (stage "mapping"),
        with its part of the map's runs (``runs``; :func:`ppaloc.onsensor.mapping.upload_map`)."""
        desc, places = np.asarray(topomap.descriptors), topomap.places
        self._places = places if runs and topomap.has_runs else None
        self._local_plans = {}  # the local term's plans were the old map's
        for s, off in zip(self.sensors, self.offsets, strict=True):
            part = None if places is None else places[off : off + s.n_nodes] - places[off]
            upload_map(s, TopoMap(topomap.kind, desc[off : off + s.n_nodes], places=part), runs)
        self.timing.sync()

    def reset(self) -> None:
        """Zero every sensor's weights, forget the previous frame and estimate."""
        for s in self.sensors:
            s.reset()
        self.top_fraction = 0

    @property
    def sim(self) -> Scamp5:
        """Sensor 0's simulator (its chip and loop intervals stand for the bank's)."""
        return self.sensors[0].sim

    def weights(self) -> np.ndarray:
        """All weights in map order (untimed reads, the pending normalisation applied)."""
        return np.concatenate([s.weights() for s in self.sensors])

    def register_planes(self) -> dict[str, np.ndarray]:
        """Sensor 0's registers worth a picture, labelled ``"sensor 0, ..."``."""
        return {f"sensor 0, {k}": v for k, v in self.sensors[0].register_planes().items()}

    # ------------------------------------------------------------------ the steps
    def begin(self, frame: np.ndarray) -> None:
        """Every sensor takes the frame (refresh, capture, block means)."""
        for s in self.sensors:
            s.begin(frame)

    def motion(self, decided: bool | None) -> bool:
        """Sensor 0's motion decision (or the controller's), shared with the others."""
        moved = self.sensors[0].motion(decided)
        self.timing.sync()
        return moved

    def transition(self, costs: tuple[int, ...]) -> None:
        """Every sensor's transition, the previous sensor's last weights carried into its
        snake's start."""
        sensors = self.sensors
        carries = [s.carry_out(len(costs) - 1) for s in sensors[:-1]]
        self.timing.sync()
        for s, carry in zip(sensors[1:], carries, strict=True):
            s.carry_in(carry)
        for i, s in enumerate(sensors):
            s.transition(costs, carried=i > 0)

    def node_values(self) -> np.ndarray:
        """Every sensor's node values, in map order."""
        values = [s.node_values() for s in self.sensors]
        self.timing.sync()
        return np.concatenate(values)

    def minimum(self, values: np.ndarray) -> float:
        """The frame's best distance: the least of the sensors' that hold the least
        readout (a sensor whose least readout is larger has a larger best distance)."""
        least = values.min()
        best = [
            s.minimum(part)
            for s, off in zip(self.sensors, self.offsets, strict=True)
            if (part := values[off : off + s.n_nodes]).min() == least
        ]
        self.timing.sync()
        return min(best)

    def add_scaled(self, shift: int, alpha: float) -> None:
        """Every sensor adds its terms with the common ``s`` and ``alpha_t``."""
        for s in self.sensors:
            s.add_scaled(shift, alpha)

    def add_local(self, gain: int, window: int) -> None:
        """The local term on every sensor, then the pairs across the cuts from the exact
        values the sensors exchange (:mod:`ppaloc.onsensor.local`)."""
        pairs, wanted = self._local_plan(window)
        values = [s.local_term(gain, window, wanted[i]) for i, s in enumerate(self.sensors)]
        self.timing.sync()
        for i, s in enumerate(self.sensors):
            others = [(a, values[j][b]) for k, a, j, b in pairs if k == i]
            s.local_edges(gain, window, values[i], others)

    def _local_plan(self, window: int) -> tuple[list[tuple[int, int, int, int]], list[set[int]]]:
        """The local term's pairs across the cuts, once per map and window: ``(sensor,
        node, its neighbour's sensor, the neighbour)``, nodes numbered within their
        sensor, and the nodes each sensor reads for them."""
        if window not in self._local_plans:
            n = sum(s.n_nodes for s in self.sensors)
            places = self._places if self._places is not None else np.arange(n)
            owner = np.searchsorted(self.offsets, np.arange(n), side="right") - 1
            first = np.asarray(self.offsets)[owner]
            pairs = [
                (int(owner[a]), int(a - first[a]), int(owner[b]), int(b - first[b]))
                for a, b in cross_pairs(place_neighbours(places, window), owner)
            ]
            wanted: list[set[int]] = [set() for _ in self.sensors]
            for i, a, j, b in pairs:
                wanted[i].add(a)
                wanted[j].add(b)
            self._local_plans[window] = (pairs, wanted)
        return self._local_plans[window]

    def detect(self, prev: int | None, bits: int = 0) -> tuple[int, float]:
        """``T``: the largest of the sensors' thresholds; with ``bits``, the candidates'
        threshold refined by the sensors at ``T`` (the largest fraction of theirs); the
        candidates: the union of theirs at it."""
        sensors, sync = self.sensors, self.timing.sync
        tops = []
        for s in sensors:
            with s.sim.stage("detect"):
                tops.append(s.local_top())
        sync()
        top = max(tops)
        fracs = [0] * len(sensors)
        if bits:
            for i, s in enumerate(sensors):
                if tops[i] == top:
                    with s.sim.stage("detect"):
                        fracs[i] = s.local_fraction(top, bits)
            sync()
        frac = max(fracs)
        while True:
            found: list[int] = []
            for s, off, own, mine in zip(sensors, self.offsets, tops, fracs, strict=True):
                if own < top or mine < frac:
                    continue
                local = None if prev is None else prev - off
                with s.sim.stage("detect"):
                    nodes = s.candidates(top, local, frac, bits)
                found += [off + i for i in nodes or ()]
            sync()
            if found or top <= -127:
                break
            # only with noise: the comparators hid every candidate this time
            if frac:
                frac, fracs = 0, [0] * len(sensors)
            else:
                top -= 1
        self.top_fraction = frac
        if not found:
            return (0 if prev is None else prev), top
        return choose_candidate(np.array(sorted(found)), prev), top

    def confidence(self, node: int, top: float, window: tuple[int, int], bits: int = 0) -> float:
        """The refined ``T`` minus the largest of the sensors' maxima outside the nodes
        ``window``, refined to ``2**-bits`` by the sensors that reach it."""
        a, b = window
        if a <= 0 and b >= self.n_nodes - 1:
            return 0.0
        outs = []
        for s, off in zip(self.sensors, self.offsets, strict=True):
            with s.sim.stage("confidence"):
                outs.append(s.outside_max(a - off, b - off, int(top)))
        self.timing.sync()
        found = [o for o in outs if o is not None]
        if not found:
            return 0.0
        out, frac = max(found), 0
        if bits:
            for s, own in zip(self.sensors, outs, strict=True):
                if own == out:
                    with s.sim.stage("confidence"):
                        frac = max(frac, s.outside_fraction(out, bits))
            self.timing.sync()
        return float(top - out) + (self.top_fraction - frac) / 2**bits

    def weight_reads(self, a: int, b: int) -> list[float]:
        """The weights of nodes ``a .. b``, each read by the sensor that holds it."""
        out: list[float] = []
        ends = [*self.offsets[1:], self.n_nodes]
        for s, off, end in zip(self.sensors, self.offsets, ends, strict=True):
            lo, hi = max(a, off), min(b, end - 1)
            if lo <= hi:
                out += s.weight_reads(lo - off, hi - off)
        self.timing.sync()
        return out

    def rank(self, node: int) -> None:
        """A bank reports no ranking."""

    def normalise(self, top: float) -> None:
        """Every sensor's normalisation takes the common ``T``."""
        for s in self.sensors:
            s.normalise(top)
