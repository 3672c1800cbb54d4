"""A map of any size on a bank of simulated sensors, combined by their controllers.

One simulated SCAMP-5 holds at most a few tiles (:attr:`SensorPipeline.capacity`: two
tiles of 2048 descriptors, or one low-res tile with the levels store). A
:class:`SensorBank` cuts a longer snake into consecutive parts, one sensor per part, all
seeing the same frame. Each sensor runs the robust preset's stages on its part; the
controllers exchange only integers at five points of the frame (docs/onsensor.md, "Sensor
banks"):

1. the motion decision of sensor 0 (the others skip the motion stage);
2. the transition's carry: before any transition, each sensor reads the weights of its
   last ``max_advance`` nodes exactly (:meth:`SensorPipeline.carry_out`, five ADC digits)
   and the next sensor writes them where its snake start reads them, instead of the
   array edge (:meth:`SensorPipeline.carry_in`);
3. the likelihood scale: ``frame_statistics`` over every sensor's readout, then each
   sensor adds the terms with the common ``s`` and ``alpha_t``;
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
from ppaloc.localise.params import (
    FilterParams,
    frame_statistics,
    likelihood_shift,
    transition_costs,
)
from ppaloc.localise.weighted import choose_candidate
from ppaloc.onsensor.core import SensorPipeline
from ppaloc.onsensor.mapping import upload_map
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

    def __init__(self, sensors: list[SensorPipeline]) -> None:
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
    """A robust-preset map on several simulated sensors (see the module docstring).

    Parameters
    ----------
    first : SensorPipeline
        Sensor 0 (e.g. the one that mapped the route); it keeps the first part.
    n_nodes : int
        Nodes of the whole map.
    make : callable
        ``make(n_nodes, index)``: a new sensor for part ``index`` (>= 1) of ``n_nodes``
        nodes, with its own noise seed.
    per_sensor : int, optional
        Nodes per sensor (default and at most: a sensor's capacity; fewer make small
        banks for tests).

    Attributes
    ----------
    sensors : list of SensorPipeline
    offsets : list of int
        The map index of each sensor's node 0.
    """

    def __init__(
        self,
        first: SensorPipeline,
        n_nodes: int,
        make: Callable[[int, int], SensorPipeline],
        per_sensor: int | None = None,
    ) -> None:
        if first.params.preset != "robust":
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
        self.robust = True
        self.alpha: int | None = None
        self.n_nodes = int(n_nodes)
        self.offsets = list(range(0, self.n_nodes, per))
        first.set_nodes(min(per, self.n_nodes))
        self.sensors = [first] + [
            make(min(per, self.n_nodes - off), i) for i, off in enumerate(self.offsets[1:], start=1)
        ]
        self.tiles = sum(s.tiles for s in self.sensors)
        self.timing = BankTiming(self.sensors)
        self.reset()

    # ------------------------------------------------------------------ map and state
    def upload(self, topomap: TopoMap) -> None:
        """Write each sensor's part of ``topomap`` into its registers (stage "mapping")."""
        desc = np.asarray(topomap.descriptors)
        for s, off in zip(self.sensors, self.offsets, strict=True):
            upload_map(s, TopoMap(topomap.kind, desc[off : off + s.n_nodes]))
        self.timing.sync()

    def reset(self) -> None:
        """Zero every sensor's weights, forget the previous frame and estimate."""
        for s in self.sensors:
            s.reset()
        self.frames = 0
        self.prev: int | None = None

    @property
    def sim(self):
        """Sensor 0's simulator (its chip and loop intervals stand for the bank's)."""
        return self.sensors[0].sim

    def weights(self) -> np.ndarray:
        """All weights in map order (untimed reads, the pending normalisation applied)."""
        return np.concatenate([s.weights() for s in self.sensors])

    def register_planes(self) -> dict[str, np.ndarray]:
        """Sensor 0's registers worth a picture, labelled ``"sensor 0, ..."``."""
        return {f"sensor 0, {k}": v for k, v in self.sensors[0].register_planes().items()}

    # ------------------------------------------------------------------ frame
    def step(self, frame: np.ndarray, moved: bool | None = None) -> tuple[int, float, bool, int]:
        """Run one frame on every sensor; return ``(node, score, moved, T)`` of the map."""
        sensors, sync = self.sensors, self.timing.sync
        self.frames += 1
        for s in sensors:
            s.frames += 1
            s.refresh()
            s.capture(frame)
            s.block_means()
        if moved is None:
            moved = sensors[0].motion()
        sync()
        first = self.frames == 1
        if not first:
            costs = transition_costs(bool(moved), self.params)
            carries = [s.carry_out(len(costs) - 1) for s in sensors[:-1]]
            sync()
            for s, carry in zip(sensors[1:], carries, strict=True):
                s.carry_in(carry)
            for i, s in enumerate(sensors):
                s.transition(costs, carried=i > 0)
        if first or moved:
            values = []
            for s in sensors:
                s.prepare_live()
                values.append(s.robust_values())
            sync()
            best, mean = frame_statistics(np.concatenate(values))
            shift = likelihood_shift(mean - best, int(self.params.gain))
            for s in sensors:
                s.robust_update(shift, best >> shift)
        node, top = self._detect()
        score = self._confidence(node, top)
        for s in sensors:
            s.normalise(top)
            s.prev = node
        self.prev = node
        return node, score, bool(moved), top

    def _detect(self) -> tuple[int, int]:
        sensors, sync = self.sensors, self.timing.sync
        tops = []
        for s in sensors:
            with s.sim.stage("detect"):
                tops.append(s.local_top())
        sync()
        top = max(tops)
        while True:
            found: list[int] = []
            for s, off, own in zip(sensors, self.offsets, tops, strict=True):
                if own < top:
                    continue
                prev = None if self.prev is None else self.prev - off
                with s.sim.stage("detect"):
                    nodes = s.candidates(top, prev)
                found += [off + i for i in nodes or ()]
            sync()
            if found or top <= -127:
                break
            top -= 1  # only with noise: the comparators hid every candidate this time
        if not found:
            return (0 if self.prev is None else self.prev), top
        return choose_candidate(np.array(sorted(found)), self.prev), top

    def _confidence(self, node: int, top: int) -> float:
        r = self.params.confidence_radius
        if node - r <= 0 and node + r >= self.n_nodes - 1:
            return 0.0
        outs = []
        for s, off in zip(self.sensors, self.offsets, strict=True):
            with s.sim.stage("confidence"):
                outs.append(s.outside_max(node - r - off, node + r - off, top))
        self.timing.sync()
        found = [o for o in outs if o is not None]
        return 0.0 if not found else float(top - max(found))
