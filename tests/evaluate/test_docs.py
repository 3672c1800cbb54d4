"""docs/evaluate-cli.md stays exact: its column table is the report's definitions, and its
"Result files" section names every file, array and field a results folder holds."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from ppaloc.evaluate.columns import COLUMNS
from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.results import CSV_COLUMNS, save_results
from ppaloc.evaluate.run import run_evaluation

DOC = Path(__file__).resolve().parents[2] / "docs" / "evaluate-cli.md"


def _section(title: str, end: str) -> str:
    text = DOC.read_text()
    return text[text.index(title) : text.index(end, text.index(title))]


def _row(column) -> str:
    def esc(t: str) -> str:
        return t.replace("|", "\\|")

    field = f"`{column.field}`" if column.field else "-"
    recall = "the run's (A, B or C)" if column.recall else "-"
    cells = [esc(column.header), field, column.unit, recall, esc(column.definition)]
    return "| " + " | ".join(cells) + " |"


def test_the_column_table_is_the_reports_definitions():
    metrics = _section("## Metrics", "## How a run works")
    rows = [line for line in metrics.splitlines() if line.startswith("| ")]
    start = rows.index("| column | `results.json` field | unit | recall definition | definition |")
    assert rows[start + 1 :] == [_row(c) for c in COLUMNS]


@pytest.fixture
def folder(mean_match, standin, monkeypatch, tiny, tmp_path) -> Path:
    other = standin.register(monkeypatch, "mean-match-shifted", offset=1, modelled=True)
    cfg = EvaluateConfig(methods=(mean_match, other))
    save_results(run_evaluation(cfg, dataset=tiny, progress=False), tmp_path / "run")
    return tmp_path / "run"


def test_result_files_names_every_array_and_field(folder):
    doc = _section("## Result files", "## The report")
    named = set(re.findall(r"`([A-Za-z_][A-Za-z0-9_.]*)`", doc))
    named |= set(re.findall(r'"([A-Za-z_][A-Za-z0-9_]*)":', doc))  # keys of the example
    summary = json.loads((folder / "results.json").read_text())
    fields = set(summary) - {"created"}
    for entry in summary["methods"].values():
        fields |= set(entry)
    missing = sorted(f for f in fields if f not in named)
    assert not missing, f"results.json fields not in docs' Result files: {missing}"
    members = set()
    for path in (folder / "arrays").glob("*.npz"):
        with np.load(path) as z:
            members |= {m for m in z.files if not re.fullmatch(r"plane\d+", m)}
    missing = sorted(m for m in members if m not in named)
    assert not missing, f"arrays not in docs' Result files: {missing}"
    assert {"frame_index", "difference", "query_index", "reference_index"} <= named
    assert "`arrays/_difference.npz`" in doc or "<code>arrays/_difference.npz</code>" in doc


def test_result_files_lists_the_csv_columns_in_order():
    doc = _section("<summary><code>results.csv</code>", "</details>")
    listed = re.search(r"columns: `([^`]+)`", doc, re.S).group(1)
    assert [c.strip() for c in listed.replace("\n", " ").split(",")] == CSV_COLUMNS
