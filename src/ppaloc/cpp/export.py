"""Simulated programs as SCAMP-5d C++: recorded kernels and traced runs (docs/cpp.md).

- :func:`kernel_to_cpp`: one recorded kernel as a function holding a static kernel block.
  The ICWs are grouped back into the macro calls they came from (each group is expanded
  again and checked to give the same ICWs), so the C++ issues exactly the recorded ICWs.
  Only the device library's functions are named: ppaloc's own ``XOR`` is written as the
  device calls it expands to (``AND``, ``NOR``, ``NOR``), so the program builds there.
- :class:`Tracer`: an observer of the simulator (:mod:`ppaloc.sim.observe`) recording
  what every simulator it observes does, as it runs: kernel runs, controller calls with
  their arguments and readouts, frame boundaries (``set_image``). Pass it to the
  simulators an on-sensor localiser creates with ``OnSensorLocaliser(...,
  observers=[tracer])``. Nothing is copied from the pipeline's code, and nothing in the
  simulator is replaced: whatever the on-sensor pipeline runs is what gets exported.
- :func:`to_cpp`: a kernel, or a trace, as C++. A trace becomes a whole device program:
  the kernels, a setup function (the masks and the map upload), one function per frame
  with its controller calls (array coordinates turned into hardware addresses), every
  readout checked against what the Python controller read, and the estimates posted.

The controller's decisions (which kernels and calls follow a readout) are those the
Python controller took on the traced frames: the program replays them and posts
``diverged`` at the first readout that differs, so it is exact for the traced frames and
says so when it is run on others.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ppaloc.cpp.server import events_buffer, pack_dreg_rows
from ppaloc.errors import PpalocError
from ppaloc.sim import Direction, Kernel, Register, Scamp5
from ppaloc.sim.controller import to_scamp_buffer
from ppaloc.sim.isa import Instruction
from ppaloc.sim.macros import ProgramAPI
from ppaloc.sim.observe import ControllerCall, ImageSet, KernelRun, PlaneWrite, SimEvent
from ppaloc.sim.registers import register_by_name

__all__ = ["Trace", "Tracer", "kernel_to_cpp", "to_cpp"]

# Primitives whose ICW name is also the device API's function.
_DEVICE_PRIMITIVES = frozenset(
    {"nop", "rpix", "bus", "bus2", "bus3", "where", "all", "SET", "CLR", "MOV", "OR", "NOR",
     "NOT", "WHERE", "DNEWS0", "DNEWS1"}
)  # fmt: skip


#: ppaloc's own macros (no device function), by the device calls that issue the same ICWs:
#: ``XOR`` is the expansion ``AND(d, x, y)`` (the macro header's), the kernel API's
#: ``NOR(R0, x, y)`` and the 2-ICW in-place ``NOR(d, R0)``: ``d := (x AND y) NOR (x NOR y)``.
_DEVICE_FORMS: dict[str, Callable[..., list[str]]] = {
    "XOR": lambda d, x, y: [f"AND({d}, {x}, {y})", f"NOR(R0, {x}, {y})", f"NOR({d}, R0)"],
}


# ------------------------------------------------------------------ kernels
class _Recorder(ProgramAPI):
    """Collects the ICWs a macro call expands to, without a simulator."""

    def __init__(self) -> None:
        self.out: list[Instruction] = []

    def _emit(self, instructions: tuple[Instruction, ...]) -> None:
        self.out.extend(instructions)


def _parse_arg(token: str) -> Any:
    token = token.strip()
    with contextlib.suppress(PpalocError):
        return register_by_name(token)
    names = token.split("|")
    if all(n in Direction.__members__ for n in names):
        d = Direction(0)
        for n in names:
            d |= Direction[n]
        return d
    if token in ("True", "False"):
        return token == "True"
    return int(token)


def _same(a: Instruction, b: Instruction) -> bool:
    return (a.op, a.dsts, a.srcs) == (b.op, b.dsts, b.srcs)


def _calls(instructions: Sequence[Instruction]) -> list[str]:
    """The macro calls (as C++ statements) that issue exactly ``instructions``."""
    out: list[str] = []
    i = 0
    while i < len(instructions):
        ins = instructions[i]
        origin = ins.origin
        if origin:
            m = re.fullmatch(r"(\w+)\((.*)\)", origin)
            try:
                name, body = m.group(1), m.group(2)  # type: ignore[union-attr]
                args = [_parse_arg(t) for t in body.split(",")] if body.strip() else []
                rec = _Recorder()
                getattr(rec, name)(*args)
            except (AttributeError, ValueError, TypeError, PpalocError):
                rec = None
            n = 0 if rec is None else len(rec.out)
            chunk = instructions[i : i + n]
            if n and len(chunk) == n and all(map(_same, chunk, rec.out)):  # type: ignore[union-attr]
                if name in _DEVICE_FORMS:
                    out += [f"{c};" for c in _device_form(name, args, chunk)]
                else:
                    out.append(f"{origin};")
                i += n
                continue
        if ins.op in _DEVICE_PRIMITIVES:
            out.append(f"{ins.op}({', '.join(r.name for r in (*ins.dsts, *ins.srcs))});")
        else:
            out.append(_raw_word(ins, i))
        i += 1
    return out


def _device_form(name: str, args: list, chunk: Sequence[Instruction]) -> list[str]:
    """The device calls of :data:`_DEVICE_FORMS` for one macro call, checked to issue
    exactly the ICWs ``chunk`` the call issued."""
    calls = _DEVICE_FORMS[name](*(a.name for a in args))
    rec = _Recorder()
    for c in calls:
        m = re.fullmatch(r"(\w+)\((.*)\)", c)
        getattr(rec, m.group(1))(*(_parse_arg(t) for t in m.group(2).split(",")))  # type: ignore[union-attr]
    if len(rec.out) != len(chunk) or not all(map(_same, chunk, rec.out)):
        raise PpalocError(f"cannot export {name}{tuple(args)}: {'; '.join(calls)} differs")
    return calls


def _raw_word(ins: Instruction, i: int) -> str:
    """``icw(clock, {bits})``: an ICW no device function issues alone, as its raw word."""
    from ppaloc.cpp.shimgen import icw_bits
    from ppaloc.sim.bits import CLOCKS, decode, encode

    try:
        clock, bits = encode(ins)
        back = decode(clock, bits)
    except PpalocError as exc:
        raise PpalocError(f"cannot export ICW #{i} {ins}: {exc}") from None
    if not _same(back, ins):
        raise PpalocError(f"cannot export ICW #{i} {ins}: its raw word reads back as {back}")
    names = {v: k for k, v in icw_bits().items()}
    clocks = {v: k for k, v in CLOCKS.items()}
    shown = ", ".join(names[b] for b in sorted(bits))
    return f"icw(SCAMP5_CLOCK_{clocks[clock].upper()}, {{{shown}}});  // {ins}"


def kernel_to_cpp(
    kernel: Kernel | Sequence[Instruction], name: str = "kernel", *, heap: bool = False
) -> str:
    """A recorded kernel as a C++ function running one static kernel block.

    Parameters
    ----------
    kernel : Kernel or sequence of Instruction
    name : str
        The function's name.
    heap : bool
        Start the kernel with ``move_to_heap(true)`` (it then does not hold room on the
        1024-ICW stack every static kernel shares).

    Examples
    --------
    >>> from ppaloc.sim import Scamp5, A, B, C, east
    >>> sim = Scamp5(8, 8)
    >>> with sim.kernel() as k:
    ...     k.movx(A, B, east)
    ...     k.add(C, A, B)
    >>> print(kernel_to_cpp(k, "edges"))
    // 4 ICWs: analog 4, digital 0, dnews 0, nop 0
    void edges() {
        scamp5_kernel_begin();
            movx(A, B, east);
            add(C, A, B);
        scamp5_kernel_end();
    }
    """
    instructions = list(kernel)
    counts = dict.fromkeys(("analog", "digital", "dnews", "nop"), 0)
    for ins in instructions:
        counts[ins.clock] = counts.get(ins.clock, 0) + 1
    shown = ", ".join(f"{k} {v}" for k, v in counts.items())
    body = (["move_to_heap(true);"] if heap else []) + _calls(instructions)
    lines = [f"// {len(instructions)} ICWs: {shown}", f"void {name}() {{"]
    lines.append("    scamp5_kernel_begin();")
    lines += [f"        {stmt}" for stmt in body]
    lines += ["    scamp5_kernel_end();", "}"]
    return "\n".join(lines)


# ------------------------------------------------------------------ tracing
@dataclass
class Trace:
    """What one simulator did, in order: the events its observers received
    (:mod:`ppaloc.sim.observe`: kernel runs, controller calls, ``set_image``, ``write``)."""

    sim: Scamp5
    events: list[SimEvent] = field(default_factory=list)

    @property
    def frames(self) -> int:
        """Frames the simulator was given (``set_image`` calls)."""
        return sum(1 for e in self.events if isinstance(e, ImageSet))


class Tracer:
    """An observer recording one :class:`Trace` per simulator it observes.

    Attach it to a simulator (``Scamp5(..., observers=[tracer])`` or
    ``sim.observe(tracer)``), or to every simulator an on-sensor localiser creates
    (``OnSensorLocaliser(..., observers=[tracer])``); nothing else is changed.

    Examples
    --------
    >>> from ppaloc.sim import Scamp5, A, B
    >>> tracer = Tracer()
    >>> sim = Scamp5(8, 8, observers=[tracer])
    >>> sim.scamp5_in(A, 5)
    >>> with sim.kernel() as k:
    ...     k.mov(B, A)
    >>> [type(e).__name__ for e in tracer.trace_of(sim).events]
    ['ControllerCall', 'KernelRun']
    """

    def __init__(self) -> None:
        self.traces: list[Trace] = []
        self._by_sim: dict[int, Trace] = {}  # id(sim): each Trace keeps its sim alive

    def __call__(self, sim: Scamp5, event: SimEvent) -> None:
        trace = self._by_sim.get(id(sim))
        if trace is None:
            trace = self._by_sim[id(sim)] = Trace(sim)
            self.traces.append(trace)
        trace.events.append(event)

    def trace_of(self, sim: Scamp5) -> Trace:
        """The trace of ``sim``.

        Raises
        ------
        PpalocError
            If ``sim`` did nothing while this tracer observed it.
        """
        trace = self._by_sim.get(id(sim))
        if trace is None:
            raise PpalocError(
                "this simulator did nothing while the tracer observed it: pass the tracer "
                "as Scamp5(..., observers=[tracer]) or OnSensorLocaliser(..., "
                "observers=[tracer]) before running the program"
            )
        return trace


# ------------------------------------------------------------------ a trace as a program
def _reg(r: Any) -> str:
    return r.name if isinstance(r, Register) else str(int(r))


def _hw_col(sim: Scamp5, c: int, scamp_addr: bool) -> int:
    return int(c) if scamp_addr else sim.cols - 1 - int(c)


def _hw_pattern(sim: Scamp5, r: int, c: int, rx: int, cx: int, scamp_addr: bool) -> int:
    """The hardware column ``c'`` whose pattern selects what ``(r, c, rx, cx)`` selects."""
    if scamp_addr:
        return int(c)
    want = sim.address_mask(r, c, rx, cx, False)
    for guess in (int(c) ^ (sim.cols - 1), (sim.cols - 1 - int(c)) & 0xFF):
        if np.array_equal(sim.address_mask(r, guess, rx, cx, True), want):
            return guess
    raise PpalocError(
        f"the pattern (r={r}, c={c}, rx={rx}, cx={cx}) has no hardware-address form on a "
        f"{sim.cols}-column array"
    )


