"""The report's figures, drawn with matplotlib's Agg canvas from a :class:`RunResult`.

Each function returns a ``matplotlib.figure.Figure`` (no pyplot, no global state); the
report turns them into PNG bytes with :func:`png_bytes`.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from ppaloc.evaluate.run import RunResult
from ppaloc.methods import METHODS

__all__ = [
    "MAX_DRAWN",
    "difference_matrix",
    "drawn_methods",
    "drawn_note",
    "latency_per_frame",
    "latency_vs_map_size",
    "method_family",
    "png_bytes",
    "position_along_route",
    "pr_curves",
    "true_nodes",
    "turning_spans",
    "weights_heatmaps",
]

_STYLE = {
    "font.size": 10,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 9,
}


MAX_DRAWN = 12
"""Most methods a figure draws (a curve, a panel or a box each): beyond it the figures
take the methods of highest max F1 and the tables alone show the others. A figure of a
panel per method grew a panel per label, and a predictions file of hundreds of labels
took minutes to lay out, for panels too small to read."""


def method_family(result: RunResult, name: str) -> str:
    """The family of a run's method: its implementation and preset (the five places of
    the robust filter are one family, the paper's preset another, each baseline its own);
    a method ppaloc does not know (predictions read from a file) is a family of one."""
    run = result.runs[name]
    spec = None if "predictions" in run.params else METHODS.get(run.method)
    if spec is None:
        return f"file:{name}"
    return f"{spec.target}:{ {**spec.defaults, **run.params}.get('preset', '') }"


def drawn_methods(result: RunResult, among: Sequence[str] | None = None) -> list[str]:
    """The methods a figure draws of ``among`` (default: every method), in the result's
    order: every one up to :data:`MAX_DRAWN`; else the best of each family
    (:func:`method_family`; by max F1, the first on a tie), so every baseline is drawn
    beside the filter's places, then the others of highest max F1."""
    names = list(result.runs) if among is None else [n for n in result.runs if n in among]
    if len(names) <= MAX_DRAWN:
        return names

    def f1(name: str) -> float:
        v = result.runs[name].metrics.f1_max
        return float(v) if np.isfinite(v) else -1.0

    ranked = sorted(names, key=lambda n: -f1(n))  # sorted is stable
    heads = list({method_family(result, n): n for n in reversed(ranked)}.values())
    heads = sorted(heads, key=lambda n: -f1(n))[:MAX_DRAWN]
    best = set(heads) | set([n for n in ranked if n not in heads][: MAX_DRAWN - len(heads)])
    return [n for n in names if n in best]


def drawn_note(result: RunResult, among: Sequence[str] | None = None) -> str:
    """A caption's sentence saying which methods a figure of ``among`` (default: every
    method) leaves out ('' if none)."""
    names = list(result.runs) if among is None else list(among)
    n = len(names)
    if n <= MAX_DRAWN:
        return ""
    if len({method_family(result, m) for m in names}) == n:  # every method its own family
        return (
            f" Drawn: the {MAX_DRAWN} methods of highest max F1 of the {n}; the tables show "
            "every method."
        )
    return (
        f" Drawn: {MAX_DRAWN} of the {n} methods, the best of each family (each baseline, "
        "the filter's robust and paper presets, on the host and on the sensor) and then "
        "those of highest max F1; the tables show every method."
    )


def _figure(width: float, height: float) -> Figure:
    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _family(name: str) -> str:
    """A method's name without its preset: a preset shares its default's colour."""
    return name.replace("-paper-", "-")


def _colours(names: Sequence[str]) -> dict[str, Any]:
    """One colour per method family: tab10 without its grey (grey draws truths and
    backgrounds), then tab20's lighter shades."""
    import matplotlib as mpl

    families = list(dict.fromkeys(_family(n) for n in names))
    tab10, tab20 = mpl.colormaps["tab10"], mpl.colormaps["tab20"]
    palette = [tab10(i) for i in range(10) if i != 7]
    palette += [tab20(2 * i + 1) for i in range(10) if i != 7]

    def colour(i: int) -> Any:
        return palette[i % len(palette)]

    return {n: colour(families.index(_family(n))) for n in names}


def _linestyle(name: str) -> str:
    """Dashed for a non-default preset (the paper's Algorithm 1), solid otherwise."""
    return "--" if name != _family(name) else "-"


