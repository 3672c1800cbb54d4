"""A tiny stand-in Localiser and RouteDataset for the run, report and CLI tests.

Registered under a throw-away module name (``register(monkeypatch)``) so the method
registry can construct it like any real method.
"""

from __future__ import annotations

import sys
import types
from collections.abc import Sequence

import numpy as np

from ppaloc.datasets import RouteDataset
from ppaloc.localise.base import Estimate
from ppaloc.methods import METHODS, MethodSpec
from ppaloc.topomap import TopoMap

MODULE = "ppaloc_test_standin"


class MeanMatch:
    """Nearest reference frame by mean grey level; score = minus the distance.

    Frame ``i`` of :func:`tiny_dataset` has mean ``20 * i + 10``, so the estimate is exact
    up to the query noise.
    """

    def __init__(
        self,
        *,
        record_weights: bool = False,
        modelled: bool = False,
        seed: int = 0,
        offset: int = 0,
    ) -> None:
        self.name = "mean-match"
        self.record_weights = record_weights
        self.modelled = modelled
        self.seed = seed
        self.offset = offset
        self.topomap: TopoMap | None = None
        self.steps = 0

    def build_map(self, frames: Sequence[np.ndarray]) -> TopoMap:
        means = np.array([[float(np.mean(f))] for f in frames])
        self.use_map(TopoMap("mean", means, params={"offset": self.offset}))
        assert self.topomap is not None
        return self.topomap

    def use_map(self, topomap: TopoMap) -> None:
        self.topomap = topomap

    def reset(self) -> None:
        self.steps = 0

    def register_planes(self) -> dict[str, np.ndarray]:
        """Two planes standing in for a simulated sensor's registers (modelled mode only)."""
        if not self.modelled:
            return {}
        ramp = np.tile(np.linspace(-128, 127, 64, dtype=np.float32), (64, 1))
        return {"A: ramp": ramp, "R5: bits": ramp > 0}

    def step(self, frame: np.ndarray) -> Estimate:
        assert frame.shape == (256, 256) and frame.dtype == np.uint8
        assert self.topomap is not None
        self.steps += 1
        d = np.abs(self.topomap.descriptors[:, 0] - float(np.mean(frame)))
        node = int((np.argmin(d) + self.offset) % len(d))
        return Estimate(
            node=node,
            score=-float(d[node]),
            moved=None,
            ranking=np.argsort(d, kind="stable")[:3],
            weights=-d if self.record_weights else None,
            modelled_latency_ms=0.25 if self.modelled else None,
            energy_mj=0.002 if self.modelled else None,
        )


def tiny_dataset(n: int = 10, *, no_match_last: bool = True) -> RouteDataset:
    """``n`` flat reference frames (mean 20i + 10) and a noisy query of the same places.

    Query ``j`` matches references ``j-1 .. j+1`` (tolerance 1); the last query has no true
    match when ``no_match_last``.
    """
    rng = np.random.default_rng(0)
    ref = [np.full((16, 24), 20 * i + 10, np.uint8) for i in range(n)]
    qry = [
        np.clip(f.astype(int) + rng.integers(-3, 4, f.shape), 0, 255).astype(np.uint8) for f in ref
    ]
    gt = [np.arange(max(0, j - 1), min(n, j + 2)) for j in range(n)]
    if no_match_last:  # an unseen place, far from every reference: the least confident
        gt[-1] = np.zeros(0, np.int64)
        qry[-1] = np.full_like(qry[-1], 250)
    pos = np.arange(n, dtype=float)[:, None] * 5.0
    return RouteDataset(
        "tiny",
        ref,
        qry,
        gt,
        tolerance=1,
        reference_positions=pos,
        query_positions=pos + 1.0,
        meta={"spec": "tiny"},
    )


def register(monkeypatch, name: str = "mean-match", **defaults) -> str:
    """Make ``name`` a registered, available method backed by :class:`MeanMatch`."""
    module = types.ModuleType(MODULE)
    module.MeanMatch = MeanMatch  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, MODULE, module)
    monkeypatch.setitem(METHODS, name, MethodSpec(f"{MODULE}:MeanMatch", defaults, "stand-in"))
    return name
