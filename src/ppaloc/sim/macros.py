"""The programming interface shared by ``Scamp5`` and recorded kernels: primitives and macros.

Every method issues ICWs through ``self._emit``: a ``Scamp5`` runs them at once (charged as a
kernel of their own), a :class:`~ppaloc.sim.kernel.Kernel` records them. Macros expand to
the ICW sequences of the SCAMP-5 kernel API (the official headers
``scamp5_kernel_api_macro_analog.hpp`` and ``..._digital.hpp``), so their ICW counts and
the scratch registers they clobber are those of the hardware library:

- analogue macros use ``NEWS`` as scratch (``mov(y, x)`` leaves ``NEWS = -x``);
- ``AND``, ``XOR`` and ``MUX`` use ``R0`` and ``R12`` (``R12`` is written only where
  ``R0 = 1``, which the expansions arrange);
- ``DNEWS`` writes its direction selectors ``R1`` (south), ``R2`` (west), ``R3`` (north)
  and ``R4`` (east).

A macro whose arguments break a register rule raises
:class:`~ppaloc.errors.RegisterMisuseError` naming the macro call and the ICW at fault.
"""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Sequence

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim.isa import OPS, Instruction, make
from ppaloc.sim.registers import (
    DNEWS_SELECTORS,
    NEWS,
    PIX,
    R0,
    R1,
    R2,
    R12,
    XE,
    XN,
    XS,
    XW,
    Direction,
    Register,
)

__all__ = ["ProgramAPI", "expand"]

# Destination alias that leaves in every NEWS the x of the neighbour in `dir`
# (the element in `dir` pushes into its opposite neighbour's NEWS).
_PUSH_FROM = {Direction.east: XW, Direction.west: XE, Direction.north: XS, Direction.south: XN}
# Source alias that reads the NEWS of the neighbour in `dir`.
_READ_FROM = {Direction.east: XE, Direction.west: XW, Direction.north: XN, Direction.south: XS}

Step = tuple[str, tuple[Register, ...], tuple[Register, ...]]


def _dir(d: object, macro: str) -> Direction:
    if isinstance(d, Direction) and d in _PUSH_FROM:
        return d
    raise RegisterMisuseError(
        f"{macro}: direction {d!r} is not one of north, east, south, west from ppaloc.sim"
    )


def _call(name: str, args: Sequence[object]) -> str:
    def show(a: object) -> str:
        if isinstance(a, Register):
            return a.name
        if isinstance(a, Direction):
            return "|".join(m.name for m in Direction if m in a) or "0"
        return repr(a)

    return f"{name}({', '.join(show(a) for a in args)})"


def _forbid(call: str, args: Sequence[object], scratch: Sequence[Register], why: str) -> None:
    for a in args:
        if isinstance(a, Register) and a in scratch:
            raise RegisterMisuseError(f"{call}: {a.name} cannot be an argument; {why}")


def _distinct(call: str, regs: Sequence[Register]) -> None:
    names = [r.name for r in regs if isinstance(r, Register)]
    for n in names:
        if names.count(n) > 1:
            raise RegisterMisuseError(
                f"{call}: {n} appears twice but this macro needs distinct registers"
            )


def expand(call: str, steps: Sequence[Step]) -> tuple[Instruction, ...]:
    """Validate the primitive ``steps`` of a macro ``call`` into instructions."""
    return tuple(make(op, dsts, srcs, origin=call) for op, dsts, srcs in steps)


