"""The ``ppaloc`` command: click parsers and the launch wrapper.

Layers: the library (``ppaloc.evaluate`` and below) does the work; ``ppaloc.cli.commands``
has one thin ``run_*`` per command; this module only parses flags and TOML files (it
imports nothing heavy at start-up) and maps errors to exit codes in :func:`main`:

- 0: success, or standard output's reader stopped reading (``... | head``);
- 1: a user mistake (:class:`ppaloc.errors.PpalocError`) or a command-line usage error (an
  unknown option, a value click refuses), printed as one line: both are bad input;
- 2: a bare ``ppaloc``, which prints the help;
- 3: a bug: one line naming a log file that holds the traceback;
- 130: interrupted.
"""

from __future__ import annotations

import dataclasses
import errno
import logging
import math
import sys
import tempfile
import traceback
from pathlib import Path
from typing import Any

import click

from ppaloc.errors import PpalocError
from ppaloc.flags import set_once, short

__all__ = ["cli", "main"]

log = logging.getLogger("ppaloc")

_SECTIONS = ("evaluate", "bench", "map", "localise", "demo", "sweep", "score")

DEFAULT_MAP_METHOD = "weighted-node-patch"
"""`ppaloc map` without --method: the weighted-node filter on the baselines' own 64x32 image,
the host filter of the best mean max F1 over the 65 routes and the 40 held-out ones
(README, "Which to pick")."""


# -- configuration ------------------------------------------------------------------------


def _parse_value(text: str) -> Any:
    """A flag value as TOML would read it (``8`` -> 8, ``0.5``, ``true``, ``[1, 2]``), a
    parenthesised tuple as a list (``(8, 8)`` -> [8, 8], as Python writes it), else text.

    Examples
    --------
    >>> _parse_value("(8,8)"), _parse_value("[8, 8]"), _parse_value("0.5"), _parse_value("image")
    ([8, 8], [8, 8], 0.5, 'image')
    """
    import tomllib

    stripped = text.strip()
    if stripped.startswith("(") and stripped.endswith(")"):
        stripped = f"[{stripped[1:-1]}]"
    try:
        return tomllib.loads(f"v = {stripped}")["v"]
    except (tomllib.TOMLDecodeError, RecursionError):
        return text


