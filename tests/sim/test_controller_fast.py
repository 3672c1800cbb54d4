"""The controller's fast paths against the plain operations they stand for.

FLAG-masked host writes and droop (``sim.hostloops``: numba loops against the numpy
versions), the in-place ``shift``, the cached IN level and address patterns, and the
timing model's cached per-kernel and per-call costs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.sim import FLAG, IN, NEWS, R5, A, B, Scamp5, hostloops
from ppaloc.sim.noise import NoiseModel, NoiseParams
from ppaloc.sim.timing import TimingModel, evaluate_us

SHAPES = st.tuples(st.integers(1, 12), st.integers(1, 12))
VALUES = st.floats(-200, 200, width=32) | st.sampled_from([0.0, -0.0, -128.0, 127.0])


def _bits(x: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(x).view(np.uint32 if x.dtype == np.float32 else np.uint64)


@st.composite
def planes(draw, n_extra: int = 0):
    shape = draw(SHAPES)
    out = draw(arrays(np.float32, shape, elements=VALUES))
    flag = draw(arrays(np.bool_, shape))
    extra = [draw(arrays(np.float32, shape, elements=VALUES)) for _ in range(n_extra)]
    return out, flag, extra


needs_numba = pytest.mark.skipif(not hostloops.have_numba(), reason="numba not installed")


@needs_numba
@settings(max_examples=60, deadline=None)
@given(planes(n_extra=1), st.booleans())
def test_select_equals_the_masked_copy(case, wide):
    out, flag, (src,) = case
    if wide:  # a float64 source is cast to float32 as numpy casts it
        src = src.astype(np.float64) / 3
    want, got = out.copy(), out.copy()
    hostloops.numpy_loops().select(want, src, flag)
    hostloops.select(got, src, flag)
    assert np.array_equal(_bits(got), _bits(want))


@needs_numba
@settings(max_examples=80, deadline=None)
@given(planes(), st.integers(-13, 13), st.integers(-13, 13), st.booleans())
def test_shift_loop_equals_the_numpy_shift(case, v, h, everywhere):
    """The in-place numba shift (chunks read before they are written, edges after)
    against the numpy one, every offset sign and FLAG everywhere or not."""
    out, flag, _ = case
    rows, cols = out.shape
    v, h = max(-(rows - 1), min(rows - 1, v)), max(-(cols - 1), min(cols - 1, h))
    want, got = out.copy(), out.copy()
    hostloops.numpy_loops().shift(want, v, h, flag, everywhere, False, want, want, False, 0)
    hostloops.shift(got, v, h, flag, everywhere)
    assert np.array_equal(_bits(got), _bits(want))


@needs_numba
@settings(max_examples=40, deadline=None)
@given(planes(), VALUES)
def test_fill_and_any_equal_numpys(case, value):
    out, flag, _ = case
    want, got = out.copy(), out.copy()
    want.fill(np.float32(value))
    hostloops.fill(got, value)
    assert np.array_equal(_bits(got), _bits(want))
    assert hostloops.any_set(flag) == bool(flag.any())
    assert not hostloops.any_set(np.zeros_like(flag))
    assert hostloops.all_set(flag) == bool(flag.all())
    assert hostloops.all_set(np.ones_like(flag))


@needs_numba
def test_any_finds_a_lone_one_anywhere_in_a_full_plane():
    plane = np.zeros((256, 256), dtype=bool)
    assert not hostloops.any_set(plane)
    for r, c in ((0, 0), (255, 255), (100, 7), (3, 250)):
        plane[r, c] = True
        assert hostloops.any_set(plane)
        plane[r, c] = False


@needs_numba
@pytest.mark.parametrize("shape", [(256, 256), (3, 5), (1, 1)])
def test_all_finds_a_lone_zero_anywhere_in_a_set_plane(shape):
    plane = np.ones(shape, dtype=bool)
    assert hostloops.all_set(plane)
    for r, c in ((0, 0), (shape[0] - 1, shape[1] - 1), (shape[0] // 2, shape[1] // 3)):
        plane[r, c] = False
        assert not hostloops.all_set(plane) and not hostloops.numpy_loops().all_set(plane)
        plane[r, c] = True


def test_a_partial_flag_is_looked_at_once_until_a_kernel_or_a_flag_access():
    """Host calls between two kernels find a partial FLAG by one pass; a kernel run or a
    write through FLAG's plane makes the next call look again."""
    sim = Scamp5(4, 4, engine="compiled" if hostloops.have_numba() else "numpy")
    sim.write(A, np.arange(16.0).reshape(4, 4) - 8)
    with sim.kernel() as k:
        k.where(A)  # FLAG := A > 0, partial
    sim._flag_masked = None  # unknown, as after an engine that does not track it
    sim.scamp5_in(B, 5)
    assert sim._flag_partial
    assert sim.read(B)[0, 0] == 0 and sim.read(B)[3, 3] == 5
    k.run()  # FLAG may have changed: looked at again, unless the engine knows it
    assert sim._flag_partial == (sim.engine.name == "compiled")  # it tracks FLAG: partial
    assert sim.read(B)[0, 0] == 0 and sim.read(B)[3, 3] == 5
    with sim.kernel() as k2:
        k2.all()
    sim.scamp5_in(B, 7)
    assert (sim.read(B) == 7).all()
    sim._dplane(FLAG)[0, 0] = False  # a write through the plane
    assert not sim._flag_partial and sim._flag_masked is None
    sim.scamp5_in(B, 9)
    assert sim.read(B)[0, 0] == 7 and sim.read(B)[0, 1] == 9
    assert sim._flag_partial


