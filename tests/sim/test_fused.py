"""The compiled engine's fused tier: passes, saturation by range, when it fuses, its cache.

Its results against the reference engine's bytes are tested on random programs in
tests/sim/test_engines.py; here are the planner's cuts, the generated code's choices and
the engine's policy.
"""

from __future__ import annotations

import numpy as np
import pytest

import ppaloc.sim as s
from ppaloc.errors import SimulatorError
from ppaloc.sim import Scamp5
from ppaloc.sim.engines import available_engines
from ppaloc.sim.isa import make

pytestmark = pytest.mark.skipif("compiled" not in available_engines(), reason="no numba")


@pytest.fixture
def fused(monkeypatch: pytest.MonkeyPatch, tmp_path):
    """The fused module with a cache folder of the test's own."""
    from ppaloc.sim.engines import fused

    monkeypatch.setenv("PPALOC_KERNEL_CACHE", str(tmp_path / "kernels"))
    return fused


def block_mean_step(direction) -> list:
    """movx(B, A, direction); add(C, A, B); divq(A, C) as ICWs: a push, then local ICWs."""
    return [
        make("bus", (direction,), (s.A,)),
        make("bus", (s.B,), (s.NEWS,)),
        make("bus", (s.NEWS,), (s.A, s.B)),
        make("bus", (s.C,), (s.NEWS,)),
        make("bus2", (s.A, s.NEWS), (s.C,)),
        make("bus", (s.A,), (s.NEWS,)),
    ]


def test_a_pass_ends_where_a_neighbour_term_would_read_what_it_wrote(fused) -> None:
    step = block_mean_step(s.XE)
    passes = fused.plan(step + step)
    # the second push reads A, which the first pass wrote: a new pass, with its pre-step
    assert [len(p.icws) for p in passes] == [6, 6]
    assert [[kind for kind, _, _ in p.pre] for p in passes] == [["push"], ["push"]]
    read = [make("bus", (s.NEWS,), (s.A,)), make("bus", (s.B,), (s.XW,))]
    assert [len(p.icws) for p in fused.plan(read)] == [1, 1]  # NEWS written, then read
    flag = [make("where", (), (s.A,)), make("bus", (s.XE,), (s.B,))]
    assert [len(p.icws) for p in fused.plan(flag)] == [1, 1]  # FLAG written, then pushed by


def test_saturation_is_written_only_where_a_value_can_leave_the_range(fused) -> None:
    def body(*icws) -> str:
        return fused.source([make(*i) for i in icws], 4, 4, noisy=False)

    copy = body(("bus", (s.B,), (s.A,)), ("nop", (), ()))
    assert "clip_hi(-" in copy and "clip(" not in copy  # -A can only exceed 127
    half = body(("bus2", (s.B, s.C), (s.A,)), ("nop", (), ()))
    assert "clip" not in half.split("def run")[1]  # A / -2 stays inside
    total = body(("bus", (s.B,), (s.A, s.C)), ("nop", (), ()))
    assert "clip(-" in total  # A + C can leave at both ends
    pixel = body(("bus", (s.B,), (s.PIX,)), ("nop", (), ()))
    assert "clip(-" in pixel  # PIX is not assumed inside the range


@pytest.mark.parametrize("mode", ["ideal", "typical"])
def test_saturated_ends_and_masks_are_the_reference_bytes(mode: str, monkeypatch) -> None:
    """Every value at the ends of the range, FLAG set in some elements, every kind of
    write the ranges reason about."""
    program = [
        ("where", (), (s.D,)),
        ("bus", (s.B,), (s.A,)),
        ("bus", (s.C,), (s.A, s.B)),
        ("bus", (s.F,), (s.A, s.D)),  # -(A + D): beyond both ends
        ("bus2", (s.E, s.NEWS), (s.F,)),
        ("bus3", (s.B, s.C, s.D), (s.A,)),
        ("all", (), ()),
        ("bus", (s.XS,), (s.A, s.C)),
        ("bus", (s.E,), (s.NEWS,)),
    ]
    sims = []
    for engine, after in (("reference", "never"), ("compiled", "1")):
        monkeypatch.setenv("PPALOC_FUSE_AFTER", after)
        sim = Scamp5(4, 6, noise=mode, seed=3, engine=engine)
        ends = np.array([[-128, 127, -0.0, 0.0, -127.5, 126.5]] * 4)
        sim.write(s.A, ends)
        sim.write(s.C, ends[:, ::-1])
        sim.write(s.D, np.array([[-128, 127, 0, 2, -3, 1]] * 4))
        with sim.kernel() as k:
            for ins in program:
                k.icw(*ins)
        k.run()
        sims.append(sim)
    ref, got = sims
    assert got._a.tobytes() == ref._a.tobytes()
    assert got._d.tobytes() == ref._d.tobytes()


