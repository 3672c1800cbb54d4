"""What each ``ppaloc`` command does, as thin functions over the library.

Each ``run_*`` takes already-parsed, typed arguments (a config dataclass, paths), calls
the library (``ppaloc.evaluate``, ``ppaloc.methods``, ``ppaloc.topomap``) and prints a short
summary. The click parsers in :mod:`ppaloc.cli.main` only read flags and config files.
"""

from __future__ import annotations

import sys
import time
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.cli.localise import run_localise
from ppaloc.cli.outputs import (
    check_png,
    check_suffix,
    default_png,
    refuse_input_as_out,
    refuse_link_loop,
)
from ppaloc.errors import DataError, PpalocError

__all__ = [
    "refuse_out_in_datasets",
    "run_bench",
    "run_demo",
    "run_evaluate",
    "run_localise",
    "run_map",
    "run_matrix",
    "run_score",
    "run_show",
    "run_sweep",
    "run_warm_up",
]


def _console():
    from rich.console import Console

    return Console(highlight=False, soft_wrap=False, width=None if sys.stdout.isatty() else 160)


_NARROW_DROPS = ("P@F1", "R@F1", "loop ms", "AUC", "chip ms", "mJ", "P@100R", "R@100P")
"""The printed table's columns left out, in this order (those without a figure first),
until its method names fit whole on a narrow terminal (80 columns: the names had folded
into five-letter pieces)."""


def print_results_table(summary: dict[str, Any], *, title: str = "") -> None:
    """Print the comparison table of a ``results.json`` summary on stdout."""
    from rich import box
    from rich.table import Table

    from ppaloc.evaluate.report import comparison_table, method_notes

    header, rows = comparison_table(summary, short=True)
    keep = [i for i, h in enumerate(header) if h not in ("Repr.", "p95 ms")]
    widths = [max([len(header[i])] + [len(r[i]) for r in rows]) for i in range(len(header))]
    console = _console()
    left_out = []
    empty = [
        n for n in _NARROW_DROPS if n in header and {r[header.index(n)] for r in rows} <= {"-"}
    ]
    for name in [*empty, *_NARROW_DROPS]:  # names whole on a narrow terminal: fewer columns
        if sum(widths[i] + 2 for i in keep) + 1 <= console.width:  # padding, rules, edges
            break
        if name in header and header.index(name) in keep:
            keep.remove(header.index(name))
            left_out.append(name)
    table = Table(
        title=title or None,
        title_justify="left",
        box=box.SIMPLE_HEAD,
        pad_edge=False,
        padding=(0, 1, 0, 0),
    )
    for i in keep:
        if i == 0:  # the method name folds on a terminal too narrow still, numbers never do
            table.add_column(header[i], overflow="fold")
        else:
            table.add_column(header[i], justify="right", min_width=widths[i])
    for r in rows:
        table.add_row(*(r[i] for i in keep))
    console.print(table)
    recall = {m.get("recall_definition", "A") for m in summary["methods"].values()}
    config = summary.get("config")
    scored = isinstance(config, dict) and config.get("command") == "score"
    host = (
        "median time per query as the predictions file gives it"
        if scored
        else "median wall-clock time of step on this machine"
    )
    turning = (
        "F1 str., F1 turn = max F1 of the straight and of the turning query frames alone;\n"
        if "F1 str." in header
        else ""
    )
    print(
        f"F1 = max F1 (recall definition {', '.join(sorted(recall))}); "
        f"R@100P = recall at 100% precision;\n{turning}"
        "P@100R = precision with every query accepted (100% recall under recall B and C);\n"
        f"host ms = {host};\n"
        "chip ms, loop ms = modelled time per frame on the sensor and for the whole hardware "
        "loop (docs/onsensor.md, Timing);\nmJ = modelled energy per frame."
    )
    for note in method_notes(summary, short=True):
        print(f"note: {note}")
    if left_out:
        print(
            f"left out to fit this terminal's {console.width} columns: {', '.join(left_out)} "
            "(a wider terminal shows them; results.csv and the report hold every figure)"
        )


# -- evaluate ------------------------------------------------------------------------------


