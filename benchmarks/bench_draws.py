"""The noise draws' cost per value against the memory floor, side by side in one run.

``python benchmarks/bench_draws.py`` times, on planes of 256 x 256 float32 values
(interleaved rounds, medians, ns per value):

- *write floor*: one float32 written per value (``hostloops.fill``, 4 bytes a value), the
  least any generator that delivers a plane can cost; *copy floor*: read 4 and write 4
  (``np.copyto``);
- *bank window*: what an ICW's temporal noise costs the engines, an add that reads a
  window of the seeded bank (``NoiseModel._bank``) into a plane;
- *counter normal*: ``ppaloc.sim.draws.normal`` (SplitMix64 at each index, the float32
  inverse-CDF transform, one compiled loop), and its numpy version; *counter bits*: the
  SplitMix64 words alone, their top 32 bits stored (what the transform adds to the hash);
- *PCG64*: numpy's ``standard_normal`` (float32, ziggurat) and its raw 64-bit words;
- *model bank*: the noise bank, offsets and pixel offsets of one 256 x 256 ``typical``
  model, drawn by the counter streams (``NoiseModel``) and, for comparison, by PCG64 as
  the model drew them before (the same amounts), in ms.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable

import numpy as np

from ppaloc.sim import draws, hostloops
from ppaloc.sim.noise import PRESETS, NoiseModel

N = 256 * 256


def _timer(fn: Callable[[], object], reps: int) -> Callable[[], float]:
    def once() -> float:
        fn()
        t = time.perf_counter()
        for _ in range(reps):
            fn()
        return (time.perf_counter() - t) / reps

    return once


def pcg_model(seed: int = 1) -> None:
    """The ``typical`` model's planes drawn as before the counter streams (PCG64)."""
    p = PRESETS["typical"]
    rng = np.random.default_rng([seed, 0x5CA45])
    (rng.standard_normal((7, 256, 256)) * p.fixed_offset_sd).astype(np.float32)
    (rng.standard_normal((256, 256)) * p.pixel_offset_sd).astype(np.float32)
    bank = (rng.standard_normal(4 * N) * p.temporal_sd).astype(np.float32)
    _ = bank * np.float32(math.hypot(p.temporal_sd, p.division_sd) / p.temporal_sd)


def bits_filler() -> Callable[[np.ndarray, np.uint64], None] | None:
    """A compiled loop storing the top 32 bits of each SplitMix64 word (None without numba)."""
    loops = draws._loops()
    if loops is None:
        return None
    import numba

    draw = loops.draw

    @numba.njit(error_model="numpy", boundscheck=False)
    def fill_bits(out, k):  # pragma: no cover - compiled
        for i in range(out.size):
            out[i] = np.uint32(draw(k, np.uint64(i)) >> np.uint64(32))

    return fill_bits


def main(rounds: int = 9) -> None:
    out = np.empty(N, np.float32)
    src = np.ones(N, np.float32)
    model = NoiseModel("typical", (256, 256), 7, seed=1)
    bank = model._bank
    k = draws.key(1, 9)
    rng = np.random.default_rng(0)
    words = np.empty(N, np.uint32)
    fill_bits = bits_filler()
    per_value = {
        "write floor (4 B)": _timer(lambda: hostloops.fill(out, 1.0), 200),
        "copy floor (4 B in, 4 B out)": _timer(lambda: np.copyto(out, src), 200),
        "bank window + add": _timer(lambda: np.add(src, bank[12_345 : 12_345 + N], out=out), 200),
        "counter normal (compiled)": _timer(lambda: draws.normal(k, 77, N, 0.25), 50),
        "counter normal (numpy)": _timer(lambda: draws.normal_numpy(k, 77, N, 0.25), 5),
        **(
            {"counter bits (compiled)": _timer(lambda: fill_bits(words, k), 200)}
            if fill_bits
            else {}
        ),
        "PCG64 standard_normal f32": _timer(
            lambda: rng.standard_normal(N, np.float32, out=out), 20
        ),
        "PCG64 raw 64-bit words": _timer(lambda: rng.bit_generator.random_raw(N), 20),
    }
    per_model = {
        "model planes, counter streams": _timer(
            lambda: NoiseModel("typical", (256, 256), 7, seed=1), 3
        ),
        "model planes, PCG64 (before)": _timer(pcg_model, 3),
    }
    times: dict[str, list[float]] = {name: [] for name in [*per_value, *per_model]}
    for _ in range(rounds):
        for name, timer in [*per_value.items(), *per_model.items()]:
            times[name].append(timer())
    med = {name: statistics.median(v) for name, v in times.items()}
    floor = med["write floor (4 B)"] / N
    print(f"{'per value, 256 x 256 float32':32s} {'ns':>8s} {'x write floor':>14s}")
    for name in per_value:
        ns = med[name] / N
        print(f"{name:32s} {ns * 1e9:8.3f} {ns / floor:14.1f}")
    for name in per_model:
        print(f"{name:32s} {med[name] * 1e3:8.2f} ms")


if __name__ == "__main__":
    main()
