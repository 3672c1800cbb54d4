"""Tiny hand-made results (5 queries, 6 reference frames, two methods): what the folder
holds, the figures drawn from its files only, and folders of the older format read."""

from __future__ import annotations

import base64
import hashlib
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
from ppaloc.evaluate import figures
from ppaloc.evaluate.columns import COLUMNS, column_of
from ppaloc.evaluate.difference import DifferenceMatrix
from ppaloc.evaluate.report import comparison_table, paper_table, write_report
from ppaloc.evaluate.results import RESULTS_FORMAT, load_results, save_results, upgrade_summary
from ppaloc.evaluate.run import MethodRun, RunResult, method_metrics
from ppaloc.npzfile import npz_bytes

GT = [[0], [1, 2], [3], [4], []]
"""Accepted reference frames of the five queries (the last has no true match)."""

VALUES = (np.arange(30, dtype=np.float32).reshape(5, 6) % 7) / 4
"""A 5 x 6 difference matrix: query i against reference frame j."""

IMG = re.compile(r"<img src='data:image/png;base64,([A-Za-z0-9+/=]+)' alt='([^']*)'>")


def method(name: str, ref_index, score, frame_index, weights=None) -> MethodRun:
    gt = PackedSets.from_sets([np.array(g, np.int64) for g in GT])
    ref_index = np.array(ref_index, np.int64)
    score = np.array(score, np.float64)
    ranking = ref_index[:, None].copy()
    frame_index = np.array(frame_index, np.int64)
    node = np.searchsorted(frame_index, ref_index, side="right") - 1
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
        frame_index=frame_index,
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
        difference=DifferenceMatrix(VALUES, np.arange(5), np.arange(6)),
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
    assert "accuracy" not in alpha and summary["difference"]["arrays"] == "arrays/_difference.npz"
    with np.load(folder / "arrays" / "_difference.npz") as z:
        assert sorted(z.files) == ["difference", "query_index", "reference_index"]
        np.testing.assert_array_equal(z["difference"], VALUES)
        assert z["difference"].dtype == np.float32 and z["query_index"].tolist() == [0, 1, 2, 3, 4]
    with np.load(folder / "arrays" / "beta.npz") as z:
        assert z["frame_index"].tolist() == [0, 2, 3, 5]
    csv_header = (folder / "results.csv").read_text().splitlines()[0].split(",")
    assert csv_header[6] == "precision_at_100r"  # where accuracy was: readers by position


def test_the_difference_matrix_comes_back(folder):
    result, _ = load_results(folder)
    d = result.difference
    np.testing.assert_array_equal(d.values, VALUES)
    assert d.reference_index.tolist() == list(range(6)) and d.measure.startswith("mean absolute")
    assert result.runs["beta"].frame_index.tolist() == [0, 2, 3, 5]


def test_the_difference_figure_from_files(folder):
    result, _ = load_results(folder)
    fig = figures.difference_matrix(result)
    shown = [ax for ax in fig.axes if ax.get_visible() and ax.images]
    assert len(shown) == 3  # the matrix alone, then one panel per method
    alone, alpha, _ = shown
    np.testing.assert_array_equal(alone.images[0].get_array(), VALUES.T)  # x query, y reference
    assert alone.images[0].get_extent() == [-0.5, 4.5, -0.5, 5.5]
    accepted, rejected = (c.get_offsets() for c in alpha.collections[1:3])
    assert np.asarray(accepted).tolist() == [[0, 0], [1, 2], [2, 3]]  # score >= 0.7
    assert np.asarray(rejected).tolist() == [[3, 1], [4, 5]]
    assert "2 of 5" not in alpha.get_title() and "3 of 5 accepted" in alpha.get_title()
    assert figures.png_bytes(fig)[:8] == b"\x89PNG\r\n\x1a\n"


def _overlaps(a, b) -> bool:
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


