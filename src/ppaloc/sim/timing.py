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
import math
import numbers
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from types import MappingProxyType
from typing import Any

import numpy as np

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
    fixed_range, per_unit_range : tuple[float, float], optional
        The (low, high) of ``fixed_us`` and ``per_unit_us`` for the interval bounds
        (:meth:`TimingConstants.corner`); None: the value is exact, or follows another
        constant (``simple``, or the AnalogNet fit for ``scan_events``).
    simple : bool
        A one-command call (a DAC load, an address pattern, a wired-OR): its fixed cost
        is taken equal to the per-call overhead at the bounds, so both move together.
    launch : bool
        The fixed cost is one kernel launch (the library's shifts): it follows the
        refitted ``kernel_launch_us`` at the bounds.
    """

    fixed_us: float
    per_unit_us: float = 0.0
    per_unit_icws: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))
    unit: str = ""
    source: str = "estimate"
    fixed_range: tuple[float, float] | None = None
    per_unit_range: tuple[float, float] | None = None
    simple: bool = False
    launch: bool = False


_ESTIMATE_ADDR = "estimate: address decoders set one DREG plane, a few ICWs + DAC-free"
_HEADER = "scamp5_api_analog.hpp (official SCAMP-5d headers)"
_ROUGHLY = "; 'roughly': +-15%"
_USB = "estimate: host link at 10-40 MB/s (USB 2.0 bulk; no published SCAMP-5d figure), 20 MB/s mid"


def _default_calls() -> Mapping[str, CallCost]:
    simple = {"simple": True}
    calls = {
        "scamp5_in": CallCost(
            0.5,
            source="estimate: DAC settling + 2 transfer ICWs (AnalogNet calibration prior)",
            **simple,
        ),
        "load_in": CallCost(0.5, source="estimate: same DAC path as scamp5_in", **simple),
        "load_pattern": CallCost(0.5, source=_ESTIMATE_ADDR, **simple),
        "load_point": CallCost(0.5, source=_ESTIMATE_ADDR, **simple),
        "load_rect": CallCost(
            0.5, source=_ESTIMATE_ADDR + " (AnalogNet calibration prior for draw_rect)", **simple
        ),
        "select_pattern": CallCost(0.5, source=_ESTIMATE_ADDR, **simple),
        "select_point": CallCost(0.5, source=_ESTIMATE_ADDR, **simple),
        "select_rect": CallCost(0.5, source=_ESTIMATE_ADDR, **simple),
        "shift_areg": CallCost(
            0.33,
            per_unit_icws=MappingProxyType({"analog": 2}),
            unit="pixel step",
            source="estimate: one kernel launch + one movx (2 analogue ICWs) per step",
            launch=True,
        ),
        "shift_dreg": CallCost(
            0.33,
            per_unit_icws=MappingProxyType({"digital": 3, "dnews": 1}),
            unit="pixel step",
            source="estimate: DNEWS macro (CLR, SET, DNEWS) + REFRESH every 2 steps "
            "(scamp5_api_digital.hpp default refresh=2)",
            launch=True,
        ),
        "global_sum_16": CallCost(
            13.5,
            source=_HEADER + ': "roughly 14 usec" in total' + _ROUGHLY,
            fixed_range=(11.4, 15.6),
        ),
        "global_sum_64": CallCost(
            27.5,
            source=_HEADER + ': "roughly 28 usec" in total' + _ROUGHLY,
            fixed_range=(23.3, 31.7),
        ),
        "global_or": CallCost(0.5, source="estimate: one wired-OR read of the array", **simple),
        "global_count": CallCost(
            14.0,
            source="estimate: DREG->AREG conversion ICWs + global_sum_16 (14 us)",
            fixed_range=(11.9, 16.1),
        ),
        "global_count_64": CallCost(
            28.0,
            source="estimate: DREG->AREG conversion ICWs + global_sum_64 (28 us)",
            fixed_range=(23.8, 32.2),
        ),
        "scan_areg": CallCost(
            0.0,
            per_unit_us=0.1,
            unit="value",
            source="estimate: one ADC conversion + one byte to the controller per value "
            "(0.05-0.2 us: 5-20 M values/s)",
            per_unit_range=(0.05, 0.2),
        ),
        "scan_areg_8x8": CallCost(
            6.0,
            source='estimate: 64 ADC conversions, "slightly faster" than scan_areg '
            "(64 x 0.05-0.2 us)",
            fixed_range=(3.2, 12.8),
        ),
        "scan_areg_mean_8x8": CallCost(
            27.5,
            source="estimate: same 8x8 block-summing readout as global_sum_64 (28 us)",
            fixed_range=(23.3, 31.7),
        ),
        "scan_dreg": CallCost(
            0.0,
            per_unit_us=1.6,
            unit="row",
            source="estimate: 32 bytes per row; " + _USB.removeprefix("estimate: "),
            per_unit_range=(0.8, 3.2),
        ),
        "scan_events": CallCost(
            0.0,
            per_unit_us=0.877,
            unit="event slot (max_num)",
            source="calibrated: AnalogNet event readout, 273 us for 3 x max_num=100 "
            "(scamp5_output.hpp: time proportional to max_num)",
        ),
        # -- the frame loop of a hardware experiment on a dataset (boundary "loop") -----
        "vs_frame_loop_control": CallCost(
            10.0,
            source="estimate: the controller's per-frame USB message poll and frame "
            "pacing; no published figure (2-50 us)",
            fixed_range=(2.0, 50.0),
        ),
        "vs_gui_request_image": CallCost(
            250.0,
            per_unit_us=0.05,
            unit="byte",
            source="estimate: one request/answer round trip to the host over USB 2.0 "
            "(125 us microframes: 1-8 of them, 2 mid) + the bit-planes' bytes; " + _USB[10:],
            fixed_range=(125.0, 1000.0),
            per_unit_range=(0.025, 0.1),
        ),
        "vs_wait": CallCost(
            0.0,
            per_unit_us=1.0,
            unit="us waited",
            source="vs_m0.hpp: vs_wait(usec), a polled delay of usec microseconds",
        ),
        "scamp5_draw_pixel": CallCost(
            0.0,
            source="estimate: one address write into the drawn DREG (the per-call overhead only)",
        ),
        "scamp5_draw_rect": CallCost(
            0.0,
            source="estimate: one address write into the drawn DREG (the per-call overhead only)",
        ),
        "usb_output": CallCost(
            5.0,
            per_unit_us=0.05,
            unit="byte",
            source="estimate: a buffered message to the host (1-20 us) + its bytes; " + _USB[10:],
            fixed_range=(1.0, 20.0),
            per_unit_range=(0.025, 0.1),
        ),
    }
    return MappingProxyType(calls)


def _const(
    default: float, unit: str, source: str, bounds: tuple[float, float] | str | None = None
) -> Any:
    """A scalar constant: its unit, source and interval (None: exact; "fit": AnalogNet)."""
    return field(default=default, metadata={"unit": unit, "source": source, "bounds": bounds})


#: The interval levels of every modelled time.
LEVELS: tuple[str, ...] = ("low", "mid", "high")


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
        "fit",
    )
    digital_cycles: float = _const(
        1.0, "cycles/ICW", "estimate: one 10 MHz cycle (SCAMP5_CLOCK_DIGITAL)"
    )
    dnews_cycles: float = _const(
        1.0, "cycles/ICW", "estimate: one 10 MHz cycle (SCAMP5_CLOCK_DNEWS)"
    )
    nop_cycles: float = _const(
        3.72, "cycles/ICW", "scamp5_icw.hpp: nop is an analogue-clock ICW (clk=0)", "fit"
    )
    kernel_launch_us: float = _const(
        0.33, "us/kernel", "calibrated: AnalogNet input binarisation (3 kernels) = 13 us", "fit"
    )
    call_overhead_us: float = _const(
        0.5,
        "us/call",
        "estimate: one controller command to the chip (0.2-0.625 us: the low end a few "
        "80-bit words at the 10 MHz ICW rate; the high end where AnalogNet's fit leaves "
        "a kernel launch of ~0 us)",
        (0.2, 0.625),
    )
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

    def corner(self, level: str, overhead_us: float, clock_hz: float = DEFAULT_CLOCK_HZ) -> Any:
        """One bound's point set: every independent cost at its ``level`` end.

        The per-call overhead (and the one-command calls that move with it) is set to
        ``overhead_us``, and the constants fitted on AnalogNet (analogue ICW cycles,
        kernel launch, event slot) are refitted under those call costs
        (:func:`analognet_fit`), so that each corner still reproduces AnalogNet's three
        measured stages. ``level`` is ``"low"`` or ``"high"``.
        """
        if level not in ("low", "high"):
            raise TimingError(f"level={level!r} is invalid: use 'low' or 'high'")
        end = 0 if level == "low" else 1
        scalars: dict[str, Any] = {"call_overhead_us": float(overhead_us)}
        for f in fields(self):
            b = f.metadata.get("bounds") if f.name != "calls" else None
            if isinstance(b, tuple) and f.name != "call_overhead_us":
                scalars[f.name] = b[end]
        calls = {}
        for name, cost in self.calls.items():
            changes: dict[str, Any] = {}
            if cost.simple:
                changes["fixed_us"] = float(overhead_us)
            elif cost.fixed_range is not None:
                changes["fixed_us"] = cost.fixed_range[end]
            if cost.per_unit_range is not None:
                changes["per_unit_us"] = cost.per_unit_range[end]
            calls[name] = replace(cost, **changes) if changes else cost
        point = replace(self, calls=MappingProxyType(calls), **scalars)
        a_cycles, launch_us, slot_us = analognet_fit(point, clock_hz)
        calls["scan_events"] = replace(calls["scan_events"], per_unit_us=slot_us)
        for name, cost in calls.items():
            if cost.launch:
                calls[name] = replace(cost, fixed_us=launch_us)
        return replace(
            point,
            analog_cycles=a_cycles,
            nop_cycles=a_cycles,
            kernel_launch_us=launch_us,
            calls=MappingProxyType(calls),
        )

    def corners(self, clock_hz: float = DEFAULT_CLOCK_HZ) -> dict[str, list[Any]]:
        """The point sets a bound is the extreme of: ``{"low": [...], "high": [...]}``.

        Modelled time is linear in every constant with non-negative counts, and the
        refitted constants are linear in the overhead, so a program's low (high) bound
        is its smallest (largest) time over the two ends of the overhead's interval
        with the independent costs at their low (high) ends.
        """
        lo, hi = fields_bounds(self)["call_overhead_us"]
        return {
            level: [self.corner(level, o, clock_hz) for o in (lo, hi)] for level in ("low", "high")
        }

    def interval_table(
        self, clock_hz: float = DEFAULT_CLOCK_HZ
    ) -> list[tuple[str, float, float, float, str, str]]:
        """Rows ``(name, low, mid, high, unit, source)``: the one table of every cost.

        Fitted constants show the range they take over the corners (their low and high
        are correlated with the call costs, not free); exact ones low = mid = high.
        """
        corners = [c for cs in self.corners(clock_hz).values() for c in cs]
        rows = []
        for f in fields(self):
            if f.name == "calls":
                continue
            vals = [getattr(c, f.name) for c in corners]
            rows.append(
                (
                    f.name,
                    min(vals),
                    getattr(self, f.name),
                    max(vals),
                    f.metadata["unit"],
                    f.metadata["source"],
                )
            )
        for name, cost in self.calls.items():
            fixed = [c.calls[name].fixed_us for c in corners]
            per = [c.calls[name].per_unit_us for c in corners]
            unit = "us"
            if cost.per_unit_icws:
                icws = ", ".join(f"{n:g} {c}" for c, n in cost.per_unit_icws.items())
                unit += f" + ({icws} ICWs) per {cost.unit}"
            rows.append((f"call {name}", min(fixed), cost.fixed_us, max(fixed), unit, cost.source))
            if cost.per_unit_us or cost.per_unit_range:
                rows.append(
                    (
                        f"call {name} per {cost.unit}",
                        min(per),
                        cost.per_unit_us,
                        max(per),
                        "us",
                        cost.source,
                    )
                )
        return rows


def fields_bounds(constants: TimingConstants) -> dict[str, Any]:
    """The ``bounds`` metadata of every scalar field (None: exact, "fit": AnalogNet)."""
    return {f.name: f.metadata.get("bounds") for f in fields(constants) if f.name != "calls"}


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
    units : dict[str, float]
        Units charged per call name (event slots, pixel steps, values, ...).
    """

    name: str
    icws: dict[str, int] = field(default_factory=dict)
    kernels: int = 0
    calls: dict[str, int] = field(default_factory=dict)
    us: float = 0.0
    chip_uj: float = 0.0
    units: dict[str, float] = field(default_factory=dict)

    def counts(self) -> dict[str, float]:
        """This stage as a count vector (see :func:`evaluate_us`)."""
        out: dict[str, float] = {f"icw:{c}": float(n) for c, n in self.icws.items()}
        if self.kernels:
            out["kernels"] = float(self.kernels)
        out.update({f"calls:{c}": float(n) for c, n in self.calls.items()})
        out.update({f"units:{c}": float(n) for c, n in self.units.items() if n})
        return out

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


def _checked_clock(value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not 0 < value < math.inf:
        raise TimingError(
            f"clock_hz={value!r} is invalid: use a positive frequency in Hz (e.g. 10e6)"
        )
    return float(value)


def _checked_constants(value: Any) -> TimingConstants:
    if not isinstance(value, TimingConstants):
        raise TimingError(
            f"constants={value!r} is invalid: use a ppaloc.sim.TimingConstants "
            "(e.g. dataclasses.replace(TimingConstants(), kernel_launch_us=0.5))"
        )
    return value


def _checked_pe_count(value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < 1:
        raise TimingError(
            f"pe_count={value!r} is invalid: use the number of processing elements, a "
            "positive integer (rows x cols, e.g. 256 * 256)"
        )
    return int(value)


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
        self._clock_hz = _checked_clock(clock_hz)
        self._constants = TimingConstants() if constants is None else _checked_constants(constants)
        self._pe_count = _checked_pe_count(pe_count)
        self._charges = 0
        self._forget_costs()
        self.reset()

    # The per-kernel and per-call costs are computed once and kept (the same arithmetic,
    # so the same floats); changing the clock, the constants or the PE count drops them.
    @property
    def clock_hz(self) -> float:
        """Instruction clock of the array, Hz."""
        return self._clock_hz

    @clock_hz.setter
    def clock_hz(self, value: float) -> None:
        self._clock_hz = _checked_clock(value)  # checked as the constructor checks it
        self._forget_costs()

    @property
    def constants(self) -> TimingConstants:
        """The constants table charged with (mid values)."""
        return self._constants

    @constants.setter
    def constants(self, value: TimingConstants) -> None:
        self._constants = _checked_constants(value)
        self._forget_costs()

    @property
    def pe_count(self) -> int:
        """Processing elements the chip energy counts per ICW."""
        return self._pe_count

    @pe_count.setter
    def pe_count(self, value: int) -> None:
        self._pe_count = _checked_pe_count(value)
        self._forget_costs()

    def _forget_costs(self) -> None:
        self._corners: dict[str, list[TimingConstants]] | None = None
        self._kernel_costs: dict[tuple, tuple[float, float, tuple[tuple[str, int], ...]]] = {}
        self._call_costs: dict[str, tuple[float, float, float]] = {}

    def reset(self) -> None:
        """Forget every charged cost and close all stages."""
        self._stages: dict[str, StageCost] = {}
        self._stack: list[str] = []
        self._row: StageCost | None = None  # the current stage's row, once charged
        self._total_us = 0.0
        self._chip_uj = 0.0
        self._charges += 1

    @property
    def charges(self) -> int:
        """A token that changes whenever anything is charged or the model is reset (equal
        tokens: equal :meth:`counts_by_stage`)."""
        return self._charges

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
        row = self._row
        if row is None:
            name = self.current_stage
            row = self._stages.get(name)
            if row is None:
                row = self._stages[name] = StageCost(name)
            self._row = row
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
        chip = n_icws * self._pe_count * self._constants.energy_pj_per_pe_icw * 1e-6
        row.us += us
        row.chip_uj += chip
        self._total_us += us
        self._chip_uj += chip

    def _kernel_cost(self, key: tuple) -> tuple[float, float, tuple[tuple[str, int], ...]]:
        """(time, chip energy, nonzero ICW counts) of one run of a kernel's counts."""
        counts = dict(key)
        us, n = self._icw_time(counts)
        chip = n * self._pe_count * self._constants.energy_pj_per_pe_icw * 1e-6
        nonzero = tuple((cls, int(k)) for cls, k in counts.items() if k)
        if len(self._kernel_costs) >= 4096:
            self._kernel_costs.clear()
        cost = self._kernel_costs[key] = (self._constants.kernel_launch_us + us, chip, nonzero)
        return cost

    def charge_kernel(self, counts: Mapping[str, int] | tuple[tuple[str, int], ...]) -> None:
        """Charge one kernel run: launch overhead + its ICWs' cycles.

        Parameters
        ----------
        counts : Mapping[str, int] or tuple of (str, int)
            ICWs per clock class; keys from :data:`CLOCK_CLASSES`, missing ones count 0.
            A recorded kernel passes its counts' items as a tuple, made once, so that a
            run looks its cost up without building the key.
        """
        key = counts if isinstance(counts, tuple) else tuple(counts.items())
        cost = self._kernel_costs.get(key)
        if cost is None:
            cost = self._kernel_cost(key)
        self._add_kernel(*cost)

    def _add_kernel(self, us: float, chip: float, nonzero: tuple[tuple[str, int], ...]) -> None:
        """One kernel run's cost added to the stage's row and the totals (the one place
        the sums are made, in one order: :meth:`charge_kernel` and :meth:`kernel_charger`'s
        calls give the same floats)."""
        self._charges += 1
        row = self._row or self._stage_row()
        icws = row.icws
        for cls, k in nonzero:
            icws[cls] = icws.get(cls, 0) + k
        row.kernels += 1
        row.us += us
        row.chip_uj += chip
        self._total_us += us
        self._chip_uj += chip

    def kernel_charger(self, counts: tuple[tuple[str, int], ...]) -> Callable[[], None]:
        """A call that charges one run of a kernel of ``counts`` (as :meth:`charge_kernel`
        takes them), as :meth:`charge_kernel` does it: the same sums in the same order,
        so the same floats. The cost is looked up once, when the call is made, and used
        while the constants, the clock and the PE count stay as they were (a change of
        any of them makes the call charge through :meth:`charge_kernel`). A recorded
        kernel makes one for its runs."""
        key = counts
        costs = self._kernel_costs
        us, chip, nonzero = costs.get(key) or self._kernel_cost(key)
        charge_kernel, add = self.charge_kernel, self._add_kernel

        def charge() -> None:
            if self._kernel_costs is not costs:  # the costs were forgotten since
                charge_kernel(key)
                return
            add(us, chip, nonzero)

        return charge

    def _call_cost(self, name: str) -> tuple[float, float, float]:
        """(fixed time with the overhead, time per unit, ICWs per unit) of call ``name``."""
        try:
            cost = self._constants.calls[name]
        except KeyError:
            known = ", ".join(sorted(self._constants.calls))
            raise TimingError(
                f"no modelled cost for controller call {name!r}; known: {known}"
            ) from None
        icw_us, _ = self._icw_time(cost.per_unit_icws)
        entry = (
            self._constants.call_overhead_us + cost.fixed_us,
            cost.per_unit_us + icw_us,
            sum(cost.per_unit_icws.values()),
        )
        self._call_costs[name] = entry
        return entry

    def call_us(self, name: str, units: float = 1.0) -> float:
        """Modelled duration of one controller call, microseconds (nothing is charged)."""
        base, per_unit, _ = self._call_costs.get(name) or self._call_cost(name)
        return base + units * per_unit

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
        base, per_unit, icws_per_unit = self._call_costs.get(name) or self._call_cost(name)
        us = base + units * per_unit
        self._charges += 1
        row = self._row or self._stage_row()
        calls = row.calls
        calls[name] = calls.get(name, 0) + 1
        if units:
            row.units[name] = row.units.get(name, 0.0) + float(units)
        n_icws = units * icws_per_unit
        row.us += us
        self._total_us += us
        if n_icws:  # a call without ICWs adds no chip energy (+ 0.0 changes nothing)
            chip = n_icws * self._pe_count * self._constants.energy_pj_per_pe_icw * 1e-6
            row.chip_uj += chip
            self._chip_uj += chip

    def charge_rounds(self, steps: Sequence[str | tuple[tuple[str, int], ...]], times: int) -> None:
        """Charge ``times`` rounds of ``steps``, each round the steps in order.

        A step is a controller call's name (one unit, as :meth:`charge_call` with its
        default) or a kernel run's counts as a tuple of ``(clock class, ICWs)`` (as
        :meth:`charge_kernel` takes them). Every sum (the clock, the energy, the stage's
        time, energy and units) is accumulated one step at a time, in the order the steps
        charged one by one would add to it, so the floats are the same bytes as those
        ``times * len(steps)`` charges; only the Python per charge is saved.

        Examples
        --------
        >>> a, b = TimingModel(), TimingModel()
        >>> kernel = (("analog", 1), ("digital", 2))
        >>> for _ in range(3):
        ...     a.charge_call("load_in")
        ...     a.charge_kernel(kernel)
        >>> b.charge_rounds(("load_in", kernel), 3)
        >>> (a.now_us, a.energy_uj, a.report().stages) == (b.now_us, b.energy_uj, b.report().stages)
        True
        """
        plan = self._rounds_plan(steps, times)
        if not times or not plan:
            return
        row = self._row or self._stage_row()
        # Each sum in one sequential accumulation (np.add.accumulate adds element by element
        # in float64, as the charges one by one add Python floats), over the steps in order.
        us = np.tile([step[0] for step in plan], times)
        # a kernel adds its chip energy (+ 0.0 changes nothing), a call only with ICWs
        chip = np.tile([step[1] for step in plan if step[2] is None or step[1]], times)
        self._total_us = _accumulated(self._total_us, us)
        row.us = _accumulated(row.us, us)
        if chip.size:
            self._chip_uj = _accumulated(self._chip_uj, chip)
            row.chip_uj = _accumulated(row.chip_uj, chip)
        units = {name: row.units.get(name, 0.0) for _, _, name, _ in plan if name}
        for name in units:
            per_round = sum(step[2] == name for step in plan)
            units[name] = _accumulated(units[name], np.ones(per_round * times))
        row.units.update(units)
        for _, _, name, nonzero in plan:
            if name is None:
                row.kernels += times
                for cls, k in nonzero:
                    row.icws[cls] = row.icws.get(cls, 0) + k * times
            else:
                row.calls[name] = row.calls.get(name, 0) + times
        self._charges += times * len(plan)

    def _rounds_plan(
        self, steps: Sequence[str | tuple[tuple[str, int], ...]], times: int
    ) -> list[tuple[float, float, str | None, tuple[tuple[str, int], ...]]]:
        """(time, chip energy, call name or None, kernel ICWs) per step of a round."""
        if times < 0:
            raise TimingError(f"negative rounds {times!r}")
        plan = []
        for step in steps:
            if isinstance(step, str):
                base, per_unit, icws_per_unit = self._call_costs.get(step) or self._call_cost(step)
                chip = icws_per_unit * self._pe_count * self._constants.energy_pj_per_pe_icw
                plan.append((base + 1.0 * per_unit, chip * 1e-6, step, ()))
            else:
                cost = self._kernel_costs.get(step) or self._kernel_cost(step)
                plan.append((cost[0], cost[1], None, cost[2]))
        return plan

    def rounds_clock(
        self, steps: Sequence[str | tuple[tuple[str, int], ...]], times: int
    ) -> np.ndarray:
        """The clock :meth:`charge_rounds` of the same arguments would pass through,
        without charging anything: ``now_us`` after each of its ``times * len(steps)``
        charges, in order (float64, microseconds; the same floats as the charges one by
        one leave, each an addition to the one before).

        A caller that replays what happens between the charges (droop accounted per
        elapsed interval, as :class:`~ppaloc.sim.engine.Scamp5` does) reads the instants
        here, then charges the rounds.

        Examples
        --------
        >>> t = TimingModel()
        >>> clock = t.rounds_clock(("load_in",), 2)
        >>> t.charge_call("load_in")
        >>> bool(clock[0] == t.now_us), len(clock)
        (True, 2)
        """
        plan = self._rounds_plan(steps, times)
        us = np.tile([step[0] for step in plan], times)
        return np.add.accumulate(np.concatenate(([self._total_us], us)))[1:]

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
        self._row = None
        try:
            yield
        finally:
            self._stack.pop()
            self._row = None

    def counts_by_stage(self) -> dict[str, dict[str, float]]:
        """Everything charged since the last reset as count vectors, by stage.

        Differences of two snapshots give a frame's counts (:func:`diff_counts`), which
        :meth:`interval` turns into a low/mid/high time.
        """
        return {name: row.counts() for name, row in self._stages.items()}

    def interval(self, counts: Mapping[str, float]) -> Interval:
        """Low/mid/high modelled time of ``counts`` with this model's constants (us)."""
        if self._corners is None:
            self._corners = self.constants.corners(self.clock_hz)
        return interval_us(counts, self.constants, self.clock_hz, corners=self._corners)

    def report(self) -> TimingReport:
        """Per-stage table and totals of everything charged since the last reset."""
        system_uj = self.constants.system_power_w * self._total_us
        return TimingReport(
            stages=tuple(
                StageCost(
                    s.name, dict(s.icws), s.kernels, dict(s.calls), s.us, s.chip_uj, dict(s.units)
                )
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


def analognet_fit(
    constants: TimingConstants, clock_hz: float = DEFAULT_CLOCK_HZ
) -> tuple[float, float, float]:
    """Refit the three free constants on AnalogNet's stages under ``constants``' calls.

    Every other constant (the call costs, the digital cycles) is held; the analogue ICW
    cycles (``nop`` counted as analogue), the kernel launch and the ``scan_events`` cost
    per slot are solved from the three measured stage times (three equations, three
    unknowns).

    Returns
    -------
    tuple of float
        ``(analog_cycles, kernel_launch_us, scan_events per-slot us)``.

    Raises
    ------
    TimingError
        If the held constants leave no non-negative solution (the calls alone cost more
        than a stage measured).
    """
    import numpy as np

    held = replace(
        constants,
        analog_cycles=0.0,
        nop_cycles=0.0,
        kernel_launch_us=0.0,
        calls=MappingProxyType(
            {
                **constants.calls,
                "scan_events": replace(constants.calls["scan_events"], per_unit_us=0.0),
            }
        ),
    )
    rows, rhs = [], []
    for prog in ANALOGNET_STAGES.values():
        t = TimingModel(clock_hz, held)
        n_analog = n_kernels = n_slots = 0.0
        for counts in prog["kernels"]:
            t.charge_kernel(counts)
            n_analog += counts.get("analog", 0) + counts.get("nop", 0)
            n_kernels += 1
        for name, units in prog["calls"]:
            t.charge_call(name, units)
            n_slots += units if name == "scan_events" else 0
        rows.append([n_analog / clock_hz * 1e6, n_kernels, n_slots])
        rhs.append(prog["measured_us"] - t.now_us)
    a_cycles, launch, slot = (float(x) for x in np.linalg.solve(np.array(rows), np.array(rhs)))
    if min(a_cycles, launch, slot) < 0:
        raise TimingError(
            f"call_overhead_us={constants.call_overhead_us!r} leaves AnalogNet's stages no "
            f"non-negative fit (analog {a_cycles:.3f} cycles, launch {launch:.3f} us, slot "
            f"{slot:.3f} us): use cheaper calls"
        )
    return a_cycles, launch, slot


# --------------------------------------------------------------------------------------
# Count vectors and intervals: a program's time under any point set of constants.


@dataclass(frozen=True)
class Interval:
    """A modelled time as low/mid/high (same unit throughout)."""

    low: float
    mid: float
    high: float

    def scaled(self, k: float) -> Interval:
        """The interval times ``k`` (e.g. 1e-3 for us -> ms)."""
        return Interval(self.low * k, self.mid * k, self.high * k)

    def __add__(self, other: Interval) -> Interval:
        return Interval(self.low + other.low, self.mid + other.mid, self.high + other.high)

    def as_dict(self) -> dict[str, float]:
        """``{"low", "mid", "high"}``."""
        return {"low": self.low, "mid": self.mid, "high": self.high}

    def as_list(self) -> list[float]:
        """``[low, mid, high]``."""
        return [self.low, self.mid, self.high]

    def contains(self, value: float) -> bool:
        """Whether ``low <= value <= high``."""
        return self.low <= value <= self.high


def add_counts(*vectors: Mapping[str, float]) -> dict[str, float]:
    """Sum of count vectors."""
    out: dict[str, float] = {}
    for v in vectors:
        for k, n in v.items():
            out[k] = out.get(k, 0.0) + n
    return out


def diff_counts(
    after: Mapping[str, Mapping[str, float]], before: Mapping[str, Mapping[str, float]]
) -> dict[str, dict[str, float]]:
    """Per-stage counts charged between two :meth:`TimingModel.counts_by_stage` snapshots."""
    out = {}
    for stage, counts in after.items():
        prev = before.get(stage, {})
        d = {k: n - prev.get(k, 0.0) for k, n in counts.items()}
        d = {k: n for k, n in d.items() if n}
        if d:
            out[stage] = d
    return out


def evaluate_us(
    counts: Mapping[str, float], constants: TimingConstants, clock_hz: float = DEFAULT_CLOCK_HZ
) -> float:
    """Modelled time (us) of a count vector under one point set of constants.

    Keys: ``"icw:<class>"`` (ICWs of a clock class), ``"kernels"`` (kernel runs),
    ``"calls:<name>"`` (controller calls) and ``"units:<name>"`` (their units). With the
    model's own constants this equals what :class:`TimingModel` charged.
    """
    table = _coefficients(constants, clock_hz)
    us = 0.0
    for key, n in counts.items():
        coef = table.get(key)
        if coef is None:
            coef = table[key] = _coefficient(key, constants, clock_hz)
        if coef[0]:  # an ICW class: n * cycles / clock * 1e6, in that order
            us += n * coef[1] / clock_hz * 1e6
        else:
            us += n * coef[1]
    return us


#: (id(constants), clock) -> (constants, {count key: coefficient}): each key's cost is
#: looked up once per point set (the constants are frozen; the entry keeps them alive).
_COEFFICIENTS: dict[tuple[int, float], tuple[TimingConstants, dict[str, tuple[bool, float]]]] = {}


def _coefficients(constants: TimingConstants, clock_hz: float) -> dict[str, tuple[bool, float]]:
    entry = _COEFFICIENTS.get((id(constants), clock_hz))
    if entry is None or entry[0] is not constants:
        if len(_COEFFICIENTS) >= 256:
            _COEFFICIENTS.clear()
        entry = _COEFFICIENTS[(id(constants), clock_hz)] = (constants, {})
    return entry[1]


def _coefficient(key: str, constants: TimingConstants, clock_hz: float) -> tuple[bool, float]:
    """``(is an ICW class, factor)``: the cost of one count of ``key``."""
    kind, _, name = key.partition(":")
    if kind == "icw":
        return True, constants.cycles(name)
    if kind == "kernels":
        return False, constants.kernel_launch_us
    if kind in ("calls", "units"):
        try:
            cost = constants.calls[name]
        except KeyError:
            raise TimingError(f"no modelled cost for controller call {name!r}") from None
        if kind == "calls":
            return False, constants.call_overhead_us + cost.fixed_us
        return False, cost.per_unit_us + sum(
            k * constants.cycles(c) / clock_hz * 1e6 for c, k in cost.per_unit_icws.items()
        )
    raise TimingError(f"unknown count key {key!r}")


def interval_us(
    counts: Mapping[str, float],
    constants: TimingConstants | None = None,
    clock_hz: float = DEFAULT_CLOCK_HZ,
    *,
    corners: Mapping[str, list[TimingConstants]] | None = None,
) -> Interval:
    """Low/mid/high modelled time (us) of a count vector (:meth:`TimingConstants.corners`)."""
    constants = constants if constants is not None else TimingConstants()
    corners = corners if corners is not None else constants.corners(clock_hz)
    mid = evaluate_us(counts, constants, clock_hz)
    # the mid constants are the fit's rounded values (3.72 cycles, 0.33 us), a hair off
    # the refitted corners' line: a bound never lies on the wrong side of the mid
    return Interval(
        min(mid, *(evaluate_us(counts, c, clock_hz) for c in corners["low"])),
        mid,
        max(mid, *(evaluate_us(counts, c, clock_hz) for c in corners["high"])),
    )


def _accumulated(start: float, steps: np.ndarray) -> float:
    """``start`` plus each of ``steps`` in turn, as a Python float: the same float as the
    additions one by one (an accumulation adds sequentially, never pairwise)."""
    return float(np.add.accumulate(np.concatenate(([start], steps)))[-1])
