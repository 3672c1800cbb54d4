"""The weights' local centroid as the reported estimate, measured offline on every route.

Not collected by pytest. The robust filter reports the local centroid of its weights
about the detected node (``centroid_radius`` 2, ``centroid_temperature`` 2;
docs/localise.md, item 16). This is the measurement that chose them: each route is run
once with the centroid off (``centroid_radius=0``: the detected node reported) and its
weights recorded, and every variant replaces the reported nodes after the run with the
centroid of the recorded weights about them (:func:`offline_centroid`, the filter's own
:func:`~ppaloc.localise.params.local_centroid`), so the figures are what the filter
would score reporting that variant (on a frame a speed lane reports, about the lane's
node but from the filter's own weights, which the filter itself does not do).

``int`` variants read each weight as one ADC read gives it (``weight_read``, the
nearest integer: what ``ppa8`` and the sensor read), the others its exact value (what
float reads). The weights are recorded after the frame's normalisation, which in ``ppa8``
subtracts an integer and so leaves the reads as the filter's own; in float it subtracts
the exact maximum, so there the ``int`` variants round what no filter rounds, and with
the default ``ppa8`` weights the exact variants are not what the ``ppa8`` filter does::

    .venv/bin/python benchmarks/eval_centroid.py                    # 65 routes, ppa8, ~10 min
    .venv/bin/python benchmarks/eval_centroid.py --held-out         # the 40 held-out routes
    .venv/bin/python benchmarks/eval_centroid.py --methods weighted-node-lowres16 --float

Prints, per method, each variant's mean max F1 over the generated and the real routes
and the routes it raises and lowers against the detected node (``--json`` keeps every
route's figure).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import DATA, PLACE_OF, completed, held_out_routes, route_pool, routes
from ppaloc.localise.params import centroid_window, local_centroid, weight_read

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


def offline_centroid(
    weights: np.ndarray, node: int, radius: int, temperature: float, rounded: bool
) -> int:
    """The centroid the filter would report about ``node`` from one frame's recorded
    weights: :func:`~ppaloc.localise.params.local_centroid` over the
    :func:`~ppaloc.localise.params.centroid_window`, each weight read as one ADC read
    gives it with ``rounded`` (:func:`~ppaloc.localise.params.weight_read`)."""
    a, b = centroid_window(node, radius, len(weights))
    values = [float(v) for v in weights[a : b + 1]]
    reads = [weight_read(v) for v in values] if rounded else values
    return local_centroid(reads, a, temperature)  # type: ignore[arg-type]


def variant_name(temperature: float, radius: int, rounded: bool) -> str:
    """``"T2 r2 int"``: the column of a variant."""
    return f"T{temperature:g} r{radius}" + (" int" if rounded else "")


def evaluate_route(
    label: str, spec: str, methods: Sequence[str], arithmetic: str
) -> dict[str, Any]:
    """Every method on one route: the detected node's max F1 and each variant's."""
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
        user["centroid_radius"] = 0  # the detected node, which the variants move
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
                [offline_centroid(weights[i], int(n), radius, temperature, rounded)
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
    print(f"max F1, the detected node against its local centroid ({arithmetic} weights)")
    print(summary(records, methods))
    if args.json is not None:
        args.json.write_text(json.dumps(records, indent=1))


if __name__ == "__main__":
    main()
