"""Max F1 of every baseline (and the weighted-node filter) on the shared real datasets.

Not collected by pytest. Run from the project root::

    .venv/bin/python benchmarks/eval_baselines.py            # every dataset, every method
    .venv/bin/python benchmarks/eval_baselines.py --only gp  # Gardens Point pairs only
    .venv/bin/python benchmarks/eval_baselines.py --tune-particle  # choose the PF defaults
    .venv/bin/python benchmarks/eval_baselines.py --dip  # SeqSLAM's enhancement, diagnosed

Frames go through the sensor front-end (``to_sensor``) once per traversal and are shared by
every method, and every method runs through the evaluation's own runner
(:func:`ppaloc.evaluate.run.run_method`, what ``ppaloc evaluate`` runs): a node is read as
the reference frame it predicts, and every method is judged by the dataset's accepted
sets. Scores are the methods' own confidences; max F1 uses recall definition A
(correct accepted / queries with a true match) over every distinct score, tolerance +-2.
SeqSLAM is also run in OpenSeqSLAM's centred (offline) mode for reference.

``--tune-particle`` is how the particle filter's ``sigma_rel`` and re-initialisation rate
were chosen: a grid over both, scored by the mean max F1 over synthetic routes that no
evaluation uses (seeds 11 and 12, summer -> winter and summer -> night, 300 places,
variable speed) and two filter seeds. The real datasets play no part in that choice.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from PIL import Image

from ppaloc.baselines import SeqSLAM
from ppaloc.baselines._common import uniqueness_ratio
from ppaloc.baselines.seqslam import contrast_enhance
from ppaloc.datasets import RouteDataset, load_dataset, to_grey, to_sensor
from ppaloc.errors import PpalocError
from ppaloc.evaluate.metrics import evaluate_estimates
from ppaloc.evaluate.run import MethodRun, run_method
from ppaloc.methods import make_localiser
from ppaloc.place.patch import mean_abs_diff, patch_normalise

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
NORDLAND = f"nordland:{DATA}/nordland-64x32?tolerance=2"
GP = f"gardens-point:{DATA}/gardens-point?tolerance=2"
DATASETS = {
    "nordland summer->winter": f"{NORDLAND}&ref=summer&query=winter",
    "gp day_left->day_right": f"{GP}&ref=day_left&query=day_right",
    "gp day_right->night_right": f"{GP}&ref=day_right&query=night_right",
    "gp day_left->night_right": f"{GP}&ref=day_left&query=night_right",
}
METHODS: dict[str, tuple[str, dict]] = {
    # label: (registry name, parameters)
    "single-frame": ("single-frame", {}),
    "seqslam": ("seqslam", {}),
    "seqslam-centred": ("seqslam-centred", {}),  # offline: reads ds/2 future frames
    # OpenSeqSLAM's edges (inf off the map, windows cut at the query's ends): for comparison.
    "seqslam-cut": ("seqslam", {"edges": "cut"}),
    "seqslam-noenhance": ("seqslam", {"enhance_window": 0}),
    "able-m": ("able-m", {}),
    "able-m-L20": ("able-m", {"length": 20}),
    "able-m-L40": ("able-m", {"length": 40}),
    "able-m-256bits": ("able-m", {"n_bits": 256}),
    "particle-filter": ("particle-filter", {}),
    "particle-filter-raw": ("particle-filter", {"observation": "raw"}),
    # The earlier defaults (1% re-initialisation), chosen on the real pairs: for comparison.
    "particle-filter-reinit1": ("particle-filter", {"p_jump": 0.24}),
    "weighted-node-lowres": ("weighted-node-lowres", {}),
    "weighted-node-lowres16": ("weighted-node-lowres16", {}),
    "weighted-node-haar": ("weighted-node-haar", {}),
    "weighted-node-patch": ("weighted-node-patch", {}),
    "weighted-node-lbp": ("weighted-node-lbp", {}),
}


def run(
    label: str, ds: RouteDataset, ref: list[np.ndarray], query: list[np.ndarray], pf_seed: int = 0
) -> MethodRun:
    """One method over the whole query through the evaluation's own runner
    (:func:`~ppaloc.evaluate.run.run_method`, as ``ppaloc evaluate`` runs it): each
    estimate's node is read as the reference frame it predicts (a keyframe node's own
    frame), an offline method (centred SeqSLAM) is handed the query first, and every
    method is judged by the same accepted sets."""
    name, params = METHODS[label]
    if name == "particle-filter":
        params = {**params, "seed": pf_seed}
    return run_method(name, ref, query, ds.ground_truth, params=params)


TUNING_ROUTES = [
    f"synthetic:?places=300&query={cond}&seed={seed}&tolerance=2"
    for seed in (11, 12)
    for cond in ("winter", "night")
]
TUNING_SIGMA_REL = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0)
TUNING_REINIT = (0.01, 0.02, 0.05, 0.1)
TUNING_FILTER_SEEDS = (0, 1)


def tune_particle() -> None:
    """Print the mean max F1 of every (sigma_rel, re-initialisation) pair on the tuning
    routes, best last. ``p_stay`` and ``p_forward`` stay at their defaults; ``p_jump``
    takes what the re-initialisation leaves."""
    routes = []
    for spec in TUNING_ROUTES:
        ds = load_dataset(spec)
        routes.append((ds, [to_sensor(f) for f in ds.reference], [to_sensor(f) for f in ds.query]))
    scores = {}
    for sigma_rel in TUNING_SIGMA_REL:
        for reinit in TUNING_REINIT:
            f1 = []
            for ds, ref, query in routes:
                for seed in TUNING_FILTER_SEEDS:
                    loc = make_localiser(
                        "particle-filter",
                        sigma_rel=sigma_rel,
                        p_jump=1.0 - 0.15 - 0.6 - reinit,
                        seed=seed,
                    )
                    loc.build_map(ref)
                    est = [loc.step(f) for f in query]
                    m = evaluate_estimates(
                        [e.node for e in est], [e.score for e in est], ds.ground_truth
                    )
                    f1.append(m.f1_max)
            scores[sigma_rel, reinit] = float(np.mean(f1))
            print(
                f"sigma_rel {sigma_rel:5.2f}  re-init {reinit:4.2f}  mean max F1 "
                f"{scores[sigma_rel, reinit]:.4f}  (min {min(f1):.4f})",
                flush=True,
            )
    best = max(scores, key=scores.get)
    print(f"best: sigma_rel {best[0]}, re-initialisation {best[1]}, mean max F1 {scores[best]:.4f}")


def _lanczos_image(frame: np.ndarray) -> np.ndarray:
    grey = Image.fromarray(to_grey(frame)).resize((64, 32), Image.Resampling.LANCZOS)
    return patch_normalise(np.asarray(grey, dtype=np.float64))


def _max_f1(nodes: list[int], scores: list[float], ground_truth) -> float:
    return evaluate_estimates(nodes, scores, ground_truth).f1_max


def dip() -> None:
    """Why SeqSLAM's contrast enhancement helps on Nordland and hurts on GP day_left ->
    day_right: the shape of the raw difference column around the true node, where the
    per-frame minimum lands before and after enhancement, and SeqSLAM's max F1 with
    OpenSeqSLAM's whole-matrix minimum subtracted instead of the constant shift."""
    for name in ("nordland summer->winter", "gp day_left->day_right"):
        ds = load_dataset(DATASETS[name])
        s = SeqSLAM()
        s.build_map([to_sensor(f) for f in ds.reference])
        d = np.stack([s.difference_column(to_sensor(f)) for f in ds.query], axis=1)  # (N, Q)
        n, q = d.shape
        truth = np.arange(q)  # both sets are index-aligned: query i is reference i
        inner = range(10, min(n, q) - 10)
        profile = np.mean([d[j - 3 : j + 4, j] / np.median(d[:, j]) for j in inner], axis=0)
        enhanced = contrast_enhance(d, s.enhance_window)
        near = [np.mean(np.abs(m.argmin(axis=0) - truth) <= 2) for m in (d, enhanced)]
        print(
            f"{name}: raw difference / column median at offsets -3..+3: "
            + " ".join(f"{v:.3f}" for v in profile)
        )
        print(f"{name}: per-frame argmin within +-2, raw {near[0]:.3f}, enhanced {near[1]:.3f}")
        cols = range(min(n, q))
        ranks = [np.median([np.sum(m[:, j] < m[j, j]) for j in cols]) for m in (d, enhanced)]
        print(f"{name}: median rank of the true node, raw {ranks[0]:.0f}, enhanced {ranks[1]:.0f}")
        # The same from OpenSeqSLAM's own front end: a 64x32 Lanczos resize of the originals.
        ref = np.stack([_lanczos_image(f) for f in ds.reference])
        d2 = np.stack([mean_abs_diff(_lanczos_image(f), ref) for f in ds.query], axis=1)
        near2 = [np.mean(np.abs(m.argmin(axis=0) - truth) <= 2) for m in (d2, contrast_enhance(d2))]
        print(
            f"{name}: the same from 64x32 Lanczos resizes of the original frames, raw "
            f"{near2[0]:.3f}, enhanced {near2[1]:.3f}"
        )
        z = (enhanced - enhanced.min()).T  # OpenSeqSLAM: DD - min(min(DD)); (Q, N)
        fills = np.median(z, axis=1)
        for mode, before, after in (("past", s.ds, 0), ("centred", s.ds // 2, s.ds // 2)):
            nodes, scores = [], []
            for t in range(q):
                lo, hi = max(0, t - before), min(q - 1, t + after)
                cost = s.window_costs(z[lo : hi + 1], fills[lo : hi + 1], lo - t)
                best = int(np.argmin(cost))
                nodes.append(best)
                scores.append(uniqueness_ratio(cost, best, s.rwindow // 2))
            f1 = _max_f1(nodes, scores, ds.ground_truth)
            print(f"{name}: SeqSLAM {mode}, whole-matrix minimum subtracted: max F1 {f1:.3f}")


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", choices=["gp", "nordland"], default=None)
    parser.add_argument("--methods", nargs="*", default=list(METHODS), choices=list(METHODS))
    parser.add_argument("--pf-seed", type=int, default=0, help="seed of the particle filters")
    parser.add_argument("--out", type=Path, default=None, help="write the table as JSON")
    parser.add_argument(
        "--tune-particle", action="store_true", help="choose the particle filter's defaults"
    )
    parser.add_argument("--dip", action="store_true", help="diagnose SeqSLAM's enhancement")
    args = parser.parse_args()
    if args.dip:
        dip()
        return
    if args.tune_particle:
        tune_particle()
        return
    rows = []
    for name, spec in DATASETS.items():
        if args.only == "gp" and not name.startswith("gp"):
            continue
        if args.only == "nordland" and not name.startswith("nordland"):
            continue
        ds = load_dataset(spec)
        ref = [to_sensor(f) for f in ds.reference]
        query = [to_sensor(f) for f in ds.query]
        for method in args.methods:
            try:
                result = run(method, ds, ref, query, args.pf_seed)
            except PpalocError as exc:  # a method not available in this tree
                print(f"{name:28s} {method:22s} unavailable: {exc}")
                continue
            m = result.metrics
            dt = float(np.nanmean(result.latency_ms))
            row = {
                "dataset": name,
                "method": method,
                "f1_max": round(m.f1_max, 4),
                "precision_at_100r": round(m.precision_at_100r, 4),
                "recall_at_100p": round(m.recall_at_100p, 4),
                "ms_per_frame": round(dt, 2),
                "n_queries": m.n_queries,
            }
            rows.append(row)
            print(
                f"{name:28s} {method:22s} maxF1 {m.f1_max:.4f}  P@100R {m.precision_at_100r:.4f}  "
                f"R@100P {m.recall_at_100p:.4f}  {dt:7.2f} ms/frame",
                flush=True,
            )
    if args.out:
        args.out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
