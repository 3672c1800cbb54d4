"""Counter-based draws (ppaloc.sim.draws): a value is a function of (key, index) alone."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats
from scipy.special import ndtri

from ppaloc.errors import SimulatorError
from ppaloc.sim import Scamp5, draws
from ppaloc.sim.hostloops import have_numba


def test_the_compiled_loop_gives_numpys_bytes() -> None:
    if not have_numba():
        pytest.skip("numba is not installed: normal() is normal_numpy()")
    for seed, start in ((0, 0), (5, 123_456_789), (9, 2**40 + 7)):
        k = draws.key(seed, 3)
        fast = draws.normal(k, start, 20_000, 0.25)
        slow = draws.normal_numpy(k, start, 20_000, 0.25)
        assert fast.dtype == slow.dtype == np.float32
        assert fast.tobytes() == slow.tobytes()


def test_words_at_the_ends_of_the_range() -> None:
    # top 32 bits: sign bit, then k; v = (k + 1/2) / 2**31 is P(|Z| > z)
    ks = np.array([0, 1, 1000, 2**20, 2**24, 2**30, 2**31 - 2**8], dtype=np.uint64)
    z = draws.normal_of_bits(ks << np.uint64(32))
    v = (ks.astype(np.float32).astype(np.float64) + 0.5) / 2**31
    exact = ndtri(1 - v / 2)
    body = exact < 5.04  # all but 5e-7 of the draws
    assert np.allclose(z[body], exact[body], rtol=2e-6, atol=1e-6)
    assert np.allclose(z, exact, rtol=4e-4)  # the far tail
    assert z[0] == pytest.approx(6.338, abs=0.003)  # the largest |z|
    neg = draws.normal_of_bits((ks | np.uint64(1 << 31)) << np.uint64(32))
    assert np.array_equal(neg, -z)  # the sign bit negates exactly
    # k = 2**31 - 1 rounds to v = 1 in float32: z = 0, no NaN
    assert draws.normal_of_bits(np.array([0x7FFFFFFF << 32], dtype=np.uint64))[0] == 0


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**63),
    start=st.integers(0, 2**62),
    cuts=st.lists(st.integers(0, 300), min_size=1, max_size=4),
)
def test_a_draw_depends_on_its_index_only(seed: int, start: int, cuts: list[int]) -> None:
    k = draws.key(seed, 1)
    whole = draws.normal(k, start, 300)
    edges = sorted({0, 300, *cuts})
    pieces = [draws.normal(k, start + a, b - a) for a, b in itertools.pairwise(edges)]
    assert np.concatenate(pieces).tobytes() == whole.tobytes()
    assert draws.normal(k, start, 300).tobytes() == whole.tobytes()  # same seed, same bytes
    other = draws.normal(draws.key(seed, 2), start, 300)  # another stream
    assert not np.array_equal(other, whole)


def test_a_stream_is_standard_normal_and_uncorrelated() -> None:
    z = draws.normal(draws.key(11, 1), 0, 1 << 18).astype(np.float64)
    assert abs(z.mean()) < 4 / np.sqrt(z.size)
    assert z.var() == pytest.approx(1.0, abs=4 * np.sqrt(2 / z.size))
    assert (z**4).mean() == pytest.approx(3.0, abs=0.05)  # kurtosis: not a sum of uniforms
    assert stats.kstest(z, "norm").pvalue > 1e-3
    for lag in (1, 2, 256):  # neighbours in index (a plane's rows are 256 long)
        assert abs(np.corrcoef(z[:-lag], z[lag:])[0, 1]) < 4 / np.sqrt(z.size)
    # two streams of one seed, and one stream of two seeds, element by element
    w = draws.normal(draws.key(11, 2), 0, 1 << 18).astype(np.float64)
    u = draws.normal(draws.key(12, 1), 0, 1 << 18).astype(np.float64)
    assert abs(np.corrcoef(z, w)[0, 1]) < 4 / np.sqrt(z.size)
    assert abs(np.corrcoef(z, u)[0, 1]) < 4 / np.sqrt(z.size)


def test_index_below_is_uniform_and_checked() -> None:
    idx = draws.index_below(draws.key(1, 4), np.arange(60_000, dtype=np.uint64), 7)
    assert idx.min() == 0 and idx.max() == 6
    counts = np.bincount(idx, minlength=7)
    assert stats.chisquare(counts).pvalue > 1e-3
    with pytest.raises(SimulatorError, match=r"index_below: n=0 is out of range; use 1 <= n"):
        draws.index_below(draws.key(1, 4), np.arange(3, dtype=np.uint64), 0)


def test_the_noise_models_draws_are_by_index() -> None:
    a = Scamp5(16, 16, noise="typical", seed=3).noise
    b = Scamp5(16, 16, noise="typical", seed=3).noise
    first = a.take(5000)  # crosses a batch
    assert a.draws_taken == 5000
    starts, gains = b.draw(4000, 1000)
    assert np.array_equal(first[0][4000:], starts) and np.array_equal(first[1][4000:], gains)
    assert b.draws_taken == 0  # drawing by index takes nothing
    assert a.offsets.tobytes() == b.offsets.tobytes()
    assert a._bank.tobytes() == b._bank.tobytes()
    assert 0 <= starts.min() and starts.max() <= len(a._bank) - 256
    with pytest.raises(SimulatorError, match=r"NoiseModel.draw: an ideal model draws no noise"):
        Scamp5(4, 4).noise.draw(0, 1)
