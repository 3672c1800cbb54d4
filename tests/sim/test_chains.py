"""Chains of neighbour moves composed by the compiled engine leave the reference's bytes:
in ideal mode as one composed function, under noise (typical, high, fast droop) each step
with its own gain, cell offsets and window, the planes between the steps in row buffers."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ppaloc.sim as s
from ppaloc.sim import NoiseParams, Scamp5
from ppaloc.sim.engines import available_engines, chains

pytestmark = pytest.mark.skipif("compiled" not in available_engines(), reason="no numba")

LOCAL = [s.A, s.B, s.C, s.D, s.E, s.F]
#: the read of each direction's neighbour, and the push that reads the same neighbour
AXES = {1: [(s.XE, s.XW), (s.XW, s.XE)], 0: [(s.XN, s.XS), (s.XS, s.XN)]}
SPECIAL = [-128.0, 127.0, -127.5, 126.5, -0.0, 0.0, 1.0, -1.0]


@st.composite
def chain_kernels(draw: st.DrawFn) -> tuple[int, int, list, np.ndarray, np.ndarray]:
    """(rows, cols, ICWs, start values, FLAG): a linked chain of moves along one axis
    (each step reading what the one before wrote), ICWs after it that read or overwrite
    its planes, values with the saturation's edges and both zeros."""
    rows, cols = draw(st.integers(1, 7)), draw(st.integers(1, 7))
    axis = draw(st.sampled_from([0, 1]))
    n = draw(st.integers(2, 12))
    read = draw(st.booleans())  # the first step: a read of NEWS, or a push
    plane = s.NEWS if read else draw(st.sampled_from(LOCAL))
    icws = []
    for _ in range(n):
        read_reg, push_reg = draw(st.sampled_from(AXES[axis]))
        if read:
            plane = draw(st.sampled_from(LOCAL))
            icws.append(("bus", (plane,), (read_reg,)))
        else:
            icws.append(("bus", (push_reg,), (plane,)))
            plane = s.NEWS
        read = not read
    after = draw(
        st.sampled_from(
            [
                None,
                ("bus", (s.NEWS,), (s.A, s.B)),  # NEWS overwritten unread
                ("bus", (s.C,), (s.NEWS,)),  # NEWS read
                ("bus", (s.A,), (s.B,)),
                ("where", (), (s.D,)),
                [("where", (), (s.D,)), ("bus", (s.NEWS,), (s.A, s.B))],  # partly overwritten
            ]
        )
    )
    if isinstance(after, tuple):
        icws.append(after)
    elif after is not None:
        icws.extend(after)
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    values = rng.integers(-130, 130, (7, rows, cols)) / rng.choice([1, 2, 4])
    values = np.where(rng.random(values.shape) < 0.3, rng.choice(SPECIAL, values.shape), values)
    flag = np.ones((rows, cols), dtype=bool)
    if draw(st.booleans()):
        flag = rng.random((rows, cols)) < 0.7
    return rows, cols, icws, values, flag


#: Noise modes of the noisy chains: the presets, every term zero (the noisy path, where
#: signed zeros show: a missing term's -0.0 plus offsets and windows of zeros) and fast
#: droop (planes droop a lot between the host writes and the kernel).
NOISES = {
    "typical": "typical",
    "high": "high",
    "zero": NoiseParams(),
    "aged": NoiseParams(temporal_sd=0.5, fixed_offset_sd=2.0, decay_per_ms=2000.0),
}


def run(
    engine: str, rows: int, cols: int, icws: list, values, flag, noise="ideal", seed=0
) -> Scamp5:
    sim = Scamp5(rows, cols, noise=noise, engine=engine, seed=seed)
    for reg, v in zip([*LOCAL, s.NEWS], values, strict=True):
        sim.write(reg, v)
    sim.write(s.FLAG, flag)
    with sim.kernel() as k:
        for icw in icws:
            k.icw(*icw)
    return sim


@settings(max_examples=300, deadline=None)
@given(case=chain_kernels())
def test_a_composed_chain_leaves_the_reference_bytes(case) -> None:
    ref, got = (run(engine, *case) for engine in ("reference", "compiled"))
    assert got._a.tobytes() == ref._a.tobytes()
    assert got._d.tobytes() == ref._d.tobytes()


@pytest.mark.parametrize("noise", list(NOISES))
@settings(max_examples=200, deadline=None)
@given(case=chain_kernels(), seed=st.integers(0, 7), news_last=st.booleans())
def test_a_noisy_chain_leaves_the_reference_bytes(noise, case, seed, news_last) -> None:
    """Chains of noisy moves (both axes, mixed directions, 2 to 12 steps, arrays from 1 x
    1, FLAG set, where the chain runs in one pass, or partial, where it runs ICW by ICW;
    its planes read, overwritten or partly overwritten later, and NEWS overwritten at
    the end or not: a column chain runs in one pass only with one plane left to write)
    against the reference."""
    rows, cols, icws, values, flag = case
    if news_last:
        icws = [*icws, ("bus", (s.NEWS,), (s.A, s.B))]
    case = rows, cols, icws, values, flag
    ref, got = (run(engine, *case, NOISES[noise], seed) for engine in ("reference", "compiled"))
    assert got._a.tobytes() == ref._a.tobytes()
    assert got._d.tobytes() == ref._d.tobytes()


