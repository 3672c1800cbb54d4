"""Max F1 of the weighted-node filter against the baselines on every route we can build.

Not collected by pytest. Run from anywhere (paths resolve from this file)::

    .venv/bin/python benchmarks/eval_robust.py                       # every route and method
    .venv/bin/python benchmarks/eval_robust.py --routes "seed=1" --methods single-frame
    .venv/bin/python benchmarks/eval_robust.py --param particle-filter.sigma_rel=0.2
    .venv/bin/python benchmarks/eval_robust.py --sweep weighted-node-lbp.alpha=2,4,8,16
    .venv/bin/python benchmarks/eval_robust.py --json robust.json
    .venv/bin/python benchmarks/eval_robust.py --representations     # filter x descriptor
    .venv/bin/python benchmarks/eval_robust.py --representations --held-out
    .venv/bin/python benchmarks/eval_robust.py --representations --seed-spread 10

Routes (:func:`routes`): Nordland summer -> winter (tolerance +-2) and its sparse
patch-normalised variant (every 10th frame, ``patch_norm=8``, tolerance +-1), three Gardens
Point pairs (tolerance +-2), all from ``../shared/data`` next to the project (skipped with
a note when absent), and 60 generated routes: seeds 1-5 x ``speed_var`` 0.2 / 0.65 x with
or without stops x a winter, autumn or dusk query against a summer map (``--places``
places, default 200; tolerance +-1, the generator's default). "With stops" is the
generator's default count (one per 150 places, at least one); "without" is ``stops=0``.
``--held-out`` runs the routes of :func:`held_out_routes` instead (the four real pairs the
other way round and 36 generated routes, none of which a default was chosen on: the road
with turns, the indoor lab, night).

Every method is run as ``ppaloc evaluate`` runs it (``ppaloc.evaluate.run``: the sensor
front-end once per route, then ``run_method`` per method, ``seed=0`` where a method takes
one, recall definition A) and its max F1 is reported. Routes run in a process pool
(``--jobs``, default 2). Baseline results (every method whose name does not start with
``weighted-node`` or ``onsensor``) are cached in ``.cache/eval_robust/``, keyed by the
spec, the method, its parameters and a hash of the sources that decide them
(``ppaloc/baselines``, ``ppaloc/datasets``, ``ppaloc/frontend.py``, ``ppaloc/place``, whose
functions compute every baseline's image and places, ``ppaloc/localise/enhance.py``, whose
contrast enhancement SeqSLAM and the particle filter call, ``ppaloc/localise/base.py``,
``ppaloc/topomap``, ``ppaloc/evaluate/metrics.py`` and ``run.py``, ``ppaloc/methods.py``,
and the values of the low-res places' normalisation constants the baselines read from
``ppaloc/localise/params.py``); ``--no-cache`` ignores it. SIGTERM (``kill PID``) ends the
pool's workers with the script, as Ctrl-C does (:func:`route_pool`).

Output: a Markdown table (route x method, max F1, and ``best WN - best baseline``: the
best of the weighted-node places (:data:`WN_BEST`) minus the best baseline) and a summary
line; with ``--sweep METHOD.key=v1,v2,...`` a table route x value with the mean and the
minimum over routes instead.

``--representations`` gives every filter the same information: each baseline that takes a
``descriptor`` (:func:`descriptor_columns`) runs once per descriptor, the weighted-node
filter's places first and the method's own last (``particle-filter/lowres``, ``/lowres16``,
``/lbp``, ``/haar``, ``/patch``; ABLE-M, binary only, on ``lbp`` and its own ``ldb``), next
to the weighted-node filter on each place (:data:`REPRESENTATION_METHODS` unless
``--methods`` names others). After the route table
comes a table of route groups (:func:`route_group`: each real route, each generated
condition over its seeds) with the means over the real, the generated and all routes,
then the line of the filter's target on the same information (:func:`same_place_summary`):
on how many routes the better weighted-node place (the one of highest max F1, chosen by
the filter's own figures) scores at least the particle filter on that place, by how much
each of the others falls short, and, a weaker count beside it, on how many some place
does (five places give five chances) and each place's own count. ``--seed-spread K`` runs the
particle filter on each of those others' place at K seeds in all (the table's seed
among them) and prints its mean, spread and range there beside the weighted-node filter's
figure, which draws nothing: how much of a shortfall is one seed's luck.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import hashlib
import json
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"
CACHE_DIR = ROOT / ".cache" / "eval_robust"
SOURCES = (
    "src/ppaloc/baselines",
    "src/ppaloc/datasets",
    "src/ppaloc/frontend.py",
    "src/ppaloc/place",
    "src/ppaloc/localise/enhance.py",
    "src/ppaloc/localise/base.py",
    "src/ppaloc/topomap",
    "src/ppaloc/evaluate/metrics.py",
    "src/ppaloc/evaluate/run.py",
    "src/ppaloc/methods.py",
)
"""What a cached baseline figure depends on besides its spec, method and parameters (with
:data:`SHARED_VALUES`)."""

SHARED_VALUES = ("DEFAULT_CONTRAST", "DEFAULT_CONTRAST_PATCH")
"""Constants of ``ppaloc.localise.params`` the baselines read (the low-res places'
normalisation, ``ppaloc.baselines._descriptors``): their values join the hash, not the
file, which the filter's every default would change."""