def _parse_params(items: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """``--param METHOD.KEY=VALUE`` flags -> ``{method: {key: value}}``."""
    out: dict[str, dict[str, Any]] = {}
    for item in items:
        key, eq, value = item.partition("=")
        method, dot, name = key.rpartition(".")
        if not eq or not dot or not method or not name:
            raise PpalocError(
                f"--param {item!r} must look like METHOD.KEY=VALUE, "
                "e.g. --param weighted-node-lowres.gain=8"
            )
        table = out.setdefault(method.strip(), {})
        what = f"--param {method.strip()}.{name.strip()}"
        set_once(table, name.strip(), _parse_value(value.strip()), what)
    return out


def _parse_method_params(items: tuple[str, ...]) -> dict[str, Any]:
    """``--param KEY=VALUE`` flags (one method) -> ``{key: value}``."""
    out: dict[str, Any] = {}
    for item in items:
        key, eq, value = item.partition("=")
        if not eq or not key.strip():
            raise PpalocError(f"--param {item!r} must look like KEY=VALUE, e.g. --param gain=8")
        set_once(out, key.strip(), _parse_value(value.strip()), f"--param {key.strip()}")
    return out


def _file_values(path: Path | None, section: str) -> dict[str, Any]:
    """Top-level keys of a TOML file plus its ``[section]`` table (other sections ignored)."""
    if path is None:
        return {}
    from ppaloc.evaluate.config import read_toml

    data = read_toml(path)
    values = {k: v for k, v in data.items() if k not in _SECTIONS}
    table = data.get(section, {})
    if not isinstance(table, dict):
        raise PpalocError(
            f"{section} = {short(table)} in {path} must be a table: write [{section}] "
            "and its keys below it"
        )
    values.update(table)
    return values


_CLI_TYPES: dict[str, tuple[type, ...]] = {
    "out": (str, Path),
    "quiet": (bool,),
    "no_report": (bool,),
    "method": (str,),
    "scheduler": (str,),
}
"""Type of each key a command reads itself (not a config dataclass field)."""


def _check_cli_values(values: dict[str, Any], source: Path | None, *, flags: bool = False) -> None:
    """Refuse a command-level key of the wrong type (``out = 5``, ``quiet = "yes"``), or
    an empty name; ``flags``: the values are the flags' (``--method ''``), not a file's."""
    where = f" in {source}" if source else ""
    for key, types in _CLI_TYPES.items():
        value = values.get(key)
        if isinstance(value, str) and key in ("method", "scheduler") and not value.strip():
            given = f"--{key} {value!r}" if flags else f"{key} = ''"
            raise PpalocError(f"{given} is empty{where}: give a name, or leave it out")
        if value is None or isinstance(value, types):
            continue
        wanted = {"quiet": "true or false", "no_report": "true or false"}.get(key, "a string")
        raise PpalocError(f"{key} = {short(value)}{where} must be {wanted}")


def _check_params(params: Any, source: Path | None) -> None:
    """``params`` must be a table of tables, one per method."""
    where = f" in {source}" if source else ""
    if params is None:
        return
    if not isinstance(params, dict) or not all(isinstance(p, dict) for p in params.values()):
        raise PpalocError(
            f"params = {short(params)}{where} must be a table of tables, one per method, "
            "e.g. [params.seqslam] then ds = 20"
        )


def _check_method_params(params: Any, source: Path | None) -> None:
    """Each ``params`` table names a known method and holds only its valid parameters
    (type and range, then the method's own checks: it is built once, without a map),
    before any work."""
    from ppaloc.methods import check_method, registry

    where = f" in {source}" if source else ""
    for method, values in (params or {}).items():
        if method not in registry():
            raise PpalocError(
                f"params given for unknown method {short(method)}{where}; methods: "
                + ", ".join(registry())
            )
        check_method(method, values)  # what it reads from the dataset: when it runs


def _check_flag_params_run(
    flag_params: dict[str, dict[str, Any]], methods: Any, listed_in: Path | None = None
) -> None:
    """Refuse a ``--param METHOD.KEY=VALUE`` flag for a method the run leaves out: it
    would change nothing, silently (``-m weighted-node-lbp --param
    weighted-node-lowres.gain=3``); a configuration file's ``[params.METHOD]`` may hold
    tables for methods a run leaves out, as shared files do. ``listed_in``: the file
    whose ``methods`` the run takes (no ``--method`` flag given, which would replace it)."""
    if not methods:
        return  # every available method runs
    run = [methods] if isinstance(methods, str) else list(methods)
    for method, values in flag_params.items():
        if method not in run:
            key = next(iter(values))  # a known method's valid key: checked before
            add = (
                f"add {method!r} to methods in {listed_in} (a --method flag would replace "
                "that list)"
                if listed_in is not None
                else f"add --method {method}"
            )
            raise PpalocError(
                f"--param {method}.{key} is for a method this run leaves out (methods: "
                f"{', '.join(map(str, run))}); {add} or correct the method's name"
            )


def _check_file_types(
    cls: type, file_values: dict[str, Any], source: Path | None, skip: tuple[str, ...] = ()
) -> None:
    """A config file's values are typed and ranged even where a flag overrides them."""
    from ppaloc.evaluate.config import check_limits, check_types

    values = {k: v for k, v in file_values.items() if k not in skip}
    if isinstance(values.get("methods"), str):  # one name stands for a list of one
        values["methods"] = [values["methods"]]
    check_types(cls, values, source=str(source or ""))
    check_limits(values, source=str(source or ""))


def _output(value: Any, *, folder: bool, flag: str = "--out", in_place: bool = False) -> Path:
    """The checked output location (see :func:`ppaloc.cli.outputs.check_output`; ``-``
    is refused: standard output holds neither a folder nor a binary file)."""
    from ppaloc.cli.outputs import check_output

    return check_output(value, flag, folder=folder, in_place=in_place)


def _text_output(value: Any, flag: str = "--out") -> Path | None:
    """The checked output file of text, or None for ``-``: standard output (see
    :func:`ppaloc.cli.outputs.check_text_output`)."""
    from ppaloc.cli.outputs import check_text_output

    return check_text_output(value, flag)


def _merge(
    file_values: dict[str, Any],
    flags: dict[str, Any],
    *,
    source: Path | None = None,
    nested: bool = True,
) -> dict[str, Any]:
    """Flags that were given (not None, not empty) override the file; params merge per
    method (``nested``: ``{method: {key: value}}``) or key by key (one method's table)."""
    from ppaloc.evaluate.config import check_limits

    merged = dict(file_values)
    _check_cli_values(merged, source)  # a bad file value is refused even when a flag wins
    # a flag's number is refused as the flag's, not the file's (whose name it would carry)
    check_limits({k: v for k, v in flags.items() if isinstance(v, int | float)})
    if nested:  # one method's table is checked by the command, which names its section
        _check_params(merged.get("params"), source)
    for key, value in flags.items():
        if value is None or value == () or value == {}:
            continue
        if key == "params" and nested:
            params = {m: dict(p) for m, p in merged.get("params", {}).items()}
            for m, p in value.items():
                params.setdefault(m, {}).update(p)
            merged["params"] = params
        elif key == "params":
            base = merged.get("params", {})
            merged["params"] = {**base, **value} if isinstance(base, dict) else base
        else:
            merged[key] = value
    _check_cli_values(flags, None, flags=True)  # the file's values were checked above
    return merged


def _pop(values: dict[str, Any], key: str, default: Any) -> Any:
    value = values.pop(key, None)
    return default if value is None else value


def _setup_logging(verbose: int) -> None:
    level = logging.WARNING - 10 * min(verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")


# -- parsers --------------------------------------------------------------------------------


class _SafePath(click.Path):
    """``click.Path`` that refuses an empty path, a NUL, an over-long path, and a folder
    where a file is expected (or the reverse) as user mistakes (exit 1, one line)."""

    def __init__(self, *, file_okay: bool = True, dir_okay: bool = True, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.want_file, self.want_dir = file_okay, dir_okay

    def convert(self, value: Any, param: Any, ctx: Any) -> Any:
        if self.allow_dash and value == "-":  # as typed: the command says what it means
            return value  # (a Path would not tell it from ./-, a file named -)
        flag = param.opts[0] if param is not None and param.opts else "path"
        flag = flag if flag.startswith("-") else flag.upper()
        if isinstance(value, str):
            from ppaloc.cli.outputs import check_path_text, refuse_folder_text

            check_path_text(value, flag)
            if not self.want_dir:
                refuse_folder_text(value, flag)
        path = Path(super().convert(value, param, ctx))
        if not self.want_dir and path.is_dir():
            raise PpalocError(f"{flag} {path} is a folder; give a file")
        if not self.want_file and path.is_file():
            raise PpalocError(f"{flag} {path} is a file; give a folder")
        return path


_CONFIG = click.option(
    "--config",
    "config_file",
    type=_SafePath(dir_okay=False, path_type=Path),
    help="TOML file with any of this command's keys; flags override it.",
)
_QUIET = click.option(
    "--quiet", "-q", is_flag=True, default=None, help="No table, no progress bar."
)

_LIVE_HOST = click.option(
    "--host",
    default="127.0.0.1",
    show_default=True,
    help="Address the --live page listens on (the default: this machine only).",
)
_LIVE_PORT = click.option(
    "--port",
    type=int,
    default=0,
    show_default=True,
    help="Port of the --live page (0: a free one).",
)
_TOLERANCE = click.option(
    "--tolerance",
    type=int,
    help="Accepted distance to the true frame, in frames [default: the dataset's own: "
    "1 for nordland and synthetic, 2 for gardens-point (0 with gt=vprbench), 0 for the "
    "other kinds; docs/datasets.md, Kinds].",
)
_RECALL = click.option(
    "--recall",
    type=click.Choice(["A", "B", "C"], case_sensitive=False),
    help="Recall definition (default A: correct accepted / queries with a true match).",
)
_RESULTS_OUT = click.option(
    "--out",
    type=_SafePath(file_okay=False, allow_dash=True, path_type=Path),
    help="Folder for results.json, results.csv, arrays/ and the report [default: results].",
)
_NO_REPORT = click.option(
    "--no-report", is_flag=True, default=None, help="Write result files only."
)


class _MethodsHelp(click.Command):
    """A command whose help ends with the methods available in this install."""

    def format_epilog(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        super().format_epilog(ctx, formatter)
        from ppaloc.methods import available_methods, registry

        names = available_methods()
        with formatter.section("Available methods"):
            formatter.write_dl([(n, registry()[n].summary) for n in names] or [("(none)", "")])


@click.group(
    context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100},
    epilog="""\b
Examples:
  ppaloc demo
  ppaloc evaluate --dataset 'synthetic:?places=300&seed=1' --method weighted-node-lbp --out run1
  ppaloc map 'nordland:../shared/data/nordland-64x32?ref=summer' --out summer.npz
  ppaloc localise summer.npz frames/ --out estimates.csv
  ppaloc score estimates.csv --dataset 'nordland:../shared/data/nordland-64x32' --out scored
  ppaloc bench --sizes 256,1024,4096
  ppaloc sweep --config sweep.toml --out sweep1
  ppaloc show run1
  ppaloc methods weighted-node-lbp     # its parameters, defaults and ranges

Run `ppaloc COMMAND --help` for each command's options.""",
)
@click.version_option(package_name="ppaloc", prog_name="ppaloc")
@click.option("--verbose", "-v", count=True, help="Log more (-v info, -vv debug).")
def cli(verbose: int) -> None:
    """Weighted node mapping and localisation on a simulated SCAMP-5 pixel processor array."""
    _setup_logging(verbose)


@cli.command(
    epilog="""\b
Examples:
  ppaloc demo                      # writes ./ppaloc-report/report.html
  ppaloc demo --out /tmp/demo --places 100"""
)
@click.option(
    "--out",
    type=_SafePath(file_okay=False, allow_dash=True, path_type=Path),
    default=Path("ppaloc-report"),
    show_default=True,
    help="Folder for results and report.",
)
@click.option(
    "--places",
    type=click.IntRange(10, 100_000),
    default=200,
    show_default=True,
    help="Route length.",
)
@click.option(
    "--bench-sizes",
    default="64,256,1024,4096",
    show_default=True,
    help="Map sizes of the latency-against-map-size figure.",
)
@_QUIET
def demo(out: Path, places: int, bench_sizes: str, quiet: bool | None) -> None:
    """Run every available method on the built-in synthetic route and write the report.

    Builds the procedural route synthetic:?places=PLACES&query=winter&seed=0&sync=1&stops=2
    (summer map; winter query at the mapping speed with two stops), evaluates every
    available method, times them against map size, prints the comparison table and
    writes OUT/report.html.
    """
    from ppaloc.cli.commands import run_demo
    from ppaloc.evaluate.config import BenchConfig

    sizes = _sizes(bench_sizes)
    BenchConfig(sizes=tuple(sizes))  # checked before any work
    out = _output(out, folder=True)
    run_demo(out, quiet=bool(quiet), places=places, bench_sizes=sizes)


@cli.command(
    cls=_MethodsHelp,
    epilog="""\b
Examples:
  ppaloc evaluate --dataset 'synthetic:?places=300&seed=1' --out run1
  ppaloc evaluate --dataset 'nordland:../shared/data/nordland-64x32?ref=summer&query=winter' \\
      --method weighted-node-lowres --method seqslam --tolerance 2 --out nordland
  ppaloc evaluate --config run.toml --recall C
  ppaloc evaluate -d 'synthetic:?query=winter' -d 'synthetic:?query=night' --out seasons
\b
run.toml:
  dataset = "synthetic:?places=300&seed=1"
  methods = ["weighted-node-lowres", "seqslam"]
  tolerance = 2
  out = "run1"
  [params.weighted-node-lowres]
  gain = 8""",
)
@click.option(
    "--dataset",
    "-d",
    "datasets",
    multiple=True,
    help="Dataset spec KIND:PATH?key=value (see docs/datasets.md); repeatable: one "
    "results folder per dataset under --out and a matrix.csv over all.",
)
@click.option(
    "--method",
    "-m",
    "methods",
    multiple=True,
    help="Method name, repeatable (default: every available method).",
)
@_TOLERANCE
@_RECALL
@click.option("--seed", type=int, help="Seed for methods that draw random numbers.")
@click.option(
    "--param",
    "params",
    multiple=True,
    metavar="METHOD.KEY=VALUE",
    help="A method parameter, repeatable, e.g. weighted-node-lowres.gain=8.",
)
@click.option(
    "--weights/--no-weights",
    "record_weights",
    default=None,
    help="Record per-node weights for the heatmap (default on).",
)
@_RESULTS_OUT
@_NO_REPORT
@_CONFIG
@_QUIET
def evaluate(
    datasets: tuple[str, ...],
    methods: tuple[str, ...],
    tolerance: int | None,
    recall: str | None,
    seed: int | None,
    params: tuple[str, ...],
    record_weights: bool | None,
    out: Path | None,
    no_report: bool | None,
    config_file: Path | None,
    quiet: bool | None,
) -> None:
    """Evaluate methods on a dataset: metrics, latency, result files and the report."""
    from ppaloc.cli.commands import run_evaluate, run_matrix
    from ppaloc.evaluate.config import EvaluateConfig, config_from_mapping, reject_unknown_keys

    file_values = _file_values(config_file, "evaluate")
    _check_file_types(EvaluateConfig, file_values, config_file, skip=("dataset",))
    flag_params = _parse_params(params)
    values = _merge(
        file_values,
        {
            "dataset": list(datasets) if len(datasets) > 1 else (datasets or [None])[0],
            "methods": methods,
            "tolerance": tolerance,
            "recall": recall,
            "seed": seed,
            "params": flag_params,
            "record_weights": record_weights,
            "out": out,
            "no_report": no_report,
            "quiet": quiet,
        },
        source=config_file,
    )
    fields = [f.name for f in dataclasses.fields(EvaluateConfig)]
    reject_unknown_keys(
        values, [*fields, "out", "no_report", "quiet"], source=str(config_file or "")
    )
    _check_method_params(values.get("params"), config_file)
    _check_flag_params_run(flag_params, values.get("methods"), None if methods else config_file)
    out_dir = _output(_pop(values, "out", "results"), folder=True)
    report = not _pop(values, "no_report", False)
    quiet_ = bool(_pop(values, "quiet", False))
    if "dataset" not in values:
        raise PpalocError(
            "no dataset: give --dataset SPEC (e.g. 'synthetic:?places=300') or dataset = in "
            "the --config file"
        )
    if isinstance(values.get("methods"), str):
        values["methods"] = [values["methods"]]
    specs = values["dataset"]
    source = str(config_file) if config_file else ""
    if isinstance(specs, list | tuple) and not specs:
        raise PpalocError(
            f"dataset = [] in {source or 'the flags'} lists no dataset: give at least one spec"
        )
    if isinstance(specs, list | tuple):
        configs = [
            config_from_mapping(EvaluateConfig, {**values, "dataset": d}, source=source)
            for d in specs
        ]
        run_matrix(configs, out_dir, quiet=quiet_, report=report)
    else:
        config = config_from_mapping(EvaluateConfig, values, source=source)
        run_evaluate(config, out_dir, quiet=quiet_, report=report)


@cli.command(
    epilog="""\b
Examples:
  ppaloc score netvlad.csv --dataset 'gardens-point:DIR?ref=day_left&query=night_right' \\
      --out scored
  ppaloc score a.csv b.csv -d 'nordland:DIR?ref=summer&query=winter' --tolerance 2
  ppaloc localise route.npz winter/ --out est.csv && ppaloc score est.csv -d SPEC
\b
PREDICTIONS columns (a header line; docs/evaluate-cli.md, Predictions files):
  query or query_name          the 0-based query index, or the query frame's file name
  reference or reference_name  the predicted reference frame (index or file name)
  score                        confidence, higher = surer
  method                       optional label (several methods in one file)
  reference_2 .. reference_K   optional next best reference frames, best first
  latency_ms, moved            optional time per query (ms) and motion decision (1/0)
A CSV of `ppaloc localise` is read as it is (frame, path, reference_frame).""",
)
@click.argument(
    "predictions",
    nargs=-1,
    required=True,
    type=_SafePath(dir_okay=False, path_type=Path),
)
@click.option(
    "--dataset", "-d", help="Dataset spec KIND:PATH?key=value whose queries were predicted."
)
@_TOLERANCE
@_RECALL
@_RESULTS_OUT
@_NO_REPORT
@_CONFIG
@_QUIET
def score(
    predictions: tuple[Path, ...],
    dataset: str | None,
    tolerance: int | None,
    recall: str | None,
    out: Path | None,
    no_report: bool | None,
    config_file: Path | None,
    quiet: bool | None,
) -> None:
    """Score PREDICTIONS files (CSV) of any method against a dataset: the metrics, result
    files and report of `ppaloc evaluate`."""
    from ppaloc.cli.commands import run_score
    from ppaloc.evaluate.config import config_from_mapping, reject_unknown_keys
    from ppaloc.evaluate.score import ScoreConfig

    file_values = _file_values(config_file, "score")
    _check_file_types(ScoreConfig, file_values, config_file, skip=("predictions",))
    values = _merge(
        file_values,
        {
            "dataset": dataset,
            "tolerance": tolerance,
            "recall": recall,
            "out": out,
            "no_report": no_report,
            "quiet": quiet,
        },
        source=config_file,
        nested=False,
    )
    source = str(config_file or "")
    reject_unknown_keys(
        values, ["dataset", "tolerance", "recall", "out", "no_report", "quiet"], source=source
    )
    out_dir = _output(_pop(values, "out", "results"), folder=True)
    report = not _pop(values, "no_report", False)
    quiet_ = bool(_pop(values, "quiet", False))
    if values.get("dataset") is None:
        raise PpalocError(
            "no dataset: give --dataset SPEC, the dataset whose queries were predicted (e.g. "
            "'folder:REF_DIR,QUERY_DIR'), or dataset = in the --config file"
        )
    values["predictions"] = [str(p) for p in predictions]
    config = config_from_mapping(ScoreConfig, values, source=source)
    run_score(config, out_dir, quiet=quiet_, report=report)


@cli.command(
    cls=_MethodsHelp,
    epilog="""\b
Examples:
  ppaloc bench
  ppaloc bench --method weighted-node-lbp --method seqslam --sizes 256,1024,4096 --out bench""",
)
@click.option("--method", "-m", "methods", multiple=True, help="Method name, repeatable.")
@click.option("--sizes", help="Comma-separated map sizes in nodes [default: 64,256,1024].")
@click.option("--queries", type=int, help="Timed frames per size [default: 20].")
@click.option("--seed", type=int, help="Seed of the random maps and frames.")
@click.option(
    "--max-build-s",
    type=float,
    help="Skip a size whose map build would take longer than this (seconds) [default: no limit].",
)
@click.option(
    "--param",
    "params",
    multiple=True,
    metavar="METHOD.KEY=VALUE",
    help="A method parameter, repeatable, e.g. seqslam.ds=20.",
)
@click.option(
    "--out",
    type=_SafePath(file_okay=False, allow_dash=True, path_type=Path),
    help="Folder for bench.json and bench.csv.",
)
@_CONFIG
@_QUIET
def bench(
    methods: tuple[str, ...],
    sizes: str | None,
    queries: int | None,
    seed: int | None,
    max_build_s: float | None,
    params: tuple[str, ...],
    out: Path | None,
    config_file: Path | None,
    quiet: bool | None,
) -> None:
    """Host time per frame against map size, every method on the same random maps."""
    from ppaloc.cli.commands import run_bench
    from ppaloc.evaluate.config import BenchConfig, config_from_mapping, reject_unknown_keys

    size_list = None if sizes is None else _sizes(sizes)
    file_values = _file_values(config_file, "bench")
    _check_file_types(BenchConfig, file_values, config_file)
    flag_params = _parse_params(params)
    values = _merge(
        file_values,
        {
            "methods": methods,
            "sizes": size_list,
            "queries": queries,
            "seed": seed,
            "max_build_s": max_build_s,
            "params": flag_params,
            "out": out,
            "quiet": quiet,
        },
        source=config_file,
    )
    fields = [f.name for f in dataclasses.fields(BenchConfig)]
    reject_unknown_keys(values, [*fields, "out", "quiet"], source=str(config_file or ""))
    out_dir = values.pop("out", None)
    quiet_ = bool(_pop(values, "quiet", False))
    config = config_from_mapping(BenchConfig, values, source=str(config_file or ""))
    _check_method_params(config.params, config_file)
    _check_flag_params_run(flag_params, config.methods, None if methods else config_file)
    out_path = None if out_dir is None else _output(out_dir, folder=True)
    run_bench(config, out_path, quiet=quiet_)


@cli.command(
    cls=_MethodsHelp,
    epilog="""\b
Examples:
  ppaloc sweep --config sweep.toml --out sweep1
  ppaloc sweep --config sweep.toml --out sweep1 --scheduler tcp://10.0.0.5:8786
  ppaloc sweep -m seqslam -m weighted-node-paper-lbp -d 'synthetic:?places=100&seed=1' \\
      --param 'weighted-node-paper-lbp.gamma=[0.25, 0.5]' --out gamma
\b
sweep.toml:
  [sweep]
  methods = ["weighted-node-paper-lbp", "seqslam"]
  datasets = ["synthetic:?places=100&seed=1", "synthetic:?places=100&seed=2"]
  tolerance = 2
  [sweep.params.weighted-node-paper-lbp]
  gamma = [0.25, 0.5]        # a list is swept; a single value is fixed
\b
Writes OUT/cells/<method>-<id>/ (one results folder per cell, the moment it finishes),
OUT/summary.csv, OUT/summary.json and OUT/report.html. Run it again to skip the finished
cells and retry the failed ones.""",
)
@click.option(
    "--out",
    type=_SafePath(file_okay=False, allow_dash=True, path_type=Path),
    help="Folder of the sweep: cells/, summary.csv, summary.json, report.html.",
)
@click.option(
    "--scheduler",
    metavar="tcp://HOST:PORT",
    help="A running Dask scheduler to run the cells on [default: a local cluster].",
)
@click.option(
    "--workers",
    type=click.IntRange(1),
    help="Worker processes of the local cluster [default: one per core].",
)
@click.option("--method", "-m", "methods", multiple=True, help="Method name, repeatable (an axis).")
@click.option(
    "--dataset", "-d", "datasets", multiple=True, help="Dataset spec, repeatable (an axis)."
)
@click.option(
    "--param",
    "params",
    multiple=True,
    metavar="METHOD.KEY=VALUE",
    help="A method parameter, repeatable; a list sweeps it, e.g. 'seqslam.ds=[10, 20]'.",
)
@_TOLERANCE
@click.option("--seed", type=int, help="Seed for methods that draw random numbers.")
@click.option("--no-report", is_flag=True, default=None, help="Write the summary files only.")
@_CONFIG
@_QUIET
def sweep(
    out: Path | None,
    scheduler: str | None,
    workers: int | None,
    methods: tuple[str, ...],
    datasets: tuple[str, ...],
    params: tuple[str, ...],
    tolerance: int | None,
    seed: int | None,
    no_report: bool | None,
    config_file: Path | None,
    quiet: bool | None,
) -> None:
    """Run a grid of methods x datasets x method parameters on a Dask cluster."""
    from ppaloc.cli.commands import run_sweep
    from ppaloc.evaluate.config import check_limits, reject_unknown_keys
    from ppaloc.evaluate.sweep import SweepConfig, sweep_config_from_mapping

    values = _merge(
        _file_values(config_file, "sweep"),
        {
            "methods": methods,
            "datasets": datasets,
            "params": _parse_params(params),
            "tolerance": tolerance,
            "seed": seed,
            "out": out,
            "scheduler": scheduler,
            "workers": workers,
            "no_report": no_report,
            "quiet": quiet,
        },
        source=config_file,
    )
    source = str(config_file or "")
    extra = ["out", "scheduler", "workers", "connect_timeout", "no_report", "quiet"]
    fields = [f.name for f in dataclasses.fields(SweepConfig)]
    reject_unknown_keys(values, [*fields, *extra], source=source)
    out_dir = values.pop("out", None)
    if out_dir is None:
        raise PpalocError(
            "no output folder: give --out DIR (or out = in the --config file); a second run "
            "with the same folder skips the finished cells"
        )
    options = {k: values.pop(k, None) for k in extra if k != "out"}
    for key in ("scheduler", "workers", "connect_timeout"):
        value = options[key]
        wanted = {"scheduler": str, "workers": int, "connect_timeout": (int, float)}[key]
        if value is not None and (not isinstance(value, wanted) or isinstance(value, bool)):
            raise PpalocError(f"{key}={value!r} in {source or 'the flags'} has the wrong type")
    if options["workers"] is not None and not 1 <= options["workers"] <= 256:
        raise PpalocError(f"workers={options['workers']!r} must be an integer in [1, 256]")
    timeout = options["connect_timeout"]
    if timeout is not None and not (math.isfinite(timeout) and 0 < timeout <= 3600):
        raise PpalocError(f"connect_timeout={timeout!r} must be a number of seconds in (0, 3600]")
    keys = ("seed", "tolerance", "max_weight_values")
    check_limits({k: values.get(k) for k in keys}, source=source)  # before any cluster starts
    # a sweep writes into its folder (cells, summary, report), never beside it
    out_dir = _output(out_dir, folder=True, in_place=True)
    config = sweep_config_from_mapping(values, source=source)
    run_sweep(
        config,
        Path(out_dir),
        scheduler=options["scheduler"],
        workers=options["workers"],
        connect_timeout=float(options["connect_timeout"] or 10.0),
        quiet=bool(options["quiet"]),
        report=not options["no_report"],
        source=source,
    )


@cli.command(
    "map",
    cls=_MethodsHelp,
    epilog="""\b
Examples:
  ppaloc map 'synthetic:?places=300' --out route.npz
  ppaloc map 'nordland:../shared/data/nordland-64x32?ref=summer' --method weighted-node-lbp \\
      --out summer-lbp.npz
  ppaloc map folder:summer/ --out summer.npz       # a folder of reference images alone
  ppaloc map video:drive.mp4?step=5 --out drive.npz""",
)
@click.argument("dataset")
@click.option(
    "--out",
    type=_SafePath(dir_okay=False, allow_dash=True, readable=False, path_type=Path),
    help="Map file to write (.npz).",
)
@click.option(
    "--method",
    "-m",
    help=f"Method whose map to build [default: {DEFAULT_MAP_METHOD}, the most accurate host "
    "filter; a map for the sensor takes a sensor place, e.g. weighted-node-lowres16].",
)
@click.option("--param", "params", multiple=True, metavar="KEY=VALUE", help="Method parameter.")
@_CONFIG
@_QUIET
def map_(
    dataset: str,
    out: Path | None,
    method: str | None,
    params: tuple[str, ...],
    config_file: Path | None,
    quiet: bool | None,
) -> None:
    """Build a map from the reference traversal of DATASET and save it.

    DATASET is a spec; folder: and video: also take the reference alone (folder:REF_DIR).
    """
    from ppaloc.cli.commands import run_map

    values = _merge(
        _file_values(config_file, "map"),
        {"out": out, "method": method, "params": _parse_method_params(params), "quiet": quiet},
        source=config_file,
        nested=False,
    )
    _reject_unknown(values, ["method", "out", "params", "quiet"], config_file, "map")
    if values.get("out") is None:
        raise PpalocError("no output file: give --out MAP.npz")
    out_file = _output(values["out"], folder=False)
    run_map(
        dataset,
        str(values.get("method") or DEFAULT_MAP_METHOD),
        out_file,
        dict(values.get("params", {})),
        quiet=bool(values.get("quiet")),
    )


@cli.command(
    cls=_MethodsHelp,
    epilog="""\b
Examples:
  ppaloc localise route.npz frames/ --out estimates.csv
  ppaloc localise route.npz q0001.png q0002.png          # CSV lines on stdout
  ppaloc localise route.npz drive.mp4 --out estimates.csv
\b
Frames are localised in the order given; a folder's images in natural order of their
names (img2 before img10). Image files of one folder given out of that order (a shell
sorts frame10 before frame2) are refused unless --keep-order.
\b
CSV columns: frame,path,node,reference_frame,score,moved,latency_ms,reference_name
(path: VIDEO#INDEX for a video frame; reference_name: the reference frame's file name,
or VIDEO#INDEX, where the map records it)""",
)
@click.argument("map_path", metavar="MAP", type=_SafePath(dir_okay=False, path_type=Path))
@click.argument("frames", nargs=-1, required=True, type=_SafePath(path_type=Path))
@click.option(
    "--out",
    type=_SafePath(dir_okay=False, allow_dash=True, readable=False, path_type=Path),
    help="CSV file to write; - or none: standard output.",
)
@click.option("--method", "-m", help="Method to localise with [default: the map's].")
@click.option("--param", "params", multiple=True, metavar="KEY=VALUE", help="Method parameter.")
@click.option(
    "--keep-order",
    is_flag=True,
    help="Localise image files in the order given even where it is not natural order.",
)
@click.option(
    "--live",
    is_flag=True,
    help="Show each frame's sensor image, node weights and estimate in a browser as it runs "
    "(on-sensor methods; the URL is printed on stderr; frames paced to 30 per second).",
)
@_LIVE_HOST
@_LIVE_PORT
@click.option(
    "--fps",
    type=float,
    default=30.0,
    show_default=True,
    help="Most frames per second the --live page lets through, so they can be watched.",
)
@_CONFIG
def localise(
    map_path: Path,
    frames: tuple[Path, ...],
    out: Path | None,
    method: str | None,
    params: tuple[str, ...],
    keep_order: bool,
    live: bool,
    host: str,
    port: int,
    fps: float,
    config_file: Path | None,
) -> None:
    """Localise FRAMES (image files, folders of images or videos, in order) against a
    saved MAP."""
    from ppaloc.cli.commands import run_localise

    view = _live_view(live, host, port, fps)
    values = _merge(
        _file_values(config_file, "localise"),
        {"out": out, "method": method, "params": _parse_method_params(params)},
        source=config_file,
        nested=False,
    )
    _reject_unknown(values, ["method", "out", "params"], config_file, "localise")
    run_localise(
        map_path,
        list(frames),
        None if values.get("out") is None else _text_output(values["out"]),
        method=values.get("method"),
        params=dict(values.get("params", {})),
        keep_order=keep_order,
        live=view,
    )


@cli.command(
    epilog="""\b
Examples:
  ppaloc show run1                  # table + run1/report.html rebuilt from the files
  ppaloc show sweep1                # a sweep's best cells + its report rebuilt
  ppaloc show route.npz --out route.png
  ppaloc show planes.npz            # every 2-D array as a register plane
  ppaloc show est.csv               # a localise CSV: its rows, and est.png"""
)
@click.argument("path", type=_SafePath(path_type=Path))
@click.option(
    "--out",
    type=_SafePath(dir_okay=False, allow_dash=True, readable=False, path_type=Path),
    help="PNG to write (maps, planes, CSV; a name ending in .png).",
)
@_QUIET
def show(path: Path, out: Path | None, quiet: bool | None) -> None:
    """Render a results folder or a sweep's (table and report), a saved map, register planes
    or a localise CSV (rows, and a plot of predicted reference against query)."""
    from ppaloc.cli.commands import run_show

    run_show(path, None if out is None else _output(out, folder=False), quiet=bool(quiet))


@cli.command(
    epilog="""\b
Examples:
  ppaloc methods                       # every method available here, one line each
  ppaloc methods weighted-node-lbp     # its parameters: default, accepted values
  ppaloc methods seqslam able-m""",
)
@click.argument("names", nargs=-1)
def methods(names: tuple[str, ...]) -> None:
    """List the methods, or each named method's parameters (the keys of --param
    METHOD.KEY=VALUE) with the default it runs with and the values accepted."""
    from ppaloc.cli.commands import run_methods

    run_methods(list(names))


@cli.command(
    "warm-up",
    epilog="""\b
Examples:
  ppaloc warm-up        # once per machine (and after an upgrade)

\b
It can take tens of minutes on a busy two-core machine; Ctrl-C keeps what it has
compiled, and the next warm-up goes on from there.""",
)
@_QUIET
def warm_up(quiet: bool | None) -> None:
    """Compile the simulator's fast code for the on-sensor pipelines now, in the
    foreground, instead of in the background of the commands that run them."""
    from ppaloc.cli.commands import run_warm_up

    run_warm_up(quiet=bool(quiet))


@cli.group()
def cpp() -> None:
    """SCAMP-5d C++ programs on the simulator (docs/cpp.md)."""


@cpp.command(
    "run",
    epilog="""\b
Examples:
  ppaloc cpp run edges.cpp --image scene.png --set threshold=30 --out edges-run
  ppaloc cpp run main.cpp extra.cpp -I inc -D THRESHOLD=30 --out run
  ppaloc cpp run tracker.cpp --dataset video:clip.mp4 --out run
  ppaloc cpp run tracker.cpp --stream /dev/video0 --stream-format v4l2 --frames 100 --out run
  ppaloc cpp run tracker.cpp --dataset 'synthetic:?places=20' --frames 5 --out run""",
)
@click.argument("program", nargs=-1, required=True, type=_SafePath(path_type=Path))
@click.option(
    "-I",
    "--include",
    "include_dirs",
    multiple=True,
    type=_SafePath(path_type=Path),
    metavar="DIR",
    help="A folder of the program's headers (repeatable), as the compiler's -I.",
)
@click.option(
    "-D",
    "--define",
    "defines",
    multiple=True,
    metavar="NAME[=VALUE]",
    help="A macro for the program (repeatable), as the compiler's -D: -D NAME=1, -DNAME.",
)
@click.option("--image", type=_SafePath(dir_okay=False, path_type=Path), help="Frame image.")
@click.option(
    "--dataset",
    help="Dataset spec whose query frames are the exposures, or a folder of images or a video "
    "alone: folder:DIR, video:FILE.mp4.",
)
@click.option(
    "--stream",
    metavar="INPUT",
    help="A live stream or camera PyAV opens (FFmpeg's -i: /dev/video0, rtsp://..., a lavfi "
    "graph), each frame decoded as the program asks for it; --frames bounds it.",
)
@click.option(
    "--stream-format",
    metavar="FMT",
    help="The stream's FFmpeg input format (FFmpeg's -f: v4l2, lavfi, ...).",
)
@click.option(
    "--stream-option",
    "stream_options",
    multiple=True,
    metavar="NAME=VALUE",
    help="An FFmpeg input option of the stream (repeatable): video_size=640x480, framerate=30.",
)
@click.option(
    "--frames",
    type=int,
    help="Frames to run [default: 1 image, all of a folder or video, 10 of a dataset or stream].",
)
@click.option(
    "--set",
    "settings",
    multiple=True,
    metavar="NAME=VALUE",
    help="A slider's or switch's value, NAME its GUI text with or without a trailing ':'.",
)
@click.option("--timeout", type=float, default=60.0, show_default=True, help="Seconds.")
@click.option(
    "--noise",
    type=click.Choice(["ideal", "low", "typical", "high"]),
    default="ideal",
    show_default=True,
    help="The simulator's noise preset.",
)
@click.option("--seed", type=int, default=0, show_default=True, help="Seed of the noise.")
@click.option(
    "--kernel-check/--no-kernel-check",
    default=True,
    show_default=True,
    help="Run a static kernel's body again at later passes to compare it with its "
    "recording, warning at the first difference (a kernel in a helper called with other "
    "registers); its other C++ statements, a counter or a printf, then run again too, "
    "which the device never does. --no-kernel-check runs each body once, as the device.",
)
@click.option(
    "--out",
    required=True,
    type=_SafePath(file_okay=False, allow_dash=True, path_type=Path),
    help="Folder to write (replaced whole when the run succeeds).",
)
@click.option(
    "--live",
    is_flag=True,
    help="Show the displays, sliders, switches and text in a browser as the program runs "
    "(the URL is printed on stderr; frames paced to 30 per second).",
)
@_LIVE_HOST
@_LIVE_PORT
@_QUIET
def cpp_run(
    program: tuple[Path, ...],
    include_dirs: tuple[Path, ...],
    defines: tuple[str, ...],
    image: Path | None,
    dataset: str | None,
    stream: str | None,
    stream_format: str | None,
    stream_options: tuple[str, ...],
    frames: int | None,
    settings: tuple[str, ...],
    timeout: float,
    noise: str,
    seed: int,
    kernel_check: bool,
    out: Path,
    live: bool,
    host: str,
    port: int,
    quiet: bool | None,
) -> None:
    """Compile PROGRAM (one or more C++ sources) against the SCAMP-5d shim and run it on
    the simulator."""
    from ppaloc.cli.commands import refuse_out_in_datasets
    from ppaloc.cpp.command import run_cpp

    view = _live_view(live, host, port)
    out_path = _output(out, folder=True)
    if dataset is not None:
        refuse_out_in_datasets(out_path, [dataset], reference=True)

    run_cpp(
        program,
        out_path,
        include_dirs=include_dirs,
        defines=defines,
        image=image,
        dataset=dataset,
        frames=frames,
        stream=stream,
        stream_format=stream_format,
        stream_options=stream_options,
        settings=settings,
        timeout=timeout,
        noise=noise,
        seed=seed,
        quiet=bool(quiet),
        live=view,
        kernel_check=kernel_check,
    )


def _live_view(live: bool, host: str, port: int, fps: float | None = None) -> Any:
    """The ``--live`` view of a command (None without ``--live``; ``--host``, ``--port``
    or ``--fps`` without it are refused)."""
    from ppaloc.cpp.live import MAX_FPS, MIN_FPS, LiveError, LiveView

    if not live:
        ctx = click.get_current_context()
        for flag in ("host", "port") if fps is None else ("host", "port", "fps"):
            if ctx.get_parameter_source(flag) is not click.core.ParameterSource.DEFAULT:
                raise PpalocError(f"--{flag} is for the live view: give --live with it")
        return None
    if fps is not None and not MIN_FPS <= fps <= MAX_FPS:
        raise LiveError(
            f"--fps {fps:g} must be a number of frames per second in [{MIN_FPS}, {MAX_FPS}]"
        )
    return LiveView(
        host,
        port,
        fps=30.0 if fps is None else fps,
        announce=lambda url: click.echo(f"live view: {url}", err=True),
    )


def _sizes(text: str) -> list[int]:
    parts = [s.strip() for s in text.split(",") if s.strip()]
    if len(text) > 1000 or not all(p.isascii() and p.isdigit() and len(p) < 20 for p in parts):
        raise PpalocError(
            f"sizes {short(text)} must be comma-separated whole numbers, e.g. 64,256,1024"
        )
    return [int(p) for p in parts]


def _reject_unknown(
    values: dict[str, Any], allowed: list[str], source: Path | None, section: str
) -> None:
    """Refuse a key of a ``map``/``localise`` section that the command does not take, and
    ``params`` that is not one method's table."""
    from ppaloc.evaluate.config import reject_unknown_keys

    reject_unknown_keys(values, allowed, source=str(source or ""))
    if not isinstance(values.get("params", {}), dict):
        raise PpalocError(
            f"params in {source} must be a table of the method's keys, e.g. "
            f"[{section}.params] followed by gain = 8"
        )


# -- launch ---------------------------------------------------------------------------------


def _crash_log(exc: BaseException) -> Path:
    fd, name = tempfile.mkstemp(prefix="ppaloc-crash-", suffix=".log")
    # an argument of bytes that are not UTF-8 is held as surrogates: written as escapes
    with open(fd, "w", encoding="utf-8", errors="backslashreplace") as f:
        f.write(" ".join(sys.argv) + "\n\n")
        f.write("".join(traceback.format_exception(exc)))
    return Path(name)


MAX_WORD = 300
"""Longest run of characters without a space a message shows whole (a path is at most
4096 characters; a 40 KB value pasted by mistake is cut)."""


def _one_line(text: str) -> str:
    """``text`` on one line, each over-long word cut to its start and its length.

    Examples
    --------
    >>> _one_line("bad   value " + "a" * 1000 + " here")[:36]
    'bad value aaaaaaaaaaaaaaaaaaaaaaaaaa'
    >>> _one_line("x" * 1000).endswith("... (1000 characters)")
    True
    """
    words = str(text).split()
    return " ".join(
        w if len(w) <= MAX_WORD else f"{w[:120]}... ({len(w)} characters)" for w in words
    )


def _show_warning(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: Any = None,
    line: str | None = None,
) -> None:
    """A warning that reaches the user, as one line (not Python's file, line and source)."""
    print(f"ppaloc: warning: {_one_line(f'{category.__name__}: {message}')}", file=sys.stderr)


class _NamedStdout:
    """``sys.stdout`` whose write errors name it: the system's error for a write to standard
    output (a full disk under ``ppaloc localise ... > est.csv``) carries no file name, and
    :func:`main` reads an error without one as a bug. Its binary ``buffer`` (which click
    writes to where the text stream's encoding cannot hold its output) is named alike;
    everything else is the stream's."""

    name = "standard output"

    def __init__(self, stream: Any) -> None:
        self._stream = stream

    def write(self, text: Any) -> int:
        try:
            return self._stream.write(text)
        except OSError as exc:
            raise self._named(exc) from None

    def writelines(self, lines: Any) -> None:
        for line in lines:
            self.write(line)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except OSError as exc:
            raise self._named(exc) from None

    @property
    def buffer(self) -> _NamedStdout:
        return _NamedStdout(self._stream.buffer)

    def _named(self, exc: OSError) -> Exception:
        if isinstance(exc, BrokenPipeError):  # not an OSError: click would exit 1 on it
            return _ReaderGone()
        if exc.filename is not None:
            return exc
        return OSError(exc.errno, exc.strerror, self.name)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


class _ReaderGone(Exception):
    """Standard output's reader stopped reading (``ppaloc localise ... | head``): not an
    error, the command ends there with exit code 0. Click turns an ``EPIPE`` it meets into
    exit code 1 without a word (and a command's own ``OSError`` handling could take it for
    a path's), so :class:`_NamedStdout` raises this instead."""


def _discard_stdout(stream: Any) -> None:
    """Point standard output's file descriptor at the null device once its reader has
    gone: what is still buffered would fail the flush at exit (``Exception ignored ...
    BrokenPipeError``, exit code 120)."""
    import os

    try:
        fd = stream.fileno()
        null = os.open(os.devnull, os.O_WRONLY)
    except (AttributeError, OSError, ValueError):  # not a file (a test's stream)
        return
    os.dup2(null, fd)
    os.close(null)


def main(argv: list[str] | None = None) -> int:
    """Run the ``ppaloc`` command; return the exit code (see the module docstring)."""
    import warnings

    shown, warnings.showwarning = warnings.showwarning, _show_warning
    stdout = sys.stdout
    if stdout is not None:
        sys.stdout = _NamedStdout(stdout)
    try:
        code = _main(argv)
    finally:
        sys.stdout = stdout
        warnings.showwarning = shown
    if code == _READER_GONE:
        _discard_stdout(stdout)
        return 0
    return code


def _main(argv: list[str] | None) -> int:
    try:
        cli.main(args=argv, prog_name="ppaloc", standalone_mode=False)
        if sys.stdout is not None:
            sys.stdout.flush()  # what is still buffered: its failure is reported here
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.exceptions.Abort:
        print("ppaloc: interrupted", file=sys.stderr)
        return 130
    except click.exceptions.NoArgsIsHelpError as exc:  # bare `ppaloc`: the help, unflattened
        print(exc.ctx.get_help(), file=sys.stderr)
        return 2
    except click.UsageError as exc:
        cmd = exc.ctx.command_path if exc.ctx is not None else "ppaloc"
        print(
            f"{cmd}: error: {_one_line(exc.format_message())} (see `{cmd} --help`)",
            file=sys.stderr,
        )
        return 1
    except click.ClickException as exc:
        print(f"ppaloc: error: {_one_line(exc.format_message())}", file=sys.stderr)
        return exc.exit_code or 1
    except PpalocError as exc:
        print(f"ppaloc: error: {_one_line(str(exc))}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("ppaloc: interrupted", file=sys.stderr)
        return 130
    except (_ReaderGone, BrokenPipeError):
        return _READER_GONE
    except OSError as exc:  # the system refused a path the user gave: not a bug
        if exc.errno not in _USER_ERRNOS or exc.filename is None:
            return _internal_error(exc)
        name = short(str(exc.filename), 120)
        fix = (
            "free some space there or give another location"
            if exc.errno in (errno.ENOSPC, errno.EDQUOT)
            else "check the path"
        )
        print(f"ppaloc: error: {exc.strerror}: {name}; {fix}", file=sys.stderr)
        return 1
    except Exception as exc:  # a bug: keep the traceback for the report, show one line
        return _internal_error(exc)
    return 0


_READER_GONE = -1
"""What :func:`_main` returns when standard output's reader has gone (exit code 0)."""

_USER_ERRNOS = frozenset(
    {
        errno.ENAMETOOLONG,
        errno.ELOOP,
        errno.EACCES,
        errno.EPERM,
        errno.ENOSPC,
        errno.EDQUOT,
        errno.EROFS,
        errno.ENOTDIR,
        errno.EISDIR,
        errno.ENOENT,
        errno.ENXIO,
    }
)
"""OS errors that name a path the user gave or the space it lives in (exit 1, not 3)."""


def _internal_error(exc: BaseException) -> int:
    """Keep the traceback for the report, show one line (exit 3)."""
    path = _crash_log(exc)
    log.debug("internal error", exc_info=exc)
    print(
        f"ppaloc: internal error ({type(exc).__name__}: {_one_line(str(exc))[:300]}); "
        f"this is a bug, the traceback is in {path}",
        file=sys.stderr,
    )
    return 3
