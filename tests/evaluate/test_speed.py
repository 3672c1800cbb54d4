"""The query-speed check: centres from the ground truth, robust window speeds, the warning
once per method, and its field in results.json and the report."""

from __future__ import annotations

import json
import logging

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.datasets import load_dataset
from ppaloc.errors import DataError
from ppaloc.evaluate import EvaluateConfig, load_results, run_evaluation, save_results
from ppaloc.evaluate.report import method_notes, write_report
from ppaloc.evaluate.speed import (
    check_speed,
    match_centres,
    speed_checks,
    window_speeds,
)


def test_centres_skip_queries_without_a_match() -> None:
    got = match_centres([np.array([1, 2, 3]), np.array([], dtype=np.int64), np.array([9])])
    np.testing.assert_array_equal(got, [2.0, np.nan, 9.0])


def test_window_speed_is_robust_to_a_glitch_and_to_gaps() -> None:
    # 1.5 reference frames a frame, one ground-truth jump and two queries without a match.
    c = 1.5 * np.arange(40.0)
    c[12] = 200.0
    c[[5, 30]] = np.nan
    speeds = window_speeds(c, 10)
    assert speeds.shape == (30,)
    np.testing.assert_allclose(speeds, 1.5, atol=1e-9)
    # A window with fewer than two known frames has no speed.
    assert np.isnan(window_speeds(np.array([0.0, np.nan, np.nan, np.nan]), 2)).all()
    assert window_speeds(np.arange(5.0), 10).size == 0


