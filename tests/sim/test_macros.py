"""Golden tests of every macro: results, ICW counts and the scratch registers they clobber."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import RegisterMisuseError
from ppaloc.sim import (
    FLAG,
    NEWS,
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
    A,
    B,
    C,
    D,
    E,
    F,
    Scamp5,
    east,
    north,
    south,
    west,
)

SHAPE = (4, 5)
X = np.arange(20, dtype=np.float32).reshape(SHAPE) * 2 - 19  # odd values -19..19
Y = np.full(SHAPE, 7.0, dtype=np.float32)
P = np.array([[1, 0, 1, 0, 1]] * 4, dtype=bool)
Q = np.array([[1, 1, 0, 0, 1]] * 4, dtype=bool)
S = np.array([[1], [0], [1], [0]], dtype=bool) & np.ones(SHAPE, dtype=bool)


def _shift(x: np.ndarray, direction, fill=0) -> np.ndarray:
    """x of the neighbour in `direction` (fill beyond the edge)."""
    dr, dc = direction.offset
    out = np.full_like(x, fill)
    rows, cols = x.shape
    out[max(0, -dr) : rows - max(0, dr), max(0, -dc) : cols - max(0, dc)] = x[
        max(0, dr) : rows - max(0, -dr), max(0, dc) : cols - max(0, -dc)
    ]
    return out


@pytest.fixture
def sim() -> Scamp5:
    s = Scamp5(rows=SHAPE[0], cols=SHAPE[1])
    s.write(A, X)
    s.write(B, Y)
    s.write(R5, P)
    s.write(R6, Q)
    s.write(R7, S)
    return s


def icws(sim: Scamp5, call) -> int:
    """Record ``call(k)`` in a kernel and return its ICW count."""
    with sim.kernel() as k:
        call(k)
    return len(k)


def test_mov_add_sub_neg_and_their_news(sim: Scamp5) -> None:
    assert icws(sim, lambda k: k.mov(C, A)) == 2
    assert np.array_equal(sim.read(C), X)
    assert np.array_equal(sim.read(NEWS), -X)
    assert icws(sim, lambda k: k.add(C, A, B)) == 2
    assert np.array_equal(sim.read(C), X + 7)
    assert np.array_equal(sim.read(NEWS), -(X + 7))
    assert icws(sim, lambda k: k.add(D, A, B, C)) == 2
    assert np.array_equal(sim.read(D), 2 * X + 14)
    assert icws(sim, lambda k: k.sub(C, A, B)) == 2
    assert np.array_equal(sim.read(C), X - 7)
    assert np.array_equal(sim.read(NEWS), -X)
    assert icws(sim, lambda k: k.neg(C, A)) == 2
    assert np.array_equal(sim.read(C), -X)
    assert np.array_equal(sim.read(NEWS), np.zeros(SHAPE))


def test_add_saturates_in_news_first() -> None:
    sim = Scamp5(rows=1, cols=2)
    sim.write(A, [[100, -100]])
    sim.write(B, [[100, -100]])
    sim.add(C, A, B)  # NEWS := clip(-200) then C := -NEWS
    assert np.array_equal(sim.read(NEWS), [[-128, 127]])
    assert np.array_equal(sim.read(C), [[127, -127]])


def test_abs_is_six_icws_and_leaves_flag_all(sim: Scamp5) -> None:
    sim.write(A, np.where(X == -19, -128, X))
    assert icws(sim, lambda k: k.abs(C, A)) == 6
    assert np.array_equal(sim.read(C), np.minimum(np.abs(np.where(X == -19, -128, X)), 127))
    assert sim.read(FLAG).all()


def test_res_zeroes_one_or_two_registers(sim: Scamp5) -> None:
    sim.write(C, X)
    sim.write(D, X)
    assert icws(sim, lambda k: k.res(C)) == 2
    assert np.array_equal(sim.read(C), np.zeros(SHAPE))
    sim.write(C, X)
    assert icws(sim, lambda k: k.res(C, D)) == 3
    assert not sim.read(C).any() and not sim.read(D).any()


def test_divisions(sim: Scamp5) -> None:
    assert icws(sim, lambda k: k.divq(C, A)) == 2
    assert np.array_equal(sim.read(C), X / 2)
    assert icws(sim, lambda k: k.div(C, D, E, A)) == 5
    assert np.array_equal(sim.read(C), X / 2)
    assert np.array_equal(sim.read(D), -X / 2)
    assert np.array_equal(sim.read(E), X)
    sim.write(F, X)
    assert icws(sim, lambda k: k.div(C, D, F)) == 5
    assert np.array_equal(sim.read(C), X / 2)
    assert np.array_equal(sim.read(F), X)
    sim.write(C, X)
    assert icws(sim, lambda k: k.diva(C, D, E)) == 5
    assert np.array_equal(sim.read(C), X / 2)
    assert np.array_equal(sim.read(D), -X / 2)
    assert np.array_equal(sim.read(E), -X / 2)


@pytest.mark.parametrize("d1", [north, east, south, west])
@pytest.mark.parametrize("d2", [north, east, south, west])
def test_mov2x_reads_two_steps_away(sim: Scamp5, d1, d2) -> None:
    assert icws(sim, lambda k: k.mov2x(C, A, d1, d2)) == 2
    # NEWS := -(x of the neighbour in d1); C := -(NEWS of the neighbour in d2)
    assert np.array_equal(sim.read(C), _shift(_shift(X, d1), d2))


@pytest.mark.parametrize("d", [north, east, south, west])
def test_addx_subx(sim: Scamp5, d) -> None:
    assert icws(sim, lambda k: k.addx(C, A, B, d)) == 2
    assert np.array_equal(sim.read(C), _shift(X + Y, d))
    assert icws(sim, lambda k: k.subx(C, A, d, B)) == 2
    assert np.array_equal(sim.read(C), _shift(X, d) - Y)
    assert icws(sim, lambda k: k.add2x(C, A, B, d, d)) == 2
    assert np.array_equal(sim.read(C), _shift(_shift(X + Y, d), d))
    assert icws(sim, lambda k: k.sub2x(C, A, d, d, B)) == 2
    assert np.array_equal(sim.read(C), _shift(_shift(X, d), d) - Y)


def test_mov_with_direction_is_movx(sim: Scamp5) -> None:
    sim.mov(C, A, east)
    assert np.array_equal(sim.read(C), _shift(X, east))


def test_newsblur_sums_the_four_neighbours(sim: Scamp5) -> None:
    assert icws(sim, lambda k: k.newsblur(C, A)) == 2
    total = sum(_shift(X, d) for d in (north, east, south, west))
    assert np.array_equal(sim.read(C), total)  # -(sum of neighbours' NEWS = -X)


def test_respix_keeps_reset_level(sim: Scamp5) -> None:
    sim.set_image(np.full(SHAPE, 200, dtype=np.uint8))
    assert icws(sim, lambda k: k.respix(C)) == 5
    assert np.array_equal(sim.read(C), np.zeros(SHAPE))
    assert icws(sim, lambda k: k.respix()) == 3


def test_get_image_icw_counts(sim: Scamp5) -> None:
    sim.set_image(np.zeros(SHAPE, dtype=np.uint8))
    assert icws(sim, lambda k: k.get_image(C, D)) == 6
    assert icws(sim, lambda k: k.get_image(C)) == 5


# --------------------------------------------------------------------- digital macros
def test_and_clobbers_r0_and_r12(sim: Scamp5) -> None:
    assert icws(sim, lambda k: k.AND(R8, R5, R6)) == 4
    assert np.array_equal(sim.read(R8), P & Q)
    assert np.array_equal(sim.read(R0), ~Q)
    assert np.array_equal(sim.read(R12), ~P)


def test_nand_imp_nimp_clr_if(sim: Scamp5) -> None:
    assert icws(sim, lambda k: k.NAND(R8, R5, R6)) == 4
    assert np.array_equal(sim.read(R8), ~(P & Q))
    assert icws(sim, lambda k: k.IMP(R8, R5, R6)) == 2
    assert np.array_equal(sim.read(R8), P | ~Q)
    assert icws(sim, lambda k: k.NIMP(R8, R5, R6)) == 2
    assert np.array_equal(sim.read(R8), ~P & Q)
    sim.write(R8, P)
    assert icws(sim, lambda k: k.CLR_IF(R8, R6)) == 2
    assert np.array_equal(sim.read(R8), P & ~Q)


def test_xor(sim: Scamp5) -> None:
    assert icws(sim, lambda k: k.XOR(R8, R5, R6)) == 7
    assert np.array_equal(sim.read(R8), P ^ Q)


def test_mux_selects_and_clobbers(sim: Scamp5) -> None:
    assert icws(sim, lambda k: k.MUX(R8, R7, R5, R6)) == 5
    assert np.array_equal(sim.read(R8), np.where(S, P, Q))
    assert np.array_equal(sim.read(R0), S)
    assert np.array_equal(sim.read(R12), np.where(S, P, Q))


def test_two_icw_or_nor_not_macros(sim: Scamp5) -> None:
    sim.write(R8, P)
    assert icws(sim, lambda k: k.OR(R8, R6)) == 2
    assert np.array_equal(sim.read(R8), P | Q)
    sim.write(R8, P)
    assert icws(sim, lambda k: k.NOR(R8, R6)) == 2
    assert np.array_equal(sim.read(R8), ~(P | Q))
    sim.write(R8, P)
    assert icws(sim, lambda k: k.NOT(R8)) == 2
    assert np.array_equal(sim.read(R8), ~P)
    assert icws(sim, lambda k: k.REFRESH(R8)) == 2
    assert np.array_equal(sim.read(R8), ~P)


@pytest.mark.parametrize("d", [north, east, south, west])
@pytest.mark.parametrize("boundary", [0, 1])
def test_dnews_macro_every_direction(sim: Scamp5, d, boundary) -> None:
    assert icws(sim, lambda k: k.DNEWS(R8, R5, d, boundary)) == 3
    assert np.array_equal(sim.read(R8), _shift(P, d, fill=bool(boundary)))
    selectors = {south: R1, west: R2, north: R3, east: R4}
    for direction, reg in selectors.items():
        assert sim.read(reg).all() == (direction == d)


def test_dnews_macro_several_directions(sim: Scamp5) -> None:
    sim.DNEWS(R8, R7, north | south)
    assert np.array_equal(sim.read(R8), _shift(S, north) | _shift(S, south))


# ------------------------------------------------------------------------ misuse
@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda s: s.sub(A, B, A), r"in sub\(A, B, A\): bus\(A, NEWS, A\) lists A twice"),
        (lambda s: s.abs(A, A), r"in abs\(A, A\): bus\(A, NEWS, A\) lists A twice"),
        (lambda s: s.mov(NEWS, A), r"in mov\(NEWS, A\): bus\(NEWS, NEWS\) lists NEWS twice"),
        (lambda s: s.div(A, B, A), r"div\(A, B, A\): A appears twice"),
        (lambda s: s.div(A, B, C, A), r"div\(A, B, C, A\): A appears twice"),
        (lambda s: s.diva(A, A, B), r"diva\(A, A, B\): A appears twice"),
        (lambda s: s.movx(A, B, 3), r"movx\(A, B, 3\): direction 3 is not one of"),
        (lambda s: s.AND(R5, R0, R6), r"AND\(R5, R0, R6\): R0 cannot be an argument"),
        (lambda s: s.MUX(R12, R5, R6, R7), r"MUX\(R12, R5, R6, R7\): R12 cannot be"),
        (lambda s: s.XOR(R5, R5, R6), r"XOR\(R5, R5, R6\): R5 appears twice"),
        (lambda s: s.DNEWS(R5, R1, east), r"DNEWS\(R5, R1, east, 0\): R1 cannot be an argument"),
        (lambda s: s.DNEWS(R5, R6, 0), r"DNEWS\(R5, R6, 0, 0\): dir must be"),
        (lambda s: s.add(A, B, C, B), r"in add\(A, B, C, B\): bus\(NEWS, B, C, B\) lists B"),
        (lambda s: s.movx(R5, A, east), r"movx\(R5, A, east\): bus\(R5, NEWS\): R5 is a digital"),
    ],
)
def test_macro_misuse_names_the_call(sim: Scamp5, call, message) -> None:
    with pytest.raises(RegisterMisuseError, match=message):
        call(sim)


# ------------------------------------------------- further macros of the official headers
@pytest.mark.parametrize("d", [north, east, south, west])
def test_deprecated_sub_with_direction(sim: Scamp5, d) -> None:
    # sub(y, x0, dir, x1) = bus(NEWS, x0); bus(y, X<dir>, x1): y := x0 of the dir neighbour - x1
    with sim.kernel() as k:
        k.sub(C, A, d, B)
    alias = {north: "XN", east: "XE", south: "XS", west: "XW"}[d]
    assert [str(i) for i in k] == ["bus(NEWS, A)", f"bus(C, {alias}, B)"]
    assert np.array_equal(sim.read(C), _shift(X, d) - Y)
    assert np.array_equal(sim.read(NEWS), -X)


def test_deprecated_sub_golden() -> None:
    sim = Scamp5(rows=1, cols=3)
    sim.write(A, [[1, 2, 3]])
    sim.write(B, [[10, 10, 10]])
    sim.sub(C, A, east, B)
    assert sim.read(C).tolist() == [[-8.0, -7.0, -10.0]]  # [2-10, 3-10, 0-10]


def test_getpix_with_a_stored_reset_level() -> None:
    sim = Scamp5(rows=1, cols=3)
    sim.set_image(np.array([[0, 128, 255]], dtype=np.uint8))  # PIX = p/2 - 64
    sim.write(D, [[1.0, 2.0, 3.0]])  # stands for a reset level kept by respix(D)
    with sim.kernel() as k:
        k.getpix(A, D)
    assert len(k) == 2
    assert sim.read(A).tolist() == [[-65.0, -2.0, 60.5]]  # PIX - D
    with sim.kernel() as k:
        k.getpix(B, C, D)
    assert len(k) == 3
    assert sim.read(C).tolist() == [[64.0, 0.0, -63.5]]  # -PIX
    assert sim.read(B).tolist() == [[-128.0, -2.0, 124.0]]  # 2 PIX - D (clipped at -128)


def test_newsblurh_and_newsblurv() -> None:
    sim = Scamp5(rows=3, cols=3)
    x = np.arange(9, dtype=np.float32).reshape(3, 3)
    sim.write(A, x)
    with sim.kernel() as k:
        k.newsblurh(B, A)
        k.newsblurv(C, A, 2)
    assert len(k) == 2 + 4
    # B := west + east neighbours (0 beyond the edge)
    assert sim.read(B).tolist() == [[1, 2, 1], [4, 8, 4], [7, 14, 7]]
    # one pass: north + south = [[3,4,5],[6,8,10],[3,4,5]]; the second sums that again
    assert sim.read(C).tolist() == [[6, 8, 10], [6, 8, 10], [6, 8, 10]]


def test_andx_nandx_xorx(sim: Scamp5) -> None:
    sim.write(R8, Q)
    assert icws(sim, lambda k: k.ANDX(R7, R8, R5)) == 3
    assert np.array_equal(sim.read(R7), Q & P)  # Ra := Rb AND Rx
    assert np.array_equal(sim.read(R8), ~P)  # Rb := NOT Rx
    assert np.array_equal(sim.read(R0), ~Q)
    sim.write(R8, Q)
    assert icws(sim, lambda k: k.NANDX(R7, R8, R5)) == 3
    assert np.array_equal(sim.read(R7), ~(Q & P))
    sim.write(R8, Q)
    assert icws(sim, lambda k: k.XORX(R7, R8, R5)) == 6
    assert np.array_equal(sim.read(R7), Q ^ P)
    assert np.array_equal(sim.read(R8), Q & ~P)  # Rx := *


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda s: s.IMP(R12, R5, R6), r"IMP\(R12, R5, R6\): R12 cannot be the destination"),
        (lambda s: s.NIMP(R12, R5, R6), r"NIMP\(R12, R5, R6\): R12 cannot be the destination"),
        (lambda s: s.CLR_IF(R12, R5), r"CLR_IF\(R12, R5\): R12 cannot be the destination"),
        (lambda s: s.ANDX(R12, R5, R6), r"ANDX\(R12, R5, R6\): R12 cannot be the destination"),
        (lambda s: s.XORX(R5, R12, R6), r"XORX\(R5, R12, R6\): R12 cannot be the destination"),
        (lambda s: s.XORX(R5, R6, R0), r"XORX\(R5, R6, R0\): R0 cannot be an argument"),
        (lambda s: s.ANDX(R5, R5, R6), r"ANDX\(R5, R5, R6\): R5 appears twice"),
        (lambda s: s.sub(A, B, east, A), r"in sub\(A, B, east, A\): bus\(A, XE, A\) lists A"),
        (lambda s: s.sub(A, B, east), r"sub\(A, B, east\): give the register to subtract"),
        (lambda s: s.sub(A, B, C, D), r"sub\(A, B, C, D\): the third argument must be a dir"),
        (lambda s: s.getpix(A, A), r"in getpix\(A, A\): bus\(A, NEWS, A\) lists A twice"),
    ],
)
def test_further_macro_misuse(sim: Scamp5, call, message) -> None:
    with pytest.raises(RegisterMisuseError, match=message):
        call(sim)
