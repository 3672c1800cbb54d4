"""A map's runs on the sensor: a weight flows along the nodes of one place for free.

A map of every frame made with the image motion test keeps a stop of the reference as a
run of nodes of one place (``TopoMap.places``), and the robust transition lets each
weight flow along its run: ``w_i := max(w_j, j <= i in the run of i)``, the host's
running maximum (:meth:`ppaloc.localise.host.HostExecutor.transition`).

On the sensor the controller keeps, with the map, the rectangles of block rows that hold
the nodes continuing their predecessor's place (:func:`plan_runs`; no register is kept:
every digital register is taken, and ``R12`` is the macros' scratch). After the
transition's floor (stage ``"runs"``) it loads those rectangles into a working plane and
keeps the node roots among them (:func:`_run_mask`: one ``load_rect`` and one OR per
rectangle, a root pattern and an AND per tile), then ``run_steps`` times (the longest
run less one): ``S := -W`` moves one node along the snake
(:func:`~ppaloc.onsensor.snake.snake_step`, tiles continuing), and a root of the mask
takes its predecessor's weight where that is not smaller (one kernel, one analogue write
per taken weight). After step ``k`` each weight is the largest of itself and the ``k``
nodes before it in its run, so ``run_steps`` steps give the running maximum exactly in
ideal mode. A map without runs costs nothing.

The maximum commutes with what surrounds it on the sensor: the floor (a maximum with a
constant) and the stay cost still pending on every weight alike
(:mod:`ppaloc.onsensor.transition`). A bank cuts its map between places
(:func:`bank_offsets`), so no run crosses from one sensor to the next.
"""

from __future__ import annotations

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.onsensor.program import neg_copy
from ppaloc.onsensor.sensor import Sensor
from ppaloc.onsensor.snake import park, snake_masks, snake_step
from ppaloc.sim import FLAG, Kernel, Register

__all__ = [
    "bank_offsets",
    "continues",
    "longest_run",
    "node_rects",
    "plan_runs",
    "running_max",
]


def continues(places: np.ndarray) -> np.ndarray:
    """Per node, whether it shows its predecessor's place (node 0 never does).

    Examples
    --------
    >>> continues(np.array([0, 1, 1, 1, 2])).tolist()
    [False, False, True, True, False]
    """
    places = np.asarray(places)
    out = np.zeros(len(places), bool)
    out[1:] = places[1:] == places[:-1]
    return out


def longest_run(places: np.ndarray) -> int:
    """Nodes in the longest run of one place (0 for no node).

    Examples
    --------
    >>> longest_run(np.array([0, 1, 1, 1, 2])), longest_run(np.array([0, 1, 2]))
    (3, 1)
    """
    places = np.asarray(places)
    if not len(places):
        return 0
    return int(np.bincount(places - places[0]).max())


def bank_offsets(places: np.ndarray | None, n_nodes: int, per: int, least: int = 1) -> list[int]:
    """The first node of each sensor of a bank holding ``n_nodes`` nodes, ``per`` at most
    on one: every ``per`` nodes, or on a map with runs the start of the run a cut would
    fall into, so that each run stays on one sensor. Every sensor but the last holds at
    least ``least`` nodes (the nodes a frame may advance into the next sensor).

    Examples
    --------
    >>> bank_offsets(None, 10, 4)
    [0, 4, 8]
    >>> bank_offsets(np.array([0, 1, 2, 2, 2, 3, 4, 5, 5, 6]), 10, 4)
    [0, 2, 6]
    """
    if places is None:
        return list(range(0, n_nodes, per))
    places = np.asarray(places)
    offsets, start = [0], 0
    while start + per < n_nodes:
        cut = start + per
        if places[cut] == places[cut - 1]:  # inside a run: cut at its first node
            cut = int(np.searchsorted(places, places[cut], side="left"))
        if cut - start < least:
            run = np.flatnonzero(places == places[start + per])
            raise PpalocError(
                f"a bank of {per}-node sensors cannot cut this map between places: the run "
                f"of nodes {run[0]}..{run[-1]} (a stop of the reference, frame by frame) "
                f"leaves sensor {len(offsets) - 1} {cut - start} node(s), fewer than "
                f"{least}; map with keyframes=true (the default), which keeps a stop as one "
                "node"
            )
        offsets.append(cut)
        start = cut
    return offsets


