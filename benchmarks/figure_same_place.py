"""Every weighted-node place against the particle filter on the same place, route by route.

Not collected by pytest. Reads JSON files of ``benchmarks/eval_robust.py --representations``
(one panel each) and draws, for every route and every place both filters ran on, the
weighted-node filter's max F1 against the particle filter's on that place (the same
information): a point above the diagonal is a route the filter wins on that place. Each
panel's title counts the routes on which the better weighted-node place is at least the
particle filter on its place (:func:`eval_robust.same_place_summary`, the target of the
filter on the same information)::

    .venv/bin/python benchmarks/eval_robust.py --representations --jobs 2 --json repr.json
    .venv/bin/python benchmarks/eval_robust.py --representations --held-out --jobs 2 \\
        --json held.json
    .venv/bin/python benchmarks/figure_same_place.py repr.json held.json \\
        --titles "the 65 routes,the 40 held-out routes" --out docs/img/same-place.png
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from eval_robust import PLACE_OF, same_place_summary

BASELINE = "particle-filter"
"""The baseline each place is compared with, run on that place (``BASELINE/DESCRIPTOR``)."""

NAMES = {
    "lowres": "8x8 images",
    "lowres16": "16x16 images",
    "lbp": "LBP",
    "haar": "Haar signs",
    "patch": "64x32 patch (host)",
}
"""The legend's name of each place."""


def pairs(records: list[dict[str, Any]]) -> dict[str, tuple[list[float], list[float]]]:
    """Per place: (the particle filter's max F1 on it, the weighted-node filter's), over
    the routes on which both ran."""
    out: dict[str, tuple[list[float], list[float]]] = {}
    for rec in records:
        res = rec["results"]
        for wn, place in PLACE_OF.items():
            base = f"{BASELINE}/{place}"
            if wn in res and base in res:
                xs, ys = out.setdefault(place, ([], []))
                xs.append(float(res[base]["f1_max"]))
                ys.append(float(res[wn]["f1_max"]))
    return out


def draw(paths: list[Path], titles: list[str], out: Path) -> None:
    """One panel a file, written to ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        1, len(paths), figsize=(5.2 * len(paths), 5), squeeze=False, constrained_layout=True
    )
    for ax, path, title in zip(axes[0], paths, titles, strict=True):
        records = json.loads(path.read_text())["routes"]
        for place, (xs, ys) in pairs(records).items():
            ax.plot(xs, ys, "o", markersize=4, alpha=0.75, label=NAMES.get(place, place))
        _, stats = same_place_summary(records, BASELINE)
        ax.plot([0, 1], [0, 1], color="black", linewidth=0.8)
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        ax.set_xlabel("particle filter on the place (max F1)")
        ax.set_title(
            f"{title}: the better place (by its own F1) at least\nthe particle filter on it "
            f"on {stats['held']} of {stats['routes']} routes",
            fontsize=10,
        )
    axes[0][0].set_ylabel("weighted-node filter on the place (max F1)")
    axes[0][-1].legend(loc="lower right", fontsize=8)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", type=Path, nargs="+", help="eval_robust --representations JSON")
    parser.add_argument("--titles", default=None, help="comma-separated, one a file")
    parser.add_argument("--out", type=Path, default=Path("same-place.png"))
    args = parser.parse_args(argv)
    titles = (
        [t.strip() for t in args.titles.split(",")]
        if args.titles
        else [path.stem for path in args.runs]
    )
    if len(titles) != len(args.runs):
        raise SystemExit(f"error: {len(titles)} titles for {len(args.runs)} files")
    for path in args.runs:
        if not path.is_file():
            raise SystemExit(f"error: {path} is not a file")
    draw(args.runs, titles, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
