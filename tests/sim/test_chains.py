"""Chains of neighbour moves composed by the compiled engine leave the reference's bytes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import ppaloc.sim as s
from ppaloc.sim import Scamp5
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


def run(engine: str, rows: int, cols: int, icws: list, values, flag) -> Scamp5:
    sim = Scamp5(rows, cols, noise="ideal", engine=engine)
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
