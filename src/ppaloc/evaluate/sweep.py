"""Parameter sweeps: a grid of methods x datasets x method parameters, every cell on a
Dask cluster (a local one by default, or an existing scheduler).

The grid, its cells and their folders are in :mod:`ppaloc.evaluate.sweep_grid`
(re-exported here); this module runs the cells. How a sweep keeps its work:

- everything is checked on the client before any cell runs: the configuration keys, the
  method names, the dataset specs (parsed, not loaded) and every cell's parameters
  (:func:`ppaloc.methods.make_localiser`); then the scheduler is reached;
- finished cells (``results.json`` exists and parses) are skipped, so a second run of the
  same sweep runs only what is missing or failed;
- workers load each dataset from its spec string (one task per dataset, shared by its
  cells: the client never loads frames, let alone ships them), run a cell and return its
  result files; the client writes them atomically the moment the cell finishes,
  ``results.json`` last, so a crash, a killed worker or Ctrl-C loses no finished cell
  (Dask re-runs a task whose worker died);
- a failed cell is recorded (``error.json``, one-line message) and the others go on;
- ``OUT/summary.csv`` and ``OUT/summary.json`` are rebuilt from the cell folders at the
  end, and after an interruption.

Every method that takes a ``seed`` gets the cell's seed, so a cell's metrics do not depend
on the number of workers or on the order in which cells run.

``dask.distributed`` is imported only when a sweep runs, not with this module.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
import os
import signal
import tempfile
import threading
import traceback
import uuid
from collections import Counter
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc import __version__
from ppaloc.errors import DataError, PpalocError
from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.sweep_grid import (
    COMBINE,
    METRIC_COLUMNS,
    SWEEP_NAMES,
    Cell,
    SweepConfig,
    axes,
    cell_status,
    collect_summary,
    expand,
    one_line_error,
    sweep_config_from_mapping,
    sweep_wrote,
    validate,
    write_cell,
    write_cell_error,
    write_summary,
)
from ppaloc.fileio import check_replaceable_folder, held_interrupt

__all__ = [
    "COMBINE",
    "METRIC_COLUMNS",
    "SWEEP_NAMES",
    "Cell",
    "SweepConfig",
    "SweepOutcome",
    "axes",
    "cell_status",
    "collect_summary",
    "connect",
    "expand",
    "run_sweep",
    "sweep_config_from_mapping",
    "validate",
    "write_summary",
]

log = logging.getLogger(__name__)


# -- on the workers ---------------------------------------------------------------------------


def _worker_version() -> str:
    """Run on every worker before a sweep: the ppaloc version it imports."""
    return __version__


def _load_dataset(spec: str) -> Any:
    """Run on a worker: the dataset of ``spec`` with every frame read (native size), so the
    cells on it share one load."""
    from ppaloc.datasets.registry import load_dataset

    ds = load_dataset(spec)
    return dataclasses.replace(
        ds,
        reference=[np.asarray(ds.reference[i]) for i in range(len(ds.reference))],
        query=[np.asarray(ds.query[i]) for i in range(len(ds.query))],
        ground_truth=[np.asarray(g) for g in ds.ground_truth],
    )


def _run_cell(config: dict[str, Any], dataset: Any) -> dict[str, bytes]:
    """Run on a worker: one cell's evaluation; its result files as ``{relative path: bytes}``
    (written by :func:`ppaloc.evaluate.results.write_results`)."""
    from ppaloc.evaluate.results import write_results
    from ppaloc.evaluate.run import run_evaluation

    result = run_evaluation(EvaluateConfig(**config), dataset=dataset, progress=False)
    with tempfile.TemporaryDirectory(prefix="ppaloc-cell-") as tmp:
        write_results(result, tmp)  # a private folder: no transaction needed
        root = Path(tmp)
        return {
            p.relative_to(root).as_posix(): p.read_bytes()
            for p in sorted(root.rglob("*"))
            if p.is_file()
        }


# -- the cluster -----------------------------------------------------------------------------


def _probe(address: str, timeout: float) -> None:
    """Refuse an unreachable ``tcp://HOST:PORT`` at once, before Dask retries for ``timeout``,
    and an address of a scheme Dask does not speak (``http://``: Dask's own error left a
    half-made client whose clean-up printed a traceback)."""
    import socket

    from distributed.comm import registry

    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    try:  # Dask's own and those a package adds (an entry point Dask loads when first named)
        registry.get_backend(scheme)
    except ValueError:
        scheme_known = False
    else:
        scheme_known = scheme != "inproc"  # inproc: inside one process only
    if not scheme_known:
        known = ", ".join(f"{s}://" for s in sorted(registry.backends) if s != "inproc")
        raise PpalocError(
            f"--scheduler {address!r}: Dask reaches a scheduler by {known}, not {scheme}://; "
            "e.g. tcp://10.0.0.5:8786"
        )
    if scheme not in ("tcp", "tls"):
        return
    host, colon, port = rest.rpartition(":")
    if not colon or not port.isdigit() or not host:
        raise PpalocError(
            f"--scheduler {address!r} must look like tcp://HOST:PORT, e.g. tcp://10.0.0.5:8786"
        )
    if not 1 <= int(port) <= 65535:  # no scheduler can listen there: not a start-one advice
        raise PpalocError(f"--scheduler {address!r}: port {int(port)} must be in [1, 65535]")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout):
            pass
    except OSError as exc:
        raise PpalocError(
            f"cannot reach the Dask scheduler at {address} ({exc.strerror or exc}); start one "
            "with `dask scheduler` and workers with `dask worker ADDRESS`, or drop --scheduler "
            "for a local cluster"
        ) from None


def _quiet_dask() -> bool:
    """Silence distributed's logging unless ppaloc logs at INFO or below (``-v``)."""
    return logging.getLogger("ppaloc").getEffectiveLevel() > logging.INFO


