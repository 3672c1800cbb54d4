"""Simulator speed per engine and noise mode, side by side (``make bench``; or run this file).

Two kernels on a 256 x 256 array, recorded once and replayed:

- the *mixed* 100-ICW kernel (analogue arithmetic, neighbour moves, division, FLAG,
  digital logic, DNEWS);
- an *all-analogue frame* (capture, then 8x8 block means by three halvings east and three
  south: the shape of the on-sensor low-res reduction), 42 ICWs.

Both are measured against the *numpy floor*: one ``np.add`` plus one clip per ICW on a
256 x 256 float32 plane, the cost of an engine that issues a numpy call per ICW.
``python benchmarks/bench_sim.py`` prints ICW/s per engine and mode, the floor, the ratio
to it, and simulated frames/s of both on-sensor pipelines per engine, all in one run with
the engines interleaved round by round (medians; this machine is shared, so only figures
of one run compare). Targets (issue 12): compiled, ideal: >= 5x the floor on both kernels;
the on-sensor 8x8 pipeline at >= 386 simulated frames/s ideal, >= 100 with typical noise.
"""

from __future__ import annotations

import importlib.util
import os
import statistics
import sys
import time
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from ppaloc.sim import (
    NEWS,
    R5,
    R6,
    R7,
    R8,
    R9,
    A,
    B,
    C,
    D,
    E,
    F,
    Kernel,
    Scamp5,
    east,
    north,
    south,
    west,
)
from ppaloc.sim.engines import available_engines
from ppaloc.sim.noise import fast_clip

N_ICWS = 100
MODES = ("ideal", "typical")


def mixed_kernel(sim: Scamp5) -> Kernel:
    """Record a 100-ICW kernel mixing every clock class and common macros."""
    with sim.kernel() as k:
        k.get_image(A, B)  # 6
        k.movx(C, A, east)  # 2
        k.sub(D, A, C)  # 2
        k.movx(C, A, south)  # 2
        k.sub(E, A, C)  # 2
        k.abs(F, D)  # 6
        k.add(C, F, E)  # 2
        k.divq(D, C)  # 2
        k.div(D, E, F, C)  # 5
        k.diva(D, E, F)  # 5
        k.addx(E, A, B, west)  # 2
        k.subx(F, A, north, B)  # 2
        k.where(D)  # 1
        k.mov(E, A)  # 2
        k.neg(F, E)  # 2
        k.all()  # 1
        k.newsblur(C, A, 2)  # 4
        k.bus3(D, E, F, C)  # 1
        k.bus2(D, E, A, B)  # 1
        k.res(F)  # 2
        k.SET(R5)  # 1
        k.CLR(R6, R7)  # 1
        k.where(A)  # 1
        k.all()  # 1
        k.NOT(R6, R5)  # 1
        k.OR(R7, R5, R6)  # 1
        k.NOR(R8, R5, R6, R7)  # 1
        k.AND(R9, R5, R7)  # 4
        k.XOR(R8, R5, R6)  # 7
        k.MUX(R9, R5, R6, R7)  # 5
        k.DNEWS(R8, R9, north | east)  # 3
        k.DNEWS(R6, R5, south, 1)  # 3
        k.MOV(R7, R8)  # 1
        k.REFRESH(R5)  # 2
        k.WHERE(R5)  # 1
        k.ALL()  # 1
        k.movx(D, A, west)  # 2
        k.mov2x(E, A, north, east)  # 2
        k.add(F, A, B, C)  # 2
        k.AND(R7, R5, R6)  # 4
        k.OR(R9, R5)  # 2
        k.nop()  # 1
        k.SET(R8)  # 1
    assert len(k) == N_ICWS, len(k)
    return k


def analogue_frame(sim: Scamp5) -> Kernel:
    """Record an analogue-only frame: capture, then 8x8 block means by six halvings."""
    with sim.kernel() as k:
        k.get_image(A, D)  # 6
        for direction in (west, west, west, north, north, north):
            k.movx(B, A, direction)  # 2: the neighbour's value
            k.add(C, A, B)  # 2
            k.divq(A, C)  # 2: the pair's mean
    assert len(k) == 42, len(k)
    return k


KERNELS: dict[str, Callable[[Scamp5], Kernel]] = {"mixed": mixed_kernel, "frame": analogue_frame}


#: "fused": the compiled engine with every stretch fused from its first run (its second
#: tier; compiled once per machine, then taken from the cache folder).
FUSED = "fused"


def bench_engines() -> list[str]:
    """The installed engines, and the compiled engine's fused tier where numba is."""
    engines = available_engines()
    return [*engines, FUSED] if "compiled" in engines else engines


@contextmanager
def engine_env(engine: str):
    """``PPALOC_ENGINE`` (and ``PPALOC_FUSE_AFTER``) for ``engine``, restored afterwards."""
    wanted = {"PPALOC_ENGINE": "compiled" if engine == FUSED else engine}
    wanted["PPALOC_FUSE_AFTER"] = "1" if engine == FUSED else "never"
    before = {key: os.environ.get(key) for key in wanted}
    os.environ.update(wanted)
    try:
        yield
    finally:
        for key, value in before.items():
            if value is None:
                del os.environ[key]
            else:
                os.environ[key] = value


