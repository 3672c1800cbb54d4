"""The grid of a parameter sweep: its configuration, its cells, their folders and the
summary rebuilt from them (no Dask here: :mod:`ppaloc.evaluate.sweep` runs the cells).

A sweep is described by a :class:`SweepConfig` (the ``[sweep]`` table of a TOML file).
:func:`expand` turns it into :class:`Cell` objects, datasets outermost; each cell is one
:func:`ppaloc.evaluate.run.run_evaluation` of one method with one set of parameters on
one dataset, with a stable id (the SHA-256 of :meth:`Cell.identity`) that names its folder
``OUT/cells/<method>-<id>/``. A cell is *finished* iff its ``results.json`` (the format of
``ppaloc evaluate``) exists and parses; :func:`write_summary` rebuilds ``summary.csv`` and
``summary.json`` from the cell folders alone.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import math
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc import __version__
from ppaloc.errors import DataError, PpalocError
from ppaloc.evaluate.config import (
    EvaluateConfig,
    check_spec_text,
    check_tolerance,
    reject_unknown_keys,
    with_tolerance,
)
from ppaloc.evaluate.results import (
    CSV_COLUMNS,
    ROLE_COLUMNS,
    check_method_entry,
    upgrade_summary,
    written_by_ppaloc,
)
from ppaloc.fileio import new_folder, source_date, write_bytes

__all__ = [
    "COMBINE",
    "MAX_CELLS",
    "METRIC_COLUMNS",
    "SUMMARY_VERSION",
    "SWEEP_NAMES",
    "Cell",
    "SweepConfig",
    "axes",
    "cell_status",
    "collect_summary",
    "expand",
    "grid_size",
    "one_line_error",
    "sweep_config_from_mapping",
    "sweep_wrote",
    "validate",
    "write_cell",
    "write_cell_error",
    "write_summary",
]

COMBINE = ("product", "one-at-a-time")
"""How the swept parameters of a method combine: every combination (the Cartesian
product), or each parameter varied alone with the others at their defaults."""

METRIC_COLUMNS = [c for c in CSV_COLUMNS if c != "method" and c not in ROLE_COLUMNS]
"""The metric columns of ``summary.csv``: those of ``results.csv`` after ``method``, but the
roles."""

_RESERVED = {"method", "dataset", "status", "cell", "tolerance", *METRIC_COLUMNS}
_NOT_RUN = "not run"


# -- configuration ---------------------------------------------------------------------------


def _values(value: Any) -> tuple[list[Any], bool]:
    """``(values, swept)``: a list is an axis of values, anything else one fixed value."""
    if isinstance(value, list | tuple):
        return list(value), True
    return [value], False


@dataclass(frozen=True)
class SweepConfig:
    """What ``ppaloc sweep`` runs: a grid of methods x datasets x method parameters.

    Parameters
    ----------
    methods : tuple of str
        Method names (``ppaloc.methods``), at least one.
    datasets : tuple of str
        Dataset specs (``KIND:PATH?key=value``, docs/datasets.md), at least one.
    params : dict
        ``{method: {key: value or [values]}}`` (TOML tables ``[sweep.params.METHOD]``): a
        list is swept (an axis of the grid), any other value is fixed for every cell of
        that method. A parameter whose value is itself a list is swept as a list of lists
        (``advance = [[0, 1], [0, 2]]``).
    tolerance : int or list of int, optional
        Ground-truth tolerance in frames (None: each spec's own); a list is an axis.
    seed : int or list of int
        Passed to every method that takes a ``seed``; a list is an axis.
    recall : {"A", "B", "C"}
        Recall definition of the metrics.
    record_weights : bool
        Keep each cell's per-node weights in its arrays (off by default: a sweep keeps
        metrics, and weights make the cell folders large).
    max_weight_values : int
        As in :class:`ppaloc.evaluate.EvaluateConfig`.
    combine : {"product", "one-at-a-time"}
        ``product``: every combination of a method's swept parameters. ``one-at-a-time``:
        each swept parameter alone, the others at their defaults (a sensitivity table).
    """

    methods: tuple[str, ...] = ()
    datasets: tuple[str, ...] = ()
    params: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    tolerance: int | list[int] | None = None
    seed: int | list[int] = 0
    recall: str = "A"
    record_weights: bool = False
    max_weight_values: int = 4_000_000
    combine: str = "product"

    def __post_init__(self) -> None:
        methods = [self.methods] if isinstance(self.methods, str) else self.methods
        datasets = [self.datasets] if isinstance(self.datasets, str) else self.datasets
        for key, items, example in (
            ("methods", methods, 'methods = ["weighted-node-lbp", "seqslam"]'),
            ("datasets", datasets, 'datasets = ["synthetic:?places=100&seed=1"]'),
        ):
            if not isinstance(items, list | tuple) or not all(isinstance(s, str) for s in items):
                raise PpalocError(f"{key}={items!r} must be a list of strings, e.g. {example}")
            if not items:
                raise PpalocError(f"{key} is empty: the grid has no cell; give e.g. {example}")
        object.__setattr__(self, "methods", tuple(dict.fromkeys(methods)))
        object.__setattr__(self, "datasets", tuple(dict.fromkeys(datasets)))
        if not isinstance(self.params, Mapping) or not all(
            isinstance(v, Mapping) for v in self.params.values()
        ):
            raise PpalocError(
                "params must be a table of tables, e.g. [sweep.params.weighted-node-paper-lbp] "
                "gamma = [0.25, 0.5]"
            )
        for method, table in self.params.items():
            if method not in self.methods:
                raise PpalocError(
                    f"[sweep.params.{method}]: {method!r} is not in methods "
                    f"({', '.join(self.methods)}); add it to methods or remove the table"
                )
            for key, value in table.items():
                if isinstance(value, list | tuple) and not value:
                    raise PpalocError(
                        f"[sweep.params.{method}] {key} = [] is empty: give at least one value "
                        "(a list is swept, a single value is fixed)"
                    )
                odd = _not_a_value(value)
                if odd is not None:  # a TOML date or time: no method takes one
                    raise PpalocError(
                        f"[sweep.params.{method}] {key} = {odd} is a TOML "
                        f"{type(odd).__name__}, not a parameter value; give a number, a "
                        "string (quoted) or a list of them"
                    )
                if not _finite(value):  # no cell's identity (JSON) could be written
                    raise PpalocError(
                        f"[sweep.params.{method}] {key} = {value!r} holds NaN or an infinite "
                        "number (one as large as 1e400 is read as inf); give finite numbers"
                    )
        for key, low in (("seed", None), ("tolerance", 0)):
            value = getattr(self, key)
            if value is None and key == "tolerance":
                continue
            values, _ = _values(value)
            ok = bool(values) and all(
                isinstance(v, int) and not isinstance(v, bool) and (low is None or v >= low)
                for v in values
            )
            if not ok:
                bound = "" if low is None else f" >= {low}"
                raise PpalocError(
                    f"{key}={value!r} must be an integer{bound} or a non-empty list of them"
                )
        if str(self.recall).upper() not in ("A", "B", "C"):
            raise PpalocError(f"recall={self.recall!r} must be one of A, B, C")
        object.__setattr__(self, "recall", str(self.recall).upper())
        if self.combine not in COMBINE:
            raise PpalocError(f"combine={self.combine!r} must be one of {', '.join(COMBINE)}")
        if not isinstance(self.record_weights, bool):
            raise PpalocError(f"record_weights={self.record_weights!r} must be true or false")
        if not isinstance(self.max_weight_values, int) or isinstance(self.max_weight_values, bool):
            raise PpalocError(f"max_weight_values={self.max_weight_values!r} must be an integer")

    def swept(self, method: str) -> dict[str, list[Any]]:
        """The swept parameters of ``method`` and their values, in the order given."""
        out = {}
        for key, value in self.params.get(method, {}).items():
            values, swept = _values(value)
            if swept:
                out[key] = values
        return out

    def fixed(self, method: str) -> dict[str, Any]:
        """The fixed (not swept) parameters of ``method``."""
        return {
            k: v for k, v in self.params.get(method, {}).items() if not isinstance(v, list | tuple)
        }

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (for the summary)."""
        d = dataclasses.asdict(self)
        d["methods"], d["datasets"] = list(self.methods), list(self.datasets)
        d["params"] = {m: _jsonable(dict(p)) for m, p in self.params.items()}
        return _jsonable(d)


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, list | tuple):
        return [_jsonable(x) for x in v]
    if isinstance(v, np.generic):
        return v.item()
    return v