def run_evaluate(
    config: Any,
    out: Path,
    *,
    quiet: bool = False,
    bench: Any = None,
    report: bool = True,
    shown_as: Path | None = None,
) -> Path:
    """Run ``config`` (an EvaluateConfig), write results (and report) as the folder ``out``,
    replacing it whole (``shown_as``: the folder name to print, if not ``out``).

    Returns
    -------
    Path
        ``out/results.json``.
    """
    from ppaloc.evaluate.run import run_evaluation

    _check_results_out(out, config.dataset)
    result = run_evaluation(config, progress=not quiet)
    return _write_run(result, out, quiet=quiet, bench=bench, report=report, shown_as=shown_as)


def _write_run(
    result: Any,
    out: Path,
    *,
    quiet: bool,
    bench: Any = None,
    report: bool = True,
    shown_as: Path | None = None,
) -> Path:
    """Write a RunResult (of ``evaluate`` or ``score``) as the folder ``out`` with its
    report, in one transaction; print the table. Returns ``out/results.json``."""
    from ppaloc.evaluate.bench import save_bench
    from ppaloc.evaluate.report import write_report_files
    from ppaloc.evaluate.results import results_folder, write_results

    # One transaction: `out` is replaced whole by the results, bench and report at the end.
    with results_folder(out) as stage:
        write_results(result, stage)
        if bench is not None:
            save_bench(_bench_with_bar(bench, quiet=quiet), stage / "bench.json")
        if report:
            write_report_files(stage)
    path = out / "results.json"
    if not quiet:
        import json

        summary = json.loads(path.read_text(encoding="utf-8"))
        print_results_table(summary, title=f"{result.dataset_name} ({result.dataset})")
        print(f"results: {shown_as or out}/results.json")
        if report:
            print(f"report:  {shown_as or out}/report.html")
    return path


def run_score(config: Any, out: Path, *, quiet: bool = False, report: bool = True) -> Path:
    """Score predictions files (a ScoreConfig) against a dataset: the same metrics, result
    files and report as ``run_evaluate``, written as the folder ``out``.

    Returns
    -------
    Path
        ``out/results.json``.
    """
    from ppaloc.evaluate.score import score_predictions

    _check_results_out(out, config.dataset, [Path(p) for p in config.predictions])
    result = score_predictions(config)
    return _write_run(result, out, quiet=quiet, report=report)


def _dataset_paths(spec: str, *, reference: bool = False) -> list[Path]:
    """The files and folders a dataset spec reads (``reference``: a spec of ``ppaloc map``,
    whose reference may come alone); none when the spec does not parse (its own error
    comes when it is loaded)."""
    from ppaloc.datasets.registry import parse_dataset_spec, parse_reference_spec

    try:
        return list((parse_reference_spec if reference else parse_dataset_spec)(spec).paths)
    except PpalocError:
        return []


def refuse_out_in_datasets(out: Path, specs: Sequence[str], *, reference: bool = False) -> None:
    """Refuse an ``out`` that is a file or folder of the datasets ``specs`` read, or lies
    inside one (``evaluate`` refused it; ``sweep`` and ``cpp run --dataset`` wrote their
    folder among the frames); ``reference``: specs whose reference may come alone."""
    for spec in specs:
        refuse_input_as_out(out, _dataset_paths(spec, reference=reference), what="the dataset's")


def _check_results_out(out: Path, spec: str, inputs: Sequence[Path] = ()) -> None:
    """Before any work: ``out`` can become a results folder (absent, empty or an earlier
    one), and is neither an input nor inside a file or folder the dataset reads."""
    from ppaloc.evaluate.results import check_replaceable

    _check_out_dir(out)
    check_replaceable(out)
    refuse_input_as_out(out, inputs)
    refuse_input_as_out(out, _dataset_paths(spec), what="the dataset's")


