"""Max F1 where the query leaves the map: does a method know when no place explains it?

Not collected by pytest. Each route's reference is cut after its first ``--share`` (2/3)
of frames and mapped; every query frame is localised. The query frames whose accepted
references all lie past the cut have no true match, so an estimate there counts only
against a method, by its confidence: a method that knows it is lost gives them low
scores and keeps its max F1 and recall at 100% precision. Every method gets the same
reference, query and ground truth (the dataset's, cut at the same frames). With
``--gap A B`` a stretch in the middle is left out instead (the reference frames from
the share ``A`` to ``B`` of the route): the query drives through places the map lacks
(a detour, a new road) and back onto the map::

    .venv/bin/python benchmarks/eval_offmap.py                     # about 10 min, 2 cores
    .venv/bin/python benchmarks/eval_offmap.py --methods weighted-node-lowres16,particle-filter
    .venv/bin/python benchmarks/eval_offmap.py --param weighted-node-lowres16.lost_window=0
    .venv/bin/python benchmarks/eval_offmap.py --gap 0.4 0.55

Routes: Nordland summer -> winter and Gardens Point day_right -> night_right and
day_left -> day_right (``../shared/data``, skipped with a note when absent), and two
generated routes. Columns: max F1 and, in brackets, recall at 100% precision, and
``off-map >= right``: the share of the off-map frames scored at least the median score
of the right estimates on the map (lower is better).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import DATA, parse_params, routes
from ppaloc.datasets import to_sensor
from ppaloc.datasets.registry import load_dataset
from ppaloc.errors import PpalocError
from ppaloc.evaluate.metrics import is_correct
from ppaloc.evaluate.run import run_method
from ppaloc.methods import check_method

METHODS = (
    "weighted-node-lowres16",
    "weighted-node-lowres",
    "weighted-node-haar",
    "weighted-node-lbp",
    "particle-filter",
    "seqslam",
    "able-m",
    "single-frame",
)
"""The default methods; ``particle-filter`` also runs on the 16x16 place (``/lowres16``)."""


REAL_ROUTES = ("nordland summer->winter", "gp day_right->night_right", "gp day_left->day_right")
"""The real routes, as :func:`eval_robust.routes` names and specifies them."""


def offmap_routes(data_dir: Path | None = DATA) -> list[tuple[str, str]]:
    """``(label, spec)`` of every route, real data first (those missing are skipped, with
    :func:`eval_robust.routes`' note)."""
    real = dict(routes(data_dir))
    out = [(label, real[label]) for label in REAL_ROUTES if label in real]
    for seed, query in ((1, "winter"), (2, "autumn")):
        spec = f"synthetic:?places=300&query={query}&seed={seed}&speed_var=0.2"
        out.append((f"synthetic seed={seed} {query}", spec))
    return out


def cut_route(
    spec: str, share: float, gap: tuple[float, float] | None = None
) -> tuple[list, list, list[np.ndarray], np.ndarray]:
    """The reference's first ``share`` of frames (or all but the frames from the share
    ``gap[0]`` to ``gap[1]`` of them), every query frame, the ground truth cut the same
    way (its frames numbered as the cut reference's), and which queries are off the map
    (no accepted frame left)."""
    ds = load_dataset(spec)
    n = len(ds.reference)
    kept = np.ones(n, dtype=bool)
    if gap is None:
        kept[max(1, round(share * n)) :] = False
    else:
        a, b = round(gap[0] * n), round(gap[1] * n)
        if not 0 < a < b < n:
            raise PpalocError(f"--gap {gap[0]} {gap[1]} leaves no stretch inside {n} frames")
        kept[a:b] = False
    number = np.cumsum(kept) - 1  # a kept frame's index in the cut reference
    reference = [to_sensor(f) for f in ds.reference[np.flatnonzero(kept).tolist()]]
    query = [to_sensor(f) for f in ds.query]
    truth = [np.asarray([number[r] for r in g if kept[r]], dtype=np.int64) for g in ds.ground_truth]
    off = np.array([len(g) == 0 for g in truth]) & np.array([len(g) > 0 for g in ds.ground_truth])
    return reference, query, truth, off


def score_route(
    spec: str,
    columns: Sequence[tuple[str, str, dict[str, Any]]],
    share: float,
    gap: tuple[float, float] | None = None,
) -> dict[str, dict[str, float]]:
    """Max F1, recall at 100% precision and the off-map share above the right median."""
    reference, query, truth, off = cut_route(spec, share, gap)
    out = {}
    for column, method, params in columns:
        run = run_method(method, reference, query, truth, params=params)
        score = np.asarray(run.score, dtype=np.float64)
        right = is_correct(run.ref_index, truth)
        median = np.median(score[right]) if right.any() else np.inf
        out[column] = {
            "f1_max": float(run.metrics.f1_max),
            "recall_at_100p": float(run.metrics.recall_at_100p),
            "off_above": float(np.mean(score[off] >= median)) if off.any() else float("nan"),
            "off_frames": int(off.sum()),
        }
    return out


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--param", action="append", default=[], metavar="METHOD.key=value")
    parser.add_argument("--share", type=float, default=2 / 3, help="the reference kept")
    parser.add_argument(
        "--gap",
        type=float,
        nargs=2,
        default=None,
        metavar=("A", "B"),
        help="leave out the reference frames from the share A to B of the route instead "
        "of cutting its end (--share is then not used)",
    )
    parser.add_argument("--routes", default=None, metavar="SUBSTR")
    parser.add_argument("--data", type=Path, default=DATA)
    args = parser.parse_args(argv)
    if not 0 < args.share < 1:
        parser.error(f"--share {args.share} must lie between 0 and 1")
    if args.gap is not None and not 0 < args.gap[0] < args.gap[1] < 1:
        parser.error(f"--gap {args.gap[0]} {args.gap[1]}: want 0 < A < B < 1")
    user = parse_params(args.param)
    names = [n.strip() for n in args.methods.split(",")]
    for method in set(user) - set(names):
        parser.error(f"--param {method}.*: {method} is not one of --methods")
    columns = []
    for name in names:
        if name == "particle-filter":
            columns.append(("particle-filter", name, dict(user.get(name, {}))))
            pf = dict(user.get(name, {}), descriptor="lowres16")
            columns.append(("particle-filter/lowres16", name, pf))
        else:  # every other method on its own default descriptor
            columns.append((name, name, dict(user.get(name, {}))))
    for column, method, params in columns:  # every name and parameter, before any data
        try:
            check_method(method, params)
        except PpalocError as exc:
            parser.error(f"{column}: {exc}")
    chosen = [r for r in offmap_routes(args.data) if not args.routes or args.routes in r[0]]
    if not chosen:
        parser.error("no route to run")
    rows = []
    for label, spec in chosen:
        start = time.perf_counter()
        try:
            rows.append((label, score_route(spec, columns, args.share, args.gap)))
        except PpalocError as exc:
            parser.error(f"{label}: {exc}")
        print(f"{label}: {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)
    names = [c for c, _, _ in columns]
    print(f"| route (off-map frames) | {' | '.join(names)} |")
    print("|---|" + "---|" * len(names))
    for label, res in rows:
        cells = [
            f"{res[c]['f1_max']:.3f} ({res[c]['recall_at_100p']:.2f}) {res[c]['off_above']:.2f}"
            for c in names
        ]
        print(f"| {label} ({res[names[0]]['off_frames']}) | {' | '.join(cells)} |")


if __name__ == "__main__":
    main()
