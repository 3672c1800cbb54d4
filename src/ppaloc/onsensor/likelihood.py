"""Adding every node's likelihood on the sensor: the robust scaled term and the paper's.

The representation (:mod:`~ppaloc.onsensor.lowres`, :mod:`~ppaloc.onsensor.lbp`,
:mod:`~ppaloc.onsensor.haar`) gives
each tile's distance tree, which leaves ``value_scale = (sign, e)``: ``sign * mu *
2**-e`` at every node root; this module reads and scales it.

- Robust (docs/ppa8.md, robust preset, item 3): stage ``"scale"`` reads every node's
  integer ``r_i`` (:func:`node_values`), the schedule chooses this frame's ``s`` and
  ``alpha_t`` from all of them, and stage ``"compare"`` adds ``alpha_t - mu 2**-s``
  (:func:`add_scaled`) with as few writes on a weight as the registers allow.
- Paper (Algorithm 1): ``w += alpha - mu 2**-shift`` per tile in one kernel with the tree
  (:func:`add_paper`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ppaloc.onsensor.program import neg_copy, pull, scale_negated
from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.transition import settle
from ppaloc.onsensor.weights import WeightState
from ppaloc.sim import IN, NEWS, XE, Kernel, Register, west

__all__ = ["add_paper", "add_scaled", "node_values", "scaled_sources"]

Tree = tuple[Callable[..., Any], tuple]
"""A tile's distance tree as a kernel body: ``(builder, args)``, ``builder(k, *args)``."""


def node_values(sensor: Sensor, places: Any) -> np.ndarray:
    """Robust, stage ``"scale"``: every node's integer ``r_i`` (the trees, read out).

    After the live frame is in place (``places.prepare_live``). The distance tree of each
    tile leaves its nodes' values at their blocks' top-left PEs, and ``scan_areg`` reads
    them (the ADC codes give the integers exactly, ``places.values``); the last tile's
    values stay in ``spare`` for :func:`add_scaled`. A bank combines the values of all
    its sensors before the update.
    """
    sim, r = sensor.sim, sensor.roles
    values = np.empty(sensor.n_nodes, np.int64)
    with sim.stage("scale"):
        for t in range(sensor.tiles):
            places.tree_calls(t, halving=True)
            build, args = places.tree(t, halving=True)
            sensor.run(build, *args)
            nodes, br, bc = sensor.tile_nodes[t]
            last_row = int(br.max()) * sensor.bh
            codes = sim.scan_areg(r.spare, 0, 0, last_row, sensor.size - 1, sensor.bh, sensor.bw)
            values[nodes] = places.values(codes[br, bc].astype(np.int64))
    return values


def add_scaled(sensor: Sensor, places: Any, state: WeightState, s: int, alpha: int) -> None:
    """Robust, stage ``"compare"``: ``w += alpha_t - mu 2**-s`` at every node.

    After :func:`node_values`, with this frame's shift ``s`` and ``alpha_t`` (the
    controller's, from every node of the map). The last tile's tree values are still in
    ``spare``; an earlier tile's tree is recomputed.
    """
    sim, r = sensor.sim, sensor.roles
    w, neg = r.weights, r.negated
    state.last_shift, state.last_alpha = s, alpha
    if state.negated:  # no transition since the last update: the weights back first
        sensor.run(neg_copy, w, neg)
        state.negated = False
    if not -128 <= alpha - state.pending_offset <= 127:
        settle(sensor, state)
    offset, state.pending_offset = state.pending_offset, 0
    with sim.stage("compare"):
        for t in reversed(range(sensor.tiles)):
            recompute = t != sensor.tiles - 1
            if recompute:
                places.tree_calls(t, halving=True)
            sensor.root_pattern(r.d.pattern, t)
            sim.load_in(alpha - offset)  # with the stay cost the transition left
            tree = places.tree(t, halving=True) if recompute else None
            sensor.run(
                _tree_update,
                tree,
                s,
                t,
                r.spare,
                r.frame,
                places.value_scale,
                r.d.pattern,
                w,
                neg,
            )
        state.negated = neg is not None
    state.scale.charge(1 if state.negated else 2)  # -(w + ...) into negated, or twice


def add_paper(sensor: Sensor, places: Any, alpha: int, shift: int) -> None:
    """Paper, stage ``"compare"``, per tile: ``w += alpha - mu 2**-shift`` in one kernel
    with the tile's tree (an adding tree; the term clipped as one ``add``)."""
    sim, r = sensor.sim, sensor.roles
    sign, exponent = places.value_scale
    with sim.stage("compare"):
        for t in range(sensor.tiles):
            places.tree_calls(t, halving=False)
            sensor.root_pattern(r.d.pattern, t)
            sim.load_in(alpha)
            tree = places.tree(t, halving=False)
            sensor.run(
                _paper_update,
                tree,
                r.spare,
                r.frame,
                sign,
                exponent - shift,
                t,
                r.d.pattern,
                r.weights,
            )


