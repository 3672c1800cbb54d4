"""Accuracy of the weighted-node filter on the shared real datasets and the synthetic route.

Run from the project root:
``python benchmarks/eval_weighted_node.py [--preset paper] [--arithmetic ppa8]`` (the robust
preset by default; ``benchmarks/eval_robust.py`` compares it with the baselines on every route).
Prints max F1 (recall definition A: recall over queries that have a true match; tolerance
+-2 frames) for Nordland summer -> winter and Gardens Point, for both representations and
the ``always_forward`` and ``image`` motion models, all with default parameters; then, on
the synthetic route (the default speed profile, the wide one, and one frame per place), the
image motion model's accuracy against the dataset's ``query_moved``, how far its count of
forward moves drifts from the true place (mean |drift|, places), and the filter's F1 with
each motion model (tolerance +-1 place). ``--synthetic-only`` skips the real data.
Not collected by pytest.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.evaluate.metrics import is_correct, max_f1, pr_curve
from ppaloc.evaluate.run import predicted_frames
from ppaloc.localise.weighted import WeightedNodeLocaliser

DATA = "../shared/data"
GP = f"gardens-point:{DATA}/gardens-point"
DATASETS = {
    "nordland summer->winter": f"nordland:{DATA}/nordland-64x32?ref=summer&query=winter",
    "gardens day_left->day_right": f"{GP}?ref=day_left&query=day_right",
    "gardens day_right->night_right": f"{GP}?ref=day_right&query=night_right",
}
SYNTHETIC = (
    "synthetic:?places=300&query=winter&seed=1",
    "synthetic:?places=300&query=winter&seed=1&speed_var=0.65",
    "synthetic:?places=300&query=winter&seed=1&sync=1",
)


def evaluate(loc: WeightedNodeLocaliser, ref: list, query: list, truth: list) -> dict:
    """Build the map, localise the query in order, and score it."""
    t0 = time.perf_counter()
    topomap = loc.build_map(ref)
    est = loc.localise(query)
    frames = predicted_frames(np.array([e.node for e in est]), topomap.frame_index)
    correct = is_correct(frames, truth)
    has_match = np.array([len(t) > 0 for t in truth])
    curve = pr_curve([e.score for e in est], correct, has_match, recall="A")
    return {
        "f1": max_f1(curve)[0],
        "accuracy": float(correct[has_match].mean()),
        "moved": np.array([bool(e.moved) for e in est]),
        "seconds": time.perf_counter() - t0,
    }


def load(spec: str) -> tuple[list, list, list, object]:
    ds = load_dataset(spec)
    ref = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]
    return ref, query, list(ds.ground_truth), ds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--arithmetic", default="float", choices=("float", "ppa8"))
    parser.add_argument("--preset", default="robust", choices=("robust", "paper"))
    parser.add_argument("--synthetic-only", action="store_true")
    args = parser.parse_args()
    for name, spec in {} if args.synthetic_only else DATASETS.items():
        ref, query, truth, _ = load(spec)
        for rep in ("lowres", "lbp"):
            for motion in ("always_forward", "image"):
                loc = WeightedNodeLocaliser(
                    rep, preset=args.preset, motion=motion, arithmetic=args.arithmetic
                )
                r = evaluate(loc, ref, query, truth)
                alpha = "per frame" if loc.alpha is None else f"{loc.alpha:g}"
                print(
                    f"{name:31s} {rep:6s} {motion:14s} maxF1={r['f1']:.4f} "
                    f"acc={r['accuracy']:.4f} alpha={alpha} "
                    f"stay={1 - r['moved'].mean():.3f} ({r['seconds']:.1f} s)",
                    flush=True,
                )
    for spec in SYNTHETIC:
        ref, query, truth, ds = load(spec)
        moved = np.asarray(ds.query_moved, bool)
        nearest = np.floor(np.asarray(ds.meta["query_place"]) + 0.5)
        for rep in ("lowres", "lbp"):
            for motion in ("always_forward", "image", "oracle"):
                loc = WeightedNodeLocaliser(
                    rep,
                    preset=args.preset,
                    motion=motion,
                    arithmetic=args.arithmetic,
                    oracle_moves=moved,
                )
                r = evaluate(loc, ref, query, truth)
                line = f"{spec[10:]:45s} {rep:6s} {motion:14s} "
                line += f"maxF1={r['f1']:.4f} acc={r['accuracy']:.4f}"
                if motion == "image":
                    agree = r["moved"][1:] == moved[1:]
                    drift = np.abs(np.cumsum(r["moved"]) - nearest).mean()
                    line += f" motion-accuracy={agree.mean():.4f} (frames 1..{len(moved) - 1})"
                    line += f" mean|drift|={drift:.1f}"
                print(line, flush=True)


if __name__ == "__main__":
    main()
