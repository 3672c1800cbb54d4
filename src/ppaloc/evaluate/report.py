"""The report: a self-contained HTML page and a Markdown twin, built from result files only.

:func:`write_report` reads a results folder (:mod:`ppaloc.evaluate.results`), draws the
figures (:mod:`ppaloc.evaluate.figures`) and writes ``report.html`` (figures embedded as
base64 PNG, no external resources) and ``report.md`` (figures as PNG files under
``figures/``).
"""

from __future__ import annotations

import base64
import html
import json
import logging
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.errors import PpalocError
from ppaloc.evaluate import figures
from ppaloc.evaluate.bench import load_bench
from ppaloc.evaluate.columns import COLUMNS, TERMS, column_of
from ppaloc.evaluate.difference import DIFFERENCE_SAMPLES, MEASURE
from ppaloc.evaluate.metrics import RECALL_DEFINITIONS
from ppaloc.evaluate.results import check_report_figures, load_results, upgrade_summary
from ppaloc.evaluate.run import RunResult
from ppaloc.fileio import update_folder, write_bytes

__all__ = [
    "FIGURE_KEYS",
    "REPRESENTATIONS",
    "comparison_table",
    "figure_files",
    "method_label",
    "method_notes",
    "paper_table",
    "write_report",
    "write_report_files",
]

log = logging.getLogger(__name__)

REPRESENTATIONS = {
    "lowres": "8x8 image, SAD",
    "lowres16": "16x16 image, SAD",
    "lbp": "32-bit LBP, Hamming",
    "haar": "192 Haar signs, Hamming",
    "patch": "64x32 patch-normalised image, SAD",
    "seqslam": "patch-normalised image, SAD",
    "single-frame": "patch-normalised image, SAD",
    "particle-filter": "patch-normalised image",
    "able-m": "LDB binary code, Hamming",
}
"""Map kind (or an image baseline's ``descriptor``) -> how the report names the place
representation."""

#: The weighted-node filter's places, in the order tables show them.
_PLACES = ("lowres", "lowres16", "lbp", "haar", "patch")


FIGURE_KEYS = ("pr-curves", "difference", "position", "weights", "latency", "latency-vs-size")
"""The report's figures (``figures/KEY.png``), besides one ``registers-METHOD`` per
on-sensor method."""


def figure_files(methods: list[str]) -> list[str]:
    """Every figure file the report of a folder with ``methods`` may write, relative to the
    folder (what replacing the folder may delete as ppaloc's own)."""
    keys = [*FIGURE_KEYS, *(f"registers-{m}" for m in methods)]
    return [f"figures/{key}.png" for key in keys]


@dataclass(frozen=True)
class ReportFigure:
    """One figure of an HTML report: its anchor key, title, caption and PNG bytes."""

    key: str
    title: str
    caption: str
    png: bytes


def _fmt(v: Any, digits: int = 3) -> str:
    if v is None or (isinstance(v, float) and not np.isfinite(v)):
        return "-"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return str(v)


def _ms(v: float | None) -> str:
    if v is None:
        return "-"
    return f"{v:.3g}" if v < 100 else f"{v:.0f}"


def _bounded_ms(m: dict[str, Any], boundary: str, short: bool = False) -> str:
    """``mid (low-high)`` of a method's ``modelled_time_ms[boundary]`` (``short``: the mid
    only); "-" without one."""
    t = (m.get("modelled_time_ms") or {}).get(boundary)
    if not t:
        return _ms(m.get("modelled_latency_ms")) if boundary == "chip" else "-"
    if short:
        return _ms(t["mid"])
    return f"{_ms(t['mid'])} ({_ms(t['low'])}-{_ms(t['high'])})"


_SHORT_HEADER = [
    "Method",
    "Repr.",
    "F1",
    "P@F1",
    "R@F1",
    "AUC",
    "R@100P",
    "P@100R",
    "host ms",
    "p95 ms",
    "chip ms",
    "loop ms",
    "mJ",
]
_SHORT_REPR = {
    "lowres": "8x8 img",
    "lowres16": "16x16 img",
    "lbp": "LBP",
    "haar": "Haar",
    "patch": "patch img",
}


