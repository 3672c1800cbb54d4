"""Simulation speed of the on-sensor pipelines: simulated frames per second.

``make bench`` runs these with pytest-benchmark; ``python benchmarks/bench_onsensor.py``
prints simulated frames per second (median over frames, one core) and the modelled
per-frame latency, for both pipelines and both filter presets (``"robust"``, ``"paper"``),
in ideal mode and under the ``"typical"`` noise preset, at the paper's map sizes (1024
low-res images, 2048 LBP descriptors; one full register each), and the 16x16 place
(``lowres16``, 256 images, one full register; the robust preset, the one that runs on
it) and the Haar signs (``haar``, 512 places, both digital tiles of one sensor; robust).
The motion model is ``"image"`` and the frames move, so every stage of either preset
runs. Each row is one sensor's frame: the robust preset's speed lanes, a sensor each
(docs/onsensor.md, "The speed lanes"), are off (``lane_speed=0, slow_lane=False``);
with them a frame simulates four sensors.

Targets on one core of this machine, the pipelines of both representations (robust
preset, the compiled engine): the chip's own rates, 386 simulated frames per second for
8x8 images and 315 for descriptors (Castillo-Elizalde et al., ICRA 2021), in ideal mode,
and 150 under ``typical`` noise. Each row prints its ratio to the chip's rate of its kind
of place (``x chip``: 386 for the images, 315 for LBP and the Haar signs) and to the
modelled time of its own frame (``x modelled``: simulated frames/s times the modelled
frame; 1 would be a twin as fast as the sensor this program models).

``--fused`` runs the compiled engine's fused tier from the first run (its code compiled
while the localisers are set up, once per machine); without it, the first tier only.

``python benchmarks/bench_onsensor.py --split`` prints, for the robust pipelines, the
median frame time and how much of it the engine's kernel runs take (the ICWs, and under
noise the droop applied to the planes a kernel touches); the rest is the controller's
calls (DAC loads, shifts, patterns, readouts) and the timing bookkeeping.

``python benchmarks/bench_onsensor.py --bank [--bank-nodes N --bank-frames F --rep R]``
runs a map of the whole Nordland line's length (35,768 nodes: the shared Nordland
summer map repeated, each copy rotated by 97 places so copies differ at their joins) on
a bank of simulated sensors (docs/onsensor.md, "Sensor banks") over the first winter
query frames, and the host's ppa8 filter on the same map: agreement, modelled time and
energy per frame, simulation speed, upload time and peak memory.
"""

from __future__ import annotations

import os
import statistics
import time
from functools import cache

import numpy as np
import pytest

from ppaloc.localise.params import NO_LANES, runs_on
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.place import LOWRES_GRIDS, haar_plane, pack_plane
from ppaloc.topomap import TopoMap

MAP_SIZES = {"lowres": 1024, "lowres16": 256, "lbp": 2048, "haar": 512}
#: The pipelines measured, in the order printed.
REPRESENTATIONS = ("lowres", "lowres16", "lbp", "haar")
#: The paper's SCAMP-5d rates, frames per second: 8x8 images and descriptors.
CHIP_RATE = {"lowres": 386.0, "lowres16": 386.0, "lbp": 315.0, "haar": 315.0}
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
    if representation == "haar":  # the signs of random 16x16 images
        return TopoMap("haar", pack_plane(haar_plane(rng.integers(0, 256, (n, 16, 16)))))
    side = LOWRES_GRIDS[representation]
    return TopoMap(representation, rng.integers(0, 256, (n, side, side), dtype=np.uint8))


def localiser(representation: str, noise: str, preset: str = "robust") -> OnSensorLocaliser:
    """One sensor's pipeline (the speed lanes off) with the benchmark's map, warmed up."""
    kw = {"alpha": 8} if preset == "paper" else dict(NO_LANES)
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
@pytest.mark.parametrize("representation", REPRESENTATIONS)
def test_frame(benchmark, representation, noise, preset):
    if not runs_on(representation, preset):
        pytest.skip(f"the {preset} preset does not run on {representation}")
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


def split(representation: str, noise: str, preset: str = "robust") -> tuple[float, float]:
    """(median seconds per frame, median seconds of it inside the engine's kernel runs)."""
    from ppaloc.sim import Scamp5

    inside = [0.0]
    compile_kernel = Scamp5._compile_kernel

    def timed_compile(sim, instructions):  # each kernel's runner, timed
        run = compile_kernel(sim, instructions)

        def timed() -> None:
            t = time.perf_counter()
            run()
            inside[0] += time.perf_counter() - t

        return timed

    Scamp5._compile_kernel = timed_compile
    try:
        loc = localiser(representation, noise, preset)
        frame_s, kernel_s = [], []
        for _ in range(3):
            for f in frames():
                inside[0] = 0.0
                t = time.perf_counter()
                loc.step(f)
                frame_s.append(time.perf_counter() - t)
                kernel_s.append(inside[0])
    finally:
        Scamp5._compile_kernel = compile_kernel
    return statistics.median(frame_s), statistics.median(kernel_s)