@needs_numba
@settings(max_examples=80, deadline=None)
@given(
    planes(n_extra=2),
    st.integers(-13, 13),
    st.integers(-13, 13),
    st.booleans(),
    st.none() | st.floats(2**-10, 3, width=32),  # a step of 0 is never taken
)
def test_noisy_shift_loop_equals_droop_shift_and_noisy_write(case, v, h, everywhere, step):
    """The one-pass noisy shift against its definition: the shifted plane, the droop
    of the kept elements, then a noisy write where FLAG."""
    out, flag, (offset, window) = case
    rows, cols = out.shape
    v, h = max(-(rows - 1), min(rows - 1, v)), max(-(cols - 1), min(cols - 1, h))
    want, got = out.copy(), out.copy()
    shifted = want.copy()
    loops = hostloops.numpy_loops()
    loops.shift(shifted, v, h, flag, True, False, shifted, shifted, False, np.float32(0))
    if step is not None:
        loops.droop(want, np.float32(step))
    loops.noisy_write(want, shifted, offset, window, flag, everywhere)
    hostloops.noisy_shift(got, v, h, flag, everywhere, offset, window, step)
    assert np.array_equal(_bits(got), _bits(want))
    numpy_got = out.copy()  # and the numpy version of the same call
    s = np.float32(0) if step is None else np.float32(step)
    loops.shift(numpy_got, v, h, flag, everywhere, True, offset, window, step is not None, s)
    assert np.array_equal(_bits(numpy_got), _bits(want))


