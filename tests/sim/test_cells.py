"""``Scamp5.load_in_cells`` against the same program written out call by call.

Without observers the routine writes all but the last cell at once (in ideal mode one
pass; under noise each cell's draw, write and the droop of the cells after it) and
charges the calls it does not make (``TimingModel.charge_rounds``); observed, or where a
digital register could decay meanwhile, it makes the calls one by one. Either way every
plane, the pending droop, the draws taken, the modelled time and energy, the stage
report, the observers' events and whatever the simulator does next must be those of the
program that makes each ``load_pattern``, ``load_in`` and kernel run itself.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim import IN, NEWS, PRESETS, R2, R3, R5, A, B, C, F, Scamp5, east
from ppaloc.sim.cells import period_mask
from ppaloc.sim.engines import available_engines
from ppaloc.sim.observe import ControllerCall, KernelRun
from ppaloc.sim.timing import TimingModel

#: Ideal, every preset, one with noise but no digital retention, one without droop, and one
#: whose registers pass their retention time within microseconds (digital decay draws
#: while the cells load: the routine makes its calls one by one).
NOISES = {
    "ideal": "ideal",
    **PRESETS,
    "typical-no-retention": replace(PRESETS["typical"], digital_retention_ms=None),
    "typical-no-droop": replace(PRESETS["typical"], decay_per_ms=0.0),
    "typical-decaying": replace(
        PRESETS["typical"], digital_retention_ms=0.002, digital_flip_per_ms=0.5
    ),
}
CALL_BY_CALL = {"typical-decaying"}
ENGINES = available_engines()


def _grid(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """DAC values with the edge cases: 0 (whose negation is -0.0) and -128 (saturates)."""
    values = rng.integers(-128, 128, shape)
    values.flat[0], values.flat[-1] = 0, -128
    return values


def _by_calls(sim: Scamp5, areg, values: np.ndarray, dreg, kernels: dict) -> None:
    """The routine's program, written out: a pattern, a DAC load and a kernel per cell."""
    p, q = values.shape
    for (i, j), v in np.ndenumerate(values):
        sim.load_pattern(dreg, i, j, period_mask(p), period_mask(q))
        sim.load_in(int(v))
        kernel = kernels.get((areg, dreg))
        if kernel is None:
            with sim.kernel() as kernel:
                kernel.WHERE(dreg)
                kernel.bus(areg, IN)
                kernel.all()
            kernels[(areg, dreg)] = kernel
        else:
            kernel.run()


def _state(sim: Scamp5) -> tuple:
    """Every plane's bytes, the droop and retention bookkeeping, the draws taken, the
    clock, the energy and the stage report."""
    report = sim.timing.report()
    return (
        sim._a.tobytes(),
        sim._d.tobytes(),
        sim._droop_us.tobytes(),
        sim._last_us,
        sim._dtouch_us.tobytes(),
        sim._dtouch_low,
        sim._in_level,
        sim.noise.draws_taken,
        sim.noise.rng.bit_generator.state["state"],
        sim.timing.now_us,
        sim.timing.energy_uj,
        sim.timing.charges,
        [(s.name, s.icws, s.kernels, s.calls, s.us, s.chip_uj, s.units) for s in report.stages],
    )


def _counting(sim: Scamp5, call: str = "load_in") -> list:
    """The arguments of every ``call`` (a controller call) the simulator makes from now on."""
    seen: list = []
    original = getattr(sim, call)

    def counted(*args, **kwargs):
        seen.append(args)
        return original(*args, **kwargs)

    setattr(sim, call, counted)
    return seen


