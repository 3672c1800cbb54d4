"""The compiled engine: a kernel encoded once into a table, run by numba-compiled loops.

``compile`` turns every ICW into one row of integers (op code, destinations, sources, the
neighbour direction of each, the kernel-relative index of its first noise draw) and the
whole kernel then runs in one call of :func:`_run`, machine code compiled once per machine
(numba's ``cache=True`` keeps it in ``__pycache__``).

Per ICW, each analogue transfer is one pass over the plane in the common case (local
sources, one destination): the sum, the bus's negation or division, the transfer gain, the
receiving cell's offset and temporal noise, the saturation and the FLAG mask in the same
loop; a neighbour move (a push of one source, a read of one neighbour's NEWS, FLAG set
everywhere) is one pass too, and in ideal mode a chain of such moves (a shift by several
elements, :mod:`.chains`) is one pass in all; under noise a chain runs band by band, its
planes between the steps in buffers (:func:`_noisy_chain`). The noise draws of the
kernel are taken from the seeded bank up front
(:meth:`~ppaloc.sim.noise.NoiseModel.take`), in the order the other engines draw them, so
every engine leaves the same bytes; a kernel's call applies the droop pending on its
planes first (:meth:`CompiledEngine.compile`). Digital planes stay
one byte per element and run as bytes (``uint8`` views), which LLVM vectorises 64 PEs to
an instruction.

The dispatch of an ICW is inlined into the kernel's loop (``inline="always"``) and the
whole engine runs without numba's reference-counting runtime (``_nrt=False``; nothing in
it allocates): a call passing the simulator's planes as arguments cost about 250 ns, more
than many ICWs' work. Every op takes the rows ``[r0, r1)`` it works on; kernels run them
over the whole array (running a kernel as a wavefront of row bands, each ICW lagging as
far as its data dependencies need, was measured and gave no gain at 256 x 256: the planes
are served from the second-level and last-level caches either way).

Under noise the larger pieces (a chain's bands, a neighbour move's rows, a one-pass
transfer's elements) can be shared among threads (``$PPALOC_THREADS``, default 1;
:attr:`CompiledEngine.threads`), each element computed as on one thread.

An ICW this engine has no code for runs through the numpy engine's closure, between
compiled parts, so a new row of ``isa.OPS`` works at once.

numba is imported here only: ``ppaloc.sim`` imports without it.
"""

from __future__ import annotations

import logging
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numba
import numpy as np
from numba import types
from numba.core.cpu import CPUTargetOptions
from numba.extending import overload

from ppaloc.errors import SimulatorError
from ppaloc.sim.engines import chains, in_order
from ppaloc.sim.isa import Instruction
from ppaloc.sim.registers import FLAG, NEWS, PIX, R0, R12

if TYPE_CHECKING:
    from ppaloc.sim.engine import Scamp5

__all__ = [
    "FUSE_AFTER",
    "FUSE_ENV",
    "MAX_FUSE_AFTER",
    "MAX_THREADS",
    "CompiledEngine",
    "KernelDroop",
    "dead_last_destinations",
    "dead_writes",
    "fuse_after_from_env",
    "overwritten_unread",
]

log = logging.getLogger(__name__)

# op codes
_NOP, _RPIX, _BUS, _WHERE, _ALL, _SET, _CLR, _MOV, _NOT, _OR, _NOR = range(11)
_WHERED, _LATCH, _LATCHN, _UNLATCH, _DNEWS = range(11, 16)
_CHAIN = 16  # the head of a chain of neighbour moves (.chains): its index and length
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
#: The analogue planes that droop (A-F, NEWS: indices 0 .. _N_DECAY - 1).
_N_DECAY = NEWS.index + 1


def _dir(reg) -> int:
    return _DIR_CODE[reg.direction.offset] if reg.role == "neighbour" else 0


def _draws(ins: Instruction) -> int:
    """Noise draws of one ICW when noisy: one per analogue destination, one per where."""
    if ins.op in _TRANSFERS:
        return len(ins.dsts)
    return 1 if ins.op == "where" else 0


def encode(
    instructions: list[Instruction], ideal: bool = False, rows: int = 0, cols: int = 0
) -> tuple[np.ndarray, int, tuple[np.ndarray, ...]]:
    """(table of rows, noise draws of the whole segment when noisy, chain tables).

    Every chain of neighbour moves (:mod:`.chains`, on a ``rows`` x ``cols`` array;
    none without the array's shape) gets a head row before its ICWs: run composed when
    FLAG is set everywhere (ideal: :func:`_chain`; noisy: :func:`_noisy_chain`, each
    step's draws read from its own row), else its ICWs run one by one. Under noise a
    transfer's last destinations that are overwritten unread are not written
    (:func:`dead_last_destinations`; each costs its cell offsets and a noise window).
    """
    body = np.zeros((len(instructions), _WIDTH), dtype=np.int64)
    draw = 0
    for n, ins in enumerate(instructions):
        row = body[n]
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
    unread = overwritten_unread(instructions)
    dead = dead_writes(instructions, unread)
    for n in dead:
        body[n, _OP] = _NOP  # its noise draws stay counted: later draws keep their index
    if not ideal:
        for n, keep in dead_last_destinations(instructions, unread).items():
            body[n, _ND] = keep  # the kept ones keep their draws, the ICW its gain
    found = chains.compose(instructions, set(dead), unread, not ideal) if rows and cols else []
    heads = np.zeros((len(found), _WIDTH), dtype=np.int64)
    for c, ch in enumerate(found):
        heads[c, _OP], heads[c, _PARTS], heads[c, _ND] = _CHAIN, c, len(ch.steps)
    prog = np.insert(body, [ch.start for ch in found], heads, axis=0) if found else body
    return prog, draw, chains.tables(found, rows, cols, ideal)


def overwritten_unread(instructions: list[Instruction]) -> list[set[int]]:
    """Per ICW, the analogue planes whose value just after it no later ICW reads.

    A later transfer's write covers every element an earlier one wrote if FLAG has not
    shrunk in between (``where``/``WHERE`` may shrink it; ``all`` only grows it), and the
    earlier value is lost if no ICW between reads that plane (NEWS through any alias).
    The kernel's end is a read of everything.
    """
    after: list[set[int]] = [set()] * len(instructions)
    killed: set[int] = set()  # planes fully overwritten later, before any read
    for n in range(len(instructions) - 1, -1, -1):
        after[n] = set(killed)
        ins = instructions[n]
        if ins.op in ("where", "WHERE"):
            killed.clear()
        if ins.op in _TRANSFERS:
            killed |= {d.index for d in ins.dsts}
        if ins.spec.src_kind == "analog":
            killed -= {r.index for r in ins.srcs}
    return after


def dead_writes(instructions: list[Instruction], unread: list[set[int]] | None = None) -> list[int]:
    """Indices of one-destination transfers whose plane is overwritten before it is read
    (:func:`overwritten_unread`, or ``unread`` when given). Typical: a macro's NEWS
    scratch written again by the next macro."""
    if unread is None:
        unread = overwritten_unread(instructions)
    return [
        n
        for n, ins in enumerate(instructions)
        if ins.op in _TRANSFERS and len(ins.dsts) == 1 and ins.dsts[0].index in unread[n]
    ]


