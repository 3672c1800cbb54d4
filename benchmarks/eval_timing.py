"""The timing model against published SCAMP-5 times, and the paper's frame times.

Run from the project root: ``python benchmarks/eval_timing.py [--json] [--frames N]``.
Not collected by pytest. Two parts:

- ``validation``: published SCAMP-5 times of public, fully described programs that were
  not used to fit any constant, each modelled as counts (kernels, ICWs, calls) and
  given its low/mid/high interval (``ppaloc.sim.timing.interval_us``);
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
from ppaloc.sim.timing import (
    ANALOGNET_STAGES,
    TimingConstants,
    add_counts,
    diff_counts,
    evaluate_us,
    interval_us,
)

DATA = Path("../shared/data")
PAPER_MS = {"lowres": 2.59, "lbp": 3.17}
PAPER_NODES = {"lowres": 1024, "lbp": 2048}
PAPER_SOURCE = (
    "Liu, Bose, Chen, Carey, Dudek, Mayol-Cuevas, 'Weighted Node Mapping and Localisation "
    "on a Pixel Processor Array', ICRA 2021: frame time on SCAMP-5d"
)

#: AnalogNet's whole frame: 2260 frames per second (Wong, Guillard, Murai, Saeedi, Kelly,
#: "AnalogNet: Convolutional Neural Network Inference on Analog Focal Plane Sensor
#: Processors", arXiv:2006.01765, 2020, abstract). Its three on-array stages are the fit;
#: what this workload tests is the rest of the frame: the frame-loop control and the
#: dense layer on the controller -- so it is partly dependent on the fit, and the only
#: published whole-program time found.
ANALOGNET_FPS = 2260.0
#: Estimate of the dense layer on the controller (us): 100-300 events (200 mid) read out,
#: each adding one weight to 10 class sums at 2-6 cycles per accumulate (4 mid) on a
#: ~200 MHz controller core.
DENSE_LAYER_US = tuple(e * 10 * c / 204.0 for e, c in ((100, 2), (200, 4), (300, 6)))


def validation() -> list[dict]:
    """Published SCAMP-5 times beside their modelled intervals (us)."""
    stages = []
    for prog in ANALOGNET_STAGES.values():
        counts = [{f"icw:{c}": float(n) for c, n in k.items() if n} for k in prog["kernels"]]
        counts.append({"kernels": float(len(prog["kernels"]))})
        for name, units in prog["calls"]:
            counts.append({f"calls:{name}": 1.0, f"units:{name}": float(units)})
        stages.append(add_counts(*counts))
    frame = add_counts(*stages, {"calls:vs_frame_loop_control": 1.0})
    iv = interval_us(frame)
    lo, mid, hi = DENSE_LAYER_US
    return [
        {
            "workload": "AnalogNet MNIST inference, whole frame (3 fitted on-array stages "
            "+ frame-loop control + dense layer on the controller)",
            "source": "Wong et al., AnalogNet, arXiv:2006.01765 (2020), abstract: 2260 FPS",
            "published_us": 1e6 / ANALOGNET_FPS,
            "modelled_us": [iv.low + lo, iv.mid + mid, iv.high + hi],
            "independent": "partly: the three stages (354 us) are the calibration; the "
            "frame-loop control and the dense-layer estimate are not fitted",
        }
    ]


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
    result = {"validation": validation(), "paper": paper(args.frames, args.start)}
    if args.json:
        print(json.dumps(result, indent=1))
        return
    for v in result["validation"]:
        lo, mid, hi = v["modelled_us"]
        pub = v["published_us"]
        print(
            f"{v['workload']}\n  published {pub:.0f} us ({v['source']}); modelled "
            f"{mid:.0f} us [{lo:.0f}, {hi:.0f}], mid {100 * (mid / pub - 1):+.0f}%, "
            f"{'inside' if lo <= pub <= hi else 'OUTSIDE'}; independent: {v['independent']}"
        )
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
