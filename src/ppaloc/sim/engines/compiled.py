"""The compiled engine: a kernel encoded once into a table, run by numba-compiled loops.

``compile`` turns every ICW into one row of integers (op code, destinations, sources, the
neighbour direction of each, the kernel-relative index of its first noise draw) and the
whole kernel then runs in one call of :func:`_run`, machine code compiled once per machine
(numba's ``cache=True`` keeps it in ``__pycache__``). Per ICW, each analogue transfer is
one pass over the plane in the common case (local sources, one destination): the sum, the
bus's negation or division, the transfer gain, the receiving cell's offset and temporal
noise, the saturation and the FLAG mask in the same loop, with no temporary plane. The
noise draws of the kernel are taken from the seeded bank up front
(:meth:`~ppaloc.sim.noise.NoiseModel.take`), in the order the other engines draw them, so
every engine leaves the same bytes. Digital planes stay one byte per element (packing
them into words would make every east/west move a bit shift, for planes that already fit
in cache).

An ICW this engine has no code for runs through the numpy engine's closure, between
compiled segments, so a new row of ``isa.OPS`` works at once.

numba is imported here only: ``ppaloc.sim`` imports without it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numba
import numpy as np

from ppaloc.sim.engines import in_order
from ppaloc.sim.isa import Instruction
from ppaloc.sim.registers import FLAG, NEWS, PIX, R0, R12

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = ["CompiledEngine"]

# op codes
_NOP, _RPIX, _BUS, _WHERE, _ALL, _SET, _CLR, _MOV, _NOT, _OR, _NOR = range(11)
_WHERED, _LATCH, _LATCHN, _UNLATCH, _DNEWS = range(11, 16)
_CODES = {
    "nop": _NOP,
    "rpix": _RPIX,
    "bus": _BUS,
    "bus2": _BUS,
    "bus3": _BUS,
    "where": _WHERE,
    "all": _ALL,
    "SET": _SET,
    "CLR": _CLR,
    "MOV": _MOV,
    "NOT": _NOT,
    "OR": _OR,
    "NOR": _NOR,
    "WHERE": _WHERED,
    "LATCH": _LATCH,
    "LATCHN": _LATCHN,
    "UNLATCH": _UNLATCH,
    "DNEWS0": _DNEWS,
    "DNEWS1": _DNEWS,
    "busn": _BUS,
    "sq": _BUS,
    "blurset": _NOP,
    "PROP_R": _LATCH,
}
_TRANSFERS = ("bus", "bus2", "bus3", "busn", "sq")
# row layout
_OP, _PARTS, _ND, _D0, _DD0, _NS, _S0, _SD0, _DRAW, _EDGE = 0, 1, 2, 3, 7, 11, 12, 16, 20, 21
_WIDTH = 22
# direction codes -> (d_row, d_col); 0 is a local register
_DR = np.array([0, -1, 0, 1, 0], dtype=np.int64)
_DC = np.array([0, 0, 1, 0, -1], dtype=np.int64)
_DIR_CODE = {(-1, 0): 1, (0, 1): 2, (1, 0): 3, (0, -1): 4}
# DNEWS selectors R1 south, R2 west, R3 north, R4 east, as direction codes
_SEL_DIR = np.array([0, 3, 4, 1, 2], dtype=np.int64)
_FLAG, _NEWS, _PIX, _R0, _R12 = FLAG.index, NEWS.index, PIX.index, R0.index, R12.index


def _dir(reg) -> int:
    return _DIR_CODE[reg.direction.offset] if reg.role == "neighbour" else 0


def _draws(ins: Instruction) -> int:
    """Noise draws of one ICW when noisy: one per analogue destination, one per where."""
    if ins.op in _TRANSFERS:
        return len(ins.dsts)
    return 1 if ins.op == "where" else 0


def encode(instructions: list[Instruction]) -> tuple[np.ndarray, int]:
    """(table of rows, noise draws of the whole segment when noisy)."""
    prog = np.zeros((len(instructions), _WIDTH), dtype=np.int64)
    draw = 0
    for n, ins in enumerate(instructions):
        row = prog[n]
        row[_OP] = _CODES[ins.op]
        row[_PARTS] = len(ins.dsts) if ins.op in ("bus2", "bus3", "busn") else 1
        row[_ND], row[_NS] = len(ins.dsts), len(ins.srcs)
        for k, r in enumerate(ins.dsts):
            row[_D0 + k], row[_DD0 + k] = r.index, _dir(r)
        for k, r in enumerate(ins.srcs):
            row[_S0 + k], row[_SD0 + k] = r.index, _dir(r)
        row[_DRAW] = draw
        row[_EDGE] = ins.op == "DNEWS1"
        draw += _draws(ins)
    for n in dead_writes(instructions):
        prog[n, _OP] = _NOP  # its noise draws stay counted: later draws keep their index
    return prog, draw


def dead_writes(instructions: list[Instruction]) -> list[int]:
    """Indices of one-destination transfers whose plane is overwritten before it is read.

    A later write to the same plane covers every element an earlier one wrote if FLAG
    has not shrunk in between (``where``/``WHERE`` may shrink it; ``all`` only grows it),
    and the earlier value is lost if no ICW between reads that plane (NEWS through any
    alias). Typical: a macro's NEWS scratch written again by the next macro. The kernel's
    end is a read of everything.
    """
    killed: set[int] = set()  # planes fully overwritten later, before any read
    dead = []
    for n in range(len(instructions) - 1, -1, -1):
        ins = instructions[n]
        if ins.op in ("where", "WHERE"):
            killed.clear()
        if ins.op in _TRANSFERS:
            planes = {d.index for d in ins.dsts}
            if len(ins.dsts) == 1 and planes <= killed:
                dead.append(n)
            killed |= planes
        if ins.spec.src_kind == "analog":
            killed -= {r.index for r in ins.srcs}
    return sorted(dead)


class CompiledEngine:
    """Runs a kernel as one call of numba-compiled code (``engine="compiled"``)."""

    name = "compiled"

    def __init__(self, sim: Scamp5) -> None:
        self.sim = sim
        shape = (sim.rows, sim.cols)
        self._t = np.zeros(shape, dtype=np.float32)
        self._t2 = np.zeros(shape, dtype=np.float32)
        self._tb = np.zeros(shape, dtype=np.bool_)
        self._none = np.zeros(0, dtype=np.float32)
        self._no_starts = np.zeros(0, dtype=np.int64)
        self._no_gains = np.zeros(0, dtype=np.float64)

    def supports(self, op: str) -> bool:
        """Whether ``op`` has compiled code (others run through the numpy engine)."""
        return op in _CODES

    @staticmethod
    def _encodable(ins: Instruction) -> bool:
        return ins.op in _CODES and len(ins.dsts) <= 4 and len(ins.srcs) <= 4

    def compile(self, instructions: tuple[Instruction, ...]) -> Callable[[], None]:
        """Compiled segments of the kernel, with numpy closures for any other op."""
        parts: list[Callable[[], None]] = []
        run_of: list[Instruction] = []
        for ins in (*instructions, None):
            if ins is not None and self._encodable(ins):
                run_of.append(ins)
                continue
            if run_of:
                parts.append(self._segment(run_of))
                run_of = []
            if ins is not None:
                parts.append(self.sim._compile(ins))
        return in_order(parts)

    def _segment(self, instructions: list[Instruction]) -> Callable[[], None]:
        sim = self.sim
        prog, m = encode(instructions)
        noise = sim.noise
        a, d, latch = sim._a, sim._d, sim._latch
        t, t2, tb = self._t, self._t2, self._tb
        if noise.ideal:
            bank = bank_div = self._none
        else:
            bank, bank_div = noise._bank, noise._bank_div
        offsets, pixel = noise.offsets, noise.pixel_offset
        none_s, none_g = self._no_starts, self._no_gains

        def run() -> None:
            if noise.ideal or m == 0:
                starts, gains = none_s, none_g
            else:
                starts, gains = noise.take(m)
            _run(prog, a, d, latch, t, t2, tb, offsets, pixel, bank, bank_div, starts, gains)
            sim._flag_masked = None  # the numpy engine's cached FLAG mask may be stale

        return run


_jit = numba.njit(cache=True, nogil=True, boundscheck=False)
# Every loop below keeps its branches outside the innermost loop (or as selects inside),
# so that LLVM vectorises it; values are float32 throughout, in the reference's order.


@_jit
def _clip(v):
    lo = np.float32(-128.0)
    hi = np.float32(127.0)
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v


@_jit
def _all_true(plane):
    acc = True
    for p in range(plane.size):  # no early exit: a reduction LLVM vectorises
        acc = acc & plane[p]
    return acc


@_jit
def _locals(row, nsrc):
    """Plane indices of the row's local sources, and how many."""
    locs = np.zeros(4, dtype=np.int64)
    nl = 0
    for k in range(nsrc):
        if row[_SD0 + k] == 0:
            locs[nl] = row[_S0 + k]
            nl += 1
    return locs, nl


