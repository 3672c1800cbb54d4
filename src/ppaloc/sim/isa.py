"""The instruction set: one immutable record per ICW and one table describing every primitive.

An *instruction control word* (ICW) is what the SCAMP-5 controller broadcasts to all
processing elements in one clock. Here an ICW is an :class:`Instruction`: an operation
name, its destination and source registers, and (for messages and listings) the macro call
it came from. :data:`OPS` describes every primitive once: its clock class (which sets its
cost), how many destinations and sources of which kind it takes, and a one-line meaning.
Each row also says how the engine builds the instruction from its building blocks
(``Scamp5._op_*``: a FLAG-masked analogue transfer, an OR of digital planes, ...) into a
bound numpy operation. To add an instruction, add its row here; give it a method in
``macros.ProgramAPI`` if programs should call it by name (``k.icw(op, dsts, srcs)`` issues
any row directly).

Clock classes follow the ICW's clock field in the SCAMP-5 headers: analogue bus operations,
``where``, ``all``/``ALL`` and ``rpix`` use the analogue clock; ``SET``/``CLR``/``MOV``/
``OR``/``NOR``/``NOT``/``WHERE`` and the two halves of ``REFRESH`` the digital clock;
``DNEWS0``/``DNEWS1`` the DNEWS clock; ``nop`` an empty word. The header's PROP clock
(``PROP0``/``PROP1``, asynchronous propagation) has no constant of its own in the timing
model and is counted in the ``dnews`` class; ``PROP_R`` and ``sq``/``blur*`` carry the
analogue clock, ``blurset`` the digital one, as their ICWs do.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from ppaloc.errors import RegisterMisuseError
from ppaloc.sim.registers import Register

__all__ = ["CLOCK_CLASSES", "OPS", "Instruction", "OpSpec", "make"]

#: Clock classes an ICW can belong to (keys of kernel counts and of the timing model).
CLOCK_CLASSES: tuple[str, ...] = ("analog", "digital", "dnews", "nop")


@dataclass(frozen=True, slots=True)
class OpSpec:
    """The description of one primitive.

    Attributes
    ----------
    name : str
        SCAMP-5 name of the instruction.
    clock : str
        Clock class, one of :data:`CLOCK_CLASSES`.
    dst_kind, src_kind : str or None
        ``"analog"`` or ``"digital"``: the kind of register the destinations / sources
        must be (None: the instruction takes none).
    n_dst, n_src : tuple of int
        Inclusive (min, max) numbers of destinations and sources.
    meaning : str
        What the instruction does in every flagged element.
    build : callable
        ``build(engine, instruction) -> op``: the engine building block that performs it
        (``op()`` then runs it on the engine's planes).
    """

    name: str
    clock: str
    dst_kind: str | None
    src_kind: str | None
    n_dst: tuple[int, int]
    n_src: tuple[int, int]
    meaning: str
    build: Callable[[Any, Instruction], Callable[[], None]]


def _spec(name, clock, dst_kind, src_kind, n_dst, n_src, meaning, build) -> tuple[str, OpSpec]:
    return name, OpSpec(name, clock, dst_kind, src_kind, n_dst, n_src, meaning, build)


#: Every primitive, by name. ``a``: analogue, ``d``: digital register.
OPS: dict[str, OpSpec] = dict(
    [
        # name      clock     dst kind   src kind   n_dst   n_src   meaning, engine building block
        _spec("nop", "nop", None, None, (0, 0), (0, 0), "nothing", lambda m, i: m._op_nop(i)),
        _spec("rpix", "analog", None, None, (0, 0), (0, 0), "PIX := reset level",
              lambda m, i: m._op_rpix(i)),
        _spec("bus", "analog", "analog", "analog", (1, 1), (0, 4), "a := -(sum of sources)",
              lambda m, i: m._op_transfer(i, 1)),
        _spec("bus2", "analog", "analog", "analog", (2, 2), (0, 2), "a, b := -(sum)/2",
              lambda m, i: m._op_transfer(i, 2)),
        _spec("bus3", "analog", "analog", "analog", (3, 3), (1, 1), "a, b, c := -src/3",
              lambda m, i: m._op_transfer(i, 3)),
        _spec("where", "analog", None, "analog", (0, 0), (1, 3), "FLAG := (sum > 0)",
              lambda m, i: m._op_where(i)),
        _spec("all", "analog", None, None, (0, 0), (0, 0), "FLAG := 1",
              lambda m, i: m._op_flag_all(i)),
        _spec("SET", "digital", "digital", None, (1, 4), (0, 0), "d... := 1",
              lambda m, i: m._op_fill(i, True)),
        _spec("CLR", "digital", "digital", None, (1, 4), (0, 0), "d... := 0",
              lambda m, i: m._op_fill(i, False)),
        _spec("MOV", "digital", "digital", "digital", (1, 1), (1, 1), "d := s",
              lambda m, i: m._op_copy(i, False)),
        _spec("NOT", "digital", "digital", "digital", (1, 1), (1, 1), "d := NOT s",
              lambda m, i: m._op_copy(i, True)),
        _spec("OR", "digital", "digital", "digital", (1, 1), (2, 4), "d := OR of sources",
              lambda m, i: m._op_or(i, False)),
        _spec("NOR", "digital", "digital", "digital", (1, 1), (2, 4), "d := NOT(OR of sources)",
              lambda m, i: m._op_or(i, True)),
        _spec("WHERE", "digital", None, "digital", (0, 0), (1, 3), "FLAG := OR of sources",
              lambda m, i: m._op_flag_or(i)),
        _spec("LATCH", "digital", None, "digital", (0, 0), (1, 2), "bus latch := OR of sources",
              lambda m, i: m._op_latch(i, False)),
        _spec("LATCHN", "digital", None, "digital", (0, 0), (1, 2), "bus latch := NOR",
              lambda m, i: m._op_latch(i, True)),
        _spec("UNLATCH", "digital", "digital", None, (1, 1), (0, 0), "d := bus latch",
              lambda m, i: m._op_unlatch(i)),
        _spec("DNEWS0", "dnews", "digital", "digital", (1, 1), (1, 1), "d := OR of s_dir, edge 0",
              lambda m, i: m._op_dnews(i, False)),
        _spec("DNEWS1", "dnews", "digital", "digital", (1, 1), (1, 1), "d := OR of s_dir, edge 1",
              lambda m, i: m._op_dnews(i, True)),
        # The rows below are built by ppaloc.sim.semantics (one definition for every engine).
        _spec("busn", "analog", "analog", "analog", (1, 7), (0, 7), "a... := -(sum) / n_dst",
              lambda m, i: m._op_transfer(i, len(i.dsts))),
        _spec("sq", "analog", "analog", "analog", (1, 1), (1, 2), "NEWS := -(sum), squarer path",
              lambda m, i: m._op_transfer(i, 1)),
        _spec("blurset", "digital", None, "digital", (0, 0), (2, 2), "reads R1, R2 (blur links)",
              lambda m, i: m._op_nop(i)),
        _spec("blur", "analog", "analog", "analog", (1, 1), (1, 1), "a := -diffuse(x), both axes",
              lambda m, i: _semantics().build_blur(m, i, True, True)),
        _spec("blurh", "analog", "analog", "analog", (1, 1), (1, 1), "a := -diffuse(x), E-W",
              lambda m, i: _semantics().build_blur(m, i, True, False)),
        _spec("blurv", "analog", "analog", "analog", (1, 1), (1, 1), "a := -diffuse(x), N-S",
              lambda m, i: _semantics().build_blur(m, i, False, True)),
        _spec("PROP_R", "analog", None, "digital", (0, 0), (1, 1), "bus latch := R12",
              lambda m, i: m._op_latch(i, False)),
        _spec("PROP0", "dnews", "digital", None, (1, 1), (0, 0), "R12 flooded through R0, edge 0",
              lambda m, i: _semantics().build_prop(m, i, False)),
        _spec("PROP1", "dnews", "digital", None, (1, 1), (0, 0), "R12 flooded through R0, edge 1",
              lambda m, i: _semantics().build_prop(m, i, True)),
    ]
)  # fmt: skip


def _semantics():
    from ppaloc.sim import semantics

    return semantics


@dataclass(frozen=True, slots=True)
class Instruction:
    """One ICW: an operation with its destination and source registers.

    Attributes
    ----------
    op : str
        A key of :data:`OPS`.
    dsts, srcs : tuple of Register
        Destination and source registers, in the order written.
    origin : str or None
        The macro call this ICW was expanded from (e.g. ``"sub(A, B, C)"``), if any.
    """

    op: str
    dsts: tuple[Register, ...] = ()
    srcs: tuple[Register, ...] = ()
    origin: str | None = None

    @property
    def spec(self) -> OpSpec:
        """This instruction's row of :data:`OPS`."""
        return OPS[self.op]

    @property
    def clock(self) -> str:
        """Clock class of this ICW."""
        return OPS[self.op].clock

    def __str__(self) -> str:
        args = ", ".join(r.name for r in (*self.dsts, *self.srcs))
        return f"{self.op}({args})"


def _where(origin: str | None) -> str:
    return f"in {origin}: " if origin else ""


def make(
    op: str,
    dsts: tuple[Register, ...] = (),
    srcs: tuple[Register, ...] = (),
    origin: str | None = None,
) -> Instruction:
    """Build and validate one instruction.

    Raises
    ------
    RegisterMisuseError
        If a register is of the wrong kind, is not writable, the number of operands is
        out of range, or one register is listed twice; the message names the instruction
        (and the macro call it came from).
    """
    spec = OPS[op]
    ins = Instruction(op, tuple(dsts), tuple(srcs), origin)
    at = _where(origin)
    for r in (*ins.dsts, *ins.srcs):  # first: every message below prints the instruction
        if not isinstance(r, Register):
            raise RegisterMisuseError(
                f"{at}{op}: {r!r} is not a register handle; use A..F, NEWS, XN/XE/XS/XW, "
                "PIX, IN, R0..R12, FLAG or SELECT from ppaloc.sim"
            )
    for regs, kind, (lo, hi), what in (
        (ins.dsts, spec.dst_kind, spec.n_dst, "destination"),
        (ins.srcs, spec.src_kind, spec.n_src, "source"),
    ):
        if not lo <= len(regs) <= hi:
            want = f"{lo}" if lo == hi else f"{lo} to {hi}"
            raise RegisterMisuseError(
                f"{at}{op} takes {want} {what} register(s), got {len(regs)}: {ins}"
            )
        for r in regs:
            if r.kind != kind:
                raise RegisterMisuseError(
                    f"{at}{ins}: {r.name} is {'an analogue' if r.kind == 'analog' else 'a digital'}"
                    f" register but {op} needs {kind} {what}s"
                )
            if what == "destination" and not r.writable:
                why = (
                    "read-only"
                    if r.role in ("pixel", "input", "select")
                    else "set by where/WHERE/all"
                )
                raise RegisterMisuseError(
                    f"{at}{ins}: {r.name} cannot be written by an instruction (it is {why})"
                )
    seen: set[str] = set()
    for r in (*ins.dsts, *ins.srcs):
        if r.name in seen:
            raise RegisterMisuseError(
                f"{at}{ins} lists {r.name} twice; a register may appear only once per "
                "instruction (use a scratch register)"
            )
        seen.add(r.name)
    news_dsts = [r.name for r in ins.dsts if r.role in ("news", "neighbour")]
    if len(news_dsts) > 1:
        raise RegisterMisuseError(
            f"{at}{ins} writes the NEWS plane twice ({', '.join(news_dsts)}); "
            "write at most one of NEWS, XN, XE, XS, XW per instruction"
        )
    news_srcs = [r.name for r in ins.srcs if r.role in ("news", "neighbour")]
    if news_dsts and news_srcs:
        raise RegisterMisuseError(
            f"{at}{ins} reads and writes NEWS ({news_dsts[0]} and {', '.join(news_srcs)}): "
            "NEWS, XN, XE, XS and XW are one register, which an ICW cannot read and write; "
            "copy the value to another register first"
        )
    return ins
