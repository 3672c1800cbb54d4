"""Simulation speed of the on-sensor pipelines: simulated frames per second.

``make bench`` runs these with pytest-benchmark; ``python benchmarks/bench_onsensor.py``
prints simulated frames per second (median over frames, one core) and the modelled
per-frame latency, for both pipelines and both filter presets (``"robust"``, ``"paper"``),
in ideal mode and under the ``"typical"`` noise preset, at the paper's map sizes (1024
low-res images, 2048 LBP descriptors; one full register each). The motion model is
``"image"`` and the frames move, so every stage of either preset runs.

Target on one core of this machine: >= 50 simulated frames per second for the 8x8
low-res pipeline in ideal mode (SCAMP-5 itself runs it at 386 frames per second).
"""

from __future__ import annotations

import statistics
import time
from functools import cache

import numpy as np
import pytest

from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.topomap import TopoMap

MAP_SIZES = {"lowres": 1024, "lbp": 2048}
FRAMES = 12


@cache
def frames() -> np.ndarray:
    """Blocky random frames (16x16-pixel cells) with a moving offset: real texture."""
    rng = np.random.default_rng(0)
    cells = rng.integers(0, 256, (FRAMES + 1, 17, 17)).astype(np.uint8)
    out = np.empty((FRAMES, 256, 256), np.uint8)
    for i in range(FRAMES):
        big = np.kron(cells[i], np.ones((16, 16), np.uint8))
        out[i] = big[i % 16 : i % 16 + 256, :256]
    return out


@cache
def topomap(representation: str) -> TopoMap:
    rng = np.random.default_rng(1)
    n = MAP_SIZES[representation]
    if representation == "lbp":
        return TopoMap("lbp", rng.integers(0, 2**32, n, dtype=np.uint32))
    return TopoMap("lowres", rng.integers(0, 256, (n, 8, 8), dtype=np.uint8))


def localiser(representation: str, noise: str, preset: str = "robust") -> OnSensorLocaliser:
    kw = {"alpha": 8} if preset == "paper" else {}
    loc = OnSensorLocaliser(representation, noise=noise, preset=preset, motion="image", **kw)
    loc.use_map(topomap(representation))
    for f in frames()[:3]:  # records every kernel once
        loc.step(f)
    return loc


def stepper(loc: OnSensorLocaliser):
    state = {"i": 0}

    def step() -> None:
        loc.step(frames()[state["i"] % FRAMES])
        state["i"] += 1

    return step


@pytest.mark.parametrize("preset", ["robust", "paper"])
@pytest.mark.parametrize("noise", ["ideal", "typical"])
@pytest.mark.parametrize("representation", ["lowres", "lbp"])
def test_frame(benchmark, representation, noise, preset):
    loc = localiser(representation, noise, preset)
    benchmark.pedantic(stepper(loc), rounds=FRAMES, iterations=1)


def measure(representation: str, noise: str, preset: str = "robust") -> tuple[float, float]:
    """(simulated frames per second, median modelled latency in ms)."""
    loc = localiser(representation, noise, preset)
    seconds, latency = [], []
    for f in frames():
        t = time.perf_counter()
        est = loc.step(f)
        seconds.append(time.perf_counter() - t)
        latency.append(est.modelled_latency_ms)
    return 1.0 / statistics.median(seconds), statistics.median(latency)


def main() -> None:
    print(f"{'pipeline':8s} {'preset':7s} {'noise':8s} {'frames/s':>9s} {'modelled ms':>12s}")
    for rep in ("lowres", "lbp"):
        for preset in ("robust", "paper"):
            for noise in ("ideal", "typical"):
                fps, ms = measure(rep, noise, preset)
                print(f"{rep:8s} {preset:7s} {noise:8s} {fps:9.1f} {ms:12.3f}", flush=True)


if __name__ == "__main__":
    main()
