"""Capture and block means on the sensor: the frame into the array, its 8x8 grid of means.

Stages ``"capture"`` and ``"reduce"``. :func:`capture` reads the image into the
``frame`` role (``v = p/2 - 64``) and refreshes the static masks; :func:`block_means`
leaves minus every grid block's exact mean at its top-left PE by a halving tree and, when
asked, spreads it over the block into ``means`` (``F := -m``): by masked copies from the
roots (:func:`spread_copies`, a few writes per PE) or by the paper's doubling tree over a
zero background. For a finer live grid (``lowres16``) the tree stops at that grid's
blocks first and the controller reads their codes (:func:`read_grid`), then it goes on
to the 8x8 grid's blocks, which the image motion test compares with.
"""

from __future__ import annotations

import numpy as np

from ppaloc.onsensor.program import add_level, halve_level, pull_shift, tree_levels
from ppaloc.onsensor.sensor import GRID, Sensor, mask_bits
from ppaloc.sim import IN, NEWS, Kernel, Register, north, west

__all__ = ["block_means", "capture", "read_grid", "spread_copies"]


def capture(sensor: Sensor, frame: np.ndarray) -> None:
    """Capture into ``frame`` (``v = p/2 - 64``), refresh static masks, reload block roots."""
    sim, r = sensor.sim, sensor.roles
    sim.set_image(frame)
    with sim.stage("capture"):
        sensor.run(_capture, r.frame, r.static)
        bits = mask_bits(sensor.block)
        sim.load_pattern(r.d.root32, 0, 0, bits, bits)


def _capture(k: Kernel, frame: Register, static: tuple[Register, ...]) -> None:
    k.get_image(frame)
    for reg in static:
        k.REFRESH(reg)


def _levels(sensor: Sensor) -> tuple[int, ...]:
    levels = []
    d = 1
    while d < sensor.block:
        levels.append(d)
        d *= 2
    return tuple(levels)


def block_means(sensor: Sensor, spread: str | None, grid: int = GRID) -> np.ndarray | None:
    """``means := -m``: every PE holds minus the exact mean of its grid block of ``v``.

    A halving tree leaves each block's mean at its top-left PE (``spare``; also ``+m`` in
    ``root_means`` where the representation has one). ``spread``: ``"copies"``
    (:func:`spread_copies`), ``"tree"`` (the paper's doubling tree over a zero
    background) or None (the roots only).

    ``grid``: the live grid's cells per side. Finer than the 8x8 blocks (16), the tree
    first stops at its blocks, whose codes :func:`read_grid` reads, and then goes on
    (the 8x8 means are the means of the finer ones, exact); the codes are returned,
    ``(grid, grid)`` uint8. None for the 8x8 grid, whose codes are read where needed.
    """
    r = sensor.roles
    levels = _levels(sensor)
    with sensor.stage("reduce"):
        if grid == GRID:
            codes = None
            sensor.run(_reduce, r.spare, r.frame, r.means, r.root_means, levels)
        else:
            fine = sensor.size // grid  # PEs per side of a block of the finer grid
            if grid < GRID or fine * grid != sensor.size:
                raise AssertionError(f"grid {grid} does not refine the 8x8 blocks")
            split = levels.index(fine)
            sensor.run(_reduce, r.spare, r.frame, r.means, None, levels[:split])
            codes = read_grid(sensor, fine)
            sensor.run(_halve_on, r.spare, r.means, r.root_means, levels[split:])
        if spread == "copies":
            spread_copies(sensor)
        elif spread == "tree":
            sensor.run(_spread_tree, r.means, r.spare, r.d.root32, levels)
    return codes


