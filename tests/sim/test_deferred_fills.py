"""Deferred constant fills (``Scamp5._fill_later``) are never seen: the same bytes as
writing every fill at once, whatever reads the plane next.

A DAC load in ideal mode (and ``IN`` in every mode, and a noiseless level such as
``scamp5_in``'s ``temp`` under noise) records its constant instead of writing the plane;
the pass runs when the plane is next used, or is dropped when another fill comes first or
the next kernel overwrites the plane whole before reading it. Random
programs of DAC loads, kernels of any ICWs (FLAG set and partial), host reads and
shifts run on a simulator that defers and on one that writes each fill at once. The same
programs check that a DAC level written over a whole plane drops the plane's pending
droop rather than applying it (``Scamp5._overwrite``), and that a shift or a masked DAC
write applies it in its own pass (``Scamp5._aplane_and_droop``), against a simulator that
applies it in a pass before, under fast droop too.

A kernel whose leading transfers read only deferred constants has them folded on the
compiled engine (``Scamp5._with_folding``): their destinations become fills and the rest
runs as a kernel of its own. Programs whose kernels start so run on every engine and are
compared with the reference engine writing every fill at once.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, reject, settings
from hypothesis import strategies as st
from ppaloc_tests_sim_icws import icws as shared_icws

import ppaloc.sim as s
from ppaloc.errors import RegisterMisuseError
from ppaloc.sim import OPS, NoiseParams, Scamp5, hostloops
from ppaloc.sim import engine as engine_module
from ppaloc.sim.engines import available_engines
from ppaloc.sim.isa import make
from ppaloc.sim.registers import ANALOG_PLANES, DIGITAL_PLANES

ROWS, COLS = 4, 5
LOADED = [s.A, s.B, s.C, s.D, s.E, s.F, s.NEWS]
ANALOG_DST = [*LOADED, s.XN, s.XE, s.XS, s.XW]
ANALOG_SRC = [*ANALOG_DST, s.PIX, s.IN]
DIGITAL_DST = [getattr(s, f"R{i}") for i in range(13)]
DIGITAL_SRC = [*DIGITAL_DST, s.FLAG]
POOLS = {"analog": (ANALOG_DST, ANALOG_SRC), "digital": (DIGITAL_DST, DIGITAL_SRC)}


class Eager(Scamp5):
    """Writes every fill at once, applies a plane's pending droop before a host write of
    every element, and in a pass of its own before a shift or a masked DAC write (what
    the deferral, the dropped droop and the droop taken into a host call's pass must be
    indistinguishable from)."""

    def _fill_later(self, i: int, value: float) -> None:
        hostloops.fill(self._aplane(ANALOG_PLANES[i]), value)  # drooped, then filled

    def _overwrite(self, reg: s.Register) -> np.ndarray:
        return self._aplane(reg)

    def _aplane_and_droop(self, reg: s.Register) -> tuple[np.ndarray, None]:
        return self._aplane(reg), None


#: Noise modes: ideal, the preset, and fast droop (a plane's pending droop is large).
NOISES = {
    "ideal": "ideal",
    "typical": "typical",
    "aged": NoiseParams(temporal_sd=0.5, decay_per_ms=2000.0),
}


def icws() -> st.SearchStrategy[tuple[str, tuple, tuple]]:
    """One valid instruction of any row of the op table, over this module's registers."""
    return shared_icws(POOLS)


values = st.integers(-128, 127)
steps = st.one_of(
    st.tuples(st.just("in"), st.sampled_from(LOADED), values),
    st.tuples(st.just("load_in"), st.just(None), values),
    st.tuples(st.just("load_in_reg"), st.sampled_from(LOADED), values),
    st.tuples(st.just("read"), st.sampled_from([*LOADED, s.IN]), st.just(0)),
    st.tuples(st.just("shift"), st.sampled_from(LOADED), st.integers(-2, 2)),
    st.tuples(st.just("kernel"), st.lists(icws(), min_size=1, max_size=4), st.just(0)),
)


def play(cls: type[Scamp5], engine: str, noise: str, program: list, seed: int) -> list:
    """Run ``program``; return every value read and the planes' bytes at the end."""
    sim = cls(ROWS, COLS, noise=NOISES[noise], seed=seed % 5, engine=engine)
    rng = np.random.default_rng(seed)
    for r in ANALOG_PLANES:
        if r is not s.PIX:
            sim.write(r, rng.integers(-128, 128, (ROWS, COLS)) / 2)
    for r in DIGITAL_PLANES:
        if r is not s.FLAG:
            sim.write(r, rng.random((ROWS, COLS)) < 0.5)
    seen = []
    for kind, reg, arg in program:
        if kind == "in":
            temp = s.A if reg is s.NEWS else s.NEWS
            sim.scamp5_in(reg, arg, temp)
        elif kind == "load_in":
            sim.load_in(arg)
        elif kind == "load_in_reg":
            temp = s.B if reg is s.NEWS else s.NEWS
            sim.load_in(reg, arg, temp)
        elif kind == "read":
            seen.append(sim.read(reg).tobytes())
        elif kind == "shift":
            sim.shift(reg, reg.index % 2 * arg, arg)
        else:
            with sim.kernel() as k:
                for op, dsts, srcs in reg:
                    k.icw(op, dsts, srcs)
    # the planes only at the end: reading them (``_a``) writes every deferred fill
    return [*seen, sim._a.tobytes(), sim._d.tobytes()]