def bank(n_nodes: int = 35_768, n_frames: int = 200, rep: str = "lbp") -> None:
    """The bank run of the module docstring; prints one block of figures."""
    import resource

    from ppaloc.datasets import to_sensor
    from ppaloc.datasets.registry import load_dataset
    from ppaloc.localise.weighted import WeightedNodeLocaliser

    ds = load_dataset("nordland:../shared/data/nordland-64x32?ref=summer&query=winter")
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in list(ds.query)[:n_frames]]
    # one bank, as the rows above are one sensor: the speed lanes (a bank each) off
    kw = {"motion": "always_forward", "record_weights": True, **NO_LANES}
    host = WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)
    base = host.build_map(ref).descriptors
    copies = -(-n_nodes // len(base))
    desc = np.concatenate([np.roll(base, -97 * c, axis=0) for c in range(copies)])[:n_nodes]
    big = TopoMap(rep, desc)
    host.use_map(big)
    t = time.perf_counter()
    loc = OnSensorLocaliser(rep, **kw)
    loc.use_map(big)
    upload = time.perf_counter() - t
    pipe = loc.pipeline
    sensors = getattr(pipe, "sensors", [pipe])
    want = host.localise(query)
    t = time.perf_counter()
    got = loc.localise(query)
    wall = time.perf_counter() - t
    same = np.mean([a.node == b.node for a, b in zip(want, got, strict=True)])
    werr = max(float(np.abs(a.weights - b.weights).max()) for a, b in zip(want, got, strict=True))
    ms = [e.modelled_latency_ms for e in got[1:]]
    mj = [e.energy_mj for e in got[1:]]
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(
        f"bank {rep}: {n_nodes} nodes on {len(sensors)} sensors "
        f"({sum(s.tiles for s in sensors)} tiles), {len(query)} query frames\n"
        f"  estimates equal to the host's ppa8 filter: {same * 100:.2f}% of frames, "
        f"max |dw| {werr:.1e}\n"
        f"  modelled per frame: {statistics.median(ms):.3f} ms (median; slowest sensor per "
        f"phase + exchanges), {statistics.median(mj):.3f} mJ (sum of the sensors)\n"
        f"  simulation: {len(query) / wall:.2f} frames/s ({wall:.0f} s for the query), map "
        f"upload {upload:.0f} s, peak memory {rss:.0f} MB"
    )


def main() -> None:
    import argparse

    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--bank", action="store_true", help="the sensor-bank run only")
    parser.add_argument("--bank-nodes", type=int, default=35_768)
    parser.add_argument("--bank-frames", type=int, default=200)
    parser.add_argument("--rep", default="lbp", choices=["lbp", "lowres"])
    parser.add_argument("--split", action="store_true", help="kernel runs vs the rest")
    parser.add_argument(
        "--fused",
        action="store_true",
        help="the compiled engine's fused tier from the first run (compiled at set-up, once "
        "per machine); without it the first tier only, so that no compile runs meanwhile",
    )
    args = parser.parse_args()
    os.environ["PPALOC_FUSE_AFTER"] = "1" if args.fused else "never"
    if args.bank:
        bank(args.bank_nodes, args.bank_frames, args.rep)
        return
    if args.split:
        print(f"{'pipeline':9s} {'noise':8s} {'frames/s':>9s} {'frame ms':>9s} {'kernels ms':>11s}")
        for rep in REPRESENTATIONS:
            for noise in ("ideal", "typical"):
                frame, kernels = split(rep, noise)
                ms = f"{frame * 1e3:9.2f} {kernels * 1e3:11.2f}"
                print(f"{rep:9s} {noise:8s} {1 / frame:9.1f} {ms}", flush=True)
        return
    head = f"{'pipeline':9s} {'preset':7s} {'noise':8s} {'frames/s':>9s} {'modelled ms':>12s}"
    print(f"{head} {'x chip':>7s} {'x modelled':>11s}")
    for rep in REPRESENTATIONS:
        for preset in ("robust", "paper"):
            if not runs_on(rep, preset):
                continue
            for noise in ("ideal", "typical"):
                fps, ms = measure(rep, noise, preset)
                ratios = f"{fps / CHIP_RATE[rep]:7.2f} {fps * ms / 1e3:11.3f}"
                print(f"{rep:9s} {preset:7s} {noise:8s} {fps:9.1f} {ms:12.3f} {ratios}", flush=True)


if __name__ == "__main__":
    main()
