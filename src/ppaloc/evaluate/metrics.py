"""Place-recognition metrics: the precision-recall curve and what is read off it.

Every query frame gets one estimate: a predicted reference index and a confidence score
(higher = surer). A threshold ``t`` *accepts* the queries with ``score >= t``. Each
prediction is one of three things:

*correct*
    its reference index is in the query's (hard) ground-truth set (tolerance already
    applied): what the method had to find;
*soft*
    it is not in the hard set but in the query's soft set, where the dataset has one
    (VPR_Tutorial's ``GTsoft``): near enough not to be wrong, not near enough to be right;
*wrong*
    anything else, including every prediction for a query with no true match (empty hard
    set) that is not soft.

The curve has one point per distinct score value, from the highest (fewest accepted) to the
lowest (all accepted): a fixed grid of thresholds would skip points and under-report recall
at 100% precision.

Precision is ``correct accepted / (correct accepted + wrong accepted)``: an accepted soft
prediction is neither a true nor a false positive. Recall counts hard matches found and has
three definitions in use in the place-recognition literature, so it is always labelled:

``A`` (default)
    correct accepted / queries that have a true match. The strict one: a query whose best
    match is wrong (or only soft) still counts against recall, and queries with no true
    match do not.
``B``
    correct accepted / queries whose best match is correct. Measures only how well the
    score separates right from wrong estimates; reaches 1 when everything is accepted.
``C``
    correct accepted / (correct accepted + rejected queries that have a true match). The
    classic ``TP / (TP + FN)``: a rejected query with a true match is a false negative; a
    rejected query without one is a true negative and counts nowhere.

The same rule holds for every metric: a soft prediction is never a true positive (recall
A, B, C, recall@K and the error in frames count hard matches only) and never a false
positive (precision and precision at 100% recall leave it out); a query without a true
match is never in a recall's denominator, and its prediction, accepted, is a false
positive unless soft.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.errors import PpalocError

__all__ = [
    "RECALL_DEFINITIONS",
    "Metrics",
    "PRCurve",
    "auc",
    "evaluate_estimates",
    "is_correct",
    "localisation_error_frames",
    "localisation_error_m",
    "max_f1",
    "metrics_table",
    "pr_curve",
    "precision_at_100_recall",
    "recall_at_100_precision",
    "recall_at_k",
]

RECALL_DEFINITIONS: dict[str, str] = {
    "A": "correct accepted / queries that have a true match",
    "B": "correct accepted / queries whose best match is correct",
    "C": "correct accepted / (correct accepted + rejected queries that have a true match)",
}
"""Recall definition letter -> what it divides by (see the module docstring)."""


def _as_nodes(nodes: Any) -> np.ndarray:
    """Predicted reference indices as int64, refusing values that are not whole numbers
    within int64 (0.9 was truncated to 0 and counted correct; 1e30 cast to garbage with a
    warning) in one line."""
    a = np.asarray(nodes)
    if a.dtype.kind == "f":
        bad = ~np.isfinite(a) | (a != np.round(a)) | (np.abs(a) >= 2.0**63)
        if bad.any():
            i = int(np.flatnonzero(bad.ravel())[0])
            value = float(a.ravel()[i])
            raise ValueError(f"predicted node [{i}] is {value!r}, not a whole number within int64")
    elif a.dtype.kind not in "biu":
        raise ValueError(f"predicted nodes must be integers, got dtype {a.dtype}")
    return a.astype(np.int64).ravel()


def _as_ground_truth(ground_truth: Sequence[Any], n: int) -> PackedSets:
    """The ground truth packed (no copy when it already is), checked to have ``n`` rows."""
    if len(ground_truth) != n:
        raise ValueError(f"ground truth has {len(ground_truth)} rows for {n} estimates")
    return PackedSets.from_sets(ground_truth)


def _entry_rows(gt: PackedSets) -> np.ndarray:
    """The query (row) of every packed index."""
    return np.repeat(np.arange(len(gt), dtype=np.int64), gt.lengths)


def is_correct(nodes: np.ndarray, ground_truth: Sequence[Any]) -> np.ndarray:
    """Whether each predicted reference index is in its query's ground-truth set.

    Parameters
    ----------
    nodes : array_like of int, shape (M,)
        Predicted reference index per query.
    ground_truth : sequence of array_like of int, length M
        Accepted reference indices per query (empty: no true match).

    Returns
    -------
    ndarray of bool, shape (M,)

    Examples
    --------
    >>> is_correct([3, 7], [[2, 3, 4], []]).tolist()
    [True, False]
    """
    nodes = _as_nodes(nodes)
    gt = _as_ground_truth(ground_truth, len(nodes))
    rows = _entry_rows(gt)
    hit = gt.indices == nodes[rows]
    return np.bincount(rows[hit], minlength=len(nodes)) > 0


@dataclass(frozen=True)
class PRCurve:
    """A precision-recall curve, one point per distinct score, highest threshold first.

    Attributes
    ----------
    thresholds : ndarray of float, shape (P,)
        Distinct score values, descending; point ``j`` accepts ``score >= thresholds[j]``.
    precision, recall, f1 : ndarray of float, shape (P,)
        At each threshold; recall under ``recall_definition``.
    accepted, correct_accepted : ndarray of int, shape (P,)
        Counts at each threshold.
    recall_definition : str
        ``"A"``, ``"B"`` or ``"C"`` (see :data:`RECALL_DEFINITIONS`).
    soft_accepted : ndarray of int, shape (P,)
        Accepted soft predictions at each threshold (neither true nor false positives).
    """

    thresholds: np.ndarray
    precision: np.ndarray
    recall: np.ndarray
    f1: np.ndarray
    accepted: np.ndarray
    correct_accepted: np.ndarray
    recall_definition: str = "A"
    soft_accepted: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


def _check_recall(recall: str) -> str:
    key = str(recall).upper()
    if key not in RECALL_DEFINITIONS:
        raise PpalocError(
            f"recall definition {recall!r} is unknown; choose one of "
            + ", ".join(f"{k} ({v})" for k, v in RECALL_DEFINITIONS.items())
        )
    return key


def _f1(precision: np.ndarray, recall: np.ndarray) -> np.ndarray:
    total = precision + recall
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, 2 * precision * recall / np.where(total > 0, total, 1), 0.0)


def pr_curve(
    scores: np.ndarray,
    correct: np.ndarray,
    has_match: np.ndarray,
    *,
    recall: str = "A",
    soft: np.ndarray | None = None,
) -> PRCurve:
    """The precision-recall curve swept over every distinct score value.

    Parameters
    ----------
    scores : array_like of float, shape (M,)
        Confidence per query (higher = surer); NaN is not allowed, +-inf is.
    correct : array_like of bool, shape (M,)
        Whether the query's predicted index is a true match (:func:`is_correct`).
    has_match : array_like of bool, shape (M,)
        Whether the query has any true match (non-empty ground truth).
    recall : {"A", "B", "C"}
        Recall definition (:data:`RECALL_DEFINITIONS`).
    soft : array_like of bool, shape (M,), optional
        Whether the prediction is soft (in the soft set, not the hard one): left out of
        precision, never correct (see the module docstring).

    Returns
    -------
    PRCurve
        Empty arrays when there are no queries. A ratio whose denominator is 0 is 0.

    Examples
    --------
    >>> c = pr_curve([0.9, 0.8, 0.8, 0.1], [True, False, True, True], [True] * 4)
    >>> c.thresholds.tolist(), c.precision.tolist(), c.recall.tolist()
    ([0.9, 0.8, 0.1], [1.0, 0.6666666666666666, 0.75], [0.25, 0.5, 0.75])
    >>> c = pr_curve([0.9, 0.8, 0.8, 0.1], [True, False, True, True], [True] * 4,
    ...              soft=[False, True, False, False])
    >>> c.precision.tolist(), c.recall.tolist(), c.soft_accepted.tolist()
    ([1.0, 1.0, 1.0], [0.25, 0.5, 0.75], [0, 1, 1])
    """
    definition = _check_recall(recall)
    scores = np.asarray(scores, dtype=np.float64).ravel()
    correct = np.asarray(correct, dtype=bool).ravel()
    has_match = np.asarray(has_match, dtype=bool).ravel()
    soft = np.zeros(len(scores), bool) if soft is None else np.asarray(soft, dtype=bool).ravel()
    if not (len(scores) == len(correct) == len(has_match) == len(soft)):
        raise ValueError(
            f"scores, correct, has_match and soft differ in length: "
            f"{len(scores)}, {len(correct)}, {len(has_match)}, {len(soft)}"
        )
    if np.isnan(scores).any():
        raise ValueError("scores contain NaN; a localiser must return a comparable confidence")
    if np.any(correct & ~has_match):
        raise ValueError("a query without a true match cannot be correct")
    if np.any(correct & soft):
        raise ValueError("a correct prediction cannot also be soft (soft means: not hard)")
    m = len(scores)
    # Sort by score descending; the last index of each run of equal scores is one point.
    order = np.argsort(-scores, kind="stable")
    s = scores[order]
    tp_cum = np.cumsum(correct[order])
    soft_cum = np.cumsum(soft[order])
    match_cum = np.cumsum(has_match[order])
    if m:
        last = np.flatnonzero(np.append(s[1:] != s[:-1], True))
    else:
        last = np.zeros(0, dtype=np.int64)
    thresholds = s[last]
    accepted = last + 1
    empty = np.zeros(0, dtype=np.int64)
    tp = tp_cum[last] if m else empty
    soft_acc = soft_cum[last] if m else empty
    judged = accepted - soft_acc  # accepted predictions that are right or wrong
    precision = np.where(judged > 0, tp / np.maximum(judged, 1), 0.0)
    if definition == "A":
        denom = np.full(len(tp), int(has_match.sum()))
    elif definition == "B":
        denom = np.full(len(tp), int(correct.sum()))
    else:  # false negatives: rejected queries that have a true match
        rejected_with_match = int(has_match.sum()) - (match_cum[last] if m else empty)
        denom = tp + rejected_with_match
    rec = np.where(denom > 0, tp / np.maximum(denom, 1), 0.0)
    return PRCurve(
        thresholds=thresholds,
        precision=precision.astype(np.float64),
        recall=rec.astype(np.float64),
        f1=_f1(precision, rec),
        accepted=accepted.astype(np.int64),
        correct_accepted=tp.astype(np.int64),
        recall_definition=definition,
        soft_accepted=soft_acc.astype(np.int64),
    )


def max_f1(curve: PRCurve) -> tuple[float, float, float, float]:
    """The best F1 on the curve and its precision, recall and threshold.

    Ties go to the highest threshold (the first point). An empty curve gives zeros and a
    NaN threshold.

    Examples
    --------
    >>> c = pr_curve([0.9, 0.8, 0.8, 0.1], [True, False, True, True], [True] * 4)
    >>> [round(v, 4) for v in max_f1(c)]
    [0.75, 0.75, 0.75, 0.1]
    """
    if len(curve.f1) == 0:
        return 0.0, 0.0, 0.0, float("nan")
    j = int(np.argmax(curve.f1))
    return (
        float(curve.f1[j]),
        float(curve.precision[j]),
        float(curve.recall[j]),
        float(curve.thresholds[j]),
    )


def auc(curve: PRCurve) -> float:
    """Area under the precision-recall curve by the trapezoid rule.

    The curve is taken from recall 0, where precision is held at the first point's value
    (the most confident threshold), to the last point (everything accepted). Recall never
    decreases along the curve, so the area is in [0, 1].

    Examples
    --------
    >>> auc(pr_curve([0.9, 0.1], [True, True], [True, True]))
    1.0
    """
    if len(curve.recall) == 0:
        return 0.0
    r = np.concatenate([[0.0], curve.recall])
    p = np.concatenate([[curve.precision[0]], curve.precision])
    return float(np.sum(np.diff(r) * (p[1:] + p[:-1]) / 2))


def recall_at_100_precision(curve: PRCurve) -> float:
    """The highest recall at a threshold where every accepted query is correct (0 if none).

    Examples
    --------
    >>> recall_at_100_precision(pr_curve([0.9, 0.8, 0.1], [True, False, True], [True] * 3))
    0.3333333333333333
    """
    perfect = curve.precision >= 1.0
    return float(curve.recall[perfect].max()) if perfect.any() else 0.0


def precision_at_100_recall(curve: PRCurve) -> float:
    """The precision with every query accepted: the curve's last point (0 if it is empty).

    That point accepts every estimate, so its precision is the fraction of *all* queries
    whose best match is correct (queries without a true match count as wrong; a soft
    prediction, neither right nor wrong, counts nowhere). Under recall
    ``B`` and ``C`` accepting everything is recall 1, so this is the precision at 100%
    recall (P@100R) the place-recognition literature reports; under ``A`` that point's
    recall is ``correct / queries with a true match``, the highest the method reaches,
    which is 1 only when every such query is right. The number itself does not depend on
    the recall definition.

    Examples
    --------
    >>> curve = pr_curve([0.9, 0.5, 0.2, 0.1], [True, False, True, True], [True] * 4)
    >>> precision_at_100_recall(curve), float(curve.recall[-1])
    (0.75, 0.75)
    """
    return float(curve.precision[-1]) if len(curve.precision) else 0.0


_RECALL_ROWS = 4096
"""Queries looked up per block in :func:`recall_at_k`: its working arrays stay a few MB
whatever the route's length."""