DEFAULT_METHODS = (
    "weighted-node-lbp",
    "weighted-node-lowres",
    "weighted-node-lowres16",
    "weighted-node-haar",
    "weighted-node-patch",
    "weighted-node-paper-lbp",
    "weighted-node-paper-lowres",
    "particle-filter",
    "seqslam",
    "able-m",
    "single-frame",
)
REPRESENTATION_METHODS = (
    "weighted-node-lowres",
    "weighted-node-lowres16",
    "weighted-node-lbp",
    "weighted-node-haar",
    "weighted-node-patch",
    "particle-filter",
    "seqslam",
    "single-frame",
    "able-m",
)
"""The methods of ``--representations`` (each baseline expanded by :func:`descriptor_columns`)."""
WN_BEST = (
    "weighted-node-lbp",
    "weighted-node-lowres",
    "weighted-node-lowres16",
    "weighted-node-haar",
    "weighted-node-patch",
)
"""The weighted-node methods the ``best WN - best baseline`` column takes the better of."""
HOST_ONLY = ("weighted-node-patch",)
"""Of :data:`WN_BEST`, the places no sensor holds: the summary counts the better of the
others on its own line too."""
SEEDS = (1, 2, 3, 4, 5)
SPEED_VARS = (0.2, 0.65)
QUERIES = ("winter", "autumn", "dusk")
GP_PAIRS = (("day_left", "day_right"), ("day_right", "night_right"), ("day_left", "night_right"))
SEED = 0
"""``seed`` given to every method that takes one (``ppaloc evaluate``'s default)."""


def routes(data_dir: Path | str | None = DATA, places: int = 200) -> list[tuple[str, str]]:
    """Every route of the benchmark as ``(label, spec)``, real data first.

    The real-data routes need ``data_dir/nordland-64x32`` and ``data_dir/gardens-point``;
    those missing (or ``data_dir=None``) are left out with a note on stderr.
    """
    out: list[tuple[str, str]] = []
    data = None if data_dir is None else Path(data_dir)
    nordland = None if data is None else data / "nordland-64x32"
    if nordland is not None and nordland.is_dir():
        base = f"nordland:{nordland}?ref=summer&query=winter"
        out.append(("nordland summer->winter", f"{base}&tolerance=2"))
        out.append(
            (
                "nordland summer->winter step=10 patch_norm=8",
                f"{base}&step=10&patch_norm=8&tolerance=1",
            )
        )
    else:
        print(f"note: {nordland} not found: the Nordland routes are skipped", file=sys.stderr)
    gp = None if data is None else data / "gardens-point"
    if gp is not None and gp.is_dir():
        for ref, query in GP_PAIRS:
            out.append(
                (f"gp {ref}->{query}", f"gardens-point:{gp}?ref={ref}&query={query}&tolerance=2")
            )
    else:
        print(f"note: {gp} not found: the Gardens Point routes are skipped", file=sys.stderr)
    for seed in SEEDS:
        for speed_var in SPEED_VARS:
            for stops in (True, False):
                for query in QUERIES:
                    label = (
                        f"synthetic seed={seed} speed_var={speed_var} "
                        f"{'stops' if stops else 'no-stops'} {query}"
                    )
                    spec = (
                        f"synthetic:?places={places}&query={query}&seed={seed}"
                        f"&speed_var={speed_var}"
                    )
                    out.append((label, spec if stops else f"{spec}&stops=0"))
    return out


HELD_OUT_SEEDS = (2, 3, 4, 5)
HELD_OUT_TURN_QUERIES = ("autumn", "winter", "dusk", "night")
LAB_SEEDS = (2, 3, 4)
LAB_QUERIES = ("changed", "moved", "people", "dim")
NIGHT_SEEDS = (1, 2, 3, 4)
REVERSED_PAIRS = (
    ("nordland-64x32", "nordland", "winter", "summer"),
    ("gardens-point", "gardens-point", "day_right", "day_left"),
    ("gardens-point", "gardens-point", "night_right", "day_right"),
    ("gardens-point", "gardens-point", "night_right", "day_left"),
)
"""``(folder, loader, ref, query)``: the real pairs of :func:`routes` with map and query
exchanged (tolerance +-2, as there)."""


def _reversed_real_routes(data_dir: Path | str | None) -> list[tuple[str, str]]:
    """The :data:`REVERSED_PAIRS` whose folder is under ``data_dir``; a note for the rest."""
    out: list[tuple[str, str]] = []
    missing: set[Path | None] = set()
    for folder, loader, ref, query in REVERSED_PAIRS:
        root = None if data_dir is None else Path(data_dir) / folder
        if root is None or not root.is_dir():
            missing.add(root)
            continue
        short = "gp" if loader == "gardens-point" else loader
        out.append(
            (f"{short} {ref}->{query}", f"{loader}:{root}?ref={ref}&query={query}&tolerance=2")
        )
    for root in sorted(missing, key=str):
        print(f"note: {root} not found: its reversed pairs are skipped", file=sys.stderr)
    return out


def held_out_routes(data_dir: Path | str | None = DATA, places: int = 200) -> list[tuple[str, str]]:
    """Routes on which no default was chosen, as ``(label, spec)``: four real pairs of
    :func:`routes` the other way round (:data:`REVERSED_PAIRS`: the map from the traversal
    that was the query; needs ``data_dir``, skipped with a note like :func:`routes`), then
    the generated ones: the road with eight turns (seeds 2-5; a summer map, an autumn,
    winter, dusk or night query), the indoor lab (seeds 2-4, 150 places, as
    ``eval_worlds.py``; each of its changed conditions) and the straight road at night
    (seeds 1-4, ``speed_var`` 0.2 and 0.65, the generator's stops): worlds and a
    condition that :func:`routes` does not hold.

    Examples
    --------
    >>> held = [label for label, _ in held_out_routes(None)]
    >>> len(held), held[0], held[-1]
    (36, 'synthetic seed=2 turns=8 autumn', 'synthetic seed=4 speed_var=0.65 stops night')
    """
    out = _reversed_real_routes(data_dir)
    for seed in HELD_OUT_SEEDS:
        for query in HELD_OUT_TURN_QUERIES:
            spec = f"synthetic:?places={places}&turns=8&query={query}&seed={seed}"
            out.append((f"synthetic seed={seed} turns=8 {query}", spec))
    for seed in LAB_SEEDS:
        for query in LAB_QUERIES:
            spec = f"synthetic:?world=lab&places=150&query={query}&seed={seed}"
            out.append((f"synthetic seed={seed} lab {query}", spec))
    for seed in NIGHT_SEEDS:
        for speed_var in SPEED_VARS:
            spec = f"synthetic:?places={places}&query=night&seed={seed}&speed_var={speed_var}"
            out.append((f"synthetic seed={seed} speed_var={speed_var} stops night", spec))
    return out


