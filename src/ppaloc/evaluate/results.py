"""Result files: write a run to a folder and read it back (reports are built from these).

Layout of a results folder::

    results.json          summary: dataset, its roles, tolerance, per-method metrics, config,
                          version
    results.csv           one row per method, the same scalars as results.json, and the
                          roles (database, query)
    arrays/_dataset.npz   ground truth (CSR: gt_indptr, gt_indices; soft ground truth as
                          gt_soft_indptr, gt_soft_indices where the dataset has one),
                          positions, query_moved, query_turning and reference_turning
                          (where the dataset has them)
    arrays/<method>.npz   per-query arrays of one method (see MethodRun) and its map's
                          frame_index
    arrays/_difference.npz  the difference matrix of sampled (query, reference) frame pairs
                          (see ppaloc.evaluate.difference)
    arrays/<method>.registers.npz  register planes after the last frame (on-sensor only):
                          ``labels`` (P,) str and ``plane0`` .. ``plane{P-1}`` (2-D)
    bench.json            latency against map size, where measured (ppaloc bench / demo)

:func:`save_results` writes the whole folder as one transaction
(:func:`ppaloc.fileio.new_folder`): the files go into a staging folder beside ``out``
that then takes its place in one step, so a reader (or a run killed at any moment) sees
the whole earlier folder or the whole new one, and nothing of an earlier run is left in
the new one. ``results.json``, written last, lists every other result file with its
SHA-256 (``files``); :func:`load_results` checks them, and bounds every array and index.
``results.json`` carries its format version (``format``, :data:`RESULTS_FORMAT`); a folder
written before the field existed (format 1) is read with its fields renamed
(:func:`upgrade_summary`), one written by a newer ppaloc is refused.
"""

from __future__ import annotations

import contextlib
import csv
import hashlib
import io
import json
import os
import re
import sys
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc import __version__
from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.errors import DataError
from ppaloc.evaluate.difference import DifferenceMatrix
from ppaloc.evaluate.run import MethodRun, RunResult, method_metrics
from ppaloc.fileio import (
    check_replaceable_folder,
    new_folder,
    recover_folder,
    source_date,
    write_bytes,
)
from ppaloc.npzfile import NpzError, npz_bytes, read_npz

__all__ = [
    "CSV_COLUMNS",
    "MAX_RESULT_BYTES",
    "RESULTS_FORMAT",
    "ROLE_COLUMNS",
    "array_file",
    "check_method_entry",
    "check_replaceable",
    "check_report_figures",
    "load_results",
    "results_folder",
    "save_results",
    "upgrade_summary",
    "write_results",
    "written_by_ppaloc",
]

RESULTS_FORMAT = 2
"""Version of the results folder's format, written as ``format`` in ``results.json``.

1 (no ``format`` field): each method's precision with every query accepted is named
``accuracy``; no ``frame_index`` per method and no difference matrix.
2: that number is ``precision_at_100r``; ``frame_index`` and ``arrays/_difference.npz``.
"""

_RENAMED = {1: {"accuracy": "precision_at_100r"}}
"""Per older format, the method fields renamed since (old name -> current name)."""

MAX_RESULT_BYTES = 16 << 30
"""Most array bytes one result ``.npz`` may hold (16 GiB); larger claims are refused."""

CSV_COLUMNS = [
    "method",
    "f1_max",
    "precision_at_f1",
    "recall_at_f1",
    "auc",
    "recall_at_100p",
    "precision_at_100r",
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
    "database",
    "query",
]
"""Columns of ``results.csv``, in order (the last two: the dataset's roles,
:data:`ROLE_COLUMNS`)."""

ROLE_COLUMNS = ("database", "query")
"""The columns of ``results.csv`` that say what the reference and the query traversals are
(the same in every row), not metrics."""

_ARRAYS = ("node", "ref_index", "score", "moved", "ranking", "latency_ms")
_OPTIONAL = ("weights", "modelled_latency_ms", "energy_mj", "frame_index")
_DIFFERENCE = ("difference", "query_index", "reference_index")
_DIFFERENCE_FILE = "arrays/_difference.npz"
_DATASET_OPTIONAL = (
    "reference_positions",
    "query_positions",
    "query_moved",
    "query_turning",
    "reference_turning",
)


_OWN_NAMES = frozenset(
    {
        "results.json",
        "results.csv",
        "arrays",
        "report.html",
        "report.md",
        "figures",
        "bench.json",
        "bench.csv",
        "matrix.csv",
    }
)
"""What ppaloc writes at the top of a results folder (matrix runs add ``NN-<spec>/``)."""
_CARRIED = ("bench.json", "bench.csv")  # a separate `ppaloc bench --out` into the folder


