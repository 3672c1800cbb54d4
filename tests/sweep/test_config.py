"""The sweep's grid, its checks before any cell runs, cell ids and the summary (no cluster)."""

from __future__ import annotations

import datetime
import hashlib
import json
import subprocess
import sys
import time

import pytest
from click.testing import CliRunner

from ppaloc.cli import cli, main
from ppaloc.errors import PpalocError
from ppaloc.evaluate.sweep import (
    METRIC_COLUMNS,
    Cell,
    SweepConfig,
    axes,
    cell_status,
    collect_summary,
    expand,
    run_sweep,
    sweep_config_from_mapping,
    validate,
)
from ppaloc.fileio import write_bytes

TINY = ("synthetic:?places=20&seed=1&size=64", "synthetic:?places=20&seed=2&size=64")


def run(capsys, *args: object) -> tuple[int, str, str]:
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


# -- the grid --------------------------------------------------------------------------------


def test_the_issue_grid_has_six_cells_in_dataset_method_parameter_order(issue_config):
    cells = expand(issue_config)
    assert [(c.dataset, c.method, dict(c.axes)) for c in cells] == [
        (TINY[0], "weighted-node-paper-lbp", {"gamma": 0.25}),
        (TINY[0], "weighted-node-paper-lbp", {"gamma": 0.5}),
        (TINY[0], "seqslam", {}),
        (TINY[1], "weighted-node-paper-lbp", {"gamma": 0.25}),
        (TINY[1], "weighted-node-paper-lbp", {"gamma": 0.5}),
        (TINY[1], "seqslam", {}),
    ]
    assert {c.spec for c in cells} == {f"{d}&tolerance=2" for d in TINY}
    assert len({c.id for c in cells}) == 6
    assert axes(issue_config) == {
        "method": ["weighted-node-paper-lbp", "seqslam"],
        "dataset": list(TINY),
        "gamma": [0.25, 0.5],
    }


def test_product_and_one_at_a_time():
    params = {"weighted-node-lbp": {"gain": [1, 2, 4], "memory": [32, 64], "stay_cost": 8}}
    product = expand(SweepConfig(methods=("weighted-node-lbp",), datasets=TINY, params=params))
    assert len(product) == 2 * 3 * 2
    assert all(c.params["stay_cost"] == 8 for c in product)  # a single value is fixed
    assert {tuple(c.axes) for c in product} == {("gain", "memory")}
    each = expand(
        SweepConfig(
            methods=("weighted-node-lbp",),
            datasets=TINY[:1],
            params=params,
            combine="one-at-a-time",
        )
    )
    assert [dict(c.params) for c in each] == [
        {"stay_cost": 8, "gain": 1},
        {"stay_cost": 8, "gain": 2},
        {"stay_cost": 8, "gain": 4},
        {"stay_cost": 8, "memory": 32},
        {"stay_cost": 8, "memory": 64},
    ]


def test_a_grid_of_too_many_cells_is_refused_before_it_is_listed():
    # 200 x 200 x 100 values made 4 million cells in memory, minutes before the first ran
    params = {"seqslam": {"ds": list(range(1, 201)), "vmin": [0.1] * 200, "vmax": [1] * 100}}
    config = SweepConfig(methods=("seqslam",), datasets=TINY, params=params, seed=[0, 1])
    with pytest.raises(PpalocError) as info:
        expand(config)  # counted, not listed
    assert str(info.value) == (
        "the grid has 16,000,000 cells (2 datasets x 2 seeds x 4,000,000 method settings), "
        "more than the 100,000 one sweep runs: sweep fewer values, or split the grid into "
        "several sweeps"
    )


def test_seed_and_tolerance_lists_are_axes_and_columns():
    config = SweepConfig(methods=("seqslam",), datasets=TINY[:1], seed=[0, 1], tolerance=[1, 3])
    cells = expand(config)
    assert [(c.seed, c.tolerance, dict(c.axes)) for c in cells] == [
        (0, 1, {"seed": 0, "tolerance": 1}),
        (0, 3, {"seed": 0, "tolerance": 3}),
        (1, 1, {"seed": 1, "tolerance": 1}),
        (1, 3, {"seed": 1, "tolerance": 3}),
    ]
    assert list(axes(config)) == ["method", "dataset", "seed", "tolerance"]