# -- parameters -----------------------------------------------------------------------------


def parse_value(text: str) -> Any:
    """A flag value as a Python literal where it is one (``8``, ``0.5``, ``'x'``, ``(1, 2)``,
    ``True``; also ``true``/``false``), else the text itself."""
    text = text.strip()
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def parse_param(item: str) -> tuple[str, str, str]:
    """``METHOD.key=value`` -> ``(method, key, value text)``."""
    key, eq, value = item.partition("=")
    method, dot, name = key.rpartition(".")
    if not eq or not dot or not method.strip() or not name.strip():
        raise SystemExit(
            f"error: {item!r} must look like METHOD.key=value, e.g. weighted-node-lbp.alpha=8"
        )
    return method.strip(), name.strip(), value


def add_param_option(parser: argparse.ArgumentParser) -> None:
    """``--param METHOD.key=value``, repeatable, read by :func:`parse_params`."""
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="METHOD.key=value",
        help="a method parameter (repeatable; values parsed as Python literals)",
    )


def parse_params(items: Sequence[str]) -> dict[str, dict[str, Any]]:
    """``--param`` items (``METHOD.key=value``) as each method's parameters.

    Examples
    --------
    >>> parse_params(["weighted-node-lbp.gain=8", "weighted-node-lbp.contrast=off"])
    {'weighted-node-lbp': {'gain': 8, 'contrast': 'off'}}
    """
    params: dict[str, dict[str, Any]] = {}
    for item in items:
        method, key, value = parse_param(item)
        params.setdefault(method, {})[key] = parse_value(value)
    return params


def descriptor_columns(name: str, user: dict[str, Any]) -> list[tuple[str, str, dict[str, Any]]]:
    """The ``(column, method, params)`` jobs of method ``name`` under ``--representations``.

    A method that declares a ``descriptor`` parameter with a fixed set of values runs once
    per value, the others first and its own (the default) last, in columns
    ``NAME/DESCRIPTOR``; any other method is one column. ``user`` must not set the
    descriptor itself.

    Examples
    --------
    >>> [c.split("/")[1] for c, _, _ in descriptor_columns("particle-filter", {})]
    ['lowres', 'lowres16', 'lbp', 'haar', 'patch']
    >>> [c for c, _, p in descriptor_columns("able-m", {"length": 20})]
    ['able-m/lbp', 'able-m/haar', 'able-m/ldb']
    >>> descriptor_columns("weighted-node-lbp", {})
    [('weighted-node-lbp', 'weighted-node-lbp', {})]
    """
    from typing import Literal, get_args, get_origin

    from ppaloc.methods import method_parameters

    declared = (method_parameters(name) or {}).get("descriptor")
    if declared is None or get_origin(declared.hint) is not Literal:
        return [(name, name, dict(user))]
    if "descriptor" in user:
        raise SystemExit(
            f"error: --representations runs {name} on every descriptor; drop "
            f"--param {name}.descriptor={user['descriptor']!r}"
        )
    values = [v for v in get_args(declared.hint) if v != declared.default] + [declared.default]
    return [(f"{name}/{v}", name, {**user, "descriptor": v}) for v in values]


def route_group(label: str) -> str:
    """The group a route's figures are averaged in: a real route is its own group, a
    generated one is its condition over the seeds.

    Examples
    --------
    >>> route_group("synthetic seed=3 speed_var=0.2 stops winter")
    'generated, speed_var=0.2, stops, winter'
    >>> route_group("gp day_left->day_right")
    'gp day_left->day_right'
    """
    words = label.split()
    if words[:1] != ["synthetic"]:
        return label
    return "generated, " + ", ".join(w for w in words[1:] if not w.startswith("seed="))


def is_cached_method(name: str) -> bool:
    """Baselines are cached; the weighted-node and on-sensor methods (under work) are not."""
    return not name.startswith(("weighted-node", "onsensor"))


def source_hash(root: Path = ROOT) -> str:
    """SHA-256 over the values of :data:`SHARED_VALUES` and the paths and bytes of every
    ``.py`` file under :data:`SOURCES`."""
    from ppaloc.localise import params

    h = hashlib.sha256()
    for name in SHARED_VALUES:
        h.update(f"{name}={getattr(params, name)!r}\0".encode())
    for rel in SOURCES:
        p = root / rel
        files = sorted(p.rglob("*.py")) if p.is_dir() else [p] if p.is_file() else []
        for f in files:
            h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
    return h.hexdigest()


def _cache_file(cache_dir: Path, spec: str, method: str, params: dict, source: str) -> Path:
    key = json.dumps(
        {"spec": spec, "method": method, "params": params, "source": source, "recall": "A"},
        sort_keys=True,
        default=repr,
    )
    return cache_dir / f"{hashlib.sha256(key.encode()).hexdigest()[:32]}.json"


# -- one route --------------------------------------------------------------------------------


