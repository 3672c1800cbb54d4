"""Max F1 against the size of a place, for every method on every descriptor it takes.

Not collected by pytest. Reads two JSON files of ``benchmarks/eval_robust.py`` (the same
65 routes): one ``--representations`` run (every baseline on the weighted-node filter's
low-res place and LBP code and on its own descriptor) and one default run (which holds the
paper's preset), and draws the mean max F1 of each method against the values (or bits)
each place holds, with the paper's two points (Algorithm 1 on 32 LBP bits and on 64 block
means) marked::

    .venv/bin/python benchmarks/eval_robust.py --representations --jobs 2 --json repr.json
    .venv/bin/python benchmarks/eval_robust.py --jobs 2 --json acc.json
    .venv/bin/python benchmarks/figure_place_budget.py repr.json acc.json \
        --out docs/img/place-budget.png

Two panels: the 5 real routes, and all 65. A place's size is what it holds, whatever the
type of a value: 32 bits (LBP), 64 block means (low-res), 192 bits (the Haar signs),
256 block means (the 16x16 low-res place), 1384 bits (ABLE-M's LDB code),
2048 patch-normalised values (the 64x32 image of the particle filter, SeqSLAM and
single-frame matching).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

SIZES = {"lbp": 32, "lowres": 64, "haar": 192, "lowres16": 256, "ldb": 1384, "patch": 2048}
"""Values (or bits) per place of each descriptor."""

IMAGES = ("lbp", "lowres", "haar", "lowres16", "patch")
"""The descriptors of the image baselines, smallest first."""

SERIES = {
    "weighted-node filter (robust)": {
        d: f"weighted-node-{d}" for d in ("lbp", "lowres", "haar", "lowres16")
    },
    "particle filter": {d: f"particle-filter/{d}" for d in IMAGES},
    "SeqSLAM": {d: f"seqslam/{d}" for d in IMAGES},
    "single-frame": {d: f"single-frame/{d}" for d in IMAGES},
    "ABLE-M": {"lbp": "able-m/lbp", "haar": "able-m/haar", "ldb": "able-m/ldb"},
}
"""Each line of the figure: descriptor -> the column of the ``--representations`` run."""

PAPER = {"lbp": "weighted-node-paper-lbp", "lowres": "weighted-node-paper-lowres"}
"""The paper's Algorithm 1 (the default run's columns)."""


def means(path: Path, columns: dict[str, str]) -> dict[str, tuple[float, float]]:
    """Mean max F1 of each column over the real routes and over every route."""
    routes = json.loads(path.read_text())["routes"]
    real = [r for r in routes if not r["label"].startswith("synthetic")]
    out = {}
    for key, column in columns.items():
        values = [[r["results"][column]["f1_max"] for r in rs] for rs in (real, routes)]
        out[key] = (float(np.mean(values[0])), float(np.mean(values[1])))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("representations", type=Path, help="eval_robust --representations JSON")
    parser.add_argument("default", type=Path, help="eval_robust JSON of the default methods")
    parser.add_argument("--out", type=Path, default=Path("place-budget.png"))
    args = parser.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), sharey=True, constrained_layout=True)
    paper = means(args.default, PAPER)
    for name, columns in SERIES.items():
        got = means(args.representations, columns)
        xs = [SIZES[d] for d in columns]
        for i, ax in enumerate(axes):
            ax.plot(xs, [got[d][i] for d in columns], "o-", label=name)
    for i, ax in enumerate(axes):
        ax.plot(
            [SIZES[d] for d in PAPER],
            [paper[d][i] for d in PAPER],
            "*",
            markersize=14,
            color="black",
            label="the paper's Algorithm 1 (LBP, 8x8)",
        )
        ax.set_xscale("log", base=2)
        # every other name a line lower: 192 and 256 sit close on the log axis
        names = [f"{v}\n{chr(10) * (k % 2)}{d}" for k, (d, v) in enumerate(SIZES.items())]
        ax.set_xticks(list(SIZES.values()), names)
        ax.set_xlabel("values (or bits) per place")
        ax.set_title(["the 5 real routes", "all 65 routes"][i])
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("mean max F1")
    axes[0].set_ylim(0, 1)
    axes[1].legend(loc="lower right", fontsize=8)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