def _padded_rankings(
    rankings: np.ndarray | Sequence[np.ndarray | None], nodes: np.ndarray | None
) -> np.ndarray:
    """Rankings as an (M, K) int64 matrix padded with -1 (a 2-D array is used as is)."""
    if isinstance(rankings, np.ndarray) and rankings.ndim == 2:
        return rankings.astype(np.int64, copy=False)
    flat_nodes = None if nodes is None else np.asarray(nodes).ravel()
    ranks = []
    for i, r in enumerate(rankings):
        if r is None:
            r = [] if flat_nodes is None else [int(flat_nodes[i])]
        ranks.append(np.asarray(r, dtype=np.int64).ravel())
    padded = np.full((len(ranks), max((len(r) for r in ranks), default=0)), -1, np.int64)
    for i, r in enumerate(ranks):
        padded[i, : len(r)] = r
    return padded


def recall_at_k(
    rankings: np.ndarray | Sequence[np.ndarray | None],
    ground_truth: Sequence[Any],
    nodes: np.ndarray | None = None,
) -> np.ndarray:
    """Recall@K for K = 1 .. the longest ranking: the fraction of queries with a true match
    whose K best candidates include a correct one.

    Parameters
    ----------
    rankings : ndarray of int, shape (M, K), or sequence of (array_like of int or None)
        Candidates per query, best first, as reference indices: an (M, K) matrix padded
        with -1 (what a run records; read as is), or one array per query. ``None`` (a
        frame where the method did not rank) counts as the single candidate ``nodes[i]``.
    ground_truth : sequence of array_like of int, length M
        Accepted reference indices per query (a :class:`PackedSets` is read without a copy).
    nodes : array_like of int, shape (M,), optional
        Predicted reference index per query, used where a ranking is ``None``.

    Returns
    -------
    ndarray of float, shape (K,)
        ``out[k - 1]`` is recall@k. Empty when no query has a ranking.

    Examples
    --------
    >>> recall_at_k([[4, 2, 9], [1, 5, 6]], [[2], [6, 7]]).tolist()
    [0.0, 0.5, 1.0]
    >>> recall_at_k(np.array([[4, 2, -1], [1, 5, 6]]), [[2], [6, 7]]).tolist()
    [0.0, 0.5, 1.0]
    """
    padded = _padded_rankings(rankings, nodes)
    gt = _as_ground_truth(ground_truth, len(padded))
    m, k_max = padded.shape
    has_match = gt.lengths > 0
    if k_max == 0 or not has_match.any():
        return np.zeros(k_max, dtype=np.float64)
    # Every accepted (query, reference) pair as one sorted key; a candidate is correct
    # when its own key is among them.
    span = int(max(padded.max(), gt.indices.max(initial=0))) + 2
    truth = _entry_rows(gt) * span + (gt.indices + 1)
    if np.any(truth[1:] < truth[:-1]):
        truth = np.sort(truth)
    # First position (1-based) of a correct candidate; k_max + 1 when none.
    first = np.full(m, k_max + 1, dtype=np.int64)
    for a in range(0, m, _RECALL_ROWS):
        block = padded[a : a + _RECALL_ROWS]
        keys = np.arange(a, a + len(block), dtype=np.int64)[:, None] * span + (block + 1)
        at = np.minimum(np.searchsorted(truth, keys), len(truth) - 1)
        hits = (truth[at] == keys) & (block >= 0)
        found = hits.any(axis=1)
        first[a : a + len(block)][found] = hits.argmax(axis=1)[found] + 1
    first = first[has_match]
    ks = np.arange(1, k_max + 1)
    return (first[None, :] <= ks[:, None]).mean(axis=1)


