"""The local term of ``local_gain`` on the sensor: each node loses a constant for every
neighbour along the snake that is strictly closer to the live frame (stage ``"local"``).

The host's :meth:`ppaloc.localise.host.HostExecutor.add_local` subtracts ``gain *
closer_share(distances, window)``: a node loses ``step = gain / (2 window)`` units
(:func:`ppaloc.localise.params.local_step`, a DAC integer) for each of the ``2 window``
nodes within ``+-window`` whose distance is strictly smaller. On the sensor, after the
frame's update:

1. every node's tree value ``v = sign * mu * 2**-e`` at its root in ``spare``: on a
   sensor of one tile the values the update read, kept in ``means`` meanwhile
   (:func:`keep_values`); on two tiles each tile's distance tree again, tile 1's values
   moved one PE east, where its weights are;
2. the controller reads exactly (:func:`ppaloc.onsensor.carry.read_exact`) the values of
   the nodes within ``window`` of a tile's end where the neighbour is in another tile
   or, on a bank, on another sensor;
3. per tile, a copy ``-v`` moves one node along the tile's snake per step, forwards
   ``window`` times, then backwards ``window`` times
   (:func:`ppaloc.onsensor.snake.tile_step`: FLAG-masked ``scamp5_shift`` inside the
   block rows, the row starts, or the row ends going backwards, from a copy shifted one
   block row); after step ``k`` one ``where`` flags the
   roots whose neighbour ``k`` away is strictly closer (``sign (v_i - v_j) > 0``) and one
   masked ``add`` takes ``step`` from their weights. A node whose neighbour ``k`` away
   is outside the tile is cleared from the mask (one point load a step);
4. the controller compares those pairs on the values it read and takes ``count *
   step`` from each such node (one point load and one masked ``add``); on a bank, after
   the sensors have exchanged their end values (:func:`local_edges`).

Under noise each moved copy carries the fixed offsets of the PEs it was written in, the
same on every frame, so a comparison of two nearly equal distances goes the same way on
every frame (docs/localise.md, "Local contrast of the distances").

In ideal mode every value is exact (a dyadic fraction), so the flags are the host's
strict comparisons of the exact distances and the weights equal the host's ``ppa8``
filter. The weights' scale is not charged: the nodes that lose the constant are not the
local best, whose path the scale follows (:mod:`ppaloc.onsensor.gain`).
"""

from __future__ import annotations

from typing import Any

from ppaloc.localise.params import local_step
from ppaloc.onsensor.carry import read_exact
from ppaloc.onsensor.program import and_planes, neg_copy
from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.snake import tile_masks, tile_step
from ppaloc.onsensor.weights import WeightState
from ppaloc.sim import FLAG, IN, NEWS, XE, Kernel, Register

__all__ = ["keep_values", "local_edges", "local_term"]


def keep_values(sensor: Sensor) -> None:
    """Before the update on a sensor of one tile: ``means := -v`` (the tree values the
    scale's readout left in ``spare``, which the update's halvings overwrite)."""
    r = sensor.roles
    with sensor.stage("local"):
        sensor.run(neg_copy, r.means, r.spare)


