"""Helpers for the on-sensor tests: generated routes of blocky random places."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

Route = tuple[list[np.ndarray], list[np.ndarray]]


def make_route(n: int, seed: int, order: Sequence[int] | None = None) -> Route:
    """(reference, query): ``n`` blocky random sensor frames (16 x 16 blocks of 16 x 16
    PEs); the query visits the places in ``order`` (default each once), each with noise."""
    rng = np.random.default_rng(seed)
    base = rng.integers(0, 256, (n, 16, 16)).astype(np.uint8)
    ref = [np.kron(b, np.ones((16, 16), np.uint8)) for b in base]
    query = []
    for i in range(n) if order is None else order:
        noise = rng.integers(-12, 13, ref[i].shape)
        query.append(np.clip(ref[i].astype(int) + noise, 0, 255).astype(np.uint8))
    return ref, query


@pytest.fixture
def blocky_route() -> Callable[..., Route]:
    """:func:`make_route`, for tests that build their own routes."""
    return make_route