def run_matrix(
    configs: Sequence[Any], out: Path, *, quiet: bool = False, report: bool = True
) -> Path:
    """Methods x datasets: one results folder per dataset under ``out`` and ``matrix.csv``.

    Returns
    -------
    Path
        ``out/matrix.csv``: one row per (dataset, method) with the columns of
        ``results.csv`` after ``dataset`` and ``folder``.
    """
    import csv
    import io
    import json

    from ppaloc.evaluate.results import CSV_COLUMNS, check_replaceable, results_folder
    from ppaloc.fileio import write_bytes

    _check_out_dir(out)
    check_replaceable(out)
    for config in configs:
        refuse_input_as_out(out, _dataset_paths(config.dataset), what="the dataset's")
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["dataset", "folder", *CSV_COLUMNS])
    with results_folder(out) as stage:  # the whole matrix replaces `out` at the end
        for i, config in enumerate(configs):
            name = matrix_folder(i, config.resolved_dataset())
            path = run_evaluate(
                config, stage / name, quiet=quiet, report=report, shown_as=out / name
            )
            spec = json.loads(path.read_text(encoding="utf-8"))["dataset"]
            with open(path.with_suffix(".csv"), encoding="utf-8", newline="") as f:
                for row in list(csv.reader(f))[1:]:
                    writer.writerow([spec, name, *row])
        write_bytes(stage / "matrix.csv", text.getvalue())
    matrix = out / "matrix.csv"
    if not quiet:
        print(f"matrix: {matrix}")
    return matrix