@contextmanager
def connect(
    scheduler: str | None = None, *, workers: int | None = None, connect_timeout: float = 10.0
) -> Iterator[Any]:
    """A ``distributed.Client``: on the scheduler at ``scheduler``, or on a new
    ``LocalCluster`` of ``workers`` single-threaded worker processes (default: one per
    core), closed at the end.

    Raises
    ------
    PpalocError
        An unreachable scheduler, one without workers, or workers without ppaloc (or with
        another version of it).
    """
    import distributed  # noqa: F401  (its import sets its loggers' levels: before ours)

    with _dask_logging(quiet=_quiet_dask()):
        with _client(scheduler, workers=workers, connect_timeout=connect_timeout) as client:
            yield client


#: The loggers a sweep quiets (unless ``-v``), and the level each is set to: distributed's
#: own at ERROR; tornado's callback errors (``tornado.application``), which the cluster's
#: event loop logs with a traceback when Ctrl-C stops it mid-callback, at CRITICAL (Dask's
#: own default for ``tornado``; nothing a user of a sweep can act on).
QUIET_LOGGERS = (
    ("distributed", logging.ERROR),
    ("tornado", logging.CRITICAL),
    ("tornado.application", logging.CRITICAL),
)


@contextmanager
def _dask_logging(*, quiet: bool) -> Iterator[None]:
    """The loggers of :data:`QUIET_LOGGERS` at their levels while a sweep runs (unless
    ``-v``), restored after."""
    loggers = [(logging.getLogger(name), level) for name, level in QUIET_LOGGERS]
    before = [logger.level for logger, _ in loggers]
    if quiet:
        for logger, level in loggers:
            logger.setLevel(level)
    try:
        yield
    finally:
        for (logger, _), level in zip(loggers, before, strict=True):
            logger.setLevel(level)


@contextmanager
def _client(scheduler: str | None, *, workers: int | None, connect_timeout: float) -> Iterator[Any]:
    from distributed import Client, LocalCluster

    if scheduler:
        _probe(scheduler, connect_timeout)
        try:
            client = Client(scheduler, timeout=connect_timeout, set_as_default=False)
        except (OSError, TimeoutError, ValueError) as exc:
            raise PpalocError(
                f"cannot connect to the Dask scheduler at {scheduler}: {' '.join(str(exc).split())}"
            ) from None
        try:
            _check_workers(client, scheduler, connect_timeout)
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    quiet = _quiet_dask()  # the worker processes' logging
    cluster = client = None
    try:
        with _sigint_deferred():  # the start-up whole, then Ctrl-C (the cluster then closes)
            cluster = LocalCluster(
                n_workers=n,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",  # a free port: never the "8787 is in use" warning
                # A failed cell is recorded with its error; the worker's own "Compute
                # Failed" log of it would only repeat it on stderr.
                silence_logs=logging.CRITICAL if quiet else False,
            )
            client = Client(cluster, set_as_default=False)
            from ppaloc.evaluate._sweep_plugin import IgnoreSigint

            client.register_plugin(IgnoreSigint(), name=IgnoreSigint.name)
        _check_workers(client, "the local cluster", connect_timeout)
        yield client
    finally:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()


@contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Hold Ctrl-C back while a local cluster starts; raise it (KeyboardInterrupt) after.

    SIGINT is blocked in this thread: the cluster's threads, and the worker processes they
    spawn, inherit the mask, so a worker never sees Ctrl-C from its first instruction
    (the IgnoreSigint plugin comes only once it runs) and none prints a traceback as it
    dies. Here a Ctrl-C is recorded and raised once the cluster and its client are whole,
    so that they close cleanly instead of half-made.
    """
    came: list[bool] = []
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, lambda *_: came.append(True)) if main else None
    mask = None
    if hasattr(signal, "pthread_sigmask"):
        from multiprocessing import resource_tracker

        # started first: starting it unblocks SIGINT in the thread that does (Python 3.11)
        resource_tracker.ensure_running()
        mask = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        if mask is not None:
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)
        if main:
            signal.signal(signal.SIGINT, previous or signal.default_int_handler)
    if came:
        raise KeyboardInterrupt


def _check_workers(client: Any, where: str, timeout: float) -> None:
    try:
        client.wait_for_workers(1, timeout=timeout)
    except TimeoutError:
        raise PpalocError(
            f"the Dask scheduler at {where} has no workers after {timeout:g} s; start some with "
            "`dask worker ADDRESS`"
        ) from None
    try:
        versions = client.run(_worker_version)
    except Exception as exc:  # the workers cannot unpickle a ppaloc function
        raise PpalocError(
            f"the workers of {where} cannot run ppaloc ({one_line_error(exc)}); install ppaloc "
            f"{__version__} on every worker"
        ) from None
    other = {a: v for a, v in versions.items() if v != __version__}
    if other:
        addr, version = next(iter(other.items()))
        raise PpalocError(
            f"worker {addr} runs ppaloc {version}, this client {__version__}; install the same "
            "version on every worker"
        )


# -- running a sweep ---------------------------------------------------------------------------


@dataclass(frozen=True)
class SweepOutcome:
    """What a sweep did.

    Attributes
    ----------
    out : Path
        The output folder.
    summary : dict
        The content of ``summary.json`` (:func:`collect_summary`).
    n_cells, n_skipped, n_run, n_failed : int
        Cells in the grid, already finished before this run, run now, failed now.
    failures : list of (Cell, str)
        The cells that failed in this run and their one-line errors.
    """

    out: Path
    summary: dict[str, Any]
    n_cells: int
    n_skipped: int
    n_run: int
    n_failed: int
    failures: list[tuple[Cell, str]] = field(default_factory=list)


CellHook = Callable[[Cell, str], None]
"""Called on the client as ``hook(cell, status)`` after a cell's files are written."""


def check_sweep_folder(out: Path) -> None:
    """Refuse an ``out`` that is a file, or a folder holding files a sweep did not write, at
    its top or inside ``figures/`` and ``cells/`` (:func:`sweep_wrote`): its cell folders,
    figures and summaries are replaced, a user's files must not go with them. An absent or
    empty folder, or an earlier sweep's (to resume it), is fine."""
    written: dict[Path, frozenset[str]] = {}
    check_replaceable_folder(
        out,
        owned=lambda folder, name: sweep_wrote(folder, name, written),
        marked=lambda folder: (folder / "cells").is_dir() or (folder / "summary.json").is_file(),
        markers="cells/ or summary.json",
        writer="a sweep",
        kind="sweep folder",
        error=DataError,
        nested=True,
    )