def _plain_log_ticks(axis: Any) -> None:
    """Label a log axis 0.2, 1, 10 rather than 2x10^-1, 10^0, 10^1."""
    from matplotlib.ticker import FuncFormatter, LogLocator

    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_locator(LogLocator(base=10, subs=(2.0, 5.0)))
    axis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}"))


def png_bytes(fig: Figure) -> bytes:
    """The figure as PNG bytes."""
    import matplotlib as mpl

    from ppaloc.fileio import PNG_SOFTWARE

    buf = io.BytesIO()
    with mpl.rc_context(_STYLE):
        fig.savefig(buf, format="png", metadata={"Software": PNG_SOFTWARE})
    return buf.getvalue()


def pr_curves(result: RunResult) -> Figure:
    """Precision against recall of every method in one plot, max-F1 points marked."""
    fig = _figure(10.0, 5.2)
    ax = fig.add_subplot()
    names = drawn_methods(result)
    colours = _colours(names)
    definition = "A"
    for name in names:
        run = result.runs[name]
        c = run.metrics.curve
        definition = c.recall_definition
        if not len(c.recall):
            continue
        r = np.concatenate([[0.0], c.recall])
        p = np.concatenate([[c.precision[0]], c.precision])
        ax.plot(
            r,
            p,
            color=colours[name],
            ls=_linestyle(name),
            lw=1.8,
            label=f"{name}{' (offline)' if run.reads_future else ''} (F1 {run.metrics.f1_max:.2f})",
        )
        ax.plot(
            run.metrics.recall_at_f1,
            run.metrics.precision_at_f1,
            "o",
            color=colours[name],
            ms=6,
            mec="black",
        )
    ax.set_xlim(0, 1.01)
    ax.set_ylim(0, 1.02)
    ax.set_xlabel(f"recall (definition {definition})")
    ax.set_ylabel("precision")
    ax.set_title(f"Precision-recall, {result.dataset_name} (dots: max F1)")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return fig


def _true_reference(ground_truth: Sequence[np.ndarray]) -> np.ndarray:
    """The middle accepted reference index per query (NaN where there is no true match)."""
    return np.array(
        [float(np.median(g)) if len(g) else np.nan for g in ground_truth], dtype=np.float64
    )


def _f2(v: float | None) -> str:
    return "-" if v is None else f"{v:.2f}"