class _Program:
    """Builds the C++ text of a trace."""

    def __init__(self, trace: Trace, heap: bool) -> None:
        self.sim = trace.sim
        self.trace = trace
        self.heap = heap
        self.kernels: dict[int, tuple[str, str]] = {}  # id(kernel or tuple) -> (name, text)
        self.direct: dict[tuple, str] = {}
        self.tables: list[str] = []
        self.checks = 0

    def kernel(self, key: Kernel | None, instructions: Sequence[Instruction]) -> str:
        ref = id(key) if isinstance(key, Kernel) else None
        if ref is not None and ref in self.kernels:
            return self.kernels[ref][0]
        if ref is None:
            sig = tuple((i.op, i.dsts, i.srcs, i.origin) for i in instructions)
            if sig in self.direct:
                return self.direct[sig]
        name = f"k{len(self.kernels) + len(self.direct)}"
        on_heap = isinstance(key, Kernel) and key.on_heap  # moved there by its program
        text = kernel_to_cpp(instructions, name, heap=self.heap or on_heap)
        if ref is not None:
            self.kernels[ref] = (name, text)
        else:
            self.direct[sig] = name
            self.kernels[id(sig)] = (name, text)
        return name

    def table(self, data: bytes) -> str:
        name = f"want{len(self.tables)}"
        values = ", ".join(str(b) for b in data)
        self.tables.append(f"static const uint8_t {name}[{len(data)}] = {{{values}}};")
        return name

    def check_int(self, expr: str, want: int) -> str:
        self.checks += 1
        return f"ppaloc_check({expr}, {int(want)}, {self.checks});"

    def check_buffer(self, call: str, want: bytes) -> str:
        self.checks += 1
        table = self.table(want)
        return (
            f"{{ static uint8_t got[{len(want)}]; {call.replace('BUF', 'got')}; "
            f"ppaloc_check_bytes(got, {table}, {len(want)}, {self.checks}); }}"
        )

    def call(self, name: str, a: Mapping[str, Any], result: Any) -> str:
        sim = self.sim
        hw = bool(a.get("scamp_addr", False))
        if name == "scamp5_in":
            return f"scamp5_in({_reg(a['areg'])}, {a['value']}, {_reg(a['temp'])});"
        if name == "load_in":
            if a["value"] is None:
                return f"scamp5_load_in({int(a['areg_or_value'])});"
            return f"scamp5_load_in({_reg(a['areg_or_value'])}, {a['value']}, {_reg(a['temp'])});"
        if name == "scamp5_get_image":
            return f"scamp5_get_image({_reg(a['yf'])}, {_reg(a['yh'])}, {a['gain']});"
        if name in ("load_pattern", "select_pattern"):
            c = _hw_pattern(sim, a["r"], a["c"], a["rx"], a["cx"], hw)
            target = f"{_reg(a['dreg'])}, " if "dreg" in a else ""
            return f"scamp5_{name}({target}{a['r']}, {c}, {a['rx']}, {a['cx']});"
        if name in ("load_point", "select_point"):
            target = f"{_reg(a['dreg'])}, " if "dreg" in a else ""
            return f"scamp5_{name}({target}{a['r']}, {_hw_col(sim, a['c'], hw)});"
        if name in ("load_rect", "select_rect"):
            ra, rb = sorted((int(a["r0"]), int(a["r1"])))
            ca, cb = sorted((_hw_col(sim, a["c0"], hw), _hw_col(sim, a["c1"], hw)))
            target = f"{_reg(a['dreg'])}, " if "dreg" in a else ""
            # the device's (r0, c0) is the top-right corner: the smaller hardware column
            return f"scamp5_{name}({target}{ra}, {ca}, {rb}, {cb});"
        if name == "shift":
            reg = a["reg"]
            if reg.kind == "analog":
                return f"scamp5_shift({_reg(reg)}, {a['h']}, {a['v']});"
            refresh = a.get("refresh", 2)
            return f"scamp5_shift({_reg(reg)}, {a['h']}, {a['v']}, {a['boundary']}, {refresh});"
        if name in ("global_sum_16", "global_sum_64"):
            return self.check_int(f"(int)scamp5_{name}({_reg(a['areg'])})", result)
        if name == "global_or":
            c = _hw_pattern(sim, a["r"], a["c"], a["rx"], a["cx"], hw)
            expr = f"scamp5_global_or({_reg(a['dreg'])}, {a['r']}, {c}, {a['rx']}, {a['cx']})"
            return self.check_int(expr, result)
        if name == "global_count":
            expr = f"scamp5_global_count({_reg(a['dreg'])}, {_reg(a['temp'])}, {a['options']})"
            return self.check_int(expr, result)
        if name == "read_areg":
            expr = f"scamp5_read_areg({_reg(a['areg'])}, {a['r']}, {_hw_col(sim, a['c'], hw)})"
            return self.check_int(expr, result)
        if name == "scan_areg":
            r1 = sim.rows - 1 if a["r1"] is None else int(a["r1"])
            c1 = sim.cols - 1 if a["c1"] is None else int(a["c1"])
            cols = list(range(int(a["c0"]), c1 + 1, int(a["cs"])))
            hw_cols = sorted(_hw_col(sim, c, hw) for c in cols)
            call = (
                f"scamp5_scan_areg({_reg(a['areg'])}, BUF, {a['r0']}, {hw_cols[0]}, {r1}, "
                f"{hw_cols[-1]}, {a['rs']}, {a['cs']})"
            )
            return self.check_buffer(call, to_scamp_buffer(result).tobytes())
        if name in ("scan_areg_8x8", "scan_areg_mean_8x8"):
            call = f"scamp5_{name}({_reg(a['areg'])}, BUF)"
            return self.check_buffer(call, to_scamp_buffer(result).tobytes())
        if name == "scan_dreg":
            r1 = sim.rows - 1 if a["r1"] is None else int(a["r1"])
            call = f"scamp5_scan_dreg({_reg(a['dreg'])}, BUF, {a['r0']}, {r1})"
            return self.check_buffer(call, pack_dreg_rows(result))
        if name == "scan_events":
            events = np.asarray(result).reshape(-1, 2)
            if not hw:
                events = np.stack([events[:, 0], sim.cols - 1 - events[:, 1]], axis=1)
            call = (
                f"scamp5_scan_events({_reg(a['dreg'])}, BUF, {a['max_num']}, {a['h_dir']}, "
                f"{a['v_dir']})"
            )
            return self.check_buffer(call, events_buffer(events, int(a["max_num"])))
        if name in ("kernel_all", "kernel_refresh_dreg", "draw_end", "draw_negate"):
            return f"scamp5_{name}();"
        if name == "load_dac":
            if a["dac"] is None:
                return f"scamp5_load_dac({int(a['areg_or_dac'])});"
            return f"scamp5_load_dac({_reg(a['areg_or_dac'])}, {a['dac']}, {_reg(a['temp'])});"
        if name in ("select_row", "select_rowx", "select_colx"):
            return f"scamp5_{name}({int(next(iter(a.values())))});"
        if name == "select_col":
            return f"scamp5_select_col({_hw_col(sim, a['c'], hw)});"
        if name == "draw_begin":
            return f"scamp5_draw_begin({_reg(a['dreg'])});"
        if name in ("global_sum_fast", "vs_scamp5_get_parameter"):
            arg = _reg(next(iter(a.values())))
            prefix = "" if name.startswith("vs_") else "scamp5_"
            return self.check_int(f"(int){prefix}{name}({arg})", result)
        raise PpalocError(
            f"the traced program calls {name}, which the export does not write yet; "
            "docs/cpp.md lists the calls it writes"
        )

    def sections(self) -> list[list[str]]:
        """Statements of the setup (index 0) and of each frame."""
        out: list[list[str]] = [[]]
        for event in self.trace.events:
            if isinstance(event, ImageSet):
                out.append([])
            elif isinstance(event, KernelRun):
                out[-1].append(f"{self.kernel(event.kernel, event.instructions)}();")
            elif isinstance(event, ControllerCall):
                out[-1].append(self.call(event.name, event.arguments, event.result))
            elif isinstance(event, PlaneWrite):
                raise PpalocError(
                    f"the traced run set {event.register.name} with sim.write, an inspection "
                    "tool with no device call: set registers through kernels and controller "
                    "calls in a program to export"
                )
            else:
                raise PpalocError(f"a trace holds simulator events, not {event!r}")
        return out