def sweep_config_from_mapping(values: Mapping[str, Any], *, source: str = "") -> SweepConfig:
    """Build a :class:`SweepConfig` from TOML or flag values, rejecting unknown keys.

    ``None`` values are ignored (a flag not given). A missing ``methods`` or ``datasets``
    is the empty-grid error.

    Raises
    ------
    PpalocError
        Naming the unknown key and the valid ones, or the bad value.

    Examples
    --------
    >>> cfg = sweep_config_from_mapping(
    ...     {"methods": ["seqslam"], "datasets": ["synthetic:?places=20"], "tolerance": 2}
    ... )
    >>> cfg.methods, cfg.tolerance
    (('seqslam',), 2)
    >>> sweep_config_from_mapping({"method": ["seqslam"]}, source="sweep.toml")
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: unknown configuration key 'method' in sweep.toml; valid keys: \
methods, datasets, params, tolerance, seed, recall, record_weights, max_weight_values, combine
    """
    fields = [f.name for f in dataclasses.fields(SweepConfig)]
    reject_unknown_keys(values, fields, source=source)
    where = f"{source}: " if source else ""
    try:
        return SweepConfig(**{k: v for k, v in values.items() if v is not None})
    except PpalocError as exc:
        raise PpalocError(f"{where}{exc}") from None
    except (TypeError, ValueError) as exc:
        raise PpalocError(f"{where}bad sweep configuration: {exc}") from exc


