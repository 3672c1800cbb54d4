"""Tiny hand-made results (5 queries, 6 reference frames, two methods): what the folder
holds, the report drawn from its files only, and folders of the older format read."""

from __future__ import annotations

import base64
import io
import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.errors import DataError
from ppaloc.evaluate.columns import COLUMNS, column_of
from ppaloc.evaluate.report import comparison_table, paper_table, write_report
from ppaloc.evaluate.results import RESULTS_FORMAT, load_results, save_results, upgrade_summary
from ppaloc.evaluate.run import MethodRun, RunResult, method_metrics

GT = [[0], [1, 2], [3], [4], []]
"""Accepted reference frames of the five queries (the last has no true match)."""

IMG = re.compile(r"<img src='data:image/png;base64,([A-Za-z0-9+/=]+)' alt='([^']*)'>")


def method(name: str, ref_index, score, frame_index, weights=None) -> MethodRun:
    gt = PackedSets.from_sets([np.array(g, np.int64) for g in GT])
    ref_index = np.array(ref_index, np.int64)
    score = np.array(score, np.float64)
    ranking = ref_index[:, None].copy()
    frame_index = np.array(frame_index, np.int64)
    node = np.searchsorted(frame_index, ref_index, side="right") - 1  # the node's own frame
    return MethodRun(
        method=name,
        params={},
        map_kind="lbp" if name == "beta" else "single-frame",
        n_nodes=len(frame_index),
        build_s=0.5,
        node=node,
        ref_index=ref_index,
        score=score,
        moved=np.full(5, -1, np.int8),
        ranking=ranking,
        latency_ms=np.array([1.0, 2.0, 3.0, 4.0, 5.0]),
        metrics=method_metrics(ref_index, score, gt, ranking, recall="A"),
        weights=weights,
    )


@pytest.fixture
def folder(tmp_path) -> Path:
    weights = np.arange(20, dtype=np.float32).reshape(5, 4)
    runs = {
        # one node per reference frame: q0..q2 right, q3 wrong, q4 has no match
        "alpha": method("alpha", [0, 2, 3, 1, 5], [0.9, 0.8, 0.7, 0.6, 0.1], range(6)),
        # a keyframe map: 4 nodes standing for frames 0-1, 2, 3-4, 5
        "beta": method("beta", [0, 2, 3, 5, 5], [0.5, 0.5, 0.4, 0.9, 0.2], [0, 2, 3, 5], weights),
    }
    result = RunResult(
        dataset="tiny:golden",
        dataset_name="golden",
        tolerance=0,
        ground_truth=PackedSets.from_sets([np.array(g, np.int64) for g in GT]),
        n_reference=6,
        runs=runs,
    )
    save_results(result, tmp_path / "golden")
    return tmp_path / "golden"


def test_the_folder_holds_the_golden_numbers(folder):
    summary = json.loads((folder / "results.json").read_text())
    assert summary["format"] == RESULTS_FORMAT == 2
    alpha, beta = summary["methods"]["alpha"], summary["methods"]["beta"]
    # alpha: correct q0-q2 of 5 queries; max F1 at threshold 0.7 (P 1, R 3/4 under A)
    assert alpha["precision_at_100r"] == pytest.approx(0.6)
    assert (alpha["f1_max"], alpha["threshold_at_f1"]) == (pytest.approx(6 / 7), 0.7)
    assert alpha["recall_at_100p"] == pytest.approx(0.75)
    # beta: its most confident query is wrong, so no threshold has precision 1
    assert beta["precision_at_100r"] == pytest.approx(0.6)
    assert (beta["f1_max"], beta["threshold_at_f1"], beta["recall_at_100p"]) == (0.75, 0.4, 0)
    assert "accuracy" not in alpha
    csv_header = (folder / "results.csv").read_text().splitlines()[0].split(",")
    assert csv_header[6] == "precision_at_100r"  # where accuracy was: readers by position