def local_term(
    sensor: Sensor,
    places: Any,
    state: WeightState,
    gain: int,
    window: int,
    ends: tuple[bool, bool] = (False, False),
) -> dict[int, float]:
    """Stages 1-4 of the module docstring within this sensor; returns the exact values
    of its first ``window`` nodes where a bank has a sensor before it and of its last
    where it has one after it (``ends``; for :func:`local_edges`)."""
    step = _step_of(gain, window)
    sim, r = sensor.sim, sensor.roles
    n, cap = sensor.n_nodes, sensor.layout.capacity
    spans = [(t * cap, min(n, (t + 1) * cap) - 1) for t in range(sensor.tiles)]
    with sim.stage("local"):
        _values(sensor, places)
        wanted = set()
        before, after = ends
        for t, (first, last) in enumerate(spans):
            if t or before:
                wanted.update(range(first, min(first + window, last + 1)))
            if t < sensor.tiles - 1 or after:
                wanted.update(range(max(last - window + 1, first), last + 1))
        values = {
            node: read_exact(sensor, r.spare, *sensor.root_of(node), r.frame, r.means)
            for node in sorted(wanted)
        }
        for t, (first, last) in enumerate(spans):
            for backward in (False, True):
                _compare_along(sensor, places, state, t, first, last, step, window, backward)
        tile = {node: node // cap for node in values}
        _penalise(
            sensor,
            state,
            step,
            _closer_counts(places, values, values, window, lambda a, b: tile[a] != tile[b]),
        )
    near_end = set(range(window) if before else ()) | set(range(n - window, n) if after else ())
    return {node: v for node, v in values.items() if node in near_end}


def local_edges(
    sensor: Sensor,
    places: Any,
    state: WeightState,
    gain: int,
    window: int,
    own: dict[int, float],
    others: dict[int, float],
) -> None:
    """Stage 4 across a bank's cuts: this sensor's end nodes (``own``, from
    :func:`local_term`) against the other sensors' (``others``, keyed by node in this
    sensor's numbering: negative before it, ``n_nodes`` and more after it)."""
    step = _step_of(gain, window)
    with sensor.sim.stage("local"):
        _penalise(
            sensor, state, step, _closer_counts(places, own, others, window, lambda a, b: True)
        )


def _step_of(gain: int, window: int) -> int:
    """Units a strictly closer neighbour costs (``FilterParams`` has checked that it is
    an integer)."""
    step = local_step(gain, window)
    if step is None:
        raise AssertionError(f"local_gain={gain}, local_window={window}: a fractional step")
    return step


def _values(sensor: Sensor, places: Any) -> None:
    """``spare := v`` at every node root (stage 1)."""
    r = sensor.roles
    if sensor.tiles == 1:
        sensor.run(neg_copy, r.spare, r.means)  # kept by keep_values
        return
    for t in range(sensor.tiles):
        places.tree_calls(t, halving=True)
        build, args = places.tree(t, halving=True)
        sensor.run(build, *args)
        if t == 0:
            sensor.run(neg_copy, r.means, r.spare)
        else:
            sensor.root_pattern(r.d.pattern, 0)
            sensor.run(_east_merge, r.spare, r.means, r.d.pattern)


def _closer_counts(
    places: Any,
    mine: dict[int, float],
    others: dict[int, float],
    window: int,
    pair: Any,
) -> dict[int, int]:
    """For each node of ``mine``: how many nodes of ``others`` within ``window`` (and
    ``pair(a, b)``: not compared on the array) are strictly closer to the frame."""
    sign = places.value_scale[0]
    counts: dict[int, int] = {}
    for a, va in mine.items():
        for b, vb in others.items():
            if 0 < abs(a - b) <= window and pair(a, b) and sign * (va - vb) > 0:
                counts[a] = counts.get(a, 0) + 1
    return counts


def _penalise(sensor: Sensor, state: WeightState, step: int, counts: dict[int, int]) -> None:
    """``w := clip(w - count * step)`` at each node's root (a point load and a masked
    ``add``; ``count * step`` is at most ``local_gain``, within the DAC's range)."""
    sim, r = sensor.sim, sensor.roles
    target, sign = (r.negated, 1) if state.negated else (r.weights, -1)
    for node, count in sorted(counts.items()):
        sim.load_point(r.d.pattern, *sensor.root_of(node))
        sim.load_in(sign * count * step)
        sensor.run(_masked_add, r.d.pattern, target)


def _compare_along(
    sensor: Sensor,
    places: Any,
    state: WeightState,
    tile: int,
    first: int,
    last: int,
    step: int,
    window: int,
    backward: bool,
) -> None:
    """Stage 3 in one direction: ``window`` steps of ``-v`` along tile ``tile``'s snake,
    a comparison and a masked ``add`` after each."""
    sim, r = sensor.sim, sensor.roles
    dr = r.d
    v, moved, scratch = r.spare, r.frame, r.means
    allowed, hit = dr.u, dr.d
    sensor.root_pattern(dr.pattern, tile)
    sensor.run(and_planes, allowed, dr.pattern, dr.valid)
    tile_masks(sensor, tile, backward)
    sensor.run(neg_copy, moved, v)
    target, sign = (r.negated, 1) if state.negated else (r.weights, -1)
    for k in range(1, window + 1):
        # the node whose neighbour k away is outside the tile: the controller's pair
        edge = last - (k - 1) if backward else first + (k - 1)
        if first <= edge <= last:
            sim.load_point(dr.pattern, *sensor.root_of(edge))
            sensor.run(_clear_where, allowed, dr.pattern)
        tile_step(sensor, moved, scratch, backward)
        sim.load_in(sign * step)
        sensor.run(_flag_closer, places.value_scale[0], v, moved, allowed, hit, target)


def _east_merge(k: Kernel, v: Register, kept: Register, tile0: Register) -> None:
    """``v`` one PE east (tile 1's roots: ``NEWS`` of the east neighbour, then back), and
    ``v := -kept`` at tile 0's roots."""
    k.bus(XE, v)
    k.bus(v, NEWS)
    k.WHERE(tile0)
    k.bus(v, kept)
    k.all()


def _clear_where(k: Kernel, y: Register, mask: Register) -> None:
    k.CLR_IF(y, mask)


def _flag_closer(
    k: Kernel,
    sign: int,
    v: Register,
    moved: Register,
    allowed: Register,
    hit: Register,
    target: Register,
) -> None:
    """``moved = -v_j``: FLAG where ``sign (v_i - v_j) > 0`` (node ``j`` strictly closer),
    kept at the allowed roots, then ``target += IN`` there (``-step`` on the weights,
    ``+step`` on minus the weights)."""
    if sign > 0:
        k.where(v, moved)  # v_i - v_j > 0
    else:
        k.bus(NEWS, v, moved)  # v_j - v_i
        k.where(NEWS)
    k.AND(hit, FLAG, allowed)
    k.WHERE(hit)
    k.add(target, target, IN)
    k.all()


def _masked_add(k: Kernel, mask: Register, target: Register) -> None:
    k.WHERE(mask)
    k.add(target, target, IN)
    k.all()