def localisation_error_frames(nodes: np.ndarray, ground_truth: Sequence[Any]) -> np.ndarray:
    """Per query, how many reference frames the prediction lies outside its true set.

    0 for a correct estimate; the distance to the nearest accepted reference index
    otherwise; NaN for a query with no true match.

    Returns
    -------
    ndarray of float, shape (M,)

    Examples
    --------
    >>> localisation_error_frames([5, 10, 3], [[4, 5, 6], [2, 3, 4], []]).tolist()
    [0.0, 6.0, nan]
    """
    nodes = _as_nodes(nodes)
    gt = _as_ground_truth(ground_truth, len(nodes))
    out = np.full(len(nodes), np.nan)
    nonempty = gt.lengths > 0
    if nonempty.any():
        distance = np.abs(gt.indices - nodes[_entry_rows(gt)]).astype(np.float64)
        out[nonempty] = np.minimum.reduceat(distance, gt.indptr[:-1][nonempty])
    return out


def localisation_error_m(
    nodes: np.ndarray,
    reference_positions: np.ndarray,
    query_positions: np.ndarray,
) -> np.ndarray:
    """Per query, the Euclidean distance in metres from the predicted reference position
    to the query's own position.

    Parameters
    ----------
    nodes : array_like of int, shape (M,)
        Predicted reference index per query.
    reference_positions : ndarray of float, shape (N, D)
    query_positions : ndarray of float, shape (M, D)

    Returns
    -------
    ndarray of float, shape (M,)

    Examples
    --------
    >>> localisation_error_m([1, 0], [[0.0, 0.0], [3.0, 4.0]], [[0.0, 0.0], [0.0, 0.0]])
    array([5., 0.])
    """
    nodes = _as_nodes(nodes)
    ref = np.asarray(reference_positions, dtype=np.float64)
    qry = np.asarray(query_positions, dtype=np.float64)
    ref = ref[:, None] if ref.ndim == 1 else ref
    qry = qry[:, None] if qry.ndim == 1 else qry
    if len(qry) != len(nodes):
        raise ValueError(f"{len(qry)} query positions for {len(nodes)} estimates")
    outside = (nodes < 0) | (nodes >= len(ref))
    if outside.any():  # -1 was measured against the last reference, N an IndexError
        i = int(np.flatnonzero(outside)[0])
        raise ValueError(
            f"predicted node [{i}] is {int(nodes[i])}, outside the {len(ref)} reference positions"
        )
    return np.linalg.norm(ref[nodes] - qry, axis=1)


