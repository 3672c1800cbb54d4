"""The report page of a sweep, built from ``summary.json`` only.

:func:`write_sweep_report` writes ``report.html`` (self-contained, figures as base64 PNG,
the style of :mod:`ppaloc.evaluate.report`) and ``report.md`` (figures under
``figures/``) into a sweep's output folder:

1. the best cell per method and dataset (highest max F1, its parameters, its folder);
2. max F1 against each swept parameter: per method, the mean and the minimum over its
   cells with each value (a sensitivity table);
3. heat maps of max F1: method x dataset (the best cell of each), and for every method
   each pair of its swept axes (parameters, dataset, seed, tolerance), averaged over the
   other axes;
4. the failed cells with their errors, then every cell;
5. the datasets behind the short labels, and the sweep's configuration.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc import __version__
from ppaloc.errors import DataError
from ppaloc.evaluate.report import ReportFigure
from ppaloc.evaluate.sweep_grid import SUMMARY_VERSION, sweep_wrote
from ppaloc.fileio import new_folder, write_bytes

__all__ = [
    "best_cells",
    "dataset_labels",
    "f1_grid",
    "heatmap_axes",
    "load_summary",
    "sensitivity",
    "write_sweep_report",
]


def load_summary(out: str | Path) -> dict[str, Any]:
    """Read ``OUT/summary.json`` of a sweep.

    Raises
    ------
    DataError
        If it is missing, not strict JSON, not a sweep summary, or a field the report
        reads does not have the type ppaloc writes (a hand edit, a damaged file).
    """
    path = Path(out) / "summary.json"
    try:
        summary = json.loads(path.read_text(encoding="utf-8"), parse_constant=_not_json)
    except FileNotFoundError:
        raise DataError(
            f"{out} holds no summary.json; give a folder written by `ppaloc sweep --out`"
        ) from None
    except RecursionError:
        raise DataError(f"cannot read {path}: it is nested too deep") from None
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read {path}: {exc}") from None
    if not isinstance(summary, dict) or summary.get("format") != "ppaloc-sweep-summary":
        raise DataError(f"{path} is not a ppaloc sweep summary")
    version = summary.get("version", SUMMARY_VERSION)
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise DataError(f"{path}: 'version' is {_shown(version)}, expected a version number")
    if version > SUMMARY_VERSION:
        raise DataError(
            f"{path} is in sweep summary version {version}, newer than this ppaloc "
            f"{__version__} reads (1 to {SUMMARY_VERSION}); show it with the ppaloc that "
            "wrote it, or run the sweep again with this one"
        )
    problem = _summary_problem(summary)
    if problem:
        raise DataError(
            f"{path}: {problem}; run `ppaloc sweep --out {out}` again with its configuration "
            "(finished cells are kept) to write it anew"
        )
    return summary


def _not_json(name: str) -> Any:
    """NaN or Infinity, which ppaloc never writes in a summary (strict JSON)."""
    raise ValueError(f"it holds {name}, which is not JSON")


def _summary_problem(summary: Mapping[str, Any]) -> str | None:
    """The first field of a sweep summary that the report cannot read as ppaloc writes it
    (``collect_summary``), in words; None when every field it reads is right."""
    for key, kind, words in (
        ("config", dict, "a table"),
        ("axes", dict, "a table of lists"),
        ("cells", list, "a list of tables"),
        ("counts", dict, "a table of counts"),
    ):
        if not isinstance(summary.get(key), kind):
            return f"{key!r} {_state(summary, key)}, expected {words}"
    axes = summary["axes"]
    for name, values in axes.items():
        if not isinstance(values, list):
            return f"axes.{name} is {_shown(values)}, expected a list"
    for name in ("method", "dataset"):
        if not all(isinstance(v, str) for v in axes.get(name, [None])):
            return f"axes.{name} {_state(axes, name)}, expected a list of names"
    for key in ("cells", "ok", "failed", "not_run"):
        value = summary["counts"].get(key)
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            return f"counts.{key} {_state(summary['counts'], key)}, expected a count >= 0"
    for i, row in enumerate(summary["cells"]):
        if not isinstance(row, dict):
            return f"cells[{i}] is {_shown(row)}, expected a table"
        for key in ("method", "dataset", "status", "cell"):
            if not isinstance(row.get(key), str):
                return f"cells[{i}].{key} {_state(row, key)}, expected a string"
        for key, axis in (("method", "method"), ("dataset", "dataset")):
            if row[key] not in axes[axis]:
                return f"cells[{i}].{key} {row[key]!r:.80} is not in axes.{axis}"
        for key in ("f1_max", "auc", "recall_at_100p"):
            value = row.get(key)
            if value is not None and not _is_float(value):  # 1e400 reads as inf, 10**400 an int
                return f"cells[{i}].{key} is {_shown(value)}, expected a number or null"
    return None


def _is_float(value: Any) -> bool:
    """``value`` is a finite number a float holds (an int of 400 digits is not one)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    return -sys.float_info.max <= value <= sys.float_info.max


