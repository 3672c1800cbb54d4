"""Controller (host) calls: golden results on tiny arrays, coordinate frames, costs, errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.errors import RegisterMisuseError, SimulatorError
from ppaloc.sim import (
    FLAG,
    IN,
    NEWS,
    PIX,
    R1,
    R2,
    R3,
    R4,
    R5,
    R6,
    R7,
    SELECT,
    XE,
    A,
    B,
    C,
    D,
    E,
    Scamp5,
)
from ppaloc.sim.controller import MAX_EVENTS, from_scamp_buffer, to_scamp_buffer


def sim_(rows=4, cols=4, **kw) -> Scamp5:
    return Scamp5(rows, cols, **kw)


def last_call(sim: Scamp5) -> dict[str, int]:
    return sim.timing.report().stages[-1].calls


# ----------------------------------------------------------------------------- DAC


def test_scamp5_in_loads_areg_in_and_news():
    sim = sim_()
    sim.scamp5_in(A, -37)
    assert (sim.read(A) == -37).all()
    assert (sim.read(IN) == -37).all()
    assert (sim.read(NEWS) == 37).all()  # the library's temporary holds -value
    assert last_call(sim) == {"scamp5_in": 1}
    assert sim.timing.now_us == pytest.approx(1.0)


def test_scamp5_in_obeys_flag():
    sim = sim_(2, 2)
    sim.write(FLAG, np.array([[1, 0], [0, 1]], dtype=bool))
    sim.scamp5_in(B, 5)
    assert sim.read(B).tolist() == [[5, 0], [0, 5]]


@pytest.mark.parametrize("value", [128, -129, 1000])
def test_scamp5_in_rejects_out_of_range_value(value):
    with pytest.raises(
        SimulatorError, match=rf"scamp5_in: value={value} is out of range; use \[-128, 127\]"
    ):
        sim_().scamp5_in(A, value)


@pytest.mark.parametrize("value", [1.5, "3", True])
def test_scamp5_in_rejects_non_integers(value):
    with pytest.raises(SimulatorError, match=r"must be an integer in \[-128, 127\]"):
        sim_().scamp5_in(A, value)


@pytest.mark.parametrize("reg", [PIX, IN, XE, R5])
def test_scamp5_in_rejects_non_writable_registers(reg):
    with pytest.raises(
        RegisterMisuseError, match=f"scamp5_in: {reg.name} is not one of A-F or NEWS"
    ):
        sim_().scamp5_in(reg, 1)


def test_load_in_two_forms():
    sim = sim_()
    sim.load_in(12)
    assert (sim.read(IN) == 12).all() and (sim.read(A) == 0).all()
    sim.load_in(A, -3)
    assert (sim.read(A) == -3).all()
    assert sim.timing.report().stages[-1].calls == {"load_in": 2}
    with pytest.raises(SimulatorError, match="load_in: value=200 is out of range"):
        sim.load_in(200)
    with pytest.raises(SimulatorError, match="give a value"):
        sim.load_in(A)


def test_dac_loads_use_the_header_temp_register():
    # scamp5_in(areg, value, temp=NEWS) and scamp5_load_in(areg, value, temp=NEWS): the value
    # passes through `temp`, which is left holding -value
    sim = sim_(2, 2)
    sim.load_in(A, 9)
    assert sim.read(A).tolist() == [[9, 9], [9, 9]]
    assert sim.read(NEWS).tolist() == [[-9, -9], [-9, -9]]
    sim.scamp5_in(B, -4, C)
    assert sim.read(B).tolist() == [[-4, -4], [-4, -4]]
    assert sim.read(C).tolist() == [[4, 4], [4, 4]]
    assert sim.read(NEWS).tolist() == [[-9, -9], [-9, -9]]  # untouched when temp is C
    sim.load_in(D, 3, E)
    assert (sim.read(D) == 3).all() and (sim.read(E) == -3).all()
    with pytest.raises(RegisterMisuseError, match=r"scamp5_in: temp=B is the target; use"):
        sim.scamp5_in(B, 1, B)
    with pytest.raises(RegisterMisuseError, match=r"load_in: R5 is not one of A-F or NEWS"):
        sim.load_in(A, 1, R5)


def test_scamp5_spellings_exist():
    sim = sim_()
    sim.scamp5_load_pattern(R5, 0, 0, 255, 255)
    sim.in_(A, 1)
    assert sim.read(R5).all() and (sim.read(A) == 1).all()


# ------------------------------------------------------------------ address patterns


def test_load_pattern_golden():
    sim = sim_(4, 4)
    sim.load_pattern(R5, 0, 1, 0b10, 0b10)
    assert sim.read(R5).astype(int).tolist() == [
        [0, 1, 0, 1],
        [0, 0, 0, 0],
        [0, 1, 0, 1],
        [0, 0, 0, 0],
    ]
    assert last_call(sim) == {"load_pattern": 1}


def test_load_pattern_header_example():
    # official header: mask 192 makes addresses 3, 67, 131 and 195 match 3
    sim = Scamp5(256, 256)
    sim.load_pattern(R6, 3, 0, 192, 255)
    rows = np.flatnonzero(sim.read(R6).any(axis=1))
    assert rows.tolist() == [3, 67, 131, 195]
    assert sim.read(R6)[3].all()


def test_load_pattern_hardware_frame_mirrors_columns():
    sim = sim_(4, 8)
    sim.load_pattern(R5, 1, 2, 0, 0, scamp_addr=True)
    expected = np.zeros((4, 8), bool)
    expected[1, 8 - 1 - 2] = True
    assert (sim.read(R5) == expected).all()


@settings(max_examples=40, deadline=None)
@given(*(st.integers(0, 255) for _ in range(4)))
def test_property_load_pattern_matches_bruteforce_and_frames(r, c, rx, cx):
    sim = Scamp5(16, 256)
    sim.load_pattern(R5, r, c, rx, cx)
    sim.load_pattern(R6, r, c, rx, cx, scamp_addr=True)
    sim.load_pattern(R7, r, 255 - c, rx, cx)
    got, hw, flipped = sim.read(R5), sim.read(R6), sim.read(R7)
    brute = np.array(
        [[(i & ~rx) == (r & ~rx) and (j & ~cx) == (c & ~cx) for j in range(256)] for i in range(16)]
    )
    assert (got == brute).all()
    assert (hw == got[:, ::-1]).all()  # hardware column address = 255 - array column
    assert (hw == flipped).all()  # ... which is the same family of patterns


@pytest.mark.parametrize("args", [(256, 0, 0, 0), (0, -1, 0, 0), (0, 0, 0, 300)])
def test_load_pattern_rejects_non_8bit_addresses(args):
    with pytest.raises(
        SimulatorError, match=r"load_pattern: \w+=-?\d+ is out of range; use \[0, 255\]"
    ):
        sim_().load_pattern(R5, *args)


def test_load_pattern_rejects_analogue_and_flag():
    for reg in (A, FLAG, SELECT):
        with pytest.raises(RegisterMisuseError, match="is not one of R0-R12"):
            sim_().load_pattern(reg, 0, 0, 0, 0)


def test_load_point_and_frames():
    sim = sim_(3, 4)
    sim.load_point(R5, 1, 2)
    assert np.argwhere(sim.read(R5)).tolist() == [[1, 2]]
    sim.load_point(R5, 1, 0, scamp_addr=True)
    assert np.argwhere(sim.read(R5)).tolist() == [[1, 3]]
    with pytest.raises(SimulatorError, match=r"load_point: c=4 is out of range; use \[0, 3\]"):
        sim.load_point(R5, 0, 4)


def test_load_rect_any_corner_order_and_frames():
    sim = sim_(4, 5)
    sim.load_rect(R5, 1, 1, 2, 3)
    expected = np.zeros((4, 5), bool)
    expected[1:3, 1:4] = True
    assert (sim.read(R5) == expected).all()
    sim.load_rect(R6, 2, 3, 1, 1)
    assert (sim.read(R6) == expected).all()
    sim.load_rect(R7, 1, 0, 2, 1, scamp_addr=True)  # hardware columns 0-1 = east edge
    expected = np.zeros((4, 5), bool)
    expected[1:3, 3:5] = True
    assert (sim.read(R7) == expected).all()


def test_select_calls_write_select():
    sim = sim_(2, 4)
    sim.select_point(0, 1)
    assert np.argwhere(sim.read(SELECT)).tolist() == [[0, 1]]
    sim.select_rect(0, 0, 1, 1)
    assert sim.read(SELECT).sum() == 4
    sim.select_pattern(0, 0, 0, 0)
    assert np.argwhere(sim.read(SELECT)).tolist() == [[0, 0]]


# -------------------------------------------------------------------------- shifts


PICTURE = np.arange(1, 10, dtype=np.float32).reshape(3, 3)


@pytest.mark.parametrize(
    ("h", "v", "expected"),
    [
        (1, 0, [[0, 1, 2], [0, 4, 5], [0, 7, 8]]),  # east
        (-1, 0, [[2, 3, 0], [5, 6, 0], [8, 9, 0]]),  # west
        (0, 1, [[4, 5, 6], [7, 8, 9], [0, 0, 0]]),  # north
        (0, -1, [[0, 0, 0], [1, 2, 3], [4, 5, 6]]),  # south
        (2, -1, [[0, 0, 0], [0, 0, 1], [0, 0, 4]]),
    ],
)
def test_shift_areg_all_directions(h, v, expected):
    sim = sim_(3, 3)
    sim.write(A, PICTURE)
    sim.shift(A, h, v)
    assert sim.read(A).tolist() == expected
    assert last_call(sim) == {"shift_areg": 1}
    assert sim.timing.now_us == pytest.approx(0.5 + 0.33 + (abs(h) + abs(v)) * 2 * 0.372)


def test_shift_areg_obeys_flag():
    sim = sim_(1, 3)
    sim.write(A, np.array([[1.0, 2.0, 3.0]]))
    sim.write(FLAG, np.array([[0, 1, 1]], dtype=bool))
    sim.shift(A, 1, 0)
    assert sim.read(A).tolist() == [[1.0, 1.0, 2.0]]


@pytest.mark.parametrize(
    ("h", "v", "selector"),
    [(1, 0, R2), (-1, 0, R4), (0, 1, R1), (0, -1, R3)],
)
def test_shift_dreg_directions_boundary_and_selectors(h, v, selector):
    sim = sim_(3, 3)
    centre = np.zeros((3, 3), bool)
    centre[1, 1] = True
    sim.write(R5, centre)
    sim.shift(R5, h, v, boundary=1)
    got = sim.read(R5)
    assert got[1 - v, 1 + h]  # the 1 moved by (h east, v north)
    assert got.sum() == 1 + 3  # plus the row or column of 1s shifted in
    for sel in (R1, R2, R3, R4):
        assert sim.read(sel).all() == (sel is selector)
    assert last_call(sim) == {"shift_dreg": 1}


def test_shift_rejects_bad_arguments():
    sim = sim_(3, 3)
    with pytest.raises(SimulatorError, match=r"shift: h=70000 is out of range"):
        sim.shift(A, 70000, 0)
    with pytest.raises(SimulatorError, match=r"shift: boundary=2 is out of range"):
        sim.shift(R5, 0, 0, boundary=2)
    with pytest.raises(RegisterMisuseError):
        sim.shift(PIX, 1, 0)


# ----------------------------------------------------------------- global readouts


def test_global_sum_16_golden():
    sim = sim_(8, 8)
    plane = np.repeat(np.repeat(np.arange(16, dtype=np.float32).reshape(4, 4) * 8 - 60, 2, 0), 2, 1)
    sim.write(A, plane)
    grid = np.zeros((4, 4), np.uint8)
    total = sim.global_sum_16(A, out=grid)
    expected = np.arange(16).reshape(4, 4) * 8 - 60 + 128
    assert grid.tolist() == expected.tolist()
    assert total == int(expected.sum())
    assert last_call(sim) == {"global_sum_16": 1}
    assert sim.timing.now_us == pytest.approx(14.0)


def test_global_sum_constant_and_saturation():
    sim = sim_(8, 8)
    sim.write(A, np.full((8, 8), 10.0))
    assert sim.global_sum_16(A) == 16 * 138
    assert sim.global_sum_64(A) == 64 * 138
    sim.write(A, np.full((8, 8), 127.0))
    assert sim.global_sum_64(A) == 64 * 255
    sim.write(A, np.full((8, 8), -128.0))
    assert sim.global_sum_16(A) == 0


def test_global_sum_quantises_block_means():
    sim = sim_(4, 4)
    sim.write(A, np.array([[1.0, 0.0, 0.0, 0.0]] * 4))  # block (0, 0) mean 0.5 -> half up
    grid = np.zeros((4, 4), np.uint8)
    sim.global_sum_16(A, out=grid)
    assert grid[0, 0] == 129 and grid[0, 1] == 128


def test_global_sum_needs_divisible_array_and_right_out_shape():
    with pytest.raises(SimulatorError, match="global_sum_64 needs rows and cols divisible by 8"):
        sim_(4, 4).global_sum_64(A)
    bad_out = r"out must be a writable numpy array of shape \(4, 4\) .*got shape \(2, 2\)"
    with pytest.raises(SimulatorError, match=bad_out):
        sim_(4, 4).global_sum_16(A, out=np.zeros((2, 2), np.uint8))


def test_global_or_whole_array_and_pattern():
    sim = sim_(4, 4)
    assert sim.global_or(R5) == 0
    sim.load_point(R5, 2, 3)
    assert sim.global_or(R5) == 1
    assert sim.global_or(R5, 0, 0, 0b01, 0b11) == 0  # rows 0-1 only
    assert sim.global_or(R5, 2, 3, 0, 0) == 1
    assert sim.global_or(R5, 2, 0, 0, 0, scamp_addr=True) == 1  # hardware col 0 = array col 3
    assert sim.global_or(FLAG) == 1  # any digital source
    assert last_call(sim) == {"load_point": 1, "global_or": 6}


def test_global_count_golden_and_clobbers_temp():
    sim = sim_(8, 8)
    assert sim.global_count(R5, B) == 0
    assert (sim.read(B) == -128).all()
    sim.load_rect(R5, 0, 0, 7, 3)  # left half
    assert sim.global_count(R5, B) == 2048  # 4095 * 8 * 255 / (255 * 16) = 2047.5 half up
    assert sim.read(B)[0].tolist() == [127] * 4 + [-128] * 4
    sim.load_rect(R5, 0, 0, 7, 7)
    assert sim.global_count(R5, B, 1) == 4095
    calls = sim.timing.report().stages[-1].calls
    assert calls["global_count"] == 2 and calls["global_count_64"] == 1


# ------------------------------------------------------------------ image readouts

GRID = np.array([[0, 1, 2, 3], [10, 11, 12, 13], [20, 21, 22, 23]], dtype=np.float32)


def test_scan_areg_full_and_strided():
    sim = sim_(3, 4)
    sim.write(A, GRID)
    assert sim.scan_areg(A).tolist() == (GRID + 128).tolist()
    assert sim.scan_areg(A, 0, 1, 2, 3, 2, 2).tolist() == [[129, 131], [149, 151]]
    assert sim.timing.report().stages[-1].calls == {"scan_areg": 2}
    assert sim.timing.now_us == pytest.approx(2 * 0.5 + (12 + 4) * 0.1)


def test_scan_areg_hardware_frame_and_buffer_order():
    sim = sim_(3, 4)
    sim.write(A, GRID)
    # hardware columns 0..1 are array columns 3..2; output stays in array orientation
    assert sim.scan_areg(A, 0, 0, 2, 1, scamp_addr=True).tolist() == [
        [130, 131],
        [140, 141],
        [150, 151],
    ]
    codes = sim.scan_areg(A)
    buf = to_scamp_buffer(codes)
    # header: buffer[3] is the first column from the right, fourth row down (here: 3 rows)
    assert buf[:3].tolist() == (GRID[:, 3] + 128).tolist()
    assert buf[3] == GRID[0, 2] + 128
    assert (from_scamp_buffer(buf, 3, 4) == codes).all()


def test_scan_areg_rejects_empty_region():
    with pytest.raises(SimulatorError, match="empty region"):
        sim_(3, 4).scan_areg(A, 2, 0, 1, 3)


def test_read_areg_single_element():
    sim = sim_(3, 4)
    sim.write(A, GRID)
    assert sim.read_areg(A, 1, 2) == 140
    assert sim.read_areg(A, 1, 0, scamp_addr=True) == 141


def test_adc_rounds_half_up_and_clips():
    sim = sim_(1, 4)
    sim.write(A, np.array([[-128.0, -0.5, 0.49, 127.0]]))
    assert sim.scan_areg(A).tolist() == [[0, 128, 128, 255]]


def test_scan_areg_8x8_samples_top_right_of_each_block():
    sim = sim_(16, 16)
    plane = np.arange(256, dtype=np.float32).reshape(16, 16) - 128
    sim.write(A, plane)
    got = sim.scan_areg_8x8(A).astype(int) - 128
    rows, cols = np.arange(0, 16, 2), np.arange(1, 16, 2)
    assert got.tolist() == plane[np.ix_(rows, cols)].astype(int).tolist()
    assert last_call(sim) == {"scan_areg_8x8": 1}


def test_scan_areg_mean_8x8_golden():
    sim = sim_(16, 16)
    means = np.arange(64, dtype=np.float32).reshape(8, 8) - 32
    sim.write(A, np.kron(means, np.ones((2, 2), np.float32)))
    assert (sim.scan_areg_mean_8x8(A).astype(int) - 128).tolist() == means.astype(int).tolist()
    with pytest.raises(
        SimulatorError, match="scan_areg_mean_8x8 needs rows and cols divisible by 8"
    ):
        sim_(4, 4).scan_areg_mean_8x8(A)


def test_scan_dreg_rows():
    sim = sim_(4, 4)
    sim.load_rect(R5, 1, 0, 2, 1)
    got = sim.scan_dreg(R5, 1, 2)
    assert got.astype(int).tolist() == [[1, 1, 0, 0], [1, 1, 0, 0]]
    assert sim.scan_dreg(R5).shape == (4, 4)
    assert sim.timing.report().stages[-1].calls["scan_dreg"] == 2
    with pytest.raises(SimulatorError, match="r1=0 is before r0=2"):
        sim.scan_dreg(R5, 2, 0)


def test_scan_events_order_is_east_column_first_then_north_to_south():
    sim = sim_(3, 3)
    sim.write(R5, np.array([[1, 0, 1], [0, 1, 1], [1, 0, 0]], dtype=bool))
    assert sim.scan_events(R5, 10).tolist() == [[0, 2], [1, 2], [1, 1], [0, 0], [2, 0]]
    assert sim.scan_events(R5, 10, h_dir=1).tolist() == [[0, 0], [2, 0], [1, 1], [0, 2], [1, 2]]
    assert sim.scan_events(R5, 10, v_dir=1).tolist() == [[1, 2], [0, 2], [1, 1], [2, 0], [0, 0]]
    assert sim.scan_events(R5, 2).tolist() == [[0, 2], [1, 2]]
    assert sim.scan_events(R5, 2, scamp_addr=True).tolist() == [[0, 0], [1, 0]]


def test_scan_events_keeps_an_event_at_origin_and_charges_max_num():
    sim = sim_(2, 2)
    sim.load_point(R5, 0, 0)
    assert sim.scan_events(R5, 50).tolist() == [[0, 0]]
    assert sim.scan_events(R6, 50).shape == (0, 2)
    assert sim.timing.now_us == pytest.approx(1.0 + 2 * (0.5 + 50 * 0.877))


@pytest.mark.parametrize("n", [0, MAX_EVENTS + 1])
def test_scan_events_rejects_bad_max_num(n):
    with pytest.raises(
        SimulatorError, match=rf"scan_events: max_num={n} is out of range; use \[1, 4000\]"
    ):
        sim_().scan_events(R5, n)


def test_readouts_reject_wrong_register_kinds():
    sim = sim_(8, 8)
    with pytest.raises(RegisterMisuseError, match="scan_events: A is not a digital register"):
        sim.scan_events(A)
    with pytest.raises(RegisterMisuseError, match="global_sum_16: R5 is not one of A-F or NEWS"):
        sim.global_sum_16(R5)


def test_pix_is_readable_through_the_adc():
    sim = sim_(4, 4)
    sim.set_image(np.full((4, 4), 200, np.uint8))
    assert (sim.scan_areg(PIX) == 128 + 200 // 2 - 64).all()


# --------------------------------------------------------------------------- noise


def test_noisy_readouts_scatter_around_ideal_and_repeat_with_seed():
    def codes(seed):
        sim = Scamp5(32, 32, noise="high", seed=seed)
        sim.write(A, np.full((32, 32), 10.0))
        return sim.scan_areg(A).astype(int)

    a, b, c = codes(1), codes(1), codes(2)
    assert (a == b).all()
    assert not (a == c).all()
    assert abs(a.mean() - 138) < 0.5
    assert 0.2 < a.std() < 2.0
    ideal = Scamp5(32, 32)
    ideal.write(A, np.full((32, 32), 10.0))
    assert (ideal.scan_areg(A) == 138).all()


def test_noisy_scamp5_in_and_load_in():
    sim = Scamp5(32, 32, noise="high", seed=3)
    sim.scamp5_in(A, 20)
    sim.load_in(B, 20)
    a, b = sim.read(A), sim.read(B)
    assert abs(a.mean() - 20) < 0.5 and 0 < a.std() < 2
    assert abs(b.mean() - 20) < 1.0 and b.std() > 0


@settings(max_examples=40, deadline=None)
@given(
    st.integers(0, 2**31 - 1),
    st.integers(1, 40),
    st.integers(0, 1),
    st.integers(0, 1),
)
def test_property_scan_events_is_the_ordered_prefix_of_all_ones(seed, max_num, h_dir, v_dir):
    rng = np.random.default_rng(seed)
    plane = rng.random((5, 7)) < 0.3
    sim = Scamp5(5, 7)
    sim.write(R5, plane)
    got = [tuple(e) for e in sim.scan_events(R5, max_num, h_dir, v_dir).tolist()]
    ones = [(int(r), int(c)) for r, c in np.argwhere(plane)]
    # hardware column (6 - col) ascending unless h_dir, then row ascending unless v_dir
    key = [(c if h_dir else 6 - c, 4 - r if v_dir else r) for r, c in ones]
    expected = [rc for _, rc in sorted(zip(key, ones, strict=True))][:max_num]
    assert got == expected


@settings(max_examples=40, deadline=None)
@given(st.integers(-3, 3), st.integers(-3, 3))
def test_property_shift_and_back_restores_the_interior(h, v):
    rng = np.random.default_rng(0)
    plane = rng.integers(-100, 100, (8, 8)).astype(np.float32)
    sim = Scamp5(8, 8)
    sim.write(A, plane)
    sim.shift(A, h, v)
    sim.shift(A, -h, -v)
    got = sim.read(A)
    rows = slice(max(0, v), 8 + min(0, v))  # rows/cols whose content stayed on the array
    cols = slice(max(0, -h), 8 + min(0, -h))
    assert (got[rows, cols] == plane[rows, cols]).all()
    outside = np.ones((8, 8), bool)
    outside[rows, cols] = False
    assert (got[outside] == 0).all()


def test_scamp5_get_image_runs_the_capture_kernel():
    sim = sim_(2, 2)
    sim.set_image(np.array([[0, 100], [200, 255]], np.uint8))
    sim.scamp5_get_image(A, B)
    assert sim.read(A).tolist() == [[-128.0, -28.0], [72.0, 127.0]]  # full range: p - 128
    assert sim.read(B).tolist() == [[64.0, 14.0], [-36.0, -63.5]]  # -(p/2 - 64)
    rep = sim.timing.report()
    assert (rep.total_kernels, rep.total_icws, rep.total_calls) == (1, 6, 0)
    with pytest.raises(SimulatorError, match="gain=2 is not modelled; use gain=1"):
        sim.scamp5_get_image(A, B, 2)


def test_unflagged_elements_keep_drooping_through_a_masked_host_write():
    from ppaloc.sim import NoiseParams

    sim = Scamp5(2, 2, noise=NoiseParams(decay_per_ms=1.0))
    sim.write(A, np.full((2, 2), 50.0))
    sim.write(FLAG, np.array([[1, 0], [0, 0]], dtype=bool))
    sim.timing.charge_call("scan_events", 5000)  # about 4.4 ms of modelled time
    sim.shift(A, 0, 0)  # a masked analogue host write
    droop = sim.timing.now_us / 1000  # 1 unit per ms
    assert droop > 4
    assert np.allclose(sim.read(A), 50 - droop, atol=1e-3)  # flagged or not


def test_a_dac_load_starts_fresh_after_a_long_host_call():
    from ppaloc.sim import NoiseParams

    sim = Scamp5(2, 2, noise=NoiseParams(decay_per_ms=1.0))
    sim.timing.charge_call("scan_events", 5000)  # about 4.4 ms
    sim.scamp5_in(B, 20)
    sim.nop()  # a kernel: pending droop is applied from the write on
    assert np.allclose(sim.read(B), 20, atol=0.01)