def _nan_stat(fn: Any, a: np.ndarray | None) -> float | None:
    if a is None:
        return None
    finite = a[np.isfinite(a)]
    return float(fn(finite)) if finite.size else None


@dataclass(frozen=True)
class Metrics:
    """Everything :func:`evaluate_estimates` measures for one method on one dataset.

    Attributes
    ----------
    f1_max, precision_at_f1, recall_at_f1, threshold_at_f1 : float
        The best F1 on the PR curve and where it is reached.
    auc : float
        Area under the PR curve (trapezoid, see :func:`auc`).
    recall_at_100p : float
        Highest recall at 100% precision.
    precision_at_100r : float
        Precision with every query accepted: the fraction of all queries whose best match
        is correct (:func:`precision_at_100_recall`; 100% recall under recall B and C).
    recall_definition : str
        ``"A"``, ``"B"`` or ``"C"``.
    n_queries, n_with_match, n_correct : int
    n_soft : int
        Queries whose prediction is soft (in the soft set, not the hard one).
    error_frames_median, error_frames_mean : float or None
        Of :func:`localisation_error_frames` over queries with a true match.
    error_m_median, error_m_mean : float or None
        Of :func:`localisation_error_m`, where positions were given.
    recall_at_k : ndarray of float, shape (K,)
        ``recall_at_k[k - 1]`` is recall@k (empty when the method does not rank).
    curve : PRCurve
    correct : ndarray of bool, shape (M,)
    error_frames : ndarray of float, shape (M,)
    error_m : ndarray of float, shape (M,), or None
    f1_max_straight, f1_max_turning : float or None
        Max F1 over the queries taken on straight stretches and over those taken in turns
        (the PR curve of each subset alone), where the dataset says which frames turn
        (``meta["query_turning"]``); ``None`` when unknown or when the subset is empty.
    """

    f1_max: float
    precision_at_f1: float
    recall_at_f1: float
    threshold_at_f1: float
    auc: float
    recall_at_100p: float
    precision_at_100r: float
    recall_definition: str
    n_queries: int
    n_with_match: int
    n_correct: int
    error_frames_median: float | None
    error_frames_mean: float | None
    error_m_median: float | None
    error_m_mean: float | None
    recall_at_k: np.ndarray = field(repr=False)
    curve: PRCurve = field(repr=False)
    correct: np.ndarray = field(repr=False)
    error_frames: np.ndarray = field(repr=False)
    error_m: np.ndarray | None = field(default=None, repr=False)
    f1_max_straight: float | None = None
    f1_max_turning: float | None = None
    n_soft: int = 0

    def summary(self) -> dict[str, Any]:
        """The scalar metrics as a JSON-ready dict (recall@K as ``{"1": r1, "5": r5, ...}``)."""
        out = {
            k: v
            for k, v in asdict(self).items()
            if k not in {"recall_at_k", "curve", "correct", "error_frames", "error_m"}
        }
        for key, value in out.items():  # strict JSON: no NaN or infinity
            if isinstance(value, float) and not np.isfinite(value):
                out[key] = None
        out["recall_at_k"] = {
            str(k): float(self.recall_at_k[k - 1])
            for k in (1, 5, 10, 20)
            if k <= len(self.recall_at_k)
        }
        return out


