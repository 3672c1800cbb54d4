"""Plane loops of the host side: FLAG-masked writes and droop, one pass each.

The controller's DAC loads and shifts write analogue planes only where FLAG is set, and
droop steps every analogue value towards 0. In numpy a masked copy
(``np.copyto(..., where=)``) runs several times slower when FLAG changes every few
elements (as after a comparison of image data), and the droop takes two passes and a
temporary plane. Here each is one branch-free loop over the plane, compiled by numba
when it is installed (the compiled engine's dependency; imported on first use only),
else the plain numpy operations, which give the same bytes
(tests/sim/test_controller_fast.py checks one against the other). Every array is
C-contiguous (whole planes, or views of whole planes). Scalar values are passed as
Python floats and rounded to float32 inside the loops: a call from the host is a few
arguments to type, and a ``np.float32`` made per call cost as much as the typing.
"""

from __future__ import annotations

import importlib.util
from types import SimpleNamespace

import numpy as np

__all__ = [
    "all_set",
    "any_in_grid",
    "any_set",
    "cell_writes",
    "droop",
    "droop_each",
    "droop_pending",
    "fill",
    "fill_where",
    "grid",
    "have_numba",
    "load_image",
    "noisy_level",
    "noisy_shift",
    "noisy_write",
    "numpy_loops",
    "select",
    "shift",
]

_LOOPS: SimpleNamespace | None = None


def have_numba() -> bool:
    """Whether the numba loops are used (numba installed, as for ``engine="compiled"``)."""
    return importlib.util.find_spec("numba") is not None


def _loops() -> SimpleNamespace:
    global _LOOPS
    if _LOOPS is None:
        _LOOPS = _numba_loops() if have_numba() else _NUMPY
    return _LOOPS


def select(out: np.ndarray, src: np.ndarray, flag: np.ndarray) -> None:
    """``out := src`` (cast to ``out``'s float32) where ``flag``; planes of one shape."""
    _loops().select(out, src, flag)


def fill(out: np.ndarray, value: float) -> None:
    """``out := float32(value)`` everywhere (``ndarray.fill`` takes twice as long)."""
    _loops().fill(out, float(value))


def any_set(plane: np.ndarray) -> bool:
    """Whether any element of a bool plane is set (``plane.any()``)."""
    return bool(_loops().any_set(plane))