def _run(
    noise: str,
    engine: str,
    rows: int,
    cols: int,
    shapes,
    routine: bool,
    observer=None,
    calls: list | None = None,
):
    """A seeded program around two or three loads (the first records the kernel), then a
    noisy kernel and a readout after them; the state after each step (and, in ``calls``,
    how many ``load_in`` each load made)."""
    sim = Scamp5(rows, cols, noise=NOISES[noise], seed=3, engine=engine)
    if observer is not None:
        sim.observe(observer)
    seen = _counting(sim)
    per_event = sim.timing.call_us("scan_events", 2) - sim.timing.call_us("scan_events", 1)
    sim.timing.charge_call("scan_events", 123_457.3 / per_event)  # a clock past 0.1 s: its
    # intervals are differences of large floats (rounded), which add up in their order
    rng = np.random.default_rng(7)
    for reg in (A, B, C, F):
        sim.write(reg, rng.uniform(-128, 127, (rows, cols)))
    kernels: dict = {}
    states = []
    with sim.stage("load"):
        for n, shape in enumerate(shapes):
            values = _grid(rng, shape)
            dreg = R2 if n == 2 else R5  # a second kernel, recorded among the first's runs
            sim.load_pattern(R3, n, 0, 0, 0)  # time passes: F has droop pending at the start
            if routine:
                sim.load_in_cells(F, values, dreg)
            else:
                _by_calls(sim, F, values, dreg, kernels)
            states.append(_state(sim))
            if calls is not None:
                calls.append(len(seen))
            seen.clear()
    with sim.kernel() as k:  # what follows reads F, IN and FLAG as the loads left them
        k.add(A, F, IN)
        k.movx(B, F, east)
    states.append(_state(sim))
    states.append(sim.scan_areg_8x8(A).tobytes() if rows >= 8 and cols >= 8 else None)
    return states


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("noise", NOISES)
def test_the_same_bytes_time_and_energy_as_the_calls(noise, engine):
    shapes = [(4, 4), (4, 4), (2, 2), (2, 4)]
    calls: list = []
    got = _run(noise, engine, 8, 8, shapes, True, calls=calls)
    assert got == _run(noise, engine, 8, 8, shapes, False)
    # the first load of each kernel records it (every call made); the others are written
    # at once but for the last cell's calls, unless a register may decay meanwhile
    assert calls == ([16, 16, 4, 8] if noise in CALL_BY_CALL else [16, 1, 4, 1])


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("noise", ["typical", "high"])
def test_many_cells_droop_and_draw_as_the_calls(noise, engine):
    """256 and 64 cells (the 16 x 16 and 8 x 8 places): each cell's value droops by the
    steps of every later cell's kernel, and the draws cross a batch of the noise model's
    draws (4096) on the way."""
    shapes = [(16, 16)] + [(16, 16), (8, 8)] * 14  # 4736 draws
    calls: list = []
    got = _run(noise, engine, 32, 32, shapes, True, calls=calls)
    assert got == _run(noise, engine, 32, 32, shapes, False)
    assert calls == [256, 1, 64] + [1] * 26


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("noise", ["ideal", "typical"])
def test_cells_on_an_array_the_periods_do_not_tile(noise, engine):
    """Rows beyond 256 match no 8-bit pattern, and 6 rows take period 4 once and a half:
    the rows and columns no cell selects keep their values (drooping, under noise)."""
    for rows, cols, shapes in ((260, 4, [(2, 2), (2, 2)]), (6, 5, [(4, 2), (4, 2)])):
        calls: list = []
        got = _run(noise, engine, rows, cols, shapes, True, calls=calls)
        assert got == _run(noise, engine, rows, cols, shapes, False)
        assert calls[1] == 1


@pytest.mark.parametrize("noise", ["ideal", "typical", "typical-decaying"])
def test_loads_are_written_at_once_unless_a_register_may_decay(noise):
    """The fast path is taken where it is exact (unobserved, no digital decay possible
    before the last cell) and only there; the stage report counts every call either way."""
    sim = Scamp5(8, 8, noise=NOISES[noise])
    seen = _counting(sim)
    sim.load_in_cells(F, np.arange(16).reshape(4, 4), R5)  # records the kernel
    seen.clear()
    sim.load_in_cells(F, np.arange(16).reshape(4, 4), R5)
    assert len(seen) == (16 if noise in CALL_BY_CALL else 1)
    assert sim.timing.report().stages[0].calls == {"load_pattern": 32, "load_in": 32}


def test_a_register_past_retention_later_sends_the_loads_call_by_call():
    """Typical retention (1.5 s): loads take the fast path while every register of R0-R12
    was written within it, and go call by call once the clock passes it (a register never
    written decays from then on, drawing every time the clock moves)."""
    sim = Scamp5(8, 8, noise="typical")
    seen = _counting(sim)
    values = np.arange(16).reshape(4, 4)
    sim.load_in_cells(F, values, R5)
    seen.clear()
    sim.load_in_cells(F, values, R5)
    assert len(seen) == 1
    per_event = sim.timing.call_us("scan_events", 2) - sim.timing.call_us("scan_events", 1)
    sim.timing.charge_call("scan_events", 1.6e6 / per_event)  # modelled time passes
    seen.clear()
    sim.load_in_cells(F, values, R5)
    assert sim.timing.now_us > 1.5e6 and len(seen) == 16