def _state(table: Mapping[str, Any], key: str) -> str:
    """What a summary's ``table`` holds under ``key``, in words: ``is missing`` where it has
    no such field (which read ``is None``, as if the field said null), else ``is VALUE``."""
    return "is missing" if key not in table else f"is {_shown(table[key])}"


def _shown(value: Any) -> str:
    """A value of a summary as a message shows it: its repr, cut to 60 characters."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _key(v: Any) -> str:
    return json.dumps(v, sort_keys=True)


def _text(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:g}"
    return v if isinstance(v, str) else json.dumps(v)


def _fmt(v: Any) -> str:
    return "-" if v is None else f"{v:.3f}"


def dataset_labels(specs: Sequence[str], *, width: int = 44) -> dict[str, str]:
    """Short labels of dataset specs: what tells each apart from the others.

    The kind (when the specs are of several kinds), the folder's name (when specs of one
    kind read different folders) and the ``key=value`` pairs that differ between the
    specs of the same kind. Labels longer than ``width`` are cut; if two labels come out
    the same, the specs are numbered ``D1``, ``D2``, ... instead.

    Examples
    --------
    >>> dataset_labels(["synthetic:?places=100&seed=1", "synthetic:?places=100&seed=2"])
    {'synthetic:?places=100&seed=1': 'seed=1', 'synthetic:?places=100&seed=2': 'seed=2'}
    >>> list(dataset_labels(["nordland:data/nl?query=winter", "synthetic:?seed=3",
    ...                      "synthetic:?seed=4"]).values())
    ['nordland', 'synthetic seed=3', 'synthetic seed=4']
    >>> dataset_labels(["synthetic:?seed=1"])
    {'synthetic:?seed=1': 'synthetic:?seed=1'}
    """
    if len(specs) < 2:
        return {s: _shorten(s, width) for s in specs}
    parsed = []
    for spec in specs:
        head, _, query = spec.partition("?")
        kind, _, path = head.partition(":")
        parsed.append((kind, path, [p for p in query.split("&") if p]))
    kinds = {k for k, _, _ in parsed}
    labels = {}
    for spec, (kind, path, pairs) in zip(specs, parsed, strict=True):
        same = [(pa, pp) for k, pa, pp in parsed if k == kind]
        common = set.intersection(*(set(pp) for _, pp in same))
        words = [kind] if len(kinds) > 1 else []
        if len({pa for pa, _ in same}) > 1:
            words.append(Path(path.split(",")[0]).name or path)
        rest = "&".join(p for p in pairs if p not in common)
        words += [rest] if rest else []
        labels[spec] = _shorten(" ".join(words) or spec, width)
    if len(set(labels.values())) < len(labels):  # the same text twice: number them
        labels = {s: f"D{i + 1}" for i, s in enumerate(specs)}
    return labels


def _shorten(text: str, width: int) -> str:
    return text if len(text) <= width else text[: width - 1] + "…"


def best_cells(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The best finished cell (highest ``f1_max``; ties: the first in the grid) of every
    method and dataset, by method then dataset; ``row`` is None where no cell finished.

    Returns
    -------
    list of dict
        ``method``, ``dataset``, ``row`` (the summary row), ``ok`` and ``cells`` (finished
        and all cells of that method and dataset).
    """
    groups: dict[tuple[str, str], dict[str, Any]] = {}
    for row in summary["cells"]:
        g = groups.setdefault(
            (row["method"], row["dataset"]),
            {"method": row["method"], "dataset": row["dataset"], "row": None, "ok": 0, "cells": 0},
        )
        g["cells"] += 1
        if row["status"] != "ok" or row.get("f1_max") is None:
            continue
        g["ok"] += 1
        if g["row"] is None or row["f1_max"] > g["row"]["f1_max"]:
            g["row"] = row
    methods = {m: i for i, m in enumerate(summary["axes"]["method"])}
    datasets = {d: i for i, d in enumerate(summary["axes"]["dataset"])}
    return sorted(
        groups.values(),
        key=lambda g: (methods.get(g["method"], 0), datasets.get(g["dataset"], 0)),
    )