#: The results files whose presence marks a folder as ppaloc's (a run's, a matrix run's or
#: a ``ppaloc bench --out``'s); only such a folder is replaced.
_MARKERS = ("results.json", "matrix.csv", "bench.json")


def _temporary_of(name: str, owned: Iterable[str]) -> bool:
    """Whether ``name`` is the temporary a killed write of one of ``owned`` left
    (``.results.json.PID-xxxxxxxx.tmp``)."""
    own = "|".join(re.escape(n) for n in owned)
    return re.fullmatch(rf"\.({own})\.\d{{1,10}}-[0-9a-f]{{4,16}}\.tmp", name) is not None


def _written_files(folder: Path) -> frozenset[str]:
    """The files below ``folder`` that its ``results.json`` says ppaloc wrote: the checked
    ``files``, each method's ``arrays`` and ``registers``, the difference matrix, the
    dataset's arrays, and the report's figures (none where there is no results.json).

    Raises
    ------
    DataError
        A ``results.json`` that cannot be read or is not a table, named as such.
    """
    from ppaloc.evaluate.report import figure_files

    path = folder / "results.json"
    try:
        summary = json.loads(path.read_bytes())
    except FileNotFoundError:
        return frozenset()
    except (OSError, ValueError, RecursionError) as exc:
        why = (
            "nested too deep"
            if isinstance(exc, RecursionError)
            else (exc.strerror or str(exc) if isinstance(exc, OSError) else f"not JSON: {exc}")
        )
        raise _unreadable_summary(path, why) from None
    if not isinstance(summary, dict):
        raise _unreadable_summary(path, "not a results table")
    named: list[Any] = ["arrays/_dataset.npz"]
    files = summary.get("files")
    named += list(files) if isinstance(files, dict) else []
    methods = summary.get("methods")
    methods = methods if isinstance(methods, dict) else {}
    for entry in methods.values():
        if isinstance(entry, dict):
            named += [entry.get("arrays"), entry.get("registers")]
    difference = summary.get("difference")
    if isinstance(difference, dict):
        named.append(difference.get("arrays"))
    named += figure_files([str(m) for m in methods])
    return frozenset(n for n in named if isinstance(n, str))


def _unreadable_summary(path: Path, why: str) -> DataError:
    """The error of a ``results.json`` that cannot be read where it alone tells ppaloc's
    files below ``arrays/`` and ``figures/`` from a user's (they were refused as the
    user's, naming ``arrays/_dataset.npz`` rather than the file at fault)."""
    return DataError(
        f"cannot read {path} ({why}), which names the files ppaloc wrote in its arrays/ and "
        "figures/, so the folder cannot be replaced without losing a file of yours; restore "
        "results.json (read permission, or a copy) or give a new folder"
    )


def _ours(folder: Path, name: str, written: dict[Path, frozenset[str]] | None = None) -> bool:
    """A name ppaloc writes in a results folder: one of :data:`_OWN_NAMES`, a matrix run's
    ``NN-<spec>/`` (a folder holding a ``results.json``), or a temporary a killed write left
    (``.results.json.PID-xxxxxxxx.tmp``). A path below a subfolder (``arrays/x.npz``) is
    ppaloc's where ``results.json`` names it (:func:`_written_files`; ``written`` caches
    those per folder), or where it lies in a matrix run's folder that holds it as its own."""
    head, sep, rest = name.partition("/")
    if sep:
        if not _ours(folder, head):
            return False
        if head not in _OWN_NAMES:  # a matrix run's results folder
            return _ours(folder / head, rest, written)
        if head not in ("arrays", "figures"):
            return False
        written = {} if written is None else written
        if folder not in written:
            written[folder] = _written_files(folder)
        own = written[folder]
        base, _, leaf = name.rpartition("/")
        if name in own:
            return True
        return _temporary_of(leaf, [n.rpartition("/")[2] for n in own if n.startswith(base + "/")])
    if name.startswith(".") and name.endswith(".tmp"):
        return _temporary_of(name, _OWN_NAMES)
    if re.fullmatch(r"\d{2,}-.*", name):
        sub = folder / name
        return sub.is_dir() and not sub.is_symlink() and (sub / "results.json").is_file()
    return name in _OWN_NAMES


def written_by_ppaloc(
    folder: Path, name: str, written: dict[Path, frozenset[str]] | None = None
) -> bool:
    """Whether ``name``, a path relative to the results folder ``folder`` (``/`` between
    its parts: ``arrays/x.npz``), is an entry ppaloc writes there: what
    :func:`check_replaceable` accepts (``written`` caches what each folder's
    ``results.json`` names). A sweep's cell folders are results folders."""
    return _ours(folder, name, written)