@needs_numba
@settings(max_examples=120, deadline=None)
@given(
    planes(n_extra=2),
    st.integers(-13, 13),
    st.integers(-13, 13),
    st.booleans(),
    st.none() | st.floats(2**-10, 3, width=32),
    st.floats(2**-10, 40, width=32),  # the pending droop (a step of 0 is never taken)
)
def test_noisy_shift_applies_the_pending_droop_as_a_pass_before_it(
    case, v, h, everywhere, step, before
):
    """The pending droop taken into the shift's pass (``before``): the same bytes as a
    droop pass over the whole plane, then the shift (its values read drooped, its kept
    elements drooped again by ``step``), from the numba loop and the numpy one."""
    out, flag, (offset, window) = case
    rows, cols = out.shape
    v, h = max(-(rows - 1), min(rows - 1, v)), max(-(cols - 1), min(cols - 1, h))
    want, got = out.copy(), out.copy()
    hostloops.droop(want, np.float32(before))
    hostloops.noisy_shift(want, v, h, flag, everywhere, offset, window, step)
    hostloops.noisy_shift(got, v, h, flag, everywhere, offset, window, step, np.float32(before))
    assert np.array_equal(_bits(got), _bits(want))
    numpy_got = out.copy()
    s = np.float32(0) if step is None else np.float32(step)
    droops = step is not None and not everywhere
    loops = hostloops.numpy_loops()
    loops.noisy_shift(numpy_got, v, h, flag, everywhere, None, True, offset, window, droops, s,
                      True, np.float32(before))  # fmt: skip
    assert np.array_equal(_bits(numpy_got), _bits(want))


@needs_numba
@settings(max_examples=80, deadline=None)
@given(planes(n_extra=1), VALUES, st.booleans(), st.floats(2**-10, 40, width=32))
def test_masked_levels_apply_the_pending_droop_as_a_pass_before_them(
    case, value, everywhere, before
):
    """A masked fill and a masked noisy level with the plane's pending droop in their
    pass (``before``): the bytes of a droop pass, then the write."""
    out, flag, (window,) = case
    b = np.float32(before)
    want, got = out.copy(), out.copy()
    hostloops.droop(want, b)
    hostloops.fill_where(want, value, flag)
    hostloops.fill_where(got, value, flag, b)
    assert np.array_equal(_bits(got), _bits(want))
    want, got = out.copy(), out.copy()
    if not everywhere:  # everywhere, every element is written: nothing droops
        hostloops.droop(want, b)
    hostloops.noisy_level(want, value, window, flag, everywhere)
    hostloops.noisy_level(got, value, window, flag, everywhere, None if everywhere else b)
    assert np.array_equal(_bits(got), _bits(want))
    for loops in (hostloops.numpy_loops(),):  # and the numpy versions of the same calls
        numpy_got = out.copy()
        loops.fill_where(numpy_got, value, flag, True, b)
        want = out.copy()
        hostloops.droop(want, b)
        hostloops.fill_where(want, value, flag)
        assert np.array_equal(_bits(numpy_got), _bits(want))


@needs_numba
def test_shift_loop_on_a_full_plane_crosses_its_chunks():
    """Full planes, every kind of FLAG row the row-by-row shift tells apart (none, every,
    some element of a row flagged), offsets of every sign and the array's ends, ideal and
    noisy (with and without the droop of the kept elements)."""
    rng = np.random.default_rng(3)
    row_flags = np.zeros((256, 256), dtype=bool)
    row_flags[rng.random(256) < 0.5] = True  # whole rows, as address patterns make
    row_flags[7, ::3] = True  # and a mixed row
    offsets = ((9, -3), (-9, 3), (0, 1), (0, -1), (-255, 0), (17, 250), (32, 0), (0, 0))
    for v, h in (*offsets, (-32, 32), (0, -255), (255, -255)):
        plane = rng.normal(0, 60, (256, 256)).astype(np.float32)
        for flag in (rng.random((256, 256)) < 0.5, row_flags):
            for everywhere in (True, False):
                want, got = plane.copy(), plane.copy()
                numpy_shift = hostloops.numpy_loops().shift
                numpy_shift(want, v, h, flag, everywhere, False, want, want, False, 0)
                hostloops.shift(got, v, h, flag, everywhere)
                assert np.array_equal(_bits(got), _bits(want)), (v, h, everywhere)
                offset, window = (rng.normal(0, 3, (256, 256)).astype(np.float32) for _ in "ow")
                for step in (None, np.float32(0.25)):
                    for before in (None, np.float32(0.75)):
                        want, got = plane.copy(), plane.copy()
                        droops, s = step is not None and not everywhere, np.float32(step or 0)
                        if before is not None:
                            hostloops.droop(want, before)
                        numpy_shift(want, v, h, flag, everywhere, True, offset, window, droops, s)
                        hostloops.noisy_shift(
                            got, v, h, flag, everywhere, offset, window, step, before
                        )
                        assert np.array_equal(_bits(got), _bits(want)), (v, h, step, before)


