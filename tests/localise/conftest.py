"""Helpers for the localise tests: blocky sensor frames with known low-res images."""

from __future__ import annotations

import numpy as np
import pytest


def blocky(image: np.ndarray) -> np.ndarray:
    """A (256, 256) sensor frame whose 32x32 blocks are constant: ``lowres_image`` = image."""
    return np.kron(np.asarray(image, np.uint8), np.ones((32, 32), np.uint8))


def stepped(route: np.ndarray, pattern: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Query frames at the route positions given by repeating ``pattern`` steps, and
    those positions."""
    idx, pos, i = [], 0, 0
    while pos < len(route):
        idx.append(pos)
        pos += pattern[i % len(pattern)]
        i += 1
    return route[idx], np.asarray(idx)


@pytest.fixture
def route() -> np.ndarray:
    """20 seeded random blocky frames: a toy route whose places all look different."""
    rng = np.random.default_rng(7)
    return np.stack([blocky(rng.integers(0, 256, (8, 8))) for _ in range(20)])
