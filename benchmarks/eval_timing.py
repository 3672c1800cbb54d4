"""The timing model against published SCAMP-5 times, and the paper's frame times.

Run from the project root: ``python benchmarks/eval_timing.py [--json] [--frames N]``.
Not collected by pytest. Two parts (and ``validation_candidates``: the published times
considered and not used, each with its source and reason):

- ``validation``: published SCAMP-5 times of public, fully described programs, each
  modelled as counts (kernels, ICWs, calls) and given its low/mid/high interval
  (``ppaloc.sim.timing_validation``: the workloads, the part of each that no constant was
  fitted to, and the candidates considered and not used, with the reasons);
- ``paper``: the weighted-node paper's measured frame times (2.59 ms with 8x8 images,
  3.17 ms with descriptors, SCAMP-5d) beside the modelled ``chip`` and ``loop``
  intervals of the paper preset at its map sizes, for both program structures
  (``"ppaloc"``: the simulated pipeline; ``"precursor"``: the stages the public precursor
  programs differently, replaced by its counts). Nothing is fitted to these two figures.

The query frames are the shared Nordland summer copy (``../shared/data``; their content
sets the injection's draw calls), or blocky random frames when it is absent.
"""

from __future__ import annotations

import argparse
import dataclasses
import glob
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from ppaloc.datasets import to_sensor
from ppaloc.localise.weighted import WeightedNodeLocaliser
from ppaloc.onsensor import OnSensorLocaliser
from ppaloc.onsensor.precursor import (
    REPLACED_STAGES,
    STRUCTURES,
    loop_counts,
    precursor_stage_counts,
    structure_counts,
)
from ppaloc.sim.timing import TimingConstants, add_counts, diff_counts, evaluate_us
from ppaloc.sim.timing_validation import CANDIDATES, WORKLOADS

DATA = Path("../shared/data")
PAPER_MS = {"lowres": 2.59, "lbp": 3.17}
PAPER_NODES = {"lowres": 1024, "lbp": 2048}
PAPER_SOURCE = (
    "Liu, Bose, Chen, Carey, Dudek, Mayol-Cuevas, 'Weighted Node Mapping and Localisation "
    "on a Pixel Processor Array', ICRA 2021: frame time on SCAMP-5d"
)


def validation() -> list[dict]:
    """Published SCAMP-5 times beside their modelled intervals (us; ``timing_validation``)."""
    return [w.as_dict() for w in WORKLOADS]


def _frames(n: int) -> tuple[list[np.ndarray], str]:
    files = sorted(glob.glob(str(DATA / "nordland-64x32" / "summer" / "*")))
    if len(files) >= 1024:
        from PIL import Image

        return [to_sensor(np.asarray(Image.open(f))) for f in files], "Nordland summer"
    rng = np.random.default_rng(0)
    cells = rng.integers(0, 256, (n + 2048, 16, 16)).astype(np.uint8)
    return [np.kron(c, np.ones((16, 16), np.uint8)) for c in cells], "blocky random"


def paper(n_frames: int = 40, start: int = 600) -> list[dict]:
    """The paper preset at the paper's map sizes: chip and loop, both structures (ms).

    The map is the first 1024 (lowres) or all 1788 (lbp: one tile of 2048) frames; the
    query is ``n_frames`` consecutive map frames from ``start`` (the route's first frames
    are dark and nearly empty, which would understate the injection's draw calls).
    """
    frames, source = _frames(n_frames)
    out = []
    for rep in ("lowres", "lbp"):
        n = min(PAPER_NODES[rep], len(frames))
        host = WeightedNodeLocaliser(rep, preset="paper", motion="image", arithmetic="ppa8")
        topomap = host.build_map(frames[:n])
        query = frames[start : start + n_frames]
        row = {
            "representation": rep,
            "published_ms": PAPER_MS[rep],
            "source": PAPER_SOURCE,
            "nodes": n,
            "frames": f"{source} frames {start}-{start + n_frames - 1}, the paper preset, "
            "image motion",
        }
        for structure in STRUCTURES:
            loc = OnSensorLocaliser(rep, preset="paper", motion="image")
            loc.use_map(topomap)
            row[structure] = _timed(loc, query, rep, structure)
        out.append(row)
    return out


