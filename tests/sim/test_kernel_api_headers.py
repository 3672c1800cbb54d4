"""The kernel API of ``scamp5_kernel_api*.hpp`` / ``scamp5_icw.hpp``: expansions, raw words,
the shared ICW stack and the modelled analogue / asynchronous primitives."""

from __future__ import annotations

import gc

import numpy as np
import pytest

from ppaloc.errors import RegisterMisuseError
from ppaloc.sim import (
    FLAG,
    IN,
    MAX_ICWS,
    NEWS,
    PIX,
    R0,
    R1,
    R2,
    R3,
    R4,
    R5,
    R6,
    R7,
    R8,
    R12,
    SELECT,
    XE,
    XW,
    A,
    B,
    C,
    D,
    E,
    IcwStackWarning,
    Scamp5,
    east,
    north,
    south,
    west,
)
from ppaloc.sim.bits import decode, encode
from ppaloc.sim.registers import RECT
from ppaloc.sim.semantics import diffuse


def listing(call) -> list[str]:
    sim = Scamp5(4, 4)
    with sim.kernel() as k:
        call(k)
    return [str(i) for i in k]


# ------------------------------------------------------------------ header expansions
# Each list is the header's push_icw sequence for the macro, written in ppaloc's op names.
GOLDEN = {
    "gauss(A, B)": (
        lambda k: k.gauss(A, B),
        ["blurset(R1, R2)", "blur(NEWS, B)", "blur(A, NEWS)"]
        + ["blur(NEWS, A)", "blur(A, NEWS)"] * 2,
    ),
    "gauss(A, A, 1)": (
        lambda k: k.gauss(A, A, 1),
        ["blurset(R1, R2)", "blur(NEWS, A)", "blur(A, NEWS)"],
    ),
    "gaussh(C, D, 2)": (
        lambda k: k.gaussh(C, D, 2),
        ["blurset(R1, R2)", "blurh(NEWS, D)", "blurh(C, NEWS)", "blurh(NEWS, C)", "blurh(C, NEWS)"],
    ),
    "gaussv(E, A, 1)": (
        lambda k: k.gaussv(E, A, 1),
        ["blurset(R1, R2)", "blurv(NEWS, A)", "blurv(E, NEWS)"],
    ),
    "PROP0()": (lambda k: k.PROP0(), ["PROP_R(R12)", "PROP0(R12)"]),
    "PROP1()": (lambda k: k.PROP1(), ["PROP_R(R12)", "PROP1(R12)"]),
    "sq(A)": (lambda k: k.sq(A), ["sq(NEWS, A)"]),
    "sq(A, B)": (lambda k: k.sq(A, B), ["sq(NEWS, A, B)"]),
    "blurset()": (lambda k: k.blurset(), ["blurset(R1, R2)"]),
    "blur(A, B)": (lambda k: k.blur(A, B), ["blur(A, B)"]),
    "bus({A}, {B, C})": (lambda k: k.bus((A,), (B, C)), ["bus(A, B, C)"]),
    "bus({A, B}, {C})": (lambda k: k.bus((A, B), (C,)), ["bus2(A, B, C)"]),
    "bus({A, B, C}, {D})": (lambda k: k.bus((A, B, C), (D,)), ["bus3(A, B, C, D)"]),
    "bus({A, B, C, D}, {E})": (lambda k: k.bus((A, B, C, D), (E,)), ["busn(A, B, C, D, E)"]),
    "bus({A, B}, {C, D, E})": (lambda k: k.bus((A, B), (C, D, E)), ["busn(A, B, C, D, E)"]),
}


