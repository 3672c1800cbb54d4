"""The image motion test on the sensor (docs/ppa8.md, "Per frame", item 1).

Stage ``"motion"``. Each pixel of the captured frame is compared with its block's exact
mean (``spare := v - m``) with a dead zone of ``motion_margin`` units through the DAC;
two bit-planes (clearly above ``U``, clearly below ``D``) are kept from one frame to the
next, the crossings ``(U_prev & D) | (D_prev & U)`` and the textured pixels ``U | D`` are
counted exactly on the array (:func:`count`) and the controller decides with the host's
:func:`ppaloc.localise.motion.forward_decision`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ppaloc.localise.motion import forward_decision
from ppaloc.localise.params import FilterParams
from ppaloc.onsensor.program import add_level, pull, tree_levels
from ppaloc.onsensor.roles import DRegs
from ppaloc.onsensor.sensor import Sensor
from ppaloc.sim import FLAG, NEWS, Kernel, Register, east

__all__ = ["MotionPlanes", "count", "image_motion"]


@dataclass
class MotionPlanes:
    """What the controller remembers of the motion test between frames.

    Attributes
    ----------
    have_prev : bool
        Whether the previous frame's planes are in ``d.u_prev`` and ``d.d_prev``.
    last_counts : (int, int) or None
        The last decision's ``(changed, support)``.
    """

    have_prev: bool = False
    last_counts: tuple[int, int] | None = None

    def forget(self) -> None:
        """No previous planes (a new query or a new traversal)."""
        self.have_prev = False
        self.last_counts = None


def image_motion(sensor: Sensor, memory: MotionPlanes, params: FilterParams) -> bool:
    """The image motion test on the captured frame (after the spread block means).

    The first call after :meth:`MotionPlanes.forget` only keeps the planes (stay). Used
    per query frame by the image model and per reference frame by the keyframe mapping
    run.
    """
    sim, r = sensor.sim, sensor.roles
    dr = r.d
    with sim.stage("motion"):
        sensor.run(_diff, r.spare, r.frame, r.means)  # spare = v - m
        sim.scamp5_in(r.frame, -params.motion_margin)
        sensor.run(_planes, dr, r.spare, r.frame)
        if not memory.have_prev:
            sensor.run(_keep, dr)
            memory.have_prev = True
            memory.last_counts = None
            return False
        sensor.run(_logic, dr)
        changed = count(sensor, dr.tmp_b)
        support = count(sensor, dr.tmp_a)
    memory.last_counts = (changed, support)
    return forward_decision(
        changed, support, shift=params.motion_shift, min_support=params.motion_min_support
    )


def _diff(k: Kernel, out: Register, frame: Register, means: Register) -> None:
    k.add(out, frame, means)


def _planes(k: Kernel, dr: DRegs, diff: Register, margin: Register) -> None:
    k.where(diff, margin)
    k.MOV(dr.u, FLAG)
    k.all()
    k.bus(NEWS, diff)
    k.where(NEWS, margin)
    k.MOV(dr.d, FLAG)
    k.all()


def _keep(k: Kernel, dr: DRegs) -> None:
    k.MOV(dr.u_prev, dr.u)
    k.MOV(dr.d_prev, dr.d)


def _logic(k: Kernel, dr: DRegs) -> None:
    k.AND(dr.cand, dr.u_prev, dr.d)
    k.AND(dr.tmp_a, dr.d_prev, dr.u)
    k.OR(dr.tmp_b, dr.cand, dr.tmp_a)  # changed
    k.OR(dr.tmp_a, dr.u, dr.d)  # support
    _keep(k, dr)


def count(sensor: Sensor, dreg: Register) -> int:
    """Exact number of 1s of ``dreg``: 8x16 in-array sums read by the ADC, added up.

    ``global_count`` is an estimate on SCAMP-5; the motion decision needs exact counts,
    so each 8x8 block is summed by an adding tree (values 0/1, sums <= 64), pairs of
    blocks are added into ``NEWS`` as ``-(sum) >= -128`` and the controller adds the 512
    ADC codes.
    """
    sim, r = sensor.sim, sensor.roles
    sim.scamp5_in(r.frame, 1)
    sensor.run(_count, dreg, r.spare, r.frame)
    codes = sim.scan_areg(NEWS, 0, 0, sensor.size - 1, sensor.size - 1, 8, 16)
    return int((128 - codes.astype(np.int64)).sum())


def _count(k: Kernel, dreg: Register, acc: Register, one: Register) -> None:
    k.res(acc)
    k.WHERE(dreg)
    k.mov(acc, one)
    k.all()
    tree_levels(k, add_level, acc, one, (1, 2, 4), (1, 2, 4))
    pull(k, one, acc, east, 8)
    k.bus(NEWS, acc, one)
