"""Run configurations: frozen dataclasses read from a TOML file and overridden by flags.

The same keys come from a TOML file (``--config FILE.toml``) and from command-line flags;
a flag given on the command line wins. Unknown keys are an error that lists the valid ones,
so a typo never silently falls back to a default. The resolved configuration is written
into every result file.
"""

from __future__ import annotations

import dataclasses
import errno
import math
import os
import re
import stat
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from ppaloc.errors import PpalocError
from ppaloc.seeds import SEED_MAX

__all__ = [
    "DEMO_DATASET",
    "LIMITS",
    "MAX_BENCH_SIZE",
    "BenchConfig",
    "EvaluateConfig",
    "check_limits",
    "check_spec_text",
    "check_tolerance",
    "check_types",
    "config_from_mapping",
    "demo_dataset",
    "read_toml",
    "reject_unknown_keys",
    "with_tolerance",
]


def demo_dataset(places: int = 200) -> str:
    """The spec of the built-in route ``ppaloc demo`` runs on (procedural, no files needed).

    A summer map and a winter query re-driven at the mapping speed (one frame per place)
    with two stops: the paper's setting, where the motion model has to tell forward from
    stay. Variable speed (drop ``sync=1``) is a harder test, described in docs/localise.md.
    """
    return f"synthetic:?places={places}&query=winter&seed=0&sync=1&stops=2"


DEMO_DATASET = demo_dataset()
"""The default dataset of ``ppaloc demo`` and of an ``evaluate`` config without one."""

C = TypeVar("C")

MAX_BENCH_SIZE = 262_144
"""Largest map ``ppaloc bench`` builds (2^18 nodes: minutes for the slowest methods)."""

LIMITS: dict[str, tuple[float, float]] = {
    "tolerance": (0, 1000),
    "seed": (0, SEED_MAX),
    "max_weight_values": (0, 100_000_000),
    "queries": (1, 100_000),
    "warmup": (0, 10_000),
    "sizes": (2, MAX_BENCH_SIZE),
    "max_build_s": (0.0, 86_400.0),
}
"""Accepted range of every numeric configuration key, inclusive (one place for the
``EvaluateConfig``/``BenchConfig`` checks and the documentation; a list key's range holds
for each item)."""

MAX_SIZES = 64
"""Most map sizes one bench times."""

MAX_CONFIG_BYTES = 1 << 20
"""Largest configuration file read (1 MiB)."""


def check_limits(values: Mapping[str, Any], *, source: str = "") -> None:
    """Refuse a numeric configuration value outside :data:`LIMITS` (or not finite).

    Raises
    ------
    PpalocError
        Naming the key, the value and the accepted range.

    Examples
    --------
    >>> check_limits({"seed": -1})
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: seed=-1 must be an integer in [0, 9223372036854775807]
    """
    where = f" in {source}" if source else ""
    for key, value in values.items():
        if key not in LIMITS or value is None:
            continue
        low, high = LIMITS[key]
        items = value if isinstance(value, list | tuple) else [value]
        real = isinstance(low, float)
        noun = "a number" if real else "an integer"
        bound = f"[{low:g}, {high:g}]" if real else f"[{int(low)}, {int(high)}]"
        for item in items:
            number = isinstance(item, int | float) and not isinstance(item, bool)
            if not number or (not real and not float(item).is_integer()):
                raise PpalocError(f"{key}={item!r}{where} must be {noun} in {bound}")
            if not (math.isfinite(item) and low <= item <= high):
                raise PpalocError(f"{key}={item!r}{where} must be {noun} in {bound}")


