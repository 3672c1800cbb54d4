"""The local term of ``local_gain`` on the sensor: each node loses a constant for every
neighbour along the map that is strictly closer to the live frame (stage ``"local"``).

The host's :meth:`ppaloc.localise.host.HostExecutor.add_local` subtracts ``gain *
closer_share(distances, window, places)``: a node loses ``step = gain / (2 window)``
units (:func:`ppaloc.localise.params.local_step`, a DAC integer) for each of its ``2
window`` neighbours whose distance is strictly smaller: the nodes within ``+-window``,
or on a map with runs the nodes next to its run's ``window`` places each way
(:func:`~ppaloc.localise.enhance.place_neighbours`, :func:`neighbours`). On the sensor,
after the frame's update:

1. every node's tree value ``v = sign * mu * 2**-e`` at its root in ``spare``: on a
   sensor of one tile the values the update read, kept in ``means`` meanwhile
   (:func:`keep_values`); on two tiles each tile's distance tree again, tile 1's values
   moved one PE east, where its weights are;
2. the controller reads exactly (:func:`ppaloc.onsensor.carry.read_exact`) the values of
   the nodes whose neighbour is in another tile, both ends of each such pair, and, on a
   bank, those its pairs across the cuts need;
3. per tile, a copy ``-v`` moves one node along the tile's snake per step, forwards
   ``window`` times, then backwards ``window`` times
   (:func:`ppaloc.onsensor.snake.tile_step`: FLAG-masked ``scamp5_shift`` inside the
   block rows, the row starts, or the row ends going backwards, from a copy shifted one
   block row); on a map with runs each step then moves the copy on along the runs, at
   the roots that continue their run only (the snake masks ANDed with the controller's
   rectangles, ``Sensor.run_chains``), as many times as the tile's longest stretch of
   them, so every node of a run holds the value next to its run. After step ``k`` one
   ``where`` flags the roots whose neighbour ``k`` places away is strictly closer
   (``sign (v_i - v_j) > 0``) and one masked ``add`` takes ``step`` from their weights.
   The nodes whose neighbour ``k`` away is outside the tile are cleared from the mask
   (a point load, or a window of rectangles for a run);
4. the controller compares those pairs on the values it read and takes ``count *
   step`` from each such node (one point load and one masked ``add``); on a bank, after
   the sensors have exchanged their values (:func:`local_edges`).

Under noise each moved copy carries the fixed offsets of the PEs it was written in, the
same on every frame, so a comparison of two nearly equal distances goes the same way on
every frame (docs/localise.md, "Local contrast of the distances").

In ideal mode every value is exact (a dyadic fraction), so the flags are the host's
strict comparisons of the exact distances and the weights equal the host's ``ppa8``
filter. The weights' scale is not charged: the nodes that lose the constant are not the
local best, whose path the scale follows (:mod:`ppaloc.onsensor.gain`).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from ppaloc.localise.enhance import place_neighbours
from ppaloc.localise.params import local_step
from ppaloc.onsensor.carry import read_exact
from ppaloc.onsensor.program import and_planes, neg_copy
from ppaloc.onsensor.roles import DRegs
from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.snake import tile_masks, tile_step
from ppaloc.onsensor.weights import WeightState
from ppaloc.sim import FLAG, IN, NEWS, XE, Kernel, Register

__all__ = ["keep_values", "local_edges", "local_term", "neighbours"]


def keep_values(sensor: Sensor) -> None:
    """Before the update on a sensor of one tile: ``means := -v`` (the tree values the
    scale's readout left in ``spare``, which the update's halvings overwrite)."""
    r = sensor.roles
    with sensor.stage("local"):
        sensor.run(neg_copy, r.means, r.spare)


def neighbours(sensor: Sensor, window: int) -> np.ndarray:
    """The nodes of this sensor each node is compared with
    (:func:`~ppaloc.localise.enhance.place_neighbours`: on a map with runs the nodes next
    to its run, else ``i -+ k``), -1 past the sensor's ends."""
    places = sensor.run_places if sensor.run_places is not None else np.arange(sensor.n_nodes)
    return place_neighbours(places, window)


def cross_pairs(near: np.ndarray, owner: np.ndarray) -> list[tuple[int, int]]:
    """The pairs ``(node, neighbour)`` of ``near`` (:func:`neighbours`) whose ``owner``
    (a tile, a bank's sensor) differs: the pairs the controller compares on values it
    reads. Sorted."""
    node = np.broadcast_to(np.arange(near.shape[-1]), near.shape)
    cross = (near >= 0) & (owner[np.maximum(near, 0)] != owner[node])
    return sorted(zip(node[cross].tolist(), near[cross].tolist(), strict=True))


def _plan(sensor: Sensor, window: int) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """:func:`neighbours` and the pairs across this sensor's tiles, once per map and
    window (the controller's table)."""
    if window not in sensor.local_plans:
        near = neighbours(sensor, window)
        tile = np.arange(sensor.n_nodes) // sensor.layout.capacity
        sensor.local_plans[window] = (near, cross_pairs(near, tile))
    return sensor.local_plans[window]


