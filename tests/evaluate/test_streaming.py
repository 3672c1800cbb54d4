"""Streaming: map, evaluate and localise consume frames one at a time, and stop at Ctrl-C.

A watched traversal makes each frame on request and counts how many it has made and how
many are still alive, so a method or a run that materialises the traversal (a list of
frames, ``np.stack``, a frame kept per estimate) or reads ahead fails here.
"""

from __future__ import annotations

import weakref
from pathlib import Path

import numpy as np
import pytest

from ppaloc.datasets import RouteDataset
from ppaloc.datasets.frames import DEFAULT_CACHE, RenderedFrames
from ppaloc.evaluate import run as run_module
from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.run import run_evaluation
from ppaloc.localise.base import Estimate
from ppaloc.methods import available_methods, make_localiser
from ppaloc.topomap import TopoMap

ALIVE_BOUND = DEFAULT_CACHE + 4
"""Frames a streaming run may hold at once: one sequence's cache and the frames in use."""

HOST_METHODS = [m for m in available_methods() if not m.startswith("onsensor")]


class Watched:
    """A generated traversal: frame ``i`` (a (256, 256) sensor frame) made on request.

    ``made`` counts the frames made, ``peak`` the most alive at once; ``interrupt_at``
    raises KeyboardInterrupt when that frame is requested (a Ctrl-C between frames).
    """

    def __init__(self, seed: int, interrupt_at: int | None = None) -> None:
        self.seed, self.interrupt_at = seed, interrupt_at
        self.made = self.alive = self.peak = 0

    def __call__(self, i: int) -> np.ndarray:
        if i == self.interrupt_at:
            raise KeyboardInterrupt
        rng = np.random.default_rng([self.seed, i // 2])  # two frames per place
        frame = np.repeat(np.repeat(rng.integers(0, 256, (16, 16), np.uint8), 16, 0), 16, 1)
        self.made += 1
        self.alive += 1
        self.peak = max(self.peak, self.alive)
        weakref.finalize(frame, self._gone)
        return frame

    def _gone(self) -> None:
        self.alive -= 1


def watched_dataset(n: int = 120, **kw) -> tuple[RouteDataset, Watched, Watched]:
    ref, qry = Watched(1), Watched(1, **kw)  # the query re-drives the reference
    truth = [np.array([j]) for j in range(n)]
    ds = RouteDataset("watched", RenderedFrames(ref, n), RenderedFrames(qry, n), truth)
    return ds, ref, qry


class Pacer:
    """A localiser that checks it is never handed frames ahead of what it consumed."""

    name = "pacer"

    def __init__(self, ref: Watched, qry: Watched) -> None:
        self.ref, self.qry, self.steps = ref, qry, 0

    def build_map(self, frames) -> TopoMap:
        means = []
        for k, f in enumerate(frames, 1):
            assert self.ref.made <= k, f"{self.ref.made} reference frames made for {k} read"
            means.append([float(f.mean())])
        return TopoMap("mean", np.array(means))

    def reset(self) -> None:
        self.steps = 0

    def step(self, frame: np.ndarray) -> Estimate:
        self.steps += 1
        assert self.qry.made <= self.steps, f"{self.qry.made} query frames made ahead"
        return Estimate(node=self.steps - 1, score=1.0)


def test_a_run_reads_each_frame_when_it_is_consumed_and_drops_it():
    ds, ref, qry = watched_dataset()
    run = run_evaluation(
        EvaluateConfig(), dataset=ds, localisers={"pacer": Pacer(ref, qry)}, progress=False
    )
    assert run.runs["pacer"].node.tolist() == list(range(120))
    assert (ref.made, qry.made) == (120, 120)  # each frame read once, in order
    assert max(ref.peak, qry.peak) <= ALIVE_BOUND


@pytest.mark.parametrize("method", HOST_METHODS)
def test_every_host_method_maps_and_localises_a_stream(method):
    """build_map keeps descriptors, not frames; a run keeps numbers, not estimates."""
    ds, ref, qry = watched_dataset()
    loc = make_localiser(method, **({"seed": 0} if method == "particle-filter" else {}))
    cfg = EvaluateConfig(record_weights=False)
    run_evaluation(cfg, dataset=ds, localisers={method: loc}, progress=False)
    assert ref.peak <= ALIVE_BOUND, f"{method} held {ref.peak} reference frames at once"
    assert qry.peak <= ALIVE_BOUND, f"{method} held {qry.peak} query frames at once"


def test_several_methods_share_a_short_route_and_stream_a_long_one(monkeypatch):
    ds, ref, qry = watched_dataset()
    pacers = {"a": Pacer(ref, qry), "b": Pacer(ref, qry)}
    cfg = EvaluateConfig()
    run_evaluation(cfg, dataset=ds, localisers={"a": pacers["a"]}, progress=False)
    assert ref.made == 120  # one method: nothing kept for a next one

    ds, ref, qry = watched_dataset()
    loc_a, loc_b = make_localiser("weighted-node-lbp"), make_localiser("single-frame")
    run_evaluation(cfg, dataset=ds, localisers={"a": loc_a, "b": loc_b}, progress=False)
    assert (ref.made, qry.made) == (120, 120)  # fits SHARED_FRAMES_BYTES: read once

    monkeypatch.setattr(run_module, "SHARED_FRAMES_BYTES", 0)
    ds, ref, qry = watched_dataset()
    run_evaluation(cfg, dataset=ds, localisers={"a": loc_a, "b": loc_b}, progress=False)
    assert (ref.made, qry.made) == (240, 240)  # too long to keep: each method reads again
    assert max(ref.peak, qry.peak) <= ALIVE_BOUND


class Weighing(Pacer):
    """A Pacer whose estimates carry N weights each (as ``record_weights`` does)."""

    def __init__(self, ref: Watched, qry: Watched) -> None:
        super().__init__(ref, qry)
        self.weights = Watched(2)

    def step(self, frame: np.ndarray) -> Estimate:
        est = super().step(frame)
        w = self.weights(self.steps).ravel()[:120].astype(np.float32)
        weakref.finalize(w, self.weights._gone)
        self.weights.alive += 1
        return Estimate(node=est.node, score=est.score, weights=w)


@pytest.mark.parametrize("limit", [10, 10**6])
def test_a_run_keeps_no_estimate_and_its_weights_only_below_the_limit(limit):
    ds, ref, qry = watched_dataset()
    loc = Weighing(ref, qry)
    cfg = EvaluateConfig(max_weight_values=limit)
    run = run_evaluation(cfg, dataset=ds, localisers={"w": loc}, progress=False).runs["w"]
    assert loc.weights.peak <= 3  # each estimate's weights dropped with it
    assert (run.weights is None) == (limit == 10)
    if run.weights is not None:
        assert run.weights.shape == (120, 120) and run.weights.dtype == np.float32


# -- the commands ------------------------------------------------------------------------------


@pytest.fixture
def watched_spec(monkeypatch):
    """Every dataset spec loads a fresh watched dataset; returns the last one's watchers."""
    made: dict[str, Watched] = {}

    def load(spec: str, **kw) -> RouteDataset:
        interrupt = {"ref": None, "query": None}
        if "interrupt=" in spec:
            side, at = spec.split("interrupt=")[1].split(":")
            interrupt[side] = int(at)
        n = 60
        made["ref"], made["query"] = Watched(1, interrupt["ref"]), Watched(1, interrupt["query"])
        truth = [np.array([j]) for j in range(n)]
        ref, qry = RenderedFrames(made["ref"], n), RenderedFrames(made["query"], n)
        return RouteDataset("watched", ref, qry, truth, meta={"spec": spec})

    monkeypatch.setattr("ppaloc.datasets.registry.load_dataset", load)
    return made


def test_map_command_streams_the_reference(watched_spec, tmp_path):
    from ppaloc.cli.main import main

    assert main(["map", "w", "-m", "weighted-node-lbp", "-q", "--out", str(tmp_path / "m.npz")]) == 0
    assert watched_spec["ref"].made == 60 and watched_spec["ref"].peak <= ALIVE_BOUND


@pytest.mark.parametrize("side", ["ref", "query"])
def test_ctrl_c_during_evaluate_stops_at_once_and_writes_nothing(
    watched_spec, tmp_path, capsys, side
):
    from ppaloc.cli.main import main

    out = tmp_path / "run"
    args = ["evaluate", "-q", "-m", "weighted-node-lbp", "-m", "single-frame", "--out", str(out)]
    assert main([*args[:1], "-d", f"w?interrupt={side}:30", *args[1:]]) == 130
    assert capsys.readouterr().err.strip() == "ppaloc: interrupted"  # one line, no traceback
    assert watched_spec[side].made == 30  # no frame read after the interrupt
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # no folder, no stale stage


def test_ctrl_c_during_map_leaves_no_map_and_no_temporary(watched_spec, tmp_path, capsys):
    from ppaloc.cli.main import main

    target = tmp_path / "m.npz"
    target.write_bytes(b"the earlier map")
    args = ["map", "w?interrupt=ref:20", "-m", "weighted-node-lowres", "--out", str(target)]
    assert main(args) == 130
    assert capsys.readouterr().err.strip() == "ppaloc: interrupted"
    assert [p.name for p in tmp_path.iterdir()] == ["m.npz"]
    assert target.read_bytes() == b"the earlier map"


def test_ctrl_c_during_localise_keeps_the_earlier_csv(tmp_path, capsys, monkeypatch):
    from PIL import Image

    from ppaloc.cli.main import main

    frames = tmp_path / "frames"
    frames.mkdir()
    rng = np.random.default_rng(0)
    for i in range(12):
        Image.fromarray(rng.integers(0, 256, (32, 64), np.uint8)).save(frames / f"{i:03d}.png")
    map_path = tmp_path / "m.npz"
    assert main(["map", "synthetic:?places=12&seed=1", "-q", "--out", str(map_path)]) == 0
    csv = tmp_path / "est.csv"
    csv.write_text("earlier\n")
    import ppaloc.datasets.images as images

    read, calls = images.read_grey, []

    def interrupted(path: Path) -> np.ndarray:
        calls.append(path)
        if len(calls) == 5:
            raise KeyboardInterrupt
        return read(path)

    monkeypatch.setattr(images, "read_grey", interrupted)
    assert main(["localise", str(map_path), str(frames), "--out", str(csv)]) == 130
    assert capsys.readouterr().err.strip() == "ppaloc: interrupted"
    assert len(calls) == 5 and csv.read_text() == "earlier\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["est.csv", "frames", "m.npz"]
