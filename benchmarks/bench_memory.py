"""Peak resident memory of ``ppaloc evaluate`` (and ``ppaloc map``) against route length.

Each size runs in a fresh subprocess, the command a user types::

    ppaloc evaluate -d 'synthetic:?places=N&seed=1' -m weighted-node-lbp --out DIR -q

and its peak resident set size is the child's ``ru_maxrss`` (``os.wait4``: the same figure
as ``/usr/bin/time -v``'s "Maximum resident set size"). Frames stream, so the peak should
hardly move with N: the map (4 bytes a node for LBP) and the per-query arrays (a few hundred
bytes a query) are all that grow.

``python benchmarks/bench_memory.py`` prints the peak at N = 2,000 and N = 30,000 (several
minutes: 60,000 rendered frames) and their ratio; ``--sizes`` and ``--command map`` change
what is measured. Target: the peak grows by less than 30% from 2,000 to 30,000 places
(ratio < 1.3). ``make bench`` runs a shorter pytest form (300 and 3,000 places), which
asserts the same ratio.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_RATIO = 1.3
PPALOC = Path(sys.executable).with_name("ppaloc")


def command(kind: str, places: int, out: Path) -> list[str]:
    """The measured command line for a route of ``places`` places."""
    spec = f"synthetic:?places={places}&seed=1"
    if kind == "map":
        return [str(PPALOC), "map", spec, "-m", "weighted-node-lbp", "-q", "--out", str(out)]
    return [str(PPALOC), "evaluate", "-d", spec, "-m", "weighted-node-lbp", "-q", "--out", str(out)]


def peak_rss_mb(kind: str, places: int) -> tuple[float, float]:
    """Peak resident memory (MB) and wall time (s) of one run in a fresh process."""
    with tempfile.TemporaryDirectory(prefix="ppaloc-mem-") as tmp:
        out = Path(tmp) / ("map.npz" if kind == "map" else "run")
        t0 = time.perf_counter()
        proc = subprocess.Popen(command(kind, places, out), stdout=subprocess.DEVNULL)
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"{kind} with places={places} exited {proc.returncode}")
    return usage.ru_maxrss / 1024, wall  # Linux: kilobytes


def measure(kind: str, sizes: list[int]) -> list[tuple[int, float, float]]:
    return [(n, *peak_rss_mb(kind, n)) for n in sizes]


def test_peak_memory_flat_with_route_length(benchmark):
    """Short form for ``make bench``: 300 and 3,000 places."""
    rows = benchmark.pedantic(measure, args=("evaluate", [300, 3000]), rounds=1, iterations=1)
    (_, small, _), (_, large, _) = rows
    benchmark.extra_info.update({"peak_mb_300": small, "peak_mb_3000": large})
    assert large / small < TARGET_RATIO, f"peak {small:.0f} MB -> {large:.0f} MB"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="2000,30000", help="places, comma-separated")
    parser.add_argument("--command", choices=("evaluate", "map"), default="evaluate")
    args = parser.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = measure(args.command, sizes)
    for n, mb, wall in rows:
        print(f"{args.command} places={n:>6}: peak RSS {mb:7.1f} MB  ({wall:.0f} s)")
    ratio = rows[-1][1] / rows[0][1]
    verdict = "met" if ratio < TARGET_RATIO else "missed"
    print(f"ratio {sizes[-1]}/{sizes[0]} places: {ratio:.3f} (target < {TARGET_RATIO}: {verdict})")


if __name__ == "__main__":
    main()
