"""Building blocks of the on-sensor programs: recorded kernels, moves, halving and adding trees.

Every helper here issues ICWs through a kernel recorder ``k`` (a
:class:`ppaloc.sim.Kernel`), so a pipeline stage records its kernel once and replays it
on every frame (:class:`KernelCache`). Conventions (docs/onsensor.md):

- ``pull(k, y, x, dir, d)``: ``y`` takes the ``x`` of the element ``d`` steps away in
  ``dir`` (``movx``/``mov2x`` chains: one analogue ICW per step, NEWS as scratch).
- ``halve_level(k, x, y, dir, d)``: with ``x = -q``, ``x := -(q + q[+d dir]) / 2``, ``y``
  scratch. The sum ``q + q'`` passes through ``NEWS`` with the sign that keeps it inside
  [-128, 127] for values in [-64, 63.5] (block means) or [0, 63.5] (halved differences),
  so nothing saturates and every value stays an exact dyadic rational.
- ``add_level(k, x, y, dir, d)``: ``x := x + x[+d dir]`` (the ``add`` macro), for adding
  trees of small integers and for doubling a pattern over a zero background.
"""

from __future__ import annotations

from collections.abc import Callable

from ppaloc.sim import NEWS, Direction, Kernel, Register, Scamp5

__all__ = ["KernelCache", "add_level", "halve_level", "pull", "pull_shift", "scale_negated"]


class KernelCache:
    """Record each named kernel on first use and replay it afterwards.

    Parameters
    ----------
    sim : Scamp5
        The simulator the kernels run on.
    """

    def __init__(self, sim: Scamp5) -> None:
        self.sim = sim
        self._kernels: dict[str, Kernel] = {}

    def run(self, name: str, build: Callable[[Kernel], None]) -> None:
        """Run kernel ``name``; ``build(k)`` records it the first time (and runs it once)."""
        kernel = self._kernels.get(name)
        if kernel is None:
            with self.sim.kernel() as kernel:
                build(kernel)
            self._kernels[name] = kernel
        else:
            kernel.run()

    def icws(self, name: str) -> int:
        """ICWs of the recorded kernel ``name``."""
        return len(self._kernels[name])

    def __contains__(self, name: str) -> bool:
        return name in self._kernels


def pull(k: Kernel, y: Register, x: Register, direction: Direction, d: int) -> None:
    """``y := x`` of the element ``d`` steps away in ``direction`` (``d`` analogue ICWs, >= 2).

    Beyond the array edge the moved value is 0.
    """
    if d < 1:
        raise ValueError(f"pull distance must be >= 1, got {d}")
    if d == 1:
        k.movx(y, x, direction)
        return
    k.mov2x(y, x, direction, direction)
    left = d - 2
    while left >= 2:
        k.mov2x(y, y, direction, direction)
        left -= 2
    if left:
        k.movx(y, y, direction)


def pull_shift(sim: Scamp5, reg: Register, direction: Direction, d: int) -> None:
    """Controller ``shift`` so that ``reg`` takes the value ``d`` steps away in ``direction``.

    ``scamp5_shift`` moves the picture; pulling from the east moves it west, and so on.
    """
    dr, dc = direction.offset
    # shift(reg, h, v): new[r, c] = old[r + v, c - h]; we want new[r, c] = old[r + d dr, c + d dc]
    sim.shift(reg, -d * dc, d * dr)


def halve_level(k: Kernel, x: Register, y: Register, direction: Direction, d: int) -> None:
    """One level of a halving tree: with ``x = -q``, ``x := -(q + q') / 2``, ``q'`` ``d`` away.

    ``y`` is scratch. ``NEWS = -(x + y) = q + q'`` must fit a register (values in
    [-64, 63.5], or [0, 63.5]); ``bus2`` then halves it exactly into ``x`` (and ``y``).
    """
    pull(k, y, x, direction, d)
    k.bus(NEWS, x, y)
    k.bus2(x, y, NEWS)


def add_level(k: Kernel, x: Register, y: Register, direction: Direction, d: int) -> None:
    """One level of an adding tree: ``x := x + x'`` with ``x'`` ``d`` steps away (``y`` scratch)."""
    pull(k, y, x, direction, d)
    k.add(x, x, y)


def scale_negated(k: Kernel, x: Register, sign: int, exponent: int, y: Register) -> Register:
    """Leave ``-(base * 2**exponent)`` in ``x`` or ``y``, given ``x = sign * base``.

    Only halving (``bus2`` with ``NEWS`` as the second destination, as in ``divq``) and
    adding are used, so the result is exact. ``exponent`` is at most 1 (one doubling).

    Returns
    -------
    Register
        The register holding the result (``x`` or ``y``).
    """
    if exponent > 1:
        raise ValueError(f"exponent {exponent} > 1 needs more than one doubling")
    cur, other, s = x, y, sign
    if exponent == 1:
        k.mov(other, cur)  # NEWS = -x
        k.bus(NEWS, cur, other)  # NEWS = -2x
        k.bus(other, NEWS)  # other = 2x = 2 sign base
        cur, other = other, cur
    for _ in range(-exponent):
        k.bus2(other, NEWS, cur)  # other = -cur / 2
        cur, other, s = other, cur, -s
    if s != -1:
        k.bus(other, cur)
        cur = other
    return cur