def moves(axis: int, n: int, rng: np.random.Generator, source, plane, way=None) -> list:
    """``n`` linked moves along ``axis`` in random directions (or all in direction
    ``way``, 0 or 1), from ``source`` (a push first) through NEWS and ``plane``."""
    icws, read, src = [], False, source
    for _ in range(n):
        read_reg, push_reg = AXES[axis][rng.integers(2) if way is None else way]
        if read:
            icws.append(("bus", (plane,), (read_reg,)))
            src = plane
        else:
            icws.append(("bus", (push_reg,), (src,)))
        read = not read
    return icws


@pytest.mark.parametrize("shape", [(9, 1500), (40, 300), (5, 4096), (3, 2), (300, 1)])
def test_noisy_chains_across_bands_leave_the_reference_bytes(shape) -> None:
    """Noisy chains on arrays whose rows make several bands (a band is about 4096
    elements of whole rows; the last one short), rows of one element, columns of one:
    row and column chains of 2 to 16 steps, onto their source (whose rows a column
    chain must read before it writes them, from either end) or not, NEWS read after the
    chain or not."""
    rows, cols = shape
    rng = np.random.default_rng(rows * cols)
    values = rng.integers(-128, 128, (7, rows, cols)).astype(np.float32)
    values[:, ::3, ::5] = rng.choice(SPECIAL, values[:, ::3, ::5].shape)
    flag = np.ones((rows, cols), dtype=bool)
    afters = ([], [("bus", (s.C,), (s.NEWS,))], [("bus", (s.NEWS,), (s.A, s.B))])
    for axis in (0, 1):
        for n in (2, 3, 8, 16):
            for way in (None, 0, 1):
                for source, plane in ((s.F, s.F), (s.D, s.F)):
                    for after in afters:
                        icws = moves(axis, n, rng, source, plane, way) + after
                        ref, got = (
                            run(engine, rows, cols, icws, values, flag, "typical", n)
                            for engine in ("reference", "compiled")
                        )
                        assert got._a.tobytes() == ref._a.tobytes(), (axis, n, way, source)


def test_noisy_chains_run_composed_where_they_save_passes() -> None:
    """Under noise every row chain and every column chain with one output is composed
    (a two-step chain onto its own source too); a column chain whose NEWS is read later
    (two outputs) runs ICW by ICW."""
    from ppaloc.sim.engines.compiled import _CHAIN, encode

    def composed(build, noisy=True) -> int:
        icws = recorded(build)
        prog, _, _ = encode(icws, not noisy, 16, 16)
        return int((prog[:, 0] == _CHAIN).sum())

    def onto_source(k) -> None:
        k.mov2x(s.F, s.F, s.south, s.south)
        k.bus(s.NEWS, s.A)  # NEWS overwritten unread: F the one output

    assert composed(onto_source) == 1
    assert composed(onto_source, noisy=False) == 0

    def column_news_read(k) -> None:
        k.mov2x(s.F, s.D, s.south, s.south)
        k.bus(s.C, s.NEWS)

    def row_news_read(k) -> None:
        k.mov2x(s.F, s.D, s.east, s.east)
        k.bus(s.C, s.NEWS)

    assert composed(column_news_read) == 0
    assert composed(column_news_read, noisy=False) == 1
    assert composed(row_news_read) == 1


def unread(icws: list) -> list:
    from ppaloc.sim.engines.compiled import overwritten_unread

    return overwritten_unread(icws)


def recorded(build) -> list:
    sim = Scamp5(16, 16, noise="ideal", engine="reference")
    with sim.kernel() as k:
        build(k)
    return list(k)


def test_shift_chains_are_found_and_the_planes_read_later_kept() -> None:
    def build(k) -> None:
        k.movx(s.F, s.D, s.east)  # not a chain: its second ICW reads NEWS locally
        for _ in range(4):
            k.mov2x(s.F, s.F, s.east, s.east)
        k.add(s.E, s.D, s.F)  # overwrites NEWS unread

    icws = recorded(build)
    (chain,) = chains.compose(icws, set(), unread(icws))
    assert (chain.start, len(chain.steps), chain.source, chain.axis) == (2, 8, s.F.index, 1)
    assert chain.outputs == ((s.F.index, 8),)  # NEWS left out: overwritten before a read
    assert chains.find(icws, set())[0].outputs == ((s.NEWS.index, 7), (s.F.index, 8))


def test_a_two_step_chain_onto_its_source_is_left_to_run_icw_by_icw() -> None:
    icws = recorded(lambda k: k.mov2x(s.F, s.F, s.south, s.south))
    assert len(chains.find(icws, set())) == 1
    assert chains.compose(icws, set(), unread(icws)) == []
    icws = recorded(lambda k: k.mov2x(s.F, s.D, s.south, s.south))
    assert len(chains.compose(icws, set(), unread(icws))) == 1
