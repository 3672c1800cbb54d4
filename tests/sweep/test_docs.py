"""docs/sweep.md: its TOML files are valid sweeps (checked as `ppaloc sweep` checks them
before any cell runs), the refusal it shows is the real message, and its Python runs."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest

from ppaloc.errors import PpalocError
from ppaloc.evaluate.sweep import expand, sweep_config_from_mapping, validate

DOC = Path(__file__).resolve().parents[2] / "docs" / "sweep.md"
TEXT = DOC.read_text()
TOML = re.findall(r"```toml\n(.*?)```", TEXT, re.S)
PYTHON = re.findall(r"```python\n(.*?)```", TEXT, re.S)


def _config(block: str):
    return sweep_config_from_mapping(tomllib.loads(block)["sweep"], source="sweep.md")


@pytest.mark.parametrize(
    ("index", "cells"), [(0, 6), (1, 60), (2, 384)], ids=["issue", "gain", "robust"]
)
def test_the_toml_files_are_valid_sweeps_of_the_size_the_page_says(index, cells):
    assert len(TOML) == 3
    config = _config(TOML[index])
    grid = expand(config)
    validate(config, grid)
    assert len(grid) == cells
    assert f"{cells} cells" in TEXT or cells == 6


def test_the_refusal_shown_for_gamma_on_the_robust_filter_is_the_real_one():
    block = TOML[0].replace("weighted-node-paper-lbp", "weighted-node-lbp")
    config = _config(block)
    with pytest.raises(PpalocError) as info:
        validate(config, expand(config), source="sweep.toml")
    assert f"ppaloc: error: {info.value}\n" in TEXT


def test_the_python_example_runs(tmp_path, monkeypatch, capsys):
    # as a script: its run under the __main__ guard Dask's spawned workers need
    (block,) = PYTHON
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}
    exec(compile(block, "docs/sweep.md python block", "exec"), namespace)
    assert (namespace["outcome"].n_run, namespace["outcome"].n_failed) == (3, 0)
    assert capsys.readouterr().out.splitlines()[0] == "3 0"  # as its comment says
    assert (tmp_path / "sweep-py" / "report.html").is_file()


def test_the_refusal_shown_for_a_users_file_in_figures_is_the_real_one(tmp_path, monkeypatch):
    from ppaloc.evaluate.sweep import check_sweep_folder

    (tmp_path / "sweep1" / "cells").mkdir(parents=True)
    (tmp_path / "sweep1" / "figures").mkdir()
    (tmp_path / "sweep1" / "figures" / "notes.txt").write_text("keep me")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(PpalocError) as info:
        check_sweep_folder(Path("sweep1"))
    assert f"`{info.value}`" in " ".join(TEXT.split())


def test_the_first_examples_table_shows_what_its_cells_score():
    # the page's seqslam rows had gone stale: the table is the sweep's, cell by cell
    from ppaloc.evaluate.config import EvaluateConfig
    from ppaloc.evaluate.run import run_evaluation

    sweep = tomllib.loads(TOML[0])["sweep"]
    table = TEXT.split("$ ppaloc sweep --config sweep.toml --out gamma\n", 1)[1]
    rows = re.findall(r"^ (\S+) +seed=(\d) +([\d.]+) +([\d.]+) +(\S+) +\d/\d$", table, re.M)
    assert len(rows) == 4
    for method, seed, f1, auc, swept in rows:
        (dataset,) = [d for d in sweep["datasets"] if d.endswith(f"seed={seed}")]
        key, _, value = swept.partition("=")
        params = {} if swept == "-" else {method: {key: tomllib.loads(f"v = {value}")["v"]}}
        config = EvaluateConfig(
            dataset=dataset,
            methods=(method,),
            tolerance=sweep["tolerance"],
            params=params,
            record_weights=False,
        )
        metrics = run_evaluation(config, progress=False).runs[method].metrics
        assert (f"{metrics.f1_max:.3f}", f"{metrics.auc:.3f}") == (f1, auc), (method, seed)