def check_replaceable(out: str | Path) -> None:
    """Refuse an ``out`` that is a file or a folder holding files ppaloc did not write, at
    its top or inside the subfolders ppaloc writes (``arrays/``, ``figures/``, a matrix
    run's folders): a results folder is replaced whole; a user's own files must not go with
    it."""
    written: dict[Path, frozenset[str]] = {}
    check_replaceable_folder(
        out,
        owned=lambda folder, name: _ours(folder, name, written),
        marked=lambda folder: any((folder / m).is_file() for m in _MARKERS),
        markers=" or ".join(_MARKERS),
        writer="ppaloc",
        kind="results folder",
        error=DataError,
        nested=True,
    )


def check_report_figures(folder: str | Path) -> None:
    """Refuse to rebuild the report of ``folder`` where its ``figures/`` holds an entry
    ppaloc did not write: the report's figures are replaced whole, and a user's file must
    not go with them (``ppaloc show DIR``)."""
    folder = Path(folder)
    figures = folder / "figures"
    if figures.is_symlink() or not figures.is_dir():
        return
    _read_summary(folder)  # an unreadable results.json is named as such, not its figures
    written: dict[Path, frozenset[str]] = {}
    for root, dirs, files in os.walk(figures):
        dirs.sort()
        for name in sorted([*dirs, *files]):
            rel = (Path(root) / name).relative_to(folder).as_posix()
            if not _ours(folder, rel, written):
                raise DataError(
                    f"{folder} holds {rel!r}, which ppaloc did not write, and the report's "
                    "figures are replaced whole; move it out of figures/ first"
                )