# The macros of the earlier rounds, from the same headers (scamp5_kernel_api_macro_*.hpp).
GOLDEN.update(
    {
        "res(A)": (lambda k: k.res(A), ["bus(NEWS)", "bus(A, NEWS)"]),
        "res(A, B)": (lambda k: k.res(A, B), ["bus(NEWS)", "bus(A, NEWS)", "bus(B, NEWS)"]),
        "mov(A, B)": (lambda k: k.mov(A, B), ["bus(NEWS, B)", "bus(A, NEWS)"]),
        "add(A, B, C)": (lambda k: k.add(A, B, C), ["bus(NEWS, B, C)", "bus(A, NEWS)"]),
        "add(A, B, C, D)": (lambda k: k.add(A, B, C, D), ["bus(NEWS, B, C, D)", "bus(A, NEWS)"]),
        "sub(A, B, C)": (lambda k: k.sub(A, B, C), ["bus(NEWS, B)", "bus(A, NEWS, C)"]),
        "neg(A, B)": (lambda k: k.neg(A, B), ["bus(NEWS)", "bus(A, NEWS, B)"]),
        "abs(A, B)": (
            lambda k: k.abs(A, B),
            ["bus(NEWS)", "bus(A, NEWS, B)", "bus(NEWS, B)", "where(B)", "bus(A, NEWS)", "all()"],
        ),
        "divq(A, B)": (lambda k: k.divq(A, B), ["bus2(A, NEWS, B)", "bus(A, NEWS)"]),
        "div(A, B, C)": (
            lambda k: k.div(A, B, C),
            ["bus2(A, B, C)", "bus(NEWS, C, B)", "bus(C, NEWS, A)", "bus2(A, B, C)", "bus(A, B)"],
        ),
        "div(A, B, C, D)": (
            lambda k: k.div(A, B, C, D),
            ["bus2(A, B, D)", "bus(NEWS, D, B)", "bus(C, NEWS, A)", "bus2(A, B, C)", "bus(A, B)"],
        ),
        "div(A, B, C, C)": (  # x0 may be y2: the 3-argument form's expansion
            lambda k: k.div(A, B, C, C),
            ["bus2(A, B, C)", "bus(NEWS, C, B)", "bus(C, NEWS, A)", "bus2(A, B, C)", "bus(A, B)"],
        ),
        "diva(A, B, C)": (
            lambda k: k.diva(A, B, C),
            ["bus2(B, C, A)", "bus(NEWS, B, A)", "bus(A, NEWS, C)", "bus2(B, C, A)", "bus(A, B)"],
        ),
        "movx(A, B, east)": (lambda k: k.movx(A, B, east), ["bus(XW, B)", "bus(A, NEWS)"]),
        "movx(A, B, west)": (lambda k: k.movx(A, B, west), ["bus(XE, B)", "bus(A, NEWS)"]),
        "movx(A, B, north)": (lambda k: k.movx(A, B, north), ["bus(XS, B)", "bus(A, NEWS)"]),
        "movx(A, B, south)": (lambda k: k.movx(A, B, south), ["bus(XN, B)", "bus(A, NEWS)"]),
        "mov(A, B, west)": (lambda k: k.mov(A, B, west), ["bus(XE, B)", "bus(A, NEWS)"]),
        "sub(A, B, east, C)": (lambda k: k.sub(A, B, east, C), ["bus(NEWS, B)", "bus(A, XE, C)"]),
        "sub(A, B, south, C)": (
            lambda k: k.sub(A, B, south, C),
            ["bus(NEWS, B)", "bus(A, XS, C)"],
        ),
        "mov2x(A, B, east, north)": (
            lambda k: k.mov2x(A, B, east, north),
            ["bus(XW, B)", "bus(A, XN)"],
        ),
        "addx(A, B, C, south)": (
            lambda k: k.addx(A, B, C, south),
            ["bus(XN, B, C)", "bus(A, NEWS)"],
        ),
        "add2x(A, B, C, west, south)": (
            lambda k: k.add2x(A, B, C, west, south),
            ["bus(XE, B, C)", "bus(A, XS)"],
        ),
        "subx(A, B, north, C)": (
            lambda k: k.subx(A, B, north, C),
            ["bus(XS, B)", "bus(A, NEWS, C)"],
        ),
        "sub2x(A, B, east, west, C)": (
            lambda k: k.sub2x(A, B, east, west, C),
            ["bus(XW, B)", "bus(A, XW, C)"],
        ),
        "get_image(A)": (
            lambda k: k.get_image(A),
            ["bus(NEWS, PIX)", "rpix()", "rpix()", "nop()", "bus(A, NEWS, PIX)"],
        ),
        "get_image(A, B)": (
            lambda k: k.get_image(A, B),
            ["bus(NEWS, PIX)", "bus(B, PIX)", "rpix()", "rpix()", "nop()", "bus(A, B, NEWS, PIX)"],
        ),
        "respix()": (lambda k: k.respix(), ["rpix()", "rpix()", "nop()"]),
        "respix(A)": (
            lambda k: k.respix(A),
            ["rpix()", "rpix()", "nop()", "bus(NEWS, PIX)", "bus(A, NEWS)"],
        ),
        "getpix(A, B)": (lambda k: k.getpix(A, B), ["bus(NEWS, PIX)", "bus(A, NEWS, B)"]),
        "getpix(A, B, C)": (
            lambda k: k.getpix(A, B, C),
            ["bus(B, PIX)", "bus(NEWS, PIX)", "bus(A, B, NEWS, C)"],
        ),
        "newsblur(A, B, 2)": (
            lambda k: k.newsblur(A, B, 2),
            ["bus(NEWS, B)", "bus(A, XE, XW, XN, XS)", "bus(NEWS, A)", "bus(A, XE, XW, XN, XS)"],
        ),
        "newsblurh(A, B)": (lambda k: k.newsblurh(A, B), ["bus(NEWS, B)", "bus(A, XE, XW)"]),
        "newsblurv(A, B)": (lambda k: k.newsblurv(A, B), ["bus(NEWS, B)", "bus(A, XN, XS)"]),
        "NOT(R5)": (lambda k: k.NOT(R5), ["LATCHN(R5)", "UNLATCH(R5)"]),
        "OR(R5, R6)": (lambda k: k.OR(R5, R6), ["LATCH(R5, R6)", "UNLATCH(R5)"]),
        "NOR(R5, R6)": (lambda k: k.NOR(R5, R6), ["LATCHN(R5, R6)", "UNLATCH(R5)"]),
        "DNEWS(R5, R6, north | east)": (
            lambda k: k.DNEWS(R5, R6, north | east),
            ["CLR(R1, R2, R3, R4)", "SET(R3, R4)", "DNEWS0(R5, R6)"],
        ),
        "DNEWS(R5, R6, south | west, 1)": (
            lambda k: k.DNEWS(R5, R6, south | west, 1),
            ["CLR(R1, R2, R3, R4)", "SET(R1, R2)", "DNEWS1(R5, R6)"],
        ),
        "AND(R5, R6, R7)": (
            lambda k: k.AND(R5, R6, R7),
            ["SET(R0)", "NOT(R12, R6)", "NOT(R0, R7)", "NOR(R5, R0, R12)"],
        ),
        "NAND(R5, R6, R7)": (
            lambda k: k.NAND(R5, R6, R7),
            ["SET(R0)", "NOT(R12, R6)", "NOT(R0, R7)", "OR(R5, R0, R12)"],
        ),
        "ANDX(R5, R6, R7)": (
            lambda k: k.ANDX(R5, R6, R7),
            ["NOT(R0, R6)", "NOT(R6, R7)", "NOR(R5, R0, R6)"],
        ),
        "NANDX(R5, R6, R7)": (
            lambda k: k.NANDX(R5, R6, R7),
            ["NOT(R0, R6)", "NOT(R6, R7)", "OR(R5, R0, R6)"],
        ),
        "IMP(R5, R6, R7)": (lambda k: k.IMP(R5, R6, R7), ["NOT(R0, R7)", "OR(R5, R6, R0)"]),
        "NIMP(R5, R6, R7)": (lambda k: k.NIMP(R5, R6, R7), ["NOT(R0, R7)", "NOR(R5, R6, R0)"]),
        "XORX(R5, R6, R7)": (
            lambda k: k.XORX(R5, R6, R7),
            [
                "NOT(R0, R7)",
                "NOR(R5, R6, R0)",
                "NOT(R0, R6)",
                "NOR(R6, R7, R0)",
                "LATCH(R5, R6)",
                "UNLATCH(R5)",
            ],
        ),
        "MUX(R5, R6, R7, R8)": (
            lambda k: k.MUX(R5, R6, R7, R8),
            ["SET(R0)", "MOV(R12, R8)", "MOV(R0, R6)", "MOV(R12, R7)", "MOV(R5, R12)"],
        ),
        "CLR_IF(R5, R6)": (lambda k: k.CLR_IF(R5, R6), ["NOT(R0, R5)", "NOR(R5, R0, R6)"]),
        "REFRESH(R5)": (lambda k: k.REFRESH(R5), ["LATCH(R5)", "UNLATCH(R5)"]),
    }
)