class ProgramAPI:
    """Instructions and macros with SCAMP-5 names and argument order.

    Subclasses implement ``_emit(instructions)``.
    """

    def _emit(self, instructions: tuple[Instruction, ...]) -> None:  # pragma: no cover
        raise NotImplementedError

    def _prim(self, op: str, dsts=(), srcs=()) -> None:
        self._emit((make(op, tuple(dsts), tuple(srcs)),))

    def _macro(self, name: str, args: Sequence[object], steps: Sequence[Step]) -> None:
        self._emit(expand(_call(name, args), steps))

    def icw(
        self,
        op: str | int,
        dsts: Sequence[Register] | Iterable[int] = (),
        srcs: Sequence[Register] = (),
    ) -> None:
        """Issue one ICW: a row of the op table by name, ``k.icw("bus", (A,), (B, C))``, or
        the header's raw word ``k.icw(clock, bits)`` (``icw(uint8_t clock, {bits...})``:
        the clock field and the bit positions of ``SCAMP5_ICW_BITS``), decoded by
        :func:`ppaloc.sim.bits.decode` into the instruction it encodes."""
        if isinstance(op, int) and not isinstance(op, bool):
            from ppaloc.sim.bits import decode

            self._emit((decode(op, dsts),))
            return
        if not isinstance(op, str) or op not in OPS:
            raise RegisterMisuseError(f"{op!r} is not an instruction; use one of {sorted(OPS)}")
        for name, regs in (("dsts", dsts), ("srcs", srcs)):
            if isinstance(regs, Register) or not isinstance(regs, Sequence):
                raise RegisterMisuseError(
                    f"icw({op!r}): {name}={regs!r} must be a tuple of registers, e.g. (A,)"
                )
        self._prim(op, dsts, srcs)

    # ------------------------------------------------------------------ analogue primitives
    def nop(self) -> None:
        """An empty ICW (one clock)."""
        self._prim("nop")

    def rpix(self) -> None:
        """Reset ``PIX`` to its reset level (the captured image is gone)."""
        self._prim("rpix")

    def bus(self, a: Register | Sequence[Register], *srcs: Register) -> None:
        """``a := -(sum of up to four sources)``; no source: ``a := 0``.

        The header's several-destination form ``bus({a, b, ...}, {x, y, ...})`` is
        ``k.bus((a, b, ...), (x, y, ...))``: one ICW, every destination gets
        ``-(sum) / n_destinations`` (the current splits), so ``bus((a, b), (x,))`` is the
        same ICW as ``bus2(a, b, x)``.
        """
        if isinstance(a, Register):
            self._prim("bus", (a,), srcs)
            return
        if not isinstance(a, Sequence) or isinstance(a, str):
            raise RegisterMisuseError(
                f"bus({a!r}): give a register, or the destinations and the sources as two "
                "tuples, e.g. bus(A, B) or bus((A, B), (C,))"
            )
        if len(srcs) > 1 or (srcs and isinstance(srcs[0], Register)):
            raise RegisterMisuseError(
                "bus(dsts, srcs): give the destinations and the sources as two tuples, "
                "e.g. bus((A, B), (C,))"
            )
        dsts, sources = tuple(a), tuple(srcs[0]) if srcs else ()
        n, m = len(dsts), len(sources)
        if n == 1 and m <= 4:
            op = "bus"
        elif n == 2 and m <= 2:
            op = "bus2"
        elif n == 3 and m == 1:
            op = "bus3"
        else:
            op = "busn"
        self._prim(op, dsts, sources)

    def bus2(self, a: Register, b: Register, *srcs: Register) -> None:
        """``a, b := -(sum of up to two sources) / 2`` (the current is split in two)."""
        self._prim("bus2", (a, b), srcs)

    def bus3(self, a: Register, b: Register, c: Register, src: Register) -> None:
        """``a, b, c := -src / 3``."""
        self._prim("bus3", (a, b, c), (src,))

    def sq(self, x0: Register, x1: Register | None = None) -> None:
        """``sq(x0[, x1])``: one ICW writing ``NEWS`` from the sources through the PE's
        ``selsq`` path; modelled as ``NEWS := -(x0 + x1)`` (docs/sim.md: the squarer's
        transfer is not public)."""
        self._prim("sq", (NEWS,), (x0,) if x1 is None else (x0, x1))

    def blurset(self) -> None:
        """The ICW needed once before blurs: reads R1 and R2, which enable the blur links."""
        self._prim("blurset", (), (R1, R2))

    def blur(self, a: Register, x0: Register) -> None:
        """Analogue asynchronous blur: ``a := -diffuse(x0)`` over the links R1/R2 enable."""
        self._blur("blur", a, x0)

    def blurh(self, a: Register, x0: Register) -> None:
        """As :meth:`blur`, east-west links only."""
        self._blur("blurh", a, x0)

    def blurv(self, a: Register, x0: Register) -> None:
        """As :meth:`blur`, north-south links only."""
        self._blur("blurv", a, x0)

    def _blur(self, op: str, a: Register, x0: Register) -> None:
        for r in (a, x0):
            if isinstance(r, Register) and r.role == "neighbour":
                raise RegisterMisuseError(
                    f"{_call(op, (a, x0))}: {r.name} is a neighbour's NEWS; a blur reads and "
                    "writes the element's own registers (use NEWS)"
                )
        self._prim(op, (a,), (x0,))

    def where(self, *srcs: Register) -> None:
        """``FLAG := (sum of one to three analogue sources) > 0``."""
        self._prim("where", (), srcs)

    def all(self) -> None:
        """``FLAG := 1`` in every element."""
        self._prim("all")

    # ------------------------------------------------------------------- digital primitives
    def SET(self, *dregs: Register) -> None:
        """``d := 1`` for one to four digital registers."""
        self._prim("SET", dregs)

    def CLR(self, *dregs: Register) -> None:
        """``d := 0`` for one to four digital registers."""
        self._prim("CLR", dregs)

    def MOV(self, d: Register, d0: Register) -> None:
        """``d := d0``."""
        self._prim("MOV", (d,), (d0,))

    def OR(self, d: Register, *srcs: Register) -> None:
        """``d := OR of 2-4 sources``; with one source the 2-ICW macro ``d := d OR src``."""
        if len(srcs) == 1:
            self._macro("OR", (d, *srcs), [("LATCH", (), (d, srcs[0])), ("UNLATCH", (d,), ())])
        else:
            self._prim("OR", (d,), srcs)

    def NOR(self, d: Register, *srcs: Register) -> None:
        """``d := NOT(OR of 2-4 sources)``; one source: 2-ICW macro ``d := d NOR src``."""
        if len(srcs) == 1:
            self._macro("NOR", (d, *srcs), [("LATCHN", (), (d, srcs[0])), ("UNLATCH", (d,), ())])
        else:
            self._prim("NOR", (d,), srcs)

    def NOT(self, d: Register, d0: Register | None = None) -> None:
        """``d := NOT d0``; without ``d0`` the 2-ICW macro ``d := NOT d``."""
        if d0 is None:
            self._macro("NOT", (d,), [("LATCHN", (), (d,)), ("UNLATCH", (d,), ())])
        else:
            self._prim("NOT", (d,), (d0,))

    def WHERE(self, *srcs: Register) -> None:
        """``FLAG := OR of one to three digital sources``."""
        self._prim("WHERE", (), srcs)

    def ALL(self) -> None:
        """``FLAG := 1`` (the same ICW as :meth:`all`)."""
        self._prim("all")

    def DNEWS0(self, d: Register, d0: Register) -> None:
        """``d := OR of d0 of the neighbours selected by R1-R4``; beyond the edge reads 0."""
        self._prim("DNEWS0", (d,), (d0,))

    def DNEWS1(self, d: Register, d0: Register) -> None:
        """As :meth:`DNEWS0`, but beyond the edge reads 1."""
        self._prim("DNEWS1", (d,), (d0,))

    def REFRESH(self, d: Register) -> None:
        """Read ``d`` and write it back (2 ICWs), restarting its retention time."""
        self._macro("REFRESH", (d,), [("LATCH", (), (d,)), ("UNLATCH", (d,), ())])

    def PROP0(self) -> None:
        """Asynchronous propagation on R12 masked by R0 (edge 0); 2 ICWs (PROP_R, PROP_0)."""
        self._macro("PROP0", (), [("PROP_R", (), (R12,)), ("PROP0", (R12,), ())])

    def PROP1(self) -> None:
        """As :meth:`PROP0`, the array edge counting as 1."""
        self._macro("PROP1", (), [("PROP_R", (), (R12,)), ("PROP1", (R12,), ())])

    # ------------------------------------------------------------------- analogue macros
    def res(self, a: Register, b: Register | None = None) -> None:
        """``a := 0`` (and ``b := 0``); 2 (3) ICWs, NEWS := 0."""
        steps: list[Step] = [("bus", (NEWS,), ()), ("bus", (a,), (NEWS,))]
        if b is not None:
            steps.append(("bus", (b,), (NEWS,)))
        self._macro("res", (a,) if b is None else (a, b), steps)

    def mov(self, y: Register, x0: Register, dir: Direction | None = None) -> None:
        """``y := x0`` (2 ICWs, NEWS := -x0); with ``dir``, the deprecated form of movx."""
        if dir is not None:
            return self.movx(y, x0, dir)
        self._macro("mov", (y, x0), [("bus", (NEWS,), (x0,)), ("bus", (y,), (NEWS,))])

    def add(self, y: Register, x0: Register, x1: Register, x2: Register | None = None) -> None:
        """``y := x0 + x1 (+ x2)``; 2 ICWs, NEWS := -(sum)."""
        srcs = (x0, x1) if x2 is None else (x0, x1, x2)
        self._macro("add", (y, *srcs), [("bus", (NEWS,), srcs), ("bus", (y,), (NEWS,))])

    def sub(
        self, y: Register, x0: Register, x1: Register | Direction, x2: Register | None = None
    ) -> None:
        """``y := x0 - x1``; 2 ICWs, NEWS := -x0; ``y`` must differ from ``x1``.

        The header's deprecated four-argument form ``sub(y, x0, dir, x1)`` gives
        ``y := x0`` of the neighbour in ``dir`` minus the local ``x1``, as
        ``bus(NEWS, x0); bus(y, X<dir>, x1)`` (unlike :meth:`subx`, it reads the
        neighbour's NEWS instead of pushing into it).
        """
        if x2 is None and not isinstance(x1, Direction):
            self._macro("sub", (y, x0, x1), [("bus", (NEWS,), (x0,)), ("bus", (y,), (NEWS, x1))])
            return
        call = _call("sub", (y, x0, x1) if x2 is None else (y, x0, x1, x2))
        if x2 is None:
            raise RegisterMisuseError(
                f"{call}: give the register to subtract, sub(y, x0, dir, x1), or use "
                "movx(y, x0, dir) to only move"
            )
        if not isinstance(x1, Direction):
            raise RegisterMisuseError(
                f"{call}: the third argument must be a direction in the four-argument form "
                "sub(y, x0, dir, x1); for y := x0 - x1 write sub(y, x0, x1)"
            )
        d = _dir(x1, call)
        self._emit(expand(call, [("bus", (NEWS,), (x0,)), ("bus", (y,), (_READ_FROM[d], x2))]))

    def neg(self, y: Register, x0: Register) -> None:
        """``y := -x0``; 2 ICWs, NEWS := 0."""
        self._macro("neg", (y, x0), [("bus", (NEWS,), ()), ("bus", (y,), (NEWS, x0))])

    def abs(self, y: Register, x0: Register) -> None:
        """``y := |x0|``; 6 ICWs, ends with ``all()`` (FLAG := 1), NEWS := -x0."""
        self._macro(
            "abs",
            (y, x0),
            [
                ("bus", (NEWS,), ()),
                ("bus", (y,), (NEWS, x0)),
                ("bus", (NEWS,), (x0,)),
                ("where", (), (x0,)),
                ("bus", (y,), (NEWS,)),
                ("all", (), ()),
            ],
        )

    def divq(self, y0: Register, x0: Register) -> None:
        """``y0 := x0 / 2`` (quick, 2 ICWs, less accurate than div)."""
        self._macro("divq", (y0, x0), [("bus2", (y0, NEWS), (x0,)), ("bus", (y0,), (NEWS,))])

    def div(self, y0: Register, y1: Register, y2: Register, x0: Register | None = None) -> None:
        """``y0 := x0 / 2`` (x0 defaults to y2); y1 := -x0/2, y2 := x0; 5 ICWs, NEWS scratch.

        ``x0`` may be ``y2`` (the header's expansion is then the 3-argument form's)."""
        src = y2 if x0 is None else x0
        args = (y0, y1, y2) if x0 is None else (y0, y1, y2, x0)
        call = _call("div", args)
        _distinct(call, (y0, y1, y2) if src == y2 else args)
        self._emit(
            expand(
                call,
                [
                    ("bus2", (y0, y1), (src,)),
                    ("bus", (NEWS,), (src, y1)),
                    ("bus", (y2,), (NEWS, y0)),
                    ("bus2", (y0, y1), (y2,)),
                    ("bus", (y0,), (y1,)),
                ],
            )
        )

    def diva(self, y0: Register, y1: Register, y2: Register) -> None:
        """``y0 := y0 / 2`` in place; y1, y2 := -y0/2; 5 ICWs, NEWS scratch."""
        call = _call("diva", (y0, y1, y2))
        _distinct(call, (y0, y1, y2))
        self._emit(
            expand(
                call,
                [
                    ("bus2", (y1, y2), (y0,)),
                    ("bus", (NEWS,), (y1, y0)),
                    ("bus", (y0,), (NEWS, y2)),
                    ("bus2", (y1, y2), (y0,)),
                    ("bus", (y0,), (y1,)),
                ],
            )
        )

    def movx(self, y: Register, x0: Register, dir: Direction) -> None:
        """``y := x0`` of the neighbour in ``dir`` (``west`` moves the picture east)."""
        call = _call("movx", (y, x0, dir))
        d = _dir(dir, call)
        self._emit(expand(call, [("bus", (_PUSH_FROM[d],), (x0,)), ("bus", (y,), (NEWS,))]))

    def mov2x(self, y: Register, x0: Register, dir: Direction, dir2: Direction) -> None:
        """``y := x0`` of the neighbour two steps away (``dir`` then ``dir2``); FLAG all."""
        call = _call("mov2x", (y, x0, dir, dir2))
        d, d2 = _dir(dir, call), _dir(dir2, call)
        self._emit(
            expand(call, [("bus", (_PUSH_FROM[d],), (x0,)), ("bus", (y,), (_READ_FROM[d2],))])
        )

    def addx(self, y: Register, x0: Register, x1: Register, dir: Direction) -> None:
        """``y := x0 + x1``, both of the neighbour in ``dir``."""
        call = _call("addx", (y, x0, x1, dir))
        d = _dir(dir, call)
        self._emit(expand(call, [("bus", (_PUSH_FROM[d],), (x0, x1)), ("bus", (y,), (NEWS,))]))

    def add2x(
        self, y: Register, x0: Register, x1: Register, dir: Direction, dir2: Direction
    ) -> None:
        """``y := x0 + x1`` of the element two steps away (``dir`` then ``dir2``)."""
        call = _call("add2x", (y, x0, x1, dir, dir2))
        d, d2 = _dir(dir, call), _dir(dir2, call)
        self._emit(
            expand(call, [("bus", (_PUSH_FROM[d],), (x0, x1)), ("bus", (y,), (_READ_FROM[d2],))])
        )

    def subx(self, y: Register, x0: Register, dir: Direction, x1: Register) -> None:
        """``y := x0`` of the neighbour in ``dir`` minus the local ``x1``."""
        call = _call("subx", (y, x0, dir, x1))
        d = _dir(dir, call)
        self._emit(expand(call, [("bus", (_PUSH_FROM[d],), (x0,)), ("bus", (y,), (NEWS, x1))]))

    def sub2x(
        self, y: Register, x0: Register, dir: Direction, dir2: Direction, x1: Register
    ) -> None:
        """``y := x0`` of the element two steps away minus the local ``x1``."""
        call = _call("sub2x", (y, x0, dir, dir2, x1))
        d, d2 = _dir(dir, call), _dir(dir2, call)
        self._emit(
            expand(call, [("bus", (_PUSH_FROM[d],), (x0,)), ("bus", (y,), (_READ_FROM[d2], x1))])
        )

    def newsblur(self, y: Register, x: Register, iterations: int = 1) -> None:
        """``y :=`` the sum of the four neighbours of ``x`` (each pass sums those of the last
        pass), ``iterations`` times; NEWS scratch (it holds the negated input of a pass)."""
        self._newsblur("newsblur", y, x, iterations, (XE, XW, XN, XS))

    def newsblurh(self, y: Register, x: Register, iterations: int = 1) -> None:
        """Sum of the east and west neighbours, ``iterations`` times; NEWS scratch."""
        self._newsblur("newsblurh", y, x, iterations, (XE, XW))

    def newsblurv(self, y: Register, x: Register, iterations: int = 1) -> None:
        """Sum of the north and south neighbours, ``iterations`` times; NEWS scratch."""
        self._newsblur("newsblurv", y, x, iterations, (XN, XS))

    def _newsblur(
        self, name: str, y: Register, x: Register, iterations: int, nbrs: tuple[Register, ...]
    ) -> None:
        call = _call(name, (y, x, iterations))
        _check_iterations(call, iterations)
        steps: list[Step] = [("bus", (NEWS,), (x,)), ("bus", (y,), nbrs)]
        for _ in range(1, iterations):
            steps += [("bus", (NEWS,), (y,)), ("bus", (y,), nbrs)]
        self._emit(expand(call, steps))

    def gauss(self, y: Register, x: Register, iterations: int = 3) -> None:
        """Blur ``x`` into ``y`` (may be the same register); ``blurset`` + 2 blurs per
        iteration, NEWS scratch; R1 and R2 must enable the links."""
        self._gauss("gauss", "blur", y, x, iterations)

    def gaussh(self, y: Register, x: Register, iterations: int = 3) -> None:
        """As :meth:`gauss`, horizontal only."""
        self._gauss("gaussh", "blurh", y, x, iterations)

    def gaussv(self, y: Register, x: Register, iterations: int = 3) -> None:
        """As :meth:`gauss`, vertical only."""
        self._gauss("gaussv", "blurv", y, x, iterations)

    def _gauss(self, name: str, op: str, y: Register, x: Register, iterations: int) -> None:
        call = _call(name, (y, x, iterations))
        _check_iterations(call, iterations)
        steps: list[Step] = [("blurset", (), (R1, R2)), (op, (NEWS,), (x,)), (op, (y,), (NEWS,))]
        for _ in range(1, iterations):
            steps += [(op, (NEWS,), (y,)), (op, (y,), (NEWS,))]
        self._emit(expand(call, steps))

    def getpix(self, y: Register, h_or_res: Register, pix_res: Register | None = None) -> None:
        """Read PIX against a stored reset level (no reset of PIX).

        ``getpix(y, pix_res)``: ``y := PIX - pix_res`` (half range; 2 ICWs).
        ``getpix(y, h, pix_res)``: ``h := -PIX``, ``y := 2 PIX - pix_res`` (full range;
        3 ICWs). ``pix_res`` is a reset level kept earlier, e.g. by ``respix(pix_res)``.
        """
        if pix_res is None:
            steps: list[Step] = [("bus", (NEWS,), (PIX,)), ("bus", (y,), (NEWS, h_or_res))]
            self._macro("getpix", (y, h_or_res), steps)
        else:
            h = h_or_res
            steps = [
                ("bus", (h,), (PIX,)),
                ("bus", (NEWS,), (PIX,)),
                ("bus", (y,), (h, NEWS, pix_res)),
            ]
            self._macro("getpix", (y, h, pix_res), steps)

    def get_image(self, y: Register, h: Register | None = None) -> None:
        """Capture: ``y`` := full-range image (``h`` := its negated half) and reset PIX.

        With ``h`` (6 ICWs) an ideal pixel ``p`` gives the full-range ``y = p - 128`` (in
        [-128, 127]) and ``h = -(p/2 - 64)``, its negated half; without it (5 ICWs) ``y``
        is the half-range image ``p/2 - 64``, in which the pixel's fixed-pattern offset
        cancels against its reset level.
        """
        if h is None:
            steps: list[Step] = [
                ("bus", (NEWS,), (PIX,)),
                ("rpix", (), ()),
                ("rpix", (), ()),
                ("nop", (), ()),
                ("bus", (y,), (NEWS, PIX)),
            ]
            self._macro("get_image", (y,), steps)
        else:
            steps = [
                ("bus", (NEWS,), (PIX,)),
                ("bus", (h,), (PIX,)),
                ("rpix", (), ()),
                ("rpix", (), ()),
                ("nop", (), ()),
                ("bus", (y,), (h, NEWS, PIX)),
            ]
            self._macro("get_image", (y, h), steps)

    def respix(self, y: Register | None = None) -> None:
        """Reset PIX (3 ICWs); with ``y``, also keep its reset level in ``y`` (5 ICWs)."""
        steps: list[Step] = [("rpix", (), ()), ("rpix", (), ()), ("nop", (), ())]
        if y is not None:
            steps += [("bus", (NEWS,), (PIX,)), ("bus", (y,), (NEWS,))]
        self._macro("respix", () if y is None else (y,), steps)

    # -------------------------------------------------------------------- digital macros
    def AND(self, d: Register, d0: Register, d1: Register) -> None:
        """``d := d0 AND d1``; 4 ICWs, clobbers R0 (:= NOT d1) and R12 (:= NOT d0)."""
        call = _call("AND", (d, d0, d1))
        _forbid(call, (d, d0, d1), (R0, R12), "AND uses R0 and R12 as scratch")
        self._emit(expand(call, _and_steps(d, d0, d1)))

    def NAND(self, d: Register, d0: Register, d1: Register) -> None:
        """``d := NOT(d0 AND d1)``; 4 ICWs, clobbers R0 and R12."""
        call = _call("NAND", (d, d0, d1))
        _forbid(call, (d, d0, d1), (R0, R12), "NAND uses R0 and R12 as scratch")
        steps = _and_steps(d, d0, d1)
        steps[-1] = ("OR", (d,), (R0, R12))
        self._emit(expand(call, steps))

    def XOR(self, d: Register, d0: Register, d1: Register) -> None:
        """``d := d0 XOR d1``; 7 ICWs (AND, a NOR, a 2-ICW NOR), clobbers R0 and R12."""
        call = _call("XOR", (d, d0, d1))
        _forbid(call, (d, d0, d1), (R0, R12), "XOR uses R0 and R12 as scratch")
        _distinct(call, (d, d0, d1))  # d is written before the sources are read again
        steps = [
            *_and_steps(d, d0, d1),
            ("NOR", (R0,), (d0, d1)),
            ("LATCHN", (), (d, R0)),
            ("UNLATCH", (d,), ()),
        ]
        self._emit(expand(call, steps))

    def IMP(self, d: Register, d0: Register, d1: Register) -> None:
        """``d := d0 OR NOT d1``; 2 ICWs, clobbers R0."""
        call = _call("IMP", (d, d0, d1))
        _forbid(call, (d, d0, d1), (R0,), "IMP uses R0 as scratch")
        _no_r12_dst(call, (d,))
        self._emit(expand(call, [("NOT", (R0,), (d1,)), ("OR", (d,), (d0, R0))]))

    def NIMP(self, d: Register, d0: Register, d1: Register) -> None:
        """``d := NOT d0 AND d1``; 2 ICWs, clobbers R0."""
        call = _call("NIMP", (d, d0, d1))
        _forbid(call, (d, d0, d1), (R0,), "NIMP uses R0 as scratch")
        _no_r12_dst(call, (d,))
        self._emit(expand(call, [("NOT", (R0,), (d1,)), ("NOR", (d,), (d0, R0))]))

    def CLR_IF(self, d: Register, d0: Register) -> None:
        """``d := 0 where d0 = 1``; 2 ICWs, clobbers R0."""
        call = _call("CLR_IF", (d, d0))
        _forbid(call, (d, d0), (R0,), "CLR_IF uses R0 as scratch")
        _no_r12_dst(call, (d,))
        self._emit(expand(call, [("NOT", (R0,), (d,)), ("NOR", (d,), (R0, d0))]))

    def ANDX(self, d: Register, d0: Register, x: Register) -> None:
        """``d := d0 AND x``, ``d0 := NOT x``; 3 ICWs, clobbers R0 (:= NOT d0)."""
        self._andx("ANDX", d, d0, x, "NOR")

    def NANDX(self, d: Register, d0: Register, x: Register) -> None:
        """``d := NOT(d0 AND x)``, ``d0 := NOT x``; 3 ICWs, clobbers R0."""
        self._andx("NANDX", d, d0, x, "OR")

    def _andx(self, name: str, d: Register, d0: Register, x: Register, last: str) -> None:
        call = _call(name, (d, d0, x))
        _forbid(call, (d, d0, x), (R0,), f"{name} uses R0 as scratch")
        _no_r12_dst(call, (d, d0))
        _distinct(call, (d, d0))
        steps: list[Step] = [("NOT", (R0,), (d0,)), ("NOT", (d0,), (x,)), (last, (d,), (R0, d0))]
        self._emit(expand(call, steps))

    def XORX(self, d: Register, d0: Register, d1: Register) -> None:
        """``d := d0 XOR d1``, ``d0 := d0 AND NOT d1``; 6 ICWs, clobbers R0."""
        call = _call("XORX", (d, d0, d1))
        _forbid(call, (d, d0, d1), (R0,), "XORX uses R0 as scratch")
        _no_r12_dst(call, (d, d0))
        _distinct(call, (d, d0, d1))
        steps: list[Step] = [
            ("NOT", (R0,), (d1,)),
            ("NOR", (d,), (d0, R0)),
            ("NOT", (R0,), (d0,)),
            ("NOR", (d0,), (d1, R0)),
            ("LATCH", (), (d, d0)),
            ("UNLATCH", (d,), ()),
        ]
        self._emit(expand(call, steps))

    def MUX(self, d: Register, sel: Register, d1: Register, d0: Register) -> None:
        """``d := d1 where sel = 1, else d0``; 5 ICWs, clobbers R0 (:= sel) and R12."""
        call = _call("MUX", (d, sel, d1, d0))
        _forbid(call, (d, sel, d1, d0), (R0, R12), "MUX uses R0 and R12 as scratch")
        self._emit(
            expand(
                call,
                [
                    ("SET", (R0,), ()),
                    ("MOV", (R12,), (d0,)),
                    ("MOV", (R0,), (sel,)),
                    ("MOV", (R12,), (d1,)),
                    ("MOV", (d,), (R12,)),
                ],
            )
        )

    def DNEWS(self, d: Register, d0: Register, dir: Direction, boundary: bool | int = 0) -> None:
        """``d := OR of d0 of the neighbours in dir`` (e.g. ``north | east``); 3 ICWs.

        Sets the selectors R1 (south), R2 (west), R3 (north), R4 (east); beyond the array
        edge ``d0`` reads ``boundary``.
        """
        if isinstance(boundary, float | str) or boundary not in (0, 1):
            raise RegisterMisuseError(
                f"{_call('DNEWS', (d, d0, dir))}: boundary={boundary!r} is the value read "
                "beyond the array edge; use 0 or 1"
            )
        call = _call("DNEWS", (d, d0, dir, int(boundary)))
        if not isinstance(dir, Direction) or int(dir) == 0 or int(dir) & ~15:
            raise RegisterMisuseError(
                f"{call}: dir must be north, east, south, west or a | of them from ppaloc.sim"
            )
        # in the header's order (R1 south, R2 west, R3 north, R4 east): the same word
        sels = tuple(
            sorted((DNEWS_SELECTORS[m] for m in Direction if m in dir), key=lambda r: r.index)
        )
        _forbid(call, (d0,), tuple(DNEWS_SELECTORS.values()), "DNEWS overwrites R1-R4 first")
        self._emit(
            expand(
                call,
                [
                    ("CLR", tuple(DNEWS_SELECTORS.values()), ()),
                    ("SET", sels, ()),
                    ("DNEWS1" if boundary else "DNEWS0", (d,), (d0,)),
                ],
            )
        )