@_jit
def _local_sum(out, af, locs, nl):
    """out := the local sources summed left to right (0 with none)."""
    n = out.size
    if nl == 0:
        for p in range(n):
            out[p] = np.float32(0.0)
    elif nl == 1:
        x0 = af[locs[0]]
        for p in range(n):
            out[p] = x0[p]
    elif nl == 2:
        x0, x1 = af[locs[0]], af[locs[1]]
        for p in range(n):
            out[p] = x0[p] + x1[p]
    elif nl == 3:
        x0, x1, x2 = af[locs[0]], af[locs[1]], af[locs[2]]
        for p in range(n):
            out[p] = (x0[p] + x1[p]) + x2[p]
    else:
        x0, x1, x2, x3 = af[locs[0]], af[locs[1]], af[locs[2]], af[locs[3]]
        for p in range(n):
            out[p] = ((x0[p] + x1[p]) + x2[p]) + x3[p]


@_jit
def _sum_value(out, af, locs, nl, parts, ideal, scale):
    """out := the bus's value of the local sources' sum (1 to 4 of them), in one pass."""
    n = out.size
    x0 = af[locs[0]]
    x1 = af[locs[1]] if nl > 1 else x0
    x2 = af[locs[2]] if nl > 2 else x0
    x3 = af[locs[3]] if nl > 3 else x0
    if nl == 1:
        for p in range(n):
            out[p] = _value(x0[p], parts, ideal, scale)
    elif nl == 2:
        for p in range(n):
            out[p] = _value(x0[p] + x1[p], parts, ideal, scale)
    elif nl == 3:
        for p in range(n):
            out[p] = _value((x0[p] + x1[p]) + x2[p], parts, ideal, scale)
    else:
        for p in range(n):
            out[p] = _value(((x0[p] + x1[p]) + x2[p]) + x3[p], parts, ideal, scale)


