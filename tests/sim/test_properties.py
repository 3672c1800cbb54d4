"""Property test: random macro programs leave the reference engine's bytes on every engine.

The programs mix the analogue macros (with FLAG set by ``where`` around them), neighbour
moves, the digital macros and DNEWS, issued directly and as one kernel. The reference
engine (``ppaloc.sim.engines.reference``) interprets each ICW on fresh arrays from the
documented semantics; the golden tests of test_engine.py and test_macros.py check it
when the suite runs with ``--engine reference``.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import ppaloc.sim as s
from ppaloc.sim.engines import available_engines

ROWS, COLS = 3, 4
AREGS = ["A", "B", "C", "D", "E", "F"]
DREGS = ["R5", "R6", "R7", "R8", "R9", "R10", "R11"]
DIRS = {"north": (-1, 0), "east": (0, 1), "south": (1, 0), "west": (0, -1)}
SELECTOR = {"south": "R1", "west": "R2", "north": "R3", "east": "R4"}


def issue(k, step: tuple) -> None:
    """Issue one program step through the simulator's API."""
    op, *args = step
    reg = lambda n: getattr(s, n)  # noqa: E731
    direction = lambda n: getattr(s, n)  # noqa: E731
    if op in ("mov", "add", "sub", "neg", "abs", "divq", "div"):
        getattr(k, op)(*map(reg, args))
    elif op == "movx":
        k.movx(reg(args[0]), reg(args[1]), direction(args[2]))
    elif op == "subx":
        k.subx(reg(args[0]), reg(args[1]), direction(args[2]), reg(args[3]))
    elif op == "where_mov":
        k.where(reg(args[0]))
        k.mov(reg(args[1]), reg(args[2]))
        k.all()
    elif op == "where_movx":
        k.where(reg(args[0]))
        k.movx(reg(args[1]), reg(args[2]), direction(args[3]))
        k.all()
    elif op in ("AND", "OR", "XOR", "MUX", "NOT"):
        getattr(k, op)(*map(reg, args))
    elif op == "DNEWS":
        r, x, dirs, boundary = args
        combined = s.Direction(0)
        for name in dirs:
            combined |= direction(name)
        k.DNEWS(reg(r), reg(x), combined, boundary)


def distinct(n: int, pool: list[str]) -> st.SearchStrategy:
    return st.lists(st.sampled_from(pool), min_size=n, max_size=n, unique=True)


areg = st.sampled_from(AREGS)
dreg = st.sampled_from(DREGS)
direction_st = st.sampled_from(list(DIRS))


def _pair_then(op: str, pool: list[str], middle: st.SearchStrategy, *, tail=()):
    """(op, r0, <middle>, r1) with r0 != r1 drawn from pool."""
    return distinct(2, pool).flatmap(
        lambda r: st.tuples(st.just(op), st.just(r[0]), middle, *tail, st.just(r[1]))
    )


steps = st.one_of(
    st.tuples(st.just("mov"), areg, areg),
    st.tuples(st.just("add"), areg).flatmap(lambda t: distinct(2, AREGS).map(lambda x: (*t, *x))),
    st.tuples(st.just("add"), areg).flatmap(lambda t: distinct(3, AREGS).map(lambda x: (*t, *x))),
    _pair_then("sub", AREGS, areg),  # sub(y, x0, x1) with y != x1
    distinct(2, AREGS).map(lambda r: ("neg", *r)),
    distinct(2, AREGS).map(lambda r: ("abs", *r)),
    distinct(2, AREGS).map(lambda r: ("divq", *r)),
    distinct(4, AREGS).map(lambda r: ("div", *r)),
    st.tuples(st.just("movx"), areg, areg, direction_st),
    _pair_then("subx", AREGS, areg, tail=(direction_st,)),
    st.tuples(st.just("where_mov"), areg, areg, areg),
    st.tuples(st.just("where_movx"), areg, areg, areg, direction_st),
    st.tuples(st.just("AND"), dreg, dreg, dreg),
    distinct(3, DREGS).map(lambda r: ("OR", *r)),
    distinct(3, DREGS).map(lambda r: ("XOR", *r)),
    st.tuples(st.just("MUX"), dreg, dreg, dreg, dreg),
    distinct(2, DREGS).map(lambda r: ("NOT", *r)),
    distinct(2, DREGS).flatmap(
        lambda r: st.tuples(
            st.just("DNEWS"),
            st.just(r[0]),
            st.just(r[1]),
            st.lists(direction_st, min_size=1, max_size=4, unique=True).map(tuple),
            st.integers(0, 1),
        )
    ),
)


@settings(max_examples=150, deadline=None)
@given(program=st.lists(steps, min_size=1, max_size=10), seed=st.integers(0, 2**16))
def test_random_macro_programs_match_the_reference(program: list[tuple], seed: int) -> None:
    rng = np.random.default_rng(seed)
    a0 = {r: rng.integers(-128, 128, (ROWS, COLS)) / rng.choice([1, 2]) for r in AREGS}
    a0["NEWS"] = rng.integers(-128, 128, (ROWS, COLS)).astype(float)
    d0 = {r: rng.random((ROWS, COLS)) < 0.5 for r in [*DREGS, "R0", "R1", "R2", "R3", "R4", "R12"]}
    d0["FLAG"] = np.ones((ROWS, COLS), dtype=bool)

    def run(engine: str, mode: str) -> s.Scamp5:
        sim = s.Scamp5(rows=ROWS, cols=COLS, engine=engine)
        for name, v in {**a0, **d0}.items():
            sim.write(getattr(s, name), v)
        if mode == "direct":
            for step in program:
                issue(sim, step)
        else:
            with sim.kernel() as k:
                for step in program:
                    issue(k, step)
        return sim

    for mode in ("direct", "kernel"):
        ref = run("reference", mode)
        for engine in available_engines():
            sim = run(engine, mode)
            assert sim._a.tobytes() == ref._a.tobytes(), (engine, mode, program)
            assert sim._d.tobytes() == ref._d.tobytes(), (engine, mode, program)
