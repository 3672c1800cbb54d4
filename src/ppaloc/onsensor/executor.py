"""The sensor executor: a schedule's steps as PPA programs on one simulated sensor.

:class:`SensorExecutor` implements :class:`ppaloc.localise.schedule.Executor` over a
:class:`~ppaloc.onsensor.sensor.Sensor` and its representation's
:class:`~ppaloc.onsensor.places.Places`: each step runs the stage modules
(:mod:`~ppaloc.onsensor.capture`, :mod:`~ppaloc.onsensor.motion`,
:mod:`~ppaloc.onsensor.snake`, :mod:`~ppaloc.onsensor.transition`,
:mod:`~ppaloc.onsensor.likelihood`, :mod:`~ppaloc.onsensor.detect`), every one a recorded
kernel or a ``scamp5_*`` call charged to the simulator's timing model under a stage name.
The controller's side does only integer work on readouts, and the decisions are the
host's (the schedule's), so in ideal mode the estimates are those of the host in ppa8
arithmetic frame for frame (docs/ppa8.md).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams
from ppaloc.localise.schedule import SensorPlan
from ppaloc.onsensor import detect, gain, likelihood, local
from ppaloc.onsensor.capture import block_means, capture
from ppaloc.onsensor.carry import carry_in, carry_out
from ppaloc.onsensor.haar import HaarPlaces
from ppaloc.onsensor.lbp import LbpPlaces
from ppaloc.onsensor.lowres import Lowres16Places, LowresPlaces
from ppaloc.onsensor.motion import MotionPlanes, image_motion
from ppaloc.onsensor.places import Places
from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.snake import shift_weights
from ppaloc.onsensor.transition import transition
from ppaloc.onsensor.weights import WeightState, read_roots, read_weights
from ppaloc.sim import Kernel, NoiseParams, Register, Scamp5, TimingModel
from ppaloc.sim.observe import SimObserver
from ppaloc.topomap import SnakeLayout, TopoMap

__all__ = ["PLACES", "SensorExecutor"]

#: The representation of each place kind on the sensor.
PLACES: dict[str, type[Places]] = {
    "lowres": LowresPlaces,
    "lowres16": Lowres16Places,
    "lbp": LbpPlaces,
    "haar": HaarPlaces,
}


class SensorExecutor:
    """One simulated sensor holding a map, and every step a schedule calls on it.

    Parameters
    ----------
    representation : {"lowres", "lowres16", "lbp", "haar"}
    n_nodes : int
        Nodes of the map (tiles follow from the layout's capacity).
    params : FilterParams
        The filter's parameters (the schedule's).
    plan : SensorPlan
        What the schedule asks of the sensor (stores, spread, weight scale).
    noise : str or NoiseParams
        Noise preset (or parameters) of the simulator.
    seed : int
        Seed of the simulator's noise.
    size : int
        Array side (256 on SCAMP-5; smaller arrays, multiples of 64, for tests).
    store : str, optional
        How the map is held (a key of the representation's ``stores``; default the
        first the plan prefers).
    observers : sequence of SimObserver
        Observers of the sensor's simulator (:mod:`ppaloc.sim.observe`).

    Attributes
    ----------
    sensor : Sensor
    places : Places
    state : WeightState
        What the controller still owes the weights (pending normalisation, ...).
    planes : MotionPlanes
        The motion test's memory between frames.
    frames : int
        Frames since :meth:`reset`.
    """

    exact = True
    integer_readout = True

    def __init__(
        self,
        representation: str,
        n_nodes: int,
        params: FilterParams,
        plan: SensorPlan,
        *,
        noise: str | NoiseParams = "ideal",
        seed: int = 0,
        size: int = 256,
        store: str | None = None,
        observers: Sequence[SimObserver] = (),
    ) -> None:
        if not isinstance(params, FilterParams):
            raise PpalocError(
                f"params must be a ppaloc.localise.params.FilterParams, got {type(params).__name__}"
            )
        try:
            cls = PLACES[representation]
        except KeyError:
            raise PpalocError(
                f"no on-sensor pipeline for representation {representation!r}; known: "
                f"{', '.join(PLACES)}"
            ) from None
        store = cls.choose_store(plan, store)
        self.sensor = Sensor(
            representation,
            cls.roles,
            n_nodes,
            store=store,
            max_tiles=cls.max_tiles(plan, store),
            noise=noise,
            seed=seed,
            size=size,
            observers=observers,
        )
        self.places = cls(self.sensor, params)
        self.representation = representation
        self.params, self.plan = params, plan
        with self.sensor.stage("setup"):
            self.places.setup_masks()
            self.sensor.valid_roots()
        # the weights' scale under the array's transfer gain, calibrated on the array once
        # where the schedule's weights live through many writes (mod:`ppaloc.onsensor.gain`)
        log_gain = gain.calibrate(self.sensor) if plan.keep_scale else 0.0
        self.state = WeightState(gain.WeightScale(log_gain))
        self.planes = MotionPlanes()
        self.reset()

    # ------------------------------------------------------------------ the sensor
    @property
    def sim(self) -> Scamp5:
        """The simulator."""
        return self.sensor.sim

    @property
    def timing(self) -> TimingModel:
        """The simulator's timing model: modelled time and energy, by stage."""
        return self.sensor.sim.timing

    @property
    def layout(self) -> SnakeLayout:
        """The map's snake layout."""
        return self.sensor.layout

    @property
    def store(self) -> str:
        """How the map is held."""
        return self.sensor.store

    @property
    def n_nodes(self) -> int:
        """Nodes of the map on this sensor."""
        return self.sensor.n_nodes

    @property
    def tiles(self) -> int:
        """Tiles the map takes."""
        return self.sensor.tiles

    @property
    def capacity(self) -> int:
        """Nodes this sensor holds with its store."""
        return self.sensor.capacity

    def set_nodes(self, n_nodes: int) -> None:
        """Hold a map of ``n_nodes`` nodes from now on (after a keyframe mapping run).

        Recomputes the tiles and the valid roots (stage ``"setup"``) on the same sensor.
        """
        sensor = self.sensor
        sensor.tiles = sensor.tiles_for(int(n_nodes))
        sensor.n_nodes = int(n_nodes)
        sensor.local_plans = {}  # the local term's table was of the old size
        with sensor.stage("setup"):
            sensor.valid_roots()
        sensor.node_grid()

    def reset(self) -> None:
        """Zero the weights, forget the previous frame, estimate and pending work."""
        with self.sensor.stage("reset"):
            self.sensor.run(_res, self.sensor.roles.weights)
        self.state.reset()
        self.planes.forget()
        self.places.reset()
        self.frames = 0

    # ------------------------------------------------------------------ the steps
    def begin(self, frame: np.ndarray) -> None:
        """Refresh the map store where it needs it, capture, block means."""
        self.frames += 1
        self.places.refresh(self.frames)
        self.capture(frame)

    def capture(self, frame: np.ndarray) -> None:
        """Capture ``frame`` and reduce it to block means (spread where the comparison or
        the image motion test needs them), without counting a frame."""
        capture(self.sensor, frame)
        image = self.params.motion == "image"
        self._block_means(self.plan.spread if self.places.spread_means or image else None)

    def _block_means(self, spread: str | None) -> None:
        """The block means (spread as asked), and a finer live grid's codes read out
        (:func:`ppaloc.onsensor.capture.block_means`) where the representation has one."""
        codes = block_means(self.sensor, spread, self.places.grid)
        if codes is not None:
            self.places.grid_codes = codes

    def motion(self, decided: bool | None) -> bool:
        """``decided`` when given (the controller's), else the sensor's own test: the
        image motion stage, or forward on every frame but the first."""
        if decided is not None:
            return decided
        if self.params.motion == "always_forward":
            return self.frames != 1
        if self.params.motion != "image":
            raise AssertionError(f"motion={self.params.motion!r}: the controller decides")
        return image_motion(self.sensor, self.planes, self.params)

    def transition(self, costs: tuple[int, ...], carried: bool = False) -> None:
        """Robust: :func:`ppaloc.onsensor.transition.transition` (``carried``: on a bank's
        later sensor, the previous sensor's weights enter node 0), each weight then
        flowing along its run on a map with runs (:mod:`ppaloc.onsensor.runs`)."""
        memory = int(self.params.memory)  # type: ignore[arg-type]
        transition(self.sensor, self.state, memory, costs, carried, runs=True)

    def node_values(self) -> np.ndarray:
        """Robust: the live frame in place, then every node's ``r_i`` (:mod:`.likelihood`)."""
        self.places.prepare_live()
        return likelihood.node_values(self.sensor, self.places)

    def minimum(self, values: np.ndarray) -> float:
        """Robust: the frame's best distance (the representation's
        :meth:`~ppaloc.onsensor.places.Places.minimum`: refined on the array for low-res
        images, the least readout for descriptors)."""
        return self.places.minimum(values)

    def _normalised(self) -> None:
        """Apply a normalisation still pending (a schedule whose frame has no transition
        to carry it): the transition that stays on every node for free."""
        if self.state.pending_top is not None:
            memory = int(self.params.memory)  # type: ignore[arg-type]
            transition(self.sensor, self.state, memory, (0,))

    def add_scaled(self, shift: int, alpha: float) -> None:
        """Robust: ``w += alpha_t - mu 2**-s`` (:func:`ppaloc.onsensor.likelihood.add_scaled`)."""
        self._normalised()
        if self.params.local_gain and self.sensor.tiles == 1:
            local.keep_values(self.sensor)  # the local term reads them after the update
        likelihood.add_scaled(self.sensor, self.places, self.state, shift, int(alpha))

    def add_local(self, gain: int, window: int) -> None:
        """Robust, ``local_gain`` (:func:`ppaloc.onsensor.local.local_term`)."""
        self.local_term(gain, window)

    def local_term(self, gain: int, window: int, wanted: Collection[int] = ()) -> dict[int, float]:
        """The local term within this sensor; the exact values of the nodes ``wanted``
        (a bank's pairs across its cuts)."""
        return local.local_term(self.sensor, self.places, self.state, gain, window, wanted)

    def local_edges(
        self, gain: int, window: int, own: dict[int, float], others: Sequence[tuple[int, float]]
    ) -> None:
        """The local term across a bank's cuts (:func:`~ppaloc.onsensor.local.local_edges`)."""
        local.local_edges(self.sensor, self.places, self.state, gain, window, own, others)

    def shift(self) -> None:
        """Paper: every weight one node along the snake (``advance = (1, 1)`` only)."""
        self._normalised()
        shift_weights(self.sensor)

    def add_likelihood(self, alpha: float, shift: int) -> None:
        """Paper: the live frame in place, then ``w += alpha - mu 2**-shift`` per tile."""
        self._normalised()
        self.places.prepare_live()
        likelihood.add_paper(self.sensor, self.places, int(alpha), shift)

    def detect(self, prev: int | None, bits: int = 0) -> tuple[int, float]:
        """``(node, T)`` (:func:`ppaloc.onsensor.detect.detect`)."""
        self._normalised()
        return detect.detect(self.sensor, self.state, prev, bits)

    def confidence(self, node: int, top: float, window: tuple[int, int], bits: int = 0) -> float:
        """The refined ``T`` minus the maximum outside the nodes ``window``, each to
        ``2**-bits`` (:func:`ppaloc.onsensor.detect.confidence`)."""
        return detect.confidence(self.sensor, self.state, int(top), *window, bits)

    def weight_reads(self, a: int, b: int) -> list[float]:
        """Nodes ``a .. b``'s weights, a read each (:func:`~.weights.read_roots`)."""
        return list(read_roots(self.sensor, self.state, a, b))

    def rank(self, node: int) -> None:
        """The sensor reports no ranking."""

    def normalise(self, top: float) -> None:
        """Robust: ``w := max(clip(w - T), -memory)``, only remembered: the next frame's
        transition subtracts ``T`` with the copy and the stay candidate it writes anyway
        and applies the floor after its candidates, so the normalisation costs no weight
        write of its own. :meth:`weights` applies a pending normalisation to what it reads.
        """
        self.state.pending_top = int(top)

    def adjust(self, amount: float) -> None:
        """Paper: ``w := clip(w - g)``, ``g`` an integer through the DAC (stage ``"adjust"``)."""
        sensor = self.sensor
        with sensor.stage("adjust"):
            sensor.sim.scamp5_in(sensor.roles.spare, -int(amount))
            sensor.run(_subtract_plane, sensor.roles.weights, sensor.roles.spare)

    # ------------------------------------------------------------------ a bank's exchanges
    def carry_out(self, steps: int) -> list[float]:
        """This sensor's last ``steps`` weights, read exactly (:mod:`ppaloc.onsensor.carry`)."""
        return carry_out(self.sensor, self.state, int(self.params.memory), steps)  # type: ignore[arg-type]

    def carry_in(self, values: Sequence[float]) -> None:
        """The previous sensor's last weights, where this snake's start reads them."""
        carry_in(self.sensor, self.state, list(values))

    def local_top(self) -> int:
        """``floor(max W)`` over this sensor's nodes."""
        return detect.local_top(self.sensor, self.state)

    def outside_fraction(self, out: int, bits: int) -> int:
        """After :meth:`outside_max` found ``out``: the largest ``j < 2**bits`` with a node
        outside its window at ``w >= out + j 2**-bits``
        (:func:`ppaloc.onsensor.detect.outside_fraction`)."""
        return detect.outside_fraction(self.sensor, self.state, out, bits)

    def local_fraction(self, top: int, bits: int) -> int:
        """The largest ``j < 2**bits`` with a node of this sensor at ``w >= top + j
        2**-bits`` (:func:`ppaloc.onsensor.detect.max_fraction`)."""
        return detect.max_fraction(self.sensor, self.state, top, bits)

    def candidates(
        self, top: int, prev: int | None, frac: int = 0, bits: int = 0
    ) -> list[int] | None:
        """This sensor's nodes with ``w >= top + frac 2**-bits``
        (:func:`ppaloc.onsensor.detect.candidates`)."""
        return detect.candidates(self.sensor, self.state, top, prev, frac, bits)

    def outside_max(self, a: int, b: int, top: int) -> int | None:
        """The largest threshold in [-127, top] met by a node outside ``a..b``."""
        return detect.outside_max(self.sensor, self.state, a, b, top)

    # ------------------------------------------------------------------ mapping
    def sense_node(self, frame: np.ndarray) -> Any:
        """Describe one reference frame on the sensor, as the mapping run does.

        Capture, block means, then the representation's description; all charged to
        the stage ``"mapping"``.
        """
        with self.sensor.stage("mapping"):
            capture(self.sensor, frame)
            self._block_means_for_mapping(spread=None)
            return self.places.describe()

    def _block_means_for_mapping(self, spread: bool | None) -> None:
        if spread is None:
            spread = self.places.spread_means or self.params.motion == "image"
        self._block_means(self.plan.spread if spread else None)

    def map_keyframes(self, frames: Sequence[np.ndarray]) -> tuple[list[Any], list[int]]:
        """The keyframe mapping run: ``(nodes, kept)`` over a reference traversal.

        Every frame is captured, reduced and put through the sensor's own image motion
        stage (between consecutive reference frames); a frame becomes a node when it says
        forward, the first frame always (docs/ppa8.md, "The map"; the host's
        :func:`ppaloc.localise.weighted.keyframe_test`). Only kept frames are described.
        All charged to the stage ``"mapping"``; the motion planes are forgotten at the end.
        """
        nodes: list[Any] = []
        kept: list[int] = []
        self.planes.forget()
        for i, frame in enumerate(frames):
            with self.sensor.stage("mapping"):
                capture(self.sensor, frame)
                self._block_means_for_mapping(spread=True)
                moved = image_motion(self.sensor, self.planes, self.params)
                if moved or not kept:
                    nodes.append(self.places.describe())
                    kept.append(i)
        self.planes.forget()
        return nodes, kept

    def map_places(self, frames: Sequence[np.ndarray]) -> tuple[list[Any], list[int]]:
        """The mapping run of a map of every frame with places: ``(nodes, places)``.

        As :meth:`map_keyframes`, but every frame is described and becomes a node; the
        sensor's image motion stage says whether it shows a new place (the first frame
        is place 0; the host's :func:`ppaloc.localise.weighted.place_test`).
        """
        nodes: list[Any] = []
        places: list[int] = []
        self.planes.forget()
        for frame in frames:
            with self.sensor.stage("mapping"):
                capture(self.sensor, frame)
                self._block_means_for_mapping(spread=True)
                moved = image_motion(self.sensor, self.planes, self.params)
                nodes.append(self.places.describe())
                places.append(0 if not places else places[-1] + int(moved))
        self.planes.forget()
        return nodes, places

    def node_blocks(self, topomap: TopoMap) -> np.ndarray:
        """Each node's values on the PEs of its block, as the comparison reads them."""
        return self.places.node_blocks(topomap)

    # ------------------------------------------------------------------ inspection
    @property
    def last_shift(self) -> int | None:
        """Robust: the likelihood shift of the last frame that added a likelihood."""
        return self.state.last_shift

    @property
    def last_alpha(self) -> int | None:
        """Robust: the offset ``alpha_t`` of the last frame that added a likelihood."""
        return self.state.last_alpha

    def weights(self) -> np.ndarray:
        """The weights in map order as the host reports them (an untimed inspection)."""
        return read_weights(self.sensor, self.state, self.params.memory)

    def register_planes(self) -> dict[str, np.ndarray]:
        """The registers worth a picture, labelled ``"NAME: role"`` (untimed reads).

        The map tiles, the weights, the representation's live planes, the motion
        bit-planes of the last frame and the last detection's candidates; the working
        planes are left out, since after a frame they hold whatever the last stage left.
        """
        sim, r = self.sensor.sim, self.sensor.roles
        planes = self.places.map_planes()
        if self.state.negated:
            planes[f"{r.negated.name}: minus the weights"] = sim.read(r.negated)  # type: ignore[union-attr]
        planes[f"{r.weights.name}: weights"] = sim.read(r.weights)  # before a pending step
        planes.update(self.places.live_planes())
        # the kept copies: the local term works in u and d after the motion stage
        planes[f"{r.d.u_prev.name}: motion, above block mean"] = sim.read(r.d.u_prev)
        planes[f"{r.d.d_prev.name}: motion, below block mean"] = sim.read(r.d.d_prev)
        planes[f"{r.d.cand.name}: detection candidates"] = sim.read(r.d.cand)
        return planes


def _res(k: Kernel, w: Register) -> None:
    k.res(w)


def _subtract_plane(k: Kernel, w: Register, minus: Register) -> None:
    k.add(w, w, minus)