def matrix_folder(position: int, spec: str) -> str:
    """The results folder of the dataset at ``position`` (0-based) of a matrix run.

    ``NN-<kind>-<last part of each path>-<keys>-<hash>``: the spec made readable (its
    folders dropped, the kind left out where the first path's last part begins with it,
    runs of other characters as ``-``, cut to 64 characters) and the first 8 hex digits
    of the SHA-256 of the whole spec as run, so two specs never share a name even where
    their readable parts are cut alike, and the same spec gets the same name in every run.

    Examples
    --------
    >>> matrix_folder(0, "nordland:../shared/data/nordland-64x32?ref=summer&query=winter")
    '01-nordland-64x32-ref-summer-query-winter-2a00ad56'
    >>> matrix_folder(1, "synthetic:?places=300&query=night")
    '02-synthetic-places-300-query-night-077fb80d'
    """
    import hashlib
    import re

    def readable(text: str) -> str:
        return re.sub(r"[^A-Za-z0-9]+", "-", text).strip("-")

    head, _, query = spec.partition("?")
    kind, _, paths = head.partition(":")
    tails = [re.split(r"[/\\]", p.strip().rstrip("/"))[-1] for p in paths.split(",")]
    said = tails[0] and readable(tails[0]).lower().startswith(readable(kind).lower())
    parts = [*([] if said else [kind]), *tails]
    slug = readable("-".join([*parts, query]))[:64].strip("-")
    digest = hashlib.sha256(spec.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    return f"{position + 1:02d}-{slug or 'dataset'}-{digest}"


def _check_out_dir(out: Path) -> None:
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {out} is a file; give a folder for the results")


def run_demo(
    out: Path,
    *,
    quiet: bool = False,
    places: int = 200,
    bench_sizes: Sequence[int] = (64, 256, 1024, 4096),
) -> Path:
    """The built-in synthetic route, every available method, table, report with bench."""
    from ppaloc.evaluate.config import BenchConfig, EvaluateConfig, demo_dataset

    dataset = demo_dataset(places)
    t0 = time.perf_counter()
    path = run_evaluate(
        EvaluateConfig(dataset=dataset),
        out,
        quiet=quiet,
        bench=BenchConfig(sizes=tuple(bench_sizes), queries=20, warmup=2, max_build_s=4.0),
    )
    if not quiet:
        print(f"demo done in {time.perf_counter() - t0:.0f} s; open {out / 'report.html'}")
    return path


# -- bench ---------------------------------------------------------------------------------


def run_bench(config: Any, out: Path | None, *, quiet: bool = False) -> dict[str, Any]:
    """Time every method against map size; print a table; write ``out/bench.json``."""
    from rich.table import Table

    from ppaloc.evaluate.bench import save_bench
    from ppaloc.evaluate.results import check_replaceable
    from ppaloc.fileio import update_folder

    if out is not None:
        _check_out_dir(out)
        check_replaceable(out)
    bench = _bench_with_bar(config, quiet=quiet)
    if out is not None:
        out.parent.mkdir(parents=True, exist_ok=True)
        with update_folder(out) as stage:  # bench.json and bench.csv replace theirs together
            save_bench(bench, stage / "bench.json")
        path = out / "bench.json"
    if not quiet:
        table = Table(title="Host time per frame (ms) against map size", title_justify="left")
        sizes = list(config.sizes)
        table.add_column("Method")
        for s in sizes:
            table.add_column(f"{s} nodes", justify="right")
        for name in dict.fromkeys(r["method"] for r in bench["rows"]):
            cells = {r["n_nodes"]: r for r in bench["rows"] if r["method"] == name}
            table.add_row(name, *(_bench_cell(cells.get(s)) for s in sizes))
        _console().print(table)
        if out is not None:
            print(f"bench: {path}")
    return bench


def _bench_with_bar(config: Any, *, quiet: bool) -> dict[str, Any]:
    """Run the bench with a progress bar per method (on a terminal, unless quiet)."""
    from ppaloc.evaluate.bench import run_bench as bench_run
    from ppaloc.evaluate.run import ProgressBar, resolve_methods

    with ProgressBar(not quiet) as bar:
        for name in resolve_methods(config.methods):
            bar.add(name, len(config.sizes), label=f"{name} vs map size")
        return bench_run(config, progress=bar)


def _bench_cell(row: dict[str, Any] | None) -> str:
    if row is None or "skipped" in row:
        return "-"
    return f"{row['latency_ms_median']:.3g}"


# -- sweep ---------------------------------------------------------------------------------


def run_sweep(
    config: Any,
    out: Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    connect_timeout: float = 10.0,
    quiet: bool = False,
    report: bool = True,
    source: str = "",
) -> Any:
    """Run a sweep (a SweepConfig) into ``out``; print the best cells; write the report.

    Raises
    ------
    PpalocError
        Before any cell runs for a bad configuration or an unreachable scheduler; after
        the summary and report are written when cells failed (the first one's error).
    """
    from ppaloc.evaluate.sweep import run_sweep as sweep_run
    from ppaloc.evaluate.sweep_report import write_sweep_report

    refuse_out_in_datasets(out, config.datasets)
    outcome = sweep_run(
        config,
        out,
        scheduler=scheduler,
        workers=workers,
        connect_timeout=connect_timeout,
        progress=not quiet,
        source=source,
    )
    if report:
        write_sweep_report(out)
    summary = outcome.summary
    if not quiet:
        _print_best_cells(summary)
        c = summary["counts"]
        print(
            f"{c['cells']} cells: {outcome.n_skipped} already done, {outcome.n_run} run now, "
            f"{c['ok']} finished, {c['failed']} failed"
        )
        print(f"summary: {out / 'summary.csv'}")
        if report:
            print(f"report:  {out / 'report.html'}")
    if outcome.failures:
        cell, error = outcome.failures[0]
        raise PpalocError(
            f"{len(outcome.failures)} of {outcome.n_cells} cells failed, the first "
            f"({cell.label()}): {error}; the errors are in {out / 'summary.csv'}, run the "
            "same command again to retry them"
        )
    return outcome


def _print_best_cells(summary: dict[str, Any]) -> None:
    """Print a sweep summary's best cell per method and dataset (a table)."""
    from rich import box
    from rich.table import Table

    from ppaloc.evaluate.sweep_report import best_cells, dataset_labels

    labels = dataset_labels(summary["axes"]["dataset"])
    swept = [a for a in summary["axes"] if a not in ("method", "dataset")]
    table = Table(
        title="Best cell per method and dataset",
        title_justify="left",
        box=box.SIMPLE_HEAD,
        pad_edge=False,
    )
    best = best_cells(summary)
    for name in ("Method", "Dataset", "F1", "AUC", "Swept values", "Cells ok"):
        if name == "Method":  # whole, never cut: two methods may share their first letters
            width = max([len(name)] + [len(g["method"]) for g in best])
            table.add_column(name, no_wrap=True, min_width=width)
        elif name in ("Dataset", "Swept values"):  # folded where the terminal is narrow
            table.add_column(
                name, overflow="fold", justify="left" if name == "Dataset" else "right"
            )
        else:
            table.add_column(name, justify="right", no_wrap=True)
    for g in best:
        r = g["row"] or {}
        values = ", ".join(f"{a}={r[a]}" for a in swept if r.get(a) is not None)
        table.add_row(
            g["method"],
            labels.get(g["dataset"], g["dataset"]),
            "-" if r.get("f1_max") is None else f"{r['f1_max']:.3f}",
            "-" if r.get("auc") is None else f"{r['auc']:.3f}",
            values or "-",
            f"{g['ok']}/{g['cells']}",
        )
    _console().print(table)


# -- map and localise ------------------------------------------------------------------------


def _count_nodes(topomap: Any) -> str:
    """``300 lbp nodes``, ``1 patch node``: a map's size as the commands print it."""
    return f"{len(topomap)} {topomap.kind} node{'' if len(topomap) == 1 else 's'}"


def run_map(
    dataset: str, method: str, out: Path, params: dict[str, Any], *, quiet: bool = False
) -> Path:
    """Build the map of ``method`` from the reference traversal of ``dataset``; save it.

    ``dataset`` is a spec; a kind of two traversals (``folder:``, ``video:``) may name its
    reference alone (``folder:REF_DIR``). Where the reference frames are files, the map's
    provenance records each node's frame name (``reference_names``, see
    :data:`MAX_NAMES_BYTES`), which ``ppaloc localise`` writes beside the reference index.
    """
    from ppaloc.datasets.registry import load_reference
    from ppaloc.evaluate.run import ProgressBar, ReportedFrames, resolve_methods, sensor_stream
    from ppaloc.methods import make_localiser
    from ppaloc.topomap.io import refuse_missing_folder

    (method,) = resolve_methods([method])
    if out.is_dir():
        raise DataError(f"--out {out} is a folder; give a file name such as map.npz")
    refuse_missing_folder(out)  # before the map is built, not after
    loc = make_localiser(method, **params)  # parameters checked before the dataset loads
    refuse_input_as_out(out, _dataset_paths(dataset, reference=True), what="the dataset's")
    check_suffix(out, "a map (.npz)", "a name ending in .npz")
    ds = load_reference(dataset)
    reference = sensor_stream(ds.reference)  # read, converted and described one at a time
    with ProgressBar(not quiet) as bar:
        bar.add("reference", len(reference), label="reference frames")
        topomap = loc.build_map(ReportedFrames(reference, lambda done: bar("reference", done)))
    if topomap.positions is None and ds.reference_positions is not None:
        idx = np.asarray(topomap.frame_index)
        topomap.positions = np.asarray(ds.reference_positions)[idx]
    topomap.provenance["method"] = method
    topomap.provenance["method_params"] = params
    names = node_names(ds.reference, topomap.frame_index)
    if names is not None:
        topomap.provenance["reference_names"] = names
    path = topomap.save(out, dataset=dataset)
    if not quiet:
        print(f"map: {path} ({_count_nodes(topomap)} from {ds.name}, {method})")
    return path


MAX_NAMES_BYTES = 512 << 10
"""Most bytes of node frame names a map records (512 KiB of its 1 MiB header: about
25,000 names such as ``images-00010.png``); a longer map records none."""


def node_names(reference: Any, frame_index: np.ndarray) -> list[str] | None:
    """The name of each node's reference frame (``FrameSequence.names``), or None where
    the frames have no names or the names exceed :data:`MAX_NAMES_BYTES`."""
    names = reference.names() if hasattr(reference, "names") else None
    if names is None:
        return None
    chosen = [names[int(i)] for i in np.asarray(frame_index)]
    size = sum(len(n.encode("utf-8", "surrogateescape")) + 4 for n in chosen)
    if size > MAX_NAMES_BYTES:
        return None
    return chosen


# -- show ------------------------------------------------------------------------------------


def run_show(path: Path, out: Path | None, *, quiet: bool = False) -> Path | None:
    """Show a results folder (table + report), a saved map, saved register planes, or a
    localise CSV (any predictions file: a table and a plot of predicted reference against
    query).

    Returns
    -------
    Path or None
        The file written (report or PNG).
    """
    from ppaloc.fileio import recover_folder

    what = "give a results folder, a map (.npz), register planes (.npz) or a localise CSV"
    recover_folder(path)  # a results folder whose replacement was killed half-way
    if path.is_dir():
        marks = ("results.json", "matrix.csv", "summary.json")  # what _show_results reads
        if out is not None and any((path / name).is_file() for name in marks):
            if not any((path / name).is_file() for name in marks[:2]):
                from ppaloc.evaluate.sweep_report import load_summary

                load_summary(path)  # a cpp run's summary.json is named, not --out
            raise DataError(
                f"--out {out}: a results folder's report is rebuilt inside it "
                f"({path / 'report.html'}); --out names the PNG of a map, register planes "
                "or a CSV: leave it out"
            )
        return _show_results(path, quiet=quiet)
    if not path.is_file():
        refuse_link_loop(path, "the path")
        state = "is not a regular file" if path.exists() else "does not exist"
        raise DataError(f"{path} {state}; {what}")
    folder = _results_folder_of(path)
    if folder is not None:
        raise DataError(
            f"{path} is a file of the results folder {folder}: ppaloc show {folder} shows "
            "it (the table, and the report rebuilt from its files)"
        )
    if path.suffix.lower() == ".csv":
        from ppaloc.cli.showcsv import show_predictions

        return show_predictions(path, out, quiet=quiet)
    try:
        with zipfile.ZipFile(path) as archive:
            is_map = "header.npy" in archive.namelist()  # a map's JSON header entry
    except (zipfile.BadZipFile, OSError):
        raise DataError(
            f"{path} is not a readable .npz archive (not a zip file, or truncated); give a "
            "results folder, a map (.npz) or register planes (.npz)"
        ) from None
    if is_map:  # a damaged map is refused by load_map with its cause, not drawn as planes
        return _show_map(path, out, quiet=quiet)
    return _show_planes(path, out, quiet=quiet)


_FOLDER_FILES = {
    "results.json": ("results.json",),
    "results.csv": ("results.json",),
    "report.html": ("results.json", "summary.json"),
    "report.md": ("results.json", "summary.json"),
    "matrix.csv": ("matrix.csv",),
    "summary.json": ("summary.json",),
    "summary.csv": ("summary.json",),
}
"""A results or sweep folder's own files, by name, and the files that mark the folder."""


def _results_folder_of(path: Path) -> Path | None:
    """The results (or sweep) folder ``path`` is one of the files of, where ``ppaloc
    show`` reads the folder, not the file: its ``results.json``, report, table, or a
    method's ``arrays/*.npz`` (register planes, ``*.registers.npz``, and the difference
    matrix, ``_difference.npz``, one 2-D array, are drawn alone)."""
    parent = path.parent
    marks = _FOLDER_FILES.get(path.name, ())
    if any((parent / mark).is_file() for mark in marks):
        if path.name != "summary.json" or (parent / "cells").is_dir():  # not a cpp run's
            return parent
    in_arrays = parent.name == "arrays" and (parent.parent / "results.json").is_file()
    drawn = path.name.endswith(".registers.npz") or path.name == "_difference.npz"
    if in_arrays and path.suffix == ".npz" and not drawn:
        return parent.parent
    return None


def _show_results(folder: Path, *, quiet: bool) -> Path:
    import json

    from ppaloc.evaluate.report import write_report

    if not (folder / "results.json").is_file() and (folder / "matrix.csv").is_file():
        for sub in sorted(p.parent for p in folder.glob("*/results.json")):
            _show_results(sub, quiet=quiet)
        if not quiet:
            print(f"matrix: {folder / 'matrix.csv'}")
        return folder / "matrix.csv"
    if not (folder / "results.json").is_file() and (folder / "summary.json").is_file():
        from ppaloc.evaluate.sweep_report import load_summary, write_sweep_report

        summary = load_summary(folder)  # a sweep's; a damaged or foreign one named as such
        report = write_sweep_report(folder)  # from summary.json, as `ppaloc sweep` writes it
        if not quiet:
            _print_best_cells(summary)
            print(f"report:  {report}")
        return report
    if not (folder / "results.json").is_file():
        raise DataError(
            f"{folder} holds no results.json; give a folder written by `ppaloc evaluate --out`"
        )
    report = write_report(folder)
    if not quiet:
        summary = json.loads((folder / "results.json").read_text(encoding="utf-8"))
        name, spec = summary.get("dataset_name"), summary.get("dataset", "")
        print_results_table(summary, title=f"{name} ({spec})" if name else f"{spec}")  # as run
        print(f"report: {report}")
    return report


def _show_map(path: Path, out: Path | None, *, quiet: bool) -> Path:
    from ppaloc.topomap import load_map

    topomap = load_map(path)
    if not len(topomap):
        raise DataError(f"{path} is a map of 0 nodes: there is nothing to draw")
    out = out or default_png(path)
    refuse_input_as_out(out, [path])
    check_png(out)
    layout = topomap.layout
    if layout is not None:
        from ppaloc.sim.render import render_montage

        d = np.asarray(topomap.descriptors)
        if topomap.kind == "lbp":  # bit 31 - b of a code at block PE (b // 8, b % 8): digital
            bits = np.unpackbits(d.astype(">u4").view(np.uint8).reshape(len(d), 4), axis=1)
            planes = layout.to_planes(bits.reshape(len(d), *layout.block_shape).astype(bool))
        elif topomap.kind == "haar":  # one sign per PE of a 16x16 block: digital
            planes = topomap.planes().astype(bool)
        else:  # grey levels as analogue register units (0..255 -> -128..127)
            planes = layout.to_planes(d.astype(np.uint8), fill=128).astype(np.float32) - 128
        labels = {f"{topomap.kind} tile {i}": p for i, p in enumerate(planes)}
        render_montage(labels, out, scale=2)
    else:
        from ppaloc.evaluate.figures import png_bytes
        from ppaloc.fileio import write_bytes

        write_bytes(out, png_bytes(_descriptor_figure(topomap)))
    if not quiet:
        print(f"{path}: {_count_nodes(topomap)} -> {out}")
    return out


def _descriptor_figure(topomap: Any) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    d = np.asarray(topomap.descriptors).reshape(len(topomap), -1).astype(np.float64)
    fig = Figure(figsize=(8, 4), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    im = ax.imshow(d.T, aspect="auto", interpolation="nearest", cmap="gray")
    ax.set_xlabel("map node")
    ax.set_ylabel("descriptor element")
    ax.set_title(f"{topomap.kind} map, {len(topomap)} nodes")
    fig.colorbar(im, ax=ax, label="value")
    return fig


MAX_PLANE_CELLS = 50_000_000
"""Most cells ``ppaloc show`` draws from one file of register planes (a sensor's plane is
256 x 256 = 65,536): a compressed ``.npz`` of a few MB can claim a 40,000 x 40,000 plane,
which took 15 GB and a minute to draw."""


def _show_planes(path: Path, out: Path | None, *, quiet: bool) -> Path:
    from ppaloc.npzfile import NpzError, read_npz
    from ppaloc.sim.render import render_montage

    try:  # every member's size bounded before it is read (8 bytes a cell at most)
        arrays = read_npz(path, max_bytes=8 * MAX_PLANE_CELLS)
    except NpzError as exc:
        raise DataError(f"{path}: {exc}") from None
    except OSError as exc:
        raise DataError(f"cannot read {path} ({exc.strerror or exc})") from None
    planes = {k: a for k, a in arrays.items() if a.ndim == 2}
    labels = arrays.get("labels")
    if (  # a results folder's arrays/METHOD.registers.npz: each plane under its label
        labels is not None
        and labels.ndim == 1
        and labels.dtype.kind == "U"
        and len(set(labels.tolist())) == len(labels) == len(planes)
        and all(f"plane{i}" in planes for i in range(len(labels)))
    ):
        planes = {str(label): planes[f"plane{i}"] for i, label in enumerate(labels)}
    if not planes:
        raise DataError(f"{path} holds no 2-D arrays to draw as register planes")
    cells = sum(a.size for a in planes.values())
    if cells > MAX_PLANE_CELLS:
        raise DataError(
            f"{path}: its 2-D arrays hold {cells} cells, more than the {MAX_PLANE_CELLS} "
            "ppaloc show draws (a sensor's plane is 256 x 256); save fewer or smaller planes"
        )
    for name, a in planes.items():
        if a.dtype.kind not in "biuf":  # register planes are real numbers or bits
            raise DataError(
                f"{path}: array {name!r} holds {a.dtype} values, not numbers or bits to draw"
            )
        if a.size == 0:  # it was drawn as a plane of no pixels, said to be drawn
            raise DataError(
                f"{path}: array {name!r} has shape {a.shape}, no cells to draw; give planes "
                "of at least one row and one column"
            )
        bad = int(np.count_nonzero(~np.isfinite(a))) if a.dtype.kind == "f" else 0
        if bad:  # a register holds a number; NaN has no grey level
            raise DataError(
                f"{path}: array {name!r} holds {bad} NaN or infinite values, which no "
                "register holds; replace them (e.g. np.nan_to_num) before drawing"
            )
    (first, a), *rest = planes.items()
    other = next(((n, b) for n, b in rest if b.shape != a.shape), None)
    if other is not None:  # the montage draws planes of one size (it named itself, not the file)
        raise DataError(
            f"{path}: arrays {first!r} ({a.shape[0]} x {a.shape[1]}) and {other[0]!r} "
            f"({other[1].shape[0]} x {other[1].shape[1]}) differ in shape; register planes "
            "are drawn side by side at one size: save the planes of each size in a file of "
            "their own"
        )
    out = out or default_png(path)
    refuse_input_as_out(out, [path])
    check_png(out)
    render_montage(planes, out, scale=1)
    if not quiet:
        print(f"{path}: {len(planes)} planes -> {out}")
    return out


# -- methods ---------------------------------------------------------------------------------


def run_methods(names: list[str]) -> None:
    """Print every available method with its summary, or each of ``names`` with its
    parameters (:func:`ppaloc.methods.parameter_table`): what ``--param`` takes, found
    without reading the source or the documentation."""
    from rich import box
    from rich.markup import escape
    from rich.table import Table

    from ppaloc.methods import available_methods, parameter_table, registry

    available = available_methods()
    if not names:
        width = max(map(len, available), default=0)
        for name in available:
            print(f"{name:<{width}}  {registry()[name].summary}")
        print("\nppaloc methods NAME lists a method's parameters.")
        return
    for name in names:
        if name not in available:
            raise PpalocError(f"method {name!r} is unknown; choose from: {', '.join(available)}")
    required = False
    for k, name in enumerate(names):
        rows, left_out = parameter_table(name)
        required = required or any(row[1] == "required" for row in rows)
        print(("\n" if k else "") + f"{name}: {registry()[name].summary}")
        if not rows and not left_out:
            print("  takes any keyword (its class declares no parameters)")
            continue
        table = Table(box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 1, 0, 0))
        for column in ("parameter", "default", "accepted", "what"):
            table.add_column(column, overflow="fold")
        for row in rows:  # as written: a default [1, 1] or a doc's [lo, hi] is no markup
            table.add_row(*map(escape, row))
        _console().print(table)
        if left_out:
            print(f"not read by its preset (other methods' parameters): {', '.join(left_out)}")
    print(
        ("\nrequired = the method needs a value given with --param." if required else "")
        + "\n- = none given: the method chooses. Set one with --param METHOD.KEY=VALUE; what "
        "each sets: docs/localise.md (the weighted-node filter), docs/onsensor.md (the "
        "simulated sensor), docs/baselines.md (the baselines)."
    )


# -- warm-up ---------------------------------------------------------------------------------


def run_warm_up(*, quiet: bool = False) -> int:
    """Compile the fused code of every on-sensor pipeline (:func:`ppaloc.onsensor.warm.warm_up`)
    with a progress bar; print how many stretches were compiled. Returns that number."""
    from ppaloc.evaluate.run import ProgressBar
    from ppaloc.sim.engines import available_engines

    if "compiled" not in available_engines():
        raise PpalocError(
            "ppaloc warm-up compiles the simulator's numba code, and numba is not installed "
            "here: install ppaloc with its fast extra (pip install 'ppaloc[fast]'), or run "
            "without it (the numpy engine compiles nothing)"
        )
    from ppaloc.onsensor.warm import CONFIGS, warm_up

    with ProgressBar(not quiet) as bar:
        bar.add("run", len(CONFIGS), label="pipelines run")
        bar.add("compile", 1, label="stretches compiled")

        def progress(task: str, done: int, total: int) -> None:
            if task == "compile":
                bar.set_total("compile", total)
            bar(task, done)

        n = warm_up(progress)
    if not quiet:
        print(f"compiled {n} fused stretches; later runs find them in the cache folder")
    return n