def test_no_legend_covers_the_estimates_or_the_weights(folder):
    # an estimate of the first frames far up the map sat under a legend in the top left
    result, _ = load_results(folder)
    position = figures.position_along_route(result)
    position.canvas.draw()
    (legend,) = position.legends
    box = legend.get_window_extent()
    assert [t.get_text() for t in legend.get_texts()] == ["true", "correct", "wrong"]
    assert not any(_overlaps(box, ax.get_window_extent()) for ax in position.axes)
    assert not any(ax.get_legend() for ax in position.axes)
    weights = figures.weights_heatmaps(result)
    (ax,) = [a for a in weights.axes if a.images]
    assert ax.get_legend() is None
    assert ax.get_title().endswith("; cyan: the accepted nodes lie between the lines")


def test_the_weights_figure_draws_the_truth_in_nodes(folder):
    result, _ = load_results(folder)
    fig = figures.weights_heatmaps(result)
    (ax,) = [a for a in fig.axes if a.images]
    low, high = (line.get_ydata() for line in ax.lines)
    # accepted frames 0, 1-2, 3, 4, none; nodes of frames 0-1, 2, 3-4, 5: the accepted
    # nodes 0, 0-1, 2, 2 bracketed half a node out, so the weights there stay visible
    np.testing.assert_array_equal(low, [-0.5, -0.5, 1.5, 1.5, np.nan])
    np.testing.assert_array_equal(high, [0.5, 1.5, 2.5, 2.5, np.nan])
    assert ax.get_ylabel() == "map node (index)" and "4 nodes for 6 reference frames" in (
        ax.get_title()
    )


def test_true_nodes_by_hand():
    frames = np.array([2, 5, 9])
    out = figures.true_nodes(np.array([0, 2, 4.5, 5, 8, 9, 30, np.nan]), frames)
    np.testing.assert_array_equal(out, [0, 0, 0, 1, 1, 2, 2, np.nan])


def test_the_report_from_files_only(folder, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(folder, copy)
    page = write_report(copy).read_text()
    titles = [alt for _, alt in IMG.findall(page)]
    assert titles[:2] == ["Precision-recall curves", "Difference matrix"]
    for data, _ in IMG.findall(page):
        Image.open(io.BytesIO(base64.b64decode(data))).load()
    assert "P @100%R" in page and "Accuracy" not in page
    assert "<th>Recall definition</th>" in page and "one query frame in" not in page
    md = (copy / "report.md").read_text()
    assert "![Difference matrix](figures/difference.png)" in md
    assert (copy / "figures" / "difference.png").is_file()


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
    """Rewrite a folder as format 1 wrote it: no format, `accuracy`, no frame_index, no
    difference matrix (checksums recorded again, as that version did)."""
    summary = json.loads((folder / "results.json").read_text())
    del summary["format"], summary["difference"]
    del summary["files"]["arrays/_difference.npz"]
    (folder / "arrays" / "_difference.npz").unlink()
    for name, entry in summary["methods"].items():
        entry["accuracy"] = entry.pop("precision_at_100r")
        path = folder / entry["arrays"]
        with np.load(path) as z:
            arrays = {k: z[k] for k in z.files if k != "frame_index"}
        path.write_bytes(npz_bytes(arrays))
        summary["files"][entry["arrays"]] = hashlib.sha256(path.read_bytes()).hexdigest()
        assert name
    (folder / "results.json").write_text(json.dumps(summary))


def test_a_format_1_folder_is_read_under_todays_names(folder, capsys):
    _as_format_1(folder)
    raw = json.loads((folder / "results.json").read_text())
    assert comparison_table(raw)[1][0][7] == "0.600"  # the printed table of `ppaloc show`
    result, summary = load_results(folder)
    assert summary["methods"]["alpha"]["precision_at_100r"] == pytest.approx(0.6)
    assert result.difference is None and result.runs["beta"].frame_index is None
    page = write_report(folder).read_text()
    titles = [alt for _, alt in IMG.findall(page)]
    assert "Difference matrix" not in titles and "Weights over time" in titles
    fig = figures.weights_heatmaps(result)
    assert "true node not drawn" in fig.axes[0].get_title()  # 4 nodes for 6 frames

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


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"query_index": np.array([0, 1, 2, 3, 9])}, r"query_index\[4\] is 9, outside 0\.\.4"),
        ({"reference_index": np.array([0, 2, 1, 3, 4, 5])}, r"reference_index is not increasing"),
        ({"difference": np.zeros((5, 5), np.float32)}, r"difference has 5 columns for 6"),
        ({"difference": np.zeros((4, 6), np.float32)}, r"difference has shape \(4, 6\)"),
    ],
)
def test_a_damaged_difference_matrix_is_named(folder, change, message):
    path = folder / "arrays" / "_difference.npz"
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(change)
    path.write_bytes(npz_bytes(arrays))
    summary = json.loads((folder / "results.json").read_text())
    summary["files"]["arrays/_difference.npz"] = hashlib.sha256(path.read_bytes()).hexdigest()
    (folder / "results.json").write_text(json.dumps(summary))
    with pytest.raises(DataError, match=rf"_difference.npz: {message}"):
        load_results(folder)


