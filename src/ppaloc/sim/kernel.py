"""Kernels: recorded ICW sequences that run on the array, and replay cheaply.

``with sim.kernel() as k:`` records every instruction and macro issued through ``k``; at the
end of the block the kernel is compiled into a list of bound numpy operations and run once.
``k.run()`` (or ``sim.run(k)``) replays it without recording or compiling again.

The ICW stack: as in the SCAMP-5 library, recorded kernels keep their ICWs on one stack of
1024 (``ICW_STACK_CAP``) per simulator, shared by every kernel alive at once (a ``static``
kernel there lives for the whole program; here a kernel leaves the stack when it is garbage
collected, as a dynamic kernel's destructor frees it, or at the end of its recording after
``k.move_to_heap(True)``). An ICW recorded when the stack is full is dropped, as the
library drops it; where the library is silent, the end of the recording warns once
(:class:`IcwStackWarning`), ``k.dropped`` counts the ICWs lost and ``repr(k)`` shows them.

A kernel runs when its block ends, so ``sim.read`` inside an open block would show the
planes as they were before it: it raises :class:`~ppaloc.errors.KernelError` instead.
"""

from __future__ import annotations

import itertools
import warnings
import weakref
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

from ppaloc.errors import KernelError
from ppaloc.sim.isa import Instruction
from ppaloc.sim.macros import ProgramAPI

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = ["MAX_ICWS", "IcwStack", "IcwStackWarning", "Kernel", "icw_stack", "recording"]

#: Capacity of the SCAMP-5 ICW stack (``ICW_STACK_CAP`` of the kernel API).
MAX_ICWS = 1024


class IcwStack:
    """The ICWs each live kernel of one simulator holds on the shared stack."""

    def __init__(self) -> None:
        self._held: dict[int, int] = {}
        self._ids = itertools.count()

    @property
    def used(self) -> int:
        """ICWs held by every live kernel (recorded or recording)."""
        return sum(self._held.values())

    def free(self) -> int:
        """ICWs that can still be pushed (the cap less what every live kernel holds)."""
        return max(0, MAX_ICWS - self.used)

    def open(self) -> int:
        """A new kernel on the stack (holding nothing yet); returns its key."""
        key = next(self._ids)
        self._held[key] = 0
        return key

    def hold(self, key: int, n: int) -> None:
        """Kernel ``key`` now holds ``n`` ICWs."""
        self._held[key] = n

    def release(self, key: int) -> None:
        """Kernel ``key`` leaves the stack (freed, failed, or moved to the heap)."""
        self._held.pop(key, None)


_STACKS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_RECORDING: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class IcwStackWarning(UserWarning):
    """A kernel lost ICWs: the shared 1024-ICW stack was full while it was recorded."""


def recording(sim: Scamp5) -> int:
    """How many ``with sim.kernel()`` blocks of ``sim`` are open (recording, not run yet)."""
    return _RECORDING.get(sim, 0)


def icw_stack(sim: Scamp5) -> IcwStack:
    """The shared ICW stack of ``sim`` (created on first use)."""
    stack = _STACKS.get(sim)
    if stack is None:
        stack = _STACKS[sim] = IcwStack()
    return stack


