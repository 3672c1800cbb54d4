"""The numpy engine: each ICW compiled once into bound, in-place numpy operations.

The building blocks are the simulator's ``_op_*`` methods (``ppaloc.sim.engine``), which
each row of ``isa.OPS`` names; closures are cached per instruction by the simulator.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ppaloc.sim.engines import in_order
from ppaloc.sim.isa import OPS, Instruction

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = ["NumpyEngine"]


class NumpyEngine:
    """Runs a kernel as a list of precompiled numpy closures (``engine="numpy"``)."""

    name = "numpy"

    def __init__(self, sim: Scamp5) -> None:
        self.sim = sim

    def supports(self, op: str) -> bool:
        """Every row of ``isa.OPS`` has a numpy building block."""
        return op in OPS

    def compile(self, instructions: tuple[Instruction, ...]) -> Callable[[], None]:
        """Closures for each ICW, called in order by the returned runner."""
        return in_order([self.sim._compile(ins) for ins in instructions])
