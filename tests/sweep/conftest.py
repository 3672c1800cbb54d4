"""Fixtures of the sweep tests: tiny routes, a grid in the issue's form, Dask clusters."""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

from ppaloc.evaluate.sweep import SweepConfig

TINY = ("synthetic:?places=20&seed=1&size=64", "synthetic:?places=20&seed=2&size=64")
"""Two 20-place procedural routes with 64x64 frames: a cell takes a fraction of a second."""

ISSUE_TOML = """\
[sweep]
methods = ["weighted-node-paper-lbp", "seqslam"]
datasets = ["synthetic:?places=20&seed=1&size=64", "synthetic:?places=20&seed=2&size=64"]
tolerance = 2

[sweep.params.weighted-node-paper-lbp]
gamma = [0.25, 0.5]
"""
"""The issue's example on tiny routes, with gamma on the paper's Algorithm 1 (the method
that takes it): 6 cells."""


@pytest.fixture
def tiny() -> tuple[str, str]:
    return TINY


@pytest.fixture
def issue_config() -> SweepConfig:
    """:data:`ISSUE_TOML` as a :class:`SweepConfig`."""
    return SweepConfig(
        methods=("weighted-node-paper-lbp", "seqslam"),
        datasets=TINY,
        tolerance=2,
        params={"weighted-node-paper-lbp": {"gamma": [0.25, 0.5]}},
    )


@contextmanager
def local_cluster(n_workers: int, *, processes: bool) -> Iterator[Any]:
    """A quiet ``LocalCluster`` and its client; on exit every worker process has ended."""
    import psutil
    from distributed import Client, LocalCluster

    cluster = LocalCluster(
        n_workers=n_workers,
        threads_per_worker=1,
        processes=processes,
        dashboard_address=":0",
        silence_logs=logging.CRITICAL,
    )
    client = Client(cluster, set_as_default=False)
    pids = set(client.run(os.getpid).values()) if processes else set()
    try:
        yield client
    finally:
        if processes:  # the workers now (a killed worker was restarted with a new pid)
            pids |= set(client.run(os.getpid).values())
        client.close()
        cluster.close()
        children = [p for p in psutil.Process().children(recursive=True) if p.pid in pids]
        _, alive = psutil.wait_procs(children, timeout=10)
        assert not alive, f"worker processes left behind: {alive}"


@pytest.fixture(scope="session")
def make_cluster():
    """:func:`local_cluster`, for a test that needs a cluster of its own."""
    return local_cluster


@pytest.fixture(scope="module")
def cluster2() -> Iterator[Any]:
    """A client on a LocalCluster of 2 single-threaded worker processes (per module)."""
    logger = logging.getLogger("distributed")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        with local_cluster(2, processes=True) as client:
            yield client
    finally:
        logger.setLevel(level)


@pytest.fixture
def issue_toml(tmp_path) -> Any:
    path = tmp_path / "sweep.toml"
    path.write_text(ISSUE_TOML)
    return path
