"""Score predictions read from a file: any method's output, measured as ``ppaloc evaluate``
measures a method it runs.

A predictions file is a CSV with a header line; each row is one query's prediction
(docs/evaluate-cli.md, "Predictions files", is the reference):

=========================  ===========================================================
column                     meaning
=========================  ===========================================================
``query``                  0-based index of the query frame in the dataset's query
                           traversal (after its ``start``/``stop``/``step``)
``query_name``             or the query frame's name: its file name (``img-12.png``,
                           any folder before it ignored) or ``VIDEO#INDEX``
``reference``              0-based index of the predicted reference frame
``reference_name``         or its name, as for queries
``score``                  confidence, a finite number, higher = surer
``method`` (optional)      a label: rows of several methods in one file
``reference_2`` ..         (optional) the next best reference frames, best first,
``reference_K``            indices (or ``reference_name_2`` .. names); empty cells pad
``latency_ms`` (optional)  time per query in milliseconds (empty: not measured)
``moved`` (optional)       the method's motion decision: 1, 0, or empty
=========================  ===========================================================

``ppaloc localise``'s CSV is read as it is: ``frame`` is ``query``, ``path`` is
``query_name``, ``reference_frame`` is ``reference``, and its ``node`` is ignored. Where a
row gives both an index and a name, the name is used when the dataset's frames have names
(image files, videos), the index otherwise.

Every file is read and checked (columns, numbers, NaN, size) before the dataset is
loaded, and every row is matched to the dataset (indices in range, names known, one row
per query, no query missing) before anything is measured; each problem is one line
naming the file, the line and the fix. The predictions then become a :class:`MethodRun`
per method (``node`` and ``ref_index`` both the predicted reference frame, one "node"
per reference frame) and a :class:`RunResult`, written and reported by the same code as
a run of ``ppaloc evaluate``.
"""

from __future__ import annotations

import csv
import io
import math
import os
import re
import stat
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.datasets import RouteDataset
from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.errors import DataError, PpalocError
from ppaloc.evaluate.config import (
    check_limits,
    check_spec_text,
    check_tolerance,
    with_tolerance,
)
from ppaloc.evaluate.run import MethodRun, RunResult, method_metrics, scoring_protocol

__all__ = [
    "MAX_LATENCY_MS",
    "MAX_PREDICTIONS_BYTES",
    "MAX_RANK",
    "PREDICTION_FROM_FILE",
    "Predictions",
    "ScoreConfig",
    "match_predictions",
    "read_predictions",
    "score_predictions",
]

MAX_PREDICTIONS_BYTES = 256 << 20
"""Largest predictions file read (256 MiB: about five million rows of a localise CSV)."""

MAX_RANK = 100
"""Deepest ranking a file may give (``reference_2`` .. ``reference_100``)."""

MAX_LATENCY_MS = 86_400_000.0
"""Longest time per query a file may give: a day, in milliseconds (more is a unit mistake,
and the sums of the report's statistics would overflow)."""

MAX_LABEL = 64
"""Longest method label, in characters."""

PREDICTION_FROM_FILE = (
    "one reference frame per query, as the predictions file gives it (ppaloc score); it "
    "never depends on the ground truth"
)
"""How a file's prediction becomes a reference frame (results.json's ``protocol``)."""

_ALIASES = {"frame": "query", "path": "query_name", "reference_frame": "reference"}
"""``ppaloc localise``'s columns and what they are."""
_IGNORED = frozenset({"node"})
"""Columns read and not used (localise's map node: the reference frame is its own column)."""
_SCALARS = ("query", "query_name", "reference", "reference_name", "score", "method")
_OPTIONAL = ("latency_ms", "moved")
_RANKED = re.compile(r"reference(_name)?_(0|[1-9][0-9]{0,5})")  # reference_02 is not rank 2
_INDEX = re.compile(r"\s*\+?[0-9]{1,19}\s*")
_MAX_INDEX = (1 << 63) - 1
"""Largest frame index read (a 64-bit integer's: 19 digits go beyond it)."""


