"""The on-sensor system's figures: agreement, modelled frame time, noise, figures.

Run from the project root: ``python benchmarks/eval_onsensor.py [--part NAME ...]
[--preset robust paper] [--figures DIR]``. Not collected by pytest. Parts (each for the
presets given, default both):

- ``agreement``: in ideal mode, ``OnSensorLocaliser`` against
  ``WeightedNodeLocaliser(arithmetic="ppa8")`` with the same parameters, each mapping the
  reference itself (robust with image motion: keyframes, so the kept frames are compared
  too): the fraction of frames with the same node, the same motion decision and the
  same score (robust: the sensor's integer ``T - T_out`` equals ``floor(best) -
  floor(outside)`` of the host; paper: the two scores within 1), and the largest weight
  difference, on the synthetic route (image motion) and on Nordland summer -> winter
  (image motion and always forward), for both representations.
- ``timing``: modelled latency and energy per frame at the paper's map sizes (1024 low-res
  images, 2048 descriptors) and at Nordland's (1788 nodes: two low-res tiles), with the
  per-stage breakdown (mean over frames) and the ratio to the paper's 2.59 ms / 3.17 ms
  on SCAMP-5.
- ``noise``: max F1 (recall definition A, tolerance of the dataset) in ideal mode, under
  the ``"typical"`` noise preset and under that preset without analogue droop, on
  Nordland summer -> winter and Gardens Point day_left -> day_right, both
  representations, always-forward motion (both are frame-synchronised).
- ``figures``: the database, weights and difference registers (PNG) into ``--figures``
  (the paper preset's files as before, the robust preset's with ``_robust``).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import statistics
import time
from collections import defaultdict
from pathlib import Path

import numpy as np

from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.evaluate.metrics import is_correct, max_f1, pr_curve
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.sim import PRESETS
from ppaloc.topomap import TopoMap

DATA = "../shared/data"
NORDLAND = f"nordland:{DATA}/nordland-64x32?ref=summer&query=winter"
GARDENS = f"gardens-point:{DATA}/gardens-point?ref=day_left&query=day_right"
SYNTHETIC = "synthetic:?places=300&query=winter&seed=1"
PAPER_MS = {"lowres": 2.59, "lbp": 3.17}
PAPER_NODES = {"lowres": 1024, "lbp": 2048}
NORDLAND_NODES = 1788
FILTER_PRESETS = ("robust", "paper")
#: The "typical" preset without analogue droop: separates the droop of the stored database
#: (the map sits in registers for the whole query) from the per-operation noise.
NO_DROOP = dataclasses.replace(PRESETS["typical"], decay_per_ms=0.0)


def load(spec: str):
    ds = load_dataset(spec)
    return [to_sensor(f) for f in ds.reference], [to_sensor(f) for f in ds.query], ds


def agreement(
    name: str, spec: str, motions: tuple[str, ...], presets: tuple[str, ...] = FILTER_PRESETS
) -> None:
    ref, query, _ = load(spec)
    for rep in ("lowres", "lbp"):
        for preset in presets:
            for motion in motions:
                kw = {"preset": preset, "motion": motion, "record_weights": True}
                host = WeightedNodeLocaliser(rep, arithmetic="ppa8", **kw)
                sensor = OnSensorLocaliser(rep, **kw)
                t = time.perf_counter()
                want, got = host.build_map(ref), sensor.build_map(ref)
                same_map = np.array_equal(want.frame_index, got.frame_index) and np.array_equal(
                    want.descriptors, got.descriptors
                )
                a, b = host.localise(query), sensor.localise(query)
                pairs = list(zip(a, b, strict=True))
                node = np.mean([x.node == y.node for x, y in pairs])
                moved = np.mean([x.moved == y.moved for x, y in pairs])
                if preset == "robust":  # after the normalisation the host's w[node] = best - T
                    score = [y.score == math.ceil(x.score - x.weights[x.node]) for x, y in pairs]
                else:
                    score = [abs(y.score - x.score) < 1 for x, y in pairs]
                werr = max(float(np.abs(x.weights - y.weights).max()) for x, y in pairs)
                print(
                    f"agreement {name:24s} {rep:6s} {preset:6s} {motion:14s} "
                    f"nodes={len(got)} same map={same_map} node {node * 100:7.2f}% "
                    f"moved {moved * 100:7.2f}% score {np.mean(score) * 100:7.2f}% "
                    f"max |dw|={werr:.1e} of {len(query)} frames "
                    f"({len(query) / (time.perf_counter() - t):.1f} frames/s host+sensor)",
                    flush=True,
                )


def _frames(n: int) -> list[np.ndarray]:
    rng = np.random.default_rng(0)
    out = []
    cells = rng.integers(0, 256, (n, 17, 17)).astype(np.uint8)
    for i in range(n):
        big = np.kron(cells[i], np.ones((16, 16), np.uint8))
        out.append(big[i % 16 : i % 16 + 256, :256])
    return out


def _random_map(rep: str, n: int) -> TopoMap:
    rng = np.random.default_rng(1)
    if rep == "lbp":
        return TopoMap("lbp", rng.integers(0, 2**32, n, dtype=np.uint32))
    return TopoMap("lowres", rng.integers(0, 256, (n, 8, 8), dtype=np.uint8))


def timing(n_frames: int = 24, presets: tuple[str, ...] = FILTER_PRESETS) -> None:
    """Per-stage modelled time per frame at the paper's and Nordland's map sizes.

    The frames are blocky random images moving by one pixel per frame, so the image
    motion test says forward on every frame (every stage of either preset runs); a
    robust *stay* frame skips the scale readout, the replication/descriptor and the
    comparison (the "stay frame" line).
    """
    for rep in ("lowres", "lbp"):
        for n in (PAPER_NODES[rep], NORDLAND_NODES):
            topomap = _random_map(rep, n)
            for preset in presets:
                for motion in ("image", "always_forward"):
                    kw = {"alpha": 8} if preset == "paper" else {}
                    loc = OnSensorLocaliser(rep, preset=preset, motion=motion, **kw)
                    loc.use_map(topomap)
                    _time_frames(loc, rep, n, preset, motion, n_frames)


def _time_frames(loc, rep: str, n: int, preset: str, motion: str, n_frames: int) -> None:
    sim = loc.pipeline.sim
    per_stage: dict[str, list[float]] = defaultdict(list)
    totals, energy = [], []
    for i, frame in enumerate(_frames(n_frames)):
        sim.timing.reset()
        est = loc.step(frame)
        if i < 2:  # the first frame records the kernels and has no motion decision
            continue
        report = sim.timing.report()
        for s in report.stages:
            per_stage[s.name].append(s.us)
        totals.append(est.modelled_latency_ms)
        energy.append(est.energy_mj)
    ms = statistics.median(totals)
    print(
        f"\ntiming {rep} ({n} nodes, {loc.pipeline.tiles} tile(s)), preset={preset}, "
        f"motion={motion}: {ms:.3f} ms per frame (median), {ms / PAPER_MS[rep]:.2f} x the "
        f"paper's {PAPER_MS[rep]} ms; energy {statistics.median(energy):.3f} mJ per frame"
    )
    means = {}
    for name, values in per_stage.items():
        full = values + [0.0] * (len(totals) - len(values))
        means[name] = statistics.mean(full)
        print(f"  {name:12s} {means[name]:8.1f} us (mean over frames)")
    if preset == "robust":
        live = ("scale", "replicate", "lbp", "compare")
        stay = sum(v for k, v in means.items() if k not in live) / 1000.0
        print(f"  {'stay frame':12s} {stay * 1000:8.1f} us (robust: no likelihood on stay)")


def noise(n_query: int | None = None, presets: tuple[str, ...] = FILTER_PRESETS) -> None:
    for name, spec in (("nordland summer->winter", NORDLAND), ("gardens day_l->day_r", GARDENS)):
        ref, query, ds = load(spec)
        query = query[:n_query]
        truth = list(ds.ground_truth)[: len(query)]
        has_match = np.array([len(t) > 0 for t in truth])
        for rep in ("lowres", "lbp"):
            for preset in presets:
                for level in ("ideal", "typical", "typical-no-droop"):
                    setting = NO_DROOP if level == "typical-no-droop" else level
                    loc = OnSensorLocaliser(
                        rep, noise=setting, seed=0, preset=preset, motion="always_forward"
                    )
                    loc.build_map(ref)  # mapped by the same (noisy) sensor
                    t = time.perf_counter()
                    est = loc.localise(query)
                    nodes = np.array([e.node for e in est])
                    correct = is_correct(nodes, truth)
                    curve = pr_curve([e.score for e in est], correct, has_match, recall="A")
                    print(
                        f"noise {name:24s} {rep:6s} {preset:6s} {level:16s} "
                        f"maxF1={max_f1(curve)[0]:.4f} acc={correct[has_match].mean():.4f} "
                        f"({len(query) / (time.perf_counter() - t):.1f} frames/s)",
                        flush=True,
                    )


def figures(out: Path, presets: tuple[str, ...] = FILTER_PRESETS) -> None:
    from ppaloc.onsensor.figures import (
        database_figure,
        difference_figure,
        weights_figure,
        weights_history_image,
    )

    out.mkdir(parents=True, exist_ok=True)
    ref, query, _ = load(GARDENS)
    for preset in presets:
        tag = "" if preset == "paper" else f"_{preset}"
        for rep in ("lowres", "lbp"):
            loc = OnSensorLocaliser(
                rep, preset=preset, motion="always_forward", record_weights=True
            )
            loc.build_map(ref)
            print(database_figure(loc, out / f"{rep}{tag}_database.png"))
            print(weights_figure(loc, query[:60], out / f"{rep}{tag}_weights.png", snapshots=4))
            print(difference_figure(loc, query[60], out / f"{rep}{tag}_difference.png"))
            history = out / f"{rep}{tag}_weights_history.png"
            print(weights_history_image(loc.localise(query), history))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--part",
        nargs="*",
        default=["agreement", "timing", "noise", "figures"],
        choices=["agreement", "timing", "noise", "figures"],
    )
    parser.add_argument("--figures", type=Path, default=Path("onsensor-figures"))
    parser.add_argument("--max-query", type=int, default=None, help="first N queries only")
    parser.add_argument(
        "--preset",
        nargs="*",
        default=list(FILTER_PRESETS),
        choices=list(FILTER_PRESETS),
        help="filter presets to run (default both)",
    )
    parser.add_argument(
        "--route",
        nargs="*",
        default=["synthetic", "nordland"],
        choices=["synthetic", "nordland"],
        help="routes of the agreement part (default both)",
    )
    args = parser.parse_args()
    presets = tuple(args.preset)
    if "timing" in args.part:
        timing(presets=presets)
    if "agreement" in args.part:
        if "synthetic" in args.route:
            agreement("synthetic (300 places)", SYNTHETIC, ("image",), presets)
        if "nordland" in args.route:
            agreement("nordland summer->winter", NORDLAND, ("image", "always_forward"), presets)
    if "noise" in args.part:
        noise(args.max_query, presets)
    if "figures" in args.part:
        figures(args.figures, presets)


if __name__ == "__main__":
    main()