@pytest.mark.parametrize("name", list(GOLDEN))
def test_macro_expands_to_the_header_sequence(name) -> None:
    call, want = GOLDEN[name]
    assert listing(call) == want


def test_clock_classes_of_the_new_icws() -> None:
    sim = Scamp5(4, 4)
    with sim.kernel() as k:
        k.gauss(A, B, 1)  # blurset: digital clock; blurs: analogue
        k.PROP0()  # PROP_R: clock 0 (analogue); PROP_0: the PROP clock, counted as dnews
        k.sq(A)
    assert k.counts == {"analog": 4, "digital": 1, "dnews": 1, "nop": 0}


# ------------------------------------------------------------------ raw ICW words
def test_raw_words_from_the_header_bits() -> None:
    # bus(A, B): W1 (13) with A's and B's select bits SEL1 (21), SEL2 (22)
    assert str(decode(0, {13, 21, 22})) == "bus(A, B)"
    # bus(XW, C): the NEWS write bit W4 (16), SEL4 (24) with selw (29), and C's SEL3 (23)
    assert str(decode(0, {16, 24, 29, 23})) == "bus(XW, C)"
    assert str(decode(0, {2, 1})) == "rpix()"
    assert str(decode(0, {28, 61, 11})) == "all()"
    assert str(decode(0, {20, 21})) == "where(A)"
    # MOV(R5, R6): clk 1, s_in plrb bit bitmode, LR5 (48), RR6 (37)
    assert str(decode(1, {5, 61, 62, 63, 48, 37})) == "MOV(R5, R6)"
    assert str(decode(1, {5, 60, 48, 49})) == "SET(R5, R6)"
    # the two halves of the NOT(Rl) macro: read with nbit, write with nbit
    assert str(decode(1, {61, 58, 36})) == "LATCHN(R5)"
    assert str(decode(1, {58, 48})) == "UNLATCH(R5)"
    assert str(decode(2, {5, 11, 59, 61, 62, 31, 30, 48, 37})) == "DNEWS1(R5, R6)"
    assert str(decode(1, {32, 33})) == "blurset(R1, R2)"
    assert str(decode(0, {3, 4, 13, 21, 22})) == "blur(A, B)"
    assert str(decode(3, {5, 43, 55, 31, 11, 59})) == "PROP0(R12)"
    assert str(decode(1, {5, 61, 62, 63, 48, 64, 72, 76})) == "MOV(R5, RECT)"