def evaluate_route(
    label: str,
    spec: str,
    jobs: Sequence[tuple[str, str, dict[str, Any]]],
    cache_dir: str | None,
    source: str,
) -> dict[str, Any]:
    """Run every ``(column, method, params)`` of ``jobs`` on one route.

    The route is loaded from ``spec`` and its frames go through the sensor front-end once
    (only if some job is not cached); each method then runs as ``ppaloc evaluate`` runs it.
    Returns ``{"label", "spec", "seconds", "results": {column: figures}, "errors"}``.
    """
    from ppaloc.datasets import load_dataset
    from ppaloc.errors import PpalocError
    from ppaloc.evaluate.run import localiser_params, run_method, sensor_frames
    from ppaloc.methods import METHODS, make_localiser

    t0 = time.perf_counter()
    results: dict[str, dict[str, Any]] = {}
    errors: dict[str, str] = {}
    todo = []
    for column, name, user in jobs:
        params = localiser_params(name, user, seed=SEED, record_weights=False)
        path = None
        if cache_dir is not None and is_cached_method(name):
            path = _cache_file(Path(cache_dir), spec, name, params, source)
            if path.is_file():
                try:
                    results[column] = {**json.loads(path.read_text())["result"], "cached": True}
                    continue
                except (OSError, ValueError, KeyError):
                    pass  # a broken entry is recomputed
        todo.append((column, name, params, path))
    if todo:
        ds = load_dataset(spec)
        gt = [np.asarray(g, dtype=np.int64) for g in ds.ground_truth]
        reference = sensor_frames(ds.reference)
        query = sensor_frames(ds.query)
        positions_ok = ds.reference_positions is not None and ds.query_positions is not None
        for column, name, params, path in todo:
            t = time.perf_counter()
            try:
                extra = {}
                if params.get("motion") == "oracle" and "oracle_moves" not in params:
                    if ds.query_moved is None:
                        raise PpalocError(f"{name}: motion='oracle' needs query_moved")
                    extra = {"oracle_moves": ds.query_moved}
                loc = make_localiser(name, **params, **extra)
                run = run_method(
                    name,
                    reference,
                    query,
                    gt,
                    params={**METHODS[name].defaults, **params},
                    recall="A",
                    reference_positions=ds.reference_positions if positions_ok else None,
                    query_positions=ds.query_positions if positions_ok else None,
                    query_moved=ds.query_moved,
                    localiser=loc,
                )
            except PpalocError as exc:
                errors[column] = str(exc)
                continue
            m = run.metrics
            result = {
                "f1_max": float(m.f1_max),
                "precision_at_100r": float(m.precision_at_100r),
                "recall_at_100p": float(m.recall_at_100p),
                "n_queries": int(m.n_queries),
                "n_reference": len(reference),
                "latency_ms_median": float(np.median(run.latency_ms)) if len(query) else None,
                "seconds": time.perf_counter() - t,
                "params": run.params,
            }
            if path is not None:
                path.parent.mkdir(parents=True, exist_ok=True)
                tmp = path.with_suffix(f".{os.getpid()}.tmp")
                entry = {"spec": spec, "method": name, "source": source, "result": result}
                tmp.write_text(json.dumps(entry, indent=1, default=repr))
                tmp.replace(path)
            results[column] = {**result, "cached": False}
    return {
        "label": label,
        "spec": spec,
        "seconds": time.perf_counter() - t0,
        "results": results,
        "errors": errors,
    }


def _end_workers(signum: int, frame: Any) -> None:
    """End this process's pool workers, then this process as ``signum`` ends it."""
    children = multiprocessing.active_children()
    for child in children:
        child.terminate()
    for child in children:
        child.join(timeout=10)
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)


def completed(futures: Iterable[Future], poll: float = 0.5) -> Iterator[Future]:
    """``futures`` as each finishes, like ``as_completed``, waking every ``poll`` seconds.

    The kernel hands a signal sent to the process to any of its threads. Where one of
    the pool's threads takes it, Python only marks the handler due, and the main
    thread, asleep in ``as_completed`` or ``result()`` until a route ends, does not run
    it: SIGTERM then left the script and its workers running for the rest of their
    routes. Waking every ``poll`` seconds runs a due handler (or Ctrl-C's
    KeyboardInterrupt) within ``poll`` seconds, at the cost of a wake-up each ``poll``.
    """
    pending = set(futures)
    while pending:
        done, pending = wait(pending, timeout=poll, return_when=FIRST_COMPLETED)
        yield from done


@contextlib.contextmanager
def route_pool(workers: int) -> Iterator[ProcessPoolExecutor]:
    """A pool of ``workers`` spawned processes that SIGTERM ends with this one.

    Ctrl-C reaches the workers too (a terminal signals the whole process group), but
    SIGTERM (``kill PID``, a job scheduler's stop) reaches this process alone: it ended,
    and its workers ran on with their routes and then waited for work that never came,
    for over an hour. While the pool is open, SIGTERM ends the workers first, then this
    process as SIGTERM would (from the main thread, which alone sets signal handlers).
    Wait for the pool's futures with :func:`completed`, not ``as_completed`` or
    ``result()``: the handler runs in the main thread, and only once that thread wakes.
    """
    # Spawned workers inherit these before they import numpy: one BLAS thread each.
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    ctx = multiprocessing.get_context("spawn")
    main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _end_workers) if main else None
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            yield pool
    finally:
        if main:
            signal.signal(signal.SIGTERM, previous)


