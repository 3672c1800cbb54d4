"""Every engine against the reference engine on random ICW programs, in every noise mode.

Programs are random valid ICW sequences drawn from the op table itself (analogue and
digital registers, FLAG by where/WHERE/all, neighbour transfers, DNEWS, latches), split
into a few kernels so that droop and digital decay run between them. Every engine must
leave the same bytes in every plane: in ideal mode, with a preset whose every term is zero,
and under noise (the draws are indexed the same way on every engine).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ppaloc_tests_sim_icws import icws as shared_icws

import ppaloc.sim as s
from ppaloc.errors import SimulatorError
from ppaloc.sim import OPS, NoiseParams, Scamp5
from ppaloc.sim import engine as engine_module
from ppaloc.sim.engines import ENGINES, available_engines, default_engine
from ppaloc.sim.isa import make
from ppaloc.sim.registers import ANALOG_PLANES, DIGITAL_PLANES

ROWS, COLS = 4, 5
ANALOG_DST = [s.A, s.B, s.C, s.D, s.E, s.F, s.NEWS, s.XN, s.XE, s.XS, s.XW]
ANALOG_SRC = [*ANALOG_DST, s.PIX, s.IN]
DIGITAL_DST = [getattr(s, f"R{i}") for i in range(13)]
DIGITAL_SRC = [*DIGITAL_DST, s.FLAG, s.SELECT]
POOLS = {"analog": (ANALOG_DST, ANALOG_SRC), "digital": (DIGITAL_DST, DIGITAL_SRC)}

MODES: dict[str, str | NoiseParams] = {
    "ideal": "ideal",
    "low": "low",
    "typical": "typical",
    "high": "high",
    "zero": NoiseParams(),  # the noisy path with every term zero
    "aged": NoiseParams(  # fast droop and digital decay, to exercise both between kernels
        temporal_sd=0.5,
        decay_per_ms=2000.0,
        digital_retention_ms=0.0,
        digital_flip_per_ms=0.3,
    ),
}


def icws() -> st.SearchStrategy[tuple[str, tuple, tuple]]:
    """One valid instruction of any row of the op table, over this module's registers."""
    return shared_icws(POOLS)


programs = st.lists(st.lists(icws(), min_size=1, max_size=12), min_size=1, max_size=3)


def start_state(sim: Scamp5, seed: int) -> None:
    """Random analogue values (halves too), random bits, a random FLAG and a scene."""
    rng = np.random.default_rng(seed)
    for r in ANALOG_PLANES:
        if r is not s.PIX:
            sim.write(r, rng.integers(-128, 128, (ROWS, COLS)) / rng.choice([1, 2, 4]))
    for r in DIGITAL_PLANES:
        sim.write(r, rng.random((ROWS, COLS)) < 0.5)
    sim.set_image(rng.integers(0, 256, (ROWS, COLS), dtype=np.uint8))


def run(engine: str, mode: str, program: list, seed: int, direct: bool = False) -> Scamp5:
    sim = Scamp5(ROWS, COLS, noise=MODES[mode], seed=seed % 7, engine=engine)
    start_state(sim, seed)
    for kernel in program:
        if direct:
            for op, dsts, srcs in kernel:
                sim.icw(op, dsts, srcs)
        else:
            with sim.kernel() as k:
                for op, dsts, srcs in kernel:
                    k.icw(op, dsts, srcs)
    return sim


def same_bytes(a: Scamp5, b: Scamp5) -> None:
    assert a._a.tobytes() == b._a.tobytes(), "analogue planes differ"
    assert a._d.tobytes() == b._d.tobytes(), "digital planes differ"
    assert a._latch.tobytes() == b._latch.tobytes(), "bus latch differs"