def dead_last_destinations(
    instructions: list[Instruction], unread: list[set[int]] | None = None
) -> dict[int, int]:
    """Per transfer of several destinations whose last ones (its own element's planes) are
    overwritten before they are read (:func:`overwritten_unread`): how many of its
    destinations to write, the first ones. Typical: the NEWS of a halving
    ``bus2(x, NEWS, y)`` that the next halving writes again. Only the last ones go, so
    that each kept destination keeps its noise draw (the ICW's first draw and gain, then
    one per destination, in order)."""
    if unread is None:
        unread = overwritten_unread(instructions)
    out: dict[int, int] = {}
    for n, ins in enumerate(instructions):
        if ins.op not in _TRANSFERS or len(ins.dsts) < 2:
            continue
        keep = len(ins.dsts)
        while keep > 1 and (
            ins.dsts[keep - 1].role != "neighbour" and ins.dsts[keep - 1].index in unread[n]
        ):
            keep -= 1
        if keep < len(ins.dsts):
            out[n] = keep
    return out


@dataclass(frozen=True)
class KernelDroop:
    """The droop pending before a kernel, as its first part applies it: ``codes`` per
    decaying plane (0 not named by the kernel, 1 named, 2 named and overwritten whole
    before it is read: dropped when FLAG is known to be set everywhere as the kernel
    starts, :func:`~ppaloc.sim.engine.overwritten_first`), the decay per ms, and
    ``before``, the simulator's call that applies it before a runner that cannot."""

    codes: np.ndarray
    decay: float
    before: Callable[[], None]


def _after(droop: KernelDroop | None, run: Callable[[], None]) -> Callable[[], None]:
    """``run``, after the simulator's call that applies ``droop`` (if any)."""
    if droop is None:
        return run
    before = droop.before

    def aged() -> None:
        before()
        run()

    return aged