def run_all(
    selected: list[tuple[str, str]],
    jobs: list[tuple[str, str, dict[str, Any]]],
    *,
    workers: int,
    cache_dir: Path | None,
) -> list[dict[str, Any]]:
    """Every route through :func:`evaluate_route`, ``workers`` at a time; one line per
    finished route on stderr. Returns the route records in the order of ``selected``."""
    source = source_hash()
    cache = None if cache_dir is None else str(cache_dir)
    done: dict[str, dict[str, Any]] = {}
    n = len(selected)
    t0 = time.perf_counter()

    def report(rec: dict[str, Any]) -> None:
        done[rec["label"]] = rec
        hits = sum(r.get("cached", False) for r in rec["results"].values())
        cacheable = sum(is_cached_method(name) for _, name, _ in jobs) if cache else 0
        line = f"[{len(done):3d}/{n}] {rec['label']:52s} {rec['seconds']:7.1f} s"
        line += f"  (cached {hits}/{cacheable}; {time.perf_counter() - t0:.0f} s elapsed)"
        for column, err in rec["errors"].items():
            line += f"\n          {column}: {err}"
        print(line, file=sys.stderr, flush=True)

    if workers <= 1 or n <= 1:
        for label, spec in selected:
            report(evaluate_route(label, spec, jobs, cache, source))
    else:
        with route_pool(min(workers, n)) as pool:
            futures = {
                pool.submit(evaluate_route, label, spec, jobs, cache, source): label
                for label, spec in selected
            }
            for fut in completed(futures):
                try:
                    report(fut.result())
                except Exception as exc:  # one broken route must not stop the rest
                    label = futures[fut]
                    spec = dict(selected)[label]
                    msg = f"{type(exc).__name__}: {exc}"
                    report(
                        {
                            "label": label,
                            "spec": spec,
                            "seconds": 0.0,
                            "results": {},
                            "errors": {"route": msg},
                        }
                    )
    return [done[label] for label, _ in selected]


# -- tables ---------------------------------------------------------------------------------


PLACE_OF = {
    "weighted-node-lowres": "lowres",
    "weighted-node-lowres16": "lowres16",
    "weighted-node-lbp": "lbp",
    "weighted-node-haar": "haar",
    "weighted-node-patch": "patch",
}
"""The descriptor a baseline takes for each weighted-node place (the same information)."""


def _same_place_pairs(
    row: dict[str, float], baseline: str
) -> list[tuple[float, str, float, float]]:
    """``(weighted-node minus baseline, place, weighted-node, baseline)`` for each place of
    ``row`` that both the weighted-node filter and ``baseline/DESCRIPTOR`` ran on."""
    return [
        (row[wn] - row[f"{baseline}/{place}"], place, row[wn], row[f"{baseline}/{place}"])
        for wn, place in PLACE_OF.items()
        if wn in row and f"{baseline}/{place}" in row
    ]


def _better_place(pairs: list[tuple[float, str, float, float]]) -> tuple[float, str, float, float]:
    """The pair of the weighted-node filter's better place: the highest weighted-node max
    F1 (the filter's own figure, chosen without the baseline's), the first on a tie."""
    return max(pairs, key=lambda p: p[2])


def same_place(row: dict[str, float], baseline: str = "particle-filter") -> str:
    """Whether the better weighted-node place of ``row`` (by its own max F1) scores at
    least ``baseline`` on that place (``baseline/DESCRIPTOR``), and on which places it does.

    >>> same_place({"weighted-node-lbp": 0.5, "particle-filter/lbp": 0.6,
    ...             "weighted-node-haar": 0.7, "particle-filter/haar": 0.65})
    'at least particle-filter on its better place: haar (0.700 against 0.650)'
    >>> same_place({"weighted-node-lbp": 0.5, "particle-filter/lbp": 0.4,
    ...             "weighted-node-haar": 0.7, "particle-filter/haar": 0.75}).split("; ")
    ... # doctest: +NORMALIZE_WHITESPACE
    ['below particle-filter on its better place: short by 0.050 on haar (0.700 against
      0.750)', 'at least it on lbp']
    """
    pairs = _same_place_pairs(row, baseline)
    if not pairs:
        return f"no weighted-node place beside {baseline} on the same place"
    gap, place, w, b = _better_place(pairs)
    if gap >= 0:
        return f"at least {baseline} on its better place: {place} ({w:.3f} against {b:.3f})"
    text = (
        f"below {baseline} on its better place: short by {-gap:.3f} on {place} "
        f"({w:.3f} against {b:.3f})"
    )
    held = [p for g, p, _, _ in pairs if g >= 0]
    return text + (f"; at least it on {', '.join(held)}" if held else "")


def same_place_summary(
    records: list[dict[str, Any]], baseline: str = "particle-filter"
) -> tuple[str, dict[str, Any]]:
    """On how many routes the better weighted-node place (by its own max F1) scores at
    least ``baseline`` on that place (issue target: every route), and by how much the
    others fall short; beside it, the routes where some place does (a weaker count: five
    places give five chances) and each place's own count.

    Returns the text and ``{"baseline", "held", "held_some", "routes", "places": {place:
    [held, routes]}, "short": [{"label", "place", "weighted_node", "baseline", "gap"}]}``;
    a route counts where some place ran beside ``baseline`` on it.

    >>> rec = lambda label, wn, pf: {"label": label, "results": {
    ...     "weighted-node-haar": {"f1_max": wn}, "particle-filter/haar": {"f1_max": pf}}}
    >>> text, stats = same_place_summary([rec("a", 0.7, 0.6), rec("b", 0.5, 0.52)])
    >>> short = stats["short"][0]
    >>> stats["held"], stats["routes"], short["label"], round(short["gap"], 3)
    (1, 2, 'b', -0.02)
    >>> text.split("; ")  # doctest: +NORMALIZE_WHITESPACE
    ['The better weighted-node place (by its own max F1) scores at least particle-filter on
      that place on 1 of 2 routes (some place on 1: haar 1 of 2)',
     'below it: b (haar 0.500 against 0.520, short by 0.020)']
    """
    held, held_some, routes, short = 0, 0, 0, []
    places: dict[str, list[int]] = {}
    for rec in records:
        row = {c: v for c in rec["results"] if (v := _f1(rec, c)) is not None}
        pairs = _same_place_pairs(row, baseline)
        if not pairs:
            continue
        routes += 1
        held_some += any(g >= 0 for g, _, _, _ in pairs)
        for g, p, _, _ in pairs:
            count = places.setdefault(p, [0, 0])
            count[0] += g >= 0
            count[1] += 1
        gap, place, w, b = _better_place(pairs)
        if gap >= 0:
            held += 1
        else:
            short.append(
                {
                    "label": rec["label"],
                    "place": place,
                    "weighted_node": w,
                    "baseline": b,
                    "gap": gap,
                }
            )
    each = ", ".join(f"{p} {h} of {n}" for p, (h, n) in places.items())
    text = (
        f"The better weighted-node place (by its own max F1) scores at least {baseline} on "
        f"that place on {held} of {routes} routes (some place on {held_some}: {each})"
    )
    if short:
        text += "; below it: " + "; ".join(
            f"{s['label']} ({s['place']} {s['weighted_node']:.3f} against {s['baseline']:.3f}, "
            f"short by {-s['gap']:.3f})"
            for s in short
        )
    stats = {
        "baseline": baseline,
        "held": held,
        "held_some": held_some,
        "routes": routes,
        "places": places,
        "short": short,
    }
    return text, stats