def test_a_method_parameter_named_like_a_metric_gets_a_prefixed_column():
    config = SweepConfig(methods=("seqslam",), datasets=TINY[:1], params={"seqslam": {"auc": [1]}})
    assert list(expand(config)[0].axes) == ["param:auc"]


def test_cell_id_is_the_sha256_of_its_canonical_identity():
    cell = Cell("seqslam", "synthetic:?places=20&seed=1", {"ds": 10}, {"ds": 10}, tolerance=2)
    text = (
        '{"dataset":"synthetic:?places=20&seed=1","max_weight_values":4000000,'
        '"method":"seqslam","params":{"ds":10},"recall":"A","record_weights":false,'
        '"seed":0,"tolerance":2}'
    )
    assert cell.id == hashlib.sha256(text.encode()).hexdigest()[:16] == "0073b7a81cbaf89b"
    assert cell.folder == "cells/seqslam-0073b7a81cbaf89b"
    reordered = Cell("seqslam", cell.dataset, {"ds": 10}, {}, tolerance=2)
    assert reordered.id == cell.id  # the summary's axes are not part of the identity
    assert Cell("seqslam", cell.dataset, {"ds": 12}, {}, tolerance=2).id != cell.id
    assert Cell("seqslam", cell.dataset, {"ds": 10}, {}, tolerance=2, seed=1).id != cell.id


# -- bad input: one line naming the key, before any cell runs ---------------------------------


def _config(**values):
    base = {"methods": ["seqslam"], "datasets": [TINY[0]]}
    return sweep_config_from_mapping({**base, **values}, source="sweep.toml")


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"methods": []}, "sweep.toml: methods is empty: the grid has no cell; give e.g. methods"),
        ({"datasets": []}, "sweep.toml: datasets is empty: the grid has no cell"),
        (
            {"params": {"seqslam": {"ds": []}}},
            "sweep.toml: [sweep.params.seqslam] ds = [] is empty: give at least one value",
        ),
        (
            {"params": {"able-m": {"bits": [1, 2]}}},
            "sweep.toml: [sweep.params.able-m]: 'able-m' is not in methods (seqslam); add it",
        ),
        (  # TOML's inf (or 1e400): no cell's identity could be written (an internal error)
            {"params": {"seqslam": {"vmin": [float("inf"), 0.5]}}},
            "sweep.toml: [sweep.params.seqslam] vmin = [inf, 0.5] holds NaN or an infinite",
        ),
        (
            {"params": {"seqslam": {"vmin": float("nan")}}},
            "sweep.toml: [sweep.params.seqslam] vmin = nan holds NaN or an infinite number",
        ),
        (  # a TOML date: no cell's identity could be written (an internal error)
            {"params": {"seqslam": {"ds": [datetime.date(1979, 5, 27), 3]}}},
            "sweep.toml: [sweep.params.seqslam] ds = 1979-05-27 is a TOML date, not a",
        ),
        (
            {"params": {"seqslam": {"ds": {"a": datetime.time(7, 32)}}}},
            "sweep.toml: [sweep.params.seqslam] ds = 07:32:00 is a TOML time, not a",
        ),
        ({"seed": []}, "sweep.toml: seed=[] must be an integer or a non-empty list of them"),
        ({"tolerance": [-1]}, "sweep.toml: tolerance=[-1] must be an integer >= 0 or a"),
        ({"combine": "zip"}, "sweep.toml: combine='zip' must be one of product, one-at-a-time"),
        ({"methods": "seqslam, able-m"}, None),  # one string is one method (two, joined)
    ],
)
def test_bad_values_name_their_key(values, message):
    if message is None:
        with pytest.raises(
            PpalocError, match="methods: method 'seqslam, able-m' names 2 methods in one"
        ):
            validate(_config(**values), expand(_config(**values)))
        return
    with pytest.raises(PpalocError) as info:
        _config(**values)
    assert str(info.value).startswith(message)
    assert "\n" not in str(info.value)