def test_a_frame_index_outside_the_route_is_named(folder):
    path = folder / "arrays" / "beta.npz"
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["frame_index"] = np.array([0, 2, 3, 6])
    path.write_bytes(npz_bytes(arrays))
    summary = json.loads((folder / "results.json").read_text())
    summary["files"]["arrays/beta.npz"] = hashlib.sha256(path.read_bytes()).hexdigest()
    (folder / "results.json").write_text(json.dumps(summary))
    with pytest.raises(DataError, match=r"beta.npz: frame_index\[3\] is 6, outside 0\.\.5"):
        load_results(folder)


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


def test_each_place_has_its_column_and_a_baseline_is_shown_on_its_descriptor():
    def entry(kind: str, f1: float, **params) -> dict:
        keys = ("precision_at_f1", "recall_at_f1", "auc", "recall_at_100p", "precision_at_100r")
        more = dict.fromkeys((*keys, "latency_ms_p95", "energy_mj"))
        return {"map_kind": kind, "params": params, "f1_max": f1, "latency_ms_median": 1.0, **more}

    summary = {
        "methods": {
            "weighted-node-lowres": entry("lowres", 0.7),
            "weighted-node-lowres16": entry("lowres16", 0.8),
            "weighted-node-lbp": entry("lbp", 0.6),
            "weighted-node-patch": entry("patch", 0.9),
            "particle-filter": entry("particle-filter", 0.5, descriptor="lowres16"),
            "seqslam": entry("seqslam", 0.4),
            # a baseline's own image named or not: the same column either way
            "single-frame": entry("single-frame", 0.3, descriptor="patch"),
        }
    }
    header, rows = paper_table(summary)
    assert header[1::2] == [
        "F1 (8x8 image)",
        "F1 (16x16 image)",
        "F1 (32-bit LBP)",
        "F1 (64x32 patch-normalised)",
        "F1 (method's own)",
    ]
    table = {row[0]: row[1::2] for row in rows}
    assert table == {
        "weighted-node": ["0.700", "0.800", "0.600", "0.900", ""],
        "particle-filter": ["", "0.500", "", "", ""],
        "seqslam": ["", "", "", "", "0.400"],
        "single-frame": ["", "", "", "", "0.300"],
    }
    assert all(column_of(h) is not None for h in header)
    reps = [row[1] for row in comparison_table(summary)[1]]
    assert reps == [
        "8x8 image, SAD",
        "16x16 image, SAD",
        "32-bit LBP, Hamming",
        "64x32 patch-normalised image, SAD",
        "16x16 image, SAD",
        "patch-normalised image, SAD",
        "patch-normalised image, SAD",
    ]