# -- the grid --------------------------------------------------------------------------------


def _finite(value: Any) -> bool:
    """Whether ``value`` (a parameter: a number, a string, a list of them...) holds no NaN
    or infinite float."""
    if isinstance(value, float):
        return math.isfinite(value)
    if isinstance(value, list | tuple):
        return all(_finite(v) for v in value)
    if isinstance(value, Mapping):
        return all(_finite(v) for v in value.values())
    return True


def _not_a_value(value: Any) -> Any:
    """The first item of ``value`` (a parameter, lists and tables walked) that is none of
    a bool, number, string or None (a TOML date or time), or None where there is none."""
    if isinstance(value, list | tuple):
        return next((odd for v in value if (odd := _not_a_value(v)) is not None), None)
    if isinstance(value, Mapping):
        return _not_a_value(list(value.values()))
    return None if value is None or isinstance(value, bool | int | float | str) else value


def _canonical(value: Any) -> str:
    return json.dumps(_jsonable(value), sort_keys=True, separators=(",", ":"), allow_nan=False)


@dataclass(frozen=True)
class Cell:
    """One cell of a sweep: one method with one set of parameters on one dataset.

    Attributes
    ----------
    method : str
    dataset : str
        The dataset spec as the sweep names it.
    params : dict
        Every user parameter of the method in this cell (fixed and swept).
    axes : dict
        The swept values of this cell, by column name (parameters, ``seed``,
        ``tolerance``), for the summary.
    seed, tolerance, recall, record_weights, max_weight_values
        As in :class:`SweepConfig`, for this cell.
    """

    method: str
    dataset: str
    params: Mapping[str, Any]
    axes: Mapping[str, Any]
    seed: int = 0
    tolerance: int | None = None
    recall: str = "A"
    record_weights: bool = False
    max_weight_values: int = 4_000_000

    @property
    def spec(self) -> str:
        """The dataset spec with the tolerance applied (what the workers load)."""
        return (
            self.dataset if self.tolerance is None else with_tolerance(self.dataset, self.tolerance)
        )

    def evaluate_config(self) -> EvaluateConfig:
        """The :class:`EvaluateConfig` this cell runs."""
        return EvaluateConfig(
            dataset=self.dataset,
            methods=(self.method,),
            tolerance=self.tolerance,
            recall=self.recall,
            seed=self.seed,
            record_weights=self.record_weights,
            max_weight_values=self.max_weight_values,
            params={self.method: dict(self.params)},
        )

    def identity(self) -> dict[str, Any]:
        """What a cell's results depend on, hashed into its :attr:`id`."""
        return {
            "method": self.method,
            "dataset": self.dataset,
            "tolerance": self.tolerance,
            "params": dict(self.params),
            "seed": self.seed,
            "recall": self.recall,
            "record_weights": self.record_weights,
            "max_weight_values": self.max_weight_values,
        }

    @property
    def id(self) -> str:
        """16 hex digits of the SHA-256 of :meth:`identity` as canonical JSON (sorted keys,
        no spaces): the same cell has the same id in every run, on every machine.

        Examples
        --------
        >>> Cell("seqslam", "synthetic:?places=20", {"ds": 10}, {"ds": 10}).id
        '6b44b01ca9906a52'
        """
        text = _canonical(self.identity())
        return hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]

    @property
    def folder(self) -> str:
        """The cell's folder relative to the sweep's output folder."""
        return f"cells/{self.method}-{self.id}"

    def describe(self) -> dict[str, Any]:
        """The content of the cell's ``cell.json``."""
        return {
            "id": self.id,
            "method": self.method,
            "dataset": self.dataset,
            "spec": self.spec,
            "params": _jsonable(dict(self.params)),
            "axes": _jsonable(dict(self.axes)),
            "config": self.evaluate_config().to_dict(),
        }

    def label(self) -> str:
        """A short human-readable name: method, swept values, dataset."""
        swept = " ".join(f"{k}={_text(v)}" for k, v in self.axes.items())
        return " ".join(p for p in (self.method, swept, "on", self.dataset) if p)


