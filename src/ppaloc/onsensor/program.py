"""Building blocks of the on-sensor programs: recorded kernels, moves, halving and adding trees.

Every helper here issues ICWs through a kernel recorder ``k`` (a
:class:`ppaloc.sim.Kernel`), so a pipeline stage records its kernel once and replays it
on every frame (:class:`KernelCache`, which knows a kernel by its builder and the values
it is built from, never by a hand-typed name). Conventions (docs/onsensor.md):

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

import dataclasses
import enum
import os
import types
from collections.abc import Callable
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.sim import NEWS, Direction, Kernel, Register, Scamp5, east, south
from ppaloc.sim.isa import Instruction
from ppaloc.sim.macros import ProgramAPI

__all__ = [
    "CHECK_KERNELS",
    "KernelCache",
    "add_level",
    "halve_level",
    "kernel_key",
    "pull",
    "pull_shift",
    "scale_negated",
    "tree_levels",
]

CHECK_KERNELS = "PPALOC_CHECK_KERNELS"
"""Environment variable: ``1`` makes every :class:`KernelCache` record each call again and
refuse a replay whose recording would differ (the test suite's check of the keys)."""

_PLAIN = (int, float, str, bool, bytes, type(None), Register, enum.Enum)


def _value_key(value: Any, what: str) -> Any:
    """A hashable key of a value a kernel is built from, or a one-line error: a value
    whose state may change (an object, a list, an array) could change the body under the
    same key."""
    if isinstance(value, _PLAIN):
        return (type(value).__name__, value)
    if isinstance(value, np.integer | np.floating | np.bool_):
        return _value_key(value.item(), what)
    if isinstance(value, tuple | frozenset):
        return (type(value).__name__, tuple(_value_key(v, what) for v in value))
    if isinstance(value, types.FunctionType):
        return kernel_key(value, ())
    params = getattr(type(value), "__dataclass_params__", None)
    if params is not None and params.frozen:
        fields = tuple(_value_key(getattr(value, f.name), what) for f in dataclasses.fields(value))
        return (type(value).__qualname__, fields)
    raise PpalocError(
        f"a kernel builder's {what} is {type(value).__name__} {value!r:.60}: a kernel is "
        "cached by its builder and the values it is built from, which must be plain "
        "(registers, numbers, text, tuples, frozen dataclasses); pass what it reads as "
        "arguments instead"
    )


def kernel_key(build: Callable[..., Any], args: tuple) -> tuple:
    """What identifies the kernel ``build(k, *args)`` records: the builder's code, the
    plain values its closure and defaults hold, and ``args``.

    Examples
    --------
    >>> from ppaloc.sim import A, B
    >>> kernel_key(lambda k, r: k.mov(r, A), (B,)) == kernel_key(lambda k, r: k.mov(r, A), (B,))
    False
    >>> def mov(k, r):
    ...     k.mov(r, A)
    >>> kernel_key(mov, (B,)) == kernel_key(mov, (B,)) != kernel_key(mov, (A,))
    True
    """
    if not isinstance(build, types.FunctionType):
        raise PpalocError(
            f"a kernel builder must be a function, not {type(build).__name__} (a bound "
            "method carries its object's state): write it as a function of its arguments"
        )
    closure = tuple(
        _value_key(cell.cell_contents, f"closure value {name!r}")
        for name, cell in zip(build.__code__.co_freevars, build.__closure__ or (), strict=True)
    )
    defaults = tuple(_value_key(v, "default") for v in build.__defaults__ or ())
    kwdefaults = tuple(
        (k, _value_key(v, "default")) for k, v in sorted((build.__kwdefaults__ or {}).items())
    )
    return (
        build.__code__,
        closure,
        defaults,
        kwdefaults,
        tuple(_value_key(a, "argument") for a in args),
    )


def _lasting(build: Callable[..., Any]) -> bool:
    """Whether ``build`` is a function that lives as long as its module (defined at module
    or class level, no closure, no defaults): its identity then stands for its code."""
    return (
        isinstance(build, types.FunctionType)
        and build.__closure__ is None
        and not build.__defaults__
        and not build.__kwdefaults__
        and "<locals>" not in build.__qualname__
        and "<lambda>" not in build.__qualname__
    )


class _Recorder(ProgramAPI):
    """Records a kernel body without running it (the check of :class:`KernelCache`)."""

    def __init__(self) -> None:
        self.recorded: list[Instruction] = []
        self.heap = False

    def _emit(self, instructions: tuple[Instruction, ...]) -> None:
        self.recorded.extend(instructions)

    def move_to_heap(self, flag: bool = True) -> None:
        """As :meth:`ppaloc.sim.Kernel.move_to_heap`: where the body is kept, not what it is."""
        self.heap = bool(flag)


class KernelCache:
    """Record each kernel once, by what it is, and replay it afterwards.

    ``run(build, *args)`` records ``build(k, *args)`` the first time its key
    (:func:`kernel_key`: the builder's code, the plain values of its closure and defaults,
    and ``args``) is seen, which runs it once, and replays the recording afterwards. So a
    body can only depend on values its key holds: a closure over an object whose state
    may change is refused. Keys whose recordings are the same ICWs, kept in the same place
    (the ICW stack, or the heap after ``move_to_heap``), share one kernel (the first
    recorded), so every distinct body holds the ICW stack once.

    Parameters
    ----------
    sim : Scamp5
        The simulator the kernels run on.
    check : bool, optional
        Record every call again and refuse one whose body differs from the cached
        kernel's (default: the environment variable :data:`CHECK_KERNELS` is ``1``).
    """

    def __init__(self, sim: Scamp5, *, check: bool | None = None) -> None:
        self.sim = sim
        self.check = os.environ.get(CHECK_KERNELS) == "1" if check is None else bool(check)
        self._by_key: dict[tuple, Kernel] = {}
        self._by_body: dict[tuple[tuple[Instruction, ...], bool], Kernel] = {}
        # (builder, args, their types) -> kernel, for builders that live as long as their
        # module (no closure, no defaults): the key of a call seen before, without
        # walking its values again
        self._seen: dict[tuple, Kernel] = {}

    def run(self, build: Callable[..., Any], *args: Any) -> Kernel:
        """Run the kernel ``build(k, *args)`` records (recorded on the first call)."""
        try:
            seen = (build, args, tuple(map(type, args)))
            kernel = self._seen.get(seen)
        except TypeError:  # an unhashable value: kernel_key names it
            seen, kernel = None, None
        if kernel is None:
            key = kernel_key(build, args)
            kernel = self._by_key.get(key)
            if kernel is None:
                with self.sim.kernel() as kernel:
                    build(kernel, *args)
                body = (kernel.instructions, kernel.on_heap)  # the same ICWs, kept alike
                kernel = self._by_key[key] = self._by_body.setdefault(body, kernel)
                if seen is not None and _lasting(build):
                    self._seen[seen] = kernel
                return kernel
            if seen is not None and _lasting(build):
                self._seen[seen] = kernel
        if self.check:
            again = _Recorder()
            build(again, *args)
            if again.heap != kernel.on_heap:
                raise AssertionError(
                    f"kernel {build.__qualname__}{args!r} moves itself to the heap on one "
                    "recording and not on another"
                )
            if tuple(again.recorded) != kernel.instructions:
                raise AssertionError(
                    f"kernel {build.__qualname__}{args!r} records a different body under "
                    "the same key: it reads a value its key does not hold"
                )
        kernel.run()
        return kernel

    @property
    def kernels(self) -> int:
        """Distinct kernel bodies recorded."""
        return len(self._by_body)

    @property
    def icws(self) -> int:
        """ICWs of every distinct recorded body that stays on the ICW stack (what they
        hold of it; a kernel moved to the heap holds nothing)."""
        return sum(len(k) for k in self._by_body.values() if not k.on_heap)


def neg_copy(k: Kernel, y: Register, x: Register) -> None:
    """``y := -x`` (one ``bus``: a bus transfer negates)."""
    k.bus(y, x)


def and_planes(k: Kernel, y: Register, a: Register, b: Register) -> None:
    """``y := a AND b`` (digital)."""
    k.AND(y, a, b)


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


def tree_levels(
    k: Kernel,
    level: Callable[..., None],
    x: Register,
    y: Register,
    east_steps: tuple[int, ...],
    south_steps: tuple[int, ...],
) -> None:
    """A tree over blocks to their top-left PEs: ``level`` (:func:`halve_level` or
    :func:`add_level`) at each of ``east_steps``, then each of ``south_steps``."""
    for step in east_steps:
        level(k, x, y, east, step)
    for step in south_steps:
        level(k, x, y, south, step)


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
