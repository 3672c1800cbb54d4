"""The on-sensor system's figures: agreement, modelled frame time, noise, figures.

Run from the project root: ``python benchmarks/eval_onsensor.py [--part NAME ...]
[--figures DIR]``. Not collected by pytest. Parts:

- ``agreement``: in ideal mode, the fraction of frames where ``OnSensorLocaliser`` and
  ``WeightedNodeLocaliser(arithmetic="ppa8")`` (same parameters, same map) give the same
  node, on the synthetic route (image motion) and on Nordland summer -> winter (image
  motion and always forward), for both representations.
- ``timing``: modelled latency and energy per frame at the paper's map sizes (1024 low-res
  images, 2048 descriptors), with the per-stage breakdown (median over frames) and the
  ratio to the paper's 2.59 ms / 3.17 ms on SCAMP-5.
- ``noise``: max F1 (recall definition A, tolerance of the dataset) in ideal mode, under
  the ``"typical"`` noise preset and under that preset without analogue droop, on
  Nordland summer -> winter and Gardens Point day_left -> day_right, both
  representations, always-forward motion (both are frame-synchronised).
- ``figures``: the database, weights and difference registers (PNG) into ``--figures``.
"""

from __future__ import annotations

import argparse
import dataclasses
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
#: The "typical" preset without analogue droop: separates the droop of the stored database
#: (the map sits in registers for the whole query) from the per-operation noise.
NO_DROOP = dataclasses.replace(PRESETS["typical"], decay_per_ms=0.0)


def load(spec: str):
    ds = load_dataset(spec)
    return [to_sensor(f) for f in ds.reference], [to_sensor(f) for f in ds.query], ds


def agreement(name: str, spec: str, motions: tuple[str, ...]) -> None:
    ref, query, _ = load(spec)
    for rep in ("lowres", "lbp"):
        for motion in motions:
            host = WeightedNodeLocaliser(rep, motion=motion, arithmetic="ppa8")
            topomap = host.build_map(ref)
            sensor = OnSensorLocaliser(rep, motion=motion)
            sensor.use_map(topomap)
            t = time.perf_counter()
            a = [e.node for e in host.localise(query)]
            b = [e.node for e in sensor.localise(query)]
            same = float(np.mean(np.array(a) == np.array(b)))
            print(
                f"agreement {name:24s} {rep:6s} {motion:14s} {same * 100:7.2f}% of "
                f"{len(query)} frames ({len(query) / (time.perf_counter() - t):.1f} frames/s "
                "host+sensor)",
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


def timing(n_frames: int = 24) -> None:
    """Per-stage modelled time per frame at the paper's map sizes (image motion)."""
    rng = np.random.default_rng(1)
    for rep in ("lowres", "lbp"):
        n = PAPER_NODES[rep]
        if rep == "lbp":
            topomap = TopoMap("lbp", rng.integers(0, 2**32, n, dtype=np.uint32))
        else:
            topomap = TopoMap("lowres", rng.integers(0, 256, (n, 8, 8), dtype=np.uint8))
        for motion in ("image", "always_forward"):
            loc = OnSensorLocaliser(rep, motion=motion, alpha=8)
            loc.use_map(topomap)
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
                f"\ntiming {rep} ({n} nodes, motion={motion}): {ms:.3f} ms per frame "
                f"(median), {ms / PAPER_MS[rep]:.2f} x the paper's {PAPER_MS[rep]} ms; "
                f"energy {statistics.median(energy):.3f} mJ per frame"
            )
            for name, values in per_stage.items():
                full = values + [0.0] * (len(totals) - len(values))
                print(f"  {name:12s} {statistics.mean(full):8.1f} us (mean over frames)")


def noise(n_query: int | None = None) -> None:
    for name, spec in (("nordland summer->winter", NORDLAND), ("gardens day_l->day_r", GARDENS)):
        ref, query, ds = load(spec)
        query = query[:n_query]
        truth = list(ds.ground_truth)[: len(query)]
        has_match = np.array([len(t) > 0 for t in truth])
        for rep in ("lowres", "lbp"):
            for preset in ("ideal", "typical", "typical-no-droop"):
                setting = NO_DROOP if preset == "typical-no-droop" else preset
                loc = OnSensorLocaliser(rep, noise=setting, seed=0, motion="always_forward")
                loc.build_map(ref)  # mapped by the same (noisy) sensor
                t = time.perf_counter()
                est = loc.localise(query)
                nodes = np.array([e.node for e in est])
                correct = is_correct(nodes, truth)
                curve = pr_curve([e.score for e in est], correct, has_match, recall="A")
                print(
                    f"noise {name:24s} {rep:6s} {preset:8s} maxF1={max_f1(curve)[0]:.4f} "
                    f"acc={correct[has_match].mean():.4f} "
                    f"({len(query) / (time.perf_counter() - t):.1f} frames/s)",
                    flush=True,
                )


def figures(out: Path) -> None:
    from ppaloc.onsensor.figures import (
        database_figure,
        difference_figure,
        weights_figure,
        weights_history_image,
    )

    out.mkdir(parents=True, exist_ok=True)
    ref, query, _ = load(GARDENS)
    for rep in ("lowres", "lbp"):
        loc = OnSensorLocaliser(rep, motion="always_forward", record_weights=True)
        loc.build_map(ref)
        print(database_figure(loc, out / f"{rep}_database.png"))
        print(weights_figure(loc, query[:60], out / f"{rep}_weights.png", snapshots=4))
        print(difference_figure(loc, query[60], out / f"{rep}_difference.png"))
        print(weights_history_image(loc.localise(query), out / f"{rep}_weights_history.png"))


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
    args = parser.parse_args()
    if "timing" in args.part:
        timing()
    if "agreement" in args.part:
        agreement("synthetic (300 places)", SYNTHETIC, ("image",))
        agreement("nordland summer->winter", NORDLAND, ("image", "always_forward"))
    if "noise" in args.part:
        noise(args.max_query)
    if "figures" in args.part:
        figures(args.figures)


if __name__ == "__main__":
    main()