def test_raw_icw_runs_like_the_named_op() -> None:
    a, b = Scamp5(3, 3), Scamp5(3, 3)
    for sim in (a, b):
        sim.write(B, np.arange(9.0).reshape(3, 3))
    a.icw(0, [13, 21, 22])  # bus(A, B)
    b.bus(A, B)
    np.testing.assert_array_equal(a.read(A), b.read(A))


def test_encode_decode_round_trip() -> None:
    sim = Scamp5(4, 4)
    with sim.kernel() as k:
        k.bus(A, B, C)
        k.bus((A, B, C, D), (E,))
        k.bus(XW, A)
        k.bus(A, XE, PIX, IN)
        k.gauss(A, B, 1)
        k.PROP1()
        k.sq(A, B)
        k.AND(R5, R1, R2)
        k.DNEWS(R3, R5, east)
        k.MOV(R5, SELECT)
        k.MOV(R5, RECT)
        k.MOV(R0, FLAG)
    for ins in k:
        back = decode(*encode(ins))
        assert (back.op, back.dsts, set(back.srcs)) == (ins.op, ins.dsts, set(ins.srcs))


def test_encode_spells_latch_halves_as_their_macro() -> None:
    # the header's words (scamp5_kernel_api_macro_digital.hpp, scamp5_icw.hpp): NOT and NOR
    # write back with nbit, OR with bit and bitmode, REFRESH_R / REFRESH_L set s_in
    sim = Scamp5(2, 2)
    with sim.kernel() as k:
        k.NOT(R5)
        k.NOR(R5, R6)
        k.OR(R5, R6)
        k.REFRESH(R5)
    words = [(clock, sorted(bits)) for clock, bits in map(encode, k)]
    assert words == [
        (1, [36, 58, 61]),
        (1, [48, 58]),
        (1, [36, 37, 58, 61]),
        (1, [48, 58]),
        (1, [36, 37, 61, 62, 63]),
        (1, [48, 62, 63]),
        (1, [5, 36, 61, 62, 63]),
        (1, [5, 48, 62, 63]),
    ]
    for ins in k:
        back = decode(*encode(ins))
        assert (back.op, back.dsts, back.srcs) == (ins.op, ins.dsts, ins.srcs)


