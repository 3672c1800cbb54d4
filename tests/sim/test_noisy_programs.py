"""Random programs of host calls and kernels leave the reference engine's bytes on the
compiled engine, first tier and fused from the first run, in every noise mode.

The programs mix what the compiled engine does in its own calls under noise with what
the simulator defers or applies between them: noiseless DAC levels over a whole plane
(``scamp5_in``'s ``temp``, deferred as in ideal mode) and masked ones, shifts, host reads
and readouts right after a deferred fill, FLAG set partially by the host or by a kernel
(``where``) before chains of neighbour moves, chains that write NEWS before a later
kernel reads it, kernels run again after time passed (their planes' pending droop
applied in the kernel's own call), and digital registers that decay meanwhile. Arrays
from one element, rows or columns of one element, values at the range's ends and both
zeros.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ppaloc_tests_sim_icws import LOCAL, chain
from ppaloc_tests_sim_icws import icws as shared_icws

import ppaloc.sim as s
from ppaloc.sim import NoiseParams, Scamp5
from ppaloc.sim.engines import available_engines
from ppaloc.sim.registers import ANALOG_PLANES, DIGITAL_PLANES

pytestmark = pytest.mark.skipif("compiled" not in available_engines(), reason="no numba")

LOADED = [*LOCAL, s.NEWS]
ANALOG_DST = [*LOADED, s.XN, s.XE, s.XS, s.XW]
ANALOG_SRC = [*ANALOG_DST, s.PIX, s.IN]
DIGITAL_DST = [getattr(s, f"R{i}") for i in range(13)]
POOLS = {"analog": (ANALOG_DST, ANALOG_SRC), "digital": (DIGITAL_DST, [*DIGITAL_DST, s.FLAG])}
SHAPES = [(1, 1), (1, 6), (6, 1), (3, 7), (4, 5)]
SPECIAL = [-128.0, 127.0, -0.0, 0.0, 0.5, -0.5]

NOISES = {
    "ideal": "ideal",
    "typical": "typical",
    "high": "high",
    "aged": NoiseParams(temporal_sd=0.5, fixed_offset_sd=2.0, decay_per_ms=2000.0),
    "quiet": NoiseParams(decay_per_ms=500.0),  # no temporal noise: scamp5_in's areg deferred
    "retain": NoiseParams(
        temporal_sd=0.5, decay_per_ms=500.0, digital_retention_ms=0.002, digital_flip_per_ms=1.0
    ),
}


piece = st.one_of(
    chain(),
    shared_icws(POOLS).map(lambda icw: [icw]),
    st.sampled_from(LOCAL).map(lambda r: [("where", (), (r,))]),
    st.just([("all", (), ())]),
    st.just([("bus", (s.C,), (s.NEWS,))]),  # a read of what a chain left in NEWS
)
kernels = st.lists(piece, min_size=1, max_size=4).map(lambda ps: [i for p in ps for i in p])
values = st.integers(-128, 127)
steps = st.one_of(
    st.tuples(st.just("in"), st.sampled_from(LOADED), values),
    st.tuples(st.just("load_in"), st.just(None), values),
    st.tuples(st.just("load_in_reg"), st.sampled_from(LOADED), values),
    st.tuples(st.just("read"), st.sampled_from([*LOADED, s.IN]), st.just(0)),
    st.tuples(st.just("readout"), st.sampled_from(LOADED), st.integers(0, 2)),
    st.tuples(st.just("shift"), st.sampled_from(LOADED), st.integers(-2, 2)),
    st.tuples(st.just("flag"), st.just(None), st.integers(0, 2**16)),
    st.tuples(st.just("kernel"), kernels, st.integers(1, 3)),
)


def play(engine: str, noise: str, shape: tuple[int, int], program: list, seed: int) -> list:
    """Run ``program``; return every value read and the planes' bytes at the end."""
    rows, cols = shape
    sim = Scamp5(rows, cols, noise=NOISES[noise], seed=seed % 5, engine=engine)
    rng = np.random.default_rng(seed)
    for r in ANALOG_PLANES:
        if r is not s.PIX:
            v = rng.integers(-128, 128, shape) / 2
            sim.write(r, np.where(rng.random(shape) < 0.2, rng.choice(SPECIAL, shape), v))
    for r in DIGITAL_PLANES:
        if r is not s.FLAG:
            sim.write(r, rng.random(shape) < 0.5)
    seen = []
    for kind, reg, arg in program:
        if kind == "in":
            sim.scamp5_in(reg, arg, s.A if reg is s.NEWS else s.NEWS)
        elif kind == "load_in":
            sim.load_in(arg)
        elif kind == "load_in_reg":
            sim.load_in(reg, arg, s.B if reg is s.NEWS else s.NEWS)
        elif kind == "read":
            seen.append(sim.read(reg).tobytes())
        elif kind == "readout":  # right after whatever came before, a deferred fill too
            if arg == 0:
                seen.append(sim.global_or(s.R1))
            elif arg == 1:
                seen.append(sim.scan_areg(reg).tobytes())
            else:
                seen.append(sim.read_areg(reg, rows - 1, 0))
        elif kind == "shift":
            sim.shift(reg, reg.index % 2 * arg, arg)
        elif kind == "flag":  # FLAG partial (or not) as the next call or kernel starts
            sim.write(s.FLAG, np.random.default_rng(arg).random(shape) < 0.7)
        else:
            with sim.kernel() as k:
                for op, dsts, srcs in reg:
                    k.icw(op, dsts, srcs)
            for _ in range(arg - 1):  # again, with the droop of the time since pending
                k.run()
    return [*seen, sim._a.tobytes(), sim._d.tobytes()]


@pytest.mark.parametrize("noise", list(NOISES))
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    program=st.lists(steps, min_size=1, max_size=10),
    shape=st.sampled_from(SHAPES),
    seed=st.integers(0, 2**16),
)
def test_the_first_tier_leaves_the_reference_bytes(noise, program, shape, seed):
    expected = play("reference", noise, shape, program, seed)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PPALOC_FUSE_AFTER", "never")
        assert play("compiled", noise, shape, program, seed) == expected


@pytest.mark.parametrize("noise", ["typical", "aged"])
@settings(max_examples=5, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    program=st.lists(steps, min_size=1, max_size=6),
    shape=st.sampled_from(SHAPES),
    seed=st.integers(0, 2**16),
)
def test_the_fused_tier_leaves_the_reference_bytes(noise, program, shape, seed):
    expected = play("reference", noise, shape, program, seed)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("PPALOC_FUSE_AFTER", "1")  # every stretch fused from its first run
        assert play("compiled", noise, shape, program, seed) == expected