@pytest.mark.parametrize("mode", list(MODES))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(program=programs, seed=st.integers(0, 2**16))
def test_every_engine_leaves_the_reference_bytes(mode: str, program: list, seed: int) -> None:
    ref = run("reference", mode, program, seed)
    for engine in available_engines():
        if engine != "reference":
            same_bytes(run(engine, mode, program, seed), ref)
    # direct calls run one kernel per ICW (other timing, so other droop): compare them apart
    direct = run("reference", mode, program, seed, direct=True)
    same_bytes(run(default_engine(), mode, program, seed, direct=True), direct)


needs_numba = pytest.mark.skipif("compiled" not in available_engines(), reason="no numba")
fused_programs = st.lists(st.lists(icws(), min_size=2, max_size=10), min_size=1, max_size=1)


@needs_numba
@pytest.mark.parametrize("mode", list(MODES))
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(program=fused_programs, seed=st.integers(0, 2**16))
def test_the_fused_tier_leaves_the_reference_bytes(mode: str, program: list, seed: int) -> None:
    """Random kernels with every stretch the second tier can fuse fused from the first
    run (each compiles, so fewer examples than the first tier's test)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PPALOC_FUSE_AFTER", "1")
        fused = run("compiled", mode, program, seed)
    same_bytes(fused, run("reference", mode, program, seed))


def test_engine_by_name_and_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in available_engines():
        assert Scamp5(2, 2, engine=name).engine.name == name
    with pytest.raises(SimulatorError, match="engine='fast' is not an engine: use one of"):
        Scamp5(2, 2, engine="fast")
    monkeypatch.setenv("PPALOC_ENGINE", "reference")
    assert Scamp5(2, 2).engine.name == "reference"
    monkeypatch.setenv("PPALOC_ENGINE", "nope")
    with pytest.raises(SimulatorError, match="PPALOC_ENGINE='nope' is not an engine"):
        Scamp5(2, 2)
    monkeypatch.delenv("PPALOC_ENGINE")
    assert Scamp5(2, 2).engine.name == available_engines()[-1]
    assert set(available_engines()) <= set(ENGINES)


@pytest.mark.parametrize(
    ("noise", "op", "dsts", "srcs", "path"),
    [
        ("ideal", "bus", (s.B,), (s.A, s.C), "run_direct"),
        ("ideal", "bus", (s.NEWS,), (s.A,), "run_direct"),
        ("ideal", "bus2", (s.B, s.C), (s.A,), "run_ideal"),
        ("ideal", "bus", (s.XW,), (s.A,), "run_ideal"),
        ("typical", "bus", (s.B,), (s.A, s.XE), "run_noisy"),
        ("typical", "bus3", (s.B, s.C, s.XS), (s.A,), "run_noisy"),
    ],
)
def test_each_numpy_transfer_path_is_the_reference(noise, op, dsts, srcs, path) -> None:
    """The numpy engine's three transfer builders, each on an ICW of its precondition."""
    sims = []
    for engine in ("reference", "numpy"):
        sim = Scamp5(ROWS, COLS, noise=noise, seed=3, engine=engine)
        start_state(sim, 5)
        with sim.kernel() as k:
            k.icw(op, dsts, srcs)
        k.run()
        sims.append(sim)
    assert sims[1]._compile(make(op, dsts, srcs)).__name__ == path
    same_bytes(*sims)


@pytest.mark.skipif("compiled" not in available_engines(), reason="numba is not installed")
@pytest.mark.parametrize("mode", ["ideal", "typical"])
def test_dead_scratch_writes_are_skipped_with_the_same_bytes(mode: str) -> None:
    from ppaloc.sim.engines.compiled import dead_writes

    W, R = ("bus", (s.NEWS,), (s.A,)), ("bus", (s.B,), (s.NEWS,))
    where, flag_all = ("where", (), (s.C,)), ("all", (), ())
    cases = {
        (W, W, R): [0],  # overwritten before any read
        (W, R, W, R): [1],  # NEWS read in between (B, written twice, is not)
        (W, where, W, R): [],  # FLAG may have shrunk: the second write covers less
        (W, flag_all, ("bus", (s.XE,), (s.C,)), R): [0],  # all only grows FLAG; a push too
    }
    for program, dead in cases.items():
        assert dead_writes([make(*ins) for ins in program]) == dead, program
        same_bytes(
            run("compiled", mode, [list(program)], 9), run("reference", mode, [list(program)], 9)
        )


