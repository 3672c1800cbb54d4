"""Sweeps on a LocalCluster of 2 workers: end to end, failed cells, a killed worker, resume
after an interruption (Ctrl-C included), and the same metrics on 1 and 2 workers."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from ppaloc.cli import main
from ppaloc.evaluate.results import load_results
from ppaloc.evaluate.sweep import METRIC_COLUMNS, SweepConfig, expand, run_sweep
from ppaloc.evaluate.sweep_report import write_sweep_report

TINY = ("synthetic:?places=20&seed=1&size=64", "synthetic:?places=20&seed=2&size=64")
TIMING = {"latency_ms_median", "latency_ms_p95", "build_s"}
"""Columns measured on the host: the only ones that may differ between two runs."""


def read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def results_files(out: Path) -> dict[str, float]:
    """Every cell's results.json and its modification time."""
    return {str(p.relative_to(out)): p.stat().st_mtime_ns for p in out.glob("cells/*/results.json")}


def test_the_issue_grid_end_to_end_through_the_command(capsys, tmp_path, cluster2, issue_toml):
    out = tmp_path / "sweep"
    address = cluster2.scheduler.address
    code = main(["sweep", "--config", str(issue_toml), "--out", str(out), "--scheduler", address])
    stdout, err = capsys.readouterr()
    assert code == 0, err
    assert "Best cell per method and dataset" in stdout
    assert "6 cells: 0 already done, 6 run now, 6 finished, 0 failed" in stdout
    rows = read_csv(out / "summary.csv")
    assert list(rows[0]) == ["method", "dataset", "gamma", *METRIC_COLUMNS, "status", "cell"]
    assert [(r["method"], r["dataset"], r["gamma"], r["status"]) for r in rows] == [
        ("weighted-node-paper-lbp", TINY[0], "0.25", "ok"),
        ("weighted-node-paper-lbp", TINY[0], "0.5", "ok"),
        ("seqslam", TINY[0], "", "ok"),
        ("weighted-node-paper-lbp", TINY[1], "0.25", "ok"),
        ("weighted-node-paper-lbp", TINY[1], "0.5", "ok"),
        ("seqslam", TINY[1], "", "ok"),
    ]
    for row in rows:  # each cell is a results folder of `ppaloc evaluate`, read back whole
        result, summary = load_results(out / row["cell"])
        entry = summary["methods"][row["method"]]
        assert float(row["f1_max"]) == entry["f1_max"] == result.runs[row["method"]].metrics.f1_max
        assert float(row["auc"]) == entry["auc"]
        assert summary["tolerance"] == 2
        assert entry["params"].get("gamma") == (float(row["gamma"]) if row["gamma"] else None)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["counts"] == {"cells": 6, "ok": 6, "failed": 0, "not_run": 0}
    assert [r["f1_max"] for r in summary["cells"]] == [float(r["f1_max"]) for r in rows]
    page = (out / "report.html").read_text()
    assert page.count("<img src='data:image/png;base64,") == 2  # method x dataset, gamma x dataset
    assert "Best cell per method and dataset" in page
    assert "weighted-node-paper-lbp: max F1 over gamma x dataset" in page

    before = results_files(out)
    code = main(["sweep", "--config", str(issue_toml), "--out", str(out), "--scheduler", address])
    stdout, _ = capsys.readouterr()
    assert code == 0
    assert "6 cells: 6 already done, 0 run now, 6 finished, 0 failed" in stdout
    assert results_files(out) == before  # nothing redone


