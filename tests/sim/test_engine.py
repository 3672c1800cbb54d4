"""Golden tests of the analogue primitives, FLAG semantics and neighbour transfers."""

from __future__ import annotations

import re

import numpy as np
import pytest

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim import (
    FLAG,
    NEWS,
    PIX,
    XE,
    XN,
    XS,
    XW,
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

X = np.arange(20, dtype=np.float32).reshape(4, 5) - 10  # values -10..9, [row, col]


@pytest.fixture
def sim() -> Scamp5:
    s = Scamp5(rows=4, cols=5)
    s.write(A, X)
    s.write(B, 2 * X)
    s.write(C, np.full((4, 5), 3.0))
    return s


def test_bus_negates_the_sum_of_up_to_four_sources(sim: Scamp5) -> None:
    sim.write(D, np.ones((4, 5)))
    sim.bus(E)
    assert np.array_equal(sim.read(E), np.zeros((4, 5)))
    sim.bus(E, A)
    assert np.array_equal(sim.read(E), -X)
    sim.bus(E, A, B)
    assert np.array_equal(sim.read(E), -3 * X)
    sim.bus(E, A, B, C)
    assert np.array_equal(sim.read(E), -3 * X - 3)
    sim.bus(E, A, B, C, D)
    assert np.array_equal(sim.read(E), -3 * X - 4)


def test_bus2_and_bus3_split_the_current(sim: Scamp5) -> None:
    sim.bus2(D, E, A)
    assert np.array_equal(sim.read(D), -X / 2)
    assert np.array_equal(sim.read(E), -X / 2)
    sim.bus2(D, E, A, B)
    assert np.array_equal(sim.read(D), -3 * X / 2)
    sim.bus2(D, E)
    assert np.array_equal(sim.read(E), np.zeros((4, 5)))
    sim.bus3(D, E, F, C)
    for r in (D, E, F):
        assert np.array_equal(sim.read(r), np.full((4, 5), -1.0))


def test_saturation_at_both_ends(sim: Scamp5) -> None:
    sim.write(A, np.full((4, 5), -128.0))
    sim.bus(D, A)
    assert np.array_equal(sim.read(D), np.full((4, 5), 127.0))
    sim.write(B, np.full((4, 5), 100.0))
    sim.bus(D, B, C)  # 103 -> -103
    assert np.array_equal(sim.read(D), np.full((4, 5), -103.0))
    sim.write(C, np.full((4, 5), 100.0))
    sim.bus(D, B, C)
    assert np.array_equal(sim.read(D), np.full((4, 5), -128.0))
    sim.write(A, 1000 * np.ones((4, 5)))
    assert sim.read(A).max() == 127


def test_where_sets_flag_and_flag_masks_analogue_writes(sim: Scamp5) -> None:
    sim.where(A)
    assert np.array_equal(sim.read(FLAG), X > 0)
    sim.bus(D, C)
    assert np.array_equal(sim.read(D), np.where(X > 0, -3.0, 0.0))
    sim.where(A, C)  # FLAG := A + 3 > 0
    assert np.array_equal(sim.read(FLAG), X + 3 > 0)
    sim.all()
    assert sim.read(FLAG).all()


@pytest.mark.parametrize(
    ("direction", "expected"),
    [
        # y takes x of the neighbour in `direction`; beyond the edge reads 0
        (east, np.pad(X[:, 1:], ((0, 0), (0, 1)))),
        (west, np.pad(X[:, :-1], ((0, 0), (1, 0)))),
        (north, np.pad(X[:-1, :], ((1, 0), (0, 0)))),
        (south, np.pad(X[1:, :], ((0, 1), (0, 0)))),
    ],
)
def test_movx_all_four_directions(sim: Scamp5, direction, expected) -> None:
    sim.movx(D, A, direction)
    assert np.array_equal(sim.read(D), expected)
    assert np.array_equal(sim.read(NEWS), -expected)


def test_movx_west_moves_the_picture_east() -> None:
    sim = Scamp5(rows=1, cols=4)
    sim.write(A, [[5, 0, 0, 0]])
    sim.movx(B, A, west)
    assert np.array_equal(sim.read(B), [[0, 5, 0, 0]])


@pytest.mark.parametrize(
    ("alias", "expected"),
    [
        (XE, np.pad(X[:, 1:], ((0, 0), (0, 1)))),
        (XW, np.pad(X[:, :-1], ((0, 0), (1, 0)))),
        (XN, np.pad(X[:-1, :], ((1, 0), (0, 0)))),
        (XS, np.pad(X[1:, :], ((0, 1), (0, 0)))),
    ],
)
def test_neighbour_aliases_read_the_neighbours_news(sim: Scamp5, alias, expected) -> None:
    sim.write(NEWS, X)
    sim.bus(D, alias)
    assert np.array_equal(sim.read(D), -expected)


def test_flag_of_both_elements_gates_a_neighbour_transfer(sim: Scamp5) -> None:
    flag = np.ones((4, 5), dtype=bool)
    flag[1, 2] = False
    sim.write(NEWS, np.full((4, 5), 7.0))
    sim.write(D, np.full((4, 5), 50.0))
    sim.write(FLAG, flag)
    sim.bus(D, XE)  # D := -NEWS of the east neighbour
    got = sim.read(D)
    assert got[1, 2] == 50  # unflagged: kept
    assert got[1, 1] == 0  # its east neighbour (1, 2) is unflagged: link carries 0
    assert got[0, 4] == 0  # beyond the edge
    assert got[0, 0] == -7
    # push form: bus(XW, C) leaves in NEWS the -C of the east neighbour
    sim.write(NEWS, np.full((4, 5), 99.0))
    sim.bus(XW, C)
    news = sim.read(NEWS)
    assert news[1, 2] == 99  # unflagged receiver keeps its NEWS
    assert news[1, 1] == 0  # sender (1, 2) unflagged
    assert news[2, 1] == -3
    assert news[2, 4] == 0  # no sender beyond the east edge


def test_get_image_capture_contract() -> None:
    sim = Scamp5(rows=2, cols=3)
    img = np.array([[0, 1, 2], [128, 254, 255]], dtype=np.uint8)
    sim.set_image(img)
    sim.get_image(A, B)
    assert np.array_equal(sim.read(A), img - 128.0)  # the full range [-128, 127]
    assert np.array_equal(sim.read(B), -(img / 2 - 64))  # the negated half range
    assert np.array_equal(sim.read(PIX), np.zeros((2, 3)))  # reset
    sim.set_image(img)
    sim.get_image(C)
    assert np.array_equal(sim.read(C), img / 2 - 64)  # half range


def test_misuse_errors_name_the_instruction(sim: Scamp5) -> None:
    with pytest.raises(RegisterMisuseError, match=r"bus\(A, A\) lists A twice"):
        sim.bus(A, A)
    with pytest.raises(RegisterMisuseError, match=r"in sub\(A, B, A\): bus\(A, NEWS, A\)"):
        sim.sub(A, B, A)
    with pytest.raises(RegisterMisuseError, match="PIX cannot be written"):
        sim.bus(PIX, A)
    with pytest.raises(RegisterMisuseError, match="bus takes 0 to 4 source"):
        sim.bus(A, B, C, D, E, F)
    with pytest.raises(SimulatorError, match=r"set_image needs a uint8 array of shape \(4, 5\)"):
        sim.set_image(np.zeros((4, 5)))


# ------------------------------------------------------------------ digital primitives
from ppaloc.sim import R0, R1, R2, R3, R4, R5, R6, R7, R8, R9, R10, R12, SELECT  # noqa: E402

P = np.array([[1, 0, 1, 0, 1]] * 4, dtype=bool)
Q = np.array([[1, 1, 0, 0, 1]] * 4, dtype=bool)
S = np.array([[1, 0, 0, 0, 0]] * 4, dtype=bool)


@pytest.fixture
def dsim() -> Scamp5:
    s = Scamp5(rows=4, cols=5)
    s.write(R5, P)
    s.write(R6, Q)
    s.write(R7, S)
    return s


def test_set_clr_mov_not(dsim: Scamp5) -> None:
    dsim.SET(R8, R9, R10, R1)
    assert all(dsim.read(r).all() for r in (R8, R9, R10, R1))
    dsim.CLR(R8, R9)
    assert not dsim.read(R8).any() and not dsim.read(R9).any() and dsim.read(R10).all()
    dsim.MOV(R8, R5)
    assert np.array_equal(dsim.read(R8), P)
    dsim.NOT(R9, R5)
    assert np.array_equal(dsim.read(R9), ~P)


def test_or_nor_with_two_to_four_sources(dsim: Scamp5) -> None:
    dsim.OR(R8, R5, R6)
    assert np.array_equal(dsim.read(R8), P | Q)
    dsim.OR(R8, R5, R6, R7)
    assert np.array_equal(dsim.read(R8), P | Q | S)
    dsim.NOR(R8, R5, R6)
    assert np.array_equal(dsim.read(R8), ~(P | Q))
    dsim.SET(R9)
    dsim.NOR(R8, R5, R6, R7, R9)
    assert not dsim.read(R8).any()


def test_where_all_and_flag_ignored_by_digital_ops(dsim: Scamp5) -> None:
    dsim.WHERE(R5)
    assert np.array_equal(dsim.read(FLAG), P)
    dsim.MOV(R8, R6)  # digital: FLAG does not mask
    assert np.array_equal(dsim.read(R8), Q)
    dsim.WHERE(R5, R6, R7)
    assert np.array_equal(dsim.read(FLAG), P | Q | S)
    dsim.ALL()
    assert dsim.read(FLAG).all()
    dsim.write(SELECT, S)
    dsim.MOV(R8, SELECT)  # SELECT and FLAG are readable sources
    assert np.array_equal(dsim.read(R8), S)


def test_r12_is_written_only_where_r0_is_set(dsim: Scamp5) -> None:
    dsim.write(R0, Q)
    dsim.write(R12, S)
    dsim.MOV(R12, R5)
    assert np.array_equal(dsim.read(R12), np.where(Q, P, S))
    dsim.write(R12, S)
    dsim.SET(R12)
    assert np.array_equal(dsim.read(R12), Q | S)
    dsim.CLR(R12)
    assert np.array_equal(dsim.read(R12), S & ~Q)
    dsim.write(R12, S)
    dsim.NOR(R12, R5, R6)
    assert np.array_equal(dsim.read(R12), np.where(Q, ~(P | Q), S))
    dsim.write(R12, S)
    dsim.DNEWS0(R12, R5)  # no selector set: 0 where written
    assert np.array_equal(dsim.read(R12), S & ~Q)


@pytest.mark.parametrize(
    ("selector", "shift"),
    [(R1, (1, 0)), (R2, (0, -1)), (R3, (-1, 0)), (R4, (0, 1))],
    ids=["R1-south", "R2-west", "R3-north", "R4-east"],
)
@pytest.mark.parametrize("edge", [0, 1])
def test_dnews_each_selector(dsim: Scamp5, selector, shift, edge) -> None:
    dsim.CLR(R1, R2, R3, R4)
    dsim.SET(selector)
    (dsim.DNEWS1 if edge else dsim.DNEWS0)(R8, R5)
    dr, dc = shift
    padded = np.pad(P, 1, constant_values=bool(edge))
    expected = padded[1 + dr : 5 + dr, 1 + dc : 6 + dc]
    assert np.array_equal(dsim.read(R8), expected)


def test_dnews_selectors_are_per_element(dsim: Scamp5) -> None:
    # only column 0 reads east, only column 4 reads west
    dsim.CLR(R1, R2, R3)
    east_sel = np.zeros((4, 5), dtype=bool)
    east_sel[:, 0] = True
    west_sel = np.zeros((4, 5), dtype=bool)
    west_sel[:, 4] = True
    dsim.write(R4, east_sel)
    dsim.write(R2, west_sel)
    dsim.DNEWS0(R8, R6)  # Q = [1, 1, 0, 0, 1]
    assert np.array_equal(dsim.read(R8)[0], [True, False, False, False, False])


def test_digital_misuse(dsim: Scamp5) -> None:
    with pytest.raises(RegisterMisuseError, match=r"OR\(R5, R5, R6\) lists R5 twice"):
        dsim.OR(R5, R5, R6)
    with pytest.raises(RegisterMisuseError, match="FLAG cannot be written"):
        dsim.MOV(FLAG, R5)
    with pytest.raises(RegisterMisuseError, match="SELECT cannot be written"):
        dsim.SET(SELECT)
    with pytest.raises(RegisterMisuseError, match=r"MOV\(R5, A\): A is an analogue register"):
        dsim.MOV(R5, A)
    with pytest.raises(RegisterMisuseError, match="SET takes 1 to 4 destination"):
        dsim.SET(R1, R2, R3, R4, R5)


def test_inspection_helpers_validate(dsim: Scamp5) -> None:
    with pytest.raises(SimulatorError, match=r"shape \(2, 2\) into R5: use shape \(4, 5\)"):
        dsim.write(R5, np.zeros((2, 2)))
    with pytest.raises(SimulatorError, match="non-binary values into digital R5"):
        dsim.write(R5, np.full((4, 5), 2))
    with pytest.raises(SimulatorError, match="XE is not an analogue register plane"):
        dsim.read(XE)
    with pytest.raises(SimulatorError, match="rows=0 is invalid"):
        Scamp5(rows=0)
    with pytest.raises(SimulatorError, match=r"cols=1000000 is too large: use at most 4096"):
        Scamp5(rows=2, cols=10**6)  # not a MemoryError from numpy
    with pytest.raises(SimulatorError, match="NaN or infinity into A"):
        dsim.write(A, np.full((4, 5), np.nan))


def test_any_op_table_row_can_be_issued_by_name(sim: Scamp5) -> None:
    from ppaloc.sim import OPS

    assert {"bus", "bus2", "bus3", "where", "all", "rpix", "nop", "DNEWS0"} <= set(OPS)
    assert all(spec.clock in ("analog", "digital", "dnews", "nop") for spec in OPS.values())
    sim.icw("bus", (D,), (A, B))
    assert np.array_equal(sim.read(D), -3 * X)
    with pytest.raises(RegisterMisuseError, match="'blurx' is not an instruction; use one of"):
        sim.icw("blurx", (D,), (A,))


@pytest.mark.parametrize(
    ("dsts", "srcs", "shown"),
    [
        ((NEWS,), (XE,), "bus(NEWS, XE)"),
        ((XW,), (NEWS,), "bus(XW, NEWS)"),
        ((XW,), (A, XN), "bus(XW, A, XN)"),
    ],
)
def test_an_icw_cannot_read_and_write_the_news_plane(sim: Scamp5, dsts, srcs, shown) -> None:
    # NEWS and XN/XE/XS/XW select the same NEWS cells (scamp5_icw.hpp: one W bit, SEL4)
    with pytest.raises(RegisterMisuseError, match=rf"{re.escape(shown)} reads and writes NEWS"):
        sim.icw("bus", dsts, srcs)


def test_official_news_patterns_stay_legal(sim: Scamp5) -> None:
    sim.bus(XW, A)  # push (movx): NEWS := -A of the east neighbour
    east_a = np.pad(X[:, 1:], ((0, 0), (0, 1)))
    assert np.array_equal(sim.read(NEWS), -east_a)
    sim.bus(D, XE, XW, XN, XS)  # several neighbour reads (newsblur)
    news = -east_a
    total = sum(
        np.pad(news, 1)[1 + dr : 5 + dr, 1 + dc : 6 + dc]
        for dr, dc in ((0, 1), (0, -1), (-1, 0), (1, 0))
    )
    assert np.array_equal(sim.read(D), np.clip(-total, -128, 127))
    sim.bus(NEWS, A, B)  # local write
    assert np.array_equal(sim.read(NEWS), -3 * X)
    sim.where(NEWS, XE)  # FLAG := NEWS + NEWS_east > 0
    east_news = np.pad(-3 * X[:, 1:], ((0, 0), (0, 1)))
    assert np.array_equal(sim.read(FLAG), -3 * X + east_news > 0)