_PRELUDE = """\
static int ppaloc_mismatch = 0;  // readouts that differ from the traced run

static void ppaloc_check(int got, int want, int id) {
    if (got != want && !ppaloc_mismatch++)
        vs_post_text("diverged at readout %d: got %d, traced %d", id, got, want);
}

static void ppaloc_check_bytes(const uint8_t* got, const uint8_t* want, int n, int id) {
    for (int i = 0; i < n; ++i) {
        if (got[i] != want[i]) {
            if (!ppaloc_mismatch++)
                vs_post_text("diverged at readout %d, byte %d: got %d, traced %d", id, i,
                             got[i], want[i]);
            return;
        }
    }
}
"""


def _trace_to_cpp(
    trace: Trace, estimates: Sequence[tuple[int, float]] | None, title: str, heap: bool
) -> str:
    program = _Program(trace, heap)
    sections = program.sections()
    n_frames = len(sections) - 1
    if estimates is not None and len(estimates) != n_frames:
        raise PpalocError(
            f"{len(estimates)} estimates for a trace of {n_frames} frames: give one per frame"
        )
    lines = [
        f"// {title}",
        "// Generated by ppaloc (ppaloc.cpp.export.to_cpp) from a traced run of "
        f"{n_frames} frame(s) on a {trace.sim.rows}x{trace.sim.cols} array.",
        "// Kernels are static kernel blocks; controller calls use hardware addresses;",
        "// every readout is checked against the traced run (docs/cpp.md, Export).",
        "#include <scamp5.hpp>",
        "using namespace SCAMP5_PE;",
        "",
        _PRELUDE,
    ]
    frames_text = []
    for k, body in enumerate(sections):
        fn = "ppaloc_setup" if k == 0 else f"ppaloc_frame_{k - 1}"
        text = [f"static void {fn}() {{", *(f"    {s}" for s in body)]
        if k and estimates is not None:
            node, score = estimates[k - 1]
            text.append(
                f'    if (!ppaloc_mismatch) vs_post_text("estimate %d: node {int(node)} '
                f'score {float(score):g}", {k - 1});'
            )
        text.append("}")
        frames_text.append("\n".join(text))
    kernels = [text for _, text in program.kernels.values()]
    lines += [*program.tables, ""]
    for text in kernels:
        head, rest = text.split("\n", 1)
        lines += [head, "static " + rest, ""]
    lines += frames_text
    cases = "\n".join(f"            case {k}: ppaloc_frame_{k}(); break;" for k in range(n_frames))
    lines += [
        "",
        "int main() {",
        "    vs_init();",
        "    ppaloc_setup();",
        "    for (int frame = 0;; ++frame) {",
        "        vs_frame_loop_control();",
        "        switch (frame) {",
        cases,
        '            default: vs_post_text("traced frames done"); break;',
        "        }",
        "    }",
        "}",
        "",
    ]
    return "\n".join(lines)


def to_cpp(
    source: Kernel | Sequence[Instruction] | Trace,
    *,
    name: str = "kernel",
    estimates: Sequence[tuple[int, float]] | None = None,
    title: str = "a ppaloc program",
    heap: bool = True,
) -> str:
    """SCAMP-5d C++ of a recorded kernel (a function) or of a trace (a whole program).

    Parameters
    ----------
    source : Kernel, sequence of Instruction, or Trace
        A kernel, or a :class:`Trace` from a :class:`Tracer`.
    name : str
        A kernel's function name.
    estimates : sequence of (node, score), optional
        A trace's per-frame estimates, posted by the program while its readouts agree.
    title : str
        A trace's first comment line.
    heap : bool
        A trace's kernels start with ``move_to_heap(true)``, so a long pipeline does not
        overflow the 1024-ICW stack that static kernels share. A kernel its program moved
        to the heap (:attr:`ppaloc.sim.Kernel.on_heap`) starts with it either way.
    """
    if isinstance(source, Trace):
        return _trace_to_cpp(source, estimates, title, heap)
    return kernel_to_cpp(source, name, heap=isinstance(source, Kernel) and source.on_heap)
