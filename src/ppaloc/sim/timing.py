"""Modelled time and energy of a SCAMP-5 program (first version; constants refined later)."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field

__all__ = ["CLOCK_CLASSES", "StageCost", "TimingConstants", "TimingModel", "TimingReport"]

CLOCK_CLASSES = ("analog", "digital", "dnews", "nop")


@dataclass(frozen=True)
class TimingConstants:
    """Timing and energy constants (sources in docs/sim-controller.md)."""

    kernel_launch_us: float = 1.0
    call_overhead_us: float = 2.0
    call_us: Mapping[str, float] = field(
        default_factory=lambda: {"global_sum_16": 14.0, "global_sum_64": 28.0}
    )
    call_default_us: float = 1.0
    energy_pj_per_pe_icw: float = 1.9
    system_power_w: float = 2.5


@dataclass
class StageCost:
    """Accumulated cost of one stage."""

    name: str
    icws: int = 0
    kernels: int = 0
    calls: int = 0
    us: float = 0.0


@dataclass
class TimingReport:
    """Per-stage costs and totals."""

    stages: list[StageCost]
    total_us: float
    energy_uj: float

    def __str__(self) -> str:
        lines = [f"{'stage':<24}{'ICWs':>10}{'kernels':>9}{'calls':>7}{'us':>12}"]
        for s in self.stages:
            lines.append(f"{s.name:<24}{s.icws:>10}{s.kernels:>9}{s.calls:>7}{s.us:>12.2f}")
        lines.append(f"total {self.total_us:.2f} us, energy {self.energy_uj:.3f} uJ")
        return "\n".join(lines)


class TimingModel:
    """Accumulates modelled time of kernels and controller calls, grouped in stages."""

    def __init__(
        self,
        clock_hz: float = 10e6,
        constants: TimingConstants | None = None,
        *,
        pe_count: int = 256 * 256,
    ) -> None:
        self.clock_hz = float(clock_hz)
        self.constants = constants or TimingConstants()
        self.pe_count = pe_count
        self.reset()

    def reset(self) -> None:
        """Forget all charged costs."""
        self._stages: dict[str, StageCost] = {}
        self._stack: list[str] = []
        self._total_us = 0.0
        self._icws = 0

    @property
    def now_us(self) -> float:
        """Modelled time elapsed since construction or the last reset, in microseconds."""
        return self._total_us

    def _current(self) -> StageCost:
        name = "/".join(self._stack) or "(unstaged)"
        if name not in self._stages:
            self._stages[name] = StageCost(name)
        return self._stages[name]

    def charge_kernel(self, counts: Mapping[str, int]) -> None:
        """Charge one kernel run given its ICW counts per clock class."""
        n = sum(int(v) for v in counts.values())
        us = self.constants.kernel_launch_us + n / self.clock_hz * 1e6
        s = self._current()
        s.icws += n
        s.kernels += 1
        s.us += us
        self._icws += n
        self._total_us += us

    def charge_call(self, name: str, units: float = 1.0) -> None:
        """Charge one controller call by its SCAMP-5 name."""
        c = self.constants
        us = c.call_overhead_us + c.call_us.get(name, c.call_default_us) * units
        s = self._current()
        s.calls += 1
        s.us += us
        self._total_us += us

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Group the costs charged inside the ``with`` block under ``name``."""
        self._stack.append(name)
        try:
            yield
        finally:
            self._stack.pop()

    def report(self) -> TimingReport:
        """Per-stage table and totals."""
        c = self.constants
        energy = (
            self._icws * self.pe_count * c.energy_pj_per_pe_icw * 1e-6
            + c.system_power_w * self._total_us
        )
        return TimingReport(list(self._stages.values()), self._total_us, energy)