@_jit
def _add_neighbours(t, news, flag, row, nsrc, flag_all):
    """t += each neighbour source's NEWS (0 from an unflagged PE; beyond the edge no term)."""
    rows, cols = t.shape
    zero = np.float32(0.0)
    for k in range(nsrc):
        code = row[_SD0 + k]
        if code == 0:
            continue
        dr, dc = _DR[code], _DC[code]
        c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
        w = c_hi - c_lo
        for r in range(max(0, -dr), min(rows, rows - dr)):
            # slices, so that every index is a plain non-negative loop counter
            trow = t[r, c_lo:c_hi]
            nrow = news[r + dr, c_lo + dc : c_hi + dc]
            frow = flag[r + dr, c_lo + dc : c_hi + dc]
            if flag_all:
                for c in range(w):
                    trow[c] = trow[c] + nrow[c]
            else:
                for c in range(w):
                    v = nrow[c]  # loads outside the select, so that it vectorises
                    trow[c] = trow[c] + (v if frow[c] else zero)


@_jit
def _bus_value(tf, parts, ideal, scale):
    """tf := the bus's value: -(sum)/parts, saturated when ideal; times -(1 + g)/parts else."""
    n = tf.size
    if not ideal:
        for p in range(n):
            tf[p] = tf[p] * scale
    elif parts == 1:
        for p in range(n):
            tf[p] = _clip(-tf[p])
    elif parts == 2:
        m_half = np.float32(-0.5)
        for p in range(n):
            tf[p] = _clip(tf[p] * m_half)
    else:
        m_parts = np.float32(-parts)
        for p in range(n):
            tf[p] = _clip(tf[p] / m_parts)


