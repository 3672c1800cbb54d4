"""Validation workloads of the timing model: their reconstruction and their intervals."""

from __future__ import annotations

import dataclasses

import pytest

from ppaloc.sim.timing import ANALOGNET_STAGES, TimingConstants, TimingError, evaluate_us
from ppaloc.sim.timing_validation import (
    ANALOGNET_FRAME,
    CANDIDATES,
    WORKLOADS,
    Workload,
    program_counts,
)


def test_analognet_frame_counts_are_its_stages_counted_by_hand():
    # binarisation 8+12 analogue, 1 nop, 5+5+2 digital, 3 kernels, 2 scamp5_in, 1 load_rect;
    # convolutions 44+42+94 analogue, 3 kernels; readout 3 x (3 analogue, 3 digital, a
    # scamp5_in, scan_events(100)); then one frame-loop control
    assert ANALOGNET_FRAME.counts() == {
        "icw:analog": 8 + 12 + 44 + 42 + 94 + 3 * 3,
        "icw:nop": 1,
        "icw:digital": 5 + 5 + 2 + 3 * 3,
        "kernels": 3 + 3 + 3,
        "calls:scamp5_in": 2 + 3,
        "units:scamp5_in": 5,
        "calls:load_rect": 1,
        "units:load_rect": 1,
        "calls:scan_events": 3,
        "units:scan_events": 300,
        "calls:vs_frame_loop_control": 1,
    }
    assert ANALOGNET_FRAME.fitted_published_us == 13 + 68 + 273


def test_program_counts_adds_a_kernel_per_entry_and_units_per_call():
    counts = program_counts([{"analog": 2}, {"analog": 1, "digital": 4}], [("scan_events", 7)])
    assert counts == {
        "icw:analog": 3,
        "icw:digital": 4,
        "kernels": 2,
        "calls:scan_events": 1,
        "units:scan_events": 7,
    }
    assert program_counts([], [("global_or", 0)]) == {"calls:global_or": 1}


def test_fitted_part_costs_what_was_measured_at_every_corner():
    # the claim that the fitted part tests nothing: each corner reproduces AnalogNet's stages
    corners = TimingConstants().corners()
    for c in corners["low"] + corners["high"]:
        assert evaluate_us(ANALOGNET_FRAME.fitted, c) == pytest.approx(354.0, abs=1e-6)


@pytest.mark.parametrize("w", WORKLOADS, ids=lambda w: w.name.split(",")[0])
def test_published_time_inside_the_interval_with_the_mid_within_15_percent(w):
    iv = w.interval()
    assert iv.low <= iv.mid <= iv.high
    assert iv.contains(w.published_us)
    assert iv.mid == pytest.approx(w.published_us, rel=0.15)


@pytest.mark.parametrize("w", WORKLOADS, ids=lambda w: w.name.split(",")[0])
def test_unfitted_part_inside_its_interval(w):
    part = w.as_dict()["unfitted_part"]
    lo, mid, hi = part["modelled_us"]
    assert lo <= part["published_us"] <= hi
    whole = w.interval()
    assert mid == pytest.approx(whole.mid - w.fitted_published_us, abs=0.5)


def test_as_dict_has_the_issue_fields():
    d = ANALOGNET_FRAME.as_dict()
    assert {"workload", "source", "published_us", "modelled_us", "independent"} <= set(d)
    assert len(d["modelled_us"]) == 3
    assert d["modelled_us"] == sorted(d["modelled_us"])
    assert d["published_us"] == pytest.approx(1e6 / 2260)


def test_host_estimate_must_be_ordered():
    with pytest.raises(TimingError, match=r"host_us=\(3, 2, 1\) is invalid"):
        dataclasses.replace(ANALOGNET_FRAME, host_us=(3, 2, 1))
    assert isinstance(dataclasses.replace(ANALOGNET_FRAME, host_us=(0, 0, 0)), Workload)


def test_every_candidate_names_its_source_figure_and_reason():
    assert len({c.name for c in CANDIDATES}) == len(CANDIDATES)
    for c in CANDIDATES:
        assert c.source and c.published and c.reason
    names = {w.name for w in WORKLOADS}
    assert not names & {c.name for c in CANDIDATES}


def test_analognet_stage_table_is_what_the_workload_reads():
    # a change to the calibration table must show in the workload, not be copied beside it
    stages = ANALOGNET_STAGES.values()
    assert ANALOGNET_FRAME.fitted_published_us == sum(p["measured_us"] for p in stages)
    n_kernels = sum(len(p["kernels"]) for p in stages)
    assert ANALOGNET_FRAME.fitted["kernels"] == n_kernels
