"""Sensitivity of the robust weighted-node filter: max F1 against each of its parameters.

Not collected by pytest. Every parameter of the robust preset is varied alone, over a
range of at least 4x around its default, with the others at their defaults, for every
representation (``weighted-node-lbp``, ``weighted-node-lowres`` and
``weighted-node-lowres16``) on every route of ``benchmarks/eval_robust.py``. Each route
goes through the sensor front-end once; every cell runs as ``ppaloc evaluate`` runs it::

    .venv/bin/python benchmarks/sensitivity_robust.py              # about 35 min, 2 jobs
    .venv/bin/python benchmarks/sensitivity_robust.py --routes "seed=1" --json s.json
    .venv/bin/python benchmarks/sensitivity_robust.py --from s.json   # re-print a table
    .venv/bin/python benchmarks/sensitivity_robust.py --only speed_window,speed_confidence
    .venv/bin/python benchmarks/sensitivity_robust.py --held-out --only centroid_radius

Output: one Markdown row per parameter value: the mean max F1 over the routes for each
representation, the mean of the best of them per route, the same on Nordland summer ->
winter, and the minimum over routes of the best. A broad plateau
around the default (bold) is what a robust default looks like; a peak would be a tuned one.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import CACHE_DIR, DATA, held_out_routes, routes, run_all
from ppaloc.localise.params import FilterParams

METHODS = ("weighted-node-lbp", "weighted-node-lowres", "weighted-node-lowres16")
GRID: dict[str, tuple[int, ...]] = {
    "gain": (1, 2, 4, 8, 16),
    "memory": (32, 48, 64, 96, 127),
    "stay_cost": (1, 2, 4, 8, 16),
    "move_cost": (1, 2, 4, 8, 16),
    "skip_cost": (1, 2, 4, 8, 16),
    "max_advance": (1, 2, 3),
    "contrast": (0, 16, 24, 32, 48, 64, 96, 127),
    "contrast_patch": (2, 4, 8),
    "motion_margin": (2, 3, 4, 5, 6, 8),
    "local_gain": (0, 1, 2, 4, 8),
    "local_window": (1, 2, 4),
    "speed_window": (0, 6, 8, 12, 24),
    "speed_confidence": (0, 16, 32, 48, 64),
    "lost_window": (0, 4, 8, 16, 32),
    "speed_vary": (0, 1, 2, 4, 8, 16),
    "still_decay": (0, 4, 8, 16, 32, 64, 127),
    "lane_speed": (0, 2, 3),
    "lanes": (1, 2, 4),
    "slow_lane": (False, True),
    "lane_lead": (0, 16, 24, 32, 64, 127),
    "lane_confidence": (0, 8, 16, 24, 32, 48),
    "lane_speed_lead": (0, 4, 8, 16, 32, 64),
    "centroid_radius": (0, 1, 2, 3, 4),
    "centroid_temperature": (1, 2, 4, 8),
    "concentration_radius": (0, 2, 3, 4, 6, 8),
    "concentration_temperature": (1, 2, 4, 8, 16),
}
"""Each parameter's values: at least a 4x range around the default (``lane_speed``: off
and every speed a lane can have, above one place a frame and at most ``max_advance``;
``slow_lane``: off and on; ``lane_lead``: off, then 16 to 127; ``lane_confidence``: no
gate, then 8 to 48; ``lane_speed_lead``: off, then 4 to 64; ``centroid_radius``: off,
then 1 to 4 nodes; ``centroid_temperature``: 1 to 8 units; ``concentration_radius``: off,
then 2 to 8 nodes; ``concentration_temperature``: 1 to 16 units)."""

METRICS = {"f1_max": "max F1", "recall_at_100p": "recall at 100% precision"}
"""What a table's cells may average (``--metric``): the confidence's parameters move the
ranking of the estimates, which recall at 100% precision reads most directly."""

NORDLAND = "nordland summer->winter"


def jobs(keys: tuple[str, ...] = tuple(GRID)) -> list[tuple[str, str, dict]]:
    """``(column, method, params)`` for every value of ``keys`` and representation."""
    out = []
    for key in keys:
        values = GRID[key]
        for v in values:
            for m in METHODS:
                out.append((f"{m}|{key}={v}", m, {key: v}))
    return out


def table(records: list[dict], metric: str = "f1_max") -> str:
    """The compact sensitivity table from route records of :func:`run_all`: each cell a
    mean (or minimum) of ``metric`` (:data:`METRICS`), "best" the best of the places."""
    defaults = FilterParams.create("lbp")
    lines = [
        f"{METRICS[metric]}:\n",
        "| parameter | value | LBP mean | low-res mean | 16x16 low-res mean | best, mean "
        "| real, best | Nordland S->W (best) | best, min |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for key, values in GRID.items():
        for v in values:
            per = {m: [] for m in METHODS}
            best, real, nord = [], [], None
            for rec in records:
                f = [rec["results"].get(f"{m}|{key}={v}", {}).get(metric) for m in METHODS]
                if any(x is None for x in f):
                    continue
                for m, x in zip(METHODS, f, strict=True):
                    per[m].append(x)
                best.append(max(f))
                if not rec["label"].startswith("synthetic"):
                    real.append(max(f))
                if rec["label"] == NORDLAND:
                    nord = max(f)
            if not best:
                continue
            mark = "**" if v == getattr(defaults, key) else ""
            cells = [
                *(f"{np.mean(per[m]):.3f}" for m in METHODS),
                f"{np.mean(best):.3f}",
                "-" if not real else f"{np.mean(real):.3f}",
                "-" if nord is None else f"{nord:.3f}",
                f"{np.min(best):.3f}",
            ]
            lines.append(f"| `{key}` | {mark}{v}{mark} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--routes", default=None, metavar="SUBSTR")
    parser.add_argument("--places", type=int, default=200)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument(
        "--held-out",
        action="store_true",
        help="the 40 routes no default was chosen on (eval_robust.held_out_routes)",
    )
    parser.add_argument(
        "--only", default=None, metavar="KEY,KEY", help="only these parameters' rows"
    )
    parser.add_argument("--json", type=Path, default=None, help="write the route records here")
    parser.add_argument("--from", dest="source", type=Path, default=None, help="re-print a --json")
    parser.add_argument(
        "--metric", choices=tuple(METRICS), default="f1_max", help="what the cells average"
    )
    args = parser.parse_args()
    if args.source is not None:
        print(table(json.loads(args.source.read_text())["routes"], args.metric))
        return
    t0 = time.perf_counter()
    pick = held_out_routes if args.held_out else routes
    selected = pick(args.data, args.places)
    if args.routes:
        selected = [(label, spec) for label, spec in selected if args.routes in label]
    if not selected:
        raise SystemExit(f"error: no route label contains {args.routes!r}")
    keys = tuple(GRID) if not args.only else tuple(args.only.split(","))
    unknown = sorted(set(keys) - set(GRID))
    if unknown:
        raise SystemExit(f"error: --only {unknown[0]!r} is not one of {', '.join(GRID)}")
    records = run_all(selected, jobs(keys), workers=args.jobs, cache_dir=CACHE_DIR)
    print(table(records, args.metric))
    wall = time.perf_counter() - t0
    print(f"\n{len(records)} routes, wall time {wall:.0f} s, {args.jobs} jobs", file=sys.stderr)
    if args.json:
        args.json.write_text(json.dumps({"routes": records, "wall_s": wall}, default=repr))


if __name__ == "__main__":
    main()
