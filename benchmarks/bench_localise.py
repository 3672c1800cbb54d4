"""The weighted-node filter: per-frame latency against map size.

``make bench`` runs these with pytest-benchmark; ``python benchmarks/bench_localise.py``
prints the same figures as a table of medians (milliseconds, one core), side by side;
``--lanes`` prints the robust filter's frame without speed lanes, with the lane at 2
alone, with the two fast lanes and with the defaults' three (docs/localise.md, "A query
faster or slower than the map").

Targets on one core, per query frame at N = 10**6 nodes (float arithmetic, the host's
fast path): <= 5 ms with 32-bit LBP descriptors, <= 20 ms with 8x8 low-res images. One
step is the whole of Algorithm 1: descriptor of the live frame, weight shift (an offset
change), likelihood against every node, update, detection, confidence, a top-10 ranking
and, every k frames, the adjustment. The motion model is ``always_forward`` so that the
figure is the filter's; the image motion model adds a constant (``test_image_motion``).
"""

from __future__ import annotations

import statistics
import sys
import time
from functools import cache

import numpy as np
import pytest

from ppaloc.localise.motion import ImageMotion
from ppaloc.localise.params import NO_LANES
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.topomap import TopoMap

SIZES = (10**3, 10**4, 10**5, 10**6)
FRAMES = 8


@cache
def frames() -> np.ndarray:
    return np.random.default_rng(0).integers(0, 256, (FRAMES, 256, 256), dtype=np.uint8)


@cache
def topomap(representation: str, n: int) -> TopoMap:
    rng = np.random.default_rng(n)
    if representation == "lbp":
        return TopoMap("lbp", rng.integers(0, 2**32, n, dtype=np.uint32))
    return TopoMap("lowres", rng.integers(0, 256, (n, 8, 8), dtype=np.uint8))


def localiser(
    representation: str, n: int, arithmetic: str, preset: str = "robust", **extra: object
) -> WeightedNodeLocaliser:
    if preset == "paper":
        extra["alpha"] = 8
    loc = WeightedNodeLocaliser(
        representation, preset=preset, motion="always_forward", arithmetic=arithmetic, **extra
    )
    loc.use_map(topomap(representation, n))
    for f in frames():  # warm up: first touch of every array
        loc.step(f)
    return loc


def stepper(loc: WeightedNodeLocaliser):
    state = {"i": 0}

    def step() -> None:
        loc.step(frames()[state["i"] % FRAMES])
        state["i"] += 1

    return step


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("representation", ["lbp", "lowres"])
@pytest.mark.parametrize("preset", ["robust", "paper"])
def test_step_float(benchmark, preset, representation, n):
    benchmark(stepper(localiser(representation, n, "float", preset)))


@pytest.mark.parametrize("n", SIZES[:3])
@pytest.mark.parametrize("representation", ["lbp", "lowres"])
@pytest.mark.parametrize("preset", ["robust", "paper"])
def test_step_ppa8(benchmark, preset, representation, n):
    benchmark(stepper(localiser(representation, n, "ppa8", preset)))


def test_image_motion(benchmark):
    model = ImageMotion()
    state = {"i": 0}

    def step() -> None:
        model.step(frames()[state["i"] % FRAMES])
        state["i"] += 1

    benchmark(step)


def median_ms(step, repeats: int = 15) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        step()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


LANES = (
    ("no lanes", NO_LANES),
    ("2", {"lanes": 1, "slow_lane": False}),
    ("3/2, 2", {"slow_lane": False}),
    ("3/2, 2, 1/2", {}),
)
"""The robust filter's speed lanes (docs/localise.md, item 13): none, the lane at 2 alone,
the two fast lanes, and the defaults' three."""


def lanes_table(repeats: int = 5) -> None:
    """Robust float per-frame medians with each set of speed lanes, side by side (the
    rows interleaved ``repeats`` times, so a noisy machine loads them alike)."""
    print(f"{'N':>9} {'place':>7} " + " ".join(f"{name:>13}" for name, _ in LANES))
    for n in SIZES[2:]:
        for rep in ("lbp", "lowres"):
            locs = [localiser(rep, n, "float", **kw) for _, kw in LANES]
            runs: list[list[float]] = [[] for _ in locs]
            for _ in range(repeats):
                for times, loc in zip(runs, locs, strict=True):
                    times.append(median_ms(stepper(loc), 3))
            cells = " ".join(f"{statistics.median(t):>13.2f}" for t in runs)
            print(f"{n:>9} {rep:>7} {cells}")


def main() -> None:
    if "--lanes" in sys.argv[1:]:
        lanes_table()
        return
    head = f"{'preset':>7} {'N':>9} {'lbp float':>10} {'lbp ppa8':>10} {'lowres float':>13}"
    print(head + f" {'lowres ppa8':>12}")
    for n in SIZES:
        for preset in ("robust", "paper"):
            row = [
                median_ms(stepper(localiser(rep, n, arithmetic, preset)))
                for rep in ("lbp", "lowres")
                for arithmetic in ("float", "ppa8")
            ]
            line = f"{preset:>7} {n:>9} {row[0]:>10.3f} {row[1]:>10.3f} {row[2]:>13.3f}"
            print(line + f" {row[3]:>12.3f}")
    print(f"image motion model: {median_ms(stepper_motion()):.3f} ms per frame")


def stepper_motion():
    model = ImageMotion()
    state = {"i": 0}

    def step() -> None:
        model.step(frames()[state["i"] % FRAMES])
        state["i"] += 1

    return step


if __name__ == "__main__":
    main()