def _text(v: Any) -> str:
    return json.dumps(_jsonable(v)) if isinstance(v, list | tuple | dict) else str(v)


def _column(param: str) -> str:
    """The summary column of a swept method parameter (``param:NAME`` if NAME is taken)."""
    return f"param:{param}" if param in _RESERVED else param


MAX_CELLS = 100_000
"""Most cells one sweep holds (every cell is listed, checked and given a folder)."""


def grid_size(config: SweepConfig) -> int:
    """The number of cells :func:`expand` lists (before a value listed twice is merged),
    counted without listing them.

    Raises
    ------
    PpalocError
        If it is more than :data:`MAX_CELLS`.

    Examples
    --------
    >>> grid_size(SweepConfig(methods=("seqslam",), datasets=("synthetic:?places=9",),
    ...                       params={"seqslam": {"ds": [5, 10], "vmin": [0.1, 0.2]}}))
    4
    """
    settings = 0
    for method in config.methods:
        lengths = [len(v) for v in config.swept(method).values()]
        product = config.combine == "product" or not lengths
        settings += math.prod(lengths) if product else sum(lengths)
    parts = [(len(config.datasets), "dataset")]
    for value, noun in ((config.seed, "seed"), (config.tolerance, "tolerance")):
        values, swept = _values(value)
        if swept:
            parts.append((len(values), noun))
    total = settings * math.prod(n for n, _ in parts)
    if total > MAX_CELLS:
        shown = " x ".join(f"{n:,} {noun}{'s' if n != 1 else ''}" for n, noun in parts)
        raise PpalocError(
            f"the grid has {total:,} cells ({shown} x {settings:,} method settings), more "
            f"than the {MAX_CELLS:,} one sweep runs: sweep fewer values, or split the grid "
            "into several sweeps"
        )
    return total