def _timed(loc: OnSensorLocaliser, query: list, rep: str, structure: str) -> dict:
    """Step ``query``; per frame the chip counts of ``structure`` and both loop variants."""
    timing = loc.pipeline.sim.timing
    loc.reset()
    chip, drawn, only_bytes, stages = [], [], [], defaultdict(list)
    for i, frame in enumerate(query):
        before = timing.counts_by_stage()
        est = loc.step(frame)
        ours = diff_counts(timing.counts_by_stage(), before)
        weights = loc.pipeline.weights() if structure == "precursor" else None
        counts = structure_counts(ours, rep, structure, forward=bool(est.moved), weights=weights)
        if i < 2:  # the first frames record the kernels and have no motion decision
            continue
        chip.append(timing.interval(counts).as_list())
        drawn.append(timing.interval(add_counts(counts, loop_counts(frame))).as_list())
        bytes_loop = add_counts(counts, loop_counts(frame, injection="bytes"))
        only_bytes.append(timing.interval(bytes_loop).as_list())
        per_stage = dict(ours)
        if structure == "precursor":
            for name in REPLACED_STAGES[rep]:
                per_stage.pop(name, None)
            per_stage.update(precursor_stage_counts(rep, forward=bool(est.moved), weights=weights))
        for name, c in per_stage.items():
            stages[name].append(evaluate_us(c, TimingConstants()))
    n = len(chip)
    out = {
        "chip": np.median(chip, axis=0).round(4).tolist(),
        "loop": np.median(drawn, axis=0).round(4).tolist(),
        "loop_bytes_only": np.median(only_bytes, axis=0).round(4).tolist(),
        "stages_mid_us": {k: round(sum(v) / n, 1) for k, v in stages.items()},
    }
    for key in ("chip", "loop", "loop_bytes_only"):
        out[key] = [v / 1000.0 for v in out[key]]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--frames", type=int, default=40, help="query frames per run")
    ap.add_argument("--start", type=int, default=600, help="first query frame")
    args = ap.parse_args()
    result = {
        "validation": validation(),
        "validation_candidates": [dataclasses.asdict(c) for c in CANDIDATES],
        "paper": paper(args.frames, args.start),
    }
    if args.json:
        print(json.dumps(result, indent=1))
        return
    for v in result["validation"]:
        print(f"{v['workload']}\n  {v['source']}; independent: {v['independent']}")
        for label, part in (("whole", v), ("unfitted part", v["unfitted_part"])):
            lo, mid, hi = part["modelled_us"]
            pub = part["published_us"]
            print(
                f"  {label}: published {pub:.0f} us; modelled {mid:.0f} us [{lo:.0f}, "
                f"{hi:.0f}], mid {100 * (mid / pub - 1):+.0f}%, "
                f"{'inside' if lo <= pub <= hi else 'OUTSIDE'}"
            )
    print(f"\nconsidered and not used ({len(CANDIDATES)}):")
    for c in CANDIDATES:
        print(f"  {c.name} ({c.source}: {c.published}): {c.reason}")
    for p in result["paper"]:
        print(
            f"\n{p['representation']} ({p['nodes']} nodes, {p['frames']}): paper "
            f"{p['published_ms']} ms"
        )
        for s in STRUCTURES:
            r = p[s]
            for b in ("chip", "loop", "loop_bytes_only"):
                lo, mid, hi = r[b]
                inside = "inside" if lo <= p["published_ms"] <= hi else "outside"
                print(
                    f"  {s:9s} {b:15s} {mid:6.2f} ms [{lo:.2f}, {hi:.2f}] "
                    f"(high/low {hi / lo:.2f}; paper {inside})"
                )
            top = sorted(r["stages_mid_us"].items(), key=lambda kv: -kv[1])
            print("    stages (mid, us): " + ", ".join(f"{k} {v:.0f}" for k, v in top))


if __name__ == "__main__":
    main()
