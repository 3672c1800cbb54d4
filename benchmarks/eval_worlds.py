"""Every method on the new synthetic worlds: the indoor lab and a road route with turns.

Max F1 overall and split by whether the query frame was taken on a straight stretch or in
a turn (``meta["query_turning"]``), printed as the Markdown table of docs/datasets.md::

    .venv/bin/python benchmarks/eval_worlds.py               # all but the onsensor-* methods
    .venv/bin/python benchmarks/eval_worlds.py --onsensor    # the simulated sensor too (slow)
    .venv/bin/python benchmarks/eval_worlds.py --out /tmp/w  # also keep each results folder

Each run is ``ppaloc evaluate`` on the same spec (reports can be made from ``--out``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from ppaloc.evaluate.config import EvaluateConfig
from ppaloc.evaluate.results import save_results
from ppaloc.evaluate.run import run_evaluation
from ppaloc.methods import available_methods

SPECS = {
    "lab, map -> changed": "synthetic:?world=lab&places=150&query=changed&seed=1",
    "road, 8 turns, summer -> winter": "synthetic:?places=200&turns=8&query=winter&seed=1",
}


def _f(v: float | None) -> str:
    return "-" if v is None else f"{v:.3f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--onsensor", action="store_true", help="include onsensor-* methods")
    parser.add_argument("--out", type=Path, help="save each run's results folder here")
    args = parser.parse_args()
    methods = [m for m in available_methods() if args.onsensor or not m.startswith("onsensor")]
    rows = []
    for label, spec in SPECS.items():
        t0 = time.perf_counter()
        result = run_evaluation(
            EvaluateConfig(dataset=spec, methods=tuple(methods)), progress=False
        )
        if args.out:
            save_results(result, args.out / label.split(",")[0])
        turning = result.query_turning
        n_turn = int(turning.sum()) if turning is not None else 0
        print(
            f"{label}: {len(result.ground_truth)} queries, {n_turn} turning "
            f"({time.perf_counter() - t0:.0f} s)"
        )
        for name, run in result.runs.items():
            m = run.metrics
            rows.append((label, name, m.f1_max, m.f1_max_straight, m.f1_max_turning))
    print()
    print("| route | method | F1 max | F1 straight | F1 turning |")
    print("|---|---|---|---|---|")
    for label, name, f1, straight, turn in rows:
        print(f"| {label} | {name} | {_f(f1)} | {_f(straight)} | {_f(turn)} |")


if __name__ == "__main__":
    main()
