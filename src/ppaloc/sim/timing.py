"""Modelled time and energy of a SCAMP-5 program.

A program on the simulated array costs time in three ways, as on the real device:

1. **ICWs.** Every instruction control word (ICW) takes a number of clock cycles that
   depends on its clock class (``"analog"``, ``"digital"``, ``"dnews"``, ``"nop"``; the
   classes of the official ``scamp5_icw.hpp``), at ``clock_hz`` (10 MHz by default).
2. **Kernel launches.** Each run of a kernel (including a replay) pays a fixed launch
   overhead on the controller.
3. **Controller calls.** Each host-side ``scamp5_*`` call (DAC loads, address patterns,
   shifts, readouts) pays a per-call overhead plus its own cost, fixed and/or per unit
   (per event slot for ``scan_events``, per pixel step for ``shift``, ...).

Energy is the chip's operations (ICWs x processing elements x energy per PE-operation)
plus the system's power times the modelled time.

Every constant lives in :class:`TimingConstants` with its unit and public source (or the
word *estimate*); the free overheads are calibrated on the AnalogNet stage times measured
on SCAMP-5 hardware (:data:`ANALOGNET_STAGES`, :func:`analognet_calibration`). See
docs/sim-controller.md for the derivation.

Examples
--------
>>> t = TimingModel()
>>> with t.stage("capture"):
...     t.charge_kernel({"digital": 10})
>>> round(t.now_us, 3)  # launch 0.33 us + 10 digital cycles at 10 MHz
1.33
"""

from __future__ import annotations

import contextlib
import numbers
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Any

from ppaloc.errors import SimulatorError

__all__ = [
    "ANALOGNET_STAGES",
    "CLOCK_CLASSES",
    "DEFAULT_CLOCK_HZ",
    "CallCost",
    "StageCost",
    "TimingConstants",
    "TimingError",
    "TimingModel",
    "TimingReport",
    "analognet_calibration",
]

#: ICW clock classes a kernel's counts may name (``scamp5_icw.hpp``: SCAMP5_CLOCK_*).
CLOCK_CLASSES: tuple[str, ...] = ("analog", "digital", "dnews", "nop")

#: SCAMP-5 instruction clock (Carey et al., "A 100,000 fps vision sensor with embedded
#: 535 GOPS/W 256x256 SIMD processor array", VLSI Circuits 2013: 10 MHz array clock).
DEFAULT_CLOCK_HZ = 10e6

_UNSTAGED = "(unstaged)"


class TimingError(SimulatorError, ValueError):
    """A bad argument to the timing model (also a ``ValueError``, as it always was)."""


class UnknownStageError(SimulatorError, KeyError):
    """A report has no stage of that name (also a ``KeyError``, as a failed lookup)."""

    __str__ = Exception.__str__  # the message, not KeyError's quoted repr


@dataclass(frozen=True)
class CallCost:
    """Modelled cost of one controller call, on top of the common per-call overhead.

    Attributes
    ----------
    fixed_us : float
        Fixed cost of the call in microseconds.
    per_unit_us : float
        Cost per unit (see ``unit``) in microseconds.
    per_unit_icws : Mapping[str, float]
        ICWs the call issues per unit, by clock class; timed with the model's cycles per
        class and clock, so they follow a change of clock.
    unit : str
        What ``units`` counts for this call (``"event slot"``, ``"pixel step"``, ...).
    source : str
        Public source of the figure, or ``"estimate"`` with the reasoning.
    """

    fixed_us: float
    per_unit_us: float = 0.0
    per_unit_icws: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    unit: str = ""
    source: str = "estimate"


_ESTIMATE_ADDR = "estimate: address decoders set one DREG plane, a few ICWs + DAC-free"
_HEADER = "scamp5_api_analog.hpp (official SCAMP-5d headers)"