def local_term(
    sensor: Sensor,
    places: Any,
    state: WeightState,
    gain: int,
    window: int,
    wanted: Collection[int] = (),
) -> dict[int, float]:
    """Stages 1-4 of the module docstring within this sensor; returns the exact values
    of the nodes ``wanted`` (a bank's pairs across its cuts, :func:`local_edges`)."""
    step = _step_of(gain, window)
    sim, r = sensor.sim, sensor.roles
    n, cap = sensor.n_nodes, sensor.layout.capacity
    spans = [(t * cap, min(n, (t + 1) * cap) - 1) for t in range(sensor.tiles)]
    near, pairs = _plan(sensor, window)
    with sim.stage("local"):
        _values(sensor, places)
        read = {a for a, _ in pairs} | {b for _, b in pairs} | set(wanted)
        values = {
            node: read_exact(sensor, r.spare, *sensor.root_of(node), r.frame, r.means)
            for node in sorted(read)
        }
        for t, (first, last) in enumerate(spans):
            for backward in (False, True):
                _compare_along(
                    sensor, places, state, t, (first, last), step, near[int(backward)], backward
                )
        mine = [(a, values[a], values[b]) for a, b in pairs]
        _penalise(sensor, state, step, _closer(places.value_scale[0], mine))
    return {node: values[node] for node in wanted}


def local_edges(
    sensor: Sensor,
    places: Any,
    state: WeightState,
    gain: int,
    window: int,
    own: dict[int, float],
    others: Sequence[tuple[int, float]],
) -> None:
    """Stage 4 across a bank's cuts: each ``(node, value)`` of ``others`` is a
    neighbour of this sensor's ``node`` on another sensor, ``own`` this sensor's exact
    values (from :func:`local_term`)."""
    step = _step_of(gain, window)
    mine = [(node, own[node], value) for node, value in others]
    with sensor.sim.stage("local"):
        _penalise(sensor, state, step, _closer(places.value_scale[0], mine))


def _closer(sign: int, pairs: Sequence[tuple[int, float, float]]) -> dict[int, int]:
    """For each ``(node, its value, a neighbour's value)``: how many of the node's
    neighbours are strictly closer to the frame (``sign (v_i - v_j) > 0``)."""
    counts: dict[int, int] = {}
    for node, mine, other in pairs:
        if sign * (mine - other) > 0:
            counts[node] = counts.get(node, 0) + 1
    return counts


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
    span: tuple[int, int],
    step: int,
    near: np.ndarray,
    backward: bool,
) -> None:
    """Stage 3 in one direction: ``window`` steps of ``-v`` along tile ``tile``'s snake
    (``near[k - 1]``: each node's neighbour ``k`` places away), a comparison and a
    masked ``add`` after each. On a map with runs each step is one node along the snake
    and then one node more at the roots that continue their run (backwards: whose run
    continues), as many times as the tile's longest stretch of them
    (``Sensor.run_chains``), so that every node of a run reads the node next to it."""
    sim, r = sensor.sim, sensor.roles
    dr = r.d
    first, last = span
    v, moved, scratch = r.spare, r.frame, r.means
    allowed, hit = dr.u, dr.d
    sensor.root_pattern(dr.pattern, tile)
    sensor.run(and_planes, allowed, dr.pattern, dr.valid)
    tile_masks(sensor, tile, backward)
    fresh = True  # the tile's snake masks are loaded
    sensor.run(neg_copy, moved, v)
    target, sign = (r.negated, 1) if state.negated else (r.weights, -1)
    chain = sensor.run_chains.get((tile, backward))
    nodes = np.arange(first, last + 1)
    cleared = 0
    for k in range(1, len(near) + 1):
        # the nodes whose neighbour k away is outside the tile: the controller's pairs
        ahead = near[k - 1, first : last + 1]
        outside = nodes[(ahead < first) | (ahead > last)]
        new = outside[cleared:] if not backward else outside[: len(outside) - cleared]
        cleared = len(outside)
        assert len(new) == 0 or new[-1] - new[0] == len(new) - 1, "a prefix or suffix"
        if len(new) == 1:
            sim.load_point(dr.pattern, *sensor.root_of(int(new[0])))
            sensor.run(_clear_where, allowed, dr.pattern)
        elif len(new) > 1:
            sensor.window(int(new[0]), int(new[-1]))
            sensor.run(_clear_where, allowed, dr.tmp_b)
            fresh = False
        if chain is not None:
            sensor.roots_in(hit, dr.pattern, [(tile, chain[0])])
            fresh = False
        if not fresh:
            tile_masks(sensor, tile, backward)
            fresh = True
        tile_step(sensor, moved, scratch, backward)
        if chain is not None:  # along the runs: only the roots that continue them move
            sensor.run(_and_masks, dr, hit)
            fresh = False
            for _ in range(chain[1]):
                tile_step(sensor, moved, scratch, backward)
        sim.load_in(sign * step)
        sensor.run(_flag_closer, places.value_scale[0], v, moved, allowed, hit, target)


def _and_masks(k: Kernel, dr: DRegs, keep: Register) -> None:
    """The snake masks of :func:`~ppaloc.onsensor.snake.tile_masks` kept at ``keep``."""
    k.AND(dr.cand, dr.cand, keep)
    k.AND(dr.tmp_a, dr.tmp_a, keep)
    k.AND(dr.tmp_b, dr.tmp_b, keep)


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