def test_unknown_axis_name_lists_the_valid_keys():
    with pytest.raises(PpalocError) as info:
        _config(gamma=[0.25, 0.5])
    assert str(info.value) == (
        "unknown configuration key 'gamma' in sweep.toml; valid keys: methods, datasets, "
        "params, tolerance, seed, recall, record_weights, max_weight_values, combine"
    )


def test_a_parameter_the_method_does_not_take_is_refused_before_any_cell_runs():
    config = _config(params={"seqslam": {"gamma": [0.25, 0.5]}})
    with pytest.raises(PpalocError) as info:
        validate(config, expand(config), source="sweep.toml")
    assert str(info.value).startswith(
        "sweep.toml: [sweep.params.seqslam] (cell gamma=0.25): method 'seqslam': unknown "
        "parameter 'gamma'; its parameters: mode, size,"
    )


def test_the_issue_form_with_gamma_on_the_robust_filter_points_to_the_paper_methods():
    config = sweep_config_from_mapping(
        {
            "methods": ["weighted-node-lbp", "seqslam"],
            "datasets": list(TINY),
            "tolerance": 2,
            "params": {"weighted-node-lbp": {"gamma": [0.25, 0.5]}},
        }
    )
    assert len(expand(config)) == 6  # the issue's form is read as it is
    with pytest.raises(PpalocError, match=r"gamma=0.25 is a parameter of preset 'paper'"):
        validate(config, expand(config))


def test_a_bad_value_of_a_parameter_names_the_cell():
    config = _config(
        methods=["weighted-node-paper-lbp"],
        params={"weighted-node-paper-lbp": {"gamma": [0.25, 0.3]}},
    )
    with pytest.raises(
        PpalocError, match=r"\(cell gamma=0.3\): method 'weighted-node-paper-lbp': gamma=0.3"
    ):
        validate(config, expand(config))


def test_unknown_method_and_dataset_key():
    with pytest.raises(PpalocError, match=r"^methods: method 'seqslm' is unknown"):
        config = _config(methods=["seqslm"])
        validate(config, expand(config))
    config = _config(datasets=["synthetic:?plces=20"])
    with pytest.raises(PpalocError, match=r"datasets: dataset spec .* unknown key 'plces'"):
        validate(config, expand(config))


def test_an_unreachable_scheduler_fails_at_once_and_writes_nothing(tmp_path, issue_config):
    import socket

    out = tmp_path / "sweep"
    with socket.socket() as s:  # a port held, not listened on: no other process takes it
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        t0 = time.perf_counter()
        with pytest.raises(PpalocError) as info:
            run_sweep(issue_config, out, scheduler=f"tcp://127.0.0.1:{port}", connect_timeout=2)
        assert time.perf_counter() - t0 < 5
    assert str(info.value).startswith(f"cannot reach the Dask scheduler at tcp://127.0.0.1:{port}")
    assert not out.exists()
    with pytest.raises(PpalocError, match="must look like tcp://HOST:PORT"):
        run_sweep(issue_config, out, scheduler="localhost")
    for port in (0, 99999):  # no scheduler listens there: not "start one" advice
        with pytest.raises(PpalocError, match=rf"'tcp://127.0.0.1:{port}': port {port} must be in"):
            run_sweep(issue_config, out, scheduler=f"tcp://127.0.0.1:{port}")