@_jit
def _blend(dst, src, flag):
    """dst := src where flag, bit for bit (a branch-free blend of the float32 bits)."""
    du, su, f8 = dst.view(np.uint32), src.view(np.uint32), flag.view(np.uint8)
    for p in range(dst.size):
        m = np.uint32(0) - np.uint32(f8[p])
        du[p] = (su[p] & m) | (du[p] & ~m)


@_jit
def _write(dst, src, flag, flag_all, noisy, off, win, tmp):
    """dst := src (+ the cell's offset + temporal noise, saturated, when noisy), FLAG-masked.

    ``tmp`` is a scratch plane for the noisy masked case (it may be ``src`` itself).
    """
    n = dst.size
    if noisy:
        if flag_all:
            for p in range(n):
                dst[p] = _clip((src[p] + off[p]) + win[p])
        else:
            for p in range(n):
                tmp[p] = _clip((src[p] + off[p]) + win[p])
            _blend(dst, tmp, flag)
    elif flag_all:
        for p in range(n):
            dst[p] = src[p]
    else:
        _blend(dst, src, flag)


@_jit
def _fused_copy(dst, x0, x1, nl, flag, flag_all):
    """The commonest ICW in one pass: dst := clip(-(x0 [+ x1])), ideal, FLAG-masked."""
    n = dst.size
    if nl == 1:
        if flag_all:
            for p in range(n):
                dst[p] = _clip(-x0[p])
        else:
            for p in range(n):
                v = _clip(-x0[p])
                old = dst[p]
                dst[p] = v if flag[p] else old
    elif flag_all:
        for p in range(n):
            dst[p] = _clip(-(x0[p] + x1[p]))
    else:
        for p in range(n):
            v = _clip(-(x0[p] + x1[p]))
            old = dst[p]
            dst[p] = v if flag[p] else old


@_jit
def _fused_noisy(dst, x0, x1, nl, scale, off, win, flag, flag_all):
    """One noisy ICW in one pass: dst := clip((sum * scale + offset) + noise), FLAG-masked."""
    n = dst.size
    if nl == 1:
        for p in range(n):
            v = _clip((x0[p] * scale + off[p]) + win[p])
            old = dst[p]
            dst[p] = v if (flag_all or flag[p]) else old
    else:
        for p in range(n):
            v = _clip(((x0[p] + x1[p]) * scale + off[p]) + win[p])
            old = dst[p]
            dst[p] = v if (flag_all or flag[p]) else old


@_jit
def _push(t2, t, flag, code, flag_all):
    """t2[r] := t of the sender r - offset if flagged, else 0; 0 beyond the edge."""
    rows, cols = t.shape
    dr, dc = -_DR[code], -_DC[code]
    zero = np.float32(0.0)
    c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
    w = c_hi - c_lo
    for r in range(rows):
        out = t2[r]
        rr = r + dr
        if rr < 0 or rr >= rows:
            for c in range(cols):
                out[c] = zero
            continue
        for c in range(0, c_lo):
            out[c] = zero
        for c in range(c_hi, cols):
            out[c] = zero
        o = out[c_lo:c_hi]
        trow = t[rr, c_lo + dc : c_hi + dc]
        frow = flag[rr, c_lo + dc : c_hi + dc]
        if flag_all:
            for c in range(w):
                o[c] = trow[c]
        else:
            for c in range(w):
                v = trow[c]
                o[c] = v if frow[c] else zero


@_jit
def _value(v, parts, ideal, scale):
    """The bus's value of a sum: -(v)/parts saturated when ideal, v * scale when noisy."""
    if not ideal:
        return v * scale
    if parts == 1:
        return _clip(-v)
    if parts == 2:
        return _clip(v * np.float32(-0.5))
    return _clip(v / np.float32(-parts))


