"""ICWs per second of the simulator on a 256 x 256 array (``make bench``).

One mixed 100-ICW kernel (analogue arithmetic, neighbour moves, division, FLAG, digital
logic, DNEWS) is recorded once and replayed; the figure is 100 / (median replay time).
Targets on one core: >= 50,000 ICW/s ideal, >= 20,000 ICW/s with "typical" noise.
"""

from __future__ import annotations

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

N_ICWS = 100


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


def prepared(noise: str) -> tuple[Scamp5, Kernel]:
    sim = Scamp5(noise=noise, seed=1)
    rng = np.random.default_rng(2)
    sim.set_image(rng.integers(0, 256, (256, 256), dtype=np.uint8))
    k = mixed_kernel(sim)
    return sim, k


@pytest.mark.parametrize("noise", ["ideal", "typical"])
def test_icws_per_second(benchmark, noise: str) -> None:
    sim, k = prepared(noise)
    n = len(k)
    assert n == N_ICWS
    benchmark.extra_info["icws"] = n
    benchmark(k.run)
    rate = n / benchmark.stats.stats.median
    benchmark.extra_info["icw_per_s"] = round(rate)
    print(f"\n{noise}: {n} ICWs per kernel, {rate:,.0f} ICW/s (median)")
    assert np.isfinite(sim.read(NEWS)).all()
