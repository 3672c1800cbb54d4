"""A host routine: load a small image into every period of a register, cell by cell.

SCAMP-5 has no call that writes an arbitrary image into a register; a host program loads
one through the DAC a cell at a time (the public precursor's ``load_analog_image``): per
cell an address pattern selects the PEs that take the cell's value, the DAC drives
``IN`` with it, and a kernel copies ``IN`` into the register where the pattern is set.
:meth:`CellLoadMixin.load_in_cells` is that routine, defined once: a ``p x q`` grid of
DAC values tiled over the array with period ``(p, q)``, made of the simulator's own
calls and one kernel, so it is timed, observed and noisy exactly as those calls are.

It is a host routine, not a SCAMP-5 library call: observers receive its calls and
kernel runs one by one (``load_pattern``, ``load_in``, a ``KernelRun``, per cell), as
the program written out call by call would make them. With no observer attached, the
simulator replays all but the last cell at once and makes only the last cell's calls,
charging the timing model every other cell's calls and kernel run in order
(:meth:`~ppaloc.sim.timing.TimingModel.charge_rounds`): in ideal mode one pass writes the
cells; under noise each cell's draw (taken by index), write and the droop of the time to
each later cell's kernel run are replayed with the same float32 operations
(:func:`~ppaloc.sim.hostloops.cell_writes`). The same bytes in every register, the same
draws taken and the same modelled time and energy as the cell-by-cell path, which the
routine takes where a digital register could decay meanwhile (its draws come from a
sequential generator) and when observed.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim import hostloops
from ppaloc.sim.registers import IN, R0, Register

if TYPE_CHECKING:
    from ppaloc.sim.kernel import Kernel
    from ppaloc.sim.timing import TimingModel

__all__ = ["CellLoadMixin", "period_mask"]


def period_mask(n: int) -> int:
    """``rx``/``cx`` of ``load_pattern`` that matches addresses modulo ``n`` (a power of 2).

    Examples
    --------
    >>> bin(period_mask(8)), period_mask(1)
    ('0b11111000', 255)
    """
    return 0xFF & ~(n - 1)


class CellLoadMixin:
    """:meth:`load_in_cells` and :meth:`pattern_cells`, mixed into
    :class:`ppaloc.sim.engine.Scamp5`."""

    rows: int
    cols: int
    timing: TimingModel
    noise: Any
    _observers: tuple
    _call_frame: Any
    _retention: bool
    _a: np.ndarray
    _droop_us: np.ndarray
    _last_us: float
    _dtouch_low: float
    #: The kernel ``WHERE(dreg); bus(areg, IN); all`` by ``(areg, dreg)`` (recorded at
    #: the first cell ever loaded so).
    _cell_kernels: dict[tuple[Register, Register], Kernel] | None = None
    #: Per period ``(p, q)``: the cell whose value each row, column takes last (-1: none),
    #: and whether they are simply ``r % p``, ``c % q`` (the grid tiles the plane).
    _cell_index: dict[tuple[int, int], tuple[np.ndarray, np.ndarray, bool]] | None = None
    #: Per period: :meth:`_cell_groups`' flat indices, bounds and scratch.
    _cell_groups_cache: dict[tuple[int, int], tuple] | None = None
    #: The kernel ``OR(dreg, tmp)`` or ``CLR_IF(dreg, tmp)`` by ``(dreg, tmp, clear)``.
    _pattern_kernels: dict[tuple[Register, Register, bool], Kernel] | None = None

    if TYPE_CHECKING:

        def _areg(self, call: str, reg: Any, *, source: bool = False) -> Register: ...
        def _dreg(self, call: str, reg: Any, *, source: bool = False) -> Register: ...
        def _aplane(self, reg: Register) -> np.ndarray: ...
        def _pattern(self, r: int, c: int, rx: int, cx: int, scamp_addr: bool) -> Any: ...
        def _dplane(self, reg: Register) -> np.ndarray: ...
        def kernel(self) -> Kernel: ...
        def load_pattern(self, dreg: Register, r: int, c: int, rx: int, cx: int) -> None: ...
        def load_in(self, areg_or_value: Register | int) -> None: ...

    def load_in_cells(self, areg: Register, values: np.ndarray, dreg: Register) -> None:
        """``areg := -values`` tiled with period ``values.shape``, one DAC load per cell.

        For each cell ``(i, j)`` of the ``p x q`` grid ``values``, in row-major order:
        ``load_pattern(dreg, i, j, period_mask(p), period_mask(q))`` (every PE whose row
        is ``i`` and column ``j`` modulo the period), ``load_in(values[i, j])`` and the
        kernel ``WHERE(dreg); bus(areg, IN); all`` (one transfer: it negates, as any
        ``bus``). Afterwards ``areg`` holds ``-values[r % p, c % q]`` at PE ``(r, c)``
        (saturated at 127: ``-(-128)``), ``dreg`` the last cell's pattern, ``IN`` the last
        value and FLAG is set everywhere. On a 256 x 256 array a 16 x 16 grid is 256 cells:
        768 controller calls and kernel runs, as the chip runs them.

        Parameters
        ----------
        areg : Register
            Destination, one of A-F or NEWS.
        values : numpy.ndarray of int, shape (p, q)
            DAC values in [-128, 127]; ``p``, ``q`` powers of two, at most 256 (the
            period of an 8-bit address pattern).
        dreg : Register
            The pattern's register (one of R0-R12), left holding the last cell's.

        Raises
        ------
        SimulatorError
            If ``values`` is not a 2-D integer array of such a shape and range, or the
            routine is called inside an open ``with sim.kernel()`` block.
        RegisterMisuseError
            If ``areg`` or ``dreg`` is not a register the calls take.

        Examples
        --------
        >>> import numpy as np
        >>> from ppaloc.sim import Scamp5, A, R5
        >>> sim = Scamp5(4, 4)
        >>> sim.load_in_cells(A, np.array([[1, -2], [3, 4]]), R5)
        >>> sim.read(A).astype(int)
        array([[-1,  2, -1,  2],
               [-3, -4, -3, -4],
               [-1,  2, -1,  2],
               [-3, -4, -3, -4]])
        >>> sim.timing.report().stages[0].calls
        {'load_pattern': 4, 'load_in': 4}
        """
        call = "load_in_cells"
        self._areg(call, areg)
        self._dreg(call, dreg)
        grid = _checked_values(call, values)
        self._between_kernels(call)
        p, q = grid.shape
        rx, cx = period_mask(p), period_mask(q)
        cells = np.ndindex(p, q)
        kernels = self._cell_kernels
        if kernels is None:
            kernels = self._cell_kernels = {}
        kernel = kernels.get((areg, dreg))
        if kernel is not None and grid.size > 1 and self._batched(kernel):
            steps = ("load_pattern", "load_in", kernel._counts)
            if self.noise.ideal:
                self._write_cells(areg, grid)
                self.timing.charge_rounds(steps, grid.size - 1)
                cells = [(p - 1, q - 1)]  # its calls leave dreg, IN and FLAG as they were
            else:
                clock = self.timing.rounds_clock(steps, grid.size - 1)
                if self._undecayed(float(clock.max())):
                    self._write_cells_noisy(areg, grid, clock)
                    self.timing.charge_rounds(steps, grid.size - 1)
                    cells = [(p - 1, q - 1)]
        for i, j in cells:
            self.load_pattern(dreg, i, j, rx, cx)
            self.load_in(int(grid[i, j]))
            if kernel is None:  # recorded (and run) at the first cell
                with self.kernel() as kernel:
                    kernel.WHERE(dreg)  # type: ignore[attr-defined]
                    kernel.bus(areg, IN)  # type: ignore[attr-defined]
                    kernel.all()  # type: ignore[attr-defined]
                kernels[(areg, dreg)] = kernel
            else:
                kernel.run()

    def pattern_cells(
        self, dreg: Register, cells: np.ndarray, tmp: Register, clear: bool = False
    ) -> None:
        """``dreg |= `` (``clear``: ``&= NOT``) the set cells of ``cells`` tiled with
        period ``cells.shape``, one address pattern and one kernel per set cell.

        For each set cell ``(i, j)`` of the ``p x q`` grid, in row-major order:
        ``load_pattern(tmp, i, j, period_mask(p), period_mask(q))`` and the kernel
        ``OR(dreg, tmp)`` (``clear``: ``CLR_IF(dreg, tmp)``, which leaves ``R0 = NOT
        dreg``). Afterwards ``tmp`` holds the last set cell's pattern. A host routine as
        :meth:`load_in_cells` is: a digital image written into every period of a
        register (a descriptor replicated into every node block). Observed, or where a
        digital register could decay meanwhile, the calls run one by one; otherwise all
        but the last set cell are written at once, their calls and kernel runs charged in
        order and, under noise, the droop time they let pass accounted as they would.

        Examples
        --------
        >>> import numpy as np
        >>> from ppaloc.sim import Scamp5, R5, R6
        >>> sim = Scamp5(4, 4)
        >>> sim.pattern_cells(R5, np.array([[1, 0], [0, 1]], bool), R6)
        >>> sim.read(R5).astype(int)
        array([[1, 0, 1, 0],
               [0, 1, 0, 1],
               [1, 0, 1, 0],
               [0, 1, 0, 1]])
        """
        call = "pattern_cells"
        self._dreg(call, dreg)
        self._dreg(call, tmp)
        if tmp == dreg or (clear and tmp == R0):  # refused before any call is made
            why = (
                "the pattern would overwrite the register it is ORed into"
                if tmp == dreg
                else "CLR_IF(dreg, tmp) uses R0 as its scratch"
            )
            raise RegisterMisuseError(
                f"{call}({dreg.name}, cells, {tmp.name}{', clear=True' if clear else ''}): "
                f"tmp must be another digital register: {why}"
            )
        grid = np.asarray(cells)
        if (
            grid.ndim != 2
            or grid.dtype.kind not in "biu"
            or any(n > 256 or n & (n - 1) for n in grid.shape)
        ):
            raise SimulatorError(
                f"{call}: cells of shape {grid.shape} are invalid; use a 2-D bool array "
                "whose sides are powers of two up to 256"
            )
        self._between_kernels(call)
        p, q = grid.shape
        rx, cx = period_mask(p), period_mask(q)
        order = np.flatnonzero(grid.reshape(-1).astype(bool))
        kernels = self._pattern_kernels
        if kernels is None:
            kernels = self._pattern_kernels = {}
        kernel = kernels.get((dreg, tmp, clear))
        if kernel is not None and len(order) > 1 and self._batched(kernel):
            steps = ("load_pattern", kernel._counts)
            m = len(order) - 1
            replay = True
            if not self.noise.ideal:
                clock = self.timing.rounds_clock(steps, m)
                replay = self._undecayed(float(clock.max()))
                if replay:
                    self._elapse_rounds(clock[0::2])
            if replay:
                written = np.zeros(p * q, bool)
                written[order[:-1]] = True
                self._or_cells(self._dplane(dreg), written.reshape(p, q), clear)
                self.timing.charge_rounds(steps, m)
                order = order[-1:]
        for flat in order:
            i, j = divmod(int(flat), q)
            self.load_pattern(tmp, i, j, rx, cx)
            if kernel is None:  # recorded (and run) at the first set cell
                with self.kernel() as kernel:
                    if clear:
                        kernel.CLR_IF(dreg, tmp)  # type: ignore[attr-defined]
                    else:
                        kernel.OR(dreg, tmp)  # type: ignore[attr-defined]
                kernels[(dreg, tmp, clear)] = kernel
            else:
                kernel.run()

    def _or_cells(self, plane: np.ndarray, written: np.ndarray, clear: bool) -> None:
        """``plane |=`` (``clear``: ``&= NOT``) the ``p x q`` bool grid ``written`` at the
        PEs each cell's pattern selects, the last cell's where two select one PE. A grid
        that tiles the plane goes in as ``p`` whole rows repeated down it (a 3-D view),
        not through a gather over the plane."""
        p, q = written.shape
        row_cell, col_cell, tiled = self._cells_of(p, q)
        if tiled:
            view = plane.reshape(self.rows // p, p, self.cols)
            band = np.tile(written, (1, self.cols // q))
        else:
            view = plane
            band = written.reshape(-1)[row_cell[:, None] * q + col_cell[None, :]]
            band &= (row_cell >= 0)[:, None] & (col_cell >= 0)[None, :]
        if clear:
            view &= ~band
        else:
            view |= band

    def _elapse_rounds(self, at: np.ndarray, skip: int = -1) -> np.ndarray:
        """The droop bookkeeping of elapse instants ``at`` that the routine's calls would
        make: every analogue plane but ``skip`` has its pending droop time grow by each
        interval in turn (float64 sums in that order, as
        :meth:`~ppaloc.sim.engine.Scamp5._elapse` adds them), and the last instant is
        kept. Returns the intervals (0 where no time passed). The caller has checked
        that no register can decay meanwhile (:meth:`_undecayed`)."""
        elapsed = np.diff(np.concatenate(([self._last_us], at)))
        elapsed[elapsed <= 0] = 0.0  # an interval of no time adds nothing
        if self.noise.params.decay_per_ms:
            pending = self._droop_us
            for r in range(len(pending)):
                if r != skip:
                    pending[r] = np.add.accumulate(np.concatenate(([pending[r]], elapsed)))[-1]
        self._last_us = float(at[-1])
        return elapsed

    def _between_kernels(self, call: str) -> None:
        """Refuse a routine that runs kernels of its own inside an open kernel block."""
        from ppaloc.sim.kernel import recording

        if recording(self):
            raise SimulatorError(
                f"{call} inside an open `with sim.kernel()` block: it runs kernels of its "
                "own; call it between kernels"
            )

    def _batched(self, kernel: Kernel) -> bool:
        """Whether the cells may be written at once: no observer and no call around this
        one (both receive every call), the kernel whole (no ICW dropped from a full stack)
        and run before (compiled, its counts known)."""
        return (
            not self._observers
            and self._call_frame is None
            and not kernel.dropped
            and kernel._counts is not None
        )

    def _undecayed(self, until_us: float) -> bool:
        """Whether no digital register can decay before the clock reaches ``until_us``: no
        retention modelled, or every register of R0-R12 written or refreshed within the
        retention time of it (:meth:`~ppaloc.sim.engine.Scamp5._elapse` then draws and
        changes nothing digital, so the cells' writes may be replayed without it)."""
        params = self.noise.params
        if not self._retention or not params.digital_flip_per_ms:
            return True
        return until_us - self._dtouch_low <= params.digital_retention_ms * 1e3

    def _cells_of(self, p: int, q: int) -> tuple[np.ndarray, np.ndarray, bool]:
        """Per row, per column the cell of period ``(p, q)`` that writes it last (-1:
        none), and whether they are ``r % p``, ``c % q`` (worked out once per period)."""
        index = self._cell_index
        if index is None:
            index = self._cell_index = {}
        cached = index.get((p, q))
        if cached is None:
            row_cell = np.full(self.rows, -1, np.int64)
            col_cell = np.full(self.cols, -1, np.int64)
            for i in range(p):  # later cells win, as their writes come later
                row_cell[self._pattern(i, 0, period_mask(p), 0xFF, False).row_ok] = i
            for j in range(q):
                col_cell[self._pattern(0, j, 0xFF, period_mask(q), False).col_ok] = j
            tiled = (  # every row r in cell r % p, every column c in cell c % q
                self.rows % p == 0
                and self.cols % q == 0
                and np.array_equal(row_cell, np.arange(self.rows) % p)
                and np.array_equal(col_cell, np.arange(self.cols) % q)
            )
            cached = index[(p, q)] = (row_cell, col_cell, tiled)
        return cached

    def _write_cells(self, areg: Register, grid: np.ndarray) -> None:
        """Every cell's value into ``areg`` as the kernels write it in ideal mode:
        ``clip(-v, -128, 127)`` in float32 (``-0.0`` for 0, as the negation gives), at the
        PEs the cell's pattern selects, the last cell's where two select one PE."""
        p, q = grid.shape
        row_cell, col_cell, tiled = self._cells_of(p, q)
        value = np.negative(grid.astype(np.float32))
        np.clip(value, np.float32(-128), np.float32(127), out=value)
        plane = self._aplane(areg)
        rows, cols = row_cell >= 0, col_cell >= 0
        if tiled:  # p whole rows of the grid repeated, written down the plane (a 3-D view)
            band = np.tile(value, (1, self.cols // q))
            plane.reshape(self.rows // p, p, self.cols)[...] = band[None]
        elif rows.all() and cols.all():
            plane[...] = value[row_cell][:, col_cell]
        else:
            sel = np.ix_(np.flatnonzero(rows), np.flatnonzero(cols))
            plane[sel] = value[row_cell[rows]][:, col_cell[cols]]

    def _cell_groups(self, p: int, q: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The array's flat indices grouped by the cell of period ``(p, q)`` that writes
        them last (first those no cell writes, then cell 0, 1, ... in row-major order),
        the groups' bounds in it (``p * q + 2``) and a float32 scratch of the largest
        group's length: :func:`~ppaloc.sim.hostloops.cell_writes`' arguments, made once."""
        groups = self._cell_groups_cache
        if groups is None:
            groups = self._cell_groups_cache = {}
        cached = groups.get((p, q))
        if cached is None:
            row_cell, col_cell, _ = self._cells_of(p, q)
            cell = row_cell[:, None] * q + col_cell[None, :]
            cell[(row_cell < 0)[:, None] | (col_cell < 0)[None, :]] = -1
            group = cell.reshape(-1) + 1
            order = np.argsort(group, kind="stable").astype(np.int64)
            counts = np.bincount(group, minlength=p * q + 1)
            bounds = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
            cached = groups[(p, q)] = (order, bounds, np.empty(counts.max(), np.float32))
        return cached

    def _write_cells_noisy(self, areg: Register, grid: np.ndarray, clock: np.ndarray) -> None:
        """All but the last cell of ``grid`` as their calls and kernel runs leave the
        simulator under noise, the clock not yet charged (``clock``: ``now_us`` after each
        of those charges, :meth:`~ppaloc.sim.timing.TimingModel.rounds_clock`).

        Per cell ``k`` the calls and the run would: account the droop of the time elapsed
        at ``load_pattern`` and at the kernel's start (the analogue planes' pending droop,
        float64 sums in that order), droop ``areg`` by the step of its pending time
        (``float32(decay_per_ms * us / 1000)``), take one draw ``j`` (window start, gain)
        and write ``clip((float32(v) * float32(-(1 + g_j)) + offset) + window_j)`` where
        the pattern selects. Here the draws are taken at once, each element gets its
        cell's write and then the droop steps of the cells after it (the steps before
        its write change nothing that is read again), and the pending droop and the last
        elapse instant are set as those calls leave them. The caller has checked that no
        digital register decays meanwhile (:meth:`_undecayed`); FLAG, ``dreg`` and
        ``IN`` are left to the last cell's calls, which set them whole.
        """
        p, q = grid.shape
        m = grid.size - 1
        noise = self.noise
        params = noise.params
        starts, gains = noise.take(m)
        values = grid.reshape(-1)[:m].astype(np.float32) * gains.astype(np.float32)
        # each cell's elapse instants: after load_pattern, after load_in (its kernel's)
        at = clock.reshape(m, 3)[:, :2].reshape(-1)
        i = areg.index
        elapsed = self._elapse_rounds(at, skip=i)  # the other planes sum every interval
        decay = params.decay_per_ms
        pending = self._droop_us
        if decay:
            both = elapsed.reshape(m, 2)
            start = np.zeros(m)
            start[0] = pending[i]
            us = (start + both[:, 0]) + both[:, 1]  # pending += elapsed, twice per cell
            steps = np.where(us > 0, decay * us / 1000.0, 0.0).astype(np.float32)
            pending[i] = 0.0
        else:
            steps = np.zeros(m, np.float32)
        order, bounds, buf = self._cell_groups(p, q)
        hostloops.cell_writes(
            self._a[i],
            order,
            bounds,
            values,
            noise.offsets[i],
            noise._bank,
            starts,
            steps,
            bool(decay),
            buf,
        )


def _checked_values(call: str, values: Any) -> np.ndarray:
    """``values`` as a 2-D int64 array of DAC values with a power-of-two shape."""
    grid = np.asarray(values)
    if grid.ndim != 2 or grid.dtype.kind not in "iu" or grid.size == 0:
        raise SimulatorError(
            f"{call}: values of shape {grid.shape} and dtype {grid.dtype} are invalid; "
            "use a 2-D integer array (p, q)"
        )
    for n in grid.shape:
        if n > 256 or n & (n - 1):
            raise SimulatorError(
                f"{call}: a period of {n} cells is invalid; use a power of two up to 256"
            )
    lo, hi = int(grid.min()), int(grid.max())
    if lo < -128 or hi > 127:
        bad = lo if lo < -128 else hi
        raise SimulatorError(f"{call}: value {bad} is out of range; use [-128, 127]")
    return grid.astype(np.int64)