def prepared(kernel: str, noise: str, engine: str | None = None) -> tuple[Scamp5, Kernel]:
    with engine_env(engine or available_engines()[-1]):
        sim = Scamp5(noise=noise, seed=1)
        rng = np.random.default_rng(2)
        sim.set_image(rng.integers(0, 256, (256, 256), dtype=np.uint8))
        return sim, KERNELS[kernel](sim)


def numpy_floor() -> Callable[[], None]:
    """One numpy add plus one clip on a 256 x 256 float32 plane: the per-ICW call floor."""
    x = np.zeros((256, 256), np.float32)
    y = np.full((256, 256), 0.5, np.float32)
    lo, hi = np.float32(-128), np.float32(127)

    def icw() -> None:
        np.add(x, y, out=x)
        fast_clip(x, lo, hi, out=x)

    return icw


@pytest.mark.parametrize("noise", MODES)
@pytest.mark.parametrize("kernel", list(KERNELS))
@pytest.mark.parametrize("engine", bench_engines())
def test_icws_per_second(benchmark, engine: str, kernel: str, noise: str) -> None:
    sim, k = prepared(kernel, noise, engine)
    benchmark.extra_info["icws"] = len(k)
    benchmark(k.run)
    assert np.isfinite(sim.read(NEWS)).all()
    if benchmark.stats:  # None under --benchmark-disable
        rate = len(k) / benchmark.stats.stats.median
        benchmark.extra_info["icw_per_s"] = round(rate)
        print(f"\n{engine} {kernel} {noise}: {len(k)} ICWs per kernel, {rate:,.0f} ICW/s")


def test_numpy_floor(benchmark) -> None:
    benchmark(numpy_floor())
    if benchmark.stats:
        print(f"\nnumpy floor: {1 / benchmark.stats.stats.median:,.0f} ICW/s (median)")


# --------------------------------------------------------------------- one side-by-side run
def _timer(fn: Callable[[], None], reps: int) -> Callable[[], float]:
    def once() -> float:
        fn()  # warm: caches hold this workload's planes, as in a steady replay loop
        t = time.perf_counter()
        for _ in range(reps):
            fn()
        return (time.perf_counter() - t) / reps

    return once


def _onsensor_module():
    path = Path(__file__).with_name("bench_onsensor.py")
    spec = importlib.util.spec_from_file_location("bench_onsensor", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _localiser(bench, representation: str, noise: str, engine: str):
    """An on-sensor localiser whose simulators run on ``engine`` (kernels recorded)."""
    with engine_env(engine):
        return bench.localiser(representation, noise)


def main(rounds: int = 7, engines: list[str] | None = None, onsensor: bool = True) -> None:
    engines = engines or bench_engines()
    timers: dict[tuple, Callable[[], float]] = {("floor", "-", "-"): _timer(numpy_floor(), 200)}
    sizes = {}
    for engine in engines:
        reps = 1 if engine == "reference" else 10
        for kernel in KERNELS:
            for noise in MODES:
                _, k = prepared(kernel, noise, engine)
                timers[(engine, kernel, noise)] = _timer(k.run, reps)
                sizes[kernel] = len(k)
    if onsensor:
        bench = _onsensor_module()
        for engine in engines:
            if engine == "reference":
                continue  # minutes per frame set: run it on its own if wanted
            for rep in ("lowres", "lbp"):
                for noise in MODES:
                    step = bench.stepper(_localiser(bench, rep, noise, engine))
                    timers[(engine, f"onsensor-{rep}", noise)] = _timer(step, 2)
    times: dict[tuple, list[float]] = {key: [] for key in timers}
    for _ in range(rounds):  # interleaved, so that load changes hit every figure alike
        for key, timer in timers.items():
            times[key].append(timer())
    med = {key: statistics.median(v) for key, v in times.items()}
    floor = 1 / med[("floor", "-", "-")]
    print(f"numpy floor (one add + clip per ICW, 256 x 256): {floor:,.0f} ICW/s")
    print(f"{'engine':10s} {'kernel':16s} {'noise':8s} {'rate':>16s} {'x floor':>8s}")
    for (engine, kernel, noise), t in med.items():
        if engine == "floor":
            continue
        if kernel in KERNELS:
            rate = sizes[kernel] / t
            shown = f"{rate:12,.0f} ICW/s"
            ratio = f"{rate / floor:8.2f}"
        else:
            shown, ratio = f"{1 / t:9.1f} frames/s", ""
        print(f"{engine:10s} {kernel:16s} {noise:8s} {shown:>16s} {ratio:>8s}", flush=True)


if __name__ == "__main__":
    main(engines=sys.argv[1:] or None)