def seed_spread_jobs(
    place: str, seeds: int, user: dict[str, Any] | None = None
) -> list[tuple[str, str, dict[str, Any]]]:
    """The particle filter on ``place`` at the ``seeds - 1`` seeds after the table's (its
    ``user`` parameters' ``seed``, else :data:`SEED`), with the table's other parameters,
    one column each: ``particle-filter/PLACE@seed=S``.

    >>> [c for c, _, _ in seed_spread_jobs("haar", 3)]
    ['particle-filter/haar@seed=1', 'particle-filter/haar@seed=2']
    >>> seed_spread_jobs("lbp", 2, {"seed": 7, "n_particles": 200})[0][2]
    {'seed': 8, 'n_particles': 200, 'descriptor': 'lbp'}
    """
    user = dict(user or {})
    first = int(user.get("seed", SEED))
    return [
        (
            f"particle-filter/{place}@seed={s}",
            "particle-filter",
            {**user, "seed": s, "descriptor": place},
        )
        for s in range(first + 1, first + seeds)
    ]


def seed_spread_summary(
    short: list[dict[str, Any]],
    records: list[dict[str, Any]],
    seeds: int,
    user: dict[str, Any] | None = None,
) -> tuple[str, list[dict[str, Any]]]:
    """For each route of ``short`` (:func:`same_place_summary`'s), the particle filter's
    max F1 on that place at each seed that ran (the table's and the extra runs in
    ``records``, :func:`seed_spread_jobs`; a run that failed is left out and its seed
    not named), beside the weighted-node filter's, which draws nothing: how far a
    shortfall is the particle filter's luck on one seed. ``sd`` is the sample standard
    deviation (None from one run).

    >>> short = [{"label": "a", "place": "haar", "weighted_node": 0.86, "baseline": 0.87}]
    >>> recs = [{"label": "a", "results": {"particle-filter/haar@seed=1": {"f1_max": 0.85},
    ...                                    "particle-filter/haar@seed=2": {"f1_max": 0.89}}}]
    >>> text, rows = seed_spread_summary(short, recs, 3)
    >>> print(text)  # doctest: +NORMALIZE_WHITESPACE
    The particle filter's max F1 over its seeds on the routes below it: a,
    particle-filter/haar over seeds 0-2: mean 0.870, sd 0.020, range 0.850-0.890; the
    weighted-node filter's 0.860 at or above it on 1 of 3 seeds
    >>> rows[0]["mean"], rows[0]["at_or_below"], rows[0]["seeds"]
    (0.87, 1, [0, 1, 2])
    """
    by_label = {r["label"]: r for r in records}
    first = int((user or {}).get("seed", SEED))
    parts, rows = [], []
    for entry in short:
        place, wn = entry["place"], entry["weighted_node"]
        results = by_label.get(entry["label"], {}).get("results", {})
        ran, f1s = [first], [float(entry["baseline"])]  # the table's own run
        for column, _, job in seed_spread_jobs(place, seeds, user):
            value = results.get(column, {}).get("f1_max")
            if value is not None:
                ran.append(int(job["seed"]))
                f1s.append(float(value))
        arr = np.asarray(f1s)
        sd = float(arr.std(ddof=1)) if arr.size > 1 else None
        row = {
            "label": entry["label"],
            "place": place,
            "weighted_node": wn,
            "seeds": ran,
            "f1_max": f1s,
            "mean": round(float(arr.mean()), 6),
            "sd": None if sd is None else round(sd, 6),
            "min": float(arr.min()),
            "max": float(arr.max()),
            "at_or_below": int((arr <= wn).sum()),
        }
        rows.append(row)
        if len(ran) == 1:
            named = f"seed {ran[0]}"
        elif ran == list(range(ran[0], ran[-1] + 1)):
            named = f"seeds {ran[0]}-{ran[-1]}"
        else:
            named = f"seeds {ran}"
        spread = "no sd from one run" if sd is None else f"sd {sd:.3f}"
        parts.append(
            f"{row['label']}, particle-filter/{place} over {named}: mean "
            f"{row['mean']:.3f}, {spread}, range {row['min']:.3f}-{row['max']:.3f}; the "
            f"weighted-node filter's {wn:.3f} at or above it on {row['at_or_below']} of "
            f"{arr.size} seeds"
        )
    text = "The particle filter's max F1 over its seeds on the routes below it: " + "; ".join(parts)
    return text, rows


def _f1(rec: dict[str, Any], column: str) -> float | None:
    r = rec["results"].get(column)
    return None if r is None else r["f1_max"]


def _cell(v: float | None, signed: bool = False) -> str:
    if v is None:
        return "-"
    return f"{v:+.3f}" if signed else f"{v:.3f}"


