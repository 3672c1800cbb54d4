"""Deferred constant fills (``Scamp5._fill_later``) are never seen: the same bytes as
writing every fill at once, whatever reads the plane next.

A DAC load in ideal mode (and ``IN`` in every mode) records its constant instead of
writing the plane; the pass runs when the plane is next used, or is dropped when another
fill comes first or the next kernel overwrites the plane whole before reading it. Random
programs of DAC loads, kernels of any ICWs (FLAG set and partial), host reads and
shifts run on a simulator that defers and on one that writes each fill at once.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ppaloc_tests_sim_icws import icws as shared_icws

import ppaloc.sim as s
from ppaloc.sim import Scamp5, hostloops
from ppaloc.sim.engines import available_engines
from ppaloc.sim.registers import ANALOG_PLANES, DIGITAL_PLANES

ROWS, COLS = 4, 5
LOADED = [s.A, s.B, s.C, s.D, s.E, s.F, s.NEWS]
ANALOG_DST = [*LOADED, s.XN, s.XE, s.XS, s.XW]
ANALOG_SRC = [*ANALOG_DST, s.PIX, s.IN]
DIGITAL_DST = [getattr(s, f"R{i}") for i in range(13)]
DIGITAL_SRC = [*DIGITAL_DST, s.FLAG]
POOLS = {"analog": (ANALOG_DST, ANALOG_SRC), "digital": (DIGITAL_DST, DIGITAL_SRC)}


class Eager(Scamp5):
    """Writes every fill at once (what the deferral must be indistinguishable from)."""

    def _fill_later(self, i: int, value: float) -> None:
        hostloops.fill(self._analog_planes[i], value)


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
    sim = cls(ROWS, COLS, noise=noise, seed=seed % 5, engine=engine)
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
@pytest.mark.parametrize("noise", ["ideal", "typical"])
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(program=st.lists(steps, min_size=1, max_size=10), seed=st.integers(0, 2**16))
def test_deferred_fills_are_never_seen(engine, noise, program, seed):
    assert play(Scamp5, engine, noise, program, seed) == play(Eager, engine, noise, program, seed)


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