def _place(m: dict[str, Any]) -> str:
    """The place a method compared: its map kind, or a baseline's ``descriptor`` when it
    ran on one of the weighted-node filter's places (``descriptor="lowres16"``)."""
    descriptor = (m.get("params") or {}).get("descriptor")
    # a baseline's "patch" is its own image, written out or not: its own column
    filters_place = descriptor in _PLACES and descriptor != "patch"
    return descriptor if filters_place else m.get("map_kind", "")


def method_label(name: str, entry: dict[str, Any], *, short: bool = False) -> str:
    """A method's name as tables show it: marked when it read future frames (offline).

    Examples
    --------
    >>> method_label("seqslam-centred", {"reads_future": True}, short=True)
    'seqslam-centred (offline)'
    """
    if not entry.get("reads_future"):
        return name
    return f"{name} (offline)" if short else f"{name} (offline: reads future frames)"


def method_notes(summary: dict[str, Any], *, short: bool = False) -> list[str]:
    """What a reader must know about some methods' figures: an offline method that read
    future frames, and the speed check's warnings (:mod:`ppaloc.evaluate.speed`); ``short``
    for a terminal, where the warning itself was logged during the run."""
    notes: list[str] = []
    alike: dict[str, list[str]] = {}  # short speed notes: one line for the methods alike
    for name, m in summary["methods"].items():
        if m.get("reads_future"):
            notes.append(
                f"{name} is offline (reads future frames)"
                if short
                else f"{name} is offline: its estimate for a frame reads frames after it, "
                "which an online method never sees; compare it with online methods with care."
            )
        check = m.get("speed_check") or {}
        if check.get("warning"):
            lo, hi = check["range"]
            speeds = (
                f"off the speed it assumes ({lo:.3g})"
                if lo == hi
                else f"outside the speeds it searches ({lo:.3g}-{hi:.3g})"
            )  # "(1-1)" said nothing
            if short:
                said = f"the query moves {speeds} on {check['share_outside']:.0%} of the route"
                if said not in alike:
                    alike[said] = []
                    notes.append(said)
                alike[said].append(name)
            else:
                notes.append(check["warning"])
    return [f"{', '.join(alike[n])}: {n}" if n in alike else n for n in notes]


def comparison_table(
    summary: dict[str, Any], *, short: bool = False
) -> tuple[list[str], list[list[str]]]:
    """Every scalar metric and the frame times: one row per method.

    Parameters
    ----------
    summary : dict
        The content of ``results.json``.
    short : bool
        Short headers and representation names (for a terminal).

    Returns
    -------
    header : list of str
    rows : list of list of str
    """
    summary = upgrade_summary(summary)  # an older folder's fields under today's names
    header = [
        "Method",
        "Representation",
        "F1 max",
        "P @F1",
        "R @F1",
        "AUC",
        "R @100%P",
        "P @100%R",
        "Host ms/frame (median)",
        "Host ms (p95)",
        "Modelled chip ms/frame (low-high)",
        "Modelled loop ms/frame (low-high)",
        "Energy mJ/frame",
    ]
    rows = []
    for name, m in summary["methods"].items():
        kind = _place(m)
        rep = _SHORT_REPR.get(kind, "own") if short else REPRESENTATIONS.get(kind, kind or "-")
        rows.append(
            [
                method_label(name, m, short=short),
                rep,
                _fmt(m["f1_max"]),
                _fmt(m["precision_at_f1"]),
                _fmt(m["recall_at_f1"]),
                _fmt(m["auc"]),
                _fmt(m["recall_at_100p"]),
                _fmt(m["precision_at_100r"]),
                _ms(m.get("latency_ms_median")),
                _ms(m.get("latency_ms_p95")),
                _bounded_ms(m, "chip", short),
                _bounded_ms(m, "loop", short),
                _fmt(m.get("energy_mj"), 3),
            ]
        )
    if has_turning_split(summary):  # after F1 max: the same metric on each subset
        header.insert(3, "F1 straight")
        header.insert(4, "F1 turning")
        short_header = [*_SHORT_HEADER[:3], "F1 str.", "F1 turn", *_SHORT_HEADER[3:]]
        for row, m in zip(rows, summary["methods"].values(), strict=True):
            row[3:3] = [_fmt(m.get("f1_max_straight")), _fmt(m.get("f1_max_turning"))]
    else:
        short_header = _SHORT_HEADER
    return (short_header if short else header), rows