@pytest.mark.skipif("compiled" not in available_engines(), reason="numba is not installed")
@pytest.mark.parametrize("mode", ["ideal", "typical", "aged"])
def test_dead_last_destinations_are_skipped_with_the_same_bytes(mode: str) -> None:
    """A halving's NEWS that the next ICW writes again is not written under noise; the
    kept destination keeps its draw and the ICW its gain."""
    from ppaloc.sim.engines.compiled import dead_last_destinations

    def halve(x, y):
        return ("bus2", (x, s.NEWS), (y,))

    R, where = ("bus", (s.B,), (s.NEWS,)), ("where", (), (s.C,))
    cases = {
        (halve(s.E, s.D), halve(s.D, s.E), ("bus", (s.NEWS,), (s.C,)), R): {0: 1, 1: 1},
        (halve(s.E, s.D), R): {},  # NEWS read
        (halve(s.E, s.D), where, ("bus", (s.NEWS,), (s.C,)), R): {},  # FLAG may shrink
        (("bus3", (s.A, s.E, s.NEWS), (s.D,)), ("bus2", (s.E, s.NEWS), (s.A,)), R): {0: 1},
        (("bus2", (s.NEWS, s.E), (s.D,)), ("bus", (s.NEWS,), (s.C,)), R): {},  # NEWS first
        (("bus3", (s.A, s.E, s.F), (s.D,)), ("bus", (s.F,), (s.C,)), R): {0: 2},
        (("bus2", (s.E, s.XE), (s.D,)), ("bus", (s.NEWS,), (s.C,)), R): {},  # a push
    }
    for program, kept in cases.items():
        assert dead_last_destinations([make(*ins) for ins in program]) == kept, program
        for seed in range(4):
            same_bytes(
                run("compiled", mode, [list(program)], seed),
                run("reference", mode, [list(program)], seed),
            )


def test_pending_droop_equals_droop_step_by_step() -> None:
    """A plane no kernel touches droops as much, applied at once when it is next read."""
    params = NoiseParams(decay_per_ms=40.0)
    sims = [Scamp5(ROWS, COLS, noise=params, seed=1) for _ in range(2)]
    values = np.linspace(-120, 120, ROWS * COLS).reshape(ROWS, COLS)
    for sim in sims:
        sim.write(s.A, values)
    with sims[0].kernel() as idle:
        idle.bus(s.B, s.C)
    with sims[1].kernel() as touching:
        touching.bus(s.B, s.A)
    for _ in range(50):
        idle.run()
        touching.run()
    lazy, eager = sims[0].read(s.A), sims[1].read(s.A)
    assert np.abs(lazy - values).max() > 1  # it did droop
    assert np.allclose(lazy, eager, atol=1e-4)
    assert np.all(np.abs(lazy) <= np.abs(values))  # towards 0, never past it


