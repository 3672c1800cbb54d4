"""Noise statistics: every component produces its configured magnitude, seeded."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.errors import SimulatorError
from ppaloc.sim import FLAG, PRESETS, R5, R6, A, B, C, D, NoiseParams, Scamp5

SHAPE = (64, 64)  # 4096 elements per plane


def noisy(seed: int = 0, **params: float) -> Scamp5:
    return Scamp5(*SHAPE, noise=NoiseParams(**params), seed=seed)


def nop_kernel(sim: Scamp5):
    with sim.kernel() as k:
        for _ in range(1000):
            k.nop()
    return k


def advance(sim: Scamp5, k, ms: float) -> None:
    """Run nop kernels until `ms` of modelled time have passed, then apply decay."""
    end = sim.timing.now_us + ms * 1000
    while sim.timing.now_us < end:
        k.run()
    sim._elapse()


def test_ideal_is_exact_and_presets_exist() -> None:
    assert Scamp5(4, 4).noise.ideal
    assert {"low", "typical", "high"} <= set(PRESETS)
    assert PRESETS["low"].temporal_sd < PRESETS["typical"].temporal_sd < PRESETS["high"].temporal_sd
    with pytest.raises(SimulatorError, match=r"noise='loud' is unknown: use 'ideal', one of"):
        Scamp5(4, 4, noise="loud")
    with pytest.raises(SimulatorError, match=r"NoiseParams.temporal_sd=-1.0 is invalid"):
        NoiseParams(temporal_sd=-1.0)
    # a probability per millisecond: above 1 the decay's arithmetic has no meaning
    with pytest.raises(SimulatorError, match=r"digital_flip_per_ms=1.5 is invalid: it is a"):
        NoiseParams(digital_retention_ms=1.0, digital_flip_per_ms=1.5)
    assert NoiseParams(digital_retention_ms=1.0, digital_flip_per_ms=1.0).digital_flip_per_ms == 1


def test_temporal_noise_magnitude_and_independence() -> None:
    sim = noisy(temporal_sd=0.5)
    sim.write(A, np.full(SHAPE, 10.0))
    first = None
    errors = []
    for _ in range(8):
        sim.bus(B, A)
        err = sim.read(B) + 10
        errors.append(err)
        first = err if first is None else first
    e = np.stack(errors)
    assert abs(e.mean()) < 0.02
    assert e.std() == pytest.approx(0.5, rel=0.05)
    # fresh per write: consecutive writes of one element are uncorrelated
    lag1 = np.corrcoef(e[:-1].ravel(), e[1:].ravel())[0, 1]
    assert abs(lag1) < 0.05


def test_fixed_pattern_offsets_are_fixed_per_element_and_register() -> None:
    sim = noisy(fixed_offset_sd=1.0)
    sim.bus(B, A)
    once = sim.read(B)
    sim.bus(B, A)
    assert np.array_equal(sim.read(B), once)  # fixed in time
    assert once.std() == pytest.approx(1.0, rel=0.05)
    sim.bus(C, A)
    assert abs(np.corrcoef(once.ravel(), sim.read(C).ravel())[0, 1]) < 0.05  # per register
    other = noisy(seed=1, fixed_offset_sd=1.0)
    other.bus(B, A)
    assert not np.array_equal(other.read(B), once)


def test_transfer_error_is_proportional_to_signal() -> None:
    sim = noisy(transfer_gain=-0.01)
    sim.write(A, np.full(SHAPE, 100.0))
    sim.bus(B, A)
    assert np.allclose(sim.read(B), -99.0)
    sim.write(A, np.full(SHAPE, 10.0))
    sim.bus(B, A)
    assert np.allclose(sim.read(B), -9.9)
    spread = noisy(transfer_gain_sd=0.02)
    spread.write(A, np.full(SHAPE, 50.0))
    gains = []
    for _ in range(300):
        spread.bus(B, A)
        gains.append(spread.read(B)[0, 0] / -50.0 - 1)
    assert np.std(gains) == pytest.approx(0.02, rel=0.15)


def test_division_adds_its_own_noise() -> None:
    sim = noisy(temporal_sd=0.3, division_sd=0.4)
    sim.write(A, np.full(SHAPE, 20.0))
    sim.bus2(B, C, A)
    for reg in (B, C):
        assert (sim.read(reg) + 10).std() == pytest.approx(0.5, rel=0.05)
    sim.bus(B, A)
    assert (sim.read(B) + 20).std() == pytest.approx(0.3, rel=0.05)


def test_analogue_values_droop_towards_zero_with_modelled_time() -> None:
    sim = noisy(decay_per_ms=2.0)
    k = nop_kernel(sim)
    values = np.where(np.arange(SHAPE[1]) % 2 == 0, 50.0, -50.0) * np.ones(SHAPE)
    sim.write(A, values)
    sim.write(B, np.full(SHAPE, 1.0))
    sim._elapse()
    t0 = sim.timing.now_us
    advance(sim, k, 3.0)
    drop = 2.0 * (sim.timing.now_us - t0) / 1000
    assert np.allclose(sim.read(A), values - np.sign(values) * drop, atol=1e-3)
    assert not sim.read(B).any()  # never past zero


def test_digital_registers_decay_without_refresh() -> None:
    sim = noisy(digital_retention_ms=1.0, digital_flip_per_ms=0.5)
    k = nop_kernel(sim)
    sim.SET(R5, R6)
    t0 = sim.timing.now_us
    for _ in range(6):  # 6 x ~0.5 ms, refreshing R5 each time
        advance(sim, k, 0.5)
        sim.REFRESH(R5)
    assert sim.read(R5).all()
    beyond_ms = (sim.timing.now_us - t0) / 1000 - 1.0
    kept = sim.read(R6).mean()
    assert kept == pytest.approx(0.5**beyond_ms, abs=0.05)


def test_pixel_fixed_pattern_cancels_in_half_range_capture() -> None:
    sim = noisy(pixel_offset_sd=2.0)
    img = np.full(SHAPE, 128, dtype=np.uint8)
    sim.set_image(img)
    sim.get_image(A)  # PIX - reset level: the offset cancels
    assert np.allclose(sim.read(A), 0.0)
    sim.set_image(img)
    sim.get_image(B, C)  # 2 * PIX - reset level: the offset stays
    assert sim.read(B).std() == pytest.approx(2.0, rel=0.05)


def test_same_seed_same_bytes() -> None:
    def run(seed: int) -> bytes:
        sim = Scamp5(*SHAPE, noise="typical", seed=seed)
        sim.set_image(np.full(SHAPE, 90, dtype=np.uint8))
        sim.get_image(A, B)
        sim.div(C, D, B, A)
        return sim._a.tobytes()

    assert run(5) == run(5)
    assert run(5) != run(6)


def test_saturation_holds_with_noise() -> None:
    sim = Scamp5(*SHAPE, noise="high", seed=2)
    sim.write(A, np.full(SHAPE, -128.0))
    sim.bus(B, A)
    assert sim.read(B).max() <= 127 and sim.read(B).min() >= -128


def test_where_compares_a_noisy_sum() -> None:
    # FLAG := (0.1 + n > 0), n ~ N(0, 0.5): P = Phi(0.2) = 0.5793 per element
    sim = noisy(temporal_sd=0.5)
    sim.write(A, np.full(SHAPE, 0.1))
    flags = []
    for _ in range(4):
        sim.where(A)
        flags.append(sim.read(FLAG))
    assert np.mean(flags) == pytest.approx(0.5793, abs=0.02)  # 16384 draws: sd 0.004
    ideal = Scamp5(*SHAPE)
    ideal.write(A, np.full(SHAPE, 0.1))
    ideal.where(A)
    assert ideal.read(FLAG).all()


def test_small_arrays_get_fresh_temporal_noise_too() -> None:
    # a 4 x 4 array: 300 writes must not cycle through a handful of noise planes
    sim = Scamp5(4, 4, noise=NoiseParams(temporal_sd=1.0), seed=4)
    planes = set()
    for _ in range(300):
        sim.bus(B, A)
        planes.add(sim.read(B).tobytes())
    assert len(planes) >= 295
    # and one element's mean over many writes shrinks like sd / sqrt(n)
    values = []
    for _ in range(2000):
        sim.bus(B, A)
        values.append(sim.read(B)[1, 2])
    assert abs(np.mean(values)) < 4 / np.sqrt(2000)  # 4 sigma


@pytest.mark.parametrize("preset", ["low", "typical", "high"])
def test_each_preset_produces_its_table_magnitudes(preset: str) -> None:
    p = PRESETS[preset]
    sim = Scamp5(*SHAPE, noise=preset, seed=7)  # A = 0: the gain error has nothing to scale
    writes = []
    for _ in range(6):
        sim.bus(B, A)
        writes.append(sim.read(B).astype(np.float64))
    w = np.stack(writes)
    temporal = (w[1:] - w[:-1]).std() / np.sqrt(2)  # the fixed offset cancels
    assert temporal == pytest.approx(p.temporal_sd, rel=0.05)
    fixed = w.mean(axis=0)  # offset + temporal / sqrt(6)
    expected = np.sqrt(p.fixed_offset_sd**2 + p.temporal_sd**2 / 6)
    assert fixed.std() == pytest.approx(expected, rel=0.05)
    sim.write(A, np.full(SHAPE, 100.0))
    sim.bus2(B, C, A)  # -50 + offset + N(0, hypot(temporal, division))
    div = (sim.read(B) + 50 - sim.noise.offsets[B.index]).std()
    assert div == pytest.approx(np.hypot(p.temporal_sd, p.division_sd), rel=0.1)