class Kernel(ProgramAPI):
    """A recorded sequence of ICWs bound to one simulator.

    Create it with ``sim.kernel()``. Inside ``with``, every primitive and macro method
    (``k.bus``, ``k.mov``, ``k.AND``, ...) appends its ICWs. On leaving the block without an
    exception the kernel runs once; later runs replay the compiled operations.

    Attributes
    ----------
    sim : Scamp5
        The simulator it runs on.
    instructions : tuple of Instruction
        The recorded ICWs, in order.
    counts : dict
        ICWs per clock class (``"analog"``, ``"digital"``, ``"dnews"``, ``"nop"``).
    """

    def __init__(self, sim: Scamp5) -> None:
        self.sim = sim
        self._recorded: list[Instruction] = []
        self._open = False
        self._sealed = False
        self._ops: Callable[[], None] | None = None
        self._icws: tuple[Instruction, ...] | None = None
        self._counts: tuple[tuple[str, int], ...] | None = None
        self._dwritten = None
        self._runner: Callable[[], None] | None = None  # a run while nothing observes
        self._failed = False
        self._heap = False
        self._stack_key: int | None = None
        #: ICWs dropped because the shared ICW stack was full.
        self.dropped = 0

    # ---------------------------------------------------------------- recording
    def __enter__(self) -> Kernel:
        self._check_not_failed()
        if self._sealed:
            raise KernelError("this kernel is already recorded; replay it with k.run()")
        self._open = True
        _RECORDING[self.sim] = recording(self.sim) + 1
        stack = icw_stack(self.sim)
        self._stack_key = key = stack.open()
        weakref.finalize(self, stack.release, key)
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self._open = False
        _RECORDING[self.sim] = recording(self.sim) - 1
        stack = icw_stack(self.sim)
        if exc_type is not None or self._heap:
            stack.release(self._stack_key)
        if exc_type is None:
            self._sealed = True
            if self.dropped:
                warnings.warn(
                    f"this kernel lost {self.dropped} of its {len(self) + self.dropped} ICWs: "
                    f"the {MAX_ICWS}-ICW stack that live kernels share is full (let kernels "
                    "no longer needed go, or call k.move_to_heap(True) in their blocks); "
                    "k.dropped counts them",
                    IcwStackWarning,
                    stacklevel=2,
                )
            self.run()
        else:
            self._failed = True

    def move_to_heap(self, flag: bool = True) -> None:
        """``move_to_heap(true)`` of the kernel API: at the end of its recording the kernel
        leaves the shared ICW stack (it is kept elsewhere), freeing its room for others."""
        if not self._open:
            raise KernelError("move_to_heap is called inside the kernel's `with` block")
        self._heap = bool(flag)

    def leave_stack(self) -> None:
        """The kernel leaves the shared ICW stack now, as when it is garbage collected (the
        kernel API's destructor: a C++ kernel object deleted), freeing its room for others;
        it keeps its recording, to be inspected."""
        if self._stack_key is not None:
            icw_stack(self.sim).release(self._stack_key)

    @property
    def on_heap(self) -> bool:
        """Whether the kernel left the shared ICW stack at the end of its recording
        (:meth:`move_to_heap`)."""
        return self._heap

    def _check_not_failed(self) -> None:
        if self._failed:
            raise KernelError(
                "the recording of this kernel failed; record a new one with sim.kernel()"
            )

    def _emit(self, instructions: tuple[Instruction, ...]) -> None:
        if self._sealed or not self._open:
            raise KernelError(
                "instructions can be added to a kernel only inside its `with sim.kernel() "
                "as k:` block; record a new kernel for new instructions"
            )
        stack = icw_stack(self.sim)
        room = stack.free()
        kept = instructions[:room]
        self.dropped += len(instructions) - len(kept)
        self._recorded.extend(kept)
        stack.hold(self._stack_key, len(self._recorded))

    # ------------------------------------------------------------------ running
    @property
    def instructions(self) -> tuple[Instruction, ...]:
        if self._icws is None:  # recording (or never run): the ICWs so far
            return tuple(self._recorded)
        return self._icws

    @property
    def counts(self) -> dict[str, int]:
        from ppaloc.sim.engine import count_clocks

        return count_clocks(self._recorded)

    def __repr__(self) -> str:
        state = "recorded" if self._sealed else "recording"
        lost = f", {self.dropped} dropped (ICW stack full)" if self.dropped else ""
        return f"Kernel({len(self._recorded)} ICWs{lost}, {state}, {self.counts})"

    def __len__(self) -> int:
        return len(self._recorded)

    def __iter__(self) -> Iterator[Instruction]:
        return iter(self._recorded)

    def listing(self) -> str:
        """One ICW per line, with the macro call each came from."""
        lines = []
        for n, ins in enumerate(self._recorded):
            origin = f"  # {ins.origin}" if ins.origin else ""
            lines.append(f"{n:4d}  {ins}{origin}")
        return "\n".join(lines)

    def run(self) -> None:
        """Run the kernel on its simulator (compiled once, on the first run).

        The simulator's observers receive a :class:`~ppaloc.sim.observe.KernelRun` of
        this kernel after each run.
        """
        runner = self._runner
        if runner is None:  # compiled only once sealed and whole, so a replay checks nothing
            runner = self._compile()
        sim = self.sim
        if sim._observers:
            sim._run_ops(self._ops, self._counts, self._dwritten)
            sim._observed_icws(self, self._icws)
        else:  # the same run, its choices made once (Scamp5._kernel_runner)
            runner()

    def _compile(self) -> Callable[[], None]:
        """The first run's checks, then the runner, what each run charges and touches,
        and the run of all of it while nothing observes."""
        from ppaloc.sim.engine import count_clocks, written_digital

        self._check_not_failed()
        if not self._sealed:
            raise KernelError("a kernel runs after its `with` block has ended")
        self._icws = tuple(self._recorded)  # sealed: what observers receive
        self._counts = tuple(count_clocks(self._recorded).items())  # the timing's key
        self._dwritten = written_digital(self._recorded)
        self._ops = self.sim._compile_kernel(self._recorded)
        self._runner = self.sim._kernel_runner(self._ops, self._counts, self._dwritten)
        return self._runner
