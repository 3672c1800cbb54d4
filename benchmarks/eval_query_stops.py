"""What the ground truth's reading of the query's own stops changes, for every method.

Not collected by pytest. A frame-synchronised dataset's ground truth accepts for query
frame ``i`` the reference frames ``i +- tolerance``, closed over the reference's stops
(the ``still-frames`` groups of ``ppaloc.datasets.sameplace``). Where the query stands
longer than the reference did, the frames it still stands in are judged by their index,
past the reference's stop. This prints each method's max F1, recall at 100% precision
and accuracy (precision at 100% recall) with the dataset's ground truth and with it also
closed over the query's own stops: the same ``still-frames`` rule run on the query
frames, every frame of a query group accepting what any frame of the group accepts. Every
method is run once and judged both ways::

    .venv/bin/python benchmarks/eval_query_stops.py            # Nordland, about 5 min
    .venv/bin/python benchmarks/eval_query_stops.py --methods weighted-node-lowres16
    .venv/bin/python benchmarks/eval_query_stops.py --param weighted-node-lowres16.still_decay=0

The dataset's ground truth is the one every other figure uses; this only measures how
much of a method's score the query's stops decide.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import DATA, parse_params, routes
from ppaloc.datasets import to_sensor
from ppaloc.datasets.groundtruth import PackedSets
from ppaloc.datasets.registry import load_dataset
from ppaloc.datasets.sameplace import still_groups, thumbnails
from ppaloc.evaluate.run import method_metrics, run_method

METHODS = (
    "weighted-node-lowres16",
    "weighted-node-lowres",
    "weighted-node-haar",
    "weighted-node-lbp",
    "particle-filter",
    "particle-filter/lowres16",
    "particle-filter/haar",
    "seqslam",
    "able-m",
    "single-frame",
)
"""The default methods; ``NAME/DESCRIPTOR`` runs ``NAME`` on that descriptor."""


def close_over_query_groups(truth: PackedSets, groups: np.ndarray) -> PackedSets:
    """Every query frame of a group ``[first, end)`` accepts the union of the group's sets."""
    sets = [np.asarray(truth[i]) for i in range(len(truth))]
    for first, end in groups:
        union = np.unique(np.concatenate(sets[first:end]))
        sets[first:end] = [union] * (end - first)
    return PackedSets.from_sets(sets)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--route", default="nordland summer->winter")
    parser.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="METHOD.key=value",
        help="a method's parameter (repeatable), e.g. weighted-node-lowres16.still_decay=0",
    )
    args = parser.parse_args()
    user = parse_params(args.param)
    specs = dict(routes())
    if args.route not in specs:
        raise SystemExit(f"error: no route {args.route!r}; routes: {', '.join(specs)}")
    if not DATA.is_dir():
        print(f"skipped: {DATA} is absent")
        return
    ds = load_dataset(specs[args.route])
    groups = still_groups(thumbnails(ds.query))
    closed = close_over_query_groups(ds.ground_truth, groups)
    grew = sum(len(closed[i]) != len(ds.ground_truth[i]) for i in range(len(closed)))
    print(
        f"{args.route}: {len(groups)} query stops, {int(np.sum(groups[:, 1] - groups[:, 0]))} "
        f"frames in them; {grew} of {len(closed)} query frames accept more"
    )
    reference = [to_sensor(f) for f in ds.reference]
    query = [to_sensor(f) for f in ds.query]
    print(f"{'method':26s} {'max F1':>15s} {'R@100P':>15s} {'accuracy':>15s}")
    for column in args.methods.split(","):
        name, _, descriptor = column.strip().partition("/")
        params = {**user.get(name, {}), **({"descriptor": descriptor} if descriptor else {})}
        run = run_method(name, reference, query, ds.ground_truth, params=params)
        score = np.asarray(run.score, float)
        cells = []
        for truth in (ds.ground_truth, closed):
            m = method_metrics(run.ref_index, score, truth, run.ranking, recall="A")
            cells.append((m.f1_max, m.recall_at_100p, m.precision_at_100r))
        (f0, r0, a0), (f1, r1, a1) = cells
        print(
            f"{column.strip():26s} {f0:6.3f} -> {f1:5.3f} {r0:6.3f} -> {r1:5.3f} "
            f"{a0:6.3f} -> {a1:5.3f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