def scaled_sources(
    k: Kernel,
    s: int,
    need: int,
    value: Register,
    scratch: Register,
    value_scale: tuple[int, int],
) -> tuple[Register, ...]:
    """Registers whose sum is ``need * mu * 2**-s``, from the tree's value in ``value``.

    Halvings (``bus2``, one write each) alternate between ``value`` and ``scratch`` and
    flip the sign; when the last one has the wrong sign, the pair of the last two (``H +
    (-H / 2) = H / 2``) has the right one, so no negation is written. Only ``s`` below the
    tree's scale costs extra writes (one doubling by a copy, one more negation when the
    sign is wrong).
    """
    sign, exponent = value_scale  # value = sign * mu * 2**-exponent
    halvings = s - exponent
    if halvings < 0:  # s = 0 at low-res (-mu/2): two copies of +-mu/2
        if sign != need:
            k.bus(scratch, value)
        else:
            k.mov(scratch, value)
        k.mov(value, scratch)  # value = scratch
        return (value, scratch)
    cur, other = value, scratch
    for _ in range(halvings):
        k.bus2(other, NEWS, cur)  # other = -cur / 2
        cur, other = other, cur
        sign = -sign
    if sign == need:
        return (cur,)
    if halvings:
        return (other, cur)  # the last two halvings: -cur / 2 ... + cur = need |mu_s|
    k.bus(other, cur)
    return (other,)


def _tree_update(
    k: Kernel,
    tree: tuple | None,
    s: int,
    tile: int,
    value: Register,
    scratch: Register,
    value_scale: tuple[int, int],
    pattern: Register,
    w: Register,
    neg: Register | None,
) -> None:
    """Robust: (the tile's tree, where recomputed, then) ``w += alpha_t - mu 2**-s`` at
    tile ``tile``'s roots, ``alpha_t`` in ``IN``.

    The paper's :func:`add_paper` negates the scaled term when the halvings' parity is
    wrong (one write) and moves it for tile 1 by a ``movx`` (two), then ``add`` (two): up
    to five writes on a weight's term. Here the term is a sum of sources with the right
    sign (:func:`scaled_sources`); tile 0 takes ``NEWS := -(w + alpha - mu_s)``, ``w :=
    -NEWS`` (the ``add``, clip [-127, 127]); tile 1 pushes ``+mu_s`` into the east
    neighbour's ``NEWS`` (one write, which negates and moves it to the weight's PE), then
    ``X := -(w + alpha - mu_s)`` and ``w := -X``: the same two writes and clip on the
    weight, three fewer in all. With a ``negated`` register the update writes ``-(w +
    alpha - mu_s)`` there once instead (the next transition writes ``w`` back).
    """
    if tree is not None:
        build, args = tree
        build(k, *args)
    if tile == 0:
        sources = scaled_sources(k, s, -1, value, scratch, value_scale)
        k.WHERE(pattern)
        if neg is not None:  # the one write: negated := -(w + alpha - mu_s)
            k.bus(neg, *sources, w, IN)
        else:
            k.bus(NEWS, *sources, w, IN)  # -(w + alpha - mu_s), clipped; pair first
            k.bus(w, NEWS)
        k.all()
        return
    if tile > 1:
        raise AssertionError("a sensor holds at most two tiles")
    sources = scaled_sources(k, s, 1, value, scratch, value_scale)
    k.bus(XE, *sources)  # NEWS = -mu_s of the west neighbour: at tile 1's root
    k.WHERE(pattern)
    if neg is not None:
        k.bus(neg, w, NEWS, IN)
    else:
        k.bus(scratch, w, NEWS, IN)  # -(w + alpha - mu_s), clipped
        k.bus(w, scratch)
    k.all()


def _paper_update(
    k: Kernel,
    tree: tuple,
    x: Register,
    y: Register,
    sign: int,
    exponent: int,
    tile: int,
    pattern: Register,
    w: Register,
) -> None:
    """The tile's tree, then ``w += alpha - base 2**exponent`` at tile ``tile``'s roots
    (``x = sign base`` after the tree).

    ``alpha`` is in ``IN``; the roots are in ``pattern``. One ``add`` of three sources:
    ``NEWS = -(w + alpha - mu_s)`` saturates, then ``w = -NEWS``, so ``w`` is clipped to
    [-127, 127] (docs/ppa8.md).
    """
    build, args = tree
    build(k, *args)
    neg = scale_negated(k, x, sign, exponent, y)
    if tile:
        spare = y if neg is x else x
        pull(k, spare, neg, west, tile)
        neg = spare
    k.WHERE(pattern)
    k.add(w, w, neg, IN)
    k.all()
