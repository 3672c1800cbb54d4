"""A toy route shared by the baseline tests: distinct places, a noisy, darker second pass."""

from __future__ import annotations

import numpy as np
import pytest


def make_route(n: int, seed: int) -> np.ndarray:
    """``n`` sensor frames of distinct places: random 16x16 grey patterns, upsampled."""
    rng = np.random.default_rng(seed)
    small = rng.integers(20, 236, (n, 16, 16)).astype(np.float64)
    return np.kron(small, np.ones((16, 16))).astype(np.uint8)


def revisit(frames: np.ndarray, seed: int, noise: float = 25.0, gain: float = 0.7) -> np.ndarray:
    """The same places seen again: darker (``gain``) with Gaussian pixel noise."""
    rng = np.random.default_rng(seed)
    out = frames.astype(np.float64) * gain + rng.normal(0.0, noise, frames.shape)
    return np.clip(out, 0, 255).astype(np.uint8)


@pytest.fixture(scope="module")
def toy_route() -> tuple[np.ndarray, np.ndarray]:
    """(reference, query): 60 reference places; the query revisits places 10 .. 49."""
    ref = make_route(60, seed=1)
    query = revisit(ref[10:50], seed=2)
    return ref, query