@_jit
def _write_bus(dst, tf, parts, ideal, scale, flag, flag_all, off, win):
    """dst := the bus's value of the sum in tf (+ offset and noise, saturated), FLAG-masked."""
    n = dst.size
    if ideal:
        if flag_all:
            for p in range(n):
                dst[p] = _value(tf[p], parts, True, scale)
        else:
            for p in range(n):
                v = _value(tf[p], parts, True, scale)
                old = dst[p]
                dst[p] = v if flag[p] else old
    else:
        for p in range(n):
            v = _clip((tf[p] * scale + off[p]) + win[p])
            old = dst[p]
            dst[p] = v if (flag_all or flag[p]) else old


@_jit
def _transfer(row, a, af, df, t, t2, offsets, bank, bank_div, starts, gains, flag_all):
    parts, nd, nsrc = row[_PARTS], row[_ND], row[_NS]
    ideal = bank.size == 0
    rows, cols = a.shape[1], a.shape[2]
    n = rows * cols
    flagf = df[_FLAG]
    flag2 = flagf.reshape(rows, cols)
    base = row[_DRAW]
    scale = np.float32(0.0)
    if not ideal:
        scale = np.float32(gains[base] / parts)
    locs, nl = _locals(row, nsrc)
    bank_w = bank if parts == 1 else bank_div
    if nd == 1 and row[_DD0] == 0 and nl == nsrc and 0 < nl <= 2:
        d0 = row[_D0]
        x0, x1 = af[locs[0]], af[locs[nl - 1]]
        if ideal and parts == 1:
            _fused_copy(af[d0], x0, x1, nl, flagf, flag_all)
            return
        if not ideal:
            win = bank_w[starts[base] : starts[base] + n]
            _fused_noisy(af[d0], x0, x1, nl, scale, offsets[d0].ravel(), win, flagf, flag_all)
            return
    tf = t.ravel()
    if nl == nsrc and nl > 0 and (nd > 1 or row[_DD0] != 0):  # sum and value in one pass
        _sum_value(tf, af, locs, nl, parts, ideal, scale)
    else:
        _local_sum(tf, af, locs, nl)
        if nl < nsrc:
            _add_neighbours(t, a[_NEWS], flag2, row, nsrc, flag_all)
        if nd == 1 and row[_DD0] == 0:  # value, noise, saturation and mask in one pass
            d0 = row[_D0]
            win = bank_w[starts[base] : starts[base] + n] if not ideal else bank
            _write_bus(af[d0], tf, parts, ideal, scale, flagf, flag_all, offsets[d0].ravel(), win)
            return
        _bus_value(tf, parts, ideal, scale)
    for k in range(nd):
        di, code = row[_D0 + k], row[_DD0 + k]
        win = bank_w[starts[base + k] : starts[base + k] + n] if not ideal else bank
        src = tf
        if code != 0 and ideal and flag_all:  # every element receives: push straight in
            _push(a[di], t, flag2, code, True)
            continue
        if code != 0:  # pushed: the receiver gets its sender's value
            _push(t2, t, flag2, code, flag_all)
            src = t2.ravel()
        _write(af[di], src, flagf, flag_all, not ideal, offsets[di].ravel(), win, t2.ravel())


@_jit
def _where(row, a, af, df, t, bank, starts):
    rows, cols = a.shape[1], a.shape[2]
    nsrc = row[_NS]
    tf = t.ravel()
    locs, nl = _locals(row, nsrc)
    _local_sum(tf, af, locs, nl)
    flagf = df[_FLAG]
    if nl < nsrc:
        _add_neighbours(t, a[_NEWS], flagf.reshape(rows, cols), row, nsrc, _all_true(flagf))
    zero = np.float32(0.0)
    if bank.size:
        s0 = starts[row[_DRAW]]
        for p in range(tf.size):
            flagf[p] = (tf[p] + bank[s0 + p]) > zero
    else:
        for p in range(tf.size):
            flagf[p] = tf[p] > zero