@pytest.mark.skipif("compiled" not in available_engines(), reason="no numba")
@pytest.mark.parametrize("fuse_after", [None, 1])
def test_a_compiled_kernel_applies_the_pending_droop_in_its_own_call(
    monkeypatch: pytest.MonkeyPatch, fuse_after: int | None
) -> None:
    """Under droop a compiled kernel applies the droop pending on its planes in its own
    call (the first tier; the fused tier's code after the simulator's call), dropping
    it for a plane it overwrites whole first; a kernel whose first ICW runs through the
    numpy engine (a blur) leaves it to the simulator's call. The reference's bytes
    either way, FLAG set everywhere or not when a kernel starts."""
    from ppaloc.sim import hostloops

    calls: list[int] = []
    pending = hostloops.droop_pending
    monkeypatch.setattr(hostloops, "droop_pending", lambda *a: calls.append(1) or pending(*a))
    params = NoiseParams(temporal_sd=0.5, decay_per_ms=300.0)
    sims = {}
    for engine in ("reference", "compiled"):
        sim = sims[engine] = Scamp5(8, 8, noise=params, seed=3, engine=engine)
        if engine == "compiled":
            sim.engine.fuse_after = fuse_after
        rng = np.random.default_rng(5)
        for r in (s.A, s.B, s.C, s.D, s.E, s.F, s.NEWS):
            sim.write(r, rng.integers(-128, 128, (8, 8)) / 2)
        kernels = []
        with sim.kernel() as k:  # D read first, E and NEWS overwritten first, C read later
            k.bus2(s.E, s.NEWS, s.D)
            k.bus2(s.D, s.NEWS, s.E)
            k.bus(s.NEWS, s.C)
            k.where(s.IN, s.D, s.NEWS)
        kernels.append(k)
        with sim.kernel() as k:  # under that FLAG: F keeps its drooped values unflagged
            k.bus(s.F, s.A, s.B)
            k.all()
        kernels.append(k)
        with sim.kernel() as k:  # its first ICW through the numpy engine
            k.blur(s.A, s.C)
            k.bus(s.B, s.A)
        kernels.append(k)
        calls.clear()
        for _ in range(4):
            for k in kernels:
                k.run()
        if engine == "compiled" and fuse_after is None:
            assert len(calls) == 4  # the blur kernel's only
    same_bytes(sims["compiled"], sims["reference"])


def test_the_reference_engine_models_every_op() -> None:
    engine = Scamp5(2, 2, engine="reference").engine
    assert [op for op in OPS if not engine.supports(op)] == []


FAST_ENGINES = [e for e in available_engines() if e != "reference"]
FAST_ENGINES += ["fused"] if "compiled" in FAST_ENGINES else []


def fast(engine: str, monkeypatch: pytest.MonkeyPatch) -> str:
    """The engine's name; "fused" is the compiled engine fusing from the first run."""
    if engine == "fused":
        monkeypatch.setenv("PPALOC_FUSE_AFTER", "1")
        return "compiled"
    return engine