def test_a_scheduler_of_a_scheme_dask_does_not_speak_is_one_line(tmp_path, issue_config, capfd):
    # Dask's own ValueError was turned into one line, but the client it left half made
    # printed "Exception ignored in: <function Client.__del__ ...>" and a traceback
    import gc

    with pytest.raises(PpalocError) as info:
        run_sweep(issue_config, tmp_path / "out", scheduler="http://x:1", connect_timeout=2)
    gc.collect()
    assert str(info.value) == (
        "--scheduler 'http://x:1': Dask reaches a scheduler by tcp://, tls://, ucx://, ws://, "
        "wss://, not http://; e.g. tcp://10.0.0.5:8786"
    )
    with pytest.raises(PpalocError, match=r"^--scheduler 'inproc://x': Dask reaches a sch"):
        run_sweep(issue_config, tmp_path / "out", scheduler="inproc://x", connect_timeout=2)
    gc.collect()
    assert "Traceback" not in capfd.readouterr().err


def test_a_scheduler_of_a_scheme_a_package_adds_to_dask_is_not_refused(monkeypatch):
    # a comm backend a package registers (an entry point in distributed.comm.backends, as
    # distributed-ucxx's ucxx://) is loaded by Dask when first named: it was refused as a
    # scheme Dask does not speak, since it was not loaded yet
    from importlib.metadata import EntryPoint

    from distributed.comm import registry

    from ppaloc.evaluate.sweep import _probe

    added = EntryPoint("added", "distributed.comm.tcp:TCPBackend", "distributed.comm.backends")
    monkeypatch.setattr(registry, "backends", dict(registry.backends))
    monkeypatch.setattr(
        registry, "_entry_points", lambda name, group: [added] if name == "added" else []
    )
    _probe("added://10.0.0.5:8786", 1.0)  # nothing to probe for a scheme not tcp or tls
    assert "added" in registry.backends
    with pytest.raises(PpalocError, match=r"by added://, tcp://, .*not http://"):
        _probe("http://x:1", 1.0)


def test_bad_parameters_fail_before_the_scheduler_is_reached(tmp_path):
    config = _config(params={"seqslam": {"gamma": [0.5]}})
    with pytest.raises(PpalocError, match="unknown parameter 'gamma'"):
        run_sweep(config, tmp_path / "out", scheduler="tcp://127.0.0.1:1")


# -- the command -----------------------------------------------------------------------------


def test_help_lists_sweep_and_shows_its_example():
    assert "sweep" in CliRunner().invoke(cli, ["--help"]).output
    result = CliRunner().invoke(cli, ["sweep", "--help"])
    assert result.exit_code == 0
    assert "[sweep.params.weighted-node-paper-lbp]" in result.output
    assert "--scheduler" in result.output


@pytest.mark.parametrize(
    ("toml", "args", "message"),
    [
        (
            '[sweep]\nmethods = ["seqslam"]\ndatasets = ["synthetic:?places=20"]\nmetods = 1\n',
            [],
            "ppaloc: error: unknown configuration key 'metods' in {path}; valid keys: methods,",
        ),
        (
            '[sweep]\nmethods = ["seqslam"]\ndatasets = ["synthetic:?places=20"]\n',
            ["--no-out"],
            "ppaloc: error: no output folder: give --out DIR",
        ),
        (
            '[sweep]\nmethods = ["seqslam"]\ndatasets = ["synthetic:?places=20"]\n'
            "[sweep.params.seqslam]\ngamma = [0.25]\n",
            [],
            "ppaloc: error: {path}: [sweep.params.seqslam] (cell gamma=0.25): method 'seqslam': "
            "unknown parameter 'gamma'",
        ),
        (
            '[sweep]\nmethods = ["seqslam"]\ndatasets = []\n',
            [],
            "ppaloc: error: {path}: datasets is empty",
        ),
        (
            '[sweep]\nmethods = ["seqslam"]\ndatasets = ["synthetic:?places=20"]\nworkers = "2"\n',
            [],
            "ppaloc: error: workers='2' in {path} has the wrong type",
        ),
    ],
)
def test_command_errors_are_one_line_with_exit_1(capsys, tmp_path, toml, args, message):
    path = tmp_path / "sweep.toml"
    path.write_text(toml)
    out = [] if args == ["--no-out"] else ["--out", tmp_path / "out"]
    code, _, err = run(capsys, "sweep", "--config", path, *out)
    assert code == 1
    assert err.startswith(message.format(path=path))
    assert err.count("\n") == 1
    assert not (tmp_path / "out").exists()