@needs_numba
@settings(max_examples=60, deadline=None)
@given(planes(), VALUES)
def test_fill_where_equals_the_masked_fill(case, value):
    out, flag, _ = case
    want, got = out.copy(), out.copy()
    hostloops.numpy_loops().fill_where(want, np.float32(value), flag)
    hostloops.fill_where(got, value, flag)
    assert np.array_equal(_bits(got), _bits(want))


@needs_numba
@settings(max_examples=60, deadline=None)
@given(planes(), st.floats(1e-6, 300))
def test_droop_equals_the_clip_and_subtract(case, step):
    out, _, _ = case
    want, got = out.copy(), out.copy()
    hostloops.numpy_loops().droop(want, np.float32(step))
    hostloops.droop(got, step)
    assert np.array_equal(_bits(got), _bits(want))


@needs_numba
@settings(max_examples=60, deadline=None)
@given(
    planes(n_extra=3),
    st.lists(st.sampled_from([0.0, 0.5, 7.0, 1234.5]), min_size=4, max_size=4),
    st.sets(st.integers(0, 3)),
    st.sets(st.integers(0, 3)),
    st.floats(0.001, 5000),
)
def test_droop_pending_equals_a_droop_per_plane(case, pending, which, dropped, decay):
    """One call that drops the pending time of some planes and droops others by theirs, as
    the numpy loops and as ``NoiseModel.droop_step`` rounds each plane's step."""
    out, _, extra = case
    stack = np.stack([out, *extra])
    which = np.array(sorted(which - dropped), dtype=np.int64)
    dropped = np.array(sorted(dropped), dtype=np.int64)
    want, got = stack.copy(), stack.copy()
    want_us, got_us = np.array(pending), np.array(pending)
    hostloops.numpy_loops().droop_pending(want, want_us, which, decay, dropped)
    hostloops.droop_pending(got, got_us, which, decay, dropped)
    assert np.array_equal(_bits(got), _bits(want))
    assert np.array_equal(got_us, want_us)
    model = NoiseModel(NoiseParams(decay_per_ms=decay), stack.shape[1:], 7)
    by_plane = stack.copy()
    for i in which:
        step = model.droop_step(pending[i])
        if step is not None:
            hostloops.numpy_loops().droop(by_plane[i], step)
    assert np.array_equal(_bits(got), _bits(by_plane))
    assert not got_us[which].any() and not got_us[dropped].any()


@needs_numba
@settings(max_examples=60, deadline=None)
@given(planes(n_extra=3), st.booleans())
def test_noisy_write_equals_add_add_clip_and_masked_copy(case, everywhere):
    out, flag, (values, offset, window) = case
    want, got = out.copy(), out.copy()
    hostloops.numpy_loops().noisy_write(want, values.copy(), offset, window, flag, everywhere)
    hostloops.noisy_write(got, values.copy(), offset, window, flag, everywhere)
    assert np.array_equal(_bits(got), _bits(want))


