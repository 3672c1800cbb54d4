"""Soft ground truth and the dataset's roles through a run, the results folder and report."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from ppaloc.datasets import RouteDataset
from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.errors import DataError
from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.report import write_report
from ppaloc.evaluate.results import load_results, save_results
from ppaloc.evaluate.run import run_evaluation

ROLES = {"database": "tiny summer drive", "query": "tiny winter drive"}


@pytest.fixture
def softened(tiny):
    """The tiny route with hard sets of the exact frame only and soft sets of +-1; the
    stand-in's predictions are the exact frame (correct) up to query noise."""
    hard = [np.array([j]) for j in range(len(tiny.query) - 1)] + [np.zeros(0, np.int64)]
    truth = PackedSets.from_sets(hard).with_soft(tiny.ground_truth)
    return RouteDataset(
        tiny.name,
        tiny.reference,
        tiny.query,
        truth,
        tolerance=0,
        reference_positions=tiny.reference_positions,
        query_positions=tiny.query_positions,
        meta={**tiny.meta, "roles": ROLES},
    )


def test_soft_truth_and_roles_round_trip(mean_match, softened, tmp_path):
    result = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=softened, progress=False)
    assert result.roles == ROLES
    m = result.runs[mean_match].metrics
    save_results(result, tmp_path)
    back, summary = load_results(tmp_path)
    assert summary["roles"] == ROLES and back.roles == ROLES
    assert back.ground_truth.soft is not None
    assert [r.tolist() for r in back.ground_truth.soft] == [
        r.tolist() for r in softened.soft_ground_truth
    ]
    m_back = back.runs[mean_match].metrics
    assert (m_back.f1_max, m_back.precision_at_100r, m_back.n_soft) == (
        m.f1_max,
        m.precision_at_100r,
        m.n_soft,
    )
    assert summary["methods"][mean_match]["n_soft"] == m.n_soft
    with open(tmp_path / "results.csv") as f:
        rows = list(csv.DictReader(f))
    assert (rows[0]["database"], rows[0]["query"]) == (ROLES["database"], ROLES["query"])
    report = write_report(tmp_path).read_text()
    assert "Database: tiny summer drive; query: tiny winter drive." in report
    assert "Database: tiny summer drive" in (tmp_path / "report.md").read_text()


def test_a_soft_prediction_changes_precision_not_recall(mean_match, softened, tiny):
    cfg = EvaluateConfig(methods=(mean_match,), params={mean_match: {"offset": 1}})
    shifted = run_evaluation(cfg, dataset=softened, progress=False).runs[mean_match].metrics
    # every prediction one frame ahead: never hard, soft but for the last query's (no true
    # match, no soft set): precision and accuracy judge that one alone
    assert shifted.n_correct == 0 and shifted.n_soft == len(tiny.query) - 1
    assert shifted.f1_max == 0.0 and shifted.precision_at_100r == 0.0
    assert shifted.curve.soft_accepted[-1] == len(tiny.query) - 1
    plain = run_evaluation(
        cfg,
        dataset=RouteDataset(
            tiny.name, tiny.reference, tiny.query, [r.copy() for r in softened.ground_truth],
            tolerance=0, meta=tiny.meta,
        ),
        progress=False,
    ).runs[mean_match].metrics  # fmt: skip
    assert plain.n_soft == 0 and plain.precision_at_100r == 0.0


def test_old_folders_without_roles_or_soft_still_load(mean_match, tiny, tmp_path):
    result = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=False)
    assert result.roles is None
    save_results(result, tmp_path)
    back, summary = load_results(tmp_path)
    assert summary["roles"] is None and back.roles is None and back.ground_truth.soft is None
    assert "Database:" not in write_report(tmp_path).read_text()
    summary["roles"] = {"database": 3}
    (tmp_path / "results.json").write_text(json.dumps(summary))
    with pytest.raises(DataError, match=r"'roles' is \{'database': 3\}, expected"):
        load_results(tmp_path)


def test_the_report_says_what_the_same_place_closure_did(mean_match, tiny, tmp_path):
    rule = {
        "kind": "frames",
        "same_place": {
            "rule": "still-frames",
            "groups": 2,
            "grouped_frames": 5,
            "query_groups": 1,
            "query_grouped_frames": 3,
            "queries_changed": 4,
        },
    }
    tiny.meta["ground_truth_rule"] = rule
    result = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=False)
    save_results(result, tmp_path)
    said = (
        "Accepted sets closed over the same-place groups (still-frames): 2 in the reference "
        "(5 frames), 1 in the query (3 frames); 4 queries changed."
    )
    assert said in write_report(tmp_path).read_text()
    assert said in (tmp_path / "report.md").read_text()
    tiny.meta["ground_truth_rule"] = {"kind": "frames", "same_place": {"rule": "off"}}
    save_results(run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny), tmp_path)
    assert "closed over" not in write_report(tmp_path).read_text()
