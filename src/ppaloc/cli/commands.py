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
from contextlib import nullcontext
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.errors import DataError, PpalocError
from ppaloc.fileio import atomic_write

__all__ = [
    "run_bench",
    "run_demo",
    "run_evaluate",
    "run_localise",
    "run_map",
    "run_matrix",
    "run_show",
    "run_sweep",
]


def _console():
    from rich.console import Console

    return Console(highlight=False, soft_wrap=False, width=None if sys.stdout.isatty() else 160)


def print_results_table(summary: dict[str, Any], *, title: str = "") -> None:
    """Print the comparison table of a ``results.json`` summary on stdout."""
    from rich import box
    from rich.table import Table

    from ppaloc.evaluate.report import comparison_table

    header, rows = comparison_table(summary, short=True)
    keep = [i for i, h in enumerate(header) if h not in ("Repr.", "p95 ms")]  # fit 80 columns
    table = Table(
        title=title or None,
        title_justify="left",
        box=box.SIMPLE_HEAD,
        pad_edge=False,
        padding=(0, 1, 0, 0),
    )
    for i in keep:
        width = max([len(header[i])] + [len(r[i]) for r in rows])
        if i == 0:  # the method name folds on a narrow terminal, numbers never do
            table.add_column(header[i], overflow="fold")
        else:
            table.add_column(header[i], justify="right", min_width=width)
    for r in rows:
        table.add_row(*(r[i] for i in keep))
    _console().print(table)
    recall = {m.get("recall_definition", "A") for m in summary["methods"].values()}
    print(
        f"F1 = max F1 (recall definition {', '.join(sorted(recall))}); "
        "R@100P = recall at 100% precision;\n"
        "P@100R = precision with every query accepted (100% recall under recall B and C);\n"
        "host ms = median wall-clock time of step on this machine;\n"
        "chip ms, loop ms = modelled time per frame on the sensor and for the whole hardware "
        "loop (docs/onsensor.md, Timing);\nmJ = modelled energy per frame."
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
    from ppaloc.evaluate.bench import save_bench
    from ppaloc.evaluate.report import write_report_files
    from ppaloc.evaluate.results import check_replaceable, results_folder, write_results
    from ppaloc.evaluate.run import run_evaluation

    _check_out_dir(out)
    check_replaceable(out)
    result = run_evaluation(config, progress=not quiet)
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

        summary = json.loads(path.read_text())
        print_results_table(summary, title=f"{result.dataset_name} ({result.dataset})")
        print(f"results: {shown_as or out}/results.json")
        if report:
            print(f"report:  {shown_as or out}/report.html")
    return path


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
    import re

    from ppaloc.evaluate.results import CSV_COLUMNS, check_replaceable, results_folder
    from ppaloc.fileio import write_bytes

    _check_out_dir(out)
    check_replaceable(out)
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(["dataset", "folder", *CSV_COLUMNS])
    with results_folder(out) as stage:  # the whole matrix replaces `out` at the end
        for i, config in enumerate(configs):
            slug = re.sub(r"[^A-Za-z0-9]+", "-", config.dataset).strip("-")[:60]
            name = f"{i + 1:02d}-{slug}"
            path = run_evaluate(
                config, stage / name, quiet=quiet, report=report, shown_as=out / name
            )
            spec = json.loads(path.read_text())["dataset"]
            with open(path.with_suffix(".csv")) as f:
                for row in list(csv.reader(f))[1:]:
                    writer.writerow([spec, name, *row])
        write_bytes(stage / "matrix.csv", text.getvalue())
    matrix = out / "matrix.csv"
    if not quiet:
        print(f"matrix: {matrix}")
    return matrix


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
    from ppaloc.evaluate.sweep_report import best_cells, dataset_labels, write_sweep_report

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
        from rich import box
        from rich.table import Table

        labels = dataset_labels(summary["axes"]["dataset"])
        swept = [a for a in summary["axes"] if a not in ("method", "dataset")]
        table = Table(
            title="Best cell per method and dataset",
            title_justify="left",
            box=box.SIMPLE_HEAD,
            pad_edge=False,
        )
        for name in ("Method", "Dataset", "F1", "AUC", "Swept values", "Cells ok"):
            table.add_column(name, justify="left" if name in ("Method", "Dataset") else "right")
        for g in best_cells(summary):
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


# -- map and localise ------------------------------------------------------------------------

_KIND_METHOD = {"lowres": "weighted-node-lowres", "lbp": "weighted-node-lbp"}


def run_map(
    dataset: str, method: str, out: Path, params: dict[str, Any], *, quiet: bool = False
) -> Path:
    """Build the map of ``method`` from the reference traversal of ``dataset``; save it."""
    from ppaloc.datasets.registry import load_dataset
    from ppaloc.evaluate.run import ProgressBar, ReportedFrames, resolve_methods, sensor_stream
    from ppaloc.methods import make_localiser

    (method,) = resolve_methods([method])
    if out.is_dir():
        raise DataError(f"--out {out} is a folder; give a file name such as map.npz")
    loc = make_localiser(method, **params)  # parameters checked before the dataset loads
    ds = load_dataset(dataset)
    reference = sensor_stream(ds.reference)  # read, converted and described one at a time
    with ProgressBar(not quiet) as bar:
        bar.add("reference", len(reference), label="reference frames")
        topomap = loc.build_map(ReportedFrames(reference, lambda done: bar("reference", done)))
    if topomap.positions is None and ds.reference_positions is not None:
        idx = np.asarray(topomap.frame_index)
        topomap.positions = np.asarray(ds.reference_positions)[idx]
    topomap.provenance["method"] = method
    topomap.provenance["method_params"] = params
    path = topomap.save(out, dataset=dataset)
    if not quiet:
        print(f"map: {path} ({len(topomap)} {topomap.kind} nodes from {ds.name}, {method})")
    return path


def _frame_paths(inputs: Sequence[Path]) -> list[Path]:
    from ppaloc.datasets.images import list_images

    paths: list[Path] = []
    for p in inputs:
        if p.is_dir():
            paths += list_images(p, "frame folder")
        elif p.is_file():
            paths.append(p)
        else:
            raise DataError(f"frame {p} does not exist; give image files or a folder of images")
    if not paths:
        raise DataError("no frames given; give image files or a folder of images")
    return paths


def _method_for_map(topomap: Any, method: str | None) -> str:
    if method:
        return method
    named = topomap.provenance.get("method")
    if named:
        return str(named)
    guess = _KIND_METHOD.get(topomap.kind, topomap.kind)
    return guess


def _check_map_kind(topomap: Any, loc: Any, name: str, map_path: Path) -> None:
    """Refuse a map of another kind than ``loc`` needs, naming the methods that read it and
    how to build the right one."""
    from ppaloc.methods import METHODS

    needs = getattr(loc, "representation", None) or getattr(loc, "kind", None)
    if needs is None or topomap.kind == needs:
        return
    readers = [m for m, s in METHODS.items() if s.defaults.get("representation") == topomap.kind]
    built_by = topomap.provenance.get("method")
    if built_by and built_by not in readers:
        readers.insert(0, str(built_by))
    use = f"localise it with --method {readers[0]}" if readers else "use a matching map"
    raise PpalocError(
        f"map {map_path} holds {topomap.kind!r} nodes but method {name!r} needs "
        f"{needs!r} nodes: {use}, or build a map for {name} with "
        f"`ppaloc map DATASET --method {name} --out MAP.npz`"
    )


def _refuse_input_as_out(out: Path | None, inputs: Sequence[Path]) -> None:
    """Refuse an ``--out`` that is one of the command's inputs or lies in an input folder:
    writing it would replace what the user saved."""
    if out is None:
        return
    target = out.resolve()
    for given in inputs:
        source = Path(given).resolve()
        if target == source or (source.is_dir() and source in target.parents):
            raise DataError(
                f"--out {out} would overwrite the input {given}; give another file name"
            )


def run_localise(
    map_path: Path,
    frames: Sequence[Path],
    out: Path | None,
    *,
    method: str | None = None,
    params: dict[str, Any] | None = None,
) -> int:
    """Localise image frames against a saved map, one CSV line per frame as it is processed.

    With ``out`` the lines go to a temporary file that replaces ``out`` at the end
    (never a half-written CSV under the final name); without, to stdout.

    Returns
    -------
    int
        Frames localised.
    """
    from ppaloc.datasets import to_sensor
    from ppaloc.datasets.images import read_grey
    from ppaloc.evaluate.run import ProgressBar, resolve_methods
    from ppaloc.methods import make_localiser
    from ppaloc.topomap import load_map

    topomap = load_map(map_path)
    name = _method_for_map(topomap, method)
    (name,) = resolve_methods([name])
    stored = topomap.provenance.get("method_params") or {} if not method else {}
    if not isinstance(stored, dict):
        raise DataError(f"map {map_path}: provenance.method_params is not a table of parameters")
    try:
        make_localiser(name, **stored)  # the map's own parameters, checked as the user's are
    except PpalocError as exc:
        raise DataError(f"map {map_path}: provenance.method_params refused: {exc}") from None
    loc = make_localiser(name, **{**stored, **(params or {})})
    use = getattr(loc, "use_map", None)
    if use is None:
        raise PpalocError(f"method {name!r} cannot load a saved map (it has no use_map)")
    _check_map_kind(topomap, loc, name, map_path)
    use(topomap)
    loc.reset()
    paths = _frame_paths(frames)
    _refuse_input_as_out(out, [map_path, *frames, *paths])  # paths: symlinked frames too
    frame_index = np.asarray(topomap.frame_index)
    header = "frame,path,node,reference_frame,score,moved,latency_ms\n"
    if out is not None:
        if out.is_dir():
            raise DataError(f"--out {out} is a folder; give a file name such as estimates.csv")
        out.parent.mkdir(parents=True, exist_ok=True)
    # The bar only when the CSV goes to a file: on stdout it would interleave with the lines.
    with (
        atomic_write(out, "w") if out is not None else nullcontext(sys.stdout) as stream,
        ProgressBar(out is not None) as bar,
    ):
        bar.add("frames", len(paths), label="frames")
        stream.write(header)
        for i, p in enumerate(paths):
            frame = to_sensor(read_grey(p))
            t = time.perf_counter_ns()
            est = loc.step(frame)
            ms = (time.perf_counter_ns() - t) / 1e6
            moved = "" if est.moved is None else int(est.moved)
            stream.write(
                f"{i},{_csv_text(str(p))},{est.node},{int(frame_index[est.node])},"
                f"{est.score:.6g},{moved},{ms:.4f}\n"
            )
            stream.flush()
            bar("frames", i + 1)
    return len(paths)


def _csv_text(s: str) -> str:
    return '"' + s.replace('"', '""') + '"' if any(c in s for c in ',"\n') else s


# -- show ------------------------------------------------------------------------------------


def run_show(path: Path, out: Path | None, *, quiet: bool = False) -> Path | None:
    """Show a results folder (table + report), a saved map or saved register planes.

    Returns
    -------
    Path or None
        The file written (report or PNG).
    """
    from ppaloc.fileio import recover_folder

    recover_folder(path)  # a results folder whose replacement was killed half-way
    if path.is_dir():
        return _show_results(path, quiet=quiet)
    if not path.is_file():
        state = "is not a regular file" if path.exists() else "does not exist"
        raise DataError(
            f"{path} {state}; give a results folder, a map (.npz) or register planes (.npz)"
        )
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


def _show_results(folder: Path, *, quiet: bool) -> Path:
    import json

    from ppaloc.evaluate.report import write_report

    if not (folder / "results.json").is_file() and (folder / "matrix.csv").is_file():
        for sub in sorted(p.parent for p in folder.glob("*/results.json")):
            _show_results(sub, quiet=quiet)
        if not quiet:
            print(f"matrix: {folder / 'matrix.csv'}")
        return folder / "matrix.csv"
    if not (folder / "results.json").is_file():
        raise DataError(
            f"{folder} holds no results.json; give a folder written by `ppaloc evaluate --out`"
        )
    report = write_report(folder)
    if not quiet:
        summary = json.loads((folder / "results.json").read_text())
        print_results_table(summary, title=f"{summary.get('dataset', '')}")
        print(f"report: {report}")
    return report


def _show_map(path: Path, out: Path | None, *, quiet: bool) -> Path:
    from ppaloc.topomap import load_map

    topomap = load_map(path)
    if not len(topomap):
        raise DataError(f"{path} is a map of 0 nodes: there is nothing to draw")
    out = out or path.with_suffix(".png")
    _refuse_input_as_out(out, [path])
    layout = topomap.layout
    if layout is not None:
        from ppaloc.sim.render import render_montage

        d = np.asarray(topomap.descriptors)
        if topomap.kind == "lbp":  # bit 31 - b of a code at block PE (b // 8, b % 8): digital
            bits = np.unpackbits(d.astype(">u4").view(np.uint8).reshape(len(d), 4), axis=1)
            planes = layout.to_planes(bits.reshape(len(d), *layout.block_shape).astype(bool))
        else:  # grey levels as analogue register units (0..255 -> -128..127)
            planes = layout.to_planes(d.astype(np.uint8), fill=128).astype(np.float32) - 128
        labels = {f"{topomap.kind} tile {i}": p for i, p in enumerate(planes)}
        render_montage(labels, out, scale=2)
    else:
        from ppaloc.evaluate.figures import png_bytes
        from ppaloc.fileio import write_bytes

        write_bytes(out, png_bytes(_descriptor_figure(topomap)))
    if not quiet:
        print(f"{path}: {len(topomap)} {topomap.kind} nodes -> {out}")
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


def _show_planes(path: Path, out: Path | None, *, quiet: bool) -> Path:
    from ppaloc.evaluate.results import MAX_RESULT_BYTES
    from ppaloc.npzfile import NpzError, read_npz
    from ppaloc.sim.render import render_montage

    try:  # every member's size bounded before it is read
        arrays = read_npz(path, max_bytes=MAX_RESULT_BYTES)
    except NpzError as exc:
        raise DataError(f"{path}: {exc}") from None
    except OSError as exc:
        raise DataError(f"cannot read {path} ({exc.strerror or exc})") from None
    planes = {k: a for k, a in arrays.items() if a.ndim == 2}
    if not planes:
        raise DataError(f"{path} holds no 2-D arrays to draw as register planes")
    for name, a in planes.items():
        if a.dtype.kind not in "biuf":  # register planes are real numbers or bits
            raise DataError(
                f"{path}: array {name!r} holds {a.dtype} values, not numbers or bits to draw"
            )
    out = out or path.with_suffix(".png")
    _refuse_input_as_out(out, [path])
    render_montage(planes, out, scale=1)
    if not quiet:
        print(f"{path}: {len(planes)} planes -> {out}")
    return out
