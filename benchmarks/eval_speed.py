"""Max F1 of each method on one generated route driven at a constant multiple of the
mapping speed.

Not collected by pytest. Run from the project root::

    .venv/bin/python benchmarks/eval_speed.py                       # autumn and winter
    .venv/bin/python benchmarks/eval_speed.py --queries autumn --speeds 0.5,1,2
    .venv/bin/python benchmarks/eval_speed.py --param weighted-node-lowres16.lane_speed=0
    .venv/bin/python benchmarks/eval_speed.py --representations     # the same information

The route is ``synthetic:?places=200&query=Q&seed=S&speed=V`` for each speed ``V`` (the
query crosses ``V`` places a frame, with the generator's stops; docs/datasets.md), so
the figures separate a method's speed assumption from its place recognition, which the
65 routes of ``benchmarks/eval_robust.py`` do not: there every query keeps the mapping
speed on average. Each method runs through the evaluation's runner
(:func:`ppaloc.evaluate.run.run_method`) with its defaults; each table's last row gives
the speeds the method declares (``speed_range``, the range ``ppaloc evaluate`` warns
outside: docs/baselines.md, "Query speed").

``--representations`` gives every filter the same information, as in ``eval_robust.py``:
the weighted-node filter on each of its places (``weighted-node-patch`` among them) and
each baseline that takes a ``descriptor`` once per descriptor (columns ``NAME/DESCRIPTOR``);
after each table, a line per speed says whether the better weighted-node place scores at
least the particle filter on the same place (:func:`same_place`).

``--queries nordland`` runs the real Nordland summer -> winter route of ``../shared/data``
instead, the winter query subsampled to each speed (:func:`faster`: frame ``round(i v)``
for ``i = 0, 1, ...``; speeds of at least 1, as a subsampled query cannot be slower)::

    .venv/bin/python benchmarks/eval_speed.py --queries nordland --speeds 1,1.5,2
"""

from __future__ import annotations

import argparse
import json
import sys
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from ppaloc.datasets import load_dataset, to_sensor
from ppaloc.evaluate.run import run_method
from ppaloc.methods import make_localiser

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import DATA, add_param_option, descriptor_columns, parse_params, same_place

METHODS = (
    "weighted-node-lowres16",
    "weighted-node-lowres",
    "weighted-node-haar",
    "weighted-node-lbp",
    "particle-filter",
    "seqslam",
    "able-m",
)
REPRESENTATION_METHODS = (
    "weighted-node-lowres16",
    "weighted-node-lowres",
    "weighted-node-haar",
    "weighted-node-lbp",
    "weighted-node-patch",
    "particle-filter",
)
"""The methods of ``--representations`` (the particle filter expanded per descriptor)."""
SPEEDS = (0.35, 0.5, 0.7, 1.0, 1.5, 2.0, 2.5)
QUERIES = ("autumn", "winter")


def route(query: str, seed: int, speed: float, places: int = 200) -> str:
    """The spec of the generated route at ``speed`` places a query frame."""
    return f"synthetic:?places={places}&query={query}&seed={seed}&speed={speed:g}"


NORDLAND = "nordland:{data}/nordland-64x32?ref=summer&query=winter"


def faster(n: int, speed: float) -> np.ndarray:
    """The query frames of a traversal of ``n`` frames driven ``speed`` times as fast:
    ``round(i speed)`` (half up) for ``i = 0, 1, ...`` below ``n``.

    >>> faster(7, 2).tolist(), faster(7, 1.5).tolist()
    ([0, 2, 4, 6], [0, 2, 3, 5, 6])
    """
    if speed < 1:
        raise SystemExit(f"error: speed {speed:g}: a subsampled query runs at 1 or faster")
    idx = np.unique(np.floor(np.arange(0, n, speed) + 0.5).astype(np.int64))
    return idx[idx < n]


@cache
def _nordland() -> tuple[list, list, list]:
    """The shared Nordland route's sensor frames and ground truth, loaded once."""
    if not DATA.is_dir():
        raise SystemExit(f"error: {DATA} not found: the nordland route needs the shared data")
    ds = load_dataset(NORDLAND.format(data=DATA))
    return (
        [to_sensor(f) for f in ds.reference],
        [to_sensor(f) for f in ds.query],
        list(ds.ground_truth),
    )


def frames_at(query: str, seed: int, speed: float, places: int) -> tuple[list, list, list]:
    """``(reference, query, truth)`` of the route at ``speed``: generated, or Nordland's
    winter query subsampled (``query="nordland"``)."""
    if query == "nordland":
        ref, frames, truth = _nordland()
        idx = faster(len(frames), speed)
        return ref, [frames[i] for i in idx], [truth[i] for i in idx]
    ds = load_dataset(route(query, seed, speed, places))
    ref = [to_sensor(f) for f in ds.reference]
    return ref, [to_sensor(f) for f in ds.query], list(ds.ground_truth)


