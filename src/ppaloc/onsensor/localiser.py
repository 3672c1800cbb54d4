"""``OnSensorLocaliser``: the weighted-node filter run as PPA programs on the simulator.

It implements :class:`ppaloc.localise.base.Localiser`, so evaluation treats it like any
other method. The map lives in the simulated sensor's registers (written by
:func:`ppaloc.onsensor.mapping.upload_map`), and every frame runs the pipeline of
:func:`ppaloc.onsensor.pipeline.make_pipeline`. In ideal mode the estimates equal those
of ``WeightedNodeLocaliser(arithmetic="ppa8")`` with the same parameters (docs/ppa8.md,
docs/onsensor.md); with a noise preset they show what the analogue array does to them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.localise.base import Estimate
from ppaloc.localise.motion import ImageMotion, OracleMotion
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor.mapping import upload_map
from ppaloc.onsensor.pipeline import PipelineParams, SensorPipeline, make_pipeline
from ppaloc.sim import NoiseParams
from ppaloc.topomap import TopoMap

__all__ = ["NOISE_PRESETS", "OnSensorLocaliser"]

NOISE_PRESETS = ("ideal", "low", "typical", "high")


class OnSensorLocaliser:
    """The paper's system on a simulated SCAMP-5: map in registers, filter as PPA programs.

    Parameters
    ----------
    representation : {"lowres", "lbp"}
        8x8 images in an analogue register (8x8 PEs per node, 1024 per tile) or 32-bit
        LBP descriptors in a digital register (4x8 PEs per node, 2048 per tile).
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
    **filter_params
        The filter's parameters, with the defaults and checks of
        :class:`ppaloc.localise.weighted.WeightedNodeLocaliser`: ``alpha``, ``gamma``,
        ``k``, ``shift``, ``motion``, ``confidence_radius``, ``oracle_moves``,
        ``motion_margin``, ``motion_shift``, ``motion_min_support``; ``ranking_k`` is
        accepted but the sensor reports no ranking; ``advance`` must be (1, 1).

    Notes
    -----
    ``score`` is the integer detection threshold ``T = floor(max W)`` minus the same
    threshold outside nodes ``node - R .. node + R``, both found by ``global_or`` searches
    (the host reports the unrounded difference). ``weights`` (with ``record_weights``)
    are read from the weight register as an untimed inspection.
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
        **filter_params: Any,
    ) -> None:
        if not isinstance(noise, NoiseParams) and noise not in NOISE_PRESETS:
            raise PpalocError(
                f"noise={noise!r} is not one of {', '.join(NOISE_PRESETS)} or a "
                "ppaloc.sim.NoiseParams"
            )
        if arithmetic != "ppa8":
            raise PpalocError(
                f"arithmetic={arithmetic!r}: the sensor computes in register arithmetic; "
                "use arithmetic='ppa8' (or the host WeightedNodeLocaliser for 'float')"
            )
        if tuple(filter_params.get("advance", (1, 1))) != (1, 1):
            raise PpalocError(
                f"advance={filter_params['advance']!r}: the sensor shifts weights by exactly "
                "one node per forward move (the paper's motion model); use advance=(1, 1)"
            )
        # The host filter validates every shared parameter (with the same defaults) and
        # chooses alpha from the map; the sensor reads its settings from it.
        try:
            self._host = WeightedNodeLocaliser(representation, arithmetic="ppa8", **filter_params)
        except TypeError as exc:
            raise PpalocError(f"OnSensorLocaliser: {exc}") from exc
        if self._host.shift > 8:
            raise PpalocError(f"shift={self._host.shift} is too large for the sensor; use 0..8")
        self.representation = representation
        self.noise = noise
        self.seed = int(seed)
        self.size = int(size)
        self.record_weights = bool(record_weights)
        self.motion = self._host.motion
        # the oracle's moves are the controller's input; the host has checked them
        moves = filter_params.get("oracle_moves")
        self._oracle = OracleMotion(moves) if self.motion == "oracle" else None
        self.name = f"onsensor-{representation}"
        self.topomap: TopoMap | None = None
        self.pipeline: SensorPipeline | None = None

    @property
    def alpha(self) -> float | None:
        """The likelihood offset in use (chosen from the map when not given)."""
        return self._host.alpha

    # -- map ---------------------------------------------------------------------------
    def build_map(self, frames: Iterable[np.ndarray]) -> TopoMap:
        """Map a reference traversal on the sensor (one node per frame) and write the map.

        Every frame is captured and described by the sensor itself
        (:meth:`SensorPipeline.sense_node`: the block means read through the ADC, or the
        descriptor compared on the array), so with noise the map carries the same
        fixed-pattern errors as the queries; in ideal mode the nodes equal
        :func:`ppaloc.topomap.build_topomap`'s. The nodes are then written into the
        database registers (:func:`ppaloc.onsensor.mapping.upload_map`).
        """
        frames = list(frames)
        if not frames:
            raise PpalocError("the reference traversal is empty: a map needs at least one frame")
        for frame in frames:
            self._check_frame(frame)
        pipe = self._new_pipeline(len(frames))
        nodes = [pipe.sense_node(np.asarray(f)) for f in frames]
        dtype = np.uint32 if self.representation == "lbp" else np.uint8
        topomap = TopoMap(
            self.representation,
            np.asarray(nodes, dtype=dtype),
            params={
                "kind": self.representation,
                "keyframe_threshold": None,
                "keyframe_units": None,
                "n_frames": len(frames),
                "mapped_on": f"simulated SCAMP-5, noise={self._noise_name()}",
            },
        )
        self._install(topomap, pipe)
        return topomap

    def use_map(self, topomap: TopoMap) -> None:
        """Write ``topomap`` (e.g. loaded from a file) into a fresh simulated sensor."""
        if topomap.kind != self.representation:
            self._host.use_map(topomap)  # raises the host's clear error
        self._install(topomap, self._new_pipeline(len(topomap)))

    def _noise_name(self) -> str:
        return self.noise if isinstance(self.noise, str) else "custom"

    def _new_pipeline(self, n_nodes: int) -> SensorPipeline:
        h = self._host
        # the oracle's decisions come from the controller: the array runs always_forward
        motion: dict[str, Any] = {"motion": "always_forward"}
        if isinstance(m := h.motion_model, ImageMotion):
            motion = {
                "motion": "image",
                "margin": m.margin,
                "motion_shift": m.shift,
                "min_support": m.min_support,
            }
        params = PipelineParams(
            alpha=0,  # set in _install, once the map is known
            gamma=h.gamma,
            k=h.k,
            shift=h.shift,
            confidence_radius=h.confidence_radius,
            **motion,
        )
        return make_pipeline(
            self.representation,
            n_nodes,
            params,
            noise=self.noise,
            seed=self.seed,
            size=self.size,
        )

    def _install(self, topomap: TopoMap, pipe: SensorPipeline) -> None:
        self._host.use_map(topomap)  # checks the map and chooses alpha from it
        pipe.params = dataclasses.replace(pipe.params, alpha=int(self._host.alpha))
        upload_map(pipe, topomap)
        self.pipeline = pipe
        self.topomap = topomap
        self.reset()

    def _check_frame(self, frame: np.ndarray) -> None:
        frame = np.asarray(frame)
        if frame.dtype != np.uint8 or frame.shape != (self.size, self.size):
            raise PpalocError(
                f"a sensor frame must be uint8 of shape ({self.size}, {self.size}), got "
                f"{frame.dtype} {frame.shape}: convert frames with ppaloc.datasets.to_sensor"
            )

    # -- per query ---------------------------------------------------------------------
    def reset(self) -> None:
        """Zero the weight register and forget the previous frame (the map stays)."""
        if self.pipeline is not None:
            self.pipeline.reset()
        if self._oracle is not None:
            self._oracle.reset()

    def step(self, frame: np.ndarray) -> Estimate:
        """Localise one sensor frame ((size, size) uint8) on the simulated sensor."""
        pipe = self.pipeline
        if pipe is None:
            raise PpalocError("no map: call build_map(frames) or use_map(topomap) first")
        frame = np.asarray(frame)
        self._check_frame(frame)
        moved = None if self._oracle is None else self._oracle.step(frame)
        timing = pipe.sim.timing
        t0, e0 = timing.now_us, timing.energy_uj
        node, score, moved, _ = pipe.step(frame, moved)
        weights = pipe.weights() if self.record_weights else None
        return Estimate(
            node=int(node),
            score=float(score),
            moved=moved,
            ranking=None,
            weights=weights,
            modelled_latency_ms=(timing.now_us - t0) / 1000.0,
            energy_mj=(timing.energy_uj - e0) / 1000.0,
        )

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
