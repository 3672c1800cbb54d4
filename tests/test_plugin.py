"""A method of one's own, registered by a package in the ``ppaloc.methods`` entry-point
group, is offered by every command: the example package of docs/evaluate-cli.md
(``examples/plugin/``), installed in a temporary folder."""

from __future__ import annotations

import csv
import json
import logging
import re
import shutil
import tomllib
from pathlib import Path

import pytest

from ppaloc.methods import available_methods, make_localiser, method_parameters, plugins

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "plugin"
TINY = "synthetic:?places=12&size=32&sync=1&seed=2"


def _install(site: Path, entry_points: dict[str, str], module: Path | None = None) -> None:
    """A package as pip leaves it: its module and a ``.dist-info`` with the entry points."""
    if module is not None:
        shutil.copy(module, site / module.name)
    info = site / "ppaloc_example_plugin-0.1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: ppaloc-example-plugin\nVersion: 0.1.0\n"
    )
    lines = "".join(f"{k} = {v}\n" for k, v in entry_points.items())
    (info / "entry_points.txt").write_text(f"[ppaloc.methods]\n{lines}")


@pytest.fixture
def site(tmp_path, monkeypatch):
    """A folder on ``sys.path`` (and the workers' PYTHONPATH) that packages install into."""
    folder = tmp_path / "site"
    folder.mkdir()
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv("PYTHONPATH", str(folder))
    plugins.cache_clear()
    yield folder
    plugins.cache_clear()


@pytest.fixture
def example(site):
    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())
    _install(
        site, project["project"]["entry-points"]["ppaloc.methods"], EXAMPLE / "ppaloc_thumbnail.py"
    )
    return "thumbnail"


def test_the_docs_show_the_example_package_as_it_is():
    docs = (ROOT / "docs" / "evaluate-cli.md").read_text()
    section = docs[docs.index("## Your own method") :]
    assert (EXAMPLE / "pyproject.toml").read_text() in section
    assert (EXAMPLE / "ppaloc_thumbnail.py").read_text() in section
    code = (EXAMPLE / "ppaloc_thumbnail.py").read_text().splitlines()
    assert len([line for line in code if line.strip()]) <= 30


def test_a_plugin_method_is_offered_with_its_parameters(example):
    assert example in available_methods()
    assert method_parameters(example)["side"].default == 16
    loc = make_localiser(example, side=8)
    assert loc.side == 8


def test_a_plugin_method_runs_in_evaluate_bench_and_a_sweep(example, tmp_path, monkeypatch):
    from ppaloc.cli.main import main

    monkeypatch.chdir(tmp_path)
    args = ["evaluate", "-d", TINY, "-m", example, "-m", "single-frame", "--out", "r", "-q"]
    assert main(args) == 0
    results = json.loads((tmp_path / "r" / "results.json").read_text())
    assert set(results["methods"]) == {example, "single-frame"}
    assert results["methods"][example]["f1_max"] > 0.5
    assert main(["bench", "-m", example, "--sizes", "8,16", "--queries", "2", "-q"]) == 0
    (tmp_path / "s.toml").write_text(
        f'[sweep]\nmethods = ["{example}"]\ndatasets = ["{TINY}"]\n'
        f"[sweep.params.{example}]\nside = [8, 16]\n"
    )
    assert main(["sweep", "--config", "s.toml", "--out", "s", "--workers", "1", "-q"]) == 0
    with (tmp_path / "s" / "summary.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [(r["method"], r["side"], r["status"]) for r in rows] == [
        (example, "8", "ok"),
        (example, "16", "ok"),
    ]


def test_a_wrong_parameter_of_a_plugin_is_one_line(example, capsys):
    from ppaloc.cli.main import main

    assert main(["evaluate", "-d", TINY, "-m", example, "--param", f"{example}.side=x"]) == 1
    err = capsys.readouterr().err
    assert re.search(r"method 'thumbnail': side='x' must be an integer", err)


def test_a_plugin_never_replaces_a_builtin_and_a_broken_one_is_left_out(site, caplog):
    _install(
        site,
        {
            "seqslam": "ppaloc_thumbnail:Thumbnail",
            "missing": "no_such_module_anywhere:Nothing",
            "not-a-class": "json:dumps",
        },
    )
    with caplog.at_level(logging.WARNING, logger="ppaloc.methods"):
        found = plugins()
    assert found == {}
    assert make_localiser("seqslam").name == "seqslam"
    text = caplog.text
    assert "method 'seqslam'" in text and "a method of that name exists" in text
    assert "method 'missing'" in text and "cannot be loaded" in text
    assert "method 'not-a-class'" in text and "not a class or a MethodSpec" in text


def test_ppaloc_methods_lists_a_plugins_parameters(example, site, capsys):
    from ppaloc.cli.main import main

    (site / "ppaloc_needy.py").write_text(
        "class Needy:\n    name = 'needy'\n    def __init__(self, *, k: int) -> None: ...\n"
        "class Loose:\n    name = 'loose'\n    def __init__(self, **kw) -> None: ...\n"
    )
    shutil.rmtree(next(site.glob("*.dist-info")))
    _install(
        site,
        {
            example: "ppaloc_thumbnail:Thumbnail",
            "needy": "ppaloc_needy:Needy",  # cannot be built without k: its declaration
            "loose": "ppaloc_needy:Loose",
        },
    )
    plugins.cache_clear()
    assert main(["methods", example, "needy", "loose"]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line.split() for line in out.splitlines() if line.strip()}
    assert rows["side"][1:3] == ["16", "an"]
    assert rows["k"][1:3] == ["required", "an"]  # "-" said the method chooses it
    assert "\nrequired = the method needs a value given with --param.\n" in out
    assert "  takes any keyword (its class declares no parameters)" in out
