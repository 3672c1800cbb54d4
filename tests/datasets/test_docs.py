"""docs/ground-truth.md's worked example runs as written and prints what it shows."""

from __future__ import annotations

import contextlib
import io
import json
import re
import shlex
from pathlib import Path

import numpy as np
from PIL import Image

DOC = Path(__file__).resolve().parents[2] / "docs" / "ground-truth.md"
TEXT = DOC.read_text()
EXAMPLE = TEXT.split("## A worked example", 1)[1]


def _files() -> dict[str, str]:
    """The files the example shows: a line `` `path`: `` and the ```csv block after it."""
    return dict(re.findall(r"^`([^`]+)`[^\n]*:\n\n```csv\n(.*?)```", EXAMPLE, flags=re.S | re.M))


def _build(root: Path) -> None:
    """The folder of the example: its CSV files, and one stand-in image per frame named."""
    for rel, body in _files().items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(body)
    for traversal, csv in (("ref", "ref.csv"), ("query", "query.csv")):
        folder = root / "my-route" / traversal
        folder.mkdir(parents=True, exist_ok=True)
        names = [line.split(",")[0] for line in (root / "my-route" / csv).read_text().split()[1:]]
        for k, name in enumerate(names):
            Image.fromarray(np.full((48, 64), 20 + 25 * k, np.uint8)).save(folder / name)


def test_the_example_shows_every_file_it_reads():
    assert set(_files()) == {
        "my-route/ref.csv", "my-route/query.csv", "my-route/hard.csv", "my-route/soft.csv"
    }  # fmt: skip


def test_the_worked_example_runs_and_prints_what_it_shows(tmp_path, monkeypatch, capsys):
    _build(tmp_path)
    monkeypatch.chdir(tmp_path)
    pairs = re.findall(r"```python\n(.*?)```\n\n```text\n(.*?)```", EXAMPLE, flags=re.S)
    assert len(pairs) == 2
    namespace: dict = {}
    for k, (code, shown) in enumerate(pairs):
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            exec(compile(code, f"ground-truth.md python block {k}", "exec"), namespace)
        assert printed.getvalue().strip() == shown.strip(), f"block {k}"
    (command,) = re.findall(r"```console\n\$ (.*?)\n```", EXAMPLE, flags=re.S)
    from ppaloc.cli import main

    args = shlex.split(command)
    assert args[0] == "ppaloc"
    assert main([*args[1:], "--quiet"]) == 0, capsys.readouterr().err
    summary = json.loads((tmp_path / "my-results" / "results.json").read_text())
    assert summary["roles"] == {
        "database": "images in my-route/ref", "query": "images in my-route/query"
    }  # fmt: skip
    assert summary["n_queries"] == 6
    assert summary["protocol"]["ground_truth"]["tolerance_unit"] == "metres"
    report = (tmp_path / "my-results" / "report.md").read_text()
    assert "(5 with a true match), tolerance 25.0 m." in report
    assert "Database: images in my-route/ref; query: images in my-route/query." in report
