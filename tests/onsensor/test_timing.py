"""The chip and loop boundaries, and the precursor's program structure as counts."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.errors import PpalocError
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.precursor import (
    PRECURSOR_EVENT_SLOTS,
    REPLACED_STAGES,
    injection_counts,
    kernel_counts,
    loop_counts,
    precursor_detect_counts,
    precursor_stage_counts,
    structure_counts,
)
from ppaloc.sim.timing import TimingConstants, add_counts, evaluate_us, interval_us

K = TimingConstants()


def test_precursor_kernels_are_recorded_with_the_macro_table():
    sad = kernel_counts("sub_abs_clr")
    assert sad["kernels"] == 1 and sad["icw:analog"] >= 4 and sad["icw:digital"] >= 1
    assert kernel_counts("refresh4") == {"icw:digital": 8.0, "kernels": 1.0}
    with pytest.raises(PpalocError, match="no precursor kernel 'nope'"):
        kernel_counts("nope")


def test_injection_draws_runs_of_full_bytes_and_the_set_bits_of_the_others():
    black = np.zeros((256, 256), np.uint8)
    white = np.full((256, 256), 255, np.uint8)
    c_black, c_white = injection_counts(black), injection_counts(white)
    assert c_black["calls:scamp5_draw_pixel"] == 0 and c_black["calls:scamp5_draw_rect"] == 0
    assert c_white["calls:scamp5_draw_rect"] == 4 * 256 and c_white["calls:scamp5_draw_pixel"] == 0
    stripes = np.zeros((256, 256), np.uint8)
    stripes[:, ::2] = 0xF0  # the top 4 bits set on every other column: mixed bytes
    c = injection_counts(stripes)
    assert c["calls:scamp5_draw_pixel"] == 4 * 256 * 128 and c["calls:scamp5_draw_rect"] == 0
    assert c["units:vs_gui_request_image"] == 4 * 256 * 32
    with pytest.raises(PpalocError, match="multiple of 8 columns"):
        injection_counts(np.zeros((4, 5), np.uint8))


def test_loop_adds_the_frame_control_and_the_estimate():
    c = loop_counts(np.zeros((256, 256), np.uint8))
    assert c["calls:vs_frame_loop_control"] == 1 and c["units:usb_output"] == 4
    assert interval_us(c).mid > 1600  # 32 KiB at 20 MB/s alone
    frame = np.random.default_rng(0).integers(0, 256, (256, 256)).astype(np.uint8)
    drawn, only = loop_counts(frame), loop_counts(frame, injection="bytes")
    assert "calls:scamp5_draw_pixel" not in only
    assert only["units:vs_gui_request_image"] == drawn["units:vs_gui_request_image"]
    assert interval_us(drawn).low > interval_us(only).high  # ~30k drawn pixels
    with pytest.raises(PpalocError, match="injection='fast'"):
        loop_counts(frame, injection="fast")


def test_precursor_detection_follows_the_thresholds_and_caps_the_events():
    one = precursor_detect_counts(None)
    assert one["calls:scan_events"] == 1 and one["calls:scan_areg"] == 1
    low = precursor_detect_counts(np.zeros(50))  # nothing above 1: all six passes
    assert low["calls:scan_events"] == 6 and "calls:scan_areg" not in low
    many = precursor_detect_counts(np.full(1000, 100.0))
    assert many["calls:scan_events"] == 1 and many["calls:scan_areg"] == PRECURSOR_EVENT_SLOTS
    second = precursor_detect_counts(np.array([40.0, 50.0, -3.0]))  # none > 63, two > 31
    assert second["calls:scan_events"] == 2 and second["calls:scan_areg"] == 2


@pytest.mark.parametrize("rep", ["lowres", "lbp"])
def test_structures_replace_exactly_the_precursors_stages(rep):
    ours = {"capture": {"kernels": 1.0}, "compare": {"kernels": 5.0}, "detect": {"kernels": 9.0}}
    assert structure_counts(ours, rep, "ppaloc") == {"kernels": 15.0}
    theirs = precursor_stage_counts(rep, forward=False)
    assert "shift" not in theirs and ("replicate" in theirs) == (rep == "lowres")
    got = structure_counts(ours, rep, "precursor", forward=False)
    want = add_counts({"kernels": 1.0}, *theirs.values())
    assert got == want
    assert set(REPLACED_STAGES[rep]) >= {"compare", "detect"}
    with pytest.raises(PpalocError, match="structure='other'"):
        structure_counts(ours, rep, "other")


def test_precursor_replication_is_64_dac_loads():
    rep = precursor_stage_counts("lowres", forward=True)
    assert rep["replicate"]["calls:load_in"] == 64
    assert rep["replicate"]["calls:scan_areg_mean_8x8"] == 1
    assert rep["shift"]["units:shift_dreg"] >= 248


def test_the_localiser_reports_both_boundaries_with_chip_mid_the_latency(blocky_route):
    frames = blocky_route(6, 3, [])[0]
    loc = OnSensorLocaliser("lbp", preset="paper", motion="always_forward", alpha=8)
    loc.build_map(frames)
    assert loc.modelled_time_ms() is None
    est = loc.localise(frames)
    t = loc.modelled_time_ms()
    assert t["chip"]["mid"] == pytest.approx(np.median([e.modelled_latency_ms for e in est]))
    for b in ("chip", "loop"):
        assert t[b]["low"] <= t[b]["mid"] <= t[b]["high"]
    assert t["loop"]["low"] > t["chip"]["high"]
    pre = OnSensorLocaliser(
        "lbp", preset="paper", motion="always_forward", alpha=8, timing_structure="precursor"
    )
    pre.use_map(loc.topomap)
    est2 = pre.localise(frames)
    assert [e.node for e in est2] == [e.node for e in est]  # timing only
    assert pre.modelled_time_ms()["chip"]["mid"] > t["chip"]["mid"]
    loc.reset()
    assert loc.modelled_time_ms() is None
    with pytest.raises(PpalocError, match="timing_structure='x'"):
        OnSensorLocaliser("lbp", timing_structure="x")


def test_mid_counts_evaluate_to_the_charged_time(blocky_route):
    frames = blocky_route(4, 5, [])[0]
    loc = OnSensorLocaliser("lowres", preset="paper", motion="always_forward", alpha=8)
    loc.build_map(frames)
    est = loc.localise(frames)
    chip = [c for c, _ in loc.frame_times]
    for iv, e in zip(chip, est, strict=True):
        assert iv.mid / 1000 == pytest.approx(e.modelled_latency_ms, abs=1e-9)
    assert evaluate_us({"kernels": 2.0}, K) == pytest.approx(2 * K.kernel_launch_us)


def test_a_run_summary_carries_both_boundaries(blocky_route):
    from ppaloc.evaluate.run import run_method

    frames = blocky_route(5, 7, [])[0]
    loc = OnSensorLocaliser("lbp", preset="paper", motion="always_forward", alpha=8)
    truth = [np.array([i]) for i in range(5)]
    summary = run_method("onsensor-paper-lbp", frames, frames, truth, localiser=loc).summary()
    t = summary["modelled_time_ms"]
    assert set(t) == {"chip", "loop"} and set(t["chip"]) == {"low", "mid", "high"}
    assert t["chip"]["mid"] == pytest.approx(summary["modelled_latency_ms"])


def _plain_draws(img: np.ndarray, bit_planes: int = 4) -> tuple[int, int]:
    """(draw_rect, draw_pixel) counts byte by byte: a rect per run of 0xFF bytes in a row,
    a pixel per set bit of every other byte."""
    rects = pixels = 0
    for b in range(bit_planes):
        for row in (img >> (7 - b)) & 1:
            run = False
            for k in range(0, len(row), 8):
                byte = row[k : k + 8]
                full = bool(byte.all())
                rects += full and not run
                pixels += 0 if full else int(byte.sum())
                run = full
    return rects, pixels


@settings(max_examples=30, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(1, 8),
    st.sampled_from([1, 4, 16]),
    st.sampled_from([1, 3, 4, 8]),
)
def test_injection_counts_every_byte_as_the_plain_walk(seed, rows, cell, bit_planes):
    """Every plane's bytes as the walk counts them (all planes are counted at once)."""
    rng = np.random.default_rng(seed)
    cells = rng.choice([0, 255, 128, 77, 0xF0, 0x0F], size=(rows, 64 // cell))
    img = np.repeat(cells, cell, axis=1).astype(np.uint8)
    img[0, rng.integers(0, 64)] = rng.integers(0, 256)  # a stray value breaks a run
    c = injection_counts(img, bit_planes)
    got = (c["calls:scamp5_draw_rect"], c["calls:scamp5_draw_pixel"])
    assert got == _plain_draws(img, bit_planes)


def test_a_frames_counts_leave_out_what_is_charged_between_frames(blocky_route):
    """The next frame starts from the last frame's end counts only while nothing else
    was charged: a call between frames is in neither frame."""
    frames = blocky_route(4, 5, [])[0]

    def run(between: bool) -> list:
        loc = OnSensorLocaliser("lbp", preset="paper", motion="always_forward", alpha=8)
        loc.build_map(frames)
        loc.reset()
        for i, f in enumerate(frames):
            loc.step(f)
            if between and i == 1:
                loc.pipeline.sim.load_in(5)  # charged outside any frame
        return loc.frame_times

    assert run(True) == run(False)