def sensitivity(summary: Mapping[str, Any]) -> list[tuple[str, list[str], list[list[str]]]]:
    """Max F1 against each swept method parameter: one table per parameter, one row per
    value.

    A *route* is a dataset with a seed and a tolerance. Per method that sweeps the
    parameter: the mean and the minimum over the routes of its max F1 at that value (per
    route, the mean over its cells with that value, i.e. over its other parameters). With
    two or more such methods, also the best of them per route, its mean and minimum (the
    columns of ``benchmarks/sensitivity_robust.py``).

    Returns
    -------
    list of (parameter, header, rows)
    """
    out = []
    general = ("method", "dataset", "seed", "tolerance")
    for axis in summary["axes"]:
        if axis in general:
            continue
        methods = [
            m
            for m in summary["axes"]["method"]
            if any(r["method"] == m and r.get(axis) is not None for r in summary["cells"])
        ]
        header = [axis]
        for m in methods:
            header += [f"{m} mean", f"{m} min"]
        several = len(methods) > 1
        if several:
            best = "better of the two" if len(methods) == 2 else "best of the methods"
            header += [f"{best}, mean", f"{best}, min"]
        rows = []
        # the finished cells by their value of the axis, read once (each value scanned
        # every cell: 300 x 300 values took minutes)
        by_value: dict[str, list[Mapping[str, Any]]] = {}
        for r in summary["cells"]:
            if (
                r["method"] in methods
                and r["status"] == "ok"
                and r.get("f1_max") is not None
                and r.get(axis) is not None
            ):
                by_value.setdefault(_key(r[axis]), []).append(r)
        for value in summary["axes"][axis]:
            per: dict[str, dict[str, list[float]]] = {m: {} for m in methods}
            for r in by_value.get(_key(value), []):
                route = _key([r["dataset"], r.get("seed"), r.get("tolerance")])
                per[r["method"]].setdefault(route, []).append(float(r["f1_max"]))
            means = {m: {k: float(np.mean(v)) for k, v in per[m].items()} for m in methods}
            row = [_text(value)]
            for m in methods:
                row += _mean_min(list(means[m].values()))
            if several:
                routes = set.intersection(*(set(means[m]) for m in methods))
                row += _mean_min([max(means[m][k] for m in methods) for k in routes])
            rows.append(row)
        out.append((axis, header, rows))
    return out


def _mean_min(values: list[float]) -> list[str]:
    if not values:
        return ["-", "-"]
    return [_fmt(float(np.mean(values))), _fmt(min(values))]


def _axis_values(summary: Mapping[str, Any], axis: str, rows: Sequence[Mapping]) -> list[Any]:
    present = {_key(r.get(axis)) for r in rows if r.get(axis) is not None}
    ordered = [v for v in summary["axes"].get(axis, []) if _key(v) in present]
    return ordered


def heatmap_axes(summary: Mapping[str, Any]) -> list[tuple[str | None, str, str]]:
    """The heat maps of a sweep as ``(method, row axis, column axis)``; method None is the
    method x dataset map (best cell of each).

    Per method: the axes it sweeps with at least two values (its parameters, then
    ``dataset``, ``seed``, ``tolerance``), every pair of them (with ``combine =
    "one-at-a-time"`` no pair of two parameters: they were never varied together). A
    method with one swept axis gets it against ``dataset``.
    """
    out: list[tuple[str | None, str, str]] = []
    methods = summary["axes"]["method"]
    datasets = summary["axes"]["dataset"]
    if len(methods) > 1 or len(datasets) > 1:
        out.append((None, "method", "dataset"))
    together = summary["config"].get("combine", "product") == "product"
    general = ("dataset", "seed", "tolerance")
    for method in methods:
        rows = [r for r in summary["cells"] if r["method"] == method]
        swept = [
            a
            for a in summary["axes"]
            if a not in ("method", "dataset") and len(_axis_values(summary, a, rows)) > 1
        ]
        if len(datasets) > 1:
            swept.insert(len([a for a in swept if a not in general]), "dataset")
        params = [a for a in swept if a not in general]
        if len(swept) == 1 and swept[0] != "dataset":
            out.append((method, swept[0], "dataset"))
            continue
        for i, a in enumerate(swept):
            for b in swept[i + 1 :]:
                if together or a not in params or b not in params:
                    out.append((method, a, b))
    return out