def any_in_grid(plane: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> bool:
    """Whether a bool plane is set at any ``[r, c]`` with ``rows[r] and cols[c]`` (an
    address pattern's elements), reading only the pattern's rows."""
    return bool(_loops().any_in_grid(plane, rows, cols))


def all_set(plane: np.ndarray) -> bool:
    """Whether every element of a bool plane is set (``plane.all()``)."""
    return bool(_loops().all_set(plane))


def load_image(out: np.ndarray, image: np.ndarray, offset: np.ndarray | None) -> None:
    """``out := float32(image) * 0.5 - 64`` (+ ``offset``, float32, unless None): a uint8
    image as the half-range level ``PIX`` reads, in one pass."""
    loops = _loops()
    if offset is None:
        loops.load_image(out, image, out, False)
    else:
        loops.load_image(out, image, offset, True)


def grid(out: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> None:
    """``out[r, c] := rows[r] and cols[c]`` (bool planes and vectors): an address pattern
    written row by row from its two vectors, without reading a plane."""
    _loops().grid(out, rows, cols)


def fill_where(
    out: np.ndarray, value: float, flag: np.ndarray, before: np.float32 | None = None
) -> None:
    """``out := float32(value)`` where ``flag``; with ``before`` (the droop pending on
    ``out``) the kept elements droop by it first, as :func:`droop` of the whole plane
    before the fill: one pass instead of two."""
    pre = before is not None
    _loops().fill_where(out, float(value), flag, pre, np.float32(before if pre else 0.0))


def shift(plane: np.ndarray, v: int, h: int, flag: np.ndarray, everywhere: bool) -> None:
    """``plane[r, c] := plane[r + v, c - h]`` (0 from beyond the edge) where ``flag``
    (everywhere if ``everywhere``), in place: the ideal analogue ``shift`` in one pass."""
    _loops().ideal_shift(plane, v, h, flag, everywhere, np.empty(plane.shape[1], np.float32))


def noisy_shift(
    plane: np.ndarray,
    v: int,
    h: int,
    flag: np.ndarray,
    everywhere: bool,
    offset: np.ndarray,
    window: np.ndarray,
    step: np.float32 | None,
    before: np.float32 | None = None,
) -> None:
    """A noisy ``shift`` in place, one pass: where ``flag`` (everywhere if ``everywhere``)
    ``plane[r, c] := clip((plane[r + v, c - h] + offset) + window, -128, 127)`` (0 for
    the value from beyond the edge), as :func:`noisy_write` writes the shifted plane;
    elsewhere the old value droops by ``step`` (none if None), as :func:`droop` after
    the shifted values were read. ``before``: the droop pending on ``plane`` when the
    call starts (none if None), which every old value takes first, the shifted ones
    and the kept ones, as :func:`droop` of the whole plane before the shift would."""
    droops = step is not None and not everywhere
    s = np.float32(0.0) if step is None else np.float32(step)
    pre = before is not None
    b = np.float32(before if pre else 0.0)
    buf = np.empty(plane.shape[1], np.float32)
    _loops().noisy_shift(
        plane, v, h, flag, everywhere, buf, True, offset, window, droops, s, pre, b
    )


def droop(planes: np.ndarray, step: float) -> None:
    """``planes -= clip(planes, -step, step)`` in float32."""
    _loops().droop(planes, np.float32(step))


def droop_pending(
    planes: np.ndarray,
    pending_us: np.ndarray,
    which: np.ndarray,
    decay_per_ms: float,
    dropped: np.ndarray,
) -> None:
    """Apply and clear the droop pending on ``planes[which[k]]``; clear it unapplied on
    ``planes[dropped[k]]`` (planes about to be overwritten whole), in one call.

    ``pending_us`` (float64, one per plane) is the modelled time each plane has not been
    drooped for; a plane's step is ``float32(decay_per_ms * us / 1000)``, as
    :meth:`ppaloc.sim.noise.NoiseModel.droop_step` rounds it.
    """
    _loops().droop_pending(planes, pending_us, which, float(decay_per_ms), dropped)


def droop_each(planes: np.ndarray, which: np.ndarray, steps: np.ndarray, n: int) -> None:
    """:func:`droop` of ``planes[which[k]]`` by ``steps[k]`` for ``k < n``, in one call."""
    _loops().droop_each(planes, which, steps, n)


def noisy_write(
    out: np.ndarray,
    values: np.ndarray,
    offset: np.ndarray,
    window: np.ndarray,
    flag: np.ndarray,
    everywhere: bool,
) -> None:
    """``out := clip((values + offset) + window, -128, 127)`` where ``flag`` (everywhere
    if ``everywhere``), float32: a noisy host write (``values`` may be overwritten)."""
    loops = _loops()
    loops.noisy_write(out, values, offset, window, flag, everywhere)


def noisy_level(
    out: np.ndarray,
    value: float,
    window: np.ndarray,
    flag: np.ndarray,
    everywhere: bool,
    before: np.float32 | None = None,
) -> None:
    """``out := clip(float32(value) + window, -128, 127)`` where ``flag`` (everywhere if
    ``everywhere``), float32: one DAC level written with one temporal-noise window; with
    ``before`` (the droop pending on ``out``) the kept elements droop by it first, as
    :func:`droop` of the whole plane before the write."""
    pre = before is not None
    b = np.float32(before if pre else 0.0)
    _loops().noisy_level(out, float(value), window, flag, everywhere, pre, b)


def cell_writes(
    plane: np.ndarray,
    order: np.ndarray,
    bounds: np.ndarray,
    values: np.ndarray,
    offset: np.ndarray,
    bank: np.ndarray,
    starts: np.ndarray,
    steps: np.ndarray,
    droops: bool,
    buf: np.ndarray,
) -> None:
    """Noisy cell writes into ``plane``, each followed by the droop of the cells after it.

    The elements are grouped by the cell that writes them: ``order[bounds[g]:bounds[g +
    1]]`` are the flat indices of group ``g``, group 0 the elements no cell writes and
    group ``k + 1`` those of cell ``k`` (``k < m = values.size``; the elements of later
    cells are left alone). Cell ``k`` writes ``clip((values[k] + offset) + bank[starts[k]
    + e], -128, 127)`` at its elements ``e`` (float32, :func:`noisy_write`'s order with
    the window that starts at ``starts[k]``); then, if ``droops``, the droop steps
    ``steps[k + 1:]`` apply one after the other, as :func:`droop` before each later
    cell's write (group 0: every step; a step of 0: no droop). ``buf`` is float32
    scratch of the largest group's length. The same bytes as the writes and droops one
    plane pass at a time; each group's steps run over its elements in a buffer (a loop
    that vectorises), not over the plane.
    """
    _loops().cell_writes(plane, order, bounds, values, offset, bank, starts, steps, droops, buf)


def numpy_loops() -> SimpleNamespace:
    """The plain numpy versions (used without numba; the tests' reference)."""

    def select_np(out: np.ndarray, src: np.ndarray, flag: np.ndarray) -> None:
        np.copyto(out, src, where=flag, casting="unsafe")

    def fill_np(out: np.ndarray, value: float, flag: np.ndarray, pre=False, pstep=0.0) -> None:
        if pre:  # the droop pending on the plane, then the fill: the definition
            droop_np(out, np.float32(pstep))
        np.copyto(out, np.float32(value), where=flag)

    def fill_all_np(out: np.ndarray, value: float) -> None:
        out.fill(np.float32(value))

    def any_np(plane: np.ndarray) -> bool:
        return bool(plane.any())

    def all_np(plane: np.ndarray) -> bool:
        return bool(plane.all())

    def any_in_grid_np(plane: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> bool:
        return bool(plane[rows][:, cols].any())

    def load_image_np(out, image, offset, offsets: bool) -> None:
        np.multiply(image, np.float32(0.5), out=out, casting="unsafe")
        np.subtract(out, np.float32(64.0), out=out)
        if offsets:
            np.add(out, offset, out=out)

    def grid_np(out: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> None:
        np.logical_and(rows[:, None], cols[None, :], out=out)

    scratch: dict[tuple[int, ...], np.ndarray] = {}

    def shift_np(
        plane, v, h, flag, everywhere, noisy, offset, window, droops, step, pre=False, pstep=0.0
    ) -> None:
        rows, cols = plane.shape
        if pre:  # the droop pending on the plane, then the shift: the definition
            droop_np(plane, np.float32(pstep))
        new = np.zeros_like(plane)
        r0, r1 = max(0, -v), min(rows, rows - v)
        c0, c1 = max(0, h), min(cols, cols + h)
        if r0 < r1 and c0 < c1:
            new[r0:r1, c0:c1] = plane[r0 + v : r1 + v, c0 - h : c1 - h]
        if noisy:
            if droops:  # the kept elements droop after the shifted values were read
                droop_np(plane, step)
            noisy_np(plane, new, offset, window, flag, everywhere)
        else:
            np.copyto(plane, new, where=True if everywhere else flag)

    def ideal_shift_np(plane, v, h, flag, everywhere, buf) -> None:
        shift_np(plane, v, h, flag, everywhere, False, plane, plane, False, np.float32(0))

    def noisy_shift_np(
        plane, v, h, flag, everywhere, buf, noisy, offset, window, droops, step, pre, pstep
    ):
        shift_np(plane, v, h, flag, everywhere, noisy, offset, window, droops, step, pre, pstep)

    def droop_np(planes: np.ndarray, step: np.float32) -> None:
        tmp = scratch.get(planes.shape)
        if tmp is None:
            tmp = scratch[planes.shape] = np.empty(planes.shape, dtype=np.float32)
        np.clip(planes, -step, step, out=tmp)
        np.subtract(planes, tmp, out=planes)

    def droop_each_np(planes, which, steps, n) -> None:
        for k in range(n):
            droop_np(planes[which[k]], steps[k])

    def droop_pending_np(planes, pending, which, decay, dropped) -> None:
        pending[dropped] = 0.0
        for i in which:
            us = pending[i]
            if us > 0:
                pending[i] = 0.0
                droop_np(planes[i], np.float32(decay * us / 1000.0))

    def cell_writes_np(plane, order, bounds, values, offset, bank, starts, steps, droops, buf):
        flat, off = plane.reshape(-1), offset.reshape(-1)
        m = values.size
        for g in range(m + 1):
            idx = order[bounds[g] : bounds[g + 1]]
            if idx.size == 0 or (g == 0 and not droops):
                continue
            if g == 0:
                v = flat[idx]
            else:  # noisy_np's operations on the cell's elements
                v = values[g - 1] + off[idx]
                np.add(v, bank[starts[g - 1] + idx], out=v)
                np.clip(v, np.float32(-128.0), np.float32(127.0), out=v)
            if droops:
                for j in range(g, m):
                    if steps[j]:
                        droop_np(v, steps[j])
            flat[idx] = v

    lo, hi = np.float32(-128.0), np.float32(127.0)

    def noisy_np(out, values, offset, window, flag, everywhere) -> None:
        np.add(values, offset, out=values)
        np.add(values, window, out=values)
        np.clip(values, lo, hi, out=values)
        if everywhere:
            np.copyto(out, values)
        else:
            np.copyto(out, values, where=flag)

    def noisy_level_np(out, value, window, flag, everywhere, pre=False, pstep=0.0) -> None:
        if pre:  # the droop pending on the plane, then the write: the definition
            droop_np(out, np.float32(pstep))
        new = np.clip(np.float32(value) + window, np.float32(-128), np.float32(127))
        np.copyto(out, new, where=True if everywhere else flag)

    return SimpleNamespace(
        select=select_np,
        fill=fill_all_np,
        any_set=any_np,
        all_set=all_np,
        any_in_grid=any_in_grid_np,
        grid=grid_np,
        load_image=load_image_np,
        fill_where=fill_np,
        shift=shift_np,
        ideal_shift=ideal_shift_np,
        noisy_shift=noisy_shift_np,
        droop=droop_np,
        droop_each=droop_each_np,
        noisy_level=noisy_level_np,
        noisy_write=noisy_np,
        droop_pending=droop_pending_np,
        cell_writes=cell_writes_np,
    )


_NUMPY = numpy_loops()


def _numba_loops() -> SimpleNamespace:
    """The numba versions: flat loops that read both operands and select, so they vectorise."""
    import numba

    jit = numba.njit(cache=True, nogil=True, boundscheck=False)

    @numba.njit(cache=True, nogil=True, boundscheck=False, inline="always")
    def _noisy_value(x, offset, noise):  # pragma: no cover - compiled
        v = x + offset  # float32, in noisy_write's order; clipped max, then min
        v = v + noise
        v = v if v > np.float32(-128.0) else np.float32(-128.0)
        return v if v < np.float32(127.0) else np.float32(127.0)

    @numba.njit(cache=True, nogil=True, boundscheck=False, inline="always")
    def _droop_of(x, step):  # pragma: no cover - compiled
        t = x if x > -step else -step  # numpy's clip: max, then min
        return t if t < step else step

    @jit
    def select_nb(out, src, flag):  # pragma: no cover - compiled
        n = out.size
        o = out.reshape(n)
        s = src.reshape(n)
        f = flag.reshape(n)
        for i in range(n):
            x = np.float32(s[i])
            y = o[i]
            o[i] = x if f[i] else y

    @jit
    def fill_nb(out, value, flag, pre, pstep):  # pragma: no cover - compiled
        # with pre, each kept element droops by pstep first (droop_nb's operations)
        n = out.size
        o = out.reshape(n)
        f = flag.reshape(n)
        x = np.float32(value)  # the wrappers pass a float: rounded here, once
        if pre:
            for i in range(n):
                y = o[i]
                y = y - _droop_of(y, pstep)
                o[i] = x if f[i] else y
            return
        for i in range(n):
            y = o[i]
            o[i] = x if f[i] else y

    from numba.core.cpu import CPUTargetOptions

    # row views without reference counting (numba's underscored option, long present; a
    # numba without it compiles the same code with its runtime)
    no_runtime = {"_nrt": False} if hasattr(CPUTargetOptions, "_nrt") else {}
    rows_jit = numba.njit(cache=True, nogil=True, boundscheck=False, **no_runtime)

    @numba.njit(cache=True, nogil=True, boundscheck=False, inline="always", **no_runtime)
    def _move(dst, src, fr, whole):  # pragma: no cover - compiled
        # dst := src (views of one length) where fr, or everywhere if whole
        if whole:
            for i in range(dst.size):
                dst[i] = src[i]
        else:
            for i in range(dst.size):
                x = src[i]
                y = dst[i]
                dst[i] = x if fr[i] else y

    @numba.njit(cache=True, nogil=True, boundscheck=False, inline="always", **no_runtime)
    def _clear(dst, fr, whole):  # pragma: no cover - compiled
        # dst := 0 where fr, or everywhere if whole
        zero = np.float32(0.0)
        if whole:
            for i in range(dst.size):
                dst[i] = zero
        else:
            for i in range(dst.size):
                y = dst[i]
                dst[i] = zero if fr[i] else y

    @numba.njit(cache=True, nogil=True, boundscheck=False, inline="always", **no_runtime)
    def _move_noisy(dst, src, od, wd, fr, whole, droops, step):  # pragma: no cover
        # dst := the noisy value of src where fr (everywhere if whole); elsewhere the old
        # value drooped by step if droops (the operations of noisy_write and droop)
        if whole:
            for i in range(dst.size):
                dst[i] = _noisy_value(src[i], od[i], wd[i])
        elif droops:
            for i in range(dst.size):
                x = _noisy_value(src[i], od[i], wd[i])
                y = dst[i]
                y = y - _droop_of(y, step)
                dst[i] = x if fr[i] else y
        else:
            for i in range(dst.size):
                x = _noisy_value(src[i], od[i], wd[i])
                y = dst[i]
                dst[i] = x if fr[i] else y

    @numba.njit(cache=True, nogil=True, boundscheck=False, inline="always", **no_runtime)
    def _clear_noisy(dst, od, wd, fr, whole, droops, step):  # pragma: no cover
        # _move_noisy of a source of zeros (the elements whose source lies beyond the edge)
        zero = np.float32(0.0)
        if whole:
            for i in range(dst.size):
                dst[i] = _noisy_value(zero, od[i], wd[i])
        elif droops:
            for i in range(dst.size):
                x = _noisy_value(zero, od[i], wd[i])
                y = dst[i]
                y = y - _droop_of(y, step)
                dst[i] = x if fr[i] else y
        else:
            for i in range(dst.size):
                x = _noisy_value(zero, od[i], wd[i])
                y = dst[i]
                dst[i] = x if fr[i] else y

    @numba.njit(cache=True, nogil=True, boundscheck=False, inline="always", **no_runtime)
    def _droop_row(dst, step):  # pragma: no cover - compiled
        # dst droops by step in place (droop_nb's operations, on a row)
        for i in range(dst.size):
            x = dst[i]
            dst[i] = x - _droop_of(x, step)

    @rows_jit
    def rows_shift_nb(
        plane, v, h, flag, everywhere, buf, noisy, offset, window, droops, step, pre, pstep
    ):  # pragma: no cover - compiled
        # the shift row by row: row r takes row r + v moved by h (0 from beyond the edge),
        # the rows in the order that reads every source row before it is written (a row's
        # own values, v = 0, through ``buf``, one row long); a row FLAG leaves whole is
        # skipped (noisy with droop: only drooped), one it sets whole written without a
        # select (address patterns flag whole rows). Noisy, each written element gets
        # clip((value + offset) + window) and with ``droops`` each kept one droops by
        # ``step`` after the values were read. With ``pre`` every old value first droops
        # by ``pstep`` (the droop pending when the call starts: a source row as it is
        # copied into ``buf``, a row as its turn comes, before its kept elements take
        # ``step``), as a droop pass over the plane before the shift would. Row views: no
        # reference counting, no allocation
        rows, cols = plane.shape
        c_lo, c_hi = max(0, h), min(cols, cols + h)  # the columns with a source column
        for j in range(rows):
            r = j if v > 0 else rows - 1 - j
            dst, fr = plane[r], flag[r]
            n_set = cols
            if not everywhere:
                n_set = 0
                for c in range(cols):
                    n_set += fr[c]
            if n_set == 0:
                if noisy and pre:
                    _droop_row(dst, pstep)
                if noisy and droops:
                    _droop_row(dst, step)
                continue
            whole = n_set == cols
            s = r + v
            od, wd = offset[r], window[r]
            if 0 <= s < rows:
                src = plane[s, c_lo - h : c_hi - h]
                if v == 0 or pre:  # the row's own values, or the drooped source, in buf
                    own = src
                    src = buf[: own.size]
                    for i in range(own.size):
                        src[i] = own[i]
                    if pre:
                        _droop_row(src, pstep)
                if noisy and pre and not whole:  # the kept elements' pending droop
                    _droop_row(dst, pstep)
                if noisy:
                    inner = slice(c_lo, c_hi)
                    _move_noisy(
                        dst[inner], src, od[inner], wd[inner], fr[inner], whole, droops, step
                    )
                    _clear_noisy(dst[:c_lo], od[:c_lo], wd[:c_lo], fr[:c_lo], whole, droops, step)
                    _clear_noisy(dst[c_hi:], od[c_hi:], wd[c_hi:], fr[c_hi:], whole, droops, step)
                else:
                    _move(dst[c_lo:c_hi], src, fr[c_lo:c_hi], whole)
                    _clear(dst[:c_lo], fr[:c_lo], whole)
                    _clear(dst[c_hi:], fr[c_hi:], whole)
            elif noisy:
                if pre and not whole:
                    _droop_row(dst, pstep)
                _clear_noisy(dst, od, wd, fr, whole, droops, step)
            else:
                _clear(dst, fr, whole)

    @rows_jit
    def any_in_grid_nb(plane, rows, cols):  # pragma: no cover - compiled
        found = False
        for r in range(rows.size):
            if rows[r]:
                row = plane[r]
                acc = False
                for c in range(cols.size):  # no early exit: a reduction LLVM vectorises
                    acc = acc | (row[c] & cols[c])
                found = found or acc
        return found

    @rows_jit
    def ideal_rows_shift_nb(plane, v, h, flag, everywhere, buf):  # pragma: no cover
        # rows_shift_nb's ideal case: fewer arguments for the call to pass
        zero = np.float32(0.0)
        rows_shift_nb(
            plane, v, h, flag, everywhere, buf, False, plane, plane, False, zero, False, zero
        )

    @jit
    def fill_all_nb(out, value):  # pragma: no cover - compiled
        o = out.reshape(out.size)
        x = np.float32(value)
        for i in range(o.size):
            o[i] = x

    @jit
    def any_nb(plane):  # pragma: no cover - compiled
        b = plane.reshape(plane.size).view(np.uint8)
        whole = b.size - b.size % 8
        words = b[:whole].view(np.uint64)
        acc = np.uint64(0)
        for w in range(words.size):  # no early exit: a reduction LLVM vectorises
            acc |= words[w]
        found = acc != 0
        for i in range(whole, b.size):
            found = found or b[i] != 0
        return found

    @jit
    def all_nb(plane):  # pragma: no cover - compiled
        b = plane.reshape(plane.size).view(np.uint8)
        whole = b.size - b.size % 8
        words = b[:whole].view(np.uint64)
        ones = np.uint64(0x0101010101010101)
        acc = True
        for w in range(words.size):  # no early exit: a reduction LLVM vectorises
            acc = acc & (words[w] == ones)
        for i in range(whole, b.size):
            acc = acc and b[i] != 0
        return acc

    @jit
    def load_image_nb(out, image, offset, offsets):  # pragma: no cover - compiled
        n = out.size
        o = out.reshape(n)
        img = image.reshape(n)
        off = offset.reshape(offset.size)
        half = np.float32(0.5)
        mid = np.float32(64.0)
        if offsets:  # the numpy version's operations, element by element
            for i in range(n):
                o[i] = (np.float32(img[i]) * half - mid) + off[i]
        else:
            for i in range(n):
                o[i] = np.float32(img[i]) * half - mid

    @jit
    def grid_nb(out, rows, cols):  # pragma: no cover - compiled
        n_cols = cols.size
        o = out.reshape(out.size)
        for r in range(rows.size):  # flat indices: no row view is made
            base = r * n_cols
            if rows[r]:
                for c in range(n_cols):
                    o[base + c] = cols[c]
            else:
                for c in range(n_cols):
                    o[base + c] = False

    @jit
    def droop_nb(planes, step):  # pragma: no cover - compiled
        n = planes.size
        p = planes.reshape(n)
        lo = -step
        for i in range(n):
            x = p[i]
            t = x if x > lo else lo  # numpy's clip: max, then min
            t = t if t < step else step
            p[i] = x - t

    @jit
    def droop_each_nb(planes, which, steps, n):  # pragma: no cover - compiled
        for k in range(n):
            droop_nb(planes[which[k]], steps[k])

    @jit
    def droop_pending_nb(planes, pending, which, decay, dropped):  # pragma: no cover
        for k in range(dropped.size):
            pending[dropped[k]] = 0.0
        for k in range(which.size):
            i = which[k]
            us = pending[i]
            if us > 0:
                pending[i] = 0.0
                droop_nb(planes[i], np.float32(decay * us / 1000.0))

    @jit
    def noisy_nb(out, values, offset, window, flag, everywhere):  # pragma: no cover - compiled
        n = out.size
        o = out.reshape(n)
        v = values.reshape(n)
        off = offset.reshape(n)
        win = window.reshape(n)
        f = flag.reshape(n)
        lo = np.float32(-128.0)
        hi = np.float32(127.0)
        for i in range(n):
            x = v[i] + off[i]  # float32, in the numpy version's order
            x = x + win[i]
            x = x if x > lo else lo
            x = x if x < hi else hi
            y = o[i]
            o[i] = x if everywhere or f[i] else y

    @jit
    def level_nb(out, value, window, flag, everywhere, pre, pstep):  # pragma: no cover
        # with pre (and not everywhere) each kept element droops by pstep first
        n = out.size
        o = out.reshape(n)
        win = window.reshape(n)
        f = flag.reshape(n)
        lo = np.float32(-128.0)
        hi = np.float32(127.0)
        v = np.float32(value)
        if pre and not everywhere:
            for i in range(n):
                x = v + win[i]  # float32, as the numpy version
                x = x if x > lo else lo
                x = x if x < hi else hi
                y = o[i]
                y = y - _droop_of(y, pstep)
                o[i] = x if f[i] else y
            return
        for i in range(n):
            x = v + win[i]  # float32, as the numpy version
            x = x if x > lo else lo
            x = x if x < hi else hi
            y = o[i]
            o[i] = x if everywhere or f[i] else y

    @jit
    def cell_writes_nb(plane, order, bounds, values, offset, bank, starts, steps, droops, buf):
        # pragma: no cover - compiled
        flat = plane.reshape(plane.size)
        off = offset.reshape(offset.size)
        m = values.size
        for g in range(m + 1):  # group 0: the elements no cell writes; g: cell g - 1
            lo, n = bounds[g], bounds[g + 1] - bounds[g]
            if n == 0 or (g == 0 and not droops):
                continue
            if g == 0:
                for e in range(n):
                    buf[e] = flat[order[lo + e]]
            else:
                x = values[g - 1]
                s0 = starts[g - 1]
                for e in range(n):
                    i = order[lo + e]
                    buf[e] = _noisy_value(x, off[i], bank[s0 + i])
            if droops:  # the later cells' steps, one after the other (vectorised over e)
                for j in range(g, m):
                    step = steps[j]
                    if step == 0:  # no droop at that cell
                        continue
                    for e in range(n):
                        y = buf[e]
                        buf[e] = y - _droop_of(y, step)
            for e in range(n):
                flat[order[lo + e]] = buf[e]

    return SimpleNamespace(
        select=select_nb,
        fill=fill_all_nb,
        any_set=any_nb,
        all_set=all_nb,
        grid=grid_nb,
        load_image=load_image_nb,
        fill_where=fill_nb,
        ideal_shift=ideal_rows_shift_nb,
        any_in_grid=any_in_grid_nb,
        noisy_shift=rows_shift_nb,
        droop=droop_nb,
        droop_each=droop_each_nb,
        noisy_level=level_nb,
        noisy_write=noisy_nb,
        droop_pending=droop_pending_nb,
        cell_writes=cell_writes_nb,
    )
