"""Result files: write a run to a folder and read it back (reports are built from these).

Layout of a results folder::

    results.json          summary: dataset, tolerance, per-method metrics, config, version
    results.csv           one row per method, the same scalars as results.json
    arrays/_dataset.npz   ground truth (CSR: gt_indptr, gt_indices), positions, query_moved,
                          query_turning and reference_turning (where the dataset has them)
    arrays/<method>.npz   per-query arrays of one method (see MethodRun)
    arrays/<method>.registers.npz  register planes after the last frame (on-sensor only):
                          ``labels`` (P,) str and ``plane0`` .. ``plane{P-1}`` (2-D)
    bench.json            latency against map size, where measured (ppaloc bench / demo)

Every file is written atomically (a temporary file in the same folder, then
``os.replace``), so an interrupted run never leaves a half-written result.
"""

from __future__ import annotations

import csv
import io
import json
import re
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.errors import DataError
from ppaloc.evaluate.run import MethodRun, RunResult, method_metrics
from ppaloc.fileio import write_bytes

__all__ = [
    "CSV_COLUMNS",
    "array_file",
    "load_results",
    "save_results",
]

CSV_COLUMNS = [
    "method",
    "f1_max",
    "precision_at_f1",
    "recall_at_f1",
    "auc",
    "recall_at_100p",
    "accuracy",
    "recall_definition",
    "latency_ms_median",
    "latency_ms_p95",
    "modelled_latency_ms",
    "energy_mj",
    "error_frames_median",
    "error_m_median",
    "recall_at_1",
    "recall_at_5",
    "recall_at_10",
    "motion_accuracy",
    "n_nodes",
    "n_queries",
    "build_s",
    "f1_max_straight",
    "f1_max_turning",
]
"""Columns of ``results.csv``, in order."""

_ARRAYS = ("node", "ref_index", "score", "moved", "ranking", "latency_ms")
_OPTIONAL = ("weights", "modelled_latency_ms", "energy_mj")
_DATASET_OPTIONAL = (
    "reference_positions",
    "query_positions",
    "query_moved",
    "query_turning",
    "reference_turning",
)


def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return buf.getvalue()


def array_file(method: str) -> str:
    """Relative path of a method's per-query arrays inside a results folder."""
    return f"arrays/{re.sub(r'[^A-Za-z0-9_.-]', '_', method)}.npz"


def _csv_row(name: str, summary: dict[str, Any], n_queries: int) -> list[Any]:
    rk = summary.get("recall_at_k", {})
    row = {**summary, "method": name, "n_queries": n_queries}
    for k in ("1", "5", "10"):
        row[f"recall_at_{k}"] = rk.get(k)
    return ["" if row.get(c) is None else row.get(c) for c in CSV_COLUMNS]