@contextlib.contextmanager
def results_folder(out: str | Path) -> Iterator[Path]:
    """A fresh staging folder that replaces ``out`` whole when the block ends cleanly.

    ``out`` must be absent, empty or an earlier results folder
    (:func:`check_replaceable`); its ``bench.json`` and ``bench.csv`` are kept. An
    exception (or a kill) inside the block leaves ``out`` as it was.
    """
    out = Path(out)
    check_replaceable(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with new_folder(out, carry=_CARRIED) as stage:
        yield stage


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def array_file(method: str) -> str:
    """Relative path of a method's per-query arrays inside a results folder."""
    return f"arrays/{re.sub(r'[^A-Za-z0-9_.-]', '_', method)}.npz"


def _csv_row(
    name: str, summary: dict[str, Any], n_queries: int, roles: dict[str, str] | None
) -> list[Any]:
    rk = summary.get("recall_at_k", {})
    row = {**summary, **(roles or {}), "method": name, "n_queries": n_queries}
    for k in ("1", "5", "10"):
        row[f"recall_at_{k}"] = rk.get(k)
    return ["" if row.get(c) is None else row.get(c) for c in CSV_COLUMNS]


def save_results(result: RunResult, out: str | Path) -> Path:
    """Write ``result`` as the folder ``out``, replacing it whole (see :func:`results_folder`);
    return ``out/results.json``."""
    out = Path(out)
    with results_folder(out) as stage:
        write_results(result, stage)
    return out / "results.json"


def write_results(result: RunResult, out: str | Path) -> Path:
    """Write ``result``'s files into the folder ``out`` (a staging folder: nothing here is
    transactional on its own); return ``out/results.json``.

    The same result gives the same bytes: no clock time is written (``created`` only
    where ``SOURCE_DATE_EPOCH`` is set) and the ``.npz`` entries carry fixed timestamps.
    """
    out = Path(out)
    written: list[str] = []
    summary = {"format": RESULTS_FORMAT, **result.summary()}
    when = source_date()
    if when is None:
        summary.pop("created", None)
    else:
        summary["created"] = when.isoformat(timespec="seconds")
    for name, run in result.runs.items():
        rel = array_file(name)
        summary["methods"][name]["arrays"] = rel
        arrays = {k: getattr(run, k) for k in _ARRAYS}
        arrays.update({k: getattr(run, k) for k in _OPTIONAL if getattr(run, k) is not None})
        arrays["curve_thresholds"] = run.metrics.curve.thresholds
        arrays["curve_precision"] = run.metrics.curve.precision
        arrays["curve_recall"] = run.metrics.curve.recall
        write_bytes(out / rel, npz_bytes(arrays))
        written.append(rel)
        if run.registers:
            names = list(run.registers)
            planes = {f"plane{i}": np.asarray(run.registers[n]) for i, n in enumerate(names)}
            planes["labels"] = np.array(names)
            reg_rel = rel.replace(".npz", ".registers.npz")
            summary["methods"][name]["registers"] = reg_rel
            write_bytes(out / reg_rel, npz_bytes(planes))
            written.append(reg_rel)
    gt = PackedSets.from_sets(result.ground_truth)
    ds_arrays = {"gt_indptr": gt.indptr, "gt_indices": gt.indices}
    if gt.soft is not None:
        ds_arrays.update(gt_soft_indptr=gt.soft.indptr, gt_soft_indices=gt.soft.indices)
    for key in _DATASET_OPTIONAL:
        value = getattr(result, key)
        if value is not None:
            ds_arrays[key] = np.asarray(value)
    write_bytes(out / "arrays" / "_dataset.npz", npz_bytes(ds_arrays))
    written.append("arrays/_dataset.npz")
    if result.difference is not None:
        d = result.difference
        write_bytes(
            out / _DIFFERENCE_FILE,
            npz_bytes(
                {
                    "difference": np.asarray(d.values, dtype=np.float32),
                    "query_index": np.asarray(d.query_index, dtype=np.int64),
                    "reference_index": np.asarray(d.reference_index, dtype=np.int64),
                }
            ),
        )
        written.append(_DIFFERENCE_FILE)
        summary["difference"] = {"arrays": _DIFFERENCE_FILE, "measure": d.measure}
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(CSV_COLUMNS)
    for name, s in summary["methods"].items():
        writer.writerow(_csv_row(name, s, summary["n_queries"], summary.get("roles")))
    write_bytes(out / "results.csv", text.getvalue())
    written.append("results.csv")
    summary["files"] = {rel: _sha256(out / rel) for rel in sorted(written)}
    # allow_nan=False: results.json must stay strict JSON (NaN and Infinity are not)
    return write_bytes(out / "results.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")


def _again(folder: Path) -> str:
    return f"run `ppaloc evaluate --out {folder}` again"


def _read_npz(path: Path, required: Sequence[str], folder: Path) -> dict[str, np.ndarray]:
    """Every array of a result ``.npz``, each bounded before it is read (no unpickling); a
    missing, damaged or incomplete file is a :class:`DataError` naming it."""
    if not path.is_file():
        raise DataError(f"{folder} is not whole: {path} is missing; {_again(folder)}")
    try:
        arrays = read_npz(path, max_bytes=MAX_RESULT_BYTES)
    except NpzError as exc:
        raise DataError(f"cannot read {path} ({exc}); {_again(folder)}") from None
    except OSError as exc:
        raise DataError(f"cannot read {path} ({exc.strerror or exc}); {_again(folder)}") from None
    _require(arrays, required, path)
    return arrays


def _require(arrays: Mapping[str, np.ndarray], names: Sequence[str], path: Path) -> None:
    missing = [n for n in names if n not in arrays]
    if missing:
        raise DataError(f"{path} has no array {missing[0]!r}; it was not written by ppaloc")


def _bools(value: np.ndarray | None) -> np.ndarray | None:
    return None if value is None else np.asarray(value, dtype=bool)


def _inner(folder: Path, rel: Any, field: str) -> Path:
    """``folder / rel`` for a relative path stored in results.json, refused if it leaves
    the folder."""
    if not isinstance(rel, str) or not rel:
        raise DataError(f"{folder / 'results.json'}: {field} is {rel!r:.60}, not a file name")
    path = Path(rel)
    if path.is_absolute() or ".." in path.parts:
        raise DataError(
            f"{folder / 'results.json'}: {field} {rel!r:.60} points outside the folder; "
            f"{_again(folder)}"
        )
    return folder / path


def _check_whole(folder: Path, files: Any) -> None:
    """Every file results.json lists is there with the checksum it recorded."""
    if not isinstance(files, dict):
        raise DataError(f"{folder / 'results.json'}: 'files' is not a table; {_again(folder)}")
    for rel, digest in files.items():
        path = _inner(folder, rel, f"files entry {rel!r:.60}")
        if not path.is_file():
            raise DataError(f"{folder} is not whole: {rel} is missing; {_again(folder)}")
        if _sha256(path) != digest:
            raise DataError(
                f"{folder} is not whole: {rel} does not match the checksum in results.json "
                f"(files of two runs mixed, or damaged); {_again(folder)}"
            )


def _count(summary: Mapping[str, Any], key: str, path: Path, default: int | None = None) -> int:
    value = summary.get(key, default)
    if not isinstance(value, int) or isinstance(value, bool) or value < 0:
        raise DataError(f"{path}: {key!r} is {value!r:.40}, expected a count >= 0")
    return value


def _check_array(
    a: np.ndarray, where: str, *, length: int, ndim: int = 1, bounds: tuple[int, int] | None = None
) -> None:
    """``a`` has ``ndim`` dimensions and ``length`` rows; integer values in ``bounds``."""
    if a.ndim != ndim or len(a) != length:
        raise DataError(f"{where} has shape {a.shape}, expected {length} rows in {ndim}-D")
    if a.dtype.kind not in "biuf":
        raise DataError(f"{where} holds {a.dtype}, not numbers")
    if bounds is not None and a.size:
        if a.dtype.kind not in "iu":
            raise DataError(f"{where} holds {a.dtype}, expected integers")
        lo, hi = bounds
        bad = np.flatnonzero((a < lo) | (a >= hi))
        if bad.size:
            at = np.unravel_index(int(bad[0]), a.shape)
            shown = ", ".join(map(str, at))
            raise DataError(
                f"{where}[{shown}] is {int(a[at])}, outside {lo}..{hi - 1} (an index into "
                f"{hi} entries)"
            )


_METRICS = (
    "f1_max",
    "precision_at_f1",
    "recall_at_f1",
    "auc",
    "recall_at_100p",
    "precision_at_100r",
)
"""Every method's entry of results.json has these (a number, or null)."""
_NUMBERS = (
    "latency_ms_median",
    "latency_ms_p95",
    "modelled_latency_ms",
    "modelled_latency_ms_mean",
    "energy_mj",
    "f1_max_straight",
    "f1_max_turning",
    "error_frames_median",
    "error_m_median",
    "motion_accuracy",
    "n_nodes",
    "build_s",
)
"""Optional fields of a method's entry that hold a number or null."""


def _not_strict_json(name: str) -> Any:
    """``json.loads``'s hook for NaN, Infinity and -Infinity, which ppaloc never writes
    (strict JSON, ``allow_nan=False``): a hand-edited value is refused where it is read."""
    raise ValueError(
        f"results.json holds {name}, which is not JSON (ppaloc writes null where there is no value)"
    )


def _is_number(v: Any) -> bool:
    """None, or a finite number a float holds: 1e400 reads as inf and an int of 400
    digits overflows where it is drawn or formatted, and ppaloc writes neither."""
    if v is None:
        return True
    if isinstance(v, bool) or not isinstance(v, int | float):
        return False
    return -sys.float_info.max <= v <= sys.float_info.max


def _check_fields(
    entry: Mapping[str, Any], name: str, path: Path, *, complete: bool = True
) -> None:
    """The fields a table or report reads from a method's entry have the types ppaloc
    writes (a hand-edited results.json is named, field and all, in one line); with
    ``complete``, every one of :data:`_METRICS` is there."""

    def bad(field: str, value: Any, want: str, *, missing: bool = False) -> DataError:
        state = "is missing" if missing else f"is {value!r:.40}"  # not the text 'missing'
        return DataError(
            f"{path}: methods.{name}.{field} {state}, expected {want}; "
            "give a folder written by `ppaloc evaluate --out` (or run it again)"
        )

    for field in _METRICS if complete else ():
        if field not in entry:
            raise bad(field, None, "a number", missing=True)
    for field in (*_METRICS, *_NUMBERS):
        if not _is_number(entry.get(field)):
            raise bad(field, entry[field], "a number or null")
    for field in ("map_kind", "recall_definition"):
        if not isinstance(entry.get(field, ""), str):
            raise bad(field, entry[field], "a string")
    if not isinstance(entry.get("params", {}), dict):  # the report reads its descriptor
        raise bad("params", entry["params"], "a table of the method's parameters")
    rk = entry.get("recall_at_k", {})
    if not isinstance(rk, dict) or not all(_is_number(v) for v in rk.values()):
        raise bad("recall_at_k", rk, "a table of numbers")
    if not isinstance(entry.get("reads_future", False), bool):
        raise bad("reads_future", entry["reads_future"], "true or false")
    speed = entry.get("speed_check")
    if speed is not None and not (
        isinstance(speed, dict)
        and isinstance(speed.get("warning"), str | None)
        and _is_number(speed.get("query_speed_median"))
        and _is_number(speed.get("share_outside"))
        and isinstance(speed.get("range"), list)
        and len(speed["range"]) == 2
        and all(_is_number(x) and x is not None for x in speed["range"])
    ):
        raise bad(
            "speed_check", speed, "a table of range, query_speed_median, share_outside, warning"
        )
    times = entry.get("modelled_time_ms")
    if times is not None:
        ok = isinstance(times, dict) and all(
            isinstance(t, dict)
            and {"low", "mid", "high"} <= set(t)
            and all(_is_number(x) and x is not None for x in t.values())
            for t in times.values()
        )
        if not ok:
            raise bad("modelled_time_ms", times, "a table of {low, mid, high} numbers")


def check_method_entry(entry: Mapping[str, Any], name: str, path: str | Path) -> None:
    """Refuse (``DataError``, naming ``path`` and the field) a method's entry of a
    ``results.json`` where a field a table or report reads, if there, lacks the type
    ppaloc writes (a sweep's cell: its fields go into the sweep's summary)."""
    _check_fields(entry, name, Path(path), complete=False)


def upgrade_summary(summary: dict[str, Any], path: str | Path = "results.json") -> dict[str, Any]:
    """A ``results.json`` summary in the current format (:data:`RESULTS_FORMAT`).

    A summary of an older format comes back as a new dict whose method entries carry
    today's names (format 1: ``accuracy`` -> ``precision_at_100r``); the given one is not
    changed. A current summary is returned as it is.

    Raises
    ------
    DataError
        If ``format`` is not a known version (one written by a newer ppaloc, or edited).

    Examples
    --------
    >>> old = {"methods": {"m": {"f1_max": 0.5, "accuracy": 0.75}}}
    >>> new = upgrade_summary(old)
    >>> new["format"], new["methods"]["m"], old["methods"]["m"]["accuracy"]
    (2, {'f1_max': 0.5, 'precision_at_100r': 0.75}, 0.75)
    """
    version = summary.get("format", 1)
    if version == RESULTS_FORMAT:
        return summary
    if not isinstance(version, int) or isinstance(version, bool) or version not in _RENAMED:
        newer = isinstance(version, int) and not isinstance(version, bool) and version > 0
        raise DataError(
            f"{path} is in results format {version!r:.40}, "
            + (
                f"newer than this ppaloc {__version__} reads (1 to {RESULTS_FORMAT}); "
                "read it with the ppaloc that wrote it, or run `ppaloc evaluate` again"
                if newer
                else f"not one ppaloc writes (1 to {RESULTS_FORMAT}); give a folder written "
                "by `ppaloc evaluate --out`"
            )
        )
    out = {**summary, "format": RESULTS_FORMAT}
    methods = summary.get("methods")
    if isinstance(methods, dict):
        out["methods"] = {k: dict(v) if isinstance(v, dict) else v for k, v in methods.items()}
        for old in range(version, RESULTS_FORMAT):
            for entry in out["methods"].values():
                if not isinstance(entry, dict):
                    continue
                for before, after in _RENAMED.get(old, {}).items():
                    if before in entry and after not in entry:
                        entry[after] = entry.pop(before)
    return out


def _load_difference(
    folder: Path, summary: Mapping[str, Any], n_queries: int, n_ref: int
) -> DifferenceMatrix | None:
    """The difference matrix a folder records (None when it has none: format 1)."""
    entry = summary.get("difference")
    if entry is None:
        return None
    path = folder / "results.json"
    if not isinstance(entry, dict) or not isinstance(entry.get("measure", ""), str):
        raise DataError(
            f"{path}: difference is {entry!r:.60}, expected a table with arrays and measure; "
            f"{_again(folder)}"
        )
    d_path = _inner(folder, entry.get("arrays", _DIFFERENCE_FILE), "difference.arrays")
    d = _read_npz(d_path, _DIFFERENCE, folder)
    q_index, r_index, values = d["query_index"], d["reference_index"], d["difference"]
    _check_array(
        q_index, f"{d_path}: query_index", length=len(q_index), bounds=(0, max(n_queries, 1))
    )
    _check_array(
        r_index, f"{d_path}: reference_index", length=len(r_index), bounds=(0, n_ref or 2**62)
    )
    for name, index in (("query_index", q_index), ("reference_index", r_index)):
        if np.any(np.diff(index) <= 0):
            raise DataError(f"{d_path}: {name} is not increasing; {_again(folder)}")
    _check_array(values, f"{d_path}: difference", length=len(q_index), ndim=2)
    if values.shape[1] != len(r_index):
        raise DataError(
            f"{d_path}: difference has {values.shape[1]} columns for {len(r_index)} "
            f"reference frames; {_again(folder)}"
        )
    return DifferenceMatrix(
        values.astype(np.float32, copy=False),
        q_index.astype(np.int64, copy=False),
        r_index.astype(np.int64, copy=False),
        entry.get("measure", ""),
    )


def _read_summary(folder: Path) -> dict[str, Any]:
    """The table ``folder/results.json`` holds, as written (strict JSON, a table).

    Raises
    ------
    DataError
        If the file is missing, unreadable, not JSON, nested too deep or not a table.
    """
    path = folder / "results.json"
    if not path.is_file():
        raise DataError(
            f"{folder} holds no results.json; give a folder written by `ppaloc evaluate --out`"
        )
    try:
        summary = json.loads(path.read_text(encoding="utf-8"), parse_constant=_not_strict_json)
    except RecursionError:
        raise DataError(f"cannot read the results in {folder}: {path} is nested too deep") from None
    except (OSError, ValueError) as exc:
        raise DataError(f"cannot read the results in {folder}: {exc}") from None
    if not isinstance(summary, dict):
        raise DataError(f"{path} is not a results table; give a folder written by ppaloc")
    return summary


def load_results(folder: str | Path) -> tuple[RunResult, dict[str, Any]]:
    """Read a results folder written by :func:`save_results`.

    Metrics are recomputed from the per-query arrays (so a report never depends on
    anything but the files). Every file ``results.json`` lists must match its checksum,
    every array its expected shape, and every stored index must point into what it
    indexes.

    Returns
    -------
    RunResult
        With every method's arrays and metrics.
    dict
        The raw ``results.json``.

    Raises
    ------
    DataError
        If the folder or one of its files is missing, unreadable, not whole (files of two
        runs), or holds an array or index out of range; the message names the file and
        the field.
    """
    folder = Path(folder)
    if not folder.exists():
        recover_folder(folder)  # a transaction killed between its two renames
    path = folder / "results.json"
    summary = upgrade_summary(_read_summary(folder), path)
    missing = [k for k in ("dataset", "tolerance", "methods") if k not in summary]
    if missing:
        raise DataError(
            f"{path} has no {missing[0]!r} entry; give a folder written by `ppaloc evaluate --out`"
        )
    if not isinstance(summary["methods"], dict) or not all(
        isinstance(v, dict) for v in summary["methods"].values()
    ):
        raise DataError(f"{path}: 'methods' is not a table of methods; {_again(folder)}")
    if not summary["methods"]:
        raise DataError(f"{path}: 'methods' is empty; {_again(folder)}")
    for name, entry in summary["methods"].items():
        _check_fields(entry, name, path)
    protocol = summary["protocol"] if isinstance(summary.get("protocol"), dict) else {}
    truth = protocol.get("ground_truth")
    if truth is not None and not isinstance(truth, dict):  # the report reads its tolerance
        raise DataError(
            f"{path}: protocol.ground_truth is {truth!r:.40}, expected a table; {_again(folder)}"
        )
    if "files" in summary:
        _check_whole(folder, summary["files"])
    tolerance = _count(summary, "tolerance", path)
    n_ref = _count(summary, "n_reference", path, 0)
    ds_path = folder / "arrays" / "_dataset.npz"
    ds = _read_npz(ds_path, ("gt_indptr", "gt_indices"), folder)
    indptr, indices = ds["gt_indptr"], ds["gt_indices"]
    if indptr.ndim != 1 or len(indptr) < 1 or indptr.dtype.kind not in "iu":
        raise DataError(f"{ds_path}: gt_indptr has shape {indptr.shape}, expected (M + 1,)")
    n_queries = len(indptr) - 1
    _check_csr(indptr, indices, f"{ds_path}: gt", n_ref, folder)
    if _count(summary, "n_queries", path, n_queries) != n_queries:
        raise DataError(
            f"{folder} is not whole: results.json has {summary['n_queries']} queries, "
            f"{ds_path.name} {n_queries}; {_again(folder)}"
        )
    per_query = ("query_positions", "query_moved", "query_turning")
    for key, value in ds.items():
        if key in per_query:
            _check_array(value, f"{ds_path}: {key}", length=n_queries, ndim=value.ndim or 1)
        elif key in ("reference_positions", "reference_turning") and n_ref:
            _check_array(value, f"{ds_path}: {key}", length=n_ref, ndim=value.ndim or 1)
    gt = PackedSets(indices, indptr, _soft_sets(ds, ds_path, n_queries, n_ref, folder))
    runs: dict[str, MethodRun] = {}
    for name, s in summary["methods"].items():
        a_path = _inner(folder, s.get("arrays", array_file(name)), f"{name}.arrays")
        a = _read_npz(a_path, _ARRAYS, folder)
        n_nodes = _count(s, "n_nodes", path, 0)
        where = f"{a_path}:"
        for key in ("score", "moved", "latency_ms", "modelled_latency_ms", "energy_mj"):
            if key in a:
                _check_array(a[key], f"{where} {key}", length=n_queries)
        _check_array(a["node"], f"{where} node", length=n_queries, bounds=(0, n_nodes or 2**62))
        if n_ref:
            _check_array(a["ref_index"], f"{where} ref_index", length=n_queries, bounds=(0, n_ref))
            _check_array(
                a["ranking"], f"{where} ranking", length=n_queries, ndim=2, bounds=(-1, n_ref)
            )
        else:
            _check_array(a["ref_index"], f"{where} ref_index", length=n_queries)
            _check_array(a["ranking"], f"{where} ranking", length=n_queries, ndim=2)
        if "weights" in a:
            _check_array(a["weights"], f"{where} weights", length=n_queries, ndim=2)
            if n_nodes and a["weights"].shape[1] != n_nodes:
                raise DataError(
                    f"{where} weights has {a['weights'].shape[1]} columns for {n_nodes} nodes"
                )
        frame_index = a.get("frame_index")
        if frame_index is not None:
            _check_array(
                frame_index,
                f"{where} frame_index",
                length=n_nodes or len(frame_index),
                bounds=(0, n_ref or 2**62),
            )
        registers = None
        if s.get("registers"):
            reg_path = _inner(folder, s["registers"], f"{name}.registers")
            planes = _read_npz(reg_path, ("labels",), folder)
            labels = [str(x) for x in np.ravel(planes["labels"])]
            _require(planes, [f"plane{i}" for i in range(len(labels))], reg_path)
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
            n_nodes=n_nodes,
            build_s=None if s.get("build_s") is None else float(s["build_s"]),
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
            reads_future=bool(s.get("reads_future", False)),
            speed_check=s.get("speed_check"),
            frame_index=frame_index,
        )
    result = RunResult(
        dataset=summary["dataset"],
        dataset_name=summary.get("dataset_name", summary["dataset"]),
        tolerance=tolerance,
        ground_truth=gt,
        n_reference=n_ref,
        runs=runs,
        config=summary.get("config", {}),
        reference_positions=ds.get("reference_positions"),
        query_positions=ds.get("query_positions"),
        query_moved=ds.get("query_moved"),
        query_turning=_bools(ds.get("query_turning")),
        reference_turning=_bools(ds.get("reference_turning")),
        protocol=protocol,
        difference=_load_difference(folder, summary, n_queries, n_ref),
        ppaloc_version=summary.get("ppaloc_version", ""),
        created=summary.get("created", ""),
        roles=_roles(summary, path),
    )
    return result, summary


