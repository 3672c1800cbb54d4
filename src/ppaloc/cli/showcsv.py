"""``ppaloc show est.csv``: a localise CSV (or any predictions file) as a table and a plot
of the predicted reference frame against the query frame.

The file is read by :func:`ppaloc.evaluate.score.read_predictions`, the reader of
``ppaloc score``, so what ``show`` draws is what ``score`` would measure; without a
dataset, queries are placed by their index (else by row) and references need their index.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.errors import DataError

__all__ = ["predictions_figure", "show_predictions"]

_SHOWN_ROWS = 8
"""Rows printed from each end of a method's predictions."""


def _ints(values: list[str], path: Path, lines: np.ndarray, column: str) -> np.ndarray:
    out = np.empty(len(values), dtype=np.int64)
    for i, v in enumerate(values):
        if not v:
            raise DataError(
                f"{path} line {lines[i]}: {column} is empty; show draws frames by their "
                "indices (score the file against its dataset to match names: ppaloc score)"
            )
        out[i] = int(v)
    return out


def _arrays(p: Any) -> tuple[np.ndarray, np.ndarray, str]:
    """(query position, predicted reference index, query axis label) of one method."""
    refs = p.references[0]
    if "reference" not in refs:
        raise DataError(
            f"{p.source} names its references by file name only; show draws reference "
            "indices: score it against its dataset instead (ppaloc score FILE --dataset SPEC)"
        )
    reference = _ints(refs["reference"], p.source, p.lines, "reference")
    if "query" in p.queries:
        return _ints(p.queries["query"], p.source, p.lines, "query"), reference, "query frame"
    return np.arange(len(p)), reference, "row of the file"


#: The largest score magnitude the colour bar draws in score units (a million times below a
#: float64's limit: its ticks and margins are computed with headroom).
_LARGEST_DRAWN = np.finfo(np.float64).max / 2**20


def predictions_figure(predictions: list[Any], title: str) -> Any:
    """One panel per method: predicted reference frame against query, coloured by score;
    of more than :data:`~ppaloc.evaluate.figures.MAX_DRAWN` methods, the first of them in
    the file, the title saying so.

    Returns
    -------
    matplotlib.figure.Figure
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ppaloc.evaluate.figures import MAX_DRAWN

    drawn = predictions[:MAX_DRAWN]  # a panel a label: hundreds took minutes to lay out
    n = len(drawn)
    fig = Figure(figsize=(8, 3.2 * n + 0.6), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    for ax, p in zip(axes, drawn, strict=True):
        x, y, xlabel = _arrays(p)
        colour, label = np.asarray(p.score, dtype=np.float64), "score (higher = surer)"
        largest = np.abs(colour).max() if colour.size else 0.0
        if largest > _LARGEST_DRAWN:
            # finite scores whose span a float64 cannot hold (-1e308 and 1e308), or so
            # near its limit that the colour bar's ticks overflow (1e308 everywhere): the
            # colour bar cannot be drawn in score units, so the colours are their ranks
            # (equal scores, equal ranks)
            colour = np.unique(colour, return_inverse=True)[1].reshape(colour.shape)
            label = "rank of the score (higher = surer)"
        points = ax.scatter(x, y, c=colour, s=9, cmap="viridis", linewidths=0)
        fig.colorbar(points, ax=ax, label=label)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("predicted reference frame")
        ax.set_title(f"{p.label}: {len(p)} predictions")
        ax.grid(alpha=0.3)
    if len(predictions) > n:
        title += f" (the first {n} of {len(predictions)} methods)"
    fig.suptitle(title)
    return fig


def show_predictions(path: Path, out: Path | None, *, quiet: bool = False) -> Path:
    """Print a predictions file's rows (the first and last of each method) and write the
    plot of predicted reference against query to ``out`` (default: beside the file, .png).

    Returns
    -------
    Path
        The PNG written.
    """
    from ppaloc.cli.outputs import check_png, default_png, refuse_input_as_out
    from ppaloc.evaluate.figures import png_bytes
    from ppaloc.evaluate.score import read_predictions
    from ppaloc.fileio import write_bytes

    predictions = read_predictions(path)
    drawn = [(p, *_arrays(p)) for p in predictions]  # every problem before anything is written
    out = out or default_png(path)
    refuse_input_as_out(out, [path])
    check_png(out)
    write_bytes(out, png_bytes(predictions_figure(predictions, path.name)))
    if not quiet:
        for p, x, y, _ in drawn:
            _print_table(p, x, y)
        print(f"{path}: {sum(len(p) for p in predictions)} predictions -> {out}")
    return out


def _print_table(p: Any, x: np.ndarray, y: np.ndarray) -> None:
    from rich import box
    from rich.table import Table

    from ppaloc.cli.commands import _console

    names = p.queries.get("query_name")
    table = Table(title=f"{p.label} ({p.source.name})", title_justify="left", box=box.SIMPLE_HEAD)
    for column in ("query", "name", "reference", "score", "moved", "ms"):
        table.add_column(column, justify="left" if column == "name" else "right")
    n = len(p)
    rows = list(range(n)) if n <= 2 * _SHOWN_ROWS else [*range(_SHOWN_ROWS), -1]
    if n > 2 * _SHOWN_ROWS:
        rows += list(range(n - _SHOWN_ROWS, n))
    for r in rows:
        if r < 0:
            table.add_row("...", "", "", "", "", "")
            continue
        moved = {1: "1", 0: "0"}.get(int(p.moved[r]), "")
        ms = "" if not np.isfinite(p.latency_ms[r]) else f"{p.latency_ms[r]:.3g}"
        name = Path(names[r]).name if names else ""  # the file, not its folders
        table.add_row(str(x[r]), name, str(y[r]), f"{p.score[r]:.4g}", moved, ms)
    _console().print(table)
    finite = p.latency_ms[np.isfinite(p.latency_ms)]
    timing = f", median {np.median(finite):.3g} ms a frame" if finite.size else ""
    print(
        f"{n} predictions of {len(np.unique(y))} distinct reference frames (range "
        f"{y.min()}..{y.max()}), score {p.score.min():.4g} to {p.score.max():.4g}{timing}"
    )
