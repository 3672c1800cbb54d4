"""The simulated SCAMP-5 array: register file, primitive semantics, FLAG and R0 rules.

Each register is one plane of shape (rows, cols): analogue planes are float32 in
[-128, 127], digital planes bool. Instructions are compiled once into closures over these
planes (bound, in-place numpy operations) and run as often as needed, so a recorded kernel
replays with little Python overhead.

Semantics (docs/sim.md has the reasoning):

- An analogue write happens only in elements whose ``FLAG`` is 1; digital instructions
  ignore ``FLAG``. A digital write to ``R12`` happens only where ``R0`` is 1.
- Analogue values saturate at [-128, 127] after every write, in every noise mode.
- A neighbour transfer links an element's bus with the ``NEWS`` of its neighbour. It takes
  effect only where both are flagged: a neighbour term (``XE`` as a source) contributes the
  neighbour's ``NEWS`` only if the neighbour is flagged, and a pushed value (``XW`` as a
  destination) carries the sender's sum only if the sender is flagged; otherwise, and
  beyond the array edge, the link carries 0. The written element must itself be flagged.
- ``DNEWS0``/``DNEWS1``: every element ORs the source of the neighbours its own selectors
  R1 (south), R2 (west), R3 (north), R4 (east) name; beyond the edge the source reads 0/1.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from typing import TYPE_CHECKING

import numpy as np

from ppaloc.errors import KernelError, SimulatorError
from ppaloc.sim import hostloops
from ppaloc.sim.cells import CellLoadMixin
from ppaloc.sim.controller import ControllerMixin
from ppaloc.sim.engines import make_engine
from ppaloc.sim.isa import CLOCK_CLASSES, Instruction
from ppaloc.sim.macros import ProgramAPI
from ppaloc.sim.noise import NoiseModel, NoiseParams
from ppaloc.sim.noise import fast_clip as _clip
from ppaloc.sim.observe import ImageSet, ObservableMixin, PlaneWrite, SimObserver
from ppaloc.sim.registers import (
    ANALOG_PLANES,
    DIGITAL_PLANES,
    DNEWS_SELECTORS,
    FLAG,
    IN,
    NEWS,
    PIX,
    R0,
    R12,
    Register,
)
from ppaloc.sim.timing import TimingModel

if TYPE_CHECKING:
    from ppaloc.sim.kernel import Kernel

__all__ = ["Scamp5"]

_LO = np.float32(-128.0)
_HI = np.float32(127.0)
_FLAG_I = FLAG.index
_NEWS_I = NEWS.index
_IN_I = IN.index
_N_ANALOG = len(ANALOG_PLANES)
_N_DIGITAL = len(DIGITAL_PLANES)
#: The longest side of a simulated array: 16 times the device's 256 (a 4096 x 4096 array
#: holds its planes in a few GiB; a side of 10**6 would ask for terabytes).
MAX_SIDE = 4096
_DECAYING = tuple(r.index for r in ANALOG_PLANES if r.role in ("general", "news"))
assert _DECAYING == tuple(range(len(_DECAYING)))  # contiguous: one slice droops them all
_DECAY_PLANES = slice(0, len(_DECAYING))

Op = Callable[[], None]
_Dest = tuple[np.ndarray, int, tuple | None]  # (plane, plane index, push slices or None)


def _slices(dr: int, dc: int) -> tuple[tuple[slice, slice], tuple[slice, slice]]:
    """(out, in) slices so that ``out_plane[out] = in_plane[in]`` reads (r + dr, c + dc)."""

    def one(d: int) -> tuple[slice, slice]:
        if d == 0:
            return slice(None), slice(None)
        if d > 0:
            return slice(0, -d), slice(d, None)
        return slice(-d, None), slice(0, d)

    (ro, ri), (co, ci) = one(dr), one(dc)
    return (ro, co), (ri, ci)


def _edge_slices(dr: int, dc: int, rows: int, cols: int) -> list[tuple[slice, slice]]:
    """The parts of a plane whose (r + dr, c + dc) lies beyond the edge."""
    out = []
    if dr > 0:
        out.append((slice(rows - dr, None), slice(None)))
    elif dr < 0:
        out.append((slice(0, -dr), slice(None)))
    if dc > 0:
        out.append((slice(None), slice(cols - dc, None)))
    elif dc < 0:
        out.append((slice(None), slice(0, -dc)))
    return out


_BUS_OPS = frozenset({"bus", "bus2", "bus3", "busn"})
_FLAG_OPS = frozenset({"where", "WHERE", "all"})


def same_level(a: float, b: float | None) -> bool:
    """Whether a fill of ``a`` writes the bytes a plane of level ``b`` holds (None:
    unknown): equal values of the same sign (``0.0`` and ``-0.0`` differ in their bytes).

    Examples
    --------
    >>> same_level(3.0, 3.0), same_level(0.0, -0.0), same_level(1.0, None)
    (True, False, False)
    """
    return b is not None and a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


def overwritten_first(instructions: Iterable[Instruction]) -> frozenset[int]:
    """Decaying analogue planes a kernel overwrites whole before anything reads them, if
    FLAG is set everywhere when it starts.

    A plane counts when its first use is as a destination of a bus transfer (``bus``,
    ``bus2``, ``bus3``, ``busn``; not a neighbour's ``NEWS`` by a push) that does not
    also read it, and no ICW before that one changes FLAG (``where``, ``WHERE``, ``all``
    or a digital write of FLAG): with FLAG set everywhere that transfer writes every
    element, so the plane's pending droop would change nothing that is read again.
    """
    seen: set[int] = set()
    fresh: set[int] = set()
    flag_kept = True
    for ins in instructions:
        reads = {r.index for r in ins.srcs if r.kind == "analog"}
        if flag_kept and ins.op in _BUS_OPS:
            for d in ins.dsts:
                i = d.index
                if d.role != "neighbour" and i < len(_DECAYING) and i not in seen | reads:
                    fresh.add(i)
        seen |= reads
        seen |= {r.index for r in ins.dsts if r.kind == "analog"}
        if ins.op in _FLAG_OPS or any(r.index == _FLAG_I and r.kind == "digital" for r in ins.dsts):
            flag_kept = False
    return frozenset(fresh)


def droop_planes(instructions: Iterable[Instruction]) -> tuple[tuple[int, ...], frozenset[int]]:
    """(the decaying analogue planes the ICWs name, in order; those of them the kernel
    overwrites whole before reading, :func:`overwritten_first`): what the droop pending
    before a kernel is applied to, or dropped from."""
    instructions = tuple(instructions)
    touched = {
        r.index
        for ins in instructions
        for r in (*ins.dsts, *ins.srcs)
        if r.kind == "analog" and r.index < len(_DECAYING)
    }
    return tuple(sorted(touched)), overwritten_first(instructions)


def _named_planes(instructions: tuple[Instruction, ...]) -> tuple[frozenset[int], frozenset[int]]:
    """(the analogue planes the ICWs name; those of them the kernel overwrites whole before
    reading, :func:`overwritten_first`): what :meth:`Scamp5._settle_fills` takes."""
    used = frozenset(
        r.index for ins in instructions for r in (*ins.dsts, *ins.srcs) if r.kind == "analog"
    )
    return used, overwritten_first(instructions)


def constant_prefix(instructions: tuple[Instruction, ...]) -> tuple[Instruction, ...]:
    """The kernel's leading bus transfers (``bus``, ``bus2``, ``bus3``, ``busn``) that read
    and write only their own element's registers (no neighbour alias, one source or more):
    with FLAG set everywhere and constant sources, each writes one constant everywhere."""
    n = 0
    for ins in instructions:
        if (
            ins.op not in _BUS_OPS
            or not ins.srcs
            or any(r.kind != "analog" or r.role == "neighbour" for r in (*ins.dsts, *ins.srcs))
        ):
            break
        n += 1
    return instructions[:n]


def fold_transfers(
    steps: Iterable[tuple[tuple[int, ...], int, tuple[int, ...]]], values: dict[int, float]
) -> dict[int, float]:
    """Ideal bus transfers on constant planes: per step ``(sources, parts, destinations)``
    every destination := clip(-(sum of the sources, left to right) / parts), in float32
    as the engines compute it (``-sum``, ``sum * -0.5``, ``sum / -parts``). ``values``:
    the planes' constants before (updated and returned).

    Examples
    --------
    >>> fold_transfers([((3,), 2, (4, 6)), ((4, 8), 1, (3,))], {3: 100.0, 8: -99.0})
    {3: 127.0, 8: -99.0, 4: -50.0, 6: -50.0}
    """
    for srcs, parts, dsts in steps:
        total = np.float32(values[srcs[0]])
        for i in srcs[1:]:
            total = total + np.float32(values[i])
        if parts == 1:
            value = -total
        elif parts == 2:
            value = total * np.float32(-0.5)
        else:
            value = total / np.float32(-parts)
        if value < _LO:
            value = _LO
        elif value > _HI:
            value = _HI
        for i in dsts:
            values[i] = float(value)
    return values


class Scamp5(ObservableMixin, ControllerMixin, CellLoadMixin, ProgramAPI):
    """A simulated SCAMP-5 pixel processor array.

    Parameters
    ----------
    rows, cols : int
        Array size (256 x 256 on the chip; small arrays make readable tests).
    noise : str or NoiseParams
        ``"ideal"`` (exact, saturation only), ``"low"``, ``"typical"``, ``"high"`` or a
        :class:`~ppaloc.sim.noise.NoiseParams`.
    seed : int
        Seed of every random draw (noise, digital decay); same seed, same bytes.
    clock_hz : float
        ICW clock of the timing model.
    engine : str or None
        ``"reference"``, ``"numpy"`` or ``"compiled"`` (needs numba): what runs the ICWs
        (:mod:`ppaloc.sim.engines`; every engine gives the same bytes). None: the
        ``PPALOC_ENGINE`` environment variable, else the fastest installed.
    observers : sequence of SimObserver
        Attached from the start, as by :meth:`observe` one by one: each is called as
        ``observer(sim, event)`` after every kernel run, controller call, ``set_image``
        and ``write`` (:mod:`ppaloc.sim.observe`). Detach one with :meth:`unobserve`.

    Examples
    --------
    >>> import numpy as np
    >>> from ppaloc.sim import Scamp5, A, B, east
    >>> sim = Scamp5(rows=2, cols=3)
    >>> sim.write(A, np.array([[1, 2, 3], [4, 5, 6]]))
    >>> with sim.kernel() as k:
    ...     k.movx(B, A, east)
    >>> sim.read(B)
    array([[2., 3., 0.],
           [5., 6., 0.]], dtype=float32)
    """

    def __init__(
        self,
        rows: int = 256,
        cols: int = 256,
        noise: str | NoiseParams = "ideal",
        seed: int = 0,
        clock_hz: float = 10e6,
        engine: str | None = None,
        observers: Iterable[SimObserver] = (),
    ) -> None:
        for name, v in (("rows", rows), ("cols", cols)):
            if not isinstance(v, int | np.integer) or isinstance(v, bool) or v < 1:
                raise SimulatorError(f"{name}={v!r} is invalid: use a positive integer")
            if v > MAX_SIDE:
                raise SimulatorError(
                    f"{name}={v!r} is too large: use at most {MAX_SIDE} (the device's array is "
                    "256 x 256; every element holds about 150 bytes of planes)"
                )
        if not isinstance(seed, int | np.integer) or isinstance(seed, bool) or seed < 0:
            raise SimulatorError(f"seed={seed!r} is invalid: use an integer >= 0")
        self._init_observers(observers)  # checked with the other arguments
        self.rows, self.cols = int(rows), int(cols)
        shape = (self.rows, self.cols)
        self.rng = np.random.default_rng(seed)
        self.noise = NoiseModel(noise, shape, _N_ANALOG, seed)
        self.timing = TimingModel(clock_hz=clock_hz)
        self._analog_planes = np.zeros((_N_ANALOG, *shape), dtype=np.float32)
        # constant fills not yet written (plane index -> level; _fill_later)
        self._fills: dict[int, float] = {}
        self._d = np.zeros((_N_DIGITAL, *shape), dtype=bool)
        self._d[_FLAG_I] = True
        self._t = [np.zeros(shape, dtype=np.float32) for _ in range(3)]
        self._tb = [np.zeros(shape, dtype=bool) for _ in range(2)]
        self._latch = np.zeros(shape, dtype=bool)
        self._mask = np.zeros(shape, dtype=np.uint32)
        self._flag_masked: bool | None = False  # None: unknown, recompute
        self._flag_partial = False  # FLAG seen partial since the last kernel or FLAG access
        self._in_level: float | None = 0.0  # the level IN holds everywhere (None: unknown)
        # the level IN's plane itself holds everywhere (its fill written; None: unknown)
        self._in_plane: float | None = 0.0
        self._image: np.ndarray | None = None
        self._ops_cache: dict[tuple, Op] = {}
        self._last_us = 0.0
        self._droop_us = np.zeros(len(_DECAYING))  # droop not yet applied, per plane (us)
        self._droop_which = np.zeros(len(_DECAYING), dtype=np.int64)  # _flush_droop's
        self._droop_steps = np.zeros(len(_DECAYING), dtype=np.float32)
        self._dtouch_us = np.zeros(_N_DIGITAL)
        self._dtouch_low = 0.0  # at most the oldest of R0-R12's last writes (us)
        params = self.noise.params  # digital writes are timed only if registers decay
        self._retention = bool(params and params.digital_retention_ms is not None)
        if not self.noise.ideal:
            self._analog_planes[PIX.index] = self.noise.pixel_offset
        self.engine = make_engine(engine, self)

    # ------------------------------------------------------------------ inspection
    def __repr__(self) -> str:
        mode = "ideal" if self.noise.ideal else "noisy"
        return f"Scamp5(rows={self.rows}, cols={self.cols}, {mode}, {self.engine.name})"

    @property
    def _a(self) -> np.ndarray:
        """Every analogue plane, (planes, rows, cols) float32, with every fill written."""
        if self._fills:
            self._write_fills()
        self._in_plane = None  # the caller may change IN through the planes
        return self._analog_planes

    def _aplane(self, reg: Register) -> np.ndarray:
        """The live float32 plane of analogue ``reg`` (a view; writes bypass FLAG)."""
        if not isinstance(reg, Register) or reg.kind != "analog" or reg.role == "neighbour":
            raise SimulatorError(
                f"{reg!r} is not an analogue register plane: use A..F, NEWS, PIX or IN"
            )
        i = reg.index
        if i in self._fills:
            self._write_fill(i, self._fills.pop(i))
        if i < len(_DECAYING) and self._droop_us[i]:
            self._flush_droop((i,))
        elif i == _IN_I:
            self._in_level = self._in_plane = None  # the caller may change IN through the view
        return self._analog_planes[i]

    def _aplane_and_droop(self, reg: Register) -> tuple[np.ndarray, np.float32 | None]:
        """:meth:`_aplane` for a host call that rewrites the whole plane in one pass (a
        shift, a masked DAC write): the plane with its deferred fill written, and the droop
        pending on it taken (cleared) instead of applied, for the call to apply to each old
        value it reads or keeps (None: nothing droops). The bytes are those of the droop
        pass :meth:`_aplane` makes, without the pass."""
        if not isinstance(reg, Register) or reg.kind != "analog" or reg.role == "neighbour":
            return self._aplane(reg), None  # the same error as _aplane
        i = reg.index
        if i >= len(_DECAYING):
            return self._aplane(reg), None
        if i in self._fills:
            self._write_fill(i, self._fills.pop(i))
        return self._analog_planes[i], self._take_droop(reg)

    def _overwrite(self, reg: Register) -> np.ndarray:
        """The live plane of analogue ``reg`` for a host write of every element: its
        deferred fill and its pending droop are dropped, not applied (the old values are
        never seen again; the new ones start their own time). ``reg`` is checked by the
        caller (one of A-F, NEWS or IN)."""
        i = reg.index
        self._fills.pop(i, None)
        if i < len(_DECAYING):
            self._droop_us[i] = 0.0
        elif i == _IN_I:
            self._in_level = self._in_plane = None
        return self._analog_planes[i]

    def _set_in(self, value: float) -> None:
        """Drive ``IN`` with ``value`` everywhere (no pass when it already holds it; the
        pass itself deferred, :meth:`_fill_later`)."""
        if self._in_level != value:
            self._fill_later(_IN_I, value)
            self._in_level = value
        if self._call_frame is not None:
            self._note_write(IN)

    def _fill_later(self, i: int, value: float) -> None:
        """Analogue plane ``i`` now holds ``float32(value)`` everywhere: the pass that
        writes it is deferred until the plane is next used (:meth:`_aplane`, :attr:`_a`,
        a kernel that reads it), and dropped when the value is never read: another fill
        comes first, or the next kernel to use the plane overwrites it whole before
        reading it (:meth:`_settle_fills`). The DAC loads of a frame leave ``IN`` and a
        ``temp`` (NEWS) so about forty times a frame. A plane that droops (noisy, A-F and
        NEWS) starts its droop time afresh, as a write does (its pending droop is
        dropped): its fill is written before any droop is applied to it (the pass of a
        kernel that reads it or of a host access, :meth:`_aplane`), so the bytes are those
        of the fill written at once and drooped for the time since."""
        self._fills[i] = value
        if i < len(_DECAYING):
            self._droop_us[i] = 0.0

    def _write_fill(self, i: int, value: float) -> None:
        """Write the deferred fill of analogue plane ``i``: one pass, none for ``IN`` when
        its plane already holds ``value`` (IN is written by fills and host views only,
        never by an ICW: a DAC level set, replaced before any kernel read it, and set
        again leaves the plane as it was)."""
        if i == _IN_I:
            if same_level(value, self._in_plane):
                return
            self._in_plane = value
        hostloops.fill(self._analog_planes[i], value)

    def _write_fills(self) -> None:
        """Write every deferred fill (:meth:`_fill_later`)."""
        fills = self._fills
        while fills:
            self._write_fill(*fills.popitem())

    def _settle_fills(self, used: frozenset[int], fresh: frozenset[int]) -> None:
        """Before a kernel that names the analogue planes ``used``: write their deferred
        fills, except those of ``fresh`` planes (:func:`overwritten_first`) when FLAG is
        known to be set everywhere (the kernel then overwrites them whole before reading:
        the fill is never seen); fills of planes the kernel does not name stay deferred."""
        fills = self._fills
        if used.isdisjoint(fills):
            return
        whole = self._flag_masked is False
        for i in [i for i in fills if i in used]:
            value = fills.pop(i)
            if not (whole and i in fresh):
                self._write_fill(i, value)

    def _take_droop(self, reg: Register) -> np.float32 | None:
        """The droop step pending on analogue ``reg``, cleared without a pass: the caller
        applies it to the elements it does not overwrite (None: nothing droops)."""
        i = reg.index
        if i >= len(_DECAYING) or not self._droop_us[i]:
            return None
        us = self._droop_us[i]
        self._droop_us[i] = 0.0
        return self.noise.droop_step(us)

    def _flag_state(self) -> tuple[np.ndarray, bool]:
        """FLAG's plane (to read) and whether it is 1 everywhere: the tracked state when it
        is known, else one pass. A pass that finds FLAG set everywhere is kept as the
        tracked state (no mask needed); one that finds it partial is kept in
        ``_flag_partial`` (the numpy engine's mask is not built) until the next kernel run
        or FLAG access, the only ways FLAG changes: the host calls of a frame between two
        kernels look once, not once each."""
        flag = self._d[_FLAG_I]
        masked = self._flag_masked
        if masked is not None:
            return flag, not masked
        if self._flag_partial:
            return flag, False
        if hostloops.all_set(flag):
            self._flag_masked = False
            return flag, True
        self._flag_partial = True
        return flag, False

    def _scratch(self) -> np.ndarray:
        """A float32 scratch plane for a host call's values (what :meth:`_write_analog`
        copies from; overwritten by the next host write)."""
        return self._t[2]

    def _dplane(self, reg: Register) -> np.ndarray:
        """The live bool plane of digital ``reg`` (incl. FLAG and SELECT; a view)."""
        if not isinstance(reg, Register) or reg.kind != "digital":
            raise SimulatorError(f"{reg!r} is not a digital register: use R0..R12, FLAG or SELECT")
        if reg.index == _FLAG_I:
            self._flag_masked = None  # the caller may change FLAG through the view
            self._flag_partial = False
        return self._d[reg.index]

    def _as_plane(self, reg: Register, values: object, dtype: type) -> np.ndarray:
        try:
            arr = np.asarray(values)
        except ValueError:  # ragged nested sequences
            arr = None
        if arr is None or arr.dtype.kind not in "biuf":
            shown = repr(values) if len(repr(values)) <= 60 else f"a {type(values).__name__}"
            raise SimulatorError(
                f"cannot write {shown} into {reg.name}: use numbers, a scalar or an array "
                f"of shape ({self.rows}, {self.cols})"
            )
        if arr.ndim != 0 and arr.shape != (self.rows, self.cols):
            raise SimulatorError(
                f"cannot write an array of shape {arr.shape} into {reg.name}: "
                f"use shape ({self.rows}, {self.cols}) or a scalar"
            )
        if dtype is bool and arr.dtype != bool:
            if not np.isin(arr, (0, 1)).all():
                raise SimulatorError(
                    f"cannot write non-binary values into digital {reg.name}: use 0/1 or bools"
                )
        return np.broadcast_to(arr, (self.rows, self.cols))

    def _write_analog(self, reg: Register, values: object, where: np.ndarray | None = None) -> None:
        """Set analogue ``reg`` everywhere, or where ``where`` is set (clipped; with write
        noise when not ideal: the draw is taken for the whole plane either way)."""
        if not self.noise.ideal:
            self._elapse()  # older values droop first; the new one starts fresh
        if self._call_frame is not None:
            self._note_write(reg)
        whole = where is None and type(values) is float  # a level over the old values
        plane = self._overwrite(reg) if whole else self._aplane(reg)
        t = self._t[2]
        if values is not t:  # a host call may form its values in the scratch plane
            if type(values) is float or (
                isinstance(values, np.ndarray)
                and values.shape == t.shape
                and values.dtype.kind == "f"
            ):
                np.copyto(t, values, casting="unsafe")
            else:
                np.copyto(t, self._as_plane(reg, values, float), casting="unsafe")
        if not self.noise.ideal:  # offset, noise, clip and FLAG in one pass
            offset, window = self.noise.terms(reg.index, divided=False)
            flag = self._d[_FLAG_I] if where is None else where
            hostloops.noisy_write(plane, t, offset, window, flag, where is None)
        elif where is None:
            _clip(t, _LO, _HI, out=plane)
        else:
            _clip(t, _LO, _HI, out=t)
            hostloops.select(plane, t, where)

    def _write_digital(self, reg: Register, values: object) -> None:
        """Set digital ``reg`` everywhere (no R0 rule: this is the host's pattern load)."""
        plane = self._dplane(reg)
        if not self.noise.ideal:
            self._elapse()
        if not (
            isinstance(values, np.ndarray) and values.dtype == bool and values.shape == plane.shape
        ):
            values = self._as_plane(reg, values, bool)
        np.copyto(plane, values, casting="unsafe")
        self._touch_digital(reg.index)
        if self._call_frame is not None:
            self._note_write(reg)

    def _write_digital_grid(self, reg: Register, rows: np.ndarray, cols: np.ndarray) -> None:
        """Set digital ``reg`` to an address pattern, ``rows[r] and cols[c]`` (bool
        vectors): :meth:`_write_digital` of the pattern's plane, written from the vectors
        (the pattern loads of a frame would each read a cached 64 KB plane)."""
        plane = self._dplane(reg)
        if not self.noise.ideal:
            self._elapse()
        hostloops.grid(plane, rows, cols)
        self._touch_digital(reg.index)
        if self._call_frame is not None:
            self._note_write(reg)

    def read(self, reg: Register) -> np.ndarray:
        """A copy of ``reg``'s plane: float32 in [-128, 127] (analogue) or bool (digital).

        An inspection tool: untimed, no readout noise. Refused inside an open ``with
        sim.kernel()`` block (the kernel runs when the block ends: the plane would be the
        one from before it).
        """
        from ppaloc.sim.kernel import recording

        if recording(self):
            name = reg.name if isinstance(reg, Register) else repr(reg)
            raise KernelError(
                f"sim.read({name}) inside an open `with sim.kernel()` block: the kernel has "
                "not run yet (it runs when the block ends); read after the block"
            )
        if isinstance(reg, Register) and reg.kind == "digital":
            return self._d[reg.index].copy()
        return self._aplane(reg) + np.float32(0.0)  # a copy; -0.0 shown as 0.0

    def write(self, reg: Register, values: object) -> None:
        """Set ``reg``'s plane exactly (analogue values clipped to [-128, 127]).

        An inspection tool: untimed, noiseless, ignores FLAG and R0. Observers receive a
        :class:`~ppaloc.sim.observe.PlaneWrite` (a program has no device call for it).
        """
        if isinstance(reg, Register) and reg.kind == "digital":
            self._write_digital(reg, values)
        else:
            arr = self._as_plane(reg, values, float)
            if not np.isfinite(arr).all():
                raise SimulatorError(f"cannot write NaN or infinity into {reg.name}")
            if not self.noise.ideal:
                self._elapse()  # before the plane is taken: the new value starts fresh
            np.copyto(self._aplane(reg), np.clip(arr, -128, 127), casting="unsafe")
        if self._observers:
            values = self.read(reg)
            values.flags.writeable = False
            self._notify(PlaneWrite(reg, values))

    def set_image(self, image: np.ndarray) -> None:
        """Set the scene ``PIX`` sees until the next ``rpix``: a uint8 (rows, cols) image.

        ``PIX`` then reads ``p/2 - 64`` (half range) for a pixel ``p``, so in ideal mode
        ``get_image(y, h)`` yields the full-range ``y = p - 128`` (and ``h = -(p/2 - 64)``)
        and ``get_image(y)`` the half-range ``y = p/2 - 64``, as the SCAMP-5d header states.
        Observers receive an :class:`~ppaloc.sim.observe.ImageSet` (a frame boundary).
        """
        img = np.asarray(image)
        if img.dtype != np.uint8 or img.shape != (self.rows, self.cols):
            raise SimulatorError(
                f"set_image needs a uint8 array of shape ({self.rows}, {self.cols}), got "
                f"{img.dtype} {img.shape}: convert frames with ppaloc.datasets.to_sensor"
            )
        self._image = img.copy()
        if not self.noise.ideal:
            self._elapse()
        offset = None if self.noise.ideal else self.noise.pixel_offset
        hostloops.load_image(self._analog_planes[PIX.index], self._image, offset)
        # observers receive this copy, read-only (made so after the compiled loop, which
        # is specialised for writable arrays)
        self._image.flags.writeable = False
        if self._observers:
            self._notify(ImageSet(self._image))

    # --------------------------------------------------------------------- kernels
    def kernel(self) -> Kernel:
        """A recorder: ``with sim.kernel() as k: k.mov(A, B)`` records, then runs once.

        Returns
        -------
        Kernel
            Replay it with ``k.run()`` or ``sim.run(k)``.
        """
        from ppaloc.sim.kernel import Kernel

        return Kernel(self)

    def run(self, kernel: Kernel) -> None:
        """Run a recorded kernel of this simulator (same as ``kernel.run()``)."""
        from ppaloc.sim.kernel import Kernel

        if not isinstance(kernel, Kernel):
            raise KernelError(
                f"sim.run needs a Kernel recorded with `with sim.kernel() as k:`, "
                f"got {type(kernel).__name__}"
            )
        if kernel.sim is not self:
            raise KernelError("this kernel was recorded on another Scamp5; record it on this one")
        kernel.run()

    def _emit(self, instructions: tuple[Instruction, ...]) -> None:
        """Instructions issued directly on the simulator run at once as a kernel of their own."""
        run = self._compile_kernel(instructions)
        self._run_ops(run, count_clocks(instructions), written_digital(instructions))
        if self._observers:
            self._observed_icws(None, instructions)

    def _compile_kernel(self, instructions: tuple[Instruction, ...]) -> Op:
        """A runner performing ``instructions`` in order, built by this simulator's engine.

        The runner first writes the deferred fills of the planes the ICWs name (or drops
        them, :meth:`_settle_fills`), and with droop applies the droop pending on those
        planes (the others keep accumulating it until something touches them).
        """
        instructions = tuple(instructions)
        run = self._with_droop(self.engine.compile(instructions), instructions)
        return self._with_folding(run, instructions)

    def _with_folding(self, run: Op, instructions: tuple[Instruction, ...]) -> Op:
        """``run`` after the deferred fills of the planes the ICWs name are settled
        (:meth:`_with_fills`), or in ideal mode on an engine that folds
        (``engine.folds``) a runner that computes the kernel's leading transfers on
        constants once, not once per element, when they read only planes with a deferred
        fill (:meth:`_fill_later`) and FLAG is known to be set everywhere as the kernel
        starts.

        Such a transfer (``bus``, ``bus2``, ``bus3``, ``busn`` of local registers, one
        source or more: :func:`constant_prefix`) writes one constant into every element
        of each destination, so its destinations become deferred fills of that value
        (:func:`fold_transfers`: the engines' float32 operations in their order) and the
        rest of the kernel runs as a kernel of its own (compiled on first use, per
        length of the folded prefix). The bytes are those of the whole kernel: the fills
        are written when the planes are next used, or dropped.
        """
        prefix = ()
        if self.noise.ideal and getattr(self.engine, "folds", False):
            prefix = constant_prefix(instructions)
        if not prefix:
            return self._with_fills(run, instructions)
        steps = tuple(
            (
                tuple(r.index for r in ins.srcs),
                len(ins.dsts) if ins.op != "bus" else 1,
                tuple(r.index for r in ins.dsts),
            )
            for ins in prefix
        )
        # per length n of a folded prefix (longest first): the planes it reads before
        # writing them (each must hold a fill) and the planes it writes
        cuts: list[tuple[int, frozenset[int], frozenset[int], tuple[int, ...]]] = []
        needed: set[int] = set()
        written: set[int] = set()
        for n, (srcs, _, dsts) in enumerate(steps, 1):
            needed |= set(srcs) - written
            written |= set(dsts)
            cuts.append((n, frozenset(needed), frozenset(written), tuple(sorted(needed))))
        cuts.reverse()
        first = cuts[-1][1]  # what the first transfer reads: no fold without it
        rests: dict[int, Op | None] = {}
        fills = self._fills
        used, fresh = _named_planes(instructions)
        settle = self._settle_fills

        def rest_of(n: int) -> Op | None:
            rest_ins = instructions[n:]
            rest = self._with_fills(self.engine.compile(rest_ins), rest_ins) if rest_ins else None
            rests[n] = rest
            return rest

        # (prefix length, the levels it reads) -> the levels it leaves, per plane it
        # writes: a frame folds the same levels again and again (the fraction tests' DAC
        # loads). Not kept for a zero read (0.0 and -0.0 are equal keys, not the same bytes)
        folded: dict[tuple, tuple[tuple[int, float], ...]] = {}

        def fold(n: int, need: tuple[int, ...], wrote: frozenset[int]) -> None:
            levels = tuple([fills[i] for i in need])
            key = (n, levels)
            out = folded.get(key)
            if out is None:
                values = fold_transfers(steps[:n], dict(zip(need, levels, strict=True)))
                out = tuple([(i, values[i]) for i in wrote])
                if 0.0 not in levels:
                    if len(folded) >= 256:
                        folded.clear()
                    folded[key] = out
            for i, value in out:
                fills[i] = value

        def run_folding() -> None:
            if fills:
                if self._flag_masked is False and first.issubset(fills):
                    for n, need, wrote, order in cuts:
                        if need.issubset(fills):
                            fold(n, order, wrote)
                            rest = rests[n] if n in rests else rest_of(n)
                            if rest is not None:
                                rest()
                            return
                settle(used, fresh)  # what _with_fills's runner does, in this call
            run()

        return run_folding

    def _with_fills(self, run: Op, instructions: tuple[Instruction, ...]) -> Op:
        """``run``, first settling the deferred fills of the planes the ICWs name
        (:meth:`_settle_fills`)."""
        used, fresh = _named_planes(instructions)
        fills = self._fills
        settle = self._settle_fills

        def run_filled() -> None:
            if fills:
                settle(used, fresh)
            run()

        return run_filled

    def _with_droop(self, run: Op, instructions: tuple[Instruction, ...]) -> Op:
        """``run``, first applying (or dropping) the droop pending on the planes the ICWs
        name, when planes droop; ``run`` itself when it applies that droop as it runs (a
        runner marked ``applies_droop``: the compiled engine's, in its first call)."""
        aging = self._droop_applier(instructions)
        if aging is None or getattr(run, "applies_droop", False):
            return run

        def run_aged() -> None:
            aging()
            run()

        return run_aged

    def _droop_applier(self, instructions: tuple[Instruction, ...]) -> Op | None:
        """What applies (or drops) the droop pending on the planes the ICWs name before
        they run, in one call (None when planes do not droop): each touched plane's step
        applied in a pass and its pending time cleared, except a plane the kernel
        overwrites whole before reading it when FLAG is known to be set everywhere as it
        starts (:func:`overwritten_first`), whose pending time is only cleared."""
        if self.noise.ideal or not self.noise.params.decay_per_ms:
            return None
        touched, fresh = droop_planes(instructions)
        pending = self._droop_us
        planes, decay = self._analog_planes, self.noise.params.decay_per_ms
        every = np.array(touched, dtype=np.int64)
        rest = np.array([i for i in touched if i not in fresh], dtype=np.int64)
        fresh_idx = np.array(sorted(fresh), dtype=np.int64)
        none = fresh_idx[:0]
        droop_pending = hostloops.droop_pending

        def age() -> None:
            droop_pending(planes, pending, every, decay, none)

        if not fresh:
            return age

        def age_fresh() -> None:
            # planes the kernel overwrites whole before reading (FLAG set everywhere when
            # it starts) need not droop first: their old values are never seen again
            if self._flag_masked is False:
                droop_pending(planes, pending, rest, decay, fresh_idx)
            else:
                droop_pending(planes, pending, every, decay, none)

        return age_fresh

    def _run_ops(
        self, run: Op, counts: dict[str, int] | tuple[tuple[str, int], ...], dwritten: np.ndarray
    ) -> None:
        if not self.noise.ideal:
            self._elapse()
        self._flag_partial = False  # the kernel may change FLAG
        run()
        self.timing.charge_kernel(counts)
        if self._retention and dwritten.size:
            self._touch_digital(dwritten)

    def _kernel_runner(
        self, run: Op, counts: tuple[tuple[str, int], ...], dwritten: np.ndarray
    ) -> Op:
        """One call that does what :meth:`_run_ops` does for a recorded kernel (``run``,
        its ``counts`` and the digital planes it writes), its choices made once: the noise
        mode, whether digital writes are timed, and the kernel's cost
        (:meth:`TimingModel.kernel_charger`). A kernel runs through it while nothing
        observes the simulator (:meth:`Kernel.run`); the same planes, draws, clock and
        charges as :meth:`_run_ops`."""
        timing = self.timing
        charge = timing.kernel_charger(counts)
        elapse = None if self.noise.ideal else self._elapse
        touched = dwritten if self._retention and dwritten.size else None

        def run_kernel() -> None:
            if elapse is not None:
                elapse()
            self._flag_partial = False  # the kernel may change FLAG
            run()
            if self.timing is timing:
                charge()
            else:  # a timing model put in place since
                self.timing.charge_kernel(counts)
            if touched is not None:
                self._touch_digital(touched)

        return run_kernel

    def _touch_digital(self, planes: np.ndarray | int) -> None:
        """Digital ``planes`` (indices) written now: their retention starts again (nothing
        to note when the noise model has no retention, as in ideal mode)."""
        if not self._retention:
            return
        now = self.timing.now_us
        self._dtouch_us[planes] = now
        if now < self._dtouch_low:  # the clock was reset
            self._dtouch_low = now

    def _elapse(self) -> None:
        """Account analogue droop (applied when a plane is next touched: a kernel reading or
        writing it, or any host access) and apply digital decay, for the modelled time
        since last time."""
        now = self.timing.now_us
        elapsed = now - self._last_us
        self._last_us = now
        if elapsed <= 0:
            return
        params = self.noise.params
        if params and params.decay_per_ms:  # applied at next touch
            self._droop_us += elapsed
        retention = params.digital_retention_ms if params else None
        if retention is None or not params.digital_flip_per_ms:
            return
        if now - self._dtouch_low <= retention * 1e3:  # no register can be past retention
            return
        touched = self._dtouch_us[: R12.index + 1]
        self._dtouch_low = float(touched.min())
        ages = now - touched
        for i in np.flatnonzero(ages > retention * 1e3):  # only registers past retention
            self.noise.digital_decay(self._d[i], ages[i], elapsed)

    def _flush_droop(self, planes: tuple[int, ...]) -> None:
        """Apply the droop pending on ``planes`` (indices of A-F, NEWS), all at once.

        Droop moves a value towards 0 by a step proportional to time and never past 0, so
        one step for the whole pending time is the same as the steps one by one.
        """
        pending = self._droop_us
        if len(planes) == len(_DECAYING) and np.all(pending == pending[0]):
            self.noise.droop(self._analog_planes[_DECAY_PLANES], pending[0])  # one call for all
            pending[:] = 0.0
            return
        which, steps = self._droop_which, self._droop_steps
        n = 0
        for i in planes:  # the planes' steps, then one call for them all
            us = pending[i]
            if us:
                step = self.noise.droop_step(us)
                pending[i] = 0.0
                if step is not None:
                    which[n], steps[n] = i, step
                    n += 1
        if n:
            hostloops.droop_each(self._analog_planes, which, steps, n)

    # ------------------------------------------------------------- FLAG machinery
    def _flag_mask(self) -> np.ndarray | None:
        """None where FLAG is 1 everywhere, else a uint32 mask (all ones where flagged)."""
        masked = self._flag_masked
        if masked is None:
            flag = self._d[_FLAG_I]
            masked = not flag.all()
            if masked:
                np.copyto(self._mask, flag, casting="unsafe")
                np.negative(self._mask, out=self._mask)
            self._flag_masked = masked
        return self._mask if masked else None

    @staticmethod
    def _blend(dst: np.ndarray, val: np.ndarray, mask: np.ndarray) -> None:
        """``dst := val`` where ``mask`` bits are set, exactly (bitwise; destroys ``val``)."""
        du = dst.view(np.uint32)
        vu = val.view(np.uint32)
        np.bitwise_xor(vu, du, out=vu)
        np.bitwise_and(vu, mask, out=vu)
        np.bitwise_xor(du, vu, out=du)

    # ---------------------------------------------------------------- compilation
    def _compile(self, ins: Instruction) -> Op:
        """A closure performing ``ins`` on this simulator's planes (built by its op table row).

        Closures depend only on the instruction and this simulator's fixed planes, so they
        are cached: repeated direct calls and re-recorded kernels skip the build.
        """
        key = (ins.op, ins.dsts, ins.srcs)
        op = self._ops_cache.get(key)
        if op is None:
            if len(self._ops_cache) >= 4096:
                self._ops_cache.clear()
            op = self._ops_cache[key] = ins.spec.build(self, ins)
        return op

    # Building blocks the op table (isa.OPS) composes instructions from.
    def _op_nop(self, ins: Instruction) -> Op:
        return _noop

    def _op_rpix(self, ins: Instruction) -> Op:
        pix = self._analog_planes[PIX.index]
        level = self.noise.pixel_offset

        def rpix() -> None:
            np.copyto(pix, level)

        return rpix

    def _sum_closure(self, srcs: Iterable[Register]) -> Callable[[np.ndarray], None]:
        """A function writing the sum of analogue ``srcs`` (with neighbour terms) into out."""
        a = self._analog_planes
        local = [a[s.index] for s in srcs if s.role != "neighbour"]
        nbr = [_slices(*s.direction.offset) for s in srcs if s.role == "neighbour"]
        news = a[_NEWS_I]
        gated = self._t[1]
        gated_u = gated.view(np.uint32)
        news_u = news.view(np.uint32)
        mask_of = self._flag_mask

        def total(out: np.ndarray) -> None:
            if not local:
                out.fill(0)
            elif len(local) == 1:
                np.copyto(out, local[0])
            else:
                np.add(local[0], local[1], out=out)
                for x in local[2:]:
                    np.add(out, x, out=out)
            if nbr:
                mask = mask_of()
                src = news
                if mask is not None:  # an unflagged neighbour's NEWS is not connected
                    np.bitwise_and(news_u, mask, out=gated_u)
                    src = gated
                for o, i in nbr:
                    np.add(out[o], src[i], out=out[o])

        return total

    def _op_transfer(self, ins: Instruction, parts: int) -> Op:
        """``dst := -(sum of sources) / parts`` for every destination, FLAG-masked.

        One of three builders, by precondition (each is cross-checked against the
        reference engine by tests/sim/test_engines.py, which draws ICWs of every kind):
        :meth:`_transfer_direct` (ideal, one destination that is a plane of this element),
        :meth:`_transfer_ideal` (ideal, several destinations or a pushed one) and
        :meth:`_transfer_noisy` (any ICW under noise).
        """
        value = self._bus_value(ins, parts)
        dsts = self._transfer_destinations(ins)
        if not self.noise.ideal:
            return self._transfer_noisy(value, dsts, divided=parts > 1)
        # Ideal values that cannot leave [-128, 127] need no clip: no source gives 0, and
        # bus3 divides one source in [-128, 127] by 3.
        clip = _clip if (ins.srcs and parts != 3) else _no_clip
        if len(dsts) == 1 and dsts[0][2] is None:
            return self._transfer_direct(value, dsts[0][0], clip)
        return self._transfer_ideal(value, dsts, clip)

    def _transfer_destinations(
        self, ins: Instruction
    ) -> list[tuple[np.ndarray, int, tuple | None]]:
        """(plane, plane index, shift) per destination; shift: (out, in, edges) of a push."""
        dsts = []
        for d in ins.dsts:
            if d.role == "neighbour":
                # NEWS[r] := value of the element r - offset(d) (the sender)
                dr, dc = d.direction.offset
                o, i = _slices(-dr, -dc)
                edges = _edge_slices(-dr, -dc, self.rows, self.cols)
                dsts.append((self._analog_planes[_NEWS_I], d.index, (o, i, edges)))
            else:
                dsts.append((self._analog_planes[d.index], d.index, None))
        return dsts

    def _bus_value(self, ins: Instruction, parts: int) -> Callable[[np.ndarray], None]:
        """``value(out)``: out := -(sum of sources) / parts (times the ICW's gain when noisy)."""
        a = self._analog_planes
        total = self._sum_closure(ins.srcs)
        noise = self.noise
        ideal = noise.ideal
        has_nbr_src = any(s.role == "neighbour" for s in ins.srcs)
        local = [s for s in ins.srcs if s.role != "neighbour"]
        lone = a[local[0].index] if len(local) == 1 and not has_nbr_src else None
        m_half = np.float32(-0.5)
        d_parts = np.float32(-parts)

        def value(out: np.ndarray) -> None:
            src = out
            if lone is not None:
                src = lone  # one local source: no copy, scale straight from it
            else:
                total(out)
            if not ideal:
                np.multiply(src, np.float32(noise.negated_gain() / parts), out=out)
            elif parts == 1:
                np.negative(src, out=out)
            elif parts == 2:
                np.multiply(src, m_half, out=out)  # exact: a power of two
            else:
                np.divide(src, d_parts, out=out)

        return value

    def _transfer_direct(self, value, plane: np.ndarray, clip) -> Op:
        """Precondition: ideal, one destination, a plane of the element itself (not pushed).

        The value goes straight into the plane when FLAG is 1 everywhere, else through a
        scratch plane and the exact bitwise blend. Safe in place: an ICW never reads the
        register it writes (``isa.make``), so the destination is not a source.
        """
        t0 = self._t[0]
        mask_of = self._flag_mask
        blend = self._blend

        def run_direct() -> None:
            mask = mask_of()
            if mask is None:  # straight into the destination
                value(plane)
                clip(plane, _LO, _HI, out=plane)
            else:
                value(t0)
                clip(t0, _LO, _HI, out=t0)
                blend(plane, t0, mask)

        return run_direct

    def _transfer_ideal(self, value, dsts: list, clip) -> Op:
        """Precondition: ideal; several destinations (``bus2``, ``bus3``) or a pushed one.

        One saturated value for every destination; a pushed destination receives its
        sender's value (0 from an unflagged sender and beyond the edge).
        """
        t0, t1, t2 = self._t
        t0u, t1u = t0.view(np.uint32), t1.view(np.uint32)
        mask_of = self._flag_mask
        blend = self._blend

        def run_ideal() -> None:
            mask = mask_of()
            value(t0)
            clip(t0, _LO, _HI, out=t0)  # one value for every destination
            for plane, _, shift in dsts:
                if shift is None:
                    if mask is None:
                        np.copyto(plane, t0)
                    else:
                        np.copyto(t1, t0)
                        blend(plane, t1, mask)
                    continue
                o, i, edges = shift
                if mask is None:
                    np.copyto(plane[o], t0[i])
                    for e in edges:
                        plane[e] = 0
                else:
                    np.bitwise_and(t0u, mask, out=t1u)  # an unflagged sender drives nothing
                    np.copyto(t2[o], t1[i])
                    for e in edges:
                        t2[e] = 0
                    blend(plane, t2, mask)

        return run_ideal

    def _transfer_noisy(self, value, dsts: list, divided: bool) -> Op:
        """Precondition: noisy. The value carries the ICW's transfer gain; each destination
        adds its cell's offset and one temporal noise draw (in destination order), then
        saturates and is FLAG-masked; a pushed one first receives its sender's value."""
        t0, t1, t2 = self._t
        noise = self.noise
        mask_of = self._flag_mask
        blend = self._blend
        single = len(dsts) == 1

        def run_noisy() -> None:
            mask = mask_of()
            value(t0)
            for plane, index, shift in dsts:
                val = t0 if single else t1
                if not single:
                    np.copyto(t1, t0)
                if shift is not None:
                    o, i, edges = shift
                    if mask is not None:  # an unflagged sender drives nothing
                        vu = val.view(np.uint32)
                        np.bitwise_and(vu, mask, out=vu)
                    np.copyto(t2[o], val[i])
                    for e in edges:
                        t2[e] = 0
                    val = t2
                noise.perturb(val, index, divided)  # noise of the written (receiving) cell
                if mask is None:
                    _clip(val, _LO, _HI, out=plane)  # straight into the destination
                else:
                    _clip(val, _LO, _HI, out=val)
                    blend(plane, val, mask)

        return run_noisy

    def _op_where(self, ins: Instruction) -> Op:
        total = self._sum_closure(ins.srcs)
        t0 = self._t[0]
        flag = self._d[_FLAG_I]
        noise = self.noise
        zero = np.float32(0)

        def where() -> None:
            total(t0)
            if not noise.ideal:  # the comparator sees a noisy sum
                np.add(t0, noise.window(), out=t0)
            np.greater(t0, zero, out=flag)
            self._flag_masked = None

        return where

    def _op_flag_all(self, ins: Instruction) -> Op:
        flag = self._d[_FLAG_I]

        def all_() -> None:
            flag.fill(True)
            self._flag_masked = False

        return all_

    # -------------------------------------------------------------- digital ops
    def _digital_store(self, dst: Register, compute: Callable[[np.ndarray], None]) -> Op:
        """Wrap ``compute(out)`` so that R12 is written only where R0 = 1."""
        plane = self._d[dst.index]
        if dst.index != R12.index:
            return lambda: compute(plane)
        tb = self._tb[0]
        r0 = self._d[R0.index]

        def masked() -> None:
            compute(tb)
            np.bitwise_xor(tb, plane, out=tb)
            np.bitwise_and(tb, r0, out=tb)
            np.bitwise_xor(plane, tb, out=plane)

        return masked

    def _dsrc(self, ins: Instruction) -> list[np.ndarray]:
        return [self._d[s.index] for s in ins.srcs]

    def _op_fill(self, ins: Instruction, value: bool) -> Op:
        planes = [self._d[d.index] for d in ins.dsts if d.index != R12.index]
        r12 = any(d.index == R12.index for d in ins.dsts)
        p12 = self._d[R12.index]
        r0 = self._d[R0.index]

        def set_clear() -> None:
            if r12:  # first: R0 as it was before this ICW (SET/CLR may list R0 too)
                if value:
                    np.logical_or(p12, r0, out=p12)
                else:
                    np.greater(p12, r0, out=p12)  # p12 AND NOT r0
            for p in planes:
                p.fill(value)

        return set_clear

    def _op_copy(self, ins: Instruction, invert: bool) -> Op:
        (s,) = self._dsrc(ins)
        if invert:
            return self._digital_store(ins.dsts[0], lambda out: np.logical_not(s, out=out))
        return self._digital_store(ins.dsts[0], lambda out: np.copyto(out, s))

    def _or_into(self, srcs: list[np.ndarray], invert: bool) -> Callable[[np.ndarray], None]:
        first, rest = srcs[0], srcs[1:]

        def compute(out: np.ndarray) -> None:
            if rest:
                np.logical_or(first, rest[0], out=out)
                for x in rest[1:]:
                    np.logical_or(out, x, out=out)
            else:
                np.copyto(out, first)
            if invert:
                np.logical_not(out, out=out)

        return compute

    def _op_or(self, ins: Instruction, invert: bool) -> Op:
        return self._digital_store(ins.dsts[0], self._or_into(self._dsrc(ins), invert))

    def _op_flag_or(self, ins: Instruction) -> Op:
        compute = self._or_into(self._dsrc(ins), False)
        flag = self._d[_FLAG_I]
        tb = self._tb[0]
        reads_flag = any(s.index == _FLAG_I for s in ins.srcs)

        def where() -> None:
            if reads_flag:  # WHERE(x, FLAG): every source is read before FLAG is written
                compute(tb)
                np.copyto(flag, tb)
            else:
                compute(flag)
            self._flag_masked = None

        return where

    def _op_latch(self, ins: Instruction, invert: bool) -> Op:
        compute = self._or_into(self._dsrc(ins), invert)
        latch = self._latch
        return lambda: compute(latch)

    def _op_unlatch(self, ins: Instruction) -> Op:
        latch = self._latch
        return self._digital_store(ins.dsts[0], lambda out: np.copyto(out, latch))

    def _op_dnews(self, ins: Instruction, edge: bool) -> Op:
        (src,) = self._dsrc(ins)
        tb = self._tb[1]
        rows, cols = self.rows, self.cols
        parts = []
        for direction, sel in DNEWS_SELECTORS.items():
            dr, dc = direction.offset
            o, i = _slices(dr, dc)
            parts.append((self._d[sel.index], o, i, _edge_slices(dr, dc, rows, cols)))

        acc = np.zeros((rows, cols), dtype=bool)

        def compute(out: np.ndarray) -> None:
            # Accumulate apart from ``out``: the destination may be a selector (R1-R4)
            # that is still being read.
            acc.fill(False)
            for sel, o, i, edges in parts:
                np.copyto(tb[o], src[i])
                for e in edges:
                    tb[e] = edge
                np.logical_and(tb, sel, out=tb)
                np.logical_or(acc, tb, out=acc)
            np.copyto(out, acc)

        return self._digital_store(ins.dsts[0], compute)


def _noop() -> None:
    return None


def _no_clip(values: np.ndarray, lo: np.float32, hi: np.float32, out: np.ndarray) -> None:
    """Stands in for the clip where the value is in range by construction."""


def count_clocks(instructions: Iterable[Instruction]) -> dict[str, int]:
    """ICWs per clock class (every class present, zeros included)."""
    counts = dict.fromkeys(CLOCK_CLASSES, 0)
    for ins in instructions:
        counts[ins.clock] += 1
    return counts


def written_digital(instructions: Iterable[Instruction]) -> np.ndarray:
    """Indices of the digital planes the instructions write (for retention bookkeeping)."""
    idx = sorted({d.index for ins in instructions for d in ins.dsts if d.kind == "digital"})
    return np.asarray(idx, dtype=np.intp)


__all__ += ["count_clocks", "written_digital"]