@settings(max_examples=60, deadline=None)
@given(
    planes(n_extra=1),
    st.integers(1, 5),
    st.data(),
    st.lists(st.sampled_from([0.0, 1e-4, 0.37, 3.0, 300.0]), min_size=5, max_size=5),
    st.booleans(),
)
def test_cell_writes_equal_a_droop_and_a_noisy_write_per_cell(case, m, data, steps, droops):
    """Each element's cell write, then the later cells' droop steps, against the plane
    passes they stand for: per cell a droop of the whole plane, then the noisy write of
    its elements (``noisy_write`` where the cell's group is); group -1 only droops, the
    elements of cell m (written after these) are left alone."""
    out, _, (offset,) = case
    size = out.size
    group = np.array(data.draw(st.lists(st.integers(-1, m), min_size=size, max_size=size)))
    bank = np.random.default_rng(m).normal(0, 40, size * 3).astype(np.float32)
    starts = np.array(data.draw(st.lists(st.integers(0, 2 * size), min_size=m, max_size=m)))
    values = np.array(data.draw(st.lists(VALUES, min_size=m, max_size=m)), np.float32)
    steps = np.array(steps[:m], np.float32)
    order = np.argsort(group + 1, kind="stable").astype(np.int64)
    counts = np.bincount(group + 1, minlength=m + 2)
    bounds = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
    buf = np.empty(max(counts.max(), 1), np.float32)
    want = out.copy()
    loops = hostloops.numpy_loops()
    for k in range(m):
        if droops and steps[k]:  # a step of 0: no droop at that cell
            loops.droop(want, steps[k])
        window = bank[starts[k] : starts[k] + size].reshape(out.shape)
        cell = (group == k).reshape(out.shape)
        loops.noisy_write(want, np.full(out.shape, values[k]), offset, window, cell, False)
    keep = (group == m).reshape(out.shape)
    want[keep] = out[keep]
    for cell_writes in (loops.cell_writes, hostloops.cell_writes):
        got = out.copy()
        cell_writes(got, order, bounds, values, offset, bank, starts, steps, droops, buf)
        assert np.array_equal(_bits(got), _bits(want))


def _plain_shift(old: np.ndarray, h: int, v: int) -> np.ndarray:
    """``new[r, c] = old[r + v, c - h]``, 0 from beyond the edge, index by index."""
    rows, cols = old.shape
    new = np.zeros_like(old)
    for r in range(rows):
        for c in range(cols):
            if 0 <= r + v < rows and 0 <= c - h < cols:
                new[r, c] = old[r + v, c - h]
    return new


@settings(max_examples=60, deadline=None)
@given(planes(), st.integers(-13, 13), st.integers(-13, 13), st.sampled_from(["host", "kernel"]))
def test_ideal_shift_writes_the_shifted_plane_where_flag(case, h, v, how):
    old, flag, _ = case
    old = np.clip(old, -128, 127)  # what a register holds
    rows, cols = old.shape
    h, v = max(-(cols - 1), min(cols - 1, h)), max(-(rows - 1), min(rows - 1, v))
    sim = Scamp5(rows, cols)
    sim.write(A, old)
    if how == "host":
        sim.write(FLAG, flag)
    else:  # FLAG from a kernel's where: the tracked state is unknown afterwards
        sim.write(B, np.where(flag, 1.0, -1.0))
        with sim.kernel() as k:
            k.where(B)
    sim.shift(A, h, v)
    want = np.where(flag, _plain_shift(old, h, v), old)
    assert np.array_equal(_bits(sim.read(A)), _bits(want + np.float32(0)))


def test_shift_with_flag_everywhere_moves_in_place():
    sim = Scamp5(3, 4)
    old = np.arange(12, dtype=np.float32).reshape(3, 4) - 6
    sim.write(A, old)
    sim.shift(A, -1, 1)  # from the south-east neighbour
    assert sim.read(A).tolist() == _plain_shift(old, -1, 1).tolist()


OPS = {
    "scamp5_in": lambda sim: sim.scamp5_in(B, 17),
    "load_in": lambda sim: sim.load_in(A, -5),
    "shift": lambda sim: sim.shift(A, 2, -1),
    "shift_west": lambda sim: sim.shift(B, -3, 0),
}