def turning_spans(turning: np.ndarray | None) -> list[tuple[int, int]]:
    """Runs of consecutive turning frames as ``(first, last)`` index pairs.

    >>> turning_spans(np.array([0, 1, 1, 0, 0, 1], bool))
    [(1, 2), (5, 5)]
    >>> turning_spans(None)
    []
    """
    if turning is None:
        return []
    t = np.concatenate([[False], np.asarray(turning, dtype=bool).ravel(), [False]])
    edges = np.flatnonzero(t[1:] != t[:-1])
    return [(int(a), int(b) - 1) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def position_along_route(result: RunResult) -> Figure:
    """True and predicted reference frame per query, one panel per method (paper Fig. 10).

    Query frames taken in a turn (``result.query_turning``, where known) are shaded grey,
    and each panel's title adds the max F1 on straight and on turning queries.
    """
    names = drawn_methods(result)
    cols = 2 if len(names) > 1 else 1
    rows = -(-len(names) // cols)
    fig = _figure(11.0 if cols == 2 else 7.0, 2.7 * rows + 0.4)
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True, sharey=True)
    truth = _true_reference(result.ground_truth)
    q = np.arange(len(truth))
    spans = turning_spans(result.query_turning)
    for ax, name in zip(axes.ravel(), names, strict=False):
        run = result.runs[name]
        ok = run.metrics.correct
        for i, (a, b) in enumerate(spans):
            ax.axvspan(
                a - 0.5, b + 0.5, color="0.88", lw=0, zorder=0, label="turning" if i == 0 else None
            )
        ax.plot(q, truth, color="0.55", lw=2.5, label="true", zorder=1)
        ax.scatter(q[ok], run.ref_index[ok], s=5, color="tab:green", label="correct", zorder=2)
        ax.scatter(q[~ok], run.ref_index[~ok], s=5, color="tab:red", label="wrong", zorder=3)
        title = f"{name}: P@100%R {run.metrics.precision_at_100r:.2f}"
        m = run.metrics
        if m.f1_max_turning is not None:  # some queries turn
            title += f", F1 straight {_f2(m.f1_max_straight)} | turning {_f2(m.f1_max_turning)}"
        ax.set_title(title)
        ax.grid(alpha=0.3)
    for ax in axes.ravel()[len(names) :]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("reference frame")
    for ax in axes[-1, :]:
        ax.set_xlabel("query frame")
    # below the panels: inside one, it hid the estimates of the first frames, which are
    # the top left's where a filter starts far from the truth
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(
        handles, labels, loc="outside lower center", ncols=len(labels), markerscale=3,
        frameon=False,
    )  # fmt: skip
    fig.suptitle(f"Position estimate along the route, {result.dataset_name}")
    return fig


def true_nodes(truth: np.ndarray, frame_index: np.ndarray) -> np.ndarray:
    """The map node standing for each true reference frame: the node whose own frame
    (``TopoMap.frame_index``) is the last at or before it (a keyframe map's node stands
    for the frames up to the next node's).

    Parameters
    ----------
    truth : ndarray of float, shape (M,)
        A reference frame per query (NaN: none).
    frame_index : ndarray of int, shape (N,)
        Each node's reference frame.

    Returns
    -------
    ndarray of float, shape (M,)
        Node index per query (NaN where ``truth`` is NaN).

    Examples
    --------
    >>> true_nodes(np.array([0.0, 3.0, 4.0, 9.0, np.nan]), np.array([0, 1, 4, 8])).tolist()
    [0.0, 1.0, 2.0, 3.0, nan]
    """
    truth = np.asarray(truth, dtype=np.float64)
    frames = np.asarray(frame_index, dtype=np.int64)
    out = np.full(truth.shape, np.nan)
    ok = np.isfinite(truth)
    if not len(frames) or not ok.any():
        return out
    order = np.argsort(frames, kind="stable")
    at = np.searchsorted(frames[order], np.floor(truth[ok]), side="right") - 1
    out[ok] = order[np.maximum(at, 0)]
    return out


def weights_heatmaps(result: RunResult) -> Figure | None:
    """Per-node weights over time of every method that recorded them (None if none did).

    The y axis is the map's nodes, so the true position is carried from reference frames
    to nodes through the map's ``frame_index`` (:func:`true_nodes`); a folder that does not
    record it draws the truth only where the map has one node per reference frame.
    """
    recorded = [n for n, r in result.runs.items() if r.weights is not None]
    runs = [result.runs[n] for n in drawn_methods(result, recorded)]
    if not runs:
        return None
    fig = _figure(11.0, 2.6 * len(runs) + 0.4)
    axes = fig.subplots(len(runs), 1, squeeze=False)[:, 0]
    truth = _true_reference(result.ground_truth)
    first, last = _truth_span(result.ground_truth)
    for ax, run in zip(axes, runs, strict=True):
        w = np.asarray(run.weights, dtype=np.float64)
        finite = w[np.isfinite(w)]
        lo, hi = np.percentile(finite, [1, 99.5]) if finite.size else (0.0, 1.0)
        im = ax.imshow(
            w.T,
            aspect="auto",
            origin="lower",
            interpolation="nearest",
            cmap="magma",
            vmin=lo,
            vmax=hi if hi > lo else lo + 1,
            extent=(-0.5, w.shape[0] - 0.5, -0.5, w.shape[1] - 0.5),
        )
        n_nodes = w.shape[1]
        frames = run.frame_index
        if frames is None and n_nodes == result.n_reference:
            frames = np.arange(n_nodes)
        title = f"{run.method}: node weights after each frame ({n_nodes} nodes"
        if result.n_reference and n_nodes != result.n_reference:
            title += f" for {result.n_reference} reference frames"
        title += ")"
        if frames is not None and len(frames) == n_nodes:
            # the accepted nodes bracketed, half a node out: a line on the true node hid
            # the weights it was drawn to be compared with (a one-node peak entirely)
            q = np.arange(len(truth))
            for edge, side in ((first, -0.5), (last, 0.5)):
                ax.plot(q, true_nodes(edge, frames) + side, color="cyan", lw=0.7, alpha=0.8)
            title += "; cyan: the accepted nodes lie between the lines"  # no legend inside
        else:
            title += "; true node not drawn: the folder lacks the map's frame_index"
        ax.set_title(title)
        ax.set_ylabel("map node (index)")
        fig.colorbar(im, ax=ax, label="weight (method's own units)", pad=0.01)
    axes[-1].set_xlabel("query frame (index)")
    return fig


def _truth_span(ground_truth: Sequence[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """First and last accepted reference frame per query (NaN where there is none)."""
    lo = np.array([float(np.min(g)) if len(g) else np.nan for g in ground_truth])
    hi = np.array([float(np.max(g)) if len(g) else np.nan for g in ground_truth])
    return lo, hi


_TRUTH_COLOUR = "#00d4ff"


def difference_matrix(result: RunResult) -> Figure | None:
    """The difference matrix with the ground truth and each method's predicted path over it.

    The first panel is the matrix alone (``result.difference``: query frame on x, reference
    frame on y, dark = alike), so the valley the images make is not hidden; then one panel
    per method over the same matrix: the accepted reference frames of each query as a band,
    and the method's predicted reference frame per query, a filled dot where the method's
    maximum-F1 threshold accepts it and a hollow one where that threshold rejects it.
    None when the result has no difference matrix.
    """
    d = result.difference
    if d is None or not result.runs:
        return None
    names = drawn_methods(result)
    panels = len(names) + 1
    cols = 2 if panels <= 4 else 3
    rows = -(-panels // cols)
    side = 4.6 if cols == 2 else 3.7
    fig = _figure(side * cols + 1.1, side * rows + 1.0)
    axes = fig.subplots(rows, cols, squeeze=False, sharex=True, sharey=True)
    values = np.asarray(d.values, dtype=np.float64)
    finite = values[np.isfinite(values)]
    lo, hi = np.percentile(finite, [1, 99]) if finite.size else (0.0, 1.0)
    sq, sr = d.strides
    extent = (
        d.query_index[0] - sq / 2,
        d.query_index[-1] + sq / 2,
        d.reference_index[0] - sr / 2,
        d.reference_index[-1] + sr / 2,
    )
    colours = _colours(names)
    truth_lo, truth_hi = _truth_span(result.ground_truth)
    q = np.arange(len(truth_lo))
    size = float(np.clip(3000.0 / max(len(q), 1), 1.5, 18.0))
    # crisp cells while a panel has more pixels than the matrix has samples, smoothed
    # (anti-aliased) beyond: a nearest-neighbour shrink would drop rows, maybe the valley
    fits = max(values.shape) <= side * fig.dpi * 0.8
    image = None
    for k, ax in enumerate(axes.ravel()[:panels]):
        image = ax.imshow(
            values.T,
            origin="lower",
            aspect="auto",
            cmap="gray",
            vmin=lo,
            vmax=hi if hi > lo else lo + 1,
            extent=extent,
            interpolation="nearest" if fits else "antialiased",
        )
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        if k == 0:
            ax.set_title("the frame difference alone\n(what the images say)")
            continue
        name = names[k - 1]
        run = result.runs[name]
        ax.fill_between(
            q,
            truth_lo - 0.5,
            truth_hi + 0.5,
            step="mid",
            color=_TRUTH_COLOUR,
            alpha=0.45,
            lw=0,
            label="true (accepted reference frames)",
        )
        m = run.metrics
        if np.isfinite(m.threshold_at_f1):
            kept = run.score >= m.threshold_at_f1
        else:
            kept = np.ones(len(q), dtype=bool)
        c = colours[name]
        ax.scatter(q[kept], run.ref_index[kept], s=size, color=c, lw=0)
        ax.scatter(
            q[~kept],
            run.ref_index[~kept],
            s=size * 1.6,
            facecolors="none",
            edgecolors=c,
            lw=0.7,
        )
        ax.set_title(f"{name}\nF1 {m.f1_max:.2f}, {int(kept.sum())} of {len(q)} accepted")
    for ax in axes.ravel()[panels:]:
        ax.set_visible(False)
    for ax in axes[:, 0]:
        ax.set_ylabel("reference frame")
    for j in range(cols):  # the lowest panel shown in each column carries the x axis
        lowest = axes[max(r for r in range(rows) if r * cols + j < panels), j]
        lowest.xaxis.set_tick_params(labelbottom=True)
        lowest.set_xlabel("query frame")
    handles = [
        _legend_patch(),
        _legend_marker(filled=True),
        _legend_marker(filled=False),
    ]
    labels = [
        "true (accepted reference frames)",
        "predicted, accepted at the method's max-F1 threshold",
        "predicted, rejected there",
    ]
    fig.legend(handles, labels, loc="outside lower center", ncols=3, frameon=False)
    fig.colorbar(
        image,
        ax=axes.ravel().tolist(),
        label="frame difference, mean |z| per pixel (dark = alike)",
        shrink=0.6 if rows > 2 else 0.9,
        pad=0.01,
    )
    fig.suptitle(f"Difference matrix, {result.dataset_name} ({d.sampling()})")
    return fig


def _legend_patch() -> Any:
    from matplotlib.patches import Patch

    return Patch(color=_TRUTH_COLOUR, alpha=0.45, lw=0)


def _legend_marker(*, filled: bool) -> Any:
    """A neutral legend dot (each panel's method has its own colour)."""
    from matplotlib.lines import Line2D

    return Line2D(
        [],
        [],
        ls="",
        marker="o",
        markersize=6,
        markerfacecolor="0.3" if filled else "none",
        markeredgecolor="0.3",
    )


def latency_vs_map_size(bench: dict[str, Any]) -> Figure | None:
    """Median host time per frame against map size (log-log), p95 as a band."""
    rows = [r for r in bench.get("rows", []) if "skipped" not in r] if bench else []
    if not rows:
        return None
    from matplotlib.ticker import FuncFormatter, NullFormatter

    names = list(dict.fromkeys(r["method"] for r in rows))
    colours = _colours(names)
    modelled_names = {r["method"] for r in rows if r.get("modelled_latency_ms_median") is not None}
    # the legend, a line per curve beside the axes, sets the height: at a fixed 4.8 in the
    # demo's 26 curves ran off the bottom of the figure
    fig = _figure(10.0, max(4.8, 0.2 * (len(names) + len(modelled_names)) + 1.2))
    ax = fig.add_subplot()
    for name in names:
        rs = sorted((r for r in rows if r["method"] == name), key=lambda r: r["n_nodes"])
        n = [r["n_nodes"] for r in rs]
        med = [r["latency_ms_median"] for r in rs]
        p95 = [r["latency_ms_p95"] for r in rs]
        # a preset shares its default's colour and dashes mean modelled here, so the
        # paper's Algorithm 1 is told apart by hollow markers
        hollow = {"mfc": "white"} if _linestyle(name) != "-" else {}
        ax.plot(n, med, "o-", color=colours[name], label=name, **hollow)
        ax.fill_between(n, med, p95, color=colours[name], alpha=0.1, lw=0)
        modelled = [
            (r["n_nodes"], r["modelled_latency_ms_median"])
            for r in rs
            if r.get("modelled_latency_ms_median") is not None
        ]
        if modelled:
            mx, my = zip(*modelled, strict=True)
            ax.plot(
                mx, my, "s--", color=colours[name], label=f"{name} (modelled on-sensor)", **hollow
            )
    ax.set_xscale("log", base=2)
    ax.set_yscale("log")
    ax.set_xticks(sorted({r["n_nodes"] for r in rows}))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    _plain_log_ticks(ax.yaxis)
    ax.set_xlabel("map size (nodes)")
    ax.set_ylabel("time per frame (ms, median; band to host p95)")
    ax.set_title(
        "Latency against map size (random maps; solid host, dashed modelled)\n"
        "hollow markers: the paper's Algorithm 1"
    )
    ax.grid(alpha=0.3, which="both")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return fig


def latency_per_frame(result: RunResult) -> Figure:
    """Distribution of host time per frame of every method in this run that was timed
    (box plot; predictions scored from a file without times are left out)."""
    data = {n: np.asarray(r.latency_ms) for n, r in result.runs.items()}
    data = {n: a[np.isfinite(a)] for n, a in data.items() if np.isfinite(a).any()}
    data = {n: data[n] for n in drawn_methods(result, list(data))}
    names = list(data)
    fig = _figure(10.0, 0.45 * len(names) + 1.4)
    ax = fig.add_subplot()
    data = list(data.values())
    import matplotlib as mpl

    version = tuple(int(x) for x in mpl.__version__.split(".")[:2] if x.isdigit())
    # the keyword names changed in matplotlib 3.9 (tick_labels) and 3.10 (orientation)
    kw: dict[str, Any] = {"tick_labels" if version >= (3, 9) else "labels": names}
    kw.update({"orientation": "horizontal"} if version >= (3, 10) else {"vert": False})
    ax.boxplot(data, showfliers=False, **kw)
    ax.set_xscale("log")
    _plain_log_ticks(ax.xaxis)
    ax.set_xlabel("host time per frame (ms)")
    ax.set_title(f"Host time per frame, {result.dataset_name} (whiskers 1.5 IQR)")
    ax.grid(alpha=0.3, axis="x", which="both")
    return fig