@pytest.mark.parametrize(
    ("clock", "bits", "message"),
    [
        (4, {1}, "the clock must be 0"),
        (0, {80}, "bit positions run from 0 to 79"),
        (0, {16, 24}, "exactly one of NEWS, XN"),
        (3, {5}, "PROP clock"),
        (0, "x", "must be bit positions"),
        (0, [13.7], r"bits=\[13.7\] must be bit positions"),  # not taken as bit 13
        (0, [True], "must be bit positions"),
        (0, 5, "must be bit positions"),
        # named as the program writes it (icw(1,{plrb,bit,bitmode,wr,LR4}) of the public VO
        # program), not by bit numbers
        (1, {61, 62, 63, 64, 47}, r"icw\(1, \{LR4, plrb, bit, bitmode, wr\}\): no modelled"),
    ],
)
def test_raw_word_mistakes(clock, bits, message) -> None:
    with pytest.raises(RegisterMisuseError, match=message):
        Scamp5(2, 2).icw(clock, bits)


# ------------------------------------------------------------------ semantics
def test_blur_negates_a_diffusion_that_keeps_sum_and_constants() -> None:
    sim = Scamp5(5, 5)
    x = np.zeros((5, 5), np.float32)
    x[2, 2] = 80
    sim.write(B, x)
    sim.SET(R1, R2)  # every link conducts
    sim.blur(A, B)
    got = sim.read(A)
    np.testing.assert_allclose(got, -diffuse(x))
    assert got.sum() == pytest.approx(-80) and got[2, 2] == -40 and got[1, 2] == -10
    sim.write(B, np.full((5, 5), 12.0))
    sim.gauss(A, B)
    np.testing.assert_allclose(sim.read(A), 12.0)


def test_blur_links_follow_r1_and_r2() -> None:
    sim = Scamp5(3, 3)
    x = np.zeros((3, 3), np.float32)
    x[1, 1] = 64
    sim.write(B, x)
    sim.CLR(R1, R2)  # no link: a blur is a plain negated copy
    sim.blur(A, B)
    np.testing.assert_array_equal(sim.read(A), -x)
    sim.SET(R2)  # east-west links only
    sim.blur(A, B)
    assert sim.read(A)[0].tolist() == [0, 0, 0] and sim.read(A)[1, 0] == -8
    sim.SET(R1)
    sim.blurh(A, B)  # horizontal only, whatever R1 says
    assert sim.read(A)[0, 1] == 0


def test_blur_obeys_flag() -> None:
    sim = Scamp5(2, 2)
    sim.write(B, np.full((2, 2), 10.0))
    sim.write(A, np.full((2, 2), 3.0))
    sim.write(FLAG, np.array([[1, 0], [0, 1]], bool))
    sim.SET(R1, R2)
    sim.blur(A, B)
    assert sim.read(A).tolist() == [[-10, 3], [3, -10]]