def _noisy_run(flag: np.ndarray | None, seed: int, op: str) -> Scamp5:
    sim = Scamp5(8, 8, noise="typical", seed=seed)
    sim.write(A, np.linspace(-100, 100, 64).reshape(8, 8))
    sim.write(B, np.linspace(50, -70, 64).reshape(8, 8))
    sim.load_in(7)  # some modelled time: droop pending on every plane
    if flag is not None:
        sim.write(FLAG, flag)
    OPS[op](sim)
    return sim


@settings(max_examples=20, deadline=None)
@given(arrays(np.bool_, (8, 8)), st.integers(0, 100), st.sampled_from(sorted(OPS)))
def test_noisy_host_writes_take_the_same_draws_and_obey_flag(flag, seed, op):
    """Masked or not, a noisy write takes the same draws: with FLAG partly set, each
    element equals the run with FLAG everywhere (where set) or with FLAG nowhere."""
    every = _noisy_run(None, seed, op)
    masked = _noisy_run(flag, seed, op)
    none = _noisy_run(np.zeros_like(flag), seed, op)
    for reg in (A, B, NEWS):
        want = np.where(flag, every.read(reg), none.read(reg))
        assert np.array_equal(_bits(masked.read(reg)), _bits(want)), reg


def test_in_is_driven_again_after_a_write_through_its_plane():
    sim = Scamp5(4, 4)
    sim.load_in(3)
    sim.write(IN, 7)  # through the plane: the level the controller knows is stale
    sim.load_in(3)
    assert (sim.read(IN) == 3).all()
    sim._aplane(IN)[0, 0] = 9
    sim.load_in(3)
    assert (sim.read(IN) == 3).all()


def test_address_patterns_are_cached_read_only_and_equal_fresh_ones():
    sim = Scamp5(8, 8)
    sim.load_pattern(R5, 1, 2, 0b100, 0b001)
    first = sim.read(R5)
    sim.load_pattern(R5, 1, 2, 0b100, 0b001)
    assert np.array_equal(sim.read(R5), first)
    mask = sim.address_mask(1, 2, 0b100, 0b001, False)
    assert not mask.flags.writeable
    rows, cols = np.nonzero(first)
    assert set(rows.tolist()) == {1, 5} and set(cols.tolist()) == {2, 3}


@settings(max_examples=40, deadline=None)
@given(
    SHAPES,
    st.integers(0, 255),
    st.integers(0, 255),
    st.integers(0, 255),
    st.integers(0, 255),
    st.booleans(),
)
def test_load_pattern_writes_the_address_definition_from_its_vectors(
    shape, r, c, rx, cx, scamp_addr
):
    """The pattern is written row by row from its row and column vectors (numba and
    numpy alike): the header's definition, over whatever the register held."""
    sim = Scamp5(*shape)
    sim.write(R5, np.random.default_rng(r).random(shape) < 0.5)
    sim.load_pattern(R5, r, c, rx, cx, scamp_addr=scamp_addr)
    rows, cols = np.arange(shape[0])[:, None], np.arange(shape[1])[None, :]
    if scamp_addr:
        cols = shape[1] - 1 - cols
    want = ((rows & ~rx) == (r & ~rx)) & ((cols & ~cx) == (c & ~cx))
    assert np.array_equal(sim.read(R5), want)
    pattern = sim._pattern(r, c, rx, cx, scamp_addr)
    plain = np.ones(shape, dtype=bool)
    hostloops.numpy_loops().grid(plain, pattern.row_ok, pattern.col_ok)
    assert np.array_equal(plain, want) and np.array_equal(pattern.mask, want)


@settings(max_examples=30, deadline=None)
@given(SHAPES, st.integers(0, 2**32 - 1), st.booleans())
def test_load_image_is_the_half_range_level_plus_the_offset(shape, seed, offsets):
    rng = np.random.default_rng(seed)
    image = rng.integers(0, 256, shape).astype(np.uint8)
    offset = rng.normal(0, 2, shape).astype(np.float32) if offsets else None
    want = np.multiply(image, np.float32(0.5), dtype=np.float32) - np.float32(64.0)
    if offsets:
        want = want + offset
    got, plain = np.empty(shape, np.float32), np.empty(shape, np.float32)
    hostloops.load_image(got, image, offset)
    hostloops.numpy_loops().load_image(plain, image, got if offset is None else offset, offsets)
    assert np.array_equal(_bits(got), _bits(want)) and np.array_equal(_bits(plain), _bits(want))