def test_the_report_from_files_only(folder, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    page = write_report(copy).read_text()
    titles = [alt for _, alt in IMG.findall(page)]
    assert titles[:2] == ["Precision-recall curves", "Position estimate along the route"]
    for data, _ in IMG.findall(page):
        Image.open(io.BytesIO(base64.b64decode(data))).load()
    assert "P @100%R" in page and "Accuracy" not in page
    assert "<th>Recall definition</th>" in page


def test_every_column_the_tables_show_has_a_definition(folder):
    summary = json.loads((folder / "results.json").read_text())
    summary["methods"]["alpha"]["f1_max_turning"] = 0.5  # the turning columns shown too
    summary["methods"]["beta"]["map_kind"] = "lowres"
    headers = comparison_table(summary)[0] + paper_table(summary)[0]
    from ppaloc.evaluate.report import _extra_table

    headers += _extra_table(summary)[0]
    undefined = [h for h in headers if column_of(h) is None]
    assert not undefined, f"columns without a definition: {undefined}"
    assert {column_of(h) for h in headers} == set(COLUMNS)  # and nothing defined in vain
    page = write_report(folder).read_text()
    for column in {column_of(h) for h in comparison_table(summary)[0]} - {None}:
        if column.header in ("F1 straight", "F1 turning"):
            continue  # this folder's own summary has no turning split
        assert f"<td>{column.header}</td>" in page.replace("&#x27;", "'"), column.header


def _as_format_1(folder: Path) -> None:
    """Rewrite a folder as format 1 wrote it: no format, `accuracy`."""
    summary = json.loads((folder / "results.json").read_text())
    del summary["format"]
    for entry in summary["methods"].values():
        entry["accuracy"] = entry.pop("precision_at_100r")
    (folder / "results.json").write_text(json.dumps(summary))


def test_a_format_1_folder_is_read_under_todays_names(folder, capsys):
    _as_format_1(folder)
    raw = json.loads((folder / "results.json").read_text())
    assert comparison_table(raw)[1][0][7] == "0.600"  # the printed table of `ppaloc show`
    result, summary = load_results(folder)
    assert summary["methods"]["alpha"]["precision_at_100r"] == pytest.approx(0.6)
    assert result.runs["alpha"].metrics.precision_at_100r == pytest.approx(0.6)
    page = write_report(folder).read_text()
    assert ">0.600</td>" in page and "P @100%R" in page

    from ppaloc.cli import main

    assert main(["show", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "P@100R" in out and "0.600" in out


@pytest.mark.parametrize(
    ("version", "message"),
    [
        (3, r"is in results format 3, newer than this ppaloc .* reads \(1 to 2\); read it"),
        ("2", r"is in results format '2', not one ppaloc writes \(1 to 2\)"),
        (0, r"is in results format 0, not one ppaloc writes"),
    ],
)
def test_an_unknown_format_is_refused_in_one_line(folder, version, message, capsys):
    summary = json.loads((folder / "results.json").read_text())
    summary["format"] = version
    (folder / "results.json").write_text(json.dumps(summary))
    with pytest.raises(DataError, match=rf"^{folder / 'results.json'} {message}"):
        load_results(folder)
    from ppaloc.cli import main

    assert main(["show", str(folder), "-q"]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "results format" in err


def test_upgrade_leaves_the_given_summary_alone():
    old = {"dataset": "d", "methods": {"m": {"accuracy": 0.5, "f1_max": 0.1}}}
    new = upgrade_summary(old)
    assert new["methods"]["m"] == {"f1_max": 0.1, "precision_at_100r": 0.5}
    assert old == {"dataset": "d", "methods": {"m": {"accuracy": 0.5, "f1_max": 0.1}}}
    assert upgrade_summary(new) is new


def test_a_sweep_reads_a_format_1_cell_under_todays_names(folder):
    from types import SimpleNamespace

    from ppaloc.evaluate.sweep_grid import cell_status

    _as_format_1(folder)
    cell = SimpleNamespace(folder=folder.name, method="alpha")
    status, results = cell_status(folder.parent, cell)
    assert status == "ok" and results["methods"]["alpha"]["precision_at_100r"] == 0.6
    summary = json.loads((folder / "results.json").read_text())
    summary["format"] = 7
    (folder / "results.json").write_text(json.dumps(summary))
    status, results = cell_status(folder.parent, cell)
    assert results is None and "results format 7, newer than this ppaloc" in status