def _no_r12_dst(call: str, dsts: Sequence[Register]) -> None:
    """R12 is written only where R0 = 1, and these macros use R0 as their own scratch."""
    for r in dsts:
        if isinstance(r, Register) and r == R12:
            raise RegisterMisuseError(
                f"{call}: R12 cannot be the destination: it is written only where R0 = 1 and "
                "this macro uses R0 as scratch; write to another register and MOV it"
            )


MAX_ITERATIONS = 1 << 16
"""Most passes of a blur macro (``newsblur*``, ``gauss*``), the bound of the controller's
``diffuse`` and ``flood`` iterations: two ICWs a pass, far beyond a kernel's 1024."""


def _check_iterations(call: str, iterations: object) -> None:
    if (
        isinstance(iterations, bool)
        or not isinstance(iterations, numbers.Integral)
        or iterations < 1
    ):
        raise SimulatorError(f"{call}: iterations={iterations!r} is invalid; use an integer >= 1")
    if iterations > MAX_ITERATIONS:  # its steps are listed before the kernel keeps 1024
        raise SimulatorError(
            f"{call}: iterations={iterations!r} is too many; use an integer in "
            f"[1, {MAX_ITERATIONS}] (a kernel holds 1024 ICWs)"
        )


def _and_steps(d: Register, d0: Register, d1: Register) -> list[Step]:
    return [
        ("SET", (R0,), ()),
        ("NOT", (R12,), (d0,)),
        ("NOT", (R0,), (d1,)),
        ("NOR", (d,), (R0, R12)),
    ]