def run_sweep(
    config: SweepConfig,
    out: str | Path,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    client: Any = None,
    connect_timeout: float = 10.0,
    progress: bool = False,
    on_cell: CellHook | None = None,
    source: str = "",
) -> SweepOutcome:
    """Run every unfinished cell of ``config`` on a Dask cluster; write ``out``.

    Parameters
    ----------
    config : SweepConfig
    out : str or Path
        Output folder: ``cells/<method>-<id>/`` (a results folder per cell),
        ``summary.csv`` and ``summary.json``.
    scheduler : str, optional
        Address of a running scheduler (``tcp://HOST:PORT``); default a ``LocalCluster``.
    workers : int, optional
        Worker processes of the local cluster (default: one per core).
    client : distributed.Client, optional
        Use this client instead (tests, scripts); it is not closed.
    connect_timeout : float
        Seconds to wait for the scheduler and its first worker.
    progress : bool
        A progress bar over the cells on a terminal.
    on_cell : callable, optional
        ``on_cell(cell, status)`` after each cell's files are written.
    source : str
        Where the configuration came from, for messages.

    Returns
    -------
    SweepOutcome

    Raises
    ------
    PpalocError
        Before any cell runs: a bad key, method, dataset spec or parameter, or an
        unreachable scheduler.
    KeyboardInterrupt
        After cancelling the cells in flight and rebuilding the summary.
    """
    out = Path(out)
    check_sweep_folder(out)
    cells = expand(config)
    validate(config, cells, source=source)
    todo = [c for c in cells if cell_status(out, c)[0] != "ok"]
    n_skipped = len(cells) - len(todo)
    failures: list[tuple[Cell, str]] = []
    n_run = 0
    if todo:
        from contextlib import nullcontext

        context = (
            nullcontext(client)
            if client is not None
            else connect(scheduler, workers=workers, connect_timeout=connect_timeout)
        )
        completed = False
        try:
            with context as active:
                out.mkdir(parents=True, exist_ok=True)
                n_run = _run_cells(
                    active, todo, out, len(cells), n_skipped, failures, progress, on_cell
                )
            completed = True
        finally:
            if not completed and out.is_dir():  # interrupted: the summary of what finished
                write_summary(config, out)
    summary = write_summary(config, out)
    order = {c.id: i for i, c in enumerate(cells)}
    failures.sort(key=lambda f: order[f[0].id])  # in grid order, not in order of completion
    return SweepOutcome(
        out=out,
        summary=summary,
        n_cells=len(cells),
        n_skipped=n_skipped,
        n_run=n_run,
        n_failed=len(failures),
        failures=failures,
    )


def _run_cells(
    client: Any,
    todo: Sequence[Cell],
    out: Path,
    total: int,
    done: int,
    failures: list[tuple[Cell, str]],
    progress: bool,
    on_cell: CellHook | None,
) -> int:
    """Submit ``todo`` (one dataset task per spec, one task per cell) and write each cell
    as it finishes; return the cells finished or failed. On any exit (Ctrl-C included) the
    tasks still in flight are cancelled and the summary is left to the caller."""
    from distributed import as_completed

    from ppaloc.evaluate.run import ProgressBar

    token = uuid.uuid4().hex[:8]
    datasets: dict[str, Any] = {}
    left = Counter(c.spec for c in todo)
    futures: dict[Any, Cell] = {}
    n = 0
    try:
        for cell in todo:
            if cell.spec not in datasets:
                key = hashlib.sha256(cell.spec.encode("utf-8")).hexdigest()[:12]
                datasets[cell.spec] = client.submit(
                    _load_dataset, cell.spec, key=f"ppaloc-dataset-{key}-{token}", pure=False
                )
            config = cell.evaluate_config().to_dict()
            future = client.submit(
                _run_cell,
                config,
                datasets[cell.spec],
                key=f"ppaloc-cell-{cell.id}-{token}",
                pure=False,
            )
            futures[future] = cell
        with ProgressBar(progress) as bar:
            bar.add("cells", total, label=f"sweep cells ({done} already done)")
            bar("cells", done)
            held_interrupt()  # one held before this run is not this run's
            for future in as_completed(list(futures), loop=client.loop):
                cell = futures.pop(future)
                status = _collect(future, cell, out)
                if held_interrupt():  # Ctrl-C while the cell's folder went in: it stays
                    raise KeyboardInterrupt
                if status != "ok":
                    failures.append((cell, status))
                    log.info("cell %s failed: %s", cell.label(), status)
                else:
                    log.info("cell %s done", cell.label())
                future.release()
                left[cell.spec] -= 1
                if not left[cell.spec]:
                    datasets.pop(cell.spec).release()
                n += 1
                bar("cells", done + n)
                if on_cell is not None:
                    on_cell(cell, status)
    finally:
        pending = [*futures, *datasets.values()]
        if pending:
            try:
                client.cancel(pending)
            except Exception as exc:  # a lost scheduler: nothing left to cancel there
                log.warning("could not cancel %d tasks: %s", len(pending), one_line_error(exc))
    return n


def _collect(future: Any, cell: Cell, out: Path) -> str:
    """Write a completed future's cell (its files, or its error); return its status."""
    try:
        files = future.result()
    except (KeyboardInterrupt, SystemExit):
        raise
    except BaseException as exc:  # the cell failed: its error, a lost worker, a cancellation
        line = one_line_error(exc)
        trace = "".join(traceback.format_exception(exc))
        write_cell_error(out, cell, line, trace)
        return line
    write_cell(out, cell, files)
    return "ok"
