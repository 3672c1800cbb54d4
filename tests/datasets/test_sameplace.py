"""Same-place groups: the still-frames rule, the positions rule and the closure."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image

from ppaloc.datasets.frames import ImageFrames, RenderedFrames
from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.datasets.route import RawRoute, assemble
from ppaloc.datasets.sameplace import (
    STILL_FRAMES,
    close_over_groups,
    close_over_query_groups,
    group_labels,
    position_groups,
    still_groups,
    thumbnail,
    thumbnails,
)
from ppaloc.errors import DataError


def _scene(seed: int, shape=(48, 64)) -> np.ndarray:
    """A smooth grey scene (mean near 128, deviation near 50): seen by the rule."""
    coarse = np.random.default_rng(seed).uniform(0, 255, (4, 6)).astype(np.float32)
    big = Image.fromarray(coarse, mode="F").resize(shape[::-1], Image.Resampling.BILINEAR)
    return np.asarray(big).clip(0, 255).astype(np.uint8)


A, B, C = _scene(1), _scene(2), _scene(3)
DARK = (_scene(5) // 4).astype(np.uint8)  # a lit tunnel wall: deviation 12.6, mean 31 < 40
BLANK = np.zeros_like(A)


def test_still_groups_golden():
    # 0-2 one scene standing; 3 moving; 4-5 dark and still (not a place); 6 blank;
    # 7-8 blank and still (not a place); 9-11 another scene standing; 12 alone
    frames = [A, A, A, B, DARK, DARK, BLANK, BLANK, BLANK, C, C, C, B]
    assert still_groups(thumbnail(f) for f in frames).tolist() == [[0, 3], [9, 12]]


def test_small_changes_stay_one_place_and_a_creep_splits():
    noisy = [np.clip(A + np.random.default_rng(k).normal(0, 2, A.shape), 0, 255) for k in range(4)]
    frames = [f.astype(np.uint8) for f in noisy]
    assert still_groups(thumbnail(f) for f in frames).tolist() == [[0, 4]]
    # a 512-pixel view creeping 1 pixel a frame along a wide scene: consecutive frames
    # alike, the view drifts; the span splits it where chaining steps would make one place
    coarse = np.random.default_rng(1).uniform(0, 255, (4, 12)).astype(np.float32)
    wide = Image.fromarray(coarse, mode="F").resize((2048, 96), Image.Resampling.BILINEAR)
    scene = np.asarray(wide).clip(0, 255).astype(np.uint8)
    thumbs = [thumbnail(scene[:, k : k + 512]) for k in range(60)]
    steps = [float(np.abs(_z(a) - _z(b)).mean()) for a, b in itertools.pairwise(thumbs)]
    assert max(steps) <= STILL_FRAMES.max_step
    groups = still_groups(thumbs)
    assert groups.tolist() == [[0, 17], [17, 33], [33, 49], [49, 60]]
    for a, b in groups:  # every frame within max_span of its group's first
        assert all(
            np.abs(_z(thumbs[k]) - _z(thumbs[a])).mean() <= STILL_FRAMES.max_span
            for k in range(a, b)
        )


def _z(t: np.ndarray) -> np.ndarray:
    t = t.astype(np.float64)
    return (t - t.mean()) / t.std()


def test_thumbnails_do_not_depend_on_the_frame_size():
    big = np.asarray(Image.fromarray(A).resize((640, 480), Image.Resampling.BILINEAR))
    np.testing.assert_allclose(thumbnail(big), thumbnail(A), atol=1.5)
    assert still_groups(thumbnail(f) for f in [big, big, A, A]).tolist() == [[0, 4]]


def test_jpeg_thumbnails_read_reduced_match_a_full_decode(tmp_path):
    big = np.asarray(Image.fromarray(_scene(5)).resize((963, 541), Image.Resampling.BILINEAR))
    paths = []
    for k in range(3):
        p = tmp_path / f"f{k}.jpg"
        Image.fromarray(big).save(p, quality=90)
        paths.append(p)
    reduced = list(thumbnails(ImageFrames(paths)))
    full = [thumbnail(f) for f in ImageFrames(paths)]
    assert np.abs(reduced[0] - full[0]).mean() < 0.5
    assert still_groups(reduced).tolist() == still_groups(full).tolist() == [[0, 3]]


def test_thumbnails_read_each_frame_once_in_order():
    reads = []

    def render(i):
        reads.append(i)
        return A

    seq = RenderedFrames(render, 50, cache=0)
    assert still_groups(thumbnails(seq)).tolist() == [[0, 50]]
    assert reads == list(range(50))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(["A", "B", "C", "dark", "blank"]), max_size=30))
def test_groups_are_disjoint_runs_of_seen_frames(names):
    pick = {"A": A, "B": B, "C": C, "dark": DARK, "blank": BLANK}
    thumbs = [thumbnail(pick[n]) for n in names]
    groups = still_groups(thumbs)
    flat = groups.ravel().tolist()
    assert flat == sorted(flat) and all(b - a >= 2 for a, b in groups)
    for a, b in groups:
        assert len({names[k] for k in range(a, b)}) == 1
        assert names[a] in "ABC"
    # every run of one seen scene is one group, exactly
    runs = []
    k = 0
    while k < len(names):
        j = k
        while j < len(names) and names[j] == names[k]:
            j += 1
        if names[k] in "ABC" and j - k >= 2:
            runs.append([k, j])
        k = j
    assert groups.tolist() == runs


def test_position_groups_golden():
    p = np.array([[0, 0], [0.4, 0], [0.9, 0], [1.2, 0], [5, 0], [9, 0], [9, 0.2]], float)
    assert position_groups(p, 1.0).tolist() == [[0, 3], [5, 7]]
    assert position_groups(p, 0.0).tolist() == []
    assert position_groups(np.zeros((0, 2)), 1.0).shape == (0, 2)


def test_group_labels_and_closure_golden():
    groups = np.array([[2, 5], [7, 9]])
    assert group_labels(groups, 10).tolist() == [-1, -1, 0, 0, 0, -1, -1, 1, 1, -1]
    sets = PackedSets.from_sets([[0, 1], [1, 2], [4], [], [5, 6], [8, 9]]).with_soft(
        [[0, 1], [1, 2], [4, 5, 6, 7], [3], [5, 6], [8, 9]]
    )
    closed = close_over_groups(sets, groups, 10)
    assert [r.tolist() for r in closed] == [
        [0, 1], [1, 2, 3, 4], [2, 3, 4], [], [5, 6], [7, 8, 9]
    ]  # fmt: skip
    assert [r.tolist() for r in closed.soft] == [
        [0, 1], [1, 2, 3, 4], [2, 3, 4, 5, 6, 7, 8], [2, 3, 4], [5, 6], [7, 8, 9]
    ]  # fmt: skip


@settings(max_examples=80, deadline=None)
@given(st.data())
def test_closure_matches_a_slow_reference(data):
    n = data.draw(st.integers(1, 25))
    cuts = sorted(data.draw(st.sets(st.integers(0, n), max_size=8)))
    groups = np.array(
        [[a, b] for a, b in zip(cuts[::2], cuts[1::2], strict=False) if b - a >= 2]
    ).reshape(-1, 2)
    sets = data.draw(st.lists(st.sets(st.integers(0, n - 1), max_size=5), max_size=8))
    closed = close_over_groups([sorted(s) for s in sets], groups, n)
    for s, got in zip(sets, closed, strict=True):
        want = set(s)
        for a, b in groups:
            if want & set(range(a, b)):
                want |= set(range(a, b))
        assert got.tolist() == sorted(want)
    again = close_over_groups(closed, groups, n)  # closing twice changes nothing
    assert [r.tolist() for r in again] == [r.tolist() for r in closed]


def _groups_from(cuts: list[int]) -> np.ndarray:
    pairs = [[a, b] for a, b in zip(cuts[::2], cuts[1::2], strict=False) if b - a >= 2]
    return np.array(pairs, dtype=np.int64).reshape(-1, 2)


@settings(max_examples=80, deadline=None)
@given(st.data())
def test_query_closure_matches_a_slow_reference(data):
    m = data.draw(st.integers(1, 12))
    groups = _groups_from(sorted(data.draw(st.sets(st.integers(0, m), max_size=6))))
    hard = data.draw(st.lists(st.sets(st.integers(0, 9), max_size=4), min_size=m, max_size=m))
    extra = data.draw(st.lists(st.sets(st.integers(0, 9), max_size=2), min_size=m, max_size=m))
    soft = [h | e for h, e in zip(hard, extra, strict=True)]
    sets = PackedSets.from_sets([sorted(h) for h in hard]).with_soft([sorted(x) for x in soft])
    closed = close_over_query_groups(sets, groups)
    for got, rows in ((closed, hard), (closed.soft, soft)):
        want = [set(r) for r in rows]
        for a, b in groups:
            union = set().union(*rows[a:b])
            want[a:b] = [union] * (b - a)
        assert [r.tolist() for r in got] == [sorted(w) for w in want]
    for h, x in zip(closed, closed.soft, strict=True):  # a soft set still holds its hard set
        assert set(h.tolist()) <= set(x.tolist())


def test_the_query_closure_is_bounded(monkeypatch):
    from ppaloc.datasets import sameplace

    monkeypatch.setattr(sameplace, "MAX_GROUND_TRUTH_ITEMS", 8)
    sets = PackedSets.from_sets([[0], [1, 2], [3], [4]])
    assert close_over_query_groups(sets, np.array([[0, 2]])).indices.size == 8

    def no_large_arrays(*args, **kwargs):
        raise AssertionError("the closed sets were built before the bound was checked")

    monkeypatch.setattr(sameplace.np, "tile", no_large_arrays)
    with pytest.raises(DataError, match=r"query's same-place groups would accept 13 \(query, "
                       r"reference\) pairs, more than 8; .* \(same_place=off\)"):  # fmt: skip
        close_over_query_groups(sets, np.array([[0, 3]]))


def _route(frames, *, places=None, accepted=None, truth=None, query=None) -> RawRoute:
    n = len(frames)
    query = frames if query is None else query
    return RawRoute(
        name="t",
        reference=RenderedFrames(lambda i: frames[i], n),
        query=RenderedFrames(lambda i: query[i], len(query) if places is None else len(places)),
        default_tolerance=0,
        query_place=None if places is None else np.asarray(places, float),
        accepted=accepted,
        truth=truth or {"source": "index"},
    )


FRAMES = [A, B, B, B, C, DARK, DARK, A]


def test_assemble_closes_positional_truth_and_records_the_rule():
    ds = assemble(_route(FRAMES, places=range(8)), {"tolerance": 0})
    assert [g.tolist() for g in ds.ground_truth] == [
        [0], [1, 2, 3], [1, 2, 3], [1, 2, 3], [4], [5], [6], [7]
    ]  # fmt: skip
    assert ds.reference_groups.tolist() == [[1, 4]]
    rule = ds.meta["ground_truth_rule"]
    assert rule == {
        "kind": "frames",
        "source": "index",
        "tolerance": 0,
        "tolerance_unit": "frames",
        "same_place": {
            "rule": "still-frames",
            "params": {
                "thumbnail": 16, "min_mean": 40.0, "min_std": 8.0, "max_step": 0.05,
                "max_span": 0.15,
            },
            "groups": 1,
            "grouped_frames": 3,
            "query_groups": 1,
            "query_grouped_frames": 3,
            "queries_changed": 3,
        },
    }  # fmt: skip
    assert ds.query_groups.tolist() == [[1, 4]]
    again = assemble(_route(FRAMES, places=range(8)), {"tolerance": 0})
    assert json.dumps(again.meta["ground_truth_rule"]) == json.dumps(rule)


def test_a_query_standing_longer_than_the_reference_accepts_the_place_it_stands_at():
    # the reference stands at B for frames 1-2 and moves on to C; the query stands at B
    # for frames 1-3: by index its frame 3 is at C, but it still shows B
    E = _scene(4)
    ref, query = [A, B, B, C, E, A], [A, B, B, B, C, E]
    ds = assemble(_route(ref, places=range(6), query=query), {"tolerance": 0})
    assert ds.reference_groups.tolist() == [[1, 3]] and ds.query_groups.tolist() == [[1, 4]]
    assert [g.tolist() for g in ds.ground_truth] == [
        [0], [1, 2, 3], [1, 2, 3], [1, 2, 3], [4], [5]
    ]  # fmt: skip
    assert ds.meta["ground_truth_rule"]["same_place"]["queries_changed"] == 3
    off = assemble(_route(ref, places=range(6), query=query), {"same_place": "off"})
    assert off.query_groups is None and off.ground_truth[3].tolist() == [3]
    # the rule before the query's stops were read: the reference's groups alone
    alone = assemble(
        _route(ref, places=range(6), query=query),
        {"tolerance": 0, "same_place": "reference-images"},
    )
    assert alone.query_groups is None and alone.reference_groups.tolist() == [[1, 3]]
    assert [g.tolist() for g in alone.ground_truth] == [[0], [1, 2], [1, 2], [3], [4], [5]]
    rule = alone.meta["ground_truth_rule"]["same_place"]
    assert (rule["traversals"], rule["queries_changed"]) == ("reference", 2)
    assert "query_groups" not in rule


def test_the_positions_rule_leaves_the_query_to_its_positions():
    E = _scene(4)
    ref, query = [A, B, B, C, E, A], [A, B, B, B, C, E]
    raw = _route(ref, places=range(6), query=query)
    raw.reference_positions = np.array([[0, 0], [5, 0], [5, 0], [10, 0], [15, 0], [20, 0]], float)
    ds = assemble(raw, {"tolerance": 0, "same_place": "positions"})
    assert ds.query_groups is None and ds.ground_truth[3].tolist() == [3]
    assert ds.ground_truth[1].tolist() == [1, 2]


def test_tolerance_then_closure_and_the_switch():
    ds = assemble(_route(FRAMES, places=range(8)), {"tolerance": 1})
    assert ds.ground_truth[0].tolist() == [0, 1, 2, 3]  # frame 1 within tolerance: its group
    off = assemble(_route(FRAMES, places=range(8)), {"tolerance": 1, "same_place": "off"})
    assert off.ground_truth[0].tolist() == [0, 1]
    assert off.reference_groups is None
    assert off.meta["ground_truth_rule"]["same_place"] == {
        "rule": "off", "reason": "same_place=off"
    }  # fmt: skip


def test_groups_are_found_on_the_kept_reference_frames():
    ds = assemble(_route(FRAMES, places=range(8)), {"tolerance": 0, "start": 2, "stop": 8})
    assert ds.reference_groups.tolist() == [[0, 2]]  # frames 2, 3 of the original
    assert ds.ground_truth[0].tolist() == [0, 1]


def test_explicit_sets_are_the_files_word_unless_asked():
    sets = [np.array([k]) for k in range(8)]
    ds = assemble(_route(FRAMES, accepted=sets), {"tolerance": 0})
    assert [g.tolist() for g in ds.ground_truth] == [[k] for k in range(8)]
    assert ds.meta["ground_truth_rule"]["same_place"]["rule"] == "off"
    asked = assemble(_route(FRAMES, accepted=sets), {"tolerance": 0, "same_place": "images"})
    assert asked.ground_truth[2].tolist() == [1, 2, 3]


def test_positions_rule_needs_positions():
    with pytest.raises(DataError, match=r"same_place=positions needs reference positions"):
        assemble(_route(FRAMES, places=range(8)), {"same_place": "positions"})


def test_soft_tolerance_builds_soft_sets_and_is_checked():
    ds = assemble(_route(FRAMES, places=range(8)), {"tolerance": 0, "soft_tolerance": 1})
    assert ds.soft_ground_truth[0].tolist() == [0, 1, 2, 3]  # closed like the hard sets
    assert ds.soft_ground_truth[7].tolist() == [6, 7]
    assert ds.meta["ground_truth_rule"]["soft_tolerance"] == 1
    with pytest.raises(DataError, match=r"soft_tolerance=1 is below tolerance=2; .* >= tolerance"):
        assemble(_route(FRAMES, places=range(8)), {"tolerance": 2, "soft_tolerance": 1})


def test_the_closure_is_bounded(monkeypatch):
    from ppaloc.datasets import sameplace

    monkeypatch.setattr(sameplace, "MAX_GROUND_TRUTH_ITEMS", 22)
    groups = np.array([[0, 10]])
    assert close_over_groups([[1], [2]], groups, 12).indices.size == 20
    with pytest.raises(DataError, match=r"\(the longest 10 frames\) would accept up to 34 \(query, "
                       r"reference\) pairs, more than 22; .* \(same_place=off\)"):  # fmt: skip
        close_over_groups([[1], [2], [11, 3]], groups, 12)