def margins(rec: dict[str, Any], methods: Sequence[str], wn: Sequence[str]) -> float | None:
    """Best of the ``wn`` methods minus the best baseline on one route (None: either missing)."""
    best_wn = [v for c in wn if (v := _f1(rec, c)) is not None]
    best_base = [v for c in methods if is_cached_method(c) and (v := _f1(rec, c)) is not None]
    if not best_wn or not best_base:
        return None
    return max(best_wn) - max(best_base)


def comparison_table(records: list[dict[str, Any]], methods: Sequence[str]) -> tuple[str, dict]:
    """The Markdown table and the summary lines of the comparison mode."""
    lines = [
        "| route | " + " | ".join(methods) + " | best WN - best baseline |",
        "|---|" + "---|" * (len(methods) + 1),
    ]
    wn_cols = [c for c in WN_BEST if c in methods]
    for rec in records:
        cells = [_cell(_f1(rec, c)) for c in methods]
        lines.append(
            f"| {rec['label']} | "
            + " | ".join(cells)
            + f" | {_cell(margins(rec, methods, wn_cols), True)} |"
        )
    summary: dict[str, Any] = {}
    if not any(c.startswith("weighted-node") for c in methods):
        return "\n".join(lines) + "\n\nno weighted-node column: nothing to compare", summary
    groups = [("best of " + "/".join(wn_cols), wn_cols)] if wn_cols else []
    on_sensor = [c for c in wn_cols if c not in HOST_ONLY]
    if on_sensor and len(on_sensor) < len(wn_cols):
        groups.append(("best of the places a sensor holds, " + "/".join(on_sensor), on_sensor))
    every_wn = [c for c in methods if c.startswith("weighted-node")]
    if set(every_wn) - set(wn_cols):
        groups.append(("best of every weighted-node-* column", every_wn))
    text = []
    for what, cols in groups:
        m = [(margins(r, methods, cols), r["label"]) for r in records]
        m = [(v, label) for v, label in m if v is not None]
        if not m:
            text.append(f"{what}: no route has both a weighted-node and a baseline figure")
            continue
        wins = sum(v >= 0 for v, _ in m)
        low, where = min(m)
        text.append(
            f"{what}: >= every baseline on {wins} of {len(m)} routes; "
            f"minimum margin {low:+.3f} ({where})"
        )
        summary[what] = {"routes": len(m), "wins": wins, "min_margin": low, "min_route": where}
    return "\n".join(lines) + "\n\n" + "\n".join(text), summary


