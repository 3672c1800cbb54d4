"""Helpers for the on-sensor tests: generated routes of blocky random places, and the
host's ppa8 filter against the sensor on one of them."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

Route = tuple[list[np.ndarray], list[np.ndarray]]

#: A query over 8 places with a stop at place 2 and a skip of place 5.
STOP_AND_SKIP = [0, 1, 2, 2, 2, 3, 4, 6, 7]


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


def agree(
    rep: str, route: Route, n_nodes: int, sensor_kw: dict | None = None, **kw
) -> tuple[list, list, object]:
    """The host's ppa8 filter and the sensor's on ``route``, each mapping it: the same map
    of ``n_nodes`` nodes, then both estimate lists and the sensor's localiser."""
    from ppaloc.localise.weighted import WeightedNodeLocaliser
    from ppaloc.onsensor import OnSensorLocaliser

    ref, query = route
    kw |= {"record_weights": True}
    host = WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)
    sensor = OnSensorLocaliser(rep, **kw, **(sensor_kw or {}))
    want, got = host.build_map(ref), sensor.build_map(ref)
    np.testing.assert_array_equal(got.descriptors, want.descriptors)
    np.testing.assert_array_equal(got.frame_index, want.frame_index)
    assert len(got) == n_nodes
    return host.localise(query), sensor.localise(query), sensor


def assert_same_estimates(a: list, b: list) -> None:
    """The same nodes, motion decisions and scores; the weights to 1e-4."""
    assert [e.node for e in b] == [e.node for e in a]
    assert [e.moved for e in b] == [e.moved for e in a]
    for x, y in zip(a, b, strict=True):
        assert y.score == x.score
        np.testing.assert_allclose(y.weights, x.weights, rtol=0, atol=1e-4)


def assert_maps_as_the_host(rep: str, shape: tuple[int, ...]) -> None:
    """The sensor's mapping run of ``rep`` gives the host's nodes (``shape``) on textured,
    black, white and random frames."""
    from ppaloc.onsensor import OnSensorLocaliser
    from ppaloc.topomap import build_topomap

    ref, _ = make_route(3, 6)
    ref += [np.zeros((256, 256), np.uint8), np.full((256, 256), 255, np.uint8)]
    ref.append(np.random.default_rng(6).integers(0, 256, (256, 256), dtype=np.uint8))
    got = OnSensorLocaliser(rep, motion="always_forward").build_map(ref)
    np.testing.assert_array_equal(got.descriptors, build_topomap(ref, rep).descriptors)
    assert got.kind == rep and got.descriptors.shape == shape


def places_with_runs(n: int, seed: int, runs: tuple[tuple[int, int], ...]) -> np.ndarray:
    """Places of ``n`` nodes: random runs, and the runs ``(first, last)`` given."""
    rng = np.random.default_rng(seed)
    same = rng.random(n) < 0.3
    for first, last in runs:
        same[first] = False
        same[first + 1 : last + 1] = True
        if last + 1 < n:
            same[last + 1] = False
    same[0] = False
    return np.cumsum(~same) - 1
