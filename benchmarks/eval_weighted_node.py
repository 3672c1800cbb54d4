"""Accuracy of the weighted-node filter on the shared real datasets and the synthetic route.

Run from the project root: ``python benchmarks/eval_weighted_node.py [--quick]``. Prints max
F1 (tolerance +-2) for Nordland summer -> winter and Gardens Point, for both
representations and both motion models, and the image motion model's accuracy on the
synthetic route with stops. Not collected by pytest.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.localise.weighted import WeightedNodeLocaliser

DATA = "../shared/data"
GP = f"gardens-point:{DATA}/gardens-point"
DATASETS = {
    "nordland summer->winter": f"nordland:{DATA}/nordland-64x32?ref=summer&query=winter",
    "gardens day_left->day_right": f"{GP}?ref=day_left&query=day_right",
    "gardens day_right->night_right": f"{GP}?ref=day_right&query=night_right",
}


def max_f1(nodes: np.ndarray, scores: np.ndarray, truth: list[np.ndarray]) -> float:
    """Max F1 over every distinct score threshold (a prediction is accepted when score >= t)."""
    correct = np.array([n in t for n, t in zip(nodes, truth, strict=True)])
    positives = sum(len(t) > 0 for t in truth)
    order = np.argsort(-scores, kind="stable")
    s, c = scores[order], correct[order]
    tp = np.cumsum(c)
    accepted = np.arange(1, len(s) + 1)
    last = np.r_[s[1:] != s[:-1], True]  # evaluate only at the end of each tie group
    precision, recall = tp[last] / accepted[last], tp[last] / max(positives, 1)
    f1 = np.where(precision + recall > 0, 2 * precision * recall / (precision + recall), 0)
    return float(f1.max())


def run(loc: WeightedNodeLocaliser, ref: list, query: list) -> tuple[np.ndarray, np.ndarray, list]:
    loc.build_map(ref)
    est = loc.localise(query)
    return np.array([e.node for e in est]), np.array([e.score for e in est]), est


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--arithmetic", default="float", choices=("float", "ppa8"))
    args = parser.parse_args()
    for name, spec in DATASETS.items():
        ds = load_dataset(spec)
        ref = [to_sensor(f) for f in ds.reference]
        query = [to_sensor(f) for f in ds.query]
        truth = list(ds.ground_truth)
        for rep in ("lowres", "lbp"):
            for motion in ("always_forward", "image"):
                loc = WeightedNodeLocaliser(rep, motion=motion, arithmetic=args.arithmetic)
                t0 = time.perf_counter()
                nodes, scores, est = run(loc, ref, query)
                acc = np.mean([n in t for n, t in zip(nodes, truth, strict=True)])
                print(
                    f"{name:32s} {rep:6s} {motion:14s} maxF1={max_f1(nodes, scores, truth):.4f} "
                    f"acc={acc:.4f} alpha={loc.alpha:g} "
                    f"stay={np.mean([not e.moved for e in est]):.3f} "
                    f"({time.perf_counter() - t0:.1f} s)",
                    flush=True,
                )


if __name__ == "__main__":
    main()