def test_flags_build_a_sweep_without_a_file(capsys, tmp_path):
    code, _, err = run(
        capsys,
        "sweep",
        "-m",
        "seqslam",
        "-d",
        TINY[0],
        "--param",
        "seqslam.gamma=[1, 2]",
        "--out",
        tmp_path / "out",
    )
    assert code == 1
    assert "[sweep.params.seqslam] (cell gamma=1): method 'seqslam': unknown parameter" in err


def test_the_command_line_does_not_import_dask():
    code = (
        "import sys; from ppaloc.cli import main; from click.testing import CliRunner; "
        "from ppaloc.cli import cli; CliRunner().invoke(cli, ['sweep', '--help']); "
        "import ppaloc.evaluate, ppaloc.evaluate.sweep; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "[]"


# -- cell folders and the summary -------------------------------------------------------------


def _finish(out, cell, f1):
    results = {
        "dataset": cell.spec,
        "n_queries": 40,
        "methods": {cell.method: {"f1_max": f1, "auc": f1 / 2, "recall_at_k": {"1": 0.5}}},
    }
    write_bytes(out / cell.folder / "results.json", json.dumps(results))


def test_the_summary_is_rebuilt_from_the_cell_folders(tmp_path, issue_config):
    config = issue_config
    cells = expand(config)
    _finish(tmp_path, cells[0], 0.75)
    write_bytes(tmp_path / cells[1].folder / "error.json", json.dumps({"error": "it broke"}))
    write_bytes(tmp_path / cells[2].folder / "results.json", '{"methods": {"seqsl')  # cut short
    _finish(tmp_path, cells[3], 0.5)
    summary = collect_summary(config, tmp_path)
    assert summary["columns"] == ["method", "dataset", "gamma", *METRIC_COLUMNS, "status", "cell"]
    rows = summary["cells"]
    assert [r["status"] for r in rows] == ["ok", "it broke", "not run", "ok", "not run", "not run"]
    assert [r["f1_max"] for r in rows[:4]] == [0.75, None, None, 0.5]
    assert rows[0]["recall_at_1"] == 0.5 and rows[0]["n_queries"] == 40
    assert [r["gamma"] for r in rows] == [0.25, 0.5, None, 0.25, 0.5, None]
    assert summary["counts"] == {"cells": 6, "ok": 2, "failed": 1, "not_run": 3}
    assert cell_status(tmp_path, cells[2]) == ("not run", None)  # unparsable: not finished


@pytest.mark.parametrize(
    ("value", "message"),
    [('"high"', "f1_max is 'high', expected a number"), ("1" + "0" * 400, "f1_max is 10000")],
)
def test_a_cell_whose_results_hold_a_field_of_another_type_is_failed(
    tmp_path, issue_config, value, message
):
    # it went into summary.json as it was, and ppaloc show on the sweep refused the summary
    # (or ended in an internal error), telling to run the sweep again, which kept the cell
    cell = expand(issue_config)[0]
    _finish(tmp_path, cell, 0.75)
    path = tmp_path / cell.folder / "results.json"
    path.write_text(path.read_text().replace("0.75", value))  # a hand edit
    status, results = cell_status(tmp_path, cell)
    assert results is None and f"{path}: methods.{cell.method}.{message}" in status
    row = collect_summary(issue_config, tmp_path)["cells"][0]
    assert row["f1_max"] is None and row["status"] == status


def test_a_cell_whose_results_hold_nan_is_not_finished(tmp_path, issue_config):
    cell = expand(issue_config)[0]
    _finish(tmp_path, cell, 0.75)
    path = tmp_path / cell.folder / "results.json"
    path.write_text(path.read_text().replace("0.75", "NaN"))  # a hand edit; never written
    assert cell_status(tmp_path, cell) == ("not run", None)
