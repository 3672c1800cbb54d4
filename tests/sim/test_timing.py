"""Timing and energy model: sums, per-class cycles, stages, energy, calibration."""

from __future__ import annotations

import dataclasses
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rich.console import Console

from ppaloc.sim.timing import (
    ANALOGNET_STAGES,
    CLOCK_CLASSES,
    CallCost,
    TimingConstants,
    TimingModel,
    analognet_calibration,
)

K = TimingConstants()


def test_kernel_of_n_digital_icws_costs_launch_plus_n_cycles():
    t = TimingModel(clock_hz=10e6)
    t.charge_kernel({"digital": 7})
    assert t.now_us == pytest.approx(K.kernel_launch_us + 7 * 0.1)


@pytest.mark.parametrize("cls", CLOCK_CLASSES)
def test_each_clock_class_costs_its_cycles(cls):
    t = TimingModel(clock_hz=10e6)
    t.charge_kernel({cls: 5})
    assert t.now_us == pytest.approx(K.kernel_launch_us + 5 * K.cycles(cls) / 10e6 * 1e6)


def test_analog_icw_uses_calibrated_cycles():
    t = TimingModel()
    assert t.icw_us("analog") == pytest.approx(0.372)
    assert t.icw_us("digital") == pytest.approx(0.1)


def test_doubling_the_clock_halves_icw_time_not_launch():
    slow, fast = TimingModel(clock_hz=10e6), TimingModel(clock_hz=20e6)
    for t in (slow, fast):
        t.charge_kernel({"analog": 100, "digital": 50})
    launch = K.kernel_launch_us
    assert fast.now_us - launch == pytest.approx((slow.now_us - launch) / 2)


def test_zero_counts_and_missing_classes_are_fine():
    t = TimingModel()
    t.charge_kernel({"analog": 0, "digital": 0, "dnews": 0, "nop": 0})
    assert t.now_us == pytest.approx(K.kernel_launch_us)
    assert t.report().stages[0].icws == {}


def test_unknown_clock_class_and_negative_count_are_bugs():
    t = TimingModel()
    with pytest.raises(ValueError, match="unknown clock class 'fast'"):
        t.charge_kernel({"fast": 1})
    with pytest.raises(ValueError, match="negative ICW count"):
        t.charge_kernel({"analog": -1})
    with pytest.raises(ValueError, match=r"clock_hz=0 is invalid: use a positive frequency"):
        TimingModel(clock_hz=0)


def test_call_cost_is_overhead_plus_fixed_plus_units():
    t = TimingModel()
    t.charge_call("scan_events", 100)
    assert t.now_us == pytest.approx(0.5 + 0.877 * 100)
    t.reset()
    t.charge_call("global_sum_64")
    assert t.now_us == pytest.approx(28.0)
    t.reset()
    t.charge_call("global_sum_16")
    assert t.now_us == pytest.approx(14.0)


def test_call_per_unit_icws_follow_the_cycles():
    t = TimingModel()
    t.charge_call("shift_areg", 3)  # overhead + launch + 3 movx of 2 analogue ICWs
    assert t.now_us == pytest.approx(0.5 + 0.33 + 3 * 2 * 0.372)
    rep = t.report()
    assert rep.stages[0].icws == {}  # call ICWs count for energy, not as kernel ICWs
    assert rep.chip_uj == pytest.approx(6 * 65536 * 1.87e-6)


def test_unknown_call_lists_the_known_ones():
    with pytest.raises(ValueError, match="no modelled cost for controller call 'teleport'"):
        TimingModel().charge_call("teleport")


def test_stage_totals_add_up_and_nest():
    t = TimingModel()
    t.charge_call("global_or")
    with t.stage("a"):
        t.charge_kernel({"analog": 10})
        with t.stage("b"):
            t.charge_call("scamp5_in")
    with t.stage("a"):
        t.charge_kernel({"digital": 4})
    rep = t.report()
    assert [s.name for s in rep.stages] == ["(unstaged)", "a", "a/b"]
    assert sum(s.us for s in rep.stages) == pytest.approx(rep.total_us)
    assert rep.total_us == pytest.approx(t.now_us)
    a = rep.stage("a")
    assert (a.kernels, a.icws, a.n_icws, a.n_calls) == (2, {"analog": 10, "digital": 4}, 14, 0)
    assert rep.stage("a/b").calls == {"scamp5_in": 1}
    assert (rep.total_icws, rep.total_kernels, rep.total_calls) == (14, 2, 2)
    with pytest.raises(KeyError):
        rep.stage("missing")


def test_stage_closes_on_exception_and_rejects_bad_names():
    t = TimingModel()
    with pytest.raises(RuntimeError), t.stage("x"):
        raise RuntimeError
    assert t.current_stage == "(unstaged)"
    for bad in ("", "a/b"):
        with pytest.raises(ValueError, match="stage name"), t.stage(bad):
            pass