def test_prop_floods_r12_through_r0() -> None:
    sim = Scamp5(5, 5)
    mask = np.ones((5, 5), bool)
    mask[:, 2] = False  # a wall
    seed = np.zeros((5, 5), bool)
    seed[0, 0] = True
    sim.write(R0, mask)
    sim.write(R12, seed)
    sim.SET(R1, R2, R3, R4)
    sim.PROP0()
    want = np.zeros((5, 5), bool)
    want[:, :2] = True
    np.testing.assert_array_equal(sim.read(R12), want)
    sim.write(R12, np.zeros((5, 5), bool))
    sim.PROP1()  # the edge counts as 1: both sides of the wall fill
    np.testing.assert_array_equal(sim.read(R12), mask)


def test_prop_follows_the_selectors() -> None:
    sim = Scamp5(1, 5)
    sim.write(R0, np.ones((1, 5), bool))
    sim.write(R12, np.array([[0, 0, 1, 0, 0]], bool))
    sim.CLR(R1, R2, R3, R4)
    sim.SET(R2)  # every element reads its west neighbour: the 1 runs east
    sim.PROP0()
    assert sim.read(R12).astype(int).tolist() == [[0, 0, 1, 1, 1]]


def test_sq_writes_news_only() -> None:
    sim = Scamp5(2, 2)
    sim.write(A, np.full((2, 2), 5.0))
    sim.write(B, np.full((2, 2), 7.0))
    sim.sq(A)
    assert (sim.read(NEWS) == -5).all() and (sim.read(B) == 7).all()


def test_several_destination_bus_splits_the_current() -> None:
    sim = Scamp5(2, 2)
    sim.write(E, np.full((2, 2), 40.0))
    sim.bus((A, B, C, D), (E,))
    for r in (A, B, C, D):
        assert (sim.read(r) == -10).all()


def test_rect_is_read_only() -> None:
    with pytest.raises(RegisterMisuseError, match="RECT cannot be written"):
        Scamp5(2, 2).MOV(RECT, R5)


# ------------------------------------------------------------------ the shared ICW stack
def test_live_kernels_share_the_stack() -> None:
    sim = Scamp5(2, 2)
    with sim.kernel() as first:
        for _ in range(1000):
            first.nop()
    with (
        pytest.warns(IcwStackWarning, match="lost 6 of its 30 ICWs") as said,
        sim.kernel() as second,
    ):
        for _ in range(30):
            second.nop()
    assert len(said) == 1  # once per kernel, at the end of its recording
    assert len(second) == MAX_ICWS - 1000 and second.dropped == 6
    del second
    gc.collect()
    with sim.kernel() as third:  # the freed kernel's room is back
        for _ in range(24):
            third.nop()
    assert third.dropped == 0


def test_nested_kernels_count_together() -> None:
    sim = Scamp5(2, 2)
    with sim.kernel() as outer:
        for _ in range(600):
            outer.nop()
        with pytest.warns(IcwStackWarning, match="lost 176 of"), sim.kernel() as inner:
            for _ in range(600):
                inner.nop()
    assert len(outer) == 600 and len(inner) == MAX_ICWS - 600


def test_move_to_heap_leaves_the_stack() -> None:
    sim = Scamp5(2, 2)
    with sim.kernel() as big:
        big.move_to_heap(True)
        for _ in range(MAX_ICWS):
            big.nop()
    with sim.kernel() as k:
        for _ in range(MAX_ICWS):
            k.nop()
    assert len(big) == len(k) == MAX_ICWS and not k.dropped


def test_leave_stack_frees_the_room_and_keeps_the_recording() -> None:
    sim = Scamp5(2, 2)
    with sim.kernel() as old:
        for _ in range(MAX_ICWS):
            old.nop()
    old.leave_stack()  # the C++ object deleted: its room goes back to the stack
    with sim.kernel() as k:
        for _ in range(MAX_ICWS):
            k.nop()
    assert not k.dropped and len(old) == MAX_ICWS


def test_a_failed_recording_frees_its_room() -> None:
    sim = Scamp5(2, 2)
    with pytest.raises(ZeroDivisionError), sim.kernel() as k:
        for _ in range(MAX_ICWS):
            k.nop()
        1 / 0  # noqa: B018
    with sim.kernel() as k2:
        for _ in range(MAX_ICWS):
            k2.nop()
    assert not k2.dropped
