"""The compiled engine's work shared among threads leaves the reference engine's bytes.

With ``threads`` above 1 (``$PPALOC_THREADS``) the compiled engine's first tier shares,
under noise, a chain's bands of rows, a neighbour move's rows and a one-pass transfer's
elements among threads. Each element gets the same float32 operations on the same values
and the same noise draws (drawn by position), so every plane holds the bytes of one
thread: random programs and chains are run with 1, 2 and 3 threads on arrays that make
one band or several (and rows or columns of one element) against the reference engine.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ppaloc_tests_sim_icws import AXES, LOCAL, chain
from ppaloc_tests_sim_icws import icws as shared_icws

import ppaloc.sim as s
from ppaloc.errors import SimulatorError
from ppaloc.sim import NoiseParams, Scamp5
from ppaloc.sim.engines import available_engines
from ppaloc.sim.registers import ANALOG_PLANES, DIGITAL_PLANES

pytestmark = pytest.mark.skipif("compiled" not in available_engines(), reason="no numba")

ANALOG_DST = [*LOCAL, s.NEWS, s.XN, s.XE, s.XS, s.XW]
ANALOG_SRC = [*ANALOG_DST, s.PIX, s.IN]
DIGITAL_DST = [getattr(s, f"R{i}") for i in range(13)]
POOLS = {"analog": (ANALOG_DST, ANALOG_SRC), "digital": (DIGITAL_DST, [*DIGITAL_DST, s.FLAG])}
#: shapes of one band and of several (a band is about 4096 elements of whole rows)
SHAPES = [(1, 1), (1, 9), (9, 1), (4, 5), (7, 13), (3, 2048), (9, 1024), (40, 1)]
SPECIAL = [-128.0, 127.0, -0.0, 0.0, 0.5, -0.5]
NOISES = {
    "ideal": "ideal",
    "typical": "typical",
    "high": "high",
    "zero": NoiseParams(),
    "aged": NoiseParams(temporal_sd=0.5, fixed_offset_sd=2.0, decay_per_ms=2000.0),
}


def move() -> st.SearchStrategy[list[tuple]]:
    """One neighbour move: a push of a local plane or a read of a neighbour's NEWS."""
    push = st.tuples(st.sampled_from([s.XN, s.XE, s.XS, s.XW]), st.sampled_from(LOCAL)).map(
        lambda p: [("bus", (p[0],), (p[1],))]
    )
    read = st.tuples(st.sampled_from(LOCAL), st.sampled_from([s.XN, s.XE, s.XS, s.XW])).map(
        lambda p: [("bus", (p[0],), (p[1],))]
    )
    return st.one_of(push, read)


def local() -> st.SearchStrategy[list[tuple]]:
    """A one-pass transfer of one or two local sources into one local plane."""
    planes = st.lists(st.sampled_from([*LOCAL, s.NEWS]), min_size=2, max_size=3, unique=True)
    return planes.map(lambda p: [("bus", (p[0],), tuple(p[1:]))])


def halving() -> st.SearchStrategy[list[tuple]]:
    """A ``bus2`` of one local source into two local planes (one pass into both)."""
    planes = st.lists(st.sampled_from(LOCAL), min_size=3, max_size=3, unique=True)
    return planes.map(lambda p: [("bus2", (p[0], p[1]), (p[2],))])


pieces = st.one_of(
    chain(most=8),
    move(),
    local(),
    halving(),
    shared_icws(POOLS).map(lambda i: [i]),
    st.just([("all", (), ())]),
)
kernels = st.lists(st.lists(pieces, min_size=1, max_size=6), min_size=1, max_size=3)


def run(threads: int, shape, noise, program, seed: int, flag_all: bool) -> Scamp5:
    """The program on the reference engine (``threads`` 0) or the compiled one."""
    rows, cols = shape
    engine = "reference" if threads == 0 else "compiled"
    sim = Scamp5(rows, cols, noise=NOISES[noise], seed=seed % 5, engine=engine)
    if threads:
        sim.engine.threads = threads
    rng = np.random.default_rng(seed)
    for r in ANALOG_PLANES:
        if r is not s.PIX:
            v = rng.integers(-128, 128, shape) / rng.choice([1, 2, 4])
            sim.write(r, np.where(rng.random(shape) < 0.2, rng.choice(SPECIAL, shape), v))
    for r in DIGITAL_PLANES:
        sim.write(r, rng.random(shape) < 0.5)
    if flag_all:
        sim.write(s.FLAG, np.ones(shape, dtype=bool))
    sim.set_image(rng.integers(0, 256, shape, dtype=np.uint8))
    for kernel in program:
        with sim.kernel() as k:
            for piece in kernel:
                for icw in piece:
                    k.icw(*icw)
    return sim


def same_bytes(a: Scamp5, b: Scamp5) -> None:
    assert a._a.tobytes() == b._a.tobytes(), "analogue planes differ"
    assert a._d.tobytes() == b._d.tobytes(), "digital planes differ"
    assert a._latch.tobytes() == b._latch.tobytes(), "bus latch differs"


@pytest.mark.parametrize("noise", list(NOISES))
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(
    program=kernels,
    shape=st.sampled_from(SHAPES),
    seed=st.integers(0, 2**16),
    flag_all=st.booleans(),
)
def test_threads_leave_the_reference_bytes(noise, program, shape, seed, flag_all) -> None:
    """Random kernels of chains, single neighbour moves, one-pass transfers, halvings
    into two planes, any ICW of the op table and ``all`` (FLAG set everywhere, where the
    shared paths run), with 2 and 3 threads, against the reference engine."""
    ref = run(0, shape, noise, program, seed, flag_all)
    for threads in (2, 3):
        same_bytes(run(threads, shape, noise, program, seed, flag_all), ref)


