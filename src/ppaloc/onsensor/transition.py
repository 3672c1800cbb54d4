"""The robust transition on the sensor (docs/ppa8.md, robust preset, items 5 and 2).

Stages ``"transition"``, ``"restore"`` and ``"normalise"``: the last frame's
normalisation, then ``w_i := clip(max_d (w_{i-d} - c_d))``, the weights' scale restored
when the transfer gain has drifted it a step, and the floor.
"""

from __future__ import annotations

from ppaloc.onsensor import gain
from ppaloc.onsensor.runs import running_max
from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.snake import park, snake_masks, snake_step
from ppaloc.onsensor.weights import WeightState
from ppaloc.sim import IN, NEWS, Kernel, Register

__all__ = ["floor", "settle", "subtract", "take_candidate", "transition"]


def transition(
    sensor: Sensor,
    state: WeightState,
    memory: int,
    costs: tuple[int, ...],
    carried: bool = False,
    runs: bool = False,
) -> None:
    """The last frame's normalisation, then ``w_i := clip(max_d (w_{i-d} - c_d))``.

    The normalisation of the last frame (``n := max(clip(w - T), -memory)``; the
    executor's ``normalise`` keeps ``T``) writes no weight of its own: ``S``
    (``shifted``) starts as ``-(w - T)`` (one ``bus`` with ``-T`` in ``IN``) and moves one
    node along the snake per ``d`` (:func:`~ppaloc.onsensor.snake.snake_step`, with
    ``+memory`` and the tile carry parked first, :func:`~ppaloc.onsensor.snake.park`);
    the stay candidate is ``w := clip(w - (T + c_0))`` in place (one ``add``; nothing
    when ``T + c_0 = 0``); every other candidate is taken in place by
    :func:`take_candidate`, which writes a weight only where its candidate wins (a
    hypothesis moving one node takes three analogue writes: copy, shift, take). Stage
    ``"normalise"``: the floor last, ``w := max(w, max(-memory - min c, -127))``
    (:func:`floor`). Exact: a candidate from a node below the floor, the array edge
    (``-memory - c_d``, for every ``d``, also ``d >= N``) and any clip at -127 are at most
    the floor, and no candidate reaches the top clip (``w - T < 1``). On a bank's later
    sensor (``carried``) the previous sensor's last weights, written by
    :func:`ppaloc.onsensor.carry.carry_in`, enter node 0 instead of the edge. With
    ``runs``, on a map with runs of one place, each weight then flows along its run
    (:func:`ppaloc.onsensor.runs.running_max`, stage ``"runs"``).
    """
    sim, r = sensor.sim, sensor.roles
    w, s, x = r.weights, r.shifted, r.spare
    top = state.pending_top or 0
    steps = len(costs) - 1 if carried else min(len(costs) - 1, sensor.n_nodes - 1)
    lowest = max(-int(memory) - min(costs), -127)
    negated, neg = state.negated, r.negated
    # from -w (negated): the stay cost waits for the update's write (w + c_0 units)
    offset = int(costs[0]) if negated and 0 < costs[0] <= min(126, 127 - lowest) else 0
    with sim.stage("transition"):
        if negated:  # w := -(negated + T), the normalisation in the one write back
            sim.load_in(int(top))
            sensor.run(_bus2, w, neg, IN)
            state.negated = False
        if steps:
            snake_masks(sensor)
            if top and not negated:
                sim.load_in(-int(top))
                sensor.run(_bus2, s, w, IN)  # S := -(W - T)
            else:
                sensor.run(_bus1, s, w)  # S := -W
            park(sensor, s, x, int(memory), steps, carried)
        stay = int(costs[0]) - offset + (0 if negated else int(top))
        # the bus writes on each candidate's weight: the stay's adds; a move's copy into S
        # and its take (the snake's shifts are controller shifts, no bus)
        writes = [subtract(sensor, w, stay)]
        for d in range(1, steps + 1):
            snake_step(sensor, s, x, d)
            writes.append(1 + take_candidate(sensor, s, x, int(costs[d]) - offset))
    # the weights' scale follows the cheapest candidate's path (the others of a frame
    # take as many, but a free stay; a move into a snake's row start, the first node of
    # each block row, takes a few more copies)
    cheapest = min(range(steps + 1), key=lambda d: costs[d])
    state.scale.charge(int(negated) + writes[cheapest])
    restore_scale(sensor, state)
    state.pending_top = None
    with sim.stage("normalise"):
        floor(sensor, lowest + offset)
    if runs:
        running_max(sensor)
    state.pending_offset = offset