def group_table(records: list[dict[str, Any]], columns: Sequence[str]) -> tuple[str, dict]:
    """Route group x column table of the mean max F1 (:func:`route_group`), then the means
    over the real routes, the generated routes and all routes.

    Returns the Markdown table and ``{row: {column: mean or None}}`` (with ``routes``, the
    number of routes averaged in the row).
    """
    rows: dict[str, list[dict[str, Any]]] = {}
    for rec in records:
        rows.setdefault(route_group(rec["label"]), []).append(rec)
    real = [r for r in records if not r["label"].startswith("synthetic")]
    generated = [r for r in records if r["label"].startswith("synthetic")]
    summary_rows = [
        (f"**mean of the {len(real)} real routes**", real),
        (f"**mean of the {len(generated)} generated routes**", generated),
        (f"**mean of the {len(records)} routes**", records),
    ]
    lines = ["| route group | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns)]
    stats: dict[str, dict[str, Any]] = {}
    seeds = {
        g: f"{g} ({len(r)} seeds)" if g.startswith("generated") else g for g, r in rows.items()
    }
    for name, recs in [*((seeds[g], r) for g, r in rows.items()), *summary_rows]:
        if not recs:
            continue
        means: dict[str, Any] = {"routes": len(recs)}
        for c in columns:
            vals = [v for r in recs if (v := _f1(r, c)) is not None]
            means[c] = float(np.mean(vals)) if len(vals) == len(recs) else None
        stats[name.strip("*")] = means
        lines.append(f"| {name} | " + " | ".join(_cell(means[c]) for c in columns) + " |")
    return "\n".join(lines), stats


def sweep_table(records: list[dict[str, Any]], columns: Sequence[str]) -> tuple[str, dict]:
    """Route x value table with the mean and the minimum over routes."""
    lines = ["| route | " + " | ".join(columns) + " |", "|---|" + "---|" * len(columns)]
    for rec in records:
        lines.append(
            f"| {rec['label']} | " + " | ".join(_cell(_f1(rec, c)) for c in columns) + " |"
        )
    stats: dict[str, dict[str, float | None]] = {}
    for c in columns:
        vals = [v for r in records if (v := _f1(r, c)) is not None]
        stats[c] = {
            "mean": float(np.mean(vals)) if vals else None,
            "min": float(np.min(vals)) if vals else None,
        }
    lines.append("| **mean** | " + " | ".join(_cell(stats[c]["mean"]) for c in columns) + " |")
    lines.append("| **min** | " + " | ".join(_cell(stats[c]["min"]) for c in columns) + " |")
    return "\n".join(lines), stats


# -- command line ---------------------------------------------------------------------------


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description="Max F1 of the weighted-node filter against the baselines on every route.",
        epilog="Routes, caching and columns: see the module docstring.",
    )
    parser.add_argument("--places", type=int, default=200, help="places of the generated routes")
    parser.add_argument(
        "--methods",
        default=None,
        help="comma-separated method names (default: "
        + ",".join(DEFAULT_METHODS)
        + "; with --representations: "
        + ",".join(REPRESENTATION_METHODS)
        + ")",
    )
    parser.add_argument(
        "--representations",
        action="store_true",
        help="run every baseline on each descriptor it takes (the weighted-node filter's "
        "lowres and lbp places and its own) and add a table of route groups",
    )
    add_param_option(parser)
    parser.add_argument(
        "--routes", default=None, metavar="SUBSTR", help="only routes whose label contains this"
    )
    parser.add_argument("--jobs", type=int, default=2, help="routes run in parallel")
    parser.add_argument(
        "--no-cache", action="store_true", help="ignore (and do not write) the cache"
    )
    parser.add_argument(
        "--json", type=Path, default=None, metavar="PATH", help="write every figure here"
    )
    parser.add_argument(
        "--sweep",
        default=None,
        metavar="METHOD.key=v1,v2,...",
        help="run only METHOD at each value of key and print route x value",
    )
    parser.add_argument(
        "--seed-spread",
        type=int,
        default=0,
        metavar="K",
        help="with --representations: run the particle filter on each route where no "
        "weighted-node place reaches it on the same place at K seeds in all (the table's "
        "seed among them) and print its spread there",
    )
    parser.add_argument("--data", type=Path, default=DATA, help="the shared data folder")
    parser.add_argument(
        "--held-out",
        action="store_true",
        help="the routes no default was chosen on (held_out_routes: the real pairs the "
        "other way round, the road with turns, the lab, night) instead of the 65",
    )
    args = parser.parse_args(argv)

    from ppaloc.errors import PpalocError
    from ppaloc.methods import METHODS, available_methods, make_localiser

    t0 = time.perf_counter()
    params = parse_params(args.param)
    available = set(available_methods())
    notes: list[str] = []

    if args.seed_spread and not args.representations:
        raise SystemExit("error: --seed-spread reads --representations' same-place line; give both")
    if args.seed_spread and not 2 <= args.seed_spread <= 100:
        raise SystemExit(
            f"error: --seed-spread {args.seed_spread} must be in [2, 100] (the seeds in all, "
            "the table's one among them)"
        )
    if args.sweep and args.representations:
        raise SystemExit("error: --sweep and --representations do not go together; give one")
    if args.sweep:
        method, key, values_text = parse_param(args.sweep)
        if method not in available:
            raise SystemExit(
                f"error: method {method!r} is not available; choose from {sorted(available)}"
            )
        values = [parse_value(v) for v in values_text.split(",") if v.strip()]
        columns = [f"{key}={v!r}" if isinstance(v, str) else f"{key}={v}" for v in values]
        jobs = [
            (c, method, {**params.get(method, {}), key: v})
            for c, v in zip(columns, values, strict=True)
        ]
    else:
        if args.methods is None:
            args.methods = ",".join(
                REPRESENTATION_METHODS if args.representations else DEFAULT_METHODS
            )
        requested = [m.strip() for m in args.methods.split(",") if m.strip()]
        methods = []
        for name in requested:
            if name not in available:
                why = "not available in this install" if name in METHODS else "not registered"
                notes.append(f"note: method {name!r} is {why}; its column is skipped")
            elif name not in methods:
                methods.append(name)
        for name in params:
            if name not in methods:
                notes.append(f"note: --param for {name!r}, which is not run, is ignored")
        if args.representations:
            jobs = [j for name in methods for j in descriptor_columns(name, params.get(name, {}))]
        else:
            jobs = [(name, name, params.get(name, {})) for name in methods]
        columns = [column for column, _, _ in jobs]
    for note in notes:
        print(note, file=sys.stderr)
    for _, name, user in jobs:  # a bad parameter fails here, before any route is loaded
        if user.get("motion") == "oracle":
            continue  # needs the route's true motion: checked when the route runs
        try:
            make_localiser(name, **user)
        except PpalocError as exc:
            raise SystemExit(f"error: {exc}") from None
    if not jobs:
        raise SystemExit("error: no method to run")

    selected = (
        held_out_routes(args.data, args.places) if args.held_out else routes(args.data, args.places)
    )
    if args.routes:
        selected = [(label, spec) for label, spec in selected if args.routes in label]
    if not selected:
        raise SystemExit(f"error: no route label contains {args.routes!r}")
    records = run_all(
        selected,
        jobs,
        workers=args.jobs,
        cache_dir=None if args.no_cache else CACHE_DIR,
    )
    if args.sweep:
        table, summary = sweep_table(records, columns)
    else:
        table, summary = comparison_table(records, columns)
    groups = same = None
    if args.representations:
        group_text, groups = group_table(records, columns)
        table += "\n\nMean max F1 per route group:\n\n" + group_text
        same_text, same = same_place_summary(records)
        table += "\n\n" + same_text
        if args.seed_spread:
            user = params.get("particle-filter", {})
            shorts = {s["label"]: s["place"] for s in same["short"]}
            spread_records = []
            for place in sorted(set(shorts.values())):
                picked = [(lb, sp) for lb, sp in selected if shorts.get(lb) == place]
                spread_records += run_all(
                    picked,
                    seed_spread_jobs(place, args.seed_spread, user),
                    workers=args.jobs,
                    cache_dir=None if args.no_cache else CACHE_DIR,
                )
            spread_text, spread = seed_spread_summary(
                same["short"], spread_records, args.seed_spread, user
            )
            same["seed_spread"] = spread
            if not same["routes"]:
                spread_text = "--seed-spread: no route ran the particle filter beside a place"
            elif not spread:
                spread_text = "--seed-spread: no route is below the particle filter; nothing to run"
            table += "\n\n" + spread_text
    wall = time.perf_counter() - t0
    print(table)
    print(f"\n{len(records)} routes, wall time {wall:.0f} s, {args.jobs} jobs", file=sys.stderr)
    if args.json:
        out = {
            "mode": "sweep"
            if args.sweep
            else "representations"
            if args.representations
            else "compare",
            "sweep": args.sweep,
            "columns": list(columns),
            "params": params,
            "places": args.places,
            "notes": notes,
            "summary": summary,
            "groups": groups,
            "same_place": same,
            "wall_s": wall,
            "routes": records,
        }
        from ppaloc.fileio import atomic_write

        with atomic_write(args.json, "w") as f:
            f.write(json.dumps(out, indent=1, default=repr))


if __name__ == "__main__":
    main()
