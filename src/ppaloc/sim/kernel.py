"""Kernels: recorded ICW sequences that run on the array, and replay cheaply.

``with sim.kernel() as k:`` records every instruction and macro issued through ``k``; at the
end of the block the kernel is compiled into a list of bound numpy operations and run once.
``k.run()`` (or ``sim.run(k)``) replays it without recording or compiling again. Like the
SCAMP-5 controller's instruction buffer, a kernel holds at most 1024 ICWs.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import TYPE_CHECKING

from ppaloc.errors import KernelError
from ppaloc.sim.isa import Instruction
from ppaloc.sim.macros import ProgramAPI

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = ["MAX_ICWS", "Kernel"]

#: Capacity of the SCAMP-5 ICW buffer (``ICW_STACK_CAP`` of the kernel API).
MAX_ICWS = 1024


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
        self._ops: list | None = None
        self._counts: dict[str, int] | None = None
        self._dwritten = None
        self._failed = False

    # ---------------------------------------------------------------- recording
    def __enter__(self) -> Kernel:
        self._check_not_failed()
        if self._sealed:
            raise KernelError("this kernel is already recorded; replay it with k.run()")
        self._open = True
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        self._open = False
        if exc_type is None:
            self._sealed = True
            self.run()
        else:
            self._failed = True

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
        n = len(self._recorded) + len(instructions)
        if n > MAX_ICWS:
            raise KernelError(
                f"kernel would hold {n} ICWs, more than the {MAX_ICWS} the SCAMP-5 "
                "instruction buffer holds: split the work into several kernels"
            )
        self._recorded.extend(instructions)

    # ------------------------------------------------------------------ running
    @property
    def instructions(self) -> tuple[Instruction, ...]:
        return tuple(self._recorded)

    @property
    def counts(self) -> dict[str, int]:
        from ppaloc.sim.engine import count_clocks

        return count_clocks(self._recorded)

    def __repr__(self) -> str:
        state = "recorded" if self._sealed else "recording"
        return f"Kernel({len(self._recorded)} ICWs, {state}, {self.counts})"

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
        """Run the kernel on its simulator (compiled once, on the first run)."""
        self._check_not_failed()
        if not self._sealed:
            raise KernelError("a kernel runs after its `with` block has ended")
        if self._ops is None:
            from ppaloc.sim.engine import count_clocks, written_digital

            self._ops = self.sim._compile_kernel(self._recorded)
            self._counts = count_clocks(self._recorded)
            self._dwritten = written_digital(self._recorded)
        self.sim._run_ops(self._ops, self._counts, self._dwritten)