@pytest.mark.parametrize("engine", available_engines())
@pytest.mark.parametrize("noise", list(NOISES))
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(program=st.lists(steps, min_size=1, max_size=10), seed=st.integers(0, 2**16))
def test_deferred_fills_are_never_seen(engine, noise, program, seed):
    assert play(Scamp5, engine, noise, program, seed) == play(Eager, engine, noise, program, seed)


@st.composite
def constant_kernel(draw: st.DrawFn) -> list[tuple]:
    """DAC loads, then a kernel that starts with bus transfers of local registers on what
    they left constant (every form: halvings, thirds, sums to saturation, IN read) and may
    go on with any ICWs: the kind of kernel whose leading ICWs fold."""
    extreme = st.one_of(values, st.sampled_from([-128, -127, 127, 126, 100, -100]))
    loads = draw(st.lists(st.sampled_from(LOADED), min_size=1, max_size=4, unique=True))
    steps = [("in", reg, draw(extreme)) for reg in loads]
    constant = set(loads) - {s.NEWS} if len(loads) > 1 else set(loads)
    if draw(st.booleans()):
        steps.append(("load_in", None, draw(extreme)))
        constant.add(s.IN)
    body = []
    for _ in range(draw(st.integers(1, 5))):
        op = draw(st.sampled_from(["bus", "bus", "bus2", "bus2", "bus3", "busn"]))
        spec = OPS[op]
        dsts = draw(st.lists(st.sampled_from(LOADED), min_size=spec.n_dst[0],
                             max_size=spec.n_dst[1], unique=True))  # fmt: skip
        pool = sorted(constant, key=lambda r: r.index)
        srcs = draw(st.lists(st.sampled_from(pool), min_size=max(1, spec.n_src[0]),
                             max_size=spec.n_src[1], unique=True))  # fmt: skip
        try:
            make(op, tuple(dsts), tuple(srcs))
        except RegisterMisuseError:
            continue
        body.append((op, tuple(dsts), tuple(srcs)))
        constant |= set(dsts)
    body += draw(st.lists(icws(), max_size=3))
    if not body:
        reject()
    return [*steps, ("kernel", body, 0)]


folding_steps = st.one_of(
    constant_kernel().map(tuple),
    st.tuples(st.tuples(st.just("read"), st.sampled_from([*LOADED, s.IN]), st.just(0))),
    st.tuples(st.tuples(st.just("kernel"), st.lists(icws(), min_size=1, max_size=3), st.just(0))),
    st.tuples(st.tuples(st.just("shift"), st.sampled_from(LOADED), st.integers(-2, 2))),
)


@pytest.mark.parametrize("engine", available_engines())
@pytest.mark.parametrize("noise", list(NOISES))
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(blocks=st.lists(folding_steps, min_size=1, max_size=5), seed=st.integers(0, 2**16))
def test_transfers_on_deferred_constants_fold_to_the_same_bytes(engine, noise, blocks, seed):
    program = [step for block in blocks for step in block]
    expected = play(Eager, "reference", noise, program, seed)
    assert play(Scamp5, engine, noise, program, seed) == expected


def test_a_kernel_on_constants_folds(monkeypatch):
    """Halvings of a DAC constant (the detection's fraction plane) leave fills, not
    passes: only the planes the rest of the kernel reads are written."""
    if "compiled" not in available_engines():
        pytest.skip("folding is the compiled engine's")
    sim = Scamp5(8, 8, engine="compiled")
    sim.write(s.C, np.arange(64).reshape(8, 8) - 32)
    with sim.kernel() as k:  # record (and run) once
        k.bus2(s.E, s.NEWS, s.D)
        k.bus2(s.D, s.NEWS, s.E)
        k.bus(s.NEWS, s.C)
        k.where(s.IN, s.D, s.NEWS)
        k.all()
    passes = count_fills(monkeypatch)
    folded = []
    fold = engine_module.fold_transfers
    monkeypatch.setattr(
        engine_module, "fold_transfers", lambda *a: folded.append(len(a[0])) or fold(*a)
    )
    sim.scamp5_in(s.D, 7)  # D, its temp NEWS and IN deferred
    sim.load_in(3)
    k.run()
    assert folded == [2]  # both halvings, not the bus that reads C
    planes = {sim._analog_planes[r.index].__array_interface__["data"][0]: r for r in (s.D, s.IN)}
    assert sorted(planes[p].name for p in passes) == ["D", "IN"]  # E stays deferred
    assert sim._fills == {s.E.index: -3.5}
    assert (sim.read(s.D) == 1.75).all() and (sim.read(s.E) == -3.5).all()