def _default_calls() -> Mapping[str, CallCost]:
    calls = {
        "scamp5_in": CallCost(
            0.5, source="estimate: DAC settling + 2 transfer ICWs (AnalogNet calibration prior)"
        ),
        "load_in": CallCost(0.5, source="estimate: same DAC path as scamp5_in"),
        "load_pattern": CallCost(0.5, source=_ESTIMATE_ADDR),
        "load_point": CallCost(0.5, source=_ESTIMATE_ADDR),
        "load_rect": CallCost(
            0.5, source=_ESTIMATE_ADDR + " (AnalogNet calibration prior for draw_rect)"
        ),
        "select_pattern": CallCost(0.5, source=_ESTIMATE_ADDR),
        "select_point": CallCost(0.5, source=_ESTIMATE_ADDR),
        "select_rect": CallCost(0.5, source=_ESTIMATE_ADDR),
        "shift_areg": CallCost(
            0.33,
            per_unit_icws=MappingProxyType({"analog": 2}),
            unit="pixel step",
            source="estimate: one kernel launch + one movx (2 analogue ICWs) per step",
        ),
        "shift_dreg": CallCost(
            0.33,
            per_unit_icws=MappingProxyType({"digital": 3, "dnews": 1}),
            unit="pixel step",
            source="estimate: DNEWS macro (CLR, SET, DNEWS) + REFRESH every 2 steps "
            "(scamp5_api_digital.hpp default refresh=2)",
        ),
        "global_sum_16": CallCost(13.5, source=_HEADER + ': "roughly 14 usec" in total'),
        "global_sum_64": CallCost(27.5, source=_HEADER + ': "roughly 28 usec" in total'),
        "global_or": CallCost(0.5, source="estimate: one wired-OR read of the array"),
        "global_count": CallCost(
            14.0, source="estimate: DREG->AREG conversion ICWs + global_sum_16 (14 us)"
        ),
        "global_count_64": CallCost(
            28.0, source="estimate: DREG->AREG conversion ICWs + global_sum_64 (28 us)"
        ),
        "scan_areg": CallCost(
            0.0, per_unit_us=0.1, unit="value", source="estimate: one ADC conversion per value"
        ),
        "scan_areg_8x8": CallCost(
            6.0, source='estimate: 64 ADC conversions, "slightly faster" than scan_areg'
        ),
        "scan_areg_mean_8x8": CallCost(
            27.5, source="estimate: same 8x8 block-summing readout as global_sum_64 (28 us)"
        ),
        "scan_dreg": CallCost(
            0.0, per_unit_us=1.6, unit="row", source="estimate: 32 bytes per row at ~20 MB/s"
        ),
        "scan_events": CallCost(
            0.0,
            per_unit_us=0.877,
            unit="event slot (max_num)",
            source="calibrated: AnalogNet event readout, 273 us for 3 x max_num=100 "
            "(scamp5_output.hpp: time proportional to max_num)",
        ),
    }
    return MappingProxyType(calls)


def _const(default: float, unit: str, source: str) -> Any:
    return field(default=default, metadata={"unit": unit, "source": source})


