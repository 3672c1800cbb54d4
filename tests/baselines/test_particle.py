"""The 1-D particle filter: seeded, resamples systematically, locks on and recovers."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.baselines.particle import ParticleFilter, systematic_resample
from ppaloc.errors import PpalocError


def test_systematic_resample_golden() -> None:
    w = np.array([0.5, 0.25, 0.25, 0.0])
    assert systematic_resample(w, 0.5).tolist() == [0, 0, 1, 2]
    assert systematic_resample(w, 0.0).tolist() == [0, 0, 1, 2]
    assert systematic_resample(np.array([0.0, 1.0, 0.0]), 0.99).tolist() == [1, 1, 1]


def test_systematic_resample_counts_are_floor_or_ceil() -> None:
    rng = np.random.default_rng(0)
    w = rng.random(50)
    counts = np.bincount(systematic_resample(w, 0.37), minlength=50)
    expected = 50 * w / w.sum()
    assert np.all(np.abs(counts - expected) < 1.0 + 1e-9)


def run(pf: ParticleFilter, frames) -> list:
    pf.reset()
    return [pf.step(f) for f in frames]


def test_same_seed_same_run_other_seed_differs(toy_route) -> None:
    ref, query = toy_route
    pf = ParticleFilter(record_weights=True)
    pf.build_map(ref)
    a, b = run(pf, query[:10]), run(pf, query[:10])
    assert [e.node for e in a] == [e.node for e in b]
    assert [e.score for e in a] == [e.score for e in b]
    np.testing.assert_array_equal(a[-1].weights, b[-1].weights)
    other = ParticleFilter(seed=1, record_weights=True)
    other.use_map(pf.map)
    c = run(other, query[:10])
    assert [e.score for e in a] != [e.score for e in c]


def test_locks_on_the_toy_route(toy_route) -> None:
    ref, query = toy_route
    pf = ParticleFilter()
    pf.build_map(ref)
    est = run(pf, query)
    nodes = np.array([e.node for e in est])
    assert np.mean(np.abs(nodes[5:] - np.arange(15, 50)) <= 1) >= 0.95
    assert all(0.0 <= e.score <= 1.0 for e in est)
    assert est[-1].score > 0.5


def test_recovers_from_a_kidnapping(toy_route) -> None:
    ref, query = toy_route
    pf = ParticleFilter()
    pf.build_map(ref)
    # Places 10..29, then a jump back to places 10..29 (the second half of the query
    # starts at place 10 again).
    frames = np.concatenate([query[:20], query[:20]])
    nodes = np.array([e.node for e in run(pf, frames)])
    assert np.all(np.abs(nodes[30:] - np.arange(20, 30)) <= 1)


def test_user_errors_name_the_fix() -> None:
    with pytest.raises(PpalocError, match="must be >= 0 and sum to at most 1"):
        ParticleFilter(p_stay=0.5, p_forward=0.6)
    with pytest.raises(PpalocError, match="observation='sad' is unknown"):
        ParticleFilter(observation="sad")
    with pytest.raises(PpalocError, match="max_jump >= 2"):
        ParticleFilter(max_jump=1)