def test_fuse_after_comes_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    from ppaloc.sim.engines.compiled import FUSE_AFTER, fuse_after_from_env

    monkeypatch.delenv("PPALOC_FUSE_AFTER", raising=False)
    assert fuse_after_from_env() == FUSE_AFTER
    monkeypatch.setenv("PPALOC_FUSE_AFTER", "never")
    assert fuse_after_from_env() is None
    monkeypatch.setenv("PPALOC_FUSE_AFTER", "5")
    assert fuse_after_from_env() == 5
    for bad in ("0", "-2", "soon", "²"):
        monkeypatch.setenv("PPALOC_FUSE_AFTER", bad)
        with pytest.raises(SimulatorError, match="PPALOC_FUSE_AFTER"):
            fuse_after_from_env()


def _stretch_text(fused, sim: Scamp5, kernel) -> str:
    return fused.source(list(kernel.instructions), sim.rows, sim.cols, not sim.noise.ideal)


def test_a_stretch_is_compiled_in_the_background_and_then_taken_from_the_cache(
    fused, monkeypatch: pytest.MonkeyPatch
) -> None:
    """On its nth run a stretch's fused code is compiled by another process; the stretch
    moves to it once it is there, and a later simulator takes it from the cache at once."""
    loads: list[str] = []
    real_load = fused.load
    monkeypatch.setattr(fused, "load", lambda t: loads.append(t) or real_load(t))
    monkeypatch.setenv("PPALOC_FUSE_AFTER", "3")
    sims = [Scamp5(4, 4, seed=1, engine="compiled"), Scamp5(4, 4, seed=1, engine="reference")]
    kernels = []
    for sim in sims:
        sim.write(s.A, np.arange(16).reshape(4, 4))
        with sim.kernel() as k:  # the first run
            for ins in block_mean_step(s.XS):
                k.icw(ins.op, ins.dsts, ins.srcs)
        kernels.append(k)
    text = _stretch_text(fused, sims[0], kernels[0])
    for k in kernels:
        k.run()
    assert fused.background._running is None and not fused.cached(text)  # two runs
    for k in kernels:
        k.run()  # the third: the compile starts
    assert fused.background._running.wait(timeout=300) == 0
    assert fused.cached(text) and loads == []  # compiled elsewhere, not loaded here yet
    for _ in range(40):
        for k in kernels:
            k.run()
    assert loads == [text]  # moved to the fused code
    assert sims[0]._a.tobytes() == sims[1]._a.tobytes()
    monkeypatch.setenv("PPALOC_FUSE_AFTER", "1000")
    again = Scamp5(4, 4, seed=1, engine="compiled")
    with again.kernel() as k2:  # cached: fused on the first run, whatever fuse_after says
        for ins in block_mean_step(s.XS):
            k2.icw(ins.op, ins.dsts, ins.srcs)
    assert loads == [text, text]


def test_a_waiting_stretch_looks_for_the_files_cached_and_failed_read(fused) -> None:
    """The marks a stretch waiting for its code looks for every 16 runs (as text, one
    ``os.path.exists`` each) are the files :func:`cached` and :func:`failed` read."""
    import pathlib

    text = "x = 1\n"
    done, failed = fused.marks(text)
    assert not fused.cached(text) and not fused.failed(text)
    pathlib.Path(done).parent.mkdir(parents=True, exist_ok=True)
    pathlib.Path(done).touch()
    assert fused.cached(text) and not fused.failed(text)
    pathlib.Path(failed).touch()
    assert fused.failed(text)


def test_a_cache_folder_that_cannot_be_written_compiles_in_memory(
    monkeypatch: pytest.MonkeyPatch, tmp_path
) -> None:
    from ppaloc.sim.engines import fused

    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("PPALOC_KERNEL_CACHE", str(blocker / "kernels"))
    sims = []
    for after in ("never", "1"):
        monkeypatch.setenv("PPALOC_FUSE_AFTER", after)
        sim = Scamp5(4, 4, seed=2, engine="compiled")
        sim.write(s.A, np.arange(16).reshape(4, 4) - 8)
        with sim.kernel() as k:
            for ins in block_mean_step(s.XW):
                k.icw(ins.op, ins.dsts, ins.srcs)
        sims.append(sim)
    assert sims[0]._a.tobytes() == sims[1]._a.tobytes()
    assert not fused.cached(_stretch_text(fused, sims[1], k))


