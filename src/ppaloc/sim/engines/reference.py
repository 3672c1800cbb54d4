"""The reference engine: one ICW at a time, whole planes, written to be read.

Every instruction is interpreted on fresh arrays straight from the semantics of docs/sim.md
(FLAG masks analogue writes; an unflagged neighbour drives 0; beyond the edge a transfer
carries 0 and DNEWS the boundary bit; R12 is written only where R0 is 1; every analogue
write saturates), with the noise model's draws taken in the same order as every other
engine (one draw index per written analogue destination and per noisy comparison, the
transfer gain read at the ICW's first index). It trades speed for obviousness: the fast
engines are checked against it (tests/sim/test_engines.py).

The arithmetic is float32 and in the documented order (local sources left to right, then
neighbour terms), so ideal results are the exact IEEE values every engine must produce.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from ppaloc.sim import semantics
from ppaloc.sim.isa import Instruction
from ppaloc.sim.registers import DNEWS_SELECTORS, FLAG, NEWS, PIX, R0, R1, R2, R12, Register

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = ["ReferenceEngine", "neighbour"]

_F32 = np.float32


def neighbour(plane: np.ndarray, dr: int, dc: int, fill: object) -> tuple[np.ndarray, np.ndarray]:
    """(value of element (r + dr, c + dc) with ``fill`` beyond the edge, inside mask)."""
    rows, cols = plane.shape
    padded = np.full((rows + 2, cols + 2), fill, dtype=plane.dtype)
    padded[1:-1, 1:-1] = plane
    inside = np.zeros((rows + 2, cols + 2), dtype=bool)
    inside[1:-1, 1:-1] = True
    window = (slice(1 + dr, 1 + dr + rows), slice(1 + dc, 1 + dc + cols))
    return padded[window].copy(), inside[window].copy()


class ReferenceEngine:
    """Interprets each ICW on the simulator's planes (``engine="reference"``)."""

    name = "reference"

    def __init__(self, sim: Scamp5) -> None:
        self.sim = sim
        self._ops: dict[str, Callable[[Instruction], None]] = {
            "nop": lambda ins: None,
            "rpix": self._rpix,
            "bus": lambda ins: self._transfer(ins, 1),
            "bus2": lambda ins: self._transfer(ins, 2),
            "bus3": lambda ins: self._transfer(ins, 3),
            "where": self._where,
            "all": self._all,
            "SET": lambda ins: self._fill(ins, True),
            "CLR": lambda ins: self._fill(ins, False),
            "MOV": lambda ins: self._store(ins.dsts[0], self._d(ins.srcs[0]).copy()),
            "NOT": lambda ins: self._store(ins.dsts[0], ~self._d(ins.srcs[0])),
            "OR": lambda ins: self._store(ins.dsts[0], self._or(ins.srcs)),
            "NOR": lambda ins: self._store(ins.dsts[0], ~self._or(ins.srcs)),
            "WHERE": lambda ins: self._set_flag(self._or(ins.srcs)),
            "LATCH": lambda ins: np.copyto(sim._latch, self._or(ins.srcs)),
            "LATCHN": lambda ins: np.copyto(sim._latch, ~self._or(ins.srcs)),
            "UNLATCH": lambda ins: self._store(ins.dsts[0], sim._latch.copy()),
            "DNEWS0": lambda ins: self._dnews(ins, False),
            "DNEWS1": lambda ins: self._dnews(ins, True),
            "busn": lambda ins: self._transfer(ins, len(ins.dsts)),
            "sq": lambda ins: self._transfer(ins, 1),
            "blurset": lambda ins: None,
            "PROP_R": lambda ins: np.copyto(sim._latch, self._or(ins.srcs)),
            "blur": lambda ins: self._blur(ins, True, True),
            "blurh": lambda ins: self._blur(ins, True, False),
            "blurv": lambda ins: self._blur(ins, False, True),
            "PROP0": lambda ins: self._prop(False),
            "PROP1": lambda ins: self._prop(True),
        }

    def supports(self, op: str) -> bool:
        """Whether this engine has its own model of ``op`` (else it runs the numpy one)."""
        return op in self._ops

    def compile(self, instructions: tuple[Instruction, ...]) -> Callable[[], None]:
        """A runner interpreting ``instructions`` in order (nothing is precomputed).

        An op without a model here (a row added to ``isa.OPS`` later) runs through the
        numpy engine's building block.
        """
        steps = []
        for ins in instructions:
            own = self._ops.get(ins.op)
            if own is None:
                shared = self.sim._compile(ins)
                steps.append((lambda ins, op=shared: op(), ins))
            else:
                steps.append((own, ins))

        def run() -> None:
            for step, ins in steps:
                step(ins)

        return run

    # ------------------------------------------------------------------ planes
    def _a(self, reg: Register) -> np.ndarray:
        return self.sim._analog_planes[reg.index]

    def _d(self, reg: Register) -> np.ndarray:
        return self.sim._d[reg.index]

    @property
    def _flag(self) -> np.ndarray:
        return self.sim._d[FLAG.index]

    def _set_flag(self, value: np.ndarray) -> None:
        np.copyto(self._flag, value)
        self.sim._flag_masked = None  # the fast engines' cached mask is stale

    # ---------------------------------------------------------------- analogue
    def _sum(self, srcs: tuple[Register, ...]) -> np.ndarray:
        """Local sources left to right, then each neighbour's NEWS (0 if unflagged)."""
        local = [self._a(s) for s in srcs if s.role != "neighbour"]
        total = local[0].copy() if local else np.zeros(self._flag.shape, _F32)
        for x in local[1:]:
            total = total + x
        driven = np.where(self._flag, self._a(NEWS), _F32(0))  # an unflagged PE drives nothing
        for s in srcs:
            if s.role == "neighbour":
                value, inside = neighbour(driven, *s.direction.offset, fill=_F32(0))
                total = np.where(inside, total + value, total)  # beyond the edge: no term
        return total

    def _transfer(self, ins: Instruction, parts: int) -> None:
        """Every destination := -(sum of sources) / parts, FLAG-masked, saturated."""
        noise = self.sim.noise
        flag = self._flag
        total = self._sum(ins.srcs)
        if noise.ideal:
            if parts == 1:
                value = -total
            elif parts == 2:
                value = total * _F32(-0.5)  # exact, as a division by -2
            else:
                value = total / _F32(-parts)
            value = np.clip(value, _F32(-128), _F32(127))
        else:  # the ICW's transfer error scales the value (the bus negates)
            value = total * _F32(noise.negated_gain() / parts)
        for dst in ins.dsts:
            written = value
            if dst.role == "neighbour":  # pushed: the receiver gets its sender's value
                dr, dc = dst.direction.offset
                sent = np.where(flag, written, _F32(0))
                written, _ = neighbour(sent, -dr, -dc, fill=_F32(0))
            if not noise.ideal:  # the receiving cell's offset and temporal noise
                written = written + noise.offsets[dst.index]
                written = written + noise.window(divided=parts > 1)
                written = np.clip(written, _F32(-128), _F32(127))
            plane = self._a(dst)
            np.copyto(plane, np.where(flag, written, plane))

    def _blur(self, ins: Instruction, horizontal: bool, vertical: bool) -> None:
        """A bus transfer of ``semantics.diffuse(x)`` (links enabled by R1, R2)."""
        noise = self.sim.noise
        (dst,), (src,) = ins.dsts, ins.srcs
        spread = semantics.diffuse(
            self._a(src), horizontal=horizontal, vertical=vertical, r1=self._d(R1), r2=self._d(R2)
        )
        if noise.ideal:
            value = -spread
        else:  # one transfer: its gain, the written cell's offset, one noise draw
            value = spread * _F32(noise.negated_gain())
            value = value + noise.offsets[dst.index]
            value = value + noise.window()
        value = np.clip(value, _F32(-128), _F32(127))
        plane = self._a(dst)
        np.copyto(plane, np.where(self._flag, value, plane))

    def _prop(self, boundary: bool) -> None:
        """R12 := ``semantics.propagate`` of R12 through R0 along the DNEWS selectors."""
        selectors = {d: self._d(r) for d, r in DNEWS_SELECTORS.items()}
        self._store(R12, semantics.propagate(self._d(R12), self._d(R0), selectors, boundary))

    def _where(self, ins: Instruction) -> None:
        total = self._sum(ins.srcs)
        if not self.sim.noise.ideal:  # the comparator sees a noisy sum
            total = total + self.sim.noise.window()
        self._set_flag(total > 0)

    def _all(self, ins: Instruction) -> None:
        self._set_flag(np.ones(self._flag.shape, dtype=bool))

    def _rpix(self, ins: Instruction) -> None:
        np.copyto(self._a(PIX), self.sim.noise.pixel_offset)

    # ----------------------------------------------------------------- digital
    def _store(self, dst: Register, value: np.ndarray, r0: np.ndarray | None = None) -> None:
        """dst := value; R12 only where R0 (as given, else as now) is 1."""
        plane = self._d(dst)
        if dst.index == R12.index:
            value = np.where(self._d(R0) if r0 is None else r0, value, plane)
        np.copyto(plane, value)

    def _fill(self, ins: Instruction, value: bool) -> None:
        """Every destination := value, all at once (R12's mask is R0 before this ICW)."""
        r0 = self._d(R0).copy()
        for dst in ins.dsts:
            self._store(dst, np.full(self._flag.shape, value), r0)

    def _or(self, srcs: tuple[Register, ...]) -> np.ndarray:
        out = np.zeros(self._flag.shape, dtype=bool)
        for s in srcs:
            out = out | self._d(s)
        return out

    def _dnews(self, ins: Instruction, edge: bool) -> None:
        """OR of the source of each neighbour the element's own selector names."""
        src = self._d(ins.srcs[0])
        out = np.zeros(self._flag.shape, dtype=bool)
        for direction, selector in DNEWS_SELECTORS.items():
            value, _ = neighbour(src, *direction.offset, fill=edge)
            out = out | (self._d(selector) & value)
        self._store(ins.dsts[0], out)
