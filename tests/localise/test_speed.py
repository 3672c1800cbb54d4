"""The robust filter's speed from its own path (``speed_window``, ``speed_confidence``)."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from ppaloc.errors import PpalocError
from ppaloc.localise.params import FilterParams, PathSpeed, path_speed, transition_costs
from ppaloc.localise.schedule import FrameResult, RobustSchedule
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.topomap import TopoMap

from .conftest import stepped


@given(
    a=st.integers(1, 64),
    f=st.integers(1, 32),
    stay=st.integers(0, 64),
    skip=st.integers(0, 64),
    most=st.integers(1, 3),
)
def test_the_costs_are_a_valley_at_the_speed(a, f, stay, skip, most):
    """Each cost is ``k |d - v|`` rounded half up, less the least: falling up to ``v =
    a / f`` and rising after it; the costs of one node a frame at ``v = 1``; a still
    frame's costs ignore the speed."""
    p = FilterParams.create("lbp", stay_cost=stay, skip_cost=skip, max_advance=most)
    costs = transition_costs(True, p, PathSpeed(a, f))
    v = Fraction(a, f)
    exact = [int((stay if d < v else skip) * abs(d - v) + Fraction(1, 2)) for d in range(most + 1)]
    assert list(costs) == [c - min(exact) for c in exact]
    below = [c for d, c in enumerate(costs) if d <= v]
    above = [c for d, c in enumerate(costs) if d >= v]
    assert below == sorted(below, reverse=True) and above == sorted(above)
    assert transition_costs(True, p, PathSpeed(f, f)) == transition_costs(True, p)
    assert transition_costs(False, p, PathSpeed(a, f)) == transition_costs(False, p)


def test_the_costs_round_half_a_unit_up():
    p = FilterParams.create("lbp", stay_cost=3, skip_cost=5)
    # v = 3/2: stay 3 x 1.5 = 4.5 -> 5, +1 3 x 0.5 = 1.5 -> 2, +2 5 x 0.5 = 2.5 -> 3,
    # +3 5 x 1.5 = 7.5 -> 8; less the least, 2 (rounding halves to even would give 2, 0, 0, 6)
    assert transition_costs(True, p, PathSpeed(3, 2)) == (3, 0, 1, 6)


@pytest.mark.parametrize(
    ("places", "scores", "want"),
    [
        ([0, 1, 2, 3], [40] * 4, None),  # three forward frames: not yet a window of 4
        ([0, 1, 2, 3, 5], [40] * 5, (5, 4)),
        ([9, 0, 1, 2, 3, 5], [40] * 6, (5, 4)),  # only the last four steps count
        ([9, 0, 1, 2, 3, 5], [0, 40, 40, 40, 40, 40], (5, 4)),  # and their five estimates
        ([0, 1, 2, 1, 3], [40] * 5, None),  # a step back: a re-localisation
        ([0, 1, 5, 6, 7], [40] * 5, None),  # four places in a frame: beyond max_advance
        ([0, 1, 2, 3, 5], [40, 40, 31, 40, 40], None),  # one estimate below the gate
        ([0, 1, 2, 3, 5], [31, 40, 40, 40, 40], None),  # the window's first end counts too
        ([0, 1, 2, 3, 5], [40, 40, 32, 40, 40], (5, 4)),  # at the gate passes
        ([0, 3, 6, 9, 12], [40] * 5, (2, 1)),  # 3 a frame: clipped to 2
        ([0, 0, 0, 0, 0], [40] * 5, (1, 2)),  # 0: clipped to 1/2
    ],
)
def test_the_path_speed_is_read_only_from_a_path_the_filter_could_take(places, scores, want):
    p = FilterParams.create("lbp", speed_window=4, speed_confidence=32)
    assert path_speed(places, scores, p) == want


def test_no_window_no_speed():
    p = FilterParams.create("lbp", speed_window=0)
    assert path_speed(list(range(100)), [99] * 100, p) is None


@pytest.mark.parametrize(
    "bad", [{"speed_window": -1}, {"speed_window": 65}, {"speed_confidence": 128}]
)
def test_out_of_range_is_a_clear_error(bad):
    with pytest.raises(PpalocError, match=next(iter(bad))):
        FilterParams.create("lbp", **bad)


def test_a_map_with_runs_counts_places():
    p = FilterParams.create("lbp")
    sched = RobustSchedule(p)
    sched.use_map(TopoMap("lbp", np.zeros(6, np.uint32), places=[0, 1, 1, 1, 2, 3]))
    assert [sched.place(i) for i in range(6)] == [0, 1, 1, 1, 2, 3]
    sched.use_map(TopoMap("lbp", np.zeros(6, np.uint32)))
    assert [sched.place(i) for i in range(6)] == list(range(6))