@dataclass(frozen=True)
class TimingConstants:
    """Every timing and energy constant of the model, with its unit and source.

    Replace single values with :func:`dataclasses.replace`; ``calls`` maps each controller
    call (by its SCAMP-5 name) to its :class:`CallCost`.
    """

    analog_cycles: float = _const(
        3.72,
        "cycles/ICW",
        "calibrated: AnalogNet 3 convolutions (180 analogue ICWs, 3 kernels) = 68 us "
        "together with input binarisation = 13 us",
    )
    digital_cycles: float = _const(
        1.0, "cycles/ICW", "estimate: one 10 MHz cycle (SCAMP5_CLOCK_DIGITAL)"
    )
    dnews_cycles: float = _const(
        1.0, "cycles/ICW", "estimate: one 10 MHz cycle (SCAMP5_CLOCK_DNEWS)"
    )
    nop_cycles: float = _const(
        3.72, "cycles/ICW", "scamp5_icw.hpp: nop is an analogue-clock ICW (clk=0)"
    )
    kernel_launch_us: float = _const(
        0.33, "us/kernel", "calibrated: AnalogNet input binarisation (3 kernels) = 13 us"
    )
    call_overhead_us: float = _const(0.5, "us/call", "estimate: one controller command to the chip")
    energy_pj_per_pe_icw: float = _const(
        1.87,
        "pJ per PE per ICW",
        "Carey et al. 2013: 535 GOPS/W, one op = one PE executing one ICW (1/535e9 J)",
    )
    system_power_w: float = _const(
        2.5,
        "W",
        "estimate: SCAMP-5d system draws 1.5-2.5 W (upper end); AnalogNet's "
        "0.7 mJ at 2260 fps implies ~1.6 W",
    )
    calls: Mapping[str, CallCost] = field(default_factory=_default_calls)

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name == "calls":
                continue
            if not isinstance(v, numbers.Real) or not 0 <= v < float("inf"):
                raise TimingError(
                    f"TimingConstants.{f.name}={v!r} is invalid: use a finite number >= 0 "
                    f"({f.metadata['unit']})"
                )

    def cycles(self, clock_class: str) -> float:
        """Cycles one ICW of ``clock_class`` takes."""
        table = {
            "analog": self.analog_cycles,
            "digital": self.digital_cycles,
            "dnews": self.dnews_cycles,
            "nop": self.nop_cycles,
        }
        if clock_class not in table:
            raise TimingError(
                f"unknown clock class {clock_class!r}; expected one of {CLOCK_CLASSES}"
            )
        return table[clock_class]

    def table(self) -> list[tuple[str, float, str, str]]:
        """Rows ``(name, value, unit, source)`` of every scalar constant and call cost."""
        rows = [
            ("clock_hz (default)", DEFAULT_CLOCK_HZ, "Hz", "Carey et al. 2013: 10 MHz"),
        ]
        for f in fields(self):
            if f.name != "calls":
                rows.append(
                    (f.name, getattr(self, f.name), f.metadata["unit"], f.metadata["source"])
                )
        for name, cost in self.calls.items():
            per = ""
            if cost.per_unit_us or cost.per_unit_icws:
                icws = ", ".join(f"{n:g} {c}" for c, n in cost.per_unit_icws.items())
                per = f" + {cost.per_unit_us:g} us" if cost.per_unit_us else " +"
                per += f" ({icws} ICWs)" if icws else ""
                per += f" per {cost.unit}"
            rows.append((f"call {name}", cost.fixed_us, "us" + per, cost.source))
        return rows


@dataclass
class StageCost:
    """Costs accumulated under one stage name.

    Attributes
    ----------
    name : str
        Stage path; nested stages are joined with ``/``.
    icws : dict[str, int]
        ICWs run, by clock class.
    kernels : int
        Kernel runs (each pays one launch).
    calls : dict[str, int]
        Controller calls, by SCAMP-5 name.
    us : float
        Modelled time, microseconds.
    chip_uj : float
        Energy of the array's operations, microjoules.
    """

    name: str
    icws: dict[str, int] = field(default_factory=dict)
    kernels: int = 0
    calls: dict[str, int] = field(default_factory=dict)
    us: float = 0.0
    chip_uj: float = 0.0

    @property
    def n_icws(self) -> int:
        """ICWs of all clock classes."""
        return sum(self.icws.values())

    @property
    def n_calls(self) -> int:
        """Controller calls of all kinds."""
        return sum(self.calls.values())


