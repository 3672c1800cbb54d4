"""What the ground truth's reading of the query's own stops changes, for every method.

Not collected by pytest. A frame-synchronised dataset's ground truth accepts for query
frame ``i`` the reference frames ``i +- tolerance``, closed over the same-place groups of
both traversals (the ``still-frames`` rule of ``ppaloc.datasets.sameplace``): a query
frame of a reference stop accepts the whole stop, and every frame of a query stop accepts
what any frame of it accepts, so the frames where the query stands longer than the
reference did are not judged by their index, past the reference's stop. This prints each
method's max F1, recall at 100% precision and accuracy (precision at 100% recall) with
the truth closed over the reference's stops only (the rule before the query's were read)
and with the dataset's. Every method is run once and judged both ways::

    .venv/bin/python benchmarks/eval_query_stops.py            # Nordland, about 5 min
    .venv/bin/python benchmarks/eval_query_stops.py --methods weighted-node-lowres16
    .venv/bin/python benchmarks/eval_query_stops.py --param weighted-node-lowres16.still_decay=0
    .venv/bin/python benchmarks/eval_query_stops.py --methods weighted-node-lowres16 --wrong 12

``--wrong N`` also lists each method's ``N`` surest wrong estimates by the dataset's
ground truth: what a confidence that ranks as it should would put last.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import DATA, parse_params, routes
from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.evaluate.metrics import is_correct
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


def surest_wrong(
    predicted: np.ndarray, score: np.ndarray, truth: Sequence[np.ndarray], n: int
) -> list[tuple[int, int, np.ndarray, float]]:
    """The ``n`` wrong estimates of highest score: ``(query, predicted reference frame,
    accepted set, score)``, the surest first (ties in query order)."""
    wrong = np.flatnonzero(~is_correct(predicted, truth)).tolist()
    wrong.sort(key=lambda q: -float(score[q]))
    return [(q, int(predicted[q]), np.asarray(truth[q]), float(score[q])) for q in wrong[:n]]


def _accepts(refs: np.ndarray) -> str:
    return "none" if refs.size == 0 else f"{refs.min()}-{refs.max()}"


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
    parser.add_argument(
        "--wrong", type=int, default=0, metavar="N", help="list each method's N surest wrong"
    )
    args = parser.parse_args()
    user = parse_params(args.param)
    specs = dict(routes())
    if args.route not in specs:
        raise SystemExit(f"error: no route {args.route!r}; routes: {', '.join(specs)}")
    if not DATA.is_dir():
        print(f"skipped: {DATA} is absent")
        return
    spec = specs[args.route]
    ds = load_dataset(spec)
    groups = ds.query_groups
    if groups is None:
        raise SystemExit(f"error: {args.route!r} has no query groups (its rule reads no images)")
    sep = "&" if "?" in spec else "?"
    before = load_dataset(f"{spec}{sep}same_place=reference-images").ground_truth
    grew = int(np.count_nonzero(before.lengths != ds.ground_truth.lengths))
    print(
        f"{args.route}: {len(groups)} query stops, {int(np.sum(groups[:, 1] - groups[:, 0]))} "
        f"frames in them; {grew} of {len(before)} query frames accept more than with the "
        "reference's stops alone"
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
        for truth in (before, ds.ground_truth):
            m = method_metrics(run.ref_index, score, truth, run.ranking, recall="A")
            cells.append((m.f1_max, m.recall_at_100p, m.precision_at_100r))
        (f0, r0, a0), (f1, r1, a1) = cells
        print(
            f"{column.strip():26s} {f0:6.3f} -> {f1:5.3f} {r0:6.3f} -> {r1:5.3f} "
            f"{a0:6.3f} -> {a1:5.3f}",
            flush=True,
        )
        for q, ref, accepted, sc in surest_wrong(run.ref_index, score, ds.ground_truth, args.wrong):
            print(f"    query {q}: reference {ref}, accepts {_accepts(accepted)}, score {sc:.2f}")


if __name__ == "__main__":
    main()