@pytest.mark.parametrize("slow", ["fused", "first"])
def test_after_a_trial_of_both_tiers_a_stretch_keeps_the_faster(
    slow: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    import time

    from ppaloc.sim.engines.compiled import CompiledEngine

    calls = {"fused": 0, "first": 0}
    real = {"fused": CompiledEngine._fused, "first": CompiledEngine._segment}

    def counted(which: str):
        def build(self, *args):
            inner = real[which](self, *args)

            def run() -> None:
                calls[which] += 1
                if which == slow:
                    time.sleep(0.002)
                inner()

            return run

        return build

    monkeypatch.setattr(CompiledEngine, "_fused", counted("fused"))
    monkeypatch.setattr(CompiledEngine, "_segment", counted("first"))
    monkeypatch.setenv("PPALOC_FUSE_AFTER", "1")
    sim = Scamp5(4, 4, seed=1, engine="compiled")
    with sim.kernel() as k:
        for ins in block_mean_step(s.XE):
            k.icw(ins.op, ins.dsts, ins.srcs)
    trial = CompiledEngine.TRIAL_RUNS
    for _ in range(2 * trial + 9):  # the trial (the recording run is its first), then 10
        k.run()
    fast = "first" if slow == "fused" else "fused"
    assert calls[slow] == trial and calls[fast] == trial + 10


@pytest.mark.parametrize("noise", ["ideal", "typical"])
def test_a_stretch_of_only_nops_fuses_into_no_loop(fused, noise, monkeypatch) -> None:
    """Two nops are a fusable stretch; their pass touches nothing, so it has no loop (an
    empty loop is not valid Python) and the kernel leaves the reference's bytes."""
    monkeypatch.setenv("PPALOC_FUSE_AFTER", "1")
    nops = [("nop", (), ()), ("nop", (), ())]
    assert "for p" not in fused.source([make(*i) for i in nops], 4, 5, noisy=noise != "ideal")
    sims = []
    for engine in ("reference", "compiled"):
        sim = Scamp5(4, 5, noise=noise, seed=2, engine=engine)
        sim.write(s.A, np.arange(20.0).reshape(4, 5))
        with sim.kernel() as k:
            k.icw("bus", (s.B,), (s.A,))
            for icw in nops:
                k.icw(*icw)
        sims.append(sim)
    assert sims[0]._a.tobytes() == sims[1]._a.tobytes()


@pytest.mark.parametrize("noise", ["ideal", "typical"])
def test_a_stretch_numba_cannot_compile_here_runs_on_the_first_tier(
    fused, noise, monkeypatch, caplog
) -> None:
    """With ``fuse_after`` 1 a stretch is compiled in this process; where numba cannot
    compile it (a stretch of about a thousand ICWs ends in a RecursionError in numba's
    analysis) the kernel still runs, on the first tier, with the reference's bytes, the
    stretch is marked failed, and a later simulator does not try it again."""
    from ppaloc.sim.engines.compiled import CompiledEngine

    tried = []

    def unable(text):
        tried.append(text)

        def run(*args):
            raise RecursionError("maximum recursion depth exceeded")

        return run

    monkeypatch.setattr(fused, "load", unable)
    monkeypatch.setenv("PPALOC_FUSE_AFTER", "1")
    built = []
    real = CompiledEngine._fused
    monkeypatch.setattr(
        CompiledEngine, "_fused", lambda self, *a: built.append(1) or real(self, *a)
    )
    sims = []
    for engine in ("reference", "compiled", "compiled"):
        sim = Scamp5(6, 7, noise=noise, seed=3, engine=engine)
        sim.write(s.A, np.arange(42.0).reshape(6, 7) - 20)
        with sim.kernel() as k:
            for ins in block_mean_step(s.XE):
                k.icw(ins.op, ins.dsts, ins.srcs)
        for _ in range(3):
            k.run()
        sims.append(sim)
    assert sims[0]._a.tobytes() == sims[1]._a.tobytes() == sims[2]._a.tobytes()
    assert len(tried) == 1 and not built  # the second simulator read the failed mark
    assert fused.failed(tried[0]) and not fused.cached(tried[0])
    assert "could not be compiled (RecursionError)" in caplog.text


def test_a_module_that_fails_to_load_leaves_nothing_behind(fused, monkeypatch) -> None:
    """A generated module whose import fails raises its own error every time, not a
    missing ``run`` of a half-made module left in sys.modules."""
    import sys

    text = "raise ValueError('broken on purpose')\n"
    for _ in range(2):
        with pytest.raises(ValueError, match="broken on purpose"):
            fused.load(text)
    assert fused._name(text) not in sys.modules


def _neighbour_stretch(seed: int) -> list:
    """A random fusable stretch of many passes: pushes and reads in every direction (each
    reading what the ICW before wrote, so each starts a pass), local sums and halvings,
    and now and then a FLAG change, which ends a group of passes."""
    rng = np.random.default_rng(seed)
    planes = [s.A, s.B, s.C, s.D]
    out = []
    for _ in range(14):
        x, y = rng.choice(len(planes), 2, replace=False)
        a, b = planes[x], planes[y]
        direction = [s.XN, s.XS, s.XE, s.XW][rng.integers(4)]
        kind = rng.integers(9)
        if kind == 0:  # a push of a plane the pass may have written, then its use
            out += [make("bus", (direction,), (a,)), make("bus", (b,), (s.NEWS,))]
        elif kind == 1:  # NEWS written, then a neighbour's read
            out += [make("bus", (s.NEWS,), (a,)), make("bus", (b,), (direction, a))]
        elif kind == 2:
            out += [make("bus", (s.NEWS,), (a, b)), make("bus2", (a, b), (s.NEWS,))]
        elif kind == 3:
            out += [make("bus", (b,), (a,)), make("bus", (s.NEWS,), (b, a))]
        elif kind == 4:
            out += [make("bus", (b,), (direction,)), make("bus", (s.NEWS,), (b,))]
        elif kind < 8:
            out += [make("bus", (s.NEWS,), (a,)), make("bus", (b,), (direction,))]
        else:
            out += [make("where", (), (a,)) if rng.integers(2) else make("all", (), ())]
    return out


@pytest.mark.parametrize(
    ("rows", "cols", "mode", "seed"),
    [(7, 5, "ideal", 1), (6, 9, "typical", 2), (1, 6, "ideal", 3), (5, 1, "ideal", 4),
     (2, 3, "typical", 5), (9, 4, "ideal", 6)],
)  # fmt: skip
def test_passes_run_row_by_row_leave_the_reference_bytes(
    fused, rows: int, cols: int, mode: str, seed: int, monkeypatch
) -> None:
    """Groups of passes run as a wavefront over rows (each neighbour term keeping three
    rows): vertical terms in both directions, edges, one-row and one-column arrays, FLAG
    partial at the start or set by the stretch."""
    program = _neighbour_stretch(seed)
    groups = fused.groups(fused.plan(program))
    assert len(groups) < len(fused.plan(program))  # passes do run together
    assert any(any(r.direction.offset[0] for _, _, r in ps.pre) for g in groups for ps in g)
    sims = []
    for engine, after in (("reference", "never"), ("compiled", "1")):
        monkeypatch.setenv("PPALOC_FUSE_AFTER", after)
        sim = Scamp5(rows, cols, noise=mode, seed=seed, engine=engine)
        rng = np.random.default_rng(seed)
        for plane in (s.A, s.B, s.C, s.D, s.NEWS):
            sim.write(plane, rng.integers(-128, 128, (rows, cols)) / rng.choice([1, 2]))
        sim.write(s.FLAG, rng.random((rows, cols)) < 0.7 if seed % 2 else np.ones((rows, cols)))
        with sim.kernel() as k:
            for ins in program:
                k.icw(ins.op, ins.dsts, ins.srcs)
        k.run()
        sims.append(sim)
    ref, got = sims
    assert got._a.tobytes() == ref._a.tobytes()
    assert got._d.tobytes() == ref._d.tobytes()


@pytest.mark.parametrize("flag", ["partial", "full"])
def test_a_write_overwritten_by_a_later_pass_is_stored_only_when_needed(
    fused, flag: str, monkeypatch
) -> None:
    """C written in one pass and overwritten in the next, which reads no C: with FLAG set
    everywhere the first write need not reach memory; under a partial FLAG the second
    write keeps it where FLAG is 0, so it must."""
    program = [
        make("bus", (s.C,), (s.A,)),
        make("bus", (s.NEWS,), (s.A,)),
        make("bus", (s.B,), (s.XE,)),  # reads the NEWS just written: a second pass
        make("bus", (s.C,), (s.B,)),
    ]
    (group,) = fused.groups(fused.plan(program))
    assert fused._unstored(group, [True, True])[0] == {s.C.index}
    assert fused._unstored(group, [False, False])[0] == frozenset()
    sims = []
    for engine, after in (("reference", "never"), ("compiled", "1")):
        monkeypatch.setenv("PPALOC_FUSE_AFTER", after)
        sim = Scamp5(4, 5, seed=1, engine=engine)
        rng = np.random.default_rng(0)
        for plane in (s.A, s.B, s.C):
            sim.write(plane, rng.integers(-128, 128, (4, 5)))
        if flag == "partial":
            sim.write(s.FLAG, rng.random((4, 5)) < 0.5)
        with sim.kernel() as k:
            for ins in program:
                k.icw(ins.op, ins.dsts, ins.srcs)
        sims.append(sim)
    assert sims[1]._a.tobytes() == sims[0]._a.tobytes()