@pytest.mark.parametrize("shape", [(9, 1500), (40, 300), (5, 4096), (300, 1), (256, 64)])
def test_shared_chains_across_bands_leave_the_reference_bytes(shape) -> None:
    """Noisy chains of 2 to 16 steps along both axes, onto their source (a column chain's
    bands then run in order, on one thread) or not, on arrays of several bands."""
    rng = np.random.default_rng(shape[0] * shape[1])
    for axis in (0, 1):
        for n in (2, 3, 8, 16):
            for source, plane in ((s.F, s.F), (s.D, s.F)):
                program, read, src = [], False, source
                for _ in range(n):
                    read_reg, push_reg = AXES[axis][int(rng.integers(2))]
                    if read:
                        program.append(("bus", (plane,), (read_reg,)))
                        src = plane
                    else:
                        program.append(("bus", (push_reg,), (src,)))
                    read = not read
                program.append(("bus", (s.NEWS,), (s.A, s.B)))
                seed = int(rng.integers(2**16))
                ref = run(0, shape, "typical", [[program]], seed, True)
                for threads in (2, 3):
                    got = run(threads, shape, "typical", [[program]], seed, True)
                    same_bytes(got, ref)


def test_threads_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """``$PPALOC_THREADS`` sets the threads (1 when unset); arrays below ``SPLIT_MIN``
    elements, and numba's ``workqueue`` threading layer, run on one thread."""
    import numba

    from ppaloc.sim.engines.compiled import (
        SPLIT_MIN,
        THREADS_ENV,
        threads_from_env,
        usable_threads,
    )

    monkeypatch.delenv(THREADS_ENV, raising=False)
    assert threads_from_env() == 1
    monkeypatch.setenv(THREADS_ENV, "2")
    assert threads_from_env() == 2
    assert Scamp5(128, SPLIT_MIN // 128, engine="compiled").engine.threads == usable_threads(2)
    assert Scamp5(4, 5, engine="compiled").engine.threads == 1
    monkeypatch.setattr(numba, "threading_layer", lambda: "workqueue")
    assert usable_threads(2) == 1
    for bad in ("0", "two", "-1", "²", "2²"):
        monkeypatch.setenv(THREADS_ENV, bad)
        with pytest.raises(SimulatorError, match=THREADS_ENV):
            threads_from_env()


@pytest.mark.parametrize(
    ("name", "value", "says"),
    [
        # no machine integer holds it: numba was given an object and failed (a traceback)
        ("PPALOC_THREADS", "9" * 20, "'99999999999999999999' is invalid: use a number of "
         "threads from 1 to 1024"),
        ("PPALOC_THREADS", "1025", "'1025' is invalid: use a number of threads from 1 to 1024"),
        # more digits than Python converts: its own error, naming no variable
        ("PPALOC_THREADS", "1" * 5000, "'" + "1" * 35 + "...' is invalid"),
        ("PPALOC_FUSE_AFTER", "9" * 20, "'99999999999999999999' is invalid: use a number of "
         "runs from 1 to 1,000,000,000, or never"),
        ("PPALOC_FUSE_AFTER", "1" * 5000, "'" + "1" * 35 + "...' is invalid"),
    ],
)  # fmt: skip
def test_a_count_beyond_its_maximum_is_refused_in_the_environment_check(
    monkeypatch: pytest.MonkeyPatch, name: str, value: str, says: str
) -> None:
    from ppaloc.sim.engines import check_environment
    from ppaloc.sim.engines.compiled import fuse_after_from_env, threads_from_env

    monkeypatch.setenv("PPALOC_ENGINE", "compiled")
    monkeypatch.setenv(name, value)
    parse = threads_from_env if name == "PPALOC_THREADS" else fuse_after_from_env
    for check in (check_environment, parse):
        with pytest.raises(SimulatorError, match=f"^{name}={re.escape(says)}"):
            check()
    monkeypatch.setenv(name, "0" * 30 + "2")  # leading zeros are the number they lead
    assert check_environment() is None


def test_one_thread_compiles_no_parallel_code(monkeypatch: pytest.MonkeyPatch) -> None:
    """With one thread (the default) a kernel runs the variant of ``_run`` typed with
    ``threads=None``, which neither calls nor compiles the parallel (``prange``) functions:
    a fresh numba cache then pays no parallel compilation; a number of threads compiles
    them when a kernel first calls one."""
    import numba
    from numba import types

    from ppaloc.sim.engines import compiled

    monkeypatch.delenv(compiled.THREADS_ENV, raising=False)
    sim = Scamp5(128, 128, noise="typical", seed=0, engine="compiled")
    assert sim.engine.threads == 1
    with sim.kernel() as k:
        k.icw("bus", (s.B,), (s.A,))
        k.icw("bus", (s.XE,), (s.B,))
    assert any(sig[-1] == types.none for sig in compiled._run.signatures)

    def parallel(x, threads):
        x[0] = threads

    par = numba.njit(parallel)
    call = compiled._shared(par)

    @numba.njit
    def kernel(x, threads):
        if compiled._many(threads):
            call(x, threads)
        else:
            x[0] = -1

    x = np.zeros(1)
    kernel(x, None)
    assert x[0] == -1 and par.signatures == []
    kernel(x, 2)
    assert x[0] == 2 and len(par.signatures) == 1