def expand(config: SweepConfig) -> list[Cell]:
    """Every cell of the grid, datasets outermost, then methods, then parameter values;
    a cell that comes up twice (a value listed twice) is kept once.

    Examples
    --------
    >>> cfg = SweepConfig(
    ...     methods=("weighted-node-paper-lbp", "seqslam"),
    ...     datasets=("synthetic:?places=100&seed=1", "synthetic:?places=100&seed=2"),
    ...     tolerance=2,
    ...     params={"weighted-node-paper-lbp": {"gamma": [0.25, 0.5]}},
    ... )
    >>> [(c.method, dict(c.axes)) for c in expand(cfg)][:3]
    [('weighted-node-paper-lbp', {'gamma': 0.25}), ('weighted-node-paper-lbp', {'gamma': 0.5}), \
('seqslam', {})]
    >>> len(expand(cfg))
    6
    """
    grid_size(config)  # refused before millions of cells are listed
    seeds, seeds_swept = _values(config.seed)
    tolerances, tol_swept = _values(config.tolerance)
    cells: dict[str, Cell] = {}
    for dataset in config.datasets:
        for method in config.methods:
            fixed, swept = config.fixed(method), config.swept(method)
            if config.combine == "product" or not swept:
                keys = list(swept)
                choices = [
                    dict(zip(keys, combo, strict=True))
                    for combo in itertools.product(*(swept[k] for k in keys))
                ]
            else:  # one at a time: each swept parameter alone, the others at their defaults
                choices = [{k: v} for k, values in swept.items() for v in values]
            for choice in choices:
                for seed in seeds:
                    for tolerance in tolerances:
                        params = {**fixed, **choice}
                        shown = {_column(k): v for k, v in choice.items()}
                        if seeds_swept and "seed" not in choice:
                            shown["seed"] = seed
                        if tol_swept:
                            shown["tolerance"] = tolerance
                        cell = Cell(
                            method=method,
                            dataset=dataset,
                            params=params,
                            axes=shown,
                            seed=seed,
                            tolerance=tolerance,
                            recall=config.recall,
                            record_weights=config.record_weights,
                            max_weight_values=config.max_weight_values,
                        )
                        cells.setdefault(cell.id, cell)
    return list(cells.values())


def axes(config: SweepConfig) -> dict[str, list[Any]]:
    """Every axis of the grid with its values, in order: ``method``, ``dataset``, the swept
    parameters (columns of :func:`expand`'s ``Cell.axes``), ``seed``, ``tolerance``."""
    out: dict[str, list[Any]] = {"method": list(config.methods), "dataset": list(config.datasets)}
    for method in config.methods:
        for key, values in config.swept(method).items():
            column = out.setdefault(_column(key), [])
            column += [v for v in values if v not in column]
    seeds, seeds_swept = _values(config.seed)
    if seeds_swept:
        column = out.setdefault("seed", [])
        column += [v for v in seeds if v not in column]
    tolerances, tol_swept = _values(config.tolerance)
    if tol_swept:
        out["tolerance"] = tolerances
    return out


def validate(config: SweepConfig, cells: Sequence[Cell], *, source: str = "") -> None:
    """Check everything that can be checked on the client, before any cell runs: method
    names, dataset specs (parsed, not loaded) and every cell's parameters (the localiser
    is constructed, as ``ppaloc evaluate`` does).

    Raises
    ------
    PpalocError
        One line naming the key (and the cell) at fault.
    """
    from ppaloc.datasets.registry import parse_dataset_spec
    from ppaloc.evaluate.run import localiser_params, resolve_methods
    from ppaloc.methods import check_method

    where = f"{source}: " if source else ""
    try:
        resolve_methods(config.methods)
    except PpalocError as exc:
        raise PpalocError(f"{where}methods: {exc}") from None
    for spec in dict.fromkeys(c.spec for c in cells):
        try:
            check_spec_text(spec)
            parse_dataset_spec(spec)
        except PpalocError as exc:
            raise PpalocError(f"{where}datasets: {exc}") from None
    for dataset, tolerance in dict.fromkeys((c.dataset, c.tolerance) for c in cells):
        try:  # a tolerance axis beside a spec's own tolerance= is a contradiction
            check_tolerance(dataset, tolerance)
        except PpalocError as exc:
            raise PpalocError(f"{where}datasets: {exc}") from None
    seen: set[str] = set()
    for cell in cells:
        key = _canonical([cell.method, cell.params, cell.seed])
        if key in seen:
            continue
        seen.add(key)
        params = localiser_params(
            cell.method, cell.params, seed=cell.seed, record_weights=cell.record_weights
        )
        try:
            check_method(cell.method, params)  # what it reads from the dataset: on the worker
        except PpalocError as exc:
            swept = ", ".join(f"{k}={_text(v)}" for k, v in cell.axes.items())
            at = f" (cell {swept})" if swept else ""
            raise PpalocError(f"{where}[sweep.params.{cell.method}]{at}: {exc}") from None


# -- cell folders ----------------------------------------------------------------------------


def _no_constant(name: str) -> Any:
    """NaN or Infinity, which a cell's files never hold (ppaloc writes strict JSON)."""
    raise ValueError(f"{name} is not JSON")