def columns(
    methods: tuple[str, ...],
    params: dict[str, dict[str, Any]] | None = None,
    representations: bool = False,
) -> list[tuple[str, str, dict[str, Any]]]:
    """The ``(column, method, params)`` jobs: one a method, or with ``representations``
    each baseline once per descriptor it takes (:func:`eval_robust.descriptor_columns`).

    >>> [c for c, _, _ in columns(("weighted-node-lbp", "able-m"), representations=True)]
    ['weighted-node-lbp', 'able-m/lbp', 'able-m/haar', 'able-m/ldb']
    """
    params = params or {}
    if not representations:
        return [(m, m, dict(params.get(m) or {})) for m in methods]
    return [job for m in methods for job in descriptor_columns(m, params.get(m) or {})]


def sweep(
    query: str,
    seed: int,
    speeds: tuple[float, ...],
    methods: tuple[str, ...],
    places: int,
    params: dict[str, dict[str, Any]] | None = None,
    representations: bool = False,
) -> dict[float, dict[str, float]]:
    """Max F1 of every column (:func:`columns`) at every speed (one route each), each
    method with its ``params`` (``--param``) over its defaults."""
    jobs = columns(methods, params, representations)
    out: dict[float, dict[str, float]] = {}
    for speed in speeds:
        ref, frames, truth = frames_at(query, seed, speed, places)
        out[speed] = {
            col: run_method(m, ref, frames, truth, params=p or None).metrics.f1_max
            for col, m, p in jobs
        }
        row = " ".join(f"{m} {f:.3f}" for m, f in out[speed].items())
        print(f"  {query} seed {seed} speed {speed:g} ({len(frames)} queries): {row}", flush=True)
    return out


def declared(method: str, params: dict[str, Any] | None = None) -> str:
    """The ``speed_range`` (with ``params``) of ``method``, or of a column
    ``METHOD/DESCRIPTOR``, as ``lo-hi``, or ``-`` where it declares none."""
    if "/" in method:
        method, descriptor = method.split("/", 1)
        params = {**(params or {}), "descriptor": descriptor}
    rng = getattr(make_localiser(method, **(params or {})), "speed_range", None)
    return "-" if rng is None else f"{rng[0]:.2g}-{rng[1]:.3g}"


def table(
    figures: dict[float, dict[str, float]],
    methods: tuple[str, ...],
    params: dict[str, dict[str, Any]] | None = None,
) -> str:
    """A markdown table: one row per speed, one column per method (or column), the
    ranges last."""
    params = params or {}
    head = "| speed | " + " | ".join(methods) + " |"
    lines = [head, "|---" * (len(methods) + 1) + "|"]
    for speed, row in figures.items():
        lines.append(f"| {speed:g} | " + " | ".join(f"{row[m]:.3f}" for m in methods) + " |")
    ranges = (declared(m, params.get(m.split("/")[0])) for m in methods)
    lines.append("| declared | " + " | ".join(ranges) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--speeds", default=",".join(f"{s:g}" for s in SPEEDS))
    parser.add_argument("--queries", default=",".join(QUERIES))
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--places", type=int, default=200)
    parser.add_argument(
        "--methods",
        default=None,
        help="default: every method, or with "
        "--representations the weighted-node places and the particle filter",
    )
    parser.add_argument(
        "--representations",
        action="store_true",
        help="every filter on the same information: the weighted-node filter on each place, "
        "each baseline once per descriptor it takes",
    )
    add_param_option(parser)
    parser.add_argument("--json", type=Path, default=None, help="write every figure here")
    args = parser.parse_args(argv)
    params = parse_params(args.param)
    speeds = tuple(float(s) for s in args.speeds.split(","))
    default = REPRESENTATION_METHODS if args.representations else METHODS
    methods = tuple(args.methods.split(",")) if args.methods else default
    for name in sorted(set(params) - set(methods)):
        print(f"note: --param for {name!r}, which is not run, is ignored", file=sys.stderr)
    figures = {}
    for query in args.queries.split(","):
        figures[query] = sweep(
            query, args.seed, speeds, methods, args.places, params, args.representations
        )
        cols = tuple(c for c, _, _ in columns(methods, params, args.representations))
        print(
            f"\n{query}, seed {args.seed}:\n\n{table(figures[query], cols, params)}\n",
            flush=True,
        )
        if args.representations:
            for speed, row in figures[query].items():
                print(f"  {query} at {speed:g}: {same_place(row)}", flush=True)
    if args.json:
        data = {q: {f"{s:g}": row for s, row in f.items()} for q, f in figures.items()}
        args.json.write_text(json.dumps(data, indent=1))


if __name__ == "__main__":
    main()