def _recording(loc: WeightedNodeLocaliser) -> list[tuple[int, ...]]:
    """The costs of every transition ``loc`` runs from now on."""
    seen: list[tuple[int, ...]] = []
    transition = loc.executor.transition
    loc.executor.transition = lambda costs: (seen.append(tuple(costs)), transition(costs))[1]
    return seen


def _twice_the_speed(route, speed_confidence: int, lane_speed: int = 0, **kw):
    """The toy route there and back as a map, a query at two places a frame, and a
    filter (window 4, no speed lane: the path's own speed) that records its transitions'
    costs."""
    reference = np.concatenate([route, route[::-1]])
    frames, truth = stepped(reference, (2,))
    loc = WeightedNodeLocaliser(
        "lowres",
        motion="always_forward",
        contrast=0,
        speed_window=4,
        speed_confidence=speed_confidence,
        lane_speed=lane_speed,
        slow_lane=False,
        **kw,
    )
    loc.build_map(reference)
    return loc, _recording(loc), frames, truth


def test_a_query_at_twice_the_speed_centres_the_costs_on_two_nodes(route):
    """Once the estimate has advanced two places a frame over ``speed_window`` forward
    frames, a forward frame's costs are centred on two (free), and the filter still
    follows the query."""
    loc, seen, frames, truth = _twice_the_speed(route, speed_confidence=0)
    got = np.array([e.node for e in loc.localise(frames)])
    assert np.abs(got - truth)[3:].max() <= 1
    one_a_frame = transition_costs(True, loc.params)
    # frames 2-6 know fewer than 4 + 1 forward estimates after the first frame
    assert seen[:5] == [one_a_frame] * 5
    assert seen[5] == seen[-1] == (8, 4, 0, 4)


def test_the_gate_waits_for_a_sure_path(route):
    """With a gate, the same query's costs stay those of one node a frame until the
    estimate's confidence has reached it at both ends of the window and between them
    (this toy route's confidence grows from 0 to about 20 units over ten frames)."""
    # the margin reported (no concentration), so the frames' scores are what the gate reads
    loc, seen, frames, _ = _twice_the_speed(route, speed_confidence=8, concentration_radius=0)
    scores = [e.score for e in loc.localise(frames)]
    one_a_frame = transition_costs(True, loc.params)
    # the first window of five estimates (after the first frame's) all at the gate
    first = next(i for i in range(5, len(scores)) if min(scores[i - 4 : i + 1]) >= 8)
    assert first > 5  # later than without the gate (test above)
    # seen[k] is the transition of frame k + 2, which reads the estimates up to frame k + 1
    assert seen[:first] == [one_a_frame] * first
    assert seen[first] != one_a_frame and seen[-1] == (8, 4, 0, 4)


def test_the_path_is_cleared_with_the_query(route):
    loc = WeightedNodeLocaliser("lowres", motion="always_forward", speed_window=2)
    loc.build_map(route)
    first = [e.node for e in loc.localise(route[::2])]
    assert loc.schedule.path
    loc.reset()
    assert loc.schedule.path == ()
    assert [e.node for e in loc.localise(route[::2])] == first


def test_on_a_map_with_runs_the_path_is_counted_in_places(route):
    """A stop of the reference is a run of nodes of one place, which the estimate may
    cross in one frame: the path's speed counts places, not nodes."""
    reference = np.concatenate([route[:5], np.repeat(route[5:6], 6, axis=0), route[6:]])
    places = np.concatenate([np.arange(5), np.full(6, 5), np.arange(6, len(route))])
    loc = WeightedNodeLocaliser(
        "lowres",
        keyframes=False,
        motion="always_forward",
        speed_window=8,
        speed_confidence=0,
        concentration_radius=0,  # the margin reported: what the path records
    )
    m = loc.build_map(reference)
    loc.use_map(TopoMap(m.kind, m.descriptors, m.frame_index, places=places, params=m.params))
    ests = loc.localise(route)
    forward = [(int(places[e.node]), e.score) for e in ests[1:] if e.moved]
    assert loc.schedule.path == tuple(forward[-9:])
    assert [p for p, _ in loc.schedule.path] != [e.node for e in ests[1:] if e.moved][-9:]


