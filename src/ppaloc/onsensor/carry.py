"""A bank's carry between sensors: the last weights of one sensor, exactly, into the next.

Stage ``"carry"``. Before a robust transition each sensor of a bank
(:mod:`ppaloc.onsensor.bank`) reads the weights of its last ``max_advance`` nodes exactly
(:func:`carry_out`: five ADC digits each) and the next sensor writes them where its
snake's start reads them instead of the array edge (:func:`carry_in`).
"""

from __future__ import annotations

from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.weights import WeightState
from ppaloc.sim import IN, NEWS, D, E, Kernel, Register

__all__ = ["CARRY_DIGITS", "carry_in", "carry_out", "read_exact", "write_value"]

#: Base-128 digits of a carried value: the integer part and four of seven bits, 28
#: fractional bits (a weight's own resolution is at most 2**-23, docs/ppa8.md).
CARRY_DIGITS = 5


def carry_out(sensor: Sensor, state: WeightState, memory: int, steps: int) -> list[float]:
    """This sensor's last ``steps`` weights for the next sensor of a bank, read exactly.

    Before this sensor's own transition. Each weight is read in :data:`CARRY_DIGITS` ADC
    passes: the code gives the nearest integer ``x``, then ``D := 128 (D - x)`` (one
    ``sub`` with ``x`` in ``IN``, seven doublings) brings the next digit into range
    (``D``, ``E`` are free between the motion stage and the transition). Item ``j`` is
    node ``n - 1 - j``, raised to ``T - memory`` (the pending normalisation's floor: a
    value below it loses anyway) and kept in the weights' range [-127, 127].
    """
    r = sensor.roles
    lowest = (state.pending_top or 0) - int(memory)
    out = []
    with sensor.sim.stage("carry"):
        for j in range(steps):
            row, col = sensor.root_of(sensor.n_nodes - 1 - j)
            src = r.negated if state.negated else r.weights
            total = read_exact(sensor, src, row, col)  # type: ignore[arg-type]
            total = -total if state.negated else total
            # with noise a read can leave the register's range: clip to it
            out.append(min(max(total, lowest, -127.0), 127.0))
    return out


def read_exact(
    sensor: Sensor, src: Register, row: int, col: int, x: Register = D, y: Register = E
) -> float:
    """``src`` at PE ``(row, col)`` to ``2**-28``, in :data:`CARRY_DIGITS` ADC passes.

    The code gives the nearest integer ``d``, then ``x := 128 (x - d)`` (one ``sub`` with
    ``d`` in ``IN``, seven doublings with ``y`` as scratch; ``x`` starts as ``src``) brings
    the next digit into range. ``src`` itself is not written.
    """
    sim = sensor.sim
    total = 0
    for i in range(CARRY_DIGITS):
        d = int(sim.read_areg(src, row, col)) - 128
        total = total * 128 + d
        if i == CARRY_DIGITS - 1:
            break
        sim.load_in(d)
        sensor.run(_next_digit, src, x, y)
        src = x
    return total / 128 ** (CARRY_DIGITS - 1)


def carry_in(sensor: Sensor, state: WeightState, values: list[float]) -> None:
    """Write the previous sensor's last weights where this snake's start reads them.

    Before the transition (``carried=True``): value ``j`` goes into the weight register
    at row 1 of block ``j`` (tile 0's column, a PE that holds no weight), so the
    transition's copy ``S := -(w - T)`` turns it into the parked ``S`` of node ``-1 - j``.
    Each value is built exactly in ``D`` (:func:`write_value`) and copied by one ``bus``
    at that PE.
    """
    sim, r = sensor.sim, sensor.roles
    with sim.stage("carry"):
        reg, sign = (r.negated, -1) if state.negated else (r.weights, 1)
        for j, value in enumerate(values):
            write_value(sensor, sign * value)
            sim.load_point(r.d.pattern, 1, sensor.size - sensor.bw * (j + 1))
            sensor.run(_put, r.d.pattern, reg)


def write_value(sensor: Sensor, value: float) -> None:
    """``D := -value`` in every PE, exactly: DAC digits joined by halvings (``E`` scratch).

    ``value`` (a multiple of ``2**-28`` in [-127, 127]) in balanced base-128 digits ``y_0
    + y_1/128 + ...``: ``D := -y_last``, then per digit seven halvings (each negates;
    ``D``, ``E`` in turn) and ``D := -(E + y)`` with the digit in ``IN``; trailing zero
    digits cost nothing (an integer is one DAC load).
    """
    sim = sensor.sim
    scale = 128 ** (CARRY_DIGITS - 1)
    v = round(value * scale)
    digits = []
    for _ in range(CARRY_DIGITS - 1):
        d = (v + 64) % 128 - 64
        digits.append(d)
        v = (v - d) // 128
    digits.append(v)  # the integer part, first
    digits.reverse()
    while len(digits) > 1 and digits[-1] == 0:
        digits.pop()
    sim.scamp5_in(D, -digits[-1])
    for d in reversed(digits[:-1]):
        sim.load_in(d)
        sensor.run(_join_digit)


def _put(k: Kernel, mask: Register, reg: Register) -> None:
    k.WHERE(mask)
    k.bus(reg, D)
    k.all()


def _join_digit(k: Kernel) -> None:
    """``D := -(D / 128 + IN)`` given ``D = -P`` (seven halvings, ``E`` scratch)."""
    cur, other = D, E
    for _ in range(7):
        k.bus2(other, NEWS, cur)  # other = -cur / 2
        cur, other = other, cur
    k.bus(D, cur, IN)


def _next_digit(k: Kernel, src: Register, x: Register, y: Register) -> None:
    """``x := 128 (src - IN)`` (one ``sub``, seven doublings; ``y`` scratch)."""
    k.sub(x, src, IN)
    for _ in range(7):
        k.mov(y, x)
        k.bus(NEWS, x, y)  # -2x
        k.bus(x, NEWS)
