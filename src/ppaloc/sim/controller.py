"""Host-side (controller) API of the simulated SCAMP-5: the ``scamp5_*`` functions.

On SCAMP-5 the host program (on the vision system's micro-controller) drives the array
through a library of controller functions: it loads constants through the DAC, loads
address patterns into digital registers, shifts whole planes, and reads results out
through the ADC, the wired-OR and the event (address) readout. :class:`ControllerMixin`
gives :class:`ppaloc.sim.engine.Scamp5` those functions with SCAMP-5's names and argument
order (the ``scamp5_`` prefix may be dropped; both spellings exist), and charges every call
to the timing model (``self.timing.charge_call``).

Coordinates
-----------
Arrays are ``[row, col]``, row 0 north (top), col growing east (right), everywhere in
ppaloc. SCAMP-5's own *hardware addresses* put column address 0 at the **east** edge: the
official headers describe ``scamp5_load_rect``'s ``(r0, c0)`` as the *top-right* corner and
the ``scamp5_scan_areg`` buffers as "column-major, starting from top right"; and the
public precursor of the weighted-node pipeline numbers its nodes from hardware column 0
while the paper's snake starts at the top-right. So hardware address ``(r, c)`` is array
element ``[r, cols - 1 - c]``.

Every function here takes and returns **array coordinates** by default. Pass
``scamp_addr=True`` to give (and get) hardware addresses instead, e.g. to port SCAMP-5
code with its literal constants: ``load_pattern(R6, 0, 0, 0b11111100, 0b11100011,
scamp_addr=True)`` sets the same elements the hardware would. Readout *order* (the order
of ``scan_events`` results) always follows the hardware scan, documented per function.

Readouts through the ADC return SCAMP-5's 8-bit codes ``clip(floor(v + 128.5), 0, 255)``,
the nearest code with halves rounded up (``v`` in register units, [-128, 127]; the
contract docs/ppa8.md's readouts rely on); with noise, each conversion adds Gaussian noise of
the register's temporal standard deviation before rounding (one more analogue transfer,
to the column ADC). Digital readouts are exact.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim import hostloops
from ppaloc.sim.draw import DrawMixin
from ppaloc.sim.observe import controller_call, yes_no_argument
from ppaloc.sim.registers import (
    DNEWS_SELECTORS,
    FLAG,
    NEWS,
    R0,
    R1,
    R2,
    R3,
    R4,
    R12,
    RECT,
    SELECT,
    Direction,
    Register,
    register_by_name,
)

if TYPE_CHECKING:
    from ppaloc.sim.timing import TimingModel

__all__ = [
    "MAX_EVENTS",
    "PARAMETERS",
    "ControllerMixin",
    "dac_level",
    "from_scamp_buffer",
    "to_scamp_buffer",
]

#: Largest ``max_num`` of ``scan_events`` (``SCAMP5_MAX_AER_ITERATIONS`` in the headers).
MAX_EVENTS = 4000
#: Up to this many 1s an event scan sorts them by scan position (beyond, it walks the plane).
_SPARSE_EVENTS = 8192


def to_scamp_buffer(grid: np.ndarray) -> np.ndarray:
    """Flatten a 2-D readout (array orientation) into SCAMP-5's buffer order.

    SCAMP-5's ``scamp5_scan_areg*`` buffers are column-major starting from the top-right
    element: ``buffer[3]`` is the first column from the right, fourth row down.

    Parameters
    ----------
    grid : numpy.ndarray, shape (n_rows, n_cols)
        A readout in array orientation (row 0 north, col 0 west).

    Returns
    -------
    numpy.ndarray, shape (n_rows * n_cols,)

    Examples
    --------
    >>> to_scamp_buffer(np.array([[1, 2], [3, 4]])).tolist()
    [2, 4, 1, 3]
    """
    return np.ascontiguousarray(np.asarray(grid)[:, ::-1].T).ravel()


def from_scamp_buffer(buffer: np.ndarray, n_rows: int, n_cols: int) -> np.ndarray:
    """Inverse of :func:`to_scamp_buffer`: a SCAMP-5 buffer back to array orientation.

    Examples
    --------
    >>> from_scamp_buffer(np.array([2, 4, 1, 3]), 2, 2).tolist()
    [[1, 2], [3, 4]]
    """
    return np.asarray(buffer).reshape(n_cols, n_rows).T[:, ::-1].copy()


_WIDE_MASK = (1 << 16) - 1
"""A "don't care" mask over every address bit of an array of up to 4096 (a default pattern
selects the whole array where it is larger than the chip's 256)."""

_DNEWS_SELECTORS = frozenset({"R1", "R2", "R3", "R4"})
"""The digital registers that select a DNEWS step's direction (a digital shift's steps)."""


def _as_int(call: str, name: str, value: Any, lo: int, hi: int) -> int:
    if type(value) is int and lo <= value <= hi:  # the common case, checked first
        return value
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | np.integer):
        raise SimulatorError(f"{call}: {name}={value!r} must be an integer in [{lo}, {hi}]")
    if not lo <= int(value) <= hi:
        raise SimulatorError(f"{call}: {name}={value!r} is out of range; use [{lo}, {hi}]")
    return int(value)


def _pattern_args(call: str, r: Any, c: Any, rx: Any, cx: Any) -> tuple[int, int, int, int]:
    """``(r, c, rx, cx)`` checked: 8-bit integers."""
    return (
        _as_int(call, "r", r, 0, 255),
        _as_int(call, "c", c, 0, 255),
        _as_int(call, "rx", rx, 0, 255),
        _as_int(call, "cx", cx, 0, 255),
    )


class _Pattern(NamedTuple):
    """The elements an address pattern selects: the plane, its rows and columns (index
    arrays; None when every row, column matches), and whether each row and column
    matches (bool vectors: the plane is their outer AND)."""

    mask: np.ndarray
    rows: np.ndarray | None
    cols: np.ndarray | None
    row_ok: np.ndarray
    col_ok: np.ndarray


#: ``vs_scamp5_get_parameter`` numbers of the header (``vs_scamp5.hpp``).
PARAMETERS = {
    "SCAMP5_GLOBAL_SUM_16_AREG_MIN": 4,
    "SCAMP5_GLOBAL_SUM_16_AREG_MAX": 5,
    "SCAMP5_GLOBAL_SUM_16_FLOOR": 6,
    "SCAMP5_GLOBAL_SUM_16_SPAN": 7,
    "SCAMP5_GLOBAL_SUM_64_AREG_MIN": 8,
    "SCAMP5_GLOBAL_SUM_64_AREG_MAX": 9,
    "SCAMP5_GLOBAL_SUM_64_FLOOR": 10,
    "SCAMP5_GLOBAL_SUM_64_SPAN": 11,
}


def dac_level(code: int) -> float:
    """Register level of a 12-bit DAC code: ``-128 + 255 * code / 4095`` (an estimate)."""
    return -128.0 + 255.0 * code / 4095.0


