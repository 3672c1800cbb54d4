"""The turning flags in a results folder: saved, read back, split in the table and figure."""

import json

import numpy as np
import pytest

from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.figures import position_along_route, turning_spans
from ppaloc.evaluate.report import comparison_table, write_report
from ppaloc.evaluate.results import load_results, save_results
from ppaloc.evaluate.run import run_evaluation

TURNING = np.array([False, False, True, True, True, False, False, True, False, False])


@pytest.fixture
def turned(tiny):
    tiny.meta["query_turning"] = TURNING.copy()
    tiny.meta["reference_turning"] = np.roll(TURNING, 1)
    return tiny


def test_flags_round_trip_and_split_metrics(mean_match, turned, tmp_path):
    result = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=turned, progress=False)
    assert np.array_equal(result.query_turning, TURNING)
    save_results(result, tmp_path)
    back, summary = load_results(tmp_path)
    assert back.query_turning.dtype == bool
    assert np.array_equal(back.query_turning, TURNING)
    assert np.array_equal(back.reference_turning, np.roll(TURNING, 1))
    m, m_back = result.runs[mean_match].metrics, back.runs[mean_match].metrics
    assert m.f1_max_turning is not None and m.f1_max_straight is not None
    assert (m_back.f1_max_straight, m_back.f1_max_turning) == (m.f1_max_straight, m.f1_max_turning)
    assert summary["methods"][mean_match]["f1_max_turning"] == pytest.approx(m.f1_max_turning)
    header, rows = comparison_table(summary)
    assert header[2:5] == ["F1 max", "F1 straight", "F1 turning"]
    assert rows[0][4] == f"{m.f1_max_turning:.3f}"
    short, _ = comparison_table(summary, short=True)
    assert len(short) == len(header)
    csv = (tmp_path / "results.csv").read_text().splitlines()
    assert csv[0].endswith(",f1_max_straight,f1_max_turning,database,query")
    assert (
        position_along_route(back).axes[0].get_title().endswith(f"turning {m.f1_max_turning:.2f}")
    )
    report = write_report(tmp_path).read_text()
    assert "F1 turning" in report and "Shaded bands" in report


def test_old_folder_without_flags_loads(mean_match, tiny, tmp_path):
    save_results(
        run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=tiny, progress=False),
        tmp_path,
    )
    ds = dict(np.load(tmp_path / "arrays" / "_dataset.npz"))
    assert "query_turning" not in ds
    summary = json.loads((tmp_path / "results.json").read_text())
    for m in summary["methods"].values():  # as written before the split existed
        m.pop("f1_max_straight"), m.pop("f1_max_turning")
    (tmp_path / "results.json").write_text(json.dumps(summary))
    back, summary = load_results(tmp_path)
    assert back.query_turning is None and back.reference_turning is None
    assert back.runs[mean_match].metrics.f1_max_turning is None
    assert "F1 straight" not in comparison_table(summary)[0]
    assert write_report(tmp_path).is_file()


def test_spans():
    assert turning_spans(TURNING) == [(2, 4), (7, 7)]
    assert turning_spans(np.ones(3, bool)) == [(0, 2)]
    assert turning_spans(np.zeros(3, bool)) == []


def test_tiny_route_with_turns_renders(mean_match, tmp_path):
    cfg = EvaluateConfig(
        dataset="synthetic:?turns=3&places=40&seed=2&size=32", methods=(mean_match,)
    )
    result = run_evaluation(cfg, progress=False)
    assert result.query_turning is not None and result.query_turning.any()
    save_results(result, tmp_path)
    back, _ = load_results(tmp_path)
    assert np.array_equal(back.query_turning, result.query_turning)
    assert write_report(tmp_path).is_file()
    assert (tmp_path / "figures" / "position.png").stat().st_size > 0


def test_the_printed_table_says_what_its_turning_columns_are(mean_match, turned, tmp_path, capsys):
    # the columns "F1 str." and "F1 turn" were printed without a word on what they are
    from ppaloc.cli.commands import print_results_table

    legend = "F1 str., F1 turn = max F1 of the straight and of the turning query frames alone;"
    for shown in (True, False):
        if not shown:  # the same route without its turning flags
            del turned.meta["query_turning"], turned.meta["reference_turning"]
        run = run_evaluation(EvaluateConfig(methods=(mean_match,)), dataset=turned, progress=False)
        folder = tmp_path / str(shown)
        save_results(run, folder)
        print_results_table(load_results(folder)[1])
        out = capsys.readouterr().out
        assert ("F1 str." in out) is shown and (legend in out) is shown
