"""Property test: random macro programs in ideal mode equal a plain numpy reference.

The reference below interprets each macro directly on float64/bool arrays, following the
documented semantics (sums negated and clipped to [-128, 127] at every bus, NEWS as the
analogue scratch, R0/R12 as the digital scratch, neighbours beyond the edge reading 0, or
the DNEWS boundary value). It shares no code with the engine.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import ppaloc.sim as s

ROWS, COLS = 3, 4
AREGS = ["A", "B", "C", "D", "E", "F"]
DREGS = ["R5", "R6", "R7", "R8", "R9", "R10", "R11"]
DIRS = {"north": (-1, 0), "east": (0, 1), "south": (1, 0), "west": (0, -1)}
SELECTOR = {"south": "R1", "west": "R2", "north": "R3", "east": "R4"}


def c(v: np.ndarray) -> np.ndarray:
    return np.clip(v, -128, 127)


def shift(x: np.ndarray, d: str, fill=0) -> np.ndarray:
    """x of the neighbour in direction d; `fill` beyond the edge."""
    dr, dc = DIRS[d]
    padded = np.pad(x, 1, constant_values=fill)
    return padded[1 + dr : 1 + dr + ROWS, 1 + dc : 1 + dc + COLS].copy()


class Reference:
    """A slow, direct interpreter of macro programs."""

    def __init__(self, a: dict[str, np.ndarray], d: dict[str, np.ndarray]) -> None:
        self.a = {k: v.astype(np.float64) for k, v in a.items()}
        self.d = {k: v.copy() for k, v in d.items()}

    def apply(self, step: tuple) -> None:
        a, d = self.a, self.d
        op, *args = step
        if op == "mov":
            y, x = args
            a["NEWS"] = c(-a[x])
            a[y] = c(-a["NEWS"])
        elif op == "add":
            y, *xs = args
            a["NEWS"] = c(-sum(a[x] for x in xs))
            a[y] = c(-a["NEWS"])
        elif op == "sub":
            y, x0, x1 = args
            a["NEWS"] = c(-a[x0])
            a[y] = c(-(a["NEWS"] + a[x1]))
        elif op == "neg":
            y, x = args
            a["NEWS"] = np.zeros((ROWS, COLS))
            a[y] = c(-a[x])
        elif op == "abs":
            y, x = args
            a[y] = c(-a[x])
            a["NEWS"] = c(-a[x])
            a[y] = np.where(a[x] > 0, c(-a["NEWS"]), a[y])
            d["FLAG"] = np.ones((ROWS, COLS), dtype=bool)
        elif op == "divq":
            y, x = args
            a["NEWS"] = c(-a[x] / 2)
            a[y] = c(-a["NEWS"])
        elif op == "div":
            y0, y1, y2, x = args
            a[y0] = a[y1] = c(-a[x] / 2)
            a["NEWS"] = c(-(a[x] + a[y1]))
            a[y2] = c(-(a["NEWS"] + a[y0]))
            a[y0] = a[y1] = c(-a[y2] / 2)
            a[y0] = c(-a[y1])
        elif op == "movx":
            y, x, direction = args
            a["NEWS"] = c(-shift(a[x], direction))
            a[y] = c(-a["NEWS"])
        elif op == "subx":
            y, x0, direction, x1 = args
            a["NEWS"] = c(-shift(a[x0], direction))
            a[y] = c(-(a["NEWS"] + a[x1]))
        elif op == "where_mov":
            f, y, x = args
            flag = a[f] > 0
            a["NEWS"] = np.where(flag, c(-a[x]), a["NEWS"])
            a[y] = np.where(flag, c(-a["NEWS"]), a[y])
            d["FLAG"] = np.ones((ROWS, COLS), dtype=bool)
        elif op == "where_movx":
            f, y, x, direction = args
            flag = a[f] > 0
            # the sender (neighbour in `direction`) drives only if flagged; edge reads 0
            pushed = shift(np.where(flag, a[x], 0.0), direction)
            a["NEWS"] = np.where(flag, c(-pushed), a["NEWS"])
            a[y] = np.where(flag, c(-a["NEWS"]), a[y])
            d["FLAG"] = np.ones((ROWS, COLS), dtype=bool)
        elif op == "AND":
            r, x, y = args
            d["R12"] = ~d[x]
            d["R0"] = ~d[y]
            d[r] = ~(d["R0"] | d["R12"])
        elif op == "OR":
            r, x, y = args
            d[r] = d[x] | d[y]
        elif op == "XOR":
            r, x, y = args
            d["R12"] = ~d[x]
            d["R0"] = ~d[y]
            d[r] = ~(d["R0"] | d["R12"])
            d["R0"] = ~(d[x] | d[y])
            d[r] = ~(d[r] | d["R0"])
        elif op == "MUX":
            r, sel, x1, x0 = args
            d["R0"] = d[sel].copy()
            d["R12"] = np.where(d[sel], d[x1], d[x0])
            d[r] = d["R12"].copy()
        elif op == "NOT":
            r, x = args
            d[r] = ~d[x]
        elif op == "DNEWS":
            r, x, dirs, boundary = args
            for name, sel in SELECTOR.items():
                d[sel] = np.full((ROWS, COLS), name in dirs)
            out = np.zeros((ROWS, COLS), dtype=bool)
            for name in dirs:
                out |= shift(d[x], name, fill=bool(boundary))
            d[r] = out
        else:  # pragma: no cover
            raise AssertionError(op)


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

    ref = Reference(a0, d0)
    for step in program:
        ref.apply(step)

    for mode in ("direct", "kernel"):
        sim = s.Scamp5(rows=ROWS, cols=COLS)
        for name, v in a0.items():
            sim.write(getattr(s, name), v)
        for name, v in d0.items():
            sim.write(getattr(s, name), v)
        if mode == "direct":
            for step in program:
                issue(sim, step)
        else:
            with sim.kernel() as k:
                for step in program:
                    issue(k, step)
        for name, v in ref.a.items():
            assert np.array_equal(sim.read(getattr(s, name)), v), (mode, name, program)
        for name, v in ref.d.items():
            assert np.array_equal(sim.read(getattr(s, name)), v), (mode, name, program)
