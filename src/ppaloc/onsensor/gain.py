"""The weights' scale under the array's transfer gain: calibrated once, restored in steps.

Every analogue write of a ``bus`` copies a current, and the copy carries a gain error
``g`` proportional to the signal (``sim.noise``: ``transfer_gain``; a few tenths of a
percent on SCAMP-5, docs/sim.md). The robust weights take four such writes per forward
frame (the transition's copy and take, or its stay subtraction; the update's two), so
without care they are scaled by about ``(1 + g) ** 4`` every frame: exponential forgetting
of the evidence, which the filter's long memory does not survive (``g = -0.2%`` is a
factor of 0.992 per frame, and the host's own filter with that forgetting loses 0.84 ->
0.73 max F1 on Nordland; docs/onsensor.md, "The weights' scale").

The controller corrects it as a PPA program would, from the chip itself:

1. at start-up (:func:`calibrate`, stage ``"calibrate"``) it loads a DAC level into
   ``D``, copies it :data:`CALIBRATION_WRITES` times between ``D`` and ``E`` in one kernel
   and reads the mean back by ``scan_areg_mean_8x8``, :data:`CALIBRATION_CHAINS` times:
   the log gain per write, averaged over the whole array (the fixed-pattern offsets and
   the temporal noise average out);
2. the pipeline counts the writes its weight path issues (:meth:`WeightScale.charge`);
3. when the weights have drifted by one :data:`RESTORE_STEP` (``1/16``) they are scaled
   back by ``1 +- 1/16`` at the node roots (:func:`restore`: four halvings and one ``add``,
   about every eight frames at ``g = -0.2%``).

In ideal mode the calibration reads exactly its level, the log gain is 0 and nothing is
ever restored: the weights stay the host's bit for bit.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from ppaloc.sim import NEWS, D, E, Kernel, Register

if TYPE_CHECKING:  # the sensor imports nothing of this module; only the types are needed
    from ppaloc.onsensor.sensor import Sensor

__all__ = [
    "CALIBRATION_CHAINS",
    "CALIBRATION_LEVEL",
    "CALIBRATION_WRITES",
    "RESTORE_STEP",
    "RESTORE_WRITES",
    "WeightScale",
    "calibrate",
    "restore",
]

#: The DAC level the calibration copies: room for the chain's gain either way (a gain of
#: up to +0.5% per write keeps it below 127, and -3% above 1) and for the chain's
#: fixed-pattern walk (about 22 units per PE after the chain, averaged out in the mean).
CALIBRATION_LEVEL = 64
#: ``bus`` copies in one calibration chain (an even number: the value keeps its sign). At
#: ``g = -0.2%`` they take 64 to 49.5; the ADC's rounding of the mean (at most half a code)
#: is then up to 4% of ``g`` (less when the readout noise dithers it).
CALIBRATION_WRITES = 128
#: Chains measured and averaged: the per-instruction spread of the gain (sd 0.2% each)
#: averages to 4.5% of ``g`` over 512 writes (one chain of 512 would saturate sooner).
CALIBRATION_CHAINS = 4
#: The restoration's step, as a power of two: the weights are scaled by ``1 + 2**-k``
#: (four halvings, ``k = 4``) once they have drifted by that factor. A larger step is rarer
#: and its halvings' noise is spread over more frames; the scale wanders by up to the step
#: in between (docs/onsensor.md gives F1 for ``k`` = 3, 4, 5).
RESTORE_STEP = 4


def calibrate(pipe: Sensor) -> float:
    """The array's mean log transfer gain per ``bus`` write, measured on the array.

    Per chain (:data:`CALIBRATION_CHAINS`): ``D := CALIBRATION_LEVEL`` (the DAC),
    :data:`CALIBRATION_WRITES` copies ``E := -D``, ``D := -E`` in one kernel, then the 64
    block means of ``D`` by the ADC. Returns the mean of ``log(mean / level) / writes``.
    Uses ``D``, ``E`` and ``NEWS`` (free at start-up); stage ``"calibrate"``.
    """
    sim = pipe.sim
    logs = []
    with sim.stage("calibrate"):
        pipe.run(_all)
        for _ in range(CALIBRATION_CHAINS):
            sim.scamp5_in(D, CALIBRATION_LEVEL)
            pipe.run(_chain)
            mean = float(sim.scan_areg_mean_8x8(D).astype(np.float64).mean()) - 128.0
            if mean <= 0:  # a gain beyond any SCAMP-5's: nothing sensible to correct
                return 0.0
            logs.append(math.log(mean / CALIBRATION_LEVEL))  # code = floor(mean + 128.5)
    return float(np.mean(logs)) / CALIBRATION_WRITES


def _all(k: Kernel) -> None:
    k.all()


def _chain(k: Kernel) -> None:
    # a start-up kernel of 128 ICWs: kept off the shared 1024-ICW stack, which the
    # frame's kernels need (a map of every frame in Haar signs on a bank fills it)
    k.move_to_heap(True)
    for _ in range(CALIBRATION_WRITES // 2):
        k.bus(E, D)
        k.bus(D, E)


class WeightScale:
    """The controller's estimate of the weights' scale (its log), and when to restore it.

    Parameters
    ----------
    log_gain : float
        The calibrated log gain per write (:func:`calibrate`; 0 in ideal mode).
    step : int
        :data:`RESTORE_STEP`.
    """

    def __init__(self, log_gain: float, step: int = RESTORE_STEP) -> None:
        self.log_gain = float(log_gain)
        self.step = int(step)
        self.log_scale = 0.0
        self.restores = 0

    def reset(self) -> None:
        """New weights (all zero): their scale is exact again."""
        self.log_scale = 0.0

    def charge(self, writes: int) -> None:
        """``writes`` more ``bus`` writes on every weight."""
        self.log_scale += writes * self.log_gain

    def due(self) -> int:
        """+1: expand by ``1 + 2**-step`` now; -1: shrink by ``1 - 2**-step``; 0: not yet."""
        if self.log_gain == 0.0:
            return 0
        if self.log_scale <= -math.log1p(2.0**-self.step):
            return 1
        if self.log_scale >= -math.log1p(-(2.0**-self.step)):
            return -1
        return 0

    def restored(self, sign: int, writes: int) -> None:
        """A restoration by ``1 + sign 2**-step`` taking ``writes`` writes was issued."""
        self.log_scale += math.log1p(sign * 2.0**-self.step) + writes * self.log_gain
        self.restores += 1


#: ``bus`` writes one :func:`restore` issues on the weights themselves (``NEWS``, then the
#: weight register); the halvings write only the correction term.
RESTORE_WRITES = 2


def restore(pipe: Sensor, reg: Register, mask: Register, sign: int, step: int) -> None:
    """``reg := reg (1 + sign 2**-step)`` where ``mask`` is set (the node roots).

    ``step`` halvings alternate between ``D`` and ``E`` (each ``bus2`` negates, so the
    term's sign follows the parity; one more copy fixes it when it is wrong), then
    ``NEWS := -(reg + term)``, ``reg := -NEWS``: two writes on the weights. ``D``, ``E``
    and ``NEWS`` must be free (the end of the robust transition).
    """
    pipe.run(_restore, reg, mask, sign, step)


def _restore(k: Kernel, reg: Register, mask: Register, sign: int, step: int) -> None:
    k.WHERE(mask)
    cur, other = reg, D
    for _ in range(step):
        k.bus2(other, NEWS, cur)  # other = -cur / 2
        cur, other = other, (E if other is D else D)
    # cur = (-1)**step reg 2**-step; the term must be sign reg 2**-step
    if (-1) ** step != sign:
        k.bus(other, cur)
        cur = other
    k.bus(NEWS, reg, cur)
    k.bus(reg, NEWS)
    k.all()