def f1_grid(
    summary: Mapping[str, Any], method: str | None, row_axis: str, col_axis: str
) -> tuple[list[Any], list[Any], np.ndarray]:
    """Max F1 over two axes: ``(row values, column values, matrix)``, NaN where no cell
    finished. For a method: the mean over its other axes; for ``method=None`` (the method
    x dataset map): the best cell of each method and dataset."""
    rows = [
        r
        for r in summary["cells"]
        if (method is None or r["method"] == method)
        and r["status"] == "ok"
        and r.get("f1_max") is not None
    ]
    everything = [r for r in summary["cells"] if method is None or r["method"] == method]
    yv = _axis_values(summary, row_axis, everything)
    xv = _axis_values(summary, col_axis, everything)
    yi = {_key(v): i for i, v in enumerate(yv)}
    xi = {_key(v): i for i, v in enumerate(xv)}
    cells: dict[tuple[int, int], list[float]] = {}
    for r in rows:
        a, b = r.get(row_axis), r.get(col_axis)
        if a is None or b is None:
            continue
        cells.setdefault((yi[_key(a)], xi[_key(b)]), []).append(float(r["f1_max"]))
    grid = np.full((len(yv), len(xv)), np.nan)
    for (i, j), values in cells.items():
        grid[i, j] = max(values) if method is None else float(np.mean(values))
    return yv, xv, grid


MAX_WRITTEN_CELLS = 400
"""Most squares of a heat map that carry their value as text; a larger map is colours
alone (its values are in ``summary.csv``): 300 x 300 values, a text each, took over ten
minutes to draw."""

MAX_TICKS = 40
"""Most labelled ticks along a heat map's axis; beyond, every k-th value is labelled."""