def test_a_failed_cell_is_recorded_and_the_others_go_on(capsys, tmp_path, cluster2):
    out = tmp_path / "sweep"
    missing = tmp_path / "no-such-folder"
    toml = tmp_path / "sweep.toml"
    toml.write_text(
        "[sweep]\n"
        'methods = ["seqslam", "single-frame"]\n'
        f'datasets = ["{TINY[0]}", "folder:{missing}/ref,{missing}/query"]\n'
    )
    args = ["sweep", "--config", str(toml), "--out", str(out)]
    code = main([*args, "--scheduler", cluster2.scheduler.address, "-q"])
    _, err = capsys.readouterr()
    assert code == 1
    assert err.startswith("ppaloc: error: 2 of 4 cells failed, the first (seqslam on folder:")
    assert err.count("\n") == 1
    rows = read_csv(out / "summary.csv")
    assert [r["status"] for r in rows[:2]] == ["ok", "ok"]
    for row in rows[2:]:
        assert str(missing) in row["status"] and "\n" not in row["status"]
        assert row["f1_max"] == ""
        error = json.loads((out / row["cell"] / "error.json").read_text())
        assert error["error"] == row["status"]
        assert not (out / row["cell"] / "results.json").exists()
    assert "Failed cells" in (out / "report.html").read_text()

    before = results_files(out)  # a second run retries the failed cells only
    code = main([*args, "--scheduler", cluster2.scheduler.address, "-q"])
    capsys.readouterr()
    assert code == 1
    assert results_files(out) == before


def test_resume_after_an_interruption_runs_only_the_missing_cells(tmp_path, cluster2, issue_config):
    out = tmp_path / "sweep"
    finished = []

    def interrupt_after_two(cell, status):
        finished.append(cell.id)
        if len(finished) == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_sweep(issue_config, out, client=cluster2, on_cell=interrupt_after_two)
    rows = json.loads((out / "summary.json").read_text())["cells"]
    done = {r["cell"] for r in rows if r["status"] == "ok"}
    assert done == {f"cells/{c.method}-{c.id}" for c in expand(issue_config) if c.id in finished}
    assert sum(r["status"] == "not run" for r in rows) == 4
    before = results_files(out)
    assert len(before) == 2

    again = []
    outcome = run_sweep(issue_config, out, client=cluster2, on_cell=lambda c, s: again.append(c.id))
    assert (outcome.n_skipped, outcome.n_run, outcome.n_failed) == (2, 4, 0)
    assert sorted(again + finished) == sorted(c.id for c in expand(issue_config))
    after = results_files(out)
    assert {k: after[k] for k in before} == before  # the finished cells were not touched
    assert outcome.summary["counts"]["ok"] == 6


def test_ctrl_c_while_a_cells_folder_goes_in_stops_the_sweep_after_it(
    tmp_path, cluster2, issue_config, monkeypatch
):
    # the cell's transaction held the Ctrl-C (its folder is a result) and the sweep lost
    # it: it ran on to its end and exited 0
    import contextlib

    from ppaloc import fileio

    real, calls = fileio._sigint_held, []

    @contextlib.contextmanager
    def held():
        with real() as came:
            yield came
            if not calls:  # Ctrl-C as the first cell's folder takes its place
                calls.append(1)
                came.append(True)

    monkeypatch.setattr(fileio, "_sigint_held", held)
    finished = []
    with pytest.raises(KeyboardInterrupt):
        run_sweep(
            issue_config,
            tmp_path / "sweep",
            client=cluster2,
            on_cell=lambda c, s: finished.append(c),
        )
    rows = json.loads((tmp_path / "sweep" / "summary.json").read_text())["cells"]
    assert sum(r["status"] == "ok" for r in rows) == 1 and len(finished) == 0


def test_one_and_two_workers_give_the_same_metrics(tmp_path, cluster2, make_cluster):
    config = SweepConfig(
        methods=("particle-filter", "weighted-node-paper-lbp"),
        datasets=TINY,
        params={"particle-filter": {"n_particles": [50, 100]}, "weighted-node-paper-lbp": {}},
        seed=[0, 3],
    )
    two = run_sweep(config, tmp_path / "two", client=cluster2).summary
    with make_cluster(1, processes=False) as one_worker:
        one = run_sweep(config, tmp_path / "one", client=one_worker).summary

    def metrics(summary):
        return [{k: v for k, v in r.items() if k not in TIMING} for r in summary["cells"]]

    assert all(r["status"] == "ok" for r in one["cells"])
    assert metrics(one) == metrics(two)
    seeds = {r["seed"]: r["f1_max"] for r in one["cells"] if r["method"] == "particle-filter"}
    assert len(seeds) == 2  # the seed reaches the particle filter