def test_latency_against_map_size_keeps_its_legend_and_tells_the_presets_apart():
    # the demo's 19 methods (7 modelled too) ran the legend off the bottom of a 4.8 in
    # figure, and the paper's preset drew exactly as its default (same colour, line, marker)
    names = [f"weighted-node-m{i}" for i in range(8)] + ["weighted-node-paper-m0"]
    names += [f"onsensor-m{i}" for i in range(6)] + ["onsensor-paper-m0"]
    names += ["seqslam", "able-m", "particle-filter"]
    rows = [
        {
            "method": name,
            "n_nodes": n,
            "latency_ms_median": 1.0 + i,
            "latency_ms_p95": 2.0 + i,
            **({"modelled_latency_ms_median": 0.5} if name.startswith("onsensor") else {}),
        }
        for i, name in enumerate(names)
        for n in (64, 256)
    ]
    fig = figures.latency_vs_map_size({"rows": rows})
    fig.canvas.draw()
    (ax,) = fig.axes
    legend = ax.get_legend()
    assert len(legend.get_texts()) == len(names) + 7
    box, page = legend.get_window_extent(), fig.bbox
    assert page.y0 <= box.y0 and box.y1 <= page.y1 and box.x1 <= page.x1
    lines = {line.get_label(): line for line in ax.lines}
    for default, paper in [
        ("weighted-node-m0", "weighted-node-paper-m0"),
        ("onsensor-m0", "onsensor-paper-m0"),
        ("onsensor-m0 (modelled on-sensor)", "onsensor-paper-m0 (modelled on-sensor)"),
    ]:
        a, b = lines[default], lines[paper]
        assert a.get_color() == b.get_color() and a.get_linestyle() == b.get_linestyle()
        assert a.get_markerfacecolor() != b.get_markerfacecolor(), paper


def test_a_recall_at_k_the_method_cannot_give_is_explained(folder):
    # the report showed '-' under Recall@5 and Recall@10 (every on-sensor method's
    # Recall@K) and its definitions did not say why
    write_report(folder)
    md = (folder / "report.md").read_text()
    row = next(line for line in md.splitlines() if line.startswith("| alpha |") and "0.0" in line)
    assert row.split("|")[3:5] == [" - ", " - "]  # a ranking of one candidate: no @5, @10
    (term,) = [line for line in md.splitlines() if line.startswith("- **Recall@K**")]
    assert "'-' where the method ranks fewer than K candidates" in term


def test_figures_of_many_methods_draw_the_best_of_each_family(monkeypatch):
    # the demo's many places of one filter must not push the baselines out of its figures
    from types import SimpleNamespace

    monkeypatch.setattr(figures, "MAX_DRAWN", 4, raising=False)
    f1s = {
        "weighted-node-lowres": 0.99,
        "weighted-node-lowres16": 0.98,
        "weighted-node-lbp": 0.97,
        "weighted-node-haar": 0.96,
        "weighted-node-patch": 0.95,
        "weighted-node-paper-lbp": 0.94,
        "single-frame": 0.30,
        "particle-filter": 0.90,
        "seqslam": 0.80,
    }
    runs = {
        name: SimpleNamespace(method=name, params={}, metrics=SimpleNamespace(f1_max=f1))
        for name, f1 in f1s.items()
    }
    result = SimpleNamespace(runs=runs)
    # four families of five: the best of the filter's robust places, its paper preset,
    # the particle filter and SeqSLAM; single-frame is the family of lowest max F1
    assert figures.drawn_methods(result) == [
        "weighted-node-lowres",
        "weighted-node-paper-lbp",
        "particle-filter",
        "seqslam",
    ]
    assert "the best of each family" in figures.drawn_note(result)
    monkeypatch.setattr(figures, "MAX_DRAWN", 7, raising=False)  # room for two places more
    assert figures.drawn_methods(result) == [
        "weighted-node-lowres",
        "weighted-node-lowres16",
        "weighted-node-lbp",
        "weighted-node-paper-lbp",
        "single-frame",
        "particle-filter",
        "seqslam",
    ]
    # predictions read from a file are each a family of one: the highest max F1 alone
    for run in runs.values():
        run.params = {"predictions": "p.csv"}
    monkeypatch.setattr(figures, "MAX_DRAWN", 4, raising=False)
    assert figures.drawn_methods(result) == list(f1s)[:4]
    assert "of highest max F1 of the 9" in figures.drawn_note(result)