def _every(n: int) -> range:
    """The ticks labelled along an axis of ``n`` values: all of up to :data:`MAX_TICKS`,
    else every k-th from the first."""
    return range(0, n, max(1, -(-n // MAX_TICKS)))


def _heatmap(
    grid: np.ndarray, ylabels: list[str], xlabels: list[str], ylabel: str, xlabel: str, title: str
) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    ny, nx = grid.shape
    longest = max(map(len, ylabels), default=0)
    width = min(14.0, max(4.5, 2.2 + 0.95 * nx + 0.07 * longest, 1.4 + 0.085 * len(title)))
    rotate = nx > 4
    below = 0.05 * max(map(len, xlabels), default=0) if rotate else 0.0  # slanted tick labels
    height = min(14.0, max(2.6, 1.6 + 0.42 * ny + below))
    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    masked = np.ma.masked_invalid(grid)
    im = ax.imshow(masked, vmin=0.0, vmax=1.0, cmap="viridis", aspect="auto")
    ax.set_facecolor("#e4e4e8")
    if ny * nx <= MAX_WRITTEN_CELLS:
        for i in range(ny):
            for j in range(nx):
                v = grid[i, j]
                text = "-" if math.isnan(v) else f"{v:.2f}"
                colour = "black" if math.isnan(v) or v > 0.6 else "white"
                ax.text(j, i, text, ha="center", va="center", fontsize=8, color=colour)
    xs, ys = _every(nx), _every(ny)
    ax.set_xticks(
        xs,
        [xlabels[j] for j in xs],
        rotation=30 if rotate else 0,
        ha="right" if rotate else "center",
    )
    ax.set_yticks(ys, [ylabels[i] for i in ys])
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    fig.colorbar(im, ax=ax, label="max F1", shrink=0.9)
    return fig


def _figures(summary: Mapping[str, Any], labels: Mapping[str, str]) -> list[ReportFigure]:
    from ppaloc.evaluate.figures import png_bytes

    def names(axis: str, values: list[Any]) -> list[str]:
        return [labels.get(v, v) if axis == "dataset" else _text(v) for v in values]

    out = []
    for n, (method, a, b) in enumerate(heatmap_axes(summary)):
        yv, xv, grid = f1_grid(summary, method, a, b)
        if not grid.size:
            continue
        if method is None:
            title = "Max F1 of the best cell, method x dataset"
            caption = (
                "Each square: the highest max F1 of a method on a dataset over its swept "
                "parameters (the best-cell table). '-': no cell finished."
            )
        else:
            title = f"{method}: max F1 over {a} x {b}"
            others = [
                x
                for x in heatmap_axes_of(summary, method)
                if x not in (a, b) and x not in ("method",)
            ]
            rest = f", mean over {', '.join(others)}" if others else ""
            caption = f"Max F1 of {method} by {a} and {b}{rest}. '-': no cell finished."
        if grid.size > MAX_WRITTEN_CELLS:
            caption = caption.replace(
                "'-': no cell finished.",
                f"Colours alone (more than {MAX_WRITTEN_CELLS} squares): the values are in "
                "summary.csv; grey: no cell finished.",
            )
        fig = _heatmap(grid, names(a, yv), names(b, xv), a, b, title)
        out.append(ReportFigure(f"heatmap-{n + 1}", title, caption, png_bytes(fig)))
    return out


def heatmap_axes_of(summary: Mapping[str, Any], method: str) -> list[str]:
    """The axes along which ``method``'s cells differ (two or more values)."""
    rows = [r for r in summary["cells"] if r["method"] == method]
    return [a for a in summary["axes"] if a != "method" and len(_axis_values(summary, a, rows)) > 1]


def _html_table_plain(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(v)}</td>" for v in r) + "</tr>" for r in rows
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _swept_text(row: Mapping[str, Any], axis_names: Sequence[str]) -> str:
    return ", ".join(f"{a}={_text(row[a])}" for a in axis_names if row.get(a) is not None) or "-"


def _md_cells(rows: list[list[str]]) -> list[list[str]]:
    return [[v.replace("|", "\\|") for v in r] for r in rows]


def _check_figures(out: Path) -> None:
    """Refuse to rebuild the report of the sweep folder ``out`` where its ``figures/`` holds
    an entry a sweep did not write: the figures are replaced whole, and a user's file must
    not go with them."""
    figures = out / "figures"
    if figures.is_symlink() or not figures.is_dir():
        return
    for root, dirs, files in os.walk(figures):
        dirs.sort()
        for name in sorted([*dirs, *files]):
            rel = (Path(root) / name).relative_to(out).as_posix()
            if not sweep_wrote(out, rel):
                raise DataError(
                    f"{out} holds {rel!r}, which a sweep did not write, and the report's "
                    "figures are replaced whole; move it out of figures/ first"
                )


def write_sweep_report(out: str | Path) -> Path:
    """Write ``report.html`` and ``report.md`` into a sweep's folder, from ``summary.json``;
    ``figures/`` (the heat maps for report.md) is replaced whole.

    Returns
    -------
    Path
        ``out/report.html``.

    Raises
    ------
    DataError
        No readable ``summary.json``, or ``figures/`` holds a file the report does not
        write (it would be lost with the old figures).
    """
    from ppaloc.evaluate.report import _CSS, _html_table, _md_table

    out = Path(out)
    summary = load_summary(out)
    _check_figures(out)
    labels = dataset_labels(summary["axes"]["dataset"])
    swept = [a for a in summary["axes"] if a not in ("method", "dataset")]
    figs = _figures(summary, labels)
    counts = summary["counts"]

    best_header = [
        "Method",
        "Dataset",
        "Best F1",
        "AUC",
        "R @100%P",
        "Swept values",
        "Cells ok",
        "Cell",
    ]
    best_rows = []
    for g in best_cells(summary):
        r = g["row"]
        best_rows.append(
            [
                g["method"],
                labels.get(g["dataset"], g["dataset"]),
                _fmt(r and r.get("f1_max")),
                _fmt(r and r.get("auc")),
                _fmt(r and r.get("recall_at_100p")),
                _swept_text(r, swept) if r else "-",
                f"{g['ok']}/{g['cells']}",
                r["cell"] if r else "-",
            ]
        )
    all_header = ["Method", "Dataset", *swept, "F1", "AUC", "R @100%P", "Status"]
    all_rows = [
        [
            r["method"],
            labels.get(r["dataset"], r["dataset"]),
            *(_text(r.get(a)) for a in swept),
            _fmt(r.get("f1_max")),
            _fmt(r.get("auc")),
            _fmt(r.get("recall_at_100p")),
            r["status"],
        ]
        for r in summary["cells"]
    ]
    failed = [r for r in summary["cells"] if r["status"] not in ("ok", "not run")]
    fail_header = ["Method", "Dataset", "Swept values", "Error", "Cell"]
    fail_rows = [
        [
            r["method"],
            labels.get(r["dataset"], r["dataset"]),
            _swept_text(r, swept),
            r["status"],
            r["cell"],
        ]
        for r in failed
    ]
    ds_rows = [[labels[s], s] for s in summary["axes"]["dataset"]]
    title = f"ppaloc sweep: {counts['cells']} cells"
    meta = (
        f"{counts['ok']} finished, {counts['failed']} failed, {counts['not_run']} not run; "
        f"{len(summary['axes']['method'])} methods x {len(summary['axes']['dataset'])} "
        f"datasets; swept: {', '.join(swept) or 'nothing but methods and datasets'}. "
        f"ppaloc {summary.get('ppaloc_version', '')}"
        + (f", {summary['created']}." if summary.get("created") else ".")
    )
    config = json.dumps(summary["config"], indent=2)
    parts = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        "<meta name='viewport' content='width=device-width, initial-scale=1'>",
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1><p class='meta'>{html.escape(meta)}</p>",
        "<nav>"
        + " · ".join(
            [
                "<a href='#best'>Best cells</a>",
                *(
                    f"<a href='#sensitivity-{html.escape(a)}'>Max F1 against {html.escape(a)}</a>"
                    for a, _, _ in sensitivity(summary)
                ),
                *(f"<a href='#{f.key}'>{html.escape(f.title)}</a>" for f in figs),
                *(["<a href='#failed'>Failed cells</a>"] if failed else []),
                "<a href='#cells'>All cells</a>",
                "<a href='#datasets'>Datasets</a>",
                "<a href='#configuration'>Configuration</a>",
            ]
        )
        + "</nav>",
        "<h2 id='best'>Best cell per method and dataset</h2>",
        "<p>The finished cell with the highest max F1 of each method on each dataset; its "
        "folder (under this one) holds its results.json, results.csv and arrays "
        "(<code>ppaloc show FOLDER</code> draws its report). Best F1 per column in bold "
        "green.</p>",
        _html_table(best_header, best_rows, best_cols=(2, 3, 4)),
    ]
    tables = sensitivity(summary)
    for axis, header, rows in tables:
        parts.append(
            f"<h2 id='sensitivity-{html.escape(axis)}'>Max F1 against {html.escape(axis)}</h2>"
        )
        parts.append(
            "<p>Per method, the mean and the minimum of max F1 over its finished cells with "
            "each value (over the datasets, seeds and its other parameters).</p>"
        )
        parts.append(_html_table(header, rows, best_cols=tuple(range(1, len(header)))))
    for f in figs:
        b64 = base64.b64encode(f.png).decode("ascii")
        parts.append(
            f"<h2 id='{f.key}'>{html.escape(f.title)}</h2><figure>"
            f"<img src='data:image/png;base64,{b64}' alt='{html.escape(f.title)}'>"
            f"<figcaption>{html.escape(f.caption)}</figcaption></figure>"
        )
    if failed:
        parts.append("<h2 id='failed'>Failed cells</h2>")
        parts.append(
            "<p>Run the same sweep again to retry them (finished cells are skipped); each "
            "folder's error.json holds the traceback.</p>"
        )
        parts.append(_html_table_plain(fail_header, fail_rows))
    parts.append("<h2 id='cells'>All cells</h2>")
    parts.append(_html_table(all_header, all_rows, best_cols=()))
    parts.append("<h2 id='datasets'>Datasets</h2>")
    parts.append(_html_table_plain(["Label", "Spec"], ds_rows))
    parts.append("<h2 id='configuration'>Configuration</h2>")
    parts.append(f"<pre>{html.escape(config)}</pre></body></html>\n")
    path = write_bytes(out / "report.html", "\n".join(parts))

    best_rows, all_rows, fail_rows = (_md_cells(t) for t in (best_rows, all_rows, fail_rows))
    md = [f"# {title}", "", meta, "", "## Best cell per method and dataset", ""]
    md += [_md_table(best_header, best_rows), ""]
    for axis, header, rows in tables:
        md += [f"## Max F1 against {axis}", "", _md_table(header, rows), ""]
    with new_folder(out / "figures") as stage:  # the figures replaced whole, old ones dropped
        for f in figs:
            rel = f"figures/{f.key}.png"
            write_bytes(stage / f"{f.key}.png", f.png)
            md += [f"## {f.title}", "", f"![{f.title}]({rel})", "", f.caption, ""]
    if failed:
        md += ["## Failed cells", "", _md_table(fail_header, fail_rows), ""]
    md += ["## All cells", "", _md_table(all_header, all_rows), ""]
    md += ["## Datasets", "", _md_table(["Label", "Spec"], ds_rows), ""]
    md += ["## Configuration", "", "```json", config, "```", ""]
    write_bytes(out / "report.md", "\n".join(md))
    return path