def _is_index(text: str) -> bool:
    """Whether ``text`` is a 0-based frame index: a whole number a 64-bit integer holds
    (``9999999999999999999`` was read and ended ``ppaloc show`` in an internal error)."""
    return _INDEX.fullmatch(text) is not None and int(text) <= _MAX_INDEX


#: A byte that is not UTF-8, as ``surrogateescape`` decodes it (a frame's own file name,
#: which ``ppaloc localise`` writes back as its bytes).
_RAW_BYTE = re.compile("[\udc80-\udcff]")
_DOCS = "see docs/evaluate-cli.md, Predictions files"


@dataclass(frozen=True)
class ScoreConfig:
    """What ``ppaloc score`` measures.

    Parameters
    ----------
    dataset : str
        Dataset spec whose queries were predicted.
    predictions : tuple of str
        Predictions files (CSV), one or more.
    tolerance : int, optional
        Accepted distance to the true reference frame, in frames (None: the spec's, else
        the dataset kind's default; a spec with another ``tolerance=`` is refused).
    recall : {"A", "B", "C"}
        Recall definition.
    """

    dataset: str
    predictions: tuple[str, ...]
    tolerance: int | None = None
    recall: str = "A"

    def __post_init__(self) -> None:
        object.__setattr__(self, "predictions", tuple(str(p) for p in self.predictions))
        if not self.predictions:
            raise PpalocError("no predictions file: give one or more CSV files to score")
        check_limits({"tolerance": self.tolerance})
        check_spec_text(self.dataset)
        check_tolerance(self.dataset, self.tolerance)
        if str(self.recall).upper() not in ("A", "B", "C"):
            raise PpalocError(f"recall={self.recall!r} must be one of A, B, C")
        object.__setattr__(self, "recall", str(self.recall).upper())

    def resolved_dataset(self) -> str:
        """The dataset spec with ``tolerance`` applied."""
        if self.tolerance is None:
            return self.dataset
        return with_tolerance(self.dataset, self.tolerance)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (for result files)."""
        return {
            "command": "score",
            "dataset": self.dataset,
            "predictions": list(self.predictions),
            "tolerance": self.tolerance,
            "recall": self.recall,
        }


@dataclass(eq=False)
class Predictions:
    """One method's rows of a predictions file, read and checked for syntax, not yet
    matched to a dataset.

    Attributes
    ----------
    label : str
        The method's label (its ``method`` column, else the file's stem).
    source : Path
        The file.
    lines : ndarray of int, shape (R,)
        The file line of each row (the header is line 1), for messages.
    queries : dict of str to list of str
        ``"query"`` and/or ``"query_name"``: each row's text.
    references : list of dict of str to list of str
        Rank by rank (rank 1 first): ``"reference"`` and/or ``"reference_name"`` texts
        (an empty text pads a rank below 1).
    score : ndarray of float, shape (R,)
    latency_ms : ndarray of float, shape (R,)
        NaN where not given.
    moved : ndarray of int8, shape (R,)
        1, 0, or -1 where not given.
    """

    label: str
    source: Path
    lines: np.ndarray
    queries: dict[str, list[str]]
    references: list[dict[str, list[str]]]
    score: np.ndarray
    latency_ms: np.ndarray
    moved: np.ndarray

    def __len__(self) -> int:
        return len(self.lines)


# -- reading -------------------------------------------------------------------------------


def _show(text: str, limit: int = 40) -> str:
    """``repr(text)`` cut to about ``limit`` characters (a message never echoes a huge field)."""
    shown = repr(text)
    return shown if len(shown) <= limit else f"{shown[: limit - 4]}...'"


def _raw_bytes(path: Path, max_bytes: int) -> bytes:
    """The file's bytes: a regular file (checked before opening: a FIFO would block) of at
    most ``max_bytes``."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        raise DataError(f"predictions file {path} does not exist; check the path") from None
    except OSError as exc:
        raise DataError(f"cannot read predictions file {path} ({exc.strerror or exc})") from None
    if stat.S_ISDIR(info.st_mode):
        raise DataError(f"predictions file {path} is a folder; give a CSV file")
    if not stat.S_ISREG(info.st_mode):
        raise DataError(
            f"predictions file {path} is not a regular file (a pipe, device or socket); save "
            "the predictions to a file and give that"
        )
    if info.st_size > max_bytes:
        raise DataError(
            f"predictions file {path} is {info.st_size} bytes, more than {max_bytes} "
            f"({max_bytes >> 20} MiB); split it by method into several files"
        )
    try:
        with open(path, "rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as exc:
        raise DataError(f"cannot read predictions file {path} ({exc.strerror or exc})") from None
    if len(raw) > max_bytes:
        raise DataError(f"predictions file {path} grew beyond {max_bytes} bytes while read")
    return raw


def _header(path: Path, row: list[str], at: int = 1) -> dict[str, int]:
    """Column name (localise's names read as the general ones) -> position; every name
    known, none twice, the needed ones present."""
    columns: dict[str, int] = {}
    given: dict[str, str] = {}
    names = {raw.strip().lower() for raw in row}
    if "f1_max" in names and "score" not in names:  # a table the commands write
        folder = path.parent
        written = any((folder / n).is_file() for n in ("results.json", "summary.json"))
        show = (
            f"ppaloc show {folder} shows its folder"
            if written or path.name == "matrix.csv"
            else "ppaloc show shows the folder the run wrote it in"
        )  # a copy elsewhere: its folder holds no run to show
        raise DataError(
            f"{path} is a table of results (f1_max per method: results.csv or matrix.csv "
            "of ppaloc evaluate, summary.csv of ppaloc sweep), not predictions (one row per "
            f"query: query, reference, score); {show}"
        )
    for i, raw in enumerate(row):
        name = raw.strip().lower()
        if not name:
            raise DataError(
                f"{path} line {at}: column {i + 1} has no name; name every column ({_DOCS})"
            )
        key = _ALIASES.get(name, name)
        ranked = _RANKED.fullmatch(key)
        known = key in _SCALARS or key in _OPTIONAL or key in _IGNORED
        if ranked and not 2 <= int(ranked.group(2)) <= MAX_RANK:
            raise DataError(
                f"{path} line {at}: column {name!r} ranks beyond 2..{MAX_RANK}; rank 1 is the "
                f"reference column, the next best are reference_2 .. reference_{MAX_RANK}"
            )
        if not known and not ranked:
            valid = "query, query_name, reference, reference_name, score, method, "
            valid += "reference_2.., reference_name_2.., latency_ms, moved"
            raise DataError(
                f"{path} line {at}: unknown column {_show(raw)}; the columns are {valid} "
                f"(and localise's frame, path, node, reference_frame; {_DOCS})"
            )
        if key in columns:
            raise DataError(
                f"{path} line {at}: columns {given[key]!r} and {name!r} both give the {key}; "
                "keep one of them"
            )
        columns[key], given[key] = i, name
    if "score" not in columns:
        raise DataError(
            f"{path} has no score column (its columns: {', '.join(given.values())}); add "
            "score, the confidence of each prediction, higher = surer"
        )
    if "query" not in columns and "query_name" not in columns:
        raise DataError(
            f"{path} names no query: add a query column (the 0-based query index) or "
            "query_name (the query frame's file name)"
        )
    if "reference" not in columns and "reference_name" not in columns:
        raise DataError(
            f"{path} names no predicted reference: add a reference column (the 0-based "
            "reference index) or reference_name (the reference frame's file name)"
        )
    ranks = sorted({int(m.group(2)) for c in columns if (m := _RANKED.fullmatch(c))})
    if ranks and ranks != list(range(2, len(ranks) + 2)):
        missing = next(k for k in range(2, ranks[-1] + 1) if k not in ranks)
        raise DataError(
            f"{path} line {at}: reference ranks jump from {missing - 1} to {ranks[-1]}; give "
            f"reference_{missing} (every rank from 2 up to the deepest)"
        )
    return columns


def _number(path: Path, line: int, column: str, text: str, fix: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise DataError(
            f"{path} line {line}: {column} {_show(text)} is not a number; {fix}"
        ) from None
    if not math.isfinite(value):
        raise DataError(f"{path} line {line}: {column} is {text.strip()}; {fix}")
    return value


def _label(path: Path, line: int, text: str, from_file: bool) -> str:
    """A method label: 1 to :data:`MAX_LABEL` printable characters, not starting with
    ``_`` or ``.`` (the result folder's own files start so)."""
    label = text.strip()
    ok = (
        0 < len(label) <= MAX_LABEL
        and label.isprintable()
        and label[0] not in "_."
        and not label.endswith(".registers")
    )
    if ok:
        return label
    where = (
        f"{path}: the file name gives method label {_show(label)}"
        if from_file
        else f"{path} line {line}: method {_show(label)}"
    )
    fix = "add a method column" if from_file else "give a label"
    raise DataError(
        f"{where}, which is not a label of 1 to {MAX_LABEL} printable characters not "
        f"starting with _ or .; {fix} such as netvlad"
    )


def read_predictions(
    path: str | os.PathLike[str], *, max_bytes: int | None = None
) -> list[Predictions]:
    """Read one predictions file and check its syntax; no dataset is needed.

    Parameters
    ----------
    path : str or Path
        A CSV file (UTF-8, a header line; see the module docstring for the columns).
    max_bytes : int, optional
        Largest file read (default :data:`MAX_PREDICTIONS_BYTES`).

    Returns
    -------
    list of Predictions
        One per method label, in the order the labels first appear.

    Raises
    ------
    DataError
        One line naming the file, the line and the fix: not a regular file, too large,
        not UTF-8, no header, an unknown or missing column, a row with the wrong number
        of fields, an index that is not a whole number, a score that is not a finite
        number, an empty prediction.

    Examples
    --------
    >>> import tempfile
    >>> f = Path(tempfile.mkdtemp()) / "netvlad.csv"
    >>> _ = f.write_text("query,reference,score\\n0,0,0.9\\n1,3,0.2\\n")
    >>> (p,) = read_predictions(f)
    >>> p.label, p.queries["query"], p.references[0]["reference"], p.score.tolist()
    ('netvlad', ['0', '1'], ['0', '3'], [0.9, 0.2])
    """
    path = Path(path)
    raw = _raw_bytes(path, MAX_PREDICTIONS_BYTES if max_bytes is None else max_bytes)
    try:
        text, raw_bytes = raw.decode("utf-8-sig"), False
    except UnicodeDecodeError:
        # a frame's file name that is not UTF-8 is its own bytes (as ppaloc localise writes
        # it, and as the dataset's folder listing reads it); every other field is checked
        # to be UTF-8 text (_check_text)
        text, raw_bytes = raw.decode("utf-8-sig", "surrogateescape"), True
    del raw
    reader = csv.reader(io.StringIO(text, newline=""))
    try:
        header = next(reader, None)
        while header is not None and not any(c.strip() for c in header):
            header = next(reader, None)  # blank lines before the header
        if header is None:
            raise DataError(
                f"{path} is empty; give a CSV whose first line names its columns, e.g. "
                "query,reference,score"
            )
        if raw_bytes:
            _check_text(path, reader.line_num, header, "the header")
        columns = _header(path, header, reader.line_num)
        return _read_rows(path, reader, columns, len(header), raw_bytes)
    except csv.Error as exc:
        raise DataError(
            f"{path} line {reader.line_num}: not CSV ({exc}); write one row per line, "
            "fields separated by commas"
        ) from None


def _read_rows(
    path: Path, reader: Any, columns: dict[str, int], width: int, raw_bytes: bool
) -> list[Predictions]:
    """Every row's prediction, grouped by method label; ``raw_bytes``: the file holds
    bytes that are not UTF-8, allowed in file names only."""
    query_cols = [c for c in ("query", "query_name") if c in columns]
    deepest = max([1] + [int(m.group(2)) for c in columns if (m := _RANKED.fullmatch(c))])
    rank_cols: list[list[tuple[str, int]]] = []
    for k in range(1, deepest + 1):
        suffix = "" if k == 1 else f"_{k}"
        rank_cols.append(
            [
                (f"reference{n}", columns[f"reference{n}{suffix}"])
                for n in ("", "_name")
                if f"reference{n}{suffix}" in columns
            ]
        )
    names = {i: c for c, i in columns.items()}
    text_cols = [i for c, i in columns.items() if raw_bytes and not _is_name_column(c)]
    groups: dict[str, dict[str, Any]] = {}
    stem_label = None if "method" in columns else _label(path, 1, path.stem, True)
    for row in reader:
        line = reader.line_num
        if not any(c.strip() for c in row):
            continue  # a blank line
        if len(row) != width:
            raise DataError(
                f"{path} line {line} has {len(row)} fields for the header's {width} columns; "
                "give every row one field per column (an empty field where there is no value)"
            )
        cells = [c.strip() for c in row]
        for i in text_cols:
            _check_text(path, line, [cells[i]], f"the {names[i]} field")
        label = stem_label or _label(path, line, cells[columns["method"]], False)
        g = groups.get(label)
        if g is None:
            g = groups[label] = {
                "lines": [],
                "queries": {c: [] for c in query_cols},
                "refs": [{name: [] for name, _ in cols} for cols in rank_cols],
                "score": [],
                "latency": [],
                "moved": [],
            }
        for c in query_cols:
            value = cells[columns[c]]
            if c == "query" and not _is_index(value) and not (value == "" and len(query_cols) > 1):
                raise DataError(
                    f"{path} line {line}: query {_show(value)} is not a query index; give the "
                    "0-based index of the query frame (a whole number >= 0)"
                )
            g["queries"][c].append(value)
        for k, cols in enumerate(rank_cols, 1):
            given = False
            for name, i in cols:
                value = cells[i]
                column = name if k == 1 else f"{name}_{k}"
                if name == "reference" and value and not _is_index(value):
                    raise DataError(
                        f"{path} line {line}: {column} {_show(value)} is not a reference "
                        "index; give the 0-based index of the reference frame (a whole "
                        "number >= 0)"
                    )
                given = given or bool(value)
                g["refs"][k - 1][name].append(value)
            if k == 1 and not given:
                raise DataError(
                    f"{path} line {line}: no predicted reference; give the reference frame "
                    "this query is matched to (every query needs one)"
                )
        g["score"].append(
            _number(
                path,
                line,
                "score",
                cells[columns["score"]],
                "give every query a finite confidence, higher = surer (a query the method "
                "could not place: its lowest score)",
            )
        )
        g["latency"].append(_latency(path, line, cells, columns))
        g["moved"].append(_moved(path, line, cells, columns))
        g["lines"].append(line)
    if not groups:
        raise DataError(f"{path} has a header but no rows; give one row per query")
    return [
        Predictions(
            label=label,
            source=path,
            lines=np.asarray(g["lines"], dtype=np.int64),
            queries=g["queries"],
            references=g["refs"],
            score=np.asarray(g["score"], dtype=np.float64),
            latency_ms=np.asarray(g["latency"], dtype=np.float64),
            moved=np.asarray(g["moved"], dtype=np.int8),
        )
        for label, g in groups.items()
    ]


def _is_name_column(column: str) -> bool:
    """Whether ``column`` holds frames' file names (``query_name``, ``reference_name``,
    ``reference_name_K``): the one kind of field whose bytes need not be UTF-8."""
    return column == "query_name" or column.startswith("reference_name")


def _check_text(path: Path, line: int, cells: list[str], what: str) -> None:
    """Refuse ``cells`` holding a byte that is not UTF-8 (only file names may)."""
    if any(_RAW_BYTE.search(c) for c in cells):
        raise DataError(
            f"{path} line {line}: {what} is not UTF-8 text; save the file as UTF-8 text "
            "(only the frames' file names, query_name and reference_name, may hold other "
            "bytes)"
        )


def _latency(path: Path, line: int, cells: list[str], columns: Mapping[str, int]) -> float:
    if "latency_ms" not in columns or not cells[columns["latency_ms"]]:
        return math.nan
    value = _number(
        path,
        line,
        "latency_ms",
        cells[columns["latency_ms"]],
        "give the time per query in milliseconds (>= 0), or leave the field empty",
    )
    if value < 0:
        raise DataError(
            f"{path} line {line}: latency_ms is {value:g}; a time is >= 0 (or leave it empty)"
        )
    if value > MAX_LATENCY_MS:
        raise DataError(
            f"{path} line {line}: latency_ms is {value:g}, more than a day per query "
            f"(at most {MAX_LATENCY_MS:.0f}); give the time in milliseconds"
        )
    return value


_MOVED = {"1": 1, "0": 0, "true": 1, "false": 0, "": -1}


def _moved(path: Path, line: int, cells: list[str], columns: Mapping[str, int]) -> int:
    if "moved" not in columns:
        return -1
    text = cells[columns["moved"]].lower()
    if text not in _MOVED:
        raise DataError(
            f"{path} line {line}: moved {_show(text)} is not 1, 0 or empty; give the method's "
            "motion decision (1 forward, 0 stay) or leave it empty"
        )
    return _MOVED[text]


# -- matching to a dataset --------------------------------------------------------------------


class _Names:
    """A traversal's frame names -> index, matched on the last path component."""

    def __init__(self, names: Sequence[str] | None, what: str) -> None:
        self.names, self.what = names, what
        self.index: dict[str, int] = {}
        self.twice: dict[str, int] = {}
        for i, name in enumerate(names or ()):
            if name in self.index:
                self.twice[name] = i
            else:
                self.index[name] = i

    def find(self, value: str, path: Path, line: int, column: str, dataset: str) -> int:
        key = re.split(r"[/\\]", value)[-1]
        i = self.index.get(key)
        if i is None:
            assert self.names
            raise DataError(
                f"{path} line {line}: {column} {_show(value)} is not a {self.what} frame of "
                f"{dataset} (its {len(self.names)} frames are named {_show(self.names[0])} .. "
                f"{_show(self.names[-1])}); give a name from the {self.what} traversal, or "
                f"{self.what} indices"
            )
        if key in self.twice:
            raise DataError(
                f"{path} line {line}: {column} {_show(value)} names {self.what} frames {i} "
                f"and {self.twice[key]} of {dataset}; give {self.what} indices instead"
            )
        return i


def _use_names(column: list[str] | None, names: _Names) -> bool:
    """A name column is used when the traversal has names and the column is not empty."""
    return column is not None and names.names is not None and any(column)


def _indices(
    p: Predictions,
    texts: dict[str, list[str]],
    names: _Names,
    n: int,
    rank: int,
    dataset: str,
) -> np.ndarray:
    """One column's frames as indices into a traversal of ``n`` frames (-1 where a rank
    below 1 is empty)."""
    what = names.what
    suffix = "" if rank == 1 else f"_{rank}"
    by_name = _use_names(texts.get(f"{what}_name"), names)
    column = f"{what}_name" if by_name else what
    if column not in texts and names.names is not None:  # only a name column, all empty
        raise DataError(
            f"{p.source}: {what}_name{suffix} is empty on every row; give each row its "
            f"{what} frame's name, or {what} indices ({what}{suffix} column)"
        )
    if column not in texts:  # a name column on a traversal without names
        raise DataError(
            f"{p.source}: {what}_name needs frame names, and the {what} frames of {dataset} "
            f"have none (rendered frames); give {what} indices ({what}{suffix} column)"
        )
    values = texts[column]
    out = np.full(len(values), -1, dtype=np.int64)
    for r, value in enumerate(values):
        if not value:
            if rank == 1:
                raise DataError(
                    f"{p.source} line {p.lines[r]}: {column}{suffix} is empty; give every "
                    f"query its {what} frame"
                )
            continue
        line = int(p.lines[r])
        if by_name:
            out[r] = names.find(value, p.source, line, column + suffix, dataset)
            continue
        i = int(value)
        if i >= n:
            raise DataError(
                f"{p.source} line {line}: {column}{suffix} {i} is outside the {n} {what} "
                f"frames of {dataset} (0..{n - 1}); indices are 0-based over the {what} "
                "traversal after its start/stop/step"
            )
        out[r] = i
    return out


@dataclass(frozen=True)
class _Matched:
    """One method's predictions as arrays over the dataset's queries."""

    label: str
    source: Path
    ref_index: np.ndarray
    score: np.ndarray
    ranking: np.ndarray
    latency_ms: np.ndarray
    moved: np.ndarray


def match_predictions(
    predictions: Sequence[Predictions], dataset: RouteDataset, *, spec: str = ""
) -> list[_Matched]:
    """Match every row to the dataset and order it by query.

    Raises
    ------
    DataError
        One line naming the file, the line and the fix: a query or reference index out of
        range, a name the traversal does not have, a query given twice, a query missing,
        two labels of one method.
    """
    where = _show(spec or dataset.name, 80)
    m, n = len(dataset.query), len(dataset.reference)
    q_names = _Names(dataset.query.names() if hasattr(dataset.query, "names") else None, "query")
    r_names = _Names(
        dataset.reference.names() if hasattr(dataset.reference, "names") else None, "reference"
    )
    out: list[_Matched] = []
    seen: dict[str, Path] = {}
    files: dict[str, str] = {}
    from ppaloc.evaluate.results import array_file

    for p in predictions:
        if p.label in seen:
            raise DataError(
                f"method {p.label!r} is given by {seen[p.label]} and {p.source}; give each "
                "method one label (a method column, or rename a file)"
            )
        seen[p.label] = p.source
        rel = array_file(p.label)
        if rel in files:
            raise DataError(
                f"methods {files[rel]!r} and {p.label!r} of {p.source} would share the result "
                f"file {rel}; give them labels that differ in a letter or digit"
            )
        files[rel] = p.label
        rows = _indices(p, p.queries, q_names, m, 1, where)
        first = np.full(m, -1, dtype=np.int64)
        for r, q in enumerate(rows):
            if first[q] >= 0:
                raise DataError(
                    f"{p.source} line {p.lines[r]}: query {q} of method {p.label!r} is already "
                    f"predicted on line {p.lines[first[q]]}; give one row per query and method"
                )
            first[q] = r
        missing = np.flatnonzero(first < 0)
        if missing.size:
            q = int(missing[0])
            named = f" ({q_names.names[q]})" if q_names.names else ""
            raise DataError(
                f"{p.source}: method {p.label!r} predicts {m - missing.size} of the {m} queries "
                f"of {where}; the first missing is query {q}{named}: give one row for every "
                "query (a query the method could not place: its lowest score), or select the "
                "queries predicted with the spec's start=/stop="
            )
        ranks = [_indices(p, refs, r_names, n, k, where) for k, refs in enumerate(p.references, 1)]
        order = first  # row of each query, in query order
        ranking = np.stack(ranks, axis=1)[order] if len(ranks) > 1 else np.zeros((m, 0), np.int64)
        out.append(
            _Matched(
                label=p.label,
                source=p.source,
                ref_index=ranks[0][order],
                score=p.score[order],
                ranking=ranking,
                latency_ms=p.latency_ms[order],
                moved=p.moved[order],
            )
        )
    return out


# -- scoring --------------------------------------------------------------------------------


def score_predictions(config: ScoreConfig, *, dataset: RouteDataset | None = None) -> RunResult:
    """Measure predictions files against a dataset, as ``ppaloc evaluate`` measures a run.

    Parameters
    ----------
    config : ScoreConfig
    dataset : RouteDataset, optional
        Use this dataset instead of loading ``config.dataset`` (tests, scripts).

    Returns
    -------
    RunResult
        One :class:`MethodRun` per method label, ready for
        :func:`ppaloc.evaluate.results.write_results` and the report.

    Raises
    ------
    PpalocError
        Before anything is measured: a bad spec, a bad file, a row that does not match
        the dataset (see :func:`read_predictions` and :func:`match_predictions`).
    """
    spec = config.resolved_dataset()
    if dataset is None:
        from ppaloc.datasets.registry import parse_dataset_spec

        parse_dataset_spec(spec)  # the spec's own mistakes before the files are read
    predictions = [p for path in config.predictions for p in read_predictions(path)]
    if dataset is None:
        from ppaloc.datasets.registry import load_dataset

        dataset = load_dataset(spec)  # lazy: folders listed, no frame read
    else:
        spec = str(dataset.meta.get("spec", dataset.name))
    matched = match_predictions(predictions, dataset, spec=spec)
    gt = PackedSets.from_sets(dataset.ground_truth)
    positions_ok = dataset.reference_positions is not None and dataset.query_positions is not None
    turning = dataset.meta.get("query_turning")
    runs: dict[str, MethodRun] = {}
    for p in matched:
        metrics = method_metrics(
            p.ref_index,
            p.score,
            gt,
            p.ranking,
            recall=config.recall,
            reference_positions=dataset.reference_positions if positions_ok else None,
            query_positions=dataset.query_positions if positions_ok else None,
            turning=None if turning is None else np.asarray(turning, dtype=bool),
        )
        motion = None
        if dataset.query_moved is not None and len(p.moved) and (p.moved >= 0).all():
            truth = np.asarray(dataset.query_moved, dtype=bool)
            motion = float(np.mean((p.moved == 1) == truth))
        runs[p.label] = MethodRun(
            method=p.label,
            params={"predictions": str(p.source)},
            map_kind="",
            n_nodes=len(dataset.reference),
            build_s=None,
            node=p.ref_index,
            ref_index=p.ref_index,
            score=p.score,
            moved=p.moved,
            ranking=p.ranking,
            latency_ms=p.latency_ms,
            metrics=metrics,
            motion_accuracy=motion,
        )
    config_dict = config.to_dict()
    config_dict["dataset"] = spec
    config_dict["methods"] = list(runs)
    protocol = {**scoring_protocol(dataset), "prediction": PREDICTION_FROM_FILE}
    return RunResult(
        dataset=spec,
        dataset_name=dataset.name,
        tolerance=int(dataset.tolerance),
        ground_truth=gt,
        n_reference=len(dataset.reference),
        runs=runs,
        config=config_dict,
        reference_positions=dataset.reference_positions,
        query_positions=dataset.query_positions,
        query_moved=dataset.query_moved,
        query_turning=None if turning is None else np.asarray(turning, dtype=bool),
        reference_turning=(
            None
            if dataset.meta.get("reference_turning") is None
            else np.asarray(dataset.meta["reference_turning"], dtype=bool)
        ),
        protocol=protocol,
        created=datetime.now(UTC).isoformat(timespec="seconds"),
    )
