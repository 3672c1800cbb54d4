"""The weights' local centroid as the reported estimate, measured offline on every route.

Not collected by pytest. The robust filter reports the node of its best weight (the
candidate nearest the last estimate among the best). Where a neighbour's weight is
nearly as high, the query often lies between them, or on the neighbour: this reports
instead the rounded centroid of the weights within ``radius`` places of that estimate,
each weighed by ``exp((w - w_best) / T)`` (:func:`local_centroid`). The filter's state,
its confidence and its next frame are unchanged: each route is run once with its
weights recorded, and every variant replaces the reported nodes after the run, so the
figures are what the filter would score if it reported the centroid.

``--rounded`` variants round each weight to an integer first: what one ADC read of each
place's weight register gives the sensor controller (five reads a frame at radius 2),
against the exact register value the ``ppa8`` arithmetic holds::

    .venv/bin/python benchmarks/eval_centroid.py                    # 65 routes, ppa8, ~10 min
    .venv/bin/python benchmarks/eval_centroid.py --held-out         # the 40 held-out routes
    .venv/bin/python benchmarks/eval_centroid.py --methods weighted-node-lowres16 --float

Prints, per method, each variant's mean max F1 over the generated and the real routes
and the routes it raises and lowers against the reported estimate (``--json`` keeps
every route's figure).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import DATA, PLACE_OF, completed, held_out_routes, route_pool, routes

METHODS = tuple(PLACE_OF)
"""The weighted-node filter on each place (``patch``: the host in float only)."""

VARIANTS = (
    (1.0, 2, True),
    (2.0, 2, True),
    (4.0, 2, True),
    (8.0, 2, True),
    (2.0, 2, False),
    (2.0, 1, True),
    (2.0, 3, True),
)
"""``(T, radius, rounded)`` of each variant: T over 8x, radius 1-3, with and without the
integer read."""


def local_centroid(
    weights: np.ndarray, node: int, radius: int, temperature: float, rounded: bool
) -> int:
    """The rounded centroid of the nodes within ``radius`` of ``node``, each weighed by
    ``exp((w - w_max) / temperature)`` over those nodes (``w`` rounded half up to an
    integer first with ``rounded``). Where the weights are flat it is the window's middle:
    the estimate itself, but near either end of the map, where the window is cut short,
    a place inward of it.

    Examples
    --------
    >>> w = np.array([0.0, 10.0, 30.0, 29.0, 29.0, 5.0])
    >>> local_centroid(w, 2, 2, 2.0, True), local_centroid(w, 2, 1, 2.0, True)
    (3, 2)
    >>> local_centroid(w, 2, 2, 0.25, True)  # a low T: the best weight alone
    2
    """
    lo, hi = max(0, node - radius), min(len(weights), node + radius + 1)
    w = np.asarray(weights[lo:hi], np.float64)
    if rounded:
        w = np.floor(w + 0.5)
    p = np.exp((w - w.max()) / temperature)
    return math.floor(float((np.arange(lo, hi) * p).sum() / p.sum()) + 0.5)


def variant_name(temperature: float, radius: int, rounded: bool) -> str:
    """``"T2 r2 int"``: the column of a variant."""
    return f"T{temperature:g} r{radius}" + (" int" if rounded else "")


def evaluate_route(
    label: str, spec: str, methods: Sequence[str], arithmetic: str
) -> dict[str, Any]:
    """Every method on one route: the reported estimate's max F1 and each variant's."""
    from ppaloc.datasets import load_dataset
    from ppaloc.evaluate.metrics import evaluate_estimates
    from ppaloc.evaluate.run import localiser_params, predicted_frames, run_method, sensor_frames
    from ppaloc.methods import METHODS as SPECS
    from ppaloc.methods import make_localiser

    t0 = time.perf_counter()
    ds = load_dataset(spec)
    truth = [np.asarray(g) for g in ds.ground_truth]
    ref, query = sensor_frames(ds.reference), sensor_frames(ds.query)
    out: dict[str, dict[str, float]] = {}
    for name in methods:
        user = {} if name.endswith("-patch") else {"arithmetic": arithmetic}
        params = localiser_params(name, user, seed=0, record_weights=True)
        loc = make_localiser(name, **params)
        run = run_method(
            name,
            ref,
            query,
            truth,
            params={**SPECS[name].defaults, **params},
            localiser=loc,
            max_weight_values=10**9,
        )
        weights = np.asarray(run.weights, np.float64)
        nodes = np.asarray(run.node)
        score = np.asarray(run.score, np.float64)
        frame_index = np.asarray(loc.topomap.frame_index)
        row = {"estimate": float(evaluate_estimates(run.ref_index, score, truth).f1_max)}
        for temperature, radius, rounded in VARIANTS:
            est = np.array(
                [local_centroid(weights[i], int(n), radius, temperature, rounded)
                 for i, n in enumerate(nodes)]
            )  # fmt: skip
            f1 = evaluate_estimates(predicted_frames(est, frame_index), score, truth).f1_max
            row[variant_name(temperature, radius, rounded)] = float(f1)
        out[name] = row
    return {"label": label, "results": out, "seconds": time.perf_counter() - t0}


def summary(records: Sequence[dict[str, Any]], methods: Sequence[str]) -> str:
    """A Markdown table per method: each variant's means and routes up / down."""
    lines = []
    for name in methods:
        rows = [r for r in records if name in r["results"]]
        if not rows:
            continue
        lines += [
            f"\n{name} ({len(rows)} routes)\n",
            "| variant | generated | real | routes up / down |",
            "|---|---|---|---|",
        ]
        for variant in rows[0]["results"][name]:
            gen = [r["results"][name][variant] for r in rows if r["label"].startswith("synth")]
            real = [r["results"][name][variant] for r in rows if not r["label"].startswith("synth")]
            diff = [r["results"][name][variant] - r["results"][name]["estimate"] for r in rows]
            up, down = sum(d > 1e-9 for d in diff), sum(d < -1e-9 for d in diff)
            lines.append(
                f"| {variant} | {np.mean(gen) if gen else float('nan'):.4f} | "
                f"{np.mean(real) if real else float('nan'):.4f} | {up} / {down} |"
            )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(METHODS), help="comma-separated")
    parser.add_argument("--held-out", action="store_true", help="the 40 held-out routes")
    parser.add_argument("--float", action="store_true", help="float weights, not ppa8")
    parser.add_argument("--routes", default=None, metavar="SUBSTR", help="routes containing it")
    parser.add_argument("--jobs", type=int, default=2, help="routes run in parallel")
    parser.add_argument("--json", type=Path, default=None, help="write every route's figures")
    args = parser.parse_args(argv)
    methods = [m.strip() for m in args.methods.split(",") if m.strip()]
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        parser.error(f"--methods: {', '.join(unknown)} not among {', '.join(METHODS)}")
    selected = (held_out_routes if args.held_out else routes)(DATA)
    if args.routes:
        selected = [(label, spec) for label, spec in selected if args.routes in label]
    if not selected:
        parser.error("no route left to run")
    arithmetic = "float" if args.float else "ppa8"
    records: list[dict[str, Any]] = []

    def report(rec: dict[str, Any]) -> None:
        records.append(rec)
        line = f"[{len(records):3d}/{len(selected)}] {rec['label']:52s} {rec['seconds']:6.1f} s"
        print(line, file=sys.stderr, flush=True)

    if args.jobs <= 1:
        for label, spec in selected:
            report(evaluate_route(label, spec, methods, arithmetic))
    else:
        with route_pool(min(args.jobs, len(selected))) as pool:
            futures = [
                pool.submit(evaluate_route, label, spec, methods, arithmetic)
                for label, spec in selected
            ]
            for fut in completed(futures):
                report(fut.result())
    order = {label: i for i, (label, _) in enumerate(selected)}
    records.sort(key=lambda r: order[r["label"]])
    print(f"max F1, the reported estimate against its local centroid ({arithmetic} weights)")
    print(summary(records, methods))
    if args.json is not None:
        args.json.write_text(json.dumps(records, indent=1))


if __name__ == "__main__":
    main()