class CompiledEngine:
    """Runs a kernel as one call of numba-compiled code (``engine="compiled"``)."""

    name = "compiled"
    #: Ideal transfers on deferred constant fills are folded by the simulator
    #: (:meth:`~ppaloc.sim.engine.Scamp5._with_folding`).
    folds = True

    def __init__(self, sim: Scamp5) -> None:
        self.sim = sim
        #: Runs of a fusable stretch on the first tier before its fused code is compiled
        #: (``$PPALOC_FUSE_AFTER``; None: never). Compiling costs about 0.1 s per ICW
        #: once per machine (numba's typing and lowering): it runs in a background
        #: process and the stretch moves to the fused code when that is done (at once
        #: when ``fuse_after`` is 1, in this process); one already in the cache folder is
        #: fused on its first run.
        self.fuse_after = fuse_after_from_env()
        shape = (sim.rows, sim.cols)
        self._t = np.zeros(shape, dtype=np.float32)
        self._t2 = np.zeros(shape, dtype=np.float32)
        self._tb = np.zeros(shape, dtype=np.bool_)
        self._runs = np.zeros(2 * sim.rows + 2, dtype=np.int64)  # rows of FLAG's 1s (_run)
        self._pre = np.zeros((0, *shape), dtype=np.float32)  # the fused tier's (_scratch)
        self._none = np.zeros(0, dtype=np.float32)
        self._no_starts = np.zeros(0, dtype=np.int64)
        self._no_gains = np.zeros(0, dtype=np.float64)
        self._no_codes = np.zeros(_N_DECAY, dtype=np.int64)  # a part with no droop to apply
        #: Threads that share the work of a kernel's larger pieces under noise (noisy
        #: chains, neighbour moves and one-pass transfers; :func:`threads_from_env`), on
        #: arrays of at least :data:`SPLIT_MIN` elements. Read when a kernel is compiled.
        asked = threads_from_env()  # a bad value is refused on any array, large or small
        self.threads = usable_threads(asked) if sim.rows * sim.cols >= SPLIT_MIN else 1

    def supports(self, op: str) -> bool:
        """Whether ``op`` has compiled code (others run through the numpy engine)."""
        return op in _CODES

    @staticmethod
    def _encodable(ins: Instruction) -> bool:
        return ins.op in _CODES and len(ins.dsts) <= 4 and len(ins.srcs) <= 4

    def compile(self, instructions: tuple[Instruction, ...]) -> Callable[[], None]:
        """Compiled segments of the kernel, with numpy closures for any other op.

        A run of at least two ICWs the second tier can fuse (:mod:`.fused`) starts on
        this tier and moves to generated, fused loops on its :attr:`fuse_after`-th run.

        When planes droop, the kernel's first part applies the droop pending on the planes
        the kernel names (the simulator's :meth:`~ppaloc.sim.engine.Scamp5._with_droop`
        does it in a call of its own before the kernel otherwise): a first-tier segment
        in its own call (:func:`_run`), the fused tier's code through the simulator's call
        before it. The runner is then marked ``applies_droop``; a kernel whose first ICW
        runs through the numpy engine is left to the simulator.
        """
        droop = self._kernel_droop(instructions)
        parts: list[Callable[[], None]] = []
        run_of: list[Instruction] = []
        for ins in (*instructions, None):
            if ins is not None and self._encodable(ins):
                run_of.append(ins)
                continue
            if run_of:
                parts.extend(self._tiered(run_of, droop if not parts else None))
                run_of = []
            if ins is not None:
                parts.append(self.sim._compile(ins))
        run = in_order(parts)  # a closure of this call's own (the first part applies droop)
        if droop is not None and self._encodable(instructions[0]):
            run.applies_droop = True  # type: ignore[attr-defined]
        return run

    def _kernel_droop(self, instructions: tuple[Instruction, ...]) -> KernelDroop | None:
        """The droop pending before the kernel, for its first part to apply (None when
        planes do not droop)."""
        sim = self.sim
        before = sim._droop_applier(instructions) if instructions else None
        if before is None:
            return None
        from ppaloc.sim.engine import droop_planes

        touched, fresh = droop_planes(instructions)
        codes = np.zeros(_N_DECAY, dtype=np.int64)
        for i in touched:
            codes[i] = 2 if i in fresh else 1
        return KernelDroop(codes, float(sim.noise.params.decay_per_ms), before)

    def _tiered(
        self, instructions: list[Instruction], droop: KernelDroop | None = None
    ) -> list[Callable[[], None]]:
        """Runners of an encodable run: its fusable stretches (two ICWs or more) tiered,
        the rest on this tier. ``droop``: the kernel's pending droop, for the first
        runner (:meth:`compile`)."""
        if self.fuse_after is None:  # never fused: the fused module is not even imported
            return [self._segment(instructions, droop)]
        from ppaloc.sim.engines import fused

        parts: list[Callable[[], None]] = []
        stretch: list[Instruction] = []
        other: list[Instruction] = []
        for ins in (*instructions, None):
            if ins is not None and fused.fusable(ins):
                if other:
                    parts.append(self._segment(other, None if parts else droop))
                    other = []
                stretch.append(ins)
                continue
            if len(stretch) >= 2 and self.fuse_after is not None:
                parts.append(self._tier_up(stretch, None if parts else droop))
            elif stretch:
                other.extend(stretch)
            stretch = []
            if ins is not None:
                other.append(ins)
        if other:
            parts.append(self._segment(other, None if parts else droop))
        return parts

    #: Runs of each tier, alternating, after which a stretch keeps the faster one.
    TRIAL_RUNS = 16

    def _tier_up(
        self, instructions: list[Instruction], droop: KernelDroop | None = None
    ) -> Callable[[], None]:
        """A runner of a fusable stretch: this tier until its fused code is there (from its
        ``fuse_after``-th run, compiled in the background; at once when ``fuse_after`` is
        1, in this process, or the code is in the cache folder), then both tiers in turn for
        :attr:`TRIAL_RUNS` runs each, then the faster. Both leave the same bytes; which is
        faster depends on the stretch and the machine (the fused code of a stretch of
        small passes under a partial FLAG can lose to this tier's one-pass loops). With
        ``droop`` (the kernel's first part) each tier applies the kernel's pending droop:
        this one in its call, the fused code through the simulator's call first. A
        stretch numba cannot compile (marked failed, by the background compile or by
        :func:`~ppaloc.sim.engines.fused.compile_here`) stays on this tier."""
        from ppaloc.sim.engines import fused

        sim = self.sim
        text = fused.source(instructions, sim.rows, sim.cols, not sim.noise.ideal)
        after = self.fuse_after
        first = self._segment(instructions, droop)
        state = "waiting"  # for the fused code; then "trial"; then "chosen"
        chosen, fast = first, first
        times: tuple[list[float], list[float]] = ([], [])  # (first tier, fused) per run
        runs = 0
        if fused.cached(text) or (
            after <= 1
            and not fused.failed(text)
            and fused.compile_here(text, self._shapes(instructions))
        ):
            state, fast = "trial", _after(droop, self._fused(instructions, text))
        elif after <= 1:  # numba could not compile it (now or before): this tier for good
            state = "chosen"
        done, failed = fused.marks(text)
        exists = os.path.exists

        def run() -> None:
            nonlocal state, chosen, fast, runs
            if state == "trial":  # both tiers in turn, each run timed
                k = len(times[0]) > len(times[1])
                t = time.perf_counter()
                (fast if k else first)()
                times[k].append(time.perf_counter() - t)
                if len(times[1]) == self.TRIAL_RUNS:
                    faster = statistics.median(times[1]) < statistics.median(times[0])
                    state, chosen = "chosen", fast if faster else first
                return
            if state == "waiting":
                runs += 1
                if runs == after:  # compiled in another process while this tier goes on
                    fused.background.request(text, self._shapes(instructions))
                elif runs > after and runs % 16 == 0:
                    fused.background.poll()
                    if exists(done):  # fused.cached(text)
                        state, fast = "trial", _after(droop, self._fused(instructions, text))
                    elif exists(failed):  # fused.failed(text)
                        state = "chosen"  # this tier for good
            chosen()

        return run

    def _scratch(self, k: int) -> np.ndarray:
        """``k`` scratch planes for neighbour terms, shared by every fused stretch (one block of
        memory stays in the caches, not one per stretch); grown when a stretch needs more."""
        k = max(k, 1)
        if self._pre.shape[0] < k:
            self._pre = np.zeros((k, self.sim.rows, self.sim.cols), dtype=np.float32)
        return self._pre[:k]

    def _shapes(self, instructions: list[Instruction]) -> dict[str, list[int]]:
        """The shapes of the fused code's array arguments (for the background compile)."""
        from ppaloc.sim.engines import fused

        sim, noise = self.sim, self.sim.noise
        k = fused.scratch_planes(instructions, sim.rows)
        m = sum(fused.draws(ins, not noise.ideal) for ins in instructions)
        size = sim.rows * sim.cols
        bank = [0] if noise.ideal else [size]
        return {
            "a": list(sim._analog_planes.shape), "d": list(sim._d.shape),
            "latch": list(sim._latch.shape),
            "scratch": [k, sim.rows, sim.cols], "offsets": list(noise.offsets.shape),
            "pixel": list(noise.pixel_offset.shape), "bank": bank, "bank_div": bank,
            "starts": [m], "gains": [m],
        }  # fmt: skip

    def _fused(self, instructions: list[Instruction], text: str) -> Callable[[], None]:
        """The stretch as generated, fused loops (``text``, compiled once per machine)."""
        from ppaloc.sim.engines import fused

        sim = self.sim
        noise = sim.noise
        noisy = not noise.ideal
        fn = fused.load(text)
        scratch = self._scratch(fused.scratch_planes(instructions, sim.rows))
        m = sum(fused.draws(ins, noisy) for ins in instructions)
        a, d, latch = sim._analog_planes, sim._d, sim._latch
        if noise.ideal:
            bank = bank_div = self._none
        else:
            bank, bank_div = noise._bank, noise._bank_div
        offsets, pixel = noise.offsets, noise.pixel_offset
        none_s, none_g = self._no_starts, self._no_gains
        marked = fused.cached(text)

        def run() -> None:
            nonlocal marked
            starts, gains = noise.take(m) if m else (none_s, none_g)
            all_set = fn(a, d, latch, scratch, offsets, pixel, bank, bank_div, starts, gains,
                         sim._flag_masked is False)  # fmt: skip
            sim._flag_masked = False if all_set else None
            sim._flag_partial = not all_set  # known: the host calls need not look
            if not marked:  # compiled and run once: later processes take it from the cache
                fused.mark_cached(text)
                marked = True

        return run

    def _segment(
        self, instructions: list[Instruction], droop: KernelDroop | None = None
    ) -> Callable[[], None]:
        """A first-tier runner of encodable ICWs: one call of :func:`_run`. With ``droop``
        (the kernel's first part) that call first applies the kernel's pending droop."""
        sim = self.sim
        noise = sim.noise
        prog, m, (heads, outs, edges) = encode(instructions, noise.ideal, sim.rows, sim.cols)
        codes, decay = (self._no_codes, 0.0) if droop is None else (droop.codes, droop.decay)
        pending = sim._droop_us
        a, d, latch = sim._analog_planes, sim._d, sim._latch
        t, t2, tb = self._t, self._t2, self._tb
        if noise.ideal:
            bank = bank_div = self._none
        else:
            bank, bank_div = noise._bank, noise._bank_div
        offsets, pixel = noise.offsets, noise.pixel_offset
        none_s, none_g = self._no_starts, self._no_gains
        runs = self._runs
        draws = not noise.ideal and m > 0
        take = noise.take
        threads = self.threads if self.threads > 1 else None  # None: no parallel code

        def run() -> None:
            if draws:
                starts, gains = take(m)
            else:
                starts, gains = none_s, none_g
            all_set = _run(
                prog, a, d, latch, t, t2, tb,
                offsets, pixel, bank, bank_div, starts, gains, sim._flag_masked is False,
                heads, outs, edges, runs, pending, decay, codes, threads,
            )  # fmt: skip
            # what the kernel knows of FLAG at its end: set everywhere (no mask), or partial
            # (the host calls need not look; the numpy engine's cached mask is rebuilt)
            sim._flag_masked = False if all_set else None
            sim._flag_partial = not all_set

        return run


#: The default of :attr:`CompiledEngine.fuse_after`.
FUSE_AFTER = 64
#: The environment variable that sets it: a number of runs, or "never".
FUSE_ENV = "PPALOC_FUSE_AFTER"
#: The most runs :data:`FUSE_ENV` may give (more is "never" in all but name).
MAX_FUSE_AFTER = 1_000_000_000


def fuse_after_from_env() -> int | None:
    """``$PPALOC_FUSE_AFTER`` as a number of runs (None for "never"), else the default."""
    value = os.environ.get(FUSE_ENV, "").strip().lower()
    if not value:
        return FUSE_AFTER
    if value == "never":
        return None
    runs = _count(value, MAX_FUSE_AFTER)
    if runs is not None:
        return runs
    raise SimulatorError(
        f"{FUSE_ENV}={_shown(value)} is invalid: use a number of runs from 1 to "
        f"{MAX_FUSE_AFTER:,}, or never"
    )