def read_grid(sensor: Sensor, block: int) -> np.ndarray:
    """The codes ``q = floor(S / block**2)`` of every ``block`` x ``block`` block (``S``
    its pixel sum), from ``-m`` at the blocks' top-left PEs in ``spare``.

    One kernel puts ``2m - 1/2`` into ``means`` at the roots (the constant 1/2 halved
    from the DAC's -1; four writes, exact), and ``scan_areg`` at the blocks' stride reads
    ``floor(2m + 128)`` (the ADC rounds ``x + 128``): with ``v = p/2 - 64``, ``2m + 128``
    is the block's mean pixel ``S / block**2``, so for 16x16-pixel blocks the codes are
    the host's :func:`ppaloc.place.lowres_image` exactly in ideal mode (the one
    saturation, at -128, gives the right code 0). ``spare`` is kept; returns
    ``(size / block, size / block)`` uint8.
    """
    sim, r = sensor.sim, sensor.roles
    sim.load_in(-1)
    sensor.run(_twice_mean, r.means, r.spare)
    last = sensor.size - 1
    return sim.scan_areg(r.means, 0, 0, last, last, block, block)


def _twice_mean(k: Kernel, out: Register, roots: Register) -> None:
    """``out := 2m - 1/2`` from ``roots = -m`` and ``IN = -1`` (``roots`` kept)."""
    k.bus2(out, NEWS, IN)  # 1/2
    k.bus(out, roots, NEWS)  # m - 1/2
    k.bus(NEWS, out)  # 1/2 - m
    k.bus(out, roots, NEWS)  # 2m - 1/2


def _halve_on(
    k: Kernel,
    roots: Register,
    scratch: Register,
    root_means: Register | None,
    levels: tuple[int, ...],
) -> None:
    """The halving tree's remaining ``levels`` from the finer blocks' means at their roots."""
    tree_levels(k, halve_level, roots, scratch, levels, levels)
    if root_means is not None:
        k.bus(root_means, roots)


def _reduce(
    k: Kernel,
    roots: Register,
    frame: Register,
    scratch: Register,
    root_means: Register | None,
    levels: tuple[int, ...],
) -> None:
    k.bus(roots, frame)  # -v
    tree_levels(k, halve_level, roots, scratch, levels, levels)
    if root_means is not None:
        k.bus(root_means, roots)  # +m at the block roots (e.g. for the descriptor)


def _spread_tree(
    k: Kernel, means: Register, roots: Register, root32: Register, levels: tuple[int, ...]
) -> None:
    k.res(means)
    k.WHERE(root32)
    k.mov(means, roots)
    k.all()
    for direction in (west, north):
        for step in levels:
            add_level(k, means, roots, direction, step)


def spread_copies(sensor: Sensor) -> None:
    """``means := -m`` over every block by FLAG-masked copies from the block roots.

    ``means := spare`` (``-m`` at the roots; a ``mov``), then per axis and ``s = 1, 2,
    ..., block / 2`` one ``scamp5_shift`` of ``means`` by ``s`` PEs written only where the
    in-block offset lies in ``[s, 2s)`` (a periodic ``load_pattern``), which copies the
    filled offsets ``[0, s)`` onward. A PE's value goes through the ``mov`` and one write
    per set bit of its in-block offsets (at most ``2 log2(block)``): the doubling tree
    instead adds every background PE's write noise into the sums (about 38 units per PE
    under the typical preset, against about 1). Exact in ideal mode. ``2 (block - 1)`` PE
    steps (62 on a 256 array).
    """
    sim, r = sensor.sim, sensor.roles
    temp = r.d.tmp_a
    sensor.run(_mov, r.means, r.spare)
    for axis, pull_from in ((1, west), (0, north)):
        step = 1
        while step < sensor.block:
            care = (step - 1) | (0xFF & ~(sensor.block - 1))  # don't care: below step, block
            if axis:
                sim.load_pattern(temp, 0, step, 0xFF, care)
            else:
                sim.load_pattern(temp, step, 0, care, 0xFF)
            sensor.run(_where_mask, temp)
            pull_shift(sim, r.means, pull_from, step)
            step *= 2
    sensor.run(_all)


def _mov(k: Kernel, y: Register, x: Register) -> None:
    k.mov(y, x)


def _where_mask(k: Kernel, mask: Register) -> None:
    k.WHERE(mask)


def _all(k: Kernel) -> None:
    k.all()