def _read_json(path: Path) -> Any:
    """A cell file's JSON, or None where it is missing or not strict JSON (a file cut short
    or edited by hand, NaN included: the cell is then not finished, and runs again)."""
    try:
        return json.loads(path.read_text(encoding="utf-8"), parse_constant=_no_constant)
    except (OSError, ValueError, RecursionError):
        return None


def cell_status(out: str | Path, cell: Cell) -> tuple[str, dict[str, Any] | None]:
    """``(status, results)`` of a cell from its folder: ``("ok", results.json)`` when its
    ``results.json`` exists and parses (with an entry for the cell's method), else the
    recorded one-line error, else ``"not run"``."""
    folder = Path(out) / cell.folder
    results = _read_json(folder / "results.json")
    if (
        isinstance(results, dict)
        and isinstance(results.get("methods"), dict)
        and isinstance(results["methods"].get(cell.method), dict)
    ):
        try:  # a cell written before a field was renamed is read under today's names
            path = folder / "results.json"
            results = upgrade_summary(results, path)
            # a hand-edited field reached summary.json, which show then refused
            check_method_entry(results["methods"][cell.method], cell.method, path)
            return "ok", results
        except DataError as exc:
            return str(exc), None
    error = _read_json(folder / "error.json")
    if isinstance(error, dict) and error.get("error"):
        return str(error["error"]), None
    return _NOT_RUN, None


def _safe_relative(rel: str) -> Path:
    path = Path(rel)
    if path.is_absolute() or ".." in path.parts:
        raise RuntimeError(f"a worker returned a file outside its cell folder: {rel!r}")
    return path


def write_cell(out: Path, cell: Cell, files: Mapping[str, bytes]) -> None:
    """Write a finished cell's files (``{relative path: bytes}``) as its folder under
    ``out``, replacing the folder whole (:func:`ppaloc.fileio.new_folder`: an earlier
    failed run's ``error.json`` goes with it), ``results.json`` last."""
    folder = out / cell.folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    with new_folder(folder) as stage:
        for rel, data in files.items():
            if rel != "results.json":
                write_bytes(stage / _safe_relative(rel), data)
        write_bytes(stage / "cell.json", json.dumps(cell.describe(), indent=2) + "\n")
        write_bytes(stage / "results.json", files["results.json"])


def write_cell_error(out: Path, cell: Cell, line: str, trace: str) -> None:
    """Record a failed cell as its folder, replaced whole: ``cell.json`` and ``error.json``
    (one-line error, traceback)."""
    folder = out / cell.folder
    folder.parent.mkdir(parents=True, exist_ok=True)
    record = {"error": line, "traceback": trace, **_created()}
    with new_folder(folder) as stage:
        write_bytes(stage / "cell.json", json.dumps(cell.describe(), indent=2) + "\n")
        write_bytes(stage / "error.json", json.dumps(record, indent=2) + "\n")


#: What a sweep writes at the top of its folder; a folder holding anything else is not one.
SWEEP_NAMES = frozenset(
    {"cells", "summary.csv", "summary.json", "report.html", "report.md", "figures"}
)
_FIGURE = re.compile(r"heatmap-[1-9][0-9]*\.png")  # the report's figures (sweep_report)
_CELL = re.compile(r".+-[0-9a-f]{16}")  # Cell.folder
_CELL_STAGE = re.compile(r"\..+-[0-9a-f]{16}\.ppaloc-(new|old)-[0-9]+-[0-9a-f]+")
_CELL_OWN = ("cell.json", "error.json")


def sweep_wrote(folder: Path, name: str, written: dict[Path, frozenset[str]] | None = None) -> bool:
    """Whether ``name``, a path relative to the sweep folder ``folder`` (``/`` between its
    parts), is an entry a sweep writes there: one of :data:`SWEEP_NAMES` or a hidden name
    at the top (and what the latter holds: a sweep never touches it); in ``figures/``, the
    report's ``heatmap-N.png``; in ``cells/``, a cell's folder (``<method>-<id>/`` holding
    a ``cell.json``) or the staging folder a killed write of one left, and in a cell's
    folder its ``cell.json``, ``error.json`` and what ppaloc writes in a results folder
    (:func:`ppaloc.evaluate.results.written_by_ppaloc`; ``written`` caches what each
    cell's ``results.json`` names)."""
    head, sep, rest = name.partition("/")
    if not sep:
        return name.startswith(".") or name in SWEEP_NAMES
    if head.startswith("."):
        return True
    if head == "figures":
        return _FIGURE.fullmatch(rest) is not None and not (folder / name).is_dir()
    if head != "cells":
        return False
    cell, sep, inside = rest.partition("/")
    if _CELL_STAGE.fullmatch(cell):
        return True
    sub = folder / "cells" / cell
    if not (_CELL.fullmatch(cell) and sub.is_dir() and not sub.is_symlink()):
        return False
    if not (sub / "cell.json").is_file():
        return False
    return not sep or inside in _CELL_OWN or written_by_ppaloc(sub, inside, written)