@dataclass(frozen=True)
class EvaluateConfig:
    """What ``ppaloc evaluate`` runs.

    Parameters
    ----------
    dataset : str
        Dataset spec (``KIND:PATH?key=value``, see docs/datasets.md).
    methods : tuple of str
        Method names (``ppaloc.methods``); empty means every available method.
    tolerance : int, optional
        Accepted distance to the true reference frame, in frames (None: the spec's
        ``tolerance`` key, else the dataset kind's default). A spec that sets another
        ``tolerance`` is refused (:func:`check_tolerance`): one run, one tolerance.
    recall : {"A", "B", "C"}
        Recall definition (``ppaloc.evaluate.metrics.RECALL_DEFINITIONS``).
    seed : int
        Passed to every method that takes a ``seed``.
    record_weights : bool
        Ask localisers that accept ``record_weights=True`` for their per-node weights after
        every frame (the report's heatmap); skipped when queries x nodes exceeds
        ``max_weight_values``.
    max_weight_values : int
        Largest weights array (queries x nodes) kept per method.
    params : dict
        Per-method keyword arguments, ``{method name: {key: value}}`` (TOML tables
        ``[params.weighted-node-lowres]``).
    """

    dataset: str = DEMO_DATASET
    methods: tuple[str, ...] = ()
    tolerance: int | None = None
    recall: str = "A"
    seed: int = 0
    record_weights: bool = True
    max_weight_values: int = 4_000_000
    params: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "methods", tuple(self.methods))
        check_limits({k: getattr(self, k) for k in ("tolerance", "seed", "max_weight_values")})
        check_spec_text(self.dataset)
        check_tolerance(self.dataset, self.tolerance)
        if str(self.recall).upper() not in ("A", "B", "C"):
            raise PpalocError(f"recall={self.recall!r} must be one of A, B, C")
        object.__setattr__(self, "recall", str(self.recall).upper())
        if not isinstance(self.params, Mapping) or not all(
            isinstance(v, Mapping) for v in self.params.values()
        ):
            raise PpalocError(
                "params must be a table of tables, e.g. [params.weighted-node-lowres] gain = 8"
            )

    def resolved_dataset(self) -> str:
        """The dataset spec with ``tolerance`` applied."""
        return (
            self.dataset if self.tolerance is None else with_tolerance(self.dataset, self.tolerance)
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (for result files)."""
        d = dataclasses.asdict(self)
        d["methods"] = list(self.methods)
        d["params"] = {k: dict(v) for k, v in self.params.items()}
        return d


@dataclass(frozen=True)
class BenchConfig:
    """What ``ppaloc bench`` measures: host time per ``step`` against map size.

    Parameters
    ----------
    methods : tuple of str
        Method names; empty means every available method.
    sizes : tuple of int
        Map sizes (nodes) to time.
    queries : int
        Frames stepped per size (the first ``warmup`` are not timed).
    warmup : int
        Untimed frames per size.
    seed : int
        Seed of the random reference and query frames.
    params : dict
        Per-method keyword arguments, as in :class:`EvaluateConfig`.
    max_build_s : float, optional
        Time budget of one map build in seconds: a size whose build, extrapolated linearly
        from the previous size (for the first size above 256 nodes, from a 256-node trial
        build), would exceed it is skipped (None: no budget).
    """

    methods: tuple[str, ...] = ()
    sizes: tuple[int, ...] = (64, 256, 1024)
    queries: int = 20
    warmup: int = 3
    seed: int = 0
    params: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    max_build_s: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "methods", tuple(self.methods))
        keys = ("sizes", "queries", "warmup", "seed", "max_build_s")
        check_limits({k: getattr(self, k) for k in keys})
        object.__setattr__(self, "sizes", tuple(int(s) for s in self.sizes))
        if not self.sizes or len(self.sizes) > MAX_SIZES:
            raise PpalocError(
                f"sizes={list(self.sizes)} must list 1 to {MAX_SIZES} map sizes, e.g. 64,256,1024"
            )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (for result files)."""
        d = dataclasses.asdict(self)
        d["methods"], d["sizes"] = list(self.methods), list(self.sizes)
        d["params"] = {k: dict(v) for k, v in self.params.items()}
        return d


def config_from_mapping(cls: type[C], values: Mapping[str, Any], *, source: str = "") -> C:
    """Build the config ``cls`` from ``values``, rejecting unknown keys.

    Parameters
    ----------
    cls : type
        :class:`EvaluateConfig` or :class:`BenchConfig`.
    values : mapping
        Keys of ``cls``; ``None`` values are ignored (a flag not given).
    source : str
        Where the values came from, for the message (e.g. the TOML file name).

    Raises
    ------
    PpalocError
        Naming the unknown key and the valid ones.

    Examples
    --------
    >>> config_from_mapping(BenchConfig, {"sizes": [8, 16]}).sizes
    (8, 16)
    """
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    reject_unknown_keys(values, list(fields), source=source)
    where = f" in {source}" if source else ""
    check_types(cls, values, source=source)
    check_limits(values, source=source)
    try:
        return cls(**{k: v for k, v in values.items() if v is not None})
    except (TypeError, ValueError) as exc:
        raise PpalocError(f"bad configuration{where}: {exc}") from exc


def check_types(cls: type, values: Mapping[str, Any], *, source: str = "") -> None:
    """Refuse a value whose type does not fit the field of ``cls`` it sets (other keys
    are left alone), e.g. ``tolerance = "2"``.

    Raises
    ------
    PpalocError
        Naming the key, the value and the type expected.
    """
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    where = f" in {source}" if source else ""
    for key, value in values.items():
        if key not in fields:
            continue
        expected = str(fields[key].type).split(" | ")[0]
        if value is not None and not _has_type(value, expected):
            shown = repr(value) if len(repr(value)) <= 60 else repr(value)[:57] + "..."
            raise PpalocError(f"{key}={shown}{where} must be {_TYPE_WORDS.get(expected, expected)}")


_TYPE_WORDS = {
    "int": "an integer",
    "float": "a number",
    "bool": "true or false",
    "str": "a string",
    "tuple[str, ...]": "a list of strings",
    "tuple[int, ...]": "a list of integers",
}


def _has_type(value: Any, expected: str) -> bool:
    """Whether a TOML or flag value fits a config field's annotation (others: not checked)."""
    scalar = {"int": int, "float": (int, float), "bool": bool, "str": str}
    if expected in scalar:
        return isinstance(value, scalar[expected]) and (
            expected == "bool" or not isinstance(value, bool)
        )
    if expected.startswith("tuple["):
        item = expected[len("tuple[") : -len(", ...]")]
        return isinstance(value, list | tuple) and all(_has_type(v, item) for v in value)
    return True


def reject_unknown_keys(
    values: Mapping[str, Any], valid: Sequence[str], *, source: str = ""
) -> None:
    """Raise if ``values`` holds a key not in ``valid``, so a typo never falls back to a default.

    Raises
    ------
    PpalocError
        Naming the first unknown key (sorted), where it came from, and the valid keys.

    Examples
    --------
    >>> reject_unknown_keys({"sed": 2}, ["seed", "out"], source="a.toml")
    Traceback (most recent call last):
    ppaloc.errors.PpalocError: unknown configuration key 'sed' in a.toml; valid keys: seed, out
    """
    unknown = sorted(set(values) - set(valid))
    if unknown:
        where = f" in {source}" if source else ""
        raise PpalocError(
            f"unknown configuration key {unknown[0]!r}{where}; valid keys: {', '.join(valid)}"
        )


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML configuration file (keys as in the config dataclasses).

    Raises
    ------
    PpalocError
        If the file is missing or not valid TOML (with the parser's line and column).
    """
    path = Path(path)
    try:
        if path.is_dir():
            raise PpalocError(f"config file {path} is a folder; give a TOML file")
        mode = os.stat(path).st_mode  # before opening: a FIFO would block the open
        if not stat.S_ISREG(mode):
            raise PpalocError(
                f"config file {path} is not a regular file (a pipe, device or socket); give a "
                "TOML file"
            )
        with path.open("rb") as f:
            raw = f.read(MAX_CONFIG_BYTES + 1)
    except FileNotFoundError:
        raise PpalocError(f"config file {path} does not exist") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise PpalocError(
                f"config file {path} is a symlink loop (its links lead back to themselves); "
                "give a TOML file, or fix the links"
            ) from None
        raise PpalocError(f"cannot read config file {path}: {exc.__class__.__name__}") from None
    except ValueError as exc:
        raise PpalocError(f"cannot read config file {path}: {exc.__class__.__name__}") from None
    if len(raw) > MAX_CONFIG_BYTES:
        raise PpalocError(
            f"config file {path} is larger than {MAX_CONFIG_BYTES} bytes; a configuration "
            "is a few lines of TOML"
        )
    try:
        # UTF-8 with a byte-order mark, as Windows editors save it, is UTF-8 too
        text = raw.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError as exc:
        raise PpalocError(
            f"config file {path} is not UTF-8 text (byte {exc.start}); save it as UTF-8"
        ) from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise PpalocError(f"config file {path} is not valid TOML: {exc}") from None
    except RecursionError:
        raise PpalocError(f"config file {path} nests arrays or tables too deeply") from None


def _spec_tolerance(spec: str) -> str | None:
    """The text of the ``tolerance`` key a spec sets (keys compared as the spec parser
    compares them: stripped, lower-case), or None."""
    query = spec.partition("?")[2]
    for pair in query.split("&"):
        key, eq, value = pair.partition("=")
        if eq and key.strip().lower() == "tolerance":
            return value.strip()
    return None


def check_spec_text(spec: str) -> None:
    """Refuse a dataset spec that is not text the result files can record: one naming a
    file or folder whose name is bytes of another encoding than UTF-8 (Linux allows any;
    Python holds them as surrogates), which no UTF-8 file can hold, so the run failed
    after its work, writing its results.

    Such bytes elsewhere (a kind or a value typed in another encoding) make a spec that is
    wrong anyway, refused as its parser refuses it: renaming a file cannot help there.

    Raises
    ------
    PpalocError
        Naming the spec and the fix.

    Examples
    --------
    >>> check_spec_text("folder:caf\u00e9,night")  # a UTF-8 name: recorded as it is
    """
    if not isinstance(spec, str):
        return
    try:
        spec.encode("utf-8")
    except UnicodeEncodeError:
        from ppaloc.datasets import parse_dataset_spec

        parse_dataset_spec(spec)  # the spec's own mistake first
        shown = repr(spec) if len(spec) <= 120 else repr(spec[:100]) + f"... ({len(spec)} chars)"
        raise PpalocError(
            f"dataset spec {shown} names a file or folder whose name is not UTF-8 text (the "
            "\\udc.. are its bytes), which the result files, UTF-8 text, cannot record; give "
            "it a UTF-8 name, or a link to it with one (ln -s)"
        ) from None


def check_tolerance(spec: str, tolerance: int | None) -> None:
    """Refuse a tolerance given beside a spec that sets another one.

    ``--tolerance`` (or ``tolerance =`` in a configuration file) and a spec's own
    ``tolerance=`` key say the same thing twice: the same value is accepted, two values
    are a contradiction the user must settle, never silently decided for them.

    Raises
    ------
    PpalocError
        Naming both values and the fix.

    Examples
    --------
    >>> check_tolerance("synthetic:?places=20&tolerance=2", 2)
    >>> try:
    ...     check_tolerance("synthetic:?places=20&tolerance=1", 2)
    ... except PpalocError as exc:
    ...     print(str(exc).split(" in the ")[0].split(") ")[1])
    contradicts tolerance=1
    """
    if tolerance is None or not isinstance(spec, str):
        return
    text = _spec_tolerance(spec)
    if text is None:
        return
    same = re.fullmatch(r"\+?[0-9]{1,6}", text) is not None and int(text) == tolerance
    if not same:
        shown = repr(spec) if len(spec) <= 120 else repr(spec[:100]) + f"... ({len(spec)} chars)"
        value = text if len(text) <= 20 else text[:17] + "..."
        raise PpalocError(
            f"tolerance {tolerance} (--tolerance, or tolerance = in a configuration file) "
            f"contradicts tolerance={value} in the dataset spec {shown}: give the tolerance "
            "in one place only"
        )


def with_tolerance(spec: str, tolerance: int) -> str:
    """Return ``spec`` with its ``tolerance`` key set to ``tolerance`` (replaced if present).

    Examples
    --------
    >>> with_tolerance("synthetic:?places=20&tolerance=1", 3)
    'synthetic:?places=20&tolerance=3'
    >>> with_tolerance("folder:a,b", 0)
    'folder:a,b?tolerance=0'
    >>> with_tolerance("synthetic", 2)
    'synthetic:?tolerance=2'
    """
    head, _, query = spec.partition("?")
    if ":" not in head:  # a kind written alone: the query needs the colon
        head += ":"
    pairs = [p for p in query.split("&") if p and p.split("=", 1)[0].strip() != "tolerance"]
    pairs.append(f"tolerance={int(tolerance)}")
    return f"{head}?{'&'.join(pairs)}"