@pytest.mark.parametrize("engine", FAST_ENGINES)
def test_signed_zeros_move_as_the_reference_moves_them(
    engine: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """-0.0 and 0.0 are different bytes: each neighbour read and push keeps the reference's
    (with an ICW after it, so that the fused tier has a stretch to fuse)."""
    engine = fast(engine, monkeypatch)
    values = np.array([[-0.0, 0.0, -0.0, 1.0, -0.0], [0.0, -0.0, -2.0, -0.0, 0.0]] * 2)
    after = ("bus", (s.C,), (s.B,))
    for ins in [("bus", (s.B,), (n,)) for n in (s.XN, s.XE, s.XS, s.XW)] + [
        ("bus", (p,), (s.A,)) for p in (s.XN, s.XE, s.XS, s.XW)
    ]:
        sims = []
        for name in ("reference", engine):
            sim = Scamp5(ROWS, COLS, noise="ideal", engine=name)
            sim.write(s.A, values)
            sim.write(s.NEWS, -values)
            with sim.kernel() as k:
                k.icw(*ins)
                k.icw(*after)
            sims.append(sim)
        same_bytes(*sims)


FAST_PATHS = [
    ("bus", (s.B,), (s.A,)),
    ("bus", (s.B,), (s.A, s.C)),
    ("bus2", (s.B, s.C), (s.A,)),
    ("bus2", (s.B, s.NEWS), (s.A,)),
    ("bus3", (s.B, s.C, s.D), (s.A,)),
    ("bus", (s.XE,), (s.A,)),
    ("bus", (s.XS,), (s.A,)),
    ("bus", (s.B,), (s.XN,)),
    ("bus", (s.B,), (s.XW,)),
    ("bus", (s.B,), (s.XE, s.A)),
    ("where", (), (s.A,)),
    ("where", (), (s.A, s.B)),
]


@pytest.mark.parametrize("flag_all", [True, False], ids=["flag-all", "flag-some"])
@pytest.mark.parametrize("mode", ["ideal", "typical", "zero"])
@pytest.mark.parametrize("ins", FAST_PATHS, ids=lambda i: f"{i[0]}{[r.name for r in i[1]]}")
def test_each_fast_path_is_the_reference(ins: tuple, mode: str, flag_all: bool) -> None:
    """Each ICW a fast path exists for, with FLAG set everywhere or not, in each mode."""
    for engine in available_engines():
        if engine == "reference":
            continue
        sims = []
        for name in ("reference", engine):
            sim = Scamp5(ROWS, COLS, noise=MODES[mode], seed=4, engine=name)
            start_state(sim, 11)
            if flag_all:
                sim.write(s.FLAG, np.ones((ROWS, COLS), dtype=bool))
            with sim.kernel() as k:
                k.icw(*ins)
            sims.append(sim)
        same_bytes(*sims)


def aged_run(program: list, seed: int, flag_all: bool, skip: bool) -> Scamp5:
    """``program`` under fast droop, each kernel run twice after idle time; ``skip=False``
    droops every plane a kernel touches (no plane counted as overwritten first)."""
    with pytest.MonkeyPatch.context() as mp:
        if not skip:
            mp.setattr(engine_module, "overwritten_first", lambda ins: frozenset())
        sim = Scamp5(ROWS, COLS, noise=MODES["aged"], seed=seed % 7)
        start_state(sim, seed)
        if flag_all:
            sim.write(s.FLAG, np.ones((ROWS, COLS), bool))
        with sim.kernel() as idle:  # modelled time passes; no plane is touched
            for _ in range(100):
                idle.nop()
        for kernel in program:
            idle.run()
            with sim.kernel() as k:
                for op, dsts, srcs in kernel:
                    k.icw(op, dsts, srcs)
            k.run()  # again: the first run followed a host write, this one a kernel
    return sim


@pytest.mark.parametrize("flag_all", [True, False], ids=["flag-all", "flag-some"])
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(program=programs, seed=st.integers(0, 2**16))
def test_skipping_the_droop_of_overwritten_planes_changes_no_byte(
    flag_all: bool, program: list, seed: int
) -> None:
    """A plane a kernel overwrites whole before reading it is not drooped first; the bytes
    are those of droop applied to every plane the kernel touches."""
    same_bytes(aged_run(program, seed, flag_all, True), aged_run(program, seed, flag_all, False))


@pytest.mark.parametrize(
    "kernel",
    [
        [("where", (), (s.C,)), ("bus", (s.A,), (s.B,))],  # A kept where FLAG is now 0
        [("all", (), ()), ("bus", (s.A,), (s.B,))],
        [("bus", (s.B,), (s.A,)), ("bus", (s.A,), (s.C,))],  # A read before it is written
        [("bus", (s.A,), (s.B,)), ("bus", (s.C,), (s.A,))],  # A written first: skipped
    ],
    ids=["where-first", "all-first", "read-first", "written-first"],
)
def test_droop_is_skipped_only_where_no_old_value_is_seen(kernel: list) -> None:
    # FLAG set everywhere at the start, A drooping since the host wrote it
    same_bytes(aged_run([kernel], 3, True, True), aged_run([kernel], 3, True, False))


def test_overwritten_first_names_the_planes_written_before_read() -> None:
    icw = make
    first = engine_module.overwritten_first
    assert first([icw("bus", (s.A,), (s.B,))]) == {s.A.index}
    assert first([icw("bus", (s.B,), (s.A,)), icw("bus", (s.A,), (s.C,))]) == {s.B.index}
    assert first([icw("where", (), (s.C,)), icw("bus", (s.A,), (s.B,))]) == frozenset()
    assert first([icw("bus", (s.XE,), (s.B,))]) == frozenset()  # a push: not counted
    assert first([icw("bus2", (s.A, s.C), (s.B,))]) == {s.A.index, s.C.index}