@dataclass(frozen=True)
class TimingReport:
    """Per-stage costs and totals, as returned by :meth:`TimingModel.report`.

    Attributes
    ----------
    stages : tuple[StageCost, ...]
        One row per stage, in order of first use; costs outside any stage are in the
        row ``"(unstaged)"``.
    total_us : float
        Modelled time of everything charged, microseconds.
    chip_uj, system_uj : float
        Chip operation energy and system power x time, microjoules.
    clock_hz, system_power_w : float
        The clock and system power the figures were computed with.
    """

    stages: tuple[StageCost, ...]
    total_us: float
    chip_uj: float
    system_uj: float
    clock_hz: float
    system_power_w: float

    @property
    def energy_uj(self) -> float:
        """Total modelled energy (chip operations + system power x time), microjoules."""
        return self.chip_uj + self.system_uj

    @property
    def total_icws(self) -> int:
        """ICWs of all stages."""
        return sum(s.n_icws for s in self.stages)

    @property
    def total_kernels(self) -> int:
        """Kernel runs of all stages."""
        return sum(s.kernels for s in self.stages)

    @property
    def total_calls(self) -> int:
        """Controller calls of all stages."""
        return sum(s.n_calls for s in self.stages)

    def stage(self, name: str) -> StageCost:
        """The row of stage ``name``.

        Raises
        ------
        UnknownStageError
            If nothing was charged under ``name`` (a ``SimulatorError`` and a ``KeyError``).
        """
        for s in self.stages:
            if s.name == name:
                return s
        known = ", ".join(repr(s.name) for s in self.stages) or "none"
        raise UnknownStageError(f"no stage {name!r} in this report; stages: {known}")

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form: stages, totals, energy and the clock used."""
        return {
            "clock_hz": self.clock_hz,
            "system_power_w": self.system_power_w,
            "total_us": self.total_us,
            "total_icws": self.total_icws,
            "total_kernels": self.total_kernels,
            "total_calls": self.total_calls,
            "chip_uj": self.chip_uj,
            "system_uj": self.system_uj,
            "energy_uj": self.energy_uj,
            "stages": [
                {
                    "name": s.name,
                    "icws": dict(s.icws),
                    "kernels": s.kernels,
                    "calls": dict(s.calls),
                    "us": s.us,
                    "chip_uj": s.chip_uj,
                }
                for s in self.stages
            ],
        }

    def _rows(self) -> list[tuple[str, str, str, str, str, str]]:
        rows = [
            (
                s.name,
                str(s.n_icws),
                str(s.kernels),
                str(s.n_calls),
                f"{s.us:.2f}",
                f"{s.chip_uj:.3f}",
            )
            for s in self.stages
        ]
        rows.append(
            (
                "total",
                str(self.total_icws),
                str(self.total_kernels),
                str(self.total_calls),
                f"{self.total_us:.2f}",
                f"{self.chip_uj:.3f}",
            )
        )
        return rows

    _HEADERS = ("stage", "ICWs", "kernels", "calls", "time (us)", "chip (uJ)")

    def _footer(self) -> str:
        return (
            f"energy {self.energy_uj:.3f} uJ = chip {self.chip_uj:.3f} uJ + system "
            f"{self.system_power_w:g} W x {self.total_us:.2f} us ({self.system_uj:.3f} uJ); "
            f"clock {self.clock_hz / 1e6:g} MHz"
        )

    def __str__(self) -> str:
        rows = [self._HEADERS, *self._rows()]
        width0 = max(len(r[0]) for r in rows)
        widths = [max(len(r[i]) for r in rows) for i in range(1, len(self._HEADERS))]
        lines = []
        for i, r in enumerate(rows):
            cells = [r[0].ljust(width0)] + [c.rjust(w) for c, w in zip(r[1:], widths, strict=True)]
            lines.append("  ".join(cells))
            if i == 0 or i == len(rows) - 2:
                lines.append("-" * len(lines[-1]))
        lines.append(self._footer())
        return "\n".join(lines)

    def __rich__(self) -> Any:
        from rich.table import Table

        table = Table(title="modelled SCAMP-5 time", caption=self._footer())
        table.add_column(self._HEADERS[0])
        for h in self._HEADERS[1:]:
            table.add_column(h, justify="right")
        rows = self._rows()
        for i, r in enumerate(rows):
            table.add_row(
                *r, end_section=(i == len(rows) - 2), style="bold" if i == len(rows) - 1 else None
            )
        return table


class TimingModel:
    """Accumulates the modelled time and energy of kernels and controller calls.

    Parameters
    ----------
    clock_hz : float
        Instruction clock of the array, Hz.
    constants : TimingConstants, optional
        The constants table; the defaults are documented in docs/sim-controller.md.
    pe_count : int
        Number of processing elements (rows x cols) for the chip energy.

    Notes
    -----
    Costs go to the innermost open stage (:meth:`stage`); nested stage names are joined
    with ``/``. ``now_us`` keeps growing across stages until :meth:`reset`.
    """

    def __init__(
        self,
        clock_hz: float = DEFAULT_CLOCK_HZ,
        constants: TimingConstants | None = None,
        *,
        pe_count: int = 256 * 256,
    ) -> None:
        if not isinstance(clock_hz, numbers.Real) or not 0 < clock_hz < float("inf"):
            raise TimingError(
                f"clock_hz={clock_hz!r} is invalid: use a positive frequency in Hz (e.g. 10e6)"
            )
        if constants is not None and not isinstance(constants, TimingConstants):
            raise TimingError(
                f"constants={constants!r} is invalid: use a ppaloc.sim.TimingConstants "
                "(e.g. dataclasses.replace(TimingConstants(), kernel_launch_us=0.5))"
            )
        self.clock_hz = float(clock_hz)
        self.constants = constants if constants is not None else TimingConstants()
        self.pe_count = int(pe_count)
        self.reset()

    def reset(self) -> None:
        """Forget every charged cost and close all stages."""
        self._stages: dict[str, StageCost] = {}
        self._stack: list[str] = []
        self._total_us = 0.0
        self._chip_uj = 0.0

    @property
    def now_us(self) -> float:
        """Modelled time since construction or the last :meth:`reset`, microseconds."""
        return self._total_us

    @property
    def chip_uj(self) -> float:
        """Chip operation energy since the last :meth:`reset`, microjoules."""
        return self._chip_uj

    @property
    def energy_uj(self) -> float:
        """Total modelled energy (chip + system power x time) since the last reset, uJ.

        Differences of ``now_us`` and ``energy_uj`` before and after a frame give that
        frame's modelled latency and energy.
        """
        return self._chip_uj + self.constants.system_power_w * self._total_us

    @property
    def current_stage(self) -> str:
        """Name of the stage costs are charged to now."""
        return "/".join(self._stack) or _UNSTAGED

    def icw_us(self, clock_class: str) -> float:
        """Modelled duration of one ICW of ``clock_class``, microseconds."""
        return self.constants.cycles(clock_class) / self.clock_hz * 1e6

    def _stage_row(self) -> StageCost:
        name = self.current_stage
        row = self._stages.get(name)
        if row is None:
            row = self._stages[name] = StageCost(name)
        return row

    def _icw_time(self, counts: Mapping[str, float]) -> tuple[float, float]:
        us = 0.0
        n = 0.0
        for cls, k in counts.items():
            if cls not in CLOCK_CLASSES:
                raise TimingError(f"unknown clock class {cls!r}; expected one of {CLOCK_CLASSES}")
            if k < 0:
                raise TimingError(f"negative ICW count {k!r} for clock class {cls!r}")
            us += k * self.icw_us(cls)
            n += k
        return us, n

    def _add(self, row: StageCost, us: float, n_icws: float) -> None:
        chip = n_icws * self.pe_count * self.constants.energy_pj_per_pe_icw * 1e-6
        row.us += us
        row.chip_uj += chip
        self._total_us += us
        self._chip_uj += chip

    def charge_kernel(self, counts: Mapping[str, int]) -> None:
        """Charge one kernel run: launch overhead + its ICWs' cycles.

        Parameters
        ----------
        counts : Mapping[str, int]
            ICWs per clock class; keys from :data:`CLOCK_CLASSES`, missing ones count 0.
        """
        us, n = self._icw_time(counts)
        row = self._stage_row()
        for cls, k in counts.items():
            if k:
                row.icws[cls] = row.icws.get(cls, 0) + int(k)
        row.kernels += 1
        self._add(row, self.constants.kernel_launch_us + us, n)

    def call_us(self, name: str, units: float = 1.0) -> float:
        """Modelled duration of one controller call, microseconds (nothing is charged)."""
        try:
            cost = self.constants.calls[name]
        except KeyError:
            known = ", ".join(sorted(self.constants.calls))
            raise TimingError(
                f"no modelled cost for controller call {name!r}; known: {known}"
            ) from None
        icw_us, _ = self._icw_time(cost.per_unit_icws)
        return self.constants.call_overhead_us + cost.fixed_us + units * (cost.per_unit_us + icw_us)

    def charge_call(self, name: str, units: float = 1.0) -> None:
        """Charge one controller call by its SCAMP-5 name.

        Parameters
        ----------
        name : str
            The call, e.g. ``"global_sum_64"``; a key of ``constants.calls``.
        units : float
            How many units of the call's ``unit`` (``max_num`` for ``scan_events``, pixel
            steps for ``shift_areg``, ...); ignored by calls with no per-unit cost.
        """
        if units < 0:
            raise TimingError(f"negative units {units!r} for call {name!r}")
        us = self.call_us(name, units)
        cost = self.constants.calls[name]
        n_icws = units * sum(cost.per_unit_icws.values())
        row = self._stage_row()
        row.calls[name] = row.calls.get(name, 0) + 1
        self._add(row, us, n_icws)

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Charge everything inside the ``with`` block to stage ``name``.

        Stages nest (``outer/inner``) and may be re-entered; their costs accumulate.
        """
        if not isinstance(name, str) or not name or "/" in name:
            raise TimingError(
                f"stage name {name!r} is invalid: use a non-empty name without '/' "
                "(nest stages with `with` blocks instead)"
            )
        self._stack.append(name)
        try:
            yield
        finally:
            self._stack.pop()

    def report(self) -> TimingReport:
        """Per-stage table and totals of everything charged since the last reset."""
        system_uj = self.constants.system_power_w * self._total_us
        return TimingReport(
            stages=tuple(
                StageCost(s.name, dict(s.icws), s.kernels, dict(s.calls), s.us, s.chip_uj)
                for s in self._stages.values()
            ),
            total_us=self._total_us,
            chip_uj=self._chip_uj,
            system_uj=system_uj,
            clock_hz=self.clock_hz,
            system_power_w=self.constants.system_power_w,
        )