@pytest.mark.parametrize("noise", ["ideal", "typical"])
def test_observers_receive_every_call_and_kernel_run_in_order(noise):
    def events(routine: bool) -> list:
        seen: list = []

        def observer(sim, event):
            if isinstance(event, ControllerCall):
                seen.append((event.name, event.args, event.kwargs, event.writes))
            elif isinstance(event, KernelRun):
                seen.append(("kernel", event.instructions, event.writes))

        states = _run(noise, "numpy", 8, 8, [(2, 2), (2, 2)], routine, observer)
        return [seen, states]

    got, want = events(True), events(False)
    assert got == want
    assert [e[0] for e in got[0][1:4]] == ["load_pattern", "load_in", "kernel"]
    # two loads of 4 cells after a pattern each, a kernel, a readout
    assert len(got[0]) == 2 * (1 + 4 * 3) + 1 + 1


def test_the_values_negated_and_tiled():
    sim = Scamp5(4, 8)
    values = np.array([[0, -128, 5, 127], [1, 2, 3, 4]])
    sim.load_in_cells(A, values, R5)
    sim.load_in_cells(A, values, R5)  # the fast path
    want = np.tile(np.minimum(-values, 127), (2, 2)).astype(np.float32)
    got = sim.read(A)
    assert np.array_equal(got, want)
    plane = sim._a[A.index]  # the plane itself (sim.read gives +0.0)
    assert np.signbit(plane[0, 0]) and np.signbit(plane[2, 4])  # -0.0: the bus negates 0
    assert sim.read(R5).astype(int).tolist() == [[0] * 8, [0, 0, 0, 1] * 2] * 2
    assert sim.read(IN)[0, 0] == 4


@pytest.mark.parametrize(
    ("values", "message"),
    [
        (np.zeros((3, 4), int), "a period of 3 cells is invalid; use a power of two up to 256"),
        (np.zeros((512, 1), int), "a period of 512 cells is invalid"),
        (np.zeros(4, int), "values of shape (4,) and dtype int64 are invalid"),
        (np.zeros((2, 2)), "values of shape (2, 2) and dtype float64 are invalid"),
        (np.full((2, 2), 128), "value 128 is out of range; use [-128, 127]"),
        (np.full((2, 2), -129), "value -129 is out of range; use [-128, 127]"),
    ],
)
def test_bad_values_are_refused_before_any_call(values, message):
    sim = Scamp5(4, 4)
    with pytest.raises(SimulatorError) as err:
        sim.load_in_cells(A, values, R5)
    assert message in str(err.value)
    assert sim.timing.now_us == 0.0


def test_bad_registers_and_a_call_inside_a_kernel_are_refused():
    sim = Scamp5(4, 4)
    with pytest.raises(RegisterMisuseError, match=r"^load_in_cells: R5 is not one of A-F or NEWS$"):
        sim.load_in_cells(R5, np.zeros((2, 2), int), R5)
    with pytest.raises(RegisterMisuseError, match=r"^load_in_cells: A is not one of R0-R12$"):
        sim.load_in_cells(A, np.zeros((2, 2), int), A)
    with (
        pytest.raises(SimulatorError, match=r"inside an open `with sim\.kernel\(\)` block"),
        sim.kernel() as k,
    ):
        k.mov(A, B)
        sim.load_in_cells(NEWS, np.zeros((2, 2), int), R5)


def test_charge_rounds_is_the_charges_one_by_one():
    a, b = TimingModel(), TimingModel()
    kernel = (("analog", 3), ("digital", 2), ("dnews", 0))
    for t in (a, b):
        t.charge_call("scan_events", 7)
    with a.stage("s"):
        for _ in range(37):
            a.charge_call("load_pattern")
            a.charge_call("shift_areg")  # a call with ICWs: chip energy per call
            a.charge_kernel(kernel)
    with b.stage("s"):
        b.charge_rounds(("load_pattern", "shift_areg", kernel), 37)
    assert (a.now_us, a.energy_uj, a.charges) == (b.now_us, b.energy_uj, b.charges)
    assert a.report().stages == b.report().stages
    assert a.report().stage("s").chip_uj > 0


def test_rounds_clock_is_the_clock_after_each_charge_one_by_one():
    a, b = TimingModel(), TimingModel()
    kernel = (("analog", 1), ("digital", 2))
    for t in (a, b):
        t.charge_call("scan_events", 123.4)  # a clock whose sums round
    clock = b.rounds_clock(("load_pattern", "load_in", kernel), 50)
    assert b.now_us == a.now_us and b.charges == a.charges  # nothing charged
    seen = []
    for _ in range(50):
        for step in ("load_pattern", "load_in"):
            a.charge_call(step)
            seen.append(a.now_us)
        a.charge_kernel(kernel)
        seen.append(a.now_us)
    assert clock.tolist() == seen
    b.charge_rounds(("load_pattern", "load_in", kernel), 50)
    assert b.now_us == clock[-1] == a.now_us


