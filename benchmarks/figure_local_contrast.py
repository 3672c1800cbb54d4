"""Following a varying speed against keeping the real routes: local contrast options.

Not collected by pytest. Reads JSON files of ``benchmarks/eval_robust.py`` (the same 65
routes) and draws, for each, one method's mean max F1 over the 5 real routes (x) against
its mean over the 30 generated routes at ``speed_var=0.65`` (y): the trade-off that every
freedom given to the weighted-node filter moves along (docs/localise.md, "Local contrast
of the distances"). Points of one series are joined in the order given::

    .venv/bin/python benchmarks/eval_robust.py --methods weighted-node-lowres16 \\
        --param weighted-node-lowres16.enhance=10 --json enhance-10.json
    .venv/bin/python benchmarks/eval_robust.py --methods weighted-node-lowres16 \\
        --param weighted-node-lowres16.local_gain=2 --json local-2-2.json
    .venv/bin/python benchmarks/eval_robust.py --representations --json repr.json
    .venv/bin/python benchmarks/figure_local_contrast.py \\
        --point "off,,default.json" \\
        --point "enhance,R=10,enhance-10.json" \\
        --point "local_gain (W=2),g=2,local-2-2.json" \\
        --point "particle filter,same place,repr.json,particle-filter/lowres16" \\
        --out docs/img/local-contrast.png

``--point SERIES,LABEL,PATH[,COLUMN]``: COLUMN defaults to ``--method``
(``weighted-node-lowres16``). A series of one point is drawn as a star.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def group_means(path: Path, column: str) -> tuple[float, float]:
    """Mean max F1 of ``column`` over the real routes and over ``speed_var=0.65``."""
    routes = json.loads(path.read_text())["routes"]
    real = [r for r in routes if not r["label"].startswith("synthetic")]
    fast = [r for r in routes if "speed_var=0.65" in r["label"]]
    if not real or not fast:
        raise SystemExit(f"error: {path} lacks the real or the speed_var=0.65 routes")
    try:
        return tuple(  # type: ignore[return-value]
            float(np.mean([r["results"][column]["f1_max"] for r in rs])) for rs in (real, fast)
        )
    except KeyError:
        raise SystemExit(f"error: {path} has no column {column!r} on every route") from None


def parse_point(text: str, method: str) -> tuple[str, str, Path, str]:
    """``SERIES,LABEL,PATH[,COLUMN]`` -> its parts (one-line error when malformed)."""
    parts = text.split(",")
    if len(parts) not in (3, 4):
        raise SystemExit(f"error: --point {text!r} is not SERIES,LABEL,PATH[,COLUMN]")
    series, label, path = parts[:3]
    column = parts[3] if len(parts) == 4 else method
    if not Path(path).is_file():
        raise SystemExit(f"error: --point {text!r}: no file {path}")
    return series, label, Path(path), column


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--point", action="append", required=True, metavar="S,L,PATH[,COL]")
    parser.add_argument("--method", default="weighted-node-lowres16")
    parser.add_argument("--out", type=Path, default=Path("local-contrast.png"))
    args = parser.parse_args()
    series: dict[str, list[tuple[str, float, float]]] = {}
    for text in args.point:
        name, label, path, column = parse_point(text, args.method)
        real, fast = group_means(path, column)
        series.setdefault(name, []).append((label, real, fast))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.2, 5.2), constrained_layout=True)
    for name, points in series.items():
        xs, ys = [p[1] for p in points], [p[2] for p in points]
        if len(points) == 1:
            ax.plot(xs, ys, "*", markersize=14, label=name)
        else:
            ax.plot(xs, ys, "o-", label=name)
        for label, x, y in points:
            if label:
                ax.annotate(label, (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)
    ax.set_xlabel("mean max F1, the 5 real routes")
    ax.set_ylabel("mean max F1, generated routes at speed_var=0.65")
    ax.set_title(f"{args.method}: local contrast of the distances")
    ax.grid(alpha=0.3)
    ax.legend(loc="lower left", fontsize=8)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
