"""The ICW bit encoding of ``scamp5_icw.hpp``: instructions to raw words and back.

A raw SCAMP-5 ICW is a clock field and a set of bit positions (``SCAMP5_ICW_BITS``):
analogue registers have a write bit and select bits, digital ones a read (``RR``) and a
write (``LR``) bit, and flag bits choose the operation. :func:`encode` gives the word the
header's builders produce for an :class:`~ppaloc.sim.isa.Instruction`; :func:`decode`
reads a raw word (what the header's ``icw(clock, bits)`` issues) back into one, accepting
each variant the headers emit (the read and write halves of the 2-ICW macros come in
several spellings). Words that match no modelled operation raise ``RegisterMisuseError``.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable

from ppaloc.errors import RegisterMisuseError
from ppaloc.sim.isa import Instruction, make
from ppaloc.sim.registers import (
    DIGITAL_PLANES,
    FLAG,
    IN,
    NEWS,
    PIX,
    R0,
    RECT,
    SELECT,
    XE,
    XN,
    XS,
    XW,
    A,
    B,
    C,
    D,
    E,
    F,
    Register,
)

__all__ = ["BIT_NAMES", "CLOCKS", "decode", "encode", "register_fields"]

#: The names of the word's 80 bit positions (``SCAMP5_ICW_BITS``), by position: flag bits,
#: the analogue write (``W1``-``W7``) and select (``SEL1``-``SEL7``) bits, the digital read
#: (``RR1``-``RR12``) and write (``LR1``-``LR12``) bits, and the readout control bits.
BIT_NAMES: tuple[str, ...] = (
    "selsq", "selpix", "rstpix", "seldiffe", "seldiffs", "s_in", "rana", "sels", "_bit8",
    "sele", "selx", "rid", "seln",
    *(f"W{i}" for i in range(1, 8)), "wrf", *(f"SEL{i}" for i in range(1, 8)),
    "setf", "selw", "pupd", "fbus",
    *(f"RR{i}" for i in range(1, 13)), *(f"LR{i}" for i in range(1, 13)),
    "lfl", "rfl", "nbit", "nb", "plwb", "plrb", "bit", "bitmode", "wr", "ana", "dig8",
    "g_start", "g_stop", "col_out", "dir", "row_out", "s0_left", "s1_left", "rst_start",
    "rst_stop", "s0_bot", "s1_bot", "pgdb", "pgdbobus",
)  # fmt: skip

#: The header's clock field values (``SCAMP5_CLOCK_*``).
CLOCKS = {"analog": 0, "digital": 1, "dnews": 2, "prop": 3}

# Flag bits (SCAMP5_ICW_BITS).
SELSQ, SELPIX, RSTPIX, SELDIFFE, SELDIFFS, S_IN, RID = 0, 1, 2, 3, 4, 5, 11
WRF, SETF, PUPD, FBUS, NBIT, NB, PLWB, PLRB, BIT, BITMODE = 20, 28, 30, 31, 58, 59, 60, 61, 62, 63

_W = {A: 13, B: 14, C: 15, NEWS: 16, D: 17, E: 18, F: 19}
_SEL = {A: 21, B: 22, C: 23, D: 25, E: 26, F: 27, PIX: SELPIX, IN: S_IN}
_NEWS_SEL = 24
_NEWS_DIR = {NEWS: 10, XN: 7, XE: 9, XS: 12, XW: 29}


def _rr(r: Register) -> frozenset[int]:
    if r is RECT:
        return frozenset({64, 72, 76})
    if r is SELECT:
        return frozenset({64})
    if r is FLAG:
        return frozenset({6})
    if r is R0:
        return frozenset({57})
    return frozenset({32 + r.index - 1})


def _lr(r: Register) -> int:
    if r is R0:
        return 56
    return 44 + r.index - 1 if r.index <= 4 else 48 + r.index - 5


def _asel(r: Register) -> set[int]:
    if r.role in ("news", "neighbour"):
        return {_NEWS_SEL, _NEWS_DIR[r]}
    return {_SEL[r]}


def _awrite(r: Register) -> set[int]:
    return {_W[NEWS] if r.role in ("news", "neighbour") else _W[r], *_asel(r)}


# The bit the device's register constants give where a register has no write (PIX, IN)
# or no latch (FLAG, SELECT, RECT): bit 8, which no instruction uses.
_UNUSED = 8


def _masks(positions: Iterable[int]) -> dict[int, int]:
    """Bit positions as 16-bit words of the ICW: ``{word index: mask}``."""
    out: dict[int, int] = {}
    for b in positions:
        out[b // 16] = out.get(b // 16, 0) | 1 << (b % 16)
    return out


def register_fields(r: Register) -> dict[str, int]:
    """The fields of the device's register constant for ``r`` (``scamp5_icw.hpp``).

    An analogue register is ``{W_bits, sel_bits}``: 32-bit masks over the ICW's first two
    16-bit words, its write and its select bits. A digital one is ``{RR_index, RR_bits,
    LR_index, LR_bits}``: the word and the mask of its read (``RR``) and write (``LR``)
    bits. Programs compare registers by these fields, and raw ICWs are built from them.

    Examples
    --------
    >>> register_fields(A)
    {'W_bits': 8192, 'sel_bits': 2097152}
    >>> register_fields(R0)
    {'RR_index': 3, 'RR_bits': 512, 'LR_index': 3, 'LR_bits': 256}
    """
    if r.kind == "analog":
        writable = r in _W or r.role in ("news", "neighbour")
        w = sum(1 << b for b in _awrite(r) - _asel(r)) if writable else 1 << _UNUSED
        return {"W_bits": w, "sel_bits": sum(1 << b for b in _asel(r))}
    ((rr_index, rr_bits),) = _masks(_rr(r)).items()
    latch = _UNUSED if r in (FLAG, SELECT, RECT) else _lr(r)
    ((lr_index, lr_bits),) = _masks([latch]).items()
    return {"RR_index": rr_index, "RR_bits": rr_bits, "LR_index": lr_index, "LR_bits": lr_bits}


_DIGITAL_FLAGS = {
    "SET": {S_IN, PLWB},
    "CLR": {S_IN, PLRB, BIT, BITMODE},
    "MOV": {S_IN, PLRB, BIT, BITMODE},
    "OR": {S_IN, PLRB, BIT, BITMODE},
    "NOT": {S_IN, PLWB, PLRB, NBIT, BITMODE},
    "NOR": {S_IN, PLWB, PLRB, NBIT, BITMODE},
    "WHERE": {WRF, PLRB, RID},
    "LATCH": {PLRB, BIT, BITMODE},
    "LATCHN": {PLRB, NBIT},
    "UNLATCH": {BIT, BITMODE},
    "DNEWS0": {S_IN, RID, NB, PLRB, BIT, FBUS},
    "DNEWS1": {S_IN, RID, NB, PLRB, BIT, FBUS, PUPD},
    "blurset": set(),
}


def _macro_name(origin: str | None) -> str:
    """The macro an ICW was expanded from: ``"NOT"`` for ``"NOT(R5)"``."""
    return "" if origin is None else origin.split("(", 1)[0]


_NBIT_WRITES = frozenset({"NOT", "NOR", "XOR"})
"""Macros whose latch is read with ``nbit`` (``LATCHN``) and written back with it too."""


def encode(ins: Instruction) -> tuple[int, frozenset[int]]:
    """``(clock, bit positions)`` of the ICW the header builds for ``ins``.

    The latch halves of the 2-ICW digital macros are spelt as their macro spells them:
    the write half of ``NOT``/``NOR`` (whose read half sets ``nbit``) as ``nbit`` and the
    register, that of ``OR`` as ``bit, bitmode``; ``REFRESH``'s halves (the header's
    ``REFRESH_R``/``REFRESH_L``) also set ``s_in``. :func:`decode` reads each spelling.
    """
    op, bits = ins.op, set()
    if op == "nop":
        return 0, frozenset()
    if op == "rpix":
        return 0, frozenset({RSTPIX, SELPIX})
    if op == "all":
        return 0, frozenset({SETF, PLRB, RID})
    if op in ("bus", "bus2", "bus3", "busn", "where", "sq", "blur", "blurh", "blurv"):
        for d in ins.dsts:
            bits |= _awrite(d)
        for s in ins.srcs:
            bits |= _asel(s)
        bits |= {
            "where": {WRF},
            "sq": {SELSQ},
            "blur": {SELDIFFE, SELDIFFS},
            "blurh": {SELDIFFE},
            "blurv": {SELDIFFS},
        }.get(op, set())
        return 0, frozenset(bits)
    if op == "PROP_R":
        return 0, frozenset({S_IN, 43, PLRB, BIT, BITMODE})
    if op in ("PROP0", "PROP1"):
        bits = {S_IN, 43, 55, FBUS, RID, NB} | ({PUPD} if op == "PROP1" else set())
        return CLOCKS["prop"], frozenset(bits)
    bits = set(_DIGITAL_FLAGS[op])
    macro = _macro_name(ins.origin)
    if op == "UNLATCH" and macro in _NBIT_WRITES:
        bits = {NBIT}
    if op in ("LATCH", "UNLATCH") and macro in ("REFRESH", "kernel_refresh_dreg"):
        bits.add(S_IN)
    for d in ins.dsts:
        bits.add(_lr(d))
    for s in ins.srcs:
        bits |= _rr(s)
    return CLOCKS["dnews" if op.startswith("DNEWS") else "digital"], frozenset(bits)


_RR_BY_BIT = {32 + i - 1: r for r in DIGITAL_PLANES if 1 <= (i := r.index) <= 12}
_RR_BY_BIT.update({57: R0, 6: FLAG})
_LR_BY_BIT = {_lr(r): r for r in DIGITAL_PLANES if r.index <= 12}
_DIGITAL_FLAG_BITS = {S_IN, PLWB, PLRB, BIT, BITMODE, NBIT, WRF, RID, NB, FBUS, PUPD}


def _bad(clock: int, bits: Iterable[int], why: str) -> RegisterMisuseError:
    # the word by the header's bit names (plrb, LR4, ...), as a program writes it
    shown = ", ".join(BIT_NAMES[b] if 0 <= b < len(BIT_NAMES) else str(b) for b in sorted(bits))
    return RegisterMisuseError(
        f"icw({clock}, {{{shown}}}): {why}; issue a modelled word (docs/sim.md lists them) "
        "or name the operation, k.icw('bus', (A,), (B,))"
    )


def _digital_regs(bits: set[int]) -> tuple[tuple[Register, ...], tuple[Register, ...]]:
    srcs = []
    if {64, 72, 76} <= bits:
        srcs.append(RECT)
        bits -= {64, 72, 76}
    elif 64 in bits:
        srcs.append(SELECT)
        bits.discard(64)
    for b in sorted(bits & set(_RR_BY_BIT)):
        srcs.append(_RR_BY_BIT[b])
    dsts = [_LR_BY_BIT[b] for b in sorted(bits & set(_LR_BY_BIT))]
    return tuple(sorted(dsts, key=lambda r: r.index)), tuple(sorted(srcs, key=lambda r: r.index))


def _decode_digital(clock: int, bits: set[int]) -> tuple[str, tuple, tuple]:
    flags = bits & _DIGITAL_FLAG_BITS
    rest = bits - _DIGITAL_FLAG_BITS
    dsts, srcs = _digital_regs(set(rest))
    known = set().union(*(_rr(r) for r in srcs), *({_lr(r)} for r in dsts))
    if rest - known:
        raise _bad(clock, bits, f"bits {sorted(rest - known)} name no modelled register")
    if clock == CLOCKS["dnews"]:
        return ("DNEWS1" if PUPD in flags else "DNEWS0"), dsts, srcs
    if not flags and not dsts and {r.name for r in srcs} == {"R1", "R2"}:
        return "blurset", (), srcs
    if WRF in flags:
        return "WHERE", (), srcs
    if dsts and PLWB in flags and PLRB not in flags and not srcs:
        return "SET", dsts, ()
    if dsts and {PLWB, PLRB, NBIT} <= flags:
        return ("NOT" if len(srcs) == 1 else "NOR"), dsts, srcs
    if dsts and {S_IN, PLRB, BIT, BITMODE} <= flags:
        return ("CLR", "MOV")[len(srcs)] if len(srcs) < 2 else "OR", dsts, srcs
    if dsts and not srcs and PLRB not in flags:
        return "UNLATCH", dsts, ()
    if srcs and not dsts and PLRB in flags:
        return ("LATCHN" if NBIT in flags else "LATCH"), (), srcs
    raise _bad(clock, bits, "no modelled digital operation has these bits")


def _decode_analog(clock: int, bits: set[int]) -> tuple[str, tuple, tuple]:
    if not bits:
        return "nop", (), ()
    if bits == {RSTPIX, SELPIX}:
        return "rpix", (), ()
    if SETF in bits:
        return "all", (), ()
    if {S_IN, 43, PLRB, BIT, BITMODE} == bits:
        return "PROP_R", (), ()
    flags = bits & {SELSQ, SELDIFFE, SELDIFFS, WRF}
    rest = bits - flags
    dsts = [r for r, w in _W.items() if w in rest and r is not NEWS]
    srcs = [r for r in (A, B, C, D, E, F) if _SEL[r] in rest and r not in dsts]
    srcs += [r for r in (PIX, IN) if _SEL[r] in rest]
    dirs = [r for r, b in _NEWS_DIR.items() if b in rest]
    if _W[NEWS] in rest:
        if len(dirs) != 1:
            raise _bad(clock, bits, "the NEWS write needs exactly one of NEWS, XN, XE, XS, XW")
        dsts.append(dirs[0])
    else:
        srcs += dirs
    used = set().union(*(_awrite(d) for d in dsts), *(_asel(s) for s in srcs))
    if rest - used or (dirs and _NEWS_SEL not in rest):
        raise _bad(clock, bits, f"bits {sorted(rest - used)} name no modelled register")
    dsts.sort(key=lambda r: r.index)
    if WRF in flags:
        return "where", (), tuple(srcs)
    if SELSQ in flags:
        return "sq", tuple(dsts), tuple(srcs)
    if SELDIFFE in flags or SELDIFFS in flags:
        kind = {SELDIFFE, SELDIFFS} & flags
        op = "blur" if len(kind) == 2 else ("blurh" if SELDIFFE in kind else "blurv")
        return op, tuple(dsts), tuple(srcs)
    n, m = len(dsts), len(srcs)
    op = "bus" if n == 1 and m <= 4 else "bus2" if n == 2 and m <= 2 else "busn"
    if n == 3 and m == 1:
        op = "bus3"
    return op, tuple(dsts), tuple(srcs)


def decode(clock: object, bits: object) -> Instruction:
    """The instruction a raw ICW ``(clock, bit positions)`` encodes.

    Raises
    ------
    RegisterMisuseError
        If the clock is not 0-3, a bit is not in 0-79, or the word matches no modelled
        operation; the message names the word.
    """
    if isinstance(clock, bool) or not isinstance(clock, int) or clock not in CLOCKS.values():
        raise RegisterMisuseError(
            f"icw({clock!r}, ...): the clock must be 0 (analogue), 1 (digital), 2 (DNEWS) or "
            "3 (PROP); the AER, DOUT and FAST clocks are not modelled"
        )
    try:
        listed = list(bits)  # type: ignore[call-overload]
    except TypeError:
        listed = None
    if listed is None or any(
        isinstance(b, bool) or not isinstance(b, numbers.Integral) for b in listed
    ):  # 1.5 or "W1" is no bit position (int() would take 1.5 as bit 1)
        raise _bad(clock, [], f"bits={bits!r} must be bit positions (integers)")
    positions = {int(b) for b in listed}
    if any(not 0 <= b < 80 for b in positions):
        raise _bad(clock, positions, "bit positions run from 0 to 79")
    if clock == CLOCKS["prop"]:
        core = {S_IN, 43, 55, FBUS, RID, NB}
        if positions - {PUPD} != core:
            raise _bad(clock, positions, "the PROP clock's modelled words are PROP_0 and PROP_1")
        op, dsts, srcs = ("PROP1" if PUPD in positions else "PROP0"), (DIGITAL_PLANES[12],), ()
    elif clock == CLOCKS["analog"]:
        op, dsts, srcs = _decode_analog(clock, positions)
        if op == "PROP_R":
            srcs = (DIGITAL_PLANES[12],)
    else:
        op, dsts, srcs = _decode_digital(clock, positions)
    return make(
        op, dsts, srcs, origin=f"icw({clock}, {{{', '.join(map(str, sorted(positions)))}}})"
    )