def restore_scale(sensor: Sensor, state: WeightState) -> None:
    """Scale the weights back when the transfer gain has drifted them a step.

    At the end of the transition (``spare``, ``frame`` and ``NEWS`` are free, the weights
    in ``weights``), at the valid node roots only (stage ``"restore"``;
    :mod:`ppaloc.onsensor.gain`).
    """
    sign = state.scale.due()
    if sign:
        with sensor.stage("restore"):
            gain.restore(sensor, sensor.roles.weights, sensor.roles.d.valid, sign, state.scale.step)
        state.scale.restored(sign, gain.RESTORE_WRITES)


def settle(sensor: Sensor, state: WeightState) -> None:
    """Write a stay cost the transition left to an update that does not come."""
    if state.pending_offset:
        with sensor.stage("transition"):
            state.scale.charge(subtract(sensor, sensor.roles.weights, state.pending_offset))
        state.pending_offset = 0


def take_candidate(sensor: Sensor, neg: Register, scratch: Register, cost: int) -> int:
    """``w := max(w, clip(x - cost))`` in place, from ``neg = -x``, ``cost >= 0``.

    One kernel with ``cost`` in ``IN`` (the DAC, up to 127): ``NEWS = -(neg + w + cost)``
    and ``where(NEWS)`` flag the nodes where ``x - cost > w``, and ``bus(w, neg, IN)``
    writes ``x - cost`` there: one write per taken candidate (``w >= -127``, so a taken
    one is never clipped, and the others are not written). Beyond the DAC (``cost >
    127``) ``scratch := clip(x - 127)`` first (a value clipped at -128 is below every
    weight, so it never wins). Returns the ``bus`` writes a taken candidate's value went
    through from ``neg`` (1, or 3 beyond the DAC).
    """
    sim, w = sensor.sim, sensor.roles.weights
    if cost > 127:
        sim.load_in(127)
        sensor.run(_bus2, scratch, neg, IN)
        sim.load_in(cost - 127)
        sensor.run(_take_far, w, scratch)
        return 3  # scratch, then the sub's two
    if cost:
        sim.load_in(cost)
    sensor.run(_take, w, (neg, IN) if cost else (neg,))
    return 1


def subtract(sensor: Sensor, reg: Register, value: int) -> int:
    """``reg := clip(reg - value)`` by ``add`` with ``-value`` in ``IN`` (the DAC takes
    [-128, 127], so a larger ``value`` goes in steps of 127); nothing for 0. Returns the
    ``bus`` writes ``reg`` went through (two per ``add``)."""
    writes = 0
    while value:
        part = max(min(value, 127), -128)
        sensor.sim.load_in(-part)
        sensor.run(_add_in, reg)
        writes += 2
        value -= part
    return writes


def floor(sensor: Sensor, lowest: int) -> None:
    """``w := max(w, lowest)``: one kernel with ``-lowest`` in ``IN``, ``NEWS = -(w -
    lowest)`` flags ``w < lowest`` and ``bus(W, IN)`` writes ``lowest`` there (one write of
    a DAC constant)."""
    sensor.sim.load_in(-lowest)
    sensor.run(_floor, sensor.roles.weights)


def _bus1(k: Kernel, y: Register, x: Register) -> None:
    k.bus(y, x)


def _bus2(k: Kernel, y: Register, x: Register, z: Register) -> None:
    k.bus(y, x, z)


def _add_in(k: Kernel, reg: Register) -> None:
    k.add(reg, reg, IN)


def _take(k: Kernel, w: Register, sources: tuple[Register, ...]) -> None:
    k.bus(NEWS, w, *sources)
    k.where(NEWS)  # FLAG = x - cost > w
    k.bus(w, *sources)
    k.all()


def _take_far(k: Kernel, w: Register, scratch: Register) -> None:
    k.bus(NEWS, w, IN)
    k.where(scratch, NEWS)  # FLAG = x - cost > w
    k.sub(w, scratch, IN)
    k.all()


def _floor(k: Kernel, w: Register) -> None:
    k.bus(NEWS, w, IN)
    k.where(NEWS)  # FLAG = w < floor
    k.bus(w, IN)
    k.all()