def save_results(result: RunResult, out: str | Path) -> Path:
    """Write ``result`` into folder ``out`` (created if needed); return ``out/results.json``."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise DataError(f"--out {out} is a file; give a folder for the results")
    summary = result.summary()
    for name, run in result.runs.items():
        rel = array_file(name)
        summary["methods"][name]["arrays"] = rel
        arrays = {k: getattr(run, k) for k in _ARRAYS}
        arrays.update({k: getattr(run, k) for k in _OPTIONAL if getattr(run, k) is not None})
        arrays["curve_thresholds"] = run.metrics.curve.thresholds
        arrays["curve_precision"] = run.metrics.curve.precision
        arrays["curve_recall"] = run.metrics.curve.recall
        write_bytes(out / rel, _npz_bytes(arrays))
        if run.registers:
            names = list(run.registers)
            planes = {f"plane{i}": np.asarray(run.registers[n]) for i, n in enumerate(names)}
            planes["labels"] = np.array(names)
            reg_rel = rel.replace(".npz", ".registers.npz")
            summary["methods"][name]["registers"] = reg_rel
            write_bytes(out / reg_rel, _npz_bytes(planes))
    gt = result.ground_truth
    ds_arrays = {
        "gt_indptr": np.cumsum([0] + [len(g) for g in gt]).astype(np.int64),
        "gt_indices": (np.concatenate(gt) if gt else np.zeros(0)).astype(np.int64),
    }
    for key in _DATASET_OPTIONAL:
        value = getattr(result, key)
        if value is not None:
            ds_arrays[key] = np.asarray(value)
    write_bytes(out / "arrays" / "_dataset.npz", _npz_bytes(ds_arrays))
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for name, s in summary["methods"].items():
        writer.writerow(_csv_row(name, s, summary["n_queries"]))
    write_bytes(out / "results.csv", text.getvalue())
    # allow_nan=False: results.json must stay strict JSON (NaN and Infinity are not)
    return write_bytes(out / "results.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")


def _read_npz(path: Path, required: Sequence[str], folder: Path) -> dict[str, np.ndarray]:
    """Every array of a result ``.npz`` (no unpickling); a damaged or incomplete file is a
    :class:`DataError` naming it."""
    try:
        with open(path, "rb") as f, np.load(f, allow_pickle=False) as z:  # f: closed on error
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise DataError(
            f"cannot read {path} ({exc}); run `ppaloc evaluate --out {folder}` again"
        ) from None
    _require(arrays, required, path)
    return arrays


def _require(arrays: Mapping[str, np.ndarray], names: Sequence[str], path: Path) -> None:
    missing = [n for n in names if n not in arrays]
    if missing:
        raise DataError(f"{path} has no array {missing[0]!r}; it was not written by ppaloc")


def _bools(value: np.ndarray | None) -> np.ndarray | None:
    return None if value is None else np.asarray(value, dtype=bool)


def load_results(folder: str | Path) -> tuple[RunResult, dict[str, Any]]:
    """Read a results folder written by :func:`save_results`.

    Metrics are recomputed from the per-query arrays (so a report never depends on
    anything but the files).

    Returns
    -------
    RunResult
        With every method's arrays and metrics.
    dict
        The raw ``results.json``.

    Raises
    ------
    DataError
        If the folder or one of its files is missing or unreadable.
    """
    folder = Path(folder)
    path = folder / "results.json"
    if not path.is_file():
        raise DataError(
            f"{folder} holds no results.json; give a folder written by `ppaloc evaluate --out`"
        )
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read the results in {folder}: {exc}") from exc
    missing = [k for k in ("dataset", "tolerance", "methods") if k not in summary]
    if missing:
        raise DataError(
            f"{path} has no {missing[0]!r} entry; give a folder written by `ppaloc evaluate --out`"
        )
    ds = _read_npz(folder / "arrays" / "_dataset.npz", ("gt_indptr", "gt_indices"), folder)
    indptr, indices = ds["gt_indptr"], ds["gt_indices"]
    gt = [indices[indptr[i] : indptr[i + 1]] for i in range(len(indptr) - 1)]
    runs: dict[str, MethodRun] = {}
    for name, s in summary["methods"].items():
        a = _read_npz(folder / s.get("arrays", array_file(name)), _ARRAYS, folder)
        registers = None
        if s.get("registers"):
            planes = _read_npz(folder / s["registers"], ("labels",), folder)
            labels = [str(x) for x in planes["labels"]]
            _require(planes, [f"plane{i}" for i in range(len(labels))], folder / s["registers"])
            registers = {lab: planes[f"plane{i}"] for i, lab in enumerate(labels)}
        ranking = a["ranking"]
        metrics = method_metrics(
            a["ref_index"],
            a["score"],
            gt,
            ranking,
            recall=s.get("recall_definition", "A"),
            reference_positions=ds.get("reference_positions"),
            query_positions=ds.get("query_positions"),
            turning=_bools(ds.get("query_turning")),
        )
        runs[name] = MethodRun(
            method=name,
            params=s.get("params", {}),
            map_kind=s.get("map_kind", ""),
            n_nodes=int(s.get("n_nodes", 0)),
            build_s=float(s.get("build_s", 0.0)),
            node=a["node"],
            ref_index=a["ref_index"],
            score=a["score"],
            moved=a["moved"],
            ranking=ranking,
            latency_ms=a["latency_ms"],
            metrics=metrics,
            weights=a.get("weights"),
            modelled_latency_ms=a.get("modelled_latency_ms"),
            energy_mj=a.get("energy_mj"),
            modelled_time_ms=s.get("modelled_time_ms"),
            motion_accuracy=s.get("motion_accuracy"),
            registers=registers,
        )
    result = RunResult(
        dataset=summary["dataset"],
        dataset_name=summary.get("dataset_name", summary["dataset"]),
        tolerance=int(summary["tolerance"]),
        ground_truth=gt,
        n_reference=int(summary.get("n_reference", 0)),
        runs=runs,
        config=summary.get("config", {}),
        reference_positions=ds.get("reference_positions"),
        query_positions=ds.get("query_positions"),
        query_moved=ds.get("query_moved"),
        query_turning=_bools(ds.get("query_turning")),
        reference_turning=_bools(ds.get("reference_turning")),
        ppaloc_version=summary.get("ppaloc_version", ""),
        created=summary.get("created", ""),
    )
    return result, summary