def test_cached_kernel_and_call_costs_equal_fresh_ones_and_follow_the_constants():
    t, fresh = TimingModel(), TimingModel()
    counts = {"analog": 7, "digital": 3, "dnews": 0, "nop": 1}
    for _ in range(3):
        t.charge_kernel(counts)
        t.charge_call("shift_areg", 5)
    for _ in range(3):
        fresh._kernel_costs.clear()
        fresh._call_costs.clear()
        fresh.charge_kernel(counts)
        fresh._call_costs.clear()
        fresh.charge_call("shift_areg", 5)
    assert (t.now_us, t.chip_uj) == (fresh.now_us, fresh.chip_uj)
    before = t.now_us
    t.constants = dataclasses.replace(t.constants, kernel_launch_us=10.0)
    t.charge_kernel(counts)
    assert t.now_us - before > 10.0
    before = t.now_us
    t.clock_hz = 1e6  # ten times slower ICWs
    t.charge_kernel({"digital": 10})
    assert t.now_us - before == pytest.approx(10.0 + 10.0)


def test_evaluate_us_cache_follows_the_constants_object():
    t = TimingModel()
    counts = {"icw:analog": 4.0, "kernels": 2.0, "calls:load_in": 3.0}
    first = evaluate_us(counts, t.constants)
    other = dataclasses.replace(t.constants, call_overhead_us=0.2)
    assert evaluate_us(counts, other) < first
    assert evaluate_us(counts, t.constants) == first


@settings(max_examples=60, deadline=None)
@given(
    arrays(np.bool_, st.tuples(st.integers(1, 9), st.integers(1, 9))),
    st.integers(1, 90),
    st.integers(0, 1),
    st.integers(0, 1),
    st.booleans(),
    st.booleans(),
)
def test_sparse_event_scan_equals_the_plane_walk(plane, n, h, v, rows_first, scamp_addr):
    from ppaloc.sim import controller

    sim = Scamp5(*plane.shape)
    sim.write(R5, plane)
    call = "scan_events_rc" if rows_first else "scan_events"
    scan = sim.scan_events_rc if rows_first else sim.scan_events
    got = scan(R5, n, h, v, scamp_addr=scamp_addr)
    saved = controller._SPARSE_EVENTS
    controller._SPARSE_EVENTS = -1  # every plane walked
    try:
        want = scan(R5, n, h, v, scamp_addr=scamp_addr)
    finally:
        controller._SPARSE_EVENTS = saved
    assert got.dtype == want.dtype == np.int64, call
    assert got.shape == want.shape and np.array_equal(got, want), call


@settings(max_examples=60, deadline=None)
@given(
    arrays(np.bool_, (8, 16)),
    st.integers(0, 255),
    st.integers(0, 255),
    st.integers(0, 255),
    st.integers(0, 255),
    st.booleans(),
)
def test_global_or_reads_the_pattern_grid(plane, r, c, rx, cx, scamp_addr):
    sim = Scamp5(8, 16)
    sim.write(R5, plane)
    mask = sim.address_mask(r, c, rx, cx, scamp_addr)
    got = sim.global_or(R5, r, c, rx, cx, scamp_addr=scamp_addr)
    assert got == int((plane & mask).any())
    pattern = sim._pattern(r, c, rx, cx, scamp_addr)
    for i in (0, r % 8 * 16 + c % 16, 127):  # a lone 1, inside or outside the pattern
        lone = np.zeros((8, 16), dtype=bool)
        lone.flat[i] = True
        sim.write(R5, lone)
        want = bool(mask.flat[i])
        assert sim.global_or(R5, r, c, rx, cx, scamp_addr=scamp_addr) == want
        plain = hostloops.numpy_loops().any_in_grid(lone, pattern.row_ok, pattern.col_ok)
        assert plain == want


