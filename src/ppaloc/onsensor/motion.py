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
from functools import cache

import numpy as np

from ppaloc.localise.motion import MotionCounts, counted_decision
from ppaloc.localise.params import FilterParams
from ppaloc.onsensor.program import add_level, pull, tree_levels
from ppaloc.onsensor.roles import DRegs, Roles
from ppaloc.onsensor.sensor import Sensor
from ppaloc.sim import FLAG, NEWS, R1, R2, R3, R4, Kernel, Register, east, north, south, west

__all__ = ["MotionPlanes", "count", "image_motion"]


@dataclass
class MotionPlanes:
    """What the controller remembers of the motion test between frames.

    Attributes
    ----------
    have_prev : bool
        Whether the previous frame's planes are in ``d.u_prev`` and ``d.d_prev``.
    last_counts : MotionCounts or None
        The counts the last decision read (the host's
        :func:`ppaloc.localise.motion.counted_decision`).
    """

    have_prev: bool = False
    last_counts: MotionCounts | None = None

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
        crossings = dr.tmp_b  # where the crossings are when they are counted

        def coherent() -> int:
            nonlocal crossings
            source, neighbours, saves = _coherent_plan(sensor.roles)
            sensor.run(_coherent, dr, source, neighbours, saves)
            crossings = source
            return count(sensor, neighbours)

        moved, memory.last_counts = counted_decision(
            lambda: count(sensor, crossings),
            lambda: count(sensor, dr.tmp_a),
            coherent,
            shift=params.motion_shift,
            min_support=params.motion_min_support,
            coherent_shift=params.motion_coherent_shift,
        )
    return moved


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


#: The digital registers ``DNEWS`` overwrites with its direction first.
_SELECTORS = (R1, R2, R3, R4)


@cache
def _coherent_plan(roles: Roles) -> tuple[Register, Register, tuple]:
    """``(source, neighbours, saves)`` of :func:`_coherent` for a pipeline's roles (the
    same on every frame: worked out once).

    ``DNEWS`` writes its direction into R1-R4 first, where some roles keep their planes
    from frame to frame (the valid node roots; the 8x8 pipeline's class masks) and
    ``tmp_b`` may hold the crossings. Once :func:`_logic` has run and ``support`` is
    counted, ``u`` and ``d`` (copied to ``u_prev``, ``d_prev``), ``cand`` and ``tmp_a``
    are free: the crossings move to one of them if they sit in R1-R4 (``source``, where
    they stay to be counted), the coherent crossings are written to the next
    (``neighbours``), and each kept plane in R1-R4 waits in one more (``saves``:
    ``(kept, slot)`` pairs). ``pattern`` and ``root32`` are working roles, loaded again
    before their next use.
    """
    dr = roles.d
    free = [r for r in (dr.u, dr.d, dr.cand, dr.tmp_a) if r not in _SELECTORS]
    kept = sorted({r for _, r in roles.kept() if r in _SELECTORS}, key=lambda r: r.index)
    source = dr.tmp_b if dr.tmp_b not in _SELECTORS else free.pop(0)
    if len(free) < 1 + len(kept):
        raise AssertionError(
            f"the coherent count needs {1 + len(kept)} free digital registers besides the "
            f"crossings' and has {len(free)}"
        )
    neighbours = free.pop(0)
    return source, neighbours, tuple(zip(kept, free, strict=False))


def _coherent(k: Kernel, dr: DRegs, source: Register, neighbours: Register, saves: tuple) -> None:
    """``neighbours := source AND the OR of its four neighbours`` (nothing beyond the
    edge), the crossings (``tmp_b``) in ``source``; the planes kept in R1-R4 wait in
    free registers meanwhile (:func:`_coherent_plan`)."""
    if source != dr.tmp_b:
        k.MOV(source, dr.tmp_b)
    for kept, slot in saves:
        k.MOV(slot, kept)
    k.DNEWS(neighbours, source, north | east | south | west)
    k.AND(neighbours, source, neighbours)
    for kept, slot in saves:
        k.MOV(kept, slot)


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
