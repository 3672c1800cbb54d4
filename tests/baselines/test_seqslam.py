"""SeqSLAM: contrast enhancement, trajectory search, past-only incrementality, lock-on."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.baselines.seqslam import (
    SeqSLAM,
    contrast_enhance,
    trajectory_costs,
    trajectory_offsets,
)
from ppaloc.errors import PpalocError
from ppaloc.topomap import TopoMap


def naive_enhance(d: np.ndarray, window: int) -> np.ndarray:
    n, half = len(d), window // 2
    out = np.empty(n)
    for i in range(n):
        v = d[max(0, i - half) : min(n, i + half + 1)]
        out[i] = (d[i] - v.mean()) / v.std(ddof=1)
    m = 2 * half + 1
    return out + (m - 1) / np.sqrt(m)


def test_contrast_enhance_matches_the_definition() -> None:
    d = np.random.default_rng(0).random((40, 3))
    got = contrast_enhance(d, 10)
    for j in range(3):
        np.testing.assert_allclose(got[:, j], naive_enhance(d[:, j], 10), atol=1e-9)
    np.testing.assert_allclose(contrast_enhance(d[:, 0], 10), got[:, 0])


def test_enhancement_runs_over_reference_rows_for_each_query_column(toy_route) -> None:
    # OpenSeqSLAM: D(i, j) = distance of reference i to query j; row i of the enhanced
    # matrix is D(i, :) minus the mean, over the std, of rows i - R/2 .. i + R/2, per
    # column. So a query's enhanced column depends on that query and the reference
    # neighbourhood only, never on the other query frames.
    ref, query = toy_route
    s = SeqSLAM()
    s.build_map(ref[:30])
    d = np.stack([s.difference_column(f) for f in query[:6]], axis=1)  # (30 refs, 6 queries)
    for j in range(6):
        np.testing.assert_allclose(
            s.enhanced_column(query[j]), naive_enhance(d[:, j], 10), atol=1e-9
        )
    # Enhancing along the query axis instead would give something else.
    assert not np.allclose(contrast_enhance(d.T, 10).T, contrast_enhance(d, 10))


def test_contrast_enhance_golden_and_switched_off() -> None:
    # window 2 -> neighbours +-1, full window m = 3, shift (m - 1) / sqrt(m) = 2 / sqrt(3).
    # d = [0, 3, 0]: node 0 sees [0, 3] -> z = -1.5 / sqrt(4.5); node 1 sees all three.
    d = np.array([0.0, 3.0, 0.0])
    z0 = (0 - 1.5) / np.sqrt(4.5)
    z1 = (3 - 1.0) / np.sqrt(3.0)
    expected = np.array([z0, z1, z0]) + 2 / np.sqrt(3)
    np.testing.assert_allclose(contrast_enhance(d, 2), expected)
    np.testing.assert_allclose(contrast_enhance(d + 2.0, 0), d + 2.0)


def test_contrast_enhance_is_never_negative() -> None:
    # The worst case for node 5: one low value among ten equal ones in its full window.
    d = np.ones(11)
    d[5] = 0.0
    out = contrast_enhance(d, 10)
    assert out[5] == pytest.approx(0.0, abs=1e-12)
    assert np.all(out >= -1e-12)


def test_trajectory_offsets_are_exact_floors_without_duplicates() -> None:
    off = trajectory_offsets(np.arange(-10, 1), np.array([0.8, 0.9, 1.0, 1.1, 1.2]))
    assert off.shape == (5, 11)
    assert sorted(off[:, 0].tolist()) == [-12, -11, -10, -9, -8]
    assert np.all(off[:, -1] == 0)
    # -3 * 0.7 = -2.1 -> -3 ; -10 * 0.7 is exactly -7 (not -8 from rounding error).
    np.testing.assert_array_equal(
        trajectory_offsets(np.array([-10, -3]), np.array([0.7])), [[-7, -3]]
    )
    # With one column every velocity gives the same trajectory.
    assert trajectory_offsets(np.array([0]), np.array([0.8, 1.0])).shape == (1, 1)


def test_trajectory_costs_match_a_naive_search() -> None:
    rng = np.random.default_rng(1)
    cols = rng.random((4, 12))
    rel = np.arange(-3, 1)
    offsets = trajectory_offsets(rel, np.array([0.5, 1.0, 1.5]))
    expected = np.full(12, np.inf)
    for e in range(12):
        for row in offsets:
            nodes = e + row
            if nodes.min() < 0 or nodes.max() > 11:
                continue
            expected[e] = min(expected[e], sum(cols[k, nodes[k]] for k in range(4)))
    np.testing.assert_allclose(trajectory_costs(cols, offsets), expected)


def test_locks_on_the_toy_route(toy_route) -> None:
    ref, query = toy_route
    s = SeqSLAM()
    s.build_map(ref)
    nodes = np.array([s.step(f).node for f in query])
    truth = np.arange(10, 50)
    assert np.mean(np.abs(nodes[3:] - truth[3:]) <= 1) >= 0.95


def test_past_only_step_equals_batch_and_ignores_the_future(toy_route) -> None:
    ref, query = toy_route
    s = SeqSLAM(record_weights=True)
    s.build_map(ref)
    online = [s.step(f) for f in query]
    batch = s.localise_sequence(query)
    assert [e.node for e in online] == [e.node for e in batch]
    np.testing.assert_allclose([e.score for e in online], [e.score for e in batch], atol=1e-9)
    np.testing.assert_allclose(online[-1].weights, batch[-1].weights, atol=1e-9)
    # Replacing the future by other frames changes nothing up to the cut.
    cut = 25
    other = np.concatenate([query[:cut], query[::-1][: len(query) - cut]])
    altered = s.localise_sequence(other)
    assert [e.node for e in altered[:cut]] == [e.node for e in batch[:cut]]
    np.testing.assert_allclose([e.score for e in altered[:cut]], [e.score for e in batch[:cut]])


def test_centred_mode_runs_offline_and_refuses_step(toy_route) -> None:
    ref, query = toy_route
    s = SeqSLAM(mode="centred")
    s.build_map(ref)
    assert s.ds == 10
    nodes = np.array([e.node for e in s.localise_sequence(query)])
    assert np.mean(np.abs(nodes - np.arange(10, 50)) <= 1) >= 0.95
    with pytest.raises(PpalocError, match=r"mode='centred' needs ds/2 future frames"):
        s.step(query[0])
    assert SeqSLAM(mode="centred", ds=9).ds == 10


def test_confidence_is_higher_on_the_route_than_off_it(toy_route) -> None:
    ref, query = toy_route
    s = SeqSLAM()
    s.build_map(ref[10:50])
    on = [s.step(f).score for f in query][10:]
    s.reset()
    off_route = np.random.default_rng(9).integers(0, 256, (30, 256, 256), dtype=np.uint8)
    off = [s.step(f).score for f in off_route][10:]
    assert min(on) > max(off)
    assert all(0.0 <= x <= 1.0 for x in on + off)


def test_ranking_starts_with_the_estimate(toy_route) -> None:
    ref, query = toy_route
    s = SeqSLAM(top_k=5)
    s.build_map(ref)
    e = [s.step(f) for f in query[:12]][-1]
    assert e.ranking[0] == e.node and len(e.ranking) == 5


def test_user_errors_name_the_fix(toy_route) -> None:
    ref, _ = toy_route
    with pytest.raises(PpalocError, match="mode='forward' is unknown; choose 'past' or 'centred'"):
        SeqSLAM(mode="forward")
    with pytest.raises(PpalocError, match="no map yet; call build_map"):
        SeqSLAM().step(ref[0])
    with pytest.raises(
        PpalocError,
        match=r"cannot use a map of kind 'lowres'; it needs kind 'seqslam' "
        r"\(build one with `ppaloc map SPEC --method seqslam`",
    ):
        SeqSLAM().use_map(TopoMap("lowres", np.zeros((3, 8, 8), np.uint8)))
    m = SeqSLAM().build_map(ref[:5])
    with pytest.raises(PpalocError, match=r"shape \(32, 64\) but these parameters give \(16, 32\)"):
        SeqSLAM(size=(16, 32)).use_map(m)
    with pytest.raises(PpalocError, match="reference traversal is empty"):
        SeqSLAM().build_map([])


def test_window_costs_count_missing_frames_at_the_expected_cost() -> None:
    # ds = 2 (3-frame windows), one velocity (1 node a frame), 4 nodes. Two columns exist
    # (frames t-1, t), medians 2 and 4: frame t-2 is missing and costs their mean, 3.
    s = SeqSLAM(ds=2, vmin=1.0, vmax=1.0)
    cols = np.array([[1.0, 2.0, 2.0, 9.0], [4.0, 0.0, 4.0, 5.0]])
    fills = np.array([2.0, 4.0])
    # node 0: (off the map at t-1: 2) + 4 + 3; node 1: 1 + 0 + 3; node 2: 2 + 4 + 3; ...
    np.testing.assert_allclose(s.window_costs(cols, fills, -1), [9.0, 4.0, 9.0, 10.0])
    cut = SeqSLAM(ds=2, vmin=1.0, vmax=1.0, edges="cut")
    np.testing.assert_allclose(cut.window_costs(cols, fills, -1), [np.inf, 1.0, 6.0, 7.0])
    # The same columns as frames t, t+1 of a centred window at the first query frame:
    # frame t-1 does not exist (3), and node 3's line leaves the map at t+1 (4).
    np.testing.assert_allclose(s.window_costs(cols, fills, 0), [4.0, 9.0, 10.0, 16.0])


def test_a_short_sequence_is_not_surer_than_a_full_one(toy_route) -> None:
    # With the frames before the start of the query counted at their expected cost, the
    # first (one-frame) estimates are much less sure than those of full sequences; summed
    # over the frames that exist (OpenSeqSLAM's cut), the first frame looked as sure.
    ref, query = toy_route
    scores = {}
    for edges in ("expected", "cut"):
        s = SeqSLAM(edges=edges)
        s.build_map(ref)
        scores[edges] = np.array([s.step(f).score for f in query])
    full = scores["expected"][11:]
    assert scores["expected"][0] < 0.25 * np.median(full)
    assert np.all(np.diff(scores["expected"][:6]) > 0)  # surer with every frame seen
    assert scores["cut"][0] > 0.5 * np.median(scores["cut"][11:])


def test_nodes_at_the_start_of_the_map_stay_reachable(toy_route) -> None:
    # The query starts 5 frames before the map does, then drives along it: at frames
    # 10-12 it is at places 5-7, where every line of 11 frames at 0.8-1.2 nodes a frame
    # leaves the map. OpenSeqSLAM's inf makes those places unreachable; at the expected cost
    # they are found.
    ref, _ = toy_route
    rng = np.random.default_rng(5)
    before = rng.integers(0, 256, (5, 256, 256), dtype=np.uint8)
    walk = np.clip(ref[:20] * 0.7 + rng.normal(0.0, 25.0, ref[:20].shape), 0, 255)
    query = np.concatenate([before, walk.astype(np.uint8)])
    for edges, found in (("expected", True), ("cut", False)):
        s = SeqSLAM(edges=edges)
        s.build_map(ref)
        nodes = [s.step(f).node for f in query]
        assert (nodes[10:13] == [5, 6, 7]) is found


def test_centred_step_reads_ahead_and_equals_the_batch(toy_route) -> None:
    ref, query = toy_route
    s = SeqSLAM(mode="centred", record_weights=True)
    s.build_map(ref)
    assert s.reads_future and not SeqSLAM().reads_future
    batch = s.localise_sequence(query)
    s.read_ahead(query)
    online = [s.step(f) for f in query]
    assert [e.node for e in online] == [e.node for e in batch]
    np.testing.assert_allclose([e.score for e in online], [e.score for e in batch], atol=1e-9)
    np.testing.assert_allclose(online[20].weights, batch[20].weights, atol=1e-9)
    # The centred window reads ahead: replacing frames after t changes the estimate at t.
    other = np.concatenate([query[:25], query[::-1][:15]])
    altered = s.localise_sequence(other)
    assert [e.score for e in altered[20:25]] != [e.score for e in batch[20:25]]
    with pytest.raises(PpalocError, match="read_ahead was given 40 frames"):
        s.step(query[0])
    s.read_ahead(query)
    with pytest.raises(PpalocError, match="step got a frame other than frame 0 of the query"):
        s.step(query[5])
    with pytest.raises(PpalocError, match="mode='past' reads no future frame"):
        SeqSLAM().read_ahead(query)


def test_speed_range_is_the_velocities_searched() -> None:
    assert SeqSLAM().speed_range == (0.8, 1.2)
    assert SeqSLAM(vmin=0.5, vmax=2.0, vstep=0.5).speed_range == (0.5, 2.0)
    with pytest.raises(PpalocError, match="edges='none' is unknown; choose 'expected' or 'cut'"):
        SeqSLAM(edges="none")