def _roles(summary: Mapping[str, Any], path: Path) -> dict[str, str] | None:
    """``results.json``'s roles: absent or null (older folders), or two strings."""
    roles = summary.get("roles")
    if roles is None:
        return None
    if (
        not isinstance(roles, dict)
        or set(roles) != set(ROLE_COLUMNS)
        or not all(isinstance(v, str) for v in roles.values())
    ):
        raise DataError(
            f'{path}: \'roles\' is {roles!r:.60}, expected {{"database": text, "query": '
            "text}; give a folder written by `ppaloc evaluate --out` (or run it again)"
        )
    return dict(roles)


def _soft_sets(
    ds: Mapping[str, np.ndarray], ds_path: Path, n_queries: int, n_ref: int, folder: Path
) -> PackedSets | None:
    """The soft ground truth of ``_dataset.npz``, checked like the hard one (None if none)."""
    if "gt_soft_indptr" not in ds and "gt_soft_indices" not in ds:
        return None
    _require(ds, ("gt_soft_indptr", "gt_soft_indices"), ds_path)
    indptr, indices = ds["gt_soft_indptr"], ds["gt_soft_indices"]
    if indptr.ndim != 1 or len(indptr) != n_queries + 1 or indptr.dtype.kind not in "iu":
        raise DataError(
            f"{ds_path}: gt_soft_indptr has shape {indptr.shape}, expected ({n_queries + 1},)"
        )
    _check_csr(indptr, indices, f"{ds_path}: gt_soft", n_ref, folder)
    return PackedSets(indices, indptr)


def _check_csr(
    indptr: np.ndarray, indices: np.ndarray, where: str, n_ref: int, folder: Path
) -> None:
    """``where``'s ``_indices`` are reference indices (within ``n_ref`` where known) and
    its ``_indptr`` a CSR index over them: the hard and the soft ground truth alike."""
    _check_array(indices, f"{where}_indices", length=len(indices))
    if indptr[0] != 0 or np.any(np.diff(indptr) < 0) or indptr[-1] != len(indices):
        raise DataError(
            f"{where}_indptr is not a CSR index (0 first, non-decreasing, "
            f"{len(indices)} last); {_again(folder)}"
        )
    if n_ref:
        _check_array(indices, f"{where}_indices", length=len(indices), bounds=(0, n_ref))
