"""Host latency per frame against map size, every method on the same random maps.

Maps are built from random sensor frames (a seeded pool of 32 frames cycled to the map
size, so a 4096-node map costs no more memory than 32 frames); query frames are drawn
from the same generator. Only ``step`` is timed. The figures say how a method scales with
the map, not how well it localises.
"""

from __future__ import annotations

import json
import logging
import sys
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc import __version__
from ppaloc.datasets import SENSOR_SHAPE
from ppaloc.errors import DataError, PpalocError
from ppaloc.evaluate.config import BenchConfig
from ppaloc.evaluate.run import hand_query, localiser_params, resolve_methods
from ppaloc.methods import make_localiser

__all__ = ["load_bench", "run_bench", "save_bench"]

_POOL = 32
MAX_BENCH_BYTES = 64 << 20  # a bench file is a few kB; anything this large is not one
_PROBE = 256  # nodes of the trial build that budgets a first size above it

log = logging.getLogger(__name__)


def _frames(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    # Smooth random images (block noise upsampled) so that descriptors vary like scenes do.
    small = rng.integers(0, 256, (n, 32, 32), dtype=np.uint8)
    return [
        np.kron(s, np.ones((8, 8), np.uint8))[: SENSOR_SHAPE[0], : SENSOR_SHAPE[1]] for s in small
    ]


def _probe_build(name: str, params: dict[str, Any], pool: list[np.ndarray]) -> tuple[int, float]:
    """(nodes, seconds) of building a small map, to extrapolate a large build's time."""
    loc = make_localiser(name, **params)
    t0 = time.perf_counter()
    try:
        loc.build_map([pool[i % _POOL] for i in range(_PROBE)])
    except PpalocError:
        return _PROBE, 0.0
    return _PROBE, time.perf_counter() - t0


def run_bench(
    config: BenchConfig, *, progress: Callable[[str, int], None] | None = None
) -> dict[str, Any]:
    """Time ``step`` of every method of ``config`` at every map size.

    ``progress(method, sizes_done)`` is called after each size.

    Returns
    -------
    dict
        ``{"config", "ppaloc_version", "created", "rows": [{"method", "n_nodes",
        "latency_ms_median", "latency_ms_p95", "build_s", "queries"[,
        "modelled_latency_ms_median"]}, ...]}`` (the modelled on-sensor time where the
        method models it); a size a
        method refuses (a ``PpalocError`` from ``build_map``, e.g. more nodes than a
        simulated sensor holds) gives a row ``{"method", "n_nodes", "skipped": reason}``.

    Raises
    ------
    PpalocError
        For an unknown method or bad parameters.
    """
    names = resolve_methods(config.methods)
    rng = np.random.default_rng(config.seed)
    pool = _frames(rng, _POOL)
    queries = _frames(rng, config.warmup + config.queries)
    rows = []
    for name in names:
        params = localiser_params(
            name, config.params.get(name, {}), seed=config.seed, record_weights=False
        )
        last: tuple[int, float] | None = None  # (size, build seconds) of the last build
        for size in config.sizes:
            if config.max_build_s is not None and last is None and size > _PROBE:
                last = _probe_build(name, params, pool)  # so the first size is budgeted too
            if config.max_build_s is not None and last is not None:
                estimate = last[1] * size / last[0]
                if estimate > config.max_build_s:
                    reason = (
                        f"building {size} nodes would take about {estimate:.0f} s, over the "
                        f"budget of {config.max_build_s:g} s"
                    )
                    rows.append({"method": name, "n_nodes": size, "skipped": reason})
                    if progress:
                        progress(name, config.sizes.index(size) + 1)
                    continue
            loc = make_localiser(name, **params)
            t0 = time.perf_counter()
            try:
                loc.build_map([pool[i % _POOL] for i in range(size)])
            except PpalocError as exc:  # a size the method cannot hold (e.g. sensor capacity)
                rows.append({"method": name, "n_nodes": size, "skipped": str(exc)})
                log.info("bench: %s skips %d nodes: %s", name, size, exc)
                if progress:
                    progress(name, config.sizes.index(size) + 1)
                continue
            build_s = time.perf_counter() - t0
            last = (size, build_s)
            loc.reset()
            hand_query(loc, queries)  # an offline method reads the whole query first
            times, modelled = [], []
            for i, frame in enumerate(queries):
                t = time.perf_counter_ns()
                est = loc.step(frame)
                if i >= config.warmup:
                    times.append((time.perf_counter_ns() - t) / 1e6)
                    if est.modelled_latency_ms is not None:
                        modelled.append(est.modelled_latency_ms)
            row = {
                "method": name,
                "n_nodes": size,
                "latency_ms_median": float(np.median(times)),
                "latency_ms_p95": float(np.percentile(times, 95)),
                "build_s": build_s,
                "queries": len(times),
            }
            if modelled:
                row["modelled_latency_ms_median"] = float(np.median(modelled))
            rows.append(row)
            if progress:
                progress(name, config.sizes.index(size) + 1)
    return {
        "config": config.to_dict(),
        "ppaloc_version": __version__,
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "python": sys.version.split()[0],
        "rows": rows,
    }


def save_bench(bench: dict[str, Any], path: str | Path) -> Path:
    """Write a :func:`run_bench` result as JSON (atomically) and a CSV beside it."""
    from ppaloc.fileio import write_bytes

    path = Path(path)
    cols = ["method", "n_nodes", "latency_ms_median", "latency_ms_p95", "build_s", "queries"]
    lines = [",".join(cols)] + [
        ",".join(str(r.get(c, "")) for c in cols) for r in bench["rows"] if "skipped" not in r
    ]
    write_bytes(path.with_suffix(".csv"), "\n".join(lines) + "\n")
    return write_bytes(path, json.dumps(bench, indent=2, allow_nan=False) + "\n")  # strict JSON


class _NotJson(ValueError):
    pass


def _not_json(name: str) -> Any:
    """NaN or Infinity, which ``save_bench`` never writes (strict JSON): a hand edit."""
    raise _NotJson(f"it holds {name}, which is not JSON")


def load_bench(path: str | Path) -> dict[str, Any] | None:
    """Read a bench JSON file; None when it does not exist.

    Raises
    ------
    DataError
        If the file is not a bench written by :func:`save_bench`.
    """
    path = Path(path)
    if not path.is_file():
        return None
    try:
        if path.stat().st_size > MAX_BENCH_BYTES:
            raise DataError(
                f"{path} is larger than {MAX_BENCH_BYTES} bytes, not a bench file; delete it "
                "or run `ppaloc bench` again"
            )
        bench = json.loads(path.read_text(encoding="utf-8"), parse_constant=_not_json)
    except (OSError, ValueError, RecursionError) as exc:
        reason = "nested too deeply" if isinstance(exc, RecursionError) else type(exc).__name__
        reason = str(exc) if isinstance(exc, _NotJson) else reason
        raise DataError(
            f"cannot read {path} ({reason}); delete it or run `ppaloc bench` again"
        ) from None
    if not isinstance(bench, dict) or not isinstance(bench.get("rows"), list):
        raise DataError(f"{path} has no 'rows' list; it was not written by `ppaloc bench`")
    for i, row in enumerate(bench["rows"]):
        ok = isinstance(row, dict) and isinstance(row.get("method"), str)
        nodes = row.get("n_nodes") if isinstance(row, dict) else None
        if not ok or not isinstance(nodes, int) or isinstance(nodes, bool) or nodes < 1:
            raise DataError(
                f"{path}: row {i} is not a bench row (method, n_nodes, ...); delete the file or "
                "run `ppaloc bench` again"
            )
        times = [row.get(k) for k in ("latency_ms_median", "latency_ms_p95", "build_s")]
        if "skipped" not in row and not all(
            isinstance(t, int | float) and not isinstance(t, bool) and t >= 0 for t in times
        ):
            raise DataError(f"{path}: row {i} lacks its timings; run `ppaloc bench` again")
    return bench