@settings(max_examples=30, deadline=None)
@given(
    speed=st.floats(0.1, 5.0),
    start=st.integers(0, 100),
    window=st.integers(2, 12),
)
def test_a_constant_speed_is_measured_to_within_the_rounding(speed, start, window) -> None:
    c = np.round(start + speed * np.arange(40))  # centres are whole reference frames
    speeds = window_speeds(c, window)
    assert np.all(np.abs(speeds - speed) <= 1.0 / ((window + 1) // 2) + 1e-9)


def test_check_speed_thresholds_and_message() -> None:
    # 0.8..1.2 with the 25% margin: far outside below 0.64 and above 1.5.
    speeds = np.array([1.0] * 6 + [1.49] * 2 + [1.6] * 2 + [np.nan] * 3)
    ok = check_speed(speeds, (0.8, 1.2), method="seqslam")
    assert ok["share_outside"] == pytest.approx(0.2) and ok["warning"] is None
    assert ok["range"] == [0.8, 1.2] and ok["query_speed_median"] == pytest.approx(1.0)
    bad = check_speed(np.array([2.0] * 7 + [1.0] * 3), (0.8, 1.2), method="seqslam")
    assert bad["share_outside"] == pytest.approx(0.7)
    assert bad["warning"].startswith(
        "seqslam searches query speeds of 0.8 to 1.2 reference frames per query frame, but "
        "on 70% of this route the query moves at under 0.64 or over 1.5 (median 2.00)"
    )
    one = check_speed(np.full(5, 0.5), (1.0, 1.0), method="able-m")["warning"]
    assert one.startswith("able-m assumes a query speed of 1 reference frames per query")
    nothing = check_speed(np.full(3, np.nan), (0.8, 1.2))
    assert nothing["share_outside"] is None and nothing["warning"] is None


class _Declares:
    def __init__(self, speed_range):
        self.speed_range = speed_range


def test_speed_checks_warn_once_per_declaring_method(caplog) -> None:
    gt = [np.array([2 * i]) for i in range(40)]  # twice the mapping speed
    locs = {"a": _Declares((0.8, 1.2)), "b": _Declares((0.5, 3.0)), "c": object()}
    with caplog.at_level(logging.WARNING, logger="ppaloc.evaluate.speed"):
        out = speed_checks(locs, gt)
    assert set(out) == {"a", "b"}
    assert out["a"]["share_outside"] == 1.0 and out["b"]["warning"] is None
    assert [r.getMessage()[:2] for r in caplog.records] == ["a "]


def test_methods_searching_the_same_speeds_share_one_warning_line(caplog) -> None:
    gt = [np.array([2 * i]) for i in range(40)]
    locs = {n: _Declares((0.8, 1.2)) for n in ("a", "b", "c")} | {"d": _Declares((1.0, 1.0))}
    with caplog.at_level(logging.WARNING, logger="ppaloc.evaluate.speed"):
        out = speed_checks(locs, gt)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2
    assert lines[0].startswith("a, b and c each search query speeds of 0.8 to 1.2 reference")
    assert "their figures here measure their speed assumption" in lines[0]
    assert lines[1].startswith("d assumes a query speed of 1 ")
    assert all(out[n]["warning"].startswith(f"{n} searches") for n in "abc")


class _FollowsStops(_Declares):
    follows_stops = True


def test_a_method_that_follows_stops_is_checked_on_the_moving_frames(caplog) -> None:
    # one place a frame with a stop of 20 frames in the middle: a third of the windows
    # stand still, outside every range, but a motion model that calls the stop still
    # follows it (the demo's own route at 100 places warned the filter's paper preset)
    centres = [*range(20), *[20] * 20, *range(21, 40)]
    gt = [np.array([c]) for c in centres]
    moved = np.diff(centres, prepend=-1) > 0
    locs = {"a": _Declares((1.0, 1.0)), "b": _FollowsStops((1.0, 1.0))}
    with caplog.at_level(logging.WARNING, logger="ppaloc.evaluate.speed"):
        out = speed_checks(locs, gt, moved=moved)
    assert out["a"]["share_outside"] > 0.25 and out["a"]["stops_left_out"] == 0
    assert out["b"] == {
        "range": [1.0, 1.0],
        "query_speed_median": 1.0,
        "share_outside": 0.0,
        "warning": None,
        "stops_left_out": 19,
    }
    assert [r.getMessage()[:2] for r in caplog.records] == ["a "]
    # without the dataset's moves no frame is known to stand: both are checked whole
    assert speed_checks(locs, gt)["b"]["warning"] is not None


def test_the_filters_image_motion_follows_stops() -> None:
    from ppaloc.methods import make_localiser

    assert make_localiser("weighted-node-lbp").follows_stops
    assert make_localiser("onsensor-lbp", preset="paper").follows_stops
    assert not make_localiser("weighted-node-lbp", motion="always_forward").follows_stops


def test_baselines_declare_their_speeds() -> None:
    from ppaloc.methods import make_localiser

    assert make_localiser("seqslam").speed_range == (0.8, 1.2)
    assert make_localiser("seqslam-centred").speed_range == (0.8, 1.2)
    assert make_localiser("able-m").speed_range == (1.0, 1.0)
    lo, hi = make_localiser("particle-filter").speed_range
    assert 0.6 < lo < 0.7 and 1.6 < hi < 1.7
    assert not hasattr(make_localiser("single-frame"), "speed_range")


@pytest.fixture(scope="module")
def fast_route():
    """A generated route driven at twice the mapping speed (small frames, short)."""
    return load_dataset("synthetic:?places=60&query=winter&seed=1&speed=2&stops=0&size=64")


def test_an_evaluation_at_twice_the_speed_warns_and_records_it(fast_route, tmp_path, caplog):
    cfg = EvaluateConfig(methods=("seqslam", "single-frame"), record_weights=False)
    with caplog.at_level(logging.WARNING):
        result = run_evaluation(cfg, dataset=fast_route, progress=False)
    warned = [r.getMessage() for r in caplog.records if r.name == "ppaloc.evaluate.speed"]
    assert len(warned) == 1 and warned[0].startswith("seqslam searches query speeds of 0.8")
    check = result.runs["seqslam"].speed_check
    assert check["share_outside"] > 0.9 and 1.8 <= check["query_speed_median"] <= 2.2
    assert result.runs["single-frame"].speed_check is None
    out = save_results(result, tmp_path / "out")
    summary = json.loads(out.read_text())
    assert summary["methods"]["seqslam"]["speed_check"]["warning"] == warned[0]
    assert summary["methods"]["single-frame"]["speed_check"] is None
    back, _ = load_results(tmp_path / "out")
    assert back.runs["seqslam"].speed_check == check
    report = write_report(tmp_path / "out")
    assert warned[0] in (tmp_path / "out" / "report.md").read_text()
    assert "Notes on the methods" in report.read_text()
    assert method_notes(summary, short=True) == [
        f"seqslam: the query moves outside the speeds it searches (0.8-1.2) on "
        f"{check['share_outside']:.0%} of the route"
    ]
    summary["methods"]["seqslam"]["speed_check"] = {"warning": 3}
    out.write_text(json.dumps(summary))
    with pytest.raises(DataError, match=r"methods.seqslam.speed_check is \{'warning': 3\}"):
        load_results(tmp_path / "out")


def test_the_weighted_node_filters_declare_the_speeds_they_follow() -> None:
    """Host and sensor take the range from the one filter contract; it follows the costs."""
    from ppaloc.methods import make_localiser

    for name in ("weighted-node-lowres16", "weighted-node-lbp", "onsensor-lowres"):
        assert make_localiser(name).speed_range == (0.5, 2.0)  # the speed lane's top
        assert make_localiser(name, lane_speed=0).speed_range == (0.5, 1.5)
    stiff = make_localiser("weighted-node-lowres", stay_cost=8, skip_cost=8, lane_speed=0)
    assert stiff.speed_range == (0.5, 1.25)  # the slow lane's 1/2
    stiff = make_localiser(
        "weighted-node-lowres", stay_cost=8, skip_cost=8, lane_speed=0, slow_lane=False
    )
    assert stiff.speed_range == (0.75, 1.25)
    assert make_localiser("weighted-node-lowres", lane_speed=3).speed_range == (0.5, 3.0)
    assert make_localiser("weighted-node-lowres", skip_cost=1).speed_range == (0.5, 3.0)
    assert make_localiser("weighted-node-lbp", preset="paper").speed_range == (1.0, 1.0)


def test_a_weighted_node_filter_at_twice_the_speed_is_warned(fast_route, caplog) -> None:
    """Without its speed lane the filter is warned at twice the speed; with it (the
    default) the route is within its range."""
    cfg = EvaluateConfig(
        methods=("weighted-node-lowres", "weighted-node-lbp"),
        params={"weighted-node-lowres": {"lane_speed": 0}},
        record_weights=False,
    )
    with caplog.at_level(logging.WARNING):
        result = run_evaluation(cfg, dataset=fast_route, progress=False)
    check = result.runs["weighted-node-lowres"].speed_check
    assert check["range"] == [0.5, 1.5] and check["share_outside"] > 0.5
    laned = result.runs["weighted-node-lbp"].speed_check
    assert laned["range"] == [0.5, 2.0] and laned["warning"] is None
    warned = [r.getMessage() for r in caplog.records if r.name == "ppaloc.evaluate.speed"]
    assert len(warned) == 1 and warned[0].startswith("weighted-node-lowres searches query")
    assert "lower skip_cost for a faster query (1: up to 3 places a frame)" in warned[0]
    assert check["warning"] == warned[0]


def test_a_warning_names_the_method_s_own_remedy() -> None:
    fast = np.full(20, 2.5)
    own = check_speed(fast, (0.5, 1.5), method="m", remedy="lower skip_cost")["warning"]
    assert "place recognition; lower skip_cost (docs/baselines.md" in own
    generic = check_speed(fast, (0.5, 1.5), method="m")["warning"]
    assert "place recognition; widen its speed range or subsample the query (docs" in generic
    from ppaloc.methods import make_localiser

    assert make_localiser("onsensor-lbp").speed_remedy.startswith("lower skip_cost")
    assert "robust preset" in make_localiser("weighted-node-lbp", preset="paper").speed_remedy
    assert not hasattr(make_localiser("seqslam"), "speed_remedy")


def test_the_short_note_of_a_method_of_one_speed_names_that_speed():
    # the paper preset's note read "outside the speeds it searches (1-1)"
    check = {"warning": "...", "range": [1.0, 1.0], "share_outside": 0.7}
    summary = {"methods": {"weighted-node-paper-lbp": {"speed_check": check}}}
    assert method_notes(summary, short=True) == [
        "weighted-node-paper-lbp: the query moves off the speed it assumes (1) on 70% of the route"
    ]


def test_the_short_notes_of_methods_alike_are_one_line():
    # a run of every method printed a dozen lines that differed only in the name
    def check(lo, hi):
        return {"speed_check": {"warning": "...", "range": [lo, hi], "share_outside": 0.5}}

    summary = {
        "methods": {
            "weighted-node-lbp": check(0.5, 2.0),
            "seqslam-centred": {**check(0.8, 1.2), "reads_future": True},
            "onsensor-lbp": check(0.5, 2.0),
        }
    }
    assert method_notes(summary, short=True) == [
        "weighted-node-lbp, onsensor-lbp: the query moves outside the speeds it searches "
        "(0.5-2) on 50% of the route",
        "seqslam-centred is offline (reads future frames)",
        "seqslam-centred: the query moves outside the speeds it searches (0.8-1.2) on 50% of "
        "the route",
    ]
    assert len(method_notes(summary)) == 4  # the report's notes: each method's own
