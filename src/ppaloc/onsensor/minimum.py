"""The frame's best distance, refined on the array beyond the readout's resolution.

Stage ``"minimum"`` (robust preset, docs/ppa8.md, item 3). The scaled readout reads each
low-res node's tree value ``-mu/2`` as an ADC code (``code = floor(128.5 - mu/2)``, read
back as ``r = 2 (128 - code)``), so the least distance of the frame is only known to lie
in ``(r - 1, r + 1]`` (``r`` the least readout).
The frame's scale wants it to :data:`~ppaloc.localise.params.MINIMUM_BITS` fraction bits
(:func:`~ppaloc.localise.params.refined_minimum`); the controller finds ``ceil(2**k
mu_min)`` by a binary search of ``k + 1`` ``global_or`` tests, each asking whether a node
has ``mu <= r - 2 + j 2**-k`` (``2**k < j <= 3 2**k``). A test is one kernel over the
tree's value plane, which stays where it is for the update: a DAC integer ``j`` halved
``k + 1`` times in two free planes (``-j 2**-(k+1)``), and ``FLAG := mu/2 - j 2**-(k+1)
- (r - 2)/2 > 0``, the integer part through ``IN``; the candidates are the valid node
roots where FLAG is clear. Exact in ideal mode (every value is a dyadic fraction).
"""

from __future__ import annotations

from ppaloc.localise.params import MINIMUM_BITS
from ppaloc.onsensor.roles import DRegs
from ppaloc.onsensor.sensor import Sensor
from ppaloc.sim import FLAG, IN, NEWS, Kernel, Register

__all__ = ["refine_minimum"]


def refine_minimum(sensor: Sensor, least: int, bits: int = MINIMUM_BITS) -> float:
    """The frame's best distance ``ceil(2**bits mu_min) / 2**bits - 2**-(bits+1)`` from
    the least readout ``least`` (an even integer, ``mu_min`` in ``(least - 1, least + 1]``).

    After the scaled readout, with one tile whose tree values ``-mu/2`` are in ``spare``
    (kept); ``frame`` and ``means`` are the halvings' planes. ``bits + 1`` tests.
    """
    sim, r = sensor.sim, sensor.roles
    halvings = bits + 1
    sign = -1 if halvings % 2 == 0 else 1  # the DAC's j, so the last halving gives -j 2**-h
    steps = 2**bits
    # mu_min > least - 1 = least - 2 + steps / 2**bits: the first step that can hold is
    # steps + 1; the last always holds (mu_min <= least + 1)
    lo, hi = steps + 1, 3 * steps
    with sim.stage("minimum"):
        sensor.allow(False)
        while lo < hi:
            mid = (lo + hi) // 2
            sim.scamp5_in(r.frame, sign * mid)
            sim.load_in(-(int(least) - 2) // 2)
            sensor.run(_at_most, r.d, r.spare, r.frame, r.means, halvings)
            if sim.global_or(r.d.cand):
                hi = mid
            else:
                lo = mid + 1
    return (steps * (int(least) - 2) + lo) / steps - 0.5 / steps


def _at_most(
    k: Kernel, dr: DRegs, value: Register, a: Register, b: Register, halvings: int
) -> None:
    """``cand := (mu <= least - 2 + j 2**-(h-1)) AND valid`` from ``value = -mu/2``, the
    DAC's ``+-j`` in ``a`` and ``-(least - 2)/2`` in ``IN``; ``tmp_a`` holds NOT valid."""
    cur, other = a, b
    for _ in range(halvings):
        k.bus2(other, NEWS, cur)
        cur, other = other, cur
    k.bus(NEWS, value)  # mu/2
    k.where(NEWS, cur, IN)  # FLAG = mu/2 - j 2**-h - (least - 2)/2 > 0
    k.NOR(dr.cand, FLAG, dr.tmp_a)
    k.all()