def evaluate_estimates(
    nodes: np.ndarray,
    scores: np.ndarray,
    ground_truth: Sequence[Any],
    *,
    recall: str = "A",
    rankings: np.ndarray | Sequence[np.ndarray | None] | None = None,
    reference_positions: np.ndarray | None = None,
    query_positions: np.ndarray | None = None,
    turning: np.ndarray | None = None,
    soft: Sequence[Any] | None = None,
) -> Metrics:
    """All metrics of one run in one call.

    Parameters
    ----------
    nodes : array_like of int, shape (M,)
        Predicted *reference index* per query (a map node converted through the map's
        ``frame_index``; equal when the map has one node per reference frame).
    scores : array_like of float, shape (M,)
        Confidence per query, higher = surer.
    ground_truth : sequence of array_like of int, length M
        Accepted reference indices per query (``RouteDataset.ground_truth``, a
        :class:`~ppaloc.datasets.groundtruth.PackedSets` read without a copy).
    recall : {"A", "B", "C"}
        Recall definition, default ``"A"`` (see :data:`RECALL_DEFINITIONS`).
    rankings : ndarray of int, shape (M, K), or sequence of (array_like of int or None)
        Candidate reference indices per query, best first, for recall@K: the (M, K)
        matrix a run records (padded with -1), or one array per query.
    reference_positions, query_positions : ndarray of float, optional
        Route positions in metres, shapes (N, D) and (M, D), for the error in metres.
    turning : array_like of bool, shape (M,), optional
        Which queries were taken in a turn: gives ``f1_max_straight`` and ``f1_max_turning``.
    soft : sequence of array_like of int, length M, optional
        Soft ground truth per query (a prediction there is neither right nor wrong; see the
        module docstring). Default: the soft sets ``ground_truth`` carries
        (:attr:`~ppaloc.datasets.groundtruth.PackedSets.soft`), if any.

    Returns
    -------
    Metrics

    Raises
    ------
    PpalocError
        If ``recall`` is not one of A, B, C.

    Examples
    --------
    >>> m = evaluate_estimates([0, 1, 5, 3], [0.9, 0.8, 0.1, 0.7], [[0], [1], [2], [3]])
    >>> round(m.f1_max, 4), m.precision_at_f1, m.recall_at_f1, m.precision_at_100r, m.recall_at_100p
    (0.8571, 1.0, 0.75, 0.75, 0.75)
    >>> m = evaluate_estimates([0, 1, 5, 3], [0.9, 0.8, 0.1, 0.7], [[0], [1], [2], [3]],
    ...                        soft=[[0], [1], [2, 5], [3]])
    >>> m.f1_max, m.precision_at_100r, m.n_soft
    (0.8571428571428571, 1.0, 1)
    """
    nodes = _as_nodes(nodes)
    gt = _as_ground_truth(ground_truth, len(nodes))
    correct = is_correct(nodes, gt)
    has_match = gt.lengths > 0
    loose = gt.soft if soft is None else _as_ground_truth(soft, len(nodes))
    in_soft = np.zeros(len(nodes), bool) if loose is None else is_correct(nodes, loose) & ~correct
    curve = pr_curve(scores, correct, has_match, recall=recall, soft=in_soft)
    f1, p_f1, r_f1, t_f1 = max_f1(curve)
    err_frames = localisation_error_frames(nodes, gt)
    err_m = None
    if reference_positions is not None and query_positions is not None:
        err_m = localisation_error_m(nodes, reference_positions, query_positions)
        err_m = np.where(has_match, err_m, np.nan)
    if rankings is None:
        ranked = False
    elif isinstance(rankings, np.ndarray) and rankings.ndim == 2:
        ranked = len(rankings) > 0
    else:
        ranked = any(r is not None for r in rankings)
    rk = recall_at_k(rankings, gt, nodes) if ranked else np.zeros(0)
    split: dict[str, float | None] = {"f1_max_straight": None, "f1_max_turning": None}
    if turning is not None:
        turning = np.asarray(turning, dtype=bool).ravel()
        if turning.shape != nodes.shape:
            raise PpalocError(
                f"turning has {turning.size} flags for {nodes.size} queries; give one per query"
            )
        sc = np.asarray(scores, dtype=np.float64).ravel()
        for key, mask in (("f1_max_straight", ~turning), ("f1_max_turning", turning)):
            if mask.any():
                sub = pr_curve(
                    sc[mask], correct[mask], has_match[mask], recall=recall, soft=in_soft[mask]
                )
                split[key] = max_f1(sub)[0]
    return Metrics(
        **split,
        f1_max=f1,
        precision_at_f1=p_f1,
        recall_at_f1=r_f1,
        threshold_at_f1=t_f1,
        auc=auc(curve),
        recall_at_100p=recall_at_100_precision(curve),
        precision_at_100r=precision_at_100_recall(curve),
        recall_definition=curve.recall_definition,
        n_queries=len(nodes),
        n_with_match=int(has_match.sum()),
        n_correct=int(correct.sum()),
        n_soft=int(in_soft.sum()),
        error_frames_median=_nan_stat(np.median, err_frames),
        error_frames_mean=_nan_stat(np.mean, err_frames),
        error_m_median=_nan_stat(np.median, err_m),
        error_m_mean=_nan_stat(np.mean, err_m),
        recall_at_k=rk,
        curve=curve,
        correct=correct,
        error_frames=err_frames,
        error_m=err_m,
    )


def metrics_table(metrics: Mapping[str, Metrics]) -> list[dict[str, Any]]:
    """One summary row per method name, in the given order (for tables and CSV)."""
    return [{"method": name, **m.summary()} for name, m in metrics.items()]
