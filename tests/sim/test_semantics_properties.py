"""Invariants of the shared primitive definitions, the ICW bit encoding and the drawing
geometry."""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from ppaloc.sim import OPS
from ppaloc.sim.bits import decode, encode
from ppaloc.sim.draw import circle_points, line_points
from ppaloc.sim.isa import make
from ppaloc.sim.registers import (
    ANALOG_PLANES,
    DIGITAL_PLANES,
    DNEWS_SELECTORS,
    XE,
    XN,
    XS,
    XW,
)
from ppaloc.sim.semantics import diffuse, propagate

shapes = st.tuples(st.integers(1, 7), st.integers(1, 7))


@st.composite
def planes(draw, dtype):
    shape = draw(shapes)
    if dtype is bool:
        return draw(arrays(bool, shape))
    return draw(arrays(np.float32, shape, elements=st.floats(-128, 127, width=32)))


@settings(max_examples=60, deadline=None)
@given(planes(float), st.booleans(), st.booleans(), st.integers(1, 3))
def test_diffusion_keeps_the_sum_and_the_range(x, h, v, steps) -> None:
    y = diffuse(x, horizontal=h, vertical=v, steps=steps)
    assert abs(float(y.sum(dtype=np.float64)) - float(x.sum(dtype=np.float64))) < 1e-2 * x.size
    assert y.min() >= x.min() - 1e-3 and y.max() <= x.max() + 1e-3  # an average, no overshoot
    c = np.full_like(x, 9.5)
    np.testing.assert_array_equal(diffuse(c, horizontal=h, vertical=v, steps=steps), c)


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_propagation_is_monotone_bounded_and_idempotent(data) -> None:
    shape = data.draw(shapes)
    seed, mask = (data.draw(arrays(bool, shape)) for _ in range(2))
    sels = {d: data.draw(arrays(bool, shape)) for d in DNEWS_SELECTORS}
    edge = data.draw(st.booleans())
    out = propagate(seed, mask, sels, edge)
    assert (out >= seed).all()  # seeds stay
    assert not (out & ~seed & ~mask).any()  # new 1s only where the mask lets them
    np.testing.assert_array_equal(propagate(out, mask, sels, edge), out)  # a fixed point


_ANALOG_LOCAL = [r for r in ANALOG_PLANES if r.role in ("general", "news")]
_ANALOG_SRC = [r for r in ANALOG_PLANES if r.role != "news"] + [XN, XE, XS, XW]
_DIGITAL_DST = [r for r in DIGITAL_PLANES if r.role == "general"]
_DIGITAL_SRC = list(DIGITAL_PLANES)


@st.composite
def instructions(draw):
    op = draw(st.sampled_from(sorted(set(OPS) - {"PROP_R", "PROP0", "PROP1", "blurset"})))
    spec = OPS[op]
    if spec.dst_kind == "analog":
        dst_pool, src_pool = _ANALOG_LOCAL, _ANALOG_SRC
    else:
        dst_pool, src_pool = _DIGITAL_DST, _DIGITAL_SRC
    n_dst = draw(st.integers(*spec.n_dst))
    dsts = draw(st.lists(st.sampled_from(dst_pool), min_size=n_dst, max_size=n_dst, unique=True))
    if spec.src_kind == "digital":
        src_pool = _DIGITAL_SRC
    names = {d.name for d in dsts}
    if spec.src_kind == "analog" and any(d.role == "news" for d in dsts):
        src_pool = [r for r in src_pool if r.role != "neighbour"]
    pool = [r for r in src_pool if r.name not in names]
    lo, hi = spec.n_src
    if lo > len(pool):
        return make("nop")
    n_src = draw(st.integers(lo, min(hi, len(pool))))
    srcs = draw(st.lists(st.sampled_from(pool), min_size=n_src, max_size=n_src, unique=True))
    try:
        return make(op, tuple(dsts), tuple(srcs))
    except Exception:
        return make("nop")


@settings(max_examples=300, deadline=None)
@given(instructions())
def test_every_encoded_word_decodes_back(ins) -> None:
    # RECT's read bits include SELECT's: a word reading both is RECT's word
    assume(not {"RECT", "SELECT"} <= {r.name for r in ins.srcs})
    back = decode(*encode(ins))
    # the registers come back; only their order is lost (a word is a set of bits), and
    # a busn that fits a fixed form comes back as that form (the same bits)
    same_op = back.op == ins.op or (ins.op == "busn" and back.op in ("bus", "bus2", "bus3"))
    assert same_op
    assert frozenset(back.dsts) == frozenset(ins.dsts)
    assert frozenset(back.srcs) == frozenset(ins.srcs)


@settings(max_examples=100, deadline=None)
@given(st.integers(-20, 20), st.integers(-20, 20), st.integers(-20, 20), st.integers(-20, 20))
def test_lines_are_8_connected_from_end_to_end(r0, c0, r1, c1) -> None:
    rows, cols = line_points(r0, c0, r1, c1)
    assert (rows[0], cols[0], rows[-1], cols[-1]) == (r0, c0, r1, c1)
    assert len(rows) == max(abs(r1 - r0), abs(c1 - c0)) + 1
    assert (np.abs(np.diff(rows)) <= 1).all() and (np.abs(np.diff(cols)) <= 1).all()


@settings(max_examples=50, deadline=None)
@given(st.integers(-5, 5), st.integers(-5, 5), st.integers(0, 30))
def test_circle_points_lie_on_the_radius(r, c, radius) -> None:
    rows, cols = circle_points(r, c, radius)
    dist = np.hypot(rows - r, cols - c)
    assert (np.abs(dist - radius) < 1).all()
    assert {(r + radius, c), (r - radius, c), (r, c + radius), (r, c - radius)} <= set(
        zip(rows.tolist(), cols.tolist(), strict=True)
    )