def _count(value: str, maximum: int) -> int | None:
    """``value`` as a whole number from 1 to ``maximum``, else None: ASCII digits only (not
    '²', which ``int`` refuses), and no more of them than ``maximum`` has (a 5,000-digit
    value met Python's limit on converting digits, and a 20-digit one no machine integer
    holds reached numba as an object and failed there)."""
    if not (value.isascii() and value.isdigit()) or len(value.lstrip("0")) > len(str(maximum)):
        return None
    n = int(value)
    return n if 1 <= n <= maximum else None


def _shown(value: str) -> str:
    """An environment value as a message shows it: its repr, cut to 40 characters."""
    text = repr(value)
    return text if len(text) <= 40 else text[:36] + "...'"


#: The environment variable that sets :attr:`CompiledEngine.threads`.
THREADS_ENV = "PPALOC_THREADS"
#: The most threads :data:`THREADS_ENV` may ask for: far more than the cores of any
#: machine the simulator runs on (each thread takes a share of a 256 x 256 array).
MAX_THREADS = 1024
#: Elements an array must have before a kernel's work is shared among threads (a
#: parallel region costs a few microseconds to start and join).
SPLIT_MIN = 16384


def threads_from_env() -> int:
    """``$PPALOC_THREADS`` as a number of threads (1 to :data:`MAX_THREADS`), else 1 (the
    measured default here)."""
    value = os.environ.get(THREADS_ENV, "").strip()
    if not value:
        return 1
    threads = _count(value, MAX_THREADS)
    if threads is not None:
        return threads
    raise SimulatorError(
        f"{THREADS_ENV}={_shown(value)} is invalid: use a number of threads from 1 to {MAX_THREADS}"
    )


def usable_threads(threads: int) -> int:
    """``threads``, or 1 unless numba's threading layer is ``omp`` or ``tbb``: its
    fallback, ``workqueue``, takes about 100 us to start a parallel region and must not
    be entered from two threads at once."""
    if threads <= 1:
        return 1
    try:
        from numba.np.ufunc import parallel

        parallel._launch_threads()
        layer = numba.threading_layer()
    except (ImportError, AttributeError, ValueError):
        return 1
    if layer in ("omp", "tbb"):
        return threads
    log.warning("%s=%d ignored: numba's threading layer is %s", THREADS_ENV, threads, layer)
    return 1


# numba's option to compile without its reference-counting runtime (``_nrt``, long
# present though underscored); a numba without it compiles the same code with the runtime
_NO_RUNTIME = {"_nrt": False} if hasattr(CPUTargetOptions, "_nrt") else {}
_jit = numba.njit(cache=True, nogil=True, boundscheck=False, **_NO_RUNTIME)
# the per-ICW dispatch takes many arrays: inlined, so that no call passes them all
_inline = numba.njit(cache=True, nogil=True, boundscheck=False, inline="always", **_NO_RUNTIME)
# work shared among threads (``numba.prange``), where it comes in pieces large enough
_par = numba.njit(cache=True, nogil=True, boundscheck=False, parallel=True, **_NO_RUNTIME)


def _many(threads):
    """Whether work is shared: ``threads`` above 1 (``None``, one thread, shares nothing)."""
    return threads is not None and threads > 1


@overload(_many, inline="always")
def _many_typed(threads):
    if isinstance(threads, (types.NoneType, types.Omitted)):
        return lambda threads: False
    return lambda threads: threads > 1


def _shared(parallel):
    """A call of the ``parallel`` (``prange``) function whose last argument is ``threads``,
    compiled into a kernel only when ``threads`` is a number: :func:`_run` with
    ``threads=None`` (one thread, the default) neither calls nor compiles it, so a fresh
    cache pays numba's parallel compilation only when threads are asked for."""

    def call(*args):
        return parallel(*args)

    @overload(call)
    def _typed(*args):
        if isinstance(args[-1], (types.NoneType, types.Omitted)):
            return lambda *args: None  # never reached: _many(None) is False
        return lambda *args: parallel(*args)

    call.__name__ = call.__qualname__ = parallel.__name__.removesuffix("_par")
    call.__doc__ = parallel.__doc__
    return call


# Every loop below keeps its branches outside the innermost loop (or as selects inside),
# so that LLVM vectorises it; values are float32 throughout, in the reference's order.
# Every op works on the rows [r0, r1) of its planes (flat views [r0 * cols, r1 * cols)).
# (A wavefront of row bands was tried and measured: no gain, so kernels run whole planes.)


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
def _all_set(flag):
    """Whether every byte of a digital plane's ``uint8`` view is 1, eight bytes a word."""
    n = flag.size
    whole = n - n % 8
    words = flag[:whole].view(np.uint64)
    ones = np.uint64(0x0101010101010101)
    acc = True
    for w in range(words.size):  # no early exit: a reduction LLVM vectorises
        acc = acc & (words[w] == ones)
    for p in range(whole, n):
        acc = acc & (flag[p] == 1)
    return acc


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


@_inline
def _sum_at(x0, x1, x2, x3, nl, p):
    """The local sources' sum at element ``p``, left to right (``nl`` of them, 1 to 4)."""
    v = x0[p]
    if nl > 1:
        v = v + x1[p]
    if nl > 2:
        v = v + x2[p]
    if nl > 3:
        v = v + x3[p]
    return v


@_jit
def _sum_value(out, af, locs, nl, parts, ideal, scale, lo, hi):
    """out[lo:hi] := the bus's value of the local sources' sum (1 to 4), in one pass."""
    o = out[lo:hi]
    n = o.size
    x0 = af[locs[0]][lo:hi]
    x1 = af[locs[1]][lo:hi] if nl > 1 else x0
    x2 = af[locs[2]][lo:hi] if nl > 2 else x0
    x3 = af[locs[3]][lo:hi] if nl > 3 else x0
    if not ideal:
        for p in range(n):
            o[p] = _sum_at(x0, x1, x2, x3, nl, p) * scale
    elif parts == 1:
        for p in range(n):
            o[p] = _clip(-_sum_at(x0, x1, x2, x3, nl, p))
    elif parts == 2:
        m_half = np.float32(-0.5)
        for p in range(n):
            o[p] = _clip(_sum_at(x0, x1, x2, x3, nl, p) * m_half)
    else:
        m_parts = np.float32(-parts)
        for p in range(n):
            o[p] = _clip(_sum_at(x0, x1, x2, x3, nl, p) / m_parts)


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

    All arguments are flat views of the rows worked on; ``tmp`` is scratch for the noisy
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
    if nl == 1 and flag_all:
        for p in range(n):
            dst[p] = _clip((x0[p] * scale + off[p]) + win[p])
    elif nl == 1:
        for p in range(n):
            v = _clip((x0[p] * scale + off[p]) + win[p])
            old = dst[p]
            dst[p] = v if flag[p] else old
    elif flag_all:
        for p in range(n):
            dst[p] = _clip(((x0[p] + x1[p]) * scale + off[p]) + win[p])
    else:
        for p in range(n):
            v = _clip(((x0[p] + x1[p]) * scale + off[p]) + win[p])
            old = dst[p]
            dst[p] = v if flag[p] else old