def test_a_worker_killed_mid_sweep_loses_no_cell(tmp_path, make_cluster):
    config = SweepConfig(
        methods=("weighted-node-paper-lbp", "seqslam"),
        datasets=("synthetic:?places=40&seed=3&size=64",),
        params={"weighted-node-paper-lbp": {"gamma": [0.125, 0.25, 0.5, 1.0]}, "seqslam": {}},
    )
    out = tmp_path / "sweep"
    killed = []
    with make_cluster(2, processes=True) as client:

        def kill_a_busy_worker(cell, status):
            if killed:
                return
            busy = [addr for addr, keys in client.processing().items() if keys]
            if not busy:
                return
            pid = client.run(os.getpid, workers=busy[:1])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

        outcome = run_sweep(config, out, client=client, on_cell=kill_a_busy_worker)
        assert killed, "no worker was busy after the first cell"
        deadline = time.monotonic() + 60  # a nanny restarts it slowly on a loaded machine
        while killed[0] in client.run(os.getpid).values() and time.monotonic() < deadline:
            time.sleep(0.1)
        assert killed[0] not in client.run(os.getpid).values()
    assert (outcome.n_run, outcome.n_failed) == (5, 0)
    rows = outcome.summary["cells"]
    assert [r["status"] for r in rows] == ["ok"] * 5
    for row in rows:  # every cell intact: its results.json parses and its arrays load
        result, _ = load_results(out / row["cell"])
        assert result.runs[row["method"]].metrics.f1_max == row["f1_max"]


