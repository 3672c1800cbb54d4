"""The on-sensor pipelines on one thread and on several, side by side in one process.

``python benchmarks/bench_threads.py [--threads 2] [--reps lowres,lbp] [--noise typical]
[--rounds 8]`` builds the benchmark's localiser (``bench_onsensor.localiser``: robust
preset, speed lanes off, first tier) twice, once with ``$PPALOC_THREADS=1`` and once with
``--threads``, and steps both through the same frames frame by frame, the one that goes
first alternating, so that both see the same load. Prints per pipeline the median frame
of each, their ratio, the median of the frames' paired ratios, whether both gave the same
estimates on a last pass, and how busy the machine's processors were (from
``/proc/stat``, this process included) over the run. Threads share work only under noise
(``compiled.CompiledEngine.threads``), so ideal mode measures the same code twice.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def busy() -> tuple[int, int]:
    """(busy, total) jiffies of all processors since boot; (0, 0) without /proc/stat."""
    try:
        fields = Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:8]
    except OSError:
        return 0, 0
    ticks = [int(f) for f in fields]
    return sum(ticks) - ticks[3] - ticks[4], sum(ticks)


def side_by_side(representation: str, noise: str, threads: int, rounds: int) -> str:
    """One line of figures: the localisers of one thread and of ``threads``."""
    import bench_onsensor as bench
    from bench_side_by_side import alternate, compared
    from ppaloc.sim.engines.compiled import THREADS_ENV

    locs = {}
    for k in (1, threads):
        os.environ[THREADS_ENV] = str(k)
        locs[k] = bench.localiser(representation, noise)
    b0, t0 = busy()
    times = alternate(locs, rounds)
    b1, t1 = busy()
    load = f"{100 * (b1 - b0) / (t1 - t0):.0f}%" if t1 > t0 else "?"
    labels = ("1 thread", f"{threads} threads")
    line = compared(representation, noise, locs, times, 1, threads, labels)
    return f"{line}  processors busy {load}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--reps", default="lowres,lbp")
    parser.add_argument("--noise", default="typical")
    parser.add_argument("--rounds", type=int, default=8, help="passes over the 12 frames")
    args = parser.parse_args()
    os.environ["PPALOC_FUSE_AFTER"] = "never"
    for rep in args.reps.split(","):
        for noise in args.noise.split(","):
            print(side_by_side(rep, noise, args.threads, args.rounds), flush=True)


if __name__ == "__main__":
    main()