def test_the_lane_gives_its_speed_where_the_path_shows_none(route):
    """The same query at two places a frame with a gate the lagging filter passes late
    (16 units): without a lane its costs centre on two at frame 17, after the estimate
    fell up to 3 places behind; the lane (costs at two from the start) passes the gate
    first, and its speed centres the filter's costs from frame 6 on, the estimate never
    off. Break ``lane_speed_taken`` (take nothing) and the two runs are the same."""
    centred = transition_costs(True, FilterParams.create("lowres"), PathSpeed(2, 1))
    runs = {}
    for lane in (0, 2):
        loc, seen, frames, truth = _twice_the_speed(route, 16, lane_speed=lane)
        off = np.abs(np.array([e.node for e in loc.localise(frames)]) - truth)
        runs[lane] = (off.max(), seen.index(centred), loc.schedule.lane_frames)
    assert runs[0] == (3, 17, 0)
    assert runs[2][0] == 0 and runs[2][1] < 10 and runs[2][2] > 0


def test_at_the_maps_pace_the_lane_takes_nothing(route):
    """At one place a frame the lane's path is never above the filter's own range: the
    estimates and confidences equal those without a lane."""
    out = []
    for lane in (0, 2):
        loc = WeightedNodeLocaliser("lowres", motion="always_forward", contrast=0, lane_speed=lane)
        loc.build_map(route)
        out.append([(e.node, e.score) for e in loc.localise(route)])
        assert loc.schedule.lane_frames == 0
    assert out[0] == out[1]


def test_the_lane_is_checked_against_the_filter():
    assert FilterParams.create("lbp").lane_speed == 2
    assert FilterParams.create("lbp", max_advance=1).lane_speed == 0  # no room: off
    assert FilterParams.create("lbp", preset="paper").lane_speed is None
    with pytest.raises(PpalocError, match=r"^lane_speed=1 is the filter's own speed"):
        FilterParams.create("lbp", lane_speed=1)
    with pytest.raises(PpalocError, match=r"^lane_speed=3 is above max_advance=2"):
        FilterParams.create("lbp", lane_speed=3, max_advance=2)
    with pytest.raises(PpalocError, match="lane_speed"):
        FilterParams.create("lbp", lane_speed=4)


def test_a_schedule_without_its_lanes_says_so(route):
    """A robust schedule run on an executor with no lanes handed over is an error naming
    the remedy, never a filter that silently runs without them; so is a wrong count."""
    loc = WeightedNodeLocaliser("lowres", motion="always_forward")
    loc.build_map(route)
    with pytest.raises(PpalocError, match=r"^3 speed lanes \(lane_speeds\) run on as many"):
        loc.schedule.use_lanes(loc.schedule.lanes[:1])
    schedule = RobustSchedule(loc.params)
    schedule.use_map(loc.topomap)
    with pytest.raises(PpalocError, match=r"runs 3 speed lane\(s\).*use_lanes\(\.\.\.\)"):
        schedule.step(loc.executor, route[0])


def test_the_fastest_sure_lane_gives_the_speed():
    """Lanes at 2 and 3/2 (the defaults): the filter takes the faster lane's path speed
    where it passes the gate and is above the filter's own range, else the slower's."""
    schedule = RobustSchedule(FilterParams.create("lowres", slow_lane=False))
    fast, slow = schedule.lane_schedules
    assert (fast.centre, slow.centre) == (PathSpeed(2, 1), PathSpeed(3, 2))

    def record(lane, speed, score):  # a path at ``speed`` over speed_window = 8 frames
        places = [int(speed * i) for i in range(9)]
        lane._path_places, lane._path_scores = places, [score] * 9

    record(fast, 2, 10)  # not sure (below speed_confidence 32)
    record(slow, 1.5, 40)  # 12 places over 8 frames: 3/2, the top of the filter's own
    assert schedule.lane_speed() == PathSpeed(12, 8)
    record(fast, 2, 40)
    assert schedule.lane_speed() == PathSpeed(16, 8)
    record(fast, 1, 40)  # sure, but at one place a frame: the filter's own speed
    assert schedule.lane_speed() == PathSpeed(12, 8)
    record(slow, 1.25, 40)
    assert schedule.lane_speed() is None


def test_a_lanes_path_passes_its_own_gate():
    """A lane's path gives its speed where each of its estimates is sure by
    ``lane_confidence`` (24), a lower bar than the filter's own ``speed_confidence``
    (32), which the same path does not pass."""
    params = FilterParams.create("lowres", slow_lane=False)
    schedule = RobustSchedule(params)
    fast = schedule.lane_schedules[0]
    fast._path_places, fast._path_scores = [2 * i for i in range(9)], [28] * 9
    assert schedule.lane_speed() == PathSpeed(16, 8)
    assert fast.path_speed() is None  # the filter's own gate at 32
    strict = RobustSchedule(FilterParams.create("lowres", slow_lane=False, lane_confidence=32))
    lane = strict.lane_schedules[0]
    lane._path_places, lane._path_scores = fast._path_places, fast._path_scores
    assert strict.lane_speed() is None
    fast._path_scores = [28] * 8 + [23]  # one estimate below the lane's gate
    assert schedule.lane_speed() is None


