"""Count vectors and low/mid/high intervals of the timing model."""

from __future__ import annotations

import dataclasses

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.sim.timing import (
    ANALOGNET_STAGES,
    TimingConstants,
    TimingError,
    TimingModel,
    add_counts,
    analognet_calibration,
    analognet_fit,
    diff_counts,
    evaluate_us,
    interval_us,
)

K = TimingConstants()
CALLS = sorted(K.calls)

_kernel = st.fixed_dictionaries(
    {c: st.integers(0, 40) for c in ("analog", "digital", "dnews", "nop")}
).map(lambda d: ("kernel", d))
_call = st.tuples(st.sampled_from(CALLS), st.integers(0, 300)).map(lambda t: ("call", t))
_programs = st.lists(st.one_of(_kernel, _call), max_size=25)


def _run(program, stages=("a", "b")):
    t = TimingModel()
    for i, (kind, ev) in enumerate(program):
        with t.stage(stages[i % len(stages)]):
            if kind == "kernel":
                t.charge_kernel(ev)
            else:
                t.charge_call(*ev)
    return t


@settings(max_examples=60, deadline=None)
@given(_programs)
def test_counts_evaluated_with_the_mid_constants_are_what_was_charged(program):
    t = _run(program)
    counts = add_counts(*t.counts_by_stage().values())
    assert evaluate_us(counts, K) == pytest.approx(t.now_us, abs=1e-9)
    iv = t.interval(counts)
    assert iv.low <= iv.mid + 1e-9 <= iv.high + 2e-9
    assert iv.mid == pytest.approx(t.now_us, abs=1e-9)


@settings(max_examples=30, deadline=None)
@given(_programs, _programs)
def test_diff_of_snapshots_is_the_second_program(first, second):
    t = _run(first)
    before = t.counts_by_stage()
    t0 = t.now_us
    for kind, ev in second:
        with t.stage("b"):
            t.charge_kernel(ev) if kind == "kernel" else t.charge_call(*ev)
    frame = add_counts(*diff_counts(t.counts_by_stage(), before).values())
    assert evaluate_us(frame, K) == pytest.approx(t.now_us - t0, abs=1e-9)


@pytest.mark.parametrize("level", ["low", "high"])
def test_every_corner_still_reproduces_analognet(level):
    for corner in K.corners()[level]:
        for stage, (modelled, measured) in analognet_calibration(corner).items():
            assert modelled == pytest.approx(measured, rel=1e-9), stage


def test_the_fit_at_the_mid_overhead_gives_the_rounded_mid_constants():
    a, launch, slot = analognet_fit(K)
    assert a == pytest.approx(K.analog_cycles, rel=0.01)
    assert launch == pytest.approx(K.kernel_launch_us, abs=0.01)
    assert slot == pytest.approx(K.calls["scan_events"].per_unit_us, rel=0.01)


def test_an_overhead_beyond_analognet_has_no_fit():
    with pytest.raises(TimingError, match="no non-negative fit"):
        analognet_fit(dataclasses.replace(K, call_overhead_us=2.0))


def test_kernel_heavy_and_call_heavy_programs_take_opposite_corners():
    """Cheap calls refit to dear launches: the bound of a program depends on its mix."""
    kernels = {"kernels": 100.0}
    calls = {"calls:load_in": 100.0}
    low, high = K.corners()["low"]
    assert evaluate_us(kernels, low) > evaluate_us(kernels, high)
    assert evaluate_us(calls, low) < evaluate_us(calls, high)
    for counts in (kernels, calls):
        iv = interval_us(counts)
        assert iv.low < iv.mid < iv.high


def test_every_row_of_the_one_table_has_bounds_and_a_source():
    rows = K.interval_table()
    names = {r[0] for r in rows}
    assert {"analog_cycles", "kernel_launch_us", "call vs_gui_request_image per byte"} <= names
    for name, low, mid, high, unit, source in rows:
        assert low <= mid + 1e-12 and mid <= high + 1e-12, name
        assert unit and source, name
        if low < high:
            assert source.startswith(("estimate", "calibrated", "scamp5_")), name
    assert sum(1 for s in ANALOGNET_STAGES) == 3


def test_unknown_count_keys_and_levels_are_errors():
    with pytest.raises(TimingError, match="unknown count key"):
        evaluate_us({"bogus": 1.0}, K)
    with pytest.raises(TimingError, match="no modelled cost"):
        evaluate_us({"calls:nope": 1.0}, K)
    with pytest.raises(TimingError, match="level='mid'"):
        K.corner("mid", 0.5)