class ControllerMixin(DrawMixin):
    """Controller (host) calls of SCAMP-5, mixed into :class:`ppaloc.sim.engine.Scamp5`.

    Uses only the engine's internal accessors: ``rows``, ``cols``, ``_aplane``,
    ``_dplane``, ``_write_analog``, ``_write_digital``, ``_write_digital_grid``,
    ``_flag_state``, ``_set_in``, ``_take_droop``, ``_aplane_and_droop``, ``_fill_later``,
    ``_overwrite``, ``rng``, ``noise``
    and ``timing``, and tells the engine's observers (:mod:`ppaloc.sim.observe`) each
    plane a call writes (``_note_write``). Every public call is a
    :func:`~ppaloc.sim.observe.controller_call`.
    """

    rows: int
    cols: int
    timing: TimingModel
    noise: Any
    rng: np.random.Generator
    #: Address patterns by (r, c, rx, cx, scamp_addr) (made on first use).
    _address_masks: dict[tuple, _Pattern] | None = None

    if TYPE_CHECKING:

        def _aplane(self, reg: Register) -> np.ndarray: ...
        def _dplane(self, reg: Register) -> np.ndarray: ...
        def _write_analog(
            self, reg: Register, values: object, where: np.ndarray | None = None
        ) -> None: ...
        def _write_digital(self, reg: Register, bools: np.ndarray) -> None: ...
        def _write_digital_grid(
            self, reg: Register, rows: np.ndarray, cols: np.ndarray
        ) -> None: ...
        def _flag_state(self) -> tuple[np.ndarray, bool]: ...
        def _set_in(self, value: float) -> None: ...
        def _take_droop(self, reg: Register) -> np.float32 | None: ...
        def _aplane_and_droop(self, reg: Register) -> tuple[np.ndarray, np.float32 | None]: ...
        def _fill_later(self, i: int, value: float) -> None: ...
        def _overwrite(self, reg: Register) -> np.ndarray: ...

        _call_frame: Any

        def _note_write(self, reg: Register) -> None: ...

    # ----------------------------------------------------------------------------------
    # Stages

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Charge every kernel and call inside the ``with`` block to stage ``name``.

        Examples
        --------
        >>> from ppaloc.sim import Scamp5, A
        >>> sim = Scamp5(8, 8)
        >>> with sim.stage("constants"):
        ...     sim.scamp5_in(A, 10)
        >>> sim.timing.report().stage("constants").calls
        {'scamp5_in': 1}
        """
        with self.timing.stage(name):
            yield

    # ----------------------------------------------------------------------------------
    # Checks and conversions

    def _areg(self, call: str, reg: Any, *, source: bool = False) -> Register:
        ok = isinstance(reg, Register) and reg.kind == "analog"
        if ok and not source:
            ok = reg.role in ("general", "news")
        elif ok:
            ok = reg.role != "neighbour"
        if not ok:
            want = "an analogue register" if source else "one of A-F or NEWS"
            raise RegisterMisuseError(f"{call}: {reg!r} is not {want}")
        return reg

    def _dreg(self, call: str, reg: Any, *, source: bool = False) -> Register:
        ok = isinstance(reg, Register) and reg.kind == "digital"
        if ok and not source:
            ok = reg.role == "general"
        if not ok:
            want = "a digital register" if source else "one of R0-R12"
            raise RegisterMisuseError(f"{call}: {reg!r} is not {want}")
        return reg

    def _col_index(self, c: int, scamp_addr: bool) -> int:
        """Array column of column ``c`` given in array (or hardware) coordinates."""
        return self.cols - 1 - c if scamp_addr else c

    def _coord(self, call: str, name: str, value: Any, size: int) -> int:
        return _as_int(call, name, value, 0, size - 1)

    def _flag(self) -> np.ndarray:
        return self._dplane(FLAG)

    def _catch_up(self) -> None:
        """Apply the engine's time-dependent decay up to now before a readout (noisy)."""
        if not self.noise.ideal:
            elapse = getattr(self, "_elapse", None)
            if elapse is not None:
                elapse()

    def _readout_sd(self) -> float:
        if self.noise.ideal:
            return 0.0
        params = getattr(self.noise, "params", None)
        return float(getattr(params, "temporal_sd", 0.0)) if params is not None else 0.0

    def _adc(self, values: np.ndarray) -> np.ndarray:
        """8-bit ADC codes of analogue values: nearest of v + 128 (halves up), clipped."""
        v = np.asarray(values, dtype=np.float64)
        sd = self._readout_sd()
        if sd > 0:
            v = v + self.rng.normal(0.0, sd, v.shape)
        return np.clip(np.floor(v + 128.5), 0, 255).astype(np.uint8)

    def _block_means(self, call: str, plane: np.ndarray, n: int) -> np.ndarray:
        if self.rows % n or self.cols % n:
            raise SimulatorError(
                f"{call} needs rows and cols divisible by {n}, the array is "
                f"{self.rows}x{self.cols}; use sizes divisible by {n} (e.g. 256x256)"
            )
        br, bc = self.rows // n, self.cols // n
        return plane.reshape(n, br, n, bc).mean(axis=(1, 3), dtype=np.float64)

    def _pattern(self, r: int, c: int, rx: int, cx: int, scamp_addr: bool) -> _Pattern:
        """The elements an address pattern selects, worked out once per pattern."""
        key = (r, c, rx, cx, scamp_addr)
        cache = self._address_masks
        if cache is None:
            cache = self._address_masks = {}
        pattern = cache.get(key)
        if pattern is None:
            rows = np.arange(self.rows)
            cols = np.arange(self.cols)
            if scamp_addr:
                cols = self.cols - 1 - cols
            row_ok = (rows & ~rx) == (r & ~rx)
            col_ok = (cols & ~cx) == (c & ~cx)
            mask = row_ok[:, None] & col_ok[None, :]
            mask.flags.writeable = False
            pattern = _Pattern(
                mask,
                None if row_ok.all() else np.flatnonzero(row_ok),
                None if col_ok.all() else np.flatnonzero(col_ok),
                row_ok,
                col_ok,
            )
            if len(cache) >= 1024:
                cache.clear()
            cache[key] = pattern
        return pattern

    def address_mask(self, r: int, c: int, rx: int, cx: int, scamp_addr: bool) -> np.ndarray:
        """The (read-only) plane of the elements an address pattern selects: ``(r, c)``
        with "don't care" bits ``rx``, ``cx``, in hardware addresses (``scamp_addr``) or
        array coordinates (inspection; untimed, changes nothing)."""
        args = _pattern_args("address_mask", r, c, rx, cx)
        return self._pattern(*args, yes_no_argument("address_mask", "scamp_addr", scamp_addr)).mask

    # ----------------------------------------------------------------------------------
    # DAC

    def _dac_value(self, call: str, value: Any) -> int:
        return _as_int(call, "value", value, -128, 127)

    def _write_masked(self, reg: Register, values: np.ndarray | float, *, noisy: bool) -> None:
        """Write an analogue plane (or a scalar) where FLAG is set (analogue writes obey FLAG).

        One pass over the plane that selects the new value where FLAG is set
        (:mod:`ppaloc.sim.hostloops`; a plain copy when FLAG is set everywhere, known
        without a pass while the engine tracks it), not a gather and a scatter through
        boolean indices: the DAC loads and shifts of a frame are its most frequent
        controller calls. A constant written everywhere without noise (ideal mode, or a
        noiseless write such as ``scamp5_in``'s ``temp``) is deferred (``_fill_later``):
        its pass runs when the plane is next used, or never when it is overwritten first.
        ``values`` are clipped to [-128, 127].
        """
        self._catch_up()  # older values droop up to now; the new ones start fresh
        if self._call_frame is not None:
            self._note_write(reg)
        flag, everywhere = self._flag_state()
        level = not isinstance(values, np.ndarray)
        if everywhere and level and (self.noise.ideal or not noisy):
            self._fill_later(reg.index, min(max(float(values), -128.0), 127.0))
            return
        before = None  # the droop pending on the plane, when the fill below applies it
        if everywhere and level:  # a level written everywhere: the old values' droop is never seen
            current = self._overwrite(reg)
        elif level and not noisy:  # the kept elements droop in the fill's own pass
            current, before = self._aplane_and_droop(reg)
        else:
            current = self._aplane(reg)
        if noisy and not self.noise.ideal:
            self._write_analog(reg, values, None if everywhere else flag)
            return
        if isinstance(values, np.ndarray):
            values = np.clip(values, -128, 127)
            if everywhere:
                current[...] = values
            else:
                hostloops.select(current, values, flag)
            return
        value = min(max(float(values), -128.0), 127.0)
        if everywhere:
            hostloops.fill(current, value)
        else:
            hostloops.fill_where(current, value, flag, before)

    def _temp(self, call: str, areg: Register, temp: Any) -> Register | None:
        """The header's ``temp`` register (default NEWS), or None when it is ``areg``."""
        self._areg(call, temp)
        if temp is areg:
            if areg is NEWS:  # the value goes to NEWS itself
                return None
            raise RegisterMisuseError(
                f"{call}: temp={temp.name} is the target; use another register as temp "
                "(default NEWS)"
            )
        return temp

    @controller_call
    def scamp5_in(self, areg: Register, value: int, temp: Register = NEWS) -> None:
        """Load a constant into ``areg`` through the DAC, with error correction.

        The DAC drives ``IN`` with ``value`` and the value is copied into ``areg`` where
        FLAG is set, through ``temp`` (the library's temporary, ``NEWS`` by default), which
        is left holding ``-value``. ``scamp5_in`` corrects the DAC's offset, so with noise
        only the temporal noise of one write remains (compare :meth:`load_in`).

        Parameters
        ----------
        areg : Register
            Destination, one of A-F or NEWS.
        value : int
            Integer in [-128, 127].
        temp : Register
            Scratch analogue register, as in SCAMP-5 (default NEWS); must differ from
            ``areg`` unless both are NEWS.

        Raises
        ------
        SimulatorError
            If ``value`` is not an integer in [-128, 127].
        RegisterMisuseError
            If ``areg`` or ``temp`` is not one of A-F or NEWS, or ``temp`` is ``areg``.
        """
        call = "scamp5_in"
        self._areg(call, areg)
        t = self._temp(call, areg, temp)
        v = self._dac_value(call, value)
        self.timing.charge_call(call)
        self._set_in(v)
        if t is not None:
            self._write_masked(t, -float(v), noisy=False)
        if self._readout_sd() > 0:  # one write's temporal noise: a window of the bank
            self._catch_up()
            if self._call_frame is not None:
                self._note_write(areg)
            flag, everywhere = self._flag_state()
            if everywhere:
                current, before = self._overwrite(areg), None
            else:  # the kept elements droop in the write's own pass
                current, before = self._aplane_and_droop(areg)
            window = self.noise.window()
            hostloops.noisy_level(current, float(v), window, flag, everywhere, before)
        else:
            self._write_masked(areg, float(v), noisy=False)

    @controller_call
    def scamp5_get_image(self, yf: Register, yh: Register, gain: int = 1) -> None:
        """``scamp5_get_image``: capture the exposure into ``yf`` (full range) and ``yh``.

        Runs the ``get_image(yf, yh)`` macro as a kernel of its own (6 ICWs): in ideal
        mode ``yf = p - 128`` (full range) for a pixel ``p`` of the image given to
        ``set_image``, and ``yh`` holds the negated half-range image ``-(p/2 - 64)``; PIX
        is reset. Only ``gain=1`` is
        modelled (the library's higher gains repeat the exposure accumulation, whose
        analogue details are not public).

        Raises
        ------
        SimulatorError
            If ``gain`` is not 1.
        """
        call = "scamp5_get_image"
        self._areg(call, yf)
        self._areg(call, yh)
        if _as_int(call, "gain", gain, 1, 5) != 1:
            raise SimulatorError(f"{call}: gain={gain} is not modelled; use gain=1")
        self.get_image(yf, yh)  # type: ignore[attr-defined]

    @controller_call
    def load_in(
        self, areg_or_value: Register | int, value: int | None = None, temp: Register = NEWS
    ) -> None:
        """``scamp5_load_in``: load a constant through the DAC without error correction.

        Two forms, as in SCAMP-5: ``load_in(value)`` only drives ``IN`` (for kernels that
        read ``IN``); ``load_in(areg, value, temp=NEWS)`` also copies it into ``areg``
        where FLAG is set, through ``temp`` (left holding ``-value``), as plain analogue
        writes (with the write noise and fixed-pattern offsets of the engine's noise
        model).

        Raises
        ------
        SimulatorError
            If the value is not an integer in [-128, 127].
        RegisterMisuseError
            If ``areg`` or ``temp`` is not one of A-F or NEWS, or ``temp`` is ``areg``.
        """
        call = "load_in"
        if value is None:
            if isinstance(areg_or_value, Register):
                raise SimulatorError(
                    "load_in: give a value, load_in(value) or load_in(areg, value)"
                )
            v = self._dac_value(call, areg_or_value)
            self.timing.charge_call(call)
            self._set_in(v)
            return
        areg = self._areg(call, areg_or_value)
        t = self._temp(call, areg, temp)
        v = self._dac_value(call, value)
        self.timing.charge_call(call)
        self._set_in(v)
        if t is not None:
            self._write_masked(t, -float(v), noisy=True)
        self._write_masked(areg, float(v), noisy=True)

    # ----------------------------------------------------------------------------------
    # Address patterns

    @controller_call
    def load_pattern(
        self, dreg: Register, r: int, c: int, rx: int, cx: int, *, scamp_addr: bool = False
    ) -> None:
        """Set ``dreg`` to 1 where the element's address matches (r, c) under masks.

        An element at row ``row``, column ``col`` is set where ``(row & ~rx) == (r & ~rx)``
        and ``(col & ~cx) == (c & ~cx)``, i.e. the bits set in ``rx``/``cx`` are ignored;
        elsewhere ``dreg`` is cleared (official header: masking bits "allow a match to
        occur periodically"; mask 192 makes addresses 3, 67, 131 and 195 match 3).
        Digital writes ignore FLAG.

        Parameters
        ----------
        dreg : Register
            Destination, one of R0-R12.
        r, c : int
            Address to match, 8-bit (array coordinates, or hardware addresses with
            ``scamp_addr=True``).
        rx, cx : int
            Bits of the row/column address to ignore, 8-bit.

        Examples
        --------
        >>> from ppaloc.sim import Scamp5, R5
        >>> sim = Scamp5(4, 4)
        >>> sim.load_pattern(R5, 0, 1, 0b10, 0b10)   # rows 0 and 2, cols 1 and 3
        >>> sim.read(R5).astype(int)
        array([[0, 1, 0, 1],
               [0, 0, 0, 0],
               [0, 1, 0, 1],
               [0, 0, 0, 0]])
        """
        call = "load_pattern"
        self._dreg(call, dreg)
        args = _pattern_args(call, r, c, rx, cx)
        self.timing.charge_call(call)
        pattern = self._pattern(*args, scamp_addr)
        self._write_digital_grid(dreg, pattern.row_ok, pattern.col_ok)

    @controller_call
    def load_point(self, dreg: Register, r: int, c: int, *, scamp_addr: bool = False) -> None:
        """Set ``dreg`` to 1 at element (r, c) and to 0 elsewhere.

        Raises
        ------
        SimulatorError
            If (r, c) is outside the array.
        """
        call = "load_point"
        self._dreg(call, dreg)
        r = self._coord(call, "r", r, self.rows)
        c = self._coord(call, "c", c, self.cols)
        self.timing.charge_call(call)
        plane = np.zeros((self.rows, self.cols), dtype=bool)
        plane[r, self._col_index(c, scamp_addr)] = True
        self._write_digital(dreg, plane)

    def _rect(self, call: str, r0: int, c0: int, r1: int, c1: int, scamp_addr: bool) -> np.ndarray:
        r0, r1 = (self._coord(call, n, v, self.rows) for n, v in (("r0", r0), ("r1", r1)))
        c0, c1 = (self._coord(call, n, v, self.cols) for n, v in (("c0", c0), ("c1", c1)))
        ca, cb = sorted((self._col_index(c0, scamp_addr), self._col_index(c1, scamp_addr)))
        ra, rb = sorted((r0, r1))
        plane = np.zeros((self.rows, self.cols), dtype=bool)
        plane[ra : rb + 1, ca : cb + 1] = True
        return plane

    @controller_call
    def load_rect(
        self, dreg: Register, r0: int, c0: int, r1: int, c1: int, *, scamp_addr: bool = False
    ) -> None:
        """Set ``dreg`` to 1 inside the rectangle with corners (r0, c0) and (r1, c1).

        Both corners are included and their order does not matter. (SCAMP-5 documents
        ``(r0, c0)`` as the top-right corner in hardware addresses; with
        ``scamp_addr=True`` the same call sets the same elements.)
        """
        call = "load_rect"
        self._dreg(call, dreg)
        plane = self._rect(call, r0, c0, r1, c1, scamp_addr)
        self.timing.charge_call(call)
        self._write_digital(dreg, plane)

    @controller_call
    def select_pattern(self, r: int, c: int, rx: int, cx: int, *, scamp_addr: bool = False) -> None:
        """Like :meth:`load_pattern`, into ``SELECT`` (also the address parts that
        :meth:`select_col` and its siblings change one at a time)."""
        call = "select_pattern"
        args = dict(zip(("r", "c", "rx", "cx"), _pattern_args(call, r, c, rx, cx), strict=True))
        self.timing.charge_call(call)
        self._dplane(SELECT)[...] = self.address_mask(**args, scamp_addr=scamp_addr)
        if self._call_frame is not None:
            self._note_write(SELECT)
        if scamp_addr:  # the parts are kept in array columns (exact for 2^k columns)
            args["c"] = (self.cols - 1 - args["c"]) & 255
        self._select_state().update(args)

    @controller_call
    def select_point(self, r: int, c: int, *, scamp_addr: bool = False) -> None:
        """Like :meth:`load_point`, into ``SELECT`` (and the parts :meth:`select_col` edits)."""
        call = "select_point"
        r = self._coord(call, "r", r, self.rows)
        c = self._coord(call, "c", c, self.cols)
        self.timing.charge_call(call)
        plane = self._dplane(SELECT)
        plane[...] = False
        plane[r, self._col_index(c, scamp_addr)] = True
        if self._call_frame is not None:
            self._note_write(SELECT)
        self._select_state().update(r=r, c=self._col_index(c, scamp_addr), rx=0, cx=0)

    @controller_call
    def select_rect(self, r0: int, c0: int, r1: int, c1: int, *, scamp_addr: bool = False) -> None:
        """Like :meth:`load_rect`, into ``RECT``; as the header says it also modifies
        ``SELECT``, which here holds the same rectangle."""
        call = "select_rect"
        plane = self._rect(call, r0, c0, r1, c1, scamp_addr)
        self.timing.charge_call(call)
        self._dplane(RECT)[...] = plane
        self._dplane(SELECT)[...] = plane
        if self._call_frame is not None:
            self._note_write(RECT)
            self._note_write(SELECT)

    # ----------------------------------------------------------------------------------
    # Shifts

    @controller_call
    def shift(self, reg: Register, h: int, v: int, boundary: int = 0, refresh: int = 2) -> None:
        """``scamp5_shift``: move a whole register plane by (h, v) elements.

        Parameters
        ----------
        reg : Register
            An analogue register (A-F, NEWS) or a digital one (R0-R12).
        h : int
            Horizontal shift; positive moves the picture east (right), negative west.
        v : int
            Vertical shift; positive moves the picture north (up), negative south.
        boundary : int
            Digital registers only: the value (0 or 1) shifted in at the edge. Analogue
            registers shift in 0.
        refresh : int
            Digital registers only: the header's refresh interval (a ``REFRESH`` every
            ``refresh`` steps, >= 1). Ideal digital registers do not degrade within a
            shift, so it changes nothing here, and the modelled time is that of the
            default 2.

        Notes
        -----
        After ``shift(reg, h, v)``, ``new[row, col] = old[row + v, col - h]``. Analogue
        shifts write where FLAG is set, as one analogue write (the library's optimised
        method; its intermediate transfers are not modelled) and leave NEWS as it was.
        Digital shifts ignore FLAG and, like the ``DNEWS`` macro they are built from,
        leave R1-R4 selecting the direction of the last step.

        Examples
        --------
        >>> from ppaloc.sim import Scamp5, A
        >>> sim = Scamp5(1, 4)
        >>> sim.write(A, np.array([[1.0, 2.0, 3.0, 4.0]]))
        >>> sim.shift(A, 1, 0)
        >>> sim.read(A).tolist()
        [[0.0, 1.0, 2.0, 3.0]]
        """
        call = "shift"
        if not isinstance(reg, Register):
            raise RegisterMisuseError(f"{call}: {reg!r} is not a register")
        h = _as_int(call, "h", h, -(1 << 16), 1 << 16)
        v = _as_int(call, "v", v, -(1 << 16), 1 << 16)
        b = _as_int(call, "boundary", boundary, 0, 1)
        _as_int(call, "refresh", refresh, 1, 1 << 16)
        steps = abs(h) + abs(v)  # the time is the steps asked for, the move at most the array
        h = max(min(h, self.cols), -self.cols)
        v = max(min(v, self.rows), -self.rows)
        if reg.kind == "analog" and b:  # refused before the call is made
            raise RegisterMisuseError(
                f"{call}({reg.name}, {h}, {v}, boundary={b}): an analogue shift brings in 0; "
                "boundary is the value a digital shift brings in"
            )
        if reg.name in _DNEWS_SELECTORS:
            raise RegisterMisuseError(
                f"{call}({reg.name}, {h}, {v}): {reg.name} cannot be shifted: a digital shift "
                "is DNEWS steps, which overwrite R1-R4 with their direction first; copy it to "
                "another register (R5-R12) and shift that"
            )
        self._catch_up()  # shift the values as they are now
        if reg.kind == "analog":
            self._areg(call, reg)
            self._shift_analog(reg, h, v, steps)
        else:
            self._dreg(call, reg)
            old = self._dplane(reg)
            new = self._shifted(old, h, v, bool(b))
            self.timing.charge_call("shift_dreg", steps)
            last = None
            if v:
                last = Direction.south if v > 0 else Direction.north
            elif h:
                last = Direction.west if h > 0 else Direction.east
            if last is not None:
                for sel in (R1, R2, R3, R4):
                    self._write_digital(sel, np.full(old.shape, DNEWS_SELECTORS[last] is sel))
            self._write_digital(reg, new)

    def _shift_analog(self, reg: Register, h: int, v: int, steps: int) -> None:
        """The analogue ``shift``: 0 shifted in, written where FLAG, one write (noisy).

        Moved in place where FLAG, one pass (:func:`hostloops.shift`); noisy, with the
        cell offset and noise window added as by a noisy write, and the droop of the time
        the shift takes applied to the elements FLAG keeps, after the shifted values were
        read (:func:`hostloops.noisy_shift`).
        """
        plane, before = self._aplane_and_droop(reg)  # the droop pending: in the shift's pass
        self.timing.charge_call("shift_areg", steps)
        if self._call_frame is not None:
            self._note_write(reg)
        flag, everywhere = self._flag_state()
        if self.noise.ideal:
            hostloops.shift(plane, v, h, flag, everywhere)
            return
        self._catch_up()
        step = self._take_droop(reg)  # the droop since the charge, for the kept elements
        offset, window = self.noise.terms(reg.index, divided=False)
        hostloops.noisy_shift(plane, v, h, flag, everywhere, offset, window, step, before)

    @staticmethod
    def _shifted(plane: np.ndarray, h: int, v: int, fill: float | bool) -> np.ndarray:
        rows, cols = plane.shape
        out = np.full_like(plane, fill)
        # new[r, c] = old[r + v, c - h]
        r_dst = slice(max(0, -v), min(rows, rows - v))
        r_src = slice(max(0, v), min(rows, rows + v))
        c_dst = slice(max(0, h), min(cols, cols + h))
        c_src = slice(max(0, -h), min(cols, cols - h))
        out[r_dst, c_dst] = plane[r_src, c_src]
        return out

    # ----------------------------------------------------------------------------------
    # Global readouts

    @controller_call
    def global_sum_16(self, areg: Register, out: np.ndarray | None = None) -> int:
        """``scamp5_global_sum_16``: a value proportional to the sum of ``areg``.

        The array is cut into a 4 x 4 grid of blocks; each block's mean is converted by
        the ADC (code = mean + 128); the result is the sum of the 16 codes, so a plane of
        constant ``v`` gives ``16 * (v + 128)``.

        Parameters
        ----------
        areg : Register
            The analogue register to sum.
        out : numpy.ndarray, shape (4, 4), optional
            Filled with the 16 codes, in array orientation.

        Returns
        -------
        int
            Sum of the 16 codes, in [0, 4080].
        """
        return self._global_sum("global_sum_16", areg, 4, out)

    @controller_call
    def global_sum_64(self, areg: Register, out: np.ndarray | None = None) -> int:
        """``scamp5_global_sum_64``: as :meth:`global_sum_16` on an 8 x 8 grid (sum of 64
        codes, in [0, 16320]); slower and finer."""
        return self._global_sum("global_sum_64", areg, 8, out)

    def _global_sum(self, call: str, areg: Register, n: int, out: np.ndarray | None) -> int:
        self._catch_up()
        self._areg(call, areg)  # the header's AREG: A-F or NEWS, not PIX or IN
        if out is not None:  # refused before the call is made (and charged)
            got = None
            if not isinstance(out, np.ndarray) or out.shape != (n, n):
                got = f"shape {out.shape}" if isinstance(out, np.ndarray) else type(out).__name__
            elif out.dtype == np.bool_ or not np.can_cast(np.uint8, out.dtype):
                got = f"dtype {out.dtype}, which cannot hold the codes 0-255"
            elif not out.flags.writeable:
                got = "a read-only array"
            if got is not None:
                raise SimulatorError(
                    f"{call}: out must be a writable numpy array of shape ({n}, {n}) that "
                    f"holds 0-255, got {got}; pass np.zeros(({n}, {n}), dtype=np.uint8) or "
                    "leave it out"
                )
        codes = self._adc(self._block_means(call, self._aplane(areg), n))
        self.timing.charge_call(call)
        if out is not None:
            out[...] = codes
        return int(codes.sum(dtype=np.int64))

    @controller_call
    def global_or(
        self,
        dreg: Register,
        r: int = 0,
        c: int = 0,
        rx: int = 255,
        cx: int = 255,
        *,
        scamp_addr: bool = False,
    ) -> int:
        """``scamp5_global_or``: 1 if any selected element of ``dreg`` is 1, else 0.

        The optional (r, c, rx, cx) pattern selects elements as in :meth:`load_pattern`;
        the default selects the whole array.
        """
        call = "global_or"
        self._catch_up()
        self._dreg(call, dreg, source=True)
        args = _pattern_args(call, r, c, rx, cx)
        if args == (0, 0, 255, 255):  # the default: the whole array, beyond 256 too
            args = (0, 0, _WIDE_MASK, _WIDE_MASK)
        pattern = self._pattern(*args, scamp_addr)
        self.timing.charge_call(call)
        selected = self._dplane(dreg)
        if pattern.rows is None and pattern.cols is None:
            return int(hostloops.any_set(selected))
        # the pattern is a grid: its rows only, each ANDed with the columns' vector
        return int(hostloops.any_in_grid(selected, pattern.row_ok, pattern.col_ok))

    @controller_call
    def global_count(self, dreg: Register, temp: Register, options: int = 0) -> int:
        """``scamp5_global_count``: an estimate of the number of 1s in ``dreg``.

        As on SCAMP-5, ``temp`` is overwritten with an analogue image of ``dreg`` (127
        where 1, -128 where 0) that a global sum reads (4 x 4 blocks with ``options=0``,
        8 x 8 with ``options=1``); the result is scaled to [0, 4095]:
        ``4095 * sum(codes) / (255 * n_blocks)`` rounded half up. Quantisation by the ADC makes it
        an estimate: exact for 0 and all-ones, within ``4095 / 510`` of
        ``4095 * count / (rows * cols)`` in ideal mode.
        """
        call = "global_count"
        self._catch_up()
        self._dreg(call, dreg, source=True)
        self._areg(call, temp)
        o = _as_int(call, "options", options, 0, 1)
        n = 4 if o == 0 else 8
        plane = np.where(self._dplane(dreg), 127.0, -128.0)
        self._aplane(temp)[...] = plane
        if self._call_frame is not None:
            self._note_write(temp)
        codes = self._adc(self._block_means(call, self._aplane(temp), n))
        self.timing.charge_call("global_count" if o == 0 else "global_count_64")
        total = int(codes.sum(dtype=np.int64))
        return int(np.floor(4095 * total / (255 * n * n) + 0.5))

    # ----------------------------------------------------------------------------------
    # Image readouts

    @controller_call
    def read_areg(self, areg: Register, r: int, c: int, *, scamp_addr: bool = False) -> int:
        """``scamp5_read_areg``: the ADC code (0-255) of one element."""
        call = "read_areg"
        self._catch_up()
        self._areg(call, areg, source=True)
        r = self._coord(call, "r", r, self.rows)
        c = self._coord(call, "c", c, self.cols)
        value = self._aplane(areg)[r, self._col_index(c, scamp_addr)]
        self.timing.charge_call("scan_areg", 1)
        return int(self._adc(np.array(value)))

    @controller_call
    def scan_areg(
        self,
        areg: Register,
        r0: int = 0,
        c0: int = 0,
        r1: int | None = None,
        c1: int | None = None,
        rs: int = 1,
        cs: int = 1,
        *,
        scamp_addr: bool = False,
    ) -> np.ndarray:
        """``scamp5_scan_areg``: ADC codes of a grid of elements.

        Rows ``r0, r0 + rs, ... <= r1`` and columns ``c0, c0 + cs, ... <= c1`` (inclusive;
        ``r1``/``c1`` default to the last row/column).

        Returns
        -------
        numpy.ndarray of uint8, shape (n_rows, n_cols)
            Codes in array orientation (row 0 north, col 0 west) whatever the address
            frame; :func:`to_scamp_buffer` gives SCAMP-5's flat buffer order.
        """
        call = "scan_areg"
        self._catch_up()
        self._areg(call, areg, source=True)
        r1 = self.rows - 1 if r1 is None else r1
        c1 = self.cols - 1 if c1 is None else c1
        r0, r1 = (self._coord(call, n, x, self.rows) for n, x in (("r0", r0), ("r1", r1)))
        c0, c1 = (self._coord(call, n, x, self.cols) for n, x in (("c0", c0), ("c1", c1)))
        rs = _as_int(call, "rs", rs, 1, max(self.rows, 1))
        cs = _as_int(call, "cs", cs, 1, max(self.cols, 1))
        if r1 < r0 or c1 < c0:
            raise SimulatorError(
                f"{call}: empty region r0={r0}..r1={r1}, c0={c0}..c1={c1}; need r0 <= r1, c0 <= c1"
            )
        if scamp_addr:  # hardware columns c0, c0 + cs, ... are array columns east to west
            last = c0 + (c1 - c0) // cs * cs
            cols = slice(self.cols - 1 - last, self.cols - c0, cs)
        else:
            cols = slice(c0, c1 + 1, cs)
        values = self._aplane(areg)[r0 : r1 + 1 : rs, cols]  # the grid, west to east
        self.timing.charge_call(call, values.size)
        return self._adc(values)

    @controller_call
    def scan_areg_8x8(self, areg: Register) -> np.ndarray:
        """``scamp5_scan_areg_8x8``: ADC codes of an 8 x 8 grid of single elements.

        Samples hardware addresses ``(k * rows/8, l * cols/8)``, k, l = 0..7 (the first
        element of each block in hardware order, as the open JSS simulator assumes): in
        array coordinates rows ``k * rows/8`` and columns ``cols - 1 - l * cols/8``, i.e.
        the top-*right* element of each block.

        Returns
        -------
        numpy.ndarray of uint8, shape (8, 8), array orientation.
        """
        call = "scan_areg_8x8"
        self._catch_up()
        self._areg(call, areg, source=True)
        if self.rows < 8 or self.cols < 8:
            raise SimulatorError(
                f"{call} needs an array of at least 8x8, not {self.rows}x{self.cols}"
            )
        sr, sc = self.rows // 8, self.cols // 8
        rows = np.arange(8) * sr
        cols = np.sort(self.cols - 1 - np.arange(8) * sc)
        values = self._aplane(areg)[np.ix_(rows, cols)]
        self.timing.charge_call(call)
        return self._adc(values)

    @controller_call
    def scan_areg_mean_8x8(self, areg: Register) -> np.ndarray:
        """``scamp5_scan_areg_mean_8x8``: ADC codes of the means of 8 x 8 blocks.

        Returns
        -------
        numpy.ndarray of uint8, shape (8, 8), array orientation; block (i, j) covers rows
        ``i * rows/8 ...`` and columns ``j * cols/8 ...``.
        """
        call = "scan_areg_mean_8x8"
        self._catch_up()
        self._areg(call, areg, source=True)
        means = self._block_means(call, self._aplane(areg), 8)
        self.timing.charge_call(call)
        return self._adc(means)

    @controller_call
    def scan_dreg(self, dreg: Register, r0: int = 0, r1: int | None = None) -> np.ndarray:
        """``scamp5_scan_dreg``: rows ``r0..r1`` (inclusive) of a digital register.

        Returns
        -------
        numpy.ndarray of bool, shape (r1 - r0 + 1, cols), array orientation (SCAMP-5
        packs each row into 32 bytes; this returns the bits unpacked).
        """
        call = "scan_dreg"
        self._catch_up()
        self._dreg(call, dreg, source=True)
        r1 = self.rows - 1 if r1 is None else r1
        r0 = self._coord(call, "r0", r0, self.rows)
        r1 = self._coord(call, "r1", r1, self.rows)
        if r1 < r0:
            raise SimulatorError(f"{call}: r1={r1} is before r0={r0}; need r0 <= r1")
        self.timing.charge_call(call, r1 - r0 + 1)
        return self._dplane(dreg)[r0 : r1 + 1].copy()

    @controller_call
    def scan_events(
        self,
        dreg: Register,
        max_num: int = 1,
        h_dir: int = 0,
        v_dir: int = 0,
        *,
        scamp_addr: bool = False,
    ) -> np.ndarray:
        """``scamp5_scan_events``: coordinates of the 1s of ``dreg``, up to ``max_num``.

        The hardware scan finds the column address first: it walks hardware columns
        0 -> cols-1 (``h_dir=1``: the reverse), i.e. array columns from **east to west**,
        and within a column the rows 0 -> rows-1 (north to south; ``v_dir=1``: the
        reverse). Events come back in that order.

        Parameters
        ----------
        dreg : Register
            Digital register to scan.
        max_num : int
            Number of event slots, 1..4000; the modelled time is proportional to it, not
            to the number of events found.
        h_dir, v_dir : int
            Scan directions (0 or 1) in hardware addresses, as in SCAMP-5.

        Returns
        -------
        numpy.ndarray of int64, shape (n_events, 2)
            ``(row, col)`` pairs in array coordinates (hardware addresses with
            ``scamp_addr=True``), ``n_events <= max_num``. Unlike SCAMP-5's buffer there is
            no ``(0, 0)`` end marker, so an event at (0, 0) is not lost.

        Examples
        --------
        >>> from ppaloc.sim import Scamp5, R5
        >>> sim = Scamp5(4, 4)
        >>> sim.write(R5, np.eye(4, dtype=bool))
        >>> sim.scan_events(R5, 4).tolist()    # east column first
        [[3, 3], [2, 2], [1, 1], [0, 0]]
        """
        return self._scan_events("scan_events", dreg, max_num, h_dir, v_dir, scamp_addr, False)

    def _scan_events(
        self,
        call: str,
        dreg: Register,
        max_num: int,
        h_dir: int,
        v_dir: int,
        scamp_addr: bool,
        rows_first: bool,
    ) -> np.ndarray:
        """The event scan: hardware columns outer (or rows outer with ``rows_first``)."""
        self._catch_up()
        self._dreg(call, dreg, source=True)
        n = _as_int(call, "max_num", max_num, 1, MAX_EVENTS)
        h = _as_int(call, "h_dir", h_dir, 0, 1)
        v = _as_int(call, "v_dir", v_dir, 0, 1)
        plane = self._dplane(dreg)
        if np.count_nonzero(plane) <= _SPARSE_EVENTS:
            r, a = self._events_sorted(plane, n, h, v, rows_first)
        else:
            addr = plane[:, ::-1]  # [row, hardware column]
            if h:
                addr = addr[:, ::-1]
            if v:
                addr = addr[::-1, :]
            if rows_first:
                r, a = np.nonzero(addr)  # row outer, hardware column inner
            else:
                a, r = np.nonzero(addr.T)  # hardware column outer, row inner
            a, r = a[:n], r[:n]
            if h:
                a = self.cols - 1 - a
            if v:
                r = self.rows - 1 - r
        self.timing.charge_call("scan_events", n)
        cols = a if scamp_addr else self.cols - 1 - a
        return np.stack([r, cols], axis=1).astype(np.int64)

    def _events_sorted(
        self, plane: np.ndarray, n: int, h: int, v: int, rows_first: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """(rows, hardware columns) of the first ``n`` 1s in scan order, for a sparse plane:
        found in memory order, then sorted by their scan position (unique keys)."""
        r, c = np.divmod(np.flatnonzero(plane), self.cols)  # (2-D nonzero is slower)
        a = self.cols - 1 - c  # hardware column
        rk = self.rows - 1 - r if v else r  # scan position along each axis
        ak = self.cols - 1 - a if h else a
        key = rk * self.cols + ak if rows_first else ak * self.rows + rk
        order = np.argsort(key, kind="stable")[:n]
        return r[order], a[order]

    # ----------------------------------------------------------------------------------
    # Raw DAC loads

    @controller_call
    def load_dac(
        self, areg_or_dac: Register | int, dac: int | None = None, temp: Register = NEWS
    ) -> None:
        """``scamp5_load_dac``: load the analogue level of a raw 12-bit DAC code.

        ``load_dac(code)`` drives ``IN``; ``load_dac(areg, code, temp=NEWS)`` also copies
        the level into ``areg`` where FLAG is set (``temp`` := its negation), as
        :meth:`load_in` does, without error correction. The level of code ``d`` in
        [0, 4095] is ``-128 + 255 d / 4095`` (the DAC's span mapped linearly onto the
        register range; the chip's calibrated map is not public).
        """
        call = "load_dac"
        if dac is None:
            if isinstance(areg_or_dac, Register):
                raise SimulatorError(
                    "load_dac: give a code, load_dac(code) or load_dac(areg, code)"
                )
            level = dac_level(_as_int(call, "dac", areg_or_dac, 0, 4095))
            self.timing.charge_call("load_in")
            self._set_in(level)
            return
        areg = self._areg(call, areg_or_dac)
        t = self._temp(call, areg, temp)
        level = dac_level(_as_int(call, "dac", dac, 0, 4095))
        self.timing.charge_call("load_in")
        self._set_in(level)
        if t is not None:
            self._write_masked(t, -float(level), noisy=True)
        self._write_masked(areg, float(level), noisy=True)

    # ----------------------------------------------------------------------------------
    # Analogue diffusion and asynchronous flooding (kernels of modelled ICWs)

    @controller_call
    def diffuse(
        self,
        target: Register,
        iterations: int,
        vertical: bool = True,
        horizontal: bool = True,
        t0: Register = NEWS,
    ) -> None:
        """``scamp5_diffuse``: diffuse ``target`` ``iterations`` times (a kernel).

        Runs ``SET(R1, R2); blurset()`` and per iteration the blur pair
        ``blur(t0, target); blur(target, t0)`` (``blurh``/``blurv`` when only one
        direction is on), so each iteration is one :func:`ppaloc.sim.semantics.diffuse`
        step twice and ``t0`` is scratch. R1 and R2 are left set (the links they enable).
        """
        call = "diffuse"
        self._areg(call, target)
        self._areg(call, t0)
        if t0 is target:
            raise RegisterMisuseError(f"{call}: t0={t0.name} is the target; use another register")
        n = _as_int(call, "iterations", iterations, 0, 1 << 16)
        if not (vertical or horizontal):
            raise SimulatorError(f"{call}: vertical and horizontal are both off; enable one")
        op = "blur" if vertical and horizontal else ("blurv" if vertical else "blurh")
        steps = [("SET", (R1, R2), ()), ("blurset", (), (R1, R2))]
        steps += [(op, (t0,), (target,)), (op, (target,), (t0,))] * n
        self._macro(call, (target, n), steps)  # type: ignore[attr-defined]

    @controller_call
    def flood(
        self,
        dreg_target: Register,
        dreg_mask: Register,
        boundary: int,
        iterations: int = 5,
        use_local: bool = False,
    ) -> None:
        """``scamp5_flood``: flood ``dreg_target``'s 1s through the 1s of ``dreg_mask``.

        Runs a kernel of the modelled asynchronous propagation: ``SET(R1, R2, R3, R4)``
        (all four directions; skipped with ``use_local``, which keeps the caller's
        selectors), ``SET(R0); MOV(R12, target); MOV(R0, mask)``, ``iterations`` times
        ``PROP0``/``PROP1`` (``boundary`` 0/1) and ``MOV(target, R12)``. Clobbers R0 and
        R12 (and R1-R4 unless ``use_local``). One PROP ICW reaches the fixed point here
        (docs/sim.md), so ``iterations`` changes the time, not the result.
        """
        call = "flood"
        t = self._dreg(call, dreg_target)
        m = self._dreg(call, dreg_mask, source=True)
        b = _as_int(call, "boundary", boundary, 0, 1)
        n = _as_int(call, "iterations", iterations, 0, 1 << 16)
        scratch = (R0, R12, R1, R2, R3, R4)
        for name, reg in (("dreg_target", t), ("dreg_mask", m)):
            if reg in scratch:
                raise RegisterMisuseError(
                    f"{call}: {name}={reg.name} is scratch of the flood (R0, R12, R1-R4); "
                    "use another register"
                )
        prop = "PROP1" if b else "PROP0"
        steps = [] if use_local else [("SET", (R1, R2, R3, R4), ())]
        steps += [("SET", (R0,), ()), ("MOV", (R12,), (t,)), ("MOV", (R0,), (m,))]
        steps += [("PROP_R", (), (R12,)), (prop, (R12,), ())] * n
        steps += [("MOV", (t,), (R12,))]
        self._macro(call, (t, m, b, n), steps)  # type: ignore[attr-defined]

    @controller_call
    def kernel_all(self) -> None:
        """``scamp5_kernel_all``: run ``all()`` (FLAG := 1) as a kernel of its own."""
        self._macro("kernel_all", (), [("all", (), ())])  # type: ignore[attr-defined]

    @controller_call
    def kernel_refresh_dreg(self) -> None:
        """``scamp5_kernel_refresh_dreg``: ``REFRESH`` every DREG R0-R12 (26 ICWs, the
        size of the library's ``const_icw_refresh`` table)."""
        steps = []
        for i in range(13):
            r = register_by_name(f"R{i}")
            steps += [("LATCH", (), (r,)), ("UNLATCH", (r,), ())]
        self._macro("kernel_refresh_dreg", (), steps)  # type: ignore[attr-defined]

    # ----------------------------------------------------------------------------------
    # SELECT by address parts

    def _select_state(self) -> dict[str, int]:
        return self.__dict__.setdefault("_select_args", {"r": 0, "c": 0, "rx": 255, "cx": 255})

    def _select_part(self, call: str, part: str, value: Any) -> None:
        state = self._select_state()
        state[part] = _as_int(call, part, value, 0, 255)
        if part in ("r", "c"):  # selecting a row (column) selects that one row (column)
            state[part + "x"] = 0
        self.timing.charge_call("select_pattern")
        self._dplane(SELECT)[...] = self.address_mask(**state, scamp_addr=False)
        if self._call_frame is not None:
            self._note_write(SELECT)

    @controller_call
    def select_col(self, c: int, *, scamp_addr: bool = False) -> None:
        """``scamp5_select_col``: SELECT the column ``c`` (in the rows selected so far).

        The four address parts (row, column and their ignore masks) start as "every
        element"; ``select_col(c)`` sets the column to ``c`` exactly, ``select_row(r)``
        the row, ``select_colx(cx)``/``select_rowx(rx)`` the bits to ignore, and SELECT is
        the pattern they give, as :meth:`select_pattern` would.
        """
        c = self._col_index(_as_int("select_col", "c", c, 0, self.cols - 1), scamp_addr)
        self._select_part("select_col", "c", c)

    @controller_call
    def select_row(self, r: int) -> None:
        """``scamp5_select_row``: SELECT the row ``r`` (see :meth:`select_col`)."""
        self._select_part("select_row", "r", _as_int("select_row", "r", r, 0, self.rows - 1))

    @controller_call
    def select_colx(self, cx: int) -> None:
        """``scamp5_select_colx``: the column address bits to ignore (see :meth:`select_col`)."""
        self._select_part("select_colx", "cx", cx)

    @controller_call
    def select_rowx(self, rx: int) -> None:
        """``scamp5_select_rowx``: the row address bits to ignore (see :meth:`select_col`)."""
        self._select_part("select_rowx", "rx", rx)

    # ----------------------------------------------------------------------------------
    # Further global sums

    def _sum_code(self, values: np.ndarray) -> int:
        """One ADC code of a sum, scaled so that 1/16 of the array at ``v`` reads ``v``."""
        scale = self.rows * self.cols / 16
        return int(self._adc(np.array(values.sum(dtype=np.float64) / scale)))

    @controller_call
    def global_sum_fast(self, areg: Register) -> int:
        """``scamp5_global_sum_fast``: an approximate sum of the whole plane, one code.

        ``clip(floor(sum / K + 128.5), 0, 255)`` with ``K = rows * cols / 16`` (4096 on
        the chip), the scale ``global_sum_region`` documents (a 64 x 64 region spans the
        codes): a plane of constant ``v`` reads ``16 v + 128``, so it saturates beyond
        ``|v| = 8``. The scale is inferred from the headers; the circuit is not public.
        """
        call = "global_sum_fast"
        self._catch_up()
        self._areg(call, areg)
        self.timing.charge_call("global_sum_16")
        return self._sum_code(self._aplane(areg))

    @controller_call
    def global_sum_sparse(
        self,
        areg: Register,
        r: int | None = None,
        c: int | None = None,
        rx: int | None = None,
        cx: int | None = None,
        *,
        scamp_addr: bool = False,
    ) -> int:
        """``scamp5_global_sum_sparse``: :meth:`global_sum_fast` over the elements the
        pattern selects (a quarter of the array by default, so a constant plane reads
        ``4 v + 128`` and saturates less).

        With no pattern given, the header's default ``(2, 2, 254, 254)`` in hardware
        addresses: even rows and hardware-even columns (array columns ``cols - 1 - c``
        for even ``c``), the elements the chip's call samples. A pattern given in part
        takes 2 and 254 for what is left out, in the caller's coordinates.
        """
        call = "global_sum_sparse"
        self._catch_up()
        self._areg(call, areg)
        if r is None and c is None and rx is None and cx is None:
            r, c, rx, cx, scamp_addr = 2, 2, 254, 254, True
        r, c = (2 if x is None else x for x in (r, c))
        rx, cx = (254 if x is None else x for x in (rx, cx))
        args = _pattern_args(call, r, c, rx, cx)
        if args == (2, 2, 254, 254) and scamp_addr:
            # the header's default, given or not: every other row and column, beyond 256 too
            mask = self._pattern(2, 2, _WIDE_MASK - 1, _WIDE_MASK - 1, True).mask
        else:
            mask = self.address_mask(*args, scamp_addr)
        self.timing.charge_call("global_sum_16")
        return self._sum_code(self._aplane(areg)[mask])

    @controller_call
    def global_sum_region(
        self, areg: Register, r0: int, c0: int, r1: int, c1: int, *, scamp_addr: bool = False
    ) -> int:
        """``scamp5_global_sum_region``: :meth:`global_sum_fast` over the rectangle with
        corners (r0, c0), (r1, c1) (inclusive): a 64 x 64 region of ``v`` reads ``v + 128``
        on a 256 x 256 array, spanning [0, 255] as the header says."""
        call = "global_sum_region"
        self._catch_up()
        self._areg(call, areg)
        rect = self._rect(call, r0, c0, r1, c1, scamp_addr)
        self.timing.charge_call("global_sum_16")
        return self._sum_code(self._aplane(areg)[rect])

    # ----------------------------------------------------------------------------------
    # Further digital readouts

    @controller_call
    def scan_events_cr(
        self,
        dreg: Register,
        max_num: int = 1,
        h_dir: int = 0,
        v_dir: int = 0,
        *,
        scamp_addr: bool = False,
    ) -> np.ndarray:
        """``scamp5_scan_events_cr``: the same scan as :meth:`scan_events` (column
        address first; the header's buffer holds (col, row) pairs)."""
        return self.scan_events(dreg, max_num, h_dir, v_dir, scamp_addr=scamp_addr)

    @controller_call
    def scan_events_rc(
        self,
        dreg: Register,
        max_num: int = 1,
        h_dir: int = 0,
        v_dir: int = 0,
        *,
        scamp_addr: bool = False,
    ) -> np.ndarray:
        """``scamp5_scan_events_rc``: as :meth:`scan_events`, scanning for the row first.

        Rows 0 -> rows-1 outer (``v_dir=1``: the reverse), and within a row hardware
        columns 0 -> cols-1, i.e. array columns east to west (``h_dir=1``: the reverse).
        Returns ``(row, col)`` pairs like every readout here.
        """
        return self._scan_events("scan_events_rc", dreg, max_num, h_dir, v_dir, scamp_addr, True)

    @controller_call
    def scan_boundingbox(self, dreg: Register, *, scamp_addr: bool = False) -> np.ndarray | None:
        """``scamp5_scan_boundingbox``: the axis-aligned bounding box of the 1s of ``dreg``.

        Returns
        -------
        numpy.ndarray of int64, shape (2, 2), or None
            The header's two corners, top-right then bottom-left: ``[[top row, east
            column], [bottom row, west column]]`` in array coordinates (hardware column
            addresses with ``scamp_addr=True``, where the east column has the lowest
            address); None when ``dreg`` has no 1. Charged as two event slots of the
            event readout (an estimate).
        """
        call = "scan_boundingbox"
        self._catch_up()
        self._dreg(call, dreg, source=True)
        self.timing.charge_call("scan_events", 2)
        plane = self._dplane(dreg)
        rows = np.flatnonzero(plane.any(axis=1))
        cols = np.flatnonzero(plane.any(axis=0))
        if rows.size == 0:
            return None
        east, west = int(cols[-1]), int(cols[0])
        if scamp_addr:
            east, west = self.cols - 1 - east, self.cols - 1 - west
        return np.array([[rows[0], east], [rows[-1], west]], dtype=np.int64)

    # ----------------------------------------------------------------------------------
    # Chip parameters

    @controller_call
    def vs_scamp5_get_parameter(self, which: int) -> int:
        """``vs_scamp5_get_parameter``: the global-sum parameters of the modelled chip.

        ``which`` is one of the header's ``SCAMP5_GLOBAL_SUM_*`` numbers (4-11, also
        :data:`PARAMETERS` by name): the uniform AREG levels that give the minimum and
        maximum output of the 4 x 4 / 8 x 8 global sums (-128 and 127 with the ideal ADC
        here) and the output floor (0) and span (16 x 255 = 4080 / 64 x 255 = 16320).
        """
        w = _as_int("vs_scamp5_get_parameter", "which", which, 4, 11)
        n_blocks = 16 if w < 8 else 64
        return (-128, 127, 0, 255 * n_blocks)[(w - 4) % 4]

    #: ``vs_vision_chip_get_parameter`` (``vs_vision_chip.hpp``), the same table.
    vs_vision_chip_get_parameter = vs_scamp5_get_parameter


# SCAMP-5 spellings of every controller call, so published host code ports line by line.
for _name in (
    "load_in",
    "load_pattern",
    "load_point",
    "load_rect",
    "select_pattern",
    "select_point",
    "select_rect",
    "shift",
    "global_sum_16",
    "global_sum_64",
    "global_or",
    "global_count",
    "read_areg",
    "scan_areg",
    "scan_areg_8x8",
    "scan_areg_mean_8x8",
    "scan_dreg",
    "scan_events",
    "load_dac",
    "diffuse",
    "flood",
    "kernel_all",
    "kernel_refresh_dreg",
    "select_col",
    "select_row",
    "select_colx",
    "select_rowx",
    "global_sum_fast",
    "global_sum_sparse",
    "global_sum_region",
    "scan_events_rc",
    "scan_events_cr",
    "scan_boundingbox",
):
    setattr(ControllerMixin, f"scamp5_{_name}", getattr(ControllerMixin, _name))
ControllerMixin.in_ = ControllerMixin.scamp5_in  # type: ignore[attr-defined]
del _name