def plan_runs(sensor: Sensor, places: np.ndarray | None) -> None:
    """Keep the controller's table of the map's runs on ``sensor``: ``run_places`` (each
    node's place, or None for a map without runs), ``run_steps`` (the longest run less
    one), ``run_rects`` (per tile, the root rows of consecutive blocks whose nodes
    continue their predecessor's place) and ``run_chains`` (per tile and direction of
    the local term, :mod:`ppaloc.onsensor.local`: the rectangles of the tile's nodes that
    take their predecessor's value, backwards their successor's, along a run, and the
    longest stretch of them). None, or a map without runs: nothing to do at the
    transition."""
    sensor.run_steps, sensor.run_rects, sensor.run_places = 0, {}, None
    sensor.run_chains, sensor.local_plans = {}, {}
    if places is None or longest_run(places) < 2:
        return
    places = np.asarray(places, dtype=np.int64)
    sensor.run_places = places
    sensor.run_steps = longest_run(places) - 1
    sensor.run_rects = node_rects(sensor, np.flatnonzero(continues(places)))
    cap = sensor.layout.capacity
    for t in range(sensor.tiles):
        part = places[t * cap : min(len(places), (t + 1) * cap)]
        steps = longest_run(part) - 1  # the longest stretch of a chain within the tile
        if steps < 1:
            continue
        same = np.flatnonzero(part[1:] == part[:-1])  # node i + 1 continues node i's place
        for backward in (False, True):
            chain = same + (0 if backward else 1) + t * cap
            sensor.run_chains[(t, backward)] = (node_rects(sensor, chain)[t], steps)


def node_rects(sensor: Sensor, nodes: np.ndarray) -> dict[int, list[tuple[int, int, int, int]]]:
    """Per tile, the root rows of the blocks of ``nodes`` (ascending) as rectangles: one
    for each stretch of consecutive nodes in one block row (along a row the snake's
    block column moves by one per node)."""
    if not len(nodes):
        return {}
    tile, brow, bcol = sensor.layout.node_to_block(nodes)
    breaks = (np.diff(nodes) != 1) | (np.diff(tile) != 0) | (np.diff(brow) != 0)
    rects: dict[int, list[tuple[int, int, int, int]]] = {}
    for group in np.split(np.arange(len(nodes)), np.flatnonzero(breaks) + 1):
        first, last = group[0], group[-1]
        c0, c1 = sorted((int(bcol[first]), int(bcol[last])))
        row = int(brow[first]) * sensor.bh
        rects.setdefault(int(tile[first]), []).append(
            (row, c0 * sensor.bw, row, c1 * sensor.bw + sensor.bw - 1)
        )
    return rects


def running_max(sensor: Sensor) -> None:
    """``w_i := max(w_j, j <= i in the run of i)`` over the map's runs (module docstring);
    ``run_steps`` one-node steps along the snake, nothing without runs."""
    if not sensor.run_steps:
        return
    r = sensor.roles
    w, s, x, dr = r.weights, r.shifted, r.spare, r.d
    with sensor.stage("runs"):
        _run_mask(sensor)  # d.u := NOT (the roots that continue their predecessor's place)
        snake_masks(sensor)
        for _ in range(sensor.run_steps):
            sensor.run(neg_copy, s, w)  # S := -W
            park(sensor, s, x, 127, 1)  # node 0 starts a run: its edge is never taken
            snake_step(sensor, s, x, 1)  # S_i := -W_{i-1}
            sensor.run(_take_run, w, s, dr.d, dr.u)


def _run_mask(sensor: Sensor) -> None:
    """``d.u`` := NOT the roots of the nodes that continue their predecessor's place
    (working registers only: the motion stage's ``u`` and ``d`` are free after it)."""
    dr = sensor.roles.d
    sensor.roots_in(dr.u, dr.tmp_b, sorted(sensor.run_rects.items()))
    sensor.run(_not, dr.u)


def _not(k: Kernel, r: Register) -> None:
    k.NOT(r)  # r := NOT r


def _take_run(k: Kernel, w: Register, neg: Register, tmp: Register, outside: Register) -> None:
    k.where(w, neg)  # FLAG = w - x > 0, x the predecessor's weight (neg = -x)
    k.NOR(tmp, FLAG, outside)  # x >= w at a root that continues its predecessor's place
    k.WHERE(tmp)
    k.bus(w, neg)  # w := x
    k.all()