def test_energy_arithmetic():
    t = TimingModel(pe_count=100)
    t.charge_kernel({"digital": 10})  # 0.33 + 1.0 us
    rep = t.report()
    assert rep.chip_uj == pytest.approx(10 * 100 * 1.87e-12 * 1e6)
    assert rep.system_uj == pytest.approx(2.5 * 1.33)  # W x us = uJ
    assert rep.energy_uj == pytest.approx(rep.chip_uj + rep.system_uj)
    assert (t.chip_uj, t.energy_uj) == (pytest.approx(rep.chip_uj), pytest.approx(rep.energy_uj))
    before = t.energy_uj
    t.charge_call("global_or")  # 1 us, no ICWs
    assert t.energy_uj - before == pytest.approx(2.5 * 1.0)
    low = TimingModel(constants=dataclasses.replace(K, system_power_w=1.0))
    low.charge_kernel({"digital": 10})
    assert low.report().system_uj == pytest.approx(1.33)


def test_reset_forgets_everything():
    t = TimingModel()
    with t.stage("s"):
        t.charge_kernel({"analog": 3})
    t.reset()
    rep = t.report()
    assert (t.now_us, rep.stages, rep.energy_uj) == (0.0, (), 0.0)


def test_report_renders_as_text_rich_and_json():
    t = TimingModel()
    with t.stage("capture"):
        t.charge_kernel({"analog": 6})
    with t.stage("readout"):
        t.charge_call("scan_events", 10)
    rep = t.report()
    text = str(rep)
    lines = text.splitlines()
    assert lines[0].split() == ["stage", "ICWs", "kernels", "calls", "time", "(us)", "chip", "(uJ)"]
    assert any(line.split()[:4] == ["capture", "6", "1", "0"] for line in lines)
    assert any(line.startswith("total") for line in lines)
    assert "energy" in lines[-1]
    console = Console(record=True, width=120)
    console.print(rep)
    rendered = console.export_text()
    assert "capture" in rendered and "readout" in rendered and "total" in rendered
    data = json.loads(json.dumps(rep.as_dict()))
    assert data["total_us"] == pytest.approx(rep.total_us)
    assert [s["name"] for s in data["stages"]] == ["capture", "readout"]


@pytest.mark.parametrize("stage", list(ANALOGNET_STAGES))
def test_calibration_reproduces_analognet_stage_times(stage):
    modelled, measured = analognet_calibration()[stage]
    assert modelled == pytest.approx(measured, rel=0.01)


def test_calibration_is_sensitive_to_the_constants():
    slower = dataclasses.replace(K, analog_cycles=2 * K.analog_cycles)
    modelled, measured = analognet_calibration(slower)["three convolutions"]
    assert modelled > 1.9 * measured


def test_every_constant_has_a_unit_and_a_source():
    rows = K.table()
    assert len(rows) == 1 + 8 + len(K.calls)
    for name, value, unit, source in rows:
        assert unit and source, name
        assert isinstance(value, float), name
    calibrated = {r[0] for r in rows if r[3].startswith("calibrated")}
    assert {"analog_cycles", "kernel_launch_us", "call scan_events"} <= calibrated


def test_constants_are_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        K.analog_cycles = 1.0  # type: ignore[misc]
    with pytest.raises(TypeError):
        K.calls["x"] = CallCost(1.0)  # type: ignore[index]


_events = st.lists(
    st.tuples(
        st.sampled_from(["", "a", "b"]),
        st.one_of(
            st.dictionaries(st.sampled_from(CLOCK_CLASSES), st.integers(0, 50), max_size=4),
            st.tuples(st.sampled_from(sorted(K.calls)), st.integers(0, 200)),
        ),
    ),
    max_size=30,
)


@settings(max_examples=50, deadline=None)
@given(_events)
def test_property_stages_sum_to_total_and_time_never_decreases(events):
    t = TimingModel()
    last = 0.0
    for stage, ev in events:
        with t.stage(stage) if stage else _null():
            if isinstance(ev, dict):
                t.charge_kernel(ev)
            else:
                t.charge_call(*ev)
        assert t.now_us >= last
        last = t.now_us
    rep = t.report()
    assert sum(s.us for s in rep.stages) == pytest.approx(rep.total_us)
    assert rep.total_kernels == sum(isinstance(ev, dict) for _, ev in events)
    assert rep.total_calls == sum(not isinstance(ev, dict) for _, ev in events)


class _null:
    def __enter__(self):
        return None

    def __exit__(self, *exc):
        return False


def test_every_constant_is_documented():
    from pathlib import Path

    doc = (Path(__file__).parents[2] / "docs" / "sim-controller.md").read_text()
    for f in dataclasses.fields(TimingConstants):
        if f.name != "calls":
            assert f"`{f.name}`" in doc, f.name
    for name in K.calls:
        assert f"`{name}`" in doc, name