@_inline
def _blocks(n, j, threads):
    """The elements ``[p0, p1)`` thread ``j`` of ``threads`` takes of ``n``: a run of whole
    64-element blocks, the runs of all threads covering every element once."""
    blocks = (n + 63) // 64
    return min(n, (j * blocks // threads) * 64), min(n, ((j + 1) * blocks // threads) * 64)


@_par
def _fused_noisy_split_par(dst, x0, x1, nl, scale, off, win, flag, flag_all, threads):
    """:func:`_fused_noisy` with the elements shared among ``threads`` threads, each a
    run of whole 64-element blocks: every element gets the same operations."""
    n = dst.size
    for j in numba.prange(threads):
        p0, p1 = _blocks(n, j, threads)
        _fused_noisy(dst[p0:p1], x0[p0:p1], x1[p0:p1], nl, scale, off[p0:p1], win[p0:p1],
                     flag[p0:p1], flag_all)  # fmt: skip


_fused_noisy_split = _shared(_fused_noisy_split_par)


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
def _halve_into_two(d0, d1, x0, parts):
    """d0 := d1 := clip(x0 / -parts): a bus2/bus3 value into two planes in one pass.

    Ideal, FLAG set everywhere, one local source, two local destinations (the halving
    of ``divq`` and of the block means); a separate loop per ``parts``.
    """
    n = d0.size
    if parts == 2:
        m_half = np.float32(-0.5)
        for p in range(n):
            v = _clip(x0[p] * m_half)
            d0[p] = v
            d1[p] = v
    else:
        m_parts = np.float32(-parts)
        for p in range(n):
            v = _clip(x0[p] / m_parts)
            d0[p] = v
            d1[p] = v


@_jit
def _noisy_into_two(d0, d1, x0, scale, off0, win0, off1, win1):
    """A noisy bus of one local source into two local planes in one pass, FLAG all set.

    Each destination gets the value times the ICW's gain plus its own cell offset and
    noise draw: d_k := clip((x0 * scale + off_k) + win_k).
    """
    for p in range(d0.size):
        v = x0[p] * scale
        d0[p] = _clip((v + off0[p]) + win0[p])
        d1[p] = _clip((v + off1[p]) + win1[p])


@_par
def _noisy_into_two_split_par(d0, d1, x0, scale, off0, win0, off1, win1, threads):
    """:func:`_noisy_into_two` with the elements shared among ``threads`` threads, in
    whole 64-element blocks."""
    n = d0.size
    for j in numba.prange(threads):
        p0, p1 = _blocks(n, j, threads)
        _noisy_into_two(d0[p0:p1], d1[p0:p1], x0[p0:p1], scale, off0[p0:p1], win0[p0:p1],
                        off1[p0:p1], win1[p0:p1])  # fmt: skip


_noisy_into_two_split = _shared(_noisy_into_two_split_par)


@_inline
def _edge(out, c0, c1, value, noisy, orow, wrow):
    """out[c0:c1] := the value an element gets with no neighbour (+ offset and noise)."""
    for c in range(c0, c1):
        out[c] = _clip((value + orow[c]) + wrow[c]) if noisy else value


@_jit
def _neighbour_move(dst, src, code, read, ideal, scale, off, win, r0, r1):
    """A neighbour move in one pass, FLAG set everywhere: a push or a read of NEWS.

    ``read``: dst := the value of (0 + the neighbour's NEWS ``src``), no term beyond the
    edge; else a push: dst := the value of the sender's ``src``, 0 where no sender is. The
    value is clip(-sum) when ideal, else clip((sum * gain + offset) + noise) (``off`` and
    ``win``, (rows, cols) views of the receiver's offsets and its noise window).
    """
    rows, cols = src.shape
    sign = 1 if read else -1  # a read looks at the neighbour, a push comes from the sender
    dr, dc = sign * _DR[code], sign * _DC[code]
    zero = np.float32(0.0)
    edge = zero  # what a receiver with no sender gets
    if read:
        edge = _clip(-zero) if ideal else zero * scale
    c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
    w = c_hi - c_lo
    for r in range(r0, r1):
        out, orow, wrow = dst[r], off[r], win[r]
        rr = r + dr
        if rr < 0 or rr >= rows:
            _edge(out, 0, cols, edge, not ideal, orow, wrow)
            continue
        _edge(out, 0, c_lo, edge, not ideal, orow, wrow)
        _edge(out, c_hi, cols, edge, not ideal, orow, wrow)
        o, oo, ww = out[c_lo:c_hi], orow[c_lo:c_hi], wrow[c_lo:c_hi]
        x = src[rr, c_lo + dc : c_hi + dc]
        if ideal and read:
            for c in range(w):
                o[c] = _clip(-(zero + x[c]))
        elif ideal:
            for c in range(w):
                o[c] = _clip(-x[c])
        elif read:
            for c in range(w):
                o[c] = _clip(((zero + x[c]) * scale + oo[c]) + ww[c])
        else:
            for c in range(w):
                o[c] = _clip((x[c] * scale + oo[c]) + ww[c])


@_par
def _neighbour_move_split_par(dst, src, code, read, ideal, scale, off, win, threads):
    """:func:`_neighbour_move` over the whole array with its rows shared among
    ``threads`` threads (``dst`` is not ``src``, so no thread reads what another writes)."""
    rows = src.shape[0]
    for j in numba.prange(threads):
        _neighbour_move(dst, src, code, read, ideal, scale, off, win, j * rows // threads,
                        (j + 1) * rows // threads)  # fmt: skip


_neighbour_move_split = _shared(_neighbour_move_split_par)


@_jit
def _write_bus(dst, tf, parts, ideal, scale, flag, flag_all, off, win):
    """dst := the bus's value of the sum in tf (+ offset and noise, saturated), FLAG-masked."""
    n = dst.size
    if not ideal:
        for p in range(n):
            v = _clip((tf[p] * scale + off[p]) + win[p])
            old = dst[p]
            dst[p] = v if (flag_all or flag[p]) else old
        return
    if parts == 1:
        for p in range(n):
            v = _clip(-tf[p])
            old = dst[p]
            dst[p] = v if (flag_all or flag[p]) else old
    elif parts == 2:
        m_half = np.float32(-0.5)
        for p in range(n):
            v = _clip(tf[p] * m_half)
            old = dst[p]
            dst[p] = v if (flag_all or flag[p]) else old
    else:
        m_parts = np.float32(-parts)
        for p in range(n):
            v = _clip(tf[p] / m_parts)
            old = dst[p]
            dst[p] = v if (flag_all or flag[p]) else old


@_par
def _write_bus_split_par(dst, tf, parts, scale, flag, flag_all, off, win, threads):
    """:func:`_write_bus` under noise with the elements shared among ``threads`` threads,
    in whole 64-element blocks."""
    n = dst.size
    for j in numba.prange(threads):
        p0, p1 = _blocks(n, j, threads)
        _write_bus(dst[p0:p1], tf[p0:p1], parts, False, scale, flag[p0:p1], flag_all,
                   off[p0:p1], win[p0:p1])  # fmt: skip


_write_bus_split = _shared(_write_bus_split_par)


@_inline
def _transfer(row, a, af, df, t, t2, offsets, bank, bank_div, starts, gains, flag_all, r0, r1,
              threads):  # fmt: skip
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
            if _many(threads):
                _fused_noisy_split(af[d0][lo:hi], x0, x1, nl, scale, off, win, fb, flag_all,
                                   threads)  # fmt: skip
            else:
                _fused_noisy(af[d0][lo:hi], x0, x1, nl, scale, off, win, fb, flag_all)
            return
    if flag_all and nd == 2 and nsrc == 1 and nl == 1 and parts > 1:
        if row[_DD0] == 0 and row[_DD0 + 1] == 0 and row[_D0] != row[_D0 + 1]:
            x0, e0, e1 = af[locs[0]][lo:hi], row[_D0], row[_D0 + 1]
            if ideal:
                _halve_into_two(af[e0][lo:hi], af[e1][lo:hi], x0, parts)
            else:
                w0 = bank_w[starts[base] + lo : starts[base] + hi]
                w1 = bank_w[starts[base + 1] + lo : starts[base + 1] + hi]
                o0, o1 = offsets[e0].reshape(-1)[lo:hi], offsets[e1].reshape(-1)[lo:hi]
                if _many(threads):
                    _noisy_into_two_split(af[e0][lo:hi], af[e1][lo:hi], x0, scale, o0, w0,
                                          o1, w1, threads)  # fmt: skip
                else:
                    _noisy_into_two(af[e0][lo:hi], af[e1][lo:hi], x0, scale, o0, w0, o1, w1)
            return
    if parts == 1 and nd == 1 and nsrc == 1 and flag_all and r0 == 0 and r1 == rows:
        d0, code = row[_D0], row[_DD0]  # a neighbour move: a push of one source, or a read
        if (code != 0 and nl == 1) or (code == 0 and nl == 0):
            read = code == 0
            src = a[_NEWS] if read else a[locs[0]]
            off, win = a[d0], a[d0]  # unused when ideal
            if not ideal:
                off = offsets[d0]
                win = bank_w[starts[base] : starts[base] + rows * cols].reshape(rows, cols)
            code = row[_SD0] if read else code
            if _many(threads) and not ideal and d0 != (_NEWS if read else locs[0]):
                _neighbour_move_split(a[d0], src, code, read, ideal, scale, off, win, threads)
            else:
                _neighbour_move(a[d0], src, code, read, ideal, scale, off, win, r0, r1)
            return
    pushed = False
    for k in range(nd):
        pushed = pushed or row[_DD0 + k] != 0
    # a pushed destination takes its sender's value: the sum one row beyond the rows too
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
            if _many(threads) and not ideal:
                _write_bus_split(af[d0][lo:hi], tf[lo:hi], parts, scale, fb, flag_all, off,
                                 win, threads)  # fmt: skip
            else:
                _write_bus(af[d0][lo:hi], tf[lo:hi], parts, ideal, scale, fb, flag_all, off,
                           win)  # fmt: skip
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
    flagf = df[_FLAG]
    zero = np.float32(0.0)
    fb = flagf[lo:hi]
    if nsrc == 2 and nl == 2:  # FLAG from the sum of two registers, in one pass
        x0, x1 = af[locs[0]][lo:hi], af[locs[1]][lo:hi]
        if bank.size:
            s0 = starts[row[_DRAW]] + lo
            w = bank[s0 : s0 + (hi - lo)]
            for p in range(fb.size):
                fb[p] = ((x0[p] + x1[p]) + w[p]) > zero
        else:
            for p in range(fb.size):
                fb[p] = (x0[p] + x1[p]) > zero
        return
    if nsrc == 3 and nl == 3:  # the same from three (a threshold test's IN, a bound, W)
        x0, x1, x2 = af[locs[0]][lo:hi], af[locs[1]][lo:hi], af[locs[2]][lo:hi]
        if bank.size:
            s0 = starts[row[_DRAW]] + lo
            w = bank[s0 : s0 + (hi - lo)]
            for p in range(fb.size):
                fb[p] = (((x0[p] + x1[p]) + x2[p]) + w[p]) > zero
        else:
            for p in range(fb.size):
                fb[p] = ((x0[p] + x1[p]) + x2[p]) > zero
        return
    if nsrc == 1 and nl == 1:  # FLAG straight from one register, in one pass
        x = af[locs[0]][lo:hi]
    else:
        _local_sum(tf, af, locs, nl, lo, hi)
        if nl < nsrc:
            _add_neighbours(t, a[_NEWS], flagf.reshape(rows, cols), row, nsrc, flag_all, r0, r1)
        x = tf[lo:hi]
    if bank.size:
        s0 = starts[row[_DRAW]] + lo
        w = bank[s0 : s0 + (hi - lo)]
        for p in range(fb.size):
            fb[p] = (x[p] + w[p]) > zero
    else:
        for p in range(fb.size):
            fb[p] = x[p] > zero


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
def _op(row, r0, r1, a, af, df, du, du2, lu, tbu, tbu2, t, t2, flag_all,
        offsets, pixel, bank, bank_div, starts, gains, threads):  # fmt: skip
    """One ICW over the rows [r0, r1); returns whether FLAG is now set everywhere."""
    cols = a.shape[2]
    lo, hi = r0 * cols, r1 * cols
    op = row[_OP]
    if op == _BUS:
        _transfer(row, a, af, df, t, t2, offsets, bank, bank_div, starts, gains,
                  flag_all, r0, r1, threads)  # fmt: skip
    elif op == _WHERE:
        _where(row, a, af, df, t, bank, starts, flag_all, r0, r1)
        flag_all = _all_set(du[_FLAG])
    elif op == _ALL:
        f = du[_FLAG][lo:hi]
        for p in range(f.size):
            f[p] = np.uint8(1)
        flag_all = True
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
        flag_all = _all_set(du[_FLAG])
    elif op == _LATCH or op == _LATCHN:
        _or(lu[lo:hi], du, row, op == _LATCHN, lo, hi)
    elif op == _UNLATCH:
        _store(du, row[_D0], lu[lo:hi], lo, hi)
    elif op == _DNEWS:
        _dnews(row, du2, tbu2, row[_EDGE] != 0, r0, r1)
        _store(du, row[_D0], tbu[lo:hi], lo, hi)
    return flag_all


@_inline
def _chain_row(b, x, w, read1, read2, n, flip):
    """b[:w] := the first ``n`` steps of a chain applied to x[:w] (.chains._form): each
    step a read's clip(-(0 + v)) or a push's clip(-v), steps 3..n one negation or none.
    Selects, not branches, so that it vectorises."""
    z = np.float32(0.0)
    two, neg = n > 1, flip != 0
    for p in range(w):
        v = x[p]
        v1 = _clip(-((z + v) if read1 else v))
        v2 = _clip(-((z + v1) if read2 else v1))
        v = v2 if two else v1
        b[p] = -v if neg else v


@_inline
def _chain_edges(out, e, lo, hi, cols):
    """A row chain's elements outside its interior [lo, hi) get their fixed values."""
    for p in range(lo):
        out[p] = e[p]
    for p in range(hi, cols):
        out[p] = e[p]


@_jit
def _chain(a, c, heads, outs, edges, t, t2):
    """Chain ``c`` of neighbour moves composed (.chains), ideal, FLAG set everywhere: each
    plane it leaves written, in one pass. An output that is the chain's source goes
    through a row buffer (``t[0]``), written once the row is read; ``t2`` holds a copy of
    the source when a column chain's rows cannot be ordered to read first."""
    rows, cols = a.shape[1], a.shape[2]
    src, axis, o0, no, order = heads[c, 0], heads[c, 1], heads[c, 2], heads[c, 3], heads[c, 4]
    x0 = a[src]
    if order == 0:
        for r in range(rows):
            copy, orig = t2[r], x0[r]
            for p in range(cols):
                copy[p] = orig[p]
        x0 = t2
    buf = t[0]
    for i in range(rows):
        r = i if order >= 0 else rows - 1 - i
        own = -1  # the output that is the source, if any: written last
        for k in range(no):
            o = outs[o0 + k]
            plane, n, off, lo, hi = o[0], o[1], o[2], o[3], o[4]
            out = a[plane, r]
            if plane == src and order != 0:
                own, out = k, buf
            if axis == 1:
                target = out[: hi - lo] if own == k else out[lo:hi]
                _chain_row(target, x0[r, lo + off : hi + off], hi - lo, o[5], o[6], n, o[7])
                if own != k:
                    _chain_edges(out, edges[o0 + k], lo, hi, cols)
            elif lo <= r < hi:
                _chain_row(out, x0[r + off], cols, o[5], o[6], n, o[7])
            elif own != k:
                v = edges[o0 + k, r]
                for p in range(cols):
                    out[p] = v
        if own >= 0:
            lo, hi = outs[o0 + own, 3], outs[o0 + own, 4]
            out = a[src, r]
            if axis == 1:
                inner, b = out[lo:hi], buf[: hi - lo]  # plain indices, so that it vectorises
                for p in range(hi - lo):
                    inner[p] = b[p]
                _chain_edges(out, edges[o0 + own], lo, hi, cols)
            elif lo <= r < hi:
                for p in range(cols):
                    out[p] = buf[p]
            else:
                v = edges[o0 + own, r]
                for p in range(cols):
                    out[p] = v


@_inline
def _chain_step(o, x, dc, read, scale, orow, wrow):
    """One noisy move of a chain on a row, FLAG set everywhere: o := the move of row x,
    each element reading the one ``dc`` columns away (0 in a column chain, whose rows
    are picked by the caller). The operations of :func:`_neighbour_move` on one row:
    clip(((0 + x) * gain + offset) + noise) for a read, clip((x * gain + offset) +
    noise) for a push; with no neighbour, the value of a missing term (a read's 0 *
    gain, a push's 0) plus the offset and noise."""
    cols = o.size
    zero = np.float32(0.0)
    edge = zero * scale if read else zero
    c_lo, c_hi = max(0, -dc), min(cols, cols - dc)
    _edge(o, 0, c_lo, edge, True, orow, wrow)
    _edge(o, c_hi, cols, edge, True, orow, wrow)
    w = c_hi - c_lo
    oo, ow, ww = o[c_lo:c_hi], orow[c_lo:c_hi], wrow[c_lo:c_hi]
    xx = x[c_lo + dc : c_hi + dc]
    if read:
        for c in range(w):
            oo[c] = _clip(((zero + xx[c]) * scale + ow[c]) + ww[c])
    else:
        for c in range(w):
            oo[c] = _clip((xx[c] * scale + ow[c]) + ww[c])


@_inline
def _chain_move(row):
    """(read?, row offset, column offset of the element a chain step reads, its
    destination plane) from the step's ICW row: a read looks at the neighbour its
    source names, a push comes from the sender opposite its destination."""
    read = row[_DD0] == 0
    if read:
        code = row[_SD0]
        return read, _DR[code], _DC[code], row[_D0]
    code = row[_DD0]
    return read, -_DR[code], -_DC[code], row[_D0]


#: Elements of a band of rows that a noisy chain takes through all its steps at once:
#: the band's two buffers stay in the first- or second-level cache, and each step reads
#: its offsets and noise window as runs long enough for the prefetcher.
CHAIN_BAND = 4096


@_inline
def _noisy_row_bands(a, prog, first, c, heads, outs, offsets, bank, starts, gains, t, t2,
                     k0, k1, own):  # fmt: skip
    """Bands ``[k0, k1)`` of a row chain through its steps (:func:`_noisy_chain`); with
    ``own`` each band keeps its buffers in its own rows of ``t`` and ``t2``, so that
    bands may run at once, else in their first rows."""
    rows, cols = a.shape[1], a.shape[2]
    src, o0, no = heads[c, 0], heads[c, 2], heads[c, 3]
    band = max(1, CHAIN_BAND // cols)
    last = 0
    for j in range(no):
        last = max(last, outs[o0 + j, 1])
    for bb in range(k0, k1):
        b0 = bb * band
        nb = min(band, rows - b0)
        tb0 = b0 if own else 0
        ip, ib = a[src], b0  # what the step reads: a plane and its first row
        for k in range(last):
            row = prog[first + k]
            read, _, dc, dst = _chain_move(row)
            base = row[_DRAW]
            scale = np.float32(gains[base] / row[_PARTS])
            op, ob = (t, tb0) if k % 2 == 0 else (t2, tb0)
            plane = -1  # (chosen first: an array picked inside the loop ran 6x slower)
            for j in range(no):
                if outs[o0 + j, 1] == k + 1:
                    plane = outs[o0 + j, 0]
            if plane >= 0:
                op, ob = a[plane], b0
            off = offsets[dst]
            for i in range(nb):
                r = b0 + i
                s0 = starts[base] + r * cols
                _chain_step(op[ob + i], ip[ib + i], dc, read, scale, off[r],
                            bank[s0 : s0 + cols])  # fmt: skip
            ip, ib = op, ob


@_inline
def _noisy_column_bands(a, prog, first, c, heads, outs, offsets, bank, starts, gains, t, t2,
                        k0, k1, own):  # fmt: skip
    """Bands ``[k0, k1)`` of a column chain (:func:`_noisy_chain`; ``own``: as in
    :func:`_noisy_row_bands`)."""
    rows, cols = a.shape[1], a.shape[2]
    src, o0 = heads[c, 0], heads[c, 2]
    band = max(1, CHAIN_BAND // cols)
    zero = np.float32(0.0)
    plane, n, total = outs[o0, 0], outs[o0, 1], outs[o0, 2]
    down = plane == src and total < 0  # the source read above: bands from the bottom
    nbands = (rows + band - 1) // band
    for bb in range(k0, k1):
        b0 = (nbands - 1 - bb) * band if down else bb * band
        nb = min(band, rows - b0)
        tb0 = b0 if own else 0
        ip, ib = a[src], b0 + total  # step 1 reads the source at r + total
        shift = total  # step k writes the rows r + shift
        for k in range(n):
            row = prog[first + k]
            read, dr, _, dst = _chain_move(row)
            base = row[_DRAW]
            scale = np.float32(gains[base] / row[_PARTS])
            before = shift  # the rows it reads
            shift -= dr
            op, ob = (t, tb0) if k % 2 == 0 else (t2, tb0)
            if k == n - 1:
                op, ob = a[plane], b0
            off = offsets[dst]
            edge = zero * scale if read else zero
            for i in range(nb):
                q = b0 + i + shift
                if q < 0 or q >= rows:  # off the array: the next step reads no term
                    continue
                s0 = starts[base] + q * cols
                out, orow, wrow = op[ob + i], off[q], bank[s0 : s0 + cols]
                if 0 <= b0 + i + before < rows:
                    _chain_step(out, ip[ib + i], 0, read, scale, orow, wrow)
                else:
                    _edge(out, 0, cols, edge, True, orow, wrow)
            ip, ib = op, ob


@_jit
def _noisy_chain(a, prog, first, c, heads, outs, offsets, bank, starts, gains, t, t2):
    """Chain ``c`` of noisy neighbour moves (.chains; its steps are ``prog[first:]``),
    FLAG set everywhere: each plane it leaves written, without the passes between.

    Every step takes its own draws (its row's first draw: the window start and the
    gain) and its destination's cell offsets at the position the step writes, so each
    element goes through the same float32 operations, in the same order, as the ICWs
    one by one. The chain runs band by band (:data:`CHAIN_BAND` elements of whole
    rows), each band through every step, the planes between the steps in band buffers
    (``t``, ``t2``); only the chain's outputs are stored. A row chain takes each band
    of rows through the steps once and stores every output there (up to its last
    output's step). A column chain has one output (:func:`.chains.compose`): the band
    of its rows r goes through the steps, step k at the rows r + (the offsets of the
    steps after it), every element of a row whose step reads a row beyond the edge
    getting a missing term's value; when the output is the source its bands run in the
    order that reads each source row before it is written."""
    rows, cols = a.shape[1], a.shape[2]
    nbands = (rows + max(1, CHAIN_BAND // cols) - 1) // max(1, CHAIN_BAND // cols)
    if heads[c, 1] == 1:
        _noisy_row_bands(a, prog, first, c, heads, outs, offsets, bank, starts, gains, t, t2,
                         0, nbands, False)  # fmt: skip
    elif heads[c, 3] > 0:
        _noisy_column_bands(a, prog, first, c, heads, outs, offsets, bank, starts, gains,
                            t, t2, 0, nbands, False)  # fmt: skip


@_inline
def _bands_apart(c, heads, outs):
    """Whether the bands of a noisy chain may run at once: each reads only planes no
    other band writes (a row chain; a column chain whose output is not its source)."""
    return heads[c, 1] == 1 or (heads[c, 3] > 0 and outs[heads[c, 2], 0] != heads[c, 0])


@_par
def _noisy_chain_split_par(a, prog, first, c, heads, outs, offsets, bank, starts, gains, t, t2,
                       threads):  # fmt: skip
    """:func:`_noisy_chain` with its bands shared among ``threads`` threads, each a run
    of consecutive bands with buffers in its own rows (:func:`_bands_apart` holds): every
    element gets the same operations on the same values as in one thread."""
    rows, cols = a.shape[1], a.shape[2]
    band = max(1, CHAIN_BAND // cols)
    nbands = (rows + band - 1) // band
    row_chain = heads[c, 1] == 1
    for j in numba.prange(threads):
        k0, k1 = j * nbands // threads, (j + 1) * nbands // threads
        if row_chain:
            _noisy_row_bands(a, prog, first, c, heads, outs, offsets, bank, starts, gains,
                             t, t2, k0, k1, True)  # fmt: skip
        else:
            _noisy_column_bands(a, prog, first, c, heads, outs, offsets, bank, starts, gains,
                                t, t2, k0, k1, True)  # fmt: skip


_noisy_chain_split = _shared(_noisy_chain_split_par)


@_jit
def _droop(x, step):
    """``x`` droops by ``step`` in place: ``x - clip(x, -step, step)`` (numpy's clip: max,
    then min), the operations of ``hostloops.droop``."""
    lo = -step
    for p in range(x.size):
        v = x[p]
        t = v if v > lo else lo
        t = t if t < step else step
        x[p] = v - t


@_inline
def _local_only(row):
    """Whether a transfer reads and writes only its own element (no neighbour term, no
    push): under a partial FLAG it changes nothing in a row where FLAG is all 0."""
    for k in range(row[_NS]):
        if row[_SD0 + k] != 0:
            return False
    for k in range(row[_ND]):
        if row[_DD0 + k] != 0:
            return False
    return True


@_jit
def _flag_rows(flag, rows, cols, runs):
    """The runs of rows in which FLAG has a 1: ``runs[2j], runs[2j + 1]`` = first row and
    end of run ``j``; returns how many. Eight bytes a word where a row is a whole number
    of words."""
    nruns = 0
    inside = False
    words = cols // 8 if cols % 8 == 0 else 0
    for r in range(rows):
        row = flag[r * cols : (r + 1) * cols]
        hit = False
        if words:
            w = row.view(np.uint64)
            acc = np.uint64(0)
            for k in range(words):
                acc |= w[k]
            hit = acc != 0
        else:
            for p in range(cols):
                hit = hit or row[p] != 0
        if hit and not inside:
            runs[2 * nruns] = r
            inside = True
        elif inside and not hit:
            runs[2 * nruns + 1] = r
            nruns += 1
            inside = False
    if inside:
        runs[2 * nruns + 1] = rows
        nruns += 1
    return nruns


@_jit
def _run(prog, a, d, latch, t, t2, tb, offsets, pixel, bank, bank_div, starts, gains, known,
         heads, outs, edges, runs, pending, decay, codes, threads):  # fmt: skip
    """Run the ICWs of ``prog`` in order, each over the whole array; returns whether FLAG
    is then set everywhere (tracked through the kernel, as each ICW needs it). ``known``:
    FLAG is set everywhere to begin with (the simulator's tracked state), else it is
    tested. A chain's head row runs the chain composed when FLAG is set everywhere and
    skips its ICWs; else they run one by one. Under a partial FLAG a transfer that stays
    inside its element runs only over the rows where FLAG has a 1 (``runs``: scratch of
    ``2 * rows + 2``, found once per change of FLAG): the rows it skips it would leave
    as they are, and noise is drawn by position, so the bytes are the same.

    First the droop pending on the planes ``codes`` names (:class:`KernelDroop`; all 0
    when this part applies none; ``pending``: the simulator's microseconds per decaying
    plane, cleared here): a plane the kernel overwrites whole before reading it (code 2)
    has it dropped when ``known``; another droops by ``float32(decay * us / 1000)`` in a
    pass, as ``hostloops.droop_pending`` does it before the kernel."""
    rows, cols = a.shape[1], a.shape[2]
    n = rows * cols
    af = a.reshape(a.shape[0], n)
    du2 = d.view(np.uint8)
    du = du2.reshape(d.shape[0], n)
    df = d.reshape(d.shape[0], n)
    lu = latch.view(np.uint8).reshape(-1)
    tbu2 = tb.view(np.uint8)
    tbu = tbu2.reshape(-1)
    flag_all = True if known else _all_set(du[_FLAG])
    nruns = -1  # the rows of FLAG's 1s, not yet found
    for pl in range(codes.size):
        if codes[pl] == 0 or pending[pl] <= 0:
            continue
        us = pending[pl]
        pending[pl] = 0.0
        if codes[pl] == 1 or not known:  # (code 2, known: overwritten whole, never seen)
            _droop(af[pl], np.float32(decay * us / 1000.0))
    i = 0
    while i < prog.shape[0]:
        row = prog[i]
        i += 1
        op = row[_OP]
        if op == _CHAIN:
            if flag_all:
                if bank.size == 0:
                    _chain(a, row[_PARTS], heads, outs, edges, t, t2)
                elif _many(threads) and _bands_apart(row[_PARTS], heads, outs):
                    _noisy_chain_split(a, prog, i, row[_PARTS], heads, outs, offsets, bank,
                                       starts, gains, t, t2, threads)  # fmt: skip
                else:
                    _noisy_chain(a, prog, i, row[_PARTS], heads, outs, offsets, bank,
                                 starts, gains, t, t2)  # fmt: skip
                i += row[_ND]
            continue
        if not flag_all and op == _BUS and _local_only(row):
            if nruns < 0:
                nruns = _flag_rows(du[_FLAG], rows, cols, runs)
            for j in range(nruns):
                _op(row, runs[2 * j], runs[2 * j + 1], a, af, df, du, du2, lu, tbu, tbu2, t,
                    t2, flag_all, offsets, pixel, bank, bank_div, starts, gains, None)  # fmt: skip
            continue
        flag_all = _op(row, 0, rows, a, af, df, du, du2, lu, tbu, tbu2, t, t2, flag_all,
            offsets, pixel, bank, bank_div, starts, gains, threads)  # fmt: skip
        if op == _WHERE or op == _WHERED or op == _ALL:
            nruns = -1
    return flag_all
