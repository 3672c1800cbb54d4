"""Kernel recording, the 1024-ICW limit, replay and clock-class counts."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ppaloc.errors import KernelError
from ppaloc.sim import (
    MAX_ICWS,
    NEWS,
    R1,
    R2,
    R3,
    R5,
    R6,
    R7,
    A,
    B,
    C,
    D,
    E,
    F,
    IcwStackWarning,
    NoiseParams,
    Scamp5,
    east,
    north,
)
from ppaloc.sim.engines import available_engines


def program(k) -> None:
    k.get_image(A, B)
    k.movx(C, A, east)
    k.sub(D, A, C)
    k.where(D)
    k.mov(C, A)
    k.all()
    k.SET(R5)
    k.NOT(R6, R5)
    k.DNEWS(R7, R5, north)


def fresh(noise: str = "ideal", seed: int = 3) -> Scamp5:
    sim = Scamp5(rows=6, cols=7, noise=noise, seed=seed)
    img = np.random.default_rng(0).integers(0, 256, (6, 7), dtype=np.uint8)
    sim.set_image(img)
    return sim


def planes(sim: Scamp5) -> list[np.ndarray]:
    return [sim._a.copy(), sim._d.copy()]


def test_kernel_runs_once_at_exit_and_counts_clock_classes() -> None:
    sim = fresh()
    with sim.kernel() as k:
        program(k)
        with pytest.raises(KernelError, match=r"^sim.read\(A\) inside an open .* has not run yet"):
            sim.read(A)  # recorded, not yet run: the old plane would mislead
    assert sim.read(A).any()
    with pytest.raises(ZeroDivisionError), sim.kernel():
        1 / 0  # noqa: B018
    sim.read(A)  # a failed recording closes its block too
    assert len(k) == 6 + 2 + 2 + 1 + 2 + 1 + 1 + 1 + 3
    assert k.counts == {"analog": 13, "digital": 4, "dnews": 1, "nop": 1}
    assert "movx(C, A, east)" in k.listing()


@pytest.mark.parametrize("noise", ["ideal", "typical"])
def test_replay_equals_re_recording(noise: str) -> None:
    a, b = fresh(noise), fresh(noise)
    with a.kernel() as k:
        program(k)
    for _ in range(3):
        a.set_image(np.full((6, 7), 77, dtype=np.uint8))
        k.run()
    with b.kernel() as k2:
        program(k2)
    for _ in range(3):
        b.set_image(np.full((6, 7), 77, dtype=np.uint8))
        with b.kernel() as k3:
            program(k3)
    for pa, pb in zip(planes(a), planes(b), strict=True):
        assert np.array_equal(pa, pb)
    a.run(k)  # sim.run is k.run
    assert not np.array_equal(planes(a)[0], planes(b)[0]) or noise == "ideal"


def test_every_run_is_charged_to_the_timing_model() -> None:
    sim = fresh()
    with sim.stage("recorded"), sim.kernel() as k:
        program(k)
    with sim.stage("replayed"):
        k.run()
    with sim.stage("direct"):
        sim.mov(A, B)  # a direct call is a kernel of its own
    report = sim.timing.report()
    nonzero = {c: n for c, n in k.counts.items() if n}
    assert [(report.stage(s).kernels, report.stage(s).icws) for s in ("recorded", "replayed")] == [
        (1, nonzero),
        (1, nonzero),
    ]
    assert (report.stage("direct").kernels, report.stage("direct").icws) == (1, {"analog": 2})
    assert sim.timing.now_us == pytest.approx(sum(r.us for r in report.stages))
    assert report.stage("recorded").us == report.stage("replayed").us > 0


def test_the_icw_stack_drops_what_does_not_fit() -> None:
    sim = fresh()
    with (
        pytest.warns(IcwStackWarning, match=r"^this kernel lost 1 of its 1025 ICWs: the 1024-ICW"),
        sim.kernel() as k,
    ):
        for _ in range(MAX_ICWS // 2):
            k.mov(A, B)
        k.nop()
    assert len(k) == MAX_ICWS and k.dropped == 1  # the library drops the overflowing ICW
    assert "1 dropped (ICW stack full)" in repr(k)
    del k  # a freed kernel leaves the stack
    with sim.kernel() as k:
        for _ in range(MAX_ICWS):
            k.nop()
    assert len(k) == MAX_ICWS and k.dropped == 0


def test_kernel_misuse() -> None:
    sim, other = fresh(), fresh()
    with sim.kernel() as k:
        k.nop()
    with pytest.raises(KernelError, match=r"only inside its `with sim\.kernel"):
        k.mov(A, B)
    with pytest.raises(KernelError, match="already recorded"):
        with k:
            pass
    with pytest.raises(KernelError, match="recorded on another Scamp5"):
        other.run(k)
    with pytest.raises(KernelError, match=r"sim\.run needs a Kernel recorded with .*, got list"):
        sim.run([k])
    k2 = sim.kernel()
    with pytest.raises(KernelError, match=r"runs after its `with` block"):
        k2.run()


def test_exception_inside_the_block_does_not_run() -> None:
    sim = fresh()
    with pytest.raises(ZeroDivisionError), sim.kernel() as k:
        k.mov(C, A)
        k.get_image(A, B)
        1 / 0  # noqa: B018
    assert not sim.read(A).any() and not sim.read(NEWS).any()


def test_repr_and_iteration() -> None:
    sim = fresh()
    with sim.kernel() as k:
        k.mov(A, B)
        assert "recording" in repr(k)
    assert repr(k) == "Kernel(2 ICWs, recorded, {'analog': 2, 'digital': 0, 'dnews': 0, 'nop': 0})"
    assert [str(i) for i in k] == ["bus(NEWS, B)", "bus(A, NEWS)"]
    assert all(i.origin == "mov(A, B)" for i in k.instructions)


def test_a_kernel_whose_recording_failed_cannot_be_reused() -> None:
    sim = fresh()
    k = sim.kernel()
    with pytest.raises(ZeroDivisionError), k:
        k.mov(C, A)
        1 / 0  # noqa: B018
    with pytest.raises(KernelError, match=r"recording of this kernel failed; record a new one"):
        with k:
            k.nop()
    with pytest.raises(KernelError, match=r"recording of this kernel failed"):
        k.run()
    assert len(k) == 2  # what was recorded before the failure, for inspection


def test_a_replay_is_charged_at_the_costs_of_its_run() -> None:
    """A kernel's cost is bound once for its runs while nothing observes the simulator;
    a change of the clock or the constants since is charged as the observed run charges
    it (``TimingModel.charge_kernel``)."""
    sims = [fresh(), fresh()]
    sims[1].observe(lambda sim, event: None)  # runs through Scamp5._run_ops
    for sim in sims:
        with sim.kernel() as k:
            program(k)
        sim.timing.clock_hz = 5e6
        k.run()
        sim.timing.constants = dataclasses.replace(sim.timing.constants, kernel_launch_us=2.0)
        k.run()
        sim.timing.reset()
        k.run()
    plain, observed = (sim.timing for sim in sims)
    assert plain.report().as_dict() == observed.report().as_dict()
    assert (plain.now_us, plain.energy_uj) == (observed.now_us, observed.energy_uj)
    assert plain.report().stages[0].kernels == 1


#: Noise whose digital registers decay a few microseconds after their last write (the
#: kernel runs' digital writes restart their retention: Scamp5._touch_digital).
RETAINING = NoiseParams(
    temporal_sd=0.3, decay_per_ms=50.0, digital_retention_ms=0.002, digital_flip_per_ms=0.9
)


@pytest.mark.parametrize("engine", available_engines())
@pytest.mark.parametrize("noise", ["ideal", "typical", RETAINING], ids=["ideal", "typical", "ret"])
def test_an_unobserved_replay_leaves_what_an_observed_replay_does(engine, noise) -> None:
    """Replays through the runner bound at compile time (nothing observes) and through
    ``Scamp5._run_ops`` (an observer attached): the same planes, droop, draws, digital
    writes' times and decay, clock and report, a folding kernel's fills and a FLAG left
    partial included."""

    def play(observed: bool) -> list:
        sim = Scamp5(8, 8, noise=noise, seed=1, engine=engine)
        if observed:
            sim.observe(lambda sim, event: None)
        rng = np.random.default_rng(5)
        for reg in (A, B, C, D):
            sim.write(reg, rng.integers(-100, 100, (8, 8)))
        for reg in (R1, R2, R3, R5):
            sim.write(reg, rng.random((8, 8)) < 0.5)
        with sim.kernel() as digital:
            digital.OR(R1, R2, R3)
        with sim.kernel() as analogue:  # a halving of a DAC level first: it folds
            analogue.bus2(E, NEWS, D)
            analogue.add(F, E, C)
            analogue.WHERE(R5)
            analogue.bus(B, F)
        for i in range(40):
            sim.scamp5_in(D, (7, -3, 0, 7)[i % 4])
            (digital if i % 2 else analogue).run()
        report = sim.timing.report()
        return [
            sim._a.tobytes(),
            sim._d.tobytes(),
            sim._latch.tobytes(),
            sim._droop_us.tobytes(),
            sim._dtouch_us.tobytes(),
            (sim._dtouch_low, sim._last_us, sim._flag_masked, sim._flag_partial),
            (sim.noise._batch, sim.noise._k),
            (sim.timing.now_us, sim.timing.energy_uj, report.as_dict()),
        ]

    assert play(False) == play(True)
