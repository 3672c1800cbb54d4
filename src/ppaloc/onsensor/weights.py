"""The weights on the sensor between stages: what the controller still owes them.

The robust frame defers work from one stage to the next so that a weight is written as
few times as possible (docs/onsensor.md, "The robust weights"): the normalisation waits
for the next transition, the update may leave minus the weights in a free register, and
the transition may leave its stay cost to the next update. :class:`WeightState` is the
controller's record of that; :func:`read_weights` applies it to what an untimed read
of the register shows, so the weights reported are the host's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ppaloc.onsensor import gain
from ppaloc.onsensor.sensor import Sensor
from ppaloc.sim import Kernel, Register

__all__ = ["WeightState", "read_roots", "read_weights"]


@dataclass
class WeightState:
    """The controller's record of the weights' deferred work.

    Attributes
    ----------
    scale : gain.WeightScale
        The weights' scale under the array's transfer gain (:mod:`ppaloc.onsensor.gain`).
    pending_top : int or None
        Robust: the threshold ``T`` whose normalisation the next transition applies (None:
        none pending; the transition then normalises with ``T = 0``).
    negated : bool
        Robust, with a ``negated`` role: the weights are minus that register (the last
        update's one write) instead of ``weights``.
    pending_offset : int
        Robust: the stay cost ``c_0`` the next update still subtracts.
    last_shift, last_alpha : int or None
        Robust: the likelihood shift ``s`` and offset ``alpha_t`` of the last frame that
        added a likelihood (None before one).
    top_fraction : int
        The fraction ``j`` of the last detection's refined threshold ``T + j 2**-bits``
        (0 without fraction bits), which the confidence starts from.
    last_top, last_gap : int or None
        The last detection's ``T`` and the last confidence's ``T`` minus the outside
        maximum (None before one): where the next frame's threshold searches start
        (:func:`ppaloc.onsensor.detect.largest_met`). Consecutive frames' values are
        close, so a search from them takes a few ``global_or`` tests instead of a
        bisection of the whole range; the values found are the same.
    """

    scale: gain.WeightScale
    pending_top: int | None = None
    negated: bool = False
    pending_offset: int = 0
    last_shift: int | None = None
    last_alpha: int | None = None
    top_fraction: int = 0
    last_top: int | None = None
    last_gap: int | None = None

    def reset(self) -> None:
        """New weights (all zero): nothing pending, the scale exact."""
        self.scale.reset()
        self.pending_top = None
        self.negated = False
        self.pending_offset = 0
        self.last_shift = None
        self.last_alpha = None
        self.top_fraction = 0
        self.last_top = None
        self.last_gap = None


def read_weights(sensor: Sensor, state: WeightState, memory: int | None) -> np.ndarray:
    """The weights in map order, read from the register (inspection, untimed), with what
    the controller still owes them applied (the stay cost, the normalisation)."""
    r = sensor.roles
    plane = -sensor.sim.read(r.negated) if state.negated else sensor.sim.read(r.weights)
    nodes = np.arange(sensor.n_nodes)
    tile, br, bc = sensor.layout.node_to_block(nodes)
    w = plane[br * sensor.bh, bc * sensor.bw + tile].astype(np.float64)
    if state.pending_offset:
        w = np.clip(w - state.pending_offset, -127, 127)
    if state.pending_top is not None:
        w = np.maximum(np.clip(w - state.pending_top, -127, 127), -memory)  # type: ignore[operator]
    return w


def read_roots(sensor: Sensor, state: WeightState, a: int, b: int) -> list[int]:
    """The weights of nodes ``a .. b`` (this sensor's numbers), one ADC read each at the
    node's root: the nearest integer, halves up, as ``ppa8`` reads them
    (:func:`~ppaloc.localise.params.weight_read`). Stage ``"estimate"``.

    After the detection (nothing pending). Where the register holds minus the weights,
    one ``bus`` copies them into ``spare`` first: a read of minus a weight rounds its
    halves the other way.
    """
    assert state.pending_top is None and not state.pending_offset, "read after detect"
    sim, r = sensor.sim, sensor.roles
    with sensor.stage("estimate"):
        src = r.weights
        if state.negated:
            sensor.run(_negate, r.spare, r.negated)
            src = r.spare
        return [int(sim.read_areg(src, *sensor.root_of(i))) - 128 for i in range(a, b + 1)]


def _negate(k: Kernel, out: Register, src: Register) -> None:
    k.bus(out, src)
