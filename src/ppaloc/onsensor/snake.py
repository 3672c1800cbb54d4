"""Moving values one node along the snake: the paper's weight shift and the robust
transition's shifted copies.

The map's nodes follow a snake of blocks from the top-right corner (docs/onsensor.md):
inside a block row a node's predecessor is the neighbouring block (east on even rows,
west on odd ones), and a row's first node takes the last node of the row above; with two
tiles, node 0 of tile 1 takes tile 0's last node. Every move is a FLAG-masked
``scamp5_shift`` of whole block rows plus the row starts from a copy shifted one block
row south.
"""

from __future__ import annotations

from ppaloc.onsensor.program import neg_copy, pull, pull_shift
from ppaloc.onsensor.roles import DRegs
from ppaloc.onsensor.sensor import Sensor, mask_bits
from ppaloc.sim import Kernel, Register, east, north, south, west

__all__ = ["park", "shift_weights", "snake_masks", "snake_step", "tile_masks", "tile_step"]


def shift_weights(sensor: Sensor) -> None:
    """Paper, forward: ``w_i := w_{i-1}`` along the snake, ``w_0 := 0`` (tiles continue).

    Inside a block row the weights move in place by a FLAG-masked ``scamp5_shift`` (even
    rows west, odd rows east, the row starts excluded), so most weights take one analogue
    write per move. The row starts take the row end above from a copy made before
    (``spare``), and with two tiles node 0 of tile 1 takes the last node of tile 0 from a
    second copy (``frame``). Stage ``"shift"``.
    """
    sim, r = sensor.sim, sensor.roles
    dr, w = r.d, r.weights
    bh, bw, n = sensor.bh, sensor.bw, sensor.size
    tcx = 1 if sensor.tiles > 1 else 0
    rx = mask_bits(2 * bh)
    with sim.stage("shift"):
        copies = (r.spare, r.frame) if sensor.tiles > 1 else (r.spare,)
        sensor.run(_copies, w, copies)
        sim.load_pattern(dr.tmp_a, 0, n - bw, rx, tcx)  # even row starts (east end)
        sim.load_pattern(dr.cand, bh, 0, rx, tcx)  # odd row starts (west end)
        sensor.run(_or3, dr.tmp_b, dr.cand, dr.tmp_a)
        for row_mod, pull_from in ((1, east), (2, west)):
            sensor.root_pattern(dr.cand, None, row_mod=row_mod)
            sensor.run(_inner, dr)
            pull_shift(sim, w, pull_from, bw)
            sensor.run(_all)
        pull_shift(sim, r.spare, north, bh)  # spare[r, c] = -w[r - bh, c]
        sensor.run(_masked_copy, dr.tmp_b, w, r.spare)
        if sensor.tiles > 1:
            # the last node of tile 0 (bottom right) feeds node 0 of tile 1 (top right)
            sim.shift(r.frame, 1, n - bh)
            sim.load_point(dr.cand, 0, n - bw + 1)
            sensor.run(_masked_copy, dr.cand, w, r.frame)


def snake_masks(sensor: Sensor) -> None:
    """``tmp_b`` := the row starts, ``cand`` / ``tmp_a`` := the other roots of the even /
    odd block rows (both tiles): the FLAG masks of a snake shift."""
    sim, dr = sensor.sim, sensor.roles.d
    bh, bw, n = sensor.bh, sensor.bw, sensor.size
    tcx = 1 if sensor.tiles > 1 else 0
    rx = mask_bits(2 * bh)
    sim.load_pattern(dr.tmp_a, 0, n - bw, rx, tcx)  # even row starts (east end)
    sim.load_pattern(dr.cand, bh, 0, rx, tcx)  # odd row starts (west end)
    sensor.run(_or3, dr.tmp_b, dr.cand, dr.tmp_a)
    sensor.root_pattern(dr.cand, None, row_mod=1)
    sensor.root_pattern(dr.tmp_a, None, row_mod=2)
    sensor.run(_not_starts, dr)