def test_the_surest_lane_hands_its_speed_over_on_its_lead():
    """Where no path passes its gate, the surest of the lanes faster than the map gives
    its path's speed (no confidence asked of the path) where its confidence reaches
    ``lane_confidence`` (24), leads the filter's last by ``lane_speed_lead`` and its
    place is at most ``confidence_radius`` (10) ahead of the filter's; not the slow
    lane, nor where that lane's path stalled, nor from a lane whose path shows the
    filter's own speed."""
    params = FilterParams.create("lowres", lane_speed_lead=16)
    schedule = RobustSchedule(params)
    fast, mid, slow = schedule.lane_schedules  # at 2, 3/2 and 1/2

    def frame(own, scores, places=(44, 43, 38)):  # the filter's last confidence at 40
        schedule._path_places, schedule._path_scores = [40], [own]
        schedule._lane_results = [
            FrameResult(node, score, True, 0.0) for node, score in zip(places, scores, strict=True)
        ]

    fast._path_places, fast._path_scores = [2 * i for i in range(9)], [10] * 9  # unsure
    mid._path_places, mid._path_scores = [3 * i // 2 for i in range(9)], [10] * 9
    slow._path_places, slow._path_scores = [i // 2 for i in range(2, 11)], [10] * 9
    frame(4.0, (30.0, 12.0, 0.0))
    assert schedule.lane_speed() == PathSpeed(16, 8)  # 30 >= 24 and 30 >= 4 + 16
    frame(15.0, (30.0, 12.0, 0.0))
    assert schedule.lane_speed() is None  # a lead of 15
    frame(0.0, (23.5, 12.0, 0.0))
    assert schedule.lane_speed() is None  # below lane_confidence
    frame(0.0, (12.0, 30.0, 0.0))
    assert schedule.lane_speed() == PathSpeed(12, 8)  # the surest: the lane at 3/2
    frame(0.0, (30.0, 30.0, 0.0))
    assert schedule.lane_speed() == PathSpeed(16, 8)  # the first of equals, fastest first
    frame(0.0, (30.0, 12.0, 0.0), places=(51, 43, 38))
    assert schedule.lane_speed() is None  # 11 places ahead: beyond the radius
    frame(0.0, (30.0, 12.0, 0.0), places=(39, 43, 38))
    assert schedule.lane_speed() is None  # a faster lane behind the filter
    frame(0.0, (0.0, 12.0, 30.0))
    assert schedule.lane_speed() is None  # the slow lane leads: its path's gate only
    frame(0.0, (26.0, 12.0, 30.0))
    assert schedule.lane_speed() == PathSpeed(16, 8)  # the surest of the faster lanes
    fast._path_places = [8] * 9  # the surest lane's path stalled: no speed at all
    frame(4.0, (30.0, 12.0, 0.0))
    assert schedule.lane_speed() is None
    fast._path_places = list(range(9))  # one place a frame: the filter's own speed
    assert schedule.lane_speed() is None
    off = RobustSchedule(FilterParams.create("lowres", lane_speed_lead=0))
    off.lane_schedules[0]._path_places = [2 * i for i in range(9)]
    off.lane_schedules[0]._path_scores = [10] * 9
    off._path_places, off._path_scores = [40], [0.0]
    off._lane_results = [FrameResult(44, 90.0, True, 0.0)] * 3
    assert off.lane_speed() is None


def test_the_lanes_share_the_frames_distance_work(route, monkeypatch):
    """The speed lanes read the filter's distances, local term and likelihood term of
    the frame: each is computed once a frame, whatever the number of lanes."""
    import ppaloc.localise.host as host

    calls = []
    closer = host.closer_count
    monkeypatch.setattr(host, "closer_count", lambda *a: (calls.append(1), closer(*a))[1])
    loc = WeightedNodeLocaliser("lowres", motion="always_forward", lanes=2)
    loc.build_map(route)
    assert len(loc.schedule.lanes) == 3
    loc.localise(route[:5])
    assert len(calls) == 5


def test_the_slow_lane_gives_its_speed_unless_its_path_stalled():
    """The lane at 1/2 (``slow_lane``): its path speed is taken where it is at or below
    the bottom of the filter's own range (1/2), not where its path held one place over
    ``lost_window`` forward frames (a stall, not a slow query)."""
    schedule = RobustSchedule(FilterParams.create("lowres"))
    assert [lane.centre for lane in schedule.lane_schedules][-1] == PathSpeed(1, 2)
    slow = schedule.lane_schedules[-1]
    slow._path_places, slow._path_scores = [i // 2 for i in range(2, 11)], [40] * 9
    assert schedule.lane_speed() == PathSpeed(4, 8)  # 4 places over 8 frames
    slow._path_places = [1, 2, 2, 2, 2, 3, 3, 3, 3]  # 2 over 8: slower, still moving
    assert schedule.lane_speed() == PathSpeed(1, 2)
    slow._path_places = [3] * 9  # stalled over lost_window = 8 forward frames
    assert schedule.lane_speed() is None
    slow._path_places = [0, 1, 1, 2, 3, 3, 4, 4, 5]  # 5/8: the filter's own range
    assert schedule.lane_speed() is None


def test_at_a_third_of_the_maps_pace_the_slow_lane_hands_its_speed_over(route):
    """The toy route there and back, a query at one place every three frames and a gate
    of 32 units: the slow lane's speed sets the costs of some forward frames where the
    filter's own path shows none, and the estimate stays within a place of the truth
    (as without the lane: this toy route is easy for the filter's own path)."""
    reference = np.concatenate([route, route[::-1]])
    idx = np.arange(0, len(reference) * 3) // 3
    taken = {}
    for slow in (False, True):
        loc = WeightedNodeLocaliser(
            "lowres",
            motion="always_forward",
            contrast=0,
            speed_window=4,
            speed_confidence=32,
            lane_speed=0,
            slow_lane=slow,
        )
        loc.build_map(reference)
        nodes = np.array([e.node for e in loc.localise(reference[idx])])
        assert np.abs(nodes - idx).max() <= 1
        taken[slow] = loc.schedule.lane_frames
    assert taken[False] == 0 and taken[True] > 0


def test_the_lanes_share_the_maps_nodes(route):
    """Each lane's executor holds the filter's map nodes, not a copy of them (a large
    map is normalised and indexed once), with an output buffer of its own."""
    loc = WeightedNodeLocaliser("lowres", motion="always_forward")
    loc.build_map(route)
    source = loc.executor._distances
    for lane in loc.schedule.lanes:
        assert lane._distances._index is source._index
        assert lane._distances.out is not source.out


def test_a_lane_whose_confidence_leads_reports_its_estimate():
    """Where a speed lane's confidence leads the filter's by ``lane_lead``, the frame
    reports the lane's estimate and confidence, and the ranking starts with it; the
    filter's own weights go on as they would (the same weights with the rule off)."""
    rng = np.random.default_rng(54)  # a case the written-out contract keeps as an example
    nodes = rng.integers(0, 256, (8, 8, 8), dtype=np.uint8)
    frames = rng.integers(0, 256, (9, 256, 256), dtype=np.uint8)
    moves = rng.random(9) < 0.7
    frame_index = np.cumsum(rng.integers(1, 3, 8)) - 1
    kw = dict(
        arithmetic="ppa8", motion="oracle", oracle_moves=moves, record_weights=True,
        gain=16, memory=64, stay_cost=4, move_cost=0, skip_cost=4, max_advance=2,
        contrast=0, contrast_patch=2, local_gain=0, speed_window=2, speed_confidence=0,
        lost_window=0, speed_vary=0, still_decay=0, lanes=1, slow_lane=False,
        confidence_radius=1,
    )  # fmt: skip
    runs = {}
    for lead in (0, 8):
        loc = WeightedNodeLocaliser("lowres", lane_lead=lead, **kw)
        loc.use_map(TopoMap("lowres", nodes, frame_index=frame_index))
        runs[lead] = loc.localise(frames)
    own, reported = runs[0], runs[8]
    pairs = list(zip(own, reported, strict=True))
    lanes = [t for t, (a, b) in enumerate(pairs) if (a.node, a.score) != (b.node, b.score)]
    assert lanes  # the case reports a lane's estimate (here the same node, surer) on some frames
    for a, b in zip(own, reported, strict=True):
        np.testing.assert_array_equal(a.weights, b.weights)
        assert b.ranking[0] == b.node
        assert b.score == a.score or b.score >= a.score + 8
    assert all(reported[t].score >= own[t].score + 8 for t in lanes)
