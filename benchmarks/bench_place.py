"""Place representations: descriptor computation and distances against N map nodes.

``make bench`` runs these with pytest-benchmark; ``python benchmarks/bench_place.py``
prints the same figures as a table of medians (milliseconds, one core).

Targets on one core, per query frame at N = 10**6 nodes: Hamming (32-bit LBP) <= 5 ms,
SAD (8x8 low-res images) <= 20 ms. At that size the node arrays are 4 MB and 64 MB, so
both are bounded by memory bandwidth; :class:`ppaloc.place.LowresIndex` stores the
low-res nodes cell-major in L2-sized blocks so the SAD streams at that bound.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from functools import cache

import numpy as np
import pytest

from ppaloc.place import (
    LowresIndex,
    block_sums,
    hamming,
    lbp_descriptor,
    lowres_image,
    sad,
)

SIZES = (10**3, 10**4, 10**5, 10**6)
BATCH = 64  # frames per descriptor batch


@cache
def frames() -> np.ndarray:
    return np.random.default_rng(0).integers(0, 256, (BATCH, 256, 256), dtype=np.uint8)


@cache
def lbp_nodes(n: int) -> np.ndarray:
    return np.random.default_rng(1).integers(0, 2**32, n, dtype=np.uint32)


@cache
def lowres_nodes(n: int) -> np.ndarray:
    return np.random.default_rng(2).integers(0, 256, (n, 8, 8), dtype=np.uint8)


@cache
def lowres_index(n: int) -> LowresIndex:
    return LowresIndex(lowres_nodes(n))


QUERY_LBP = np.uint32(0x5A3C96E1)
QUERY_LOWRES = np.random.default_rng(3).integers(0, 256, (8, 8), dtype=np.uint8)


def cases() -> dict[str, Callable[[], object]]:
    """Every timed operation, by name; each call is one frame (or one batch)."""
    out: dict[str, Callable[[], object]] = {
        f"lowres_image x{BATCH} frames": lambda: lowres_image(frames()),
        f"lbp_descriptor x{BATCH} frames": lambda: lbp_descriptor(frames()),
    }
    for n in SIZES:
        nodes, scratch = lbp_nodes(n), np.empty(n, np.uint8)
        out[f"hamming N={n:.0e}"] = lambda nodes=nodes, s=scratch: hamming(QUERY_LBP, nodes, out=s)
    for n in SIZES:
        index, scratch = lowres_index(n), np.empty(n, np.uint16)
        out[f"LowresIndex.sad N={n:.0e}"] = lambda i=index, s=scratch: i.sad(QUERY_LOWRES, out=s)
    sums = block_sums(frames()[0])
    for n in SIZES:
        index = lowres_index(n)
        out[f"LowresIndex.sad_to_sums N={n:.0e}"] = lambda i=index: i.sad_to_sums(sums, cap=254)
    for n in SIZES:
        nodes = lowres_nodes(n)
        out[f"sad (row-major) N={n:.0e}"] = lambda nodes=nodes: sad(QUERY_LOWRES, nodes)
    return out


CASES = cases()


@pytest.mark.parametrize("name", list(CASES))
def test_place(benchmark, name: str) -> None:
    benchmark.group = "place"
    benchmark(CASES[name])


def median_ms(fn: Callable[[], object], repeats: int = 25) -> float:
    fn()  # warm up (and build cached inputs)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


if __name__ == "__main__":
    for name, fn in CASES.items():
        print(f"{name:<36} {median_ms(fn):9.3f} ms")
