"""Metrics: hand-computed goldens and invariants of the PR curve."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ppaloc.errors import PpalocError
from ppaloc.evaluate.metrics import (
    auc,
    evaluate_estimates,
    is_correct,
    localisation_error_frames,
    localisation_error_m,
    max_f1,
    pr_curve,
    recall_at_100_precision,
    recall_at_k,
)

# Six queries; query 5 has no true match. Predictions: correct, correct, wrong, correct,
# wrong, wrong (no match). Scores with a tie between queries 1 and 2.
NODES = [10, 11, 40, 13, 90, 50]
SCORES = [0.9, 0.7, 0.7, 0.5, 0.3, 0.2]
GT = [[9, 10, 11], [10, 11, 12], [11, 12, 13], [12, 13, 14], [13, 14, 15], []]


def test_is_correct_golden():
    assert is_correct(NODES, GT).tolist() == [True, True, False, True, False, False]


def test_curve_golden_recall_a():
    c = pr_curve(SCORES, is_correct(NODES, GT), [len(g) > 0 for g in GT], recall="A")
    # thresholds 0.9 | 0.7 (two queries at once) | 0.5 | 0.3 | 0.2
    assert c.thresholds.tolist() == [0.9, 0.7, 0.5, 0.3, 0.2]
    assert c.accepted.tolist() == [1, 3, 4, 5, 6]
    assert c.correct_accepted.tolist() == [1, 2, 3, 3, 3]
    np.testing.assert_allclose(c.precision, [1, 2 / 3, 3 / 4, 3 / 5, 3 / 6])
    np.testing.assert_allclose(c.recall, [1 / 5, 2 / 5, 3 / 5, 3 / 5, 3 / 5])
    f1 = [2 * p * r / (p + r) for p, r in zip(c.precision, c.recall, strict=True)]
    np.testing.assert_allclose(c.f1, f1)


def test_curve_golden_recall_b_and_c():
    correct = is_correct(NODES, GT)
    has = [len(g) > 0 for g in GT]
    b = pr_curve(SCORES, correct, has, recall="B")
    np.testing.assert_allclose(b.recall, [1 / 3, 2 / 3, 1, 1, 1])
    c = pr_curve(SCORES, correct, has, recall="c")  # case-insensitive
    # false negatives = rejected queries with a true match: 4, 2, 1, 0, 0 (query 5, with
    # no true match, is a true negative while rejected, never a false negative)
    np.testing.assert_allclose(c.recall, [1 / 5, 2 / 4, 3 / 4, 3 / 3, 3 / 3])
    assert c.recall_definition == "C"


def test_summary_values_golden():
    m = evaluate_estimates(NODES, SCORES, GT)
    # F1 per point: 1/3, 0.5333, 0.6667, 0.6, 0.5454 -> best at threshold 0.5
    assert m.f1_max == pytest.approx(2 * 0.75 * 0.6 / 1.35)
    assert (m.precision_at_f1, m.recall_at_f1, m.threshold_at_f1) == (0.75, 0.6, 0.5)
    assert m.recall_at_100p == pytest.approx(0.2)
    assert m.precision_at_100r == pytest.approx(3 / 6)
    assert (m.n_queries, m.n_with_match, m.n_correct) == (6, 5, 3)
    # trapezoid from (0, 1): (0.2*1) + 0.2*(1+2/3)/2 + 0.2*(2/3+3/4)/2 + 0 + 0
    assert m.auc == pytest.approx(0.2 + 0.2 * (5 / 3) / 2 + 0.2 * (17 / 12) / 2)
    assert m.recall_definition == "A"
    # errors: 0, 0, |40-13| = 27, 0, |90-15| = 75, nan
    np.testing.assert_array_equal(m.error_frames, [0, 0, 27, 0, 75, np.nan])
    assert m.error_frames_median == 0.0
    assert m.error_frames_mean == pytest.approx(102 / 5)
    assert m.error_m is None and m.error_m_median is None
    assert len(m.recall_at_k) == 0


def test_perfect_and_hopeless_runs():
    perfect = evaluate_estimates([0, 1, 2], [0.1, 0.5, 0.2], [[0], [1], [2]])
    assert (perfect.f1_max, perfect.auc, perfect.recall_at_100p) == (1, 1, 1)
    assert perfect.precision_at_100r == 1
    hopeless = evaluate_estimates([5, 5, 5], [0.1, 0.5, 0.2], [[0], [1], [2]])
    assert (hopeless.f1_max, hopeless.auc, hopeless.recall_at_100p) == (0, 0, 0)


def test_summary_is_json_ready():
    import json

    m = evaluate_estimates(NODES, SCORES, GT, rankings=[[n, n + 1] for n in NODES])
    text = json.dumps(m.summary())
    back = json.loads(text)
    assert back["f1_max"] == m.f1_max
    assert back["recall_at_k"] == {"1": 0.6}


def test_unknown_recall_definition_names_the_choices():
    with pytest.raises(PpalocError, match=r"recall definition 'D' is unknown; choose one of A"):
        evaluate_estimates(NODES, SCORES, GT, recall="D")


def test_nan_scores_are_a_bug():
    with pytest.raises(ValueError, match="NaN"):
        evaluate_estimates([0], [float("nan")], [[0]])


def test_empty_run():
    m = evaluate_estimates([], [], [])
    assert (m.f1_max, m.auc, m.precision_at_100r, m.n_queries) == (0, 0, 0, 0)


def test_recall_at_k_golden():
    ranks = [[4, 2, 9], [1, 5, 6], None, [0, 0, 0]]
    gt = [[2], [6, 7], [3], []]
    # query 2 falls back to its node (3: correct at k=1); query 3 has no true match
    np.testing.assert_allclose(recall_at_k(ranks, gt, nodes=[4, 1, 3, 0]), [1 / 3, 2 / 3, 1])


def test_localisation_error_m_golden():
    ref = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    qry = np.array([[1.0, 0.0], [10.0, 3.0]])
    np.testing.assert_allclose(localisation_error_m([0, 2], ref, qry), [1.0, np.hypot(10, 3)])
    m = evaluate_estimates([0, 2], [1, 1], [[0], [1]], reference_positions=ref, query_positions=qry)
    assert m.error_m_median == pytest.approx((1 + np.hypot(10, 3)) / 2)


@pytest.mark.parametrize(
    ("nodes", "message"),
    [
        ([0, -1], r"predicted node \[1\] is -1, outside the 3 reference positions"),  # wrapped
        ([0, 5], r"predicted node \[1\] is 5, outside the 3"),  # an IndexError
        ([0.0, 1.5], r"predicted node \[1\] is 1.5, not a whole number"),  # truncated
        ([0, 10**30], r"must be integers"),  # an OverflowError
        (np.array([0.0, 1e30]), r"predicted node \[1\] is 1e\+30, not a whole number within"),
    ],
)
def test_predicted_nodes_that_index_no_reference_are_named(nodes, message):
    ref, qry = np.array([[0.0], [1.0], [50.0]]), np.array([[0.0], [1.0]])
    with pytest.raises(ValueError, match=message):
        evaluate_estimates(nodes, [1, 2], [[0], [1]], reference_positions=ref, query_positions=qry)


def test_a_fractional_node_is_not_counted_correct():
    # 0.9 was truncated to node 0 and counted a true match
    with pytest.raises(ValueError, match=r"predicted node \[0\] is 0.9, not a whole number"):
        is_correct([0.9], [[0]])
    assert is_correct(np.array([2.0, 7.0]), [[1, 2], [3]]).tolist() == [True, False]


def test_localisation_error_frames_no_match_is_nan():
    assert np.isnan(localisation_error_frames([3], [[]])[0])


def test_max_f1_ties_go_to_the_highest_threshold():
    # two points with F1 = 2/3: (p=1, r=0.5) at 0.9 and (p=0.5, r=1) at 0.5
    c = pr_curve([0.9, 0.5, 0.5, 0.5], [True, True, False, False], [True, True, False, False])
    np.testing.assert_allclose(c.f1, [2 / 3, 2 / 3])
    assert max_f1(c) == (pytest.approx(2 / 3), 1.0, 0.5, 0.9)


# -- properties ------------------------------------------------------------------------------

runs = st.integers(1, 40).flatmap(
    lambda m: st.tuples(
        st.lists(st.integers(0, 4), min_size=m, max_size=m),  # predicted node
        st.lists(st.integers(0, 6), min_size=m, max_size=m),  # score (ties likely)
        st.lists(st.integers(-1, 4), min_size=m, max_size=m),  # true node, -1 = none
    )
)


@settings(max_examples=150, deadline=None)
@given(runs, st.sampled_from(["A", "B", "C"]))
def test_values_in_unit_interval_and_recall_monotone(run, definition):
    nodes, scores, truth = run
    gt = [[t] if t >= 0 else [] for t in truth]
    m = evaluate_estimates(nodes, scores, gt, recall=definition)
    for v in (m.f1_max, m.precision_at_f1, m.recall_at_f1, m.auc, m.recall_at_100p):
        assert 0.0 <= v <= 1.0
    assert 0.0 <= m.precision_at_100r <= 1.0
    c = m.curve
    for a in (c.precision, c.recall, c.f1):
        assert np.all((a >= 0) & (a <= 1))
    # thresholds descend, so recall must never decrease along the curve
    assert np.all(np.diff(c.thresholds) < 0)
    assert np.all(np.diff(c.recall) >= -1e-12)
    assert np.all(np.diff(c.accepted) > 0)
    assert c.accepted[-1] == len(nodes)
    # the last point accepts everything: its precision is the precision at 100% recall
    assert c.precision[-1] == pytest.approx(m.precision_at_100r)
    # a reference sweep: accept score >= t for every distinct t, count by brute force
    correct = is_correct(nodes, gt)
    for t, tp in zip(c.thresholds, c.correct_accepted, strict=True):
        assert tp == int(np.sum(correct & (np.asarray(scores) >= t)))


@settings(max_examples=60, deadline=None)
@given(runs)
def test_recall_at_100p_is_on_a_perfect_point(run):
    nodes, scores, truth = run
    gt = [[t] if t >= 0 else [] for t in truth]
    c = evaluate_estimates(nodes, scores, gt).curve
    r = recall_at_100_precision(c)
    assert r == 0.0 or any(
        p == 1.0 and rr == r for p, rr in zip(c.precision, c.recall, strict=True)
    )
    assert 0.0 <= auc(c) <= 1.0


sets = st.lists(
    st.tuples(
        st.integers(0, 9),  # predicted node
        st.lists(st.integers(0, 9), max_size=4, unique=True),  # ground-truth set
        st.lists(st.integers(0, 9), max_size=5),  # ranking
    ),
    max_size=25,
)


@settings(max_examples=150, deadline=None)
@given(sets)
def test_vectorised_lookups_match_a_slow_reference(rows):
    nodes = [n for n, _, _ in rows]
    gt = [sorted(g) for _, g, _ in rows]
    ranks = [r for _, _, r in rows]
    assert is_correct(nodes, gt).tolist() == [n in g for n, g in zip(nodes, gt, strict=True)]
    err = localisation_error_frames(nodes, gt)
    for e, n, g in zip(err, nodes, gt, strict=True):
        assert (np.isnan(e) and not g) or e == min(abs(x - n) for x in g)
    k_max = max((len(r) for r in ranks), default=0)
    got = recall_at_k(ranks, gt)
    matched = [(r, g) for r, g in zip(ranks, gt, strict=True) if g]
    if k_max == 0 or not matched:
        assert got.tolist() == [0.0] * k_max
    else:
        want = [
            np.mean([any(x in g for x in r[:k]) for r, g in matched]) for k in range(1, k_max + 1)
        ]
        np.testing.assert_allclose(got, want)


@settings(max_examples=100, deadline=None)
@given(sets, st.integers(1, 4))
def test_padded_rankings_and_packed_truth_give_the_list_results(rows, block):
    """The (M, K) matrix a run records and the packed truth (looked up a few rows at a
    time) give exactly what one array per query gives, unsorted truth included."""
    import ppaloc.evaluate.metrics as metrics
    from ppaloc.datasets.groundtruth import PackedSets

    gt = [g[::-1] for _, g, _ in rows]  # descending: the lookup must not rely on order
    ranks = [r for _, _, r in rows]
    k_max = max((len(r) for r in ranks), default=0)
    padded = np.full((len(ranks), k_max), -1, np.int64)
    for i, r in enumerate(ranks):
        padded[i, : len(r)] = r
    want = recall_at_k(ranks, gt)
    saved = metrics._RECALL_ROWS
    metrics._RECALL_ROWS = block
    try:
        got = recall_at_k(padded, PackedSets.from_sets(gt))
    finally:
        metrics._RECALL_ROWS = saved
    assert got.tobytes() == want.tobytes()


# Soft ground truth: query 2's prediction (40) and query 5's (50, a query with no true
# match) are soft: near enough not to be wrong, not right.
SOFT = [[9, 10, 11], [10, 11, 12], [11, 12, 13, 40], [12, 13, 14], [13, 14, 15], [50]]


def test_soft_predictions_are_neither_true_nor_false_positives():
    correct = is_correct(NODES, GT)
    soft = is_correct(NODES, SOFT) & ~correct
    assert soft.tolist() == [False, False, True, False, False, True]
    has = [len(g) > 0 for g in GT]
    a = pr_curve(SCORES, correct, has, recall="A", soft=soft)
    assert a.accepted.tolist() == [1, 3, 4, 5, 6]
    assert a.soft_accepted.tolist() == [0, 1, 1, 1, 2]
    np.testing.assert_allclose(a.precision, [1, 2 / 2, 3 / 3, 3 / 4, 3 / 4])
    np.testing.assert_allclose(a.recall, [1 / 5, 2 / 5, 3 / 5, 3 / 5, 3 / 5])
    b = pr_curve(SCORES, correct, has, recall="B", soft=soft)
    np.testing.assert_allclose(b.recall, [1 / 3, 2 / 3, 1, 1, 1])
    c = pr_curve(SCORES, correct, has, recall="C", soft=soft)
    np.testing.assert_allclose(c.recall, [1 / 5, 2 / 4, 3 / 4, 1, 1])


def test_soft_summary_golden():
    m = evaluate_estimates(NODES, SCORES, GT, soft=SOFT, rankings=[[n, 12] for n in NODES])
    assert m.f1_max == pytest.approx(0.75)  # P 1, R 0.6 at threshold 0.5
    assert (m.precision_at_f1, m.recall_at_f1, m.threshold_at_f1) == (1.0, 0.6, 0.5)
    assert m.recall_at_100p == pytest.approx(0.6)
    assert m.precision_at_100r == pytest.approx(3 / 4)  # 3 correct of the 4 right-or-wrong
    assert (m.n_correct, m.n_soft, m.n_with_match) == (3, 2, 5)
    assert m.auc == pytest.approx(0.6)
    # soft counts nowhere in recall@K or the error: hard matches only
    np.testing.assert_allclose(m.recall_at_k, [3 / 5, 4 / 5])  # query 2 finds 12 second
    np.testing.assert_array_equal(m.error_frames, [0, 0, 27, 0, 75, np.nan])
    assert m.summary()["n_soft"] == 2
    # the soft sets a PackedSets carries are read the same way
    from ppaloc.datasets.groundtruth import PackedSets

    carried = evaluate_estimates(NODES, SCORES, PackedSets.from_sets(GT).with_soft(SOFT))
    assert (carried.f1_max, carried.precision_at_100r, carried.n_soft) == (
        m.f1_max,
        m.precision_at_100r,
        2,
    )
    plain = evaluate_estimates(NODES, SCORES, GT)
    assert plain.n_soft == 0 and plain.precision_at_100r == pytest.approx(3 / 6)


def test_queries_without_a_true_match_in_every_recall_definition():
    # two queries with a match (both correct), three without (their predictions wrong)
    nodes, scores = [1, 2, 7, 8, 9], [0.9, 0.8, 0.7, 0.6, 0.5]
    gt = [[1], [2], [], [], []]
    for definition in ("A", "B", "C"):
        m = evaluate_estimates(nodes, scores, gt, recall=definition)
        # accepting the two with a match finds everything and accepts nothing wrong
        assert (m.f1_max, m.recall_at_f1, m.precision_at_f1) == (1.0, 1.0, 1.0), definition
        assert m.recall_at_100p == 1.0 and m.threshold_at_f1 == 0.8
        # the whole curve: precision falls as the no-match queries are accepted, recall stays
        np.testing.assert_allclose(m.curve.recall, [0.5, 1, 1, 1, 1])
        np.testing.assert_allclose(m.curve.precision, [1, 1, 2 / 3, 2 / 4, 2 / 5])
    assert evaluate_estimates(nodes, scores, gt).precision_at_100r == pytest.approx(2 / 5)
    nothing = evaluate_estimates([0, 1], [0.5, 0.4], [[], []], recall="C")
    assert (nothing.f1_max, nothing.recall_at_100p, nothing.n_with_match) == (0.0, 0.0, 0)
    # rejecting a query without a match is no false negative under C
    c = pr_curve([0.9, 0.1], [True, False], [True, False], recall="C")
    assert c.recall.tolist() == [1.0, 1.0]


def test_a_correct_prediction_cannot_be_soft():
    with pytest.raises(ValueError, match="cannot also be soft"):
        pr_curve([0.5], [True], [True], soft=[True])


@settings(max_examples=100, deadline=None)
@given(runs, st.sampled_from(["A", "B", "C"]))
def test_precision_at_100_recall_is_what_its_name_says(run, definition):
    """Correct / all queries; the curve's recall there is 1 under B and C (when any query
    is correct) and correct / queries with a true match under A."""
    nodes, scores, truth = run
    gt = [[t] if t >= 0 else [] for t in truth]
    m = evaluate_estimates(nodes, scores, gt, recall=definition)
    assert m.precision_at_100r == pytest.approx(m.n_correct / len(nodes))
    at_all = m.curve.recall[-1]
    if definition == "A":
        assert at_all == pytest.approx(m.n_correct / max(m.n_with_match, 1))
    elif m.n_correct:
        assert at_all == 1.0