@needs_numba
@settings(max_examples=60, deadline=None)
@given(planes(n_extra=1), st.integers(-128, 127), st.booleans())
def test_noisy_level_is_the_level_plus_its_window_clipped_where_flag(case, value, everywhere):
    out, flag, (window,) = case
    window = window * np.float32(2)  # some sums beyond the range, so the clip is tested
    want, got, numpy_got = out.copy(), out.copy(), out.copy()
    plain = np.clip(np.float32(value) + window, np.float32(-128), np.float32(127))
    np.copyto(want, plain, where=np.ones_like(flag) if everywhere else flag)
    hostloops.noisy_level(got, value, window, flag, everywhere)
    hostloops.numpy_loops().noisy_level(numpy_got, np.float32(value), window, flag, everywhere)
    assert np.array_equal(_bits(got), _bits(want))
    assert np.array_equal(_bits(numpy_got), _bits(want))


def test_scamp5_in_under_noise_writes_the_value_plus_one_window():
    """The error-corrected DAC load carries one temporal-noise window, no cell offset."""
    from ppaloc.sim import NEWS, A

    sim, twin = Scamp5(8, 8, noise="typical", seed=4), Scamp5(8, 8, noise="typical", seed=4)
    sim.scamp5_in(A, 40)
    window = twin.noise.window()  # the twin's next draw is the one the load took
    want = np.clip(np.float32(40) + window, np.float32(-128), np.float32(127))
    assert np.array_equal(_bits(sim.read(A)), _bits(want))
    assert not np.array_equal(sim.read(A), np.full((8, 8), 40, np.float32))
    assert np.array_equal(sim.read(NEWS), np.full((8, 8), -40, np.float32))


def test_digital_decay_after_the_clock_is_reset():
    from ppaloc.sim import NoiseParams
    from ppaloc.sim.registers import register_by_name

    params = NoiseParams(digital_retention_ms=0.5, digital_flip_per_ms=0.99)
    sim = Scamp5(8, 8, noise=params, seed=1)
    every = [register_by_name(f"R{i}") for i in range(13)]
    with sim.kernel() as refresh:
        for i in range(0, 13, 4):
            refresh.SET(*every[i : i + 4])
    with sim.kernel() as k:
        k.nop()
    for _ in range(2000):  # ~0.7 ms, every register rewritten: none past its retention
        refresh.run()
    assert sim.read(R5).all()
    sim.timing.reset()  # the clock starts again at 0, below every register's last write
    sim.SET(R5)
    for _ in range(1500):  # ~1 ms: R5 past its retention
        k.run()
    assert sim.read(R5).mean() < 0.9


@settings(max_examples=80, deadline=None)
@given(
    st.integers(0, 8),
    st.integers(0, 12),
    st.integers(0, 8),
    st.integers(0, 12),
    st.integers(1, 9),
    st.integers(1, 13),
    st.booleans(),
)
def test_scan_areg_reads_the_grid_element_by_element(r0, c0, dr, dc, rs, cs, scamp_addr):
    rows, cols = 9, 13
    r1, c1 = min(rows - 1, r0 + dr), min(cols - 1, c0 + dc)
    sim = Scamp5(rows, cols)
    plane = np.arange(rows * cols, dtype=np.float32).reshape(rows, cols) - 60
    sim.write(A, plane)
    got = sim.scan_areg(A, r0, c0, r1, c1, rs, cs, scamp_addr=scamp_addr)
    picked = sorted(cols - 1 - c if scamp_addr else c for c in range(c0, c1 + 1, cs))
    want = [[int(plane[r, c]) + 128 for c in picked] for r in range(r0, r1 + 1, rs)]
    assert got.tolist() == want