def test_a_kernel_folded_again_and_again_leaves_the_same_bytes():
    """A kernel folds the same levels on many runs (the fraction tests of a frame): its
    folds are kept per levels read, never for a zero (``0.0`` and ``-0.0`` are equal
    keys), and every run leaves the bytes of the reference engine writing every fill."""
    if "compiled" not in available_engines():
        pytest.skip("folding is the compiled engine's")
    # levels of D: repeated, both signs, the ends, and zeros of both signs (a negated 0.0
    # left by the first kernel, then 0.0 from the DAC)
    levels = [7, 7, -3, 7, 127, -128, -3, None, 0, None, 0, 5, 7]
    runs = []
    for cls, engine in ((Scamp5, "compiled"), (Eager, "reference")):
        sim = cls(8, 8, engine=engine)
        sim.write(s.C, np.arange(64).reshape(8, 8) - 32)
        with sim.kernel() as negate:
            negate.bus(s.D, s.A)
        with sim.kernel() as k:  # E := -D keeps a zero's sign (negated), D := -E / 2
            k.bus(s.E, s.D)
            k.bus2(s.D, s.NEWS, s.E)
            k.bus(s.NEWS, s.C)
            k.where(s.IN, s.D, s.NEWS)
            k.all()
        seen = []
        for v in levels:
            if v is None:  # D := -0.0, a fill left by a folded kernel
                sim.scamp5_in(s.A, 0, s.B)
                negate.run()
            else:
                sim.scamp5_in(s.D, v)
            sim.load_in(3)
            k.run()
            seen.append(sim._a.tobytes())  # every plane's bytes, every fill written
        runs.append([*seen, sim._d.tobytes()])
    assert runs[0] == runs[1]


def count_fills(monkeypatch) -> list[int]:
    """The planes' addresses of every fill pass from now on."""
    passes: list[int] = []
    fill = hostloops.fill

    def counted(out, value):
        passes.append(out.__array_interface__["data"][0])
        fill(out, value)

    monkeypatch.setattr(hostloops, "fill", counted)
    return passes


def test_a_fill_overwritten_first_is_never_written(monkeypatch):
    """``scamp5_in`` leaves NEWS at ``-v``; a kernel that writes NEWS first drops that
    pass, and a second ``IN`` before any kernel drops the first."""
    sim = Scamp5(8, 8)
    with sim.kernel() as k:  # record (and run) once
        k.bus(s.NEWS, s.B)
        k.where(s.IN, s.NEWS, s.A)
        k.all()
    passes = count_fills(monkeypatch)
    sim.scamp5_in(s.A, 5)  # IN, NEWS and A deferred
    sim.load_in(-3)  # IN again: its first value is never seen
    assert passes == []
    k.run()  # reads A and IN, writes NEWS before reading it
    planes = {sim._analog_planes[r.index].__array_interface__["data"][0]: r for r in (s.A, s.IN)}
    assert sorted(planes[p].name for p in passes) == ["A", "IN"]
    assert (sim.read(s.A) == 5).all() and (sim.read(s.IN) == -3).all()
    assert (sim.read(s.NEWS) == -sim.read(s.B)).all()


def test_a_partial_flag_keeps_the_fill():
    """A kernel that writes a plane first drops its fill only when FLAG is set
    everywhere as it starts: under a partial FLAG its write does not cover the plane."""
    sim = Scamp5(4, 4)
    sim.write(s.R5, np.eye(4, dtype=bool))
    sim.write(s.NEWS, np.full((4, 4), 50.0))
    sim.scamp5_in(s.C, 9)  # NEWS := -9, deferred
    with sim.kernel() as k:  # names no analogue plane: NEWS stays deferred
        k.WHERE(s.R5)
    with sim.kernel() as k:  # writes NEWS first, where FLAG (the diagonal) only
        k.bus(s.NEWS, s.A)
    news = sim.read(s.NEWS)
    assert (news[~np.eye(4, dtype=bool)] == -9).all()


def test_in_set_back_to_the_level_its_plane_holds_is_not_written_again(monkeypatch):
    """No ICW writes ``IN``: a level set, replaced before any kernel read it, and set
    again leaves the plane as it was, so no pass writes it; a host write of ``IN`` (a
    view of it) makes its level unknown again."""
    sim = Scamp5(8, 8)
    sim.write(s.B, np.arange(64).reshape(8, 8) - 32)
    with sim.kernel() as k:  # A := B + IN (record and run once; B is no constant: no fold)
        k.bus(s.NEWS, s.B, s.IN)
        k.bus(s.A, s.NEWS)
    sim.load_in(5)
    k.run()  # IN's plane holds 5
    plane_in = sim._analog_planes[s.IN.index].__array_interface__["data"][0]
    passes = count_fills(monkeypatch)
    sim.load_in(7)  # never read
    sim.load_in(5)
    k.run()
    assert plane_in not in passes
    assert (sim.read(s.A) == sim.read(s.B) + 5).all()
    sim.write(s.IN, np.full((8, 8), 1.0))
    sim.load_in(5)
    k.run()
    assert passes.count(plane_in) == 1
    assert (sim.read(s.A) == sim.read(s.B) + 5).all()