def park(
    sensor: Sensor,
    reg: Register,
    scratch: Register,
    edge: int,
    steps: int,
    carried: bool = False,
) -> None:
    """Park what enters the snake's starts during ``steps`` shifts of ``reg``.

    Row 1 of the top block row holds no root, so it is storage: at the tile-0 column of
    the first ``steps`` blocks it gets the edge value (``edge``, the DAC; on a bank's
    later sensor, ``carried``, the previous sensor's weights are there already,
    :func:`ppaloc.onsensor.carry.carry_in`), and with two tiles, at the tile-1 column of
    block ``k - 1`` (counting from the top-right), ``reg`` of tile 0's ``k``-th last node
    (one ``scamp5_shift`` of a copy: 1 + 247 steps on a 256 array). :func:`snake_step`
    then moves the right one into the two node-0 roots.
    """
    sim, dr = sensor.sim, sensor.roles.d
    n, bh = sensor.size, sensor.bh
    assert (n // bh) % 2 == 0  # the last block row runs east: tile 0 ends bottom right
    if sensor.tiles > 1:
        sensor.run(neg_copy, scratch, reg)
        # scratch[1, c] = -reg[n - bh, c - 1]: tile 0's last block row, one column east
        sim.shift(scratch, 1, n - bh - 1)
        if carried:  # row 1, tile-1 columns (tile 0's hold the carry)
            sim.load_pattern(dr.pattern, 1, 1, 0, mask_bits(sensor.bw))
        else:
            sim.load_pattern(dr.pattern, 1, 0, 0, 0xFF)  # row 1
        sensor.run(_masked_copy, dr.pattern, reg, scratch)
    if not carried:
        sim.load_pattern(dr.pattern, 1, 0, 0, mask_bits(sensor.bw))  # row 1, tile-0 columns
        sensor.run(_where, dr.pattern)
        sim.scamp5_in(reg, edge)
        sensor.run(_all)
    # the node-0 roots of the tiles, which every step writes from the parked row
    if sensor.tiles > 1:
        sim.load_pattern(dr.pattern, 0, n - sensor.bw, 0, 1)
    else:
        sim.load_point(dr.pattern, 0, n - sensor.bw)


def snake_step(sensor: Sensor, reg: Register, scratch: Register, step: int) -> None:
    """``reg_i := reg_{i-1}`` at every node root along the snake (tiles continue).

    After :func:`snake_masks` and :func:`park`; ``step`` counts the shifts from 1. As
    :func:`shift_weights` (FLAG-masked ``scamp5_shift`` inside the block rows, the row
    starts from a copy shifted one block row south), but with one scratch register: node
    0 of each tile takes the value parked for this step in row 1.
    """
    sim, dr = sensor.sim, sensor.roles.d
    bh, bw = sensor.bh, sensor.bw
    sensor.run(neg_copy, scratch, reg)
    for mask, pull_from in ((dr.cand, east), (dr.tmp_a, west)):
        sensor.run(_where, mask)
        pull_shift(sim, reg, pull_from, bw)
    sensor.run(_all)
    pull_shift(sim, scratch, north, bh)  # scratch[r, c] = -reg[r - bh, c]
    sensor.run(_starts, dr, reg, scratch, (step - 1) * bw)


def tile_masks(sensor: Sensor, tile: int, backward: bool) -> None:
    """Masks of one tile's snake for :func:`tile_step`: ``tmp_b`` := the roots of tile
    ``tile`` that take their value from the block row above (forwards: the row starts)
    or below (backwards: the row ends); ``cand`` / ``tmp_a`` := its other roots of the
    even / odd block rows."""
    sim, dr = sensor.sim, sensor.roles.d
    bh, bw, n = sensor.bh, sensor.bw, sensor.size
    rx = mask_bits(2 * bh)
    east_end, west_end = n - bw + tile, tile
    even, odd = (west_end, east_end) if backward else (east_end, west_end)
    sim.load_pattern(dr.tmp_a, 0, even, rx, 0)
    sim.load_pattern(dr.cand, bh, odd, rx, 0)
    sensor.run(_or3, dr.tmp_b, dr.cand, dr.tmp_a)
    sensor.root_pattern(dr.cand, tile, row_mod=1)
    sensor.root_pattern(dr.tmp_a, tile, row_mod=2)
    sensor.run(_not_starts, dr)


def tile_step(sensor: Sensor, reg: Register, scratch: Register, backward: bool) -> None:
    """``reg_i := reg_{i-1}`` (forwards) or ``reg_{i+1}`` (backwards) at the roots of one
    tile (after :func:`tile_masks`), as :func:`snake_step` moves them; what enters the
    tile's ends is not defined (its first node forwards, its last backwards)."""
    sim, dr = sensor.sim, sensor.roles.d
    bh, bw = sensor.bh, sensor.bw
    sensor.run(neg_copy, scratch, reg)
    even, odd = (west, east) if backward else (east, west)
    for mask, pull_from in ((dr.cand, even), (dr.tmp_a, odd)):
        sensor.run(_where, mask)
        pull_shift(sim, reg, pull_from, bw)
    sensor.run(_all)
    pull_shift(sim, scratch, south if backward else north, bh)
    sensor.run(_masked_copy, dr.tmp_b, reg, scratch)


def _copies(k: Kernel, w: Register, copies: tuple[Register, ...]) -> None:
    for c in copies:
        k.bus(c, w)


def _or3(k: Kernel, y: Register, a: Register, b: Register) -> None:
    k.OR(y, a, b)


def _inner(k: Kernel, dr: DRegs) -> None:
    k.CLR_IF(dr.cand, dr.tmp_b)
    k.WHERE(dr.cand)


def _not_starts(k: Kernel, dr: DRegs) -> None:
    k.CLR_IF(dr.cand, dr.tmp_b)
    k.CLR_IF(dr.tmp_a, dr.tmp_b)


def _masked_copy(k: Kernel, mask: Register, y: Register, neg: Register) -> None:
    """``y := -neg`` where ``mask`` is set."""
    k.WHERE(mask)
    k.bus(y, neg)
    k.all()


def _where(k: Kernel, mask: Register) -> None:
    k.WHERE(mask)


def _all(k: Kernel) -> None:
    k.all()


def _starts(k: Kernel, dr: DRegs, reg: Register, scratch: Register, back: int) -> None:
    k.WHERE(dr.tmp_b)
    k.bus(reg, scratch)
    k.all()
    pull(k, scratch, reg, south, 1)  # the parked row, one row up
    if back:
        pull(k, scratch, scratch, west, back)  # from block step - 1
    k.WHERE(dr.pattern)
    k.mov(reg, scratch)
    k.all()