def has_turning_split(summary: dict[str, Any]) -> bool:
    """Whether a ``results.json`` summary has max F1 on turning queries: the dataset says
    which frames turn and some do (on the straight default road F1 straight is F1 max)."""
    return any(m.get("f1_max_turning") is not None for m in summary["methods"].values())


_SUFFIXES = {f"-{place}": place for place in _PLACES}
_COLUMNS = (
    ("lowres", "8x8 image"),
    ("lowres16", "16x16 image"),
    ("lbp", "32-bit LBP"),
    ("haar", "192 Haar signs"),
    ("patch", "64x32 patch-normalised"),
    ("own", "method's own"),
)


def _family(name: str, kind: str) -> tuple[str, str]:
    """(method family, representation column) of a method: ``weighted-node-lbp`` ->
    (``weighted-node``, ``lbp``); a baseline is its own family in the ``own`` column."""
    for suffix, rep in _SUFFIXES.items():
        if name.endswith(suffix):
            return name[: -len(suffix)], rep
    return name, kind if kind in _PLACES else "own"


def paper_table(summary: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """The comparison in the layout of the paper's Table I: one row per method family,
    per representation the max F1 and the frame time (host median / modelled on-sensor).

    Parameters
    ----------
    summary : dict
        The content of ``results.json``.

    Returns
    -------
    header : list of str
    rows : list of list of str
        Empty cells (``""``) where a family has no method with that representation.
    """
    summary = upgrade_summary(summary)
    cells: dict[str, dict[str, dict[str, Any]]] = {}
    for name, m in summary["methods"].items():
        family, rep = _family(name, _place(m))
        cells.setdefault(family, {})[rep] = m
    used = [(rep, label) for rep, label in _COLUMNS if any(rep in c for c in cells.values())]
    header = ["Method"]
    for _, label in used:
        header += [f"F1 ({label})", f"ms/frame host | chip | loop ({label})"]
    rows = []
    for family, reps in cells.items():
        offline = any(m.get("reads_future") for m in reps.values())
        row = [method_label(family, {"reads_future": offline})]
        for rep, _ in used:
            m = reps.get(rep)
            if m is None:
                row += ["", ""]
                continue
            row += [
                _fmt(m["f1_max"]),
                f"{_ms(m.get('latency_ms_median'))} | {_bounded_ms(m, 'chip')} | "
                f"{_bounded_ms(m, 'loop')}",
            ]
        rows.append(row)
    return header, rows


def _extra_table(summary: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    header = [
        "Method",
        "Recall@1",
        "Recall@5",
        "Recall@10",
        "Median error (frames)",
        "Median error (m)",
        "Motion accuracy",
        "Nodes",
        "Map build (s)",
    ]
    rows = []
    for name, m in summary["methods"].items():
        rk = m.get("recall_at_k", {})
        rows.append(
            [
                method_label(name, m),
                _fmt(rk.get("1")),
                _fmt(rk.get("5")),
                _fmt(rk.get("10")),
                _fmt(m.get("error_frames_median"), 1),
                _fmt(m.get("error_m_median"), 1),
                _fmt(m.get("motion_accuracy")),
                _fmt(m.get("n_nodes")),
                _fmt(m.get("build_s"), 2),
            ]
        )
    return header, rows


def _register_figures(result: RunResult) -> list[ReportFigure]:
    """A montage of the saved register planes of every on-sensor method."""
    out = []
    for name, run in result.runs.items():
        if not run.registers:
            continue
        import tempfile

        from ppaloc.sim.render import render_montage

        with tempfile.TemporaryDirectory() as tmp:
            path = render_montage(run.registers, Path(tmp) / "registers.png", columns=3)
            png = path.read_bytes()
        out.append(
            ReportFigure(
                f"registers-{name}",
                f"Registers of {name} after the last frame",
                "Register planes of the simulated SCAMP-5 (256x256 PEs each) after the last "
                "query frame, read without timing or readout noise: the map tiles in the "
                "snake layout, the weights (one value per node block), the working planes, "
                "the motion bit-planes and the detection candidates. Analogue registers on a "
                "fixed grey scale (-128 black, 127 white); digital registers black/white.",
                png,
            )
        )
    return out


def _figures(result: RunResult, bench: dict[str, Any] | None) -> list[ReportFigure]:
    definitions = {run.metrics.recall_definition for run in result.runs.values()}
    d = definitions.pop() if len(definitions) == 1 else "A"
    out = [
        ReportFigure(
            "pr-curves",
            "Precision-recall curves",
            "Every distinct confidence value is a threshold. Recall definition "
            f"{d}: {RECALL_DEFINITIONS[d]}. Dots mark each method's maximum F1."
            + figures.drawn_note(result),
            figures.png_bytes(figures.pr_curves(result)),
        ),
    ]
    diff = figures.difference_matrix(result)
    if diff is not None and result.difference is not None:
        dm = result.difference
        sampled = dm.sampling()
        if sampled != "every frame":
            sampled += f" (at most {DIFFERENCE_SAMPLES} of each traversal)"
        out.append(
            ReportFigure(
                "difference",
                "Difference matrix",
                "How unlike each query frame (x) is to each reference frame (y), whatever the "
                f"method: {dm.measure or MEASURE}, dark = alike, colour clipped to the 1st-99th "
                f"percentile; {sampled}. First panel: the matrix alone. Then per method: the "
                "accepted reference frames of each query (band) and the predicted reference "
                "frame of each query, filled where the method's max-F1 threshold accepts "
                "it, hollow where it rejects it." + figures.drawn_note(result),
                figures.png_bytes(diff),
            )
        )
    out += [
        ReportFigure(
            "position",
            "Position estimate along the route",
            "Grey: the true reference frame (middle of the accepted set) of each query; "
            "dots: the predicted reference frame, green when within the tolerance "
            f"(±{result.tolerance}), red otherwise."
            + (
                " Shaded bands: query frames taken in a turn."
                if result.query_turning is not None and result.query_turning.any()
                else ""
            )
            + figures.drawn_note(result),
            figures.png_bytes(figures.position_along_route(result)),
        ),
    ]
    heat = figures.weights_heatmaps(result)
    if heat is not None:
        out.append(
            ReportFigure(
                "weights",
                "Weights over time",
                "Per-node weight (or score) after each query frame, for methods that "
                "record it, in the method's own units; y is the map's nodes (a keyframe map "
                "has fewer nodes than reference frames); colour clipped to the 1st-99.5th "
                "percentile. Cyan: the accepted nodes lie between the two lines, half a node "
                "outside them (a node stands for the reference frames from its own to the "
                "next node's), so the weights on the true nodes are not covered."
                + figures.drawn_note(
                    result, [n for n, r in result.runs.items() if r.weights is not None]
                ),
                figures.png_bytes(heat),
            )
        )
    out += _register_figures(result)
    timed = [n for n, r in result.runs.items() if np.isfinite(r.latency_ms).any()]
    if timed:
        out.append(
            ReportFigure(
                "latency",
                "Host time per frame in this run",
                (
                    "Time per query as the predictions files give it (ppaloc score), not "
                    "measured by ppaloc."
                    if isinstance(result.config, dict) and result.config.get("command") == "score"
                    else "Wall-clock time of each call to step, all methods measured in one "
                    "run on this machine."
                )
                + figures.drawn_note(result, timed),
                figures.png_bytes(figures.latency_per_frame(result)),
            )
        )
    lat = figures.latency_vs_map_size(bench) if bench else None
    if lat is not None:
        timed = [r for r in bench["rows"] if "skipped" not in r]
        n = timed[0].get("queries", "") if timed else ""
        skipped = [
            f"{r['method']} at {r['n_nodes']} nodes" for r in bench["rows"] if "skipped" in r
        ]
        note = (
            f" Not timed (over the build budget, or refused by the method): {', '.join(skipped)}."
            if skipped
            else ""
        )
        out.append(
            ReportFigure(
                "latency-vs-size",
                "Latency against map size",
                f"Median host time per step over {n} query frames on random maps of each "
                "size (solid; the band reaches the 95th percentile) and, for simulated "
                "methods, the modelled on-sensor time per frame (dashed); hollow markers: "
                f"the paper's Algorithm 1 preset of a filter drawn in its colour.{note}",
                figures.png_bytes(lat),
            )
        )
    return out


_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:0 auto;
max-width:1200px;padding:24px 32px;color:#1d2330;line-height:1.45}
h1{font-size:1.7em;margin-bottom:.2em}h2{margin-top:1.6em;border-bottom:1px solid #dde;
padding-bottom:.2em}
.meta{color:#556;font-size:.95em}
table{border-collapse:collapse;margin:.6em 0;font-size:.92em}
th,td{border:1px solid #ccd;padding:4px 9px;text-align:right}
th{background:#eef1f7}td:first-child,td:nth-child(2){text-align:left}
table.defs td,table.defs th{text-align:left;vertical-align:top}
table.defs td:nth-child(3),table.defs td:nth-child(4){white-space:nowrap}th[title]{cursor:help}
tr:nth-child(even) td{background:#f8f9fc}
td.best{font-weight:700;color:#0a5c2b}
figure{margin:1em 0 1.6em}figure img{max-width:100%;border:1px solid #e3e5ea}
figcaption{color:#445;font-size:.92em;margin-top:.3em}
pre{background:#f4f5f8;padding:10px;overflow-x:auto;font-size:.85em}
dt{font-weight:600}dd{margin:0 0 .4em 1.2em}
nav{font-size:.92em;margin:.4em 0 1em}nav a{color:#2050a0;text-decoration:none}
"""


def _html_table(
    header: list[str], rows: list[list[str]], best_cols: tuple[int, ...], *, cls: str = ""
) -> str:
    """An HTML table; each header defined in :mod:`ppaloc.evaluate.columns` carries its
    definition as a tooltip, and the highest value of each of ``best_cols`` is marked."""
    best = {}
    for c in best_cols:
        vals = [float(r[c]) for r in rows if r[c] not in ("-", "")]
        best[c] = max(vals) if vals else None
    head = "".join(f"<th{_tooltip(h)}>{html.escape(h)}</th>" for h in header)
    body = []
    for r in rows:
        cells = []
        for i, v in enumerate(r):
            cls = (
                ' class="best"'
                if i in best and best[i] is not None and v not in ("-", "") and float(v) == best[i]
                else ""
            )
            cells.append(f"<td{cls}>{html.escape(v)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    attr = f" class='{cls}'" if cls else ""
    return f"<table{attr}><thead><tr>{head}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _tooltip(header: str) -> str:
    column = column_of(header)
    if column is None:
        return ""
    return f" title='{html.escape(f'{column.definition} ({column.unit})', quote=True)}'"


def _best_columns(header: list[str]) -> tuple[int, ...]:
    """The comparison table's columns where higher is better (marked best per column)."""
    better = {"F1 max", "F1 straight", "F1 turning", "AUC", "R @100%P", "P @100%R"}
    return tuple(i for i, h in enumerate(header) if h in better)


_DEFINITION_HEADER = ["Column", "Definition", "Unit", "Recall definition"]


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    """A Markdown table; a ``|`` inside a cell is escaped so it does not split the cell."""

    def line(cells: list[str]) -> str:
        return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"

    return "\n".join([line(header), "|" + "---|" * len(header), *(line(r) for r in rows)])


def _definitions(
    tables: list[list[str]], recall: list[str]
) -> tuple[list[tuple[str, str]], list[list[str]]]:
    """The words the definitions use, and one row (column, definition, unit, recall
    definition) per column the report's tables show, in :data:`COLUMNS` order.

    Raises
    ------
    RuntimeError
        If a table shows a column without a definition (a bug: add it to
        :mod:`ppaloc.evaluate.columns`).
    """
    shown = []
    for header in (h for table in tables for h in table):
        column = column_of(header)
        if column is None:
            raise RuntimeError(f"table column {header!r} has no definition in evaluate.columns")
        if column not in shown:
            shown.append(column)
    letters = ", ".join(recall)
    rows = [
        [c.header, c.definition, c.unit, f"{letters} (this run)" if c.recall else "-"]
        for c in COLUMNS
        if c in shown
    ]
    return list(TERMS), rows


def closure_sentence(rule: dict[str, Any]) -> str:
    """What the same-place closure of the ground truth did, for the report's header line
    (empty where no rule ran): how many stops of each traversal, and queries changed.

    Examples
    --------
    >>> rule = {"rule": "still-frames", "groups": 17, "grouped_frames": 235,
    ...         "query_groups": 15, "query_grouped_frames": 249, "queries_changed": 283}
    >>> print(closure_sentence(rule).strip())  # doctest: +NORMALIZE_WHITESPACE
    Accepted sets closed over the same-place groups (still-frames): 17 in the reference
    (235 frames), 15 in the query (249 frames); 283 queries changed.
    >>> closure_sentence({"rule": "off", "reason": "same_place=off"})
    ''
    """
    if rule.get("rule") not in ("still-frames", "positions") or "groups" not in rule:
        return ""
    where = [f"{rule['groups']} in the reference ({rule['grouped_frames']} frames)"]
    if "query_groups" in rule:
        where.append(f"{rule['query_groups']} in the query ({rule['query_grouped_frames']} frames)")
    return (
        f" Accepted sets closed over the same-place groups ({rule['rule']}): "
        f"{', '.join(where)}; {rule['queries_changed']} queries changed."
    )


def write_report(folder: str | Path, *, bench_path: str | Path | None = None) -> Path:
    """Write ``report.html``, ``report.md`` and ``figures/`` into a results folder, from its
    files only, as one transaction (:func:`ppaloc.fileio.update_folder`): a kill leaves the
    folder with its earlier report whole.

    Parameters
    ----------
    folder : str or Path
        A folder written by :func:`ppaloc.evaluate.results.save_results`.
    bench_path : str or Path, optional
        A ``ppaloc bench`` JSON file (default ``folder/bench.json`` where present).

    Returns
    -------
    Path
        ``folder/report.html``.
    """
    folder = Path(folder)
    if not folder.is_dir():
        load_results(folder)  # the one-line error for a missing folder; never create one
    check_report_figures(folder)
    here = Path.cwd().resolve()
    if folder.resolve() == here or folder.resolve() in here.parents:
        # Swapping the folder a shell stands in would leave the shell in a deleted one:
        # write the report's files one by one (each still atomic).
        return write_report_files(folder, bench_path=bench_path)
    with update_folder(folder) as stage:
        try:
            write_report_files(stage, bench_path=bench_path)
        except PpalocError as exc:  # name the user's folder, not the staging copy
            raise type(exc)(str(exc).replace(str(stage), str(folder))) from None
    return folder / "report.html"


def write_report_files(folder: str | Path, *, bench_path: str | Path | None = None) -> Path:
    """Write the report's files into ``folder`` directly (a staging folder, or one no
    reader shares); earlier figures are removed first. Returns ``folder/report.html``."""
    folder = Path(folder)
    result, summary = load_results(folder)
    old = folder / "figures"  # the report's own output: earlier figures, or whatever took the name
    if old.is_symlink() or (old.exists() and not old.is_dir()):
        old.unlink()
    shutil.rmtree(old, ignore_errors=True)
    bench = load_bench(bench_path if bench_path is not None else folder / "bench.json")
    figs = _figures(result, bench)
    header, rows = comparison_table(summary)
    pheader, prows = paper_table(summary)
    xheader, xrows = _extra_table(summary)
    recall = sorted({m.get("recall_definition", "A") for m in summary["methods"].values()})
    terms, columns = _definitions([pheader, header, xheader], recall)
    title = f"ppaloc report: {result.dataset_name}"
    n_q = len(result.ground_truth)
    n_match = sum(1 for g in result.ground_truth if len(g))
    truth = result.protocol.get("ground_truth") or {}
    if truth.get("tolerance_unit") == "metres":  # positions files: the tolerance is metres
        tolerance = f"tolerance {truth.get('tolerance')} m"
    else:
        tolerance = f"tolerance ±{result.tolerance} frame{'' if result.tolerance == 1 else 's'}"
    meta = (
        f"Dataset `{result.dataset}`: {result.n_reference} reference frames, {n_q} query "
        f"frames ({n_match} with a true match), {tolerance}. "
        f"ppaloc {result.ppaloc_version}{', ' + result.created if result.created else ''}."
    )
    meta += closure_sentence(truth.get("same_place") or {})
    if result.roles:  # one line: what the map was built from and what was localised
        meta += f" Database: {result.roles['database']}; query: {result.roles['query']}."
    meta_html = html.escape(meta).replace("`", "<code>", 1).replace("`", "</code>", 1)
    parts = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        "<meta name='viewport' content='width=device-width, initial-scale=1'>",
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(title)}</h1><p class='meta'>{meta_html}</p>",
        "<nav>"
        + " · ".join(
            [
                "<a href='#comparison'>Comparison</a>",
                *(f"<a href='#{f.key}'>{html.escape(f.title)}</a>" for f in figs),
                "<a href='#definitions'>Definitions</a>",
                "<a href='#configuration'>Configuration</a>",
            ]
        )
        + "</nav>",
        "<h2 id='comparison'>Comparison (layout of the paper's Table I)</h2>",
        "<p>Max F1 per method and place representation; frame time as host wall clock "
        "(median over the query frames) | modelled on-sensor time (simulated methods "
        "only). Best F1 per column in bold green.</p>",
        _html_table(pheader, prows, best_cols=tuple(range(1, len(pheader), 2))),
        "<h2>All metrics</h2>",
        _html_table(header, rows, best_cols=_best_columns(header)),
        _html_table(xheader, xrows, best_cols=(1, 2, 3)),
    ]
    notes = method_notes(summary)
    if notes:
        parts.append("<h2 id='notes'>Notes on the methods</h2><ul>")
        parts += [f"<li>{html.escape(n)}</li>" for n in notes]
        parts.append("</ul>")
    for f in figs:
        b64 = base64.b64encode(f.png).decode("ascii")
        parts.append(
            f"<h2 id='{f.key}'>{html.escape(f.title)}</h2><figure>"
            f"<img src='data:image/png;base64,{b64}' alt='{html.escape(f.title)}'>"
            f"<figcaption>{html.escape(f.caption)}</figcaption></figure>"
        )
    parts.append("<h2 id='definitions'>Definitions</h2><dl>")
    parts += [f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in terms]
    parts.append("</dl>")
    parts.append(_html_table(_DEFINITION_HEADER, columns, best_cols=(), cls="defs"))
    parts.append("<h2 id='configuration'>Configuration</h2>")
    parts.append(f"<pre>{html.escape(json.dumps(result.config, indent=2))}</pre>")
    parts.append("</body></html>\n")
    out = write_bytes(folder / "report.html", "\n".join(parts))

    md = [f"# {title}", "", meta, ""]
    md += ["## Comparison (layout of the paper's Table I)", "", _md_table(pheader, prows), ""]
    md += ["## All metrics", "", _md_table(header, rows), "", _md_table(xheader, xrows), ""]
    if notes:
        md += ["## Notes on the methods", "", *(f"- {n}" for n in notes), ""]
    for f in figs:
        rel = f"figures/{f.key}.png"
        write_bytes(folder / rel, f.png)
        md += [f"## {f.title}", "", f"![{f.title}]({rel})", "", f.caption, ""]
    md += ["## Definitions", ""] + [f"- **{k}**: {v}" for k, v in terms]
    md += ["", _md_table(_DEFINITION_HEADER, columns)]
    md += ["", "## Configuration", "", "```json", json.dumps(result.config, indent=2), "```", ""]
    write_bytes(folder / "report.md", "\n".join(md))
    return out