@contextmanager
def _own_group(command: list[str], cwd: Path) -> Iterator[subprocess.Popen]:
    """Run ``command`` in a process group of its own, as a terminal's foreground job (what
    Ctrl-C reaches), its output piped; the group is killed if it is still running after."""
    proc = subprocess.Popen(
        command,
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        yield proc
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def _finished_cells(out: Path) -> list[Path]:
    """Cell folders with a results file, not the hidden staging folder a cell is written
    in before it replaces its target (``fileio.new_folder``): a cell there is not done."""
    return [p for p in out.glob("cells/*/results.json") if not p.parent.name.startswith(".")]


@pytest.mark.slow
def test_ctrl_c_stops_the_sweep_cleanly_and_a_second_run_finishes_it(
    tmp_path, cluster2, ppaloc_command, signal_state
):
    import psutil

    out = tmp_path / "sweep"
    config = SweepConfig(  # 12 cells on 60-place routes: a few seconds, interrupted early
        methods=("weighted-node-paper-lbp", "seqslam"),
        datasets=tuple(d.replace("places=20", "places=60") for d in TINY),
        tolerance=2,
        params={"weighted-node-paper-lbp": {"gamma": [0.0, 0.125, 0.25, 0.5, 1]}},
    )
    toml = tmp_path / "long.toml"
    toml.write_text(
        "[sweep]\n"
        'methods = ["weighted-node-paper-lbp", "seqslam"]\n'
        f"datasets = {json.dumps(list(config.datasets))}\n"
        "tolerance = 2\n"
        "[sweep.params.weighted-node-paper-lbp]\n"
        "gamma = [0.0, 0.125, 0.25, 0.5, 1]\n"
    )
    args = ["sweep", "--config", str(toml), "--out", str(out), "--workers", "2"]
    with _own_group([*ppaloc_command, *args], tmp_path) as proc:
        deadline = time.monotonic() + 60
        while not _finished_cells(out) and time.monotonic() < deadline:
            assert proc.poll() is None, proc.communicate()
            time.sleep(0.05)
        children = psutil.Process(proc.pid).children(recursive=True)
        state = signal_state(proc.pid)  # for the message, should the signal not arrive
        os.killpg(proc.pid, signal.SIGINT)  # what Ctrl-C does: the whole foreground group
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, f"[signals of the child: {state}]\n{err}"
    assert err.strip().splitlines()[-1] == "ppaloc: interrupted"
    assert "Traceback" not in err
    _, alive = psutil.wait_procs(children, timeout=10)
    assert not alive, f"processes left behind: {alive}"
    rows = read_csv(out / "summary.csv")
    ok = [r for r in rows if r["status"] == "ok"]
    assert ok and len(ok) < 12 and all(r["status"] in ("ok", "not run") for r in rows)
    before = results_files(out)
    assert len(before) == len(ok)

    outcome = run_sweep(config, out, client=cluster2)
    assert (outcome.n_skipped, outcome.n_run, outcome.n_failed) == (len(ok), 12 - len(ok), 0)
    after = results_files(out)
    assert {k: after[k] for k in before} == before


def test_a_users_file_inside_figures_or_a_cell_is_refused(tmp_path, cluster2, capsys):
    out = tmp_path / "sweep"
    args = ["sweep", "-m", "seqslam", "-d", TINY[0], "-d", TINY[1], "--out", str(out)]
    args += ["--scheduler", cluster2.scheduler.address]
    assert main(args) == 0
    assert main(args) == 0  # its own cells, summaries and figures: a re-run is accepted
    capsys.readouterr()
    cell = sorted(p.relative_to(out) for p in out.glob("cells/*"))[0].as_posix()
    assert (out / "figures" / "heatmap-1.png").is_file() and (out / cell / "arrays").is_dir()
    for mine in ("figures/notes.txt", f"{cell}/notes.txt", f"{cell}/arrays/mine.npz"):
        (out / mine).write_text("keep me")
        assert main(args) == 1
        err = capsys.readouterr().err
        assert f"holds {mine!r}, which a sweep did not write" in err, err
        assert len(err.splitlines()) == 1 and (out / mine).read_text() == "keep me"
        (out / mine).unlink()
    assert main(args) == 0


def test_the_report_is_rebuilt_from_the_summary_alone(tmp_path, cluster2, issue_config):
    out = tmp_path / "sweep"
    run_sweep(issue_config, out, client=cluster2)
    for cell in (out / "cells").iterdir():  # the report needs summary.json only
        for f in cell.rglob("*"):
            if f.is_file():
                f.unlink()
    page = write_sweep_report(out).read_text()
    assert page.count("<img src='data:image/png;base64,") == 2
    assert (out / "report.md").read_text().count("](figures/heatmap-") == 2


#: ``ppaloc`` from a shell (tests/conftest.py), with Ctrl-C pressed while the local cluster
#: starts: its workers run, their IgnoreSigint plugin is not registered yet.
CTRL_C_AT_START = (
    "import os, signal, sys; signal.pthread_sigmask(signal.SIG_SETMASK, ()); "
    "signal.signal(signal.SIGINT, signal.default_int_handler); "
    "import distributed; real = distributed.Client.__init__\n"
    "def init(self, *args, **kwargs):\n"
    "    distributed.Client.__init__ = real\n"
    "    os.killpg(0, signal.SIGINT)\n"
    "    real(self, *args, **kwargs)\n"
    "distributed.Client.__init__ = init\n"
    "from ppaloc.cli import main; sys.exit(main())"
)


def test_ctrl_c_while_the_local_cluster_starts_is_one_line(tmp_path):
    args = ["sweep", "-m", "seqslam", "-d", TINY[0], "--workers", "2", "--out", "s"]
    with _own_group([sys.executable, "-c", CTRL_C_AT_START, *args], tmp_path) as proc:
        _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert err.strip() == "ppaloc: interrupted", err  # no worker's traceback, no atexit error


@pytest.mark.parametrize("quiet", [True, False])
def test_a_sweep_quiets_the_clusters_loggers_and_restores_them(quiet):
    """Ctrl-C can stop the cluster's event loop mid-callback, and tornado then logs the
    callback's traceback: a sweep (without ``-v``) keeps those loggers quiet while it runs,
    and leaves every level as it found it."""
    import logging

    from ppaloc.evaluate.sweep import QUIET_LOGGERS, _dask_logging

    names = [name for name, _ in QUIET_LOGGERS]
    assert {"distributed", "tornado.application"} <= set(names)
    before = {name: logging.getLogger(name).level for name in names}
    with pytest.raises(KeyboardInterrupt), _dask_logging(quiet=quiet):
        for name, level in QUIET_LOGGERS:
            want = level if quiet else before[name]
            assert logging.getLogger(name).level == want, name
        assert logging.getLogger("tornado.application").isEnabledFor(logging.ERROR) != quiet
        raise KeyboardInterrupt
    assert {name: logging.getLogger(name).level for name in names} == before
