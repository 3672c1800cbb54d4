"""Single-frame matching and the registry entries of all four baselines."""

from __future__ import annotations

import numpy as np
import pytest

from ppaloc.baselines import ABLEM, ParticleFilter, SeqSLAM, SingleFrame
from ppaloc.baselines._common import top_k, uniqueness_ratio
from ppaloc.localise.base import Localiser
from ppaloc.methods import make_localiser


def test_uniqueness_ratio_golden() -> None:
    costs = np.array([5.0, 1.0, 2.0, 4.0, 8.0])
    # best = 1; outside +-1 -> nodes 3, 4 -> second = 4 -> 1 - 1/4.
    assert uniqueness_ratio(costs, 1, 1) == 0.75
    assert uniqueness_ratio(costs, 1, 10) == 1.0  # no competitor
    assert uniqueness_ratio(np.array([0.0, 5.0, 0.0]), 0, 1) == 0.0  # a tie at zero cost


def test_top_k_orders_best_first_with_ties_to_lower_index() -> None:
    ev = np.array([0.1, 0.9, 0.5, 0.9, 0.2])
    assert top_k(ev, 3).tolist() == [1, 3, 2]
    assert top_k(ev, 10).tolist() == [1, 3, 2, 4, 0]


def test_single_frame_finds_exact_revisits_and_is_unsure_off_route(toy_route) -> None:
    ref, query = toy_route
    s = SingleFrame()
    s.build_map(ref)
    est = [s.step(f) for f in ref[5:15]]
    assert [e.node for e in est] == list(range(5, 15))
    noisy = [s.step(f) for f in query]
    assert np.mean([e.node == t for e, t in zip(noisy, range(10, 50), strict=True)]) >= 0.9
    off = np.random.default_rng(5).integers(0, 256, (5, 256, 256), dtype=np.uint8)
    assert max(s.step(f).score for f in off) < min(e.score for e in est)


@pytest.mark.parametrize(
    ("name", "cls"),
    [
        ("seqslam", SeqSLAM),
        ("able-m", ABLEM),
        ("particle-filter", ParticleFilter),
        ("single-frame", SingleFrame),
    ],
)
def test_registry_builds_each_baseline_with_defaults(name, cls, toy_route) -> None:
    ref, query = toy_route
    loc = make_localiser(name)
    assert isinstance(loc, cls) and isinstance(loc, Localiser)
    assert loc.name == name
    m = loc.build_map(ref[:12])
    assert len(m) == 12 and m.kind == name
    loc.reset()
    e = loc.step(query[0])
    assert 0 <= e.node < 12 and isinstance(e.score, float)
    assert e.ranking is not None and e.ranking[0] == e.node
    assert e.weights is None
    loc2 = make_localiser(name, record_weights=True)
    loc2.use_map(m)
    assert loc2.step(query[0]).weights.shape == (12,)