# -- pattern_cells: a digital image into every period ----------------------------------


def _patterns(noise: str, engine: str, routine: bool, rows: int = 8, cols: int = 8) -> list:
    """Two clears and ORs of random cell grids (the first of each records its kernel),
    either by the routine or written out call by call; the state after each, the
    ``load_pattern`` calls each made, and what a later kernel reads."""
    sim = Scamp5(rows, cols, noise=NOISES[noise], seed=5, engine=engine)
    per_event = sim.timing.call_us("scan_events", 2) - sim.timing.call_us("scan_events", 1)
    sim.timing.charge_call("scan_events", 123_457.3 / per_event)  # a clock past 0.1 s: its
    # intervals are rounded differences of large floats, which add up in their order
    rng = np.random.default_rng(9)
    sim.write(A, rng.uniform(-100, 100, (rows, cols)))  # droop pending under noise
    seen = _counting(sim, "load_pattern")
    kernels: dict = {}
    states = []
    for clear, shape in ((False, (4, 4)), (False, (16, 16)), (True, (2, 4)), (True, (8, 8))):
        cells = rng.random(shape) < 0.5
        cells.flat[-1] = True
        seen.clear()
        if routine:
            sim.pattern_cells(R5, cells, R3, clear=clear)
        else:
            p, q = shape
            for i, j in np.argwhere(cells):
                sim.load_pattern(R3, int(i), int(j), period_mask(p), period_mask(q))
                kernel = kernels.get(clear)
                if kernel is None:
                    with sim.kernel() as kernel:
                        kernel.CLR_IF(R5, R3) if clear else kernel.OR(R5, R3)
                    kernels[clear] = kernel
                else:
                    kernel.run()
        states.append((_state(sim), len(seen), int(cells.sum())))
    with sim.kernel() as k:  # reads what the loads left: R5, and the droop of A
        k.WHERE(R5)
        k.mov(B, A)
        k.all()
    states.append(_state(sim))
    return states


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("noise", NOISES)
def test_pattern_cells_are_the_calls(noise, engine):
    got, want = _patterns(noise, engine, True), _patterns(noise, engine, False)
    assert [s[0] for s in got[:-1]] == [s[0] for s in want[:-1]]
    assert got[-1] == want[-1]
    # the second load of each kernel makes only its last cell's calls, unless a register
    # may decay meanwhile
    made = [(n, cells) for _, n, cells in got[:-1]]
    if noise in CALL_BY_CALL:
        assert made[1][0] == made[1][1] and made[3][0] == made[3][1]
    else:
        assert made[1][0] == 1 and made[3][0] == 1
    assert all(n == cells for n, cells in (made[0], made[2]))


def test_pattern_cells_on_an_array_the_periods_do_not_tile():
    got, want = (_patterns("ideal", "numpy", routine, 6, 5) for routine in (True, False))
    assert [s[0] for s in got[:-1]] == [s[0] for s in want[:-1]]
    assert got[-1] == want[-1]


def test_pattern_cells_refuses_bad_grids():
    sim = Scamp5(8, 8)
    with pytest.raises(SimulatorError, match="pattern_cells: cells of shape"):
        sim.pattern_cells(R5, np.ones((3, 4), bool), R3)
    with pytest.raises(RegisterMisuseError):
        sim.pattern_cells(A, np.ones((2, 2), bool), R3)
    with pytest.raises(SimulatorError, match="pattern_cells inside an open"), sim.kernel():
        sim.pattern_cells(R5, np.ones((2, 2), bool), R3)


@pytest.mark.parametrize(("p", "q"), [(4, 4), (2, 8), (16, 16), (3, 5), (8, 2)])
@pytest.mark.parametrize("clear", [False, True])
def test_or_cells_is_the_gather_of_each_pes_last_cell(p, q, clear):
    """``_or_cells`` (a tiling grid as rows repeated down a 3-D view, any other through a
    gather) against the gather it replaced, on random grids and planes."""
    sim = Scamp5(16, 16)
    rng = np.random.default_rng(p * 31 + q)
    for _ in range(3):
        written = rng.random((p, q)) < 0.5
        plane = rng.random((16, 16)) < 0.5
        row_cell, col_cell, _ = sim._cells_of(p, q)
        cell = row_cell[:, None] * q + col_cell[None, :]
        mask = written.reshape(-1)[cell] & (row_cell >= 0)[:, None] & (col_cell >= 0)[None, :]
        expected = plane & ~mask if clear else plane | mask
        sim._or_cells(plane, written, clear)
        assert np.array_equal(plane, expected)
