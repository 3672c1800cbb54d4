"""The controller calls added from the headers (scamp5_api_*.hpp, scamp5_output.hpp,
vs_scamp5.hpp): golden results on tiny arrays, the kernels they run, their misuse."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim import (
    FLAG,
    IN,
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
    R12,
    SELECT,
    A,
    B,
    Scamp5,
)
from ppaloc.sim.controller import PARAMETERS, dac_level
from ppaloc.sim.draw import circle_points, line_points
from ppaloc.sim.registers import RECT
from ppaloc.sim.semantics import diffuse


def test_load_dac_maps_the_12_bit_code_onto_the_register_range() -> None:
    sim = Scamp5(2, 2)
    sim.load_dac(0)
    assert (sim.read(IN) == -128).all()
    sim.load_dac(A, 4095)
    assert (sim.read(A) == 127).all() and (sim.read(NEWS) == -127).all()
    assert dac_level(2048) == pytest.approx(-128 + 255 * 2048 / 4095)
    sim.scamp5_load_dac(B, 2048, A)  # SCAMP-5 spelling, temp given
    assert sim.read(B)[0, 0] == pytest.approx(dac_level(2048))
    for bad in (-1, 4096, 1.5):
        with pytest.raises(SimulatorError, match="dac="):
            sim.load_dac(bad)


def test_diffuse_runs_the_blur_pairs_as_a_kernel() -> None:
    sim = Scamp5(6, 6)
    x = np.zeros((6, 6), np.float32)
    x[2, 3] = 100
    sim.write(A, x)
    sim.diffuse(A, 3)
    want = x
    for _ in range(3):
        want = diffuse(diffuse(want))
    np.testing.assert_allclose(sim.read(A), want, atol=1e-4)
    assert sim.read(A).sum() == pytest.approx(100, abs=1e-3)
    assert sim.read(R1).all() and sim.read(R2).all()
    assert sim.timing.report().stage("(unstaged)").icws == {"digital": 2, "analog": 6}
    sim.write(A, x)
    sim.diffuse(A, 1, vertical=False)
    assert sim.read(A)[:2].sum() == 0  # east-west only
    with pytest.raises(SimulatorError, match="both off"):
        sim.diffuse(A, 1, False, False)
    with pytest.raises(RegisterMisuseError, match="t0=A is the target"):
        sim.diffuse(A, 1, t0=A)


def test_flood_fills_the_region_of_the_seed() -> None:
    sim = Scamp5(6, 6)
    mask = np.ones((6, 6), bool)
    mask[3, :] = False  # a wall across the array
    sim.write(R6, mask)
    sim.load_point(R5, 0, 0)
    sim.flood(R5, R6, 0)
    want = np.zeros((6, 6), bool)
    want[:3] = True
    np.testing.assert_array_equal(sim.read(R5), want)
    sim.load_point(R5, 0, 0)
    sim.flood(R5, R6, 1, iterations=2)  # the edge is '1': the lower part fills too
    np.testing.assert_array_equal(sim.read(R5), mask | want)
    with pytest.raises(RegisterMisuseError, match="scratch of the flood"):
        sim.flood(R12, R6, 0)
    with pytest.raises(RegisterMisuseError, match="scratch of the flood"):
        sim.flood(R5, R0, 0)


def test_flood_use_local_keeps_the_callers_directions() -> None:
    sim = Scamp5(1, 6)
    sim.write(R6, np.ones((1, 6), bool))
    sim.load_point(R5, 0, 2)
    sim.CLR(R1, R2, R3, R4)
    sim.SET(R4)  # read the east neighbour: the flood runs west
    sim.flood(R5, R6, 0, use_local=True)
    assert sim.read(R5).astype(int).tolist() == [[1, 1, 1, 0, 0, 0]]


def test_kernel_all_and_refresh_dreg() -> None:
    sim = Scamp5(2, 2)
    sim.write(FLAG, np.zeros((2, 2), bool))
    sim.kernel_all()
    assert sim.read(FLAG).all()
    sim.write(R7, np.eye(2, dtype=bool))
    sim.scamp5_kernel_refresh_dreg()
    np.testing.assert_array_equal(sim.read(R7), np.eye(2, dtype=bool))
    assert sim.timing.report().stage("(unstaged)").icws == {"analog": 1, "digital": 26}


def test_select_parts_build_the_pattern() -> None:
    sim = Scamp5(4, 4)
    sim.select_col(1)
    np.testing.assert_array_equal(np.argwhere(sim.read(SELECT))[:, 1], [1, 1, 1, 1])
    sim.select_row(2)
    assert np.argwhere(sim.read(SELECT)).tolist() == [[2, 1]]
    sim.select_rowx(0b1)  # ignore the row's low bit: rows 2 and 3
    assert np.argwhere(sim.read(SELECT)).tolist() == [[2, 1], [3, 1]]
    sim.select_colx(0b10)  # columns 1 and 3
    assert np.argwhere(sim.read(SELECT)).tolist() == [[2, 1], [2, 3], [3, 1], [3, 3]]
    sim.select_col(0, scamp_addr=True)  # hardware column 0 is the east edge; cx := 0
    assert np.argwhere(sim.read(SELECT)).tolist() == [[2, 3], [3, 3]]
    sim.select_pattern(0, 0, 0, 0)
    sim.select_col(2)
    assert np.argwhere(sim.read(SELECT)).tolist() == [[0, 2]]


def test_select_rect_writes_rect_and_select() -> None:
    sim = Scamp5(4, 4)
    sim.select_rect(0, 3, 1, 2)
    want = np.zeros((4, 4), bool)
    want[0:2, 2:4] = True
    np.testing.assert_array_equal(sim.read(RECT), want)
    np.testing.assert_array_equal(sim.read(SELECT), want)
    sim.MOV(R5, RECT)  # RECT reads like any DREG source
    np.testing.assert_array_equal(sim.read(R5), want)


def test_global_sums_fast_sparse_region_scale() -> None:
    sim = Scamp5(16, 16)  # K = 16 * 16 / 16 = 16
    sim.write(A, np.full((16, 16), 2.0))
    assert sim.global_sum_fast(A) == 16 * 2 + 128
    assert sim.global_sum_sparse(A) == 4 * 2 + 128  # a quarter of the elements
    assert sim.global_sum_region(A, 0, 0, 3, 3) == 2 + 128  # 1/16 of the array
    sim.write(A, np.full((16, 16), 100.0))
    assert sim.global_sum_fast(A) == 255  # saturates
    assert sim.global_sum_region(A, 0, 0, 3, 3) == 228
    vals = np.zeros((16, 16))
    vals[0::2, 0::2] = 8  # even rows and even array columns
    sim.write(A, vals)
    # the header's default pattern is in hardware addresses: hardware-even columns are the
    # odd array columns of an even-width array, which hold 0 here
    assert sim.global_sum_sparse(A) == 128
    assert sim.global_sum_sparse(A, scamp_addr=True) == 128
    assert sim.global_sum_sparse(A, 2, 2, 254, 254) == 8 * 4 + 128  # array coordinates
    assert sim.global_sum_sparse(A, 1, 1, 254, 254) == 128  # the other grid: all 0
    vals[0::2] = np.roll(vals[0::2], 1, axis=1)  # now on the odd array columns
    sim.write(A, vals)
    assert sim.global_sum_sparse(A) == 8 * 4 + 128
    assert sim.global_sum_sparse(A, c=1) == 8 * 4 + 128  # the rest of the default, as given


def test_global_sums_take_an_areg_not_pix_or_in() -> None:
    # the header's global sums take AREG (A-F, NEWS); PIX and IN are sources only
    sim = Scamp5(8, 8)
    for call in (sim.global_sum_16, sim.global_sum_64, sim.global_sum_fast, sim.global_sum_sparse):
        for reg in (PIX, IN):
            with pytest.raises(RegisterMisuseError, match="is not one of A-F or NEWS"):
                call(reg)
    with pytest.raises(RegisterMisuseError):
        sim.global_sum_region(PIX, 0, 0, 3, 3)
    assert sim.global_sum_fast(NEWS) == 128


def test_shift_diffuse_flood_take_any_header_int() -> None:
    # the header's int arguments have no stated bounds: a shift beyond the array moves
    # everything out (its time is that of the steps asked for), 0 iterations do nothing
    sim = Scamp5(4, 4)
    sim.write(A, np.full((4, 4), 9.0))
    sim.write(R5, np.ones((4, 4), bool))
    before = sim.timing.now_us
    sim.shift(A, 0, -100)
    assert not sim.read(A).any()
    sim.shift(R5, 7, 0, boundary=1)
    assert sim.read(R5).all()
    sim.shift(R5, -5, 0, boundary=0)
    assert not sim.read(R5).any()
    t = sim.timing
    charged = t.call_us("shift_areg", 100) + t.call_us("shift_dreg", 7) + t.call_us("shift_dreg", 5)
    assert t.now_us - before == pytest.approx(charged)
    sim.write(A, np.eye(4) * 40)
    sim.diffuse(A, 0)
    assert sim.read(A).tolist() == (np.eye(4) * 40).tolist()
    sim.write(R6, np.ones((4, 4), bool))
    sim.load_point(R5, 0, 0)
    sim.flood(R5, R6, 0, iterations=0)
    assert sim.read(R5).sum() == 1


def test_scan_events_rc_scans_rows_first() -> None:
    sim = Scamp5(4, 4)
    plane = np.zeros((4, 4), bool)
    plane[0, 0] = plane[1, 3] = plane[0, 2] = True
    sim.write(R5, plane)
    assert sim.scan_events_rc(R5, 3).tolist() == [[0, 2], [0, 0], [1, 3]]
    assert sim.scan_events_cr(R5, 3).tolist() == sim.scan_events(R5, 3).tolist()
    assert sim.scan_events(R5, 3).tolist() == [[1, 3], [0, 2], [0, 0]]
    assert sim.scan_events_rc(R5, 3, h_dir=1).tolist() == [[0, 0], [0, 2], [1, 3]]
    assert sim.scan_events_rc(R5, 1, v_dir=1).tolist() == [[1, 3]]
    assert sim.scan_events_rc(R5, 3, scamp_addr=True).tolist() == [[0, 1], [0, 3], [1, 0]]


def test_scan_boundingbox_corners() -> None:
    sim = Scamp5(6, 6)
    plane = np.zeros((6, 6), bool)
    plane[1, 4] = plane[3, 2] = True
    sim.write(R5, plane)
    assert sim.scan_boundingbox(R5).tolist() == [[1, 4], [3, 2]]  # top-right, bottom-left
    assert sim.scan_boundingbox(R5, scamp_addr=True).tolist() == [[1, 1], [3, 3]]
    sim.write(R5, np.zeros((6, 6), bool))
    assert sim.scan_boundingbox(R5) is None


def test_get_parameter_matches_the_global_sums() -> None:
    sim = Scamp5(8, 8)
    p = {name: sim.vs_scamp5_get_parameter(w) for name, w in PARAMETERS.items()}
    sim.write(A, np.full((8, 8), float(p["SCAMP5_GLOBAL_SUM_16_AREG_MIN"])))
    assert sim.global_sum_16(A) == p["SCAMP5_GLOBAL_SUM_16_FLOOR"]
    sim.write(A, np.full((8, 8), float(p["SCAMP5_GLOBAL_SUM_64_AREG_MAX"])))
    assert sim.global_sum_64(A) == p["SCAMP5_GLOBAL_SUM_64_FLOOR"] + p["SCAMP5_GLOBAL_SUM_64_SPAN"]
    assert p["SCAMP5_GLOBAL_SUM_16_SPAN"] == 4080
    with pytest.raises(SimulatorError, match="which=3"):
        sim.vs_scamp5_get_parameter(3)
    # vs_vision_chip.hpp declares the same table under the vision system's name
    assert [sim.vs_vision_chip_get_parameter(w) for w in range(4, 12)] == list(p.values())


# ------------------------------------------------------------------ drawing
def test_line_and_circle_geometry() -> None:
    rows, cols = line_points(0, 0, 2, 5)
    assert list(zip(rows.tolist(), cols.tolist(), strict=True)) == [
        (0, 0), (0, 1), (1, 2), (1, 3), (2, 4), (2, 5)
    ]  # fmt: skip
    assert line_points(3, 3, 3, 3)[0].tolist() == [3]
    r, c = circle_points(5, 5, 2)
    assert set(zip(r.tolist(), c.tolist(), strict=True)) == {
        (3, 4), (3, 5), (3, 6), (4, 3), (4, 7), (5, 3), (5, 7), (6, 3), (6, 7),
        (7, 4), (7, 5), (7, 6),
    }  # fmt: skip
    assert circle_points(1, 1, 0)[0].tolist() == [1]


def test_draw_calls_or_into_the_target() -> None:
    sim = Scamp5(4, 4)
    sim.write(R5, np.eye(4, dtype=bool))
    sim.draw_begin(R5)
    sim.draw_pixel(0, 5)  # wraps round: column 1
    assert sim.draw_point(3, 0) and not sim.draw_point(4, 0)
    sim.draw_rect(2, 3, 3, 2)
    got = sim.read(R5)
    want = np.eye(4, dtype=bool)
    want[0, 1] = want[3, 0] = True
    want[2:4, 2:4] = True
    np.testing.assert_array_equal(got, want)
    sim.draw_negate()
    np.testing.assert_array_equal(sim.read(R5), ~want)
    sim.draw_end()
    with pytest.raises(SimulatorError, match="draw_begin"):
        sim.draw_pixel(0, 0)


def test_drawing_coordinates_are_bounded() -> None:
    # enumerated point by point: a radius of 2**31 took the host hours and gigabytes
    sim = Scamp5(8, 8)
    sim.draw_begin(R5)
    for call, args, name in (
        (sim.draw_circle, (3, 3, 2**31 - 1), "radius=2147483647"),
        (sim.draw_line, (0, 0, 2_000_000_000, 0), "r1=2000000000"),
        (sim.draw_pixel, (2**70, 0), f"r={2**70}"),
    ):
        with pytest.raises(SimulatorError, match=rf"{name} is out of range; use \[-65536, 65536\]"):
            call(*args)
    sim.draw_circle(3, 3, 65536)  # the limit itself is drawn (outside the array: nothing)
    assert not sim.read(R5).any()


def test_draw_line_and_circle_clip_or_wrap() -> None:
    sim = Scamp5(4, 4)
    sim.scamp5_draw_begin(R5)
    sim.scamp5_draw_line(0, 2, 0, 5)  # beyond the east edge: not drawn
    assert sim.read(R5)[0].astype(int).tolist() == [0, 0, 1, 1]
    sim.draw_line(1, 2, 1, 5, repeat=True)  # wrapped: columns 2, 3, 0, 1
    assert sim.read(R5)[1].all()
    sim.write(R5, np.zeros((4, 4), bool))
    sim.draw_circle(0, 0, 1)
    assert np.argwhere(sim.read(R5)).tolist() == [[0, 1], [1, 0]]
    sim.draw_circle(0, 0, 1, repeat=True)
    assert np.argwhere(sim.read(R5)).tolist() == [[0, 1], [0, 3], [1, 0], [3, 0]]
    with pytest.raises(SimulatorError, match="radius=-1"):
        sim.draw_circle(0, 0, -1)
    with pytest.raises(RegisterMisuseError):
        sim.draw_begin(A)


def test_select_point_sets_the_parts_too() -> None:
    sim = Scamp5(4, 4)
    sim.select_point(1, 2)
    sim.select_rowx(0b10)  # rows 1 and 3 of column 2
    assert np.argwhere(sim.read(SELECT)).tolist() == [[1, 2], [3, 2]]


def test_digital_shift_takes_the_headers_refresh_interval() -> None:
    sim = Scamp5(3, 3)
    sim.write(R5, np.eye(3, dtype=bool))
    sim.scamp5_shift(R5, 1, 0, 0, 4)
    assert sim.read(R5).astype(int).tolist() == [[0, 1, 0], [0, 0, 1], [0, 0, 0]]
    with pytest.raises(SimulatorError, match="refresh=0"):
        sim.shift(R5, 1, 0, 0, 0)
