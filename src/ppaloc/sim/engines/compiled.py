"""The compiled engine: a kernel encoded once into a table, run by numba-compiled loops.

``compile`` turns every ICW into one row of integers (op code, destinations, sources, the
neighbour direction of each, the kernel-relative index of its first noise draw) and the
whole kernel then runs in one call of :func:`_run`, machine code compiled once per machine
(numba's ``cache=True`` keeps it in ``__pycache__``).

**Bands.** The kernel runs as a wavefront over bands of rows instead of ICW by ICW over
whole planes: at each step every ICW processes the next band of ``band_rows`` rows, ICW
``k`` lagging ``lag[k]`` rows behind the top. The lags come from the kernel's data
dependencies (:func:`schedule`): an ICW that reads a plane one row south of the element
must run at least one row behind the ICW that wrote it, an ICW that overwrites a plane must
not pass the rows a reader still needs, so every ICW sees exactly the values it would see
if the ICWs ran one after the other over whole planes. Planes then move through the cache
in bands a few rows deep, instead of every ICW streaming whole 256 KB planes; the
per-ICW temporaries are a band, so they stay in the first-level cache. An ICW that reads
a plane north of the element and writes that same plane cannot be banded (its own earlier
band overwrote what it needs): it runs alone over the whole plane, between banded parts.

Per band, each analogue transfer is one pass in the common case (local sources, one
destination): the sum, the bus's negation or division, the transfer gain, the receiving
cell's offset and temporal noise, the saturation and the FLAG mask in the same loop. The
noise draws of the kernel are taken from the seeded bank up front
(:meth:`~ppaloc.sim.noise.NoiseModel.take`), in the order the other engines draw them, so
every engine leaves the same bytes. Digital planes stay one byte per element and run as
bytes (``uint8`` views), which LLVM vectorises 64 PEs to an instruction.

An ICW this engine has no code for runs through the numpy engine's closure, between
compiled parts, so a new row of ``isa.OPS`` works at once.

numba is imported here only: ``ppaloc.sim`` imports without it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numba
import numpy as np

from ppaloc.sim.engines import in_order
from ppaloc.sim.isa import Instruction
from ppaloc.sim.registers import ANALOG_PLANES, FLAG, NEWS, PIX, R0, R1, R4, R12

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = ["CompiledEngine", "dead_writes", "schedule"]

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
# plane identities for the schedule: analogue i -> i, digital j -> _NA + j, the bus latch
_NA = len(ANALOG_PLANES)
_LATCH_PLANE = -1

#: Rows per band: 16 rows of a 256-column array are 16 KB of a float32 plane.
BAND_ROWS = 16


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


def accesses(row: np.ndarray) -> tuple[list[tuple[int, int]], list[int]]:
    """What one encoded ICW touches when it processes row ``r``.

    Returns (reads, writes): reads as (plane, row offset) pairs, the plane read at row
    ``r + offset``; writes as planes (always written at row ``r``). Planes are numbered
    analogue ``i`` -> ``i``, digital ``j`` -> ``_NA + j``, the bus latch -> ``-1``.
    """
    op = int(row[_OP])
    flag, news = _NA + _FLAG, _NEWS
    dst = [int(row[_D0 + k]) for k in range(int(row[_ND]))]
    src = [int(row[_S0 + k]) for k in range(int(row[_NS]))]
    sdir = [int(row[_SD0 + k]) for k in range(int(row[_NS]))]
    reads: list[tuple[int, int]] = []
    writes: list[int] = []

    def masked_store(d: int) -> None:  # a digital store: R12 keeps its value where R0 is 0
        writes.append(_NA + d)
        if d == _R12:
            reads.append((_NA + _R0, 0))

    if op in (_BUS, _WHERE):
        value: list[tuple[int, int]] = []  # what the bus's value at row x reads, at x + dr
        for s, code in zip(src, sdir, strict=True):
            if code == 0:
                value.append((s, 0))
            else:
                value += [(news, int(_DR[code])), (flag, int(_DR[code]))]
        if op == _WHERE:
            reads += value
            writes.append(flag)
        else:
            for k, d in enumerate(dst):
                code = int(row[_DD0 + k])
                reads += [(flag, 0), (d, 0)]  # the FLAG mask, and the kept old value
                if code == 0:
                    reads += value
                else:  # the receiver gets its sender's value, the sender at r - offset
                    sender = -int(_DR[code])
                    reads += [(p, o + sender) for p, o in value]
                    reads.append((flag, sender))
                writes.append(d)
    elif op == _ALL:
        writes.append(flag)
    elif op == _RPIX:
        writes.append(_PIX)
    elif op in (_SET, _CLR):
        for d in dst:
            masked_store(d)
    elif op in (_MOV, _NOT, _OR, _NOR):
        reads += [(_NA + s, 0) for s in src]
        masked_store(dst[0])
    elif op == _WHERED:
        reads += [(_NA + s, 0) for s in src]
        writes.append(flag)
    elif op in (_LATCH, _LATCHN):
        reads += [(_NA + s, 0) for s in src]
        writes.append(_LATCH_PLANE)
    elif op == _UNLATCH:
        reads.append((_LATCH_PLANE, 0))
        masked_store(dst[0])
    elif op == _DNEWS:
        reads += [(_NA + sel, 0) for sel in range(R1.index, R4.index + 1)]
        reads += [(_NA + src[0], int(_DR[_SEL_DIR[sel]])) for sel in range(1, 5)]
        masked_store(dst[0])
    return reads, writes


def bandable(row: np.ndarray) -> bool:
    """Whether an ICW can run band by band: it reads no plane it writes at a row north."""
    reads, writes = accesses(row)
    return not any(o < 0 and p in writes for p, o in reads)


def schedule(prog: np.ndarray) -> np.ndarray:
    """The smallest lag (rows behind the wavefront's top) of each ICW of a banded part.

    With ``lag[k]`` rows behind, ICW ``k`` at any moment has processed every row above
    ``top - lag[k]``. It reads plane ``P`` at row ``r + o`` when it processes row ``r``, so:

    - read after write: the last earlier writer of ``P`` must have written that row
      (``lag[k] >= lag[w] + o``);
    - write after read: an earlier reader of ``P`` must have read every row before
      ``k`` overwrites it (``lag[k] >= lag[j] - o``);
    - write after write: the last writer stays the last (``lag[k] >= lag[w]``).

    Every constraint ties an ICW to earlier ones, so one pass in program order gives the
    least lags; within a step the ICWs run in program order.
    """
    lags = np.zeros(len(prog), dtype=np.int64)
    last_write: dict[int, int] = {}  # plane -> lag of its last writer
    war: dict[int, int] = {}  # plane -> max over earlier readers of lag - offset
    for k, row in enumerate(prog):
        reads, writes = accesses(row)
        need = 0
        for p, o in reads:
            if p in last_write:
                need = max(need, last_write[p] + o)
        for p in writes:
            need = max(need, last_write.get(p, 0), war.get(p, 0))
        lags[k] = need
        for p, o in reads:
            war[p] = max(war.get(p, 0), need - o)
        for p in writes:
            last_write[p] = need
    return lags


class CompiledEngine:
    """Runs a kernel as one call of numba-compiled code (``engine="compiled"``)."""

    name = "compiled"

    def __init__(self, sim: Scamp5, band_rows: int = BAND_ROWS) -> None:
        self.sim = sim
        self.band_rows = band_rows
        shape = (sim.rows, sim.cols)
        self._t = np.zeros(shape, dtype=np.float32)
        self._t2 = np.zeros(shape, dtype=np.float32)
        self._tb = np.zeros(shape, dtype=np.bool_)
        self._flagrows = np.zeros(sim.rows, dtype=np.bool_)
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
        """One runner for a run of encodable ICWs: banded parts, unbandable ICWs alone."""
        sim = self.sim
        prog, m = encode(instructions)
        # (first row, end row, lags, band) of each part: a part is one _run call
        parts: list[tuple[int, int, np.ndarray, int]] = []
        start = 0
        for n in range(len(prog) + 1):
            if n < len(prog) and bandable(prog[n]):
                continue
            if n > start:
                parts.append((start, n, schedule(prog[start:n]), self.band_rows))
            if n < len(prog):
                parts.append((n, n + 1, np.zeros(1, dtype=np.int64), sim.rows))
            start = n + 1
        noise = sim.noise
        a, d, latch = sim._a, sim._d, sim._latch
        t, t2, tb, flagrows = self._t, self._t2, self._tb, self._flagrows
        if noise.ideal:
            bank = bank_div = self._none
        else:
            bank, bank_div = noise._bank, noise._bank_div
        offsets, pixel = noise.offsets, noise.pixel_offset
        none_s, none_g = self._no_starts, self._no_gains
        tables = [(prog[i:j], lags, band) for i, j, lags, band in parts]

        def run() -> None:
            if noise.ideal or m == 0:
                starts, gains = none_s, none_g
            else:
                starts, gains = noise.take(m)
            for part, lags, band in tables:
                _run(
                    part, lags, band, a, d, latch, t, t2, tb, flagrows,
                    offsets, pixel, bank, bank_div, starts, gains,
                )  # fmt: skip
            sim._flag_masked = None  # the numpy engine's cached FLAG mask may be stale

        return run


_jit = numba.njit(cache=True, nogil=True, boundscheck=False, _nrt=False)
# the per-band dispatch takes many arrays: inlined, so that no call passes them all
_inline = numba.njit(cache=True, nogil=True, boundscheck=False, _nrt=False, inline="always")
# Every loop below keeps its branches outside the innermost loop (or as selects inside),
# so that LLVM vectorises it; values are float32 throughout, in the reference's order.
# Every op works on the rows [r0, r1) of its planes (flat views [r0 * cols, r1 * cols)).


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


@_inline
def _rows_all(flagrows, r0, r1):
    """Whether FLAG is set everywhere on rows [r0 - 1, r1] (the band and its neighbours)."""
    acc = True
    for r in range(max(0, r0 - 1), min(flagrows.size, r1 + 1)):
        acc = acc & flagrows[r]
    return acc


@_jit
def _mark_rows(flagrows, flag2, r0, r1):
    """Record which of the rows [r0, r1) of FLAG are set everywhere."""
    for r in range(r0, r1):
        flagrows[r] = _all_true(flag2[r])


@_inline
def _locals(row, nsrc):
    """Plane indices of the row's local sources (four, unused ones 0), and how many."""
    f0 = f1 = f2 = f3 = 0
    nl = 0
    for k in range(nsrc):
        if row[_SD0 + k] == 0:
            s = row[_S0 + k]
            if nl == 0:
                f0 = s
            elif nl == 1:
                f1 = s
            elif nl == 2:
                f2 = s
            else:
                f3 = s
            nl += 1
    return (f0, f1, f2, f3), nl


@_jit
def _local_sum(out, af, locs, nl, lo, hi):
    """out[lo:hi] := the local sources summed left to right (0 with none)."""
    o = out[lo:hi]
    n = o.size
    if nl == 0:
        for p in range(n):
            o[p] = np.float32(0.0)
    elif nl == 1:
        x0 = af[locs[0]][lo:hi]
        for p in range(n):
            o[p] = x0[p]
    elif nl == 2:
        x0, x1 = af[locs[0]][lo:hi], af[locs[1]][lo:hi]
        for p in range(n):
            o[p] = x0[p] + x1[p]
    elif nl == 3:
        x0, x1, x2 = af[locs[0]][lo:hi], af[locs[1]][lo:hi], af[locs[2]][lo:hi]
        for p in range(n):
            o[p] = (x0[p] + x1[p]) + x2[p]
    else:
        x0, x1 = af[locs[0]][lo:hi], af[locs[1]][lo:hi]
        x2, x3 = af[locs[2]][lo:hi], af[locs[3]][lo:hi]
        for p in range(n):
            o[p] = ((x0[p] + x1[p]) + x2[p]) + x3[p]


@_jit
def _sum_value(out, af, locs, nl, parts, ideal, scale, lo, hi):
    """out[lo:hi] := the bus's value of the local sources' sum (1 to 4), in one pass."""
    o = out[lo:hi]
    n = o.size
    x0 = af[locs[0]][lo:hi]
    x1 = af[locs[1]][lo:hi] if nl > 1 else x0
    x2 = af[locs[2]][lo:hi] if nl > 2 else x0
    x3 = af[locs[3]][lo:hi] if nl > 3 else x0
    if nl == 1:
        for p in range(n):
            o[p] = _value(x0[p], parts, ideal, scale)
    elif nl == 2:
        for p in range(n):
            o[p] = _value(x0[p] + x1[p], parts, ideal, scale)
    elif nl == 3:
        for p in range(n):
            o[p] = _value((x0[p] + x1[p]) + x2[p], parts, ideal, scale)
    else:
        for p in range(n):
            o[p] = _value(((x0[p] + x1[p]) + x2[p]) + x3[p], parts, ideal, scale)


@_jit
def _add_neighbours(t, news, flag, row, nsrc, flag_all, r0, r1):
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
        for r in range(max(r0, -dr), min(r1, rows - dr)):
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
def _bus_value(tf, parts, ideal, scale, lo, hi):
    """tf := the bus's value: -(sum)/parts, saturated when ideal; times -(1 + g)/parts else."""
    o = tf[lo:hi]
    n = o.size
    if not ideal:
        for p in range(n):
            o[p] = o[p] * scale
    elif parts == 1:
        for p in range(n):
            o[p] = _clip(-o[p])
    elif parts == 2:
        m_half = np.float32(-0.5)
        for p in range(n):
            o[p] = _clip(o[p] * m_half)
    else:
        m_parts = np.float32(-parts)
        for p in range(n):
            o[p] = _clip(o[p] / m_parts)


@_jit
def _blend(du, su, f8):
    """du := su where f8, bit for bit (a branch-free blend of the float32 bits)."""
    for p in range(du.size):
        m = np.uint32(0) - np.uint32(f8[p])
        du[p] = (su[p] & m) | (du[p] & ~m)


@_jit
def _write(dst, src, flag, flag_all, noisy, off, win, tmp):
    """dst := src (+ the cell's offset + temporal noise, saturated, when noisy), FLAG-masked.

    All arguments are the band's flat views; ``tmp`` is a scratch band for the noisy
    masked case (it may be ``src`` itself).
    """
    n = dst.size
    if noisy:
        if flag_all:
            for p in range(n):
                dst[p] = _clip((src[p] + off[p]) + win[p])
        else:
            for p in range(n):
                tmp[p] = _clip((src[p] + off[p]) + win[p])
            _blend(dst.view(np.uint32), tmp.view(np.uint32), flag.view(np.uint8))
    elif flag_all:
        for p in range(n):
            dst[p] = src[p]
    else:
        _blend(dst.view(np.uint32), src.view(np.uint32), flag.view(np.uint8))


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
def _push(t2, t, flag, code, flag_all, r0, r1):
    """t2[r] := t of the sender r - offset if flagged, else 0; 0 beyond the edge."""
    rows, cols = t.shape
    dr, dc = -_DR[code], -_DC[code]
    zero = np.float32(0.0)
    c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
    w = c_hi - c_lo
    for r in range(r0, r1):
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
def _push_copy(dst, x, code, r0, r1):
    """dst[r] := clip(-x) of the sender r - offset, 0 beyond the edge (ideal, FLAG all set)."""
    rows, cols = x.shape
    dr, dc = -_DR[code], -_DC[code]
    zero = np.float32(0.0)
    c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
    w = c_hi - c_lo
    for r in range(r0, r1):
        out = dst[r]
        rr = r + dr
        if rr < 0 or rr >= rows:
            for c in range(cols):
                out[c] = zero
            continue
        for c in range(0, c_lo):
            out[c] = zero
        for c in range(c_hi, cols):
            out[c] = zero
        o, xr = out[c_lo:c_hi], x[rr, c_lo + dc : c_hi + dc]
        for c in range(w):
            o[c] = _clip(-xr[c])


@_jit
def _neighbour_copy(dst, news, code, r0, r1):
    """dst := clip(-(0 + the neighbour's NEWS)), no term beyond the edge (ideal, FLAG all set)."""
    rows, cols = news.shape
    dr, dc = _DR[code], _DC[code]
    zero = np.float32(0.0)
    edge = _clip(-zero)
    c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
    w = c_hi - c_lo
    for r in range(r0, r1):
        out = dst[r]
        rr = r + dr
        if rr < 0 or rr >= rows:
            for c in range(cols):
                out[c] = edge
            continue
        for c in range(0, c_lo):
            out[c] = edge
        for c in range(c_hi, cols):
            out[c] = edge
        o, nr = out[c_lo:c_hi], news[rr, c_lo + dc : c_hi + dc]
        for c in range(w):
            o[c] = _clip(-(zero + nr[c]))


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


@_inline
def _transfer(row, a, af, df, t, t2, offsets, bank, bank_div, starts, gains, flag_all, r0, r1):
    parts, nd, nsrc = row[_PARTS], row[_ND], row[_NS]
    ideal = bank.size == 0
    rows, cols = a.shape[1], a.shape[2]
    lo, hi = r0 * cols, r1 * cols
    flagf = df[_FLAG]
    flag2 = flagf.reshape(rows, cols)
    fb = flagf[lo:hi]
    base = row[_DRAW]
    scale = np.float32(0.0)
    if not ideal:
        scale = np.float32(gains[base] / parts)
    locs, nl = _locals(row, nsrc)
    bank_w = bank if parts == 1 else bank_div
    if nd == 1 and row[_DD0] == 0 and nl == nsrc and 0 < nl <= 2:
        d0 = row[_D0]
        x0, x1 = af[locs[0]][lo:hi], af[locs[nl - 1]][lo:hi]
        if ideal and parts == 1:
            _fused_copy(af[d0][lo:hi], x0, x1, nl, fb, flag_all)
            return
        if not ideal:
            win = bank_w[starts[base] + lo : starts[base] + hi]
            off = offsets[d0].reshape(-1)[lo:hi]
            _fused_noisy(af[d0][lo:hi], x0, x1, nl, scale, off, win, fb, flag_all)
            return
    if ideal and parts == 1 and nd == 1 and nsrc == 1 and flag_all:  # a neighbour move
        if row[_DD0] != 0 and nl == 1:
            _push_copy(a[row[_D0]], a[locs[0]], row[_DD0], r0, r1)
            return
        if row[_DD0] == 0 and nl == 0:
            _neighbour_copy(a[row[_D0]], a[_NEWS], row[_SD0], r0, r1)
            return
    pushed = False
    for k in range(nd):
        pushed = pushed or row[_DD0 + k] != 0
    # a pushed destination takes its sender's value: the sum one row beyond the band too
    e0, e1 = (max(0, r0 - 1), min(rows, r1 + 1)) if pushed else (r0, r1)
    elo, ehi = e0 * cols, e1 * cols
    tf = t.reshape(-1)
    if nl == nsrc and nl > 0 and (nd > 1 or row[_DD0] != 0):  # sum and value in one pass
        _sum_value(tf, af, locs, nl, parts, ideal, scale, elo, ehi)
    else:
        _local_sum(tf, af, locs, nl, elo, ehi)
        if nl < nsrc:
            _add_neighbours(t, a[_NEWS], flag2, row, nsrc, flag_all, e0, e1)
        if nd == 1 and row[_DD0] == 0:  # value, noise, saturation and mask in one pass
            d0 = row[_D0]
            win = bank_w[starts[base] + lo : starts[base] + hi] if not ideal else bank
            off = offsets[d0].reshape(-1)[lo:hi]
            _write_bus(af[d0][lo:hi], tf[lo:hi], parts, ideal, scale, fb, flag_all, off, win)
            return
        _bus_value(tf, parts, ideal, scale, elo, ehi)
    t2f = t2.reshape(-1)
    for k in range(nd):
        di, code = row[_D0 + k], row[_DD0 + k]
        win = bank_w[starts[base + k] + lo : starts[base + k] + hi] if not ideal else bank
        src = tf[lo:hi]
        if code != 0 and ideal and flag_all:  # every element receives: push straight in
            _push(a[di], t, flag2, code, True, r0, r1)
            continue
        if code != 0:  # pushed: the receiver gets its sender's value
            _push(t2, t, flag2, code, flag_all, r0, r1)
            src = t2f[lo:hi]
        off = offsets[di].reshape(-1)[lo:hi]
        _write(af[di][lo:hi], src, fb, flag_all, not ideal, off, win, t2f[lo:hi])


@_inline
def _where(row, a, af, df, t, bank, starts, flag_all, r0, r1):
    rows, cols = a.shape[1], a.shape[2]
    lo, hi = r0 * cols, r1 * cols
    nsrc = row[_NS]
    tf = t.reshape(-1)
    locs, nl = _locals(row, nsrc)
    _local_sum(tf, af, locs, nl, lo, hi)
    flagf = df[_FLAG]
    if nl < nsrc:
        _add_neighbours(t, a[_NEWS], flagf.reshape(rows, cols), row, nsrc, flag_all, r0, r1)
    zero = np.float32(0.0)
    fb, tb = flagf[lo:hi], tf[lo:hi]
    if bank.size:
        s0 = starts[row[_DRAW]] + lo
        w = bank[s0 : s0 + (hi - lo)]
        for p in range(tb.size):
            fb[p] = (tb[p] + w[p]) > zero
    else:
        for p in range(tb.size):
            fb[p] = tb[p] > zero


@_jit
def _store(du, di, val, lo, hi):
    """Digital dst[lo:hi] := val (R12 only where R0 is 1); ``du`` the uint8 view."""
    out = du[di][lo:hi]
    if di == _R12:
        r0 = du[_R0][lo:hi]
        for p in range(out.size):
            m = np.uint8(0) - r0[p]
            out[p] = (val[p] & m) | (out[p] & ~m)
    else:
        for p in range(out.size):
            out[p] = val[p]


@_jit
def _or(out, du, row, invert, lo, hi):
    """out := OR of the row's digital sources over [lo, hi) (NOR when ``invert``)."""
    n = out.size
    ns = row[_NS]
    x0 = du[row[_S0]][lo:hi]
    one = np.uint8(1)
    if ns == 1:
        if invert:
            for p in range(n):
                out[p] = x0[p] ^ one
        else:
            for p in range(n):
                out[p] = x0[p]
        return
    x1 = du[row[_S0 + 1]][lo:hi]
    x2 = du[row[_S0 + 2]][lo:hi] if ns > 2 else x1
    x3 = du[row[_S0 + 3]][lo:hi] if ns > 3 else x1
    flip = one if invert else np.uint8(0)
    for p in range(n):
        out[p] = (x0[p] | x1[p] | x2[p] | x3[p]) ^ flip


@_jit
def _dnews(row, du2, tb2, edge, r0, r1):
    """tb2 := OR of the source of each neighbour the element's own selector names."""
    rows, cols = du2.shape[1], du2.shape[2]
    src = du2[row[_S0]]
    e = np.uint8(1) if edge else np.uint8(0)
    for r in range(r0, r1):
        out = tb2[r]
        for c in range(cols):
            out[c] = np.uint8(0)
    for sel in range(1, 5):
        code = _SEL_DIR[sel]
        dr, dc = _DR[code], _DC[code]
        c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
        w = c_hi - c_lo
        for r in range(r0, r1):
            out, srow = tb2[r], du2[sel, r]
            rr = r + dr
            if rr < 0 or rr >= rows:
                for c in range(cols):
                    out[c] = out[c] | (srow[c] & e)
                continue
            for c in range(0, c_lo):
                out[c] = out[c] | (srow[c] & e)
            for c in range(c_hi, cols):
                out[c] = out[c] | (srow[c] & e)
            o, sw = out[c_lo:c_hi], srow[c_lo:c_hi]
            x = src[rr, c_lo + dc : c_hi + dc]
            for c in range(w):
                o[c] = o[c] | (sw[c] & x[c])


@_inline
def _op(row, r0, r1, a, af, df, du, du2, lu, tbu, tbu2, t, t2, flagrows, flag2,
        offsets, pixel, bank, bank_div, starts, gains):  # fmt: skip
    """One ICW over the rows [r0, r1)."""
    cols = a.shape[2]
    lo, hi = r0 * cols, r1 * cols
    op = row[_OP]
    if op == _BUS:
        flag_all = _rows_all(flagrows, r0, r1)
        _transfer(row, a, af, df, t, t2, offsets, bank, bank_div, starts, gains,
                  flag_all, r0, r1)  # fmt: skip
    elif op == _WHERE:
        flag_all = _rows_all(flagrows, r0, r1)
        _where(row, a, af, df, t, bank, starts, flag_all, r0, r1)
        _mark_rows(flagrows, flag2, r0, r1)
    elif op == _ALL:
        f = du[_FLAG][lo:hi]
        for p in range(f.size):
            f[p] = np.uint8(1)
        for r in range(r0, r1):
            flagrows[r] = True
    elif op == _NOP:
        pass
    elif op == _RPIX:
        out, x = af[_PIX][lo:hi], pixel.reshape(-1)[lo:hi]
        for p in range(out.size):
            out[p] = x[p]
    elif op == _SET or op == _CLR:
        value = np.uint8(1) if op == _SET else np.uint8(0)
        nd = row[_ND]
        tb = tbu[lo:hi]
        for k in range(nd):  # R12 first: its mask is R0 before this ICW
            if row[_D0 + k] == _R12:
                for p in range(tb.size):
                    tb[p] = value
                _store(du, _R12, tb, lo, hi)
        for k in range(nd):
            if row[_D0 + k] != _R12:
                out = du[row[_D0 + k]][lo:hi]
                for p in range(out.size):
                    out[p] = value
    elif op == _MOV:
        _store(du, row[_D0], du[row[_S0]][lo:hi], lo, hi)
    elif op == _NOT or op == _OR or op == _NOR:
        if row[_D0] == _R12:  # R12 keeps its value where R0 is 0
            tb = tbu[lo:hi]
            _or(tb, du, row, op != _OR, lo, hi)
            _store(du, _R12, tb, lo, hi)
        else:  # element by element, so the destination may be a source
            _or(du[row[_D0]][lo:hi], du, row, op != _OR, lo, hi)
    elif op == _WHERED:
        _or(du[_FLAG][lo:hi], du, row, False, lo, hi)
        _mark_rows(flagrows, flag2, r0, r1)
    elif op == _LATCH or op == _LATCHN:
        _or(lu[lo:hi], du, row, op == _LATCHN, lo, hi)
    elif op == _UNLATCH:
        tb, x = tbu[lo:hi], lu[lo:hi]
        for p in range(tb.size):
            tb[p] = x[p]
        _store(du, row[_D0], tb, lo, hi)
    elif op == _DNEWS:
        _dnews(row, du2, tbu2, row[_EDGE] != 0, r0, r1)
        _store(du, row[_D0], tbu[lo:hi], lo, hi)


@_jit
def _run(prog, lags, band, a, d, latch, t, t2, tb, flagrows, offsets, pixel, bank, bank_div,
         starts, gains):  # fmt: skip
    """Run the ICWs of ``prog`` as a wavefront of bands, ICW ``i`` ``lags[i]`` rows behind."""
    rows, cols = a.shape[1], a.shape[2]
    n = rows * cols
    af = a.reshape(a.shape[0], n)
    du2 = d.view(np.uint8)
    du = du2.reshape(d.shape[0], n)
    df = d.reshape(d.shape[0], n)
    lu = latch.view(np.uint8).reshape(-1)
    tbu2 = tb.view(np.uint8)
    tbu = tbu2.reshape(-1)
    flag2 = d[_FLAG]
    _mark_rows(flagrows, flag2, 0, rows)
    top_lag = 0
    for i in range(lags.size):
        top_lag = max(top_lag, lags[i])
    steps = (rows + top_lag + band - 1) // band
    for s in range(steps):
        for i in range(prog.shape[0]):
            r0 = s * band - lags[i]
            r1 = min(r0 + band, rows)
            r0 = max(r0, 0)
            if r0 < r1:
                _op(prog[i], r0, r1, a, af, df, du, du2, lu, tbu, tbu2, t, t2, flagrows, flag2,
                    offsets, pixel, bank, bank_div, starts, gains)  # fmt: skip
