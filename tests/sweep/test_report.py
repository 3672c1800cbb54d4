"""The sweep report from a hand-written summary: best cells, sensitivity, heat-map axes,
grids, labels and the page (no cluster)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ppaloc.errors import DataError
from ppaloc.evaluate.sweep_report import (
    best_cells,
    dataset_labels,
    f1_grid,
    heatmap_axes,
    load_summary,
    sensitivity,
    write_sweep_report,
)
from ppaloc.fileio import write_bytes

A, B = "synthetic:?seed=1", "synthetic:?seed=2"


def row(method, dataset, f1, status="ok", **axes):
    return {
        "method": method,
        "dataset": dataset,
        "f1_max": f1,
        "auc": None if f1 is None else f1 / 2,
        "recall_at_100p": 0.0,
        "status": status,
        "cell": f"cells/{method}-{dataset[-1]}-{len(axes)}",
        **axes,
    }


def summary(combine="product"):
    """lbp sweeps gain (1, 2) x memory (32, 64), lowres gain only, seqslam nothing; two
    datasets; one lowres cell failed."""
    cells = []
    for d in (A, B):
        for g in (1, 2):
            for mem in (32, 64):
                f1 = 0.1 * g + (0.2 if d == B else 0.0) + (0.05 if mem == 64 else 0.0)
                cells.append(row("lbp", d, f1, gain=g, memory=mem))
        cells.append(row("lowres", d, 0.3, gain=1))
        failed = d == B
        cells.append(row("lowres", d, None if failed else 0.5, "boom" if failed else "ok", gain=2))
        cells.append(row("seqslam", d, 0.6 if d == A else 0.4))
    return {
        "format": "ppaloc-sweep-summary",
        "config": {"combine": combine},
        "axes": {
            "method": ["lbp", "lowres", "seqslam"],
            "dataset": [A, B],
            "gain": [1, 2],
            "memory": [32, 64],
        },
        "cells": cells,
        "counts": {"cells": len(cells), "ok": len(cells) - 1, "failed": 1, "not_run": 0},
    }


def test_best_cells_per_method_and_dataset():
    best = best_cells(summary())
    assert [
        (b["method"], b["dataset"], b["row"] and b["row"]["f1_max"], b["ok"], b["cells"])
        for b in best
    ] == [
        ("lbp", A, pytest.approx(0.25), 4, 4),
        ("lbp", B, pytest.approx(0.45), 4, 4),
        ("lowres", A, 0.5, 2, 2),
        ("lowres", B, 0.3, 1, 2),
        ("seqslam", A, 0.6, 1, 1),
        ("seqslam", B, 0.4, 1, 1),
    ]
    assert best[1]["row"]["gain"] == 2 and best[1]["row"]["memory"] == 64


def test_sensitivity_means_over_routes_and_the_better_method():
    tables = dict((axis, (header, rows)) for axis, header, rows in sensitivity(summary()))
    header, rows = tables["gain"]
    assert header == [
        "gain",
        "lbp mean",
        "lbp min",
        "lowres mean",
        "lowres min",
        "better of the two, mean",
        "better of the two, min",
    ]
    # gain 1: lbp per route = mean over memory: A 0.125, B 0.325; lowres 0.3 on both
    # gain 2: lbp A 0.225, B 0.425; lowres A 0.5, B failed (the better: A only)
    assert rows == [
        ["1", "0.225", "0.125", "0.300", "0.300", "0.312", "0.300"],
        ["2", "0.325", "0.225", "0.500", "0.500", "0.500", "0.500"],
    ]
    header, rows = tables["memory"]
    assert header == ["memory", "lbp mean", "lbp min"]
    # memory 32: lbp per route = mean over gain: A 0.15, B 0.35; memory 64: A 0.2, B 0.4
    assert rows == [["32", "0.250", "0.150"], ["64", "0.300", "0.200"]]


def test_heatmap_axes_pair_parameters_only_when_varied_together():
    assert heatmap_axes(summary()) == [
        (None, "method", "dataset"),
        ("lbp", "gain", "memory"),
        ("lbp", "gain", "dataset"),
        ("lbp", "memory", "dataset"),
        ("lowres", "gain", "dataset"),
    ]
    assert ("lbp", "gain", "memory") not in heatmap_axes(summary("one-at-a-time"))


def test_f1_grid_means_over_other_axes_and_takes_the_best_for_methods():
    rows, cols, grid = f1_grid(summary(), "lbp", "gain", "memory")
    assert (rows, cols) == ([1, 2], [32, 64])
    np.testing.assert_allclose(grid, [[0.2, 0.25], [0.3, 0.35]])
    rows, cols, grid = f1_grid(summary(), None, "method", "dataset")
    np.testing.assert_allclose(grid, [[0.25, 0.45], [0.5, 0.3], [0.6, 0.4]])
    _, _, grid = f1_grid(summary(), "lowres", "gain", "dataset")
    assert grid[0].tolist() == [0.3, 0.3] and grid[1, 0] == 0.5 and math.isnan(grid[1, 1])


def test_dataset_labels_keep_what_differs_and_number_what_would_clash():
    specs = [
        "nordland:a/nordland-64x32?ref=summer",
        "nordland:b/other?ref=summer",
        "synthetic:?places=9&seed=1",
        "synthetic:?places=9&seed=2",
    ]
    assert list(dataset_labels(specs).values()) == [
        "nordland nordland-64x32",
        "nordland other",
        "synthetic seed=1",
        "synthetic seed=2",
    ]
    clash = [f"synthetic:?speed_var=0.65{i}&seed={i}" for i in (1, 2)]  # cut: "speed_var…"
    assert list(dataset_labels(clash, width=10).values()) == ["D1", "D2"]


def test_the_page_has_every_section(tmp_path):
    write_bytes(tmp_path / "summary.json", json.dumps(summary()))
    page = write_sweep_report(tmp_path).read_text()
    for section in (
        "Best cell per method and dataset",
        "Max F1 against gain",
        "Max F1 against memory",
        "Failed cells",
        "All cells",
        "Datasets",
        "Configuration",
    ):
        assert section in page
    assert page.count("<img src='data:image/png;base64,") == 5
    assert "boom" in page
    md = (tmp_path / "report.md").read_text()
    assert md.count("](figures/heatmap-") == 5
    assert sorted(p.name for p in (tmp_path / "figures").iterdir()) == [
        f"heatmap-{i}.png" for i in range(1, 6)
    ]


def test_a_folder_without_a_summary_is_refused(tmp_path):
    with pytest.raises(DataError, match=r"holds no summary\.json; give a folder written by"):
        load_summary(tmp_path)
    write_bytes(tmp_path / "summary.json", '{"format": "other"}')
    with pytest.raises(DataError, match="is not a ppaloc sweep summary"):
        load_summary(tmp_path)


def test_a_users_file_in_figures_is_kept_and_the_report_refused(tmp_path):
    write_bytes(tmp_path / "summary.json", json.dumps(summary()))
    write_sweep_report(tmp_path)
    write_sweep_report(tmp_path)  # the report's own figures are replaced
    (tmp_path / "figures" / "notes.txt").write_text("keep me")
    with pytest.raises(DataError) as err:
        write_sweep_report(tmp_path)
    assert str(err.value) == (
        f"{tmp_path} holds 'figures/notes.txt', which a sweep did not write, and the report's "
        "figures are replaced whole; move it out of figures/ first"
    )
    assert (tmp_path / "figures" / "notes.txt").read_text() == "keep me"


def test_show_on_a_sweep_folder_prints_its_best_cells_and_rebuilds_its_report(tmp_path, capsys):
    # `ppaloc show` on a sweep's folder said it held no results.json, naming only evaluate
    from ppaloc.cli import main

    write_bytes(tmp_path / "summary.json", json.dumps(summary()))
    assert main(["show", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "Best cell per method and dataset" in out and "seqslam" in out
    assert f"report:  {tmp_path / 'report.html'}" in out
    assert "Max F1 against gain" in (tmp_path / "report.html").read_text()


def test_show_refuses_a_sweep_report_linked_into_a_loop_and_keeps_the_link(tmp_path, capsys):
    # report.html, a name ppaloc picks, linked to itself: the link was replaced by a file
    from ppaloc.cli import main

    write_bytes(tmp_path / "summary.json", json.dumps(summary()))
    (tmp_path / "report.html").symlink_to("report.html")
    assert main(["show", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert err == (
        f"ppaloc: error: cannot write {tmp_path / 'report.html'}: it is a symbolic link that "
        "leads into a loop (links that lead back to themselves), which writing would replace "
        "with a file; remove the link or point it at a file\n"
    )
    assert (tmp_path / "report.html").is_symlink()


def test_show_names_a_damaged_sweep_summary(tmp_path, capsys):
    from ppaloc.cli import main

    (tmp_path / "summary.json").write_text('{"format": "ppaloc-sweep-summary", ')
    assert main(["show", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert f"cannot read {tmp_path / 'summary.json'}" in err and "results.json" not in err


def _without(key):
    s = summary()
    del s[key]
    return s


def _cell_without(key):
    s = summary()
    del s["cells"][0][key]
    return s


def _counts_without(key):
    s = summary()
    del s["counts"][key]
    return s


def _axes_without(key):
    s = summary()
    del s["axes"][key]
    return s


def _cell(**changes):
    s = summary()
    s["cells"][0].update(changes)
    return s


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[" * 100_000 + "]" * 100_000, "it is nested too deep"),
        (json.dumps(summary()).replace("0.6", "NaN", 1), "it holds NaN, which is not JSON"),
        # a missing field read "'axes' is None", as if it held null
        (json.dumps(_without("axes")), "'axes' is missing, expected a table of lists"),
        (json.dumps(_without("counts")), "'counts' is missing, expected a table of counts"),
        (json.dumps({**summary(), "axes": None}), "'axes' is None, expected a table of lists"),
        (json.dumps(_cell_without("status")), "cells[0].status is missing, expected a string"),
        (json.dumps(_counts_without("ok")), "counts.ok is missing, expected a count >= 0"),
        (json.dumps(_counts_without("not_run")), "counts.not_run is missing, expected a"),
        (json.dumps(_axes_without("dataset")), "axes.dataset is missing, expected a list of"),
        (json.dumps({**summary(), "axes": {**summary()["axes"], "gain": 5}}), "axes.gain is 5"),
        (json.dumps({**summary(), "cells": "x"}), "'cells' is 'x', expected a list of tables"),
        (json.dumps({**summary(), "config": "x"}), "'config' is 'x', expected a table"),
        (json.dumps(_cell(f1_max="high")), "cells[0].f1_max is 'high', expected a number"),
        # a number no float holds was an internal error (OverflowError) or drawn as inf
        (json.dumps(_cell(f1_max=10**400)), "cells[0].f1_max is 1000000000000000000000"),
        (json.dumps(_cell(auc=0.125)).replace("0.125", "1e400"), "cells[0].auc is inf, expected"),
        (json.dumps(_cell(status=5)), "cells[0].status is 5, expected a string"),
        (json.dumps(_cell(method="other")), "cells[0].method 'other' is not in axes.method"),
        # a newer summary was read as if it were this version's
        (json.dumps({**summary(), "version": 2}), "is in sweep summary version 2, newer than"),
        (json.dumps({**summary(), "version": "1"}), "'version' is '1', expected a version"),
    ],
)
def test_a_damaged_or_hand_edited_summary_is_one_line(tmp_path, capsys, text, message):
    # each was an internal error of `ppaloc show` (RecursionError, KeyError, TypeError, ...)
    from ppaloc.cli import main

    write_bytes(tmp_path / "summary.json", text)
    assert main(["show", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("ppaloc: error: ") and "\n" not in err
    assert message in err
    assert not (tmp_path / "report.html").exists()


def test_the_printed_best_cells_keep_method_names_whole_on_80_columns(monkeypatch, capsys):
    # two methods sharing their first letters were both "weighted-node-lo…" on 80 columns
    from rich.console import Console

    import ppaloc.cli.commands as commands

    long = {"lbp": "weighted-node-lowres", "lowres": "weighted-node-lowres16"}
    data = summary()
    for cell in data["cells"]:
        cell["method"] = long.get(cell["method"], cell["method"])
        cell["dataset"] += "&query=autumn&speed_var=0.65&stops=3"
    data["axes"]["method"] = [long.get(m, m) for m in data["axes"]["method"]]
    data["axes"]["dataset"] = [d + "&query=autumn&speed_var=0.65&stops=3" for d in (A, B)]
    monkeypatch.setattr(commands, "_console", lambda: Console(width=80))
    commands._print_best_cells(data)
    out = capsys.readouterr().out
    assert "…" not in out and max(map(len, out.splitlines())) <= 80
    starts = [line.split()[0] for line in out.splitlines()[4:] if line[:2].strip()]
    assert sorted(set(starts)) == ["seqslam", "weighted-node-lowres", "weighted-node-lowres16"]


def _grid_summary(n: int) -> dict:
    """One method over gain x memory, ``n`` values each, every cell finished."""
    cells = [
        row("lbp", A, (g * n + m) / (n * n), gain=g, memory=m) for g in range(n) for m in range(n)
    ]
    return {
        "format": "ppaloc-sweep-summary",
        "config": {"combine": "product"},
        "axes": {
            "method": ["lbp"],
            "dataset": [A],
            "gain": list(range(n)),
            "memory": list(range(n)),
        },
        "cells": cells,
        "counts": {"cells": len(cells), "ok": len(cells), "failed": 0, "not_run": 0},
    }


def test_the_sensitivity_tables_read_each_cell_once_per_axis(monkeypatch):
    # each value of an axis scanned every cell: 300 x 300 values took over ten minutes
    import ppaloc.evaluate.sweep_report as sweep_report

    n, calls = 30, []
    real = sweep_report._key
    monkeypatch.setattr(sweep_report, "_key", lambda v: calls.append(1) or real(v))
    tables = dict((axis, rows) for axis, _, rows in sensitivity(_grid_summary(n)))
    assert len(calls) <= 2 * (3 * n * n + n)  # per axis: each cell's value and route
    mean = [float(r[1]) for r in tables["gain"]]
    assert mean == pytest.approx([(g * n + (n - 1) / 2) / (n * n) for g in range(n)], abs=1e-3)


def test_a_large_heat_map_is_drawn_in_colours_with_its_ticks_thinned():
    # a text per square: 90,000 squares took minutes to draw, unreadable at that size
    import ppaloc.evaluate.sweep_report as sweep_report

    n = 50
    *_, grid = f1_grid(_grid_summary(n), "lbp", "gain", "memory")
    names = [str(v) for v in range(n)]
    fig = sweep_report._heatmap(grid, names, names, "gain", "memory", "lbp")
    ax = fig.axes[0]
    assert len(ax.texts) == 0
    assert [t.get_text() for t in ax.get_xticklabels()] == [str(v) for v in range(0, n, 2)]
    figs = sweep_report._figures(_grid_summary(n), {})
    assert "Colours alone (more than 400 squares): the values are in summary.csv" in figs[0].caption
    small = sweep_report._heatmap(grid[:3, :3], names[:3], names[:3], "gain", "memory", "lbp")
    assert len(small.axes[0].texts) == 9