@_jit
def _store(df, di, val):
    """Digital dst := val (R12 only where R0 is 1)."""
    out = df[di]
    if di == _R12:
        r0 = df[_R0]
        for p in range(out.size):
            v, o = val[p], out[p]
            out[p] = v if r0[p] else o
    else:
        for p in range(out.size):
            out[p] = val[p]


@_jit
def _or(tb, df, row, invert):
    n = tb.size
    ns = row[_NS]
    x0 = df[row[_S0]]
    x1 = df[row[_S0 + 1]] if ns > 1 else x0
    x2 = df[row[_S0 + 2]] if ns > 2 else x0
    x3 = df[row[_S0 + 3]] if ns > 3 else x0
    if invert:
        for p in range(n):
            tb[p] = not (x0[p] | x1[p] | x2[p] | x3[p])
    else:
        for p in range(n):
            tb[p] = x0[p] | x1[p] | x2[p] | x3[p]


@_jit
def _dnews(row, d, df, tb2, edge):
    """tb2 := OR of the source of each neighbour the element's own selector names."""
    rows, cols = d.shape[1], d.shape[2]
    src = d[row[_S0]]
    for r in range(rows):
        for c in range(cols):
            tb2[r, c] = False
    for sel in range(1, 5):
        code = _SEL_DIR[sel]
        dr, dc = _DR[code], _DC[code]
        c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
        w = c_hi - c_lo
        for r in range(rows):
            out, srow = tb2[r], d[sel, r]
            rr = r + dr
            if rr < 0 or rr >= rows:
                for c in range(cols):
                    out[c] = out[c] | (srow[c] & edge)
                continue
            for c in range(0, c_lo):
                out[c] = out[c] | (srow[c] & edge)
            for c in range(c_hi, cols):
                out[c] = out[c] | (srow[c] & edge)
            o, sw = out[c_lo:c_hi], srow[c_lo:c_hi]
            x = src[rr, c_lo + dc : c_hi + dc]
            for c in range(w):
                o[c] = o[c] | (sw[c] & x[c])
    _store(df, row[_D0], tb2.ravel())


@_jit
def _run(prog, a, d, latch, t, t2, tb, offsets, pixel, bank, bank_div, starts, gains):
    rows, cols = a.shape[1], a.shape[2]
    n = rows * cols
    af = a.reshape(a.shape[0], n)
    df = d.reshape(d.shape[0], n)
    tbf = tb.ravel()
    latchf = latch.ravel()
    flag_all = _all_true(df[_FLAG])
    for i in range(prog.shape[0]):
        row = prog[i]
        op = row[_OP]
        if op == _BUS:
            _transfer(row, a, af, df, t, t2, offsets, bank, bank_div, starts, gains, flag_all)
        elif op == _WHERE:
            _where(row, a, af, df, t, bank, starts)
            flag_all = _all_true(df[_FLAG])
        elif op == _ALL:
            df[_FLAG][:] = True
            flag_all = True
        elif op == _NOP:
            pass
        elif op == _RPIX:
            af[_PIX][:] = pixel.ravel()
        elif op == _SET or op == _CLR:
            value = op == _SET
            nd = row[_ND]
            for k in range(nd):  # R12 first: its mask is R0 before this ICW
                if row[_D0 + k] == _R12:
                    tbf[:] = value
                    _store(df, _R12, tbf)
            for k in range(nd):
                if row[_D0 + k] != _R12:
                    df[row[_D0 + k]][:] = value
        elif op == _MOV:
            _store(df, row[_D0], df[row[_S0]])
        elif op == _NOT or op == _OR or op == _NOR:
            _or(tbf, df, row, op != _OR)
            _store(df, row[_D0], tbf)
        elif op == _WHERED:
            _or(tbf, df, row, False)
            df[_FLAG][:] = tbf
            flag_all = _all_true(df[_FLAG])
        elif op == _LATCH or op == _LATCHN:
            _or(latchf, df, row, op == _LATCHN)
        elif op == _UNLATCH:
            _store(df, row[_D0], latchf)
        elif op == _DNEWS:
            _dnews(row, d, df, tb, row[_EDGE] != 0)