def one_line_error(exc: BaseException) -> str:
    """An exception in one line: a user mistake's message, else ``Type: message``."""
    text = " ".join(str(exc).split())
    if isinstance(exc, PpalocError):
        return text or type(exc).__name__
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


# -- the summary -----------------------------------------------------------------------------


def _metrics_row(results: Mapping[str, Any], method: str) -> dict[str, Any]:
    entry = results["methods"][method]
    rk = entry.get("recall_at_k") or {}
    row = {c: entry.get(c) for c in METRIC_COLUMNS}
    row["n_queries"] = results.get("n_queries")
    for k in ("1", "5", "10"):
        row[f"recall_at_{k}"] = rk.get(k)
    return row


def collect_summary(config: SweepConfig, out: str | Path) -> dict[str, Any]:
    """The sweep's summary, read from the cell folders only: one row per cell of the grid.

    Returns
    -------
    dict
        The content of ``summary.json``: ``config``, ``axes``, ``columns``, ``cells`` (rows
        with ``method``, ``dataset``, one entry per swept axis, the metrics, ``status``
        and ``cell``, the folder), ``counts`` and provenance.
    """
    out = Path(out)
    grid = axes(config)
    axis_columns = [a for a in grid if a not in ("method", "dataset")]
    columns = ["method", "dataset", *axis_columns, *METRIC_COLUMNS, "status", "cell"]
    rows = []
    counts = Counter()
    for cell in expand(config):
        status, results = cell_status(out, cell)
        row: dict[str, Any] = {"method": cell.method, "dataset": cell.dataset}
        row.update({a: cell.axes.get(a) for a in axis_columns})
        row.update(_metrics_row(results, cell.method) if results else dict.fromkeys(METRIC_COLUMNS))
        row["status"] = status
        row["cell"] = cell.folder
        rows.append(_jsonable(row))
        counts["ok" if status == "ok" else "not_run" if status == _NOT_RUN else "failed"] += 1
    return {
        "format": "ppaloc-sweep-summary",
        "version": SUMMARY_VERSION,
        "config": config.to_dict(),
        "axes": _jsonable(grid),
        "columns": columns,
        "cells": rows,
        "counts": {
            "cells": len(rows),
            "ok": counts["ok"],
            "failed": counts["failed"],
            "not_run": counts["not_run"],
        },
        "ppaloc_version": __version__,
        **_created(),
    }


SUMMARY_VERSION = 1
"""The version of ``summary.json`` this ppaloc writes (``version``); a newer one is refused
where it is read."""


def _created() -> dict[str, str]:
    """``{"created": ...}`` where ``SOURCE_DATE_EPOCH`` is set, else nothing: the same
    cells give the same summary bytes."""
    when = source_date()
    return {} if when is None else {"created": when.isoformat(timespec="seconds")}


def write_summary(config: SweepConfig, out: str | Path) -> dict[str, Any]:
    """Rebuild ``summary.json`` and ``summary.csv`` from the cell folders; return the summary."""
    import csv
    import io

    out = Path(out)
    summary = collect_summary(config, out)
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(summary["columns"])
    for row in summary["cells"]:
        writer.writerow(
            ["" if row.get(c) is None else _csv_value(row.get(c)) for c in summary["columns"]]
        )
    write_bytes(out / "summary.csv", text.getvalue())
    write_bytes(out / "summary.json", json.dumps(summary, indent=2, allow_nan=False) + "\n")
    return summary


def _csv_value(v: Any) -> Any:
    return json.dumps(v) if isinstance(v, list | dict) else v
