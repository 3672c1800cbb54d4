"""Per-query latency of the baselines against map size, beside the weighted-node filter.

Maps are random (latency does not depend on what the descriptors show), built directly in
each method's own map format and handed over with ``use_map``; each localiser first takes
``WARMUP`` frames so sequence buffers are full, then ``step`` is timed on one sensor frame.

Two ways to run it::

    make bench                                        # pytest-benchmark, every method x N
    .venv/bin/python benchmarks/bench_baselines.py    # one table: medians and ratios

The script form times all methods in the same process, taking turns per map size (see
:func:`side_by_side`), and reports each median as a ratio to the host
weighted-node filter (``weighted-node-lowres``) at the same N.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import pytest

from ppaloc.baselines import ABLEM
from ppaloc.localise.base import Localiser
from ppaloc.methods import make_localiser
from ppaloc.topomap import TopoMap

SIZES = (100, 1000, 3600, 10_000)
"""Map sizes: 10^2, 10^3, Nordland-like 3.6 x 10^3 and 10^4 nodes."""
WARMUP = 12
BLOCK = 4
SEED = 0


def _random_map(kind: str, n: int, rng: np.random.Generator) -> TopoMap:
    if kind in ("seqslam", "single-frame", "particle-filter"):
        desc = rng.standard_normal((n, 32, 64), dtype=np.float32)
    elif kind == "able-m":
        desc = rng.integers(0, 256, (n, ABLEM().n_bytes), dtype=np.uint8)
    elif kind == "lowres":
        desc = rng.integers(0, 256, (n, 8, 8), dtype=np.uint8)
    elif kind == "lbp":
        desc = rng.integers(0, 2**32, n, dtype=np.uint32)
    else:  # pragma: no cover - a method added to METHODS below without a map recipe
        raise KeyError(kind)
    return TopoMap(kind, desc)


METHODS: dict[str, tuple[str, dict, str]] = {
    # label: (registry name, parameters, map kind)
    "weighted-node-lowres": ("weighted-node-lowres", {}, "lowres"),
    "weighted-node-lbp": ("weighted-node-lbp", {}, "lbp"),
    "seqslam": ("seqslam", {}, "seqslam"),
    "able-m": ("able-m", {}, "able-m"),
    "particle-filter": ("particle-filter", {}, "particle-filter"),
    "single-frame": ("single-frame", {}, "single-frame"),
}


def prepared(label: str, n: int) -> tuple[Localiser, np.ndarray] | None:
    """A localiser on a random map of ``n`` nodes, warmed up, and the frame to time."""
    name, params, kind = METHODS[label]
    try:
        loc = make_localiser(name, **params)
    except Exception:  # not available in this tree
        return None
    rng = np.random.default_rng(SEED)
    loc.use_map(_random_map(kind, n, rng))
    frames = rng.integers(0, 256, (WARMUP + 1, 256, 256), dtype=np.uint8)
    for f in frames[:-1]:
        loc.step(f)
    return loc, frames[-1]


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("label", list(METHODS))
def test_step_latency(benchmark, label: str, n: int) -> None:
    ready = prepared(label, n)
    if ready is None:
        pytest.skip(f"{label} is not available")
    loc, frame = ready
    rounds = 20 if n <= 3600 else 8
    benchmark.extra_info.update({"method": label, "nodes": n})
    benchmark.pedantic(loc.step, args=(frame,), rounds=rounds, iterations=1, warmup_rounds=1)


def side_by_side(n: int, rounds: int) -> dict[str, float]:
    """Median ms per ``step`` of every available method on maps of ``n`` nodes.

    The methods take turns (round-robin), so a change in machine load during the run
    affects all of them alike. In each turn a method takes one untimed step, to bring its
    own data back into the caches the others evicted, then ``BLOCK`` timed steps: each
    method is measured warm, as when it runs alone.
    """
    ready = {label: prepared(label, n) for label in METHODS}
    ready = {label: r for label, r in ready.items() if r is not None}
    times: dict[str, list[float]] = {label: [] for label in ready}
    for _ in range(rounds):
        for label, (loc, frame) in ready.items():
            loc.step(frame)
            for _ in range(BLOCK):
                t0 = time.perf_counter()
                loc.step(frame)
                times[label].append(time.perf_counter() - t0)
    return {label: statistics.median(t) * 1e3 for label, t in times.items()}


def main() -> None:
    print("median ms per query frame (ratio to weighted-node-lowres at the same N)")
    print(f"{'method':22s}" + "".join(f"{n:>18d}" for n in SIZES))
    table = {n: side_by_side(n, 10 if n <= 3600 else 4) for n in SIZES}
    for label in METHODS:
        cells = []
        for n in SIZES:
            ms, base = table[n].get(label), table[n].get("weighted-node-lowres")
            if ms is None:
                cells.append(f"{'-':>17s}")
                continue
            ratio = f"x{ms / base:.1f}" if base else ""
            cells.append(f"{ms:9.3f} {ratio:>7s}")
        print(f"{label:22s}" + "".join(f"{c:>18s}" for c in cells))


if __name__ == "__main__":
    main()