# --------------------------------------------------------------------------------------
# Calibration on public hardware measurements.

#: AnalogNet on SCAMP-5 (Wong, Guillard et al., "AnalogNet: Convolutional Neural Network
#: Inference on Analog Focal Plane Sensor Processors", 2020): measured stage times (us)
#: and each stage's program as ICW counts per clock class and controller calls, counted
#: from the public port of its SCAMP-5 code (Guillard's ``conv_instructions.hpp`` and main
#: loop; the macro expansions of the official kernel API headers).
ANALOGNET_STAGES: Mapping[str, dict[str, Any]] = MappingProxyType(
    {
        "input binarisation": {
            "measured_us": 13.0,
            # get_image(A,B)+add+CLR+where+OR+ALL+NOT+CLR | CLR+AND | res x3+WHERE+mov x3+ALL
            "kernels": [
                {"analog": 8, "nop": 1, "digital": 5},
                {"digital": 5},
                {"analog": 12, "digital": 2},
            ],
            "calls": [("scamp5_in", 1), ("load_rect", 1), ("scamp5_in", 1)],
        },
        "three convolutions": {
            "measured_us": 68.0,
            # conv_A, conv_B, conv_C: 44, 42 and 94 analogue ICWs
            "kernels": [{"analog": 44}, {"analog": 42}, {"analog": 94}],
            "calls": [],
        },
        "event readout": {
            "measured_us": 273.0,
            # per output map: scamp5_in(threshold); CLR+sub+where+MOV+ALL; scan_events(100)
            "kernels": [{"analog": 3, "digital": 3}] * 3,
            "calls": [("scamp5_in", 1), ("scan_events", 100)] * 3,
        },
    }
)


def analognet_calibration(
    constants: TimingConstants | None = None, clock_hz: float = DEFAULT_CLOCK_HZ
) -> dict[str, tuple[float, float]]:
    """Modelled vs measured time of each AnalogNet stage.

    Parameters
    ----------
    constants : TimingConstants, optional
        Constants to evaluate (default: the calibrated defaults).
    clock_hz : float
        Instruction clock, Hz.

    Returns
    -------
    dict[str, tuple[float, float]]
        Stage name -> (modelled us, measured us).
    """
    out = {}
    for stage, prog in ANALOGNET_STAGES.items():
        t = TimingModel(clock_hz, constants)
        for counts in prog["kernels"]:
            t.charge_kernel(counts)
        for name, units in prog["calls"]:
            t.charge_call(name, units)
        out[stage] = (t.now_us, prog["measured_us"])
    return out
